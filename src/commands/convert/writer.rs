//! `embertrace convert IN OUT.toml`: any scene the renderer reads, written as
//! the project's own TOML with its meshes and images beside it, so a user
//! can read and edit it and render it to the same image.
//!
//! What is written, next to `OUT.toml` (named after its stem):
//!
//! - one OBJ per run of consecutive triangles sharing a material
//!   (`STEM-mesh-K.obj`), in the scene's triangle order, so every triangle
//!   keeps its primitive number; positions, texture coordinates and vertex
//!   normals are printed in Rust's shortest form that reads back to the same
//!   `f32`, and each mesh's material goes inline into its `[[mesh]]` table;
//! - each texture and the environment map as a linear OpenEXR file
//!   (`STEM-texture-K.exr`, `STEM-environment.exr`) holding the texels the
//!   renderer uses, decoded already (an sRGB PNG becomes its linear values);
//! - spheres, point, directional and environment lights, camera and lens,
//!   film and render defaults as TOML keys.
//!
//! Nothing is written if any of these files would overwrite one the scene
//! was read from (the scene file, a texture, the environment map): a
//! conversion onto its own input is refused before it begins.
//!
//! The converted scene renders to the same image bits as the original
//! (tested on the bundled scenes); the one exception is smooth shading,
//! whose vertex normals are normalised again on loading, which may move them
//! by an ulp.

use crate::bsdf::{Bsdf, Distribution, Lobe};
use crate::error::{Error, Result};
use crate::image::{self, OutputOptions};
use crate::math::Vec3;
use crate::scene::{Material, Scene};
use crate::settings::{DirectStrategy, Roulette};
use crate::texture::ImageTexture;
use std::fmt::Write;
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// A number as TOML reads it back to the same `f32`.
fn num(x: f32) -> String {
    let s = format!("{x:?}");
    if s.contains(['.', 'e', 'E']) || s.contains("inf") || s.contains("NaN") {
        s
    } else {
        format!("{s}.0")
    }
}

fn rgb(v: Vec3) -> String {
    format!("[{}, {}, {}]", num(v.x), num(v.y), num(v.z))
}

/// A render-space point of `scene` as the world point it stands for: itself
/// when the scene was not rebased, else plus [`Scene::world_origin`], in
/// f64 and printed to read back to the same f64 (the sum is exact: the
/// origin lies on a coarse power-of-two grid).
fn world(scene: &Scene, p: Vec3) -> String {
    let o = scene.world_origin;
    if o == crate::math::DVec3::ZERO {
        return rgb(p);
    }
    let w = p.as_dvec3() + o;
    format!("[{:?}, {:?}, {:?}]", w.x, w.y, w.z)
}

/// Write `tex` as a linear EXR at `path`.
fn write_texture(path: &Path, tex: &ImageTexture) -> Result<()> {
    let mut rgb = Vec::with_capacity(tex.width() as usize * tex.height() as usize);
    for y in 0..tex.height() {
        for x in 0..tex.width() {
            rgb.push(tex.texel(x, y).to_array().map(f64::from));
        }
    }
    image::write_rgb(
        path,
        tex.width(),
        tex.height(),
        &rgb,
        &OutputOptions::default(),
    )
}

/// The files a conversion writes, in the order written (the TOML last).
#[derive(Debug, Default)]
pub struct Written {
    /// Every file, the TOML last.
    pub files: Vec<PathBuf>,
}

struct Writer<'a> {
    dir: &'a Path,
    stem: String,
    written: Written,
    /// Textures written so far (by identity), with their file names.
    textures: Vec<(Arc<ImageTexture>, String)>,
}

impl Writer<'_> {
    fn file(&mut self, name: &str) -> PathBuf {
        let p = self.dir.join(name);
        self.written.files.push(p.clone());
        p
    }

    fn texture(&mut self, tex: &Arc<ImageTexture>) -> Result<String> {
        if let Some((_, name)) = self.textures.iter().find(|(t, _)| Arc::ptr_eq(t, tex)) {
            return Ok(name.clone());
        }
        let name = format!("{}-texture-{}.exr", self.stem, self.textures.len());
        let path = self.file(&name);
        write_texture(&path, tex)?;
        self.textures.push((tex.clone(), name.clone()));
        Ok(name)
    }

    /// The inline `material = {...}` of `m`.
    fn material(&mut self, m: &Material) -> Result<String> {
        let mut keys = Vec::new();
        match &m.bsdf {
            Bsdf::Diffuse(d) => {
                keys.push("type = \"diffuse\"".to_string());
                keys.push(format!("diffuse = {}", rgb(d.albedo)));
            }
            Bsdf::Mirror(r) => {
                keys.push("type = \"mirror\"".to_string());
                keys.push(format!("reflectance = {}", rgb(r.reflectance)));
            }
            Bsdf::Glass(g) => {
                keys.push("type = \"glass\"".to_string());
                keys.push(format!("ior = {}", num(g.ior)));
                keys.push(format!("reflectance = {}", rgb(g.reflectance)));
                keys.push(format!("transmittance = {}", rgb(g.transmittance)));
            }
            Bsdf::Conductor(c) => {
                keys.push("type = \"conductor\"".to_string());
                keys.push(format!("alpha = {}", num(c.microfacet.alpha)));
                keys.push(format!("eta = {}", rgb(c.eta)));
                keys.push(format!("k = {}", rgb(c.k)));
                keys.push(distribution(c.microfacet.distribution));
            }
            Bsdf::Plastic(p) => {
                keys.push("type = \"plastic\"".to_string());
                keys.push(format!("diffuse = {}", rgb(p.diffuse())));
                keys.push(format!("ior = {}", num(p.ior())));
                keys.push(format!("alpha = {}", num(p.microfacet().alpha)));
                keys.push(distribution(p.microfacet().distribution));
                keys.push(format!("nonlinear = {}", p.nonlinear()));
            }
            Bsdf::Phong(p) => {
                keys.push("type = \"phong\"".to_string());
                keys.push(format!("diffuse = {}", rgb(p.diffuse)));
                keys.push(format!("specular = {}", rgb(p.specular)));
                keys.push(match p.lobe {
                    Lobe::Phong { shininess } => format!("shininess = {}", num(shininess)),
                    Lobe::Ggx { roughness } => format!("roughness = {}", num(roughness)),
                });
            }
        }
        // every texture in [`material_textures`]' order (planned_files')
        let mut names = Vec::new();
        for t in material_textures(m) {
            names.push(self.texture(t)?);
        }
        let mut names = names.into_iter();
        let mut next = || names.next().expect("one name per texture");
        for (key, _) in m.textured() {
            let name = next();
            if key == "texture" {
                keys.push(format!("texture = \"{name}\""));
            } else {
                // the texture replaces the constant (an emission's mean, a
                // roughness's minimum)
                let prefix = format!("{key} = ");
                keys.retain(|k| !k.starts_with(&prefix));
                keys.push(format!("{key} = {{ texture = \"{name}\" }}"));
            }
        }
        if m.maps.normal.is_some() {
            keys.push(format!("normal_map = \"{}\"", next()));
        }
        if let Some(b) = &m.maps.bump {
            keys.push(format!("bump_map = \"{}\"", next()));
            keys.push(format!("bump_scale = {}", num(b.scale)));
        }
        if m.emission != Vec3::ZERO && m.maps.emission.is_none() {
            keys.push(format!("emission = {}", rgb(m.emission)));
        }
        if m.two_sided {
            keys.push("two_sided = true".to_string());
        }
        Ok(format!("{{ {} }}", keys.join(", ")))
    }

    /// Triangles `range` as an OBJ file; returns its name.
    fn mesh(&mut self, scene: &Scene, range: std::ops::Range<usize>, k: usize) -> Result<String> {
        let name = format!("{}-mesh-{k}.obj", self.stem);
        let mut text = format!(
            "# {} triangles of {}, written by embertrace convert\n",
            range.len(),
            scene.source.display()
        );
        let uv = !scene.tri_uv.is_empty();
        // flat triangles keep zero normals in the scene: a mesh of only
        // those needs no `vn` lines
        let smooth = |t: usize| {
            !scene.tri_shading_normals.is_empty()
                && scene.tri_shading_normals[t]
                    .iter()
                    .all(|n| *n != Vec3::ZERO)
        };
        let vn = range.clone().any(smooth);
        for t in range.clone() {
            for p in scene.triangle(t as u32) {
                let _ = writeln!(text, "v {} {} {}", num(p.x), num(p.y), num(p.z));
            }
            if uv {
                for c in scene.tri_uv[t] {
                    let _ = writeln!(text, "vt {} {}", num(c.x), num(c.y));
                }
            }
            if vn {
                for c in scene.tri_shading_normals[t] {
                    let _ = writeln!(text, "vn {} {} {}", num(c.x), num(c.y), num(c.z));
                }
            }
        }
        for (j, t) in range.enumerate() {
            let corner = |c: usize| {
                let i = 3 * j + c + 1;
                match (uv, smooth(t)) {
                    (true, true) => format!("{i}/{i}/{i}"),
                    (true, false) => format!("{i}/{i}"),
                    (false, true) => format!("{i}//{i}"),
                    (false, false) => i.to_string(),
                }
            };
            let _ = writeln!(text, "f {} {} {}", corner(0), corner(1), corner(2));
        }
        let path = self.file(&name);
        image::write_file_atomically(&path, text.as_bytes())?;
        Ok(name)
    }
}

/// The textures of `m` in the order [`convert`] writes them: the textured
/// parameters ([`Material::textured`]), then the normal or bump map. (Each
/// is written as linear EXR, which every key reads as it is, so `raw` is
/// never needed.)
fn material_textures(m: &Material) -> Vec<&Arc<ImageTexture>> {
    let mut v: Vec<&Arc<ImageTexture>> = m.textured().into_iter().map(|(_, t)| t).collect();
    v.extend(m.maps.normal.as_ref());
    v.extend(m.maps.bump.as_ref().map(|b| &b.texture));
    v
}

/// The files [`convert`] writes for `scene` at `out` (in `dir`, named after
/// `stem`), in the order written: a mesh per run of triangles with one
/// material, each distinct texture, the environment map, the TOML.
fn planned_files(scene: &Scene, out: &Path, dir: &Path, stem: &str) -> Vec<PathBuf> {
    let mut files = Vec::new();
    let mut textures: Vec<Arc<ImageTexture>> = Vec::new();
    let mut texture = |m: &Material, files: &mut Vec<PathBuf>| {
        for t in material_textures(m) {
            if !textures.iter().any(|u| Arc::ptr_eq(u, t)) {
                files.push(dir.join(format!("{stem}-texture-{}.exr", textures.len())));
                textures.push(t.clone());
            }
        }
    };
    let n = scene.triangle_count();
    let (mut start, mut k) = (0, 0);
    while start < n {
        let mat = scene.tri_material[start];
        let mut end = start + 1;
        while end < n && scene.tri_material[end] == mat {
            end += 1;
        }
        files.push(dir.join(format!("{stem}-mesh-{k}.obj")));
        texture(&scene.materials[mat as usize], &mut files);
        start = end;
        k += 1;
    }
    for &m in &scene.sphere_material {
        texture(&scene.materials[m as usize], &mut files);
    }
    if scene.environment_map.is_some() {
        files.push(dir.join(format!("{stem}-environment.exr")));
    }
    files.push(out.to_path_buf());
    files
}

/// Convert `scene` to a TOML scene at `out` (which must end in `.toml`),
/// writing its meshes and images beside it.
pub fn convert(scene: &Scene, out: &Path) -> Result<Written> {
    if out.extension().and_then(|e| e.to_str()) != Some("toml") {
        return Err(Error::Settings(format!(
            "{}: the converted scene must be a .toml file",
            out.display()
        )));
    }
    let dir = match out.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    if !dir.is_dir() {
        return Err(Error::Settings(format!(
            "{}: the folder {} does not exist",
            out.display(),
            dir.display()
        )));
    }
    let stem = out
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "scene".to_string());
    let inputs = crate::outputs::Inputs::of_scene(scene);
    for f in planned_files(scene, out, dir, &stem) {
        let label = if f == out {
            f.display().to_string()
        } else {
            format!("{} (written beside {})", f.display(), out.display())
        };
        inputs.check_output(&label, &f)?;
    }
    let mut w = Writer {
        dir,
        stem,
        written: Written::default(),
        textures: Vec::new(),
    };
    let mut t = format!(
        "# Converted from {} by embertrace convert.\n\n",
        scene.source.display()
    );
    let c = &scene.camera;
    let _ = writeln!(t, "[camera]");
    let _ = writeln!(t, "origin = {}", world(scene, c.origin));
    let _ = writeln!(t, "target = {}", world(scene, c.target));
    let _ = writeln!(t, "up = {}", rgb(c.up));
    match scene.focal_pixels {
        Some(f) => {
            let _ = writeln!(t, "focal_pixels = {}", num(f));
        }
        None => {
            let _ = writeln!(t, "fov_y = {}", num(c.fov_y));
        }
    }
    if !scene.lens.is_pinhole() {
        let _ = writeln!(t, "aperture_radius = {}", num(scene.lens.aperture_radius));
        let _ = writeln!(t, "focus_distance = {}", num(scene.lens.focus_distance));
    }
    let [rw, rh] = scene.resolution;
    let r = &scene.render;
    let _ = write!(
        t,
        "\n[film]\nresolution = [{rw}, {rh}]\n\n[render]\nspp = {}\nmax_depth = {}\nlight_samples = {}\nseed = {}\nrr_depth = {}\n",
        r.spp, r.max_depth, r.light_samples, r.seed, r.rr_depth
    );
    if r.direct != DirectStrategy::Mis {
        let _ = writeln!(t, "direct = \"{}\"", r.direct);
    }
    if let Roulette::Fixed(p) = r.roulette {
        let _ = writeln!(t, "rr = {}", num(p));
    }
    // meshes: runs of consecutive triangles with one material
    let n = scene.triangle_count();
    let mut start = 0;
    let mut k = 0;
    while start < n {
        let mat = scene.tri_material[start];
        let mut end = start + 1;
        while end < n && scene.tri_material[end] == mat {
            end += 1;
        }
        let file = w.mesh(scene, start..end, k)?;
        let material = w.material(&scene.materials[mat as usize])?;
        let _ = write!(t, "\n[[mesh]]\nfile = \"{file}\"\nmaterial = {material}\n");
        if scene.world_origin != crate::math::DVec3::ZERO {
            // the OBJ holds render-space positions; this puts them back
            let _ = writeln!(
                t,
                "transform = {{ translate = {} }}",
                world(scene, Vec3::ZERO)
            );
        }
        start = end;
        k += 1;
    }
    for (s, &m) in scene.spheres.iter().zip(&scene.sphere_material) {
        let material = w.material(&scene.materials[m as usize])?;
        let _ = write!(
            t,
            "\n[[sphere]]\ncenter = {}\nradius = {}\nmaterial = {material}\n",
            world(scene, s.center),
            num(s.radius)
        );
    }
    for p in &scene.point_lights {
        let _ = write!(
            t,
            "\n[[light]]\ntype = \"point\"\nposition = {}\nintensity = {}\n",
            world(scene, p.position),
            rgb(p.intensity)
        );
        if p.attenuation != crate::light::point::PHYSICAL {
            let _ = writeln!(t, "attenuation = {}", rgb(Vec3::from(p.attenuation)));
        }
    }
    for d in &scene.directional_lights {
        let _ = write!(
            t,
            "\n[[light]]\ntype = \"directional\"\ndirection = {}\nirradiance = {}\n",
            rgb(d.direction()),
            rgb(d.irradiance())
        );
    }
    if let Some(e) = scene.environment {
        let _ = write!(
            t,
            "\n[[light]]\ntype = \"environment\"\nradiance = {}\n",
            rgb(e)
        );
    }
    if let Some(map) = &scene.environment_map {
        let name = format!("{}-environment.exr", w.stem);
        let path = w.file(&name);
        write_texture(&path, map.map())?;
        let _ = write!(
            t,
            "\n[[light]]\ntype = \"environment\"\nfile = \"{name}\"\nradiance = {}\n",
            rgb(map.radiance())
        );
    }
    w.written.files.push(out.to_path_buf());
    image::write_file_atomically(out, t.as_bytes())?;
    Ok(w.written)
}

/// The `distribution = "..."` key.
fn distribution(d: Distribution) -> String {
    let name = match d {
        Distribution::Ggx => "ggx",
        Distribution::Beckmann => "beckmann",
    };
    format!("distribution = \"{name}\"")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_files_checked_before_writing_are_the_files_written() {
        let dir = tempfile::tempdir().unwrap();
        let scenes = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes");
        for name in ["materials.toml", "cornell-spheres.toml"] {
            let scene = Scene::load(&scenes.join(name)).unwrap();
            let out = dir.path().join(name);
            let planned = planned_files(&scene, &out, dir.path(), name.trim_end_matches(".toml"));
            assert_eq!(convert(&scene, &out).unwrap().files, planned, "{name}");
        }
    }
}
