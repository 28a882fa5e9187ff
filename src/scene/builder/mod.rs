//! [`SceneBuilder`], the one way a loader makes a [`Scene`]: it gathers
//! meshes, spheres, point lights and the [`WorldCamera`] in world space
//! (f64), drops the triangles no backend should see (degenerate, non-finite,
//! beyond [`MAX_COORDINATE`]) with one warning each, holds the scene to the
//! limits of [`crate::limits`], and rebases everything to [`render_origin`]
//! before it becomes f32.

use super::instances::{NO_OVERRIDE, PrototypeShading, SceneInstances};
use super::{AlphaMask, Material, MeshData, MeshRange, Scene, Transform};
use crate::accel::{Placement, Prototype};
use crate::camera::{CameraDesc, ThinLens};
use crate::error::{Error, Result};
use crate::light::{PanelLight, PointLight, SpotLight};
use crate::limits::{MAX_COORDINATE, MAX_TRIANGLES, MAX_VERTICES};
use crate::math::{DVec3, Vec2, Vec3, needle_factor, triangle_normal};
use crate::settings::RenderDefaults;
use crate::shape::Sphere;
use glam::{DAffine3, Mat3};
use std::path::Path;

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
    /// The up vector a camera at `origin` looking at `target` uses: `up`
    /// scaled to a largest component of magnitude 1 (so that no finite value
    /// overflows in f32; a second call leaves it as it is, so a converted
    /// scene keeps its bits), or `None` when the view is undefined: the two
    /// points equal, `up` zero or not finite, or `up` within 1e-6 radians of
    /// the view axis. The test is on unit vectors in f64, so a tiny or huge
    /// `up` (a component of 1e-39 became a denormal in f32 and made the
    /// camera's right vector, and every ray, NaN) is judged by its direction
    /// alone.
    pub fn usable_up(origin: DVec3, target: DVec3, up: DVec3) -> Option<Vec3> {
        let view = (target - origin).try_normalize()?;
        let scaled = up / up.abs().max_element();
        let unit = scaled.try_normalize()?;
        (view.cross(unit).length() >= 1e-6).then(|| scaled.as_vec3())
    }

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

/// A prototype mesh (object space, f64) waiting for the build.
#[derive(Debug)]
struct PrototypeIn {
    mesh: MeshData,
    /// Index of its first material in the scene's list.
    base_material: u32,
    line: Option<usize>,
}

/// A placement of a prototype waiting for the render origin.
#[derive(Debug)]
struct InstanceIn {
    prototype: u32,
    /// Object to world.
    matrix: DAffine3,
    /// Material override, or [`NO_OVERRIDE`].
    material: u32,
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
    /// Spheres' world centres, radii, material indices and texture frames.
    spheres: Vec<(DVec3, f32, u32, Mat3)>,
    /// Point lights and their world positions.
    point_lights: Vec<(DVec3, PointLight)>,
    /// Spot lights and their world positions.
    spot_lights: Vec<(DVec3, SpotLight)>,
    /// Panel lights and their world centres.
    panel_lights: Vec<(DVec3, PanelLight)>,
    /// The camera, unless the scene is to be framed.
    camera: Option<WorldCamera>,
    /// Light a scene in which nothing emits with a uniform white
    /// environment, with a note (a bare mesh), instead of warning.
    pub(super) light_if_dark: bool,
    /// Meshes stored once for instances to place.
    prototypes: Vec<PrototypeIn>,
    /// Their placements, in order.
    instances: Vec<InstanceIn>,
    /// Triangles the placements add up to (before degenerate ones drop).
    instanced_triangles: u64,
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
                tri_dpduv: Vec::new(),
                spheres: Vec::new(),
                sphere_material: Vec::new(),
                sphere_uv_frames: Vec::new(),
                instances: SceneInstances::default(),
                environment: None,
                environment_map: None,
                point_lights: Vec::new(),
                spot_lights: Vec::new(),
                directional_lights: Vec::new(),
                panel_lights: Vec::new(),
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
            spot_lights: Vec::new(),
            panel_lights: Vec::new(),
            camera: None,
            light_if_dark: false,
            prototypes: Vec::new(),
            instances: Vec::new(),
            instanced_triangles: 0,
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
        self.check_mesh(&mesh, line)?;
        self.place(mesh, matrix, line);
        Ok(())
    }

    /// Refuse `mesh` (described at `line`) if it would take the scene past
    /// [`MAX_TRIANGLES`] or [`MAX_VERTICES`] stored, or if it is
    /// inconsistent (an index out of range, a texture without texture
    /// coordinates).
    fn check_mesh(&self, mesh: &MeshData, line: Option<usize>) -> Result<()> {
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
        let used = |m: usize| mesh.tri_material.iter().any(|&t| t as usize == m);
        if let Some((_, m)) = mesh.materials.iter().enumerate().find(|(i, m)| {
            m.alpha_mask.is_some()
                && (m.emission.max_element() > 0.0 || m.maps.emission.is_some())
                && used(*i)
        }) {
            return fail(format!(
                "mesh `{}`: material `{}` emits light and has an alpha mask; an emitter cannot be cut out (light sampling would still see the holes)",
                mesh.name, m.name
            ));
        }
        if mesh.uvs.is_empty() {
            if let Some((_, m)) = mesh.materials.iter().enumerate().find(|(i, m)| {
                (m.texture.is_some()
                    || !m.textured().is_empty()
                    || m.maps.perturbs_normal()
                    || m.alpha_mask.as_ref().is_some_and(AlphaMask::is_textured))
                    && used(*i)
            }) {
                return fail(format!(
                    "mesh `{}` has no texture coordinates (vt), but its material `{}` has a texture",
                    mesh.name, m.name
                ));
            }
        }
        Ok(())
    }

    /// Store `mesh` (described at `line`) once, in its own object space, for
    /// [`SceneBuilder::add_instance`] to place; it is not placed itself.
    /// Its triangles count towards the stored-triangle limit once, however
    /// many instances place it. Returns the prototype's index.
    pub fn add_prototype(&mut self, mut mesh: MeshData, line: Option<usize>) -> Result<u32> {
        self.check_mesh(&mesh, line)?;
        let base_material = self.absorb(&mut mesh);
        self.prototypes.push(PrototypeIn {
            mesh,
            base_material,
            line,
        });
        Ok(self.prototypes.len() as u32 - 1)
    }

    /// The name of prototype `p`.
    pub fn prototype_name(&self, p: u32) -> &str {
        &self.prototypes[p as usize].mesh.name
    }

    /// Place prototype `prototype` by the object-to-world map `matrix`
    /// (composed in f64), with `material` instead of the prototype's own
    /// when given. The scene file describes it at `line`. A singular or
    /// non-finite matrix, an unknown prototype, or more instanced triangles
    /// than 32-bit primitive ids can number is an error naming `line`.
    pub fn add_instance(
        &mut self,
        prototype: u32,
        matrix: DAffine3,
        material: Option<Material>,
        line: Option<usize>,
    ) -> Result<()> {
        let fail = |msg: String| Err(Error::input(&self.scene.source, line, msg));
        let Some(proto) = self.prototypes.get(prototype as usize) else {
            return fail(format!("instance of unknown prototype {prototype}"));
        };
        let det = matrix.matrix3.determinant();
        if !(det.is_finite() && det != 0.0 && matrix.translation.is_finite()) {
            return fail(format!(
                "instance of `{}`: its transform is singular or not finite",
                crate::error::one_line(&proto.mesh.name)
            ));
        }
        let total = self.instanced_triangles + proto.mesh.indices.len() as u64;
        let placed = self.counts.0 + self.spheres.len() as u64;
        if placed + total > u32::MAX as u64 {
            return fail(format!(
                "instance of `{}` would take the scene to {} instanced triangles: primitive ids are 32-bit (at most {} in all)",
                crate::error::one_line(&proto.mesh.name),
                total,
                u32::MAX
            ));
        }
        self.instanced_triangles = total;
        // an override keeps the prototype's cut-out (a mesh's `alpha`
        // belongs to its shape, whatever material covers it)
        let base = proto.base_material as usize;
        let mask = proto
            .mesh
            .tri_material
            .iter()
            .find_map(|&m| self.scene.materials[base + m as usize].alpha_mask.clone());
        let material = match material {
            Some(mut m) => {
                if m.alpha_mask.is_none() {
                    m.alpha_mask = mask;
                }
                if m.alpha_mask.is_some()
                    && (m.emission.max_element() > 0.0 || m.maps.emission.is_some())
                {
                    return fail(format!(
                        "instance of `{}`: its material emits light and the mesh has an alpha mask; an emitter cannot be cut out",
                        crate::error::one_line(&proto.mesh.name)
                    ));
                }
                self.scene.materials.push(m);
                self.scene.materials.len() as u32 - 1
            }
            None => NO_OVERRIDE,
        };
        self.instances.push(InstanceIn {
            prototype,
            matrix,
            material,
            line,
        });
        Ok(())
    }

    /// Move the prototypes and placements into the scene, in render space:
    /// each prototype centred on its own box (the offset folded into its
    /// placements, so its f32 object coordinates stay small), degenerate
    /// triangles dropped in object space, each placement's matrix rebased
    /// to `origin` in f64 and rounded once. Runs after the placed triangles
    /// and spheres, whose primitive ids come first.
    fn build_instances(&mut self, origin: DVec3) {
        let s = &mut self.scene;
        let mut out = SceneInstances::default();
        let mut centres = Vec::new();
        for p in std::mem::take(&mut self.prototypes) {
            let (proto, shading, centre, dropped) = object_space(p.mesh, p.base_material);
            if dropped > 0 {
                let at = crate::error::Location {
                    file: s.source.clone(),
                    line: p.line,
                };
                s.notes.push(format!(
                    "{at}: mesh `{}`: dropped {dropped} degenerate or non-finite triangles",
                    crate::error::one_line(&shading.name)
                ));
            }
            out.prototypes.push(proto);
            out.shading.push(shading);
            centres.push(centre);
        }
        let mut first = (s.indices.len() + s.spheres.len()) as u32;
        for inst in std::mem::take(&mut self.instances) {
            let k = inst.prototype as usize;
            let world = inst.matrix * DAffine3::from_translation(centres[k]);
            let m = DAffine3::from_translation(-origin) * world;
            let Some(placement) = Placement::new(inst.prototype, m, first) else {
                let at = crate::error::Location {
                    file: s.source.clone(),
                    line: inst.line,
                };
                s.warnings.push(format!(
                    "{at}: instance of `{}` dropped: its transform does not fit in f32",
                    crate::error::one_line(&out.shading[k].name)
                ));
                continue;
            };
            first += out.prototypes[k].indices.len() as u32;
            out.placements.push(placement);
            out.material.push(inst.material);
            out.normal_matrix
                .push(m.matrix3.inverse().transpose().as_mat3());
            out.world.push(world);
        }
        s.instances = out;
    }
    /// Move `mesh`'s warnings, files and materials into the scene and count
    /// its triangles and vertices towards the stored limits; returns the
    /// scene index of its first material.
    fn absorb(&mut self, mesh: &mut MeshData) -> u32 {
        self.counts.0 += mesh.indices.len() as u64;
        self.counts.1 += mesh.positions.len() as u64;
        let s = &mut self.scene;
        s.warnings.append(&mut mesh.warnings);
        for f in mesh.files.drain(..) {
            if !s.mesh_files.contains(&f) {
                s.mesh_files.push(f);
            }
        }
        let base_material = s.materials.len() as u32;
        s.materials.append(&mut mesh.materials);
        base_material
    }

    /// Place `mesh` in world space: positions through `m` (f64), normals
    /// through its inverse transpose, winding reversed by a mirror.
    fn place(&mut self, mut mesh: MeshData, m: DAffine3, line: Option<usize>) {
        let base_material = self.absorb(&mut mesh);
        mesh.transform_by(&m);
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
        self.add_sphere_framed(center, radius, material, Mat3::IDENTITY, line)
    }

    /// [`SceneBuilder::add_sphere`] with its texture frame
    /// ([`Scene::sphere_uv_frames`]).
    pub fn add_sphere_framed(
        &mut self,
        center: DVec3,
        radius: f32,
        material: Material,
        uv_frame: Mat3,
        line: Option<usize>,
    ) -> Result<()> {
        let s = &mut self.scene;
        if material.alpha_mask.is_some() {
            return Err(Error::input(
                &s.source,
                line,
                "a sphere cannot be cut out by an alpha mask (masks apply to triangle meshes)",
            ));
        }
        if self.spheres.len() as u64 >= self.max_triangles {
            return Err(Error::input(
                &s.source,
                line,
                format!("more than {} spheres", self.max_triangles),
            ));
        }
        self.spheres
            .push((center, radius, s.materials.len() as u32, uv_frame));
        s.materials.push(material);
        Ok(())
    }

    /// Add a point light at world `position` (its own position is replaced
    /// by the rebased one).
    pub fn add_point_light(&mut self, position: DVec3, light: PointLight) {
        self.point_lights.push((position, light));
    }

    /// Add a spot light at world `position` (its own position is replaced
    /// by the rebased one).
    pub fn add_spot_light(&mut self, position: DVec3, light: SpotLight) {
        self.spot_lights.push((position, light));
    }

    /// Add a panel light centred at world `center` (its own centre is
    /// replaced by the rebased one). Like the other lights, it is left out
    /// of [`SceneBuilder::world_bounds`].
    pub fn add_panel_light(&mut self, center: DVec3, light: PanelLight) {
        self.panel_lights.push((center, light));
    }

    /// Set the camera, in world space. Without one the scene is framed from
    /// its bounds, with a note.
    pub fn set_camera(&mut self, camera: WorldCamera) {
        self.camera = Some(camera);
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
        for &(c, r, ..) in &self.spheres {
            add(c - r as f64);
            add(c + r as f64);
        }
        for inst in &self.instances {
            let m = &self.prototypes[inst.prototype as usize].mesh;
            for t in &m.indices {
                for &i in t {
                    add(inst.matrix.transform_point3(m.positions[i as usize]));
                }
            }
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
        let spheres = std::mem::take(&mut self.spheres);
        if spheres.iter().any(|s| s.3 != Mat3::IDENTITY) {
            self.scene.sphere_uv_frames = spheres.iter().map(|s| s.3).collect();
        }
        for (c, radius, m, _) in spheres {
            self.scene.spheres.push(Sphere {
                center: (c - origin).as_vec3(),
                radius,
            });
            self.scene.sphere_material.push(m);
        }
        self.build_instances(origin);
        for (p, mut light) in std::mem::take(&mut self.point_lights) {
            light.position = (p - origin).as_vec3();
            self.scene.point_lights.push(light);
        }
        for (p, mut light) in std::mem::take(&mut self.spot_lights) {
            light.position = (p - origin).as_vec3();
            self.scene.spot_lights.push(light);
        }
        for (c, mut light) in std::mem::take(&mut self.panel_lights) {
            light.center = (c - origin).as_vec3();
            self.scene.panel_lights.push(light);
        }
        self.scene.tri_dpduv = super::maps::uv_derivatives(&self.scene);
        let s = &self.scene;
        let lit = s.has_emitters()
            || s.point_lights
                .iter()
                .any(|l| l.intensity.max_element() > 0.0)
            || s.spot_lights
                .iter()
                .any(|l| l.intensity.max_element() > 0.0)
            || s.directional_lights
                .iter()
                .any(|l| l.irradiance().max_element() > 0.0)
            || s.panel_lights
                .iter()
                .any(|l| l.radiance.max_element() > 0.0)
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

/// A prototype mesh in f32 object space, centred on its box when it lies
/// farther from its origin than twice its size: the geometry,
/// the shading data (materials offset by `base_material`), the centre
/// subtracted, and how many triangles were dropped (degenerate or
/// non-finite in f32).
fn object_space(mesh: MeshData, base_material: u32) -> (Prototype, PrototypeShading, DVec3, usize) {
    let (mut lo, mut hi) = (DVec3::INFINITY, DVec3::NEG_INFINITY);
    for t in &mesh.indices {
        for &i in t {
            let p = mesh.positions[i as usize];
            if p.is_finite() {
                lo = lo.min(p);
                hi = hi.max(p);
            }
        }
    }
    // re-centred only when far from its own origin (so a mesh modelled
    // around it, or written out by `convert`, keeps its coordinates bit for
    // bit)
    let centre =
        if lo.x <= hi.x && (0.5 * (lo + hi)).abs().max_element() > 2.0 * (hi - lo).max_element() {
            0.5 * (lo + hi)
        } else {
            DVec3::ZERO
        };
    let mut proto = Prototype {
        positions: mesh
            .positions
            .iter()
            .map(|&p| (p - centre).as_vec3())
            .collect(),
        indices: Vec::with_capacity(mesh.indices.len()),
    };
    let mut shading = PrototypeShading {
        name: mesh.name.clone(),
        ..PrototypeShading::default()
    };
    let (keep_uv, keep_normals) = (!mesh.uvs.is_empty(), !mesh.normals.is_empty());
    let mut dropped = 0;
    for (k, (t, &mat)) in mesh.indices.iter().zip(&mesh.tri_material).enumerate() {
        let p = t.map(|i| proto.positions[i as usize]);
        let normal = p
            .iter()
            .all(|q| q.abs().max_element() <= MAX_COORDINATE)
            .then(|| triangle_normal(p[0], p[1], p[2]))
            .flatten();
        let Some(n) = normal else {
            dropped += 1;
            continue;
        };
        proto.indices.push(*t);
        shading.normals.push(n);
        shading.needle.push(needle_factor(p));
        shading.tri_material.push(base_material + mat);
        if keep_uv {
            shading
                .tri_uv
                .push(mesh.uvs.get(k).copied().unwrap_or([Vec2::ZERO; 3]));
        }
        if keep_normals {
            // corners face the triangle's front, as for placed meshes
            let ns = mesh.normals.get(k).copied().unwrap_or([Vec3::ZERO; 3]);
            let ns = ns.map(|c| {
                // a unit normal (to a few ulps) is kept as it is, as for
                // placed meshes, so a converted scene reads back the same
                let c = if (c.length_squared() - 1.0).abs() <= 4.0 * f32::EPSILON {
                    c
                } else {
                    c.normalize_or_zero()
                };
                if !c.is_finite() {
                    Vec3::ZERO
                } else if c.dot(n) < 0.0 {
                    -c
                } else {
                    c
                }
            });
            shading.tri_shading_normals.push(ns);
        }
    }
    (proto, shading, centre, dropped)
}

#[cfg(test)]
mod tests;
