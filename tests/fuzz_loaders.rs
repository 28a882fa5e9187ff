//! A bounded, deterministic mutation fuzzer for every scene loader (issue 4
//! item 5, hard case 28): the TOML scene, the OBJ mesh (through tobj), its
//! MTL library and the `[[procedural]]` source. Each input is a bundled or
//! hand-written seed file with one to four random mutations (byte changes,
//! hostile tokens such as `nan`, `1e30`, `4294967296`, huge indices or
//! counts, deleted or repeated ranges, truncation; invalid UTF-8 included).
//!
//! Every load must return (no panic), within a time bound (no hang), and an
//! error must be one line naming one of the scene's files. The smoke run in
//! CI tries `EMBERTRACE_FUZZ_ITERS` inputs per loader (default 2000, about a
//! second each); set it
//! higher for a longer campaign. A failing input is written to
//! `target/fuzz-failure-*` for reproduction.
//!
//! cargo-fuzz needs a nightly toolchain, which this project does not use;
//! a seeded mutator on stable Rust keeps the smoke run reproducible.

use embertrace::sampler::Sampler;
use embertrace::scene::Scene;
use std::panic::{AssertUnwindSafe, catch_unwind};
use std::path::Path;
use std::time::{Duration, Instant};

/// The most one load may take before it counts as a hang (generous: CI
/// machines are shared, and the largest input the mutator can reach is a
/// procedural mesh of a few million triangles).
const HANG: Duration = Duration::from_secs(20);

const TOML: &str = r#"# fuzz seed
[camera]
origin = [0.0, 1.0, 3.9]
target = [0.0, 1.0, 0.0]
up     = [0.0, 1.0, 0.0]
fov_y  = 39.3

[film]
resolution = [64, 48]

[render]
spp = 4
max_depth = 5
light_samples = 1
seed = 0

[[mesh]]
file = "mesh.obj"
transform = { scale = 1.0, rotate = [0.0, 1.0, 0.0, 30.0], translate = [0.0, 0.5, 0.0] }

[[mesh]]
file = "mesh.obj"
material = { diffuse = [0.5, 0.4, 0.3], emission = 2.0, two_sided = true }

[[light]]
type = "environment"
radiance = [0.2, 0.3, 0.4]
"#;

const PROCEDURAL: &str = r#"[camera]
origin = [0.0, 1.2, 3.6]
target = [0.0, 0.6, 0.0]
fov_y  = 39.3

[[procedural]]
type = "sphere"
triangles = 200
displacement = 0.15
seed = 1
transform = { scale = 0.8, translate = [0.0, 0.9, 0.0] }
material = { diffuse = [0.8, 0.6, 0.4] }

[[procedural]]
type = "terrain"
triangles = 100
displacement = 0.05
seed = 2
"#;

const OBJ: &str = "# fuzz seed\nmtllib mesh.mtl\n\
v -1 0 1\nv 1 0 1\nv 1 0 -1\nv -1 0 -1\nv -1 2 -1\nv 1 2 -1\n\
vt 0 0\nvt 1 0\nvt 1 1\nvn 0 1 0\n\
o floor\nusemtl white\nf 1 2 3\nf 1/1 3/2 4/3\n\
o back\nusemtl light\nf 4//1 3//1 6//1\nf 4 6 5\nf -1 -2 -3\n";

const MTL: &str = "# fuzz seed\nnewmtl white\nKd 0.725 0.71 0.68\n\n\
newmtl light\nKd 0.78 0.78 0.78\nKe 17 12 4\n";

/// Tokens that tend to break parsers and loaders.
const TOKENS: &[&str] = &[
    "nan",
    "inf",
    "-inf",
    "NaN",
    "1e30",
    "-1e30",
    "1e39",
    "-1",
    "0",
    "-0",
    "4294967296",
    "18446744073709551616",
    "99999999999999999999",
    "1_000_000_000",
    "0x10",
    "\n",
    "\r\n",
    "\t",
    " ",
    "[",
    "]",
    "[[",
    "]]",
    "{",
    "}",
    "=",
    "\"",
    "'",
    "#",
    ",",
    ".",
    "/",
    "//",
    "f 1 2 3\n",
    "f 0 0 0\n",
    "f 1 2 99999999999\n",
    "f -9 -8 -7\n",
    "f 1\n",
    "v 1e38 1e38 1e38\n",
    "v nan 0 0\n",
    "v 1 2\n",
    "vn 0 0 0\n",
    "vt\n",
    "mtllib missing.mtl\n",
    "mtllib .\n",
    "mtllib /\n",
    "usemtl nothere\n",
    "newmtl\n",
    "Kd -1 2 nan\n",
    "Ke 1e30 0 0\n",
    "map_Kd x.png\n",
    "\u{0}",
    "\u{feff}",
    "\u{fffd}",
    "file = \".\"",
    "file = \"/\"",
    "file = \"mesh.mtl\"",
    "triangles = 1000000",
    "resolution = [1000000000, 1000000000]",
    "spp = 0",
    "type = \"cube\"",
    "[[mesh]]\n",
    "[[procedural]]\n",
    "[[light]]\n",
    "[camera]\n",
    "fov_y = 0",
    "fov_y = 180",
    "scale = 0",
    "scale = 1e30",
    "rotate = [0.0, 0.0, 0.0, 90.0]",
];

/// One to four mutations of `input`.
fn mutate(input: &[u8], s: &mut Sampler) -> Vec<u8> {
    let mut v = input.to_vec();
    let at = |s: &mut Sampler, len: usize| (s.next_u32() as usize) % (len + 1);
    for _ in 0..1 + s.next_u32() % 4 {
        match s.next_u32() % 6 {
            0 if !v.is_empty() => {
                let i = at(s, v.len() - 1);
                v[i] = s.next_u32() as u8;
            }
            1 | 2 => {
                let i = at(s, v.len());
                let t = TOKENS[s.next_u32() as usize % TOKENS.len()].as_bytes();
                v.splice(i..i, t.iter().copied());
            }
            3 if !v.is_empty() => {
                let i = at(s, v.len() - 1);
                let j = (i + 1 + s.next_u32() as usize % 40).min(v.len());
                v.drain(i..j);
            }
            4 if !v.is_empty() => {
                let i = at(s, v.len() - 1);
                let j = (i + 1 + s.next_u32() as usize % 80).min(v.len());
                let copy = v[i..j].to_vec();
                v.splice(j..j, copy);
            }
            _ => {
                let i = at(s, v.len());
                v.truncate(i);
            }
        }
    }
    v
}

fn iterations() -> u64 {
    std::env::var("EMBERTRACE_FUZZ_ITERS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(2000)
}

/// Fuzz file `target` of a scene made of `files`, loading `entry`.
fn fuzz(name: &str, files: &[(&str, &str)], target: &str, entry: &str) {
    let dir = tempfile::tempdir().unwrap();
    let names: Vec<&str> = files.iter().map(|f| f.0).collect();
    let seed_text = files.iter().find(|f| f.0 == target).unwrap().1.as_bytes();
    let n = iterations();
    let (mut ok, mut errors) = (0u64, 0u64);
    let start = Instant::now();
    for i in 0..n {
        let mut s = Sampler::new(0xf022, name.len() as u64, i);
        let input = mutate(seed_text, &mut s);
        for (f, text) in files {
            let bytes = if *f == target {
                &input[..]
            } else {
                text.as_bytes()
            };
            std::fs::write(dir.path().join(f), bytes).unwrap();
        }
        let path = dir.path().join(entry);
        let t = Instant::now();
        let result = catch_unwind(AssertUnwindSafe(|| Scene::load(&path)));
        let took = t.elapsed();
        let keep = |why: &str| {
            let out =
                Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("fuzz-failure-{name}-{i}"));
            std::fs::write(&out, &input).unwrap();
            panic!("{name} input {i} ({}): {why}", out.display());
        };
        match result {
            Err(_) => keep("the loader panicked"),
            Ok(Ok(_)) => ok += 1,
            Ok(Err(e)) => {
                errors += 1;
                let msg = e.to_string();
                if msg.contains('\n') || msg.trim().is_empty() {
                    keep(&format!("error is not one line: {msg:?}"));
                }
                if !names.iter().any(|f| msg.contains(f))
                    && !msg.contains("missing.mtl")
                    && !msg.contains("x.png")
                {
                    keep(&format!("error names no file: {msg}"));
                }
            }
        }
        if took > HANG {
            keep(&format!("took {took:?}"));
        }
    }
    eprintln!(
        "fuzz {name}: {n} inputs in {:.2} s ({ok} loaded, {errors} clean errors)",
        start.elapsed().as_secs_f64()
    );
    assert!(
        errors > 0,
        "{name}: no mutation was rejected: the mutator does nothing"
    );
}

#[test]
fn fuzz_toml_scene() {
    let files = [("scene.toml", TOML), ("mesh.obj", OBJ), ("mesh.mtl", MTL)];
    fuzz("toml", &files, "scene.toml", "scene.toml");
}

#[test]
fn fuzz_procedural_scene() {
    fuzz(
        "procedural",
        &[("scene.toml", PROCEDURAL)],
        "scene.toml",
        "scene.toml",
    );
}

#[test]
fn fuzz_obj_mesh() {
    let files = [("scene.toml", TOML), ("mesh.obj", OBJ), ("mesh.mtl", MTL)];
    fuzz("obj-in-toml", &files, "mesh.obj", "scene.toml");
    fuzz("obj", &files, "mesh.obj", "mesh.obj");
}

#[test]
fn fuzz_mtl_library() {
    let files = [("scene.toml", TOML), ("mesh.obj", OBJ), ("mesh.mtl", MTL)];
    fuzz("mtl", &files, "mesh.mtl", "mesh.obj");
}

/// Many tables load in time linear in the file. Finding each table's line
/// used to scan the whole file (20,000 `[[light]]` tables took 8.3 s, and
/// the time grew with their square), and each `[[mesh]]` parsed its OBJ
/// again.
#[test]
fn many_tables_load_in_linear_time() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("mesh.obj"), OBJ).unwrap();
    std::fs::write(dir.path().join("mesh.mtl"), MTL).unwrap();
    let n = 40_000;
    let mut toml = String::from("[camera]\norigin = [0, 0, 3]\ntarget = [0, 0, 0]\n");
    for _ in 0..n {
        toml.push_str("[[light]]\ntype = \"environment\"\nradiance = 0.00001\n");
        toml.push_str("[[mesh]]\nfile = \"mesh.obj\"\n");
    }
    std::fs::write(dir.path().join("scene.toml"), toml).unwrap();
    let t = Instant::now();
    let scene = Scene::load(&dir.path().join("scene.toml")).unwrap();
    let took = t.elapsed();
    assert_eq!(scene.meshes.len(), n);
    // 10 s: room for a loaded CI machine, and a small fraction of the
    // quadratic time
    assert!(took < Duration::from_secs(10), "{took:?}");
}
