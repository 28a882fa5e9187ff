//! `embertrace study`: the folder it writes is complete and its parts agree:
//! the CSV's errors are those of the saved renders against the saved
//! reference, the plot has one curve per setting, the Markdown lists the
//! table and the Pareto front, and a second run reuses the cached reference.

use std::path::Path;
use std::process::Command;

fn run(dir: &Path, args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_embertrace"))
        .current_dir(dir)
        .args(args)
        .output()
        .unwrap()
}

#[test]
fn study_folder_is_complete_and_consistent() {
    let dir = tempfile::tempdir().unwrap();
    let scene = concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/cornell-box.toml");
    let args = [
        "study",
        scene,
        "--out",
        "st",
        "-r",
        "16",
        "16",
        "-s",
        "8",
        "--vary",
        "max_depth=0,3",
        "--vary",
        "sampler=independent,sobol",
        "--reference-spp",
        "64",
    ];
    let out = run(dir.path(), &args);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let st = dir.path().join("st");
    for f in [
        "study.csv",
        "study.md",
        "error-vs-time.png",
        "contact-sheet.png",
        "reference.exr",
    ] {
        assert!(st.join(f).is_file(), "{f} missing");
    }
    let csv = std::fs::read_to_string(st.join("study.csv")).unwrap();
    let rows: Vec<Vec<String>> = csv
        .lines()
        .skip(1)
        .map(|l| l.split(',').map(str::to_string).collect())
        .collect();
    assert_eq!(rows.len(), 4);
    assert_eq!(rows[0][0], "\"max_depth=0 sampler=independent\"");
    for (k, r) in rows.iter().enumerate() {
        // the CSV's RMSE is the saved render's against the saved reference
        let render = st.join("renders").join(format!("{:02}.exr", k + 1));
        let d = run(
            dir.path(),
            &["diff", render.to_str().unwrap(), "st/reference.exr"],
        );
        let text = String::from_utf8_lossy(&d.stdout).to_string();
        let rmse: f64 = r[4].parse().unwrap();
        assert!(
            text.contains(&format!("rmse       {rmse:.6e}")),
            "{text} vs {r:?}"
        );
        // efficiency = 1 / (rel_mse * seconds)
        let (secs, rel, eff): (f64, f64, f64) = (
            r[1].parse().unwrap(),
            r[5].parse().unwrap(),
            r[6].parse().unwrap(),
        );
        assert!((eff * rel * secs - 1.0).abs() < 1e-3, "{r:?}");
    }
    // depth 0 misses all indirect light: a much larger error than depth 3
    let rel = |k: usize| rows[k][5].parse::<f64>().unwrap();
    assert!(rel(0) > 3.0 * rel(2), "{csv}");
    // one curve per setting, in the palette's first four colours
    let plot = image::open(st.join("error-vs-time.png")).unwrap().to_rgb8();
    for c in &embertrace::commands::study::plot::PALETTE[..4] {
        assert!(plot.pixels().any(|p| p.0 == *c), "no curve in {c:?}");
    }
    let md = std::fs::read_to_string(st.join("study.md")).unwrap();
    for r in &rows {
        assert!(
            md.contains(r[0].trim_matches('"')),
            "{} not in study.md",
            r[0]
        );
    }
    let pareto = rows.iter().filter(|r| r[7] == "true").count();
    assert!(pareto >= 1 && md.matches("\n- ").count() == pareto, "{md}");
    // a second run reuses the reference
    let again = run(dir.path(), &args);
    assert!(String::from_utf8_lossy(&again.stderr).contains("reusing the reference"));
    // bad --vary: one line, non-zero exit
    let bad = run(
        dir.path(),
        &["study", scene, "--out", "st2", "--vary", "depth=1"],
    );
    let err = String::from_utf8_lossy(&bad.stderr);
    assert!(
        !bad.status.success() && err.lines().count() == 1 && err.contains("depth"),
        "{err}"
    );
    assert!(!dir.path().join("st2").exists());
}
