//! Hostile command lines (issue 21, item 3): each is refused with one line
//! and exit 1 before anything is rendered, without a panic, and leaves every
//! file as it was: no output onto an input or onto another output, the same
//! settings refused by every command, long tokens quoted short, and a light
//! too strong for `f32` power still sampled.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

const TRIANGLE_OBJ: &str = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";

fn run(dir: &Path, args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_embertrace"))
        .current_dir(dir)
        .args(args)
        .output()
        .expect("embertrace runs")
}

/// Every file under `dir`, recursively, with its bytes (through links).
fn snapshot(dir: &Path) -> BTreeMap<PathBuf, Vec<u8>> {
    let mut files = BTreeMap::new();
    let mut todo = vec![dir.to_path_buf()];
    while let Some(d) = todo.pop() {
        for e in std::fs::read_dir(&d).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                todo.push(p);
            } else {
                files.insert(p.clone(), std::fs::read(&p).unwrap_or_default());
            }
        }
    }
    files
}

/// The one error line of a refused command (exit 1, no panic).
fn refused(out: &Output, what: &str) -> String {
    let err = String::from_utf8_lossy(&out.stderr).into_owned();
    assert_eq!(out.status.code(), Some(1), "{what}: {err}");
    assert!(!err.contains("panicked"), "{what}: {err}");
    let lines: Vec<&str> = err.lines().collect();
    assert_eq!(lines.len(), 1, "{what}: expected one line, got {err}");
    lines[0].to_string()
}

/// Settings out of range are refused alike: `-l 0` and `--tile-size 0`
/// (once silently 1) like `-s 0`, and negative numbers reach the check that
/// names them instead of clap's "unexpected argument".
#[test]
fn zero_and_negative_settings_are_one_line_errors() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path();
    std::fs::write(dir.join("m.obj"), TRIANGLE_OBJ).unwrap();
    let before = snapshot(dir);
    for (flags, expect) in [
        (vec!["-l", "0"], "-l 0"),
        (vec!["--tile-size", "0"], "--tile-size 0"),
        (vec!["--tile-size", "4294967295"], "--tile-size 4294967295"),
        (vec!["--time-limit", "-1"], "--time-limit"),
        (vec!["--target-error", "-0.5"], "--target-error"),
        (vec!["--clamp", "-1"], "--clamp"),
        (vec!["--rr", "-0.5"], "--rr -0.5"),
        (vec!["-a", "4", "-0.1"], "-a"),
        (
            vec!["--checkpoint", "c.exr", "--checkpoint-every", "-5"],
            "--checkpoint-every -5",
        ),
        (vec!["-s", "-1"], "-1"),
        (vec!["--no-such-flag"], "--no-such-flag"),
    ] {
        let mut args = vec!["render", "m.obj", "-q", "-r", "4", "4", "-o", "x.png"];
        args.extend(&flags);
        let line = refused(&run(dir, &args), &format!("{flags:?}"));
        assert!(
            line.contains(expect),
            "{flags:?}: `{line}` lacks `{expect}`"
        );
        assert_eq!(snapshot(dir), before, "{flags:?}: files changed");
    }
}

/// One settings resolver: `study`, `bench --effects`, `bench --efficiency`
/// and `parity` refuse what `render` refuses (study turned `-s 0` into 1 and
/// checked neither the depth nor the pixel limit).
#[test]
fn every_command_refuses_what_render_refuses() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path();
    std::fs::write(dir.join("m.obj"), TRIANGLE_OBJ).unwrap();
    let before = snapshot(dir);
    // the cheap ones first: before the resolver, study rendered them
    let cases: [(&[&str], &str); 7] = [
        (&["-s", "0"], "-s 0"),
        (&["-l", "0"], "-l 0"),
        (&["-m", "5000"], "0..=1024"),
        (&["-l", "1025"], "1..=1024"),
        (&["-r", "0", "4"], "out of range"),
        (&["-r", "32768", "16385"], "pixels"),
        (&["-s", "16777217"], "1..=16777216"),
    ];
    for (flags, expect) in cases {
        let has = |f: &str| flags.contains(&f);
        let mut render = vec!["render", "m.obj", "-q", "-o", "x.png"];
        let mut study = vec!["study", "m.obj", "-q", "--out", "st"];
        if !has("-r") {
            render.extend(["-r", "4", "4"]);
            study.extend(["-r", "4", "4"]);
        }
        if !has("-s") {
            study.extend(["-s", "1", "--reference-spp", "1"]);
        }
        render.extend(flags);
        study.extend(flags);
        let r = refused(&run(dir, &render), &format!("render {flags:?}"));
        let s = refused(&run(dir, &study), &format!("study {flags:?}"));
        assert!(r.contains(expect), "render {flags:?}: {r}");
        assert!(s.contains(expect), "study {flags:?}: {s}");
        if !has("-m") && !has("-l") {
            for mode in ["--effects", "--efficiency"] {
                let mut bench = vec!["bench", "m.obj", mode, "--reps", "1"];
                if !has("-r") {
                    bench.extend(["-r", "4", "4"]);
                }
                bench.extend(flags);
                let b = refused(&run(dir, &bench), &format!("bench {mode} {flags:?}"));
                assert!(b.contains(expect), "bench {mode} {flags:?}: {b}");
            }
        }
        assert_eq!(snapshot(dir), before, "{flags:?}: files written");
    }
    for (args, expect) in [
        (
            vec![
                "study", "m.obj", "--out", "st", "-r", "4", "4", "--vary", "spp=1,0",
            ],
            "spp=0",
        ),
        (
            vec![
                "study",
                "m.obj",
                "--out",
                "st",
                "-r",
                "4",
                "4",
                "--vary",
                "max_depth=5000",
            ],
            "0..=1024",
        ),
        (
            vec![
                "study",
                "m.obj",
                "--out",
                "st",
                "-r",
                "4",
                "4",
                "--vary",
                "light_samples=0",
            ],
            "light_samples=0",
        ),
        (
            vec![
                "study",
                "m.obj",
                "--out",
                "st",
                "-r",
                "4",
                "4",
                "--reference-spp",
                "0",
            ],
            "--reference-spp 0",
        ),
        (
            vec![
                "parity",
                "m.obj",
                "--rays",
                "10",
                "--image",
                "4",
                "--image-spp",
                "0",
            ],
            "--image-spp 0",
        ),
        (
            vec!["parity", "m.obj", "--rays", "10", "--image", "40000"],
            "--image 40000",
        ),
    ] {
        let line = refused(&run(dir, &args), &format!("{args:?}"));
        assert!(line.contains(expect), "{args:?}: `{line}` lacks `{expect}`");
        assert_eq!(snapshot(dir), before, "{args:?}: files written");
    }
}

/// A point light whose power `4 pi I` overflows `f32` (I = 1e38 W/sr) is
/// still chosen in proportion to its power: it lit nothing before, its
/// selection weight having become infinite, then zero.
#[test]
fn a_point_light_too_strong_for_f32_power_still_lights() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path();
    std::fs::write(
        dir.join("q.obj"),
        "v -1 0 1\nv 1 0 1\nv 1 0 -1\nv -1 0 -1\nf 1 2 3\nf 1 3 4\n",
    )
    .unwrap();
    let scene = |intensity: &str| {
        format!(
            "[camera]\norigin = [0.0, 3.0, 0.0]\ntarget = [0.0, 0.0, 0.0]\nup = [0.0, 0.0, -1.0]\nfov_y = 30.0\n\n\
             [[mesh]]\nfile = \"q.obj\"\n\n\
             [[light]]\ntype = \"point\"\nposition = [0.0, 100.0, 0.0]\nintensity = {intensity}\n\n\
             [[light]]\ntype = \"point\"\nposition = [0.0, 100.0, 0.0]\nintensity = 1.0\n"
        )
    };
    std::fs::write(dir.join("strong.toml"), scene("1e38")).unwrap();
    std::fs::write(dir.join("weak.toml"), scene("1e20")).unwrap();
    let mean = |name: &str| {
        let out = run(
            dir,
            &[
                "render", name, "-q", "-r", "4", "4", "-s", "4", "-o", "x.pfm",
            ],
        );
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        let img = embertrace::diff::Image::read(&dir.join("x.pfm")).unwrap();
        img.rgb.iter().map(|&v| v as f64).sum::<f64>() / img.rgb.len() as f64
    };
    // the floor fills the view, lit from straight above at distance 97:
    // radiance albedo I / (pi 97^2), about 1e15 for I = 1e20; the film
    // saturates each sample at 2^64 (1.8e19)
    let weak = mean("weak.toml");
    assert!(weak > 1e14, "the 1e20 light gives {weak}");
    let strong = mean("strong.toml");
    assert!(
        strong >= weak,
        "the 1e38 light gives {strong}, the 1e20 one {weak}"
    );
}
