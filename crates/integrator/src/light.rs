//! Lights: where they are and what spectrum they emit.

use colorimetry::DenselySampledSpectrum;
use glam::Vec3;

/// The shape of a light.
#[derive(Debug, Clone, Copy)]
pub(crate) enum LightKind {
    /// A point light (the paper's D65 source).
    Point { position: Vec3 },
    /// A spot light with a smooth fall-off between the inner and outer cone.
    Spot { position: Vec3, direction: Vec3, cos_inner: f32, cos_outer: f32 },
    /// A distant light; `direction` is the way the light travels.
    Directional { direction: Vec3 },
    /// A uniform environment, seen by escaping rays and illuminating from every direction.
    Environment,
}

/// A light with its emission spectrum (luminance-normalised × intensity).
#[derive(Debug, Clone)]
pub(crate) struct Light {
    pub(crate) kind: LightKind,
    pub(crate) spectrum: DenselySampledSpectrum,
}

/// Where a light is seen from a shading point.
#[derive(Debug, Clone, Copy)]
pub(crate) struct LightSample {
    /// Unit direction from the point towards the light.
    pub(crate) wi: Vec3,
    /// Distance to the light (infinite for directional lights).
    pub(crate) distance: f32,
    /// Position of the light (for shadow rays); meaningless for directional lights.
    pub(crate) position: Vec3,
    /// Inverse-square fall-off times a spot light's angular fall-off (1 for directional lights).
    pub(crate) falloff: f32,
}

impl Light {
    pub(crate) fn new(kind: LightKind, spectrum: DenselySampledSpectrum) -> Self {
        Self { kind, spectrum }
    }

    /// Direction and distance to the light from `p`; `None` for lights without a position
    /// or direction (the environment) and for points exactly at the light.
    #[inline]
    pub(crate) fn sample_from(&self, p: Vec3) -> Option<LightSample> {
        match self.kind {
            LightKind::Point { position } => point_sample(p, position, 1.0),
            LightKind::Spot { position, direction, cos_inner, cos_outer } => {
                let s = point_sample(p, position, 1.0)?;
                let cos = (-s.wi).dot(direction);
                let cone = smoothstep(cos_outer, cos_inner, cos);
                (cone > 0.0).then_some(LightSample { falloff: s.falloff * cone, ..s })
            }
            LightKind::Directional { direction } => Some(LightSample {
                wi: -direction,
                distance: f32::INFINITY,
                position: p - direction * 1e30,
                falloff: 1.0,
            }),
            LightKind::Environment => None,
        }
    }
}

fn point_sample(p: Vec3, position: Vec3, falloff: f32) -> Option<LightSample> {
    let d = position - p;
    let distance = d.length();
    // Inverse-square law: a light of intensity I gives irradiance I / d² at normal incidence.
    (distance > 0.0 && distance.is_finite()).then(|| LightSample {
        wi: d / distance,
        distance,
        position,
        falloff: falloff / (distance * distance),
    })
}

/// pbrt-v4's `SmoothStep`: 0 below `a`, 1 above `b`, a cubic in between.
fn smoothstep(a: f32, b: f32, x: f32) -> f32 {
    if a == b {
        return if x < a { 0.0 } else { 1.0 };
    }
    let t = ((x - a) / (b - a)).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn spot_falloff_is_one_inside_and_zero_outside() {
        let light = Light::new(
            LightKind::Spot {
                position: Vec3::ZERO,
                direction: Vec3::NEG_Y,
                cos_inner: 20f32.to_radians().cos(),
                cos_outer: 30f32.to_radians().cos(),
            },
            DenselySampledSpectrum::constant(1.0),
        );
        assert_eq!(light.sample_from(Vec3::new(0.0, -1.0, 0.0)).unwrap().falloff, 1.0);
        // Inverse square: twice as far, a quarter of the light.
        assert_eq!(light.sample_from(Vec3::new(0.0, -2.0, 0.0)).unwrap().falloff, 0.25);
        let outside = Vec3::new(1.0, -1.0, 0.0); // 45°
        assert!(light.sample_from(outside).is_none());
    }
}
