//! The film: per-pixel sample accumulators ([`Film`], and [`Tile`] for
//! deterministic parallel rendering). Writing a film out as PNG, OpenEXR or
//! PFM is [`crate::image`]'s ([`crate::image::write_image`]).
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

use crate::math::Vec3;

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
    // below 2^(63 - F) (8.4e6, every radiance but the rarest), `v * 2^F` is
    // exact (a power of two) and below 2^63, so the conversion to `i64`, one
    // instruction that truncates, is the floor: the value the conversion
    // from the bits gives. The per-sample adds of a `materials` render
    // (callgrind, 128 x 64, 64 spp) took 57 M instructions instead of 84 M.
    const FAST_BELOW: f64 = (1u64 << (63 - FRACTION_BITS)) as f64;
    if v < FAST_BELOW {
        return (v * (1u64 << FRACTION_BITS) as f64) as i64 as u128;
    }
    to_fixed_from_bits(v)
}

/// [`to_fixed`] for any finite `v >= 0`, from the bits of `v`.
#[inline]
fn to_fixed_from_bits(v: f64) -> u128 {
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

    /// Add the accumulators of `other`'s pixels that lie in this film's
    /// window (a whole-image film onto a crop's, say); its non-finite count
    /// is left out.
    pub fn add_overlap(&mut self, other: &Film) {
        let (a, b) = (self.bounds(), other.bounds());
        let (x0, y0) = (a.x0.max(b.x0), a.y0.max(b.y0));
        let x1 = (a.x0 + a.width).min(b.x0 + b.width);
        let y1 = (a.y0 + a.height).min(b.y0 + b.height);
        for y in y0..y1 {
            for x in x0..x1 {
                let (i, j) = (self.index(x, y), other.index(x, y));
                let p = other.pixels[j];
                self.pixels[i].merge(&p);
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
    fn fixed_point_fast_path_equals_the_bits() {
        // every magnitude from 2^-60 to 2^30, with random mantissas, and the
        // neighbours of the fast path's bound
        let mut rng = crate::sampler::Sampler::new(5, 0, 0);
        let bound = (1u64 << (63 - FRACTION_BITS)) as f64;
        let mut values = vec![0.0, -0.0, bound];
        let (mut up, mut down) = (bound, bound);
        for _ in 0..64 {
            up = f64::from_bits(up.to_bits() + 1);
            down = f64::from_bits(down.to_bits() - 1);
            values.extend([up, down]);
        }
        for e in -60..=30 {
            for _ in 0..200 {
                let m = 1.0 + rng.next_1d() as f64 + rng.next_1d() as f64 * 2f64.powi(-24);
                values.extend([m * 2f64.powi(e), f64::from((m * 2f64.powi(e)) as f32)]);
            }
        }
        for v in values {
            assert_eq!(to_fixed(v), to_fixed_from_bits(v.abs()), "{v:e}");
        }
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
}
