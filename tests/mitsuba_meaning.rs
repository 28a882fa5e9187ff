//! What a Mitsuba 3 file leaves unsaid, read as Mitsuba reads it, by
//! closed forms that need no reference (the block-by-block comparison
//! against Mitsuba's own render is `tests/data/mitsuba/meaning.xml` in
//! `tests/mitsuba.rs`):
//!
//! - an emitting shape with no `<bsdf>` reflects nothing (Mitsuba's `Shape`
//!   gives it a black diffuse): a 2 x 2 down-facing emitter of radiance 1
//!   one unit above a 2 x 2 floor of albedo 0.5 lights the floor's centre to
//!   `rho / pi E = 0.27706` whatever the depth, since the floor cannot see
//!   itself and the emitter sends nothing back;
//! - a one-sided BSDF is black from behind: the top of a lamp hung under
//!   another lamp is exactly 0, and 0.27706 again with `twosided`;
//! - `-q` hides notes and progress, never a warning.

mod common;

use common::one_pixel;
use embertrace::scene::Scene;
use embertrace::settings::IntegratorSettings;
use std::path::Path;

/// A scene of `shapes` seen by a camera at `eye` looking at `at` with a
/// 0.2 degree field of view (one pixel).
fn xml(eye: &str, at: &str, shapes: &str) -> String {
    format!(
        r#"<scene version="3.0.0">
    <integrator type="path"><integer name="max_depth" value="25"/></integrator>
    <sensor type="perspective">
        <float name="fov" value="0.2"/>
        <transform name="to_world"><lookat origin="{eye}" target="{at}" up="0, 0, -1"/></transform>
        <film type="hdrfilm"><integer name="width" value="1"/><integer name="height" value="1"/></film>
    </sensor>
{shapes}
</scene>"#
    )
}

/// A 2 x 2 rectangle at height `y` facing down, emitting 1, with `bsdf`.
fn lamp(y: f32, bsdf: &str) -> String {
    format!(
        r#"    <shape type="rectangle">
        <transform name="to_world"><rotate x="1" angle="90"/><translate y="{y}"/></transform>
        <emitter type="area"><rgb name="radiance" value="1"/></emitter>
        {bsdf}
    </shape>"#
    )
}

const FLOOR: &str = r#"    <shape type="rectangle">
        <transform name="to_world"><rotate x="1" angle="-90"/></transform>
        <bsdf type="diffuse"><rgb name="reflectance" value="0.5"/></bsdf>
    </shape>"#;

fn load(dir: &Path, text: &str) -> Scene {
    let path = dir.join("s.xml");
    std::fs::write(&path, text).unwrap();
    Scene::load(&path).unwrap_or_else(|e| panic!("{e}"))
}

/// The single pixel's mean and the variance of that mean, at the file's
/// depth.
fn pixel(scene: &Scene, spp: u32, seed: u64) -> (f64, f64) {
    let settings = IntegratorSettings {
        max_depth: scene.render.max_depth,
        ..IntegratorSettings::default()
    };
    let (m, v) = one_pixel(scene, settings, spp, seed);
    (m.y as f64, v.y as f64)
}

/// `rho / pi` times the irradiance below the centre of a 2 x 2 emitter of
/// radiance 1 at height 1: four corner form factors of a unit square.
fn floor_centre() -> f64 {
    let s = 2f64.sqrt();
    let corner = 0.5 * 2.0 * (1.0 / s) * (1.0 / s).atan();
    0.5 / std::f64::consts::PI * 4.0 * corner
}

#[test]
fn an_emitter_without_a_bsdf_reflects_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let s = load(
        dir.path(),
        &xml(
            "0, 0.5, 0",
            "0, 0, 0",
            &format!("{}\n{FLOOR}", lamp(1.0, "")),
        ),
    );
    assert_eq!(s.render.max_depth, 24);
    let exact = floor_centre();
    assert!((exact - 0.27706).abs() < 5e-6, "{exact}");
    let (m, v) = pixel(&s, 1 << 16, 11);
    let sigma = v.sqrt();
    assert!(sigma < 0.002 * exact, "too noisy to test: {sigma}");
    // a grey (0.5) emitter would add the light the floor sends back up:
    // about 5 % here, far outside the band
    assert!(
        (m - exact).abs() < 5.0 * sigma,
        "{m} vs {exact} ({:.1} sigma)",
        (m - exact) / sigma
    );
}

#[test]
fn a_one_sided_bsdf_is_black_from_behind() {
    let dir = tempfile::tempdir().unwrap();
    // the lower lamp's top, its back, faces the upper lamp's light
    let diffuse = r#"<bsdf type="diffuse"><rgb name="reflectance" value="0.5"/></bsdf>"#;
    let one = load(
        dir.path(),
        &xml(
            "0, 0.75, 0",
            "0, 0, 0",
            &format!("{}\n{}", lamp(1.5, ""), lamp(0.5, diffuse)),
        ),
    );
    assert_eq!(
        pixel(&one, 256, 3),
        (0.0, 0.0),
        "one-sided diffuse from behind"
    );
    // the same lamp wrapped in twosided reflects the upper lamp's light
    let two = load(
        dir.path(),
        &xml(
            "0, 0.75, 0",
            "0, 0, 0",
            &format!(
                "{}\n{}",
                lamp(1.5, ""),
                lamp(0.5, &format!(r#"<bsdf type="twosided">{diffuse}</bsdf>"#))
            ),
        ),
    );
    let (m, v) = pixel(&two, 1 << 16, 4);
    let exact = floor_centre();
    assert!(
        (m - exact).abs() < 5.0 * v.sqrt(),
        "{m} vs {exact} ({:.1} sigma)",
        (m - exact) / v.sqrt()
    );
}

#[test]
fn quiet_renders_still_print_warnings() {
    let dir = tempfile::tempdir().unwrap();
    // a near clip that would hide the floor: not honoured, so warned about
    let text = xml("0, 0.5, 0", "0, 0, 0", FLOOR).replace(
        r#"<float name="fov" value="0.2"/>"#,
        r#"<float name="fov" value="0.2"/><float name="near_clip" value="1"/>"#,
    );
    std::fs::write(dir.path().join("s.xml"), text).unwrap();
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_embertrace"))
        .current_dir(dir.path())
        .args(["render", "s.xml", "-q", "-s", "1", "-o", "x.png"])
        .output()
        .unwrap();
    assert!(out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("warning:") && err.contains("s.xml:") && err.contains("`near_clip` 1"),
        "{err}"
    );
    assert!(!err.contains("note:"), "-q hides notes: {err}");
}
