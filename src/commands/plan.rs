//! `embertrace plan`: the effects a scene calls for, what calls for each,
//! and the code that runs.

use crate::error::Result;
use crate::plan::Plan;
use crate::scene::Scene;
use crate::settings::{self, Flags, LightSampler};
use clap::Args;
use std::path::PathBuf;

/// The arguments of `embertrace plan`.
#[derive(Args)]
pub struct PlanArgs {
    /// Scene file: .toml, .obj, .ply, Mitsuba 3 .xml, CS184 .dae or CSE 167/168 .test.
    scene: PathBuf,
    /// Maximum bounces (decides `indirect`) [scene default].
    #[arg(short = 'm', long = "max-depth", allow_negative_numbers = true)]
    max_depth: Option<u32>,
    /// Light selection: auto (the light BVH from 64 lights that are not at
    /// infinity, else power), power (in proportion to power) or bvh (by a
    /// light BVH, by importance at the shading point) [default: auto].
    #[arg(long = "light-sampler", value_name = "auto|power|bvh")]
    light_sampler: Option<LightSampler>,
    /// Print JSON: `effects` (the names that are on), `kernel`, `details`.
    #[arg(long)]
    json: bool,
}

/// Run `embertrace plan`.
pub fn run(args: PlanArgs) -> Result<()> {
    let scene = Scene::load(&args.scene)?;
    let flags = Flags {
        max_depth: args.max_depth,
        light_sampler: args.light_sampler,
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
