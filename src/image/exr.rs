//! OpenEXR: linear `f32` R, G, B with render metadata as custom text
//! attributes, lossless (ZIP), so a file holds a film's values bit for bit;
//! and the pieces the farm's accumulation files (any channels, one layer)
//! are written and read with.

use super::{Rgb, write_atomically};
use crate::error::{Error, Result};
use ::exr::image::write::layers::WritableLayers;
use ::exr::prelude::{AnyChannels, FlatSamples, Image, Layer, LayerAttributes};
use std::fs::File;
use std::path::Path;

/// Checks metadata names against what an EXR header can hold and read back as
/// a custom attribute.
fn check_exr_metadata(path: &Path, metadata: &[(String, String)]) -> Result<()> {
    let bad = |name: &str, why: &str| {
        Err(Error::Settings(format!(
            "{}: metadata name `{}` {why}",
            path.display(),
            name.escape_debug()
        )))
    };
    for (i, (name, _)) in metadata.iter().enumerate() {
        if name.is_empty() || name.len() > 255 {
            return bad(name, "must be 1 to 255 bytes long");
        }
        if name.contains('\0') {
            return bad(name, "must not contain NUL");
        }
        if ::exr::meta::header::standard_names::ALL.contains(&name.as_bytes()) {
            return bad(name, "is a standard OpenEXR attribute");
        }
        if metadata[..i].iter().any(|(n, _)| n == name) {
            return bad(name, "appears twice");
        }
    }
    Ok(())
}

/// An `exr` error while reading `path`: I/O stays I/O, anything else means the
/// file is not a usable OpenEXR image.
fn exr_read_error(path: &Path, e: ::exr::error::Error) -> Error {
    match e {
        ::exr::error::Error::Io(e) => Error::io(path, e),
        other => Error::input(path, None, format!("not a readable OpenEXR file: {other}")),
    }
}

/// The most an OpenEXR file's pixels may grow on decoding, as a multiple of
/// the file's size. Deflate cannot expand more than about 1032 to 1
/// (RFC 1951's longest match, 258 bytes, in two bits or so); the `exr`
/// crate's coders reached at most 917 to 1 on a constant 2048 x 2048 image
/// (ZIP16, this project's measurement). 4096 leaves room for any lossless
/// writer, and keeps a 400-byte file from claiming gigabytes.
pub(crate) const MAX_EXR_EXPANSION: u64 = 4096;

/// Checks the sizes an OpenEXR file's headers claim, before any pixel is
/// allocated: every layer within [`crate::limits::check_resolution`], no
/// deep data, and pixels that the file's bytes can hold (at most
/// [`MAX_EXR_EXPANSION`] times its length once decoded). Returns the first
/// layer's data window: `(width, height, x, y)`.
pub(crate) fn check_exr_sizes(path: &Path) -> Result<(usize, usize, i32, i32)> {
    let file = File::open(path).map_err(|e| Error::io(path, e))?;
    let len = file.metadata().map_err(|e| Error::io(path, e))?.len();
    let meta = ::exr::meta::MetaData::read_from_unbuffered(file, false)
        .map_err(|e| exr_read_error(path, e))?;
    let mut claimed: u64 = 0;
    for h in &meta.headers {
        let (w, ht) = (h.layer_size.width() as u64, h.layer_size.height() as u64);
        crate::limits::check_resolution(w, ht)
            .map_err(|m| Error::input(path, None, format!("its header's data window: {m}")))?;
        if h.deep {
            return Err(Error::input(
                path,
                None,
                "deep OpenEXR data is not supported",
            ));
        }
        claimed = claimed.saturating_add(h.total_pixel_bytes() as u64);
    }
    if claimed > len.saturating_mul(MAX_EXR_EXPANSION) {
        return Err(Error::input(
            path,
            None,
            format!(
                "its headers claim {claimed} bytes of pixels, more than {MAX_EXR_EXPANSION} times its {len} bytes can hold: a damaged or forged file"
            ),
        ));
    }
    let Some(h) = meta.headers.first() else {
        return Err(Error::input(path, None, "OpenEXR file has no header"));
    };
    let pos = h.own_attributes.layer_position;
    Ok((
        h.layer_size.width(),
        h.layer_size.height(),
        pos.x(),
        pos.y(),
    ))
}

/// Layer attributes naming embertrace as the software, with `metadata` as
/// custom text attributes (names as [`check_exr_metadata`] admits them).
pub(crate) fn exr_layer_attributes(metadata: &[(String, String)]) -> LayerAttributes {
    use ::exr::meta::attribute::{AttributeValue, Text};

    let mut attributes = LayerAttributes {
        software_name: Text::new_or_none(concat!("embertrace ", env!("CARGO_PKG_VERSION"))),
        ..LayerAttributes::default()
    };
    for (name, value) in metadata {
        attributes.other.insert(
            Text::from_slice_unchecked(name.as_bytes()),
            AttributeValue::Text(Text::from_slice_unchecked(value.as_bytes())),
        );
    }
    attributes
}

/// Encodes `image` as OpenEXR and writes it to `path` atomically (see
/// [`write_file_atomically`](super::write_file_atomically)).
pub(crate) fn write_exr_image<'img, L>(path: &Path, image: &'img Image<L>) -> Result<()>
where
    L: WritableLayers<'img>,
{
    use ::exr::prelude::WritableImage;

    write_atomically(path, |w| {
        image.write().to_buffered(w).map_err(|e| match e {
            ::exr::error::Error::Io(e) => Error::io(path, e),
            other => Error::Settings(format!(
                "{}: cannot encode OpenEXR: {other}",
                path.display()
            )),
        })
    })
}

pub(super) fn write_exr(path: &Path, film: &Rgb, metadata: &[(String, String)]) -> Result<()> {
    use ::exr::prelude::{Encoding, SpecificChannels, Vec2};

    check_exr_metadata(path, metadata)?;
    let attributes = exr_layer_attributes(metadata);

    let rgb = film.to_f32();
    let width = film.width as usize;
    let channels = SpecificChannels::rgb(|pos: Vec2<usize>| {
        let i = (pos.y() * width + pos.x()) * 3;
        (rgb[i], rgb[i + 1], rgb[i + 2])
    });
    // ZIP is lossless for f32, so the file holds the film's values bit for bit.
    let layer = Layer::new(
        (width, film.height as usize),
        attributes,
        Encoding::SMALL_LOSSLESS,
        channels,
    );
    let image = Image::from_layer(layer);
    write_exr_image(path, &image)
}

/// One named image of a layered EXR ([`write_exr_layers`]): channel
/// suffixes and the planar values of each, row-major from the top.
#[derive(Debug, Clone)]
pub struct ExrLayer {
    /// The layer's name (`albedo`), empty for the main image's `R`, `G`, `B`.
    pub name: String,
    /// One `(channel, values)` pair per channel: `("R", ...)`, `("Z", ...)`.
    pub channels: Vec<(String, Vec<f32>)>,
}

/// Writes `layers` as one OpenEXR image, lossless (ZIP), atomically: the
/// single-part "multi-layer" layout compositors read (Nuke, Blender,
/// OpenImageIO), each channel named `layer.channel` (`albedo.R`,
/// `depth.Z`), the main image's channels bare. `metadata` as in
/// [`write_image`](super::write_image).
pub fn write_exr_layers(
    path: &Path,
    width: u32,
    height: u32,
    layers: &[ExrLayer],
    metadata: &[(String, String)],
) -> Result<()> {
    use ::exr::prelude::{AnyChannel, Encoding, SmallVec};

    check_exr_metadata(path, metadata)?;
    let n = width as usize * height as usize;
    let mut channels: SmallVec<[AnyChannel<FlatSamples>; 4]> = SmallVec::new();
    for layer in layers {
        for (suffix, values) in &layer.channels {
            let name = match layer.name.as_str() {
                "" => suffix.clone(),
                l => format!("{l}.{suffix}"),
            };
            if values.len() != n {
                return Err(Error::Settings(format!(
                    "{}: channel {name} holds {} values for {width} x {height} pixels",
                    path.display(),
                    values.len()
                )));
            }
            channels.push(AnyChannel::new(
                name.as_str(),
                FlatSamples::F32(values.clone()),
            ));
        }
    }
    let layer = Layer::new(
        (width as usize, height as usize),
        exr_layer_attributes(metadata),
        Encoding::SMALL_LOSSLESS,
        AnyChannels::sort(channels),
    );
    write_exr_image(path, &Image::from_layer(layer))
}

/// Reads the R, G, B channels of the first layer of an OpenEXR file as `f32`:
/// `(width, height, pixels)` with `pixels` row-major, top row first, 3 floats
/// per pixel. The size is the layer's data window.
pub fn read_exr(path: &Path) -> Result<(u32, u32, Vec<f32>)> {
    use ::exr::prelude::{ReadChannels, ReadLayers, Vec2};

    check_exr_sizes(path)?;
    let file = File::open(path).map_err(|e| Error::io(path, e))?;
    let image = ::exr::prelude::read()
        .no_deep_data()
        .largest_resolution_level()
        .rgb_channels(
            |size: Vec2<usize>, _| (size.width(), vec![0.0f32; size.area() * 3]),
            |(w, px): &mut (usize, Vec<f32>), pos: Vec2<usize>, (r, g, b): (f32, f32, f32)| {
                let i = (pos.y() * *w + pos.x()) * 3;
                px[i..i + 3].copy_from_slice(&[r, g, b]);
            },
        )
        .first_valid_layer()
        .all_attributes()
        .from_unbuffered(file)
        .map_err(|e| exr_read_error(path, e))?;
    let layer = image.layer_data;
    let too_large = || Error::input(path, None, "image dimensions exceed u32");
    let width = u32::try_from(layer.size.width()).map_err(|_| too_large())?;
    let height = u32::try_from(layer.size.height()).map_err(|_| too_large())?;
    Ok((width, height, layer.channel_data.pixels.1))
}

/// The custom text attributes of an OpenEXR file's first header (the
/// [`OutputOptions::metadata`] it was written with), sorted by name. Bytes
/// that are not UTF-8 are replaced.
pub fn read_exr_metadata(path: &Path) -> Result<Vec<(String, String)>> {
    use ::exr::meta::attribute::AttributeValue;

    let mut pairs: Vec<(String, String)> = custom_attributes(path)?
        .into_iter()
        .filter_map(|(name, value)| match value {
            AttributeValue::Text(text) => Some((
                String::from_utf8_lossy(name.as_slice()).into_owned(),
                String::from_utf8_lossy(text.as_slice()).into_owned(),
            )),
            _ => None,
        })
        .collect();
    pairs.sort();
    Ok(pairs)
}

/// The custom attributes (those OpenEXR does not define) of the first
/// header of the OpenEXR file at `path`, the header's own and its shared
/// ones. Only the header is read.
fn custom_attributes(
    path: &Path,
) -> Result<
    Vec<(
        ::exr::meta::attribute::Text,
        ::exr::meta::attribute::AttributeValue,
    )>,
> {
    let file = File::open(path).map_err(|e| Error::io(path, e))?;
    let meta = ::exr::meta::MetaData::read_from_unbuffered(file, false)
        .map_err(|e| exr_read_error(path, e))?;
    let Some(header) = meta.headers.into_iter().next() else {
        return Err(Error::input(path, None, "OpenEXR file has no header"));
    };
    Ok(header
        .own_attributes
        .other
        .into_iter()
        .chain(header.shared_attributes.other)
        .collect())
}

/// The bytes of attribute `name` of type `bytes` (OpenEXR 3's type for
/// application data, here with type hint `hint`) in the first header of
/// the OpenEXR file at `path`, if it has one. Only the header is read.
pub(crate) fn read_exr_bytes(path: &Path, name: &str, hint: &str) -> Result<Option<Vec<u8>>> {
    use ::exr::meta::attribute::AttributeValue;

    let found = custom_attributes(path)?
        .into_iter()
        .find(|(n, _)| n.as_slice() == name.as_bytes());
    match found {
        None => Ok(None),
        Some((_, AttributeValue::Bytes { type_hint, bytes }))
            if type_hint.as_slice() == hint.as_bytes() =>
        {
            Ok(Some(bytes.into_vec()))
        }
        Some(_) => Err(Error::input(
            path,
            None,
            format!("attribute `{name}` is not of type bytes with type hint `{hint}`"),
        )),
    }
}

/// `attributes` with attribute `name` of type `bytes` (type hint `hint`)
/// holding `bytes`.
pub(crate) fn with_exr_bytes(
    mut attributes: LayerAttributes,
    name: &str,
    hint: &str,
    bytes: &[u8],
) -> LayerAttributes {
    use ::exr::meta::attribute::{AttributeValue, Text};

    attributes.other.insert(
        Text::from_slice_unchecked(name.as_bytes()),
        AttributeValue::Bytes {
            type_hint: Text::from_slice_unchecked(hint.as_bytes()),
            bytes: bytes.into(),
        },
    );
    attributes
}

/// Every channel of the first layer of the OpenEXR file at `path`, with the
/// layer's attributes (the farm's accumulation files). A file that opens but
/// does not decode is an input error.
pub(crate) fn read_exr_channels(path: &Path) -> Result<Layer<AnyChannels<FlatSamples>>> {
    use ::exr::prelude::{ReadChannels, ReadLayers};

    check_exr_sizes(path)?;
    let file = File::open(path).map_err(|e| Error::io(path, e))?;
    let image = ::exr::prelude::read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .first_valid_layer()
        .all_attributes()
        .from_buffered(std::io::BufReader::new(file))
        .map_err(|e| Error::input(path, None, format!("not a readable OpenEXR file: {e}")))?;
    Ok(image.layer_data)
}

#[cfg(test)]
mod tests {
    use super::super::testing::{bits, entries, gradient_film};
    use super::super::{OutputOptions, write_image};
    use super::*;
    use std::fs;

    #[test]
    fn exr_round_trip_is_bit_exact_with_metadata() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("img.exr");
        let film = gradient_film(4, 3);
        let opts = OutputOptions {
            exposure: 3.0, // PNG only: must not change the EXR values
            metadata: vec![
                ("spp".into(), "64".into()),
                ("seed".into(), "7".into()),
                ("backend".into(), "naive".into()),
                ("render_seconds".into(), "1.25".into()),
                (
                    "a name longer than thirty-two bytes".into(),
                    "ünïcode ✓".into(),
                ),
            ],
        };
        write_image(&path, &film, &opts).unwrap();

        let (w, h, px) = read_exr(&path).unwrap();
        assert_eq!((w, h), (4, 3));
        assert_eq!(bits(&px), bits(&film.to_rgb_f32()));

        let mut expect = opts.metadata.clone();
        expect.sort();
        assert_eq!(read_exr_metadata(&path).unwrap(), expect);
        assert_eq!(entries(dir.path()), ["img.exr"]);
    }

    #[test]
    fn bad_exr_metadata_is_rejected_before_writing() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("img.exr");
        let film = gradient_film(2, 2);
        for metadata in [
            vec![("channels".to_string(), "x".to_string())],
            vec![(String::new(), "x".to_string())],
            vec![("spp".to_string(), "1".to_string()); 2],
            vec![("a\0b".to_string(), "x".to_string())],
        ] {
            let opts = OutputOptions {
                metadata,
                ..OutputOptions::default()
            };
            let err = write_image(&path, &film, &opts).unwrap_err();
            assert!(matches!(err, Error::Settings(_)), "{err}");
        }
        assert!(entries(dir.path()).is_empty());
    }

    #[test]
    fn layered_exr_names_each_channel_after_its_layer_and_keeps_the_values() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("aovs.exr");
        let plane = |k: f32| (0..6).map(|i| i as f32 * k).collect::<Vec<f32>>();
        let layers = [
            ExrLayer {
                name: String::new(),
                channels: vec![
                    ("R".into(), plane(1.0)),
                    ("G".into(), plane(2.0)),
                    ("B".into(), plane(3.0)),
                ],
            },
            ExrLayer {
                name: "depth".into(),
                channels: vec![("Z".into(), plane(0.5))],
            },
        ];
        write_exr_layers(&path, 3, 2, &layers, &[]).unwrap();
        let read = read_exr_channels(&path).unwrap();
        let names: Vec<String> = read
            .channel_data
            .list
            .iter()
            .map(|c| c.name.to_string())
            .collect();
        assert_eq!(names, ["B", "G", "R", "depth.Z"]);
        let depth = &read.channel_data.list[3].sample_data;
        assert_eq!(depth.values_as_f32().collect::<Vec<_>>(), plane(0.5));
        let short = [ExrLayer {
            name: "x".into(),
            channels: vec![("Y".into(), vec![1.0])],
        }];
        let e = write_exr_layers(&path, 3, 2, &short, &[]).unwrap_err();
        assert!(e.to_string().contains("x.Y holds 1 values"), "{e}");
    }

    #[test]
    fn reading_a_non_exr_file_is_an_input_error() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("fake.exr");
        fs::write(&path, b"definitely not an exr file").unwrap();
        assert!(matches!(read_exr(&path), Err(Error::Input { .. })));
        assert!(matches!(read_exr_metadata(&path), Err(Error::Input { .. })));
    }
}
