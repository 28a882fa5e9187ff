//! Issue 7's whole-renderer tests:
//!
//! - `--plan general` gives the specialised kernel's image bit for bit, on
//!   every bundled scene and every backend, on a CS184 course scene (panel
//!   light, emission seen only), and on small scenes that switch
//!   each kernel flag on alone (point and directional lights, environment
//!   and map, thin lens, smooth normals, textures, each material);
//! - a glass sphere in a uniform white environment renders 1.0 wherever it
//!   covers, at enough depth (a zero-variance test: one lost or doubled path
//!   fails it);
//! - a point light at the centre of a diffuse sphere gives
//!   `rho I / (pi R^2 (1 - rho))` (hard case 22);
//! - environment furnaces with an image map (hard case 23): BSDF-only
//!   samples equal rho exactly, and with map sampling and MIS a flat floor
//!   under a non-constant map matches the map's cosine-weighted integral.

mod common;

use common::batch_means;
use embertrace::accel::{self, AccelOptions, Backend};
use embertrace::integrator::PathTracer;
use embertrace::light::EnvironmentMap;
use embertrace::math::Vec3;
use embertrace::plan::{Kernel, Plan};
use embertrace::render::{RenderOutput, RenderSettings, render};
use embertrace::sampler::SamplerKind;
use embertrace::scene::Scene;
use embertrace::settings::{DirectStrategy, IntegratorSettings};
use embertrace::texture::ImageTexture;
use std::f64::consts::PI;
use std::path::{Path, PathBuf};

fn bundled(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("scenes")
        .join(name)
}

fn render_with(
    scene: &Scene,
    backend: Backend,
    kernel: Option<Kernel>,
    settings: IntegratorSettings,
    res: [u32; 2],
    spp: u32,
    seed: u64,
) -> RenderOutput {
    let acc = accel::build(backend, scene.soup(), AccelOptions::default()).unwrap();
    let tracer = match kernel {
        Some(k) => PathTracer::with_kernel(scene, acc.as_ref(), settings, k),
        None => PathTracer::new(scene, acc.as_ref(), settings),
    };
    let rs = RenderSettings {
        total_spp: None,
        resolution: res,
        spp,
        first_sample: 0,
        seed,
        threads: 0,
        tile_size: 8,
        sampler: SamplerKind::Independent,
        clamp: None,
    };
    render(&tracer, &scene.make_camera(res[0], res[1]), &rs, &|| {}).unwrap()
}

/// Specialised and general kernels give the same bits (and rays) on `scene`.
fn assert_same_bits(what: &str, scene: &Scene, backend: Backend, res: [u32; 2], spp: u32) {
    let settings = IntegratorSettings {
        max_depth: scene.render.max_depth.min(16),
        ..IntegratorSettings::default()
    };
    let plan = Plan::new(scene, &settings);
    let a = render_with(scene, backend, None, settings, res, spp, 3);
    let b = render_with(scene, backend, Some(Kernel::GENERAL), settings, res, spp, 3);
    let (x, y) = (a.film.to_rgb_f32(), b.film.to_rgb_f32());
    let differ = x
        .iter()
        .zip(&y)
        .filter(|(p, q)| p.to_bits() != q.to_bits())
        .count();
    assert_eq!(
        differ,
        0,
        "{what} on {backend}: kernel {} and general differ in {differ} values",
        plan.kernel.describe()
    );
    assert_eq!(a.rays, b.rays, "{what} on {backend}");
    assert_eq!(a.nonfinite.count, 0, "{what} on {backend}");
    assert!(x.iter().any(|&v| v > 0.0), "{what}: black image");
}

#[test]
fn general_kernel_gives_the_same_bits_on_every_bundled_scene_and_backend() {
    for name in [
        "cornell-box.toml",
        "cornell-spheres.toml",
        "materials.toml",
        "many-lights.toml",
        "cut-outs.toml",
    ] {
        let scene = Scene::load(&bundled(name)).unwrap();
        for backend in Backend::available() {
            assert_same_bits(name, &scene, backend, [24, 16], 2);
        }
    }
    // a CS184 course scene: a panel light and emission seen only
    let course = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/collada/course_box.dae");
    let scene = Scene::load(&course).unwrap();
    assert!(
        Plan::new(&scene, &IntegratorSettings::default())
            .on()
            .contains(&"emitter_roles")
    );
    for backend in Backend::available() {
        assert_same_bits("course_box.dae", &scene, backend, [48, 36], 4);
    }
    // a million triangles, or 20 million placed: the fast backends only,
    // a few pixels
    for name in ["sphere-1m.toml", "instances.toml"] {
        let scene = Scene::load(&bundled(name)).unwrap();
        for backend in Backend::available() {
            if backend != Backend::Naive {
                assert_same_bits(name, &scene, backend, [8, 8], 1);
            }
        }
    }
}

/// A scene from TOML text, with extra files, in a temporary folder.
fn scene_from(toml: &str, files: &[(&str, &[u8])]) -> Scene {
    let dir = tempfile::tempdir().unwrap();
    for (name, bytes) in files {
        std::fs::write(dir.path().join(name), bytes).unwrap();
    }
    let path = dir.path().join("s.toml");
    std::fs::write(&path, toml).unwrap();
    Scene::load(&path).unwrap()
}

/// A 16 x 8 PNG: a colour gradient (for textures and maps).
fn gradient_png() -> Vec<u8> {
    let img = image::RgbImage::from_fn(16, 8, |x, y| {
        image::Rgb([(x * 15) as u8, (y * 30) as u8, 200 - (x * 5) as u8])
    });
    let mut bytes = Vec::new();
    img.write_to(
        &mut std::io::Cursor::new(&mut bytes),
        image::ImageFormat::Png,
    )
    .unwrap();
    bytes
}

const BOX: &str = r#"
[camera]
origin = [0.0, 1.0, 3.9]
target = [0.0, 1.0, 0.0]
fov_y = 39.3
"#;

#[test]
fn general_kernel_gives_the_same_bits_with_each_effect_alone() {
    let obj = std::fs::read(bundled("cornell-box.obj")).unwrap();
    let mtl = std::fs::read(bundled("cornell-box.mtl")).unwrap();
    // a smooth-shaded, textured quad: corners' normals lean outwards
    let quad = b"v -0.5 0.2 0\nv 0.5 0.2 0\nv 0.5 1.2 0\nv -0.5 1.2 0\n\
vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n\
vn -0.3 -0.3 1\nvn 0.3 -0.3 1\nvn 0.3 0.3 1\nvn -0.3 0.3 1\n\
f 1/1/1 2/2/2 3/3/3\nf 1/1/1 3/3/3 4/4/4\n";
    let png = gradient_png();
    let files: &[(&str, &[u8])] = &[
        ("cornell-box.obj", &obj),
        ("cornell-box.mtl", &mtl),
        ("quad.obj", quad),
        ("tex.png", &png),
    ];
    let room = "[[mesh]]\nfile = \"cornell-box.obj\"\n";
    let cases = [
        (
            "point light",
            format!(
                "{room}[[light]]\ntype = \"point\"\nposition = [0.2, 1.5, 0.3]\nintensity = [2.0, 1.5, 1.0]\n"
            ),
        ),
        (
            "spot light",
            format!(
                "{room}[[light]]\ntype = \"spot\"\nposition = [0.2, 1.7, 0.3]\ntarget = [0.0, 0.0, 0.0]\nintensity = [2.0, 1.5, 1.0]\ncutoff_angle = 40.0\nbeam_width = 10.0\n"
            ),
        ),
        (
            "directional light",
            "[[mesh]]\nfile = \"quad.obj\"\n[[light]]\ntype = \"directional\"\ndirection = [0.3, -0.4, -1.0]\nirradiance = 2.0\n".to_string(),
        ),
        (
            "environment",
            format!("{room}[[light]]\ntype = \"environment\"\nradiance = [0.2, 0.3, 0.4]\n"),
        ),
        (
            "environment map",
            "[[mesh]]\nfile = \"quad.obj\"\n[[light]]\ntype = \"environment\"\nfile = \"tex.png\"\nradiance = 2.0\n".to_string(),
        ),
        (
            "smooth normals and texture",
            format!(
                "{room}[[mesh]]\nfile = \"quad.obj\"\nmaterial = {{ texture = \"tex.png\" }}\n"
            ),
        ),
        ("thin lens", room.to_string()),
        (
            "mirror",
            format!("{room}[[mesh]]\nfile = \"quad.obj\"\nmaterial = {{ type = \"mirror\" }}\n"),
        ),
        (
            "glass",
            format!(
                "{room}[[mesh]]\nfile = \"quad.obj\"\nmaterial = {{ type = \"glass\", ior = 1.33 }}\n"
            ),
        ),
        (
            "rough conductor",
            format!(
                "{room}[[mesh]]\nfile = \"quad.obj\"\nmaterial = {{ type = \"conductor\", alpha = 0.3, eta = [0.2, 0.4, 1.4], k = [3.1, 2.3, 1.8], distribution = \"beckmann\" }}\n"
            ),
        ),
        (
            "plastic",
            format!(
                "{room}[[mesh]]\nfile = \"quad.obj\"\nmaterial = {{ type = \"plastic\", diffuse = [0.5, 0.2, 0.1], alpha = 0.2, texture = \"tex.png\" }}\n"
            ),
        ),
        (
            "phong",
            format!(
                "{room}[[mesh]]\nfile = \"quad.obj\"\nmaterial = {{ type = \"phong\", diffuse = [0.5, 0.2, 0.1], specular = 0.3, shininess = 40.0, texture = \"tex.png\" }}\n"
            ),
        ),
        (
            "phong ggx",
            format!(
                "{room}[[mesh]]\nfile = \"quad.obj\"\nmaterial = {{ type = \"phong\", diffuse = 0.4, specular = [0.2, 0.5, 0.3], roughness = 0.25 }}\n"
            ),
        ),
        (
            "rough and thin glass",
            format!(
                "{room}[[mesh]]\nfile = \"quad.obj\"\nmaterial = {{ type = \"rough_glass\", ior = 1.4, alpha = 0.2 }}\n[[mesh]]\nfile = \"quad.obj\"\ntransform = {{ translate = [0.1, 0.2, 0.4] }}\nmaterial = {{ type = \"thin_glass\", ior = 1.5 }}\n"
            ),
        ),
        (
            "metallic roughness",
            format!(
                "{room}[[mesh]]\nfile = \"quad.obj\"\nmaterial = {{ type = \"metallic_roughness\", base_color = [0.6, 0.4, 0.2], metallic = 0.3, roughness = 0.4, texture = \"tex.png\", metallic_roughness = {{ texture = \"tex.png\" }} }}\n"
            ),
        ),
        (
            "emissive sphere",
            format!(
                "{room}[[sphere]]\ncenter = [0.3, 0.5, 0.2]\nradius = 0.2\nmaterial = {{ emission = [3.0, 3.0, 3.0] }}\n"
            ),
        ),        (
            "alpha mask",
            format!(
                "{room}[[mesh]]\nfile = \"quad.obj\"\nalpha = \"tex.png\"\n[[mesh]]\nfile = \"quad.obj\"\nalpha = 0.4\ntransform = {{ translate = [0.2, 0.1, 0.3] }}\n"
            ),
        ),
    ];
    for (what, body) in cases {
        let camera = if what == "thin lens" {
            BOX.replace(
                "fov_y = 39.3",
                "fov_y = 39.3\naperture_radius = 0.1\nfocus_distance = 3.0",
            )
        } else {
            BOX.to_string()
        };
        let scene = scene_from(&format!("{camera}{body}"), files);
        let plan = Plan::new(&scene, &IntegratorSettings::default());
        assert_ne!(plan.kernel, Kernel::GENERAL, "{what}: a specialised kernel");
        for backend in Backend::available() {
            assert_same_bits(what, &scene, backend, [20, 20], 2);
        }
    }
}

#[test]
fn the_plan_names_what_each_scene_calls_for() {
    let on = |name: &str| {
        let scene = Scene::load(&bundled(name)).unwrap();
        Plan::new(&scene, &IntegratorSettings::default()).on()
    };
    assert_eq!(
        on("cornell-box.toml"),
        ["diffuse", "area_light", "indirect"]
    );
    assert_eq!(
        on("cornell-spheres.toml"),
        [
            "diffuse",
            "mirror",
            "glass",
            "area_light",
            "sphere",
            "indirect"
        ]
    );
    assert_eq!(
        on("materials.toml"),
        [
            "diffuse",
            "mirror",
            "glass",
            "conductor",
            "plastic",
            "texture",
            "environment_map",
            "sphere",
            "indirect"
        ]
    );
    assert_eq!(
        on("cut-outs.toml"),
        [
            "diffuse",
            "texture",
            "area_light",
            "indirect",
            "instancing",
            "alpha_mask"
        ]
    );
    let scene = Scene::load(&bundled("cornell-box.toml")).unwrap();
    let direct_only = IntegratorSettings {
        max_depth: 1,
        ..IntegratorSettings::default()
    };
    let plan = Plan::new(&scene, &direct_only);
    assert_eq!(plan.on(), ["diffuse", "area_light"]);
    // the diffuse box compiles out materials, delta, environment, shapes, lens
    assert_eq!(
        plan.kernel,
        Kernel {
            emitters: true,
            ..Kernel::default()
        }
    );
}

#[test]
fn glass_sphere_in_a_white_environment_is_white() {
    let scene = scene_from(
        r#"
[camera]
origin = [0.0, 0.0, 3.0]
target = [0.0, 0.0, 0.0]
fov_y = 30.0
[[sphere]]
center = [0.0, 0.0, 0.0]
radius = 0.7
material = { type = "glass", ior = 1.5 }
[[light]]
type = "environment"
radiance = 1.0
"#,
        &[],
    );
    for backend in Backend::available() {
        let settings = IntegratorSettings {
            max_depth: 100,
            ..IntegratorSettings::default()
        };
        let out = render_with(&scene, backend, None, settings, [24, 24], 4, 1);
        let img = out.film.to_rgb_f32();
        // every sample is 1 up to rounding: the glass weights multiply to 1
        let worst = img.iter().map(|v| (v - 1.0).abs()).fold(0.0, f32::max);
        assert!(worst < 1e-4, "{backend}: off by {worst}");
        assert!(
            out.rays.extension > 24 * 24 * 4,
            "{backend}: sphere not hit"
        );
        // at depth 1 a path that enters the glass cannot leave it: the
        // centre keeps only the Fresnel reflection (about 0.04)
        let shallow = IntegratorSettings {
            max_depth: 1,
            ..settings
        };
        let dark = render_with(&scene, backend, None, shallow, [24, 24], 4, 1);
        let centre = dark.film.mean(12, 12);
        assert!(centre.max_element() < 0.2, "{backend}: {centre}");
    }
}

/// A thin glass sheet in a white environment: reflected or passed
/// straight through, every sample has weight 1, so the image is white; at
/// depth 1 the sheet shows its reflectance and what it transmits of the
/// sky behind (a sheet refracts nothing, so a path through it sees the sky
/// at once and depth 1 is already white too).
#[test]
fn thin_glass_sheet_in_a_white_environment_is_white() {
    let quad: &[u8] = b"v -1 -1 0\nv 1 -1 0\nv 1 1 0\nv -1 1 0\nf 1 2 3\nf 1 3 4\n";
    let scene = scene_from(
        r#"
[camera]
origin = [0.3, 0.2, 3.0]
target = [0.0, 0.0, 0.0]
fov_y = 30.0
[[mesh]]
file = "sheet.obj"
material = { type = "thin_glass", ior = 1.5 }
[[light]]
type = "environment"
radiance = 1.0
"#,
        &[("sheet.obj", quad)],
    );
    for backend in Backend::available() {
        for depth in [1, 20] {
            let settings = IntegratorSettings {
                max_depth: depth,
                ..IntegratorSettings::default()
            };
            let out = render_with(&scene, backend, None, settings, [16, 16], 4, 1);
            let img = out.film.to_rgb_f32();
            let worst = img.iter().map(|v| (v - 1.0).abs()).fold(0.0, f32::max);
            assert!(worst < 1e-4, "{backend} depth {depth}: off by {worst}");
            if depth > 1 {
                assert!(
                    out.rays.extension >= 16 * 16 * 4,
                    "{backend}: sheet not hit"
                );
            }
        }
    }
}

#[test]
fn point_light_inside_a_diffuse_sphere() {
    // hard case 22: L = rho I / (pi R^2 (1 - rho)) everywhere on the wall
    let (rho, i, r) = (0.5f64, 3.0f64, 2.0f64);
    let scene = scene_from(
        &format!(
            r#"
[camera]
origin = [0.0, 0.0, 0.0]
target = [0.0, 0.0, -1.0]
fov_y = 60.0
[[sphere]]
center = [0.0, 0.0, 0.0]
radius = {r}
material = {{ diffuse = {rho} }}
[[light]]
type = "point"
position = [0.0, 0.0, 0.0]
intensity = {i}
"#
        ),
        &[],
    );
    let expected = rho * i / (PI * r * r * (1.0 - rho));
    let res = [16u32, 16u32];
    for backend in Backend::available() {
        let out = render_with(
            &scene,
            backend,
            None,
            IntegratorSettings::default(),
            res,
            64,
            7,
        );
        let pixels = (res[0] * res[1]) as usize;
        let stats = batch_means(pixels, 16, |k| {
            out.film.mean(k as u32 % res[0], k as u32 / res[0]).y as f64
        });
        assert!(
            (stats.mean - expected).abs() < 5.0 * stats.std_err + 1e-6,
            "{backend}: {} +- {} vs {expected}",
            stats.mean,
            stats.std_err
        );
    }
}

/// A `w x h` map holding `f(u, v)` at texel centres.
fn map(w: u32, h: u32, f: impl Fn(f32, f32) -> Vec3) -> ImageTexture {
    let mut rgb = Vec::new();
    for y in 0..h {
        for x in 0..w {
            let c = f((x as f32 + 0.5) / w as f32, y as f32 / (h - 1) as f32);
            rgb.extend([c.x, c.y, c.z]);
        }
    }
    ImageTexture::from_linear_rgb(w, h, rgb).unwrap()
}

/// A floor quad (2 x 2 at y = 0, facing up) and a camera looking down at it.
fn floor_scene(rho: f32, env: EnvironmentMap) -> Scene {
    let mut m = common::MeshMaker::default();
    let mat = m.material(rho, 0.0, false);
    m.quad(
        Vec3::new(-1.0, 0.0, 1.0),
        Vec3::new(1.0, 0.0, 1.0),
        Vec3::new(1.0, 0.0, -1.0),
        Vec3::new(-1.0, 0.0, -1.0),
        mat,
    );
    let mut scene = m.scene();
    scene.camera = embertrace::camera::CameraDesc {
        origin: Vec3::new(0.0, 2.0, 0.0),
        target: Vec3::ZERO,
        up: Vec3::Z,
        fov_y: 30.0,
    };
    scene.environment_map = Some(env);
    scene
}

#[test]
fn environment_map_furnace_bsdf_only_is_exact() {
    // hard case 23 with a map: constant 0.5 texels scaled by 2
    let scene = floor_scene(0.6, uniform_map());
    assert_furnace_is_exact(&scene, 0.6, DirectStrategy::Bsdf);
}

/// A map of constant 0.5 texels scaled by 2: radiance 1 everywhere.
fn uniform_map() -> EnvironmentMap {
    EnvironmentMap::new(map(16, 8, |_, _| Vec3::splat(0.5)), Vec3::splat(2.0)).unwrap()
}

/// Every sample of `scene` (a floor of albedo `rho` under radiance 1),
/// rendered with `direct`, is exactly `rho`.
fn assert_furnace_is_exact(scene: &Scene, rho: f32, direct: DirectStrategy) {
    let settings = IntegratorSettings {
        direct,
        max_depth: 8,
        ..IntegratorSettings::default()
    };
    for backend in Backend::available() {
        let out = render_with(scene, backend, None, settings, [12, 12], 8, 2);
        for v in out.film.to_rgb_f32() {
            assert!((v - rho).abs() < 1e-5, "{direct} {backend}: {v} vs {rho}");
        }
    }
}

#[test]
fn a_diffuse_floor_under_a_uniform_sky_samples_its_bsdf_alone_by_default() {
    // Light sampling draws the whole sphere at 1 / (4 pi); the cosine lobe
    // peaks at 1 / pi: at the default MIS the bounce skips light sampling
    // (LIGHT_SAMPLING_PEAK_RATIO), so every sample is exactly rho, as with
    // BSDF sampling alone; light samples would add noise.
    assert_eq!(IntegratorSettings::default().direct, DirectStrategy::Mis);
    let mut scene = floor_scene(0.6, uniform_map());
    scene.environment_map = None;
    scene.environment = Some(Vec3::ONE);
    assert_furnace_is_exact(&scene, 0.6, DirectStrategy::Mis);
}

#[test]
fn a_map_is_light_sampled_even_where_it_is_uniform() {
    // the same radiance as a map: MIS runs (maps are never skipped), so the
    // render is not the BSDF-only one
    let scene = floor_scene(0.6, uniform_map());
    let render = |direct| {
        let settings = IntegratorSettings {
            direct,
            max_depth: 8,
            ..IntegratorSettings::default()
        };
        render_with(&scene, Backend::Bvh, None, settings, [12, 12], 8, 1)
            .film
            .to_rgb_f32()
    };
    let (mis, bsdf) = (render(DirectStrategy::Mis), render(DirectStrategy::Bsdf));
    let differ = mis.iter().zip(&bsdf).filter(|(a, b)| a != b).count();
    assert!(
        differ > mis.len() / 2,
        "{differ} of {} values differ",
        mis.len()
    );
}

#[test]
fn environment_map_lights_a_floor_by_its_cosine_integral() {
    // a non-constant map: a sky gradient and a bright patch
    let f = |u: f32, v: f32| {
        let spot = if (u - 0.3).abs() < 0.05 && (v - 0.3).abs() < 0.06 {
            40.0
        } else {
            0.0
        };
        Vec3::new(0.2 + spot, 0.5 * (1.0 - v) + spot, 1.0 - v + 0.2 * u)
    };
    let env = EnvironmentMap::new(map(64, 32, f), Vec3::ONE).unwrap();
    // E = int L(w) w.y dw over the upper hemisphere, by dense quadrature
    let (nu, nv) = (2048, 1024);
    let mut e = 0.0f64;
    for j in 0..nv / 2 {
        let theta = PI * (j as f64 + 0.5) / nv as f64;
        for i in 0..nu {
            let phi = 2.0 * PI * (i as f64 + 0.5) / nu as f64;
            let d = Vec3::new(
                (phi.sin() * theta.sin()) as f32,
                theta.cos() as f32,
                (-phi.cos() * theta.sin()) as f32,
            );
            let dw = (PI / nv as f64) * (2.0 * PI / nu as f64) * theta.sin();
            e += env.eval(d).y as f64 * theta.cos() * dw;
        }
    }
    let rho = 0.5f64;
    let expected = rho / PI * e;
    let scene = floor_scene(rho as f32, env);
    let settings = IntegratorSettings {
        max_depth: 1,
        ..IntegratorSettings::default()
    };
    let res = [16u32, 16u32];
    for backend in Backend::available() {
        let out = render_with(&scene, backend, None, settings, res, 64, 9);
        let stats = batch_means((res[0] * res[1]) as usize, 16, |k| {
            out.film.mean(k as u32 % res[0], k as u32 / res[0]).y as f64
        });
        assert!(
            (stats.mean - expected).abs() < 5.0 * stats.std_err + 2e-3 * expected,
            "{backend}: {} +- {} vs {expected}",
            stats.mean,
            stats.std_err
        );
    }
}

/// A coarse UV sphere of radius 1 as OBJ text, with vertex normals (the
/// true sphere's) when `normals` is set.
fn coarse_sphere_obj(segments: usize, rings: usize, normals: bool) -> String {
    let mut s = String::new();
    for j in 0..=rings {
        let theta = std::f32::consts::PI * j as f32 / rings as f32;
        for i in 0..segments {
            let phi = std::f32::consts::TAU * i as f32 / segments as f32;
            let p = Vec3::new(
                theta.sin() * phi.cos(),
                theta.cos(),
                -theta.sin() * phi.sin(),
            );
            s += &format!("v {} {} {}\n", p.x, p.y, p.z);
            if normals {
                s += &format!("vn {} {} {}\n", p.x, p.y, p.z);
            }
        }
    }
    let at = |j: usize, i: usize| j * segments + i % segments + 1;
    for j in 0..rings {
        for i in 0..segments {
            let (a, b, c, d) = (at(j, i), at(j + 1, i), at(j + 1, i + 1), at(j, i + 1));
            let f = |x: usize| {
                if normals {
                    format!("{x}//{x}")
                } else {
                    x.to_string()
                }
            };
            if j > 0 {
                s += &format!("f {} {} {}\n", f(a), f(b), f(d));
            }
            if j + 1 < rings {
                s += &format!("f {} {} {}\n", f(b), f(c), f(d));
            }
        }
    }
    s
}

#[test]
fn smooth_normals_leave_no_black_terminator_under_a_uniform_sky() {
    // A coarse smooth sphere in a white environment. Near the silhouette
    // some visible points have an interpolated normal facing away from the
    // viewer; a Lambertian evaluated with that normal is black there. The
    // shading rule bends such normals towards the viewer, so every pixel
    // wholly on the sphere keeps most of rho (flat shading gives exactly
    // rho); the test checks that such pixels exist.
    let obj = coarse_sphere_obj(8, 5, true);
    let scene = scene_from(
        r#"
[camera]
origin = [0.0, 0.0, 4.0]
target = [0.0, 0.0, 0.0]
fov_y = 35.0
[[mesh]]
file = "s.obj"
material = { diffuse = 0.5 }
[[light]]
type = "environment"
radiance = 1.0
"#,
        &[("s.obj", obj.as_bytes())],
    );
    let plan = Plan::new(&scene, &IntegratorSettings::default());
    assert!(plan.on().contains(&"smooth_normals"));
    let res = 64;
    let backend = Backend::default_backend();
    let out = render_with(
        &scene,
        backend,
        None,
        IntegratorSettings::default(),
        [res, res],
        32,
        4,
    );
    let acc = accel::build(backend, scene.soup(), AccelOptions::default()).unwrap();
    let camera = scene.make_camera(res, res);
    let (mut covered_pixels, mut facing_away) = (0, 0);
    for y in 0..res {
        for x in 0..res {
            let at = |dx: f32, dy: f32| {
                let ray =
                    camera.generate_ray(embertrace::math::Vec2::new(x as f32 + dx, y as f32 + dy));
                acc.intersect(&ray).map(|h| (ray, h))
            };
            // pixels wholly on the sphere: all four corners hit it
            let corners = [(0.0, 0.0), (1.0, 0.0), (0.0, 1.0), (1.0, 1.0)];
            if !corners.iter().all(|(dx, dy)| at(*dx, *dy).is_some()) {
                continue;
            }
            covered_pixels += 1;
            let (ray, hit) = at(0.5, 0.5).unwrap();
            let c = scene.tri_shading_normals[hit.prim as usize];
            let ns = (1.0 - hit.u - hit.v) * c[0] + hit.u * c[1] + hit.v * c[2];
            if ns.dot(-ray.d) < 0.0 {
                facing_away += 1;
            }
            let v = out.film.mean(x, y).y;
            assert!(v > 0.3, "pixel ({x}, {y}) on the sphere is {v}");
            assert!(v < 0.5 + 0.1, "pixel ({x}, {y}) is {v}: brighter than rho");
        }
    }
    assert!(covered_pixels > 600, "{covered_pixels} pixels");
    assert!(
        facing_away >= 5,
        "only {facing_away} pixels see a normal facing away"
    );
}

#[test]
fn smooth_normals_never_let_light_through_the_surface() {
    // A quad whose vertex normals lean far over, lit only by a point light
    // behind it: the geometric surface blocks that light, so every pixel on
    // the quad is exactly black, whatever the normals say. The same light in
    // front lights it (the control).
    let quad = b"v -1 -1 0\nv 1 -1 0\nv 1 1 0\nv -1 1 0\n\
vn -0.9 0 0.2\nvn 0.9 0 0.2\nvn 0.9 0 0.2\nvn -0.9 0 0.2\n\
f 1//1 2//2 3//3\nf 1//1 3//3 4//4\n";
    let lit = |z: f32, backend: Backend| {
        let scene = scene_from(
            &format!(
                r#"
[camera]
origin = [0.0, 0.0, 3.0]
target = [0.0, 0.0, 0.0]
fov_y = 30.0
[[mesh]]
file = "q.obj"
material = {{ diffuse = 0.9, two_sided = true }}
[[light]]
type = "point"
position = [0.3, 0.2, {z}]
intensity = 10.0
"#
            ),
            &[("q.obj", &quad[..])],
        );
        let out = render_with(
            &scene,
            backend,
            None,
            IntegratorSettings::default(),
            [16, 16],
            8,
            1,
        );
        assert_eq!(out.nonfinite.count, 0);
        out.film.to_rgb_f32().iter().filter(|v| **v != 0.0).count()
    };
    for backend in Backend::available() {
        assert_eq!(
            lit(-0.05, backend),
            0,
            "{backend}: light leaked through the quad"
        );
        assert!(lit(0.5, backend) > 100, "{backend}: the control is dark");
    }
}

#[test]
fn a_texture_on_a_mesh_without_uvs_is_an_error_naming_the_mesh() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("t.png"), gradient_png()).unwrap();
    std::fs::write(
        dir.path().join("m.obj"),
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",
    )
    .unwrap();
    let path = dir.path().join("s.toml");
    std::fs::write(
        &path,
        "[[mesh]]\nfile = \"m.obj\"\nmaterial = { texture = \"t.png\" }\n",
    )
    .unwrap();
    let e = Scene::load(&path).unwrap_err().to_string();
    assert!(
        e.contains("s.toml:1") && e.contains("mesh `m.obj`") && e.contains("texture coordinates"),
        "{e}"
    );
}
