//! Issue 39 item 5: the CS184 course's thin-lens flags, `-b` (lens radius)
//! and `-d` (focal distance), with the course's meaning: the plane in
//! focus lies `-d` along the view, and a missing `-d` is the course's 4.7
//! for a `.dae`; on any other scene a missing `-d` keeps the scene's focus
//! (the point looked at, for a TOML camera without one). Checked bit for
//! bit against the renders they must equal, and the lens is checked to
//! change the image beyond the noise.

use std::path::{Path, PathBuf};
use std::process::Command;

const BIN: &str = env!("CARGO_BIN_EXE_embertrace");

fn course_box() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/collada/course_box.dae")
}

/// The pixels of `scene` rendered at 48 x 36 with `flags` (16 spp unless
/// they say).
fn render(dir: &Path, scene: &Path, flags: &[&str]) -> Vec<f32> {
    let out = dir.join("o.exr");
    let spp: &[&str] = if flags.contains(&"-s") {
        &[]
    } else {
        &["-s", "16"]
    };
    let o = Command::new(BIN)
        .arg(scene)
        .args(spp)
        .args(["-r", "48", "36", "-m", "3", "-q", "-f"])
        .arg(&out)
        .args(flags)
        .output()
        .unwrap();
    assert!(
        o.status.success(),
        "{flags:?}: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    embertrace::image::read_exr(&out).unwrap().2
}

fn bits(v: &[f32]) -> Vec<u32> {
    v.iter().map(|x| x.to_bits()).collect()
}

/// Root mean square difference of two images.
fn rms(a: &[f32], b: &[f32]) -> f64 {
    let sum: f64 = a.iter().zip(b).map(|(x, y)| ((x - y) as f64).powi(2)).sum();
    (sum / a.len() as f64).sqrt()
}

#[test]
fn the_course_lens_flags_take_the_courses_meaning() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let scene = course_box();
    let pinhole = render(d, &scene, &[]);
    // a zero radius is the pinhole, to the bit
    assert_eq!(bits(&render(d, &scene, &["-b", "0"])), bits(&pinhole));
    // without -d, the course's focal distance 4.7
    let lens = render(d, &scene, &["-b", "0.3"]);
    assert_eq!(
        bits(&render(d, &scene, &["-b", "0.3", "-d", "4.7"])),
        bits(&lens)
    );
    assert_ne!(bits(&lens), bits(&pinhole));
    // a wide lens focused far in front of the box (its walls are 1.5
    // diagonals away) changes the image far beyond the noise: its distance
    // to the pinhole image against two pinhole renders' distance (measured
    // 0.250 against 0.027; the lens's optics are camera.rs's tests)
    let blurred = render(d, &scene, &["-b", "0.4", "-d", "0.5", "-s", "64"]);
    let sharp = render(d, &scene, &["-s", "64"]);
    let again = render(d, &scene, &["-s", "64", "--seed", "1"]);
    let (change, noise) = (rms(&blurred, &sharp), rms(&again, &sharp));
    assert!(change > 3.0 * noise, "{change} against the noise {noise}");
    // the long forms are the same flags
    assert_eq!(
        bits(&render(
            d,
            &scene,
            &["--lens-radius", "0.3", "--focal-distance", "4.7"]
        )),
        bits(&lens)
    );
}

#[test]
fn on_a_toml_scene_the_flags_replace_the_lens_and_keep_its_focus() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let toml = |lens: &str| {
        format!(
            "[camera]\norigin = [0, 1, 3.5]\ntarget = [0, 0.5, 0]\nfov_y = 40\n{lens}\n\
             [[sphere]]\ncenter = [0, 0.5, 0]\nradius = 0.5\nmaterial = {{ diffuse = 0.6 }}\n\n\
             [[sphere]]\ncenter = [0.8, 0.3, -1.5]\nradius = 0.3\nmaterial = {{ diffuse = 0.3 }}\n\n\
             [[light]]\ntype = \"environment\"\nradiance = 1.0\n"
        )
    };
    let write = |name: &str, lens: &str| {
        let p = d.join(name);
        std::fs::write(&p, toml(lens)).unwrap();
        p
    };
    let plain = write("plain.toml", "");
    let with_lens = write("lens.toml", "aperture_radius = 0.1\n");
    let far = write("far.toml", "aperture_radius = 0.1\nfocus_distance = 6.0\n");
    // -b alone: focused on the point looked at, as the TOML default is
    assert_eq!(
        bits(&render(d, &plain, &["-b", "0.1"])),
        bits(&render(d, &with_lens, &[]))
    );
    // -d alone keeps the scene's aperture
    assert_eq!(
        bits(&render(d, &with_lens, &["-d", "6"])),
        bits(&render(d, &far, &[]))
    );
    // -b replaces the scene's aperture and keeps its focus distance
    assert_eq!(
        bits(&render(d, &far, &["-b", "0"])),
        bits(&render(d, &plain, &[]))
    );

    // bad values: one line naming the flag, exit 1, no image
    for (flag, value) in [("-b", "-1"), ("-d", "0"), ("-d", "nan")] {
        let out = d.join("bad.png");
        let o = Command::new(BIN)
            .arg(&plain)
            .args([flag, value, "-q", "-f"])
            .arg(&out)
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(1), "{err}");
        assert_eq!(err.trim().lines().count(), 1, "{err}");
        assert!(err.contains(flag) && !err.contains("panicked"), "{err}");
        assert!(!out.exists());
    }
}
