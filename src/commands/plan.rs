//! `embertrace plan`: the effects a scene calls for, what calls for each,
//! and the code that runs.

use crate::accel::{self, Backend};
use crate::error::Result;
use crate::guiding::GuidingMode;
use crate::integrator::training::{
    AUTO_INDIRECT_SHARE, AUTO_MIN_SPP, GuidingReport, GuidingRequest, prepare,
};
use crate::integrator::{BsdfAlone, PathTracer};
use crate::plan::Plan;
use crate::scene::Scene;
use crate::settings::{self, Flags, LightSampler, LightSampling};
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
    /// Samples per pixel the render would take (decides `--guiding auto`'s
    /// training) [scene default].
    #[arg(short = 's', long = "spp")]
    spp: Option<u32>,
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
    /// Path guiding as `render --guiding` would decide it: auto runs the
    /// render's pre-pass (at the scene's resolution, seed and samples) and
    /// prints the share of light it found arriving after the first bounce,
    /// and where that calls for a guide, trains it and prints the guided
    /// pre-pass's variance and cost.
    #[arg(long, value_name = "auto|on|off", default_value_t = GuidingMode::Auto)]
    guiding: GuidingMode,
    /// Print JSON: `effects` (the names that are on), `kernel`, `details`,
    /// `guiding` (`mode`, `on`, `indirect_share`, `threshold`,
    /// `variance_ratio`, `cost_ratio`, `gave_up_after`, `spp`, `min_spp`),
    /// `bsdf_alone`
    /// (`lights_peak_pdf`, `from`, `materials`: where bounces skip light
    /// sampling by the uniform sky's rule; `map_peak_pdf` and
    /// `map_candidates`: under an environment map that is the only light,
    /// its highest density and the materials a pre-pass may let skip it;
    /// `measured`: what that pre-pass measured and chose, `map_peak_pdf`,
    /// `from`, `materials`, `variance_ratio`, `cost_ratio`, `skip`, or
    /// null).
    #[arg(long)]
    json: bool,
}

/// Run `embertrace plan`.
pub fn run(args: PlanArgs) -> Result<()> {
    let scene = Scene::load(&args.scene)?;
    let flags = Flags {
        max_depth: args.max_depth,
        spp: args.spp,
        light_sampler: args.light_sampler,
        light_sampling: args.light_sampling,
        ..Flags::default()
    };
    let settings = settings::resolve(&scene.render, scene.resolution, &flags)?;
    let plan = Plan::new(&scene, &settings.integrator);
    let guiding = decide_guiding(&scene, &settings, args.guiding)?;
    let alone = BsdfAlone::of(&scene, &settings.integrator);
    if args.json {
        let mut v: serde_json::Value = serde_json::from_str(&plan.json())
            .map_err(|e| crate::error::Error::Settings(format!("plan JSON: {e}")))?;
        v["guiding"] = serde_json::json!({
            "mode": guiding.mode.to_string(),
            "on": guiding.on,
            "indirect_share": guiding.auto.and_then(|m| m.indirect_share),
            "threshold": AUTO_INDIRECT_SHARE,
            "variance_ratio": guiding.auto.and_then(|m| m.variance_ratio),
            "cost_ratio": guiding.auto.and_then(|m| m.cost_ratio),
            "gave_up_after": guiding.auto.and_then(|m| m.gave_up_after),
            "spp": settings.spp,
            "min_spp": AUTO_MIN_SPP,
        });
        v["bsdf_alone"] = serde_json::json!({
            "lights_peak_pdf": alone.lights_peak_pdf,
            "from": alone.from,
            "materials": alone.materials,
            "map_peak_pdf": alone.map_peak_pdf,
            "map_candidates": alone.map_candidates,
            "measured": guiding.light_choice.as_ref().map(|c| serde_json::json!({
                "map_peak_pdf": c.map_peak_pdf,
                "from": c.from(),
                "materials": c.materials,
                "variance_ratio": c.variance_ratio,
                "cost_ratio": c.cost_ratio,
                "skip": c.skip,
            })),
        });
        println!("{v}");
    } else {
        println!("effects plan for {}:", args.scene.display());
        print!("{}", plan.text());
        match &guiding.light_choice {
            Some(choice) => println!("{}", choice.describe()),
            None => println!("{}", alone.describe()),
        }
        println!("{}", guiding.describe());
    }
    Ok(())
}

/// `render --guiding`'s decision for the scene at its own resolution, seed
/// and samples: the pre-pass and, where its share of indirect light calls
/// for it, the training and the guided pre-pass; and for an unguided
/// render, where bounces skip light sampling
/// ([`crate::integrator::light_choice`]).
fn decide_guiding(
    scene: &Scene,
    settings: &settings::Settings,
    mode: GuidingMode,
) -> Result<GuidingReport> {
    if mode == GuidingMode::On {
        return Ok(GuidingReport {
            on: mode == GuidingMode::On,
            ..GuidingReport::off(mode)
        });
    }
    // the backend a render at default flags takes, so that the pre-pass
    // measures what that render's would
    let soup = scene.soup();
    let accel = accel::build(Backend::for_scene(&soup), soup, Default::default())?;
    let [w, h] = settings.resolution;
    let camera = scene.make_camera(w, h);
    let kernel = Plan::new(scene, &settings.integrator).kernel;
    let mut tracer = PathTracer::with_kernel(scene, accel.as_ref(), settings.integrator, kernel);
    let pool = crate::render::thread_pool(settings.threads)?;
    let request = GuidingRequest {
        mode,
        resolution: settings.resolution,
        seed: settings.seed,
        spp: settings.spp,
        progressive: false,
        reuse: true,
    };
    Ok(prepare(&mut tracer, scene, &camera, &request, &pool))
}
