//! What a render runs with: the estimator's settings
//! ([`IntegratorSettings`], with its [`DirectStrategy`] and [`Roulette`]),
//! the defaults a scene file may set ([`RenderDefaults`]), and the one
//! resolver that merges those defaults with the command line's flags,
//! checked against the limits of [`crate::limits`] in one place. The scene
//! stores its defaults and the integrator reads its settings from here, so
//! neither imports the other for them.
//!
//! Every command that renders or plans a render (`render`, `study`, `bench
//! --effects` and `--efficiency`, `parity`'s image, `plan`) calls
//! [`resolve`], and `study --vary` checks each value with the same
//! `check_*` functions, so a setting one command refuses every command
//! refuses, in the same words. A flag overrides the scene; a value of zero
//! where at least one is needed (`-s 0`, `-l 0`, `--tile-size 0`) is an
//! error, never silently raised to one. Errors name the flag as the user
//! wrote it (`-s 0: ...`).

use crate::error::{Error, Result};
use crate::limits::{self, MAX_RESOLUTION};
use std::fmt;
use std::str::FromStr;

/// Which direct-lighting strategy to use.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DirectStrategy {
    /// Light and BSDF sampling combined by MIS.
    Mis,
    /// Light sampling only.
    Light,
    /// BSDF sampling only.
    Bsdf,
}

impl FromStr for DirectStrategy {
    type Err = String;
    fn from_str(s: &str) -> std::result::Result<Self, String> {
        match s {
            "mis" => Ok(DirectStrategy::Mis),
            "light" => Ok(DirectStrategy::Light),
            "bsdf" => Ok(DirectStrategy::Bsdf),
            _ => Err(format!(
                "unknown direct strategy `{s}` (expected mis, light or bsdf)"
            )),
        }
    }
}

impl fmt::Display for DirectStrategy {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            DirectStrategy::Mis => "mis",
            DirectStrategy::Light => "light",
            DirectStrategy::Bsdf => "bsdf",
        })
    }
}

/// Russian roulette policy.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Roulette {
    /// Continue with probability `min(1, max component of the throughput)`.
    Throughput,
    /// Continue with a fixed probability in `[0, 1]`.
    Fixed(f32),
}

/// How the estimator chooses a light (`--light-sampler`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum LightSampler {
    /// The light BVH when the scene has at least [`LIGHT_BVH_FROM`] lights
    /// that are not at infinity, else power.
    #[default]
    Auto,
    /// In proportion to each light's power, with an alias table.
    Power,
    /// By a light BVH, in proportion to each light's importance at the
    /// shading point (`src/integrator/light_bvh.rs`).
    Bvh,
}

/// Where non-delta bounces sample lights (`--light-sampling`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum LightSampling {
    /// At every non-delta bounce but where the BSDF's lobes are so much
    /// more concentrated than the lights that BSDF sampling alone does
    /// better: under the uniform environment by a fixed rule, under an
    /// environment map where a pre-pass measures that it pays
    /// (`src/integrator/light_choice.rs`).
    #[default]
    Auto,
    /// At every non-delta bounce (as Mitsuba 3 does).
    Always,
}

impl FromStr for LightSampling {
    type Err = String;
    fn from_str(s: &str) -> std::result::Result<Self, String> {
        match s {
            "auto" => Ok(LightSampling::Auto),
            "always" => Ok(LightSampling::Always),
            _ => Err(format!(
                "unknown light sampling `{s}` (expected auto or always)"
            )),
        }
    }
}

impl fmt::Display for LightSampling {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            LightSampling::Auto => "auto",
            LightSampling::Always => "always",
        })
    }
}

/// The number of lights (emissive triangles and spheres, point and spot
/// lights) from which `auto` picks the light BVH. Measured with the 4-wide
/// tree (guide, "Many lights"): its efficiency was the higher from the
/// smallest counts tried, 8 small lights over a floor (6.9x power's) and a
/// Cornell box with 4 point lights besides its ceiling's two triangles
/// (2.5x), at 1.03x to 1.3x the time per sample. Not lower: a lamp of a
/// few triangles that all light the same points gains nothing from a tree,
/// and the Cornell box's two keep power selection's bits.
pub const LIGHT_BVH_FROM: usize = 8;

impl LightSampler {
    /// Whether a scene with `lights` lights (not at infinity) is sampled by
    /// the light BVH.
    pub fn picks_bvh(self, lights: usize) -> bool {
        match self {
            LightSampler::Auto => lights >= LIGHT_BVH_FROM,
            LightSampler::Power => false,
            LightSampler::Bvh => true,
        }
    }
}

impl FromStr for LightSampler {
    type Err = String;
    fn from_str(s: &str) -> std::result::Result<Self, String> {
        match s {
            "auto" => Ok(LightSampler::Auto),
            "power" => Ok(LightSampler::Power),
            "bvh" => Ok(LightSampler::Bvh),
            _ => Err(format!(
                "unknown light sampler `{s}` (expected auto, power or bvh)"
            )),
        }
    }
}

impl fmt::Display for LightSampler {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            LightSampler::Auto => "auto",
            LightSampler::Power => "power",
            LightSampler::Bvh => "bvh",
        })
    }
}

/// Estimator settings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct IntegratorSettings {
    /// Maximum number of bounces.
    pub max_depth: u32,
    /// Light samples per shading point (at least 1 when light sampling is used).
    pub light_samples: u32,
    /// Direct-lighting strategy.
    pub direct: DirectStrategy,
    /// Russian roulette policy.
    pub roulette: Roulette,
    /// First bounce at which roulette may end a path.
    pub rr_depth: u32,
    /// How a light is chosen.
    pub light_sampler: LightSampler,
    /// Where bounces sample lights.
    pub light_sampling: LightSampling,
}

impl Default for IntegratorSettings {
    fn default() -> Self {
        IntegratorSettings {
            max_depth: 64,
            light_samples: 1,
            direct: DirectStrategy::Mis,
            roulette: Roulette::Throughput,
            rr_depth: 3,
            light_sampler: LightSampler::Auto,
            light_sampling: LightSampling::Auto,
        }
    }
}

/// Render settings a scene file may set; command-line flags override them.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RenderDefaults {
    /// Samples per pixel.
    pub spp: u32,
    /// Maximum path length in bounces.
    pub max_depth: u32,
    /// Light samples per shading point.
    pub light_samples: u32,
    /// Random seed.
    pub seed: u64,
    /// First bounce at which Russian roulette may end a path.
    pub rr_depth: u32,
    /// Direct-lighting strategy (`--direct`).
    pub direct: DirectStrategy,
    /// Russian roulette policy (`--rr`).
    pub roulette: Roulette,
    /// Set for scenes whose own renderer counts `-l` per light (CS184's
    /// `.dae`): see [`RenderDefaults::light_samples_for`].
    pub per_light: Option<LightCount>,
}

/// The lights a per-light `-l` loops over, as the CS184 course's
/// direct-lighting estimator does: `l` samples from each non-delta light
/// (area or ambient) and one from each delta light (point, directional).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct LightCount {
    /// Lights sampled `l` times each.
    pub sampled: u32,
    /// Lights sampled once each.
    pub delta: u32,
}

impl RenderDefaults {
    /// Light samples per shading point for a `-l` value (`None`: the
    /// scene's own). Per shading point unless the scene counts per light;
    /// then `-l l` gives the course's total, `l * sampled + delta`, which
    /// this renderer spends on lights chosen by power (with one area light,
    /// exactly the course's estimator).
    pub fn light_samples_for(&self, l: Option<u32>) -> u64 {
        match (l, self.per_light) {
            (None, _) => self.light_samples as u64,
            (Some(l), None) => l.max(1) as u64,
            (Some(l), Some(c)) => (l.max(1) as u64 * c.sampled as u64 + c.delta as u64).max(1),
        }
    }
}

impl Default for RenderDefaults {
    fn default() -> Self {
        RenderDefaults {
            spp: 64,
            max_depth: 64,
            light_samples: 1,
            seed: 0,
            rr_depth: 3,
            direct: DirectStrategy::Mis,
            roulette: Roulette::Throughput,
            per_light: None,
        }
    }
}

/// Tile side in pixels when a command does not say (`render --tile-size`'s
/// default).
pub const DEFAULT_TILE_SIZE: u32 = 16;

/// How a command names its resolution flag in errors.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ResolutionFlag {
    /// Width and height, as `-r W H`.
    WidthHeight(&'static str),
    /// One side of a square image, as `parity --image SIDE`.
    Side(&'static str),
}

/// A command's flags that bear on a render; `None` where the scene decides.
#[derive(Debug, Clone, PartialEq)]
pub struct Flags {
    /// Samples per pixel (`-s`).
    pub spp: Option<u32>,
    /// Maximum bounces (`-m`).
    pub max_depth: Option<u32>,
    /// Light samples per shading point (`-l`; per light for CS184 scenes).
    pub light_samples: Option<u32>,
    /// Image size (`-r W H`).
    pub resolution: Option<[u32; 2]>,
    /// Random seed (`--seed`).
    pub seed: Option<u64>,
    /// Direct-lighting strategy (`--direct`).
    pub direct: Option<DirectStrategy>,
    /// Fixed Russian-roulette continuation probability (`--rr`).
    pub rr: Option<f32>,
    /// First bounce at which roulette may end a path (`--rr-depth`).
    pub rr_depth: Option<u32>,
    /// How lights are chosen (`--light-sampler`) [auto].
    pub light_sampler: Option<LightSampler>,
    /// Where bounces sample lights (`--light-sampling`) [auto].
    pub light_sampling: Option<LightSampling>,
    /// Render threads (`-t`; 0 = one per core).
    pub threads: usize,
    /// Tile side (`--tile-size`) [`DEFAULT_TILE_SIZE`].
    pub tile_size: Option<u32>,
    /// The name of the samples-per-pixel flag in errors (`-s`).
    pub spp_flag: &'static str,
    /// The name of the resolution flag in errors (`-r`).
    pub resolution_flag: ResolutionFlag,
}

impl Default for Flags {
    fn default() -> Self {
        Flags {
            spp: None,
            max_depth: None,
            light_samples: None,
            resolution: None,
            seed: None,
            direct: None,
            rr: None,
            rr_depth: None,
            light_sampler: None,
            light_sampling: None,
            threads: 0,
            tile_size: None,
            spp_flag: "-s",
            resolution_flag: ResolutionFlag::WidthHeight("-r"),
        }
    }
}

/// Everything a render's image depends on that a command line can set.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Settings {
    /// Estimator settings.
    pub integrator: IntegratorSettings,
    /// Samples per pixel.
    pub spp: u32,
    /// Image size.
    pub resolution: [u32; 2],
    /// Random seed.
    pub seed: u64,
    /// Render threads (0 = one per core).
    pub threads: usize,
    /// Tile side in pixels.
    pub tile_size: u32,
}

/// The settings `flags` ask for over the scene's `defaults` and
/// `resolution`, or the first one out of range.
pub fn resolve(defaults: &RenderDefaults, resolution: [u32; 2], flags: &Flags) -> Result<Settings> {
    let settings = |m: String| Error::Settings(m);
    let spp = flags.spp.unwrap_or(defaults.spp);
    check_spp(spp as u64, &flag_label(flags.spp_flag, flags.spp, "spp")).map_err(settings)?;

    let max_depth = flags.max_depth.unwrap_or(defaults.max_depth);
    check_max_depth(
        max_depth as u64,
        &flag_label("-m", flags.max_depth, "max_depth"),
    )
    .map_err(settings)?;

    // `-l 0` is refused before a per-light scene turns it into its count
    let l_label = flag_label("-l", flags.light_samples, "light_samples");
    if flags.light_samples == Some(0) {
        check_light_samples(0, &l_label).map_err(settings)?;
    }
    let light_samples = defaults.light_samples_for(flags.light_samples);
    check_light_samples(light_samples, &l_label).map_err(settings)?;

    let [w, h] = flags.resolution.unwrap_or(resolution);
    let r_label = match (flags.resolution, flags.resolution_flag) {
        (None, _) => "the scene's resolution".to_string(),
        (Some(_), ResolutionFlag::WidthHeight(f)) => format!("{f} {w} {h}"),
        (Some(_), ResolutionFlag::Side(f)) => format!("{f} {w}"),
    };
    check_resolution(w, h, &r_label).map_err(settings)?;

    if let Some(p) = flags.rr {
        if !(0.0..=1.0).contains(&p) {
            return Err(settings(format!(
                "--rr {p}: expected a probability in [0, 1]"
            )));
        }
    }
    limits::check_threads(flags.threads).map_err(settings)?;
    let tile_size = flags.tile_size.unwrap_or(DEFAULT_TILE_SIZE);
    check_tile_size(tile_size).map_err(settings)?;

    Ok(Settings {
        integrator: IntegratorSettings {
            max_depth,
            light_samples: light_samples as u32,
            direct: flags.direct.unwrap_or(defaults.direct),
            roulette: flags.rr.map_or(defaults.roulette, Roulette::Fixed),
            rr_depth: flags.rr_depth.unwrap_or(defaults.rr_depth),
            light_sampler: flags.light_sampler.unwrap_or_default(),
            light_sampling: flags.light_sampling.unwrap_or_default(),
        },
        spp,
        resolution: [w, h],
        seed: flags.seed.unwrap_or(defaults.seed),
        threads: flags.threads,
        tile_size,
    })
}

/// `-s 4` for a flag that was given, `the scene's spp` for one that was not.
fn flag_label(flag: &str, value: Option<u32>, key: &str) -> String {
    match value {
        Some(v) => format!("{flag} {v}"),
        None => format!("the scene's {key}"),
    }
}

/// Samples per pixel, `what` naming where they came from (`-s 0`,
/// `spp=0`): 1 ..= [`limits::MAX_SPP`].
pub fn check_spp(spp: u64, what: &str) -> std::result::Result<(), String> {
    if spp == 0 {
        return Err(format!("{what}: expected at least one sample per pixel"));
    }
    limits::check_spp(spp).map_err(|m| format!("{what}: {m}"))
}

/// A maximum path depth: 0 ..= [`limits::MAX_DEPTH`].
pub fn check_max_depth(depth: u64, what: &str) -> std::result::Result<(), String> {
    limits::check_max_depth(depth).map_err(|m| format!("{what}: {m}"))
}

/// Light samples per shading point: 1 ..= [`limits::MAX_LIGHT_SAMPLES`].
pub fn check_light_samples(n: u64, what: &str) -> std::result::Result<(), String> {
    if n == 0 {
        return Err(format!(
            "{what}: expected at least one light sample per shading point"
        ));
    }
    limits::check_light_samples(n).map_err(|m| format!("{what}: {m}"))
}

/// An image size against [`limits::MAX_RESOLUTION`] and
/// [`limits::MAX_PIXELS`].
pub fn check_resolution(w: u32, h: u32, what: &str) -> std::result::Result<(), String> {
    limits::check_resolution(w as u64, h as u64).map_err(|m| format!("{what}: {m}"))
}

/// A tile side: 1 ..= [`MAX_RESOLUTION`] pixels (a tile larger than the
/// largest image gains nothing).
pub fn check_tile_size(side: u32) -> std::result::Result<(), String> {
    if side == 0 || side > MAX_RESOLUTION {
        return Err(format!(
            "--tile-size {side}: expected a tile side of 1..={MAX_RESOLUTION} pixels"
        ));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn flags() -> Flags {
        Flags::default()
    }

    #[test]
    fn flags_override_the_scene_and_the_rest_comes_from_it() {
        let d = RenderDefaults {
            spp: 8,
            max_depth: 5,
            seed: 7,
            ..RenderDefaults::default()
        };
        let s = resolve(&d, [32, 16], &flags()).unwrap();
        assert_eq!((s.spp, s.integrator.max_depth, s.seed), (8, 5, 7));
        assert_eq!((s.resolution, s.tile_size), ([32, 16], DEFAULT_TILE_SIZE));
        let f = Flags {
            spp: Some(2),
            max_depth: Some(0),
            light_samples: Some(3),
            resolution: Some([4, 4]),
            rr: Some(0.5),
            ..flags()
        };
        let s = resolve(&d, [32, 16], &f).unwrap();
        assert_eq!((s.spp, s.integrator.max_depth), (2, 0));
        assert_eq!((s.integrator.light_samples, s.resolution), (3, [4, 4]));
        assert_eq!(s.integrator.roulette, Roulette::Fixed(0.5));
    }

    #[test]
    fn zero_and_out_of_range_values_are_refused_by_name() {
        let d = RenderDefaults::default();
        let err = |f: Flags| resolve(&d, [8, 8], &f).unwrap_err().to_string();
        assert!(
            err(Flags {
                spp: Some(0),
                ..flags()
            })
            .starts_with("-s 0: ")
        );
        assert!(
            err(Flags {
                light_samples: Some(0),
                ..flags()
            })
            .starts_with("-l 0: ")
        );
        assert!(
            err(Flags {
                max_depth: Some(1025),
                ..flags()
            })
            .contains("0..=1024")
        );
        assert!(
            err(Flags {
                tile_size: Some(0),
                ..flags()
            })
            .starts_with("--tile-size 0")
        );
        assert!(
            err(Flags {
                threads: 100_000,
                ..flags()
            })
            .contains("at most 1024")
        );
        let big = Flags {
            resolution: Some([32768, 16385]),
            ..flags()
        };
        assert!(err(big).starts_with("-r 32768 16385: "));
        let side = Flags {
            resolution: Some([40000, 40000]),
            resolution_flag: ResolutionFlag::Side("--image"),
            ..flags()
        };
        assert!(err(side).starts_with("--image 40000: "));
        // a per-light scene: `-l 0` does not become its delta lights' count
        let per_light = RenderDefaults {
            per_light: Some(LightCount {
                sampled: 1,
                delta: 2,
            }),
            ..RenderDefaults::default()
        };
        let f = Flags {
            light_samples: Some(0),
            ..flags()
        };
        assert!(resolve(&per_light, [8, 8], &f).is_err());
    }
}
