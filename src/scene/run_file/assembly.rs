//! A run file's scene: its glTF, with the `[[sphere]]`s and `[[motion]]`s it adds.

use super::{MaterialSpec, RunFile};
use crate::error::{Error, Result};
use crate::materials::ShadingParams;
use crate::scene::{MaterialDesc, Scene, Sphere};
use glam::Vec3;
use std::path::Path;

impl RunFile {
    /// The scene this run file (read from `path`) describes, not yet validated: its glTF, resolved against the run
    /// file's directory and with the camera `[camera] name` picks, plus its `[[sphere]]`s and `[[motion]]`s.
    pub fn load_scene(&self, path: &Path) -> Result<Scene> {
        let mut scene = match &self.gltf {
            Some(gltf) => {
                let resolved = path.parent().unwrap_or(Path::new("")).join(gltf);
                // Name the path as written too: the resolved one alone hides which key was wrong.
                if let Err(e) = std::fs::metadata(&resolved) {
                    let context = format!(
                        "{e} (gltf = \"{}\" in {}, relative to the run file's directory)",
                        gltf.display(),
                        path.display()
                    );
                    return Err(Error::Io { path: resolved, source: std::io::Error::new(e.kind(), context) });
                }
                crate::scene::gltf::load_gltf_within(
                    &resolved,
                    self.camera.name.as_deref(),
                    self.memory_budget_bytes(),
                )?
            }
            None => {
                if let Some(name) = &self.camera.name {
                    return Err(Error::RunFile {
                        path: path.to_path_buf(),
                        message: format!(
                            "camera.name = \"{name}\" but the run file loads no glTF to pick it from"
                        ),
                    });
                }
                Scene { source: path.to_path_buf(), ..Scene::default() }
            }
        };
        self.add_spheres(&mut scene);
        for (i, light) in self.lights.iter().enumerate() {
            // Checked when the run file was parsed.
            let desc =
                light.to_desc(i).map_err(|message| Error::RunFile { path: path.to_path_buf(), message })?;
            scene.punctual_lights.push(desc);
        }
        self.apply_motions(&mut scene, path)?;
        let origin = format!("{}, relative to its directory", path.display());
        scene.environment = self.environment.load(path.parent().unwrap_or(Path::new("")), &origin)?;
        Ok(scene)
    }

    fn add_spheres(&self, scene: &mut Scene) {
        for (i, spec) in self.spheres.iter().enumerate() {
            let name = spec.name.clone().unwrap_or_else(|| format!("sphere #{i}"));
            let material = spec.material.to_material(&name, spec.radius);
            scene.materials.push(material);
            scene.spheres.push(Sphere {
                name,
                center: Vec3::from(spec.center),
                radius: spec.radius,
                material: (scene.materials.len() - 1) as u32,
                motion: spec.motion.map(Vec3::from),
            });
        }
    }

    fn apply_motions(&self, scene: &mut Scene, path: &Path) -> Result<()> {
        for motion in &self.motion {
            let mut found = false;
            for mesh in
                scene.meshes.iter_mut().filter(|m| m.node_name.as_deref() == Some(motion.node.as_str()))
            {
                mesh.motion = Some(Vec3::from(motion.translate));
                found = true;
            }
            if !found {
                let mut names: Vec<&str> =
                    scene.meshes.iter().filter_map(|m| m.node_name.as_deref()).collect();
                names.dedup();
                let names = if names.is_empty() { "none".to_owned() } else { names.join(", ") };
                return Err(Error::InvalidScene {
                    path: path.to_path_buf(),
                    object: format!("[[motion]] node = \"{}\"", motion.node),
                    problem: format!("no node of that name carries a mesh; named nodes with meshes: {names}"),
                });
            }
        }
        Ok(())
    }
}

impl MaterialSpec {
    /// The material a sphere of this radius gets: double-sided, and a closed solid as thick as the sphere.
    pub fn to_material(&self, name: &str, radius: f32) -> MaterialDesc {
        MaterialDesc {
            name: name.to_owned(),
            shading: ShadingParams {
                base_color: Vec3::from(self.base_color),
                metallic: self.metallic,
                roughness: self.roughness,
                transmission: self.transmission,
                ior: self.ior,
                specular: self.specular,
                specular_color: Vec3::ONE,
                clearcoat: self.clearcoat,
                clearcoat_roughness: self.clearcoat_roughness,
                thickness: 2.0 * radius,
            },
            base_color_texture: None,
            metallic_roughness_texture: None,
            emission: self.emission(),
            emissive_texture: None,
            normal_texture: None,
            normal_scale: 1.0,
            clearcoat_texture: None,
            clearcoat_roughness_texture: None,
            clearcoat_normal_texture: None,
            attenuation: self.attenuation(),
            double_sided: true,
            alpha_mode: crate::scene::AlphaMode::Opaque,
            alpha: 1.0,
            unlit: false,
        }
    }
}
