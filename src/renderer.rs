//! The library's front door: render a loaded [`Scene`] to an image in a few
//! lines, with the same settings, limits and estimator as `embertrace
//! render` (see the crate docs for an example).
//!
//! Anything left unset takes the scene file's value, else the renderer's
//! default, exactly as a flag left off the command line does; the settings
//! go through [`settings::resolve`], so the limits of [`crate::limits`] hold
//! here too. The estimator runs the kernel specialised for the scene's
//! effects ([`Plan`]), which renders the same image bits as the general one.

use crate::accel::{self, AccelOptions, Backend};
use crate::error::{Error, Result};
use crate::film::Film;
use crate::image::{self, OutputOptions};
use crate::integrator::{PathTracer, RayCounts};
use crate::plan::{Plan, PlanMode};
use crate::render::{self, RenderSettings};
use crate::sampler::{SampleSpace, SamplerKind};
use crate::scene::Scene;
use crate::settings::{self, Flags};
use std::path::Path;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Instant;

/// A render of one scene, configured by chained setters and run by
/// [`Renderer::render`].
#[derive(Debug, Clone)]
pub struct Renderer<'s> {
    scene: &'s Scene,
    /// `None`: [`Backend::for_scene`], as the command line picks.
    backend: Option<Backend>,
    sampler: SamplerKind,
    flags: Flags,
    denoise: bool,
    guiding: crate::guiding::GuidingMode,
}

impl<'s> Renderer<'s> {
    /// A render of `scene` with its own settings, on the backend the
    /// command line would take ([`Backend::for_scene`]) and the default
    /// sampler.
    pub fn new(scene: &'s Scene) -> Self {
        Renderer {
            scene,
            backend: None,
            sampler: SamplerKind::default(),
            flags: Flags::default(),
            denoise: false,
            guiding: crate::guiding::GuidingMode::default(),
        }
    }

    /// Path guiding ([`crate::guiding`]), as `render --guiding` (default
    /// `auto`).
    pub fn guiding(mut self, mode: crate::guiding::GuidingMode) -> Self {
        self.guiding = mode;
        self
    }

    /// Denoise the image at the end ([`crate::denoise::denoise_film`]):
    /// [`Rendered::pixels`] and [`Rendered::write`] then give the denoised
    /// image. Rendering fails with a settings error in a build without the
    /// `denoise` feature.
    pub fn denoise(mut self, denoise: bool) -> Self {
        self.denoise = denoise;
        self
    }

    /// The ray-query backend.
    pub fn backend(mut self, backend: Backend) -> Self {
        self.backend = Some(backend);
        self
    }

    /// The sample generator.
    pub fn sampler(mut self, sampler: SamplerKind) -> Self {
        self.sampler = sampler;
        self
    }

    /// Samples per pixel.
    pub fn spp(mut self, spp: u32) -> Self {
        self.flags.spp = Some(spp);
        self
    }

    /// Image width and height in pixels.
    pub fn resolution(mut self, width: u32, height: u32) -> Self {
        self.flags.resolution = Some([width, height]);
        self
    }

    /// Maximum path length in bounces.
    pub fn max_depth(mut self, depth: u32) -> Self {
        self.flags.max_depth = Some(depth);
        self
    }

    /// Random seed: the same seed gives the same image bits, whatever the
    /// thread count.
    pub fn seed(mut self, seed: u64) -> Self {
        self.flags.seed = Some(seed);
        self
    }

    /// Render threads; 0 (the default) is one per core.
    pub fn threads(mut self, threads: usize) -> Self {
        self.flags.threads = threads;
        self
    }

    /// Build the backend and render. Errors: settings beyond the limits, a
    /// backend that is not compiled in, or one that fails to build.
    pub fn render(&self) -> Result<Rendered> {
        self.render_in_passes(1, &AtomicBool::new(false), &|_| {})
    }

    /// Render in `passes` passes of whole sample indices (as equal as they
    /// divide; at most one per sample), calling `on_pass` after each and
    /// checking `stop` before each: set, the render ends with
    /// [`Error::Interrupted`] after the pass under way. The image is the same,
    /// bit for bit, as [`Renderer::render`]'s: each pixel's samples are
    /// summed in index order whatever the passes.
    pub fn render_in_passes(
        &self,
        passes: u32,
        stop: &AtomicBool,
        on_pass: &(dyn Fn(PassProgress) + Sync),
    ) -> Result<Rendered> {
        let scene = self.scene;
        let s = settings::resolve(&scene.render, scene.resolution, &self.flags)?;
        if self.denoise && !crate::denoise::AVAILABLE {
            return Err(Error::Settings(crate::denoise::HOW_TO_GET.to_string()));
        }
        let soup = scene.soup();
        let backend = self.backend.unwrap_or_else(|| Backend::for_scene(&soup));
        let accel = accel::build(backend, soup, AccelOptions::default())?;
        let kernel = Plan::new(scene, &s.integrator).kernel_for(PlanMode::Specialised);
        let mut tracer = PathTracer::with_kernel(scene, accel.as_ref(), s.integrator, kernel);
        let [w, h] = s.resolution;
        let camera = scene.make_camera(w, h);
        let pool = render::thread_pool(s.threads)?;
        crate::integrator::training::prepare(
            &mut tracer,
            scene,
            &camera,
            &crate::integrator::training::GuidingRequest {
                mode: self.guiding,
                resolution: s.resolution,
                seed: s.seed,
                spp: s.spp,
                progressive: false,
                reuse: true,
            },
            &pool,
        );
        let tracer = tracer;
        let mut film = Film::new(w, h);
        if let Some(kept) = tracer.guide().and_then(|g| g.reused()) {
            film.add_overlap(kept);
        }
        let mut rays = RayCounts::default();
        let passes = passes.clamp(1, s.spp.max(1));
        let start = Instant::now();
        let mut done = 0;
        for pass in 0..passes {
            if stop.load(Ordering::SeqCst) {
                return Err(Error::Interrupted(format!(
                    "render stopped after {done} of {} samples per pixel",
                    s.spp
                )));
            }
            // pass `pass` ends at sample floor(spp * (pass + 1) / passes)
            let end = (u64::from(s.spp) * u64::from(pass + 1) / u64::from(passes)) as u32;
            let settings = RenderSettings {
                resolution: s.resolution,
                spp: end - done,
                first_sample: done,
                total_spp: Some(s.spp),
                seed: s.seed,
                threads: s.threads,
                tile_size: s.tile_size,
                sampler: self.sampler,
                clamp: None,
            };
            let out =
                render::render_pass(&tracer, &camera, &settings, &mut film, None, &pool, &|| {});
            rays.add(&out.rays);
            done = end;
            on_pass(PassProgress {
                pass: pass + 1,
                passes,
                samples: done,
                spp: s.spp,
                seconds: start.elapsed().as_secs_f64(),
            });
        }
        let seconds = start.elapsed().as_secs_f64();
        let denoised = if self.denoise {
            let rays = crate::denoise::CameraRays {
                tracer: &tracer,
                camera: &camera,
                space: SampleSpace::new(self.sampler, s.seed, s.resolution, s.spp),
                seed: s.seed,
            };
            let samples = vec![s.spp; w as usize * h as usize];
            Some(rays.denoise_render(&film, &samples)?.image)
        } else {
            None
        };
        Ok(Rendered {
            film,
            rays,
            seconds,
            denoised,
        })
    }
}

/// Where a render in passes ([`Renderer::render_in_passes`]) stands after a
/// pass.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PassProgress {
    /// Passes finished, from 1.
    pub pass: u32,
    /// Passes in all.
    pub passes: u32,
    /// Samples per pixel finished.
    pub samples: u32,
    /// Samples per pixel in all.
    pub spp: u32,
    /// Seconds since the first pass began.
    pub seconds: f64,
}

/// A finished render.
#[derive(Debug)]
pub struct Rendered {
    /// The accumulated film: per-pixel means and variances.
    pub film: Film,
    /// Rays traced, by kind.
    pub rays: RayCounts,
    /// Wall-clock seconds spent rendering (before any denoising).
    pub seconds: f64,
    /// The denoised image ([`Renderer::denoise`]), linear RGB row by row.
    pub denoised: Option<Vec<[f64; 3]>>,
}

impl Rendered {
    /// Write the image (the denoised one when there is one); the extension
    /// picks the format (`.png`: 8-bit sRGB, `.exr` and `.pfm`: linear
    /// `f32`), written atomically.
    pub fn write(&self, path: &Path) -> Result<()> {
        match &self.denoised {
            Some(d) => image::write_rgb(
                path,
                self.film.width(),
                self.film.height(),
                d,
                &OutputOptions::default(),
            ),
            None => image::write_image(path, &self.film, &OutputOptions::default()),
        }
    }

    /// The image (the denoised one when there is one) as linear RGB, row by
    /// row from the top left.
    pub fn pixels(&self) -> Vec<[f32; 3]> {
        match &self.denoised {
            Some(d) => d.iter().map(|p| p.map(|v| v as f32)).collect(),
            None => self
                .film
                .to_rgb_f32()
                .chunks_exact(3)
                .map(|c| [c[0], c[1], c[2]])
                .collect(),
        }
    }
}
