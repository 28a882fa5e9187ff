//! The measuring commands from the command line: `bench` (its table and
//! JSON agree), `parity` (no unexplained disagreement on the bundled
//! scenes and on a dense room) and `diff` (metrics, and mismatched images
//! refused). Split from `tests/cli.rs`, which keeps the bad-input cases.

mod common;

use common::{GOOD_OBJ, entries, run, setup};
use std::path::Path;

fn cornell_scene() -> String {
    concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/cornell-box.toml").to_string()
}

#[test]
fn bench_prints_a_table_and_json_with_matching_checksums() {
    let dir = tempfile::tempdir().unwrap();
    let scene = cornell_scene();
    let out = run(
        dir.path(),
        &[
            "bench", &scene, "--rays", "3000", "--reps", "1", "--json", "b.json",
        ],
    );
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let table = String::from_utf8_lossy(&out.stdout);
    for b in embertrace::accel::Backend::available() {
        assert!(table.contains(b.name()), "table lacks {b}: {table}");
    }
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join("b.json")).unwrap()).unwrap();
    let rows = report["backends"].as_array().unwrap();
    assert_eq!(rows.len(), embertrace::accel::Backend::available().len());
    for (i, row) in rows.iter().enumerate() {
        assert!(row["build_seconds"].as_f64().unwrap() >= 0.0);
        // ratios to the first backend, which has none of its own
        assert_eq!(row["build_ratio"].is_null(), i == 0, "{row}");
        for k in row["kinds"].as_array().unwrap() {
            for key in ["ratio_single", "ratio_all"] {
                assert!(
                    if i == 0 {
                        k[key].is_null()
                    } else {
                        k[key].as_f64().unwrap() > 0.0
                    },
                    "{key}: {k}"
                );
            }
        }
        assert!(row["bytes_per_triangle"].as_f64().unwrap() > 0.0);
        let kinds: Vec<&str> = row["kinds"]
            .as_array()
            .unwrap()
            .iter()
            .map(|k| k["kind"].as_str().unwrap())
            .collect();
        assert_eq!(kinds, ["camera", "shadow", "diffuse", "random"]);
        for (k, first) in row["kinds"]
            .as_array()
            .unwrap()
            .iter()
            .zip(rows[0]["kinds"].as_array().unwrap())
        {
            assert!(
                k["mrays_single"].as_f64().unwrap() > 0.0 && k["mrays_all"].as_f64().unwrap() > 0.0
            );
            // every backend traced the same rays and found the same number of hits
            assert_eq!(
                k["hits"], first["hits"],
                "{}: {} vs {}",
                k["kind"], row["backend"], rows[0]["backend"]
            );
        }
    }
}

#[test]
fn parity_finds_no_unexplained_disagreements() {
    if embertrace::accel::Backend::available().len() < 2 {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    setup(
        dir.path(),
        &[(
            "p.toml",
            "[camera]\norigin = [0, 0.5, 3]\ntarget = [0, 0, 0]\n\n[[procedural]]\ntype = \"sphere\"\ntriangles = 4000\ndisplacement = 0.2\n\n[[procedural]]\ntype = \"terrain\"\ntriangles = 2000\ntransform = { scale = 2, translate = [0, -1, 0] }\n\n[[light]]\ntype = \"environment\"\nradiance = 1\n"
                .into(),
        )],
    );
    for scene in [
        cornell_scene(),
        dir.path().join("p.toml").display().to_string(),
    ] {
        let out = run(
            dir.path(),
            &[
                "parity", &scene, "--rays", "4000", "--image", "24", "--json", "p.json",
            ],
        );
        let stdout = String::from_utf8_lossy(&out.stdout);
        assert!(
            out.status.success(),
            "{scene}: {stdout}{}",
            String::from_utf8_lossy(&out.stderr)
        );
        let report: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(dir.path().join("p.json")).unwrap())
                .unwrap();
        assert_eq!(report["unexplained"], 0);
        let c = &report["comparisons"][0];
        assert_eq!(c["kinds"].as_array().unwrap().len(), 6);
        for k in c["kinds"].as_array().unwrap() {
            assert!(k["rays"].as_u64().unwrap() > 0);
            let kind = k["kind"].as_str().unwrap();
            if ["camera", "diffuse", "shadow", "random"].contains(&kind) {
                // generic rays: no disagreement at all, explained or not
                let total = k["hit_miss"].as_u64().unwrap()
                    + k["primitive"].as_u64().unwrap()
                    + k["distance"].as_u64().unwrap();
                assert!(total <= 2, "{scene} {kind}: {total} disagreements");
            }
        }
        assert_eq!(c["image"]["within_noise"], true);
    }
}

/// Every bundled scene, the 1.2M-triangle procedural one included, with the
/// default ray counts: its pole slivers and small triangles seen from afar
/// once gave 82 unexplained disagreements (a squarely hit sliver rejected
/// by the watertight test's distance bound, and edges judged by a fixed
/// barycentric threshold).
#[test]
fn parity_on_every_bundled_scene_leaves_nothing_unexplained() {
    use embertrace::accel::Backend;
    let embree = Backend::available().contains(&Backend::Embree);
    let dir = tempfile::tempdir().unwrap();
    let scenes = concat!(env!("CARGO_MANIFEST_DIR"), "/scenes");
    let mut checked = 0;
    for entry in entries(Path::new(scenes)) {
        if entry.extension().is_none_or(|e| e != "toml") {
            continue;
        }
        // without Embree, the BVH's only partner is brute force, which
        // parity uses up to 20k triangles
        let triangles = embertrace::scene::Scene::load(&entry)
            .unwrap()
            .traced_triangle_count();
        if !embree && triangles > 20_000 {
            continue;
        }
        let scene = entry.display().to_string();
        let out = run(dir.path(), &["parity", &scene, "--json", "p.json"]);
        let stdout = String::from_utf8_lossy(&out.stdout);
        assert!(out.status.success(), "{scene}: {stdout}");
        let report: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(dir.path().join("p.json")).unwrap())
                .unwrap();
        assert_eq!(report["unexplained"], 0, "{scene}: {stdout}");
        checked += 1;
    }
    assert!(
        checked >= 3 + embree as usize,
        "checked {checked} bundled scenes"
    );
}

/// Issue 21's concave-corner leak: on a room around a dense mesh, rays that
/// start within 1e-5 of a concave edge must hit the adjacent wall in every
/// backend (the watertight test's bound on t used to reject those hits).
/// Before the fix, 200k random rays on `cornell-mesh` left one unexplained
/// disagreement, a ray from (-0.975, 0.050, -0.99999) that Embree sent into
/// the back wall at t = 1.5e-5 and the BVH out of the room.
#[test]
fn parity_on_a_room_with_a_dense_mesh_at_200k_rays_per_kind() {
    use embertrace::accel::Backend;
    if !Backend::available().contains(&Backend::Embree) {
        return; // brute force is too slow for a million triangles
    }
    let dir = tempfile::tempdir().unwrap();
    let scene = concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/cornell-mesh.toml");
    let out = run(
        dir.path(),
        &[
            "parity", scene, "--rays", "200000", "--image", "0", "--json", "p.json",
        ],
    );
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{stdout}");
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join("p.json")).unwrap()).unwrap();
    assert_eq!(report["unexplained"], 0, "{stdout}");
}

#[test]
fn diff_reports_metrics_and_refuses_mismatched_images() {
    let dir = tempfile::tempdir().unwrap();
    setup(dir.path(), &[("m.obj", GOOD_OBJ.into())]);
    for (seed, name, res) in [
        ("1", "a.exr", "8"),
        ("2", "b.exr", "8"),
        ("1", "c.pfm", "4"),
    ] {
        let out = run(
            dir.path(),
            &[
                "render", "m.obj", "-s", "2", "--seed", seed, "-r", res, "6", "-o", name, "-q",
            ],
        );
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
    }
    let text = |o: &std::process::Output| String::from_utf8_lossy(&o.stdout).to_string();
    // an image against itself: every metric is zero
    let same = run(dir.path(), &["diff", "a.exr", "a.exr"]);
    assert!(same.status.success());
    assert!(
        text(&same).contains("rmse       0.000000e0"),
        "{}",
        text(&same)
    );
    // two seeds differ; the JSON holds the printed figures
    let out = run(
        dir.path(),
        &[
            "diff",
            "a.exr",
            "b.exr",
            "--json",
            "d.json",
            "--error-image",
            "e.png",
        ],
    );
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let d: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join("d.json")).unwrap()).unwrap();
    let rmse = d["rmse"].as_f64().unwrap();
    assert!(rmse > 0.0 && d["max_error"].as_f64().unwrap() >= rmse);
    assert!(
        text(&out).contains(&format!("rmse       {rmse:.6e}")),
        "{}",
        text(&out)
    );
    let e = image::open(dir.path().join("e.png")).unwrap();
    assert_eq!((e.width(), e.height()), (8, 6));
    // sizes differ, or a PNG is given: one line, non-zero exit, no outputs
    for args in [
        &[
            "diff",
            "a.exr",
            "c.pfm",
            "--error-image",
            "f.png",
            "--json",
            "f.json",
        ][..],
        &["diff", "e.png", "a.exr", "--error-image", "f.png"][..],
    ] {
        let out = run(dir.path(), args);
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success() && err.lines().count() == 1, "{err}");
        assert!(err.contains(args[1]), "{err}");
        assert!(!dir.path().join("f.png").exists() && !dir.path().join("f.json").exists());
    }
}
