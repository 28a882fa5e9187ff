//! Shared helpers for the integration tests: scenes built in code, and the
//! batch-means statistics of `../shared/docs/hard-cases.md` (fixed seeds,
//! bands of about 5 sigma from batch means in f64, Sidak-corrected when several
//! tests share one run).
#![allow(dead_code)]

pub mod bsdf_checks;

use embertrace::accel::{self, AccelOptions, Accelerator, Backend};
use embertrace::math::Vec3;
use embertrace::scene::{Material, MeshData, Scene, SceneBuilder, Transform};
use std::path::Path;

/// A mesh under construction: quads and triangles with their materials.
#[derive(Default)]
pub struct MeshMaker {
    pub data: MeshData,
}

impl MeshMaker {
    pub fn material(&mut self, albedo: f32, emission: f32, two_sided: bool) -> u32 {
        self.data.materials.push(Material {
            emission: Vec3::splat(emission),
            two_sided,
            ..Material::diffuse(
                &format!("m{}", self.data.materials.len()),
                Vec3::splat(albedo),
            )
        });
        self.data.materials.len() as u32 - 1
    }

    /// Triangle a-b-c, counter-clockwise seen from the front.
    pub fn tri(&mut self, a: Vec3, b: Vec3, c: Vec3, mat: u32) {
        let base = self.data.positions.len() as u32;
        self.data
            .positions
            .extend([a, b, c].map(embertrace::math::Vec3::as_dvec3));
        self.data.indices.push([base, base + 1, base + 2]);
        self.data.tri_material.push(mat);
    }

    /// Quad a-b-c-d, counter-clockwise seen from the front.
    pub fn quad(&mut self, a: Vec3, b: Vec3, c: Vec3, d: Vec3, mat: u32) {
        self.tri(a, b, c, mat);
        self.tri(a, c, d, mat);
    }

    /// Regular n-gon of radius r centred at `c` in the plane z = c.z, facing
    /// -z (down) when `down`, else +z. Returns its corners in order.
    pub fn disk(&mut self, c: Vec3, r: f32, n: usize, down: bool, mat: u32) -> Vec<Vec3> {
        let pts: Vec<Vec3> = (0..n)
            .map(|i| {
                let a = 2.0 * std::f32::consts::PI * i as f32 / n as f32;
                c + Vec3::new(r * a.cos(), r * a.sin(), 0.0)
            })
            .collect();
        for i in 0..n {
            let (p, q) = (pts[i], pts[(i + 1) % n]);
            if down {
                self.tri(c, q, p, mat);
            } else {
                self.tri(c, p, q, mat);
            }
        }
        pts
    }

    /// An axis-aligned box [lo, hi] whose faces point inwards.
    pub fn inward_box(&mut self, lo: Vec3, hi: Vec3, mat: u32) {
        let p = |x: usize, y: usize, z: usize| {
            Vec3::new(
                if x == 0 { lo.x } else { hi.x },
                if y == 0 { lo.y } else { hi.y },
                if z == 0 { lo.z } else { hi.z },
            )
        };
        self.quad(p(0, 0, 0), p(0, 0, 1), p(1, 0, 1), p(1, 0, 0), mat); // floor, +y
        self.quad(p(0, 1, 0), p(1, 1, 0), p(1, 1, 1), p(0, 1, 1), mat); // ceiling, -y
        self.quad(p(0, 0, 0), p(1, 0, 0), p(1, 1, 0), p(0, 1, 0), mat); // z = lo, +z
        self.quad(p(0, 0, 1), p(0, 1, 1), p(1, 1, 1), p(1, 0, 1), mat); // z = hi, -z
        self.quad(p(0, 0, 0), p(0, 1, 0), p(0, 1, 1), p(0, 0, 1), mat); // x = lo, +x
        self.quad(p(1, 0, 0), p(1, 0, 1), p(1, 1, 1), p(1, 1, 0), mat); // x = hi, -x
    }

    pub fn scene(self) -> Scene {
        let mut b = SceneBuilder::new(Path::new("test-scene"));
        b.add_mesh(self.data, &Transform::default());
        b.build()
    }
}

/// Lambert's formula: the form factor from a point at the origin with normal
/// `n` to a polygon (corners in order, all above the horizon).
pub fn lambert_form_factor(poly: &[Vec3], n: Vec3) -> f64 {
    let n = n.as_dvec3();
    let mut sum = 0.0;
    for i in 0..poly.len() {
        let a = poly[i].as_dvec3().normalize();
        let b = poly[(i + 1) % poly.len()].as_dvec3().normalize();
        let angle = a.dot(b).clamp(-1.0, 1.0).acos();
        sum += angle * n.dot(a.cross(b).normalize());
    }
    (sum / (2.0 * std::f64::consts::PI)).abs()
}

/// Mean and standard error of the mean from `batches` batch means.
pub struct BatchStats {
    pub mean: f64,
    pub std_err: f64,
}

/// Run `n` samples of `f` in `batches` equal batches; batch means give the
/// standard error (robust to heavy tails within a batch).
pub fn batch_means(n: usize, batches: usize, mut f: impl FnMut(usize) -> f64) -> BatchStats {
    let per = n / batches;
    let mut means = Vec::with_capacity(batches);
    for b in 0..batches {
        let mut s = 0.0;
        for i in 0..per {
            let x = f(b * per + i);
            assert!(x.is_finite() && x >= 0.0, "sample {} is {x}", b * per + i);
            s += x;
        }
        means.push(s / per as f64);
    }
    let mean = means.iter().sum::<f64>() / batches as f64;
    let var = means.iter().map(|m| (m - mean).powi(2)).sum::<f64>() / (batches - 1) as f64;
    BatchStats {
        mean,
        std_err: (var / batches as f64).sqrt(),
    }
}

/// The two-sided z quantile for `alpha` after Sidak correction over `m`
/// tests: `1 - (1 - alpha)^(1/m)`. Bisection on the normal tail.
pub fn sidak_z(alpha: f64, m: usize) -> f64 {
    let a = 1.0 - (1.0 - alpha).powf(1.0 / m as f64);
    // two-sided tail: P(|Z| > z) = erfc(z / sqrt 2)
    let (mut lo, mut hi) = (0.0f64, 40.0f64);
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if erfc(mid / std::f64::consts::SQRT_2) > a {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}

/// Complementary error function (Numerical Recipes' erfcc, |error| <
/// 1.2e-7): the renderer's own, which the Beckmann distribution uses.
pub use embertrace::bsdf::microfacet::erfc;

/// Upper `alpha` quantile of chi-square with `k` degrees of freedom
/// (Wilson and Hilferty 1931; accurate for k in the hundreds).
pub fn chi2_quantile(k: f64, alpha: f64) -> f64 {
    let z = sidak_z(2.0 * alpha, 1); // one-sided
    let a = 2.0 / (9.0 * k);
    k * (1.0 - a + z * a.sqrt()).powi(3)
}

/// Pearson's chi-square test of `observed` counts against `expected` counts
/// at level 0.01, Sidak-corrected over `tests_in_file` tests. Cells with
/// expected count below 5 are pooled into one; a sample in a cell of zero
/// expected count fails at once.
pub fn chi2_test(tests_in_file: usize, name: &str, observed: &[f64], expected: &[f64]) -> Chi2 {
    let alpha = 1.0 - (1.0f64 - 0.01).powf(1.0 / tests_in_file as f64);
    let mut cells: Vec<(f64, f64)> = observed
        .iter()
        .copied()
        .zip(expected.iter().copied())
        .collect();
    for (o, e) in &cells {
        assert!(
            *e > 0.0 || *o == 0.0,
            "{name}: {o} samples in a cell of zero expected count"
        );
    }
    cells.sort_by(|a, b| a.1.partial_cmp(&b.1).unwrap());
    let (mut pooled_o, mut pooled_e) = (0.0, 0.0);
    let mut stat = 0.0;
    let mut dof = 0usize;
    for (o, e) in cells {
        if e < 5.0 {
            pooled_o += o;
            pooled_e += e;
            continue;
        }
        stat += (o - e).powi(2) / e;
        dof += 1;
    }
    if pooled_e > 0.0 {
        stat += (pooled_o - pooled_e).powi(2) / pooled_e;
        dof += 1;
    }
    assert!(dof >= 2, "{name}: only {dof} cells, nothing to test");
    let k = (dof - 1) as f64;
    let crit = chi2_quantile(k, alpha);
    assert!(
        stat < crit,
        "{name}: chi2 {stat:.1} >= {crit:.1} with {k} dof"
    );
    Chi2 { stat, crit, dof: k }
}

/// The outcome of a passed [`chi2_test`].
pub struct Chi2 {
    /// Pearson's statistic.
    pub stat: f64,
    /// Its critical value.
    pub crit: f64,
    /// Degrees of freedom.
    pub dof: f64,
}

impl Chi2 {
    /// How many standard deviations (`sqrt(2 dof)`) the statistic lies above
    /// its mean `dof`.
    pub fn z(&self) -> f64 {
        (self.stat - self.dof) / (2.0 * self.dof).sqrt()
    }
}

/// Per-pixel statistics of an RGB image estimate: the mean and the variance
/// of that mean for every pixel and channel, interleaved (`(y w + x) 3 + c`).
pub struct PixelStats {
    pub mean: Vec<f64>,
    pub var_of_mean: Vec<f64>,
}

impl PixelStats {
    /// The statistics of `passes` independent estimates of the same image
    /// (interleaved RGB each): their mean, and the variance of that mean
    /// from their spread (`ddof = 1`).
    pub fn from_passes(passes: &[Vec<f32>]) -> PixelStats {
        let p = passes.len() as f64;
        assert!(passes.len() >= 2, "a spread needs two passes");
        let n = passes[0].len();
        let (mut mean, mut var_of_mean) = (vec![0.0; n], vec![0.0; n]);
        for i in 0..n {
            let m = passes.iter().map(|img| img[i] as f64).sum::<f64>() / p;
            let ss: f64 = passes.iter().map(|img| (img[i] as f64 - m).powi(2)).sum();
            mean[i] = m;
            var_of_mean[i] = ss / (p - 1.0) / p;
        }
        PixelStats { mean, var_of_mean }
    }

    /// The whole image's mean per channel and the variance of that mean: the
    /// sum of the pixels' variances over the pixel count squared, since each
    /// pixel draws random numbers of its own (seed, pixel, sample index), so
    /// that pixels are independent. Summing a thousand or more pixels'
    /// estimates makes the variance estimate stable, so a normal quantile
    /// applies.
    pub fn image_mean(&self) -> ([f64; 3], [f64; 3]) {
        let n = (self.mean.len() / 3) as f64;
        let (mut m, mut v) = ([0.0; 3], [0.0; 3]);
        for (i, (x, s)) in self.mean.iter().zip(&self.var_of_mean).enumerate() {
            m[i % 3] += x;
            v[i % 3] += s;
        }
        (m.map(|x| x / n), v.map(|x| x / (n * n)))
    }
}

/// A z-test of the whole image's mean, channel by channel, against a
/// reference's: `|ours - ref| <= z sqrt(var_ours + var_ref) + systematic ref`.
pub struct MeanTest {
    pub ours: [f64; 3],
    pub reference: [f64; 3],
    /// Standard error of the difference, per channel.
    pub se: [f64; 3],
    /// The normal quantile (Sidak-corrected by the caller).
    pub z: f64,
    /// Relative slack for differences that are there by design.
    pub systematic: f64,
}

impl MeanTest {
    pub fn new(ours: &PixelStats, reference: &PixelStats, z: f64, systematic: f64) -> MeanTest {
        let ((mo, vo), (mr, vr)) = (ours.image_mean(), reference.image_mean());
        MeanTest {
            ours: mo,
            reference: mr,
            se: [0, 1, 2].map(|c| (vo[c] + vr[c]).sqrt()),
            z,
            systematic,
        }
    }

    /// The band of channel `c`.
    pub fn band(&self, c: usize) -> f64 {
        self.z * self.se[c] + self.systematic * self.reference[c].abs()
    }

    /// The band of channel `c` relative to the reference's mean: the
    /// smallest uniform bias this test is sure to see is about this plus
    /// the noise's share of it.
    pub fn relative_band(&self, c: usize) -> f64 {
        self.band(c) / self.reference[c].abs()
    }

    /// The channels that fail with our image multiplied by `scale` (1 for
    /// the test itself; `1.01` asks whether a 1 % bias would be seen).
    pub fn failing_channels(&self, scale: f64) -> Vec<usize> {
        (0..3)
            .filter(|&c| (scale * self.ours[c] - self.reference[c]).abs() > self.band(c))
            .collect()
    }

    /// One line per channel for `--nocapture`.
    pub fn report(&self, name: &str) -> String {
        (0..3)
            .map(|c| {
                let d = self.ours[c] - self.reference[c];
                format!(
                    "{name} channel {c}: ours {:.6}, reference {:.6}, difference {:+.4} % ({:+.2} se), band {:.4} % of the mean",
                    self.ours[c],
                    self.reference[c],
                    100.0 * d / self.reference[c],
                    d / self.se[c],
                    100.0 * self.relative_band(c)
                )
            })
            .collect::<Vec<_>>()
            .join("\n")
    }
}

/// Every backend compiled in, built over `scene`.
pub fn backends(scene: &Scene) -> Vec<(Backend, Box<dyn Accelerator>)> {
    Backend::available()
        .into_iter()
        .map(|b| {
            (
                b,
                accel::build(b, scene.soup(), AccelOptions::default()).unwrap(),
            )
        })
        .collect()
}

/// A 1 x 1 render of `scene` with independent samples on the default
/// backend: the pixel's mean and the variance of that mean, per channel,
/// after checking that no sample was non-finite.
pub fn one_pixel(
    scene: &Scene,
    settings: embertrace::settings::IntegratorSettings,
    spp: u32,
    seed: u64,
) -> (Vec3, Vec3) {
    let acc = accel::build(
        Backend::default_backend(),
        scene.soup(),
        AccelOptions::default(),
    )
    .unwrap();
    let tracer = embertrace::integrator::PathTracer::new(scene, acc.as_ref(), settings);
    let rs = embertrace::render::RenderSettings {
        total_spp: None,
        resolution: [1, 1],
        spp,
        first_sample: 0,
        seed,
        threads: 0,
        tile_size: 8,
        sampler: embertrace::sampler::SamplerKind::Independent,
        clamp: None,
    };
    let out = embertrace::render::render(&tracer, &scene.make_camera(1, 1), &rs, &|| {}).unwrap();
    assert_eq!(out.nonfinite.count, 0);
    (out.film.mean(0, 0), out.film.variance_of_mean(0, 0))
}

/// Write each `(name, text)` of `files` under `dir`, making folders.
pub fn setup(dir: &Path, files: &[(&str, String)]) {
    for (name, text) in files {
        let p = dir.join(name);
        std::fs::create_dir_all(p.parent().unwrap()).unwrap();
        std::fs::write(p, text).unwrap();
    }
}

/// The embertrace binary run in `dir` with `args`.
pub fn run(dir: &Path, args: &[&str]) -> std::process::Output {
    std::process::Command::new(env!("CARGO_BIN_EXE_embertrace"))
        .current_dir(dir)
        .args(args)
        .output()
        .expect("embertrace runs")
}

/// The render `args` run in `dir` with `-o two.exr --checkpoint ck.exr
/// --checkpoint-every 0.05`, stopped by SIGINT as soon as `ck.exr` exists:
/// its output. Panics if the render ends first or writes no checkpoint in
/// 300 s.
pub fn interrupted_after_first_checkpoint(dir: &Path, args: &[&str]) -> std::process::Output {
    let mut child = std::process::Command::new(env!("CARGO_BIN_EXE_embertrace"))
        .current_dir(dir)
        .args(args)
        .args([
            "-o",
            "two.exr",
            "--checkpoint",
            "ck.exr",
            "--checkpoint-every",
            "0.05",
        ])
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    // within a bound far above any checkpoint interval asked for (a loaded
    // machine only makes the wait longer)
    let start = std::time::Instant::now();
    while !dir.join("ck.exr").exists() {
        if let Some(status) = child.try_wait().unwrap() {
            panic!("the render ended ({status}) before its first checkpoint");
        }
        if start.elapsed().as_secs() > 300 {
            child.kill().unwrap();
            panic!("no checkpoint after 300 s");
        }
        std::thread::sleep(std::time::Duration::from_millis(5));
    }
    // the shell's built-in kill: no procps needed on a bare machine
    let sent = std::process::Command::new("sh")
        .args(["-c", &format!("kill -INT {}", child.id())])
        .status()
        .unwrap();
    assert!(sent.success());
    child.wait_with_output().unwrap()
}

/// The embertrace binary run in the repository's root with `args`.
pub fn run_here(args: &[&str]) -> std::process::Output {
    run(Path::new(env!("CARGO_MANIFEST_DIR")), args)
}

/// A command's standard error, as text.
pub fn stderr_of(o: &std::process::Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// One triangle, as an OBJ file.
pub const GOOD_OBJ: &str = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";

/// The entries of folder `dir`, sorted.
pub fn entries(dir: &Path) -> Vec<std::path::PathBuf> {
    let mut v: Vec<std::path::PathBuf> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    v.sort();
    v
}

/// Render `scene` through the binary at `spp` samples and `w` x `h` pixels
/// to `out` (an EXR in `dir`); its pixels, RGB, top row first.
pub fn render_exr(dir: &Path, scene: &Path, out: &str, spp: u32, [w, h]: [u32; 2]) -> Vec<f32> {
    let out = dir.join(out);
    let (spp, w, h) = (spp.to_string(), w.to_string(), h.to_string());
    let o = run(
        dir,
        &[
            "render",
            scene.to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
            "--spp",
            &spp,
            "-r",
            &w,
            &h,
        ],
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    embertrace::image::read_exr(&out).unwrap().2
}
