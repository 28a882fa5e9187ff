//! Progressive rendering on the bundled Cornell box: passes give the bits of
//! one run, the time limit and the target error are honoured, adaptive
//! sampling sends samples where the variance is, and the CLI's convergence
//! log and sample map are produced and consistent.

use embertrace::accel::{self, AccelOptions, Backend};
use embertrace::camera::Camera;
use embertrace::film::Film;
use embertrace::integrator::PathTracer;
use embertrace::progressive::{
    Adaptive, Budget, PassRecord, ProgressiveOutput, StopReason, relative_error, render_progressive,
};
use embertrace::render::{RenderSettings, render};
use embertrace::sampler::SamplerKind;
use embertrace::scene::Scene;
use embertrace::settings::IntegratorSettings;
use std::path::Path;
use std::process::Command;

fn cornell() -> Scene {
    Scene::load(Path::new(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/scenes/cornell-box.toml"
    )))
    .unwrap()
}

fn settings(res: u32, spp: u32, seed: u64, sampler: SamplerKind) -> RenderSettings {
    RenderSettings {
        total_spp: None,
        resolution: [res, res],
        spp,
        first_sample: 0,
        seed,
        threads: 0,
        tile_size: 8,
        sampler,
        clamp: None,
    }
}

/// Run `f` with the default path tracer and camera for `scene` at `rs`.
fn with_tracer<R>(
    scene: &Scene,
    rs: &RenderSettings,
    f: impl FnOnce(&PathTracer<'_>, &Camera) -> R,
) -> R {
    let backend = Backend::default_backend();
    let acc = accel::build(backend, scene.soup(), AccelOptions::default()).unwrap();
    let tracer = PathTracer::new(scene, acc.as_ref(), IntegratorSettings::default());
    f(
        &tracer,
        &Camera::new(&scene.camera, rs.resolution[0], rs.resolution[1]),
    )
}

fn progressive(scene: &Scene, rs: &RenderSettings, budget: Budget) -> ProgressiveOutput {
    with_tracer(scene, rs, |t, c| {
        render_progressive(t, c, rs, &budget, None, &mut |_, _| Ok(())).unwrap()
    })
}

fn one_run(scene: &Scene, rs: &RenderSettings) -> Film {
    with_tracer(scene, rs, |t, c| render(t, c, rs, &|| {}).unwrap().film)
}

/// The root mean square of an image's values.
fn rms(v: &[f32]) -> f64 {
    (v.iter().map(|&x| (x as f64).powi(2)).sum::<f64>() / v.len() as f64).sqrt()
}

#[test]
fn passes_give_the_bits_of_one_run() {
    let scene = cornell();
    for sampler in [SamplerKind::Independent, SamplerKind::Sobol] {
        // a log of passes doubles: 1, 2, 4, 8 and then the 5 left = 13 spp
        let rs = settings(24, 13, 3, sampler);
        let budget = Budget {
            max_spp: 13,
            time_limit: Some(1e9),
            ..Budget::default()
        };
        let p = progressive(&scene, &rs, budget);
        let spp: Vec<u32> = p.passes.iter().map(|r| r.spp).collect();
        assert_eq!(spp, [1, 2, 4, 8, 13], "{sampler}");
        assert_eq!(p.stop, StopReason::Spp);
        let a = p.out.film.to_rgb_f32();
        let b = one_run(&scene, &rs).to_rgb_f32();
        assert!(
            a.iter().zip(&b).all(|(x, y)| x.to_bits() == y.to_bits()),
            "{sampler}: passes differ from one run"
        );
        assert_eq!(p.out.nonfinite.count, 0);
    }
}

/// The time-limit rule, checked on the renderer's own records rather than
/// against a clock of the test's: how long a pass takes depends on what
/// else loads the machine, so no wall-clock bound is asserted. What the
/// renderer decides from its clock is checked: it stops after the first
/// pass whose record reaches the limit, never before, and it sizes every
/// pass after the first from the time per sample measured so far, so that
/// the pass's samples (the counted work) fit in a tenth of the limit and in
/// the time left, or are a single sample per pixel.
#[test]
fn time_limit_stops_after_the_pass_that_reaches_it() {
    let scene = cornell();
    let limit = 0.5;
    let res = 64;
    let p = progressive(
        &scene,
        &settings(res, 1 << 20, 1, SamplerKind::Independent),
        Budget {
            max_spp: 1 << 20,
            time_limit: Some(limit),
            ..Budget::default()
        },
    );
    assert_eq!(p.stop, StopReason::TimeLimit);
    if let Some(e) = time_limit_violation(&p.passes, limit, u64::from(res * res)) {
        panic!("{e}");
    }
    // the image holds exactly the samples the records count
    let last = p.passes.last().unwrap();
    assert_eq!(last.samples, u64::from(last.spp) * u64::from(res * res));
    for y in 0..res {
        for x in 0..res {
            assert_eq!(p.out.film.count(x, y), u64::from(last.spp));
        }
    }
}

/// The first break of the time-limit rule of [`render_progressive`] in its
/// records (`pixels` sampled in every pass), if any: every pass but the
/// last ended before the limit and the last at or after it; pass `k + 1`
/// has at most as many samples per pixel as the passes before it
/// (doubling), and at most
/// `ceil(min(limit - t_k, limit / 10) / (t_k / samples_k * pixels))`, one
/// at least, with `t_k` and `samples_k` the record of pass `k`. The
/// renderer reads its clock after writing that record, so its own bound is
/// this one or smaller.
fn time_limit_violation(passes: &[PassRecord], limit: f64, pixels: u64) -> Option<String> {
    let (last, before) = passes.split_last()?;
    if last.seconds < limit {
        return Some(format!("stopped before the limit: {passes:?}"));
    }
    if let Some(r) = before.iter().find(|r| r.seconds >= limit) {
        return Some(format!("went on after pass {}: {passes:?}", r.pass));
    }
    passes.windows(2).find_map(|w| {
        let (prev, next) = (&w[0], &w[1]);
        let n = next.spp - prev.spp;
        let per_sample = prev.seconds / prev.samples as f64;
        let pass_time = (limit - prev.seconds).min(0.1 * limit);
        let fit = (pass_time / (per_sample * pixels as f64)).ceil().max(1.0);
        (n < 1 || n > prev.spp || n as f64 > fit).then(|| {
            format!(
                "pass {} adds {n} spp after {} spp in {:.4} s: at most {fit} fit ({passes:?})",
                next.pass, prev.spp, prev.seconds
            )
        })
    })
}

/// The check above rejects schedules that break the rule: a pass that
/// ignores the measured time (plain doubling), and a render that stops
/// before the limit or goes on after it.
#[test]
fn the_time_limit_check_rejects_a_schedule_that_ignores_the_clock() {
    let pixels = 64 * 64;
    // 7.5 ms per sample per pixel: with a 0.5 s limit, passes of at most
    // 7 spp (a tenth of the limit) once the clock has a measurement, and 3
    // when 20 ms are left
    let record = |pass: u32, spp: u32, seconds: f64| PassRecord {
        pass,
        seconds,
        spp,
        samples: u64::from(spp) * pixels,
        rays: 0,
        relative_error: 1.0,
        active_pixels: pixels,
    };
    let rate = 7.5e-3;
    let sized: Vec<PassRecord> = [1u32, 2, 4, 8, 15, 22, 29, 36, 43, 50, 57, 64, 67]
        .iter()
        .enumerate()
        .map(|(k, &spp)| record(k as u32 + 1, spp, rate * spp as f64))
        .collect();
    assert_eq!(time_limit_violation(&sized, 0.5, pixels), None);
    let doubling: Vec<PassRecord> = (0..8)
        .map(|k| record(k + 1, 1 << k, rate * f64::from(1u32 << k)))
        .collect();
    let caught = |passes: Vec<PassRecord>| time_limit_violation(&passes, 0.5, pixels).is_some();
    assert!(caught(doubling), "plain doubling passed");
    assert!(
        caught(sized[..12].to_vec()),
        "a stop before the limit passed"
    );
    let mut after = sized.clone();
    after.push(record(14, 72, 0.6));
    assert!(caught(after), "a pass after the limit passed");
}

#[test]
fn target_error_is_met_when_reported() {
    let scene = cornell();
    let target = 0.1;
    let rs = settings(32, 1 << 20, 1, SamplerKind::Independent);
    let p = progressive(
        &scene,
        &rs,
        Budget {
            max_spp: 1 << 20,
            target_error: Some(target),
            ..Budget::default()
        },
    );
    assert_eq!(p.stop, StopReason::TargetError);
    let estimate = p.passes.last().unwrap().relative_error;
    assert!(estimate <= target && estimate == relative_error(&p.out.film));
    // The actual relative RMS error against a reference of 16 times the
    // samples (other seed): the estimate is a 95 % bound on it. The
    // reference's own error adds about 1/4 of the image's in quadrature.
    let spp = p.passes.last().unwrap().spp;
    let reference = one_run(
        &scene,
        &settings(32, 16 * spp, 99, SamplerKind::Independent),
    );
    let (a, r) = (p.out.film.to_rgb_f32(), reference.to_rgb_f32());
    let diff: Vec<f32> = a.iter().zip(&r).map(|(x, y)| x - y).collect();
    let actual = rms(&diff) / rms(&r);
    assert!(
        actual <= target,
        "actual relative error {actual} above the reported {estimate} (target {target}) at {spp} spp"
    );
}

#[test]
fn adaptive_sampling_spends_samples_where_variance_is_high() {
    let scene = cornell();
    let rs = settings(32, 512, 1, SamplerKind::Independent);
    let p = progressive(
        &scene,
        &rs,
        Budget {
            max_spp: 512,
            adaptive: Some(Adaptive {
                batch: 16,
                tolerance: 0.1,
            }),
            ..Budget::default()
        },
    );
    let counts = &p.pixel_samples;
    assert!(
        counts
            .iter()
            .all(|&c| (16..=512).contains(&c) && c % 16 == 0)
    );
    assert!(counts.contains(&16) && counts.iter().any(|&c| c > 64));
    // rank pixels by relative noise measured in a separate uniform render
    let uniform = one_run(&scene, &settings(32, 64, 7, SamplerKind::Independent));
    let mut noise: Vec<(f64, u32)> = (0..32u32 * 32)
        .map(|i| {
            let px = uniform.pixel(i % 32, i / 32);
            let m: f64 = px.mean_f64().iter().sum();
            let v: f64 = px.variance_of_mean_f64().iter().sum();
            (v.sqrt() / m.max(1e-6), counts[i as usize])
        })
        .collect();
    noise.sort_by(|a, b| a.0.total_cmp(&b.0));
    let tenth = noise.len() / 10;
    let mean = |s: &[(f64, u32)]| s.iter().map(|x| x.1 as f64).sum::<f64>() / s.len() as f64;
    let (quiet, noisy) = (mean(&noise[..tenth]), mean(&noise[noise.len() - tenth..]));
    assert!(
        noisy > 3.0 * quiet,
        "noisiest tenth got {noisy} spp on average, quietest {quiet}"
    );
}

#[test]
fn cli_writes_a_consistent_convergence_log_and_sample_map() {
    let dir = tempfile::tempdir().unwrap();
    let scene = concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/cornell-box.toml");
    let run = |args: &[&str]| {
        Command::new(env!("CARGO_BIN_EXE_embertrace"))
            .current_dir(dir.path())
            .args(args)
            .output()
            .unwrap()
    };
    let ok = |o: std::process::Output| {
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    };
    ok(run(&[
        "render", scene, "-r", "16", "16", "-s", "64", "--seed", "9", "-o", "ref.exr", "-q",
    ]));
    ok(run(&[
        "render",
        scene,
        "-r",
        "16",
        "16",
        "-s",
        "16",
        "--reference",
        "ref.exr",
        "--convergence",
        "conv.csv",
        "-o",
        "out.exr",
        "--report",
        "r.json",
        "-q",
    ]));
    let csv = std::fs::read_to_string(dir.path().join("conv.csv")).unwrap();
    let mut lines = csv.lines();
    assert_eq!(
        lines.next(),
        Some("pass,seconds,spp,samples,rays,rmse,rel_mse,relative_error")
    );
    let rows: Vec<Vec<f64>> = lines
        .map(|l| l.split(',').map(|x| x.parse().unwrap()).collect())
        .collect();
    let spp: Vec<f64> = rows.iter().map(|r| r[2]).collect();
    assert_eq!(spp, [1.0, 2.0, 4.0, 8.0, 16.0]);
    for w in rows.windows(2) {
        assert!(
            w[1][1] >= w[0][1] && w[1][4] > w[0][4],
            "time and rays grow: {w:?}"
        );
    }
    // the last row is the written image against the reference
    let diff = run(&["diff", "out.exr", "ref.exr"]);
    let text = String::from_utf8_lossy(&diff.stdout).to_string();
    let last = rows.last().unwrap();
    assert!(
        text.contains(&format!("rmse       {:.6e}", last[5])),
        "{text} vs {last:?}"
    );
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join("r.json")).unwrap()).unwrap();
    assert_eq!(report["progressive"]["passes"], 5);
    assert_eq!(report["progressive"]["relative_error"]["confidence"], 0.95);

    ok(run(&[
        "render",
        scene,
        "-r",
        "16",
        "16",
        "-s",
        "64",
        "-a",
        "8",
        "0.2",
        "--sample-map",
        "rate.png",
        "-o",
        "a.png",
        "-q",
    ]));
    let map = image::open(dir.path().join("rate.png")).unwrap();
    assert_eq!((map.width(), map.height()), (16, 16));
    // bad combinations fail before rendering and leave nothing
    for args in [
        &["render", scene, "--convergence", "c.csv", "-o", "b.png"][..],
        &["render", scene, "-a", "1", "0.1", "-o", "b.png"][..],
        &["render", scene, "--time-limit", "0", "-o", "b.png"][..],
        &["render", scene, "--sample-map", "m.png", "-o", "b.png"][..],
    ] {
        let o = run(args);
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(
            !o.status.success() && err.lines().count() == 1,
            "{args:?}: {err}"
        );
        assert!(!dir.path().join("b.png").exists() && !dir.path().join("c.csv").exists());
    }
}
