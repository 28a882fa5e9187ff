//! CSE 167 / 168 `.test` scenes: what each command becomes (geometry under
//! the transform stack, spheres, lights with the course's brightness,
//! materials, render settings), the errors and warnings bad files get, and
//! the bundled test scene `tests/data/cse/cornell.test`.

use embertrace::accel::{self, AccelOptions, Backend};
use embertrace::bsdf::{Bsdf, Lobe};
use embertrace::integrator::PathTracer;
use embertrace::math::Vec3;
use embertrace::render::{RenderSettings, render};
use embertrace::sampler::SamplerKind;
use embertrace::scene::Scene;
use embertrace::settings::{DirectStrategy, IntegratorSettings, Roulette};
use std::path::Path;

mod common;

fn load(text: &str) -> Result<Scene, String> {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("s.test");
    std::fs::write(&path, text).unwrap();
    Scene::load(&path).map_err(|e| e.to_string())
}

/// The image's pixel values, rendered with the scene's own settings.
fn image(scene: &Scene, res: [u32; 2], spp: u32) -> Vec<Vec3> {
    let acc = accel::build(Backend::Bvh, scene.soup(), AccelOptions::default()).unwrap();
    let r = &scene.render;
    let settings = IntegratorSettings {
        max_depth: r.max_depth,
        light_samples: r.light_samples,
        direct: r.direct,
        roulette: r.roulette,
        rr_depth: r.rr_depth,
        ..IntegratorSettings::default()
    };
    let tracer = PathTracer::new(scene, acc.as_ref(), settings);
    let rs = RenderSettings {
        total_spp: None,
        resolution: res,
        spp,
        first_sample: 0,
        seed: 3,
        threads: 0,
        tile_size: 8,
        sampler: SamplerKind::Independent,
        clamp: None,
    };
    let rgb = render(&tracer, &scene.make_camera(res[0], res[1]), &rs, &|| {})
        .unwrap()
        .film
        .to_rgb_f32();
    rgb.chunks(3).map(|c| Vec3::new(c[0], c[1], c[2])).collect()
}

fn close(a: Vec3, b: Vec3, rel: f32) -> bool {
    (a - b).abs().max_element() <= rel * b.abs().max_element().max(1e-6)
}

const SQUARE: &str = "vertex -1 0 -1\nvertex 1 0 -1\nvertex 1 0 1\nvertex -1 0 1\n";

#[test]
fn the_transform_stack_right_multiplies_and_pops() {
    let s = load(&format!(
        "{SQUARE}pushTransform\ntranslate 10 0 0\nscale 2 2 2\nrotate 0 1 0 90\ntri 0 2 1\npopTransform\ntri 0 2 1\n"
    ))
    .unwrap();
    assert_eq!(s.triangle_count(), 2);
    // rotate acts first, then scale, then translate: (1, 0, -1) -> (-1, 0, -1)
    // -> (-2, 0, -2) -> (8, 0, -2)
    let t = s.triangle(0);
    assert!(close(t[2], Vec3::new(8.0, 0.0, -2.0), 1e-6), "{t:?}");
    // after the pop, identity again
    assert_eq!(s.triangle(1)[2], Vec3::new(1.0, 0.0, -1.0));
    // counter-clockwise seen from +y: the front faces up
    assert!(close(s.normals[1], Vec3::Y, 1e-6));
}

#[test]
fn a_mirroring_scale_keeps_the_front_side() {
    let s = load(&format!("{SQUARE}scale 1 -1 1\ntri 0 2 1\n")).unwrap();
    assert!(close(s.normals[0], -Vec3::Y, 1e-6), "{}", s.normals[0]);
}

#[test]
fn spheres_stay_analytic_under_similarities_and_tessellate_otherwise() {
    let s = load(
        "translate 0 1 0\nrotate 1 1 0 33\nscale 2 2 2\nsphere 1 0 0 0.5\n\
         scale 1 3 1\nsphere 0 0 0 1\n",
    )
    .unwrap();
    assert_eq!(s.spheres.len(), 1);
    assert!((s.spheres[0].radius - 1.0).abs() < 1e-6);
    // the centre is 2 from the translation, along the rotated x axis
    assert!(((s.spheres[0].center - Vec3::Y).length() - 2.0).abs() < 1e-5);
    // the ellipsoid: a mesh with smooth normals, 6 tall along the rotated y
    assert!(s.triangle_count() > 1000);
    assert!(!s.tri_shading_normals.is_empty());
    assert!(
        s.notes
            .iter()
            .any(|n| n.contains("s.test:6") && n.contains("ellipsoid")),
        "{:?}",
        s.notes
    );
    let b = s.bounds();
    assert!((b.max - b.min).max_element() > 5.0);
}

#[test]
fn a_directional_light_gives_a_diffuse_surface_the_course_brightness() {
    // the course's shading of a lit Lambertian is kd L cos(theta), with no
    // 1/pi: the light becomes irradiance pi L, so our kd / pi gives the same
    let s = load(&format!(
        "size 4 4\nintegrator raytracer\nmaxdepth 1\nambient 0 0 0\n\
         camera 0 3 0.001  0 0 0  0 1 0  5\n\
         directional 0 1 1  0.8 0.6 0.4\ndiffuse 0.5 0.5 0.5\n{SQUARE}tri 0 2 1\ntri 0 3 2\n"
    ))
    .unwrap();
    assert_eq!(s.directional_lights.len(), 1);
    let cos = std::f32::consts::FRAC_1_SQRT_2;
    let want = Vec3::new(0.8, 0.6, 0.4) * 0.5 * cos;
    for px in image(&s, [4, 4], 2) {
        assert!(close(px, want, 1e-4), "{px} vs {want}");
    }
}

#[test]
fn a_point_light_honours_the_attenuation_in_force_when_it_is_named() {
    let s = load(&format!(
        "size 2 2\nmaxdepth 1\nambient 0 0 0\ncamera 0 3 0.001  0 0 0  0 1 0  0.01\n\
         attenuation 0 0.5 0\npoint 0 2 0  1 1 1\nattenuation 1 0 0\npoint 0 -5 0  9 9 9\n\
         diffuse 0.5 0.5 0.5\n{SQUARE}tri 0 2 1\ntri 0 3 2\n"
    ))
    .unwrap();
    let pl = &s.point_lights;
    assert_eq!(pl.len(), 2);
    assert_eq!(pl[0].attenuation, [0.0, 0.5, 0.0]);
    assert_eq!(pl[1].attenuation, [1.0, 0.0, 0.0]);
    assert!(close(
        pl[0].intensity,
        Vec3::splat(std::f32::consts::PI),
        1e-6
    ));
    // straight below the first light at distance 2: kd L / (0.5 * 2), with
    // that light alone (one light is sampled per shading point, so the two
    // together would make this a noisy estimate)
    let mut first = s.clone();
    first.point_lights.truncate(1);
    let want = Vec3::splat(0.5 / (0.5 * 2.0));
    for px in image(&first, [2, 2], 1) {
        assert!(close(px, want, 1e-4), "{px} vs {want}");
    }
}

#[test]
fn a_quad_light_faces_ac_cross_ab_with_its_radiance() {
    // seen from below (the front, ac x ab = -y) it shows its radiance; from
    // above, nothing
    let text = |eye: &str| {
        format!(
            "size 2 2\ncamera {eye}  0 2 0  0 0 1  10\nquadLight -1 2 -1  0 0 2  2 0 0  3 2 1\n"
        )
    };
    let below = load(&text("0 0 0")).unwrap();
    assert!(close(below.normals[0], -Vec3::Y, 1e-6));
    for px in image(&below, [2, 2], 1) {
        assert!(close(px, Vec3::new(3.0, 2.0, 1.0), 1e-6), "{px}");
    }
    let above = load(&text("0 4 0")).unwrap();
    for px in image(&above, [2, 2], 1) {
        assert_eq!(px, Vec3::ZERO);
    }
}

/// The radiance of a Lambertian floor straight below a `quadLight` of
/// radiance `L`, with direct light only (`integrator direct`), is
/// `kd L F` for the form factor `F` of Lambert's formula: a check of the
/// light's area, orientation and units through the whole renderer, within
/// 5.3 standard errors (two-sided 1e-6) from 40 independent renders.
#[test]
fn a_quad_light_lights_the_floor_by_its_form_factor() {
    let s = load(
        "size 1 1\nintegrator direct\ncamera 0 0.5 0.001  0 0 0  0 1 0  0.01\n\
         quadLight -0.3 1 -0.6  0 0 1  0.9 0 0  2 2 2\ndiffuse 0.5 0.5 0.5\n\
         vertex -10 0 -10\nvertex 10 0 -10\nvertex 10 0 10\nvertex -10 0 10\ntri 0 2 1\ntri 0 3 2\n",
    )
    .unwrap();
    assert_eq!(s.render.max_depth, 1);
    let corners = [
        Vec3::new(-0.3, 1.0, -0.6),
        Vec3::new(0.6, 1.0, -0.6),
        Vec3::new(0.6, 1.0, 0.4),
        Vec3::new(-0.3, 1.0, 0.4),
    ];
    let want = 0.5 * 2.0 * common::lambert_form_factor(&corners, Vec3::Y);
    let acc = accel::build(Backend::Bvh, s.soup(), AccelOptions::default()).unwrap();
    let settings = IntegratorSettings {
        max_depth: 1,
        direct: s.render.direct,
        ..IntegratorSettings::default()
    };
    let tracer = PathTracer::new(&s, acc.as_ref(), settings);
    let camera = s.make_camera(1, 1);
    let stats = common::batch_means(40, 40, |i| {
        let rs = RenderSettings {
            total_spp: None,
            resolution: [1, 1],
            spp: 256,
            first_sample: 0,
            seed: 100 + i as u64,
            threads: 1,
            tile_size: 8,
            sampler: SamplerKind::Independent,
            clamp: None,
        };
        let out = render(&tracer, &camera, &rs, &|| {}).unwrap();
        out.film.to_rgb_f32()[0] as f64
    });
    let z = common::sidak_z(1e-6, 1);
    println!(
        "floor radiance {:.5} +- {:.5}, form factor gives {want:.5}",
        stats.mean, stats.std_err
    );
    assert!(
        (stats.mean - want).abs() < z * stats.std_err,
        "{} +- {} vs {want}",
        stats.mean,
        stats.std_err
    );
}

#[test]
fn materials_follow_the_course_and_ambient_only_the_raytracer() {
    let body = format!(
        "{SQUARE}ambient 0.1 0.2 0.3\nemission 1 0 0\ndiffuse 0.5 0.5 0.5\ntri 0 1 2\n\
         specular 0.3 0.3 0.3\nshininess 25\ntri 0 2 3\nbrdf ggx\nroughness 0\ntri 1 2 3\n"
    );
    let rt = load(&body).unwrap();
    let m = |s: &Scene, t: u32| s.material(t).clone();
    assert_eq!(
        m(&rt, 0).bsdf,
        Bsdf::Diffuse(embertrace::bsdf::Diffuse {
            albedo: Vec3::splat(0.5)
        })
    );
    assert_eq!(m(&rt, 0).emission, Vec3::new(1.1, 0.2, 0.3));
    assert!(m(&rt, 0).two_sided);
    match m(&rt, 1).bsdf {
        Bsdf::Phong(p) => {
            assert_eq!(p.lobe, Lobe::Phong { shininess: 25.0 });
            assert_eq!(p.specular, Vec3::splat(0.3));
        }
        b => panic!("{b:?}"),
    }
    match m(&rt, 2).bsdf {
        Bsdf::Phong(p) => assert_eq!(p.lobe, Lobe::Ggx { roughness: 1e-3 }),
        b => panic!("{b:?}"),
    }
    assert!(
        rt.notes
            .iter()
            .any(|n| n.contains(":14:") && n.contains("roughness")),
        "{:?}",
        rt.notes
    );
    // the path tracer ignores ambient, and says so once
    let pt = load(&format!("integrator pathtracer\n{body}")).unwrap();
    assert_eq!(m(&pt, 0).emission, Vec3::new(1.0, 0.0, 0.0));
    assert_eq!(
        pt.notes.iter().filter(|n| n.contains("`ambient`")).count(),
        1
    );
}

#[test]
fn integrator_commands_become_render_defaults() {
    let s = load("integrator pathtracer\nspp 7\nlightsamples 3\nmaxdepth -1\nnexteventestimation on\nrussianroulette on\n").unwrap();
    let r = s.render;
    assert_eq!((r.spp, r.light_samples, r.max_depth), (7, 3, 1024));
    assert_eq!(r.direct, DirectStrategy::Light);
    assert_eq!((r.roulette, r.rr_depth), (Roulette::Throughput, 1));
    let s = load("integrator pathtracer\nmaxdepth 4\n").unwrap();
    assert_eq!(
        s.render.direct,
        DirectStrategy::Bsdf,
        "NEE is off by default"
    );
    assert_eq!(s.render.roulette, Roulette::Fixed(1.0));
    assert_eq!(s.render.max_depth, 4);
    let s = load("integrator analyticdirect\nmaxdepth 4\n").unwrap();
    assert_eq!(
        (s.render.max_depth, s.render.direct),
        (1, DirectStrategy::Light)
    );
    let s = load("").unwrap();
    assert_eq!((s.resolution, s.render.max_depth), ([640, 480], 5));
}

#[test]
fn bad_lines_are_one_line_errors_naming_file_and_line() {
    let cases = [
        ("vertex 0 0 0\ntri 0 0 1\n", ":2:", "out of range"),
        ("popTransform\n", ":1:", "pushTransform"),
        ("\n\nsphere 0 0 0\n", ":3:", "4 numbers"),
        ("diffuse 1 nan 1\n", ":1:", "`nan`"),
        ("diffuse 1 -1 1\n", ":1:", "negative"),
        ("size 100 0\n", ":1:", "size"),
        ("camera 0 0 0 0 0 0 0 1 0 45\n", ":1:", "camera"),
        // an up vector parallel to the view once scaled (1e300 once made
        // NaN directions; now only its direction counts)
        ("camera 0 0 4 0 0 0 0 0 1e300 45\n", ":1:", "undefined"),
        // an eye beyond the coordinate range (found by the fuzz run)
        (
            "size 8 8\ncamera 0 2e20 4 0 0 0 0 1 0 45\n",
            ":2:",
            "beyond",
        ),
        (
            "camera 0 0 4 0 -3e18 0 0 1 0 45\n",
            ":1:",
            "point looked at",
        ),
        ("rotate 0 0 0 10\n", ":1:", "axis"),
        ("maxdepth 2.5\n", ":1:", "maxdepth"),
        ("brdf blinn\n", ":1:", "phong, ggx"),
        (
            "diffuse 0.5 0.5 2\nvertex 0 0 0\nvertex 1 0 0\nvertex 0 1 0\ntri 0 1 2\n",
            ":5:",
            "diffuse",
        ),
        ("\u{1}\u{2}tri x\n", ":1:", "unknown"),
    ];
    for (text, line, what) in cases {
        match load(text) {
            Ok(s) => {
                // unknown commands are warnings, not errors
                let w = s.warnings.join("\n");
                assert!(w.contains(line) && w.contains(what), "{text:?}: {w}");
            }
            Err(e) => {
                assert!(!e.contains('\n'), "{e}");
                assert!(
                    e.contains(&format!("s.test{line}")) && e.contains(what),
                    "{text:?}: {e}"
                );
            }
        }
    }
}

#[test]
fn the_bundled_cornell_box_loads_as_written() {
    let s = Scene::load(Path::new("tests/data/cse/cornell.test")).unwrap();
    assert_eq!(s.resolution, [160, 120]);
    assert_eq!(s.triangle_count(), 22);
    assert_eq!(s.spheres.len(), 1);
    assert_eq!(s.render.spp, 16);
    assert_eq!(s.render.direct, DirectStrategy::Mis);
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
    let plan = embertrace::plan::Plan::new(&s, &IntegratorSettings::default());
    for effect in ["diffuse", "phong", "area_light", "sphere", "indirect"] {
        assert!(plan.on().contains(&effect), "{effect}: {:?}", plan.on());
    }
    let px = image(&s, [16, 12], 4);
    assert!(px.iter().all(|p| p.is_finite()));
    assert!(px.iter().map(|p| p.x).sum::<f32>() > 0.0);
}
