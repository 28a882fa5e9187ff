//! The light building blocks on their own: the environment map against
//! Mitsuba 3's values, chi-square fits of the 2D distributions and of the
//! environment's direction sampling (hard case 12), and irradiance furnaces
//! for constant and image environments (hard case 23's estimator without the
//! geometry); and the scene's light set: an emissive sphere sampled in the
//! cone it subtends, from near and far, a quad light sampled by solid angle
//! from near and by area from far, and the power-proportional choice among
//! lights of every kind.

mod common;

use common::{batch_means, chi2_test};
use embertrace::light::EnvironmentMap;
use embertrace::light::envmap::{direction_to_uv, uv_to_direction};
use embertrace::math::{DVec3, Vec2, Vec3};
use embertrace::sampler::Sampler;
use embertrace::sampling::{PeriodicBilinear2D, PiecewiseConstant2D};
use embertrace::texture::ImageTexture;
use std::f64::consts::PI;
use std::path::PathBuf;

/// Chi-square tests in this file, for the Sidak correction.
const CHI2_TESTS: usize = 9;
const N: usize = 1_000_000;

fn data(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data")
        .join(name)
}

fn map(w: u32, h: u32, f: impl Fn(u32, u32) -> Vec3) -> ImageTexture {
    let mut rgb = Vec::new();
    for y in 0..h {
        for x in 0..w {
            rgb.extend(f(x, y).to_array());
        }
    }
    ImageTexture::from_linear_rgb(w, h, rgb).unwrap()
}

/// A map with a bright spot (400x the rest), colour gradients and black
/// bottom rows.
fn lumpy() -> EnvironmentMap {
    let m = map(32, 17, |x, y| {
        if y >= 13 {
            Vec3::ZERO
        } else if (x == 9 || x == 10) && y == 4 {
            Vec3::new(200.0, 150.0, 100.0)
        } else {
            Vec3::new(
                0.2 + 0.03 * x as f32,
                0.5 + 0.2 * ((x as f32) * 0.7).sin(),
                0.1 + 0.05 * y as f32,
            )
        }
    });
    EnvironmentMap::new(m, Vec3::new(1.0, 0.8, 1.5)).unwrap()
}

/// Mitsuba 3.9.1's `envmap` emitter (scalar_rgb) evaluated along 64
/// directions on a 16 x 8 synthetic map; see
/// `scripts/mitsuba_envmap_reference.py`.
#[test]
fn environment_lookup_matches_mitsuba() {
    let text = std::fs::read_to_string(data("mitsuba_envmap.json")).unwrap();
    let doc: serde_json::Value = serde_json::from_str(&text).unwrap();
    let env = EnvironmentMap::load(&data("mitsuba_envmap.exr"), Vec3::ONE).unwrap();
    let (w, h) = (
        doc["width"].as_u64().unwrap(),
        doc["height"].as_u64().unwrap(),
    );
    assert_eq!(
        (env.map().width() as u64, env.map().height() as u64),
        (w, h)
    );
    // the EXR Mitsuba wrote reads back as the pixels it was given, exactly
    let pixels: Vec<f32> = doc["pixels_rgb_top_row_first"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_f64().unwrap() as f32)
        .collect();
    let ours: Vec<f32> = env
        .map()
        .texels()
        .iter()
        .flat_map(|t| t.to_array())
        .collect();
    assert_eq!(ours, pixels);

    let vec3 = |v: &serde_json::Value| {
        let a: Vec<f32> = v
            .as_array()
            .unwrap()
            .iter()
            .map(|x| x.as_f64().unwrap() as f32)
            .collect();
        Vec3::new(a[0], a[1], a[2])
    };
    let samples = doc["samples"].as_array().unwrap();
    assert_eq!(samples.len(), 64);
    let mut worst = 0.0f32;
    for s in samples {
        let d = vec3(&s["d"]);
        let theirs = vec3(&s["radiance"]);
        let ours = env.eval(d);
        let err = ((ours - theirs).abs() / theirs.max(Vec3::ONE)).max_element();
        worst = worst.max(err);
        // Both evaluate atan2 and acos in f32, with different
        // implementations (libm vs Dr.Jit): a few ulps in (u, v) move the
        // bilinear weights by ~1e-6 of texel differences of ~4.
        assert!(err < 2e-5, "d = {d:?}: ours {ours:?}, Mitsuba {theirs:?}");
    }
    eprintln!("largest relative difference from Mitsuba: {worst:e}");
}

/// Counts of `N` points `draw(u)` of uniform `u` (seed `seed`) in a grid of
/// `bx x by` bins over the unit square, row-major.
fn histogram_2d(bx: usize, by: usize, seed: u64, draw: impl Fn(Vec2) -> Vec2) -> Vec<f64> {
    let mut obs = vec![0.0; bx * by];
    let mut s = Sampler::new(seed, 0, 0);
    for _ in 0..N {
        let p = draw(s.next_2d());
        let i = ((p.x as f64 * bx as f64) as usize).min(bx - 1);
        let j = ((p.y as f64 * by as f64) as usize).min(by - 1);
        obs[j * bx + i] += 1.0;
    }
    obs
}

#[test]
fn chi2_piecewise_constant_2d() {
    // 12 x 7 cells: row 2 all zero, some zero cells, values spanning 1e3
    let (nx, ny) = (12usize, 7usize);
    let f: Vec<f32> = (0..nx * ny)
        .map(|k| {
            let (x, y) = (k % nx, k / nx);
            if y == 2 || (x + 2 * y) % 5 == 0 {
                0.0
            } else {
                0.1 * (1 + (x * 7 + y * 3) % 11) as f32 * if x == 4 { 100.0 } else { 1.0 }
            }
        })
        .collect();
    let d = PiecewiseConstant2D::new(&f, nx, ny);
    let total: f64 = f.iter().map(|&v| v as f64).sum();
    // each cell split 3 x 3, so uniformity inside a cell is tested too
    let (bx, by) = (3 * nx, 3 * ny);
    let obs = histogram_2d(bx, by, 41, |u| d.sample(u).p);
    let exp: Vec<f64> = (0..bx * by)
        .map(|k| {
            let (i, j) = (k % bx, k / bx);
            f[(j / 3) * nx + i / 3] as f64 / total / 9.0 * N as f64
        })
        .collect();
    chi2_test(CHI2_TESTS, "piecewise-constant 2D", &obs, &exp);
}

#[test]
fn chi2_periodic_bilinear_2d() {
    // 10 x 6 vertices: a zero vertex row, zero vertices, a bright vertex on
    // the last column (its patches wrap to column 0), values spanning 1e3
    let (nx, rows) = (10usize, 6usize);
    let f: Vec<f32> = (0..nx * rows)
        .map(|k| {
            let (x, y) = (k % nx, k / nx);
            if y == 4 || (x + 3 * y) % 7 == 0 {
                0.0
            } else {
                0.1 * (1 + (x * 5 + y * 2) % 9) as f32 * if x == 9 { 100.0 } else { 1.0 }
            }
        })
        .collect();
    let d = PeriodicBilinear2D::new(&f, nx, rows);
    let ny = rows - 1;
    // each patch split 3 x 3; a bilinear density's mass over a rectangle
    // inside one patch is its area times the density at its centre
    let (bx, by) = (3 * nx, 3 * ny);
    let obs = histogram_2d(bx, by, 43, |u| d.sample(u).p);
    let exp: Vec<f64> = (0..bx * by)
        .map(|k| {
            let (i, j) = (k % bx, k / bx);
            let centre = Vec2::new(
                ((i as f64 + 0.5) / bx as f64) as f32,
                ((j as f64 + 0.5) / by as f64) as f32,
            );
            d.pdf(centre) as f64 / (bx * by) as f64 * N as f64
        })
        .collect();
    let sum: f64 = exp.iter().sum();
    assert!(
        (sum / N as f64 - 1.0).abs() < 1e-5,
        "expected counts sum to {sum}"
    );
    chi2_test(CHI2_TESTS, "periodic bilinear 2D", &obs, &exp);
}

/// Directions binned over (cos theta, phi), 100 x 200 cells, phi measured
/// from the map's seam shifted by half a texel (so the bins in u start where
/// the sampling patches do). Each bin's expected count is the exact integral
/// of `pdf_uv` over it, piecewise bilinear or constant (in both cases a
/// patch's mass over a rectangle inside it is the area times the value at
/// the rectangle's centre): a bin in (cos theta, phi) is a rectangle in
/// (u, v).
#[test]
fn chi2_environment_directions() {
    // the bright spot makes the constant density per patch far from the
    // bilinear one, so this map samples the bilinear density; a smooth
    // map of many texels keeps the constant one
    let env = lumpy();
    assert!(env.samples_bilinear_density());
    chi2_environment(&env, 42, "environment map directions (bilinear)");
    let smooth = EnvironmentMap::new(
        map(96, 49, |x, y| {
            Vec3::new(
                1.0 + 0.2 * y as f32 / 48.0,
                0.8,
                0.6 + 0.01 * (x % 7) as f32,
            )
        }),
        Vec3::ONE,
    )
    .unwrap();
    assert!(!smooth.samples_bilinear_density());
    chi2_environment(&smooth, 44, "environment map directions (constant)");
}

/// The chi-square test of `env`'s directions, binned as described above.
fn chi2_environment(env: &EnvironmentMap, seed: u64, name: &str) {
    let (w, h) = (env.map().width() as usize, env.map().height() as usize);
    let (nc, np) = (100usize, 200usize);
    let shift = 0.5 / w as f64;
    let mut obs = vec![0.0; nc * np];
    let mut s = Sampler::new(seed, 0, 0);
    for _ in 0..N {
        let Some(x) = env.sample(s.next_2d()) else {
            continue;
        };
        let uv = direction_to_uv(x.wi);
        let sx = (uv.x as f64 - shift).rem_euclid(1.0);
        let c = (x.wi.y as f64 + 1.0) / 2.0;
        let i = ((c * nc as f64) as usize).min(nc - 1);
        let j = ((sx * np as f64) as usize).min(np - 1);
        obs[i * np + j] += 1.0;
    }
    // pdf_uv at (s, v) in patch space, read through the public pdf
    let (px, py) = (w, h - 1);
    let pdf_uv = |sx: f64, v: f64| {
        let u = (sx + shift).rem_euclid(1.0);
        let d = uv_to_direction(Vec2::new(u as f32, v as f32));
        let sin_t = ((d.x * d.x + d.z * d.z) as f64).sqrt();
        env.pdf(d) as f64 * 2.0 * PI * PI * sin_t
    };
    let overlap = |a0: f64, a1: f64, b0: f64, b1: f64| (a1.min(b1) - a0.max(b0)).max(0.0);
    let mut exp = vec![0.0; nc * np];
    for i in 0..nc {
        // cos theta in [c0, c1] is v in [acos(c1) / pi, acos(c0) / pi]
        let c0 = 2.0 * i as f64 / nc as f64 - 1.0;
        let c1 = 2.0 * (i + 1) as f64 / nc as f64 - 1.0;
        let (v0, v1) = (c1.acos() / PI, c0.acos() / PI);
        for j in 0..np {
            let (s0, s1) = (j as f64 / np as f64, (j + 1) as f64 / np as f64);
            let mut mass = 0.0;
            // the bin's part in each patch is a rectangle in (s, v), and
            // the bilinear pdf_uv's mass over it is its area times the
            // value at its centre
            for r in 0..py {
                let (b0, b1) = (r as f64 / py as f64, (r + 1) as f64 / py as f64);
                let ov = overlap(v0, v1, b0, b1);
                if ov == 0.0 {
                    continue;
                }
                let vc = 0.5 * (v0.max(b0) + v1.min(b1));
                for k in 0..px {
                    let (a0, a1) = (k as f64 / px as f64, (k + 1) as f64 / px as f64);
                    let os = overlap(s0, s1, a0, a1);
                    if os == 0.0 {
                        continue;
                    }
                    mass += pdf_uv(0.5 * (s0.max(a0) + s1.min(a1)), vc) * ov * os;
                }
            }
            exp[i * np + j] = mass * N as f64;
        }
    }
    // the expected counts sum to N: the pdf is normalised (f32 pdfs: 1e-5)
    let sum: f64 = exp.iter().sum();
    assert!(
        (sum / N as f64 - 1.0).abs() < 1e-5,
        "expected counts sum to {sum}"
    );
    chi2_test(CHI2_TESTS, name, &obs, &exp);
}

/// Irradiance at an upward normal (+y) by sampling the environment:
/// `E = mean(L(wi) max(0, wi.y) / pdf(wi))`, per channel, with batch means.
fn irradiance_estimate(env: &EnvironmentMap, seed: u64) -> [common::BatchStats; 3] {
    let mut samples = Vec::with_capacity(N);
    let mut s = Sampler::new(seed, 0, 0);
    for _ in 0..N {
        let v = match env.sample(s.next_2d()) {
            Some(x) => x.li * x.wi.y.max(0.0) / x.pdf,
            None => Vec3::ZERO,
        };
        samples.push(v.as_dvec3());
    }
    [0, 1, 2].map(|c| batch_means(N, 100, |i| samples[i][c]))
}

#[test]
fn furnace_constant_environment_gives_pi_radiance() {
    let l = Vec3::new(0.5, 1.0, 2.0);
    let env = EnvironmentMap::new(map(8, 5, |_, _| Vec3::ONE), l).unwrap();
    let stats = irradiance_estimate(&env, 43);
    for (c, st) in stats.iter().enumerate() {
        let want = PI * l[c] as f64;
        // 5 sigma from 100 batch means (f64)
        assert!(
            (st.mean - want).abs() < 5.0 * st.std_err,
            "channel {c}: {} +- {} vs {want}",
            st.mean,
            st.std_err
        );
        assert!(st.std_err < 0.01 * want, "channel {c}: too noisy to test");
    }
}

#[test]
fn furnace_image_environment_matches_quadrature() {
    let env = lumpy();
    // midpoint rule over the upper hemisphere on a grid ~60x finer than the
    // map: the radiance is continuous and piecewise bilinear, so the error
    // (~1e-5 relative) is far inside the Monte Carlo band
    let (nt, np) = (1024usize, 2048usize);
    let mut quad = [0.0f64; 3];
    for i in 0..nt {
        let theta = (i as f64 + 0.5) / nt as f64 * PI / 2.0;
        let weight = theta.cos() * theta.sin() * (PI / 2.0 / nt as f64) * (2.0 * PI / np as f64);
        for j in 0..np {
            let u = (j as f64 + 0.5) / np as f64;
            let d = uv_to_direction(Vec2::new(u as f32, (theta / PI) as f32));
            let l = env.eval(d).as_dvec3();
            for c in 0..3 {
                quad[c] += l[c] * weight;
            }
        }
    }
    let stats = irradiance_estimate(&env, 44);
    for (c, st) in stats.iter().enumerate() {
        // 5 sigma from 100 batch means (f64)
        assert!(
            (st.mean - quad[c]).abs() < 5.0 * st.std_err,
            "channel {c}: {} +- {} vs quadrature {}",
            st.mean,
            st.std_err,
            quad[c]
        );
        assert!(
            st.std_err < 0.01 * quad[c],
            "channel {c}: too noisy to test"
        );
    }
}

/// The lights of a scene given as TOML text.
fn scene_lights(toml: &str) -> (embertrace::scene::Scene, embertrace::integrator::Lights) {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("s.toml");
    std::fs::write(&path, toml).unwrap();
    let scene = embertrace::scene::Scene::load(&path).unwrap();
    let lights = embertrace::integrator::Lights::new(&scene);
    (scene, lights)
}

fn point_at(p: Vec3) -> embertrace::math::SurfacePoint {
    embertrace::math::SurfacePoint {
        p,
        p_err: Vec3::ZERO,
        n: Vec3::Y,
    }
}

#[test]
fn chi2_emissive_sphere_cone() {
    // pbrt-v4's cone sampling of a sphere: directions uniform over the cone
    // of half-angle theta_max (cos theta uniform, phi uniform), every point
    // on the visible cap, density 1 / (2 pi (1 - cos theta_max)) that
    // `pdf_area` reproduces. From far away the Taylor branch is taken.
    let (scene, lights) = scene_lights(
        "[[sphere]]\ncenter = [0.0, 0.0, 0.0]\nradius = 0.5\nmaterial = { emission = 2.0 }\n",
    );
    for (k, dist) in [1.3f32, 200.0].into_iter().enumerate() {
        let from = point_at(Vec3::new(0.0, 0.0, dist));
        let sin2 = (0.5 / dist as f64).powi(2);
        let cos_max = (1.0 - sin2).sqrt();
        let one_minus = if sin2 < 0.000_685_23 {
            0.5 * sin2
        } else {
            1.0 - cos_max
        };
        let (nu, nphi) = (10, 12);
        let mut obs = vec![0.0; nu * nphi];
        let mut s = Sampler::new(11 + k as u64, 0, 0);
        for _ in 0..N / 4 {
            let ls = lights
                .sample(&scene, &from, s.next_1d(), s.next_2d())
                .expect("a sample");
            // on the sphere, facing the point
            let to = from.p + ls.wi * ls.shadow.t_max;
            assert!(ls.wi.dot(-Vec3::Z) > 0.0 && !ls.unreachable);
            // 1 - cos from the transverse components: exact for narrow cones
            let w = ls.wi.as_dvec3();
            let one_minus_cos = (w.x * w.x + w.y * w.y) / (1.0 - w.z);
            let pdf = 1.0 / (2.0 * PI * one_minus);
            assert!(
                (ls.pdf as f64 / pdf - 1.0).abs() < 1e-3,
                "{} vs {pdf}",
                ls.pdf
            );
            let q = embertrace::math::SurfacePoint::on_sphere(Vec3::ZERO, 0.5, to);
            let back = lights.pdf_area(&from, 0, &q) as f64;
            assert!((back / pdf - 1.0).abs() < 1e-3, "{back} vs {pdf}");
            let t = (one_minus_cos / one_minus).clamp(0.0, 0.999_999);
            let phi = (ls.wi.y as f64).atan2(ls.wi.x as f64) + PI;
            let j = ((phi / (2.0 * PI)) * nphi as f64).min(nphi as f64 - 1.0) as usize;
            obs[(t * nu as f64) as usize * nphi + j] += 1.0;
        }
        let exp = vec![(N / 4) as f64 / (nu * nphi) as f64; nu * nphi];
        chi2_test(CHI2_TESTS, &format!("sphere cone at {dist}"), &obs, &exp);
    }
}

#[test]
fn chi2_light_choice_follows_power() {
    // one light of each kind, each chosen in proportion to its power:
    // area lights L A pi, points 4 pi I, directional E pi r^2, environment
    // pi^2 r^2 L, with r the scene's bounding radius (here sqrt(3))
    let (scene, lights) = scene_lights(
        r#"
[[sphere]]
center = [0.0, 0.0, 0.0]
radius = 1.0
material = { emission = 0.5 }
[[light]]
type = "point"
position = [0.0, 3.0, 0.0]
intensity = 2.0
[[light]]
type = "directional"
direction = [0.0, -1.0, 0.0]
irradiance = 0.4
[[light]]
type = "environment"
radiance = 0.05
"#,
    );
    // the bounds are the unit sphere's box: squared half diagonal 3
    let r2 = 3.0f64;
    let powers = [
        0.5 * 4.0 * PI * PI,
        4.0 * PI * 2.0,
        0.4 * PI * r2,
        0.05 * PI * PI * r2,
    ];
    let total: f64 = powers.iter().sum();
    let from = point_at(Vec3::new(0.0, -3.0, 0.0));
    let mut obs = [0.0; 4];
    let mut s = Sampler::new(5, 0, 0);
    let n = N / 4;
    for _ in 0..n {
        let Some(ls) = lights.sample(&scene, &from, s.next_1d(), s.next_2d()) else {
            continue;
        };
        let kind = if ls.unreachable {
            if ls.shadow.t_max.is_finite() && ls.wi.y > 0.99 && ls.shadow.t_max < 7.0 {
                1
            } else {
                2
            }
        } else if ls.shadow.t_max.is_finite() && ls.shadow.t_max < 10.0 {
            0
        } else {
            3
        };
        obs[kind] += 1.0;
    }
    let exp: Vec<f64> = powers.iter().map(|p| p / total * n as f64).collect();
    chi2_test(CHI2_TESTS, "light choice", &obs, &exp);
}

#[test]
fn chi2_quad_light_by_solid_angle_near_and_by_area_far() {
    // a 2 x 1 rectangle of two triangles (one light), facing -y, seen from
    // near (where it subtends about 1.7 sr: sampled uniformly in solid
    // angle, Urena et al.) and from far (by area). The sampled point's
    // position on the rectangle must follow the density each promises:
    // cos / d^2 per unit area over the solid angle, or 1 / area.
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("quad.obj"),
        "v -1 1 -0.5\nv 1 1 -0.5\nv 1 1 0.5\nv -1 1 0.5\nf 1 2 3\nf 1 3 4\n",
    )
    .unwrap();
    let path = dir.path().join("s.toml");
    std::fs::write(
        &path,
        "[[mesh]]\nfile = \"quad.obj\"\nmaterial = { diffuse = 0.0, emission = 1.0 }\n",
    )
    .unwrap();
    let scene = embertrace::scene::Scene::load(&path).unwrap();
    let lights = embertrace::integrator::Lights::new(&scene);
    assert_eq!(lights.area_lights().len(), 1, "the quad is one light");
    for (k, from) in [Vec3::new(0.3, 0.4, 0.1), Vec3::new(0.5, -30.0, 0.2)]
        .into_iter()
        .enumerate()
    {
        let sp = point_at(from);
        let (nx, nz) = (16, 8);
        // expected density of the point over the rectangle, per cell
        let density = |x: f64, z: f64| {
            let v = DVec3::new(x, 1.0, z) - from.as_dvec3();
            let d2 = v.length_squared();
            v.y.abs() / (d2 * d2.sqrt())
        };
        let m = 8;
        let mut exp = vec![0.0; nx * nz];
        for (c, e) in exp.iter_mut().enumerate() {
            let (i, j) = (c % nx, c / nx);
            for a in 0..m {
                for b in 0..m {
                    let x = -1.0 + 2.0 * (i as f64 + (a as f64 + 0.5) / m as f64) / nx as f64;
                    let z = -0.5 + (j as f64 + (b as f64 + 0.5) / m as f64) / nz as f64;
                    *e += if k == 0 { density(x, z) } else { 1.0 };
                }
            }
        }
        let total: f64 = exp.iter().sum();
        let n = N / 4;
        for e in exp.iter_mut() {
            *e *= n as f64 / total;
        }
        let mut obs = vec![0.0; nx * nz];
        let solid_angle = lights_solid_angle(from);
        let mut s = Sampler::new(31 + k as u64, 0, 0);
        for _ in 0..n {
            let ls = lights
                .sample(&scene, &sp, s.next_1d(), s.next_2d())
                .expect("the light faces the point");
            let to = from + ls.wi * ls.shadow.t_max;
            let cell_x = (((to.x + 1.0) / 2.0 * nx as f32) as usize).min(nx - 1);
            let cell_z = (((to.z + 0.5) * nz as f32) as usize).min(nz - 1);
            obs[cell_z * nx + cell_x] += 1.0;
            // the density reported, and the one pdf_area gives back
            let v = (to - from).as_dvec3();
            let d2 = v.length_squared();
            let cos = v.y.abs() / d2.sqrt();
            let want = if k == 0 {
                1.0 / solid_angle
            } else {
                d2 / (cos * 2.0)
            };
            assert!(
                (ls.pdf as f64 / want - 1.0).abs() < 2e-3,
                "{} vs {want}",
                ls.pdf
            );
            let q = embertrace::math::SurfacePoint {
                p: to,
                p_err: Vec3::ZERO,
                n: -Vec3::Y,
            };
            let tri = if (to.x + 1.0) / 2.0 >= to.z + 0.5 {
                0
            } else {
                1
            };
            let back = lights.pdf_area(&sp, tri, &q) as f64;
            assert!((back / want - 1.0).abs() < 2e-3, "{back} vs {want}");
        }
        chi2_test(CHI2_TESTS, &format!("quad light from {from}"), &obs, &exp);
    }
}

/// The solid angle of the test quad (`[-1, 1] x [-0.5, 0.5]` at `y = 1`)
/// from `p`, by fine quadrature.
fn lights_solid_angle(p: Vec3) -> f64 {
    let n = 400;
    let mut s = 0.0;
    for i in 0..n {
        for j in 0..n {
            let x = -1.0 + 2.0 * (i as f64 + 0.5) / n as f64;
            let z = -0.5 + (j as f64 + 0.5) / n as f64;
            let v = DVec3::new(x, 1.0, z) - p.as_dvec3();
            let d2 = v.length_squared();
            s += v.y.abs() / (d2 * d2.sqrt()) * (2.0 / (n * n) as f64);
        }
    }
    s
}
