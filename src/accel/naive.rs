//! The brute-force backend: every ray is tested against every triangle with
//! the watertight routine of [`super::triangle`]. Quadratic and slow; it is
//! the oracle the other backends are checked against.

use super::triangle::WatertightRay;
use super::{Accelerator, Hit, TriangleSoup};
use crate::math::{Ray, Vec3};

/// Brute force over a copy of the triangles.
pub struct Naive {
    tris: Vec<[Vec3; 3]>,
}

impl Naive {
    /// Copy the triangles of `soup`.
    pub fn new(soup: TriangleSoup<'_>) -> Self {
        let tris = soup
            .indices
            .iter()
            .map(|t| t.map(|i| soup.positions[i as usize]))
            .collect();
        Naive { tris }
    }
}

impl Accelerator for Naive {
    fn name(&self) -> &'static str {
        "naive"
    }

    fn memory_bytes(&self) -> usize {
        self.tris.capacity() * std::mem::size_of::<[Vec3; 3]>()
    }

    fn intersect(&self, ray: &Ray) -> Option<Hit> {
        if !ray.is_finite() {
            return None;
        }
        let wr = WatertightRay::new(ray);
        let mut best: Option<Hit> = None;
        let mut t_max = ray.t_max;
        for (i, t) in self.tris.iter().enumerate() {
            if let Some(mut h) = wr.intersect(t[0], t[1], t[2], t_max) {
                // strictly closer only: ties keep the lowest index
                if best.is_none_or(|b| h.t < b.t) {
                    h.prim = i as u32;
                    t_max = h.t;
                    best = Some(h);
                }
            }
        }
        best
    }

    fn occluded(&self, ray: &Ray) -> bool {
        if !ray.is_finite() {
            return false;
        }
        let wr = WatertightRay::new(ray);
        self.tris
            .iter()
            .any(|t| wr.intersect(t[0], t[1], t[2], ray.t_max).is_some())
    }
}
