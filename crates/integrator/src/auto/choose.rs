//! `--spectral auto`: the spectral strategy a scene needs, decided from every spectrum that
//! shapes its image (the rule is documented in `docs/path-tracer.md`, "Spectral strategies").
//!
//! A light's radiance reaches the camera multiplied by the spectra it meets: reflectances and
//! surface transmittances at each interaction, and inside an absorbing medium the Beer
//! transmittance e^{−σ_a d} over the path length d. Fixed wavelength lanes point-sample that
//! product (σ_a is sampled per lane and exponentiated per lane, so the lanes see exactly the
//! point samples of e^{−σ_a d}). `auto` takes the fewest lanes whose colour of every such
//! product is within ΔE00 0.1 of its 1 nm integral, and the safe strategy when none is or the
//! scene has too many spectra to check.

use colorimetry::{DenselySampledSpectrum, Lab, Xyz, delta_e_2000};
use glam::Vec3;
use materials::is_flat;

use crate::options::IntegratorKind;
use crate::scene::{RenderScene, emitter_spectra, scene_white};
use crate::spectral::{Lanes, MAX_BINS, SpectralMode, SpectrumKind};

/// Wavelength counts `auto` may choose, cheapest first.
const AUTO_CANDIDATES: [usize; 8] = [8, 12, 16, 24, 32, 48, 64, 95];

/// Largest colour error (ΔE00) `auto` accepts for any light × surface spectrum of the scene,
/// against the 1 nm integral: a tenth of a just-noticeable difference.
const AUTO_MAX_DELTA_E: f64 = 0.1;

/// The 5 nm grid over 360–830 nm, on which the CIE tabulates line spectra.
const FINE_BINS: usize = 95;

/// Optical depth σ_max·d below which a medium counts as clear: e^{−σ_a d} ≥ e^{−0.05} = 0.951
/// at every wavelength. The lanes' error on a Beer factor grows with its depth (a notch is
/// missed or hit in proportion to how deep it is), so the deep end is what decides.
const MIN_OPTICAL_DEPTH: f64 = 0.05;

/// Most path lengths checked per absorber: the depths halve from the longest path down to the
/// clear one (a factor of 2 per step; for a σ_a range wider than 2^47 the steps widen).
const MAX_DEPTHS: usize = 48;

/// Most (light, product) pairs `auto` evaluates. Beyond it (thousands of distinct spectra,
/// which no scene of the project comes near: the ColorChecker chart has 49) the check would
/// cost more than it saves, and `auto` takes the safe strategy instead.
const MAX_CASES: usize = 20_000;

/// What `--spectral auto` picks for a scene.
///
/// Both integrators: the fewest evenly spaced wavelengths (of 8, 12, 16, 24, 32, 48, 64, 95)
/// whose colour error is below ΔE00 0.1, against the 1 nm integral, for every product of a
/// light spectrum (lights, background, emissive surfaces) with
/// - 1 (the light seen directly),
/// - every non-flat reflectance or transmittance in use, once and twice (two interactions),
/// - for every medium whose σ_a varies with λ: e^{−σ_a d} at the path lengths d from twice the
///   diagonal of the box around the material's primitives (one chord and one internal
///   reflection) down by halves to the clear depth (σ_max d = 0.05), alone, through the
///   material's transmittance twice (in and out), and times each of the spectra above (what
///   is seen through the medium, or lit through it).
///
/// A flat σ_a scales a product without changing its chromaticity (and a darker colour has a
/// smaller ΔE00 for the same relative error), so it adds nothing to check: scenes without a
/// spectral absorber are decided exactly as before absorption was considered.
///
/// The path tracer (`path`):
/// - a dispersive dielectric → `hero:8` (fixed lanes would have to keep one lane per path past
///   the prism and waste the others; hero sampling keeps its hero wavelength, stratified);
/// - otherwise the bin count above: fixed bins add no colour noise and their bias is below
///   ΔE00 0.1 by construction. Measured on the F11 ColorChecker (`docs/path-tracer.md`):
///   `bins:95` costs 1.4–1.9× `hero:8` per sample on the Cornell box but reaches mean ΔE00
///   0.03 at 1 spp, where `hero:8` needs ~512 spp.
///
/// When unsure (no bin count passes, or too many spectra to check): `hero:8` for the path
/// tracer (unbiased for any spectrum), `bins:95` for the paper's model (its finest grid).
pub fn choose_auto(scene: &RenderScene, integrator: IntegratorKind) -> SpectralMode {
    match integrator {
        // Dispersion and fluorescence shift or split wavelengths per path: only hero wavelengths can follow.
        IntegratorKind::Path | IntegratorKind::Bdpt | IntegratorKind::Sppm
            if scene.materials.iter().any(|m| m.is_dispersive() || m.fluorescence.is_some()) =>
        {
            SpectralMode::Hero { count: 8 }
        }
        IntegratorKind::Path | IntegratorKind::Bdpt | IntegratorKind::Sppm => {
            auto_bins(scene).map_or(SpectralMode::Hero { count: 8 }, SpectralMode::Bins)
        }
        IntegratorKind::WhittedHall => SpectralMode::Bins(auto_bins(scene).unwrap_or(FINE_BINS)),
    }
}

/// The fewest candidate bins that pass, or `None` when none does or the scene is too large to
/// check.
fn auto_bins(scene: &RenderScene) -> Option<usize> {
    let lights = emitter_spectra(scene);
    let surfaces = surface_spectra(scene, lights.len())?;
    let white = scene_white(scene);
    let xyz = colorimetry::relative_xyz;
    // (lit surface spectrum, its light's 1 nm XYZ, its own 1 nm XYZ).
    let cases: Vec<_> = lights
        .iter()
        .flat_map(|l| {
            // The light's own XYZ once, not once per surface it lights.
            let light_xyz = xyz(l);
            surfaces.iter().map(move |r| (light_xyz, r.product(l)))
        })
        .map(|(light_xyz, lit)| {
            let color = xyz(&lit);
            (lit, light_xyz, color)
        })
        .collect();
    let lab = |c: Xyz, white: Xyz| Lab::from_xyz(c.scaled(1.0 / white.y), white.scaled(1.0 / white.y));
    AUTO_CANDIDATES.into_iter().find(|&n| {
        let lanes = Lanes::<{ MAX_BINS }>::bins(n, &white);
        let lane_xyz = |s: &DenselySampledSpectrum| {
            let v = lanes.xyz(&lanes.project(s, SpectrumKind::Emission));
            Xyz { x: v[0].into(), y: v[1].into(), z: v[2].into() }
        };
        // Absolute error: the lanes' colour of each lit surface against its 1 nm colour, both
        // in CIELAB relative to the light's exact white (what the film's XYZ will be judged by).
        cases.iter().all(|(lit, light_xyz, color)| {
            light_xyz.y <= 0.0
                || delta_e_2000(lab(*color, *light_xyz), lab(lane_xyz(lit), *light_xyz)) < AUTO_MAX_DELTA_E
        })
    })
}

/// The spectra a light is multiplied by on its way to the camera that `auto` checks (see
/// [`choose_auto`]); `None` when, with `lights` light spectra, they exceed [`MAX_CASES`].
fn surface_spectra(scene: &RenderScene, lights: usize) -> Option<Vec<DenselySampledSpectrum>> {
    let too_many = |n: usize| n.saturating_mul(lights.max(1)) > MAX_CASES;
    let mut surfaces = vec![DenselySampledSpectrum::constant(1.0)];
    for m in &scene.materials {
        let used = [(m.kd > 0.0, &m.diffuse), (m.ks > 0.0, &m.specular), (m.is_transmissive(), &m.transmittance)];
        for (on, s) in used {
            if on && !is_flat(s) {
                surfaces.push(s.clone());
                surfaces.push(s.product(s));
            }
        }
        if too_many(surfaces.len()) {
            return None;
        }
    }
    let absorbers: Vec<usize> = (0..scene.materials.len())
        .filter(|&i| {
            let m = &scene.materials[i];
            m.absorbs() && m.absorption.as_ref().is_some_and(|a| !is_flat(a.sigma_a()))
        })
        .collect();
    if absorbers.is_empty() {
        return Some(surfaces);
    }
    let extents = material_extents(scene);
    let seen_before = surfaces.len();
    for i in absorbers {
        let (m, Some((lo, hi))) = (&scene.materials[i], extents.get(i).copied().flatten()) else {
            continue; // no primitive uses it
        };
        let Some(sigma_a) = m.absorption.as_ref().map(|a| a.sigma_a()) else { continue };
        let longest = 2.0 * f64::from((hi - lo).length());
        if !longest.is_finite() {
            return None; // a span past f32 (coordinates are bounded by 1e18, so never): unsure
        }
        let depths = beer_depths(longest, sigma_a.max_value());
        if too_many(surfaces.len() + depths.len() * (seen_before + 1)) {
            return None;
        }
        for d in depths {
            let beer = beer(sigma_a, d);
            let through = if is_flat(&m.transmittance) {
                beer.clone()
            } else {
                beer.product(&m.transmittance.product(&m.transmittance))
            };
            let seen: Vec<_> = surfaces[..seen_before].iter().map(|r| r.product(&through)).collect();
            surfaces.extend(seen);
            surfaces.push(beer);
        }
    }
    Some(surfaces)
}

/// e^{−σ_a d} at every nanometre of 360–830 nm (σ_a is 0 outside its own grid, as the lanes
/// sample it, so the transmittance is 1 there).
fn beer(sigma_a: &DenselySampledSpectrum, d: f64) -> DenselySampledSpectrum {
    let (lo, hi) = (colorimetry::LAMBDA_MIN as u32, colorimetry::LAMBDA_MAX as u32);
    let values = (lo..=hi).map(|nm| (-sigma_a.eval(f64::from(nm)) * d).exp()).collect();
    DenselySampledSpectrum::new(f64::from(lo), 1.0, values).unwrap_or_else(|_| DenselySampledSpectrum::constant(1.0))
}

/// Path lengths at which `auto` checks e^{−σ_a d}: from `longest` down by halves to the clear
/// depth [`MIN_OPTICAL_DEPTH`]`/σ_max`, at most [`MAX_DEPTHS`] (evenly spaced in log d).
fn beer_depths(longest: f64, sigma_max: f64) -> Vec<f64> {
    if !(longest > 0.0 && longest.is_finite() && sigma_max > 0.0) {
        return Vec::new();
    }
    let shortest = MIN_OPTICAL_DEPTH / sigma_max;
    if longest <= shortest {
        return vec![longest];
    }
    let ratio = longest / shortest;
    let count = (ratio.log2().ceil() as usize + 1).clamp(2, MAX_DEPTHS);
    let factor = ratio.powf(1.0 / (count - 1) as f64);
    (0..count).map(|k| longest / factor.powi(k as i32)).collect()
}

/// The box around each material's primitives (`None` for a material no primitive uses).
fn material_extents(scene: &RenderScene) -> Vec<Option<(Vec3, Vec3)>> {
    let mut out: Vec<Option<(Vec3, Vec3)>> = vec![None; scene.materials.len()];
    let mut grow = |material: Option<u32>, lo: Vec3, hi: Vec3| {
        if let Some(slot) = material.and_then(|m| out.get_mut(m as usize)) {
            *slot = Some(slot.map_or((lo, hi), |(a, b)| (a.min(lo), b.max(hi))));
        }
    };
    let geometry = &scene.geometry;
    for s in geometry.spheres() {
        let r = Vec3::splat(s.radius());
        grow(s.material(), s.center() - r, s.center() + r);
    }
    for mesh in geometry.meshes() {
        let p = mesh.positions();
        if let Some(&first) = p.first() {
            let (lo, hi) = p.iter().fold((first, first), |(lo, hi), &v| (lo.min(v), hi.max(v)));
            grow(mesh.material(), lo, hi);
        }
    }
    // Placed objects' meshes too (before, an absorber used only by instances was not checked at all).
    for (mesh, (lo, hi)) in geometry.placed_mesh_bounds() {
        if lo.cmple(hi).all() {
            grow(mesh.material(), lo, hi);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A glass slab (1 unit thick) whose σ_a is `sigma_a` (manifest syntax) before a D65
    /// emissive backdrop, as `scenes/reference/slab_band.json`: its description (the two glass quads
    /// first, then the backdrop).
    fn slab_desc(sigma_a: &str) -> geometry::SceneDescription {
        let json = format!(
            r#"{{ "camera": {{"position": [0, 0, 10], "look_at": [0, 0, 0], "vfov_deg": 4}},
            "materials": {{
              "glass": {{"model": "dielectric", "base_color": 0, "diffuse": 0, "transmission": 1, "transmittance": 1,
                         "ior": 1.5, "absorption": {{"sigma_a": {sigma_a}}}}},
              "backdrop": {{"model": "diffuse", "base_color": 0, "emission": "D65"}} }},
            "objects": [
              {{"type": "quad", "corner": [-3, -3, 0.5], "edge_u": [6, 0, 0], "edge_v": [0, 6, 0], "material": "glass"}},
              {{"type": "quad", "corner": [-3, -3, -0.5], "edge_u": [0, 6, 0], "edge_v": [6, 0, 0], "material": "glass"}},
              {{"type": "quad", "corner": [-50, -50, -5], "edge_u": [100, 0, 0], "edge_v": [0, 100, 0], "material": "backdrop"}}
            ] }}"#
        );
        geometry::parse_manifest(&json, std::path::Path::new("."), "<test>").unwrap()
    }

    /// [`slab_desc`], assembled.
    fn slab(sigma_a: &str) -> RenderScene {
        RenderScene::from_description(slab_desc(sigma_a)).unwrap()
    }

    /// ΔE00 of the lanes' colour of D65 × e^{−σ_a d} against its 1 nm colour.
    fn beer_error(scene: &RenderScene, bins: usize, d: f64) -> f64 {
        let light = emitter_spectra(scene)[0].clone();
        let glass = scene.materials.iter().find(|m| m.name == "glass").unwrap();
        let sigma_a = glass.absorption.as_ref().unwrap().sigma_a();
        let lit = beer(sigma_a, d).product(&light);
        let lanes = Lanes::<{ MAX_BINS }>::bins(bins, &scene_white(scene));
        let v = lanes.xyz(&lanes.project(&lit, SpectrumKind::Emission));
        let (white, exact) = (colorimetry::relative_xyz(&light), colorimetry::relative_xyz(&lit));
        let got = Xyz { x: v[0].into(), y: v[1].into(), z: v[2].into() };
        delta_e_2000(Lab::from_xyz(exact, white), Lab::from_xyz(got, white))
    }

    /// The rule looked at light × surface products only, never at σ_a, and chose
    /// bins:8 for glass with a narrow absorption band at 580 nm, which it renders violet.
    #[test]
    fn a_narrow_absorption_band_is_not_rendered_with_eight_bins() {
        // σ_a of `scenes/reference/slab_band.json`: a Gaussian band, peak 3 per unit at 580 nm, SD 8 nm.
        let band = "{\"samples\": [[540, 0.0], [544, 0.0001], [548, 0.001], [552, 0.0066], [556, 0.0333], [560, 0.1318], [564, 0.406], [568, 0.974], [572, 1.8196], [576, 2.6475], [580, 3.0], [584, 2.6475], [588, 1.8196], [592, 0.974], [596, 0.406], [600, 0.1318], [604, 0.0333], [608, 0.0066], [612, 0.001], [616, 0.0001], [620, 0.0]]}";
        let scene = slab(band);
        // The case is real: through the 1 unit slab, 8 bins are off by far more than a JND.
        assert!(beer_error(&scene, 8, 1.0) > 5.0, "{}", beer_error(&scene, 8, 1.0));
        let whitted = choose_auto(&scene, IntegratorKind::WhittedHall);
        let SpectralMode::Bins(n) = whitted else { panic!("{whitted}") };
        // No bin count holds the band at every path length the slab allows (up to twice its
        // diagonal): the paper's model takes its finest grid, the path tracer the unbiased hero:8.
        assert_eq!(n, FINE_BINS);
        let fine = beer_error(&scene, n, 1.0);
        assert!(fine < 0.5, "bins:{n}: {fine}");
        eprintln!("band through 1 unit: ΔE00 bins:8 {:.2}, bins:95 {fine:.3}", beer_error(&scene, 8, 1.0));
        assert_eq!(choose_auto(&scene, IntegratorKind::Path), SpectralMode::Hero { count: 8 });
    }

    /// A smooth spectral absorber needs more bins than the same scene without absorption (the
    /// RGB-upsampled attenuation colour of `scenes/gltf/glass_torus.gltf` went from bins:8 to
    /// bins:24); a flat one changes nothing.
    #[test]
    fn smooth_absorbers_add_bins_and_flat_ones_cost_nothing() {
        let clear = auto_bins(&slab("0")).unwrap();
        assert_eq!(auto_bins(&slab("0.7")), Some(clear), "a flat σ_a is a scale");
        let green = slab("{\"rgb\": [0.75, 0.1, 0.6]}");
        let n = auto_bins(&green).unwrap();
        assert!(n > clear, "bins:{n} vs bins:{clear} without absorption");
        for d in [0.5, 1.0, 4.0, 2.0 * (6f64 * 6.0 * 2.0 + 1.0).sqrt()] {
            assert!(beer_error(&green, n, d) < AUTO_MAX_DELTA_E, "d = {d}: {}", beer_error(&green, n, d));
        }
        // What the old rule chose is visibly off somewhere in the slab's range of lengths.
        assert!(beer_error(&green, clear, 4.0) > AUTO_MAX_DELTA_E, "{}", beer_error(&green, clear, 4.0));
    }

    /// An absorber used only by placed instances (a mesh placed several times) is checked as its
    /// world-space copies are: same bins. Before, instanced meshes had no extent, so the absorber
    /// was skipped and the scene got the bins of clear glass.
    #[test]
    fn absorbers_on_instances_are_checked_as_copies_are() {
        let green = "{\"rgb\": [0.75, 0.1, 0.6]}";
        let desc = || slab_desc(green);
        let placements = [glam::Mat4::IDENTITY, glam::Mat4::from_translation(Vec3::new(8.0, 0.0, 0.0))];
        let mut copies = desc();
        let glass: Vec<geometry::Mesh> = copies.meshes.drain(..2).collect();
        for m in placements {
            copies.meshes.extend(glass.iter().map(|g| g.transformed(m)));
        }
        let mut placed = desc();
        let glass: Vec<geometry::Mesh> = placed.meshes.drain(..2).collect();
        placed.instances.push(geometry::Instances::new(glass, placements.to_vec()).unwrap());
        let (copies, placed) =
            (RenderScene::from_description(copies).unwrap(), RenderScene::from_description(placed).unwrap());
        assert_eq!(placed.geometry.instance_count(), 2);
        let clear = auto_bins(&slab("0")).unwrap();
        let n = auto_bins(&copies).unwrap();
        assert!(n > clear, "bins:{n} vs bins:{clear}");
        assert_eq!(auto_bins(&placed), Some(n));
    }

    #[test]
    fn depths_halve_from_the_longest_path_to_the_clear_one() {
        let d = beer_depths(8.0, 1.0);
        assert_eq!(d[0], 8.0);
        let last = *d.last().unwrap();
        assert!((last - 0.05).abs() < 1e-12, "{last}");
        // 8 / 0.05 = 160 → ⌈log2 160⌉ = 8 halvings, 9 lengths, each step ≤ 2×.
        assert_eq!(d.len(), 9);
        assert!(d.windows(2).all(|w| w[0] / w[1] <= 2.0 + 1e-12 && w[0] > w[1]));
        // A perfect absorber band (σ_a = 1e30) cannot ask for 100+ halvings.
        assert_eq!(beer_depths(8.0, 1e30).len(), MAX_DEPTHS);
        // Already clear at the longest path: that one length; degenerate inputs: none.
        assert_eq!(beer_depths(0.01, 1.0), vec![0.01]);
        assert!(beer_depths(0.0, 1.0).is_empty() && beer_depths(1.0, 0.0).is_empty());
        assert!(beer_depths(f64::INFINITY, 1.0).is_empty());
    }
}
