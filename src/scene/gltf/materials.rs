//! Materials and textures: glTF's metallic-roughness with its extensions as a `MaterialDesc`, and
//! images decoded to linear RGBA once per use (colour or data).

use super::{Loader, label};
use crate::error::Result;
use crate::materials::ShadingParams;
use crate::scene::{AlphaMode, MaterialDesc, Texture, TextureRef, Wrap};
use glam::{Vec2, Vec3, Vec4};
use tracing::warn;

impl Loader<'_> {
    pub(super) fn default_material(&mut self) -> u32 {
        *self.default_material.get_or_insert_with(|| {
            self.scene.materials.push(MaterialDesc::default());
            (self.scene.materials.len() - 1) as u32
        })
    }

    pub(super) fn material(&mut self, material: &gltf::Material) -> Result<MaterialDesc> {
        let index = material.index().unwrap_or_default();
        let object = label("material", material.name(), index);
        let pbr = material.pbr_metallic_roughness();
        let [r, g, b, alpha] = pbr.base_color_factor();
        let base_color_texture =
            pbr.base_color_texture().map(|info| self.texture_ref(&info, true)).transpose()?;
        let metallic_roughness_texture =
            pbr.metallic_roughness_texture().map(|info| self.texture_ref(&info, false)).transpose()?;
        let emissive_texture =
            material.emissive_texture().map(|info| self.texture_ref(&info, true)).transpose()?;
        // Normal maps are data, not colour; KHR_texture_transform on them is not read (rare).
        let normal = material.normal_texture();
        let normal_texture = match &normal {
            Some(n) => {
                let texture = self.texture(&n.texture(), false)?;
                Some(TextureRef { texture, tex_coord: n.tex_coord(), transform: None })
            }
            None => None,
        };
        for (slot, texture) in [
            ("baseColorTexture", &base_color_texture),
            ("metallicRoughnessTexture", &metallic_roughness_texture),
            ("emissiveTexture", &emissive_texture),
            ("normalTexture", &normal_texture),
        ] {
            if let Some(t) = texture.filter(|t| t.tex_coord > 1) {
                return Err(self.invalid(
                    object,
                    format!(
                        "{slot} reads TEXCOORD_{}; only TEXCOORD_0 and TEXCOORD_1 are supported",
                        t.tex_coord
                    ),
                ));
            }
        }
        let mut ignored = Vec::new();
        let specular = material.specular();
        // gltf 1.4 does not parse KHR_materials_clearcoat: read it from the raw JSON.
        let clearcoat = material.extension_value("KHR_materials_clearcoat");
        let factor = |key: &str, default: f32| {
            clearcoat.and_then(|c| c.get(key)).and_then(|v| v.as_f64()).map_or(default, |v| v as f32)
        };
        let clearcoat_texture = self.extension_texture(clearcoat, "clearcoatTexture", &object)?;
        let clearcoat_roughness_texture =
            self.extension_texture(clearcoat, "clearcoatRoughnessTexture", &object)?;
        let clearcoat_normal_texture =
            self.extension_texture(clearcoat, "clearcoatNormalTexture", &object)?.map(|t| {
                let scale = clearcoat.and_then(|c| c.get("clearcoatNormalTexture")?.get("scale")?.as_f64());
                (t, scale.map_or(1.0, |s| s as f32))
            });
        let volume = material.volume();
        if let Some(v) = &volume {
            // KHR_materials_volume: a distance light travels before it is attenuated to the colour,
            // which is a fraction of each channel; anything else means nothing the extension defines.
            let (distance, color) = (v.attenuation_distance(), v.attenuation_color());
            if distance.is_nan() || distance <= 0.0 {
                return Err(self.invalid(
                    object,
                    format!("KHR_materials_volume attenuationDistance is {distance}, must be positive"),
                ));
            }
            if !color.iter().all(|c| (0.0..=1.0).contains(c)) {
                return Err(self.invalid(
                    object,
                    format!(
                        "KHR_materials_volume attenuationColor is {color:?}, each channel must be in [0, 1]"
                    ),
                ));
            }
        }

        if material.occlusion_texture().is_some() {
            ignored.push("occlusionTexture");
        }
        if material.transmission().is_some_and(|t| t.transmission_texture().is_some()) {
            ignored.push("transmissionTexture");
        }
        if specular
            .as_ref()
            .is_some_and(|s| s.specular_texture().is_some() || s.specular_color_texture().is_some())
        {
            ignored.push("specular textures");
        }
        // thicknessTexture is not read, on purpose: it is a rasterizer's stand-in for the distance a
        // ray travels inside the mesh, which a path tracer measures on the geometry itself.
        if !ignored.is_empty() {
            warn!(file = %self.path.display(), "{object}: not supported, ignored: {}", ignored.join(", "));
        }

        let desc = MaterialDesc {
            name: material.name().map_or_else(|| format!("material #{index}"), str::to_owned),
            shading: ShadingParams {
                base_color: Vec3::new(r, g, b),
                metallic: pbr.metallic_factor(),
                roughness: pbr.roughness_factor(),
                transmission: material.transmission().map_or(0.0, |t| t.transmission_factor()),
                ior: material.ior().unwrap_or(1.5),
                specular: specular.as_ref().map_or(1.0, |s| s.specular_factor()),
                specular_color: specular
                    .as_ref()
                    .map_or(Vec3::ONE, |s| Vec3::from(s.specular_color_factor())),
                clearcoat: factor("clearcoatFactor", 0.0),
                clearcoat_roughness: factor("clearcoatRoughnessFactor", 0.0),
                thickness: volume.as_ref().map_or(0.0, |v| v.thickness_factor()),
            },
            base_color_texture,
            metallic_roughness_texture,
            emission: Vec3::from(material.emissive_factor()) * material.emissive_strength().unwrap_or(1.0),
            emissive_texture,
            normal_texture,
            normal_scale: normal.as_ref().map_or(1.0, |n| n.scale()),
            clearcoat_texture,
            clearcoat_roughness_texture,
            clearcoat_normal_texture,
            attenuation: volume.as_ref().map_or(Vec3::ZERO, |v| {
                crate::scene::absorption(Vec3::from(v.attenuation_color()), v.attenuation_distance())
            }),
            double_sided: material.double_sided(),
            alpha_mode: match material.alpha_mode() {
                gltf::material::AlphaMode::Opaque => AlphaMode::Opaque,
                gltf::material::AlphaMode::Mask => {
                    AlphaMode::Mask { cutoff: material.alpha_cutoff().unwrap_or(0.5) }
                }
                gltf::material::AlphaMode::Blend => AlphaMode::Blend,
            },
            alpha,
            unlit: false,
        };
        Ok(match material.extension_value("KHR_materials_unlit") {
            Some(_) => unlit(desc),
            None => desc,
        })
    }

    /// A texture an extension the gltf crate does not parse names in `json[key]` (`index`,
    /// `texCoord`): linear data.
    fn extension_texture(
        &mut self,
        json: Option<&gltf::json::Value>,
        key: &str,
        object: &str,
    ) -> Result<Option<TextureRef>> {
        let Some(info) = json.and_then(|j| j.get(key)) else { return Ok(None) };
        let index = info.get("index").and_then(|v| v.as_u64()).map(|i| i as usize);
        let texture = index.and_then(|i| self.document.textures().nth(i));
        let Some(texture) = texture else {
            return Err(self.invalid(object, format!("{key} names no texture of the file: {info}")));
        };
        let tex_coord = info.get("texCoord").and_then(|v| v.as_u64()).unwrap_or(0) as u32;
        if tex_coord > 1 {
            return Err(
                self.invalid(object, format!("{key} reads TEXCOORD_{tex_coord}; only 0 and 1 are supported"))
            );
        }
        Ok(Some(TextureRef { texture: self.texture(&texture, false)?, tex_coord, transform: None }))
    }

    pub(super) fn texture_ref(&mut self, info: &gltf::texture::Info, srgb: bool) -> Result<TextureRef> {
        let texture = self.texture(&info.texture(), srgb)?;
        Ok(match info.texture_transform() {
            Some(t) => TextureRef {
                texture,
                tex_coord: t.tex_coord().unwrap_or(info.tex_coord()),
                transform: Some(uv_transform(t.offset(), t.rotation(), t.scale())),
            },
            None => TextureRef { texture, tex_coord: info.tex_coord(), transform: None },
        })
    }

    pub(super) fn texture(&mut self, texture: &gltf::Texture, srgb: bool) -> Result<u32> {
        if let Some(&index) = self.textures.get(&(texture.index(), srgb)) {
            return Ok(index);
        }
        let image = texture.source();
        let data = self.images.get(image.index()).ok_or_else(|| {
            self.invalid(label("texture", texture.name(), texture.index()), "refers to a missing image")
        })?;
        let name = texture
            .name()
            .or(image.name())
            .map(str::to_owned)
            .or_else(|| match image.source() {
                gltf::image::Source::Uri { uri, .. } if !uri.starts_with("data:") => Some(uri.to_owned()),
                _ => None,
            })
            .unwrap_or_else(|| format!("texture #{}", texture.index()));
        let sampler = texture.sampler();
        // An 8-bit image's texels are kept as its bytes (4 a texel), a deeper one's as linear
        // floats (16): counted against the budget before they are made, and made fallibly.
        let object = || label("texture", texture.name(), texture.index());
        let eight_bit = matches!(
            data.format,
            gltf::image::Format::R8
                | gltf::image::Format::R8G8
                | gltf::image::Format::R8G8B8
                | gltf::image::Format::R8G8B8A8
        );
        let texel_bytes = if eight_bit { size_of::<[u8; 4]>() } else { size_of::<Vec4>() };
        let bytes = u64::from(data.width) * u64::from(data.height) * texel_bytes as u64;
        self.texture_bytes += bytes;
        if self.texture_bytes > self.budget {
            return Err(self.invalid(
                object(),
                format!(
                    "its {}x{} texels need {} MiB, {} MiB with the textures before it, over \
                     the memory budget of {} MiB (--memory-budget-mib)",
                    data.width,
                    data.height,
                    bytes.div_ceil(1 << 20),
                    self.texture_bytes.div_ceil(1 << 20),
                    self.budget.div_ceil(1 << 20)
                ),
            ));
        }
        let texels = decode(data, srgb).map_err(|_| {
            let what = format!("the {}x{} texels of {}", data.width, data.height, object());
            crate::error::Error::OutOfMemory { what, bytes, budget: self.budget }
        })?;
        let (texels, bytes) = match texels {
            Texels::Bytes(bytes) => (Vec::new(), bytes),
            Texels::Floats(texels) => (texels, Vec::new()),
        };
        self.scene.textures.push(Texture {
            name,
            width: data.width,
            height: data.height,
            texels,
            bytes,
            srgb,
            wrap_s: wrap(sampler.wrap_s()),
            wrap_t: wrap(sampler.wrap_t()),
        });
        let index = (self.scene.textures.len() - 1) as u32;
        self.textures.insert((texture.index(), srgb), index);
        Ok(index)
    }
}

/// KHR_texture_transform's `T * R * S` as columns (x axis, y axis, offset); the rotation is counter-clockwise in
/// uv space whose v points down, as the extension's ratified text and its example define it.
fn uv_transform(offset: [f32; 2], rotation: f32, scale: [f32; 2]) -> [Vec2; 3] {
    let (sin, cos) = rotation.sin_cos();
    [Vec2::new(cos, -sin) * scale[0], Vec2::new(sin, cos) * scale[1], Vec2::from(offset)]
}

fn wrap(mode: gltf::texture::WrappingMode) -> Wrap {
    match mode {
        gltf::texture::WrappingMode::ClampToEdge => Wrap::ClampToEdge,
        gltf::texture::WrappingMode::MirroredRepeat => Wrap::MirroredRepeat,
        gltf::texture::WrappingMode::Repeat => Wrap::Repeat,
    }
}

/// An image's texels, as [`Texture`] holds them: an 8-bit image's bytes as RGBA (grey replicated
/// to RGB, a missing alpha 255), decoded when read; a 16-bit or float image's as linear RGBA
/// floats (grey replicated, a missing alpha 1). An error where the allocator has not got them.
fn decode(
    image: &gltf::image::Data,
    srgb: bool,
) -> std::result::Result<Texels, std::collections::TryReserveError> {
    use gltf::image::Format;
    let (channels, bytes) = match image.format {
        Format::R8 => (1, 1),
        Format::R8G8 => (2, 1),
        Format::R8G8B8 => (3, 1),
        Format::R8G8B8A8 => (4, 1),
        Format::R16 => (1, 2),
        Format::R16G16 => (2, 2),
        Format::R16G16B16 => (3, 2),
        Format::R16G16B16A16 => (4, 2),
        Format::R32G32B32FLOAT => (3, 4),
        Format::R32G32B32A32FLOAT => (4, 4),
    };
    let count = image.pixels.len() / (channels * bytes);
    if bytes == 1 {
        let mut texels = Vec::new();
        texels.try_reserve_exact(count)?;
        texels.extend(image.pixels.chunks_exact(channels).map(|px| match channels {
            1 => [px[0], px[0], px[0], 255],
            2 => [px[0], px[0], px[0], px[1]],
            3 => [px[0], px[1], px[2], 255],
            _ => [px[0], px[1], px[2], px[3]],
        }));
        return Ok(Texels::Bytes(texels));
    }
    // Float images are linear already; only integer encodings carry the sRGB curve.
    let srgb = srgb && bytes < 4;
    let mut texels = Vec::new();
    texels.try_reserve_exact(count)?;
    texels.extend(image.pixels.chunks_exact(channels * bytes).map(|px| {
        let c = |i: usize| {
            let b = &px[i * bytes..];
            match bytes {
                2 => f32::from(u16::from_ne_bytes([b[0], b[1]])) / 65535.0,
                _ => f32::from_ne_bytes([b[0], b[1], b[2], b[3]]),
            }
        };
        let (rgb, alpha) = match channels {
            1 => (Vec3::splat(c(0)), 1.0),
            2 => (Vec3::splat(c(0)), c(1)),
            3 => (Vec3::new(c(0), c(1), c(2)), 1.0),
            _ => (Vec3::new(c(0), c(1), c(2)), c(3)),
        };
        let rgb = if srgb { rgb.map(srgb_to_linear) } else { rgb };
        rgb.extend(alpha)
    }));
    Ok(Texels::Floats(texels))
}

/// Decoded texels: an 8-bit image's bytes, or linear floats.
enum Texels {
    Bytes(Vec<[u8; 4]>),
    Floats(Vec<Vec4>),
}

/// The sRGB electro-optical transfer function (IEC 61966-2-1).
pub fn srgb_to_linear(c: f32) -> f32 {
    if c <= 0.04045 { c / 12.92 } else { ((c + 0.055) / 1.055).powf(2.4) }
}

/// KHR_materials_unlit for a path tracer: the base colour (and its texture) is emitted and nothing is
/// reflected, so the surface shows its colour whatever lights it, as the extension asks. The base
/// colour texture stays for its alpha (masks, blending); everything else the material says is
/// lighting, which the extension leaves out. Vertex colours, which multiply the base colour, do not
/// reach the emission.
fn unlit(lit: MaterialDesc) -> MaterialDesc {
    MaterialDesc {
        shading: ShadingParams {
            base_color: Vec3::ZERO,
            metallic: 0.0,
            specular: 0.0,
            ..ShadingParams::default()
        },
        emission: lit.shading.base_color,
        emissive_texture: lit.base_color_texture,
        unlit: true,
        name: lit.name,
        base_color_texture: lit.base_color_texture,
        double_sided: lit.double_sided,
        alpha_mode: lit.alpha_mode,
        alpha: lit.alpha,
        ..MaterialDesc::default()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn srgb_curve_hits_its_reference_points() {
        assert_eq!(srgb_to_linear(0.0), 0.0);
        assert!((srgb_to_linear(1.0) - 1.0).abs() < 1e-6);
        assert!((srgb_to_linear(0.5) - 0.214_041_14).abs() < 1e-6);
        // The linear segment and the power segment meet at 0.04045.
        assert!((srgb_to_linear(0.04045) - srgb_to_linear(0.040_450_01)).abs() < 1e-6);
    }

    #[test]
    fn decode_handles_grey_alpha_and_sixteen_bit_images() {
        use gltf::image::{Data, Format};
        let texture = |texels: Texels, srgb: bool| {
            let (texels, bytes) = match texels {
                Texels::Bytes(bytes) => (Vec::new(), bytes),
                Texels::Floats(texels) => (texels, Vec::new()),
            };
            Texture { width: 1, height: 1, texels, bytes, srgb, ..Texture::default() }
        };
        let grey_alpha = Data { pixels: vec![255, 51], format: Format::R8G8, width: 1, height: 1 };
        let grey_alpha = texture(decode(&grey_alpha, true).unwrap(), true);
        assert_eq!(grey_alpha.texels().collect::<Vec<_>>(), vec![Vec4::new(1.0, 1.0, 1.0, 0.2)]);
        let rgb16: Vec<u8> = [65535u16, 0, 32768].iter().flat_map(|v| v.to_ne_bytes()).collect();
        let rgb16 = Data { pixels: rgb16, format: Format::R16G16B16, width: 1, height: 1 };
        let texel = texture(decode(&rgb16, false).unwrap(), false).texel(0);
        assert_eq!((texel.x, texel.y, texel.w), (1.0, 0.0, 1.0));
        assert!((texel.z - 0.5).abs() < 1e-4);
    }

    #[test]
    fn texture_transform_follows_the_extension_example() {
        // KHR_texture_transform README: offset [0, 1], rotation 90°, scale 0.5 uses the lower-left quadrant.
        let [x, y, offset] = uv_transform([0.0, 1.0], std::f32::consts::FRAC_PI_2, [0.5, 0.5]);
        for uv in [Vec2::ZERO, Vec2::X, Vec2::Y, Vec2::ONE] {
            let t = x * uv.x + y * uv.y + offset;
            assert!(t.x > -1e-6 && t.x < 0.5 + 1e-6 && t.y > 0.5 - 1e-6 && t.y < 1.0 + 1e-6, "{uv} -> {t}");
        }
    }
}
