//! Sampling a rectangle uniformly in the solid angle it subtends from a
//! point: Ureña, Fajardo and King, "An Area-Preserving Parametrization for
//! Spherical Rectangles", Computer Graphics Forum 32(4), 2013.
//!
//! Seen from a point `o`, a rectangle covers a spherical quadrilateral of
//! solid angle `S`. The parametrization maps `u in [0, 1)^2` onto it with a
//! constant Jacobian: `u.x` sweeps the area of the spherical sub-rectangle
//! left of a line of constant `x` (which fixes `x`), `u.y` the height of
//! the point along that line's projection (which fixes `y`). The density of
//! the direction to the point is then `1 / S` everywhere on the rectangle,
//! where area sampling has `d^2 / (cos theta A)`, which varies a lot over a
//! light that is large or near.
//!
//! In the rectangle's frame (`x`, `y` along its edges, `z` the normal turned
//! away from `o`), with the corner at `(x0, y0, z0)` relative to `o`
//! (`z0 <= 0`) and the far edges at `x1 = x0 + |e_x|`, `y1 = y0 + |e_y|`,
//! the normals of the four great circles through the edges are, in closed
//! form, `(0, z0, -y0)`, `(-z0, 0, x1)`, `(0, -z0, y1)` and `(z0, 0, -x0)`
//! (normalised); the interior angles `g_i` follow from consecutive normals,
//! `S = g0 + g1 + g2 + g3 - 2 pi`. Everything runs in `f64`: `S` comes out
//! of a sum of angles near `pi / 2` each, which cancels for small `S`.

use crate::math::{DVec3, Vec2, Vec3};
use std::f64::consts::PI;

/// A rectangle: a corner and two perpendicular edges.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Rectangle {
    corner: DVec3,
    /// Unit edge directions and the normal `x cross y`.
    x: DVec3,
    y: DVec3,
    z: DVec3,
    /// Edge lengths.
    len_x: f64,
    len_y: f64,
}

/// A rectangle as seen from one point, ready to be sampled.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SphericalRectangle {
    x0: f64,
    y0: f64,
    z0: f64,
    x1: f64,
    y1: f64,
    b0: f64,
    b1: f64,
    k: f64,
    solid_angle: f64,
    len_x: f64,
    len_y: f64,
}

/// Largest `|cos|` between the edges of a parallelogram taken as a
/// rectangle: beyond this the corners would sit visibly off a rectangle.
const RIGHT_ANGLE_TOLERANCE: f64 = 1e-5;

impl Rectangle {
    /// The rectangle with corner `corner` and edges `e1`, `e2`, or `None`
    /// when the edges are not perpendicular (to [`RIGHT_ANGLE_TOLERANCE`])
    /// or one has no length.
    pub fn new(corner: Vec3, e1: Vec3, e2: Vec3) -> Option<Self> {
        let (e1, e2) = (e1.as_dvec3(), e2.as_dvec3());
        let (len_x, len_y) = (e1.length(), e2.length());
        if !(len_x > 0.0 && len_y > 0.0 && (len_x * len_y).is_finite()) {
            return None;
        }
        let (x, y) = (e1 / len_x, e2 / len_y);
        if x.dot(y).abs() > RIGHT_ANGLE_TOLERANCE {
            return None;
        }
        Some(Rectangle {
            corner: corner.as_dvec3(),
            x,
            y,
            z: x.cross(y).normalize(),
            len_x,
            len_y,
        })
    }

    /// The rectangle seen from `o`, or `None` when `o` lies in its plane
    /// (it then subtends no solid angle).
    pub fn seen_from(&self, o: Vec3) -> Option<SphericalRectangle> {
        let d = self.corner - o.as_dvec3();
        let (x0, y0) = (d.dot(self.x), d.dot(self.y));
        let z0 = -d.dot(self.z).abs();
        if !(z0 < 0.0) {
            return None;
        }
        let (x1, y1) = (x0 + self.len_x, y0 + self.len_y);
        let z2 = z0 * z0;
        // unit normals of the four edges' great circles (module docs)
        let n0 = DVec3::new(0.0, z0, -y0) / (z2 + y0 * y0).sqrt();
        let n1 = DVec3::new(-z0, 0.0, x1) / (z2 + x1 * x1).sqrt();
        let n2 = DVec3::new(0.0, -z0, y1) / (z2 + y1 * y1).sqrt();
        let n3 = DVec3::new(z0, 0.0, -x0) / (z2 + x0 * x0).sqrt();
        let angle = |a: DVec3, b: DVec3| (-a.dot(b)).clamp(-1.0, 1.0).acos();
        let (g0, g1, g2, g3) = (angle(n0, n1), angle(n1, n2), angle(n2, n3), angle(n3, n0));
        let k = 2.0 * PI - g2 - g3;
        let solid_angle = g0 + g1 - k;
        if !(solid_angle > 0.0) || !solid_angle.is_finite() {
            return None;
        }
        Some(SphericalRectangle {
            x0,
            y0,
            z0,
            x1,
            y1,
            b0: n0.z,
            b1: n2.z,
            k,
            solid_angle,
            len_x: self.len_x,
            len_y: self.len_y,
        })
    }
}

impl SphericalRectangle {
    /// The solid angle the rectangle subtends.
    pub fn solid_angle(&self) -> f64 {
        self.solid_angle
    }

    /// The point that `u` maps to, as fractions `(s, t)` of the two edges
    /// (`corner + s e1 + t e2`), both in `[0, 1]`; the direction to it has
    /// density `1 / solid_angle` for uniform `u`.
    pub fn sample(&self, u: Vec2) -> [f64; 2] {
        let (x0, y0, z0, x1, y1) = (self.x0, self.y0, self.z0, self.x1, self.y1);
        // u.x: the sub-rectangle [x0, xu] holds the fraction u.x of S
        let au = u.x as f64 * self.solid_angle + self.k;
        let fu = (au.cos() * self.b0 - self.b1) / au.sin();
        let cu = (1.0 / (fu * fu + self.b0 * self.b0).sqrt())
            .copysign(fu)
            .clamp(-1.0, 1.0);
        let xu = -(cu * z0) / (1.0 - cu * cu).max(0.0).sqrt();
        let xu = if xu.is_nan() { x0 } else { xu.clamp(x0, x1) };
        // u.y: linear in the height of the point's projection on the sphere
        let d = (xu * xu + z0 * z0).sqrt();
        let h0 = y0 / (d * d + y0 * y0).sqrt();
        let h1 = y1 / (d * d + y1 * y1).sqrt();
        let hv = h0 + u.y as f64 * (h1 - h0);
        let hv2 = hv * hv;
        let yv = if hv2 < 1.0 - 1e-12 {
            (hv * d / (1.0 - hv2).sqrt()).clamp(y0, y1)
        } else {
            y1
        };
        [
            ((xu - x0) / self.len_x).clamp(0.0, 1.0),
            ((yv - y0) / self.len_y).clamp(0.0, 1.0),
        ]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn unit_square() -> Rectangle {
        Rectangle::new(Vec3::new(-0.5, -0.5, 0.0), Vec3::X, Vec3::Y).unwrap()
    }

    #[test]
    fn solid_angle_matches_the_closed_form() {
        // a square of side 2a seen from height h on its axis:
        // S = 4 asin(a^2 / (a^2 + h^2))
        for h in [0.01f32, 0.3, 1.0, 7.0, 300.0] {
            let s = unit_square().seen_from(Vec3::new(0.0, 0.0, h)).unwrap();
            let a2 = 0.25f64;
            let want = 4.0 * (a2 / (a2 + (h as f64).powi(2))).asin();
            assert!(
                (s.solid_angle() / want - 1.0).abs() < 1e-7,
                "h {h}: {} vs {want}",
                s.solid_angle()
            );
            // from below: the same
            let t = unit_square().seen_from(Vec3::new(0.0, 0.0, -h)).unwrap();
            assert!((t.solid_angle() / want - 1.0).abs() < 1e-7);
        }
        assert!(unit_square().seen_from(Vec3::new(3.0, 0.0, 0.0)).is_none());
    }

    #[test]
    fn parallelograms_and_degenerate_edges_are_not_rectangles() {
        assert!(Rectangle::new(Vec3::ZERO, Vec3::X, Vec3::new(0.1, 1.0, 0.0)).is_none());
        assert!(Rectangle::new(Vec3::ZERO, Vec3::ZERO, Vec3::Y).is_none());
    }

    #[test]
    fn corners_of_u_map_to_corners_of_the_rectangle() {
        let s = unit_square().seen_from(Vec3::new(0.2, -0.1, 0.7)).unwrap();
        for (u, want) in [
            ((0.0, 0.0), [0.0, 0.0]),
            ((1.0, 0.0), [1.0, 0.0]),
            ((0.0, 1.0), [0.0, 1.0]),
            ((1.0, 1.0), [1.0, 1.0]),
        ] {
            let got = s.sample(Vec2::new(u.0, u.1));
            assert!(
                (got[0] - want[0]).abs() < 1e-6 && (got[1] - want[1]).abs() < 1e-6,
                "{u:?} -> {got:?}"
            );
        }
    }

    #[test]
    fn equal_areas_of_u_cover_equal_solid_angles() {
        // the map preserves area up to the factor S: the solid angle of the
        // patch [s0, s1] x [t0, t1] of the rectangle that the cell of u
        // maps to is S / n^2 for every cell (measured by subdividing the
        // patch into small rectangles and summing their solid angles)
        let rect = unit_square();
        let o = Vec3::new(0.35, 0.2, 0.25);
        let s = rect.seen_from(o).unwrap();
        let n = 4;
        for i in 0..n {
            for j in 0..n {
                // the cell's image: columns of constant x (x depends on u.x
                // alone), each spanning the y that u.y in [j/n, (j+1)/n]
                // gives at that x; sum the solid angles of small patches
                let m = 64;
                let mut omega = 0.0;
                for a in 0..m {
                    let ux = |t: f64| ((i as f64 + t / m as f64) / n as f64) as f32;
                    let x_lo = s.sample(Vec2::new(ux(a as f64), 0.0))[0];
                    let x_hi = s.sample(Vec2::new(ux(a as f64 + 1.0), 0.0))[0];
                    let mid = ux(a as f64 + 0.5);
                    let sx = s.sample(Vec2::new(mid, 0.0))[0];
                    let ylo = s.sample(Vec2::new(mid, j as f32 / n as f32))[1];
                    let yhi = s.sample(Vec2::new(mid, (j + 1) as f32 / n as f32))[1];
                    for b in 0..m {
                        let sy = ylo + (yhi - ylo) * (b as f64 + 0.5) / m as f64;
                        let p = DVec3::new(sx - 0.5, sy - 0.5, 0.0) - o.as_dvec3();
                        let dist2 = p.length_squared();
                        let cos = p.z.abs() / dist2.sqrt();
                        let area = (x_hi - x_lo) * (yhi - ylo) / m as f64;
                        omega += cos / dist2 * area;
                    }
                }
                let want = s.solid_angle() / (n * n) as f64;
                assert!(
                    (omega / want - 1.0).abs() < 2e-3,
                    "cell ({i}, {j}): {omega} vs {want}"
                );
            }
        }
    }
}
