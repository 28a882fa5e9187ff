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
//! - **`<integrator type="path">`**, `"volpath"` and `"prbvolpath"` (the
//!   same without media; their shadow rays, like ours, pass through an
//!   alpha mask's holes, where Mitsuba 3.9.1's `path` stops them): `max_depth` (Mitsuba counts path segments, so
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
//!   [`DISK_SEGMENTS`](shapes::DISK_SEGMENTS) triangles: its area is short
//!   of pi by a relative 2e-4 (a named, documented bias; Mitsuba's disk is
//!   analytic).
//! - **BSDFs** `diffuse`, `conductor`, `roughconductor`, `dielectric`,
//!   `plastic`, `roughplastic`, `twosided`, with `rgb`, `float`, `spectrum`
//!   (one value) and `bitmap` textures. Indices of refraction take numbers or
//!   Mitsuba's names (`bk7`, `air`, `water`, ... from Mitsuba's table).
//!   Conductors take `eta` and `k`, a `material` of Mitsuba 3's named
//!   conductors (`Au`, `Cu`, ...: the RGB values its RGB variants use,
//!   [`crate::bsdf::named_conductors`]) or `material="none"`, the perfect
//!   mirror.
//! - **Emitters** `area` (in a shape), `point`, `directional`, `constant`,
//!   `envmap` (`filename`, `scale`; `to_world` must be the identity: our
//!   map is in Mitsuba's default orientation).
//!
//! The loader and the scene's structure are here; each concern has a file:
//! `params` (a plugin's parameters), `transform`, `sensor` (with its film
//! and sampler), `shapes`, `materials` (BSDFs and textures) and `emitters`.
//!
//! What the file leaves unsaid is read with Mitsuba's meaning:
//!
//! - A shape without a `<bsdf>` is a one-sided diffuse of reflectance 0.5,
//!   or 0 when it has an emitter (Mitsuba's `Shape` constructor).
//! - Mitsuba's reflective BSDFs (`diffuse`, the conductors, the plastics)
//!   are one-sided, black seen from behind, unless wrapped in `twosided`
//!   ([`crate::scene::Material::one_sided`]); `dielectric` is two-sided.
//! - `normalmap` and `bumpmap` honour `flip_invalid_normals` and
//!   `use_shadowing_function`, both on by default as in Mitsuba 3.7.1 and
//!   later ([`crate::scene::Maps::flip_invalid`], [`crate::scene::Maps::shadowing`]).
//! - A `sphere` keeps its `to_world` rotation for its texture coordinates:
//!   the pole is its local `+z` ([`crate::scene::Scene::sphere_uv_frames`]).
//! - Parameters read and not honoured are warnings naming the file and
//!   line (`near_clip`, `far_clip` away from their defaults; `flip_normals`
//!   on a sphere); `sample_visible` changes only the noise and is read
//!   silently. A render's `-q` never hides a warning.

mod emitters;
mod materials;
mod params;
mod sensor;
mod shapes;
mod transform;

use super::{Scene, SceneBuilder};
use crate::error::{Error, Result, one_line};
use crate::limits::check_max_depth;
use crate::math::Vec3;
use crate::texture::ImageTexture;
use glam::DVec3;
use roxmltree::{Document, Node};
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;

struct Loader<'a, 'i> {
    path: &'a Path,
    dir: PathBuf,
    defaults: HashMap<String, String>,
    ids: HashMap<String, Node<'a, 'i>>,
    /// Shapegroups by id: their prototypes in the scene builder.
    groups: HashMap<String, u32>,
    /// Loaded bitmaps by file and `raw` flag.
    textures: HashMap<(PathBuf, bool), Arc<ImageTexture>>,
    warnings: Vec<String>,
    /// The BSDFs being read, outermost first: for the nesting bound and the
    /// cycle check.
    resolving: Vec<roxmltree::NodeId>,
    doc: &'a Document<'i>,
}

/// The deepest nesting of BSDFs a Mitsuba file may use. Real scenes nest two
/// or three (a `twosided` around a `bumpmap` around a BSDF); the bound keeps
/// a hostile file from overflowing the stack.
pub(super) const MAX_BSDF_NESTING: usize = 64;

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
        groups: HashMap::new(),
        textures: HashMap::new(),
        warnings: Vec::new(),
        resolving: Vec::new(),
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
        let mut render = crate::settings::RenderDefaults {
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
        render: &mut crate::settings::RenderDefaults,
    ) -> Result<Option<u32>> {
        let kind = self.need_attr(node, "type")?;
        let mut p = self.params(node)?;
        match kind.as_str() {
            // Without media (a `<medium>` is outside the subset, an error)
            // Mitsuba's volumetric path tracers trace what `path` traces, but
            // for one difference, where they agree with embertrace and `path`
            // does not: shadow rays go on through an alpha mask's holes.
            "path" | "volpath" | "prbvolpath" => {}
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
}
