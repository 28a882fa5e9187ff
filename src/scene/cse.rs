//! CSE 167 / 168 scene files (`.test`), UCSD's course formats: one command
//! per line, `#` comments, numbers separated by white space. The raytracer
//! of CSE 167 and the path tracer of CSE 168 read the same commands; this
//! loader maps each onto the renderer's own scene, materials and settings.
//!
//! | command | here |
//! |---|---|
//! | `size w h` | the resolution (default 640 x 480) |
//! | `camera from at up fovy` | pinhole camera, vertical field of view in degrees |
//! | `output name` | a note: name the image with `-o` |
//! | `maxdepth d` | `max_depth` (default 5); `-1` is our limit, [`MAX_DEPTH`], with roulette ending paths |
//! | `vertex`, `tri a b c` | triangles of 0-based vertex indices, placed by the transform current at `tri` |
//! | `vertexnormal`, `trinormal` | the same with per-vertex shading normals |
//! | `maxverts`, `maxvertnorms` | accepted; sizes are not preallocated |
//! | `sphere x y z r` | an analytic sphere under a similarity transform; otherwise a tessellated ellipsoid with smooth normals (a note says so) |
//! | `translate`, `rotate ax ay az deg`, `scale`, `pushTransform`, `popTransform` | the course's stack: each command right-multiplies the current matrix, so the last one named acts first |
//! | `point`, `directional` | point and directional lights, placed by the current transform, with `pi` times the course's colour (see below) |
//! | `attenuation c l q` | falloff `1 / (c + l d + q d^2)` of later point lights (default `1 0 0`: none) |
//! | `ambient`, `diffuse`, `specular`, `shininess`, `emission`, `brdf`, `roughness` | the current material ([`Phong`]) |
//! | `quadLight a ab ac L` | a one-sided emitting parallelogram `a, a + ab, a + ab + ac, a + ac` of radiance `L`, facing `ac x ab` |
//! | `integrator`, `spp`, `lightsamples`, `nexteventestimation`, `russianroulette` | render defaults (below) |
//! | `importancesampling`, `lightstratify`, `gamma` | notes: BSDF sampling, the sampler's own stratification and sRGB output are used instead |
//!
//! Meaning, where the courses' and a physically based renderer's differ:
//!
//! - **Materials**: `diffuse kd`, `specular ks`, `shininess s` (and `brdf
//!   ggx` with `roughness`) become the CSE 168 BRDF, [`Phong`]; without a
//!   specular term that is exactly [`Diffuse`]. The CSE 167 raytracer's
//!   unnormalised Blinn-Phong highlight and its `ks`-weighted recursive
//!   mirror ray are not reproduced: the normalised lobe stands for both.
//! - **Lights**: the course's shading is `kd L cos / atten` for a point or
//!   directional light of colour `L`, with no `1 / pi`; our Lambertian is
//!   `kd / pi`, so a light of colour `L` becomes intensity (or irradiance)
//!   `pi L`, which gives a lit diffuse surface the course's brightness.
//! - **Ambient and emission**: both are radiance leaving the surface
//!   whatever lights it. For the CSE 167 raytracer (no `integrator`, or
//!   `integrator raytracer`) they become the material's two-sided emission
//!   (`ambient` defaults to 0.2), which in a path tracer also lights other
//!   surfaces. The CSE 168 integrators ignore `ambient` (a note says so when
//!   it is not zero); `emission` stays an emitter.
//! - **Integrators**: every file is path traced. `analyticdirect` and
//!   `direct` set `max_depth = 1` (direct light only) with light sampling;
//!   `pathtracer` takes `nexteventestimation off | on | mis` as BSDF
//!   sampling, light sampling or MIS, and `russianroulette on` as
//!   throughput roulette from the first bounce (`off`: none).
//!
//! Unknown commands are warnings naming the command and line; malformed
//! ones (a wrong number of arguments, a number that is not finite, an index
//! out of range, a `popTransform` with nothing pushed) are errors naming the
//! file and line.

use super::{EmissionRole, Material, MeshData, Scene, SceneBuilder, WorldCamera};
use crate::bsdf::{Bsdf, Diffuse, Lobe, Microfacet, Phong};
use crate::error::{Error, Result};
use crate::light::{DirectionalLight, PointLight};
use crate::limits::{self, MAX_DEPTH};
use crate::math::Vec3;
use crate::settings::{DirectStrategy, Roulette};
use glam::{DAffine3, DMat3, DQuat, DVec3};
use std::f32::consts::PI;
use std::path::Path;

/// The deepest `pushTransform` nesting accepted (the courses' files use a
/// handful; this bounds the stack's memory).
const MAX_STACK: usize = 1 << 16;

/// Rings and segments of the mesh that stands for a sphere under a
/// transform that is not a similarity.
const ELLIPSOID_RINGS: u32 = 48;
const ELLIPSOID_SEGMENTS: u32 = 96;
const ELLIPSOID_TRIANGLES: u64 = 2 * ELLIPSOID_SEGMENTS as u64 * (ELLIPSOID_RINGS as u64 - 1);

/// The material state of the file at some point.
#[derive(Debug, Clone, Copy, PartialEq)]
struct MaterialState {
    ambient: Vec3,
    diffuse: Vec3,
    specular: Vec3,
    emission: Vec3,
    shininess: f32,
    ggx: bool,
    roughness: f32,
}

impl Default for MaterialState {
    fn default() -> Self {
        MaterialState {
            ambient: Vec3::splat(0.2),
            diffuse: Vec3::ZERO,
            specular: Vec3::ZERO,
            emission: Vec3::ZERO,
            shininess: 1.0,
            ggx: false,
            roughness: 0.0,
        }
    }
}

/// Which course integrator the file names.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Integrator {
    Raytracer,
    AnalyticDirect,
    Direct,
    PathTracer,
}

struct Loader<'a> {
    path: &'a Path,
    line: usize,
    notes: Vec<String>,
    warnings: Vec<String>,
}

impl Loader<'_> {
    fn fail(&self, msg: impl Into<String>) -> Error {
        Error::input(self.path, Some(self.line), msg)
    }

    fn at(&self) -> String {
        format!("{}:{}", self.path.display(), self.line)
    }

    fn note(&mut self, msg: impl std::fmt::Display) {
        let m = format!("{}: {msg}", self.at());
        self.notes.push(m);
    }

    fn warn(&mut self, msg: impl std::fmt::Display) {
        let m = format!("{}: {msg}", self.at());
        self.warnings.push(m);
    }

    /// Exactly `N` numbers after the command.
    fn numbers<const N: usize>(&self, cmd: &str, args: &[&str]) -> Result<[f32; N]> {
        let v = self.numbers64::<N>(cmd, args)?;
        match v.iter().position(|x| !(*x as f32).is_finite()) {
            Some(i) => Err(self.fail(format!(
                "`{cmd}`: `{}` is not a finite number",
                crate::error::one_line(args[i])
            ))),
            None => Ok(v.map(|x| x as f32)),
        }
    }

    /// Exactly `N` numbers after the command, in f64 (positions and
    /// transforms, which keep their precision until the scene is rebased).
    fn numbers64<const N: usize>(&self, cmd: &str, args: &[&str]) -> Result<[f64; N]> {
        if args.len() != N {
            return Err(self.fail(format!("`{cmd}` takes {N} numbers, got {}", args.len())));
        }
        let mut out = [0.0; N];
        for (o, a) in out.iter_mut().zip(args) {
            *o = match a.parse::<f64>() {
                Ok(x) if x.is_finite() => x,
                _ => {
                    return Err(self.fail(format!(
                        "`{cmd}`: `{}` is not a finite number",
                        crate::error::one_line(a)
                    )));
                }
            };
        }
        Ok(out)
    }

    /// One whole number after the command, in `lo..=hi`.
    fn integer(&self, cmd: &str, args: &[&str], lo: i64, hi: i64) -> Result<i64> {
        match args {
            [a] => match a.parse::<i64>() {
                Ok(n) if (lo..=hi).contains(&n) => Ok(n),
                _ => Err(self.fail(format!(
                    "`{cmd}`: expected a whole number in {lo}..={hi}, got `{}`",
                    crate::error::one_line(a)
                ))),
            },
            _ => Err(self.fail(format!(
                "`{cmd}` takes one whole number, got {} arguments",
                args.len()
            ))),
        }
    }

    /// One word after the command, one of `choices`.
    fn word<'w>(&self, cmd: &str, args: &[&str], choices: &[&'w str]) -> Result<&'w str> {
        let found = match args {
            [a] => choices.iter().find(|c| *c == a),
            _ => None,
        };
        found.copied().ok_or_else(|| {
            self.fail(format!(
                "`{cmd}` takes one of {}, got `{}`",
                choices.join(", "),
                crate::error::one_line(&args.join(" "))
            ))
        })
    }

    fn colour(&self, cmd: &str, args: &[&str]) -> Result<Vec3> {
        let c = Vec3::from(self.numbers::<3>(cmd, args)?);
        if c.min_element() < 0.0 {
            return Err(self.fail(format!("`{cmd}`: a colour cannot be negative, got {c}")));
        }
        Ok(c)
    }
}

/// A triangle soup as the file builds it: world positions, and one
/// material state per triangle (indexing `states`).
#[derive(Default)]
struct Soup {
    positions: Vec<DVec3>,
    normals: Vec<[Vec3; 3]>,
    tri_state: Vec<u32>,
    any_normals: bool,
    first_line: Option<usize>,
}

impl Soup {
    fn push(&mut self, p: [DVec3; 3], n: Option<[Vec3; 3]>, state: u32, line: usize) {
        self.positions.extend(p);
        self.any_normals |= n.is_some();
        self.normals.push(n.unwrap_or([Vec3::ZERO; 3]));
        self.tri_state.push(state);
        self.first_line.get_or_insert(line);
    }

    fn len(&self) -> u64 {
        self.tri_state.len() as u64
    }
}

/// Whether `m` is a uniform scale times a rotation (so that it maps a
/// sphere to a sphere): its columns orthogonal and of one length, to a
/// relative 1e-5. Returns the scale.
fn similarity_scale(m: &DMat3) -> Option<f64> {
    let c = [m.x_axis, m.y_axis, m.z_axis];
    let len = c.map(|v| v.length());
    let s = len[0];
    if !(s > 0.0) || !s.is_finite() {
        return None;
    }
    let tol = 1e-5 * s;
    let same = len.iter().all(|l| (l - s).abs() <= tol);
    let orthogonal = (0..3).all(|i| c[i].dot(c[(i + 1) % 3]).abs() <= tol * s);
    (same && orthogonal).then_some(s)
}

/// A unit sphere as a mesh with outward unit normals.
fn unit_sphere_mesh(material: Material) -> MeshData {
    let (rings, segs) = (ELLIPSOID_RINGS, ELLIPSOID_SEGMENTS);
    let mut positions = Vec::new();
    for i in 0..=rings {
        let theta = PI * i as f32 / rings as f32;
        for j in 0..segs {
            let phi = 2.0 * PI * j as f32 / segs as f32;
            positions.push(
                Vec3::new(
                    theta.sin() * phi.cos(),
                    theta.cos(),
                    -theta.sin() * phi.sin(),
                )
                .as_dvec3(),
            );
        }
    }
    let at = |i: u32, j: u32| i * segs + j % segs;
    let mut indices = Vec::new();
    for i in 0..rings {
        for j in 0..segs {
            // counter-clockwise seen from outside
            let (a, b, c, d) = (at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1));
            if i > 0 {
                indices.push([a, b, d]);
            }
            if i + 1 < rings {
                indices.push([b, c, d]);
            }
        }
    }
    let normals = indices
        .iter()
        .map(|t: &[u32; 3]| t.map(|k| positions[k as usize].as_vec3()))
        .collect();
    MeshData {
        name: "sphere".to_string(),
        tri_material: vec![0; indices.len()],
        positions,
        indices,
        materials: vec![material],
        uvs: Vec::new(),
        normals,
        warnings: Vec::new(),
        files: Vec::new(),
    }
}

/// Load a `.test` scene.
pub fn load(path: &Path) -> Result<Scene> {
    let text = super::read_scene_text(path)?;
    let mut ld = Loader {
        path,
        line: 0,
        notes: Vec::new(),
        warnings: Vec::new(),
    };
    let mut b = SceneBuilder::new(path);
    let mut resolution = [640u32, 480];
    let mut camera: Option<WorldCamera> = None;
    let mut max_depth: u32 = 5;
    let mut unbounded = false;
    let mut integrator = Integrator::Raytracer;
    let mut spp: Option<u32> = None;
    let mut light_samples: Option<u32> = None;
    let mut nee = DirectStrategy::Bsdf;
    let mut roulette = false;

    let mut stack = vec![DAffine3::IDENTITY];
    let mut attenuation = [1.0f32, 0.0, 0.0];
    let mut state = MaterialState::default();
    let mut states: Vec<(MaterialState, usize)> = Vec::new();
    let mut vertices: Vec<DVec3> = Vec::new();
    let mut vertex_normals: Vec<(DVec3, Vec3)> = Vec::new();
    let mut soup = Soup::default();
    let mut spheres: Vec<(DVec3, f32, u32, usize)> = Vec::new();
    let mut ellipsoids: Vec<(DAffine3, u32, usize)> = Vec::new();
    let mut quads: Vec<([DVec3; 4], Vec3, usize)> = Vec::new();
    let mut point_lights = Vec::new();
    let mut directional_lights = Vec::new();

    // the index of the current material state, added on first use
    let state_index =
        |states: &mut Vec<(MaterialState, usize)>, s: MaterialState, line| match states.last() {
            Some((last, _)) if *last == s => (states.len() - 1) as u32,
            _ => {
                states.push((s, line));
                (states.len() - 1) as u32
            }
        };

    for (n, raw) in text.lines().enumerate() {
        ld.line = n + 1;
        let content = raw.split('#').next().unwrap_or("");
        let mut words = content.split_whitespace();
        let Some(cmd) = words.next() else {
            continue;
        };
        let args: Vec<&str> = words.collect();
        let line = ld.line;
        let m = *stack.last().expect("the stack keeps its base");
        match cmd {
            "size" => {
                let [w, h] = ld.numbers::<2>(cmd, &args)?;
                if w.fract() != 0.0 || h.fract() != 0.0 || w < 1.0 || h < 1.0 {
                    return Err(ld.fail(format!("`size`: expected two whole numbers, got {w} {h}")));
                }
                limits::check_resolution(w as u64, h as u64).map_err(|e| ld.fail(e))?;
                resolution = [w as u32, h as u32];
            }
            "camera" => {
                let v = ld.numbers64::<10>(cmd, &args)?;
                let origin = DVec3::new(v[0], v[1], v[2]);
                let target = DVec3::new(v[3], v[4], v[5]);
                let up = DVec3::new(v[6], v[7], v[8]);
                let fov_y = v[9] as f32;
                if !(fov_y > 0.0 && fov_y < 180.0) {
                    return Err(ld.fail(format!(
                        "`camera`: fovy {fov_y} out of range (0, 180) degrees"
                    )));
                }
                // as in a TOML scene: the camera within the range every
                // backend handles (a farther eye made its rays' directions
                // overflow)
                for (what, p) in [("eye", origin), ("point looked at", target)] {
                    if p.abs().max_element() > limits::MAX_COORDINATE as f64 {
                        return Err(ld.fail(format!(
                            "`camera`: the {what} {p} is beyond +-{:e}",
                            limits::MAX_COORDINATE
                        )));
                    }
                }
                // only up's direction matters (an up of (0, 1, 1e300) or
                // (0, 1e-39, 1) made NaN directions)
                let Some(up) = WorldCamera::usable_up(origin, target, up) else {
                    return Err(ld.fail(
                        "`camera`: the eye, the point looked at and the up vector leave the view undefined",
                    ));
                };
                camera = Some(WorldCamera {
                    origin,
                    target,
                    up,
                    fov_y,
                });
            }
            "output" => {
                let name = args.join(" ");
                ld.note(format!(
                    "`output {}` is not used: the image goes where -o says (default: the scene's name, .png)",
                    crate::error::one_line(&name)
                ));
            }
            "maxdepth" => {
                let d = ld.integer(cmd, &args, -1, MAX_DEPTH as i64)?;
                unbounded = d < 0;
                max_depth = if unbounded { MAX_DEPTH } else { d as u32 };
            }
            "maxverts" | "maxvertnorms" => {
                ld.integer(cmd, &args, 0, i64::MAX)?;
            }
            "vertex" => {
                if vertices.len() as u64 >= limits::MAX_VERTICES {
                    return Err(ld.fail(format!("more than {} vertices", limits::MAX_VERTICES)));
                }
                vertices.push(DVec3::from(ld.numbers64::<3>(cmd, &args)?));
            }
            "vertexnormal" => {
                if vertex_normals.len() as u64 >= limits::MAX_VERTICES {
                    return Err(ld.fail(format!("more than {} vertices", limits::MAX_VERTICES)));
                }
                let v = ld.numbers64::<6>(cmd, &args)?;
                vertex_normals.push((
                    DVec3::new(v[0], v[1], v[2]),
                    DVec3::new(v[3], v[4], v[5]).as_vec3(),
                ));
            }
            "tri" | "trinormal" => {
                let v = ld.numbers::<3>(cmd, &args)?;
                let count = if cmd == "tri" {
                    vertices.len()
                } else {
                    vertex_normals.len()
                };
                let mut idx = [0usize; 3];
                for (i, x) in idx.iter_mut().zip(v) {
                    if x.fract() != 0.0 || x < 0.0 || x >= count as f32 {
                        return Err(ld.fail(format!(
                            "`{cmd}`: vertex {x} out of range (the file has defined {count} {}; indices start at 0)",
                            if cmd == "tri" { "vertices" } else { "vertex normals" }
                        )));
                    }
                    *i = x as usize;
                }
                if soup.len() + spheres.len() as u64 >= limits::MAX_TRIANGLES {
                    return Err(ld.fail(format!("more than {} primitives", limits::MAX_TRIANGLES)));
                }
                let s = state_index(&mut states, state, line);
                let (p, normals) = if cmd == "tri" {
                    (idx.map(|i| vertices[i]), None)
                } else {
                    let normal_matrix = m.matrix3.inverse().transpose();
                    (
                        idx.map(|i| vertex_normals[i].0),
                        Some(
                            idx.map(|i| (normal_matrix * vertex_normals[i].1.as_dvec3()).as_vec3()),
                        ),
                    )
                };
                let mut p = p.map(|q| m.transform_point3(q));
                let mut normals = normals;
                if m.matrix3.determinant() < 0.0 {
                    p.swap(1, 2);
                    if let Some(ns) = normals.as_mut() {
                        ns.swap(1, 2);
                    }
                }
                soup.push(p, normals, s, line);
            }
            "sphere" => {
                let [x, y, z, r] = ld.numbers64::<4>(cmd, &args)?;
                if !(r > 0.0) {
                    return Err(ld.fail(format!("`sphere`: radius {r} must be positive")));
                }
                let tessellated = ellipsoids.len() as u64 * ELLIPSOID_TRIANGLES;
                if soup.len() + spheres.len() as u64 + tessellated >= limits::MAX_TRIANGLES {
                    return Err(ld.fail(format!("more than {} primitives", limits::MAX_TRIANGLES)));
                }
                let s = state_index(&mut states, state, line);
                let local = DAffine3::from_translation(DVec3::new(x, y, z))
                    * DAffine3::from_scale(DVec3::splat(r));
                let placed = m * local;
                let center = placed.translation;
                let max = limits::MAX_COORDINATE as f64;
                match similarity_scale(&placed.matrix3) {
                    Some(scale) if !(center.abs().max_element() <= max && scale <= max) => {
                        return Err(ld.fail(format!(
                            "`sphere`: centre {center} or radius {scale} beyond {:e} after the transform",
                            limits::MAX_COORDINATE
                        )));
                    }
                    Some(scale) => spheres.push((center, scale as f32, s, line)),
                    None => {
                        ld.note(format!(
                            "sphere under a transform that is not a similarity: tessellated into an ellipsoid of {} triangles with smooth normals",
                            ELLIPSOID_TRIANGLES
                        ));
                        ellipsoids.push((placed, s, line));
                    }
                }
            }
            "translate" => {
                let v = ld.numbers64::<3>(cmd, &args)?;
                *stack.last_mut().expect("base") = m * DAffine3::from_translation(DVec3::from(v));
            }
            "scale" => {
                let v = DVec3::from(ld.numbers64::<3>(cmd, &args)?);
                if v.x * v.y * v.z == 0.0 {
                    return Err(ld.fail(format!(
                        "`scale {v}`: a zero scale flattens everything after it"
                    )));
                }
                *stack.last_mut().expect("base") = m * DAffine3::from_scale(v);
            }
            "rotate" => {
                let [x, y, z, deg] = ld.numbers64::<4>(cmd, &args)?;
                let axis = DVec3::new(x, y, z);
                let len = axis.length();
                if !(len > 0.0 && len.is_finite()) {
                    return Err(ld.fail("`rotate`: the axis is zero"));
                }
                let q = DQuat::from_axis_angle(axis / len, deg.to_radians());
                *stack.last_mut().expect("base") = m * DAffine3::from_quat(q);
            }
            "pushTransform" => {
                if stack.len() >= MAX_STACK {
                    return Err(ld.fail(format!("`pushTransform` nested deeper than {MAX_STACK}")));
                }
                stack.push(m);
            }
            "popTransform" => {
                if stack.len() == 1 {
                    return Err(ld.fail("`popTransform` without a matching `pushTransform`"));
                }
                stack.pop();
            }
            "point" => {
                let v = ld.numbers64::<6>(cmd, &args)?;
                let colour = ld.colour(cmd, &args[3..])?;
                let position = m.transform_point3(DVec3::new(v[0], v[1], v[2]));
                let light = PointLight::new(Vec3::ZERO, PI * colour)
                    .with_attenuation(attenuation)
                    .ok_or_else(|| ld.fail("attenuation leaves the point light undefined"))?;
                point_lights.push((position, light));
            }
            "directional" => {
                let v = ld.numbers::<6>(cmd, &args)?;
                let colour = ld.colour(cmd, &args[3..])?;
                // the file names the direction towards the light
                let towards = m
                    .transform_vector3(DVec3::new(v[0] as f64, v[1] as f64, v[2] as f64))
                    .as_vec3();
                let light = DirectionalLight::new(-towards, PI * colour)
                    .ok_or_else(|| ld.fail("`directional`: the direction is zero"))?;
                directional_lights.push(light);
            }
            "attenuation" => {
                let a = ld.numbers::<3>(cmd, &args)?;
                if a.iter().any(|x| *x < 0.0) || a.iter().sum::<f32>() <= 0.0 {
                    return Err(ld.fail(format!(
                        "`attenuation {} {} {}`: expected non-negative terms, not all zero",
                        a[0], a[1], a[2]
                    )));
                }
                attenuation = a;
            }
            "quadLight" => {
                let v = ld.numbers64::<12>(cmd, &args)?;
                let radiance = ld.colour(cmd, &args[9..])?;
                let a = DVec3::new(v[0], v[1], v[2]);
                let ab = DVec3::new(v[3], v[4], v[5]);
                let ac = DVec3::new(v[6], v[7], v[8]);
                // Wound so that the front is ac x ab. The course's own
                // statement of this rule could not be found: no CSE 167/168
                // assignment text, reference renderer or course scene file is
                // in this repository, and a search of stored public pages and
                // code found none (only students' renderers that parse the
                // command and cite nothing on its side). The rule is this
                // loader's choice, made so that a ceiling light written with
                // `ab` along +z and `ac` along +x, as in
                // tests/data/cse/cornell.test (written for these tests in the
                // course's dialect, not a course file), faces down into the
                // room: ac x ab = -y, where ab x ac would light only the
                // ceiling. tests/cse.rs pins it
                // (a_quad_light_faces_ac_cross_ab_with_its_radiance); if the
                // course's renderer is found to emit on the other side, swap
                // the winding here and that test's expectation.
                let corners = [a, a + ac, a + ab + ac, a + ab].map(|p| m.transform_point3(p));
                quads.push((corners, radiance, line));
            }
            "ambient" => state.ambient = ld.colour(cmd, &args)?,
            "diffuse" => state.diffuse = ld.colour(cmd, &args)?,
            "specular" => state.specular = ld.colour(cmd, &args)?,
            "emission" => state.emission = ld.colour(cmd, &args)?,
            "shininess" => {
                let [s] = ld.numbers::<1>(cmd, &args)?;
                if !(0.0..=Phong::MAX_SHININESS).contains(&s) {
                    return Err(ld.fail(format!(
                        "`shininess {s}` out of range (0..={:e})",
                        Phong::MAX_SHININESS
                    )));
                }
                state.shininess = s;
            }
            "roughness" => {
                let [r] = ld.numbers::<1>(cmd, &args)?;
                if !(0.0..=1.0).contains(&r) {
                    return Err(ld.fail(format!("`roughness {r}` out of range (0..=1)")));
                }
                state.roughness = r;
            }
            "brdf" => state.ggx = ld.word(cmd, &args, &["phong", "ggx"])? == "ggx",
            "integrator" => {
                integrator = match ld.word(
                    cmd,
                    &args,
                    &["raytracer", "analyticdirect", "direct", "pathtracer"],
                )? {
                    "raytracer" => Integrator::Raytracer,
                    "analyticdirect" => Integrator::AnalyticDirect,
                    "direct" => Integrator::Direct,
                    _ => Integrator::PathTracer,
                };
            }
            "spp" => {
                spp = Some(ld.integer(cmd, &args, 1, limits::MAX_SPP as i64)? as u32);
            }
            "lightsamples" => {
                light_samples =
                    Some(ld.integer(cmd, &args, 1, limits::MAX_LIGHT_SAMPLES as i64)? as u32);
            }
            "nexteventestimation" => {
                nee = match ld.word(cmd, &args, &["off", "on", "mis"])? {
                    "off" => DirectStrategy::Bsdf,
                    "on" => DirectStrategy::Light,
                    _ => DirectStrategy::Mis,
                };
            }
            "russianroulette" => roulette = ld.word(cmd, &args, &["off", "on"])? == "on",
            "importancesampling" => {
                let how = ld.word(cmd, &args, &["hemisphere", "cosine", "brdf"])?;
                if how != "brdf" {
                    ld.note(format!(
                        "`importancesampling {how}`: directions are always sampled from the BSDF (the same expected image, less noise)"
                    ));
                }
            }
            "lightstratify" => {
                if ld.word(cmd, &args, &["off", "on"])? == "on" {
                    ld.note("`lightstratify on`: light samples come from the sampler (use --sampler sobol for stratified ones)");
                }
            }
            "gamma" => {
                let [g] = ld.numbers::<1>(cmd, &args)?;
                ld.note(format!(
                    "`gamma {g}`: PNG output is sRGB-encoded, EXR and PFM linear"
                ));
            }
            _ => ld.warn(format!(
                "unknown command `{}`, skipped",
                crate::error::one_line(cmd)
            )),
        }
    }
    ld.line = 0;

    // --- materials, now that the integrator is known ---
    let raytracer = integrator == Integrator::Raytracer;
    let mut ignored_ambient = None;
    let mut materials = Vec::with_capacity(states.len());
    for (k, (s, line)) in states.iter().enumerate() {
        ld.line = *line;
        let mut emission = s.emission;
        if raytracer {
            emission += s.ambient;
        } else if s.ambient != Vec3::ZERO && ignored_ambient.is_none() {
            ignored_ambient = Some(*line);
        }
        let bsdf = if s.specular == Vec3::ZERO {
            Bsdf::Diffuse(Diffuse { albedo: s.diffuse })
        } else {
            let lobe = if s.ggx {
                let mut r = s.roughness;
                if r < Microfacet::SMOOTH_ALPHA {
                    ld.note(format!(
                        "`roughness {r}` with `brdf ggx`: raised to {} (smoother is a mirror)",
                        Microfacet::SMOOTH_ALPHA
                    ));
                    r = Microfacet::SMOOTH_ALPHA;
                }
                Lobe::Ggx { roughness: r }
            } else {
                Lobe::Phong {
                    shininess: s.shininess,
                }
            };
            Bsdf::Phong(Phong {
                diffuse: s.diffuse,
                specular: s.specular,
                lobe,
            })
        };
        bsdf.validate()
            .map_err(|e| ld.fail(format!("material: {e}")))?;
        if (s.diffuse + s.specular).max_element() > 1.0 {
            ld.warn(format!(
                "diffuse {} + specular {} exceeds 1: the material reflects more light than it receives",
                s.diffuse, s.specular
            ));
        }
        materials.push(Material {
            name: format!("material-{k}"),
            bsdf,
            texture: None,
            emission,
            // the courses add emission whichever side is seen
            two_sided: emission != Vec3::ZERO,
            role: EmissionRole::Light,
            one_sided: false,
            maps: Default::default(),
            alpha_mask: None,
        });
    }
    if let Some(line) = ignored_ambient {
        ld.line = line;
        ld.note(
            "`ambient` is not used by the CSE 168 integrators (it is by `integrator raytracer`)",
        );
    }

    // --- geometry ---
    if !soup.tri_state.is_empty() {
        let count = soup.tri_state.len() as u32;
        let mesh = MeshData {
            name: "triangles".to_string(),
            positions: soup.positions,
            indices: (0..count).map(|t| [3 * t, 3 * t + 1, 3 * t + 2]).collect(),
            tri_material: soup.tri_state,
            materials: materials.clone(),
            uvs: Vec::new(),
            normals: if soup.any_normals {
                soup.normals
            } else {
                Vec::new()
            },
            warnings: Vec::new(),
            files: Vec::new(),
        };
        b.add_mesh_matrix(mesh, DAffine3::IDENTITY, soup.first_line)?;
    }
    if !quads.is_empty() {
        let mut mesh = MeshData {
            name: "quadLight".to_string(),
            ..MeshData::default()
        };
        for (k, (c, radiance, _)) in quads.iter().enumerate() {
            let base = mesh.positions.len() as u32;
            mesh.positions.extend(c);
            mesh.indices.push([base, base + 1, base + 2]);
            mesh.indices.push([base, base + 2, base + 3]);
            mesh.tri_material.extend([k as u32; 2]);
            mesh.materials.push(Material {
                name: format!("quadLight-{k}"),
                bsdf: Bsdf::Diffuse(Diffuse { albedo: Vec3::ZERO }),
                texture: None,
                emission: *radiance,
                two_sided: false,
                role: EmissionRole::Light,
                one_sided: false,
                maps: Default::default(),
                alpha_mask: None,
            });
        }
        b.add_mesh_matrix(mesh, DAffine3::IDENTITY, quads.first().map(|q| q.2))?;
    }
    for (center, radius, s, line) in spheres {
        b.add_sphere(center, radius, materials[s as usize].clone(), Some(line))?;
    }
    for (placed, s, line) in ellipsoids {
        let mesh = unit_sphere_mesh(materials[s as usize].clone());
        b.add_mesh_matrix(mesh, placed, Some(line))?;
    }

    // --- lights, camera, settings ---
    for (position, light) in point_lights {
        b.add_point_light(position, light);
    }
    if let Some(c) = camera {
        b.set_camera(c);
    }
    let scene = b.scene_mut();
    scene.directional_lights = directional_lights;
    scene.resolution = resolution;
    let r = &mut scene.render;
    r.max_depth = max_depth;
    if let Some(s) = spp {
        r.spp = s;
    }
    if let Some(l) = light_samples {
        r.light_samples = l;
    }
    match integrator {
        Integrator::AnalyticDirect | Integrator::Direct => {
            r.max_depth = 1;
            r.direct = DirectStrategy::Light;
        }
        Integrator::PathTracer => {
            r.direct = nee;
            if roulette {
                r.roulette = Roulette::Throughput;
                r.rr_depth = 1;
            } else {
                r.roulette = Roulette::Fixed(1.0);
            }
        }
        Integrator::Raytracer => {}
    }
    if unbounded && r.roulette == Roulette::Fixed(1.0) {
        ld.notes.push(format!(
            "{}: `maxdepth -1` without `russianroulette on`: paths stop at {MAX_DEPTH} bounces",
            path.display()
        ));
    }
    let mut scene = b.build();
    scene.notes.extend(ld.notes);
    scene.warnings.extend(ld.warnings);
    Ok(scene)
}
