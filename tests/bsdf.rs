//! The BSDF library against `../shared/docs/hard-cases.md`, section B:
//!
//! - 12: chi-square goodness of fit of every sampling routine with a density
//!   (rough conductors, GGX and Beckmann, at several roughnesses and angles;
//!   rough and smooth plastic), and binomial tests of the smooth dielectric's
//!   reflect/refract choice against the Fresnel equations;
//! - 13: sample / eval / pdf consistency;
//! - 14: extreme random numbers;
//! - 15: energy: mirror and glass lose nothing per sample; a rough conductor
//!   with Fresnel 1 loses exactly what single scattering explains; a white
//!   plastic conserves energy;
//! - 16: grazing angles;
//! - reciprocity of the reflective BSDFs, and the rough conductor tending to
//!   the smooth one as `alpha -> 0`.
//!
//! Statistics: every seed is fixed. The chi-square and binomial tests run at
//! level 0.01, Sidak-corrected over [`DISCRETE_TESTS`]. The Monte Carlo
//! bands are `z sigma` with `sigma` from batch means in f64 and `z` the
//! two-sided quantile of 1e-6 Sidak-corrected over [`MC_TESTS`] (5.54).

mod common;

use common::bsdf_checks::{N_CHI2, chi2_reflective, single_scatter_albedo};
use common::{batch_means, sidak_z};
use embertrace::bsdf::fresnel::{fr_conductor, fr_dielectric};
use embertrace::bsdf::{
    Bsdf, BsdfSample, Bxdf, Conductor, Diffuse, Distribution, Glass, Lobe, Masking,
    MetallicRoughness, Microfacet, Mirror, Phong, Plastic, RoughGlass, ThinGlass,
};
use embertrace::math::{Vec2, Vec3};
use embertrace::sampler::Sampler;
use embertrace::sampling::square_to_uniform_sphere;

/// Chi-square tests (10 + 4 Phong) plus binomial tests (5) in this file.
const DISCRETE_TESTS: usize = 14 + 5;
/// Monte Carlo bands in this file: conductor albedo (2 distributions x 3
/// roughnesses x 3 angles), white plastic (2 x 3 angles), small-alpha
/// conductor (3 roughnesses x 3 angles), the Phong lobe at normal incidence
/// (3 exponents).
const MC_TESTS: usize = 18 + 6 + 9 + 3;

/// The extreme random numbers of hard case 14: 0, the smallest subnormal,
/// 1/2, the largest float below 1, and 1.
const EXTREMES: [f32; 5] = [0.0, 1.4e-45, 0.5, 1.0 - 5.96e-8, 1.0];

/// A gold-like complex index for red, green and blue (rounded from Johnson
/// and Christy 1972); any metal would do.
const GOLD_ETA: Vec3 = Vec3::new(0.166, 0.424, 1.38);
const GOLD_K: Vec3 = Vec3::new(3.15, 2.35, 1.84);

/// A conductor whose Fresnel reflectance is 1 at every angle: a purely
/// imaginary index is a lossless ideal conductor (`|r| = 1` for both
/// polarisations; checked in `perfect_conductor_reflects_everything`).
const PERFECT_ETA: Vec3 = Vec3::ZERO;
const PERFECT_K: Vec3 = Vec3::ONE;

fn dir(theta_deg: f64, phi_deg: f64) -> Vec3 {
    let (t, p) = (theta_deg.to_radians(), phi_deg.to_radians());
    Vec3::new(
        (t.sin() * p.cos()) as f32,
        (t.sin() * p.sin()) as f32,
        t.cos() as f32,
    )
}

fn conductor(dist: Distribution, alpha: f32, eta: Vec3, k: Vec3) -> Conductor {
    Conductor {
        eta,
        k,
        microfacet: Microfacet::new(dist, alpha),
    }
}

/// Every material in a few parameterisations, with a name for messages.
fn zoo() -> Vec<(String, Bsdf)> {
    let mut v: Vec<(String, Bsdf)> = vec![
        (
            "diffuse".into(),
            Diffuse {
                albedo: Vec3::new(0.8, 0.5, 0.2),
            }
            .into(),
        ),
        ("mirror".into(), Mirror::default().into()),
        ("glass".into(), Glass::default().into()),
        ("thin glass".into(), ThinGlass::default().into()),
        ("rough glass 0.1".into(), RoughGlass::default().into()),
        (
            "rough glass 0.5 ior 1.33 tinted".into(),
            RoughGlass {
                ior: 1.33,
                alpha: 0.5,
                reflectance: Vec3::new(0.9, 0.8, 0.7),
                transmittance: Vec3::new(0.5, 0.6, 0.7),
            }
            .into(),
        ),
        (
            "glass ior 1.33 tinted".into(),
            Glass {
                ior: 1.33,
                reflectance: Vec3::new(0.9, 0.8, 0.7),
                transmittance: Vec3::new(0.5, 0.6, 0.7),
            }
            .into(),
        ),
    ];
    for dist in [Distribution::Ggx, Distribution::Beckmann] {
        for alpha in [0.0f32, 0.01, 0.1, 0.5, 1.0] {
            v.push((
                format!("conductor {dist:?} {alpha}"),
                conductor(dist, alpha, GOLD_ETA, GOLD_K).into(),
            ));
        }
    }
    for alpha in [0.0f32, 0.01, 0.2, 0.7] {
        v.push((
            format!("plastic {alpha}"),
            Plastic::new(Vec3::new(0.8, 0.5, 0.2), 1.5, alpha)
                .unwrap()
                .into(),
        ));
    }
    v.push((
        "plastic beckmann linear 0.3".into(),
        Plastic::with_options(
            Vec3::new(0.8, 0.5, 0.2),
            1.5,
            0.3,
            Distribution::Beckmann,
            Masking::default(),
            false,
        )
        .unwrap()
        .into(),
    ));
    // Mitsuba's separable masking-shadowing, as Mitsuba scenes are read
    v.push((
        "conductor ggx 0.5 separable".into(),
        Conductor {
            microfacet: Microfacet::new(Distribution::Ggx, 0.5).with_masking(Masking::Separable),
            ..conductor(Distribution::Ggx, 0.5, GOLD_ETA, GOLD_K)
        }
        .into(),
    ));
    v.push((
        "plastic ggx 0.3 separable".into(),
        Plastic::with_options(
            Vec3::new(0.8, 0.5, 0.2),
            1.5,
            0.3,
            Distribution::Ggx,
            Masking::Separable,
            true,
        )
        .unwrap()
        .into(),
    ));
    for lobe in [
        Lobe::Phong { shininess: 0.0 },
        Lobe::Phong { shininess: 20.0 },
        Lobe::Phong { shininess: 5000.0 },
        Lobe::Ggx { roughness: 0.001 },
        Lobe::Ggx { roughness: 0.4 },
    ] {
        v.push((format!("phong {lobe:?}"), phong(lobe).into()));
    }
    for (metallic, roughness, specular, ior) in [
        (0.0f32, 0.5f32, 1.0f32, 1.5f32),
        (1.0, 0.3, 1.0, 1.5),
        (0.5, 0.0, 1.0, 1.5),
        (0.0, 0.05, 0.5, 1.8),
        (0.3, 1.0, 1.0, 0.0),
    ] {
        v.push((
            format!("metallic_roughness m {metallic} r {roughness} s {specular} ior {ior}"),
            MetallicRoughness {
                base_color: Vec3::new(0.8, 0.5, 0.2),
                metallic,
                roughness,
                specular,
                specular_color: Vec3::new(1.0, 0.7, 0.4),
                ior,
            }
            .into(),
        ));
    }
    v
}

fn phong(lobe: Lobe) -> Phong {
    Phong {
        diffuse: Vec3::new(0.5, 0.3, 0.1),
        specular: Vec3::new(0.3, 0.4, 0.5),
        lobe,
    }
}

fn rel_close(a: Vec3, b: Vec3, rel: f32) -> bool {
    (a - b)
        .abs()
        .cmple(rel * a.abs().max(b.abs()) + Vec3::splat(1e-30))
        .all()
}

fn check_sample(name: &str, b: &Bsdf, wo: Vec3, s: &BsdfSample) {
    assert!(
        s.wi.is_finite() && (s.wi.length() - 1.0).abs() < 1e-5,
        "{name}: wo {wo} gave wi {}",
        s.wi
    );
    assert!(s.pdf > 0.0 && s.pdf.is_finite(), "{name}: pdf {}", s.pdf);
    assert!(
        s.f.is_finite() && s.f.min_element() >= 0.0,
        "{name}: f {}",
        s.f
    );
    if s.delta {
        assert!(b.has_delta_component(), "{name}: delta sample");
        if b.is_delta() {
            assert_eq!(b.eval(wo, s.wi), Vec3::ZERO, "{name}: eval on a delta lobe");
            assert_eq!(b.pdf(wo, s.wi), 0.0, "{name}: pdf on a delta lobe");
        }
    } else {
        assert!(!b.is_delta(), "{name}: non-delta sample from a delta BSDF");
        // sample() evaluates pdf() and eval() at the returned direction
        let pdf = b.pdf(wo, s.wi);
        assert!(
            (s.pdf - pdf).abs() <= 1e-5 * pdf,
            "{name}: sampled pdf {} vs pdf() {pdf}",
            s.pdf
        );
        let f = b.eval(wo, s.wi);
        assert!(rel_close(s.f, f, 1e-5), "{name}: sampled f {} vs {f}", s.f);
        let w = s.weight();
        let expect = f * (s.wi.z.abs() / pdf);
        assert!(rel_close(w, expect, 1e-5), "{name}: weight {w} vs {expect}");
    }
}

/// Directions `wo` for a BSDF: the upper hemisphere for reflective ones,
/// both for glass.
fn random_wo(b: &Bsdf, s: &mut Sampler) -> Vec3 {
    let w = square_to_uniform_sphere(s.next_2d());
    if b.has_transmission() {
        w
    } else {
        Vec3::new(w.x, w.y, w.z.abs())
    }
}

// ---------------------------------------------------------------------------
// 13: sample / eval / pdf consistency
// ---------------------------------------------------------------------------

#[test]
fn sample_eval_pdf_agree() {
    for (name, b) in zoo() {
        let mut s = Sampler::new(13, 0, 0);
        let mut some = 0;
        for _ in 0..20_000 {
            let wo = random_wo(&b, &mut s);
            if let Some(bs) = b.sample(wo, s.next_2d()) {
                check_sample(&name, &b, wo, &bs);
                some += 1;
            }
        }
        // guards against a BSDF that rejects everything: the worst here,
        // GGX alpha = 1 over random wo, keeps about 70 %
        assert!(some > 10_000, "{name}: only {some} samples");
    }
}

/// Delta samples point exactly where the laws of reflection and refraction
/// say (computed here in f64 from Snell's law).
#[test]
fn delta_directions_follow_reflection_and_snell() {
    let glass = Glass::default();
    let mut s = Sampler::new(131, 0, 0);
    for _ in 0..20_000 {
        let wo = square_to_uniform_sphere(s.next_2d());
        let Some(bs) = glass.sample(wo, s.next_2d()) else {
            panic!("glass gave no sample for {wo}");
        };
        let wo64 = wo.as_dvec3();
        let wi64 = bs.wi.as_dvec3();
        if bs.wi.z.signum() == wo.z.signum() {
            assert!((wi64 - glass_reflect(wo64)).length() < 1e-6);
        } else {
            // tangential components scale by -eta_o / eta_i; sides swap
            let (n_o, n_i) = if wo.z > 0.0 { (1.0, 1.5) } else { (1.5, 1.0) };
            let t = -wo64 * (n_o / n_i);
            assert!((wi64.x - t.x).abs() < 1e-6 && (wi64.y - t.y).abs() < 1e-6);
            assert!((wi64.length() - 1.0).abs() < 1e-6);
        }
    }
}

fn glass_reflect(w: embertrace::math::DVec3) -> embertrace::math::DVec3 {
    embertrace::math::DVec3::new(-w.x, -w.y, w.z)
}

// ---------------------------------------------------------------------------
// 14: extreme random numbers
// ---------------------------------------------------------------------------

#[test]
fn extreme_random_numbers() {
    let wos = [
        Vec3::Z,
        dir(30.0, 10.0),
        dir(60.0, 200.0),
        dir(89.0, 45.0),
        dir(89.99, 300.0),
    ];
    for (name, b) in zoo() {
        for wo in wos {
            for side in [1.0f32, -1.0] {
                let wo = Vec3::new(wo.x, wo.y, wo.z * side);
                for &x in &EXTREMES {
                    for &y in &EXTREMES {
                        if let Some(bs) = b.sample(wo, Vec2::new(x, y)) {
                            check_sample(&format!("{name} u=({x}, {y})"), &b, wo, &bs);
                        }
                    }
                }
            }
        }
    }
}

// ---------------------------------------------------------------------------
// 16: grazing angles
// ---------------------------------------------------------------------------

#[test]
fn grazing_angles() {
    let cosines = [1.0f32, 1e-3, 1e-6, 1e-8, 0.0, -0.0];
    for (name, b) in zoo() {
        for &c in &cosines {
            let graze = Vec3::new((1.0 - c * c).sqrt(), 0.0, c);
            let other = dir(40.0, 150.0);
            for (wo, wi) in [(other, graze), (graze, other), (graze, graze)] {
                let f = b.eval(wo, wi);
                let p = b.pdf(wo, wi);
                assert!(
                    f.is_finite() && f.min_element() >= 0.0,
                    "{name} cos {c}: f {f}"
                );
                assert!(p.is_finite() && p >= 0.0, "{name} cos {c}: pdf {p}");
                if c == 0.0 {
                    assert_eq!(f, Vec3::ZERO, "{name}: f at cos {c}");
                    assert_eq!(p, 0.0, "{name}: pdf at cos {c}");
                }
            }
            // glass also from inside
            let below = Vec3::new(graze.x, graze.y, -graze.z);
            let wos = if b.has_transmission() {
                vec![graze, below]
            } else {
                vec![graze]
            };
            for wo in wos {
                for u in [Vec2::splat(0.3), Vec2::new(0.9, 0.1)] {
                    if let Some(bs) = b.sample(wo, u) {
                        assert!(c != 0.0, "{name}: sampled at cos {c}");
                        check_sample(&format!("{name} cos {c}"), &b, wo, &bs);
                    }
                }
            }
        }
    }
}

// ---------------------------------------------------------------------------
// Reciprocity
// ---------------------------------------------------------------------------

#[test]
fn reflective_bsdfs_are_reciprocal() {
    for (name, b) in zoo() {
        if b.has_transmission() {
            continue;
        }
        let mut s = Sampler::new(17, 0, 0);
        let mut nonzero = 0;
        for i in 0..20_000 {
            let a = random_wo(&b, &mut s);
            // half the pairs random, half where the BSDF puts its samples
            // (narrow lobes are zero almost everywhere else)
            let c = match b.sample(a, s.next_2d()) {
                Some(bs) if i % 2 == 0 && !bs.delta => bs.wi,
                _ => random_wo(&b, &mut s),
            };
            let (f1, f2) = (b.eval(a, c), b.eval(c, a));
            // 1e-5: f32 rounding (the microfacet lobes are in fact written to
            // be symmetric bit for bit)
            assert!(rel_close(f1, f2, 1e-5), "{name}: f({a}, {c}) {f1} vs {f2}");
            if f1 != Vec3::ZERO {
                nonzero += 1;
            }
        }
        if !b.is_delta() {
            assert!(nonzero > 1000, "{name}: reciprocity tested on zeros");
        }
    }
}

// ---------------------------------------------------------------------------
// 12: chi-square
// ---------------------------------------------------------------------------

#[test]
fn chi2_rough_conductors() {
    // (roughness, incident angle in degrees): a narrow lobe near the normal,
    // a medium one at 60 degrees, a wide one near grazing (many reflected
    // directions fall below the horizon there and are rejected)
    let cases = [(0.1f32, 30.0), (0.4, 60.0), (0.8, 85.0)];
    for dist in [Distribution::Ggx, Distribution::Beckmann] {
        for (k, &(alpha, theta)) in cases.iter().enumerate() {
            let b: Bsdf = conductor(dist, alpha, GOLD_ETA, GOLD_K).into();
            let wo = dir(theta, 20.0);
            let name = format!("conductor {dist:?} alpha {alpha} theta {theta}");
            chi2_reflective(DISCRETE_TESTS, &name, &b, wo, 1200 + k as u64);
        }
    }
}

#[test]
fn chi2_plastic() {
    let rho = Vec3::new(0.8, 0.5, 0.2);
    let cases = [(0.2f32, 40.0), (0.05, 75.0), (0.0, 60.0)];
    for (k, &(alpha, theta)) in cases.iter().enumerate() {
        let b: Bsdf = Plastic::new(rho, 1.5, alpha).unwrap().into();
        let name = format!("plastic alpha {alpha} theta {theta}");
        chi2_reflective(
            DISCRETE_TESTS,
            &name,
            &b,
            dir(theta, 200.0),
            1210 + k as u64,
        );
    }
    let b: Bsdf = Plastic::with_options(
        rho,
        1.5,
        0.2,
        Distribution::Beckmann,
        Masking::default(),
        false,
    )
    .unwrap()
    .into();
    chi2_reflective(
        DISCRETE_TESTS,
        "plastic beckmann linear",
        &b,
        dir(50.0, 10.0),
        1213,
    );
}

#[test]
fn chi2_phong() {
    // a wide and a narrow Phong lobe, a rough and a sharp GGX one (whose
    // reflected directions near grazing often leave the hemisphere)
    let cases = [
        (Lobe::Phong { shininess: 1.0 }, 30.0),
        (Lobe::Phong { shininess: 60.0 }, 60.0),
        (Lobe::Ggx { roughness: 0.5 }, 45.0),
        (Lobe::Ggx { roughness: 0.08 }, 80.0),
    ];
    for (k, &(lobe, theta)) in cases.iter().enumerate() {
        let b: Bsdf = phong(lobe).into();
        chi2_reflective(
            DISCRETE_TESTS,
            &format!("phong {lobe:?} theta {theta}"),
            &b,
            dir(theta, 75.0),
            1300 + k as u64,
        );
    }
}

/// The normalised Phong lobe reflects exactly `ks` of the light arriving
/// along the normal (`(s + 2) / (2 pi)` times the integral of `cos^s cos`):
/// the sampled weights of a white lobe with no diffuse term average to 1.
#[test]
fn phong_lobe_reflects_ks_at_normal_incidence() {
    let z = sidak_z(1e-6, MC_TESTS);
    for (k, s) in [1.0f32, 30.0, 1000.0].into_iter().enumerate() {
        let b = Phong {
            diffuse: Vec3::ZERO,
            specular: Vec3::ONE,
            lobe: Lobe::Phong { shininess: s },
        };
        let stats = batch_means(400_000, 100, |i| {
            let mut smp = Sampler::new(1700 + k as u64, i as u64, 0);
            b.sample(Vec3::Z, smp.next_2d())
                .map_or(0.0, |bs| bs.weight().x as f64)
        });
        println!(
            "phong s {s}: albedo {:.5} +- {:.5}",
            stats.mean, stats.std_err
        );
        assert!(
            (stats.mean - 1.0).abs() < z * stats.std_err + 1e-4,
            "s {s}: {} +- {}",
            stats.mean,
            stats.std_err
        );
    }
}

/// The exact Fresnel reflectance in f64, written out independently of the
/// library: `eta` is the index on the far side of the boundary over the near
/// side's, `c` the cosine on the near side.
fn fresnel_f64(c: f64, eta: f64) -> f64 {
    let s2t = (1.0 - c * c) / (eta * eta);
    if s2t >= 1.0 {
        return 1.0;
    }
    let ct = (1.0 - s2t).sqrt();
    let rs = (c - eta * ct) / (c + eta * ct);
    let rp = (eta * c - ct) / (eta * c + ct);
    0.5 * (rs * rs + rp * rp)
}

#[test]
fn glass_chooses_reflection_with_fresnel_probability() {
    let glass = Glass::default();
    let z = sidak_z(0.01, DISCRETE_TESTS);
    // (degrees, outside?): normal, 45, near grazing outside; 30 inside; just
    // below the critical angle asin(1/1.5) = 41.81 inside
    let cases = [
        (0.0f64, true),
        (45.0, true),
        (80.0, true),
        (30.0, false),
        (41.5, false),
    ];
    for (k, &(theta, outside)) in cases.iter().enumerate() {
        let mut wo = dir(theta, 70.0);
        if !outside {
            wo.z = -wo.z;
        }
        let eta = if outside { 1.5 } else { 1.0 / 1.5 };
        let f = fresnel_f64((wo.z as f64).abs(), eta);
        // the library's f32 Fresnel: a few ulp of the f64 value
        assert!((glass.reflect_probability(wo) as f64 - f).abs() < 1e-6);
        let mut s = Sampler::new(1300 + k as u64, 0, 0);
        let mut reflected = 0usize;
        for _ in 0..N_CHI2 {
            let bs = glass.sample(wo, s.next_2d()).expect("glass always samples");
            if bs.wi.z.signum() == wo.z.signum() {
                reflected += 1;
            }
        }
        let n = N_CHI2 as f64;
        let sd = (n * f * (1.0 - f)).sqrt();
        let dev = (reflected as f64 - n * f).abs();
        println!(
            "glass theta {theta} outside {outside}: {reflected} reflections, expected {:.1} +- {sd:.1}",
            n * f
        );
        assert!(
            dev < z * sd,
            "theta {theta} outside {outside}: {reflected} reflections, expected {:.1} +- {sd:.1}",
            n * f
        );
    }
    // past the critical angle: total internal reflection, always
    let mut wo = dir(50.0, 10.0);
    wo.z = -wo.z;
    let mut s = Sampler::new(1399, 0, 0);
    for _ in 0..10_000 {
        let bs = glass.sample(wo, s.next_2d()).unwrap();
        assert!(bs.wi.z < 0.0 && bs.pdf == 1.0);
    }
}

// ---------------------------------------------------------------------------
// 15: energy
// ---------------------------------------------------------------------------

#[test]
fn mirror_and_glass_lose_nothing_per_sample() {
    let mirror: Bsdf = Mirror::default().into();
    let glass: Bsdf = Glass::default().into();
    let mut s = Sampler::new(15, 0, 0);
    let (mut refl, mut refr, mut tir) = (0, 0, 0);
    for _ in 0..100_000 {
        let wo = square_to_uniform_sphere(s.next_2d());
        let u = s.next_2d();
        // mirror: reflective, so wo on the +z side
        let up = Vec3::new(wo.x, wo.y, wo.z.abs());
        if up.z > 0.0 {
            let bs = mirror.sample(up, u).expect("mirror always samples");
            // weight = (1 / cos) * cos / 1: two f32 roundings
            assert!((bs.weight() - Vec3::ONE).abs().max_element() < 1e-6);
        }
        if wo.z == 0.0 {
            continue;
        }
        let bs = glass.sample(wo, u).expect("glass always samples");
        let w = bs.weight();
        if bs.wi.z.signum() == wo.z.signum() {
            // reflection (F) or total internal reflection (F = 1): weight R = 1
            if fr_dielectric(wo.z, 1.5) == 1.0 {
                tir += 1;
            } else {
                refl += 1;
            }
            assert!((w - Vec3::ONE).abs().max_element() < 1e-6, "{w}");
        } else {
            // refraction: radiance / eta'^2, so L / n^2 is conserved exactly
            refr += 1;
            let etap = if wo.z > 0.0 { 1.5f32 } else { 1.0 / 1.5 };
            // weight T / eta'^2 through a few f32 roundings
            assert!(
                (w * (etap * etap) - Vec3::ONE).abs().max_element() < 1e-6,
                "{w}"
            );
        }
    }
    assert!(
        refl > 1000 && refr > 1000 && tir > 1000,
        "{refl} {refr} {tir}"
    );
}

#[test]
fn perfect_conductor_reflects_everything() {
    for i in 0..=1000 {
        let c = i as f32 / 1000.0;
        let f = fr_conductor(c, PERFECT_ETA, PERFECT_K);
        // f32 rounding of complex arithmetic
        assert!((f - Vec3::ONE).abs().max_element() < 1e-6, "{c}: {f}");
    }
}

#[test]
fn rough_conductor_loses_only_what_single_scattering_explains() {
    let z = sidak_z(1e-6, MC_TESTS);
    let mut report = String::new();
    for dist in [Distribution::Ggx, Distribution::Beckmann] {
        for alpha in [0.1f32, 0.5, 1.0] {
            let b = conductor(dist, alpha, PERFECT_ETA, PERFECT_K);
            for (k, theta) in [0.0f64, 60.0, 84.0].into_iter().enumerate() {
                let wo = dir(theta, 0.0);
                let expected = single_scatter_albedo(dist, alpha as f64, wo.z as f64, false);
                let n = match dist {
                    Distribution::Ggx => 1_000_000,
                    Distribution::Beckmann => 300_000,
                };
                let stats = batch_means(n, 100, |i| {
                    let mut s = Sampler::new(1500 + k as u64, i as u64, alpha.to_bits() as u64);
                    match b.sample(wo, s.next_2d()) {
                        Some(bs) => {
                            let w = bs.weight();
                            // F G2 / G1 with F = 1: never above 1
                            assert!(w.max_element() <= 1.0 + 1e-5, "weight {w}");
                            w.x as f64
                        }
                        None => 0.0,
                    }
                });
                report += &format!(
                    "{dist:?} alpha {alpha} theta {theta}: albedo {:.5} +- {:.5}, single scattering {expected:.5}\n",
                    stats.mean, stats.std_err
                );
                // plus 1e-5 for the quadrature (converged to about 1e-6)
                let band = z * stats.std_err + 1e-5;
                assert!(
                    (stats.mean - expected).abs() < band,
                    "{dist:?} alpha {alpha} theta {theta}: {} vs {expected} (band {band})",
                    stats.mean
                );
                // never above 1 (1e-6: f32 rounding of F = 1 and of the weight)
                assert!(
                    stats.mean <= 1.0 + z * stats.std_err + 1e-6,
                    "{}",
                    stats.mean
                );
            }
        }
    }
    println!("{report}");
}

#[test]
fn white_plastic_conserves_energy() {
    let z = sidak_z(1e-6, MC_TESTS);
    for alpha in [0.0f32, 0.3] {
        let b = Plastic::new(Vec3::ONE, 1.5, alpha).unwrap();
        for (k, theta) in [0.0f64, 60.0, 85.0].into_iter().enumerate() {
            let wo = dir(theta, 30.0);
            let stats = batch_means(400_000, 100, |i| {
                let mut s = Sampler::new(1600 + k as u64, i as u64, alpha.to_bits() as u64);
                b.sample(wo, s.next_2d())
                    .map_or(0.0, |bs| bs.weight().x as f64)
            });
            // smooth: exactly 1 (the numerical E_avg is good to 1e-7);
            // rough: 1 + E(mu) - E_table(mu), and the table is within 1.2e-3
            // of E (measured, see plastic.rs)
            let table = if alpha == 0.0 { 0.0 } else { 1.2e-3 };
            println!(
                "plastic alpha {alpha} theta {theta}: albedo {:.5} +- {:.5}",
                stats.mean, stats.std_err
            );
            assert!(
                (stats.mean - 1.0).abs() < z * stats.std_err + table,
                "alpha {alpha} theta {theta}: {} +- {}",
                stats.mean,
                stats.std_err
            );
        }
    }
}

/// White furnace sanity: as `alpha -> 0` the rough conductor's albedo tends
/// to the smooth conductor's `F(cos theta_o)` and its samples crowd around
/// the mirror direction.
#[test]
fn rough_conductor_tends_to_the_smooth_one() {
    let z = sidak_z(1e-6, MC_TESTS);
    for (k, theta) in [0.0f64, 45.0, 80.0].into_iter().enumerate() {
        let wo = dir(theta, 60.0);
        let mirror_dir = Vec3::new(-wo.x, -wo.y, wo.z);
        let smooth = conductor(Distribution::Ggx, 0.0, GOLD_ETA, GOLD_K);
        let f_smooth = smooth.sample(wo, Vec2::ZERO).unwrap().weight();
        let mut prev_err = f64::INFINITY;
        for alpha in [0.05f32, 0.01, 0.002] {
            let b = conductor(Distribution::Ggx, alpha, GOLD_ETA, GOLD_K);
            let mut far = 0usize;
            let n = 200_000;
            let stats = batch_means(n, 100, |i| {
                let mut s = Sampler::new(1700 + k as u64, i as u64, alpha.to_bits() as u64);
                match b.sample(wo, s.next_2d()) {
                    Some(bs) => {
                        // GGX tails: P(tan theta_h > 20 alpha) ~ 1 / 400, and
                        // the reflection doubles the angle
                        if bs.wi.angle_between(mirror_dir) > 40.0 * alpha {
                            far += 1;
                        }
                        bs.weight().y as f64
                    }
                    None => 0.0,
                }
            });
            assert!(
                (far as f64) < 0.01 * n as f64,
                "alpha {alpha} theta {theta}: {far} samples far from the mirror direction"
            );
            let err = (stats.mean - f_smooth.y as f64).abs();
            // the gap is O(alpha): Fresnel varies over the lobe's width and
            // masking grows like alpha tan(theta); 0.5 alpha (1 + tan) bounds
            // both here with room, plus the Monte Carlo band
            let tan = theta.to_radians().tan();
            let bound = 0.5 * alpha as f64 * (1.0 + tan) + z * stats.std_err;
            assert!(
                err < bound,
                "alpha {alpha} theta {theta}: {} vs smooth {} (bound {bound})",
                stats.mean,
                f_smooth.y
            );
            println!(
                "alpha {alpha} theta {theta}: rough {:.5} smooth {:.5}",
                stats.mean, f_smooth.y
            );
            assert!(err <= prev_err + z * stats.std_err);
            prev_err = err;
        }
    }
}
