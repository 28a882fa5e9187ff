//! Hostile command lines (issue 21, item 3): each is refused with one line
//! and exit 1 before anything is rendered, without a panic, and leaves every
//! file as it was: no output onto an input or onto another output, the same
//! settings refused by every command, long tokens quoted short, and a light
//! too strong for `f32` power still sampled.

use std::path::Path;
use std::process::{Command, Output};

fn run(dir: &Path, args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_embertrace"))
        .current_dir(dir)
        .args(args)
        .output()
        .expect("embertrace runs")
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
