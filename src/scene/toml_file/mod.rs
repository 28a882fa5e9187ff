//! The TOML scene format. The schema is fixed (other scripts write it); unknown
//! keys are errors naming the key, the file and the line, and every value is
//! checked against [`crate::limits`] before anything is allocated for it.
//!
//! ```toml
//! [camera]
//! origin = [0.0, 1.0, 3.9]
//! target = [0.0, 1.0, 0.0]
//! up     = [0.0, 1.0, 0.0]
//! fov_y  = 39.3               # vertical field of view, degrees
//! # focal_pixels = 724.3       # instead: a focal length in pixels, so the
//!                             # field of view follows -r's height (CS184)
//!
//! [film]
//! resolution = [512, 512]     # width, height
//!
//! [render]                    # defaults; command-line flags override them
//! spp = 64
//! max_depth = 64
//! light_samples = 1
//! seed = 0
//! rr_depth = 3                # first bounce Russian roulette may end
//! direct = "mis"              # direct lighting: mis, light or bsdf
//! rr = 0.7                    # fixed continuation probability (1 = no
//!                             # roulette); throughput-based if absent
//!
//! [[mesh]]
//! file = "cornell-box.obj"    # relative to the scene file
//! transform = { scale = 1.0, rotate = [0, 1, 0, 30], translate = [0, 0, 0] }
//! material = { diffuse = [0.5, 0.5, 0.5], emission = 0.0, two_sided = false }
//!
//! [[light]]
//! type = "environment"
//! radiance = [1.0, 1.0, 1.0]  # or one number
//!
//! [[light]]
//! type = "spot"               # see crate::light::spot
//! position = [0.0, 1.9, 0.0]
//! target = [0.0, 0.0, 0.0]    # or direction = [0.0, -1.0, 0.0]
//! intensity = 5.0             # W/sr on the axis, or [r, g, b]
//! cutoff_angle = 30.0         # degrees (default 20)
//! beam_width = 20.0           # degrees (default 3/4 of the cutoff)
//!
//! [[light]]
//! type = "panel"              # no surface: lights by light sampling alone
//! center = [0.0, 1.99, 0.0]   # (the CS184 course's area light; light/panel.rs)
//! dim_x = [0.5, 0.0, 0.0]     # its edges
//! dim_y = [0.0, 0.0, 0.4]
//! facing = [0.0, -1.0, 0.0]   # the side it lights
//! radiance = 8.0              # or [r, g, b]
//! ```
//!
//! A material's `emission_role` is `"light"` (the default: sampled, and
//! found by BSDF samples) or `"seen_only"` ([`EmissionRole::SeenOnly`]).

use super::procedural::{self, Shape};
use super::{
    AlphaMask, BumpMap, EmissionRole, Maps, Material, MeshData, Scene, SceneBuilder, Transform,
    WorldCamera, load_obj_mesh, load_ply_mesh,
};
use crate::bsdf::{
    Bsdf, Conductor, Diffuse, Distribution, Glass, Lobe, Masking, MetallicRoughness, Microfacet,
    Mirror, Phong, Plastic, PlasticCoats, RoughGlass, ThinGlass,
};
use crate::camera::ThinLens;
use crate::error::{Error, Result};
use crate::light::{DirectionalLight, EnvironmentMap, PanelLight, PointLight, SpotLight};
use crate::limits::{self, MAX_COORDINATE, MAX_TRIANGLES, MAX_VERTICES};
use crate::math::{DVec3, Vec3};
use crate::settings::{RenderDefaults, Roulette};
use crate::texture::ImageTexture;
use serde::Deserialize;
use serde::de::{self, Deserializer, SeqAccess, Visitor};
use std::collections::HashMap;
use std::fmt;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use toml::Spanned;

mod checks;
mod materials;
mod values;
use checks::*;
use materials::*;
use values::*;

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct SceneFile {
    camera: Option<CameraToml>,
    film: Option<FilmToml>,
    render: Option<RenderToml>,
    #[serde(default)]
    mesh: Vec<MeshToml>,
    #[serde(default)]
    light: Vec<LightToml>,
    #[serde(default)]
    procedural: Vec<ProceduralToml>,
    #[serde(default)]
    sphere: Vec<SphereToml>,
    #[serde(default)]
    instance: Vec<InstanceToml>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct ProceduralToml {
    #[serde(rename = "type")]
    kind: String,
    triangles: Spanned<u64>,
    #[serde(default = "default_displacement")]
    displacement: f32,
    #[serde(default)]
    seed: u64,
    transform: Option<TransformToml>,
    material: Option<MaterialToml>,
    name: Option<String>,
    #[serde(default)]
    instance_only: bool,
    /// Opacity: a number, an image file, or `{ texture, raw }`.
    alpha: Option<toml::Value>,
}

fn default_displacement() -> f32 {
    0.1
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct CameraToml {
    origin: Spanned<Exact<f64, 3>>,
    target: Spanned<Exact<f64, 3>>,
    up: Option<Spanned<Exact<f64, 3>>>,
    fov_y: Option<Spanned<f32>>,
    aperture_radius: Option<Spanned<f32>>,
    focus_distance: Option<Spanned<f32>>,
    focal_pixels: Option<Spanned<f32>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct FilmToml {
    resolution: Spanned<Exact<u64, 2>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RenderToml {
    spp: Option<Spanned<u64>>,
    max_depth: Option<Spanned<u64>>,
    light_samples: Option<Spanned<u64>>,
    seed: Option<u64>,
    rr_depth: Option<Spanned<u64>>,
    direct: Option<Spanned<String>>,
    rr: Option<Spanned<f32>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct MeshToml {
    file: String,
    transform: Option<TransformToml>,
    material: Option<MaterialToml>,
    /// A name `[[instance]]` tables place it by.
    name: Option<String>,
    /// Stored for instances only, not placed itself.
    #[serde(default)]
    instance_only: bool,
    /// Opacity: a number, an image file, or `{ texture, raw }`.
    alpha: Option<toml::Value>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct InstanceToml {
    /// The `name` of the `[[mesh]]` or `[[procedural]]` it places.
    of: String,
    transform: Option<TransformToml>,
    /// A 4 x 4 affine matrix, row-major (instead of `transform`).
    matrix: Option<Exact<f64, 16>>,
    /// Every triangle of this instance takes this material.
    material: Option<MaterialToml>,
}

/// The named meshes (`[[mesh]]` and `[[procedural]]` with a `name`) that
/// instances place: which `[[instance]]` tables name, and for each name
/// stored, its prototype and the mesh's own transform.
struct Named<'p> {
    /// The scene file, for messages.
    path: &'p Path,
    /// Names some `[[instance]]` places.
    wanted: std::collections::HashSet<String>,
    /// Name, prototype index and own transform of each named mesh.
    stored: HashMap<String, (Option<u32>, glam::DAffine3, Option<usize>)>,
}

impl Named<'_> {
    /// Add mesh `mesh` placed by `transform`, declared at `line` with
    /// `name` and `instance_only`: a mesh an instance places (or one only
    /// instances use) is stored once as a prototype (placed by an instance
    /// of its own unless `instance_only`); any other mesh is placed as it is.
    fn add(
        &mut self,
        b: &mut SceneBuilder,
        line: Option<usize>,
        name: Option<&String>,
        instance_only: bool,
        mesh: MeshData,
        transform: &Transform,
    ) -> Result<()> {
        let path = self.path;
        let Some(name) = name else {
            if instance_only {
                return Err(Error::input(
                    path,
                    line,
                    "`instance_only = true` needs a `name` for instances to place it by",
                ));
            }
            return b.add_mesh_from(mesh, transform, line);
        };
        if name.is_empty() {
            return Err(Error::input(path, line, "`name` must not be empty"));
        }
        if let Some((_, _, first)) = self.stored.get(name) {
            let at = first
                .map(|l| format!(" (first at line {l})"))
                .unwrap_or_default();
            return Err(Error::input(
                path,
                line,
                format!("a second mesh named `{}`{at}", crate::error::clip(name)),
            ));
        }
        let m = transform.matrix();
        let prototype = if instance_only || self.wanted.contains(name) {
            let mut mesh = mesh;
            mesh.name = name.clone();
            let p = b.add_prototype(mesh, line)?;
            if !instance_only {
                b.add_instance(p, m, None, line)?;
            }
            Some(p)
        } else {
            b.add_mesh_from(mesh, transform, line)?;
            None
        };
        self.stored.insert(name.clone(), (prototype, m, line));
        Ok(())
    }
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct TransformToml {
    scale: Option<Rgb>,
    rotate: Option<Exact<f64, 4>>,
    translate: Option<Exact<f64, 3>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct MaterialToml {
    #[serde(rename = "type")]
    kind: Option<String>,
    diffuse: Option<Param>,
    texture: Option<String>,
    reflectance: Option<Param>,
    transmittance: Option<Param>,
    ior: Option<f32>,
    alpha: Option<Param>,
    eta: Option<Rgb>,
    k: Option<Rgb>,
    distribution: Option<String>,
    masking: Option<String>,
    nonlinear: Option<bool>,
    specular: Option<Param>,
    shininess: Option<f32>,
    roughness: Option<f32>,
    base_color: Option<Param>,
    metallic: Option<f32>,
    specular_color: Option<Rgb>,
    metallic_roughness: Option<Param>,
    emission: Option<Param>,
    two_sided: Option<bool>,
    emission_role: Option<String>,
    one_sided: Option<bool>,
    flip_invalid_normals: Option<bool>,
    use_shadowing_function: Option<bool>,
    normal_map: Option<String>,
    bump_map: Option<String>,
    bump_scale: Option<f32>,
}

impl MaterialToml {
    /// The BSDF keys present, by name.
    fn bsdf_keys(&self) -> Vec<&'static str> {
        let present = [
            ("diffuse", self.diffuse.is_some()),
            ("texture", self.texture.is_some()),
            ("reflectance", self.reflectance.is_some()),
            ("transmittance", self.transmittance.is_some()),
            ("ior", self.ior.is_some()),
            ("alpha", self.alpha.is_some()),
            ("eta", self.eta.is_some()),
            ("k", self.k.is_some()),
            ("distribution", self.distribution.is_some()),
            ("masking", self.masking.is_some()),
            ("nonlinear", self.nonlinear.is_some()),
            ("specular", self.specular.is_some()),
            ("shininess", self.shininess.is_some()),
            ("roughness", self.roughness.is_some()),
            ("base_color", self.base_color.is_some()),
            ("metallic", self.metallic.is_some()),
            ("specular_color", self.specular_color.is_some()),
            ("metallic_roughness", self.metallic_roughness.is_some()),
        ];
        present
            .iter()
            .filter(|(_, on)| *on)
            .map(|(k, _)| *k)
            .collect()
    }
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct SphereToml {
    center: Exact<f64, 3>,
    radius: f32,
    material: Option<MaterialToml>,
    /// Row-major 3 x 3: Scene::sphere_uv_frames' entry.
    uv_frame: Option<Exact<f32, 9>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct LightToml {
    #[serde(rename = "type")]
    kind: String,
    radiance: Option<Rgb>,
    file: Option<String>,
    position: Option<Exact<f64, 3>>,
    intensity: Option<Rgb>,
    direction: Option<Exact<f32, 3>>,
    irradiance: Option<Rgb>,
    attenuation: Option<Exact<f32, 3>>,
    target: Option<Exact<f64, 3>>,
    cutoff_angle: Option<f32>,
    beam_width: Option<f32>,
    falloff: Option<String>,
    center: Option<Exact<f64, 3>>,
    dim_x: Option<Exact<f32, 3>>,
    dim_y: Option<Exact<f32, 3>>,
    facing: Option<Exact<f32, 3>>,
}

/// Load a TOML scene.
pub fn load(path: &Path) -> Result<Scene> {
    let bytes = super::read_bounded(
        path,
        crate::limits::MAX_SCENE_FILE_BYTES,
        super::Content::Text,
    )?;
    let text = String::from_utf8(bytes)
        .map_err(|_| Error::input(path, None, "not UTF-8 text (expected a TOML scene)"))?;
    // the parser's tables cost far more than their text: refuse a file too
    // large for this machine before building anything
    crate::memory::toml_scene_estimate(&text)
        .check()
        .map_err(|m| Error::input(path, None, m))?;
    let file: SceneFile = toml::from_str(&text).map_err(|e| {
        let line = e.span().map(|s| line_of(&text, s.start));
        Error::input(path, line, e.message().trim().replace('\n', " "))
    })?;
    let dir = path.parent().unwrap_or(Path::new(""));
    let mut b = SceneBuilder::new(path);
    let mut textures = Textures::default();

    let mut named = Named {
        path,
        wanted: file.instance.iter().map(|i| i.of.clone()).collect(),
        stored: HashMap::new(),
    };
    let mesh_lines = table_lines(&text, "mesh");
    // a file listed again is parsed once
    let mut loaded: HashMap<PathBuf, MeshData> = HashMap::new();
    for (i, m) in file.mesh.iter().enumerate() {
        let line = mesh_lines.get(i).copied();
        let mesh_path = dir.join(&m.file);
        let ext = mesh_path
            .extension()
            .and_then(|e| e.to_str())
            .map(|e| e.to_ascii_lowercase());
        let read: fn(&Path) -> Result<MeshData> = match ext.as_deref() {
            Some("obj") => load_obj_mesh,
            Some("ply") => load_ply_mesh,
            _ => {
                return Err(Error::input(
                    path,
                    line,
                    format!(
                        "mesh file `{}`: unknown format (expected .obj or .ply)",
                        m.file
                    ),
                ));
            }
        };
        if mesh_path.is_dir() {
            return Err(Error::input(
                path,
                line,
                format!(
                    "mesh file `{}` is a directory (expected an .obj or .ply file)",
                    m.file
                ),
            ));
        }
        if !mesh_path.is_file() {
            return Err(Error::input(
                path,
                line,
                format!(
                    "mesh file `{}` not found (expected a file next to the scene)",
                    m.file
                ),
            ));
        }
        let mut mesh = match loaded.get(&mesh_path) {
            Some(mesh) => mesh.clone(),
            None => {
                let mesh = read(&mesh_path)?;
                loaded.insert(mesh_path.clone(), mesh.clone());
                mesh
            }
        };
        if let Some(over) = &m.material {
            for mat in &mut mesh.materials {
                apply_material(path, line, over, mat, &mut textures)?;
            }
        }
        if let Some(alpha) = &m.alpha {
            let mask = parse_alpha(path, line, alpha, &mut textures)?;
            set_alpha(path, line, &mut mesh, mask)?;
        }
        let transform = parse_transform(path, line, m.transform.as_ref())?;
        named.add(
            &mut b,
            line,
            m.name.as_ref(),
            m.instance_only,
            mesh,
            &transform,
        )?;
    }

    let procedural_lines = table_lines(&text, "procedural");
    for (i, p) in file.procedural.iter().enumerate() {
        let line = procedural_lines.get(i).copied();
        let shape = match p.kind.as_str() {
            "sphere" => Shape::Sphere,
            "terrain" => Shape::Terrain,
            other => {
                return Err(Error::input(
                    path,
                    line,
                    format!(
                        "unknown procedural type `{other}` (expected \"sphere\" or \"terrain\")"
                    ),
                ));
            }
        };
        let triangles = *p.triangles.get_ref();
        let triangles_line = Some(line_of(&text, p.triangles.span().start));
        if triangles == 0 || triangles > MAX_TRIANGLES {
            return Err(Error::input(
                path,
                triangles_line,
                format!("triangles = {triangles} out of range (1..={MAX_TRIANGLES})"),
            ));
        }
        // checked before generating: nothing is allocated for a refused request
        let (tris, verts) = procedural::counts(shape, triangles);
        let (scene_tris, scene_verts) = (b.triangle_count() + tris, b.vertex_count() + verts);
        if scene_tris > MAX_TRIANGLES || scene_verts > MAX_VERTICES {
            return Err(Error::input(
                path,
                triangles_line,
                format!(
                    "triangles = {triangles} ({tris} generated) would take the scene to {scene_tris} triangles and {scene_verts} vertices (at most {MAX_TRIANGLES} and {MAX_VERTICES})"
                ),
            ));
        }
        if !p.displacement.is_finite() || p.displacement.abs() > 0.9 {
            return Err(Error::input(
                path,
                line,
                format!(
                    "displacement must be finite and within [-0.9, 0.9], got {}",
                    p.displacement
                ),
            ));
        }
        let mut material = Material {
            name: format!("procedural{i}"),
            ..Material::default()
        };
        if let Some(over) = &p.material {
            apply_material(path, line, over, &mut material, &mut textures)?;
        }
        let transform = parse_transform(path, line, p.transform.as_ref())?;
        let name = format!("procedural {} #{i} ({tris} triangles)", p.kind);
        let name = p.name.clone().unwrap_or(name);
        let mut mesh =
            procedural::generate(shape, triangles, p.displacement, p.seed, &name, material);
        if let Some(alpha) = &p.alpha {
            let mask = parse_alpha(path, line, alpha, &mut textures)?;
            set_alpha(path, line, &mut mesh, mask)?;
        }
        named.add(
            &mut b,
            line,
            p.name.as_ref(),
            p.instance_only,
            mesh,
            &transform,
        )?;
    }

    let instance_lines = table_lines(&text, "instance");
    for (i, inst) in file.instance.iter().enumerate() {
        let line = instance_lines.get(i).copied();
        let fail = |m: String| Error::input(path, line, m);
        let Some(&(prototype, own, _)) = named.stored.get(&inst.of) else {
            let mut names: Vec<&str> = named.stored.keys().map(|k| k.as_str()).collect();
            names.sort_unstable();
            let known = if names.is_empty() {
                "no [[mesh]] or [[procedural]] has a `name`".to_string()
            } else {
                format!("named meshes: {}", crate::error::clip(&names.join(", ")))
            };
            return Err(fail(format!(
                "instance of unknown mesh `{}` ({known})",
                crate::error::clip(&inst.of)
            )));
        };
        let prototype = prototype.expect("a mesh an instance names is stored as a prototype");
        let placement = match (&inst.transform, inst.matrix) {
            (Some(_), Some(_)) => {
                return Err(fail(
                    "an instance takes `transform` or `matrix`, not both".to_string(),
                ));
            }
            (_, Some(Exact(m))) => affine_from_rows(&m).map_err(fail)?,
            (t, None) => parse_transform(path, line, t.as_ref())?.matrix(),
        };
        let material = match &inst.material {
            Some(over) => {
                let mut material = Material {
                    name: format!("instance{i}"),
                    ..Material::default()
                };
                apply_material(path, line, over, &mut material, &mut textures)?;
                Some(material)
            }
            None => None,
        };
        b.add_instance(prototype, placement * own, material, line)?;
    }

    let sphere_lines = table_lines(&text, "sphere");
    for (i, sp) in file.sphere.iter().enumerate() {
        let line = sphere_lines.get(i).copied();
        let center = check_point(path, line, "sphere.center", sp.center.0)?;
        if !(sp.radius > 0.0 && sp.radius <= MAX_COORDINATE) {
            return Err(Error::input(
                path,
                line,
                format!(
                    "sphere.radius must be a number in (0, {MAX_COORDINATE:e}], got {}",
                    sp.radius
                ),
            ));
        }
        if (center.abs() + sp.radius as f64).max_element() > MAX_COORDINATE as f64 {
            return Err(Error::input(
                path,
                line,
                format!("sphere reaches beyond +-{MAX_COORDINATE:e} on some axis"),
            ));
        }
        let mut material = Material {
            name: format!("sphere{i}"),
            ..Material::default()
        };
        if let Some(over) = &sp.material {
            apply_material(path, line, over, &mut material, &mut textures)?;
        }
        let uv_frame = match sp.uv_frame {
            None => glam::Mat3::IDENTITY,
            Some(Exact(f)) => {
                let m = glam::Mat3::from_cols_array(&f).transpose();
                let orthonormal = (m * m.transpose()).abs_diff_eq(glam::Mat3::IDENTITY, 1e-4);
                if !f.iter().all(|x| x.is_finite()) || !orthonormal {
                    return Err(Error::input(
                        path,
                        line,
                        "sphere uv_frame must be an orthonormal 3 x 3 matrix (9 numbers, row-major)",
                    ));
                }
                m
            }
        };
        b.add_sphere_framed(center, sp.radius, material, uv_frame, line)?;
    }

    let mut point_lights = Vec::new();
    let mut spot_lights = Vec::new();
    let mut panel_lights = Vec::new();
    let scene = b.scene_mut();
    let light_lines = table_lines(&text, "light");
    for (i, l) in file.light.iter().enumerate() {
        let line = light_lines.get(i).copied();
        let fail = |m: String| Error::input(path, line, m);
        let given = [
            ("radiance", l.radiance.is_some()),
            ("file", l.file.is_some()),
            ("position", l.position.is_some()),
            ("intensity", l.intensity.is_some()),
            ("direction", l.direction.is_some()),
            ("irradiance", l.irradiance.is_some()),
            ("attenuation", l.attenuation.is_some()),
            ("target", l.target.is_some()),
            ("cutoff_angle", l.cutoff_angle.is_some()),
            ("beam_width", l.beam_width.is_some()),
            ("falloff", l.falloff.is_some()),
            ("center", l.center.is_some()),
            ("dim_x", l.dim_x.is_some()),
            ("dim_y", l.dim_y.is_some()),
            ("facing", l.facing.is_some()),
        ];
        let allowed: &[&str] = match l.kind.as_str() {
            "environment" => &["radiance", "file"],
            "point" => &["position", "intensity", "attenuation"],
            "directional" => &["direction", "irradiance"],
            "spot" => &[
                "position",
                "target",
                "direction",
                "intensity",
                "cutoff_angle",
                "beam_width",
                "falloff",
            ],
            "panel" => &["center", "dim_x", "dim_y", "facing", "radiance"],
            other => {
                return Err(fail(format!(
                    "unknown light type `{other}` (expected \"environment\", \"point\", \"spot\", \"directional\" or \"panel\")"
                )));
            }
        };
        if let Some((k, _)) = given.iter().find(|(k, on)| *on && !allowed.contains(k)) {
            return Err(fail(format!(
                "`{k}` is not a key of a {} light (it takes {})",
                l.kind,
                allowed.join(", ")
            )));
        }
        let need = |v: Option<Rgb>, key: &str| {
            v.ok_or_else(|| fail(format!("{} light needs `{key}`", l.kind)))
        };
        match l.kind.as_str() {
            "environment" => {
                let r = match (&l.file, l.radiance) {
                    (Some(_), None) => Vec3::ONE,
                    (_, r) => check_colour(path, line, "radiance", need(r, "radiance")?)?,
                };
                if let Some(f) = &l.file {
                    if scene.environment_map.is_some() {
                        return Err(fail(
                            "a second environment light with a `file` (one image map per scene)"
                                .to_string(),
                        ));
                    }
                    let full = dir.join(f);
                    if let Some(why) = super::not_a_file(&full) {
                        return Err(fail(format!(
                            "environment file `{f}` {why} (expected a .exr or .png next to the scene)"
                        )));
                    }
                    // the scene's line first, then what is wrong with the image
                    let map = EnvironmentMap::load(&full, r)
                        .map_err(|e| fail(format!("environment file `{f}`: {e}")))?;
                    scene.environment_map = Some(map);
                } else {
                    scene.environment = Some(scene.environment.unwrap_or(Vec3::ZERO) + r);
                }
            }
            "panel" => {
                let (Some(c), Some(dx), Some(dy), Some(facing)) =
                    (l.center, l.dim_x, l.dim_y, l.facing)
                else {
                    return Err(fail(
                        "panel light needs `center`, `dim_x`, `dim_y` and `facing`".to_string(),
                    ));
                };
                let c = check_point(path, line, "center", c.0)?;
                let [dx, dy, facing] = [("dim_x", dx), ("dim_y", dy), ("facing", facing)]
                    .map(|(k, v)| check_vec(path, line, k, Vec3::from(v.0)));
                let l_e = check_colour(path, line, "radiance", need(l.radiance, "radiance")?)?;
                let light = PanelLight::new(Vec3::ZERO, dx?, dy?, facing?, l_e).ok_or_else(|| {
                    fail("panel light: `dim_x` and `dim_y` must span an area, and `facing` must not be zero".to_string())
                })?;
                panel_lights.push((c, light));
            }
            "point" => {
                let p = l
                    .position
                    .ok_or_else(|| fail("point light needs `position`".to_string()))?;
                let p = check_point(path, line, "position", p.0)?;
                let i = check_colour(path, line, "intensity", need(l.intensity, "intensity")?)?;
                let mut light = PointLight::new(Vec3::ZERO, i);
                if let Some(Exact(a)) = l.attenuation {
                    light = light.with_attenuation(a).ok_or_else(|| {
                        fail(format!(
                            "point light: `attenuation` [constant, linear, quadratic] must be finite, non-negative and not all zero, got {a:?}"
                        ))
                    })?;
                }
                point_lights.push((p, light));
            }
            "spot" => {
                let p = l
                    .position
                    .ok_or_else(|| fail("spot light needs `position`".to_string()))?;
                let p = check_point(path, line, "position", p.0)?;
                let direction = match (l.target, l.direction) {
                    (Some(t), None) => (check_point(path, line, "target", t.0)? - p).as_vec3(),
                    (None, Some(d)) => check_vec(path, line, "direction", Vec3::from(d.0))?,
                    _ => {
                        return Err(fail(
                            "spot light needs exactly one of `target` and `direction`".to_string(),
                        ));
                    }
                };
                let i = check_colour(path, line, "intensity", need(l.intensity, "intensity")?)?;
                let cutoff = l
                    .cutoff_angle
                    .unwrap_or(crate::light::spot::DEFAULT_CUTOFF_ANGLE);
                let light = match l.falloff.as_deref() {
                    None | Some("linear") => {
                        SpotLight::new(Vec3::ZERO, direction, i, cutoff, l.beam_width)
                    }
                    Some("smooth") => SpotLight::smooth(
                        Vec3::ZERO,
                        direction,
                        i,
                        l.beam_width.unwrap_or(cutoff * 0.75).to_radians(),
                        cutoff.to_radians(),
                    ),
                    Some("smoothstep") => SpotLight::smoothstep(
                        Vec3::ZERO,
                        direction,
                        i,
                        l.beam_width.unwrap_or(cutoff * 0.75).to_radians(),
                        cutoff.to_radians(),
                    ),
                    Some(other) => {
                        return Err(fail(format!(
                            "spot light: `falloff` must be \"linear\", \"smooth\" or \"smoothstep\", got \"{}\"",
                            crate::error::one_line(other)
                        )));
                    }
                }
                .map_err(|m| {
                    fail(if direction == Vec3::ZERO && l.target.is_some() {
                        "spot light: `target` must differ from `position`".to_string()
                    } else {
                        m
                    })
                })?;
                spot_lights.push((p, light));
            }
            _ => {
                let d = l
                    .direction
                    .ok_or_else(|| fail("directional light needs `direction`".to_string()))?;
                let e = check_colour(path, line, "irradiance", need(l.irradiance, "irradiance")?)?;
                let light = DirectionalLight::new(Vec3::from(d.0), e).ok_or_else(|| {
                    fail(format!(
                        "directional light: `direction` must be finite and non-zero, got {d:?}"
                    ))
                })?;
                scene.directional_lights.push(light);
            }
        }
    }

    if let Some(f) = &file.film {
        let Exact([w, h]) = *f.resolution.get_ref();
        limits::check_resolution(w, h)
            .map_err(|m| Error::input(path, Some(line_of(&text, f.resolution.span().start)), m))?;
        scene.resolution = [w as u32, h as u32];
    }
    let mut render = RenderDefaults::default();
    if let Some(r) = &file.render {
        // each fits in u32 once its limit holds
        if let Some(v) = &r.spp {
            render.spp = check_spanned(path, &text, v, limits::check_spp)? as u32;
        }
        if let Some(v) = &r.max_depth {
            render.max_depth = check_spanned(path, &text, v, limits::check_max_depth)? as u32;
        }
        if let Some(v) = &r.light_samples {
            render.light_samples =
                check_spanned(path, &text, v, limits::check_light_samples)? as u32;
        }
        render.seed = r.seed.unwrap_or(render.seed);
        if let Some(v) = &r.rr_depth {
            render.rr_depth = check_spanned(path, &text, v, limits::check_max_depth)? as u32;
        }
        let at = |span: std::ops::Range<usize>| Some(line_of(&text, span.start));
        if let Some(v) = &r.direct {
            render.direct = v
                .get_ref()
                .parse()
                .map_err(|m| Error::input(path, at(v.span()), format!("render.direct: {m}")))?;
        }
        if let Some(v) = &r.rr {
            let p = *v.get_ref();
            if !(0.0..=1.0).contains(&p) {
                return Err(Error::input(
                    path,
                    at(v.span()),
                    format!("render.rr = {p}: expected a continuation probability in [0, 1]"),
                ));
            }
            render.roulette = Roulette::Fixed(p);
        }
    }
    scene.render = render;
    if let Some(c) = &file.camera {
        let at = |span: std::ops::Range<usize>| Some(line_of(&text, span.start));
        let origin_line = at(c.origin.span());
        let origin = check_point(path, origin_line, "camera.origin", c.origin.get_ref().0)?;
        let target_line = at(c.target.span());
        let target = check_point(path, target_line, "camera.target", c.target.get_ref().0)?;
        let (up, up_line) = match &c.up {
            Some(u) => (DVec3::from(u.get_ref().0), at(u.span())),
            None => (DVec3::Y, target_line),
        };
        let view = target - origin;
        let Some(up) = WorldCamera::usable_up(origin, target, up) else {
            return Err(Error::input(
                path,
                up_line,
                "camera: origin and target must differ and `up` must be finite and not parallel to the view",
            ));
        };
        let fov_y = c.fov_y.as_ref().map_or(39.3, |f| *f.get_ref());
        if !(fov_y > 0.0 && fov_y < 180.0) {
            return Err(Error::input(
                path,
                c.fov_y.as_ref().and_then(|f| at(f.span())),
                format!("camera.fov_y must be in (0, 180) degrees, got {fov_y}"),
            ));
        }
        b.set_camera(WorldCamera {
            origin,
            target,
            up,
            fov_y,
        });
        let scene = b.scene_mut();
        if let Some(f) = &c.focal_pixels {
            let (line, f) = (at(f.span()), *f.get_ref());
            if !(f.is_finite() && f > 0.0) {
                return Err(Error::input(
                    path,
                    line,
                    format!("camera.focal_pixels must be a positive number, got {f}"),
                ));
            }
            scene.focal_pixels = Some(f);
        }
        // the plane in focus defaults to the target's
        let focus = c
            .focus_distance
            .as_ref()
            .map_or(view.length() as f32, |f| *f.get_ref());
        let aperture = c.aperture_radius.as_ref().map_or(0.0, |a| *a.get_ref());
        let lens_line = c
            .aperture_radius
            .as_ref()
            .or(c.focus_distance.as_ref())
            .and_then(|a| at(a.span()));
        // lens points must stay within Embree's coordinate range
        if origin.abs().max_element() + aperture.abs() as f64 > MAX_COORDINATE as f64 {
            return Err(Error::input(
                path,
                lens_line,
                format!(
                    "camera.aperture_radius {aperture:e} takes the lens beyond +-{MAX_COORDINATE:e}"
                ),
            ));
        }
        scene.lens = ThinLens::new(aperture, focus).map_err(|e| match e {
            Error::Settings(m) => Error::input(path, lens_line, format!("camera.{m}")),
            other => other,
        })?;
    }
    for (p, light) in point_lights {
        b.add_point_light(p, light);
    }
    for (p, light) in spot_lights {
        b.add_spot_light(p, light);
    }
    for (c, light) in panel_lights {
        b.add_panel_light(c, light);
    }
    Ok(b.build())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn line_numbers() {
        assert_eq!(line_of("a\nb\nc", 0), 1);
        assert_eq!(line_of("a\nb\nc", 2), 2);
        assert_eq!(line_of("\u{e9}\n\u{e9}", 1), 1, "inside a character");
        assert_eq!(line_of("a\n", 99), 2, "past the end");
        assert_eq!(table_lines("[[mesh]]\nx=1\n[[mesh]]\n", "mesh"), vec![1, 3]);
    }
}
