#!/usr/bin/env python3
"""The error against the truth of two spectrace renders that differ only in `--seed`
(`mitsuba_common.pair_errors`: mean ΔE00(a, b)/√2 and relative MSE/2, scored against the two
images' mean), and with `--seconds` the time to mean ΔE00 1 it implies (time × ΔE00²). How the
Russian-roulette depths and the depth cuts of `docs/path-tracer.md` were compared:

    for s in 1 2; do target/release/spectrace render scenes/reference/cornell_box.json \
        --integrator path --spp 256 --width 512 --height 512 --threads 2 --rr-depth 3 \
        --seed $s -q -o /tmp/rr3_$s.exr; done
    python3 xtask/compare/pair_error.py /tmp/rr3_1.exr /tmp/rr3_2.exr --seconds 34.5

Needs `pip install colour-science OpenEXR` (not Mitsuba), like the other scripts here.
"""

import argparse
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from mitsuba_common import pair_errors, read_spectrace_exr  # noqa: E402


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("a", type=Path, help="the render with one seed")
    p.add_argument("b", type=Path, help="the same render with another seed")
    p.add_argument("--seconds", type=float, help="one render's time, for the time to mean ΔE00 1")
    args = p.parse_args()
    a, b = read_spectrace_exr(args.a), read_spectrace_exr(args.b)
    de, rel_mse = pair_errors(a, b, None)
    print(f"pair ΔE00 mean {de:.4f}  relative MSE {rel_mse:.4e}  mean Y {a[:, :, 1].mean():.5f} / {b[:, :, 1].mean():.5f}")
    if args.seconds is not None:
        print(f"time × ΔE00² {args.seconds * de**2:.4g} s  (time to mean ΔE00 1 if error² ∝ 1/spp)")


if __name__ == "__main__":
    main()
