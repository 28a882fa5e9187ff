//! Chi-square goodness-of-fit tests for every sampler (hard case 12): 1e6
//! samples, cells with expected count below 5 pooled, alpha 0.01 after Sidak
//! correction over the tests in this file; no sample may land in a cell of
//! zero expected count.

mod common;

use embertrace::sampler::Sampler;
use embertrace::sampling::{
    Discrete, square_to_cosine_hemisphere, square_to_uniform_sphere, square_to_uniform_triangle,
};
use std::f64::consts::PI;

const TESTS_IN_FILE: usize = 4;
const N: usize = 1_000_000;

#[test]
fn cosine_hemisphere() {
    let (nt, np) = (100usize, 200usize);
    let mut obs = vec![0.0; nt * np];
    let mut s = Sampler::new(21, 0, 0);
    for _ in 0..N {
        let w = square_to_cosine_hemisphere(s.next_2d());
        let ct = (w.z as f64).clamp(0.0, 1.0 - 1e-12);
        let phi = (w.y as f64).atan2(w.x as f64).rem_euclid(2.0 * PI);
        let i = ((ct * nt as f64) as usize).min(nt - 1);
        let j = ((phi / (2.0 * PI) * np as f64) as usize).min(np - 1);
        obs[i * np + j] += 1.0;
    }
    let mut exp = vec![0.0; nt * np];
    for i in 0..nt {
        let (c0, c1) = (i as f64 / nt as f64, (i + 1) as f64 / nt as f64);
        // density cos/pi over d(cos) d(phi)
        let frac = (c1 * c1 - c0 * c0) / 2.0 * (2.0 * PI / np as f64) / PI;
        for j in 0..np {
            exp[i * np + j] = frac * N as f64;
        }
    }
    common::chi2_test(TESTS_IN_FILE, "cosine hemisphere", &obs, &exp);
}

#[test]
fn uniform_sphere() {
    let (nt, np) = (100usize, 200usize);
    let mut obs = vec![0.0; nt * np];
    let mut s = Sampler::new(22, 0, 0);
    for _ in 0..N {
        let w = square_to_uniform_sphere(s.next_2d());
        let ct = (w.z as f64 + 1.0) / 2.0;
        let phi = (w.y as f64).atan2(w.x as f64).rem_euclid(2.0 * PI);
        let i = ((ct * nt as f64) as usize).min(nt - 1);
        let j = ((phi / (2.0 * PI) * np as f64) as usize).min(np - 1);
        obs[i * np + j] += 1.0;
    }
    let exp = vec![N as f64 / (nt * np) as f64; nt * np];
    common::chi2_test(TESTS_IN_FILE, "uniform sphere", &obs, &exp);
}

#[test]
fn uniform_triangle() {
    let g = 40usize;
    let mut obs = vec![0.0; g * g];
    let mut s = Sampler::new(23, 0, 0);
    for _ in 0..N {
        let b = square_to_uniform_triangle(s.next_2d());
        assert!(b.x >= 0.0 && b.y >= 0.0 && b.x + b.y <= 1.0 + 1e-6);
        let i = ((b.x as f64 * g as f64) as usize).min(g - 1);
        let j = ((b.y as f64 * g as f64) as usize).min(g - 1);
        obs[i * g + j] += 1.0;
    }
    // area of each cell below the line x + y = 1, over the triangle's area 1/2
    let mut exp = vec![0.0; g * g];
    let h = 1.0 / g as f64;
    for i in 0..g {
        for j in 0..g {
            let (x0, y0) = (i as f64 * h, j as f64 * h);
            let steps = 2048;
            let mut area = 0.0;
            for k in 0..steps {
                let x = x0 + (k as f64 + 0.5) * h / steps as f64;
                area += (1.0 - x - y0).clamp(0.0, h) * h / steps as f64;
            }
            exp[i * g + j] = area / 0.5 * N as f64;
        }
    }
    common::chi2_test(TESTS_IN_FILE, "uniform triangle", &obs, &exp);
}

#[test]
fn light_selection() {
    let weights: Vec<f32> = (0..300)
        .map(|i| {
            if i % 7 == 0 {
                0.0
            } else {
                1.0 + (i % 13) as f32
            }
        })
        .collect();
    let d = Discrete::new(&weights);
    let total: f64 = weights.iter().map(|&w| w as f64).sum();
    let mut obs = vec![0.0; weights.len()];
    let mut s = Sampler::new(24, 0, 0);
    for _ in 0..N {
        let x = d.sample(s.next_1d()).unwrap();
        assert!((x.pmf as f64 - weights[x.index] as f64 / total).abs() < 1e-6);
        obs[x.index] += 1.0;
    }
    let exp: Vec<f64> = weights
        .iter()
        .map(|&w| w as f64 / total * N as f64)
        .collect();
    common::chi2_test(TESTS_IN_FILE, "light selection", &obs, &exp);
}
