//! pbrt-v4 scenes (`.pbrt`): the subset the pbrt-v4-scenes and Bitterli
//! collections use most.
//!
//! - Transforms: `Identity`, `Translate`, `Scale`, `Rotate`, `LookAt`,
//!   `Transform`, `ConcatTransform`, `CoordinateSystem`,
//!   `CoordSysTransform` (with `"camera"` and `"world"`), `AttributeBegin`
//!   and `AttributeEnd` (and the older `TransformBegin`/`End`),
//!   `ReverseOrientation`; `Include` and `Import` (read in place).
//! - `Camera "perspective"` (`fov` for the image's shorter axis,
//!   `lensradius`, `focaldistance`), `Film` (`xresolution`,
//!   `yresolution`), `Sampler` (`pixelsamples`), `Integrator` (`maxdepth`,
//!   the same count of bounces as ours).
//! - `Shape`: `trianglemesh`, `plymesh`, `sphere`, `bilinearmesh` (each
//!   patch as two triangles: exact for planar patches, the common case);
//!   `ObjectBegin`/`ObjectEnd`/`ObjectInstance` as instances.
//! - `Material`, `MakeNamedMaterial`, `NamedMaterial`: `diffuse`,
//!   `conductor` (pbrt's named metal spectra through Mitsuba's RGB values
//!   for the same metals, an RGB `eta`/`k`, or `reflectance`), `dielectric`
//!   (rough or smooth), `thindielectric` ([`crate::bsdf::ThinGlass`]), `coateddiffuse` (our rough plastic: a diffuse base under a
//!   GGX dielectric coat; pbrt's stochastic layers with `thickness` and
//!   `albedo` are not reproduced); `Texture "imagemap"` for a reflectance.
//! - Lights: `AreaLightSource "diffuse"` (`L`, `twosided`, `scale`),
//!   `LightSource` `point`, `spot` (pbrt's smoothstep falloff), `distant`,
//!   `infinite` (constant `L`, or an image: pbrt-v4's equal-area
//!   octahedral map, resampled to an equirectangular one). RGB spectra are taken as RGB (pbrt-v4
//!   normalises an RGB illuminant's spectrum so that it renders as the
//!   RGB it was given); `blackbody` is rendered white with a warning.
//!
//! **Handedness.** pbrt's camera looks down its `+z` with `+x` to the
//! image's right and `+y` up: the image's right is the camera's `+x` in
//! the world, which is `up x view` when the camera's transform keeps
//! handedness (`LookAt` alone), and `view x up` when it mirrors (the `Scale
//! -1 1 1` that exporters put before `LookAt`). Ours is always `view x up`.
//! So when the camera's transform keeps handedness, the loader mirrors the
//! whole world (every placement, light and the camera composed with `x ->
//! -x`): a reflection of world and camera together turns `view x up` into
//! the mirror image of `up x view`, and the builder keeps each surface's
//! front where its normal says through the mirror. `tests/pbrt.rs` renders
//! an asymmetric scene each way to show the image is pbrt's.
//!
//! Anything else (other shapes, materials, textures, media, filters,
//! `power` on lights) is a warning with its file and
//! line, once per kind, and is left out; a syntax error is an error at its
//! line.

mod materials;
mod tokens;

use super::{LoadOptions, Material, MeshData, Scene, SceneBuilder, WorldCamera};
use crate::camera::ThinLens;
use crate::error::{Error, Result};
use crate::light::{DirectionalLight, PointLight, SpotLight};
use crate::limits::MAX_SCENE_FILE_BYTES;
use crate::math::{DVec3, Vec2, Vec3};
use crate::texture::ImageTexture;
use glam::{DAffine3, DMat3, DMat4, DQuat};
use std::collections::{HashMap, HashSet};
use std::path::{Path, PathBuf};
use std::rc::Rc;
use std::sync::Arc;
use tokens::{Param, Statement, Values};

/// How deep `Include` may nest (a file including itself would not end).
const MAX_INCLUDE_DEPTH: usize = 32;

/// The graphics state `AttributeBegin` saves.
#[derive(Debug, Clone)]
struct Attributes {
    ctm: DAffine3,
    reverse: bool,
    material: usize,
    /// An area light's radiance and two-sidedness, for the shapes that
    /// follow.
    area: Option<(Vec3, bool)>,
}

struct Loader<'a> {
    root: &'a Path,
    b: SceneBuilder,
    attrs: Attributes,
    stack: Vec<Attributes>,
    named_frames: HashMap<String, DAffine3>,
    materials: Vec<Material>,
    named_materials: HashMap<String, usize>,
    textures: HashMap<String, Arc<ImageTexture>>,
    /// Object definitions: (name, the meshes so far).
    object: Option<(String, MeshData)>,
    objects: HashMap<String, Option<u32>>,
    warned: HashSet<String>,
    warnings: Vec<String>,
    camera: Option<(DAffine3, f64, ThinLens)>,
    /// The world mirror (module docs): `x -> -x`, or the identity when the
    /// camera's transform mirrors already.
    mirror: DAffine3,
    resolution: [u32; 2],
    files: Vec<PathBuf>,
}

/// The reflection `x -> -x`.
fn x_mirror() -> DAffine3 {
    DAffine3::from_scale(DVec3::new(-1.0, 1.0, 1.0))
}

/// Load a `.pbrt` scene.
pub(super) fn load(path: &Path, _options: &LoadOptions) -> Result<Scene> {
    let mut l = Loader {
        root: path,
        b: SceneBuilder::new(path),
        attrs: Attributes {
            ctm: DAffine3::IDENTITY,
            reverse: false,
            material: 0,
            area: None,
        },
        stack: Vec::new(),
        named_frames: HashMap::new(),
        materials: vec![Material::diffuse("default", Vec3::splat(0.5))],
        named_materials: HashMap::new(),
        textures: HashMap::new(),
        object: None,
        objects: HashMap::new(),
        warned: HashSet::new(),
        warnings: Vec::new(),
        camera: None,
        // pbrt's default camera: the identity, which keeps handedness
        mirror: x_mirror(),
        resolution: [1280, 720],
        files: Vec::new(),
    };
    l.run_file(path, 0)?;
    l.finish()
}

/// Parameter lookups with the statement's place for errors. Every lookup
/// marks the parameter read, so that [`Loader::statement`] can warn about
/// the ones nothing read.
struct Params<'s> {
    st: &'s Statement,
    read: std::cell::RefCell<HashSet<&'s str>>,
}

impl<'s> Params<'s> {
    fn get(&self, name: &str) -> Option<&'s Param> {
        let p = self.st.params.iter().find(|p| p.name == name)?;
        self.read.borrow_mut().insert(&p.name);
        Some(p)
    }

    /// Mark every parameter read: the statement as a whole was warned
    /// about (an unsupported shape, material or light).
    fn read_all(&self) {
        let mut r = self.read.borrow_mut();
        r.extend(self.st.params.iter().map(|p| p.name.as_str()));
    }

    /// The parameters nothing looked up.
    fn unread(&self) -> Vec<&'s Param> {
        let r = self.read.borrow();
        self.st
            .params
            .iter()
            .filter(|p| !r.contains(p.name.as_str()))
            .collect()
    }

    fn fail(&self, m: String) -> Error {
        Error::input(&self.st.file, Some(self.st.line), m)
    }

    fn nums(&self, name: &str) -> Option<&'s [f64]> {
        match self.get(name).map(|p| &p.values) {
            Some(Values::Nums(v)) => Some(v),
            _ => None,
        }
    }

    fn float(&self, name: &str, default: f64) -> f64 {
        self.nums(name)
            .and_then(|v| v.first().copied())
            .unwrap_or(default)
    }

    fn string(&self, name: &str) -> Option<&'s str> {
        match self.get(name).map(|p| &p.values) {
            Some(Values::Strs(v)) => v.first().map(String::as_str),
            _ => None,
        }
    }

    fn bool(&self, name: &str, default: bool) -> bool {
        match self.get(name).map(|p| &p.values) {
            Some(Values::Bools(v)) => v.first().copied().unwrap_or(default),
            _ => default,
        }
    }

    /// A colour: `rgb` (three numbers), a `float` or one-number `spectrum`
    /// (grey), or `blackbody` (white, with a warning by the caller).
    fn colour(&self, name: &str) -> Result<Option<(Vec3, bool)>> {
        let Some(p) = self.get(name) else {
            return Ok(None);
        };
        match (&p.values, p.ty.as_str()) {
            (Values::Nums(v), "rgb" | "color") if v.len() == 3 => Ok(Some((
                Vec3::new(v[0] as f32, v[1] as f32, v[2] as f32),
                false,
            ))),
            (Values::Nums(v), "float" | "spectrum") if v.len() == 1 => {
                Ok(Some((Vec3::splat(v[0] as f32), false)))
            }
            (Values::Nums(_), "blackbody") => Ok(Some((Vec3::ONE, true))),
            _ => Err(self.fail(format!(
                "parameter `{name}`: expected \"rgb {name}\" [r g b] or one number"
            ))),
        }
    }
}

impl<'a> Loader<'a> {
    fn warn(&mut self, st: &Statement, kind: &str, what: String) {
        if self.warned.insert(kind.to_string()) {
            self.warnings.push(format!(
                "{}:{}: {what}; ignored",
                st.file.display(),
                st.line
            ));
        }
    }

    fn run_file(&mut self, path: &Path, depth: usize) -> Result<()> {
        if depth > MAX_INCLUDE_DEPTH {
            return Err(Error::input(
                path,
                None,
                format!("Include nests deeper than {MAX_INCLUDE_DEPTH} files"),
            ));
        }
        let bytes = super::read_bounded(path, MAX_SCENE_FILE_BYTES, super::Content::Text)?;
        let text =
            String::from_utf8(bytes).map_err(|_| Error::input(path, None, "is not UTF-8 text"))?;
        let file = Rc::new(path.to_path_buf());
        let toks = tokens::tokenize(path, &text)?;
        for st in tokens::statements(&file, &toks)? {
            self.statement(&st, depth)?;
        }
        Ok(())
    }

    /// Run statement `st`, then warn (once per statement kind and
    /// parameter) about each parameter it did not read.
    fn statement(&mut self, st: &Statement, depth: usize) -> Result<()> {
        let p = Params {
            st,
            read: Default::default(),
        };
        self.statement_body(&p, depth)?;
        for param in p.unread() {
            let kind = match st.strings.first() {
                Some(k) => format!("{} \"{}\"", st.keyword, crate::error::one_line(k)),
                None => st.keyword.clone(),
            };
            self.warn(
                st,
                &format!("param-{kind}-{}", param.name),
                format!(
                    "parameter `{}` of {kind}",
                    crate::error::one_line(&param.name)
                ),
            );
        }
        Ok(())
    }

    fn statement_body(&mut self, p: &Params, depth: usize) -> Result<()> {
        let st = p.st;
        let n = &st.numbers;
        let concat = |l: &mut Self, m: DAffine3| l.attrs.ctm *= m;
        match st.keyword.as_str() {
            "Identity" => self.attrs.ctm = DAffine3::IDENTITY,
            "Translate" => concat(
                self,
                DAffine3::from_translation(DVec3::new(n[0], n[1], n[2])),
            ),
            "Scale" => concat(self, DAffine3::from_scale(DVec3::new(n[0], n[1], n[2]))),
            "Rotate" => {
                let axis = DVec3::new(n[1], n[2], n[3]);
                let Some(axis) = axis.try_normalize() else {
                    return Err(p.fail("Rotate: the axis is zero".into()));
                };
                concat(
                    self,
                    DAffine3::from_quat(DQuat::from_axis_angle(axis, n[0].to_radians())),
                );
            }
            "LookAt" => {
                let (eye, at, up) = (
                    DVec3::new(n[0], n[1], n[2]),
                    DVec3::new(n[3], n[4], n[5]),
                    DVec3::new(n[6], n[7], n[8]),
                );
                let m = look_at(eye, at, up).ok_or_else(|| {
                    p.fail(
                        "LookAt: the eye and the point looked at coincide, or up is along the view"
                            .into(),
                    )
                })?;
                concat(self, m);
            }
            "Transform" | "ConcatTransform" => {
                // pbrt's 16 numbers are the matrix's columns (row vectors
                // times the matrix in its notation)
                let cols: [f64; 16] = n[..16].try_into().expect("16 numbers");
                let m = DMat4::from_cols_array(&cols);
                let m = DAffine3::from_mat4(m);
                if st.keyword == "Transform" {
                    self.attrs.ctm = m;
                } else {
                    concat(self, m);
                }
            }
            "CoordinateSystem" => {
                self.named_frames
                    .insert(st.strings[0].clone(), self.attrs.ctm);
            }
            "CoordSysTransform" => match self.named_frames.get(&st.strings[0]) {
                Some(m) => self.attrs.ctm = *m,
                None => {
                    return Err(p.fail(format!(
                        "no coordinate system named `{}`",
                        crate::error::one_line(&st.strings[0])
                    )));
                }
            },
            "AttributeBegin" | "TransformBegin" => self.stack.push(self.attrs.clone()),
            "AttributeEnd" | "TransformEnd" => {
                let saved = self
                    .stack
                    .pop()
                    .ok_or_else(|| p.fail(format!("{} without its Begin", st.keyword)))?;
                if st.keyword == "TransformEnd" {
                    self.attrs.ctm = saved.ctm;
                } else {
                    self.attrs = saved;
                }
            }
            "ReverseOrientation" => self.attrs.reverse = !self.attrs.reverse,
            "WorldBegin" => {
                self.attrs.ctm = DAffine3::IDENTITY;
                self.named_frames.insert("world".into(), DAffine3::IDENTITY);
            }
            "WorldEnd" => {}
            "Include" | "Import" => {
                let file = st
                    .file
                    .parent()
                    .unwrap_or(Path::new(""))
                    .join(&st.strings[0]);
                if let Some(why) = super::not_a_file(&file) {
                    return Err(p.fail(format!(
                        "{} `{}` {why}",
                        st.keyword,
                        crate::error::one_line(&st.strings[0])
                    )));
                }
                self.files.push(file.clone());
                self.run_file(&file, depth + 1)?;
            }
            "Camera" => self.camera_statement(p)?,
            "Film" => {
                let w = p.float("xresolution", 1280.0);
                let h = p.float("yresolution", 720.0);
                crate::limits::check_resolution(w as u64, h as u64).map_err(|m| p.fail(m))?;
                self.resolution = [w as u32, h as u32];
                // the output is the command line's -o
                let _ = p.get("filename");
                if p.get("cropwindow").is_some() {
                    self.warn(st, "cropwindow", "Film cropwindow".into());
                }
            }
            "Sampler" => {
                let spp = p.float("pixelsamples", 16.0);
                crate::limits::check_spp(spp as u64).map_err(|m| p.fail(m))?;
                self.b.scene_mut().render.spp = spp as u32;
            }
            "Integrator" => {
                let d = p.float("maxdepth", 5.0);
                if !(d >= 0.0 && d <= crate::limits::MAX_DEPTH as f64) {
                    return Err(p.fail(format!(
                        "maxdepth {d} out of range (0..={})",
                        crate::limits::MAX_DEPTH
                    )));
                }
                self.b.scene_mut().render.max_depth = d as u32;
                let kind = &st.strings[0];
                if !matches!(kind.as_str(), "path" | "volpath") {
                    self.warn(
                        st,
                        "integrator",
                        format!(
                            "Integrator \"{}\" (rendered by path tracing)",
                            crate::error::one_line(kind)
                        ),
                    );
                }
            }
            "Material" => {
                let m = self.material(p, &st.strings[0], "material")?;
                self.materials.push(m);
                self.attrs.material = self.materials.len() - 1;
            }
            "MakeNamedMaterial" => {
                let ty = p
                    .string("type")
                    .ok_or_else(|| p.fail("MakeNamedMaterial needs a \"string type\"".into()))?;
                let m = self.material(p, ty, &st.strings[0])?;
                self.materials.push(m);
                self.named_materials
                    .insert(st.strings[0].clone(), self.materials.len() - 1);
            }
            "NamedMaterial" => match self.named_materials.get(&st.strings[0]) {
                Some(&m) => self.attrs.material = m,
                None => {
                    return Err(p.fail(format!(
                        "no material named `{}`",
                        crate::error::one_line(&st.strings[0])
                    )));
                }
            },
            "Texture" => self.texture(p)?,
            "AreaLightSource" => {
                if st.strings[0] != "diffuse" {
                    self.warn(
                        st,
                        "arealight",
                        format!(
                            "AreaLightSource \"{}\"",
                            crate::error::one_line(&st.strings[0])
                        ),
                    );
                    p.read_all();
                    return Ok(());
                }
                let (l, bb) = p.colour("L")?.unwrap_or((Vec3::ONE, false));
                if bb {
                    self.warn(
                        st,
                        "blackbody",
                        "a blackbody spectrum (rendered white of the same luminance)".into(),
                    );
                }
                if p.get("power").is_some() {
                    self.warn(st, "power", "a light's `power`".into());
                }
                let l = l * p.float("scale", 1.0) as f32;
                self.attrs.area = Some((l, p.bool("twosided", false)));
            }
            "LightSource" => self.light(p)?,
            "Shape" => self.shape(p)?,
            "ObjectBegin" => {
                self.stack.push(self.attrs.clone());
                self.object = Some((
                    st.strings[0].clone(),
                    MeshData {
                        name: st.strings[0].clone(),
                        ..MeshData::default()
                    },
                ));
            }
            "ObjectEnd" => {
                let (name, mesh) = self
                    .object
                    .take()
                    .ok_or_else(|| p.fail("ObjectEnd without ObjectBegin".into()))?;
                self.attrs = self
                    .stack
                    .pop()
                    .ok_or_else(|| p.fail("ObjectEnd without ObjectBegin".into()))?;
                let proto = if mesh.indices.is_empty() {
                    None
                } else {
                    Some(self.b.add_prototype(mesh, Some(st.line))?)
                };
                self.objects.insert(name, proto);
            }
            "ObjectInstance" => {
                let Some(&proto) = self.objects.get(&st.strings[0]) else {
                    return Err(p.fail(format!(
                        "no object named `{}`",
                        crate::error::one_line(&st.strings[0])
                    )));
                };
                if let Some(proto) = proto {
                    let m = self.mirror * self.attrs.ctm;
                    self.b
                        .add_instance(proto, m, None, Some(st.line))
                        .map_err(|e| p.fail(e.to_string()))?;
                }
            }
            other => {
                let kind = other.to_string();
                self.warn(st, &kind, format!("`{other}`"));
                p.read_all();
            }
        }
        Ok(())
    }

    fn camera_statement(&mut self, p: &Params) -> Result<()> {
        let st = p.st;
        self.named_frames.insert("camera".into(), self.attrs.ctm);
        if st.strings[0] != "perspective" {
            return Err(p.fail(format!(
                "Camera \"{}\": only perspective cameras are read",
                crate::error::one_line(&st.strings[0])
            )));
        }
        let fov = p.float("fov", 90.0);
        let focus = p.float("focaldistance", 1e6);
        if !(fov > 0.0 && fov < 180.0) {
            return Err(p.fail(format!("Camera fov {fov} not in (0, 180)")));
        }
        let lens = match p.nums("lensradius") {
            Some(r) if r.first().is_some_and(|&r| r > 0.0) => {
                ThinLens::new(r[0] as f32, focus as f32).map_err(|e| p.fail(e.to_string()))?
            }
            _ => ThinLens::PINHOLE,
        };
        for k in ["screenwindow", "frameaspectratio"] {
            if p.get(k).is_some() {
                self.warn(st, k, format!("Camera `{k}`"));
            }
        }
        self.camera = Some((self.attrs.ctm, fov, lens));
        self.mirror = if self.attrs.ctm.matrix3.determinant() < 0.0 {
            DAffine3::IDENTITY
        } else {
            x_mirror()
        };
        Ok(())
    }

    fn light(&mut self, p: &Params) -> Result<()> {
        let st = p.st;
        let world = self.mirror * self.attrs.ctm;
        let scale = p.float("scale", 1.0) as f32;
        if p.get("power").is_some() || p.get("illuminance").is_some() {
            self.warn(st, "power", "a light's `power` or `illuminance`".into());
        }
        let colour = |l: &mut Self, key: &str| -> Result<Vec3> {
            let (c, bb) = p.colour(key)?.unwrap_or((Vec3::ONE, false));
            if bb {
                l.warn(
                    st,
                    "blackbody",
                    "a blackbody spectrum (rendered white of the same luminance)".into(),
                );
            }
            Ok(c * scale)
        };
        let point = |key: &str, d: DVec3| {
            p.nums(key)
                .filter(|v| v.len() == 3)
                .map_or(d, |v| DVec3::new(v[0], v[1], v[2]))
        };
        match st.strings[0].as_str() {
            "point" => {
                let i = colour(self, "I")?;
                let at = world.transform_point3(point("from", DVec3::ZERO));
                self.b.add_point_light(at, PointLight::new(Vec3::ZERO, i));
            }
            "spot" => {
                let i = colour(self, "I")?;
                let from = point("from", DVec3::ZERO);
                let to = point("to", DVec3::Z);
                let at = world.transform_point3(from);
                let axis = world.transform_vector3(to - from).as_vec3();
                let cone = p.float("coneangle", 30.0);
                let delta = p.float("conedelta", 5.0);
                let l = SpotLight::smoothstep(
                    Vec3::ZERO,
                    axis,
                    i,
                    (cone - delta).max(0.0).to_radians() as f32,
                    cone.to_radians() as f32,
                )
                .map_err(|e| p.fail(e))?;
                self.b.add_spot_light(at, l);
            }
            "distant" => {
                let l = colour(self, "L")?;
                let from = point("from", DVec3::ZERO);
                let to = point("to", DVec3::Z);
                let d = world.transform_vector3(to - from).as_vec3();
                let light = DirectionalLight::new(d, l)
                    .ok_or_else(|| p.fail("distant light: `from` and `to` coincide".into()))?;
                self.b.scene_mut().directional_lights.push(light);
            }
            "infinite" => {
                if let Some(file) = p.string("filename") {
                    return self.image_infinite(p, file, scale);
                }
                let l = colour(self, "L")?;
                let s = self.b.scene_mut();
                s.environment = Some(s.environment.unwrap_or(Vec3::ZERO) + l);
            }
            other => {
                self.warn(
                    st,
                    &format!("light-{other}"),
                    format!("LightSource \"{}\"", crate::error::one_line(other)),
                );
                p.read_all();
            }
        }
        Ok(())
    }

    /// An image infinite light: pbrt-v4's equal-area octahedral map in the
    /// light's frame, resampled into an equirectangular map in ours
    /// ([`crate::light::envmap::from_equal_area`]).
    fn image_infinite(&mut self, p: &Params, file: &str, scale: f32) -> Result<()> {
        let full = p.st.file.parent().unwrap_or(Path::new("")).join(file);
        if let Some(why) = super::not_a_file(&full) {
            return Err(p.fail(format!(
                "infinite light image `{}` {why}",
                crate::error::one_line(file)
            )));
        }
        if self.b.scene_mut().environment_map.is_some() {
            return Err(p.fail("a second image infinite light (one is rendered)".into()));
        }
        let img = ImageTexture::load(&full).map_err(|e| {
            p.fail(format!(
                "infinite light image `{}`: {e}",
                crate::error::one_line(file)
            ))
        })?;
        // ours -> pbrt's world (the mirror is its own inverse) -> the light's frame
        let light_from_world = self.attrs.ctm.matrix3.inverse();
        let mirror = self.mirror.matrix3;
        let map = crate::light::envmap::from_equal_area(&img, |d| {
            light_from_world * (mirror * d.as_dvec3())
        })
        .map_err(|e| {
            p.fail(format!(
                "infinite light image `{}`: {e}",
                crate::error::one_line(file)
            ))
        })?;
        let env = crate::light::EnvironmentMap::new(map, Vec3::splat(scale))
            .map_err(|e| p.fail(e.to_string()))?;
        self.b.scene_mut().environment_map = Some(env);
        self.files.push(full);
        Ok(())
    }

    fn shape(&mut self, p: &Params) -> Result<()> {
        let st = p.st;
        let kind = st.strings[0].as_str();
        let mut material = self.materials[self.attrs.material].clone();
        if let Some((l, two_sided)) = self.attrs.area {
            material.emission = l;
            material.two_sided = two_sided;
        }
        if p.get("alpha").is_some() {
            self.warn(st, "alpha", "a shape's `alpha`".into());
        }
        let mesh = match kind {
            "sphere" => {
                let r = p.float("radius", 1.0);
                for k in ["zmin", "zmax", "phimax"] {
                    if p.get(k).is_some() {
                        self.warn(st, k, format!("sphere `{k}` (a whole sphere is rendered)"));
                    }
                }
                let world = self.mirror * self.attrs.ctm;
                let m = world.matrix3;
                let (a, b, c) = (m.x_axis.length(), m.y_axis.length(), m.z_axis.length());
                if (a - b).abs() > 1e-6 * a || (a - c).abs() > 1e-6 * a {
                    return Err(p.fail("a sphere under a non-uniform scale is not read".into()));
                }
                if self.object.is_some() {
                    self.warn(st, "object-sphere", "a sphere inside ObjectBegin".into());
                    p.read_all();
                    return Ok(());
                }
                let radius = (r * a) as f32;
                if !(radius > 0.0 && radius <= crate::limits::MAX_COORDINATE) {
                    return Err(p.fail(format!(
                        "a sphere's radius must be > 0 and at most {:e} once placed, got {radius}",
                        crate::limits::MAX_COORDINATE
                    )));
                }
                let centre = world.transform_point3(DVec3::ZERO);
                return self.b.add_sphere(centre, radius, material, Some(st.line));
            }
            "trianglemesh" | "bilinearmesh" => self.mesh_of(p, kind)?,
            "plymesh" => {
                let file = p
                    .string("filename")
                    .ok_or_else(|| p.fail("plymesh needs a \"string filename\"".into()))?;
                let full = st.file.parent().unwrap_or(Path::new("")).join(file);
                if let Some(why) = super::not_a_file(&full) {
                    return Err(p.fail(format!("plymesh `{}` {why}", crate::error::one_line(file))));
                }
                if p.get("displacement").is_some() {
                    self.warn(st, "displacement", "plymesh `displacement`".into());
                }
                let mut m = super::load_ply_mesh(&full)?;
                self.files.push(full);
                m.materials.clear();
                m.materials.push(Material::default());
                m.tri_material.iter_mut().for_each(|t| *t = 0);
                m
            }
            other => {
                self.warn(
                    st,
                    &format!("shape-{other}"),
                    format!("Shape \"{}\"", crate::error::one_line(other)),
                );
                p.read_all();
                return Ok(());
            }
        };
        let mut mesh = mesh;
        orient(&mut mesh, self.attrs.reverse);
        mesh.materials = vec![material];
        if let Some((_, obj)) = &mut self.object {
            // object space of the instance: the shape's own transform
            let mut mesh = mesh;
            mesh.transform_by(&self.attrs.ctm);
            let base = obj.materials.len() as u32;
            mesh.tri_material.iter_mut().for_each(|t| *t += base);
            obj.append(mesh);
            return Ok(());
        }
        let m = self.mirror * self.attrs.ctm;
        self.b.add_mesh_matrix(mesh, m, Some(st.line))
    }

    /// A `trianglemesh` or a `bilinearmesh` (two triangles per patch).
    fn mesh_of(&self, p: &Params, kind: &str) -> Result<MeshData> {
        let pos = p
            .nums("P")
            .filter(|v| !v.is_empty() && v.len() % 3 == 0)
            .ok_or_else(|| {
                p.fail(format!(
                    "{kind} needs \"point3 P\" (a multiple of 3 numbers)"
                ))
            })?;
        let nv = pos.len() / 3;
        let idx: Vec<u32> = match p.nums("indices") {
            Some(v) => v
                .iter()
                .map(|&i| {
                    if i >= 0.0 && i.fract() == 0.0 && (i as usize) < nv {
                        Ok(i as u32)
                    } else {
                        Err(p.fail(format!("{kind}: index {i} is not one of the {nv} vertices")))
                    }
                })
                .collect::<Result<_>>()?,
            None if kind == "trianglemesh" && nv == 3 => vec![0, 1, 2],
            None if kind == "bilinearmesh" && nv == 4 => vec![0, 1, 2, 3],
            None => return Err(p.fail(format!("{kind} needs \"integer indices\""))),
        };
        let per = if kind == "trianglemesh" { 3 } else { 4 };
        if idx.len() % per != 0 {
            return Err(p.fail(format!("{kind}: the indices are not a multiple of {per}")));
        }
        let tris: Vec<[u32; 3]> = if per == 3 {
            idx.chunks_exact(3).map(|t| [t[0], t[1], t[2]]).collect()
        } else {
            // p00 p10 p01 p11
            idx.chunks_exact(4)
                .flat_map(|q| [[q[0], q[1], q[3]], [q[0], q[3], q[2]]])
                .collect()
        };
        let uv = p.nums("uv").filter(|v| v.len() == 2 * nv);
        let nrm = p.nums("N").filter(|v| v.len() == 3 * nv);
        let v2 = |k: u32| {
            let v = uv.expect("checked");
            Vec2::new(v[2 * k as usize] as f32, v[2 * k as usize + 1] as f32)
        };
        let n3 = |k: u32| {
            let v = nrm.expect("checked");
            let i = 3 * k as usize;
            Vec3::new(v[i] as f32, v[i + 1] as f32, v[i + 2] as f32)
        };
        Ok(MeshData {
            name: format!("{kind} at line {}", p.st.line),
            positions: pos
                .chunks_exact(3)
                .map(|c| DVec3::new(c[0], c[1], c[2]))
                .collect(),
            tri_material: vec![0; tris.len()],
            uvs: if uv.is_some() {
                tris.iter().map(|t| t.map(v2)).collect()
            } else {
                Vec::new()
            },
            normals: if nrm.is_some() {
                tris.iter().map(|t| t.map(n3)).collect()
            } else {
                Vec::new()
            },
            indices: tris,
            ..MeshData::default()
        })
    }

    fn finish(mut self) -> Result<Scene> {
        if let Some((camera_from_world, fov, lens)) = self.camera {
            let inv = camera_from_world.inverse();
            let w = self.mirror * inv;
            let origin = w.transform_point3(DVec3::ZERO);
            let forward = w.transform_vector3(DVec3::Z);
            let up = w.transform_vector3(DVec3::Y);
            let target = origin + forward / forward.length();
            let up = WorldCamera::usable_up(origin, target, up).ok_or_else(|| {
                Error::input(self.root, None, "the camera's transform is singular")
            })?;
            let [wd, ht] = self.resolution;
            // pbrt's fov spans the shorter side
            let fov_y = if wd >= ht {
                fov
            } else {
                2.0 * ((0.5 * fov.to_radians()).tan() * ht as f64 / wd as f64)
                    .atan()
                    .to_degrees()
            };
            self.b.set_camera(WorldCamera {
                origin,
                target,
                up,
                fov_y: fov_y as f32,
            });
            self.b.scene_mut().lens = lens;
        }
        if self.object.is_some() {
            return Err(Error::input(
                self.root,
                None,
                "ObjectBegin without ObjectEnd",
            ));
        }
        let s = self.b.scene_mut();
        s.resolution = self.resolution;
        s.warnings.append(&mut self.warnings);
        s.mesh_files.append(&mut self.files);
        Ok(self.b.build())
    }
}

/// pbrt's `LookAt`: camera from world, the camera looking down its `+z`
/// with `+y` up and `+x = up x view` (left-handed).
fn look_at(eye: DVec3, at: DVec3, up: DVec3) -> Option<DAffine3> {
    let dir = (at - eye).try_normalize()?;
    let right = up.try_normalize()?.cross(dir).try_normalize()?;
    let new_up = dir.cross(right);
    let world_from_camera =
        DAffine3::from_mat3_translation(DMat3::from_cols(right, new_up, dir), eye);
    Some(world_from_camera.inverse())
}

/// Wind each triangle as pbrt orients it: counter-clockwise, reversed by
/// `ReverseOrientation`, and where the mesh has normals, towards them.
fn orient(mesh: &mut MeshData, reverse: bool) {
    for t in 0..mesh.indices.len() {
        let [a, b, c] = mesh.indices[t].map(|i| mesh.positions[i as usize]);
        let n = (b - a).cross(c - a);
        let flip = if mesh.normals.is_empty() {
            reverse
        } else {
            let s = mesh.normals[t]
                .iter()
                .fold(Vec3::ZERO, |s, &v| s + v)
                .as_dvec3();
            n.dot(s) < 0.0
        };
        if flip {
            mesh.indices[t].swap(1, 2);
            if !mesh.uvs.is_empty() {
                mesh.uvs[t].swap(1, 2);
            }
            if !mesh.normals.is_empty() {
                mesh.normals[t].swap(1, 2);
            }
        }
    }
}
