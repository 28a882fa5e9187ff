//! The film and image files: per-pixel sample accumulators ([`Film`], and
//! [`Tile`] for deterministic parallel rendering) and writing them out as PNG,
//! OpenEXR or PFM ([`write_image`]), plus the readers the tests and the `diff`
//! command use ([`read_exr`], [`read_exr_metadata`], [`read_pfm`]).
//!
//! Each pixel keeps `f64` sums of its samples and of their squares, so the
//! estimate (the mean) and its uncertainty (the variance of the mean) come from
//! the same accumulators, and accumulators from tiles and passes merge by
//! addition. This is the box-filter estimator: every sample counts only for the
//! pixel it was taken in, with equal weight (pbrt-v4, Pharr, Jakob, Humphreys,
//! *Physically Based Rendering*, 4th ed., section 5.4, "Film and Imaging").
//!
//! Samples with a non-finite component are not accumulated; the film counts
//! them ([`Film::non_finite_samples`]) so a caller can report them or fail
//! under `--strict`. Dropping them biases the estimate, and the count says by
//! how many samples.
//!
//! Image files: PNG is 8-bit sRGB (IEC 61966-2-1 transfer function) after an
//! exposure scale; EXR is linear `f32` R, G, B with render metadata as custom
//! text attributes; PFM is linear `f32` RGB, little-endian, bottom row first
//! (Paul Debevec's Portable Float Map). Every file is written to a temporary
//! file in the target directory, synced, then renamed over the target, so a
//! reader never sees a half-written image and a failed write leaves nothing.

use crate::error::{Error, Result};
use crate::math::Vec3;
use std::ffi::OsString;
use std::fs::{self, File, OpenOptions};
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

// ---------------------------------------------------------------------------
// Accumulators
// ---------------------------------------------------------------------------

/// Fractional bits of the fixed-point accumulators: a sample component `x`
/// (or its square) is added as the integer `floor(x * 2^FRACTION_BITS)`.
///
/// Why fixed point: integer addition is associative, so a pixel's sums do
/// not depend on the order in which its samples, tiles, passes, shards or
/// merged parts were added; a farm's merged image is the one-machine image
/// bit for bit (issue 20). Exact binned summation (Demmel and Nguyen,
/// "Parallel reproducible summation", IEEE TC 2015; ReproBLAS) would keep
/// more of tiny values, at several floating-point operations per add;
/// 128-bit integers cost two instructions per add.
///
/// Where the bias lives (every other add is exact):
/// - truncation: each sample component loses what lies below 2^-40
///   (9.1e-13), a relative error below 1e-10 for any component above 0.01,
///   and at most 9.1e-13 absolute for any pixel mean;
/// - saturation: a component above [`SUM_SATURATION`] (2^64, 1.8e19) adds
///   as that value, and a square above 2^64 (a component above 2^32, 4.3e9)
///   adds as 2^64, under-estimating that pixel's variance.
///
/// With at most [`MAX_SPP`](crate::limits::MAX_SPP) = 2^24 samples
/// per pixel of at most 2^104 units each, no sum can overflow its `u128`.
pub const FRACTION_BITS: u32 = 40;

/// Most units one addend may carry: `2^104 - 1` (2^24 of them fit a `u128`).
const ADDEND_MAX: u128 = (1 << 104) - 1;

/// The component value above which a sample saturates in the sum: 2^64.
pub const SUM_SATURATION: f64 = 18_446_744_073_709_551_616.0;

/// `floor(v * 2^FRACTION_BITS)` for finite `v >= 0`, at most
/// [`ADDEND_MAX`]; read straight from the bits of `v` (no float-to-`u128`
/// library call).
#[inline]
pub fn to_fixed(v: f64) -> u128 {
    debug_assert!(v >= 0.0 && v.is_finite(), "fixed point takes finite v >= 0");
    let bits = v.to_bits();
    let exp = ((bits >> 52) & 0x7ff) as i32;
    if exp == 0 {
        // zero, or subnormal: far below one unit
        return 0;
    }
    let m = u128::from(bits & ((1 << 52) - 1) | 1 << 52);
    // v = m * 2^(exp - 1075), so v * 2^F = m * 2^(exp - 1075 + F)
    let shift = exp - 1075 + FRACTION_BITS as i32;
    if shift >= 0 {
        // m < 2^53: the result fits below 2^104 for shift <= 51
        if shift > 51 { ADDEND_MAX } else { m << shift }
    } else if shift > -53 {
        m >> -shift
    } else {
        0
    }
}

/// A fixed-point sum back as `f64` (correctly rounded, then scaled exactly).
#[inline]
pub fn from_fixed(q: u128) -> f64 {
    const UNIT: f64 = 1.0 / (1u64 << FRACTION_BITS) as f64;
    q as f64 * UNIT
}

/// One pixel's running sums: fixed-point integers (see [`FRACTION_BITS`]),
/// so that they add up in any order to the same bits.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Pixel {
    /// Sum of the accepted samples, per channel, in units of 2^-40.
    pub sum: [u128; 3],
    /// Sum of the squares of the accepted samples, per channel, in units of
    /// 2^-40.
    pub sum_sq: [u128; 3],
    /// Number of samples accepted.
    pub count: u64,
}

impl Pixel {
    /// Adds one sample. The caller has checked that it is finite; a negative
    /// component (the renderer rejects those before they get here) counts
    /// as zero.
    #[inline]
    fn add(&mut self, rgb: Vec3) {
        debug_assert!(rgb.is_finite(), "non-finite sample reached a pixel");
        for c in 0..3 {
            let v = f64::from(rgb[c].max(0.0));
            // an f32 times itself is exact in f64
            self.sum[c] += to_fixed(v);
            self.sum_sq[c] += to_fixed(v * v);
        }
        self.count += 1;
    }

    /// Adds another pixel's accumulators into this one (exactly: integer
    /// addition).
    pub fn merge(&mut self, other: &Pixel) {
        for c in 0..3 {
            self.sum[c] += other.sum[c];
            self.sum_sq[c] += other.sum_sq[c];
        }
        self.count += other.count;
    }

    /// The sample mean per channel, in `f64`; zero without samples.
    pub fn mean_f64(&self) -> [f64; 3] {
        if self.count == 0 {
            return [0.0; 3];
        }
        let n = self.count as f64;
        self.sum.map(|s| from_fixed(s) / n)
    }

    /// The unbiased sample variance per channel, `(sum_sq - sum^2 / n) /
    /// (n - 1)`, in `f64`; zero with fewer than two samples. Rounding can
    /// make the difference slightly negative for constant samples; it is
    /// clamped to zero.
    pub fn variance_f64(&self) -> [f64; 3] {
        if self.count < 2 {
            return [0.0; 3];
        }
        let n = self.count as f64;
        std::array::from_fn(|c| {
            let (s, sq) = (from_fixed(self.sum[c]), from_fixed(self.sum_sq[c]));
            ((sq - s * s / n) / (n - 1.0)).max(0.0)
        })
    }

    /// The estimated variance of the mean per channel: [`Pixel::variance_f64`]
    /// divided by `n`; zero with fewer than two samples.
    pub fn variance_of_mean_f64(&self) -> [f64; 3] {
        if self.count < 2 {
            return [0.0; 3];
        }
        let n = self.count as f64;
        self.variance_f64().map(|v| v / n)
    }
}

/// Adds `rgb` to `pixel` when it is finite; otherwise counts it in
/// `non_finite`.
#[inline]
fn accept(pixel: &mut Pixel, non_finite: &mut u64, rgb: Vec3) {
    if rgb.is_finite() {
        pixel.add(rgb);
    } else {
        *non_finite += 1;
    }
}

/// A rectangle of pixels in film coordinates: columns `x0 .. x0 + width`, rows
/// `y0 .. y0 + height`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct TileBounds {
    /// First column.
    pub x0: u32,
    /// First row (row 0 is the top of the image).
    pub y0: u32,
    /// Number of columns.
    pub width: u32,
    /// Number of rows.
    pub height: u32,
}

impl TileBounds {
    /// True when pixel `(x, y)` lies inside the rectangle.
    pub fn contains(&self, x: u32, y: u32) -> bool {
        let (x, y) = (u64::from(x), u64::from(y));
        let (x0, y0) = (u64::from(self.x0), u64::from(self.y0));
        x >= x0 && x < x0 + u64::from(self.width) && y >= y0 && y < y0 + u64::from(self.height)
    }

    /// Number of pixels in the rectangle.
    pub fn area(&self) -> u64 {
        u64::from(self.width) * u64::from(self.height)
    }
}

/// Accumulators for one rectangle of the film, owned by one worker while it
/// renders, then added into the film with [`Film::merge_tile`]. Tiles never
/// overlap, so the result does not depend on which worker finishes first.
#[derive(Debug, Clone, PartialEq)]
pub struct Tile {
    bounds: TileBounds,
    pixels: Vec<Pixel>,
    non_finite: u64,
}

impl Tile {
    /// An empty tile covering `bounds`.
    pub fn new(bounds: TileBounds) -> Tile {
        Tile {
            bounds,
            pixels: vec![Pixel::default(); to_usize(bounds.area())],
            non_finite: 0,
        }
    }

    /// The rectangle this tile covers.
    pub fn bounds(&self) -> TileBounds {
        self.bounds
    }

    /// Adds one sample to pixel `(x, y)`, given in film coordinates. A sample
    /// with a non-finite component is counted, not accumulated.
    ///
    /// # Panics
    ///
    /// If `(x, y)` is outside the tile: the renderer's pixel loop produces the
    /// coordinates, so this is a bug, not bad input.
    #[inline]
    pub fn add_sample(&mut self, x: u32, y: u32, rgb: Vec3) {
        let b = self.bounds;
        assert!(b.contains(x, y), "pixel ({x}, {y}) is outside tile {b:?}");
        let i = (y - b.y0) as usize * b.width as usize + (x - b.x0) as usize;
        accept(&mut self.pixels[i], &mut self.non_finite, rgb);
    }

    /// Number of samples this tile dropped for being non-finite.
    pub fn non_finite_samples(&self) -> u64 {
        self.non_finite
    }

    /// Empties the accumulators, keeping the bounds (to reuse the tile for the
    /// next progressive pass).
    pub fn clear(&mut self) {
        self.pixels.fill(Pixel::default());
        self.non_finite = 0;
    }
}

/// The image being rendered: one [`Pixel`] of accumulators per pixel of a
/// window of the image (the whole image unless the render is a crop),
/// row-major, row 0 at the top. Pixels are addressed in image coordinates.
#[derive(Debug, Clone, PartialEq)]
pub struct Film {
    /// The window's first column and row in the image.
    x0: u32,
    y0: u32,
    width: u32,
    height: u32,
    pixels: Vec<Pixel>,
    non_finite: u64,
}

impl Film {
    /// An empty `width` x `height` film (either may be zero; such a film
    /// cannot be written out).
    pub fn new(width: u32, height: u32) -> Film {
        Film::window(TileBounds {
            x0: 0,
            y0: 0,
            width,
            height,
        })
    }

    /// An empty film for the pixels of `window` only (a crop).
    pub fn window(window: TileBounds) -> Film {
        Film {
            x0: window.x0,
            y0: window.y0,
            width: window.width,
            height: window.height,
            pixels: vec![Pixel::default(); to_usize(window.area())],
            non_finite: 0,
        }
    }

    /// The pixels this film holds, in image coordinates.
    pub fn bounds(&self) -> TileBounds {
        TileBounds {
            x0: self.x0,
            y0: self.y0,
            width: self.width,
            height: self.height,
        }
    }

    /// Width in pixels (of the window).
    pub fn width(&self) -> u32 {
        self.width
    }

    /// Height in pixels (of the window).
    pub fn height(&self) -> u32 {
        self.height
    }

    /// Every pixel's accumulators, row-major over the window.
    pub fn pixels(&self) -> &[Pixel] {
        &self.pixels
    }

    /// Every pixel's accumulators, to fill from a file.
    pub fn pixels_mut(&mut self) -> &mut [Pixel] {
        &mut self.pixels
    }

    /// Index of pixel `(x, y)` (image coordinates) in `pixels`.
    fn index(&self, x: u32, y: u32) -> usize {
        assert!(
            self.bounds().contains(x, y),
            "pixel ({x}, {y}) is outside the film's window {:?}",
            self.bounds()
        );
        (y - self.y0) as usize * self.width as usize + (x - self.x0) as usize
    }

    /// Adds one sample to pixel `(x, y)`. A sample with a non-finite component
    /// is counted in [`Film::non_finite_samples`], not accumulated.
    ///
    /// # Panics
    ///
    /// If `(x, y)` is outside the film (a bug in the caller's pixel loop).
    pub fn add_sample(&mut self, x: u32, y: u32, rgb: Vec3) {
        let i = self.index(x, y);
        accept(&mut self.pixels[i], &mut self.non_finite, rgb);
    }

    /// Adds a tile's accumulators (and its non-finite count) into the film.
    /// Merging is addition, so progressive passes can merge into the same
    /// pixels again and again.
    ///
    /// # Panics
    ///
    /// If the tile does not lie inside the film (tiles come from
    /// [`Film::tiles`], so this is a bug).
    pub fn merge_tile(&mut self, tile: &Tile) {
        self.merge_window(tile.bounds, &tile.pixels);
        self.non_finite += tile.non_finite;
    }

    /// Adds another film's accumulators (and its non-finite count) into
    /// this one: a part of a farm render into the merged film.
    ///
    /// # Panics
    ///
    /// If the other film's window is not inside this film's.
    pub fn merge_film(&mut self, other: &Film) {
        self.merge_window(other.bounds(), &other.pixels);
        self.non_finite += other.non_finite;
    }

    /// Add `pixels` (row-major over `b`) into the film's pixels under `b`.
    fn merge_window(&mut self, b: TileBounds, pixels: &[Pixel]) {
        let f = self.bounds();
        let fits = b.x0 >= f.x0
            && b.y0 >= f.y0
            && u64::from(b.x0) + u64::from(b.width) <= u64::from(f.x0) + u64::from(f.width)
            && u64::from(b.y0) + u64::from(b.height) <= u64::from(f.y0) + u64::from(f.height);
        assert!(fits, "window {b:?} is outside the film's window {f:?}");
        if b.width > 0 {
            for (row, tile_row) in pixels.chunks_exact(b.width as usize).enumerate() {
                let start = self.index(b.x0, b.y0 + row as u32);
                let film_row = &mut self.pixels[start..start + b.width as usize];
                for (p, t) in film_row.iter_mut().zip(tile_row) {
                    p.merge(t);
                }
            }
        }
    }

    /// A tile holding the film's current accumulators for `bounds`, to add
    /// a further pass's samples to. Put back with [`Film::store_tile`], the
    /// samples of every pixel are summed in the order they were taken, so a
    /// render in passes gives the same bits as one run.
    ///
    /// # Panics
    ///
    /// If `bounds` does not lie inside the film.
    pub fn tile_state(&self, bounds: TileBounds) -> Tile {
        let mut tile = Tile::new(bounds);
        for (row, tile_row) in tile
            .pixels
            .chunks_exact_mut(bounds.width.max(1) as usize)
            .enumerate()
        {
            let start = self.index(bounds.x0, bounds.y0 + row as u32);
            tile_row.copy_from_slice(&self.pixels[start..start + bounds.width as usize]);
        }
        tile
    }

    /// Replace the film's accumulators under `tile` with the tile's (made
    /// from [`Film::tile_state`]), and add its non-finite count.
    ///
    /// # Panics
    ///
    /// If the tile does not lie inside the film.
    pub fn store_tile(&mut self, tile: &Tile) {
        let b = tile.bounds;
        for (row, tile_row) in tile
            .pixels
            .chunks_exact(b.width.max(1) as usize)
            .enumerate()
        {
            let start = self.index(b.x0, b.y0 + row as u32);
            self.pixels[start..start + b.width as usize].copy_from_slice(tile_row);
        }
        self.non_finite += tile.non_finite;
    }

    /// The film cut into `tile_size` x `tile_size` tiles in row-major order
    /// (left to right, then top to bottom): the image's tile grid (from its
    /// top left corner, whatever the window) clipped to the film's window. A
    /// `tile_size` of 0 is taken as 1.
    pub fn tiles(&self, tile_size: u32) -> Vec<TileBounds> {
        let size = u64::from(tile_size.max(1));
        let f = self.bounds();
        let (x1, y1) = (
            u64::from(f.x0) + u64::from(f.width),
            u64::from(f.y0) + u64::from(f.height),
        );
        let mut tiles = Vec::new();
        let mut y = u64::from(f.y0);
        while y < y1 {
            let ty1 = ((y / size + 1) * size).min(y1);
            let mut x = u64::from(f.x0);
            while x < x1 {
                let tx1 = ((x / size + 1) * size).min(x1);
                tiles.push(TileBounds {
                    x0: x as u32,
                    y0: y as u32,
                    width: (tx1 - x) as u32,
                    height: (ty1 - y) as u32,
                });
                x = tx1;
            }
            y = ty1;
        }
        tiles
    }

    /// The accumulators of pixel `(x, y)`.
    ///
    /// # Panics
    ///
    /// If `(x, y)` is outside the film.
    pub fn pixel(&self, x: u32, y: u32) -> &Pixel {
        &self.pixels[self.index(x, y)]
    }

    /// Number of samples accepted at pixel `(x, y)`.
    ///
    /// # Panics
    ///
    /// If `(x, y)` is outside the film.
    pub fn count(&self, x: u32, y: u32) -> u64 {
        self.pixel(x, y).count
    }

    /// The estimate at pixel `(x, y)`: the mean of its samples, zero without
    /// samples.
    ///
    /// # Panics
    ///
    /// If `(x, y)` is outside the film.
    pub fn mean(&self, x: u32, y: u32) -> Vec3 {
        let m = self.pixel(x, y).mean_f64();
        Vec3::new(m[0] as f32, m[1] as f32, m[2] as f32)
    }

    /// The estimated variance of [`Film::mean`] at pixel `(x, y)`: unbiased
    /// sample variance divided by the sample count, zero with fewer than two
    /// samples.
    ///
    /// # Panics
    ///
    /// If `(x, y)` is outside the film.
    pub fn variance_of_mean(&self, x: u32, y: u32) -> Vec3 {
        let v = self.pixel(x, y).variance_of_mean_f64();
        Vec3::new(v[0] as f32, v[1] as f32, v[2] as f32)
    }

    /// Number of samples dropped for having a non-finite component (directly
    /// or through merged tiles).
    pub fn non_finite_samples(&self) -> u64 {
        self.non_finite
    }

    /// Number of samples accepted over the whole film.
    pub fn total_samples(&self) -> u64 {
        self.pixels.iter().map(|p| p.count).sum()
    }

    /// The image average: the mean over all pixels of each pixel's mean, in
    /// `f64` (pixels without samples count as zero; an empty film gives zero).
    pub fn mean_rgb(&self) -> [f64; 3] {
        if self.pixels.is_empty() {
            return [0.0; 3];
        }
        let mut total = [0.0f64; 3];
        for p in &self.pixels {
            let m = p.mean_f64();
            for c in 0..3 {
                total[c] += m[c];
            }
        }
        let n = self.pixels.len() as f64;
        total.map(|t| t / n)
    }

    /// The pixel means as `f32`, row-major, top row first, 3 floats (R, G, B)
    /// per pixel.
    pub fn to_rgb_f32(&self) -> Vec<f32> {
        self.pixels
            .iter()
            .flat_map(|p| p.mean_f64().map(|m| m as f32))
            .collect()
    }
}

/// `n` as `usize`; pixel counts of a `u32` x `u32` image fit on every 64-bit
/// target, and allocating that many would fail first on a 32-bit one.
fn to_usize(n: u64) -> usize {
    usize::try_from(n).expect("pixel count exceeds the address space")
}

// ---------------------------------------------------------------------------
// Output formats and options
// ---------------------------------------------------------------------------

/// An image file format, chosen by the file's extension.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ImageFormat {
    /// `.png`: 8-bit sRGB.
    Png,
    /// `.exr`: OpenEXR, linear `f32` RGB with metadata.
    Exr,
    /// `.pfm`: Portable Float Map, linear `f32` RGB.
    Pfm,
}

impl ImageFormat {
    /// The format named by `path`'s extension (case-insensitive), or a
    /// [`Error::Settings`] naming the path and the formats accepted.
    pub fn from_path(path: &Path) -> Result<ImageFormat> {
        let Some(ext) = path.extension() else {
            return Err(Error::Settings(format!(
                "{}: output file has no extension (expected .png, .exr or .pfm)",
                path.display()
            )));
        };
        let ext = ext.to_string_lossy();
        match ext.to_ascii_lowercase().as_str() {
            "png" => Ok(ImageFormat::Png),
            "exr" => Ok(ImageFormat::Exr),
            "pfm" => Ok(ImageFormat::Pfm),
            _ => Err(Error::Settings(format!(
                "{}: unknown output format `.{ext}` (expected .png, .exr or .pfm)",
                path.display()
            ))),
        }
    }
}

/// How [`write_image`] writes a film.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct OutputOptions {
    /// Exposure in stops: PNG pixels are scaled by `2^exposure` before sRGB
    /// encoding. EXR and PFM always hold the unscaled radiance.
    pub exposure: f32,
    /// Name-value pairs stored as custom text attributes in the EXR header
    /// (for example `spp`, `seed`, `backend`, `render_seconds`); ignored by PNG
    /// and PFM. Names must be 1 to 255 bytes, without NUL, unique, and not one
    /// of OpenEXR's standard attribute names. Both are stored as UTF-8 bytes.
    pub metadata: Vec<(String, String)>,
}

/// Checks an output path before rendering, so a bad one fails fast: the
/// extension names a known format, the path names a file (not a directory),
/// and the parent directory exists and accepts a new file (a temporary file is
/// created there and removed).
pub fn check_output_path(path: &Path) -> Result<()> {
    ImageFormat::from_path(path)?;
    let dir = parent_dir(path);
    match fs::metadata(dir) {
        Ok(m) if m.is_dir() => {}
        Ok(_) => {
            return Err(Error::Settings(format!(
                "{}: {} is not a directory",
                path.display(),
                dir.display()
            )));
        }
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
            return Err(Error::Settings(format!(
                "{}: the output directory {} does not exist",
                path.display(),
                dir.display()
            )));
        }
        Err(e) => return Err(Error::io(dir, e)),
    }
    if path.is_dir() {
        return Err(Error::Settings(format!(
            "{}: is a directory, not an image file",
            path.display()
        )));
    }
    // Probe: can we create the temporary file the real write will need? The
    // guard removes it again.
    let (probe, file) = TempFile::create(path)?;
    drop(file);
    drop(probe);
    Ok(())
}

/// Writes `film` to `path` in the format its extension names, atomically (see
/// [`write_file_atomically`]).
pub fn write_image(path: &Path, film: &Film, opts: &OutputOptions) -> Result<()> {
    let means: Vec<[f64; 3]> = film.pixels.iter().map(Pixel::mean_f64).collect();
    write_rgb(path, film.width, film.height, &means, opts)
}

/// Writes linear RGB pixels (row-major, top row first) to `path` in the
/// format its extension names, atomically: what [`write_image`] does with a
/// film's means, for images that are not renders (textures, maps).
pub fn write_rgb(
    path: &Path,
    width: u32,
    height: u32,
    rgb: &[[f64; 3]],
    opts: &OutputOptions,
) -> Result<()> {
    let format = ImageFormat::from_path(path)?;
    if width == 0 || height == 0 {
        return Err(Error::Settings(format!(
            "{}: cannot write an empty {width}x{height} image",
            path.display(),
        )));
    }
    assert_eq!(rgb.len() as u64, u64::from(width) * u64::from(height));
    let img = Rgb { width, height, rgb };
    match format {
        ImageFormat::Png => write_png(path, &img, opts.exposure),
        ImageFormat::Exr => write_exr(path, &img, &opts.metadata),
        ImageFormat::Pfm => write_pfm(path, &img),
    }
}

/// Pixels on their way to a file.
struct Rgb<'a> {
    width: u32,
    height: u32,
    rgb: &'a [[f64; 3]],
}

impl Rgb<'_> {
    fn to_f32(&self) -> Vec<f32> {
        self.rgb.iter().flat_map(|p| p.map(|v| v as f32)).collect()
    }
}

// ---------------------------------------------------------------------------
// Atomic writes
// ---------------------------------------------------------------------------

/// The directory `path` lives in (`.` for a bare file name).
fn parent_dir(path: &Path) -> &Path {
    match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    }
}

/// A temporary file next to its target, removed on drop unless it was renamed
/// into place.
struct TempFile {
    path: PathBuf,
    renamed: bool,
}

impl TempFile {
    /// Creates `.{name}.tmp-{pid}-{n}` in `target`'s directory, where `n` makes
    /// concurrent writes from one process distinct.
    fn create(target: &Path) -> Result<(TempFile, File)> {
        static NEXT: AtomicU64 = AtomicU64::new(0);
        let Some(name) = target.file_name() else {
            return Err(Error::Settings(format!(
                "{}: not a file name",
                target.display()
            )));
        };
        let mut tmp_name = OsString::from(".");
        tmp_name.push(name);
        tmp_name.push(format!(
            ".tmp-{}-{}",
            std::process::id(),
            NEXT.fetch_add(1, Ordering::Relaxed)
        ));
        let path = parent_dir(target).join(tmp_name);
        let file = OpenOptions::new()
            .write(true)
            .create_new(true)
            .open(&path)
            .map_err(|e| Error::io(target, e))?;
        Ok((
            TempFile {
                path,
                renamed: false,
            },
            file,
        ))
    }
}

impl Drop for TempFile {
    fn drop(&mut self) {
        if !self.renamed {
            // Best effort: the write already failed, and that error is the one
            // to report.
            let _ = fs::remove_file(&self.path);
        }
    }
}

/// Writes `path` through `write`: the bytes go to a temporary file in the same
/// directory, which is flushed, synced and renamed over `path`. On any error
/// (including one from `write`) the temporary file is removed and `path` is
/// left as it was.
pub(crate) fn write_atomically<F>(path: &Path, write: F) -> Result<()>
where
    F: FnOnce(&mut BufWriter<File>) -> Result<()>,
{
    let (mut tmp, file) = TempFile::create(path)?;
    let mut w = BufWriter::new(file);
    write(&mut w)?;
    let file = w
        .into_inner()
        .map_err(|e| Error::io(path, e.into_error()))?;
    file.sync_all().map_err(|e| Error::io(path, e))?;
    drop(file);
    fs::rename(&tmp.path, path).map_err(|e| Error::io(path, e))?;
    tmp.renamed = true;
    // Make the rename itself durable. Best effort: the new file is already in
    // place, so failing here would misreport a completed write.
    if let Ok(dir) = File::open(parent_dir(path)) {
        let _ = dir.sync_all();
    }
    Ok(())
}

/// Writes `bytes` to `path` atomically: to a temporary file in the same
/// directory, synced, then renamed over `path`; on error nothing appears at
/// `path` (an existing file is left untouched) and the temporary file is
/// removed. For reports and other small files.
pub fn write_file_atomically(path: &Path, bytes: &[u8]) -> Result<()> {
    write_atomically(path, |w| w.write_all(bytes).map_err(|e| Error::io(path, e)))
}

// ---------------------------------------------------------------------------
// PNG
// ---------------------------------------------------------------------------

/// The sRGB transfer function (IEC 61966-2-1): linear `x` in `[0, 1]` to the
/// encoded value, `12.92 x` below `0.0031308`, else `1.055 x^(1/2.4) - 0.055`.
fn linear_to_srgb(x: f64) -> f64 {
    if x < 0.0031308 {
        12.92 * x
    } else {
        1.055 * x.powf(1.0 / 2.4) - 0.055
    }
}

/// Linear radiance to an 8-bit sRGB code value: clamped to `[0, 1]` (NaN
/// gives 0), encoded, rounded to nearest.
pub fn srgb8(linear: f64) -> u8 {
    if linear.is_nan() || linear <= 0.0 {
        return 0;
    }
    let encoded = linear_to_srgb(linear.min(1.0)).clamp(0.0, 1.0);
    (encoded * 255.0).round() as u8
}

/// The film's 8-bit sRGB bytes, row-major, top row first, after scaling the
/// pixel means by `2^exposure`.
fn png_bytes(film: &Rgb, exposure: f32) -> Vec<u8> {
    let scale = f64::from(exposure).exp2();
    film.rgb
        .iter()
        .flat_map(|p| p.map(|m| srgb8(m * scale)))
        .collect()
}

fn write_png(path: &Path, film: &Rgb, exposure: f32) -> Result<()> {
    use image::ImageEncoder;
    if !exposure.is_finite() {
        return Err(Error::Settings(format!(
            "{}: exposure must be a finite number of stops, got {exposure}",
            path.display()
        )));
    }
    let bytes = png_bytes(film, exposure);
    write_atomically(path, |w| {
        image::codecs::png::PngEncoder::new(w)
            .write_image(
                &bytes,
                film.width,
                film.height,
                image::ExtendedColorType::Rgb8,
            )
            .map_err(|e| match e {
                image::ImageError::IoError(e) => Error::io(path, e),
                other => Error::io(path, std::io::Error::other(other)),
            })
    })
}

// ---------------------------------------------------------------------------
// OpenEXR
// ---------------------------------------------------------------------------

/// Checks metadata names against what an EXR header can hold and read back as
/// a custom attribute.
fn check_exr_metadata(path: &Path, metadata: &[(String, String)]) -> Result<()> {
    let bad = |name: &str, why: &str| {
        Err(Error::Settings(format!(
            "{}: metadata name `{}` {why}",
            path.display(),
            name.escape_debug()
        )))
    };
    for (i, (name, _)) in metadata.iter().enumerate() {
        if name.is_empty() || name.len() > 255 {
            return bad(name, "must be 1 to 255 bytes long");
        }
        if name.contains('\0') {
            return bad(name, "must not contain NUL");
        }
        if exr::meta::header::standard_names::ALL.contains(&name.as_bytes()) {
            return bad(name, "is a standard OpenEXR attribute");
        }
        if metadata[..i].iter().any(|(n, _)| n == name) {
            return bad(name, "appears twice");
        }
    }
    Ok(())
}

/// An `exr` error while reading `path`: I/O stays I/O, anything else means the
/// file is not a usable OpenEXR image.
fn exr_read_error(path: &Path, e: exr::error::Error) -> Error {
    match e {
        exr::error::Error::Io(e) => Error::io(path, e),
        other => Error::input(path, None, format!("not a readable OpenEXR file: {other}")),
    }
}

fn write_exr(path: &Path, film: &Rgb, metadata: &[(String, String)]) -> Result<()> {
    use exr::meta::attribute::{AttributeValue, Text};
    use exr::prelude::{
        Encoding, Image, Layer, LayerAttributes, SpecificChannels, Vec2, WritableImage,
    };

    check_exr_metadata(path, metadata)?;
    let mut attributes = LayerAttributes {
        software_name: Text::new_or_none(concat!("embertrace ", env!("CARGO_PKG_VERSION"))),
        ..LayerAttributes::default()
    };
    for (name, value) in metadata {
        attributes.other.insert(
            Text::from_slice_unchecked(name.as_bytes()),
            AttributeValue::Text(Text::from_slice_unchecked(value.as_bytes())),
        );
    }

    let rgb = film.to_f32();
    let width = film.width as usize;
    let channels = SpecificChannels::rgb(|pos: Vec2<usize>| {
        let i = (pos.y() * width + pos.x()) * 3;
        (rgb[i], rgb[i + 1], rgb[i + 2])
    });
    // ZIP is lossless for f32, so the file holds the film's values bit for bit.
    let layer = Layer::new(
        (width, film.height as usize),
        attributes,
        Encoding::SMALL_LOSSLESS,
        channels,
    );
    let image = Image::from_layer(layer);
    write_atomically(path, |w| {
        image.write().to_buffered(w).map_err(|e| match e {
            exr::error::Error::Io(e) => Error::io(path, e),
            other => Error::Settings(format!(
                "{}: cannot encode OpenEXR: {other}",
                path.display()
            )),
        })
    })
}

/// Encode 8-bit RGB pixels (row-major, top row first) as PNG and write them
/// to `path` atomically.
pub fn write_png_rgb8(path: &Path, width: u32, height: u32, rgb: &[u8]) -> Result<()> {
    let mut bytes = Vec::new();
    image::write_buffer_with_format(
        &mut std::io::Cursor::new(&mut bytes),
        rgb,
        width,
        height,
        image::ExtendedColorType::Rgb8,
        image::ImageFormat::Png,
    )
    .map_err(|e| Error::input(path, None, format!("cannot encode PNG: {e}")))?;
    write_file_atomically(path, &bytes)
}

/// Reads the R, G, B channels of the first layer of an OpenEXR file as `f32`:
/// `(width, height, pixels)` with `pixels` row-major, top row first, 3 floats
/// per pixel. The size is the layer's data window.
pub fn read_exr(path: &Path) -> Result<(u32, u32, Vec<f32>)> {
    use exr::prelude::{ReadChannels, ReadLayers, Vec2};

    let file = File::open(path).map_err(|e| Error::io(path, e))?;
    let image = exr::prelude::read()
        .no_deep_data()
        .largest_resolution_level()
        .rgb_channels(
            |size: Vec2<usize>, _| (size.width(), vec![0.0f32; size.area() * 3]),
            |(w, px): &mut (usize, Vec<f32>), pos: Vec2<usize>, (r, g, b): (f32, f32, f32)| {
                let i = (pos.y() * *w + pos.x()) * 3;
                px[i..i + 3].copy_from_slice(&[r, g, b]);
            },
        )
        .first_valid_layer()
        .all_attributes()
        .from_unbuffered(file)
        .map_err(|e| exr_read_error(path, e))?;
    let layer = image.layer_data;
    let too_large = || Error::input(path, None, "image dimensions exceed u32");
    let width = u32::try_from(layer.size.width()).map_err(|_| too_large())?;
    let height = u32::try_from(layer.size.height()).map_err(|_| too_large())?;
    Ok((width, height, layer.channel_data.pixels.1))
}

/// The custom text attributes of an OpenEXR file's first header (the
/// [`OutputOptions::metadata`] it was written with), sorted by name. Bytes
/// that are not UTF-8 are replaced.
pub fn read_exr_metadata(path: &Path) -> Result<Vec<(String, String)>> {
    use exr::meta::attribute::AttributeValue;

    let file = File::open(path).map_err(|e| Error::io(path, e))?;
    let meta = exr::meta::MetaData::read_from_unbuffered(file, false)
        .map_err(|e| exr_read_error(path, e))?;
    let Some(header) = meta.headers.first() else {
        return Err(Error::input(path, None, "OpenEXR file has no header"));
    };
    let mut pairs: Vec<(String, String)> = header
        .own_attributes
        .other
        .iter()
        .chain(&header.shared_attributes.other)
        .filter_map(|(name, value)| match value {
            AttributeValue::Text(text) => Some((
                String::from_utf8_lossy(name.as_slice()).into_owned(),
                String::from_utf8_lossy(text.as_slice()).into_owned(),
            )),
            _ => None,
        })
        .collect();
    pairs.sort();
    Ok(pairs)
}

// ---------------------------------------------------------------------------
// PFM
// ---------------------------------------------------------------------------

fn write_pfm(path: &Path, film: &Rgb) -> Result<()> {
    let rgb = film.to_f32();
    let row_floats = film.width as usize * 3;
    write_atomically(path, |w| {
        let io = |e| Error::io(path, e);
        // A negative scale marks little-endian data.
        write!(w, "PF\n{} {}\n-1.0\n", film.width, film.height).map_err(io)?;
        let mut row_bytes = Vec::with_capacity(row_floats * 4);
        // PFM stores the bottom row first.
        for row in rgb.chunks_exact(row_floats).rev() {
            row_bytes.clear();
            row_bytes.extend(row.iter().flat_map(|v| v.to_le_bytes()));
            w.write_all(&row_bytes).map_err(io)?;
        }
        Ok(())
    })
}

/// A whitespace-separated token of a PFM header, with the 1-based line it is
/// on.
struct HeaderToken<'a> {
    text: &'a [u8],
    line: usize,
}

impl HeaderToken<'_> {
    /// The token for an error message, shortened if it is binary junk.
    fn show(&self) -> String {
        let shown = &self.text[..self.text.len().min(16)];
        let more = if self.text.len() > 16 { "..." } else { "" };
        format!("{}{more}", String::from_utf8_lossy(shown).escape_debug())
    }
}

/// Reads PFM header tokens from the start of a file.
struct HeaderReader<'a> {
    bytes: &'a [u8],
    pos: usize,
    line: usize,
}

impl<'a> HeaderReader<'a> {
    /// The next token, or `None` at the end of the file.
    fn next(&mut self) -> Option<HeaderToken<'a>> {
        let bytes = self.bytes;
        let range = crate::error::next_word(bytes, &mut self.pos, &mut self.line)?;
        Some(HeaderToken {
            text: &bytes[range],
            line: self.line,
        })
    }
}

/// Reads a Portable Float Map: `(width, height, pixels)` with `pixels`
/// row-major, top row first, 3 floats per pixel. Accepts colour (`PF`) and
/// grayscale (`Pf`, copied to R, G and B) files of either byte order (the sign
/// of the scale line); the scale's magnitude is ignored.
pub fn read_pfm(path: &Path) -> Result<(u32, u32, Vec<f32>)> {
    let bytes = fs::read(path).map_err(|e| Error::io(path, e))?;
    let bad = |line: Option<usize>, msg: String| Error::input(path, line, msg);
    let mut header = HeaderReader {
        bytes: &bytes,
        pos: 0,
        line: 1,
    };
    let mut field = |what: &str| {
        header.next().ok_or_else(|| {
            bad(
                None,
                format!("not a PFM file: the header ends before the {what}"),
            )
        })
    };

    let magic = field("`PF` or `Pf` signature")?;
    let channels = match magic.text {
        b"PF" => 3,
        b"Pf" => 1,
        _ => {
            return Err(bad(
                Some(magic.line),
                format!(
                    "not a PFM file: expected `PF` or `Pf`, found `{}`",
                    magic.show()
                ),
            ));
        }
    };
    let mut dimension = |what: &str| -> Result<u32> {
        let tok = field(what)?;
        std::str::from_utf8(tok.text)
            .ok()
            .and_then(|s| s.parse::<u32>().ok())
            .filter(|&n| n > 0)
            .ok_or_else(|| {
                bad(
                    Some(tok.line),
                    format!("expected a positive {what}, found `{}`", tok.show()),
                )
            })
    };
    let width = dimension("width")?;
    let height = dimension("height")?;
    let scale_tok = field("scale")?;
    let scale = std::str::from_utf8(scale_tok.text)
        .ok()
        .and_then(|s| s.parse::<f32>().ok())
        .filter(|s| s.is_finite() && *s != 0.0)
        .ok_or_else(|| {
            bad(
                Some(scale_tok.line),
                format!(
                    "expected a non-zero scale (negative for little-endian), found `{}`",
                    scale_tok.show()
                ),
            )
        })?;
    let little_endian = scale < 0.0;
    // Exactly one whitespace byte separates the header from the pixels.
    let data_start = header.pos + 1;
    if data_start > bytes.len() {
        return Err(bad(
            None,
            "truncated PFM file: no pixel data after the header".into(),
        ));
    }

    // In u128: 2^32 x 2^32 x 3 x 4 overflows u64.
    let expected = u128::from(width) * u128::from(height) * channels as u128 * 4;
    let found = (bytes.len() - data_start) as u128;
    if found != expected {
        let what = if found < expected {
            "truncated"
        } else {
            "trailing data in"
        };
        return Err(bad(
            None,
            format!(
                "{what} PFM file: a {width}x{height} image with {channels} channel(s) \
                 needs {expected} bytes of pixel data, found {found}"
            ),
        ));
    }

    let data = &bytes[data_start..];
    let decode = |b: &[u8]| {
        let b = [b[0], b[1], b[2], b[3]];
        if little_endian {
            f32::from_le_bytes(b)
        } else {
            f32::from_be_bytes(b)
        }
    };
    let row_bytes = width as usize * channels * 4;
    let mut pixels = Vec::with_capacity(to_usize(u64::from(width) * u64::from(height) * 3));
    // The file stores the bottom row first; the result starts with the top row.
    for row in data.chunks_exact(row_bytes).rev() {
        for px in row.chunks_exact(channels * 4) {
            if channels == 3 {
                pixels.extend(px.chunks_exact(4).map(decode));
            } else {
                let v = decode(px);
                pixels.extend([v, v, v]);
            }
        }
    }
    Ok((width, height, pixels))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fixed_point_is_exact_floor_and_saturates() {
        let unit = 1u128 << FRACTION_BITS;
        assert_eq!(to_fixed(0.0), 0);
        assert_eq!(to_fixed(1.0), unit);
        assert_eq!(to_fixed(0.75), 3 * unit / 4);
        // below one unit: nothing; f32 values from 2^-40 up are exact
        assert_eq!(to_fixed(0.5f64.powi(41)), 0);
        assert_eq!(to_fixed(0.5f64.powi(40)), 1);
        assert_eq!(to_fixed(f64::MIN_POSITIVE / 4.0), 0);
        let x = f64::from(0.1f32);
        assert_eq!(from_fixed(to_fixed(x)), x);
        // both sides of 2^24
        let below = f64::from_bits((16_777_216.0f64).to_bits() - 1);
        assert_eq!(to_fixed(below), (below * unit as f64) as u128);
        assert_eq!(to_fixed(16_777_216.0), 16_777_216 * unit);
        assert_eq!(to_fixed(3.5e9), 3_500_000_000 * unit);
        // saturation at 2^64
        assert_eq!(to_fixed(SUM_SATURATION / 2.0), (1 << 103));
        assert_eq!(to_fixed(SUM_SATURATION), ADDEND_MAX);
        assert_eq!(to_fixed(f64::MAX), ADDEND_MAX);
        // 2^24 samples at the most cannot overflow
        assert!(ADDEND_MAX.checked_mul(1 << 24).is_some());
    }

    #[test]
    fn pixel_sums_do_not_depend_on_order() {
        let samples: Vec<Vec3> = (0..1000)
            .map(|i| {
                let t = i as f32;
                Vec3::new(
                    (t * 0.37).sin().abs() * 1e3,
                    1e-7 * t,
                    (t * 1.3).cos().abs(),
                )
            })
            .collect();
        let sum = |order: &mut dyn Iterator<Item = &Vec3>| {
            let mut p = Pixel::default();
            for s in order {
                p.add(*s);
            }
            p
        };
        let forward = sum(&mut samples.iter());
        let backward = sum(&mut samples.iter().rev());
        let mut halves = sum(&mut samples[500..].iter());
        halves.merge(&sum(&mut samples[..500].iter()));
        assert_eq!(forward, backward);
        assert_eq!(forward, halves);
        // and the mean is the f64 mean to within the truncation
        let exact: f64 = samples.iter().map(|s| f64::from(s.x)).sum::<f64>() / 1000.0;
        assert!((forward.mean_f64()[0] - exact).abs() < 1e-9);
    }

    /// A film whose pixel (x, y) holds one sample that differs per pixel and
    /// channel, including values that would expose rounding or reordering.
    fn gradient_film(width: u32, height: u32) -> Film {
        let mut film = Film::new(width, height);
        for y in 0..height {
            for x in 0..width {
                let base = (y * width + x) as f32;
                film.add_sample(
                    x,
                    y,
                    Vec3::new(base + 0.1, -base * 1e-3 - 1e-30, (base + 1.0).powf(7.3)),
                );
            }
        }
        film
    }

    fn bits(v: &[f32]) -> Vec<u32> {
        v.iter().map(|f| f.to_bits()).collect()
    }

    fn entries(dir: &Path) -> Vec<String> {
        let mut names: Vec<String> = fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        names.sort();
        names
    }

    // --- accumulators --------------------------------------------------------

    #[test]
    fn mean_variance_and_count_match_hand_computation() {
        let mut film = Film::new(2, 1);
        for v in [1.0, 2.0, 3.0, 4.0] {
            film.add_sample(1, 0, Vec3::new(v, 2.0 * v, 5.0));
        }
        assert_eq!(film.count(1, 0), 4);
        assert_eq!(film.mean(1, 0), Vec3::new(2.5, 5.0, 5.0));
        // Unbiased variance of {1,2,3,4} is (30 - 100/4) / 3 = 5/3; over n = 4
        // samples the variance of the mean is 5/12. Doubling the samples
        // quadruples it; a constant channel has none.
        let v = film.variance_of_mean(1, 0);
        assert!((v.x - 5.0 / 12.0).abs() < 1e-7, "{v:?}");
        assert!((v.y - 4.0 * 5.0 / 12.0).abs() < 1e-6, "{v:?}");
        assert_eq!(v.z, 0.0);
        // Untouched pixel, and a single sample: no variance estimate.
        assert_eq!(film.mean(0, 0), Vec3::ZERO);
        assert_eq!(film.variance_of_mean(0, 0), Vec3::ZERO);
        film.add_sample(0, 0, Vec3::splat(7.0));
        assert_eq!(film.variance_of_mean(0, 0), Vec3::ZERO);
        assert_eq!(film.total_samples(), 5);
    }

    #[test]
    fn mean_rgb_averages_pixel_means() {
        let mut film = Film::new(2, 2);
        film.add_sample(0, 0, Vec3::new(1.0, 0.0, 2.0));
        film.add_sample(0, 0, Vec3::new(3.0, 0.0, 2.0)); // mean (2, 0, 2)
        film.add_sample(1, 0, Vec3::new(0.0, 4.0, 0.0)); // mean (0, 4, 0)
        film.add_sample(0, 1, Vec3::new(2.0, 0.0, 6.0)); // mean (2, 0, 6)
        // (1, 1) has no samples and counts as zero.
        assert_eq!(film.mean_rgb(), [1.0, 1.0, 2.0]);
        assert_eq!(Film::new(0, 3).mean_rgb(), [0.0; 3]);
    }

    #[test]
    fn non_finite_samples_are_counted_not_accumulated() {
        let mut film = Film::new(1, 1);
        film.add_sample(0, 0, Vec3::splat(1.0));
        film.add_sample(0, 0, Vec3::new(f32::NAN, 0.0, 0.0));
        film.add_sample(0, 0, Vec3::new(0.0, f32::INFINITY, 0.0));
        let mut tile = Tile::new(film.tiles(1)[0]);
        tile.add_sample(0, 0, Vec3::new(0.0, 0.0, f32::NEG_INFINITY));
        film.merge_tile(&tile);
        assert_eq!(film.count(0, 0), 1);
        assert_eq!(film.mean(0, 0), Vec3::splat(1.0));
        assert_eq!(film.non_finite_samples(), 3);
    }

    #[test]
    fn tiles_cover_the_film_row_major_and_clipped() {
        let film = Film::new(5, 3);
        let tiles = film.tiles(2);
        let expect = [
            (0, 0, 2, 2),
            (2, 0, 2, 2),
            (4, 0, 1, 2),
            (0, 2, 2, 1),
            (2, 2, 2, 1),
            (4, 2, 1, 1),
        ];
        let got: Vec<_> = tiles
            .iter()
            .map(|t| (t.x0, t.y0, t.width, t.height))
            .collect();
        assert_eq!(got, expect);
        assert_eq!(tiles.iter().map(TileBounds::area).sum::<u64>(), 15);
        assert_eq!(film.tiles(0).len(), 15);
        assert!(Film::new(0, 4).tiles(8).is_empty());
    }

    #[test]
    fn merged_tiles_equal_direct_samples_bit_exact() {
        let (w, h) = (5, 3);
        let mut direct = Film::new(w, h);
        let mut merged = Film::new(w, h);
        let mut tiles: Vec<Tile> = merged.tiles(3).into_iter().map(Tile::new).collect();
        assert_eq!(tiles.len(), 2);
        // Several awkward samples per pixel, so sums round.
        let mut s = 12345u32;
        for y in 0..h {
            for x in 0..w {
                for _ in 0..7 {
                    s = s.wrapping_mul(1664525).wrapping_add(1013904223);
                    let u = (s >> 8) as f32 / (1u32 << 24) as f32;
                    let rgb = Vec3::new(u * 1e3, u.sqrt() * 0.1, 1.0 / (u + 1e-3));
                    direct.add_sample(x, y, rgb);
                    let tile = tiles
                        .iter_mut()
                        .find(|t| t.bounds().contains(x, y))
                        .unwrap();
                    tile.add_sample(x, y, rgb);
                }
            }
        }
        // Merge in reverse order: disjoint tiles make the order irrelevant.
        for tile in tiles.iter().rev() {
            merged.merge_tile(tile);
        }
        assert_eq!(merged, direct);
        assert!(merged.total_samples() == 7 * 15);

        // Merging again adds again (progressive passes).
        for tile in &tiles {
            merged.merge_tile(tile);
        }
        assert_eq!(merged.count(4, 2), 14);
        assert_eq!(merged.pixel(4, 2).sum[0], 2 * direct.pixel(4, 2).sum[0]);
        let mut cleared = tiles[0].clone();
        cleared.clear();
        assert_eq!(cleared, Tile::new(tiles[0].bounds()));
    }

    #[test]
    fn rgb_f32_is_row_major_top_first() {
        let mut film = Film::new(2, 2);
        film.add_sample(1, 0, Vec3::new(1.0, 2.0, 3.0));
        film.add_sample(0, 1, Vec3::new(4.0, 5.0, 6.0));
        assert_eq!(
            film.to_rgb_f32(),
            [0.0, 0.0, 0.0, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 0.0, 0.0, 0.0]
        );
    }

    // --- PNG -----------------------------------------------------------------

    #[test]
    fn srgb_encoding_of_known_values() {
        assert_eq!(srgb8(0.0), 0);
        assert_eq!(srgb8(1.0), 255);
        // 1.055 * 0.5^(1/2.4) - 0.055 = 0.735356..., * 255 = 187.52
        assert_eq!(srgb8(0.5), 188);
        assert_eq!(srgb8(0.18), 118);
        // Clamped: negative, NaN, above one, infinite.
        assert_eq!(srgb8(-1.0), 0);
        assert_eq!(srgb8(f64::NAN), 0);
        assert_eq!(srgb8(7.0), 255);
        assert_eq!(srgb8(f64::INFINITY), 255);
        // The two pieces meet at 0.0031308 (to the precision of the standard's
        // constants), and the linear piece is used just below it.
        let b = 0.0031308f64;
        let power_piece = 1.055 * b.powf(1.0 / 2.4) - 0.055;
        assert!((12.92 * b - power_piece).abs() < 1e-7);
        assert!((linear_to_srgb(b) - linear_to_srgb(b - 1e-12)).abs() < 1e-7);
        assert_eq!(linear_to_srgb(0.001), 12.92 * 0.001);
        assert_eq!(srgb8(b), 10);
    }

    #[test]
    fn exposure_doubles_linear_value_per_stop() {
        let film_with = |v: f32| {
            let mut f = Film::new(1, 1);
            f.add_sample(0, 0, Vec3::new(v, v / 2.0, v / 4.0));
            f
        };
        let png_bytes = |f: &Film, exposure: f32| {
            let means: Vec<[f64; 3]> = f.pixels().iter().map(Pixel::mean_f64).collect();
            let rgb = Rgb {
                width: f.width(),
                height: f.height(),
                rgb: &means,
            };
            png_bytes(&rgb, exposure)
        };
        let dim = film_with(0.1);
        let bright = film_with(0.2);
        assert_eq!(png_bytes(&dim, 1.0), png_bytes(&bright, 0.0));
        assert_eq!(png_bytes(&bright, -1.0), png_bytes(&dim, 0.0));
        assert_eq!(
            png_bytes(&dim, 1.0),
            [
                srgb8(0.2f32 as f64),
                srgb8(0.1f32 as f64),
                srgb8(0.05f32 as f64)
            ]
        );
        assert_ne!(png_bytes(&dim, 1.0), png_bytes(&dim, 0.0));
    }

    #[test]
    fn png_file_holds_srgb_bytes() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("out.PNG");
        let mut film = Film::new(2, 1);
        film.add_sample(0, 0, Vec3::new(0.5, 1.0, 0.0));
        film.add_sample(1, 0, Vec3::new(0.25, 0.0, 2.0));
        write_image(&path, &film, &OutputOptions::default()).unwrap();
        let img = image::open(&path).unwrap().to_rgb8();
        assert_eq!(img.dimensions(), (2, 1));
        assert_eq!(img.as_raw(), &[188, 255, 0, srgb8(0.25), 0, 255]);
        let opts = OutputOptions {
            exposure: f32::NAN,
            ..OutputOptions::default()
        };
        assert!(matches!(
            write_image(&path, &film, &opts),
            Err(Error::Settings(_))
        ));
        assert_eq!(entries(dir.path()), ["out.PNG"]);
    }

    // --- PFM -----------------------------------------------------------------

    #[test]
    fn pfm_round_trip_is_bit_exact_and_bottom_row_first() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("img.pfm");
        let film = gradient_film(3, 2);
        write_image(&path, &film, &OutputOptions::default()).unwrap();

        let raw = fs::read(&path).unwrap();
        let header = b"PF\n3 2\n-1.0\n";
        assert_eq!(&raw[..header.len()], header);
        assert_eq!(raw.len(), header.len() + 3 * 2 * 3 * 4);
        // The first pixel in the file is the bottom-left one, (0, 1).
        let first = f32::from_le_bytes(raw[header.len()..header.len() + 4].try_into().unwrap());
        assert_eq!(first, film.mean(0, 1).x);

        let (w, h, px) = read_pfm(&path).unwrap();
        assert_eq!((w, h), (3, 2));
        assert_eq!(bits(&px), bits(&film.to_rgb_f32()));
    }

    #[test]
    fn pfm_reads_big_endian_and_grayscale() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("g.pfm");
        // 1x2 grayscale, big-endian, width and height on separate lines:
        // bottom row 2.0, top row -0.5.
        let mut bytes = b"Pf\n1\n2\n1.0\n".to_vec();
        bytes.extend(2.0f32.to_be_bytes());
        bytes.extend((-0.5f32).to_be_bytes());
        fs::write(&path, bytes).unwrap();
        let (w, h, px) = read_pfm(&path).unwrap();
        assert_eq!((w, h), (1, 2));
        assert_eq!(px, [-0.5, -0.5, -0.5, 2.0, 2.0, 2.0]);
    }

    #[test]
    fn malformed_pfm_files_give_input_errors() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("bad.pfm");
        let one_pixel = [0u8; 12];
        let cases: [(&[u8], &[u8], &str); 8] = [
            (b"P6\n1 1\n255\n", &one_pixel, "expected `PF` or `Pf`"),
            (b"PF\n0 1\n-1.0\n", &one_pixel, "positive width"),
            (b"PF\n1 x\n-1.0\n", &one_pixel, "positive height"),
            (b"PF\n1 1\n0\n", &one_pixel, "non-zero scale"),
            (b"PF\n1 1\n", b"", "ends before the scale"),
            (b"PF\n1 1\n-1.0\n", &one_pixel[..11], "truncated"),
            (b"PF\n1 1\n-1.0\n", &[0u8; 16], "trailing data"),
            (
                b"PF\n4294967295 4294967295\n-1.0\n",
                &one_pixel,
                "truncated",
            ),
        ];
        for (header, data, expect) in cases {
            fs::write(&path, [header, data].concat()).unwrap();
            let err = read_pfm(&path).unwrap_err();
            assert!(matches!(err, Error::Input { .. }), "{err}");
            assert!(err.to_string().contains(expect), "{err} (wanted {expect})");
        }
        let err = read_pfm(&dir.path().join("missing.pfm")).unwrap_err();
        assert!(matches!(err, Error::Io { .. }), "{err}");
    }

    // --- EXR -----------------------------------------------------------------

    #[test]
    fn exr_round_trip_is_bit_exact_with_metadata() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("img.exr");
        let film = gradient_film(4, 3);
        let opts = OutputOptions {
            exposure: 3.0, // PNG only: must not change the EXR values
            metadata: vec![
                ("spp".into(), "64".into()),
                ("seed".into(), "7".into()),
                ("backend".into(), "naive".into()),
                ("render_seconds".into(), "1.25".into()),
                (
                    "a name longer than thirty-two bytes".into(),
                    "ünïcode ✓".into(),
                ),
            ],
        };
        write_image(&path, &film, &opts).unwrap();

        let (w, h, px) = read_exr(&path).unwrap();
        assert_eq!((w, h), (4, 3));
        assert_eq!(bits(&px), bits(&film.to_rgb_f32()));

        let mut expect = opts.metadata.clone();
        expect.sort();
        assert_eq!(read_exr_metadata(&path).unwrap(), expect);
        assert_eq!(entries(dir.path()), ["img.exr"]);
    }

    #[test]
    fn bad_exr_metadata_is_rejected_before_writing() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("img.exr");
        let film = gradient_film(2, 2);
        for metadata in [
            vec![("channels".to_string(), "x".to_string())],
            vec![(String::new(), "x".to_string())],
            vec![("spp".to_string(), "1".to_string()); 2],
            vec![("a\0b".to_string(), "x".to_string())],
        ] {
            let opts = OutputOptions {
                metadata,
                ..OutputOptions::default()
            };
            let err = write_image(&path, &film, &opts).unwrap_err();
            assert!(matches!(err, Error::Settings(_)), "{err}");
        }
        assert!(entries(dir.path()).is_empty());
    }

    #[test]
    fn reading_a_non_exr_file_is_an_input_error() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("fake.exr");
        fs::write(&path, b"definitely not an exr file").unwrap();
        assert!(matches!(read_exr(&path), Err(Error::Input { .. })));
        assert!(matches!(read_exr_metadata(&path), Err(Error::Input { .. })));
    }

    // --- paths and atomic writes ---------------------------------------------

    #[test]
    fn unknown_or_missing_extension_is_a_settings_error() {
        let film = gradient_film(1, 1);
        let err =
            write_image(Path::new("out/img.xyz"), &film, &OutputOptions::default()).unwrap_err();
        assert_eq!(
            err.to_string(),
            "out/img.xyz: unknown output format `.xyz` (expected .png, .exr or .pfm)"
        );
        assert!(matches!(err, Error::Settings(_)));
        assert!(matches!(
            check_output_path(Path::new("img")),
            Err(Error::Settings(_))
        ));
        assert_eq!(
            ImageFormat::from_path(Path::new("a.b.ExR")).unwrap(),
            ImageFormat::Exr
        );
        assert_eq!(
            ImageFormat::from_path(Path::new("x.PFM")).unwrap(),
            ImageFormat::Pfm
        );
    }

    #[test]
    fn check_output_path_fails_fast_and_leaves_nothing() {
        let dir = tempfile::tempdir().unwrap();
        check_output_path(&dir.path().join("ok.exr")).unwrap();
        assert!(entries(dir.path()).is_empty());
        let err = check_output_path(&dir.path().join("no/such/dir/img.png")).unwrap_err();
        assert!(err.to_string().contains("does not exist"), "{err}");
        fs::create_dir(dir.path().join("sub.png")).unwrap();
        assert!(check_output_path(&dir.path().join("sub.png")).is_err());
    }

    #[test]
    fn failed_writes_leave_no_file() {
        let dir = tempfile::tempdir().unwrap();
        let film = gradient_film(2, 2);

        // Missing directory: an error naming the target, nothing created.
        let target = dir.path().join("missing").join("img.pfm");
        let err = write_image(&target, &film, &OutputOptions::default()).unwrap_err();
        assert!(
            matches!(err, Error::Io { ref path, .. } if *path == target),
            "{err}"
        );
        assert!(entries(dir.path()).is_empty());

        // An encoder that fails halfway: the partial temporary file is removed
        // and an existing target keeps its old contents.
        let target = dir.path().join("report.json");
        fs::write(&target, b"old").unwrap();
        let err = write_atomically(&target, |w| {
            w.write_all(&[1u8; 100_000]).unwrap();
            Err(Error::Settings("encoder gave up".into()))
        })
        .unwrap_err();
        assert_eq!(err.to_string(), "encoder gave up");
        assert_eq!(entries(dir.path()), ["report.json"]);
        assert_eq!(fs::read(&target).unwrap(), b"old");

        // Empty films cannot be encoded: refused before any file is made.
        let empty = dir.path().join("empty.exr");
        assert!(write_image(&empty, &Film::new(0, 2), &OutputOptions::default()).is_err());
        assert_eq!(entries(dir.path()), ["report.json"]);

        // A successful write replaces the target and leaves no temporary.
        write_file_atomically(&target, b"{\"spp\": 4}").unwrap();
        assert_eq!(fs::read(&target).unwrap(), b"{\"spp\": 4}");
        assert_eq!(entries(dir.path()), ["report.json"]);
    }
}
