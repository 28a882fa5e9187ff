//! The end of a render that needs the auxiliary images: `--albedo`,
//! `--normal`, `--aovs` (one layered EXR) and `--denoise` (with `--noisy`
//! keeping the image as rendered). The auxiliary images are rendered once,
//! after the beauty, from their own sample stream
//! ([`crate::render::render_auxiliary`]).

use super::RenderArgs;
use crate::denoise;
use crate::error::{Error, Result};
use crate::film::Film;
use crate::image::{self, ExrLayer, OutputOptions};
use crate::render::AuxiliaryImages;

/// Checks of the flags, before anything renders.
pub(super) fn check(args: &RenderArgs, farm: bool) -> Result<()> {
    if args.noisy.is_some() && !args.denoise {
        return Err(Error::Settings(
            "--noisy keeps the image as rendered beside the denoised one: it needs --denoise"
                .into(),
        ));
    }
    if farm && (args.denoise || args.aovs.is_some()) {
        return Err(Error::Settings(
            "--denoise and --aovs finish a whole image: they do not combine with --shard, --crop, --checkpoint or --resume (render the parts, merge them, then denoise)".into(),
        ));
    }
    if args.denoise && !denoise::AVAILABLE {
        return Err(Error::Settings(denoise::HOW_TO_GET.to_string()));
    }
    if let Some(p) = &args.aovs {
        super::check_exr(p, "--aovs: the AOVs are one layered OpenEXR file")?;
    }
    if let Some(p) = &args.noisy {
        image::check_output_path(p)?;
    }
    Ok(())
}

/// What [`run`] leaves for the main image and the report.
pub(super) struct Finished {
    /// The denoised image (`--denoise`), row-major linear RGB.
    pub denoised: Option<Vec<[f64; 3]>>,
    /// Seconds spent rendering the auxiliary images.
    pub auxiliary_seconds: Option<f64>,
    /// Seconds the denoiser took.
    pub denoise_seconds: Option<f64>,
}

/// Where the auxiliary images come from: the render's own camera rays.
pub(super) struct Sources<'r, 's> {
    pub rays: denoise::CameraRays<'r, 's>,
    pub resolution: [u32; 2],
    /// Whether the render was progressive: then each pixel took as many
    /// samples as its film count says (adaptive sampling stops pixels
    /// early), else `spp` each.
    pub progressive: bool,
    pub spp: u32,
}

/// Render the auxiliary images if a flag needs them, write `--albedo`,
/// `--normal` and `--noisy`, denoise, and write `--aovs` (whose main layer is
/// the image `-o` gets: the denoised one with `--denoise`).
pub(super) fn run(args: &RenderArgs, from: &Sources<'_, '_>, film: &Film) -> Result<Finished> {
    let mut done = Finished {
        denoised: None,
        auxiliary_seconds: None,
        denoise_seconds: None,
    };
    let wants_aux =
        args.albedo.is_some() || args.normal.is_some() || args.aovs.is_some() || args.denoise;
    if !wants_aux {
        return Ok(done);
    }
    let [w, h] = from.resolution;
    let samples: Vec<u32> = if from.progressive {
        film.pixels().iter().map(|p| p.count as u32).collect()
    } else {
        vec![from.spp; w as usize * h as usize]
    };
    let aux = if args.denoise {
        let d = from.rays.denoise_render(film, &samples)?;
        done.denoised = Some(d.image);
        done.auxiliary_seconds = Some(d.auxiliary_seconds);
        done.denoise_seconds = Some(d.denoise_seconds);
        d.aux
    } else {
        let (aux, seconds) = from.rays.auxiliary(from.resolution, &samples);
        done.auxiliary_seconds = Some(seconds);
        aux
    };
    let plain = OutputOptions {
        exposure: 0.0,
        metadata: Vec::new(),
    };
    if let Some(p) = &args.albedo {
        image::write_rgb(p, w, h, &aux.albedo, &plain)?;
    }
    if let Some(p) = &args.normal {
        image::write_rgb(p, w, h, &aux.normal, &plain)?;
    }
    if let Some(p) = &args.noisy {
        image::write_image(p, film, &plain)?;
    }
    let means: Vec<[f64; 3]> = film.pixels().iter().map(|p| p.mean_f64()).collect();
    if let Some(p) = &args.aovs {
        let beauty = done.denoised.as_deref().unwrap_or(&means);
        image::write_exr_layers(p, w, h, &aov_layers(beauty, &aux, film), &[])?;
    }
    Ok(done)
}

/// The layers of `--aovs`: the image, then albedo, normal, depth, position
/// and variance, named as compositors expect them.
fn aov_layers(beauty: &[[f64; 3]], aux: &AuxiliaryImages, film: &Film) -> Vec<ExrLayer> {
    let planes = |image: &[[f64; 3]], names: [&str; 3]| -> Vec<(String, Vec<f32>)> {
        (0..3)
            .map(|c| {
                let plane = image.iter().map(|p| p[c] as f32).collect();
                (names[c].to_string(), plane)
            })
            .collect()
    };
    let variance: Vec<[f64; 3]> = film
        .pixels()
        .iter()
        .map(|p| p.variance_of_mean_f64())
        .collect();
    let layer = |name: &str, channels| ExrLayer {
        name: name.to_string(),
        channels,
    };
    const RGB: [&str; 3] = ["R", "G", "B"];
    const XYZ: [&str; 3] = ["X", "Y", "Z"];
    vec![
        layer("", planes(beauty, RGB)),
        layer("albedo", planes(&aux.albedo, RGB)),
        layer("normal", planes(&aux.normal, XYZ)),
        layer(
            "depth",
            vec![(
                "Z".to_string(),
                aux.depth.iter().map(|&d| d as f32).collect(),
            )],
        ),
        layer("position", planes(&aux.position, XYZ)),
        layer("variance", planes(&variance, RGB)),
    ]
}
