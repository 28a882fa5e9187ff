//! glTF materials as [`Material`]s: the metallic-roughness BSDF with its
//! textures, factors multiplied into the texels once at load, and the
//! extensions the renderer reads (`KHR_texture_transform`,
//! `KHR_materials_emissive_strength`, `_specular`, `_ior`, `_transmission`).
//!
//! - **Base colour**: `baseColorFactor` times the texture (sRGB) becomes
//!   [`Material::texture`]; the BSDF's constant is the factor. A material
//!   whose specular layer has weight 0 (`KHR_materials_specular`'s
//!   `specularFactor` 0) and whose metalness is 0 is exactly Lambertian and
//!   becomes the diffuse BSDF, which runs the diffuse-only kernels.
//! - **Metallic-roughness**: the texture (linear; green roughness, blue
//!   metalness) times the factors becomes [`Maps::metallic_roughness`].
//! - **Normal**: the texture (linear) with `scale` applied to its x and y,
//!   [`Maps::normal`], in the tangent frame of the texture coordinates
//!   (glTF's `+y` is up in the image, the renderer's `dp/dv` once `v` is
//!   flipped, see `mod.rs`).
//! - **Emission**: `emissiveFactor` times `emissiveStrength` times the
//!   texture (sRGB), radiance as given (an area light).
//! - **Alpha**: `MASK` cuts out where `alpha < alphaCutoff` (the base
//!   colour's alpha times the factor's, thresholded per texel, so the edges
//!   between texels are stochastic); `BLEND` is a mask at 0.5, with a
//!   warning.
//! - **Transmission** (`transmissionFactor >= 0.5`): a dielectric of the
//!   material's `ior` tinted by the base colour, rough ([`RoughGlass`],
//!   GGX `alpha = roughness^2`) or smooth ([`Glass`]); partial transmission
//!   is rendered as full, with a warning (the layered mix of the
//!   specification's BTDF and the diffuse base is not modelled).
//!
//! The whole material reads one set of texture coordinates with one
//! transform: the base colour's (else the first textured slot's). A slot
//! that asks for another set or transform is read with those, with a
//! warning. `occlusionTexture` is ignored with a note (a path tracer
//! computes occlusion); so are the specular extension's textures.

use super::Once;
use super::buffers::image_bytes;
use crate::bsdf::{Bsdf, Glass, MetallicRoughness, Microfacet, RoughGlass};
use crate::error::{Error, Result};
use crate::math::Vec3;
use crate::scene::{AlphaMask, Maps, Material};
use crate::texture::ImageTexture;
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::rc::Rc;
use std::sync::Arc;

/// `KHR_texture_transform`: `uv' = T R S uv` in glTF's texture space.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct UvTransform {
    offset: [f32; 2],
    rotation: f32,
    scale: [f32; 2],
}

impl UvTransform {
    /// The transformed coordinates. The rotation turns the coordinates
    /// counter-clockwise (the image clockwise): `u' = cos u + sin v`, `v' =
    /// -sin u + cos v`, the sense that the extension's own example (offset
    /// `[0, 1]`, a quarter turn, scale 1/2: "the lower left quadrant of the
    /// source image, rotated clockwise 90 degrees") needs; the GLSL matrix
    /// printed beside it turns the other way.
    pub(super) fn apply(&self, uv: [f32; 2]) -> [f32; 2] {
        let (s, c) = self.rotation.sin_cos();
        let (x, y) = (uv[0] * self.scale[0], uv[1] * self.scale[1]);
        [
            c * x + s * y + self.offset[0],
            -s * x + c * y + self.offset[1],
        ]
    }
}

/// A material ready for the meshes, with the texture coordinates it reads.
#[derive(Debug, Clone)]
pub(super) struct Built {
    pub material: Material,
    /// `TEXCOORD_n`.
    pub uv_set: u32,
    pub uv_transform: Option<UvTransform>,
}

/// A decoded image: linear colour (sRGB-decoded unless raw) and alpha.
struct Decoded {
    width: u32,
    height: u32,
    rgb: Vec<f32>,
    alpha: Option<Vec<f32>>,
}

/// Materials, each built once, and the images they decode.
pub(super) struct Materials<'a> {
    path: &'a Path,
    buffers: &'a [Vec<u8>],
    /// Image files read.
    pub files: Vec<PathBuf>,
    decoded: HashMap<(usize, bool), Rc<Decoded>>,
    textures: HashMap<String, Arc<ImageTexture>>,
    built: HashMap<Option<usize>, Built>,
}

/// A texture slot: which image, which coordinates, which transform.
struct Slot<'a> {
    name: &'static str,
    texture: gltf::Texture<'a>,
    uv_set: u32,
    transform: Option<UvTransform>,
}

impl<'a> Slot<'a> {
    fn from_info(name: &'static str, info: gltf::texture::Info<'a>) -> Self {
        let t = info.texture_transform();
        Slot {
            name,
            texture: info.texture(),
            uv_set: t
                .as_ref()
                .and_then(|t| t.tex_coord())
                .unwrap_or(info.tex_coord()),
            transform: t.map(|t| UvTransform {
                offset: t.offset(),
                rotation: t.rotation(),
                scale: t.scale(),
            }),
        }
    }
}

impl<'a> Materials<'a> {
    pub(super) fn new(path: &'a Path, buffers: &'a [Vec<u8>]) -> Self {
        Materials {
            path,
            buffers,
            files: Vec::new(),
            decoded: HashMap::new(),
            textures: HashMap::new(),
            built: HashMap::new(),
        }
    }

    fn fail(&self, m: String) -> Error {
        Error::input(self.path, None, m)
    }

    /// The image of `texture`, decoded (from sRGB unless `raw`).
    fn decode(&mut self, texture: &gltf::Texture<'_>, raw: bool) -> Result<Rc<Decoded>> {
        let image = texture.source();
        let key = (image.index(), raw);
        if let Some(d) = self.decoded.get(&key) {
            return Ok(d.clone());
        }
        let bytes = image_bytes(self.path, &image, self.buffers, &mut self.files)?;
        let (width, height, rgb, alpha) = crate::image::decode_image_bytes(&bytes, raw)
            .map_err(|e| self.fail(format!("image {}: {e}", image.index())))?;
        let d = Rc::new(Decoded {
            width,
            height,
            rgb,
            alpha,
        });
        self.decoded.insert(key, d.clone());
        Ok(d)
    }

    /// A texture made from `texture`'s image by `f` on each texel (colour
    /// and alpha), cached under `key`.
    fn derived(
        &mut self,
        texture: &gltf::Texture<'_>,
        raw: bool,
        key: String,
        f: impl Fn(Vec3, f32) -> Vec3,
    ) -> Result<Arc<ImageTexture>> {
        let key = format!("{}:{raw}:{key}", texture.source().index());
        if let Some(t) = self.textures.get(&key) {
            return Ok(t.clone());
        }
        let d = self.decode(texture, raw)?;
        let rgb: Vec<f32> = d
            .rgb
            .chunks_exact(3)
            .enumerate()
            .flat_map(|(i, c)| {
                let a = d.alpha.as_ref().map_or(1.0, |a| a[i]);
                f(Vec3::new(c[0], c[1], c[2]), a).to_array()
            })
            .collect();
        let t = Arc::new(
            ImageTexture::from_linear_rgb(d.width, d.height, rgb)
                .map_err(|e| self.fail(format!("image {}: {e}", texture.source().index())))?,
        );
        self.textures.insert(key, t.clone());
        Ok(t)
    }

    /// The material `m` (the default material when it has no index).
    pub(super) fn get(&mut self, m: &gltf::Material<'_>, once: &mut Once) -> Result<Built> {
        if let Some(b) = self.built.get(&m.index()) {
            return Ok(b.clone());
        }
        let b = self.build(m, once)?;
        self.built.insert(m.index(), b.clone());
        Ok(b)
    }

    fn build(&mut self, m: &gltf::Material<'_>, once: &mut Once) -> Result<Built> {
        let name = match (m.name(), m.index()) {
            (Some(n), _) => crate::error::one_line(n).into_owned(),
            (None, Some(i)) => format!("material {i}"),
            (None, None) => "default".to_string(),
        };
        let pbr = m.pbr_metallic_roughness();
        let [r, g, b, a] = pbr.base_color_factor();
        let base = Vec3::new(r, g, b);
        let metallic = pbr.metallic_factor();
        let roughness = pbr.roughness_factor();
        let strength = m.emissive_strength().unwrap_or(1.0);
        let emissive = Vec3::from(m.emissive_factor()) * strength;

        // the slots, and the coordinates the material reads
        let mut slots: Vec<Slot> = Vec::new();
        slots.extend(
            pbr.base_color_texture()
                .map(|i| Slot::from_info("base colour", i)),
        );
        slots.extend(
            pbr.metallic_roughness_texture()
                .map(|i| Slot::from_info("metallic-roughness", i)),
        );
        slots.extend(m.emissive_texture().map(|i| Slot::from_info("emissive", i)));
        let normal = m.normal_texture();
        if let Some(n) = &normal {
            slots.push(Slot {
                name: "normal",
                texture: n.texture(),
                uv_set: n.tex_coord(),
                transform: None,
            });
        }
        let (uv_set, uv_transform) = slots.first().map_or((0, None), |s| (s.uv_set, s.transform));
        for s in &slots[1.min(slots.len())..] {
            if s.uv_set != uv_set || (s.transform.is_some() && s.transform != uv_transform) {
                once.warn(
                    "uv-sets",
                    format!(
                        "material `{name}`: its {} texture reads other texture coordinates or another transform than its first; every texture of a material reads the first's",
                        s.name
                    ),
                );
            }
        }
        for s in &slots {
            let sampler = s.texture.sampler();
            if sampler.wrap_s() != gltf::texture::WrappingMode::Repeat
                || sampler.wrap_t() != gltf::texture::WrappingMode::Repeat
            {
                once.warn(
                    "wrap",
                    "a texture sampler's CLAMP_TO_EDGE or MIRRORED_REPEAT wrapping is read as REPEAT".to_string(),
                );
            }
        }
        if m.occlusion_texture().is_some() {
            once.note(
                "occlusion",
                "occlusionTexture ignored: a path tracer computes occlusion itself".to_string(),
            );
        }

        let mut maps = Maps::default();
        let mut material = Material {
            name: name.clone(),
            two_sided: m.double_sided(),
            ..Material::default()
        };
        // base colour (and alpha)
        let base_texture = match pbr.base_color_texture() {
            Some(info) => {
                let t = info.texture();
                let k = format!("base:{base:?}");
                Some((self.derived(&t, false, k, |c, _| c * base)?, t))
            }
            None => None,
        };
        let transmission = m.transmission().map_or(0.0, |t| t.transmission_factor());
        let bsdf = if transmission >= 0.5 {
            if transmission < 1.0 {
                once.warn(
                    "partial-transmission",
                    format!("material `{name}`: a transmissionFactor of {transmission} is rendered as full transmission"),
                );
            }
            if m.transmission()
                .and_then(|t| t.transmission_texture())
                .is_some()
            {
                once.warn(
                    "transmission-texture",
                    "transmissionTexture ignored".to_string(),
                );
            }
            let ior = m.ior().unwrap_or(1.5);
            let ior = if ior >= 1.0 { ior } else { 1.5 };
            maps.transmittance = base_texture.as_ref().map(|(t, _)| t.clone());
            let transmittance = base.clamp(Vec3::ZERO, Vec3::ONE);
            let alpha = roughness * roughness;
            if alpha >= Microfacet::SMOOTH_ALPHA {
                Bsdf::RoughGlass(RoughGlass {
                    ior,
                    alpha,
                    reflectance: Vec3::ONE,
                    transmittance,
                })
            } else {
                Bsdf::Glass(Glass {
                    ior,
                    reflectance: Vec3::ONE,
                    transmittance,
                })
            }
        } else {
            if transmission > 0.0 {
                once.warn(
                    "partial-transmission",
                    format!("material `{name}`: a transmissionFactor of {transmission} (under 0.5) is rendered opaque"),
                );
            }
            let (specular, specular_color) = match m.specular() {
                Some(s) => {
                    if s.specular_texture().is_some() || s.specular_color_texture().is_some() {
                        once.warn(
                            "specular-texture",
                            "KHR_materials_specular's specularTexture and specularColorTexture ignored".to_string(),
                        );
                    }
                    (s.specular_factor(), Vec3::from(s.specular_color_factor()))
                }
                None => (1.0, Vec3::ONE),
            };
            material.texture = base_texture.as_ref().map(|(t, _)| t.clone());
            if specular == 0.0 && metallic == 0.0 && pbr.metallic_roughness_texture().is_none() {
                // exactly base_color / pi: the Lambertian BSDF, so that the
                // scene runs the diffuse kernels (and says so in its plan)
                Bsdf::Diffuse(crate::bsdf::Diffuse { albedo: base })
            } else {
                Bsdf::MetallicRoughness(MetallicRoughness {
                    base_color: base,
                    metallic,
                    roughness,
                    specular,
                    specular_color,
                    ior: m.ior().unwrap_or(1.5),
                })
            }
        };
        bsdf.validate()
            .map_err(|e| self.fail(format!("material `{name}`: {e}")))?;
        material.bsdf = bsdf;

        if matches!(bsdf, Bsdf::MetallicRoughness(_)) {
            if let Some(info) = pbr.metallic_roughness_texture() {
                let k = format!("mr:{metallic}:{roughness}");
                maps.metallic_roughness =
                    Some(self.derived(&info.texture(), true, k, |c, _| {
                        Vec3::new(0.0, c.y * roughness, c.z * metallic)
                    })?);
            }
        }
        if let Some(n) = &normal {
            let s = n.scale();
            let k = format!("normal:{s}");
            // n = normalize((2 c - 1) (s, s, 1)), stored back as (n' + 1) / 2
            // before normalising (the renderer normalises per lookup)
            maps.normal = Some(self.derived(&n.texture(), true, k, |c, _| {
                let v = (2.0 * c - Vec3::ONE) * Vec3::new(s, s, 1.0);
                ((v + Vec3::ONE) * 0.5).max(Vec3::ZERO)
            })?);
        }
        if !(emissive.is_finite() && emissive.min_element() >= 0.0) {
            return Err(self.fail(format!(
                "material `{name}`: emissiveFactor times emissiveStrength must be finite and >= 0, got {emissive}"
            )));
        }
        match m.emissive_texture() {
            Some(info) if emissive.max_element() > 0.0 => {
                let k = format!("emissive:{emissive:?}");
                let t = self.derived(&info.texture(), false, k, |c, _| c * emissive)?;
                material.emission = t.mean();
                maps.emission = Some(t);
            }
            _ => material.emission = emissive,
        }

        // alpha
        let cutoff = match m.alpha_mode() {
            gltf::material::AlphaMode::Opaque => None,
            gltf::material::AlphaMode::Mask => Some(m.alpha_cutoff().unwrap_or(0.5)),
            gltf::material::AlphaMode::Blend => {
                once.warn(
                    "blend",
                    "alphaMode BLEND is rendered as a cut-out at alpha 0.5".to_string(),
                );
                Some(0.5)
            }
        };
        if let Some(cutoff) = cutoff {
            let mask = match &base_texture {
                Some((_, t)) if self.decode(t, false)?.alpha.is_some() => {
                    let k = format!("alpha:{a}:{cutoff}");
                    AlphaMask::Texture(self.derived(t, false, k, |_, alpha| {
                        Vec3::splat(if alpha * a >= cutoff { 1.0 } else { 0.0 })
                    })?)
                }
                _ => AlphaMask::Constant(if a >= cutoff { 1.0 } else { 0.0 }),
            };
            if mask != AlphaMask::Constant(1.0) {
                if material.emission.max_element() > 0.0 {
                    once.warn(
                        "emissive-mask",
                        format!(
                            "material `{name}`: an emitter cannot be cut out; its alpha is ignored"
                        ),
                    );
                } else {
                    material.alpha_mask = Some(mask);
                }
            }
        }
        material.maps = maps;
        Ok(Built {
            material,
            uv_set,
            uv_transform,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The extension's example: offset `[0, 1]`, a quarter turn and scale
    /// 1/2 map the unit square onto the lower left quadrant of the image
    /// (`u` in `[0, 1/2]`, `v` in `[1/2, 1]`, `v` pointing down).
    #[test]
    fn texture_transform_follows_the_extensions_example() {
        let t = UvTransform {
            offset: [0.0, 1.0],
            rotation: std::f32::consts::FRAC_PI_2,
            scale: [0.5, 0.5],
        };
        for (uv, want) in [
            ([0.0, 0.0], [0.0, 1.0]),
            ([1.0, 0.0], [0.0, 0.5]),
            ([0.0, 1.0], [0.5, 1.0]),
            ([1.0, 1.0], [0.5, 0.5]),
        ] {
            let got = t.apply(uv);
            assert!(
                (got[0] - want[0]).abs() < 1e-6 && (got[1] - want[1]).abs() < 1e-6,
                "{uv:?} -> {got:?}, want {want:?}"
            );
        }
    }
}
