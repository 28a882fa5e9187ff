//! Every bound a scene file is held to, in one place, with its reason.
//!
//! Scene files are untrusted input: a few bytes of TOML can ask for a
//! billion-pixel film, a million copies of a large mesh or a path a hundred
//! thousand bounces deep. The loaders check each request against the limits
//! below before they allocate or build anything for it, and refuse with a
//! one-line error naming the file and line (`../shared/docs/hard-cases.md`,
//! section E). Each limit is far beyond what a render on a workstation uses,
//! and small enough that nothing downstream overflows, exhausts memory or
//! crashes.
//!
//! Files are read whole, so their sizes are capped too
//! ([`MAX_SCENE_FILE_BYTES`], [`MAX_MESH_FILE_BYTES`]): a larger regular
//! file is refused before a byte is read, and a device or pipe (`/dev/zero`)
//! is read only up to the cap, or, for a text format, up to its first NUL
//! byte. What costs time rather than memory (a high spp) is the user's to
//! ask for.

/// Largest scene description read whole (TOML, Mitsuba XML, COLLADA, `.test`,
/// MTL): 256 MiB, far beyond any hand-written or exported scene file (their
/// meshes live in files of their own).
pub const MAX_SCENE_FILE_BYTES: u64 = 256 << 20;

/// Largest mesh file read whole (OBJ, PLY): 1 GiB, about 15 million
/// triangles of OBJ text or 40 million of binary PLY. Reading an OBJ takes
/// about three times its size in memory at the peak (the bytes, the text
/// checked for tobj, tobj's arrays), so this keeps a load within a few GiB.
pub const MAX_MESH_FILE_BYTES: u64 = 1 << 30;

/// Largest accepted image side, in pixels (32768).
pub const MAX_RESOLUTION: u32 = 1 << 15;

/// Largest accepted pixel count: 2^28, about 268 Mpixels. The film keeps
/// per-pixel sums and sums of squares in fixed point (`u128`) and a count
/// (112 bytes a pixel, 28 GiB at this size).
pub const MAX_PIXELS: u64 = 1 << 28;

/// Largest coordinate magnitude a placed vertex may have. Embree silently
/// ignores, while building, any primitive containing NaN, an infinity or a
/// value greater than 1.844e18 (Embree 3 API manual, `rtcCommitScene`:
/// "values greater than 1.844E18f"; `FLT_LARGE` in Embree's
/// `common/math/constants.h`). We stop a little short of it: a file with a
/// coordinate beyond this is an error at its line, and a triangle that
/// leaves the range only once a transform places it is dropped with a
/// warning naming the mesh, so that every backend sees the same triangles.
pub const MAX_COORDINATE: f32 = 1.8e18;

/// Largest triangle count of a whole scene, all meshes and procedural
/// shapes together: 10^8. Scene arrays take about 34 bytes a triangle and
/// the pure-Rust BVH 64 more (about 10 GiB in all at this size); the
/// issue's benchmark scenes go up to 10^7. A file that asks for more (one
/// `triangles = 10^12`, or a mesh listed a million times) is refused before
/// its triangles are generated or placed.
pub const MAX_TRIANGLES: u64 = 100_000_000;

/// Largest vertex count of a whole scene: three per triangle at most, which
/// keeps every vertex index in `u32`.
pub const MAX_VERTICES: u64 = 3 * MAX_TRIANGLES;

/// Most samples per pixel a scene file may ask for: 2^24 (16.7 million).
/// Sample indices are `u32` and progressive passes count on from the last
/// one, so this leaves room for 256 such runs before an index could wrap.
pub const MAX_SPP: u32 = 1 << 24;

/// Deepest path a scene file (or `-m`) may ask for, in bounces. The path
/// tracer recurses once a bounce: on one render thread (2 MiB stack), inside
/// a closed white sphere with `--rr 1`, 3000 bounces rendered and 5000
/// aborted with a stack overflow, in the dev profile and in a release build
/// alike. 1024 keeps a margin of about three and is far beyond where
/// Russian roulette ends paths.
pub const MAX_DEPTH: u32 = 1024;

/// Most light samples per shading point a scene file may ask for: 2^10.
/// Each costs a shadow ray at every bounce, so more is only a slower render.
pub const MAX_LIGHT_SAMPLES: u32 = 1 << 10;

/// Most render threads (`-t`): 1024. Each has its own stack and tiles;
/// `-t 100000` spent tens of seconds starting threads for a small image.
/// More threads than cores gain nothing.
pub const MAX_THREADS: usize = 1024;

/// Check a thread count (0 = one per core) against [`MAX_THREADS`].
pub fn check_threads(n: usize) -> Result<(), String> {
    if n > MAX_THREADS {
        return Err(format!(
            "-t {n}: at most {MAX_THREADS} threads (0 = one per core)"
        ));
    }
    Ok(())
}

/// Check a resolution against [`MAX_RESOLUTION`] and [`MAX_PIXELS`].
pub fn check_resolution(w: u64, h: u64) -> Result<(), String> {
    if w == 0 || h == 0 || w > MAX_RESOLUTION as u64 || h > MAX_RESOLUTION as u64 {
        return Err(format!(
            "resolution {w} x {h} out of range (each side 1..={MAX_RESOLUTION}, at most {MAX_PIXELS} pixels)"
        ));
    }
    if w * h > MAX_PIXELS {
        return Err(format!(
            "resolution {w} x {h} is {} pixels (at most {MAX_PIXELS})",
            w * h
        ));
    }
    Ok(())
}

/// Check samples per pixel: 1 ..= [`MAX_SPP`].
pub fn check_spp(spp: u64) -> Result<(), String> {
    if spp == 0 || spp > MAX_SPP as u64 {
        return Err(format!("spp = {spp} out of range (1..={MAX_SPP})"));
    }
    Ok(())
}

/// Check a maximum path depth: 0 ..= [`MAX_DEPTH`].
pub fn check_max_depth(depth: u64) -> Result<(), String> {
    if depth > MAX_DEPTH as u64 {
        return Err(format!(
            "max_depth = {depth} out of range (0..={MAX_DEPTH})"
        ));
    }
    Ok(())
}

/// Check light samples per shading point: 1 ..= [`MAX_LIGHT_SAMPLES`].
pub fn check_light_samples(n: u64) -> Result<(), String> {
    if n == 0 || n > MAX_LIGHT_SAMPLES as u64 {
        return Err(format!(
            "light_samples = {n} out of range (1..={MAX_LIGHT_SAMPLES})"
        ));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bounds_are_inclusive_and_reject_zero() {
        assert!(check_resolution(1, 1).is_ok());
        assert!(check_resolution(MAX_RESOLUTION as u64, 1 << 13).is_ok());
        assert!(check_resolution(MAX_RESOLUTION as u64, MAX_RESOLUTION as u64).is_err());
        assert!(check_resolution(0, 8).is_err());
        assert!(check_resolution(1_000_000_000, 1_000_000_000).is_err());
        assert!(check_spp(1).is_ok() && check_spp(MAX_SPP as u64).is_ok());
        assert!(check_spp(0).is_err() && check_spp(MAX_SPP as u64 + 1).is_err());
        assert!(check_max_depth(0).is_ok() && check_max_depth(MAX_DEPTH as u64).is_ok());
        assert!(check_max_depth(MAX_DEPTH as u64 + 1).is_err());
        assert!(check_light_samples(0).is_err());
        assert!(check_light_samples(MAX_LIGHT_SAMPLES as u64).is_ok());
        assert!(check_light_samples(MAX_LIGHT_SAMPLES as u64 + 1).is_err());
        // the vertex limit keeps indices in u32
        assert!(MAX_VERTICES < u32::MAX as u64);
    }
}
