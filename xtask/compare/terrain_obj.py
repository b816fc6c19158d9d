#!/usr/bin/env python3
"""Write the geometry benchmarks' terrain (`crates/geometry/benches/common/mod.rs`, `terrain(n)`:
a bumpy heightfield of n×n quads, 2n² triangles) as a plain OBJ of `v` and `f` lines, for
timing the loader and the BVH build on a large mesh (`docs/perf.md`, "Loading and building").

    python3 xtask/compare/terrain_obj.py 894 /tmp/terrain_1m6.obj   # 1,598,472 triangles, 60 MB
    python3 xtask/compare/terrain_obj.py 894 /tmp/terrain_1m6.glb   # the same as a binary glTF, 29 MB

A name ending in `.glb` gets a binary glTF of one primitive: f32 positions and u32 indices in one
buffer, for timing the glTF loader on the same triangles.

`--attributes` adds a texture coordinate (`vt`) and a normal (`vn`) per vertex and writes the
faces' corners as `v/vt/vn`, as exporters with normals and UVs do (150 MB at n = 894):

    python3 xtask/compare/terrain_obj.py --attributes 894 /tmp/terrain_1m6_nt.obj

`--objects K` writes the terrain as Blender's OBJ exporter writes a scene of K objects: an
`mtllib` line (the MTL file is written beside the OBJ, two materials), then per object (a strip
of rows of quads) an `o` line, its own `v` (and with `--attributes`, `vt` and `vn`) lines, `s 0`,
a `usemtl` line alternating between the two materials, and its faces:

    python3 xtask/compare/terrain_obj.py --objects 64 --attributes 894 /tmp/terrain_objects.obj

`--colors` gives every `v` line a colour (`v x y z r g b`, as scan and photogrammetry exports
write vertex colours):

    python3 xtask/compare/terrain_obj.py --colors 894 /tmp/terrain_colors.obj

Needs numpy. Outside the project's runtime, like the other scripts here.
"""

import argparse
import json
import struct
from pathlib import Path

import numpy as np


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("n", type=int, help="quads per side (2n² triangles)")
    ap.add_argument("out")
    ap.add_argument("--attributes", action="store_true", help="vt and vn lines, v/vt/vn corners (OBJ only)")
    ap.add_argument("--objects", type=int, default=0, help="K objects of their own vertices, as Blender writes")
    ap.add_argument("--colors", action="store_true", help="a colour on every v line (OBJ only)")
    args = ap.parse_args()
    n = args.n
    i, j = np.meshgrid(np.arange(n + 1), np.arange(n + 1))
    x = (i / n * 2.0 - 1.0).astype(np.float32).ravel()
    z = (j / n * 2.0 - 1.0).astype(np.float32).ravel()
    y = (0.1 * np.sin(7.0 * x) * np.cos(5.0 * z) + 0.03 * np.sin(31.0 * x + 17.0 * z)).astype(np.float32)
    qi, qj = np.meshgrid(np.arange(n), np.arange(n))
    a = (qj * (n + 1) + qi).ravel() + 1  # OBJ indices start at 1
    b, c, d = a + 1, a + n + 1, a + n + 2
    faces = np.empty((2 * n * n, 3), np.int64)
    faces[0::2] = np.stack([a, c, b], axis=1)
    faces[1::2] = np.stack([b, c, d], axis=1)
    if args.out.endswith(".glb"):
        write_glb(args.out, np.stack([x, y, z], axis=1).astype(np.float32), (faces - 1).astype(np.uint32))
        return
    # The heightfield's normal (−∂y/∂x, 1, −∂y/∂z), normalised; u, v from x, z.
    dx = 0.7 * np.cos(7.0 * x) * np.cos(5.0 * z) + 0.93 * np.cos(31.0 * x + 17.0 * z)
    dz = -0.5 * np.sin(7.0 * x) * np.sin(5.0 * z) + 0.51 * np.cos(31.0 * x + 17.0 * z)
    normals = np.stack([-dx, np.ones_like(dx), -dz], axis=1)
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    positions = np.stack([x, y, z], axis=1)
    v_format = "v %.7g %.7g %.7g"
    if args.colors:
        # Green to brown with height.
        t = ((y - y.min()) / (y.max() - y.min())).astype(np.float32)
        positions = np.concatenate([positions, np.stack([0.2 + 0.3 * t, 0.5 - 0.2 * t, 0.1 + 0.1 * t], axis=1)], axis=1)
        v_format += " %.4g %.4g %.4g"
    uvs = np.stack([(x + 1) / 2, (z + 1) / 2], axis=1)

    def write_vertices(f, vs):
        np.savetxt(f, positions[vs], fmt=v_format)
        if args.attributes:
            np.savetxt(f, uvs[vs], fmt="vt %.6g %.6g")
            np.savetxt(f, normals[vs], fmt="vn %.6g %.6g %.6g")

    with open(args.out, "w") as f:
        f.write(f"# terrain {n}x{n} quads, {2 * n * n} triangles\n")
        if args.objects:
            mtl = Path(args.out).with_suffix(".mtl")
            mtl.write_text("newmtl grass\nKd 0.2 0.5 0.1\n\nnewmtl rock\nKd 0.4 0.4 0.38\n")
            f.write(f"mtllib {mtl.name}\n")
            # Object k: quad rows rows[k]..rows[k + 1], with vertex rows rows[k]..rows[k + 1] inclusive.
            rows = np.linspace(0, n, args.objects + 1).round().astype(int)
            written = 0
            for k in range(args.objects):
                j0, j1 = rows[k], rows[k + 1]
                if j1 == j0:
                    continue
                vs = slice(j0 * (n + 1), (j1 + 1) * (n + 1))
                f.write(f"o strip_{k}\n")
                write_vertices(f, vs)
                f.write(f"s 0\nusemtl {('grass', 'rock')[k % 2]}\n")
                # The strip's faces: rows j0..j1 of quads, two triangles each, indices renumbered.
                own = faces[2 * j0 * n : 2 * j1 * n] - j0 * (n + 1) + written
                write_faces(f, own, args.attributes)
                written += (j1 - j0 + 1) * (n + 1)
            return
        write_vertices(f, slice(None))
        write_faces(f, faces, args.attributes)


def write_faces(f, faces, attributes):
    if attributes:
        np.savetxt(f, np.repeat(faces, 3, axis=1), fmt="f %d/%d/%d %d/%d/%d %d/%d/%d")
    else:
        np.savetxt(f, faces, fmt="f %d %d %d")


def write_glb(path, positions, faces):
    """A binary glTF 2.0 file of one mesh primitive (POSITION and indices), no material."""
    pb, ib = positions.tobytes(), faces.tobytes()
    gltf = {
        "asset": {"version": "2.0"},
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1}]}],
        "buffers": [{"byteLength": len(pb) + len(ib)}],
        "bufferViews": [
            {"buffer": 0, "byteOffset": 0, "byteLength": len(pb)},
            {"buffer": 0, "byteOffset": len(pb), "byteLength": len(ib)},
        ],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": len(positions), "type": "VEC3",
             "min": positions.min(0).tolist(), "max": positions.max(0).tolist()},
            {"bufferView": 1, "componentType": 5125, "count": faces.size, "type": "SCALAR"},
        ],
    }
    js = json.dumps(gltf).encode()
    js += b" " * (-len(js) % 4)
    binary = pb + ib + b"\0" * (-(len(pb) + len(ib)) % 4)
    with open(path, "wb") as f:
        f.write(struct.pack("<III", 0x46546C67, 2, 12 + 8 + len(js) + 8 + len(binary)))
        f.write(struct.pack("<II", len(js), 0x4E4F534A) + js)
        f.write(struct.pack("<II", len(binary), 0x004E4942) + binary)


if __name__ == "__main__":
    main()
