//! Whole-integrator closed forms from `../shared/docs/hard-cases.md`:
//! the zero-variance emissive furnace (case 21), and polygon lights over a
//! diffuse receiver whose answer is `rho * Le * F` (section C, case 17),
//! each with every direct-lighting strategy and every backend.

mod common;

use common::{MeshMaker, batch_means, lambert_form_factor, sidak_z};
use embertrace::accel::{self, AccelOptions, Backend};
use embertrace::integrator::{PathTracer, RayCounts};
use embertrace::math::{Ray, Vec3};
use embertrace::sampler::Sampler;
use embertrace::scene::Scene;
use embertrace::settings::{DirectStrategy, IntegratorSettings, Roulette};

fn tracer_settings(
    max_depth: u32,
    direct: DirectStrategy,
    roulette: Roulette,
) -> IntegratorSettings {
    IntegratorSettings {
        max_depth,
        light_samples: 1,
        direct,
        roulette,
        rr_depth: 1,
        ..IntegratorSettings::default()
    }
}

fn furnace(rho: f32) -> Scene {
    let mut m = MeshMaker::default();
    let mat = m.material(rho, 1.0, false);
    m.inward_box(Vec3::splat(-1.0), Vec3::splat(1.0), mat);
    m.scene()
}

/// Camera rays from inside the furnace, spread over the sphere. (A ray aimed
/// exactly at a concave edge of the box can leak: its hit point lies on both
/// walls, and the offset along one wall's normal cannot keep it inside the
/// other. That case belongs to the self-intersection work, not to this test.)
fn furnace_rays(n: usize) -> Vec<Ray> {
    let mut rays: Vec<Ray> = vec![Ray::new(Vec3::ZERO, Vec3::X)];
    let mut s = Sampler::new(99, 0, 0);
    while rays.len() < n {
        let d = embertrace::sampling::square_to_uniform_sphere(s.next_2d());
        rays.push(Ray::new(Vec3::new(0.1, -0.2, 0.3), d));
    }
    rays
}

#[test]
fn emissive_furnace_every_sample_is_exact() {
    // BSDF-only, no roulette: every path sees Le at each of its D+1 vertices,
    // weighted rho^k, so every single sample equals sum_k rho^k. One leaked
    // ray (a miss, or a self-hit skipping a bounce) breaks equality.
    for backend in Backend::available() {
        for rho in [0.5f32, 0.8] {
            let scene = furnace(rho);
            let acc = accel::build(backend, scene.soup(), AccelOptions::default()).unwrap();
            for depth in [0u32, 1, 2, 5, 12] {
                let t = PathTracer::new(
                    &scene,
                    acc.as_ref(),
                    tracer_settings(depth, DirectStrategy::Bsdf, Roulette::Fixed(1.0)),
                );
                let expected = (1.0 - (rho as f64).powi(depth as i32 + 1)) / (1.0 - rho as f64);
                for (i, ray) in furnace_rays(400).iter().enumerate() {
                    let mut s = Sampler::new(1, i as u64, 0);
                    let l = t.li(ray, &mut s, &mut RayCounts::default());
                    for c in 0..3 {
                        // f32 rounding over <= 13 bounces: well below 1e-5 relative;
                        // a lost bounce costs at least rho^12 = 2.4e-4 of the answer
                        let rel = (l[c] as f64 - expected).abs() / expected;
                        assert!(
                            rel < 1e-5,
                            "{backend}: rho {rho}, depth {depth}, ray {i}: {} != {expected}",
                            l[c]
                        );
                    }
                }
            }
        }
    }
}

#[test]
fn emissive_furnace_with_light_sampling_and_roulette() {
    // MIS with throughput roulette from bounce 1, and with fixed roulette:
    // mean Le / (1 - rho) within a Sidak-corrected band from batch means.
    // Light sampling alone is left out here: in a box, a shading point near
    // a concave edge samples the adjacent wall with a 1/r^2 weight whose
    // variance is infinite, so no batch-means band is valid for it (the
    // polygon-light tests below cover light-only sampling).
    let cases = [(0.5f32, 2.0f64), (0.8, 5.0)];
    let strategies = [Roulette::Throughput, Roulette::Fixed(0.7)];
    let backends = Backend::available();
    let z = sidak_z(1e-6, cases.len() * strategies.len() * backends.len());
    for backend in backends {
        for (rho, expected) in cases {
            let scene = furnace(rho);
            let acc = accel::build(backend, scene.soup(), AccelOptions::default()).unwrap();
            for roulette in strategies {
                let t = PathTracer::new(
                    &scene,
                    acc.as_ref(),
                    tracer_settings(1000, DirectStrategy::Mis, roulette),
                );
                let rays = furnace_rays(64);
                let stats = batch_means(40_000, 100, |i| {
                    let mut s = Sampler::new(7, i as u64, 1);
                    let l = t.li(&rays[i % rays.len()], &mut s, &mut RayCounts::default());
                    l.x as f64
                });
                assert!(
                    (stats.mean - expected).abs() < z * stats.std_err,
                    "{backend} {roulette:?}: rho {rho}: {} +- {} vs {expected}",
                    stats.mean,
                    stats.std_err
                );
            }
        }
    }
}

/// A receiver (rho = 0.5) at z = 0 and a one-sided light polygon above it
/// facing down; returns the scene and the light's corners.
fn light_over_receiver(poly: Vec<Vec3>) -> Scene {
    let mut m = MeshMaker::default();
    let receiver = m.material(0.5, 0.0, false);
    let light = m.material(0.0, 1.0, false);
    let r = 4.0;
    m.quad(
        Vec3::new(-r, -r, 0.0),
        Vec3::new(r, -r, 0.0),
        Vec3::new(r, r, 0.0),
        Vec3::new(-r, r, 0.0),
        receiver,
    );
    // fan from the first corner, wound to face -z
    for i in 1..poly.len() - 1 {
        let (a, b, c) = (poly[0], poly[i], poly[i + 1]);
        if (b - a).cross(c - a).z < 0.0 {
            m.tri(a, b, c, light);
        } else {
            m.tri(a, c, b, light);
        }
    }
    m.scene()
}

#[test]
fn polygon_lights_match_lamberts_formula_with_every_strategy() {
    let disk: Vec<Vec3> = (0..64)
        .map(|i| {
            let a = 2.0 * std::f32::consts::PI * i as f32 / 64.0;
            Vec3::new(a.cos(), a.sin(), 1.0)
        })
        .collect();
    let centred_square = vec![
        Vec3::new(-0.5, -0.5, 1.0),
        Vec3::new(0.5, -0.5, 1.0),
        Vec3::new(0.5, 0.5, 1.0),
        Vec3::new(-0.5, 0.5, 1.0),
    ];
    let corner_square = vec![
        Vec3::new(0.0, 0.0, 1.0),
        Vec3::new(1.0, 0.0, 1.0),
        Vec3::new(1.0, 1.0, 1.0),
        Vec3::new(0.0, 1.0, 1.0),
    ];
    let triangle = vec![
        Vec3::new(0.0, 0.0, 1.0),
        Vec3::new(1.0, 0.0, 1.0),
        Vec3::new(0.0, 1.0, 1.0),
    ];
    // the document's closed forms check our Lambert's-formula helper
    for (poly, f) in [
        (&centred_square, 0.2394565),
        (&corner_square, 0.1385316),
        (&triangle, 0.0962250),
    ] {
        assert!((lambert_form_factor(poly, Vec3::Z) - f).abs() < 5e-7);
    }
    // a 64-gon of radius 1 at height 1 is close to the disk's R^2/(R^2+h^2) = 0.5
    let f_disk = lambert_form_factor(&disk, Vec3::Z);
    assert!(
        (f_disk - 0.5).abs() < 0.5 * 0.0017,
        "64-gon form factor {f_disk}"
    );

    let cases = [
        ("disk", disk),
        ("centred square", centred_square),
        ("corner square", corner_square),
        ("triangle", triangle),
    ];
    let strategies = [
        DirectStrategy::Light,
        DirectStrategy::Bsdf,
        DirectStrategy::Mis,
    ];
    let backends = Backend::available();
    let m = cases.len() * strategies.len() * backends.len();
    let z = sidak_z(1e-6, m);
    // pairwise comparisons: 3 pairs per case and backend
    let z_pair = sidak_z(1e-6, cases.len() * 3 * backends.len());
    for backend in &backends {
        for (name, poly) in &cases {
            let expected = 0.5 * lambert_form_factor(poly, Vec3::Z);
            let scene = light_over_receiver(poly.clone());
            let acc = accel::build(*backend, scene.soup(), AccelOptions::default()).unwrap();
            let ray = Ray::new(Vec3::new(0.0, 0.0, 0.5), -Vec3::Z);
            let mut results = Vec::new();
            for direct in strategies {
                let t = PathTracer::new(
                    &scene,
                    acc.as_ref(),
                    tracer_settings(1, direct, Roulette::Throughput),
                );
                let stats = batch_means(100_000, 100, |i| {
                    let mut s = Sampler::new(3, 0, i as u64);
                    t.li(&ray, &mut s, &mut RayCounts::default()).y as f64
                });
                assert!(
                    (stats.mean - expected).abs() < z * stats.std_err.max(1e-9),
                    "{backend} {name} {direct}: {} +- {} vs {expected}",
                    stats.mean,
                    stats.std_err
                );
                results.push((direct, stats));
            }
            for i in 0..results.len() {
                for j in i + 1..results.len() {
                    let (a, b) = (&results[i].1, &results[j].1);
                    let se = (a.std_err.powi(2) + b.std_err.powi(2)).sqrt().max(1e-9);
                    assert!(
                        (a.mean - b.mean).abs() < z_pair * se,
                        "{backend} {name}: {} and {} disagree: {} vs {}",
                        results[i].0,
                        results[j].0,
                        a.mean,
                        b.mean
                    );
                }
            }
        }
    }
}

#[test]
fn environment_furnace_every_sample_is_rho() {
    // Hard case 23: a convex box (faces outward) with albedo rho inside a
    // uniform environment of radiance 1, BSDF sampling only, no roulette:
    // a camera ray that hits the box sees exactly rho (one bounce, then the
    // sky), a miss sees 1. A self-hit after the bounce shows as rho^2 or
    // less, so equality to f32 rounding (1e-5 relative) catches every leak.
    let mut s = Sampler::new(23, 0, 0);
    for backend in Backend::available() {
        for rho in [0.5f32, 0.8] {
            let mut m = MeshMaker::default();
            let mat = m.material(rho, 0.0, false);
            // lo and hi swapped: the same box with its faces pointing out
            m.inward_box(Vec3::new(1.0, 0.5, 0.7), Vec3::new(-1.0, -0.5, -0.7), mat);
            let mut scene = m.scene();
            scene.environment = Some(Vec3::ONE);
            let acc = accel::build(backend, scene.soup(), AccelOptions::default()).unwrap();
            let t = PathTracer::new(
                &scene,
                acc.as_ref(),
                tracer_settings(8, DirectStrategy::Bsdf, Roulette::Fixed(1.0)),
            );
            let mut hits = 0;
            for i in 0..2000 {
                let o = embertrace::sampling::square_to_uniform_sphere(s.next_2d()) * 4.0;
                let target =
                    Vec3::new(s.next_1d() - 0.5, s.next_1d() - 0.5, s.next_1d() - 0.5) * 2.2;
                let ray = Ray::new(o, (target - o).normalize());
                let expected = if acc.intersect(&ray).is_some() {
                    hits += 1;
                    rho
                } else {
                    1.0
                };
                let mut smp = Sampler::new(2, i, 0);
                let l = t.li(&ray, &mut smp, &mut RayCounts::default());
                for c in 0..3 {
                    assert!(
                        (l[c] - expected).abs() <= 1e-5 * expected,
                        "{backend}: rho {rho}, ray {i}: {} != {expected}",
                        l[c]
                    );
                }
            }
            assert!(hits > 500, "{backend}: only {hits} rays hit the box");
        }
    }
}

#[test]
fn roulette_is_unbiased_in_a_bright_furnace() {
    // Hard case 24: rho = 0.9, Le = 1 (answer 10). Without roulette at
    // depth 1000, BSDF sampling only, every sample equals the truncated sum
    // (1 - 0.9^1001) / 0.1 exactly (to f32 rounding over 1000 bounces:
    // 1e-4 relative); with throughput roulette from depth 1, 3 or 5 and MIS,
    // the mean is 10 within a Sidak-corrected band from batch means, and
    // every sample is finite.
    let rho = 0.9f32;
    let backends = Backend::available();
    let depths = [1u32, 3, 5];
    let z = sidak_z(1e-6, depths.len() * backends.len());
    let rays = furnace_rays(64);
    for backend in backends {
        let scene = furnace(rho);
        let acc = accel::build(backend, scene.soup(), AccelOptions::default()).unwrap();
        let exact = (1.0 - 0.9f64.powi(1001)) / 0.1;
        let t = PathTracer::new(
            &scene,
            acc.as_ref(),
            tracer_settings(1000, DirectStrategy::Bsdf, Roulette::Fixed(1.0)),
        );
        for (i, ray) in rays.iter().enumerate().take(16) {
            let l = t.li(
                ray,
                &mut Sampler::new(3, i as u64, 0),
                &mut RayCounts::default(),
            );
            assert!(
                (l.x as f64 - exact).abs() < 1e-4 * exact,
                "{backend}: no roulette, ray {i}: {} != {exact}",
                l.x
            );
        }
        for rr_depth in depths {
            let settings = IntegratorSettings {
                rr_depth,
                ..tracer_settings(1000, DirectStrategy::Mis, Roulette::Throughput)
            };
            let t = PathTracer::new(&scene, acc.as_ref(), settings);
            let stats = batch_means(40_000, 100, |i| {
                let mut s = Sampler::new(24, i as u64, rr_depth as u64);
                let l = t.li(&rays[i % rays.len()], &mut s, &mut RayCounts::default());
                assert!(l.is_finite(), "{backend}: non-finite sample {l}");
                l.x as f64
            });
            assert!(
                (stats.mean - 10.0).abs() < z * stats.std_err,
                "{backend}: roulette from depth {rr_depth}: {} +- {} vs 10",
                stats.mean,
                stats.std_err
            );
        }
    }
}

#[test]
fn light_very_close_to_the_receiver() {
    // Hard case 18: a unit square light (Le = 1, facing down) centred at
    // height h over a receiver (rho = 0.5) seen at its centre, MIS. Every
    // sample is finite and non-negative at every height. For h = 1 .. 1e-4
    // the mean is rho * F(h) within a Sidak-corrected band. h = 1e-6 lies
    // below the offset policy's documented gap (`min_gap(4)` = 3.6e-5 for
    // the 8-unit receiver): the light may be skipped there (the mean is at
    // most the answer, never more), the bias `embertrace::math` names. At
    // h = 0 (light in the receiver's plane) nothing arrives. The camera
    // ray comes in under the light, grazing.
    let heights = [1.0f32, 1e-2, 1e-4, 1e-6, 0.0];
    let backends = Backend::available();
    let z = sidak_z(1e-6, heights.len() * backends.len());
    for backend in &backends {
        for h in heights {
            let square = vec![
                Vec3::new(-0.5, -0.5, h),
                Vec3::new(0.5, -0.5, h),
                Vec3::new(0.5, 0.5, h),
                Vec3::new(-0.5, 0.5, h),
            ];
            let expected = if h > 0.0 {
                0.5 * lambert_form_factor(&square, Vec3::Z)
            } else {
                0.0
            };
            let scene = light_over_receiver(square);
            let acc = accel::build(*backend, scene.soup(), AccelOptions::default()).unwrap();
            let t = PathTracer::new(
                &scene,
                acc.as_ref(),
                tracer_settings(1, DirectStrategy::Mis, Roulette::Throughput),
            );
            let o = Vec3::new(3.0, 0.0, 0.5 * h);
            let ray = Ray::new(o, (Vec3::ZERO - o).normalize());
            let stats = batch_means(100_000, 100, |i| {
                let mut s = Sampler::new(18, 0, i as u64);
                let l = t.li(&ray, &mut s, &mut RayCounts::default());
                assert!(
                    l.is_finite() && l.min_element() >= 0.0,
                    "{backend} h {h}: sample {l}"
                );
                l.y as f64
            });
            let band = z * stats.std_err.max(1e-9);
            if h == 0.0 {
                assert_eq!(
                    stats.mean, 0.0,
                    "{backend}: a light in the receiver's plane lit it"
                );
            } else if h < embertrace::math::min_gap(4.0) {
                assert!(
                    stats.mean <= expected + band,
                    "{backend} h {h}: {} above {expected}",
                    stats.mean
                );
            } else {
                assert!(
                    (stats.mean - expected).abs() < band,
                    "{backend} h {h}: {} +- {} vs {expected}",
                    stats.mean,
                    stats.std_err
                );
            }
        }
    }
}

#[test]
fn zero_area_and_zero_power_emitters_change_nothing() {
    // Hard case 19: emissive triangles with no area (collinear corners, a
    // repeated corner) and an emitter with Le = 0 are never selected: the
    // light list and every image bit equal those of the scene without them
    // (with the Le = 0 triangle kept as plain geometry in both).
    let square = [
        Vec3::new(-0.5, -0.5, 1.0),
        Vec3::new(0.5, -0.5, 1.0),
        Vec3::new(0.5, 0.5, 1.0),
        Vec3::new(-0.5, 0.5, 1.0),
    ];
    let build = |extra: bool| {
        let mut m = MeshMaker::default();
        let receiver = m.material(0.5, 0.0, false);
        let light = m.material(0.0, 1.0, false);
        let dark = m.material(0.5, 0.0, false);
        m.quad(
            Vec3::new(-4.0, -4.0, 0.0),
            Vec3::new(4.0, -4.0, 0.0),
            Vec3::new(4.0, 4.0, 0.0),
            Vec3::new(-4.0, 4.0, 0.0),
            receiver,
        );
        m.quad(square[0], square[3], square[2], square[1], light);
        m.tri(
            Vec3::new(2.0, 2.0, 0.5),
            Vec3::new(3.0, 2.0, 0.5),
            Vec3::new(2.0, 3.0, 0.5),
            dark,
        );
        if extra {
            let a = Vec3::new(-2.0, 1.0, 0.7);
            m.tri(a, a + Vec3::X, a + 2.0 * Vec3::X, light); // collinear
            m.tri(a, a, a + Vec3::Y, light); // repeated corner
        }
        m.scene()
    };
    let (plain, with) = (build(false), build(true));
    let lights = |s: &Scene| embertrace::integrator::Lights::new(s).area_lights().len();
    // the square light's two triangles make one quad light
    assert_eq!(lights(&plain), 1);
    assert_eq!(lights(&with), lights(&plain));
    for backend in Backend::available() {
        let image = |s: &Scene| {
            let acc = accel::build(backend, s.soup(), AccelOptions::default()).unwrap();
            let t = PathTracer::new(
                s,
                acc.as_ref(),
                tracer_settings(3, DirectStrategy::Mis, Roulette::Throughput),
            );
            (0..2000)
                .map(|i| {
                    let o = Vec3::new(3.0, -1.0, 0.4);
                    let d = (Vec3::new(
                        (i % 40) as f32 * 0.1 - 2.0,
                        (i / 40) as f32 * 0.1 - 2.5,
                        0.0,
                    ) - o)
                        .normalize();
                    let l = t.li(
                        &Ray::new(o, d),
                        &mut Sampler::new(19, i, 0),
                        &mut RayCounts::default(),
                    );
                    l.to_array().map(f32::to_bits)
                })
                .collect::<Vec<_>>()
        };
        assert_eq!(
            image(&plain),
            image(&with),
            "{backend}: degenerate emitters changed the image"
        );
    }
}
