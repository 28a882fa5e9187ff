//! The light BVH (`--light-sampler bvh`) as every sampler is tested: its
//! pmf over all lights sums to 1 from several points; lights are chosen
//! with the frequencies that pmf gives (chi-square); the pmf a sample
//! carries is the one MIS asks for afterwards; the image mean equals power
//! selection's within a band derived from the measured variance; the same
//! seed gives the same bits whatever the thread count; and `auto` keeps
//! power selection, bit for bit, below the threshold.

mod common;

use common::{MeanTest, PixelStats, chi2_test, sidak_z};
use embertrace::accel::{self, AccelOptions, Backend};
use embertrace::integrator::{Lights, PathTracer};
use embertrace::math::{SurfacePoint, Vec3};
use embertrace::plan::Plan;
use embertrace::render::{RenderSettings, render};
use embertrace::sampler::{Sampler, SamplerKind};
use embertrace::scene::Scene;
use embertrace::settings::{IntegratorSettings, LIGHT_BVH_FROM, LightSampler};

/// Chi-square tests in this file, for the Sidak correction.
const CHI2_TESTS: usize = 3;

/// A small many-light scene: a floor, 24 emissive triangles (one-sided,
/// facing down, and two-sided) of different radiance, two emissive
/// spheres, a point and a spot light, a directional light and a uniform
/// environment; written to a temporary folder.
fn many_light_scene() -> Scene {
    light_scene(24)
}

/// [`many_light_scene`] with `triangles` emissive triangles (at most 24).
fn light_scene(triangles: usize) -> Scene {
    let dir = tempfile::tempdir().unwrap();
    let mut obj = String::from("v -6 0 -6\nv 6 0 -6\nv 6 0 6\nv -6 0 6\nf 1 3 2\nf 1 4 3\n");
    let mut toml = String::from(
        "[camera]\norigin = [0.0, 4.0, 7.0]\ntarget = [0.0, 0.0, 0.0]\nfov_y = 50.0\n\
         [[mesh]]\nfile = \"floor.obj\"\nmaterial = { diffuse = 0.5 }\n",
    );
    for k in 0..triangles {
        let (x, z) = ((k % 6) as f32 * 1.8 - 4.5, (k / 6) as f32 * 2.2 - 3.3);
        let y = 0.6 + 0.1 * (k % 5) as f32;
        let s = 0.15 + 0.02 * (k % 3) as f32;
        let o = format!(
            "v {} {y} {}\nv {} {y} {}\nv {} {y} {}\nf 1 2 3\n",
            x,
            z,
            x + s,
            z + 0.3 * s,
            x + 0.2 * s,
            z + s
        );
        std::fs::write(dir.path().join(format!("l{k}.obj")), o).unwrap();
        toml += &format!(
            "[[mesh]]\nfile = \"l{k}.obj\"\nmaterial = {{ emission = [{}, {}, {}], two_sided = {} }}\n",
            1.0 + (k % 4) as f32 * 3.0,
            2.0 + (k % 3) as f32,
            0.5 + (k % 7) as f32,
            k % 5 == 0
        );
    }
    obj.push('\n');
    std::fs::write(dir.path().join("floor.obj"), obj).unwrap();
    toml += "[[sphere]]\ncenter = [1.0, 0.4, 1.0]\nradius = 0.2\nmaterial = { emission = 3.0 }\n\
             [[sphere]]\ncenter = [-2.0, 0.3, -1.0]\nradius = 0.3\nmaterial = { emission = [1.0, 2.0, 4.0] }\n\
             [[light]]\ntype = \"point\"\nposition = [0.5, 1.5, -2.0]\nintensity = 2.0\n\
             [[light]]\ntype = \"spot\"\nposition = [-1.0, 2.0, 2.0]\ntarget = [-1.0, 0.0, 1.5]\nintensity = [6.0, 5.0, 4.0]\ncutoff_angle = 40.0\n\
             [[light]]\ntype = \"directional\"\ndirection = [0.2, -1.0, 0.1]\nirradiance = 0.3\n\
             [[light]]\ntype = \"environment\"\nradiance = 0.05\n";
    let path = dir.path().join("s.toml");
    std::fs::write(&path, toml).unwrap();
    Scene::load(&path).unwrap()
}

fn at(p: Vec3, n: Vec3) -> SurfacePoint {
    SurfacePoint {
        p,
        p_err: Vec3::ZERO,
        n,
    }
}

/// Shading points on the floor, above it among the lights, and far away.
fn points() -> [SurfacePoint; 4] {
    [
        at(Vec3::new(0.0, 0.0, 0.0), Vec3::Y),
        at(Vec3::new(-3.0, 0.0, 2.5), Vec3::Y),
        at(Vec3::new(2.0, 0.7, -1.0), Vec3::new(0.6, 0.8, 0.0)),
        at(Vec3::new(30.0, 10.0, -40.0), Vec3::Y),
    ]
}

#[test]
fn the_pmf_over_all_lights_sums_to_one() {
    let scene = many_light_scene();
    let lights = Lights::with_sampler(&scene, LightSampler::Bvh);
    assert!(lights.uses_bvh());
    // 24 triangles, 2 spheres, a point, a spot, a directional light and
    // the environment
    for from in points() {
        let pmf = lights.selection_pmfs(&from);
        assert_eq!(pmf.len(), 30);
        let sum: f64 = pmf.iter().map(|&p| p as f64).sum();
        assert!((sum - 1.0).abs() < 1e-5, "at {}: {sum}", from.p);
        assert!(pmf.iter().all(|p| p.is_finite() && *p >= 0.0));
        // the two lights at infinity and the tree, chosen uniformly
        assert_eq!(pmf[28], 1.0 / 3.0);
        assert_eq!(pmf[29], 1.0 / 3.0);
    }
}

#[test]
fn chi2_chosen_lights_follow_the_pmf_and_mis_sees_the_same_pmf() {
    let scene = many_light_scene();
    let lights = Lights::with_sampler(&scene, LightSampler::Bvh);
    let acc = accel::build(Backend::Bvh, scene.soup(), AccelOptions::default()).unwrap();
    let n = 300_000;
    for (k, from) in points().into_iter().take(CHI2_TESTS).enumerate() {
        let pmf = lights.selection_pmfs(&from);
        let mut obs = vec![0.0; pmf.len()];
        let mut checked = 0;
        let mut s = Sampler::new(41 + k as u64, 0, 0);
        for i in 0..n {
            let u = s.next_1d();
            let c = lights.choose(&from, u).expect("a light");
            // the pmf the sample carries is the one asked for by index
            assert_eq!(c.pmf, pmf[c.index], "at {}", from.p);
            obs[c.index] += 1.0;
            // and, for an area light, the density of the whole sample is
            // what MIS computes from the point it found
            if i % 50 != 0 {
                continue;
            }
            if let Some(ls) = lights.sample(&scene, &from, u, s.next_2d()) {
                if !ls.unreachable && ls.shadow.t_max.is_finite() {
                    // the point sampled, unless another emitter hides it
                    let end = ls.shadow.o + ls.shadow.t_max * ls.shadow.d;
                    let found = hit_emitter(&scene, acc.as_ref(), &from, ls.wi)
                        .filter(|(_, to)| (to.p - end).length() < 1e-3 * (end - from.p).length());
                    if let Some((prim, to)) = found {
                        // at the sampled point itself: the hit, found from
                        // another origin, moves it where the light is grazed
                        let to = SurfacePoint { p: end, ..to };
                        let back = lights.pdf_area(&from, prim, &to);
                        checked += 1;
                        assert!(
                            (back / ls.pdf - 1.0).abs() < 2e-3,
                            "at {}: sampled {} vs MIS {back}",
                            from.p,
                            ls.pdf
                        );
                    }
                }
            }
        }
        assert!(checked > 200, "only {checked} area-light samples checked");
        let exp: Vec<f64> = pmf.iter().map(|&p| p as f64 * n as f64).collect();
        chi2_test(CHI2_TESTS, &format!("light BVH at {}", from.p), &obs, &exp);
    }
}

/// The emissive primitive a ray from `from` along `wi` hits first, and
/// the point it hits.
fn hit_emitter(
    scene: &Scene,
    acc: &dyn embertrace::accel::Accelerator,
    from: &SurfacePoint,
    wi: Vec3,
) -> Option<(u32, SurfacePoint)> {
    let ray = embertrace::math::Ray::new(from.p + 1e-4 * from.n, wi);
    let hit = acc.intersect(&ray)?;
    (scene.material(hit.prim).emission.max_element() > 0.0)
        .then(|| (hit.prim, scene.hit_point(&ray, &hit)))
}

fn image(scene: &Scene, sampler: LightSampler, seed: u64, threads: usize) -> Vec<f32> {
    let acc = accel::build(Backend::Bvh, scene.soup(), AccelOptions::default()).unwrap();
    let settings = IntegratorSettings {
        max_depth: 4,
        light_sampler: sampler,
        ..IntegratorSettings::default()
    };
    let tracer = PathTracer::new(scene, acc.as_ref(), settings);
    let rs = RenderSettings {
        total_spp: None,
        resolution: [48, 32],
        spp: 16,
        first_sample: 0,
        seed,
        threads,
        tile_size: 8,
        sampler: SamplerKind::Sobol,
        clamp: None,
    };
    render(&tracer, &scene.make_camera(48, 32), &rs, &|| {})
        .unwrap()
        .film
        .to_rgb_f32()
}

#[test]
fn bvh_selection_is_unbiased_against_power_selection() {
    // each side a mean of independent Owen-scrambled passes (different
    // seeds); the whole image's mean per channel, with its variance from
    // the passes' spread, must agree within z sigma, z the two-sided 1e-4
    // quantile Sidak-corrected over the three channels
    let scene = many_light_scene();
    let passes = 16;
    let stats = |s: LightSampler, base: u64| {
        let imgs: Vec<Vec<f32>> = (0..passes).map(|k| image(&scene, s, base + k, 0)).collect();
        PixelStats::from_passes(&imgs)
    };
    let bvh = stats(LightSampler::Bvh, 100);
    let power = stats(LightSampler::Power, 200);
    let t = MeanTest::new(&bvh, &power, sidak_z(1e-4, 3), 0.0);
    println!("{}", t.report("bvh vs power"));
    assert!(
        t.failing_channels(1.0).is_empty(),
        "{}",
        t.report("bvh vs power")
    );
    // and the band is narrow enough to mean something
    for c in 0..3 {
        assert!(t.relative_band(c) < 0.02, "{}", t.report("bvh vs power"));
    }
}

#[test]
fn the_same_seed_gives_the_same_bits_for_any_thread_count() {
    let scene = many_light_scene();
    let one = image(&scene, LightSampler::Bvh, 5, 1);
    for threads in [2, 3, 0] {
        assert!(
            image(&scene, LightSampler::Bvh, 5, threads) == one,
            "{threads} threads"
        );
    }
    assert!(one.iter().any(|&v| v > 0.0));
}

#[test]
fn auto_picks_the_bvh_from_the_threshold_and_power_below_it() {
    // 3 triangles, 2 spheres, a point and a spot: under the threshold
    let scene = light_scene(3);
    const { assert!(7 < LIGHT_BVH_FROM) };
    let plan = Plan::new(&scene, &IntegratorSettings::default());
    assert!(!plan.on().contains(&"many_lights"));
    assert!(!Lights::with_sampler(&scene, LightSampler::Auto).uses_bvh());
    assert_eq!(
        image(&scene, LightSampler::Auto, 9, 0),
        image(&scene, LightSampler::Power, 9, 0),
        "auto below the threshold is power selection, bit for bit"
    );
    let forced = IntegratorSettings {
        light_sampler: LightSampler::Bvh,
        ..IntegratorSettings::default()
    };
    let plan = Plan::new(&scene, &forced);
    let e = plan
        .effects
        .iter()
        .find(|e| e.name == "many_lights")
        .unwrap();
    assert!(e.on && e.because.contains("--light-sampler bvh"), "{e:?}");
    let bundled = Scene::load(
        &std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/many-lights.toml"),
    )
    .unwrap();
    let plan = Plan::new(&bundled, &IntegratorSettings::default());
    assert!(plan.on().contains(&"many_lights"), "{:?}", plan.on());
}

#[test]
fn the_bvh_gives_every_light_that_can_contribute_a_positive_probability() {
    // brute force: from 3000 random shading points (in and around the
    // lights, random normals), every light that reaches the point's upper
    // hemisphere with its front side must be chosen with probability > 0.
    // A triangle reaches it where one of its corners is above the shading
    // plane and the point is on its emitting side; a sphere where its
    // nearest point to the plane's upper side is above it; a point or spot
    // light where it lies above the plane and (a spot) the point is inside
    // its cutoff cone, as its own `sample_li` says. A third of the points
    // lie in a 45-degree cone around the spot's axis (its cutoff is 40), so
    // points inside and just outside its cone are both drawn.
    let scene = many_light_scene();
    let lights = Lights::with_sampler(&scene, LightSampler::Bvh);
    let area = lights.area_lights();
    let n_area = area.len();
    let mut s = Sampler::new(8, 0, 0);
    let mut checked = [0usize; 3];
    let spot = &scene.spot_lights[0];
    let (axis, side) = (spot.axis(), spot.axis().cross(Vec3::X).normalize());
    for k in 0..3000 {
        let u = s.next_2d();
        let p = if k % 3 == 0 {
            // around the spot's cone (to 45 degrees, past its 40-degree
            // cutoff), 0.2 to 3 away
            let cos = 1.0 - u.x * (1.0 - 45f32.to_radians().cos());
            let sin = (1.0 - cos * cos).sqrt();
            let phi = u.y * std::f32::consts::TAU;
            let ring = side * phi.cos() + axis.cross(side) * phi.sin();
            spot.position + (0.2 + 2.8 * s.next_1d()) * (axis * cos + ring * sin)
        } else {
            Vec3::new(12.0 * u.x - 6.0, 3.0 * s.next_1d(), 12.0 * u.y - 6.0)
        };
        let n = embertrace::sampling::square_to_uniform_sphere(s.next_2d());
        let from = at(p, n);
        let pmf = lights.selection_pmfs(&from);
        for (i, light) in area.iter().enumerate() {
            let reaches = match light.shape {
                embertrace::light::Emitter::Sphere { center, radius } => {
                    n.dot(center - p) + radius > 0.0
                }
                _ => {
                    let v = scene.triangle(light.prim);
                    let front = scene.surface_point(light.prim, 1.0 / 3.0, 1.0 / 3.0).n;
                    (light.two_sided || front.dot(p - v[0]) > 0.0)
                        && v.iter().any(|&c| n.dot(c - p) > 0.0)
                }
            };
            if reaches {
                checked[0] += 1;
                assert!(
                    pmf[i] > 0.0,
                    "area light {i} reaches {p} (n {n}) but has pmf 0"
                );
            }
        }
        for (j, l) in scene.point_lights.iter().enumerate() {
            if l.sample_li(&from)
                .is_some_and(|d| n.dot(d.wi) > 0.0 && d.li.max_element() > 0.0)
            {
                checked[1] += 1;
                assert!(
                    pmf[n_area + j] > 0.0,
                    "point light reaches {p} but has pmf 0"
                );
            }
        }
        let first_spot = n_area + scene.point_lights.len();
        for (j, l) in scene.spot_lights.iter().enumerate() {
            if l.sample_li(&from)
                .is_some_and(|d| n.dot(d.wi) > 0.0 && d.li.max_element() > 0.0)
            {
                checked[2] += 1;
                assert!(
                    pmf[first_spot + j] > 0.0,
                    "spot light reaches {p} (n {n}) but has pmf 0"
                );
            }
        }
    }
    // each kind was put to the test many times
    println!("checked (area, point, spot): {checked:?}");
    assert!(checked.iter().all(|&c| c > 200), "{checked:?}");
}

#[test]
fn points_just_inside_the_spot_cone_are_reachable_and_just_outside_get_nothing() {
    // the spot at (-1, 2, 2) aimed at (-1, 0, 1.5), cutoff 40 degrees: on a
    // ring of directions at 39.9 and 40.1 degrees from its axis, at distance
    // 1.5, with the shading normal facing the light
    let scene = many_light_scene();
    let lights = Lights::with_sampler(&scene, LightSampler::Bvh);
    let spot = &scene.spot_lights[0];
    let index = lights.area_lights().len() + scene.point_lights.len();
    let axis = spot.axis();
    let side = axis.cross(Vec3::X).normalize();
    let up = axis.cross(side);
    for k in 0..36 {
        let phi = k as f32 * std::f32::consts::TAU / 36.0;
        let ring = side * phi.cos() + up * phi.sin();
        for (deg, inside) in [(39.9f32, true), (40.1, false)] {
            let t = deg.to_radians();
            let d = axis * t.cos() + ring * t.sin();
            let p = spot.position + 1.5 * d;
            let from = at(p, -d);
            let li = spot.sample_li(&from).map_or(Vec3::ZERO, |s| s.li);
            let pmf = lights.selection_pmfs(&from)[index];
            if inside {
                assert!(
                    li.max_element() > 0.0,
                    "{deg} degrees: no light inside the cutoff"
                );
                assert!(pmf > 0.0, "{deg} degrees, phi {phi}: pmf 0 inside the cone");
            } else {
                assert_eq!(li, Vec3::ZERO, "{deg} degrees: light outside the cutoff");
            }
        }
    }
}
