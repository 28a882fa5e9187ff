//! The parallel render loop: rayon over tiles, every sample seeded by
//! (seed, pixel, sample index), tiles merged into the film in a fixed order,
//! so the image is bit-identical for any thread count.
//!
//! Non-finite and negative samples are not silently zeroed: each is counted,
//! its pixel recorded, and it is left out of that pixel's accumulation.

use crate::camera::Camera;
use crate::error::{Error, Result};
use crate::film::{Film, Tile};
use crate::integrator::{PathTracer, RayCounts};
use crate::math::Vec2;
use crate::sampler::{Sampler, SamplerKind};
use rayon::prelude::*;
use std::time::Instant;

/// How many offending pixels a report keeps.
pub const NONFINITE_PIXELS_KEPT: usize = 16;

/// What the render loop needs besides the scene and estimator.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RenderSettings {
    /// Image width and height.
    pub resolution: [u32; 2],
    /// Samples per pixel in this call.
    pub spp: u32,
    /// Index of the first sample (progressive passes continue the sequence).
    pub first_sample: u32,
    /// Random seed.
    pub seed: u64,
    /// Worker threads; 0 = all cores.
    pub threads: usize,
    /// Tile side in pixels.
    pub tile_size: u32,
    /// Sample generator.
    pub sampler: SamplerKind,
}

/// Samples that were NaN, infinite or negative, and where.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct NonFiniteReport {
    /// How many samples were rejected.
    pub count: u64,
    /// The first few pixels (in tile order) where it happened.
    pub pixels: Vec<[u32; 2]>,
}

impl NonFiniteReport {
    /// Add `other`'s count and pixels (up to [`NONFINITE_PIXELS_KEPT`]).
    pub fn merge(&mut self, other: &NonFiniteReport) {
        self.count += other.count;
        for &p in &other.pixels {
            if self.pixels.len() < NONFINITE_PIXELS_KEPT {
                self.pixels.push(p);
            }
        }
    }
}

/// A finished render.
#[derive(Debug)]
pub struct RenderOutput {
    /// The accumulated film.
    pub film: Film,
    /// Rays traced, by kind.
    pub rays: RayCounts,
    /// Rejected samples.
    pub nonfinite: NonFiniteReport,
    /// Wall-clock seconds spent rendering.
    pub seconds: f64,
    /// Threads actually used.
    pub threads: usize,
}

struct TileResult {
    tile: Tile,
    rays: RayCounts,
    nonfinite: NonFiniteReport,
}

/// What one pass added besides the samples in the film.
#[derive(Debug, Clone, Default)]
pub struct PassOutput {
    /// Rays traced, by kind.
    pub rays: RayCounts,
    /// Rejected samples.
    pub nonfinite: NonFiniteReport,
}

/// A pool of `threads` workers (0 = one per core).
pub fn thread_pool(threads: usize) -> Result<rayon::ThreadPool> {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .map_err(|e| Error::Settings(format!("cannot start {threads} threads: {e}")))
}

/// Render `settings.spp` samples per pixel into a new film. `on_tile` is called
/// after each finished tile (for progress bars).
pub fn render(
    tracer: &PathTracer<'_>,
    camera: &Camera,
    settings: &RenderSettings,
    on_tile: &(dyn Fn() + Sync),
) -> Result<RenderOutput> {
    let [w, h] = settings.resolution;
    let mut film = Film::new(w, h);
    let pool = thread_pool(settings.threads)?;
    let start = Instant::now();
    let pass = render_pass(tracer, camera, settings, &mut film, None, &pool, on_tile);
    Ok(RenderOutput {
        film,
        rays: pass.rays,
        nonfinite: pass.nonfinite,
        seconds: start.elapsed().as_secs_f64(),
        threads: pool.current_num_threads(),
    })
}

/// Add samples `first_sample .. first_sample + spp` to every pixel of `film`
/// whose entry in `active` (row-major, one per pixel) is true, or to every
/// pixel when `active` is `None`. Each pixel's samples are summed in index
/// order onto what it holds, so passes of `n` and then `m` samples give the
/// same bits as one pass of `n + m`.
pub fn render_pass(
    tracer: &PathTracer<'_>,
    camera: &Camera,
    settings: &RenderSettings,
    film: &mut Film,
    active: Option<&[bool]>,
    pool: &rayon::ThreadPool,
    on_tile: &(dyn Fn() + Sync),
) -> PassOutput {
    let bounds = film.tiles(settings.tile_size.max(1));
    let state: &Film = film;
    let results: Vec<TileResult> = pool.install(|| {
        bounds
            .par_iter()
            .map(|b| {
                let r = render_tile(tracer, camera, settings, active, state.tile_state(*b));
                on_tile();
                r
            })
            .collect()
    });
    let mut out = PassOutput::default();
    for r in &results {
        film.store_tile(&r.tile);
        out.rays.add(&r.rays);
        out.nonfinite.merge(&r.nonfinite);
    }
    out
}

fn render_tile(
    tracer: &PathTracer<'_>,
    camera: &Camera,
    settings: &RenderSettings,
    active: Option<&[bool]>,
    mut tile: Tile,
) -> TileResult {
    let mut rays = RayCounts::default();
    let mut nonfinite = NonFiniteReport::default();
    let b = tile.bounds();
    let width = settings.resolution[0] as u64;
    for y in b.y0..b.y0 + b.height {
        for x in b.x0..b.x0 + b.width {
            let pixel = y as u64 * width + x as u64;
            if active.is_some_and(|a| !a[pixel as usize]) {
                continue;
            }
            for s in settings.first_sample..settings.first_sample + settings.spp {
                let mut sampler =
                    Sampler::with_kind(settings.sampler, settings.seed, pixel, s as u64);
                let jitter = sampler.next_2d();
                let ray = camera.generate_ray(Vec2::new(x as f32, y as f32) + jitter);
                let l = tracer.li(&ray, &mut sampler, &mut rays);
                if l.is_finite() && l.min_element() >= 0.0 {
                    tile.add_sample(x, y, l);
                } else {
                    nonfinite.count += 1;
                    if nonfinite.pixels.len() < NONFINITE_PIXELS_KEPT {
                        nonfinite.pixels.push([x, y]);
                    }
                }
            }
        }
    }
    TileResult {
        tile,
        rays,
        nonfinite,
    }
}
