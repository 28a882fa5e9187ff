//! Unit tests of the BVH as a whole: degenerate inputs, the depth bound, and
//! exact agreement with the naive backend on adversarial scenes (the shared
//! conformance suite in `tests/conformance.rs` covers the hard cases for
//! every backend).

use super::*;
use crate::accel::naive::Naive;
use crate::math::Vec3;
use crate::sampler::Sampler;
use crate::sampling::square_to_uniform_sphere;

/// Triangles with their own corners.
#[derive(Default)]
struct Soup {
    p: Vec<Vec3>,
    i: Vec<[u32; 3]>,
}

impl Soup {
    fn tri(&mut self, a: Vec3, b: Vec3, c: Vec3) {
        let n = self.p.len() as u32;
        self.p.extend([a, b, c]);
        self.i.push([n, n + 1, n + 2]);
    }

    fn soup(&self) -> TriangleSoup<'_> {
        TriangleSoup::triangles(&self.p, &self.i)
    }

    fn bvh(&self, quality: BvhQuality) -> Bvh {
        Bvh::new(self.soup(), quality).expect("a small BVH builds")
    }
}

/// Asserts that the BVH (both qualities) answers every ray exactly like the
/// naive backend.
fn assert_parity(soup: &Soup, rays: &[Ray]) {
    let naive = Naive::new(soup.soup());
    for quality in [BvhQuality::Fast, BvhQuality::High] {
        let bvh = soup.bvh(quality);
        for r in rays {
            assert_eq!(bvh.intersect(r), naive.intersect(r), "{quality:?} on {r:?}");
            assert_eq!(bvh.occluded(r), naive.occluded(r), "{quality:?} on {r:?}");
        }
    }
}

fn random_rays(s: &mut Sampler, n: usize, centre: Vec3, radius: f32) -> Vec<Ray> {
    (0..n)
        .map(|_| {
            let o = centre + square_to_uniform_sphere(s.next_2d()) * radius * s.next_1d();
            Ray::new(o, square_to_uniform_sphere(s.next_2d()))
        })
        .collect()
}

#[test]
fn empty_soup_never_hits() {
    let bvh = Soup::default().bvh(BvhQuality::Fast);
    let r = Ray::new(Vec3::ZERO, Vec3::X);
    assert!(bvh.intersect(&r).is_none() && !bvh.occluded(&r));
    assert_eq!(bvh.stats(), TreeStats::default());
}

#[test]
fn single_triangle_is_a_root_leaf() {
    let mut soup = Soup::default();
    soup.tri(Vec3::ZERO, Vec3::X, Vec3::Y);
    let bvh = soup.bvh(BvhQuality::Fast);
    assert_eq!(bvh.stats().nodes, 0);
    let h = bvh
        .intersect(&Ray::new(Vec3::new(0.25, 0.25, 1.0), -Vec3::Z))
        .expect("hit");
    assert_eq!((h.prim, h.t), (0, 1.0));
}

#[test]
fn a_leaf_of_several_blocks_answers_every_lane() {
    // 13 stacked copies of one triangle, a little apart in z: splitting
    // them saves no box area, so they become one root leaf of four blocks
    // (4 + 4 + 4 + 1 lanes), and a ray down -z must find the top one (the
    // last, in the last block's only lane) and, from between two copies,
    // the copy below
    let mut soup = Soup::default();
    for k in 0..13 {
        let z = Vec3::Z * (k as f32 * 1e-3);
        soup.tri(z, Vec3::X + z, Vec3::Y + z);
    }
    let bvh = soup.bvh(BvhQuality::Fast);
    let root = bvh.root.expect("a root");
    assert!(root.is_leaf() && root.count() == 13 && root.blocks() == 4);
    assert_eq!((bvh.stats().blocks, bvh.blocks.len()), (4, 4));
    let down = |z: f32| Ray::new(Vec3::new(0.25, 0.25, z), -Vec3::Z);
    assert_eq!(bvh.intersect(&down(1.0)).map(|h| h.prim), Some(12));
    assert_eq!(bvh.intersect(&down(0.0075)).map(|h| h.prim), Some(7));
    assert!(!bvh.occluded(&Ray::new(Vec3::new(0.25, 0.25, 1.0), Vec3::Z)));
    let mut s = Sampler::new(3, 0, 0);
    assert_parity(&soup, &random_rays(&mut s, 5000, Vec3::splat(0.3), 1.0));
}

#[test]
fn degenerate_and_non_finite_triangles() {
    let mut s = Sampler::new(1, 0, 0);
    let mut soup = Soup::default();
    for k in 0..500 {
        let a = Vec3::new(s.next_1d(), s.next_1d(), s.next_1d());
        let b = Vec3::new(s.next_1d(), s.next_1d(), s.next_1d());
        match k % 3 {
            0 => soup.tri(a, a, b),             // repeated corner
            1 => soup.tri(a, b, 2.0 * b - a),   // collinear
            _ => soup.tri(a, a + 1e-30 * b, a), // a point
        }
    }
    let rays = random_rays(&mut s, 5000, Vec3::splat(0.5), 1.0);
    assert_parity(&soup, &rays);
    let bvh = soup.bvh(BvhQuality::Fast);
    assert!(rays.iter().all(|r| bvh.intersect(r).is_none()));

    // non-finite corners: left out of the tree, never hit, no NaN bounds
    let mut soup = Soup::default();
    soup.tri(
        Vec3::new(-1.0, -1.0, 0.0),
        Vec3::new(1.0, -1.0, 0.0),
        Vec3::Y,
    );
    soup.tri(Vec3::new(f32::NAN, 0.0, 0.0), Vec3::X, Vec3::Y);
    soup.tri(Vec3::new(0.0, f32::INFINITY, 1.0), Vec3::X, Vec3::Y);
    soup.tri(Vec3::ZERO, Vec3::X, Vec3::new(0.0, 0.0, f32::NEG_INFINITY));
    let bvh = soup.bvh(BvhQuality::Fast);
    assert_eq!(bvh.blocks.len(), 1);
    assert_eq!(
        (bvh.blocks[0].ids[0], bvh.root.map(|r| r.last_lanes())),
        (0, Some(1))
    );
    assert!(bvh.bounds.min.is_finite() && bvh.bounds.max.is_finite());
    let rays = random_rays(&mut s, 5000, Vec3::ZERO, 2.0);
    assert_parity(&soup, &rays);
    assert!(
        rays.iter()
            .all(|r| bvh.intersect(r).is_none_or(|h| h.prim == 0))
    );
}

#[test]
fn depth_bound_holds_for_skewed_input() {
    // Nested triangles over 200 binades: the SAH peels off the largest one
    // at each level, so without the depth bound the tree would be about as
    // deep as the input is long (over 60 8-wide levels).
    let mut soup = Soup::default();
    for k in 0..200 {
        let e = 2f32.powi(k - 100);
        for j in 0..3 {
            let o = Vec3::new(0.0, 0.0, j as f32 * 1e-3 * e);
            soup.tri(o, o + Vec3::X * e, o + Vec3::Y * e);
        }
    }
    for quality in [BvhQuality::Fast, BvhQuality::High] {
        let st = soup.bvh(quality).stats();
        assert!(
            st.depth <= build::MAX_DEPTH.div_ceil(node::LEVELS),
            "{st:?}"
        );
        assert!((node::WIDTH - 1) * st.depth < STACK_SIZE);
    }
    let mut s = Sampler::new(3, 0, 0);
    let mut rays = random_rays(&mut s, 3000, Vec3::ZERO, 2.0);
    // through every triangle, from outside and from within the smallest
    rays.push(Ray::new(Vec3::new(1e-31, 1e-31, 1.0), -Vec3::Z));
    rays.push(Ray::new(Vec3::new(1e-31, 1e-31, -1e-35), Vec3::Z));
    assert_parity(&soup, &rays);
}

#[test]
fn sampled_binning_keeps_the_depth_bound_and_the_answers() {
    // Like the test above, with 100 triangles a binade (20k in all): the top
    // ranges are large enough for the Fast build to bin a sample, and the
    // deep ones large enough for the depth bound to need exact counts.
    let mut soup = Soup::default();
    for k in 0..200 {
        let e = 2f32.powi(k - 100);
        for j in 0..100 {
            let o = Vec3::new(j as f32 * 1e-2 * e, 0.0, j as f32 * 1e-3 * e);
            soup.tri(o, o + Vec3::X * e, o + Vec3::Y * e);
        }
    }
    assert!(soup.i.len() > 2 << build::SAMPLE_SHIFT);
    let st = soup.bvh(BvhQuality::Fast).stats();
    assert!(
        st.depth <= build::MAX_DEPTH.div_ceil(node::LEVELS),
        "{st:?}"
    );
    let mut s = Sampler::new(4, 0, 0);
    let mut rays = random_rays(&mut s, 400, Vec3::ZERO, 2.0);
    rays.push(Ray::new(Vec3::new(1e-31, 1e-31, 1.0), -Vec3::Z));
    assert_parity(&soup, &rays);
}

#[test]
fn mixed_scene_on_huge_pages_matches_naive() {
    // cornell-mesh in small: five large walls around a tessellated sphere
    // of 64k small triangles, enough blocks (over 2 MiB) for them to be
    // mapped on huge pages; rays start inside the box, inside the sphere's
    // hollow and outside the box
    let mut soup = Soup::default();
    let (nu, nv) = (256, 128);
    let at = |u: usize, v: usize| {
        let (phi, theta) = (
            u as f32 / nu as f32 * std::f32::consts::TAU,
            v as f32 / nv as f32 * std::f32::consts::PI,
        );
        // a bumpy radius, so the surface is not convex
        let r = 0.5 + 0.02 * (7.0 * phi).sin() * (5.0 * theta).cos();
        Vec3::new(
            r * theta.sin() * phi.cos(),
            0.6 + r * theta.cos(),
            r * theta.sin() * phi.sin(),
        )
    };
    for u in 0..nu {
        for v in 0..nv {
            let (a, b, c, d) = (at(u, v), at(u + 1, v), at(u + 1, v + 1), at(u, v + 1));
            soup.tri(a, b, c);
            soup.tri(a, c, d);
        }
    }
    let c = |x: f32, y: f32, z: f32| Vec3::new(x, y, z);
    for [a, b, cc, d] in [
        [
            c(-1., 0., -1.),
            c(1., 0., -1.),
            c(1., 0., 1.),
            c(-1., 0., 1.),
        ],
        [
            c(-1., 2., -1.),
            c(1., 2., -1.),
            c(1., 2., 1.),
            c(-1., 2., 1.),
        ],
        [
            c(-1., 0., -1.),
            c(1., 0., -1.),
            c(1., 2., -1.),
            c(-1., 2., -1.),
        ],
        [
            c(-1., 0., -1.),
            c(-1., 2., -1.),
            c(-1., 2., 1.),
            c(-1., 0., 1.),
        ],
        [c(1., 0., -1.), c(1., 2., -1.), c(1., 2., 1.), c(1., 0., 1.)],
    ] {
        soup.tri(a, b, cc);
        soup.tri(a, cc, d);
    }
    let bvh = soup.bvh(BvhQuality::Fast);
    assert!(bvh.blocks.len() * std::mem::size_of::<Tri4>() > pages::HUGE_MIN);
    assert_eq!(bvh.blocks.is_mapped(), cfg!(target_os = "linux"));
    let mut s = Sampler::new(19, 6, 0);
    let mut rays = random_rays(&mut s, 300, Vec3::new(0.0, 1.0, 0.0), 1.0);
    rays.extend(random_rays(&mut s, 300, Vec3::new(0.0, 0.6, 0.0), 0.45));
    rays.extend(random_rays(&mut s, 100, Vec3::new(0.0, 1.0, 4.0), 0.5));
    // shadow-like rays from points on the sphere to the ceiling, with a
    // finite extent
    for k in 0..200 {
        let o = at((k * 37) % nu, (k * 11) % nv);
        let target = c(s.next_1d() - 0.5, 1.99, s.next_1d() - 0.5);
        let mut r = Ray::new(o, (target - o).normalize());
        r.t_max = (target - o).length();
        rays.push(r);
    }
    let hits = rays.iter().filter(|r| bvh.intersect(r).is_some()).count();
    assert!(hits > rays.len() / 2, "{hits} of {} rays hit", rays.len());
    assert_parity(&soup, &rays);
}

#[test]
fn huge_sliver_seen_from_afar_matches_naive() {
    // Found by the adversarial search below: the watertight test's `t` for
    // this 52214 x 0.5 sliver is 12 units (1.3e-4) short of the true 89796.5,
    // and t_max lies between the two. Culling on the ray's entry into the
    // sliver's box would skip a hit the naive backend reports.
    let mut soup = Soup::default();
    let x = 0.537_429_33;
    soup.tri(
        Vec3::new(x, -1.215_501_3, -0.549_488_8),
        Vec3::new(x, 52_214.426, -0.549_488_8),
        Vec3::new(x, -1.215_501_3, -0.049_488_78),
    );
    for k in 0..12 {
        // unrelated triangles, so the sliver sits under an inner node
        let c = Vec3::new(10.0 + k as f32, -20.0, 5.0 * (k % 3) as f32);
        soup.tri(c, c + Vec3::X, c + Vec3::Z);
    }
    let r = Ray {
        o: Vec3::new(27_531.541, 105_265.74, -25_629.531),
        d: Vec3::new(-0.306_593_36, -0.908_041_54, 0.285_413_98),
        t_max: 89_792.586,
    };
    let naive = Naive::new(soup.soup()).intersect(&r);
    assert!(naive.is_some_and(|h| h.prim == 0 && h.t < 89_790.0));
    assert_parity(&soup, &[r]);
}

#[test]
fn tie_goes_to_the_lowest_original_index() {
    // the same triangle three times, in an order the build will shuffle
    let mut soup = Soup::default();
    let mut s = Sampler::new(4, 0, 0);
    for k in 0..40 {
        let c = Vec3::new(k as f32 * 3.0, 0.0, 0.0);
        soup.tri(c, c + Vec3::X, c + Vec3::Y);
        if k % 8 == 0 {
            soup.tri(c, c + Vec3::X, c + Vec3::Y);
            soup.tri(c + Vec3::Y, c, c + Vec3::X);
        }
    }
    let mut rays = Vec::new();
    for k in 0..40 {
        for _ in 0..20 {
            let p = Vec3::new(k as f32 * 3.0 + 0.3 * s.next_1d(), 0.3 * s.next_1d(), 0.0);
            let o = p + Vec3::new(s.next_1d() - 0.5, s.next_1d() - 0.5, 1.0);
            rays.push(Ray::new(o, (p - o).normalize()));
        }
    }
    assert_parity(&soup, &rays);
}

/// A scene from the adversarial search: axis-aligned grids (box faces
/// shared with triangle edges), huge and tiny triangles, huge axis-aligned
/// slivers, and near-coplanar fans.
fn adversarial_scene(kind: usize, s: &mut Sampler) -> Soup {
    let mut soup = Soup::default();
    let mut r = || s.next_1d();
    match kind {
        0 => {
            let scale = [1e-3f32, 1.0, 1e3][(r() * 3.0) as usize % 3];
            let off = Vec3::new(r(), r(), r()) * scale * [0.0, 1.0, 1e4][(r() * 3.0) as usize % 3];
            for x in 0..6 {
                for y in 0..6 {
                    for z in 0..3 {
                        if r() < 0.5 {
                            continue;
                        }
                        let o = off + Vec3::new(x as f32, y as f32, z as f32) * scale;
                        let a = (r() * 3.0) as usize % 3;
                        let mut u = Vec3::ZERO;
                        let mut v = Vec3::ZERO;
                        u[(a + 1) % 3] = scale;
                        v[(a + 2) % 3] = scale;
                        soup.tri(o, o + u, o + u + v);
                        soup.tri(o, o + u + v, o + v);
                    }
                }
            }
        }
        1 => {
            for _ in 0..300 {
                let size = 10f32.powf(r() * 8.0 - 4.0);
                let c = (Vec3::new(r(), r(), r()) - Vec3::splat(0.5)) * 10.0;
                let mut v = || c + (Vec3::new(r(), r(), r()) - Vec3::splat(0.5)) * size;
                let (a, b, c) = (v(), v(), v());
                soup.tri(a, b, c);
            }
        }
        2 => {
            for _ in 0..40 {
                let big = 10f32.powf(2.0 + r() * 3.0);
                let o = (Vec3::new(r(), r(), r()) - Vec3::splat(0.5)) * 4.0;
                let a = (r() * 3.0) as usize % 3;
                let b = (a + 1 + (r() * 2.0) as usize % 2) % 3;
                let (mut ea, mut eb, mut ec) = (Vec3::ZERO, Vec3::ZERO, Vec3::ZERO);
                ea[a] = big * if r() < 0.5 { 1.0 } else { -1.0 };
                eb[b] = big * if r() < 0.5 { 1.0 } else { -1.0 };
                ec[3 - a - b] = 0.5;
                soup.tri(o, o + ea, o + eb);
                soup.tri(o, o + ea, o + ec);
            }
        }
        _ => {
            let n = Vec3::new(r() - 0.5, r() - 0.5, r() - 0.5).normalize();
            let t1 = n.any_orthonormal_vector();
            let t2 = n.cross(t1);
            for k in 0..200 {
                let c = t1 * (r() - 0.5) * 4.0 + t2 * (r() - 0.5) * 4.0;
                let a = c + n * (r() - 0.5) * 1e-3 * (k % 3) as f32;
                let b = a + t1 * (r() * 3.0) + n * (r() - 0.5) * 1e-4;
                let cc = a + t2 * (r() * 0.5) + n * (r() - 0.5) * 1e-4;
                soup.tri(a, b, cc);
                if k % 4 == 0 {
                    soup.tri(b, a, a - t2 * (r() * 0.5));
                }
            }
        }
    }
    soup
}

/// Rays that start on or near vertices and on their planes, or far away;
/// aimed at vertices, at points of edges, or anywhere; some axis-parallel,
/// some with a zero component, some grazing a triangle's plane; some with a
/// `t_max` at or near a target.
fn adversarial_rays(soup: &Soup, s: &mut Sampler, n: usize) -> Vec<Ray> {
    let lo = soup.p.iter().fold(Vec3::INFINITY, |a, &b| a.min(b));
    let hi = soup.p.iter().fold(Vec3::NEG_INFINITY, |a, &b| a.max(b));
    let ext = (hi - lo).max_element().max(1e-6);
    let axes = [Vec3::X, -Vec3::X, Vec3::Y, -Vec3::Y, Vec3::Z, -Vec3::Z];
    let mut out = Vec::with_capacity(n);
    while out.len() < n {
        let vertex = |s: &mut Sampler| soup.p[s.next_u32() as usize % soup.p.len()];
        let tri = |s: &mut Sampler| {
            soup.i[s.next_u32() as usize % soup.i.len()].map(|k| soup.p[k as usize])
        };
        let o = match s.next_u32() % 4 {
            0 => {
                vertex(s)
                    + square_to_uniform_sphere(s.next_2d())
                        * [0.0f32, 1e-3, 1.0][s.next_u32() as usize % 3]
            }
            1 => {
                let v = vertex(s);
                let mut o = lo + (hi - lo) * Vec3::new(s.next_1d(), s.next_1d(), s.next_1d());
                let a = s.next_u32() as usize % 3;
                o[a] = v[a];
                if s.next_1d() < 0.5 {
                    o[(a + 1) % 3] = v[(a + 1) % 3];
                }
                o
            }
            _ => {
                let far = [0.0f32, 0.1, 1.0, 10.0, 1e3][s.next_u32() as usize % 5];
                0.5 * (lo + hi) + square_to_uniform_sphere(s.next_2d()) * ext * (0.5 + far)
            }
        };
        let target = match s.next_u32() % 8 {
            0 => vertex(s),
            1 => {
                let [a, b, _] = tri(s);
                a + (b - a) * s.next_1d().powi(6)
            }
            2 => {
                let [_, b, c] = tri(s);
                0.5 * (b + c)
            }
            _ => o + square_to_uniform_sphere(s.next_2d()),
        };
        let mut d = (target - o).normalize();
        match s.next_u32() % 6 {
            0 => d = axes[s.next_u32() as usize % 6],
            1 => {
                let [a, b, c] = tri(s);
                let nrm = (b - a).cross(c - a).normalize();
                if nrm.is_finite() {
                    let eps = [0.0f32, 1e-7, 1e-5, 1e-3][s.next_u32() as usize % 4];
                    d = ((d - nrm * d.dot(nrm)).normalize() + nrm * eps * (s.next_1d() - 0.5))
                        .normalize();
                }
            }
            2 => {
                d[s.next_u32() as usize % 3] = if s.next_1d() < 0.5 { 0.0 } else { -0.0 };
                d = d.normalize();
            }
            _ => {}
        }
        if !d.is_finite() {
            continue;
        }
        let mut ray = Ray::new(o, d);
        if s.next_1d() < 0.3 {
            ray.t_max =
                (target - o).length() * [1.0f32, 0.5, 1.000_000_1][s.next_u32() as usize % 3];
        }
        out.push(ray);
    }
    out
}

/// A seed for a search that should explore: `EMBERTRACE_SEARCH_SEED` when
/// set (to replay a run), else a fresh one from the system; printed, with
/// the line that replays it, so a failure can be reproduced.
fn exploring_seed(test: &str) -> u64 {
    let seed = match std::env::var("EMBERTRACE_SEARCH_SEED") {
        Ok(v) => v.parse().expect("EMBERTRACE_SEARCH_SEED must be a u64"),
        Err(_) => {
            use std::io::Read;
            let mut b = [0u8; 8];
            std::fs::File::open("/dev/urandom")
                .and_then(|mut f| f.read_exact(&mut b))
                .expect("/dev/urandom");
            u64::from_le_bytes(b)
        }
    };
    eprintln!(
        "{test}: search seed {seed}; replay: EMBERTRACE_SEARCH_SEED={seed} cargo test {test}"
    );
    seed
}

#[test]
fn adversarial_scenes_match_naive_bit_for_bit() {
    // 1.2M rays of this search (60 scenes x 20k) found the sliver case above;
    // the test keeps a smaller share of it: seed 1 (which holds that case)
    // every run, and a fresh seed that explores further each run
    let fresh = exploring_seed("adversarial_scenes_match_naive_bit_for_bit");
    for (seed, scenes) in [(1, 16), (fresh, 8)] {
        let mut s = Sampler::new(seed, 0, 0);
        for k in 0..scenes {
            let soup = adversarial_scene(k % 4, &mut s);
            let rays = adversarial_rays(&soup, &mut s, 4000);
            assert_parity(&soup, &rays);
        }
    }
}

#[test]
#[ignore = "long adversarial search (about a minute in release): cargo test --release --no-default-features adversarial_search -- --ignored"]
fn adversarial_search_long() {
    let fresh = exploring_seed("adversarial_search_long");
    for seed in (0..4).map(|k| fresh.wrapping_add(k)) {
        let mut s = Sampler::new(seed, 1, 0);
        for k in 0..100 {
            let soup = adversarial_scene(k % 4, &mut s);
            let rays = adversarial_rays(&soup, &mut s, 20_000);
            assert_parity(&soup, &rays);
        }
    }
}
