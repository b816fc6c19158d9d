//! CIE 171:2006 ("Test cases to assess the accuracy of lighting computer programs"), the analytic cases
//! as spectrace's own scenes (`scenes/cie171/`), measured with `integrator::measure` (the engine of
//! `spectrace measure`) against their exact values:
//!
//! - 5.2: a point source of Lambertian distribution I(γ) = 1000 cd · cos γ (`scenes/luminaires/
//!   lambert_1000cd.ies`, the project's own file) 3 m above a plane: at the ten points A–J the illuminance
//!   is I₀ h²/d⁴ (A 111.11 … J 49.38 lx).
//! - 5.4: an isotropic 10 000 lm point source at the centre of a black 4 × 4 × 3 m room. Every point's
//!   illuminance is I cos θ / d² exactly, and the flux over the six surfaces (8 × 8 Gauss–Legendre nodes
//!   on each; the rule's own error on this integrand is 3e-5) is Φ.
//! - 5.8: a closed 4 m cube of reflectance ρ (0.5 and 0.9) with the source at its centre: the surfaces
//!   receive Φ/(1 − ρ) in all, so the mean illuminance is Φ/(S(1 − ρ)) (S = 96 m²: 208.3 and 1041.7 lx)
//!   and its indirect part ρΦ/(S(1 − ρ)) (104.2 and 937.5 lx; CIE's table rounds them to 104 and 937).
//!   Measured on the floor's 8 × 8 Gauss–Legendre nodes (the faces are alike by symmetry); the indirect
//!   part is each point's illuminance less the analytic direct I h / d³.
//!
//! Every point samples to a relative standard error of 0.25 % (so a point's 1 % is four standard errors);
//! the report gives the samples and the time each case took. `--quick` (inside `cargo test`): 5.4 and
//! 5.8 at ρ = 0.5 on 4 × 4 nodes at 1 % (the 4-point rule's own error on the direct light is 0.4–0.9 %).

use geometry::{LoadOptions, Override, Variation};
use integrator::{MeasureOptions, Measurement, SensorPoint};

use super::*;

/// Φ of both cases (lm).
const PHI: f64 = 10_000.0;

/// `n`-point Gauss–Legendre nodes and weights on [−1, 1] (the two rules the cases use, from Abramowitz &
/// Stegun table 25.4).
fn gauss_legendre(n: usize) -> Vec<(f64, f64)> {
    let half: &[(f64, f64)] = match n {
        4 => &[(0.339_981_043_584_856, 0.652_145_154_862_546), (0.861_136_311_594_053, 0.347_854_845_137_454)],
        8 => &[
            (0.183_434_642_495_650, 0.362_683_783_378_362),
            (0.525_532_409_916_329, 0.313_706_645_877_887),
            (0.796_666_477_413_627, 0.222_381_034_453_374),
            (0.960_289_856_497_536, 0.101_228_536_290_376),
        ],
        _ => unreachable!("rules of 4 and 8 points only"),
    };
    let mut rule: Vec<(f64, f64)> = half.iter().flat_map(|&(x, w)| [(-x, w), (x, w)]).collect();
    rule.sort_by(|a, b| a.0.total_cmp(&b.0));
    rule
}

/// A face: its centre, two half-edge vectors and its inward normal.
struct Face {
    centre: [f64; 3],
    u: [f64; 3],
    v: [f64; 3],
    normal: [f64; 3],
}

impl Face {
    fn area(&self) -> f64 {
        let (u, v) = (self.u, self.v);
        4.0 * ((u[0] * u[0] + u[1] * u[1] + u[2] * u[2]) * (v[0] * v[0] + v[1] * v[1] + v[2] * v[2])).sqrt()
    }

    /// The face's product-rule nodes: (sensor, weight summing to 1 over the face).
    fn nodes(&self, n: usize, name: &str) -> Vec<(SensorPoint, f64)> {
        let rule = gauss_legendre(n);
        let mut out = Vec::new();
        for (i, &(a, wa)) in rule.iter().enumerate() {
            for (j, &(b, wb)) in rule.iter().enumerate() {
                let p = [0, 1, 2].map(|k| (self.centre[k] + a * self.u[k] + b * self.v[k]) as f32);
                out.push((
                    SensorPoint {
                        name: format!("{name} {i},{j}"),
                        position: glam::Vec3::from_array(p),
                        normal: glam::Vec3::from_array(self.normal.map(|x| x as f32)),
                    },
                    wa * wb / 4.0,
                ));
            }
        }
        out
    }
}

/// The analytic direct illuminance at `p` facing `n` from an isotropic source of intensity `i` at `s`.
fn direct(i: f64, s: [f64; 3], p: glam::Vec3, n: glam::Vec3) -> f64 {
    let d = [f64::from(p.x) - s[0], f64::from(p.y) - s[1], f64::from(p.z) - s[2]];
    let d2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
    let n = n.normalize();
    let cos = -(d[0] * f64::from(n.x) + d[1] * f64::from(n.y) + d[2] * f64::from(n.z)) / d2.sqrt();
    i * cos.max(0.0) / d2
}

/// Measure `points` in a scene under `scenes/` (with `set` applied): results, samples and seconds.
fn run_case(
    root: &Path,
    file: &str,
    set: &[(&str, serde_json::Value)],
    points: &[SensorPoint],
    relative_error: f64,
    spectral: SpectralMode,
) -> anyhow::Result<(Vec<Measurement>, u64, f64)> {
    let overrides = set
        .iter()
        .map(|(p, v)| Override::new(p, v.clone()).map_err(anyhow::Error::msg))
        .collect::<anyhow::Result<_>>()?;
    let options = LoadOptions { variation: Variation { frame: None, overrides }, ..LoadOptions::default() };
    let desc = geometry::load_scene_with(&root.join("scenes").join(file), &options)?;
    let scene = integrator::RenderScene::from_description(desc)?;
    let options = MeasureOptions { target_relative_error: relative_error, seed: 171, spectral, ..Default::default() };
    let start = Instant::now();
    let m = integrator::measure(&scene, points, &options, &|_| {}, &AtomicBool::new(false))?;
    let samples = m.iter().map(|m| m.samples).sum();
    Ok((m, samples, start.elapsed().as_secs_f64()))
}

pub(super) fn checks(report: &mut Report, root: &Path, quick: bool) -> anyhow::Result<()> {
    let mut section = String::from("## CIE 171:2006 analytic cases\n\n");
    section += "| case | quantity | measured | analytic | error | points | samples | s |\n| --- | --- | --- | --- | --- | --- | --- | --- |\n";
    let intensity = PHI / (4.0 * std::f64::consts::PI);
    let n = if quick { 4 } else { 8 };
    let target = if quick { 0.01 } else { 0.0025 };

    // 5.2: the Lambertian luminaire over a plane, the ten points of the case (x, z in metres from the
    // point below the source; the scene is y-up).
    let abc = [
        ("A", 0.0, 0.0),
        ("B", 0.5, 0.0),
        ("C", 1.0, 0.0),
        ("D", 1.5, 0.0),
        ("E", 0.5, 0.5),
        ("F", 1.0, 0.5),
        ("G", 1.5, 0.5),
        ("H", 1.0, 1.0),
        ("I", 1.5, 1.0),
        ("J", 1.5, 1.5),
    ];
    let points: Vec<SensorPoint> = abc
        .iter()
        .map(|&(name, x, z)| SensorPoint {
            name: name.into(),
            position: glam::Vec3::new(x as f32, 0.0, z as f32),
            normal: glam::Vec3::Y,
        })
        .collect();
    let (m, samples, seconds) =
        run_case(root, "luminaires/cie171_5_2.json", &[], &points, target, SpectralMode::Bins(16))?;
    let mut worst = (0.0f64, "");
    for (m, &(name, x, z)) in m.iter().zip(&abc) {
        let (h, d2) = (3.0f64, 9.0 + x * x + z * z);
        let want = 1000.0 * h * h / (d2 * d2);
        let error = m.illuminance / want - 1.0;
        if error.abs() > worst.0.abs() {
            worst = (error, name);
        }
        section += &format!(
            "| 5.2 Lambertian luminaire | point {name} (lx) | {:.3} | {want:.3} | {:+.3} % | 1 | {} | |\n",
            m.illuminance,
            error * 100.0,
            m.samples
        );
    }
    section += &format!("| 5.2 Lambertian luminaire | all ten points | | | | 10 | {samples} | {seconds:.1} |\n");
    report.check(
        "CIE 171",
        "5.2 Lambertian luminaire (own IES file): ten points against I₀ h²/d⁴",
        format!("worst {:+.3} % (point {})", worst.0 * 100.0, worst.1),
        "< 1 %".into(),
        "analytic",
        worst.0.abs() < 0.01,
    );

    // 5.4: the black room, all six surfaces.
    let room = [
        Face { centre: [0.0, 0.0, 0.0], u: [2.0, 0.0, 0.0], v: [0.0, 2.0, 0.0], normal: [0.0, 0.0, 1.0] },
        Face { centre: [0.0, 0.0, 3.0], u: [2.0, 0.0, 0.0], v: [0.0, 2.0, 0.0], normal: [0.0, 0.0, -1.0] },
        Face { centre: [-2.0, 0.0, 1.5], u: [0.0, 2.0, 0.0], v: [0.0, 0.0, 1.5], normal: [1.0, 0.0, 0.0] },
        Face { centre: [2.0, 0.0, 1.5], u: [0.0, 2.0, 0.0], v: [0.0, 0.0, 1.5], normal: [-1.0, 0.0, 0.0] },
        Face { centre: [0.0, -2.0, 1.5], u: [2.0, 0.0, 0.0], v: [0.0, 0.0, 1.5], normal: [0.0, 1.0, 0.0] },
        Face { centre: [0.0, 2.0, 1.5], u: [2.0, 0.0, 0.0], v: [0.0, 0.0, 1.5], normal: [0.0, -1.0, 0.0] },
    ];
    let nodes: Vec<(SensorPoint, f64, f64)> = room
        .iter()
        .enumerate()
        .flat_map(|(k, f)| f.nodes(n, &format!("face {k}")).into_iter().map(move |(p, w)| (p, w, f.area())))
        .collect();
    let points: Vec<SensorPoint> = nodes.iter().map(|(p, ..)| p.clone()).collect();
    // Fixed lanes: a delta light's every sample is then exact (hero wavelengths would add colour noise).
    let (m, samples, seconds) = run_case(root, "cie171/black_room.json", &[], &points, target, SpectralMode::Bins(16))?;
    let source = [0.0, 0.0, 1.5];
    let worst = m
        .iter()
        .zip(&nodes)
        .map(|(m, (p, ..))| (m.illuminance / direct(intensity, source, p.position, p.normal) - 1.0).abs())
        .fold(0.0f64, f64::max);
    let flux: f64 = m.iter().zip(&nodes).map(|(m, (_, w, area))| m.illuminance * w * area).sum();
    section += &format!(
        "| 5.4 black room | worst point against I cos θ / d² | {:.4} % | 0 | | {} | {samples} | {seconds:.1} |\n",
        worst * 100.0,
        points.len()
    );
    section += &format!(
        "| 5.4 black room | flux over the surfaces (lm) | {flux:.1} | {PHI:.0} | {:+.3} % | {} | | |\n",
        (flux / PHI - 1.0) * 100.0,
        points.len()
    );
    report.check(
        "CIE 171",
        "5.4 black room: every point's illuminance against I cos θ / d²",
        format!("worst {:.4} %", worst * 100.0),
        "< 1 %".into(),
        "analytic",
        worst < 0.01,
    );
    // The rule's own error on the room's flux is 3e-5 at 8 × 8 nodes, 0.9 % at 4 × 4.
    let rule_error = if quick { 0.02 } else { 0.01 };
    report.check(
        "CIE 171",
        "5.4 black room: flux over the six surfaces is Φ",
        format!("{flux:.1} lm ({:+.3} %)", (flux / PHI - 1.0) * 100.0),
        format!("< {} %", rule_error * 100.0),
        "analytic",
        (flux / PHI - 1.0).abs() < rule_error,
    );

    // 5.8: the grey cube, the floor (all faces alike).
    let floor = Face { centre: [0.0, 0.0, -2.0], u: [2.0, 0.0, 0.0], v: [0.0, 2.0, 0.0], normal: [0.0, 0.0, 1.0] };
    let nodes = floor.nodes(n, "floor");
    let points: Vec<SensorPoint> = nodes.iter().map(|(p, _)| p.clone()).collect();
    let rhos: &[f64] = if quick { &[0.5] } else { &[0.5, 0.9] };
    for &rho in rhos {
        let set = [("materials.wall.base_color", serde_json::json!(rho))];
        let (m, samples, seconds) =
            run_case(root, "cie171/grey_cube.json", &set, &points, target, SpectralMode::Hero { count: 8 })?;
        let mean: f64 = m.iter().zip(&nodes).map(|(m, (_, w))| m.illuminance * w).sum();
        let indirect: f64 = m
            .iter()
            .zip(&nodes)
            .map(|(m, (p, w))| (m.illuminance - direct(intensity, [0.0; 3], p.position, p.normal)) * w)
            .sum();
        let worst_se = m.iter().map(|m| m.std_error / m.illuminance).fold(0.0f64, f64::max);
        let (want_mean, want_indirect) = (PHI / (96.0 * (1.0 - rho)), rho * PHI / (96.0 * (1.0 - rho)));
        for (what, got, want) in
            [("mean illuminance", mean, want_mean), ("indirect illuminance", indirect, want_indirect)]
        {
            section += &format!(
                "| 5.8 grey cube ρ {rho} | {what} (lx) | {got:.2} | {want:.2} | {:+.3} % | {} | {samples} | {seconds:.1} |\n",
                (got / want - 1.0) * 100.0,
                points.len()
            );
            report.check(
                "CIE 171",
                format!(
                    "5.8 grey cube ρ {rho}: {what} Φ/(S(1 − ρ)){}",
                    if what.starts_with("indirect") { " · ρ" } else { "" }
                ),
                format!(
                    "{got:.2} lx ({:+.3} %; worst point's standard error {:.2} %)",
                    (got / want - 1.0) * 100.0,
                    worst_se * 100.0
                ),
                "< 1 %".into(),
                "analytic",
                (got / want - 1.0).abs() < 0.01,
            );
        }
    }
    section += "\nEach point sampled to a relative standard error of ";
    section += &format!(
        "{} % (independent random numbers, seed 171); `spectrace measure` runs the same engine.\n\n",
        target * 100.0
    );
    report.sections += &section;
    Ok(())
}
