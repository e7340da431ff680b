//! Reading a file's animations: each channel's keyframes checked (times finite and increasing,
//! as many values as the interpolation needs), the nodes' hierarchy kept for posing.

use super::geometry::{check, read};
use super::{Loader, label};
use crate::error::Result;
use crate::scene::animation::{AnimatedNode, Animation, Channel, Interpolation, LocalTransform, Property};
use glam::{Mat4, Quat, Vec3, Vec4};
use gltf::accessor::{DataType, Dimensions};
use gltf::animation::util::ReadOutputs;
use tracing::warn;

impl Loader<'_> {
    /// The file's node-transform channels, all animations played together (a channel later in the
    /// file that drives a property an earlier one does is left out, with a warning); `None` when
    /// there is none. Morph-target weight channels are left out with a warning.
    pub(super) fn read_animation(&self) -> Result<Option<Animation>> {
        let mut animation = Animation {
            nodes: self
                .document
                .nodes()
                .map(|node| AnimatedNode { parent: None, local: local_transform(&node) })
                .collect(),
            ..Animation::default()
        };
        for node in self.document.nodes() {
            for child in node.children() {
                animation.nodes[child.index()].parent = Some(node.index());
            }
        }
        let mut weights = Vec::new();
        for clip in self.document.animations() {
            let clip_label = label("animation", clip.name(), clip.index());
            for channel in clip.channels() {
                let property = match channel.target().property() {
                    gltf::animation::Property::Translation => Property::Translation,
                    gltf::animation::Property::Rotation => Property::Rotation,
                    gltf::animation::Property::Scale => Property::Scale,
                    gltf::animation::Property::MorphTargetWeights => {
                        let node = channel.target().node();
                        let morphed = node.mesh().is_some_and(|mesh| {
                            mesh.primitives().any(|p| p.morph_targets().next().is_some())
                        });
                        // A channel on a node without morph targets drives nothing even once weights
                        // are played: say so, rather than promise default weights it has not got.
                        let driven = if morphed { "" } else { ", which has no morph targets" };
                        weights.push(format!(
                            "{clip_label} on {}{driven}",
                            label("node", node.name(), node.index())
                        ));
                        continue;
                    }
                };
                let node = channel.target().node().index();
                let object = format!("{clip_label} channel {}", channel.index());
                if animation.channels.iter().any(|c| c.node == node && c.property == property) {
                    warn!(
                        file = %self.path.display(),
                        "{object}: {} of node #{node} is animated by an earlier channel too; this one is ignored",
                        format!("{property:?}").to_lowercase()
                    );
                    continue;
                }
                let read = self.channel(&channel, property, node).map_err(|p| self.invalid(&object, p))?;
                animation.duration = animation.duration.max(read.end());
                animation.channels.push(read);
            }
        }
        if !weights.is_empty() {
            warn!(
                file = %self.path.display(),
                "morph-target weight channels ignored ({}): morphed meshes keep their default weights",
                weights.join(", ")
            );
        }
        Ok((!animation.channels.is_empty()).then_some(animation))
    }

    fn channel(
        &self,
        channel: &gltf::animation::Channel,
        property: Property,
        node: usize,
    ) -> std::result::Result<Channel, String> {
        let sampler = channel.sampler();
        let interpolation = match sampler.interpolation() {
            gltf::animation::Interpolation::Step => Interpolation::Step,
            gltf::animation::Interpolation::Linear => Interpolation::Linear,
            gltf::animation::Interpolation::CubicSpline => Interpolation::CubicSpline,
        };
        let buffers = self.buffers;
        let reader = channel.reader(|b| buffers.get(b.index()).map(|d| &d.0[..]));
        let input = sampler.input();
        check(&input, "input", &[Dimensions::Scalar], &[DataType::F32])?;
        let times = read(&input, "input", reader.read_inputs())?;
        if let Some(i) = times.iter().position(|t| !t.is_finite()) {
            return Err(format!("keyframe {i}'s time is {}, not finite", times[i]));
        }
        if let Some(i) = times.windows(2).position(|w| w[1] <= w[0]) {
            return Err(format!(
                "keyframe times must increase: keyframe {} is at {} s, after {} s",
                i + 1,
                times[i + 1],
                times[i]
            ));
        }
        let output = sampler.output();
        let (dimensions, types): (_, &[DataType]) = match property {
            Property::Rotation => {
                (Dimensions::Vec4, &[DataType::F32, DataType::I8, DataType::U8, DataType::I16, DataType::U16])
            }
            _ => (Dimensions::Vec3, &[DataType::F32]),
        };
        check(&output, "output", &[dimensions], types)?;
        let values: Vec<Vec4> = match reader.read_outputs() {
            Some(ReadOutputs::Translations(v)) | Some(ReadOutputs::Scales(v)) => {
                read(&output, "output", Some(v))?.into_iter().map(|v| Vec3::from(v).extend(0.0)).collect()
            }
            Some(ReadOutputs::Rotations(r)) => {
                read(&output, "output", Some(r.into_f32()))?.into_iter().map(Vec4::from).collect()
            }
            _ => read::<[f32; 4]>(&output, "output", None::<std::iter::Empty<_>>)?
                .into_iter()
                .map(Vec4::from)
                .collect(),
        };
        let per_key = if interpolation == Interpolation::CubicSpline { 3 } else { 1 };
        if values.len() != per_key * times.len() {
            return Err(format!(
                "{} output values for {} keyframes of {interpolation:?} interpolation (it needs {})",
                values.len(),
                times.len(),
                per_key * times.len()
            ));
        }
        if let Some(i) = values.iter().position(|v| !v.is_finite()) {
            return Err(format!("output value {i} is {}, not finite", values[i]));
        }
        Ok(Channel { node, property, interpolation, times, values })
    }
}

/// A node's transform as written (checked for finiteness by the walk, for the nodes it places).
fn local_transform(node: &gltf::Node) -> LocalTransform {
    match node.transform() {
        gltf::scene::Transform::Matrix { matrix } => {
            LocalTransform::Matrix(Mat4::from_cols_array_2d(&matrix))
        }
        gltf::scene::Transform::Decomposed { translation, rotation, scale } => {
            LocalTransform::Trs(Vec3::from(translation), Quat::from_array(rotation), Vec3::from(scale))
        }
    }
}
