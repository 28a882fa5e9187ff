//! The immutable [`Scene`]: flat triangle arrays, materials, lights, camera and
//! render defaults, shared read-only by every render thread. One loader per
//! format fills it through [`SceneBuilder`], which is also where geometry is
//! cleaned (degenerate and non-finite triangles dropped and reported) so that
//! every backend sees the same triangles, and where the scene-wide limits of
//! [`crate::limits`] are enforced.

mod collada;
mod cse;
mod mitsuba;
mod obj;
mod ply;
pub mod procedural;
mod toml_file;
mod xml;

use crate::accel::Hit;
use crate::bsdf::{Bsdf, Diffuse};
use crate::camera::{Camera, CameraDesc, ThinLens};
use crate::error::{Error, Result};
use crate::light::{DirectionalLight, EnvironmentMap, PointLight};
use crate::limits::{MAX_COORDINATE, MAX_SCENE_FILE_BYTES, MAX_TRIANGLES, MAX_VERTICES};
use crate::math::{DVec3, Ray, SurfacePoint, Vec2, Vec3, needle_factor, triangle_normal};
use crate::settings::RenderDefaults;
use crate::shape::Sphere;
use crate::texture::ImageTexture;
use glam::DAffine3;
use std::path::{Path, PathBuf};
use std::sync::Arc;

pub use obj::load_obj_mesh;
pub use ply::{MAX_POLYGON, load_ply_mesh};

/// A surface material: a BSDF, an optional albedo texture, and emission.
#[derive(Debug, Clone, PartialEq)]
pub struct Material {
    /// Name (from the .mtl file, or a generated one).
    pub name: String,
    /// How the surface scatters light. Checked by [`Bsdf::validate`] when
    /// loaded.
    pub bsdf: Bsdf,
    /// An albedo texture (shared by every material that names its file) that replaces the
    /// diffuse albedo of a `diffuse` BSDF or the base of a `plastic` one,
    /// looked up at the surface's texture coordinates.
    pub texture: Option<Arc<ImageTexture>>,
    /// Emitted radiance (an area light when non-zero).
    pub emission: Vec3,
    /// Emit from both sides (otherwise only from the front, where the
    /// triangle winds counter-clockwise or the sphere's normal points out).
    pub two_sided: bool,
}

impl Material {
    /// A Lambertian material named `name` with `albedo`.
    pub fn diffuse(name: &str, albedo: Vec3) -> Self {
        Material {
            name: name.to_string(),
            bsdf: Bsdf::Diffuse(Diffuse { albedo }),
            ..Material::default()
        }
    }

    /// The diffuse albedo, for a `diffuse` material.
    pub fn albedo(&self) -> Option<Vec3> {
        match &self.bsdf {
            Bsdf::Diffuse(d) => Some(d.albedo),
            _ => None,
        }
    }

    /// The material's type as scene files spell it.
    pub fn type_name(&self) -> &'static str {
        match &self.bsdf {
            Bsdf::Diffuse(_) => "diffuse",
            Bsdf::Mirror(_) => "mirror",
            Bsdf::Glass(_) => "glass",
            Bsdf::Conductor(_) => "conductor",
            Bsdf::Plastic(_) => "plastic",
            Bsdf::Phong(_) => "phong",
        }
    }
}

impl Default for Material {
    fn default() -> Self {
        Material {
            name: "default".to_string(),
            bsdf: Bsdf::Diffuse(Diffuse {
                albedo: Vec3::splat(0.8),
            }),
            texture: None,
            emission: Vec3::ZERO,
            two_sided: false,
        }
    }
}

/// The vertical field of view, in degrees, of a focal length of `f` pixels
/// on an image `height` pixels high.
fn fov_for_focal(f: f32, height: u32) -> f32 {
    2.0 * (height as f32 / (2.0 * f)).atan().to_degrees()
}

/// Where one mesh's triangles sit in the flat arrays (for messages).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct MeshRange {
    /// The mesh's name (its file, or its object name).
    pub name: String,
    /// First triangle index.
    pub start: u32,
    /// One past the last triangle index.
    pub end: u32,
}

/// Everything a render needs to know about the world. Immutable once built.
#[derive(Debug, Clone)]
pub struct Scene {
    /// The file the scene came from.
    pub source: PathBuf,
    /// The mesh files and material libraries it read, each once (textures
    /// and environment maps know their own files): inputs that no output
    /// may overwrite.
    pub mesh_files: Vec<PathBuf>,
    /// Vertex positions in render space (world minus [`Scene::world_origin`]).
    pub positions: Vec<Vec3>,
    /// Three vertex indices per triangle, counter-clockwise seen from the front.
    pub indices: Vec<[u32; 3]>,
    /// Unit geometric normal per triangle (the front side).
    pub normals: Vec<Vec3>,
    /// Per triangle, its [`crate::math::needle_factor`], which the offset
    /// policy needs at every hit.
    pub needle: Vec<f32>,
    /// Material index per triangle.
    pub tri_material: Vec<u32>,
    /// Materials.
    pub materials: Vec<Material>,
    /// Mesh ranges, in order.
    pub meshes: Vec<MeshRange>,
    /// Texture coordinates of each triangle's corners, when some mesh has
    /// them: empty, or one entry per triangle (zeros for triangles of meshes
    /// without).
    pub tri_uv: Vec<[Vec2; 3]>,
    /// Vertex normals of each triangle's corners (unit, world space), when
    /// some mesh has them: empty, or one entry per triangle, with zero
    /// vectors for triangles shaded flat.
    pub tri_shading_normals: Vec<[Vec3; 3]>,
    /// Analytic spheres; sphere `i` is primitive `triangle_count() + i`.
    pub spheres: Vec<Sphere>,
    /// Material index per sphere.
    pub sphere_material: Vec<u32>,
    /// Radiance of the uniform environment light, if any.
    pub environment: Option<Vec3>,
    /// The image-based environment light, if any.
    pub environment_map: Option<EnvironmentMap>,
    /// Point lights.
    pub point_lights: Vec<PointLight>,
    /// Directional lights.
    pub directional_lights: Vec<DirectionalLight>,
    /// The camera, in render space.
    pub camera: CameraDesc,
    /// The world point at the origin of render space: every position above
    /// (vertices, spheres, point lights, camera) is its world position minus
    /// this, computed in f64 before rounding to f32 (see
    /// [`render_origin`]). Zero unless the camera is far from the world's
    /// origin compared with what it looks at.
    pub world_origin: DVec3,
    /// The camera's lens (a pinhole unless the scene sets an aperture).
    pub lens: ThinLens,
    /// A focal length in pixels that the field of view follows (CS184's
    /// camera): when set, an image `h` pixels high sees a vertical field of
    /// `2 atan(h / (2 f))`, and `camera.fov_y` holds the one at
    /// `resolution`.
    pub focal_pixels: Option<f32>,
    /// Image width and height.
    pub resolution: [u32; 2],
    /// Render defaults from the file.
    pub render: RenderDefaults,
    /// Things worth telling the user (degenerate triangles dropped, defaults
    /// applied).
    pub notes: Vec<String>,
    /// Things the user should act on, one line each: triangles dropped
    /// because a transform took them out of range.
    pub warnings: Vec<String>,
}

impl Scene {
    /// Load a scene by extension: `.toml` (scene file), `.obj` or `.ply`
    /// (a bare mesh, framed automatically; lit by a white environment if it
    /// has no emitters), `.xml` (Mitsuba 3), `.dae` (CS184 COLLADA) or
    /// `.test` (CSE 167/168).
    pub fn load(path: &Path) -> Result<Scene> {
        let meta = std::fs::metadata(path).map_err(|e| Error::io(path, e))?;
        if meta.is_dir() {
            return Err(Error::input(
                path,
                None,
                "is a directory, expected a scene file",
            ));
        }
        let ext = path
            .extension()
            .and_then(|e| e.to_str())
            .map(|e| e.to_ascii_lowercase())
            .unwrap_or_default();
        match ext.as_str() {
            "toml" => toml_file::load(path),
            "obj" => obj::load_bare(path),
            "ply" => bare_scene(path, load_ply_mesh(path)?),
            "xml" => mitsuba::load(path),
            "test" => cse::load(path),
            "dae" => collada::load(path),
            _ => Err(Error::input(
                path,
                None,
                format!(
                    "unknown scene format `.{ext}` (expected .toml, .obj, .ply, Mitsuba 3 .xml, CS184 .dae or CSE 167/168 .test)"
                ),
            )),
        }
    }

    /// Number of triangles.
    pub fn triangle_count(&self) -> usize {
        self.indices.len()
    }

    /// The three corners of triangle `prim`.
    #[inline]
    pub fn triangle(&self, prim: u32) -> [Vec3; 3] {
        self.indices[prim as usize].map(|i| self.positions[i as usize])
    }

    /// Number of primitives: triangles, then spheres.
    pub fn primitive_count(&self) -> usize {
        self.indices.len() + self.spheres.len()
    }

    /// The sphere that primitive `prim` is, if it is one.
    #[inline]
    pub fn sphere(&self, prim: u32) -> Option<&Sphere> {
        (prim as usize)
            .checked_sub(self.indices.len())
            .map(|i| &self.spheres[i])
    }

    /// The material index of primitive `prim`.
    #[inline]
    pub fn material_index(&self, prim: u32) -> u32 {
        let nt = self.indices.len();
        match (prim as usize).checked_sub(nt) {
            None => self.tri_material[prim as usize],
            Some(i) => self.sphere_material[i],
        }
    }

    /// The material of primitive `prim` (a triangle or a sphere).
    #[inline]
    pub fn material(&self, prim: u32) -> &Material {
        &self.materials[self.material_index(prim) as usize]
    }

    /// The surface point at barycentrics `(u, v)` of triangle `prim`, rebuilt
    /// from the vertex buffer with its error bound.
    #[inline]
    pub fn surface_point(&self, prim: u32, u: f32, v: f32) -> SurfacePoint {
        let i = prim as usize;
        SurfacePoint::on_triangle_with(self.triangle(prim), u, v, self.normals[i], self.needle[i])
    }

    /// The surface point a backend's `hit` of `ray` stands for: rebuilt from
    /// the barycentrics on a triangle, or from the ray's `t`, projected back
    /// onto the sphere, on a sphere.
    #[inline]
    pub fn hit_point(&self, ray: &Ray, hit: &Hit) -> SurfacePoint {
        match self.sphere(hit.prim) {
            None => self.surface_point(hit.prim, hit.u, hit.v),
            Some(s) => SurfacePoint::on_sphere(s.center, s.radius, ray.at(hit.t)),
        }
    }

    /// Texture coordinates at a surface point: interpolated corner UVs on a
    /// triangle (zero when its mesh has none), or on a sphere, from its outward
    /// normal `n`, `u = atan2(-n.z, n.x) / 2 pi` wrapped to `[0, 1)` and
    /// `v = 1 - acos(n.y) / pi`, so `v = 1` at the top (+y) pole.
    pub fn uv(&self, prim: u32, sp: &SurfacePoint, u: f32, v: f32) -> Vec2 {
        match self.sphere(prim) {
            None => match self.tri_uv.get(prim as usize) {
                Some(t) => (1.0 - u - v) * t[0] + u * t[1] + v * t[2],
                None => Vec2::ZERO,
            },
            Some(_) => {
                let n = sp.n;
                let phi = (-n.z).atan2(n.x);
                let phi = if phi < 0.0 {
                    phi + std::f32::consts::TAU
                } else {
                    phi
                };
                let theta = n.y.clamp(-1.0, 1.0).acos();
                Vec2::new(
                    phi / std::f32::consts::TAU,
                    1.0 - theta / std::f32::consts::PI,
                )
            }
        }
    }

    /// The camera for a `width` x `height` image, with the scene's lens.
    pub fn make_camera(&self, width: u32, height: u32) -> Camera {
        let mut desc = self.camera;
        if let Some(f) = self.focal_pixels {
            desc.fov_y = fov_for_focal(f, height);
        }
        Camera::with_lens(&desc, width, height, self.lens)
    }

    /// Give the camera a focal length of `f` pixels: the field of view then
    /// follows the image height, and `camera.fov_y` is the one at the
    /// scene's own resolution.
    pub fn set_focal_pixels(&mut self, f: f32) {
        self.focal_pixels = Some(f);
        self.camera.fov_y = fov_for_focal(f, self.resolution[1]);
    }

    /// Axis-aligned bounds of all vertices used by triangles and of all
    /// spheres: `(min, max)`.
    pub fn bounds(&self) -> Bounds {
        let mut b = Bounds::empty();
        for t in &self.indices {
            for &i in t {
                b.extend(self.positions[i as usize]);
            }
        }
        for s in &self.spheres {
            b.extend(s.center - Vec3::splat(s.radius));
            b.extend(s.center + Vec3::splat(s.radius));
        }
        b
    }

    /// The primitives as a backend receives them.
    pub fn soup(&self) -> crate::accel::TriangleSoup<'_> {
        crate::accel::TriangleSoup {
            positions: &self.positions,
            indices: &self.indices,
            spheres: &self.spheres,
        }
    }

    /// Whether any material of a primitive emits.
    pub fn has_emitters(&self) -> bool {
        (0..self.primitive_count()).any(|i| self.material(i as u32).emission.max_element() > 0.0)
    }
}

/// A camera placed in world space (f64), before the scene is rebased.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WorldCamera {
    /// Eye position.
    pub origin: DVec3,
    /// Point looked at.
    pub target: DVec3,
    /// Up direction (need not be orthogonal to the view direction).
    pub up: Vec3,
    /// Vertical field of view in degrees.
    pub fov_y: f32,
}

impl WorldCamera {
    /// A camera that frames the world box `[min, max]` (empty when `min > max`):
    /// from the +z side, or looking down -y or -x on a box flat in y or x
    /// (a floor, a wall), which seen from +z would be edge-on and empty.
    pub fn framing(min: DVec3, max: DVec3) -> WorldCamera {
        let fov_y = 39.3f32;
        let (centre, size) = if min.x > max.x {
            (DVec3::ZERO, DVec3::splat(2.0 / 3f64.sqrt()))
        } else {
            (0.5 * (min + max), max - min)
        };
        let radius = (0.5 * size.length()).max(1e-6);
        let dist = radius / (0.5 * (fov_y as f64).to_radians()).sin() * 1.05;
        // a box whose extent in y (or x) is under 1e-3 of its largest is flat
        let flat = |k: f64| k < 1e-3 * size.max_element();
        let (axis, up) = if flat(size.y) && !flat(size.z) {
            (DVec3::Y, -Vec3::Z)
        } else if flat(size.x) && !flat(size.z) {
            (DVec3::X, Vec3::Y)
        } else {
            (DVec3::Z, Vec3::Y)
        };
        WorldCamera {
            origin: centre + dist * axis,
            target: centre,
            up,
            fov_y,
        }
    }
}

/// The world point a scene seen by `camera` is rebased to, so that positions
/// near the camera keep f32's precision wherever the world puts them (the
/// camera-relative render space of pbrt-v4, section 5.1.1 of *Physically
/// Based Rendering*, 4th edition): the camera's position rounded to a
/// multiple of `s`, the power of two nearest 8 times its distance `l` to its
/// target (`2^(round(log2 l) + 3)`, between 5.7 and 11.3 times `l`: the
/// unit view distances that Mitsuba's `to_world` cameras give sit in the
/// middle of a step, not on its edge). Rounding keeps a scene near the
/// world's origin as it is (zero until the camera is `s / 2` from it), and
/// makes the subtraction exact for coordinates on a coarser grid than `s`. What
/// rebasing cannot recover is precision the camera's own view lacks: a
/// point `d` from the camera lands within about `d * 2^-24` of where it
/// should in f32, whatever the world's offset.
pub fn render_origin(camera: &WorldCamera) -> DVec3 {
    let l = (camera.target - camera.origin).length();
    if !(l > 0.0 && l.is_finite() && camera.origin.is_finite()) {
        return DVec3::ZERO;
    }
    let s = 2f64.powi(l.log2().round() as i32 + 3);
    (camera.origin / s).round() * s
}

/// What a file read by [`read_bounded`] must look like.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Content {
    /// Text: a NUL byte (binary data, UTF-16, `/dev/zero`) is refused at
    /// its line as soon as it is read.
    Text,
    /// Data that starts with these bytes, in the named format.
    Magic(&'static [u8], &'static str),
}

/// Read `path` whole, refusing files over `limit` bytes before reading them
/// (devices and pipes, which have no size, after `limit` bytes) and data that
/// is not `content`, as early as it shows.
pub(crate) fn read_bounded(path: &Path, limit: u64, content: Content) -> Result<Vec<u8>> {
    use std::io::Read;
    let too_big = |size: String| {
        Error::input(
            path,
            None,
            format!("{size} bytes: larger than the {limit} bytes such a file may have"),
        )
    };
    let meta = std::fs::metadata(path).map_err(|e| Error::io(path, e))?;
    if meta.is_dir() {
        return Err(Error::input(path, None, "is a directory, expected a file"));
    }
    if meta.len() > limit {
        return Err(too_big(meta.len().to_string()));
    }
    let file = std::fs::File::open(path).map_err(|e| Error::io(path, e))?;
    let mut reader = file.take(limit + 1);
    let mut bytes = Vec::with_capacity(meta.len() as usize);
    let mut chunk = vec![0u8; 1 << 16];
    loop {
        let n = match reader.read(&mut chunk) {
            Ok(0) => break,
            Ok(n) => n,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => continue,
            Err(e) => return Err(Error::io(path, e)),
        };
        let start = bytes.len();
        bytes.extend_from_slice(&chunk[..n]);
        match content {
            Content::Text => {
                if let Some(i) = chunk[..n].iter().position(|&b| b == 0) {
                    let line = bytes[..start + i].iter().filter(|&&b| b == b'\n').count() + 1;
                    return Err(Error::input(
                        path,
                        Some(line),
                        "binary data (a NUL byte): not a text file (UTF-16 text must be converted to UTF-8)",
                    ));
                }
            }
            Content::Magic(magic, format) => {
                let have = bytes.len().min(magic.len());
                if bytes[..have] != magic[..have] {
                    return Err(not_format(path, magic, format));
                }
            }
        }
        if bytes.len() as u64 > limit {
            return Err(too_big(format!("more than {limit}")));
        }
    }
    if let Content::Magic(magic, format) = content {
        if bytes.len() < magic.len() {
            return Err(not_format(path, magic, format));
        }
    }
    Ok(bytes)
}

/// Why a file a scene names cannot be read as one: `None` when it is a
/// file, else "is a directory" or "not found".
pub(crate) fn not_a_file(path: &Path) -> Option<&'static str> {
    if path.is_file() {
        None
    } else if path.is_dir() {
        Some("is a directory")
    } else {
        Some("not found")
    }
}

/// The error for a file that lacks its format's `magic` first bytes.
fn not_format(path: &Path, magic: &[u8], format: &str) -> Error {
    Error::input(
        path,
        None,
        format!(
            "does not start with `{}`: not a {format} file",
            String::from_utf8_lossy(magic)
        ),
    )
}

/// A text scene file, read whole (see [`read_bounded`]), with the line of
/// the first byte that is not UTF-8.
fn read_scene_text(path: &Path) -> Result<String> {
    let bytes = read_bounded(path, MAX_SCENE_FILE_BYTES, Content::Text)?;
    String::from_utf8(bytes).map_err(|e| {
        let bytes = &e.as_bytes()[..e.utf8_error().valid_up_to()];
        let line = bytes.iter().filter(|&&b| b == b'\n').count() + 1;
        Error::input(path, Some(line), "not UTF-8 text")
    })
}

/// A bare mesh file as a scene: the mesh placed as it is, the camera framed
/// from its bounds, and a uniform white environment when nothing emits.
fn bare_scene(path: &Path, mesh: MeshData) -> Result<Scene> {
    let mut b = SceneBuilder::new(path);
    b.add_mesh_from(mesh, &Transform::default(), None)?;
    b.light_if_dark = true;
    Ok(b.build())
}

/// An axis-aligned box.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Bounds {
    /// Lower corner.
    pub min: Vec3,
    /// Upper corner.
    pub max: Vec3,
}

impl Bounds {
    /// The empty box.
    pub fn empty() -> Self {
        Bounds {
            min: Vec3::splat(f32::INFINITY),
            max: Vec3::splat(f32::NEG_INFINITY),
        }
    }

    /// Grow to contain `p`.
    pub fn extend(&mut self, p: Vec3) {
        self.min = self.min.min(p);
        self.max = self.max.max(p);
    }

    /// Whether nothing was added.
    pub fn is_empty(&self) -> bool {
        self.min.x > self.max.x
    }
}

/// An affine placement: scale, then rotate about an axis, then translate,
/// composed in f64 (a large translation keeps its precision until the scene
/// is rebased).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Transform {
    /// Per-axis scale.
    pub scale: DVec3,
    /// Rotation axis (any length but zero) and angle in degrees.
    pub rotate: Option<(DVec3, f64)>,
    /// Translation.
    pub translate: DVec3,
}

impl Default for Transform {
    fn default() -> Self {
        Transform {
            scale: DVec3::ONE,
            rotate: None,
            translate: DVec3::ZERO,
        }
    }
}

impl Transform {
    /// The matrix `T * R * S`.
    pub fn matrix(&self) -> DAffine3 {
        let r = match self.rotate {
            Some((axis, deg)) => glam::DQuat::from_axis_angle(axis.normalize(), deg.to_radians()),
            None => glam::DQuat::IDENTITY,
        };
        DAffine3::from_scale_rotation_translation(self.scale, r, self.translate)
    }
}

/// A mesh as a loader reads it, before placement: positions, triangles and a
/// material index per triangle into `materials`.
#[derive(Debug, Clone, Default)]
pub struct MeshData {
    /// Name for messages.
    pub name: String,
    /// Vertex positions, in f64 so that coordinates far from the origin
    /// keep their precision until the scene is rebased.
    pub positions: Vec<DVec3>,
    /// Triangles.
    pub indices: Vec<[u32; 3]>,
    /// Material per triangle, indexing `materials`.
    pub tri_material: Vec<u32>,
    /// The mesh's materials.
    pub materials: Vec<Material>,
    /// Texture coordinates of each triangle's corners: empty, or one entry
    /// per triangle.
    pub uvs: Vec<[Vec2; 3]>,
    /// Vertex normals of each triangle's corners (any length; zero = none):
    /// empty, or one entry per triangle.
    pub normals: Vec<[Vec3; 3]>,
    /// Things in the file the loader read past, one line each, with the
    /// file and line: the scene's warnings once the mesh is placed.
    pub warnings: Vec<String>,
    /// The files it was read from (the mesh file, its material libraries):
    /// the scene's [`Scene::mesh_files`] once placed.
    pub files: Vec<PathBuf>,
}

impl MeshData {
    /// Smooth vertex normals, per triangle corner: at each vertex the sum
    /// of its triangles' unit normals weighted by the triangle's angle at
    /// that vertex (Thürmer and Wüthrich 1998, the weighting Mitsuba uses
    /// when a mesh has none), normalised. Degenerate triangles add nothing;
    /// a vertex left with a zero sum gets a zero normal (shaded flat).
    pub fn vertex_normals(&self) -> Vec<[Vec3; 3]> {
        let mut sum = vec![Vec3::ZERO; self.positions.len()];
        for t in &self.indices {
            // relative to the first corner, so a far-away mesh loses nothing
            let p =
                t.map(|i| (self.positions[i as usize] - self.positions[t[0] as usize]).as_vec3());
            let n = (p[1] - p[0]).cross(p[2] - p[0]).normalize_or_zero();
            if !n.is_finite() || n == Vec3::ZERO {
                continue;
            }
            for k in 0..3 {
                let e1 = (p[(k + 1) % 3] - p[k]).normalize_or_zero();
                let e2 = (p[(k + 2) % 3] - p[k]).normalize_or_zero();
                let angle = e1.dot(e2).clamp(-1.0, 1.0).acos();
                if angle.is_finite() {
                    sum[t[k] as usize] += n * angle;
                }
            }
        }
        let unit: Vec<Vec3> = sum.iter().map(|n| n.normalize_or_zero()).collect();
        self.indices
            .iter()
            .map(|t| t.map(|i| unit[i as usize]))
            .collect()
    }
}

/// A mesh placed in world space, waiting for the scene's render origin.
#[derive(Debug)]
struct Placed {
    /// The mesh with world positions (f64), world normals and front-facing
    /// winding.
    mesh: MeshData,
    /// Index of its first material in the scene's list.
    base_material: u32,
    /// Its line in the scene file.
    line: Option<usize>,
}

/// Accumulates meshes, spheres, point lights and the camera in world space
/// (f64) and builds a [`Scene`] rebased to [`render_origin`], dropping
/// triangles no backend should see.
#[derive(Debug)]
pub struct SceneBuilder {
    scene: Scene,
    /// [`MAX_TRIANGLES`], lowered by unit tests.
    max_triangles: u64,
    /// Meshes in world space, in order.
    placed: Vec<Placed>,
    /// Triangles and vertices in `placed`.
    counts: (u64, u64),
    /// Spheres' world centres, radii and material indices.
    spheres: Vec<(DVec3, f32, u32)>,
    /// Point lights and their world positions.
    point_lights: Vec<(DVec3, PointLight)>,
    /// The camera, unless the scene is to be framed.
    camera: Option<WorldCamera>,
    /// Light a scene in which nothing emits with a uniform white
    /// environment, with a note (a bare mesh), instead of warning.
    light_if_dark: bool,
}

impl SceneBuilder {
    /// An empty scene read from `source`.
    pub fn new(source: &Path) -> Self {
        SceneBuilder {
            scene: Scene {
                source: source.to_path_buf(),
                mesh_files: Vec::new(),
                positions: Vec::new(),
                indices: Vec::new(),
                normals: Vec::new(),
                needle: Vec::new(),
                tri_material: Vec::new(),
                materials: Vec::new(),
                meshes: Vec::new(),
                tri_uv: Vec::new(),
                tri_shading_normals: Vec::new(),
                spheres: Vec::new(),
                sphere_material: Vec::new(),
                environment: None,
                environment_map: None,
                point_lights: Vec::new(),
                directional_lights: Vec::new(),
                camera: CameraDesc {
                    origin: Vec3::Z,
                    target: Vec3::ZERO,
                    up: Vec3::Y,
                    fov_y: 39.3,
                },
                world_origin: DVec3::ZERO,
                lens: ThinLens::PINHOLE,
                focal_pixels: None,
                resolution: [512, 512],
                render: RenderDefaults::default(),
                notes: Vec::new(),
                warnings: Vec::new(),
            },
            max_triangles: MAX_TRIANGLES,
            placed: Vec::new(),
            counts: (0, 0),
            spheres: Vec::new(),
            point_lights: Vec::new(),
            camera: None,
            light_if_dark: false,
        }
    }

    /// Add a mesh placed by `transform`. Triangles whose corners become
    /// non-finite or leave [`MAX_COORDINATE`] are dropped with one warning
    /// naming the mesh; zero-area triangles are dropped with a note (both
    /// when the scene is built). For meshes built in code (tests, parity
    /// scenes); loaders use [`SceneBuilder::add_mesh_from`], which also
    /// enforces the scene limits.
    pub fn add_mesh(&mut self, mesh: MeshData, transform: &Transform) {
        self.place(mesh, transform.matrix(), None);
    }

    /// Add a mesh that the scene file describes at `line`, placed by
    /// `transform`, after checking it against the scene-wide limits
    /// ([`MAX_TRIANGLES`], [`MAX_VERTICES`]) and its own consistency (every
    /// vertex and material index in range). Errors name the scene file and
    /// `line`; nothing is added then.
    pub fn add_mesh_from(
        &mut self,
        mesh: MeshData,
        transform: &Transform,
        line: Option<usize>,
    ) -> Result<()> {
        self.add_mesh_matrix(mesh, transform.matrix(), line)
    }

    /// [`SceneBuilder::add_mesh_from`] with any affine placement (a scene
    /// format's matrix, composed in f64): normals go through the inverse
    /// transpose, and a mirroring matrix (negative determinant) reverses the
    /// winding.
    pub fn add_mesh_matrix(
        &mut self,
        mesh: MeshData,
        matrix: DAffine3,
        line: Option<usize>,
    ) -> Result<()> {
        let s = &self.scene;
        let fail = |msg: String| Err(Error::input(&s.source, line, msg));
        let tris = self.counts.0 + mesh.indices.len() as u64;
        if tris > self.max_triangles {
            return fail(format!(
                "mesh `{}` ({} triangles) would take the scene to {tris} triangles (at most {})",
                mesh.name,
                mesh.indices.len(),
                self.max_triangles
            ));
        }
        let verts = self.counts.1 + mesh.positions.len() as u64;
        if verts > MAX_VERTICES {
            return fail(format!(
                "mesh `{}` ({} vertices) would take the scene to {verts} vertices (at most {MAX_VERTICES})",
                mesh.name,
                mesh.positions.len()
            ));
        }
        let n = mesh.positions.len() as u64;
        if mesh.indices.iter().flatten().any(|&i| i as u64 >= n)
            || mesh.tri_material.len() != mesh.indices.len()
            || mesh
                .tri_material
                .iter()
                .any(|&m| m as usize >= mesh.materials.len())
        {
            return fail(format!(
                "mesh `{}`: a vertex or material index is out of range",
                mesh.name
            ));
        }
        if mesh.uvs.is_empty() {
            let used = |m: usize| mesh.tri_material.iter().any(|&t| t as usize == m);
            if let Some((_, m)) = mesh
                .materials
                .iter()
                .enumerate()
                .find(|(i, m)| m.texture.is_some() && used(*i))
            {
                return fail(format!(
                    "mesh `{}` has no texture coordinates (vt), but its material `{}` has a texture",
                    mesh.name, m.name
                ));
            }
        }
        self.place(mesh, matrix, line);
        Ok(())
    }

    /// Place `mesh` in world space: positions through `m` (f64), normals
    /// through its inverse transpose, winding reversed by a mirror.
    fn place(&mut self, mut mesh: MeshData, m: DAffine3, line: Option<usize>) {
        let s = &mut self.scene;
        s.warnings.append(&mut mesh.warnings);
        for f in mesh.files.drain(..) {
            if !s.mesh_files.contains(&f) {
                s.mesh_files.push(f);
            }
        }
        let base_material = s.materials.len() as u32;
        s.materials.append(&mut mesh.materials);
        for p in &mut mesh.positions {
            *p = m.transform_point3(*p);
        }
        let normal_matrix = m.matrix3.inverse().transpose();
        for corners in &mut mesh.normals {
            *corners = corners.map(|n| {
                // a zero, non-finite or degenerate normal shades flat; a
                // unit one (to a few ulps) is kept as it is, so that a
                // scene written out with its normals reads back to the
                // same bits
                let w = (normal_matrix * n.as_dvec3()).as_vec3();
                let w = if (w.length_squared() - 1.0).abs() <= 4.0 * f32::EPSILON {
                    w
                } else {
                    w.normalize_or_zero()
                };
                if w.is_finite() { w } else { Vec3::ZERO }
            });
        }
        if m.matrix3.determinant() < 0.0 {
            for t in &mut mesh.indices {
                t.swap(1, 2);
            }
            for uv in &mut mesh.uvs {
                uv.swap(1, 2);
            }
            for ns in &mut mesh.normals {
                ns.swap(1, 2);
            }
        }
        self.counts.0 += mesh.indices.len() as u64;
        self.counts.1 += mesh.positions.len() as u64;
        self.placed.push(Placed {
            mesh,
            base_material,
            line,
        });
    }

    /// Move a placed mesh into the scene's arrays, in render space (world
    /// minus `origin`, rounded to f32), and report what was dropped.
    fn rebase(&mut self, placed: Placed, origin: DVec3) {
        let Placed {
            mesh,
            base_material,
            line,
        } = placed;
        let s = &mut self.scene;
        let base_vertex = s.positions.len() as u32;
        s.positions
            .extend(mesh.positions.iter().map(|&p| (p - origin).as_vec3()));
        let start = s.indices.len() as u32;
        // per-corner attributes line up with the triangles once any mesh has them
        let keep_uv = !mesh.uvs.is_empty() || !s.tri_uv.is_empty();
        let keep_normals = !mesh.normals.is_empty() || !s.tri_shading_normals.is_empty();
        if keep_uv {
            s.tri_uv.resize(s.indices.len(), [Vec2::ZERO; 3]);
        }
        if keep_normals {
            s.tri_shading_normals
                .resize(s.indices.len(), [Vec3::ZERO; 3]);
        }
        let (mut out_of_range, mut degenerate, mut lost_emitters) = (0usize, 0usize, 0usize);
        for (k, (t, &mat)) in mesh.indices.iter().zip(&mesh.tri_material).enumerate() {
            let idx = t.map(|i| i + base_vertex);
            let p = idx.map(|i| s.positions[i as usize]);
            if !p.iter().all(|q| q.abs().max_element() <= MAX_COORDINATE) {
                // NaN and infinities fail the comparison too
                out_of_range += 1;
                continue;
            }
            let Some(n) = triangle_normal(p[0], p[1], p[2]) else {
                degenerate += 1;
                if s.materials[(base_material + mat) as usize]
                    .emission
                    .max_element()
                    > 0.0
                {
                    lost_emitters += 1;
                }
                continue;
            };
            s.indices.push(idx);
            s.normals.push(n);
            s.needle.push(needle_factor(p));
            s.tri_material.push(base_material + mat);
            if keep_uv {
                s.tri_uv
                    .push(mesh.uvs.get(k).copied().unwrap_or([Vec2::ZERO; 3]));
            }
            if keep_normals {
                // a corner whose normal faces away from the triangle's front
                // is flipped, so each interpolated normal is on the front
                // side at that corner
                let ns = mesh.normals.get(k).copied().unwrap_or([Vec3::ZERO; 3]);
                s.tri_shading_normals
                    .push(ns.map(|c| if c.dot(n) < 0.0 { -c } else { c }));
            }
        }
        let at = crate::error::Location {
            file: s.source.clone(),
            line,
        };
        let name = crate::error::one_line(&mesh.name);
        if out_of_range > 0 {
            s.warnings.push(format!(
                "{at}: mesh `{name}`: dropped {out_of_range} triangles with coordinates beyond {MAX_COORDINATE:e} or non-finite after transform"
            ));
        }
        if degenerate > 0 {
            s.notes.push(format!(
                "{at}: mesh `{name}`: dropped {degenerate} degenerate (zero-area) triangles"
            ));
        }
        if lost_emitters > 0 {
            s.warnings.push(format!(
                "{at}: mesh `{name}`: {lost_emitters} emitting triangles have zero area in f32 after the transform (too small for their distance from the camera?), so the light they made is gone"
            ));
        }
        let end = s.indices.len() as u32;
        s.meshes.push(MeshRange {
            name: mesh.name,
            start,
            end,
        });
    }

    /// Add an analytic sphere (world centre, radius) with its own material,
    /// which the scene file describes at `line`. A textured material is
    /// fine: spheres have their own texture coordinates.
    pub fn add_sphere(
        &mut self,
        center: DVec3,
        radius: f32,
        material: Material,
        line: Option<usize>,
    ) -> Result<()> {
        let s = &mut self.scene;
        if self.spheres.len() as u64 >= self.max_triangles {
            return Err(Error::input(
                &s.source,
                line,
                format!("more than {} spheres", self.max_triangles),
            ));
        }
        self.spheres
            .push((center, radius, s.materials.len() as u32));
        s.materials.push(material);
        Ok(())
    }

    /// Add a point light at world `position` (its own position is replaced
    /// by the rebased one).
    pub fn add_point_light(&mut self, position: DVec3, light: PointLight) {
        self.point_lights.push((position, light));
    }

    /// Set the camera, in world space. Without one the scene is framed from
    /// its bounds, with a note.
    pub fn set_camera(&mut self, camera: WorldCamera) {
        self.camera = Some(camera);
    }

    /// The camera set so far.
    pub fn camera(&self) -> Option<&WorldCamera> {
        self.camera.as_ref()
    }

    /// Triangles placed so far.
    pub fn triangle_count(&self) -> u64 {
        self.counts.0
    }

    /// Vertices placed so far.
    pub fn vertex_count(&self) -> u64 {
        self.counts.1
    }

    /// World bounds of the vertices of placed triangles (those finite and
    /// within [`MAX_COORDINATE`]) and of the spheres: `(min, max)`, with
    /// `min > max` when there are none.
    pub fn world_bounds(&self) -> (DVec3, DVec3) {
        let (mut lo, mut hi) = (DVec3::INFINITY, DVec3::NEG_INFINITY);
        let mut add = |p: DVec3| {
            if p.is_finite() && p.abs().max_element() <= MAX_COORDINATE as f64 {
                lo = lo.min(p);
                hi = hi.max(p);
            }
        };
        for placed in &self.placed {
            let m = &placed.mesh;
            for t in &m.indices {
                for &i in t {
                    add(m.positions[i as usize]);
                }
            }
        }
        for &(c, r, _) in &self.spheres {
            add(c - r as f64);
            add(c + r as f64);
        }
        (lo, hi)
    }

    /// Mutable access to the scene being built (film, defaults, lens,
    /// lights without a position).
    pub fn scene_mut(&mut self) -> &mut Scene {
        &mut self.scene
    }

    /// Finish: frame the scene if no camera was set, rebase everything to
    /// [`render_origin`] and convert it to f32. A scene in which nothing
    /// emits (no emitting triangle or sphere, no point, directional or
    /// environment light) renders black: it gets a warning saying so.
    pub fn build(mut self) -> Scene {
        let camera = match self.camera {
            Some(c) => c,
            None => {
                let (lo, hi) = self.world_bounds();
                self.scene
                    .notes
                    .push("no camera: framed automatically from the scene bounds".to_string());
                WorldCamera::framing(lo, hi)
            }
        };
        let origin = render_origin(&camera);
        self.scene.world_origin = origin;
        self.scene.camera = CameraDesc {
            origin: (camera.origin - origin).as_vec3(),
            target: (camera.target - origin).as_vec3(),
            up: camera.up,
            fov_y: camera.fov_y,
        };
        if let Some(f) = self.scene.focal_pixels {
            self.scene.set_focal_pixels(f);
        }
        for placed in std::mem::take(&mut self.placed) {
            self.rebase(placed, origin);
        }
        for (c, radius, m) in std::mem::take(&mut self.spheres) {
            self.scene.spheres.push(Sphere {
                center: (c - origin).as_vec3(),
                radius,
            });
            self.scene.sphere_material.push(m);
        }
        for (p, mut light) in std::mem::take(&mut self.point_lights) {
            light.position = (p - origin).as_vec3();
            self.scene.point_lights.push(light);
        }
        let s = &self.scene;
        let emits = |m: u32| s.materials[m as usize].emission.max_element() > 0.0;
        let lit = s.tri_material.iter().any(|&m| emits(m))
            || s.sphere_material.iter().any(|&m| emits(m))
            || s.point_lights
                .iter()
                .any(|l| l.intensity.max_element() > 0.0)
            || s.directional_lights
                .iter()
                .any(|l| l.irradiance().max_element() > 0.0)
            || s.environment.is_some_and(|e| e.max_element() > 0.0)
            || s.environment_map.is_some();
        if !lit && self.light_if_dark {
            self.scene.environment = Some(Vec3::ONE);
            self.scene.notes.push(
                "nothing emits light: lighting the scene with a uniform white environment"
                    .to_string(),
            );
        } else if !lit {
            let file = crate::error::one_line(&s.source.display().to_string()).into_owned();
            self.scene.warnings.push(format!(
                "{file}: nothing emits light (no emitting surface, point, directional or environment light): the image will be black"
            ));
        }
        self.scene
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn triangle(name: &str) -> MeshData {
        MeshData {
            name: name.to_string(),
            positions: vec![DVec3::ZERO, DVec3::X, DVec3::Y],
            indices: vec![[0, 1, 2]],
            tri_material: vec![0],
            materials: vec![Material::default()],
            ..MeshData::default()
        }
    }

    #[test]
    fn a_mesh_listed_past_the_triangle_limit_is_refused_at_its_line() {
        let mut b = SceneBuilder::new(Path::new("s.toml"));
        b.max_triangles = 3;
        for line in 1..=3 {
            b.add_mesh_from(triangle("t.obj"), &Transform::default(), Some(line))
                .unwrap();
        }
        let e = b
            .add_mesh_from(triangle("t.obj"), &Transform::default(), Some(4))
            .unwrap_err()
            .to_string();
        assert_eq!(
            e,
            "s.toml:4: mesh `t.obj` (1 triangles) would take the scene to 4 triangles (at most 3)"
        );
        assert_eq!(b.triangle_count(), 3, "nothing added on refusal");
        assert_eq!(b.build().meshes.len(), 3);
    }

    #[test]
    fn inconsistent_meshes_are_refused_not_indexed() {
        let mut bad_index = triangle("a");
        bad_index.indices[0][2] = 3;
        let mut bad_material = triangle("b");
        bad_material.tri_material[0] = 1;
        let mut short_materials = triangle("c");
        short_materials.tri_material.clear();
        for mesh in [bad_index, bad_material, short_materials] {
            let mut b = SceneBuilder::new(Path::new("s.toml"));
            let name = mesh.name.clone();
            let e = b.add_mesh_from(mesh, &Transform::default(), Some(2));
            let e = e.unwrap_err().to_string();
            assert!(e.starts_with(&format!("s.toml:2: mesh `{name}`")), "{e}");
            assert_eq!(b.triangle_count(), 0);
        }
    }

    #[test]
    fn out_of_range_and_degenerate_triangles_are_reported_apart() {
        let mut b = SceneBuilder::new(Path::new("s.toml"));
        let mut mesh = triangle("m");
        // a degenerate triangle (repeated corner) next to the good one
        mesh.indices.push([0, 1, 1]);
        mesh.tri_material.push(0);
        b.add_mesh(mesh, &Transform::default());
        // corners at exactly MAX_COORDINATE are inside the range
        let far = Transform {
            scale: DVec3::splat(MAX_COORDINATE as f64),
            ..Transform::default()
        };
        b.add_mesh(triangle("edge"), &far);
        let beyond = Transform {
            translate: DVec3::new(0.0, -2.0 * MAX_COORDINATE as f64, 0.0),
            ..Transform::default()
        };
        b.add_mesh(triangle("beyond"), &beyond);
        b.set_camera(WorldCamera {
            origin: DVec3::new(0.0, 0.0, 5.0),
            target: DVec3::ZERO,
            up: Vec3::Y,
            fov_y: 40.0,
        });
        let s = b.build();
        assert_eq!(s.triangle_count(), 2);
        assert_eq!(
            s.warnings,
            [
                "s.toml: mesh `beyond`: dropped 1 triangles with coordinates beyond 1.8e18 or non-finite after transform",
                // nothing in this test scene emits
                "s.toml: nothing emits light (no emitting surface, point, directional or environment light): the image will be black"
            ]
        );
        assert_eq!(
            s.notes,
            ["s.toml: mesh `m`: dropped 1 degenerate (zero-area) triangles"]
        );
    }

    fn camera_at(origin: DVec3, target: DVec3) -> WorldCamera {
        WorldCamera {
            origin,
            target,
            up: Vec3::Y,
            fov_y: 40.0,
        }
    }

    #[test]
    fn scenes_are_rebased_only_when_the_camera_is_far_from_the_origin() {
        // the Cornell box's own camera: nothing moves
        let near = camera_at(DVec3::new(0.0, 1.0, 3.9), DVec3::new(0.0, 1.0, 0.0));
        assert_eq!(render_origin(&near), DVec3::ZERO);
        // the same view at scale 1e-3, 1e4 away: rebased to the camera's
        // position on a power-of-two grid about 8 times the view distance
        let o = DVec3::splat(1e4);
        let far = camera_at(o + 1e-3 * near.origin, o + 1e-3 * near.target);
        let r = render_origin(&far);
        let step = 1.0 / 32.0;
        assert!((r - far.origin).abs().max_element() <= step / 2.0, "{r}");
        assert_eq!(r % step, DVec3::ZERO, "{r} is on the grid");
        // a degenerate view keeps the world as it is
        assert_eq!(render_origin(&camera_at(o, o)), DVec3::ZERO);
        // a unit view distance a rounding error either side of 1 (a Mitsuba
        // `to_world` camera) gives the same grid
        for l in [1.0 - 1e-7, 1.0, 1.0 + 1e-7] {
            let c = camera_at(DVec3::new(0.0, 2.2, 5.0), DVec3::new(0.0, 2.2, 5.0 - l));
            assert_eq!(render_origin(&c), DVec3::new(0.0, 0.0, 8.0), "{l}");
        }
    }

    #[test]
    fn a_rebased_scene_keeps_its_precision_and_its_shape() {
        let o = DVec3::new(1e6, -1e6, 1e6);
        let mut b = SceneBuilder::new(Path::new("s.toml"));
        let mut mesh = triangle("t");
        let s = 1e-4;
        mesh.positions = vec![o, o + DVec3::new(s, 0.0, 0.0), o + DVec3::new(0.0, s, 0.0)];
        b.add_mesh(mesh, &Transform::default());
        b.add_point_light(
            o + DVec3::new(0.0, 0.0, s),
            PointLight::new(Vec3::ZERO, Vec3::ONE),
        );
        b.set_camera(camera_at(o + DVec3::new(0.0, 0.0, 4.0 * s), o));
        let scene = b.build();
        // in f32 at 1e6 the triangle would have collapsed (ulp 0.0625)
        assert_eq!(scene.triangle_count(), 1, "{:?}", scene.notes);
        let [p0, p1, p2] = scene.triangle(0);
        let back = |p: Vec3| p.as_dvec3() + scene.world_origin;
        for (p, want) in [(p0, o), (p1, o + DVec3::X * s), (p2, o + DVec3::Y * s)] {
            assert!((back(p) - want).length() < 1e-6 * s, "{p} -> {}", back(p));
        }
        let light = scene.point_lights[0].position;
        assert!((back(light) - (o + DVec3::Z * s)).length() < 1e-6 * s);
        let cam = scene.camera.origin;
        assert!((back(cam) - (o + DVec3::Z * 4.0 * s)).length() < 1e-6 * s);
    }

    #[test]
    fn a_flat_mesh_is_framed_face_on() {
        let floor = WorldCamera::framing(DVec3::new(-1.0, 0.0, -1.0), DVec3::new(1.0, 0.0, 1.0));
        assert_eq!(floor.target, DVec3::ZERO);
        assert!(floor.origin.y > 0.0 && floor.origin.x == 0.0 && floor.origin.z == 0.0);
        let wall = WorldCamera::framing(DVec3::new(0.0, -1.0, -1.0), DVec3::new(0.0, 1.0, 1.0));
        assert!(wall.origin.x > 0.0 && wall.origin.y == 0.0);
        let boxy = WorldCamera::framing(-DVec3::ONE, DVec3::ONE);
        assert!(boxy.origin.z > 0.0 && boxy.origin.x == 0.0 && boxy.origin.y == 0.0);
    }
}
