//! Meshes placed by a transform: the one function that maps a mesh's positions, normals, tangents
//! and winding (the glTF loader places each node's meshes with it), and the moves a host gives a
//! loaded scene's nodes (a simulation's next frame).

use super::{Mesh, Scene};
use crate::error::{Error, Result};
use glam::{Mat3, Mat4};

impl Mesh {
    /// Move the mesh by `m`: positions by the matrix, normals by its inverse transpose, tangents by its
    /// linear part with the bitangent's handedness flipped when `m` mirrors, and the triangles'
    /// winding reversed then, so that counter-clockwise stays the front face.
    pub fn transform(&mut self, m: Mat4) {
        let linear = Mat3::from_mat4(m);
        let normal_matrix = linear.inverse().transpose();
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

/// A loaded scene and the transforms a host has given its nodes, each applied to the node's
/// geometry as loaded (so the identity puts a node back).
#[derive(Clone, Debug)]
pub struct NodeMoves {
    loaded: Scene,
    moves: Vec<(String, Mat4)>,
}

impl NodeMoves {
    /// No node moved yet.
    pub fn new(loaded: Scene) -> Self {
        Self { loaded, moves: Vec::new() }
    }

    /// Give node `node` (its name, or its index) the transform `m`, replacing the one it had. The
    /// matrix must be finite and invertible, and the node must have meshes.
    pub fn set(&mut self, node: &str, m: Mat4) -> Result<()> {
        if !m.is_finite() || Mat3::from_mat4(m).determinant().abs() < 1e-12 {
            return Err(Error::Setting {
                name: format!("the transform of node {node:?}"),
                problem: "the matrix must be finite and invertible".into(),
            });
        }
        if !self.loaded.meshes.iter().any(|mesh| mesh.is_of_node(node)) {
            return Err(Error::InvalidScene {
                path: self.loaded.source.clone(),
                object: format!("node {node:?}"),
                problem: "no mesh of a node named or numbered so".into(),
            });
        }
        self.moves.retain(|(name, _)| name != node);
        self.moves.push((node.to_owned(), m));
        Ok(())
    }

    /// The scene with every node moved.
    pub fn scene(&self) -> Scene {
        let mut moved = self.loaded.clone();
        for (node, m) in &self.moves {
            for mesh in moved.meshes.iter_mut().filter(|mesh| mesh.is_of_node(node)) {
                mesh.transform(*m);
            }
        }
        moved
    }
}
