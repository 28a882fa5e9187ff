//! The parallel render loop: rayon over tiles, every sample seeded by
//! (seed, pixel, sample index), tiles merged into the film in a fixed order,
//! so the image is bit-identical for any thread count.
//!
//! Non-finite and negative samples are not silently zeroed: each is counted,
//! its pixel recorded, and it is left out of that pixel's accumulation.

use crate::camera::Camera;
use crate::error::{Error, Result};
use crate::film::{Film, Tile};
use crate::integrator::{BATCH, BLOCK, Lane, PathTracer, RayCounts};
use crate::math::{Ray, Vec2, Vec3};
use crate::sampler::{SampleSpace, Sampler, SamplerKind};
use rayon::prelude::*;
use std::time::Instant;

/// What the render loop asks of an estimator: the radiance of one sample.
/// The path tracer is one; tests implement it to inject known samples (NaN,
/// negative, bright) at chosen pixels.
pub trait Radiance: Sync {
    /// Radiance along `ray`, sample `sample` of pixel `pixel`.
    fn radiance(
        &self,
        pixel: [u32; 2],
        sample: u32,
        ray: &Ray,
        sampler: &mut Sampler,
        rays: &mut RayCounts,
    ) -> Vec3;

    /// The camera ray through film position `p` (pixels). By default a lens
    /// sample is drawn when the camera has an aperture.
    fn camera_ray(&self, camera: &Camera, p: Vec2, sampler: &mut Sampler) -> Ray {
        if camera.lens().is_pinhole() {
            camera.generate_ray(p)
        } else {
            camera.generate_ray_lens(p, sampler.next_2d())
        }
    }

    /// Sample `sample` of each of `pixels` at once: `lanes[i]` holds pixel
    /// `pixels[i]`'s camera ray and sampler, and gets its radiance in `l`.
    /// By default one sample at a time through [`Radiance::radiance`]; the
    /// path tracer traces them as one batch.
    fn radiance_batch(
        &self,
        pixels: &[[u32; 2]],
        sample: u32,
        lanes: &mut [Lane],
        rays: &mut RayCounts,
    ) {
        for (&pixel, lane) in pixels.iter().zip(lanes) {
            lane.l = self.radiance(pixel, sample, &lane.ray, &mut lane.sampler, rays);
        }
    }
}

impl Radiance for PathTracer<'_> {
    fn radiance(
        &self,
        _pixel: [u32; 2],
        _sample: u32,
        ray: &Ray,
        sampler: &mut Sampler,
        rays: &mut RayCounts,
    ) -> Vec3 {
        self.li(ray, sampler, rays)
    }

    fn camera_ray(&self, camera: &Camera, p: Vec2, sampler: &mut Sampler) -> Ray {
        PathTracer::camera_ray(self, camera, p, sampler)
    }

    fn radiance_batch(
        &self,
        pixels: &[[u32; 2]],
        _: u32,
        lanes: &mut [Lane],
        rays: &mut RayCounts,
    ) {
        if let Some(g) = self.guide() {
            for (&[x, y], lane) in pixels.iter().zip(lanes.iter_mut()) {
                lane.set_roulette_scale(g.roulette_scale(x, y));
            }
        }
        self.trace(lanes, rays);
    }
}

/// How many offending pixels a report keeps.
pub const NONFINITE_PIXELS_KEPT: usize = 16;

/// What the render loop needs besides the scene and estimator.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RenderSettings {
    /// Image width and height.
    pub resolution: [u32; 2],
    /// Samples per pixel in this call.
    pub spp: u32,
    /// Index of the first sample (progressive passes continue the sequence).
    pub first_sample: u32,
    /// Samples per pixel of the whole render, all its calls together (a
    /// progressive render's cap), for samplers whose points depend on it
    /// (`zsobol`); `None`: this call's `first_sample + spp`.
    pub total_spp: Option<u32>,
    /// Random seed.
    pub seed: u64,
    /// Worker threads; 0 = all cores.
    pub threads: usize,
    /// Tile side in pixels.
    pub tile_size: u32,
    /// Sample generator.
    pub sampler: SamplerKind,
    /// Largest component a sample may have (`--clamp`); `None` keeps every
    /// sample as it is (no bias).
    pub clamp: Option<f32>,
}

/// Samples that were NaN, infinite or negative, and where. Such a sample
/// is left out of its pixel (which then averages the samples it kept: a
/// pixel that loses samples this way is biased by whatever made them bad,
/// which is why they are counted and reported rather than zeroed).
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct NonFiniteReport {
    /// How many samples were rejected.
    pub count: u64,
    /// Of which had a NaN component.
    pub nan: u64,
    /// Had an infinite component (and no NaN).
    pub inf: u64,
    /// Were finite with a negative component.
    pub negative: u64,
    /// Rejected samples per pixel, row-major; empty until the first one.
    pub per_pixel: Vec<u32>,
    /// The first [`NONFINITE_PIXELS_KEPT`] pixels with a rejected sample,
    /// `[x, y]` in scan order (the same for any thread count or tiling).
    pub pixels: Vec<[u32; 2]>,
}

impl NonFiniteReport {
    /// Add `other`'s counts.
    pub fn merge(&mut self, other: &NonFiniteReport) {
        self.count += other.count;
        self.nan += other.nan;
        self.inf += other.inf;
        self.negative += other.negative;
        if !other.per_pixel.is_empty() {
            if self.per_pixel.is_empty() {
                self.per_pixel = vec![0; other.per_pixel.len()];
            }
            for (a, b) in self.per_pixel.iter_mut().zip(&other.per_pixel) {
                *a += b;
            }
        }
    }

    /// Record a rejected sample `l` at pixel `index` of an image `width`
    /// pixels wide and `n_pixels` in all.
    fn record(&mut self, l: Vec3, index: usize, n_pixels: usize) {
        self.count += 1;
        if l.is_nan() {
            self.nan += 1;
        } else if !l.is_finite() {
            self.inf += 1;
        } else {
            self.negative += 1;
        }
        if self.per_pixel.is_empty() {
            self.per_pixel = vec![0; n_pixels];
        }
        self.per_pixel[index] += 1;
    }

    /// Fill [`Self::pixels`] from the per-pixel counts.
    pub fn finish(&mut self, width: u32) {
        self.pixels = self
            .per_pixel
            .iter()
            .enumerate()
            .filter(|&(_, &c)| c > 0)
            .take(NONFINITE_PIXELS_KEPT)
            .map(|(i, _)| [i as u32 % width, i as u32 / width])
            .collect();
    }
}

/// What `--clamp` removed: clamping bounds each sample's largest component,
/// scaling the sample down (its hue kept). It trades variance for bias; the
/// report says how much energy it took.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct ClampReport {
    /// Samples that were scaled down.
    pub clamped: u64,
    /// Radiance removed, summed over all samples, per channel.
    pub removed: [f64; 3],
    /// Radiance kept, summed over all samples, per channel.
    pub kept: [f64; 3],
}

impl ClampReport {
    /// Add `other`'s counts.
    pub fn merge(&mut self, other: &ClampReport) {
        self.clamped += other.clamped;
        for c in 0..3 {
            self.removed[c] += other.removed[c];
            self.kept[c] += other.kept[c];
        }
    }

    /// Removed energy as a share of all energy (removed + kept), summed over
    /// channels; 0 when nothing was rendered.
    pub fn removed_fraction(&self) -> f64 {
        let r: f64 = self.removed.iter().sum();
        let k: f64 = self.kept.iter().sum();
        if r + k > 0.0 { r / (r + k) } else { 0.0 }
    }
}

/// Scale `l` so that its largest component is at most `max`, recording
/// what that removed.
fn clamp_sample(l: Vec3, max: Option<f32>, report: &mut ClampReport) -> Vec3 {
    let out = match max {
        Some(m) if l.max_element() > m => {
            report.clamped += 1;
            l * (m / l.max_element())
        }
        _ => l,
    };
    for c in 0..3 {
        report.removed[c] += f64::from(l[c]) - f64::from(out[c]);
        report.kept[c] += f64::from(out[c]);
    }
    out
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
    /// What `--clamp` removed.
    pub clamp: ClampReport,
    /// Wall-clock seconds spent rendering.
    pub seconds: f64,
    /// Threads actually used.
    pub threads: usize,
}

struct TileResult {
    tile: Tile,
    rays: RayCounts,
    nonfinite: NonFiniteReport,
    clamp: ClampReport,
}

/// What one pass added besides the samples in the film.
#[derive(Debug, Clone, Default)]
pub struct PassOutput {
    /// Rays traced, by kind.
    pub rays: RayCounts,
    /// Rejected samples.
    pub nonfinite: NonFiniteReport,
    /// What `--clamp` removed.
    pub clamp: ClampReport,
}

/// The side of the tiles a render works in for a requested `tile_size`:
/// rounded up to whole [`BLOCK`]s, so every tile holds whole blocks of the
/// image's block grid and a pixel's batch is the same whatever the tiling.
pub fn tile_side(tile_size: u32) -> u32 {
    tile_size.max(1).next_multiple_of(BLOCK)
}

/// A pool of `threads` workers (0 = one per core), at most
/// [`MAX_THREADS`](crate::limits::MAX_THREADS): every command's threads come from here.
pub fn thread_pool(threads: usize) -> Result<rayon::ThreadPool> {
    crate::limits::check_threads(threads).map_err(Error::Settings)?;
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .map_err(|e| Error::Settings(format!("cannot start {threads} threads: {e}")))
}

/// Render `settings.spp` samples per pixel into a new film. `on_tile` is called
/// after each finished tile (for progress bars).
pub fn render(
    tracer: &dyn Radiance,
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
        clamp: pass.clamp,
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
    tracer: &dyn Radiance,
    camera: &Camera,
    settings: &RenderSettings,
    film: &mut Film,
    active: Option<&[bool]>,
    pool: &rayon::ThreadPool,
    on_tile: &(dyn Fn() + Sync),
) -> PassOutput {
    let bounds = film.tiles(tile_side(settings.tile_size));
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
        out.clamp.merge(&r.clamp);
    }
    out.nonfinite.finish(film.width());
    out
}

fn render_tile(
    tracer: &dyn Radiance,
    camera: &Camera,
    settings: &RenderSettings,
    active: Option<&[bool]>,
    mut tile: Tile,
) -> TileResult {
    let mut rays = RayCounts::default();
    let mut nonfinite = NonFiniteReport::default();
    let mut clamp = ClampReport::default();
    let n_pixels = settings.resolution[0] as usize * settings.resolution[1] as usize;
    let b = tile.bounds();
    let width = settings.resolution[0] as u64;
    let space = SampleSpace::new(
        settings.sampler,
        settings.seed,
        settings.resolution,
        settings
            .total_spp
            .unwrap_or(settings.first_sample + settings.spp),
    );
    let mut pixels = [[0u32; 2]; BATCH];
    let mut lanes: Vec<Lane> = Vec::with_capacity(BATCH);
    // one batch per BLOCK x BLOCK block of the image's block grid (tiles hold
    // whole blocks, see `tile_side`) and sample index
    for by in (b.y0..b.y0 + b.height).step_by(BLOCK as usize) {
        for bx in (b.x0..b.x0 + b.width).step_by(BLOCK as usize) {
            let mut n = 0;
            for y in by..(by + BLOCK).min(b.y0 + b.height) {
                for x in bx..(bx + BLOCK).min(b.x0 + b.width) {
                    let pixel = y as u64 * width + x as u64;
                    if active.is_none_or(|a| a[pixel as usize]) {
                        pixels[n] = [x, y];
                        n += 1;
                    }
                }
            }
            for s in settings.first_sample..settings.first_sample + settings.spp {
                lanes.clear();
                for &[x, y] in &pixels[..n] {
                    let mut sampler = space.sampler(x, y, s);
                    let jitter = sampler.next_2d();
                    let ray = tracer.camera_ray(
                        camera,
                        Vec2::new(x as f32, y as f32) + jitter,
                        &mut sampler,
                    );
                    lanes.push(Lane::new(sampler, ray));
                }
                tracer.radiance_batch(&pixels[..n], s, &mut lanes, &mut rays);
                for (&[x, y], lane) in pixels[..n].iter().zip(&lanes) {
                    let l = lane.l;
                    if l.is_finite() && l.min_element() >= 0.0 {
                        tile.add_sample(x, y, clamp_sample(l, settings.clamp, &mut clamp));
                    } else {
                        let pixel = y as u64 * width + x as u64;
                        nonfinite.record(l, pixel as usize, n_pixels);
                    }
                }
            }
        }
    }
    TileResult {
        tile,
        rays,
        nonfinite,
        clamp,
    }
}

/// The denoiser's and compositor's auxiliary images
/// ([`crate::integrator::Auxiliary`]), per pixel row-major from the top.
#[derive(Debug, Clone, PartialEq)]
pub struct AuxiliaryImages {
    /// Mean first-hit albedo per pixel.
    pub albedo: Vec<[f64; 3]>,
    /// Mean first-hit shading normal per pixel (not renormalised: a pixel
    /// that straddles an edge averages its normals, as OIDN expects).
    pub normal: Vec<[f64; 3]>,
    /// Mean distance along the camera ray to the first hit, over the
    /// pixel's rays that hit something; 0 where none did (Mitsuba's `aov`
    /// integrator's convention).
    pub depth: Vec<f64>,
    /// Mean world-space position of the first hit, over the rays that hit;
    /// 0 where none did.
    pub position: Vec<[f64; 3]>,
    /// Mean radiance the camera ray's first hit emits (or the environment
    /// where it escapes): the image's noise-free part, which the denoiser
    /// leaves alone (see `crate::denoise`).
    pub emitted: Vec<[f64; 3]>,
    /// The same, re-estimated over a stratified grid of rays ([`edge_grid`])
    /// where the pixel's own rays disagree on it (an emitter's edge);
    /// elsewhere equal to `emitted`.
    pub emitted_fine: Vec<[f64; 3]>,
}

impl AuxiliaryImages {
    /// One image as `f32` RGB triples, flat: what the denoiser takes.
    pub fn flat_f32(image: &[[f64; 3]]) -> Vec<f32> {
        image.iter().flatten().map(|&v| v as f32).collect()
    }
}

/// One pixel's sums, then means, of [`AuxiliaryImages`].
#[derive(Default, Clone, Copy)]
struct AuxPixel {
    albedo: [f64; 3],
    normal: [f64; 3],
    depth: f64,
    position: [f64; 3],
    emitted: [f64; 3],
    emitted_fine: [f64; 3],
}

/// Salt that keeps the edge rays' stream apart from the image's.
const AUX_SALT: u64 = 0x6175_7869_6c69_6172;

/// The side of the stratified grid of camera rays that re-estimates a
/// pixel's emitted radiance where its own rays disagree on it by `contrast`
/// (the largest difference of a channel between two of them: the edge of a
/// light or of the sky), or `None` where they agree to within 2 % (of 1 +
/// the pixel's mean emission: a smooth sky is not an edge). A straight
/// edge through an n x n grid of jittered rays leaves the coverage wrong by
/// about `sqrt(n / 4) / n^2`, so the emission by `contrast / (2 n^1.5)`:
/// 16 keeps that near 0.01 up to a contrast of 1, 32 up to 4, and 64 (4096
/// rays, only at such pixels) at 0.017 for the Cornell box's light of 17
/// against its ceiling, where the image's own 16 rays leave about 1.
pub fn edge_grid(contrast: f32, mean: f32) -> Option<u32> {
    if contrast <= 0.02 * (1.0 + mean) {
        None
    } else if contrast < 1.0 {
        Some(16)
    } else if contrast < 4.0 {
        Some(32)
    } else {
        Some(64)
    }
}

/// The auxiliary images of a render, traced along the render's own camera
/// rays: pixel `i` averages [`PathTracer::auxiliary`] over its samples
/// `0..samples[i]` of `space` (jittered and lens-sampled exactly as
/// [`render_pass`] does), summed in sample order in `f64`. So `emitted` is,
/// bit for bit in what it sums, the part of each sample that the camera
/// ray's first hit emits, and the albedo and normal cover the pixel as the
/// image does. Each pixel is computed by one thread, so the images are the
/// same bits for any thread count.
pub fn render_auxiliary(
    tracer: &PathTracer<'_>,
    camera: &Camera,
    resolution: [u32; 2],
    space: &SampleSpace,
    samples: &[u32],
    seed: u64,
) -> AuxiliaryImages {
    let [w, h] = resolution;
    debug_assert_eq!(samples.len(), w as usize * h as usize);
    let traced: Vec<(AuxPixel, Vec3, Vec3)> = (0..w * h)
        .into_par_iter()
        .map(|i| {
            let (x, y) = (i % w, i / w);
            let mut p = AuxPixel::default();
            let mut hits = 0u32;
            let spp = samples[i as usize];
            let (mut lo, mut hi) = (Vec3::INFINITY, Vec3::NEG_INFINITY);
            for s in 0..spp {
                let mut sampler = space.sampler(x, y, s);
                let jitter = sampler.next_2d();
                let film = Vec2::new(x as f32, y as f32) + jitter;
                let ray = tracer.camera_ray(camera, film, &mut sampler);
                let aux = tracer.auxiliary(&ray);
                (lo, hi) = (lo.min(aux.emitted), hi.max(aux.emitted));
                for c in 0..3 {
                    p.albedo[c] += aux.albedo[c] as f64;
                    p.normal[c] += aux.normal[c] as f64;
                    p.emitted[c] += aux.emitted[c] as f64;
                }
                if let Some((at, distance)) = aux.first_hit {
                    hits += 1;
                    p.depth += distance as f64;
                    for c in 0..3 {
                        p.position[c] += at[c] as f64;
                    }
                }
            }
            let k = if spp > 0 { 1.0 / spp as f64 } else { 0.0 };
            let kh = if hits > 0 { 1.0 / hits as f64 } else { 0.0 };
            let emitted = p.emitted.map(|v| v * k);
            let pixel = AuxPixel {
                albedo: p.albedo.map(|v| v * k),
                normal: p.normal.map(|v| v * k),
                depth: p.depth * kh,
                position: p.position.map(|v| v * kh),
                emitted,
                emitted_fine: emitted,
            };
            (pixel, lo, hi)
        })
        .collect();
    // Where the emission varies within a pixel's 3 x 3 neighbourhood, its
    // own rays may all have missed an emitter that covers part of it (a
    // light's corner): re-estimate it there on a finer grid.
    let pixels: Vec<AuxPixel> = (0..w * h)
        .into_par_iter()
        .map(|i| {
            let (x, y) = (i % w, i / w);
            let (mut lo, mut hi) = (Vec3::INFINITY, Vec3::NEG_INFINITY);
            for ny in y.saturating_sub(1)..(y + 2).min(h) {
                for nx in x.saturating_sub(1)..(x + 2).min(w) {
                    let (_, l, u) = &traced[(ny * w + nx) as usize];
                    (lo, hi) = (lo.min(*l), hi.max(*u));
                }
            }
            let p = &traced[i as usize].0;
            let contrast = (hi - lo).max_element().max(0.0);
            let mean = p.emitted.iter().sum::<f64>() as f32 / 3.0;
            let emitted_fine = match edge_grid(contrast, mean) {
                Some(g) => edge_emission(tracer, camera, [x, y], g, seed ^ AUX_SALT, i),
                None => p.emitted,
            };
            AuxPixel { emitted_fine, ..*p }
        })
        .collect();
    AuxiliaryImages {
        albedo: pixels.iter().map(|p| p.albedo).collect(),
        normal: pixels.iter().map(|p| p.normal).collect(),
        depth: pixels.iter().map(|p| p.depth).collect(),
        position: pixels.iter().map(|p| p.position).collect(),
        emitted: pixels.iter().map(|p| p.emitted).collect(),
        emitted_fine: pixels.iter().map(|p| p.emitted_fine).collect(),
    }
}

/// Pixel `[x, y]`'s emitted radiance ([`Auxiliary`](crate::integrator::Auxiliary)'s
/// `emitted`) over a `g` x `g` stratified grid of camera
/// rays, jittered within their cells (and lens-sampled) from the stream of
/// (`seed`, pixel `i`).
fn edge_emission(
    tracer: &PathTracer<'_>,
    camera: &Camera,
    [x, y]: [u32; 2],
    g: u32,
    seed: u64,
    i: u32,
) -> [f64; 3] {
    let mut sum = [0.0f64; 3];
    for cell in 0..g * g {
        let mut sampler = Sampler::new(seed, i as u64, cell as u64);
        let u = sampler.next_2d();
        let film = Vec2::new(
            x as f32 + ((cell % g) as f32 + u.x) / g as f32,
            y as f32 + ((cell / g) as f32 + u.y) / g as f32,
        );
        let ray = tracer.camera_ray(camera, film, &mut sampler);
        let e = tracer.first_emission(&ray);
        for c in 0..3 {
            sum[c] += e[c] as f64;
        }
    }
    sum.map(|v| v / (g * g) as f64)
}
