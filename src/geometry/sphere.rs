//! Ray–sphere intersection with a reprojected hit point and its error bound (pbrt-v4 `Sphere`).

use super::offset::gamma;
use glam::Vec3;

/// Smallest `t` in (0, t_max) where `o + t·d` meets the sphere, if any.
#[inline]
pub fn intersect_sphere(o: Vec3, d: Vec3, t_max: f32, center: Vec3, radius: f32) -> Option<f32> {
    let oi = o - center;
    let a = d.length_squared();
    let b = 2.0 * d.dot(oi);
    let c = oi.length_squared() - radius * radius;
    // Discriminant from the distance of the centre to the ray's line (Haines et al., Ray Tracing Gems
    // ch. 7): it stays accurate when the ray passes far from a small sphere, where b² − 4ac cancels.
    let v = oi - (b / (2.0 * a)) * d;
    let len = v.length();
    let discrim = 4.0 * a * (radius + len) * (radius - len);
    if discrim < 0.0 {
        return None;
    }
    let root = discrim.sqrt();
    let q = if b < 0.0 { -0.5 * (b - root) } else { -0.5 * (b + root) };
    let (mut t0, mut t1) = (q / a, c / q);
    if t0 > t1 {
        std::mem::swap(&mut t0, &mut t1);
    }
    if t0 > t_max || t1 <= 0.0 {
        return None;
    }
    let t = if t0 > 0.0 { t0 } else { t1 };
    (t < t_max && t > 0.0).then_some(t)
}

/// Hit point reprojected onto the sphere, and a conservative bound on its error.
#[inline]
pub fn sphere_hit_point(o: Vec3, d: Vec3, t: f32, center: Vec3, radius: f32) -> (Vec3, Vec3) {
    let local = (o - center) + t * d;
    let local = local * (radius / local.length());
    let p = center + local;
    (p, gamma(5) * local.abs() + gamma(1) * p.abs())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ray_from_outside_hits_near_side_and_from_inside_hits_far_side() {
        let c = Vec3::new(0.0, 0.0, -5.0);
        let t = intersect_sphere(Vec3::ZERO, -Vec3::Z, f32::INFINITY, c, 1.0).unwrap();
        assert!((t - 4.0).abs() < 1e-5);
        let t = intersect_sphere(c, Vec3::X, f32::INFINITY, c, 1.0).unwrap();
        assert!((t - 1.0).abs() < 1e-5);
        assert!(intersect_sphere(Vec3::ZERO, Vec3::Z, f32::INFINITY, c, 1.0).is_none());
        assert!(intersect_sphere(Vec3::ZERO, -Vec3::Z, 3.0, c, 1.0).is_none());
    }
}
