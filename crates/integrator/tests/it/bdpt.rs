//! Bidirectional path tracing against the path tracer where both converge, and against analytic answers
//! where only light tracing finds the light (a point light through a thin glass pane).
//!
//! Tolerances are z-tests on pixel means, as in `path.rs`: every pixel is an independent estimate, so the
//! mean over P pixels has standard error s/√P with s the spread between pixels.

use geometry::Camera;
use glam::Vec3;
use integrator::{Image, Integrator, PathOptions, RenderOptions, SamplerKind, SpectralMode};

use crate::{assert_all_finite, reference, render_with, scene};

pub(crate) fn options(integrator: Integrator, w: u32, h: u32, spp: u32, seed: u64, threads: usize) -> RenderOptions {
    RenderOptions {
        width: w,
        height: h,
        integrator,
        spectral: SpectralMode::Bins(16),
        spp,
        seed,
        threads: Some(threads),
        ..RenderOptions::default()
    }
}

fn bdpt() -> Integrator {
    Integrator::Bdpt(PathOptions { sampler: SamplerKind::Independent, ..PathOptions::default() })
}

fn path() -> Integrator {
    Integrator::Path(PathOptions { sampler: SamplerKind::Independent, ..PathOptions::default() })
}

/// Mean Y over `pixels` of an image and its standard error.
pub(crate) fn mean_y(image: &Image, pixels: impl Iterator<Item = usize>) -> (f64, f64) {
    let v: Vec<f64> = pixels.map(|i| f64::from(image.pixels()[i][1])).collect();
    let n = v.len() as f64;
    let mean = v.iter().sum::<f64>() / n;
    let var = v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0);
    (mean, (var / n).sqrt())
}

/// The mean over `pixels` of `a` − `b` in Y, and its standard error from the pixels' spread of that
/// difference (the images' structure cancels; what is left is the noise of both).
fn mean_difference(a: &Image, b: &Image, pixels: impl Iterator<Item = usize>) -> (f64, f64) {
    let v: Vec<f64> = pixels.map(|i| f64::from(a.pixels()[i][1]) - f64::from(b.pixels()[i][1])).collect();
    let n = v.len() as f64;
    let mean = v.iter().sum::<f64>() / n;
    let var = v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0);
    (mean, (var / n).sqrt())
}

/// Without caustics from delta lights both estimators converge to the same image: the Cornell box (an
/// area light, a diffuse and a glass sphere) has the same mean luminance, within 5 standard errors.
#[test]
fn bdpt_agrees_with_the_path_tracer_on_the_cornell_box() {
    let scene = reference("cornell_box.json");
    let (w, h) = (24, 24);
    let (b, stats) = render_with(&scene, &options(bdpt(), w, h, 48, 1, 2));
    assert_all_finite(&b, &stats);
    let (p, _) = render_with(&scene, &options(path(), w, h, 192, 2, 2));
    let all = || 0..(w * h) as usize;
    let ((mb, sb), (mp, sp)) = (mean_y(&b, all()), mean_y(&p, all()));
    let z = (mb - mp) / (sb * sb + sp * sp).sqrt();
    assert!(z.abs() < 5.0, "bdpt {mb:.5} ± {sb:.5}, path {mp:.5} ± {sp:.5}: z = {z:.2}");
    assert!((mb / mp - 1.0).abs() < 0.02, "bdpt / path = {:.4}", mb / mp);
}

/// A mirror (reflectance 0.9, 0.8 wide) above a point light lights a white floor a second time, from the light's
/// mirror image: that light reaches the floor by a delta reflection from a delta light, which no camera
/// path can find. Light tracing does: where the image's ray to the floor crosses the mirror the floor must
/// show L = ρ/π · (I cos θ₁ / d₁² + 0.9 I cos θ₂ / d₂²), elsewhere ρ/π · I cos θ₁ / d₁² (which both
/// estimators find). The path tracer misses the mirror's share: that is the caustic it cannot render.
#[test]
fn light_tracing_finds_a_point_light_in_a_mirror() {
    let intensity = 20.0f32;
    let light = Vec3::new(0.0, 3.0, 0.0);
    let image = Vec3::new(0.0, 5.0, 0.0);
    let json = format!(
        r#"{{
        "camera": {{"position": [0, 2.5, 6], "look_at": [0, 0, 0], "up": [0, 1, 0], "vfov_deg": 40}},
        "lights": [{{"type": "point", "position": [{}, {}, {}], "spectrum": "D65", "intensity": {intensity}}}],
        "materials": {{
            "floor": {{"model": "diffuse", "base_color": 0.8}},
            "mirror": {{"model": "mirror", "base_color": 0, "specular": 0.9, "ks": 1}}
        }},
        "objects": [
            {{"type": "quad", "corner": [-4, 0, -4], "edge_u": [0, 0, 8], "edge_v": [8, 0, 0], "material": "floor"}},
            {{"type": "quad", "corner": [-0.4, 4, -0.4], "edge_u": [0.8, 0, 0], "edge_v": [0, 0, 0.8], "material": "mirror"}}
        ],
        "settings": {{"max_depth": 8}}
    }}"#,
        light.x, light.y, light.z
    );
    let scene = scene(&json);
    let (w, h) = (48, 36);
    let (b, stats) = render_with(&scene, &options(bdpt(), w, h, 64, 3, 2));
    assert_all_finite(&b, &stats);
    let (p, _) = render_with(&scene, &options(path(), w, h, 64, 4, 2));
    let camera = Camera::look_at(Vec3::new(0.0, 2.5, 6.0), Vec3::ZERO, Vec3::Y, 40.0, w as f32 / h as f32).unwrap();
    // Each pixel's floor point (its centre's ray), sorted into lit by the mirror and clear of it (a margin
    // of 0.05 from the edge of the mirror's light, so pixels straddling it are left out).
    let (mut lit, mut clear) = (Vec::new(), Vec::new());
    let mut direct = vec![0.0f64; (w * h) as usize];
    let mut mirrored = vec![0.0f64; (w * h) as usize];
    let irradiance = |from: Vec3, q: Vec3| {
        let d = from - q;
        0.8 / std::f64::consts::PI * f64::from(intensity * (d.y / d.length()) / d.length_squared())
    };
    for y in 0..h {
        for x in 0..w {
            let r = camera.generate_ray(x as f32 + 0.5, y as f32 + 0.5, w, h);
            if r.dir.y >= 0.0 {
                continue;
            }
            let q = r.origin + r.dir * (-r.origin.y / r.dir.y);
            if q.x.abs() > 3.5 || q.z.abs() > 3.5 {
                continue;
            }
            let i = (y * w + x) as usize;
            direct[i] = irradiance(light, q);
            // Where the ray from the light's image to q crosses the mirror's plane (y = 4).
            let s = image + (q - image) * (1.0 / (image.y - q.y));
            if s.x.abs() < 0.35 && s.z.abs() < 0.35 {
                mirrored[i] = 0.9 * irradiance(image, q);
                lit.push(i);
            } else if s.x.abs() > 0.45 || s.z.abs() > 0.45 {
                clear.push(i);
            }
        }
    }
    assert!(lit.len() > 40 && clear.len() > 200, "{} lit by the mirror, {} clear", lit.len(), clear.len());
    let check = |what: &str, image: &Image, pixels: &[usize], with_mirror: bool| {
        let (got, se) = mean_y(image, pixels.iter().copied());
        let want = pixels.iter().map(|&i| direct[i] + if with_mirror { mirrored[i] } else { 0.0 }).sum::<f64>()
            / pixels.len() as f64;
        assert!(
            (got - want).abs() < 5.0 * se + 0.01 * want,
            "{what}: {got:.5} ± {se:.5}, analytic {want:.5} (ratio {:.4})",
            got / want
        );
    };
    check("bdpt, lit by the mirror", &b, &lit, true);
    check("bdpt, clear of it", &b, &clear, false);
    check("path, clear of it", &p, &clear, false);
    // The path tracer finds only the direct light where the mirror lights the floor too.
    check("path, lit by the mirror (direct light only)", &p, &lit, false);
}

/// Light tracing's splats are added to the film exactly: the image is the same bits at any thread count.
#[test]
fn bdpt_images_do_not_depend_on_the_thread_count() {
    let scene = reference("cornell_box.json");
    let (one, _) = render_with(&scene, &options(bdpt(), 12, 12, 4, 9, 1));
    let (two, _) = render_with(&scene, &options(bdpt(), 12, 12, 4, 9, 2));
    assert_eq!(one.pixels(), two.pixels());
}

/// A spectrum from a prism (`scenes/caustics/prism_beam.json`): a narrow beam from a spot light through a
/// dense-flint prism throws a band on a white wall, which only light tracing can find (a delta light
/// through two delta refractions). Each wavelength must land where Snell's law sends it: the beam traced
/// through the prism's cross-section with n(λ) meets the wall at a point the camera sees at a pixel, and
/// the band's centroid in that wavelength's channel of the spectral film must be within half a pixel of
/// it, for three wavelengths, red least deviated (highest on the wall) and violet most.
#[test]
fn a_prism_throws_each_wavelength_where_snells_law_sends_it() {
    use glam::DVec2;

    let file = crate::path::reference_path("../caustics/prism_beam.json");
    let m: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&file).unwrap()).unwrap();
    let scene = integrator::RenderScene::load(&file).expect("prism_beam.json loads");
    let (w, h) = (80u32, 60u32);
    let options =
        RenderOptions { spectral: SpectralMode::Bins(48), spectral_film: true, ..options(bdpt(), w, h, 24, 5, 2) };
    let (image, stats) = render_with(&scene, &options);
    assert_all_finite(&image, &stats);
    let (wavelengths, values) = image.spectral().expect("a spectral film");
    let lanes = wavelengths.len();
    let v3 = |v: &serde_json::Value| {
        Vec3::new(v[0].as_f64().unwrap() as f32, v[1].as_f64().unwrap() as f32, v[2].as_f64().unwrap() as f32)
    };
    let cam = &m["camera"];
    let camera = Camera::look_at(
        v3(&cam["position"]),
        v3(&cam["look_at"]),
        v3(&cam["up"]),
        cam["vfov_deg"].as_f64().unwrap() as f32,
        w as f32 / h as f32,
    )
    .unwrap();
    let spot = &m["lights"][0];
    let (origin, direction) = (v3(&spot["position"]), v3(&spot["direction"]).normalize());
    let abbe = &m["materials"]["flint"]["ior"]["abbe"];
    let ior =
        materials::Ior::from_abbe(abbe["nd"].as_f64().unwrap() as f32, abbe["vd"].as_f64().unwrap() as f32).unwrap();
    // The prism's cross-section (prism.obj), counter-clockwise: an edge's outward normal is on its right.
    let (p0, p1, p2) = (DVec2::new(-1.0, -1.0), DVec2::new(1.0, -1.0), DVec2::new(0.0, 0.732051));
    let normal = |a: DVec2, b: DVec2| -(b - a).perp().normalize();
    let wall_x = 5.0;
    let mut rows = Vec::new();
    for target in [450.0f32, 550.0, 650.0] {
        let lane = (0..lanes)
            .min_by(|&a, &b| (wavelengths[a] - target).abs().total_cmp(&(wavelengths[b] - target).abs()))
            .unwrap();
        let n = f64::from(ior.eval(wavelengths[lane]));
        // The beam's axis through the left face (p2 → p0), then out of the right face (p1 → p2).
        let o = DVec2::new(f64::from(origin.x), f64::from(origin.y));
        let d = DVec2::new(f64::from(direction.x), f64::from(direction.y));
        let (t, _) = crate::prism::cross_line(o, d, p2, p0);
        let entry = o + d * t;
        let inside = crate::prism::refract(d, normal(p2, p0), n).expect("enters");
        let (t2, f2) = crate::prism::cross_line(entry, inside, p1, p2);
        assert!((0.0..=1.0).contains(&f2), "the beam leaves through the right face");
        let exit = entry + inside * t2;
        let out = crate::prism::refract(inside, normal(p1, p2), n).expect("no total internal reflection");
        let on_wall = exit + out * ((wall_x - exit.x) / out.x);
        let (ex, ey, _) =
            camera.raster_of(Vec3::new(wall_x as f32, on_wall.y as f32, 0.0), w, h).expect("the camera sees it");
        // The channel's centroid (pixel centres at x + 0.5).
        let (mut sum, mut sx, mut sy) = (0.0f64, 0.0f64, 0.0f64);
        for y in 0..h {
            for x in 0..w {
                let v = f64::from(values[(y * w + x) as usize * lanes + lane]).max(0.0);
                sum += v;
                sx += v * (f64::from(x) + 0.5);
                sy += v * (f64::from(y) + 0.5);
            }
        }
        assert!(sum > 0.0, "{} nm: no light on the wall", wavelengths[lane]);
        let (cx, cy) = (sx / sum, sy / sum);
        assert!(
            (cx - f64::from(ex)).abs() < 0.5 && (cy - f64::from(ey)).abs() < 0.5,
            "{} nm (n = {n:.5}): centroid ({cx:.2}, {cy:.2}), Snell's law puts it at ({ex:.2}, {ey:.2})",
            wavelengths[lane]
        );
        rows.push(cy);
    }
    // Red is deviated least: highest on the wall (smallest row); the band spans several pixels.
    assert!(rows[2] < rows[1] && rows[1] < rows[0], "rows {rows:?}");
    assert!(rows[0] - rows[2] > 5.0, "rows {rows:?}");
}

/// Mean luminance of bdpt and of the path tracer over the whole image must agree within 5 standard errors and
/// `tolerance` (relative): the agreement tests of scenes both converge on.
fn agree(
    what: &str,
    scene: &integrator::RenderScene,
    (w, h): (u32, u32),
    spp_bdpt: u32,
    spp_path: u32,
    tolerance: f64,
) {
    let (b, stats) = render_with(scene, &options(bdpt(), w, h, spp_bdpt, 1, 2));
    assert_all_finite(&b, &stats);
    let (p, _) = render_with(scene, &options(path(), w, h, spp_path, 2, 2));
    let all = || 0..(w * h) as usize;
    let ((mb, _), (mp, _)) = (mean_y(&b, all()), mean_y(&p, all()));
    let (d, se) = mean_difference(&b, &p, all());
    let z = d / se;
    eprintln!("{what}: bdpt {mb:.5}, path {mp:.5}, difference {d:.5} ± {se:.5}: z = {z:.2}, ratio {:.4}", mb / mp);
    assert!(z.abs() < 5.0, "{what}: bdpt {mb:.5}, path {mp:.5}, difference {d:.5} ± {se:.5}: z = {z:.2}");
    assert!((mb / mp - 1.0).abs() < tolerance, "{what}: bdpt / path = {:.4}", mb / mp);
}

/// A white floor, a grey diffuse sphere on it and a diffuse box beside, lit by `lights` only.
fn diffuse_scene(lights: &str) -> String {
    format!(
        r#"{{
        "camera": {{"position": [0, 2.2, 5], "look_at": [0, 0.5, 0], "up": [0, 1, 0], "vfov_deg": 45}},
        "lights": [{lights}],
        "materials": {{
            "floor": {{"model": "diffuse", "base_color": 0.8}},
            "grey": {{"model": "diffuse", "base_color": 0.5}}
        }},
        "objects": [
            {{"type": "quad", "corner": [-3, 0, -3], "edge_u": [0, 0, 6], "edge_v": [6, 0, 0], "material": "floor"}},
            {{"type": "sphere", "center": [-0.6, 0.7, 0], "radius": 0.7, "material": "grey"}},
            {{"type": "quad", "corner": [0.6, 0, -0.5], "edge_u": [0, 1.2, 0], "edge_v": [1, 0, 0], "material": "grey"}}
        ],
        "settings": {{"max_depth": 6}}
    }}"#
    )
}

/// Light subpaths from a uniform environment (rays from a disc the size of the scene) weighted against the
/// camera's strategies (escaping rays, next-event estimation) converge to the path tracer's image.
#[test]
fn bdpt_agrees_with_the_path_tracer_under_a_uniform_environment() {
    let scene = scene(&diffuse_scene(r#"{"type": "environment", "spectrum": "D65", "intensity": 1}"#));
    agree("uniform environment", &scene, (32, 24), 48, 192, 0.02);
}

/// The same under a daylight sky: an environment map sampled by its luminance and a sun (a directional
/// light), both starting light subpaths.
#[test]
fn bdpt_agrees_with_the_path_tracer_under_a_sky_and_sun() {
    let desc = geometry::parse_manifest(&diffuse_scene(""), std::path::Path::new("."), "<test>").unwrap();
    let sky = integrator::SkyOption { intensity: 1e-4, sun_azimuth_deg: Some(60.0), ..Default::default() };
    let options = integrator::AssemblyOptions { sky: Some(sky), ..Default::default() };
    let scene = integrator::RenderScene::from_description_with(desc, &options).unwrap();
    agree("sky and sun", &scene, (32, 24), 48, 192, 0.02);
}

/// A directional light alone (a shadow, interreflection): its light subpaths start on the disc.
#[test]
fn bdpt_agrees_with_the_path_tracer_under_a_directional_light() {
    let scene = scene(&diffuse_scene(
        r#"{"type": "directional", "direction": [0.3, -1, -0.4], "spectrum": "D65", "intensity": 3}"#,
    ));
    agree("directional light", &scene, (32, 24), 48, 192, 0.02);
}

/// A sun straight down through a smooth glass slab (n = 1.5, 4 × 4 wide, 0.1 thick, 1 above a white floor):
/// the floor beneath it gets the sun's light through two interfaces, E (1 − F)², F = ((n − 1)/(n + 1))² =
/// 0.04 at normal incidence (`max_depth` 4 leaves out internal reflections, which need 5 bounces). No camera
/// path finds that light (the slab hides the sun from next-event estimation and a directional light cannot
/// be hit): bdpt's light tracing must, so the floor under the slab reads bdpt − path = ρ/π E (1 − F)² (the
/// rest, the floor's light mirrored by the slab's underside, both find), and beside the slab ρ/π E in both.
#[test]
fn a_sun_through_a_glass_slab_lights_the_floor_by_its_transmittance() {
    let (e, rho) = (3.0f64, 0.8f64);
    let quad = |c: [f32; 3], u: [f32; 3], v: [f32; 3]| {
        format!(r#"{{"type": "quad", "corner": {c:?}, "edge_u": {u:?}, "edge_v": {v:?}, "material": "glass"}}"#)
    };
    // A box from (−2, 1, −2) to (2, 1.1, 2), faces outwards (edge_u × edge_v).
    let slab = [
        quad([-2.0, 1.1, -2.0], [0.0, 0.0, 4.0], [4.0, 0.0, 0.0]),
        quad([-2.0, 1.0, -2.0], [4.0, 0.0, 0.0], [0.0, 0.0, 4.0]),
        quad([-2.0, 1.0, 2.0], [4.0, 0.0, 0.0], [0.0, 0.1, 0.0]),
        quad([-2.0, 1.0, -2.0], [0.0, 0.1, 0.0], [4.0, 0.0, 0.0]),
        quad([2.0, 1.0, -2.0], [0.0, 0.1, 0.0], [0.0, 0.0, 4.0]),
        quad([-2.0, 1.0, -2.0], [0.0, 0.0, 4.0], [0.0, 0.1, 0.0]),
    ]
    .join(",\n");
    let json = format!(
        r#"{{
        "camera": {{"position": [0, 0.9, 4.5], "look_at": [0, 0, -0.5], "up": [0, 1, 0], "vfov_deg": 50}},
        "lights": [{{"type": "directional", "direction": [0, -1, 0], "spectrum": "D65", "intensity": {e}}}],
        "materials": {{
            "floor": {{"model": "diffuse", "base_color": {rho}}},
            "glass": {{"model": "dielectric", "base_color": 0, "diffuse": 0, "transmission": 1, "transmittance": 1.0, "ior": 1.5}}
        }},
        "objects": [
            {{"type": "quad", "corner": [-6, 0, -6], "edge_u": [0, 0, 12], "edge_v": [12, 0, 0], "material": "floor"}},
            {slab}
        ],
        "settings": {{"max_depth": 4}}
    }}"#
    );
    let scene = scene(&json);
    let (w, h) = (48, 36);
    let spp = 256;
    let (b, stats) = render_with(&scene, &options(bdpt(), w, h, spp, 3, 2));
    assert_all_finite(&b, &stats);
    let (p, _) = render_with(&scene, &options(path(), w, h, spp, 4, 2));
    let camera =
        Camera::look_at(Vec3::new(0.0, 0.9, 4.5), Vec3::new(0.0, 0.0, -0.5), Vec3::Y, 50.0, w as f32 / h as f32)
            .unwrap();
    // Pixels whose four corners' rays all meet the floor under the slab (at least 0.1 inside its edge), or
    // all beside it (0.1 outside).
    let floor_at = |x: u32, y: u32| {
        let r = camera.generate_ray(x as f32, y as f32, w, h);
        (r.dir.y < 0.0).then(|| r.origin + r.dir * (-r.origin.y / r.dir.y))
    };
    let (mut under, mut beside) = (Vec::new(), Vec::new());
    for y in 0..h {
        for x in 0..w {
            let corners: Option<Vec<Vec3>> =
                [(x, y), (x + 1, y), (x, y + 1), (x + 1, y + 1)].into_iter().map(|(cx, cy)| floor_at(cx, cy)).collect();
            let Some(corners) = corners else { continue };
            let i = (y * w + x) as usize;
            if corners.iter().all(|q| q.x.abs() < 1.9 && q.z.abs() < 1.9) {
                under.push(i);
            } else if corners.iter().all(|q| (q.x.abs() > 2.1 || q.z.abs() > 2.1) && q.x.abs() < 5.5 && q.z.abs() < 5.5)
            {
                beside.push(i);
            }
        }
    }
    assert!(under.len() > 200 && beside.len() > 100, "{} under the slab, {} beside", under.len(), beside.len());
    eprintln!("{} pixels under the slab, {} beside", under.len(), beside.len());
    let direct = rho / std::f64::consts::PI * e;
    let f = (0.5f64 / 2.5).powi(2);
    let through = direct * (1.0 - f).powi(2);
    for (what, image) in [("bdpt", &b), ("path", &p)] {
        let (got, se) = mean_y(image, beside.iter().copied());
        eprintln!("{what} beside the slab: {got:.5} ± {se:.5}, analytic {direct:.5}");
        assert!(
            (got - direct).abs() < 5.0 * se + 0.01 * direct,
            "{what} beside: {got:.5} ± {se:.5}, analytic {direct:.5}"
        );
    }
    let ((gb, _), (gp, _)) = (mean_y(&b, under.iter().copied()), mean_y(&p, under.iter().copied()));
    let (diff, se) = mean_difference(&b, &p, under.iter().copied());
    eprintln!("under the slab: bdpt {gb:.5}, path {gp:.5}; difference {diff:.5} ± {se:.5}, analytic {through:.5}");
    assert!(
        (diff - through).abs() < 5.0 * se + 0.01 * through,
        "under the slab: bdpt − path = {diff:.5} ± {se:.5}, analytic ρ/π E (1 − F)² = {through:.5} (ratio {:.4})",
        diff / through
    );
    // The path tracer finds none of the sun through the glass.
    assert!(gp < 0.1 * through, "path under the slab: {gp:.5}");
}
