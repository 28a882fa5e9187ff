//! Portable Float Map (Paul Debevec's PFM): linear `f32` RGB, written
//! little-endian, bottom row first; read in colour or grey, either byte
//! order.

use super::{Rgb, write_atomically};
use crate::error::{Error, Result};
use std::fs;
use std::io::Write;
use std::path::Path;

pub(super) fn write_pfm(path: &Path, film: &Rgb) -> Result<()> {
    let rgb = film.to_f32();
    let row_floats = film.width as usize * 3;
    write_atomically(path, |w| {
        let io = |e| Error::io(path, e);
        // A negative scale marks little-endian data.
        write!(w, "PF\n{} {}\n-1.0\n", film.width, film.height).map_err(io)?;
        let mut row_bytes = Vec::with_capacity(row_floats * 4);
        // PFM stores the bottom row first.
        for row in rgb.chunks_exact(row_floats).rev() {
            row_bytes.clear();
            row_bytes.extend(row.iter().flat_map(|v| v.to_le_bytes()));
            w.write_all(&row_bytes).map_err(io)?;
        }
        Ok(())
    })
}

/// A whitespace-separated token of a PFM header, with the 1-based line it is
/// on.
struct HeaderToken<'a> {
    text: &'a [u8],
    line: usize,
}

impl HeaderToken<'_> {
    /// The token for an error message, shortened if it is binary junk.
    fn show(&self) -> String {
        let shown = &self.text[..self.text.len().min(16)];
        let more = if self.text.len() > 16 { "..." } else { "" };
        format!("{}{more}", String::from_utf8_lossy(shown).escape_debug())
    }
}

/// Reads PFM header tokens from the start of a file.
struct HeaderReader<'a> {
    bytes: &'a [u8],
    pos: usize,
    line: usize,
}

impl<'a> HeaderReader<'a> {
    /// The next token, or `None` at the end of the file.
    fn next(&mut self) -> Option<HeaderToken<'a>> {
        let bytes = self.bytes;
        let range = crate::error::next_word(bytes, &mut self.pos, &mut self.line)?;
        Some(HeaderToken {
            text: &bytes[range],
            line: self.line,
        })
    }
}

/// Reads a Portable Float Map: `(width, height, pixels)` with `pixels`
/// row-major, top row first, 3 floats per pixel. Accepts colour (`PF`) and
/// grayscale (`Pf`, copied to R, G and B) files of either byte order (the sign
/// of the scale line); the scale's magnitude is ignored.
pub fn read_pfm(path: &Path) -> Result<(u32, u32, Vec<f32>)> {
    let bytes = fs::read(path).map_err(|e| Error::io(path, e))?;
    let bad = |line: Option<usize>, msg: String| Error::input(path, line, msg);
    let mut header = HeaderReader {
        bytes: &bytes,
        pos: 0,
        line: 1,
    };
    let mut field = |what: &str| {
        header.next().ok_or_else(|| {
            bad(
                None,
                format!("not a PFM file: the header ends before the {what}"),
            )
        })
    };

    let magic = field("`PF` or `Pf` signature")?;
    let channels = match magic.text {
        b"PF" => 3,
        b"Pf" => 1,
        _ => {
            return Err(bad(
                Some(magic.line),
                format!(
                    "not a PFM file: expected `PF` or `Pf`, found `{}`",
                    magic.show()
                ),
            ));
        }
    };
    let mut dimension = |what: &str| -> Result<u32> {
        let tok = field(what)?;
        std::str::from_utf8(tok.text)
            .ok()
            .and_then(|s| s.parse::<u32>().ok())
            .filter(|&n| n > 0)
            .ok_or_else(|| {
                bad(
                    Some(tok.line),
                    format!("expected a positive {what}, found `{}`", tok.show()),
                )
            })
    };
    let width = dimension("width")?;
    let height = dimension("height")?;
    let scale_tok = field("scale")?;
    let scale = std::str::from_utf8(scale_tok.text)
        .ok()
        .and_then(|s| s.parse::<f32>().ok())
        .filter(|s| s.is_finite() && *s != 0.0)
        .ok_or_else(|| {
            bad(
                Some(scale_tok.line),
                format!(
                    "expected a non-zero scale (negative for little-endian), found `{}`",
                    scale_tok.show()
                ),
            )
        })?;
    let little_endian = scale < 0.0;
    // Exactly one whitespace byte separates the header from the pixels.
    let data_start = header.pos + 1;
    if data_start > bytes.len() {
        return Err(bad(
            None,
            "truncated PFM file: no pixel data after the header".into(),
        ));
    }

    // In u128: 2^32 x 2^32 x 3 x 4 overflows u64.
    let expected = u128::from(width) * u128::from(height) * channels as u128 * 4;
    let found = (bytes.len() - data_start) as u128;
    if found != expected {
        let what = if found < expected {
            "truncated"
        } else {
            "trailing data in"
        };
        return Err(bad(
            None,
            format!(
                "{what} PFM file: a {width}x{height} image with {channels} channel(s) \
                 needs {expected} bytes of pixel data, found {found}"
            ),
        ));
    }

    let data = &bytes[data_start..];
    let decode = |b: &[u8]| {
        let b = [b[0], b[1], b[2], b[3]];
        if little_endian {
            f32::from_le_bytes(b)
        } else {
            f32::from_be_bytes(b)
        }
    };
    let row_bytes = width as usize * channels * 4;
    let mut pixels = Vec::with_capacity(data.len() / (channels * 4) * 3);
    // The file stores the bottom row first; the result starts with the top row.
    for row in data.chunks_exact(row_bytes).rev() {
        for px in row.chunks_exact(channels * 4) {
            if channels == 3 {
                pixels.extend(px.chunks_exact(4).map(decode));
            } else {
                let v = decode(px);
                pixels.extend([v, v, v]);
            }
        }
    }
    Ok((width, height, pixels))
}

#[cfg(test)]
mod tests {
    use super::super::testing::{bits, gradient_film};
    use super::super::{OutputOptions, write_image};
    use super::*;

    #[test]
    fn pfm_round_trip_is_bit_exact_and_bottom_row_first() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("img.pfm");
        let film = gradient_film(3, 2);
        write_image(&path, &film, &OutputOptions::default()).unwrap();

        let raw = fs::read(&path).unwrap();
        let header = b"PF\n3 2\n-1.0\n";
        assert_eq!(&raw[..header.len()], header);
        assert_eq!(raw.len(), header.len() + 3 * 2 * 3 * 4);
        // The first pixel in the file is the bottom-left one, (0, 1).
        let first = f32::from_le_bytes(raw[header.len()..header.len() + 4].try_into().unwrap());
        assert_eq!(first, film.mean(0, 1).x);

        let (w, h, px) = read_pfm(&path).unwrap();
        assert_eq!((w, h), (3, 2));
        assert_eq!(bits(&px), bits(&film.to_rgb_f32()));
    }

    #[test]
    fn pfm_reads_big_endian_and_grayscale() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("g.pfm");
        // 1x2 grayscale, big-endian, width and height on separate lines:
        // bottom row 2.0, top row -0.5.
        let mut bytes = b"Pf\n1\n2\n1.0\n".to_vec();
        bytes.extend(2.0f32.to_be_bytes());
        bytes.extend((-0.5f32).to_be_bytes());
        fs::write(&path, bytes).unwrap();
        let (w, h, px) = read_pfm(&path).unwrap();
        assert_eq!((w, h), (1, 2));
        assert_eq!(px, [-0.5, -0.5, -0.5, 2.0, 2.0, 2.0]);
    }

    #[test]
    fn malformed_pfm_files_give_input_errors() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("bad.pfm");
        let one_pixel = [0u8; 12];
        let cases: [(&[u8], &[u8], &str); 8] = [
            (b"P6\n1 1\n255\n", &one_pixel, "expected `PF` or `Pf`"),
            (b"PF\n0 1\n-1.0\n", &one_pixel, "positive width"),
            (b"PF\n1 x\n-1.0\n", &one_pixel, "positive height"),
            (b"PF\n1 1\n0\n", &one_pixel, "non-zero scale"),
            (b"PF\n1 1\n", b"", "ends before the scale"),
            (b"PF\n1 1\n-1.0\n", &one_pixel[..11], "truncated"),
            (b"PF\n1 1\n-1.0\n", &[0u8; 16], "trailing data"),
            (
                b"PF\n4294967295 4294967295\n-1.0\n",
                &one_pixel,
                "truncated",
            ),
        ];
        for (header, data, expect) in cases {
            fs::write(&path, [header, data].concat()).unwrap();
            let err = read_pfm(&path).unwrap_err();
            assert!(matches!(err, Error::Input { .. }), "{err}");
            assert!(err.to_string().contains(expect), "{err} (wanted {expect})");
        }
        let err = read_pfm(&dir.path().join("missing.pfm")).unwrap_err();
        assert!(matches!(err, Error::Io { .. }), "{err}");
    }
}
