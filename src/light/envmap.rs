//! An equirectangular (latitude-longitude) environment map: radiance arriving
//! from infinitely far away, read from an image and multiplied by a
//! `radiance` scale, importance-sampled by luminance.
//!
//! Convention (Mitsuba 3's `envmap` emitter, so one file lights a scene the
//! same way in both renderers; checked against Mitsuba 3.9.1 by
//! `tests/lights.rs` with values made by `scripts/mitsuba_envmap_reference.py`):
//! `+y` is up, and the direction `d` towards the sky reads the map at
//! `u = atan2(d.x, -d.z) / 2pi` (wrapped to `[0, 1)`), `v = acos(d.y) / pi`,
//! `v = 0` being the top row (at the poles, where the azimuth is undefined,
//! `u = 0`, as Mitsuba's `atan2` has it). Inversely, `phi = 2 pi u`, `theta = pi v` and
//! `d = (sin phi sin theta, cos theta, -cos phi sin theta)`.
//!
//! Lookup is Mitsuba's bilinear interpolation: in `u` the `w` columns sit at
//! their texel centres `(x + 0.5) / w` and wrap around; in `v` the `h` rows sit
//! at `y / (h - 1)`, so the first row is the north pole (`+y`) and the last the
//! south pole. The radiance is continuous everywhere.
//!
//! Sampling: the interpolation grid has `w x (h - 1)` patches, each spanned
//! by four texels. The density over map coordinates is the bilinear
//! interpolation of each texel's luminance times the mean of `sin theta` over
//! the half bands of latitude beside its row, sampled exactly
//! ([`PeriodicBilinear2D`]), and mapped to a direction with the Jacobian of
//! the map: `pdf_dir = pdf_uv / (2 pi^2 sin theta)`. So inside every patch
//! the density follows the radiance as the lookup interpolates it (Mitsuba
//! 3's `envmap` does the same with a hierarchical warp), and radiance over
//! density is nearly constant for a grey map, which is what lets a
//! stratified sampler's points pay off here: with a constant density per
//! patch (pbrt-v4's `ImageInfiniteLight`) the ratio varied across every
//! patch, and direct lighting under `materials`' sky had 1.4 times the
//! variance per pixel with the `sobol` sampler (measured in the README,
//! "Speed"). The density is positive wherever the radiance is, the poles'
//! rows included. That pays on maps whose patches are large against their
//! radiance's detail; on a large map the constant density per patch is as
//! good and its draw cheaper (fewer cache misses), so each map takes the
//! bilinear density only where the constant one would add more than 1 %
//! relative variance ([`BILINEAR_ABOVE`]), computed when the map is built.
//!
//! [`EnvironmentMap::sample`] returns the radiance and density at the point
//! it drew, not recomputed from the direction it made of it; they equal
//! [`EnvironmentMap::eval`] and [`EnvironmentMap::pdf`] of that direction up
//! to the direction's rounding (a few ulps in its map coordinates, more in
//! `v` near the poles, where `acos` loses precision).

use crate::error::{Error, Result};
use crate::math::{Vec2, Vec3, luminance, trig};
use crate::sampling::bilinear::constant_patch_divergence;
use crate::sampling::{PeriodicBilinear2D, PiecewiseConstant2D};
use crate::texture::ImageTexture;
use std::f32::consts::PI;
use std::path::Path;

/// A sampled direction towards the environment.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EnvironmentSample {
    /// Unit direction towards the sky.
    pub wi: Vec3,
    /// Radiance arriving along `-wi`: `eval(wi)` up to the rounding of
    /// `wi` (see [`EnvironmentMap::sample`]).
    pub li: Vec3,
    /// Solid-angle density of `wi`, `> 0` and finite: `pdf(wi)` up to the
    /// rounding of `wi`.
    pub pdf: f32,
}

/// The bilinear density is chosen where the constant density per patch
/// would add more than this relative variance to light sampling (the
/// chi-square divergence of [`constant_patch_divergence`]). Measured under
/// `materials` (direct lighting, `sobol`, variance per pixel over eight
/// seeds, bilinear against constant): its 128 x 64 sky, divergence 0.029,
/// 27 % less variance for 3 % more instructions; the same sky upsampled
/// with 20 % texel noise to 512 x 256, 1024 x 512 and 4096 x 2048,
/// divergences 0.0048, 0.0033 and 0.0026, 4 %, 1 % and 1 % less variance,
/// while on the largest map the bilinear draw's extra cache misses cost 9 %
/// of the render's time (`render -t 1 -r 256 128 -s 16`, medians of five).
const BILINEAR_ABOVE: f64 = 0.01;

/// The density over the map's patches.
#[derive(Debug, Clone)]
enum Density {
    /// The bilinear interpolation of the texels' weights, sampled exactly.
    Bilinear(PeriodicBilinear2D),
    /// Each patch's weight the mean of its corners, constant across it.
    Constant(PiecewiseConstant2D),
}

impl Density {
    #[inline]
    fn pdf(&self, p: Vec2) -> f32 {
        match self {
            Density::Bilinear(d) => d.pdf(p),
            Density::Constant(d) => d.pdf(p),
        }
    }

    /// A point and its density.
    #[inline]
    fn sample(&self, u: Vec2) -> (Vec2, f32) {
        match self {
            Density::Bilinear(d) => {
                let s = d.sample(u);
                (s.p, s.pdf)
            }
            Density::Constant(d) => {
                let s = d.sample(u);
                (s.p, s.pdf)
            }
        }
    }
}

/// An equirectangular environment map light.
#[derive(Debug, Clone)]
pub struct EnvironmentMap {
    map: ImageTexture,
    /// The scale applied to every texel.
    radiance: Vec3,
    /// Over the `w x (h - 1)` interpolation patches, vertices on the
    /// texels; its `x` is `u - 0.5 / w` (wrapped), its `y` is `v`.
    distribution: Density,
    /// Integral of the luminance of the scaled map over the sphere.
    luminance_integral: f64,
}

/// The map coordinates `(u, v)` in `[0, 1) x [0, 1]` of the unit direction
/// `d` (towards the sky), through [`trig`]'s `atan2` and `acos` (within
/// three ulps of the exact angles, and no C library call).
#[inline]
pub fn direction_to_uv(d: Vec3) -> Vec2 {
    // At the poles the azimuth is undefined; u = 0 there, as in Mitsuba 3,
    // whose atan2 (Dr.Jit's) gives 0 for (+-0, +-0) where IEEE gives +-pi.
    let mut u = if d.x == 0.0 && d.z == 0.0 {
        0.0
    } else {
        trig::atan2(d.x, -d.z) * (0.5 / PI)
    };
    if u < 0.0 {
        u += 1.0;
    }
    if u >= 1.0 {
        u = 0.0;
    }
    let v = trig::acos(d.y.clamp(-1.0, 1.0)) * (1.0 / PI);
    Vec2::new(u, v)
}

/// The unit direction of map coordinates `uv`.
#[inline]
pub fn uv_to_direction(uv: Vec2) -> Vec3 {
    direction_and_sine(uv).0
}

/// The unit direction of map coordinates `uv` and the sine of its polar
/// angle (`>= 0` for `v` in `[0, 1]`).
#[inline]
fn direction_and_sine(uv: Vec2) -> (Vec3, f32) {
    let (sin_t, cos_t) = (PI * uv.y).sin_cos();
    let (sin_p, cos_p) = (2.0 * PI * uv.x).sin_cos();
    (Vec3::new(sin_p * sin_t, cos_t, -cos_p * sin_t), sin_t)
}

/// The CS184 course's environment map `course` (its `-e` flag) laid out
/// for this module's convention, so that it lights a scene as the course
/// lights it, exactly up to rounding.
///
/// The course (`src/scene/environment_light.cpp` of cal-cs184's
/// p3_2-pathtracer) reads direction `d` at `phi = atan2(-d.z, d.x) + pi`,
/// `theta = acos(d.y)`, column `x = phi / 2pi w`, row `y = theta / pi h`,
/// bilinearly between texel centres (`x + 0.5`, `y + 0.5`), wrapping in `x`
/// and holding the first and last rows' values out to the poles.
///
/// - Columns: the course's `u_c = phi / 2pi` is this module's `0.75 - u`,
///   a mirror and a quarter turn, so course column `i` becomes column
///   `(3w/4 - 1 - i) mod w`: exact when 4 divides the width (every
///   equirectangular map we know of; others are refused).
/// - Rows: this module's rows sit at `theta = pi j / (H - 1)`. With
///   `H = 2h + 1` rows, the odd ones are the course's row centres, the even
///   ones the midpoints between them (where the course's interpolation is their
///   mean), and its first and last rows the poles, where the course holds
///   its first and last rows. The course's radiance is linear between its
///   centres, so the two lookups agree.
pub fn from_course_layout(course: &ImageTexture) -> Result<ImageTexture> {
    let (w, h) = (course.width() as usize, course.height() as usize);
    if w % 4 != 0 {
        return Err(Error::Settings(format!(
            "a CS184 environment map ({w} x {h}) must be a multiple of 4 texels wide, \
             so that the course's azimuth maps onto whole columns"
        )));
    }
    let texel = |i: usize, j: usize| course.texels()[j * w + (3 * w / 4 + w - 1 - i) % w];
    let rows = 2 * h + 1;
    let mut rgb = Vec::with_capacity(w * rows * 3);
    for r in 0..rows {
        for i in 0..w {
            let t = match r {
                0 => texel(i, 0),
                r if r == rows - 1 => texel(i, h - 1),
                r if r % 2 == 1 => texel(i, r / 2),
                r => 0.5 * (texel(i, r / 2 - 1) + texel(i, r / 2)),
            };
            rgb.extend_from_slice(&t.to_array());
        }
    }
    ImageTexture::from_linear_rgb(w as u32, rows as u32, rgb)
}

/// pbrt-v4's equal-area octahedral mapping (Clarberg 2008, "Fast
/// Equal-Area Mapping of the (Hemi)Sphere using SIMD"; pbrt-v4's
/// `EqualAreaSquareToSphere`): the unit square onto the unit sphere, `z`
/// up at the centre, in f64.
pub fn equal_area_square_to_sphere(p: glam::DVec2) -> glam::DVec3 {
    let (u, v) = (2.0 * p.x - 1.0, 2.0 * p.y - 1.0);
    let (up, vp) = (u.abs(), v.abs());
    let signed = 1.0 - (up + vp);
    let r = 1.0 - signed.abs();
    let phi = if r == 0.0 { 1.0 } else { (vp - up) / r + 1.0 } * std::f64::consts::FRAC_PI_4;
    let z = (1.0 - r * r).copysign(signed);
    let s = r * (2.0 - r * r).max(0.0).sqrt();
    glam::DVec3::new(phi.cos().copysign(u) * s, phi.sin().copysign(v) * s, z)
}

/// The inverse of [`equal_area_square_to_sphere`] for a unit `d`.
pub fn equal_area_sphere_to_square(d: glam::DVec3) -> glam::DVec2 {
    let (x, y, z) = (d.x.abs(), d.y.abs(), d.z.abs());
    let r = (1.0 - z).max(0.0).sqrt();
    let (a, b) = (x.max(y), x.min(y));
    let t = if a == 0.0 { 0.0 } else { b / a };
    let mut phi = t.atan() * std::f64::consts::FRAC_2_PI;
    if x < y {
        phi = 1.0 - phi;
    }
    let mut v = phi * r;
    let mut u = r - v;
    if d.z < 0.0 {
        std::mem::swap(&mut u, &mut v);
        u = 1.0 - u;
        v = 1.0 - v;
    }
    glam::DVec2::new(0.5 * (u.copysign(d.x) + 1.0), 0.5 * (v.copysign(d.y) + 1.0))
}

/// pbrt-v4's image infinite light, an equal-area octahedral `map` (square;
/// row 0 at `v = 0`), resampled into this module's equirectangular layout
/// (`2n` by `n + 1` texels for an `n`-texel map): each texel reads the map
/// bilinearly (clamped at its edges) at the direction `to_map` takes its
/// direction to. Resampling blurs features at the texel scale; the
/// total radiance is kept to that accuracy.
pub fn from_equal_area(
    map: &ImageTexture,
    to_map: impl Fn(Vec3) -> glam::DVec3,
) -> Result<ImageTexture> {
    let n = map.width();
    if map.height() != n {
        return Err(Error::Settings(format!(
            "an equal-area octahedral map must be square, got {} x {}",
            map.width(),
            map.height()
        )));
    }
    let (w, h) = (2 * n, n + 1);
    let lookup = |p: glam::DVec2| {
        let x = (p.x * n as f64 - 0.5).clamp(0.0, (n - 1) as f64);
        let y = (p.y * n as f64 - 0.5).clamp(0.0, (n - 1) as f64);
        let (ix, iy) = ((x as u32).min(n - 1), (y as u32).min(n - 1));
        let (ix1, iy1) = ((ix + 1).min(n - 1), (iy + 1).min(n - 1));
        let (fx, fy) = ((x - ix as f64) as f32, (y - iy as f64) as f32);
        let t = |x, y| map.texel(x, y);
        let top = (1.0 - fx) * t(ix, iy) + fx * t(ix1, iy);
        let bottom = (1.0 - fx) * t(ix, iy1) + fx * t(ix1, iy1);
        (1.0 - fy) * top + fy * bottom
    };
    let mut rgb = Vec::with_capacity((w * h * 3) as usize);
    for j in 0..h {
        for i in 0..w {
            let d = uv_to_direction(Vec2::new(i as f32 / w as f32, j as f32 / (h - 1) as f32));
            let m = to_map(d).normalize_or_zero();
            rgb.extend_from_slice(&lookup(equal_area_sphere_to_square(m)).to_array());
        }
    }
    ImageTexture::from_linear_rgb(w, h, rgb)
}

impl EnvironmentMap {
    /// The environment of `file` (an image [`ImageTexture::load`] reads),
    /// scaled by `radiance`.
    pub fn load(file: &Path, radiance: Vec3) -> Result<Self> {
        let map = ImageTexture::load(file)?;
        Self::new(map, radiance).map_err(|e| match e {
            Error::Settings(message) => Error::input(file, None, message),
            other => other,
        })
    }

    /// The environment of image `map` scaled by `radiance` (finite, `>= 0`).
    /// The map needs at least 2 rows: the first and last sit on the poles.
    pub fn new(map: ImageTexture, radiance: Vec3) -> Result<Self> {
        if map.height() < 2 {
            return Err(Error::Settings(format!(
                "an environment map is {} x {} texels: expected at least 2 rows (one per pole)",
                map.width(),
                map.height()
            )));
        }
        if !radiance.is_finite() || radiance.min_element() < 0.0 {
            return Err(Error::Settings(format!(
                "environment radiance {radiance}: expected finite values >= 0"
            )));
        }
        let (w, h) = (map.width() as usize, map.height() as usize);
        let lum: Vec<f64> = map
            .texels()
            .iter()
            .map(|&t| luminance(radiance * t).max(0.0) as f64)
            .collect();
        let band = |i: usize| {
            let t0 = std::f64::consts::PI * i as f64 / (h - 1) as f64;
            let t1 = std::f64::consts::PI * (i + 1) as f64 / (h - 1) as f64;
            (t0, t1)
        };
        // Each texel's weight is its luminance times the mean of sin theta
        // over the half bands of latitude on either side of its row, which
        // is sin theta at the row but for the terms of order (pi / h)^2 and
        // positive on the poles' rows too (Mitsuba 3 weighs by sin theta at
        // the row, zero there), so the density is positive wherever the
        // radiance is.
        let half = 0.5 * std::f64::consts::PI / (h - 1) as f64;
        let weights: Vec<f32> = (0..h)
            .flat_map(|r| {
                let t = std::f64::consts::PI * r as f64 / (h - 1) as f64;
                let (a, b) = ((t - half).max(0.0), (t + half).min(std::f64::consts::PI));
                let mean_sin = (a.cos() - b.cos()) / (b - a);
                lum[r * w..(r + 1) * w]
                    .iter()
                    .map(move |&l| (l * mean_sin) as f32)
            })
            .collect();
        let distribution = if constant_patch_divergence(&weights, w, h) > BILINEAR_ABOVE {
            Density::Bilinear(PeriodicBilinear2D::new(&weights, w, h))
        } else {
            // each patch the mean of its corners: the bilinear density's
            // mass per patch, spread evenly
            let at = |i: usize, r: usize| weights[r * w + i % w];
            let patches: Vec<f32> = (0..h - 1)
                .flat_map(|j| {
                    (0..w).map(move |i| {
                        0.25 * (at(i, j) + at(i + 1, j) + at(i, j + 1) + at(i + 1, j + 1))
                    })
                })
                .collect();
            Density::Constant(PiecewiseConstant2D::new(&patches, w, h - 1))
        };

        // The exact integral of the bilinear radiance over the sphere: along u
        // a periodic piecewise-linear function integrates to the mean of its
        // nodes; along theta, the linear ramp between two rows against
        // sin theta integrates in closed form.
        let row_mean = |i: usize| lum[i * w..(i + 1) * w].iter().sum::<f64>() / w as f64;
        let mut integral = 0.0;
        for i in 0..h - 1 {
            let (t0, t1) = band(i);
            let w1 = (t1.sin() - t0.sin()) / (t1 - t0) - t1.cos();
            let w0 = (t0.cos() - t1.cos()) - w1;
            integral += w0 * row_mean(i) + w1 * row_mean(i + 1);
        }
        Ok(EnvironmentMap {
            map,
            radiance,
            distribution,
            luminance_integral: 2.0 * std::f64::consts::PI * integral,
        })
    }

    /// The image.
    pub fn map(&self) -> &ImageTexture {
        &self.map
    }

    /// The scale applied to the image.
    pub fn radiance(&self) -> Vec3 {
        self.radiance
    }

    /// The radiance at map coordinates `uv` (Mitsuba's bilinear lookup).
    pub fn eval_uv(&self, uv: Vec2) -> Vec3 {
        if !uv.is_finite() {
            return Vec3::ZERO;
        }
        self.eval_patch(self.patch_coords(uv))
    }

    /// The radiance at patch coordinates `p` (finite; see
    /// [`EnvironmentMap::patch_coords`]).
    #[inline]
    fn eval_patch(&self, p: Vec2) -> Vec3 {
        let (w, h) = (self.map.width(), self.map.height());
        let x = p.x * w as f32;
        let y = p.y.clamp(0.0, 1.0) * (h - 1) as f32;
        let ix = (x as u32).min(w - 1);
        let iy = (y as u32).min(h - 2);
        let (fx, fy) = (x - ix as f32, y - iy as f32);
        let ix1 = if ix + 1 == w { 0 } else { ix + 1 };
        let t = |x, y| self.map.texel(x, y);
        let top = (1.0 - fx) * t(ix, iy) + fx * t(ix1, iy);
        let bottom = (1.0 - fx) * t(ix, iy + 1) + fx * t(ix1, iy + 1);
        self.radiance * ((1.0 - fy) * top + fy * bottom)
    }

    /// Radiance arriving from direction `wi` (unit, towards the sky).
    #[inline]
    pub fn eval(&self, wi: Vec3) -> Vec3 {
        self.eval_uv(direction_to_uv(wi))
    }

    /// Solid-angle density with which [`EnvironmentMap::sample`] produces
    /// `wi` (0 at the poles, where the map's Jacobian vanishes, and where the
    /// radiance is zero).
    pub fn pdf(&self, wi: Vec3) -> f32 {
        self.pdf_at(wi, direction_to_uv(wi))
    }

    /// [`EnvironmentMap::eval`] and [`EnvironmentMap::pdf`] together, with
    /// one conversion of `wi` to map coordinates (an `atan2` and an `acos`).
    #[inline]
    pub fn eval_and_pdf(&self, wi: Vec3) -> (Vec3, f32) {
        let uv = direction_to_uv(wi);
        (self.eval_uv(uv), self.pdf_at(wi, uv))
    }

    /// The density of `wi`, whose map coordinates are `uv`.
    fn pdf_at(&self, wi: Vec3, uv: Vec2) -> f32 {
        if !(self.luminance_integral > 0.0) {
            return 0.0;
        }
        let sin_theta = (wi.x * wi.x + wi.z * wi.z).sqrt();
        if !(sin_theta > 0.0) {
            return 0.0;
        }
        let pdf_uv = self.distribution.pdf(self.patch_coords(uv));
        pdf_uv / (2.0 * PI * PI * sin_theta)
    }

    /// A direction for `u` in `[0, 1]^2`, or `None` when the map is black or
    /// the point fell on a pole (where the density is not finite).
    ///
    /// The density and the radiance are those at the point drawn, not at
    /// `wi` converted back to map coordinates: that round trip (an `atan2`,
    /// an `acos` and the density again) cost 3 % of a `materials` render's
    /// instructions. They equal [`EnvironmentMap::pdf`] and
    /// [`EnvironmentMap::eval`] at `wi` up to the rounding of the direction
    /// (a few ulps in the map coordinates), so multiple importance
    /// sampling's weights still sum to one but for that rounding; and the
    /// radiance is read in the patch the density chose, never in a black
    /// neighbour across its edge.
    pub fn sample(&self, u: Vec2) -> Option<EnvironmentSample> {
        if !(self.luminance_integral > 0.0) {
            return None;
        }
        let (p, pdf_patch) = self.distribution.sample(u);
        let mut su = p.x + 0.5 / self.map.width() as f32;
        if su >= 1.0 {
            su -= 1.0;
        }
        let (wi, sin_theta) = direction_and_sine(Vec2::new(su, p.y));
        let pdf = pdf_patch / (2.0 * PI * PI * sin_theta);
        if !(pdf > 0.0) || !pdf.is_finite() {
            return None;
        }
        Some(EnvironmentSample {
            wi,
            li: self.eval_patch(p),
            pdf,
        })
    }

    /// Whether the map samples the bilinear density (else the constant one
    /// per patch; see [`BILINEAR_ABOVE`]).
    pub fn samples_bilinear_density(&self) -> bool {
        matches!(self.distribution, Density::Bilinear(_))
    }

    /// The integral over the sphere of the luminance of the (scaled) map,
    /// `int L dw`; `4 pi L` for a constant map of luminance `L`.
    pub fn luminance_integral(&self) -> f64 {
        self.luminance_integral
    }

    /// Power for light selection, for a scene whose bounding sphere has
    /// radius `scene_radius`: `pi r^2 * (int L dw) / 4`. For a constant map of
    /// luminance `L` that is `pi^2 r^2 L`, the power the uniform environment
    /// gets in [`crate::integrator::Lights`], so both kinds weigh the same when they
    /// shine the same.
    pub fn power(&self, scene_radius: f32) -> f64 {
        let r = scene_radius as f64;
        std::f64::consts::PI * r * r * self.luminance_integral / 4.0
    }

    /// Distribution coordinates (patch space) of map coordinates `uv`.
    #[inline]
    fn patch_coords(&self, uv: Vec2) -> Vec2 {
        let mut x = uv.x - 0.5 / self.map.width() as f32;
        x -= crate::math::floor(x);
        if x >= 1.0 {
            x = 0.0;
        }
        Vec2::new(x, uv.y)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The mapping and its inverse agree, the centre is `+z`, and equal
    /// areas of the square cover equal solid angles (a uniform grid's
    /// directions have the sphere's moments: mean 0, `E[z^2] = 1/3`).
    #[test]
    fn equal_area_mapping_round_trips_and_keeps_area() {
        let c = equal_area_square_to_sphere(glam::DVec2::new(0.5, 0.5));
        assert!((c - glam::DVec3::Z).length() < 1e-12, "{c}");
        let n = 400;
        let (mut mean, mut z2) = (glam::DVec3::ZERO, 0.0);
        for i in 0..n {
            for j in 0..n {
                let p = glam::DVec2::new((i as f64 + 0.5) / n as f64, (j as f64 + 0.5) / n as f64);
                let d = equal_area_square_to_sphere(p);
                assert!((d.length() - 1.0).abs() < 1e-12);
                let q = equal_area_sphere_to_square(d);
                assert!((q - p).length() < 1e-9, "{p} -> {d} -> {q}");
                mean += d;
                z2 += d.z * d.z;
            }
        }
        let m = (n * n) as f64;
        assert!((mean / m).length() < 1e-3, "{}", mean / m);
        assert!((z2 / m - 1.0 / 3.0).abs() < 1e-3, "{}", z2 / m);
    }

    /// A map that is bright in one octant only lights the directions of
    /// that octant after resampling.
    #[test]
    fn an_octahedral_map_resamples_to_its_directions() {
        let n = 32;
        let mut rgb = Vec::new();
        for y in 0..n {
            for x in 0..n {
                // the square's top-left quadrant: x < 0, y < 0 on the sphere
                let on = x < n / 2 - 1 && y < n / 2 - 1 && x + y > 2;
                rgb.extend_from_slice(&[if on { 1.0 } else { 0.0 }; 3]);
            }
        }
        let map = ImageTexture::from_linear_rgb(n, n, rgb).unwrap();
        let eq = from_equal_area(&map, |d| d.as_dvec3()).unwrap();
        let env = EnvironmentMap::new(eq, Vec3::ONE).unwrap();
        let dir = |x: f32, y: f32, z: f32| Vec3::new(x, y, z).normalize();
        assert!(env.eval(dir(-1.0, -1.0, 0.5)).x > 0.9);
        assert_eq!(env.eval(dir(1.0, 1.0, 0.5)).x, 0.0);
        assert_eq!(env.eval(dir(1.0, -1.0, 0.5)).x, 0.0);
        let flat = ImageTexture::from_linear_rgb(4, 4, vec![0.25; 48]).unwrap();
        let eq = from_equal_area(&flat, |d| d.as_dvec3()).unwrap();
        assert!(eq.texels().iter().all(|t| *t == Vec3::splat(0.25)));
        let rect = ImageTexture::from_linear_rgb(4, 2, vec![0.25; 24]).unwrap();
        assert!(from_equal_area(&rect, |d| d.as_dvec3()).is_err());
    }
    use crate::sampler::Sampler;

    /// 0, 2^-149, 0.5, the largest f32 below 1, and 1 (hard case 14).
    const EXTREMES: [f32; 5] = [0.0, 1.4e-45, 0.5, 1.0 - 5.96e-8, 1.0];

    fn map(w: u32, h: u32, f: impl Fn(u32, u32) -> Vec3) -> ImageTexture {
        let mut rgb = Vec::new();
        for y in 0..h {
            for x in 0..w {
                rgb.extend(f(x, y).to_array());
            }
        }
        ImageTexture::from_linear_rgb(w, h, rgb).unwrap()
    }

    /// A lumpy map: a bright spot, a gradient, and black bottom rows.
    fn lumpy() -> EnvironmentMap {
        let m = map(24, 13, |x, y| {
            if y >= 10 {
                Vec3::ZERO
            } else if (x, y) == (5, 3) {
                Vec3::new(80.0, 60.0, 40.0)
            } else {
                Vec3::new(0.1 + 0.05 * x as f32, 0.2, 0.05 + 0.1 * y as f32)
            }
        });
        EnvironmentMap::new(m, Vec3::new(1.0, 0.5, 2.0)).unwrap()
    }

    #[test]
    fn mitsuba_axes_convention() {
        let uv = |d: Vec3| direction_to_uv(d);
        assert_eq!(uv(-Vec3::Z), Vec2::new(0.0, 0.5));
        assert_eq!(uv(Vec3::X), Vec2::new(0.25, 0.5));
        assert_eq!(uv(Vec3::Z), Vec2::new(0.5, 0.5));
        assert_eq!(uv(-Vec3::X), Vec2::new(0.75, 0.5));
        assert_eq!(uv(Vec3::Y), Vec2::ZERO);
        assert_eq!(uv(Vec3::new(-0.0, 1.0, -0.0)), Vec2::ZERO);
        assert_eq!(uv(-Vec3::Y).y, 1.0);
        let mut s = Sampler::new(11, 0, 0);
        for _ in 0..10_000 {
            let p = s.next_2d();
            let d = uv_to_direction(p);
            assert!((d.length() - 1.0).abs() < 1e-6);
            let q = direction_to_uv(d);
            let du = (q.x - p.x).abs().min(1.0 - (q.x - p.x).abs());
            // acos loses precision near the poles: 1e-3 in v there, 1e-5 elsewhere
            let tol = if p.y < 0.01 || p.y > 0.99 { 1e-3 } else { 1e-5 };
            assert!((q.y - p.y).abs() < tol, "{p:?} -> {q:?}");
            if p.y > 0.01 && p.y < 0.99 {
                assert!(du < 1e-5, "{p:?} -> {q:?}");
            }
        }
    }

    #[test]
    fn lookup_is_bilinear_on_mitsubas_grid() {
        // 4 x 3: red = column + 1, green = 10 (row + 1)
        let env = EnvironmentMap::new(
            map(4, 3, |x, y| {
                Vec3::new(1.0 + x as f32, 10.0 * (1 + y) as f32, 1.0)
            }),
            Vec3::new(1.0, 1.0, 2.0),
        )
        .unwrap();
        let at = |u: f32, v: f32| env.eval_uv(Vec2::new(u, v));
        // columns at texel centres, rows at v = 0, 0.5, 1
        assert_eq!(at(0.125, 0.0), Vec3::new(1.0, 10.0, 2.0));
        assert_eq!(at(0.375, 0.5), Vec3::new(2.0, 20.0, 2.0));
        assert_eq!(at(0.875, 1.0), Vec3::new(4.0, 30.0, 2.0));
        // between rows and columns; u = 0 wraps between the last and first column
        assert_eq!(at(0.25, 0.25), Vec3::new(1.5, 15.0, 2.0));
        assert_eq!(at(0.0, 0.75), Vec3::new(2.5, 25.0, 2.0));
    }

    #[test]
    fn constant_map_has_constant_radiance_and_the_uniform_power() {
        let l = Vec3::new(0.5, 1.0, 2.0);
        let env = EnvironmentMap::new(map(8, 5, |_, _| Vec3::ONE), l).unwrap();
        let mut s = Sampler::new(12, 0, 0);
        for _ in 0..1000 {
            let d = uv_to_direction(s.next_2d());
            assert!((env.eval(d) - l).abs().max_element() < 1e-6);
        }
        let lum = luminance(l) as f64;
        let rel = |a: f64, b: f64| (a - b).abs() / b;
        // closed-form sums in f64: 1e-12 relative
        assert!(rel(env.luminance_integral(), 4.0 * std::f64::consts::PI * lum) < 1e-12);
        // the uniform environment's power in Lights::new: pi^2 r^2 L (f32)
        let r = 3.5f32;
        assert!(rel(env.power(r), (PI * PI * r * r * luminance(l)) as f64) < 1e-6);
    }

    #[test]
    fn luminance_integral_matches_quadrature() {
        let env = lumpy();
        // midpoint rule in (theta, phi) on a grid 40x finer than the map:
        // the radiance is continuous and piecewise bilinear, error ~1e-5
        let (nt, np) = (520usize, 960usize);
        let mut sum = 0.0f64;
        for i in 0..nt {
            let v = (i as f64 + 0.5) / nt as f64;
            let sin_t = (std::f64::consts::PI * v).sin();
            for j in 0..np {
                let u = (j as f64 + 0.5) / np as f64;
                let d = uv_to_direction(Vec2::new(u as f32, v as f32));
                sum += luminance(env.eval(d)) as f64 * sin_t;
            }
        }
        let quad = sum * 2.0 * std::f64::consts::PI * std::f64::consts::PI / (nt * np) as f64;
        let exact = env.luminance_integral();
        assert!((quad - exact).abs() < 1e-4 * exact, "{quad} vs {exact}");
    }

    #[test]
    fn density_integrates_to_one_and_vanishes_where_the_map_is_black() {
        let env = lumpy();
        // pdf_dir dw = pdf_uv du dv; pdf_uv is bilinear in each patch, so
        // the midpoint rule on a grid 4x finer than the patches (offset by
        // the half-texel shift) integrates it exactly
        let (w, h) = (24usize, 13usize);
        let (nx, ny) = (4 * w, 4 * (h - 1));
        let mut total = 0.0f64;
        for i in 0..ny {
            let v = (i as f32 + 0.5) / ny as f32;
            for j in 0..nx {
                let u = ((j as f32 + 0.5) / nx as f32 + 0.5 / w as f32).fract();
                let d = uv_to_direction(Vec2::new(u, v));
                let sin_t = (d.x * d.x + d.z * d.z).sqrt() as f64;
                let pdf_uv = env.pdf(d) as f64 * 2.0 * std::f64::consts::PI.powi(2) * sin_t;
                total += pdf_uv / (nx * ny) as f64;
                // rows 10.. are black: patches below row 10 have no density
                if v > 10.0 / 12.0 {
                    assert_eq!(env.pdf(d), 0.0, "v = {v}");
                    assert_eq!(env.eval(d), Vec3::ZERO);
                }
            }
        }
        // f32 pdf values summed in f64: 1e-5
        assert!((total - 1.0).abs() < 1e-5, "{total}");
    }

    #[test]
    fn samples_agree_with_eval_and_pdf() {
        let env = lumpy();
        assert!(env.samples_bilinear_density());
        samples_agree(&env);
        // a smooth map with black rows: the constant density per patch
        let smooth = EnvironmentMap::new(
            map(48, 25, |x, y| {
                if y >= 20 {
                    Vec3::ZERO
                } else {
                    Vec3::new(0.5 + 0.01 * y as f32, 0.4 + 0.002 * x as f32, 0.3)
                }
            }),
            Vec3::ONE,
        )
        .unwrap();
        assert!(!smooth.samples_bilinear_density());
        samples_agree(&smooth);
    }

    fn samples_agree(env: &EnvironmentMap) {
        let mut s = Sampler::new(13, 0, 0);
        let mut us: Vec<Vec2> = Vec::new();
        for &a in &EXTREMES {
            for &b in &EXTREMES {
                us.push(Vec2::new(a, b));
            }
        }
        let extremes = us.len();
        us.extend((0..200_000).map(|_| s.next_2d()));
        let (mut rejected, mut stepped) = (0, 0);
        let scale = env.radiance.max_element()
            * env
                .map
                .texels()
                .iter()
                .map(|t| t.max_element())
                .fold(0.0, f32::max);
        for (k, u) in us.into_iter().enumerate() {
            let Some(x) = env.sample(u) else {
                // only at the poles, where sin theta rounds to 0: v = 0 and
                // 1, and the smallest v, whose direction's sine underflows
                assert!(k < extremes && [0.0, 1.4e-45, 1.0].contains(&u.y), "{u:?}");
                rejected += 1;
                continue;
            };
            assert!(
                x.wi.is_finite() && (x.wi.length() - 1.0).abs() < 1e-5,
                "{u:?}"
            );
            assert!(x.pdf > 0.0 && x.pdf.is_finite(), "{u:?}: pdf {}", x.pdf);
            // the density and radiance at the point drawn, against those at
            // the direction (its map coordinates computed anew, where the
            // acos's rounding near the poles moves the density by up to
            // 2.4e-4 of itself): equal but for that rounding, except where
            // a constant density steps across a patch edge the rounding
            // crossed
            let (pdf, li) = (env.pdf(x.wi), env.eval(x.wi));
            assert!(
                (x.li - li).abs().max_element() <= 1e-4 * scale,
                "{u:?}: radiance {} at the point drawn, {li} at {:?}",
                x.li,
                x.wi
            );
            if (x.pdf - pdf).abs() > 1e-3 * pdf {
                assert!(
                    !env.samples_bilinear_density(),
                    "{u:?}: pdf {} against {pdf}",
                    x.pdf
                );
                stepped += 1;
            }
            // importance: never a direction where the map is black. The
            // extreme numbers land on patch edges, where rounding may read
            // the black row beyond the edge: the radiance
            // there is 0 (it is continuous), so that costs nothing.
            if k >= extremes {
                assert!(
                    x.li.max_element() > 0.0,
                    "{u:?} sampled black at {:?}",
                    x.wi
                );
            }
        }
        assert!(rejected <= 15, "{rejected} rejected");
        // a sample within a few ulps of a patch edge: a few in a million
        assert!(stepped <= 20, "{stepped} densities across a patch edge");
    }

    #[test]
    fn black_maps_and_bad_input() {
        let black = EnvironmentMap::new(map(4, 2, |_, _| Vec3::ZERO), Vec3::ONE).unwrap();
        assert_eq!(black.luminance_integral(), 0.0);
        assert_eq!(black.power(1.0), 0.0);
        assert!(black.sample(Vec2::splat(0.5)).is_none());
        assert_eq!(black.pdf(Vec3::X), 0.0);
        let scaled_off = EnvironmentMap::new(map(4, 2, |_, _| Vec3::ONE), Vec3::ZERO).unwrap();
        assert!(scaled_off.sample(Vec2::splat(0.5)).is_none());
        assert!(EnvironmentMap::new(map(4, 1, |_, _| Vec3::ONE), Vec3::ONE).is_err());
        assert!(
            EnvironmentMap::new(map(4, 2, |_, _| Vec3::ONE), Vec3::new(-1.0, 0.0, 0.0)).is_err()
        );
        let e = EnvironmentMap::load(Path::new("/nonexistent/sky.exr"), Vec3::ONE)
            .unwrap_err()
            .to_string();
        assert!(e.contains("sky.exr") && !e.contains('\n'), "{e}");
    }
}
