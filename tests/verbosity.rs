//! `-q` and `-v` on every command, through the one logging facility
//! (`embertrace::log`): `-q` leaves warnings and errors, `-v` adds details.

use std::path::Path;

const SCENE: &str = "scenes/cornell-box.toml";

mod common;
use common::{run_here as embertrace, stderr_of as stderr};

const COMMANDS: [&str; 8] = [
    "render", "bench", "parity", "diff", "study", "plan", "convert", "merge",
];

#[test]
fn every_command_takes_quiet_and_verbose() {
    for command in COMMANDS {
        let help = embertrace(&[command, "--help"]);
        let text = String::from_utf8_lossy(&help.stdout);
        assert!(help.status.success(), "{command} --help");
        assert!(text.contains("-q, --quiet"), "{command}: {text}");
        assert!(text.contains("-v, --verbose"), "{command}: {text}");
    }
}

#[test]
fn quiet_render_prints_nothing_and_normal_render_says_what_it_does() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("a.png");
    let out = out.to_str().unwrap();
    let common = ["render", SCENE, "-r", "8", "8", "-s", "1", "-o", out];
    let normal = embertrace(&common);
    assert!(normal.status.success());
    assert!(stderr(&normal).contains("rendering"), "{}", stderr(&normal));
    assert!(!stderr(&normal).contains("kernel:"), "{}", stderr(&normal));
    for quiet in [
        [&["-q"][..], &common[..]].concat(),
        [&common[..], &["--quiet"][..]].concat(),
    ] {
        let o = embertrace(&quiet);
        assert!(o.status.success());
        assert_eq!(stderr(&o), "", "{quiet:?}");
        assert!(Path::new(out).is_file());
    }
}

#[test]
fn verbose_render_adds_the_details() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("a.png");
    let o = embertrace(&[
        "render",
        SCENE,
        "-r",
        "8",
        "8",
        "-s",
        "1",
        "--accel",
        "bvh",
        "-o",
        out.to_str().unwrap(),
        "-v",
    ]);
    assert!(o.status.success());
    let e = stderr(&o);
    for needle in [
        "rendering",
        "loaded in",
        "backend bvh built in",
        "settings: seed",
        "kernel:",
    ] {
        assert!(e.contains(needle), "{needle:?} missing from {e}");
    }
    assert!(!e.contains("debug:"), "{e}");
    let vv = embertrace(&["-vv", "plan", SCENE]);
    assert!(vv.status.success(), "{}", stderr(&vv));
}

#[test]
fn the_course_form_takes_a_leading_quiet_flag() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("c.png");
    let o = embertrace(&[
        "-q",
        "-r",
        "8",
        "8",
        "-s",
        "1",
        "-f",
        out.to_str().unwrap(),
        SCENE,
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(stderr(&o), "");
    assert!(out.is_file());
}

#[test]
fn quiet_and_verbose_together_are_one_line_of_error() {
    let o = embertrace(&["plan", SCENE, "-q", "-v"]);
    assert_eq!(o.status.code(), Some(1));
    let e = stderr(&o);
    assert_eq!(e.trim_end().lines().count(), 1, "{e}");
    assert!(e.contains("--quiet") && e.contains("--verbose"), "{e}");
}

#[test]
fn quiet_convert_says_nothing_and_normal_convert_names_what_it_wrote() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("c.toml");
    let out = out.to_str().unwrap();
    let normal = embertrace(&["convert", SCENE, out]);
    assert!(normal.status.success(), "{}", stderr(&normal));
    assert!(stderr(&normal).contains("wrote"));
    let quiet = embertrace(&["convert", SCENE, out, "-q"]);
    assert!(quiet.status.success());
    assert_eq!(stderr(&quiet), "");
}

#[test]
fn quiet_keeps_the_warnings() {
    // a statement the image will not show is a warning: -q keeps it
    let dir = tempfile::tempdir().unwrap();
    let obj = dir.path().join("m.obj");
    std::fs::write(&obj, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\ncurv 0 1 1 2\n").unwrap();
    let out = dir.path().join("m.png");
    let o = embertrace(&[
        "render",
        obj.to_str().unwrap(),
        "-q",
        "-r",
        "4",
        "4",
        "-s",
        "1",
        "-o",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let e = stderr(&o);
    assert!(e.starts_with("warning: "), "{e}");
    assert!(e.lines().all(|l| l.starts_with("warning: ")), "{e}");
}
