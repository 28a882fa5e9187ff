//! pbrt-v4 materials and image textures (see `mod.rs` for the subset).

use super::tokens::{Param, Values};
use super::{Loader, Params};
use crate::bsdf::{
    Bsdf, Conductor, Diffuse, Distribution, Glass, Microfacet, Plastic, RoughGlass, ThinGlass,
};
use crate::error::Result;
use crate::math::Vec3;
use crate::scene::Material;
use crate::texture::ImageTexture;
use std::path::Path;
use std::sync::Arc;

impl Loader<'_> {
    pub(super) fn texture(&mut self, p: &Params) -> Result<()> {
        let st = p.st;
        let (name, class) = (&st.strings[0], &st.strings[2]);
        if class != "imagemap" {
            self.warn(
                st,
                "texture-class",
                format!(
                    "Texture class \"{}\" (only imagemap is read)",
                    crate::error::one_line(class)
                ),
            );
            p.read_all();
            return Ok(());
        }
        let file = p
            .string("filename")
            .ok_or_else(|| p.fail("imagemap needs a \"string filename\"".into()))?;
        let full = st.file.parent().unwrap_or(Path::new("")).join(file);
        if let Some(why) = crate::scene::not_a_file(&full) {
            return Err(p.fail(format!("texture `{}` {why}", crate::error::one_line(file))));
        }
        let raw = st.strings[1] == "float" || p.string("encoding") == Some("linear");
        let t = ImageTexture::load_as(&full, raw)
            .map_err(|e| p.fail(format!("texture `{}`: {e}", crate::error::one_line(file))))?;
        let scale = p.float("scale", 1.0) as f32;
        let t = if scale != 1.0 {
            let rgb: Vec<f32> = t
                .texels()
                .iter()
                .flat_map(|c| (*c * scale).to_array())
                .collect();
            ImageTexture::from_linear_rgb(t.width(), t.height(), rgb)
                .map_err(|e| p.fail(e.to_string()))?
        } else {
            t
        };
        for k in ["uscale", "vscale", "udelta", "vdelta", "invert"] {
            if p.get(k).is_some() {
                self.warn(st, k, format!("texture parameter `{k}`"));
            }
        }
        self.textures.insert(name.clone(), Arc::new(t));
        Ok(())
    }

    /// A reflectance: a colour, or a texture by name.
    fn reflectance(
        &self,
        p: &Params,
        name: &str,
        default: f32,
    ) -> Result<(Vec3, Option<Arc<ImageTexture>>)> {
        if let Some(param) = p.get(name) {
            if param.ty == "texture" {
                let Values::Strs(v) = &param.values else {
                    return Err(p.fail(format!("parameter `{name}`: expected a texture name")));
                };
                let t = self.textures.get(&v[0]).ok_or_else(|| {
                    p.fail(format!(
                        "no texture named `{}`",
                        crate::error::one_line(&v[0])
                    ))
                })?;
                return Ok((Vec3::splat(default), Some(t.clone())));
            }
        }
        let c = p.colour(name)?.map_or(Vec3::splat(default), |c| c.0);
        if !(c.is_finite() && c.min_element() >= 0.0 && c.max_element() <= 1.0) {
            return Err(p.fail(format!("`{name}` must be in [0, 1], got {c}")));
        }
        Ok((c, None))
    }

    /// pbrt's roughness as GGX alpha (`remaproughness`: the square root).
    fn alpha(p: &Params, default: f64) -> f32 {
        let r = p.nums("roughness").map_or_else(
            || {
                let u = p.float("uroughness", default);
                let v = p.float("vroughness", default);
                0.5 * (u + v)
            },
            |v| v.first().copied().unwrap_or(default),
        );
        let r = r.max(0.0);
        (if p.bool("remaproughness", true) {
            r.sqrt()
        } else {
            r
        }) as f32
    }

    pub(super) fn material(&mut self, p: &Params, ty: &str, name: &str) -> Result<Material> {
        let st = p.st;
        let mut m = Material {
            name: name.to_string(),
            ..Material::default()
        };
        m.bsdf = match ty {
            "diffuse" => {
                let (c, t) = self.reflectance(p, "reflectance", 0.5)?;
                m.texture = t;
                Bsdf::Diffuse(Diffuse { albedo: c })
            }
            "coateddiffuse" => {
                let (c, t) = self.reflectance(p, "reflectance", 0.5)?;
                m.texture = t;
                for k in ["thickness", "albedo", "g", "maxdepth", "nsamples"] {
                    if p.get(k).is_some() {
                        self.warn(
                            st,
                            &format!("coated-{k}"),
                            format!("coateddiffuse `{k}` (a plastic stands in)"),
                        );
                    }
                }
                let ior = p.float("eta", 1.5) as f32;
                Bsdf::Plastic(
                    Plastic::new(c, ior, Self::alpha(p, 0.0))
                        .map_err(|e| p.fail(format!("material `{name}`: {e}")))?,
                )
            }
            "conductor" => {
                let alpha = Self::alpha(p, 0.0);
                let (eta, k) = if let Some(r) = p.colour("reflectance")? {
                    // pbrt-v4: eta 1, k = 2 sqrt(r) / sqrt(1 - r)
                    let r = r.0.clamp(Vec3::ZERO, Vec3::splat(0.9999));
                    (
                        Vec3::ONE,
                        2.0 * r.map(f32::sqrt) / (Vec3::ONE - r).map(f32::sqrt),
                    )
                } else {
                    (
                        self.spectrum(p, "eta", "metal-Cu-eta")?,
                        self.spectrum(p, "k", "metal-Cu-k")?,
                    )
                };
                Bsdf::Conductor(Conductor {
                    eta,
                    k,
                    microfacet: Microfacet::new(Distribution::Ggx, alpha),
                })
            }
            "dielectric" | "thindielectric" => {
                let ior = match p.get("eta") {
                    Some(Param {
                        values: Values::Strs(v),
                        ..
                    }) => named_ior(&v[0]).ok_or_else(|| {
                        p.fail(format!(
                            "unknown named spectrum `{}` for eta",
                            crate::error::one_line(&v[0])
                        ))
                    })?,
                    _ => p.float("eta", 1.5) as f32,
                };
                let alpha = Self::alpha(p, 0.0);
                if ty == "dielectric" && alpha >= Microfacet::SMOOTH_ALPHA {
                    Bsdf::RoughGlass(RoughGlass {
                        ior,
                        alpha,
                        ..RoughGlass::default()
                    })
                } else if ty == "dielectric" {
                    Bsdf::Glass(Glass {
                        ior,
                        ..Glass::default()
                    })
                } else {
                    Bsdf::ThinGlass(ThinGlass {
                        ior,
                        ..ThinGlass::default()
                    })
                }
            }
            other => {
                self.warn(
                    st,
                    &format!("material-{other}"),
                    format!(
                        "material \"{}\" (rendered as diffuse 0.5)",
                        crate::error::one_line(other)
                    ),
                );
                p.read_all();
                Bsdf::Diffuse(Diffuse {
                    albedo: Vec3::splat(0.5),
                })
            }
        };
        if p.get("normalmap").is_some() {
            self.warn(st, "normalmap", "a material's `normalmap`".into());
        }
        m.bsdf
            .validate()
            .map_err(|e| p.fail(format!("material `{name}`: {e}")))?;
        Ok(m)
    }

    /// A conductor's `eta` or `k`: pbrt's named metal spectra (Mitsuba's
    /// RGB values for the same metal), or RGB.
    fn spectrum(&self, p: &Params, name: &str, default: &str) -> Result<Vec3> {
        let named = match p.get(name) {
            Some(Param {
                values: Values::Strs(v),
                ..
            }) => v[0].clone(),
            Some(_) => return p.colour(name).map(|c| c.map_or(Vec3::ZERO, |c| c.0)),
            None => default.to_string(),
        };
        let parts: Vec<&str> = named.split('-').collect();
        let found = match parts.as_slice() {
            ["metal", metal, which @ ("eta" | "k")] => {
                crate::bsdf::named_conductors::NAMED_CONDUCTORS
                    .iter()
                    .find(|(n, ..)| n == metal)
                    .map(|(_, eta, k)| Vec3::from(if *which == "eta" { *eta } else { *k }))
            }
            _ => None,
        };
        found.ok_or_else(|| {
            p.fail(format!(
                "unknown named spectrum `{}` (pbrt's metal-Ag, Al, Au, Cu, MgO, TiO2 -eta and -k are read)",
                crate::error::one_line(&named)
            ))
        })
    }
}

/// pbrt's named glass spectra as one index (at the d line, 587.6 nm): BK7
/// from the Schott catalogue; the rest are refused by the caller.
fn named_ior(name: &str) -> Option<f32> {
    match name {
        "glass-BK7" => Some(1.5168),
        _ => None,
    }
}
