//! Embree-side guards (issue 4 item 6): triangles that leave Embree's
//! coordinate range only once placed by a transform are dropped by the
//! loader, with a note naming the mesh and the count, so no backend ever
//! sees them; coordinates just inside the range are kept.

use embertrace::accel::{self, AccelOptions, Backend};
use embertrace::math::{Ray, Vec3};
use embertrace::scene::{MAX_COORDINATE, Scene};

const QUAD: &str = "v -1 -1 0\nv 1 -1 0\nv 1 1 0\nv -1 1 0\nf 1 2 3\nf 1 3 4\n";

fn scene(scale: f32) -> Scene {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("q.obj"), QUAD).unwrap();
    let toml = format!(
        "[camera]\norigin = [0.0, 0.0, 5.0]\ntarget = [0.0, 0.0, 0.0]\nfov_y = 40.0\n\
         [[mesh]]\nfile = \"q.obj\"\n\
         [[mesh]]\nfile = \"q.obj\"\ntransform = {{ scale = {scale:e}, translate = [0.0, 0.0, -1.0] }}\n"
    );
    std::fs::write(dir.path().join("s.toml"), toml).unwrap();
    Scene::load(&dir.path().join("s.toml")).unwrap()
}

#[test]
fn triangles_beyond_embrees_range_are_dropped_with_a_note() {
    // 2e18 > MAX_COORDINATE: the second quad's corners are out of range
    let s = scene(2e18);
    assert_eq!(s.triangle_count(), 2, "only the unit quad remains");
    let note = s.notes.iter().find(|n| n.contains("dropped 2 triangles"));
    let note = note.unwrap_or_else(|| panic!("no note in {:?}", s.notes));
    assert!(
        note.contains("mesh") && note.contains("q.obj") && note.contains("1.8e18"),
        "{note}"
    );
    // every backend: rays past the unit quad meet nothing
    let ray = Ray::new(Vec3::new(3.0, 3.0, 5.0), -Vec3::Z);
    for b in Backend::available() {
        let acc = accel::build(b, s.soup(), AccelOptions::default()).unwrap();
        assert!(acc.intersect(&ray).is_none(), "{b} hit a dropped triangle");
        let centre = Ray::new(Vec3::new(0.1, 0.2, 5.0), -Vec3::Z);
        assert!(
            acc.intersect(&centre)
                .is_some_and(|h| (h.t - 5.0).abs() < 1e-5),
            "{b}"
        );
    }
    // within the range, the big quad stays and is hit by every backend
    let s = scene(0.5 * MAX_COORDINATE);
    assert_eq!(s.triangle_count(), 4, "{:?}", s.notes);
    for b in Backend::available() {
        let acc = accel::build(b, s.soup(), AccelOptions::default()).unwrap();
        assert!(acc.intersect(&ray).is_some(), "{b} missed the big quad");
    }
}
