//! Whole renders of the bundled Cornell box: the image is the same bits for 1
//! and N threads; the three direct-lighting strategies converge to the same
//! image, as a whole and block by block; Embree and the naive backend answer
//! the box's rays alike.

mod common;

use common::sidak_z;
use embertrace::accel::{self, AccelOptions, Accelerator, Backend};
use embertrace::camera::Camera;
use embertrace::integrator::PathTracer;
use embertrace::math::{Ray, Vec2, Vec3};
use embertrace::render::{RenderOutput, RenderSettings, render};
use embertrace::sampler::{Sampler, SamplerKind};
use embertrace::scene::Scene;
use embertrace::settings::{DirectStrategy, IntegratorSettings};
use std::path::Path;

fn cornell() -> Scene {
    Scene::load(Path::new(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/scenes/cornell-box.toml"
    )))
    .unwrap()
}

fn render_box(
    scene: &Scene,
    backend: Backend,
    res: u32,
    spp: u32,
    threads: usize,
    tile: u32,
    direct: DirectStrategy,
) -> RenderOutput {
    render_box_seeded(scene, backend, res, spp, threads, tile, direct, 5)
}

#[allow(clippy::too_many_arguments)]
fn render_box_seeded(
    scene: &Scene,
    backend: Backend,
    res: u32,
    spp: u32,
    threads: usize,
    tile: u32,
    direct: DirectStrategy,
    seed: u64,
) -> RenderOutput {
    let acc = accel::build(backend, scene.soup(), AccelOptions::default()).unwrap();
    let settings = IntegratorSettings {
        direct,
        ..IntegratorSettings::default()
    };
    let tracer = PathTracer::new(scene, acc.as_ref(), settings);
    let camera = Camera::new(&scene.camera, res, res);
    let rs = RenderSettings {
        total_spp: None,
        resolution: [res, res],
        spp,
        first_sample: 0,
        seed,
        threads,
        tile_size: tile,
        sampler: SamplerKind::Independent,
        clamp: None,
    };
    render(&tracer, &camera, &rs, &|| {}).unwrap()
}

#[test]
fn same_bits_for_any_thread_count_and_tile_size() {
    let scene = cornell();
    let backend = Backend::default_backend();
    let one = render_box(&scene, backend, 40, 4, 1, 16, DirectStrategy::Mis);
    let many = render_box(&scene, backend, 40, 4, 3, 7, DirectStrategy::Mis);
    let a = one.film.to_rgb_f32();
    let b = many.film.to_rgb_f32();
    assert!(
        a.iter().zip(&b).all(|(x, y)| x.to_bits() == y.to_bits()),
        "images differ"
    );
    assert_eq!(one.rays, many.rays);
    assert_eq!(one.nonfinite.count, 0);
    assert!(a.iter().any(|&x| x > 0.0));
}

#[test]
fn colour_bleeds_from_the_walls() {
    // Light reflected off the red wall tints the white floor next to it, and
    // the green wall the floor on the other side: the floor's red/green
    // ratio (warm light: above 1 everywhere) is clearly higher by the red wall.
    let scene = cornell();
    let out = render_box(
        &scene,
        Backend::default_backend(),
        64,
        32,
        0,
        16,
        DirectStrategy::Mis,
    );
    let f = &out.film;
    // floor strips next to each wall, lower part of the image
    let strip = |x0: u32, x1: u32| {
        let mut c = Vec3::ZERO;
        for y in 54..60 {
            for x in x0..x1 {
                c += f.mean(x, y);
            }
        }
        c
    };
    let near_red = strip(9, 13);
    let near_green = strip(51, 55);
    let ratio_red = near_red.x / near_red.y;
    let ratio_green = near_green.x / near_green.y;
    eprintln!("floor red/green: {ratio_red} by the red wall, {ratio_green} by the green wall");
    assert!(
        ratio_red > 1.5 * ratio_green,
        "no colour bleeding: {near_red} vs {near_green}"
    );
}

/// Side of the square blocks of pixels that
/// [`direct_strategies_converge_to_the_same_image`] compares.
const STRATEGY_BLOCK: u32 = 4;

/// The three direct-lighting strategies converge to the same image, pixel
/// block by pixel block and as a whole. Each strategy renders with a seed of
/// its own, so the three estimates are independent and the variance of a
/// difference is the sum of the two variances (with one seed for all three,
/// MIS and light sampling draw nearly the same numbers and agree far inside
/// any band, whatever they compute).
///
/// - **Whole image**: the means, per channel, with standard errors from the
///   per-pixel variance; pairwise z within a Sidak band over 3 pairs x 3
///   channels at alpha 1e-6 (measured: about 3 % of the mean).
/// - **Per block**: every 4 x 4 block, per channel, the same z-test, Sidak
///   over 3 pairs x 36 blocks x 3 channels at alpha 1e-6. Blocks rather
///   than single pixels because a single pixel's variance estimate is not
///   usable here: BSDF sampling finds the small ceiling light with a few
///   per cent of its directions, so at 256 spp many floor pixels had no
///   sample that reached it, and both their mean and their variance
///   estimate were 0 (pixel z-scores of 30 against MIS, measured, with
///   nothing wrong). A block pools thousands of samples, enough for a
///   normal quantile. Measured bands, relative to a block's value: median
///   6.5 % between MIS and light sampling, 24 % against BSDF sampling
///   (which gets 4 times the samples, and is still the noisiest). A
///   difference that moves light within the image without changing its
///   mean (a mirrored image, a brighter patch) fails here and passes the
///   whole-image test.
#[test]
fn direct_strategies_converge_to_the_same_image() {
    let scene = cornell();
    let backend = Backend::default_backend();
    let res = 24;
    // BSDF sampling finds the small light rarely: 4 times the samples (its
    // samples cost less, as it traces no shadow rays)
    let outs: Vec<(DirectStrategy, RenderOutput)> = [
        (DirectStrategy::Mis, 5, 1024),
        (DirectStrategy::Light, 6, 1024),
        (DirectStrategy::Bsdf, 7, 4096),
    ]
    .into_iter()
    .map(|(d, seed, spp)| {
        (
            d,
            render_box_seeded(&scene, backend, res, spp, 0, 8, d, seed),
        )
    })
    .collect();
    // the mean and the variance of the mean of the pixels in x0..x1, y0..y1
    let stats = |o: &RenderOutput, x0: u32, x1: u32, y0: u32, y1: u32| {
        let (mut m, mut v) = (Vec3::ZERO.as_dvec3(), Vec3::ZERO.as_dvec3());
        for y in y0..y1 {
            for x in x0..x1 {
                m += o.film.mean(x, y).as_dvec3();
                v += o.film.variance_of_mean(x, y).as_dvec3();
            }
        }
        let n = ((x1 - x0) * (y1 - y0)) as f64;
        (m / n, v / (n * n))
    };
    let blocks = res / STRATEGY_BLOCK;
    let z_image = sidak_z(1e-6, 3 * 3);
    let z_block = sidak_z(1e-6, 3 * (blocks * blocks) as usize * 3);
    let mut failures = Vec::new();
    let mut worst = 0.0f64;
    for i in 0..outs.len() {
        for j in i + 1..outs.len() {
            let (a, b) = (&outs[i].1, &outs[j].1);
            let pair = format!("{} vs {}", outs[i].0, outs[j].0);
            let (ma, va) = stats(a, 0, res, 0, res);
            let (mb, vb) = stats(b, 0, res, 0, res);
            for c in 0..3 {
                let se = (va[c] + vb[c]).sqrt();
                if (ma[c] - mb[c]).abs() >= z_image * se {
                    failures.push(format!(
                        "{pair}, whole image, channel {c}: {} vs {} (se {se})",
                        ma[c], mb[c]
                    ));
                }
            }
            for by in 0..blocks {
                for bx in 0..blocks {
                    let (x0, y0) = (bx * STRATEGY_BLOCK, by * STRATEGY_BLOCK);
                    let (x1, y1) = (x0 + STRATEGY_BLOCK, y0 + STRATEGY_BLOCK);
                    let (ma, va) = stats(a, x0, x1, y0, y1);
                    let (mb, vb) = stats(b, x0, x1, y0, y1);
                    for c in 0..3 {
                        let se = (va[c] + vb[c]).sqrt();
                        let z = (ma[c] - mb[c]).abs() / se.max(1e-300);
                        worst = worst.max(z);
                        if z >= z_block {
                            failures.push(format!(
                                "{pair}, block ({bx}, {by}) channel {c}: {:.5} vs {:.5} ({z:.1} se)",
                                ma[c], mb[c]
                            ));
                        }
                    }
                }
            }
        }
    }
    eprintln!("worst block at {worst:.2} se (band {z_block:.2})");
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

fn adjacent(scene: &Scene, a: u32, b: u32) -> bool {
    let ta = scene.indices[a as usize];
    let tb = scene.indices[b as usize];
    let pa = ta.map(|i| scene.positions[i as usize]);
    let pb = tb.map(|i| scene.positions[i as usize]);
    pa.iter().filter(|p| pb.contains(p)).count() >= 1
}

#[test]
fn embree_and_naive_agree_on_cornell_box_rays() {
    let backends = Backend::available();
    if !backends.contains(&Backend::Embree) {
        eprintln!("built without Embree: nothing to compare");
        return;
    }
    let scene = cornell();
    let e = accel::build(Backend::Embree, scene.soup(), AccelOptions::default()).unwrap();
    let n = accel::build(Backend::Naive, scene.soup(), AccelOptions::default()).unwrap();
    let camera = Camera::new(&scene.camera, 64, 64);
    let mut rays: Vec<Ray> = Vec::new();
    for y in 0..64 {
        for x in 0..64 {
            rays.push(camera.generate_ray(Vec2::new(x as f32 + 0.5, y as f32 + 0.5)));
        }
    }
    let mut s = Sampler::new(11, 0, 0);
    for _ in 0..20_000 {
        let o = Vec3::new(
            s.next_1d() * 1.98 - 0.99,
            s.next_1d() * 1.98 + 0.01,
            s.next_1d() * 1.98 - 0.99,
        );
        let d = embertrace::sampling::square_to_uniform_sphere(s.next_2d());
        let mut r = Ray::new(o, d);
        if s.next_1d() < 0.3 {
            r.t_max = s.next_1d() * 2.0;
        }
        rays.push(r);
    }
    let (mut prim_diff, mut t_diff) = (0, 0);
    for r in &rays {
        let (he, hn) = (e.intersect(r), n.intersect(r));
        assert_eq!(
            he.is_some(),
            hn.is_some(),
            "hit/miss disagree on {r:?}: {he:?} vs {hn:?}"
        );
        assert_eq!(e.occluded(r), n.occluded(r), "occlusion disagrees on {r:?}");
        if let (Some(a), Some(b)) = (he, hn) {
            if (a.t - b.t).abs() > 1e-5 * a.t.max(1.0) {
                t_diff += 1;
            }
            if a.prim != b.prim {
                assert!(
                    adjacent(&scene, a.prim, b.prim),
                    "{r:?}: prims {} and {} not adjacent",
                    a.prim,
                    b.prim
                );
                prim_diff += 1;
            }
        }
    }
    assert_eq!(t_diff, 0, "distance disagreements");
    eprintln!(
        "{} rays: {prim_diff} primitive differences across shared edges",
        rays.len()
    );
}

#[test]
fn occluded_matches_intersect() {
    let scene = cornell();
    for backend in Backend::available() {
        let acc: Box<dyn Accelerator> =
            accel::build(backend, scene.soup(), AccelOptions::default()).unwrap();
        let mut s = Sampler::new(12, 0, 0);
        for _ in 0..5000 {
            let o = Vec3::new(
                s.next_1d() * 1.9 - 0.95,
                s.next_1d() * 1.9 + 0.05,
                s.next_1d() * 1.9 - 0.95,
            );
            let mut r = Ray::new(
                o,
                embertrace::sampling::square_to_uniform_sphere(s.next_2d()),
            );
            r.t_max = s.next_1d() * 3.0;
            assert_eq!(
                acc.occluded(&r),
                acc.intersect(&r).is_some(),
                "{backend}: {r:?}"
            );
        }
    }
}

#[test]
fn embree_and_naive_trace_the_same_paths() {
    // With one self-intersection policy, both backends see the same hits, so
    // the same seed traces the same paths: ray counts agree to a few rays in
    // a million (paths may split only where a ray meets a shared edge), and
    // the images agree far inside the noise. Before the conservative-t check
    // and the isotropic error bound, origins on the floor plane re-hit it in
    // one backend only and the shadow-ray counts differed by 2 %.
    if !Backend::available().contains(&Backend::Embree) {
        return;
    }
    let scene = cornell();
    let e = render_box(&scene, Backend::Embree, 48, 8, 0, 16, DirectStrategy::Mis);
    let n = render_box(&scene, Backend::Naive, 48, 8, 0, 16, DirectStrategy::Mis);
    for (a, b, kind) in [
        (e.rays.extension, n.rays.extension, "extension"),
        (e.rays.shadow, n.rays.shadow, "shadow"),
    ] {
        let rel = (a as f64 - b as f64).abs() / b as f64;
        assert!(rel < 1e-4, "{kind} rays: embree {a}, naive {b}");
    }
    let (ma, mb) = (e.film.mean_rgb(), n.film.mean_rgb());
    for c in 0..3 {
        assert!(
            (ma[c] - mb[c]).abs() < 1e-4 * mb[c],
            "channel {c}: {} vs {}",
            ma[c],
            mb[c]
        );
    }
}

fn render_sampler(scene: &Scene, sampler: SamplerKind, spp: u32, threads: usize) -> RenderOutput {
    let acc = accel::build(
        Backend::default_backend(),
        scene.soup(),
        AccelOptions::default(),
    )
    .unwrap();
    let tracer = PathTracer::new(scene, acc.as_ref(), IntegratorSettings::default());
    let camera = Camera::new(&scene.camera, 24, 24);
    let rs = RenderSettings {
        total_spp: None,
        resolution: [24, 24],
        spp,
        first_sample: 0,
        seed: 7,
        threads,
        tile_size: 8,
        sampler,
        clamp: None,
    };
    render(&tracer, &camera, &rs, &|| {}).unwrap()
}

#[test]
fn sobol_sampler_is_deterministic_and_unbiased() {
    let scene = cornell();
    let one = render_sampler(&scene, SamplerKind::Sobol, 16, 1);
    let many = render_sampler(&scene, SamplerKind::Sobol, 16, 3);
    let a = one.film.to_rgb_f32();
    assert!(
        a.iter()
            .zip(&many.film.to_rgb_f32())
            .all(|(x, y)| x.to_bits() == y.to_bits()),
        "sobol images differ between 1 and 3 threads"
    );
    assert_eq!(one.nonfinite.count, 0);
    let ind = render_sampler(&scene, SamplerKind::Independent, 16, 0);
    assert_ne!(
        a,
        ind.film.to_rgb_f32(),
        "the sampler option changed nothing"
    );
    // Same expected image: the image means agree within 5 sigma, sigma from
    // the per-pixel variance of the mean (for the Sobol render an upper
    // bound, since stratified samples vary less than independent ones).
    let stats = |o: &RenderOutput| {
        let (w, h) = (o.film.width(), o.film.height());
        let (mut m, mut v) = (0.0f64, 0.0f64);
        for y in 0..h {
            for x in 0..w {
                let p = o.film.pixel(x, y);
                m += p.mean_f64().iter().sum::<f64>();
                v += p.variance_of_mean_f64().iter().sum::<f64>();
            }
        }
        let n = (w * h) as f64;
        (m / n, v.sqrt() / n)
    };
    let ((ms, ss), (mi, si)) = (stats(&one), stats(&ind));
    assert!(
        (ms - mi).abs() < 5.0 * (ss * ss + si * si).sqrt(),
        "image means differ: sobol {ms} +- {ss}, independent {mi} +- {si}"
    );
}
