//! Ray sets shared by `bench` and `parity`: camera rays, the diffuse bounce
//! and shadow rays that path tracing spawns at the first hits, uniformly
//! random rays, and rays aimed exactly at shared edges and vertices. Every
//! set is a pure function of (scene, kind, count, seed), so every backend is
//! measured and compared on identical rays.

use crate::accel::Accelerator;
use crate::camera::Camera;
use crate::integrator::Lights;
use crate::math::{Frame, Ray, SurfacePoint, Vec2, Vec3, spawn_ray, spawn_ray_to};
use crate::sampler::Sampler;
use crate::sampling::{
    square_to_cosine_hemisphere, square_to_uniform_sphere, square_to_uniform_triangle,
};
use crate::scene::Scene;
use std::fmt;
use std::str::FromStr;

/// What a ray set holds.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum RayKind {
    /// Primary rays through random film positions.
    Camera,
    /// Occlusion rays from first hits to points on lights (or on random
    /// triangles when the scene has no area lights).
    Shadow,
    /// Cosine-sampled bounce rays from first hits.
    Diffuse,
    /// Random origins in the (slightly enlarged) scene bounds, uniform directions.
    Random,
    /// Rays aimed exactly at points of triangle edges.
    Edge,
    /// Rays aimed exactly at triangle vertices.
    Vertex,
}

impl RayKind {
    /// Every kind, in report order.
    pub const ALL: [RayKind; 6] = [
        RayKind::Camera,
        RayKind::Shadow,
        RayKind::Diffuse,
        RayKind::Random,
        RayKind::Edge,
        RayKind::Vertex,
    ];

    /// The name on the command line and in reports.
    pub fn name(self) -> &'static str {
        match self {
            RayKind::Camera => "camera",
            RayKind::Shadow => "shadow",
            RayKind::Diffuse => "diffuse",
            RayKind::Random => "random",
            RayKind::Edge => "edge",
            RayKind::Vertex => "vertex",
        }
    }

    /// Whether the set is traced with occlusion queries rather than closest hits.
    pub fn is_occlusion(self) -> bool {
        self == RayKind::Shadow
    }
}

impl fmt::Display for RayKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for RayKind {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        RayKind::ALL
            .into_iter()
            .find(|k| k.name() == s)
            .ok_or_else(|| format!("unknown ray kind `{s}` (expected camera, shadow, diffuse, random, edge or vertex)"))
    }
}

/// Rays of one kind.
#[derive(Debug, Clone)]
pub struct RaySet {
    /// The kind.
    pub kind: RayKind,
    /// The rays.
    pub rays: Vec<Ray>,
}

/// First hits of camera rays: where bounce and shadow rays start.
fn first_hits(
    scene: &Scene,
    accel: &dyn Accelerator,
    n: usize,
    seed: u64,
) -> Vec<(SurfacePoint, Vec3)> {
    let [w, h] = scene.resolution;
    let camera = Camera::new(&scene.camera, w, h);
    let mut s = Sampler::new(seed, 1, 0);
    let mut out = Vec::with_capacity(n);
    // bounded: a scene the camera barely sees yields fewer points
    for _ in 0..n.saturating_mul(8).max(64) {
        if out.len() == n {
            break;
        }
        let ray = camera.generate_ray(s.next_2d() * Vec2::new(w as f32, h as f32));
        if let Some(hit) = accel.intersect(&ray) {
            out.push((scene.hit_point(&ray, &hit), -ray.d));
        }
    }
    out
}

fn random_triangle_point(scene: &Scene, s: &mut Sampler) -> (u32, SurfacePoint) {
    let prim = ((s.next_1d() as f64 * scene.triangle_count() as f64) as u32)
        .min(scene.triangle_count() as u32 - 1);
    let b = square_to_uniform_triangle(s.next_2d());
    (prim, scene.surface_point(prim, b.x, b.y))
}

/// Generate `n` rays of `kind` for `scene` (using `accel` to find first hits).
/// Returns an empty set for a scene without triangles.
pub fn generate(
    scene: &Scene,
    accel: &dyn Accelerator,
    kind: RayKind,
    n: usize,
    seed: u64,
) -> RaySet {
    let mut rays = Vec::with_capacity(n);
    if scene.triangle_count() == 0 {
        return RaySet { kind, rays };
    }
    let bounds = scene.bounds();
    let centre = 0.5 * (bounds.min + bounds.max);
    let radius = (0.5 * (bounds.max - bounds.min).length()).max(1e-3);
    let mut s = Sampler::new(seed, kind as u64 + 2, 0);
    match kind {
        RayKind::Camera => {
            let [w, h] = scene.resolution;
            let camera = Camera::new(&scene.camera, w, h);
            for _ in 0..n {
                rays.push(camera.generate_ray(s.next_2d() * Vec2::new(w as f32, h as f32)));
            }
        }
        RayKind::Diffuse => {
            for (sp, wo) in first_hits(scene, accel, n, seed) {
                let nrm = if sp.n.dot(wo) < 0.0 { -sp.n } else { sp.n };
                let wi = Frame::from_normal(nrm).to_world(square_to_cosine_hemisphere(s.next_2d()));
                rays.push(spawn_ray(&sp, wi.normalize()));
            }
        }
        RayKind::Shadow => {
            let lights = Lights::new(scene);
            let has_area = !lights.area_lights().is_empty();
            for (sp, _) in first_hits(scene, accel, n, seed) {
                let target = if has_area {
                    let l = lights.area_lights()[(s.next_1d() * lights.area_lights().len() as f32)
                        as usize
                        % lights.area_lights().len()];
                    match scene.sphere(l.prim) {
                        Some(sph) => {
                            let n = square_to_uniform_sphere(s.next_2d());
                            SurfacePoint::on_sphere(
                                sph.center,
                                sph.radius,
                                sph.center + sph.radius * n,
                            )
                        }
                        None => {
                            let b = square_to_uniform_triangle(s.next_2d());
                            scene.surface_point(l.prim, b.x, b.y)
                        }
                    }
                } else {
                    random_triangle_point(scene, &mut s).1
                };
                rays.push(spawn_ray_to(&sp, &target));
            }
        }
        RayKind::Random => {
            for _ in 0..n {
                let u = Vec3::new(s.next_1d(), s.next_1d(), s.next_1d());
                let o = centre + (u * 2.0 - Vec3::ONE) * 1.1 * (0.5 * (bounds.max - bounds.min));
                rays.push(Ray::new(o, square_to_uniform_sphere(s.next_2d())));
            }
        }
        RayKind::Edge | RayKind::Vertex => {
            for _ in 0..n {
                let (prim, _) = random_triangle_point(scene, &mut s);
                let [p0, p1, p2] = scene.triangle(prim);
                let corner = (s.next_1d() * 3.0) as usize % 3;
                let (a, b) = [(p0, p1), (p1, p2), (p2, p0)][corner];
                let target = if kind == RayKind::Vertex {
                    a
                } else {
                    a + s.next_1d() * (b - a)
                };
                let o =
                    target + square_to_uniform_sphere(s.next_2d()) * radius * (0.05 + s.next_1d());
                let d = target - o;
                if d.length() > 0.0 {
                    rays.push(Ray::new(o, d.normalize()));
                }
            }
        }
    }
    RaySet { kind, rays }
}
