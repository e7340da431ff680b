//! Meshes placed by a transform: the one function that maps a mesh's positions, normals, tangents
//! and winding (the glTF loader places each node's meshes with it), and a scene from frame to
//! frame: posed by its animations, its nodes moved by a host (a simulation's next frame).

use super::validate::MAX_COORDINATE;
use super::{Mesh, Scene};
use crate::error::{Error, Result};
use glam::{Mat3, Mat4};
use std::collections::HashMap;

/// The matrix normals map by: the inverse transpose of `linear`, or, when `linear` is singular (a
/// scale to zero along an axis, which an animation can pass through), its cofactor matrix, which
/// points the same way wherever the inverse exists and stays finite where it does not (the faces
/// that keep an area keep their normals; the others collapse and are dropped).
fn normal_matrix(linear: Mat3) -> Mat3 {
    let inverse_transpose = linear.inverse().transpose();
    if inverse_transpose.is_finite() {
        return inverse_transpose;
    }
    let (a, b, c) = (linear.x_axis, linear.y_axis, linear.z_axis);
    Mat3::from_cols(b.cross(c), c.cross(a), a.cross(b))
}

impl Mesh {
    /// Move the mesh by `m`: positions by the matrix, normals by its inverse transpose, tangents by its
    /// linear part with the bitangent's handedness flipped when `m` mirrors, and the triangles'
    /// winding reversed then, so that counter-clockwise stays the front face.
    pub fn transform(&mut self, m: Mat4) {
        let linear = Mat3::from_mat4(m);
        let normal_matrix = normal_matrix(linear);
        let flip = m.determinant() < 0.0;
        for p in &mut self.positions {
            *p = m.transform_point3(*p);
        }
        if let Some(normals) = &mut self.normals {
            for n in normals {
                let mapped = normal_matrix * *n;
                // Zero and NaN normals are left for validation to report.
                let length = mapped.length();
                *n = if length > 0.0 && length.is_finite() { mapped / length } else { mapped };
            }
        }
        if let Some(tangents) = &mut self.tangents {
            // Tangents are directions on the surface: they map with the linear part.
            let sign = if flip { -1.0 } else { 1.0 };
            for t in tangents {
                let mapped = (linear * t.truncate()).normalize_or_zero();
                *t = mapped.extend(if t.w < 0.0 { -sign } else { sign });
            }
        }
        if flip {
            for triangle in &mut self.indices {
                triangle.swap(1, 2);
            }
        }
    }

    /// Whether the mesh belongs to the glTF node `node`: its name, or its index written out.
    pub fn is_of_node(&self, node: &str) -> bool {
        self.node_name.as_deref() == Some(node) || self.node.is_some_and(|i| i.to_string() == node)
    }
}

/// A scene from frame to frame: posed by its file's animations at a time, its nodes moved by a host
/// (each move applied to the node's geometry as posed, so the identity puts a node back), and which
/// meshes either can move (they go to the geometry's dynamic set, rebuilt alone each frame).
#[derive(Clone, Debug)]
pub struct FrameScene {
    scene: Scene,
    /// The meshes a host moved that no animation poses, as loaded.
    loaded: HashMap<usize, Mesh>,
    moves: Vec<(String, Mat4)>,
    time: f32,
    /// By mesh index: whether a frame can move the mesh.
    pub dynamic: Vec<bool>,
}

impl FrameScene {
    /// `scene` at time 0 of its animation, no node moved: its animated meshes are dynamic.
    pub fn new(scene: Scene) -> Self {
        let mut dynamic = vec![false; scene.meshes.len()];
        for i in scene.animation.iter().flat_map(|a| a.meshes.iter().filter_map(|m| m.index)) {
            dynamic[i] = true;
        }
        let mut frames = Self { scene, loaded: HashMap::new(), moves: Vec::new(), time: 0.0, dynamic };
        frames.refresh();
        frames
    }

    /// The scene as it stands.
    pub fn scene(&self) -> &Scene {
        &self.scene
    }

    /// The time the animation is posed at, in seconds.
    pub fn time(&self) -> f32 {
        self.time
    }

    /// Pose the file's animations at time `t` (seconds); the meshes that changed.
    pub fn set_time(&mut self, t: f32) -> Result<Vec<usize>> {
        if !t.is_finite() {
            return Err(Error::Setting { name: "time".into(), problem: format!("{t} is not finite") });
        }
        let previous = self.time;
        self.time = t;
        let changed = self.refresh();
        if let Some((object, problem)) = self.pose_problem() {
            // Refused: the scene stays posed where it was.
            self.time = previous;
            self.refresh();
            return Err(Error::InvalidScene {
                path: self.scene.source.clone(),
                object: format!("{object} at {t} s"),
                problem,
            });
        }
        Ok(changed)
    }

    /// What an animation's pose or a host's move gives that the loader would have refused in a file:
    /// a camera or a spot or sun light under a node scaled to nothing (no direction to look or shine
    /// along), or a vertex beyond [`MAX_COORDINATE`] (the BVH's boxes stop nesting there: a light
    /// moved to 10³⁷ m panicked `lt` indexing a pack that was not there).
    fn pose_problem(&self) -> Option<(String, String)> {
        let placed = self.dynamic.iter().zip(&self.scene.meshes).filter(|(dynamic, _)| **dynamic);
        for (_, mesh) in placed {
            let drift = mesh.motion.unwrap_or_default().abs().max_element();
            let far = mesh
                .positions
                .iter()
                .position(|p| !p.is_finite() || p.abs().max_element() + drift > MAX_COORDINATE);
            if let Some(i) = far {
                return Some((
                    mesh.name.clone(),
                    format!(
                        "vertex {i} is placed at {}, beyond the ±{MAX_COORDINATE} m f32 geometry supports",
                        mesh.positions[i]
                    ),
                ));
            }
        }
        if let Some(camera) = &self.scene.camera
            && !camera.camera_to_world.is_finite()
        {
            return Some((
                format!("camera {:?}", camera.name),
                "its node is scaled to nothing, so it has no orientation".into(),
            ));
        }
        self.scene.punctual_lights.iter().enumerate().find_map(|(i, light)| {
            light
                .problem()
                .map(|problem| (format!("light #{i}"), format!("{problem} (its node is scaled to nothing)")))
        })
    }

    /// Give node `node` (its name, or its index) the transform `m`, replacing the one it had; the
    /// meshes that changed. The matrix must be finite and invertible, and the node must have meshes.
    pub fn move_node(&mut self, node: &str, m: Mat4) -> Result<Vec<usize>> {
        if !m.is_finite() || Mat3::from_mat4(m).determinant().abs() < 1e-12 {
            return Err(Error::Setting {
                name: format!("the transform of node {node:?}"),
                problem: "the matrix must be finite and invertible".into(),
            });
        }
        // Points are moved as affine (glam's transform_point3 ignores the last row): a projective
        // row would be dropped without a word. Within 1e-6, for a host's inverted or multiplied
        // matrices, whose last row rounding leaves a little off.
        if !m.row(3).abs_diff_eq(glam::Vec4::W, 1e-6) {
            return Err(Error::Setting {
                name: format!("the transform of node {node:?}"),
                problem: format!("the last row is {}, not 0 0 0 1: the matrix must be affine", m.row(3)),
            });
        }
        let meshes: Vec<usize> = self.meshes_of(node).collect();
        if meshes.is_empty() {
            return Err(Error::InvalidScene {
                path: self.scene.source.clone(),
                object: format!("node {node:?}"),
                problem: "no mesh of a node named or numbered so".into(),
            });
        }
        let (previous_moves, mut newly_dynamic) = (self.moves.clone(), Vec::new());
        for &i in &meshes {
            if !self.dynamic[i] {
                self.dynamic[i] = true;
                self.loaded.insert(i, self.scene.meshes[i].clone());
                newly_dynamic.push(i);
            }
        }
        // A node named once by its name and once by its index is one node: its new move replaces
        // the old one (the identity puts it back whichever way it was named).
        let same_node: Vec<bool> =
            self.moves.iter().map(|(name, _)| self.meshes_of(name).eq(meshes.iter().copied())).collect();
        let mut same = same_node.into_iter();
        self.moves.retain(|_| !same.next().expect("one per move"));
        self.moves.push((node.to_owned(), m));
        let changed = self.refresh();
        if let Some((object, problem)) = self.pose_problem() {
            // Refused: the scene as it was, the meshes as static as they were (the geometry's
            // dynamic set, and so the next frame's BVH, is what it would have been without it).
            self.moves = previous_moves;
            self.refresh();
            for i in newly_dynamic {
                self.dynamic[i] = false;
                self.loaded.remove(&i);
            }
            return Err(Error::Setting {
                name: format!("the transform of node {node:?}"),
                problem: format!("{object}: {problem}"),
            });
        }
        Ok(changed)
    }

    fn meshes_of<'a>(&'a self, node: &'a str) -> impl Iterator<Item = usize> + 'a {
        self.scene.meshes.iter().enumerate().filter(move |(_, m)| m.is_of_node(node)).map(|(i, _)| i)
    }

    /// Every dynamic mesh placed anew: posed (or as loaded), then moved; their indices.
    fn refresh(&mut self) -> Vec<usize> {
        let mut changed = match self.scene.animation.clone() {
            Some(animation) => animation.pose(&mut self.scene, self.time),
            None => Vec::new(),
        };
        for (&i, loaded) in &self.loaded {
            self.scene.meshes[i] = loaded.clone();
            changed.push(i);
        }
        for (node, m) in &self.moves {
            for mesh in self.scene.meshes.iter_mut().filter(|mesh| mesh.is_of_node(node)) {
                mesh.transform(*m);
            }
        }
        changed.sort_unstable();
        changed.dedup();
        changed
    }
}
