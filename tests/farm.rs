//! Farm rendering (issue 20): shards, crops, checkpoints and merges give the
//! one-process render's image bit for bit, in any order; merges refuse parts
//! that do not belong together, with one line, exit 1 and no output file.

mod common;

use embertrace::farm::{self, Shard};
use embertrace::image::read_exr;
use std::path::Path;
use std::process::{Command, Output};

const SCENE: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/cornell-box.toml");

/// A 30 x 22 image: neither side a multiple of the 4 x 4 blocks or the
/// tiles, so crops and edges cut blocks.
const RES: [&str; 2] = ["30", "22"];

fn run(dir: &Path, args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_embertrace"))
        .current_dir(dir)
        .args(args)
        .output()
        .expect("run embertrace")
}

fn ok(dir: &Path, args: &[&str]) {
    let out = run(dir, args);
    assert!(
        out.status.success(),
        "embertrace {args:?} failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
}

/// Render `extra` flags on top of the common settings.
fn render(dir: &Path, out: &str, extra: &[&str]) {
    let mut args = vec![
        "render", SCENE, "-q", "-r", RES[0], RES[1], "-s", "10", "-m", "6", "-o", out,
    ];
    args.extend_from_slice(extra);
    ok(dir, &args);
}

fn pixels(path: &Path) -> Vec<u32> {
    read_exr(path)
        .unwrap()
        .2
        .iter()
        .map(|v| v.to_bits())
        .collect()
}

/// Merge `parts` into `out` and return the image's bits.
fn merged(dir: &Path, parts: &[&str], out: &str) -> Vec<u32> {
    let mut args = vec!["merge"];
    args.extend_from_slice(parts);
    args.extend_from_slice(&["-o", out]);
    ok(dir, &args);
    pixels(&dir.join(out))
}

#[test]
fn shards_merge_to_the_one_process_image_in_any_order() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    render(d, "full.exr", &[]);
    let full = pixels(&d.join("full.exr"));
    // 10 spp in 4 shards: 2, 3, 2, 3 samples
    for k in 1..=4 {
        render(d, &format!("s{k}.exr"), &["--shard", &format!("{k}/4")]);
    }
    assert_eq!(
        merged(d, &["s1.exr", "s2.exr", "s3.exr", "s4.exr"], "a.exr"),
        full
    );
    assert_eq!(
        merged(d, &["s4.exr", "s2.exr", "s1.exr", "s3.exr"], "b.exr"),
        full
    );
    // PNG too: the same bytes as the one-process PNG
    render(d, "full.png", &[]);
    ok(
        d,
        &[
            "merge", "s3.exr", "s1.exr", "s4.exr", "s2.exr", "-o", "m.png",
        ],
    );
    assert_eq!(
        std::fs::read(d.join("m.png")).unwrap(),
        std::fs::read(d.join("full.png")).unwrap()
    );
    // and a merge of merges: two partial accumulation files, then the image
    // not a box: samples 0..2 and 5..7 leave a hole between
    let hole = run(
        d,
        &["merge", "s1.exr", "s3.exr", "-o", "h.exr", "--accumulation"],
    );
    assert!(!hole.status.success());
    assert!(!d.join("h.exr").exists());
    ok(
        d,
        &[
            "merge",
            "s1.exr",
            "s2.exr",
            "-o",
            "p12.exr",
            "--accumulation",
        ],
    );
    ok(
        d,
        &[
            "merge",
            "s3.exr",
            "s4.exr",
            "-o",
            "p34.exr",
            "--accumulation",
        ],
    );
    assert_eq!(merged(d, &["p34.exr", "p12.exr"], "c.exr"), full);
    // an accumulation file is an image: its R, G, B are the means so far
    assert_eq!(pixels(&d.join("p34.exr")).len(), full.len());
}

#[test]
fn crops_and_shards_of_crops_merge_to_the_one_process_image() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    render(d, "full.exr", &[]);
    let full = pixels(&d.join("full.exr"));
    // windows that cut blocks and tiles: x at 13, y at 7
    render(d, "c1.exr", &["--crop", "0", "0", "13", "7"]);
    render(d, "c2.exr", &["--crop", "13", "0", "30", "7"]);
    render(
        d,
        "c3a.exr",
        &["--crop", "0", "7", "30", "22", "--shard", "1/2"],
    );
    render(
        d,
        "c3b.exr",
        &["--crop", "0", "7", "30", "22", "--shard", "2/2"],
    );
    let parts = ["c3b.exr", "c1.exr", "c3a.exr", "c2.exr"];
    assert_eq!(merged(d, &parts, "m.exr"), full);
    // a crop's file places its pixels in the image (data window offset)
    let (w, h, _) = read_exr(&d.join("c2.exr")).unwrap();
    assert_eq!((w, h), (17, 7));
}

#[test]
fn variance_of_merged_shards_equals_the_one_process_variance() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    render(d, "full.exr", &["--variance", "v.exr"]);
    render(d, "s1.exr", &["--shard", "1/2"]);
    render(d, "s2.exr", &["--shard", "2/2"]);
    ok(
        d,
        &[
            "merge",
            "s2.exr",
            "s1.exr",
            "-o",
            "m.exr",
            "--variance",
            "mv.exr",
        ],
    );
    let (v, mv) = (pixels(&d.join("v.exr")), pixels(&d.join("mv.exr")));
    assert_eq!(v, mv);
    // a variance image of a noisy render is not all zeros
    assert!(v.iter().any(|&b| f32::from_bits(b) > 0.0));
}

/// Assert that `merge parts -o out.png` fails with one line containing
/// every `expect`ed text, exit 1, and writes nothing.
fn refused(dir: &Path, parts: &[&str], expect: &[&str]) {
    let mut args = vec!["merge"];
    args.extend_from_slice(parts);
    args.extend_from_slice(&["-o", "out.png"]);
    let out = run(dir, &args);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{parts:?}: {err}");
    assert_eq!(err.trim_end().lines().count(), 1, "one line: {err}");
    for e in expect {
        assert!(err.contains(e), "{parts:?}: expected `{e}` in: {err}");
    }
    assert!(!dir.join("out.png").exists(), "{parts:?} left an image");
}

#[test]
fn merge_refuses_parts_that_do_not_belong_together() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    render(d, "s1.exr", &["--shard", "1/2"]);
    render(d, "s2.exr", &["--shard", "2/2"]);
    render(d, "seed.exr", &["--shard", "2/2", "--seed", "7"]);
    render(d, "depth.exr", &["--shard", "2/2", "-l", "2"]);
    render(d, "plain.exr", &[]);
    // the same scene under another name and folder merges; a changed
    // camera does not: the hash is of the scene, not of its name
    let scene = std::fs::read_to_string(SCENE).unwrap();
    for f in ["cornell-box.obj", "cornell-box.mtl"] {
        std::fs::copy(Path::new(SCENE).with_file_name(f), d.join(f)).unwrap();
    }
    std::fs::write(d.join("same.toml"), &scene).unwrap();
    let wider = scene.replace("fov_y  = 39.3", "fov_y  = 40.0");
    assert_ne!(wider, scene);
    std::fs::write(d.join("wider.toml"), wider).unwrap();
    for (toml, out) in [("same.toml", "same.exr"), ("wider.toml", "wider.exr")] {
        ok(
            d,
            &[
                "render", toml, "-q", "-r", RES[0], RES[1], "-s", "10", "-m", "6", "--shard",
                "2/2", "-o", out,
            ],
        );
    }
    ok(d, &["merge", "s1.exr", "same.exr", "-o", "same.png"]);
    refused(
        d,
        &["s1.exr", "wider.exr"],
        &["wider.exr", "different scene"],
    );
    refused(d, &["s1.exr", "seed.exr"], &["seed.exr", "seed = 7, not 0"]);
    refused(d, &["depth.exr", "s1.exr"], &["s1.exr", "light_samples"]);
    refused(d, &["s1.exr", "s2.exr", "s1.exr"], &["overlaps", "s1.exr"]);
    refused(
        d,
        &["s2.exr"],
        &["do not cover", "sample 0 of pixel (0, 0)"],
    );
    // a plain render is not an accumulation file; a missing file is named
    refused(
        d,
        &["s1.exr", "plain.exr"],
        &["plain.exr", "not an embertrace accumulation file"],
    );
    refused(d, &["s1.exr", "s2.exr", "nope.exr"], &["nope.exr"]);
}

#[test]
fn a_checkpointed_render_stopped_by_sigint_resumes_to_the_same_bits() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let common = ["render", SCENE, "-q", "-r", "32", "32", "-m", "6"];
    // a render that no machine finishes (2^24 samples of 1024 pixels): the
    // interrupt always comes first, however many cores there are
    let mut args: Vec<&str> = common.to_vec();
    args.extend_from_slice(&["-s", "16777216"]);
    let out = common::interrupted_after_first_checkpoint(d, &args);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(130), "{err}");
    assert!(
        err.contains("interrupted") && err.contains("--resume ck.exr"),
        "{err}"
    );
    assert!(!d.join("two.exr").exists(), "no partial image");
    let (_, prov) = farm::read_accumulation(&d.join("ck.exr")).unwrap();
    assert_eq!(prov.samples.start, 0);
    // resume to a total past what was saved (the default sampler's points
    // do not depend on the total): the bits of one uninterrupted render
    let total = (prov.samples.end + 7).to_string();
    let mut one: Vec<&str> = common.to_vec();
    one.extend_from_slice(&["-s", &total, "-o", "one.exr"]);
    ok(d, &one);
    let mut resume: Vec<&str> = common.to_vec();
    resume.extend_from_slice(&["-s", &total, "-o", "two.exr", "--resume", "ck.exr"]);
    ok(d, &resume);
    assert_eq!(pixels(&d.join("two.exr")), pixels(&d.join("one.exr")));
    // the checkpoint now holds every sample
    let n: u32 = total.parse().unwrap();
    let (_, prov) = farm::read_accumulation(&d.join("ck.exr")).unwrap();
    assert_eq!(prov.samples, 0..n);
    // with a checkpoint, -o .exr is the state too: merge takes it alone
    let (_, prov) = farm::read_accumulation(&d.join("two.exr")).unwrap();
    assert_eq!(prov.samples, 0..n);
    assert_eq!(
        merged(d, &["two.exr"], "three.exr"),
        pixels(&d.join("one.exr"))
    );
}

#[test]
fn resume_refuses_another_scene_setting_or_spp_the_sampler_depends_on() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    render(d, "a.png", &["--checkpoint", "ck.exr"]);
    let resume = |extra: &[&str]| {
        let mut args = vec![
            "render", SCENE, "-q", "-r", RES[0], RES[1], "-m", "6", "-o", "b.png", "--resume",
            "ck.exr",
        ];
        args.extend_from_slice(extra);
        run(d, &args)
    };
    let out = resume(&["-s", "10", "--seed", "3"]);
    assert!(String::from_utf8_lossy(&out.stderr).contains("seed"));
    assert!(!d.join("b.png").exists());
    // zsobol's Morton layout for 10 spp spans 16 samples a pixel: resuming
    // to 12 is fine, to 20 not
    render(
        d,
        "z.png",
        &["--checkpoint", "zk.exr", "--sampler", "zsobol"],
    );
    let zresume = |spp: &str| {
        run(
            d,
            &[
                "render",
                SCENE,
                "-q",
                "-r",
                RES[0],
                RES[1],
                "-m",
                "6",
                "-o",
                "zb.png",
                "--resume",
                "zk.exr",
                "--sampler",
                "zsobol",
                "-s",
                spp,
            ],
        )
    };
    let out = zresume("20");
    assert_eq!(out.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&out.stderr).contains("spp = 10, not 20"));
    assert!(!d.join("zb.png").exists());
    assert!(zresume("12").status.success());
    // the default sampler's points do not depend on the total: any larger
    // spp resumes
    assert!(resume(&["-s", "20"]).status.success());
}

/// Render the scene at default flags but for its size (the default sampler),
/// with `extra`.
fn at_default_flags(d: &Path, extra: &[&str]) {
    let mut a = vec!["render", SCENE, "-q", "-r", RES[0], RES[1]];
    a.extend_from_slice(extra);
    ok(d, &a);
}

#[test]
fn sample_ranges_rendered_at_different_totals_merge_to_the_one_run_bits() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let with = |extra: &[&str]| at_default_flags(d, extra);
    // samples 0..16 first, as a finished 16-spp render; 16..64 later, as
    // three shards of a 64-spp render
    with(&["-s", "16", "--checkpoint", "early.exr", "-o", "early.png"]);
    for k in 2..=4 {
        let shard = format!("{k}/4");
        let out = format!("late{k}.exr");
        with(&["-s", "64", "--shard", &shard, "-o", &out]);
    }
    with(&["-s", "64", "-o", "one.exr"]);
    let parts = ["late3.exr", "early.exr", "late4.exr", "late2.exr"];
    assert_eq!(merged(d, &parts, "all.exr"), pixels(&d.join("one.exr")));
    let (_, prov) = farm::read_accumulation(&d.join("early.exr")).unwrap();
    assert_eq!(prov.spp(), Some(16));
    // without the late shards, the 16-spp render is whole by itself; with
    // two of three, samples 48..64 are missing from the 64-spp render
    let out = run(
        d,
        &[
            "merge",
            "early.exr",
            "late2.exr",
            "late3.exr",
            "-o",
            "x.exr",
        ],
    );
    assert_eq!(out.status.code(), Some(1));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("no part holds sample 48"), "{err}");
    // zsobol's points depend on the total: its parts do not merge across
    // totals
    with(&[
        "-s",
        "16",
        "--sampler",
        "zsobol",
        "--checkpoint",
        "z16.exr",
        "-o",
        "z.png",
    ]);
    with(&[
        "-s",
        "64",
        "--sampler",
        "zsobol",
        "--shard",
        "2/4",
        "-o",
        "z64.exr",
    ]);
    let out = run(d, &["merge", "z16.exr", "z64.exr", "-o", "zz.exr"]);
    assert_eq!(out.status.code(), Some(1));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("spp = 64, not 16"), "{err}");
}

#[test]
fn a_finished_16_spp_render_resumes_to_64_with_the_bits_of_one_64_spp_run() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let with = |extra: &[&str]| at_default_flags(d, extra);
    with(&["-s", "16", "--checkpoint", "ck.exr", "-o", "sixteen.exr"]);
    with(&["-s", "64", "--resume", "ck.exr", "-o", "resumed.exr"]);
    with(&["-s", "64", "-o", "one.exr"]);
    assert_eq!(pixels(&d.join("resumed.exr")), pixels(&d.join("one.exr")));
    // a 16-spp render's samples are the 64-spp render's first 16 (its
    // first shard of four), sum for sum
    with(&["-s", "64", "--shard", "1/4", "-o", "first.exr"]);
    with(&["-s", "16", "--checkpoint", "ck16.exr", "-o", "again.exr"]);
    let (first, prov) = farm::read_accumulation(&d.join("first.exr")).unwrap();
    assert_eq!(prov.samples, 0..16);
    let (sixteen, _) = farm::read_accumulation(&d.join("ck16.exr")).unwrap();
    let sums = |f: &embertrace::film::Film| f.pixels().iter().map(|p| p.sum).collect::<Vec<_>>();
    assert_eq!(sums(&first), sums(&sixteen));
}

#[test]
fn shards_tile_the_samples() {
    for spp in [1, 2, 7, 10, 64, 1000] {
        for n in [1, 2, 3, 4, 7, 64] {
            let mut next = 0;
            for k in 1..=n {
                let r = Shard { k, n }.samples(spp);
                assert_eq!(r.start, next, "{k}/{n} of {spp}");
                assert!(r.end >= r.start);
                next = r.end;
            }
            assert_eq!(next, spp);
        }
    }
    assert!(Shard::parse("0/4").is_err());
    assert!(Shard::parse("5/4").is_err());
    assert!(Shard::parse("a/4").is_err());
    assert_eq!(Shard::parse("2/4"), Ok(Shard { k: 2, n: 4 }));
    assert!(farm::crop_window([0, 0, 0, 4], [8, 8]).is_err());
    assert!(farm::crop_window([0, 0, 9, 4], [8, 8]).is_err());
    assert!(farm::crop_window([0, 0, 8, 8], [8, 8]).is_ok());
}

/// Parts record the source digest of the build that rendered them
/// (`embertrace --version` prints it): a part from a build of other source
/// does not merge or resume, with both builds named, unless
/// `--allow-mixed-builds` says the pixels agree.
#[test]
fn parts_from_another_build_are_refused_unless_allowed() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    render(d, "s1.exr", &["--shard", "1/2"]);
    render(d, "s2.exr", &["--shard", "2/2"]);
    let (film, mut prov) = farm::read_accumulation(&d.join("s2.exr")).unwrap();
    assert_eq!(prov.build, embertrace::build_info::SOURCE_DIGEST);
    let version = run(d, &["--version"]);
    let version = String::from_utf8_lossy(&version.stdout).into_owned();
    assert!(version.contains(&prov.build), "{version}");
    prov.build = "0123456789abcdef".into();
    farm::write_accumulation(&d.join("other.exr"), &film, &prov).unwrap();
    refused(
        d,
        &["s1.exr", "other.exr"],
        &[
            "other.exr",
            "0123456789abcdef",
            &prov.version,
            "--allow-mixed-builds",
        ],
    );
    ok(
        d,
        &[
            "merge",
            "s1.exr",
            "other.exr",
            "-o",
            "mixed.exr",
            "--allow-mixed-builds",
        ],
    );
    let mixed = pixels(&d.join("mixed.exr"));
    assert_eq!(mixed, merged(d, &["s1.exr", "s2.exr"], "same.exr"));
    // a checkpoint from the other build does not resume either
    std::fs::copy(d.join("other.exr"), d.join("resume.exr")).unwrap();
    let args = [
        "render",
        SCENE,
        "-q",
        "-r",
        RES[0],
        RES[1],
        "-s",
        "10",
        "-m",
        "6",
        "--shard",
        "2/2",
        "-o",
        "r.exr",
        "--resume",
        "resume.exr",
    ];
    let out = run(d, &args);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(
        err.contains("0123456789abcdef") && err.contains("--allow-mixed-builds"),
        "{err}"
    );
}
