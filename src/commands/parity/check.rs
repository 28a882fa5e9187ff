//! `embertrace parity`: identical ray sets through every backend, each
//! compared with a reference backend ray by ray, and the same render through
//! each. Every disagreement is classified by the primitive in dispute: the
//! nearer of two different answers, which the other backend passed by.
//!
//! - `vertex`, `edge`: the ray's line crosses the disputed triangle within
//!   the `f32` rounding tolerance of two edges, or one (barycentrics computed
//!   in `f64`, tolerance `gamma(16) (R + L) L / |(p1 - p0) x (p2 - p0) . d|`
//!   for corners at most `R` from the origin and edges at most `L` long, see
//!   `exact_crossing`); or the two answers are triangles at the same
//!   distance that share an edge or vertex;
//! - `tie`: two triangles both met squarely at the same distance
//!   (coplanar overlaps), where each backend's tie rule picks one;
//! - `grazing`: the ray meets the disputed primitive at `|cos| < 1e-3`;
//! - `degenerate`: the disputed triangle is a sliver (area below `1e-6` of
//!   its longest edge squared), where rounding decides;
//! - `extent`: a shadow ray whose first hit lies within `1e-4` (relative) of
//!   its `t_max`, so the query's own rounding decides;
//! - `precision`: a distance disagreement on the same triangle within the
//!   `f32` error bound of the distance (`gamma(16) R / |cos|`): a triangle
//!   large next to the hit distance cannot fix `t` more finely in either
//!   backend; on an instanced triangle, plus the rounding of the way into
//!   its object space (`gamma(32) cond 3 |o| / |cos|`, each backend with its
//!   own inverse of the placement's map);
//! - `unexplained`: anything else, in particular a triangle hit squarely by
//!   one backend and passed by the other. `parity` exits non-zero if any
//!   exists.
//!
//! Distances disagree when `|t_a - t_b| > 1e-5 * max(1, t)` (hard case 11).

use crate::accel::triangle::distance_error_bound;
use crate::accel::{self, AccelOptions, Accelerator, Backend, Hit, Masked};
use crate::commands::raysets::{self, RayKind};
use crate::error::{Error, Result};
use crate::integrator::PathTracer;
use crate::math::{Ray, Vec3, gamma, triangle_normal};
use crate::render::{RenderSettings, render};
use crate::sampler::SamplerKind;
use crate::scene::Scene;
use crate::settings::IntegratorSettings;
use rayon::prelude::*;
use serde::Serialize;
use std::collections::BTreeMap;

/// `|cos|` below which a ray grazes a triangle.
pub const GRAZING_COS: f32 = 1e-3;

/// Disagreements of one kind between two backends.
#[derive(Debug, Clone, Default, Serialize)]
pub struct KindParity {
    /// Ray kind.
    pub kind: String,
    /// Rays traced.
    pub rays: usize,
    /// One backend hit (or found occlusion), the other did not.
    pub hit_miss: usize,
    /// Both hit, different primitives.
    pub primitive: usize,
    /// Same primitive, distance beyond `1e-5 * max(1, t)`.
    pub distance: usize,
    /// Every disagreement by class.
    pub classes: BTreeMap<String, usize>,
    /// Up to five unexplained rays, for reproduction.
    pub unexplained_examples: Vec<String>,
}

/// The image rendered through both backends.
#[derive(Debug, Clone, Serialize)]
pub struct ImageParity {
    /// Resolution side (square).
    pub resolution: u32,
    /// Samples per pixel.
    pub spp: u32,
    /// Mean RGB of the reference render.
    pub reference_mean: [f64; 3],
    /// Mean RGB of the other render.
    pub mean: [f64; 3],
    /// Fraction of pixel channels whose difference exceeds 5 standard errors.
    pub fraction_beyond_5_sigma: f64,
    /// Whether that fraction is at most 0.25 % (hard case 26's rule).
    pub within_noise: bool,
}

/// One backend against the reference.
#[derive(Debug, Clone, Serialize)]
pub struct BackendParity {
    /// The backend compared.
    pub backend: String,
    /// Per ray kind.
    pub kinds: Vec<KindParity>,
    /// The image comparison.
    pub image: ImageParity,
}

/// The whole report.
#[derive(Debug, Clone, Serialize)]
pub struct ParityReport {
    /// Scene file.
    pub scene: String,
    /// Triangles.
    pub triangles: usize,
    /// The reference backend.
    pub reference: String,
    /// Every other backend.
    pub comparisons: Vec<BackendParity>,
    /// Total unexplained disagreements (rays and images).
    pub unexplained: usize,
}

/// Where a ray's line meets a triangle: barycentrics computed in `f64` from
/// the `f32` inputs (exact to far below `f32` rounding), and how far an
/// `f32` test may misplace them.
#[derive(Debug, Clone, Copy)]
struct ExactCrossing {
    /// Barycentrics of the three corners (summing to 1); all `>= 0` inside.
    b: [f64; 3],
    /// The rounding scale of `f32` barycentrics for this ray and triangle.
    tolerance: f64,
}

/// The line of `ray` against triangle `p`, or `None` when the line is
/// parallel to it (the triangle is seen edge-on).
///
/// Tolerance: both kinds of `f32` test in use work on the corners relative
/// to the origin, whose rounding moves each corner by up to `eps R` (`R` the
/// farthest corner's distance): the watertight test's sheared coordinates
/// carry `gamma(5) (|x| + |z|)`, Embree's robust Pluecker test its
/// `v_i - o`; both then form edge functions of size `L` (the longest edge)
/// times those coordinates, so each edge function is off by a few
/// `eps (R + L) L`, against a sum of `|(p1 - p0) x (p2 - p0) . d|`. The
/// tolerance is `gamma(16) (R + L) L / |(p1 - p0) x (p2 - p0) . d|`: large
/// for a small triangle far away, a sliver, or a grazing ray, where
/// rounding decides which side of an edge the ray passes.
fn exact_crossing(p: [Vec3; 3], ray: &Ray) -> Option<ExactCrossing> {
    let [p0, p1, p2] = p.map(Vec3::as_dvec3);
    let (o, d) = (ray.o.as_dvec3(), ray.d.as_dvec3().normalize());
    let (e1, e2) = (p1 - p0, p2 - p0);
    let q = d.cross(e2);
    let det = e1.dot(q);
    if det == 0.0 || !det.is_finite() {
        return None;
    }
    let s = o - p0;
    let u = s.dot(q) / det;
    let w = d.dot(s.cross(e1)) / det;
    let r = [p0, p1, p2]
        .iter()
        .map(|c| (*c - o).length())
        .fold(0.0, f64::max);
    let l = e1.length().max(e2.length()).max((p2 - p1).length());
    Some(ExactCrossing {
        b: [1.0 - u - w, u, w],
        tolerance: gamma(16) as f64 * (r + l) * l / det.abs(),
    })
}

impl ExactCrossing {
    /// Of triangle `h.prim`; `None` for a sphere or an edge-on triangle.
    fn of(scene: &Scene, ray: &Ray, h: &Hit) -> Option<Self> {
        scene
            .sphere(h.prim)
            .is_none()
            .then(|| exact_crossing(scene.triangle(h.prim), ray))
            .flatten()
    }

    /// `Some("vertex")` or `Some("edge")` when the line passes within the
    /// tolerance of two edges or one, so rounding decides whether it hits;
    /// `None` when it hits squarely or misses clearly.
    fn near_edges(&self) -> Option<&'static str> {
        match self.b.iter().filter(|x| x.abs() <= self.tolerance).count() {
            0 => None,
            1 => Some("edge"),
            _ => Some("vertex"),
        }
    }

    /// Whether the line crosses the triangle (every barycentric at least
    /// minus the tolerance).
    fn inside(&self) -> bool {
        self.b.iter().all(|&x| x >= -self.tolerance)
    }
}

/// How many corners triangles `a` and `b` share (0 when either is a
/// sphere).
fn shared_corners(scene: &Scene, a: u32, b: u32) -> usize {
    if scene.sphere(a).is_some() || scene.sphere(b).is_some() {
        return 0;
    }
    let pa = scene.triangle(a);
    scene.triangle(b).iter().filter(|p| pa.contains(p)).count()
}

fn tri_class(scene: &Scene, ray: &Ray, h: &Hit) -> Option<&'static str> {
    if let Some(s) = scene.sphere(h.prim) {
        let n = (ray.at(h.t) - s.center).normalize_or_zero();
        return (n.dot(ray.d).abs() < GRAZING_COS).then_some("grazing");
    }
    let [p0, p1, p2] = scene.triangle(h.prim);
    let area2 = (p1 - p0).cross(p2 - p0).length();
    let longest = (p1 - p0)
        .length_squared()
        .max((p2 - p1).length_squared())
        .max((p0 - p2).length_squared());
    if !(area2 > 1e-6 * longest) {
        return Some("degenerate");
    }
    triangle_normal(p0, p1, p2)
        .is_some_and(|n| n.dot(ray.d).abs() < GRAZING_COS)
        .then_some("grazing")
}

/// Classify a hit/miss or primitive disagreement between answers `a` and
/// `b`.
///
/// Two triangles at the same distance (within `1e-5 max(1, t)`): the ray
/// meets both, and rounding or each backend's tie rule picks one (Embree's
/// is not the lowest index). That is `edge` or `vertex` when the ray meets
/// either at an edge or vertex, or the two share one; `tie` when it meets
/// both squarely (coplanar overlaps).
///
/// Otherwise the disputed primitive is the nearer answer (the other backend
/// passed it by), and only how the ray passes it explains the disagreement
/// (at an edge or vertex, grazing, degenerate). A backend that misses a
/// triangle hit squarely, or hits one missed clearly, is unexplained
/// whatever the other answer looks like.
fn classify(scene: &Scene, ray: &Ray, a: Option<Hit>, b: Option<Hit>) -> &'static str {
    let near_edges = |h: &Hit| ExactCrossing::of(scene, ray, h).and_then(|c| c.near_edges());
    let class = match (a, b) {
        (Some(x), Some(y)) if !far_enough(x.t, y.t) => {
            let (cx, cy) = (
                ExactCrossing::of(scene, ray, &x),
                ExactCrossing::of(scene, ray, &y),
            );
            // spheres (no crossing) count as met
            let met = |h: &Hit, c: Option<ExactCrossing>| {
                c.map_or(scene.sphere(h.prim).is_some(), |c| c.inside())
            };
            cx.and_then(|c| c.near_edges())
                .or_else(|| cy.and_then(|c| c.near_edges()))
                .or(match shared_corners(scene, x.prim, y.prim) {
                    0 => None,
                    1 => Some("vertex"),
                    _ => Some("edge"),
                })
                .or_else(|| (met(&x, cx) && met(&y, cy)).then_some("tie"))
                .or_else(|| tri_class(scene, ray, &x))
                .or_else(|| tri_class(scene, ray, &y))
        }
        (Some(x), Some(y)) => {
            let nearer = if x.t <= y.t { x } else { y };
            near_edges(&nearer).or_else(|| tri_class(scene, ray, &nearer))
        }
        (Some(x), None) | (None, Some(x)) => near_edges(&x).or_else(|| tri_class(scene, ray, &x)),
        (None, None) => None,
    };
    class.unwrap_or("unexplained")
}

/// Same primitive, distances within the `f32` error bound of the distance
/// itself ([`distance_error_bound`]): a triangle large next to the hit
/// distance, seen at an angle, cannot fix `t` more finely.
fn within_precision(scene: &Scene, ray: &Ray, a: &Hit, other_t: f32) -> bool {
    let bound = match scene.sphere(a.prim) {
        // every backend runs the same sphere routine: only the final f32
        // rounding of t may differ
        Some(_) => 2.0 * f32::EPSILON * a.t.abs().max(other_t.abs()),
        None => {
            let corners = scene.triangle(a.prim);
            let bound = distance_error_bound(corners, ray);
            match scene.instanced(a.prim) {
                None => bound,
                // plus the way into the instance's object space, which
                // each backend rounds with its own inverse (Embree's in
                // f32): a few ulps of the origin's coordinates, magnified by
                // the map's condition number, along the ray at the hit's
                // angle
                Some((k, _)) => {
                    let cond = scene.instances.placements[k].cond;
                    let n = (corners[1] - corners[0]).cross(corners[2] - corners[0]);
                    let cos = n.normalize_or_zero().dot(ray.d.normalize()).abs();
                    let reach = 3.0 * ray.o.abs().max_element();
                    if cos > 0.0 {
                        bound + gamma(32) * cond * reach / cos
                    } else {
                        f32::INFINITY
                    }
                }
            }
        }
    };
    (a.t - other_t).abs() <= bound
}

fn far_enough(a: f32, b: f32) -> bool {
    (a - b).abs() > 1e-5 * a.abs().max(b.abs()).max(1.0)
}

fn compare_kind(
    scene: &Scene,
    reference: &dyn Accelerator,
    other: &dyn Accelerator,
    kind: RayKind,
    rays: &[Ray],
) -> KindParity {
    let mut p = KindParity {
        kind: kind.to_string(),
        rays: rays.len(),
        ..KindParity::default()
    };
    // (kind of disagreement, class, example)
    let found: Vec<(u8, &'static str, String)> = rays
        .par_iter()
        .filter_map(|ray| {
            if kind.is_occlusion() {
                let (x, y) = (reference.occluded(ray), other.occluded(ray));
                if x == y {
                    return None;
                }
                let open = Ray {
                    t_max: f32::INFINITY,
                    ..*ray
                };
                let first = reference
                    .intersect(&open)
                    .or_else(|| other.intersect(&open));
                let class = match first {
                    Some(h) if (h.t - ray.t_max).abs() <= 1e-4 * ray.t_max => "extent",
                    Some(h) => classify(scene, ray, Some(h), None),
                    None => "unexplained",
                };
                return Some((0, class, format!("{ray:?}: occluded {x} vs {y}")));
            }
            let (x, y) = (reference.intersect(ray), other.intersect(ray));
            let which = match (x, y) {
                (None, None) => return None,
                (Some(_), None) | (None, Some(_)) => 0,
                (Some(a), Some(b)) if a.prim != b.prim => 1,
                (Some(a), Some(b)) if far_enough(a.t, b.t) => 2,
                _ => return None,
            };
            let class = match (which, x) {
                (2, Some(a)) if within_precision(scene, ray, &a, y.map_or(a.t, |b| b.t)) => {
                    "precision"
                }
                _ => classify(scene, ray, x, y),
            };
            Some((which, class, format!("{ray:?}: {x:?} vs {y:?}")))
        })
        .collect();
    for (which, class, example) in found {
        match which {
            0 => p.hit_miss += 1,
            1 => p.primitive += 1,
            _ => p.distance += 1,
        }
        *p.classes.entry(class.to_string()).or_default() += 1;
        if class == "unexplained" && p.unexplained_examples.len() < 5 {
            p.unexplained_examples.push(example);
        }
    }
    p
}

fn compare_images(
    scene: &Scene,
    reference: &dyn Accelerator,
    other: &dyn Accelerator,
    res: u32,
    spp: u32,
    settings: IntegratorSettings,
) -> Result<ImageParity> {
    let camera = scene.make_camera(res, res);
    let rs = RenderSettings {
        total_spp: None,
        resolution: [res, res],
        spp,
        first_sample: 0,
        seed: 1,
        threads: 0,
        tile_size: 16,
        sampler: SamplerKind::Independent,
        clamp: None,
    };
    // different seeds would make the test about noise; the same seed makes
    // the renders agree except where the backends' answers differ
    let a = render(
        &PathTracer::new(scene, reference, settings),
        &camera,
        &rs,
        &|| {},
    )?;
    let b = render(
        &PathTracer::new(scene, other, settings),
        &camera,
        &rs,
        &|| {},
    )?;
    let mut beyond = 0usize;
    for y in 0..res {
        for x in 0..res {
            let d = (a.film.mean(x, y) - b.film.mean(x, y)).abs();
            let se = (a.film.variance_of_mean(x, y) + b.film.variance_of_mean(x, y)).powf(0.5);
            for c in 0..3 {
                if d[c] > 5.0 * se[c] && d[c] > 1e-6 {
                    beyond += 1;
                }
            }
        }
    }
    let fraction = beyond as f64 / (3 * res * res) as f64;
    Ok(ImageParity {
        resolution: res,
        spp,
        reference_mean: a.film.mean_rgb(),
        mean: b.film.mean_rgb(),
        fraction_beyond_5_sigma: fraction,
        within_noise: fraction <= 0.0025,
    })
}

/// Settings of a parity run.
#[derive(Debug, Clone)]
pub struct ParitySettings {
    /// Rays per kind.
    pub rays: usize,
    /// Kinds to trace.
    pub kinds: Vec<RayKind>,
    /// Backends; the first is the reference.
    pub backends: Vec<Backend>,
    /// Build options.
    pub options: AccelOptions,
    /// Image side for the image comparison (0 skips it).
    pub image_resolution: u32,
    /// Samples per pixel of the image comparison.
    pub image_spp: u32,
    /// Estimator settings of the image comparison.
    pub integrator: IntegratorSettings,
}

/// Run the comparison.
pub fn run(
    scene: &Scene,
    settings: &ParitySettings,
    progress: &dyn Fn(&str),
) -> Result<ParityReport> {
    if settings.backends.len() < 2 {
        return Err(Error::Settings(format!(
            "parity needs two backends, have {:?}",
            settings
                .backends
                .iter()
                .map(|b| b.name())
                .collect::<Vec<_>>()
        )));
    }
    let reference_backend = settings.backends[0];
    let reference = accel::build(reference_backend, scene.soup(), settings.options)?;
    // every query sees the scene's alpha masks, as a render's do
    let reference = Masked {
        accel: reference.as_ref(),
        alpha: scene.alpha_test(),
    };
    let sets: Vec<_> = settings
        .kinds
        .iter()
        .map(|&k| raysets::generate(scene, &reference, k, settings.rays, 7))
        .collect();
    let mut comparisons = Vec::new();
    let mut unexplained = 0;
    for &backend in &settings.backends[1..] {
        progress(&format!("{reference_backend} vs {backend}"));
        let other = accel::build(backend, scene.soup(), settings.options)?;
        let other = Masked {
            accel: other.as_ref(),
            alpha: scene.alpha_test(),
        };
        let kinds: Vec<KindParity> = sets
            .iter()
            .map(|s| compare_kind(scene, &reference, &other, s.kind, &s.rays))
            .collect();
        unexplained += kinds
            .iter()
            .map(|k| k.classes.get("unexplained").copied().unwrap_or(0))
            .sum::<usize>();
        let image = if settings.image_resolution > 0 {
            progress(&format!("{reference_backend} vs {backend}: image"));
            compare_images(
                scene,
                reference.accel,
                other.accel,
                settings.image_resolution,
                settings.image_spp,
                settings.integrator,
            )?
        } else {
            ImageParity {
                resolution: 0,
                spp: 0,
                reference_mean: [0.0; 3],
                mean: [0.0; 3],
                fraction_beyond_5_sigma: 0.0,
                within_noise: true,
            }
        };
        if !image.within_noise {
            unexplained += 1;
        }
        comparisons.push(BackendParity {
            backend: backend.to_string(),
            kinds,
            image,
        });
    }
    Ok(ParityReport {
        scene: scene.source.display().to_string(),
        triangles: scene.triangle_count(),
        reference: reference_backend.to_string(),
        comparisons,
        unexplained,
    })
}

impl ParityReport {
    /// The table printed on stdout.
    pub fn table(&self) -> String {
        let mut out = format!(
            "{}: {} triangles, reference {}\n",
            self.scene, self.triangles, self.reference
        );
        for c in &self.comparisons {
            out += &format!("{} vs {}:\n", self.reference, c.backend);
            out += &format!(
                "  {:<8} {:>8} {:>9} {:>9} {:>9}  classes\n",
                "kind", "rays", "hit/miss", "prim", "distance"
            );
            for k in &c.kinds {
                let classes: Vec<String> =
                    k.classes.iter().map(|(n, v)| format!("{n} {v}")).collect();
                out += &format!(
                    "  {:<8} {:>8} {:>9} {:>9} {:>9}  {}\n",
                    k.kind,
                    k.rays,
                    k.hit_miss,
                    k.primitive,
                    k.distance,
                    if classes.is_empty() {
                        "-".to_string()
                    } else {
                        classes.join(", ")
                    }
                );
                for e in &k.unexplained_examples {
                    out += &format!("    unexplained: {e}\n");
                }
            }
            if c.image.resolution > 0 {
                out += &format!(
                    "  image {}x{} at {} spp: means {:.5?} vs {:.5?}; {:.3} % of pixel channels beyond 5 sigma ({})\n",
                    c.image.resolution,
                    c.image.resolution,
                    c.image.spp,
                    c.image.reference_mean,
                    c.image.mean,
                    100.0 * c.image.fraction_beyond_5_sigma,
                    if c.image.within_noise {
                        "within noise"
                    } else {
                        "NOT within noise"
                    }
                );
            }
        }
        out += &format!("unexplained disagreements: {}\n", self.unexplained);
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::accel::TriangleSoup;
    use crate::accel::naive::Naive;
    use crate::scene::procedural::{Shape, generate};
    use crate::scene::{Material, SceneBuilder, Transform};

    /// A backend that forgets one triangle: the classifier must call it out.
    struct Forgetful(Naive, u32);
    impl Accelerator for Forgetful {
        fn name(&self) -> &'static str {
            "forgetful"
        }
        fn intersect(&self, ray: &Ray) -> Option<Hit> {
            self.0.intersect(ray).filter(|h| h.prim != self.1)
        }
        fn occluded(&self, ray: &Ray) -> bool {
            self.intersect(ray).is_some()
        }
        fn intersect_masked(&self, ray: &Ray, _: &dyn crate::accel::AlphaTest) -> Option<Hit> {
            self.intersect(ray)
        }
        fn occluded_masked(&self, ray: &Ray, _: &dyn crate::accel::AlphaTest) -> bool {
            self.occluded(ray)
        }
        fn memory_bytes(&self) -> usize {
            0
        }
    }

    #[test]
    fn a_missing_triangle_is_unexplained() {
        let mut b = SceneBuilder::new(std::path::Path::new("t"));
        b.add_mesh(
            generate(Shape::Sphere, 200, 0.0, 0, "s", Material::default()),
            &Transform::default(),
        );
        let scene = b.build();
        let good = Naive::new(scene.soup());
        let bad = Forgetful(Naive::new(scene.soup()), 17);
        let rays: Vec<Ray> = (0..2000)
            .map(|i| {
                let mut s = crate::sampler::Sampler::new(0, i, 0);
                let d = crate::sampling::square_to_uniform_sphere(s.next_2d());
                Ray::new(crate::math::Vec3::ZERO, d)
            })
            .collect();
        let p = compare_kind(&scene, &good, &bad, RayKind::Random, &rays);
        assert!(
            p.classes.get("unexplained").copied().unwrap_or(0) > 0,
            "{p:?}"
        );
        let same = compare_kind(
            &scene,
            &good,
            &Naive::new(scene.soup()),
            RayKind::Random,
            &rays,
        );
        assert!(same.classes.is_empty());
    }

    /// Rays aimed at the shared edge of a lower square pass squarely through
    /// an upper one. A backend that forgets an upper triangle reports the
    /// lower square's edge instead: the edge does not explain that.
    #[test]
    fn a_squarely_missed_triangle_is_not_excused_by_an_edge_behind_it() {
        use crate::math::Vec3;
        let mut m = crate::scene::MeshData {
            materials: vec![Material::default()],
            ..Default::default()
        };
        for z in [0.0, 1.0] {
            let base = m.positions.len() as u32;
            for p in [
                Vec3::new(-1.0, -1.0, z),
                Vec3::new(1.0, -1.0, z),
                Vec3::new(1.0, 1.0, z),
                Vec3::new(-1.0, 1.0, z),
            ] {
                // (the mesh's positions may be kept in f64)
                m.positions.push(p.into());
            }
            m.indices.push([base, base + 1, base + 2]);
            m.indices.push([base, base + 2, base + 3]);
        }
        m.tri_material = vec![0; 4];
        let mut b = SceneBuilder::new(std::path::Path::new("t"));
        b.add_mesh(m, &Transform::default());
        let scene = b.build();
        // the lower diagonal, from (-0.5, -0.5) to (0.5, 0.5), from above
        let rays: Vec<Ray> = (0..101)
            .map(|i| {
                let s = -0.5 + i as f32 / 100.0;
                let o = Vec3::new(s + 0.3, s - 0.2, 3.0);
                Ray::new(o, (Vec3::new(s, s, 0.0) - o).normalize())
            })
            .collect();
        let good = Naive::new(scene.soup());
        // a backend blind to upper triangle 2 (made degenerate in its copy)
        let soup = scene.soup();
        let mut indices = soup.indices.to_vec();
        indices[2] = [0, 0, 0];
        let bad = Naive::new(TriangleSoup {
            indices: &indices,
            ..soup
        });
        let edge_hits = rays
            .iter()
            .filter_map(|r| bad.intersect(r))
            .filter(|h| h.prim < 2 && h.u.min(h.v).min(1.0 - h.u - h.v) < 1e-4)
            .count();
        assert_eq!(edge_hits, rays.len(), "the blind backend lands on the edge");
        let p = compare_kind(&scene, &good, &bad, RayKind::Random, &rays);
        assert_eq!(p.primitive, rays.len(), "{p:?}");
        assert_eq!(p.classes.get("unexplained"), Some(&rays.len()), "{p:?}");
    }
}
