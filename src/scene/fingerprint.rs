//! A fingerprint of what decides a render's image: the scene's content and every setting that
//! changes a pixel. Partial renders carry it, so that a merge refuses parts of different renders.
//! Paths, output settings, time limits, memory budgets and the chunk size (`render.chunk`, how many
//! paths a worker holds) are left out: they differ between machines or runs without changing the
//! bits. So is the target (samples per pixel, passes): a resumed render
//! may go past its first target, and an accumulator records its samples itself.

use super::{RunFile, Scene};
use std::fmt::Write;
use xxhash_rust::xxh3::Xxh3;

/// The fingerprint as 32 hex digits (xxh3, 128 bits).
pub fn fingerprint(scene: &Scene, run: &RunFile) -> String {
    let mut hasher = Xxh3::new();
    let mut settings = run.clone();
    settings.gltf = None;
    settings.output = Default::default();
    settings.render.time_limit = None;
    settings.render.spp = 0;
    settings.progressive.passes = 0;
    settings.render.memory_budget_mib = None;
    settings.render.chunk = 0;
    settings.progressive.memory_budget_mib = None;
    settings.environment.file = None;
    let mut text = String::new();
    // Debug output of plain data is stable for a given build of these types; every float prints
    // its shortest exact form.
    let _ = write!(
        text,
        "{settings:?}|{:?}|{:?}|{:?}|{:?}|{:?}",
        scene.spheres, scene.materials, scene.camera, scene.resolution, scene.punctual_lights
    );
    let mut map = None;
    if let Some(environment) = &scene.environment {
        let _ = write!(text, "|{}|{}|{:?}", environment.name, environment.strength, environment.rotation);
        match &environment.radiance {
            super::environment::EnvironmentRadiance::Constant(c) => {
                let _ = write!(text, "|{c:?}");
            }
            super::environment::EnvironmentRadiance::Map(image) => map = Some(image),
        }
    }
    hasher.update(text.as_bytes());
    // Bulk arrays by their bits, not their Debug text: a million-vertex mesh hashes in milliseconds.
    let mut floats = |values: &mut dyn Iterator<Item = f32>| {
        let bytes: Vec<u8> = values.flat_map(|v| v.to_bits().to_le_bytes()).collect();
        hasher.update(&(bytes.len() as u64).to_le_bytes());
        hasher.update(&bytes);
    };
    for mesh in &scene.meshes {
        floats(&mut mesh.positions.iter().flat_map(|p| p.to_array()));
        floats(&mut mesh.normals.iter().flatten().flat_map(|n| n.to_array()));
        for set in &mesh.uvs {
            floats(&mut set.iter().flat_map(|uv| uv.to_array()));
        }
        floats(&mut mesh.colors.iter().flatten().flat_map(|c| c.to_array()));
        floats(&mut mesh.tangents.iter().flatten().flat_map(|t| t.to_array()));
        floats(&mut mesh.indices.iter().flatten().map(|&i| f32::from_bits(i)));
        floats(&mut mesh.motion.iter().flat_map(|m| m.to_array()));
        floats(&mut [f32::from_bits(mesh.material), f32::from_bits(mesh.uvs.len() as u32)].into_iter());
    }
    if let Some(image) = map {
        floats(&mut [f32::from_bits(image.width), f32::from_bits(image.height)].into_iter());
        floats(&mut image.pixels.iter().flat_map(|p| p.to_array()));
    }
    for texture in &scene.textures {
        let header = format!(
            "{}|{}x{}|{:?}|{:?}",
            texture.name, texture.width, texture.height, texture.wrap_s, texture.wrap_t
        );
        floats(&mut header.bytes().map(|b| f32::from_bits(b as u32)));
        floats(&mut texture.texels().flat_map(|t| t.to_array()));
    }
    format!("{:032x}", hasher.digest128())
}
