//! Value types of the TOML scene format that deserialise themselves: exact-length arrays, colours (one number or `[r, g, b]`) and textured parameters.

use super::*;

/// A fixed-length array: more elements, or fewer, are an error at its line
/// (serde's own arrays stop reading after `N`).
#[derive(Debug, Clone, Copy)]
pub(super) struct Exact<T, const N: usize>(pub(super) [T; N]);

impl<'de, T: Deserialize<'de> + Copy + Default, const N: usize> Deserialize<'de> for Exact<T, N> {
    fn deserialize<D: Deserializer<'de>>(d: D) -> std::result::Result<Self, D::Error> {
        let v = Vec::<T>::deserialize(d)?;
        if v.len() != N {
            return Err(de::Error::custom(format!(
                "expected an array of {N} numbers, got {}",
                v.len()
            )));
        }
        let mut out = [T::default(); N];
        out.copy_from_slice(&v);
        Ok(Exact(out))
    }
}

/// A colour-like value: one number or an `[r, g, b]` triple.
#[derive(Debug, Clone, Copy)]
pub(super) struct Rgb(pub(super) Vec3);

impl<'de> Deserialize<'de> for Rgb {
    fn deserialize<D: Deserializer<'de>>(d: D) -> std::result::Result<Self, D::Error> {
        struct V;
        impl<'de> Visitor<'de> for V {
            type Value = Rgb;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("a number or an [r, g, b] array of three numbers")
            }
            fn visit_f64<E: de::Error>(self, v: f64) -> std::result::Result<Rgb, E> {
                Ok(Rgb(Vec3::splat(v as f32)))
            }
            fn visit_i64<E: de::Error>(self, v: i64) -> std::result::Result<Rgb, E> {
                Ok(Rgb(Vec3::splat(v as f32)))
            }
            fn visit_u64<E: de::Error>(self, v: u64) -> std::result::Result<Rgb, E> {
                Ok(Rgb(Vec3::splat(v as f32)))
            }
            fn visit_seq<A: SeqAccess<'de>>(self, mut s: A) -> std::result::Result<Rgb, A::Error> {
                let mut c = [0.0f32; 3];
                for (i, slot) in c.iter_mut().enumerate() {
                    *slot = s
                        .next_element::<f32>()?
                        .ok_or_else(|| de::Error::invalid_length(i, &self))?;
                }
                if s.next_element::<f32>()?.is_some() {
                    return Err(de::Error::invalid_length(4, &self));
                }
                Ok(Rgb(Vec3::from(c)))
            }
        }
        d.deserialize_any(V)
    }
}

/// A material parameter: one number, an `[r, g, b]` triple, or a texture
/// `{ texture = "file.png", raw = false }`.
#[derive(Debug, Clone)]
pub(super) enum Param {
    Number(f32),
    Triple(Vec3),
    Texture { file: String, raw: Option<bool> },
}

impl<'de> Deserialize<'de> for Param {
    fn deserialize<D: Deserializer<'de>>(d: D) -> std::result::Result<Self, D::Error> {
        struct V;
        impl<'de> Visitor<'de> for V {
            type Value = Param;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str(
                    "a number, an [r, g, b] array of three numbers or { texture = \"file\" }",
                )
            }
            fn visit_f64<E: de::Error>(self, v: f64) -> std::result::Result<Param, E> {
                Ok(Param::Number(v as f32))
            }
            fn visit_i64<E: de::Error>(self, v: i64) -> std::result::Result<Param, E> {
                Ok(Param::Number(v as f32))
            }
            fn visit_u64<E: de::Error>(self, v: u64) -> std::result::Result<Param, E> {
                Ok(Param::Number(v as f32))
            }
            fn visit_seq<A: SeqAccess<'de>>(self, s: A) -> std::result::Result<Param, A::Error> {
                Rgb::deserialize(de::value::SeqAccessDeserializer::new(s))
                    .map(|c| Param::Triple(c.0))
            }
            fn visit_map<A: de::MapAccess<'de>>(
                self,
                mut m: A,
            ) -> std::result::Result<Param, A::Error> {
                let (mut file, mut raw) = (None, None);
                while let Some(key) = m.next_key::<String>()? {
                    match key.as_str() {
                        "texture" => file = Some(m.next_value::<String>()?),
                        "raw" => raw = Some(m.next_value::<bool>()?),
                        other => {
                            return Err(de::Error::unknown_field(other, &["texture", "raw"]));
                        }
                    }
                }
                let file = file.ok_or_else(|| de::Error::missing_field("texture"))?;
                Ok(Param::Texture { file, raw })
            }
        }
        d.deserialize_any(V)
    }
}
