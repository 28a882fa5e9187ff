//! Hostile scene files (issue 21 item 3): inputs that are not what their
//! extension says, that never end, that are too large, or that carry more
//! than the format allows. Each gets a one-line error naming the file (and
//! the line where there is one), exit 1 and no image; or, where rendering
//! on is right, a warning naming what was read past.

use std::path::Path;
use std::process::{Command, Output};

fn run(dir: &Path, args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_embertrace"))
        .current_dir(dir)
        .args(args)
        .output()
        .unwrap()
}

/// Render `scene` in `dir`; the error's single line, after checking the exit
/// code, that nothing panicked and that no image was written.
fn refused(dir: &Path, scene: &str) -> String {
    let out = run(dir, &["render", scene, "-o", "out.png", "-s", "1", "-q"]);
    let err = String::from_utf8_lossy(&out.stderr).into_owned();
    assert_eq!(out.status.code(), Some(1), "{scene}: {err}");
    assert!(!err.contains("panicked"), "{scene}: {err}");
    assert_eq!(err.trim().lines().count(), 1, "{scene}: one line: {err}");
    assert!(!dir.join("out.png").exists(), "{scene}: no image");
    err
}

/// Render `scene` in `dir`: it must succeed; its stderr.
fn renders(dir: &Path, scene: &str) -> String {
    let out = run(
        dir,
        &["render", scene, "-o", "out.png", "-s", "1", "-r", "8", "8"],
    );
    let err = String::from_utf8_lossy(&out.stderr).into_owned();
    assert!(out.status.success(), "{scene}: {err}");
    err
}

const EXTENSIONS: [&str; 6] = ["toml", "obj", "ply", "xml", "dae", "test"];

#[test]
fn a_device_that_never_ends_is_refused_at_once() {
    let dir = tempfile::tempdir().unwrap();
    for ext in EXTENSIONS {
        let name = format!("zero.{ext}");
        std::os::unix::fs::symlink("/dev/zero", dir.path().join(&name)).unwrap();
        let err = refused(dir.path(), &name);
        assert!(err.contains(&name), "{err}");
        // the loader stops at the first chunk: a NUL byte in a text format,
        // the wrong magic in PLY
        assert!(
            err.contains("NUL") || err.contains("does not start with `ply`"),
            "{err}"
        );
    }
}

#[test]
fn files_over_the_size_limit_are_refused_before_they_are_read() {
    let dir = tempfile::tempdir().unwrap();
    for ext in EXTENSIONS {
        let name = format!("big.{ext}");
        // a sparse 2 GB file: reading it would take 2 GB of memory
        let f = std::fs::File::create(dir.path().join(&name)).unwrap();
        f.set_len(2 << 30).unwrap();
        let err = refused(dir.path(), &name);
        assert!(err.contains(&name), "{err}");
        assert!(err.contains("2147483648 bytes: larger than"), "{err}");
    }
}

#[test]
fn text_that_is_not_a_mesh_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path();
    // /etc/passwd-like text: no statement is OBJ
    std::fs::write(
        p.join("passwd.obj"),
        "root:x:0:0:root:/root:/bin/bash\ndaemon:x:1:1:daemon:/usr/sbin:/usr/sbin/nologin\n",
    )
    .unwrap();
    let err = refused(p, "passwd.obj");
    assert!(err.contains("passwd.obj:1"), "{err}");
    assert!(err.contains("not an OBJ file"), "{err}");
    // UTF-16 (little-endian, with its byte-order mark) has a NUL in every
    // ASCII character
    let utf16: Vec<u8> = "\u{feff}v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n"
        .encode_utf16()
        .flat_map(u16::to_le_bytes)
        .collect();
    std::fs::write(p.join("utf16.obj"), &utf16).unwrap();
    let err = refused(p, "utf16.obj");
    assert!(
        err.contains("utf16.obj:1") && err.contains("UTF-16"),
        "{err}"
    );
    // random bytes (a fixed seed; xorshift)
    let mut x = 0x9e37_79b9_7f4a_7c15u64;
    let random: Vec<u8> = (0..4096)
        .map(|_| {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            x as u8
        })
        .collect();
    for ext in ["obj", "ply"] {
        let name = format!("random.{ext}");
        std::fs::write(p.join(&name), &random).unwrap();
        let err = refused(p, &name);
        assert!(err.contains(&name), "{err}");
    }
}

#[test]
fn statements_read_past_are_warnings_naming_their_lines() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path();
    std::fs::write(
        p.join("m.obj"),
        "mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl red\nf 1 2 3\nfrobnicate 1 2\ncstype bspline\n",
    )
    .unwrap();
    std::fs::write(
        p.join("m.mtl"),
        "newmtl red\nKd 0.5 0 0\nKe 1 1 1\nmap_Bump bumps.png\nd 0.5\nmap_Ks spec.png\nd 1\n",
    )
    .unwrap();
    let err = renders(p, "m.obj");
    for want in [
        "m.obj:7: 1 lines start with something that is not an OBJ statement",
        "m.obj:8: `cstype` and other free-form",
        "m.mtl:4: `map_Bump` is not rendered",
        "m.mtl:5: `d` is not rendered",
        "m.mtl:6: `map_Ks` is not rendered",
    ] {
        assert!(err.contains(want), "missing `{want}` in:\n{err}");
    }
    // `d 1` (opaque) changes nothing: no second warning for `d`
    assert_eq!(err.matches("`d` is not rendered").count(), 1, "{err}");
}

#[test]
fn material_errors_name_the_line_of_their_material() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path();
    std::fs::write(
        p.join("m.obj"),
        "mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl b\nf 1 2 3\n",
    )
    .unwrap();
    std::fs::write(
        p.join("m.mtl"),
        "newmtl a\nKd 0.5 0.5 0.5\n\nnewmtl b\nKd 0.5 0.5 0.5\nmap_Kd missing.png\n",
    )
    .unwrap();
    let err = refused(p, "m.obj");
    assert!(err.contains("m.mtl:4: material `b`"), "{err}");
}

#[test]
fn arrays_with_extra_or_missing_elements_are_refused_at_their_line() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path();
    std::fs::write(p.join("m.obj"), "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").unwrap();
    let base = "[camera]\norigin = [0, 0, 3]\ntarget = [0, 0, 0]\n\n[[mesh]]\nfile = \"m.obj\"\n\n[[light]]\ntype = \"environment\"\nradiance = 1\n";
    for (extra, line) in [
        ("[film]\nresolution = [16, 16, 99]\n", 12),
        ("[film]\nresolution = [16]\n", 12),
    ] {
        std::fs::write(p.join("s.toml"), format!("{base}{extra}")).unwrap();
        let err = refused(p, "s.toml");
        assert!(err.contains(&format!("s.toml:{line}")), "{err}");
        assert!(err.contains("expected an array of 2 numbers"), "{err}");
    }
    let four = base.replace("origin = [0, 0, 3]", "origin = [0, 0, 3, 1]");
    std::fs::write(p.join("s.toml"), four).unwrap();
    let err = refused(p, "s.toml");
    assert!(
        err.contains("s.toml:2") && err.contains("3 numbers, got 4"),
        "{err}"
    );
    let translate = base.replace(
        "file = \"m.obj\"",
        "file = \"m.obj\"\ntransform = { translate = [1, 2, 3, 4] }",
    );
    std::fs::write(p.join("s.toml"), translate).unwrap();
    let err = refused(p, "s.toml");
    assert!(err.contains("s.toml:7") && err.contains("got 4"), "{err}");
}

#[test]
fn camera_errors_name_the_line_of_their_key() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path();
    let cases = [
        // the key's own line, not `[camera]`'s (line 1)
        (
            "[camera]\norigin = [0, 0, 3]\ntarget = [0, 0, 0]\nfov_y = 200\n",
            "s.toml:4",
        ),
        (
            "[camera]\norigin = [0, 0, 3]\n\ntarget = [0, 0, 3]\n",
            "s.toml:4",
        ),
        (
            "[camera]\norigin = [0, 0, 3]\ntarget = [0, 0, 0]\n\nup = [0, 0, 1]\n",
            "s.toml:5",
        ),
        (
            "[camera]\norigin = [0, 0, 3]\ntarget = [0, 0, 0]\nfocal_pixels = -1\n",
            "s.toml:4",
        ),
        (
            "[camera]\norigin = [0, 0, 3]\ntarget = [0, 0, 0]\n\naperture_radius = -1\n",
            "s.toml:5",
        ),
    ];
    for (text, want) in cases {
        std::fs::write(p.join("s.toml"), text).unwrap();
        let err = refused(p, "s.toml");
        assert!(err.contains(want), "{text}: {err}");
    }
}

#[test]
fn a_bare_flat_mesh_is_framed_face_on_and_renders() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path();
    // a floor in the y = 0 plane: framed from +z it was edge-on and empty
    std::fs::write(
        p.join("floor.obj"),
        "v -1 0 -1\nv 1 0 -1\nv 1 0 1\nv -1 0 1\nf 1 3 2\nf 1 4 3\n",
    )
    .unwrap();
    let out = run(
        p,
        &[
            "render",
            "floor.obj",
            "-o",
            "out.pfm",
            "-s",
            "4",
            "-r",
            "16",
            "16",
            "-q",
        ],
    );
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    // the floor fills the middle of the frame: the centre pixel sees it (a
    // white environment over a grey floor is under 1), the corners see sky
    let img = embertrace::image::read_pfm(&p.join("out.pfm")).unwrap();
    let at = |x: usize, y: usize| img.2[3 * (y * 16 + x)];
    assert!(at(8, 8) > 0.0 && at(8, 8) < 0.99, "centre {}", at(8, 8));
}

#[test]
fn outputs_onto_the_meshes_a_scene_reads_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path();
    let obj = "mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl w\nf 1 2 3\n";
    std::fs::write(p.join("m.obj"), obj).unwrap();
    std::fs::write(p.join("m.mtl"), "newmtl w\nKd 0.5 0.5 0.5\nKe 1 1 1\n").unwrap();
    std::fs::write(
        p.join("s.toml"),
        "[camera]\norigin = [0, 0, 3]\ntarget = [0, 0, 0]\n\n[[mesh]]\nfile = \"m.obj\"\n",
    )
    .unwrap();
    for args in [
        ["render", "s.toml", "--report", "m.obj"],
        ["render", "s.toml", "--report", "m.mtl"],
    ] {
        let out = run(p, &args);
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(1), "{args:?}: {err}");
        assert!(err.contains("a mesh file s.toml reads"), "{args:?}: {err}");
    }
    assert_eq!(std::fs::read_to_string(p.join("m.obj")).unwrap(), obj);
    // a conversion whose meshes would land on the mesh its scene reads: a
    // scene `a.toml` reading `b-mesh-0.obj`, converted to `b.toml`
    let out = run(p, &["convert", "m.obj", "b.toml"]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    std::fs::rename(p.join("b.toml"), p.join("a.toml")).unwrap();
    let mesh = std::fs::read(p.join("b-mesh-0.obj")).unwrap();
    let out = run(p, &["convert", "a.toml", "b.toml"]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(
        err.contains("b-mesh-0.obj") && err.contains("a mesh file a.toml reads"),
        "{err}"
    );
    assert_eq!(std::fs::read(p.join("b-mesh-0.obj")).unwrap(), mesh);
    assert!(!p.join("b.toml").exists());
}
