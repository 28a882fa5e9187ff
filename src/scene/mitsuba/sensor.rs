//! `<sensor type="perspective">` and `"thinlens"`, with the `<film>` and
//! `<sampler>` inside it: the camera, the resolution and the sample count.

use super::Loader;
use crate::camera::ThinLens;
use crate::error::{Error, Result, one_line};
use crate::limits::{MAX_COORDINATE, check_resolution, check_spp};
use crate::scene::{SceneBuilder, WorldCamera};
use crate::settings::RenderDefaults;
use glam::{DAffine3, DVec3};
use roxmltree::Node;

impl<'a, 'i> Loader<'a, 'i> {
    pub(super) fn sensor(
        &mut self,
        node: Node<'a, 'i>,
        b: &mut SceneBuilder,
        render: &mut RenderDefaults,
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
        // (no view direction leaves it None as well)
        let Some(up) = WorldCamera::usable_up(origin, origin + dir, m.matrix3 * DVec3::Y) else {
            return Err(self.fail(
                node,
                "sensor to_world: the view direction or up is degenerate",
            ));
        };
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
            up,
            fov_y: (2.0 * ty.atan()).to_degrees() as f32,
        });
        let scene = b.scene_mut();
        if kind == "thinlens" {
            let radius = p.number("aperture_radius").map_or(0.03, |v| v.0);
            let focus = p.number("focus_distance").map_or(0.0, |v| v.0);
            scene.lens = ThinLens::new(radius as f32, focus as f32)
                .map_err(|e| self.fail(node, format!("thinlens: {e}")))?;
        }
        // Mitsuba's defaults clip nothing a scene of ordinary size has;
        // other values hide geometry, which embertrace does not
        for (key, default) in [("near_clip", 1e-2), ("far_clip", 1e4)] {
            if let Some((v, _)) = p.number(key) {
                let clips = if key == "near_clip" {
                    v > default
                } else {
                    v < default
                };
                if clips {
                    self.warn(
                        node,
                        format!("`{key}` {v} is not honoured: embertrace clips no geometry"),
                    );
                }
            }
        }
        self.finish(p);
        Ok(())
    }
}
