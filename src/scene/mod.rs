//! The immutable [`Scene`]: flat triangle arrays, materials, lights, camera and
//! render defaults, shared read-only by every render thread. One loader per
//! format fills it through [`SceneBuilder`], which is also where geometry is
//! cleaned (degenerate and non-finite triangles dropped and reported) so that
//! every backend sees the same triangles, and where the scene-wide limits of
//! [`limits`] are enforced.

mod collada;
mod cse;
pub mod limits;
mod mitsuba;
mod obj;
mod ply;
pub mod procedural;
mod toml_file;
mod xml;

use crate::accel::{Hit, Sphere};
use crate::bsdf::{Bsdf, Diffuse};
use crate::camera::{Camera, ThinLens};
use crate::error::{Error, Result};
use crate::integrator::{DirectStrategy, Roulette};
use crate::light::{DirectionalLight, EnvironmentMap, PointLight};
use crate::math::{Ray, SurfacePoint, Vec2, Vec3, needle_factor, triangle_normal};
use crate::texture::ImageTexture;
use std::path::{Path, PathBuf};
use std::sync::Arc;

pub use limits::{MAX_COORDINATE, MAX_PIXELS, MAX_RESOLUTION, MAX_TRIANGLES, MAX_VERTICES};
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

/// The pinhole camera as a scene file describes it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CameraDesc {
    /// Eye position.
    pub origin: Vec3,
    /// Point looked at.
    pub target: Vec3,
    /// Up direction (need not be orthogonal to the view direction).
    pub up: Vec3,
    /// Vertical field of view in degrees.
    pub fov_y: f32,
}

/// The vertical field of view, in degrees, of a focal length of `f` pixels
/// on an image `height` pixels high.
fn fov_for_focal(f: f32, height: u32) -> f32 {
    2.0 * (height as f32 / (2.0 * f)).atan().to_degrees()
}

/// Render settings a scene file may set; command-line flags override them.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RenderDefaults {
    /// Samples per pixel.
    pub spp: u32,
    /// Maximum path length in bounces.
    pub max_depth: u32,
    /// Light samples per shading point.
    pub light_samples: u32,
    /// Random seed.
    pub seed: u64,
    /// First bounce at which Russian roulette may end a path.
    pub rr_depth: u32,
    /// Direct-lighting strategy (`--direct`).
    pub direct: DirectStrategy,
    /// Russian roulette policy (`--rr`).
    pub roulette: Roulette,
    /// Set for scenes whose own renderer counts `-l` per light (CS184's
    /// `.dae`): see [`RenderDefaults::light_samples_for`].
    pub per_light: Option<LightCount>,
}

/// The lights a per-light `-l` loops over, as the CS184 course's
/// direct-lighting estimator does: `l` samples from each non-delta light
/// (area or ambient) and one from each delta light (point, directional).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct LightCount {
    /// Lights sampled `l` times each.
    pub sampled: u32,
    /// Lights sampled once each.
    pub delta: u32,
}

impl RenderDefaults {
    /// Light samples per shading point for a `-l` value (`None`: the
    /// scene's own). Per shading point unless the scene counts per light;
    /// then `-l l` gives the course's total, `l * sampled + delta`, which
    /// this renderer spends on lights chosen by power (with one area light,
    /// exactly the course's estimator).
    pub fn light_samples_for(&self, l: Option<u32>) -> u64 {
        match (l, self.per_light) {
            (None, _) => self.light_samples as u64,
            (Some(l), None) => l.max(1) as u64,
            (Some(l), Some(c)) => (l.max(1) as u64 * c.sampled as u64 + c.delta as u64).max(1),
        }
    }
}

impl Default for RenderDefaults {
    fn default() -> Self {
        RenderDefaults {
            spp: 64,
            max_depth: 64,
            light_samples: 1,
            seed: 0,
            rr_depth: 3,
            direct: DirectStrategy::Mis,
            roulette: Roulette::Throughput,
            per_light: None,
        }
    }
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
    /// Vertex positions in world space.
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
    /// The camera.
    pub camera: CameraDesc,
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

    /// A camera that frames the scene's bounds from the +z side.
    pub fn framing_camera(bounds: &Bounds) -> CameraDesc {
        let fov_y = 39.3f32;
        let (centre, radius) = if bounds.is_empty() {
            (Vec3::ZERO, 1.0)
        } else {
            let c = 0.5 * (bounds.min + bounds.max);
            (c, (0.5 * (bounds.max - bounds.min).length()).max(1e-6))
        };
        let dist = radius / (0.5 * fov_y.to_radians()).sin() * 1.05;
        CameraDesc {
            origin: centre + Vec3::new(0.0, 0.0, dist),
            target: centre,
            up: Vec3::Y,
            fov_y,
        }
    }
}

/// The largest scene file read whole (an XML tree or a `.test` file's
/// lines are held in memory).
pub const MAX_SCENE_FILE_BYTES: u64 = 256 << 20;

/// A text scene file, read whole: refused beyond [`MAX_SCENE_FILE_BYTES`],
/// and with the line of the first byte that is not UTF-8.
fn read_scene_text(path: &Path) -> Result<String> {
    let size = std::fs::metadata(path)
        .map_err(|e| Error::io(path, e))?
        .len();
    if size > MAX_SCENE_FILE_BYTES {
        return Err(Error::input(
            path,
            None,
            format!(
                "{size} bytes: larger than the {MAX_SCENE_FILE_BYTES} bytes a scene file may have"
            ),
        ));
    }
    let bytes = std::fs::read(path).map_err(|e| Error::io(path, e))?;
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

/// An affine placement: scale, then rotate about an axis, then translate.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Transform {
    /// Per-axis scale.
    pub scale: Vec3,
    /// Rotation axis (any length but zero) and angle in degrees.
    pub rotate: Option<(Vec3, f32)>,
    /// Translation.
    pub translate: Vec3,
}

impl Default for Transform {
    fn default() -> Self {
        Transform {
            scale: Vec3::ONE,
            rotate: None,
            translate: Vec3::ZERO,
        }
    }
}

impl Transform {
    /// The matrix `T * R * S`.
    pub fn matrix(&self) -> glam::Affine3A {
        let r = match self.rotate {
            Some((axis, deg)) => glam::Quat::from_axis_angle(axis.normalize(), deg.to_radians()),
            None => glam::Quat::IDENTITY,
        };
        glam::Affine3A::from_scale_rotation_translation(self.scale, r, self.translate)
    }
}

/// A mesh as a loader reads it, before placement: positions, triangles and a
/// material index per triangle into `materials`.
#[derive(Debug, Clone, Default)]
pub struct MeshData {
    /// Name for messages.
    pub name: String,
    /// Vertex positions.
    pub positions: Vec<Vec3>,
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
            let p = t.map(|i| self.positions[i as usize]);
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

/// Accumulates meshes into a [`Scene`], dropping triangles no backend should see.
#[derive(Debug)]
pub struct SceneBuilder {
    scene: Scene,
    /// [`MAX_TRIANGLES`], lowered by unit tests.
    max_triangles: u64,
}

impl SceneBuilder {
    /// An empty scene read from `source`.
    pub fn new(source: &Path) -> Self {
        SceneBuilder {
            scene: Scene {
                source: source.to_path_buf(),
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
                camera: Scene::framing_camera(&Bounds::empty()),
                lens: ThinLens::PINHOLE,
                focal_pixels: None,
                resolution: [512, 512],
                render: RenderDefaults::default(),
                notes: Vec::new(),
                warnings: Vec::new(),
            },
            max_triangles: MAX_TRIANGLES,
        }
    }

    /// Add a mesh placed by `transform`. Triangles whose corners become
    /// non-finite or leave [`MAX_COORDINATE`] are dropped with one warning
    /// naming the mesh; zero-area triangles are dropped with a note. For
    /// meshes built in code (tests, parity scenes); loaders use
    /// [`SceneBuilder::add_mesh_from`], which also enforces the scene limits.
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
    /// format's matrix): normals go through the inverse transpose, and a
    /// mirroring matrix (negative determinant) reverses the winding.
    pub fn add_mesh_matrix(
        &mut self,
        mesh: MeshData,
        matrix: glam::Affine3A,
        line: Option<usize>,
    ) -> Result<()> {
        let s = &self.scene;
        let fail = |msg: String| Err(Error::input(&s.source, line, msg));
        let tris = s.indices.len() as u64 + mesh.indices.len() as u64;
        if tris > self.max_triangles {
            return fail(format!(
                "mesh `{}` ({} triangles) would take the scene to {tris} triangles (at most {})",
                mesh.name,
                mesh.indices.len(),
                self.max_triangles
            ));
        }
        let verts = s.positions.len() as u64 + mesh.positions.len() as u64;
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

    /// Place `mesh` and report what was dropped.
    fn place(&mut self, mesh: MeshData, m: glam::Affine3A, line: Option<usize>) {
        let s = &mut self.scene;
        let flip = m.matrix3.determinant() < 0.0;
        let base_material = s.materials.len() as u32;
        s.materials.extend(mesh.materials);
        let base_vertex = s.positions.len() as u32;
        s.positions
            .extend(mesh.positions.iter().map(|&p| m.transform_point3(p)));
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
        let normal_matrix = m.matrix3.inverse().transpose();
        let (mut out_of_range, mut degenerate, mut lost_emitters) = (0usize, 0usize, 0usize);
        for (k, (t, &mat)) in mesh.indices.iter().zip(&mesh.tri_material).enumerate() {
            let mut idx = t.map(|i| i + base_vertex);
            let mut uv = mesh.uvs.get(k).copied().unwrap_or([Vec2::ZERO; 3]);
            let mut ns = mesh.normals.get(k).map_or([Vec3::ZERO; 3], |c| {
                c.map(|n| {
                    // a zero, non-finite or degenerate normal shades flat; a
                    // unit one (to a few ulps) is kept as it is, so that a
                    // scene written out with its normals reads back to the
                    // same bits
                    let w = Vec3::from(normal_matrix * glam::Vec3A::from(n));
                    let w = if (w.length_squared() - 1.0).abs() <= 4.0 * f32::EPSILON {
                        w
                    } else {
                        w.normalize_or_zero()
                    };
                    if w.is_finite() { w } else { Vec3::ZERO }
                })
            });
            if flip {
                idx.swap(1, 2);
                uv.swap(1, 2);
                ns.swap(1, 2);
            }
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
                s.tri_uv.push(uv);
            }
            if keep_normals {
                // a corner whose normal faces away from the triangle's front
                // is flipped, so each interpolated normal is on the front
                // side at that corner
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
                "{at}: mesh `{name}`: {lost_emitters} emitting triangles have zero area in f32 after the transform (too small for their distance from the origin?), so the light they made is gone"
            ));
        }
        let end = s.indices.len() as u32;
        s.meshes.push(MeshRange {
            name: mesh.name,
            start,
            end,
        });
    }

    /// Add an analytic sphere with its own material, which the scene file
    /// describes at `line`. A textured material is fine: spheres have their
    /// own texture coordinates.
    pub fn add_sphere(
        &mut self,
        sphere: Sphere,
        material: Material,
        line: Option<usize>,
    ) -> Result<()> {
        let s = &mut self.scene;
        if s.spheres.len() as u64 >= self.max_triangles {
            return Err(Error::input(
                &s.source,
                line,
                format!("more than {} spheres", self.max_triangles),
            ));
        }
        s.sphere_material.push(s.materials.len() as u32);
        s.materials.push(material);
        s.spheres.push(sphere);
        Ok(())
    }

    /// Triangles placed so far.
    pub fn triangle_count(&self) -> u64 {
        self.scene.indices.len() as u64
    }

    /// Vertices placed so far.
    pub fn vertex_count(&self) -> u64 {
        self.scene.positions.len() as u64
    }

    /// Mutable access to the scene being built (camera, film, defaults, lights).
    pub fn scene_mut(&mut self) -> &mut Scene {
        &mut self.scene
    }

    /// Finish. A scene in which nothing emits (no emitting triangle or
    /// sphere, no point, directional or environment light) renders black:
    /// it gets a warning saying so.
    pub fn build(mut self) -> Scene {
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
        if !lit {
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
            positions: vec![Vec3::ZERO, Vec3::X, Vec3::Y],
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
            scale: Vec3::splat(MAX_COORDINATE),
            ..Transform::default()
        };
        b.add_mesh(triangle("edge"), &far);
        let beyond = Transform {
            translate: Vec3::new(0.0, -2.0 * MAX_COORDINATE, 0.0),
            ..Transform::default()
        };
        b.add_mesh(triangle("beyond"), &beyond);
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
}
