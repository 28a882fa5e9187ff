//! A speed report for the BVH backend, not a pass/fail test (it asserts only
//! that rays hit): build time and single-threaded Mrays/s on a displaced
//! sphere of about 200k triangles (`BVH_SPEED_TRIANGLES` overrides). Run in
//! release:
//!
//! ```sh
//! cargo test --release --no-default-features --test bvh_speed -- --ignored --nocapture
//! ```
//!
//! Each figure is the best of `BVH_SPEED_REPS` (default 5) passes over the
//! same rays, which is the least disturbed by other load on the machine.

use embertrace::accel::bvh::{Bvh, BvhQuality};
use embertrace::accel::{Accelerator, TriangleSoup};
use embertrace::math::{Ray, Vec3};
use embertrace::sampler::Sampler;
use embertrace::sampling::square_to_uniform_sphere;
use embertrace::scene::Material;
use embertrace::scene::procedural::{Shape, generate};
use std::time::Instant;

fn env(name: &str, default: usize) -> usize {
    std::env::var(name)
        .ok()
        .and_then(|v| v.replace('_', "").parse().ok())
        .unwrap_or(default)
}

/// Best-of-`reps` Mrays/s of `f` over `rays`, and the count it returned.
fn measure(rays: &[Ray], reps: usize, f: impl Fn(&Ray) -> bool) -> (f64, usize) {
    let mut best = f64::INFINITY;
    let mut count = 0;
    for _ in 0..reps {
        let t = Instant::now();
        count = rays.iter().filter(|r| f(r)).count();
        best = best.min(t.elapsed().as_secs_f64());
    }
    (rays.len() as f64 / best / 1e6, count)
}

#[test]
#[ignore = "speed report; run in release with --ignored --nocapture"]
fn bvh_speed_on_displaced_sphere() {
    let triangles = env("BVH_SPEED_TRIANGLES", 200_000);
    let reps = env("BVH_SPEED_REPS", 5);
    let n_rays = env("BVH_SPEED_RAYS", 500_000);
    let mesh = generate(
        Shape::Sphere,
        triangles as u64,
        0.15,
        1,
        "sphere",
        Material::default(),
    );
    let positions: Vec<_> = mesh.positions.iter().map(|p| p.as_vec3()).collect();
    let soup = TriangleSoup::triangles(&positions, &mesh.indices);
    let mut s = Sampler::new(42, 0, 0);
    // from outside towards random points inside the sphere: "primary" rays
    let outside: Vec<Ray> = (0..n_rays)
        .map(|_| {
            let o = square_to_uniform_sphere(s.next_2d()) * 3.0;
            let target = square_to_uniform_sphere(s.next_2d()) * 0.7 * s.next_1d();
            Ray::new(o, (target - o).normalize())
        })
        .collect();
    // from near the surface in random directions: "bounce" rays
    let inside: Vec<Ray> = (0..n_rays)
        .map(|_| {
            let o = square_to_uniform_sphere(s.next_2d()) * 0.8;
            Ray::new(o, square_to_uniform_sphere(s.next_2d()))
        })
        .collect();
    // shadow rays between random points on opposite sides
    let shadow: Vec<Ray> = (0..n_rays)
        .map(|_| {
            let a = square_to_uniform_sphere(s.next_2d()) * 2.0;
            let b = square_to_uniform_sphere(s.next_2d()) * 0.5 + Vec3::new(0.0, 0.0, 0.0);
            let d = b - a;
            Ray {
                t_max: d.length(),
                ..Ray::new(a, d.normalize())
            }
        })
        .collect();
    println!(
        "displaced sphere, {} triangles, {} rays per set, best of {reps}, 1 thread",
        mesh.indices.len(),
        n_rays
    );
    for quality in [BvhQuality::Fast, BvhQuality::High] {
        let t = Instant::now();
        let bvh = Bvh::new(soup, quality).expect("build");
        let build = t.elapsed().as_secs_f64();
        let st = bvh.stats();
        let (m_out, h_out) = measure(&outside, reps, |r| bvh.intersect(r).is_some());
        let (m_in, h_in) = measure(&inside, reps, |r| bvh.intersect(r).is_some());
        let (m_sh, _) = measure(&shadow, reps, |r| bvh.occluded(r));
        println!(
            "{quality:?}: build {:.0} ms, {:.1} B/tri, {} nodes, {} leaves, depth {}; \
             Mrays/s: closest-hit from outside {m_out:.2}, from inside {m_in:.2}, \
             occlusion {m_sh:.2}",
            build * 1e3,
            bvh.memory_bytes() as f64 / mesh.indices.len() as f64,
            st.nodes,
            st.leaves,
            st.depth,
        );
        assert_eq!(h_in, n_rays, "every ray from inside hits the closed sphere");
        assert!(h_out > n_rays / 2);
    }
}
