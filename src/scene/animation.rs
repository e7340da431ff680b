//! A glTF file's animations: keyframed translation, rotation and scale of nodes, sampled at a time
//! and composed down the node hierarchy to pose the meshes, the camera and the lights below them.
//!
//! The loader ([`super::gltf`]) fills an [`Animation`] with the nodes, the channels and a copy of
//! every animated mesh in its node's local space; [`Animation::pose`] places those copies exactly as
//! the loader places a static file's meshes (the same matrix from the same TRS, the same
//! [`Mesh::transform`], tangents made the same way), so a frame at time t is, bit for bit, the file
//! whose nodes hold the values sampled at t.

use super::{Mesh, Scene};
use glam::{Mat4, Quat, Vec3, Vec4};

/// How a channel's keyframes are joined (glTF `sampler.interpolation`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Interpolation {
    /// The value of the last keyframe at or before t.
    Step,
    /// Straight lines between keyframes; rotations by spherical interpolation.
    Linear,
    /// Cubic Hermite splines through the keyframes, with in- and out-tangents per keyframe (per
    /// second: scaled by the interval's length).
    CubicSpline,
}

/// Which of a node's transform properties a channel drives.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Property {
    /// `translation` (xyz).
    Translation,
    /// `rotation` (a unit quaternion, xyzw).
    Rotation,
    /// `scale` (xyz).
    Scale,
}

/// One animated property of one node.
#[derive(Clone, Debug)]
pub struct Channel {
    /// The node it moves.
    pub node: usize,
    /// What it drives.
    pub property: Property,
    /// How keyframes are joined.
    pub interpolation: Interpolation,
    /// Keyframe times in seconds, finite and strictly increasing.
    pub times: Vec<f32>,
    /// One value per keyframe (three for [`Interpolation::CubicSpline`]: in-tangent, value,
    /// out-tangent), vectors in xyz, quaternions in xyzw.
    pub values: Vec<Vec4>,
}

impl Channel {
    /// The channel's value at time `t` (seconds), held at the first and last keyframes outside them.
    pub fn sample(&self, t: f32) -> Vec4 {
        let times = &self.times;
        let cubic = self.interpolation == Interpolation::CubicSpline;
        let value = |k: usize| if cubic { self.values[3 * k + 1] } else { self.values[k] };
        let last = times.len() - 1;
        // NaN holds the first keyframe, as a time before the animation does.
        if t.is_nan() || t <= times[0] {
            return value(0);
        }
        if t >= times[last] {
            return value(last);
        }
        // The keyframe interval [times[k], times[k + 1]) holding t.
        let k = times.partition_point(|&key| key <= t) - 1;
        let interval = times[k + 1] - times[k];
        let s = (t - times[k]) / interval;
        let rotation = self.property == Property::Rotation;
        match self.interpolation {
            Interpolation::Step => value(k),
            Interpolation::Linear if rotation => {
                let (a, b) = (Quat::from_vec4(value(k)), Quat::from_vec4(value(k + 1)));
                Vec4::from(a.slerp(b, s))
            }
            Interpolation::Linear => value(k).lerp(value(k + 1), s),
            Interpolation::CubicSpline => {
                // glTF 2.0, Appendix C: p(s) = (2s³−3s²+1)v_k + (s³−2s²+s)·Δt·b_k + (−2s³+3s²)v_k+1
                // + (s³−s²)·Δt·a_k+1, with b_k the out-tangent of k and a_k+1 the in-tangent of k+1.
                let (s2, s3) = (s * s, s * s * s);
                let out_tangent = self.values[3 * k + 2] * interval;
                let in_tangent = self.values[3 * (k + 1)] * interval;
                let p = (2.0 * s3 - 3.0 * s2 + 1.0) * value(k)
                    + (s3 - 2.0 * s2 + s) * out_tangent
                    + (-2.0 * s3 + 3.0 * s2) * value(k + 1)
                    + (s3 - s2) * in_tangent;
                if rotation { p.normalize_or(Vec4::W) } else { p }
            }
        }
    }

    /// When the channel's last keyframe is.
    pub fn end(&self) -> f32 {
        self.times.last().copied().unwrap_or(0.0)
    }
}

/// A node's own transform as the file gives it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum LocalTransform {
    /// A matrix (glTF forbids animating such a node; its channels then act on its decomposition).
    Matrix(Mat4),
    /// Translation, rotation (as written, not yet normalised) and scale.
    Trs(Vec3, Quat, Vec3),
}

/// The node's matrix from translation `t`, rotation `q` and scale `s`, the rotation normalised
/// (exporters write quaternions rounded to a few digits; a non-unit one would also scale); `None`
/// for a rotation of zero length. The loader and the animation both build a node's matrix here,
/// which is what makes a frame equal the file posed at its time bit for bit.
pub fn trs_matrix(t: Vec3, q: Quat, s: Vec3) -> Option<Mat4> {
    let length = q.length();
    (length >= 1e-6).then(|| Mat4::from_scale_rotation_translation(s, q / length, t))
}

/// One node of the loaded scene's hierarchy.
#[derive(Clone, Debug)]
pub struct AnimatedNode {
    /// Its parent, or `None` for a root of the scene.
    pub parent: Option<usize>,
    /// Its transform as loaded.
    pub local: LocalTransform,
}

/// A mesh of the scene below an animated node, kept in its node's local space.
#[derive(Clone, Debug)]
pub struct AnimatedMesh {
    /// Its place in [`Scene::meshes`] once the scene is validated (`None` until then, or when
    /// validation removed it).
    pub index: Option<usize>,
    /// The node it hangs on.
    pub node: usize,
    /// The mesh in the node's space, as read from the file.
    pub local: Mesh,
    /// The texture coordinate set its normal map reads, when it has one and no tangents of its own
    /// (they are then made, as the loader makes them, in world space).
    pub tangents_from_uv: Option<usize>,
}

/// A KHR_lights_punctual light below an animated node.
#[derive(Clone, Debug)]
pub struct AnimatedLight {
    /// Its place in [`Scene::punctual_lights`].
    pub index: usize,
    /// The node it hangs on.
    pub node: usize,
}

/// Everything the file's animations move, and how.
#[derive(Clone, Debug, Default)]
pub struct Animation {
    /// Every node of the file, by index.
    pub nodes: Vec<AnimatedNode>,
    /// The scene's nodes, parents before children (the loader's walk).
    pub order: Vec<usize>,
    /// The channels, one per animated node property.
    pub channels: Vec<Channel>,
    /// The meshes below animated nodes.
    pub meshes: Vec<AnimatedMesh>,
    /// The camera's node, when the scene's camera is the file's and hangs below an animated node.
    pub camera: Option<usize>,
    /// The lights below animated nodes.
    pub lights: Vec<AnimatedLight>,
    /// The last keyframe of any channel, in seconds.
    pub duration: f32,
}

impl Animation {
    /// Every node's world transform at time `t`: its parent's times its own, its animated properties
    /// replaced by their values at `t`.
    pub fn world_transforms(&self, t: f32) -> Vec<Mat4> {
        let mut world = vec![Mat4::IDENTITY; self.nodes.len()];
        for &node in &self.order {
            let parent = self.nodes[node].parent.map_or(Mat4::IDENTITY, |p| world[p]);
            world[node] = parent * self.local_at(node, t);
        }
        world
    }

    /// Whether a channel drives node `node`.
    pub fn drives(&self, node: usize) -> bool {
        self.channels.iter().any(|c| c.node == node)
    }

    /// Node `node`'s translation, rotation (as it would be written) and scale at time `t`.
    pub fn node_trs(&self, node: usize, t: f32) -> (Vec3, Quat, Vec3) {
        let (mut translation, mut rotation, mut scale) = match self.nodes[node].local {
            LocalTransform::Trs(t, q, s) => (t, q, s),
            LocalTransform::Matrix(m) => {
                let (s, q, t) = m.to_scale_rotation_translation();
                (t, q, s)
            }
        };
        for channel in self.channels.iter().filter(|c| c.node == node) {
            let v = channel.sample(t);
            match channel.property {
                Property::Translation => translation = v.truncate(),
                Property::Rotation => rotation = Quat::from_vec4(v),
                Property::Scale => scale = v.truncate(),
            }
        }
        (translation, rotation, scale)
    }

    fn local_at(&self, node: usize, t: f32) -> Mat4 {
        let animated = self.drives(node);
        match self.nodes[node].local {
            LocalTransform::Matrix(m) if !animated => m,
            _ => {
                let (translation, rotation, scale) = self.node_trs(node, t);
                // A spline can pass through a zero quaternion: the rotation is then the node's own.
                trs_matrix(translation, rotation, scale).unwrap_or_else(|| {
                    let rest = match self.nodes[node].local {
                        LocalTransform::Trs(_, rotation, _) => rotation,
                        LocalTransform::Matrix(m) => m.to_scale_rotation_translation().1,
                    };
                    trs_matrix(translation, rest, scale).unwrap_or(Mat4::IDENTITY)
                })
            }
        }
    }

    /// Pose `scene` at time `t`: its animated meshes placed anew, its camera and lights moved. The
    /// indices of the meshes it replaced.
    pub fn pose(&self, scene: &mut Scene, t: f32) -> Vec<usize> {
        let world = self.world_transforms(t);
        let mut changed = Vec::with_capacity(self.meshes.len());
        for animated in &self.meshes {
            let Some(index) = animated.index else { continue };
            let Some(mesh) = scene.meshes.get_mut(index) else { continue };
            let mut posed = animated.local.clone();
            posed.transform(world[animated.node]);
            if let Some(set) = animated.tangents_from_uv
                && posed.tangents.is_none()
            {
                posed.tangents = super::tangents::generate(&posed, set);
            }
            super::validate::drop_degenerate_triangles(&mut posed);
            // What the loader and the run file set after placing it.
            posed.name = std::mem::take(&mut mesh.name);
            posed.node = mesh.node;
            posed.node_name = mesh.node_name.take();
            posed.motion = mesh.motion;
            *mesh = posed;
            changed.push(index);
        }
        if let (Some(node), Some(camera)) = (self.camera, scene.camera.as_mut()) {
            camera.camera_to_world = rigid(&world[node]);
        }
        for light in &self.lights {
            if let Some(desc) = scene.punctual_lights.get_mut(light.index) {
                let m = world[light.node];
                desc.position = m.transform_point3(Vec3::ZERO);
                desc.direction = m.transform_vector3(Vec3::NEG_Z).normalize_or_zero();
            }
        }
        changed
    }

    /// Point [`AnimatedMesh::index`] at the meshes of the validated `meshes` (matched by name, which
    /// names node, mesh and primitive).
    pub fn resolve(&mut self, meshes: &[Mesh]) {
        let by_name: std::collections::HashMap<&str, usize> =
            meshes.iter().enumerate().map(|(i, m)| (m.name.as_str(), i)).collect();
        for animated in &mut self.meshes {
            animated.index = by_name.get(animated.local.name.as_str()).copied();
        }
    }
}

/// A camera's world transform without scale or shear: keeps the viewing direction (-Z) and then
/// up (+Y) exact.
pub fn rigid(world: &Mat4) -> Mat4 {
    let z = world.z_axis.truncate().normalize();
    let y = world.y_axis.truncate().reject_from_normalized(z).normalize();
    let x = y.cross(z);
    Mat4::from_cols(x.extend(0.0), y.extend(0.0), z.extend(0.0), world.w_axis.truncate().extend(1.0))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn channel(property: Property, interpolation: Interpolation, times: &[f32], values: &[Vec4]) -> Channel {
        Channel { node: 0, property, interpolation, times: times.to_vec(), values: values.to_vec() }
    }

    /// A cubic Hermite spline with the derivatives as tangents reproduces a cubic polynomial
    /// exactly: an independent check of the spline, and of its tangents being per second (scaled by
    /// the interval, here 2.5 s and 0.5 s, not 1).
    #[test]
    fn cubic_spline_reproduces_a_cubic_with_its_derivatives_as_tangents() {
        let f = |t: f32| 0.3 * t * t * t - 1.2 * t * t + 0.5 * t + 2.0;
        let df = |t: f32| 0.9 * t * t - 2.4 * t + 0.5;
        let times = [0.0, 2.5, 3.0];
        let values: Vec<Vec4> =
            times.iter().flat_map(|&t| [Vec4::splat(df(t)), Vec4::splat(f(t)), Vec4::splat(df(t))]).collect();
        let c = channel(Property::Translation, Interpolation::CubicSpline, &times, &values);
        for i in 0..=60 {
            let t = i as f32 * 0.05;
            let got = c.sample(t).x;
            assert!((got - f(t)).abs() < 1e-4, "t {t}: {got} vs {}", f(t));
        }
        // Tangents taken per unit of the spline parameter (not scaled) miss the polynomial: by
        // 0.09 at 1 s, far outside the tolerance above.
        let unscaled = |t: f32| {
            let s = t / 2.5;
            let (s2, s3) = (s * s, s * s * s);
            (2.0 * s3 - 3.0 * s2 + 1.0) * f(0.0)
                + (s3 - 2.0 * s2 + s) * df(0.0)
                + (-2.0 * s3 + 3.0 * s2) * f(2.5)
                + (s3 - s2) * df(2.5)
        };
        let miss = (unscaled(1.0) - f(1.0)).abs();
        assert!(miss > 0.05, "unscaled tangents miss by {miss}");
    }

    /// STEP holds each keyframe's value until the next; LINEAR interpolates; both hold the end
    /// values outside the keyframes.
    #[test]
    fn step_and_linear_follow_the_keyframes() {
        let values = [Vec4::ZERO, Vec4::splat(4.0), Vec4::splat(-2.0)];
        let step = channel(Property::Scale, Interpolation::Step, &[1.0, 2.0, 4.0], &values);
        let linear = channel(Property::Scale, Interpolation::Linear, &[1.0, 2.0, 4.0], &values);
        for (t, s, l) in [
            (0.0, 0.0, 0.0),
            (1.0, 0.0, 0.0),
            (1.5, 0.0, 2.0),
            (2.0, 4.0, 4.0),
            (3.0, 4.0, 1.0),
            (3.999, 4.0, -1.997),
            (4.0, -2.0, -2.0),
            (9.0, -2.0, -2.0),
        ] {
            assert_eq!(step.sample(t).x, s, "step at {t}");
            assert!((linear.sample(t).x - l).abs() < 1e-5, "linear at {t}: {}", linear.sample(t).x);
        }
    }

    /// LINEAR rotations turn at a constant rate along the shorter arc (slerp), whatever the sign
    /// the file gives the second quaternion.
    #[test]
    fn linear_rotation_is_slerp_along_the_shorter_arc() {
        let a = Quat::IDENTITY;
        let b = Quat::from_rotation_y(2.0);
        for sign in [1.0, -1.0] {
            let c = channel(
                Property::Rotation,
                Interpolation::Linear,
                &[0.0, 1.0],
                &[Vec4::from(a), Vec4::from(b) * sign],
            );
            for s in [0.25, 0.5, 0.75] {
                let q = Quat::from_vec4(c.sample(s));
                let expected = Quat::from_rotation_y(2.0 * s);
                assert!(q.dot(expected).abs() > 1.0 - 1e-6, "s {s}: {q} vs {expected}");
            }
        }
    }
}
