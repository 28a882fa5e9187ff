//! The analytic shapes a scene holds besides its triangles: [`Sphere`]. The
//! loaders make them, every backend intersects them, and the lights sample
//! the emitting ones, so they belong to none of those rooms.

use crate::math::Vec3;

/// An analytic sphere. Its outward normal is the front side.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sphere {
    /// Centre.
    pub center: Vec3,
    /// Radius, `> 0`.
    pub radius: f32,
}
