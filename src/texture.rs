//! RGB image textures: loading, colour decoding and filtered lookup.
//!
//! Files: PNG (8 or 16 bits per channel, grey or colour; alpha is ignored) is
//! taken to be sRGB-encoded and decoded to linear RGB with the exact sRGB
//! transfer function (IEC 61966-2-1: `c / 12.92` up to 0.04045, else
//! `((c + 0.055) / 1.055)^2.4`), unless it is loaded *raw*
//! ([`ImageTexture::load_as`]), as Mitsuba's `bitmap` with `raw = true`: its
//! stored values scaled to `[0, 1]` and nothing more (for data that is not a
//! colour: roughness, normal and bump maps). OpenEXR is linear already and is read as it
//! is (the R, G and B channels of its first layer). The format is chosen by the
//! file's extension; anything else is an error, as are files that do not
//! decode, images of zero size, and texels that are not finite or negative.
//!
//! Coordinates (pbrt-v4 section 10.4, `ImageTexture`, which flips `t` the same
//! way): `(u, v)` is a texture coordinate as OBJ files store it, `v` pointing
//! up, while an image stores its top row first. So `u = 0` is the left edge of
//! the image, `v = 0` its bottom edge and `v = 1` its top edge: texel `(x, y)`
//! (row `y = 0` at the top) has its centre at `((x + 0.5) / w, 1 - (y + 0.5) / h)`.
//! Lookup is bilinear between the four nearest texel centres, with wrap
//! (repeat) addressing in both `u` and `v`, so a texture tiles the plane. An
//! image whose texels are all equal returns that texel exactly (bilinear
//! weights need not sum to exactly 1 in `f32`), so a constant texture gives
//! the same bits as the constant.
//!
//! A scalar parameter (roughness) reads [`ImageTexture::eval_scalar`]: the
//! value of a grey image, otherwise the luminance of the colour, as Mitsuba's
//! `bitmap` answers `eval_1` on an RGB image.

use crate::error::{Error, Result};
use crate::image::{read_exr, read_hdr, read_jpeg_as, read_png_as, read_png_opacity};
use crate::math::{Vec2, Vec3, luminance};
use std::path::{Path, PathBuf};

/// A linear-RGB image, row 0 at the top.
#[derive(Debug, Clone)]
pub struct ImageTexture {
    width: u32,
    height: u32,
    texels: Vec<Vec3>,
    /// The file it was read from, if any.
    source: Option<PathBuf>,
    /// A PNG read without sRGB decoding.
    raw: bool,
    /// The mean texel.
    mean: Vec3,
    /// The texel, when every texel is the same.
    uniform: Option<Vec3>,
    /// Every texel has three equal channels.
    grey: bool,
}

/// Two textures are equal when their texels are, wherever they were read.
impl PartialEq for ImageTexture {
    fn eq(&self, other: &Self) -> bool {
        (self.width, self.height) == (other.width, other.height) && self.texels == other.texels
    }
}

/// The image files a texture or environment map is read from, as errors
/// name them.
const FORMATS: &str = "a .png or .jpg (sRGB) or an .exr or .hdr (linear) image";

impl ImageTexture {
    /// Load a texture from a `.png` or `.jpg`/`.jpeg` (sRGB) or an `.exr`
    /// or `.hdr` (linear) file.
    pub fn load(path: &Path) -> Result<Self> {
        Self::load_as(path, false)
    }

    /// Load a texture; with `raw`, a PNG's or JPEG's values are taken as
    /// they are (linear) instead of decoded from sRGB. EXR and Radiance HDR
    /// are linear either way.
    pub fn load_as(path: &Path, raw: bool) -> Result<Self> {
        if path.is_dir() {
            return Err(Error::input(
                path,
                None,
                format!("is a directory, expected {FORMATS}"),
            ));
        }
        let ext = path
            .extension()
            .and_then(|e| e.to_str())
            .map(str::to_ascii_lowercase);
        let (width, height, rgb) = match ext.as_deref() {
            Some("png") => read_png_as(path, raw)?,
            Some("jpg" | "jpeg") => read_jpeg_as(path, raw)?,
            Some("exr") => read_exr(path)?,
            Some("hdr") => read_hdr(path)?,
            _ => {
                return Err(Error::input(
                    path,
                    None,
                    format!("unsupported texture format: expected {FORMATS}"),
                ));
            }
        };
        Self::from_file(path, width, height, rgb, raw)
    }

    /// An opacity texture (an alpha mask): a PNG's alpha channel when it
    /// has one, otherwise its values read raw; an EXR's R, G and B (read as
    /// a scalar by [`ImageTexture::eval_scalar`]).
    pub fn load_opacity(path: &Path) -> Result<Self> {
        let is_png = path
            .extension()
            .and_then(|e| e.to_str())
            .is_some_and(|e| e.eq_ignore_ascii_case("png"));
        if !is_png || path.is_dir() {
            return Self::load_as(path, true);
        }
        let (width, height, rgb) = read_png_opacity(path)?;
        Self::from_file(path, width, height, rgb, true)
    }

    /// The texture of the texels read from `path`, which errors name.
    fn from_file(path: &Path, width: u32, height: u32, rgb: Vec<f32>, raw: bool) -> Result<Self> {
        let texture = Self::from_linear_rgb(width, height, rgb).map_err(|e| match e {
            Error::Settings(message) => Error::input(path, None, message),
            other => other,
        })?;
        Ok(ImageTexture {
            source: Some(path.to_path_buf()),
            raw,
            ..texture
        })
    }

    /// A texture from linear RGB values, 3 per texel, row-major with the top
    /// row first.
    pub fn from_linear_rgb(width: u32, height: u32, rgb: Vec<f32>) -> Result<Self> {
        if width == 0 || height == 0 {
            return Err(Error::Settings(format!(
                "the image is {width} x {height} texels: expected at least one"
            )));
        }
        let n = width as usize * height as usize;
        if rgb.len() != 3 * n {
            return Err(Error::Settings(format!(
                "{} values for {width} x {height} RGB texels: expected {}",
                rgb.len(),
                3 * n
            )));
        }
        let mut texels = Vec::with_capacity(n);
        for (i, c) in rgb.chunks_exact(3).enumerate() {
            let t = Vec3::new(c[0], c[1], c[2]);
            if !t.is_finite() || t.min_element() < 0.0 {
                let (x, y) = (i % width as usize, i / width as usize);
                return Err(Error::Settings(format!(
                    "texel ({x}, {y}) is ({}, {}, {}): expected finite values >= 0",
                    c[0], c[1], c[2]
                )));
            }
            texels.push(t);
        }
        let sum = texels
            .iter()
            .fold(crate::math::DVec3::ZERO, |s, t| s + t.as_dvec3());
        let mean = (sum / n as f64).as_vec3();
        let uniform = texels.iter().all(|t| *t == texels[0]).then_some(texels[0]);
        let grey = texels.iter().all(|t| t.x == t.y && t.y == t.z);
        Ok(ImageTexture {
            width,
            height,
            texels,
            source: None,
            raw: false,
            mean,
            uniform,
            grey,
        })
    }

    /// Whether a PNG was read raw (not decoded from sRGB).
    pub fn is_raw(&self) -> bool {
        self.raw
    }

    /// The mean of the texels (an emission texture's power uses it).
    pub fn mean(&self) -> Vec3 {
        self.mean
    }

    /// The file the texture was read from (`None` for one made in code).
    pub fn source(&self) -> Option<&Path> {
        self.source.as_deref()
    }

    /// Width in texels.
    pub fn width(&self) -> u32 {
        self.width
    }

    /// Height in texels.
    pub fn height(&self) -> u32 {
        self.height
    }

    /// The texels, row-major, top row first.
    pub fn texels(&self) -> &[Vec3] {
        &self.texels
    }

    /// Texel `(x, y)`, row 0 at the top.
    ///
    /// # Panics
    /// If `x >= width` or `y >= height`.
    #[inline]
    pub fn texel(&self, x: u32, y: u32) -> Vec3 {
        assert!(
            x < self.width && y < self.height,
            "texel ({x}, {y}) outside"
        );
        self.texels[y as usize * self.width as usize + x as usize]
    }

    /// Texel `(x, y)` with both indices wrapped onto the image.
    #[inline]
    pub fn texel_wrapped(&self, x: i64, y: i64) -> Vec3 {
        let x = wrap(x, self.width as usize);
        let y = wrap(y, self.height as usize);
        self.texels[y * self.width as usize + x]
    }

    /// The colour at texture coordinate `uv` (`v` up), bilinear with wrap
    /// addressing. A non-finite coordinate gives black.
    pub fn eval(&self, uv: Vec2) -> Vec3 {
        if !uv.is_finite() {
            return Vec3::ZERO;
        }
        if let Some(c) = self.uniform {
            return c;
        }
        let Cell {
            x0,
            y0,
            x1,
            y1,
            fx,
            fy,
        } = self.cell(uv);
        let w = self.width as usize;
        let texel = |x: usize, y: usize| self.texels[y * w + x];
        let (a, b) = (texel(x0, y0), texel(x1, y0));
        let (c, d) = (texel(x0, y1), texel(x1, y1));
        (1.0 - fy) * ((1.0 - fx) * a + fx * b) + fy * ((1.0 - fx) * c + fx * d)
    }

    /// The largest [`ImageTexture::eval_scalar`] of any texel (a bilinear
    /// lookup never exceeds it).
    pub fn max_scalar(&self) -> f32 {
        self.texels
            .iter()
            .map(|&c| self.scalar(c))
            .fold(0.0, f32::max)
    }

    /// The smallest value [`ImageTexture::eval_scalar`] can return (bilinear
    /// lookup stays within the texels' range).
    pub fn min_scalar(&self) -> f32 {
        self.texels
            .iter()
            .map(|&c| self.scalar(c))
            .fold(f32::INFINITY, f32::min)
    }

    /// A texel's scalar: its grey value in a grey image, otherwise its
    /// luminance.
    #[inline]
    fn scalar(&self, c: Vec3) -> f32 {
        if self.grey { c.x } else { luminance(c) }
    }

    /// The gradient `(d/du, d/dv)` at `uv` of [`ImageTexture::eval_scalar`]
    /// (a bump map's slope): the derivative of the bilinear interpolant, so
    /// within a cell the difference of neighbouring texels along one axis,
    /// weighted by the other axis' bilinear weights, times the resolution
    /// (as Mitsuba 3's `bitmap` computes `eval_1_grad`). `v` points up
    /// while rows go down, hence the sign of `d/dv`. Zero for a non-finite
    /// coordinate and for a uniform texture.
    pub fn eval_scalar_grad(&self, uv: Vec2) -> Vec2 {
        if !uv.is_finite() || self.uniform.is_some() {
            return Vec2::ZERO;
        }
        let Cell {
            x0,
            y0,
            x1,
            y1,
            fx,
            fy,
        } = self.cell(uv);
        let (w, h) = (self.width as usize, self.height as usize);
        let f = |x: usize, y: usize| self.scalar(self.texels[y * w + x]);
        let (a, b) = (f(x0, y0), f(x1, y0));
        let (c, d) = (f(x0, y1), f(x1, y1));
        let ds = (1.0 - fy) * (b - a) + fy * (d - c);
        let dt = (1.0 - fx) * (c - a) + fx * (d - b);
        Vec2::new(ds * w as f32, -dt * h as f32)
    }

    /// The bilinear cell around `uv`: continuous texel coordinates with
    /// texel centres at integers, its corner texels wrapped once each
    /// ([`wrap`]; the neighbours from those) and the weights within it.
    #[inline(always)]
    fn cell(&self, uv: Vec2) -> Cell {
        let s = uv.x as f64 * self.width as f64 - 0.5;
        let t = (1.0 - uv.y as f64) * self.height as f64 - 0.5;
        let (x0, y0) = (crate::math::floor_f64(s), crate::math::floor_f64(t));
        let (fx, fy) = ((s - x0) as f32, (t - y0) as f32);
        let (w, h) = (self.width as usize, self.height as usize);
        let x0 = wrap(x0 as i64, w);
        let y0 = wrap(y0 as i64, h);
        let x1 = if x0 + 1 == w { 0 } else { x0 + 1 };
        let y1 = if y0 + 1 == h { 0 } else { y0 + 1 };
        Cell {
            x0,
            y0,
            x1,
            y1,
            fx,
            fy,
        }
    }

    /// A scalar at `uv`: the grey value of a grey image, otherwise the
    /// luminance of [`ImageTexture::eval`].
    pub fn eval_scalar(&self, uv: Vec2) -> f32 {
        self.scalar(self.eval(uv))
    }
}

/// `i` wrapped onto `0..n` (`rem_euclid`), without a division for the
/// indices a lookup at `uv` in or next to `[0, 1]^2` has: inside, or one
/// period off on either side.
#[inline(always)]
fn wrap(i: i64, n: usize) -> usize {
    let n = n as i64;
    let j = if i < 0 {
        i + n
    } else if i >= n {
        i - n
    } else {
        i
    };
    if (0..n).contains(&j) {
        j as usize
    } else {
        i.rem_euclid(n) as usize
    }
}

/// A texel cell of a bilinear lookup: corner columns `x0`, `x1` and rows
/// `y0`, `y1`, and the weights `fx`, `fy` of the second ones.
struct Cell {
    x0: usize,
    y0: usize,
    x1: usize,
    y1: usize,
    fx: f32,
    fy: f32,
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::image::srgb_to_linear;

    #[test]
    fn wrap_is_rem_euclid() {
        for n in [1usize, 2, 3, 7, 64, 1000] {
            let m = n as i64;
            let edges = [0, 1, m - 1, m, m + 1, 2 * m - 1, 2 * m, 3 * m + 2];
            for e in edges {
                for i in [e, -e, -e - 1] {
                    assert_eq!(wrap(i, n), i.rem_euclid(m) as usize, "{i} mod {n}");
                }
            }
            for i in [i64::MIN, i64::MIN + 1, i64::MAX, i64::MAX - 1] {
                assert_eq!(wrap(i, n), i.rem_euclid(m) as usize, "{i} mod {n}");
            }
        }
    }

    fn checker() -> ImageTexture {
        // 2 x 2: top row red, green; bottom row blue, white
        ImageTexture::from_linear_rgb(2, 2, vec![1., 0., 0., 0., 1., 0., 0., 0., 1., 1., 1., 1.])
            .unwrap()
    }

    #[test]
    fn texel_centres_return_texels_and_v_points_up() {
        let t = checker();
        let at = |u: f32, v: f32| t.eval(Vec2::new(u, v));
        // top-left texel centre: u = 0.25, v = 0.75
        assert_eq!(at(0.25, 0.75), Vec3::new(1., 0., 0.));
        assert_eq!(at(0.75, 0.75), Vec3::new(0., 1., 0.));
        assert_eq!(at(0.25, 0.25), Vec3::new(0., 0., 1.));
        assert_eq!(at(0.75, 0.25), Vec3::new(1., 1., 1.));
        // halfway between red and green
        assert_eq!(at(0.5, 0.75), Vec3::new(0.5, 0.5, 0.));
        // wrap: u = 0 is halfway between the right and the left column
        assert_eq!(at(0.0, 0.75), Vec3::new(0.5, 0.5, 0.));
        // repeat: shifting by whole periods changes nothing
        assert_eq!(at(0.25 + 3.0, 0.75 - 2.0), Vec3::new(1., 0., 0.));
        assert_eq!(at(f32::NAN, 0.5), Vec3::ZERO);
    }

    #[test]
    fn bad_sizes_and_values_are_errors() {
        assert!(ImageTexture::from_linear_rgb(0, 1, vec![]).is_err());
        assert!(ImageTexture::from_linear_rgb(1, 1, vec![1.0, 2.0]).is_err());
        let e = ImageTexture::from_linear_rgb(2, 1, vec![1., 1., 1., 0., f32::NAN, 0.])
            .unwrap_err()
            .to_string();
        assert!(e.contains("texel (1, 0)"), "{e}");
        assert!(ImageTexture::from_linear_rgb(1, 1, vec![-1., 0., 0.]).is_err());
    }

    #[test]
    fn png_is_decoded_from_srgb() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("t.png");
        // 2 x 1, 8-bit: (0, 128, 255) and (255, 64, 0)
        let img = image::RgbImage::from_raw(2, 1, vec![0, 128, 255, 255, 64, 0]).unwrap();
        img.save(&path).unwrap();
        let t = ImageTexture::load(&path).unwrap();
        assert_eq!((t.width(), t.height()), (2, 1));
        let lin = |v: u8| srgb_to_linear(v as f64 / 255.0) as f32;
        assert_eq!(t.texel(0, 0), Vec3::new(0.0, lin(128), 1.0));
        assert_eq!(t.texel(1, 0), Vec3::new(1.0, lin(64), 0.0));
        // 16-bit grey
        let path16 = dir.path().join("g.png");
        let g = image::ImageBuffer::<image::Luma<u16>, _>::from_raw(1, 1, vec![30000u16]).unwrap();
        g.save(&path16).unwrap();
        let t = ImageTexture::load(&path16).unwrap();
        let v = srgb_to_linear(30000.0 / 65535.0) as f32;
        assert_eq!(t.texel(0, 0), Vec3::splat(v));
    }

    #[test]
    fn a_loaded_texture_keeps_its_file() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("t.png");
        image::RgbImage::from_raw(1, 1, vec![1, 2, 3])
            .unwrap()
            .save(&path)
            .unwrap();
        let t = ImageTexture::load(&path).unwrap();
        assert_eq!(t.source(), Some(path.as_path()));
        let same = ImageTexture::from_linear_rgb(1, 1, t.texels()[0].to_array().to_vec());
        assert_eq!(same.unwrap(), t, "equal texels are equal textures");
    }

    #[test]
    fn raw_png_is_not_decoded_and_constants_are_exact() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("r.png");
        image::RgbImage::from_raw(2, 1, vec![51, 51, 51, 51, 51, 51])
            .unwrap()
            .save(&path)
            .unwrap();
        let t = ImageTexture::load_as(&path, true).unwrap();
        assert!(t.is_raw());
        assert_eq!(t.texel(0, 0), Vec3::splat(0.2));
        for uv in [Vec2::new(0.1, 0.3), Vec2::new(0.37, 0.91)] {
            assert_eq!(t.eval_scalar(uv), 0.2);
        }
        assert_eq!(t.mean(), Vec3::splat(0.2));
        let srgb = ImageTexture::load(&path).unwrap();
        assert_eq!(srgb.texel(0, 0), Vec3::splat(srgb_to_linear(0.2) as f32));
        let colour = checker();
        assert_eq!(colour.mean(), Vec3::new(0.5, 0.5, 0.5));
        let c = colour.eval(Vec2::new(0.25, 0.75));
        assert_eq!(colour.eval_scalar(Vec2::new(0.25, 0.75)), luminance(c));
    }

    #[test]
    fn the_scalar_gradient_is_the_bilinear_slope() {
        // a ramp along x: texel x holds x / 4; d/du = 1/4 per texel * 4 texels
        let ramp: Vec<f32> = (0..8).flat_map(|i| [(i % 4) as f32 / 4.0; 3]).collect();
        let t = ImageTexture::from_linear_rgb(4, 2, ramp).unwrap();
        let g = t.eval_scalar_grad(Vec2::new(0.4, 0.3));
        assert!((g.x - 1.0).abs() < 1e-6 && g.y == 0.0, "{g}");
        // the same ramp along the rows, top row 0: the value falls as v rises
        let col: Vec<f32> = (0..8).flat_map(|i| [(i / 2) as f32 / 4.0; 3]).collect();
        let t = ImageTexture::from_linear_rgb(2, 4, col).unwrap();
        let g = t.eval_scalar_grad(Vec2::new(0.3, 0.5));
        assert!((g.y + 1.0).abs() < 1e-6 && g.x == 0.0, "{g}");
        // finite differences of eval_scalar agree inside a cell
        let c = checker();
        let (uv, e) = (Vec2::new(0.4, 0.6), 1e-3);
        let g = c.eval_scalar_grad(uv);
        let du = (c.eval_scalar(uv + Vec2::X * e) - c.eval_scalar(uv - Vec2::X * e)) / (2.0 * e);
        let dv = (c.eval_scalar(uv + Vec2::Y * e) - c.eval_scalar(uv - Vec2::Y * e)) / (2.0 * e);
        assert!(
            (g.x - du).abs() < 1e-2 && (g.y - dv).abs() < 1e-2,
            "{g} {du} {dv}"
        );
    }

    /// It said "Is a directory (os error 21)" after trying to decode it.
    #[test]
    fn a_directory_is_not_an_image() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path().join("d.png");
        std::fs::create_dir(&d).unwrap();
        let e = ImageTexture::load(&d).unwrap_err().to_string();
        assert!(e.contains("d.png: is a directory, expected a .png"), "{e}");
    }

    #[test]
    fn load_errors_name_the_file() {
        let dir = tempfile::tempdir().unwrap();
        let missing = dir.path().join("missing.png");
        let e = ImageTexture::load(&missing).unwrap_err().to_string();
        assert!(e.contains("missing.png") && !e.contains('\n'), "{e}");
        let gif = dir.path().join("photo.gif");
        std::fs::write(&gif, b"not really").unwrap();
        let e = ImageTexture::load(&gif).unwrap_err().to_string();
        assert!(e.contains("photo.gif") && e.contains("unsupported"), "{e}");
        let jpg = dir.path().join("photo.jpg");
        std::fs::write(&jpg, b"not really").unwrap();
        let e = ImageTexture::load(&jpg).unwrap_err().to_string();
        assert!(
            e.contains("photo.jpg") && e.contains("not a readable JPEG"),
            "{e}"
        );
        let bad = dir.path().join("bad.png");
        std::fs::write(&bad, b"\x89PNG\r\n\x1a\n truncated").unwrap();
        let e = ImageTexture::load(&bad).unwrap_err().to_string();
        assert!(e.contains("bad.png") && !e.contains('\n'), "{e}");
        let bad_exr = dir.path().join("bad.exr");
        std::fs::write(&bad_exr, b"v/1\x01 nope").unwrap();
        let e = ImageTexture::load(&bad_exr).unwrap_err().to_string();
        assert!(e.contains("bad.exr") && !e.contains('\n'), "{e}");
    }
}
