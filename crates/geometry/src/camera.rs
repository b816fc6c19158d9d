//! A perspective pinhole camera.

use glam::Vec3;

use crate::error::{Error, Result};
use crate::ray::Ray;

/// A pinhole camera looking from `position` towards a target.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Camera {
    position: Vec3,
    forward: Vec3,
    right: Vec3,
    up: Vec3,
    tan_half_fov: f32,
    aspect: f32,
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
        Ok(Self { position, forward, right, up, tan_half_fov: (vfov_deg.to_radians() * 0.5).tan(), aspect })
    }

    /// The ray through image position (`x`, `y`) in pixels (y down) of a `width`×`height`
    /// image; unit direction.
    #[inline]
    pub fn generate_ray(&self, x: f32, y: f32, width: u32, height: u32) -> Ray {
        let sx = (2.0 * x / width as f32 - 1.0) * self.tan_half_fov * self.aspect;
        let sy = (1.0 - 2.0 * y / height as f32) * self.tan_half_fov;
        let dir = (self.forward + sx * self.right + sy * self.up).normalize();
        Ray { origin: self.position, dir }
    }

    /// Where the camera is.
    pub fn position(&self) -> Vec3 {
        self.position
    }
}
