//! Geometry: accessors read with their layouts checked, primitives triangulated, meshes placed in
//! world space.

use super::{Loader, label};
use crate::error::{Error, Result};
use crate::scene::Mesh;
use crate::scene::animation::AnimatedMesh;
use glam::{Mat4, Vec2, Vec3, Vec4};
use gltf::Semantic;
use gltf::accessor::{Accessor, DataType, Dimensions};
use gltf::mesh::Mode;
use tracing::warn;

impl Loader<'_> {
    /// Refuse a file whose meshes, every placement counted, need more than the memory budget as they
    /// are decoded and built (their vertices, indices and triangles, and [`BYTES_PER_TRIANGLE`] a
    /// triangle for what is built of them), by the accessors' declared counts, before any is read: a file of a few megabytes can place one large mesh in
    /// fifty thousand nodes, or declare 2^28 vertices of zeros.
    pub(super) fn check_geometry_budget(&self) -> Result<()> {
        // An accessor in a bufferView holds at most what the view does (a count past its end is
        // refused by name when the accessor is read); one without is all zeros of its declared count.
        let elements = |a: Accessor| match a.view() {
            Some(view) => a.count().min(view.length() / a.size().max(1)),
            None => a.count(),
        };
        let triangles = |p: gltf::Primitive| {
            let vertices = || p.get(&Semantic::Positions).map_or(0, elements);
            p.indices().map_or_else(vertices, elements) as u64 / 3
        };
        // What a vertex holds once decoded: each attribute the primitive has, at its loaded size.
        let vertex = |p: &gltf::Primitive| {
            p.attributes()
                .map(|(semantic, _)| match semantic {
                    Semantic::Positions | Semantic::Normals | Semantic::Colors(_) => 12,
                    Semantic::Tangents => 16,
                    Semantic::TexCoords(_) => 8,
                    _ => 0,
                })
                .sum::<u64>()
        };
        let vertices = |p: &gltf::Primitive| p.get(&Semantic::Positions).map_or(0, elements) as u64;
        // A node is placed at most once (the hierarchy is a tree), so each counts its mesh once.
        let placed =
            || self.document.nodes().filter_map(|node| node.mesh()).flat_map(|mesh| mesh.primitives());
        let triangles_total = placed().map(triangles).fold(0u64, u64::saturating_add);
        let vertices_total = placed().map(|p| vertices(&p)).fold(0u64, u64::saturating_add);
        let vertex_bytes =
            placed().map(|p| vertices(&p).saturating_mul(vertex(&p))).fold(0u64, u64::saturating_add);
        // As a primitive is decoded it holds its vertices, its indices (read, or made for an
        // unindexed one) and its triangles at once: what a file of zeros peaks at before its
        // degenerate triangles are dropped.
        let indices = |p: &gltf::Primitive| p.indices().map_or_else(|| vertices(p), |a| elements(a) as u64);
        let decoded = placed()
            .map(|p| indices(&p).saturating_mul(4).saturating_add(triangles(p.clone()).saturating_mul(12)))
            .fold(vertex_bytes, u64::saturating_add);
        let bytes = triangles_total.saturating_mul(BYTES_PER_TRIANGLE).saturating_add(decoded);
        if bytes > self.budget {
            return Err(self.invalid(
                "its meshes",
                format!(
                    "{triangles_total} triangles and {vertices_total} vertices, every node's placement counted, \
                     need {} MiB decoded and built, over the memory budget of {} MiB (--memory-budget-mib)",
                    bytes.div_ceil(1 << 20),
                    self.budget.div_ceil(1 << 20)
                ),
            ));
        }
        // Within the budget, but past what the process may have (`ulimit -v`): said now, by name,
        // not as an abort in the BVH's build.
        crate::memory::reserve(&format!("the meshes of {}", self.path.display()), bytes, self.budget)
    }

    /// Place `mesh`'s primitives by `world`; when an animation `moves` the node, keep each in the
    /// node's space too, for posing.
    pub(super) fn add_mesh(
        &mut self,
        node: &gltf::Node,
        mesh: &gltf::Mesh,
        world: Mat4,
        moves: bool,
    ) -> Result<()> {
        let weights = node.weights().or(mesh.weights());
        for primitive in mesh.primitives() {
            let name = format!(
                "{} {} primitive {}",
                label("node", node.name(), node.index()),
                label("mesh", mesh.name(), mesh.index()),
                primitive.index()
            );
            let mut out = self.primitive(&primitive, weights, &name)?;
            let local = moves.then(|| Mesh { name: name.clone(), ..out.clone() });
            out.transform(world);
            let normal_map = self
                .scene
                .materials
                .get(out.material as usize)
                .and_then(|m| m.normal_texture.or(m.clearcoat_normal_texture.map(|(t, _)| t)));
            if let (Some(local), Some(animation)) = (local, &mut self.animation) {
                animation.meshes.push(AnimatedMesh {
                    index: None,
                    node: node.index(),
                    tangents_from_uv: normal_map
                        .filter(|_| local.tangents.is_none())
                        .map(|m| m.tex_coord as usize),
                    local,
                });
            }
            if let (None, Some(map)) = (&out.tangents, normal_map) {
                out.tangents = crate::scene::tangents::generate(&out, map.tex_coord as usize);
                if out.tangents.is_none() {
                    warn!(file = %self.path.display(), "{name}: no tangents could be made for its normal map (no TEXCOORD_{}), shaded without it", map.tex_coord);
                }
            }
            out.node = Some(node.index());
            out.node_name = node.name().map(str::to_owned);
            out.name = name;
            self.scene.meshes.push(out);
        }
        Ok(())
    }

    /// One primitive in the mesh's local space.
    pub(super) fn primitive(
        &mut self,
        primitive: &gltf::Primitive,
        weights: Option<&[f32]>,
        name: &str,
    ) -> Result<Mesh> {
        let path = self.path;
        let bad = |problem: String| Error::InvalidScene {
            path: path.to_path_buf(),
            object: name.to_owned(),
            problem,
        };
        let mode = primitive.mode();
        if matches!(mode, Mode::Points | Mode::Lines | Mode::LineLoop | Mode::LineStrip) {
            return Err(bad(format!("unsupported primitive mode {mode:?}: only triangles can be rendered")));
        }
        let buffers = self.buffers;
        let reader = primitive.reader(|b| buffers.get(b.index()).map(|d| &d.0[..]));

        let accessor =
            primitive.get(&Semantic::Positions).ok_or_else(|| bad("has no POSITION".to_owned()))?;
        check(&accessor, "POSITION", &[Dimensions::Vec3], &[DataType::F32]).map_err(&bad)?;
        let mut positions: Vec<Vec3> = read(&accessor, "POSITION", reader.read_positions())
            .map_err(&bad)?
            .into_iter()
            .map(Vec3::from)
            .collect();
        let n = positions.len();
        let same_count = |what: &str, len: usize| {
            if len == n { Ok(()) } else { Err(bad(format!("{what} has {len} values but POSITION has {n}"))) }
        };

        let mut normals = match primitive.get(&Semantic::Normals) {
            None => None,
            Some(accessor) => {
                check(&accessor, "NORMAL", &[Dimensions::Vec3], &[DataType::F32]).map_err(&bad)?;
                let normals: Vec<Vec3> = read(&accessor, "NORMAL", reader.read_normals())
                    .map_err(&bad)?
                    .into_iter()
                    .map(Vec3::from)
                    .collect();
                same_count("NORMAL", normals.len())?;
                Some(normals)
            }
        };

        if primitive.morph_targets().len() > 0 {
            self.morphed_primitives += 1;
        }
        // The rest pose of a morphed mesh is the base plus its default weights times the targets.
        if let Some(weights) = weights.filter(|w| w.iter().any(|&w| w != 0.0)) {
            for ((i, target), (dp, dn, _)) in
                primitive.morph_targets().enumerate().zip(reader.read_morph_targets())
            {
                let w = weights.get(i).copied().unwrap_or(0.0);
                if w == 0.0 {
                    continue;
                }
                if let Some(accessor) = target.positions() {
                    let what = format!("morph target {i} POSITION");
                    check(&accessor, &what, &[Dimensions::Vec3], &[DataType::F32]).map_err(&bad)?;
                    let d = read(&accessor, &what, dp).map_err(&bad)?;
                    same_count(&what, d.len())?;
                    positions.iter_mut().zip(d).for_each(|(p, d)| *p += w * Vec3::from(d));
                }
                if let (Some(accessor), Some(normals)) = (target.normals(), normals.as_mut()) {
                    let what = format!("morph target {i} NORMAL");
                    check(&accessor, &what, &[Dimensions::Vec3], &[DataType::F32]).map_err(&bad)?;
                    let d = read(&accessor, &what, dn).map_err(&bad)?;
                    same_count(&what, d.len())?;
                    normals.iter_mut().zip(d).for_each(|(n, d)| *n += w * Vec3::from(d));
                }
            }
        }

        let tangents = match primitive.get(&Semantic::Tangents) {
            None => None,
            Some(accessor) => {
                check(&accessor, "TANGENT", &[Dimensions::Vec4], &[DataType::F32]).map_err(&bad)?;
                let values = read(&accessor, "TANGENT", reader.read_tangents()).map_err(&bad)?;
                same_count("TANGENT", values.len())?;
                Some(values.into_iter().map(Vec4::from).collect())
            }
        };

        let material = match primitive.material().index() {
            Some(index) => index as u32,
            None => self.default_material(),
        };
        // Sets are consecutive from 0; hits carry sets 0 and 1 (`SurfaceHit::uv`), the only ones textures may use.
        let mut uvs = Vec::new();
        for set in 0..2 {
            let Some(accessor) = primitive.get(&Semantic::TexCoords(set)) else {
                break;
            };
            let what = format!("TEXCOORD_{set}");
            check(&accessor, &what, &[Dimensions::Vec2], &[DataType::F32, DataType::U8, DataType::U16])
                .and_then(|()| check_normalized(&accessor, &what))
                .map_err(&bad)?;
            let values =
                read(&accessor, &what, reader.read_tex_coords(set).map(|t| t.into_f32())).map_err(&bad)?;
            same_count(&what, values.len())?;
            uvs.push(values.into_iter().map(Vec2::from).collect());
        }

        let colors = match primitive.get(&Semantic::Colors(0)) {
            None => None,
            Some(accessor) => {
                let types = [DataType::F32, DataType::U8, DataType::U16];
                check(&accessor, "COLOR_0", &[Dimensions::Vec3, Dimensions::Vec4], &types)
                    .and_then(|()| check_normalized(&accessor, "COLOR_0"))
                    .map_err(&bad)?;
                let values = read(&accessor, "COLOR_0", reader.read_colors(0).map(|c| c.into_rgb_f32()))
                    .map_err(&bad)?;
                same_count("COLOR_0", values.len())?;
                Some(values.into_iter().map(Vec3::from).collect())
            }
        };

        let vertex_indices: Vec<u32> = match primitive.indices() {
            Some(accessor) => {
                check(
                    &accessor,
                    "indices",
                    &[Dimensions::Scalar],
                    &[DataType::U8, DataType::U16, DataType::U32],
                )
                .map_err(&bad)?;
                read(&accessor, "indices", reader.read_indices().map(|i| i.into_u32())).map_err(&bad)?
            }
            None => (0..n as u32).collect(),
        };
        let (indices, leftover) = triangulate(mode, &vertex_indices);
        if leftover > 0 {
            warn!(file = %self.path.display(), "{name}: {leftover} trailing index(es) do not form a triangle, ignored");
        }
        Ok(Mesh { positions, normals, uvs, colors, tangents, indices, material, ..Mesh::default() })
    }
}

/// Rejects accessor layouts the reader would misread or panic on (it only debug-asserts them).
pub(super) fn check(
    accessor: &Accessor,
    what: &str,
    dimensions: &[Dimensions],
    types: &[DataType],
) -> Result<(), String> {
    let object = format!("{what} ({})", label("accessor", accessor.name(), accessor.index()));
    if !dimensions.contains(&accessor.dimensions()) || !types.contains(&accessor.data_type()) {
        return Err(format!(
            "{object} is {:?} of {:?}, expected one of {dimensions:?} of one of {types:?}",
            accessor.dimensions(),
            accessor.data_type()
        ));
    }
    if accessor.count() == 0 || accessor.sparse().is_some_and(|s| s.count() == 0) {
        return Err(format!("{object} has a count of 0"));
    }
    if let Some(stride) = accessor.view().and_then(|v| v.stride())
        && stride < accessor.size()
    {
        return Err(format!(
            "{object} has byteStride {stride}, less than its element size {}",
            accessor.size()
        ));
    }
    // The reader computes these extents unchecked, so an absurd count would overflow.
    let past_the_end = |what: &str, view: gltf::buffer::View| {
        format!(
            "{object}{what} reads past the end of its {} ({} bytes)",
            label("bufferView", view.name(), view.index()),
            view.length()
        )
    };
    let size = accessor.size();
    if let Some(view) = accessor.view()
        && !fits(accessor.offset(), view.stride().unwrap_or(size), accessor.count(), size, view.length())
    {
        return Err(past_the_end("", view));
    }
    if let Some(sparse) = accessor.sparse() {
        let (indices, values) = (sparse.indices(), sparse.values());
        let (index_size, view) = (indices.index_type().size(), indices.view());
        if !fits(
            indices.offset(),
            view.stride().unwrap_or(index_size),
            sparse.count(),
            index_size,
            view.length(),
        ) {
            return Err(past_the_end(" sparse indices", view));
        }
        let view = values.view();
        if !fits(values.offset(), view.stride().unwrap_or(size), sparse.count(), size, view.length()) {
            return Err(past_the_end(" sparse values", view));
        }
    }
    Ok(())
}

/// Whether `count` elements of `size` bytes, `stride` apart from `offset`, end within `length` bytes.
fn fits(offset: usize, stride: usize, count: usize, size: usize, length: usize) -> bool {
    count
        .checked_sub(1)
        .and_then(|n| n.checked_mul(stride))
        .and_then(|n| n.checked_add(size))
        .and_then(|n| n.checked_add(offset))
        .is_some_and(|end| end <= length)
}

/// The reader normalizes integer texture coordinates and colours whether or not the accessor says so; unnormalized
/// ones (KHR_mesh_quantization) would come out wrong.
fn check_normalized(accessor: &Accessor, what: &str) -> Result<(), String> {
    if accessor.data_type() == DataType::F32 || accessor.normalized() {
        return Ok(());
    }
    Err(format!(
        "{what} ({}) is {:?} but not normalized; only normalized integers are supported (KHR_mesh_quantization is not)",
        label("accessor", accessor.name(), accessor.index()),
        accessor.data_type()
    ))
}

/// Memory a triangle takes as the scene is built from it, beyond its decoded vertices and indices:
/// the flattened mesh, the BVH and its build's scratch, the shading packs. Measured on
/// scenes/dense-mesh.gltf (1.96 M triangles): the process peaks ~445 MiB above an empty run, as its
/// BVH is built.
const BYTES_PER_TRIANGLE: u64 = 200;

/// Most elements an accessor without a bufferView (all zeros) may declare: 2^28, beyond any mesh a
/// renderer of this machine's memory can hold.
const MAX_ZERO_ACCESSOR_COUNT: usize = 1 << 28;

/// Collects an accessor's values; `values` is `None` when its data lies outside its buffer, or when it has no
/// bufferView, which glTF defines as all zeros.
pub(super) fn read<T: Default + Clone>(
    accessor: &Accessor,
    what: &str,
    values: Option<impl Iterator<Item = T>>,
) -> Result<Vec<T>, String> {
    // No data behind an accessor without a bufferView (all zeros, sparse or not) bounds its count, so
    // the file's word must be checked before it is allocated.
    if accessor.view().is_none() && accessor.count() > MAX_ZERO_ACCESSOR_COUNT {
        return Err(format!(
            "{what} ({}) has no bufferView and a count of {}, over the {MAX_ZERO_ACCESSOR_COUNT} a mesh may have",
            label("accessor", accessor.name(), accessor.index()),
            accessor.count()
        ));
    }
    // The count is the file's word (checked against the budget before any accessor is read): where
    // the allocator has not got it (`ulimit -v`), that is an error naming the accessor, not an abort.
    let mut out = Vec::new();
    if values.is_some() || accessor.sparse().is_none() {
        out.try_reserve_exact(accessor.count()).map_err(|_| {
            format!(
                "{what} ({}): cannot allocate its {} elements ({} MiB): the machine or this process's \
                 limit (ulimit -v) has not got them",
                label("accessor", accessor.name(), accessor.index()),
                accessor.count(),
                (accessor.count() as u64 * size_of::<T>() as u64).div_ceil(1 << 20)
            )
        })?;
    }
    match values {
        Some(values) => {
            out.extend(values);
            Ok(out)
        }
        None if accessor.view().is_none() && accessor.sparse().is_none() => {
            out.resize(accessor.count(), T::default());
            Ok(out)
        }
        None => Err(format!(
            "{what} ({}) reads past the end of its bufferView or buffer",
            label("accessor", accessor.name(), accessor.index())
        )),
    }
}

/// Triangles from a triangle list, strip or fan (glTF 2.0 §3.7.2.1), and the number of unused trailing indices.
fn triangulate(mode: Mode, v: &[u32]) -> (Vec<[u32; 3]>, usize) {
    match mode {
        Mode::TriangleStrip => {
            let triangles = (0..v.len().saturating_sub(2))
                .map(|i| if i % 2 == 0 { [v[i], v[i + 1], v[i + 2]] } else { [v[i], v[i + 2], v[i + 1]] })
                .collect();
            (triangles, 0)
        }
        Mode::TriangleFan => (((1..v.len().saturating_sub(1)).map(|i| [v[i], v[i + 1], v[0]])).collect(), 0),
        _ => {
            let chunks = v.chunks_exact(3);
            let leftover = chunks.remainder().len();
            (chunks.map(|t| [t[0], t[1], t[2]]).collect(), leftover)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn strips_alternate_winding_and_fans_pivot_on_the_first_vertex() {
        let v = [10, 11, 12, 13, 14];
        assert_eq!(triangulate(Mode::TriangleStrip, &v).0, vec![[10, 11, 12], [11, 13, 12], [12, 13, 14]]);
        assert_eq!(triangulate(Mode::TriangleFan, &v).0, vec![[11, 12, 10], [12, 13, 10], [13, 14, 10]]);
        assert_eq!(triangulate(Mode::Triangles, &v), (vec![[10, 11, 12]], 2));
        assert!(triangulate(Mode::TriangleStrip, &v[..2]).0.is_empty());
    }
}
