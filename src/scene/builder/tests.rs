//! The builder's placement, rebasing and framing.

use super::*;

fn triangle(name: &str) -> MeshData {
    MeshData {
        name: name.to_string(),
        positions: vec![DVec3::ZERO, DVec3::X, DVec3::Y],
        indices: vec![[0, 1, 2]],
        tri_material: vec![0],
        materials: vec![Material::default()],
        ..MeshData::default()
    }
}

#[test]
fn a_mesh_listed_past_the_triangle_limit_is_refused_at_its_line() {
    let mut b = SceneBuilder::new(Path::new("s.toml"));
    b.max_triangles = 3;
    for line in 1..=3 {
        b.add_mesh_from(triangle("t.obj"), &Transform::default(), Some(line))
            .unwrap();
    }
    let e = b
        .add_mesh_from(triangle("t.obj"), &Transform::default(), Some(4))
        .unwrap_err()
        .to_string();
    assert_eq!(
        e,
        "s.toml:4: mesh `t.obj` (1 triangles) would take the scene to 4 triangles (at most 3)"
    );
    assert_eq!(b.triangle_count(), 3, "nothing added on refusal");
    assert_eq!(b.build().meshes.len(), 3);
}

#[test]
fn inconsistent_meshes_are_refused_not_indexed() {
    let mut bad_index = triangle("a");
    bad_index.indices[0][2] = 3;
    let mut bad_material = triangle("b");
    bad_material.tri_material[0] = 1;
    let mut short_materials = triangle("c");
    short_materials.tri_material.clear();
    for mesh in [bad_index, bad_material, short_materials] {
        let mut b = SceneBuilder::new(Path::new("s.toml"));
        let name = mesh.name.clone();
        let e = b.add_mesh_from(mesh, &Transform::default(), Some(2));
        let e = e.unwrap_err().to_string();
        assert!(e.starts_with(&format!("s.toml:2: mesh `{name}`")), "{e}");
        assert_eq!(b.triangle_count(), 0);
    }
}

#[test]
fn out_of_range_and_degenerate_triangles_are_reported_apart() {
    let mut b = SceneBuilder::new(Path::new("s.toml"));
    let mut mesh = triangle("m");
    // a degenerate triangle (repeated corner) next to the good one
    mesh.indices.push([0, 1, 1]);
    mesh.tri_material.push(0);
    b.add_mesh(mesh, &Transform::default());
    // corners at exactly MAX_COORDINATE are inside the range
    let far = Transform {
        scale: DVec3::splat(MAX_COORDINATE as f64),
        ..Transform::default()
    };
    b.add_mesh(triangle("edge"), &far);
    let beyond = Transform {
        translate: DVec3::new(0.0, -2.0 * MAX_COORDINATE as f64, 0.0),
        ..Transform::default()
    };
    b.add_mesh(triangle("beyond"), &beyond);
    b.set_camera(WorldCamera {
        origin: DVec3::new(0.0, 0.0, 5.0),
        target: DVec3::ZERO,
        up: Vec3::Y,
        fov_y: 40.0,
    });
    let s = b.build();
    assert_eq!(s.triangle_count(), 2);
    assert_eq!(
        s.warnings,
        [
            "s.toml: mesh `beyond`: dropped 1 triangles with coordinates beyond 1.8e18 or non-finite after transform",
            // nothing in this test scene emits
            "s.toml: nothing emits light (no emitting surface, point, directional or environment light): the image will be black"
        ]
    );
    assert_eq!(
        s.notes,
        ["s.toml: mesh `m`: dropped 1 degenerate (zero-area) triangles"]
    );
}

fn camera_at(origin: DVec3, target: DVec3) -> WorldCamera {
    WorldCamera {
        origin,
        target,
        up: Vec3::Y,
        fov_y: 40.0,
    }
}

#[test]
fn scenes_are_rebased_only_when_the_camera_is_far_from_the_origin() {
    // the Cornell box's own camera: nothing moves
    let near = camera_at(DVec3::new(0.0, 1.0, 3.9), DVec3::new(0.0, 1.0, 0.0));
    assert_eq!(render_origin(&near), DVec3::ZERO);
    // the same view at scale 1e-3, 1e4 away: rebased to the camera's
    // position on a power-of-two grid about 8 times the view distance
    let o = DVec3::splat(1e4);
    let far = camera_at(o + 1e-3 * near.origin, o + 1e-3 * near.target);
    let r = render_origin(&far);
    let step = 1.0 / 32.0;
    assert!((r - far.origin).abs().max_element() <= step / 2.0, "{r}");
    assert_eq!(r % step, DVec3::ZERO, "{r} is on the grid");
    // a degenerate view keeps the world as it is
    assert_eq!(render_origin(&camera_at(o, o)), DVec3::ZERO);
    // a unit view distance a rounding error either side of 1 (a Mitsuba
    // `to_world` camera) gives the same grid
    for l in [1.0 - 1e-7, 1.0, 1.0 + 1e-7] {
        let c = camera_at(DVec3::new(0.0, 2.2, 5.0), DVec3::new(0.0, 2.2, 5.0 - l));
        assert_eq!(render_origin(&c), DVec3::new(0.0, 0.0, 8.0), "{l}");
    }
}

#[test]
fn a_rebased_scene_keeps_its_precision_and_its_shape() {
    let o = DVec3::new(1e6, -1e6, 1e6);
    let mut b = SceneBuilder::new(Path::new("s.toml"));
    let mut mesh = triangle("t");
    let s = 1e-4;
    mesh.positions = vec![o, o + DVec3::new(s, 0.0, 0.0), o + DVec3::new(0.0, s, 0.0)];
    b.add_mesh(mesh, &Transform::default());
    b.add_point_light(
        o + DVec3::new(0.0, 0.0, s),
        PointLight::new(Vec3::ZERO, Vec3::ONE),
    );
    b.set_camera(camera_at(o + DVec3::new(0.0, 0.0, 4.0 * s), o));
    let scene = b.build();
    // in f32 at 1e6 the triangle would have collapsed (ulp 0.0625)
    assert_eq!(scene.triangle_count(), 1, "{:?}", scene.notes);
    let [p0, p1, p2] = scene.triangle(0);
    let back = |p: Vec3| p.as_dvec3() + scene.world_origin;
    for (p, want) in [(p0, o), (p1, o + DVec3::X * s), (p2, o + DVec3::Y * s)] {
        assert!((back(p) - want).length() < 1e-6 * s, "{p} -> {}", back(p));
    }
    let light = scene.point_lights[0].position;
    assert!((back(light) - (o + DVec3::Z * s)).length() < 1e-6 * s);
    let cam = scene.camera.origin;
    assert!((back(cam) - (o + DVec3::Z * 4.0 * s)).length() < 1e-6 * s);
}

#[test]
fn a_flat_mesh_is_framed_face_on() {
    let floor = WorldCamera::framing(DVec3::new(-1.0, 0.0, -1.0), DVec3::new(1.0, 0.0, 1.0));
    assert_eq!(floor.target, DVec3::ZERO);
    assert!(floor.origin.y > 0.0 && floor.origin.x == 0.0 && floor.origin.z == 0.0);
    let wall = WorldCamera::framing(DVec3::new(0.0, -1.0, -1.0), DVec3::new(0.0, 1.0, 1.0));
    assert!(wall.origin.x > 0.0 && wall.origin.y == 0.0);
    let boxy = WorldCamera::framing(-DVec3::ONE, DVec3::ONE);
    assert!(boxy.origin.z > 0.0 && boxy.origin.x == 0.0 && boxy.origin.y == 0.0);
}
