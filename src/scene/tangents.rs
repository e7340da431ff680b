//! Tangents for normal-mapped meshes that carry none: MikkTSpace (Mikkelsen 2008), the tangent
//! space glTF's normal maps are baked against, with the bitangent sign in w.

use super::Mesh;
use glam::{Vec2, Vec3, Vec4};

/// The mesh's tangents from its positions, normals (face normals where it has none) and texture
/// set `uv_set`; `None` when it has no such set or MikkTSpace gives up (degenerate input).
pub fn generate(mesh: &Mesh, uv_set: usize) -> Option<Vec<Vec4>> {
    let uvs = mesh.uvs.get(uv_set)?;
    let mut input = Input { mesh, uvs, tangents: vec![Vec4::ZERO; mesh.positions.len()] };
    mikktspace::generate_tangents(&mut input).then_some(input.tangents)
}

struct Input<'a> {
    mesh: &'a Mesh,
    uvs: &'a [Vec2],
    /// Per vertex: a vertex shared by faces whose tangents differ keeps the last (glTF splits
    /// vertices along uv seams, where they would differ most).
    tangents: Vec<Vec4>,
}

impl Input<'_> {
    fn vertex(&self, face: usize, vert: usize) -> usize {
        self.mesh.indices[face][vert] as usize
    }
}

impl mikktspace::Geometry for Input<'_> {
    fn num_faces(&self) -> usize {
        self.mesh.indices.len()
    }

    fn num_vertices_of_face(&self, _face: usize) -> usize {
        3
    }

    fn position(&self, face: usize, vert: usize) -> [f32; 3] {
        self.mesh.positions[self.vertex(face, vert)].to_array()
    }

    fn normal(&self, face: usize, vert: usize) -> [f32; 3] {
        match &self.mesh.normals {
            Some(n) => n[self.vertex(face, vert)].to_array(),
            None => {
                let [a, b, c] = self.mesh.indices[face].map(|i| self.mesh.positions[i as usize]);
                (b - a).cross(c - a).normalize_or(Vec3::Z).to_array()
            }
        }
    }

    fn tex_coord(&self, face: usize, vert: usize) -> [f32; 2] {
        self.uvs[self.vertex(face, vert)].to_array()
    }

    /// MikkTSpace's bitangent points along increasing v (OpenGL's texture space, v up); glTF's
    /// normal maps are +Y up in the image, and glTF's v runs down it, so glTF's bitangent,
    /// (n × t) · w, points along decreasing v: the sign is negated (as three.js's
    /// `computeMikkTSpaceTangents` does for glTF). Kept, a map's green channel tilted the normal the
    /// wrong way on every mesh without tangents.
    fn set_tangent_encoded(&mut self, tangent: [f32; 4], face: usize, vert: usize) {
        let v = self.vertex(face, vert);
        let [x, y, z, sign] = tangent;
        self.tangents[v] = Vec4::new(x, y, z, -sign);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A quad in the xz plane whose u runs along +x and v along +z: the tangent is +x everywhere,
    /// and glTF's bitangent (n × t) · w points along decreasing v (a normal map's +Y is up in the
    /// image, where v runs down): w · (y × x) = −z, so w = +1. (NormalTangentMirrorTest's own
    /// tangents, which Khronos wrote for glTF, have this sign on all 5240 of its triangles; MikkTSpace
    /// alone gives the other.)
    #[test]
    fn a_planar_quad_gets_its_u_direction_as_tangent() {
        let mesh = Mesh {
            positions: vec![
                Vec3::new(0.0, 0.0, 0.0),
                Vec3::new(1.0, 0.0, 0.0),
                Vec3::new(1.0, 0.0, 1.0),
                Vec3::new(0.0, 0.0, 1.0),
            ],
            normals: Some(vec![Vec3::Y; 4]),
            uvs: vec![vec![
                Vec2::new(0.0, 0.0),
                Vec2::new(1.0, 0.0),
                Vec2::new(1.0, 1.0),
                Vec2::new(0.0, 1.0),
            ]],
            indices: vec![[0, 2, 1], [0, 3, 2]],
            ..Mesh::default()
        };
        let tangents = generate(&mesh, 0).unwrap();
        for t in tangents {
            assert!((t.truncate() - Vec3::X).length() < 1e-5, "{t}");
            assert_eq!(t.w, 1.0);
        }
    }
}
