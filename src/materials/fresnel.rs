//! Fresnel reflectance (exact dielectric and Schlick) and the mirror/refraction directions it goes with.

use glam::Vec3;

/// Unpolarized Fresnel reflectance of a smooth dielectric interface (pbrt-v4 `FrDielectric`).
///
/// `cos_theta_i` is the cosine between the incident direction and the normal on the outside;
/// a negative cosine means the direction is inside, so the interface is seen with `1 / eta`.
/// `eta` is the IOR of the inside over the IOR of the outside. Returns 1 under total internal reflection.
#[inline]
pub fn fresnel_dielectric(cos_theta_i: f32, eta: f32) -> f32 {
    let mut cos_i = cos_theta_i.clamp(-1.0, 1.0);
    let mut eta = eta;
    if cos_i < 0.0 {
        eta = 1.0 / eta;
        cos_i = -cos_i;
    }
    // Snell's law: sin_t = sin_i / eta.
    let sin2_t = (1.0 - cos_i * cos_i).max(0.0) / (eta * eta);
    if sin2_t >= 1.0 {
        return 1.0;
    }
    let cos_t = (1.0 - sin2_t).max(0.0).sqrt();
    // Fresnel equations for parallel and perpendicular polarization (Born & Wolf 1999, §1.5.2).
    let r_parl = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
    let r_perp = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
    0.5 * (r_parl * r_parl + r_perp * r_perp)
}

/// Reflectance at normal incidence of an interface with relative IOR `eta`: ((eta - 1) / (eta + 1))².
#[inline]
pub fn f0_from_ior(eta: f32) -> f32 {
    let r = (eta - 1.0) / (eta + 1.0);
    r * r
}

/// Schlick's approximation with an explicit grazing value (Schlick 1994; glTF `F90`):
/// `F = F0 + (F90 - F0) (1 - cos)^5`.
#[inline]
pub fn schlick(f0: Vec3, f90: f32, cos_theta: f32) -> Vec3 {
    f0 + (Vec3::splat(f90) - f0) * schlick_weight(cos_theta)
}

/// Scalar form of [`schlick`].
#[inline]
pub fn schlick_scalar(f0: f32, f90: f32, cos_theta: f32) -> f32 {
    f0 + (f90 - f0) * schlick_weight(cos_theta)
}

/// `(1 - |cos|)^5`, the Schlick interpolation weight.
#[inline]
fn schlick_weight(cos_theta: f32) -> f32 {
    let m = (1.0 - cos_theta.abs()).clamp(0.0, 1.0);
    let m2 = m * m;
    m2 * m2 * m
}

/// Mirror `wo` about the unit normal `n`.
#[inline]
pub fn reflect(wo: Vec3, n: Vec3) -> Vec3 {
    -wo + 2.0 * wo.dot(n) * n
}

/// Refract `wi` through the interface with normal `n` and relative IOR `eta` (inside over outside).
///
/// `wi` points away from the surface; `n` may be on either side (pbrt-v4 `Refract`). Returns the
/// transmitted direction and `etap`, the relative IOR actually crossed (`eta` when entering, `1 / eta`
/// when leaving), or `None` under total internal reflection.
#[inline]
pub fn refract(wi: Vec3, n: Vec3, eta: f32) -> Option<(Vec3, f32)> {
    let mut cos_i = n.dot(wi);
    let (mut n, mut eta) = (n, eta);
    if cos_i < 0.0 {
        eta = 1.0 / eta;
        cos_i = -cos_i;
        n = -n;
    }
    let sin2_i = (1.0 - cos_i * cos_i).max(0.0);
    let sin2_t = sin2_i / (eta * eta);
    if sin2_t >= 1.0 {
        return None;
    }
    let cos_t = (1.0 - sin2_t).max(0.0).sqrt();
    Some((-wi / eta + (cos_i / eta - cos_t) * n, eta))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn normal_incidence_reflectance_is_squared_ior_ratio() {
        for eta in [1.1f32, 1.33, 1.5, 2.4] {
            let expected = f0_from_ior(eta);
            assert!((fresnel_dielectric(1.0, eta) - expected).abs() < 1e-6, "eta {eta}");
            // Seen from inside, normal incidence gives the same reflectance.
            assert!((fresnel_dielectric(-1.0, eta) - expected).abs() < 1e-6, "eta {eta} inside");
        }
    }

    #[test]
    fn reflectance_is_one_beyond_the_critical_angle() {
        let eta = 1.5f32;
        let cos_critical = (1.0 - 1.0 / (eta * eta)).sqrt();
        for cos in [cos_critical * 0.99, 0.5, 0.1, 0.0] {
            assert_eq!(fresnel_dielectric(-cos, eta), 1.0, "inside at cos {cos}");
        }
        assert!(fresnel_dielectric(-(cos_critical + 0.01), eta) < 1.0);
    }

    #[test]
    fn index_matched_interface_does_not_reflect() {
        for cos in [1.0f32, 0.7, 0.2, 0.01, -0.5] {
            assert!(fresnel_dielectric(cos, 1.0).abs() < 1e-7, "cos {cos}");
        }
        assert_eq!(f0_from_ior(1.0), 0.0);
    }

    #[test]
    fn reflectance_grows_to_one_at_grazing_incidence() {
        let mut last = 0.0;
        for i in 0..=100 {
            let cos = 1.0 - i as f32 / 100.0;
            let f = fresnel_dielectric(cos, 1.5);
            assert!(f >= last - 1e-6 && f <= 1.0);
            last = f;
        }
        assert!((last - 1.0).abs() < 1e-6);
    }

    #[test]
    fn schlick_hits_its_end_points() {
        let f0 = Vec3::new(0.9, 0.5, 0.1);
        assert!((schlick(f0, 1.0, 1.0) - f0).abs().max_element() < 1e-7);
        assert!((schlick(f0, 1.0, 0.0) - Vec3::ONE).abs().max_element() < 1e-7);
        assert_eq!(schlick_scalar(0.0, 0.0, 0.3), 0.0);
    }

    #[test]
    fn refraction_obeys_snell_and_reverses() {
        let eta = 1.5;
        let wi = Vec3::new(0.6, 0.0, 0.8);
        let (wt, etap) = refract(wi, Vec3::Z, eta).unwrap();
        assert_eq!(etap, eta);
        assert!(wt.z < 0.0 && (wt.length() - 1.0).abs() < 1e-6);
        let sin_i = (1.0 - wi.z * wi.z).sqrt();
        let sin_t = (1.0 - wt.z * wt.z).sqrt();
        assert!((sin_i - eta * sin_t).abs() < 1e-6);
        let (back, etap_back) = refract(wt, Vec3::Z, eta).unwrap();
        assert!((back - wi).length() < 1e-6);
        assert!((etap_back - 1.0 / eta).abs() < 1e-7);
        // Grazing from inside: total internal reflection.
        assert!(refract(Vec3::new(0.9, 0.0, -0.1).normalize(), Vec3::Z, eta).is_none());
    }
}
