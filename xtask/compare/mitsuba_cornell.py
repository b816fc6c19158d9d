#!/usr/bin/env python3
"""Render scenes/reference/cornell_box.json with spectrace and with Mitsuba 3 (variant
scalar_spectral, and llvm_ad_spectral with `--variants`) at equal spp, and report time and
error for both, equal-error time ratios and fitted times to mean ΔE00 < 1 and relMSE < 1e-3.

An optional comparison tool: the project does not need it. It needs `pip install mitsuba
colour-science OpenEXR` and a release build (`cargo build --release -p cli`).

The Mitsuba scene is built from the same manifest and the same data files: walls are
ColorChecker reflectances held to 360-830 nm as spectrace holds them, the light is CIE A
scaled to luminance 30 (spectrace's `emission_strength` convention), the glass is a smooth
dielectric of IOR 1.5. spectrace's emitters and diffuse surfaces are two-sided; Mitsuba's are
one-sided, so every diffuse surface is wrapped in `twosided` and the light is two
back-to-back rectangles 1e-5 apart. Both films store CIE 1931 XYZ with a box pixel filter.

Error: ΔE00 (CIELAB relative to the D65 white at Y = 1, as `cargo xtask validate`) and
relative MSE of each renderer's image against its own converged reference (`--score own`, the
default), so that the noise each leaves at a given time is compared, or against spectrace's
(`--score common`: one reference for all, as a user comparing the two would score them), or
against Mitsuba's only (`--score mitsuba`: its LLVM variant converges a reference twice as fast,
so one that can score mean ΔE00 1 is affordable; spectrace's is then not rendered). With both
references, they are also compared with each other (the systematic difference between the two
renderers).

    python3 xtask/compare/mitsuba_cornell.py --out target/mitsuba-compare --threads 1 \
        --spp 4 16 64 --ref-spp 1024

The headline comparison (Mitsuba's vectorised variant, 512², 2 threads, one reference):

    python3 xtask/compare/mitsuba_cornell.py --out target/mitsuba-compare --threads 2 \
        --spp 16 32 64 128 --ref-spp 8192 --repeats 3 --score common \
        --variants scalar_spectral llvm_ad_spectral

Time to mean ΔE00 < 1 itself (the headline figure) needs errors measured below what a
reference's own noise lets it score (a 4096-spp reference of this box leaves mean ΔE00 ~1.1):
`--pair` renders every point with a second seed and takes each renderer's error against the
truth from the two images' difference (`pair_errors`), and the time to the threshold from it:

    python3 xtask/compare/mitsuba_cornell.py --out target/mitsuba-compare --threads 2 \
        --spp 256 1024 --ref-spp 16384 --score mitsuba --pair \
        --variants llvm_ad_spectral --spectral auto hero:4

(`--ref-spp 16384` renders Mitsuba's reference in one call, which took more than 24 GB here
and was killed; the one used was the mean of four 4096-spp renders, seeds 7–10, saved under
that name.) Mean ΔE00 falls slower than 1/√spp this far from 0, so the time to ΔE00 1 is read
where the errors reach it; `--ref-spp 0` renders no reference and scores by the pairs alone
(about 28 min of two cores):

    python3 xtask/compare/mitsuba_cornell.py --out target/mitsuba-compare --threads 2 \
        --spp 4096 --ref-spp 0 --pair --variants llvm_ad_spectral --spectral auto

A spectral mode may name spectrace's sampler after an @ (`--spectral auto@independent`), a
variant Mitsuba's (`--variants llvm_ad_spectral@multijitter`); the defaults are each renderer's
own (spectrace: Sobol' points; Mitsuba: independent). A spectrace mode may also name a target
error after a slash (`--spectral auto/1.3`): the render then samples adaptively to `--target-error
1.3` (the default `spectrace render` of a path-traced scene, at target 1), `--spp` is its
`--max-spp`, and its time counts the stages that decided where the samples go.

`llvm_ad_spectral` (Mitsuba's vectorised LLVM variant) needs an LLVM drjit can load: drjit's
default LLVM 15 aborts on Debian 12, whose `libllvm19` package works; the script sets
`DRJIT_LIBLLVM_PATH=/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1` when that file exists and the
variable is unset. Its first render of a scene compiles kernels, so each variant renders once
at the smallest spp before the timed runs (a warm-up, not counted).

Time to an error: the spp ladder's errors are fitted as a power of spp (least squares in
log-log; Monte Carlo noise gives MSE ∝ 1/spp) and its times as a line in spp (set-up
included), and the fit's time at the threshold is reported; a fit that lands beyond a
quarter of the reference's spp is marked, since the reference's own noise is then a floor
under the error. `--repeats K` renders each point K times (same seed), interleaving
renderers, and takes the median time. spectrace is timed as a whole process (start-up, BVH,
output included); Mitsuba's timer starts after `load_dict`: fixed costs count against
spectrace.
"""

import argparse
import json
import os
import subprocess
import sys
import time
from pathlib import Path

LLVM19 = "/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1"
if "DRJIT_LIBLLVM_PATH" not in os.environ and os.path.exists(LLVM19):
    os.environ["DRJIT_LIBLLVM_PATH"] = LLVM19

import drjit as dr  # noqa: E402
import mitsuba as mi  # noqa: E402
import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
from mitsuba_common import (  # noqa: E402
    GRID,
    ROOT,
    delta_e00,
    held,
    illuminant,
    pair_errors,
    read_csv,
    read_spectrace_exr,
    spectrum,
)

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


def mitsuba_scene(manifest, spp, width, height, sampler="independent"):
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
            "sampler": {"type": sampler, "sample_count": spp},
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


def render_mitsuba(manifest, spp, width, height, seed, variant="scalar_spectral"):
    """`variant` may name a sampler after an @ (`llvm_ad_spectral@multijitter`; default
    Mitsuba's default, `independent`)."""
    variant, _, sampler = variant.partition("@")
    mi.set_variant(variant)
    scene = mi.load_dict(mitsuba_scene(manifest, spp, width, height, sampler or "independent"))
    start = time.perf_counter()
    image = mi.render(scene, spp=spp, seed=seed)
    image = np.array(image)  # waits for the LLVM variant's kernels to finish
    seconds = time.perf_counter() - start
    return image[:, :, :3].astype(np.float64), seconds


def time_to(spps, errors_, seconds, threshold):
    """Fitted time at which the error reaches `threshold` (see the module's docstring), and
    the fitted spp there; None with fewer than two points or if the errors do not fall with spp."""
    if len(spps) < 2:
        return None
    x = np.log(np.asarray(spps, dtype=np.float64))
    slope, intercept = np.polyfit(x, np.log(np.asarray(errors_)), 1)
    if slope >= 0:
        return None
    spp = float(np.exp((np.log(threshold) - intercept) / slope))
    per, fixed = np.polyfit(np.asarray(spps, dtype=np.float64), np.asarray(seconds), 1)
    if per <= 0:
        return None
    return per * spp + fixed, spp


def render_spectrace(binary, spp, width, height, seed, threads, spectral, out):
    """`spectral` may name a sampler after an @ (`auto@independent`; default spectrace's
    default) and an adaptive render after a slash: `auto/1.2` samples to `--target-error 1.2`
    with `spp` as `--max-spp` (and no time limit), as `spectrace render` does by default."""
    exr = out / f"spectrace_{spectral.replace(':', '').replace('@', '_').replace('/', '_te')}_{spp}_seed{seed}.exr"
    spectral, _, target = spectral.partition("/")
    spectral, _, sampler = spectral.partition("@")
    cmd = [str(binary), "render", str(SCENE), "--integrator", "path", "--seed", str(seed)]
    if target:
        cmd += ["--target-error", target, "--max-spp", str(spp), "--time-limit", "0"]
    else:
        cmd += ["--spp", str(spp)]
    cmd += ["--spectral", spectral, "--width", str(width), "--height", str(height), "--threads", str(threads)]
    if sampler:
        cmd += ["--sampler", sampler]
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
    p.add_argument(
        "--ref-spp", type=int, default=1024, help="0: render no reference (with --pair: errors from the seeds alone)"
    )
    p.add_argument("--spectral", nargs="+", default=["auto", "hero:4"])
    p.add_argument("--variants", nargs="+", default=["scalar_spectral"])
    p.add_argument(
        "--score",
        choices=["common", "own", "mitsuba"],
        help="the reference each image is scored against (default own; none with --ref-spp 0)",
    )
    p.add_argument("--repeats", type=int, default=1)
    p.add_argument(
        "--pair",
        action="store_true",
        help="also render seed 2 at each spp and estimate the error against the truth from the two seeds' difference",
    )
    args = p.parse_args()
    if args.ref_spp == 0 and not args.pair:
        p.error("--ref-spp 0 scores nothing without --pair")
    if args.ref_spp == 0 and args.score is not None:
        p.error(f"--score {args.score} needs a reference, and --ref-spp 0 renders none")
    # "none": no reference, the errors come from the seed pairs alone.
    args.score = "none" if args.ref_spp == 0 else args.score or "own"
    args.out.mkdir(parents=True, exist_ok=True)
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
    refs = {}
    # Mitsuba's own reference (its fastest variant asked for): for `--score own` and `mitsuba`,
    # and for the systematic difference between the two renderers' converged images.
    v = "llvm_ad_spectral" if "llvm_ad_spectral" in args.variants else args.variants[0].partition("@")[0]
    if args.ref_spp > 0:
        refs["mitsuba"] = cached(
            f"ref_mitsuba_{v}_{n}_{args.ref_spp}", lambda: render_mitsuba(manifest, args.ref_spp, n, n, 7, v)
        )
    # `--score mitsuba` needs no reference of spectrace's: Mitsuba's LLVM variant converges one
    # about twice as fast (16384 spp at 512²: ~25 min on two cores), so every image is scored
    # against it (as the headline figures were).
    if args.score not in ("mitsuba", "none"):
        ref_s = cached(
            f"ref_spectrace_{n}_{args.ref_spp}",
            lambda: render_spectrace(args.spectrace, args.ref_spp, n, n, 7, os.cpu_count(), "bins:95", args.out),
        )
        refs["spectrace"] = ref_s
        ratio = ref_s[:, :, 1].mean() / refs["mitsuba"][:, :, 1].mean()
        print(f"converged references ({args.ref_spp} spp), spectrace vs Mitsuba: mean Y ratio {ratio:.4f}")
        for block in (1, 4, 8):
            # Block averages take the references' own remaining noise out of the comparison.
            mean, p95, rmse = errors(downsample(ref_s, block), downsample(refs["mitsuba"], block))
            print(f"  {block}x{block} blocks: ΔE00 mean {mean:.3f} p95 {p95:.3f}, relative MSE {rmse:.2e}")
    dr.set_thread_count(args.threads)

    def reference(renderer):
        if args.score == "none":
            return None
        if args.score == "own":
            return refs[renderer]
        return refs["mitsuba"] if args.score == "mitsuba" else refs["spectrace"]

    renderers = [(f"mitsuba {v}", "mitsuba", v) for v in args.variants]
    renderers += [(f"spectrace {s}", "spectrace", s) for s in args.spectral]
    # Warm-up (the LLVM variant compiles its kernels on the first render of a scene).
    for _, kind, mode in renderers:
        if kind == "mitsuba":
            render_mitsuba(manifest, min(args.spp), n, n, 3, mode)
    results = {name: [] for name, _, _ in renderers}
    pairs = {name: [] for name, _, _ in renderers}
    seeds = [1, 2] if args.pair else [1]
    for spp in args.spp:
        times = {name: [] for name, _, _ in renderers}
        images = {}
        for _ in range(args.repeats):
            for seed in seeds:
                for name, kind, mode in renderers:
                    if kind == "mitsuba":
                        image, secs = render_mitsuba(manifest, spp, n, n, seed, mode)
                    else:
                        image, secs = render_spectrace(args.spectrace, spp, n, n, seed, args.threads, mode, args.out)
                    times[name].append(secs)
                    images[(name, seed)] = image
        for name, kind, _ in renderers:
            secs = float(np.median(times[name]))
            if args.score != "none":
                results[name].append((spp, secs, *errors(images[(name, 1)], reference(kind))))
            if args.pair:
                pairs[name].append((spp, secs, *pair_errors(images[(name, 1)], images[(name, 2)], reference(kind))))
    if args.score != "none":
        print_scored(args, renderers, results, n)
    if args.pair:
        print_pairs(pairs)


def print_scored(args, renderers, results, n):
    """The errors against the reference, the equal-error time ratios and the fitted times."""
    against = {"own": "each renderer’s own reference", "common": "spectrace’s reference", "mitsuba": "Mitsuba’s reference"}
    print(f"scored against: {against[args.score]}")
    print("renderer                    spp  seconds  Msamples/s  ΔE00 mean  ΔE00 p95  rel.MSE")
    for name, rows in results.items():
        for spp, secs, mean, p95, rmse in rows:
            rate = n * n * spp / secs / 1e6
            print(f"{name:27} {spp:4} {secs:8.2f} {rate:11.3f} {mean:10.3f} {p95:9.3f} {rmse:8.2e}")
    # Equal-error time ratios at each spp against a baseline: Monte Carlo MSE falls as 1/spp, so
    # the time to reach the baseline's error is t·(e/e_base) for relative MSE and t·(e/e_base)²
    # for ΔE00 (a distance, ∝ spp^-1/2 while noise dominates), taking time ∝ spp (spectrace's
    # fixed costs count against it). No extrapolation beyond the ladder.
    base = next((name for name, _, mode in renderers if mode.startswith("llvm_ad_spectral")), renderers[0][0])
    print(f"equal-error time ratio against {base} (below 1: faster to the same error)")
    print("renderer                    spp   ΔE00 mean   rel.MSE")
    for name, rows in results.items():
        for (spp, secs, mean, _, rmse), (_, b_secs, b_mean, _, b_rmse) in zip(rows, results[base]):
            de = (mean / b_mean) ** 2 * secs / b_secs
            mse = rmse / b_rmse * secs / b_secs
            print(f"{name:27} {spp:4} {de:11.3f} {mse:9.3f}")
    print("renderer                    time to ΔE00 < 1 (spp)   time to relMSE < 1e-3 (spp)")
    for name, rows in results.items():
        spps = [r[0] for r in rows]
        secs = [r[1] for r in rows]
        cells = []
        for column, threshold in ((2, 1.0), (4, 1e-3)):
            fit = time_to(spps, [r[column] for r in rows], secs, threshold)
            if fit is None:
                cells.append("—")
            else:
                # Beyond a quarter of the reference's spp its own noise floors the error: not a measurement.
                mark = " *" if fit[1] > args.ref_spp / 4 else "  "
                cells.append(f"{fit[0]:8.1f} s ({fit[1]:6.0f}){mark}")
        print(f"{name:27} {cells[0]:>26} {cells[1]:>30}")
    print(f"* fitted beyond a quarter of the reference's {args.ref_spp} spp: floored by its noise, not a measurement")


def print_pairs(pairs):
    """Each renderer's error against the truth from its two seeds, and the times it implies."""
    print("error against the truth from two seeds (no reference noise; see pair_errors), and the time")
    print("to mean ΔE00 1 and relative MSE 1e-3 that it implies (error² ∝ 1/spp, time ∝ spp)")
    print("renderer                    spp  seconds  ΔE00 mean  rel.MSE   → ΔE00 < 1: s (spp)   rel.MSE < 1e-3: s (spp)")
    for name, rows in pairs.items():
        for spp, secs, de, rmse in rows:
            spp_de, spp_mse = spp * de**2, spp * rmse / 1e-3
            t_de, t_mse = secs * spp_de / spp, secs * spp_mse / spp
            print(
                f"{name:27} {spp:4} {secs:8.2f} {de:10.3f} {rmse:8.2e} {t_de:10.1f} ({spp_de:6.0f}) {t_mse:12.1f} ({spp_mse:6.0f})"
            )


if __name__ == "__main__":
    main()
