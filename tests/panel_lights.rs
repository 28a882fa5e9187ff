//! Panel lights (`src/light/panel.rs`, the CS184 course's area light): an
//! emitting rectangle that lights by light sampling alone and is no
//! surface.
//!
//! - Under a 2 x 2 panel of radiance 1, one unit above a floor of albedo
//!   0.5, the floor's radiance below the centre is `rho / pi E`, with `E`
//!   the rectangle's irradiance in closed form: 0.27706. Every direct
//!   strategy gives it (no BSDF sample can find the panel, so each takes
//!   light samples of it), and so does the light BVH; bands are 5 sigma of
//!   the render's own variance of its mean.
//! - No ray sees it: a camera looking up through it sees black, bit for bit.
//! - It casts no shadow: a point light above it lights the floor as if it
//!   were not there.
//! - `embertrace convert` writes it as a TOML `panel` light that renders
//!   the same bits.

mod common;

use common::one_pixel;
use embertrace::scene::Scene;
use embertrace::settings::{DirectStrategy, IntegratorSettings, LightSampler};
use std::path::Path;

/// A floor of albedo 0.5 (the 8 x 8 square at y = 0, facing up), a 2 x 2 panel at
/// y = 1 facing down, and `extra` TOML.
fn scene(dir: &Path, camera: &str, extra: &str) -> Scene {
    let toml = format!(
        r#"
{camera}
[film]
resolution = [1, 1]

[[mesh]]
file = "floor.obj"
material = {{ diffuse = 0.5 }}

[[light]]
type = "panel"
center = [0.0, 1.0, 0.0]
dim_x = [2.0, 0.0, 0.0]
dim_y = [0.0, 0.0, 2.0]
facing = [0.0, -1.0, 0.0]
radiance = 1.0
{extra}
"#
    );
    std::fs::write(
        dir.join("floor.obj"),
        "v -4 0 -4\nv -4 0 4\nv 4 0 4\nv 4 0 -4\nf 1 2 3\nf 1 3 4\n",
    )
    .unwrap();
    let path = dir.join("panel.toml");
    std::fs::write(&path, toml).unwrap();
    Scene::load(&path).unwrap_or_else(|e| panic!("{e}"))
}

/// Looking straight down at the floor's centre from y = 0.5, through the
/// panel's plane's underside, with a field of view of 0.2 degrees.
const DOWN: &str = r#"
[camera]
origin = [0.0, 0.5, 0.0]
target = [0.0, 0.0, 0.0]
up = [0.0, 0.0, -1.0]
fov_y = 0.2
"#;

/// The single pixel's mean and the variance of that mean.
fn pixel(scene: &Scene, settings: IntegratorSettings, spp: u32, seed: u64) -> (f64, f64) {
    let (m, v) = one_pixel(scene, settings, spp, seed);
    assert_eq!(m.x, m.z, "a grey scene");
    (m.x as f64, v.x as f64)
}

/// `rho / pi` times the irradiance below the centre of a 2a x 2b rectangle
/// at height h, a sum of four corner form factors (the 1/2 of
/// `tests/common::lambert_form_factor`'s closed form, per corner).
fn closed_form(rho: f64, a: f64, b: f64, h: f64) -> f64 {
    let (x, y) = (a / h, b / h);
    let (sx, sy) = ((1.0 + x * x).sqrt(), (1.0 + y * y).sqrt());
    let corner = 0.5 * (x / sx * (y / sx).atan() + y / sy * (x / sy).atan());
    rho / std::f64::consts::PI * 4.0 * corner
}

#[test]
fn a_panel_light_lights_a_floor_as_the_closed_form_says() {
    let dir = tempfile::tempdir().unwrap();
    let s = scene(dir.path(), DOWN, "");
    let exact = closed_form(0.5, 1.0, 1.0, 1.0);
    assert!((exact - 0.27706).abs() < 5e-5, "{exact}");
    let cases = [
        ("mis", DirectStrategy::Mis, LightSampler::Power),
        ("light", DirectStrategy::Light, LightSampler::Power),
        ("bsdf", DirectStrategy::Bsdf, LightSampler::Power),
        ("mis, light BVH", DirectStrategy::Mis, LightSampler::Bvh),
    ];
    for (k, (what, direct, light_sampler)) in cases.into_iter().enumerate() {
        let settings = IntegratorSettings {
            max_depth: 1,
            direct,
            light_sampler,
            ..IntegratorSettings::default()
        };
        let (m, v) = pixel(&s, settings, 1 << 16, 60 + k as u64);
        let sigma = v.sqrt();
        assert!(sigma < 0.002 * exact, "{what}: too noisy to test ({sigma})");
        assert!(
            (m - exact).abs() < 5.0 * sigma,
            "{what}: {m} vs {exact} ({:.1} sigma)",
            (m - exact) / sigma
        );
    }
}

#[test]
fn no_ray_sees_a_panel_light() {
    let dir = tempfile::tempdir().unwrap();
    // looking up from the floor through the panel: nothing above it
    let up = r#"
[camera]
origin = [0.0, 0.5, 0.0]
target = [0.0, 2.0, 0.0]
up = [0.0, 0.0, -1.0]
fov_y = 10.0
"#;
    let s = scene(dir.path(), up, "");
    for depth in [1, 8] {
        let settings = IntegratorSettings {
            max_depth: depth,
            ..IntegratorSettings::default()
        };
        let (m, v) = pixel(&s, settings, 256, 7);
        assert_eq!((m, v), (0.0, 0.0), "max_depth {depth}");
    }
}

#[test]
fn a_panel_light_casts_no_shadow() {
    let dir = tempfile::tempdir().unwrap();
    // a point light of 1 W/sr above the panel, and the panel made dark:
    // the floor below gets 1 / 2^2 from the point light, times rho / pi
    let extra = r#"
[[light]]
type = "point"
position = [0.0, 2.0, 0.0]
intensity = 1.0
"#;
    let s0 = scene(dir.path(), DOWN, extra);
    let mut s = s0.clone();
    s.panel_lights[0].radiance = embertrace::math::Vec3::ZERO;
    let settings = IntegratorSettings {
        max_depth: 1,
        ..IntegratorSettings::default()
    };
    let (m, _) = pixel(&s, settings, 64, 3);
    let exact = 0.5 / std::f64::consts::PI * 0.25;
    // the pixel spans a 0.0017-wide spot: the falloff varies by 1e-6 in it
    assert!((m - exact).abs() < 1e-5 * exact, "{m} vs {exact}");
}

#[test]
fn a_panel_light_converts_to_a_toml_panel_light_with_the_same_bits() {
    let dir = tempfile::tempdir().unwrap();
    let s = scene(dir.path(), DOWN, "");
    let out = dir.path().join("out.toml");
    embertrace::commands::convert::convert(&s, &out).unwrap();
    let text = std::fs::read_to_string(&out).unwrap();
    assert!(text.contains("type = \"panel\""), "{text}");
    let back = Scene::load(&out).unwrap();
    assert_eq!(back.panel_lights, s.panel_lights);
    let settings = IntegratorSettings {
        max_depth: 3,
        ..IntegratorSettings::default()
    };
    assert_eq!(pixel(&s, settings, 64, 9), pixel(&back, settings, 64, 9));
}

#[test]
fn toml_panel_lights_need_their_keys_and_an_area() {
    let dir = tempfile::tempdir().unwrap();
    let write = |light: &str| {
        let path = dir.path().join("bad.toml");
        std::fs::write(&path, format!("[[light]]\n{light}\n")).unwrap();
        Scene::load(&path).map(|_| ()).unwrap_err().to_string()
    };
    let e = write("type = \"panel\"\ncenter = [0, 1, 0]\nradiance = 1.0");
    assert!(
        e.contains("needs `center`, `dim_x`, `dim_y` and `facing`") && e.contains(":1"),
        "{e}"
    );
    let e = write(
        "type = \"panel\"\ncenter = [0, 1, 0]\ndim_x = [1, 0, 0]\ndim_y = [2, 0, 0]\nfacing = [0, -1, 0]\nradiance = 1.0",
    );
    assert!(e.contains("must span an area"), "{e}");
    let e = write("type = \"panel\"\nposition = [0, 1, 0]");
    assert!(
        e.contains("`position` is not a key of a panel light"),
        "{e}"
    );
}
