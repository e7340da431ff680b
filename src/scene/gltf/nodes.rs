//! Nodes and cameras: local transforms composed down the hierarchy, checked, and the perspective
//! camera picked by name.

use super::{Loader, label};
use crate::error::Result;
use crate::scene::CameraDesc;
use crate::scene::animation::{rigid, trs_matrix};
use crate::scene::punctual::{PunctualKind, PunctualLightDesc};
use glam::{Mat3, Mat4, Quat, Vec3};
use tracing::warn;

/// A camera node met during traversal.
pub(super) struct CameraNode {
    node: String,
    camera_name: Option<String>,
    node_name: Option<String>,
    /// `None` for orthographic cameras.
    perspective: Option<(f32, Option<f32>)>,
    world: Mat4,
    /// Its node's index, when an animation moves it.
    animated_node: Option<usize>,
}

impl Loader<'_> {
    pub(super) fn local_transform(&self, node: &gltf::Node, object: &str) -> Result<Mat4> {
        let non_finite = || self.invalid(object, "transform has a NaN or infinite entry");
        match node.transform() {
            gltf::scene::Transform::Matrix { matrix } => {
                let m = Mat4::from_cols_array_2d(&matrix);
                if m.is_finite() { Ok(m) } else { Err(non_finite()) }
            }
            gltf::scene::Transform::Decomposed { translation, rotation, scale } => {
                let (t, q, s) = (Vec3::from(translation), Quat::from_array(rotation), Vec3::from(scale));
                if !(t.is_finite() && q.is_finite() && s.is_finite()) {
                    return Err(non_finite());
                }
                trs_matrix(t, q, s).ok_or_else(|| self.invalid(object, "rotation quaternion has zero length"))
            }
        }
    }

    pub(super) fn check_invertible(&self, world: &Mat4, object: &str) -> Result<()> {
        let m = Mat3::from_mat4(*world).as_dmat3();
        let scale = m.x_axis.length() * m.y_axis.length() * m.z_axis.length();
        // Relative to the axes' lengths, so that millimetre-scaled scenes are not taken as singular.
        let invertible = m.determinant().abs() > 1e-9 * scale;
        if !invertible {
            return Err(self.invalid(
                object,
                format!(
                    "transform is singular (determinant {:e}): a zero scale or collapsed axis flattens it",
                    m.determinant()
                ),
            ));
        }
        Ok(())
    }

    /// A KHR_lights_punctual light at its node: at the node's origin, shining along its local −Z.
    pub(super) fn add_light(
        &mut self,
        light: &gltf::khr_lights_punctual::Light,
        world: Mat4,
        node: &str,
    ) -> Result<()> {
        use gltf::khr_lights_punctual::Kind;
        let name = format!("{node} {}", label("light", light.name(), light.index()));
        let kind = match light.kind() {
            Kind::Point => PunctualKind::Point,
            Kind::Directional => PunctualKind::Sun,
            Kind::Spot { inner_cone_angle, outer_cone_angle } => {
                PunctualKind::Spot { inner_cone: inner_cone_angle, outer_cone: outer_cone_angle }
            }
        };
        if light.range().is_some() {
            warn!(
                file = %self.path.display(),
                "{name}: range is a real-time cut-off, ignored (light falls off with the inverse square of distance)"
            );
        }
        let desc = PunctualLightDesc {
            kind,
            position: world.transform_point3(Vec3::ZERO),
            direction: world.transform_vector3(Vec3::NEG_Z).normalize_or_zero(),
            color: Vec3::from(light.color()),
            intensity: light.intensity(),
            name,
        };
        if let Some(problem) = desc.problem() {
            return Err(self.invalid(desc.name, problem));
        }
        self.scene.punctual_lights.push(desc);
        Ok(())
    }

    pub(super) fn add_camera(
        &mut self,
        node: &gltf::Node,
        camera: &gltf::Camera,
        world: Mat4,
        object: String,
        moves: bool,
    ) {
        let perspective = match camera.projection() {
            gltf::camera::Projection::Perspective(p) => Some((p.yfov(), p.aspect_ratio())),
            gltf::camera::Projection::Orthographic(_) => {
                warn!(
                    file = %self.path.display(),
                    "{} on {object}: orthographic cameras are not supported, skipped",
                    label("camera", camera.name(), camera.index())
                );
                None
            }
        };
        self.cameras.push(CameraNode {
            node: object,
            camera_name: camera.name().map(str::to_owned),
            node_name: node.name().map(str::to_owned),
            perspective,
            world,
            animated_node: moves.then_some(node.index()),
        });
    }

    pub(super) fn pick_camera(&mut self, name: Option<&str>) -> Result<()> {
        let chosen = match name {
            None => self.cameras.iter().find(|c| c.perspective.is_some()),
            Some(name) => {
                let named = |c: &&CameraNode| {
                    c.camera_name.as_deref() == Some(name) || c.node_name.as_deref() == Some(name)
                };
                let Some(found) = self.cameras.iter().find(named) else {
                    let available: Vec<String> = self
                        .cameras
                        .iter()
                        .map(|c| {
                            format!("'{}' on {}", c.camera_name.as_deref().unwrap_or("(unnamed)"), c.node)
                        })
                        .collect();
                    let available = if available.is_empty() {
                        "the file has no cameras".to_owned()
                    } else {
                        available.join(", ")
                    };
                    return Err(self.invalid(
                        format!("camera '{name}'"),
                        format!("no such camera; available: {available}"),
                    ));
                };
                if found.perspective.is_none() {
                    return Err(self.invalid(
                        format!("camera '{name}' on {}", found.node),
                        "is orthographic; only perspective cameras are supported",
                    ));
                }
                Some(found)
            }
        };
        if let (Some(animation), Some(c)) = (&mut self.animation, chosen) {
            animation.camera = c.animated_node;
        }
        self.scene.camera = chosen.and_then(|c| {
            let (yfov, aspect_ratio) = c.perspective?;
            let name =
                c.camera_name.clone().or_else(|| c.node_name.clone()).unwrap_or_else(|| c.node.clone());
            Some(CameraDesc { name, camera_to_world: rigid(&c.world), yfov, aspect_ratio })
        });
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rigid_camera_transform_drops_scale_but_keeps_view_direction() {
        let world = Mat4::from_scale_rotation_translation(
            Vec3::new(2.0, 3.0, 4.0),
            Quat::from_rotation_y(0.5),
            Vec3::new(1.0, 2.0, 3.0),
        );
        let r = rigid(&world);
        let forward = r.transform_vector3(-Vec3::Z);
        assert!((forward - Quat::from_rotation_y(0.5) * -Vec3::Z).length() < 1e-5);
        assert!((Mat3::from_mat4(r).determinant() - 1.0).abs() < 1e-5);
        assert_eq!(r.w_axis.truncate(), Vec3::new(1.0, 2.0, 3.0));
    }
}
