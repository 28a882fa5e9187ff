//! Shared by the coverage-guided fuzz targets: write one scene's files into
//! a scratch folder (the fuzzer's input replacing one of them), load the
//! entry file, and check what `tests/fuzz_loaders.rs` checks: no panic
//! (libFuzzer reports one), and an error is one line naming a file.

use embertrace::scene::Scene;
use std::path::PathBuf;
use std::sync::OnceLock;

pub const TOML: &str = "[camera]\norigin = [0.0, 1.0, 3.9]\ntarget = [0.0, 1.0, 0.0]\n\
[film]\nresolution = [64, 48]\n[render]\nspp = 4\nmax_depth = 5\n\
[[mesh]]\nfile = \"mesh.obj\"\ntransform = { scale = 1.0, rotate = [0.0, 1.0, 0.0, 30.0] }\n\
[[procedural]]\ntype = \"sphere\"\ntriangles = 100\n\
[[light]]\ntype = \"environment\"\nradiance = 0.5\n";

pub const OBJ: &str = "mtllib mesh.mtl\nv -1 0 1\nv 1 0 1\nv 1 0 -1\nv -1 0 -1\n\
vt 0 0\nvn 0 1 0\nusemtl white\nf 1/1/1 2/1/1 3/1/1\nf 1 3 4\n";

pub const MTL: &str = "newmtl white\nKd 0.7 0.7 0.7\nnewmtl light\nKe 10 10 10\n";

fn dir() -> &'static PathBuf {
    static DIR: OnceLock<PathBuf> = OnceLock::new();
    DIR.get_or_init(|| tempfile::tempdir().expect("scratch folder").keep())
}

/// Write the scene with `target` replaced by `data`, then load `entry`.
pub fn run(data: &[u8], target: &str, entry: &str) {
    let dir = dir();
    for (name, text) in [("scene.toml", TOML), ("mesh.obj", OBJ), ("mesh.mtl", MTL)] {
        let bytes = if name == target {
            data
        } else {
            text.as_bytes()
        };
        std::fs::write(dir.join(name), bytes).expect("scratch write");
    }
    if let Err(e) = Scene::load(&dir.join(entry)) {
        let msg = e.to_string();
        assert!(!msg.contains('\n'), "error is not one line: {msg:?}");
        assert!(
            ["scene.toml", "mesh.obj", "mesh.mtl", ".mtl", ".png"]
                .iter()
                .any(|f| msg.contains(f)),
            "error names no file: {msg}"
        );
    }
}
