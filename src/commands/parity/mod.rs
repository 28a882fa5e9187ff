//! `embertrace parity`: identical rays through every backend, and the
//! disagreements explained or not ([`check`]).

pub mod check;

pub use check::*;

use super::bench::NAIVE_BENCH_LIMIT;
use super::raysets::RayKind;
use super::{BuildArgs, write_json};
use crate::accel::Backend;
use crate::error::{Error, Result};
use crate::outputs::{self, Inputs};
use crate::scene::Scene;
use crate::settings::{self, Flags, ResolutionFlag};
use clap::Args;
use std::path::PathBuf;

/// The arguments of `embertrace parity`.
#[derive(Args)]
pub struct ParityArgs {
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

/// Run `embertrace parity`.
pub fn run(args: ParityArgs) -> Result<()> {
    if let Some(j) = &args.json {
        crate::commands::render::report::check_report_path(j)?;
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
                .filter(|&b| {
                    b != Backend::Naive || scene.traced_triangle_count() <= NAIVE_BENCH_LIMIT as u64
                })
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
    let report = check::run(&scene, &settings, &crate::log::note)?;
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
