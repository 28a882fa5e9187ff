//! Denoising with Intel Open Image Denoise (OIDN; Áfra, "Intel Open Image
//! Denoise", <https://www.openimagedenoise.org>), behind the `denoise`
//! feature, through the `oidn` crate (no `unsafe` here).
//!
//! The filter is OIDN's `RT` (ray-traced images) in HDR mode on the linear
//! beauty, with the first-hit albedo and shading normal of
//! [`crate::render::render_auxiliary`] as auxiliary images and `cleanAux`
//! on: OIDN then trusts the auxiliary images as noise-free and keeps their
//! detail. They are noise-free by construction where the camera is a
//! pinhole (each is the mean over the pixel's jittered rays of a quantity
//! that follows delta surfaces deterministically; only edges and textures
//! vary within a pixel, and averaging anti-aliases them). Through a lens
//! with an aperture they are noisy (each ray samples the lens), and they
//! are prefiltered first, as OIDN's documentation asks for `cleanAux`. The
//! `oidn` crate (2.5.1) cannot give the `RT` filter an auxiliary image as
//! its only input, which is how OIDN selects its dedicated albedo and
//! normal prefilter weights, so the prefilter here runs the `RT` filter's
//! LDR weights on the albedo, and on the normal mapped from `[-1, 1]` to
//! `[0, 1]` and back: a documented approximation of OIDN's own prefilter.
//!
//! Bias: a denoised image is a biased estimate of the render (the filter
//! trades variance for a blur the error estimate does not see); `study
//! --denoise`-style measurements and the user guide's page on denoising say
//! how much. This is the place that bias enters.
//!
//! Determinism: the CPU device computes each output pixel from the same
//! inputs in the same order whatever its threads (a convolutional network,
//! no reductions across threads), so the same noisy image, albedo and
//! normal give the same bits run to run on one machine; a test checks it.
//! Another CPU (another instruction set) may round differently.

use crate::camera::Camera;
use crate::error::{Error, Result};
use crate::film::Film;
use crate::integrator::PathTracer;
use crate::render::{AuxiliaryImages, render_auxiliary};
use crate::sampler::SampleSpace;
use std::time::Instant;

/// What `--denoise` says when the build has no OIDN.
pub const HOW_TO_GET: &str = "--denoise needs Intel Open Image Denoise, which this build \
    lacks: rebuild with `--features denoise` (on Debian 12, after \
    `export OIDN_DIR=\"$(bash scripts/oidn.sh)\"`; docs/guide/denoising.md names other ways)";

/// Whether this build can denoise.
pub const AVAILABLE: bool = cfg!(feature = "denoise");

/// The denoiser's inputs: flat linear RGB triples, row-major from the top.
#[derive(Debug, Clone, Copy)]
pub struct Inputs<'a> {
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// The noisy beauty (HDR, linear).
    pub color: &'a [f32],
    /// First-hit albedo in `[0, 1]`.
    pub albedo: &'a [f32],
    /// First-hit shading normal, world space, in `[-1, 1]`.
    pub normal: &'a [f32],
    /// Whether the auxiliary images are noisy and need prefiltering.
    pub prefilter: bool,
}

impl Inputs<'_> {
    fn check(&self) -> Result<()> {
        let n = self.width as usize * self.height as usize * 3;
        for (name, len) in [
            ("colour", self.color.len()),
            ("albedo", self.albedo.len()),
            ("normal", self.normal.len()),
        ] {
            if len != n {
                return Err(Error::Settings(format!(
                    "denoise: the {name} image holds {len} values, not {n} ({} x {} x 3)",
                    self.width, self.height
                )));
            }
        }
        Ok(())
    }
}

/// Denoise a render: `film`'s image less the emission its camera rays saw
/// (`aux.emitted`, traced along the same rays) goes through [`denoise`],
/// and the emission, re-estimated at emitters' edges (`aux.emitted_fine`),
/// goes back on. A camera ray's view of a light is not noise, and a network
/// that smooths it turns the light's edge into a band of errors (on the
/// Cornell box at 16 spp, RMSE 5.5e-2 against Mitsuba, twice the noisy
/// image's, where this gives 4.8e-3; docs/guide/denoising.md).
/// `prefilter`: see [`Inputs::prefilter`] and [`CameraRays::denoise`].
pub fn denoise_film(film: &Film, aux: &AuxiliaryImages, prefilter: bool) -> Result<Vec<[f64; 3]>> {
    let reflected: Vec<[f64; 3]> = film
        .pixels()
        .iter()
        .zip(&aux.emitted)
        .map(|(p, e)| {
            let m = p.mean_f64();
            std::array::from_fn(|c| (m[c] - e[c]).max(0.0))
        })
        .collect();
    let color = AuxiliaryImages::flat_f32(&reflected);
    let albedo = AuxiliaryImages::flat_f32(&aux.albedo);
    let normal = AuxiliaryImages::flat_f32(&aux.normal);
    let out = denoise(&Inputs {
        width: film.width(),
        height: film.height(),
        color: &color,
        albedo: &albedo,
        normal: &normal,
        prefilter,
    })?;
    Ok(out
        .chunks_exact(3)
        .zip(&aux.emitted_fine)
        .map(|(c, e)| std::array::from_fn(|k| c[k].max(0.0) as f64 + e[k]))
        .collect())
}

/// A render's camera rays, which its auxiliary images follow: what `render
/// --denoise`, `merge --denoise`, `study --denoise` and
/// [`crate::Renderer::denoise`] share.
pub struct CameraRays<'r, 's> {
    /// The render's tracer.
    pub tracer: &'r PathTracer<'s>,
    /// Its camera.
    pub camera: &'r Camera,
    /// Its sample space (sampler, seed, total samples per pixel).
    pub space: SampleSpace,
    /// Its seed.
    pub seed: u64,
}

/// A render denoised, with its auxiliary images and what each step took.
pub struct Denoised {
    /// The denoised image, linear RGB row by row.
    pub image: Vec<[f64; 3]>,
    /// The auxiliary images it was denoised with.
    pub aux: AuxiliaryImages,
    /// Seconds the auxiliary images took.
    pub auxiliary_seconds: f64,
    /// Seconds the denoiser took.
    pub denoise_seconds: f64,
}

impl CameraRays<'_, '_> {
    /// The auxiliary images, each pixel `i` over its samples
    /// `0..samples[i]` ([`render_auxiliary`]), and the seconds they took.
    pub fn auxiliary(&self, resolution: [u32; 2], samples: &[u32]) -> (AuxiliaryImages, f64) {
        let t = Instant::now();
        let aux = render_auxiliary(
            self.tracer,
            self.camera,
            resolution,
            &self.space,
            samples,
            self.seed,
        );
        (aux, t.elapsed().as_secs_f64())
    }

    /// `film` denoised with `aux` ([`denoise_film`]; prefiltered where a lens
    /// with an aperture makes each auxiliary ray sample the lens), and the
    /// seconds it took.
    pub fn denoise(&self, film: &Film, aux: &AuxiliaryImages) -> Result<(Vec<[f64; 3]>, f64)> {
        let t = Instant::now();
        let prefilter = self.tracer.kernel().lens && !self.camera.lens().is_pinhole();
        let image = denoise_film(film, aux, prefilter)?;
        Ok((image, t.elapsed().as_secs_f64()))
    }

    /// Both: `film`, whose pixel `i` took samples `0..samples[i]`, denoised.
    pub fn denoise_render(&self, film: &Film, samples: &[u32]) -> Result<Denoised> {
        let (aux, auxiliary_seconds) = self.auxiliary([film.width(), film.height()], samples);
        let (image, denoise_seconds) = self.denoise(film, &aux)?;
        Ok(Denoised {
            image,
            aux,
            auxiliary_seconds,
            denoise_seconds,
        })
    }
}

/// The denoised beauty, flat linear RGB.
#[cfg(feature = "denoise")]
pub fn denoise(input: &Inputs<'_>) -> Result<Vec<f32>> {
    input.check()?;
    let fail = |what: &str, e: oidn::Error| Error::Settings(format!("denoise: {what}: {e}"));
    let device = oidn::Device::cpu().map_err(|e| fail("no OIDN CPU device", e))?;
    let (w, h) = (input.width as usize, input.height as usize);
    let mut albedo = input.albedo.to_vec();
    let mut normal = input.normal.to_vec();
    if input.prefilter {
        prefilter(&device, w, h, &mut albedo).map_err(|e| fail("prefiltering the albedo", e))?;
        normal.iter_mut().for_each(|v| *v = 0.5 * (*v + 1.0));
        prefilter(&device, w, h, &mut normal).map_err(|e| fail("prefiltering the normal", e))?;
        normal.iter_mut().for_each(|v| *v = 2.0 * *v - 1.0);
    }
    let mut filter =
        oidn::RayTracing::try_new(&device).map_err(|e| fail("cannot make the RT filter", e))?;
    filter
        .image_dimensions(w, h)
        .hdr(true)
        .clean_aux(true)
        .filter_quality(oidn::Quality::High)
        .albedo_normal(&albedo, &normal);
    let mut out = vec![0.0f32; input.color.len()];
    filter
        .filter(input.color, &mut out)
        .map_err(|e| fail("the RT filter failed", e))?;
    Ok(out)
}

/// Denoise an auxiliary image in place as an LDR colour image (see the
/// module's documentation for why not with OIDN's own prefilter weights).
#[cfg(feature = "denoise")]
fn prefilter(
    device: &oidn::Device,
    w: usize,
    h: usize,
    image: &mut [f32],
) -> std::result::Result<(), oidn::Error> {
    let mut filter = oidn::RayTracing::try_new(device)?;
    filter
        .image_dimensions(w, h)
        .hdr(false)
        .filter_quality(oidn::Quality::High);
    filter.filter_in_place(image)
}

/// Without the `denoise` feature: the one-line error of [`HOW_TO_GET`].
#[cfg(not(feature = "denoise"))]
pub fn denoise(input: &Inputs<'_>) -> Result<Vec<f32>> {
    input.check()?;
    Err(Error::Settings(HOW_TO_GET.to_string()))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn images(w: u32, h: u32, seed: u32) -> (Vec<f32>, Vec<f32>, Vec<f32>) {
        // a grey wall with a bright square, plus hash noise
        let n = (w * h) as usize;
        let mut color = Vec::with_capacity(3 * n);
        for i in 0..n as u32 {
            let (x, y) = (i % w, i / w);
            let base = if (w / 4..3 * w / 4).contains(&x) && (h / 4..3 * h / 4).contains(&y) {
                2.0
            } else {
                0.5
            };
            let hash = (i ^ seed).wrapping_mul(0x9E37_79B9).rotate_left(13);
            let noise = (hash % 1000) as f32 / 1000.0 - 0.5;
            color.extend([base * (1.0 + noise); 3]);
        }
        (color, vec![0.8; 3 * n], [0.0, 0.0, 1.0].repeat(n))
    }

    #[test]
    fn mismatched_sizes_are_settings_errors() {
        let (c, a, n) = images(8, 8, 1);
        let e = denoise(&Inputs {
            width: 8,
            height: 8,
            color: &c,
            albedo: &a[..3],
            normal: &n,
            prefilter: false,
        })
        .unwrap_err();
        assert!(e.to_string().contains("albedo image holds 3 values"), "{e}");
    }

    #[cfg(not(feature = "denoise"))]
    #[test]
    fn without_the_feature_denoising_says_how_to_get_it() {
        let (c, a, n) = images(8, 8, 1);
        let e = denoise(&Inputs {
            width: 8,
            height: 8,
            color: &c,
            albedo: &a,
            normal: &n,
            prefilter: false,
        })
        .unwrap_err();
        let text = e.to_string();
        assert_eq!(text.lines().count(), 1);
        assert!(text.contains("--features denoise") && text.contains("scripts/oidn.sh"));
    }

    #[cfg(feature = "denoise")]
    #[test]
    fn denoising_cuts_the_noise_keeps_the_mean_and_repeats_bit_for_bit() {
        let (w, h) = (64, 64);
        let (c, a, n) = images(w, h, 7);
        let input = Inputs {
            width: w,
            height: h,
            color: &c,
            albedo: &a,
            normal: &n,
            prefilter: false,
        };
        let out = denoise(&input).unwrap();
        // the noise is in the flat regions: compare each pixel with the
        // noise-free base it was drawn around
        let base = |i: usize| {
            let (x, y) = ((i / 3) as u32 % w, (i / 3) as u32 / w);
            if (w / 4..3 * w / 4).contains(&x) && (h / 4..3 * h / 4).contains(&y) {
                2.0
            } else {
                0.5
            }
        };
        let mse = |img: &[f32]| {
            img.iter()
                .enumerate()
                .map(|(i, v)| (v - base(i)).powi(2) as f64)
                .sum::<f64>()
                / img.len() as f64
        };
        assert!(
            mse(&out) < mse(&c) / 10.0,
            "{} against {}",
            mse(&out),
            mse(&c)
        );
        let mean = |img: &[f32]| img.iter().map(|&v| v as f64).sum::<f64>() / img.len() as f64;
        assert!((mean(&out) / mean(&c) - 1.0).abs() < 0.02);
        assert_eq!(denoise(&input).unwrap(), out, "a second run differs");
        let prefiltered = denoise(&Inputs {
            prefilter: true,
            ..input
        })
        .unwrap();
        assert!(mse(&prefiltered) < mse(&c) / 10.0);
    }
}
