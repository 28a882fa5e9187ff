//! The rough dielectric (`bsdf/rough_glass.rs`): chi-square tests of its
//! sampling over the whole sphere (hard case 12, both lobes, from outside
//! and from inside, beyond the critical angle included), and a white
//! furnace: with unit scales, the sampled weights times the refraction's
//! `eta'^2` (what the estimator undoes for roulette: radiance over `n^2` is
//! what a lossless boundary keeps) average to at most 1, to 1 within
//! single scattering's loss at small roughness. The agreement of `sample`,
//! `eval` and `pdf` is in `tests/bsdf.rs`, whose zoo holds two rough
//! glasses.

mod common;

use common::bsdf_checks::integrate;
use common::{batch_means, chi2_test, sidak_z};
use embertrace::bsdf::{Bsdf, Bxdf, RoughGlass};
use embertrace::math::Vec3;
use embertrace::sampler::Sampler;
use std::f64::consts::PI;

const DISCRETE_TESTS: usize = 3;
const MC_TESTS: usize = 6;
const N: usize = 1_000_000;
const N_COS: usize = 100;
const N_PHI: usize = 100;

fn dir(theta_deg: f64, phi_deg: f64) -> Vec3 {
    let (t, p) = (theta_deg.to_radians(), phi_deg.to_radians());
    Vec3::new(
        (t.sin() * p.cos()) as f32,
        (t.sin() * p.sin()) as f32,
        t.cos() as f32,
    )
}

/// Samples binned over `(cos theta, phi)` of the whole sphere plus a cell
/// for rejected samples; expected counts integrate `pdf()` per cell.
fn chi2_sphere(name: &str, b: &Bsdf, wo: Vec3, seed: u64) {
    let rejected = N_COS * N_PHI;
    let mut obs = vec![0.0f64; rejected + 1];
    let mut s = Sampler::new(seed, 0, 0);
    for _ in 0..N {
        let Some(bs) = b.sample(wo, s.next_2d()) else {
            obs[rejected] += 1.0;
            continue;
        };
        assert!(!bs.delta);
        let c = (bs.wi.z as f64).clamp(-1.0, 1.0);
        let phi = (bs.wi.y as f64).atan2(bs.wi.x as f64).rem_euclid(2.0 * PI);
        let i = (((c + 1.0) * 0.5 * N_COS as f64) as usize).min(N_COS - 1);
        let j = ((phi / (2.0 * PI) * N_PHI as f64) as usize).min(N_PHI - 1);
        obs[i * N_PHI + j] += 1.0;
    }
    let pdf = |c: f64, phi: f64| {
        let st = (1.0 - c * c).max(0.0).sqrt();
        let wi = Vec3::new((st * phi.cos()) as f32, (st * phi.sin()) as f32, c as f32);
        b.pdf(wo, wi) as f64
    };
    let mut exp = vec![0.0f64; rejected + 1];
    let (dc, dp) = (2.0 / N_COS as f64, 2.0 * PI / N_PHI as f64);
    for i in 0..N_COS {
        for j in 0..N_PHI {
            let (c0, p0) = (-1.0 + i as f64 * dc, j as f64 * dp);
            // 4 x 4 sub-cells first: the lobes' supports end sharply (a
            // microfacet facing away from either direction contributes
            // nothing), and a cell whose few nodes all miss a sliver of
            // support would expect no samples
            let (sc, sp) = (dc / 4.0, dp / 4.0);
            let mut e = 0.0;
            for a in 0..4 {
                for b in 0..4 {
                    let (c, p) = (c0 + a as f64 * sc, p0 + b as f64 * sp);
                    e += integrate(&pdf, c, c + sc, p, p + sp, 5);
                }
            }
            exp[i * N_PHI + j] = N as f64 * e;
        }
    }
    let accepted: f64 = exp.iter().sum();
    exp[rejected] = (N as f64 - accepted).max(0.0);
    let c = chi2_test(DISCRETE_TESTS, name, &obs, &exp);
    println!(
        "{name}: chi2 {:.1} < {:.1} with {} dof; rejected {} (expected {:.1})",
        c.stat, c.crit, c.dof, obs[rejected], exp[rejected]
    );
}

#[test]
fn chi2_rough_glass_from_both_sides() {
    // outside; inside below the critical angle (41.8 degrees); inside
    // beyond it, where only some microfacets let light out
    let cases = [(0.3f32, 40.0f64), (0.5, 150.0), (0.25, 125.0)];
    for (k, &(alpha, theta)) in cases.iter().enumerate() {
        let b: Bsdf = RoughGlass {
            alpha,
            ..RoughGlass::default()
        }
        .into();
        chi2_sphere(
            &format!("rough glass alpha {alpha} theta {theta}"),
            &b,
            dir(theta, 30.0),
            2100 + k as u64,
        );
    }
}

/// `int f |cos| u dwi` over the sphere, `u` the `eta'^2` the estimator
/// undoes after a refraction, by the chi-square test's cubature (100 x 100
/// cells of 4 x 4 sub-cells), in f64 from the BSDF's own `eval`.
fn albedo_by_quadrature(b: &RoughGlass, wo: Vec3) -> f64 {
    let etap = if wo.z > 0.0 { b.ior } else { 1.0 / b.ior } as f64;
    let f = |c: f64, phi: f64| {
        let st = (1.0 - c * c).max(0.0).sqrt();
        let wi = Vec3::new((st * phi.cos()) as f32, (st * phi.sin()) as f32, c as f32);
        let undo = if c * (wo.z as f64) < 0.0 {
            etap * etap
        } else {
            1.0
        };
        b.eval(wo, wi).x as f64 * c.abs() * undo
    };
    let (dc, dp) = (2.0 / (4 * N_COS) as f64, 2.0 * PI / (4 * N_PHI) as f64);
    let mut sum = 0.0;
    for i in 0..4 * N_COS {
        for j in 0..4 * N_PHI {
            let (c0, p0) = (-1.0 + i as f64 * dc, j as f64 * dp);
            sum += integrate(&f, c0, c0 + dc, p0, p0 + dp, 3);
        }
    }
    sum
}

/// Unit scales: the sampled weights (times the `eta'^2` the estimator
/// undoes) average to the quadrature of `f |cos|`, and to at most 1: a
/// single-scattering model loses energy (more from inside, where light
/// reflected totally by one microfacet is lost), never gains it.
#[test]
fn white_rough_glass_matches_its_integral_and_never_gains() {
    let z = sidak_z(1e-6, MC_TESTS);
    for alpha in [0.1f32, 0.3] {
        let b = RoughGlass {
            alpha,
            ..RoughGlass::default()
        };
        for (k, theta) in [0.0f64, 60.0, 150.0].into_iter().enumerate() {
            let wo = dir(theta, 10.0);
            let etap = if wo.z > 0.0 { b.ior } else { 1.0 / b.ior };
            let stats = batch_means(400_000, 100, |i| {
                let mut s = Sampler::new(2200 + k as u64, i as u64, alpha.to_bits() as u64);
                match b.sample(wo, s.next_2d()) {
                    Some(bs) => {
                        let undo = if bs.wi.z * wo.z < 0.0 {
                            etap * etap
                        } else {
                            1.0
                        };
                        (bs.weight().x * undo) as f64
                    }
                    None => 0.0,
                }
            });
            let expected = albedo_by_quadrature(&b, wo);
            println!(
                "rough glass alpha {alpha} theta {theta}: {:.5} +- {:.5}, quadrature {expected:.5}",
                stats.mean, stats.std_err
            );
            // the cubature is good to about 1e-3 near the lobes' peaks
            let band = z * stats.std_err + 2e-3;
            assert!(
                (stats.mean - expected).abs() < band,
                "alpha {alpha} theta {theta}: {} vs {expected} (band {band})",
                stats.mean
            );
            assert!(
                stats.mean < 1.0 + z * stats.std_err,
                "alpha {alpha} theta {theta}: gains energy, {}",
                stats.mean
            );
        }
    }
}
