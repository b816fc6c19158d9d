#!/usr/bin/env python3
"""Writes textured_cube.gltf: a unit cube whose faces carry a 16 x 16 sRGB checker texture
(orange and a light blue-grey, 4 x 4 texel squares, nearest filtering) on a grey floor, with a
camera and one point light (5 cd). A textured glTF for the error-estimate check of `cargo xtask
validate --only estimate`: texture edges and colour, a shadow, direct and indirect light.
The PNG and the geometry are embedded as data URIs. Run from anywhere:
`python3 scenes/gltf/textured_cube.py`.
"""
import base64
import json
import os
import struct
import zlib


def png_rgb(width, height, pixel):
    raw = b"".join(b"\x00" + b"".join(bytes(pixel(x, y)) for x in range(width)) for y in range(height))

    def chunk(kind, data):
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF)

    header = struct.pack(">IIBBBBB", width, height, 8, 2, 0, 0, 0)
    return b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", header) + chunk(b"IDAT", zlib.compress(raw, 9)) + chunk(b"IEND", b"")


ORANGE, GREY_BLUE = (230, 120, 30), (170, 185, 205)
texture = png_rgb(16, 16, lambda x, y: ORANGE if (x // 4 + y // 4) % 2 == 0 else GREY_BLUE)

# Cube faces: (normal, u axis, v axis); 4 vertices each, UVs over the whole texture.
faces = [
    ((1, 0, 0), (0, 0, -1), (0, 1, 0)),
    ((-1, 0, 0), (0, 0, 1), (0, 1, 0)),
    ((0, 1, 0), (1, 0, 0), (0, 0, -1)),
    ((0, -1, 0), (1, 0, 0), (0, 0, 1)),
    ((0, 0, 1), (1, 0, 0), (0, 1, 0)),
    ((0, 0, -1), (-1, 0, 0), (0, 1, 0)),
]
positions, normals, uvs, indices = [], [], [], []
for n, u, v in faces:
    base = len(positions)
    for su, sv in [(-1, -1), (1, -1), (1, 1), (-1, 1)]:
        positions.append(tuple(0.5 * n[k] + 0.5 * su * u[k] + 0.5 * sv * v[k] + (0.5 if k == 1 else 0.0) for k in range(3)))
        normals.append(n)
        uvs.append(((su + 1) / 2, (1 - sv) / 2))
    indices += [base, base + 1, base + 2, base, base + 2, base + 3]
# The floor: a 4 x 4 quad at y = 0 facing up.
floor_base = len(positions)
for x, z in [(-2, 2), (2, 2), (2, -2), (-2, -2)]:
    positions.append((x, 0.0, z))
    normals.append((0, 1, 0))
    uvs.append((0.0, 0.0))
floor_indices = [floor_base, floor_base + 1, floor_base + 2, floor_base, floor_base + 2, floor_base + 3]

def pack(fmt, rows):
    return b"".join(struct.pack(fmt, *r) for r in rows)

blobs = [
    pack("<3f", positions),
    pack("<3f", normals),
    pack("<2f", uvs),
    struct.pack("<%dH" % len(indices), *indices),
    struct.pack("<%dH" % len(floor_indices), *floor_indices),
]
buffer, views = b"", []
for blob in blobs:
    while len(buffer) % 4:
        buffer += b"\x00"
    views.append({"buffer": 0, "byteOffset": len(buffer), "byteLength": len(blob)})
    buffer += blob
count = len(positions)
lo = [min(p[k] for p in positions) for k in range(3)]
hi = [max(p[k] for p in positions) for k in range(3)]
gltf = {
    "asset": {"version": "2.0", "generator": "spectrace scenes/gltf/textured_cube.py"},
    "scene": 0,
    "scenes": [{"nodes": [0, 1, 2, 3]}],
    "nodes": [
        {"mesh": 0},
        {"mesh": 1},
        {"camera": 0, "translation": [2.2, 1.9, 2.6], "rotation": [-0.1819, 0.3374, 0.0666, 0.9212]},
        {"extensions": {"KHR_lights_punctual": {"light": 0}}, "translation": [1.5, 3.0, 1.0]},
    ],
    "cameras": [{"type": "perspective", "perspective": {"yfov": 0.7, "znear": 0.05, "aspectRatio": 1.0}}],
    "extensionsUsed": ["KHR_lights_punctual"],
    "extensions": {"KHR_lights_punctual": {"lights": [{"type": "point", "intensity": 5.0, "color": [1, 1, 1]}]}},
    "meshes": [
        {"primitives": [{"attributes": {"POSITION": 0, "NORMAL": 1, "TEXCOORD_0": 2}, "indices": 3, "material": 0}]},
        {"primitives": [{"attributes": {"POSITION": 0, "NORMAL": 1, "TEXCOORD_0": 2}, "indices": 4, "material": 1}]},
    ],
    "materials": [
        {"name": "checker", "pbrMetallicRoughness": {"baseColorTexture": {"index": 0}, "metallicFactor": 0.0, "roughnessFactor": 0.6}},
        {"name": "floor", "pbrMetallicRoughness": {"baseColorFactor": [0.5, 0.5, 0.5, 1.0], "metallicFactor": 0.0, "roughnessFactor": 1.0}},
    ],
    "textures": [{"source": 0, "sampler": 0}],
    "samplers": [{"magFilter": 9728, "minFilter": 9728}],
    "images": [{"uri": "data:image/png;base64," + base64.b64encode(texture).decode()}],
    "buffers": [{"byteLength": len(buffer), "uri": "data:application/octet-stream;base64," + base64.b64encode(buffer).decode()}],
    "bufferViews": views,
    "accessors": [
        {"bufferView": 0, "componentType": 5126, "count": count, "type": "VEC3", "min": lo, "max": hi},
        {"bufferView": 1, "componentType": 5126, "count": count, "type": "VEC3"},
        {"bufferView": 2, "componentType": 5126, "count": count, "type": "VEC2"},
        {"bufferView": 3, "componentType": 5123, "count": len(indices), "type": "SCALAR"},
        {"bufferView": 4, "componentType": 5123, "count": len(floor_indices), "type": "SCALAR"},
    ],
}
out = os.path.join(os.path.dirname(os.path.abspath(__file__)), "textured_cube.gltf")
with open(out, "w") as f:
    json.dump(gltf, f, indent=1)
    f.write("\n")
