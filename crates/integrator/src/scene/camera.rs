//! The one place a render's camera is decided: the file's camera (or the one
//! `--camera N|NAME` names), else a default view chosen by the cheap pass (`survey.rs`) among framed
//! candidates — the three-quarter view unless another shows clearly more front-facing, lit surface
//! (the inside of a room through its open side, or from within a closed one); then the command line's
//! `--look-from`, `--look-at` and `--fov`, which work for every format.

use std::str::FromStr;

use geometry::{CameraDesc, Projection, SceneFormat};
use glam::Vec3;

use crate::error::{Error, Result};
use crate::scene::survey::{GRID, Survey, ViewScore};

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
/// `bounds` the scene's (`None` without geometry) and `framing` the part of them the default view frames
/// ([`framing_bounds`]); `survey` scores the default view's candidates (without one, the three-quarter
/// view). Notes for the user go to `warnings`.
pub(crate) fn choose_camera(
    format: SceneFormat,
    cameras: &[(String, CameraDesc)],
    bounds: Option<(Vec3, Vec3)>,
    framing: Option<(Vec3, Vec3)>,
    options: &CameraOptions,
    survey: Option<&Survey<'_>>,
    warnings: &mut Vec<String>,
) -> Result<ChosenCamera> {
    let (lo, hi) = bounds.unwrap_or((Vec3::splat(-1.0), Vec3::splat(1.0)));
    let (frame_lo, frame_hi) = framing.or(bounds).unwrap_or((lo, hi));
    let center = 0.5 * (frame_lo + frame_hi);
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
                // With --look-from the eye is the user's: no view to choose.
                let survey = survey.filter(|_| options.look_from.is_none() && bounds.is_some());
                default_view(frame_lo, frame_hi, up_axis, vfov, aspect, survey)
            }
        },
    };
    apply_overrides(chosen, center, up_axis, options)
}

/// The default view of the box `lo`–`hi`: the three-quarter view ([`default_camera`]) unless `survey`
/// finds a candidate view that shows clearly more ([`choose_view`]).
fn default_view(
    lo: Vec3,
    hi: Vec3,
    up_axis: UpAxis,
    vfov: f32,
    aspect: f32,
    survey: Option<&Survey<'_>>,
) -> ChosenCamera {
    let center = 0.5 * (lo + hi);
    let up_name = if up_axis == UpAxis::Z { "Z" } else { "Y" };
    let three_quarter = default_camera(lo, hi, up_axis, vfov, aspect);
    let plain = |desc: CameraDesc, detail: String| ChosenCamera {
        source: format!(
            "no camera in the file: a three-quarter view ({VIEW_AZIMUTH_DEG}° to the side, {VIEW_ELEVATION_DEG}° above, {up_name}-up) framing the bounds, looking at ({:.3}, {:.3}, {:.3}), vfov {}°{detail}",
            center.x, center.y, center.z, desc.vfov_deg
        ),
        desc,
    };
    let Some(survey) = survey else { return plain(three_quarter, String::new()) };
    let started = std::time::Instant::now();
    let choice = choose_view(lo, hi, up_axis, vfov, aspect, survey);
    let ms = started.elapsed().as_secs_f64() * 1e3;
    let kept = choice.candidates[0].1;
    if choice.index == 0 {
        return plain(
            three_quarter,
            format!(
                " (score {:.2}; no other of {} views scores clearly more; {ms:.0} ms)",
                kept.score,
                choice.candidates.len()
            ),
        );
    }
    let (view, score) = &choice.candidates[choice.index];
    // Where the three-quarter view met back faces (a fifth of what it met or more), the chosen one sees what
    // they hide: the inside of a room when they lie on the bounds of a box that is not flat, else the side
    // the surfaces face.
    let extent = hi - lo;
    let room = 2 * kept.back_on_bounds >= kept.back && extent.min_element() >= 0.1 * extent.max_element();
    let through = match (view.inside, 5 * kept.back >= kept.front + kept.back, room) {
        (true, ..) | (false, false, _) => "",
        (false, true, true) => ", looking in through the open side",
        (false, true, false) => ", the side its surfaces face",
    };
    let place = if view.inside { "" } else { ", framing the bounds" };
    ChosenCamera {
        source: format!(
            "no camera in the file: default view from {}{place}{through} ({up_name}-up), looking at ({:.3}, {:.3}, {:.3}), vfov {}°; score {:.2} against {:.2} for the three-quarter view, which meets {} back and {} front faces of {} rays (best of {} views, {ms:.0} ms)",
            view.label,
            view.desc.look_at.x,
            view.desc.look_at.y,
            view.desc.look_at.z,
            view.desc.vfov_deg,
            score.score,
            kept.score,
            kept.back,
            kept.front,
            GRID.0 * GRID.1,
            choice.candidates.len()
        ),
        desc: view.desc.clone(),
    }
}

/// A candidate view: where it looks from (for the note), the camera, and whether it stands inside the
/// bounds (a room's interior).
#[derive(Debug, Clone)]
pub(crate) struct View {
    pub(crate) label: String,
    pub(crate) desc: CameraDesc,
    pub(crate) inside: bool,
}

/// The candidate views and their scores, and the index of the one chosen (0: the three-quarter view).
#[derive(Debug)]
pub(crate) struct ViewChoice {
    pub(crate) candidates: Vec<(View, ViewScore)>,
    pub(crate) index: usize,
}

/// A candidate replaces the three-quarter view only when it scores more by [`TIE_MARGIN`] and by
/// [`TIE_RATIO`] of the three-quarter view's score (a score is the mean over the surfaces a view meets,
/// in [−1, 1]: 1 for front faces only, lit where the file has lights), and meets at least half as many
/// surfaces. An object seen from outside scores about 1 from every side, so it keeps the three-quarter
/// view; a view of walls from outside (back faces, or unlit outer sides of double-sided walls around a
/// lamp) scores 0.5 or less, and a view into the room beats it.
const TIE_MARGIN: f32 = 0.1;
/// See [`TIE_MARGIN`].
const TIE_RATIO: f32 = 0.5;

/// Vertical field of view of a view from inside a room, degrees: a wide interior lens (24 mm on full
/// frame is 53°), so that a wall and some floor and ceiling show.
const INSIDE_VFOV_DEG: f32 = 55.0;

/// Score the candidate views of the box `lo`–`hi` and choose one: the three-quarter view, the seven other
/// diagonal three-quarter views (front or back, left or right, above or below) and the six axis views, each
/// framed as the three-quarter view is; when every one of those sees more back faces than front and the
/// back faces lie on the bounds (a closed room seen from outside), also four views from inside, one towards
/// each horizontal side. Ties go to the earlier candidate; the three-quarter view is kept unless beaten by
/// the margins ([`TIE_MARGIN`]).
pub(crate) fn choose_view(
    lo: Vec3,
    hi: Vec3,
    up_axis: UpAxis,
    vfov: f32,
    aspect: f32,
    survey: &Survey<'_>,
) -> ViewChoice {
    let (front, right, up) = match up_axis {
        UpAxis::Y => (Vec3::Z, Vec3::X, Vec3::Y),
        UpAxis::Z => (Vec3::NEG_Y, Vec3::X, Vec3::Z),
    };
    let axis_name = |v: Vec3| {
        let (i, sign) = if v.x.abs() > 0.5 {
            (0, v.x)
        } else if v.y.abs() > 0.5 {
            (1, v.y)
        } else {
            (2, v.z)
        };
        format!("{}{}", if sign > 0.0 { "+" } else { "−" }, ["X", "Y", "Z"][i])
    };
    let (az, el) = (VIEW_AZIMUTH_DEG.to_radians(), VIEW_ELEVATION_DEG.to_radians());
    let diagonal = |side: f32, ahead: f32, above: f32| {
        (right * (side * az.sin() * el.cos()) + front * (ahead * az.cos() * el.cos()) + up * (above * el.sin()))
            .normalize()
    };
    let outside = |label: String, back: Vec3| {
        // A view along the up axis keeps the front at the bottom of the image.
        let cam_up = if back.dot(up).abs() > 0.99 { -front * back.dot(up).signum() } else { up };
        View { label, desc: framed_camera(lo, hi, back, cam_up, vfov, aspect), inside: false }
    };
    let word = |sign: f32, yes: &'static str, no: &'static str| if sign > 0.0 { yes } else { no };
    let mut views = Vec::new();
    // The default three-quarter view first (front, right, above), then in order of preference on ties.
    for (ahead, side, above) in [
        (1.0, 1.0, 1.0),
        (1.0, -1.0, 1.0),
        (-1.0, 1.0, 1.0),
        (-1.0, -1.0, 1.0),
        (1.0, 1.0, -1.0),
        (1.0, -1.0, -1.0),
        (-1.0, 1.0, -1.0),
        (-1.0, -1.0, -1.0),
    ] {
        let label = format!(
            "the {}-{}, {} (three-quarter)",
            word(ahead, "front", "back"),
            word(side, "right", "left"),
            word(above, "above", "below")
        );
        views.push(outside(label, diagonal(side, ahead, above)));
        if views.len() == 1 {
            // The axis views that show the front and the sides come right after the default view.
            for (name, back) in [("front", front), ("right", right), ("left", -right), ("top", up)] {
                views.push(outside(format!("{}, the {name} (axis-aligned)", axis_name(back)), back));
            }
        }
    }
    for (name, back) in [("back", -front), ("bottom", -up)] {
        views.push(outside(format!("{}, the {name} (axis-aligned)", axis_name(back)), back));
    }
    let mut candidates: Vec<(View, ViewScore)> = views
        .into_iter()
        .map(|v| {
            let score = survey.score(&v.desc, aspect);
            (v, score)
        })
        .collect();
    // A closed room: every outside view sees mostly back faces, and the default view's lie on the bounds.
    let kept = candidates[0].1;
    let room = candidates.iter().all(|(_, s)| s.back > s.front) && 2 * kept.back_on_bounds >= kept.back;
    if room {
        for towards in [-front, front, right, -right] {
            let view = inside_camera(lo, hi, towards, up);
            let score = survey.score(&view, aspect);
            let label = format!(
                "inside the room, near its {} wall looking towards {}",
                axis_name(-towards),
                axis_name(towards)
            );
            candidates.push((View { label, desc: view, inside: true }, score));
        }
    }
    // Views that meet fewer than half as many surfaces as the three-quarter view do not compete: a sliver
    // of front faces seen edge-on is no better view for being clean.
    let kept_hits = kept.front + kept.back;
    let mut index = 0;
    for (i, (_, s)) in candidates.iter().enumerate() {
        if 2 * (s.front + s.back) >= kept_hits && s.score > candidates[index].1.score {
            index = i;
        }
    }
    let best = candidates[index].1.score;
    if index != 0 && best - kept.score <= TIE_MARGIN.max(TIE_RATIO * kept.score) {
        index = 0;
    }
    ViewChoice { candidates, index }
}

/// A camera inside the box `lo`–`hi` (a room), near the wall opposite `towards`, a tenth of the height
/// above the centre, looking at the far wall a tenth below the centre, with [`INSIDE_VFOV_DEG`].
fn inside_camera(lo: Vec3, hi: Vec3, towards: Vec3, up: Vec3) -> CameraDesc {
    let center = 0.5 * (lo + hi);
    let extent = hi - lo;
    let depth = extent.dot(towards.abs());
    let height = extent.dot(up);
    CameraDesc {
        position: center - towards * (0.4 * depth) + up * (0.1 * height),
        look_at: center + towards * (0.5 * depth) - up * (0.1 * height),
        up,
        vfov_deg: INSIDE_VFOV_DEG,
        projection: Projection::Perspective,
        aspect_ratio: None,
        width: None,
        height: None,
    }
}

/// What the default view frames: the bounds of everything but ground planes much larger than the rest
/// ([`GROUND_RATIO`]), so that an object on a large floor fills the image instead of the floor; and a note
/// naming what was left out. `None` without geometry.
pub(crate) fn framing_bounds(
    desc: &geometry::SceneDescription,
    up_axis: UpAxis,
) -> (Option<(Vec3, Vec3)>, Option<String>) {
    let bounds = desc.bounds();
    let box_of = |points: &mut dyn Iterator<Item = Vec3>| {
        points.fold(None, |acc: Option<(Vec3, Vec3)>, p| Some(acc.map_or((p, p), |(lo, hi)| (lo.min(p), hi.max(p)))))
    };
    let mut items: Vec<(Vec3, Vec3, bool)> = Vec::new();
    for s in &desc.spheres {
        items.push((s.center() - Vec3::splat(s.radius()), s.center() + Vec3::splat(s.radius()), false));
    }
    for m in &desc.meshes {
        if let Some((lo, hi)) = box_of(&mut m.positions().iter().copied()) {
            items.push((lo, hi, true));
        }
    }
    for i in &desc.instances {
        if let Some((lo, hi)) = i.bounds() {
            items.push((lo, hi, false));
        }
    }
    let up = if up_axis == UpAxis::Z { 2 } else { 1 };
    // A mesh flat along the up axis (thinner than 1 % of its width) is a candidate ground plane.
    let flat = |(lo, hi, mesh): &(Vec3, Vec3, bool)| {
        let e = *hi - *lo;
        *mesh && e[up] <= 0.01 * e.max_element() && e.max_element() > 0.0
    };
    let Some((rest_lo, rest_hi)) =
        items.iter().filter(|i| !flat(i)).fold(None, |acc: Option<(Vec3, Vec3)>, (lo, hi, _)| {
            Some(acc.map_or((*lo, *hi), |(a, b)| (a.min(*lo), b.max(*hi))))
        })
    else {
        return (bounds, None);
    };
    let rest_size = (rest_hi - rest_lo).length();
    let mut framed = (rest_lo, rest_hi);
    let mut dropped = 0;
    for item in items.iter().filter(|i| flat(i)) {
        let (lo, hi, _) = *item;
        // Huge, and at or below the bottom of the rest: a ground plane.
        let ground = (hi - lo).max_element() > GROUND_RATIO * rest_size && hi[up] <= rest_lo[up] + 0.05 * rest_size;
        if ground {
            dropped += 1;
        } else {
            framed = (framed.0.min(lo), framed.1.max(hi));
        }
    }
    if dropped == 0 {
        return (bounds, None);
    }
    let note = format!(
        "{dropped} ground plane(s) more than {GROUND_RATIO}× the size of the rest of the scene left out of the default view's framing"
    );
    (Some(framed), Some(note))
}

/// A flat mesh at the bottom of the scene is a ground plane left out of the framing when it is wider than
/// this many times the diagonal of everything else (a studio floor under a product: the floor would
/// otherwise set the distance and leave the object a few pixels wide).
const GROUND_RATIO: f32 = 4.0;

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
    let (az, el) = (VIEW_AZIMUTH_DEG.to_radians(), VIEW_ELEVATION_DEG.to_radians());
    // `back`: from the centre towards the eye. Y-up fronts face +Z; Z-up fronts face −Y.
    let (back, up) = match up_axis {
        UpAxis::Y => (Vec3::new(az.sin() * el.cos(), el.sin(), az.cos() * el.cos()), Vec3::Y),
        UpAxis::Z => (Vec3::new(az.sin() * el.cos(), -az.cos() * el.cos(), el.sin()), Vec3::Z),
    };
    framed_camera(lo, hi, back, up, vfov_deg, aspect)
}

/// A camera on the unit direction `back` from the centre of the box `lo`–`hi`, looking at the centre with
/// `up` (not parallel to `back`), at the nearest distance where all eight corners lie within
/// [`FRAME_FILL`] of the half field of view, vertically and horizontally.
pub(crate) fn framed_camera(lo: Vec3, hi: Vec3, back: Vec3, up: Vec3, vfov_deg: f32, aspect: f32) -> CameraDesc {
    let center = 0.5 * (lo + hi);
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
        let chosen = choose_camera(SceneFormat::Obj, &[], None, None, &options, None, &mut warnings).unwrap();
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
        let c = choose_camera(SceneFormat::Gltf, &[], None, None, &down, None, &mut warnings).unwrap().desc;
        assert!(Camera::look_at(c.position, c.look_at, c.up, c.vfov_deg, 1.0).is_ok());
        // The same point twice, or a bad fov: errors that say so.
        let same = CameraOptions { look_from: Some(Vec3::ONE), look_at: Some(Vec3::ONE), ..CameraOptions::default() };
        assert!(choose_camera(SceneFormat::Obj, &[], None, None, &same, None, &mut warnings).is_err());
        let fov = CameraOptions { vfov_deg: Some(180.0), ..CameraOptions::default() };
        assert!(choose_camera(SceneFormat::Obj, &[], None, None, &fov, None, &mut warnings).is_err());
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
            choose_camera(SceneFormat::Gltf, &cameras, None, None, &options, None, w)
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
        choose_camera(SceneFormat::Obj, &[], flat, None, &CameraOptions::default(), None, &mut w).unwrap();
        assert_eq!(w.len(), 1, "{w:?}");
        assert!(w[0].contains("--up z"));
        let mut w = Vec::new();
        let z_up = CameraOptions { up: Some(UpAxis::Z), ..CameraOptions::default() };
        let c = choose_camera(SceneFormat::Obj, &[], flat, None, &z_up, None, &mut w).unwrap().desc;
        assert!(w.is_empty() && c.up == Vec3::Z && c.position.z > 0.0 && c.position.y < 0.0);
        let mut w = Vec::new();
        choose_camera(SceneFormat::Obj, &[], ground, None, &CameraOptions::default(), None, &mut w).unwrap();
        assert!(w.is_empty(), "{w:?}");
        let cube = Some((Vec3::splat(-1.0), Vec3::splat(1.0)));
        choose_camera(SceneFormat::Obj, &[], cube, None, &CameraOptions::default(), None, &mut w).unwrap();
        assert!(w.is_empty());
    }

    /// A flat mesh at the bottom, over four times the size of the rest, is a ground plane; one above the rest
    /// (a ceiling), or of comparable size, is framed.
    #[test]
    fn ground_planes_are_left_out_of_the_framing_and_nothing_else() {
        let cube = || {
            let p: Vec<Vec3> =
                (0..8).map(|i| Vec3::new((i & 1) as f32, ((i >> 1) & 1) as f32, ((i >> 2) & 1) as f32)).collect();
            geometry::Mesh::new(p, None, None, vec![[0, 1, 2], [1, 3, 2], [4, 6, 5], [5, 6, 7]], None).unwrap()
        };
        let plane = |half: f32, y: f32| {
            let p = vec![
                Vec3::new(-half, y, -half),
                Vec3::new(half, y, -half),
                Vec3::new(half, y, half),
                Vec3::new(-half, y, half),
            ];
            geometry::Mesh::new(p, None, None, vec![[0, 2, 1], [0, 3, 2]], None).unwrap()
        };
        let framing = |planes: Vec<geometry::Mesh>, up| {
            let mut d = geometry::SceneDescription::empty(SceneFormat::Obj);
            d.meshes.push(cube());
            d.meshes.extend(planes);
            framing_bounds(&d, up)
        };
        let unit = Some((Vec3::ZERO, Vec3::ONE));
        let (framed, note) = framing(vec![plane(50.0, 0.0)], UpAxis::Y);
        assert_eq!(framed, unit);
        assert!(note.unwrap().contains("1 ground plane"));
        // A ceiling, a floor of the cube's own size, and a floor under Z-up (the plane is then a wall) are framed.
        for (planes, up) in [
            (vec![plane(50.0, 1.0)], UpAxis::Y),
            (vec![plane(1.0, 0.0)], UpAxis::Y),
            (vec![plane(50.0, 0.0)], UpAxis::Z),
        ] {
            let (framed, note) = framing(planes, up);
            assert!(note.is_none() && framed.is_some_and(|(lo, hi)| hi.x - lo.x > 1.5), "{framed:?}");
        }
    }
}
