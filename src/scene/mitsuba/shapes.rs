//! Shapes: `obj` and `ply` meshes, and the built-in `rectangle`, `cube`,
//! `disk` (tessellated) and `sphere` (analytic), with `to_world`,
//! `flip_normals`, `face_normals` and an `area` emitter inside; and
//! instancing: a `shapegroup` (its meshes, each placed by its own
//! `to_world`, stored once as one prototype) and `instance` (a `<ref>` to a
//! shapegroup and a `to_world`).

use super::Loader;
use super::params::Params;
use crate::error::{Result, one_line};
use crate::limits::MAX_COORDINATE;
use crate::math::{Vec2, Vec3};
use crate::scene::{Material, MeshData, SceneBuilder, load_obj_mesh, load_ply_mesh};
use glam::{DAffine3, DVec3, Mat3};
use roxmltree::Node;

/// What one `<shape>` adds.
pub(super) enum Geometry {
    /// A mesh in its own space and its `to_world`.
    Mesh(MeshData, DAffine3),
    /// An analytic sphere: world centre, radius, material.
    Sphere(DVec3, f32, Material, Mat3),
}

/// Triangles of a tessellated `disk`.
pub const DISK_SEGMENTS: usize = 256;

impl<'a, 'i> Loader<'a, 'i> {
    /// A shape's BSDF: a child `<bsdf>` or `<ref>`, or Mitsuba's default:
    /// a one-sided diffuse of reflectance 0.5, or 0 when the shape emits
    /// (Mitsuba's `Shape` constructor: an emitter's surface reflects
    /// nothing unless the file gives it a BSDF).
    fn shape_material(&mut self, p: &mut Params<'a, 'i>, emits: bool) -> Result<Material> {
        match p.unnamed_of("bsdf") {
            Some(node) => self.bsdf(node),
            None => {
                let (name, albedo) = if emits {
                    ("default-emitter", 0.0)
                } else {
                    ("default", 0.5)
                };
                Ok(Material {
                    one_sided: true,
                    ..Material::diffuse(name, Vec3::splat(albedo))
                })
            }
        }
    }

    pub(super) fn shape(&mut self, node: Node<'a, 'i>, b: &mut SceneBuilder) -> Result<()> {
        let line = Some(self.line(node));
        match self.need_attr(node, "type")?.as_str() {
            "shapegroup" => self.shapegroup(node, b),
            "instance" => self.instance(node, b),
            _ => match self.shape_geometry(node)? {
                Geometry::Mesh(mesh, m) => b.add_mesh_matrix(mesh, m, line),
                Geometry::Sphere(c, r, material, uv) => {
                    b.add_sphere_framed(c, r, material, uv, line)
                }
            },
        }
    }

    /// A `shapegroup`: its shapes (meshes only; a sphere inside is refused),
    /// each moved by its own `to_world`, merged into one prototype that
    /// `instance`s place by the group's `id`.
    fn shapegroup(&mut self, node: Node<'a, 'i>, b: &mut SceneBuilder) -> Result<()> {
        let id = self.need_attr(node, "id")?;
        if self.groups.contains_key(&id) {
            return Err(self.fail(
                node,
                format!("a second shapegroup with id `{}`", one_line(&id)),
            ));
        }
        let mut group = MeshData {
            name: id.clone(),
            ..MeshData::default()
        };
        for c in node.children().filter(|n| n.is_element()) {
            if c.tag_name().name() != "shape" {
                return Err(self.fail(
                    c,
                    format!(
                        "<{}> inside a shapegroup (expected <shape>)",
                        one_line(c.tag_name().name())
                    ),
                ));
            }
            let kind = self.need_attr(c, "type")?;
            if matches!(kind.as_str(), "shapegroup" | "instance") {
                return Err(self.fail(
                    c,
                    format!(
                        "a `{}` inside a shapegroup (one level of instancing)",
                        one_line(&kind)
                    ),
                ));
            }
            match self.shape_geometry(c)? {
                Geometry::Mesh(mut mesh, m) => {
                    mesh.transform_by(&m);
                    group.append(mesh);
                }
                Geometry::Sphere(..) => {
                    return Err(self.fail(
                        c,
                        "a sphere inside a shapegroup is not supported (instances hold meshes; place the sphere itself)",
                    ));
                }
            }
        }
        let prototype = b.add_prototype(group, Some(self.line(node)))?;
        self.groups.insert(id, prototype);
        Ok(())
    }

    /// An `instance`: the shapegroup its `<ref>` names, placed by its
    /// `to_world`.
    fn instance(&mut self, node: Node<'a, 'i>, b: &mut SceneBuilder) -> Result<()> {
        let refs: Vec<Node> = node
            .children()
            .filter(|n| n.is_element() && n.tag_name().name() == "ref")
            .collect();
        let [r] = refs[..] else {
            return Err(self.fail(
                node,
                "an instance needs exactly one <ref id=\"...\"/> naming a shapegroup",
            ));
        };
        let id = self.need_attr(r, "id")?;
        let Some(&prototype) = self.groups.get(&id) else {
            return Err(self.fail(
                r,
                format!(
                    "instance of `{}`, which is no shapegroup defined above",
                    one_line(&id)
                ),
            ));
        };
        let mut m = DAffine3::IDENTITY;
        for c in node.children().filter(|n| n.is_element()) {
            match (c.tag_name().name(), c.attribute("name")) {
                ("ref", _) => {}
                ("transform", Some("to_world")) => m = self.transform(c)?,
                (tag, _) => {
                    return Err(self.fail(
                        c,
                        format!(
                            "<{}> inside an instance (it takes a <ref> and a to_world <transform>)",
                            one_line(tag)
                        ),
                    ));
                }
            }
        }
        b.add_instance(prototype, m, None, Some(self.line(node)))
    }

    /// A shape's geometry: a mesh (as read, with its material) and its
    /// `to_world`, or an analytic sphere placed in world space.
    fn shape_geometry(&mut self, node: Node<'a, 'i>) -> Result<Geometry> {
        let kind = self.need_attr(node, "type")?;
        let at = self.line(node);
        let mut p = self.params(node)?;
        let emits = node.children().any(|c| c.has_tag_name("emitter"));
        let mut material = self.shape_material(&mut p, emits)?;
        if let Some(e) = p.unnamed_of("emitter") {
            let et = self.need_attr(e, "type")?;
            if et != "area" {
                return Err(self.fail(
                    e,
                    format!("emitter `{}` inside a shape (expected area)", one_line(&et)),
                ));
            }
            let mut ep = self.params(e)?;
            material.emission = ep.colour(self, "radiance")?.unwrap_or(Vec3::ONE);
            self.finish(ep);
        }
        let m = p.matrix("to_world").unwrap_or(DAffine3::IDENTITY);
        let flip = p.boolean("flip_normals").is_some_and(|v| v.0);
        let face_normals = p.boolean("face_normals").is_some_and(|v| v.0);
        let mut mesh = match kind.as_str() {
            "obj" | "ply" => {
                let file = p.text("filename").ok_or_else(|| {
                    self.fail(node, format!("shape `{kind}` needs a `filename` string"))
                })?;
                let full = self.dir.join(&file);
                if let Some(why) = crate::scene::not_a_file(&full) {
                    return Err(self.fail(node, format!("mesh file `{}` {why}", one_line(&file))));
                }
                let mut mesh = if kind == "obj" {
                    load_obj_mesh(&full)?
                } else {
                    load_ply_mesh(&full)?
                };
                mesh.materials.truncate(0);
                mesh.tri_material.iter_mut().for_each(|m| *m = 0);
                if face_normals {
                    mesh.normals.clear();
                } else if mesh.normals.is_empty() {
                    mesh.normals = mesh.vertex_normals();
                }
                mesh
            }
            "rectangle" => quad_mesh(&[
                [-1.0, -1.0, 0.0],
                [1.0, -1.0, 0.0],
                [1.0, 1.0, 0.0],
                [-1.0, 1.0, 0.0],
            ]),
            "cube" => cube_mesh(),
            "disk" => disk_mesh(),
            "sphere" => {
                let center = p.vector("center").unwrap_or(DVec3::ZERO);
                let radius = p.number("radius").map_or(1.0, |v| v.0) as f32;
                let (c, r) = self.sphere_placement(node, &m, center, radius)?;
                if flip {
                    self.warn(
                        node,
                        "flip_normals on a sphere is not supported (it emits outwards)",
                    );
                }
                self.finish(p);
                if !(r > 0.0 && (c.abs() + r as f64).max_element() <= MAX_COORDINATE as f64) {
                    return Err(self.fail(
                        node,
                        format!("sphere at {c} of radius {r}: the radius must be > 0 and the sphere within +-{MAX_COORDINATE:e}"),
                    ));
                }
                return Ok(Geometry::Sphere(c, r, material, sphere_uv_frame(&m)));
            }
            other => {
                return Err(self.fail(
                    node,
                    format!(
                        "shape `{}` is not in the subset (expected obj, ply, rectangle, cube, sphere, disk, shapegroup or instance)",
                        one_line(other)
                    ),
                ));
            }
        };
        self.finish(p);
        if kind != "obj" {
            // Mitsuba looks `v = 0` up at the image's top row and embertrace
            // at its bottom (the OBJ convention; Mitsuba's OBJ reader flips
            // `vt` itself, its PLY reader and built-in shapes do not)
            for t in &mut mesh.uvs {
                for uv in t {
                    uv.y = 1.0 - uv.y;
                }
            }
        }
        if flip {
            for t in &mut mesh.indices {
                t.swap(1, 2);
            }
            for t in &mut mesh.uvs {
                t.swap(1, 2);
            }
            for t in &mut mesh.normals {
                t.swap(1, 2);
            }
        }
        material.name = node
            .attribute("id")
            .map_or_else(|| format!("{kind} at line {at}"), str::to_string);
        if material.texture.is_some() && mesh.uvs.is_empty() {
            return Err(self.fail(
                node,
                format!("shape `{kind}` has a bitmap texture but no texture coordinates"),
            ));
        }
        mesh.name = material.name.clone();
        mesh.materials = vec![material];
        mesh.tri_material = vec![0; mesh.indices.len()];
        Ok(Geometry::Mesh(mesh, m))
    }

    /// A sphere's world centre and radius: `to_world` must be a similarity.
    fn sphere_placement(
        &self,
        node: Node,
        m: &DAffine3,
        center: DVec3,
        radius: f32,
    ) -> Result<(DVec3, f32)> {
        let cols = [m.matrix3.x_axis, m.matrix3.y_axis, m.matrix3.z_axis];
        let s = cols[0].length();
        let similar = cols.iter().all(|c| (c.length() - s).abs() <= 1e-5 * s)
            && cols[0].dot(cols[1]).abs() <= 1e-5 * s * s
            && cols[0].dot(cols[2]).abs() <= 1e-5 * s * s
            && cols[1].dot(cols[2]).abs() <= 1e-5 * s * s;
        if !similar {
            return Err(self.fail(
                node,
                "sphere to_world must scale uniformly (an ellipsoid is not a sphere)",
            ));
        }
        Ok((m.transform_point3(center), radius * s as f32))
    }
}

/// The texture frame of a Mitsuba sphere placed by the similarity `m`
/// ([`crate::scene::Scene::sphere_uv_frames`]): a world direction `n` goes
/// to the sphere's local frame by `R^T n` (`R` the rotation part of `m`),
/// where Mitsuba takes `u = atan2(y, x) / 2 pi` and `v = acos(z) / pi`
/// (`src/shapes/sphere.cpp`); `(x, z, -y)` then gives the same `u` and
/// `1 - v` under embertrace's mapping (pole `+y`, `u = atan2(-z, x) / 2 pi`,
/// `v = 1 - acos(y) / pi`): `1 - v` because Mitsuba looks `v = 0` up at an
/// image's top row and embertrace at its bottom, as for meshes above.
fn sphere_uv_frame(m: &DAffine3) -> Mat3 {
    let s = m.matrix3.x_axis.length();
    let r = (m.matrix3 * (1.0 / s)).as_mat3();
    let to_ours = Mat3::from_cols(
        glam::Vec3::new(1.0, 0.0, 0.0),
        glam::Vec3::new(0.0, 0.0, -1.0),
        glam::Vec3::new(0.0, 1.0, 0.0),
    );
    to_ours * r.transpose()
}

/// Two triangles over the corners `c` (counter-clockwise seen from the
/// front), with UVs (0, 0) to (1, 1) as Mitsuba's rectangle has them.
fn quad_mesh(c: &[[f64; 3]; 4]) -> MeshData {
    let uv = [
        Vec2::new(0.0, 0.0),
        Vec2::new(1.0, 0.0),
        Vec2::new(1.0, 1.0),
        Vec2::new(0.0, 1.0),
    ];
    MeshData {
        name: String::new(),
        positions: c.iter().map(|&p| DVec3::from(p)).collect(),
        indices: vec![[0, 1, 2], [0, 2, 3]],
        tri_material: vec![0, 0],
        materials: Vec::new(),
        uvs: vec![[uv[0], uv[1], uv[2]], [uv[0], uv[2], uv[3]]],
        normals: Vec::new(),
        warnings: Vec::new(),
        files: Vec::new(),
    }
}

/// `[-1, 1]^3`, faces outwards.
fn cube_mesh() -> MeshData {
    let mut mesh = MeshData::default();
    for axis in 0..3 {
        for sign in [-1.0f32, 1.0] {
            // u, v span the face so that u x v points along sign * axis
            let n = Vec3::from({
                let mut a = [0.0; 3];
                a[axis] = sign;
                a
            });
            let u = Vec3::from({
                let mut a = [0.0; 3];
                a[(axis + 1) % 3] = 1.0;
                a
            });
            let v = n.cross(u);
            let base = mesh.positions.len() as u32;
            for (a, b) in [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)] {
                mesh.positions.push((n + a * u + b * v).as_dvec3());
            }
            mesh.indices.push([base, base + 1, base + 2]);
            mesh.indices.push([base, base + 2, base + 3]);
            let uv = [
                Vec2::new(0.0, 0.0),
                Vec2::new(1.0, 0.0),
                Vec2::new(1.0, 1.0),
                Vec2::new(0.0, 1.0),
            ];
            mesh.uvs.push([uv[0], uv[1], uv[2]]);
            mesh.uvs.push([uv[0], uv[2], uv[3]]);
        }
    }
    mesh.tri_material = vec![0; mesh.indices.len()];
    mesh
}

/// The unit disk at z = 0 facing +z, as [`DISK_SEGMENTS`] triangles around
/// its centre.
fn disk_mesh() -> MeshData {
    let mut mesh = MeshData {
        positions: vec![DVec3::ZERO],
        ..MeshData::default()
    };
    for i in 0..DISK_SEGMENTS {
        let phi = std::f64::consts::TAU * i as f64 / DISK_SEGMENTS as f64;
        mesh.positions.push(DVec3::new(phi.cos(), phi.sin(), 0.0));
    }
    let n = DISK_SEGMENTS as u32;
    for i in 0..n {
        mesh.indices.push([0, 1 + i, 1 + (i + 1) % n]);
    }
    mesh.tri_material = vec![0; mesh.indices.len()];
    mesh
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn generated_shapes_face_the_way_mitsuba_says() {
        let normal = |m: &MeshData, t: usize| {
            let [a, b, c] = m.indices[t].map(|i| m.positions[i as usize].as_vec3());
            (b - a).cross(c - a).normalize()
        };
        let r = quad_mesh(&[
            [-1.0, -1.0, 0.0],
            [1.0, -1.0, 0.0],
            [1.0, 1.0, 0.0],
            [-1.0, 1.0, 0.0],
        ]);
        assert_eq!(normal(&r, 0), Vec3::Z);
        let c = cube_mesh();
        assert_eq!(c.indices.len(), 12);
        for t in 0..12 {
            let [a, b, d] = c.indices[t].map(|i| c.positions[i as usize].as_vec3());
            let centre = (a + b + d) / 3.0;
            assert!(normal(&c, t).dot(centre) > 0.0, "face {t} points inwards");
        }
        let d = disk_mesh();
        for t in 0..DISK_SEGMENTS {
            assert!((normal(&d, t) - Vec3::Z).length() < 1e-5);
        }
        // area: (n / 2) sin(2 pi / n), short of pi by a relative 2.5e-4 at most
        let area: f32 = (0..DISK_SEGMENTS)
            .map(|t| {
                let [a, b, c] = d.indices[t].map(|i| d.positions[i as usize].as_vec3());
                0.5 * (b - a).cross(c - a).length()
            })
            .sum();
        assert!((area / std::f32::consts::PI - 1.0).abs() < 2.5e-4, "{area}");
    }
}
