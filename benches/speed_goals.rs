//! The pure-Rust BVH's speed goals, measured against Embree on the bundled
//! 1.2M-triangle scene and checked (a benchmark, not a test: timings on a
//! shared machine are noisy, so nothing here runs in CI):
//!
//! ```sh
//! cargo bench --bench speed_goals            # SPEED_GOALS_REPS=5 SPEED_GOALS_RAYS=200000
//! ```
//!
//! The goals: single-threaded Mrays/s at least [`MIN_RAY_RATIO`] of
//! Embree's for camera, shadow and diffuse rays; a build no slower than
//! Embree's ([`MAX_BUILD_RATIO`]); at most [`MAX_BYTES_PER_TRIANGLE`] bytes
//! per triangle. Both backends run in robust mode with their default
//! builds, in one process, taking turns (see `embertrace::commands::bench`); each
//! ratio is the median of back-to-back ratios. Prints `embertrace bench`'s
//! table, then one line per goal, and exits non-zero if a goal is missed.

use embertrace::accel::{AccelOptions, Backend};
use embertrace::commands::bench::throughput::{self as bench, ThroughputSettings};
use embertrace::scene::Scene;
use std::process::ExitCode;

/// Least BVH / Embree single-threaded Mrays/s for the kinds in
/// [`RATIO_KINDS`].
const MIN_RAY_RATIO: f64 = 0.8;
/// The ray kinds the ratio goal covers.
const RATIO_KINDS: [&str; 3] = ["camera", "shadow", "diffuse"];
/// Largest BVH / Embree build time.
const MAX_BUILD_RATIO: f64 = 1.0;
/// Largest BVH memory per triangle.
const MAX_BYTES_PER_TRIANGLE: f64 = 100.0;

fn env(name: &str, default: usize) -> usize {
    std::env::var(name)
        .ok()
        .and_then(|v| v.replace('_', "").parse().ok())
        .unwrap_or(default)
}

fn main() -> ExitCode {
    if !Backend::available().contains(&Backend::Embree) {
        println!("speed goals compare the BVH with Embree: build with the embree feature");
        return ExitCode::SUCCESS;
    }
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/sphere-1m.toml");
    let scene = match Scene::load(std::path::Path::new(path)) {
        Ok(s) => s,
        Err(e) => {
            eprintln!("{e}");
            return ExitCode::FAILURE;
        }
    };
    let settings = ThroughputSettings {
        backends: vec![Backend::Embree, Backend::Bvh],
        threads: 0,
        reps: env("SPEED_GOALS_REPS", 5),
        rays: env("SPEED_GOALS_RAYS", 200_000),
        options: AccelOptions::default(),
    };
    let report = match bench::run(&scene, &settings, &|line| eprintln!("{line}")) {
        Ok(r) => r,
        Err(e) => {
            eprintln!("{e}");
            return ExitCode::FAILURE;
        }
    };
    print!("{}", report.table());
    let bvh = &report.backends[1];
    let mut checks = vec![
        (
            format!("build time / Embree's <= {MAX_BUILD_RATIO}"),
            bvh.build_ratio.unwrap_or(f64::INFINITY),
            bvh.build_ratio.is_some_and(|r| r <= MAX_BUILD_RATIO),
        ),
        (
            format!("bytes per triangle <= {MAX_BYTES_PER_TRIANGLE}"),
            bvh.bytes_per_triangle,
            bvh.bytes_per_triangle <= MAX_BYTES_PER_TRIANGLE,
        ),
    ];
    for k in bvh.kinds.iter().filter(|k| RATIO_KINDS.contains(&&*k.kind)) {
        let r = k.ratio_single.unwrap_or(0.0);
        checks.push((
            format!("{} Mrays/s / Embree's, 1 thread >= {MIN_RAY_RATIO}", k.kind),
            r,
            r >= MIN_RAY_RATIO,
        ));
    }
    let mut missed = 0;
    for (goal, value, met) in &checks {
        println!(
            "{:<6} {goal}: {value:.3}",
            if *met { "met" } else { "MISSED" }
        );
        missed += usize::from(!met);
    }
    if missed > 0 {
        ExitCode::FAILURE
    } else {
        ExitCode::SUCCESS
    }
}
