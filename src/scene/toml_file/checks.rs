//! Line numbers of the TOML scene format's tables and values, the range checks every value passes, and `transform` tables.

use super::*;

/// Line (1-based) of byte `offset` in `text`.
/// (Counted in bytes: an offset inside a multi-byte character cannot panic.)
pub(super) fn line_of(text: &str, offset: usize) -> usize {
    let bytes = text.as_bytes();
    bytes[..offset.min(bytes.len())]
        .iter()
        .filter(|&&b| b == b'\n')
        .count()
        + 1
}

/// Lines (1-based) of the `[[table]]` headers named `name`, in order, for
/// messages. One pass over the text: a scene may list many tables.
pub(super) fn table_lines(text: &str, name: &str) -> Vec<usize> {
    let header = format!("[[{name}]]");
    text.lines()
        .enumerate()
        .filter(|(_, l)| l.trim_start().starts_with(&header))
        .map(|(n, _)| n + 1)
        .collect()
}

/// Check a spanned integer with `check` (from [`limits`]); errors at its line.
pub(super) fn check_spanned<T: Copy + Into<u64>>(
    path: &Path,
    text: &str,
    v: &Spanned<T>,
    check: fn(u64) -> std::result::Result<(), String>,
) -> Result<T> {
    let value = *v.get_ref();
    check(value.into()).map_err(|m| Error::input(path, Some(line_of(text, v.span().start)), m))?;
    Ok(value)
}

pub(super) fn check_vec(path: &Path, line: Option<usize>, what: &str, v: Vec3) -> Result<Vec3> {
    if v.is_finite() {
        Ok(v)
    } else {
        Err(Error::input(
            path,
            line,
            format!("{what} must be finite, got {v}"),
        ))
    }
}

/// A world position: finite and within Embree's range.
pub(super) fn check_point(
    path: &Path,
    line: Option<usize>,
    what: &str,
    p: [f64; 3],
) -> Result<DVec3> {
    let v = DVec3::from(p);
    if !v.is_finite() {
        return Err(Error::input(
            path,
            line,
            format!("{what} must be finite, got {v}"),
        ));
    }
    if v.abs().max_element() > MAX_COORDINATE as f64 {
        return Err(Error::input(
            path,
            line,
            format!("{what} must be within +-{MAX_COORDINATE:e} on every axis, got {v}"),
        ));
    }
    Ok(v)
}

pub(super) fn check_colour(path: &Path, line: Option<usize>, what: &str, c: Rgb) -> Result<Vec3> {
    let v = check_vec(path, line, what, c.0)?;
    if v.min_element() < 0.0 {
        return Err(Error::input(
            path,
            line,
            format!("{what} must be non-negative, got {v}"),
        ));
    }
    Ok(v)
}

/// Check and convert a `transform = {...}` table.
pub(super) fn parse_transform(
    path: &Path,
    line: Option<usize>,
    t: Option<&TransformToml>,
) -> Result<Transform> {
    let mut transform = Transform::default();
    let Some(t) = t else {
        return Ok(transform);
    };
    if let Some(s) = t.scale {
        transform.scale = check_vec(path, line, "transform.scale", s.0)?.as_dvec3();
        if transform.scale.x * transform.scale.y * transform.scale.z == 0.0 {
            return Err(Error::input(
                path,
                line,
                "transform.scale must be non-zero on every axis",
            ));
        }
    }
    if let Some(Exact(r)) = t.rotate {
        let axis = DVec3::new(r[0], r[1], r[2]);
        if axis.length() == 0.0 || !axis.is_finite() || !r[3].is_finite() {
            return Err(Error::input(
                path,
                line,
                "transform.rotate must be [ax, ay, az, degrees] with a non-zero axis",
            ));
        }
        transform.rotate = Some((axis, r[3]));
    }
    if let Some(Exact(tr)) = t.translate {
        // finite is enough: what a translation takes beyond Embree's range
        // is dropped with a warning naming the mesh, as for any transform
        let v = DVec3::from(tr);
        if !v.is_finite() {
            return Err(Error::input(
                path,
                line,
                format!("transform.translate must be finite, got {v}"),
            ));
        }
        transform.translate = v;
    }
    Ok(transform)
}

/// The affine map of a row-major 4 x 4 `matrix` (an instance's `matrix`
/// key): finite, with a last row of `[0, 0, 0, 1]`.
pub(super) fn affine_from_rows(m: &[f64; 16]) -> std::result::Result<glam::DAffine3, String> {
    if !m.iter().all(|x| x.is_finite()) {
        return Err("matrix must be 16 finite numbers".to_string());
    }
    if m[12..] != [0.0, 0.0, 0.0, 1.0] {
        return Err(format!(
            "matrix must be affine: its last row must be [0, 0, 0, 1], got {:?}",
            &m[12..]
        ));
    }
    let col = |c: usize| DVec3::new(m[c], m[4 + c], m[8 + c]);
    Ok(glam::DAffine3::from_cols(col(0), col(1), col(2), col(3)))
}
