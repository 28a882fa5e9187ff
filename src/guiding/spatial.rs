//! The spatial half of the SD-tree: per class of surface normal, a binary
//! tree over a cube around the scene, each split at the middle of its box,
//! the axes taking turns x, y, z down the tree (Müller et al. 2017).
//!
//! Finding a point's leaf is on every guided bounce, so it reads no
//! floating point per level: a split at depth `d` halves axis `d mod 3` for
//! the `(d / 3)`-th time, so it reads the next binary digit of the point's
//! coordinate along that axis in the cube. The point's digits, 16 per axis
//! (enough for [`MAX_SPATIAL_DEPTH`] levels), interleaved in that order
//! (a Morton code), are the walk's left/right choices, one bit per level;
//! and the first [`TOP_LEVELS`] levels are a table per class. The leaf is
//! the one halving the point's coordinates level by level finds: doubling
//! a coordinate in `[0, 1]` and taking 1 off when it is past one half is
//! exact in floating point, and reads the same digits.

use crate::math::Vec3;

/// The deepest the spatial tree grows.
pub(super) const MAX_SPATIAL_DEPTH: u32 = 48;

/// Binary digits per axis that a walk reads at most: one per three levels.
const DIGITS: u32 = MAX_SPATIAL_DEPTH / 3;

/// The levels below each class's root that a lookup reads from a table.
const TOP_LEVELS: u32 = 6;

/// Table entries per class: one per path through the top levels.
const TOP_CELLS: usize = 1 << TOP_LEVELS;

/// Marks a table entry that is a leaf, not a node to walk on from.
const LEAF_FLAG: u32 = 1 << 31;

/// A node of the spatial tree: a leaf (its index into the leaves) or a
/// split at the middle of its box along `axis`, with children at `child`
/// and `child + 1` (lower half first).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) enum SpatialNode {
    Leaf(u32),
    Split { axis: u8, child: u32 },
}

/// Surfaces are told apart by their normal's class: its largest axis and
/// that axis's sign (6 classes), each with a spatial tree of its own. The
/// two faces of a thin wall, or of a door, then learn apart: what arrives
/// at one face's hemisphere is below the other's horizon, where a guided
/// sample would be wasted.
pub(super) const NORMAL_CLASSES: usize = 6;

/// The class of normal `n` ([`NORMAL_CLASSES`]).
#[inline]
pub(super) fn normal_class(n: Vec3) -> usize {
    let a = n.abs();
    let axis = if a.x >= a.y && a.x >= a.z {
        0
    } else if a.y >= a.z {
        1
    } else {
        2
    };
    2 * axis + usize::from(n[axis] < 0.0)
}

/// The first [`DIGITS`] binary digits of `q` in `[0, 1]`, as an integer;
/// 1 (and anything not below it) has every digit 1, as halving finds.
#[inline]
fn digits(q: f32) -> u64 {
    if q < 1.0 {
        // exact: a power of two times q, then its integer part
        (q * (1u32 << DIGITS) as f32) as u64
    } else {
        (1 << DIGITS) - 1
    }
}

/// Bit `j` of `x` (below 2^16) moved to bit `3 j`.
#[inline]
fn spread(x: u64) -> u64 {
    let x = (x | x << 16) & 0x001f_0000_ff00_00ff;
    let x = (x | x << 8) & 0x100f_00f0_0f00_f00f;
    let x = (x | x << 4) & 0x10c3_0c30_c30c_30c3;
    (x | x << 2) & 0x1249_2492_4924_9249
}

/// The walk's choices for the point at `q` in the cube: bit
/// `3 DIGITS - 1 - d` says which half the split at depth `d` takes.
#[inline]
fn morton(q: Vec3) -> u64 {
    spread(digits(q.x)) << 2 | spread(digits(q.y)) << 1 | spread(digits(q.z))
}

/// The spatial trees over a cube around the scene, one per normal class:
/// nodes `0..NORMAL_CLASSES` are the roots.
#[derive(Debug, Clone, PartialEq)]
pub(super) struct SpatialTree {
    pub(super) origin: Vec3,
    /// `1 / side` of the cube.
    pub(super) inv_size: f32,
    nodes: Vec<SpatialNode>,
    /// Per class and path through its [`TOP_LEVELS`] levels (the top bits
    /// of [`morton`]): the leaf it ends in ([`LEAF_FLAG`] set) or the node
    /// at that depth.
    top: Vec<u32>,
}

impl SpatialTree {
    pub(super) fn new(min: Vec3, max: Vec3) -> Self {
        let (min, max) = if min.x <= max.x {
            (min, max)
        } else {
            (Vec3::ZERO, Vec3::ONE)
        };
        let side = (max - min).max_element();
        // a little larger than the scene, so no surface point is on the edge
        let side = if side > 0.0 && side.is_finite() {
            side * 1.01
        } else {
            1.0
        };
        let centre = 0.5 * (min + max);
        let mut tree = SpatialTree {
            origin: centre - Vec3::splat(0.5 * side),
            inv_size: 1.0 / side,
            nodes: (0..NORMAL_CLASSES as u32).map(SpatialNode::Leaf).collect(),
            top: Vec::new(),
        };
        tree.tabulate();
        tree
    }

    /// A tree read back from a saved guide: `nodes` must already be known
    /// to end every walk at a leaf of fewer than `2^31` (children after
    /// their node, within the tree). Refused unless it is a tree this
    /// build grows: every node reached once, each split's axis its depth
    /// mod 3, no split at depth [`MAX_SPATIAL_DEPTH`] or below.
    pub(super) fn from_parts(
        origin: Vec3,
        inv_size: f32,
        nodes: Vec<SpatialNode>,
    ) -> Result<Self, String> {
        let mut seen = vec![false; nodes.len()];
        let mut stack: Vec<(usize, u32)> = (0..NORMAL_CLASSES).map(|c| (c, 0)).collect();
        while let Some((node, depth)) = stack.pop() {
            if std::mem::replace(&mut seen[node], true) {
                return Err(format!("spatial node {node} has two parents"));
            }
            match nodes[node] {
                SpatialNode::Split { axis, child } => {
                    if u32::from(axis) != depth % 3 || depth >= MAX_SPATIAL_DEPTH {
                        return Err(format!(
                            "spatial node {node}: a split along axis {axis} at depth {depth}"
                        ));
                    }
                    stack.push((child as usize, depth + 1));
                    stack.push((child as usize + 1, depth + 1));
                }
                SpatialNode::Leaf(l) if l & LEAF_FLAG != 0 => {
                    return Err(format!("spatial leaf {l}: more than 2^31 leaves"));
                }
                SpatialNode::Leaf(_) => {}
            }
        }
        let mut tree = SpatialTree {
            origin,
            inv_size,
            nodes,
            top: Vec::new(),
        };
        tree.tabulate();
        Ok(tree)
    }

    /// The nodes, roots first.
    pub(super) fn nodes(&self) -> &[SpatialNode] {
        &self.nodes
    }

    /// Halve leaf node `node` at `depth` into leaves `low` (the lower half)
    /// and `high`; returns the first child node. [`SpatialTree::tabulate`]
    /// must follow before a lookup.
    pub(super) fn halve(&mut self, node: usize, depth: u32, low: u32, high: u32) -> usize {
        debug_assert!(depth < MAX_SPATIAL_DEPTH);
        let child = self.nodes.len();
        self.nodes.push(SpatialNode::Leaf(low));
        self.nodes.push(SpatialNode::Leaf(high));
        self.nodes[node] = SpatialNode::Split {
            axis: (depth % 3) as u8,
            child: child as u32,
        };
        child
    }

    /// Fill [`SpatialTree::top`] from the nodes.
    pub(super) fn tabulate(&mut self) {
        let nodes = &self.nodes;
        self.top = (0..NORMAL_CLASSES)
            .flat_map(|class| {
                (0..TOP_CELLS).map(move |path| {
                    let mut node = class;
                    for d in 0..TOP_LEVELS {
                        match nodes[node] {
                            SpatialNode::Leaf(l) => return l | LEAF_FLAG,
                            SpatialNode::Split { child, .. } => {
                                node = child as usize + ((path >> (TOP_LEVELS - 1 - d)) & 1)
                            }
                        }
                    }
                    match nodes[node] {
                        SpatialNode::Leaf(l) => l | LEAF_FLAG,
                        SpatialNode::Split { .. } => node as u32,
                    }
                })
            })
            .collect();
    }

    /// The leaf holding point `p` on a surface of normal `n` (points
    /// outside the cube go to the nearest leaf).
    #[inline]
    pub(super) fn leaf(&self, p: Vec3, n: Vec3) -> usize {
        let q = ((p - self.origin) * self.inv_size).clamp(Vec3::ZERO, Vec3::ONE);
        let m = morton(q);
        let levels = 3 * DIGITS;
        let top = self.top[normal_class(n) * TOP_CELLS + (m >> (levels - TOP_LEVELS)) as usize];
        if top & LEAF_FLAG != 0 {
            return (top & !LEAF_FLAG) as usize;
        }
        let mut node = top as usize;
        let mut bit = levels - 1 - TOP_LEVELS;
        loop {
            match self.nodes[node] {
                SpatialNode::Leaf(l) => return l as usize,
                SpatialNode::Split { child, .. } => {
                    node = child as usize + ((m >> bit) & 1) as usize;
                    // no split lies below the last digit
                    bit = bit.saturating_sub(1);
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampler::mix64;

    /// The leaf halving the point's coordinates level by level finds (the
    /// lookup before the Morton code and the table).
    fn leaf_by_halving(t: &SpatialTree, p: Vec3, n: Vec3) -> usize {
        let mut q = ((p - t.origin) * t.inv_size).clamp(Vec3::ZERO, Vec3::ONE);
        let mut node = normal_class(n);
        loop {
            match t.nodes[node] {
                SpatialNode::Leaf(l) => return l as usize,
                SpatialNode::Split { axis, child } => {
                    let a = axis as usize;
                    if q[a] < 0.5 {
                        q[a] *= 2.0;
                        node = child as usize;
                    } else {
                        q[a] = q[a] * 2.0 - 1.0;
                        node = child as usize + 1;
                    }
                }
            }
        }
    }

    fn unit(k: u64) -> f32 {
        (mix64(k) >> 40) as f32 / (1u64 << 24) as f32
    }

    #[test]
    fn the_morton_walk_finds_the_leaf_halving_finds_down_to_the_deepest_split() {
        let mut t = SpatialTree::new(Vec3::splat(-1.0), Vec3::splat(3.0));
        // split the leaves holding a few points all the way down, and
        // random leaves of every class a few levels
        let mut leaves = NORMAL_CLASSES as u32;
        let deep = [
            Vec3::new(0.3, 0.7, 1.1),
            t.origin,
            t.origin + Vec3::splat(1.0 / t.inv_size),
            Vec3::new(1.0, 1.0, 1.0),
        ];
        let mut deepest = Vec::new();
        for (k, &p) in deep.iter().enumerate() {
            let n = [Vec3::X, -Vec3::Y, Vec3::Z, -Vec3::Z][k];
            let mut node = normal_class(n);
            let mut q = ((p - t.origin) * t.inv_size).clamp(Vec3::ZERO, Vec3::ONE);
            for depth in 0..MAX_SPATIAL_DEPTH {
                let SpatialNode::Leaf(l) = t.nodes[node] else {
                    unreachable!("the walk follows leaves it made")
                };
                t.halve(node, depth, l, leaves);
                leaves += 1;
                let SpatialNode::Split { child, .. } = t.nodes[node] else {
                    unreachable!()
                };
                let a = (depth % 3) as usize;
                node = child as usize + usize::from(q[a] >= 0.5);
                q[a] = if q[a] < 0.5 {
                    q[a] * 2.0
                } else {
                    q[a] * 2.0 - 1.0
                };
            }
            let SpatialNode::Leaf(l) = t.nodes[node] else {
                unreachable!()
            };
            deepest.push((p, n, l as usize));
        }
        t.tabulate();
        // points near the deep ones (differing in low digits), at the
        // cube's faces and corners, outside it, and anywhere
        let side = 1.0 / t.inv_size;
        let mut points: Vec<Vec3> = Vec::new();
        for (k, &p) in deep.iter().enumerate() {
            points.push(p);
            for j in 0..200u64 {
                let e = 10f32.powf(-2.0 - 5.0 * unit(j ^ (k as u64 * 7919)));
                let d = Vec3::new(unit(3 * j), unit(3 * j + 1), unit(3 * j + 2)) - 0.5;
                points.push(p + d * e * side);
            }
        }
        for j in 0..2000u64 {
            let d = Vec3::new(unit(j << 8), unit(j << 8 | 1), unit(j << 8 | 2));
            points.push(t.origin + (d * 1.2 - 0.1) * side);
        }
        let normals = [Vec3::X, -Vec3::X, Vec3::Y, -Vec3::Y, Vec3::Z, -Vec3::Z];
        for &p in &points {
            for &n in &normals {
                let want = leaf_by_halving(&t, p, n);
                assert_eq!(t.leaf(p, n), want, "point {p:?}, normal {n:?}");
            }
        }
        // the deep points reach the leaves 48 levels down that hold them
        assert_eq!(leaves, NORMAL_CLASSES as u32 + 4 * MAX_SPATIAL_DEPTH);
        for (p, n, l) in deepest {
            assert_eq!(t.leaf(p, n), l, "point {p:?}");
        }
    }

    #[test]
    fn a_saved_tree_this_build_would_not_grow_is_refused() {
        let leaf = SpatialNode::Leaf;
        let mut nodes: Vec<SpatialNode> = (0..NORMAL_CLASSES as u32).map(leaf).collect();
        nodes[0] = SpatialNode::Split { axis: 0, child: 6 };
        nodes.extend([leaf(0), leaf(6)]);
        assert!(SpatialTree::from_parts(Vec3::ZERO, 1.0, nodes.clone()).is_ok());
        let mut wrong_axis = nodes.clone();
        wrong_axis[0] = SpatialNode::Split { axis: 1, child: 6 };
        let e = SpatialTree::from_parts(Vec3::ZERO, 1.0, wrong_axis).unwrap_err();
        assert!(e.contains("axis 1 at depth 0"), "{e}");
        // two parents
        let mut shared = nodes;
        shared[1] = SpatialNode::Split { axis: 0, child: 6 };
        let e = SpatialTree::from_parts(Vec3::ZERO, 1.0, shared).unwrap_err();
        assert!(e.contains("two parents"), "{e}");
    }
}
