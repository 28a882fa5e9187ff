//! `<transform>`: `translate`, `rotate`, `scale`, `matrix` (4 x 4 or 3 x 3,
//! row-major) and `lookat`, composed in file order (each applies after the
//! ones before it).

use super::Loader;
use crate::error::{Result, one_line};
use crate::scene::WorldCamera;
use glam::{DAffine3, DMat3, DVec3};
use roxmltree::Node;

impl<'a, 'i> Loader<'a, 'i> {
    /// A `<transform>`: its operations composed in file order.
    pub(super) fn transform(&mut self, node: Node<'a, 'i>) -> Result<DAffine3> {
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
                    // the cameras' test (origin and target apart, up at
                    // least 1e-6 radians off the view), so that a lookat
                    // gives the same answer for a sensor as for a shape
                    let defined = WorldCamera::usable_up(origin, target, up).is_some();
                    if !defined || left == DVec3::ZERO {
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
}
