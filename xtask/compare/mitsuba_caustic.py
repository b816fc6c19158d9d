#!/usr/bin/env python3
"""A caustic against Mitsuba 3's particle tracer: `scenes/caustics/glass_sphere.json` (a smooth glass
sphere, IOR 1.5, over a white Lambertian floor under a D65 point light) rendered by spectrace's `bdpt`
and `path` and by Mitsuba's `ptracer`, compared on the floor seen around the sphere.

An optional comparison tool (issue 44), outside the project like the other mitsuba_*.py: needs numpy,
colour-science, OpenEXR, Mitsuba 3 from pip and a release build. Mitsuba's vectorised variant
(llvm_ad_spectral) when it loads, which wants
`DRJIT_LIBLLVM_PATH=/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1` here, else scalar_spectral.

    DRJIT_LIBLLVM_PATH=/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1 python3 \\
        xtask/compare/mitsuba_caustic.py --spectrace target/release/spectrace --out target/caustic

What it reports (stdout and OUT/table_caustic.md):
- agreement: the reference is Mitsuba's `ptracer` at `--ref-spp` (in parts of 1024 spp, seeds 100…);
  spectrace's `bdpt` at `--spp` × `--seeds`, averaged. On the floor pixels whose four corners' rays miss
  the sphere: the luminance ratio over all of them, over the caustic's core (the floor pixels whose
  reference Y is above `--core` × the floor's median: the focus under the sphere), and the mean ΔE00 of
  4×4 blocks lying wholly on that floor;
- time to equal error: relMSE (mean over the floor of (Y − Y_ref)² / (Y_ref² + (0.01 mean Y_ref)²))
  of single renders at increasing spp, each renderer with `--threads` threads, paired in one run,
  and the wall time each took; the table gives the time each needs to reach `--target` relMSE
  (interpolated log–log between the spp that straddle it), and what the path tracer reaches (it
  does not converge: it cannot find the caustic).
"""

import argparse
import json
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from mitsuba_common import ROOT, delta_e00, illuminant, read_spectrace_exr, spectrum  # noqa: E402

from mitsuba_glass_noise import set_fast_variant  # noqa: E402  (llvm_ad_spectral where it loads)

import mitsuba as mi  # noqa: E402

SCENE = ROOT / "scenes/caustics/glass_sphere.json"


def mitsuba_scene(desc, args):
    cam = desc["camera"]
    light = desc["lights"][0]
    floor, ball = desc["objects"]
    c0, eu, ev = (np.array(floor[k], dtype=float) for k in ("corner", "edge_u", "edge_v"))
    centre = c0 + 0.5 * (eu + ev)
    # Mitsuba's rectangle spans [-1, 1]² in its xy plane, normal +z: scaled, turned to face +y, moved.
    to_world = (
        mi.ScalarTransform4f().translate(centre.tolist())
        .rotate([1, 0, 0], -90)
        .scale([np.linalg.norm(eu) / 2, np.linalg.norm(ev) / 2, 1])
    )
    reflectance = float(desc["materials"]["floor"]["base_color"])
    return {
        "type": "scene",
        "integrator": {"type": "ptracer", "max_depth": desc["settings"]["max_depth"] + 1},
        "sensor": {
            "type": "perspective",
            "fov": cam["vfov_deg"],
            "fov_axis": "y",
            "to_world": mi.ScalarTransform4f().look_at(origin=cam["position"], target=cam["look_at"], up=cam["up"]),
            "film": {
                "type": "hdrfilm",
                "width": args.width,
                "height": args.height,
                "pixel_format": "xyz",
                "rfilter": {"type": "box"},
            },
            "sampler": {"type": "independent"},
        },
        "light": {
            "type": "point",
            "position": light["position"],
            "intensity": spectrum(illuminant("cie_d65_5nm.csv", light["intensity"])),
        },
        "floor": {
            "type": "rectangle",
            "to_world": to_world,
            "bsdf": {"type": "diffuse", "reflectance": {"type": "uniform", "value": reflectance}},
        },
        "ball": {
            "type": "sphere",
            "center": ball["center"],
            "radius": ball["radius"],
            "bsdf": {"type": "dielectric", "int_ior": 1.5, "ext_ior": 1.0},
        },
    }


def render_mitsuba(scene, spp, seed):
    start = time.perf_counter()
    image = np.array(mi.render(scene, spp=spp, seed=seed))[:, :, :3].astype(np.float64)
    return image, time.perf_counter() - start


def render_spectrace(args, integrator, spp, seed):
    exr = args.out / f"{integrator}_{spp}_s{seed}.exr"
    cmd = [str(args.spectrace), "render", str(SCENE), "--integrator", integrator, "--spp", str(spp)]
    cmd += ["--seed", str(seed), "--spectral", "hero:4", "--wavelength-pdf", "visible", "-q"]
    cmd += ["--width", str(args.width), "--height", str(args.height), "--threads", str(args.threads)]
    cmd += ["--sampler", "independent", "-o", str(exr)]
    start = time.perf_counter()
    subprocess.run(cmd, check=True)
    return read_spectrace_exr(exr), time.perf_counter() - start


def floor_mask(desc, width, height):
    """Pixels whose four corners' camera rays miss the sphere and hit the floor (y = 0, within the quad)."""
    cam = desc["camera"]
    eye, target, up = (np.array(cam[k], dtype=float) for k in ("position", "look_at", "up"))
    forward = (target - eye) / np.linalg.norm(target - eye)
    right = np.cross(forward, up)
    right /= np.linalg.norm(right)
    up = np.cross(right, forward)
    t = np.tan(np.radians(cam["vfov_deg"]) / 2)
    aspect = width / height
    xs = (np.arange(width + 1) / width * 2 - 1) * t * aspect
    ys = (1 - np.arange(height + 1) / height * 2) * t
    sx, sy = np.meshgrid(xs, ys)
    d = forward + sx[..., None] * right + sy[..., None] * up
    d /= np.linalg.norm(d, axis=-1, keepdims=True)
    ball = desc["objects"][1]
    c, r = np.array(ball["center"], dtype=float), ball["radius"]
    oc = eye - c
    b = (d * oc).sum(-1)
    disc = b**2 - ((oc**2).sum() - r**2)
    misses = disc < 0
    tf = -eye[1] / np.where(d[..., 1] < 0, d[..., 1], -1e-30)
    p = eye + tf[..., None] * d
    on = (d[..., 1] < 0) & (np.abs(p[..., 0]) < 5.9) & (np.abs(p[..., 2]) < 5.9)
    ok = misses & on
    return ok[:-1, :-1] & ok[1:, :-1] & ok[:-1, 1:] & ok[1:, 1:]


def rel_mse(y, ref, mask):
    floor = (0.01 * ref[mask].mean()) ** 2
    return float(np.mean(((y - ref) ** 2 / (ref**2 + floor))[mask]))


def time_to(target, runs):
    """Seconds to reach relMSE `target`, log–log between the two runs that straddle it (None if never)."""
    for (s0, e0), (s1, e1) in zip(runs, runs[1:]):
        if e0 > target >= e1:
            f = (np.log(target) - np.log(e0)) / (np.log(e1) - np.log(e0))
            return float(np.exp(np.log(s0) + f * (np.log(s1) - np.log(s0))))
    return runs[0][0] if runs and runs[0][1] <= target else None


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--out", type=Path, default=ROOT / "target/caustic")
    p.add_argument("--spectrace", type=Path, default=ROOT / "target/release/spectrace")
    p.add_argument("--width", type=int, default=160)
    p.add_argument("--height", type=int, default=120)
    p.add_argument("--ref-spp", type=int, default=16384)
    p.add_argument("--spp", type=int, default=1024)
    p.add_argument("--seeds", type=int, default=2)
    p.add_argument("--core", type=float, default=4.0, help="caustic core: reference Y above this × the floor's median")
    p.add_argument("--threads", type=int, default=2)
    p.add_argument("--target", type=float, default=0.01, help="relMSE for the time to equal error")
    p.add_argument("--ladder", type=int, nargs="+", default=[16, 32, 64, 128, 256, 512])
    p.add_argument(
        "--integrators",
        nargs="+",
        default=["bdpt", "sppm", "path"],
        choices=["bdpt", "sppm", "path"],
        help="spectrace's integrators to compare (sppm: spp = iterations, one photon per pixel each)",
    )
    args = p.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    args.spectrace = args.spectrace.resolve()
    variant = set_fast_variant()
    mi.set_log_level(mi.LogLevel.Warn)
    if variant.startswith("llvm"):
        import drjit as dr

        dr.set_thread_count(args.threads)
    desc = json.loads(SCENE.read_text())
    scene = mi.load_dict(mitsuba_scene(desc, args))
    mask = floor_mask(desc, args.width, args.height)

    ref_file = args.out / f"ref_{args.width}x{args.height}_{args.ref_spp}.npy"
    if ref_file.exists():
        ref_xyz = np.load(ref_file)
    else:
        parts = max(1, args.ref_spp // 1024)
        ref_xyz = np.mean([render_mitsuba(scene, 1024, 100 + i)[0] for i in range(parts)], axis=0)
        np.save(ref_file, ref_xyz)
    ref = ref_xyz[..., 1]
    core = mask & (ref > args.core * np.median(ref[mask]))

    ours = {
        f"spectrace {i}": np.mean([render_spectrace(args, i, args.spp, s)[0] for s in range(1, 1 + args.seeds)], axis=0)
        for i in args.integrators
    }
    mits = np.mean([render_mitsuba(scene, args.spp, s)[0] for s in range(1, 1 + args.seeds)], axis=0)

    def block_de(img):
        b = 4
        h, w = mask.shape
        shape = (h // b, b, w // b, b)
        inside = mask[: shape[0] * b, : shape[2] * b].reshape(shape).all(axis=(1, 3))
        mean = lambda x: x[: shape[0] * b, : shape[2] * b].reshape(*shape, 3).mean(axis=(1, 3))  # noqa: E731
        return float(delta_e00(mean(img), mean(ref_xyz))[inside].mean())

    lines = [
        f"Glass sphere caustic, {args.width}×{args.height}; reference Mitsuba 3 ptracer ({variant}) "
        f"{args.ref_spp} spp; floor = {int(mask.sum())} pixels, core = {int(core.sum())} pixels "
        f"(Y_ref > {args.core} × median); renders {args.spp} spp × {args.seeds} seeds.",
        "",
        "| renderer | Y / Y_ref floor | Y / Y_ref core | block ΔE00 (4×4, floor) |",
        "| --- | --- | --- | --- |",
    ]
    for name, img in [("Mitsuba ptracer", mits), *ours.items()]:
        y = img[..., 1]
        lines.append(
            f"| {name} | {y[mask].mean() / ref[mask].mean():.4f} | {y[core].mean() / ref[core].mean():.4f} "
            f"| {block_de(img):.3f} |"
        )

    runs = {"Mitsuba ptracer": [], **{f"spectrace {i}": [] for i in args.integrators}}
    for spp in args.ladder:
        # Interleaved, so the three share the machine's state at each rung.
        img, sec = render_mitsuba(scene, spp, 7)
        runs["Mitsuba ptracer"].append((sec, rel_mse(img[..., 1], ref, mask)))
        for integrator in args.integrators:
            img, sec = render_spectrace(args, integrator, spp, 7)
            runs[f"spectrace {integrator}"].append((sec, rel_mse(img[..., 1], ref, mask)))
    lines += [
        "",
        f"Time to relMSE {args.target} on the floor (single renders, seed 7, {args.threads} threads, spp "
        f"{args.ladder}; wall seconds, spectrace's including its start-up):",
        "",
        "| renderer | relMSE at each spp | seconds at each spp | time to target |",
        "| --- | --- | --- | --- |",
    ]
    for name, r in runs.items():
        t = time_to(args.target, r)
        lines.append(
            f"| {name} | {', '.join(f'{e:.3g}' for _, e in r)} | {', '.join(f'{s:.2f}' for s, _ in r)} "
            f"| {'not reached' if t is None else f'{t:.2f} s'} |"
        )
    print("\n".join(lines))
    (args.out / "table_caustic.md").write_text("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
