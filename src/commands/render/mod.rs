//! `embertrace render`: a scene to an image, with its report
//! ([`report`]), sample maps, variance, and the farm's parts (shards, crops,
//! checkpoints).

mod finish;
pub mod report;

use super::{BuildArgs, check_exr, write_json, write_variance};
use crate::accel::{self, Backend};
use crate::commands::diff::{Image, compare};
use crate::error::clip;
use crate::error::{Error, Result};
use crate::farm::{self, Shard};
use crate::film;
use crate::guiding::GuidingMode;
use crate::image::{self, OutputOptions};
use crate::integrator::PathTracer;
use crate::integrator::training::GuidingReport;
use crate::log;
use crate::outputs::{self, Inputs};
use crate::plan::{Plan, PlanMode};
use crate::progressive::{Adaptive, Budget, CONFIDENCE, PassRecord, render_progressive};
use crate::render::{self, RenderSettings};
use crate::sampler::SamplerKind;
use crate::scene::Scene;
use crate::settings::{self, Flags, LightSampler, LightSampling};
use crate::settings::{DirectStrategy, IntegratorSettings, Roulette};
use clap::Args;
use indicatif::{ProgressBar, ProgressStyle};
use report::{ErrorEstimate, ProgressiveReport, RenderReport};
use std::path::PathBuf;
use std::time::Instant;

/// The arguments of `embertrace render`.
#[derive(Args)]
pub struct RenderArgs {
    /// Scene file: .toml, .obj, .ply, Mitsuba 3 .xml, CS184 .dae or CSE 167/168 .test.
    scene: PathBuf,
    /// Output image; the extension picks the format (.png, .exr, .pfm).
    #[arg(short = 'o', long = "output", visible_short_alias = 'f')]
    output: Option<PathBuf>,
    /// Samples per pixel [scene default, else 64].
    #[arg(short = 's', long = "spp", allow_negative_numbers = true)]
    spp: Option<u32>,
    /// Light samples per shading point; for a CS184 .dae scene, samples per
    /// area light as the course counts them [scene default, else 1].
    #[arg(short = 'l', long = "light-samples", allow_negative_numbers = true)]
    light_samples: Option<u32>,
    /// Maximum bounces: 0 = emission only, 1 = direct only [scene default, else 64].
    #[arg(short = 'm', long = "max-depth", allow_negative_numbers = true)]
    max_depth: Option<u32>,
    /// Resolution: width height [scene default].
    #[arg(short = 'r', long = "resolution", num_args = 2, value_names = ["W", "H"], allow_negative_numbers = true)]
    resolution: Option<Vec<u32>>,
    /// Render threads; 0 = all cores.
    #[arg(
        short = 't',
        long = "threads",
        default_value_t = 0,
        allow_negative_numbers = true
    )]
    threads: usize,
    /// Environment map with the CS184 course's layout (its `-e`: an
    /// equirectangular image whose azimuth runs from -x towards +z, read
    /// as the course reads it), replacing the scene's environment.
    #[arg(short = 'e', long = "course-envmap", value_name = "FILE")]
    course_envmap: Option<PathBuf>,
    /// Thin-lens aperture radius (the CS184 course's `-b`), replacing the
    /// scene's; 0 is a pinhole [scene's lens].
    #[arg(short = 'b', long = "lens-radius", allow_negative_numbers = true)]
    lens_radius: Option<f32>,
    /// Distance from the lens to the plane in focus, along the view (the
    /// CS184 course's `-d`) [the scene's; without one, 4.7 for a CS184 .dae
    /// as in the course, else the distance to the point looked at].
    #[arg(short = 'd', long = "focal-distance", allow_negative_numbers = true)]
    focal_distance: Option<f32>,
    /// With --resume: continue a checkpoint written by a build of different
    /// source (only when the pixels are known to agree).
    #[arg(long)]
    allow_mixed_builds: bool,
    /// The camera to render through, by name, in a glTF file with several
    /// [the file's first perspective camera].
    #[arg(long = "camera", value_name = "NAME")]
    camera: Option<String>,
    /// Vector instruction set of the estimator's kernels: auto (the widest
    /// the CPU has), avx512, avx2 or scalar (the x86-64 baseline). The
    /// image is the same bits on every level [env EMBERTRACE_SIMD, else auto].
    #[arg(long)]
    simd: Option<crate::simd::Choice>,
    /// Random seed [scene default, else 0].
    #[arg(long, allow_negative_numbers = true)]
    seed: Option<u64>,
    /// Sample generator: sobol (padded, Owen-scrambled Sobol points: the
    /// least error per unit of time), zsobol (the same along a Morton curve:
    /// blue-noise error, dearer per sample) or independent (PCG32).
    #[arg(long, default_value_t = SamplerKind::default())]
    sampler: SamplerKind,
    /// Ray-query backend: embree, bvh (pure Rust), naive (brute force) or
    /// embree+naive (Embree for camera rays, brute force for the rest)
    /// [embree+naive for a scene of at most 32 triangles and no spheres,
    /// else embree; bvh without Embree].
    #[arg(long)]
    accel: Option<Backend>,
    /// Direct lighting: mis, light or bsdf [scene default, else mis].
    #[arg(long)]
    direct: Option<DirectStrategy>,
    /// Estimator kernel: specialised (for the scene's effects, see
    /// `embertrace plan`) or general (every effect compiled in; same image).
    #[arg(long, default_value = "specialised")]
    plan: PlanMode,
    /// Fixed Russian-roulette continuation probability in [0, 1]
    /// [default: throughput-based].
    #[arg(long = "rr", value_name = "P", allow_negative_numbers = true)]
    rr: Option<f32>,
    /// First bounce at which Russian roulette may end a path [default: the
    /// scene's, 3 unless it says].
    #[arg(long = "rr-depth", allow_negative_numbers = true)]
    rr_depth: Option<u32>,
    /// Light selection: auto (the light BVH from 8 lights that are not at
    /// infinity, else power), power (in proportion to power) or bvh (by a
    /// light BVH, by importance at the shading point) [default: auto].
    #[arg(long = "light-sampler", value_name = "auto|power|bvh")]
    light_sampler: Option<LightSampler>,
    /// Where non-delta bounces sample lights: auto (everywhere but where
    /// the BSDF's lobes are far narrower than the lights: a fixed rule
    /// under the uniform sky, a pre-pass under an environment map) or
    /// always [default: auto].
    #[arg(long = "light-sampling", value_name = "auto|always")]
    light_sampling: Option<LightSampling>,
    /// Path guiding: auto (where a pre-pass finds most of the light arriving
    /// after the first bounce, the guide is trained and kept if a guided
    /// pre-pass reaches a lower error in the same time), on or off. A guided
    /// render first trains the guide over 1, 2, 4, ... spp (a quarter of
    /// -s), and its Russian roulette is adjoint-driven.
    #[arg(long, value_name = "auto|on|off", default_value_t = GuidingMode::Auto)]
    guiding: GuidingMode,
    /// Write a JSON report of the run.
    #[arg(long, value_name = "FILE")]
    report: Option<PathBuf>,
    /// Exposure in stops, applied to PNG output.
    #[arg(
        long,
        default_value_t = 0.0,
        allow_negative_numbers = true,
        value_parser = crate::commands::parse_exposure
    )]
    exposure: f32,
    #[command(flatten)]
    build: BuildArgs,
    /// Tile side in pixels.
    #[arg(long, default_value_t = 16, allow_negative_numbers = true)]
    tile_size: u32,
    /// Fail (non-zero exit, no image) if any sample is NaN, infinite or negative.
    #[arg(long)]
    strict: bool,
    /// Write where NaN, infinite or negative samples were: PNG (black where
    /// none, brighter red for more) or EXR/PFM (the count per pixel).
    #[arg(long, value_name = "FILE")]
    aov: Option<PathBuf>,
    /// Write the first-hit albedo (OIDN's definition: delta surfaces
    /// followed) averaged over each pixel's rays, for a denoiser (.exr).
    #[arg(long, value_name = "FILE")]
    albedo: Option<PathBuf>,
    /// Write the first-hit shading normal averaged over each pixel's rays,
    /// for a denoiser (.exr).
    #[arg(long, value_name = "FILE")]
    normal: Option<PathBuf>,
    /// Denoise the image with Intel Open Image Denoise (the RT filter, HDR,
    /// with the albedo and normal as auxiliary images): -o gets the denoised
    /// image. Needs a build with `--features denoise`.
    #[arg(long)]
    denoise: bool,
    /// With --denoise, also write the image as rendered, before denoising.
    #[arg(long, value_name = "FILE")]
    noisy: Option<PathBuf>,
    /// Write one layered OpenEXR file: the image (R, G, B), then albedo,
    /// normal (world space, X Y Z), depth (distance along the camera ray,
    /// Z), position (world space) and variance (of each pixel's mean).
    #[arg(long, value_name = "FILE")]
    aovs: Option<PathBuf>,
    /// Scale every sample down so that no component exceeds MAX (biased:
    /// the report states the energy removed) [default: no clamp].
    #[arg(long, value_name = "MAX", allow_negative_numbers = true)]
    clamp: Option<f32>,
    /// Stop after the pass that reaches this many seconds of rendering
    /// (-s, if given, still caps the samples per pixel).
    #[arg(long, value_name = "SECONDS", allow_negative_numbers = true)]
    time_limit: Option<f64>,
    /// Stop when the estimated relative error of the image (95 %
    /// confidence) is at most E.
    #[arg(long, value_name = "E", allow_negative_numbers = true)]
    target_error: Option<f64>,
    /// Adaptive sampling: every BATCH samples, stop sampling a pixel whose
    /// 95 % confidence interval is within TOL of its mean (-s is the most).
    #[arg(short = 'a', num_args = 2, value_names = ["BATCH", "TOL"], allow_negative_numbers = true)]
    adaptive: Option<Vec<f64>>,
    /// Write where the samples went (samples per pixel, false colour) as PNG.
    #[arg(long, value_name = "FILE")]
    sample_map: Option<PathBuf>,
    /// A reference image (.exr or .pfm) for --convergence.
    #[arg(long, value_name = "FILE")]
    reference: Option<PathBuf>,
    /// After every pass, log seconds, spp, rays, RMSE and relative MSE
    /// against --reference to this CSV file (passes double the spp).
    #[arg(long, value_name = "FILE")]
    convergence: Option<PathBuf>,
    /// Render the K-th of N equal parts of every pixel's samples; -o then
    /// writes an accumulation file (.exr) for `embertrace merge`.
    #[arg(long, value_name = "K/N", value_parser = Shard::parse)]
    shard: Option<Shard>,
    /// Render only the pixels [X0, X1) x [Y0, Y1) (origin top left); -o then
    /// writes an accumulation file (.exr) for `embertrace merge`.
    #[arg(long, num_args = 4, value_names = ["X0", "Y0", "X1", "Y1"], allow_negative_numbers = true)]
    crop: Option<Vec<u32>>,
    /// Save the render's state (an accumulation file) to FILE as it goes, at
    /// the end, and on SIGINT or SIGTERM.
    #[arg(long, value_name = "FILE")]
    checkpoint: Option<PathBuf>,
    /// Seconds between checkpoints.
    #[arg(
        long,
        value_name = "SECONDS",
        default_value_t = 60.0,
        requires = "checkpoint",
        allow_negative_numbers = true
    )]
    checkpoint_every: f64,
    /// Continue the render saved in FILE to -s samples per pixel (it keeps
    /// saving to FILE unless --checkpoint names another); a guided render
    /// samples from the guide FILE holds, without training again.
    #[arg(long, value_name = "FILE")]
    resume: Option<PathBuf>,
    /// Write the per-pixel variance of the mean, per channel, as EXR.
    #[arg(long, value_name = "FILE")]
    variance: Option<PathBuf>,
}

/// Samples per pixel at most when a time or error budget is given without -s.
const BUDGET_MAX_SPP: u32 = 1 << 20;

/// Run `embertrace render`.
pub fn run(args: RenderArgs) -> Result<()> {
    if let Some(choice) = args.simd {
        crate::simd::set_active(choice.resolve().map_err(Error::Settings)?);
    }
    let output = args.output.clone().unwrap_or_else(|| {
        let stem = args.scene.file_stem().unwrap_or_default().to_string_lossy();
        PathBuf::from(format!("{stem}.png"))
    });
    // every file the render writes; a resumed render saves to its --resume
    // file unless --checkpoint names another
    let written: Vec<outputs::Output<'_>> = [
        ("-o", Some(&output)),
        ("--report", args.report.as_ref()),
        ("--aov", args.aov.as_ref()),
        ("--albedo", args.albedo.as_ref()),
        ("--normal", args.normal.as_ref()),
        ("--noisy", args.noisy.as_ref()),
        ("--aovs", args.aovs.as_ref()),
        ("--sample-map", args.sample_map.as_ref()),
        ("--convergence", args.convergence.as_ref()),
        ("--checkpoint", args.checkpoint.as_ref()),
        (
            "--resume",
            args.resume.as_ref().filter(|_| args.checkpoint.is_none()),
        ),
        ("--variance", args.variance.as_ref()),
    ]
    .into_iter()
    .filter_map(|(flag, path)| Some((flag, path?.as_path())))
    .collect();
    outputs::check_distinct(&written)?;
    image::check_output_path(&output)?;
    if let Some(r) = &args.report {
        crate::commands::render::report::check_report_path(r)?;
    }
    let say = log::note;
    let adaptive = match args.adaptive.as_deref() {
        None => None,
        Some(&[batch, tolerance]) => {
            if !(batch >= 2.0 && batch.fract() == 0.0 && batch <= u32::MAX as f64) {
                return Err(Error::Settings(format!(
                    "-a {batch} {tolerance}: the batch must be a whole number of samples, at least 2"
                )));
            }
            Some(Adaptive {
                batch: batch as u32,
                tolerance,
            })
        }
        Some(_) => unreachable!("clap takes exactly two values for -a"),
    };
    let mut budget = Budget {
        max_spp: 0,
        time_limit: args.time_limit,
        target_error: args.target_error,
        adaptive,
    };
    budget.validate()?;
    if let Some(p) = &args.aov {
        image::check_output_path(p)?;
    }
    for (flag, p) in [("--albedo", &args.albedo), ("--normal", &args.normal)] {
        if let Some(p) = p {
            let exr = p.extension().is_some_and(|e| e.eq_ignore_ascii_case("exr"));
            if !exr {
                return Err(Error::Settings(format!(
                    "{flag} {}: the denoiser's auxiliary images are written as .exr",
                    p.display()
                )));
            }
            image::check_output_path(p)?;
        }
    }
    if let Some(c) = args.clamp {
        if !(c > 0.0 && c.is_finite()) {
            return Err(Error::Settings(format!(
                "--clamp must be a positive number, not {c}"
            )));
        }
    }
    if let Some(p) = &args.sample_map {
        if !budget.is_progressive() {
            return Err(Error::Settings(
                "--sample-map needs adaptive sampling (-a) or a budget: with a fixed spp every pixel gets the same".into(),
            ));
        }
        image::check_output_path(p)?;
    }
    if let Some(p) = &args.convergence {
        crate::commands::render::report::check_report_path(p)?;
    }
    if args.convergence.is_some() != args.reference.is_some() {
        return Err(Error::Settings(
            "--convergence and --reference go together: the log measures error against the reference".into(),
        ));
    }
    let reference = args.reference.as_deref().map(Image::read).transpose()?;
    let farm_part = args.shard.is_some() || args.crop.is_some();
    let farm = farm_part || args.checkpoint.is_some() || args.resume.is_some();
    if farm {
        if budget.is_progressive() || args.reference.is_some() || args.sample_map.is_some() {
            return Err(Error::Settings(
                "--shard, --crop, --checkpoint and --resume render a fixed spp: they do not combine with --time-limit, --target-error, -a, --reference or --sample-map".into(),
            ));
        }
        if farm_part {
            check_exr(
                &output,
                "-o: --shard and --crop write an accumulation file for `embertrace merge`",
            )?;
        }
        if !(args.checkpoint_every > 0.0 && args.checkpoint_every.is_finite()) {
            return Err(Error::Settings(format!(
                "--checkpoint-every {}: expected a positive number of seconds",
                args.checkpoint_every
            )));
        }
        if let Some(c) = &args.checkpoint {
            check_exr(c, "--checkpoint: a checkpoint is an accumulation file")?;
        }
    }
    finish::check(&args, farm)?;
    if let Some(v) = &args.variance {
        check_exr(v, "--variance")?;
    }

    let t0 = Instant::now();
    let options = crate::scene::LoadOptions {
        camera: args.camera.clone(),
    };
    let mut scene = Scene::load_with(&args.scene, &options)?;
    if args.lens_radius.is_some() || args.focal_distance.is_some() {
        scene.lens = lens_from_flags(&scene, &args.scene, args.lens_radius, args.focal_distance)?;
    }
    if let Some(file) = &args.course_envmap {
        let map = crate::texture::ImageTexture::load(file)?;
        let laid_out = crate::light::envmap::from_course_layout(&map)
            .and_then(|m| crate::light::EnvironmentMap::new(m, crate::math::Vec3::ONE))
            .map_err(|e| match e {
                Error::Settings(m) => Error::input(file, None, m),
                other => other,
            })?;
        if scene.environment_map.is_some() || scene.environment.is_some() {
            say("note: -e replaces the scene's environment");
        }
        scene.environment = None;
        scene.environment_map = Some(laid_out);
    }
    let load_seconds = t0.elapsed().as_secs_f64();
    let mut inputs = Inputs::of_scene(&scene);
    if let Some(file) = &args.course_envmap {
        inputs.add(file, "the -e environment map");
    }
    if let Some(r) = &args.reference {
        inputs.add(r, "the --reference image");
    }
    if let (Some(r), Some(c)) = (&args.resume, &args.checkpoint) {
        if !outputs::same_file(r, c) {
            inputs.add(r, "the render --resume continues");
        }
    }
    outputs::check(&written, &inputs)?;

    // with a time or error budget and no -s, passes go on to BUDGET_MAX_SPP
    let budget_spp =
        (budget.time_limit.is_some() || budget.target_error.is_some()).then_some(BUDGET_MAX_SPP);
    let flags = Flags {
        spp: args.spp.or(budget_spp),
        max_depth: args.max_depth,
        light_samples: args.light_samples,
        resolution: args.resolution.as_deref().map(|r| [r[0], r[1]]),
        seed: args.seed,
        direct: args.direct,
        rr: args.rr,
        rr_depth: args.rr_depth,
        light_sampler: args.light_sampler,
        light_sampling: args.light_sampling,
        threads: args.threads,
        tile_size: Some(args.tile_size),
        ..Flags::default()
    };
    let resolved = settings::resolve(&scene.render, scene.resolution, &flags)?;
    let (resolution, spp, seed, integrator) = (
        resolved.resolution,
        resolved.spp,
        resolved.seed,
        resolved.integrator,
    );
    let [w, h] = resolution;
    for note in &scene.notes {
        say(&format!("note: {}", clip(note)));
    }
    // a warning is something the file asked for that the image lacks:
    // -q hides progress and notes, never these
    for warning in &scene.warnings {
        log::warn(&clip(warning));
    }
    let backend = args
        .accel
        .unwrap_or_else(|| Backend::for_scene(&scene.soup()));

    let t1 = Instant::now();
    let accel = accel::build(backend, scene.soup(), args.build.options())?;
    let accel_build_seconds = t1.elapsed().as_secs_f64();

    let camera = scene.make_camera(w, h);
    let plan = Plan::new(&scene, &integrator);
    let kernel = plan.kernel_for(args.plan);
    let mut tracer = PathTracer::with_kernel(&scene, accel.as_ref(), integrator, kernel);
    let settings = RenderSettings {
        total_spp: None,
        resolution,
        spp,
        first_sample: 0,
        seed,
        threads: resolved.threads,
        tile_size: resolved.tile_size,
        sampler: args.sampler,
        clamp: args.clamp,
    };
    let side = crate::render::tile_side(settings.tile_size);
    let tiles = (w.div_ceil(side) * h.div_ceil(side)) as u64;
    let bar = if log::progress_bars() {
        let b = ProgressBar::new(tiles);
        if let Ok(style) =
            ProgressStyle::with_template("{elapsed_precise} [{bar:40}] {percent}% eta {eta}")
        {
            b.set_style(style.progress_chars("=> "));
        }
        b
    } else {
        ProgressBar::hidden()
    };
    let inst = &scene.instances;
    let instanced = if inst.is_empty() {
        String::new()
    } else {
        format!(
            ", {} more in {} instances",
            inst.triangle_count(),
            inst.placements.len()
        )
    };
    say(&format!(
        "rendering {} ({} triangles{instanced}) at {w}x{h}, {spp} spp, max depth {}, backend {backend}",
        args.scene.display(),
        scene.triangle_count(),
        integrator.max_depth
    ));
    if log::enabled(log::Level::Verbose) {
        let library = matches!(backend, Backend::Embree | Backend::EmbreeNaive)
            .then(accel::embree_library)
            .flatten()
            .map_or(String::new(), |l| format!(" ({l})"));
        log::detail(&format!(
            "loaded in {load_seconds:.3} s; backend {backend}{library} built in {accel_build_seconds:.3} s, {} bytes",
            accel.memory_bytes()
        ));
        log::detail(&format!(
            "settings: seed {seed}, sampler {}, tiles of {side} px, {} threads, SIMD {}, effects [{}]",
            args.sampler,
            match resolved.threads {
                0 => std::thread::available_parallelism().map_or(1, usize::from),
                n => n,
            },
            crate::simd::active(),
            plan.on().join(", ")
        ));
        log::detail(&format!("kernel: {}", kernel.describe()));
        log::debug(&format!(
            "build {}",
            crate::build_info::LONG_VERSION.replace('\n', "; ")
        ));
    }
    budget.max_spp = spp;
    let progressive = budget.is_progressive() || reference.is_some();
    let request = crate::integrator::training::GuidingRequest {
        mode: args.guiding,
        resolution,
        seed,
        spp,
        progressive: budget.is_progressive(),
        reuse: args.clamp.is_none(),
    };
    // a guided checkpoint carries its guide: resume samples from it (under
    // --guiding off it is left, and the settings' check refuses the file)
    let saved_guide = match &args.resume {
        Some(path) if args.guiding != GuidingMode::Off => farm::read_guide(path)?,
        _ => None,
    };
    let guiding = match saved_guide {
        Some(guide) => crate::integrator::training::resume(&mut tracer, guide, &request),
        None => crate::integrator::training::prepare(
            &mut tracer,
            &scene,
            &camera,
            &request,
            &render::thread_pool(resolved.threads)?,
        ),
    };
    if let Some(choice) = &guiding.light_choice {
        say(&choice.describe());
    }
    if args.guiding != GuidingMode::Off {
        say(&guiding.describe());
    }
    let tracer = tracer;
    let mut part_provenance = None;
    let (out, progress) = if farm {
        bar.finish_and_clear();
        let provenance = farm::Provenance {
            version: env!("CARGO_PKG_VERSION").to_string(),
            build: crate::build_info::SOURCE_DIGEST.to_string(),
            scene: args
                .scene
                .file_name()
                .map(|n| n.to_string_lossy().into_owned())
                .unwrap_or_default(),
            scene_hash: farm::scene_hash(&scene),
            settings: image_settings(
                &settings,
                &integrator,
                backend,
                &args.build,
                &kernel.describe(),
                &guiding,
            ),
            samples: args.shard.map_or(0..spp, |s| s.samples(spp)),
            window: match &args.crop {
                Some(c) => farm::crop_window([c[0], c[1], c[2], c[3]], resolution)?,
                None => farm::full_window(resolution),
            },
        };
        let out = render_farm(&args, &tracer, &camera, &settings, &provenance, &say)?;
        // a part, or a checkpointed render's .exr: the state itself (whose
        // R, G, B are the image), so merge can take it too
        if farm_part || image::ImageFormat::from_path(&output)? == image::ImageFormat::Exr {
            part_provenance = Some(provenance);
        }
        (out, None)
    } else if progressive {
        if let Some(r) = &reference {
            if (r.width, r.height) != (w, h) {
                return Err(Error::Settings(format!(
                    "--reference is {}x{} but the render is {w}x{h}",
                    r.width, r.height
                )));
            }
        }
        bar.finish_and_clear();
        let mut log = String::from("pass,seconds,spp,samples,rays,rmse,rel_mse,relative_error\n");
        let mut on_pass = |p: &PassRecord, film: &film::Film| -> Result<()> {
            if let Some(r) = &reference {
                let img = Image {
                    width: w,
                    height: h,
                    rgb: film.to_rgb_f32(),
                };
                let d = compare(
                    &img,
                    r,
                    &args.scene,
                    args.reference
                        .as_deref()
                        .unwrap_or_else(|| std::path::Path::new("")),
                )?;
                log += &format!(
                    "{},{:.6},{},{},{},{:.6e},{:.6e},{:.6e}\n",
                    p.pass,
                    p.seconds,
                    p.spp,
                    p.samples,
                    p.rays,
                    d.rmse,
                    d.rel_mse,
                    p.relative_error
                );
            }
            log::note(&format!(
                "pass {}: {} spp, {:.2} s, relative error {:.4}, {} pixels active",
                p.pass, p.spp, p.seconds, p.relative_error, p.active_pixels
            ));
            Ok(())
        };
        let kept = tracer.guide().and_then(|g| g.reused());
        let po = render_progressive(&tracer, &camera, &settings, &budget, kept, &mut on_pass)?;
        if let Some(path) = &args.convergence {
            image::write_file_atomically(path, log.as_bytes())?;
        }
        if let Some(path) = &args.sample_map {
            write_sample_map(path, w, h, &po.pixel_samples)?;
        }
        let last = po.passes.last().copied();
        let info = ProgressiveReport {
            stop: po.stop,
            spp_reached: po.pixel_samples.iter().copied().max().unwrap_or(0),
            samples: last.map_or(0, |p| p.samples),
            passes: po.passes.len() as u32,
            time_limit: budget.time_limit,
            target_error: budget.target_error,
            relative_error: ErrorEstimate {
                estimate: last.map_or(f64::INFINITY, |p| p.relative_error),
                confidence: CONFIDENCE,
            },
        };
        (po.out, Some(info))
    } else {
        let mut out = render::render(&tracer, &camera, &settings, &|| bar.inc(1))?;
        if let Some(kept) = tracer.guide().and_then(|g| g.reused()) {
            out.film.add_overlap(kept);
        }
        bar.finish_and_clear();
        (out, None)
    };

    let report = RenderReport::new(
        &args.scene,
        backend.name(),
        &settings,
        &integrator,
        load_seconds,
        accel_build_seconds,
        &out,
        &output,
    );
    let mut report = report;
    report.effects = plan.on().iter().map(|n| n.to_string()).collect();
    report.kernel = kernel.describe();
    report.simd = crate::simd::active().to_string();
    report.guiding = Some(report::GuidingSummary::of(&guiding));
    report.light_sampling = guiding
        .light_choice
        .as_ref()
        .map(report::LightSamplingSummary::of);
    // the pre-pass and the training are part of the render's time
    report.render_seconds += guiding.prepass_seconds + guiding.train_seconds;
    if let Some(p) = progress {
        report.spp = p.spp_reached;
        log::note(&format!(
            "stopped ({:?}) at {} spp after {} passes; relative error {:.4} at {:.0} % confidence",
            p.stop,
            p.spp_reached,
            p.passes,
            p.relative_error.estimate,
            p.relative_error.confidence * 100.0
        ));
        report.progressive = Some(p);
    }
    let bad = &out.nonfinite;
    if bad.count > 0 {
        log::warn(&format!(
            "{} samples left out ({} NaN, {} infinite, {} negative), first at pixel {:?}",
            bad.count, bad.nan, bad.inf, bad.negative, bad.pixels[0]
        ));
        if args.strict {
            return Err(Error::Strict(format!(
                "--strict: {} NaN, infinite or negative samples, first at pixel {:?}; no image written",
                bad.count, bad.pixels[0]
            )));
        }
    }
    if let Some(c) = &report.clamp {
        say(&format!(
            "--clamp {}: {} samples scaled down, {:.3} % of the energy removed",
            c.max,
            c.clamped_samples,
            100.0 * c.removed_fraction
        ));
    }
    if let Some(p) = &args.aov {
        write_bad_sample_map(p, w, h, &bad.per_pixel)?;
    }
    let finished = finish::run(
        &args,
        &finish::Sources {
            rays: crate::denoise::CameraRays {
                tracer: &tracer,
                camera: &camera,
                space: crate::sampler::SampleSpace::new(args.sampler, seed, resolution, spp),
                seed,
            },
            resolution,
            progressive,
            spp,
        },
        &out.film,
    )?;
    report.auxiliary_seconds = finished.auxiliary_seconds;
    report.denoise_seconds = finished.denoise_seconds;
    if let Some(t) = finished.denoise_seconds {
        say(&format!("denoised in {t:.2} s (Intel Open Image Denoise)"));
    }
    let options = OutputOptions {
        exposure: args.exposure,
        metadata: report.metadata(),
    };
    match (&part_provenance, &finished.denoised) {
        (Some(p), _) => farm::write_accumulation(&output, &out.film, p)?,
        (None, Some(d)) => image::write_rgb(&output, w, h, d, &options)?,
        (None, None) => image::write_image(&output, &out.film, &options)?,
    }
    if let Some(path) = &args.variance {
        write_variance(path, &out.film)?;
    }
    if let Some(path) = &args.report {
        write_json(path, &report)?;
    }
    say(&format!(
        "wrote {}: {:.2} s, {} rays, {:.2} Mrays/s, {:.3} Mpaths/s",
        output.display(),
        out.seconds,
        out.rays.total(),
        report.mrays_per_second,
        report.mpaths_per_second
    ));
    Ok(())
}

/// The sample map: each pixel's sample count on the false-colour ramp of
/// `diff`, white at the most any pixel took.
fn write_sample_map(path: &std::path::Path, w: u32, h: u32, counts: &[u32]) -> Result<()> {
    let top = counts.iter().copied().max().unwrap_or(0).max(1) as f64;
    let rgb: Vec<u8> = counts
        .iter()
        .flat_map(|&c| crate::commands::diff::ramp(c as f64 / top))
        .collect();
    image::write_png_rgb8(path, w, h, &rgb)
}

/// The map of rejected samples: per pixel, their count (EXR, PFM) or red
/// brightening with the count, black where none (PNG).
fn write_bad_sample_map(path: &std::path::Path, w: u32, h: u32, per_pixel: &[u32]) -> Result<()> {
    let count = |i: usize| per_pixel.get(i).copied().unwrap_or(0);
    if image::ImageFormat::from_path(path)? == image::ImageFormat::Png {
        let top = per_pixel.iter().copied().max().unwrap_or(0).max(1) as f32;
        let rgb: Vec<u8> = (0..w as usize * h as usize)
            .flat_map(|i| match count(i) {
                0 => [0, 0, 0],
                c => [(95.0 + 160.0 * c as f32 / top) as u8, 0, 0],
            })
            .collect();
        return image::write_png_rgb8(path, w, h, &rgb);
    }
    let map: Vec<[f64; 3]> = (0..w as usize * h as usize)
        .map(|i| [count(i) as f64; 3])
        .collect();
    image::write_rgb(path, w, h, &map, &OutputOptions::default())
}

/// Every setting that changes a render's image, for accumulation files:
/// parts merge, and checkpoints resume, only under equal settings.
fn image_settings(
    s: &RenderSettings,
    i: &IntegratorSettings,
    backend: Backend,
    build: &BuildArgs,
    kernel: &str,
    guiding: &GuidingReport,
) -> Vec<(String, String)> {
    let roulette = match i.roulette {
        Roulette::Throughput => "throughput".to_string(),
        Roulette::Fixed(p) => format!("fixed {p:?}"),
    };
    [
        (
            "resolution",
            format!("{}x{}", s.resolution[0], s.resolution[1]),
        ),
        ("spp", s.spp.to_string()),
        ("seed", s.seed.to_string()),
        ("sampler", s.sampler.to_string()),
        ("max_depth", i.max_depth.to_string()),
        ("light_samples", i.light_samples.to_string()),
        ("direct", i.direct.to_string()),
        ("roulette", roulette),
        ("rr_depth", i.rr_depth.to_string()),
        ("backend", backend.name().to_string()),
        ("robust", (!build.no_robust).to_string()),
        (
            "bvh_quality",
            format!("{:?}", build.bvh_quality).to_lowercase(),
        ),
        ("kernel", kernel.to_string()),
        ("clamp", s.clamp.map_or("none".into(), |c| format!("{c:?}"))),
    ]
    .into_iter()
    .map(|(n, v)| (n.to_string(), v))
    // only when forced, so that files written before the setting existed
    // (all `auto`) still merge and resume
    .chain(
        (i.light_sampler != LightSampler::Auto)
            .then(|| ("light_sampler".to_string(), i.light_sampler.to_string())),
    )
    .chain(
        (i.light_sampling != LightSampling::Auto)
            .then(|| ("light_sampling".to_string(), i.light_sampling.to_string())),
    )
    // only when guided, so that unguided files written before guiding
    // existed still merge and resume; the training is a function of these
    // settings and the seed, so its iterations name the guide
    // (and the training samples the part holding sample 0 adds, when any)
    .chain(guiding.on.then(|| {
        let kept = match guiding.kept_spp {
            0 => String::new(),
            n => format!(", {n}{}", farm::KEPT_SPP_SUFFIX),
        };
        (
            "guiding".to_string(),
            format!("{} iterations{kept}", guiding.iterations),
        )
    }))
    .collect()
}

/// Set by SIGINT or SIGTERM while a checkpointed render runs.
static STOP: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);

/// Render a shard, crop or checkpointed render (see [`farm::render_part`]).
fn render_farm(
    args: &RenderArgs,
    tracer: &PathTracer<'_>,
    camera: &crate::camera::Camera,
    settings: &RenderSettings,
    provenance: &farm::Provenance,
    say: &dyn Fn(&str),
) -> Result<render::RenderOutput> {
    let resume = match &args.resume {
        Some(path) => {
            let (film, saved) = farm::read_accumulation(path)?;
            let spp_saved = saved.spp().unwrap_or(0);
            farm::check_resume(
                path,
                &saved,
                provenance,
                settings.sampler.same_points(spp_saved, settings.spp),
                args.allow_mixed_builds,
            )?;
            say(&format!(
                "resuming {}: samples {}..{} of {}..{}",
                path.display(),
                saved.samples.start,
                saved.samples.end,
                provenance.samples.start,
                provenance.samples.end
            ));
            Some((film, saved.samples.end))
        }
        None => None,
    };
    let checkpoint = args
        .checkpoint
        .clone()
        .or_else(|| args.resume.clone())
        .map(|path| farm::Checkpoint {
            path,
            every: args.checkpoint_every,
        });
    if checkpoint.is_some() {
        ctrlc::set_handler(|| STOP.store(true, std::sync::atomic::Ordering::SeqCst))
            .map_err(|e| Error::Settings(format!("cannot catch SIGINT and SIGTERM: {e}")))?;
    }
    let part = farm::Part {
        provenance: provenance.clone(),
        resume,
        // only a checkpoint keeps the guide: shards and crops train their own
        guide: checkpoint
            .as_ref()
            .and_then(|_| tracer.guide())
            .map(crate::guiding::Guide::to_bytes),
        kept: tracer.guide().and_then(|g| g.reused()),
        checkpoint: checkpoint.clone(),
        stop: &STOP,
    };
    let po = farm::render_part(tracer, camera, settings, part, say)?;
    if po.interrupted {
        let c = checkpoint.expect("only a checkpointed render stops early");
        return Err(Error::Interrupted(format!(
            "interrupted: {} holds samples {}..{} of {}..{}; no image written; continue with --resume {}",
            c.path.display(),
            provenance.samples.start,
            po.done,
            provenance.samples.start,
            provenance.samples.end,
            c.path.display()
        )));
    }
    Ok(po.out)
}

/// The CS184 course's focus distance when `-d` is not given
/// (`pathtracer_focalDistance` in its `application.h`).
const COURSE_FOCAL_DISTANCE: f32 = 4.7;

/// The lens `-b` and `-d` make of `scene`'s: each flag replaces its part;
/// a missing `-d` keeps the scene's focus distance when it has a lens, and
/// is otherwise 4.7 for a CS184 `.dae` (the course's default) or the
/// distance from the eye to the point looked at.
fn lens_from_flags(
    scene: &Scene,
    path: &std::path::Path,
    radius: Option<f32>,
    distance: Option<f32>,
) -> Result<crate::camera::ThinLens> {
    let course = path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("dae"));
    let focus = distance.unwrap_or(if !scene.lens.is_pinhole() {
        scene.lens.focus_distance
    } else if course {
        COURSE_FOCAL_DISTANCE
    } else {
        (scene.camera.target - scene.camera.origin).length()
    });
    let radius = radius.unwrap_or(scene.lens.aperture_radius);
    if !(radius >= 0.0 && radius.is_finite()) {
        return Err(Error::Settings(format!(
            "-b (lens radius): expected a finite number >= 0, got {radius}"
        )));
    }
    if !(focus > 0.0 && focus.is_finite()) {
        return Err(Error::Settings(format!(
            "-d (focal distance): expected a finite number > 0, got {focus}"
        )));
    }
    crate::camera::ThinLens::new(radius, focus)
}
