//! Hostile command lines (issue 21, item 3): each is refused with one line
//! and exit 1 before anything is rendered, without a panic, and leaves every
//! file as it was: no output onto an input or onto another output, the same
//! settings refused by every command, long tokens quoted short, and a light
//! too strong for `f32` power still sampled.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

const SCENES: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/scenes");

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

/// `s.toml`: a floor mesh (`floor.obj`) with a texture (`checker.png`)
/// under an environment map (`sky.exr`).
fn textured_scene(dir: &Path) {
    for f in ["checker.png", "sky.exr", "floor.obj"] {
        std::fs::copy(Path::new(SCENES).join(f), dir.join(f)).unwrap();
    }
    std::fs::write(
        dir.join("s.toml"),
        "[camera]\norigin = [0.0, 1.6, 6.5]\ntarget = [0.0, 0.6, 0.0]\n\n\
         [film]\nresolution = [8, 4]\n\n[render]\nspp = 1\n\n\
         [[light]]\ntype = \"environment\"\nfile = \"sky.exr\"\nradiance = 1.0\n\n\
         [[mesh]]\nfile = \"floor.obj\"\n\
         material = { type = \"diffuse\", diffuse = 0.8, texture = \"checker.png\" }\n",
    )
    .unwrap();
}

/// `-o` and every other output flag onto a file the scene read (its
/// texture, environment map or the scene file, also through `..`, a
/// symbolic link or a hard link) is refused, naming both; nothing is
/// written.
#[test]
fn outputs_onto_the_scenes_inputs_are_refused() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path();
    textured_scene(dir);
    std::fs::create_dir(dir.join("sub")).unwrap();
    std::fs::copy(dir.join("sky.exr"), dir.join("ref.exr")).unwrap();
    #[cfg(unix)]
    {
        std::os::unix::fs::symlink("checker.png", dir.join("link.png")).unwrap();
        std::fs::hard_link(dir.join("checker.png"), dir.join("hard.png")).unwrap();
    }
    let before = snapshot(dir);
    let mut cases: Vec<(Vec<&str>, Vec<&str>)> = vec![
        (vec!["-o", "checker.png"], vec!["-o checker.png", "texture"]),
        (
            vec!["-o", "sub/../checker.png"],
            vec!["checker.png", "texture"],
        ),
        (vec!["-o", "sky.exr"], vec!["-o sky.exr", "environment"]),
        (
            vec!["-o", "x.png", "--report", "s.toml"],
            vec!["--report s.toml", "scene"],
        ),
        (
            vec!["-o", "x.png", "--aov", "checker.png"],
            vec!["--aov checker.png", "texture"],
        ),
        (
            vec!["-o", "x.png", "--variance", "sky.exr"],
            vec!["--variance sky.exr", "environment"],
        ),
        (
            vec!["-o", "x.png", "--checkpoint", "sky.exr"],
            vec!["--checkpoint sky.exr", "environment"],
        ),
        (
            vec![
                "-o",
                "x.png",
                "-a",
                "2",
                "0.5",
                "--sample-map",
                "checker.png",
            ],
            vec!["--sample-map checker.png", "texture"],
        ),
        (
            vec![
                "-o",
                "x.png",
                "--reference",
                "sky.exr",
                "--convergence",
                "s.toml",
            ],
            vec!["--convergence s.toml", "scene"],
        ),
        (
            vec![
                "-o",
                "ref.exr",
                "--reference",
                "ref.exr",
                "--convergence",
                "c.csv",
            ],
            vec!["-o ref.exr", "--reference"],
        ),
    ];
    if cfg!(unix) {
        cases.push((vec!["-o", "link.png"], vec!["-o link.png", "checker.png"]));
        cases.push((vec!["-o", "hard.png"], vec!["-o hard.png", "checker.png"]));
    }
    each_refused(dir, cases, "overwrite", &before);
}

/// Render `s.toml` in `dir` with each case's flags: refused, with `word`
/// and the case's texts in its one line, and no file in `dir` changed.
fn each_refused(
    dir: &Path,
    cases: Vec<(Vec<&str>, Vec<&str>)>,
    word: &str,
    before: &BTreeMap<PathBuf, Vec<u8>>,
) {
    for (flags, expect) in cases {
        let mut args = vec!["render", "s.toml", "-q"];
        args.extend(&flags);
        let line = refused(&run(dir, &args), &format!("{flags:?}"));
        assert!(line.contains(word), "{flags:?}: {line}");
        for e in expect {
            assert!(line.contains(e), "{flags:?}: `{line}` lacks `{e}`");
        }
        assert_eq!(&snapshot(dir), before, "{flags:?}: files changed");
    }
}

/// Two outputs naming one file (`-o X --report X` left only the report)
/// are refused before anything is read or rendered.
#[test]
fn two_outputs_onto_one_file_are_refused() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path();
    textured_scene(dir);
    let before = snapshot(dir);
    let cases = [
        (
            vec!["-o", "x.png", "--report", "x.png"],
            ["-o x.png", "--report x.png"],
        ),
        (
            vec!["-o", "x.exr", "--variance", "./x.exr"],
            ["-o x.exr", "--variance ./x.exr"],
        ),
        (
            vec!["-o", "x.png", "--aov", "x.png"],
            ["-o x.png", "--aov x.png"],
        ),
        (
            vec![
                "-o",
                "x.png",
                "--report",
                "r.json",
                "--reference",
                "sky.exr",
                "--convergence",
                "r.json",
            ],
            ["--report r.json", "--convergence r.json"],
        ),
        (
            vec![
                "-o",
                "x.png",
                "--checkpoint",
                "c.exr",
                "--variance",
                "c.exr",
            ],
            ["--checkpoint c.exr", "--variance c.exr"],
        ),
    ];
    let cases = cases.into_iter().map(|(f, e)| (f, e.to_vec())).collect();
    each_refused(dir, cases, "same file", &before);
}

/// `convert` refuses to write its TOML, or a mesh or image beside it, over
/// a file the scene read.
#[test]
fn convert_never_overwrites_what_the_scene_read() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path();
    textured_scene(dir);
    // a scene whose environment map and texture carry the names a
    // conversion to out.toml writes
    std::fs::copy(dir.join("sky.exr"), dir.join("out-environment.exr")).unwrap();
    std::fs::copy(dir.join("sky.exr"), dir.join("out-texture-0.exr")).unwrap();
    let s = std::fs::read_to_string(dir.join("s.toml")).unwrap();
    std::fs::write(
        dir.join("env.toml"),
        s.replace("\"sky.exr\"", "\"out-environment.exr\""),
    )
    .unwrap();
    std::fs::write(
        dir.join("tex.toml"),
        s.replace("\"checker.png\"", "\"out-texture-0.exr\""),
    )
    .unwrap();
    let before = snapshot(dir);
    for (args, expect) in [
        (["convert", "s.toml", "s.toml"], "s.toml"),
        (["convert", "s.toml", "./s.toml"], "s.toml"),
        (["convert", "env.toml", "out.toml"], "out-environment.exr"),
        (["convert", "tex.toml", "out.toml"], "out-texture-0.exr"),
    ] {
        let line = refused(&run(dir, &args), &format!("{args:?}"));
        assert!(
            line.contains("overwrite") && line.contains(expect),
            "{args:?}: {line}"
        );
        assert_eq!(snapshot(dir), before, "{args:?}: files changed");
    }
    // and a conversion beside the inputs still works
    let out = run(dir, &["convert", "s.toml", "c.toml"]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
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
        (vec!["-s", "-1"], "invalid value '-1' for '--spp <SPP>'"),
        (vec!["--no-such-flag"], "--no-such-flag"),
    ] {
        let mut args = vec!["render", "m.obj", "-q", "-r", "4", "4", "-o", "x.png"];
        args.extend(&flags);
        let line = refused(&run(dir, &args), &format!("{flags:?}"));
        assert!(
            line.contains(expect),
            "{flags:?}: `{line}` lacks `{expect}`"
        );
        assert!(
            !line.contains("--help'"),
            "{flags:?}: two pointers to help: {line}"
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

/// A 10 MB token in a file is quoted by its first characters and its size,
/// not whole.
#[test]
fn long_tokens_are_quoted_short() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path();
    let big = "k".repeat(10_000_000);
    let files = [
        ("key.toml", format!("[camera]\n{big} = 1\n"), "key.toml:2"),
        (
            "value.toml",
            format!("[[light]]\ntype = \"{big}\"\n"),
            "value.toml:1",
        ),
        (
            "token.obj",
            format!("{TRIANGLE_OBJ}f 1 2 {big}\n"),
            "token.obj:5",
        ),
    ];
    for (name, text, at) in &files {
        std::fs::write(dir.join(name), text).unwrap();
        let line = refused(
            &run(dir, &["render", name, "-q", "-r", "4", "4", "-o", "x.png"]),
            name,
        );
        assert!(line.len() < 400, "{name}: {} bytes of error", line.len());
        assert!(line.contains(at), "{name}: {line}");
        assert!(
            line.contains("kkkkkkkk") && line.contains(" bytes)"),
            "{name}: {line}"
        );
    }
}

/// A texture path that is a directory says so (it said "not found").
#[test]
fn a_texture_that_is_a_directory_says_so() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path();
    textured_scene(dir);
    std::fs::create_dir(dir.join("tex.png")).unwrap();
    let s = std::fs::read_to_string(dir.join("s.toml")).unwrap();
    std::fs::write(dir.join("d.toml"), s.replace("checker.png", "tex.png")).unwrap();
    let line = refused(
        &run(dir, &["render", "d.toml", "-q", "-o", "x.png"]),
        "directory texture",
    );
    assert!(
        line.contains("tex.png") && line.contains("directory"),
        "{line}"
    );
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
        let img = embertrace::commands::diff::Image::read(&dir.join("x.pfm")).unwrap();
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
