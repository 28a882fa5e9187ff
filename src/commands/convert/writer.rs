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
//! - one OBJ per run of one material of each instanced prototype
//!   (`STEM-prototype-P-K.obj`, object space), a named `instance_only`
//!   `[[mesh]]` each, and an `[[instance]]` per placement and run with the
//!   placement's exact `f64` matrix: instances stay instances;
//! - spheres, point, spot, directional and environment lights, camera and lens,
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

use crate::bsdf::{Bsdf, Distribution, Lobe, Masking};
use crate::error::{Error, Result};
use crate::image::{self, OutputOptions};
use crate::math::{Vec2, Vec3};
use crate::scene::{AlphaMask, EmissionRole, Material, NO_OVERRIDE, Scene};
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

    /// The inline `material = {...}` of `m`, and the mesh's `alpha` key
    /// line when it has a mask (empty otherwise): an opacity texture is
    /// written as the linear values it was read to, which `alpha = "f.exr"`
    /// reads back as they are.
    fn material(&mut self, m: &Material) -> Result<(String, String)> {
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
            Bsdf::RoughGlass(g) => {
                keys.push("type = \"rough_glass\"".to_string());
                keys.push(format!("ior = {}", num(g.ior)));
                keys.push(format!("alpha = {}", num(g.alpha)));
                keys.push(format!("reflectance = {}", rgb(g.reflectance)));
                keys.push(format!("transmittance = {}", rgb(g.transmittance)));
            }
            Bsdf::ThinGlass(g) => {
                keys.push("type = \"thin_glass\"".to_string());
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
                keys.extend(masking(c.microfacet.masking));
            }
            Bsdf::Plastic(p) => {
                keys.push("type = \"plastic\"".to_string());
                keys.push(format!("diffuse = {}", rgb(p.diffuse())));
                keys.push(format!("ior = {}", num(p.ior())));
                keys.push(format!("alpha = {}", num(p.microfacet().alpha)));
                keys.push(distribution(p.microfacet().distribution));
                keys.extend(masking(p.microfacet().masking));
                keys.push(format!("nonlinear = {}", p.nonlinear()));
            }
            Bsdf::MetallicRoughness(p) => {
                keys.push("type = \"metallic_roughness\"".to_string());
                keys.push(format!("base_color = {}", rgb(p.base_color)));
                keys.push(format!("metallic = {}", num(p.metallic)));
                keys.push(format!("roughness = {}", num(p.roughness)));
                keys.push(format!("specular = {}", num(p.specular)));
                keys.push(format!("specular_color = {}", rgb(p.specular_color)));
                keys.push(format!("ior = {}", num(p.ior)));
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
        if m.one_sided {
            keys.push("one_sided = true".to_string());
        }
        if m.maps.perturbs_normal() {
            keys.push(format!("flip_invalid_normals = {}", m.maps.flip_invalid));
            keys.push(format!("use_shadowing_function = {}", m.maps.shadowing));
        }
        if m.role == EmissionRole::SeenOnly {
            keys.push("emission_role = \"seen_only\"".to_string());
        }
        let alpha = match &m.alpha_mask {
            None => String::new(),
            Some(AlphaMask::Constant(a)) => format!("alpha = {}\n", num(*a)),
            Some(AlphaMask::Texture(_)) => format!("alpha = \"{}\"\n", next()),
        };
        Ok((format!("{{ {} }}", keys.join(", ")), alpha))
    }

    /// Triangles `range` as an OBJ file; returns its name.
    fn mesh(&mut self, scene: &Scene, range: std::ops::Range<usize>, k: usize) -> Result<String> {
        let name = format!("{}-mesh-{k}.obj", self.stem);
        let corners: Vec<[Vec3; 3]> = range.clone().map(|t| scene.triangle(t as u32)).collect();
        let uvs = scene.tri_uv.get(range.clone()).unwrap_or(&[]);
        let normals = scene.tri_shading_normals.get(range).unwrap_or(&[]);
        let what = format!("triangles of {}", scene.source.display());
        self.obj(&name, &what, &corners, uvs, normals)?;
        Ok(name)
    }

    /// Triangles `range` of prototype `p` (object space) as an OBJ file;
    /// returns its name.
    fn prototype(
        &mut self,
        scene: &Scene,
        p: usize,
        range: std::ops::Range<usize>,
        k: usize,
    ) -> Result<String> {
        let name = format!("{}-prototype-{p}-{k}.obj", self.stem);
        let inst = &scene.instances;
        let proto = &inst.prototypes[p];
        let sh = &inst.shading[p];
        let corners: Vec<[Vec3; 3]> = range.clone().map(|t| proto.triangle(t as u32)).collect();
        let uvs = sh.tri_uv.get(range.clone()).unwrap_or(&[]);
        let normals = sh.tri_shading_normals.get(range).unwrap_or(&[]);
        let what = format!(
            "triangles of prototype `{}` of {} (object space)",
            crate::error::one_line(&sh.name),
            scene.source.display()
        );
        self.obj(&name, &what, &corners, uvs, normals)?;
        Ok(name)
    }

    /// Write an OBJ file `name` of triangles with `corners`, and per corner
    /// texture coordinates `uvs` and vertex normals `normals` (each empty,
    /// or one entry per triangle; a triangle with a zero normal is flat).
    fn obj(
        &mut self,
        name: &str,
        what: &str,
        corners: &[[Vec3; 3]],
        uvs: &[[Vec2; 3]],
        normals: &[[Vec3; 3]],
    ) -> Result<()> {
        let mut text = format!(
            "# {} {what}, written by embertrace convert\n",
            corners.len()
        );
        let uv = !uvs.is_empty();
        // flat triangles keep zero normals in the scene: a mesh of only
        // those needs no `vn` lines
        let smooth = |t: usize| {
            normals
                .get(t)
                .is_some_and(|c| c.iter().all(|n| *n != Vec3::ZERO))
        };
        let vn = (0..corners.len()).any(smooth);
        for (t, tri) in corners.iter().enumerate() {
            for p in tri {
                let _ = writeln!(text, "v {} {} {}", num(p.x), num(p.y), num(p.z));
            }
            if uv {
                for c in uvs[t] {
                    let _ = writeln!(text, "vt {} {}", num(c.x), num(c.y));
                }
            }
            if vn {
                for c in normals[t] {
                    let _ = writeln!(text, "vn {} {} {}", num(c.x), num(c.y), num(c.z));
                }
            }
        }
        for t in 0..corners.len() {
            let corner = |c: usize| {
                let i = 3 * t + c + 1;
                match (uv, smooth(t)) {
                    (true, true) => format!("{i}/{i}/{i}"),
                    (true, false) => format!("{i}/{i}"),
                    (false, true) => format!("{i}//{i}"),
                    (false, false) => i.to_string(),
                }
            };
            let _ = writeln!(text, "f {} {} {}", corner(0), corner(1), corner(2));
        }
        let path = self.file(name);
        image::write_file_atomically(&path, text.as_bytes())
    }
}

/// Runs of consecutive equal entries of `materials`: `(start..end,
/// material)`, in order.
fn runs(materials: &[u32]) -> Vec<(std::ops::Range<usize>, u32)> {
    let mut out = Vec::new();
    let mut start = 0;
    while start < materials.len() {
        let mat = materials[start];
        let mut end = start + 1;
        while end < materials.len() && materials[end] == mat {
            end += 1;
        }
        out.push((start..end, mat));
        start = end;
    }
    out
}

/// The textures of `m` in the order [`convert`] writes them: the textured
/// parameters ([`Material::textured`]), then the normal or bump map. (Each
/// is written as linear EXR, which every key reads as it is, so `raw` is
/// never needed.)
fn material_textures(m: &Material) -> Vec<&Arc<ImageTexture>> {
    let mut v: Vec<&Arc<ImageTexture>> = m.textured().into_iter().map(|(_, t)| t).collect();
    v.extend(m.maps.normal.as_ref());
    v.extend(m.maps.bump.as_ref().map(|b| &b.texture));
    if let Some(AlphaMask::Texture(t)) = &m.alpha_mask {
        v.push(t);
    }
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
    for (k, (_, mat)) in runs(&scene.tri_material).into_iter().enumerate() {
        files.push(dir.join(format!("{stem}-mesh-{k}.obj")));
        texture(&scene.materials[mat as usize], &mut files);
    }
    for &m in &scene.sphere_material {
        texture(&scene.materials[m as usize], &mut files);
    }
    let inst = &scene.instances;
    for (p, sh) in inst.shading.iter().enumerate() {
        for (k, (_, mat)) in runs(&sh.tri_material).into_iter().enumerate() {
            files.push(dir.join(format!("{stem}-prototype-{p}-{k}.obj")));
            texture(&scene.materials[mat as usize], &mut files);
        }
    }
    for &m in inst.material.iter().filter(|&&m| m != NO_OVERRIDE) {
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
    for (k, (range, mat)) in runs(&scene.tri_material).into_iter().enumerate() {
        let file = w.mesh(scene, range, k)?;
        let (material, alpha) = w.material(&scene.materials[mat as usize])?;
        let _ = write!(
            t,
            "\n[[mesh]]\nfile = \"{file}\"\nmaterial = {material}\n{alpha}"
        );
        if scene.world_origin != crate::math::DVec3::ZERO {
            // the OBJ holds render-space positions; this puts them back
            let _ = writeln!(
                t,
                "transform = {{ translate = {} }}",
                world(scene, Vec3::ZERO)
            );
        }
    }
    instances(&mut w, scene, &mut t)?;
    for (i, (s, &m)) in scene.spheres.iter().zip(&scene.sphere_material).enumerate() {
        // spheres have no masks (the loaders refuse them)
        let (material, _) = w.material(&scene.materials[m as usize])?;
        let _ = write!(
            t,
            "\n[[sphere]]\ncenter = {}\nradius = {}\nmaterial = {material}\n",
            world(scene, s.center),
            num(s.radius)
        );
        if let Some(f) = scene.sphere_uv_frames.get(i) {
            let rows: Vec<String> = (0..3).flat_map(|r| f.row(r).to_array()).map(num).collect();
            let _ = writeln!(t, "uv_frame = [{}]", rows.join(", "));
        }
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
    for l in &scene.spot_lights {
        let _ = write!(
            t,
            "\n[[light]]\ntype = \"spot\"\nposition = {}\ndirection = {}\nintensity = {}\ncutoff_angle = {}\nbeam_width = {}\n",
            world(scene, l.position),
            rgb(l.direction()),
            rgb(l.intensity),
            num(l.cutoff_angle()),
            num(l.beam_width())
        );
        match l.falloff_kind() {
            crate::light::Falloff::Linear => {}
            crate::light::Falloff::Smooth => {
                let _ = writeln!(t, "falloff = \"smooth\"");
            }
            crate::light::Falloff::SmoothStep => {
                let _ = writeln!(t, "falloff = \"smoothstep\"");
            }
        }
    }
    for l in &scene.panel_lights {
        let _ = write!(
            t,
            "\n[[light]]\ntype = \"panel\"\ncenter = {}\ndim_x = {}\ndim_y = {}\nfacing = {}\nradiance = {}\n",
            world(scene, l.center),
            rgb(l.dim_x),
            rgb(l.dim_y),
            rgb(l.facing),
            rgb(l.radiance)
        );
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

/// The prototypes (a named, `instance_only` mesh per run of one material,
/// in object space) and their placements (an `[[instance]]` of each run,
/// by its exact `f64` object-to-world matrix, with the material override).
/// A prototype of one material keeps every primitive number; one of
/// several is placed run by run, which renumbers its triangles (the same
/// image, not the same bits).
fn instances(w: &mut Writer, scene: &Scene, t: &mut String) -> Result<()> {
    let inst = &scene.instances;
    let mut names: Vec<Vec<String>> = Vec::new();
    for (p, sh) in inst.shading.iter().enumerate() {
        let mut runs_of = Vec::new();
        for (k, (range, mat)) in runs(&sh.tri_material).into_iter().enumerate() {
            let file = w.prototype(scene, p, range, k)?;
            let (material, alpha) = w.material(&scene.materials[mat as usize])?;
            let name = format!("prototype{p}-{k}");
            let _ = write!(
                t,
                "\n# prototype {p}: `{}`\n[[mesh]]\nfile = \"{file}\"\nname = \"{name}\"\ninstance_only = true\nmaterial = {material}\n{alpha}",
                crate::error::one_line(&sh.name)
            );
            runs_of.push(name);
        }
        names.push(runs_of);
    }
    for (k, placement) in inst.placements.iter().enumerate() {
        let m = inst.world[k];
        let (l, c) = (m.matrix3, m.translation);
        let rows = [
            [l.x_axis.x, l.y_axis.x, l.z_axis.x, c.x],
            [l.x_axis.y, l.y_axis.y, l.z_axis.y, c.y],
            [l.x_axis.z, l.y_axis.z, l.z_axis.z, c.z],
        ];
        let matrix = rows
            .iter()
            .flatten()
            .map(|x| format!("{x:?}"))
            .chain(["0.0", "0.0", "0.0", "1.0"].map(String::from))
            .collect::<Vec<_>>()
            .join(", ");
        let material = match inst.material[k] {
            NO_OVERRIDE => None,
            // the override's mask is the prototype's (it keeps it on load)
            m => Some(w.material(&scene.materials[m as usize])?.0),
        };
        for name in &names[placement.prototype as usize] {
            let _ = write!(t, "\n[[instance]]\nof = \"{name}\"\nmatrix = [{matrix}]\n");
            if let Some(material) = &material {
                let _ = writeln!(t, "material = {material}");
            }
        }
    }
    Ok(())
}

/// The `distribution = "..."` key.
fn distribution(d: Distribution) -> String {
    let name = match d {
        Distribution::Ggx => "ggx",
        Distribution::Beckmann => "beckmann",
    };
    format!("distribution = \"{name}\"")
}

/// The `masking = "..."` key, where it is not the default.
fn masking(m: Masking) -> Option<String> {
    (m != Masking::default()).then(|| format!("masking = \"{}\"", m.name()))
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
