#!/usr/bin/env python3
"""Noise of a rough glass sphere under a point light, spectrace against Mitsuba 3 at equal spp: the
relative MSE of each renderer against a converged reference, and the pixels beyond 10σ of it.

An optional comparison tool (issue 42): the scene is mitsuba_materials.py's (a unit sphere seen
from (0, 0, 10), D65 point light at (-4, 5, 8), optionally the D65 environment), its sphere the
rough dielectric of IOR 1.5 without energy compensation (Mitsuba's roughdielectric, GGX α; spectrace
roughness √α), `--lights point` by default. It needs what mitsuba_materials.py needs and a release
build; Mitsuba's vectorised variant (llvm_ad_spectral) when it loads, which wants
`DRJIT_LIBLLVM_PATH=/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1` here, else scalar_spectral.

    DRJIT_LIBLLVM_PATH=/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1 python3 \\
        xtask/compare/mitsuba_glass_noise.py --spectrace target/release/spectrace --out target/glass-noise

Measured on the Y channel over the pixels wholly on the sphere:
- the reference is the mean of `--ref-parts` Mitsuba renders of `--ref-spp` each (seeds 100…);
  σ(p), a pixel's standard deviation of an `--spp` estimate, is those parts' spread scaled by
  √(ref-spp / spp) (so it carries the parts' own sampling noise: with 32 parts a pixel whose parts
  caught no rare path has its σ underestimated, which is why Mitsuba's own renders count a few);
- each renderer renders `--seeds` images of `--spp` (seeds 1, 2, …): relMSE = mean over the sphere of
  (Y − Y_ref)² / (Y_ref² + (0.01 · mean Y_ref)²), averaged over the seeds (the floor keeps the
  sphere's black pixels from dividing by 0); outliers = pixels with Y − Y_ref > 10 σ, per seed;
  the largest (Y − Y_ref) / σ over the seeds; luminance ratio = the seeds' mean Y over the sphere /
  the reference's.
The table (stdout and OUT/table_glass_noise.md) gives each renderer's relMSE, spectrace's over
Mitsuba's, the outlier counts and the luminance ratios.
"""

import argparse
import sys
from pathlib import Path
from types import SimpleNamespace

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import mitsuba_materials as mm  # noqa: E402  (sets the scalar_spectral variant, changed below)
from mitsuba_common import ROOT  # noqa: E402

import mitsuba as mi  # noqa: E402


def set_fast_variant():
    """llvm_ad_spectral where it loads (the same path tracer, vectorised), else scalar_spectral."""
    try:
        mi.set_variant("llvm_ad_spectral")
        mi.load_dict({"type": "scene"})
    except Exception:  # noqa: BLE001 (no LLVM library: Dr.Jit raises several kinds)
        mi.set_variant("scalar_spectral")
    return mi.variant()


def mitsuba_renders(args, spp, seeds):
    """Mitsuba's Y images, one per seed, at `spp`."""
    bsdf = {"type": "roughdielectric", "distribution": "ggx", "alpha": args.alpha, "int_ior": 1.5, "ext_ior": 1.0}
    scene = mi.load_dict(mm.mitsuba_scene(bsdf, None, args))
    return np.array([np.array(mi.render(scene, spp=spp, seed=seed))[:, :, 1].astype(np.float64) for seed in seeds])


def spectrace_renders(args, seeds):
    """spectrace's Y images, one per seed, at `--spp` (hero:4, visible wavelength density, as Mitsuba)."""
    material = {
        "model": "dielectric",
        "ior": 1.5,
        "transmittance": 1.0,
        "roughness": float(np.sqrt(args.alpha)),
        "multiple_scattering": False,
    }
    manifest = mm.spectrace_manifest(material, None, args)
    name = f"glass_{args.alpha}_{args.lights}_{getattr(args, 'integrator', 'path')}"
    return np.array([mm.render_spectrace(manifest, name, seed, args)[0][:, :, 1] for seed in seeds])


def score(images, ref, sigma, mask):
    """(relMSE averaged over the images, outlier count per image, largest (Y − Y_ref) / σ, luminance ratio)."""
    floor = (0.01 * ref[mask].mean()) ** 2
    rel = [float(np.mean(((im - ref) ** 2 / (ref**2 + floor))[mask])) for im in images]
    outliers = [int(((im - ref) > 10.0 * sigma)[mask].sum()) for im in images]
    z = max(float(((im - ref) / np.maximum(sigma, 1e-30))[mask].max()) for im in images)
    lum = float(np.mean([im[mask].mean() for im in images]) / ref[mask].mean())
    return float(np.mean(rel)), outliers, z, lum


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--out", type=Path, default=ROOT / "target/glass-noise")
    p.add_argument("--spectrace", type=Path, default=ROOT / "target/release/spectrace")
    p.add_argument("--size", type=int, default=128)
    p.add_argument("--spp", type=int, default=512)
    p.add_argument("--seeds", type=int, default=4, help="images per renderer at --spp")
    p.add_argument("--ref-spp", type=int, default=1024)
    p.add_argument("--ref-parts", type=int, default=32)
    p.add_argument("--alpha", type=float, default=0.15, help="GGX α (spectrace roughness √α)")
    p.add_argument("--lights", choices=["both", "env", "point"], default="point")
    p.add_argument("--env", type=float, default=0.5, help="environment luminance, nits")
    p.add_argument("--point", type=float, default=105.0 * np.pi, help="point light intensity, cd")
    p.add_argument("--max-depth", type=int, default=32)
    p.add_argument("--threads", type=int, default=1, help="spectrace's (the statistics do not depend on it)")
    p.add_argument(
        "--integrator",
        nargs="+",
        default=["path"],
        choices=["path", "bdpt"],
        help="spectrace's integrators to score (each its own row)",
    )
    args = p.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    args.spectrace = args.spectrace.resolve()
    variant = set_fast_variant()
    mask = mm.sphere_mask(args.size)

    ref_file = args.out / f"ref_{args.size}_{args.alpha}_{args.lights}_{args.ref_parts}x{args.ref_spp}.npy"
    if ref_file.exists():
        parts = np.load(ref_file)
    else:
        parts = mitsuba_renders(args, args.ref_spp, range(100, 100 + args.ref_parts))
        np.save(ref_file, parts)
    ref = parts.mean(axis=0)
    sigma = parts.std(axis=0, ddof=1) * np.sqrt(args.ref_spp / args.spp)

    seeds = range(1, 1 + args.seeds)
    mitsuba = score(mitsuba_renders(args, args.spp, seeds), ref, sigma, mask)
    rows = [("Mitsuba 3.9.1", mitsuba)]
    for integrator in args.integrator:
        run = SimpleNamespace(**dict(vars(args), integrator=integrator))
        rows.append((f"spectrace {integrator}", score(spectrace_renders(run, seeds), ref, sigma, mask)))
    table = [
        f"Rough glass sphere (IOR 1.5, GGX α {args.alpha}, uncompensated), lights: {args.lights}, "
        f"{args.size}×{args.size}, {args.spp} spp × {args.seeds} seeds per renderer; reference Mitsuba "
        f"{args.ref_parts} × {args.ref_spp} spp ({variant}); sphere = {int(mask.sum())} pixels, "
        f"mean Y_ref {ref[mask].mean():.4g}.",
        "",
        "| renderer | relMSE | relMSE / Mitsuba's | pixels > 10σ (per seed) | largest (Y − Y_ref) / σ | Y / Y_ref |",
        "| --- | --- | --- | --- | --- | --- |",
    ]
    for name, (rel, outliers, z, lum) in rows:
        table.append(f"| {name} | {rel:.4g} | {rel / mitsuba[0]:.2f} | {outliers} | {z:.1f} | {lum:.4f} |")
    print("\n".join(table))
    (args.out / "table_glass_noise.md").write_text("\n".join(table) + "\n")


if __name__ == "__main__":
    main()
