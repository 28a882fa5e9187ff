//! Wavefront OBJ/MTL meshes through tobj. MTL `Kd` is the diffuse albedo and
//! `Ke` the emitted radiance (an area light, front side only).
//!
//! tobj reports malformed files without line numbers, so a short validating
//! pass runs first: it names the file and line of a non-finite, out-of-range
//! ([`MAX_COORDINATE`]) or unparsable vertex, an out-of-range face index, a
//! face that takes the file past [`MAX_TRIANGLES`], or a missing material
//! library.

use super::limits::{MAX_COORDINATE, MAX_TRIANGLES, MAX_VERTICES};
use super::{Material, MeshData, Scene, SceneBuilder, Transform};
use crate::error::{Error, Result};
use crate::math::Vec3;
use std::path::{Path, PathBuf};

/// Read `path` as one mesh (all its objects merged), with its materials.
pub fn load_obj_mesh(path: &Path) -> Result<MeshData> {
    let text = std::fs::read(path).map_err(|e| Error::io(path, e))?;
    let text = String::from_utf8_lossy(&text);
    let mtllibs = validate(path, &text)?;
    for lib in &mtllibs {
        if !lib.is_file() {
            return Err(Error::input(
                lib,
                None,
                format!(
                    "cannot read material library named by {} (expected a readable .mtl file)",
                    path.display()
                ),
            ));
        }
        validate_mtl(lib)?;
    }
    let options = tobj::LoadOptions {
        triangulate: true,
        single_index: false,
        ignore_points: true,
        ignore_lines: true,
    };
    let (models, materials) = tobj::load_obj(path, &options)
        .map_err(|e| Error::input(path, None, format!("malformed OBJ: {e}")))?;
    let tobj_materials = match materials {
        Ok(m) => m,
        Err(e) if mtllibs.is_empty() => {
            let _ = e;
            Vec::new()
        }
        Err(e) => {
            return Err(Error::input(
                &mtllibs[0],
                None,
                format!("malformed material library: {e}"),
            ));
        }
    };
    let mut mesh = MeshData {
        name: path
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default(),
        ..MeshData::default()
    };
    for m in &tobj_materials {
        mesh.materials.push(convert_material(m, &mtllibs, path)?);
    }
    let default_material = mesh.materials.len() as u32;
    mesh.materials.push(Material::default());
    for model in &models {
        let m = &model.mesh;
        let base = mesh.positions.len() as u32;
        for p in m.positions.chunks_exact(3) {
            mesh.positions.push(Vec3::new(p[0], p[1], p[2]));
        }
        let count = (m.positions.len() / 3) as u32;
        let mat = m
            .material_id
            .filter(|&i| i < tobj_materials.len())
            .map_or(default_material, |i| i as u32);
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
    }
    Ok(mesh)
}

fn convert_material(m: &tobj::Material, libs: &[PathBuf], obj: &Path) -> Result<Material> {
    let file = libs.first().map_or(obj, |p| p.as_path());
    let colour = |name: &str, c: Option<[f32; 3]>, default: Vec3| -> Result<Vec3> {
        let v = c.map_or(default, Vec3::from);
        if !v.is_finite() || v.min_element() < 0.0 {
            return Err(Error::input(
                file,
                None,
                format!(
                    "material `{}`: {name} must be finite and non-negative, got {v}",
                    m.name
                ),
            ));
        }
        Ok(v)
    };
    let albedo = colour("Kd", m.diffuse, Vec3::splat(0.8))?;
    if albedo.max_element() > 1.0 {
        return Err(Error::input(
            file,
            None,
            format!(
                "material `{}`: Kd must be at most 1 (energy conservation), got {albedo}",
                m.name
            ),
        ));
    }
    Ok(Material {
        name: m.name.clone(),
        albedo,
        emission: colour("Ke", m.emissive, Vec3::ZERO)?,
        two_sided: false,
    })
}

/// Check vertex lines and face indices, naming the line of the first problem.
/// Returns the material libraries the file names, resolved next to it.
fn validate(path: &Path, text: &str) -> Result<Vec<PathBuf>> {
    let count = |key: &str| {
        text.lines()
            .filter(|l| l.split_whitespace().next() == Some(key))
            .count() as i64
    };
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
    let mut seen = [0i64; 3];
    // triangles after fan triangulation: a face of n vertices makes n - 2
    let mut triangles = 0u64;
    let mut libs = Vec::new();
    let dir = path.parent().unwrap_or(Path::new(""));
    for (n, line) in text.lines().enumerate() {
        let line_no = Some(n + 1);
        let line = line.split('#').next().unwrap_or("");
        let mut words = line.split_whitespace();
        match words.next() {
            Some("v") => {
                let coords: Vec<&str> = words.collect();
                if coords.len() < 3 {
                    return Err(Error::input(
                        path,
                        line_no,
                        "expected three coordinates after `v`",
                    ));
                }
                for c in &coords[..3] {
                    match c.parse::<f32>() {
                        Ok(x) if x.abs() <= MAX_COORDINATE => {}
                        Ok(x) if x.is_finite() => {
                            return Err(Error::input(
                                path,
                                line_no,
                                format!(
                                    "vertex coordinate `{c}` is beyond +-{MAX_COORDINATE:e} (expected a number within Embree's range)"
                                ),
                            ));
                        }
                        Ok(_) => {
                            return Err(Error::input(
                                path,
                                line_no,
                                format!(
                                    "vertex coordinate `{c}` is not finite (expected a finite number)"
                                ),
                            ));
                        }
                        Err(_) => {
                            return Err(Error::input(
                                path,
                                line_no,
                                format!("cannot parse vertex coordinate `{c}` (expected a number)"),
                            ));
                        }
                    }
                }
                seen[0] += 1;
            }
            Some("vt") => seen[1] += 1,
            Some("vn") => seen[2] += 1,
            Some("f") => {
                let verts: Vec<&str> = words.collect();
                if verts.len() < 3 {
                    return Err(Error::input(
                        path,
                        line_no,
                        "a face needs at least three vertices",
                    ));
                }
                triangles += verts.len() as u64 - 2;
                if triangles > MAX_TRIANGLES {
                    return Err(Error::input(
                        path,
                        line_no,
                        format!(
                            "this face takes the file past {MAX_TRIANGLES} triangles (the scene limit)"
                        ),
                    ));
                }
                for v in verts {
                    let parts: Vec<&str> = v.split('/').collect();
                    if parts.len() > 3 || parts[0].is_empty() {
                        return Err(Error::input(
                            path,
                            line_no,
                            format!(
                                "cannot parse face vertex `{v}` (expected v, v/vt, v//vn or v/vt/vn)"
                            ),
                        ));
                    }
                    const KIND: [&str; 3] = ["vertex", "texture coordinate", "normal"];
                    for (k, part) in parts.iter().enumerate() {
                        if part.is_empty() {
                            continue;
                        }
                        let Ok(i) = part.parse::<i64>() else {
                            return Err(Error::input(
                                path,
                                line_no,
                                format!("cannot parse face vertex `{v}` (expected an index)"),
                            ));
                        };
                        let ok = if i > 0 {
                            i <= total[k]
                        } else {
                            i < 0 && seen[k] + i >= 0
                        };
                        if !ok {
                            return Err(Error::input(
                                path,
                                line_no,
                                format!(
                                    "face {} index {i} out of range (the file has {} of them)",
                                    KIND[k], total[k]
                                ),
                            ));
                        }
                    }
                }
            }
            Some("mtllib") => {
                let rest = line.trim_start()["mtllib".len()..].trim();
                if !rest.is_empty() {
                    libs.push(dir.join(rest));
                }
            }
            _ => {}
        }
    }
    Ok(libs)
}

/// Check the colour lines of a material library before tobj reads it:
/// tobj 4.0 panics on a `Kd`, `Ka`, `Ks`, `Ke` or `Tf` line with fewer than
/// three values (found by `tests/fuzz_loaders.rs`), so those get a clear
/// error with the line instead.
fn validate_mtl(lib: &Path) -> Result<()> {
    let bytes = std::fs::read(lib).map_err(|e| Error::io(lib, e))?;
    let text = String::from_utf8_lossy(&bytes);
    for (n, line) in text.lines().enumerate() {
        let line = line.split('#').next().unwrap_or("");
        let mut words = line.split_whitespace();
        if let Some(key @ ("Ka" | "Kd" | "Ks" | "Ke" | "Tf")) = words.next() {
            let values: Vec<&str> = words.take(3).collect();
            if values.len() < 3 || values.iter().any(|v| v.parse::<f32>().is_err()) {
                return Err(Error::input(
                    lib,
                    Some(n + 1),
                    format!(
                        "expected three numbers after `{key}`, got `{}`",
                        values.join(" ")
                    ),
                ));
            }
        }
    }
    Ok(())
}

/// A bare `.obj` as a scene: framed from its bounds, lit by a uniform white
/// environment when it has no emitters.
pub fn load_bare(path: &Path) -> Result<Scene> {
    let mesh = load_obj_mesh(path)?;
    let mut b = SceneBuilder::new(path);
    b.add_mesh_from(mesh, &Transform::default(), None)?;
    let mut scene = b.build();
    scene.camera = Scene::framing_camera(&scene.bounds());
    scene
        .notes
        .push("camera framed automatically from the mesh bounds".to_string());
    if !scene.has_emitters() {
        scene.environment = Some(Vec3::ONE);
        scene.notes.push(
            "no emitters in the mesh: lighting it with a uniform white environment".to_string(),
        );
    }
    Ok(scene)
}
