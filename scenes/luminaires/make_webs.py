#!/usr/bin/env python3
"""Writes the synthetic photometric files of this folder (spectrace's own, from formulas; no measured data).

- lambert_1000cd.ies / .ldt: CIE 171:2006 test case 5.2's source, I(γ) = 1000 cd · cos γ below the
  horizon, rotationally symmetric. The IES file stores 500 cos γ with a candela multiplier of 2; the LDT
  file 500 cos γ cd/klm for a 2000 lm lamp: both exercise their format's multipliers.
- asymmetric.ies / .ldt: no symmetry, I(γ, C) = 1000 cd · cos γ · (1 + sin γ (0.4 cos C + 0.3 sin C)),
  C planes every 5°, so the C0, C90, C180 and C270 directions all differ.

Run from this folder: python3 make_webs.py
"""
import math

GAMMA = [2.5 * i for i in range(37)]  # 0..90°


def lambert(g, c):
    return 500.0 * math.cos(math.radians(g))


def asymmetric(g, c):
    gr, cr = math.radians(g), math.radians(c)
    return 1000.0 * math.cos(gr) * (1.0 + math.sin(gr) * (0.4 * math.cos(cr) + 0.3 * math.sin(cr)))


def fmt(v):
    return f"{max(v, 0.0):.4f}"


def write_ies(name, title, planes, f, multiplier):
    lines = [
        "IES:LM-63-2019",
        "[TEST] spectrace synthetic web",
        "[TESTLAB] spectrace",
        "[ISSUEDATE] 2025-01-01",
        "[MANUFAC] spectrace (synthetic, from a formula: scenes/luminaires/make_webs.py)",
        f"[LUMINAIRE] {title}",
        "TILT=NONE",
        f"1 -1 {multiplier} {len(GAMMA)} {len(planes)} 1 2 0 0 0",
        "1.0 1.0 0",
        " ".join(f"{g:g}" for g in GAMMA),
        " ".join(f"{c:g}" for c in planes),
    ]
    for c in planes:
        lines.append(" ".join(fmt(f(g, c)) for g in GAMMA))
    open(name, "w").write("\r\n".join(lines) + "\r\n")


def write_ldt(name, title, isym, mc, dc, planes, f, flux):
    lines = [
        "spectrace synthetic web (scenes/luminaires/make_webs.py)",
        "1" if isym == 1 else "3",  # Ityp: point source, rotational or other symmetry
        str(isym),
        str(mc),
        f"{dc:g}",
        str(len(GAMMA)),
        "2.5",
        "none",
        title,
        "0",
        name,
        "2025-01-01 spectrace",
        "0", "0", "0", "0", "0", "0", "0", "0", "0",  # dimensions (mm): a point source
        "100",  # DFF %
        "100",  # LORL %
        "1",  # conversion factor for intensities
        "0",  # tilt during measurement
        "1",  # lamp sets
        "1",  # lamps
        "synthetic",
        f"{flux:g}",  # total flux (lm)
        "3000",
        "100",
        "10",
    ]
    lines += ["0"] * 10  # direct ratios
    lines += [f"{dc * i:g}" for i in range(mc)]
    lines += [f"{g:g}" for g in GAMMA]
    for c in planes:
        lines += [fmt(f(g, c)) for g in GAMMA]
    open(name, "w").write("\r\n".join(lines) + "\r\n")


write_ies("lambert_1000cd.ies", "Lambertian point source, I = 1000 cd cos(gamma)", [0.0], lambert, 2)
write_ldt("lambert_1000cd.ldt", "Lambertian point source, I = 1000 cd cos(gamma)", 1, 24, 15, [0.0], lambert, 2000)
planes = [5.0 * i for i in range(72)]
write_ies("asymmetric.ies", "asymmetric web", planes, asymmetric, 1)
write_ldt("asymmetric.ldt", "asymmetric web", 0, 72, 5, planes, lambda g, c: asymmetric(g, c), 1000)
