//! A small RGB canvas for the figures `embertrace study` writes: lines,
//! rectangles, images and text (the public-domain 8x8 bitmap font of the
//! `font8x8` crate), a log-log line plot with labelled axes and a legend,
//! and a labelled grid of images. No font files, no system libraries.

use crate::error::Result;
use crate::image::write_png_rgb8;
use font8x8::UnicodeFonts;
use std::path::Path;

/// An RGB colour.
pub type Rgb = [u8; 3];

/// White.
pub const WHITE: Rgb = [255, 255, 255];
/// Black.
pub const BLACK: Rgb = [0, 0, 0];
/// Light grey, for grid lines.
pub const GRID: Rgb = [225, 225, 225];

/// Distinguishable line colours: Okabe and Ito's colour-blind-safe set
/// ("Color Universal Design", 2008), then four darker ones. Series beyond
/// these repeat the colours with dashed lines.
pub const PALETTE: [Rgb; 12] = [
    [0, 114, 178],
    [213, 94, 0],
    [0, 158, 115],
    [204, 121, 167],
    [230, 159, 0],
    [86, 180, 233],
    [0, 0, 0],
    [200, 190, 40],
    [140, 20, 20],
    [90, 50, 150],
    [120, 120, 120],
    [60, 100, 30],
];

/// Side of a glyph in pixels at scale 1.
pub const GLYPH: u32 = 8;

/// An RGB image to draw on; row 0 at the top.
#[derive(Debug, Clone, PartialEq)]
pub struct Canvas {
    /// Width.
    pub width: u32,
    /// Height.
    pub height: u32,
    /// `width * height * 3` bytes.
    pub rgb: Vec<u8>,
}

impl Canvas {
    /// A canvas filled with `bg`.
    pub fn new(width: u32, height: u32, bg: Rgb) -> Canvas {
        Canvas {
            width,
            height,
            rgb: bg
                .iter()
                .copied()
                .cycle()
                .take(width as usize * height as usize * 3)
                .collect(),
        }
    }

    /// Set pixel `(x, y)`; outside the canvas nothing happens.
    pub fn set(&mut self, x: i64, y: i64, c: Rgb) {
        if x >= 0 && y >= 0 && (x as u32) < self.width && (y as u32) < self.height {
            let i = (y as usize * self.width as usize + x as usize) * 3;
            self.rgb[i..i + 3].copy_from_slice(&c);
        }
    }

    /// The colour at `(x, y)` (inside the canvas).
    pub fn get(&self, x: u32, y: u32) -> Rgb {
        let i = (y as usize * self.width as usize + x as usize) * 3;
        [self.rgb[i], self.rgb[i + 1], self.rgb[i + 2]]
    }

    /// Fill the rectangle from `(x, y)`, `w` by `h` pixels.
    pub fn fill(&mut self, x: i64, y: i64, w: u32, h: u32, c: Rgb) {
        for j in 0..h as i64 {
            for i in 0..w as i64 {
                self.set(x + i, y + j, c);
            }
        }
    }

    /// A line `thickness` pixels wide from `a` to `b` (Bresenham's
    /// algorithm, a square pen).
    pub fn line(&mut self, a: (f64, f64), b: (f64, f64), c: Rgb, thickness: u32) {
        self.dashed_line(a, b, c, thickness, 0);
    }

    /// A line drawn `dash` pixels on, `dash` off (solid for 0).
    pub fn dashed_line(&mut self, a: (f64, f64), b: (f64, f64), c: Rgb, thickness: u32, dash: u32) {
        let (mut x0, mut y0) = (a.0.round() as i64, a.1.round() as i64);
        let (x1, y1) = (b.0.round() as i64, b.1.round() as i64);
        let (dx, dy) = ((x1 - x0).abs(), -(y1 - y0).abs());
        let (sx, sy) = (if x0 < x1 { 1 } else { -1 }, if y0 < y1 { 1 } else { -1 });
        let mut err = dx + dy;
        let r = thickness as i64 / 2;
        let mut step = 0u32;
        loop {
            if dash == 0 || (step / dash) % 2 == 0 {
                self.fill(x0 - r, y0 - r, thickness, thickness, c);
            }
            step += 1;
            if x0 == x1 && y0 == y1 {
                break;
            }
            let e2 = 2 * err;
            if e2 >= dy {
                err += dy;
                x0 += sx;
            }
            if e2 <= dx {
                err += dx;
                y0 += sy;
            }
        }
    }

    /// Text with its top-left corner at `(x, y)`, each glyph `8 * scale`
    /// pixels square; characters without a glyph print as `?`.
    pub fn text(&mut self, x: i64, y: i64, s: &str, c: Rgb, scale: u32) {
        for (k, ch) in s.chars().enumerate() {
            let glyph = font8x8::BASIC_FONTS
                .get(ch)
                .or_else(|| font8x8::BASIC_FONTS.get('?'))
                .unwrap_or([0; 8]);
            let gx = x + (k as u32 * GLYPH * scale) as i64;
            for (row, bits) in glyph.iter().enumerate() {
                for col in 0..8 {
                    if bits >> col & 1 != 0 {
                        let (px, py) = (gx + col * scale as i64, y + row as i64 * scale as i64);
                        self.fill(px, py, scale, scale, c);
                    }
                }
            }
        }
    }

    /// Text rotated a quarter turn anticlockwise (reading upwards), its
    /// bottom-left corner at `(x, y)`.
    pub fn text_up(&mut self, x: i64, y: i64, s: &str, c: Rgb, scale: u32) {
        let mut tmp = Canvas::new(text_width(s, scale), GLYPH * scale, WHITE);
        tmp.text(0, 0, s, c, scale);
        for ty in 0..tmp.height {
            for tx in 0..tmp.width {
                if tmp.get(tx, ty) != WHITE {
                    self.set(x + ty as i64, y - tx as i64, c);
                }
            }
        }
    }

    /// Copy `img` (width `w`, 8-bit RGB) with its top-left corner at `(x, y)`.
    pub fn blit(&mut self, x: i64, y: i64, w: u32, img: &[u8]) {
        for (j, row) in img.chunks_exact(w as usize * 3).enumerate() {
            for (i, p) in row.chunks_exact(3).enumerate() {
                self.set(x + i as i64, y + j as i64, [p[0], p[1], p[2]]);
            }
        }
    }

    /// Write as PNG, atomically.
    pub fn save(&self, path: &Path) -> Result<()> {
        write_png_rgb8(path, self.width, self.height, &self.rgb)
    }
}

/// Width in pixels of `s` at `scale`.
pub fn text_width(s: &str, scale: u32) -> u32 {
    s.chars().count() as u32 * GLYPH * scale
}

/// One curve of a plot.
#[derive(Debug, Clone, PartialEq)]
pub struct Series {
    /// Legend label.
    pub label: String,
    /// `(x, y)` points, in order; points with a non-positive or non-finite
    /// coordinate are left out (the axes are logarithmic).
    pub points: Vec<(f64, f64)>,
}

/// The decades `10^k` covering `[lo, hi]` (at least one decade wide).
fn decades(lo: f64, hi: f64) -> (i32, i32) {
    let a = lo.log10().floor() as i32;
    let b = (hi.log10().ceil() as i32).max(a + 1);
    (a, b)
}

/// `10^k` written compactly: `0.01`, `1`, `1000`, `1e-05`, `1e+06`.
fn decade_label(k: i32) -> String {
    if (-2..=3).contains(&k) {
        format!("{}", 10f64.powi(k))
    } else {
        format!("1e{k}")
    }
}

/// A log-log line plot of `series` with a title, axis labels, decade grid
/// lines and a legend, `width` x `height` pixels.
pub fn log_log_plot(
    series: &[Series],
    title: &str,
    x_label: &str,
    y_label: &str,
    width: u32,
    height: u32,
) -> Canvas {
    let mut c = Canvas::new(width, height, WHITE);
    let pts: Vec<(f64, f64)> = series
        .iter()
        .flat_map(|s| s.points.iter().copied())
        .filter(|&(x, y)| x > 0.0 && y > 0.0 && x.is_finite() && y.is_finite())
        .collect();
    let (mut x_lo, mut x_hi, mut y_lo, mut y_hi) = (1.0, 10.0, 1.0, 10.0);
    if !pts.is_empty() {
        x_lo = pts.iter().map(|p| p.0).fold(f64::INFINITY, f64::min);
        x_hi = pts.iter().map(|p| p.0).fold(0.0, f64::max);
        y_lo = pts.iter().map(|p| p.1).fold(f64::INFINITY, f64::min);
        y_hi = pts.iter().map(|p| p.1).fold(0.0, f64::max);
    }
    let (xa, xb) = decades(x_lo, x_hi);
    let (ya, yb) = decades(y_lo, y_hi);
    // plot area: room for the title, tick labels and axis labels, legend
    let legend_w = series
        .iter()
        .map(|s| text_width(&s.label, 1) + 40)
        .max()
        .unwrap_or(0)
        .min(width / 3);
    let (left, top, right, bottom) = (
        90i64,
        40i64,
        width as i64 - legend_w as i64 - 20,
        height as i64 - 60,
    );
    let px =
        |x: f64| left as f64 + (x.log10() - xa as f64) / (xb - xa) as f64 * (right - left) as f64;
    let py =
        |y: f64| bottom as f64 - (y.log10() - ya as f64) / (yb - ya) as f64 * (bottom - top) as f64;
    for k in xa..=xb {
        let x = px(10f64.powi(k));
        c.line((x, top as f64), (x, bottom as f64), GRID, 1);
        let l = decade_label(k);
        c.text(
            x as i64 - text_width(&l, 1) as i64 / 2,
            bottom + 8,
            &l,
            BLACK,
            1,
        );
    }
    for k in ya..=yb {
        let y = py(10f64.powi(k));
        c.line((left as f64, y), (right as f64, y), GRID, 1);
        let l = decade_label(k);
        c.text(
            left - 8 - text_width(&l, 1) as i64,
            y as i64 - 4,
            &l,
            BLACK,
            1,
        );
    }
    c.line(
        (left as f64, top as f64),
        (left as f64, bottom as f64),
        BLACK,
        1,
    );
    c.line(
        (left as f64, bottom as f64),
        (right as f64, bottom as f64),
        BLACK,
        1,
    );
    c.text(
        (width as i64 - text_width(title, 2) as i64) / 2,
        8,
        title,
        BLACK,
        2,
    );
    let xl = text_width(x_label, 1) as i64;
    c.text((left + right) / 2 - xl / 2, bottom + 28, x_label, BLACK, 1);
    let yl = text_width(y_label, 1) as i64;
    c.text_up(16, (top + bottom) / 2 + yl / 2, y_label, BLACK, 1);
    for (k, s) in series.iter().enumerate() {
        let col = PALETTE[k % PALETTE.len()];
        let dash = if (k / PALETTE.len()) % 2 == 1 { 6 } else { 0 };
        let p: Vec<(f64, f64)> = s
            .points
            .iter()
            .filter(|&&(x, y)| x > 0.0 && y > 0.0 && x.is_finite() && y.is_finite())
            .map(|&(x, y)| (px(x), py(y)))
            .collect();
        for w in p.windows(2) {
            c.dashed_line(w[0], w[1], col, 2, dash);
        }
        for &q in &p {
            c.fill(q.0 as i64 - 2, q.1 as i64 - 2, 5, 5, col);
        }
        let ly = top + 10 + 16 * k as i64;
        let (l0, l1) = (
            ((right + 20) as f64, (ly + 4) as f64),
            ((right + 40) as f64, (ly + 4) as f64),
        );
        c.dashed_line(l0, l1, col, 3, dash.min(4));
        c.text(right + 46, ly, &s.label, BLACK, 1);
    }
    c
}

/// A grid of `cells` (8-bit RGB images, all `w` x `h`), `columns` wide,
/// each with up to two lines of label below it.
pub fn contact_sheet(cells: &[(Vec<u8>, [String; 2])], w: u32, h: u32, columns: u32) -> Canvas {
    let columns = columns.max(1);
    let rows = (cells.len() as u32).div_ceil(columns).max(1);
    let label_w = cells
        .iter()
        .flat_map(|(_, l)| l.iter().map(|s| text_width(s, 1)))
        .max()
        .unwrap_or(0);
    let cell_w = w.max(label_w) + 24;
    let cell_h = h + 2 * GLYPH + 16;
    let mut c = Canvas::new(cell_w * columns, cell_h * rows, WHITE);
    for (k, (img, label)) in cells.iter().enumerate() {
        let (cx, cy) = (
            (k as u32 % columns * cell_w) as i64,
            (k as u32 / columns * cell_h) as i64,
        );
        c.blit(cx + 6, cy + 6, w, img);
        for (line, s) in label.iter().enumerate() {
            c.text(
                cx + 6,
                cy + 8 + h as i64 + (line as u32 * (GLYPH + 2)) as i64,
                s,
                BLACK,
                1,
            );
        }
    }
    c
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn text_and_lines_land_where_asked() {
        let mut c = Canvas::new(40, 20, WHITE);
        c.text(0, 0, "I", BLACK, 1);
        assert!((0..8).any(|x| c.get(x, 3) == BLACK), "the I's stem");
        assert!((8..40).all(|x| (0..8).all(|y| c.get(x, y) == WHITE)));
        c.line((10.0, 15.0), (30.0, 15.0), [255, 0, 0], 1);
        assert!((10..=30).all(|x| c.get(x, 15) == [255, 0, 0]));
        assert_eq!(c.get(9, 15), WHITE);
        let mut up = Canvas::new(20, 40, WHITE);
        up.text_up(2, 30, "ab", BLACK, 1);
        assert!((0..20).any(|x| (14..31).any(|y| up.get(x, y) == BLACK)));
    }

    #[test]
    fn plot_draws_every_series_in_its_colour() {
        let s = vec![
            Series {
                label: "a".into(),
                points: vec![(0.1, 1.0), (1.0, 0.1), (10.0, 0.01)],
            },
            Series {
                label: "b".into(),
                points: vec![(0.2, 2.0), (2.0, 0.5), (-1.0, f64::NAN)],
            },
        ];
        let c = log_log_plot(&s, "t", "seconds", "error", 400, 300);
        for col in &PALETTE[..2] {
            assert!(c.rgb.chunks_exact(3).any(|p| p == col), "{col:?} missing");
        }
        assert!(!c.rgb.chunks_exact(3).any(|p| p == PALETTE[2]));
    }

    #[test]
    fn contact_sheet_places_cells_in_a_grid() {
        let red = [255u8, 0, 0].repeat(4 * 4);
        let blue = [0u8, 0, 255].repeat(4 * 4);
        let l = || ["x".to_string(), String::new()];
        let c = contact_sheet(&[(red, l()), (blue.clone(), l()), (blue, l())], 4, 4, 2);
        assert_eq!(c.get(7, 7), [255, 0, 0]);
        assert!(c.rgb.chunks_exact(3).filter(|p| *p == [0, 0, 255]).count() == 32);
        assert_eq!(c.height % 2, 0);
    }
}
