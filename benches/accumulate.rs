//! What the fixed-point accumulators (issue 20; `film::FRACTION_BITS`) cost
//! per sample, against the `f64` sums they replaced, as a share of a real
//! sample's time (a benchmark, not a test: nothing here runs in CI):
//!
//! ```sh
//! cargo bench --bench accumulate         # ACCUMULATE_REPS=7
//! ```
//!
//! It renders the Cornell box (128 x 128, 16 spp, one thread, the default
//! sampler) for the time of one sample, then adds the same number of
//! samples to a 16 x 16 tile through `Tile::add_sample` and through an
//! `f64` accumulator written as the old one was, taking turns; each figure
//! is the median of the repetitions. The goal: at most 2 % of a sample.

use embertrace::accel::{self, AccelOptions, Backend};
use embertrace::camera::Camera;
use embertrace::commands::bench::median;
use embertrace::film::{Tile, TileBounds};
use embertrace::integrator::PathTracer;
use embertrace::math::Vec3;
use embertrace::render::{RenderSettings, render};
use embertrace::sampler::SamplerKind;
use embertrace::scene::Scene;
use embertrace::settings::IntegratorSettings;
use std::hint::black_box;
use std::process::ExitCode;
use std::time::Instant;

/// The old accumulator: `f64` sums of samples and squares, and a count.
#[derive(Clone, Copy, Default)]
struct F64Pixel {
    sum: [f64; 3],
    sum_sq: [f64; 3],
    count: u64,
}

const SIDE: u32 = 16;

/// The tile's pixel of sample `i`, and the sample: varied values of
/// realistic size (0.001 to 100).
fn sample(i: u64) -> (u32, u32, Vec3) {
    let h = i.wrapping_mul(0x9e37_79b9_7f4a_7c15);
    let v = |k: u32| 10f32.powf(((h >> (8 * k)) & 0xff) as f32 / 51.0 - 3.0);
    (
        (i % 16) as u32,
        ((i / 16) % 16) as u32,
        Vec3::new(v(1), v(2), v(3)),
    )
}

fn fixed(n: u64) -> f64 {
    let mut tile = Tile::new(TileBounds {
        x0: 0,
        y0: 0,
        width: SIDE,
        height: SIDE,
    });
    let t = Instant::now();
    for i in 0..n {
        let (x, y, s) = sample(i);
        tile.add_sample(x, y, black_box(s));
    }
    black_box(&tile);
    t.elapsed().as_secs_f64() / n as f64
}

fn float(n: u64) -> f64 {
    let mut px = vec![F64Pixel::default(); (SIDE * SIDE) as usize];
    let t = Instant::now();
    for i in 0..n {
        let (x, y, s) = sample(i);
        let s = black_box(s);
        // the old Tile::add_sample's bounds check, then its accumulate
        assert!(x < SIDE && y < SIDE, "pixel ({x}, {y}) is outside the tile");
        if s.is_finite() {
            let p = &mut px[(y * SIDE + x) as usize];
            for c in 0..3 {
                let v = f64::from(s[c]);
                p.sum[c] += v;
                p.sum_sq[c] += v * v;
            }
            p.count += 1;
        }
    }
    black_box(&px);
    t.elapsed().as_secs_f64() / n as f64
}

fn main() -> ExitCode {
    let reps: usize = std::env::var("ACCUMULATE_REPS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(7);
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/cornell-box.toml");
    let scene = match Scene::load(std::path::Path::new(path)) {
        Ok(s) => s,
        Err(e) => {
            eprintln!("{e}");
            return ExitCode::FAILURE;
        }
    };
    let acc = accel::build(
        Backend::default_backend(),
        scene.soup(),
        AccelOptions::default(),
    )
    .expect("the Cornell box builds");
    let integrator = IntegratorSettings {
        max_depth: scene.render.max_depth,
        ..IntegratorSettings::default()
    };
    let tracer = PathTracer::new(&scene, acc.as_ref(), integrator);
    let res = 128;
    let camera = Camera::new(&scene.camera, res, res);
    let rs = RenderSettings {
        total_spp: None,
        resolution: [res, res],
        spp: 16,
        first_sample: 0,
        seed: 1,
        threads: 1,
        tile_size: 16,
        sampler: SamplerKind::default(),
        clamp: None,
    };
    let samples = u64::from(res * res) * 16;
    let (mut per_sample, mut fx, mut fl) = (Vec::new(), Vec::new(), Vec::new());
    for _ in 0..reps {
        let t = Instant::now();
        black_box(render(&tracer, &camera, &rs, &|| {}).expect("renders"));
        per_sample.push(t.elapsed().as_secs_f64() / samples as f64);
        fx.push(fixed(samples));
        fl.push(float(samples));
    }
    let (s, fx, fl) = (median(per_sample), median(fx), median(fl));
    let share = (fx - fl) / s;
    println!(
        "Cornell box 128x128 16 spp, 1 thread: {:.1} ns per sample (median of {reps})",
        s * 1e9
    );
    println!(
        "accumulate, fixed point (Tile::add_sample): {:.2} ns per sample",
        fx * 1e9
    );
    println!(
        "accumulate, f64 sums (the old way):          {:.2} ns per sample",
        fl * 1e9
    );
    println!(
        "fixed point costs {:+.2} ns per sample: {:+.3} % of a sample (goal: at most 2 %)",
        (fx - fl) * 1e9,
        100.0 * share
    );
    if share > 0.02 {
        return ExitCode::FAILURE;
    }
    ExitCode::SUCCESS
}
