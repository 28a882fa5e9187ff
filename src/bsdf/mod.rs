//! BSDFs, evaluated in a local shading frame. Conventions (as pbrt-v4's
//! `BxDF`, chapter 9):
//!
//! - `wo` and `wi` both point away from the surface.
//! - The frame's +z axis is the normal turned towards `wo` for the reflective
//!   BSDFs ([`Diffuse`], [`Mirror`], [`Conductor`], [`Plastic`], [`Phong`],
//!   [`MetallicRoughness`]: they see
//!   `wo.z > 0` and return zero or `None` otherwise). A BSDF that transmits
//!   ([`Glass`], [`RoughGlass`], [`ThinGlass`], see [`Bxdf::has_transmission`]) needs to know which side is
//!   inside: its +z is the surface's outward normal and `wo.z < 0` means `wo`
//!   is inside.
//! - `eval` returns `f(wo, wi)` **without** the cosine factor; estimators
//!   multiply by `|cos theta_i|` themselves.
//! - `sample` takes two uniform numbers (BSDFs with several lobes choose with
//!   the first and rescale it), so every BSDF consumes the sample stream the
//!   same way. It returns a [`BsdfSample`] whose `pdf` equals `pdf(wo, wi)`
//!   (solid angle) and whose `f` equals `eval(wo, wi)`; it returns `None`
//!   instead of a sample with zero pdf.
//! - **Delta lobes** (perfect specular reflection and refraction) have no
//!   density: `eval` and `pdf` return 0 for them, always. `sample` returns
//!   them with [`BsdfSample::delta`] set, `f` the coefficient of the Dirac
//!   delta divided by `|cos theta_i|` and `pdf` the probability of choosing
//!   that lobe (pbrt's convention), so [`BsdfSample::weight`] is still the
//!   Monte Carlo weight. An estimator gives such a sample MIS weight 1 and
//!   never light-samples through the lobe.
//!
//! The materials:
//!
//! | type | lobes | file |
//! |---|---|---|
//! | [`Diffuse`] | Lambertian | `diffuse.rs` |
//! | [`Mirror`] | delta reflection | `mirror.rs` |
//! | [`Glass`] | delta reflection + delta refraction | `glass.rs` |
//! | [`Conductor`] | GGX or Beckmann microfacet, delta when smooth | `conductor.rs` |
//! | [`Plastic`] | GGX or delta coat over a Lambertian base | `plastic.rs` |
//! | [`Phong`] | Lambertian plus a Phong or GGX-Schlick lobe (CSE 168) | `phong.rs` |
//! | [`RoughGlass`] | GGX microfacet reflection + refraction | `rough_glass.rs` |
//! | [`ThinGlass`] | delta reflection + straight delta transmission (a sheet) | `thin_glass.rs` |
//! | [`MetallicRoughness`] | glTF 2.0: Lambertian and GGX-Schlick mixed by metalness | `metallic_roughness.rs` |
//!
//! Each implements [`Bxdf`], so an estimator can be generic over the material
//! types a scene uses; [`Bsdf`] is the closed sum of all of them.

mod conductor;
mod diffuse;
pub mod fresnel;
mod glass;
mod metallic_roughness;
pub mod microfacet;
mod mirror;
pub mod named_conductors;
mod phong;
mod plastic;
mod rough_glass;
mod thin_glass;

pub use conductor::{Conductor, ConductorLanes, LaneSamples, samples_at_normals_lanes};
pub use diffuse::Diffuse;
pub use glass::Glass;
pub use metallic_roughness::MetallicRoughness;
pub use microfacet::{Distribution, Masking, Microfacet};
pub use mirror::Mirror;
pub use phong::{Lobe, Phong};
pub use plastic::{Plastic, PlasticCoats};
pub use rough_glass::RoughGlass;
pub use thin_glass::ThinGlass;

use crate::math::{Vec2, Vec3};

/// A direction sampled from a BSDF.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BsdfSample {
    /// Sampled incident direction, local frame.
    pub wi: Vec3,
    /// `f(wo, wi)`, without the cosine; for a delta sample, the Dirac
    /// coefficient over `|cos theta_i|`.
    pub f: Vec3,
    /// Solid-angle density of `wi`, or for a delta sample the probability of
    /// its lobe; always `> 0`.
    pub pdf: f32,
    /// Whether `wi` came from a delta lobe (so `eval` and `pdf` are zero
    /// there, and MIS does not apply).
    pub delta: bool,
}

impl BsdfSample {
    /// The Monte Carlo weight `f |cos| / pdf`.
    pub fn weight(&self) -> Vec3 {
        self.f * (self.wi.z.abs() / self.pdf)
    }

    /// `Some(self)` when the pdf is positive and finite and `f` and the
    /// weight are finite. A sample whose `f` and `pdf` both underflow (a
    /// microfacet normal deep in a Beckmann tail, probability around 1e-40)
    /// has a meaningless ratio and is dropped as if rejected.
    pub(crate) fn checked(self) -> Option<Self> {
        let ok = self.pdf > 0.0
            && self.pdf.is_finite()
            && self.f.is_finite()
            && self.weight().is_finite();
        ok.then_some(self)
    }
}

/// The sample of `b` at `wi` for `wo`: `f` and `pdf` evaluated there, so
/// that they agree with [`Bxdf::eval`] and [`Bxdf::pdf`] bit for bit;
/// `None` below the horizon or where the sample is degenerate.
pub(crate) fn sample_at(b: &impl Bxdf, wo: Vec3, wi: Vec3) -> Option<BsdfSample> {
    if !(wi.z > 0.0) {
        return None;
    }
    BsdfSample {
        wi,
        f: b.eval(wo, wi),
        pdf: b.pdf(wo, wi),
        delta: false,
    }
    .checked()
}

/// Choose between two lobes with the first random number: the first with
/// probability `p`. Returns the choice and the random numbers with the
/// first rescaled to `[0, 1)` within it, so each lobe sees uniform numbers.
pub(crate) fn choose_lobe(u: Vec2, p: f32) -> (bool, Vec2) {
    // the largest f32 below 1
    const ONE_MINUS_EPSILON: f32 = 1.0 - f32::EPSILON / 2.0;
    if u.x < p {
        (true, Vec2::new((u.x / p).min(ONE_MINUS_EPSILON), u.y))
    } else {
        let x = ((u.x - p) / (1.0 - p)).min(ONE_MINUS_EPSILON);
        (false, Vec2::new(x, u.y))
    }
}

/// The interface every BSDF implements (see the module docs for the
/// conventions).
pub trait Bxdf {
    /// `f(wo, wi)` without the cosine; zero on delta lobes.
    fn eval(&self, wo: Vec3, wi: Vec3) -> Vec3;

    /// Solid-angle density with which [`Bxdf::sample`] returns `wi` given
    /// `wo`; zero on delta lobes.
    fn pdf(&self, wo: Vec3, wi: Vec3) -> f32;

    /// A direction `wi` for `wo`, from two uniform numbers in `[0, 1)`.
    fn sample(&self, wo: Vec3, u: Vec2) -> Option<BsdfSample>;

    /// Every lobe is a delta: `eval` and `pdf` are zero everywhere, so light
    /// sampling is useless and MIS does not apply.
    fn is_delta(&self) -> bool;

    /// Some lobe is a delta (a sample may come back with `delta` set).
    fn has_delta_component(&self) -> bool;

    /// The BSDF transmits, so its frame's +z must be the outward normal rather
    /// than the normal turned towards `wo`.
    fn has_transmission(&self) -> bool {
        false
    }

    /// Index of refraction inside relative to outside, for a BSDF that
    /// transmits (1 otherwise). A refracted sample changes radiance by
    /// `1 / eta'^2` (see [`Glass`]); the estimator undoes that factor before
    /// Russian roulette looks at the throughput (pbrt-v4's `etaScale`).
    fn eta(&self) -> f32 {
        1.0
    }

    /// A lower bound on how concentrated every non-delta lobe's sampling
    /// is: for every `wo` above the surface, each such lobe's solid-angle
    /// density [`Bxdf::pdf`] peaks at least this high. Where it is far above
    /// every light's density, light sampling's MIS weight is small wherever
    /// the BSDF is not, and the path tracer samples the BSDF alone
    /// ([`crate::integrator`]'s `LIGHT_SAMPLING_PEAK_RATIO`). 0, the
    /// default, claims nothing (a BSDF with a broad lobe, or one not
    /// analysed).
    fn lobe_peak_pdf(&self) -> f32 {
        0.0
    }
}

/// Any of the BSDFs, for code that does not specialise on the material.
// Plastic carries its 64-entry coat table inline (about 300 bytes). Materials
// are built once per scene and borrowed per shading point, so a Box would
// only add a pointer chase to every evaluation.
#[allow(clippy::large_enum_variant)]
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Bsdf {
    /// Lambertian.
    Diffuse(Diffuse),
    /// Perfect mirror.
    Mirror(Mirror),
    /// Smooth dielectric.
    Glass(Glass),
    /// Rough or smooth metal.
    Conductor(Conductor),
    /// Diffuse base under a dielectric coat.
    Plastic(Plastic),
    /// Diffuse plus a Phong or GGX lobe (the CSE 168 material).
    Phong(Phong),
    /// The glTF 2.0 metallic-roughness material.
    MetallicRoughness(MetallicRoughness),
    /// A thin dielectric sheet.
    ThinGlass(ThinGlass),
    /// Rough dielectric boundary.
    RoughGlass(RoughGlass),
}

macro_rules! dispatch {
    ($self:ident, $b:ident => $e:expr) => {
        match $self {
            Bsdf::Diffuse($b) => $e,
            Bsdf::Mirror($b) => $e,
            Bsdf::Glass($b) => $e,
            Bsdf::Conductor($b) => $e,
            Bsdf::Plastic($b) => $e,
            Bsdf::Phong($b) => $e,
            Bsdf::MetallicRoughness($b) => $e,
            Bsdf::ThinGlass($b) => $e,
            Bsdf::RoughGlass($b) => $e,
        }
    };
}

impl Bxdf for Bsdf {
    fn eval(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        dispatch!(self, b => Bxdf::eval(b, wo, wi))
    }

    fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        dispatch!(self, b => Bxdf::pdf(b, wo, wi))
    }

    fn sample(&self, wo: Vec3, u: Vec2) -> Option<BsdfSample> {
        dispatch!(self, b => Bxdf::sample(b, wo, u))
    }

    fn is_delta(&self) -> bool {
        dispatch!(self, b => b.is_delta())
    }

    fn has_delta_component(&self) -> bool {
        dispatch!(self, b => b.has_delta_component())
    }

    fn has_transmission(&self) -> bool {
        dispatch!(self, b => b.has_transmission())
    }

    fn eta(&self) -> f32 {
        dispatch!(self, b => b.eta())
    }

    fn lobe_peak_pdf(&self) -> f32 {
        dispatch!(self, b => b.lobe_peak_pdf())
    }
}

impl Bsdf {
    /// Checks the parameters, so that a loader can report bad input (with its
    /// file and line) instead of rendering NaN. The message names the scene
    /// key and the accepted range. ([`Plastic::new`] checks its own.)
    pub fn validate(&self) -> Result<(), String> {
        match self {
            Bsdf::Diffuse(d) => check_unit_rgb("diffuse", d.albedo),
            Bsdf::Mirror(m) => m.validate(),
            Bsdf::Glass(g) => g.validate(),
            Bsdf::Conductor(c) => c.validate(),
            Bsdf::Plastic(_) => Ok(()),
            Bsdf::Phong(p) => p.validate(),
            Bsdf::MetallicRoughness(m) => m.validate(),
            Bsdf::ThinGlass(g) => g.validate(),
            Bsdf::RoughGlass(g) => g.validate(),
        }
    }
}

/// `Ok` when every channel of `v` is finite and in `[0, 1]`.
pub(crate) fn check_unit_rgb(key: &str, v: Vec3) -> Result<(), String> {
    if v.is_finite() && v.min_element() >= 0.0 && v.max_element() <= 1.0 {
        Ok(())
    } else {
        Err(format!(
            "`{key}` must be three numbers in [0, 1], got [{}, {}, {}]",
            v.x, v.y, v.z
        ))
    }
}

/// `Ok` when the roughness is finite and `>= 0`.
pub(crate) fn check_alpha(alpha: f32) -> Result<(), String> {
    if alpha.is_finite() && alpha >= 0.0 {
        Ok(())
    } else {
        Err(format!("`alpha` must be a finite number >= 0, got {alpha}"))
    }
}

impl From<Diffuse> for Bsdf {
    fn from(b: Diffuse) -> Self {
        Bsdf::Diffuse(b)
    }
}

impl From<Mirror> for Bsdf {
    fn from(b: Mirror) -> Self {
        Bsdf::Mirror(b)
    }
}

impl From<Glass> for Bsdf {
    fn from(b: Glass) -> Self {
        Bsdf::Glass(b)
    }
}

impl From<Conductor> for Bsdf {
    fn from(b: Conductor) -> Self {
        Bsdf::Conductor(b)
    }
}

impl From<Plastic> for Bsdf {
    fn from(b: Plastic) -> Self {
        Bsdf::Plastic(b)
    }
}

impl From<MetallicRoughness> for Bsdf {
    fn from(b: MetallicRoughness) -> Self {
        Bsdf::MetallicRoughness(b)
    }
}

impl From<RoughGlass> for Bsdf {
    fn from(b: RoughGlass) -> Self {
        Bsdf::RoughGlass(b)
    }
}

impl From<ThinGlass> for Bsdf {
    fn from(b: ThinGlass) -> Self {
        Bsdf::ThinGlass(b)
    }
}

impl From<Phong> for Bsdf {
    fn from(b: Phong) -> Self {
        Bsdf::Phong(b)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn validation_names_the_key() {
        let ok: [Bsdf; 4] = [
            Diffuse { albedo: Vec3::ONE }.into(),
            Mirror::default().into(),
            Glass::default().into(),
            Conductor {
                eta: Vec3::ZERO,
                k: Vec3::ONE,
                microfacet: Microfacet::new(Distribution::Beckmann, 0.3),
            }
            .into(),
        ];
        for b in ok {
            assert_eq!(b.validate(), Ok(()), "{b:?}");
        }
        let bad: [(Bsdf, &str); 6] = [
            (
                Diffuse {
                    albedo: Vec3::splat(1.5),
                }
                .into(),
                "`diffuse`",
            ),
            (
                Mirror {
                    reflectance: Vec3::new(0.5, f32::NAN, 0.5),
                }
                .into(),
                "`reflectance`",
            ),
            (
                Glass {
                    ior: 0.0,
                    ..Glass::default()
                }
                .into(),
                "`ior`",
            ),
            (
                Glass {
                    transmittance: -Vec3::ONE,
                    ..Glass::default()
                }
                .into(),
                "`transmittance`",
            ),
            (
                Conductor {
                    eta: Vec3::ZERO,
                    k: Vec3::new(1.0, 0.0, 1.0),
                    microfacet: Microfacet::new(Distribution::Ggx, 0.1),
                }
                .into(),
                "`eta`",
            ),
            (
                Conductor {
                    eta: Vec3::ONE,
                    k: Vec3::ONE,
                    microfacet: Microfacet::new(Distribution::Ggx, f32::INFINITY),
                }
                .into(),
                "`alpha`",
            ),
        ];
        for (b, key) in bad {
            let e = b.validate().unwrap_err();
            assert!(e.contains(key), "{e}");
        }
        assert!(
            Plastic::new(Vec3::ONE, 0.9, 0.0)
                .unwrap_err()
                .contains("`ior`")
        );
        assert!(
            Plastic::new(Vec3::ONE, 1.5, -1.0)
                .unwrap_err()
                .contains("`alpha`")
        );
        assert!(
            Plastic::new(Vec3::splat(2.0), 1.5, 0.1)
                .unwrap_err()
                .contains("`diffuse`")
        );
        assert_eq!("beckmann".parse(), Ok(Distribution::Beckmann));
        assert_eq!("ggx".parse(), Ok(Distribution::Ggx));
        assert!(
            "phong"
                .parse::<Distribution>()
                .unwrap_err()
                .contains("ggx or beckmann")
        );
    }
}
