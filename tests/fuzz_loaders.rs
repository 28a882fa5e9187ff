//! A bounded, deterministic mutation fuzzer for every scene loader (issue 4
//! item 5, hard case 28): the TOML scene, the OBJ mesh (through tobj), its
//! MTL library, the `[[procedural]]` source, PLY meshes (ASCII and both
//! binary byte orders), Mitsuba 3 XML scenes, CS184 COLLADA `.dae` scenes,
//! CSE 167/168 `.test` scenes, glTF 2.0 (`.gltf` and `.glb`) and pbrt-v4.
//! Each input is a bundled or hand-written seed file with one to four random
//! mutations (byte changes, hostile tokens such as `nan`, `1e30`,
//! `4294967296`, huge indices or counts, deleted or repeated ranges,
//! truncation; invalid UTF-8 included).
//!
//! Every load must return (no panic), within a bound on its work (no hang:
//! each load runs on its own thread, and the test fails if that thread has
//! used [`HANG_CPU_TICKS`] of CPU time without answering: CPU time, not
//! wall-clock time, so that other tests loading the machine cannot make a
//! slow load look like a hang), and an error must be one line naming one of
//! the scene's files.
//! Memory is bounded by the scene limits (`embertrace::limits`), which
//! `tests/cli.rs` and the loaders' unit tests check directly.
//!
//! Each loader gets `EMBERTRACE_FUZZ_ITERS` inputs (default 200, so that
//! `cargo test` stays quick); `scripts/fuzz` is the CI smoke run (2000 per
//! loader unless the variable says otherwise). A failing input is written to
//! `target/tmp/fuzz-failure-*` for reproduction.
//!
//! **The run's seed.** Input `i` of a loader is a function of the run's seed
//! (`EMBERTRACE_FUZZ_SEED`, a `u64`, decimal or `0x` hex), the loader's name
//! and `i` alone, so a run replays exactly from its seed. Unset, the seed is
//! fresh (from the process's random hash keys), so that every run tries new
//! inputs; each loader prints the seed first, as a command that replays it,
//! and a failure repeats it. `scripts/fuzz` (the CI step) chooses a fresh
//! seed itself and prints it before building. Each loader also prints a
//! digest of its inputs: the same seed gives the same digest.
//!
//! This seeded mutator runs on stable Rust. For coverage-guided campaigns,
//! `fuzz/` holds cargo-fuzz targets for the same loaders
//! (`cargo +nightly fuzz run toml_scene`).

use embertrace::sampler::Sampler;
use embertrace::scene::Scene;
use std::path::Path;
use std::sync::{OnceLock, mpsc};
use std::time::{Duration, Instant};

/// The CPU time (clock ticks of `/proc`, 1/100 s) one load may use before
/// it counts as a hang: 20 s, generous, as the largest mesh the mutator can
/// ask for is a procedural one of a few million triangles; a true hang
/// (a loop) never answers and uses CPU time all along. A thread blocked
/// without using CPU is left to the test harness's own timeout.
const HANG_CPU_TICKS: u64 = 2000;

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

[[mesh]]
file = "mesh.obj"
material = { type = "plastic", diffuse = 0.5, ior = 1.5, alpha = 0.1 }

[[sphere]]
center = [0.3, 0.4, -0.2]
radius = 0.3
material = { type = "glass", ior = 1.5, reflectance = 1.0, transmittance = [1.0, 0.9, 0.8] }

[[sphere]]
center = [-0.4, 0.3, 0.1]
radius = 0.25
material = { type = "conductor", alpha = 0.2, eta = [0.2, 0.4, 1.4], k = 3.0, distribution = "beckmann", emission = 0.5 }

[[light]]
type = "point"
position = [0.0, 1.8, 0.0]
intensity = [2.0, 2.0, 2.0]

[[light]]
type = "directional"
direction = [0.3, -1.0, 0.2]
irradiance = 1.5
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

/// Hostile seeds: every value at or next to its limit
/// (`embertrace::limits`), the inline-array spelling of tables,
/// out-of-range placements, and comments and quoting in odd places, so that
/// one or two mutations reach the edges.
const TOML_EDGES: &str = r#"mesh = [{ file = "mesh.obj", transform = { scale = [1e18, -1e18, 1e18], translate = [9e17, 0, -9e17] } }, { 'file' = 'mesh.obj', material = { two_sided = false, emission = [0, 0, 1e30] } }, { file = "mesh.obj", material = { type = "mirror", reflectance = 1 } }]
light = [{ type = "environment", radiance = 0 }, { type = "point", position = [1.8e18, 0, 0], intensity = 3e38 }, { type = "directional", direction = [1e-38, 0, 0], irradiance = 1e30 }]
sphere = [{ center = [1.7e18, 0, 0], radius = 1e17 }, { center = [0, 0, 0], radius = 1e-38, material = { type = "glass", ior = 1e-30 } }]
procedural = [{ type = "terrain", triangles = 8, displacement = -0.9, seed = 18446744073709551615, transform = { rotate = [1e-19, 0, 0, 1e30] } }]
[camera] # comment
"origin" = [1.8e18, -1.8e18, 1.8e18]
target = [-0.0, 0.0, 0.0]
up = [1e-38, 1, 0]
fov_y = 179.99
aperture_radius = 1e30
focus_distance = 1e-38
[film]
resolution = [32768, 8192]
[render]
spp = 16777216
max_depth = 1024
light_samples = 1024
seed = 0x7fffffffffffffff
"#;

/// Polygons, negative and mixed index forms, groups and smoothing, points
/// and lines, CRLF, tabs, comments after values, a vertex with colours.
const OBJ_EDGES: &str = "mtllib mesh.mtl\r\nv 0 0 0\r\nv 1.8e18 0 0 # far\nv\t0 1 0 1.0 0.5 0.25\n\
v -1e-45 -0 1\nv 1 1 1\nvt 0.5 0.5 0\nvn 0 0 -1\ng a b\ns off\ns 1\no\n\
usemtl light\nf 1 2 3 4 5 -1 -2 -3\nf -5/-1/-1 -4/1/1 -3//1\np 1 2\nl 1 2 3\n\
usemtl nothere\nusemtl\nf 1/1/1 2/1/1 3/1/1 # tail\n";

/// Every statement tobj reads, including texture maps and a repeated name.
const MTL_EDGES: &str = "newmtl white\nKa 0 0 0\nKd 1 1 1\nKs 0 0 0\nNs 10\nNi 1.5\nd 1\nTr 0\n\
illum 2\nKe 0 0 0\nmap_Kd tex.png\nmap_Ks s.png\nmap_Ns n.png\nmap_d d.png\nmap_Bump b.png\n\
newmtl white\nKd 0 0 0\n\tnewmtl light\t\nKe 1e30 1e30 1e30\nTf 1 1 1\n";

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

/// The run's seed: `EMBERTRACE_FUZZ_SEED`, or a fresh one, the same for
/// every loader of this process.
fn run_seed() -> u64 {
    static SEED: OnceLock<u64> = OnceLock::new();
    *SEED.get_or_init(|| match std::env::var("EMBERTRACE_FUZZ_SEED") {
        Ok(v) => parse_seed(&v).unwrap_or_else(|| {
            panic!("EMBERTRACE_FUZZ_SEED={v:?} is not a u64 (decimal or 0x hex)")
        }),
        Err(_) => {
            use std::hash::{BuildHasher, Hasher};
            // std's hash keys are drawn from the OS's random source
            let mut h = std::collections::hash_map::RandomState::new().build_hasher();
            h.write_u128(
                std::time::SystemTime::now()
                    .duration_since(std::time::UNIX_EPOCH)
                    .map_or(0, |d| d.as_nanos()),
            );
            h.finish()
        }
    })
}

fn parse_seed(v: &str) -> Option<u64> {
    let v = v.trim().replace('_', "");
    match v.strip_prefix("0x").or_else(|| v.strip_prefix("0X")) {
        Some(hex) => u64::from_str_radix(hex, 16).ok(),
        None => v.parse().ok(),
    }
}

/// Input `i` of loader `name` from seed files `seeds` in the run of `seed`.
fn input(name: &str, seeds: &[&[u8]], seed: u64, i: u64) -> Vec<u8> {
    let mut s = Sampler::new(seed, stream(name), i);
    mutate(seeds[i as usize % seeds.len()], &mut s)
}

/// The command that replays this run (of the test running now).
fn replay(seed: u64, iterations: u64) -> String {
    let test = std::thread::current()
        .name()
        .filter(|t| *t != "main")
        .map(|t| format!(" {t} --exact"))
        .unwrap_or_default();
    // the features this binary was built with: a failure may be Embree's
    let features = if cfg!(feature = "embree") {
        ""
    } else if cfg!(feature = "embree4") {
        " --no-default-features --features embree4"
    } else {
        " --no-default-features"
    };
    format!(
        "EMBERTRACE_FUZZ_SEED={seed} EMBERTRACE_FUZZ_ITERS={iterations} \
         cargo test{features} --test fuzz_loaders --{test} --nocapture"
    )
}

fn iterations() -> u64 {
    std::env::var("EMBERTRACE_FUZZ_ITERS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(200)
}

/// How one load ended.
enum Outcome {
    Loaded,
    Failed(String),
    Panicked,
    Hung,
}

/// Load `path` on a thread of its own, until it answers or has used
/// [`HANG_CPU_TICKS`] of CPU time.
fn load_bounded(path: &Path) -> Outcome {
    let (tx, rx) = mpsc::channel();
    let (tid_tx, tid_rx) = mpsc::channel();
    let path = path.to_path_buf();
    // a panic drops the sender; a hang leaves the thread behind, and the
    // test fails at once
    std::thread::spawn(move || {
        let _ = tid_tx.send(thread_id());
        let r = Scene::load(&path)
            .map(render_tiny)
            .map_err(|e| e.to_string());
        let _ = tx.send(r);
    });
    let tid = tid_rx.recv().expect("the loading thread starts");
    loop {
        // how often to look at the thread's CPU time, not a bound on it
        match rx.recv_timeout(Duration::from_millis(50)) {
            Ok(Ok(())) => return Outcome::Loaded,
            Ok(Err(msg)) => return Outcome::Failed(msg),
            Err(mpsc::RecvTimeoutError::Disconnected) => return Outcome::Panicked,
            Err(mpsc::RecvTimeoutError::Timeout) => {
                let stat = format!("/proc/self/task/{tid}/stat");
                // gone: it has just ended, and the channel says how
                if std::fs::read_to_string(stat).is_ok_and(|s| cpu_ticks(&s) > HANG_CPU_TICKS) {
                    return Outcome::Hung;
                }
            }
        }
    }
}

/// Render a scene that loaded at 2 x 2 pixels, 1 sample, 4 bounces, with
/// every backend compiled in, so that values a loader accepts (a huge
/// aperture, a light at the edge of the range) are shown not to crash the
/// renderer or Embree (which aborts the process on a ray it deems invalid;
/// the default-feature suite runs this with Embree). Scenes of more than 100 000
/// primitives are only loaded.
fn render_tiny(scene: Scene) {
    use embertrace::accel::{self, AccelOptions, Backend};
    if scene.primitive_count() > 100_000 {
        return;
    }
    for backend in Backend::available() {
        let acc = accel::build(backend, scene.soup(), AccelOptions::default())
            .expect("a loaded scene builds");
        render_with(&scene, acc.as_ref());
    }
}

fn render_with(scene: &Scene, acc: &dyn embertrace::accel::Accelerator) {
    use embertrace::integrator::PathTracer;
    use embertrace::render::{RenderSettings, render};
    use embertrace::settings::IntegratorSettings;
    let settings = IntegratorSettings {
        max_depth: 4,
        ..IntegratorSettings::default()
    };
    let tracer = PathTracer::new(scene, acc, settings);
    let rs = RenderSettings {
        total_spp: None,
        resolution: [2, 2],
        spp: 1,
        first_sample: 0,
        seed: 0,
        threads: 1,
        tile_size: 2,
        sampler: embertrace::sampler::SamplerKind::Independent,
        clamp: None,
    };
    render(&tracer, &scene.make_camera(2, 2), &rs, &|| {}).expect("a loaded scene renders");
}

/// A stream number per loader, so that no two loaders mutate alike.
fn stream(name: &str) -> u64 {
    name.bytes().fold(0xcbf2_9ce4_8422_2325, |h, b| {
        (h ^ b as u64).wrapping_mul(0x100_0000_01b3)
    })
}

/// Fuzz file `target` of a scene made of `files`, loading `entry`: input `i`
/// mutates seed `i % seeds.len()`.
fn fuzz(name: &str, files: &[(&str, &str)], target: &str, seeds: &[&[u8]], entry: &str) {
    let dir = tempfile::tempdir().unwrap();
    let names: Vec<&str> = files.iter().map(|f| f.0).collect();
    let (n, seed) = (iterations(), run_seed());
    eprintln!("fuzz {name}: seed {seed}; replay: {}", replay(seed, n));
    let (mut ok, mut errors) = (0u64, 0u64);
    let mut digest = stream("");
    let start = Instant::now();
    for i in 0..n {
        let input = input(name, seeds, seed, i);
        digest = input.iter().fold(digest, |h, &b| {
            (h ^ u64::from(b)).wrapping_mul(0x100_0000_01b3)
        });
        for (f, text) in files {
            let bytes = if *f == target {
                &input[..]
            } else {
                text.as_bytes()
            };
            std::fs::write(dir.path().join(f), bytes).unwrap();
        }
        let path = dir.path().join(entry);
        let keep = |why: &str| {
            let out =
                Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("fuzz-failure-{name}-{i}"));
            std::fs::write(&out, &input).unwrap();
            panic!(
                "{name} input {i} of the run of seed {seed} ({}): {why}; replay: {}",
                out.display(),
                replay(seed, i + 1)
            );
        };
        match load_bounded(&path) {
            Outcome::Panicked => keep("the loader panicked"),
            Outcome::Hung => keep(&format!("no answer in {HANG_CPU_TICKS} ticks of CPU time")),
            Outcome::Loaded => ok += 1,
            Outcome::Failed(msg) => {
                errors += 1;
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
    }
    eprintln!(
        "fuzz {name}: {n} inputs (digest {digest:016x}) in {:.2} s ({ok} loaded, {errors} clean errors)",
        start.elapsed().as_secs_f64()
    );
    assert!(
        errors > 0,
        "{name}: no mutation was rejected: the mutator does nothing"
    );
}

/// A seed gives the same inputs every time it is used, whatever else ran
/// before; another seed gives other inputs; the variable's spellings parse.
#[test]
fn a_seed_reproduces_its_inputs() {
    let seeds = [TOML.as_bytes(), TOML_EDGES.as_bytes()];
    let run =
        |seed: u64| -> Vec<Vec<u8>> { (0..50).map(|i| input("toml", &seeds, seed, i)).collect() };
    let a = run(0x5eed);
    // interleave other work on the generator's state, then replay
    let _ = run(1);
    assert_eq!(run(0x5eed), a);
    let b = run(0x5eee);
    assert!(a.iter().zip(&b).filter(|(x, y)| x != y).count() > 40);
    // input i does not depend on how many inputs the run has
    assert_eq!(input("toml", &seeds, 0x5eed, 49), a[49]);
    assert_eq!(parse_seed("0x5eed"), Some(0x5eed));
    assert_eq!(parse_seed(" 24301 "), Some(24301));
    assert_eq!(parse_seed("18_446_744_073_709_551_615"), Some(u64::MAX));
    assert_eq!(parse_seed("seed"), None);
    // the seed in use is printed, in a command that sets it
    assert!(replay(7, 3).starts_with("EMBERTRACE_FUZZ_SEED=7 EMBERTRACE_FUZZ_ITERS=3 "));
}

const FILES: [(&str, &str); 3] = [("scene.toml", TOML), ("mesh.obj", OBJ), ("mesh.mtl", MTL)];

#[test]
fn fuzz_toml_scene() {
    let seeds = [TOML.as_bytes(), TOML_EDGES.as_bytes()];
    fuzz("toml", &FILES, "scene.toml", &seeds, "scene.toml");
}

#[test]
fn fuzz_procedural_scene() {
    let files = [("scene.toml", PROCEDURAL)];
    fuzz(
        "procedural",
        &files,
        "scene.toml",
        &[PROCEDURAL.as_bytes()],
        "scene.toml",
    );
}

#[test]
fn fuzz_obj_mesh() {
    let seeds = [OBJ.as_bytes(), OBJ_EDGES.as_bytes()];
    fuzz("obj-in-toml", &FILES, "mesh.obj", &seeds, "scene.toml");
    fuzz("obj", &FILES, "mesh.obj", &seeds, "mesh.obj");
}

#[test]
fn fuzz_mtl_library() {
    fuzz(
        "mtl",
        &FILES,
        "mesh.mtl",
        &[MTL.as_bytes(), MTL_EDGES.as_bytes()],
        "mesh.obj",
    );
}

/// The hostile seeds themselves, unmutated: each loads or fails cleanly
/// (they sit on the limits, so a load must not allocate much or take long).
#[test]
fn edge_seeds_load_or_fail_cleanly() {
    let dir = tempfile::tempdir().unwrap();
    for (toml, obj, mtl) in [
        (TOML_EDGES, OBJ, MTL),
        (TOML, OBJ_EDGES, MTL),
        (TOML, OBJ, MTL_EDGES),
    ] {
        for (f, text) in [("scene.toml", toml), ("mesh.obj", obj), ("mesh.mtl", mtl)] {
            std::fs::write(dir.path().join(f), text).unwrap();
        }
        for entry in ["scene.toml", "mesh.obj"] {
            match load_bounded(&dir.path().join(entry)) {
                Outcome::Loaded => {}
                Outcome::Failed(msg) => assert!(!msg.contains('\n'), "{msg}"),
                Outcome::Panicked => panic!("{entry} panicked"),
                Outcome::Hung => panic!("{entry} hung"),
            }
        }
    }
}

/// Many tables load in time linear in the file. Finding each table's line
/// used to scan the whole file (20,000 `[[light]]` tables took 8.3 s, and
/// the time grew with their square), and each `[[mesh]]` parsed its OBJ
/// again. Asserted on counted work, not on a clock: the bytes the loading
/// thread reads (each file once), and the CPU time of the loading thread
/// alone (which other processes' load does not inflate) growing about
/// fourfold from 10,000 to 40,000 table pairs; a quadratic cost would grow
/// sixteenfold, so the bound is eightfold. Each size is loaded three times
/// and its least time kept. The sizes were 5,000 and 20,000: the smaller
/// took 2 to 6 clock ticks of 10 ms, so one tick of rounding moved the
/// ratio by a third, and a CI run measured [2, 19] ticks (9.5x) where
/// other runs here gave 3.2x to 6.7x.
#[test]
fn many_tables_load_in_linear_time() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("mesh.obj"), OBJ).unwrap();
    std::fs::write(dir.path().join("mesh.mtl"), MTL).unwrap();
    let mut ticks = Vec::new();
    for n in [10_000, 40_000] {
        let mut toml = String::from("[camera]\norigin = [0, 0, 3]\ntarget = [0, 0, 0]\n");
        for _ in 0..n {
            toml.push_str("[[light]]\ntype = \"environment\"\nradiance = 0.00001\n");
            toml.push_str("[[mesh]]\nfile = \"mesh.obj\"\n");
        }
        std::fs::write(dir.path().join("scene.toml"), &toml).unwrap();
        let mut least = u64::MAX;
        for _ in 0..3 {
            let (t0, r0) = (thread_cpu_ticks(), thread_bytes_read());
            let scene = Scene::load(&dir.path().join("scene.toml")).unwrap();
            let (t1, r1) = (thread_cpu_ticks(), thread_bytes_read());
            assert_eq!(scene.meshes.len(), n);
            least = least.min(t1 - t0);
            // the scene, the OBJ and its MTL once each, and the few hundred
            // bytes of this thread's own /proc reads
            let once = (toml.len() + OBJ.len() + MTL.len()) as u64;
            assert!(
                r1 - r0 <= once + 4096,
                "{n} tables: {} bytes read, {once} in the files",
                r1 - r0
            );
        }
        ticks.push(least.max(1));
    }
    eprintln!("CPU ticks for 10,000 and 40,000 table pairs: {ticks:?}");
    assert!(
        ticks[1] <= 8 * ticks[0],
        "4 times the tables took {} times the CPU time ({ticks:?} ticks)",
        ticks[1] as f64 / ticks[0] as f64
    );
}

/// User plus system CPU time of the calling thread, in clock ticks.
fn thread_cpu_ticks() -> u64 {
    cpu_ticks(&std::fs::read_to_string("/proc/thread-self/stat").expect("Linux /proc"))
}

/// User plus system CPU time (fields 14 and 15) of a `/proc/.../stat` line.
fn cpu_ticks(stat: &str) -> u64 {
    // the command name (field 2) is in parentheses and may hold spaces
    let f: Vec<&str> = stat[stat.rfind(')').unwrap() + 2..].split(' ').collect();
    f[11].parse::<u64>().unwrap() + f[12].parse::<u64>().unwrap()
}

/// The calling thread's id as `/proc/self/task/` names it (field 1 of its
/// `stat`).
fn thread_id() -> u64 {
    let s = std::fs::read_to_string("/proc/thread-self/stat").expect("Linux /proc");
    s.split(' ').next().unwrap().parse().unwrap()
}

/// Bytes the calling thread has read through `read` and the like
/// (`rchar` of `/proc/thread-self/io`).
fn thread_bytes_read() -> u64 {
    let s = std::fs::read_to_string("/proc/thread-self/io").expect("Linux /proc");
    s.lines()
        .find_map(|l| l.strip_prefix("rchar: "))
        .and_then(|v| v.trim().parse().ok())
        .expect("rchar in /proc/thread-self/io")
}

/// A PLY header for 4 vertices with normals and UVs and 2 faces (a quad and
/// a triangle), in `format`.
fn ply_header(format: &str) -> String {
    format!(
        "ply\nformat {format} 1.0\nelement vertex 4\nproperty float x\nproperty float y\n\
         property float z\nproperty float nx\nproperty float ny\nproperty float nz\n\
         property float u\nproperty float v\nproperty uchar red\nelement face 2\n\
         property list uchar int vertex_indices\nend_header\n"
    )
}

const PLY_VERTS: [[f32; 8]; 4] = [
    [-0.5, 0.0, -0.5, 0.0, 1.0, 0.0, 0.0, 0.0],
    [0.5, 0.0, -0.5, 0.0, 1.0, 0.0, 1.0, 0.0],
    [0.5, 0.0, 0.5, 0.0, 1.0, 0.0, 1.0, 1.0],
    [-0.5, 1.0, 0.5, 0.0, 0.0, 1.0, 0.0, 1.0],
];
const PLY_FACES: [&[i32]; 2] = [&[0, 1, 2, 3], &[0, 2, 3]];

fn ply_seeds() -> Vec<Vec<u8>> {
    let mut ascii = ply_header("ascii");
    for v in PLY_VERTS {
        let words: Vec<String> = v.iter().map(|x| x.to_string()).collect();
        ascii += &format!("{} 200\n", words.join(" "));
    }
    for f in PLY_FACES {
        let words: Vec<String> = f.iter().map(|x| x.to_string()).collect();
        ascii += &format!("{} {}\n", f.len(), words.join(" "));
    }
    let mut seeds = vec![ascii.into_bytes()];
    for big in [false, true] {
        let order = if big {
            "binary_big_endian"
        } else {
            "binary_little_endian"
        };
        let mut b = ply_header(order).into_bytes();
        for v in PLY_VERTS {
            for x in v {
                b.extend(if big {
                    x.to_be_bytes()
                } else {
                    x.to_le_bytes()
                });
            }
            b.push(200);
        }
        for f in PLY_FACES {
            b.push(f.len() as u8);
            for &i in f {
                b.extend(if big {
                    i.to_be_bytes()
                } else {
                    i.to_le_bytes()
                });
            }
        }
        seeds.push(b);
    }
    seeds
}

#[test]
fn fuzz_ply_mesh() {
    let scene = "[camera]\norigin = [0, 0.5, 3]\ntarget = [0, 0.3, 0]\nfov_y = 40\n\n\
                 [[mesh]]\nfile = \"mesh.ply\"\n\n[[mesh]]\nfile = \"mesh.ply\"\n\
                 material = { emission = 1 }\n";
    let files = [("scene.toml", scene), ("mesh.ply", "")];
    let seeds = ply_seeds();
    let seeds: Vec<&[u8]> = seeds.iter().map(|s| &s[..]).collect();
    fuzz("ply-in-toml", &files, "mesh.ply", &seeds, "scene.toml");
    fuzz("ply", &files, "mesh.ply", &seeds, "mesh.ply");
}

/// A Mitsuba scene using most of the subset, with the fuzz OBJ.
const MITSUBA: &str = r#"<scene version="3.0.0">
    <default name="spp" value="4"/>
    <integrator type="path"><integer name="max_depth" value="5"/><integer name="rr_depth" value="2"/></integrator>
    <sensor type="thinlens">
        <float name="fov" value="45"/><string name="fov_axis" value="diagonal"/>
        <float name="aperture_radius" value="0.01"/><float name="focus_distance" value="3"/>
        <transform name="to_world"><lookat origin="0, 1, 4" target="0, 0.5, 0" up="0, 1, 0"/></transform>
        <sampler type="independent"><integer name="sample_count" value="$spp"/></sampler>
        <film type="hdrfilm"><integer name="width" value="32"/><integer name="height" value="24"/><rfilter type="box"/></film>
    </sensor>
    <bsdf type="twosided" id="w"><bsdf type="roughplastic"><rgb name="diffuse_reflectance" value="0.5 0.4 0.3"/><string name="int_ior" value="bk7"/></bsdf></bsdf>
    <emitter type="point"><point name="position" x="0" y="2" z="1"/><spectrum name="intensity" value="3"/></emitter>
    <emitter type="directional"><vector name="direction" value="0, -1, -0.2"/><float name="irradiance" value="0.5"/></emitter>
    <emitter type="constant"><rgb name="radiance" value="0.1"/></emitter>
    <shape type="obj"><string name="filename" value="mesh.obj"/><ref id="w"/>
        <transform name="to_world"><matrix value="1 0 0 0  0 1 0 0.1  0 0 1 0  0 0 0 1"/><rotate y="1" angle="15"/></transform></shape>
    <shape type="disk"><boolean name="flip_normals" value="true"/><bsdf type="conductor"/>
        <emitter type="area"><rgb name="radiance" value="2, 2, 1"/></emitter></shape>
    <shape type="sphere"><point name="center" value="0.5 0.5 0"/><float name="radius" value="0.3"/><bsdf type="dielectric"/></shape>
    <shape type="cube"><transform name="to_world"><scale value="0.2"/><translate x="-0.6"/></transform>
        <bsdf type="roughconductor"><string name="distribution" value="ggx"/><rgb name="eta" value="0.2"/><rgb name="k" value="3"/></bsdf></shape>
</scene>
"#;

#[test]
fn fuzz_cse_test() {
    let cornell = include_str!("data/cse/cornell.test");
    let raytracer = "size 64 48\ncamera 0 0 4 0 0 0 0 1 0 45\nmaxdepth 3\nattenuation 1 0.1 0\n\
        point 1 2 3 1 1 1\ndirectional 0 1 1 0.5 0.5 0.5\nambient 0.1 0.1 0.1\nmaxverts 4\n\
        maxvertnorms 3\nvertexnormal 0 0 0 0 0 1\nvertexnormal 1 0 0 0 0 1\nvertexnormal 0 1 0 0 1 1\n\
        trinormal 0 1 2\nvertex -1 -1 0\nvertex 1 -1 0\nvertex 1 1 0\nvertex -1 1 0\n\
        diffuse 0.5 0.2 0.1\nspecular 0.3 0.3 0.3\nshininess 20\nemission 0 0 0\n\
        pushTransform\nrotate 0 0 1 45\nscale 1 2 1\ntri 0 1 2\nsphere 0 0 -1 0.5\npopTransform\n\
        translate 0 0 -2\ntri 0 2 3\nsphere 1 1 1 0.25\noutput x.png\ngamma 2.2\n";
    fuzz(
        "cse-test",
        &[("scene.test", "")],
        "scene.test",
        &[cornell.as_bytes(), raytracer.as_bytes()],
        "scene.test",
    );
}

#[test]
fn fuzz_collada_dae() {
    let room = include_str!("data/collada/room.dae");
    fuzz(
        "collada-dae",
        &[("scene.dae", "")],
        "scene.dae",
        &[room.as_bytes()],
        "scene.dae",
    );
}

#[test]
fn fuzz_mitsuba_xml() {
    let cbox = include_str!("data/mitsuba/cbox.xml");
    let files = [("scene.xml", ""), ("mesh.obj", OBJ), ("mesh.mtl", MTL)];
    fuzz(
        "mitsuba-xml",
        &files,
        "scene.xml",
        &[MITSUBA.as_bytes(), cbox.as_bytes()],
        "scene.xml",
    );
}

#[test]
fn fuzz_gltf() {
    // the bundled box as JSON (mutations reach the JSON and the base64
    // buffer) and as GLB (the chunk headers and the binary data)
    let json = include_str!("../scenes/cornell-box.gltf");
    // textures, a normal map, a camera and a spot light (tests/gltf.rs)
    let textured = include_str!("data/gltf/textured.gltf");
    let glb: &[u8] = include_bytes!("../scenes/cornell-box.glb");
    fuzz(
        "gltf",
        &[("scene.gltf", "")],
        "scene.gltf",
        &[json.as_bytes(), textured.as_bytes()],
        "scene.gltf",
    );
    fuzz(
        "glb",
        &[("scene.glb", "")],
        "scene.glb",
        &[glb],
        "scene.glb",
    );
}

/// Transforms, named materials, objects, lights and every shape the pbrt
/// loader reads, as one seed.
const PBRT: &str = r#"Scale -1 1 1
LookAt 0 1 4  0 1 0  0 1 0
Camera "perspective" "float fov" [ 40 ] "float lensradius" 0.01 "float focaldistance" 4
Film "rgb" "integer xresolution" [ 32 ] "integer yresolution" [ 24 ]
Sampler "zsobol" "integer pixelsamples" 4
Integrator "path" "integer maxdepth" [ 5 ]
WorldBegin
MakeNamedMaterial "gold" "string type" "conductor" "spectrum eta" "metal-Au-eta" "spectrum k" "metal-Au-k" "float roughness" 0.1
MakeNamedMaterial "coat" "string type" "coateddiffuse" "rgb reflectance" [ 0.5 0.4 0.3 ] "float roughness" 0.05
ObjectBegin "q"
  Shape "bilinearmesh" "point3 P" [ 0 0 0 1 0 0 0 1 0 1 1 0 ]
ObjectEnd
AttributeBegin
  Translate 1 0 0
  Rotate 30 0 1 0
  ObjectInstance "q"
AttributeEnd
AttributeBegin
  NamedMaterial "gold"
  Shape "sphere" "float radius" 0.5
AttributeEnd
AttributeBegin
  AreaLightSource "diffuse" "rgb L" [ 4 4 4 ] "bool twosided" true
  ReverseOrientation
  NamedMaterial "coat"
  Shape "trianglemesh" "point3 P" [ -1 2 -1 1 2 -1 1 2 1 ] "normal N" [ 0 -1 0 0 -1 0 0 -1 0 ] "point2 uv" [ 0 0 1 0 1 1 ]
AttributeEnd
LightSource "spot" "rgb I" [ 5 5 5 ] "point3 from" [ 0 3 0 ] "point3 to" [ 0 0 0 ] "float coneangle" 30
LightSource "distant" "rgb L" [ 1 1 1 ]
LightSource "infinite" "rgb L" [ 0.1 0.1 0.1 ]
"#;

#[test]
fn fuzz_pbrt() {
    let cornell = include_str!("../scenes/cornell-box.pbrt");
    fuzz(
        "pbrt",
        &[("scene.pbrt", "")],
        "scene.pbrt",
        &[cornell.as_bytes(), PBRT.as_bytes()],
        "scene.pbrt",
    );
}
