//! Materials of the TOML scene format: every `material` key, textures, alpha masks.

use super::*;

/// A mesh's `alpha`: a number in `[0, 1]`, an image file (a PNG's alpha
/// channel, or its values read raw: [`ImageTexture::load_opacity`]), or
/// `{ texture = "file", raw = bool }` (the image's scalar value, decoded
/// from sRGB unless `raw`, which is the default).
pub(super) fn parse_alpha(
    path: &Path,
    line: Option<usize>,
    value: &toml::Value,
    textures: &mut Textures,
) -> Result<AlphaMask> {
    let fail = |m: String| Error::input(path, line, m);
    let expected = "alpha must be a number in [0, 1], an image file name, or { texture = \"file\", raw = true }";
    match value {
        toml::Value::Float(_) | toml::Value::Integer(_) => {
            let a = match value {
                toml::Value::Float(f) => *f,
                toml::Value::Integer(i) => *i as f64,
                _ => unreachable!("matched above"),
            };
            if !(0.0..=1.0).contains(&a) {
                return Err(fail(format!("alpha = {a} out of range ([0, 1])")));
            }
            Ok(AlphaMask::Constant(a as f32))
        }
        toml::Value::String(file) => Ok(AlphaMask::Texture(textures.opacity(path, line, file)?)),
        toml::Value::Table(t) => {
            let mut file = None;
            let mut raw = true;
            for (k, v) in t {
                match (k.as_str(), v) {
                    ("texture", toml::Value::String(f)) => file = Some(f),
                    ("raw", toml::Value::Boolean(r)) => raw = *r,
                    _ => return Err(fail(format!("{expected} (unexpected key `{k}`)"))),
                }
            }
            let file = file.ok_or_else(|| fail(expected.to_string()))?;
            Ok(AlphaMask::Texture(textures.get(path, line, file, raw)?))
        }
        _ => Err(fail(expected.to_string())),
    }
}

/// Give every material of `mesh` the opacity `mask` (see
/// [`super::AlphaMask`]); an emitting material cannot be cut out.
pub(super) fn set_alpha(
    path: &Path,
    line: Option<usize>,
    mesh: &mut MeshData,
    mask: AlphaMask,
) -> Result<()> {
    for m in &mut mesh.materials {
        if m.emission.max_element() > 0.0 || m.maps.emission.is_some() {
            return Err(Error::input(
                path,
                line,
                format!(
                    "alpha: mesh `{}` emits light, and an emitter cannot be cut out (light sampling would still see the holes)",
                    crate::error::one_line(&mesh.name)
                ),
            ));
        }
        m.alpha_mask = Some(mask.clone());
    }
    Ok(())
}

/// Textures named by the scene file, each loaded once per decoding.
#[derive(Default)]
pub(super) struct Textures {
    loaded: HashMap<(PathBuf, bool), Arc<ImageTexture>>,
    opacity: HashMap<PathBuf, Arc<ImageTexture>>,
}

impl Textures {
    /// The texture at `file` (relative to the scene's folder), loaded on
    /// first use; `raw`: a PNG is read linear, not decoded from sRGB.
    fn get(
        &mut self,
        path: &Path,
        line: Option<usize>,
        file: &str,
        raw: bool,
    ) -> Result<Arc<ImageTexture>> {
        let full = path.parent().unwrap_or(Path::new("")).join(file);
        if let Some(t) = self.loaded.get(&(full.clone(), raw)) {
            return Ok(t.clone());
        }
        if let Some(why) = super::super::not_a_file(&full) {
            return Err(Error::input(
                path,
                line,
                format!("texture `{file}` {why} (expected a .png or .exr file next to the scene)"),
            ));
        }
        // the scene's line first, then what is wrong with the image
        let t = Arc::new(
            ImageTexture::load_as(&full, raw)
                .map_err(|e| Error::input(path, line, format!("texture `{file}`: {e}")))?,
        );
        self.loaded.insert((full, raw), t.clone());
        Ok(t)
    }

    /// The opacity texture at `file` ([`ImageTexture::load_opacity`]),
    /// loaded on first use.
    fn opacity(
        &mut self,
        path: &Path,
        line: Option<usize>,
        file: &str,
    ) -> Result<Arc<ImageTexture>> {
        let full = path.parent().unwrap_or(Path::new("")).join(file);
        if let Some(t) = self.opacity.get(&full) {
            return Ok(t.clone());
        }
        if let Some(why) = super::super::not_a_file(&full) {
            return Err(Error::input(
                path,
                line,
                format!(
                    "alpha texture `{file}` {why} (expected a .png or .exr file next to the scene)"
                ),
            ));
        }
        let t = Arc::new(
            ImageTexture::load_opacity(&full)
                .map_err(|e| Error::input(path, line, format!("alpha texture `{file}`: {e}")))?,
        );
        self.opacity.insert(full, t.clone());
        Ok(t)
    }
}

/// The BSDF keys each material type accepts.
pub(super) fn keys_of_type(kind: &str) -> Option<&'static [&'static str]> {
    Some(match kind {
        "diffuse" => &["diffuse", "texture"],
        "mirror" => &["reflectance"],
        "glass" | "thin_glass" => &["ior", "reflectance", "transmittance"],
        "rough_glass" => &["ior", "alpha", "reflectance", "transmittance"],
        "conductor" => &["alpha", "eta", "k", "distribution", "masking"],
        "plastic" => &[
            "diffuse",
            "texture",
            "ior",
            "alpha",
            "distribution",
            "masking",
            "nonlinear",
        ],
        "phong" => &["diffuse", "texture", "specular", "shininess", "roughness"],
        "metallic_roughness" => &[
            "base_color",
            "texture",
            "metallic",
            "roughness",
            "specular",
            "specular_color",
            "ior",
            "metallic_roughness",
        ],
        _ => return None,
    })
}

/// A parameter's value: its constant (the default where a texture gives
/// it) and its texture.
pub(super) struct Value {
    constant: Vec3,
    texture: Option<Arc<ImageTexture>>,
}

/// Apply a `material = {...}` table to `mat`.
///
/// With `type`, the table describes the whole material: `mat` keeps only its
/// name, and keys the table leaves out take the type's defaults (diffuse 0.8;
/// reflectance and transmittance 1; ior 1.5; conductor `alpha` 0.1, `eta` 0
/// and `k` 1 (a perfect conductor), GGX; plastic `alpha` 0; phong `specular` 0
/// and `shininess` 1, or the GGX lobe when `roughness` is given;
/// metallic-roughness as glTF's defaults, a white rough metal, with
/// `base_color` or `texture` for its base colour and `metallic_roughness =
/// { texture = "file" }` for glTF's packed texture, read linear). Without `type`,
/// the keys given override those of `mat` (from an MTL file, say): `diffuse`
/// or `texture` make it diffuse, and keys of other types are an error.
///
/// `diffuse`, `reflectance`, `transmittance`, `specular`, `alpha` and
/// `emission` may be `{ texture = "file", raw = false }`: a PNG is decoded
/// from sRGB for the colours and read linear for `alpha`, or linear for any
/// with `raw = true`; EXR is linear. `normal_map` and `bump_map` (with
/// `bump_scale`, 1 by default) name raw images; a material takes one of them.
pub(super) fn apply_material(
    path: &Path,
    line: Option<usize>,
    over: &MaterialToml,
    mat: &mut Material,
    textures: &mut Textures,
) -> Result<()> {
    let fail = |m: String| Error::input(path, line, m);
    let keys = over.bsdf_keys();
    // a colour in [0, 1] (or its texture, sRGB unless raw)
    let unit =
        |textures: &mut Textures, key: &str, v: &Option<Param>, default: f32| -> Result<Value> {
            let constant = match v {
                None => Vec3::splat(default),
                Some(Param::Texture { file, raw }) => {
                    return Ok(Value {
                        constant: Vec3::splat(default),
                        texture: Some(textures.get(path, line, file, raw.unwrap_or(false))?),
                    });
                }
                Some(Param::Number(x)) => Vec3::splat(*x),
                Some(Param::Triple(c)) => *c,
            };
            let v = check_colour(path, line, &format!("material.{key}"), Rgb(constant))?;
            if v.max_element() > 1.0 {
                return Err(fail(format!("material.{key} must be at most 1, got {v}")));
            }
            Ok(Value {
                constant: v,
                texture: None,
            })
        };
    let base_colour = over.kind.as_deref() == Some("metallic_roughness");
    let (colour_key, colour) = if base_colour {
        ("base_color", &over.base_color)
    } else {
        ("diffuse", &over.diffuse)
    };
    let diffuse_key = match (colour, &over.texture) {
        (Some(Param::Texture { .. }), Some(_)) => {
            return Err(fail(format!(
                "material.texture and material.{colour_key} = {{ texture = ... }} exclude each other"
            )));
        }
        (_, Some(file)) => Some(Param::Texture {
            file: file.clone(),
            raw: None,
        }),
        (d, None) => d.clone(),
    };
    let diffuse = unit(
        textures,
        colour_key,
        &diffuse_key,
        if base_colour { 1.0 } else { 0.8 },
    )?;
    let texture = diffuse.texture.clone();
    match over.kind.as_deref() {
        None => {
            if let Some(k) = keys.iter().find(|k| !["diffuse", "texture"].contains(k)) {
                return Err(fail(format!(
                    "material.{k} needs a `type` (one of diffuse, mirror, glass, conductor, plastic, phong, metallic_roughness, thin_glass, rough_glass)"
                )));
            }
            if over.diffuse.is_some() || texture.is_some() {
                let albedo = match over.diffuse {
                    Some(Param::Number(_) | Param::Triple(_)) => diffuse.constant,
                    _ => mat.albedo().unwrap_or(Vec3::splat(0.8)),
                };
                mat.bsdf = Bsdf::Diffuse(Diffuse { albedo });
                mat.texture = texture.or(mat.texture.take());
            }
        }
        Some(kind) => {
            let allowed = keys_of_type(kind).ok_or_else(|| {
                fail(format!(
                    "unknown material type `{kind}` (expected diffuse, mirror, glass, conductor, plastic, phong, metallic_roughness, thin_glass or rough_glass)"
                ))
            })?;
            if let Some(k) = keys.iter().find(|k| !allowed.contains(k)) {
                return Err(fail(format!(
                    "material.{k} is not a key of type `{kind}` (it takes {})",
                    allowed.join(", ")
                )));
            }
            let ior = over.ior.unwrap_or(1.5);
            let distribution = match &over.distribution {
                Some(d) => d
                    .parse::<Distribution>()
                    .map_err(|e| fail(format!("material.distribution: {e}")))?,
                None => Distribution::Ggx,
            };
            let masking = match &over.masking {
                Some(m) => m
                    .parse::<Masking>()
                    .map_err(|e| fail(format!("material.masking: {e}")))?,
                None => Masking::default(),
            };
            // roughness: one number, or a texture read linear
            let alpha = |textures: &mut Textures,
                         default: f32|
             -> Result<(f32, Option<Arc<ImageTexture>>)> {
                match &over.alpha {
                    None => Ok((default, None)),
                    Some(Param::Number(a)) => Ok((*a, None)),
                    Some(Param::Triple(_)) => Err(fail(
                        "material.alpha must be one number or { texture = ... }, not a triple"
                            .into(),
                    )),
                    Some(Param::Texture { file, raw }) => {
                        let t = textures.get(path, line, file, raw.unwrap_or(true))?;
                        // the smallest roughness stands for the texture, so
                        // the plan sees a delta lobe if any texel is smooth
                        Ok((t.min_scalar(), Some(t)))
                    }
                }
            };
            let mut maps = Maps::default();
            let bsdf = match kind {
                "diffuse" => Bsdf::Diffuse(Diffuse {
                    albedo: diffuse.constant,
                }),
                "mirror" => {
                    let r = unit(textures, "reflectance", &over.reflectance, 1.0)?;
                    maps.specular = r.texture;
                    Bsdf::Mirror(Mirror {
                        reflectance: r.constant,
                    })
                }
                "rough_glass" => {
                    let r = unit(textures, "reflectance", &over.reflectance, 1.0)?;
                    let t = unit(textures, "transmittance", &over.transmittance, 1.0)?;
                    maps.specular = r.texture;
                    maps.transmittance = t.texture;
                    let (a, at) = alpha(textures, 0.1)?;
                    let a = if at.is_some() {
                        a.max(Microfacet::SMOOTH_ALPHA)
                    } else {
                        a
                    };
                    maps.alpha = at;
                    Bsdf::RoughGlass(RoughGlass {
                        ior,
                        alpha: a,
                        reflectance: r.constant,
                        transmittance: t.constant,
                    })
                }
                "glass" | "thin_glass" => {
                    let r = unit(textures, "reflectance", &over.reflectance, 1.0)?;
                    let t = unit(textures, "transmittance", &over.transmittance, 1.0)?;
                    maps.specular = r.texture;
                    maps.transmittance = t.texture;
                    if kind == "glass" {
                        Bsdf::Glass(Glass {
                            ior,
                            reflectance: r.constant,
                            transmittance: t.constant,
                        })
                    } else {
                        Bsdf::ThinGlass(ThinGlass {
                            ior,
                            reflectance: r.constant,
                            transmittance: t.constant,
                        })
                    }
                }
                "conductor" => {
                    let (a, t) = alpha(textures, 0.1)?;
                    maps.alpha = t;
                    Bsdf::Conductor(Conductor {
                        eta: over.eta.map_or(Vec3::ZERO, |c| c.0),
                        k: over.k.map_or(Vec3::ONE, |c| c.0),
                        microfacet: Microfacet::new(distribution, a).with_masking(masking),
                    })
                }
                "phong" => {
                    let lobe = match (over.shininess, over.roughness) {
                        (Some(_), Some(_)) => {
                            return Err(fail(
                                "material.shininess (a Phong lobe) and material.roughness (a GGX lobe) exclude each other".into(),
                            ));
                        }
                        (s, None) => Lobe::Phong {
                            shininess: s.unwrap_or(1.0),
                        },
                        (None, Some(r)) => Lobe::Ggx { roughness: r },
                    };
                    let spec = unit(textures, "specular", &over.specular, 0.0)?;
                    maps.specular = spec.texture;
                    Bsdf::Phong(Phong {
                        diffuse: diffuse.constant,
                        specular: spec.constant,
                        lobe,
                    })
                }
                "metallic_roughness" => {
                    let specular = match over.specular {
                        None => 1.0,
                        Some(Param::Number(s)) => s,
                        Some(_) => {
                            return Err(fail(
                                "material.specular of a metallic_roughness material is one number in [0, 1] (KHR_materials_specular's specularFactor)".into(),
                            ));
                        }
                    };
                    maps.metallic_roughness = match &over.metallic_roughness {
                        None => None,
                        Some(Param::Texture { file, raw }) => {
                            Some(textures.get(path, line, file, raw.unwrap_or(true))?)
                        }
                        Some(_) => {
                            return Err(fail(
                                "material.metallic_roughness must be { texture = \"file\" } (green: roughness, blue: metalness)".into(),
                            ));
                        }
                    };
                    Bsdf::MetallicRoughness(MetallicRoughness {
                        base_color: diffuse.constant,
                        metallic: over.metallic.unwrap_or(1.0),
                        roughness: over.roughness.unwrap_or(1.0),
                        specular,
                        specular_color: over.specular_color.map_or(Vec3::ONE, |c| c.0),
                        ior,
                    })
                }
                _ => {
                    let (a, t) = alpha(textures, 0.0)?;
                    let plastic = Plastic::with_options(
                        diffuse.constant,
                        ior,
                        a,
                        distribution,
                        masking,
                        over.nonlinear.unwrap_or(true),
                    )
                    .map_err(|e| fail(format!("material: {e}")))?;
                    if let Some(t) = t {
                        let coats = PlasticCoats::new(&plastic, t.min_scalar(), t.max_scalar())
                            .map_err(|e| fail(format!("material.alpha: {e}")))?;
                        maps.plastic_coats = Some(Arc::new(coats));
                        maps.alpha = Some(t);
                    }
                    Bsdf::Plastic(plastic)
                }
            };
            bsdf.validate()
                .map_err(|e| fail(format!("material: {e}")))?;
            mat.bsdf = bsdf;
            mat.texture = texture;
            mat.emission = Vec3::ZERO;
            mat.two_sided = false;
            mat.role = EmissionRole::Light;
            mat.maps = maps;
        }
    }
    match &over.emission {
        None => {}
        Some(Param::Texture { file, raw }) => {
            let t = textures.get(path, line, file, raw.unwrap_or(false))?;
            mat.emission = t.mean();
            mat.maps.emission = Some(t);
        }
        Some(Param::Number(x)) => {
            mat.emission = check_colour(path, line, "material.emission", Rgb(Vec3::splat(*x)))?;
            mat.maps.emission = None;
        }
        Some(Param::Triple(c)) => {
            mat.emission = check_colour(path, line, "material.emission", Rgb(*c))?;
            mat.maps.emission = None;
        }
    }
    if over.bump_scale.is_some() && over.bump_map.is_none() {
        return Err(fail("material.bump_scale needs a material.bump_map".into()));
    }
    match (&over.normal_map, &over.bump_map) {
        (Some(_), Some(_)) => {
            return Err(fail(
                "material.normal_map and material.bump_map exclude each other".into(),
            ));
        }
        (Some(file), None) => {
            mat.maps.normal = Some(textures.get(path, line, file, true)?);
            mat.maps.bump = None;
        }
        (None, Some(file)) => {
            let scale = over.bump_scale.unwrap_or(1.0);
            if !scale.is_finite() {
                return Err(fail(format!(
                    "material.bump_scale must be finite, got {scale}"
                )));
            }
            mat.maps.bump = Some(BumpMap {
                texture: textures.get(path, line, file, true)?,
                scale,
            });
            mat.maps.normal = None;
        }
        (None, None) => {}
    }
    if let Some(t) = over.two_sided {
        mat.two_sided = t;
    }
    if let Some(o) = over.one_sided {
        mat.one_sided = o;
    }
    if let Some(f) = over.flip_invalid_normals {
        mat.maps.flip_invalid = f;
    }
    if let Some(s) = over.use_shadowing_function {
        mat.maps.shadowing = s;
    }
    match over.emission_role.as_deref() {
        None => {}
        Some("light") => mat.role = EmissionRole::Light,
        Some("seen_only") => mat.role = EmissionRole::SeenOnly,
        Some(other) => {
            return Err(fail(format!(
                "material.emission_role `{other}`: expected \"light\" or \"seen_only\""
            )));
        }
    }
    Ok(())
}
