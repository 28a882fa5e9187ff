//! Issue items 4 and 5, whole-renderer tests:
//!
//! - textures on every parameter a peer renderer textures: a constant
//!   texture renders the same bits as the constant (roughness, reflectance);
//!   the plan names each textured parameter; `--plan general` stays
//!   bit-identical with textured parameters, normal and bump maps;
//! - normal and bump maps in closed form (flat maps change nothing, a tilted
//!   normal map and a linear bump ramp shade a Lambertian plane under a
//!   directional light as the cosine of the tilt predicts);
//! - bad keys and files are one-line errors naming the scene file and line;
//! - `convert` writes every textured parameter and map back;
//! - `render --albedo --normal` (item 7) writes the same bits for any thread
//!   count and refuses outputs onto inputs or other outputs.

use embertrace::accel::{self, AccelOptions, Backend};
use embertrace::integrator::PathTracer;
use embertrace::plan::{Kernel, Plan};
use embertrace::render::{RenderOutput, RenderSettings, render};
use embertrace::sampler::SamplerKind;
use embertrace::scene::Scene;
use embertrace::settings::IntegratorSettings;
use std::path::PathBuf;

fn render_with(scene: &Scene, backend: Backend, kernel: Option<Kernel>, spp: u32) -> RenderOutput {
    let acc = accel::build(backend, scene.soup(), AccelOptions::default()).unwrap();
    let settings = IntegratorSettings {
        max_depth: scene.render.max_depth.min(8),
        ..IntegratorSettings::default()
    };
    let tracer = match kernel {
        Some(k) => PathTracer::with_kernel(scene, acc.as_ref(), settings, k),
        None => PathTracer::new(scene, acc.as_ref(), settings),
    };
    let res = [16, 16];
    let rs = RenderSettings {
        total_spp: None,
        resolution: res,
        spp,
        first_sample: 0,
        seed: 7,
        threads: 0,
        tile_size: 8,
        sampler: SamplerKind::Independent,
        clamp: None,
    };
    render(&tracer, &scene.make_camera(res[0], res[1]), &rs, &|| {}).unwrap()
}

fn bits(out: &RenderOutput) -> Vec<u32> {
    out.film.to_rgb_f32().iter().map(|v| v.to_bits()).collect()
}

/// A folder holding `files` and the scene `toml` as `s.toml`.
fn folder(toml: &str, files: &[(&str, Vec<u8>)]) -> (tempfile::TempDir, PathBuf) {
    let dir = tempfile::tempdir().unwrap();
    for (name, bytes) in files {
        std::fs::write(dir.path().join(name), bytes).unwrap();
    }
    let path = dir.path().join("s.toml");
    std::fs::write(&path, toml).unwrap();
    (dir, path)
}

fn load(toml: &str, files: &[(&str, Vec<u8>)]) -> Scene {
    let (_dir, path) = folder(toml, files);
    Scene::load(&path).unwrap()
}

/// The error loading `toml` gives, checked to be one line naming `s.toml`.
fn load_error(toml: &str, files: &[(&str, Vec<u8>)]) -> String {
    let (_dir, path) = folder(toml, files);
    let e = Scene::load(&path).unwrap_err().to_string();
    assert!(!e.contains('\n'), "not one line: {e}");
    e
}

/// A PNG of `w x h` RGB8 texels from `f(x, y)`.
fn png(w: u32, h: u32, f: impl Fn(u32, u32) -> [u8; 3]) -> Vec<u8> {
    let img = image::RgbImage::from_fn(w, h, |x, y| image::Rgb(f(x, y)));
    let mut bytes = Vec::new();
    img.write_to(
        &mut std::io::Cursor::new(&mut bytes),
        image::ImageFormat::Png,
    )
    .unwrap();
    bytes
}

/// A unit quad in the z = 0 plane facing +z, with UVs, as an OBJ.
const QUAD: &str = "v -1 -1 0\nv 1 -1 0\nv 1 1 0\nv -1 1 0\n\
vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n\
f 1/1 2/2 3/3\nf 1/1 3/3 4/4\n";

/// The quad seen from the front, under a white environment and a
/// directional light, with `material`.
fn quad_scene(material: &str) -> String {
    format!(
        r#"
[camera]
origin = [0.0, 0.0, 3.0]
target = [0.0, 0.0, 0.0]
fov_y = 30.0
[render]
max_depth = 3
[[mesh]]
file = "q.obj"
material = {material}
[[sphere]]
center = [0.0, 0.0, -3.0]
radius = 0.5
material = {{ emission = 2.0 }}
[[light]]
type = "directional"
direction = [-0.3, -0.2, -1.0]
irradiance = 1.5
[[light]]
type = "environment"
radiance = 0.3
"#
    )
}

fn grey(v: u8) -> Vec<u8> {
    png(2, 2, |_, _| [v, v, v])
}

#[test]
fn a_constant_texture_renders_the_constant_bits() {
    // 51 / 255 = 0.2 exactly in f32 once read raw; a uniform texture
    // returns its texel exactly, so the BSDFs are equal bit for bit
    let files = [("q.obj", QUAD.as_bytes().to_vec()), ("c.png", grey(51))];
    let pairs = [
        (
            r#"{ type = "conductor", alpha = 0.2, eta = [0.2, 0.4, 1.4], k = [3.1, 2.3, 1.8] }"#,
            r#"{ type = "conductor", alpha = { texture = "c.png" }, eta = [0.2, 0.4, 1.4], k = [3.1, 2.3, 1.8] }"#,
        ),
        (
            r#"{ type = "mirror", reflectance = 0.2 }"#,
            r#"{ type = "mirror", reflectance = { texture = "c.png", raw = true } }"#,
        ),
        (
            r#"{ type = "glass", reflectance = 0.2, transmittance = 0.2 }"#,
            r#"{ type = "glass", reflectance = { texture = "c.png", raw = true }, transmittance = { texture = "c.png", raw = true } }"#,
        ),
        (
            r#"{ diffuse = 0.5, emission = 0.2, two_sided = true }"#,
            r#"{ diffuse = 0.5, emission = { texture = "c.png", raw = true }, two_sided = true }"#,
        ),
        (
            r#"{ type = "plastic", diffuse = [0.6, 0.3, 0.2], alpha = 0.2 }"#,
            r#"{ type = "plastic", diffuse = [0.6, 0.3, 0.2], alpha = { texture = "c.png" } }"#,
        ),
        (
            r#"{ type = "phong", diffuse = 0.5, specular = 0.2, shininess = 20.0 }"#,
            r#"{ type = "phong", diffuse = 0.5, specular = { texture = "c.png", raw = true }, shininess = 20.0 }"#,
        ),
    ];
    for (constant, textured) in pairs {
        let a = load(&quad_scene(constant), &files);
        let b = load(&quad_scene(textured), &files);
        assert!(b.materials.iter().any(|m| !m.textured().is_empty()));
        for backend in Backend::available() {
            let (x, y) = (
                render_with(&a, backend, Some(Kernel::GENERAL), 4),
                render_with(&b, backend, None, 4),
            );
            assert!(x.film.to_rgb_f32().iter().any(|v| *v > 0.0));
            assert_eq!(bits(&x), bits(&y), "{textured} on {backend}");
        }
    }
}

#[test]
fn the_plan_names_each_textured_parameter_and_general_is_bit_identical() {
    let ramp = png(8, 4, |x, y| [(x * 30) as u8, (y * 60) as u8, 90]);
    let files = [
        ("q.obj", QUAD.as_bytes().to_vec()),
        ("r.png", ramp),
        ("c.png", grey(51)),
    ];
    let cases = [
        (
            r#"{ type = "conductor", alpha = { texture = "r.png" } }"#,
            "`default` alpha",
        ),
        (
            r#"{ type = "glass", transmittance = { texture = "r.png" } }"#,
            "`default` transmittance",
        ),
        (
            r#"{ type = "mirror", reflectance = { texture = "r.png" } }"#,
            "`default` reflectance",
        ),
        (
            r#"{ type = "diffuse", diffuse = { texture = "r.png" } }"#,
            "`default` texture",
        ),
        (
            r#"{ type = "phong", specular = { texture = "r.png" }, shininess = 9.0 }"#,
            "`default` specular",
        ),
    ];
    for (material, because) in cases {
        let scene = load(&quad_scene(material), &files);
        let plan = Plan::new(&scene, &IntegratorSettings::default());
        let texture = plan.effects.iter().find(|e| e.name == "texture").unwrap();
        assert!(texture.on, "{material}");
        assert!(texture.because.contains(because), "{}", texture.because);
        assert!(plan.kernel.materials);
        for backend in Backend::available() {
            let a = render_with(&scene, backend, None, 2);
            let b = render_with(&scene, backend, Some(Kernel::GENERAL), 2);
            assert_eq!(bits(&a), bits(&b), "{material} on {backend}");
            assert_eq!(a.nonfinite.count, 0);
        }
    }
}

#[test]
fn a_textured_roughness_varies_the_highlight() {
    // smooth on the left half, rough on the right: the images differ from
    // both constants, and the plan sees the delta lobe of the smooth texels
    let half = png(4, 1, |x, _| if x < 2 { [0, 0, 0] } else { [128, 128, 128] });
    let files = [("q.obj", QUAD.as_bytes().to_vec()), ("h.png", half)];
    let scene = load(
        &quad_scene(r#"{ type = "conductor", alpha = { texture = "h.png" } }"#),
        &files,
    );
    let plan = Plan::new(&scene, &IntegratorSettings::default());
    assert!(plan.kernel.delta, "a smooth texel is a delta lobe");
    // the image: where a pixel sees one texel only, it is the render of
    // that texel's constant, bit for bit (the quad reflects into the
    // environment only, so a pixel depends on its own texel), and the two
    // constants' highlights differ there
    let smooth = load(
        &quad_scene(r#"{ type = "conductor", alpha = 0.0 }"#),
        &files,
    );
    let rough = load(
        &quad_scene(r#"{ type = "conductor", alpha = 0.5019608 }"#),
        &files,
    );
    assert_halves_match(&scene, &smooth, &rough);
}

/// The quad spans u = 0.1 to 0.9 across the 16 columns, 0.0502 a column; a
/// 4 x 1 texture of two left texels and two right ones (wrapped, bilinear)
/// is the left value alone for u in [0.125, 0.375] (columns 1 to 4) and the
/// right value alone in [0.625, 0.875] (columns 11 to 14). There, `textured`
/// renders what `left` and `right` render (same seed, same paths), and those
/// two differ by far more. Not bit for bit: the bilinear blend of equal
/// texels rounds in the last place, and a mirror's roughness of 0 blended
/// to 1e-9 is a very sharp lobe, not a delta one.
fn assert_halves_match(textured: &Scene, left: &Scene, right: &Scene) {
    let backend = Backend::default_backend();
    let (t, a, b) = (
        render_with(textured, backend, None, 16),
        render_with(left, backend, None, 16),
        render_with(right, backend, None, 16),
    );
    let mean = |out: &RenderOutput, xs: std::ops::RangeInclusive<usize>| {
        let rgb = out.film.to_rgb_f32();
        let n = 16 * xs.clone().count() * 3;
        (0..16)
            .flat_map(|y| {
                xs.clone()
                    .flat_map(move |x| (0..3).map(move |c| 3 * (16 * y + x) + c))
            })
            .map(|i| f64::from(rgb[i]))
            .sum::<f64>()
            / n as f64
    };
    for (xs, same, other, side) in [(1..=4, &a, &b, "left"), (11..=14, &b, &a, "right")] {
        let (got, want, far) = (
            mean(&t, xs.clone()),
            mean(same, xs.clone()),
            mean(other, xs),
        );
        eprintln!("{side}: textured {got:.5}, its constant {want:.5}, the other {far:.5}");
        // measured: the textured means equal their constants' to 5 digits;
        // the plastic's constants differ by 3.5 %, the conductor's by 80 %
        assert!((got - want).abs() < 0.001 * want, "{side}: {got} vs {want}");
        assert!(
            (far - want).abs() > 0.02 * want,
            "{side}: the constants differ: {far} vs {want}"
        );
    }
}

#[test]
fn a_textured_plastic_roughness_renders_between_its_constants() {
    // a plastic whose roughness texture is 0.1 on the left half and 0.4 on
    // the right: each half renders as its constant does (the coat table
    // interpolates between levels; the texels away from the seam are exact
    // level values)
    let half = png(
        4,
        1,
        |x, _| {
            if x < 2 { [26, 26, 26] } else { [102, 102, 102] }
        },
    );
    let files = [("q.obj", QUAD.as_bytes().to_vec()), ("h.png", half)];
    let m = |alpha: &str| {
        format!(r#"{{ type = "plastic", diffuse = [0.6, 0.3, 0.2], alpha = {alpha} }}"#)
    };
    let textured = load(&quad_scene(&m(r#"{ texture = "h.png" }"#)), &files);
    let smooth = load(&quad_scene(&m("0.10196078")), &files);
    let rough = load(&quad_scene(&m("0.4")), &files);
    assert_halves_match(&textured, &smooth, &rough);
    let plan = Plan::new(&textured, &IntegratorSettings::default());
    assert!(plan.on().contains(&"texture"));
}

#[test]
fn bad_texture_keys_and_files_are_one_line_errors_with_the_line() {
    let files = [("q.obj", QUAD.as_bytes().to_vec()), ("c.png", grey(51))];
    let cases = [
        (
            r#"{ type = "mirror", reflectance = { texture = "c.png", gamma = 2.2 } }"#,
            "gamma",
        ),
        (
            r#"{ type = "mirror", reflectance = { raw = true } }"#,
            "texture",
        ),
        (
            r#"{ type = "mirror", reflectance = { texture = "missing.png" } }"#,
            "missing.png",
        ),
        (
            r#"{ type = "conductor", alpha = [0.1, 0.2, 0.3] }"#,
            "alpha",
        ),
        (
            r#"{ texture = "c.png", diffuse = { texture = "c.png" } }"#,
            "exclude each other",
        ),
        (
            r#"{ normal_map = "c.png", bump_map = "c.png" }"#,
            "exclude each other",
        ),
        (r#"{ bump_scale = 2.0 }"#, "bump_scale"),
        (r#"{ normal_map = "nope.png" }"#, "nope.png"),
        (r#"{ emission = { texture = "q.obj" } }"#, "q.obj"),
    ];
    for (material, what) in cases {
        let e = load_error(&quad_scene(material), &files);
        assert!(
            (e.contains("s.toml:8:") || e.contains("s.toml:10:")) && e.contains(what),
            "{material}: {e}"
        );
    }
}

#[test]
fn an_emission_texture_is_seen_and_sampled_at_the_uv() {
    // left texel black, right texel white (raw): the camera sees the right
    // half of the quad bright and the left dark; a sphere in front of the
    // quad is lit by it through light samples (the power uses the mean 0.5)
    let half = png(
        2,
        1,
        |x, _| if x == 0 { [0, 0, 0] } else { [255, 255, 255] },
    );
    let files = [("q.obj", QUAD.as_bytes().to_vec()), ("h.png", half)];
    let scene = load(
        &quad_scene(r#"{ diffuse = 0.0, emission = { texture = "h.png", raw = true } }"#),
        &files,
    );
    assert_eq!(
        scene.materials[0].emission,
        embertrace::math::Vec3::splat(0.5)
    );
    for backend in Backend::available() {
        let out = render_with(&scene, backend, None, 64);
        let rgb = out.film.to_rgb_f32();
        // every pixel sees the emission at its u, black diffuse adding
        // nothing: the wrapped bilinear texture is the triangle wave
        // 1 - 2 d(u, 0.75) (d the distance on the circle), linear across each
        // pixel, whose box average is its value at the pixel's centre. The
        // quad's u = (X + 1) / 2 and the screen's half-width at the quad is
        // 3 tan 15 degrees. Band: a pixel spans 0.0502 in u, so a sample's
        // value has sd 2 x 0.0502 / sqrt(12) = 0.029, 0.0036 over 64
        // samples: 5 sd is 0.018
        let half = 3.0 * 15f64.to_radians().tan();
        for y in 0..16 {
            for x in 0..16 {
                let screen = (2.0 * (x as f64 + 0.5) / 16.0 - 1.0) * half;
                let u = (screen + 1.0) / 2.0;
                let d = (u - 0.75).abs().min(1.0 - (u - 0.75).abs());
                let expect = 1.0 - 2.0 * d;
                let got = f64::from(rgb[3 * (16 * y + x)]);
                assert!(
                    (got - expect).abs() < 0.018,
                    "{backend}: pixel ({x}, {y}) at u {u:.3}: {got} vs {expect}"
                );
            }
        }
        let general = render_with(&scene, backend, Some(Kernel::GENERAL), 64);
        assert_eq!(bits(&out), bits(&general));
    }
}

/// The quad, lit only by a directional light travelling along `dir`,
/// direct lighting only: every pixel is `rho / pi E cos`, with the cosine
/// taken against the shading normal.
fn lit_quad(material: &str, dir: [f32; 3]) -> String {
    format!(
        r#"
[camera]
origin = [0.0, 0.0, 3.0]
target = [0.0, 0.0, 0.0]
fov_y = 30.0
[render]
max_depth = 1
[[mesh]]
file = "q.obj"
material = {material}
[[light]]
type = "directional"
direction = [{}, {}, {}]
irradiance = 2.0
"#,
        dir[0], dir[1], dir[2]
    )
}

fn image_sum(out: &RenderOutput) -> f64 {
    out.film.to_rgb_f32().iter().map(|&v| v as f64).sum()
}

/// The normal a raw 8-bit normal-map texel encodes (Mitsuba 3's
/// `normalmap`: `2 c - 1`, normalised), in f64.
fn decoded(c: [u8; 3]) -> [f64; 3] {
    let v = c.map(|b| 2.0 * b as f64 / 255.0 - 1.0);
    let l = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    v.map(|x| x / l)
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// `image(mapped) / image(plain)` against `cos(n', l) / cos(n, l)`, on every
/// backend; returns whether the two images had the same bits.
fn check_ratio(mapped: &str, files: &[(&str, Vec<u8>)], n_mapped: [f64; 3], dir: [f32; 3]) -> bool {
    let plain = load(&lit_quad("{ diffuse = 0.5 }", dir), files);
    let scene = load(&lit_quad(mapped, dir), files);
    let l = {
        let d = dir.map(|x| -x as f64);
        let n = dot(d, d).sqrt();
        d.map(|x| x / n)
    };
    let predicted = dot(n_mapped, l) / l[2];
    let mut same = true;
    for backend in Backend::available() {
        let a = render_with(&plain, backend, None, 2);
        let b = render_with(&scene, backend, None, 2);
        let ratio = image_sum(&b) / image_sum(&a);
        assert!(
            (ratio - predicted).abs() < 2e-5 * predicted,
            "{mapped} on {backend}: ratio {ratio}, predicted {predicted}"
        );
        same &= bits(&a) == bits(&b);
        let general = render_with(&scene, backend, Some(Kernel::GENERAL), 2);
        assert_eq!(bits(&b), bits(&general), "{mapped} on {backend}: general");
    }
    same
}

#[test]
fn a_flat_normal_map_tilts_by_its_quantisation_only() {
    // (128, 128, 255) is not (0, 0, 1): 2 * 128 / 255 - 1 = 1/255, a tilt of
    // atan(sqrt(2) / 255) = 0.32 degrees towards +s +t. So the image is not
    // the unmapped one's bits; it is what that tilt predicts (to 2e-5).
    let files = [
        ("q.obj", QUAD.as_bytes().to_vec()),
        ("n.png", png(2, 2, |_, _| [128, 128, 255])),
    ];
    let dir = [-0.3, -0.2, -1.0];
    let same = check_ratio(
        r#"{ diffuse = 0.5, normal_map = "n.png" }"#,
        &files,
        decoded([128, 128, 255]),
        dir,
    );
    assert!(!same, "the 1/255 tilt shows");
}

#[test]
fn a_tilted_normal_map_shades_as_the_cosine_predicts() {
    // s = +x (dp/du of the quad), t = n x s = +y, n = +z
    for texel in [[200u8, 128, 220], [90, 170, 230], [128, 40, 200]] {
        let files = [
            ("q.obj", QUAD.as_bytes().to_vec()),
            ("n.png", png(2, 2, |_, _| texel)),
        ];
        for dir in [[-0.3f32, -0.2, -1.0], [0.5, 0.1, -1.0]] {
            check_ratio(
                r#"{ diffuse = 0.5, normal_map = "n.png" }"#,
                &files,
                decoded(texel),
                dir,
            );
        }
    }
}

#[test]
fn a_zero_bump_map_changes_no_bit() {
    let files = [("q.obj", QUAD.as_bytes().to_vec()), ("b.png", grey(77))];
    let same = check_ratio(
        r#"{ diffuse = 0.5, bump_map = "b.png", bump_scale = 3.0 }"#,
        &files,
        [0.0, 0.0, 1.0],
        [-0.3, -0.2, -1.0],
    );
    assert!(same, "a constant height has no slope: the same bits");
}

#[test]
fn a_linear_bump_ramp_tilts_the_normal_by_the_predicted_angle() {
    // heights 20 x / 255 over 8 texels: dh/du = 8 * 20 / 255 between texel
    // centres (the camera sees u in [0.1, 0.9], inside them, so no wrap);
    // with dp/du = (2, 0, 0), dp/dv = (0, 2, 0) and scale k the normal is
    // (-2 g, 0, 4) normalised, g = k dh/du: a tilt of atan(g / 2)
    let ramp = png(8, 1, |x, _| [(20 * x) as u8; 3]);
    let files = [("q.obj", QUAD.as_bytes().to_vec()), ("b.png", ramp)];
    for k in [0.5f64, 2.0] {
        let g = k * 8.0 * 20.0 / 255.0;
        let l = (4.0 * g * g + 16.0f64).sqrt();
        let n = [-2.0 * g / l, 0.0, 4.0 / l];
        for dir in [[-0.3f32, -0.2, -1.0], [0.4, 0.0, -1.0]] {
            check_ratio(
                &format!(r#"{{ diffuse = 0.5, bump_map = "b.png", bump_scale = {k} }}"#),
                &files,
                n,
                dir,
            );
        }
    }
}

#[test]
fn normal_maps_let_no_light_through_the_surface_and_turn_shapes_on() {
    // a map leaning far over (towards -x), a light from behind the quad
    // whose direction the leaning normal faces: still exactly black
    let files = [
        ("q.obj", QUAD.as_bytes().to_vec()),
        ("n.png", png(2, 2, |_, _| [10, 128, 140])),
    ];
    let scene = load(
        &lit_quad(
            r#"{ diffuse = 0.9, normal_map = "n.png" }"#,
            [-1.0, 0.0, 0.05],
        ),
        &files,
    );
    let plan = Plan::new(&scene, &IntegratorSettings::default());
    assert!(plan.kernel.shapes && plan.on().contains(&"normal_map"));
    for backend in Backend::available() {
        let out = render_with(&scene, backend, None, 4);
        assert!(
            out.film.to_rgb_f32().iter().all(|v| *v == 0.0),
            "{backend}: leak"
        );
    }
}

#[test]
fn maps_on_spheres_smooth_meshes_and_every_material_keep_general_bit_identical() {
    let bumps = png(8, 8, |x, y| [((x * 37 + y * 11) % 256) as u8; 3]);
    let normals = png(4, 4, |x, y| [100 + 20 * x as u8, 90 + 25 * y as u8, 230]);
    let smooth = "v -1 -1 0\nv 1 -1 0\nv 1 1 0\nv -1 1 0\n\
vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n\
vn -0.3 -0.3 1\nvn 0.3 -0.3 1\nvn 0.3 0.3 1\nvn -0.3 0.3 1\n\
f 1/1/1 2/2/2 3/3/3\nf 1/1/1 3/3/3 4/4/4\n";
    let files = [
        ("q.obj", smooth.as_bytes().to_vec()),
        ("b.png", bumps),
        ("n.png", normals),
    ];
    for material in [
        r#"{ diffuse = 0.7, normal_map = "n.png" }"#,
        r#"{ diffuse = 0.7, bump_map = "b.png", bump_scale = 0.3 }"#,
        r#"{ type = "glass", normal_map = "n.png" }"#,
        r#"{ type = "conductor", alpha = 0.2, bump_map = "b.png" }"#,
        r#"{ type = "plastic", alpha = 0.1, normal_map = "n.png" }"#,
    ] {
        let body = quad_scene(material).replace(
            "material = { emission = 2.0 }",
            &format!("material = {material}"),
        );
        let scene = load(&body, &files);
        let plan = Plan::new(&scene, &IntegratorSettings::default());
        assert!(plan.kernel.shapes, "{material}");
        for backend in Backend::available() {
            let a = render_with(&scene, backend, None, 2);
            let b = render_with(&scene, backend, Some(Kernel::GENERAL), 2);
            assert_eq!(bits(&a), bits(&b), "{material} on {backend}");
            assert_eq!(a.nonfinite.count, 0, "{material} on {backend}");
        }
    }
}

#[test]
fn convert_writes_every_textured_parameter_and_map_back() {
    let ramp = png(8, 4, |x, y| [(x * 30) as u8, (y * 60) as u8, 90]);
    let normals = png(4, 4, |x, y| [100 + 20 * x as u8, 90 + 25 * y as u8, 230]);
    let files = [
        ("q.obj", QUAD.as_bytes().to_vec()),
        ("r.png", ramp),
        ("n.png", normals),
    ];
    for material in [
        r#"{ type = "glass", reflectance = { texture = "r.png" }, transmittance = { texture = "r.png", raw = true }, normal_map = "n.png" }"#,
        r#"{ type = "conductor", alpha = { texture = "r.png" }, bump_map = "r.png", bump_scale = 0.2 }"#,
        r#"{ type = "phong", diffuse = { texture = "r.png" }, specular = { texture = "n.png" }, shininess = 7.0 }"#,
        r#"{ type = "mirror", reflectance = { texture = "n.png", raw = true }, emission = { texture = "r.png" } }"#,
    ] {
        let (dir, path) = folder(&quad_scene(material), &files);
        let scene = Scene::load(&path).unwrap();
        let out = dir.path().join("converted.toml");
        let written = embertrace::commands::convert::convert(&scene, &out).unwrap();
        assert_eq!(written.files.last(), Some(&out));
        let again = Scene::load(&out).unwrap();
        let m = |s: &Scene| s.materials[s.tri_material[0] as usize].clone();
        let (a, b) = (m(&scene), m(&again));
        assert_eq!(a.bsdf, b.bsdf, "{material}");
        assert_eq!(a.texture, b.texture, "{material}");
        assert_eq!(a.maps, b.maps, "{material}");
        assert_eq!(a.emission, b.emission, "{material}");
        // the same to rounding: a bump map's dp/du and dp/dv are recomputed
        // from the corners as written, which may round differently
        let backend = Backend::Bvh;
        let x = render_with(&scene, backend, None, 2).film.to_rgb_f32();
        let y = render_with(&again, backend, None, 2).film.to_rgb_f32();
        for (p, q) in x.iter().zip(&y) {
            assert!(
                (p - q).abs() <= 1e-5 * p.abs().max(1.0),
                "{material}: {p} {q}"
            );
        }
    }
}

/// `render --albedo --normal` (issue item 7) through the binary: the
/// auxiliary images are EXR, the same bits for 1 and 3 threads; a diffuse
/// quad seen head-on has albedo 0.5 and normal +z; an output onto an input
/// (the normal map) or onto another output is refused with one line.
#[test]
fn denoiser_outputs_are_deterministic_and_refuse_collisions() {
    let files = [
        ("q.obj", QUAD.as_bytes().to_vec()),
        ("n.png", png(2, 2, |_, _| [128, 128, 255])),
    ];
    let (dir, path) = folder(
        &lit_quad(
            r#"{ diffuse = 0.5, normal_map = "n.png" }"#,
            [0.0, 0.0, -1.0],
        ),
        &files,
    );
    let bin = env!("CARGO_BIN_EXE_embertrace");
    let run = |threads: &str, albedo: &str, normal: &str| {
        std::process::Command::new(bin)
            .args([
                "render",
                path.to_str().unwrap(),
                "-r",
                "8",
                "8",
                "-s",
                "3",
                "-q",
            ])
            .args(["-t", threads, "-o"])
            .arg(dir.path().join("img.exr"))
            .arg("--albedo")
            .arg(dir.path().join(albedo))
            .arg("--normal")
            .arg(dir.path().join(normal))
            .output()
            .unwrap()
    };
    let out = run("1", "a1.exr", "n1.exr");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(run("3", "a3.exr", "n3.exr").status.success());
    let read = |f: &str| embertrace::image::read_exr(&dir.path().join(f)).unwrap();
    assert_eq!(read("a1.exr"), read("a3.exr"));
    assert_eq!(read("n1.exr"), read("n3.exr"));
    let (_, _, albedo) = read("a1.exr");
    assert!(albedo.iter().all(|&v| v == 0.5), "{albedo:?}");
    let (_, _, normal) = read("n1.exr");
    let n = decoded([128, 128, 255]);
    for px in normal.chunks(3) {
        for c in 0..3 {
            assert!((px[c] as f64 - n[c]).abs() < 1e-6, "{px:?} {n:?}");
        }
    }
    for (albedo, normal, what) in [
        ("n.png", "n2.exr", "n.png"),
        ("x.exr", "x.exr", "same file"),
        ("img.exr", "n4.exr", "same file"),
    ] {
        let out = run("1", albedo, normal);
        let e = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success() && e.contains(what), "{e}");
        assert_eq!(e.trim_end().lines().count(), 1, "{e}");
    }
}
