//! Per-pixel colour error between two renders, shared by `paper` and `validate`.

use colorimetry::{Lab, Xyz, delta_e_2000};

/// The D65 white at Y = 1 (CIE 015:2018, 2°): the reference white of the ΔE00 comparisons
/// between renders (the film stores Y = 1 for white).
pub(crate) const WHITE: Xyz = Xyz { x: 0.95047, y: 1.0, z: 1.08883 };

pub(crate) fn xyz_of(p: [f32; 3]) -> Xyz {
    Xyz { x: p[0].into(), y: p[1].into(), z: p[2].into() }
}

/// ΔE00 of every pixel pair, in CIELAB relative to [`WHITE`].
pub(crate) fn delta_e_all(a: &[[f32; 3]], b: &[[f32; 3]]) -> Vec<f64> {
    a.iter()
        .zip(b)
        .map(|(p, q)| delta_e_2000(Lab::from_xyz(xyz_of(*p), WHITE), Lab::from_xyz(xyz_of(*q), WHITE)))
        .collect()
}

pub(crate) fn mean(v: &[f64]) -> f64 {
    v.iter().sum::<f64>() / v.len().max(1) as f64
}

/// 95th percentile (nearest rank); 0 for no values.
pub(crate) fn p95(v: &[f64]) -> f64 {
    let mut s = v.to_vec();
    s.sort_by(f64::total_cmp);
    s.get(((s.len().max(1) - 1) as f64 * 0.95).round() as usize).copied().unwrap_or(0.0)
}
