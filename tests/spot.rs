//! Spot lights (`[[light]] type = "spot"`): the radiance a diffuse floor
//! reflects under one, at points on the axis, inside the beam, in the
//! transition band and outside the cutoff, against the closed form
//! `rho / pi * I f(theta) cos(theta) / r^2` with Mitsuba's falloff `f`
//! (one delta light, direct lighting only: every single sample is exact, so
//! one sample per point is the test); the plan and the kernel it turns on;
//! the chi-square of power selection with a spot light's power; and the
//! one-line errors for bad keys.

mod common;

use embertrace::accel::{self, AccelOptions, Backend};
use embertrace::integrator::{PathTracer, RayCounts};
use embertrace::math::{Ray, Vec3};
use embertrace::plan::Plan;
use embertrace::sampler::Sampler;
use embertrace::scene::Scene;
use embertrace::settings::{DirectStrategy, IntegratorSettings, Roulette};
use std::f64::consts::PI;

const FLOOR: &str = "v -20 0 -20\nv 20 0 -20\nv 20 0 20\nv -20 0 20\nf 1 3 2\nf 1 4 3\n";

/// Load `toml` as `s.toml` beside a 40 x 40 floor at y = 0 (`floor.obj`).
fn load(toml: &str) -> Result<Scene, String> {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("floor.obj"), FLOOR).unwrap();
    let p = dir.path().join("s.toml");
    std::fs::write(&p, toml).unwrap();
    Scene::load(&p).map_err(|e| e.to_string())
}

const CAMERA: &str = "[camera]\norigin = [0.0, 6.0, 6.0]\ntarget = [0.0, 0.0, 0.0]\n";

fn floor_with(light: &str) -> String {
    format!(
        "{CAMERA}[[mesh]]\nfile = \"floor.obj\"\nmaterial = {{ diffuse = 0.5 }}\n[[light]]\ntype = \"spot\"\n{light}"
    )
}

/// Mitsuba's falloff at angle `theta` (radians), in f64.
fn falloff(theta: f64, cutoff_deg: f64, beam_deg: f64) -> f64 {
    let (c, b) = (cutoff_deg.to_radians(), beam_deg.to_radians());
    if theta >= c {
        0.0
    } else if theta <= b {
        1.0
    } else {
        (c - theta) / (c - b)
    }
}

#[test]
fn a_diffuse_floor_reflects_the_closed_form_under_a_spot() {
    // the spot 2 above the origin, pointing straight down; cutoff 30, beam 15
    let h = 2.0f64;
    let intensity = [3.0f64, 2.0, 1.0];
    let scene = load(&floor_with(
        "position = [0.0, 2.0, 0.0]\ntarget = [0.0, 0.0, 0.0]\nintensity = [3.0, 2.0, 1.0]\ncutoff_angle = 30.0\nbeam_width = 15.0\n",
    ))
    .unwrap();
    assert_eq!(scene.spot_lights.len(), 1);
    for backend in Backend::available() {
        let acc = accel::build(backend, scene.soup(), AccelOptions::default()).unwrap();
        for direct in [
            DirectStrategy::Mis,
            DirectStrategy::Light,
            DirectStrategy::Bsdf,
        ] {
            let settings = IntegratorSettings {
                max_depth: 1,
                light_samples: 1,
                direct,
                roulette: Roulette::Fixed(1.0),
                rr_depth: 1,
                ..IntegratorSettings::default()
            };
            let t = PathTracer::new(&scene, acc.as_ref(), settings);
            // angles off the axis: on it, inside the beam, in the band,
            // just inside and outside the cutoff, far outside
            for deg in [0.0f64, 10.0, 14.0, 16.0, 22.5, 28.0, 29.5, 30.5, 45.0] {
                let x = h * deg.to_radians().tan();
                let p = Vec3::new(x as f32, 0.0, 0.0);
                let o = Vec3::new(x as f32 - 1.0, 5.0, 3.0);
                let ray = Ray::new(o, (p - o).normalize());
                // the hit's actual distance from the axis, in f64
                let hit_x = {
                    let d = ray.d.as_dvec3();
                    let s = -(o.y as f64) / d.y;
                    o.x as f64 + s * d.x
                };
                let r2 = h * h + hit_x * hit_x;
                let cos = h / r2.sqrt();
                let f = falloff(cos.acos(), 30.0, 15.0);
                let mut s = Sampler::new(3, 0, 0);
                let l = t.li(&ray, &mut s, &mut RayCounts::default());
                for c in 0..3 {
                    let want = 0.5 / PI * intensity[c] * f * cos / r2;
                    let got = l[c] as f64;
                    assert!(
                        (got - want).abs() <= 2e-4 * want.max(1e-3),
                        "{backend} {direct:?} {deg} degrees, channel {c}: {got} vs {want}"
                    );
                }
            }
        }
    }
}

#[test]
fn direction_and_defaults_follow_mitsuba() {
    // `direction` instead of `target`, defaults cutoff 20 and beam 15
    let scene = load(&floor_with(
        "position = [1.0, 2.0, 0.0]\ndirection = [0.0, -3.0, 0.0]\nintensity = 4\n",
    ))
    .unwrap();
    let s = &scene.spot_lights[0];
    assert_eq!((s.cutoff_angle(), s.beam_width()), (20.0, 15.0));
    assert_eq!(s.axis(), -Vec3::Y);
    assert_eq!(s.intensity, Vec3::splat(4.0));
    // a delta light: the kernel has delta checks, and the plan says why
    let plan = Plan::new(&scene, &IntegratorSettings::default());
    assert!(plan.kernel.delta);
    assert!(plan.on().contains(&"spot_light"), "{:?}", plan.on());
    assert!(!plan.on().contains(&"point_light"));
}

#[test]
fn bad_spot_keys_are_one_line_errors_at_the_light() {
    let cases = [
        ("position = [0.0, 2.0, 0.0]\nintensity = 1\n", "exactly one"),
        (
            "position = [0.0, 2.0, 0.0]\ntarget = [0.0, 0.0, 0.0]\ndirection = [0.0, -1.0, 0.0]\nintensity = 1\n",
            "exactly one",
        ),
        ("target = [0.0, 0.0, 0.0]\nintensity = 1\n", "position"),
        (
            "position = [0.0, 2.0, 0.0]\ntarget = [0.0, 0.0, 0.0]\n",
            "intensity",
        ),
        (
            "position = [0.0, 2.0, 0.0]\ntarget = [0.0, 2.0, 0.0]\nintensity = 1\n",
            "differ",
        ),
        (
            "position = [0.0, 2.0, 0.0]\ndirection = [0.0, 0.0, 0.0]\nintensity = 1\n",
            "non-zero",
        ),
        (
            "position = [0.0, 2.0, 0.0]\ndirection = [0.0, -1.0, 0.0]\nintensity = 1\ncutoff_angle = 0.0\n",
            "cutoff_angle",
        ),
        (
            "position = [0.0, 2.0, 0.0]\ndirection = [0.0, -1.0, 0.0]\nintensity = 1\ncutoff_angle = 95.0\n",
            "(0, 90]",
        ),
        (
            "position = [0.0, 2.0, 0.0]\ndirection = [0.0, -1.0, 0.0]\nintensity = 1\ncutoff_angle = nan\n",
            "cutoff_angle",
        ),
        (
            "position = [0.0, 2.0, 0.0]\ndirection = [0.0, -1.0, 0.0]\nintensity = 1\ncutoff_angle = 20.0\nbeam_width = 25.0\n",
            "beam_width",
        ),
        (
            "position = [0.0, 2.0, 0.0]\ndirection = [0.0, -1.0, 0.0]\nintensity = 1\nbeam_width = -1.0\n",
            "beam_width",
        ),
        (
            "position = [0.0, 2.0, 0.0]\ndirection = [0.0, -1.0, 0.0]\nintensity = -1\n",
            "non-negative",
        ),
        (
            "position = [0.0, 2.0, 0.0]\ndirection = [0.0, -1.0, 0.0]\nintensity = 1\nattenuation = [1.0, 0.0, 0.0]\n",
            "attenuation",
        ),
        (
            "position = [0.0, 2.0, 0.0]\ndirection = [0.0, -1.0, inf]\nintensity = 1\n",
            "finite",
        ),
    ];
    // the [[light]] header is on line 7 of `floor_with`'s text
    for (keys, word) in cases {
        let e = load(&floor_with(keys)).unwrap_err();
        assert!(!e.contains('\n'), "not one line: {e}");
        assert!(
            e.contains("s.toml") && e.contains(":7") && e.contains(word),
            "{keys}: {e}"
        );
    }
    // a spot key on another light
    let e = load(&format!(
        "{CAMERA}[[light]]\ntype = \"point\"\nposition = [0.0, 1.0, 0.0]\nintensity = 1\ncutoff_angle = 10.0\n"
    ))
    .unwrap_err();
    assert!(e.contains("cutoff_angle") && e.contains(":4"), "{e}");
}

#[test]
fn chi2_a_spot_light_is_chosen_by_its_falloffs_power() {
    // power selection: a point light of I = 1 weighs 4 pi, a spot of I = 2
    // with cutoff 30 and beam 10 weighs 2 * 2 pi (1 - (sin c - sin b) / (c - b))
    let scene = load(&format!(
        "{CAMERA}[[light]]\ntype = \"point\"\nposition = [0.0, 3.0, 0.0]\nintensity = 1.0\n\
         [[light]]\ntype = \"spot\"\nposition = [2.0, 3.0, 0.0]\ndirection = [0.0, -1.0, 0.0]\n\
         intensity = 2.0\ncutoff_angle = 30.0\nbeam_width = 10.0\n"
    ))
    .unwrap();
    let lights = embertrace::integrator::Lights::new(&scene);
    let (c, b) = (30f64.to_radians(), 10f64.to_radians());
    let powers = [
        4.0 * PI,
        2.0 * 2.0 * PI * (1.0 - (c.sin() - b.sin()) / (c - b)),
    ];
    let total: f64 = powers.iter().sum();
    let from = embertrace::math::SurfacePoint {
        p: Vec3::ZERO,
        p_err: Vec3::ZERO,
        n: Vec3::Y,
    };
    let n = 200_000;
    let mut obs = [0.0; 2];
    let mut s = Sampler::new(17, 0, 0);
    for _ in 0..n {
        let chosen = lights.choose(&from, s.next_1d()).unwrap();
        obs[chosen.index] += 1.0;
    }
    let exp: Vec<f64> = powers.iter().map(|p| p / total * n as f64).collect();
    common::chi2_test(1, "point and spot by power", &obs, &exp);
}
