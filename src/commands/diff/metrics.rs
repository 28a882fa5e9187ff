//! `embertrace diff A B`: how far image `A` is from reference `B`.
//!
//! Both images are linear float images (OpenEXR or PFM) of the same size.
//! Every metric is taken over all pixels and all three channels, in `f64`:
//!
//! - `rmse`: `sqrt(mean((a - b)^2))`;
//! - `rel_mse`: `mean((a - b)^2 / (b^2 + eps))` with `eps = 1e-2`, the
//!   relative MSE of Rousselle, Knaus and Zwicker ("Adaptive Sampling and
//!   Reconstruction using Greedy Error Minimization", SIGGRAPH Asia 2011),
//!   whose `eps` keeps black reference pixels from dominating;
//! - `mae`: `mean(|a - b|)`;
//! - `max_error`: the largest `|a - b|`, and the pixel where it occurs (the
//!   first in scan order).
//!
//! A channel value that is NaN or infinite in either image is not compared:
//! it is counted in `non_finite` instead, so one bad pixel cannot turn every
//! metric into NaN without saying so.
//!
//! The optional error image shows each pixel's mean absolute error over its
//! channels on a black-blue-red-yellow-white ramp, scaled so that `scale`
//! (by default the largest per-pixel error) is white.

use crate::error::{Error, Result};
use crate::image::{read_exr, read_pfm, write_png_rgb8};
use serde::Serialize;
use std::path::Path;

/// `eps` of the relative MSE.
pub const REL_MSE_EPS: f64 = 1e-2;

/// A linear RGB image: row-major, top row first, three floats per pixel.
#[derive(Debug, Clone, PartialEq)]
pub struct Image {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// `width * height * 3` channel values.
    pub rgb: Vec<f32>,
}

impl Image {
    /// Read an OpenEXR (`.exr`) or Portable Float Map (`.pfm`) file.
    pub fn read(path: &Path) -> Result<Image> {
        let ext = path
            .extension()
            .and_then(|e| e.to_str())
            .map(str::to_ascii_lowercase);
        let (width, height, rgb) = match ext.as_deref() {
            Some("exr") => read_exr(path)?,
            Some("pfm") => read_pfm(path)?,
            _ => {
                return Err(Error::input(
                    path,
                    None,
                    "expected a linear float image (.exr or .pfm) to compare",
                ));
            }
        };
        Ok(Image { width, height, rgb })
    }
}

/// The differences between an image and its reference.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct DiffStats {
    /// Pixels compared.
    pub pixels: u64,
    /// Root mean squared error.
    pub rmse: f64,
    /// Relative mean squared error (`eps` = [`REL_MSE_EPS`]).
    pub rel_mse: f64,
    /// Mean absolute error.
    pub mae: f64,
    /// Largest absolute error of one channel.
    pub max_error: f64,
    /// `[x, y]` of the largest error.
    pub max_error_pixel: [u32; 2],
    /// Channel values left out because either image has NaN or infinity.
    pub non_finite: u64,
}

/// Compare `a` with the reference `b`; `a_name` and `b_name` only label a
/// size mismatch.
pub fn compare(a: &Image, b: &Image, a_name: &Path, b_name: &Path) -> Result<DiffStats> {
    if (a.width, a.height) != (b.width, b.height) {
        return Err(Error::input(
            a_name,
            None,
            format!(
                "is {}x{} but the reference {} is {}x{}: images must be the same size",
                a.width,
                a.height,
                b_name.display(),
                b.width,
                b.height
            ),
        ));
    }
    let (mut se, mut rel, mut ae, mut n, mut bad) = (0.0f64, 0.0f64, 0.0f64, 0u64, 0u64);
    let (mut max, mut at) = (0.0f64, 0usize);
    for (i, (&x, &y)) in a.rgb.iter().zip(&b.rgb).enumerate() {
        if !(x.is_finite() && y.is_finite()) {
            bad += 1;
            continue;
        }
        let (x, y) = (x as f64, y as f64);
        let d = x - y;
        se += d * d;
        rel += d * d / (y * y + REL_MSE_EPS);
        ae += d.abs();
        n += 1;
        if d.abs() > max {
            (max, at) = (d.abs(), i / 3);
        }
    }
    let mean = |s: f64| if n > 0 { s / n as f64 } else { 0.0 };
    Ok(DiffStats {
        pixels: u64::from(a.width) * u64::from(a.height),
        rmse: mean(se).sqrt(),
        rel_mse: mean(rel),
        mae: mean(ae),
        max_error: max,
        max_error_pixel: [at as u32 % a.width.max(1), at as u32 / a.width.max(1)],
        non_finite: bad,
    })
}

/// Each pixel's mean absolute error over its finite channels (0 where none
/// is finite).
pub fn error_map(a: &Image, b: &Image) -> Vec<f64> {
    a.rgb
        .chunks_exact(3)
        .zip(b.rgb.chunks_exact(3))
        .map(|(p, q)| {
            let d: Vec<f64> = p
                .iter()
                .zip(q)
                .filter(|(x, y)| x.is_finite() && y.is_finite())
                .map(|(&x, &y)| (x as f64 - y as f64).abs())
                .collect();
            if d.is_empty() {
                0.0
            } else {
                d.iter().sum::<f64>() / d.len() as f64
            }
        })
        .collect()
}

/// The false-colour ramp at `s` in `[0, 1]`: black, blue, red, yellow, white.
pub fn ramp(s: f64) -> [u8; 3] {
    const STOPS: [[f64; 3]; 5] = [
        [0.0, 0.0, 0.0],
        [0.0, 0.0, 1.0],
        [1.0, 0.0, 0.0],
        [1.0, 1.0, 0.0],
        [1.0, 1.0, 1.0],
    ];
    let s = if s.is_nan() { 0.0 } else { s.clamp(0.0, 1.0) } * 4.0;
    let k = (s as usize).min(3);
    let f = s - k as f64;
    std::array::from_fn(|c| {
        let v = STOPS[k][c] + f * (STOPS[k + 1][c] - STOPS[k][c]);
        (v * 255.0).round() as u8
    })
}

/// Write the error image of `a` against `b` as a PNG: `scale` (or, if
/// `None`, the largest pixel error) maps to white.
pub fn write_error_image(path: &Path, a: &Image, b: &Image, scale: Option<f64>) -> Result<f64> {
    let map = error_map(a, b);
    let top = scale.unwrap_or_else(|| map.iter().copied().fold(0.0, f64::max));
    let rgb: Vec<u8> = map
        .iter()
        .flat_map(|&e| ramp(if top > 0.0 { e / top } else { 0.0 }))
        .collect();
    write_png_rgb8(path, a.width, a.height, &rgb)?;
    Ok(top)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn img(w: u32, h: u32, rgb: Vec<f32>) -> Image {
        Image {
            width: w,
            height: h,
            rgb,
        }
    }

    #[test]
    fn metrics_of_a_known_difference() {
        // reference all 1; the image differs by 0.5 in one channel of pixel
        // (1, 0) and by -1 in one channel of pixel (0, 1)
        let b = img(2, 2, vec![1.0; 12]);
        let mut a = b.clone();
        a.rgb[3] = 1.5;
        a.rgb[8] = 0.0;
        let s = compare(&a, &b, Path::new("a"), Path::new("b")).unwrap();
        let n = 12.0f64;
        assert!((s.rmse - ((0.25 + 1.0) / n).sqrt()).abs() < 1e-12);
        assert!((s.mae - 1.5 / n).abs() < 1e-12);
        assert!((s.rel_mse - (0.25 + 1.0) / (1.0 + REL_MSE_EPS) / n).abs() < 1e-12);
        assert_eq!((s.max_error, s.max_error_pixel), (1.0, [0, 1]));
        assert_eq!((s.pixels, s.non_finite), (4, 0));
    }

    #[test]
    fn identical_images_have_zero_error_and_non_finite_values_are_counted() {
        let mut a = img(3, 1, vec![0.2, 0.4, 0.6, 1.0, 2.0, 3.0, 0.0, 0.0, 0.0]);
        let s = compare(&a, &a.clone(), Path::new("a"), Path::new("b")).unwrap();
        assert_eq!(
            (s.rmse, s.rel_mse, s.mae, s.max_error),
            (0.0, 0.0, 0.0, 0.0)
        );
        let b = a.clone();
        a.rgb[4] = f32::NAN;
        a.rgb[5] = f32::INFINITY;
        let s = compare(&a, &b, Path::new("a"), Path::new("b")).unwrap();
        assert_eq!((s.non_finite, s.rmse), (2, 0.0));
    }

    #[test]
    fn size_mismatch_is_one_line_naming_both_files() {
        let e = compare(
            &img(2, 1, vec![0.0; 6]),
            &img(1, 2, vec![0.0; 6]),
            Path::new("render.exr"),
            Path::new("ref.exr"),
        )
        .unwrap_err()
        .to_string();
        assert!(
            e.contains("render.exr") && e.contains("ref.exr") && !e.contains('\n'),
            "{e}"
        );
    }

    #[test]
    fn ramp_ends_and_stops() {
        assert_eq!(ramp(0.0), [0, 0, 0]);
        assert_eq!(ramp(0.25), [0, 0, 255]);
        assert_eq!(ramp(0.5), [255, 0, 0]);
        assert_eq!(ramp(1.0), [255, 255, 255]);
        assert_eq!(ramp(7.0), [255, 255, 255]);
        assert_eq!(ramp(f64::NAN), [0, 0, 0]);
    }
}
