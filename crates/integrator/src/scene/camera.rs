//! The one place a render's camera is decided: the file's camera (or the one
//! `--camera N|NAME` names), else a default three-quarter view that frames the scene's bounds;
//! then the command line's `--look-from`, `--look-at` and `--fov`, which work for every format.

use std::str::FromStr;

use geometry::{CameraDesc, Projection, SceneFormat};
use glam::Vec3;

use crate::error::{Error, Result};

/// The world axis that points up, for the default camera.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum UpAxis {
    /// +Y up: glTF (glTF 2.0 §3.4 "+Y is up, the front of an asset faces +Z"), the manifest, and most OBJ.
    #[default]
    Y,
    /// +Z up (Blender, CAD and scans), with the front facing −Y (Blender's front view looks along +Y).
    Z,
}

impl FromStr for UpAxis {
    type Err = Error;

    fn from_str(s: &str) -> Result<Self> {
        match s {
            "y" | "Y" => Ok(Self::Y),
            "z" | "Z" => Ok(Self::Z),
            _ => Err(Error::InvalidOption { option: "up", value: s.to_owned(), expected: "y or z" }),
        }
    }
}

/// What the user asks of the camera; every field optional (`Default`: the file decides).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct CameraOptions {
    /// One of the file's cameras, by name or by index in file order (`--camera N|NAME`).
    pub camera: Option<String>,
    /// Up axis of the default camera (`--up y|z`); `None`: +Y.
    pub up: Option<UpAxis>,
    /// Eye position (`--look-from X,Y,Z`), overriding the chosen camera's.
    pub look_from: Option<Vec3>,
    /// Point looked at (`--look-at X,Y,Z`), overriding the chosen camera's; when only `look_from` is
    /// given, the centre of the bounds.
    pub look_at: Option<Vec3>,
    /// Vertical field of view in degrees (`--fov DEG`), in (0, 180).
    pub vfov_deg: Option<f32>,
    /// Width / height of the image to frame (the default camera fits the bounds in both directions);
    /// `None`: the default 640×480.
    pub aspect: Option<f32>,
}

/// Vertical field of view of the default camera, degrees (a moderate lens, as Blender's 50 mm default ≈ 39.6°).
pub(crate) const DEFAULT_VFOV_DEG: f32 = 40.0;

/// Azimuth of the default view from the front towards the side (+X), degrees: a three-quarter view that
/// shows the front and one side (product photography's usual 30–45°).
const VIEW_AZIMUTH_DEG: f32 = 35.0;

/// Elevation of the default view above the horizon, degrees: enough to see the top and a ground plane
/// (not edge-on), little enough to keep the front.
const VIEW_ELEVATION_DEG: f32 = 25.0;

/// Fraction of the half field of view the bounds' corners may reach: a 5 % margin on each side.
const FRAME_FILL: f32 = 0.9;

/// A Z-up file seen as Y-up looks flat in y and long in z: warn when y's extent is below this fraction of
/// z's and z is the longest side (by [`Z_LONGEST_MARGIN`] over x; a Y-up ground plane is about as long in x).
const FLAT_Y_RATIO: f32 = 0.25;
/// See [`FLAT_Y_RATIO`].
const Z_LONGEST_MARGIN: f32 = 1.25;

/// The camera decided for a scene, and a one-line account of where it comes from.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct ChosenCamera {
    pub desc: CameraDesc,
    pub source: String,
}

/// Decide the camera: see the module docs. `cameras` are the file's, named, the first being its default;
/// `bounds` the scene's (`None` without geometry). Notes for the user go to `warnings`.
pub(crate) fn choose_camera(
    format: SceneFormat,
    cameras: &[(String, CameraDesc)],
    bounds: Option<(Vec3, Vec3)>,
    options: &CameraOptions,
    warnings: &mut Vec<String>,
) -> Result<ChosenCamera> {
    let (lo, hi) = bounds.unwrap_or((Vec3::splat(-1.0), Vec3::splat(1.0)));
    let center = 0.5 * (lo + hi);
    let up_axis = options.up.unwrap_or_default();
    let chosen = match &options.camera {
        Some(wanted) => {
            let found = cameras
                .iter()
                .position(|(name, _)| name == wanted)
                .or_else(|| wanted.parse::<usize>().ok().filter(|i| *i < cameras.len()));
            let Some(index) = found else {
                let names: Vec<String> = cameras.iter().enumerate().map(|(i, (n, _))| format!("{i} '{n}'")).collect();
                return Err(Error::Camera(format!(
                    "--camera {wanted}: no such camera in the file ({})",
                    if names.is_empty() { "it has none".to_owned() } else { format!("it has {}", names.join(", ")) }
                )));
            };
            let (name, c) = &cameras[index];
            ChosenCamera { desc: c.clone(), source: format!("the file's camera {index} '{name}' (--camera)") }
        }
        None => match cameras.first() {
            Some((name, c)) => {
                let more = if cameras.len() > 1 {
                    format!(" (the first of {}; --camera N|NAME chooses)", cameras.len())
                } else {
                    String::new()
                };
                ChosenCamera { desc: c.clone(), source: format!("the file's camera '{name}'{more}") }
            }
            None => {
                if format == SceneFormat::Obj && options.up.is_none() {
                    let extent = hi - lo;
                    if extent.y < FLAT_Y_RATIO * extent.z && extent.z > Z_LONGEST_MARGIN * extent.x {
                        warnings.push(format!(
                            "the bounds are much flatter in y ({:.3}) than in z ({:.3}): if the file is Z-up, pass --up z",
                            extent.y, extent.z
                        ));
                    }
                }
                let aspect = options.aspect.unwrap_or(
                    crate::options::DEFAULT_RESOLUTION.0 as f32 / crate::options::DEFAULT_RESOLUTION.1 as f32,
                );
                let vfov = options.vfov_deg.unwrap_or(DEFAULT_VFOV_DEG);
                let desc = default_camera(lo, hi, up_axis, vfov, aspect);
                let up = if up_axis == UpAxis::Z { "Z" } else { "Y" };
                ChosenCamera {
                    source: format!(
                        "no camera in the file: a three-quarter view ({VIEW_AZIMUTH_DEG}° to the side, {VIEW_ELEVATION_DEG}° above, {up}-up) framing the bounds, looking at ({:.3}, {:.3}, {:.3}), vfov {}°",
                        center.x, center.y, center.z, desc.vfov_deg
                    ),
                    desc,
                }
            }
        },
    };
    apply_overrides(chosen, center, up_axis, options)
}

/// `--look-from`, `--look-at`, `--fov` on top of the chosen camera, validated.
fn apply_overrides(
    chosen: ChosenCamera,
    center: Vec3,
    up_axis: UpAxis,
    options: &CameraOptions,
) -> Result<ChosenCamera> {
    if options.look_from.is_none() && options.look_at.is_none() && options.vfov_deg.is_none() {
        return Ok(chosen);
    }
    let ChosenCamera { mut desc, mut source } = chosen;
    if let Some(p) = options.look_from {
        desc.position = p;
        // Moving the eye alone keeps looking at the scene, not along the old direction.
        desc.look_at = options.look_at.unwrap_or(center);
    }
    if let Some(t) = options.look_at {
        desc.look_at = t;
    }
    if let Some(fov) = options.vfov_deg {
        if let Projection::Orthographic { .. } = desc.projection {
            return Err(Error::Camera(format!(
                "--fov {fov}: {} is orthographic (no field of view; --look-from and --look-at apply)",
                source
            )));
        }
        if !(fov > 0.0 && fov < 180.0) {
            return Err(Error::Camera(format!("--fov {fov}: the field of view must be in (0, 180) degrees")));
        }
        desc.vfov_deg = fov;
    }
    if !(desc.position.is_finite() && desc.look_at.is_finite()) {
        return Err(Error::Camera("--look-from and --look-at must be finite".to_owned()));
    }
    let Some(forward) = (desc.look_at - desc.position).try_normalize() else {
        return Err(Error::Camera(format!(
            "--look-from and --look-at give the same point ({}, {}, {})",
            desc.position.x, desc.position.y, desc.position.z
        )));
    };
    // Keep the camera's up unless the new direction is (nearly) parallel to it: then the world's up,
    // then +X for a view straight down that axis.
    let world_up = if up_axis == UpAxis::Z { Vec3::Z } else { Vec3::Y };
    desc.up = [desc.up, world_up, Vec3::X]
        .into_iter()
        .find(|u| u.normalize_or_zero().cross(forward).length() > 1e-3)
        .unwrap_or(Vec3::Z);
    source.push_str("; --look-from/--look-at/--fov from the command line");
    Ok(ChosenCamera { desc, source })
}

/// The default camera: a three-quarter view from the front, above and to the side ([`VIEW_AZIMUTH_DEG`],
/// [`VIEW_ELEVATION_DEG`]) looking at the centre of the box `lo`–`hi`, at the nearest distance where all
/// eight corners lie within [`FRAME_FILL`] of the half field of view, vertically and horizontally.
pub(crate) fn default_camera(lo: Vec3, hi: Vec3, up_axis: UpAxis, vfov_deg: f32, aspect: f32) -> CameraDesc {
    let center = 0.5 * (lo + hi);
    let (az, el) = (VIEW_AZIMUTH_DEG.to_radians(), VIEW_ELEVATION_DEG.to_radians());
    // `back`: from the centre towards the eye. Y-up fronts face +Z; Z-up fronts face −Y.
    let (back, up) = match up_axis {
        UpAxis::Y => (Vec3::new(az.sin() * el.cos(), el.sin(), az.cos() * el.cos()), Vec3::Y),
        UpAxis::Z => (Vec3::new(az.sin() * el.cos(), -az.cos() * el.cos(), el.sin()), Vec3::Z),
    };
    let right = up.cross(back).normalize();
    let cam_up = back.cross(right);
    let tan_v = FRAME_FILL * (0.5 * vfov_deg.to_radians()).tan();
    let tan_h = tan_v * aspect;
    // A corner at offset p from the centre is at depth D − p·back from an eye at distance D; it is inside
    // the frame when |p·right| ≤ tan_h · depth and |p·cam_up| ≤ tan_v · depth.
    let mut distance = 0.0f32;
    for i in 0..8 {
        let corner = Vec3::new(
            if i & 1 == 0 { lo.x } else { hi.x },
            if i & 2 == 0 { lo.y } else { hi.y },
            if i & 4 == 0 { lo.z } else { hi.z },
        );
        let p = corner - center;
        let depth_offset = p.dot(back);
        distance =
            distance.max(p.dot(right).abs() / tan_h + depth_offset).max(p.dot(cam_up).abs() / tan_v + depth_offset);
    }
    // A point (or empty) scene: a small positive distance so the camera is not at the target.
    let distance = distance.max(1e-3 * (1.0 + center.length()));
    CameraDesc {
        position: center + distance * back,
        look_at: center,
        up,
        vfov_deg,
        projection: Projection::Perspective,
        aspect_ratio: None,
        width: None,
        height: None,
    }
}

#[cfg(test)]
mod tests {
    use geometry::Camera;

    use super::*;

    /// Projects `p` with a camera of aspect `aspect` to normalized image coordinates in [−1, 1]².
    fn project(c: &CameraDesc, aspect: f32, p: Vec3) -> (f32, f32) {
        let forward = (c.look_at - c.position).normalize();
        let right = forward.cross(c.up).normalize();
        let up = right.cross(forward);
        let d = p - c.position;
        let t = (0.5 * c.vfov_deg.to_radians()).tan();
        (d.dot(right) / (d.dot(forward) * t * aspect), d.dot(up) / (d.dot(forward) * t))
    }

    #[test]
    fn the_default_camera_frames_every_corner_from_front_above_and_side() {
        let (lo, hi) = (Vec3::new(-2.0, 0.0, -1.0), Vec3::new(2.0, 3.0, 1.0));
        for (up_axis, aspect) in [(UpAxis::Y, 4.0 / 3.0), (UpAxis::Y, 0.5), (UpAxis::Z, 16.0 / 9.0)] {
            let c = default_camera(lo, hi, up_axis, 40.0, aspect);
            let mut extreme = 0.0f32;
            for i in 0..8 {
                let corner = Vec3::new(
                    if i & 1 == 0 { lo.x } else { hi.x },
                    if i & 2 == 0 { lo.y } else { hi.y },
                    if i & 4 == 0 { lo.z } else { hi.z },
                );
                let (x, y) = project(&c, aspect, corner);
                extreme = extreme.max(x.abs()).max(y.abs());
            }
            // Every corner inside, and the tightest one exactly at the fill fraction (not loosely framed).
            assert!((extreme - FRAME_FILL).abs() < 1e-4, "{up_axis:?} {aspect}: {extreme}");
            let back = (c.position - c.look_at).normalize();
            let (up, front) = if up_axis == UpAxis::Y { (Vec3::Y, Vec3::Z) } else { (Vec3::Z, Vec3::NEG_Y) };
            // 25° above the horizon, in front, 35° to the +x side.
            assert!((back.dot(up) - VIEW_ELEVATION_DEG.to_radians().sin()).abs() < 1e-5);
            let horizontal = (back - back.dot(up) * up).normalize();
            assert!((horizontal.dot(front) - VIEW_AZIMUTH_DEG.to_radians().cos()).abs() < 1e-5);
            assert!(horizontal.x > 0.0);
            assert_eq!(c.look_at, 0.5 * (lo + hi));
        }
    }

    #[test]
    fn look_from_and_look_at_give_the_expected_basis() {
        let options = CameraOptions {
            look_from: Some(Vec3::new(0.0, 0.0, 10.0)),
            look_at: Some(Vec3::new(0.0, 0.0, 0.0)),
            vfov_deg: Some(30.0),
            ..CameraOptions::default()
        };
        let mut warnings = Vec::new();
        let chosen = choose_camera(SceneFormat::Obj, &[], None, &options, &mut warnings).unwrap();
        let c = &chosen.desc;
        assert_eq!((c.position, c.look_at, c.vfov_deg), (Vec3::new(0.0, 0.0, 10.0), Vec3::ZERO, 30.0));
        let camera = Camera::look_at(c.position, c.look_at, c.up, c.vfov_deg, 1.0).unwrap();
        // Centre pixel looks down −z; the right edge towards +x at 15°, the top edge towards +y at 15°.
        let centre = camera.generate_ray(50.0, 50.0, 100, 100).dir;
        assert!((centre - Vec3::NEG_Z).length() < 1e-6, "{centre}");
        let right = camera.generate_ray(100.0, 50.0, 100, 100).dir;
        assert!((right - Vec3::new(15f32.to_radians().sin(), 0.0, -15f32.to_radians().cos())).length() < 1e-6);
        let top = camera.generate_ray(50.0, 0.0, 100, 100).dir;
        assert!((top - Vec3::new(0.0, 15f32.to_radians().sin(), -15f32.to_radians().cos())).length() < 1e-6);
        // Looking straight down the up axis: another up is chosen, not an error.
        let down = CameraOptions {
            look_from: Some(Vec3::new(0.0, 5.0, 0.0)),
            look_at: Some(Vec3::ZERO),
            ..CameraOptions::default()
        };
        let c = choose_camera(SceneFormat::Gltf, &[], None, &down, &mut warnings).unwrap().desc;
        assert!(Camera::look_at(c.position, c.look_at, c.up, c.vfov_deg, 1.0).is_ok());
        // The same point twice, or a bad fov: errors that say so.
        let same = CameraOptions { look_from: Some(Vec3::ONE), look_at: Some(Vec3::ONE), ..CameraOptions::default() };
        assert!(choose_camera(SceneFormat::Obj, &[], None, &same, &mut warnings).is_err());
        let fov = CameraOptions { vfov_deg: Some(180.0), ..CameraOptions::default() };
        assert!(choose_camera(SceneFormat::Obj, &[], None, &fov, &mut warnings).is_err());
    }

    #[test]
    fn cameras_are_chosen_by_name_or_index_and_a_missing_one_is_an_error() {
        let cam = |x: f32| CameraDesc {
            position: Vec3::new(x, 0.0, 5.0),
            look_at: Vec3::ZERO,
            up: Vec3::Y,
            vfov_deg: 30.0,
            projection: Projection::Perspective,
            aspect_ratio: None,
            width: None,
            height: None,
        };
        let cameras = vec![("front".to_owned(), cam(0.0)), ("side".to_owned(), cam(4.0))];
        let mut w = Vec::new();
        let pick = |sel: Option<&str>, w: &mut Vec<String>| {
            let options = CameraOptions { camera: sel.map(str::to_owned), ..CameraOptions::default() };
            choose_camera(SceneFormat::Gltf, &cameras, None, &options, w)
        };
        assert_eq!(pick(None, &mut w).unwrap().desc, cam(0.0));
        assert_eq!(pick(Some("side"), &mut w).unwrap().desc, cam(4.0));
        assert_eq!(pick(Some("1"), &mut w).unwrap().desc, cam(4.0));
        let err = pick(Some("top"), &mut w).unwrap_err().to_string();
        assert!(err.contains("0 'front', 1 'side'"), "{err}");
        assert!(pick(Some("2"), &mut w).is_err());
    }

    #[test]
    fn a_flat_in_y_obj_warns_that_it_may_be_z_up() {
        let mut w = Vec::new();
        let flat = Some((Vec3::new(-1.0, -0.1, -2.0), Vec3::new(1.0, 0.1, 2.0)));
        // A ground plane as long in x as in z is not taken for Z-up.
        let ground = Some((Vec3::new(-4.0, -0.1, -4.0), Vec3::new(4.0, 1.0, 4.0)));
        choose_camera(SceneFormat::Obj, &[], flat, &CameraOptions::default(), &mut w).unwrap();
        assert_eq!(w.len(), 1, "{w:?}");
        assert!(w[0].contains("--up z"));
        let mut w = Vec::new();
        let z_up = CameraOptions { up: Some(UpAxis::Z), ..CameraOptions::default() };
        let c = choose_camera(SceneFormat::Obj, &[], flat, &z_up, &mut w).unwrap().desc;
        assert!(w.is_empty() && c.up == Vec3::Z && c.position.z > 0.0 && c.position.y < 0.0);
        let mut w = Vec::new();
        choose_camera(SceneFormat::Obj, &[], ground, &CameraOptions::default(), &mut w).unwrap();
        assert!(w.is_empty(), "{w:?}");
        let cube = Some((Vec3::splat(-1.0), Vec3::splat(1.0)));
        choose_camera(SceneFormat::Obj, &[], cube, &CameraOptions::default(), &mut w).unwrap();
        assert!(w.is_empty());
    }
}
