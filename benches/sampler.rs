//! What the sample generators cost per request, by sampler (a benchmark,
//! not a test: nothing here runs in CI):
//!
//! ```sh
//! cargo bench --bench sampler         # SAMPLER_REPS=7
//! ```
//!
//! It draws the requests of a render's samples the way `render::render_tile`
//! does (a 16 x 16 block of pixels, one sample of each pixel at a time, 32
//! samples per pixel of a 256 x 256 image): a sampler per sample, the camera
//! jitter (2D), then eight bounces of a light choice (1D), a light point
//! (2D), a BSDF direction (2D) and a Russian-roulette draw (1D). Each figure
//! is the median over the repetitions of the nanoseconds per sample (50
//! requests), the samplers taking turns.

use embertrace::commands::bench::median;
use embertrace::sampler::{SampleSpace, SamplerKind};
use std::hint::black_box;
use std::time::Instant;

const SIDE: u32 = 16;
const SPP: u32 = 32;
const BOUNCES: u32 = 8;

/// Seconds to draw every sample of the image's first `blocks` blocks.
fn run(kind: SamplerKind, blocks: u32) -> (f64, f32) {
    let space = SampleSpace::new(kind, 7, [256, 256], SPP);
    let mut sum = 0.0f32;
    let start = Instant::now();
    for b in 0..blocks {
        let (bx, by) = ((b % 16) * SIDE, (b / 16) * SIDE);
        for s in 0..SPP {
            for y in by..by + SIDE {
                for x in bx..bx + SIDE {
                    let mut sampler = space.sampler(black_box(x), y, s);
                    let j = sampler.next_2d();
                    let mut acc = j.x + j.y;
                    for _ in 0..BOUNCES {
                        acc += sampler.next_1d();
                        let l = sampler.next_2d();
                        let d = sampler.next_2d();
                        acc += l.x * d.y + l.y * d.x;
                        acc += sampler.next_1d();
                    }
                    sum += black_box(acc);
                }
            }
        }
    }
    (start.elapsed().as_secs_f64(), sum)
}

fn main() {
    let reps: usize = std::env::var("SAMPLER_REPS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(7);
    let blocks = 64;
    let samples = (blocks * SIDE * SIDE * SPP) as f64;
    let kinds = [
        SamplerKind::Independent,
        SamplerKind::Sobol,
        SamplerKind::ZSobol,
    ];
    let mut times = vec![Vec::new(); kinds.len()];
    let mut check = [0.0f32; 3];
    for _ in 0..reps {
        for (k, &kind) in kinds.iter().enumerate() {
            let (t, sum) = run(kind, blocks);
            times[k].push(t / samples * 1e9);
            check[k] = sum;
        }
    }
    let base = median(times[0].clone());
    for (k, &kind) in kinds.iter().enumerate() {
        let m = median(times[k].clone());
        println!(
            "{:<12} {:7.1} ns/sample  {:5.2}x independent  (checksum {})",
            kind.name(),
            m,
            m / base,
            check[k]
        );
    }
}
