//! Procedural meshes, so that tests and benchmarks run on 100k to 10M
//! triangles without shipping large files (`[[procedural]]` in a TOML scene):
//!
//! ```toml
//! [[procedural]]
//! type = "sphere"          # or "terrain"
//! triangles = 1_000_000    # approximate; the exact count is reported
//! displacement = 0.1       # amplitude of the smooth displacement
//! seed = 0
//! transform = { scale = 1.0, translate = [0, 1, 0] }
//! material = { diffuse = 0.7 }
//! ```
//!
//! The sphere is a latitude-longitude grid of unit radius displaced along its
//! normal; the terrain is a grid over `[-1, 1]^2` in the xz plane displaced in
//! y. The displacement is a sum of eight sinusoids with random directions,
//! frequencies doubling and amplitudes halving (a cheap band-limited noise),
//! drawn from the scene's deterministic sampler, so a given seed always
//! gives the same mesh.

use super::{Material, MeshData};
use crate::math::Vec3;
use crate::sampler::Sampler;

pub use crate::limits::MAX_TRIANGLES;

/// A procedural shape.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Shape {
    /// A displaced unit sphere.
    Sphere,
    /// A displaced height field over `[-1, 1]^2`.
    Terrain,
}

struct Noise {
    waves: [(Vec3, f32, f32); 8],
}

impl Noise {
    fn new(seed: u64) -> Self {
        let mut s = Sampler::new(seed, u64::MAX, 0);
        let mut waves = [(Vec3::ZERO, 0.0, 0.0); 8];
        let mut amp_total = 0.0;
        for (k, w) in waves.iter_mut().enumerate() {
            let dir = crate::sampling::square_to_uniform_sphere(s.next_2d());
            let freq = 2.0 * (1u32 << k) as f32;
            let amp = 1.0 / (1u32 << k) as f32;
            amp_total += amp;
            *w = (dir * freq, s.next_1d() * std::f32::consts::TAU, amp);
        }
        for w in &mut waves {
            w.2 /= amp_total;
        }
        Noise { waves }
    }

    /// Smooth noise in `[-1, 1]`.
    fn at(&self, p: Vec3) -> f32 {
        self.waves
            .iter()
            .map(|(w, phase, amp)| amp * (w.dot(p) + phase).sin())
            .sum()
    }
}

/// The grid resolution for about `triangles` triangles: rings of the sphere
/// (with twice as many segments), or cells along a side of the terrain.
fn grid(shape: Shape, triangles: u64) -> u32 {
    let t = triangles.min(MAX_TRIANGLES) as f64;
    match shape {
        // 4 r (r - 1) triangles for r rings and 2 r segments
        Shape::Sphere => (((1.0 + (1.0 + t).sqrt()) / 2.0).ceil() as u32).max(3),
        // 2 n^2 triangles
        Shape::Terrain => ((t / 2.0).sqrt().ceil() as u32).max(2),
    }
}

/// Exact triangle and vertex counts of [`generate`]`(shape, triangles, ..)`,
/// so that a loader can check them against the scene limits before
/// generating anything.
pub fn counts(shape: Shape, triangles: u64) -> (u64, u64) {
    let g = grid(shape, triangles) as u64;
    match shape {
        Shape::Sphere => (4 * g * (g - 1), 2 + (g - 1) * 2 * g),
        Shape::Terrain => (2 * g * g, (g + 1) * (g + 1)),
    }
}

/// Generate a mesh with about `triangles` triangles (at least a few dozen;
/// requests beyond [`MAX_TRIANGLES`] are treated as [`MAX_TRIANGLES`]).
pub fn generate(
    shape: Shape,
    triangles: u64,
    displacement: f32,
    seed: u64,
    name: &str,
    material: Material,
) -> MeshData {
    let noise = Noise::new(seed);
    let mut m = MeshData {
        name: name.to_string(),
        materials: vec![material],
        ..MeshData::default()
    };
    match shape {
        Shape::Sphere => {
            let r = grid(shape, triangles);
            let s = 2 * r;
            let at = |theta: f32, phi: f32| {
                let d = Vec3::new(
                    theta.sin() * phi.cos(),
                    theta.cos(),
                    theta.sin() * phi.sin(),
                );
                (d * (1.0 + displacement * noise.at(d))).as_dvec3()
            };
            let pi = std::f32::consts::PI;
            m.positions.push(at(0.0, 0.0));
            for i in 1..r {
                let theta = pi * i as f32 / r as f32;
                for j in 0..s {
                    m.positions.push(at(theta, 2.0 * pi * j as f32 / s as f32));
                }
            }
            m.positions.push(at(pi, 0.0));
            let ring = |i: u32, j: u32| 1 + (i - 1) * s + (j % s);
            let south = m.positions.len() as u32 - 1;
            for j in 0..s {
                // outward-facing: counter-clockwise seen from outside
                m.indices.push([0, ring(1, j + 1), ring(1, j)]);
                m.indices.push([south, ring(r - 1, j), ring(r - 1, j + 1)]);
            }
            for i in 1..r - 1 {
                for j in 0..s {
                    let (a, b, c, d) = (
                        ring(i, j),
                        ring(i, j + 1),
                        ring(i + 1, j + 1),
                        ring(i + 1, j),
                    );
                    m.indices.push([a, b, c]);
                    m.indices.push([a, c, d]);
                }
            }
        }
        Shape::Terrain => {
            let n = grid(shape, triangles);
            for i in 0..=n {
                for j in 0..=n {
                    let x = -1.0 + 2.0 * j as f32 / n as f32;
                    let z = -1.0 + 2.0 * i as f32 / n as f32;
                    let y = displacement * noise.at(Vec3::new(x, 0.0, z));
                    m.positions.push(Vec3::new(x, y, z).as_dvec3());
                }
            }
            let v = |i: u32, j: u32| i * (n + 1) + j;
            for i in 0..n {
                for j in 0..n {
                    // facing +y
                    m.indices.push([v(i, j), v(i + 1, j), v(i + 1, j + 1)]);
                    m.indices.push([v(i, j), v(i + 1, j + 1), v(i, j + 1)]);
                }
            }
        }
    }
    m.tri_material = vec![0; m.indices.len()];
    m
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::triangle_normal;

    #[test]
    fn counts_and_orientation() {
        for (shape, n) in [(Shape::Sphere, 10_000u64), (Shape::Terrain, 10_000)] {
            let m = generate(shape, n, 0.1, 3, "t", Material::default());
            let count = m.indices.len() as f64;
            assert!(
                (count - n as f64).abs() < 0.05 * n as f64,
                "{shape:?}: {count} triangles"
            );
            for t in &m.indices {
                let p = t.map(|i| m.positions[i as usize].as_vec3());
                let nrm = triangle_normal(p[0], p[1], p[2]).expect("no degenerate triangles");
                let c = (p[0] + p[1] + p[2]) / 3.0;
                let outward = match shape {
                    Shape::Sphere => c.normalize(),
                    Shape::Terrain => Vec3::Y,
                };
                assert!(nrm.dot(outward) > 0.0, "{shape:?}: triangle faces inward");
            }
        }
        for shape in [Shape::Sphere, Shape::Terrain] {
            for n in [0, 1, 7, 100, 12_345] {
                let m = generate(shape, n, 0.1, 3, "t", Material::default());
                let want = (m.indices.len() as u64, m.positions.len() as u64);
                assert_eq!(counts(shape, n), want, "{shape:?} {n}");
            }
        }
        let a = generate(Shape::Sphere, 1000, 0.2, 1, "a", Material::default());
        let b = generate(Shape::Sphere, 1000, 0.2, 1, "b", Material::default());
        assert_eq!(a.positions, b.positions);
    }
}
