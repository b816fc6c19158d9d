#!/usr/bin/env python3
"""Render spectrace's rough materials and Mitsuba 3's (variant scalar_spectral) on the same
scene and score the difference.

An optional comparison tool: the project does not need it. It needs `pip install mitsuba
colour-science OpenEXR` and a release build (`cargo build --release -p cli`).

The scene, both sides: a unit sphere at the origin seen from (0, 0, 10) (vfov 14°), lit by a
uniform D65 environment (`--env` nits) and one D65 point light at (-4, 5, 8) (`--point` cd);
both films CIE XYZ (spectrace's linear-sRGB EXR is converted back exactly), box filter.
spectrace normalises a named spectrum to relative luminance 1 and reads the intensity in nits
and cd; Mitsuba gets the same normalised D65 values as spectral radiance and intensity, and its
XYZ film divides by the integral of ȳ, so the two Y scales are the same (row 0, a Lambertian
sphere, checks it).

Rows (spectrace manifest material ↔ Mitsuba BSDF), GGX α = r² with r spectrace's roughness:
- diffuse 0.8 ↔ diffuse 0.8;
- conductor Au, Cu (the tables of data/metals/ given to Mitsuba as `irregular` η and k),
  α 0.1, 0.3, 0.6, "multiple_scattering": false ↔ roughconductor ggx (the same model), and
  spectrace's default (Kulla–Conty compensation on: not the same model);
- dielectric IOR 1.5, α 0.1, 0.15, 0.3, "transmittance": 1 (clear, as the default now is; binaries before
  the fix tinted it by the base colour, 0.5), the same way ↔ roughdielectric;
- conductor Au (α 0.1, 0.4) and Cu (α 0.25) given as a user would, `"eta"`/`"k"` columns of a CSV in nm
  written from the same tables ↔ roughconductor with those tables (the same model);
- plastic, grey 0.5 and red (ColorChecker 15, the same spectrum both sides), α 0 (↔ `plastic`), 0.2, 0.4
  (↔ `roughplastic` ggx), linear and `nonlinear`, `"multiple_scattering": false` (the same model up to the
  masking term, see crates/materials/src/bsdf/plastic.rs) and spectrace's default (compensated: not the
  same model);
- glossy plastic: spectrace's gltf_metal_rough (glTF Appendix B, metallic 0, base colour 0.5,
  ior 1.5; a UV-sphere mesh written as glTF, and the same mesh as PLY for Mitsuba) ↔ principled
  (metallic 0, specular 0.5, i.e. F0 0.04) and ↔ roughplastic (int_ior 1.5, diffuse 0.5). Not the
  same models.

spectrace renders with hero:4 and the visible wavelength density (Mitsuba's); max depth
`--max-depth` bounces (Mitsuba's `max_depth` is one more: it counts the camera segment).
Each side is rendered twice (seeds 1 and 2): "self" is the ΔE00 between its two renders
(the noise), "cross" the ΔE00 between the renderers' seed-1 images, "cross avg" between the
two renderers' averages of both seeds, "4×4" the same on 4×4-pixel block means (noise
divided by about 4; only blocks wholly on the sphere). Scores over the pixels whose footprint lies wholly
inside the sphere's silhouette (from the geometry) and over the whole image; luminance ratio =
mean Y spectrace / mean Y Mitsuba over the sphere (both seeds). Table to stdout and OUT/table.md; EXRs and
.npy images in OUT.

    /work/venv-mi/bin/python xtask/compare/mitsuba_materials.py --out target/mitsuba-materials \\
        --spectrace target/release/spectrace --size 128 --spp 512

`--lights env` or `--lights point` renders with one light only (to isolate a difference);
`--only NAME...` renders only the rows whose name contains one of the strings, `--alpha A...`
only those of these α.

The noise of the rough glass under the point light at equal spp (relMSE against a converged
reference, pixels beyond 10σ of it) is mitsuba_glass_noise.py's one command.
"""

import argparse
import base64
import json
import struct
import subprocess
import sys
import time
from pathlib import Path

import drjit as dr
import mitsuba as mi
import numpy as np
import OpenEXR

sys.path.insert(0, str(Path(__file__).resolve().parent))
from mitsuba_common import GRID, ROOT, delta_e00, held, illuminant, read_csv, read_spectrace_exr, spectrum  # noqa: E402

mi.set_variant("scalar_spectral")

CAMERA = {"position": [0.0, 0.0, 10.0], "look_at": [0.0, 0.0, 0.0], "up": [0.0, 1.0, 0.0], "vfov_deg": 14.0}
LIGHT_POS = [-4.0, 5.0, 8.0]
METAL_FILES = {"Au": "Au_johnson_christy_1972.csv", "Cu": "Cu_johnson_christy_1972.csv"}
PLASTIC_BASE = 0.5


def metal_ior(metal):
    """η and k of data/metals/, on the table's own wavelengths (nm), as Mitsuba `irregular` spectra."""
    table = np.loadtxt(ROOT / "data/metals" / METAL_FILES[metal], delimiter=",", skiprows=1)
    lam = table[:, 0] * 1000.0

    def irregular(values):
        return {
            "type": "irregular",
            "wavelengths": ", ".join(f"{v:.6g}" for v in lam),
            "values": ", ".join(f"{v:.6g}" for v in values),
        }

    return irregular(table[:, 1]), irregular(table[:, 2])


def write_index_csv(out, metal):
    """data/metals/'s table of `metal` as the CSV a user would write (nm, n, k), in OUT; its file name."""
    table = np.loadtxt(ROOT / "data/metals" / METAL_FILES[metal], delimiter=",", skiprows=1)
    name = f"{metal}_index.csv"
    lines = ["wavelength_nm,n,k"] + [f"{l * 1000.0:.6g},{n:.6g},{k:.6g}" for l, n, k in table]
    (out / name).write_text("\n".join(lines) + "\n")
    return name


def colorchecker(patch):
    """ColorChecker patch `patch` (1-based) of data/, held to 360–830 nm as spectrace holds it."""
    _, table = read_csv("colorchecker_reflectance.csv")
    return held(table[:, 0], table[:, patch], GRID)


def rows(plastic_alphas, out):
    """(name, α, same model?, spectrace material or "gltf", Mitsuba BSDF dict), row 0 first."""
    out_dir = out
    out = [("diffuse", None, "yes", {"model": "diffuse", "base_color": 0.8}, {"type": "diffuse", "reflectance": 0.8})]
    for compensated in (False, True):
        same = "no: compensation on" if compensated else "yes"
        suffix = " (compensated)" if compensated else ""
        for metal in METAL_FILES:
            eta, k = metal_ior(metal)
            for alpha in (0.1, 0.3, 0.6):
                mat = {"model": "conductor", "metal": metal, "roughness": float(np.sqrt(alpha))}
                if not compensated:
                    mat["multiple_scattering"] = False
                bsdf = {"type": "roughconductor", "distribution": "ggx", "alpha": alpha, "eta": eta, "k": k}
                out.append((f"conductor {metal}{suffix}", alpha, same, mat, bsdf))
        for alpha in (0.1, 0.15, 0.3):
            # `transmittance` 1, explicit: older binaries tinted a bare manifest dielectric by `base_color`.
            mat = {"model": "dielectric", "ior": 1.5, "transmittance": 1.0, "roughness": float(np.sqrt(alpha))}
            if not compensated:
                mat["multiple_scattering"] = False
            bsdf = {"type": "roughdielectric", "distribution": "ggx", "alpha": alpha, "int_ior": 1.5, "ext_ior": 1.0}
            out.append((f"dielectric 1.5{suffix}", alpha, same, mat, bsdf))
    for alpha in plastic_alphas:
        principled = {
            "type": "principled",
            "base_color": {"type": "rgb", "value": [PLASTIC_BASE] * 3},
            "metallic": 0.0,
            "specular": 0.5,
            "roughness": float(np.sqrt(alpha)),
            "spec_tint": 0.0,
            "sheen": 0.0,
            "clearcoat": 0.0,
            "spec_trans": 0.0,
            "anisotropic": 0.0,
        }
        plastic = {
            "type": "roughplastic",
            "distribution": "ggx",
            "alpha": alpha,
            "int_ior": 1.5,
            "ext_ior": 1.0,
            "diffuse_reflectance": {"type": "rgb", "value": [PLASTIC_BASE] * 3},
        }
        same = "no: glTF App. B vs "
        out.append(("gltf_metal_rough vs principled", alpha, same + "Disney", "gltf", principled))
        out.append(("gltf_metal_rough vs roughplastic", alpha, same + "roughplastic", "gltf", plastic))
    # Conductors from a user's η/k file (the same data as the named metals, written as CSV in nm).
    for metal, alphas in (("Au", (0.1, 0.4)), ("Cu", (0.25,))):
        csv = write_index_csv(out_dir, metal)
        eta, k = metal_ior(metal)
        for alpha in alphas:
            mat = {
                "model": "conductor",
                "eta": {"csv": csv, "column": "n"},
                "k": {"csv": csv, "column": "k"},
                "roughness": float(np.sqrt(alpha)),
                "multiple_scattering": False,
            }
            bsdf = {"type": "roughconductor", "distribution": "ggx", "alpha": alpha, "eta": eta, "k": k}
            out.append((f"conductor {metal} eta/k file", alpha, "yes", mat, bsdf))
    # spectrace's plastic against roughplastic (and plastic at α 0): grey and red (ColorChecker 15) bases.
    red = colorchecker(15)
    for base_name, spectrace_base, mitsuba_base in (
        ("grey 0.5", 0.5, 0.5),
        ("red", "colorchecker:15", spectrum(red)),
    ):
        for alpha in (0.0, 0.2, 0.4):
            for nonlinear in (False, True):
                for compensated in (False, True):
                    if compensated and (alpha == 0.0 or nonlinear):
                        continue
                    mat = {"model": "plastic", "base_color": spectrace_base, "ior": 1.5, "roughness": float(np.sqrt(alpha))}
                    if nonlinear:
                        mat["nonlinear"] = True
                    if not compensated:
                        mat["multiple_scattering"] = False
                    bsdf = {
                        "type": "plastic" if alpha == 0.0 else "roughplastic",
                        "int_ior": 1.5,
                        "ext_ior": 1.0,
                        "diffuse_reflectance": mitsuba_base,
                        "nonlinear": nonlinear,
                    }
                    if alpha > 0.0:
                        bsdf.update({"distribution": "ggx", "alpha": alpha})
                    name = f"plastic {base_name}{' nonlinear' if nonlinear else ''}{' (compensated)' if compensated else ''}"
                    out.append((name, alpha, "no: compensation on" if compensated else "yes", mat, bsdf))
    return out


def uv_sphere(segments):
    """A unit UV sphere: positions (= normals), triangle indices, counter-clockwise from outside."""
    rings = segments // 2
    theta = np.linspace(0.0, np.pi, rings + 1)
    phi = np.linspace(0.0, 2.0 * np.pi, segments + 1)
    t, p = np.meshgrid(theta, phi, indexing="ij")
    pos = np.stack([np.sin(t) * np.cos(p), np.cos(t), -np.sin(t) * np.sin(p)], axis=-1).reshape(-1, 3)
    tris = []
    for i in range(rings):
        for j in range(segments):
            a, b = i * (segments + 1) + j, (i + 1) * (segments + 1) + j
            if i > 0:
                tris.append((a, b, a + 1))
            if i < rings - 1:
                tris.append((a + 1, b, b + 1))
    return pos.astype(np.float32), np.array(tris, dtype=np.uint32)


def write_meshes(out, alpha, segments):
    """The plastic sphere as glTF (metallic 0, roughness √α, base colour) and the same mesh as PLY."""
    pos, tris = uv_sphere(segments)
    pos_bytes, idx_bytes = pos.tobytes(), tris.tobytes()
    data = pos_bytes + idx_bytes
    gltf = {
        "asset": {"version": "2.0"},
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0, "NORMAL": 0}, "indices": 1, "material": 0}]}],
        "materials": [
            {
                "pbrMetallicRoughness": {
                    "baseColorFactor": [PLASTIC_BASE] * 3 + [1.0],
                    "metallicFactor": 0.0,
                    "roughnessFactor": float(np.sqrt(alpha)),
                }
            }
        ],
        "buffers": [
            {"byteLength": len(data), "uri": "data:application/octet-stream;base64," + base64.b64encode(data).decode()}
        ],
        "bufferViews": [
            {"buffer": 0, "byteOffset": 0, "byteLength": len(pos_bytes), "target": 34962},
            {"buffer": 0, "byteOffset": len(pos_bytes), "byteLength": len(idx_bytes), "target": 34963},
        ],
        "accessors": [
            {
                "bufferView": 0,
                "componentType": 5126,
                "count": len(pos),
                "type": "VEC3",
                "min": pos.min(axis=0).tolist(),
                "max": pos.max(axis=0).tolist(),
            },
            {"bufferView": 1, "componentType": 5125, "count": tris.size, "type": "SCALAR"},
        ],
    }
    gltf_path = out / f"plastic_{alpha}.gltf"
    gltf_path.write_text(json.dumps(gltf))
    ply_path = out / "sphere_mesh.ply"
    header = (
        "ply\nformat binary_little_endian 1.0\n"
        f"element vertex {len(pos)}\nproperty float x\nproperty float y\nproperty float z\n"
        "property float nx\nproperty float ny\nproperty float nz\n"
        f"element face {len(tris)}\nproperty list uchar uint vertex_indices\nend_header\n"
    )
    with open(ply_path, "wb") as f:
        f.write(header.encode())
        f.write(np.concatenate([pos, pos], axis=1).astype("<f4").tobytes())
        for t in tris:
            f.write(struct.pack("<B3I", 3, *t))
    return gltf_path, ply_path


def spectrace_manifest(material, gltf_path, args):
    lights = []
    if args.lights in ("both", "point"):
        lights.append({"type": "point", "position": LIGHT_POS, "spectrum": "D65", "intensity": args.point})
    if args.lights in ("both", "env"):
        lights.append({"type": "environment", "spectrum": "D65", "intensity": args.env})
    manifest = {
        "camera": dict(CAMERA, width=args.size, height=args.size),
        "lights": lights,
        "settings": {"max_depth": args.max_depth, "integrator": "path"},
    }
    if material == "gltf":
        manifest["objects"] = [{"type": "mesh", "file": gltf_path.name}]
    else:
        manifest["materials"] = {"m": material}
        manifest["objects"] = [{"type": "sphere", "center": [0, 0, 0], "radius": 1, "material": "m"}]
    return manifest


def render_spectrace(manifest, name, seed, args):
    scene = args.out / f"{name}.json"
    scene.write_text(json.dumps(manifest, indent=1))
    exr = args.out / f"{name}_spectrace_s{seed}.exr"
    integrator = getattr(args, "integrator", "path")
    cmd = [str(args.spectrace), "render", str(scene), "--integrator", integrator, "--spp", str(args.spp)]
    cmd += ["--seed", str(seed), "--spectral", "hero:4", "--wavelength-pdf", "visible"]
    # (A render's samples do not depend on the thread count; mitsuba_glass_noise.py raises it.)
    cmd += ["--threads", str(getattr(args, "threads", 1))]
    cmd += ["--max-depth", str(args.max_depth), "-q", "-o", str(exr)]
    start = time.perf_counter()
    subprocess.run(cmd, check=True)
    return read_spectrace_exr(exr), time.perf_counter() - start


def mitsuba_scene(bsdf, ply_path, args):
    d65 = illuminant("cie_d65_5nm.csv", 1.0)
    scene = {
        "type": "scene",
        "integrator": {"type": "path", "max_depth": args.max_depth + 1},
        "sensor": {
            "type": "perspective",
            "fov": CAMERA["vfov_deg"],
            "fov_axis": "y",
            "to_world": mi.ScalarTransform4f().look_at(
                origin=CAMERA["position"], target=CAMERA["look_at"], up=CAMERA["up"]
            ),
            "film": {
                "type": "hdrfilm",
                "width": args.size,
                "height": args.size,
                "pixel_format": "xyz",
                "rfilter": {"type": "box"},
            },
            "sampler": {"type": "independent", "sample_count": args.spp},
        },
    }
    if args.lights in ("both", "point"):
        scene["point"] = {"type": "point", "position": LIGHT_POS, "intensity": spectrum(d65 * args.point)}
    if args.lights in ("both", "env"):
        scene["env"] = {"type": "constant", "radiance": spectrum(d65 * args.env)}
    if ply_path is not None:
        scene["sphere"] = {"type": "ply", "filename": str(ply_path), "bsdf": bsdf, "face_normals": False}
    else:
        scene["sphere"] = {"type": "sphere", "center": [0, 0, 0], "radius": 1.0, "bsdf": bsdf}
    return scene


def render_mitsuba(bsdf, ply_path, name, seed, args):
    scene = mi.load_dict(mitsuba_scene(bsdf, ply_path, args))
    start = time.perf_counter()
    image = mi.render(scene, spp=args.spp, seed=seed)
    seconds = time.perf_counter() - start
    xyz = np.array(image)[:, :, :3].astype(np.float64)
    # Written with OpenEXR: mi.Bitmap.write hangs after dr.set_thread_count(1) (Mitsuba 3.9.1).
    channels = {"XYZ": OpenEXR.Channel(xyz.astype(np.float32))}
    OpenEXR.File({"compression": OpenEXR.ZIP_COMPRESSION}, channels).write(str(args.out / f"{name}_mitsuba_s{seed}.exr"))
    return xyz, seconds


def sphere_mask(size):
    """Pixels whose four corners' camera rays all hit the unit sphere (no silhouette pixels)."""
    t = np.tan(np.radians(CAMERA["vfov_deg"]) / 2.0)
    edges = (np.arange(size + 1) / size * 2.0 - 1.0) * t
    x, y = np.meshgrid(edges, edges)
    # A ray from distance 10 at angle φ off the axis hits the unit sphere iff sin φ < 1/10.
    hit = (x**2 + y**2) / (x**2 + y**2 + 1.0) < 0.01
    return hit[:-1, :-1] & hit[1:, :-1] & hit[:-1, 1:] & hit[1:, 1:]


def blocks(image, mask, block):
    """Block means of an image, and the blocks that lie wholly inside the mask."""
    h, w = mask.shape
    shape = (h // block, block, w // block, block)
    means = image[: shape[0] * block, : shape[2] * block].reshape(*shape, -1).mean(axis=(1, 3))
    inside = mask[: shape[0] * block, : shape[2] * block].reshape(shape).all(axis=(1, 3))
    return means, inside


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--out", type=Path, default=ROOT / "target/mitsuba-materials")
    p.add_argument("--spectrace", type=Path, default=ROOT / "target/release/spectrace")
    p.add_argument("--size", type=int, default=128)
    p.add_argument("--spp", type=int, default=512)
    p.add_argument("--max-depth", type=int, default=32)
    p.add_argument("--env", type=float, default=0.5, help="environment luminance, nits")
    p.add_argument("--point", type=float, default=105.0 * np.pi, help="point light intensity, cd")
    p.add_argument("--lights", choices=["both", "env", "point"], default="both")
    p.add_argument("--plastic-alpha", type=float, nargs="*", default=[0.1, 0.3])
    p.add_argument("--mesh-segments", type=int, default=256)
    p.add_argument("--only", nargs="*", default=None, help="rows whose name contains one of these")
    p.add_argument("--alpha", type=float, nargs="*", default=None, help="rows of these α only")
    args = p.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    args.spectrace = args.spectrace.resolve()
    dr.set_thread_count(1)
    mask = sphere_mask(args.size)
    table = [
        f"Sphere {args.size}×{args.size}, {args.spp} spp each side, lights: {args.lights} "
        f"(D65 environment {args.env:g} nits, D65 point light {args.point:g} cd at {LIGHT_POS}), "
        f"max depth {args.max_depth}; spectrace hero:4 (visible pdf), Mitsuba 3.9.1 scalar_spectral. "
        f"Sphere = {int(mask.sum())} pixels.",
        "",
        "| # | material | α | same model? | ΔE00 sphere (cross) | self Mitsuba | self spectrace "
        "| cross avg | cross avg 4×4 | self 4×4 M / s | ΔE00 image (cross) | Y ratio sphere | ΔE00 sphere mean "
        "| s Mitsuba | s spectrace |",
        "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |",
    ]
    print("\n".join(table), flush=True)
    mitsuba_cache = {}
    for i, (name, alpha, same, material, bsdf) in enumerate(rows(args.plastic_alpha, args.out)):
        if args.only is not None and not any(o in name for o in args.only):
            continue
        if args.alpha is not None and alpha not in args.alpha:
            continue
        tag = f"{i:02}_{name.split(' (')[0].replace(' ', '_').replace('/', '-')}_{alpha}_{args.lights}"
        gltf_path = ply_path = None
        if material == "gltf":
            gltf_path, ply_path = write_meshes(args.out, alpha, args.mesh_segments)
        key = (json.dumps(bsdf, sort_keys=True), ply_path is not None)
        if key not in mitsuba_cache:
            mitsuba_cache[key] = [render_mitsuba(bsdf, ply_path, tag, seed, args) for seed in (1, 2)]
        (m1, tm), (m2, _) = mitsuba_cache[key]
        manifest = spectrace_manifest(material, gltf_path, args)
        (s1, ts), (s2, _) = (render_spectrace(manifest, tag, seed, args) for seed in (1, 2))
        for side, image in (("mitsuba", m1), ("spectrace", s1)):
            np.save(args.out / f"{tag}_{side}.npy", image)
        cross = delta_e00(s1, m1)
        cross_avg = delta_e00((s1 + s2) / 2, (m1 + m2) / 2)
        b = {k: blocks(v, mask, 4) for k, v in (("m1", m1), ("m2", m2), ("s1", s1), ("s2", s2))}
        inside = b["m1"][1]
        cross_b = delta_e00((b["s1"][0] + b["s2"][0]) / 2, (b["m1"][0] + b["m2"][0]) / 2)[inside].mean()
        self_bm = delta_e00(b["m2"][0], b["m1"][0])[inside].mean()
        self_bs = delta_e00(b["s2"][0], b["s1"][0])[inside].mean()
        ratio = (s1 + s2)[mask][:, 1].mean() / (m1 + m2)[mask][:, 1].mean()
        # The sphere's mean colour, both seeds each side: what "within ΔE00 x per sphere" compares.
        mean_s, mean_m = (s1 + s2)[mask].mean(axis=0) / 2, (m1 + m2)[mask].mean(axis=0) / 2
        sphere_de = float(delta_e00(mean_s[None, None, :], mean_m[None, None, :])[0, 0])
        line = (
            f"| {i} | {name} | {alpha if alpha is not None else '–'} | {same} | {cross[mask].mean():.3f} "
            f"| {delta_e00(m2, m1)[mask].mean():.3f} | {delta_e00(s2, s1)[mask].mean():.3f} "
            f"| {cross_avg[mask].mean():.3f} | {cross_b:.3f} | {self_bm:.3f} / {self_bs:.3f} "
            f"| {cross.mean():.3f} | {ratio:.4f} | {sphere_de:.3f} | {tm:.1f} | {ts:.1f} |"
        )
        print(line, flush=True)
        table.append(line)
    (args.out / f"table_{args.lights}.md" if args.lights != "both" else args.out / "table.md").write_text(
        "\n".join(table) + "\n"
    )


if __name__ == "__main__":
    main()
