//! The subcommands of the `embertrace` binary, one module each with its
//! command-line arguments (clap) and its `run`; `src/main.rs` only parses
//! and dispatches. Modules used by one command alone live under it.

pub mod bench;
pub mod convert;
pub mod diff;
pub mod merge;
pub mod parity;
pub mod plan;
pub mod raysets;
pub mod render;
pub mod study;

use crate::accel::AccelOptions;
use crate::accel::bvh::BvhQuality;
use crate::error::{Error, Result};
use crate::film;
use crate::image::{self, OutputOptions};
use clap::Args;

/// How backends are built (shared by every command).
#[derive(Args)]
pub struct BuildArgs {
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
    /// The accelerator options these flags ask for.
    pub fn options(&self) -> AccelOptions {
        AccelOptions {
            robust: !self.no_robust,
            bvh_quality: self.bvh_quality,
        }
    }
}

/// `--exposure`: a finite number of stops, refused when the command line is
/// read, before any work (NaN would otherwise be found only when the image
/// is written).
pub(crate) fn parse_exposure(s: &str) -> std::result::Result<f32, String> {
    let v: f32 = s.parse().map_err(|e| format!("{e}"))?;
    if !v.is_finite() {
        return Err(format!("expected a finite number of stops, got {v}"));
    }
    Ok(v)
}

/// Write `value` as pretty JSON to `path`, atomically.
pub(crate) fn write_json(path: &std::path::Path, value: &impl serde::Serialize) -> Result<()> {
    let text =
        serde_json::to_string_pretty(value).expect("plain numbers and strings serialise") + "\n";
    image::write_file_atomically(path, text.as_bytes())
}

/// Fail unless `path` names an `.exr` file that can be written.
pub(crate) fn check_exr(path: &std::path::Path, what: &str) -> Result<()> {
    image::check_output_path(path)?;
    if image::ImageFormat::from_path(path)? != image::ImageFormat::Exr {
        return Err(Error::Settings(format!(
            "{}: {what}: expected an .exr file",
            path.display()
        )));
    }
    Ok(())
}

/// The per-pixel variance of the mean, per channel, as EXR.
pub(crate) fn write_variance(path: &std::path::Path, f: &film::Film) -> Result<()> {
    let v: Vec<[f64; 3]> = f
        .pixels()
        .iter()
        .map(|p| p.variance_of_mean_f64())
        .collect();
    image::write_rgb(path, f.width(), f.height(), &v, &OutputOptions::default())
}
