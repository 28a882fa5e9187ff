//! Piecewise-constant densities on `[0, 1)` and `[0, 1)^2`, sampled by exact
//! inversion of their cumulative distribution (pbrt-v4 section A.5,
//! `PiecewiseConstant1D` and `PiecewiseConstant2D`).
//!
//! A 1D function given by `n` non-negative cell values is the density
//! `p(x) = f[i] / I` on cell `i = floor(x n)`, where `I = sum f / n` is its
//! integral. Sampling finds the cell whose cumulative range holds `u` and
//! inverts linearly inside it, so `x` is a continuous point, not a cell index.
//! The 2D density is the product of a marginal over rows (each row weighted by
//! its integral) and the 1D conditional of the chosen row.
//!
//! Guarantees:
//! - a cell of value zero (or a row of integral zero) is never sampled, for any
//!   `u` in `[0, 1]`, including the extremes 0 and 1;
//! - the sampled point lies in `[0, 1)` and inside the chosen cell, so
//!   `pdf(sample.x)` returns exactly the density that `sample` reported;
//! - negative, NaN and infinite cell values count as zero;
//! - all-zero input falls back to the uniform density (pdf 1 everywhere), as
//!   pbrt-v4 does, so a caller never divides by a zero integral; callers that
//!   must not sample such a function check [`PiecewiseConstant1D::integral`].
//!
//! The cumulative sums are kept in `f64`, so a large map's table loses no cell
//! to rounding; the resolution of a draw is still that of its `f32` number `u`
//! (24 bits), so a cell whose probability is far below 2^-24 is rarely or
//! never reached, though its density is positive (a bias of that order).

use crate::math::Vec2;

/// A piecewise-constant density on `[0, 1)` with `n` equal cells.
#[derive(Debug, Clone)]
pub struct PiecewiseConstant1D {
    /// Cell values (non-negative, finite).
    func: Vec<f32>,
    /// `cdf[i]` is the integral of the function over `[0, i / n)`, not
    /// normalised; `cdf[n]` is the integral. For all-zero input, `i / n`.
    cdf: Vec<f64>,
    /// Integral of the function over `[0, 1)` (0 for all-zero input).
    integral: f64,
    /// A guide table (Chen and Asau 1974; Devroye, "Non-Uniform Random
    /// Variate Generation", 1986, section III.2.4): `guide[k]` is the cell
    /// that the target `k / n` of the total falls in, so a draw searches only
    /// between two neighbouring entries (a cell or two on average) instead
    /// of bisecting the whole table: one or two dependent loads where a
    /// 512-wide environment map's row and column took eighteen.
    guide: Vec<u32>,
}

/// One draw from a [`PiecewiseConstant1D`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sample1D {
    /// The point, in `[0, 1)`.
    pub x: f32,
    /// Its density, `> 0`.
    pub pdf: f32,
    /// The cell it lies in: `floor(x n)`.
    pub cell: usize,
}

/// One draw from a [`PiecewiseConstant2D`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sample2D {
    /// The point, in `[0, 1)^2`; `x` runs along a row, `y` across rows.
    pub p: Vec2,
    /// Its density with respect to area on the unit square, `> 0`.
    pub pdf: f32,
    /// The cell it lies in: `[column, row]`.
    pub cell: [usize; 2],
}

impl PiecewiseConstant1D {
    /// The density proportional to the cell values `func` (at least one cell).
    ///
    /// # Panics
    /// If `func` is empty: a distribution needs a domain.
    pub fn new(func: &[f32]) -> Self {
        // every f32 is exact in f64 and back
        Self::from_f64(&func.iter().map(|&f| f as f64).collect::<Vec<_>>())
    }

    /// The density proportional to `weights`, kept in `f64` for the
    /// cumulative table (negative and non-finite values count as zero).
    pub(crate) fn from_f64(weights: &[f64]) -> Self {
        assert!(
            !weights.is_empty(),
            "a piecewise-constant function needs a cell"
        );
        let weights: Vec<f64> = weights
            .iter()
            .map(|&w| if w.is_finite() && w > 0.0 { w } else { 0.0 })
            .collect();
        let func = weights.iter().map(|&w| w as f32).collect();
        Self::with_weights(func, &weights)
    }

    /// The distribution over cells with values `func` (already non-negative)
    /// whose cumulative table is built from `weights` (the same values, in
    /// `f64` where the caller has them more exactly).
    fn with_weights(func: Vec<f32>, weights: &[f64]) -> Self {
        assert!(
            u32::try_from(func.len()).is_ok(),
            "{} cells: at most 2^32 - 1",
            func.len()
        );
        let n = func.len() as f64;
        let mut cdf = Vec::with_capacity(func.len() + 1);
        cdf.push(0.0);
        let mut acc = 0.0f64;
        for &w in weights {
            acc += w / n;
            cdf.push(acc);
        }
        let integral = acc;
        if !(integral > 0.0) {
            // all zero: uniform
            for (i, c) in cdf.iter_mut().enumerate() {
                *c = i as f64 / n;
            }
        }
        let guide = guide_table(&cdf);
        PiecewiseConstant1D {
            func,
            cdf,
            integral,
            guide,
        }
    }

    /// Number of cells.
    pub fn len(&self) -> usize {
        self.func.len()
    }

    /// Always false: a distribution has at least one cell.
    pub fn is_empty(&self) -> bool {
        self.func.is_empty()
    }

    /// Integral of the function over `[0, 1)`: the mean cell value. Zero means
    /// the all-zero input, sampled uniformly.
    pub fn integral(&self) -> f64 {
        self.integral
    }

    /// The cell values (after negative and non-finite ones were zeroed).
    pub fn func(&self) -> &[f32] {
        &self.func
    }

    /// The cell holding `x` (points outside `[0, 1)` are clamped to the first
    /// or last cell).
    #[inline]
    pub fn cell_of(&self, x: f32) -> usize {
        cell_index(x, self.func.len())
    }

    /// Density of cell `i`.
    #[inline]
    pub fn pdf_cell(&self, i: usize) -> f32 {
        if self.integral > 0.0 {
            (self.func[i] as f64 / self.integral) as f32
        } else {
            1.0
        }
    }

    /// Density at `x`.
    #[inline]
    pub fn pdf(&self, x: f32) -> f32 {
        self.pdf_cell(self.cell_of(x))
    }

    /// The cell whose cumulative range holds `u` (clamped to `[0, 1]`), a
    /// cell of positive probability, and where in that range `u` falls, in
    /// `[0, 1]`: for a caller that samples inside the cell by a density of
    /// its own.
    #[inline]
    pub fn locate(&self, u: f32) -> (usize, f64) {
        locate(&self.cdf, &self.guide, u)
    }

    /// The point whose cumulative probability is `u` (clamped to `[0, 1]`).
    pub fn sample(&self, u: f32) -> Sample1D {
        let (x, i) = invert(&self.cdf, &self.guide, u);
        Sample1D {
            x,
            pdf: self.pdf_cell(i),
            cell: i,
        }
    }
}

/// The guide table of the cumulative table `cdf` (`n + 1` entries, `n`
/// cells): entry `k` of `n + 1` is the cell whose range holds the fraction
/// `k / n` of the total (see [`PiecewiseConstant1D`]).
pub(crate) fn guide_table(cdf: &[f64]) -> Vec<u32> {
    let n = cdf.len() - 1;
    let total = cdf[n];
    (0..=n)
        .map(|k| {
            let target = k as f64 / n as f64 * total;
            cdf[1..].partition_point(|&c| c <= target).min(n - 1) as u32
        })
        .collect()
}

/// The cell of `n` (`0 < n < 2^32`) equal cells on `[0, 1)` that holds `x`
/// (points outside are clamped to the first or last cell).
#[inline]
fn cell_index(x: f32, n: usize) -> usize {
    // x has 24 significant bits, so for n < 2^29 the product is exact and
    // truncating a positive product is the floor; for larger tables it may
    // round up across a cell boundary, which moves a point by one cell but
    // keeps draws and densities consistent, since both find cells here.
    // Through u32, not usize: x86-64 converts between f64 and u32 in one
    // instruction, and saturating at 2^32 - 1 gives the same clamp.
    let i = x as f64 * n as u32 as f64;
    if i > 0.0 {
        (i as u32 as usize).min(n - 1)
    } else {
        0
    }
}

/// The cell `i` whose cumulative range holds the fraction `u` (clamped to
/// `[0, 1]`) of the total, a cell of positive probability, and where in that
/// range `u` falls, `du` in `[0, 1]` (in `f64`, finer than a point of
/// [`invert`] can say).
#[inline]
fn locate(cdf: &[f64], guide: &[u32], u: f32) -> (usize, f64) {
    let n = cdf.len() - 1;
    // n < 2^32 (checked when the table was built): exact in f64, and one
    // instruction from u32
    let nf = n as u32 as f64;
    let total = cdf[n];
    let u = (u as f64).clamp(0.0, 1.0);
    let target = u * total;
    // the first cell whose upper cumulative bound exceeds the target has
    // `cdf[i] <= target < cdf[i + 1]`, so it has positive probability;
    // the guide narrows the search, and the answer is checked against
    // that definition (rounding can put it one entry off the guide's
    // range, when the whole table is searched instead)
    let k = ((u * nf) as u32 as usize).min(n - 1);
    let (lo, hi) = (guide[k] as usize, guide[k + 1] as usize);
    let mut i = lo + cdf[1 + lo..=1 + hi].partition_point(|&c| c <= target);
    let first = (i == 0 || cdf[i] <= target) && (i >= n || cdf[i + 1] > target);
    if !first {
        i = cdf[1..].partition_point(|&c| c <= target);
    }
    if i >= n {
        // u == 1: the last cell with positive probability, at its top
        i = cdf[1..].partition_point(|&c| c < total);
    }
    let (lo, hi) = (cdf[i], cdf[i + 1]);
    (i, ((target - lo) / (hi - lo)).clamp(0.0, 1.0))
}

/// The point `x` whose cumulative probability is `u` (clamped to `[0, 1]`)
/// and its cell `i`, for the cumulative table `cdf` of `n` cells (`n + 1`
/// entries, see [`PiecewiseConstant1D`]) and its guide table `guide`.
#[inline]
fn invert(cdf: &[f64], guide: &[u32], u: f32) -> (f32, usize) {
    let (i, du) = locate(cdf, guide, u);
    let n = cdf.len() - 1;
    let nf = n as u32 as f64;
    let mut x = ((i as u32 as f64 + du) / nf) as f32;
    // Rounding to f32 can carry x onto a cell boundary: keep it in cell
    // i (and below 1), so that `pdf(x)` is the density reported here.
    while cell_index(x, n) > i || x >= 1.0 {
        x = crate::math::next_float_down(x);
    }
    while cell_index(x, n) < i {
        x = crate::math::next_float_up(x);
    }
    (x, i)
}

/// A piecewise-constant density on `[0, 1)^2` over a grid of `nx` columns by
/// `ny` rows: the marginal density picks a row `y`, the row's conditional
/// density picks `x`.
///
/// The rows' tables lie one after another in flat arrays, and the density
/// of every cell is kept ready, so a draw or a density lookup goes straight
/// to its row's entries (no row object to load first) and divides nothing.
#[derive(Debug, Clone)]
pub struct PiecewiseConstant2D {
    /// Columns.
    nx: usize,
    /// The rows' cumulative tables ([`PiecewiseConstant1D`]'s `cdf`),
    /// `nx + 1` entries each, row 0 first.
    cdf: Vec<f64>,
    /// The rows' guide tables, `nx + 1` entries each.
    guide: Vec<u32>,
    /// Density of each cell with respect to area, row-major:
    /// `f / integral` rounded to `f32` (1 everywhere for all-zero input).
    pdf: Vec<f32>,
    /// Over rows, weighted by each row's integral.
    marginal: PiecewiseConstant1D,
}

impl PiecewiseConstant2D {
    /// The density proportional to `func`, `nx` values per row, `ny` rows,
    /// row-major (row 0 first; it covers `y` in `[0, 1 / ny)`).
    ///
    /// # Panics
    /// If `nx` or `ny` is 0 or `func.len() != nx * ny`.
    pub fn new(func: &[f32], nx: usize, ny: usize) -> Self {
        assert!(nx > 0 && ny > 0, "a 2D distribution needs a cell");
        assert_eq!(func.len(), nx * ny, "{nx} x {ny} cells");
        let rows: Vec<PiecewiseConstant1D> = func
            .chunks_exact(nx)
            .map(PiecewiseConstant1D::new)
            .collect();
        // the marginal's table uses the rows' f64 integrals, so rows of tiny
        // weight keep their exact share
        let row_integrals: Vec<f64> = rows.iter().map(|r| r.integral()).collect();
        let row_func: Vec<f32> = row_integrals.iter().map(|&w| w as f32).collect();
        let marginal = PiecewiseConstant1D::with_weights(row_func, &row_integrals);
        let total = marginal.integral;
        let mut cdf = Vec::with_capacity(ny * (nx + 1));
        let mut guide = Vec::with_capacity(ny * (nx + 1));
        let mut pdf = Vec::with_capacity(nx * ny);
        for row in &rows {
            cdf.extend_from_slice(&row.cdf);
            guide.extend_from_slice(&row.guide);
            pdf.extend(row.func.iter().map(|&f| {
                if total > 0.0 {
                    (f as f64 / total) as f32
                } else {
                    1.0
                }
            }));
        }
        PiecewiseConstant2D {
            nx,
            cdf,
            guide,
            pdf,
            marginal,
        }
    }

    /// Number of columns and rows.
    pub fn size(&self) -> [usize; 2] {
        [self.nx, self.marginal.len()]
    }

    /// Integral of the function over the unit square (0 for all-zero input,
    /// which is sampled uniformly).
    pub fn integral(&self) -> f64 {
        self.marginal.integral
    }

    /// Density of cell `[column, row]` with respect to area.
    #[inline]
    pub fn pdf_cell(&self, cell: [usize; 2]) -> f32 {
        assert!(cell[0] < self.nx, "column {} of {}", cell[0], self.nx);
        self.pdf[cell[1] * self.nx + cell[0]]
    }

    /// The cell holding `p` (clamped onto the grid).
    #[inline]
    pub fn cell_of(&self, p: Vec2) -> [usize; 2] {
        [cell_index(p.x, self.nx), self.marginal.cell_of(p.y)]
    }

    /// Density at `p` with respect to area on the unit square.
    #[inline]
    pub fn pdf(&self, p: Vec2) -> f32 {
        self.pdf_cell(self.cell_of(p))
    }

    /// The point for `u` in `[0, 1]^2`: `u.y` picks the row, `u.x` the point
    /// along it.
    #[inline]
    pub fn sample(&self, u: Vec2) -> Sample2D {
        let (y, row) = invert(&self.marginal.cdf, &self.marginal.guide, u.y);
        let entries = row * (self.nx + 1)..(row + 1) * (self.nx + 1);
        let (x, column) = invert(&self.cdf[entries.clone()], &self.guide[entries], u.x);
        let cell = [column, row];
        Sample2D {
            p: Vec2::new(x, y),
            pdf: self.pdf_cell(cell),
            cell,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampler::Sampler;

    /// 0, the smallest subnormal 2^-149, 0.5, the largest f32 below 1, and 1.
    const EXTREMES: [f32; 5] = [0.0, 1.4e-45, 0.5, 1.0 - 5.96e-8, 1.0];

    #[test]
    fn the_guide_table_finds_the_cell_a_full_search_finds() {
        // tables with runs of zeros, spikes and smooth parts; every u of a
        // fine grid and the extremes: the guided search must return the
        // cell the definition gives (first cell whose upper bound exceeds
        // the target), which is what bisecting the whole table returns
        let mut r = Sampler::new(9, 0, 0);
        for n in [1usize, 2, 3, 7, 64, 511, 1000] {
            let func: Vec<f32> = (0..n)
                .map(|i| match (i * 7 + n) % 5 {
                    0 => 0.0,
                    1 => 1e4,
                    _ => r.next_1d() + 1e-3,
                })
                .collect();
            let d = PiecewiseConstant1D::new(&func);
            let total = d.cdf[n];
            let mut us: Vec<f32> = (0..20_000).map(|k| k as f32 / 20_000.0).collect();
            us.extend([0.0, 1.4e-45, 1.0 - 5.96e-8, 1.0]);
            for u in us {
                let target = (u as f64).clamp(0.0, 1.0) * total;
                let mut want = d.cdf[1..].partition_point(|&c| c <= target);
                if want >= n {
                    want = d.cdf[1..].partition_point(|&c| c < total);
                }
                assert_eq!(d.sample(u).cell, want, "n {n}, u {u}");
            }
        }
    }

    #[test]
    fn one_d_inverts_its_cdf_exactly() {
        let d = PiecewiseConstant1D::new(&[1.0, 0.0, 3.0, 0.0]);
        assert_eq!(d.integral(), 1.0);
        // cdf: [0, 0.25, 0.25, 1.0, 1.0]
        let s = d.sample(0.125);
        assert_eq!((s.x, s.pdf, s.cell), (0.125, 1.0, 0));
        let s = d.sample(0.25);
        assert_eq!((s.x, s.cell), (0.5, 2));
        let s = d.sample(0.625);
        assert_eq!((s.x, s.pdf, s.cell), (0.625, 3.0, 2));
        assert_eq!(d.pdf(0.3), 0.0);
        assert_eq!(d.pdf(0.74), 3.0);
    }

    #[test]
    fn zero_cells_are_never_sampled_even_at_the_extremes() {
        let d = PiecewiseConstant1D::new(&[0.0, 2.0, 0.0, 0.0, 5.0, 0.0]);
        for &u in &EXTREMES {
            let s = d.sample(u);
            assert!(s.cell == 1 || s.cell == 4, "u={u} chose cell {}", s.cell);
            assert!((0.0..1.0).contains(&s.x) && s.pdf > 0.0);
            assert_eq!(d.pdf(s.x), s.pdf, "u={u}");
            assert_eq!(d.cell_of(s.x), s.cell);
        }
        let mut r = Sampler::new(3, 0, 0);
        for _ in 0..100_000 {
            let s = d.sample(r.next_1d());
            assert!(s.cell == 1 || s.cell == 4);
            assert_eq!(d.pdf(s.x), s.pdf);
        }
    }

    #[test]
    fn all_zero_and_bad_values_fall_back_to_uniform() {
        let d = PiecewiseConstant1D::new(&[0.0, f32::NAN, -1.0, f32::INFINITY]);
        assert_eq!(d.integral(), 0.0);
        for &u in &EXTREMES {
            let s = d.sample(u);
            assert_eq!(s.pdf, 1.0);
            assert!((0.0..1.0).contains(&s.x));
            assert!(
                (s.x - u).abs() <= 6e-8,
                "uniform: x = u, got {} for {u}",
                s.x
            );
        }
        let d2 = PiecewiseConstant2D::new(&[0.0; 6], 3, 2);
        assert_eq!(d2.integral(), 0.0);
        let s = d2.sample(Vec2::new(0.7, 0.2));
        assert_eq!(s.pdf, 1.0);
        assert!((s.p - Vec2::new(0.7, 0.2)).length() < 1e-6);
        assert_eq!(d2.pdf(Vec2::new(0.1, 0.9)), 1.0);
    }

    #[test]
    fn two_d_skips_zero_rows_and_cells() {
        // row 1 is all zero; column 0 of row 0 is zero
        let f = [0.0, 1.0, 2.0, 0.0, 0.0, 0.0, 4.0, 0.0, 1.0];
        let d = PiecewiseConstant2D::new(&f, 3, 3);
        let integral: f64 = f.iter().map(|&v| v as f64).sum::<f64>() / 9.0;
        assert!((d.integral() - integral).abs() < 1e-15);
        let mut points = Vec::new();
        for &a in &EXTREMES {
            for &b in &EXTREMES {
                points.push(Vec2::new(a, b));
            }
        }
        let mut r = Sampler::new(4, 0, 0);
        points.extend((0..100_000).map(|_| r.next_2d()));
        for u in points {
            let s = d.sample(u);
            let [cx, cy] = s.cell;
            assert!(f[cy * 3 + cx] > 0.0, "{u:?} chose zero cell {:?}", s.cell);
            assert!(s.p.x >= 0.0 && s.p.x < 1.0 && s.p.y >= 0.0 && s.p.y < 1.0);
            assert_eq!(d.cell_of(s.p), s.cell);
            assert_eq!(d.pdf(s.p), s.pdf);
            let expect = (f[cy * 3 + cx] as f64 / integral) as f32;
            assert!((s.pdf - expect).abs() <= 1e-6 * expect);
        }
    }
}
