//! Embree-side guards (issue 4 item 6): triangles that leave Embree's
//! coordinate range (`MAX_COORDINATE`, 1.8e18) or become non-finite only once
//! placed by a transform are dropped by the loader, with one warning per mesh
//! that names the scene file, the mesh's line and the count, so no backend
//! ever sees them and all backends agree that they are never hit.
//! Coordinates just inside the range are kept. Coordinates out of range in a
//! file are a load error at their line (tests/cli.rs).

mod common;

use common::backends;
use embertrace::limits::MAX_COORDINATE;
use embertrace::math::{Ray, Vec3};
use embertrace::scene::Scene;

const QUAD: &str = "v -1 -1 0\nv 1 -1 0\nv 1 1 0\nv -1 1 0\nf 1 2 3\nf 1 3 4\n";

/// Load `toml` next to the unit quad `q.obj`, with a white environment
/// appended (a scene without light gets a warning of its own, which these
/// tests do not count).
fn load(toml: &str) -> Scene {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("q.obj"), QUAD).unwrap();
    let lit = format!("{toml}\n[[light]]\ntype = \"environment\"\nradiance = 1.0\n");
    std::fs::write(dir.path().join("s.toml"), lit).unwrap();
    Scene::load(&dir.path().join("s.toml")).unwrap()
}

const CAMERA: &str = "[camera]\norigin = [0.0, 0.0, 5.0]\ntarget = [0.0, 0.0, 0.0]\nfov_y = 40.0\n";

/// The unit quad at z = 0 (line 5), then the quad scaled by `scale` at
/// z = -1 (line 7).
fn two_quads(scale: f32) -> Scene {
    load(&format!(
        "{CAMERA}[[mesh]]\nfile = \"q.obj\"\n\
         [[mesh]]\nfile = \"q.obj\"\ntransform = {{ scale = {scale:e}, translate = [0.0, 0.0, -1.0] }}\n"
    ))
}

#[test]
fn triangles_beyond_embrees_range_are_dropped_with_one_warning() {
    // 2e18 > MAX_COORDINATE: the second quad's corners are out of range
    let s = two_quads(2e18);
    assert_eq!(s.triangle_count(), 2, "only the unit quad remains");
    assert_eq!(
        s.warnings.len(),
        1,
        "one warning per mesh: {:?}",
        s.warnings
    );
    let w = &s.warnings[0];
    assert!(
        w.ends_with(
            "s.toml:7: mesh `q.obj`: dropped 2 triangles with coordinates beyond 1.8e18 or non-finite after transform"
        ),
        "{w}"
    );
    // every backend: rays aimed where the big quad would be meet nothing;
    // the unit quad is still hit at its distance
    let past = Ray::new(Vec3::new(3.0, 3.0, 5.0), -Vec3::Z);
    let centre = Ray::new(Vec3::new(0.1, 0.2, 5.0), -Vec3::Z);
    for (b, acc) in backends(&s) {
        assert!(acc.intersect(&past).is_none(), "{b} hit a dropped triangle");
        assert!(!acc.occluded(&past), "{b}: a dropped triangle occludes");
        let hit = acc.intersect(&centre);
        // 1e-5: the hit distance is 5 up to the f32 rounding of the watertight test
        assert!(
            hit.is_some_and(|h| (h.t - 5.0).abs() < 1e-5),
            "{b}: {hit:?}"
        );
    }
    // within the range, the big quad stays and is hit by every backend
    let s = two_quads(0.5 * MAX_COORDINATE);
    assert_eq!(s.triangle_count(), 4, "{:?}", s.warnings);
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
    for (b, acc) in backends(&s) {
        assert!(acc.intersect(&past).is_some(), "{b} missed the big quad");
    }
}

#[test]
fn a_mesh_partly_out_of_range_keeps_the_rest() {
    // Scaled by 1e18 and turned 45 degrees about z, the quad's corner 2,
    // (1, -1), lands at x = 1.41e18 and corner 4 at x = -1.41e18, corners 1
    // and 3 at x = 0; moved by 5e17 in x, only corner 2 (1.91e18) is out of
    // range, so triangle (1, 2, 3) goes and (1, 3, 4) stays. The second quad,
    // stretched to x in [-3e17, 1.7e18], stays whole.
    let s = load(&format!(
        "{CAMERA}[[mesh]]\nfile = \"q.obj\"\ntransform = {{ scale = 1e18, rotate = [0.0, 0.0, 1.0, 45.0], translate = [5e17, 0.0, 0.0] }}\n\
         [[mesh]]\nfile = \"q.obj\"\ntransform = {{ scale = [1e18, 1.0, 1.0], translate = [7e17, 0.0, -1.0] }}\n"
    ));
    assert_eq!(s.triangle_count(), 3, "{:?}", s.warnings);
    assert_eq!(s.warnings.len(), 1, "{:?}", s.warnings);
    let w = &s.warnings[0];
    assert!(
        w.contains("s.toml:5: mesh `q.obj`: dropped 1 triangles"),
        "{w}"
    );
    assert_eq!(s.meshes[0].end - s.meshes[0].start, 1);
    assert_eq!(s.meshes[1].end - s.meshes[1].start, 2);
    // the kept triangle (1, 3, 4) is the one with corner 4 at x < 0
    let kept = s.triangle(s.meshes[0].start);
    assert!(kept.iter().any(|p| p.x < -5e17), "{kept:?}");
}

#[test]
fn procedural_meshes_pushed_out_of_range_are_dropped_in_every_backend() {
    // a terrain of 2 n^2 triangles over [-1, 1]^2, scaled by 1e19: every
    // triangle is out of range; a small sphere beside it stays
    let s = load(&format!(
        "{CAMERA}[[procedural]]\ntype = \"terrain\"\ntriangles = 50\ndisplacement = 0.0\n\
         transform = {{ scale = 1e19, rotate = [1.0, 0.0, 0.0, 90.0] }}\n\
         [[procedural]]\ntype = \"sphere\"\ntriangles = 100\ndisplacement = 0.0\n\
         transform = {{ scale = 0.5 }}\n"
    ));
    let terrain = &s.meshes[0];
    assert_eq!(terrain.start, terrain.end, "the whole terrain is dropped");
    assert_eq!(s.warnings.len(), 1, "{:?}", s.warnings);
    let w = &s.warnings[0];
    assert!(
        w.contains("s.toml:5: mesh `procedural terrain #0 (50 triangles)`: dropped 50 triangles"),
        "{w}"
    );
    // where the terrain would be (the plane z = 0, facing the camera), every
    // backend sees nothing but the sphere of radius 0.5
    for (b, acc) in backends(&s) {
        for (x, y) in [(0.9, 0.9), (-3.0, 2.0), (100.0, -40.0)] {
            let ray = Ray::new(Vec3::new(x, y, 5.0), -Vec3::Z);
            assert!(acc.intersect(&ray).is_none(), "{b} hit at ({x}, {y})");
        }
        let ray = Ray::new(Vec3::new(0.0, 0.0, 5.0), -Vec3::Z);
        assert!(acc.intersect(&ray).is_some(), "{b} missed the sphere");
    }
}

#[test]
fn non_finite_after_transform_is_dropped_too() {
    // 1e30 is finite as a scale, but 1e30 * 1 = 1e30 > 1.8e18 and the
    // rotation mixes 1e30 * cos and sin terms: coordinates out of range or,
    // for a scale of 3e38, infinite
    for scale in ["1e30", "3e38"] {
        let s = load(&format!(
            "{CAMERA}[[mesh]]\nfile = \"q.obj\"\ntransform = {{ scale = {scale}, rotate = [0.0, 0.0, 1.0, 45.0], translate = [3e38, 0.0, 0.0] }}\n"
        ));
        assert_eq!(s.triangle_count(), 0, "{scale}");
        assert_eq!(s.warnings.len(), 1, "{scale}: {:?}", s.warnings);
        assert!(s.warnings[0].contains("dropped 2 triangles"), "{scale}");
        for (b, acc) in backends(&s) {
            let ray = Ray::new(Vec3::new(0.0, 0.0, 5.0), -Vec3::Z);
            assert!(acc.intersect(&ray).is_none(), "{b}");
        }
    }
}
