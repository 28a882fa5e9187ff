//! What an environment map's importance sampling costs per draw, by map
//! size (a benchmark, not a test: nothing here runs in CI):
//!
//! ```sh
//! cargo bench --bench envmap          # ENVMAP_REPS=5
//! ```
//!
//! For maps of 128 x 64, 1024 x 512 and 4096 x 2048 texels (a sky's
//! gradient, a small bright sun and per-texel noise), it times
//! `EnvironmentMap::sample` (the draw by the density the map chose, the
//! direction, its radiance and density) and `EnvironmentMap::pdf` at the
//! drawn directions,
//! and, for scale, the raw draws of the two 2D densities over the same
//! grid: `PeriodicBilinear2D` (what the map uses) and the constant density
//! per patch of `PiecewiseConstant2D` (what it used before). The uniform
//! numbers are independent, so on the large maps most draws miss the
//! cache, as in a render's incoherent bounces. Each figure is the median
//! over the repetitions of the nanoseconds per call, the kinds taking
//! turns.

use embertrace::commands::bench::median;
use embertrace::light::EnvironmentMap;
use embertrace::math::{Vec2, Vec3};
use embertrace::sampler::{Sampler, mix64};
use embertrace::sampling::{PeriodicBilinear2D, PiecewiseConstant2D};
use embertrace::texture::ImageTexture;
use std::hint::black_box;
use std::time::Instant;

const DRAWS: usize = 1 << 20;

/// A sky of `w x h` texels: brighter towards the zenith, a 5 x 5 sun of
/// 400, and each texel scaled by 0.8 to 1.2.
fn sky(w: usize, h: usize) -> Vec<Vec3> {
    (0..w * h)
        .map(|k| {
            let (x, y) = (k % w, k / w);
            let v = y as f32 / (h - 1) as f32;
            let noise = 0.8 + 0.4 * (mix64(k as u64) >> 40) as f32 / (1u64 << 24) as f32;
            let sun = x.abs_diff(3 * w / 4) <= 2 && y.abs_diff(h / 4) <= 2;
            let base = Vec3::new(0.4, 0.6, 1.0) * (1.5 - v);
            noise * if sun { Vec3::splat(400.0) } else { base }
        })
        .collect()
}

/// Nanoseconds per call of `f` over `us`.
fn time<T>(us: &[Vec2], mut f: impl FnMut(Vec2) -> T) -> f64 {
    let start = Instant::now();
    for &u in us {
        black_box(f(black_box(u)));
    }
    start.elapsed().as_secs_f64() / us.len() as f64 * 1e9
}

fn main() {
    let reps: usize = std::env::var("ENVMAP_REPS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(5);
    let mut s = Sampler::new(1, 0, 0);
    let us: Vec<Vec2> = (0..DRAWS).map(|_| s.next_2d()).collect();
    println!(
        "{:>11}  {:>8}  {:>9}  {:>9}  {:>9}  {:>9}",
        "map", "chosen", "sample", "pdf", "bilinear", "constant"
    );
    for (w, h) in [(128usize, 64usize), (1024, 512), (4096, 2048)] {
        let texels = sky(w, h);
        let rgb: Vec<f32> = texels.iter().flat_map(|t| t.to_array()).collect();
        let map = ImageTexture::from_linear_rgb(w as u32, h as u32, rgb).expect("a valid map");
        let env = EnvironmentMap::new(map, Vec3::ONE).expect("a valid environment");
        // the raw densities over the same grid: vertices on the texels, and
        // a patch's constant value the mean of its corners
        let lum: Vec<f32> = texels
            .iter()
            .map(|t| t.dot(Vec3::new(0.2126, 0.7152, 0.0722)))
            .collect();
        let bilinear = PeriodicBilinear2D::new(&lum, w, h);
        let patches: Vec<f32> = (0..h - 1)
            .flat_map(|j| {
                let lum = &lum;
                (0..w).map(move |i| {
                    let i1 = (i + 1) % w;
                    0.25 * (lum[j * w + i]
                        + lum[j * w + i1]
                        + lum[(j + 1) * w + i]
                        + lum[(j + 1) * w + i1])
                })
            })
            .collect();
        let constant = PiecewiseConstant2D::new(&patches, w, h - 1);
        let dirs: Vec<Vec3> = us
            .iter()
            .filter_map(|&u| env.sample(u))
            .map(|x| x.wi)
            .collect();
        let mut t: [Vec<f64>; 4] = Default::default();
        for _ in 0..reps {
            t[0].push(time(&us, |u| env.sample(u).map(|x| x.pdf)));
            let mut k = 0;
            t[1].push(time(&us, |_| {
                k = (k + 1) % dirs.len();
                env.pdf(dirs[k])
            }));
            t[2].push(time(&us, |u| bilinear.sample(u).pdf));
            t[3].push(time(&us, |u| constant.sample(u).pdf));
        }
        let [a, b, c, d] = t.map(median);
        println!(
            "{:>11}  {:>8}  {a:>6.1} ns  {b:>6.1} ns  {c:>6.1} ns  {d:>6.1} ns",
            format!("{w} x {h}"),
            if env.samples_bilinear_density() {
                "bilinear"
            } else {
                "constant"
            }
        );
    }
}
