//! BSDFs (`diffuse`, `conductor`, `roughconductor`, `dielectric`,
//! `plastic`, `roughplastic`, `twosided`, `normalmap`, `bumpmap`) and
//! `bitmap` textures, read into a [`Material`].
//!
//! A `bitmap` (`filename`, `raw`; `filter_type` bilinear and `wrap_mode`
//! repeat, other values warned about and read as those) may stand for
//! diffuse `reflectance`, plastic `diffuse_reflectance`, dielectric
//! `specular_reflectance` and `specular_transmittance`, and roughconductor
//! `alpha`. As in Mitsuba, a PNG is decoded from sRGB unless `raw` is true,
//! whatever the parameter (a normal map without `raw` is decoded too).
//! Rough conductors and plastics take Mitsuba's separable masking-shadowing
//! `G1(wo) G1(wi)` ([`Masking::Separable`]; embertrace's own default is the
//! height-correlated form, brighter where both directions are masked, by
//! `1 + Lo Li / (1 + Lo + Li)` for Smith's `Lambda`s `Lo` and `Li`: 12 %
//! with GGX at alpha 0.3 and both directions 80 degrees from the normal),
//! so that a Mitsuba scene renders as in Mitsuba.
//! `normalmap` (its `normalmap` texture) and `bumpmap` (any nested texture,
//! `scale`) wrap one BSDF, whose material they give the map; their
//! `use_shadowing_function` is not modelled (a warning unless false) and
//! `flip_invalid_normals` is read and ignored.

use super::params::{Params, Value};
use super::{Loader, MAX_BSDF_NESTING};
use crate::bsdf::{Bsdf, Conductor, Diffuse, Distribution, Glass, Masking, Microfacet, Plastic};
use crate::error::{Error, Result, one_line};
use crate::math::Vec3;
use crate::scene::{EmissionRole, Material};
use crate::texture::ImageTexture;
use roxmltree::Node;
use std::sync::Arc;

/// Indices of refraction by Mitsuba's names (Mitsuba 3 documentation,
/// "Dielectric" plugin, table of named indices).
const NAMED_IOR: [(&str, f32); 23] = [
    ("vacuum", 1.0),
    ("helium", 1.00004),
    ("hydrogen", 1.00013),
    ("air", 1.00028),
    ("carbon dioxide", 1.00045),
    ("water", 1.3330),
    ("acetone", 1.36),
    ("ethanol", 1.361),
    ("carbon tetrachloride", 1.461),
    ("glycerol", 1.4729),
    ("benzene", 1.501),
    ("silicone oil", 1.52045),
    ("bromine", 1.661),
    ("water ice", 1.31),
    ("fused quartz", 1.458),
    ("pyrex", 1.470),
    ("acrylic glass", 1.49),
    ("polypropylene", 1.49),
    ("bk7", 1.5046),
    ("sodium chloride", 1.544),
    ("amber", 1.55),
    ("pet", 1.5750),
    ("diamond", 2.419),
];

impl<'a, 'i> Loader<'a, 'i> {
    pub(super) fn texture(&mut self, node: Node<'a, 'i>) -> Result<Arc<ImageTexture>> {
        let kind = self.need_attr(node, "type")?;
        if kind != "bitmap" {
            return Err(self.fail(
                node,
                format!(
                    "texture `{}` is not in the subset (expected bitmap)",
                    one_line(&kind)
                ),
            ));
        }
        let mut p = self.params(node)?;
        let file = p
            .text("filename")
            .ok_or_else(|| self.fail(node, "bitmap needs a `filename` string"))?;
        for key in ["filter_type", "wrap_mode"] {
            if let Some(v) = p.text(key) {
                let ours = if key == "filter_type" {
                    "bilinear"
                } else {
                    "repeat"
                };
                if v != ours {
                    self.warn(
                        node,
                        format!("bitmap {key} `{}`: embertrace uses {ours}", one_line(&v)),
                    );
                }
            }
        }
        let raw = p.boolean("raw").is_some_and(|v| v.0);
        self.finish(p);
        let full = self.dir.join(&file);
        if let Some(t) = self.textures.get(&(full.clone(), raw)) {
            return Ok(t.clone());
        }
        if let Some(why) = crate::scene::not_a_file(&full) {
            return Err(self.fail(node, format!("bitmap `{}` {why}", one_line(&file))));
        }
        let t = Arc::new(
            ImageTexture::load_as(&full, raw)
                .map_err(|e| self.fail(node, format!("bitmap: {e}")))?,
        );
        self.textures.insert((full, raw), t.clone());
        Ok(t)
    }

    /// A colour-like parameter that may be a bitmap: (value, texture).
    fn reflectance(
        &mut self,
        p: &mut Params<'a, 'i>,
        key: &str,
        default: f32,
    ) -> Result<(Vec3, Option<Arc<ImageTexture>>)> {
        if let Some(node) = p.object(key) {
            if node.tag_name().name() != "texture" {
                return Err(self.fail(node, format!("`{key}` must be a colour or a texture")));
            }
            return Ok((Vec3::splat(default), Some(self.texture(node)?)));
        }
        let c = p.colour(self, key)?.unwrap_or(Vec3::splat(default));
        if c.max_element() > 1.0 {
            return Err(Error::input(
                self.path,
                Some(p.line),
                format!("{}: `{key}` must be at most 1, got {c}", p.owner),
            ));
        }
        Ok((c, None))
    }

    fn ior(&self, p: &mut Params<'a, 'i>, key: &str, default: f32) -> Result<f32> {
        match p.take(key) {
            None => Ok(default),
            Some((Value::Number(v), _)) if v > 0.0 => Ok(v as f32),
            Some((Value::Text(name), line)) => NAMED_IOR
                .iter()
                .find(|(n, _)| *n == name.to_ascii_lowercase())
                .map(|(_, v)| *v)
                .ok_or_else(|| {
                    Error::input(
                        self.path,
                        Some(line),
                        format!(
                            "{key}: unknown material `{}` (give a number)",
                            one_line(&name)
                        ),
                    )
                }),
            Some((_, line)) => Err(Error::input(
                self.path,
                Some(line),
                format!("{key}: expected a positive number or a material name"),
            )),
        }
    }

    fn distribution(&self, p: &mut Params<'a, 'i>) -> Result<Distribution> {
        match p.text("distribution").as_deref() {
            None | Some("beckmann") => Ok(Distribution::Beckmann),
            Some("ggx") => Ok(Distribution::Ggx),
            Some(other) => Err(Error::input(
                self.path,
                Some(p.line),
                format!(
                    "distribution `{}` (expected beckmann or ggx)",
                    one_line(other)
                ),
            )),
        }
    }

    /// A roughness that may be a bitmap: (value, texture); with a texture,
    /// the value is its smallest (so a smooth texel shows as a delta lobe).
    fn alpha_or_texture(
        &mut self,
        p: &mut Params<'a, 'i>,
    ) -> Result<(f32, Option<Arc<ImageTexture>>)> {
        if let Some(node) = p.object("alpha") {
            if node.tag_name().name() != "texture" {
                return Err(self.fail(node, "`alpha` must be a number or a texture"));
            }
            let t = self.texture(node)?;
            return Ok((t.min_scalar(), Some(t)));
        }
        Ok((self.alpha(p)?, None))
    }

    fn alpha(&self, p: &mut Params<'a, 'i>) -> Result<f32> {
        let a = p.number("alpha").map_or(0.1, |v| v.0) as f32;
        if let (Some((u, _)), Some((v, _))) = (p.number("alpha_u"), p.number("alpha_v")) {
            if u != v {
                return Err(Error::input(
                    self.path,
                    Some(p.line),
                    "anisotropic roughness (alpha_u != alpha_v) is not in the subset",
                ));
            }
            return Ok(u as f32);
        }
        Ok(a)
    }

    /// A `<bsdf>`, nested ones (`twosided`, `mask`, `bumpmap`,
    /// `normalmap`) included. Nesting is bounded by [`MAX_BSDF_NESTING`] and a
    /// BSDF that contains itself through a `<ref>` is refused, so no file can
    /// recurse without end.
    pub(super) fn bsdf(&mut self, node: Node<'a, 'i>) -> Result<Material> {
        if self.resolving.contains(&node.id()) {
            let id = node.attribute("id").unwrap_or("");
            return Err(self.fail(
                node,
                format!(
                    "<bsdf id=\"{}\"> contains itself through a <ref>",
                    one_line(id)
                ),
            ));
        }
        if self.resolving.len() >= MAX_BSDF_NESTING {
            return Err(self.fail(node, format!("BSDFs nested deeper than {MAX_BSDF_NESTING}")));
        }
        self.resolving.push(node.id());
        let m = self.bsdf_at(node);
        self.resolving.pop();
        m
    }

    fn bsdf_at(&mut self, node: Node<'a, 'i>) -> Result<Material> {
        if node.tag_name().name() != "bsdf" {
            return Err(self.fail(node, "expected a <bsdf>"));
        }
        let kind = self.need_attr(node, "type")?;
        let name = node
            .attribute("id")
            .map_or_else(|| kind.clone(), str::to_string);
        let mut p = self.params(node)?;
        let mut texture = None;
        let mut maps = crate::scene::Maps::default();
        let air = 1.00028;
        let bsdf = match kind.as_str() {
            "twosided" => {
                let inner = p
                    .unnamed_of("bsdf")
                    .ok_or_else(|| self.fail(node, "twosided needs one nested <bsdf>"))?;
                if p.unnamed_of("bsdf").is_some() {
                    return Err(self.fail(
                        node,
                        "twosided with two different sides is not in the subset",
                    ));
                }
                self.finish(p);
                // the same BSDF on both sides (the front's, mirrored)
                let mut m = self.bsdf(inner)?;
                m.one_sided = false;
                m.name = name;
                return Ok(m);
            }
            "mask" => {
                // Mitsuba 3's `mask`: opacity (a float or a texture, 0.5 by
                // default) over one nested BSDF
                let inner = p
                    .unnamed_of("bsdf")
                    .or_else(|| p.any_of("bsdf"))
                    .ok_or_else(|| self.fail(node, "mask needs one nested <bsdf>"))?;
                let mask = match p.object("opacity") {
                    Some(t) if t.tag_name().name() == "texture" => {
                        crate::scene::AlphaMask::Texture(self.texture(t)?)
                    }
                    Some(other) => {
                        return Err(
                            self.fail(other, "mask: opacity must be a float or a <texture>")
                        );
                    }
                    None => {
                        let a = p.number("opacity").map_or(0.5, |v| v.0);
                        if !(0.0..=1.0).contains(&a) {
                            return Err(
                                self.fail(node, format!("mask: opacity {a} out of range ([0, 1])"))
                            );
                        }
                        crate::scene::AlphaMask::Constant(a as f32)
                    }
                };
                self.finish(p);
                let mut m = self.bsdf(inner)?;
                if m.alpha_mask.is_some() {
                    return Err(self.fail(node, "a mask inside another mask is not in the subset"));
                }
                m.alpha_mask = Some(mask);
                m.name = name;
                return Ok(m);
            }
            "normalmap" | "bumpmap" => {
                let inner = p
                    .unnamed_of("bsdf")
                    .or_else(|| p.any_of("bsdf"))
                    .ok_or_else(|| self.fail(node, format!("{kind} needs one nested <bsdf>")))?;
                let map = if kind == "normalmap" {
                    p.object("normalmap")
                } else {
                    p.any_of("texture")
                }
                .ok_or_else(|| {
                    self.fail(
                        node,
                        if kind == "normalmap" {
                            "normalmap needs a <texture name=\"normalmap\">"
                        } else {
                            "bumpmap needs a nested <texture>"
                        },
                    )
                })?;
                if map.tag_name().name() != "texture" {
                    return Err(self.fail(map, format!("{kind}: expected a <texture>")));
                }
                let t = self.texture(map)?;
                let scale = p.number("scale").map_or(1.0, |v| v.0) as f32;
                // both on by default since Mitsuba 3.7.1 (Maps docs)
                let shadowing = p.boolean("use_shadowing_function").is_none_or(|v| v.0);
                let flip_invalid = p.boolean("flip_invalid_normals").is_none_or(|v| v.0);
                if !scale.is_finite() {
                    return Err(self.fail(node, format!("bumpmap: `scale` {scale} is not finite")));
                }
                self.finish(p);
                let mut m = self.bsdf(inner)?;
                if m.maps.perturbs_normal() {
                    return Err(self.fail(
                        node,
                        "a normalmap or bumpmap inside another is not in the subset",
                    ));
                }
                if kind == "normalmap" {
                    m.maps.normal = Some(t);
                } else {
                    m.maps.bump = Some(crate::scene::BumpMap { texture: t, scale });
                }
                m.maps.shadowing = shadowing;
                m.maps.flip_invalid = flip_invalid;
                m.name = name;
                return Ok(m);
            }
            "diffuse" => {
                let (albedo, t) = self.reflectance(&mut p, "reflectance", 0.5)?;
                texture = t;
                Bsdf::Diffuse(Diffuse { albedo })
            }
            "conductor" | "roughconductor" => {
                let material = p.text("material").unwrap_or_else(|| "none".into());
                let eta = p.colour(self, "eta")?;
                let k = p.colour(self, "k")?;
                let (eta, k) = match (eta, k) {
                    (Some(e), Some(k)) if material == "none" => (e, k),
                    (None, None) if material == "none" => (Vec3::ZERO, Vec3::ONE),
                    // Mitsuba 3's presets, as its RGB variants see them
                    (None, None) => match named_conductor(&material) {
                        // AlSb: Mitsuba's RGB conversion clamps its red
                        // channel's spectra to eta = k = 0
                        Some((eta, k)) if (0..3).any(|c| eta[c] == 0.0 && k[c] == 0.0) => {
                            return Err(self.fail(
                                node,
                                format!(
                                    "conductor material `{}`: Mitsuba 3's RGB form of it has eta = k = 0 in a channel (its spectrum clamped out of gamut), which has no Fresnel reflectance; give `eta` and `k`",
                                    one_line(&material)
                                ),
                            ));
                        }
                        Some(ior) => ior,
                        None => {
                            return Err(self.fail(
                                node,
                                format!(
                                    "conductor material `{}` is not one of Mitsuba 3's named conductors (Au, Ag, Al, Cu, Cr, W, ... and their `_palik` forms)",
                                    one_line(&material)
                                ),
                            ));
                        }
                    },
                    (Some(_), Some(_)) => {
                        return Err(self.fail(
                            node,
                            "conductor: give either `eta` and `k` or `material`, not both",
                        ));
                    }
                    _ => return Err(self.fail(node, "conductor: give both `eta` and `k`")),
                };
                self.white(&mut p, node, "specular_reflectance")?;
                let microfacet = if kind == "conductor" {
                    Microfacet::new(Distribution::Ggx, 0.0)
                } else {
                    let distribution = self.distribution(&mut p)?;
                    let (alpha, t) = self.alpha_or_texture(&mut p)?;
                    maps.alpha = t;
                    // Mitsuba's G is the separable G1(wo) G1(wi)
                    Microfacet::new(distribution, alpha).with_masking(Masking::Separable)
                };
                p.boolean("sample_visible");
                Bsdf::Conductor(Conductor { eta, k, microfacet })
            }
            "dielectric" => {
                let int = self.ior(&mut p, "int_ior", 1.5046)?;
                let ext = self.ior(&mut p, "ext_ior", air)?;
                let (reflectance, r) = self.reflectance(&mut p, "specular_reflectance", 1.0)?;
                let (transmittance, t) = self.reflectance(&mut p, "specular_transmittance", 1.0)?;
                maps.specular = r;
                maps.transmittance = t;
                Bsdf::Glass(Glass {
                    ior: int / ext,
                    reflectance,
                    transmittance,
                })
            }
            "plastic" | "roughplastic" => {
                let int = self.ior(&mut p, "int_ior", 1.49)?;
                let ext = self.ior(&mut p, "ext_ior", air)?;
                let (diffuse, t) = self.reflectance(&mut p, "diffuse_reflectance", 0.5)?;
                texture = t;
                self.white(&mut p, node, "specular_reflectance")?;
                let nonlinear = p.boolean("nonlinear").is_some_and(|v| v.0);
                let (distribution, alpha) = if kind == "plastic" {
                    (Distribution::Ggx, 0.0)
                } else {
                    p.boolean("sample_visible");
                    if p.object("alpha").is_some() {
                        return Err(self.fail(
                            node,
                            "roughplastic: a textured `alpha` is not supported (the coat's table is built per roughness); give a number",
                        ));
                    }
                    (self.distribution(&mut p)?, self.alpha(&mut p)?)
                };
                Bsdf::Plastic(
                    Plastic::with_options(
                        diffuse,
                        int / ext,
                        alpha,
                        distribution,
                        Masking::Separable,
                        nonlinear,
                    )
                    .map_err(|e| self.fail(node, format!("{kind}: {e}")))?,
                )
            }
            other => {
                return Err(self.fail(
                    node,
                    format!(
                        "bsdf `{}` is not in the subset (expected diffuse, conductor, roughconductor, dielectric, plastic, roughplastic, twosided, mask, normalmap or bumpmap)",
                        one_line(other)
                    ),
                ));
            }
        };
        self.finish(p);
        bsdf.validate()
            .map_err(|e| self.fail(node, format!("bsdf `{kind}`: {e}")))?;
        Ok(Material {
            name,
            bsdf,
            texture,
            emission: Vec3::ZERO,
            two_sided: false,
            role: EmissionRole::Light,
            // Mitsuba's dielectric transmits; its reflective BSDFs test
            // both cosines in the shading frame and are black from behind
            one_sided: !matches!(bsdf, Bsdf::Glass(_)),
            maps,
            alpha_mask: None,
        })
    }

    /// A `specular_reflectance` that embertrace has no scale for: only 1.
    fn white(&mut self, p: &mut Params<'a, 'i>, node: Node, key: &str) -> Result<()> {
        if let Some(c) = p.colour(self, key)? {
            if c != Vec3::ONE {
                self.warn(
                    node,
                    format!("`{key}` {c} is read as 1 (no specular scale in this BSDF)"),
                );
            }
        }
        Ok(())
    }
}

/// Mitsuba 3's named conductor `name` (case as Mitsuba spells it): its RGB
/// `eta` and `k` ([`crate::bsdf::named_conductors`]).
fn named_conductor(name: &str) -> Option<(Vec3, Vec3)> {
    crate::bsdf::named_conductors::NAMED_CONDUCTORS
        .iter()
        .find(|(n, _, _)| *n == name)
        .map(|&(_, eta, k)| (Vec3::from(eta), Vec3::from(k)))
}
