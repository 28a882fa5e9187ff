//! Fresnel reflectance and the laws of specular reflection and refraction, in
//! the local shading frame (normal = +z).
//!
//! - [`fr_dielectric`]: the exact unpolarised Fresnel reflectance of a smooth
//!   boundary between two dielectrics (pbrt-v4, section 9.3.2, "The Fresnel
//!   Equations"), with total internal reflection.
//! - [`fr_conductor`]: the same equations with a complex index of refraction
//!   `eta + i k` for metals (pbrt-v4, section 9.3.6, "The Fresnel Equations for
//!   Conductors").
//! - [`reflect`] and [`refract`]: mirror reflection about the normal and
//!   Snell's law (pbrt-v4, sections 9.3.1 and 9.3.2).
//!
//! Relative indices of refraction follow pbrt: `eta = eta_t / eta_i` is the
//! index below the surface (the `-z` side) over the index above it; a
//! direction with `cos < 0` is below the surface, and the formulas then swap
//! the media by using `1 / eta`.

use crate::math::Vec3;

/// Fresnel reflectance of a smooth dielectric boundary for light arriving at
/// `cos_theta_i` from the normal, where `eta` is the index below the surface
/// over the index above it. A negative cosine means the light arrives from
/// below. Returns 1 under total internal reflection. Exact (no Schlick
/// approximation).
pub fn fr_dielectric(cos_theta_i: f32, eta: f32) -> f32 {
    let mut cos_i = cos_theta_i.clamp(-1.0, 1.0);
    let mut eta = eta;
    if cos_i < 0.0 {
        eta = 1.0 / eta;
        cos_i = -cos_i;
    }
    let sin2_i = (1.0 - cos_i * cos_i).max(0.0);
    let sin2_t = sin2_i / (eta * eta);
    if !(sin2_t < 1.0) {
        // total internal reflection (or a NaN input: reflect, never refract)
        return 1.0;
    }
    let cos_t = (1.0 - sin2_t).max(0.0).sqrt();
    let r_parl = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
    let r_perp = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
    0.5 * (r_parl * r_parl + r_perp * r_perp)
}

/// Fresnel reflectance of a conductor with complex index `eta + i k` (relative
/// to the medium above) for light arriving at `cos_theta_i`, per RGB channel.
/// `eta` must be positive or `k` non-zero in every channel. Light never
/// arrives from inside a metal, so the cosine is clamped to `[0, 1]`.
///
/// The closed form in real arithmetic (Born and Wolf, "Principles of
/// Optics", section 14.2; the form Mitsuba 3 and Lazanyi and Szirmay-Kalos
/// 2005 use): with `a^2 - b^2 = eta^2 - k^2 - sin^2` and `ab = eta k`,
///
/// `r_s = (a^2 + b^2 + cos^2 - 2 a cos) / (a^2 + b^2 + cos^2 + 2 a cos)`,
/// `r_p = r_s (t - 2 a cos sin^2) / (t + 2 a cos sin^2)`, `t = (a^2 + b^2)
/// cos^2 + sin^4`, and `F = (r_s + r_p) / 2`.
///
/// Two square roots and three divisions a channel, against two roots and
/// four divisions in complex arithmetic. `a^2 = ((a^2 + b^2) + (a^2 - b^2)) / 2`
/// cancels when `k` dominates (silver: `k / eta` near 30), so where `a^2 -
/// b^2 < 0` it is computed as `2 eta^2 k^2 / ((a^2 + b^2) - (a^2 - b^2))`,
/// the same value without the subtraction. A purely imaginary index (`eta =
/// 0`, `k > 0`) is a lossless ideal conductor: `a = 0`, so both polarisations
/// reflect with `|r| = 1` and `F = 1` at every angle.
pub fn fr_conductor(cos_theta_i: f32, eta: Vec3, k: Vec3) -> Vec3 {
    Vec3::from_array(std::array::from_fn(|c| {
        fr_conductor_channel(cos_theta_i, eta[c], k[c])
    }))
}

/// One channel of [`fr_conductor`]. Written without a branch or a call
/// (selects), so that a loop of it over a batch's lanes vectorises
/// (`bsdf::samples_at_normals_lanes`); the scalar path and the lanes are
/// this one function.
#[inline(always)]
pub fn fr_conductor_channel(cos_theta_i: f32, eta: f32, k: f32) -> f32 {
    let cos = cos_theta_i.clamp(0.0, 1.0);
    let cos2 = cos * cos;
    let sin2 = 1.0 - cos2;
    // a^2 - b^2, as (eta^2 - k^2 - 1) + cos^2: sin^2 = 1 - cos^2 would round
    // away the small cosines that matter where eta^2 - k^2 is near 1
    let diff = (eta * eta - k * k - 1.0) + cos2;
    let ek = eta * k;
    let sum = (diff * diff + 4.0 * ek * ek).sqrt(); // a^2 + b^2
    let a2 = if diff >= 0.0 {
        0.5 * (sum + diff)
    } else {
        2.0 * ek * ek / (sum - diff)
    };
    let a = a2.sqrt();
    let s1 = sum + cos2;
    let s2 = 2.0 * cos * a;
    // s1 + s2 = 0 only at grazing incidence on eta = 1, k = 0: F = 1 there
    let r_s = if s1 + s2 > 0.0 {
        (s1 - s2) / (s1 + s2)
    } else {
        1.0
    };
    let t = sum * cos2 + sin2 * sin2;
    let u = s2 * sin2;
    let r_p = r_s * (t - u) / (t + u);
    0.5 * (r_s + r_p)
}

/// Mirror reflection of `w` about the normal `n`: `-w + 2 (w . n) n`.
pub fn reflect(w: Vec3, n: Vec3) -> Vec3 {
    -w + 2.0 * w.dot(n) * n
}

/// The refracted direction and the relative index it saw.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Refraction {
    /// The transmitted direction, on the other side of the surface from `wi`,
    /// pointing away from it; unit length when `wi` is.
    pub wt: Vec3,
    /// The relative index `eta_t / eta_i` that `wi`'s side sees: `eta` when
    /// `wi` is above the surface, `1 / eta` when it is below.
    pub etap: f32,
}

/// Snell's law for `wi` (pointing away from the surface) through the surface
/// with normal `n`, where `eta` is the index on `n`'s back side over the index
/// on its front side. `None` under total internal reflection.
pub fn refract(wi: Vec3, n: Vec3, eta: f32) -> Option<Refraction> {
    let mut cos_i = n.dot(wi);
    let (mut eta, mut n) = (eta, n);
    if cos_i < 0.0 {
        eta = 1.0 / eta;
        cos_i = -cos_i;
        n = -n;
    }
    let sin2_i = (1.0 - cos_i * cos_i).max(0.0);
    let sin2_t = sin2_i / (eta * eta);
    if !(sin2_t < 1.0) {
        return None;
    }
    let cos_t = (1.0 - sin2_t).max(0.0).sqrt();
    let wt = -wi / eta + (cos_i / eta - cos_t) * n;
    Some(Refraction { wt, etap: eta })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The dielectric equations at normal incidence reduce to
    /// `((eta - 1) / (eta + 1))^2`, from either side.
    #[test]
    fn dielectric_normal_incidence() {
        for eta in [1.0f32, 1.33, 1.5, 2.4] {
            let r0 = ((eta - 1.0) / (eta + 1.0)).powi(2);
            assert!((fr_dielectric(1.0, eta) - r0).abs() < 1e-6);
            assert!((fr_dielectric(-1.0, eta) - r0).abs() < 1e-6);
        }
    }

    /// Glass (eta 1.5): Brewster's angle atan(1.5) has no parallel
    /// reflection, so F = r_perp^2 / 2; past the critical angle asin(1/1.5)
    /// inside, everything reflects; grazing incidence reflects everything.
    #[test]
    fn dielectric_brewster_critical_grazing() {
        let eta = 1.5f64;
        let tb = eta.atan();
        let (ci, si) = (tb.cos(), tb.sin());
        let ct = (1.0 - (si / eta).powi(2)).sqrt();
        let r_perp = (ci - eta * ct) / (ci + eta * ct);
        let f = fr_dielectric(ci as f32, eta as f32) as f64;
        // f32 evaluation of a value of order 0.07: a few ulp
        assert!((f - 0.5 * r_perp * r_perp).abs() < 1e-6, "{f}");
        let crit = (1.0 / eta).asin();
        assert_eq!(fr_dielectric(-(crit + 1e-3).cos() as f32, 1.5), 1.0);
        assert!(fr_dielectric(-(crit - 1e-3).cos() as f32, 1.5) < 1.0);
        assert_eq!(fr_dielectric(0.0, 1.5), 1.0);
        assert_eq!(fr_dielectric(-0.0, 1.5), 1.0);
    }

    /// With `k = 0` the conductor equations are the dielectric ones.
    #[test]
    fn conductor_with_no_absorption_is_a_dielectric() {
        for c in [1.0f32, 0.8, 0.5, 0.2, 0.01] {
            let fc = fr_conductor(c, Vec3::splat(1.5), Vec3::ZERO);
            let fd = fr_dielectric(c, 1.5);
            assert!((fc - Vec3::splat(fd)).abs().max_element() < 1e-6, "{c}");
        }
    }

    /// Normal incidence on a metal: `((n - 1)^2 + k^2) / ((n + 1)^2 + k^2)`;
    /// grazing incidence reflects everything; values stay in [0, 1].
    #[test]
    fn conductor_normal_and_grazing() {
        let eta = Vec3::new(0.2, 0.92, 1.1);
        let k = Vec3::new(3.9, 2.45, 2.2);
        let f = fr_conductor(1.0, eta, k);
        let r0 = ((eta - 1.0) * (eta - 1.0) + k * k) / ((eta + 1.0) * (eta + 1.0) + k * k);
        assert!((f - r0).abs().max_element() < 1e-6, "{f} vs {r0}");
        assert!((fr_conductor(0.0, eta, k) - Vec3::ONE).abs().max_element() < 1e-6);
        for i in 0..=100 {
            let f = fr_conductor(i as f32 / 100.0, eta, k);
            assert!(f.min_element() >= 0.0 && f.max_element() <= 1.0 + 1e-6);
            // a purely imaginary index reflects everything (f32 rounding)
            let ideal = fr_conductor(i as f32 / 100.0, Vec3::ZERO, Vec3::new(0.1, 1.0, 10.0));
            assert!((ideal - Vec3::ONE).abs().max_element() < 1e-6, "{ideal}");
        }
    }

    /// The closed form against the Fresnel equations in complex `f64`
    /// arithmetic (pbrt-v4's `FrComplex`): `cos_t = sqrt(1 - sin^2 / eta^2)`,
    /// `r_parl = (eta cos_i - cos_t) / (eta cos_i + cos_t)`, `r_perp =
    /// (cos_i - eta cos_t) / (cos_i + eta cos_t)`, over the named metals'
    /// ranges (silver's `k / eta` near 30 included) and every angle.
    #[test]
    fn conductor_closed_form_matches_complex_arithmetic() {
        type C = (f64, f64);
        let mul = |a: C, b: C| (a.0 * b.0 - a.1 * b.1, a.0 * b.1 + a.1 * b.0);
        let div = |a: C, b: C| {
            let n = b.0 * b.0 + b.1 * b.1;
            ((a.0 * b.0 + a.1 * b.1) / n, (a.1 * b.0 - a.0 * b.1) / n)
        };
        let sqrt = |z: C| {
            let r = (z.0 * z.0 + z.1 * z.1).sqrt();
            let re = (0.5 * (r + z.0)).sqrt();
            let im = (0.5 * (r - z.0)).sqrt().copysign(z.1);
            (re, im)
        };
        let norm = |z: C| z.0 * z.0 + z.1 * z.1;
        let reference = |cos: f64, eta: f64, k: f64| {
            let e = (eta, k);
            let sin2_t = div((1.0 - cos * cos, 0.0), mul(e, e));
            let cos_t = sqrt((1.0 - sin2_t.0, -sin2_t.1));
            let ec = (e.0 * cos, e.1 * cos);
            let r_parl = div(
                (ec.0 - cos_t.0, ec.1 - cos_t.1),
                (ec.0 + cos_t.0, ec.1 + cos_t.1),
            );
            let ect = mul(e, cos_t);
            let r_perp = div((cos - ect.0, -ect.1), (cos + ect.0, ect.1));
            0.5 * (norm(r_parl) + norm(r_perp))
        };
        // silver, gold, copper, aluminium (pbrt-v4's spectra at 450 to 650 nm),
        // a dielectric and an ideal conductor
        let metals = [
            (0.155, 4.83),
            (0.18, 3.1),
            (1.38, 1.91),
            (0.27, 2.78),
            (1.0, 9.2),
            (1.5, 0.0),
            (1.0, 0.0),
            (0.0, 3.0),
        ];
        for (eta, k) in metals {
            for i in 0..=1000 {
                let cos = i as f64 / 1000.0;
                let f = fr_conductor(cos as f32, Vec3::splat(eta as f32), Vec3::splat(k as f32));
                let want = if cos == 0.0 {
                    1.0
                } else {
                    reference(cos, eta, k)
                };
                assert!(
                    (f.x as f64 - want).abs() < 2e-6 && f.x == f.y && f.y == f.z,
                    "eta {eta} k {k} cos {cos}: {f} against {want}"
                );
            }
        }
    }

    #[test]
    fn snell_and_tir() {
        let wi = Vec3::new(0.6, 0.0, 0.8);
        let r = refract(wi, Vec3::Z, 1.5).unwrap();
        assert_eq!(r.etap, 1.5);
        assert!(r.wt.z < 0.0 && (r.wt.length() - 1.0).abs() < 1e-6);
        // sin_t = sin_i / eta
        assert!((r.wt.x.abs() - 0.6 / 1.5).abs() < 1e-6);
        assert!(
            r.wt.x < 0.0,
            "the transmitted ray crosses to the other side"
        );
        // and back: the reverse path refracts to the original direction
        let back = refract(r.wt, Vec3::Z, 1.5).unwrap();
        assert!((back.etap - 1.0 / 1.5).abs() < 1e-7);
        assert!((back.wt - wi).abs().max_element() < 1e-6);
        // from inside past the critical angle
        assert!(refract(Vec3::new(0.8, 0.0, -0.6), Vec3::Z, 1.5).is_none());
        assert_eq!(reflect(wi, Vec3::Z), Vec3::new(-0.6, 0.0, 0.8));
    }
}
