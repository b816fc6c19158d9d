//! The white furnace of every BSDF model of the materials crate, as a markdown table: each model's
//! directional albedo ∫ f |cos θ_i| dω_i over the sphere (refraction's radiance scaling undone: it moves
//! radiance between media and creates no energy), seen from 0°, 45° and 75°, at α = roughness² ∈ {0.05,
//! 0.2, 0.5, 1}, with the energy compensation (`Material::multiple_scattering`) off and on.
//!
//! ```text
//! cargo run --release -p materials --example furnace_table
//! ```
//!
//! Each value is the mean of `Bsdf::sample_f`'s weights (f |cos| / pdf, the path tracer's throughput
//! factor) over `SAMPLES` draws, averaged over the four lanes; the largest standard error is printed under
//! the table. A model is one line of [`MODELS`].

use colorimetry::{SampledSpectrum, SampledWavelengths};
use glam::Vec3;
use materials::Coat;
use materials::bsdf::{
    Bsdf, ConductorBxdf, Frame, GltfMetalRoughBxdf, Metal, PlasticBxdf, RoughDielectricBxdf, ThinDielectricBxdf,
    TrowbridgeReitz, plastic_table,
};

/// Lanes: four wavelengths across the visible (nm); they matter only for the measured metal.
const LAMBDA: [f32; 4] = [450.0, 510.0, 570.0, 630.0];
const ALPHAS: [f32; 4] = [0.05, 0.2, 0.5, 1.0];
const ANGLES: [f32; 3] = [0.0, 45.0, 75.0];
/// Draws per value: the standard error of a furnace estimate is then below 0.002 (printed).
const SAMPLES: usize = 200_000;

const WHITE: SampledSpectrum<4> = SampledSpectrum([1.0; 4]);

/// What a model is at one hit: one BSDF, or `KHR_materials_clearcoat`'s mixture, which the path tracer
/// samples by picking the coat lobe with [`Coat::probability`] and the base otherwise.
enum Model {
    Bsdf(Bsdf<4>),
    Coated { coat: Coat, lobe: Bsdf<4>, base: Bsdf<4> },
}

/// A row of the table: its name, whether roughness and compensation apply (otherwise one line with α
/// "–"), and the model at (α, compensation on).
struct Row {
    name: &'static str,
    rough: bool,
    model: fn(f32, bool) -> Model,
}

/// The glTF metallic–roughness model at α (roughness √α), compensated or as the path tracer builds it
/// with `multiple_scattering` off.
fn gltf(base: f32, metallic: f32, alpha: f32, compensate: bool) -> GltfMetalRoughBxdf<4> {
    let g = GltfMetalRoughBxdf::new(SampledSpectrum([base; 4]), metallic, alpha.sqrt(), 1.5);
    if compensate { g.compensated() } else { g.conserving() }
}

const MODELS: &[Row] = &[
    Row { name: "Lambertian white", rough: false, model: |_, _| Model::Bsdf(Bsdf::Lambertian { r: WHITE }) },
    Row {
        name: "conductor Au",
        rough: true,
        model: |a, c| {
            let lambda = SampledWavelengths::from_parts(LAMBDA, [1.0; 4]);
            Model::Bsdf(Bsdf::Conductor(ConductorBxdf::metal(Metal::Au, &lambda, TrowbridgeReitz::isotropic(a), c)))
        },
    },
    Row {
        name: "conductor white",
        rough: true,
        model: |a, c| {
            Model::Bsdf(Bsdf::Conductor(ConductorBxdf::from_reflectance(WHITE, TrowbridgeReitz::isotropic(a), c)))
        },
    },
    Row {
        name: "rough dielectric 1.5 (from outside)",
        rough: true,
        model: |a, c| {
            Model::Bsdf(Bsdf::RoughDielectric(RoughDielectricBxdf::new(TrowbridgeReitz::isotropic(a), 1.5, WHITE, c)))
        },
    },
    Row {
        name: "thin dielectric 1.5",
        rough: false,
        model: |_, _| Model::Bsdf(Bsdf::ThinDielectric(ThinDielectricBxdf::new(1.5, WHITE))),
    },
    Row {
        name: "glTF metal, base 0.8",
        rough: true,
        model: |a, c| Model::Bsdf(Bsdf::GltfMetalRough(gltf(0.8, 1.0, a, c))),
    },
    Row {
        name: "glTF dielectric, white (metallic 0)",
        rough: true,
        model: |a, c| Model::Bsdf(Bsdf::GltfMetalRough(gltf(1.0, 0.0, a, c))),
    },
    Row {
        name: "glTF dielectric, base 0.5 (metallic 0)",
        rough: true,
        model: |a, c| Model::Bsdf(Bsdf::GltfMetalRough(gltf(0.5, 0.0, a, c))),
    },
    Row {
        name: "glTF metallic 0.5, white",
        rough: true,
        model: |a, c| Model::Bsdf(Bsdf::GltfMetalRough(gltf(1.0, 0.5, a, c))),
    },
    Row {
        name: "glTF default material (white, metallic 1; α 1 is the default)",
        rough: true,
        model: |a, c| Model::Bsdf(Bsdf::GltfMetalRough(gltf(1.0, 1.0, a, c))),
    },
    Row {
        name: "glTF white dielectric under a full clear coat of the same α",
        rough: true,
        model: |a, c| {
            let coat = Coat { weight: 1.0, roughness: a.sqrt() };
            let lobe = GltfMetalRoughBxdf::clearcoat(coat.roughness);
            let lobe = if c { lobe.compensated() } else { lobe };
            Model::Coated { coat, lobe: Bsdf::GltfMetalRough(lobe), base: Bsdf::GltfMetalRough(gltf(1.0, 0.0, a, c)) }
        },
    },
    Row { name: "plastic, white base, index 1.5", rough: true, model: |a, c| Model::Bsdf(plastic(1.0, a, c)) },
    Row { name: "plastic, base 0.5, index 1.5", rough: true, model: |a, c| Model::Bsdf(plastic(0.5, a, c)) },
];

/// The plastic model at α with index 1.5 over a grey base, compensated or as Mitsuba 3's `roughplastic`.
fn plastic(base: f32, alpha: f32, compensate: bool) -> Bsdf<4> {
    let table = plastic_table(alpha, 1.5, compensate);
    Bsdf::Plastic(PlasticBxdf::new(SampledSpectrum([base; 4]), TrowbridgeReitz::isotropic(alpha), 1.5, false, table))
}

/// SplitMix64 (Steele, Lea & Flood 2014): uniform numbers in [0, 1), deterministic per seed.
struct Rng(u64);

impl Rng {
    fn uniform(&mut self) -> f32 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        ((z ^ (z >> 31)) >> 40) as f32 * (1.0 / 16_777_216.0)
    }
}

/// Mean and standard error of one BSDF's albedo from `wo` (lane average).
fn albedo(bsdf: &Bsdf<4>, wo: Vec3, rng: &mut Rng) -> (f64, f64) {
    let frame = Frame { n: Vec3::Z, ns: Vec3::Z };
    let (mut sum, mut sum2) = (0.0f64, 0.0f64);
    for _ in 0..SAMPLES {
        let (uc, u) = (rng.uniform(), glam::Vec2::new(rng.uniform(), rng.uniform()));
        let x = bsdf.sample_f(&frame, wo, uc, u).map_or(0.0, |s| f64::from(s.weight.average() * s.eta_scale));
        sum += x;
        sum2 += x * x;
    }
    let n = SAMPLES as f64;
    let mean = sum / n;
    (mean, ((sum2 / n - mean * mean).max(0.0) / n).sqrt())
}

/// A model's albedo from θ degrees: a coat's mixture weighs its two parts' albedos by the coat's
/// probability, exactly as the path tracer's pick does in expectation.
fn model_albedo(model: &Model, theta: f32, rng: &mut Rng) -> (f64, f64) {
    let t = theta.to_radians();
    let wo = Vec3::new(t.sin(), 0.0, t.cos());
    match model {
        Model::Bsdf(b) => albedo(b, wo, rng),
        Model::Coated { coat, lobe, base } => {
            let p = f64::from(coat.probability(wo.z));
            let ((a, sa), (b, sb)) = (albedo(lobe, wo, rng), albedo(base, wo, rng));
            (p * a + (1.0 - p) * b, (p * p * sa * sa + (1.0 - p) * (1.0 - p) * sb * sb).sqrt())
        }
    }
}

fn main() {
    let mut rng = Rng(1);
    let mut worst_se = 0.0f64;
    let mut cell = |model: &Model, theta: f32| {
        let (e, se) = model_albedo(model, theta, &mut rng);
        worst_se = worst_se.max(se);
        format!("{e:.3}")
    };
    let mut header = String::from("| model | α |");
    let mut rule = String::from("| --- | --- |");
    for t in ANGLES {
        header += &format!(" {t}° off | {t}° on |");
        rule += " --- | --- |";
    }
    println!("{header}\n{rule}");
    for row in MODELS {
        let alphas: &[f32] = if row.rough { &ALPHAS } else { &[1.0] };
        for &a in alphas {
            let (off, on) = ((row.model)(a, false), (row.model)(a, true));
            let alpha = if row.rough { a.to_string() } else { "–".into() };
            let mut line = format!("| {} | {alpha} |", row.name);
            for t in ANGLES {
                let e_off = cell(&off, t);
                let e_on = if row.rough { cell(&on, t) } else { e_off.clone() };
                line += &format!(" {e_off} | {e_on} |");
            }
            println!("{line}");
        }
    }
    println!("\n{SAMPLES} samples a value, largest standard error {worst_se:.4}.");
}
