//! The default for the smallest scenes (`--accel embree+naive`): Embree
//! for coherent batches (camera rays, which it traces as packets) and for
//! every shadow ray, the sixteen-wide brute force ([`super::naive`]) for
//! the closest hits of scattered rays.
//!
//! With a few dozen triangles a ray's closest hit is two or three passes of
//! sixteen watertight tests, cheaper than a walk of Embree's tree in robust
//! mode for rays that go every which way; a block of camera rays, which
//! share their path, Embree traces cheaper as one packet. A shadow ray is
//! the other way round: Embree's walk stops at the first hit near the ray,
//! the brute force goes through blocks of sixteen until one is hit, and
//! through all of them for a ray that reaches its light (`bench`: naive
//! shadow rays at 0.61x to 0.64x Embree's rate on the door, its diffuse
//! bounces at 1.38x to 1.66x).
//! Sending shadow rays to Embree instead of the brute force, one thread,
//! user time, alternating (5 rounds, medians of the paired ratios): door
//! (`benches/race/hard/door-ajar.xml`, 128 spp, unguided) 0.984x the time,
//! the Cornell box (16 spp) 0.906x. With the shadow rays on the brute
//! force, the backend took 0.854x `embree`'s time on the door (32 spp) and
//! 0.983x on the Cornell box. With spheres it was slower on
//! `scenes/materials.toml` (2 triangles, 1.062x: the brute force keeps its
//! spheres in a small tree), so [`super::Backend::for_scene`] picks it for
//! triangles alone.

use super::{Accelerator, AlphaTest, Coherence, Hit};
use crate::math::Ray;

/// Embree for packets and shadow rays, another backend for the rest.
pub(super) struct Hybrid {
    /// Answers coherent batches.
    pub(super) packets: Box<dyn Accelerator>,
    /// Answers the closest hits of single rays and incoherent batches.
    pub(super) scattered: Box<dyn Accelerator>,
}

impl Hybrid {
    /// The backend that answers a batch of this coherence.
    fn for_batch(&self, coherence: Coherence) -> &dyn Accelerator {
        match coherence {
            Coherence::Coherent => self.packets.as_ref(),
            Coherence::Incoherent => self.scattered.as_ref(),
        }
    }
}

impl Accelerator for Hybrid {
    fn name(&self) -> &'static str {
        super::Backend::EmbreeNaive.name()
    }
    fn intersect(&self, ray: &Ray) -> Option<Hit> {
        self.scattered.intersect(ray)
    }
    fn occluded(&self, ray: &Ray) -> bool {
        self.packets.occluded(ray)
    }
    fn memory_bytes(&self) -> usize {
        self.packets.memory_bytes() + self.scattered.memory_bytes()
    }
    fn intersect_masked(&self, ray: &Ray, alpha: &dyn AlphaTest) -> Option<Hit> {
        self.scattered.intersect_masked(ray, alpha)
    }
    fn occluded_masked(&self, ray: &Ray, alpha: &dyn AlphaTest) -> bool {
        self.packets.occluded_masked(ray, alpha)
    }
    fn intersect_batch(&self, rays: &[Ray], hits: &mut [Option<Hit>], coherence: Coherence) {
        self.for_batch(coherence)
            .intersect_batch(rays, hits, coherence)
    }
    fn occluded_batch(&self, rays: &[Ray], occluded: &mut [bool], coherence: Coherence) {
        self.packets.occluded_batch(rays, occluded, coherence)
    }
}

#[cfg(all(test, any(feature = "embree", feature = "embree4")))]
mod tests {
    use super::super::{AccelOptions, Backend, TriangleSoup, build};
    use super::*;
    use crate::math::Vec3;
    use crate::sampler::Sampler;

    /// A unit cube's 12 triangles and a 2 x 2 grid's 8 below it.
    fn scene() -> (Vec<Vec3>, Vec<[u32; 3]>) {
        let mut p: Vec<Vec3> = (0..8)
            .map(|k| Vec3::new((k & 1) as f32, (k >> 1 & 1) as f32, (k >> 2) as f32))
            .collect();
        let mut i = vec![
            [0, 2, 1],
            [1, 2, 3],
            [4, 5, 6],
            [5, 7, 6],
            [0, 1, 4],
            [1, 5, 4],
            [2, 6, 3],
            [3, 6, 7],
            [0, 4, 2],
            [2, 4, 6],
            [1, 3, 5],
            [3, 7, 5],
        ];
        for y in 0..3 {
            for x in 0..3 {
                p.push(Vec3::new(x as f32 - 1.0, y as f32 - 1.0, -1.0));
            }
        }
        for y in 0..2u32 {
            for x in 0..2u32 {
                let a = 8 + y * 3 + x;
                i.push([a, a + 1, a + 3]);
                i.push([a + 1, a + 4, a + 3]);
            }
        }
        (p, i)
    }

    #[test]
    fn packets_and_shadow_rays_go_to_embree_and_the_rest_to_the_brute_force() {
        let (p, i) = scene();
        let soup = TriangleSoup::triangles(&p, &i);
        let opts = AccelOptions::default();
        let hybrid = build(Backend::EmbreeNaive, soup, opts).unwrap();
        let embree = build(Backend::Embree, soup, opts).unwrap();
        let naive = build(Backend::Naive, soup, opts).unwrap();
        assert_eq!(hybrid.name(), "embree+naive");
        let mut s = Sampler::new(3, 0, 0);
        let mut v3 = || Vec3::new(s.next_1d(), s.next_1d(), s.next_1d()) - 0.5;
        let rays: Vec<Ray> = (0..64)
            .map(|_| {
                let o = Vec3::new(0.5, 0.5, 3.0) + 0.2 * v3();
                let d = (Vec3::new(0.0, 0.0, -1.0) + 0.4 * v3()).normalize();
                Ray::new(o, d)
            })
            .collect();
        let mut differ = 0;
        for chunk in rays.chunks(16) {
            for coherence in [Coherence::Coherent, Coherence::Incoherent] {
                let want = match coherence {
                    Coherence::Coherent => &embree,
                    Coherence::Incoherent => &naive,
                };
                let (mut got, mut expect) = (vec![None; 16], vec![None; 16]);
                hybrid.intersect_batch(chunk, &mut got, coherence);
                want.intersect_batch(chunk, &mut expect, coherence);
                assert_eq!(got, expect, "{coherence:?}");
                let (mut got, mut expect) = (vec![false; 16], vec![false; 16]);
                hybrid.occluded_batch(chunk, &mut got, coherence);
                embree.occluded_batch(chunk, &mut expect, coherence);
                assert_eq!(got, expect, "{coherence:?}");
            }
            for r in chunk {
                assert_eq!(hybrid.intersect(r), naive.intersect(r));
                assert_eq!(hybrid.occluded(r), embree.occluded(r));
                // the two answer the same hits, to a few ulps
                if hybrid.intersect(r) != embree.intersect(r) {
                    differ += 1;
                }
            }
        }
        let hits = rays.iter().filter(|r| naive.intersect(r).is_some()).count();
        assert!(hits > 48, "{hits} of 64 rays hit");
        // which backend answered shows in the last bits of `t`, `u`, `v`
        assert!(differ > 0, "Embree and the brute force agreed to the bit");
    }

    #[test]
    fn only_small_triangle_scenes_default_to_it() {
        let (p, i) = scene();
        assert_eq!(i.len(), 20);
        let soup = TriangleSoup::triangles(&p, &i);
        assert_eq!(Backend::for_scene(&soup), Backend::EmbreeNaive);
        let many: Vec<[u32; 3]> = i.iter().cycle().take(33).copied().collect();
        let soup = TriangleSoup::triangles(&p, &many);
        assert_eq!(Backend::for_scene(&soup), Backend::Embree);
        let at_limit: Vec<[u32; 3]> = i.iter().cycle().take(32).copied().collect();
        let soup = TriangleSoup::triangles(&p, &at_limit);
        assert_eq!(Backend::for_scene(&soup), Backend::EmbreeNaive);
        let sphere = [crate::shape::Sphere {
            center: Vec3::ZERO,
            radius: 1.0,
        }];
        let soup = TriangleSoup {
            spheres: &sphere,
            ..TriangleSoup::triangles(&p, &i)
        };
        assert_eq!(Backend::for_scene(&soup), Backend::Embree);
        assert_eq!("embree+naive".parse::<Backend>(), Ok(Backend::EmbreeNaive));
    }
}
