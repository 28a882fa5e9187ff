//! PNG: a film's means as 8-bit sRGB after an exposure scale, 8-bit RGB
//! maps and plots as they are, and PNG textures (8 or 16 bits per channel,
//! grey or colour, alpha ignored) decoded to linear RGB. JPEG textures
//! (8-bit sRGB) and Radiance `.hdr` images (linear RGBE) are read here too,
//! through the same decoder.

use super::srgb::{srgb_to_linear, srgb8};
use super::{Rgb, write_atomically, write_file_atomically};
use crate::error::{Error, Result};
use std::path::Path;

/// The film's 8-bit sRGB bytes, row-major, top row first, after scaling the
/// pixel means by `2^exposure`.
fn png_bytes(film: &Rgb, exposure: f32) -> Vec<u8> {
    let scale = f64::from(exposure).exp2();
    film.rgb
        .iter()
        .flat_map(|p| p.map(|m| srgb8(m * scale)))
        .collect()
}

pub(super) fn write_png(path: &Path, film: &Rgb, exposure: f32) -> Result<()> {
    use ::image::ImageEncoder;
    if !exposure.is_finite() {
        return Err(Error::Settings(format!(
            "{}: exposure must be a finite number of stops, got {exposure}",
            path.display()
        )));
    }
    let bytes = png_bytes(film, exposure);
    write_atomically(path, |w| {
        ::image::codecs::png::PngEncoder::new(w)
            .write_image(
                &bytes,
                film.width,
                film.height,
                ::image::ExtendedColorType::Rgb8,
            )
            .map_err(|e| match e {
                ::image::ImageError::IoError(e) => Error::io(path, e),
                other => Error::io(path, std::io::Error::other(other)),
            })
    })
}

/// Encode 8-bit RGB pixels (row-major, top row first) as PNG and write them
/// to `path` atomically.
pub fn write_png_rgb8(path: &Path, width: u32, height: u32, rgb: &[u8]) -> Result<()> {
    let mut bytes = Vec::new();
    ::image::write_buffer_with_format(
        &mut std::io::Cursor::new(&mut bytes),
        rgb,
        width,
        height,
        ::image::ExtendedColorType::Rgb8,
        ::image::ImageFormat::Png,
    )
    .map_err(|e| Error::input(path, None, format!("cannot encode PNG: {e}")))?;
    write_file_atomically(path, &bytes)
}

/// Reads a PNG (8 or 16 bits per channel, grey or colour; alpha is ignored)
/// as sRGB-encoded and decodes it to linear RGB: `(width, height, rgb)`,
/// row-major, top row first, 3 floats per pixel.
pub fn read_png(path: &Path) -> Result<(u32, u32, Vec<f32>)> {
    read_png_as(path, false)
}

/// The decoded image of the `format` file at `path` (whatever its
/// extension says).
fn decode_as(path: &Path, format: ::image::ImageFormat) -> Result<::image::DynamicImage> {
    let mut reader = ::image::ImageReader::open(path).map_err(|e| Error::io(path, e))?;
    reader.set_format(format);
    let name = match format {
        ::image::ImageFormat::Jpeg => "JPEG",
        ::image::ImageFormat::Hdr => "Radiance HDR",
        _ => "PNG",
    };
    reader.decode().map_err(|e| match e {
        ::image::ImageError::IoError(e) => Error::io(path, e),
        other => Error::input(path, None, format!("not a readable {name} file: {other}")),
    })
}

/// The decoded image of the PNG at `path`.
fn decode(path: &Path) -> Result<::image::DynamicImage> {
    decode_as(path, ::image::ImageFormat::Png)
}

/// A PNG as an opacity: its alpha channel when it has one, otherwise its
/// stored values (as [`read_png_as`] with `raw`), each scaled to `[0, 1]`
/// (alpha is linear by the PNG specification). `(width, height, rgb)` with
/// the alpha repeated in all three channels, or the colour of an image
/// without alpha.
pub fn read_png_opacity(path: &Path) -> Result<(u32, u32, Vec<f32>)> {
    let img = decode(path)?;
    if !img.color().has_alpha() {
        return read_png_as(path, true);
    }
    let img = img.into_rgba16();
    let rgb = img
        .pixels()
        .flat_map(|p| [p.0[3] as f32 / u16::MAX as f32; 3])
        .collect();
    Ok((img.width(), img.height(), rgb))
}

/// [`read_png`], or with `raw` the stored values as they are, scaled to
/// `[0, 1]` and not decoded from sRGB (Mitsuba's `bitmap` with `raw = true`:
/// normal maps, roughness maps and other data that is not a colour).
pub fn read_png_as(path: &Path, raw: bool) -> Result<(u32, u32, Vec<f32>)> {
    to_linear(decode(path)?, raw)
}

/// A JPEG (8 bits per channel, grey or colour, as baseline and progressive
/// JPEG store them) decoded from sRGB to linear RGB like [`read_png_as`],
/// or with `raw` its values scaled to `[0, 1]`.
pub fn read_jpeg_as(path: &Path, raw: bool) -> Result<(u32, u32, Vec<f32>)> {
    to_linear(decode_as(path, ::image::ImageFormat::Jpeg)?, raw)
}

/// A Radiance `.hdr` (RGBE) image: its linear RGB values, `(width, height,
/// rgb)`, row-major, top row first.
pub fn read_hdr(path: &Path) -> Result<(u32, u32, Vec<f32>)> {
    let img = decode_as(path, ::image::ImageFormat::Hdr)?.into_rgb32f();
    Ok((img.width(), img.height(), img.into_raw()))
}

/// An image decoded from memory: width, height, linear RGB (3 per texel),
/// and the alpha channel when the image has one.
pub type DecodedImage = (u32, u32, Vec<f32>, Option<Vec<f32>>);

/// A PNG or JPEG held in memory (a glTF file's embedded or external
/// image), its format told by its first bytes: `(width, height, rgb,
/// alpha)`, the colour as [`read_png_as`] gives it and the alpha channel
/// (linear, in `[0, 1]`) when the image has one. The error says what is
/// wrong in one line.
pub fn decode_image_bytes(bytes: &[u8], raw: bool) -> std::result::Result<DecodedImage, String> {
    let format = ::image::guess_format(bytes)
        .map_err(|_| "not a PNG or JPEG image (unrecognised first bytes)".to_string())?;
    if !matches!(
        format,
        ::image::ImageFormat::Png | ::image::ImageFormat::Jpeg
    ) {
        return Err(format!(
            "a {format:?} image: only PNG and JPEG are read here"
        ));
    }
    let img = ::image::load_from_memory_with_format(bytes, format)
        .map_err(|e| format!("not a readable {format:?} image: {e}"))?;
    let alpha = img.color().has_alpha().then(|| {
        img.to_rgba16()
            .pixels()
            .map(|p| p.0[3] as f32 / u16::MAX as f32)
            .collect()
    });
    let (w, h, rgb) = to_linear(img, raw).map_err(|e| e.to_string())?;
    Ok((w, h, rgb, alpha))
}

/// The decoded 8- or 16-bit image `img` as linear RGB (from sRGB unless
/// `raw`).
fn to_linear(img: ::image::DynamicImage, raw: bool) -> Result<(u32, u32, Vec<f32>)> {
    // 8-bit values v become 257 v exactly, so one 16-bit table serves both
    let img = img.into_rgb16();
    let lut: Vec<f32> = (0..=u16::MAX)
        .map(|v| {
            let c = v as f64 / u16::MAX as f64;
            (if raw { c } else { srgb_to_linear(c) }) as f32
        })
        .collect();
    let rgb = img.as_raw().iter().map(|&v| lut[v as usize]).collect();
    Ok((img.width(), img.height(), rgb))
}

#[cfg(test)]
mod tests {
    use super::super::testing::entries;
    use super::super::{OutputOptions, write_image};
    use super::*;
    use crate::film::{Film, Pixel};
    use crate::math::Vec3;

    #[test]
    fn exposure_doubles_linear_value_per_stop() {
        let film_with = |v: f32| {
            let mut f = Film::new(1, 1);
            f.add_sample(0, 0, Vec3::new(v, v / 2.0, v / 4.0));
            f
        };
        let png_bytes = |f: &Film, exposure: f32| {
            let means: Vec<[f64; 3]> = f.pixels().iter().map(Pixel::mean_f64).collect();
            let rgb = Rgb {
                width: f.width(),
                height: f.height(),
                rgb: &means,
            };
            png_bytes(&rgb, exposure)
        };
        let dim = film_with(0.1);
        let bright = film_with(0.2);
        assert_eq!(png_bytes(&dim, 1.0), png_bytes(&bright, 0.0));
        assert_eq!(png_bytes(&bright, -1.0), png_bytes(&dim, 0.0));
        assert_eq!(
            png_bytes(&dim, 1.0),
            [
                srgb8(0.2f32 as f64),
                srgb8(0.1f32 as f64),
                srgb8(0.05f32 as f64)
            ]
        );
        assert_ne!(png_bytes(&dim, 1.0), png_bytes(&dim, 0.0));
    }

    #[test]
    fn png_file_holds_srgb_bytes() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("out.PNG");
        let mut film = Film::new(2, 1);
        film.add_sample(0, 0, Vec3::new(0.5, 1.0, 0.0));
        film.add_sample(1, 0, Vec3::new(0.25, 0.0, 2.0));
        write_image(&path, &film, &OutputOptions::default()).unwrap();
        let img = ::image::open(&path).unwrap().to_rgb8();
        assert_eq!(img.dimensions(), (2, 1));
        assert_eq!(img.as_raw(), &[188, 255, 0, srgb8(0.25), 0, 255]);
        let opts = OutputOptions {
            exposure: f32::NAN,
            ..OutputOptions::default()
        };
        assert!(matches!(
            write_image(&path, &film, &opts),
            Err(Error::Settings(_))
        ));
        assert_eq!(entries(dir.path()), ["out.PNG"]);
    }
}
