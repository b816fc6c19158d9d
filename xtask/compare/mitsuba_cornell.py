#!/usr/bin/env python3
"""Render scenes/reference/cornell_box.json with spectrace and with Mitsuba 3 (variant
scalar_spectral) at equal spp, and report time and error for both.

An optional comparison tool: the project does not need it. It needs `pip install mitsuba
colour-science OpenEXR` and a release build (`cargo build --release -p cli`).

The Mitsuba scene is built from the same manifest and the same data files: walls are
ColorChecker reflectances held to 360-830 nm as spectrace holds them, the light is CIE A
scaled to luminance 30 (spectrace's `emission_strength` convention), the glass is a smooth
dielectric of IOR 1.5. spectrace's emitters and diffuse surfaces are two-sided; Mitsuba's are
one-sided, so every diffuse surface is wrapped in `twosided` and the light is two
back-to-back rectangles 1e-5 apart. Both films store CIE 1931 XYZ with a box pixel filter.

Error: ΔE00 (CIELAB relative to the D65 white at Y = 1, as `cargo xtask validate`) and
relative MSE of each renderer's image against its own converged reference, so that the
noise each leaves at a given time is compared; the converged references are also compared
with each other (the systematic difference between the two renderers).

    python3 xtask/compare/mitsuba_cornell.py --out target/mitsuba-compare --threads 1 \
        --spp 4 16 64 --ref-spp 1024
"""

import argparse
import json
import os
import subprocess
import sys
import time
from pathlib import Path

import drjit as dr
import mitsuba as mi
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from mitsuba_common import GRID, ROOT, delta_e00, held, illuminant, read_csv, read_spectrace_exr, spectrum  # noqa: E402

SCENE = ROOT / "scenes/reference/cornell_box.json"

mi.set_variant("scalar_spectral")


def reflectance(name):
    header, table = read_csv("colorchecker_reflectance.csv")
    assert name.startswith("colorchecker:"), name
    column = int(name.split(":")[1])
    return held(table[:, 0], table[:, column], GRID)


def emission(name, strength):
    assert name == "A", name
    return illuminant("cie_a_1nm.csv", strength)


def rectangle(corner, eu, ev, bsdf, emitter=None, flip=False, lift=0.0):
    corner, eu, ev = (np.array(v, dtype=float) for v in (corner, eu, ev))
    if flip:
        eu, ev = ev, eu
    n = np.cross(eu, ev)
    n /= np.linalg.norm(n)
    centre = corner + 0.5 * eu + 0.5 * ev + lift * n
    m = np.eye(4)
    m[:3, 0], m[:3, 1], m[:3, 2], m[:3, 3] = 0.5 * eu, 0.5 * ev, n, centre
    shape = {"type": "rectangle", "to_world": mi.ScalarTransform4f(m.tolist()), "bsdf": bsdf}
    if emitter is not None:
        shape["emitter"] = emitter
    return shape


def mitsuba_scene(manifest, spp, width, height):
    mats = manifest["materials"]

    def bsdf(name):
        m = mats[name]
        if m.get("model") == "dielectric":
            return {"type": "dielectric", "int_ior": float(m["ior"]), "ext_ior": 1.0}
        base = m["base_color"]
        r = spectrum(reflectance(base)) if isinstance(base, str) else {"type": "spectrum", "value": float(base)}
        return {"type": "twosided", "bsdf": {"type": "diffuse", "reflectance": r}}

    cam = manifest["camera"]
    scene = {
        "type": "scene",
        "integrator": {"type": "path", "max_depth": manifest["settings"]["max_depth"] + 1},
        "sensor": {
            "type": "perspective",
            "fov": float(cam["vfov_deg"]),
            "fov_axis": "y",
            "to_world": mi.ScalarTransform4f().look_at(origin=cam["position"], target=cam["look_at"], up=[0, 1, 0]),
            "film": {
                "type": "hdrfilm",
                "width": width,
                "height": height,
                "pixel_format": "xyz",
                "rfilter": {"type": "box"},
            },
            "sampler": {"type": "independent", "sample_count": spp},
        },
    }
    for i, o in enumerate(manifest["objects"]):
        m = mats[o["material"]]
        if o["type"] == "sphere":
            scene[f"s{i}"] = {
                "type": "sphere",
                "center": o["center"],
                "radius": float(o["radius"]),
                "bsdf": bsdf(o["material"]),
            }
        elif "emission" in m:
            radiance = {"type": "area", "radiance": spectrum(emission(m["emission"], m["emission_strength"]))}
            for side, (flip, lift) in enumerate([(False, 0.0), (True, 1e-5)]):
                scene[f"q{i}_{side}"] = rectangle(
                    o["corner"], o["edge_u"], o["edge_v"], bsdf(o["material"]), radiance, flip, lift
                )
        else:
            scene[f"q{i}"] = rectangle(o["corner"], o["edge_u"], o["edge_v"], bsdf(o["material"]))
    return scene


def render_mitsuba(manifest, spp, width, height, seed):
    scene = mi.load_dict(mitsuba_scene(manifest, spp, width, height))
    start = time.perf_counter()
    image = mi.render(scene, spp=spp, seed=seed)
    seconds = time.perf_counter() - start
    return np.array(image)[:, :, :3].astype(np.float64), seconds


def render_spectrace(binary, spp, width, height, seed, threads, spectral, out):
    exr = out / f"spectrace_{spectral.replace(':', '')}_{spp}.exr"
    cmd = [str(binary), "render", str(SCENE), "--integrator", "path", "--spp", str(spp), "--seed", str(seed)]
    cmd += ["--spectral", spectral, "--width", str(width), "--height", str(height), "--threads", str(threads)]
    cmd += ["-q", "-o", str(exr)]
    if spectral.startswith("hero"):
        cmd += ["--wavelength-pdf", "visible"]
    start = time.perf_counter()
    subprocess.run(cmd, check=True)
    seconds = time.perf_counter() - start
    return read_spectrace_exr(exr), seconds


def errors(image, reference):
    de = delta_e00(image, reference)
    y, y_ref = image[:, :, 1], reference[:, :, 1]
    rel_mse = float(np.mean((y - y_ref) ** 2 / (y_ref**2 + 1e-2)))
    return float(de.mean()), float(np.percentile(de, 95)), rel_mse


def downsample(image, block):
    h, w, c = image.shape
    return image[: h - h % block, : w - w % block].reshape(h // block, block, w // block, block, c).mean(axis=(1, 3))


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--out", type=Path, default=ROOT / "target/mitsuba-compare")
    p.add_argument("--threads", type=int, default=1)
    p.add_argument("--spectrace", type=Path, default=ROOT / "target/release/spectrace")
    p.add_argument("--size", type=int, default=512)
    p.add_argument("--spp", type=int, nargs="+", default=[4, 16, 64])
    p.add_argument("--ref-spp", type=int, default=1024)
    p.add_argument("--spectral", nargs="+", default=["auto", "hero:4"])
    args = p.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    dr.set_thread_count(args.threads)
    manifest = json.loads(SCENE.read_text())
    n = args.size

    def cached(name, make):
        path = args.out / f"{name}.npy"
        if path.exists():
            return np.load(path)
        image, _ = make()
        np.save(path, image)
        return image

    dr.set_thread_count(os.cpu_count())
    ref_m = cached(f"ref_mitsuba_{n}_{args.ref_spp}", lambda: render_mitsuba(manifest, args.ref_spp, n, n, 7))
    ref_s = cached(
        f"ref_spectrace_{n}_{args.ref_spp}",
        lambda: render_spectrace(args.spectrace, args.ref_spp, n, n, 7, os.cpu_count(), "bins:95", args.out),
    )
    dr.set_thread_count(args.threads)
    ratio = ref_s[:, :, 1].mean() / ref_m[:, :, 1].mean()
    print(f"converged references ({args.ref_spp} spp), spectrace vs Mitsuba: mean Y ratio {ratio:.4f}")
    for block in (1, 4, 8):
        # Block averages take the references' own remaining noise out of the comparison.
        mean, p95, rmse = errors(downsample(ref_s, block), downsample(ref_m, block))
        print(f"  {block}x{block} blocks: ΔE00 mean {mean:.3f} p95 {p95:.3f}, relative MSE {rmse:.2e}")
    print("renderer           spp  seconds  Msamples/s  ΔE00 mean  ΔE00 p95  rel.MSE")
    rows = []
    for spp in args.spp:
        image, secs = render_mitsuba(manifest, spp, n, n, 1)
        rows.append(("mitsuba scalar_spectral", spp, secs, *errors(image, ref_m)))
        for spectral in args.spectral:
            image, secs = render_spectrace(args.spectrace, spp, n, n, 1, args.threads, spectral, args.out)
            rows.append((f"spectrace {spectral}", spp, secs, *errors(image, ref_s)))
    for name, spp, secs, mean, p95, rmse in rows:
        rate = n * n * spp / secs / 1e6
        print(f"{name:24} {spp:4} {secs:8.2f} {rate:11.3f} {mean:10.3f} {p95:9.3f} {rmse:8.2e}")


if __name__ == "__main__":
    main()
