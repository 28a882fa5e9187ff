//! Image files: writing a film or linear RGB pixels as PNG, OpenEXR or PFM
//! ([`write_image`], [`write_rgb`]), and the readers textures, the tests and
//! the `diff` command use ([`read_png`], [`read_exr`], [`read_exr_metadata`],
//! [`read_pfm`]).
//!
//! PNG is 8-bit sRGB (IEC 61966-2-1 transfer function, [`srgb8`]) after an
//! exposure scale; EXR is linear `f32` R, G, B with render metadata as custom
//! text attributes; PFM is linear `f32` RGB, little-endian, bottom row first
//! (Paul Debevec's Portable Float Map). Every file is written to a temporary
//! file in the target directory, synced, then renamed over the target, so a
//! reader never sees a half-written image and a failed write leaves nothing
//! ([`write_file_atomically`]).

mod atomic;
mod exr;
mod pfm;
mod png;
mod srgb;

pub use self::exr::{ExrLayer, read_exr, read_exr_metadata, write_exr_layers};
pub(crate) use self::exr::{
    check_exr_sizes, exr_layer_attributes, read_exr_bytes, read_exr_channels, with_exr_bytes,
    write_exr_image,
};
pub(crate) use atomic::write_atomically;
pub use atomic::write_file_atomically;
pub use pfm::read_pfm;
pub use png::{
    decode_image_bytes, read_hdr, read_jpeg_as, read_png, read_png_as, read_png_opacity,
    write_png_rgb8,
};
pub use srgb::{srgb_to_linear, srgb8};

use crate::error::{Error, Result};
use crate::film::{Film, Pixel};
use atomic::{TempFile, parent_dir};
use std::fs;
use std::path::Path;

/// An image file format, chosen by the file's extension.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ImageFormat {
    /// `.png`: 8-bit sRGB.
    Png,
    /// `.exr`: OpenEXR, linear `f32` RGB with metadata.
    Exr,
    /// `.pfm`: Portable Float Map, linear `f32` RGB.
    Pfm,
}

impl ImageFormat {
    /// The format named by `path`'s extension (case-insensitive), or a
    /// [`Error::Settings`] naming the path and the formats accepted.
    pub fn from_path(path: &Path) -> Result<ImageFormat> {
        let Some(ext) = path.extension() else {
            return Err(Error::Settings(format!(
                "{}: output file has no extension (expected .png, .exr or .pfm)",
                path.display()
            )));
        };
        let ext = ext.to_string_lossy();
        match ext.to_ascii_lowercase().as_str() {
            "png" => Ok(ImageFormat::Png),
            "exr" => Ok(ImageFormat::Exr),
            "pfm" => Ok(ImageFormat::Pfm),
            _ => Err(Error::Settings(format!(
                "{}: unknown output format `.{ext}` (expected .png, .exr or .pfm)",
                path.display()
            ))),
        }
    }
}

/// How [`write_image`] writes a film.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct OutputOptions {
    /// Exposure in stops: PNG pixels are scaled by `2^exposure` before sRGB
    /// encoding. EXR and PFM always hold the unscaled radiance.
    pub exposure: f32,
    /// Name-value pairs stored as custom text attributes in the EXR header
    /// (for example `spp`, `seed`, `backend`, `render_seconds`); ignored by PNG
    /// and PFM. Names must be 1 to 255 bytes, without NUL, unique, and not one
    /// of OpenEXR's standard attribute names. Both are stored as UTF-8 bytes.
    pub metadata: Vec<(String, String)>,
}

/// Checks an output path before rendering, so a bad one fails fast: the
/// extension names a known format, the path names a file (not a directory),
/// and the parent directory exists and accepts a new file (a temporary file is
/// created there and removed).
pub fn check_output_path(path: &Path) -> Result<()> {
    ImageFormat::from_path(path)?;
    let dir = parent_dir(path);
    match fs::metadata(dir) {
        Ok(m) if m.is_dir() => {}
        Ok(_) => {
            return Err(Error::Settings(format!(
                "{}: {} is not a directory",
                path.display(),
                dir.display()
            )));
        }
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
            return Err(Error::Settings(format!(
                "{}: the output directory {} does not exist",
                path.display(),
                dir.display()
            )));
        }
        Err(e) => return Err(Error::io(dir, e)),
    }
    if path.is_dir() {
        return Err(Error::Settings(format!(
            "{}: is a directory, not an image file",
            path.display()
        )));
    }
    // a device or FIFO is written in place, with no temporary file
    if atomic::is_special(path)? {
        return Ok(());
    }
    // Probe: can we create the temporary file the real write will need? The
    // guard removes it again.
    let (probe, file) = TempFile::create(path)?;
    drop(file);
    drop(probe);
    Ok(())
}

/// Writes `film` to `path` in the format its extension names, atomically (see
/// [`write_file_atomically`]).
pub fn write_image(path: &Path, film: &Film, opts: &OutputOptions) -> Result<()> {
    let means: Vec<[f64; 3]> = film.pixels().iter().map(Pixel::mean_f64).collect();
    write_rgb(path, film.width(), film.height(), &means, opts)
}

/// Writes linear RGB pixels (row-major, top row first) to `path` in the
/// format its extension names, atomically: what [`write_image`] does with a
/// film's means, for images that are not renders (textures, maps).
pub fn write_rgb(
    path: &Path,
    width: u32,
    height: u32,
    rgb: &[[f64; 3]],
    opts: &OutputOptions,
) -> Result<()> {
    let format = ImageFormat::from_path(path)?;
    if width == 0 || height == 0 {
        return Err(Error::Settings(format!(
            "{}: cannot write an empty {width}x{height} image",
            path.display(),
        )));
    }
    assert_eq!(rgb.len() as u64, u64::from(width) * u64::from(height));
    let img = Rgb { width, height, rgb };
    match format {
        ImageFormat::Png => png::write_png(path, &img, opts.exposure),
        ImageFormat::Exr => self::exr::write_exr(path, &img, &opts.metadata),
        ImageFormat::Pfm => pfm::write_pfm(path, &img),
    }
}

/// Pixels on their way to a file.
struct Rgb<'a> {
    width: u32,
    height: u32,
    rgb: &'a [[f64; 3]],
}

impl Rgb<'_> {
    fn to_f32(&self) -> Vec<f32> {
        self.rgb.iter().flat_map(|p| p.map(|v| v as f32)).collect()
    }
}

#[cfg(test)]
mod testing {
    use crate::film::Film;
    use crate::math::Vec3;
    use std::fs;
    use std::path::Path;

    /// channel, including values that would expose rounding or reordering.
    pub(super) fn gradient_film(width: u32, height: u32) -> Film {
        let mut film = Film::new(width, height);
        for y in 0..height {
            for x in 0..width {
                let base = (y * width + x) as f32;
                film.add_sample(
                    x,
                    y,
                    Vec3::new(base + 0.1, -base * 1e-3 - 1e-30, (base + 1.0).powf(7.3)),
                );
            }
        }
        film
    }

    pub(super) fn bits(v: &[f32]) -> Vec<u32> {
        v.iter().map(|f| f.to_bits()).collect()
    }

    pub(super) fn entries(dir: &Path) -> Vec<String> {
        let mut names: Vec<String> = fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        names.sort();
        names
    }
}

#[cfg(test)]
mod tests {
    use super::testing::{entries, gradient_film};
    use super::*;

    #[test]
    fn unknown_or_missing_extension_is_a_settings_error() {
        let film = gradient_film(1, 1);
        let err =
            write_image(Path::new("out/img.xyz"), &film, &OutputOptions::default()).unwrap_err();
        assert_eq!(
            err.to_string(),
            "out/img.xyz: unknown output format `.xyz` (expected .png, .exr or .pfm)"
        );
        assert!(matches!(err, Error::Settings(_)));
        assert!(matches!(
            check_output_path(Path::new("img")),
            Err(Error::Settings(_))
        ));
        assert_eq!(
            ImageFormat::from_path(Path::new("a.b.ExR")).unwrap(),
            ImageFormat::Exr
        );
        assert_eq!(
            ImageFormat::from_path(Path::new("x.PFM")).unwrap(),
            ImageFormat::Pfm
        );
    }

    #[test]
    fn check_output_path_fails_fast_and_leaves_nothing() {
        let dir = tempfile::tempdir().unwrap();
        check_output_path(&dir.path().join("ok.exr")).unwrap();
        assert!(entries(dir.path()).is_empty());
        let err = check_output_path(&dir.path().join("no/such/dir/img.png")).unwrap_err();
        assert!(err.to_string().contains("does not exist"), "{err}");
        fs::create_dir(dir.path().join("sub.png")).unwrap();
        assert!(check_output_path(&dir.path().join("sub.png")).is_err());
    }
}
