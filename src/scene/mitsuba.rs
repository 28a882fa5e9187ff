//! Mitsuba 3 scene files (`.xml`): a documented subset, read into the same
//! [`Scene`] as the TOML format, with Mitsuba's own meanings (the plugin
//! reference of the Mitsuba 3 documentation, "Scene format" and "Plugin
//! reference" chapters).
//!
//! What is read (anything else is a one-line error, or a warning when the
//! image can still be what the file means without it):
//!
//! - **Structure:** `<scene version>`, `<default name value>` and `$name`
//!   substitution in every attribute, `<bsdf id>` / `<texture id>` at the
//!   top level and `<ref id>` to them.
//! - **`<integrator type="path">`** (`volpath` and `prbvolpath` are read as
//!   `path`, without media): `max_depth` (Mitsuba counts path segments, so
//!   `max_depth = n` is our `n - 1` bounces; -1 is our limit) and
//!   `rr_depth` (the same numbering as ours: roulette from the `rr_depth`-th
//!   bounce).
//! - **`<sensor type="perspective">` and `"thinlens"`**: `fov`, `fov_axis`
//!   (`x` the default, `y`, `diagonal`, `smaller`, `larger`; converted to our
//!   vertical field of view with the film's aspect), `to_world`,
//!   `aperture_radius`, `focus_distance`; inside it `<film type="hdrfilm">`
//!   (`width`, `height`; default 768 x 576) and `<sampler>`
//!   (`sample_count`, `seed`). The camera looks along its local +z with +y up.
//! - **Transforms:** `lookat`, `translate`, `rotate`, `scale`, `matrix`
//!   (4 x 4 or 3 x 3, row-major), composed in file order (each applies after
//!   the ones before it).
//! - **Shapes** `obj`, `ply`, `rectangle` (`[-1, 1]^2` at z = 0, facing +z),
//!   `cube` (`[-1, 1]^3`), `sphere` (`center`, `radius`, a similarity
//!   `to_world`), `disk` (the unit disk at z = 0, facing +z), with
//!   `to_world`, `flip_normals` and `face_normals`. A mesh without vertex
//!   normals and without `face_normals` gets angle-weighted vertex normals,
//!   as Mitsuba computes them. The disk is tessellated into
//!   [`DISK_SEGMENTS`] triangles: its area is short of pi by a relative
//!   2e-4 (a named, documented bias; Mitsuba's disk is analytic).
//! - **BSDFs** `diffuse`, `conductor`, `roughconductor`, `dielectric`,
//!   `plastic`, `roughplastic`, `twosided`, with `rgb`, `float`, `spectrum`
//!   (one value) and `bitmap` textures. Indices of refraction take numbers or
//!   Mitsuba's names (`bk7`, `air`, `water`, ... from Mitsuba's table).
//!   Conductors take `eta` and `k` (named metals need spectral data, so they
//!   are an error) or `material="none"`, the perfect mirror.
//! - **Emitters** `area` (in a shape), `point`, `directional`, `constant`,
//!   `envmap` (`filename`, `scale`; `to_world` must be the identity: our
//!   map is in Mitsuba's default orientation).
//!
//! One difference stays, by design: Mitsuba's BSDFs other than `twosided`
//! and `dielectric` are black seen from behind, and embertrace's surfaces
//! scatter on both sides. In a closed room seen from inside the two agree;
//! a back face in view differs.

use super::{Material, MeshData, Scene, SceneBuilder, WorldCamera, load_obj_mesh, load_ply_mesh};
use crate::bsdf::{Bsdf, Conductor, Diffuse, Distribution, Glass, Microfacet, Plastic};
use crate::camera::ThinLens;
use crate::error::{Error, Result, one_line};
use crate::light::directional::DirectionalLight;
use crate::light::envmap::EnvironmentMap;
use crate::light::point::PointLight;
use crate::limits::{MAX_COORDINATE, check_max_depth, check_resolution, check_spp};
use crate::math::{Vec2, Vec3};
use crate::texture::ImageTexture;
use glam::{DAffine3, DMat3, DVec3};
use roxmltree::{Document, Node};
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// Triangles of a tessellated `disk`.
pub const DISK_SEGMENTS: usize = 256;

/// Indices of refraction by Mitsuba's names (Mitsuba 3 documentation,
/// "Dielectric" plugin, table of named indices).
const NAMED_IOR: [(&str, f32); 23] = [
    ("vacuum", 1.0),
    ("helium", 1.00004),
    ("hydrogen", 1.00013),
    ("air", 1.00028),
    ("carbon dioxide", 1.00045),
    ("water", 1.3330),
    ("acetone", 1.36),
    ("ethanol", 1.361),
    ("carbon tetrachloride", 1.461),
    ("glycerol", 1.4729),
    ("benzene", 1.501),
    ("silicone oil", 1.52045),
    ("bromine", 1.661),
    ("water ice", 1.31),
    ("fused quartz", 1.458),
    ("pyrex", 1.470),
    ("acrylic glass", 1.49),
    ("polypropylene", 1.49),
    ("bk7", 1.5046),
    ("sodium chloride", 1.544),
    ("amber", 1.55),
    ("pet", 1.5750),
    ("diamond", 2.419),
];

/// A parameter's value.
#[derive(Debug, Clone)]
enum Value<'a, 'i> {
    Number(f64),
    Bool(bool),
    Text(String),
    Colour(Vec3),
    Vector(DVec3),
    Matrix(DAffine3),
    /// A nested plugin (`bsdf`, `texture`, `emitter`, `film`, `sampler`,
    /// `rfilter`), or a `ref` resolved to one.
    Object(Node<'a, 'i>),
}

/// A plugin's parameters, each taken at most once; what is left is warned
/// about.
struct Params<'a, 'i> {
    /// (name, value, line, taken).
    items: Vec<(String, Value<'a, 'i>, usize, bool)>,
    /// Nested plugins without a `name` (a shape's bsdf and emitter).
    unnamed: Vec<(Node<'a, 'i>, bool)>,
    /// Parameters read with the wrong type: (name, expected, line).
    mistyped: Vec<(String, String, usize)>,
    /// `<tag type>` and its line, for messages.
    owner: String,
    line: usize,
}

struct Loader<'a, 'i> {
    path: &'a Path,
    dir: PathBuf,
    defaults: HashMap<String, String>,
    ids: HashMap<String, Node<'a, 'i>>,
    textures: HashMap<PathBuf, Arc<ImageTexture>>,
    warnings: Vec<String>,
    doc: &'a Document<'i>,
}

/// Load a Mitsuba 3 scene file.
pub fn load(path: &Path) -> Result<Scene> {
    let text = super::read_scene_text(path)?;
    let options = roxmltree::ParsingOptions {
        allow_dtd: false,
        nodes_limit: 10_000_000,
        ..roxmltree::ParsingOptions::default()
    };
    let doc = Document::parse_with_options(&text, options).map_err(|e| {
        let pos = e.pos();
        Error::input(
            path,
            Some(pos.row as usize),
            format!("not well-formed XML: {}", one_line(&e.to_string())),
        )
    })?;
    let mut loader = Loader {
        path,
        dir: path.parent().unwrap_or(Path::new("")).to_path_buf(),
        defaults: HashMap::new(),
        ids: HashMap::new(),
        textures: HashMap::new(),
        warnings: Vec::new(),
        doc: &doc,
    };
    loader.scene()
}

impl<'a, 'i> Loader<'a, 'i> {
    fn line(&self, node: Node) -> usize {
        super::xml::line(self.doc, node)
    }

    fn fail(&self, node: Node, msg: impl Into<String>) -> Error {
        super::xml::error(self.path, self.doc, node, msg)
    }

    fn warn(&mut self, node: Node, msg: impl std::fmt::Display) {
        let w = super::xml::warning(self.path, self.doc, node, msg);
        self.warnings.push(w);
    }

    /// Attribute `name` with `$defaults` substituted.
    fn attr(&self, node: Node, name: &str) -> Result<Option<String>> {
        let Some(raw) = node.attribute(name) else {
            return Ok(None);
        };
        if !raw.contains('$') {
            return Ok(Some(raw.to_string()));
        }
        let mut out = String::new();
        let mut rest = raw;
        while let Some(i) = rest.find('$') {
            out.push_str(&rest[..i]);
            let after = &rest[i + 1..];
            let end = after
                .find(|c: char| !(c.is_ascii_alphanumeric() || c == '_'))
                .unwrap_or(after.len());
            let key = &after[..end];
            let Some(v) = self.defaults.get(key) else {
                return Err(self.fail(
                    node,
                    format!(
                        "`${}` has no `<default name=\"{}\">`",
                        one_line(key),
                        one_line(key)
                    ),
                ));
            };
            out.push_str(v);
            rest = &after[end..];
        }
        out.push_str(rest);
        Ok(Some(out))
    }

    fn need_attr(&self, node: Node, name: &str) -> Result<String> {
        self.attr(node, name)?.ok_or_else(|| {
            self.fail(
                node,
                format!("<{}> needs a `{name}` attribute", node.tag_name().name()),
            )
        })
    }

    fn number(&self, node: Node, text: &str, what: &str) -> Result<f64> {
        let v = text.trim().parse::<f64>().map_err(|_| {
            self.fail(
                node,
                format!("{what}: cannot read `{}` as a number", one_line(text)),
            )
        })?;
        if !v.is_finite() {
            return Err(self.fail(node, format!("{what}: {v} is not finite")));
        }
        Ok(v)
    }

    /// Numbers separated by commas or white space.
    fn numbers(&self, node: Node, text: &str, what: &str) -> Result<Vec<f64>> {
        text.split(|c: char| c == ',' || c.is_whitespace())
            .filter(|w| !w.is_empty())
            .take(17)
            .map(|w| self.number(node, w, what))
            .collect()
    }

    /// A vector from `value="x, y, z"` or `x= y= z=` (missing ones 0).
    fn vector(&self, node: Node, what: &str) -> Result<DVec3> {
        if let Some(v) = self.attr(node, "value")? {
            let n = self.numbers(node, &v, what)?;
            return match n[..] {
                [x, y, z] => Ok(DVec3::new(x, y, z)),
                [s] => Ok(DVec3::splat(s)),
                _ => Err(self.fail(node, format!("{what}: expected three numbers"))),
            };
        }
        let mut out = [0.0f64; 3];
        for (k, axis) in ["x", "y", "z"].iter().enumerate() {
            if let Some(v) = self.attr(node, axis)? {
                out[k] = self.number(node, &v, what)?;
            }
        }
        Ok(DVec3::from(out))
    }

    /// A colour: one number (grey) or three.
    fn colour(&self, node: Node, what: &str) -> Result<Vec3> {
        let v = self.need_attr(node, "value")?;
        let n = self.numbers(node, &v, what)?;
        let c = match n[..] {
            [g] => Vec3::splat(g as f32),
            [r, g, b] => Vec3::new(r as f32, g as f32, b as f32),
            _ => {
                return Err(self.fail(
                    node,
                    format!(
                        "{what}: expected one value or three (r, g, b){}",
                        if node.tag_name().name() == "spectrum" {
                            "; spectra given as wavelength:value pairs are not in the subset"
                        } else {
                            ""
                        }
                    ),
                ));
            }
        };
        if !c.is_finite() || c.min_element() < 0.0 {
            return Err(self.fail(node, format!("{what}: must be finite and >= 0, got {c}")));
        }
        Ok(c)
    }

    /// A `<transform>`: its operations composed in file order.
    fn transform(&mut self, node: Node<'a, 'i>) -> Result<DAffine3> {
        let mut m = DAffine3::IDENTITY;
        for op in node.children().filter(|n| n.is_element()) {
            let name = op.tag_name().name();
            let what = format!("<{name}>");
            let step = match name {
                "translate" => DAffine3::from_translation(self.vector(op, &what)?),
                "scale" => {
                    let s = if op.attribute("value").is_some() {
                        self.vector(op, &what)?
                    } else {
                        let mut s = [1.0f64; 3];
                        for (k, axis) in ["x", "y", "z"].iter().enumerate() {
                            if let Some(v) = self.attr(op, axis)? {
                                s[k] = self.number(op, &v, &what)?;
                            }
                        }
                        DVec3::from(s)
                    };
                    DAffine3::from_scale(s)
                }
                "rotate" => {
                    let axis = self.vector(op, &what)?;
                    let angle = self.number(op, &self.need_attr(op, "angle")?, &what)?;
                    if !(axis.length() > 0.0) || !axis.is_finite() {
                        return Err(self.fail(op, "<rotate>: the axis must be non-zero"));
                    }
                    DAffine3::from_axis_angle(axis.normalize(), angle.to_radians())
                }
                "matrix" => {
                    let v = self.need_attr(op, "value")?;
                    let n = self.numbers(op, &v, &what)?;
                    let f = |r: usize, c: usize, w: usize| n[r * w + c];
                    match n.len() {
                        16 => {
                            let last = [f(3, 0, 4), f(3, 1, 4), f(3, 2, 4), f(3, 3, 4)];
                            if last != [0.0, 0.0, 0.0, 1.0] {
                                return Err(self.fail(
                                    op,
                                    "<matrix>: a projective last row is not supported (expected 0 0 0 1)",
                                ));
                            }
                            DAffine3::from_cols(
                                DVec3::new(f(0, 0, 4), f(1, 0, 4), f(2, 0, 4)),
                                DVec3::new(f(0, 1, 4), f(1, 1, 4), f(2, 1, 4)),
                                DVec3::new(f(0, 2, 4), f(1, 2, 4), f(2, 2, 4)),
                                DVec3::new(f(0, 3, 4), f(1, 3, 4), f(2, 3, 4)),
                            )
                        }
                        9 => DAffine3::from_mat3(DMat3::from_cols(
                            DVec3::new(f(0, 0, 3), f(1, 0, 3), f(2, 0, 3)),
                            DVec3::new(f(0, 1, 3), f(1, 1, 3), f(2, 1, 3)),
                            DVec3::new(f(0, 2, 3), f(1, 2, 3), f(2, 2, 3)),
                        )),
                        _ => {
                            return Err(
                                self.fail(op, "<matrix>: expected 16 (4 x 4) or 9 (3 x 3) numbers")
                            );
                        }
                    }
                }
                "lookat" => {
                    let point =
                        |key: &str| -> Result<DVec3> {
                            let v = self.need_attr(op, key)?;
                            let n = self.numbers(op, &v, &format!("<lookat> {key}"))?;
                            match n[..] {
                                [x, y, z] => Ok(DVec3::new(x, y, z)),
                                _ => Err(self
                                    .fail(op, format!("<lookat> {key}: expected three numbers"))),
                            }
                        };
                    let origin = point("origin")?;
                    let target = point("target")?;
                    let up = match op.attribute("up") {
                        Some(_) => point("up")?,
                        None => DVec3::Y,
                    };
                    let dir = (target - origin).normalize_or_zero();
                    let left = up.cross(dir).normalize_or_zero();
                    if dir == DVec3::ZERO || left == DVec3::ZERO {
                        return Err(self.fail(
                            op,
                            "<lookat>: origin and target coincide, or up is parallel to the view",
                        ));
                    }
                    let new_up = dir.cross(left);
                    DAffine3::from_cols(left, new_up, dir, origin)
                }
                other => {
                    return Err(self.fail(
                        op,
                        format!(
                            "<{}> is not a transform operation (expected translate, rotate, scale, matrix or lookat)",
                            one_line(other)
                        ),
                    ));
                }
            };
            m = step * m;
        }
        if !(m.matrix3.is_finite() && m.translation.is_finite()) {
            return Err(self.fail(node, "<transform>: the matrix is not finite"));
        }
        Ok(m)
    }

    /// The parameters of plugin element `node`.
    fn params(&mut self, node: Node<'a, 'i>) -> Result<Params<'a, 'i>> {
        let mut p = Params {
            items: Vec::new(),
            unnamed: Vec::new(),
            mistyped: Vec::new(),
            owner: format!(
                "<{} type=\"{}\">",
                node.tag_name().name(),
                one_line(node.attribute("type").unwrap_or(""))
            ),
            line: self.line(node),
        };
        for c in node.children().filter(|n| n.is_element()) {
            let tag = c.tag_name().name();
            let name = self.attr(c, "name")?;
            let value = match tag {
                "float" | "integer" => {
                    let what = format!(
                        "<{tag} name=\"{}\">",
                        one_line(name.as_deref().unwrap_or(""))
                    );
                    Value::Number(self.number(c, &self.need_attr(c, "value")?, &what)?)
                }
                "boolean" => match self.need_attr(c, "value")?.as_str() {
                    "true" => Value::Bool(true),
                    "false" => Value::Bool(false),
                    v => {
                        return Err(self.fail(
                            c,
                            format!("<boolean>: `{}` is neither true nor false", one_line(v)),
                        ));
                    }
                },
                "string" => Value::Text(self.need_attr(c, "value")?),
                "rgb" | "spectrum" => Value::Colour(self.colour(c, &format!("<{tag}>"))?),
                "point" | "vector" => Value::Vector(self.vector(c, &format!("<{tag}>"))?),
                "transform" => Value::Matrix(self.transform(c)?),
                "bsdf" | "texture" | "emitter" | "film" | "sampler" | "rfilter" => {
                    if c.attribute("id").is_some() && tag != "film" {
                        self.register(c)?;
                    }
                    Value::Object(c)
                }
                "ref" => {
                    let id = self.need_attr(c, "id")?;
                    let target = *self.ids.get(&id).ok_or_else(|| {
                        self.fail(c, format!("<ref id=\"{}\">: no object has this id (it must come before the ref)", one_line(&id)))
                    })?;
                    Value::Object(target)
                }
                "default" => {
                    self.default(c)?;
                    continue;
                }
                other => {
                    return Err(self.fail(
                        c,
                        format!(
                            "<{}> inside {}: not part of the supported Mitsuba subset",
                            one_line(other),
                            p.owner
                        ),
                    ));
                }
            };
            match name {
                Some(n) => p.items.push((n, value, self.line(c), false)),
                None => match value {
                    Value::Object(o) => p.unnamed.push((o, false)),
                    _ => {
                        return Err(self.fail(c, format!("<{tag}> needs a `name` attribute")));
                    }
                },
            }
        }
        Ok(p)
    }

    fn register(&mut self, node: Node<'a, 'i>) -> Result<()> {
        let id = self.need_attr(node, "id")?;
        if self.ids.insert(id.clone(), node).is_some() {
            return Err(self.fail(node, format!("a second object with id `{}`", one_line(&id))));
        }
        Ok(())
    }

    fn default(&mut self, node: Node) -> Result<()> {
        let name = self.need_attr(node, "name")?;
        let value = self.need_attr(node, "value")?;
        // a command line would override it; a file's first default stands
        self.defaults.entry(name).or_insert(value);
        Ok(())
    }

    /// Warn about parameters nobody took, or took with the wrong type.
    fn finish(&mut self, p: Params<'a, 'i>) {
        for (name, expected, line) in &p.mistyped {
            self.warnings.push(format!(
                "{}:{line}: `{}` of {} should be {expected}; ignored",
                self.path.display(),
                one_line(name),
                p.owner
            ));
        }
        for (name, _, line, taken) in &p.items {
            if !taken {
                self.warnings.push(format!(
                    "{}:{line}: `{}` is not a parameter of {} that embertrace reads; ignored",
                    self.path.display(),
                    one_line(name),
                    p.owner
                ));
            }
        }
        for (node, taken) in &p.unnamed {
            if !taken {
                let line = self.line(*node);
                self.warnings.push(format!(
                    "{}:{line}: <{}> inside {} is not used; ignored",
                    self.path.display(),
                    node.tag_name().name(),
                    p.owner
                ));
            }
        }
    }

    fn scene(&mut self) -> Result<Scene> {
        let root = self.doc.root_element();
        if root.tag_name().name() != "scene" {
            return Err(self.fail(
                root,
                format!(
                    "expected <scene> as the root element, found <{}>",
                    one_line(root.tag_name().name())
                ),
            ));
        }
        match root.attribute("version") {
            None => return Err(self.fail(root, "<scene> needs a `version` attribute")),
            Some(v) if !v.starts_with('3') && !v.starts_with("2.") => {
                self.warn(
                    root,
                    format!(
                        "scene version {} (read as Mitsuba 3; older scenes may differ)",
                        one_line(v)
                    ),
                );
            }
            _ => {}
        }
        let mut b = SceneBuilder::new(self.path);
        let mut sensor = None;
        let mut integrator = None;
        // Mitsuba's default when no integrator is given is `path` with
        // max_depth -1 (our limit) and rr_depth 5
        let mut render = super::RenderDefaults {
            max_depth: crate::limits::MAX_DEPTH,
            ..Default::default()
        };
        let mut rr_depth = Some(5);
        for c in root.children().filter(|n| n.is_element()) {
            match c.tag_name().name() {
                "default" => self.default(c)?,
                "bsdf" | "texture" => {
                    if c.attribute("id").is_some() {
                        self.register(c)?;
                    } else {
                        self.warn(c, "a top-level plugin without an `id` is never used");
                    }
                }
                "integrator" => integrator = Some(c),
                "sensor" => {
                    if sensor.is_some() {
                        self.warn(c, "a second <sensor>: only the first renders");
                    } else {
                        sensor = Some(c);
                    }
                }
                "shape" => self.shape(c, &mut b)?,
                "emitter" => self.emitter(c, &mut b)?,
                "include" => {
                    return Err(
                        self.fail(c, "<include> is not part of the supported Mitsuba subset")
                    );
                }
                other => {
                    return Err(self.fail(
                        c,
                        format!(
                            "<{}> is not part of the supported Mitsuba subset",
                            one_line(other)
                        ),
                    ));
                }
            }
        }
        if let Some(node) = integrator {
            rr_depth = self.integrator(node, &mut render)?;
        }
        match sensor {
            Some(s) => self.sensor(s, &mut b, &mut render)?,
            None => b.scene_mut().resolution = [768, 576],
        }
        let mut scene = b.build();
        if let Some(rr) = rr_depth {
            render.rr_depth = rr;
        }
        scene.render = render;
        scene.warnings.append(&mut self.warnings);
        Ok(scene)
    }

    fn integrator(
        &mut self,
        node: Node<'a, 'i>,
        render: &mut super::RenderDefaults,
    ) -> Result<Option<u32>> {
        let kind = self.need_attr(node, "type")?;
        let mut p = self.params(node)?;
        match kind.as_str() {
            "path" => {}
            "volpath" | "prbvolpath" => self.warn(
                node,
                format!("integrator `{kind}` read as `path` (no participating media)"),
            ),
            other => {
                return Err(self.fail(
                    node,
                    format!(
                        "integrator `{}` is not in the subset (expected path)",
                        one_line(other)
                    ),
                ));
            }
        }
        if let Some((d, line)) = p.number("max_depth") {
            if d == -1.0 {
                render.max_depth = crate::limits::MAX_DEPTH;
            } else if d >= 1.0 && d.fract() == 0.0 {
                let ours = d as u64 - 1;
                check_max_depth(ours).map_err(|m| {
                    Error::input(self.path, Some(line), format!("max_depth {d}: {m}"))
                })?;
                render.max_depth = ours as u32;
            } else {
                return Err(Error::input(
                    self.path,
                    Some(line),
                    format!("max_depth {d}: expected -1 (no limit) or a whole number >= 1"),
                ));
            }
        }
        let mut rr = Some(5);
        if let Some((d, line)) = p.number("rr_depth") {
            if !(d >= 1.0 && d.fract() == 0.0 && d <= u32::MAX as f64) {
                return Err(Error::input(
                    self.path,
                    Some(line),
                    format!("rr_depth {d}: expected a whole number >= 1"),
                ));
            }
            rr = Some(d as u32);
        }
        if let Some((true, line)) = p.boolean("hide_emitters") {
            self.warnings.push(format!(
                "{}:{line}: hide_emitters is not supported: emitters seen directly are shown",
                self.path.display()
            ));
        }
        self.finish(p);
        Ok(rr)
    }

    fn sensor(
        &mut self,
        node: Node<'a, 'i>,
        b: &mut SceneBuilder,
        render: &mut super::RenderDefaults,
    ) -> Result<()> {
        let scene = b.scene_mut();
        let kind = self.need_attr(node, "type")?;
        if kind != "perspective" && kind != "thinlens" {
            return Err(self.fail(
                node,
                format!(
                    "sensor `{}` is not in the subset (expected perspective or thinlens)",
                    one_line(&kind)
                ),
            ));
        }
        let mut p = self.params(node)?;
        let mut size = [768u64, 576];
        if let Some(film) = p.object("film").or_else(|| p.unnamed_of("film")) {
            let ft = self.need_attr(film, "type")?;
            if ft != "hdrfilm" {
                self.warn(film, format!("film `{}` read as hdrfilm", one_line(&ft)));
            }
            let mut fp = self.params(film)?;
            for (k, key) in ["width", "height"].iter().enumerate() {
                if let Some((v, line)) = fp.number(key) {
                    if !(v >= 1.0 && v.fract() == 0.0) {
                        return Err(Error::input(
                            self.path,
                            Some(line),
                            format!("film {key} {v}: expected a whole number >= 1"),
                        ));
                    }
                    size[k] = v as u64;
                }
            }
            if let Some(f) = fp.object("rfilter").or_else(|| fp.unnamed_of("rfilter")) {
                let t = f.attribute("type").unwrap_or("");
                if t != "box" {
                    self.warn(
                        f,
                        format!(
                            "rfilter `{}`: embertrace uses a box filter (images are a little sharper than Mitsuba's)",
                            one_line(t)
                        ),
                    );
                }
            }
            self.finish(fp);
        }
        check_resolution(size[0], size[1])
            .map_err(|m| Error::input(self.path, Some(self.line(node)), m))?;
        scene.resolution = [size[0] as u32, size[1] as u32];
        if let Some(s) = p.object("sampler").or_else(|| p.unnamed_of("sampler")) {
            let mut sp = self.params(s)?;
            if let Some((n, line)) = sp.number("sample_count") {
                if !(n >= 1.0 && n.fract() == 0.0) {
                    return Err(Error::input(
                        self.path,
                        Some(line),
                        format!("sample_count {n}: expected a whole number >= 1"),
                    ));
                }
                check_spp(n as u64).map_err(|m| {
                    Error::input(self.path, Some(line), format!("sample_count: {m}"))
                })?;
                render.spp = n as u32;
            } else {
                render.spp = 4;
            }
            if let Some((seed, _)) = sp.number("seed") {
                render.seed = seed.abs() as u64;
            }
            self.finish(sp);
        }
        let m = p.matrix("to_world").unwrap_or(DAffine3::IDENTITY);
        let origin = m.translation;
        let dir = (m.matrix3 * DVec3::Z).normalize_or_zero();
        let up = m.matrix3 * DVec3::Y;
        if dir == DVec3::ZERO || up.cross(dir) == DVec3::ZERO {
            return Err(self.fail(
                node,
                "sensor to_world: the view direction or up is degenerate",
            ));
        }
        if m.matrix3.determinant() < 0.0 {
            self.warn(
                node,
                "sensor to_world mirrors the image; embertrace renders it unmirrored",
            );
        }
        if origin.abs().max_element() > MAX_COORDINATE as f64 {
            return Err(self.fail(
                node,
                format!("sensor origin {origin} is beyond +-{MAX_COORDINATE:e}"),
            ));
        }
        let fov = match p.number("fov") {
            Some((f, line)) => {
                if !(f > 0.0 && f < 180.0) {
                    return Err(Error::input(
                        self.path,
                        Some(line),
                        format!("fov {f}: expected degrees in (0, 180)"),
                    ));
                }
                f
            }
            None => {
                return Err(self.fail(
                    node,
                    "sensor needs `fov` (focal_length is not in the subset)",
                ));
            }
        };
        let axis = p.text("fov_axis").unwrap_or_else(|| "x".into());
        let (w, h) = (size[0] as f64, size[1] as f64);
        let t = (fov.to_radians() / 2.0).tan();
        let ty = match axis.as_str() {
            "x" => t * h / w,
            "y" => t,
            "diagonal" => t * h / (w * w + h * h).sqrt(),
            "smaller" if w < h => t * h / w,
            "smaller" => t,
            "larger" if w > h => t * h / w,
            "larger" => t,
            other => {
                return Err(self.fail(
                    node,
                    format!(
                        "fov_axis `{}` (expected x, y, diagonal, smaller or larger)",
                        one_line(other)
                    ),
                ));
            }
        };
        b.set_camera(WorldCamera {
            origin,
            target: origin + dir,
            up: up.as_vec3(),
            fov_y: (2.0 * ty.atan()).to_degrees() as f32,
        });
        let scene = b.scene_mut();
        if kind == "thinlens" {
            let radius = p.number("aperture_radius").map_or(0.03, |v| v.0);
            let focus = p.number("focus_distance").map_or(0.0, |v| v.0);
            scene.lens = ThinLens::new(radius as f32, focus as f32)
                .map_err(|e| self.fail(node, format!("thinlens: {e}")))?;
        }
        for key in ["near_clip", "far_clip"] {
            p.number(key);
        }
        self.finish(p);
        Ok(())
    }

    /// A shape's BSDF: a child `<bsdf>` or `<ref>`, or Mitsuba's default
    /// (diffuse 0.5).
    fn shape_material(&mut self, p: &mut Params<'a, 'i>) -> Result<Material> {
        match p.unnamed_of("bsdf") {
            Some(node) => self.bsdf(node),
            None => Ok(Material::diffuse("default", Vec3::splat(0.5))),
        }
    }

    fn shape(&mut self, node: Node<'a, 'i>, b: &mut SceneBuilder) -> Result<()> {
        let kind = self.need_attr(node, "type")?;
        let at = self.line(node);
        let line = Some(at);
        let mut p = self.params(node)?;
        let mut material = self.shape_material(&mut p)?;
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
                if let Some(why) = super::not_a_file(&full) {
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
                return b.add_sphere(c, r, material, line);
            }
            other => {
                return Err(self.fail(
                    node,
                    format!(
                        "shape `{}` is not in the subset (expected obj, ply, rectangle, cube, sphere or disk)",
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
        b.add_mesh_matrix(mesh, m, line)
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

    fn texture(&mut self, node: Node<'a, 'i>) -> Result<Arc<ImageTexture>> {
        let kind = self.need_attr(node, "type")?;
        if kind != "bitmap" {
            return Err(self.fail(
                node,
                format!(
                    "texture `{}` is not in the subset (expected bitmap)",
                    one_line(&kind)
                ),
            ));
        }
        let mut p = self.params(node)?;
        let file = p
            .text("filename")
            .ok_or_else(|| self.fail(node, "bitmap needs a `filename` string"))?;
        for key in ["filter_type", "wrap_mode"] {
            if let Some(v) = p.text(key) {
                let ours = if key == "filter_type" {
                    "bilinear"
                } else {
                    "repeat"
                };
                if v != ours {
                    self.warn(
                        node,
                        format!("bitmap {key} `{}`: embertrace uses {ours}", one_line(&v)),
                    );
                }
            }
        }
        self.finish(p);
        let full = self.dir.join(&file);
        if let Some(t) = self.textures.get(&full) {
            return Ok(t.clone());
        }
        if let Some(why) = super::not_a_file(&full) {
            return Err(self.fail(node, format!("bitmap `{}` {why}", one_line(&file))));
        }
        let t = Arc::new(ImageTexture::load(&full)?);
        self.textures.insert(full, t.clone());
        Ok(t)
    }

    /// A colour-like parameter that may be a bitmap: (value, texture).
    fn reflectance(
        &mut self,
        p: &mut Params<'a, 'i>,
        key: &str,
        default: f32,
    ) -> Result<(Vec3, Option<Arc<ImageTexture>>)> {
        if let Some(node) = p.object(key) {
            if node.tag_name().name() != "texture" {
                return Err(self.fail(node, format!("`{key}` must be a colour or a texture")));
            }
            return Ok((Vec3::splat(default), Some(self.texture(node)?)));
        }
        let c = p.colour(self, key)?.unwrap_or(Vec3::splat(default));
        if c.max_element() > 1.0 {
            return Err(Error::input(
                self.path,
                Some(p.line),
                format!("{}: `{key}` must be at most 1, got {c}", p.owner),
            ));
        }
        Ok((c, None))
    }

    fn ior(&self, p: &mut Params<'a, 'i>, key: &str, default: f32) -> Result<f32> {
        match p.take(key) {
            None => Ok(default),
            Some((Value::Number(v), _)) if v > 0.0 => Ok(v as f32),
            Some((Value::Text(name), line)) => NAMED_IOR
                .iter()
                .find(|(n, _)| *n == name.to_ascii_lowercase())
                .map(|(_, v)| *v)
                .ok_or_else(|| {
                    Error::input(
                        self.path,
                        Some(line),
                        format!(
                            "{key}: unknown material `{}` (give a number)",
                            one_line(&name)
                        ),
                    )
                }),
            Some((_, line)) => Err(Error::input(
                self.path,
                Some(line),
                format!("{key}: expected a positive number or a material name"),
            )),
        }
    }

    fn distribution(&self, p: &mut Params<'a, 'i>) -> Result<Distribution> {
        match p.text("distribution").as_deref() {
            None | Some("beckmann") => Ok(Distribution::Beckmann),
            Some("ggx") => Ok(Distribution::Ggx),
            Some(other) => Err(Error::input(
                self.path,
                Some(p.line),
                format!(
                    "distribution `{}` (expected beckmann or ggx)",
                    one_line(other)
                ),
            )),
        }
    }

    fn alpha(&self, p: &mut Params<'a, 'i>) -> Result<f32> {
        let a = p.number("alpha").map_or(0.1, |v| v.0) as f32;
        if let (Some((u, _)), Some((v, _))) = (p.number("alpha_u"), p.number("alpha_v")) {
            if u != v {
                return Err(Error::input(
                    self.path,
                    Some(p.line),
                    "anisotropic roughness (alpha_u != alpha_v) is not in the subset",
                ));
            }
            return Ok(u as f32);
        }
        Ok(a)
    }

    fn bsdf(&mut self, node: Node<'a, 'i>) -> Result<Material> {
        if node.tag_name().name() != "bsdf" {
            return Err(self.fail(node, "expected a <bsdf>"));
        }
        let kind = self.need_attr(node, "type")?;
        let name = node
            .attribute("id")
            .map_or_else(|| kind.clone(), str::to_string);
        let mut p = self.params(node)?;
        let mut texture = None;
        let air = 1.00028;
        let bsdf = match kind.as_str() {
            "twosided" => {
                let inner = p
                    .unnamed_of("bsdf")
                    .ok_or_else(|| self.fail(node, "twosided needs one nested <bsdf>"))?;
                if p.unnamed_of("bsdf").is_some() {
                    return Err(self.fail(
                        node,
                        "twosided with two different sides is not in the subset",
                    ));
                }
                self.finish(p);
                // embertrace's surfaces scatter on both sides already
                let mut m = self.bsdf(inner)?;
                m.name = name;
                return Ok(m);
            }
            "diffuse" => {
                let (albedo, t) = self.reflectance(&mut p, "reflectance", 0.5)?;
                texture = t;
                Bsdf::Diffuse(Diffuse { albedo })
            }
            "conductor" | "roughconductor" => {
                let material = p.text("material").unwrap_or_else(|| "none".into());
                let eta = p.colour(self, "eta")?;
                let k = p.colour(self, "k")?;
                let (eta, k) = match (eta, k) {
                    (Some(e), Some(k)) => (e, k),
                    (None, None) if material == "none" => (Vec3::ZERO, Vec3::ONE),
                    (None, None) => {
                        return Err(self.fail(
                            node,
                            format!(
                                "conductor material `{}`: named metals need spectral data; give `eta` and `k` as rgb",
                                one_line(&material)
                            ),
                        ));
                    }
                    _ => return Err(self.fail(node, "conductor: give both `eta` and `k`")),
                };
                self.white(&mut p, node, "specular_reflectance")?;
                let microfacet = if kind == "conductor" {
                    Microfacet::new(Distribution::Ggx, 0.0)
                } else {
                    Microfacet::new(self.distribution(&mut p)?, self.alpha(&mut p)?)
                };
                p.boolean("sample_visible");
                Bsdf::Conductor(Conductor { eta, k, microfacet })
            }
            "dielectric" => {
                let int = self.ior(&mut p, "int_ior", 1.5046)?;
                let ext = self.ior(&mut p, "ext_ior", air)?;
                let (reflectance, _) = self.reflectance(&mut p, "specular_reflectance", 1.0)?;
                let (transmittance, _) = self.reflectance(&mut p, "specular_transmittance", 1.0)?;
                Bsdf::Glass(Glass {
                    ior: int / ext,
                    reflectance,
                    transmittance,
                })
            }
            "plastic" | "roughplastic" => {
                let int = self.ior(&mut p, "int_ior", 1.49)?;
                let ext = self.ior(&mut p, "ext_ior", air)?;
                let (diffuse, t) = self.reflectance(&mut p, "diffuse_reflectance", 0.5)?;
                texture = t;
                self.white(&mut p, node, "specular_reflectance")?;
                let nonlinear = p.boolean("nonlinear").is_some_and(|v| v.0);
                let (distribution, alpha) = if kind == "plastic" {
                    (Distribution::Ggx, 0.0)
                } else {
                    p.boolean("sample_visible");
                    (self.distribution(&mut p)?, self.alpha(&mut p)?)
                };
                Bsdf::Plastic(
                    Plastic::with_options(diffuse, int / ext, alpha, distribution, nonlinear)
                        .map_err(|e| self.fail(node, format!("{kind}: {e}")))?,
                )
            }
            other => {
                return Err(self.fail(
                    node,
                    format!(
                        "bsdf `{}` is not in the subset (expected diffuse, conductor, roughconductor, dielectric, plastic, roughplastic or twosided)",
                        one_line(other)
                    ),
                ));
            }
        };
        self.finish(p);
        bsdf.validate()
            .map_err(|e| self.fail(node, format!("bsdf `{kind}`: {e}")))?;
        Ok(Material {
            name,
            bsdf,
            texture,
            emission: Vec3::ZERO,
            two_sided: false,
        })
    }

    /// A `specular_reflectance` that embertrace has no scale for: only 1.
    fn white(&mut self, p: &mut Params<'a, 'i>, node: Node, key: &str) -> Result<()> {
        if let Some(c) = p.colour(self, key)? {
            if c != Vec3::ONE {
                self.warn(
                    node,
                    format!("`{key}` {c} is read as 1 (no specular scale in this BSDF)"),
                );
            }
        }
        Ok(())
    }

    fn emitter(&mut self, node: Node<'a, 'i>, b: &mut SceneBuilder) -> Result<()> {
        let kind = self.need_attr(node, "type")?;
        let mut p = self.params(node)?;
        let mut point_light = None;
        let scene = b.scene_mut();
        match kind.as_str() {
            "point" => {
                let at = match p.vector("position") {
                    Some(v) => v,
                    None => {
                        p.matrix("to_world")
                            .unwrap_or(DAffine3::IDENTITY)
                            .translation
                    }
                };
                if at.abs().max_element() > MAX_COORDINATE as f64 {
                    return Err(self.fail(
                        node,
                        format!("point light at {at}: beyond +-{MAX_COORDINATE:e}"),
                    ));
                }
                let i = p.colour(self, "intensity")?.unwrap_or(Vec3::ONE);
                point_light = Some((at, PointLight::new(Vec3::ZERO, i)));
            }
            "directional" => {
                let d = match p.vector("direction") {
                    Some(v) => v,
                    None => p.matrix("to_world").unwrap_or(DAffine3::IDENTITY).matrix3 * DVec3::Z,
                }
                .as_vec3();
                let e = p.colour(self, "irradiance")?.unwrap_or(Vec3::ONE);
                let light = DirectionalLight::new(d, e).ok_or_else(|| {
                    self.fail(
                        node,
                        format!("directional light: direction {d} must be finite and non-zero"),
                    )
                })?;
                scene.directional_lights.push(light);
            }
            "constant" => {
                let r = p.colour(self, "radiance")?.unwrap_or(Vec3::ONE);
                scene.environment = Some(scene.environment.unwrap_or(Vec3::ZERO) + r);
            }
            "envmap" => {
                let file = p
                    .text("filename")
                    .ok_or_else(|| self.fail(node, "envmap needs a `filename` string"))?;
                let scale = p.number("scale").map_or(1.0, |v| v.0) as f32;
                if !(scale >= 0.0) {
                    return Err(self.fail(node, format!("envmap scale {scale}: expected >= 0")));
                }
                if let Some(m) = p.matrix("to_world") {
                    if !m.abs_diff_eq(DAffine3::IDENTITY, 1e-6) {
                        return Err(self.fail(
                            node,
                            "envmap to_world other than the identity is not in the subset",
                        ));
                    }
                }
                if scene.environment_map.is_some() {
                    return Err(self.fail(node, "a second envmap (one image map per scene)"));
                }
                let full = self.dir.join(&file);
                if let Some(why) = super::not_a_file(&full) {
                    return Err(self.fail(node, format!("envmap `{}` {why}", one_line(&file))));
                }
                scene.environment_map = Some(EnvironmentMap::load(&full, Vec3::splat(scale))?);
            }
            "area" => {
                return Err(self.fail(node, "an area emitter belongs inside a <shape>"));
            }
            other => {
                return Err(self.fail(
                    node,
                    format!(
                        "emitter `{}` is not in the subset (expected area, point, directional, constant or envmap)",
                        one_line(other)
                    ),
                ));
            }
        }
        if let Some((at, light)) = point_light {
            b.add_point_light(at, light);
        }
        self.finish(p);
        Ok(())
    }
}

impl<'a, 'i> Params<'a, 'i> {
    /// Take parameter `name` if `fits` its value; a parameter of that name
    /// that does not fit is marked taken and reported as a wrong type.
    fn take_as<T>(
        &mut self,
        name: &str,
        expected: &str,
        fits: impl Fn(&Value<'a, 'i>) -> Option<T>,
    ) -> Option<(T, usize)> {
        let item = self
            .items
            .iter_mut()
            .find(|(n, _, _, taken)| n == name && !taken)?;
        item.3 = true;
        match fits(&item.1) {
            Some(v) => Some((v, item.2)),
            None => {
                self.mistyped
                    .push((name.to_string(), expected.to_string(), item.2));
                None
            }
        }
    }

    fn take(&mut self, name: &str) -> Option<(Value<'a, 'i>, usize)> {
        self.take_as(name, "", |v| Some(v.clone()))
    }

    fn number(&mut self, name: &str) -> Option<(f64, usize)> {
        self.take_as(name, "a <float> or <integer>", |v| match v {
            Value::Number(x) => Some(*x),
            _ => None,
        })
    }

    fn boolean(&mut self, name: &str) -> Option<(bool, usize)> {
        self.take_as(name, "a <boolean>", |v| match v {
            Value::Bool(x) => Some(*x),
            _ => None,
        })
    }

    fn text(&mut self, name: &str) -> Option<String> {
        self.take_as(name, "a <string>", |v| match v {
            Value::Text(x) => Some(x.clone()),
            _ => None,
        })
        .map(|v| v.0)
    }

    fn vector(&mut self, name: &str) -> Option<DVec3> {
        self.take_as(name, "a <point> or <vector>", |v| match v {
            Value::Vector(x) => Some(*x),
            _ => None,
        })
        .map(|v| v.0)
    }

    fn matrix(&mut self, name: &str) -> Option<DAffine3> {
        self.take_as(name, "a <transform>", |v| match v {
            Value::Matrix(x) => Some(*x),
            _ => None,
        })
        .map(|v| v.0)
    }

    /// A nested plugin named `name`; a parameter of that name of another
    /// kind is left for the other getters.
    fn object(&mut self, name: &str) -> Option<Node<'a, 'i>> {
        let is_object = self
            .items
            .iter()
            .any(|(n, v, _, taken)| n == name && !taken && matches!(v, Value::Object(_)));
        if !is_object {
            return None;
        }
        self.take_as(name, "a nested plugin", |v| match v {
            Value::Object(n) => Some(*n),
            _ => None,
        })
        .map(|v| v.0)
    }

    /// The first unnamed nested plugin with tag `tag`, not yet taken.
    fn unnamed_of(&mut self, tag: &str) -> Option<Node<'a, 'i>> {
        let item = self
            .unnamed
            .iter_mut()
            .find(|(n, taken)| n.tag_name().name() == tag && !taken)?;
        item.1 = true;
        Some(item.0)
    }

    /// A colour-like parameter (`rgb`, `spectrum` or `float`), >= 0.
    fn colour(&mut self, loader: &Loader, name: &str) -> Result<Option<Vec3>> {
        match self.take(name) {
            None => Ok(None),
            Some((Value::Colour(c), _)) => Ok(Some(c)),
            Some((Value::Number(v), _)) if v >= 0.0 => Ok(Some(Vec3::splat(v as f32))),
            Some((_, line)) => Err(Error::input(
                loader.path,
                Some(line),
                format!(
                    "`{name}` of {}: expected an rgb value or a non-negative float",
                    self.owner
                ),
            )),
        }
    }
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
