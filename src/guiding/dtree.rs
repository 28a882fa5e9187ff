//! The directional half of an SD-tree (Müller, Gross and Novák 2017,
//! "Practical Path Guiding for Efficient Light-Transport Simulation",
//! section 3): a quadtree over the unit square, which the cylindrical map
//! [`square_to_dir`] lays over the sphere of directions with equal area,
//! so a cell's share of the square is its share of solid angle.
//!
//! Each node holds the energy of its four quadrants; a quadrant either is
//! a leaf or points to a child node. A [`BuildTree`] sums the energy of the
//! records of one training iteration (in `f64`, in the order they come);
//! [`BuildTree::to_sampling`] freezes it into a [`SampleTree`], which draws
//! directions in proportion to that energy; [`BuildTree::refined`] lays out
//! the next iteration's tree, subdividing where a quadrant holds more than
//! [`SUBDIVIDE_FRACTION`] of the energy and merging where it holds less.

use crate::math::{Vec2, Vec3};
use std::f32::consts::PI;

/// A quadrant holding more than this share of a tree's energy is split in
/// the next iteration (Müller et al. 2017's `rho = 0.01`).
pub const SUBDIVIDE_FRACTION: f64 = 0.01;

/// The deepest a quadtree grows (Müller et al. 2017: 20 levels).
pub const MAX_DEPTH: u32 = 20;

/// The largest f32 below 1.
const ONE_MINUS_EPSILON: f32 = 1.0 - f32::EPSILON / 2.0;

/// The unit square's point for direction `d` (unit length): `x` is
/// `(cos theta + 1) / 2`, `y` is `phi / 2 pi`. Equal-area: the Jacobian of
/// [`square_to_dir`] is `4 pi` everywhere. The azimuth comes from
/// [`crate::math::trig::atan2`] (no C library call: glibc's `atan2f` was
/// 3 % of a guided render's time).
#[inline]
pub fn dir_to_square(d: Vec3) -> Vec2 {
    let x = ((d.z.clamp(-1.0, 1.0) + 1.0) * 0.5).min(ONE_MINUS_EPSILON);
    let mut phi = crate::math::trig::atan2(d.y, d.x);
    if phi < 0.0 {
        phi += 2.0 * PI;
    }
    let y = (phi * (0.5 / PI)).clamp(0.0, ONE_MINUS_EPSILON);
    Vec2::new(x, y)
}

/// The direction at point `q` of the unit square ([`dir_to_square`]'s
/// inverse).
#[inline]
pub fn square_to_dir(q: Vec2) -> Vec3 {
    let cos_theta = 2.0 * q.x - 1.0;
    let sin_theta = (1.0 - cos_theta * cos_theta).max(0.0).sqrt();
    let (s, c) = (2.0 * PI * q.y).sin_cos();
    Vec3::new(sin_theta * c, sin_theta * s, cos_theta)
}

/// Which quadrant of a node `q` (in the node's own unit square) falls in,
/// and `q` in that quadrant's unit square. Quadrant `i` has `x` half
/// `i & 1` and `y` half `i >> 1`.
#[inline]
fn quadrant(q: Vec2) -> (usize, Vec2) {
    let ix = usize::from(q.x >= 0.5);
    let iy = usize::from(q.y >= 0.5);
    let child = Vec2::new(
        (q.x * 2.0 - ix as f32).clamp(0.0, ONE_MINUS_EPSILON),
        (q.y * 2.0 - iy as f32).clamp(0.0, ONE_MINUS_EPSILON),
    );
    (ix + 2 * iy, child)
}

/// A node while it gathers energy: its quadrants' sums, and per quadrant
/// the child node's index (0 for a leaf quadrant: the root is node 0 and
/// never anyone's child).
#[derive(Debug, Clone, PartialEq)]
struct BuildNode {
    sum: [f64; 4],
    child: [u32; 4],
}

const EMPTY: BuildNode = BuildNode {
    sum: [0.0; 4],
    child: [0; 4],
};

/// A quadtree gathering one iteration's energy.
#[derive(Debug, Clone, PartialEq)]
pub struct BuildTree {
    nodes: Vec<BuildNode>,
}

impl Default for BuildTree {
    fn default() -> Self {
        BuildTree { nodes: vec![EMPTY] }
    }
}

impl BuildTree {
    /// Add `value` at point `q` of the square: to the quadrant holding `q`
    /// at every level down to its leaf. Training filters its records
    /// ([`BuildTree::add_filtered`]); the tests build trees with this.
    #[cfg(test)]
    fn add(&mut self, q: Vec2, value: f64) {
        let mut node = 0usize;
        let mut q = q;
        loop {
            let (i, inner) = quadrant(q);
            self.nodes[node].sum[i] += value;
            match self.nodes[node].child[i] {
                0 => return,
                c => {
                    node = c as usize;
                    q = inner;
                }
            }
        }
    }

    /// Add `value` spread over a box around point `q` the size of the leaf
    /// cell holding `q` (Müller 2019's directional box filter), in
    /// proportion to the box's overlap with each cell: the box wraps around
    /// in `y` (the azimuth) and is clipped to the square in `x`, its value
    /// kept whole.
    pub fn add_filtered(&mut self, q: Vec2, value: f64) {
        let mut size = 1.0f64;
        let mut node = 0usize;
        let mut inner = q;
        loop {
            let (i, next) = quadrant(inner);
            size *= 0.5;
            match self.nodes[node].child[i] {
                0 => break,
                c => {
                    node = c as usize;
                    inner = next;
                }
            }
        }
        let (x, y) = (q.x as f64, q.y as f64);
        let x0 = (x - 0.5 * size).max(0.0);
        let x1 = (x + 0.5 * size).min(1.0);
        let density = value / ((x1 - x0) * size);
        let (y0, y1) = (y - 0.5 * size, y + 0.5 * size);
        // the box's parts within the square, the azimuth wrapped
        let parts = [(y0.max(0.0), y1.min(1.0)), (y0 + 1.0, 1.0), (0.0, y1 - 1.0)];
        for (lo, hi) in parts {
            if hi > lo {
                self.splat(0, [0.0, 0.0], 1.0, [x0, x1, lo, hi], density);
            }
        }
    }

    /// Add `density` times the overlap of box `b` (`[x0, x1, y0, y1]`) with
    /// each quadrant of node `node`, whose square has corner `origin` and
    /// side `side`, recursively.
    fn splat(&mut self, node: usize, origin: [f64; 2], side: f64, b: [f64; 4], density: f64) {
        let half = 0.5 * side;
        for i in 0..4 {
            let qx = origin[0] + half * (i & 1) as f64;
            let qy = origin[1] + half * (i >> 1) as f64;
            let w = (b[1].min(qx + half) - b[0].max(qx)).max(0.0);
            let h = (b[3].min(qy + half) - b[2].max(qy)).max(0.0);
            if w * h > 0.0 {
                self.nodes[node].sum[i] += density * w * h;
                if let c @ 1.. = self.nodes[node].child[i] {
                    self.splat(c as usize, [qx, qy], half, b, density);
                }
            }
        }
    }

    /// The energy of all records added.
    pub fn total(&self) -> f64 {
        self.nodes[0].sum.iter().sum()
    }

    /// Nodes in the tree (for the report).
    pub fn node_count(&self) -> usize {
        self.nodes.len()
    }

    /// The energy frozen into a tree that samples in proportion to it.
    pub fn to_sampling(&self) -> SampleTree {
        let total = self.total();
        SampleTree::with_nodes(
            self.nodes
                .iter()
                .map(|n| SampleNode::new(n.sum.map(|s| s as f32), n.child))
                .collect(),
            total > 0.0 && total.is_finite(),
        )
    }

    /// The next iteration's empty tree: a quadrant whose share of the
    /// energy exceeds [`SUBDIVIDE_FRACTION`] gets a child (whose quadrants
    /// inherit this tree's sums below it, or a quarter of the quadrant's
    /// where this tree stops), recursively, to [`MAX_DEPTH`] levels; the
    /// rest are leaves. With no energy, a single node.
    pub fn refined(&self) -> BuildTree {
        let total = self.total();
        let mut out = BuildTree::default();
        if !(total > 0.0) {
            return out;
        }
        // (new node, old node or none, the sums the new node's quadrants
        // start from, depth)
        let mut stack: Vec<(usize, Option<usize>, [f64; 4], u32)> =
            vec![(0, Some(0), self.nodes[0].sum, 1)];
        while let Some((new, old, sums, depth)) = stack.pop() {
            for (i, &sum) in sums.iter().enumerate() {
                if depth >= MAX_DEPTH || sum / total <= SUBDIVIDE_FRACTION {
                    continue;
                }
                let old_child = old
                    .map(|o| self.nodes[o].child[i])
                    .filter(|&c| c != 0)
                    .map(|c| c as usize);
                let child_sums = match old_child {
                    Some(c) => self.nodes[c].sum,
                    None => [sum / 4.0; 4],
                };
                let idx = out.nodes.len();
                out.nodes.push(EMPTY);
                out.nodes[new].child[i] = idx as u32;
                stack.push((idx, old_child, child_sums, depth + 1));
            }
        }
        out
    }
}

/// A node of a frozen tree, with what sampling and density lookups need
/// precomputed from its quadrants' energies `s`: the probability of the
/// lower x half (`s[0] + s[2]` of the total), of the lower y half within
/// each x half, and per quadrant its density factor `4 s[i] / total`. A
/// node without energy is uniform.
#[derive(Debug, Clone, PartialEq)]
struct SampleNode {
    p_left: f32,
    p_low: [f32; 2],
    factor: [f32; 4],
    child: [u32; 4],
}

impl SampleNode {
    fn new(s: [f32; 4], child: [u32; 4]) -> Self {
        let total = s[0] + s[1] + s[2] + s[3];
        if !(total > 0.0 && total.is_finite()) {
            return SampleNode {
                p_left: 0.5,
                p_low: [0.5; 2],
                factor: [1.0; 4],
                child,
            };
        }
        let half = |a: f32, b: f32| if a + b > 0.0 { a / (a + b) } else { 0.5 };
        SampleNode {
            p_left: (s[0] + s[2]) / total,
            p_low: [half(s[0], s[2]), half(s[1], s[3])],
            factor: s.map(|x| 4.0 * x / total),
            child,
        }
    }
}

/// A quadtree frozen from a [`BuildTree`]: draws points of the square, and
/// so directions, in proportion to the energy it was built from.
#[derive(Debug, Clone, PartialEq)]
pub struct SampleTree {
    nodes: Vec<SampleNode>,
    /// The density walk's first [`TOP_LEVELS`] levels, per path through
    /// them (the point's top digits, `x` in the low half of the index):
    /// the density so far, and the node reached at that depth, or 0 where
    /// a leaf ended the walk and the density is the answer.
    top: Vec<(f32, u32)>,
    usable: bool,
}

/// The levels of a quadtree that [`SampleTree::pdf`] reads from a table:
/// 256 entries, 2 KB per spatial leaf, in place of four dependent loads
/// from nodes scattered over the tree. Against 3 levels (64 entries), door
/// scene, `--guiding on`, one thread, the binaries alternating: 0.967x the
/// time at 64 spp (5 rounds), 0.983x at 256 (3 rounds); 5 levels gained no
/// more (0.969x, 0.988x) at four times the memory.
const TOP_LEVELS: u32 = 4;

impl Default for SampleTree {
    fn default() -> Self {
        BuildTree::default().to_sampling()
    }
}

/// One choice between two halves with probability `p` of the first: the
/// half, and `u` rescaled to `[0, 1)` within it.
#[inline]
fn choose(u: f32, p: f32) -> (usize, f32) {
    if u < p {
        (0, (u / p).min(ONE_MINUS_EPSILON))
    } else {
        (1, ((u - p) / (1.0 - p)).clamp(0.0, ONE_MINUS_EPSILON))
    }
}

impl SampleTree {
    /// The tree over `nodes` (root first), with its density table.
    fn with_nodes(nodes: Vec<SampleNode>, usable: bool) -> Self {
        let side = 1u32 << TOP_LEVELS;
        let top = (0..side * side)
            .map(|cell| {
                let (x, y) = (cell % side, cell / side);
                let mut node = 0usize;
                let mut pdf = 1.0f32 / (4.0 * PI);
                for bit in (0..TOP_LEVELS).rev() {
                    let i = ((x >> bit) & 1) as usize | ((((y >> bit) & 1) as usize) << 1);
                    pdf *= nodes[node].factor[i];
                    match nodes[node].child[i] {
                        0 => return (pdf, 0),
                        c => node = c as usize,
                    }
                }
                (pdf, node as u32)
            })
            .collect();
        SampleTree { nodes, top, usable }
    }

    /// Whether the tree has energy to sample from.
    #[inline]
    pub fn is_usable(&self) -> bool {
        self.usable
    }

    /// A direction drawn in proportion to the energy, and its solid-angle
    /// density. Only for a usable tree ([`SampleTree::is_usable`]).
    pub fn sample(&self, u: Vec2) -> (Vec3, f32) {
        let (mut ux, mut uy) = (u.x, u.y);
        let mut node = &self.nodes[0];
        let mut origin = Vec2::ZERO;
        let mut size = 1.0f32;
        let mut pdf = 1.0f32 / (4.0 * PI);
        loop {
            // x half first, then the y half within it
            let (ix, x) = choose(ux, node.p_left);
            let (iy, y) = choose(uy, node.p_low[ix]);
            (ux, uy) = (x, y);
            let i = ix + 2 * iy;
            pdf *= node.factor[i];
            size *= 0.5;
            origin += Vec2::new(ix as f32, iy as f32) * size;
            match node.child[i] {
                0 => break,
                c => node = &self.nodes[c as usize],
            }
        }
        let q =
            (origin + Vec2::new(ux, uy) * size).clamp(Vec2::ZERO, Vec2::splat(ONE_MINUS_EPSILON));
        (square_to_dir(q), pdf)
    }

    /// The solid-angle density [`SampleTree::sample`] draws direction `d`
    /// with (0 for a tree without energy).
    pub fn pdf(&self, d: Vec3) -> f32 {
        if !self.usable {
            return 0.0;
        }
        // The quadrant at depth k is bit k of the point's binary fraction
        // in each coordinate ([`quadrant`]'s doubling is exact), so the
        // walk reads the bits of the point scaled to 24-bit integers: the
        // same quadrants, with nothing but the next node's load between
        // one level and the next
        const _: () = assert!(MAX_DEPTH <= 24);
        let q = dir_to_square(d);
        let scale = (1u32 << 24) as f32;
        let (x, y) = ((q.x * scale) as u32, (q.y * scale) as u32);
        // the first levels from the table: the same factors, multiplied
        // in the same order
        let shift = 24 - TOP_LEVELS;
        let (mut pdf, node) = self.top[((x >> shift) | (y >> shift) << TOP_LEVELS) as usize];
        if node == 0 {
            return pdf;
        }
        let mut node = &self.nodes[node as usize];
        let mut bit = shift - 1;
        loop {
            let i = ((x >> bit) & 1) as usize | ((((y >> bit) & 1) as usize) << 1);
            pdf *= node.factor[i];
            match node.child[i] {
                0 => return pdf,
                c => {
                    node = &self.nodes[c as usize];
                    bit -= 1;
                }
            }
        }
    }

    /// Append the tree to a saved guide ([`super::persist`]).
    pub(super) fn write(&self, w: &mut super::bytes::Writer) {
        w.u8(u8::from(self.usable));
        w.len(self.nodes.len());
        for n in &self.nodes {
            w.f32(n.p_left);
            for v in n.p_low.into_iter().chain(n.factor) {
                w.f32(v);
            }
            for c in n.child {
                w.u32(c);
            }
        }
    }

    /// A tree [`SampleTree::write`] wrote, checked so that sampling and
    /// density walks stay in it and end: children come after their node,
    /// no node is deeper than [`MAX_DEPTH`] levels (the density's bit walk
    /// reads 24), probabilities lie in `[0, 1]` and density factors are
    /// finite and `>= 0`.
    pub(super) fn read(
        r: &mut super::bytes::Reader<'_>,
    ) -> Result<SampleTree, super::bytes::Refusal> {
        let usable = match r.u8()? {
            0 => false,
            1 => true,
            b => return Err(format!("usable flag {b}")),
        };
        let n = r.count("quadtree nodes", 44)?;
        if n == 0 {
            return Err("a quadtree without a root".into());
        }
        let mut nodes = Vec::with_capacity(n);
        let mut depth = vec![0u32; n];
        for i in 0..n {
            let p_left = r.f32()?;
            let p_low = [r.f32()?, r.f32()?];
            let factor = [r.f32()?, r.f32()?, r.f32()?, r.f32()?];
            let child = [r.u32()?, r.u32()?, r.u32()?, r.u32()?];
            let prob = |p: f32| (0.0..=1.0).contains(&p);
            if !prob(p_left) || !p_low.iter().all(|&p| prob(p)) {
                return Err(format!("quadtree node {i}: a probability outside [0, 1]"));
            }
            if !factor.iter().all(|f| f.is_finite() && *f >= 0.0) {
                return Err(format!("quadtree node {i}: a density factor {factor:?}"));
            }
            for &c in child.iter().filter(|&&c| c != 0) {
                let c = c as usize;
                if c <= i || c >= n {
                    return Err(format!("quadtree node {i}: child {c} outside the tree"));
                }
                depth[c] = depth[c].max(depth[i] + 1);
                if depth[c] >= MAX_DEPTH {
                    return Err(format!("quadtree node {c}: deeper than {MAX_DEPTH} levels"));
                }
            }
            nodes.push(SampleNode {
                p_left,
                p_low,
                factor,
                child,
            });
        }
        Ok(SampleTree::with_nodes(nodes, usable))
    }

    /// Nodes in the tree.
    pub fn node_count(&self) -> usize {
        self.nodes.len()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampler::Sampler;

    #[test]
    fn the_square_map_round_trips_and_keeps_area() {
        let mut s = Sampler::new(3, 0, 0);
        for _ in 0..1000 {
            let q = s.next_2d();
            let d = square_to_dir(q);
            assert!((d.length() - 1.0).abs() < 1e-5);
            let back = dir_to_square(d);
            assert!(
                (back - q).abs().max_element() < 1e-4,
                "{q} -> {d} -> {back}"
            );
        }
        // a band of the square's x is a band of cos theta: equal area
        let band = |x0: f32, x1: f32| (x1 - x0) * 4.0 * PI;
        assert!((band(0.0, 0.5) - 2.0 * PI).abs() < 1e-6);
    }

    /// The box filter keeps a record's value whole, spreads it over the
    /// cells its leaf-sized box overlaps in proportion, wraps it around the
    /// azimuth's seam and clips it at the poles' edges.
    #[test]
    fn the_box_filter_spreads_a_record_over_the_cells_its_box_overlaps() {
        // one level of children under every quadrant: leaf cells of 1/4
        let mut tree = BuildTree::default();
        for i in 0..4 {
            tree.nodes[0].child[i] = tree.nodes.len() as u32;
            tree.nodes.push(EMPTY);
        }
        let sums = |t: &BuildTree| t.nodes.iter().map(|n| n.sum).collect::<Vec<_>>();
        // at a cell's centre the box is the cell: as `add`
        let (mut a, mut b) = (tree.clone(), tree.clone());
        a.add_filtered(Vec2::new(0.125, 0.375), 2.0);
        b.add(Vec2::new(0.125, 0.375), 2.0);
        assert_eq!(sums(&a), sums(&b));
        // on the corner of four cells: a quarter in each, across the root's
        // quadrants (0.5, 0.5 is the root's centre)
        let mut c = tree.clone();
        c.add_filtered(Vec2::new(0.5, 0.5), 4.0);
        assert_eq!(c.nodes[0].sum, [1.0; 4]);
        assert_eq!(c.nodes[1].sum, [0.0, 0.0, 0.0, 1.0]);
        assert_eq!(c.nodes[4].sum, [1.0, 0.0, 0.0, 0.0]);
        // at the seam y = 0: half wraps to y just below 1
        let mut d = tree.clone();
        d.add_filtered(Vec2::new(0.125, 0.0), 1.0);
        assert!((d.total() - 1.0).abs() < 1e-12);
        assert_eq!(d.nodes[0].sum, [0.5, 0.0, 0.5, 0.0]);
        assert_eq!(d.nodes[1].sum, [0.5, 0.0, 0.0, 0.0]);
        assert_eq!(d.nodes[3].sum, [0.0, 0.0, 0.5, 0.0]);
        // at the edge x = 0: clipped, the value kept whole in the part inside
        let mut e = tree;
        e.add_filtered(Vec2::new(0.0, 0.125), 1.0);
        assert_eq!(e.nodes[0].sum, [1.0, 0.0, 0.0, 0.0]);
        assert_eq!(e.nodes[1].sum, [1.0, 0.0, 0.0, 0.0]);
    }

    /// A tree built from energy concentrated around one direction: its
    /// samples' densities agree with `pdf`, the density integrates to 1,
    /// and most samples land near the direction.
    #[test]
    fn a_refined_tree_samples_what_it_learned() {
        let target = Vec3::new(0.3, -0.5, 0.81).normalize();
        let mut s = Sampler::new(11, 0, 0);
        let mut tree = BuildTree::default();
        for _ in 0..6 {
            let mut next = tree.refined();
            for _ in 0..20_000 {
                let d = square_to_dir(s.next_2d());
                // a lobe around the target, plus a floor
                let v = (d.dot(target).max(0.0)).powi(20) + 0.01;
                next.add(dir_to_square(d), v as f64);
            }
            tree = next;
        }
        assert!(tree.node_count() > 20, "{} nodes", tree.node_count());
        let st = tree.to_sampling();
        assert!(st.is_usable());
        let mut near = 0;
        for _ in 0..10_000 {
            let (d, pdf) = st.sample(s.next_2d());
            let p = st.pdf(d);
            assert!((p - pdf).abs() <= 1e-3 * pdf, "{p} against {pdf}");
            if d.dot(target) > 0.9 {
                near += 1;
            }
        }
        // the cap dot > 0.9 is 5 % of the sphere; the lobe puts most there
        assert!(near > 5_000, "{near} of 10000 near the lobe");
        // the density integrates to 1 (uniform directions, mean of pdf * 4 pi)
        let n = 200_000;
        let mut sum = 0.0f64;
        for _ in 0..n {
            let d = square_to_dir(s.next_2d());
            sum += st.pdf(d) as f64 * 4.0 * std::f64::consts::PI;
        }
        let mean = sum / n as f64;
        assert!((mean - 1.0).abs() < 0.03, "integral {mean}");
        // the walk by the point's bits is the walk by halving, bit for bit
        let by_halving = |d: Vec3| {
            let mut q = dir_to_square(d);
            let mut node = &st.nodes[0];
            let mut pdf = 1.0f32 / (4.0 * PI);
            loop {
                let (i, inner) = quadrant(q);
                pdf *= node.factor[i];
                match node.child[i] {
                    0 => return pdf,
                    c => {
                        node = &st.nodes[c as usize];
                        q = inner;
                    }
                }
            }
        };
        for _ in 0..100_000 {
            let d = square_to_dir(s.next_2d());
            assert_eq!(st.pdf(d).to_bits(), by_halving(d).to_bits(), "{d}");
        }
        for d in [
            Vec3::Z,
            -Vec3::Z,
            Vec3::X,
            -Vec3::X,
            Vec3::Y,
            -Vec3::Y,
            target,
        ] {
            assert_eq!(st.pdf(d).to_bits(), by_halving(d).to_bits(), "{d}");
        }
    }

    #[test]
    fn an_empty_tree_is_not_usable_and_refines_to_one_node() {
        let t = BuildTree::default();
        assert!(!t.to_sampling().is_usable());
        assert_eq!(t.refined().node_count(), 1);
        assert_eq!(t.to_sampling().pdf(Vec3::Z), 0.0);
    }
}
