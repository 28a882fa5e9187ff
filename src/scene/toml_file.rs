//! The TOML scene format. The schema is fixed (other scripts write it); unknown
//! keys are errors naming the key, the file and the line, and every value is
//! checked against [`super::limits`] before anything is allocated for it.
//!
//! ```toml
//! [camera]
//! origin = [0.0, 1.0, 3.9]
//! target = [0.0, 1.0, 0.0]
//! up     = [0.0, 1.0, 0.0]
//! fov_y  = 39.3               # vertical field of view, degrees
//!
//! [film]
//! resolution = [512, 512]     # width, height
//!
//! [render]                    # defaults; command-line flags override them
//! spp = 64
//! max_depth = 64
//! light_samples = 1
//! seed = 0
//!
//! [[mesh]]
//! file = "cornell-box.obj"    # relative to the scene file
//! transform = { scale = 1.0, rotate = [0, 1, 0, 30], translate = [0, 0, 0] }
//! material = { diffuse = [0.5, 0.5, 0.5], emission = 0.0, two_sided = false }
//!
//! [[light]]
//! type = "environment"
//! radiance = [1.0, 1.0, 1.0]  # or one number
//! ```

use super::limits::{self, MAX_COORDINATE, MAX_TRIANGLES, MAX_VERTICES};
use super::procedural::{self, Shape};
use super::{
    CameraDesc, Material, MeshData, RenderDefaults, Scene, SceneBuilder, Transform, load_obj_mesh,
};
use crate::error::{Error, Result};
use crate::math::Vec3;
use serde::Deserialize;
use serde::de::{self, Deserializer, SeqAccess, Visitor};
use std::collections::HashMap;
use std::fmt;
use std::path::{Path, PathBuf};
use toml::Spanned;

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
}

fn default_displacement() -> f32 {
    0.1
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct CameraToml {
    origin: [f32; 3],
    target: [f32; 3],
    #[serde(default = "default_up")]
    up: [f32; 3],
    #[serde(default = "default_fov")]
    fov_y: f32,
}

fn default_up() -> [f32; 3] {
    [0.0, 1.0, 0.0]
}

fn default_fov() -> f32 {
    39.3
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct FilmToml {
    resolution: Spanned<[u64; 2]>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RenderToml {
    spp: Option<Spanned<u64>>,
    max_depth: Option<Spanned<u64>>,
    light_samples: Option<Spanned<u64>>,
    seed: Option<u64>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct MeshToml {
    file: String,
    transform: Option<TransformToml>,
    material: Option<MaterialToml>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct TransformToml {
    scale: Option<Rgb>,
    rotate: Option<[f32; 4]>,
    translate: Option<[f32; 3]>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct MaterialToml {
    diffuse: Option<Rgb>,
    emission: Option<Rgb>,
    two_sided: Option<bool>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct LightToml {
    #[serde(rename = "type")]
    kind: String,
    radiance: Option<Rgb>,
}

/// A colour-like value: one number or an `[r, g, b]` triple.
#[derive(Debug, Clone, Copy)]
struct Rgb(Vec3);

impl<'de> Deserialize<'de> for Rgb {
    fn deserialize<D: Deserializer<'de>>(d: D) -> std::result::Result<Self, D::Error> {
        struct V;
        impl<'de> Visitor<'de> for V {
            type Value = Rgb;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("a number or an [r, g, b] array of three numbers")
            }
            fn visit_f64<E: de::Error>(self, v: f64) -> std::result::Result<Rgb, E> {
                Ok(Rgb(Vec3::splat(v as f32)))
            }
            fn visit_i64<E: de::Error>(self, v: i64) -> std::result::Result<Rgb, E> {
                Ok(Rgb(Vec3::splat(v as f32)))
            }
            fn visit_u64<E: de::Error>(self, v: u64) -> std::result::Result<Rgb, E> {
                Ok(Rgb(Vec3::splat(v as f32)))
            }
            fn visit_seq<A: SeqAccess<'de>>(self, mut s: A) -> std::result::Result<Rgb, A::Error> {
                let mut c = [0.0f32; 3];
                for (i, slot) in c.iter_mut().enumerate() {
                    *slot = s
                        .next_element::<f32>()?
                        .ok_or_else(|| de::Error::invalid_length(i, &self))?;
                }
                if s.next_element::<f32>()?.is_some() {
                    return Err(de::Error::invalid_length(4, &self));
                }
                Ok(Rgb(Vec3::from(c)))
            }
        }
        d.deserialize_any(V)
    }
}

/// Line (1-based) of byte `offset` in `text`.
/// (Counted in bytes: an offset inside a multi-byte character cannot panic.)
fn line_of(text: &str, offset: usize) -> usize {
    let bytes = text.as_bytes();
    bytes[..offset.min(bytes.len())]
        .iter()
        .filter(|&&b| b == b'\n')
        .count()
        + 1
}

/// Lines (1-based) of the `[[table]]` headers named `name`, in order, for
/// messages. One pass over the text: a scene may list many tables.
fn table_lines(text: &str, name: &str) -> Vec<usize> {
    let header = format!("[[{name}]]");
    text.lines()
        .enumerate()
        .filter(|(_, l)| l.trim_start().starts_with(&header))
        .map(|(n, _)| n + 1)
        .collect()
}

/// Check a spanned integer with `check` (from [`limits`]); errors at its line.
fn check_spanned<T: Copy + Into<u64>>(
    path: &Path,
    text: &str,
    v: &Spanned<T>,
    check: fn(u64) -> std::result::Result<(), String>,
) -> Result<T> {
    let value = *v.get_ref();
    check(value.into()).map_err(|m| Error::input(path, Some(line_of(text, v.span().start)), m))?;
    Ok(value)
}

fn check_vec(path: &Path, line: Option<usize>, what: &str, v: Vec3) -> Result<Vec3> {
    if v.is_finite() {
        Ok(v)
    } else {
        Err(Error::input(
            path,
            line,
            format!("{what} must be finite, got {v}"),
        ))
    }
}

/// A camera position: finite and within Embree's range.
fn check_point(path: &Path, line: Option<usize>, what: &str, p: [f32; 3]) -> Result<Vec3> {
    let v = check_vec(path, line, what, Vec3::from(p))?;
    if v.abs().max_element() > MAX_COORDINATE {
        return Err(Error::input(
            path,
            line,
            format!("{what} must be within +-{MAX_COORDINATE:e} on every axis, got {v}"),
        ));
    }
    Ok(v)
}

fn check_colour(path: &Path, line: Option<usize>, what: &str, c: Rgb) -> Result<Vec3> {
    let v = check_vec(path, line, what, c.0)?;
    if v.min_element() < 0.0 {
        return Err(Error::input(
            path,
            line,
            format!("{what} must be non-negative, got {v}"),
        ));
    }
    Ok(v)
}

/// Apply a `material = {...}` override to `mat`.
fn apply_material(
    path: &Path,
    line: Option<usize>,
    over: &MaterialToml,
    mat: &mut Material,
) -> Result<()> {
    if let Some(d) = over.diffuse {
        let d = check_colour(path, line, "material.diffuse", d)?;
        if d.max_element() > 1.0 {
            return Err(Error::input(
                path,
                line,
                format!("material.diffuse must be at most 1, got {d}"),
            ));
        }
        mat.albedo = d;
    }
    if let Some(e) = over.emission {
        mat.emission = check_colour(path, line, "material.emission", e)?;
    }
    if let Some(t) = over.two_sided {
        mat.two_sided = t;
    }
    Ok(())
}

/// Check and convert a `transform = {...}` table.
fn parse_transform(
    path: &Path,
    line: Option<usize>,
    t: Option<&TransformToml>,
) -> Result<Transform> {
    let mut transform = Transform::default();
    let Some(t) = t else {
        return Ok(transform);
    };
    if let Some(s) = t.scale {
        transform.scale = check_vec(path, line, "transform.scale", s.0)?;
        if transform.scale.x * transform.scale.y * transform.scale.z == 0.0 {
            return Err(Error::input(
                path,
                line,
                "transform.scale must be non-zero on every axis",
            ));
        }
    }
    if let Some(r) = t.rotate {
        let axis = check_vec(
            path,
            line,
            "transform.rotate axis",
            Vec3::new(r[0], r[1], r[2]),
        )?;
        if axis.length() == 0.0 || !r[3].is_finite() {
            return Err(Error::input(
                path,
                line,
                "transform.rotate must be [ax, ay, az, degrees] with a non-zero axis",
            ));
        }
        transform.rotate = Some((axis, r[3]));
    }
    if let Some(tr) = t.translate {
        transform.translate = check_vec(path, line, "transform.translate", Vec3::from(tr))?;
    }
    Ok(transform)
}

/// Load a TOML scene.
pub fn load(path: &Path) -> Result<Scene> {
    let bytes = std::fs::read(path).map_err(|e| Error::io(path, e))?;
    let text = String::from_utf8(bytes)
        .map_err(|_| Error::input(path, None, "not UTF-8 text (expected a TOML scene)"))?;
    let file: SceneFile = toml::from_str(&text).map_err(|e| {
        let line = e.span().map(|s| line_of(&text, s.start));
        Error::input(path, line, e.message().trim().replace('\n', " "))
    })?;
    let dir = path.parent().unwrap_or(Path::new(""));
    let mut b = SceneBuilder::new(path);

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
        if ext.as_deref() != Some("obj") {
            return Err(Error::input(
                path,
                line,
                format!("mesh file `{}`: unknown format (expected .obj)", m.file),
            ));
        }
        if mesh_path.is_dir() {
            return Err(Error::input(
                path,
                line,
                format!(
                    "mesh file `{}` is a directory (expected an .obj file)",
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
                let mesh = load_obj_mesh(&mesh_path)?;
                loaded.insert(mesh_path.clone(), mesh.clone());
                mesh
            }
        };
        if let Some(over) = &m.material {
            for mat in &mut mesh.materials {
                apply_material(path, line, over, mat)?;
            }
        }
        let transform = parse_transform(path, line, m.transform.as_ref())?;
        b.add_mesh_from(mesh, &transform, line)?;
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
            apply_material(path, line, over, &mut material)?;
        }
        let transform = parse_transform(path, line, p.transform.as_ref())?;
        let name = format!("procedural {} #{i} ({tris} triangles)", p.kind);
        let mesh = procedural::generate(shape, triangles, p.displacement, p.seed, &name, material);
        b.add_mesh_from(mesh, &transform, line)?;
    }

    let scene = b.scene_mut();
    let light_lines = table_lines(&text, "light");
    for (i, l) in file.light.iter().enumerate() {
        let line = light_lines.get(i).copied();
        match l.kind.as_str() {
            "environment" => {
                let r = l.radiance.ok_or_else(|| {
                    Error::input(path, line, "environment light needs `radiance`")
                })?;
                let r = check_colour(path, line, "radiance", r)?;
                scene.environment = Some(scene.environment.unwrap_or(Vec3::ZERO) + r);
            }
            other => {
                return Err(Error::input(
                    path,
                    line,
                    format!("unknown light type `{other}` (expected \"environment\")"),
                ));
            }
        }
    }

    if let Some(f) = &file.film {
        let [w, h] = *f.resolution.get_ref();
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
    }
    scene.render = render;
    match &file.camera {
        Some(c) => {
            let line = text
                .lines()
                .position(|l| l.trim() == "[camera]")
                .map(|n| n + 1);
            let origin = check_point(path, line, "camera.origin", c.origin)?;
            let target = check_point(path, line, "camera.target", c.target)?;
            let up = check_vec(path, line, "camera.up", Vec3::from(c.up))?;
            let view = target - origin;
            if view.length() == 0.0 || view.cross(up).length() == 0.0 {
                return Err(Error::input(
                    path,
                    line,
                    "camera: origin and target must differ and `up` must not be parallel to the view",
                ));
            }
            if !(c.fov_y > 0.0 && c.fov_y < 180.0) {
                return Err(Error::input(
                    path,
                    line,
                    format!("camera.fov_y must be in (0, 180) degrees, got {}", c.fov_y),
                ));
            }
            scene.camera = CameraDesc {
                origin,
                target,
                up,
                fov_y: c.fov_y,
            };
        }
        None => {
            scene.camera = Scene::framing_camera(&scene.bounds());
            scene
                .notes
                .push("no [camera]: framed automatically from the scene bounds".to_string());
        }
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
