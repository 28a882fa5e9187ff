//! The CS184 path tracer's COLLADA scenes (`.dae`), read with the meaning
//! the course's own loader gives them (`src/scene/collada/collada.cpp`,
//! `src/application/application.cpp`, `src/pathtracer/camera.cpp` and
//! `src/scene/light.cpp` of github.com/cal-cs184/p3_2-pathtracer-current):
//!
//! - **Up axis**: `<asset><up_axis>` is required; `Z_UP` maps `(x, y, z)` to
//!   `(-x, z, y)`, `X_UP` to `(y, x, -z)`, as one matrix in front of every
//!   node's.
//! - **Nodes**: `<matrix>` (row-major; it ends the node's transform list,
//!   as in the course), `<translate>`, `<rotate>` (axis and degrees) and
//!   `<scale>`, composed in COLLADA's order; child nodes inherit. The course
//!   composes lists in the reverse order and misreads `rotate` and `scale`,
//!   which no course file uses (they all use `<matrix>`): we follow the
//!   COLLADA standard there, and say so in the README.
//! - **Meshes**: `<polylist>` (fanned) and `<triangles>`, positions through
//!   `<vertices>`, and per-corner `NORMAL`s (smooth shading). `TEXCOORD`s
//!   are read past.
//! - **Spheres**: the CGL `<extra>` `<sphere><radius>`, centred at the node's
//!   origin, scaled by the length of its transformed x axis.
//! - **Materials**: the CGL extras `emission` (`radiance`; seen from both
//!   sides and never sampled, [`EmissionRole::SeenOnly`]: the course's
//!   `EmissionBSDF` is counted by `zero_bounce_radiance`, on camera rays and
//!   after delta bounces, while its light reaches the scene through the
//!   area light beside it), `diffuse`
//!   (`reflectance` or `albedo`; not read by the course, which takes
//!   diffuse colours from `profile_COMMON`), `mirror`
//!   (`reflectance`), `glass` (`transmittance`, `reflectance`, `ior`;
//!   `roughness` ignored as by the course), `refraction` and `microfacet`
//!   (Beckmann, `alpha`, `eta`, `k`); else `profile_COMMON`'s
//!   `phong`/`lambert`/`blinn` diffuse colour; else diffuse 0.5.
//! - **Lights** (the CGL extra first, then `technique_common`): `area`, a
//!   one-sided rectangle of radiance `color` centred at the node's origin,
//!   facing its `-z`, with sides the transformed `(-1, 0, 0)` and
//!   `(0, 1, 0)`, which lights the scene by light sampling and is no
//!   geometry (a [`PanelLight`]: the course keeps it in `scene->lights` and
//!   out of its BVH, so no ray sees it and it casts no shadow); `point`, with no falloff (the course ignores the
//!   attenuation it reads); `directional`, towards the node's `-z`;
//!   `ambient`, radiance from the upper (`+y`) hemisphere.
//! - **Camera**: the course does not use the camera node's position. It
//!   looks at the centre of the geometry's bounding box from 1.5 times the
//!   box's diagonal away, along the direction of the node's transformed
//!   point `(0, 0, -1)`, with `+y` up; `yfov` (or `xfov` with
//!   `aspect_ratio`) fixes a focal length in pixels for an 800 x 600 window
//!   that `-r` then keeps, so the field of view follows the image height.
//! - **`-l`** counts samples per area light, as the course's
//!   `ns_area_light` does ([`crate::settings::RenderDefaults::light_samples_for`]);
//!   the course's defaults are 1 sample per pixel, 1 bounce and `-l 1`.
//!
//! Unsupported elements (`spot` lights, other cameras, `<lines>`, ...) are
//! warnings naming the element and line; malformed ones are errors naming
//! the file and line.

use super::{EmissionRole, Material, MeshData, Scene, SceneBuilder, WorldCamera};
use crate::bsdf::{Bsdf, Conductor, Diffuse, Distribution, Glass, Microfacet, Mirror};
use crate::error::{Error, Result, one_line};
use crate::light::{DirectionalLight, EnvironmentMap, PanelLight, PointLight};
use crate::limits::{self, MAX_COORDINATE};
use crate::math::Vec3;
use crate::settings::LightCount;
use crate::texture::ImageTexture;
use glam::{DAffine3, DMat3, DMat4, DVec3};
use roxmltree::{Document, Node};
use std::collections::HashMap;
use std::path::Path;

/// The course's default window, whose height fixes the focal length.
const WINDOW: [u32; 2] = [800, 600];

/// Rows of the map that stands for the ambient hemisphere light.
const AMBIENT_ROWS: u32 = 513;

struct Loader<'a, 'i> {
    path: &'a Path,
    doc: &'a Document<'i>,
    ids: HashMap<&'a str, Node<'a, 'i>>,
    warnings: Vec<String>,
    builder: SceneBuilder,
    /// The camera node's world transform, if any.
    camera: Option<(DAffine3, Node<'a, 'i>)>,
    /// Area lights added (to the builder, as panel lights).
    area_lights: usize,
    ambient: Vec3,
    /// Point lights added (to the builder).
    point_lights: usize,
    directional_lights: Vec<DirectionalLight>,
}

/// Load a CS184 COLLADA scene.
pub fn load(path: &Path) -> Result<Scene> {
    let text = super::read_scene_text(path)?;
    let options = roxmltree::ParsingOptions {
        allow_dtd: false,
        nodes_limit: 10_000_000,
        ..roxmltree::ParsingOptions::default()
    };
    let doc = Document::parse_with_options(&text, options).map_err(|e| {
        Error::input(
            path,
            Some(e.pos().row as usize),
            format!("not well-formed XML: {}", one_line(&e.to_string())),
        )
    })?;
    let mut ids = HashMap::new();
    for n in doc.descendants().filter(|n| n.is_element()) {
        if let Some(id) = n.attribute("id") {
            ids.entry(id).or_insert(n);
        }
    }
    let ld = Loader {
        path,
        doc: &doc,
        ids,
        warnings: Vec::new(),
        builder: SceneBuilder::new(path),
        camera: None,
        area_lights: 0,
        ambient: Vec3::ZERO,
        point_lights: 0,
        directional_lights: Vec::new(),
    };
    ld.scene()
}

fn child<'a, 'i>(n: Node<'a, 'i>, name: &str) -> Option<Node<'a, 'i>> {
    n.children()
        .find(|c| c.is_element() && c.tag_name().name() == name)
}

fn children<'a, 'i>(n: Node<'a, 'i>, name: &'a str) -> impl Iterator<Item = Node<'a, 'i>> + 'a {
    n.children()
        .filter(move |c| c.is_element() && c.tag_name().name() == name)
}

impl<'a, 'i> Loader<'a, 'i> {
    fn line(&self, n: Node) -> usize {
        super::xml::line(self.doc, n)
    }

    fn fail(&self, n: Node, msg: impl Into<String>) -> Error {
        super::xml::error(self.path, self.doc, n, msg)
    }

    fn warn(&mut self, n: Node, msg: impl std::fmt::Display) {
        let w = super::xml::warning(self.path, self.doc, n, msg);
        self.warnings.push(w);
    }

    /// The element a path of child names leads to from `n`, following a
    /// `url="#id"` on the last one (the course's `get_element`).
    fn element(&self, n: Node<'a, 'i>, query: &str) -> Option<Node<'a, 'i>> {
        let mut e = n;
        for name in query.split('/') {
            e = child(e, name)?;
        }
        match e.attribute("url") {
            Some(url) => self.ids.get(url.strip_prefix('#').unwrap_or(url)).copied(),
            None => Some(e),
        }
    }

    /// The element `#id` (or `id`) names, as an error at `at` when missing.
    fn target(&self, at: Node<'a, 'i>, reference: &str, what: &str) -> Result<Node<'a, 'i>> {
        let id = reference.strip_prefix('#').unwrap_or(reference);
        self.ids.get(id).copied().ok_or_else(|| {
            self.fail(
                at,
                format!(
                    "{what} `{}` is not defined in the file",
                    one_line(reference)
                ),
            )
        })
    }

    /// Every number of an element's text.
    fn numbers(&self, n: Node, limit: usize) -> Result<Vec<f64>> {
        let text = n.text().unwrap_or("");
        let mut out = Vec::new();
        for w in text.split_ascii_whitespace() {
            if out.len() >= limit {
                return Err(self.fail(
                    n,
                    format!("<{}> has more than {limit} numbers", n.tag_name().name()),
                ));
            }
            match w.parse::<f64>() {
                Ok(x) if x.is_finite() => out.push(x),
                _ => {
                    return Err(self.fail(
                        n,
                        format!(
                            "<{}>: `{}` is not a finite number",
                            n.tag_name().name(),
                            one_line(w)
                        ),
                    ));
                }
            }
        }
        Ok(out)
    }

    /// Exactly `k` numbers (a colour may carry a fourth, alpha, ignored
    /// when `k` is 3).
    fn fixed<const K: usize>(&self, n: Node) -> Result<[f64; K]> {
        let v = self.numbers(n, K + 1)?;
        if v.len() == K || (K == 3 && v.len() == 4) {
            let mut out = [0.0; K];
            out.copy_from_slice(&v[..K]);
            Ok(out)
        } else {
            Err(self.fail(
                n,
                format!(
                    "<{}>: expected {K} numbers, got {}",
                    n.tag_name().name(),
                    v.len()
                ),
            ))
        }
    }

    fn colour(&self, n: Node) -> Result<Vec3> {
        let c = DVec3::from(self.fixed::<3>(n)?).as_vec3();
        if c.min_element() < 0.0 {
            return Err(self.fail(
                n,
                format!(
                    "<{}>: a colour cannot be negative, got {c}",
                    n.tag_name().name()
                ),
            ));
        }
        Ok(c)
    }

    /// A required child's colour or number.
    /// The 3-vectors of float source `id` (`what`: position or normal),
    /// as an error at `at` when it is missing or has fewer than three
    /// numbers per element.
    fn vec3_source(
        &self,
        sources: &HashMap<&str, (Vec<f64>, usize)>,
        id: &str,
        at: Node,
        what: &str,
    ) -> Result<Vec<DVec3>> {
        let (v, stride) = sources.get(id).ok_or_else(|| {
            self.fail(
                at,
                format!(
                    "{what} source `{}` is not a float array of this mesh",
                    one_line(id)
                ),
            )
        })?;
        if *stride < 3 {
            return Err(self.fail(at, format!("{what}s need three numbers each")));
        }
        Ok(v.chunks_exact(*stride)
            .map(|c| DVec3::new(c[0], c[1], c[2]))
            .collect())
    }

    /// The numbers an `<accessor>` reads from its source's array `v`: `count`
    /// elements of `stride` numbers from `offset` (COLLADA 1.4.1's
    /// defaults: all of the array, stride 1, offset 0), with the stride. An
    /// accessor that claims more than the array holds is an error at its
    /// line; numbers past its elements are not part of the source.
    fn accessed(&self, a: Node, v: Vec<f64>) -> Result<(Vec<f64>, usize)> {
        let attr = |name: &str, default: usize| -> Result<usize> {
            match a.attribute(name) {
                None => Ok(default),
                Some(x) => x.trim().parse::<usize>().map_err(|_| {
                    self.fail(
                        a,
                        format!("<accessor> {name} `{}` is not a whole number", one_line(x)),
                    )
                }),
            }
        };
        let stride = attr("stride", 1)?;
        let offset = attr("offset", 0)?;
        if stride == 0 {
            return Err(self.fail(a, "<accessor> stride 0"));
        }
        let count = attr("count", v.len().saturating_sub(offset) / stride)?;
        let end = count
            .checked_mul(stride)
            .and_then(|n| n.checked_add(offset))
            .filter(|&end| end <= v.len())
            .ok_or_else(|| {
                self.fail(
                    a,
                    format!(
                        "<accessor> claims {count} elements of {stride} numbers from offset {offset}; its array has {} numbers",
                        v.len()
                    ),
                )
            })?;
        let v = if offset == 0 && end == v.len() {
            v
        } else {
            v[offset..end].to_vec()
        };
        Ok((v, stride))
    }

    fn need(&self, parent: Node<'a, 'i>, name: &str) -> Result<Node<'a, 'i>> {
        self.element(parent, name).ok_or_else(|| {
            self.fail(
                parent,
                format!("<{}> needs a <{name}>", parent.tag_name().name()),
            )
        })
    }

    fn scene(mut self) -> Result<Scene> {
        let root = self.doc.root_element();
        if root.tag_name().name() != "COLLADA" {
            return Err(self.fail(
                root,
                format!(
                    "expected a <COLLADA> document, found <{}>",
                    one_line(root.tag_name().name())
                ),
            ));
        }
        let up = self
            .element(root, "asset/up_axis")
            .ok_or_else(|| self.fail(root, "no <asset><up_axis>: the course's loader needs one"))?;
        let global = match up.text().map(str::trim) {
            Some("Y_UP") => DMat3::IDENTITY,
            Some("Z_UP") => DMat3::from_cols(
                DVec3::new(-1.0, 0.0, 0.0),
                DVec3::new(0.0, 0.0, 1.0),
                DVec3::new(0.0, 1.0, 0.0),
            ),
            Some("X_UP") => DMat3::from_cols(
                DVec3::new(0.0, 1.0, 0.0),
                DVec3::new(1.0, 0.0, 0.0),
                DVec3::new(0.0, 0.0, -1.0),
            ),
            other => {
                return Err(self.fail(
                    up,
                    format!(
                        "up axis `{}`: expected X_UP, Y_UP or Z_UP",
                        one_line(other.unwrap_or(""))
                    ),
                ));
            }
        };
        let global = DAffine3::from_mat3(global);
        let visual = self
            .element(root, "scene/instance_visual_scene")
            .ok_or_else(|| {
                self.fail(
                    root,
                    "no <scene><instance_visual_scene> (or its url names nothing)",
                )
            })?;
        for n in children(visual, "node") {
            self.node(n, global, 0)?;
        }
        self.finish()
    }

    /// A node and its children, under the world transform `parent`.
    fn node(&mut self, n: Node<'a, 'i>, parent: DAffine3, depth: usize) -> Result<()> {
        if depth > 256 {
            return Err(self.fail(n, "nodes nested deeper than 256"));
        }
        let mut local = DMat4::IDENTITY;
        for e in n.children().filter(|c| c.is_element()) {
            let m = match e.tag_name().name() {
                "matrix" => {
                    let v = self.numbers(e, 16)?;
                    if v.len() < 16 {
                        // the course reads with a stringstream, which leaves
                        // the values it cannot read 0 (CBgems.dae's camera
                        // has 15)
                        self.warn(
                            e,
                            format!("<matrix> has {} of 16 numbers; the rest read as 0, as the course reads them", v.len()),
                        );
                    }
                    let mut m = [0.0; 16];
                    m[..v.len()].copy_from_slice(&v);
                    // row-major in the file; ends the list, as in the course
                    local = DMat4::from_cols_array(&m).transpose();
                    break;
                }
                "translate" => DMat4::from_translation(DVec3::from(self.fixed::<3>(e)?)),
                "scale" => DMat4::from_scale(DVec3::from(self.fixed::<3>(e)?)),
                "rotate" => {
                    let [x, y, z, deg] = self.fixed::<4>(e)?;
                    let axis = DVec3::new(x, y, z);
                    if !(axis.length() > 0.0) {
                        return Err(self.fail(e, "<rotate>: the axis is zero"));
                    }
                    DMat4::from_axis_angle(axis.normalize(), deg.to_radians())
                }
                "lookat" | "skew" => {
                    self.warn(
                        e,
                        format!(
                            "<{}> is not supported (the course ignores it too); skipped",
                            e.tag_name().name()
                        ),
                    );
                    continue;
                }
                _ => continue,
            };
            local *= m;
        }
        let affine = DAffine3::from_mat4(local);
        if (local.row(3) - glam::DVec4::W).abs().max_element() > 1e-6 {
            // the course keeps the bottom row only to divide mesh vertices
            // by w; its cameras and lights ignore it
            self.warn(
                n,
                "the node's transform has a projective bottom row; only its affine part is used",
            );
        }
        let world = parent * affine;
        for c in children(n, "node") {
            self.node(c, world, depth + 1)?;
        }
        if let Some(e) = child(n, "instance_camera") {
            if self.camera.is_some() {
                self.warn(e, "a second camera; the first one is used");
            } else {
                let cam = self.target(e, e.attribute("url").unwrap_or(""), "camera")?;
                self.camera = Some((world, cam));
            }
        } else if let Some(e) = child(n, "instance_light") {
            let light = self.target(e, e.attribute("url").unwrap_or(""), "light")?;
            self.light(light, world)?;
        } else if let Some(e) = child(n, "instance_geometry") {
            let geometry = self.target(e, e.attribute("url").unwrap_or(""), "geometry")?;
            let material = match self.element(e, "bind_material/technique_common/instance_material")
            {
                Some(im) => {
                    let target = im
                        .attribute("target")
                        .ok_or_else(|| self.fail(im, "<instance_material> needs a `target`"))?;
                    let m = self.target(im, target, "material")?;
                    self.material(m)?
                }
                None => Material::diffuse("default", Vec3::splat(0.5)),
            };
            if let Some(mesh) = child(geometry, "mesh") {
                let data = self.mesh(geometry, mesh, material)?;
                let line = self.line(geometry);
                self.builder.add_mesh_matrix(data, world, Some(line))?;
            } else if let Some(radius) = self.sphere_radius(geometry)? {
                let center = world.transform_point3(DVec3::ZERO);
                let r = (radius * world.transform_vector3(DVec3::X).length()) as f32;
                if !(r > 0.0
                    && r <= MAX_COORDINATE
                    && center.abs().max_element() <= MAX_COORDINATE as f64)
                {
                    return Err(self.fail(
                        geometry,
                        format!("sphere of radius {r} at {center}: out of range"),
                    ));
                }
                let line = self.line(geometry);
                self.builder.add_sphere(center, r, material, Some(line))?;
            } else {
                self.warn(
                    geometry,
                    "a <geometry> with neither a <mesh> nor a CGL <sphere>; skipped",
                );
            }
        }
        Ok(())
    }

    /// The CGL technique of an element's `<extra>`, if any.
    fn cgl(&self, n: Node<'a, 'i>) -> Option<Node<'a, 'i>> {
        children(n, "extra")
            .flat_map(|x| children(x, "technique"))
            .find(|t| t.attribute("profile") == Some("CGL"))
    }

    fn sphere_radius(&self, geometry: Node<'a, 'i>) -> Result<Option<f64>> {
        let Some(t) = self.cgl(geometry) else {
            return Ok(None);
        };
        let Some(r) = self.element(t, "sphere/radius") else {
            return Ok(None);
        };
        let [r] = self.fixed::<1>(r)?;
        Ok(Some(r))
    }

    fn material(&mut self, m: Node<'a, 'i>) -> Result<Material> {
        let name = m
            .attribute("name")
            .or(m.attribute("id"))
            .unwrap_or("material")
            .to_string();
        let effect = self
            .element(m, "instance_effect")
            .ok_or_else(|| self.fail(m, "<material> has no <instance_effect> naming an effect"))?;
        let mut mat = Material::diffuse(&name, Vec3::splat(0.5));
        if let Some(t) = self.cgl(effect) {
            // as in the course, the last BSDF listed wins
            for b in t.children().filter(|c| c.is_element()) {
                let kind = b.tag_name().name();
                let bsdf = match kind {
                    "emission" => {
                        mat.emission = self.colour(self.need(b, "radiance")?)?;
                        mat.two_sided = true;
                        // the course's EmissionBSDF: seen, never sampled
                        mat.role = EmissionRole::SeenOnly;
                        Bsdf::Diffuse(Diffuse { albedo: Vec3::ZERO })
                    }
                    // not in the course's loader (its diffuse comes from
                    // profile_COMMON), but named by CGL-profile files
                    // written for it: `reflectance`, or `albedo`
                    "diffuse" => {
                        let c = self
                            .element(b, "reflectance")
                            .or_else(|| self.element(b, "albedo"))
                            .ok_or_else(|| {
                                self.fail(b, "<diffuse> needs a <reflectance> or <albedo>")
                            })?;
                        Bsdf::Diffuse(Diffuse {
                            albedo: self.colour(c)?,
                        })
                    }
                    "mirror" => Bsdf::Mirror(Mirror {
                        reflectance: self.colour(self.need(b, "reflectance")?)?,
                    }),
                    "microfacet" => {
                        let alpha = self.fixed::<1>(self.need(b, "alpha")?)?[0] as f32;
                        Bsdf::Conductor(Conductor {
                            eta: self.colour(self.need(b, "eta")?)?,
                            k: self.colour(self.need(b, "k")?)?,
                            microfacet: Microfacet::new(Distribution::Beckmann, alpha),
                        })
                    }
                    "glass" | "refraction" => {
                        let ior = self.fixed::<1>(self.need(b, "ior")?)?[0] as f32;
                        let reflectance = if kind == "glass" {
                            self.colour(self.need(b, "reflectance")?)?
                        } else {
                            Vec3::ZERO
                        };
                        Bsdf::Glass(Glass {
                            ior,
                            reflectance,
                            transmittance: self.colour(self.need(b, "transmittance")?)?,
                        })
                    }
                    other => {
                        self.warn(
                            b,
                            format!(
                                "CGL material <{}> is not supported; skipped",
                                one_line(other)
                            ),
                        );
                        continue;
                    }
                };
                bsdf.validate()
                    .map_err(|e| self.fail(b, format!("<{kind}>: {e}")))?;
                if kind != "emission" {
                    mat.emission = Vec3::ZERO;
                    mat.two_sided = false;
                    mat.role = EmissionRole::Light;
                }
                mat.bsdf = bsdf;
            }
        } else if let Some(common) = self.technique_common(effect) {
            for shading in ["phong", "lambert", "blinn"] {
                if let Some(c) = self.element(common, &format!("{shading}/diffuse/color")) {
                    let albedo = self.colour(c)?;
                    let bsdf = Bsdf::Diffuse(Diffuse { albedo });
                    bsdf.validate()
                        .map_err(|e| self.fail(c, format!("diffuse: {e}")))?;
                    mat.bsdf = bsdf;
                    break;
                }
            }
        }
        Ok(mat)
    }

    /// `profile_COMMON/technique[sid=common]`, else `technique_common`.
    fn technique_common(&self, n: Node<'a, 'i>) -> Option<Node<'a, 'i>> {
        child(n, "profile_COMMON")
            .and_then(|p| children(p, "technique").find(|t| t.attribute("sid") == Some("common")))
            .or_else(|| child(n, "technique_common"))
    }

    fn mesh(
        &mut self,
        geometry: Node<'a, 'i>,
        mesh: Node<'a, 'i>,
        material: Material,
    ) -> Result<MeshData> {
        // float sources
        let mut sources: HashMap<&str, (Vec<f64>, usize)> = HashMap::new();
        for s in children(mesh, "source") {
            let (Some(id), Some(fa)) = (s.attribute("id"), child(s, "float_array")) else {
                continue;
            };
            let count: usize = match fa.attribute("count").map(str::parse) {
                Some(Ok(c)) => c,
                _ => return Err(self.fail(fa, "<float_array> needs a whole-number `count`")),
            };
            let v = self.numbers(fa, count)?;
            if v.len() != count {
                return Err(self.fail(
                    fa,
                    format!("<float_array> claims {count} numbers and has {}", v.len()),
                ));
            }
            let (v, stride) = match self.element(s, "technique_common/accessor") {
                Some(a) => self.accessed(a, v)?,
                None => (v, 3),
            };
            sources.insert(id, (v, stride));
        }
        let vertices = self.need(mesh, "vertices")?;
        let vertices_id = vertices.attribute("id").unwrap_or("");
        let pos_src = children(vertices, "input")
            .find(|i| i.attribute("semantic") == Some("POSITION"))
            .ok_or_else(|| self.fail(vertices, "<vertices> has no POSITION input"))?;
        let pos_id = pos_src
            .attribute("source")
            .unwrap_or("")
            .trim_start_matches('#');
        let positions = self.vec3_source(&sources, pos_id, pos_src, "position")?;
        if positions.len() as u64 > limits::MAX_VERTICES {
            return Err(self.fail(
                pos_src,
                format!("more than {} vertices", limits::MAX_VERTICES),
            ));
        }
        let mut data = MeshData {
            name: geometry
                .attribute("name")
                .or(geometry.attribute("id"))
                .unwrap_or("mesh")
                .to_string(),
            positions,
            materials: vec![material],
            ..MeshData::default()
        };
        let mut corner_normals: Vec<[Vec3; 3]> = Vec::new();
        let mut any_normals = false;
        for prim in mesh.children().filter(|c| c.is_element()) {
            let kind = prim.tag_name().name();
            if !matches!(kind, "polylist" | "triangles") {
                if matches!(
                    kind,
                    "lines" | "linestrips" | "polygons" | "trifans" | "tristrips"
                ) {
                    self.warn(prim, format!("<{kind}> is not supported; skipped"));
                }
                continue;
            }
            let mut vertex_offset = None;
            let mut normal: Option<(usize, Vec<Vec3>)> = None;
            let mut stride = 1;
            for input in children(prim, "input") {
                let offset: usize = input
                    .attribute("offset")
                    .and_then(|o| o.parse().ok())
                    .unwrap_or(0);
                if offset > 64 {
                    return Err(self.fail(input, "an input offset above 64"));
                }
                stride = stride.max(offset + 1);
                let source = input
                    .attribute("source")
                    .unwrap_or("")
                    .trim_start_matches('#');
                match input.attribute("semantic") {
                    Some("VERTEX") => {
                        if source != vertices_id {
                            return Err(self.fail(
                                input,
                                format!(
                                    "VERTEX input `{}` is not this mesh's <vertices>",
                                    one_line(source)
                                ),
                            ));
                        }
                        vertex_offset = Some(offset);
                    }
                    Some("NORMAL") => {
                        let n = self.vec3_source(&sources, source, input, "normal")?;
                        normal = Some((offset, n.iter().map(|n| n.as_vec3()).collect::<Vec<_>>()));
                    }
                    _ => {}
                }
            }
            let vertex_offset = vertex_offset
                .ok_or_else(|| self.fail(prim, format!("<{kind}> has no VERTEX input")))?;
            let count: usize = prim
                .attribute("count")
                .and_then(|c| c.parse().ok())
                .ok_or_else(|| self.fail(prim, format!("<{kind}> needs a whole-number `count`")))?;
            let sizes: Vec<usize> = if kind == "polylist" {
                let vc = self.need(prim, "vcount")?;
                let v = self.numbers(vc, count)?;
                if v.len() != count {
                    return Err(self.fail(
                        vc,
                        format!("<vcount> has {} sizes for {count} polygons", v.len()),
                    ));
                }
                v.iter()
                    .map(|&s| {
                        if s.fract() == 0.0 && (3.0..=256.0).contains(&s) {
                            Ok(s as usize)
                        } else {
                            Err(self
                                .fail(vc, format!("a polygon of {s} corners (expected 3 to 256)")))
                        }
                    })
                    .collect::<Result<_>>()?
            } else {
                vec![3; count.min(limits::MAX_TRIANGLES as usize + 1)]
            };
            let corners: usize = sizes.iter().sum();
            let p = self.need(prim, "p")?;
            let indices = self.numbers(p, corners.saturating_mul(stride))?;
            if indices.len() != corners * stride {
                return Err(self.fail(
                    p,
                    format!(
                        "<p> has {} indices, the polygons need {}",
                        indices.len(),
                        corners * stride
                    ),
                ));
            }
            let index = |k: usize, off: usize, len: usize| -> Result<u32> {
                let x = indices[k * stride + off];
                if x.fract() == 0.0 && x >= 0.0 && (x as usize) < len {
                    Ok(x as u32)
                } else {
                    Err(self.fail(p, format!("index {x} out of range (0..{len})")))
                }
            };
            let nv = data.positions.len();
            let mut k = 0;
            for &size in &sizes {
                let v: Vec<u32> = (0..size)
                    .map(|j| index(k + j, vertex_offset, nv))
                    .collect::<Result<_>>()?;
                let n: Option<Vec<Vec3>> = match &normal {
                    Some((off, ns)) => Some(
                        (0..size)
                            .map(|j| index(k + j, *off, ns.len()).map(|i| ns[i as usize]))
                            .collect::<Result<_>>()?,
                    ),
                    None => None,
                };
                for j in 1..size - 1 {
                    data.indices.push([v[0], v[j], v[j + 1]]);
                    data.tri_material.push(0);
                    match &n {
                        Some(n) => {
                            any_normals = true;
                            corner_normals.push([n[0], n[j], n[j + 1]]);
                        }
                        None => corner_normals.push([Vec3::ZERO; 3]),
                    }
                }
                if data.indices.len() as u64 > limits::MAX_TRIANGLES {
                    return Err(self.fail(
                        prim,
                        format!("more than {} triangles", limits::MAX_TRIANGLES),
                    ));
                }
                k += size;
            }
        }
        if any_normals {
            data.normals = corner_normals;
        }
        Ok(data)
    }

    fn light(&mut self, light: Node<'a, 'i>, world: DAffine3) -> Result<()> {
        let technique = self
            .cgl(light)
            .or_else(|| self.technique_common(light))
            .ok_or_else(|| self.fail(light, "<light> has neither a CGL nor a common technique"))?;
        let Some(e) = technique.children().find(|c| c.is_element()) else {
            return Err(self.fail(technique, "the light's technique is empty"));
        };
        let kind = e.tag_name().name();
        let colour = |ld: &Self| ld.colour(ld.need(e, "color")?);
        let origin = world.transform_point3(DVec3::ZERO);
        // the course transforms directions as points (w = 1) and subtracts
        // the origin where it does; kept as it does
        let point = |p: DVec3| world.transform_point3(p);
        match kind {
            "area" => {
                let radiance = colour(self)?;
                let dir = (point(-DVec3::Z) - origin).normalize_or_zero();
                let dim_x = point(-DVec3::X) - origin;
                let dim_y = point(DVec3::Y) - origin;
                if dir == DVec3::ZERO || dim_x.cross(dim_y).length_squared() == 0.0 {
                    return Err(self.fail(e, "the area light's node transform flattens it"));
                }
                let far = origin.abs() + 0.5 * (dim_x.abs() + dim_y.abs());
                if !(far.max_element() <= MAX_COORDINATE as f64) {
                    return Err(self.fail(
                        e,
                        format!("the area light reaches past coordinate {MAX_COORDINATE:e}"),
                    ));
                }
                // the course keeps it in `scene->lights` only: it lights by
                // light sampling and is no geometry
                let panel = PanelLight::new(
                    Vec3::ZERO,
                    dim_x.as_vec3(),
                    dim_y.as_vec3(),
                    dir.as_vec3(),
                    radiance,
                )
                .ok_or_else(|| self.fail(e, "the area light's node transform flattens it"))?;
                self.area_lights += 1;
                self.builder.add_panel_light(origin, panel);
            }
            "point" => {
                let l = PointLight::new(Vec3::ZERO, colour(self)?)
                    .with_attenuation([1.0, 0.0, 0.0])
                    .expect("constant falloff is valid");
                self.point_lights += 1;
                self.builder.add_point_light(origin, l);
            }
            "directional" => {
                // the course's direction towards the light is minus the
                // transformed point (0, 0, -1)
                let towards_light = -point(-DVec3::Z).as_vec3();
                let l = DirectionalLight::new(-towards_light, colour(self)?)
                    .ok_or_else(|| self.fail(e, "the directional light's direction is zero"))?;
                self.directional_lights.push(l);
            }
            "ambient" => self.ambient += colour(self)?,
            other => self.warn(
                e,
                format!("<{}> lights are not supported; skipped", one_line(other)),
            ),
        }
        Ok(())
    }

    /// The camera's focal length in pixels, as the course's `Camera::configure`
    /// fixes it for its 800 x 600 window.
    fn focal_pixels(&self, cam: Node<'a, 'i>) -> Result<f32> {
        let p = self
            .element(cam, "optics/technique_common/perspective")
            .ok_or_else(|| {
                self.fail(
                    cam,
                    "the camera has no <perspective> (the course supports no other)",
                )
            })?;
        let read = |name: &str| -> Result<Option<f64>> {
            match child(p, name) {
                Some(e) => Ok(Some(self.fixed::<1>(e)?[0])),
                None => Ok(None),
            }
        };
        let h = read("xfov")?.unwrap_or(50.0);
        let v = match (read("yfov")?, read("aspect_ratio")?) {
            (Some(v), _) => v,
            (None, Some(a)) if a > 0.0 => {
                2.0 * ((0.5 * h).to_radians().tan() / a).atan().to_degrees()
            }
            _ => {
                return Err(self.fail(
                    p,
                    "<perspective> needs a <yfov>, or an <xfov> with an <aspect_ratio>",
                ));
            }
        };
        if !(h > 0.0 && h < 180.0 && v > 0.0 && v < 180.0) {
            return Err(self.fail(p, format!("field of view {h} x {v} degrees out of range")));
        }
        let half = |deg: f64| (0.5 * deg).to_radians().tan();
        let ar = WINDOW[0] as f64 / WINDOW[1] as f64;
        let v = if half(h) / half(v) > ar {
            2.0 * (half(h) / ar).atan().to_degrees()
        } else {
            v
        };
        Ok((WINDOW[1] as f64 / (2.0 * half(v))) as f32)
    }

    fn finish(mut self) -> Result<Scene> {
        let path = self.path;
        // the camera, placed from the bounds of the geometry (lights left
        // out, as in the course)
        let (lo, hi) = self.builder.world_bounds();
        let (focal, view) = match self.camera {
            Some((world, cam)) => {
                let f = self.focal_pixels(cam)?;
                // the course normalises the transformed point (0, 0, -1)
                let d = world.transform_point3(-DVec3::Z).normalize_or_zero();
                if d == DVec3::ZERO {
                    return Err(
                        self.fail(cam, "the camera node's transform leaves no view direction")
                    );
                }
                (Some(f), d)
            }
            None => (None, DVec3::Z),
        };
        let mut notes = Vec::new();
        let camera = if lo.x > hi.x {
            WorldCamera::framing(lo, hi)
        } else {
            let target = 0.5 * (lo + hi);
            let distance = 1.5 * (hi - lo).length();
            notes.push(format!(
                "{}: camera placed as the course places it: {distance} from the centre of the geometry's bounds, along {view}",
                path.display()
            ));
            // the course nudges a vertical view off the pole; so do we
            let up = if view.y.abs() > 1.0 - 1e-6 {
                Vec3::NEG_Z
            } else {
                Vec3::Y
            };
            WorldCamera {
                origin: target + distance * view,
                target,
                up,
                fov_y: 39.3,
            }
        };
        let ambient = self.ambient;
        if ambient != Vec3::ZERO {
            // radiance from the upper hemisphere: rows from the +y pole to
            // the horizon lit
            let rows: Vec<f32> = (0..AMBIENT_ROWS)
                .flat_map(|r| [if r <= AMBIENT_ROWS / 2 { 1.0 } else { 0.0 }; 3])
                .collect();
            let map = ImageTexture::from_linear_rgb(1, AMBIENT_ROWS, rows)?;
            self.builder.scene_mut().environment_map = Some(
                EnvironmentMap::new(map, ambient)
                    .map_err(|e| Error::input(path, None, format!("ambient light: {e}")))?,
            );
        }
        let count = LightCount {
            sampled: (self.area_lights + usize::from(ambient != Vec3::ZERO)) as u32,
            delta: (self.point_lights + self.directional_lights.len()) as u32,
        };
        self.builder.scene_mut().directional_lights = self.directional_lights;
        self.builder.set_camera(camera);
        self.builder.scene_mut().resolution = WINDOW;
        self.builder.scene_mut().focal_pixels = focal;
        let mut scene = self.builder.build();
        // the course's defaults: 1 sample, 1 bounce, 1 sample per area light
        scene.render.spp = 1;
        scene.render.max_depth = 1;
        scene.render.per_light = Some(count);
        scene.render.light_samples = scene
            .render
            .light_samples_for(Some(1))
            .min(limits::MAX_LIGHT_SAMPLES as u64) as u32;
        scene.notes.extend(notes);
        scene.warnings.extend(self.warnings);
        Ok(scene)
    }
}
