#!/usr/bin/env python3
"""Bidirectional path tracing against the path tracer on scenes both converge on: the mean luminance
ratio and the mean ΔE00 of 8×8-pixel blocks between `--integrator bdpt` and `--integrator path`, with
the path tracer against itself at another seed as the noise floor of the block figure.

An optional comparison tool (issue 44): needs numpy, colour-science, OpenEXR and a release build.

    python3 xtask/compare/bdpt_agreement.py --spectrace target/release/spectrace --out target/bdpt-agreement

Each scene is rendered at `--size` (width; height from the scene's aspect), `hero:4` wavelengths,
independent numbers, `--threads`: bdpt at `--bdpt-spp`, the path tracer at `--path-spp` twice (seeds 1
and 2). The table (stdout and OUT/table_bdpt_agreement.md) gives Y(bdpt) / Y(path), the block ΔE00 of
bdpt against path seed 1, and of path seed 2 against path seed 1 (what noise alone gives), and the
wall time of each render.
"""

import argparse
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from mitsuba_common import ROOT, delta_e00, read_spectrace_exr  # noqa: E402

SCENES = ["scenes/reference/cornell_box.json", "scenes/paper/five_spheres.json", "scenes/gltf/textured_cube.gltf"]


def render(args, scene, integrator, spp, seed):
    exr = args.out / f"{Path(scene).stem}_{integrator}_{spp}_s{seed}.exr"
    cmd = [str(args.spectrace), "render", str(ROOT / scene), "--integrator", integrator, "--spp", str(spp)]
    cmd += ["--seed", str(seed), "--spectral", "hero:4", "--sampler", "independent", "-q"]
    cmd += ["--width", str(args.size), "--threads", str(args.threads), "-o", str(exr)]
    start = time.perf_counter()
    subprocess.run(cmd, check=True)
    return read_spectrace_exr(exr), time.perf_counter() - start


def blocks(image, b=8):
    h, w = image.shape[:2]
    return image[: h // b * b, : w // b * b].reshape(h // b, b, w // b, b, 3).mean(axis=(1, 3))


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--out", type=Path, default=ROOT / "target/bdpt-agreement")
    p.add_argument("--spectrace", type=Path, default=ROOT / "target/release/spectrace")
    p.add_argument("--size", type=int, default=128)
    p.add_argument("--bdpt-spp", type=int, default=1024)
    p.add_argument("--path-spp", type=int, default=4096)
    p.add_argument("--threads", type=int, default=2)
    p.add_argument("--scenes", nargs="+", default=SCENES)
    args = p.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    args.spectrace = args.spectrace.resolve()
    lines = [
        f"bdpt ({args.bdpt_spp} spp) against path ({args.path_spp} spp), width {args.size}, hero:4, "
        f"independent numbers, {args.threads} threads.",
        "",
        "| scene | Y bdpt / Y path | block ΔE00 bdpt–path | block ΔE00 path–path (noise) | seconds bdpt / path |",
        "| --- | --- | --- | --- | --- |",
    ]
    for scene in args.scenes:
        b, tb = render(args, scene, "bdpt", args.bdpt_spp, 1)
        p1, tp = render(args, scene, "path", args.path_spp, 1)
        p2, _ = render(args, scene, "path", args.path_spp, 2)
        ratio = b[..., 1].mean() / p1[..., 1].mean()
        de = float(delta_e00(blocks(b), blocks(p1)).mean())
        noise = float(delta_e00(blocks(p2), blocks(p1)).mean())
        lines.append(f"| {scene} | {ratio:.4f} | {de:.3f} | {noise:.3f} | {tb:.1f} / {tp:.1f} |")
        print(lines[-1], flush=True)
    print("\n".join(lines))
    (args.out / "table_bdpt_agreement.md").write_text("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
