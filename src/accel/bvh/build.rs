//! BVH construction: a binary tree by binned SAH (Wald, "On fast Construction
//! of SAH-based Bounding Volume Hierarchies", IEEE RT 2007: 16 bins on each
//! axis of the centroid bounds), parallel over subtrees with `rayon::join`,
//! then collapsed into 4-wide nodes by repeatedly opening the child with the
//! largest surface area (the standard wide-BVH collapse, as in Embree's
//! BVH4). `High` quality sweeps every split position of sorted centroids on
//! all three axes instead of 16 bins.
//!
//! Depth bound: past binary depth [`SAH_DEPTH`], a node is split at its
//! object median, so the binary depth is at most `SAH_DEPTH + log2(n) + 1`,
//! and the 4-wide traversal stack (3 entries per level) fits in
//! [`super::STACK_SIZE`] for any `n <= 2^28`.

use super::{Aabb, LEAF_MAX};
use crate::math::Vec3;

/// Binary depth after which splits fall back to the object median.
pub const SAH_DEPTH: usize = 48;
const BINS: usize = 16;
/// Cost of a traversal step relative to one triangle test in the SAH. Measured
/// on `scenes/sphere-1m.toml` (bench, 2-core dev machine): 1.0 gave 1.35
/// camera Mrays/s and 88.8 B/triangle, 4.0 gave 1.50 and 64.4 (larger leaves).
const TRAVERSAL_COST: f32 = 4.0;
const PARALLEL_THRESHOLD: usize = 4096;

/// A triangle's bounds and centroid during the build.
#[derive(Debug, Clone, Copy)]
pub struct PrimRef {
    pub bounds: Aabb,
    pub centroid: Vec3,
    pub id: u32,
}

/// A node of the binary build tree.
pub enum BinNode {
    /// `count` primitives starting at `start` of the reordered primitive list.
    Leaf {
        bounds: Aabb,
        start: usize,
        count: usize,
    },
    /// Two children.
    Inner {
        bounds: Aabb,
        children: Box<[BinNode; 2]>,
    },
}

impl BinNode {
    /// The node's bounds.
    pub fn bounds(&self) -> &Aabb {
        match self {
            BinNode::Leaf { bounds, .. } | BinNode::Inner { bounds, .. } => bounds,
        }
    }
}

fn bounds_of(prims: &[PrimRef]) -> (Aabb, Aabb) {
    let mut b = Aabb::EMPTY;
    let mut c = Aabb::EMPTY;
    for p in prims {
        b = b.union(&p.bounds);
        c.grow(p.centroid);
    }
    (b, c)
}

/// Best split found: axis and the number of primitives going left after
/// partitioning by `key < threshold`.
struct Split {
    cost: f32,
    axis: usize,
    threshold: f32,
}

fn binned_split(prims: &[PrimRef], cbounds: &Aabb) -> Option<Split> {
    let mut best: Option<Split> = None;
    for axis in 0..3 {
        let lo = cbounds.min[axis];
        let extent = cbounds.max[axis] - lo;
        if !(extent > 0.0) {
            continue;
        }
        let scale = BINS as f32 / extent;
        let mut bins = [(Aabb::EMPTY, 0usize); BINS];
        for p in prims {
            let i = (((p.centroid[axis] - lo) * scale) as usize).min(BINS - 1);
            bins[i].0 = bins[i].0.union(&p.bounds);
            bins[i].1 += 1;
        }
        // sweep: right-side areas first
        let mut right_area = [0.0f32; BINS];
        let mut acc = Aabb::EMPTY;
        let mut count = 0;
        let mut right_count = [0usize; BINS];
        for i in (1..BINS).rev() {
            acc = acc.union(&bins[i].0);
            count += bins[i].1;
            right_area[i] = acc.area();
            right_count[i] = count;
        }
        let mut left = Aabb::EMPTY;
        let mut left_count = 0;
        for i in 0..BINS - 1 {
            left = left.union(&bins[i].0);
            left_count += bins[i].1;
            let rc = right_count[i + 1];
            if left_count == 0 || rc == 0 {
                continue;
            }
            let cost = left.area() * left_count as f32 + right_area[i + 1] * rc as f32;
            if best.as_ref().is_none_or(|b| cost < b.cost) {
                best = Some(Split {
                    cost,
                    axis,
                    threshold: lo + (i + 1) as f32 / scale,
                });
            }
        }
    }
    best
}

/// Full sweep over sorted centroids on every axis (the `High` quality).
/// Sorts `prims` by the winning axis and returns the split index and cost.
fn sweep_split(prims: &mut [PrimRef]) -> Option<(f32, usize)> {
    let n = prims.len();
    let mut best: Option<(f32, usize, usize)> = None;
    let mut right_area = vec![0.0f32; n];
    for axis in 0..3 {
        prims.sort_unstable_by(|a, b| {
            a.centroid[axis]
                .total_cmp(&b.centroid[axis])
                .then(a.id.cmp(&b.id))
        });
        let mut acc = Aabb::EMPTY;
        for i in (1..n).rev() {
            acc = acc.union(&prims[i].bounds);
            right_area[i] = acc.area();
        }
        let mut left = Aabb::EMPTY;
        for i in 0..n - 1 {
            left = left.union(&prims[i].bounds);
            let cost = left.area() * (i + 1) as f32 + right_area[i + 1] * (n - i - 1) as f32;
            if best.is_none_or(|b| cost < b.0) {
                best = Some((cost, axis, i + 1));
            }
        }
    }
    let (cost, axis, at) = best?;
    prims.sort_unstable_by(|a, b| {
        a.centroid[axis]
            .total_cmp(&b.centroid[axis])
            .then(a.id.cmp(&b.id))
    });
    Some((cost, at))
}

fn partition(prims: &mut [PrimRef], axis: usize, threshold: f32) -> usize {
    let mut i = 0;
    for j in 0..prims.len() {
        if prims[j].centroid[axis] < threshold {
            prims.swap(i, j);
            i += 1;
        }
    }
    i
}

fn median_split(prims: &mut [PrimRef], cbounds: &Aabb) -> usize {
    let e = cbounds.max - cbounds.min;
    let axis = if e.x >= e.y && e.x >= e.z {
        0
    } else if e.y >= e.z {
        1
    } else {
        2
    };
    let mid = prims.len() / 2;
    prims.select_nth_unstable_by(mid, |a, b| {
        a.centroid[axis]
            .total_cmp(&b.centroid[axis])
            .then(a.id.cmp(&b.id))
    });
    mid
}

/// Build the binary tree over `prims` (reordered in place); `offset` is the
/// position of `prims[0]` in the whole list.
pub fn build(prims: &mut [PrimRef], offset: usize, depth: usize, high: bool) -> BinNode {
    let (bounds, cbounds) = bounds_of(prims);
    let n = prims.len();
    let leaf = BinNode::Leaf {
        bounds,
        start: offset,
        count: n,
    };
    if n <= 1 {
        return leaf;
    }
    let leaf_cost = n as f32;
    let area = bounds.area().max(f32::MIN_POSITIVE);
    let mid = if depth >= SAH_DEPTH {
        median_split(prims, &cbounds)
    } else if high && n <= 1 << 16 {
        match sweep_split(prims) {
            Some((cost, at)) if n > LEAF_MAX || TRAVERSAL_COST + cost / area < leaf_cost => at,
            Some(_) => return leaf,
            None => median_split(prims, &cbounds),
        }
    } else {
        match binned_split(prims, &cbounds) {
            Some(s) if n > LEAF_MAX || TRAVERSAL_COST + s.cost / area < leaf_cost => {
                partition(prims, s.axis, s.threshold)
            }
            Some(_) => return leaf,
            // every centroid equal: split by count
            None if n > LEAF_MAX => median_split(prims, &cbounds),
            None => return leaf,
        }
    };
    let mid = if mid == 0 || mid == n { n / 2 } else { mid };
    let (l, r) = prims.split_at_mut(mid);
    let (left, right) = if n >= PARALLEL_THRESHOLD {
        rayon::join(
            || build(l, offset, depth + 1, high),
            || build(r, offset + mid, depth + 1, high),
        )
    } else {
        (
            build(l, offset, depth + 1, high),
            build(r, offset + mid, depth + 1, high),
        )
    };
    BinNode::Inner {
        bounds,
        children: Box::new([left, right]),
    }
}
