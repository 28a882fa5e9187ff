//! `embertrace merge`: accumulation files (shards, crops, checkpoints)
//! combined into the final image, bit for bit the one-process render.

use super::{check_exr, write_json, write_variance};
use crate::error::Result;
use crate::farm;
use crate::image::{self, OutputOptions};
use crate::outputs::{self, Inputs};
use clap::Args;
use std::path::PathBuf;

/// The arguments of `embertrace merge`.
#[derive(Args)]
pub struct MergeArgs {
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
    #[arg(
        long,
        default_value_t = 0.0,
        allow_negative_numbers = true,
        value_parser = crate::commands::parse_exposure
    )]
    exposure: f32,
    /// Write a JSON report of the merge: the parts, time and peak memory.
    #[arg(long, value_name = "FILE")]
    report: Option<PathBuf>,
    /// Merge parts rendered by builds of different source (their
    /// accumulation files record it): only when the pixels are known to
    /// agree.
    #[arg(long)]
    allow_mixed_builds: bool,
    /// Denoise the merged image with Intel Open Image Denoise (a build with
    /// `--features denoise`): the auxiliary images are traced anew along
    /// the render's camera rays, from the scene (--scene), which must be
    /// the one the parts were rendered from.
    #[arg(long, requires = "scene", conflicts_with = "accumulation")]
    denoise: bool,
    /// The scene the parts were rendered from (for --denoise).
    #[arg(long, value_name = "FILE")]
    scene: Option<PathBuf>,
}

/// Run `embertrace merge`.
pub fn run(args: MergeArgs) -> Result<()> {
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
        image::check_output_path(&args.output)?;
    }
    if let Some(v) = &args.variance {
        check_exr(v, "--variance")?;
    }
    if let Some(r) = &args.report {
        crate::commands::render::report::check_report_path(r)?;
    }
    if args.denoise && !crate::denoise::AVAILABLE {
        return Err(crate::error::Error::Settings(
            crate::denoise::HOW_TO_GET.to_string(),
        ));
    }
    let (merged, prov, mut report) =
        farm::merge(&args.parts, args.accumulation, args.allow_mixed_builds)?;
    let denoised = match (&args.scene, args.denoise) {
        (Some(scene), true) => {
            let (image, aux_seconds, denoise_seconds) = denoise_merged(scene, &merged, &prov)?;
            report.auxiliary_seconds = Some(aux_seconds);
            report.denoise_seconds = Some(denoise_seconds);
            Some(image)
        }
        _ => None,
    };
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
        match &denoised {
            Some(d) => {
                image::write_rgb(&args.output, merged.width(), merged.height(), d, &options)?
            }
            None => image::write_image(&args.output, &merged, &options)?,
        }
    }
    if let Some(v) = &args.variance {
        write_variance(v, &merged)?;
    }
    report.peak_memory_bytes = farm::peak_memory_bytes();
    if let Some(r) = &args.report {
        write_json(r, &report)?;
    }
    crate::log::note(&format!(
        "merged {} parts into {} ({} x {} pixels, samples {}..{}) in {:.2} s",
        args.parts.len(),
        args.output.display(),
        merged.width(),
        merged.height(),
        prov.samples.start,
        prov.samples.end,
        report.seconds
    ));
    Ok(())
}

/// The merged render, denoised as `render --denoise` denoises a
/// one-process render: the auxiliary images of the scene at `scene_path`
/// (checked against the parts' scene hash) along the render's own camera
/// rays (its seed, sampler, samples and backend, from the provenance), then
/// [`crate::denoise::denoise_film`]. The same bits as `render --denoise`,
/// since the merged film is. Returns the image and the seconds the
/// auxiliary images and the denoiser took.
fn denoise_merged(
    scene_path: &std::path::Path,
    film: &crate::film::Film,
    prov: &farm::Provenance,
) -> Result<(Vec<[f64; 3]>, f64, f64)> {
    use crate::error::Error;
    let scene = crate::scene::Scene::load(scene_path)?;
    let hash = farm::scene_hash(&scene);
    if hash != prov.scene_hash {
        return Err(Error::Settings(format!(
            "merge --denoise: {} is not the scene the parts were rendered from (hash {hash:016x}, the parts say {:016x})",
            scene_path.display(),
            prov.scene_hash
        )));
    }
    let setting = |name: &str| {
        prov.setting(name)
            .ok_or_else(|| Error::Settings(format!("merge --denoise: the parts record no {name}")))
    };
    let parse_err =
        |name: &str, e: String| Error::Settings(format!("merge --denoise: {name}: {e}"));
    let seed: u64 = setting("seed")?
        .parse()
        .map_err(|e: std::num::ParseIntError| parse_err("seed", e.to_string()))?;
    let sampler: crate::sampler::SamplerKind = setting("sampler")?
        .parse()
        .map_err(|e| parse_err("sampler", e))?;
    let backend: crate::accel::Backend = setting("backend")?
        .parse()
        .map_err(|e| parse_err("backend", e))?;
    let resolution = prov
        .resolution()
        .ok_or_else(|| parse_err("resolution", "missing".into()))?;
    let spp = prov
        .spp()
        .ok_or_else(|| parse_err("spp", "missing".into()))?;
    let accel = crate::accel::build(backend, scene.soup(), crate::accel::AccelOptions::default())?;
    let tracer = crate::integrator::PathTracer::new(&scene, accel.as_ref(), Default::default());
    let rays = crate::denoise::CameraRays {
        tracer: &tracer,
        camera: &scene.make_camera(resolution[0], resolution[1]),
        space: crate::sampler::SampleSpace::new(sampler, seed, resolution, spp),
        seed,
    };
    let samples: Vec<u32> = film.pixels().iter().map(|p| p.count as u32).collect();
    let d = rays.denoise_render(film, &samples)?;
    Ok((d.image, d.auxiliary_seconds, d.denoise_seconds))
}
