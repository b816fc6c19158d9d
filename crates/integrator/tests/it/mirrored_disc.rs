//! A caustic only photon mapping renders, with its analytic image: shared by the integration tests
//! (`sppm.rs`) and `cargo xtask validate --only caustics` (which includes this file).

use geometry::Camera;
use glam::Vec3;

const INTENSITY: f32 = 40.0;
const CONE_DEG: f32 = 20.0;

/// A spot light at (0, 3, 0) points up into a mirror M1 (reflectance 0.9, 0.8 wide) at y = 4, which throws
/// its cone back down as a disc of light on a white floor (ρ 0.8): from the light's image at (0, 5, 0),
/// E = 0.9 I cos θ / d² within 20° of straight down. The camera sees the floor only in a second mirror
/// M2 (0.9, the wall z = −4.5), so every path of that light is light → M1 → floor → M2 → camera: a delta
/// vertex on both sides of the one diffuse vertex.
pub(crate) fn mirrored_disc() -> String {
    format!(
        r#"{{
        "camera": {{"position": [0, 8, 4], "look_at": [0, 2.6, -4.5], "up": [0, 1, 0], "vfov_deg": 14}},
        "lights": [{{"type": "spot", "position": [0, 3, 0], "direction": [0, 1, 0], "inner_cone_deg": {CONE_DEG},
                     "outer_cone_deg": {CONE_DEG}, "spectrum": "D65", "intensity": {INTENSITY}}}],
        "materials": {{
            "floor": {{"model": "diffuse", "base_color": 0.8}},
            "mirror": {{"model": "mirror", "base_color": 0, "specular": 0.9, "ks": 1}}
        }},
        "objects": [
            {{"type": "quad", "corner": [-4.5, 0, -4.5], "edge_u": [0, 0, 9], "edge_v": [9, 0, 0], "material": "floor"}},
            {{"type": "quad", "corner": [-0.4, 4, -0.4], "edge_u": [0.8, 0, 0], "edge_v": [0, 0, 0.8], "material": "mirror"}},
            {{"type": "quad", "corner": [-4.5, 0, -4.5], "edge_u": [9, 0, 0], "edge_v": [0, 4, 0], "material": "mirror"}}
        ],
        "settings": {{"max_depth": 8}}
    }}"#
    )
}

/// The analytic image of [`mirrored_disc`]: per pixel (its centre's ray) the radiance it sees in M2, and
/// the pixels well inside the disc and well outside it (0.35 from its edge, about a pixel's footprint on
/// the floor, so pixels straddling it are left out).
pub(crate) fn disc_answer(w: u32, h: u32) -> (Vec<f64>, Vec<usize>, Vec<usize>) {
    let camera =
        Camera::look_at(Vec3::new(0.0, 8.0, 4.0), Vec3::new(0.0, 2.6, -4.5), Vec3::Y, 14.0, w as f32 / h as f32)
            .unwrap();
    let image = Vec3::new(0.0, 5.0, 0.0);
    let edge = 5.0 * CONE_DEG.to_radians().tan();
    let mut want = vec![0.0f64; (w * h) as usize];
    let (mut inside, mut outside) = (Vec::new(), Vec::new());
    for y in 0..h {
        for x in 0..w {
            let r = camera.generate_ray(x as f32 + 0.5, y as f32 + 0.5, w, h);
            // Rays that pass M1 on their way (it hides the middle of the view) are left out.
            let m1 = r.origin + r.dir * ((4.0 - r.origin.y) / r.dir.y);
            if m1.x.abs() < 0.5 && m1.z.abs() < 0.5 {
                continue;
            }
            // M2 at z = −4.5 (x in ±4.5, y in 0..4), then the floor.
            let t = (-4.5 - r.origin.z) / r.dir.z;
            let a = r.origin + r.dir * t;
            if !(t > 0.0 && a.x.abs() < 4.4 && a.y > 0.1 && a.y < 3.9) {
                continue;
            }
            let d = Vec3::new(r.dir.x, r.dir.y, -r.dir.z);
            let q = a + d * (-a.y / d.y);
            if q.x.abs() > 4.0 || q.z.abs() > 4.0 {
                continue;
            }
            let i = (y * w + x) as usize;
            let radius = q.x.hypot(q.z);
            if radius < edge - 0.35 {
                let to = image - q;
                let irradiance = 0.9 * INTENSITY * (to.y / to.length()) / to.length_squared();
                want[i] = 0.9 * 0.8 / std::f64::consts::PI * f64::from(irradiance);
                inside.push(i);
            } else if radius > edge + 0.35 {
                outside.push(i);
            }
        }
    }
    (want, inside, outside)
}
