//! Wavefront OBJ/MTL meshes through tobj. MTL `Kd` is the diffuse albedo,
//! `Ke` the emitted radiance (an area light, front side only), and `illum`,
//! `Ks`, `Ns`, `Ni` and `map_Kd` choose other materials ([`convert_material`]'s
//! table). Texture coordinates (`vt`) and vertex normals (`vn`) are kept per
//! triangle corner: the normals give smooth shading.
//!
//! tobj reports malformed files without line numbers, and reads a few things
//! differently from the OBJ files people have (a comment after a value is an
//! error to it, a tab after `usemtl` loses the name, `l a b c` becomes a
//! triangle). So each file first goes through [`prepare`]: one pass that
//! checks every statement tobj will read, naming the file and line of the
//! first problem (a non-finite, out-of-range ([`MAX_COORDINATE`]) or
//! unparsable vertex, a zero `w`, an out-of-range or forward face index, a
//! face that takes the file past [`MAX_TRIANGLES`], a bad material
//! statement, a missing material library), and writes the lines out in the
//! one form tobj reads as meant: comments stripped, blanks trimmed, `w`
//! applied and vertex colours dropped, lines and points left out (they are
//! not rendered). tobj then parses that text, so its view and the checks
//! are the same.

use super::{Content, EmissionRole, Material, MeshData, Scene, read_bounded};
use crate::bsdf::{Bsdf, Diffuse, Glass, Mirror, Plastic};
use crate::error::{Error, Result};
use crate::limits::{
    MAX_COORDINATE, MAX_MESH_FILE_BYTES, MAX_SCENE_FILE_BYTES, MAX_TRIANGLES, MAX_VERTICES,
};
use crate::math::{DVec3, Vec2, Vec3};
use crate::texture::ImageTexture;
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// Read `path` as one mesh (all its objects merged), with its materials.
pub fn load_obj_mesh(path: &Path) -> Result<MeshData> {
    let bytes = read_bounded(path, MAX_MESH_FILE_BYTES, Content::Text)?;
    let obj = prepare(path, &String::from_utf8_lossy(&bytes), MAX_TRIANGLES)?;
    drop(bytes);
    let mut warnings = obj.warnings;
    // every library the file names, checked and cleaned before tobj asks
    let mut libs: HashMap<PathBuf, String> = HashMap::new();
    // the line of each material's `newmtl`, in the first library naming it
    let mut newmtl_lines: HashMap<String, (PathBuf, usize)> = HashMap::new();
    for (name, line) in &obj.mtllibs {
        let lib = path.parent().unwrap_or(Path::new("")).join(name);
        if libs.contains_key(name) {
            continue;
        }
        if !lib.is_file() {
            return Err(Error::input(
                path,
                Some(*line),
                format!(
                    "cannot read material library `{}` (expected a readable .mtl file next to the OBJ)",
                    name.display()
                ),
            ));
        }
        let bytes = read_bounded(&lib, MAX_SCENE_FILE_BYTES, Content::Text)?;
        let prepared = prepare_mtl(&lib, &String::from_utf8_lossy(&bytes))?;
        for (material, line) in prepared.materials {
            newmtl_lines
                .entry(material)
                .or_insert_with(|| (lib.clone(), line));
        }
        warnings.extend(prepared.warnings);
        libs.insert(name.clone(), prepared.text);
    }
    let options = tobj::LoadOptions {
        triangulate: true,
        single_index: false,
        ignore_points: true,
        ignore_lines: true,
    };
    let (models, materials) = tobj::load_obj_buf(&mut obj.text.as_bytes(), &options, |name| {
        let text = libs.get(name).ok_or(tobj::LoadError::OpenFileFailed)?;
        tobj::load_mtl_buf(&mut text.as_bytes())
    })
    .map_err(|e| Error::input(path, None, format!("malformed OBJ: {e}")))?;
    let tobj_materials = match materials {
        Ok(m) => m,
        Err(_) if obj.mtllibs.is_empty() => Vec::new(),
        Err(e) => {
            let (name, line) = &obj.mtllibs[0];
            return Err(Error::input(
                path,
                Some(*line),
                format!("material library `{}`: malformed: {e}", name.display()),
            ));
        }
    };
    let mut mesh = MeshData {
        name: path
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default(),
        warnings,
        files: std::iter::once(path.to_path_buf())
            .chain(
                obj.mtllibs
                    .iter()
                    .map(|(name, _)| path.parent().unwrap_or(Path::new("")).join(name)),
            )
            .collect(),
        ..MeshData::default()
    };
    let lib_file = obj.mtllibs.first().map_or(path.to_path_buf(), |(name, _)| {
        path.parent().unwrap_or(Path::new("")).join(name)
    });
    let mut textures: HashMap<String, Arc<ImageTexture>> = HashMap::new();
    for m in &tobj_materials {
        let (file, line) = match newmtl_lines.get(&m.name) {
            Some((file, line)) => (file.as_path(), Some(*line)),
            None => (lib_file.as_path(), None),
        };
        mesh.materials
            .push(convert_material(m, file, line, &mut textures)?);
    }
    let default_material = mesh.materials.len() as u32;
    mesh.materials.push(Material::default());
    for model in &models {
        let m = &model.mesh;
        let base = mesh.positions.len() as u32;
        for p in m.positions.chunks_exact(3) {
            mesh.positions.push(DVec3::new(p[0], p[1], p[2]));
        }
        let count = (m.positions.len() / 3) as u32;
        let mat = m
            .material_id
            .filter(|&i| i < tobj_materials.len())
            .map_or(default_material, |i| i as u32);
        let first = mesh.indices.len();
        for t in m.indices.chunks_exact(3) {
            if t.iter().any(|&i| i >= count) {
                return Err(Error::input(
                    path,
                    None,
                    format!("object `{}`: face index out of range", model.name),
                ));
            }
            mesh.indices.push([t[0] + base, t[1] + base, t[2] + base]);
            mesh.tri_material.push(mat);
        }
        // per-corner texture coordinates and normals, when every face of the
        // object has them (`f v/vt/vn`); otherwise zeros (no UV, flat)
        let corners = m.indices.len();
        let uvs = (m.texcoord_indices.len() == corners).then(|| {
            corner_values(&m.texcoord_indices, &m.texcoords, 2, |c| {
                Vec2::new(c[0] as f32, c[1] as f32)
            })
        });
        let normals = (m.normal_indices.len() == corners).then(|| {
            corner_values(&m.normal_indices, &m.normals, 3, |c| {
                Vec3::new(c[0] as f32, c[1] as f32, c[2] as f32)
            })
        });
        if let Some(uvs) = uvs.flatten() {
            mesh.uvs.resize(first, [Vec2::ZERO; 3]);
            mesh.uvs.extend(uvs);
        }
        if let Some(ns) = normals.flatten() {
            mesh.normals.resize(first, [Vec3::ZERO; 3]);
            mesh.normals.extend(ns);
        }
    }
    let n = mesh.indices.len();
    if !mesh.uvs.is_empty() {
        mesh.uvs.resize(n, [Vec2::ZERO; 3]);
    }
    if !mesh.normals.is_empty() {
        mesh.normals.resize(n, [Vec3::ZERO; 3]);
    }
    Ok(mesh)
}

/// Each triangle's three corner values of an attribute with `width`
/// components per value, or `None` when an index is out of range or a value
/// is not finite.
fn corner_values<T: Copy>(
    indices: &[u32],
    values: &[f64],
    width: usize,
    make: impl Fn(&[f64]) -> T,
) -> Option<Vec<[T; 3]>> {
    let get = |i: u32| {
        let c = values.get(i as usize * width..(i as usize + 1) * width)?;
        c.iter().all(|x| x.is_finite()).then(|| make(c))
    };
    indices
        .chunks_exact(3)
        .map(|t| Some([get(t[0])?, get(t[1])?, get(t[2])?]))
        .collect()
}

/// The Phong exponent `Ns` as a microfacet roughness: `alpha = sqrt(2 / (Ns +
/// 2))`, the Beckmann width whose normal distribution has the same peak
/// shape as a Blinn-Phong lobe of that exponent (Walter et al. 2007,
/// "Microfacet Models for Refraction through Rough Surfaces", section 5.2).
/// `Ns = 0` gives `alpha = 1`; large `Ns` tends to 0 (a smooth coat).
pub fn ns_to_alpha(ns: f32) -> f32 {
    (2.0 / (ns.max(0.0) + 2.0)).sqrt()
}

/// An MTL material as a [`Material`]:
///
/// | MTL | material |
/// |---|---|
/// | `illum 3` | `mirror` with `reflectance = Ks` (1 when absent) |
/// | `illum 4`, `6` or `7` | `glass` with `ior = Ni` (1.5 when absent) |
/// | `illum 2` with a non-black `Ks` and an `Ns` | `plastic` with `diffuse = Kd`, `ior = Ni` (1.5), `alpha` from `Ns` ([`ns_to_alpha`]) |
/// | anything else | `diffuse` with `Kd` |
///
/// The coat of a plastic reflects by its Fresnel factor, so the size of `Ks`
/// only switches the coat on. `map_Kd` is an albedo texture (relative to the
/// MTL file) for a diffuse or plastic material; `Ke` is emission.
fn convert_material(
    m: &tobj::Material,
    file: &Path,
    line: Option<usize>,
    textures: &mut HashMap<String, Arc<ImageTexture>>,
) -> Result<Material> {
    let fail = |msg: String| Error::input(file, line, format!("material `{}`: {msg}", m.name));
    // prepare_mtl has checked each colour line; this guards the defaults
    let colour = |name: &str, c: Option<[f64; 3]>, default: Vec3| -> Result<Vec3> {
        let v = c.map_or(default, |c| DVec3::from(c).as_vec3());
        if !v.is_finite() || v.min_element() < 0.0 {
            return Err(fail(format!(
                "{name} must be finite and non-negative, got {v}"
            )));
        }
        Ok(v)
    };
    let albedo = colour("Kd", m.diffuse, Vec3::splat(0.8))?;
    if albedo.max_element() > 1.0 {
        return Err(fail(format!(
            "Kd must be at most 1 (energy conservation), got {albedo}"
        )));
    }
    let ks = colour("Ks", m.specular, Vec3::ZERO)?;
    let ior = m.optical_density.map_or(1.5, |v| v as f32);
    let bsdf = match m.illumination_model {
        Some(3) => {
            let reflectance = colour("Ks", m.specular, Vec3::ONE)?;
            Bsdf::Mirror(Mirror { reflectance })
        }
        Some(4 | 6 | 7) => Bsdf::Glass(Glass {
            ior,
            ..Glass::default()
        }),
        Some(2) if ks.max_element() > 0.0 && m.shininess.is_some() => {
            let alpha = ns_to_alpha(m.shininess.unwrap_or(0.0) as f32);
            Bsdf::Plastic(
                Plastic::new(albedo, ior, alpha)
                    .map_err(|e| fail(format!("as plastic (illum 2 with Ks and Ns): {e}")))?,
            )
        }
        _ => Bsdf::Diffuse(Diffuse { albedo }),
    };
    bsdf.validate()
        .map_err(|e| fail(format!("{e} (from Ks, Ni or Kd)")))?;
    let texture = match &m.diffuse_texture {
        Some(name) if matches!(bsdf, Bsdf::Diffuse(_) | Bsdf::Plastic(_)) => {
            let t = match textures.get(name) {
                Some(t) => t.clone(),
                None => {
                    let full = file.parent().unwrap_or(Path::new("")).join(name);
                    if let Some(why) = super::not_a_file(&full) {
                        return Err(fail(format!(
                            "map_Kd `{name}` {why} (expected a .png or .exr next to the MTL file)"
                        )));
                    }
                    let t = ImageTexture::load(&full)
                        .map_err(|e| fail(format!("map_Kd `{name}`: {e}")))?;
                    let t = Arc::new(t);
                    textures.insert(name.clone(), t.clone());
                    t
                }
            };
            Some(t)
        }
        _ => None,
    };
    Ok(Material {
        name: m.name.clone(),
        bsdf,
        texture,
        emission: colour("Ke", m.emissive, Vec3::ZERO)?,
        two_sided: false,
        role: EmissionRole::Light,
        one_sided: false,
        maps: Default::default(),
        alpha_mask: None,
    })
}

/// A line split into its statement and the rest, comments and surrounding
/// blanks removed.
fn split_statement(raw: &str) -> (&str, &str) {
    let line = raw.split('#').next().unwrap_or("").trim();
    match line.find(char::is_whitespace) {
        Some(i) => (&line[..i], line[i..].trim()),
        None => (line, ""),
    }
}

/// An OBJ file checked and rewritten for tobj.
struct PreparedObj {
    /// The text tobj parses, line for line the file's (so line numbers agree).
    text: String,
    /// The material libraries named, as written, with their lines.
    mtllibs: Vec<(PathBuf, usize)>,
    /// Statements read past, one line for the file.
    warnings: Vec<String>,
}

/// Every statement of the OBJ format (Wavefront's "Object Files (.obj)"
/// specification, Appendix B1 of the Advanced Visualizer manual): those
/// not rendered (free-form curves and surfaces, display attributes) are
/// read past with a warning; anything else means the file is not OBJ.
const OBJ_STATEMENTS: [&str; 40] = [
    "v",
    "vt",
    "vn",
    "vp",
    "f",
    "l",
    "p",
    "o",
    "g",
    "s",
    "mg",
    "usemtl",
    "mtllib",
    "cstype",
    "deg",
    "bmat",
    "step",
    "curv",
    "curv2",
    "surf",
    "parm",
    "trim",
    "hole",
    "scrv",
    "sp",
    "end",
    "con",
    "maplib",
    "usemap",
    "lod",
    "ctech",
    "stech",
    "shadow_obj",
    "trace_obj",
    "bevel",
    "c_interp",
    "d_interp",
    "call",
    "csh",
    "fo",
];

/// Parse `s` as a number, or say which `what` at `line` could not be.
fn number(path: &Path, line: usize, what: &str, s: &str) -> Result<f64> {
    s.parse::<f64>().map_err(|_| {
        Error::input(
            path,
            Some(line),
            format!("cannot parse {what} `{s}` (expected a number)"),
        )
    })
}

/// Check an OBJ file statement by statement and rewrite it for tobj (see the
/// module header). Errors name `path` and the line. `max_triangles` is
/// [`MAX_TRIANGLES`] but in unit tests.
fn prepare(path: &Path, text: &str, max_triangles: u64) -> Result<PreparedObj> {
    let lines: Vec<(&str, &str)> = text.lines().map(split_statement).collect();
    let count = |key: &str| lines.iter().filter(|l| l.0 == key).count() as i64;
    // positions, texture coordinates, normals: in the file, and seen so far
    // (negative indices count back from the last one seen)
    let total = [count("v"), count("vt"), count("vn")];
    if total[0] as u64 > MAX_VERTICES {
        return Err(Error::input(
            path,
            None,
            format!("{} vertices (at most {MAX_VERTICES} in a scene)", total[0]),
        ));
    }
    const KIND: [&str; 3] = ["vertex", "texture coordinate", "normal"];
    let mut seen = [0i64; 3];
    // tobj turns the faces of an `o`, `g` or `usemtl` group into a mesh when
    // the group ends, with the vertices read so far: a positive index must
    // not reach past the group's end. The largest one of each kind, and the
    // line that used it, since the group began.
    let mut reach: [Option<(i64, usize)>; 3] = [None; 3];
    let check_reach = |reach: &mut [Option<(i64, usize)>; 3], seen: &[i64; 3]| -> Result<()> {
        for k in 0..3 {
            if let Some((i, line)) = reach[k].take() {
                if i > seen[k] {
                    return Err(Error::input(
                        path,
                        Some(line),
                        format!(
                            "face {} index {i} refers past the end of its `o`/`g`/`usemtl` group (only {} defined by then)",
                            KIND[k], seen[k]
                        ),
                    ));
                }
            }
        }
        Ok(())
    };
    // triangles after fan triangulation: a face of n vertices makes n - 2
    let mut triangles = 0u64;
    let mut mtllibs = Vec::new();
    let (mut unknown, mut first_unknown, mut read_past) = (0usize, None, None);
    let mut out = String::with_capacity(text.len());
    for (n, &(key, rest)) in lines.iter().enumerate() {
        let line_no = n + 1;
        let err = |msg: String| Err(Error::input(path, Some(line_no), msg));
        match key {
            "v" => {
                let values: Vec<&str> = rest.split_whitespace().collect();
                if !matches!(values.len(), 3 | 4 | 6) {
                    return err(format!(
                        "expected `v x y z`, `v x y z w` or `v x y z r g b`, got {} values",
                        values.len()
                    ));
                }
                let mut p = [0f64; 3];
                for (c, s) in p.iter_mut().zip(&values) {
                    *c = number(path, line_no, "vertex coordinate", s)?;
                }
                // tobj divides by w, in f64, as here
                if values.len() == 4 {
                    let w = number(path, line_no, "vertex weight w", values[3])?;
                    if !w.is_finite() || w == 0.0 {
                        return err(format!(
                            "vertex weight w = `{}` (expected a finite, non-zero number)",
                            values[3]
                        ));
                    }
                    for c in &mut p {
                        *c /= w;
                    }
                }
                let over_w = if values.len() == 4 {
                    format!(" divided by w = `{}`", values[3])
                } else {
                    String::new()
                };
                for (c, s) in p.iter().zip(&values) {
                    if c.is_nan() || c.is_infinite() {
                        return err(format!(
                            "vertex coordinate `{s}`{over_w} is not finite (expected a finite number)"
                        ));
                    }
                    if c.abs() > MAX_COORDINATE as f64 {
                        return err(format!(
                            "vertex coordinate `{s}`{over_w} is beyond +-{MAX_COORDINATE:e} (expected a number within Embree's range)"
                        ));
                    }
                }
                seen[0] += 1;
                if values.len() == 3 {
                    out.push_str("v ");
                    out.push_str(rest);
                } else {
                    // `{}` prints the shortest text that reads back to the same f64
                    out.push_str(&format!("v {} {} {}", p[0], p[1], p[2]));
                }
            }
            "vt" | "vn" => {
                let (k, want) = if key == "vt" { (1, 2) } else { (2, 3) };
                let values: Vec<&str> = rest.split_whitespace().take(want).collect();
                if values.len() < want {
                    return err(format!(
                        "expected {want} numbers after `{key}`, got {}",
                        values.len()
                    ));
                }
                for s in values {
                    number(path, line_no, KIND[k], s)?;
                }
                seen[k] += 1;
                out.push_str(key);
                out.push(' ');
                out.push_str(rest);
            }
            "f" => {
                let verts: Vec<&str> = rest.split_whitespace().collect();
                if verts.len() < 3 {
                    return err("a face needs at least three vertices".into());
                }
                triangles += verts.len() as u64 - 2;
                if triangles > max_triangles {
                    return err(format!(
                        "this face takes the file past {max_triangles} triangles (the scene limit)"
                    ));
                }
                for v in verts {
                    let parts: Vec<&str> = v.split('/').collect();
                    if parts.len() > 3 || parts[0].is_empty() {
                        return err(format!(
                            "cannot parse face vertex `{v}` (expected v, v/vt, v//vn or v/vt/vn)"
                        ));
                    }
                    for (k, part) in parts.iter().enumerate() {
                        if part.is_empty() {
                            continue;
                        }
                        let Ok(i) = part.parse::<i64>() else {
                            return err(format!(
                                "cannot parse face vertex `{v}` (expected an index)"
                            ));
                        };
                        let ok = if i > 0 {
                            i <= total[k]
                        } else {
                            i < 0 && seen[k] + i >= 0
                        };
                        if !ok {
                            return err(format!(
                                "face {} index {i} out of range (the file has {} of them)",
                                KIND[k], total[k]
                            ));
                        }
                        if i > seen[k] && reach[k].is_none_or(|(r, _)| i > r) {
                            reach[k] = Some((i, line_no));
                        }
                    }
                }
                out.push_str("f ");
                out.push_str(rest);
            }
            // lines and points are not rendered
            "l" | "p" => {}
            "o" | "g" | "usemtl" => {
                check_reach(&mut reach, &seen)?;
                if key == "usemtl" && rest.is_empty() {
                    return err("expected a material name after `usemtl`".into());
                }
                out.push_str(key);
                out.push(' ');
                out.push_str(rest);
            }
            "mtllib" => {
                if rest.is_empty() {
                    return err("expected a file name after `mtllib`".into());
                }
                mtllibs.push((PathBuf::from(rest), line_no));
                out.push_str("mtllib ");
                out.push_str(rest);
            }
            // `s`, `#`, blank lines and statements tobj ignores
            "" | "s" => {}
            _ if OBJ_STATEMENTS.contains(&key) => {
                if read_past.is_none() {
                    read_past = Some((line_no, key));
                }
            }
            _ => {
                unknown += 1;
                if first_unknown.is_none() {
                    first_unknown = Some((line_no, key));
                }
            }
        }
        out.push('\n');
    }
    check_reach(&mut reach, &seen)?;
    // a statement quoted in a message: its first 40 characters
    let token = |t: &str| {
        let t: String = t.chars().take(40).collect();
        crate::error::one_line(&t).into_owned()
    };
    let mut warnings = Vec::new();
    if let Some((line, key)) = first_unknown {
        let key = token(key);
        if triangles == 0 {
            return Err(Error::input(
                path,
                Some(line),
                format!(
                    "`{key}` is not an OBJ statement, and the file has no faces: not an OBJ file"
                ),
            ));
        }
        warnings.push(format!(
            "{}: {unknown} lines start with something that is not an OBJ statement (read past)",
            crate::error::Location {
                file: path.to_path_buf(),
                line: Some(line),
            }
        ));
    }
    if let Some((line, key)) = read_past {
        warnings.push(format!(
            "{}: `{key}` and other free-form or display statements are not rendered (read past)",
            crate::error::Location {
                file: path.to_path_buf(),
                line: Some(line),
            }
        ));
    }
    if triangles == 0 {
        warnings.push(format!(
            "{}: no faces: the mesh adds nothing to the scene",
            crate::error::Location {
                file: path.to_path_buf(),
                line: None,
            }
        ));
    }
    Ok(PreparedObj {
        text: out,
        mtllibs,
        warnings,
    })
}

/// Check a material library statement by statement, as tobj will read it
/// (tobj 4.0 panics on a colour line with fewer than three values, found by
/// `tests/fuzz_loaders.rs`), and rewrite it the same way as [`prepare`].
/// `Kd` must lie in `[0, 1]` and `Ke` be finite and non-negative.
fn prepare_mtl(lib: &Path, text: &str) -> Result<PreparedMtl> {
    let mut out = String::with_capacity(text.len());
    let mut materials = Vec::new();
    // keys read past, in order of first use, with that line
    let mut read_past: Vec<(&str, usize)> = Vec::new();
    for (n, raw) in text.lines().enumerate() {
        let err = |msg: String| Err(Error::input(lib, Some(n + 1), msg));
        let (key, rest) = split_statement(raw);
        let first = rest.split_whitespace().next();
        let value = first.and_then(|v| v.parse::<f32>().ok());
        let ignored = match key {
            "map_Ka" | "map_Ks" | "map_Bump" | "map_bump" | "bump" | "map_Ns" | "map_ns"
            | "map_NS" | "map_d" | "disp" | "decal" | "refl" | "norm" | "map_Pr" | "map_Pm"
            | "Pr" | "Pm" | "Ps" | "Pc" | "Pcr" | "aniso" | "anisor" | "sharpness" => true,
            // opacity other than full and transmission filters other than
            // white would change the surface
            "d" => value != Some(1.0),
            "Tr" => value != Some(0.0),
            "Tf" => rest
                .split_whitespace()
                .take(3)
                .any(|v| v.parse::<f32>().ok() != Some(1.0)),
            _ => false,
        };
        if ignored && !read_past.iter().any(|(k, _)| *k == key) {
            read_past.push((key, n + 1));
        }
        match key {
            "newmtl" if rest.is_empty() => {
                return err("expected a material name after `newmtl`".into());
            }
            "newmtl" => materials.push((rest.to_string(), n + 1)),
            "Ka" | "Kd" | "Ks" | "Ke" | "Tf" => {
                let values: Vec<&str> = rest.split_whitespace().take(3).collect();
                let c: Vec<f32> = values.iter().filter_map(|v| v.parse().ok()).collect();
                if c.len() < 3 {
                    return err(format!(
                        "expected three numbers after `{key}`, got `{}`",
                        values.join(" ")
                    ));
                }
                let c = Vec3::from_slice(&c);
                let what = match key {
                    "Kd" => "a diffuse albedo, each channel in [0, 1]",
                    "Ke" => "an emitted radiance, finite and non-negative",
                    _ => "",
                };
                let bad = !c.is_finite()
                    || c.min_element() < 0.0
                    || (key == "Kd" && c.max_element() > 1.0);
                if !what.is_empty() && bad {
                    return err(format!("{key} {c}: expected {what}"));
                }
            }
            "Ns" | "Ni" | "d" if first.is_none_or(|v| v.parse::<f32>().is_err()) => {
                return err(format!("expected a number after `{key}`"));
            }
            "illum" if first.is_none_or(|v| v.parse::<u8>().is_err()) => {
                return err("expected an illumination model (0 to 255) after `illum`".into());
            }
            "map_Ka" | "map_Kd" | "map_Ks" | "map_Bump" | "map_bump" | "map_Ns" | "map_ns"
            | "map_NS" | "bump" | "map_d"
                if rest.is_empty() =>
            {
                return err(format!("expected a file name after `{key}`"));
            }
            _ => {}
        }
        if !key.is_empty() {
            out.push_str(key);
            out.push(' ');
            out.push_str(rest);
        }
        out.push('\n');
    }
    let warnings = read_past
        .iter()
        .map(|(key, line)| {
            format!(
                "{}: `{key}` is not rendered (read past; materials use Kd, Ks, Ke, Ns, Ni, illum and map_Kd)",
                crate::error::Location {
                    file: lib.to_path_buf(),
                    line: Some(*line),
                }
            )
        })
        .collect();
    Ok(PreparedMtl {
        text: out,
        materials,
        warnings,
    })
}

/// A material library checked and rewritten for tobj.
struct PreparedMtl {
    /// The text tobj parses, line for line the file's.
    text: String,
    /// Each `newmtl` name with its line.
    materials: Vec<(String, usize)>,
    /// One line for each key read past (with its first line).
    warnings: Vec<String>,
}

/// A bare `.obj` as a scene (see [`super::bare_scene`]).
pub fn load_bare(path: &Path) -> Result<Scene> {
    super::bare_scene(path, load_obj_mesh(path)?)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn load(obj: &str, mtl: &str) -> Result<MeshData> {
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(dir.path().join("m.obj"), obj).unwrap();
        std::fs::write(dir.path().join("m.mtl"), mtl).unwrap();
        load_obj_mesh(&dir.path().join("m.obj"))
    }

    #[test]
    fn prepared_text_keeps_lines_and_says_one_thing_per_statement() {
        let text = "# head\r\n  v 1 2 3 # c\nv 2 4 6 2\nv\t1 1 1 0.5 0.5 0.5\nl 1 2 3\np 1\n\
                    usemtl\tred  # x\nf 1 2 3 # tail\ns off\n";
        let p = prepare(Path::new("m.obj"), text, 10).unwrap();
        assert_eq!(
            p.text, "\nv 1 2 3\nv 1 2 3\nv 1 1 1\n\n\nusemtl red\nf 1 2 3\n\n",
            "comments and blanks gone, w applied, colours, lines and points dropped"
        );
        assert_eq!(p.text.lines().count(), text.lines().count());
    }

    #[test]
    fn the_triangle_limit_stops_at_the_face_that_crosses_it() {
        let text = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 2 0\nf 1 2 3 4 5\nf 1 2 3\nf 1 3 4\n";
        // the pentagon makes 3 triangles, then 4, then 5
        assert!(prepare(Path::new("m.obj"), text, 4).is_err_and(|e| {
            e.to_string()
                .starts_with("m.obj:8: this face takes the file past 4 triangles")
        }));
        assert!(prepare(Path::new("m.obj"), text, 5).is_ok());
    }

    #[test]
    fn tobj_reads_what_the_checks_read() {
        let quad = "v 0 0 0\nv 2 0 0 2\nv 1 1 0\nv 0 1 0\n";
        // trailing comments, a tab after usemtl, a leading blank before
        // mtllib: tobj alone failed or lost the material on each
        let m = load(
            &format!(" mtllib m.mtl\n{quad}usemtl\tred\nf 1 2 3 # first\nl 1 2 3\nf 1 3 4\n"),
            "newmtl red # c\nKd 0.5 0 0\n",
        )
        .unwrap();
        assert_eq!(m.indices.len(), 2, "`l` is not a triangle");
        assert_eq!(m.positions[1], DVec3::X, "w divides the vertex");
        assert_eq!(m.materials[0].name, "red");
        assert_eq!(m.materials[0].albedo(), Some(Vec3::new(0.5, 0.0, 0.0)));
        assert_eq!(m.tri_material, [0, 0]);
    }

    #[test]
    fn bad_statements_name_their_line() {
        let v3 = "v 0 0 0\nv 1 0 0\nv 0 1 0\n";
        for (obj, mtl, want) in [
            ("v 0 0 0 0\n", "", "m.obj:1: vertex weight w = `0`"),
            (
                "v 1 0 0 1e-40\n",
                "",
                "m.obj:1: vertex coordinate `1` divided by w",
            ),
            (
                "v 0 0 2e18\n",
                "",
                "m.obj:1: vertex coordinate `2e18` is beyond",
            ),
            ("v 0 0 0 1 1\n", "", "m.obj:1: expected `v x y z`"),
            ("vt 0\n", "", "m.obj:1: expected 2 numbers after `vt`"),
            ("vn 0 x 1\n", "", "m.obj:1: cannot parse normal `x`"),
            ("usemtl\n", "", "m.obj:1: expected a material name"),
            ("mtllib\n", "", "m.obj:1: expected a file name"),
            (
                "o a\nf 1 2 3\ng b\nv 0 0 0\nv 0 0 0\nv 0 0 0\n",
                "",
                "m.obj:2: face vertex index 3",
            ),
            (
                &format!("mtllib m.mtl\n{v3}"),
                "newmtl\n",
                "m.mtl:1: expected a material name",
            ),
            (
                &format!("mtllib m.mtl\n{v3}"),
                "newmtl a\nKe 1 -1 1\n",
                "m.mtl:2: Ke",
            ),
            (
                &format!("mtllib m.mtl\n{v3}"),
                "newmtl a\nNs\n",
                "m.mtl:2: expected a number",
            ),
            (
                &format!("mtllib m.mtl\n{v3}"),
                "newmtl a\nillum 300\n",
                "m.mtl:2: expected an illumination",
            ),
            (
                &format!("mtllib m.mtl\n{v3}"),
                "newmtl a\nmap_Kd\n",
                "m.mtl:2: expected a file name",
            ),
        ] {
            let e = load(obj, mtl).unwrap_err().to_string();
            let at = e.find("m.obj:").or_else(|| e.find("m.mtl:")).unwrap_or(0);
            assert!(e[at..].starts_with(want), "{obj:?} {mtl:?}: {e}");
        }
    }
}
