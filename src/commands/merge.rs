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
    let (merged, prov, mut report) =
        farm::merge(&args.parts, args.accumulation, args.allow_mixed_builds)?;
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
        image::write_image(&args.output, &merged, &options)?;
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
