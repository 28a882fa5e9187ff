//! `embertrace bench`: build time, memory and ray throughput of each
//! backend ([`throughput`]), the cost of each effect (`--effects`,
//! [`effect_costs`]) and the renderer's efficiency (`--efficiency`,
//! [`efficiency`]).

pub mod effect_costs;
pub mod efficiency;
pub mod throughput;

pub use throughput::*;

use super::{BuildArgs, write_json};
use crate::accel::Backend;
use crate::error::{Error, Result};
use crate::outputs::{self, Inputs};
use crate::sampler::SamplerKind;
use crate::scene::Scene;
use crate::settings::{self, Flags, LightSampler};
use clap::Args;
use std::path::PathBuf;

/// The arguments of `embertrace bench`.
#[derive(Args)]
pub struct BenchArgs {
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
    /// Light selection of the --effects and --efficiency renders: auto,
    /// power or bvh [default: auto].
    #[arg(long = "light-sampler", value_name = "auto|power|bvh")]
    light_sampler: Option<LightSampler>,
}

/// Triangle count above which `bench` leaves the naive backend out unless named.
pub(crate) const NAIVE_BENCH_LIMIT: usize = 20_000;

/// Run `embertrace bench`.
pub fn run(args: BenchArgs) -> Result<()> {
    if let Some(j) = &args.json {
        crate::commands::render::report::check_report_path(j)?;
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
        light_sampler: args.light_sampler,
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
        let settings = efficiency::EfficiencySettings {
            backend,
            resolution: resolved.resolution,
            spp: resolved.spp,
            sampler: args.sampler,
            reps: args.reps,
            options: args.build.options(),
        };
        let report = efficiency::run(&scene, &settings, integrator, &crate::log::note)?;
        print!("{}", report.table());
        if let Some(j) = &args.json {
            write_json(j, &report)?;
        }
        return Ok(());
    }
    if args.effects {
        let settings = effect_costs::EffectCostSettings {
            backend,
            resolution: resolved.resolution,
            spp: resolved.spp,
            reps: args.reps,
            threads: resolved.threads,
            options: args.build.options(),
        };
        let report = effect_costs::run(&scene, &settings, integrator, &crate::log::note)?;
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
            .filter(|&b| {
                b != Backend::Naive || scene.traced_triangle_count() <= NAIVE_BENCH_LIMIT as u64
            })
            .collect(),
    };
    let settings = ThroughputSettings {
        backends,
        threads: args.threads,
        reps: args.reps,
        rays: args.rays,
        options: args.build.options(),
    };
    let report = throughput::run(&scene, &settings, &crate::log::note)?;
    print!("{}", report.table());
    if let Some(j) = &args.json {
        write_json(j, &report)?;
    }
    Ok(())
}
