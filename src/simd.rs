//! The vector instruction set the estimator's batch kernels and the BVH's
//! traversal run with, chosen at run time (issue 37): one binary uses
//! AVX-512 where the CPU has it, AVX2 where it has that, and the x86-64
//! baseline (SSE2) elsewhere.
//!
//! That code is compiled once per level through the `pulp` crate: its
//! `Simd::vectorize` runs an operation inside a function compiled with the
//! level's target features, and the code inlined there is compiled for that
//! level (the BVH's 8-wide node test gains from it, and so do the kernel
//! steps written across the batch's lanes, `integrator/path/kernel_bsdf.rs`:
//! the cosine warp of diffuse bounces and the rough GGX conductors'
//! samples; the rest of the kernels' shading is still one lane at a time).
//! `pulp` is safe to call (it checks the CPU before it hands out a level),
//! maintained, and covers the three x86-64 levels a render farm meets; it
//! is why this crate needs no `unsafe` for its vector code.
//!
//! **The same image on every level.** Every level computes the same IEEE
//! operations in the same order: Rust never fuses a multiply and an add
//! unless the code asks (`mul_add`, which is exact either way), vector and
//! scalar `+ - * / sqrt` round alike, and the transcendental functions are
//! the same code on every level. So a render's pixels do not depend on the
//! level (`tests/simd_levels.rs` forces each level the machine has and
//! compares bits).

use std::fmt;
use std::str::FromStr;
use std::sync::atomic::{AtomicU8, Ordering};

/// The level [`active`] returns: 0 until chosen, else `1 + Level as u8`.
static ACTIVE: AtomicU8 = AtomicU8::new(0);

/// The level the kernels run with: the one [`set_active`] chose, else the
/// environment's `EMBERTRACE_SIMD` (read once; one of `--simd`'s values),
/// else the widest this CPU runs. An `EMBERTRACE_SIMD` that does not parse
/// or names a level the CPU lacks is reported once on stderr and ignored.
pub fn active() -> Level {
    match ACTIVE.load(Ordering::Relaxed) {
        0 => {
            let level = match std::env::var("EMBERTRACE_SIMD") {
                Err(_) => Level::detected(),
                Ok(v) => match v.parse::<Choice>().and_then(Choice::resolve) {
                    Ok(l) => l,
                    Err(e) => {
                        crate::log::warn(&format!("EMBERTRACE_SIMD ignored: {e}"));
                        Level::detected()
                    }
                },
            };
            // the first caller's answer stands (another thread may have
            // chosen meanwhile)
            match ACTIVE.compare_exchange(0, 1 + level as u8, Ordering::Relaxed, Ordering::Relaxed)
            {
                Ok(_) => level,
                Err(_) => active(),
            }
        }
        v => Level::ALL[v as usize - 1],
    }
}

/// Make `level` the one the kernels run with from now on (`--simd`).
pub fn set_active(level: Level) {
    ACTIVE.store(1 + level as u8, Ordering::Relaxed);
}

/// A vector instruction-set level.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Level {
    /// The x86-64 baseline (SSE2), or no vector unit on other targets.
    Scalar,
    /// x86-64-v3: AVX2, FMA, BMI2 (8 lanes of `f32`).
    Avx2,
    /// x86-64-v4: AVX-512 F/BW/CD/DQ/VL (16 lanes of `f32`).
    Avx512,
}

impl Level {
    /// Every level, narrowest first.
    pub const ALL: [Level; 3] = [Level::Scalar, Level::Avx2, Level::Avx512];

    /// The widest level this CPU runs.
    pub fn detected() -> Level {
        #[cfg(target_arch = "x86_64")]
        {
            if pulp::x86::V4::try_new().is_some() {
                return Level::Avx512;
            }
            if pulp::x86::V3::try_new().is_some() {
                return Level::Avx2;
            }
        }
        Level::Scalar
    }

    /// Whether this CPU runs the level.
    pub fn is_supported(self) -> bool {
        self <= Level::detected()
    }

    /// The levels this CPU runs, narrowest first.
    pub fn supported() -> Vec<Level> {
        Level::ALL
            .into_iter()
            .filter(|l| l.is_supported())
            .collect()
    }

    /// The name `--simd` takes and the report prints.
    pub fn name(self) -> &'static str {
        match self {
            Level::Scalar => "scalar",
            Level::Avx2 => "avx2",
            Level::Avx512 => "avx512",
        }
    }

    /// The dispatcher for this level (or the widest supported one below
    /// it: a level the CPU lacks is never run).
    pub fn dispatcher(self) -> Dispatch {
        let arch = 'found: {
            #[cfg(target_arch = "x86_64")]
            {
                if self >= Level::Avx512
                    && let Some(simd) = pulp::x86::V4::try_new()
                {
                    break 'found pulp::Arch::V4(simd);
                }
                if self >= Level::Avx2
                    && let Some(simd) = pulp::x86::V3::try_new()
                {
                    break 'found pulp::Arch::V3(simd);
                }
            }
            pulp::Arch::Scalar
        };
        Dispatch { level: self, arch }
    }
}

/// A level checked against the CPU once, ready to run code with it: what
/// the kernels and the BVH keep, so that a call costs one branch, not a
/// CPU-feature query.
#[derive(Debug, Clone, Copy)]
pub struct Dispatch {
    level: Level,
    arch: pulp::Arch,
}

impl Dispatch {
    /// The level asked for.
    pub fn level(&self) -> Level {
        self.level
    }

    /// `op` run with the level's instruction set: its code, inlined into
    /// a function compiled for that set, is compiled (and vectorised) for it.
    #[inline(always)]
    pub fn run<Op: pulp::WithSimd>(&self, op: Op) -> Op::Output {
        self.arch.dispatch(op)
    }
}

impl Default for Dispatch {
    /// The [`active`] level's.
    fn default() -> Self {
        active().dispatcher()
    }
}

impl fmt::Display for Level {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// What `--simd` takes: a level, or `auto` for the widest the CPU has.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Choice {
    /// The widest level the CPU runs.
    #[default]
    Auto,
    /// This level; refused where the CPU lacks it.
    Level(Level),
}

impl Choice {
    /// The level to run, or why it cannot run here.
    pub fn resolve(self) -> Result<Level, String> {
        match self {
            Choice::Auto => Ok(Level::detected()),
            Choice::Level(l) if l.is_supported() => Ok(l),
            Choice::Level(l) => Err(format!(
                "--simd {l}: this CPU does not run it (it runs {})",
                Level::supported()
                    .iter()
                    .map(|l| l.name())
                    .collect::<Vec<_>>()
                    .join(", ")
            )),
        }
    }
}

impl FromStr for Choice {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "auto" => Ok(Choice::Auto),
            "scalar" => Ok(Choice::Level(Level::Scalar)),
            "avx2" => Ok(Choice::Level(Level::Avx2)),
            "avx512" => Ok(Choice::Level(Level::Avx512)),
            other => Err(format!(
                "unknown SIMD level `{}` (expected auto, scalar, avx2 or avx512)",
                crate::error::one_line(other)
            )),
        }
    }
}

impl fmt::Display for Choice {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Choice::Auto => f.write_str("auto"),
            Choice::Level(l) => l.fmt(f),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn levels_parse_print_and_resolve() {
        for l in Level::ALL {
            assert_eq!(l.name().parse::<Choice>(), Ok(Choice::Level(l)));
            assert_eq!(Choice::Level(l).to_string(), l.name());
            assert_eq!(Choice::Level(l).resolve().is_ok(), l.is_supported());
        }
        assert_eq!(Choice::Auto.resolve(), Ok(Level::detected()));
        assert!("sse9".parse::<Choice>().unwrap_err().contains("sse9"));
        assert!(Level::Scalar.is_supported());
        assert_eq!(Level::supported().last(), Some(&Level::detected()));
    }

    /// Each supported level runs the operation with its own vector width
    /// (`f32` lanes: 1 for the baseline pulp calls scalar, 8, 16).
    #[test]
    fn dispatch_runs_the_level_asked_for() {
        struct Width;
        impl pulp::WithSimd for Width {
            type Output = usize;
            fn with_simd<S: pulp::Simd>(self, _: S) -> usize {
                S::F32_LANES
            }
        }
        for l in Level::supported() {
            let want = match l {
                Level::Scalar => 1,
                Level::Avx2 => 8,
                Level::Avx512 => 16,
            };
            assert_eq!(l.dispatcher().run(Width), want, "{l}");
        }
    }
}
