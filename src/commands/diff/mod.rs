//! `embertrace diff`: an image against a reference ([`metrics`]).

pub mod metrics;

pub use metrics::{Image, compare, ramp};

use super::write_json;
use crate::error::{Error, Result};
use crate::image;
use crate::outputs::{self, Inputs};
use clap::Args;
use std::path::PathBuf;

/// The arguments of `embertrace diff`.
#[derive(Args)]
pub struct DiffArgs {
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

/// Run `embertrace diff`.
pub fn run(args: DiffArgs) -> Result<()> {
    use metrics::write_error_image;
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
        crate::commands::render::report::check_report_path(j)?;
    }
    if let Some(p) = &args.error_image {
        image::check_output_path(p)?;
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
        crate::log::note(&format!("error image: {} (white = {top:.3e})", p.display()));
    }
    if let Some(j) = &args.json {
        write_json(j, &stats)?;
    }
    Ok(())
}
