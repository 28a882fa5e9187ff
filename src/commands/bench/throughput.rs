//! `embertrace bench`: for each backend, the build time, memory per triangle,
//! and Mrays/s for camera, shadow, diffuse and random rays, single-threaded
//! and on all cores. Every figure is the median of `reps` repetitions, and
//! every backend traces the same ray sets in the same process.
//!
//! Backends take turns within each repetition (build A, build B, build A,
//! ...; then A's camera rays, B's camera rays, A's again, ...), so a slow
//! spell of a shared machine falls on both sides of a comparison instead of
//! on one backend's whole row. Each backend after the first also gets its
//! ratios to the first: the median over repetitions of the ratio of the two
//! figures measured back to back, which drifts less than the ratio of two
//! medians.

use crate::accel::{self, AccelOptions, Accelerator, Backend, Masked};
use crate::commands::raysets::{self, RayKind, RaySet};
use crate::error::{Error, Result};
use crate::scene::Scene;
use rayon::prelude::*;
use serde::Serialize;
use std::time::Instant;

/// Ray kinds timed by `bench`.
pub const THROUGHPUT_RAY_KINDS: [RayKind; 4] = [
    RayKind::Camera,
    RayKind::Shadow,
    RayKind::Diffuse,
    RayKind::Random,
];

/// One backend's throughput for one ray kind.
#[derive(Debug, Clone, Serialize)]
pub struct KindResult {
    /// Ray kind.
    pub kind: String,
    /// Rays in the set.
    pub rays: usize,
    /// Median Mrays/s on one thread.
    pub mrays_single: f64,
    /// Median Mrays/s on all threads.
    pub mrays_all: f64,
    /// Hits (closest-hit kinds) or occluded rays (shadow): a checksum that the
    /// backends must share.
    pub hits: usize,
    /// Median over repetitions of this backend's single-threaded Mrays/s
    /// divided by the first backend's, measured back to back (null for the
    /// first backend).
    pub ratio_single: Option<f64>,
    /// The same for all threads.
    pub ratio_all: Option<f64>,
}

/// One backend's row.
#[derive(Debug, Clone, Serialize)]
pub struct BackendResult {
    /// Backend name.
    pub backend: String,
    /// Median build seconds.
    pub build_seconds: f64,
    /// Median over repetitions of this backend's build time divided by the
    /// first backend's, built back to back (null for the first backend).
    pub build_ratio: Option<f64>,
    /// Bytes held by the structure.
    pub memory_bytes: usize,
    /// Bytes per triangle.
    pub bytes_per_triangle: f64,
    /// Per ray kind.
    pub kinds: Vec<KindResult>,
}

/// The whole benchmark.
#[derive(Debug, Clone, Serialize)]
pub struct ThroughputReport {
    /// Scene file.
    pub scene: String,
    /// Triangles.
    pub triangles: usize,
    /// Threads in the "all" columns.
    pub threads: usize,
    /// Repetitions per figure (the median is reported).
    pub reps: usize,
    /// The Embree library the `embree` row ran on (`"Embree 4.4.0"`), null
    /// in a build without Embree: Embree 3 and 4 cannot share a process, so
    /// `scripts/bench-embree` compares the two builds' reports.
    pub embree: Option<String>,
    /// One row per backend.
    pub backends: Vec<BackendResult>,
}

/// The median of `v` (the mean of the middle two for an even count), the
/// statistic every benchmark of the crate reports.
pub fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(|a, b| a.total_cmp(b));
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

fn trace(accel: &dyn Accelerator, set: &RaySet) -> usize {
    if set.kind.is_occlusion() {
        set.rays.iter().filter(|r| accel.occluded(r)).count()
    } else {
        set.rays
            .iter()
            .filter(|r| accel.intersect(r).is_some())
            .count()
    }
}

fn trace_parallel(accel: &dyn Accelerator, set: &RaySet) -> usize {
    let occlusion = set.kind.is_occlusion();
    set.rays
        .par_chunks(4096)
        .map(|c| {
            if occlusion {
                c.iter().filter(|r| accel.occluded(r)).count()
            } else {
                c.iter().filter(|r| accel.intersect(r).is_some()).count()
            }
        })
        .sum()
}

/// Settings of a benchmark run.
#[derive(Debug, Clone)]
pub struct ThroughputSettings {
    /// Backends to measure.
    pub backends: Vec<Backend>,
    /// Threads for the "all" columns; 0 = all cores.
    pub threads: usize,
    /// Repetitions per figure.
    pub reps: usize,
    /// Rays per kind.
    pub rays: usize,
    /// Options for building each backend.
    pub options: AccelOptions,
}

/// Run the benchmark on `scene`. `progress` receives a line per step.
pub fn run(
    scene: &Scene,
    settings: &ThroughputSettings,
    progress: &dyn Fn(&str),
) -> Result<ThroughputReport> {
    let pool = crate::render::thread_pool(settings.threads)?;
    let threads = pool.current_num_threads();
    let reps = settings.reps.max(1);
    // Ray sets come from the first backend (first hits decide where bounce
    // and shadow rays start), then every backend traces the same sets.
    let first = settings
        .backends
        .first()
        .ok_or_else(|| Error::Settings("no backend to benchmark".into()))?;
    let generator = accel::build(*first, scene.soup(), settings.options)?;
    let sets: Vec<RaySet> = THROUGHPUT_RAY_KINDS
        .iter()
        .map(|&k| {
            let masked = Masked {
                accel: generator.as_ref(),
                alpha: scene.alpha_test(),
            };
            raysets::generate(scene, &masked, k, settings.rays, 1)
        })
        .collect();
    drop(generator);
    let tris = scene.triangle_count().max(1);
    let backends = &settings.backends;
    let names = backends
        .iter()
        .map(|b| b.name())
        .collect::<Vec<_>>()
        .join(", ");
    progress(&format!(
        "building {names}: {reps} times each, taking turns"
    ));
    let mut build_times = vec![Vec::new(); backends.len()];
    let mut accels: Vec<Option<Box<dyn Accelerator>>> = backends.iter().map(|_| None).collect();
    for _ in 0..reps {
        for (i, &backend) in backends.iter().enumerate() {
            drop(accels[i].take()); // free the previous build before timing the next
            let t = Instant::now();
            let a = accel::build(backend, scene.soup(), settings.options)?;
            build_times[i].push(t.elapsed().as_secs_f64());
            accels[i] = Some(a);
        }
    }
    let accels: Vec<Box<dyn Accelerator>> = accels
        .into_iter()
        .map(|a| a.expect("reps >= 1 builds every backend"))
        .collect();
    // a scene with alpha masks is traced through them (as a render is); the
    // others call the backend directly, without the wrapper's indirection
    let masked: Vec<Masked> = accels
        .iter()
        .map(|a| Masked {
            accel: a.as_ref(),
            alpha: scene.alpha_test(),
        })
        .collect();
    let traced = |i: usize| -> &dyn Accelerator {
        if masked[i].alpha.is_some() {
            &masked[i]
        } else {
            accels[i].as_ref()
        }
    };
    // per backend, per kind: single- and all-thread Mrays/s of each repetition
    let mut single = vec![vec![Vec::new(); sets.len()]; backends.len()];
    let mut all = single.clone();
    let mut hits = vec![vec![0; sets.len()]; backends.len()];
    for (k, set) in sets.iter().enumerate() {
        progress(&format!(
            "{} rays x {reps}, backends taking turns",
            set.kind
        ));
        for _ in 0..reps {
            for i in 0..accels.len() {
                let t = Instant::now();
                hits[i][k] = trace(traced(i), set);
                single[i][k].push(set.rays.len() as f64 / t.elapsed().as_secs_f64() / 1e6);
                let t = Instant::now();
                let h = pool.install(|| trace_parallel(traced(i), set));
                all[i][k].push(set.rays.len() as f64 / t.elapsed().as_secs_f64() / 1e6);
                debug_assert_eq!(h, hits[i][k]);
            }
        }
    }
    let mut rows = Vec::new();
    for (i, accel) in accels.iter().enumerate() {
        let memory = accel.memory_bytes();
        let ratio = |v: &[f64], first: &[f64]| {
            (i > 0).then(|| median(v.iter().zip(first).map(|(a, b)| a / b).collect()))
        };
        let kinds = sets
            .iter()
            .enumerate()
            .map(|(k, set)| KindResult {
                kind: set.kind.to_string(),
                rays: set.rays.len(),
                mrays_single: median(single[i][k].clone()),
                mrays_all: median(all[i][k].clone()),
                hits: hits[i][k],
                ratio_single: ratio(&single[i][k], &single[0][k]),
                ratio_all: ratio(&all[i][k], &all[0][k]),
            })
            .collect();
        rows.push(BackendResult {
            backend: backends[i].to_string(),
            build_seconds: median(build_times[i].clone()),
            build_ratio: ratio(&build_times[i], &build_times[0]),
            memory_bytes: memory,
            bytes_per_triangle: memory as f64 / tris as f64,
            kinds,
        });
    }
    Ok(ThroughputReport {
        scene: scene.source.display().to_string(),
        triangles: scene.triangle_count(),
        threads,
        reps,
        embree: backends
            .contains(&Backend::Embree)
            .then(accel::embree_library)
            .flatten(),
        backends: rows,
    })
}

impl ThroughputReport {
    /// The table printed on stdout.
    pub fn table(&self) -> String {
        let mut out = format!(
            "{}: {} triangles; Mrays/s, median of {} runs; 1 thread / {} threads\n",
            self.scene, self.triangles, self.reps, self.threads
        );
        if let Some(lib) = &self.embree {
            out += &format!("embree: {lib}\n");
        }
        out += &format!("{:<8} {:>9} {:>9}", "backend", "build ms", "B/tri");
        for k in THROUGHPUT_RAY_KINDS {
            out += &format!(" {:>17}", k.name());
        }
        out.push('\n');
        for r in &self.backends {
            out += &format!(
                "{:<8} {:>9.2} {:>9.1}",
                r.backend,
                1e3 * r.build_seconds,
                r.bytes_per_triangle
            );
            for k in &r.kinds {
                out += &format!(
                    " {:>17}",
                    format!("{:.2} / {:.2}", k.mrays_single, k.mrays_all)
                );
            }
            out.push('\n');
        }
        if let Some(first) = self.backends.first().filter(|_| self.backends.len() > 1) {
            out += &format!(
                "ratio to {}, median of back-to-back pairs; build time / Mrays/s 1 thread / {} threads\n",
                first.backend, self.threads
            );
            for r in &self.backends[1..] {
                out += &format!(
                    "{:<8} {:>9} {:>9}",
                    r.backend,
                    format!("{:.2}x", r.build_ratio.unwrap_or(f64::NAN)),
                    ""
                );
                for k in &r.kinds {
                    out += &format!(
                        " {:>17}",
                        format!(
                            "{:.2} / {:.2}",
                            k.ratio_single.unwrap_or(f64::NAN),
                            k.ratio_all.unwrap_or(f64::NAN)
                        )
                    );
                }
                out.push('\n');
            }
        }
        out
    }
}
