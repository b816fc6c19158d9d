//! A luminaire's goniometric web as a model: the file's planes expanded by its symmetry to C ∈ [0°, 360°],
//! intensities interpolated bilinearly in (C, γ) (what LM-63 and EULUMDAT readers do between measured
//! angles; zero outside the file's γ range), the luminous flux ∫ I dω exactly for that interpolant, and
//! directions sampled in proportion to it.
//!
//! Frame: γ is measured from the nadir (`direction`), C counter-clockwise about the luminaire's up axis
//! (−nadir) seen from above, from the C0 half-plane (`up`): C90 = C0 × nadir.

use std::f32::consts::TAU;

use geometry::{PhotometricWeb, WebSymmetry};
use glam::{Vec2, Vec3};

use crate::sampling::PiecewiseConstant2D;

/// A goniometric web, expanded and oriented, with its flux and sampling distribution.
#[derive(Debug, Clone)]
pub(crate) struct Luminaire {
    nadir: Vec3,
    c0: Vec3,
    c90: Vec3,
    /// Expanded C planes (radians), from 0 to 2π inclusive, strictly increasing.
    c: Vec<f32>,
    /// Vertical angles (radians), strictly increasing, within [0, π].
    gamma: Vec<f32>,
    /// cos γ at each vertical angle.
    cos_gamma: Vec<f32>,
    /// Candela per (plane, angle): `candela[i * gamma.len() + j]`.
    candela: Vec<f32>,
    /// ∫ I dω of the interpolated web (lm at a scale of 1).
    flux: f64,
    /// Cells (C interval, γ interval) chosen ∝ their flux; rows are γ intervals.
    distribution: PiecewiseConstant2D,
}

/// The intensity of plane `c_deg` (any angle in [0, 360]) folded into the given planes by `symmetry`, at
/// every vertical angle: linear between the given planes (exact on one).
fn folded_plane(web: &PhotometricWeb, c_deg: f32) -> Vec<f32> {
    let n = web.gamma_deg.len();
    let folded = match web.symmetry {
        WebSymmetry::None | WebSymmetry::Rotational => c_deg,
        WebSymmetry::C0C180 => {
            if c_deg <= 180.0 {
                c_deg
            } else {
                360.0 - c_deg
            }
        }
        WebSymmetry::C90C270 => {
            if c_deg < 90.0 {
                180.0 - c_deg
            } else if c_deg > 270.0 {
                540.0 - c_deg
            } else {
                c_deg
            }
        }
        WebSymmetry::Quadrant => {
            let c = c_deg % 180.0;
            if c > 90.0 { 180.0 - c } else { c }
        }
    };
    let planes = &web.c_deg;
    let plane = |i: usize| &web.candela[i * n..(i + 1) * n];
    if planes.len() == 1 {
        return plane(0).to_vec();
    }
    // With no symmetry the planes wrap: between the last and the first + 360°.
    let wrap = web.symmetry == WebSymmetry::None;
    let above = planes.partition_point(|&p| p <= folded);
    let (i0, i1, a0, a1) = if above == 0 {
        let last = planes.len() - 1;
        if wrap { (last, 0, planes[last] - 360.0, planes[0]) } else { (0, 0, planes[0], planes[0]) }
    } else if above == planes.len() {
        let last = planes.len() - 1;
        if wrap { (last, 0, planes[last], planes[0] + 360.0) } else { (last, last, planes[last], planes[last]) }
    } else {
        (above - 1, above, planes[above - 1], planes[above])
    };
    let t = if a1 > a0 { ((folded - a0) / (a1 - a0)).clamp(0.0, 1.0) } else { 0.0 };
    plane(i0).iter().zip(plane(i1)).map(|(&x, &y)| x + t * (y - x)).collect()
}

/// The C planes (degrees) the expanded web needs: the given ones, their mirror images, 0 and 360.
fn expanded_planes(web: &PhotometricWeb) -> Vec<f32> {
    let mut planes: Vec<f32> = vec![0.0, 360.0];
    if web.symmetry != WebSymmetry::Rotational {
        for &p in &web.c_deg {
            planes.push(p);
            match web.symmetry {
                WebSymmetry::C0C180 => planes.push(360.0 - p),
                WebSymmetry::C90C270 => planes.push((540.0 - p) % 360.0),
                WebSymmetry::Quadrant => planes.extend([180.0 - p, 180.0 + p, 360.0 - p]),
                WebSymmetry::None | WebSymmetry::Rotational => {}
            }
        }
    }
    planes.retain(|p| (0.0..=360.0).contains(p));
    planes.sort_by(f32::total_cmp);
    planes.dedup_by(|a, b| (*a - *b).abs() < 1e-3);
    planes
}

impl Luminaire {
    /// The model of `web`, its nadir along `direction` and its C0 half-plane towards `up` (both unit,
    /// perpendicular: the loader makes them so).
    pub(crate) fn new(web: &PhotometricWeb, direction: Vec3, up: Vec3) -> Self {
        let nadir = direction.normalize_or(Vec3::NEG_Y);
        let c0 = up.reject_from_normalized(nadir).try_normalize().unwrap_or_else(|| nadir.any_orthonormal_vector());
        let c90 = c0.cross(nadir);
        let planes_deg = expanded_planes(web);
        let candela: Vec<f32> = planes_deg.iter().flat_map(|&c| folded_plane(web, c)).collect();
        let c: Vec<f32> = planes_deg.iter().map(|d| d.to_radians()).collect();
        let gamma: Vec<f32> = web.gamma_deg.iter().map(|d| d.to_radians()).collect();
        let cos_gamma = gamma.iter().map(|g| g.cos()).collect();
        let (nc, ng) = (c.len(), gamma.len());
        // Flux of each cell, exact for the bilinear interpolant: averaged over C (linear there), then
        // ∫ (a (1 − t) + b t) sin γ dγ = a S0 + (b − a) S1 over the γ interval, t = (γ − γ0) / Δγ.
        let mut cells = Vec::with_capacity((nc - 1) * (ng - 1));
        for j in 0..ng - 1 {
            let (g0, g1) = (f64::from(gamma[j]), f64::from(gamma[j + 1]));
            let s0 = g0.cos() - g1.cos();
            let s1 = -g1.cos() + (g1.sin() - g0.sin()) / (g1 - g0);
            for i in 0..nc - 1 {
                let at = |i: usize, j: usize| f64::from(candela[i * ng + j]);
                let a = 0.5 * (at(i, j) + at(i + 1, j));
                let b = 0.5 * (at(i, j + 1) + at(i + 1, j + 1));
                let dc = f64::from(c[i + 1] - c[i]);
                cells.push((dc * (a * s0 + (b - a) * s1)).max(0.0));
            }
        }
        let flux = cells.iter().sum();
        let weights: Vec<f32> = cells.iter().map(|&f| f as f32).collect();
        let distribution = PiecewiseConstant2D::new(&weights, nc - 1, ng - 1);
        Self { nadir, c0, c90, c, gamma, cos_gamma, candela, flux, distribution }
    }

    /// ∫ I dω over the sphere: the luminaire's flux in lumens (times the light's scale).
    pub(crate) fn flux(&self) -> f64 {
        self.flux
    }

    /// (C, γ) of the world direction `w` (unit) leaving the luminaire.
    fn angles(&self, w: Vec3) -> (f32, f32) {
        let gamma = w.dot(self.nadir).clamp(-1.0, 1.0).acos();
        let mut c = w.dot(self.c90).atan2(w.dot(self.c0));
        if c < 0.0 {
            c += TAU;
        }
        (c.min(TAU), gamma)
    }

    /// The interval of `x` in `grid` (index of its lower end), if within.
    fn interval(grid: &[f32], x: f32) -> Option<usize> {
        if !(x >= grid[0] && x <= grid[grid.len() - 1]) {
            return None;
        }
        Some(grid.partition_point(|&g| g <= x).saturating_sub(1).min(grid.len() - 2))
    }

    /// Luminous intensity (cd) towards the unit world direction `w`: bilinear in (C, γ), zero outside the
    /// web's vertical angles.
    #[inline]
    pub(crate) fn intensity(&self, w: Vec3) -> f32 {
        let (c, gamma) = self.angles(w);
        let (Some(i), Some(j)) = (Self::interval(&self.c, c), Self::interval(&self.gamma, gamma)) else { return 0.0 };
        let ng = self.gamma.len();
        let tc = ((c - self.c[i]) / (self.c[i + 1] - self.c[i])).clamp(0.0, 1.0);
        let tg = ((gamma - self.gamma[j]) / (self.gamma[j + 1] - self.gamma[j])).clamp(0.0, 1.0);
        let at = |i: usize, j: usize| self.candela[i * ng + j];
        let near = at(i, j) + tg * (at(i, j + 1) - at(i, j));
        let far = at(i + 1, j) + tg * (at(i + 1, j + 1) - at(i + 1, j));
        near + tc * (far - near)
    }

    /// Solid angle of cell (`i`, `j`).
    fn cell_solid_angle(&self, i: usize, j: usize) -> f32 {
        (self.c[i + 1] - self.c[i]) * (self.cos_gamma[j] - self.cos_gamma[j + 1])
    }

    /// A direction leaving the luminaire, sampled ∝ the flux of the web's cells and uniformly in solid
    /// angle within one (pbrt-v4 `GoniometricLight::SampleLe`'s direction part), with its density per
    /// steradian; `None` for a dark web.
    pub(crate) fn sample_le(&self, u: Vec2) -> Option<(Vec3, f32)> {
        if !(self.flux > 0.0) {
            return None;
        }
        let (p, density, (i, j)) = self.distribution.sample(u);
        let (nc, ng) = (self.c.len() - 1, self.gamma.len() - 1);
        // Where in the cell: the distribution's point, stretched from its equal pieces onto the cell.
        let fx = (p.x * nc as f32 - i as f32).clamp(0.0, 1.0);
        let fy = (p.y * ng as f32 - j as f32).clamp(0.0, 1.0);
        let c = self.c[i] + fx * (self.c[i + 1] - self.c[i]);
        let cos_gamma = self.cos_gamma[j] + fy * (self.cos_gamma[j + 1] - self.cos_gamma[j]);
        let sin_gamma = (1.0 - cos_gamma * cos_gamma).max(0.0).sqrt();
        let w = sin_gamma * (c.cos() * self.c0 + c.sin() * self.c90) + cos_gamma * self.nadir;
        let pdf = density / (nc * ng) as f32 / self.cell_solid_angle(i, j);
        (pdf > 0.0 && pdf.is_finite()).then_some((w, pdf))
    }

    /// The density of [`Luminaire::sample_le`] for the unit direction `w`.
    pub(crate) fn pdf_le(&self, w: Vec3) -> f32 {
        if !(self.flux > 0.0) {
            return 0.0;
        }
        let (c, gamma) = self.angles(w);
        let (Some(i), Some(j)) = (Self::interval(&self.c, c), Self::interval(&self.gamma, gamma)) else { return 0.0 };
        let (nc, ng) = (self.c.len() - 1, self.gamma.len() - 1);
        self.distribution.pdf_of(i, j) / (nc * ng) as f32 / self.cell_solid_angle(i, j)
    }
}

#[cfg(test)]
mod tests {
    use std::f64::consts::PI;

    use geometry::PhotometricFormat;

    use super::*;
    use crate::sampling::Rng;

    /// A web of `f(C°, γ°)` at the planes `c_deg` and γ = 0, 5, …, 180°.
    fn web(symmetry: WebSymmetry, c_deg: Vec<f32>, f: impl Fn(f32, f32) -> f32) -> PhotometricWeb {
        let gamma_deg: Vec<f32> = (0..=36).map(|i| 5.0 * i as f32).collect();
        let candela =
            c_deg.iter().flat_map(|&c| gamma_deg.iter().map(move |&g| (c, g))).map(|(c, g)| f(c, g)).collect();
        PhotometricWeb { path: "t.ies".into(), format: PhotometricFormat::Ies, symmetry, c_deg, gamma_deg, candela }
    }

    fn planes(from: f32, to: f32) -> Vec<f32> {
        (0..).map(|i| from + 10.0 * i as f32).take_while(|&c| c <= to).collect()
    }

    /// The world direction at (C, γ) in degrees of a luminaire aimed down with C0 along +X.
    fn towards(c: f32, g: f32) -> Vec3 {
        let (c, g) = (c.to_radians(), g.to_radians());
        // C90 = C0 × nadir = X × (−Y) = −Z.
        g.sin() * (c.cos() * Vec3::X - c.sin() * Vec3::Z) - g.cos() * Vec3::Y
    }

    #[test]
    fn every_symmetry_expands_to_the_full_web_of_the_same_function() {
        let g = |gamma: f32| 100.0 + 50.0 * gamma.to_radians().cos();
        type F = fn(f32) -> f32;
        let cases: [(WebSymmetry, f32, f32, F); 4] = [
            (WebSymmetry::Rotational, 0.0, 0.0, |_| 1.0),
            (WebSymmetry::C0C180, 0.0, 180.0, |c| 1.0 + 0.5 * c.to_radians().cos()),
            (WebSymmetry::C90C270, 90.0, 270.0, |c| 1.0 + 0.5 * c.to_radians().sin()),
            (WebSymmetry::Quadrant, 0.0, 90.0, |c| 1.0 + 0.5 * (2.0 * c).to_radians().cos()),
        ];
        for (symmetry, from, to, shape) in cases {
            let f = |c: f32, gamma: f32| g(gamma) * shape(c);
            let half = Luminaire::new(&web(symmetry, planes(from, to), f), Vec3::NEG_Y, Vec3::X);
            let full = Luminaire::new(&web(WebSymmetry::None, planes(0.0, 350.0), f), Vec3::NEG_Y, Vec3::X);
            for c in [0.0, 20.0, 90.0, 135.0, 200.0, 270.0, 300.0, 355.0] {
                // Not γ = 0: C is undefined at the nadir (this test function is not single-valued there).
                for gamma in [10.0, 30.0, 62.5, 120.0] {
                    let w = towards(c, gamma);
                    let (a, b) = (half.intensity(w), full.intensity(w));
                    assert!((a - b).abs() < 1e-3 * b, "{symmetry:?} C{c} γ{gamma}: {a} vs full {b}");
                    if c % 10.0 == 0.0 && gamma % 5.0 == 0.0 {
                        assert!(
                            (a - f(c, gamma)).abs() < 1e-3 * a,
                            "{symmetry:?} C{c} γ{gamma}: {a} vs {}",
                            f(c, gamma)
                        );
                    }
                }
            }
        }
        // C increases counter-clockwise seen from above: with C0 = +X, C90 is −Z (C90–C270 web: 1.5 × g there).
        let c90 = Luminaire::new(
            &web(WebSymmetry::C90C270, planes(90.0, 270.0), |c, _| 1.0 + 0.5 * c.to_radians().sin()),
            Vec3::NEG_Y,
            Vec3::X,
        );
        assert!((c90.intensity(Vec3::new(0.0, -1.0, -1.0).normalize()) - 1.5).abs() < 1e-4);
        assert!((c90.intensity(Vec3::new(0.0, -1.0, 1.0).normalize()) - 0.5).abs() < 1e-4);
    }

    #[test]
    fn interpolation_is_bilinear_in_c_and_gamma_and_zero_beyond_the_web() {
        // Planes every 10° (0–350), so between C10 and C20, γ 5 and 10: the bilinear mean of the corners.
        let lum =
            Luminaire::new(&web(WebSymmetry::None, planes(0.0, 350.0), |c, g| c + 1000.0 * g), Vec3::NEG_Y, Vec3::X);
        let got = lum.intensity(towards(15.0, 7.5));
        assert!((got - (15.0 + 7500.0)).abs() < 0.05, "{got}");
        // Across the seam from C350 to C360 = C0: halfway between 350 and 0.
        let seam = lum.intensity(towards(355.0, 10.0));
        assert!((seam - (175.0 + 10_000.0)).abs() < 0.05, "{seam}");
        // A downlight's web (γ ≤ 90°) sends nothing upwards.
        let mut down = web(WebSymmetry::Rotational, vec![0.0], |_, g| if g <= 90.0 { 10.0 } else { 0.0 });
        down.gamma_deg.truncate(19);
        down.candela.truncate(19);
        let lum = Luminaire::new(&down, Vec3::NEG_Y, Vec3::X);
        assert_eq!(lum.intensity(Vec3::Y), 0.0);
        assert_eq!(lum.intensity(towards(0.0, 95.0)), 0.0);
        assert_eq!(lum.intensity(towards(0.0, 89.0)), 10.0);
        // Hemisphere of 10 cd: 20π lm.
        assert!((lum.flux() - 20.0 * PI).abs() < 1e-3, "{}", lum.flux());
    }

    #[test]
    fn flux_integrates_the_interpolated_web() {
        let iso = Luminaire::new(&web(WebSymmetry::Rotational, vec![0.0], |_, _| 100.0), Vec3::NEG_Y, Vec3::X);
        assert!((iso.flux() / (400.0 * PI) - 1.0).abs() < 1e-6, "{}", iso.flux());
        // I = 1000 cos γ below the horizon: Φ = 1000 π; the 5° chords lose ≈ Δγ²/12 of it.
        let lambert = Luminaire::new(
            &web(WebSymmetry::C0C180, planes(0.0, 180.0), |_, g| 1000.0 * g.to_radians().cos().max(0.0)),
            Vec3::X,
            Vec3::Y,
        );
        assert!((lambert.flux() / (1000.0 * PI) - 1.0).abs() < 1e-3, "{}", lambert.flux());
    }

    /// χ² of `sample_le` against `pdf_le` on 16 × 8 bins of (azimuth about +Y, cos θ), which cut across the
    /// web's cells (aimed sideways), expected counts by a 24 × 24 midpoint rule per bin.
    #[test]
    fn sample_le_follows_its_density_and_its_density_the_intensity() {
        let f = |c: f32, g: f32| {
            let (c, g) = (c.to_radians(), g.to_radians());
            (1000.0 * g.cos() * (1.0 + g.sin() * (0.4 * c.cos() + 0.3 * c.sin()))).max(0.0) + 20.0
        };
        let lum = Luminaire::new(
            &web(WebSymmetry::None, planes(0.0, 350.0), f),
            Vec3::new(1.0, -0.5, 0.2).normalize(),
            Vec3::Y,
        );
        let (nx, ny) = (16usize, 8usize);
        let bin = |w: Vec3| {
            let phi = w.z.atan2(w.x).rem_euclid(std::f32::consts::TAU);
            let x = ((phi / std::f32::consts::TAU) * nx as f32) as usize;
            let y = (((w.y + 1.0) * 0.5) * ny as f32) as usize;
            x.min(nx - 1) + nx * y.min(ny - 1)
        };
        let n = 400_000u32;
        let mut counts = vec![0f64; nx * ny];
        let mut rng = Rng::new(43, 0, 0);
        let mut flux_estimate = 0.0f64;
        for _ in 0..n {
            let (w, pdf) = lum.sample_le(rng.uniform2()).expect("a lit web samples");
            let again = lum.pdf_le(w);
            assert!((again - pdf).abs() <= 2e-3 * pdf, "pdf {pdf} vs pdf_le {again}");
            counts[bin(w)] += 1.0;
            flux_estimate += f64::from(lum.intensity(w) / pdf);
        }
        let flux_estimate = flux_estimate / f64::from(n);
        assert!((flux_estimate / lum.flux() - 1.0).abs() < 0.01, "E[I/pdf] = {flux_estimate}, flux {}", lum.flux());
        let m = 24;
        let mut chi2 = 0.0;
        let mut dof = 0;
        for y in 0..ny {
            for x in 0..nx {
                let mut p = 0.0f64;
                for sy in 0..m {
                    for sx in 0..m {
                        let cos_t = -1.0 + 2.0 * (y as f64 + (sy as f64 + 0.5) / m as f64) / ny as f64;
                        let phi = std::f64::consts::TAU * (x as f64 + (sx as f64 + 0.5) / m as f64) / nx as f64;
                        let sin_t = (1.0 - cos_t * cos_t).sqrt();
                        let w = Vec3::new((sin_t * phi.cos()) as f32, cos_t as f32, (sin_t * phi.sin()) as f32);
                        p += f64::from(lum.pdf_le(w));
                    }
                }
                let expected = p * (4.0 * PI / (nx * ny * m * m) as f64) * f64::from(n);
                if expected > 5.0 {
                    chi2 += (counts[x + nx * y] - expected).powi(2) / expected;
                    dof += 1;
                }
            }
        }
        // Wilson–Hilferty: the χ² quantile at p = 1e-4 for `dof` degrees of freedom.
        let k = f64::from(dof - 1);
        let limit = k * (1.0 - 2.0 / (9.0 * k) + 3.719 * (2.0 / (9.0 * k)).sqrt()).powi(3);
        assert!(chi2 < limit, "χ² = {chi2} over {dof} bins, limit {limit}");
    }
}
