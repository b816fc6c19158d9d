"""What the Mitsuba 3 comparison scripts share: the data files read as spectrace reads them, the
light-unit convention, spectrace's EXR read back as CIE XYZ, and the ΔE00 scoring.

Imported by mitsuba_cornell.py and mitsuba_materials.py (run those, not this). Needs numpy,
colour-science and OpenEXR; it does not import Mitsuba.
"""

import csv
from pathlib import Path

import colour
import numpy as np
import OpenEXR

ROOT = Path(__file__).resolve().parents[2]


def read_csv(name):
    """A table of data/ (header row, then numbers): (header, array of rows)."""
    with open(ROOT / "data" / name) as f:
        rows = list(csv.reader(f))
    header, body = rows[0], [[float(v) for v in r] for r in rows[1:]]
    return header, np.array(body)


def held(lam, values, grid):
    """Linear interpolation holding the end values (spectrace's `held_to_visible`)."""
    return np.interp(grid, lam, values)


GRID = np.arange(360.0, 831.0, 1.0)
_, CMF = read_csv("cie1931_2deg_xyz_cmf_1nm.csv")
YBAR = np.interp(GRID, CMF[:, 0], CMF[:, 2])


def illuminant(file, strength):
    """An illuminant table of data/ on GRID, as spectrace uses a named light spectrum: held to
    360-830 nm, normalised to relative luminance 1 (sum S ybar = sum ybar at 1 nm), times the
    strength (nits, cd, ...). Mitsuba's XYZ film divides by the integral of ybar, so these values
    given to Mitsuba as spectral radiance (intensity) render the same Y as spectrace."""
    _, table = read_csv(file)
    s = held(table[:, 0], table[:, 1], GRID)
    return s * (YBAR.sum() / (s * YBAR).sum()) * strength


def spectrum(values, grid=GRID):
    """A Mitsuba `spectrum` dict (irregular, from (λ, value) pairs)."""
    return {"type": "spectrum", "value": [(float(l), float(v)) for l, v in zip(grid, values)]}


SRGB_TO_XYZ = np.array(
    [[0.4124564, 0.3575761, 0.1804375], [0.2126729, 0.7151522, 0.0721750], [0.0193339, 0.1191920, 0.9503041]]
)


def read_spectrace_exr(path):
    """spectrace's EXR (linear sRGB primaries, D65 white, not clamped) as CIE XYZ."""
    with OpenEXR.File(str(path)) as f:
        rgb = np.asarray(f.channels()["RGB"].pixels, dtype=np.float64)[:, :, :3]
    return rgb @ SRGB_TO_XYZ.T


def delta_e00(image, reference):
    """Per-pixel CIEDE2000 between two XYZ images, CIELAB relative to the D65 white at Y = 1 (as
    `cargo xtask validate`); negative XYZ (noise) clamped to 0."""
    white = colour.xy_to_XYZ(colour.CCS_ILLUMINANTS["CIE 1931 2 Degree Standard Observer"]["D65"])
    xy_white = colour.XYZ_to_xy(white)
    lab = colour.XYZ_to_Lab(np.clip(image, 0, None), xy_white)
    lab_ref = colour.XYZ_to_Lab(np.clip(reference, 0, None), xy_white)
    return colour.delta_E(lab, lab_ref, method="CIE 2000")


def pair_errors(a, b, reference):
    """The mean ΔE00 and relative MSE of one image against the truth, estimated from two
    independent images of one renderer at one spp (seeds 1 and 2): their difference has twice
    one image's noise variance and no bias (both renderers converge to the same image: the
    references agree to their own noise), so ΔE00(a, b) / √2 and relMSE(a, b) / 2. A reference
    scores an image only down to its own noise (a 4096-spp reference of this box alone leaves mean
    ΔE00 ~1.1); two seeds need none, so the time to ΔE00 < 1 can be measured where no affordable
    reference reaches. ΔE00 is not linear in the colour difference far from 0, so the /√2 is exact
    only as the errors shrink: read it at the ladder's top."""
    de = float(delta_e00(a, b).mean()) / np.sqrt(2.0)
    # Without a reference (`--ref-spp 0`) the two images' mean stands in for it.
    y_ref = (reference if reference is not None else 0.5 * (a + b))[:, :, 1]
    rel_mse = float(np.mean((a[:, :, 1] - b[:, :, 1]) ** 2 / (y_ref**2 + 1e-2))) / 2.0
    return de, rel_mse
