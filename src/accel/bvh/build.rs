//! BVH construction, top-down, straight into [`WIDTH`]-wide nodes.
//!
//! Splits are chosen by the surface area heuristic (MacDonald and Booth,
//! "Heuristics for ray tracing using space subdivision", 1990):
//!
//! - [`BvhQuality::Fast`]: binned SAH (Wald, "On fast Construction of
//!   SAH-based Bounding Volume Hierarchies", IEEE RT 2007) with [`BINS`]
//!   bins on each of the three axes of the centroid bounds, binning in
//!   parallel for large ranges. Ranges of more than 2^[`SAMPLE_SHIFT`]
//!   triangles bin an evenly strided sample of about that many (the bins'
//!   counts scaled back up): the split plane is chosen from the sample, the
//!   partition that follows is exact. On the 1.2M-triangle benchmark scene
//!   this cut the build from 218 to 188 ms on two threads (median of 5
//!   alternating runs of `bench`; 545 to 386 ms before the fix described
//!   at [`ID_TAG`]) with no measurable change in Mrays/s on any ray kind;
//!   2^12 cost 2.6% on camera rays of a rougher scene.
//! - [`BvhQuality::High`]: a full sweep over the centroids sorted on each
//!   axis (every split position is evaluated) for ranges of up to
//!   [`SWEEP_MAX`] triangles, [`HIGH_BINS`] bins above that.
//!
//! Both builds sweep ranges of up to [`SMALL`] triangles exhaustively, where
//! that is cheaper than binning.
//!
//! A node of [`WIDTH`] = 2^[`LEVELS`] slots is made from binary splits: its
//! range is split [`LEVELS`] times over (every part that the SAH does not
//! make a leaf is split again), and while a slot is still free the
//! largest-area part that is not a leaf is split once more (Wald et al.,
//! "Getting Rid of Packets", RT 2008; Embree's BVH4 and BVH8 open the
//! largest child the same way). Subtrees of more than
//! [`PARALLEL_MIN`] triangles are built in parallel with rayon, and the
//! binning and partitioning of large ranges are parallel too.
//!
//! Depth bound. Every path through a node crosses at least [`LEVELS`] binary
//! levels unless it ends in a leaf, so the depth in nodes is at most
//! `ceil(MAX_DEPTH / LEVELS)` when no leaf is deeper than [`MAX_DEPTH`] binary
//! levels. The builder guarantees that: a range of `n` triangles at binary
//! depth `d` always satisfies `n <= LEAF_MAX * 2^(MAX_DEPTH - d)` (true at
//! the root for any `n < 2^44`), and an SAH split whose larger half would
//! break it at depth `d + 1` is replaced by an object-median split, which
//! halves the range. The traversal stack ([`super::STACK_SIZE`]) is sized
//! from this bound.

use super::BvhQuality;
use super::node::{Aabb, BLOCK, ChildRef, LEAF_MAX, LEVELS, Node, WIDTH};
use super::pages::PageArray;
use glam::{Vec3A, Vec4};
use rayon::prelude::*;
use std::ops::Range;

/// Deepest binary level of a leaf (the root is level 0).
pub const MAX_DEPTH: usize = 42;
/// Bins per axis of the `Fast` build.
pub const BINS: usize = 16;
/// Bins per axis of the `High` build above [`SWEEP_MAX`] triangles.
pub const HIGH_BINS: usize = 64;
/// Largest range the `High` build sweeps exhaustively.
pub const SWEEP_MAX: usize = 1 << 16;
/// Ranges up to this size are swept exhaustively by both builds: cheaper
/// than binning there, and exact.
pub const SMALL: usize = 32;
/// Cost of a traversal step relative to one triangle test, charged per
/// binary split in the SAH; it decides leaf against split for ranges of at
/// most [`LEAF_MAX`] (a leaf costs a test per lane of its blocks, see
/// [`leaf_cost`]). On the 1.2M-triangle benchmark sphere, 8 was 13% faster
/// on camera rays and 17% on diffuse rays than 4 (median of 8 alternating
/// runs), with 47 instead of 53 bytes per triangle; 16 measured like 8.
pub const TRAVERSAL_COST: f32 = 8.0;
/// Subtrees at least this large are built in parallel.
pub const PARALLEL_MIN: usize = 4096;
/// Ranges at least this large are binned (and bounded) in parallel.
const PARALLEL_BIN_MIN: usize = 1 << 15;
const CHUNK: usize = 1 << 13;
/// Ranges at least this large are partitioned in parallel.
const PARALLEL_PARTITION_MIN: usize = 1 << 16;
/// The `Fast` build's binning samples about 2^`SAMPLE_SHIFT` triangles of
/// larger ranges (see the module documentation).
pub const SAMPLE_SHIFT: usize = 13;

/// Flipped into the bits of the index stored in [`PrimRef`]'s spare lane,
/// so that every index below 2^30 reads as a normal float (in `[2, 2^17)`
/// for the indices a BVH holds) rather than a subnormal one.
///
/// Why it matters: the build's vector arithmetic (centroids, bin indices,
/// areas) runs on all four lanes, the spare one included, and on x86 an
/// operation on a subnormal operand takes a microcode assist of a hundred
/// cycles or more (Embree avoids this by setting the denormals-are-zero
/// flag in its threads; that takes `unsafe` here). With the raw index bits,
/// every index below 2^23 is subnormal: binning cost 40 ns a triangle
/// instead of 6, and the sphere-1m build took 700 ms on one thread instead
/// of 309.
const ID_TAG: u32 = 0x4000_0000;

/// A triangle during the build: its bounds and original index, in 32 bytes
/// (the index rides in the unused fourth lane of the lower corner, as in
/// Embree's `PrimRef`): the partitions move a third fewer bytes than with a
/// separate field.
#[derive(Debug, Clone, Copy)]
pub struct PrimRef {
    /// Lower corner; lane `w` holds the index's bits, flipped by [`ID_TAG`].
    lo: Vec4,
    /// Upper corner; lane `w` is 0.
    hi: Vec4,
}

impl PrimRef {
    /// Triangle `id` with bounds `bounds`.
    pub fn new(bounds: &Aabb, id: u32) -> Self {
        PrimRef {
            lo: bounds.min.extend(f32::from_bits(id ^ ID_TAG)),
            hi: bounds.max.extend(0.0),
        }
    }

    /// The triangle's bounds.
    #[inline(always)]
    pub fn bounds(&self) -> Aabb {
        Aabb {
            min: Vec3A::from_vec4(self.lo),
            max: Vec3A::from_vec4(self.hi),
        }
    }

    /// Index of the triangle in the input.
    #[inline(always)]
    pub fn id(&self) -> u32 {
        self.lo.w.to_bits() ^ ID_TAG
    }

    /// Twice the centroid of the bounds (the factor 2 cancels out of every
    /// comparison and saves a multiplication).
    #[inline(always)]
    fn center2(&self) -> Vec3A {
        Vec3A::from_vec4(self.lo) + Vec3A::from_vec4(self.hi)
    }
}

/// Total order on centroids along `axis`, ties broken by index: sorts and
/// medians are deterministic.
fn by_center(axis: usize) -> impl Fn(&PrimRef, &PrimRef) -> std::cmp::Ordering {
    move |a, b| {
        a.center2()[axis]
            .total_cmp(&b.center2()[axis])
            .then(a.id().cmp(&b.id()))
    }
}

/// Bounds of the triangles and of their (doubled) centroids.
#[derive(Debug, Clone, Copy)]
struct Info {
    bounds: Aabb,
    centers: Aabb,
}

impl Info {
    const EMPTY: Info = Info {
        bounds: Aabb::EMPTY,
        centers: Aabb::EMPTY,
    };

    fn merge(self, o: Info) -> Info {
        Info {
            bounds: self.bounds.union(&o.bounds),
            centers: self.centers.union(&o.centers),
        }
    }

    #[inline(always)]
    fn add(&mut self, p: &PrimRef) {
        self.bounds = self.bounds.union(&p.bounds());
        self.centers.grow(p.center2());
    }

    fn of(prims: &[PrimRef]) -> Info {
        let serial = |c: &[PrimRef]| {
            let mut i = Info::EMPTY;
            for p in c {
                i.add(p);
            }
            i
        };
        if prims.len() >= PARALLEL_BIN_MIN {
            prims
                .par_chunks(CHUNK)
                .map(serial)
                .reduce(|| Info::EMPTY, Info::merge)
        } else {
            serial(prims)
        }
    }
}

/// How a range is split (or not): the builder's choice for it.
#[derive(Debug, Clone, Copy)]
enum SplitChoice {
    /// Make a leaf.
    Leaf,
    /// Triangles whose bin on `axis` is below `bin` go left.
    Binned {
        axis: usize,
        lo: f32,
        scale: f32,
        bins: usize,
        bin: usize,
    },
    /// The range is sorted on the split axis; the first `at` go left.
    Sorted { at: usize },
    /// Object median on `axis`.
    Median { axis: usize },
}

/// A range of triangles waiting to become a leaf or a subtree.
struct Item<'a> {
    prims: &'a mut [PrimRef],
    /// Position of `prims[0]` in the whole (reordered) list.
    offset: usize,
    depth: usize,
    info: Info,
    choice: SplitChoice,
}

/// The largest range allowed at binary depth `depth`.
fn capacity(depth: usize) -> usize {
    let levels = MAX_DEPTH.saturating_sub(depth);
    if levels >= 40 {
        usize::MAX
    } else {
        LEAF_MAX << levels
    }
}

/// SAH cost of a leaf of `n` triangles, in triangle tests: the leaf test
/// takes whole blocks, so a part-filled block costs as much as a full one.
#[inline]
fn leaf_cost(n: usize) -> f32 {
    n.next_multiple_of(BLOCK) as f32
}

/// SAH cost of a split, in triangle tests, given the parent's half area.
#[inline]
fn split_cost(parent_area: f32, left: f32, nl: usize, right: f32, nr: usize) -> f32 {
    TRAVERSAL_COST + (left * leaf_cost(nl) + right * leaf_cost(nr)) / parent_area
}

/// Per-axis bins: bounds and counts.
#[derive(Clone)]
struct Bins<const B: usize> {
    bounds: [[Aabb; B]; 3],
    count: [[u32; B]; 3],
}

impl<const B: usize> Bins<B> {
    fn empty() -> Self {
        Bins {
            bounds: [[Aabb::EMPTY; B]; 3],
            count: [[0; B]; 3],
        }
    }

    fn merge(mut self, o: Self) -> Self {
        for a in 0..3 {
            for b in 0..B {
                self.bounds[a][b] = self.bounds[a][b].union(&o.bounds[a][b]);
                self.count[a][b] += o.count[a][b];
            }
        }
        self
    }
}

/// Adding this to a float in `[0, 2^23)` rounds it to an integer that is
/// then the low bits of the sum's mantissa.
const ROUND: f32 = 8_388_608.0; // 2^23

/// Bin index of a doubled centroid coordinate `c`, with `lo` and `scale`
/// from the centroid bounds: `(c - lo) * scale - 0.5` clamped to
/// `[0, bins - 1]` and rounded to nearest, the truncation `floor((c - lo) *
/// scale)` but for ties, without a float-to-integer conversion (whose
/// saturation fix-ups made it the binning loop's bottleneck). [`bins_of`]
/// does the same arithmetic lane by lane, so the counts the SAH saw when
/// binning are the counts the partition gets.
#[inline(always)]
fn bin_of(c: f32, lo: f32, scale: f32, bins: usize) -> usize {
    let x = ((c - lo) * scale - 0.5).max(0.0).min((bins - 1) as f32);
    ((x + ROUND).to_bits() & 0xffff) as usize
}

/// [`bin_of`] on the three axes at once, in vector operations.
#[inline(always)]
fn bins_of(c: Vec3A, lo: Vec3A, scale: Vec3A, bins: usize) -> [usize; 3] {
    let x = ((c - lo) * scale - Vec3A::splat(0.5))
        .max(Vec3A::ZERO)
        .min(Vec3A::splat((bins - 1) as f32));
    (x + Vec3A::splat(ROUND))
        .to_array()
        .map(|v| (v.to_bits() & 0xffff) as usize)
}

/// A split candidate: its SAH cost, the choice, and how many triangles go left.
struct Candidate {
    cost: f32,
    choice: SplitChoice,
    left: usize,
}

/// The best binned split of a range, or `None` when all centroids coincide.
/// With `sample`, a range of more than 2^[`SAMPLE_SHIFT`] triangles bins a
/// strided sample, and the candidate's count on the left is an estimate.
fn binned_split<const B: usize>(prims: &[PrimRef], info: &Info, sample: bool) -> Option<Candidate> {
    let lo = info.centers.min;
    let extent = info.centers.max - lo;
    // scale so that the largest centroid lands in the last bin
    let scale = Vec3A::from_array(extent.to_array().map(|e| {
        if e > 0.0 {
            B as f32 * (1.0 - 1e-6) / e
        } else {
            0.0
        }
    }));
    if scale == Vec3A::ZERO {
        return None;
    }
    let stride = if sample {
        (prims.len() >> SAMPLE_SHIFT).max(1)
    } else {
        1
    };
    let bin_chunk = |c: &[PrimRef]| {
        let mut bins = Bins::<B>::empty();
        for p in c.iter().step_by(stride) {
            let idx = bins_of(p.center2(), lo, scale, B);
            for (a, &i) in idx.iter().enumerate() {
                bins.bounds[a][i] = bins.bounds[a][i].union(&p.bounds());
                bins.count[a][i] += 1;
            }
        }
        bins
    };
    let bins = if prims.len() >= PARALLEL_BIN_MIN * stride {
        prims
            .par_chunks(CHUNK * stride)
            .map(bin_chunk)
            .reduce(Bins::empty, Bins::merge)
    } else {
        bin_chunk(prims)
    };
    let parent = info.bounds.half_area().max(f32::MIN_POSITIVE);
    let mut best: Option<Candidate> = None;
    for axis in 0..3 {
        if scale[axis] == 0.0 {
            continue;
        }
        // right-to-left: area and count of bins b.. on the right
        let mut right_area = [0.0f32; B];
        let mut right_count = [0usize; B];
        let mut acc = Aabb::EMPTY;
        let mut n = 0;
        for b in (1..B).rev() {
            acc = acc.union(&bins.bounds[axis][b]);
            n += bins.count[axis][b] as usize * stride;
            right_area[b] = acc.half_area();
            right_count[b] = n;
        }
        let mut left = Aabb::EMPTY;
        let mut nl = 0;
        for b in 1..B {
            left = left.union(&bins.bounds[axis][b - 1]);
            nl += bins.count[axis][b - 1] as usize * stride;
            let nr = right_count[b];
            if nl == 0 || nr == 0 {
                continue;
            }
            let cost = split_cost(parent, left.half_area(), nl, right_area[b], nr);
            if best.as_ref().is_none_or(|c| cost < c.cost) {
                let choice = SplitChoice::Binned {
                    axis,
                    lo: lo[axis],
                    scale: scale[axis],
                    bins: B,
                    bin: b,
                };
                best = Some(Candidate {
                    cost,
                    choice,
                    left: nl,
                });
            }
        }
    }
    best
}

/// `x`'s bits, mapped so that unsigned order is `f32::total_cmp` order.
#[inline(always)]
fn order_bits(x: f32) -> u32 {
    let b = x.to_bits();
    if b >> 31 == 1 { !b } else { b | 1 << 31 }
}

/// Sort keys of `prims` along `axis`: centroid, then position (so sorts
/// are deterministic), packed in a `u64` whose low half is the position.
fn sort_keys(prims: &[PrimRef], axis: usize, keys: &mut [u64]) {
    for (i, (k, p)) in keys.iter_mut().zip(prims).enumerate() {
        *k = (order_bits(p.center2()[axis]) as u64) << 32 | i as u64;
    }
    keys.sort_unstable();
}

/// The best split over every position of the centroids sorted on each
/// axis; leaves `prims` sorted on the winning axis.
fn sweep_split(prims: &mut [PrimRef], info: &Info) -> Option<Candidate> {
    let n = prims.len();
    let parent = info.bounds.half_area().max(f32::MIN_POSITIVE);
    // scratch on the stack for small ranges, the heap for large ones: the
    // right-hand areas, and the sorted keys of the axis being swept and of
    // the best one so far (kept, so the winner need not be sorted again)
    let (mut small_area, mut small_keys) = ([0.0f32; SMALL], [[0u64; SMALL]; 2]);
    let (mut large_area, mut large_keys) = (Vec::new(), [Vec::new(), Vec::new()]);
    let (right_area, [mut keys, mut best_keys]) = if n <= SMALL {
        let [a, b] = &mut small_keys;
        (&mut small_area[..n], [&mut a[..n], &mut b[..n]])
    } else {
        large_area.resize(n, 0.0f32);
        let [a, b] = &mut large_keys;
        a.resize(n, 0u64);
        b.resize(n, 0u64);
        (&mut large_area[..], [&mut a[..], &mut b[..]])
    };
    let bounds = |k: u64| prims[k as u32 as usize].bounds();
    let mut best: Option<(f32, usize)> = None;
    for axis in 0..3 {
        if !(info.centers.max[axis] > info.centers.min[axis]) {
            continue;
        }
        sort_keys(prims, axis, keys);
        // right_area[i]: area of the triangles from sorted position i on
        let mut acc = Aabb::EMPTY;
        for (ra, &k) in right_area.iter_mut().zip(keys.iter()).rev() {
            acc = acc.union(&bounds(k));
            *ra = acc.half_area();
        }
        let mut left = Aabb::EMPTY;
        let mut improved = false;
        for (i, (&k, &ra)) in keys.iter().zip(&right_area[1..]).enumerate() {
            left = left.union(&bounds(k));
            let nl = i + 1;
            let cost = split_cost(parent, left.half_area(), nl, ra, n - nl);
            if best.is_none_or(|(c, _)| cost < c) {
                best = Some((cost, nl));
                improved = true;
            }
        }
        if improved {
            std::mem::swap(&mut keys, &mut best_keys);
        }
    }
    let (cost, at) = best?;
    // reorder along the winning axis
    if n <= SMALL {
        let mut sorted = [prims[0]; SMALL];
        for (s, &k) in sorted.iter_mut().zip(best_keys.iter()) {
            *s = prims[k as u32 as usize];
        }
        prims.copy_from_slice(&sorted[..n]);
    } else {
        let sorted: Vec<PrimRef> = best_keys
            .iter()
            .map(|&k| prims[k as u32 as usize])
            .collect();
        prims.copy_from_slice(&sorted);
    }
    Some(Candidate {
        cost,
        choice: SplitChoice::Sorted { at },
        left: at,
    })
}

fn longest_axis(e: Vec3A) -> usize {
    if e.x >= e.y && e.x >= e.z {
        0
    } else if e.y >= e.z {
        1
    } else {
        2
    }
}

impl<'a> Item<'a> {
    /// Measure a range and decide how it is split.
    fn new(prims: &'a mut [PrimRef], offset: usize, depth: usize, quality: BvhQuality) -> Self {
        let info = Info::of(prims);
        Item::with_info(prims, offset, depth, info, quality)
    }

    /// Like [`Item::new`], with the range's bounds already known.
    fn with_info(
        prims: &'a mut [PrimRef],
        offset: usize,
        depth: usize,
        info: Info,
        quality: BvhQuality,
    ) -> Self {
        let mut item = Item {
            prims,
            offset,
            depth,
            info,
            choice: SplitChoice::Leaf,
        };
        item.choice = item.choose(quality);
        item
    }

    fn len(&self) -> usize {
        self.prims.len()
    }

    fn choose(&mut self, quality: BvhQuality) -> SplitChoice {
        let n = self.len();
        // a split costs at least TRAVERSAL_COST, so a leaf that costs no
        // more wins without measuring any split (the SAH would say so too)
        if leaf_cost(n) <= TRAVERSAL_COST || self.depth >= MAX_DEPTH {
            debug_assert!(n <= LEAF_MAX, "the depth bound keeps deep ranges small");
            return SplitChoice::Leaf;
        }
        let median = SplitChoice::Median {
            axis: longest_axis(self.info.centers.max - self.info.centers.min),
        };
        let best = match quality {
            _ if n <= SMALL => sweep_split(self.prims, &self.info),
            // the depth bound needs exact counts only where a half could
            // exceed the capacity one level down
            BvhQuality::Fast => {
                let sample = n <= capacity(self.depth + 1);
                binned_split::<BINS>(self.prims, &self.info, sample)
            }
            BvhQuality::High if n <= SWEEP_MAX => sweep_split(self.prims, &self.info),
            BvhQuality::High => binned_split::<HIGH_BINS>(self.prims, &self.info, false),
        };
        let Some(best) = best else {
            // every centroid equal: split by count if the leaf would be too big
            return if n > LEAF_MAX {
                median
            } else {
                SplitChoice::Leaf
            };
        };
        if n <= LEAF_MAX && leaf_cost(n) <= best.cost {
            return SplitChoice::Leaf;
        }
        // keep the depth bound: each half must fit one level further down
        if best.left.max(n - best.left) > capacity(self.depth + 1) {
            median
        } else {
            best.choice
        }
    }

    /// Apply the choice: two halves one level down.
    fn split(self, quality: BvhQuality) -> (Item<'a>, Item<'a>) {
        let n = self.len();
        // the binned partition measures both halves as it goes
        let (mid, infos) = match self.choice {
            SplitChoice::Leaf => unreachable!("split is only called on chosen splits"),
            SplitChoice::Binned {
                axis,
                lo,
                scale,
                bins,
                bin,
            } => {
                let (mid, l, r) = par_partition(self.prims, &|p: &PrimRef| {
                    bin_of(p.center2()[axis], lo, scale, bins) < bin
                });
                (mid, Some((l, r)))
            }
            SplitChoice::Sorted { at } => (at, None),
            SplitChoice::Median { axis } => {
                self.prims.select_nth_unstable_by(n / 2, by_center(axis));
                (n / 2, None)
            }
        };
        debug_assert!(0 < mid && mid < n, "a split leaves both halves non-empty");
        let (l, r) = self.prims.split_at_mut(mid);
        let depth = self.depth + 1;
        let offset = self.offset;
        let make = |prims, offset, info: Option<Info>| match info {
            Some(info) => Item::with_info(prims, offset, depth, info, quality),
            None => Item::new(prims, offset, depth, quality),
        };
        let (li, ri) = (infos.map(|i| i.0), infos.map(|i| i.1));
        if n >= PARALLEL_MIN {
            rayon::join(|| make(l, offset, li), || make(r, offset + mid, ri))
        } else {
            (make(l, offset, li), make(r, offset + mid, ri))
        }
    }
}

/// [`partition`], in parallel for large ranges: both halves are partitioned
/// at once, then the right part of the first and the left part of the
/// second trade places (the smaller one swaps with the far end of the
/// other). The order depends on the range's length only, not on timing.
fn par_partition(
    prims: &mut [PrimRef],
    left: &(impl Fn(&PrimRef) -> bool + Sync),
) -> (usize, Info, Info) {
    let n = prims.len();
    if n < PARALLEL_PARTITION_MIN {
        return partition(prims, left);
    }
    let h = n / 2;
    let (a, b) = prims.split_at_mut(h);
    let ((ma, la, ra), (mb, lb, rb)) =
        rayon::join(|| par_partition(a, left), || par_partition(b, left));
    let k = (h - ma).min(mb);
    let (x, y) = prims.split_at_mut(h);
    x[ma..ma + k]
        .par_chunks_mut(CHUNK)
        .zip(y[mb - k..mb].par_chunks_mut(CHUNK))
        .for_each(|(p, q)| p.swap_with_slice(q));
    (ma + mb, la.merge(lb), ra.merge(rb))
}

/// In-place partition: the elements for which `left` holds first. Returns
/// their count and the bounds of both halves.
fn partition(prims: &mut [PrimRef], left: impl Fn(&PrimRef) -> bool) -> (usize, Info, Info) {
    let (mut li, mut ri) = (Info::EMPTY, Info::EMPTY);
    let (mut i, mut j) = (0, prims.len());
    loop {
        while i < j && left(&prims[i]) {
            li.add(&prims[i]);
            i += 1;
        }
        while i < j && !left(&prims[j - 1]) {
            ri.add(&prims[j - 1]);
            j -= 1;
        }
        if i >= j {
            return (i, li, ri);
        }
        prims.swap(i, j - 1);
        li.add(&prims[i]);
        ri.add(&prims[j - 1]);
        i += 1;
        j -= 1;
    }
}

/// A built subtree before it is flattened into the node array.
enum Built {
    Leaf {
        start: usize,
        count: usize,
    },
    Inner {
        children: Box<[(Aabb, Built)]>,
        /// The subtree's shape: its inner nodes and leaves (so that its
        /// place in the flat arrays is known before it is flattened), and
        /// its depth in inner nodes.
        shape: TreeStats,
    },
}

impl Built {
    fn shape(&self) -> TreeStats {
        match self {
            Built::Leaf { count, .. } => TreeStats {
                nodes: 0,
                leaves: 1,
                blocks: count.div_ceil(BLOCK),
                depth: 0,
            },
            Built::Inner { shape, .. } => *shape,
        }
    }
}

/// Build the subtree for an item that splits.
fn build_inner(item: Item<'_>, quality: BvhQuality) -> Built {
    debug_assert!(!matches!(item.choice, SplitChoice::Leaf));
    let large = item.len() >= PARALLEL_MIN;
    let mut slots: Vec<Item<'_>> = Vec::with_capacity(WIDTH);
    slots.push(item);
    // every slot that is not a leaf is split LEVELS times: each node spans
    // at least LEVELS binary levels
    for _ in 0..LEVELS {
        let mut next = Vec::with_capacity(WIDTH);
        for s in slots {
            if matches!(s.choice, SplitChoice::Leaf) {
                next.push(s);
            } else {
                let (c, d) = s.split(quality);
                next.extend([c, d]);
            }
        }
        slots = next;
    }
    // free slots: split the largest-area child that is not a leaf
    while slots.len() < WIDTH {
        let pick = slots
            .iter()
            .enumerate()
            .filter(|(_, s)| !matches!(s.choice, SplitChoice::Leaf))
            .max_by(|x, y| {
                x.1.info
                    .bounds
                    .half_area()
                    .total_cmp(&y.1.info.bounds.half_area())
            })
            .map(|(i, _)| i);
        let Some(i) = pick else { break };
        let (c, d) = slots.swap_remove(i).split(quality);
        slots.extend([c, d]);
    }
    let child = |s: Item<'_>| {
        let bounds = s.info.bounds;
        let built = match s.choice {
            SplitChoice::Leaf => Built::Leaf {
                start: s.offset,
                count: s.len(),
            },
            _ => build_inner(s, quality),
        };
        (bounds, built)
    };
    let children: Vec<(Aabb, Built)> = if large {
        slots.into_par_iter().map(child).collect()
    } else {
        slots.into_iter().map(child).collect()
    };
    let mut shape = TreeStats {
        nodes: 1,
        leaves: 0,
        blocks: 0,
        depth: 0,
    };
    for (_, c) in &children {
        let s = c.shape();
        shape.nodes += s.nodes;
        shape.leaves += s.leaves;
        shape.blocks += s.blocks;
        shape.depth = shape.depth.max(s.depth + 1);
    }
    Built::Inner {
        children: children.into_boxed_slice(),
        shape,
    }
}

/// Shape of a finished tree, for tests and reports.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct TreeStats {
    /// Inner nodes.
    pub nodes: usize,
    /// Leaves.
    pub leaves: usize,
    /// Triangle blocks (a leaf has one to `LEAF_MAX / BLOCK`).
    pub blocks: usize,
    /// Most inner nodes on a path from the root to a leaf.
    pub depth: usize,
}

/// Subtrees with at least this many inner nodes are flattened in parallel.
const PARALLEL_FLATTEN_MIN: usize = 256;

/// Write `built` into its place, depth-first: `nodes[0]` is its root (when
/// inner) and `blocks[0]` its first block's range of triangles, which are
/// node `node_base` and block `block_base` of the whole tree. Consumes the
/// subtree, so its memory is freed where it is flattened (in parallel for
/// large subtrees).
fn flatten(
    built: Built,
    nodes: &mut [Node],
    node_base: usize,
    blocks: &mut [Range<usize>],
    block_base: usize,
) -> ChildRef {
    let (children, shape) = match built {
        Built::Leaf { start, count } => {
            for (k, b) in blocks.iter_mut().enumerate() {
                let first = start + k * BLOCK;
                *b = first..(first + BLOCK).min(start + count);
            }
            return ChildRef::leaf(block_base, count);
        }
        Built::Inner { children, shape } => (children, shape),
    };
    let (this, mut nodes_rest) = nodes.split_first_mut().expect("an inner node has a slot");
    let mut blocks_rest = blocks;
    let (mut nb, mut bb) = (node_base + 1, block_base);
    // each child's slots, in depth-first order
    let mut parts = Vec::with_capacity(children.len());
    for (bounds, child) in children.into_vec() {
        let s = child.shape();
        let (n, nr) = std::mem::take(&mut nodes_rest).split_at_mut(s.nodes);
        let (b, br) = std::mem::take(&mut blocks_rest).split_at_mut(s.blocks);
        (nodes_rest, blocks_rest) = (nr, br);
        parts.push((bounds, child, n, nb, b, bb));
        nb += s.nodes;
        bb += s.blocks;
    }
    let one = |(bounds, child, n, nb, b, bb): (
        Aabb,
        Built,
        &mut [Node],
        usize,
        &mut [Range<usize>],
        usize,
    )| { (bounds, flatten(child, n, nb, b, bb)) };
    let refs: Vec<(Aabb, ChildRef)> = if shape.nodes >= PARALLEL_FLATTEN_MIN {
        parts.into_par_iter().map(one).collect()
    } else {
        parts.into_iter().map(one).collect()
    };
    let mut node = Node::EMPTY;
    for (k, (bounds, r)) in refs.iter().enumerate() {
        node.set(k, bounds, *r);
    }
    *this = node;
    ChildRef::inner(node_base)
}

/// A finished tree: nodes in depth-first order, the root reference (a leaf
/// when everything fits in one), each triangle block's range of the
/// reordered `prims` (a leaf's blocks are consecutive), and the tree's
/// shape.
pub struct Tree {
    /// Nodes, depth-first.
    pub nodes: PageArray<Node>,
    /// The root.
    pub root: ChildRef,
    /// Ranges of `prims`, one per triangle block, in block order.
    pub blocks: Vec<Range<usize>>,
    /// Shape.
    pub stats: TreeStats,
    /// Bounds of every triangle.
    pub bounds: Aabb,
}

/// Build over `prims` (reordered into leaf order).
pub fn build(prims: &mut [PrimRef], quality: BvhQuality) -> Tree {
    let root = Item::new(prims, 0, 0, quality);
    let bounds = root.info.bounds;
    let built = match root.choice {
        SplitChoice::Leaf => Built::Leaf {
            start: 0,
            count: root.len(),
        },
        _ => build_inner(root, quality),
    };
    let stats = built.shape();
    // `flatten` writes every node (in parallel, faulting its pages in)
    let mut nodes = PageArray::zeroed(stats.nodes);
    let mut blocks = vec![0..0; stats.blocks];
    let root = flatten(built, &mut nodes, 0, &mut blocks, 0);
    Tree {
        nodes,
        root,
        blocks,
        stats,
        bounds,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::accel::bvh::MAX_TRIANGLES;
    use crate::math::Vec3;

    #[test]
    fn prim_refs_keep_bounds_and_index_in_32_bytes() {
        assert_eq!(std::mem::size_of::<PrimRef>(), 32);
        let b = Aabb::of_triangle(&[Vec3::new(-1.0, 2.0, 3.0), Vec3::X, Vec3::Z]);
        for id in [0, 1, 12_345, MAX_TRIANGLES as u32 - 1, u32::MAX] {
            let p = PrimRef::new(&b, id);
            assert_eq!((p.bounds(), p.id()), (b, id));
            assert_eq!(p.center2(), b.min + b.max);
        }
        // the spare lane never holds a subnormal (see ID_TAG)
        for id in [0, 1, 12_345, (1 << 23) - 1, MAX_TRIANGLES as u32 - 1] {
            let p = PrimRef::new(&b, id);
            assert!(p.lo.w.is_normal() && (p.lo + p.hi).w.is_normal());
        }
        assert!(PrimRef::new(&Aabb::EMPTY, 7).bounds().is_empty());
    }

    #[test]
    fn parallel_partition_matches_the_serial_one() {
        // 2.5 times the parallel threshold, so the halves are uneven
        let n = PARALLEL_PARTITION_MIN * 5 / 2;
        let prims: Vec<PrimRef> = (0..n as u32)
            .map(|i| {
                // scattered centroids: a multiplicative hash of the index
                let x = (i.wrapping_mul(2_654_435_761) >> 8) as f32 / (1 << 24) as f32;
                let c = Vec3::new(x, 1.0 - x, (i % 7) as f32);
                PrimRef::new(&Aabb::of_triangle(&[c, c + Vec3::X, c + Vec3::Y]), i)
            })
            .collect();
        let left = |p: &PrimRef| p.center2().x < 1.37;
        let (mut par, mut ser) = (prims.clone(), prims);
        let (m, pl, pr) = par_partition(&mut par, &left);
        let (ms, sl, sr) = partition(&mut ser, left);
        assert_eq!(m, ms);
        assert!(0 < m && m < n);
        assert!(par[..m].iter().all(left) && !par[m..].iter().any(left));
        for (a, b) in [(pl, sl), (pr, sr)] {
            assert_eq!((a.bounds, a.centers), (b.bounds, b.centers));
        }
        // the same triangles on each side
        let ids = |s: &[PrimRef]| {
            let mut v: Vec<u32> = s.iter().map(PrimRef::id).collect();
            v.sort_unstable();
            v
        };
        assert_eq!(ids(&par[..m]), ids(&ser[..m]));
        assert_eq!(ids(&par[m..]), ids(&ser[m..]));
    }

    #[test]
    fn vector_and_scalar_bins_agree_and_follow_the_floor() {
        // centroids spread over [lo, lo + extent] on each axis, ends included
        let lo = Vec3A::new(-3.0, 0.25, 1e-3);
        let extent = Vec3A::new(6.0, 1e-4, 7e3);
        let scale = Vec3A::from_array(extent.to_array().map(|e| BINS as f32 * (1.0 - 1e-6) / e));
        let mut last = [0usize; 3];
        for k in 0..=1000 {
            let c = lo + extent * (k as f32 / 1000.0);
            let v = bins_of(c, lo, scale, BINS);
            for a in 0..3 {
                let s = bin_of(c[a], lo[a], scale[a], BINS);
                assert_eq!(v[a], s, "axis {a} at {c}");
                assert!(s < BINS && s >= last[a], "in range and monotone");
                let y = (c[a] - lo[a]) * scale[a];
                // the floor, but for ties at whole numbers, which may go down
                assert!(
                    s == (y.floor() as usize).min(BINS - 1) || y == y.floor(),
                    "{y} -> {s}"
                );
                last[a] = s;
            }
        }
        // the ends land in the first and last bins
        assert_eq!(bins_of(lo, lo, scale, BINS), [0; 3]);
        assert_eq!(bins_of(lo + extent, lo, scale, BINS), [BINS - 1; 3]);
    }
}
