//! The `embertrace` command line: parse flags, call the library, print.

use clap::{Args, Parser, Subcommand};
use embertrace::accel::bvh::BvhQuality;
use embertrace::accel::{self, AccelOptions, Backend};
use embertrace::bench::{self, BenchSettings};
use embertrace::diff::{Image, compare};
use embertrace::error::clip;
use embertrace::error::{Error, Result};
use embertrace::farm::{self, Shard};
use embertrace::film::{self, OutputOptions};
use embertrace::integrator::PathTracer;
use embertrace::settings::{DirectStrategy, IntegratorSettings, Roulette};
use embertrace::outputs::{self, Inputs};
use embertrace::parity::{self, ParitySettings};
use embertrace::plan::{Plan, PlanMode};
use embertrace::progressive::{Adaptive, Budget, CONFIDENCE, PassRecord, render_progressive};
use embertrace::raysets::RayKind;
use embertrace::render::{self, RenderSettings};
use embertrace::report::RenderReport;
use embertrace::report::{ErrorEstimate, ProgressiveReport};
use embertrace::sampler::SamplerKind;
use embertrace::scene::Scene;
use embertrace::settings::{self, Flags, ResolutionFlag};
use indicatif::{ProgressBar, ProgressStyle};
use std::io::IsTerminal;
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Instant;

#[derive(Parser)]
#[command(
    name = "embertrace",
    version,
    about = "A physically based path tracer (Embree or brute force for ray queries).",
    after_help = "The classic form `embertrace -t 8 -s 64 -l 16 -m 5 -r 480 360 -f out.png SCENE` means `embertrace render ...`."
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Render a scene (.toml, .obj, .ply, Mitsuba 3 .xml, CS184 .dae or CSE .test) to an image.
    Render(Box<RenderArgs>),
    /// Measure build time, memory and ray throughput of each backend.
    Bench(BenchArgs),
    /// Trace identical rays through every backend and report disagreements.
    Parity(ParityArgs),
    /// Compare an image with a reference: RMSE, relative MSE, MAE, max error.
    Diff(DiffArgs),
    /// Render a scene under several settings: error against time, a contact
    /// sheet and the Pareto front.
    Study(StudyArgs),
    /// Print the effects a scene calls for, what calls for each, and the
    /// code that runs.
    Plan(PlanArgs),
    /// Write any scene the renderer reads as a TOML scene, with its meshes
    /// and images beside it.
    Convert(ConvertArgs),
    /// Combine accumulation files (shards, crops, checkpoints) into the
    /// final image, bit for bit the one-process render.
    Merge(MergeArgs),
}

#[derive(Args)]
struct ConvertArgs {
    /// The scene to convert.
    input: PathBuf,
    /// The TOML scene to write (meshes and images go beside it).
    output: PathBuf,
}

#[derive(Args)]
struct PlanArgs {
    /// Scene file: .toml, .obj, .ply, Mitsuba 3 .xml, CS184 .dae or CSE 167/168 .test.
    scene: PathBuf,
    /// Maximum bounces (decides `indirect`) [scene default].
    #[arg(short = 'm', long = "max-depth", allow_negative_numbers = true)]
    max_depth: Option<u32>,
    /// Print JSON: `effects` (the names that are on), `kernel`, `details`.
    #[arg(long)]
    json: bool,
}

#[derive(Args)]
struct StudyArgs {
    /// Scene file: .toml, .obj, .ply, Mitsuba 3 .xml, CS184 .dae or CSE 167/168 .test.
    scene: PathBuf,
    /// Output folder (created if missing).
    #[arg(long, value_name = "DIR")]
    out: PathBuf,
    /// A setting and its values, NAME=V1,V2,...; repeat to combine. Names:
    /// spp, max_depth, light_samples, direct, rr, rr_depth, backend, sampler.
    #[arg(long, value_name = "NAME=V1,V2,...")]
    vary: Vec<String>,
    /// Reference image (.exr or .pfm), or `auto` to render (and cache in DIR)
    /// one at --reference-spp with another seed.
    #[arg(long, default_value = "auto")]
    reference: String,
    /// Samples per pixel of an `auto` reference.
    #[arg(long, default_value_t = 1024, allow_negative_numbers = true)]
    reference_spp: u32,
    /// Samples per pixel [scene default].
    #[arg(short = 's', long = "spp", allow_negative_numbers = true)]
    spp: Option<u32>,
    /// Maximum bounces [scene default].
    #[arg(short = 'm', long = "max-depth", allow_negative_numbers = true)]
    max_depth: Option<u32>,
    /// Light samples per shading point (per area light for a CS184 .dae)
    /// [scene default].
    #[arg(short = 'l', long = "light-samples", allow_negative_numbers = true)]
    light_samples: Option<u32>,
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
    /// Random seed [scene default].
    #[arg(long, allow_negative_numbers = true)]
    seed: Option<u64>,
    /// Base backend [embree when compiled in].
    #[arg(long)]
    accel: Option<Backend>,
    #[command(flatten)]
    build: BuildArgs,
    /// Print nothing but errors.
    #[arg(short = 'q', long)]
    quiet: bool,
}

#[derive(Args)]
struct DiffArgs {
    /// The image to measure (.exr or .pfm).
    image: PathBuf,
    /// The reference (.exr or .pfm), same size.
    reference: PathBuf,
    /// Write a false-colour map of each pixel's mean absolute error (PNG).
    #[arg(long, value_name = "FILE")]
    error_image: Option<PathBuf>,
    /// Error shown as white in the error image [default: the largest].
    #[arg(long, value_name = "E", allow_negative_numbers = true)]
    error_scale: Option<f64>,
    /// Write the metrics as JSON too.
    #[arg(long, value_name = "FILE")]
    json: Option<PathBuf>,
}

#[derive(Args)]
struct ParityArgs {
    /// Scene file: .toml, .obj, .ply, Mitsuba 3 .xml, CS184 .dae or CSE 167/168 .test.
    scene: PathBuf,
    /// Rays per kind.
    #[arg(long, default_value_t = 100_000, allow_negative_numbers = true)]
    rays: usize,
    /// Ray kinds, comma-separated.
    #[arg(
        long,
        value_delimiter = ',',
        default_value = "camera,diffuse,shadow,random,edge,vertex"
    )]
    kinds: Vec<RayKind>,
    /// Backends, comma-separated; the first is the reference [naive when the
    /// scene has at most 20k triangles, then every other one compiled in].
    #[arg(long, value_delimiter = ',')]
    accel: Option<Vec<Backend>>,
    /// Write the report as JSON too.
    #[arg(long, value_name = "FILE")]
    json: Option<PathBuf>,
    /// Side of the image rendered through each backend (0 skips it).
    #[arg(long, default_value_t = 64, allow_negative_numbers = true)]
    image: u32,
    /// Samples per pixel of that image.
    #[arg(long, default_value_t = 16, allow_negative_numbers = true)]
    image_spp: u32,
    #[command(flatten)]
    build: BuildArgs,
}

#[derive(Args)]
struct BenchArgs {
    /// Scene file: .toml, .obj, .ply, Mitsuba 3 .xml, CS184 .dae or CSE 167/168 .test.
    scene: PathBuf,
    /// Backends, comma-separated [every one compiled in; naive only below
    /// 20k triangles unless named].
    #[arg(long, value_delimiter = ',')]
    accel: Option<Vec<Backend>>,
    /// Threads for the all-cores columns; 0 = all cores.
    #[arg(short = 't', long, default_value_t = 0, allow_negative_numbers = true)]
    threads: usize,
    /// Write the numbers as JSON too.
    #[arg(long, value_name = "FILE")]
    json: Option<PathBuf>,
    /// Rays per kind.
    #[arg(long, default_value_t = 200_000, allow_negative_numbers = true)]
    rays: usize,
    /// Repetitions per figure (the median is reported).
    #[arg(long, default_value_t = 5, allow_negative_numbers = true)]
    reps: usize,
    #[command(flatten)]
    build: BuildArgs,
    /// Instead of ray throughput, measure what each effect costs per sample:
    /// the scene under its specialised kernel and --plan general, then with
    /// one effect added at a time.
    #[arg(long)]
    effects: bool,
    /// Instead of ray throughput, measure the renderer's efficiency: a
    /// one-thread render's time against the time its ray queries alone take.
    #[arg(long, conflicts_with = "effects")]
    efficiency: bool,
    /// Resolution of the --effects and --efficiency renders: width height.
    #[arg(short = 'r', long = "resolution", num_args = 2, value_names = ["W", "H"], default_values_t = [128, 128], allow_negative_numbers = true)]
    resolution: Vec<u32>,
    /// Samples per pixel of the --effects and --efficiency renders.
    #[arg(
        short = 's',
        long = "spp",
        default_value_t = 16,
        allow_negative_numbers = true
    )]
    spp: u32,
    /// Sampler of the --efficiency renders.
    #[arg(long, default_value_t = SamplerKind::default())]
    sampler: SamplerKind,
}

#[derive(Args)]
struct RenderArgs {
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
    /// Random seed [scene default, else 0].
    #[arg(long, allow_negative_numbers = true)]
    seed: Option<u64>,
    /// Sample generator: sobol (padded, Owen-scrambled Sobol points: the
    /// least error per unit of time), zsobol (the same along a Morton curve:
    /// blue-noise error, dearer per sample) or independent (PCG32).
    #[arg(long, default_value_t = SamplerKind::default())]
    sampler: SamplerKind,
    /// Ray-query backend: embree or naive [embree when compiled in].
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
    /// Write a JSON report of the run.
    #[arg(long, value_name = "FILE")]
    report: Option<PathBuf>,
    /// Exposure in stops, applied to PNG output.
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
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
    /// Scale every sample down so that no component exceeds MAX (biased:
    /// the report states the energy removed) [default: no clamp].
    #[arg(long, value_name = "MAX", allow_negative_numbers = true)]
    clamp: Option<f32>,
    /// Print nothing but errors.
    #[arg(short = 'q', long)]
    quiet: bool,
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
    /// saving to FILE unless --checkpoint names another).
    #[arg(long, value_name = "FILE")]
    resume: Option<PathBuf>,
    /// Write the per-pixel variance of the mean, per channel, as EXR.
    #[arg(long, value_name = "FILE")]
    variance: Option<PathBuf>,
}

#[derive(Args)]
struct MergeArgs {
    /// Accumulation files (from render --shard, --crop or --checkpoint), in
    /// any order.
    #[arg(required = true)]
    parts: Vec<PathBuf>,
    /// The merged image (.png, .exr or .pfm), or with --accumulation an
    /// accumulation file (.exr).
    #[arg(short = 'o', long = "output")]
    output: PathBuf,
    /// Write an accumulation file for a later merge instead of the image:
    /// the parts need then cover only a box of pixels and samples.
    #[arg(long)]
    accumulation: bool,
    /// Write the per-pixel variance of the mean, per channel, as EXR.
    #[arg(long, value_name = "FILE")]
    variance: Option<PathBuf>,
    /// Exposure in stops, applied to PNG output.
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
    exposure: f32,
    /// Write a JSON report of the merge: the parts, time and peak memory.
    #[arg(long, value_name = "FILE")]
    report: Option<PathBuf>,
}

/// Samples per pixel at most when a time or error budget is given without -s.
const BUDGET_MAX_SPP: u32 = 1 << 20;

/// How backends are built (shared by every command).
#[derive(Args)]
struct BuildArgs {
    /// Turn off Embree's robust (watertight) mode.
    #[arg(long)]
    no_robust: bool,
    /// Build quality of the pure-Rust BVH: fast (binned SAH) or high (full sweep).
    #[arg(long, default_value = "fast", value_parser = parse_quality)]
    bvh_quality: BvhQuality,
}

fn parse_quality(s: &str) -> std::result::Result<BvhQuality, String> {
    match s {
        "fast" => Ok(BvhQuality::Fast),
        "high" => Ok(BvhQuality::High),
        _ => Err(format!("unknown BVH quality `{s}` (expected fast or high)")),
    }
}

impl BuildArgs {
    fn options(&self) -> AccelOptions {
        AccelOptions {
            robust: !self.no_robust,
            bvh_quality: self.bvh_quality,
        }
    }
}

/// Words that start the subcommand form; anything else is the classic form.
const SUBCOMMANDS: &[&str] = &[
    "render",
    "bench",
    "parity",
    "diff",
    "study",
    "plan",
    "convert",
    "merge",
    "help",
    "-h",
    "--help",
    "-V",
    "--version",
];

/// `embertrace plan`.
fn run_plan(args: PlanArgs) -> Result<()> {
    let scene = Scene::load(&args.scene)?;
    let flags = Flags {
        max_depth: args.max_depth,
        ..Flags::default()
    };
    let settings = settings::resolve(&scene.render, scene.resolution, &flags)?;
    let plan = Plan::new(&scene, &settings.integrator);
    if args.json {
        print!("{}", plan.json());
    } else {
        println!("effects plan for {}:", args.scene.display());
        print!("{}", plan.text());
    }
    Ok(())
}

fn main() -> ExitCode {
    // arguments as the OS gives them: a path need not be UTF-8
    let mut argv: Vec<std::ffi::OsString> = std::env::args_os().collect();
    if argv.len() > 1 && !SUBCOMMANDS.contains(&argv[1].to_str().unwrap_or("")) {
        argv.insert(1, "render".into());
    }
    let cli = match Cli::try_parse_from(argv) {
        Ok(cli) => cli,
        Err(e) => return command_line_error(e),
    };
    let result = match cli.command {
        Command::Render(args) => run_render(*args),
        Command::Bench(args) => run_bench(args),
        Command::Parity(args) => run_parity(args),
        Command::Diff(args) => run_diff(args),
        Command::Study(args) => run_study(args),
        Command::Plan(args) => run_plan(args),
        Command::Merge(args) => run_merge(args),
        Command::Convert(args) => Scene::load(&args.input).and_then(|scene| {
            let w = embertrace::convert::convert(&scene, &args.output)?;
            eprintln!("wrote {} ({} files)", args.output.display(), w.files.len());
            Ok(())
        }),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(Error::Interrupted(m)) => {
            eprintln!("embertrace: {m}");
            // the shell's code for a process that SIGINT ended
            ExitCode::from(130)
        }
        Err(e) => {
            eprintln!("embertrace: error: {e}");
            ExitCode::FAILURE
        }
    }
}

/// Help and the version go to stdout as clap prints them; any other
/// command-line error is one line on stderr and exit status 1, like every
/// other error.
fn command_line_error(e: clap::Error) -> ExitCode {
    use clap::error::ErrorKind;
    if matches!(
        e.kind(),
        ErrorKind::DisplayHelp
            | ErrorKind::DisplayVersion
            | ErrorKind::DisplayHelpOnMissingArgumentOrSubcommand
    ) {
        e.exit();
    }
    let text = e.render().to_string();
    let message = text.split("Usage:").next().unwrap_or_default();
    // "error: ...:" then the arguments it lists, then a tip: one line
    let mut line = String::new();
    let lines = message.lines().map(str::trim);
    for l in lines.filter(|l| !l.is_empty() && !l.starts_with("For more information")) {
        if !line.is_empty() {
            line += if line.ends_with(':') { " " } else { "; " };
        }
        line += l;
    }
    let line = line.strip_prefix("error: ").unwrap_or(&line);
    eprintln!(
        "embertrace: error: {} (see embertrace help)",
        embertrace::error::clip(line)
    );
    ExitCode::FAILURE
}

/// The sample map: each pixel's sample count on the false-colour ramp of
/// `diff`, white at the most any pixel took.
fn write_sample_map(path: &std::path::Path, w: u32, h: u32, counts: &[u32]) -> Result<()> {
    let top = counts.iter().copied().max().unwrap_or(0).max(1) as f64;
    let rgb: Vec<u8> = counts
        .iter()
        .flat_map(|&c| embertrace::diff::ramp(c as f64 / top))
        .collect();
    film::write_png_rgb8(path, w, h, &rgb)
}

/// The map of rejected samples: per pixel, their count (EXR, PFM) or red
/// brightening with the count, black where none (PNG).
fn write_bad_sample_map(path: &std::path::Path, w: u32, h: u32, per_pixel: &[u32]) -> Result<()> {
    let count = |i: usize| per_pixel.get(i).copied().unwrap_or(0);
    if film::ImageFormat::from_path(path)? == film::ImageFormat::Png {
        let top = per_pixel.iter().copied().max().unwrap_or(0).max(1) as f32;
        let rgb: Vec<u8> = (0..w as usize * h as usize)
            .flat_map(|i| match count(i) {
                0 => [0, 0, 0],
                c => [(95.0 + 160.0 * c as f32 / top) as u8, 0, 0],
            })
            .collect();
        return film::write_png_rgb8(path, w, h, &rgb);
    }
    let map: Vec<[f64; 3]> = (0..w as usize * h as usize)
        .map(|i| [count(i) as f64; 3])
        .collect();
    film::write_rgb(path, w, h, &map, &OutputOptions::default())
}

/// Write `value` as pretty JSON to `path`, atomically.
fn write_json(path: &std::path::Path, value: &impl serde::Serialize) -> Result<()> {
    let text =
        serde_json::to_string_pretty(value).expect("plain numbers and strings serialise") + "\n";
    film::write_file_atomically(path, text.as_bytes())
}

fn run_study(args: StudyArgs) -> Result<()> {
    use embertrace::study::{self, ReferenceChoice, RunSettings, StudyOptions};
    let vary = args
        .vary
        .iter()
        .map(|v| study::parse_vary(v).map_err(Error::Settings))
        .collect::<Result<Vec<_>>>()?;
    if args.out.is_file() {
        return Err(Error::Settings(format!(
            "--out {}: is a file, expected a folder",
            args.out.display()
        )));
    }
    let reference = match args.reference.as_str() {
        "auto" => ReferenceChoice::Auto,
        p => ReferenceChoice::File(PathBuf::from(p)),
    };
    settings::check_spp(
        args.reference_spp as u64,
        &format!("--reference-spp {}", args.reference_spp),
    )
    .map_err(Error::Settings)?;
    let scene = Scene::load(&args.scene)?;
    let flags = Flags {
        spp: args.spp,
        max_depth: args.max_depth,
        light_samples: args.light_samples,
        resolution: args.resolution.as_deref().map(|r| [r[0], r[1]]),
        seed: args.seed,
        threads: args.threads,
        ..Flags::default()
    };
    let resolved = settings::resolve(&scene.render, scene.resolution, &flags)?;
    let base = RunSettings {
        integrator: resolved.integrator,
        spp: resolved.spp,
        seed: resolved.seed,
        backend: args.accel.unwrap_or_else(Backend::default_backend),
        sampler: SamplerKind::default(),
        resolution: resolved.resolution,
        threads: resolved.threads,
    };
    let opts = StudyOptions {
        out: args.out.clone(),
        vary,
        reference,
        reference_spp: args.reference_spp,
        base,
        build: args.build.options(),
    };
    let quiet = args.quiet;
    let say = move |m: &str| {
        if !quiet {
            eprintln!("{m}");
        }
    };
    let rows = study::run(&args.scene, &scene, &opts, &say)?;
    if !quiet {
        for r in &rows {
            println!(
                "{:<40} {:>8.3} s  relMSE {:.3e}  efficiency {:.3e}{}",
                r.label,
                r.seconds,
                r.rel_mse,
                r.efficiency,
                if r.pareto { "  (Pareto)" } else { "" }
            );
        }
        println!("wrote {}", args.out.join("study.md").display());
    }
    Ok(())
}

fn run_diff(args: DiffArgs) -> Result<()> {
    use embertrace::diff::{Image, compare, write_error_image};
    let written: Vec<outputs::Output<'_>> = [
        ("--json", args.json.as_deref()),
        ("--error-image", args.error_image.as_deref()),
    ]
    .into_iter()
    .filter_map(|(flag, path)| Some((flag, path?)))
    .collect();
    let mut inputs = Inputs::new();
    inputs.add(&args.image, "the image to measure");
    inputs.add(&args.reference, "the reference image");
    outputs::check(&written, &inputs)?;
    if let Some(j) = &args.json {
        embertrace::report::check_report_path(j)?;
    }
    if let Some(p) = &args.error_image {
        film::check_output_path(p)?;
    }
    if let Some(s) = args.error_scale {
        if !(s > 0.0 && s.is_finite()) {
            return Err(Error::Settings(format!(
                "--error-scale must be a positive number, not {s}"
            )));
        }
    }
    let a = Image::read(&args.image)?;
    let b = Image::read(&args.reference)?;
    let stats = compare(&a, &b, &args.image, &args.reference)?;
    println!(
        "{} vs {}: {}x{}",
        args.image.display(),
        args.reference.display(),
        a.width,
        a.height
    );
    println!("rmse       {:.6e}", stats.rmse);
    println!("rel_mse    {:.6e}", stats.rel_mse);
    println!("mae        {:.6e}", stats.mae);
    println!(
        "max_error  {:.6e} at [{}, {}]",
        stats.max_error, stats.max_error_pixel[0], stats.max_error_pixel[1]
    );
    if stats.non_finite > 0 {
        println!("non_finite {} channel values left out", stats.non_finite);
    }
    if let Some(p) = &args.error_image {
        let top = write_error_image(p, &a, &b, args.error_scale)?;
        eprintln!("error image: {} (white = {top:.3e})", p.display());
    }
    if let Some(j) = &args.json {
        write_json(j, &stats)?;
    }
    Ok(())
}

/// Triangle count above which `bench` leaves the naive backend out unless named.
const NAIVE_BENCH_LIMIT: usize = 20_000;

fn run_bench(args: BenchArgs) -> Result<()> {
    if let Some(j) = &args.json {
        embertrace::report::check_report_path(j)?;
    }
    if args.rays == 0 {
        return Err(Error::Settings(
            "--rays 0: expected at least one ray per kind".into(),
        ));
    }
    let scene = Scene::load(&args.scene)?;
    if let Some(j) = &args.json {
        outputs::check(&[("--json", j)], &Inputs::of_scene(&scene))?;
    }
    // the --effects and --efficiency renders' settings
    let flags = Flags {
        spp: Some(args.spp),
        resolution: Some([args.resolution[0], args.resolution[1]]),
        threads: args.threads,
        ..Flags::default()
    };
    let resolved = settings::resolve(&scene.render, scene.resolution, &flags)?;
    let backend = args
        .accel
        .as_ref()
        .and_then(|l| l.first().copied())
        .unwrap_or_else(Backend::default_backend);
    let integrator = resolved.integrator;
    if args.efficiency {
        let settings = embertrace::efficiency::EfficiencySettings {
            backend,
            resolution: resolved.resolution,
            spp: resolved.spp,
            sampler: args.sampler,
            reps: args.reps,
            options: args.build.options(),
        };
        let report = embertrace::efficiency::run(&scene, &settings, integrator, &|line| {
            eprintln!("{line}")
        })?;
        print!("{}", report.table());
        if let Some(j) = &args.json {
            write_json(j, &report)?;
        }
        return Ok(());
    }
    if args.effects {
        let settings = embertrace::effects_bench::EffectsBenchSettings {
            backend,
            resolution: resolved.resolution,
            spp: resolved.spp,
            reps: args.reps,
            threads: resolved.threads,
            options: args.build.options(),
        };
        let report = embertrace::effects_bench::run(&scene, &settings, integrator, &|line| {
            eprintln!("{line}")
        })?;
        print!("{}", report.table());
        if let Some(j) = &args.json {
            write_json(j, &report)?;
        }
        return Ok(());
    }
    let backends = match args.accel {
        Some(list) => list,
        None => Backend::available()
            .into_iter()
            .filter(|&b| b != Backend::Naive || scene.triangle_count() <= NAIVE_BENCH_LIMIT)
            .collect(),
    };
    let settings = BenchSettings {
        backends,
        threads: args.threads,
        reps: args.reps,
        rays: args.rays,
        options: args.build.options(),
    };
    let report = bench::run(&scene, &settings, &|line| eprintln!("{line}"))?;
    print!("{}", report.table());
    if let Some(j) = &args.json {
        write_json(j, &report)?;
    }
    Ok(())
}

fn run_parity(args: ParityArgs) -> Result<()> {
    if let Some(j) = &args.json {
        embertrace::report::check_report_path(j)?;
    }
    let scene = Scene::load(&args.scene)?;
    if let Some(j) = &args.json {
        outputs::check(&[("--json", j)], &Inputs::of_scene(&scene))?;
    }
    // the image rendered through each backend (--image 0 skips it)
    let flags = Flags {
        spp: Some(args.image_spp),
        resolution: (args.image > 0).then_some([args.image; 2]),
        spp_flag: "--image-spp",
        resolution_flag: ResolutionFlag::Side("--image"),
        ..Flags::default()
    };
    let resolved = settings::resolve(&scene.render, scene.resolution, &flags)?;
    let backends = match args.accel {
        Some(list) => list,
        None => {
            // naive is the oracle where it is affordable; it goes first
            let mut v: Vec<Backend> = Backend::available();
            v.sort_by_key(|&b| b != Backend::Naive);
            v.into_iter()
                .filter(|&b| b != Backend::Naive || scene.triangle_count() <= NAIVE_BENCH_LIMIT)
                .collect()
        }
    };
    let settings = ParitySettings {
        rays: args.rays,
        kinds: args.kinds,
        backends,
        options: args.build.options(),
        image_resolution: args.image,
        image_spp: resolved.spp,
        integrator: resolved.integrator,
    };
    let report = parity::run(&scene, &settings, &|line| eprintln!("{line}"))?;
    print!("{}", report.table());
    if let Some(j) = &args.json {
        write_json(j, &report)?;
    }
    if report.unexplained > 0 {
        return Err(Error::Strict(format!(
            "{} unexplained disagreements between backends",
            report.unexplained
        )));
    }
    Ok(())
}

fn run_render(args: RenderArgs) -> Result<()> {
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
    film::check_output_path(&output)?;
    if let Some(r) = &args.report {
        embertrace::report::check_report_path(r)?;
    }
    let say = |msg: &str| {
        if !args.quiet {
            eprintln!("{msg}");
        }
    };
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
        film::check_output_path(p)?;
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
        film::check_output_path(p)?;
    }
    if let Some(p) = &args.convergence {
        embertrace::report::check_report_path(p)?;
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
    if let Some(v) = &args.variance {
        check_exr(v, "--variance")?;
    }

    let t0 = Instant::now();
    let scene = Scene::load(&args.scene)?;
    let load_seconds = t0.elapsed().as_secs_f64();
    let mut inputs = Inputs::of_scene(&scene);
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
    for warning in &scene.warnings {
        say(&format!("warning: {}", clip(warning)));
    }
    let backend = args.accel.unwrap_or_else(Backend::default_backend);

    let t1 = Instant::now();
    let accel = accel::build(backend, scene.soup(), args.build.options())?;
    let accel_build_seconds = t1.elapsed().as_secs_f64();

    let camera = scene.make_camera(w, h);
    let plan = Plan::new(&scene, &integrator);
    let kernel = plan.kernel_for(args.plan);
    let tracer = PathTracer::with_kernel(&scene, accel.as_ref(), integrator, kernel);
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
    let side = embertrace::render::tile_side(settings.tile_size);
    let tiles = (w.div_ceil(side) * h.div_ceil(side)) as u64;
    let bar = if std::io::stderr().is_terminal() && !args.quiet {
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
    say(&format!(
        "rendering {} ({} triangles) at {w}x{h}, {spp} spp, max depth {}, backend {backend}",
        args.scene.display(),
        scene.triangle_count(),
        integrator.max_depth
    ));
    budget.max_spp = spp;
    let progressive = budget.is_progressive() || reference.is_some();
    let mut part_provenance = None;
    let (out, progress) = if farm {
        bar.finish_and_clear();
        let provenance = farm::Provenance {
            version: env!("CARGO_PKG_VERSION").to_string(),
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
        if farm_part || film::ImageFormat::from_path(&output)? == film::ImageFormat::Exr {
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
            if !args.quiet {
                eprintln!(
                    "pass {}: {} spp, {:.2} s, relative error {:.4}, {} pixels active",
                    p.pass, p.spp, p.seconds, p.relative_error, p.active_pixels
                );
            }
            Ok(())
        };
        let po = render_progressive(&tracer, &camera, &settings, &budget, &mut on_pass)?;
        if let Some(path) = &args.convergence {
            film::write_file_atomically(path, log.as_bytes())?;
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
        let out = render::render(&tracer, &camera, &settings, &|| bar.inc(1))?;
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
    if let Some(p) = progress {
        report.spp = p.spp_reached;
        if !args.quiet {
            eprintln!(
                "stopped ({:?}) at {} spp after {} passes; relative error {:.4} at {:.0} % confidence",
                p.stop,
                p.spp_reached,
                p.passes,
                p.relative_error.estimate,
                p.relative_error.confidence * 100.0
            );
        }
        report.progressive = Some(p);
    }
    let bad = &out.nonfinite;
    if bad.count > 0 {
        say(&format!(
            "warning: {} samples left out ({} NaN, {} infinite, {} negative), first at pixel {:?}",
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
    let options = OutputOptions {
        exposure: args.exposure,
        metadata: report.metadata(),
    };
    match &part_provenance {
        Some(p) => farm::write_accumulation(&output, &out.film, p)?,
        None => film::write_image(&output, &out.film, &options)?,
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

/// Fail unless `path` names an `.exr` file that can be written.
fn check_exr(path: &std::path::Path, what: &str) -> Result<()> {
    film::check_output_path(path)?;
    if film::ImageFormat::from_path(path)? != film::ImageFormat::Exr {
        return Err(Error::Settings(format!(
            "{}: {what}: expected an .exr file",
            path.display()
        )));
    }
    Ok(())
}

/// The per-pixel variance of the mean, per channel, as EXR.
fn write_variance(path: &std::path::Path, f: &film::Film) -> Result<()> {
    let v: Vec<[f64; 3]> = f
        .pixels()
        .iter()
        .map(|p| p.variance_of_mean_f64())
        .collect();
    film::write_rgb(path, f.width(), f.height(), &v, &OutputOptions::default())
}

/// Every setting that changes a render's image, for accumulation files:
/// parts merge, and checkpoints resume, only under equal settings.
fn image_settings(
    s: &RenderSettings,
    i: &IntegratorSettings,
    backend: Backend,
    build: &BuildArgs,
    kernel: &str,
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
    .collect()
}

/// Set by SIGINT or SIGTERM while a checkpointed render runs.
static STOP: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);

/// Render a shard, crop or checkpointed render (see [`farm::render_part`]).
fn render_farm(
    args: &RenderArgs,
    tracer: &PathTracer<'_>,
    camera: &embertrace::camera::Camera,
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

fn run_merge(args: MergeArgs) -> Result<()> {
    let written: Vec<outputs::Output<'_>> = [
        ("-o", Some(args.output.as_path())),
        ("--variance", args.variance.as_deref()),
        ("--report", args.report.as_deref()),
    ]
    .into_iter()
    .filter_map(|(flag, path)| Some((flag, path?)))
    .collect();
    let mut inputs = Inputs::new();
    for part in &args.parts {
        inputs.add(part, "a part to merge");
    }
    outputs::check(&written, &inputs)?;
    if args.accumulation {
        check_exr(&args.output, "--accumulation")?;
    } else {
        film::check_output_path(&args.output)?;
    }
    if let Some(v) = &args.variance {
        check_exr(v, "--variance")?;
    }
    if let Some(r) = &args.report {
        embertrace::report::check_report_path(r)?;
    }
    let (merged, prov, mut report) = farm::merge(&args.parts, args.accumulation)?;
    if args.accumulation {
        farm::write_accumulation(&args.output, &merged, &prov)?;
    } else {
        let options = OutputOptions {
            exposure: args.exposure,
            metadata: prov
                .metadata()
                .into_iter()
                .filter(|(n, _)| n != "embertrace.kind")
                .collect(),
        };
        film::write_image(&args.output, &merged, &options)?;
    }
    if let Some(v) = &args.variance {
        write_variance(v, &merged)?;
    }
    report.peak_memory_bytes = farm::peak_memory_bytes();
    if let Some(r) = &args.report {
        write_json(r, &report)?;
    }
    eprintln!(
        "merged {} parts into {} ({} x {} pixels, samples {}..{}) in {:.2} s",
        args.parts.len(),
        args.output.display(),
        merged.width(),
        merged.height(),
        prov.samples.start,
        prov.samples.end,
        report.seconds
    );
    Ok(())
}
