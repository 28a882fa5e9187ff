//! Alpha masks (`alpha` on a `[[mesh]]`): every backend ignores the same
//! candidate hits (the naive and BVH backends bit for bit, Embree on the
//! same primitives), a constant opacity `a` stops its share `a` of the rays
//! and two layers decide independently (binomial bands), opacities 0 and 1
//! are exact, a texture's zeros are holes and its ones are solid, shadow
//! rays see through, a black cut-out screen in front of a light lets
//! `1 - a` of it through in a render, and bad input is a one-line error.

mod common;

use common::backends;
use embertrace::accel::{self, AccelOptions, Accelerator, Backend, Hit};
use embertrace::integrator::PathTracer;
use embertrace::math::{Ray, Vec3};
use embertrace::render::{RenderSettings, render};
use embertrace::sampler::{Sampler, SamplerKind};
use embertrace::scene::Scene;
use embertrace::settings::IntegratorSettings;
use std::path::Path;

/// A 2 x 2 quad in the plane `z = 0` facing +z, UVs 0..1 over it.
const QUAD: &str = "v -1 -1 0\nv 1 -1 0\nv 1 1 0\nv -1 1 0\n\
vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nf 1/1 2/2 3/3\nf 1/1 3/3 4/4\n";

/// An 8 x 1 grey PNG: the left four texels 0, the right four 255.
fn halves_png() -> Vec<u8> {
    let mut bytes = Vec::new();
    let img = image::GrayImage::from_fn(8, 1, |x, _| image::Luma([if x < 4 { 0 } else { 255 }]));
    img.write_to(
        &mut std::io::Cursor::new(&mut bytes),
        image::ImageFormat::Png,
    )
    .unwrap();
    bytes
}

/// Load `toml` (a camera is added) beside `quad.obj` and `halves.png`.
fn load(toml: &str) -> Result<Scene, String> {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("quad.obj"), QUAD).unwrap();
    std::fs::write(dir.path().join("halves.png"), halves_png()).unwrap();
    let p = dir.path().join("s.toml");
    std::fs::write(
        &p,
        format!("[camera]\norigin = [0.0, 0.0, 5.0]\ntarget = [0.0, 0.0, 0.0]\n{toml}"),
    )
    .unwrap();
    Scene::load(&p).map_err(|e| e.to_string())
}

/// A `[[mesh]]` of the quad with `extra` keys (on the line after `file`).
fn quad(extra: &str) -> String {
    format!("[[mesh]]\nfile = \"quad.obj\"\n{extra}\n")
}

/// The quad moved to height `z`, with `extra` keys.
fn quad_at(z: f32, extra: &str) -> String {
    quad(&format!(
        "{extra}\ntransform = {{ translate = [0.0, 0.0, {z}] }}"
    ))
}

/// `n` rays from above the quads (z = 3), aimed at random points of the
/// central 1.6 x 1.6 square of the plane z = 0 (inside the quads).
fn rays_down(n: usize, seed: u64) -> Vec<Ray> {
    let mut s = Sampler::new(seed, 0, 0);
    (0..n)
        .map(|_| {
            let o = Vec3::new(s.next_1d() - 0.5, s.next_1d() - 0.5, 3.0);
            let p = Vec3::new(1.6 * s.next_1d() - 0.8, 1.6 * s.next_1d() - 0.8, 0.0);
            Ray::new(o, (p - o).normalize())
        })
        .collect()
}

/// The masked closest hits of `rays`.
fn hits(scene: &Scene, a: &dyn Accelerator, rays: &[Ray]) -> Vec<Option<Hit>> {
    let alpha = scene.alpha_test().expect("the scene has masks");
    rays.iter().map(|r| a.intersect_masked(r, alpha)).collect()
}

/// Five binomial standard deviations around `p` for `n` trials.
fn band(p: f64, n: usize) -> f64 {
    5.0 * (p * (1.0 - p) / n as f64).sqrt()
}

#[test]
fn a_constant_opacity_stops_its_share_of_rays_in_every_backend() {
    let n = 40_000;
    let rays = rays_down(n, 1);
    for a in [0.3f64, 0.75] {
        let scene = load(&quad_at(0.0, &format!("alpha = {a}"))).unwrap();
        let alpha = scene.alpha_test().unwrap();
        let mut answers = Vec::new();
        for (b, acc) in backends(&scene) {
            let found = hits(&scene, acc.as_ref(), &rays);
            let blocked: Vec<bool> = rays.iter().map(|r| acc.occluded_masked(r, alpha)).collect();
            let share = found.iter().filter(|h| h.is_some()).count() as f64 / n as f64;
            assert!(
                (share - a).abs() < band(a, n),
                "{b}: alpha {a} stopped {share} of the rays"
            );
            // a shadow ray sees the same hole its closest-hit twin does
            assert!(
                found.iter().zip(&blocked).all(|(h, &o)| h.is_some() == o),
                "{b}: occlusion and closest hit disagree"
            );
            // without the mask every ray stops
            assert!(rays.iter().all(|r| acc.intersect(r).is_some()), "{b}");
            answers.push((b, found));
        }
        // every backend ignores the same hits: the naive and BVH backends
        // bit for bit; Embree may give a ray on the quad's diagonal to the
        // other triangle (both are right), whose hash differs (one such ray
        // in this set when written)
        let get = |want: Backend| &answers.iter().find(|(b, _)| *b == want).unwrap().1;
        assert_eq!(get(Backend::Naive), get(Backend::Bvh), "alpha {a}");
        for (b, other) in &answers {
            let differ = get(Backend::Bvh)
                .iter()
                .zip(other)
                .filter(|(x, y)| x.map(|h| h.prim) != y.map(|h| h.prim))
                .count();
            assert!(
                differ <= n / 5000,
                "alpha {a}: bvh and {b} differ on {differ} rays"
            );
        }
    }
}

#[test]
fn two_layers_decide_independently() {
    // two quads of opacity 1/2, one above the other: a ray meets the upper
    // with probability 1/2, the lower with 1/4, neither with 1/4 (a test
    // that drew one number per ray would give 1/2, 0, 1/2)
    let scene = load(&format!(
        "{}{}",
        quad_at(1.0, "alpha = 0.5"),
        quad_at(0.0, "alpha = 0.5")
    ))
    .unwrap();
    let n = 40_000;
    let rays = rays_down(n, 2);
    for (b, acc) in backends(&scene) {
        let found = hits(&scene, acc.as_ref(), &rays);
        let upper = found
            .iter()
            .filter(|h| h.is_some_and(|h| h.prim < 2))
            .count() as f64
            / n as f64;
        let lower = found
            .iter()
            .filter(|h| h.is_some_and(|h| h.prim >= 2))
            .count() as f64
            / n as f64;
        let none = found.iter().filter(|h| h.is_none()).count() as f64 / n as f64;
        for (what, got, want) in [
            ("upper", upper, 0.5),
            ("lower", lower, 0.25),
            ("none", none, 0.25),
        ] {
            assert!(
                (got - want).abs() < band(want, n),
                "{b}: {what} {got}, expected {want}"
            );
        }
    }
}

#[test]
fn opacities_zero_and_one_are_exact() {
    let rays = rays_down(2_000, 3);
    let opaque = load(&quad_at(0.0, "")).unwrap();
    assert!(opaque.alpha_test().is_none(), "no mask, no filter");
    let solid = load(&quad_at(0.0, "alpha = 1")).unwrap();
    let clear = load(&quad_at(0.0, "alpha = 0.0")).unwrap();
    for ((b, plain), ((_, one), (_, zero))) in backends(&opaque)
        .into_iter()
        .zip(backends(&solid).into_iter().zip(backends(&clear)))
    {
        let want: Vec<Option<Hit>> = rays.iter().map(|r| plain.intersect(r)).collect();
        assert_eq!(hits(&solid, one.as_ref(), &rays), want, "{b}: alpha 1");
        assert!(
            hits(&clear, zero.as_ref(), &rays)
                .iter()
                .all(Option::is_none),
            "{b}: alpha 0"
        );
    }
}

#[test]
fn a_textured_mask_has_holes_where_the_texture_is_zero() {
    // texels 0..3 are 0 and 4..7 are 1: bilinear lookup is exactly 0 for u
    // in [1/16, 7/16] and exactly 1 for u in [9/16, 15/16]
    let scene = load(&quad_at(0.0, "alpha = \"halves.png\"")).unwrap();
    let rays = rays_down(20_000, 4);
    let (mut holes, mut solid) = (0, 0);
    for (b, acc) in backends(&scene) {
        let found = hits(&scene, acc.as_ref(), &rays);
        for (r, h) in rays.iter().zip(&found) {
            // where the ray meets z = 0, and its u
            let t = -r.o.z / r.d.z;
            let u = (r.o.x + t * r.d.x + 1.0) / 2.0;
            if (0.07..0.43).contains(&u) {
                assert!(h.is_none(), "{b}: hit in a hole at u = {u}");
                holes += 1;
            } else if (0.57..0.93).contains(&u) {
                assert!(h.is_some(), "{b}: missed the solid half at u = {u}");
                solid += 1;
            }
        }
    }
    assert!(holes > 1000 && solid > 1000, "{holes} {solid}");
}

#[test]
fn backends_agree_on_the_bundled_cut_out_scene() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cut-outs.toml");
    let scene = Scene::load(&path).unwrap();
    let alpha = scene.alpha_test().unwrap();
    // rays from points in the box in every direction
    let mut s = Sampler::new(9, 0, 0);
    let rays: Vec<Ray> = (0..20_000)
        .map(|_| {
            let o = Vec3::new(
                1.8 * s.next_1d() - 0.9,
                1.9 * s.next_1d() + 0.05,
                1.8 * s.next_1d() - 0.9,
            );
            let d = embertrace::sampling::square_to_uniform_sphere(s.next_2d());
            Ray::new(o, d)
        })
        .collect();
    let all = backends(&scene);
    let answer = |acc: &dyn Accelerator| -> Vec<(Option<u32>, bool)> {
        rays.iter()
            .map(|r| {
                let shadow = Ray { t_max: 1.0, ..*r };
                (
                    acc.intersect_masked(r, alpha).map(|h| h.prim),
                    acc.occluded_masked(&shadow, alpha),
                )
            })
            .collect()
    };
    let bits = |acc: &dyn Accelerator| -> Vec<Option<Hit>> { hits(&scene, acc, &rays) };
    let naive = all.iter().find(|(b, _)| *b == Backend::Naive).unwrap();
    let bvh = all.iter().find(|(b, _)| *b == Backend::Bvh).unwrap();
    assert_eq!(
        bits(naive.1.as_ref()),
        bits(bvh.1.as_ref()),
        "BVH = naive, bit for bit"
    );
    let reference = answer(bvh.1.as_ref());
    let cut = reference
        .iter()
        .filter(|(p, _)| p.is_some_and(|p| scene.material(p).alpha_mask.is_some()))
        .count();
    assert!(cut > 500, "the rays meet the masked cards ({cut})");
    for (b, acc) in &all {
        let other = answer(acc.as_ref());
        let differ = reference.iter().zip(&other).filter(|(x, y)| x != y).count();
        // Embree's barycentrics differ from the watertight routine's by a
        // few ulps: a hit whose opacity lookup straddles its ray's threshold
        // there may go the other way (none in this set when written)
        assert!(
            differ <= 2,
            "{b}: {differ} of {} answers differ",
            rays.len()
        );
    }
}

fn render_mean(
    scene: &Scene,
    backend: Backend,
    res: u32,
    spp: u32,
    threads: usize,
) -> (Vec<f32>, Vec3) {
    let acc = accel::build(backend, scene.soup(), AccelOptions::default()).unwrap();
    let settings = IntegratorSettings {
        max_depth: 4,
        ..IntegratorSettings::default()
    };
    let tracer = PathTracer::new(scene, acc.as_ref(), settings);
    let rs = RenderSettings {
        total_spp: None,
        resolution: [res, res],
        spp,
        first_sample: 0,
        seed: 5,
        threads,
        tile_size: 8,
        sampler: SamplerKind::Independent,
        clamp: None,
    };
    let out = render(&tracer, &scene.make_camera(res, res), &rs, &|| {}).unwrap();
    let rgb = out.film.to_rgb_f32();
    let mut sum = [0f64; 3];
    for p in rgb.chunks_exact(3) {
        for c in 0..3 {
            sum[c] += p[c] as f64;
        }
    }
    let n = (res * res) as f64;
    (
        rgb,
        Vec3::new(
            (sum[0] / n) as f32,
            (sum[1] / n) as f32,
            (sum[2] / n) as f32,
        ),
    )
}

#[test]
fn a_black_screen_of_opacity_a_lets_one_minus_a_of_a_light_through() {
    // the camera looks at an emitter (radiance 1) filling the view through
    // a black screen of opacity 1/4 (a cut-out emitter would be refused;
    // the screen reflects nothing): each camera sample sees the light with
    // probability 3/4, so the mean is 3/4 with per-sample variance 3/16
    let toml = format!(
        "{}{}",
        quad(
            "material = { emission = 1.0, diffuse = 0.0 }\ntransform = { scale = 20.0, translate = [0.0, 0.0, -1.0] }"
        ),
        quad(
            "alpha = 0.25\nmaterial = { diffuse = 0.0 }\ntransform = { scale = 20.0, translate = [0.0, 0.0, 1.0] }"
        )
    );
    let scene = load(&toml).unwrap();
    let (res, spp) = (32u32, 16u32);
    let n = (res * res * spp) as f64;
    let sd = (3.0f64 / 16.0 / n).sqrt();
    for backend in Backend::available() {
        let (_, mean) = render_mean(&scene, backend, res, spp, 0);
        for c in 0..3 {
            assert!(
                (mean[c] as f64 - 0.75).abs() < 5.0 * sd,
                "{backend}: mean {mean}, expected 0.75 +- {}",
                5.0 * sd
            );
        }
    }
}

#[test]
fn shadow_rays_see_through_the_holes() {
    // a point light above a diffuse floor, a screen of opacity 0.4 between:
    // the floor under it gets 0.6 of the light it gets beside it
    let toml = format!(
        "{}{}[[light]]\ntype = \"point\"\nposition = [0.0, 0.0, 4.0]\nintensity = 10.0\n",
        quad("material = { diffuse = 0.5 }\ntransform = { scale = 10.0 }"),
        quad(
            "alpha = 0.4\nmaterial = { diffuse = 0.0 }\ntransform = { scale = 0.5, translate = [0.0, 0.0, 2.0] }"
        )
    );
    let scene = load(&toml).unwrap();
    let alpha = scene.alpha_test().unwrap();
    let n = 40_000;
    for (b, acc) in backends(&scene) {
        // shadow rays from floor points under the screen's centre to the light
        let mut s = Sampler::new(6, 0, 0);
        let mut lit = 0;
        for _ in 0..n {
            let p = Vec3::new(0.1 * s.next_1d() - 0.05, 0.1 * s.next_1d() - 0.05, 1e-3);
            let to = Vec3::new(0.0, 0.0, 4.0) - p;
            let r = Ray {
                t_max: to.length() * (1.0 - 1e-4),
                ..Ray::new(p, to.normalize())
            };
            if !acc.occluded_masked(&r, alpha) {
                lit += 1;
            }
        }
        let share = lit as f64 / n as f64;
        assert!(
            (share - 0.6).abs() < band(0.6, n),
            "{b}: {share} of the light"
        );
    }
}

#[test]
fn renders_of_masked_scenes_do_not_depend_on_the_thread_count() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cut-outs.toml");
    let scene = Scene::load(&path).unwrap();
    for backend in Backend::available() {
        let (one, _) = render_mean(&scene, backend, 24, 2, 1);
        let (two, _) = render_mean(&scene, backend, 24, 2, 2);
        assert!(
            one.iter()
                .zip(&two)
                .all(|(a, b)| a.to_bits() == b.to_bits()),
            "{backend}: 1 and 2 threads differ"
        );
    }
}

fn error_of(toml: &str) -> String {
    let e = load(toml).unwrap_err();
    assert!(!e.contains('\n'), "one line: {e}");
    e
}

#[test]
fn bad_alpha_is_a_one_line_error_naming_the_line() {
    for (extra, want) in [
        ("alpha = 1.5", "out of range"),
        ("alpha = -0.1", "out of range"),
        ("alpha = [0.1, 0.2, 0.3]", "alpha must be"),
        ("alpha = \"missing.png\"", "missing.png"),
        ("alpha = { texture = \"halves.png\", bogus = 1 }", "bogus"),
        (
            "alpha = 0.5\nmaterial = { emission = 1.0 }",
            "cannot be cut out",
        ),
    ] {
        let e = error_of(&quad_at(0.0, extra));
        assert!(e.contains(want), "{extra}: {e}");
        assert!(
            e.contains("s.toml:4"),
            "{extra}: names the [[mesh]] line: {e}"
        );
    }
}

#[test]
fn an_instance_keeps_its_prototypes_cut_out_under_a_material_override() {
    let scene = load(
        "[[mesh]]\nfile = \"quad.obj\"\nname = \"q\"\ninstance_only = true\nalpha = 0.5\n\
         [[instance]]\nof = \"q\"\nmaterial = { diffuse = 0.2 }\n",
    )
    .unwrap();
    let n = 20_000;
    let rays = rays_down(n, 8);
    for (b, acc) in backends(&scene) {
        let share = hits(&scene, acc.as_ref(), &rays)
            .iter()
            .filter(|h| h.is_some())
            .count() as f64
            / n as f64;
        assert!((share - 0.5).abs() < band(0.5, n), "{b}: {share}");
    }
}
