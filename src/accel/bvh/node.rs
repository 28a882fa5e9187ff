//! The BVH's memory layout: axis-aligned boxes, the 8-wide node whose eight
//! child boxes are stored as structure-of-arrays (one `[f32; 8]` per plane,
//! one lane per child, as in Embree's BVH4 and BVH8: Wald et al., "Embree: A
//! Kernel Framework for Efficient CPU Ray Tracing", ACM TOG 33(4), 2014),
//! and the packing of child references into one `u32`.

use crate::math::Vec3;
use glam::Vec3A;

/// An axis-aligned box (16-byte SIMD corners: the builder unions millions).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Aabb {
    /// Lower corner.
    pub min: Vec3A,
    /// Upper corner.
    pub max: Vec3A,
}

impl Aabb {
    /// The empty box: inverted, so it contains nothing and is the identity
    /// of [`Aabb::union`].
    pub const EMPTY: Aabb = Aabb {
        min: Vec3A::splat(f32::INFINITY),
        max: Vec3A::splat(f32::NEG_INFINITY),
    };

    /// The bounds of a triangle.
    #[inline]
    pub fn of_triangle(p: &[Vec3; 3]) -> Aabb {
        let [a, b, c] = p.map(Vec3A::from);
        Aabb {
            min: a.min(b).min(c),
            max: a.max(b).max(c),
        }
    }

    /// Whether the box contains nothing (like [`Aabb::EMPTY`]).
    #[inline]
    pub fn is_empty(&self) -> bool {
        self.min.cmpgt(self.max).any()
    }

    /// Grow to contain `p`.
    #[inline]
    pub fn grow(&mut self, p: Vec3A) {
        self.min = self.min.min(p);
        self.max = self.max.max(p);
    }

    /// The smallest box containing both.
    #[inline]
    pub fn union(&self, o: &Aabb) -> Aabb {
        Aabb {
            min: self.min.min(o.min),
            max: self.max.max(o.max),
        }
    }

    /// Half the surface area (0 for the empty box), the SAH's weight.
    #[inline]
    pub fn half_area(&self) -> f32 {
        let e = (self.max - self.min).max(Vec3A::ZERO);
        e.x * e.y + e.y * e.z + e.z * e.x
    }
}

/// Children per node. The builder handles any power of two up to 32 and the
/// slab test any multiple of 4 (four children per `Vec4`). With one-block
/// leaves, 8-wide nodes were no faster than 4-wide ones; since leaves hold
/// up to four blocks (and the nodes of the 1.2M-triangle benchmark sphere
/// fit in the last-level cache), 8-wide nodes are faster on every ray kind:
/// camera +15%, shadow +16%, diffuse +32% (median of 6 alternating runs of
/// `bench`, single-threaded), at the same memory per triangle. Embree picks
/// BVH8 on this machine too.
pub const WIDTH: usize = 8;
/// Binary levels a node spans at least (`log2(WIDTH)`).
pub const LEVELS: usize = WIDTH.trailing_zeros() as usize;
const _: () = assert!(WIDTH == 1 << LEVELS && WIDTH <= 32);

/// Triangles per block: the unit the leaf test takes at once ([`Tri4`]).
///
/// [`Tri4`]: crate::accel::triangle::Tri4
pub const BLOCK: usize = 4;

/// Most triangles in a leaf: up to four consecutive blocks. A leaf of
/// several blocks trades a node step (a dependent load, a cache miss in
/// large scenes) for block tests whose loads are independent.
pub const LEAF_MAX: usize = 16;

/// Top bit of a child reference: set for a leaf.
const LEAF_BIT: u32 = 1 << 31;
/// Bits of a leaf reference that hold `count - 1`.
const COUNT_BITS: u32 = 4;
const _: () = assert!(LEAF_MAX == 1 << COUNT_BITS && LEAF_MAX % BLOCK == 0);

/// Most triangles a BVH can hold: a leaf reference keeps its first block's
/// index in 27 bits, and there are never more blocks than triangles.
pub const MAX_TRIANGLES: usize = 1 << (31 - COUNT_BITS);

/// A child reference: an inner node's index, or (top bit set) a leaf: the
/// first `count <= LEAF_MAX` triangles of the consecutive blocks starting at
/// block `block` (every block full but the last).
#[derive(Debug, Clone, Copy, PartialEq, Eq, bytemuck::Pod, bytemuck::Zeroable)]
#[repr(transparent)]
pub struct ChildRef(pub u32);

impl ChildRef {
    /// The reference to inner node `index`.
    #[inline]
    pub fn inner(index: usize) -> ChildRef {
        debug_assert!(index < LEAF_BIT as usize);
        ChildRef(index as u32)
    }

    /// The reference to a leaf: `count` triangles from block `block` on.
    #[inline]
    pub fn leaf(block: usize, count: usize) -> ChildRef {
        debug_assert!((1..=LEAF_MAX).contains(&count) && block < MAX_TRIANGLES);
        ChildRef(LEAF_BIT | (block as u32) << COUNT_BITS | (count as u32 - 1))
    }

    /// Whether this is a leaf.
    #[inline(always)]
    pub fn is_leaf(self) -> bool {
        self.0 & LEAF_BIT != 0
    }

    /// A leaf's first block (meaningless for an inner node).
    #[inline(always)]
    pub fn block(self) -> usize {
        ((self.0 & !LEAF_BIT) >> COUNT_BITS) as usize
    }

    /// A leaf's triangle count (meaningless for an inner node).
    #[inline(always)]
    pub fn count(self) -> usize {
        (self.0 & (LEAF_MAX as u32 - 1)) as usize + 1
    }

    /// A leaf's blocks (meaningless for an inner node).
    #[inline(always)]
    pub fn blocks(self) -> usize {
        self.count().div_ceil(BLOCK)
    }

    /// The lane mask of a leaf's last block: one bit per triangle
    /// (meaningless for an inner node); the blocks before it are full.
    #[inline(always)]
    pub fn last_lanes(self) -> u32 {
        (2 << (self.0 & (BLOCK as u32 - 1))) - 1
    }

    /// An inner node's index (meaningless for a leaf).
    #[inline(always)]
    pub fn index(self) -> usize {
        self.0 as usize
    }
}

/// A node: the bounds of its [`WIDTH`] children, plane by plane, then the
/// children: 32 bytes per child, aligned to 64 so that an 8-wide node
/// occupies exactly four cache lines. An unused slot has the empty box: the
/// slab test of the traversal rejects it for every ray (its near plane is at
/// `+inf` whatever the direction's sign), so it needs no separate check.
/// Plain data with no implicit padding, so that it can live in memory
/// mapped for huge pages ([`super::pages`]).
#[derive(Debug, Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
#[repr(C, align(64))]
pub struct Node {
    /// `planes[a][slot]` is the lower plane on axis `a` (`0..3`), and
    /// `planes[3 + a][slot]` the upper one: a ray picks its near and far
    /// planes by index, with no branch on its direction's signs.
    pub planes: [[f32; WIDTH]; 6],
    /// Child references.
    pub child: [ChildRef; WIDTH],
    /// Fills the node to whole cache lines.
    pad: [u32; WIDTH],
}

impl Node {
    /// A node with four empty slots.
    pub const EMPTY: Node = Node {
        planes: [
            [f32::INFINITY; WIDTH],
            [f32::INFINITY; WIDTH],
            [f32::INFINITY; WIDTH],
            [f32::NEG_INFINITY; WIDTH],
            [f32::NEG_INFINITY; WIDTH],
            [f32::NEG_INFINITY; WIDTH],
        ],
        child: [ChildRef(0); WIDTH],
        pad: [0; WIDTH],
    };

    /// Put child `r` with bounds `b` in slot `k`.
    pub fn set(&mut self, k: usize, b: &Aabb, r: ChildRef) {
        for a in 0..3 {
            self.planes[a][k] = b.min[a];
            self.planes[3 + a][k] = b.max[a];
        }
        self.child[k] = r;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn child_refs_round_trip() {
        let r = ChildRef::leaf(MAX_TRIANGLES - 1, LEAF_MAX);
        assert!(r.is_leaf());
        assert_eq!(
            (r.block(), r.count(), r.blocks(), r.last_lanes()),
            (MAX_TRIANGLES - 1, LEAF_MAX, LEAF_MAX / BLOCK, 0b1111)
        );
        let r = ChildRef::leaf(7, 1);
        assert_eq!((r.block(), r.blocks(), r.last_lanes()), (7, 1, 1));
        assert_eq!(ChildRef::leaf(0, 3).last_lanes(), 0b111);
        let r = ChildRef::leaf(9, 6);
        assert_eq!((r.block(), r.blocks(), r.last_lanes()), (9, 2, 0b11));
        let r = ChildRef::inner(123_456);
        assert!(!r.is_leaf());
        assert_eq!(r.index(), 123_456);
    }

    #[test]
    fn node_is_whole_cache_lines() {
        assert_eq!(std::mem::size_of::<Node>(), 32 * WIDTH);
        assert_eq!(std::mem::align_of::<Node>(), 64);
    }

    #[test]
    fn empty_box_is_union_identity_with_zero_area() {
        let b = Aabb::of_triangle(&[Vec3::ZERO, Vec3::X, Vec3::Y]);
        assert_eq!(Aabb::EMPTY.union(&b), b);
        assert_eq!(Aabb::EMPTY.half_area(), 0.0);
        assert_eq!(b.half_area(), 1.0);
    }
}
