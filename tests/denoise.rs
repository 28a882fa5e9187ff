//! `render --denoise`, `--noisy` and `--aovs`. The denoiser's own tests run
//! in a build with `--features denoise` (CI builds one with OIDN from
//! `scripts/oidn.sh`); the rest run in every build.

use embertrace::image::read_exr;
use std::path::Path;

const SCENE: &str = "scenes/cornell-box.toml";

mod common;
use common::{run_here as embertrace, stderr_of as stderr};

/// A refused command line: exit 1, one line, and `out` not written.
fn refused(args: &[&str], out: &Path, needle: &str) {
    let o = embertrace(args);
    assert_eq!(o.status.code(), Some(1), "{args:?}: {}", stderr(&o));
    let e = stderr(&o);
    assert_eq!(e.trim_end().lines().count(), 1, "{e}");
    assert!(e.contains(needle), "{needle:?} missing from {e}");
    assert!(!out.exists(), "{} written", out.display());
}

#[test]
fn noisy_without_denoise_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("a.exr");
    let noisy = dir.path().join("n.exr");
    let (o, n) = (out.to_str().unwrap(), noisy.to_str().unwrap());
    refused(
        &[
            "render", SCENE, "-r", "8", "8", "-s", "1", "-o", o, "--noisy", n,
        ],
        &out,
        "--noisy",
    );
}

#[test]
fn denoise_and_aovs_do_not_combine_with_farm_parts() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("part.exr");
    let o = out.to_str().unwrap();
    let aovs = dir.path().join("aovs.exr");
    for extra in [&["--denoise"][..], &["--aovs", aovs.to_str().unwrap()][..]] {
        let args = [
            &[
                "render", SCENE, "-r", "8", "8", "-s", "1", "-o", o, "--shard", "1/2",
            ][..],
            extra,
        ]
        .concat();
        refused(&args, &out, "--shard");
    }
}

#[test]
fn aovs_must_be_exr() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("a.png");
    let aovs = dir.path().join("aovs.png");
    let args = [
        "render",
        SCENE,
        "-r",
        "8",
        "8",
        "-s",
        "1",
        "-o",
        out.to_str().unwrap(),
        "--aovs",
        aovs.to_str().unwrap(),
    ];
    refused(&args, &out, "--aovs");
}

/// The channels of a layered EXR by name, as `f32` planes.
fn channels(path: &Path) -> Vec<(String, Vec<f32>)> {
    use exr::prelude::{ReadChannels, ReadLayers};
    let image = exr::prelude::read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .first_valid_layer()
        .all_attributes()
        .from_file(path)
        .expect("a readable EXR");
    image
        .layer_data
        .channel_data
        .list
        .iter()
        .map(|c| (c.name.to_string(), c.sample_data.values_as_f32().collect()))
        .collect()
}

#[test]
fn aovs_hold_the_image_and_five_layers_named_for_compositors() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("a.exr");
    let aovs = dir.path().join("aovs.exr");
    let o = embertrace(&[
        "render",
        SCENE,
        "-r",
        "24",
        "24",
        "-s",
        "4",
        "-q",
        "-o",
        out.to_str().unwrap(),
        "--aovs",
        aovs.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let ch = channels(&aovs);
    let names: Vec<&str> = ch.iter().map(|(n, _)| n.as_str()).collect();
    assert_eq!(
        names,
        [
            "B",
            "G",
            "R",
            "albedo.B",
            "albedo.G",
            "albedo.R",
            "depth.Z",
            "normal.X",
            "normal.Y",
            "normal.Z",
            "position.X",
            "position.Y",
            "position.Z",
            "variance.B",
            "variance.G",
            "variance.R"
        ]
    );
    let get = |name: &str| &ch.iter().find(|(n, _)| n == name).unwrap().1;
    // the main layer is the image -o got, bit for bit
    let (_, _, image) = read_exr(&out).unwrap();
    for (c, name) in ["R", "G", "B"].iter().enumerate() {
        let plane: Vec<f32> = image.iter().skip(c).step_by(3).copied().collect();
        assert_eq!(get(name), &plane, "{name}");
    }
    let n = 24 * 24;
    for i in 0..n {
        for c in ["albedo.R", "albedo.G", "albedo.B"] {
            assert!((0.0..=1.0).contains(&get(c)[i]), "{c} {}", get(c)[i]);
        }
        let len =
            (get("normal.X")[i].powi(2) + get("normal.Y")[i].powi(2) + get("normal.Z")[i].powi(2))
                .sqrt();
        assert!(len <= 1.0 + 1e-5, "normal length {len}");
        for c in ["variance.R", "variance.G", "variance.B"] {
            assert!(get(c)[i] >= 0.0);
        }
    }
    // inside the closed box every ray hits: depth is the distance from the
    // camera (at [0, 1, 3.9]) to the position, up to the averaging over a
    // pixel's rays, which only edges feel
    let origin = [0.0f32, 1.0, 3.9];
    let agree = (0..n)
        .filter(|&i| {
            let p = [
                get("position.X")[i],
                get("position.Y")[i],
                get("position.Z")[i],
            ];
            let d = (0..3)
                .map(|k| (p[k] - origin[k]).powi(2))
                .sum::<f32>()
                .sqrt();
            let z = get("depth.Z")[i];
            z > 0.0 && (z - d).abs() <= 1e-3 * z
        })
        .count();
    assert!(
        agree * 10 >= n * 9,
        "depth and position agree at {agree} of {n} pixels"
    );
}

#[cfg(not(feature = "denoise"))]
#[test]
fn without_the_feature_denoise_says_how_to_get_it_and_writes_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("a.png");
    let args = [
        "render",
        SCENE,
        "-r",
        "8",
        "8",
        "-s",
        "1",
        "-o",
        out.to_str().unwrap(),
        "--denoise",
    ];
    refused(&args, &out, "--features denoise");
}

/// Root-mean-square error of `path` against the Mitsuba 3 reference of the
/// Cornell box at 128 x 128 (scripts/mitsuba_cornell_reference.py 1024
/// 128), and the ratio of the two images' means.
#[cfg(feature = "denoise")]
fn against_mitsuba(path: &Path) -> (f64, f64) {
    let (_, _, a) = read_exr(path).unwrap();
    let (_, _, r) = read_exr(Path::new("tests/data/cornell-128-mitsuba.exr")).unwrap();
    assert_eq!(a.len(), r.len());
    let mse = a
        .iter()
        .zip(&r)
        .map(|(x, y)| ((x - y) as f64).powi(2))
        .sum::<f64>()
        / a.len() as f64;
    let mean = |v: &[f32]| v.iter().map(|&x| x as f64).sum::<f64>() / v.len() as f64;
    (mse.sqrt(), mean(&a) / mean(&r))
}

#[cfg(feature = "denoise")]
#[test]
fn denoised_16_spp_reaches_the_error_of_256_spp_and_keeps_the_mean() {
    let dir = tempfile::tempdir().unwrap();
    let den = dir.path().join("den.exr");
    let noisy = dir.path().join("noisy.exr");
    let report = dir.path().join("r.json");
    let o = embertrace(&[
        "render",
        SCENE,
        "-r",
        "128",
        "128",
        "-s",
        "16",
        "--seed",
        "1",
        "-q",
        "--denoise",
        "-o",
        den.to_str().unwrap(),
        "--noisy",
        noisy.to_str().unwrap(),
        "--report",
        report.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let (rmse, mean) = against_mitsuba(&den);
    let (rmse_noisy, _) = against_mitsuba(&noisy);
    // Measured (tests/denoise.rs's setting, seeds 1 and 11 to 15): denoised
    // 16 spp 4.69e-3 to 4.81e-3; noisy 256 spp 4.80e-3 to 5.20e-3 (median
    // 5.00e-3), noisy 16 spp 2.2e-2 to 2.7e-2. The bound is that median:
    // the denoised spread is 0.04e-3, so it sits five of them above.
    assert!(rmse <= 5.0e-3, "denoised RMSE {rmse:.3e}");
    assert!(
        rmse < rmse_noisy / 3.0,
        "{rmse:.3e} against the noisy {rmse_noisy:.3e}"
    );
    // measured 0.9963 to 0.9966: the denoiser darkens by a third of a percent
    assert!((mean - 1.0).abs() < 0.01, "mean ratio {mean}");
    let r = std::fs::read_to_string(&report).unwrap();
    assert!(r.contains("\"denoise_seconds\""), "{r}");
    assert!(r.contains("\"auxiliary_seconds\""), "{r}");
}

#[cfg(feature = "denoise")]
#[test]
fn denoising_repeats_bit_for_bit_whatever_the_thread_count() {
    let dir = tempfile::tempdir().unwrap();
    let mut images = Vec::new();
    for (k, threads) in ["1", "2", "2"].iter().enumerate() {
        let out = dir.path().join(format!("d{k}.exr"));
        let o = embertrace(&[
            "render",
            SCENE,
            "-r",
            "48",
            "32",
            "-s",
            "4",
            "-q",
            "--denoise",
            "-t",
            threads,
            "-o",
            out.to_str().unwrap(),
        ]);
        assert!(o.status.success(), "{}", stderr(&o));
        images.push(read_exr(&out).unwrap().2);
    }
    assert!(images[0] == images[1], "-t 1 and -t 2 differ");
    assert!(images[1] == images[2], "two runs differ");
}

#[cfg(not(feature = "denoise"))]
#[test]
fn study_denoise_without_the_feature_says_how_to_get_it() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("study");
    let args = [
        "study",
        SCENE,
        "--out",
        out.to_str().unwrap(),
        "-r",
        "8",
        "8",
        "-s",
        "1",
        "--denoise",
    ];
    refused(&args, &out, "--features denoise");
}

#[cfg(feature = "denoise")]
#[test]
fn study_denoise_adds_denoised_curves_and_the_bias_of_each_image() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("study");
    let o = embertrace(&[
        "study",
        SCENE,
        "--out",
        out.to_str().unwrap(),
        "-r",
        "32",
        "32",
        "--vary",
        "spp=4,16",
        "--reference",
        "tests/data/cornell-32-mitsuba.exr",
        "--denoise",
        "-q",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let csv = std::fs::read_to_string(out.join("study.csv")).unwrap();
    let mut lines = csv.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    for column in [
        "mean_error",
        "block_error",
        "denoised_rmse",
        "denoised_block_error",
    ] {
        assert!(header.contains(&column), "{column} missing from {header:?}");
    }
    let col = |row: &str, name: &str| -> f64 {
        let i = header.iter().position(|h| *h == name).unwrap();
        row.split(',').nth(i).unwrap().parse().unwrap()
    };
    let rows: Vec<&str> = lines.collect();
    assert_eq!(rows.len(), 2);
    for row in &rows {
        // denoising a 4- or 16-spp image brings its RMSE down
        assert!(col(row, "denoised_rmse") < col(row, "rmse"), "{row}");
        assert!(col(row, "denoised_seconds") > col(row, "seconds"), "{row}");
    }
    let md = std::fs::read_to_string(out.join("study.md")).unwrap();
    assert!(md.contains("denoised: seconds"), "{md}");
}

#[test]
fn merge_denoise_needs_the_scene() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("m.exr");
    let args = [
        "merge",
        "a.exr",
        "b.exr",
        "-o",
        out.to_str().unwrap(),
        "--denoise",
    ];
    refused(&args, &out, "--scene");
}

#[cfg(not(feature = "denoise"))]
#[test]
fn merge_denoise_without_the_feature_says_how_to_get_it() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("m.exr");
    let o = out.to_str().unwrap();
    let args = ["merge", "a.exr", "-o", o, "--denoise", "--scene", SCENE];
    refused(&args, &out, "--features denoise");
}

#[cfg(feature = "denoise")]
#[test]
fn merge_denoise_of_shards_is_render_denoise_bit_for_bit() {
    let dir = tempfile::tempdir().unwrap();
    let path = |name: &str| dir.path().join(name).to_str().unwrap().to_string();
    let common = [
        "render", SCENE, "-r", "40", "24", "-s", "8", "--seed", "5", "-q",
    ];
    for k in 1..=2 {
        let shard = format!("{k}/2");
        let out = path(&format!("s{k}.exr"));
        let args = [&common[..], &["--shard", &shard, "-o", &out]].concat();
        let o = embertrace(&args);
        assert!(o.status.success(), "{}", stderr(&o));
    }
    let one = path("one.exr");
    let o = embertrace(&[&common[..], &["--denoise", "-o", &one]].concat());
    assert!(o.status.success(), "{}", stderr(&o));
    let merged = path("merged.exr");
    let report = path("merge.json");
    let (s1, s2) = (path("s1.exr"), path("s2.exr"));
    let o = embertrace(&[
        "merge",
        &s1,
        &s2,
        "-o",
        &merged,
        "--denoise",
        "--scene",
        SCENE,
        "--report",
        &report,
        "-q",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let a = read_exr(Path::new(&one)).unwrap().2;
    let b = read_exr(Path::new(&merged)).unwrap().2;
    assert!(a == b, "merge --denoise differs from render --denoise");
    let r = std::fs::read_to_string(&report).unwrap();
    assert!(r.contains("\"denoise_seconds\""), "{r}");
    // another scene is refused, naming it
    let other = "scenes/materials.toml";
    let o = embertrace(&[
        "merge",
        &s1,
        &s2,
        "-o",
        &path("x.exr"),
        "--denoise",
        "--scene",
        other,
    ]);
    assert_eq!(o.status.code(), Some(1));
    assert!(
        stderr(&o).contains("not the scene the parts were rendered from"),
        "{}",
        stderr(&o)
    );
}
