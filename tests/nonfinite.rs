//! Non-finite accounting (hard case 25, issue 4 item 4): NaN, infinite and
//! negative samples are counted by kind, their pixels recorded in scan
//! order, and they are left out of the image, the same for any thread count
//! and tiling; `--clamp` reports exactly the energy it removed; the CLI
//! writes the map of bad samples and the report's fields.

use embertrace::camera::{Camera, CameraDesc};
use embertrace::film::Film;
use embertrace::integrator::RayCounts;
use embertrace::math::{Ray, Vec3};
use embertrace::render::{Radiance, RenderOutput, RenderSettings, render};
use embertrace::sampler::{Sampler, SamplerKind};

/// 1.0 everywhere except: NaN at sample 0 of pixel (3, 1), +inf at sample 1
/// of (0, 2), -0.5 in every sample of (5, 5), and 4.0 (red only) at (7, 0).
struct Injected;

impl Radiance for Injected {
    fn radiance(&self, p: [u32; 2], s: u32, _: &Ray, _: &mut Sampler, _: &mut RayCounts) -> Vec3 {
        match (p, s) {
            ([3, 1], 0) => Vec3::new(1.0, f32::NAN, 1.0),
            ([0, 2], 1) => Vec3::new(f32::INFINITY, 1.0, 1.0),
            ([5, 5], _) => Vec3::new(1.0, -0.5, 1.0),
            ([7, 0], _) => Vec3::new(4.0, 0.0, 0.0),
            _ => Vec3::ONE,
        }
    }
}

fn run(threads: usize, tile: u32, clamp: Option<f32>) -> RenderOutput {
    let desc = CameraDesc {
        origin: Vec3::new(0.0, 0.0, 1.0),
        target: Vec3::ZERO,
        up: Vec3::Y,
        fov_y: 40.0,
    };
    let camera = Camera::new(&desc, 8, 6);
    let rs = RenderSettings {
        total_spp: None,
        resolution: [8, 6],
        spp: 4,
        first_sample: 0,
        seed: 1,
        threads,
        tile_size: tile,
        sampler: SamplerKind::Independent,
        clamp,
    };
    render(&Injected, &camera, &rs, &|| {}).unwrap()
}

fn bits(f: &Film) -> Vec<u32> {
    f.to_rgb_f32().iter().map(|x| x.to_bits()).collect()
}

#[test]
fn bad_samples_are_counted_located_and_left_out() {
    let out = run(1, 16, None);
    let bad = &out.nonfinite;
    assert_eq!((bad.count, bad.nan, bad.inf, bad.negative), (6, 1, 1, 4));
    assert_eq!(bad.pixels, [[3, 1], [0, 2], [5, 5]], "scan order");
    assert_eq!(bad.per_pixel[8 + 3], 1);
    assert_eq!(bad.per_pixel[5 * 8 + 5], 4);
    // left out: the pixels average the samples they kept
    assert_eq!((out.film.count(3, 1), out.film.mean(3, 1)), (3, Vec3::ONE));
    assert_eq!((out.film.count(5, 5), out.film.mean(5, 5)), (0, Vec3::ZERO));
    assert_eq!(out.film.total_samples(), 8 * 6 * 4 - 6);
    // the same bits and report for other thread counts and tilings
    for (t, tile) in [(3, 16), (2, 3), (4, 1)] {
        let o = run(t, tile, None);
        assert_eq!(&o.nonfinite, bad, "{t} threads, tile {tile}");
        assert_eq!(bits(&o.film), bits(&out.film), "{t} threads, tile {tile}");
    }
}

#[test]
fn clamp_reports_the_energy_it_removed() {
    let out = run(2, 4, Some(2.0));
    // pixel (7, 0): 4 samples of red 4.0 scaled to 2.0
    assert_eq!(out.clamp.clamped, 4);
    assert_eq!(out.clamp.removed, [8.0, 0.0, 0.0]);
    assert_eq!(out.film.mean(7, 0), Vec3::new(2.0, 0.0, 0.0));
    // kept: every accepted sample after clamping; 1.0 in 3 channels for the
    // ordinary ones (all but the 6 rejected and the 4 clamped), 2.0 red for
    // each clamped one
    let ordinary = (8 * 6 * 4 - 6 - 4) as f64;
    let kept = 3.0 * ordinary + 2.0 * 4.0;
    let total: f64 = out.clamp.kept.iter().sum();
    assert_eq!(total, kept);
    assert!((out.clamp.removed_fraction() - 8.0 / (8.0 + kept)).abs() < 1e-15);
    // without a clamp nothing is removed and the bright pixel keeps its value
    let free = run(2, 4, None);
    assert_eq!((free.clamp.clamped, free.clamp.removed), (0, [0.0; 3]));
    assert_eq!(free.film.mean(7, 0), Vec3::new(4.0, 0.0, 0.0));
}

#[test]
fn cli_reports_kinds_and_writes_the_bad_sample_map() {
    let dir = tempfile::tempdir().unwrap();
    let scene = concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/cornell-box.toml");
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_embertrace"))
        .current_dir(dir.path())
        .args([
            "render", scene, "-r", "16", "16", "-s", "4", "--aov", "bad.exr", "--clamp", "1",
            "--strict", "--report", "r.json", "-o", "o.png", "-q",
        ])
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let (w, h, px) = embertrace::image::read_exr(&dir.path().join("bad.exr")).unwrap();
    assert_eq!((w, h), (16, 16));
    assert!(
        px.iter().all(|&c| c == 0.0),
        "the box renders no bad sample"
    );
    let r: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join("r.json")).unwrap()).unwrap();
    for k in ["nan", "inf", "negative"] {
        assert_eq!(r["nonfinite"][k], 0, "{k}");
    }
    // the light (radiance above 1) is clamped, and the report says how much
    let c = &r["clamp"];
    assert_eq!(c["max"], 1.0);
    assert!(c["clamped_samples"].as_u64().unwrap() > 0);
    let f = c["removed_fraction"].as_f64().unwrap();
    assert!(f > 0.0 && f < 1.0, "{c}");
}
