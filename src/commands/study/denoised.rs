//! `study --denoise`: each pass of each setting is also denoised
//! ([`crate::denoise::denoise_film`]), which gives a denoised
//! error-against-time curve beside the noisy one (its time: the render's so
//! far plus the auxiliary images' and the denoiser's for that pass), and
//! every final image, noisy or denoised, gets two measures of bias:
//!
//! - the mean error: the image's mean over the reference's, less 1;
//! - the block error: the RMS difference of 8 x 8 block means, relative to
//!   the reference's RMS. Averaging 64 pixels divides a noisy image's
//!   per-pixel noise by 8 but leaves what the denoiser smoothed into the
//!   wrong place, so where a denoised image's block error stops falling
//!   with spp, its bias dominates.

use crate::camera::Camera;
use crate::commands::diff::Image;
use crate::error::Result;
use crate::film::Film;
use crate::integrator::PathTracer;
use crate::sampler::SampleSpace;

/// Side of the blocks of [`block_error`].
pub const BLOCK: u32 = 8;

/// One pass, denoised.
pub struct DenoisedPass {
    /// The denoised image.
    pub image: Image,
    /// Seconds the auxiliary images and the denoiser took.
    pub seconds: f64,
}

/// Denoise `film` (a pass of the render whose camera rays `space` draws,
/// each pixel having taken its film count of samples).
pub fn denoise_pass(
    tracer: &PathTracer<'_>,
    camera: &Camera,
    space: &SampleSpace,
    seed: u64,
    film: &Film,
) -> Result<DenoisedPass> {
    let rays = crate::denoise::CameraRays {
        tracer,
        camera,
        space: *space,
        seed,
    };
    let samples: Vec<u32> = film.pixels().iter().map(|p| p.count as u32).collect();
    let d = rays.denoise_render(film, &samples)?;
    Ok(DenoisedPass {
        image: Image {
            width: film.width(),
            height: film.height(),
            rgb: d.image.iter().flatten().map(|&v| v as f32).collect(),
        },
        seconds: d.auxiliary_seconds + d.denoise_seconds,
    })
}

/// `mean(image) / mean(reference) - 1` over every channel value.
pub fn mean_error(image: &Image, reference: &Image) -> f64 {
    let mean = |v: &[f32]| v.iter().map(|&x| x as f64).sum::<f64>() / v.len().max(1) as f64;
    mean(&image.rgb) / mean(&reference.rgb) - 1.0
}

/// The RMS difference of the images' [`BLOCK`] x [`BLOCK`] block means
/// (per channel; partial blocks at the right and bottom edges left out),
/// relative to the RMS of the reference's.
pub fn block_error(image: &Image, reference: &Image) -> f64 {
    let (bw, bh) = (image.width / BLOCK, image.height / BLOCK);
    let (mut diff, mut norm) = (0.0f64, 0.0f64);
    for by in 0..bh {
        for bx in 0..bw {
            for c in 0..3 {
                let (mut a, mut r) = (0.0f64, 0.0f64);
                for y in by * BLOCK..(by + 1) * BLOCK {
                    for x in bx * BLOCK..(bx + 1) * BLOCK {
                        let i = ((y * image.width + x) * 3) as usize + c;
                        a += image.rgb[i] as f64;
                        r += reference.rgb[i] as f64;
                    }
                }
                let n = (BLOCK * BLOCK) as f64;
                diff += (a / n - r / n).powi(2);
                norm += (r / n).powi(2);
            }
        }
    }
    if norm > 0.0 {
        (diff / norm).sqrt()
    } else {
        0.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn image(w: u32, h: u32, f: impl Fn(u32, u32) -> f32) -> Image {
        let rgb = (0..w * h).flat_map(|i| [f(i % w, i / w); 3]).collect();
        Image {
            width: w,
            height: h,
            rgb,
        }
    }

    #[test]
    fn block_error_sees_a_shift_of_the_mean_but_not_zero_mean_noise() {
        let reference = image(16, 16, |_, _| 1.0);
        // +-0.5 alternating: every 8 x 8 block averages to the reference
        let noise = image(16, 16, |x, y| if (x + y) % 2 == 0 { 1.5 } else { 0.5 });
        assert!(block_error(&noise, &reference) < 1e-12);
        assert!(mean_error(&noise, &reference).abs() < 1e-12);
        let biased = image(16, 16, |_, _| 1.1);
        assert!((block_error(&biased, &reference) - 0.1).abs() < 1e-6);
        assert!((mean_error(&biased, &reference) - 0.1).abs() < 1e-6);
        // a bias that moves light from one block to its neighbour: the mean
        // error cannot see it, the block error does
        let moved = image(16, 16, |x, _| if x < 8 { 1.2 } else { 0.8 });
        assert!(mean_error(&moved, &reference).abs() < 1e-6);
        assert!((block_error(&moved, &reference) - 0.2).abs() < 1e-6);
    }
}
