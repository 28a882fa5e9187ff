//! The command line. Bad input gets a clear one-line error naming the file (and line where
//! known), a non-zero exit, no panic, and no output file left behind
//! (`../shared/docs/hard-cases.md`, section E, case 27).

mod common;

use common::{GOOD_OBJ, entries, run, setup};
use std::path::Path;
use std::process::Command;

struct Case {
    name: &'static str,
    files: Vec<(&'static str, String)>,
    scene: &'static str,
    /// Text the error line must contain (file name, line, expectation).
    expect: Vec<&'static str>,
}

fn toml_with_mesh(extra: &str) -> String {
    format!(
        "[camera]\norigin = [0, 0, 3]\ntarget = [0, 0, 0]\n\n[[mesh]]\nfile = \"m.obj\"\n{extra}\n"
    )
}

fn cases() -> Vec<Case> {
    vec![
        Case {
            name: "missing scene file",
            files: vec![],
            scene: "nope.toml",
            expect: vec!["nope.toml"],
        },
        Case {
            name: "malformed toml",
            files: vec![("s.toml", "[camera\norigin = [0, 0, 3]\n".into())],
            scene: "s.toml",
            expect: vec!["s.toml:1"],
        },
        Case {
            name: "unknown key",
            files: vec![
                ("m.obj", GOOD_OBJ.into()),
                ("s.toml", toml_with_mesh("colour = 3")),
            ],
            scene: "s.toml",
            expect: vec!["s.toml:7", "colour"],
        },
        Case {
            name: "unknown key in camera",
            files: vec![(
                "s.toml",
                "[camera]\norigin = [0, 0, 3]\ntarget = [0, 0, 0]\nfov = 40\n".into(),
            )],
            scene: "s.toml",
            expect: vec!["s.toml:4", "fov"],
        },
        Case {
            name: "wrong type",
            files: vec![("s.toml", "[render]\nspp = \"many\"\n".into())],
            scene: "s.toml",
            expect: vec!["s.toml:2"],
        },
        Case {
            name: "absurd resolution",
            files: vec![(
                "s.toml",
                "[film]\nresolution = [1000000000, 1000000000]\n".into(),
            )],
            scene: "s.toml",
            expect: vec!["s.toml:2", "resolution"],
        },
        Case {
            name: "mesh file missing",
            files: vec![("s.toml", toml_with_mesh(""))],
            scene: "s.toml",
            expect: vec!["s.toml:5", "m.obj"],
        },
        Case {
            name: "malformed obj vertex",
            files: vec![
                ("m.obj", "v 0 0 0\nv 1 zero 0\nv 0 1 0\nf 1 2 3\n".into()),
                ("s.toml", toml_with_mesh("")),
            ],
            scene: "s.toml",
            expect: vec!["m.obj:2", "zero"],
        },
        Case {
            name: "index out of range",
            files: vec![("m.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 7\n".into())],
            scene: "m.obj",
            expect: vec!["m.obj:4", "out of range"],
        },
        Case {
            name: "negative index out of range",
            files: vec![("m.obj", "v 0 0 0\nf -1 -2 -3\n".into())],
            scene: "m.obj",
            expect: vec!["m.obj:2"],
        },
        Case {
            name: "NaN coordinate",
            files: vec![("m.obj", "v 0 0 0\nv nan 0 0\nv 0 1 0\nf 1 2 3\n".into())],
            scene: "m.obj",
            expect: vec!["m.obj:2", "finite"],
        },
        Case {
            name: "infinite coordinate",
            files: vec![("m.obj", "v 0 0 0\nv 1e39 0 0\nv 0 1 0\nf 1 2 3\n".into())],
            scene: "m.obj",
            expect: vec!["m.obj:2", "1e39", "beyond +-1.8e18"],
        },
        Case {
            name: "truncated face",
            files: vec![("m.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2\n".into())],
            scene: "m.obj",
            expect: vec!["m.obj:4"],
        },
        Case {
            name: "missing mtl",
            files: vec![("m.obj", format!("mtllib gone.mtl\n{GOOD_OBJ}"))],
            scene: "m.obj",
            expect: vec!["gone.mtl"],
        },
        Case {
            name: "directory as scene",
            files: vec![("d.toml/x", String::new())],
            scene: "d.toml",
            expect: vec!["d.toml", "directory"],
        },
        Case {
            name: "unknown scene format",
            files: vec![("s.blend", String::new())],
            scene: "s.blend",
            expect: vec!["s.blend", "unknown scene format"],
        },
        Case {
            name: "unknown light type",
            files: vec![(
                "s.toml",
                "[[light]]\ntype = \"laser\"\nradiance = 1\n".into(),
            )],
            scene: "s.toml",
            expect: vec!["s.toml:1", "laser"],
        },
        Case {
            name: "a spot light's beam wider than its cutoff",
            files: vec![(
                "s.toml",
                "[[light]]\ntype = \"spot\"\nposition = [0, 1, 0]\ndirection = [0, -1, 0]\nintensity = 1\ncutoff_angle = 10\nbeam_width = 20\n".into(),
            )],
            scene: "s.toml",
            expect: vec!["s.toml:1", "beam_width", "cutoff_angle"],
        },
        Case {
            name: "a spot light with both target and direction",
            files: vec![(
                "s.toml",
                "[camera]\norigin = [0, 0, 3]\ntarget = [0, 0, 0]\n[[light]]\ntype = \"spot\"\nposition = [0, 1, 0]\ntarget = [0, 0, 0]\ndirection = [0, -1, 0]\nintensity = 1\n".into(),
            )],
            scene: "s.toml",
            expect: vec!["s.toml:4", "exactly one of `target` and `direction`"],
        },
        Case {
            name: "a Mitsuba spot light with a projected texture",
            files: vec![(
                "s.xml",
                "<scene version=\"3.0.0\">\n<emitter type=\"spot\">\n<texture name=\"texture\" type=\"bitmap\"/>\n</emitter>\n</scene>\n".into(),
            )],
            scene: "s.xml",
            expect: vec!["s.xml:3", "texture"],
        },
        Case {
            name: "negative emission",
            files: vec![
                ("m.obj", GOOD_OBJ.into()),
                ("s.toml", toml_with_mesh("material = { emission = -1 }")),
            ],
            scene: "s.toml",
            expect: vec!["s.toml:5", "non-negative"],
        },
        // found by tests/fuzz_loaders.rs: both made tobj 4.0 panic
        Case {
            name: "colour with two values in the material library",
            files: vec![
                ("m.obj", format!("mtllib m.mtl\nusemtl a\n{GOOD_OBJ}")),
                ("m.mtl", "newmtl a\nKd 0.5 0.5\n".into()),
            ],
            scene: "m.obj",
            expect: vec!["m.mtl:2", "Kd"],
        },
        Case {
            name: "normal index out of range",
            files: vec![(
                "m.obj",
                "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nf 1//1 2//1 3//-11\n".into(),
            )],
            scene: "m.obj",
            expect: vec!["m.obj:5", "normal index -11"],
        },
        // resource limits (src/limits.rs): refused before anything is
        // allocated for them, at the line that asks
        Case {
            name: "procedural triangle count of 1e12",
            files: vec![(
                "s.toml",
                "[[procedural]]\ntype = \"sphere\"\ntriangles = 1_000_000_000_000\n".into(),
            )],
            scene: "s.toml",
            expect: vec!["s.toml:3", "triangles", "100000000"],
        },
        Case {
            name: "procedural sphere just past the scene's triangle limit",
            files: vec![(
                "s.toml",
                "[[procedural]]\ntype = \"sphere\"\ntriangles = 99_999_999\n".into(),
            )],
            scene: "s.toml",
            // 5001 rings: 4 * 5001 * 5000 triangles
            expect: vec!["s.toml:3", "100020000 triangles"],
        },
        Case {
            name: "too many pixels",
            files: vec![("s.toml", "[film]\nresolution = [32768, 16384]\n".into())],
            scene: "s.toml",
            expect: vec!["s.toml:2", "pixels"],
        },
        Case {
            name: "spp beyond u32",
            files: vec![("s.toml", "[render]\nspp = 4294967296\n".into())],
            scene: "s.toml",
            expect: vec!["s.toml:2", "spp"],
        },
        Case {
            name: "spp zero in the scene file",
            files: vec![("s.toml", "[render]\nseed = 1\nspp = 0\n".into())],
            scene: "s.toml",
            expect: vec!["s.toml:3", "spp = 0"],
        },
        Case {
            name: "path depth that would overflow the stack",
            files: vec![("s.toml", "[render]\nmax_depth = 100000\n".into())],
            scene: "s.toml",
            expect: vec!["s.toml:2", "max_depth", "1024"],
        },
        Case {
            name: "zero light samples",
            files: vec![("s.toml", "[render]\nlight_samples = 0\n".into())],
            scene: "s.toml",
            expect: vec!["s.toml:2", "light_samples"],
        },
        // non-finite and out-of-range numbers
        Case {
            name: "NaN camera origin",
            files: vec![(
                "s.toml",
                "[camera]\norigin = [nan, 0, 3]\ntarget = [0, 0, 0]\n".into(),
            )],
            scene: "s.toml",
            expect: vec!["s.toml:2", "camera.origin", "finite"],
        },
        Case {
            name: "camera beyond Embree's range",
            files: vec![(
                "s.toml",
                "[camera]\norigin = [0, 0, 1e30]\ntarget = [0, 0, 0]\n".into(),
            )],
            scene: "s.toml",
            expect: vec!["s.toml:2", "camera.origin", "1.8e18"],
        },
        Case {
            name: "infinite transform scale",
            files: vec![
                ("m.obj", GOOD_OBJ.into()),
                ("s.toml", toml_with_mesh("transform = { scale = inf }")),
            ],
            scene: "s.toml",
            expect: vec!["s.toml:5", "transform.scale", "finite"],
        },
        Case {
            name: "1e30 coordinate",
            files: vec![("m.obj", "v 0 0 0\nv 1e30 0 0\nv 0 1 0\nf 1 2 3\n".into())],
            scene: "m.obj",
            expect: vec!["m.obj:2", "1e30", "1.8e18"],
        },
        Case {
            name: "w that takes a coordinate out of range",
            files: vec![("m.obj", "v 0 0 0\nv 0 1 0\nv 1 0 0 1e-40\nf 1 2 3\n".into())],
            scene: "m.obj",
            expect: vec!["m.obj:3", "w = `1e-40`", "beyond +-1.8e18"],
        },
        Case {
            name: "truncated vertex",
            files: vec![("m.obj", "v 0 0 0\nv 1 0 0\nv 0 1\n".into())],
            scene: "m.obj",
            expect: vec!["m.obj:3", "v x y z"],
        },
        Case {
            name: "face index past the end of its object",
            files: vec![(
                "m.obj",
                "o a\nf 1 2 3\no b\nv 0 0 0\nv 1 0 0\nv 0 1 0\n".into(),
            )],
            scene: "m.obj",
            expect: vec!["m.obj:2", "index 3"],
        },
        Case {
            name: "albedo above one in the material library",
            files: vec![
                ("m.obj", format!("mtllib m.mtl\nusemtl a\n{GOOD_OBJ}")),
                ("m.mtl", "newmtl a\nKd 0.5 2 0.5\n".into()),
            ],
            scene: "m.obj",
            expect: vec!["m.mtl:2", "Kd", "[0, 1]"],
        },
        // directories where files are expected
        Case {
            name: "directory as mesh file",
            files: vec![("d.obj/x", String::new()), ("s.toml", "[camera]\norigin = [0, 0, 3]\ntarget = [0, 0, 0]\n\n[[mesh]]\nfile = \"d.obj\"\n".into())],
            scene: "s.toml",
            expect: vec!["s.toml:5", "d.obj", "directory"],
        },
        Case {
            name: "directory as material library",
            files: vec![
                ("lib.mtl/x", String::new()),
                ("m.obj", format!("mtllib lib.mtl\n{GOOD_OBJ}")),
            ],
            scene: "m.obj",
            expect: vec!["m.obj:1", "lib.mtl"],
        },
        // found by tests/fuzz_loaders.rs: a quoted newline made the error two lines
        Case {
            name: "newline inside a quoted light type",
            files: vec![(
                "s.toml",
                "[[light]]\ntype = \"\\nvironment\"\nradiance = 1\n".into(),
            )],
            scene: "s.toml",
            expect: vec!["s.toml:1", "`\\nvironment`"],
        },
        Case {
            name: "a key of another material type",
            files: vec![
                ("m.obj", GOOD_OBJ.into()),
                (
                    "s.toml",
                    toml_with_mesh("material = { type = \"mirror\", ior = 1.5 }"),
                ),
            ],
            scene: "s.toml",
            expect: vec!["s.toml:5", "material.ior", "`mirror`"],
        },
        Case {
            name: "unknown material type",
            files: vec![
                ("m.obj", GOOD_OBJ.into()),
                ("s.toml", toml_with_mesh("material = { type = \"velvet\" }")),
            ],
            scene: "s.toml",
            expect: vec!["s.toml:5", "velvet", "conductor"],
        },
        Case {
            name: "an unknown direct-lighting strategy",
            files: vec![("s.toml", "[render]\nspp = 4\ndirect = \"nee\"\n".into())],
            scene: "s.toml",
            expect: vec!["s.toml:3", "render.direct", "`nee`"],
        },
        Case {
            name: "a roulette probability above 1",
            files: vec![("s.toml", "[render]\nrr = 1.5\n".into())],
            scene: "s.toml",
            expect: vec!["s.toml:2", "render.rr = 1.5"],
        },
        Case {
            name: "a phong material with both lobes",
            files: vec![
                ("m.obj", GOOD_OBJ.into()),
                (
                    "s.toml",
                    toml_with_mesh(
                        "material = { type = \"phong\", shininess = 10, roughness = 0.2 }",
                    ),
                ),
            ],
            scene: "s.toml",
            expect: vec!["s.toml:5", "material.shininess", "material.roughness"],
        },
        Case {
            name: "a phong material with a negative shininess",
            files: vec![
                ("m.obj", GOOD_OBJ.into()),
                (
                    "s.toml",
                    toml_with_mesh("material = { type = \"phong\", shininess = -2 }"),
                ),
            ],
            scene: "s.toml",
            expect: vec!["s.toml:5", "shininess = -2"],
        },
        Case {
            name: "glass with a zero index",
            files: vec![
                ("m.obj", GOOD_OBJ.into()),
                (
                    "s.toml",
                    toml_with_mesh("material = { type = \"glass\", ior = 0 }"),
                ),
            ],
            scene: "s.toml",
            expect: vec!["s.toml:5", "`ior`"],
        },
        Case {
            name: "unknown microfacet distribution",
            files: vec![
                ("m.obj", GOOD_OBJ.into()),
                (
                    "s.toml",
                    toml_with_mesh(
                        "material = { type = \"conductor\", distribution = \"phong\" }",
                    ),
                ),
            ],
            scene: "s.toml",
            expect: vec!["s.toml:5", "ggx or beckmann"],
        },
        Case {
            name: "unknown masking-shadowing form",
            files: vec![
                ("m.obj", GOOD_OBJ.into()),
                (
                    "s.toml",
                    toml_with_mesh("material = { type = \"plastic\", masking = \"smith\" }"),
                ),
            ],
            scene: "s.toml",
            expect: vec!["s.toml:5", "height-correlated or separable"],
        },
        Case {
            name: "texture file missing",
            files: vec![
                ("m.obj", GOOD_OBJ.into()),
                ("s.toml", toml_with_mesh("material = { texture = \"t.png\" }")),
            ],
            scene: "s.toml",
            expect: vec!["s.toml:5", "t.png", "not found"],
        },
        Case {
            name: "sphere with a negative radius",
            files: vec![(
                "s.toml",
                "[[sphere]]\ncenter = [0, 0, 0]\nradius = -1\n".into(),
            )],
            scene: "s.toml",
            expect: vec!["s.toml:1", "sphere.radius"],
        },
        Case {
            name: "point light without intensity",
            files: vec![(
                "s.toml",
                "[[light]]\ntype = \"point\"\nposition = [0, 1, 0]\n".into(),
            )],
            scene: "s.toml",
            expect: vec!["s.toml:1", "`intensity`"],
        },
        Case {
            name: "point light attenuated by nothing",
            files: vec![(
                "s.toml",
                "\n[[light]]\ntype = \"point\"\nposition = [0, 1, 0]\nintensity = 1\nattenuation = [0, 0, 0]\n"
                    .into(),
            )],
            scene: "s.toml",
            expect: vec!["s.toml:2", "`attenuation`"],
        },
        Case {
            name: "directional light along a zero vector",
            files: vec![(
                "s.toml",
                "[[light]]\ntype = \"directional\"\ndirection = [0, 0, 0]\nirradiance = 1\n"
                    .into(),
            )],
            scene: "s.toml",
            expect: vec!["s.toml:1", "`direction`"],
        },
        Case {
            name: "environment map file missing",
            files: vec![(
                "s.toml",
                "[[light]]\ntype = \"environment\"\nfile = \"sky.exr\"\n".into(),
            )],
            scene: "s.toml",
            expect: vec!["s.toml:1", "sky.exr", "not found"],
        },
        Case {
            name: "negative aperture",
            files: vec![(
                "s.toml",
                "[camera]\norigin = [0, 0, 3]\ntarget = [0, 0, 0]\naperture_radius = -0.1\n"
                    .into(),
            )],
            scene: "s.toml",
            expect: vec!["s.toml:4", "aperture_radius"],
        },
        Case {
            name: "aperture that takes the lens out of range",
            files: vec![(
                "s.toml",
                "[camera]\norigin = [0, 0, 3]\ntarget = [0, 0, 0]\naperture_radius = 1e30\n"
                    .into(),
            )],
            scene: "s.toml",
            expect: vec!["s.toml:4", "aperture_radius", "1.8e18"],
        },
        Case {
            name: "directional light along a denormal direction is fine, along NaN is not",
            files: vec![(
                "s.toml",
                "[[light]]\ntype = \"directional\"\ndirection = [1e-38, 0, nan]\nirradiance = 1\n"
                    .into(),
            )],
            scene: "s.toml",
            expect: vec!["s.toml:1", "`direction`"],
        },
        Case {
            name: "map_Kd that does not exist",
            files: vec![
                ("m.obj", format!("mtllib m.mtl\nusemtl a\nvt 0 0\n{GOOD_OBJ}")),
                ("m.mtl", "newmtl a\nKd 0.5 0.5 0.5\nmap_Kd none.png\n".into()),
            ],
            scene: "m.obj",
            expect: vec!["m.mtl", "none.png"],
        },
        Case {
            name: "control character in the scene",
            files: vec![("s.toml", "[camera]\norigin = [0, 0, \u{0}]\n".into())],
            scene: "s.toml",
            expect: vec!["s.toml:2"],
        },
    ]
}

#[test]
fn bad_scenes_fail_cleanly() {
    for case in cases() {
        let dir = tempfile::tempdir().unwrap();
        setup(dir.path(), &case.files);
        let before = entries(dir.path());
        let out = run(
            dir.path(),
            &[
                "render", case.scene, "-o", "out.png", "-s", "1", "-r", "8", "8", "--report",
                "r.json",
            ],
        );
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(
            out.status.code(),
            Some(1),
            "{}: exit status {:?}, stderr {stderr}",
            case.name,
            out.status
        );
        assert!(
            !stderr.contains("panicked"),
            "{}: panicked: {stderr}",
            case.name
        );
        let lines: Vec<&str> = stderr.lines().filter(|l| !l.starts_with("note:")).collect();
        assert_eq!(
            lines.len(),
            1,
            "{}: expected one error line, got {stderr}",
            case.name
        );
        for e in &case.expect {
            assert!(
                lines[0].contains(e),
                "{}: `{}` lacks `{e}`",
                case.name,
                lines[0]
            );
        }
        assert_eq!(
            entries(dir.path()),
            before,
            "{}: files left behind",
            case.name
        );
    }
}

#[test]
fn bad_settings_fail_before_rendering() {
    let dir = tempfile::tempdir().unwrap();
    setup(dir.path(), &[("m.obj", GOOD_OBJ.into())]);
    for (args, expect) in [
        (
            vec!["m.obj", "-o", "out.xyz"],
            "expected .png, .exr or .pfm",
        ),
        (vec!["m.obj", "-o", "no/such/dir/out.png"], "does not exist"),
        (vec!["m.obj", "-s", "0"], "at least one sample"),
        (vec!["m.obj", "--rr", "1.5"], "[0, 1]"),
        (vec!["m.obj", "-r", "0", "10"], "out of range"),
        // deeper paths overflowed the render threads' stacks (an abort)
        (vec!["m.obj", "-m", "5000"], "0..=1024"),
        (vec!["m.obj", "-s", "16777217"], "1..=16777216"),
        (vec!["m.obj", "-l", "1025"], "1..=1024"),
    ] {
        let out = run(dir.path(), &args);
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(1), "{args:?}: {stderr}");
        assert!(stderr.contains(expect), "{args:?}: {stderr}");
        assert!(!stderr.contains("panicked"));
    }
    assert_eq!(entries(dir.path()), vec![dir.path().join("m.obj")]);
}

#[test]
fn triangles_placed_out_of_range_are_one_warning_and_the_render_goes_on() {
    let dir = tempfile::tempdir().unwrap();
    // the second triangle's corners reach 2e18 once scaled: out of Embree's range
    // (lit, so that the only warning is the one under test)
    let toml = toml_with_mesh(
        "\n[[mesh]]\nfile = \"m.obj\"\ntransform = { scale = 2e18 }\n\n[[light]]\ntype = \"environment\"\nradiance = 1.0",
    );
    setup(dir.path(), &[("m.obj", GOOD_OBJ.into()), ("s.toml", toml)]);
    let out = run(
        dir.path(),
        &["s.toml", "-s", "1", "-r", "8", "8", "-o", "out.png"],
    );
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    let warnings: Vec<&str> = stderr
        .lines()
        .filter(|l| l.starts_with("warning:"))
        .collect();
    assert_eq!(
        warnings,
        [
            "warning: s.toml:8: mesh `m.obj`: dropped 1 triangles with coordinates beyond 1.8e18 or non-finite after transform"
        ],
        "{stderr}"
    );
    assert!(dir.path().join("out.png").is_file());
}

#[test]
fn classic_command_line_renders() {
    let dir = tempfile::tempdir().unwrap();
    setup(dir.path(), &[("m.obj", GOOD_OBJ.into())]);
    let out = run(
        dir.path(),
        &[
            "-t", "2", "-s", "2", "-l", "1", "-m", "2", "-r", "16", "12", "-f", "out.pfm", "m.obj",
            "--report", "r.json",
        ],
    );
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let (w, h, _) = embertrace::image::read_pfm(&dir.path().join("out.pfm")).unwrap();
    assert_eq!((w, h), (16, 12));
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join("r.json")).unwrap()).unwrap();
    for key in [
        "scene",
        "backend",
        "spp",
        "max_depth",
        "resolution",
        "seed",
        "sampler",
        "threads",
        "load_seconds",
        "accel_build_seconds",
        "render_seconds",
        "rays",
        "mrays_per_second",
        "nonfinite_samples",
        "mean_rgb",
    ] {
        assert!(report.get(key).is_some(), "report lacks {key}");
    }
    assert_eq!(report["spp"], 2);
    assert_eq!(report["max_depth"], 2);
    assert_eq!(report["resolution"], serde_json::json!([16, 12]));
    assert_eq!(report["threads"], 2);
    assert_eq!(report["rays"]["camera"], 16 * 12 * 2);
    assert_eq!(report["nonfinite_samples"], 0);
    // a bare mesh without emitters is lit by the white environment
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(stderr.contains("environment"), "{stderr}");
    assert!(report["mean_rgb"][0].as_f64().unwrap() > 0.0);
}

#[test]
fn the_cs184_command_line_renders_a_dae() {
    let dir = tempfile::tempdir().unwrap();
    let room = include_str!("data/collada/room.dae");
    setup(dir.path(), &[("room.dae", room.into())]);
    let out = run(
        dir.path(),
        &[
            "-t",
            "8",
            "-s",
            "2",
            "-l",
            "4",
            "-m",
            "2",
            "-r",
            "48",
            "36",
            "-f",
            "spheres.png",
            "room.dae",
            "--report",
            "r.json",
        ],
    );
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    let img = image::open(dir.path().join("spheres.png")).unwrap();
    assert_eq!((img.width(), img.height()), (48, 36));
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join("r.json")).unwrap()).unwrap();
    // -l 4 per area light: 4 from the room's area light, 1 from its point
    // light
    assert_eq!(report["light_samples"], 5);
    assert_eq!(report["max_depth"], 2);
    assert!(
        stderr.contains("camera placed as the course places it"),
        "{stderr}"
    );
}

#[test]
fn exr_output_carries_render_metadata() {
    let dir = tempfile::tempdir().unwrap();
    setup(dir.path(), &[("m.obj", GOOD_OBJ.into())]);
    let out = run(
        dir.path(),
        &[
            "render", "m.obj", "-s", "3", "--seed", "9", "-r", "8", "6", "-o", "out.exr", "-q",
        ],
    );
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(
        out.stderr.is_empty(),
        "-q printed {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let (w, h, rgb) = embertrace::image::read_exr(&dir.path().join("out.exr")).unwrap();
    assert_eq!((w, h, rgb.len()), (8, 6, 8 * 6 * 3));
    let meta = embertrace::image::read_exr_metadata(&dir.path().join("out.exr")).unwrap();
    let get = |k: &str| meta.iter().find(|(n, _)| n == k).map(|(_, v)| v.clone());
    assert_eq!(get("embertrace.spp").as_deref(), Some("3"));
    assert_eq!(get("embertrace.seed").as_deref(), Some("9"));
    // a scene of a few triangles: Embree for camera rays, the brute force
    // for the rest, where Embree is compiled in
    let want = if cfg!(any(feature = "embree", feature = "embree4")) {
        "embree+naive"
    } else {
        "bvh"
    };
    assert_eq!(get("embertrace.backend").as_deref(), Some(want));
    let secs: f64 = get("embertrace.render_seconds").unwrap().parse().unwrap();
    assert!(secs > 0.0);
}

/// Issue 21: paths need not be UTF-8. A missing scene whose name is not
/// UTF-8 gets the one-line error (it used to panic in `std::env::args`),
/// and such a name works as the output.
#[cfg(unix)]
#[test]
fn paths_that_are_not_utf8_are_files_like_any_other() {
    use std::ffi::OsStr;
    use std::os::unix::ffi::OsStrExt;
    let dir = tempfile::tempdir().unwrap();
    setup(dir.path(), &[("m.obj", GOOD_OBJ.into())]);
    let scene = OsStr::from_bytes(b"sc\xffene.toml");
    let out = Command::new(env!("CARGO_BIN_EXE_embertrace"))
        .current_dir(dir.path())
        .arg("render")
        .arg(scene)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(!err.contains("panicked"), "{err}");
    assert!(err.contains("ene.toml"), "{err}");
    let image = OsStr::from_bytes(b"out\xfe.png");
    let out = Command::new(env!("CARGO_BIN_EXE_embertrace"))
        .current_dir(dir.path())
        .args(["render", "m.obj", "-q", "-r", "4", "4", "-s", "1", "-o"])
        .arg(image)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(dir.path().join(image).is_file());
}

/// Issue 21: `-t 100000` spent tens of seconds starting threads; every
/// command takes its threads from one place, which refuses more than
/// `MAX_THREADS` with one line and writes nothing.
#[test]
fn absurd_thread_counts_are_refused_in_every_command() {
    let dir = tempfile::tempdir().unwrap();
    setup(dir.path(), &[("m.obj", GOOD_OBJ.into())]);
    for args in [
        vec![
            "render", "m.obj", "-r", "4", "4", "-s", "1", "-t", "100000", "-o", "a.png",
        ],
        vec![
            "bench", "m.obj", "--rays", "10", "--reps", "1", "-t", "100000",
        ],
        vec![
            "study", "m.obj", "--out", "st", "-t", "100000", "-s", "1", "-r", "4", "4",
        ],
    ] {
        let out = run(dir.path(), &args);
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(1), "{args:?}: {err}");
        assert!(err.contains("at most 1024 threads"), "{args:?}: {err}");
    }
    assert!(!dir.path().join("a.png").exists());
}

/// Issue 21: a scene in which nothing emits, and a scene whose only light
/// collapsed to zero area in f32 (the Cornell box scaled by 1e-3 and moved
/// 1e4 from the origin), render black: each gets a warning naming why.
#[test]
fn scenes_that_lose_or_lack_their_light_say_so() {
    let dir = tempfile::tempdir().unwrap();
    let scenes = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes");
    for f in ["cornell-box.obj", "cornell-box.mtl"] {
        std::fs::copy(scenes.join(f), dir.path().join(f)).unwrap();
    }
    setup(
        dir.path(),
        &[
            ("m.obj", GOOD_OBJ.into()),
            ("dark.toml", toml_with_mesh("")),
            (
                "far.toml",
                "[camera]\norigin = [10000.0, 10000.001, 10000.0039]\ntarget = [10000.0, 10000.001, 10000.0]\n\
                 up = [0, 1, 0]\nfov_y = 39.3\n\n[[mesh]]\nfile = \"cornell-box.obj\"\n\
                 transform = { scale = 0.001, translate = [10000, 10000, 10000] }\n"
                    .into(),
            ),
            (
                "distant.toml",
                "[camera]\norigin = [0, 0, 0]\ntarget = [10000.0, 10000.001, 10000.0]\n\
                 up = [0, 1, 0]\nfov_y = 39.3\n\n[[mesh]]\nfile = \"cornell-box.obj\"\n\
                 transform = { scale = 0.001, translate = [10000, 10000, 10000] }\n"
                    .into(),
            ),
            (
                "lit.toml",
                "[camera]\norigin = [0.0, 1.0, 3.9]\ntarget = [0.0, 1.0, 0.0]\n\n[[mesh]]\nfile = \"cornell-box.obj\"\n".into(),
            ),
        ],
    );
    let warnings = |scene: &str| {
        let out = run(
            dir.path(),
            &["render", scene, "-r", "8", "8", "-s", "1", "-o", "x.png"],
        );
        assert!(out.status.success());
        String::from_utf8_lossy(&out.stderr)
            .lines()
            .filter(|l| l.starts_with("warning:"))
            .map(str::to_string)
            .collect::<Vec<_>>()
    };
    let dark = warnings("dark.toml");
    assert!(
        dark.iter().any(|w| w.contains("nothing emits light")),
        "{dark:?}"
    );
    // moved 1e4 from the origin with its camera: rebased, the box keeps
    // its light (it lost it before scenes were rebased)
    assert_eq!(warnings("far.toml"), Vec::<String>::new());
    // seen from the origin, 1.7e4 away, the light is too small for f32 at
    // that distance from the camera: no rebasing recovers it
    let distant = warnings("distant.toml");
    assert!(
        distant
            .iter()
            .any(|w| w.contains("distant.toml:7")
                && w.contains("2 emitting triangles have zero area")),
        "{distant:?}"
    );
    assert!(
        distant.iter().any(|w| w.contains("nothing emits light")),
        "{distant:?}"
    );
    assert_eq!(warnings("lit.toml"), Vec::<String>::new());
}

/// `completions SHELL` prints a script that completes the subcommands and
/// their flags; `man` prints a roff page naming them; an unknown shell is a
/// one-line error.
#[test]
fn completions_and_the_man_page_name_every_subcommand() {
    let dir = tempfile::tempdir().unwrap();
    let text = |args: &[&str]| {
        let o = run(dir.path(), args);
        assert!(
            o.status.success(),
            "{args:?}: {}",
            String::from_utf8_lossy(&o.stderr)
        );
        String::from_utf8(o.stdout).unwrap()
    };
    let bash = text(&["completions", "bash"]);
    assert!(bash.contains("_embertrace()") && bash.contains("complete -F _embertrace"));
    let fish = text(&["completions", "fish"]);
    let zsh = text(&["completions", "zsh"]);
    assert!(zsh.starts_with("#compdef embertrace"));
    let man = text(&["man"]);
    assert!(man.contains(".TH embertrace 1"));
    for sub in [
        "render", "plan", "convert", "merge", "bench", "parity", "diff", "study",
    ] {
        assert!(bash.contains(sub), "bash lacks {sub}");
        assert!(
            fish.contains(&format!("-a \"{sub}\"")) || fish.contains(&format!("-f -a \"{sub}\"")),
            "fish lacks {sub}"
        );
        assert!(man.contains(sub), "man page lacks {sub}");
    }
    // render's flags complete too
    assert!(bash.contains("--time-limit") && fish.contains("time-limit"));
    let o = run(dir.path(), &["completions", "tcsh"]);
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(err.trim().lines().count(), 1, "{err}");
}
