//! Geometry shared by every module: glam re-exports, [`Ray`], the shading
//! [`Frame`], and the one self-intersection policy ([`offset_ray_origin`],
//! [`spawn_ray`], [`spawn_ray_to`]). No other module offsets a ray.
//!
//! The offset policy follows pbrt-v4 (Pharr, Jakob, Humphreys, *Physically
//! Based Rendering*, 4th ed., section 6.8.6, "Robust Spawned Ray Origins"):
//! a hit point is rebuilt from barycentrics and the vertex buffer, its absolute
//! floating-point error is bounded (`gamma(7) * sum |b_i p_i|`, section 6.8.5),
//! and a spawned ray starts just outside that error box along the geometric
//! normal, rounded one ulp further away. The bias this introduces is the
//! offset itself: surfaces closer than [`min_gap`] to the origin surface can
//! be skipped.
//!
//! One addition to pbrt's bound: pbrt's own triangle test rejects hits whose
//! `t` is within its error bound, so the point's error is all an offset must
//! clear. Embree gives no such guarantee: its `t` for the source triangle
//! can be off by a few ulps of the triangle's extent seen from the origin,
//! which for a triangle much larger than the point's coordinates (a 2000-unit
//! sliver hit near 10) is far more than the point's error, and more again
//! for a needle, whose normal Embree computes from a cross product that
//! cancels (its direction is off by about `eps / sin(smallest angle)`). The
//! error box is therefore widened by `gamma(16) * reach * cond`, with
//! `reach` the distance to the farthest corner and `cond` the triangle's
//! `1 / sin(smallest angle)` (found by hard cases 4 and 5 in
//! `tests/conformance.rs`: a 2000-unit sliver, and a needle of a sphere
//! squashed 1e-4 : 2e-3 : 8).

pub mod trig;

pub use glam::{DVec3, Vec2, Vec3, Vec3A};

/// A ray `o + t d` for `t` in `[0, t_max]`. `d` is unit length unless stated
/// otherwise, so `t` is a distance.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Ray {
    /// Origin.
    pub o: Vec3,
    /// Direction.
    pub d: Vec3,
    /// Largest accepted hit distance.
    pub t_max: f32,
}

impl Ray {
    /// A ray with an unbounded extent.
    pub fn new(o: Vec3, d: Vec3) -> Self {
        Ray {
            o,
            d,
            t_max: f32::INFINITY,
        }
    }

    /// The point at parameter `t` (for display and tests; hit points are rebuilt
    /// from barycentrics instead).
    pub fn at(&self, t: f32) -> Vec3 {
        self.o + t * self.d
    }

    /// True when origin, direction and extent are all usable by a backend.
    pub fn is_finite(&self) -> bool {
        self.o.is_finite() && self.d.is_finite() && !self.t_max.is_nan() && self.t_max >= 0.0
    }
}

/// `gamma(n) = n eps / (1 - n eps)` with `eps` half an ulp of 1 (Higham's
/// bound on the relative error of `n` floating-point operations).
pub fn gamma(n: i32) -> f32 {
    let e = f32::EPSILON * 0.5 * n as f32;
    e / (1.0 - e)
}

/// The next representable `f32` above `x` (infinity stays infinity).
#[inline]
pub fn next_float_up(x: f32) -> f32 {
    if x.is_infinite() && x > 0.0 {
        return x;
    }
    let x = if x == -0.0 { 0.0 } else { x };
    let bits = x.to_bits();
    let bits = if x >= 0.0 { bits + 1 } else { bits - 1 };
    f32::from_bits(bits)
}

/// The next representable `f32` below `x`.
#[inline]
pub fn next_float_down(x: f32) -> f32 {
    -next_float_up(-x)
}

/// An orthonormal basis around a unit normal `n` (Duff et al., "Building an
/// Orthonormal Basis, Revisited", JCGT 2017): continuous except at `n.z = -0`,
/// exact for `n.z = -1`, no branches on a threshold.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Frame {
    /// First tangent.
    pub s: Vec3,
    /// Second tangent.
    pub t: Vec3,
    /// The normal.
    pub n: Vec3,
}

impl Frame {
    /// The frame whose third axis is `n` (unit length).
    pub fn from_normal(n: Vec3) -> Self {
        let sign = 1.0f32.copysign(n.z);
        let a = -1.0 / (sign + n.z);
        let b = n.x * n.y * a;
        let s = Vec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x);
        let t = Vec3::new(b, sign + n.y * n.y * a, -n.y);
        Frame { s, t, n }
    }

    /// World direction to local coordinates (normal = +z).
    pub fn to_local(&self, v: Vec3) -> Vec3 {
        Vec3::new(v.dot(self.s), v.dot(self.t), v.dot(self.n))
    }

    /// Local coordinates to a world direction.
    pub fn to_world(&self, v: Vec3) -> Vec3 {
        self.s * v.x + self.t * v.y + self.n * v.z
    }
}

/// The unit geometric normal of a triangle, `normalize((p1 - p0) x (p2 - p0))`,
/// or `None` for a degenerate triangle. Needle triangles, whose cross product
/// cancels catastrophically in `f32`, are recomputed in `f64`.
pub fn triangle_normal(p0: Vec3, p1: Vec3, p2: Vec3) -> Option<Vec3> {
    let e1 = p1 - p0;
    let e2 = p2 - p0;
    let n = e1.cross(e2);
    let len = n.length();
    let scale = e1.length() * e2.length();
    if len.is_finite() && scale.is_finite() && len > 1e-4 * scale && len > 0.0 {
        return Some(n / len);
    }
    // sin(angle between the edges) < 1e-4, or overflow/underflow: redo in f64.
    let (d0, d1, d2) = (p0.as_dvec3(), p1.as_dvec3(), p2.as_dvec3());
    let n = (d1 - d0).cross(d2 - d0);
    let len = n.length();
    if len.is_finite() && len > 0.0 {
        let n = (n / len).as_vec3();
        n.is_finite().then_some(n)
    } else {
        None
    }
}

/// A surface point as the self-intersection policy sees it: the position, a
/// bound on its absolute error per axis, and the unit geometric normal.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SurfacePoint {
    /// Position rebuilt from barycentrics.
    pub p: Vec3,
    /// Absolute error bound of `p`, per axis.
    pub p_err: Vec3,
    /// Unit geometric normal.
    pub n: Vec3,
}

impl SurfacePoint {
    /// The point with barycentrics `(1 - u - v, u, v)` on triangle `(p0, p1, p2)`,
    /// with pbrt-v4's error bound for it, made isotropic (see below).
    pub fn on_triangle(p: [Vec3; 3], u: f32, v: f32, n: Vec3) -> Self {
        Self::on_triangle_with(p, u, v, n, needle_factor(p))
    }

    /// [`SurfacePoint::on_triangle`] with the triangle's [`needle_factor`]
    /// given (scenes compute it once per triangle: in `f64`, with square
    /// roots and a division, it cost a tenth of a render when computed at
    /// every hit).
    #[inline]
    pub fn on_triangle_with(p: [Vec3; 3], u: f32, v: f32, n: Vec3, needle: f32) -> Self {
        // the same operations, in the same order, as the per-axis form
        // `b0 p0 + u p1 + v p2`, on 4-wide vectors
        let [a, b, c] = p.map(Vec3A::from);
        let (ta, tb, tc) = (a * (1.0 - u - v), b * u, c * v);
        let pos = ta + tb + tc;
        let p_err = gamma(7) * (ta.abs() + tb.abs() + tc.abs()).max_element();
        // Isotropic: every axis gets the largest per-axis bound. pbrt's
        // per-axis bound is zero along an axis where the point is exact (on
        // the plane y = 0, say), but a ray query's own rounding mixes the
        // axes, so an origin one ulp off such a plane can still see it at a
        // tiny positive t in a backend we cannot patch (Embree).
        // Plus the backend allowance for large triangles (module docs).
        let reach = (a - pos)
            .abs()
            .max((b - pos).abs())
            .max((c - pos).abs())
            .max_element();
        SurfacePoint {
            p: pos.into(),
            p_err: Vec3::splat(p_err + gamma(16) * reach * needle),
            n,
        }
    }
}

impl SurfacePoint {
    /// The point of the sphere `(center, radius)` nearest to `hit` (a point a
    /// ray query found on it, off by its rounding), with the outward normal.
    /// Projecting back onto the sphere (pbrt-v4 section 6.8.5) leaves an error
    /// of a few ulps of the coordinates involved: the bound is
    /// `gamma(5) * (|center| + radius)` on every axis, isotropic like the
    /// triangle's.
    pub fn on_sphere(center: Vec3, radius: f32, hit: Vec3) -> Self {
        let d = hit - center;
        let len = d.length();
        // a degenerate query (hit at the centre) still gets a valid frame
        let n = if len > 0.0 && len.is_finite() {
            d / len
        } else {
            Vec3::Y
        };
        let p = center + radius * n;
        let p_err = Vec3::splat(gamma(5) * (center.abs().max_element() + radius));
        SurfacePoint { p, p_err, n }
    }
}

/// The origin for a ray leaving `sp` in direction `w`: pushed along the
/// geometric normal, to the side `w` points to, just past the error box of the
/// point, then rounded one ulp further out on every axis the normal has a
/// component along. The ulp step is taken even when the error bound is zero
/// (a point on an axis-aligned plane through 0 is exact): the origin then
/// lies strictly off the plane, so no backend can report the source surface
/// at `t = 0`, whatever its `tnear` rule.
#[inline]
pub fn offset_ray_origin(sp: &SurfacePoint, w: Vec3) -> Vec3 {
    let n = Vec3A::from(sp.n);
    let d = n.abs().dot(Vec3A::from(sp.p_err));
    let dir = if w.dot(sp.n) < 0.0 { -n } else { n };
    let po = Vec3A::from(sp.p) + d * dir;
    Vec3::new(
        step_out(po.x, dir.x),
        step_out(po.y, dir.y),
        step_out(po.z, dir.z),
    )
}

/// `x` moved one ulp the way `dir`'s sign says (not at all for `dir == 0`).
#[inline]
fn step_out(x: f32, dir: f32) -> f32 {
    if dir > 0.0 {
        next_float_up(x)
    } else if dir < 0.0 {
        next_float_down(x)
    } else {
        x
    }
}

/// A ray leaving surface point `sp` in unit direction `d`.
#[inline]
pub fn spawn_ray(sp: &SurfacePoint, d: Vec3) -> Ray {
    Ray::new(offset_ray_origin(sp, d), d)
}

/// A shadow ray from `from` to `to` (both surface points): both ends are
/// offset off their surfaces, so neither surface can be hit, and the extent
/// stops short of the offset target by a relative bound on the error of the
/// distance computation (`gamma(3)`), not a fixed epsilon. The direction is
/// unit length and `t_max` is a distance.
pub fn spawn_ray_to(from: &SurfacePoint, to: &SurfacePoint) -> Ray {
    let pf = offset_ray_origin(from, to.p - from.p);
    let pt = offset_ray_origin(to, pf - to.p);
    let delta = pt - pf;
    let dist = delta.length();
    if dist.is_nan() || dist <= 0.0 || !dist.is_finite() {
        return Ray {
            o: pf,
            d: from.n,
            t_max: 0.0,
        };
    }
    Ray {
        o: pf,
        d: delta / dist,
        t_max: dist * (1.0 - gamma(3)),
    }
}

/// `1 / sin(smallest angle)` of a triangle, in `f64` (the largest product of
/// two edge lengths over twice the area): 1.15 for an equilateral triangle,
/// large for needles and slivers; 1 for a degenerate one, which is never
/// hit.
pub fn needle_factor(p: [Vec3; 3]) -> f32 {
    let [a, b, c] = p.map(|q| q.as_dvec3());
    let twice_area = (b - a).cross(c - a).length();
    let l = [(b - a).length(), (c - b).length(), (a - c).length()];
    let top = (l[0] * l[1]).max(l[1] * l[2]).max(l[2] * l[0]);
    if twice_area > 0.0 && top.is_finite() {
        (top / twice_area).max(1.0) as f32
    } else {
        1.0
    }
}

/// Smallest gap between two parallel surfaces, at coordinates of magnitude
/// at most `scale` (so corners at most `2 scale` apart per axis), that a
/// spawned ray never skips: the offset is at most
/// `(gamma(7) * 3 * scale + gamma(16) * 2 * scale * 2) * sqrt(3)` plus two
/// ulps (the error box projected on the normal, then rounded out), about
/// `9.0e-6 * scale`, for triangles whose smallest angle is at least 30
/// degrees ([`needle_factor`] at most 2; a needle's gap grows with its
/// factor). Two surfaces farther apart than this are always resolved;
/// `tests/conformance.rs` case 6 checks thin shells at exactly this gap in
/// every backend.
pub fn min_gap(scale: f32) -> f32 {
    let s = scale.abs();
    let ulp = f32::EPSILON * s.max(f32::MIN_POSITIVE);
    (gamma(7) * 3.0 * s + gamma(16) * 2.0 * s * 2.0) * 3.0f32.sqrt() + 2.0 * ulp
}

/// `x.floor()` without a call: the x86-64 baseline has no rounding
/// instruction (SSE4.1's `roundss`), so `f32::floor` is a call into libm,
/// which the texture and environment lookups made on every hit. Values of
/// magnitude `2^23` or more (and NaN, infinities) are already integers and
/// come back as they are; `-0.0` comes back as `0.0`.
#[inline]
pub fn floor(x: f32) -> f32 {
    if !(x.abs() < 8_388_608.0) {
        return x;
    }
    let t = x as i32 as f32;
    if t > x { t - 1.0 } else { t }
}

/// [`floor`] for `f64` (values of magnitude `2^52` or more come back as
/// they are).
#[inline]
pub fn floor_f64(x: f64) -> f64 {
    if !(x.abs() < 4_503_599_627_370_496.0) {
        return x;
    }
    let t = x as i64 as f64;
    if t > x { t - 1.0 } else { t }
}

/// Linear-RGB luminance (Rec. 709 primaries).
pub fn luminance(c: Vec3) -> f32 {
    0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z
}

/// [`luminance`] in `f64`: finite for any finite colour (light powers,
/// which can overflow `f32`).
pub fn luminance_f64(c: Vec3) -> f64 {
    0.2126 * c.x as f64 + 0.7152 * c.y as f64 + 0.0722 * c.z as f64
}

#[cfg(test)]
mod tests {
    use super::*;

    fn check_frame(n: Vec3) {
        let f = Frame::from_normal(n);
        for (a, b) in [(f.s, f.t), (f.s, f.n), (f.t, f.n)] {
            assert!(
                a.as_dvec3().dot(b.as_dvec3()).abs() < 1e-6,
                "{n:?}: not orthogonal"
            );
        }
        for v in [f.s, f.t, f.n] {
            assert!(
                ((v.as_dvec3().length()) - 1.0).abs() < 1e-6,
                "{n:?}: not unit"
            );
            assert!(v.is_finite());
        }
        // right-handed: s x t = n
        assert!((f.s.cross(f.t) - f.n).length() < 1e-5, "{n:?}: left-handed");
        let w = Vec3::new(0.3, -0.5, 0.81).normalize();
        assert!((f.to_world(f.to_local(w)) - w).length() < 1e-6);
    }

    #[test]
    fn frames_at_singular_normals() {
        for n in [Vec3::X, -Vec3::X, Vec3::Y, -Vec3::Y, Vec3::Z, -Vec3::Z] {
            check_frame(n);
        }
        check_frame(Vec3::new(0.0, 0.0, -1.0));
        check_frame(Vec3::new(1e-8, 0.0, -1.0).normalize());
        let mut s = 1u64;
        for _ in 0..10_000 {
            let mut r = || {
                s = s
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                ((s >> 40) as f32 / (1u64 << 24) as f32) * 2.0 - 1.0
            };
            let v = Vec3::new(r(), r(), r());
            if v.length() > 1e-3 {
                check_frame(v.normalize());
            }
        }
    }

    #[test]
    fn floor_matches_the_library_floor() {
        let mut xs = vec![
            0.0,
            -0.0,
            0.5,
            -0.5,
            1.0,
            -1.0,
            2.9999998,
            -2.9999998,
            8_388_607.5,
            -8_388_607.5,
            8_388_608.0,
            1e30,
            -1e30,
            f32::INFINITY,
            f32::NEG_INFINITY,
            f32::MIN_POSITIVE,
            -f32::MIN_POSITIVE,
        ];
        let mut s = 7u32;
        for _ in 0..100_000 {
            s = s.wrapping_mul(747_796_405).wrapping_add(2_891_336_453);
            xs.push(f32::from_bits(s) % 1e7);
        }
        for x in xs {
            let (a, b) = (floor(x), x.floor());
            assert!(a == b || (a.is_nan() && b.is_nan()), "{x}: {a} vs {b}");
            let y = x as f64 * 1.000_000_1;
            assert!(floor_f64(y) == y.floor() || y.is_nan(), "{y}");
        }
        assert!(floor(f32::NAN).is_nan());
    }

    #[test]
    fn next_float_steps_one_ulp() {
        assert_eq!(next_float_up(1.0), 1.0 + f32::EPSILON);
        assert_eq!(next_float_down(1.0), 1.0 - f32::EPSILON / 2.0);
        assert_eq!(next_float_up(-0.0), f32::from_bits(1));
        assert_eq!(next_float_up(0.0), f32::from_bits(1));
        assert_eq!(next_float_down(0.0), -f32::from_bits(1));
        assert_eq!(next_float_up(f32::INFINITY), f32::INFINITY);
    }

    #[test]
    fn needle_normal_uses_f64() {
        let n = triangle_normal(
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(0.5, 1e-7, 0.0),
        )
        .expect("needle has area");
        assert!((n - Vec3::Z).length() < 1e-6, "{n:?}");
        assert!(triangle_normal(Vec3::ZERO, Vec3::X, 2.0 * Vec3::X).is_none());
        assert!(triangle_normal(Vec3::ZERO, Vec3::ZERO, Vec3::Y).is_none());
    }

    #[test]
    fn needle_factor_grows_as_the_smallest_angle_shrinks() {
        let eq = [Vec3::ZERO, Vec3::X, Vec3::new(0.5, 0.75f32.sqrt(), 0.0)];
        assert!((needle_factor(eq) - 2.0 / 3f32.sqrt()).abs() < 1e-6);
        let right = [Vec3::ZERO, Vec3::X, Vec3::Y];
        assert!((needle_factor(right) - 2f32.sqrt()).abs() < 1e-6);
        // a needle 8 long and 1e-3 wide: 1 / sin(angle) about 8 / 1e-3
        let needle = [
            Vec3::ZERO,
            Vec3::new(8.0, 0.0, 0.0),
            Vec3::new(4.0, 1e-3, 0.0),
        ];
        let f = needle_factor(needle);
        assert!(f > 3000.0 && f < 20_000.0, "{f}");
        assert_eq!(needle_factor([Vec3::ZERO, Vec3::X, 2.0 * Vec3::X]), 1.0);
    }

    #[test]
    fn spawned_rays_leave_the_error_box() {
        let tri = [
            Vec3::new(1e4, 1e4, 1e4),
            Vec3::new(1e4 + 1.0, 1e4, 1e4),
            Vec3::new(1e4, 1e4 + 1.0, 1e4),
        ];
        let sp = SurfacePoint::on_triangle(tri, 0.3, 0.3, Vec3::Z);
        let up = offset_ray_origin(&sp, Vec3::Z);
        let down = offset_ray_origin(&sp, -Vec3::Z);
        assert!(up.z - sp.p.z > sp.p_err.z, "up offset too small");
        assert!(sp.p.z - down.z > sp.p_err.z, "down offset too small");
        assert!(up.z - 1e4 <= min_gap(1e4 + 1.0));
        // an exact point (zero error bound) still leaves its plane
        let exact = SurfacePoint {
            p: Vec3::new(0.3, 0.2, 0.0),
            p_err: Vec3::ZERO,
            n: Vec3::Z,
        };
        assert!(offset_ray_origin(&exact, Vec3::Z).z > 0.0);
        assert!(offset_ray_origin(&exact, -Vec3::Z).z < 0.0);
    }

    #[test]
    fn shadow_ray_stops_short_of_target() {
        let a = SurfacePoint {
            p: Vec3::ZERO,
            p_err: Vec3::splat(1e-7),
            n: Vec3::Z,
        };
        let b = SurfacePoint {
            p: Vec3::new(0.0, 0.0, 2.0),
            p_err: Vec3::splat(1e-7),
            n: -Vec3::Z,
        };
        let r = spawn_ray_to(&a, &b);
        assert!(r.o.z > 0.0);
        assert!(r.at(r.t_max).z < 2.0);
        assert!((r.d - Vec3::Z).length() < 1e-6);
    }
}
