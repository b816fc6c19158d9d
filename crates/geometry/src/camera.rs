//! Cameras: a perspective pinhole, or an orthographic projection.

use glam::Vec3;

use crate::error::{Error, Result};
use crate::ray::Ray;

/// A camera looking from `position` towards a target: a pinhole (rays from `position`) or orthographic
/// (parallel rays from a rectangle through `position`, perpendicular to the view).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Camera {
    position: Vec3,
    forward: Vec3,
    right: Vec3,
    up: Vec3,
    /// Pinhole: tan(vfov / 2), the half height of the image plane at distance 1. Orthographic: the half
    /// height of the viewed rectangle.
    tan_half_fov: f32,
    aspect: f32,
    orthographic: bool,
}

impl Camera {
    /// A camera at `position` looking at `target`, `up` roughly up, vertical field of view
    /// `vfov_deg` in (0, 180), `aspect` = width / height.
    pub fn look_at(position: Vec3, target: Vec3, up: Vec3, vfov_deg: f32, aspect: f32) -> Result<Self> {
        if !(position.is_finite() && target.is_finite() && up.is_finite()) {
            return Err(Error::Camera("position, target and up must be finite".to_owned()));
        }
        let forward =
            (target - position).try_normalize().ok_or_else(|| Error::Camera("target equals position".into()))?;
        let right =
            forward.cross(up).try_normalize().ok_or_else(|| Error::Camera("up is parallel to the view".into()))?;
        if !(vfov_deg > 0.0 && vfov_deg < 180.0) {
            return Err(Error::Camera(format!("vertical field of view {vfov_deg}° is outside (0, 180)")));
        }
        if !(aspect > 0.0 && aspect.is_finite()) {
            return Err(Error::Camera(format!("aspect ratio {aspect} must be > 0")));
        }
        let up = right.cross(forward);
        Ok(Self {
            position,
            forward,
            right,
            up,
            tan_half_fov: (vfov_deg.to_radians() * 0.5).tan(),
            aspect,
            orthographic: false,
        })
    }

    /// An orthographic camera at `position` looking at `target`, `up` roughly up, seeing a rectangle
    /// `2·half_height` high (scene units) and `aspect` (= width / height) times as wide, centred on
    /// `position` and perpendicular to the view; rays start on that rectangle.
    pub fn orthographic(position: Vec3, target: Vec3, up: Vec3, half_height: f32, aspect: f32) -> Result<Self> {
        if !(half_height > 0.0 && half_height.is_finite()) {
            return Err(Error::Camera(format!("orthographic half height {half_height} must be finite and > 0")));
        }
        // The basis and its checks are the pinhole's (any valid field of view: it is replaced).
        let pinhole = Self::look_at(position, target, up, 90.0, aspect)?;
        Ok(Self { tan_half_fov: half_height, orthographic: true, ..pinhole })
    }

    /// The ray through image position (`x`, `y`) in pixels (y down) of a `width`×`height`
    /// image; unit direction.
    #[inline]
    pub fn generate_ray(&self, x: f32, y: f32, width: u32, height: u32) -> Ray {
        if self.orthographic {
            return self.orthographic_ray(x, y, width, height);
        }
        let sx = (2.0 * x / width as f32 - 1.0) * self.tan_half_fov * self.aspect;
        let sy = (1.0 - 2.0 * y / height as f32) * self.tan_half_fov;
        let dir = (self.forward + sx * self.right + sy * self.up).normalize();
        Ray { origin: self.position, dir }
    }

    /// Out of line, so that the pinhole's rays pay only the test (callgrind: 6 instructions per ray
    /// inline, on the Cornell box).
    #[inline(never)]
    fn orthographic_ray(&self, x: f32, y: f32, width: u32, height: u32) -> Ray {
        let sx = (2.0 * x / width as f32 - 1.0) * self.tan_half_fov * self.aspect;
        let sy = (1.0 - 2.0 * y / height as f32) * self.tan_half_fov;
        Ray { origin: self.position + sx * self.right + sy * self.up, dir: self.forward }
    }

    /// Where a pinhole camera sees the point `p`: its image position (`x`, `y`) in pixels (y down, as
    /// [`Camera::generate_ray`] takes them) in a `width`×`height` image and the cosine between the view
    /// axis and the direction to `p`; `None` behind the camera, outside the image, or for an orthographic
    /// camera (light tracing connects to a pinhole only).
    pub fn raster_of(&self, p: Vec3, width: u32, height: u32) -> Option<(f32, f32, f32)> {
        if self.orthographic {
            return None;
        }
        let d = p - self.position;
        let z = d.dot(self.forward);
        let length = d.length();
        if !(z > 0.0 && length > 0.0 && length.is_finite()) {
            return None;
        }
        let sx = d.dot(self.right) / (z * self.tan_half_fov * self.aspect);
        let sy = d.dot(self.up) / (z * self.tan_half_fov);
        let x = (sx + 1.0) * 0.5 * width as f32;
        let y = (1.0 - sy) * 0.5 * height as f32;
        let inside = (0.0..width as f32).contains(&x) && (0.0..height as f32).contains(&y);
        inside.then_some((x, y, z / length))
    }

    /// The area of a pinhole camera's image plane at distance 1 from the eye (pbrt-v4's `A` of
    /// `PerspectiveCamera`): the importance it emits along a ray at angle θ to the axis is
    /// 1 / (A cos⁴ θ), so that it integrates to 1 over the image.
    pub fn image_plane_area(&self) -> f32 {
        4.0 * self.tan_half_fov * self.tan_half_fov * self.aspect
    }

    /// The unit view direction.
    pub fn forward(&self) -> Vec3 {
        self.forward
    }

    /// Whether rays are parallel (orthographic) rather than from the eye.
    pub fn is_orthographic(&self) -> bool {
        self.orthographic
    }

    /// Where the camera is (an orthographic camera: the centre of its rectangle).
    pub fn position(&self) -> Vec3 {
        self.position
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A point seen through a pixel projects back to that pixel, at the ray's cosine to the axis.
    #[test]
    fn raster_of_inverts_generate_ray() {
        let c = Camera::look_at(Vec3::new(1.0, 2.0, 5.0), Vec3::ZERO, Vec3::Y, 40.0, 1.5).unwrap();
        for (x, y) in [(0.5, 0.5), (299.25, 1.0), (150.0, 100.0), (17.3, 199.9)] {
            let r = c.generate_ray(x, y, 300, 200);
            let (px, py, cos) = c.raster_of(r.origin + 7.0 * r.dir, 300, 200).unwrap();
            assert!((px - x).abs() < 1e-3 && (py - y).abs() < 1e-3, "({x}, {y}) → ({px}, {py})");
            assert!((cos - r.dir.dot(c.forward())).abs() < 1e-6);
        }
        assert!(c.raster_of(Vec3::new(1.0, 2.0, 10.0), 300, 200).is_none(), "behind the camera");
        // tan 20° squared × 4 × 1.5.
        assert!((c.image_plane_area() - 4.0 * 0.363_970_23f32.powi(2) * 1.5).abs() < 1e-5);
    }

    /// An orthographic camera 2 high and 4 wide (aspect 2) at z = 5 looking down −z: every ray points
    /// along −z, and the image's corners and centre start at the rectangle's corners and centre.
    #[test]
    fn orthographic_rays_are_parallel_and_start_on_the_rectangle() {
        let c = Camera::orthographic(Vec3::new(0.0, 0.0, 5.0), Vec3::ZERO, Vec3::Y, 1.0, 2.0).unwrap();
        assert!(c.is_orthographic());
        for (x, y, origin) in [
            (0.0, 0.0, Vec3::new(-2.0, 1.0, 5.0)),
            (200.0, 100.0, Vec3::new(2.0, -1.0, 5.0)),
            (100.0, 50.0, Vec3::new(0.0, 0.0, 5.0)),
            (150.0, 25.0, Vec3::new(1.0, 0.5, 5.0)),
        ] {
            let r = c.generate_ray(x, y, 200, 100);
            assert_eq!(r.dir, Vec3::NEG_Z);
            assert!((r.origin - origin).length() < 1e-6, "({x}, {y}): {}", r.origin);
        }
        assert!(Camera::orthographic(Vec3::ZERO, Vec3::Z, Vec3::Y, 0.0, 1.0).is_err());
        assert!(Camera::orthographic(Vec3::ZERO, Vec3::Z, Vec3::Z, 1.0, 1.0).is_err());
    }
}
