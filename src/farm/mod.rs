//! Rendering beyond one process: sample-range shards (`--shard K/N`), pixel
//! windows (`--crop`), accumulation files, `merge`, and checkpoints.
//!
//! An **accumulation file** is a render's state: for every pixel of its
//! window, the fixed-point sums of its samples and of their squares and the
//! sample count (see [`crate::film::FRACTION_BITS`]), plus where it came
//! from (the [`Provenance`]). It is one OpenEXR part whose channels are
//! grouped into layers, so image tools open it:
//!
//! - `R`, `G`, `B` (`f32`): the pixel means, the image so far;
//! - `variance.R`, `variance.G`, `variance.B` (`f32`): the variance of each
//!   mean;
//! - `count` (`u32`): samples accepted per pixel;
//! - `sum.R.0` ... `sum.B.3` and `sumsq.R.0` ... `sumsq.B.3` (`u32`): the
//!   exact 128-bit accumulators, four 32-bit limbs each, limb 0 the lowest.
//!
//! The data window is the crop window, inside a display window of the whole
//! image, so a viewer places a crop where it belongs. Provenance goes in
//! text attributes named `embertrace.*`.
//!
//! Because the sums are integers, adding parts in any order gives the same
//! bits, and a merge of shards or crops equals the one-process render bit for
//! bit: the samples themselves are the same (every sample is seeded by seed,
//! pixel and sample index, and pixels are traced in the same 4 x 4 blocks of
//! the image's grid), and their sums no longer depend on the order.

use crate::error::{Error, Result};
use crate::film::{Film, TileBounds};
use crate::image::{
    check_exr_sizes, exr_layer_attributes, read_exr_channels, read_exr_metadata, write_exr_image,
};
use crate::scene::Scene;
use std::fmt::Write as _;
use std::ops::Range;
use std::path::{Path, PathBuf};

mod merge;
pub use crate::hash::Fnv;
pub use crate::memory::peak_memory_bytes;
pub use merge::{MergeReport, PartInfo, merge};

/// `--shard K/N`: the K-th (1-based) of N equal parts of every pixel's
/// samples.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Shard {
    /// Which part, `1..=n`.
    pub k: u32,
    /// How many parts.
    pub n: u32,
}

impl Shard {
    /// Parse `K/N` with `1 <= K <= N`.
    pub fn parse(s: &str) -> std::result::Result<Shard, String> {
        let bad = || format!("--shard {s}: expected K/N with 1 <= K <= N, for example 3/8");
        let (k, n) = s.split_once('/').ok_or_else(bad)?;
        let k: u32 = k.trim().parse().map_err(|_| bad())?;
        let n: u32 = n.trim().parse().map_err(|_| bad())?;
        if k == 0 || k > n {
            return Err(bad());
        }
        Ok(Shard { k, n })
    }

    /// The sample indices of this shard of a render of `spp` samples per
    /// pixel: `floor((k - 1) spp / n) .. floor(k spp / n)`, so the N shards
    /// tile `0..spp` (some are empty when `n > spp`).
    pub fn samples(&self, spp: u32) -> Range<u32> {
        let at = |k: u32| (u64::from(k) * u64::from(spp) / u64::from(self.n)) as u32;
        at(self.k - 1)..at(self.k)
    }
}

/// `--crop X0 Y0 X1 Y1`: the half-open pixel window `[x0, x1) x [y0, y1)`,
/// origin top left, checked against the image size.
pub fn crop_window(c: [u32; 4], resolution: [u32; 2]) -> Result<TileBounds> {
    let [x0, y0, x1, y1] = c;
    let [w, h] = resolution;
    if !(x0 < x1 && x1 <= w && y0 < y1 && y1 <= h) {
        return Err(Error::Settings(format!(
            "--crop {x0} {y0} {x1} {y1}: expected X0 < X1 <= {w} and Y0 < Y1 <= {h} (half-open, in pixels, origin top left)"
        )));
    }
    Ok(TileBounds {
        x0,
        y0,
        width: x1 - x0,
        height: y1 - y0,
    })
}

/// The whole image as a window.
pub fn full_window(resolution: [u32; 2]) -> TileBounds {
    TileBounds {
        x0: 0,
        y0: 0,
        width: resolution[0],
        height: resolution[1],
    }
}

// ---------------------------------------------------------------------------
// Hashes
// ---------------------------------------------------------------------------

/// A hash of everything in `scene` that can change an image: geometry
/// (bit patterns), materials, textures, lights, camera, lens, resolution and
/// render defaults. Left out: where the file lies (farm nodes mount it at
/// different paths) and the notes and warnings loading printed. Every field
/// is named, so a field added to [`Scene`] fails to compile here until it is
/// considered.
pub fn scene_hash(scene: &Scene) -> u64 {
    let Scene {
        source: _,
        // where the geometry came from changes no pixel
        mesh_files: _,
        positions,
        indices,
        normals,
        needle,
        tri_material,
        materials,
        meshes,
        tri_uv,
        tri_shading_normals,
        // derived from the positions, UVs and materials hashed here
        tri_dpduv: _,
        spheres,
        sphere_material,
        sphere_uv_frames,
        instances,
        environment,
        environment_map,
        point_lights,
        spot_lights,
        directional_lights,
        panel_lights,
        camera,
        // where render space sits in the world changes no pixel
        world_origin: _,
        lens,
        focal_pixels,
        resolution,
        render,
        notes: _,
        warnings: _,
    } = scene;
    let mut h = Fnv::default();
    h.floats(positions.len(), positions.iter().flat_map(|p| p.to_array()));
    h.words(indices.len(), indices.iter().flatten().copied());
    h.floats(normals.len(), normals.iter().flat_map(|p| p.to_array()));
    h.floats(needle.len(), needle.iter().copied());
    h.words(tri_material.len(), tri_material.iter().copied());
    h.floats(
        tri_uv.len(),
        tri_uv.iter().flatten().flat_map(|p| p.to_array()),
    );
    h.floats(
        tri_shading_normals.len(),
        tri_shading_normals
            .iter()
            .flatten()
            .flat_map(|p| p.to_array()),
    );
    h.words(sphere_material.len(), sphere_material.iter().copied());
    // the rest is small or rare: its Debug text, streamed into the hash
    let _ = write!(
        h,
        "{materials:?}{meshes:?}{spheres:?}{environment:?}{environment_map:?}{point_lights:?}\
         {directional_lights:?}{camera:?}{lens:?}{focal_pixels:?}{resolution:?}{render:?}"
    );
    // written only when there are any, so that the hash of a scene
    // without spot lights is what it was before they existed
    if !spot_lights.is_empty() {
        let _ = write!(h, "{spot_lights:?}");
    }
    if !panel_lights.is_empty() || !sphere_uv_frames.is_empty() {
        let _ = write!(h, "{panel_lights:?}{sphere_uv_frames:?}");
    }
    // instances: the prototypes' bits, then each placement's (the shading
    // data follows from the geometry and the materials above); nothing for
    // a scene without, whose hash stays what it was
    if instances.is_empty() {
        return h.finish();
    }
    for (p, sh) in instances.prototypes.iter().zip(&instances.shading) {
        h.floats(
            p.positions.len(),
            p.positions.iter().flat_map(|q| q.to_array()),
        );
        h.words(p.indices.len(), p.indices.iter().flatten().copied());
        h.words(sh.tri_material.len(), sh.tri_material.iter().copied());
        h.floats(
            sh.tri_uv.len(),
            sh.tri_uv.iter().flatten().flat_map(|q| q.to_array()),
        );
        h.floats(
            sh.tri_shading_normals.len(),
            sh.tri_shading_normals
                .iter()
                .flatten()
                .flat_map(|q| q.to_array()),
        );
    }
    h.floats(
        instances.placements.len(),
        instances.placements.iter().flat_map(|p| {
            p.to_render
                .to_cols_array()
                .into_iter()
                .chain([f32::from_bits(p.prototype)])
        }),
    );
    h.words(instances.material.len(), instances.material.iter().copied());
    h.finish()
}

// ---------------------------------------------------------------------------
// Provenance
// ---------------------------------------------------------------------------

/// Prefix of the text attributes an accumulation file keeps its provenance
/// in.
const ATTR: &str = "embertrace.";

/// Where an accumulation file came from, and what it holds.
#[derive(Debug, Clone, PartialEq)]
pub struct Provenance {
    /// The embertrace version that rendered it.
    pub version: String,
    /// The build's source digest ([`crate::build_info::SOURCE_DIGEST`]):
    /// parts from builds whose code differs do not merge unless asked to.
    /// Empty in files written before builds recorded it.
    pub build: String,
    /// The scene file's name (for messages only; not compared).
    pub scene: String,
    /// [`scene_hash`] of the scene.
    pub scene_hash: u64,
    /// Every setting that changes the image, `name = value`, in a fixed
    /// order: resolution, spp, seed, sampler, max depth, light samples,
    /// direct strategy, roulette, backend, kernel, clamp. Parts merge only if
    /// these are equal.
    pub settings: Vec<(String, String)>,
    /// The sample indices every pixel of the window holds.
    pub samples: Range<u32>,
    /// The pixel window it covers.
    pub window: TileBounds,
}

/// How the `guiding` setting (`4 iterations, 12 spp kept`) ends the
/// training samples per pixel that a guided render's part beginning at
/// sample 0 holds besides its own ([`crate::guiding::Guide::reused`]).
pub const KEPT_SPP_SUFFIX: &str = " spp kept";

impl Provenance {
    /// Training samples per pixel a part beginning at sample 0 holds
    /// besides its own ([`KEPT_SPP_SUFFIX`]); 0 when unguided.
    pub fn kept_spp(&self) -> u32 {
        self.setting("guiding")
            .and_then(|v| v.split(", ").find_map(|f| f.strip_suffix(KEPT_SPP_SUFFIX)))
            .and_then(|n| n.parse().ok())
            .unwrap_or(0)
    }

    /// The value of setting `name`.
    pub fn setting(&self, name: &str) -> Option<&str> {
        self.settings
            .iter()
            .find(|(n, _)| n == name)
            .map(|(_, v)| v.as_str())
    }

    /// The image size, from the `resolution` setting.
    pub fn resolution(&self) -> Option<[u32; 2]> {
        let (w, h) = self.setting("resolution")?.split_once('x')?;
        Some([w.parse().ok()?, h.parse().ok()?])
    }

    /// The render's samples per pixel, from the `spp` setting.
    pub fn spp(&self) -> Option<u32> {
        self.setting("spp")?.parse().ok()
    }

    /// A hash of the settings, for reports.
    pub fn settings_hash(&self) -> u64 {
        let mut h = Fnv::default();
        for (n, v) in &self.settings {
            let _ = writeln!(h, "{n}={v}");
        }
        h.finish()
    }

    /// The attributes this provenance is stored as.
    pub fn metadata(&self) -> Vec<(String, String)> {
        let w = self.window;
        let mut m = vec![
            (format!("{ATTR}kind"), "accumulation".to_string()),
            (format!("{ATTR}version"), self.version.clone()),
            (format!("{ATTR}build"), self.build.clone()),
            (format!("{ATTR}scene"), self.scene.clone()),
            (
                format!("{ATTR}scene_hash"),
                format!("{:016x}", self.scene_hash),
            ),
            (
                format!("{ATTR}settings_hash"),
                format!("{:016x}", self.settings_hash()),
            ),
            (
                format!("{ATTR}samples"),
                format!("{} {}", self.samples.start, self.samples.end),
            ),
            (
                format!("{ATTR}window"),
                format!("{} {} {} {}", w.x0, w.y0, w.x0 + w.width, w.y0 + w.height),
            ),
        ];
        for (n, v) in &self.settings {
            m.push((format!("{ATTR}setting.{n}"), v.clone()));
        }
        m
    }

    /// Read a provenance back from `path`'s attributes (sorted by name, as
    /// [`crate::image::read_exr_metadata`] returns them).
    fn from_metadata(path: &Path, meta: &[(String, String)]) -> Result<Provenance> {
        let get = |name: &str| {
            meta.iter()
                .find(|(n, _)| n.strip_prefix(ATTR) == Some(name))
                .map(|(_, v)| v.as_str())
        };
        let bad = |what: &str| {
            Error::input(
                path,
                None,
                format!("not an embertrace accumulation file ({what})"),
            )
        };
        if get("kind") != Some("accumulation") {
            return Err(bad(
                "no embertrace.kind = accumulation attribute: write one with render --shard, --crop or --checkpoint",
            ));
        }
        let nums = |name: &str, n: usize| -> Result<Vec<u32>> {
            let v: Vec<u32> = get(name)
                .ok_or_else(|| bad(&format!("no {ATTR}{name}")))?
                .split_whitespace()
                .map(|t| t.parse::<u32>())
                .collect::<std::result::Result<_, _>>()
                .map_err(|_| bad(&format!("{ATTR}{name} is not {n} numbers")))?;
            if v.len() != n {
                return Err(bad(&format!("{ATTR}{name} is not {n} numbers")));
            }
            Ok(v)
        };
        let s = nums("samples", 2)?;
        let w = nums("window", 4)?;
        if s[0] > s[1] || w[0] >= w[2] || w[1] >= w[3] {
            return Err(bad("empty or inverted window or sample range"));
        }
        let scene_hash = u64::from_str_radix(get("scene_hash").unwrap_or(""), 16)
            .map_err(|_| bad(&format!("no valid {ATTR}scene_hash")))?;
        let prefix = format!("{ATTR}setting.");
        // the settings' order is the writer's; the reader sees them sorted,
        // which is as good for comparing
        let settings = meta
            .iter()
            .filter_map(|(n, v)| Some((n.strip_prefix(&prefix)?.to_string(), v.clone())))
            .collect();
        let p = Provenance {
            version: get("version").unwrap_or("").to_string(),
            build: get("build").unwrap_or("").to_string(),
            scene: get("scene").unwrap_or("").to_string(),
            scene_hash,
            settings,
            samples: s[0]..s[1],
            window: TileBounds {
                x0: w[0],
                y0: w[1],
                width: w[2] - w[0],
                height: w[3] - w[1],
            },
        };
        let (Some([rw, rh]), Some(spp)) = (p.resolution(), p.spp()) else {
            return Err(bad("no resolution or spp setting"));
        };
        // the documented limits hold for what a file says as for a command
        // line: a forged part cannot claim more
        crate::limits::check_resolution(u64::from(rw), u64::from(rh))
            .and_then(|()| crate::limits::check_spp(u64::from(spp)))
            .map_err(|m| bad(&m))?;
        if w[2] > rw || w[3] > rh || s[1] > spp {
            return Err(bad("window or sample range outside the render"));
        }
        Ok(p)
    }

    /// Settings sorted by name, for comparing provenances whatever order
    /// they were written or read in.
    fn sorted_settings(&self) -> Vec<(String, String)> {
        let mut s = self.settings.clone();
        s.sort();
        s
    }
}

// ---------------------------------------------------------------------------
// Accumulation files
// ---------------------------------------------------------------------------

/// Names of the channels of one 128-bit accumulator: `{layer}.{c}.0..3`.
fn limb_names(layer: &str, c: char) -> [String; 4] {
    std::array::from_fn(|k| format!("{layer}.{c}.{k}"))
}

const RGB: [char; 3] = ['R', 'G', 'B'];

/// Name of the attribute a checkpoint of a guided render keeps its guide
/// in (OpenEXR type `bytes`, type hint [`GUIDE_HINT`];
/// [`crate::guiding::Guide::to_bytes`]'s format).
pub const GUIDE_ATTRIBUTE: &str = "embertrace.guide";

/// The type hint of [`GUIDE_ATTRIBUTE`].
const GUIDE_HINT: &str = "application/x-embertrace-guide";

/// Write `film` with its provenance as an accumulation file, atomically.
pub fn write_accumulation(path: &Path, film: &Film, prov: &Provenance) -> Result<()> {
    write_state(path, film, prov, None)
}

/// The guide a checkpoint at `path` saved ([`GUIDE_ATTRIBUTE`]), if it
/// saved one; a guide that does not read back is an input error.
pub fn read_guide(path: &Path) -> Result<Option<crate::guiding::Guide>> {
    let Some(bytes) = crate::image::read_exr_bytes(path, GUIDE_ATTRIBUTE, GUIDE_HINT)? else {
        return Ok(None);
    };
    crate::guiding::Guide::from_bytes(&bytes)
        .map(Some)
        .map_err(|e| Error::input(path, None, format!("{GUIDE_ATTRIBUTE}: {e}")))
}

/// [`write_accumulation`], with `guide` (saved guide bytes) in
/// [`GUIDE_ATTRIBUTE`] when given.
fn write_state(path: &Path, film: &Film, prov: &Provenance, guide: Option<&[u8]>) -> Result<()> {
    use exr::prelude::{
        AnyChannel, AnyChannels, Encoding, FlatSamples, Image, ImageAttributes, IntegerBounds,
        Layer, LayerAttributes, SmallVec, Vec2,
    };
    let b = film.bounds();
    debug_assert_eq!(b, prov.window);
    let px = film.pixels();
    let mut channels: SmallVec<[AnyChannel<FlatSamples>; 4]> = SmallVec::new();
    for (c, name) in RGB.iter().enumerate() {
        let mean = px.iter().map(|p| p.mean_f64()[c] as f32).collect();
        channels.push(AnyChannel::new(
            name.to_string().as_str(),
            FlatSamples::F32(mean),
        ));
        let var = px
            .iter()
            .map(|p| p.variance_of_mean_f64()[c] as f32)
            .collect();
        channels.push(AnyChannel::new(
            format!("variance.{name}").as_str(),
            FlatSamples::F32(var),
        ));
        for (layer, acc) in [("sum", 0), ("sumsq", 1)] {
            for (k, limb) in limb_names(layer, *name).into_iter().enumerate() {
                let v = px
                    .iter()
                    .map(|p| {
                        let q = if acc == 0 { p.sum[c] } else { p.sum_sq[c] };
                        (q >> (32 * k)) as u32
                    })
                    .collect();
                channels.push(AnyChannel::new(limb.as_str(), FlatSamples::U32(v)));
            }
        }
    }
    let counts = px.iter().map(|p| p.count as u32).collect();
    channels.push(AnyChannel::new("count", FlatSamples::U32(counts)));

    let [rw, rh] = prov
        .resolution()
        .expect("a provenance we made has a resolution");
    let mut attributes = LayerAttributes {
        layer_position: Vec2(b.x0 as i32, b.y0 as i32),
        ..exr_layer_attributes(&prov.metadata())
    };
    if let Some(g) = guide {
        attributes = crate::image::with_exr_bytes(attributes, GUIDE_ATTRIBUTE, GUIDE_HINT, g);
    }
    let layer = Layer::new(
        (b.width as usize, b.height as usize),
        attributes,
        Encoding::SMALL_LOSSLESS,
        AnyChannels::sort(channels),
    );
    let mut image = Image::from_layer(layer);
    image.attributes = ImageAttributes::new(IntegerBounds::new((0, 0), (rw as usize, rh as usize)));
    write_exr_image(path, &image)
}

/// `(width, height, x, y)` of a window, as an EXR data window says it.
fn pixel_window(w: TileBounds) -> (usize, usize, i32, i32) {
    (
        w.width as usize,
        w.height as usize,
        w.x0 as i32,
        w.y0 as i32,
    )
}

/// Checks, from its header alone, that an accumulation file's pixels are the
/// window its provenance claims and that its bytes can hold them: nothing is
/// allocated from the attributes until they agree with the data.
fn check_pixels_match(path: &Path, prov: &Provenance) -> Result<()> {
    window_matches(path, prov, check_exr_sizes(path)?)
}

/// Fails unless `found`, a data window `(width, height, x, y)`, is the
/// window `prov` claims.
fn window_matches(path: &Path, prov: &Provenance, found: (usize, usize, i32, i32)) -> Result<()> {
    let (lw, lh, x, y) = found;
    if found != pixel_window(prov.window) {
        return Err(Error::input(
            path,
            None,
            format!("its pixels ({lw} x {lh} at {x}, {y}) do not match its embertrace.window"),
        ));
    }
    Ok(())
}

/// Read an accumulation file: its film (window and exact sums) and
/// provenance.
pub fn read_accumulation(path: &Path) -> Result<(Film, Provenance)> {
    use exr::prelude::FlatSamples;
    let meta = read_exr_metadata(path)?;
    let prov = Provenance::from_metadata(path, &meta)?;
    // read_exr_channels checks the header's sizes before it allocates
    let layer = read_exr_channels(path)?;
    let w = prov.window;
    let pos = layer.attributes.layer_position;
    let found = (layer.size.width(), layer.size.height(), pos.x(), pos.y());
    window_matches(path, &prov, found)?;
    let channel = |name: &str| -> Result<&[u32]> {
        let ch = layer
            .channel_data
            .list
            .iter()
            .find(|c| c.name.eq(name))
            .ok_or_else(|| Error::input(path, None, format!("no `{name}` channel")))?;
        match &ch.sample_data {
            FlatSamples::U32(v) => Ok(v),
            _ => Err(Error::input(
                path,
                None,
                format!("channel `{name}` is not 32-bit unsigned"),
            )),
        }
    };
    let mut film = Film::window(w);
    let counts = channel("count")?;
    for (p, &n) in film.pixels_mut().iter_mut().zip(counts) {
        p.count = u64::from(n);
    }
    for (c, name) in RGB.iter().enumerate() {
        for (layer_name, acc) in [("sum", 0), ("sumsq", 1)] {
            let limbs = limb_names(layer_name, *name)
                .map(|n| channel(&n))
                .into_iter()
                .collect::<Result<Vec<_>>>()?;
            for (i, p) in film.pixels_mut().iter_mut().enumerate() {
                let q = (0..4).fold(0u128, |q, k| q | u128::from(limbs[k][i]) << (32 * k));
                if acc == 0 {
                    p.sum[c] = q;
                } else {
                    p.sum_sq[c] = q;
                }
            }
        }
    }
    let kept = if prov.samples.start == 0 {
        prov.kept_spp()
    } else {
        0
    };
    let too_many = film
        .pixels()
        .iter()
        .any(|p| p.count > u64::from(prov.samples.end - prov.samples.start) + u64::from(kept));
    if too_many {
        return Err(Error::input(
            path,
            None,
            "a pixel counts more samples than its sample range holds",
        ));
    }
    Ok((film, prov))
}

fn window_array(w: TileBounds) -> [u32; 4] {
    [w.x0, w.y0, w.x0 + w.width, w.y0 + w.height]
}

/// A build's source digest as messages name it.
pub fn build_name(digest: &str) -> &str {
    if digest.is_empty() {
        "not recorded"
    } else {
        digest
    }
}

/// Check that `prov` (from a checkpoint) was made by this scene and these
/// settings, except `spp`, which may differ when `same_points` says the
/// sampler's points do not depend on it.
pub fn check_resume(
    path: &Path,
    prov: &Provenance,
    now: &Provenance,
    same_points: bool,
    allow_mixed_builds: bool,
) -> Result<()> {
    let fail = |what: String| {
        Err(Error::Settings(format!(
            "--resume {}: {what}; render it again or resume with the settings it was made with",
            path.display()
        )))
    };
    if !allow_mixed_builds && (&prov.version, &prov.build) != (&now.version, &now.build) {
        return fail(format!(
            "written by embertrace {} (source {}), this is {} (source {}); pass --allow-mixed-builds if their pixels agree",
            prov.version,
            build_name(&prov.build),
            now.version,
            build_name(&now.build)
        ));
    }
    if prov.scene_hash != now.scene_hash {
        return fail("made from a different scene (or the scene changed)".into());
    }
    let now_s = now.sorted_settings();
    for ((n, v), (n_now, v_now)) in prov.sorted_settings().iter().zip(&now_s) {
        if n != n_now {
            return fail(format!(
                "made with setting {n} where this render has {n_now} (one of them set only when used, as guiding)"
            ));
        }
        if v != v_now && !(n == "spp" && same_points) {
            return fail(format!("made with {n} = {v}, not {v_now}"));
        }
    }
    if prov.settings.len() != now_s.len() {
        return fail("made with other settings".into());
    }
    if prov.window != now.window {
        return fail(format!(
            "covers pixels {:?}, this render {:?}",
            window_array(prov.window),
            window_array(now.window)
        ));
    }
    if prov.samples.start != now.samples.start || prov.samples.end > now.samples.end {
        return fail(format!(
            "holds samples {}..{}, this render wants {}..{}",
            prov.samples.start, prov.samples.end, now.samples.start, now.samples.end
        ));
    }
    Ok(())
}

// ---------------------------------------------------------------------------
// Rendering a part, with checkpoints
// ---------------------------------------------------------------------------

/// Where and how often a render saves its state.
#[derive(Debug, Clone)]
pub struct Checkpoint {
    /// The accumulation file.
    pub path: PathBuf,
    /// Seconds between saves (the render saves after the first pass that
    /// ends this long after the last save, and at the end).
    pub every: f64,
}

/// The longest a pass of a checkpointed render aims to take: the render
/// stops (on a signal) and saves only between passes.
pub const PASS_SECONDS: f64 = 2.0;

/// A part of a render: its window, its samples, where it saves.
pub struct Part<'a> {
    /// What every accumulation file of this render says (its `samples` are
    /// the part's target range).
    pub provenance: Provenance,
    /// The state to continue from (`--resume`): its film and the samples it
    /// holds, `provenance.samples.start .. done`.
    pub resume: Option<(Film, u32)>,
    /// Save here as the render goes, and at the end.
    pub checkpoint: Option<Checkpoint>,
    /// The guide the render samples from ([`crate::guiding::Guide::to_bytes`]),
    /// saved with every checkpoint so that `--resume` samples from it
    /// without training again.
    pub guide: Option<Vec<u8>>,
    /// Training samples the render keeps ([`crate::guiding::Guide::reused`]):
    /// added to the film when the part begins at sample 0 and resumes
    /// nothing, so that a pixel's parts hold them once.
    pub kept: Option<&'a Film>,
    /// Set (by a signal handler) to stop after the current pass.
    pub stop: &'a std::sync::atomic::AtomicBool,
}

/// How a part's render ended.
#[derive(Debug)]
pub struct PartOutput {
    /// The film and counts, as a one-process render returns them.
    pub out: crate::render::RenderOutput,
    /// Samples `provenance.samples.start .. done` are in the film.
    pub done: u32,
    /// Whether it stopped early (on `stop`).
    pub interrupted: bool,
}

/// Render `part`: its window, samples `part.provenance.samples` of every
/// pixel (`settings.spp` is the whole render's spp, which samplers depend
/// on), in passes of whole sample indices when checkpointing (passes give
/// the same bits as one run), saving the state every `every` seconds and at
/// the end, and stopping early when `part.stop` is set.
pub fn render_part(
    tracer: &dyn crate::render::Radiance,
    camera: &crate::camera::Camera,
    settings: &crate::render::RenderSettings,
    part: Part<'_>,
    say: &dyn Fn(&str),
) -> Result<PartOutput> {
    use crate::integrator::RayCounts;
    use crate::render::{ClampReport, NonFiniteReport, RenderOutput, RenderSettings, render_pass};
    use std::sync::atomic::Ordering;
    use std::time::Instant;

    let prov = &part.provenance;
    let target = prov.samples.clone();
    let (mut film, mut done) = match part.resume {
        Some((film, done)) => (film, done),
        None => {
            let mut film = Film::window(prov.window);
            if let (Some(k), 0) = (part.kept, target.start) {
                film.add_overlap(k);
            }
            (film, target.start)
        }
    };
    let pool = crate::render::thread_pool(settings.threads)?;
    let (mut rays, mut nonfinite, mut clamp) = (
        RayCounts::default(),
        NonFiniteReport::default(),
        ClampReport::default(),
    );
    let save = |film: &Film, done: u32| -> Result<()> {
        if let Some(c) = &part.checkpoint {
            let p = Provenance {
                samples: target.start..done,
                ..prov.clone()
            };
            write_state(&c.path, film, &p, part.guide.as_deref())?;
        }
        Ok(())
    };
    let start = Instant::now();
    let mut last_save = Instant::now();
    let mut per_sample: Option<f64> = None;
    let mut interrupted = false;
    while done < target.end {
        if part.stop.load(Ordering::SeqCst) {
            interrupted = true;
            break;
        }
        let left = target.end - done;
        let n = match (&part.checkpoint, per_sample) {
            (None, _) => left,
            (Some(_), None) => 1,
            (Some(c), Some(t)) => {
                let aim = c.every.min(PASS_SECONDS);
                ((aim / t).floor().clamp(1.0, f64::from(left))) as u32
            }
        };
        let rs = RenderSettings {
            first_sample: done,
            spp: n,
            total_spp: Some(settings.spp),
            ..*settings
        };
        let t = Instant::now();
        let pass = render_pass(tracer, camera, &rs, &mut film, None, &pool, &|| {});
        per_sample = Some(t.elapsed().as_secs_f64() / f64::from(n));
        rays.add(&pass.rays);
        nonfinite.merge(&pass.nonfinite);
        clamp.merge(&pass.clamp);
        done += n;
        if let Some(c) = &part.checkpoint {
            if done < target.end && last_save.elapsed().as_secs_f64() >= c.every {
                save(&film, done)?;
                say(&format!(
                    "checkpoint {}: samples {}..{done} of {}..{}",
                    c.path.display(),
                    target.start,
                    target.start,
                    target.end
                ));
                last_save = Instant::now();
            }
        }
    }
    if part.checkpoint.is_some() {
        save(&film, done)?;
    }
    nonfinite.finish(prov.resolution().map_or(1, |r| r[0]));
    Ok(PartOutput {
        out: RenderOutput {
            film,
            rays,
            nonfinite,
            clamp,
            seconds: start.elapsed().as_secs_f64(),
            threads: pool.current_num_threads(),
        },
        done,
        interrupted,
    })
}
