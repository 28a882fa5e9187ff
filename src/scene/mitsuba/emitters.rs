//! Emitters outside shapes: `point`, `spot`, `directional`, `constant` and
//! `envmap` (an `area` emitter belongs inside a shape).

use super::Loader;
use crate::error::{Error, Result, one_line};
use crate::light::directional::DirectionalLight;
use crate::light::envmap::EnvironmentMap;
use crate::light::point::PointLight;
use crate::light::spot::{DEFAULT_CUTOFF_ANGLE, SpotLight};
use crate::limits::MAX_COORDINATE;
use crate::math::Vec3;
use crate::scene::SceneBuilder;
use glam::{DAffine3, DVec3};
use roxmltree::Node;

impl<'a, 'i> Loader<'a, 'i> {
    pub(super) fn emitter(&mut self, node: Node<'a, 'i>, b: &mut SceneBuilder) -> Result<()> {
        let kind = self.need_attr(node, "type")?;
        let mut p = self.params(node)?;
        let mut point_light = None;
        let mut spot_light = None;
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
            "spot" => {
                if let Some((_, line)) = p.take("texture") {
                    return Err(Error::input(
                        self.path,
                        Some(line),
                        "spot emitter: a projected `texture` is not in the subset (embertrace's spot light has no texture)",
                    ));
                }
                // local frame: at the origin, pointing along +z
                let m = p.matrix("to_world").unwrap_or(DAffine3::IDENTITY);
                let at = m.translation;
                if !at.is_finite() || at.abs().max_element() > MAX_COORDINATE as f64 {
                    return Err(self.fail(
                        node,
                        format!("spot light at {at}: beyond +-{MAX_COORDINATE:e}"),
                    ));
                }
                // angles about the axis are kept only by a rotation times a
                // uniform scale (Mitsuba's cone would turn elliptical)
                let l = m.matrix3;
                let g = l.transpose() * l;
                let s2 = g.x_axis.x;
                let conformal = s2 > 0.0
                    && (g - glam::DMat3::from_diagonal(DVec3::splat(s2)))
                        .to_cols_array()
                        .iter()
                        .all(|x| x.abs() <= 1e-6 * s2);
                if !conformal {
                    return Err(self.fail(
                        node,
                        "spot light: to_world must be a rotation and uniform scale (a lookat, rotate, translate)",
                    ));
                }
                let i = p.colour(self, "intensity")?.unwrap_or(Vec3::ONE);
                let cutoff = p
                    .number("cutoff_angle")
                    .map_or(DEFAULT_CUTOFF_ANGLE, |v| v.0 as f32);
                let beam = p.number("beam_width").map(|v| v.0 as f32);
                let light = SpotLight::new(Vec3::ZERO, (l * DVec3::Z).as_vec3(), i, cutoff, beam)
                    .map_err(|e| self.fail(node, e))?;
                spot_light = Some((at, light));
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
                if let Some(why) = crate::scene::not_a_file(&full) {
                    return Err(self.fail(node, format!("envmap `{}` {why}", one_line(&file))));
                }
                let map = EnvironmentMap::load(&full, Vec3::splat(scale))
                    .map_err(|e| self.fail(node, format!("envmap: {e}")))?;
                scene.environment_map = Some(map);
            }
            "area" => {
                return Err(self.fail(node, "an area emitter belongs inside a <shape>"));
            }
            other => {
                return Err(self.fail(
                    node,
                    format!(
                        "emitter `{}` is not in the subset (expected area, point, spot, directional, constant or envmap)",
                        one_line(other)
                    ),
                ));
            }
        }
        if let Some((at, light)) = point_light {
            b.add_point_light(at, light);
        }
        if let Some((at, light)) = spot_light {
            b.add_spot_light(at, light);
        }
        self.finish(p);
        Ok(())
    }
}
