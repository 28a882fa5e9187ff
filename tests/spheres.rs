//! Analytic spheres in every backend: the same closest hit (primitive and
//! `t`, bit for bit: every backend runs the same routine) on random scenes of
//! spheres and triangles, the edge cases of the quadratic (tangent rays, a
//! ray from inside, a sphere behind the ray, `t_max` cut-offs, huge and tiny
//! spheres), and the self-intersection property the renderer relies on: a
//! ray spawned from a sphere's hit point (`SurfacePoint::on_sphere` and
//! `spawn_ray`) leaving outwards never sees that sphere again, and one
//! leaving inwards finds its far side, never the near one.

use embertrace::accel::{self, AccelOptions, Accelerator, Backend, Coherence, Hit, TriangleSoup};
use embertrace::math::{Ray, SurfacePoint, Vec3, spawn_ray};
use embertrace::sampler::Sampler;
use embertrace::sampling::square_to_uniform_sphere;
use embertrace::shape::Sphere;

fn build(b: Backend, p: &[Vec3], i: &[[u32; 3]], s: &[Sphere]) -> Box<dyn Accelerator> {
    let soup = TriangleSoup {
        positions: p,
        indices: i,
        spheres: s,
        instances: Default::default(),
        masked: false,
    };
    accel::build(b, soup, AccelOptions::default()).unwrap()
}

fn all(s: &[Sphere]) -> Vec<(Backend, Box<dyn Accelerator>)> {
    Backend::available()
        .into_iter()
        .map(|b| (b, build(b, &[], &[], s)))
        .collect()
}

#[test]
fn edge_cases_in_every_backend() {
    let unit = Sphere {
        center: Vec3::new(0.0, 0.0, -5.0),
        radius: 1.0,
    };
    for (b, a) in all(&[unit]) {
        let hit = |o: Vec3, d: Vec3, t_max: f32| {
            let mut r = Ray::new(o, d.normalize());
            r.t_max = t_max;
            a.intersect(&r).map(|h| (h.prim, h.t))
        };
        // from outside: the near side at 4
        assert_eq!(hit(Vec3::ZERO, -Vec3::Z, f32::MAX), Some((0, 4.0)), "{b}");
        // t_max before the sphere, and exactly at it (inclusive)
        assert_eq!(hit(Vec3::ZERO, -Vec3::Z, 3.5), None, "{b}");
        assert_eq!(hit(Vec3::ZERO, -Vec3::Z, 4.0), Some((0, 4.0)), "{b}");
        // from the centre: the far side at the radius
        assert_eq!(
            hit(Vec3::new(0.0, 0.0, -5.0), Vec3::Y, f32::MAX),
            Some((0, 1.0)),
            "{b}"
        );
        // behind the ray, and beside it
        assert_eq!(hit(Vec3::ZERO, Vec3::Z, f32::MAX), None, "{b}");
        assert_eq!(
            hit(Vec3::new(1.5, 0.0, 0.0), -Vec3::Z, f32::MAX),
            None,
            "{b}"
        );
        // grazing just inside and just outside the silhouette
        assert!(
            hit(Vec3::new(0.999, 0.0, 0.0), -Vec3::Z, f32::MAX).is_some(),
            "{b}"
        );
        assert!(
            hit(Vec3::new(1.001, 0.0, 0.0), -Vec3::Z, f32::MAX).is_none(),
            "{b}"
        );
        // occlusion agrees
        let mut r = Ray::new(Vec3::ZERO, -Vec3::Z);
        assert!(a.occluded(&r), "{b}");
        r.t_max = 3.9;
        assert!(!a.occluded(&r), "{b}");
    }
    // a huge sphere and a tiny one
    let huge = Sphere {
        center: Vec3::new(0.0, -1.0e6, 0.0),
        radius: 1.0e6,
    };
    let tiny = Sphere {
        center: Vec3::new(0.0, 1.0, 0.0),
        radius: 1.0e-4,
    };
    for (b, a) in all(&[huge, tiny]) {
        let h = a
            .intersect(&Ray::new(Vec3::new(0.0, 10.0, 0.0), -Vec3::Y))
            .unwrap();
        assert_eq!(h.prim, 1, "{b}: the tiny sphere is in front");
        assert!((h.t - (9.0 - 1.0e-4)).abs() < 1e-5, "{b}: {}", h.t);
        let h = a
            .intersect(&Ray::new(Vec3::new(0.5, 10.0, 0.0), -Vec3::Y))
            .unwrap();
        assert_eq!(h.prim, 0, "{b}");
        assert!((h.t - 10.0).abs() < 1e-2, "{b}: {}", h.t);
    }
}

/// A small xorshift for scene layout (not a Monte Carlo estimate).
struct Rng(u64);
impl Rng {
    fn next(&mut self) -> f32 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        (self.0 >> 40) as f32 / (1u64 << 24) as f32
    }
    fn vec(&mut self, scale: f32) -> Vec3 {
        Vec3::new(self.next() - 0.5, self.next() - 0.5, self.next() - 0.5) * (2.0 * scale)
    }
}

#[test]
fn backends_agree_bit_for_bit_on_spheres_and_triangles() {
    let mut rng = Rng(0x9e37_79b9_7f4a_7c15);
    let mut positions = Vec::new();
    let mut indices = Vec::new();
    for k in 0..200u32 {
        let c = rng.vec(10.0);
        positions.extend([c, c + rng.vec(1.5), c + rng.vec(1.5)]);
        indices.push([3 * k, 3 * k + 1, 3 * k + 2]);
    }
    let spheres: Vec<Sphere> = (0..300)
        .map(|_| Sphere {
            center: rng.vec(10.0),
            radius: 0.05 + 0.8 * rng.next(),
        })
        .collect();
    let backends: Vec<(Backend, Box<dyn Accelerator>)> = Backend::available()
        .into_iter()
        .map(|b| (b, build(b, &positions, &indices, &spheres)))
        .collect();
    let (mut sphere_hits, mut tri_hits) = (0, 0);
    let mut all_rays = Vec::new();
    for _ in 0..20_000 {
        let o = rng.vec(14.0);
        let ray = Ray::new(o, (rng.vec(1.0) + Vec3::splat(1e-3)).normalize());
        all_rays.push(ray);
        let oracle = backends.last().unwrap().1.intersect(&ray);
        match oracle {
            Some(h) if h.prim >= 200 => sphere_hits += 1,
            Some(_) => tri_hits += 1,
            None => {}
        }
        for (b, a) in &backends {
            let h = a.intersect(&ray);
            match (h, oracle) {
                (Some(x), Some(y)) if x.prim >= 200 || y.prim >= 200 => {
                    assert_eq!(
                        (x.prim, x.t.to_bits()),
                        (y.prim, y.t.to_bits()),
                        "{b}: {ray:?}"
                    );
                }
                // triangles: Embree's own test, within its documented agreement
                (Some(x), Some(y)) => assert!((x.t - y.t).abs() <= 1e-5 * x.t.max(1.0), "{b}"),
                (x, y) => assert_eq!(x.is_some(), y.is_some(), "{b}: {ray:?}"),
            }
            assert_eq!(a.occluded(&ray), oracle.is_some(), "{b}: {ray:?}");
        }
    }
    assert!(
        sphere_hits > 2000 && tri_hits > 200,
        "{sphere_hits} {tri_hits}"
    );
    // batched queries (Embree's packets, whose lanes reach the sphere
    // callbacks in groups) answer as single rays do, bit for bit
    let bits = |h: Option<Hit>| h.map(|h| (h.prim, h.t.to_bits(), h.u.to_bits(), h.v.to_bits()));
    for (b, a) in &backends {
        for c in all_rays.chunks(16) {
            let mut hits = [None; 16];
            let mut occ = [false; 16];
            a.intersect_batch(c, &mut hits[..c.len()], Coherence::Incoherent);
            a.occluded_batch(c, &mut occ[..c.len()], Coherence::Incoherent);
            for (k, r) in c.iter().enumerate() {
                assert_eq!(bits(hits[k]), bits(a.intersect(r)), "{b}: batch on {r:?}");
                assert_eq!(occ[k], a.occluded(r), "{b}: batch occlusion on {r:?}");
            }
        }
    }
}

#[test]
fn rays_spawned_from_a_sphere_never_hit_it_at_its_own_point() {
    // Spheres with centres up to 1e3 away and radii from 1e-3 to 1e3: hit
    // them from outside, rebuild the point as shading does, and spawn rays
    // both ways. Outwards: the sphere is never hit again (it is convex).
    // Inwards: the far side (about 2 r cos theta), within rounding.
    let mut rng = Rng(42);
    let mut s = Sampler::new(3, 0, 0);
    let mut inward = 0;
    for k in 0..400 {
        let center = rng.vec(1.0e3);
        let radius = 10f32.powf(-3.0 + 6.0 * rng.next());
        let sphere = Sphere { center, radius };
        for (b, a) in all(&[sphere]) {
            for _ in 0..8 {
                let dir_in = square_to_uniform_sphere(s.next_2d());
                let o = center - dir_in * (radius * (2.0 + 3.0 * rng.next()));
                let ray = Ray::new(o, dir_in);
                let Some(h) = a.intersect(&ray) else {
                    continue;
                };
                let sp = SurfacePoint::on_sphere(center, radius, ray.at(h.t));
                let w = square_to_uniform_sphere(s.next_2d());
                let out = if w.dot(sp.n) > 0.0 { w } else { -w };
                assert!(
                    a.intersect(&spawn_ray(&sp, out)).is_none(),
                    "{b} sphere {k}: an outward ray hit the sphere again"
                );
                let inw = -out;
                let spawned = spawn_ray(&sp, inw);
                let far = a
                    .intersect(&spawned)
                    .unwrap_or_else(|| panic!("{b} sphere {k}: an inward ray left the sphere"));
                // the far root from the spawned origin, in f64: about
                // 2 r cos theta, longer for grazing rays (the origin sits a
                // little inside the surface)
                let f = (spawned.o - center).as_dvec3();
                let d = spawned.d.as_dvec3();
                let bb = -f.dot(d);
                let c = f.length_squared() - (radius as f64).powi(2);
                assert!(c < 0.0, "{b} sphere {k}: the spawned origin is outside");
                let expected = bb + (bb * bb - c).sqrt();
                let scale = (center.abs().max_element() + radius) as f64;
                assert!(
                    (far.t as f64 - expected).abs() <= 1e-5 * scale,
                    "{b} sphere {k}: far side at {} instead of {expected} (r {radius})",
                    far.t
                );
                assert!(
                    far.t as f64 >= 0.5 * 2.0 * radius as f64 * inw.dot(-sp.n) as f64,
                    "{b} sphere {k}: hit at {}, before the far side",
                    far.t
                );
                inward += 1;
            }
        }
    }
    assert!(inward > 1000);
}
