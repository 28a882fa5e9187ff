//! The coverage-guided fuzz targets' harness (`fuzz/fuzz_targets/common.rs`,
//! which `cargo +nightly fuzz run` drives) run on stable in CI: coverage
//! guidance needs a nightly toolchain that CI does not install, but the
//! harness itself, the files it writes and the checks it makes (no panic;
//! an error is one line naming a file) are compiled and exercised here,
//! over each target's seed file, every prefix of it at a stride of 5 bytes,
//! and single-byte changes at every position, so the targets cannot rot
//! unseen.

#[path = "../fuzz/fuzz_targets/common.rs"]
#[allow(dead_code)]
mod harness;

#[test]
fn the_fuzz_targets_harness_takes_truncated_and_changed_seeds() {
    // (the file the fuzzer replaces, the file loaded, its seed) as each
    // target in fuzz/fuzz_targets/ names them
    let targets = [
        ("scene.toml", "scene.toml", harness::TOML),
        ("mesh.obj", "mesh.obj", harness::OBJ),
        ("mesh.mtl", "mesh.obj", harness::MTL),
    ];
    for (target, entry, seed) in targets {
        let seed = seed.as_bytes();
        harness::run(seed, target, entry);
        for end in (0..seed.len()).step_by(5) {
            harness::run(&seed[..end], target, entry);
        }
        for (i, b) in [b'\0', b'[', b'9', b'\n', 0xff]
            .into_iter()
            .cycle()
            .enumerate()
            .take(seed.len())
        {
            let mut changed = seed.to_vec();
            changed[i] = b;
            harness::run(&changed, target, entry);
        }
    }
}
