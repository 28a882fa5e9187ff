//! `merge`: accumulation files added into one film, after checking that
//! they come from one scene and settings, do not overlap and fill a box of
//! pixels and samples.

use super::{Provenance, check_pixels_match, peak_memory_bytes, read_accumulation, window_array};
use crate::error::{Error, Result};
use crate::film::{Film, TileBounds};
use crate::image::read_exr_metadata;
use crate::sampler::SamplerKind;
use std::path::PathBuf;

/// One part as `merge` saw it.
#[derive(Debug, Clone, serde::Serialize)]
pub struct PartInfo {
    /// The file.
    pub path: PathBuf,
    /// Its sample indices, `[start, end)`.
    pub samples: [u32; 2],
    /// Its window, `[x0, y0, x1, y1]`.
    pub window: [u32; 4],
    /// Seconds to read it.
    pub read_seconds: f64,
}

/// What `merge` did.
#[derive(Debug, Clone, serde::Serialize)]
pub struct MergeReport {
    /// The parts, in the order given.
    pub parts: Vec<PartInfo>,
    /// The merged window, `[x0, y0, x1, y1]`.
    pub window: [u32; 4],
    /// The merged sample range.
    pub samples: [u32; 2],
    /// Whether that is the whole render (every pixel, every sample).
    pub complete: bool,
    /// The scene's hash and the settings' hash, hexadecimal.
    pub scene_hash: String,
    /// Hash of the settings every part shares.
    pub settings_hash: String,
    /// Seconds for the whole merge (reading, checking, adding).
    pub seconds: f64,
    /// Peak resident memory of the process, bytes (Linux; 0 elsewhere).
    pub peak_memory_bytes: u64,
    /// `merge --denoise`: seconds the auxiliary images took.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub auxiliary_seconds: Option<f64>,
    /// `merge --denoise`: seconds the denoiser took.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub denoise_seconds: Option<f64>,
}

/// A part's box in (x, y, sample) space, half-open.
fn part_box(p: &Provenance) -> [[u64; 2]; 3] {
    let w = window_array(p.window).map(u64::from);
    [
        [w[0], w[2]],
        [w[1], w[3]],
        [u64::from(p.samples.start), u64::from(p.samples.end)],
    ]
}

fn volume(b: &[[u64; 2]; 3]) -> u128 {
    b.iter().map(|[a, z]| u128::from(z - a)).product()
}

/// Merge accumulation files, in any order. Every part must come from the
/// same scene, version and settings (but `spp`, where the sampler draws the
/// same points whatever the total: the merge then takes the largest); no
/// two may hold the same sample of the same pixel; together they must fill
/// a box of pixels and samples exactly, and, unless `partial`, the whole
/// render (every pixel, samples `0..spp`).
/// Returns the merged film, its provenance and a report; fails with a
/// one-line message naming the part at fault.
pub fn merge(
    parts: &[PathBuf],
    partial: bool,
    allow_mixed_builds: bool,
) -> Result<(Film, Provenance, MergeReport)> {
    let start = std::time::Instant::now();
    if parts.is_empty() {
        return Err(Error::Settings("merge: no parts given".into()));
    }
    // read every provenance first: a mismatch fails before any pixel is read
    let mut provs = Vec::with_capacity(parts.len());
    for path in parts {
        let meta = read_exr_metadata(path)?;
        let prov = Provenance::from_metadata(path, &meta)?;
        // the merged film is allocated from the windows: they must be the
        // parts' real pixels first
        check_pixels_match(path, &prov)?;
        provs.push(prov);
    }
    let (first, p0) = (&parts[0], &provs[0]);
    // parts rendered at different times may ask for different totals where
    // the sampler's points do not depend on the total: the merge then holds
    // the largest, and each part's samples are those of that render
    let extends = |p: &Provenance| {
        let kind = |p: &Provenance| p.setting("sampler")?.parse::<SamplerKind>().ok();
        match (kind(p), kind(p0), p.spp(), p0.spp()) {
            (Some(k), Some(k0), Some(a), Some(b)) => k == k0 && k.same_points(a, b),
            _ => false,
        }
    };
    let spp_free = |p: &Provenance| {
        let mut s = p.sorted_settings();
        if extends(p) {
            s.retain(|(n, _)| n != "spp");
        }
        s
    };
    let s0 = spp_free(p0);
    for (path, p) in parts.iter().zip(&provs).skip(1) {
        let at_fault = |what: String| {
            Error::Settings(format!(
                "merge: {}: {what} (the first part, {}, says otherwise); nothing written",
                path.display(),
                first.display()
            ))
        };
        if !allow_mixed_builds && (&p.version, &p.build) != (&p0.version, &p0.build) {
            return Err(at_fault(format!(
                "rendered by embertrace {} (source {}), not {} (source {}); pass --allow-mixed-builds if their pixels agree",
                p.version,
                super::build_name(&p.build),
                p0.version,
                super::build_name(&p0.build)
            )));
        }
        if p.scene_hash != p0.scene_hash {
            return Err(at_fault(format!(
                "rendered from a different scene ({}, hash {:016x})",
                p.scene, p.scene_hash
            )));
        }
        let (s, s0) = if extends(p) {
            (spp_free(p), s0.clone())
        } else {
            (p.sorted_settings(), p0.sorted_settings())
        };
        if s != s0 {
            let differs = s
                .iter()
                .zip(&s0)
                .find(|(a, b)| a != b)
                .map(|((n, v), (n0, v0))| {
                    if n == n0 {
                        format!("{n} = {v}, not {v0}")
                    } else {
                        format!("setting {n} where the first has {n0}")
                    }
                })
                .unwrap_or_else(|| "a different number of settings".into());
            return Err(at_fault(format!("rendered with other settings: {differs}")));
        }
    }
    // overlaps, then coverage of the bounding box
    let boxes: Vec<_> = provs.iter().map(part_box).collect();
    for i in 0..boxes.len() {
        for j in 0..i {
            let overlap = (0..3)
                .all(|a| boxes[i][a][0].max(boxes[j][a][0]) < boxes[i][a][1].min(boxes[j][a][1]));
            if overlap {
                return Err(Error::Settings(format!(
                    "merge: part {} ({}) overlaps part {} ({}): both hold samples {}..{} of pixels in {:?}; nothing written",
                    i + 1,
                    parts[i].display(),
                    j + 1,
                    parts[j].display(),
                    boxes[i][2][0].max(boxes[j][2][0]),
                    boxes[i][2][1].min(boxes[j][2][1]),
                    window_array(provs[i].window),
                )));
            }
        }
    }
    let mut bound = boxes[0];
    for b in &boxes[1..] {
        for a in 0..3 {
            bound[a] = [bound[a][0].min(b[a][0]), bound[a][1].max(b[a][1])];
        }
    }
    let filled: u128 = boxes.iter().map(volume).sum();
    let res = p0.resolution().expect("checked when read");
    let spp = provs
        .iter()
        .map(|p| p.spp().expect("checked when read"))
        .max()
        .expect("one part at least");
    let whole = [
        [0, u64::from(res[0])],
        [0, u64::from(res[1])],
        [0, u64::from(spp)],
    ];
    if filled != volume(&bound) || (!partial && bound != whole) {
        let target = if partial { bound } else { whole };
        let hole = find_hole(&boxes, &target);
        return Err(Error::Settings(format!(
            "merge: the parts do not cover {}: no part holds sample {} of pixel ({}, {}); nothing written",
            if partial {
                "a box of pixels and samples"
            } else {
                "the whole render"
            },
            hole[2],
            hole[0],
            hole[1]
        )));
    }
    // add the parts' exact sums
    let window = TileBounds {
        x0: bound[0][0] as u32,
        y0: bound[1][0] as u32,
        width: (bound[0][1] - bound[0][0]) as u32,
        height: (bound[1][1] - bound[1][0]) as u32,
    };
    let mut film = Film::window(window);
    let mut infos = Vec::with_capacity(parts.len());
    for (path, p) in parts.iter().zip(&provs) {
        let t = std::time::Instant::now();
        let (part, read) = read_accumulation(path)?;
        if read != *p {
            return Err(Error::input(path, None, "changed while merging"));
        }
        film.merge_film(&part);
        infos.push(PartInfo {
            path: path.clone(),
            samples: [p.samples.start, p.samples.end],
            window: window_array(p.window),
            read_seconds: t.elapsed().as_secs_f64(),
        });
    }
    let mut prov = Provenance {
        samples: bound[2][0] as u32..bound[2][1] as u32,
        window,
        ..p0.clone()
    };
    for (n, v) in &mut prov.settings {
        if n == "spp" {
            *v = spp.to_string();
        }
    }
    let report = MergeReport {
        parts: infos,
        window: window_array(window),
        samples: [prov.samples.start, prov.samples.end],
        complete: bound == whole,
        scene_hash: format!("{:016x}", prov.scene_hash),
        settings_hash: format!("{:016x}", prov.settings_hash()),
        seconds: start.elapsed().as_secs_f64(),
        peak_memory_bytes: peak_memory_bytes(),
        auxiliary_seconds: None,
        denoise_seconds: None,
    };
    Ok((film, prov, report))
}

/// A point of `target` that no box covers (boxes do not overlap and do not
/// fill it): found on the grid of the boxes' own coordinates.
fn find_hole(boxes: &[[[u64; 2]; 3]], target: &[[u64; 2]; 3]) -> [u64; 3] {
    let cuts = |a: usize| {
        let mut v: Vec<u64> = boxes
            .iter()
            .flat_map(|b| b[a])
            .chain(target[a])
            .filter(|&c| c >= target[a][0] && c < target[a][1])
            .collect();
        v.sort_unstable();
        v.dedup();
        v
    };
    let (xs, ys, ss) = (cuts(0), cuts(1), cuts(2));
    for &s in &ss {
        for &y in &ys {
            for &x in &xs {
                let p = [x, y, s];
                if !boxes
                    .iter()
                    .any(|b| (0..3).all(|a| b[a][0] <= p[a] && p[a] < b[a][1]))
                {
                    return p;
                }
            }
        }
    }
    // boxes outside the target only (cannot happen for a merge's bound)
    [target[0][0], target[1][0], target[2][0]]
}
