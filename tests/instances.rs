//! Instancing: one prototype mesh placed by many affine maps.
//!
//! - Every backend answers rays on instanced scenes: the BVH's two-level
//!   search equals the naive backend's scan bit for bit (closest hit and
//!   occlusion); Embree, which maps rays into object space with its own
//!   inverse, agrees on hit or miss, on the placement and the triangle, and
//!   on `t` to a relative `1e-4`.
//! - A placed copy and an instance of the same mesh by the same map answer
//!   the same rays (up to that rounding).
//! - The self-intersection policy holds on instances: rays leaving a convex
//!   prototype's surface outwards never find it again, inwards always find
//!   its far side, under rotations, uneven scales, a mirror, a tiny scale and
//!   a far translation, in every backend.
//! - Memory grows with the placements by their transforms, not by the mesh.
//! - The TOML keys: errors name the file and line.

mod common;

use common::backends;
use embertrace::accel::{self, AccelOptions, Backend, Coherence, Hit};
use embertrace::math::{DVec3, Ray, Vec3, spawn_ray};
use embertrace::sampler::Sampler;
use embertrace::sampling::square_to_uniform_sphere;
use embertrace::scene::procedural::{Shape, generate};
use embertrace::scene::{Material, MeshData, Scene, SceneBuilder, WorldCamera};
use glam::{DAffine3, DQuat};
use std::path::Path;

/// A sphere of about `triangles` triangles, radius 1 (convex when not
/// displaced).
fn rock(triangles: u64, displacement: f32) -> MeshData {
    generate(
        Shape::Sphere,
        triangles,
        displacement,
        5,
        "rock",
        Material::default(),
    )
}

/// The maps the tests place with: plain, turned and unevenly scaled,
/// mirrored, tiny, small and far from the origin (the way into object space
/// then rounds at 1e4 times its size), and far from the origin (kept last).
fn maps() -> Vec<DAffine3> {
    vec![
        DAffine3::from_scale_rotation_translation(
            DVec3::splat(1e-2),
            DQuat::from_rotation_z(0.4),
            DVec3::new(100.0, 30.0, 60.0),
        ),
        DAffine3::from_translation(DVec3::new(-3.0, 0.0, 0.0)),
        DAffine3::from_scale_rotation_translation(
            DVec3::new(2.0, 0.5, 1.0),
            DQuat::from_axis_angle(DVec3::new(1.0, 1.0, 0.0).normalize(), 0.7),
            DVec3::new(3.0, 0.5, 0.0),
        ),
        DAffine3::from_scale_rotation_translation(
            DVec3::new(-1.0, 1.0, 1.0),
            DQuat::from_rotation_y(0.3),
            DVec3::new(0.0, 0.0, -3.0),
        ),
        DAffine3::from_scale_rotation_translation(
            DVec3::splat(1e-3),
            DQuat::IDENTITY,
            DVec3::new(0.0, 3.0, 0.0),
        ),
        DAffine3::from_translation(DVec3::new(1.0e4, -2.0e4, 5.0e3)),
    ]
}

/// A scene of `mesh` placed by each of `maps`, as instances or as copies.
fn scene_of(mesh: &MeshData, maps: &[DAffine3], instanced: bool) -> Scene {
    let mut b = SceneBuilder::new(Path::new("instances.toml"));
    if instanced {
        let p = b.add_prototype(mesh.clone(), None).unwrap();
        for m in maps {
            b.add_instance(p, *m, None, None).unwrap();
        }
    } else {
        for m in maps {
            b.add_mesh_matrix(mesh.clone(), *m, None).unwrap();
        }
    }
    // the camera at the origin keeps render space = world space
    b.set_camera(WorldCamera {
        origin: DVec3::ZERO,
        target: DVec3::new(0.0, 0.0, -1.0),
        up: Vec3::Y,
        fov_y: 40.0,
    });
    b.build()
}

/// Rays at each map's placement: from 3 units out (in object space) towards
/// points within its unit ball, mapped to world space, plus a few from the
/// origin.
fn rays(maps: &[DAffine3], per_map: usize) -> Vec<Ray> {
    let mut s = Sampler::new(99, 0, 0);
    let mut out = Vec::new();
    for m in maps {
        for _ in 0..per_map {
            let from = m.transform_point3(3.0 * square_to_uniform_sphere(s.next_2d()).as_dvec3());
            let to = m.transform_point3(
                0.9 * s.next_1d() as f64 * square_to_uniform_sphere(s.next_2d()).as_dvec3(),
            );
            let d = (to - from).normalize().as_vec3();
            out.push(Ray::new(from.as_vec3(), d));
        }
    }
    out
}

/// The placement index and prototype triangle of a hit on `scene`.
fn where_hit(scene: &Scene, h: &Hit) -> (usize, u32) {
    scene
        .instanced(h.prim)
        .expect("every triangle is instanced")
}

#[test]
fn backends_agree_on_instanced_rays() {
    let maps = maps();
    let scene = scene_of(&rock(2000, 0.2), &maps, true);
    assert_eq!(scene.instances.placements.len(), maps.len());
    let rays = rays(&maps, 400);
    let all = backends(&scene);
    let naive = &all.iter().find(|(b, _)| *b == Backend::Naive).unwrap().1;
    let (mut hits, mut embree_off) = (0, 0);
    for ray in &rays {
        let want = naive.intersect(ray);
        let occluded = naive.occluded(ray);
        assert_eq!(
            occluded,
            want.is_some(),
            "naive disagrees with itself on {ray:?}"
        );
        hits += usize::from(want.is_some());
        for (b, acc) in &all {
            let got = acc.intersect(ray);
            match b {
                // not in `available()`: its single rays are the brute force's
                Backend::Naive | Backend::EmbreeNaive => {}
                Backend::Bvh => {
                    assert_eq!(got, want, "bvh on {ray:?}");
                    assert_eq!(acc.occluded(ray), occluded, "bvh occlusion on {ray:?}");
                }
                Backend::Embree => {
                    let same = match (got, want) {
                        (None, None) => true,
                        (Some(g), Some(w)) => {
                            // Embree's own f32 inverse rounds the way into
                            // object space at the ray origin's magnitude
                            let tol = 1e-4 * w.t + 8.0 * f32::EPSILON * ray.o.abs().max_element();
                            where_hit(&scene, &g).0 == where_hit(&scene, &w).0
                                && (g.t - w.t).abs() <= tol
                        }
                        _ => false,
                    };
                    embree_off += usize::from(!same);
                    assert_eq!(acc.occluded(ray), got.is_some(), "embree occlusion");
                }
            }
        }
    }
    assert!(
        hits > rays.len() / 2,
        "only {hits} of {} rays hit",
        rays.len()
    );
    // the brute force's batches (one dispatch for the triangles, then the
    // placements) answer as its single rays, bit for bit, a NaN ray too
    let mut batch = rays.clone();
    batch[3].o.x = f32::NAN;
    for chunk in batch.chunks(16) {
        let mut got = [None; 16];
        naive.intersect_batch(chunk, &mut got[..chunk.len()], Coherence::Incoherent);
        for (ray, g) in chunk.iter().zip(got) {
            let bits = |h: Option<Hit>| h.map(|h| (h.prim, [h.t, h.u, h.v].map(f32::to_bits)));
            assert_eq!(
                bits(g),
                bits(naive.intersect(ray)),
                "naive batch on {ray:?}"
            );
        }
    }
    // grazing rays may go either way across a silhouette edge
    assert!(
        embree_off * 1000 <= rays.len(),
        "embree differs from the oracle on {embree_off} of {} rays",
        rays.len()
    );
}

#[test]
fn a_copy_and_an_instance_answer_the_same_rays() {
    // not the far map: a copy there has f32 world corners, moved by up to
    // 2e-3 (an ulp at 2e4), which the instance's object-space corners are
    // not
    let mut maps = maps();
    maps.pop();
    let mesh = rock(2000, 0.2);
    let copies = scene_of(&mesh, &maps, false);
    let instances = scene_of(&mesh, &maps, true);
    let n = copies.triangle_count() / maps.len();
    assert_eq!(
        copies.triangle_count(),
        n * maps.len(),
        "no triangle dropped"
    );
    let corners = &instances.instances.prototypes[0].indices;
    // triangles sharing an edge: where the copies' rounding may send a ray
    // near that edge to the other one
    let neighbours = |a: u32, b: u32| {
        let (a, b) = (corners[a as usize], corners[b as usize]);
        a.iter().filter(|i| b.contains(i)).count() >= 2
    };
    let rays = rays(&maps, 400);
    for backend in Backend::available() {
        let a = accel::build(backend, copies.soup(), AccelOptions::default()).unwrap();
        let b = accel::build(backend, instances.soup(), AccelOptions::default()).unwrap();
        let mut flips = 0;
        for ray in &rays {
            match (a.intersect(ray), b.intersect(ray)) {
                (None, None) => {}
                (Some(x), Some(y)) => {
                    let (k, t) = where_hit(&instances, &y);
                    let (copy, tri) = (x.prim as usize / n, x.prim % n as u32);
                    assert_eq!(copy, k, "{backend}: another placement on {ray:?}");
                    assert!(
                        tri == t || neighbours(tri, t),
                        "{backend}: triangle {tri} of the copy, {t} of the instance on {ray:?}"
                    );
                    // plus a few ulps of the copies' world corners
                    let tol = 1e-4 * x.t + 8.0 * f32::EPSILON * ray.o.abs().max_element();
                    assert!(
                        (x.t - y.t).abs() <= tol,
                        "{backend}: t {} against {} on {ray:?}",
                        x.t,
                        y.t
                    );
                }
                _ => flips += 1,
            }
        }
        // a ray grazing the silhouette may hit one and miss the other
        assert!(
            flips * 1000 <= rays.len(),
            "{backend}: hit and miss differ on {flips} of {} rays",
            rays.len()
        );
    }
}

#[test]
fn rays_leaving_an_instance_never_find_it_again() {
    // a convex prototype: outward rays cannot meet it, inward ones must
    let maps = maps();
    let scene = scene_of(&rock(800, 0.0), &maps, true);
    let inst = &scene.instances;
    let per = inst.prototypes[0].indices.len() as u32;
    let mut s = Sampler::new(17, 0, 0);
    for (backend, acc) in backends(&scene) {
        for (k, (m, placement)) in maps.iter().zip(&inst.placements).enumerate() {
            let centre = m.transform_point3(DVec3::ZERO).as_vec3();
            for _ in 0..300 {
                let t = (s.next_1d() * per as f32) as u32 % per;
                let (u, v) = {
                    let (a, b) = (s.next_1d(), s.next_1d());
                    if a + b > 1.0 {
                        (1.0 - a, 1.0 - b)
                    } else {
                        (a, b)
                    }
                };
                let prim = placement.first_prim + t;
                let sp = scene.surface_point(prim, u, v);
                assert!(
                    sp.n.dot(sp.p - centre) > 0.0,
                    "placement {k}: the front normal points outwards"
                );
                let d = square_to_uniform_sphere(s.next_2d());
                let out = if d.dot(sp.n) > 0.0 { d } else { -d };
                if let Some(h) = acc.intersect(&spawn_ray(&sp, out)) {
                    assert!(
                        scene.instanced(h.prim).map(|x| x.0) != Some(k),
                        "{backend}, placement {k}: an outward ray met its own surface at t = {}",
                        h.t
                    );
                }
                let hit = acc.intersect(&spawn_ray(&sp, -out));
                let h = hit.unwrap_or_else(|| {
                    panic!("{backend}, placement {k}: an inward ray left the closed surface")
                });
                assert_eq!(scene.instanced(h.prim).map(|x| x.0), Some(k));
                assert_ne!(
                    h.prim, prim,
                    "{backend}, placement {k}: met its own triangle"
                );
            }
        }
    }
}

#[test]
fn memory_grows_by_the_placements_not_by_the_mesh() {
    let mesh = rock(20_000, 0.2);
    let grid = |n: usize| -> Vec<DAffine3> {
        (0..n)
            .map(|i| {
                DAffine3::from_scale_rotation_translation(
                    DVec3::splat(0.2),
                    DQuat::from_rotation_y(i as f64),
                    DVec3::new((i % 40) as f64, 0.0, (i / 40) as f64),
                )
            })
            .collect()
    };
    let (one, many) = (
        scene_of(&mesh, &grid(1), true),
        scene_of(&mesh, &grid(1000), true),
    );
    assert!(one.instances.triangle_count() >= 20_000);
    assert_eq!(
        many.instances.triangle_count(),
        1000 * one.instances.triangle_count()
    );
    for backend in Backend::available() {
        let build = |s: &Scene| accel::build(backend, s.soup(), AccelOptions::default()).unwrap();
        let (a, b) = (build(&one).memory_bytes(), build(&many).memory_bytes());
        println!("{backend}: one placement {a} bytes, 1000 placements {b} bytes");
        assert!(
            b as f64 <= 1.5 * a as f64 + 2.0e6,
            "{backend}: 1000 placements take {b} bytes against {a} for one"
        );
    }
}

/// The error loading `toml` (beside the Cornell box's OBJ) gives.
fn toml_error(toml: &str) -> String {
    let dir = tempfile::tempdir().unwrap();
    let obj = concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/cornell-box.obj");
    let path = dir.path().join("s.toml");
    std::fs::write(&path, toml.replace("OBJ", obj)).unwrap();
    let e = Scene::load(&path).expect_err("refused").to_string();
    e.replace(&path.display().to_string(), "s.toml")
}

#[test]
fn instance_keys_are_checked_at_their_line() {
    let mesh = "[[mesh]]\nfile = \"OBJ\"\nname = \"box\"\ninstance_only = true\n";
    for (toml, want) in [
        (
            format!("{mesh}[[instance]]\nof = \"boxes\"\n"),
            "s.toml:5: instance of unknown mesh `boxes` (named meshes: box)",
        ),
        (
            format!("{mesh}{mesh}"),
            "s.toml:5: a second mesh named `box` (first at line 1)",
        ),
        (
            "[[mesh]]\nfile = \"OBJ\"\ninstance_only = true\n".to_string(),
            "s.toml:1: `instance_only = true` needs a `name` for instances to place it by",
        ),
        (
            format!(
                "{mesh}[[instance]]\nof = \"box\"\ntransform = {{ scale = 2 }}\nmatrix = [1,0,0,0, 0,1,0,0, 0,0,1,0, 0,0,0,1]\n"
            ),
            "s.toml:5: an instance takes `transform` or `matrix`, not both",
        ),
        (
            format!(
                "{mesh}[[instance]]\nof = \"box\"\nmatrix = [1,0,0,0, 0,1,0,0, 0,0,1,0, 0,0,1,1]\n"
            ),
            "s.toml:5: matrix must be affine: its last row must be [0, 0, 0, 1], got [0.0, 0.0, 1.0, 1.0]",
        ),
        (
            format!(
                "{mesh}[[instance]]\nof = \"box\"\nmatrix = [1,0,0,0, 0,0,0,0, 0,0,1,0, 0,0,0,1]\n"
            ),
            "s.toml:5: instance of `box`: its transform is singular or not finite",
        ),
        (
            format!("{mesh}[[instance]]\nof = \"box\"\nmatrix = [1,0,0,0, 0,1,0,0, 0,0,1,0]\n"),
            "expected an array of 16 numbers, got 12",
        ),
    ] {
        let e = toml_error(&toml);
        assert!(e.contains(want), "{toml}\ngave: {e}\nwanted: {want}");
    }
}

#[test]
fn toml_instances_place_the_named_mesh_by_its_own_transform_then_theirs() {
    let dir = tempfile::tempdir().unwrap();
    let obj = concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/cornell-box.obj");
    let path = dir.path().join("s.toml");
    std::fs::write(
        &path,
        format!(
            "[[mesh]]\nfile = \"{obj}\"\nname = \"box\"\ntransform = {{ translate = [1, 0, 0] }}\n\
             [[mesh]]\nfile = \"{obj}\"\nname = \"unused\"\n\
             [[instance]]\nof = \"box\"\ntransform = {{ translate = [0, 0, 5] }}\n\
             [[instance]]\nof = \"box\"\nmatrix = [2,0,0,0, 0,2,0,0, 0,0,2,0, 0,0,0,1]\n\
             material = {{ diffuse = [0.1, 0.2, 0.3] }}\n"
        ),
    )
    .unwrap();
    let scene = Scene::load(&path).unwrap();
    let inst = &scene.instances;
    // the named mesh is placed by an instance of its own; the unused name
    // is a plain mesh
    assert_eq!(inst.prototypes.len(), 1);
    assert_eq!(inst.placements.len(), 3);
    assert_eq!(scene.meshes.len(), 1);
    let w: Vec<DVec3> = inst.world.iter().map(|m| m.translation).collect();
    assert_eq!(
        w,
        [
            DVec3::new(1.0, 0.0, 0.0),
            DVec3::new(1.0, 0.0, 5.0),
            DVec3::new(2.0, 0.0, 0.0)
        ]
    );
    assert_eq!(inst.world[2].matrix3.x_axis.x, 2.0);
    let over = inst.material[2] as usize;
    assert_eq!(
        scene.materials[over].albedo(),
        Some(Vec3::new(0.1, 0.2, 0.3))
    );
    let plan = embertrace::plan::Plan::new(&scene, &Default::default());
    assert!(plan.on().contains(&"instancing"));
    assert!(
        plan.kernel.shapes,
        "instances run the kernel with shape dispatch"
    );
}

#[test]
fn instanced_emitters_are_weighed_as_placed_copies_and_found_with_their_density() {
    // an emissive rock of 80 triangles placed three times, as instances and
    // as copies: each placement is chosen with the same probability (power
    // by area; the copies pair some triangles into quad lights, the
    // instances do not, so the lights themselves differ), and the density
    // `pdf_area` gives an instanced point found by a ray along a light
    // sample is the one the sample carried
    let mut mesh = rock(80, 0.0);
    for m in &mut mesh.materials {
        m.emission = Vec3::new(2.0, 1.0, 0.5);
    }
    let per = mesh.indices.len() as u32;
    let maps = &maps()[..3];
    let placed = scene_of(&mesh, maps, false);
    let instanced = scene_of(&mesh, maps, true);
    // selection by power for the weights (the light BVH's choice depends on
    // how the lights cluster, which the quads change); the default (the
    // BVH, from 64 lights) for the densities as well
    use embertrace::integrator::Lights;
    use embertrace::settings::LightSampler;
    let (lp, li) = (
        Lights::with_sampler(&placed, LightSampler::Power),
        Lights::with_sampler(&instanced, LightSampler::Power),
    );
    let li_bvh = Lights::new(&instanced);
    assert!(li_bvh.uses_bvh());
    assert_eq!(li.area_lights().len(), 3 * per as usize);
    let acc = accel::build(Backend::Bvh, instanced.soup(), AccelOptions::default()).unwrap();
    let mut s = Sampler::new(11, 0, 0);
    let mut found = 0;
    for _ in 0..300 {
        let from = embertrace::math::SurfacePoint {
            p: 0.5 * square_to_uniform_sphere(s.next_2d()),
            p_err: Vec3::ZERO,
            n: square_to_uniform_sphere(s.next_2d()),
        };
        // the probability of each placement
        let by_copy = |lights: &embertrace::integrator::Lights, copy: &dyn Fn(u32) -> usize| {
            let pmf = lights.selection_pmfs(&from);
            let mut sum = [0.0f64; 3];
            for (l, p) in lights.area_lights().iter().zip(&pmf) {
                sum[copy(l.prim)] += f64::from(*p);
            }
            sum
        };
        let a = by_copy(&lp, &|prim| (prim / per) as usize);
        let b = by_copy(&li, &|prim| instanced.instanced(prim).unwrap().0);
        for k in 0..3 {
            assert!(
                (a[k] - b[k]).abs() <= 1e-4 * a[k].max(b[k]),
                "copy {k}: {a:?} vs {b:?}"
            );
        }
        assert!((a.iter().sum::<f64>() - 1.0).abs() < 1e-5);
        // a light sample, found again, under either selection
        let (u_select, u) = (s.next_1d(), s.next_2d());
        for lights in [&li, &li_bvh] {
            let Some(ls) = lights.sample(&instanced, &from, u_select, u) else {
                continue;
            };
            let Some(h) = acc.intersect(&Ray::new(from.p, ls.wi)) else {
                continue;
            };
            let to = instanced.surface_point(h.prim, h.u, h.v);
            let pdf = lights.pdf_area(&from, h.prim, &to);
            assert!(pdf > 0.0, "an instanced emitter has density 0");
            // the ray finds the sampled point unless another triangle of
            // the rock lies in front of it
            if h.t >= 0.999 * ls.shadow.t_max {
                found += 1;
                assert!(
                    (pdf - ls.pdf).abs() <= 1e-3 * ls.pdf,
                    "pdf_area {pdf} against the sample's {}",
                    ls.pdf
                );
            }
        }
    }
    assert!(found > 200, "{found} sampled points found again");
}
