//! The immutable [`Scene`]: flat triangle arrays, materials, lights, camera and
//! render defaults, shared read-only by every render thread. One loader per
//! format fills it through [`SceneBuilder`], which is also where geometry is
//! cleaned (degenerate and non-finite triangles dropped and reported) so that
//! every backend sees the same triangles, and where the scene-wide limits of
//! [`crate::limits`] are enforced.
//!
//! Files: this one holds the [`Scene`] and its [`Material`]s; `builder.rs`
//! places, cleans and rebases what loaders read; `mesh.rs` is a mesh as read
//! and its placement; `input.rs` reads files under their size caps; one file
//! (or folder) per format: `toml_file`, `obj`, `ply`, `mitsuba`, `collada`,
//! `cse`.

mod alpha;
mod builder;
mod collada;
mod cse;
mod gltf;
mod input;
mod instances;
pub mod maps;
mod mesh;
mod mitsuba;
mod obj;
mod pbrt;
mod ply;
pub mod procedural;
mod toml_file;
mod xml;

use crate::accel::Hit;
use crate::bsdf::{Bsdf, Diffuse};
use crate::camera::{Camera, CameraDesc, ThinLens};
use crate::error::{Error, Result};
use crate::light::{DirectionalLight, EnvironmentMap, PanelLight, PointLight, SpotLight};
use crate::math::{DVec3, Ray, SurfacePoint, Vec2, Vec3, trig};
use crate::settings::RenderDefaults;
use crate::shape::Sphere;
use crate::texture::ImageTexture;
use glam::Mat3;
use std::path::{Path, PathBuf};
use std::sync::Arc;

pub use alpha::AlphaMask;
pub use builder::{SceneBuilder, WorldCamera, render_origin};
pub use gltf::LUMENS_PER_WATT;
use input::read_scene_text;
pub(crate) use input::{Content, not_a_file, read_bounded};
pub use instances::{NO_OVERRIDE, PrototypeShading, SceneInstances};
pub use maps::{BumpMap, Maps};
pub use mesh::{MeshData, Transform};
pub use obj::load_obj_mesh;
pub use ply::{MAX_POLYGON, load_ply_mesh};

/// What the estimator does with a material's emission. Every scene format
/// gives [`EmissionRole::Light`] except where the file's own renderer means
/// otherwise (the CS184 course's `.dae` scenes, [`collada`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum EmissionRole {
    /// An area light: light sampling picks it, BSDF samples find it, and
    /// multiple importance sampling weighs the two.
    #[default]
    Light,
    /// Seen, never sampled: the emission counts where a camera ray finds
    /// it, or a delta bounce (mirror, glass) that is not the path's last
    /// (`max_depth`), and nowhere else. It is not among the lights, and a
    /// non-delta bounce that finds it adds nothing, since the light it
    /// stands for lights the scene otherwise. This is the CS184 course's
    /// emissive `light` mesh, whose light comes from its CGL area light
    /// ([`crate::light::PanelLight`]): the course's `EmissionBSDF` is seen
    /// by `zero_bounce_radiance`, which the course adds for camera rays and,
    /// in `at_least_one_bounce_radiance`, for the hit of a delta bounce
    /// that the ray's depth lets go on; its mesh lights are never sampled.
    SeenOnly,
}

/// A surface material: a BSDF, an optional albedo texture, and emission.
#[derive(Debug, Clone, PartialEq)]
pub struct Material {
    /// Name (from the .mtl file, or a generated one).
    pub name: String,
    /// How the surface scatters light. Checked by [`Bsdf::validate`] when
    /// loaded.
    pub bsdf: Bsdf,
    /// An albedo texture (shared by every material that names its file) that replaces the
    /// diffuse albedo of a `diffuse` BSDF, the base of a `plastic` one or
    /// the base colour of a `metallic_roughness` one,
    /// looked up at the surface's texture coordinates.
    pub texture: Option<Arc<ImageTexture>>,
    /// Emitted radiance (an area light when non-zero); the mean of
    /// `maps.emission` when that is set.
    pub emission: Vec3,
    /// Emit from both sides (otherwise only from the front, where the
    /// triangle winds counter-clockwise or the sphere's normal points out).
    pub two_sided: bool,
    /// What the estimator does with the emission ([`EmissionRole`]).
    pub role: EmissionRole,
    /// Black seen from behind: where `wo` is below the front shading normal
    /// (the interpolated vertex normal, else the geometric one), the
    /// surface neither reflects nor transmits and a path that reaches it
    /// ends there (its emission still counts, by `two_sided`). Mitsuba 3's
    /// reflective BSDFs (`diffuse`, the conductors, the plastics) are so
    /// unless wrapped in `twosided`; every other format's surfaces, and the
    /// TOML format's, reflect on both sides.
    pub one_sided: bool,
    /// Textures on the other parameters, and a normal or bump map.
    pub maps: Maps,
    /// Cut-outs: the surface's opacity (see [`AlphaMask`]); `None` is
    /// opaque.
    pub alpha_mask: Option<AlphaMask>,
}

impl Material {
    /// Whether the material is an area light, one that light sampling
    /// picks: it emits, with [`EmissionRole::Light`].
    pub fn is_light(&self) -> bool {
        self.emission.max_element() > 0.0 && self.role == EmissionRole::Light
    }

    /// Whether the material emits with [`EmissionRole::SeenOnly`].
    pub fn is_seen_only(&self) -> bool {
        self.emission.max_element() > 0.0 && self.role == EmissionRole::SeenOnly
    }

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

    /// The textured parameters, by the key scene files give them, with
    /// their textures (the diffuse albedo's as `texture`).
    pub fn textured(&self) -> Vec<(&'static str, &Arc<ImageTexture>)> {
        let m = &self.maps;
        [
            ("texture", self.texture.as_ref()),
            (Maps::specular_key(&self.bsdf), m.specular.as_ref()),
            ("transmittance", m.transmittance.as_ref()),
            ("alpha", m.alpha.as_ref()),
            ("emission", m.emission.as_ref()),
            ("metallic_roughness", m.metallic_roughness.as_ref()),
        ]
        .into_iter()
        .filter_map(|(k, t)| t.map(|t| (k, t)))
        .collect()
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
            Bsdf::MetallicRoughness(_) => "metallic_roughness",
            Bsdf::ThinGlass(_) => "thin_glass",
            Bsdf::RoughGlass(_) => "rough_glass",
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
            role: EmissionRole::Light,
            one_sided: false,
            maps: Maps::default(),
            alpha_mask: None,
        }
    }
}

/// The vertical field of view, in degrees, of a focal length of `f` pixels
/// on an image `height` pixels high.
fn fov_for_focal(f: f32, height: u32) -> f32 {
    2.0 * (height as f32 / (2.0 * f)).atan().to_degrees()
}

/// Choices a scene file leaves to whoever reads it.
#[derive(Debug, Clone, Default)]
pub struct LoadOptions {
    /// The camera to render through, by name, in a format that holds
    /// several (glTF): `None` takes the file's first.
    pub camera: Option<String>,
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
    /// Per triangle, the derivatives `[dp/du, dp/dv]` of the position with
    /// respect to the texture coordinates (the tangent frame of normal and
    /// bump maps), when some material needs them: empty, or one entry per
    /// triangle (zeros for triangles whose material needs none, or whose
    /// UVs are degenerate). Computed once by the builder
    /// ([`maps::uv_derivatives`]); read through [`Scene::uv_derivatives`].
    pub tri_dpduv: Vec<[Vec3; 2]>,
    /// Analytic spheres; sphere `i` is primitive `triangle_count() + i`.
    pub spheres: Vec<Sphere>,
    /// Material index per sphere.
    pub sphere_material: Vec<u32>,
    /// Per sphere, the rotation (or reflection) that takes a world
    /// direction from its centre into the frame where [`Scene::uv`]'s
    /// mapping applies (pole `+y`, `u` from `+x` towards `-z`); empty when
    /// every sphere uses the world's axes. A Mitsuba 3 sphere maps its
    /// local `+z` pole there, with its `to_world` rotation (Mitsuba's
    /// `u = atan2(y, x) / 2 pi`, `v = acos(z) / pi` in the sphere's frame).
    pub sphere_uv_frames: Vec<Mat3>,
    /// Instanced meshes: prototypes stored once and their placements, whose
    /// triangles are the primitives after the spheres.
    pub instances: SceneInstances,
    /// Radiance of the uniform environment light, if any.
    pub environment: Option<Vec3>,
    /// The image-based environment light, if any.
    pub environment_map: Option<EnvironmentMap>,
    /// Point lights.
    pub point_lights: Vec<PointLight>,
    /// Spot lights.
    pub spot_lights: Vec<SpotLight>,
    /// Directional lights.
    pub directional_lights: Vec<DirectionalLight>,
    /// Panel lights: emitting rectangles that are no surface, lighting by
    /// light sampling alone (the CS184 course's area lights).
    pub panel_lights: Vec<PanelLight>,
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
    /// has no emitters), `.xml` (Mitsuba 3), `.dae` (CS184 COLLADA),
    /// `.test` (CSE 167/168), `.gltf` and `.glb` (glTF 2.0) or `.pbrt`
    /// (pbrt-v4).
    pub fn load(path: &Path) -> Result<Scene> {
        Self::load_with(path, &LoadOptions::default())
    }

    /// [`Scene::load`] with the choices the file leaves to its reader.
    pub fn load_with(path: &Path, options: &LoadOptions) -> Result<Scene> {
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
        if options.camera.is_some() && !matches!(ext.as_str(), "gltf" | "glb") {
            return Err(Error::input(
                path,
                None,
                "--camera picks one of a glTF file's cameras; this format has one camera",
            ));
        }
        match ext.as_str() {
            "toml" => toml_file::load(path),
            "obj" => obj::load_bare(path),
            "ply" => bare_scene(path, load_ply_mesh(path)?),
            "xml" => mitsuba::load(path),
            "test" => cse::load(path),
            "dae" => collada::load(path),
            "gltf" | "glb" => gltf::load(path, options),
            "pbrt" => pbrt::load(path, options),
            _ => Err(Error::input(
                path,
                None,
                format!(
                    "unknown scene format `.{ext}` (expected .toml, .obj, .ply, Mitsuba 3 .xml, CS184 .dae, CSE 167/168 .test, glTF 2.0 .gltf or .glb, or pbrt-v4 .pbrt)"
                ),
            )),
        }
    }

    /// Number of placed (not instanced) triangles.
    pub fn triangle_count(&self) -> usize {
        self.indices.len()
    }

    /// Number of triangles a ray may meet: placed ones plus every
    /// placement's (what brute force pays for).
    pub fn traced_triangle_count(&self) -> u64 {
        self.indices.len() as u64 + self.instances.triangle_count()
    }

    /// The first instanced primitive: placed triangles and spheres come
    /// before.
    #[inline]
    fn first_instanced(&self) -> usize {
        self.indices.len() + self.spheres.len()
    }

    /// The placement and prototype triangle of primitive `prim`, if it is
    /// an instanced one.
    #[inline]
    pub fn instanced(&self, prim: u32) -> Option<(usize, u32)> {
        ((prim as usize) >= self.first_instanced()).then(|| self.instances.locate(prim))
    }

    /// The three corners of triangle `prim` (placed or instanced), in render
    /// space.
    #[inline]
    pub fn triangle(&self, prim: u32) -> [Vec3; 3] {
        match self.indices.get(prim as usize) {
            Some(t) => t.map(|i| self.positions[i as usize]),
            None => {
                let (k, t) = self.instances.locate(prim);
                self.instances.triangle(k, t)
            }
        }
    }

    /// Number of primitives: placed triangles, spheres, then instanced
    /// triangles.
    pub fn primitive_count(&self) -> usize {
        self.first_instanced() + self.instances.triangle_count() as usize
    }

    /// The sphere that primitive `prim` is, if it is one.
    #[inline]
    pub fn sphere(&self, prim: u32) -> Option<&Sphere> {
        (prim as usize)
            .checked_sub(self.indices.len())
            .and_then(|i| self.spheres.get(i))
    }

    /// The material index of primitive `prim` (a triangle, a sphere or an
    /// instanced triangle).
    #[inline]
    pub fn material_index(&self, prim: u32) -> u32 {
        let nt = self.indices.len();
        match (prim as usize).checked_sub(nt) {
            None => self.tri_material[prim as usize],
            Some(i) => match self.sphere_material.get(i) {
                Some(&m) => m,
                None => {
                    let (k, t) = self.instances.locate(prim);
                    self.instances.material_index(k, t)
                }
            },
        }
    }

    /// The material of primitive `prim` (a triangle or a sphere).
    #[inline]
    pub fn material(&self, prim: u32) -> &Material {
        &self.materials[self.material_index(prim) as usize]
    }

    /// The surface point at barycentrics `(u, v)` of placed triangle `prim`,
    /// rebuilt from the vertex buffer with its error bound.
    #[inline]
    pub fn surface_point_placed(&self, prim: u32, u: f32, v: f32) -> SurfacePoint {
        let i = prim as usize;
        let p = self.indices[i].map(|k| self.positions[k as usize]);
        SurfacePoint::on_triangle_with(p, u, v, self.normals[i], self.needle[i])
    }

    /// The surface point at barycentrics `(u, v)` of triangle `prim`, placed
    /// ([`Scene::surface_point_placed`]) or instanced
    /// ([`SceneInstances::surface_point`]).
    #[inline]
    pub fn surface_point(&self, prim: u32, u: f32, v: f32) -> SurfacePoint {
        if (prim as usize) < self.indices.len() {
            self.surface_point_placed(prim, u, v)
        } else {
            let (k, t) = self.instances.locate(prim);
            self.instances.surface_point(k, t, u, v)
        }
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

    /// The vertex normals of triangle `prim` (render space), when all three
    /// of its corners have one; `None` for spheres and flat triangles.
    #[inline]
    pub fn corner_normals(&self, prim: u32) -> Option<[Vec3; 3]> {
        if (prim as usize) < self.first_instanced() {
            let c = self.tri_shading_normals.get(prim as usize)?;
            return c.iter().all(|n| *n != Vec3::ZERO).then_some(*c);
        }
        let (k, t) = self.instances.locate(prim);
        self.instances.corner_normals(k, t)
    }

    /// Texture coordinates at a surface point: interpolated corner UVs on a
    /// triangle (zero when its mesh has none), or on a sphere, from its outward
    /// normal `n`, `u = atan2(-n.z, n.x) / 2 pi` wrapped to `[0, 1)` and
    /// `v = 1 - acos(n.y) / pi`, so `v = 1` at the top (+y) pole.
    pub fn uv(&self, prim: u32, sp: &SurfacePoint, u: f32, v: f32) -> Vec2 {
        let corners = match self.instanced(prim) {
            Some((k, t)) => self.instances.uv(k, t),
            None => self.tri_uv.get(prim as usize).copied(),
        };
        match self.sphere(prim) {
            None => match corners {
                Some(t) => (1.0 - u - v) * t[0] + u * t[1] + v * t[2],
                None => Vec2::ZERO,
            },
            Some(_) => {
                let n = self.sphere_uv_frame(prim).map_or(sp.n, |f| f * sp.n);
                let phi = trig::atan2(-n.z, n.x);
                let phi = if phi < 0.0 {
                    phi + std::f32::consts::TAU
                } else {
                    phi
                };
                let theta = trig::acos(n.y.clamp(-1.0, 1.0));
                Vec2::new(
                    phi / std::f32::consts::TAU,
                    1.0 - theta / std::f32::consts::PI,
                )
            }
        }
    }

    /// The derivatives `[dp/du, dp/dv]` of the surface position with respect
    /// to the texture coordinates at `sp` on primitive `prim`: from the
    /// builder's per-triangle table, or on a sphere from its UV mapping
    /// ([`Scene::uv`]). `None` where they are degenerate (a triangle with
    /// degenerate UVs, a sphere's poles) or were not computed (a triangle
    /// whose material has no normal or bump map): the caller then builds a
    /// frame around the normal alone.
    pub fn uv_derivatives(&self, prim: u32, sp: &SurfacePoint) -> Option<[Vec3; 2]> {
        if let Some((k, t)) = self.instanced(prim) {
            // an instance's, from its render-space corners (per hit: a
            // table per placement would grow with the placements)
            let uv = self.instances.uv(k, t)?;
            let d = maps::triangle_uv_derivatives(self.instances.triangle(k, t), uv);
            return (d[0] != Vec3::ZERO && d[1] != Vec3::ZERO).then_some(d);
        }
        match self.sphere(prim) {
            None => self
                .tri_dpduv
                .get(prim as usize)
                .filter(|d| d[0] != Vec3::ZERO && d[1] != Vec3::ZERO)
                .copied(),
            Some(s) => match self.sphere_uv_frame(prim) {
                None => maps::sphere_uv_derivatives(s.radius, sp.n),
                Some(f) => maps::sphere_uv_derivatives(s.radius, f * sp.n)
                    .map(|d| d.map(|v| f.transpose() * v)),
            },
        }
    }

    /// [`Scene::sphere_uv_frames`]'s entry for primitive `prim`, a sphere.
    #[inline]
    fn sphere_uv_frame(&self, prim: u32) -> Option<Mat3> {
        let i = (prim as usize).checked_sub(self.indices.len())?;
        self.sphere_uv_frames.get(i).copied()
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

    /// Axis-aligned bounds of all vertices used by triangles, of all
    /// spheres and of every placement's box: `(min, max)`.
    pub fn bounds(&self) -> Bounds {
        let mut b = Bounds::empty();
        if !self.instances.is_empty() {
            let (lo, hi) = self.instances.bounds();
            if lo.x <= hi.x {
                b.extend(lo);
                b.extend(hi);
            }
        }
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
            instances: self.instances.soup(),
            masked: self.alpha_test().is_some(),
        }
    }

    /// The material indices some primitive uses (instanced ones included),
    /// each once, in increasing order.
    pub fn used_materials(&self) -> Vec<u32> {
        let mut used = vec![false; self.materials.len()];
        for &m in self.tri_material.iter().chain(&self.sphere_material) {
            used[m as usize] = true;
        }
        let inst = &self.instances;
        for (k, p) in inst.placements.iter().enumerate() {
            let proto = &inst.shading[p.prototype as usize];
            match inst.material[k] {
                NO_OVERRIDE => proto
                    .tri_material
                    .iter()
                    .for_each(|&m| used[m as usize] = true),
                m if !proto.tri_material.is_empty() => used[m as usize] = true,
                _ => {}
            }
        }
        (0..self.materials.len() as u32)
            .filter(|&m| used[m as usize])
            .collect()
    }

    /// Whether the material of some primitive emits with
    /// [`EmissionRole::SeenOnly`].
    pub fn seen_only_emitters(&self) -> bool {
        self.used_materials()
            .iter()
            .any(|&m| self.materials[m as usize].is_seen_only())
    }

    /// Whether any material of a primitive emits.
    pub fn has_emitters(&self) -> bool {
        self.used_materials()
            .iter()
            .any(|&m| self.materials[m as usize].emission.max_element() > 0.0)
    }
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
