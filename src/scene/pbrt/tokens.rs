//! pbrt-v4's scene syntax: tokens (words, numbers, quoted strings,
//! brackets, `#` comments to the end of the line) and statements (a
//! keyword, its positional arguments, and `"type name" value` parameters),
//! each with its file and line.

use crate::error::{Error, Result};
use std::path::{Path, PathBuf};
use std::rc::Rc;

/// One token.
#[derive(Debug, Clone, PartialEq)]
pub(super) enum Tok {
    Word(String),
    Str(String),
    Num(f64),
    Open,
    Close,
}

/// A token and where it is.
#[derive(Debug, Clone)]
pub(super) struct Token {
    pub tok: Tok,
    pub line: usize,
}

/// The tokens of `text`, read from `path`.
pub(super) fn tokenize(path: &Path, text: &str) -> Result<Vec<Token>> {
    let mut out = Vec::new();
    let b = text.as_bytes();
    let (mut i, mut line) = (0, 1);
    while i < b.len() {
        let c = b[i];
        match c {
            b'\n' => {
                line += 1;
                i += 1;
            }
            c if c.is_ascii_whitespace() => i += 1,
            b'#' => {
                while i < b.len() && b[i] != b'\n' {
                    i += 1;
                }
            }
            b'[' | b']' => {
                out.push(Token {
                    tok: if c == b'[' { Tok::Open } else { Tok::Close },
                    line,
                });
                i += 1;
            }
            b'"' => {
                let start = i + 1;
                let mut j = start;
                while j < b.len() && b[j] != b'"' && b[j] != b'\n' {
                    j += 1;
                }
                if j >= b.len() || b[j] != b'"' {
                    return Err(Error::input(
                        path,
                        Some(line),
                        "a string without its closing quote",
                    ));
                }
                out.push(Token {
                    tok: Tok::Str(text[start..j].to_string()),
                    line,
                });
                i = j + 1;
            }
            _ => {
                let start = i;
                while i < b.len()
                    && !b[i].is_ascii_whitespace()
                    && !matches!(b[i], b'"' | b'[' | b']' | b'#')
                {
                    i += 1;
                }
                let word = &text[start..i];
                let first = word.as_bytes()[0];
                let tok = if first.is_ascii_digit() || matches!(first, b'-' | b'+' | b'.') {
                    let v: f64 = word.parse().map_err(|_| {
                        Error::input(
                            path,
                            Some(line),
                            format!("`{}` is not a number", crate::error::one_line(word)),
                        )
                    })?;
                    Tok::Num(v)
                } else {
                    Tok::Word(word.to_string())
                };
                out.push(Token { tok, line });
            }
        }
    }
    Ok(out)
}

/// A parameter's values.
#[derive(Debug, Clone, PartialEq)]
pub(super) enum Values {
    Nums(Vec<f64>),
    Strs(Vec<String>),
    Bools(Vec<bool>),
}

/// A `"type name" value` parameter.
#[derive(Debug, Clone)]
pub(super) struct Param {
    pub ty: String,
    pub name: String,
    pub values: Values,
}

/// A statement: keyword, positional arguments, parameters, and where.
#[derive(Debug, Clone)]
pub(super) struct Statement {
    pub keyword: String,
    pub strings: Vec<String>,
    pub numbers: Vec<f64>,
    pub params: Vec<Param>,
    pub file: Rc<PathBuf>,
    pub line: usize,
}

/// How many positional strings and numbers a keyword takes, and whether
/// parameters follow.
fn shape_of(keyword: &str) -> Option<(usize, usize, bool)> {
    Some(match keyword {
        "Shape" | "Camera" | "Film" | "Sampler" | "Integrator" | "PixelFilter" | "Accelerator"
        | "Material" | "MakeNamedMaterial" | "LightSource" | "AreaLightSource"
        | "MakeNamedMedium" | "Attribute" => (1, 0, true),
        "Texture" => (3, 0, true),
        "NamedMaterial" | "CoordinateSystem" | "CoordSysTransform" | "ObjectBegin"
        | "ObjectInstance" | "Include" | "Import" | "ColorSpace" => (1, 0, false),
        "Option" => (0, 0, true),
        "Translate" | "Scale" => (0, 3, false),
        "Rotate" => (0, 4, false),
        "LookAt" => (0, 9, false),
        "Transform" | "ConcatTransform" => (0, 16, false),
        "WorldBegin" | "WorldEnd" | "AttributeBegin" | "AttributeEnd" | "TransformBegin"
        | "TransformEnd" | "ObjectEnd" | "ReverseOrientation" | "Identity" => (0, 0, false),
        "MediumInterface" | "TransformTimes" | "ActiveTransform" => (0, 0, false),
        _ => return None,
    })
}

/// The statements of `tokens`, from `file`.
pub(super) fn statements(file: &Rc<PathBuf>, tokens: &[Token]) -> Result<Vec<Statement>> {
    let fail = |line: usize, m: String| Error::input(file, Some(line), m);
    let mut out = Vec::new();
    let mut i = 0;
    while i < tokens.len() {
        let line = tokens[i].line;
        let Tok::Word(keyword) = &tokens[i].tok else {
            return Err(fail(line, "expected a statement keyword".into()));
        };
        let Some((ns, nn, has_params)) = shape_of(keyword) else {
            return Err(fail(
                line,
                format!("unknown statement `{}`", crate::error::one_line(keyword)),
            ));
        };
        i += 1;
        let mut st = Statement {
            keyword: keyword.clone(),
            strings: Vec::new(),
            numbers: Vec::new(),
            params: Vec::new(),
            file: file.clone(),
            line,
        };
        // MediumInterface and the timing statements take what follows
        if matches!(
            keyword.as_str(),
            "MediumInterface" | "TransformTimes" | "ActiveTransform"
        ) {
            while i < tokens.len() && !matches!(tokens[i].tok, Tok::Word(_)) {
                i += 1;
            }
            out.push(st);
            continue;
        }
        for _ in 0..ns {
            match tokens.get(i).map(|t| &t.tok) {
                Some(Tok::Str(s)) => st.strings.push(s.clone()),
                _ => return Err(fail(line, format!("`{keyword}` expects a quoted string"))),
            }
            i += 1;
        }
        if nn > 0 {
            let bracketed = matches!(tokens.get(i).map(|t| &t.tok), Some(Tok::Open));
            if bracketed {
                i += 1;
            }
            for _ in 0..nn {
                match tokens.get(i).map(|t| &t.tok) {
                    Some(Tok::Num(v)) => st.numbers.push(*v),
                    _ => return Err(fail(line, format!("`{keyword}` expects {nn} numbers"))),
                }
                i += 1;
            }
            if bracketed {
                match tokens.get(i).map(|t| &t.tok) {
                    Some(Tok::Close) => i += 1,
                    _ => {
                        return Err(fail(
                            line,
                            format!("`{keyword}`: expected `]` after {nn} numbers"),
                        ));
                    }
                }
            }
        }
        if has_params {
            while let Some(Tok::Str(decl)) = tokens.get(i).map(|t| &t.tok) {
                let pline = tokens[i].line;
                let mut words = decl.split_whitespace();
                let (Some(ty), Some(name), None) = (words.next(), words.next(), words.next())
                else {
                    return Err(fail(
                        pline,
                        format!(
                            "`{}` is not a parameter declaration (\"type name\")",
                            crate::error::one_line(decl)
                        ),
                    ));
                };
                i += 1;
                let mut raw = Vec::new();
                match tokens.get(i).map(|t| &t.tok) {
                    Some(Tok::Open) => {
                        i += 1;
                        loop {
                            match tokens.get(i).map(|t| &t.tok) {
                                Some(Tok::Close) => {
                                    i += 1;
                                    break;
                                }
                                Some(Tok::Open) | None => {
                                    return Err(fail(
                                        pline,
                                        format!("parameter `{name}`: unclosed `[`"),
                                    ));
                                }
                                Some(t) => raw.push(t.clone()),
                            }
                            i += 1;
                        }
                    }
                    Some(t @ (Tok::Num(_) | Tok::Str(_) | Tok::Word(_))) => {
                        raw.push(t.clone());
                        i += 1;
                    }
                    _ => return Err(fail(pline, format!("parameter `{name}` has no value"))),
                }
                let values = values_of(ty, &raw)
                    .map_err(|m| fail(pline, format!("parameter `{name}`: {m}")))?;
                st.params.push(Param {
                    ty: ty.to_string(),
                    name: name.to_string(),
                    values,
                });
            }
        }
        out.push(st);
    }
    Ok(out)
}

/// Typed values of a parameter of type `ty`.
fn values_of(ty: &str, raw: &[Tok]) -> std::result::Result<Values, String> {
    match ty {
        "bool" => raw
            .iter()
            .map(|t| match t {
                Tok::Word(w) | Tok::Str(w) if w == "true" => Ok(true),
                Tok::Word(w) | Tok::Str(w) if w == "false" => Ok(false),
                _ => Err("expected true or false".to_string()),
            })
            .collect::<std::result::Result<_, _>>()
            .map(Values::Bools),
        "string" | "texture" => raw
            .iter()
            .map(|t| match t {
                Tok::Str(s) => Ok(s.clone()),
                _ => Err("expected a quoted string".to_string()),
            })
            .collect::<std::result::Result<_, _>>()
            .map(Values::Strs),
        // a spectrum is numbers (wavelength-value pairs) or a named one
        "spectrum" if matches!(raw.first(), Some(Tok::Str(_))) => raw
            .iter()
            .map(|t| match t {
                Tok::Str(s) => Ok(s.clone()),
                _ => Err("expected a named spectrum".to_string()),
            })
            .collect::<std::result::Result<_, _>>()
            .map(Values::Strs),
        _ => raw
            .iter()
            .map(|t| match t {
                Tok::Num(v) if v.is_finite() => Ok(*v),
                Tok::Num(_) => Err("a number is not finite".to_string()),
                _ => Err(format!("expected numbers for a `{ty}`")),
            })
            .collect::<std::result::Result<_, _>>()
            .map(Values::Nums),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn statements_read_positional_arguments_and_parameters() {
        let text = "# c\nLookAt 0 0 5  0 0 0  0 1 0\nShape \"trianglemesh\" \"point3 P\" [0 0 0 1 0 0 0 1 0]\n  \"integer indices\" [0 1 2] \"bool flag\" true\nTexture \"t\" \"spectrum\" \"imagemap\" \"string filename\" \"a.png\"\nTransform [1 0 0 0 0 1 0 0 0 0 1 0 0 0 0 1]\n";
        let file = Rc::new(PathBuf::from("s.pbrt"));
        let toks = tokenize(&file, text).unwrap();
        let st = statements(&file, &toks).unwrap();
        assert_eq!(st.len(), 4);
        assert_eq!(st[0].numbers.len(), 9);
        assert_eq!(st[1].line, 3);
        assert_eq!(st[1].params.len(), 3);
        assert_eq!(st[1].params[2].values, Values::Bools(vec![true]));
        assert_eq!(st[2].strings, ["t", "spectrum", "imagemap"]);
        assert_eq!(st[3].numbers.len(), 16);
        let bad = tokenize(&file, "Shape \"sphere\nx").unwrap_err();
        assert!(bad.to_string().contains(":1"), "{bad}");
        let e = statements(&file, &tokenize(&file, "\n\nFrobnicate 1").unwrap()).unwrap_err();
        assert!(
            e.to_string().contains(":3") && e.to_string().contains("Frobnicate"),
            "{e}"
        );
    }
}
