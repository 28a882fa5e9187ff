//! `embertrace study`: a scene rendered under several settings, error
//! against time, a contact sheet and the Pareto front ([`runs`], [`plot`]).

pub mod denoised;
pub mod plot;
pub mod runs;

use super::BuildArgs;
use crate::accel::Backend;
use crate::error::{Error, Result};
use crate::log;
use crate::sampler::SamplerKind;
use crate::scene::Scene;
use crate::settings::{self, Flags, LightSampler};
use clap::Args;
use std::path::PathBuf;

/// The arguments of `embertrace study`.
#[derive(Args)]
pub struct StudyArgs {
    /// Scene file: .toml, .obj, .ply, Mitsuba 3 .xml, CS184 .dae or CSE 167/168 .test.
    scene: PathBuf,
    /// Output folder (created if missing).
    #[arg(long, value_name = "DIR")]
    out: PathBuf,
    /// A setting and its values, NAME=V1,V2,...; repeat to combine. Names:
    /// spp, max_depth, light_samples, direct, rr, rr_depth, backend, sampler,
    /// light_sampler.
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
    /// Light selection: auto (the light BVH from 8 lights that are not at
    /// infinity, else power), power (in proportion to power) or bvh (by a
    /// light BVH, by importance at the shading point) [default: auto].
    #[arg(long = "light-sampler", value_name = "auto|power|bvh")]
    light_sampler: Option<LightSampler>,
    #[command(flatten)]
    build: BuildArgs,
    /// Also denoise every pass (Intel Open Image Denoise, a build with
    /// `--features denoise`): denoised error-against-time curves beside the
    /// noisy ones, and each final image's bias (mean error, 8 x 8 block
    /// error).
    #[arg(long)]
    denoise: bool,
}

/// Run `embertrace study`.
pub fn run(args: StudyArgs) -> Result<()> {
    use self::runs::{ReferenceChoice, RunSettings, StudyOptions};
    let vary = args
        .vary
        .iter()
        .map(|v| runs::parse_vary(v).map_err(Error::Settings))
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
    if args.denoise && !crate::denoise::AVAILABLE {
        return Err(Error::Settings(crate::denoise::HOW_TO_GET.to_string()));
    }
    let scene = Scene::load(&args.scene)?;
    let flags = Flags {
        spp: args.spp,
        max_depth: args.max_depth,
        light_samples: args.light_samples,
        resolution: args.resolution.as_deref().map(|r| [r[0], r[1]]),
        seed: args.seed,
        threads: args.threads,
        light_sampler: args.light_sampler,
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
        denoise: args.denoise,
    };
    let rows = runs::run(&args.scene, &scene, &opts, &log::note)?;
    // -q: the files alone, no table on stdout either
    if log::enabled(log::Level::Normal) {
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
