//! Checks shared by the BSDF tests: the chi-square test of hard case 12
//! for a reflective BSDF, and the single-scattering albedo of a Smith
//! microfacet mirror by quadrature.

use super::chi2_test;
use embertrace::bsdf::{Bsdf, Bxdf, Distribution};
use embertrace::math::Vec3;
use embertrace::sampler::Sampler;
use std::f64::consts::PI;

/// Samples per chi-square test.
pub const N_CHI2: usize = 1_000_000;
const N_THETA: usize = 100;
const N_PHI: usize = 200;

/// 4-point Gauss-Legendre nodes and weights on [-1, 1].
const GL4: [(f64, f64); 4] = [
    (-0.861_136_311_594_053, 0.347_854_845_137_454),
    (-0.339_981_043_584_856, 0.652_145_154_862_546),
    (0.339_981_043_584_856, 0.652_145_154_862_546),
    (0.861_136_311_594_053, 0.347_854_845_137_454),
];

fn gl4(f: &impl Fn(f64, f64) -> f64, x0: f64, x1: f64, y0: f64, y1: f64) -> f64 {
    let (cx, hx, cy, hy) = (
        0.5 * (x0 + x1),
        0.5 * (x1 - x0),
        0.5 * (y0 + y1),
        0.5 * (y1 - y0),
    );
    let mut s = 0.0;
    for (a, wa) in GL4 {
        for (b, wb) in GL4 {
            s += wa * wb * f(cx + hx * a, cy + hy * b);
        }
    }
    s * hx * hy
}

/// Adaptive cubature of `f` over a cell: accept when the 2x2 refinement
/// agrees with the whole-cell rule to 1e-6 relative (1e-13 absolute, i.e.
/// 1e-7 samples out of 1e6), else recurse.
pub fn integrate(
    f: &impl Fn(f64, f64) -> f64,
    x0: f64,
    x1: f64,
    y0: f64,
    y1: f64,
    depth: u32,
) -> f64 {
    let coarse = gl4(f, x0, x1, y0, y1);
    let (xm, ym) = (0.5 * (x0 + x1), 0.5 * (y0 + y1));
    let quads = [
        (x0, xm, y0, ym),
        (xm, x1, y0, ym),
        (x0, xm, ym, y1),
        (xm, x1, ym, y1),
    ];
    let fine: f64 = quads.iter().map(|&(a, b, c, d)| gl4(f, a, b, c, d)).sum();
    if depth == 0 || (fine - coarse).abs() <= 1e-6 * fine.abs() + 1e-13 {
        return fine;
    }
    quads
        .iter()
        .map(|&(a, b, c, d)| integrate(f, a, b, c, d, depth - 1))
        .sum()
}

/// The chi-square test of hard case 12 for a reflective BSDF at `wo`: 1e6
/// samples binned over `(cos theta, phi)` of the upper hemisphere (100 x 200
/// cells), plus one cell for delta samples, whose expected share is the
/// lobe probability the delta samples report, and one for rejected samples
/// (`None`), whose expected share is what the others leave. Expected counts
/// integrate `pdf()` over each cell (to about 1e-6 relative, so the
/// remainder is good to about one sample).
/// `tests_in_file` is the number of discrete tests the calling file runs
/// (for Sidak's correction).
pub fn chi2_reflective(tests_in_file: usize, name: &str, b: &Bsdf, wo: Vec3, seed: u64) {
    let (delta_cell, rejected_cell) = (N_THETA * N_PHI, N_THETA * N_PHI + 1);
    let mut obs = vec![0.0f64; N_THETA * N_PHI + 2];
    let mut s = Sampler::new(seed, 0, 0);
    let mut delta_pdf: Option<f32> = None;
    for _ in 0..N_CHI2 {
        let Some(bs) = b.sample(wo, s.next_2d()) else {
            obs[rejected_cell] += 1.0;
            continue;
        };
        assert!(bs.wi.z > 0.0, "{name}: sample below the surface");
        if bs.delta {
            assert!(delta_pdf.is_none_or(|p| p == bs.pdf));
            delta_pdf = Some(bs.pdf);
            obs[delta_cell] += 1.0;
            continue;
        }
        let c = (bs.wi.z as f64).clamp(0.0, 1.0);
        let phi = (bs.wi.y as f64).atan2(bs.wi.x as f64).rem_euclid(2.0 * PI);
        let i = ((c * N_THETA as f64) as usize).min(N_THETA - 1);
        let j = ((phi / (2.0 * PI) * N_PHI as f64) as usize).min(N_PHI - 1);
        obs[i * N_PHI + j] += 1.0;
    }
    let mut exp = vec![0.0f64; N_THETA * N_PHI + 2];
    let pdf = |c: f64, phi: f64| {
        let st = (1.0 - c * c).max(0.0).sqrt();
        let wi = Vec3::new((st * phi.cos()) as f32, (st * phi.sin()) as f32, c as f32);
        b.pdf(wo, wi) as f64
    };
    let (dc, dp) = (1.0 / N_THETA as f64, 2.0 * PI / N_PHI as f64);
    for i in 0..N_THETA {
        for j in 0..N_PHI {
            let (c0, p0) = (i as f64 * dc, j as f64 * dp);
            exp[i * N_PHI + j] = N_CHI2 as f64 * integrate(&pdf, c0, c0 + dc, p0, p0 + dp, 6);
        }
    }
    exp[delta_cell] = N_CHI2 as f64 * delta_pdf.unwrap_or(0.0) as f64;
    let accepted: f64 = exp.iter().sum();
    exp[rejected_cell] = (N_CHI2 as f64 - accepted).max(0.0);
    let c = chi2_test(tests_in_file, name, &obs, &exp);
    println!(
        "{name}: chi2 {:.1} < {:.1} with {} dof (z {:.2}); rejected {} (expected {:.1})",
        c.stat,
        c.crit,
        c.dof,
        c.z(),
        obs[rejected_cell],
        exp[rejected_cell]
    );
}

/// Smith's Lambda for each distribution in f64, written out independently
/// of the library (Heitz 2014, eqs. 69 and 72).
pub fn lambda_f64(dist: Distribution, alpha: f64, w: embertrace::math::DVec3) -> f64 {
    let sin = (w.x * w.x + w.y * w.y).sqrt();
    if sin == 0.0 {
        return 0.0;
    }
    let tan = sin / w.z;
    match dist {
        Distribution::Ggx => 0.5 * ((1.0 + alpha * alpha * tan * tan).sqrt() - 1.0),
        Distribution::Beckmann => {
            let a = 1.0 / (alpha * tan);
            0.5 * (-super::erfc(a) + (-a * a).exp() / (a * PI.sqrt()))
        }
    }
}

/// The single-scattering albedo of a Smith microfacet mirror with Fresnel 1,
/// `E(mu) = integral D(h) G2(wo, wi) (wo . h) / mu dh`, by a midpoint rule
/// over `h` warped by `D(h) cos(theta_h)` (the classic inverse-CDF warps,
/// not the library's visible-normal sampler), in f64; symmetric in phi, so
/// half the circle. Converged to about 1e-6 (checked against grids of 8000 x
/// 2000). Anything a multiple-scattering model would add is
/// missing, so this is exactly what the BSDF must reflect. `separable`:
/// Smith's separable `G1(wo) G1(wi)` in place of the height-correlated `G2`.
pub fn single_scatter_albedo(dist: Distribution, alpha: f64, mu: f64, separable: bool) -> f64 {
    let wo = embertrace::math::DVec3::new((1.0 - mu * mu).sqrt(), 0.0, mu);
    let lo = lambda_f64(dist, alpha, wo);
    let (nu, nv) = (2000usize, 500usize);
    let mut sum = 0.0;
    for i in 0..nu {
        // u = 1 - (1 - t)^4 crowds the nodes into GGX's long tail, where the
        // weight 1 / cos(theta_h) of a grazing view is largest (a uniform
        // grid in u is off by 1e-3 at 84 degrees; this one converges to 1e-6)
        let t = (i as f64 + 0.5) / nu as f64;
        let u = 1.0 - (1.0 - t).powi(4);
        let jacobian = 4.0 * (1.0 - t).powi(3);
        let tan2 = match dist {
            Distribution::Ggx => alpha * alpha * u / (1.0 - u),
            Distribution::Beckmann => -alpha * alpha * (1.0 - u).ln(),
        };
        let ch = 1.0 / (1.0 + tan2).sqrt();
        let sh = tan2.sqrt() * ch;
        for j in 0..nv {
            let phi = PI * (j as f64 + 0.5) / nv as f64;
            let h = embertrace::math::DVec3::new(sh * phi.cos(), sh * phi.sin(), ch);
            let woh = wo.dot(h);
            if woh <= 0.0 {
                continue;
            }
            let wi = 2.0 * woh * h - wo;
            if wi.z <= 0.0 {
                continue;
            }
            let li = lambda_f64(dist, alpha, wi);
            let g2 = if separable {
                1.0 / ((1.0 + lo) * (1.0 + li))
            } else {
                1.0 / (1.0 + lo + li)
            };
            sum += g2 * woh / (mu * ch) * jacobian;
        }
    }
    sum / (nu * nv) as f64
}
