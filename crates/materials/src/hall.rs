//! The paper's shading terms (Lee, Lee, Lee & Ha 2004, eqs. 6–7, after Hall & Greenberg
//! 1983) as pure functions of directions. Spectral factors (F_d, F_s, T_s, light SPD) are
//! applied by the integrator; these return the geometric weights.
//!
//! Directions point away from the surface: `n` the shading normal facing the viewer, `v`
//! towards the viewer, `l` towards the light. See `docs/paper-model.md` for the choices made
//! where the paper is ambiguous (notably: highlights use Hall's half vector, not (L·N)^n).

use glam::Vec3;

/// Eq. 6, diffuse term: the cosine (N·L), zero for lights behind the surface.
#[inline]
pub fn diffuse_weight(n: Vec3, l: Vec3) -> f32 {
    n.dot(l).max(0.0)
}

/// Eq. 6, specular highlight: (N·H)^n with H = normalise(L + V) (Hall's form; the paper
/// prints (L·N)^n, which has no highlight that moves with the viewer).
#[inline]
pub fn specular_weight(n: Vec3, v: Vec3, l: Vec3, shininess: f32) -> f32 {
    if n.dot(l) <= 0.0 {
        return 0.0;
    }
    let h = (l + v).normalize_or_zero();
    n.dot(h).max(0.0).powf(shininess)
}

/// Eq. 7, transmitted highlight: (N·H′)^n for a light on the far side of a transparent
/// surface, with Hall's transmission half vector H′ generalised as in Walter et al. 2007:
/// H′ ∝ −(η_v V + η_l L), where `eta_v` and `eta_l` are the indices of the media on the
/// viewer's and the light's sides. Zero unless the light is behind the surface.
#[inline]
pub fn transmission_weight(n: Vec3, v: Vec3, l: Vec3, eta_v: f32, eta_l: f32, shininess: f32) -> f32 {
    if n.dot(l) >= 0.0 || eta_v == eta_l {
        // Same side, or no refraction at all (H′ undefined: the light is seen straight through,
        // which the refracted ray already accounts for).
        return 0.0;
    }
    let h = -(eta_v * v + eta_l * l);
    let h = h.normalize_or_zero();
    n.dot(h).abs().powf(shininess)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn diffuse_is_the_clamped_cosine() {
        let l = Vec3::new(0.0, 0.6, 0.8);
        assert!((diffuse_weight(Vec3::Z, l) - 0.8).abs() < 1e-6);
        assert_eq!(diffuse_weight(Vec3::Z, -l), 0.0);
    }

    #[test]
    fn specular_peaks_in_the_mirror_direction() {
        let l = Vec3::new(0.6, 0.0, 0.8);
        let mirror = Vec3::new(-0.6, 0.0, 0.8);
        assert!((specular_weight(Vec3::Z, mirror, l, 20.0) - 1.0).abs() < 1e-5);
        let off = Vec3::new(-0.3, 0.3, 0.9).normalize();
        assert!(specular_weight(Vec3::Z, off, l, 20.0) < 0.9);
        assert_eq!(specular_weight(Vec3::Z, mirror, -l, 20.0), 0.0);
    }

    #[test]
    fn transmission_highlight_peaks_along_the_refracted_direction() {
        // Viewer outside (η = 1) looking down into glass (η = 1.3); the light below, along
        // the direction that refracts into the viewer: then H′ is the normal.
        let eta = 1.3f32;
        let v = Vec3::new(0.5, 0.0, 0.866_025_4); // 30° from the normal
        let (t, _) = crate::scattering::refract(v, Vec3::Z, eta).unwrap();
        let w = transmission_weight(Vec3::Z, v, t, 1.0, eta, 20.0);
        assert!((w - 1.0).abs() < 1e-4, "{w}");
        assert_eq!(transmission_weight(Vec3::Z, v, -t, 1.0, eta, 20.0), 0.0);
    }
}
