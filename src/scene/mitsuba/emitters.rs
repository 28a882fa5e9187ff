//! Emitters outside shapes: `point`, `directional`, `constant` and
//! `envmap` (an `area` emitter belongs inside a shape).

use super::Loader;
use crate::error::{Result, one_line};
use crate::light::directional::DirectionalLight;
use crate::light::envmap::EnvironmentMap;
use crate::light::point::PointLight;
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
                if let Some(why) = crate::scene::not_a_file(&full) {
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
