//! A plugin's parameters (`<float>`, `<rgb>`, `<transform>`, nested
//! plugins and `<ref>`s), each taken at most once by the code that reads the
//! plugin; what is left, or was given the wrong type, is warned about.

use super::Loader;
use crate::error::{Error, Result, one_line};
use crate::math::Vec3;
use glam::{DAffine3, DVec3};
use roxmltree::Node;

/// A parameter's value.
#[derive(Debug, Clone)]
pub(super) enum Value<'a, 'i> {
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
pub(super) struct Params<'a, 'i> {
    /// (name, value, line, taken).
    items: Vec<(String, Value<'a, 'i>, usize, bool)>,
    /// Nested plugins without a `name` (a shape's bsdf and emitter).
    unnamed: Vec<(Node<'a, 'i>, bool)>,
    /// Parameters read with the wrong type: (name, expected, line).
    mistyped: Vec<(String, String, usize)>,
    /// `<tag type>` and its line, for messages.
    pub(super) owner: String,
    pub(super) line: usize,
}

impl<'a, 'i> Loader<'a, 'i> {
    /// The parameters of plugin element `node`.
    pub(super) fn params(&mut self, node: Node<'a, 'i>) -> Result<Params<'a, 'i>> {
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

    /// Warn about parameters nobody took, or took with the wrong type.
    pub(super) fn finish(&mut self, p: Params<'a, 'i>) {
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

    pub(super) fn take(&mut self, name: &str) -> Option<(Value<'a, 'i>, usize)> {
        self.take_as(name, "", |v| Some(v.clone()))
    }

    pub(super) fn number(&mut self, name: &str) -> Option<(f64, usize)> {
        self.take_as(name, "a <float> or <integer>", |v| match v {
            Value::Number(x) => Some(*x),
            _ => None,
        })
    }

    pub(super) fn boolean(&mut self, name: &str) -> Option<(bool, usize)> {
        self.take_as(name, "a <boolean>", |v| match v {
            Value::Bool(x) => Some(*x),
            _ => None,
        })
    }

    pub(super) fn text(&mut self, name: &str) -> Option<String> {
        self.take_as(name, "a <string>", |v| match v {
            Value::Text(x) => Some(x.clone()),
            _ => None,
        })
        .map(|v| v.0)
    }

    pub(super) fn vector(&mut self, name: &str) -> Option<DVec3> {
        self.take_as(name, "a <point> or <vector>", |v| match v {
            Value::Vector(x) => Some(*x),
            _ => None,
        })
        .map(|v| v.0)
    }

    pub(super) fn matrix(&mut self, name: &str) -> Option<DAffine3> {
        self.take_as(name, "a <transform>", |v| match v {
            Value::Matrix(x) => Some(*x),
            _ => None,
        })
        .map(|v| v.0)
    }

    /// A nested plugin named `name`; a parameter of that name of another
    /// kind is left for the other getters.
    pub(super) fn object(&mut self, name: &str) -> Option<Node<'a, 'i>> {
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

    /// The first nested plugin with tag `tag` not yet taken, named or not
    /// (a `bumpmap`'s texture takes any name).
    pub(super) fn any_of(&mut self, tag: &str) -> Option<Node<'a, 'i>> {
        if let Some(item) = self.items.iter_mut().find(|(_, v, _, taken)| {
            !taken && matches!(v, Value::Object(n) if n.tag_name().name() == tag)
        }) {
            item.3 = true;
            if let Value::Object(n) = item.1 {
                return Some(n);
            }
        }
        self.unnamed_of(tag)
    }

    /// The first unnamed nested plugin with tag `tag`, not yet taken.
    pub(super) fn unnamed_of(&mut self, tag: &str) -> Option<Node<'a, 'i>> {
        let item = self
            .unnamed
            .iter_mut()
            .find(|(n, taken)| n.tag_name().name() == tag && !taken)?;
        item.1 = true;
        Some(item.0)
    }

    /// A colour-like parameter (`rgb`, `spectrum` or `float`), >= 0.
    pub(super) fn colour(&mut self, loader: &Loader, name: &str) -> Result<Option<Vec3>> {
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
