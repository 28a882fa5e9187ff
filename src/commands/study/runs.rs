//! `embertrace study SCENE --out DIR`: render one scene under a set of
//! settings and show what each costs and buys.
//!
//! Each `--vary NAME=V1,V2,...` gives values for one setting; with several,
//! every combination is rendered (at most [`MAX_SETTINGS`]). Every setting is
//! rendered progressively (1, 2, 4, ... samples per pixel up to its spp,
//! [`crate::progressive`]), and after each pass the image is compared with a
//! reference ([`crate::commands::diff`]): that gives its error-against-time curve.
//! Settings render one after another, each on all threads, so their times
//! compare.
//!
//! The reference is a given image, or (`auto`) a render of the base
//! settings at [`reference spp`](StudyOptions::reference_spp) with another
//! seed, cached in `DIR/reference.exr` together with a key of everything it
//! depends on. Its own noise is part of every measured error: an error
//! curve flattens where it meets the reference's noise.
//!
//! Outputs in `DIR`: `study.csv`, `error-vs-time.png`, `contact-sheet.png`,
//! `study.md`, and each setting's final image in `renders/`.

use super::denoised::{DenoisedPass, block_error, denoise_pass, mean_error};
use super::plot::{Series, contact_sheet, log_log_plot};
use crate::accel::{self, AccelOptions, Accelerator, Backend};
use crate::commands::diff::{Image, compare};
use crate::error::{Error, Result};
use crate::film::Film;
use crate::image::{self, OutputOptions, write_file_atomically};
use crate::integrator::PathTracer;
use crate::progressive::{Budget, render_progressive};
use crate::render::RenderSettings;
use crate::sampler::{SampleSpace, SamplerKind};
use crate::scene::Scene;
use crate::settings;
use crate::settings::{DirectStrategy, IntegratorSettings, Roulette};
use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// Added to the base seed for an `auto` reference, so that its noise is
/// independent of the renders it judges.
pub const REFERENCE_SEED_OFFSET: u64 = 1_000_003;

/// Most settings one study renders.
pub const MAX_SETTINGS: usize = 64;

/// The settings a study can vary, as `--vary` names them.
pub const VARY_NAMES: &[&str] = &[
    "spp",
    "max_depth",
    "light_samples",
    "direct",
    "rr",
    "rr_depth",
    "backend",
    "sampler",
    "light_sampler",
];

/// Everything one render of a study depends on.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RunSettings {
    /// Estimator settings.
    pub integrator: IntegratorSettings,
    /// Samples per pixel.
    pub spp: u32,
    /// Seed.
    pub seed: u64,
    /// Backend.
    pub backend: Backend,
    /// Sample generator.
    pub sampler: SamplerKind,
    /// Image size.
    pub resolution: [u32; 2],
    /// Threads (0 = all).
    pub threads: usize,
}

impl RunSettings {
    /// Set `name` to `value` (one of [`VARY_NAMES`]).
    pub fn set(&mut self, name: &str, value: &str) -> std::result::Result<(), String> {
        let number = |v: &str| {
            v.parse::<u32>()
                .map_err(|_| format!("{name}={v}: expected a whole number"))
        };
        // the checks every command makes of -s, -m and -l
        let label = format!("{name}={value}");
        match name {
            "spp" => {
                let n = number(value)?;
                settings::check_spp(n as u64, &label)?;
                self.spp = n;
            }
            "max_depth" => {
                let n = number(value)?;
                settings::check_max_depth(n as u64, &label)?;
                self.integrator.max_depth = n;
            }
            "light_samples" => {
                let n = number(value)?;
                settings::check_light_samples(n as u64, &label)?;
                self.integrator.light_samples = n;
            }
            "rr_depth" => self.integrator.rr_depth = number(value)?,
            "direct" => self.integrator.direct = value.parse::<DirectStrategy>()?,
            "rr" => {
                self.integrator.roulette = match value {
                    "throughput" => Roulette::Throughput,
                    "off" => Roulette::Fixed(1.0),
                    p => match p.parse::<f32>() {
                        Ok(q) if (0.0..=1.0).contains(&q) => Roulette::Fixed(q),
                        _ => {
                            return Err(format!(
                                "rr={p}: expected throughput, off or a probability in [0, 1]"
                            ));
                        }
                    },
                }
            }
            "backend" => self.backend = value.parse()?,
            "sampler" => self.sampler = value.parse()?,
            "light_sampler" => self.integrator.light_sampler = value.parse()?,
            _ => {
                return Err(format!(
                    "cannot vary `{name}` (expected one of {})",
                    VARY_NAMES.join(", ")
                ));
            }
        }
        Ok(())
    }

    /// A key for everything that decides the reference image.
    fn reference_key(&self, scene: &Path, spp: u32) -> String {
        format!(
            "{} {:?} spp {spp} seed {} {:?} {}x{}",
            scene.display(),
            self.integrator,
            self.seed,
            self.sampler,
            self.resolution[0],
            self.resolution[1]
        )
    }
}

/// Where the reference comes from.
#[derive(Debug, Clone, PartialEq)]
pub enum ReferenceChoice {
    /// A given image.
    File(PathBuf),
    /// Render (or reuse) `DIR/reference.exr`.
    Auto,
}

/// A study's settings.
#[derive(Debug, Clone)]
pub struct StudyOptions {
    /// Output folder (created if missing).
    pub out: PathBuf,
    /// `(name, values)` per `--vary`, in order.
    pub vary: Vec<(String, Vec<String>)>,
    /// The reference.
    pub reference: ReferenceChoice,
    /// Samples per pixel of an `auto` reference.
    pub reference_spp: u32,
    /// Settings every render starts from.
    pub base: RunSettings,
    /// How backends are built.
    pub build: AccelOptions,
    /// Also denoise every pass (`--denoise`, [`super::denoised`]).
    pub denoise: bool,
}

/// Parse `NAME=V1,V2,...`.
pub fn parse_vary(s: &str) -> std::result::Result<(String, Vec<String>), String> {
    let (name, values) = s
        .split_once('=')
        .ok_or_else(|| format!("--vary {s}: expected NAME=V1,V2,..."))?;
    let name = name.trim().replace('-', "_");
    if !VARY_NAMES.contains(&name.as_str()) {
        return Err(format!(
            "--vary {s}: cannot vary `{name}` (expected one of {})",
            VARY_NAMES.join(", ")
        ));
    }
    let values: Vec<String> = values.split(',').map(|v| v.trim().to_string()).collect();
    if values.iter().any(String::is_empty) {
        return Err(format!("--vary {s}: empty value"));
    }
    Ok((name, values))
}

/// One rendered setting.
#[derive(Debug, Clone)]
pub struct StudyRow {
    /// `name=value` of each varied setting.
    pub label: String,
    /// The settings.
    pub settings: RunSettings,
    /// Seconds of rendering.
    pub seconds: f64,
    /// Samples per pixel.
    pub spp: u32,
    /// Rays traced.
    pub rays: u64,
    /// RMSE against the reference.
    pub rmse: f64,
    /// Relative MSE against the reference.
    pub rel_mse: f64,
    /// `1 / (rel_mse * seconds)`.
    pub efficiency: f64,
    /// `(seconds, rel_mse)` after each pass.
    pub curve: Vec<(f64, f64)>,
    /// Whether no other setting has both less time and less error.
    pub pareto: bool,
    /// [`super::denoised::mean_error`] of the final image.
    pub mean_error: f64,
    /// [`super::denoised::block_error`] of the final image.
    pub block_error: f64,
    /// The same figures for the denoised image (`--denoise`).
    pub denoised: Option<DenoisedRow>,
}

/// A setting's figures once denoised.
#[derive(Debug, Clone, PartialEq)]
pub struct DenoisedRow {
    /// Seconds of rendering, auxiliary images and denoising.
    pub seconds: f64,
    /// RMSE against the reference.
    pub rmse: f64,
    /// Relative MSE against the reference.
    pub rel_mse: f64,
    /// `1 / (rel_mse * seconds)`.
    pub efficiency: f64,
    /// [`super::denoised::mean_error`].
    pub mean_error: f64,
    /// [`super::denoised::block_error`].
    pub block_error: f64,
    /// `(seconds, rel_mse)` after each pass, denoised.
    pub curve: Vec<(f64, f64)>,
}

/// Every combination of the varied values applied to `base`, labelled.
pub fn combinations(
    base: &RunSettings,
    vary: &[(String, Vec<String>)],
) -> Result<Vec<(String, RunSettings)>> {
    let mut out = vec![(String::new(), *base)];
    let mut seen = Vec::new();
    for (name, values) in vary {
        if seen.contains(name) {
            return Err(Error::Settings(format!("--vary {name} given twice")));
        }
        seen.push(name.clone());
        let mut next = Vec::new();
        for (label, s) in &out {
            for v in values {
                let mut t = *s;
                t.set(name, v)
                    .map_err(|e| Error::Settings(format!("--vary: {e}")))?;
                let sep = if label.is_empty() { "" } else { " " };
                next.push((format!("{label}{sep}{name}={v}"), t));
            }
        }
        if next.len() > MAX_SETTINGS {
            return Err(Error::Settings(format!(
                "--vary: {} combinations, at most {MAX_SETTINGS}",
                next.len()
            )));
        }
        out = next;
    }
    if out.len() == 1 && out[0].0.is_empty() {
        out[0].0 = "base".into();
    }
    Ok(out)
}

/// Mark the settings on the Pareto front of (seconds, rel_mse).
pub fn mark_pareto(rows: &mut [StudyRow]) {
    let points: Vec<(f64, f64)> = rows.iter().map(|r| (r.seconds, r.rel_mse)).collect();
    for (i, r) in rows.iter_mut().enumerate() {
        let (t, e) = points[i];
        r.pareto = !points
            .iter()
            .enumerate()
            .any(|(j, &(tj, ej))| j != i && tj <= t && ej <= e && (tj < t || ej < e));
    }
}

/// What the study's renderer calls after each pass: the render's seconds
/// so far, its film, and with `--denoise` the pass denoised.
type OnPass<'a> = dyn FnMut(f64, &Film, Option<DenoisedPass>) -> Result<()> + 'a;

struct Renderer<'s> {
    scene: &'s Scene,
    build: AccelOptions,
    accels: BTreeMap<String, Box<dyn Accelerator>>,
}

impl Renderer<'_> {
    fn accel(&mut self, b: Backend) -> Result<&dyn Accelerator> {
        if !self.accels.contains_key(b.name()) {
            let a = accel::build(b, self.scene.soup(), self.build)?;
            self.accels.insert(b.name().into(), a);
        }
        Ok(self.accels[b.name()].as_ref())
    }

    /// Render `s` progressively; `on_pass` sees each pass's time and film,
    /// and with `denoise` the pass denoised.
    fn render(
        &mut self,
        s: &RunSettings,
        denoise: bool,
        on_pass: &mut OnPass<'_>,
    ) -> Result<(Film, f64, u64)> {
        let scene = self.scene;
        let accel = self.accel(s.backend)?;
        let tracer = PathTracer::new(scene, accel, s.integrator);
        let camera = scene.make_camera(s.resolution[0], s.resolution[1]);
        let space = SampleSpace::new(s.sampler, s.seed, s.resolution, s.spp);
        let rs = RenderSettings {
            total_spp: None,
            resolution: s.resolution,
            spp: s.spp,
            first_sample: 0,
            seed: s.seed,
            threads: s.threads,
            tile_size: 16,
            sampler: s.sampler,
            clamp: None,
        };
        let budget = Budget {
            max_spp: s.spp,
            ..Budget::default()
        };
        // the render's clock runs through the callbacks: what denoising
        // took is taken back off, so the times are the render's alone
        let mut denoising = 0.0;
        let out = render_progressive(&tracer, &camera, &rs, &budget, None, &mut |p, f| {
            let rendering = p.seconds - denoising;
            let denoised = denoise
                .then(|| denoise_pass(&tracer, &camera, &space, s.seed, f))
                .transpose()?;
            denoising += denoised.as_ref().map_or(0.0, |d| d.seconds);
            on_pass(rendering, f, denoised)
        })?;
        Ok((
            out.out.film,
            out.out.seconds - denoising,
            out.out.rays.total(),
        ))
    }
}

fn image_of(film: &Film) -> Image {
    Image {
        width: film.width(),
        height: film.height(),
        rgb: film.to_rgb_f32(),
    }
}

/// The 8-bit sRGB thumbnail of `film` (box-filtered down by an integer
/// factor to at most `max_side` pixels a side) and its size.
fn thumbnail(film: &Film, max_side: u32) -> (Vec<u8>, u32, u32) {
    let (w, h) = (film.width(), film.height());
    let k = w.max(h).div_ceil(max_side).max(1);
    let (tw, th) = (w / k, h / k);
    let mut out = Vec::with_capacity((tw * th * 3) as usize);
    for y in 0..th {
        for x in 0..tw {
            let mut sum = [0.0f64; 3];
            for j in 0..k {
                for i in 0..k {
                    let m = film.pixel(x * k + i, y * k + j).mean_f64();
                    (0..3).for_each(|c| sum[c] += m[c]);
                }
            }
            out.extend(sum.map(|v| image::srgb8(v / (k * k) as f64)));
        }
    }
    (out, tw, th)
}

/// Run the study; returns its rows (also written to `DIR`).
pub fn run(
    scene_path: &Path,
    scene: &Scene,
    opts: &StudyOptions,
    say: &dyn Fn(&str),
) -> Result<Vec<StudyRow>> {
    let settings = combinations(&opts.base, &opts.vary)?;
    std::fs::create_dir_all(opts.out.join("renders")).map_err(|e| Error::io(&opts.out, e))?;
    let mut renderer = Renderer {
        scene,
        build: opts.build,
        accels: BTreeMap::new(),
    };
    let (reference, ref_path) = match &opts.reference {
        ReferenceChoice::File(p) => (Image::read(p)?, p.clone()),
        ReferenceChoice::Auto => {
            let path = opts.out.join("reference.exr");
            let mut base = opts.base;
            base.seed = opts.base.seed.wrapping_add(REFERENCE_SEED_OFFSET);
            base.spp = opts.reference_spp;
            base.sampler = SamplerKind::Independent;
            let key = base.reference_key(scene_path, base.spp);
            let cached = path.exists()
                && image::read_exr_metadata(&path).ok().is_some_and(|m| {
                    m.iter()
                        .any(|(k, v)| k == "embertrace.study_key" && *v == key)
                });
            if cached {
                say(&format!("reusing the reference {}", path.display()));
            } else {
                say(&format!(
                    "rendering the reference: {} spp, seed {}",
                    base.spp, base.seed
                ));
                let (film, secs, _) = renderer.render(&base, false, &mut |_, _, _| Ok(()))?;
                let meta = vec![
                    ("embertrace.study_key".to_string(), key),
                    ("embertrace.spp".to_string(), base.spp.to_string()),
                    (
                        "embertrace.render_seconds".to_string(),
                        format!("{secs:.3}"),
                    ),
                ];
                image::write_image(
                    &path,
                    &film,
                    &OutputOptions {
                        exposure: 0.0,
                        metadata: meta,
                    },
                )?;
            }
            (Image::read(&path)?, path)
        }
    };
    if (reference.width, reference.height) != (opts.base.resolution[0], opts.base.resolution[1]) {
        return Err(Error::input(
            &ref_path,
            None,
            format!(
                "is {}x{} but the study renders {}x{}",
                reference.width, reference.height, opts.base.resolution[0], opts.base.resolution[1]
            ),
        ));
    }
    let mut rows = Vec::new();
    let mut thumbs = Vec::new();
    for (k, (label, s)) in settings.iter().enumerate() {
        say(&format!("[{}/{}] {label}", k + 1, settings.len()));
        let mut curve = Vec::new();
        let mut denoised_curve = Vec::new();
        let mut last_denoised = None;
        let (film, seconds, rays) = renderer.render(s, opts.denoise, &mut |t, f, dn| {
            let d = compare(&image_of(f), &reference, scene_path, &ref_path)?;
            curve.push((t, d.rel_mse));
            if let Some(dn) = dn {
                let dd = compare(&dn.image, &reference, scene_path, &ref_path)?;
                denoised_curve.push((t + dn.seconds, dd.rel_mse));
                last_denoised = Some((dn, dd, t));
            }
            Ok(())
        })?;
        let image = image_of(&film);
        let d = compare(&image, &reference, scene_path, &ref_path)?;
        let denoised = last_denoised.map(|(dn, dd, t)| {
            let secs = t + dn.seconds;
            DenoisedRow {
                seconds: secs,
                rmse: dd.rmse,
                rel_mse: dd.rel_mse,
                efficiency: 1.0 / (dd.rel_mse * secs),
                mean_error: mean_error(&dn.image, &reference),
                block_error: block_error(&dn.image, &reference),
                curve: denoised_curve,
            }
        });
        let name = format!("{:02}.exr", k + 1);
        image::write_image(
            &opts.out.join("renders").join(&name),
            &film,
            &OutputOptions {
                exposure: 0.0,
                metadata: vec![("embertrace.study_setting".into(), label.clone())],
            },
        )?;
        let (img, tw, th) = thumbnail(&film, 192);
        thumbs.push((
            img,
            tw,
            th,
            label.clone(),
            format!("{seconds:.2} s, relMSE {:.2e}", d.rel_mse),
        ));
        rows.push(StudyRow {
            label: label.clone(),
            settings: *s,
            seconds,
            spp: s.spp,
            rays,
            rmse: d.rmse,
            rel_mse: d.rel_mse,
            efficiency: 1.0 / (d.rel_mse * seconds),
            curve,
            pareto: false,
            mean_error: mean_error(&image, &reference),
            block_error: block_error(&image, &reference),
            denoised,
        });
    }
    mark_pareto(&mut rows);
    write_outputs(scene_path, opts, &rows, &thumbs, &ref_path)?;
    Ok(rows)
}

type Thumb = (Vec<u8>, u32, u32, String, String);

fn write_outputs(
    scene_path: &Path,
    opts: &StudyOptions,
    rows: &[StudyRow],
    thumbs: &[Thumb],
    ref_path: &Path,
) -> Result<()> {
    let dir = &opts.out;
    let mut csv = String::from(
        "setting,seconds,spp,rays,rmse,rel_mse,efficiency,pareto,mean_error,block_error",
    );
    if opts.denoise {
        csv += ",denoised_seconds,denoised_rmse,denoised_rel_mse,denoised_efficiency,\
                denoised_mean_error,denoised_block_error";
    }
    csv.push('\n');
    for r in rows {
        let _ = write!(
            csv,
            "\"{}\",{:.6e},{},{},{:.6e},{:.6e},{:.6e},{},{:.6e},{:.6e}",
            r.label,
            r.seconds,
            r.spp,
            r.rays,
            r.rmse,
            r.rel_mse,
            r.efficiency,
            r.pareto,
            r.mean_error,
            r.block_error
        );
        if let Some(d) = &r.denoised {
            let _ = write!(
                csv,
                ",{:.6e},{:.6e},{:.6e},{:.6e},{:.6e},{:.6e}",
                d.seconds, d.rmse, d.rel_mse, d.efficiency, d.mean_error, d.block_error
            );
        }
        csv.push('\n');
    }
    write_file_atomically(&dir.join("study.csv"), csv.as_bytes())?;

    let mut series: Vec<Series> = rows
        .iter()
        .map(|r| Series {
            label: r.label.clone(),
            points: r.curve.clone(),
        })
        .collect();
    series.extend(rows.iter().filter_map(|r| {
        r.denoised.as_ref().map(|d| Series {
            label: format!("{} denoised", r.label).trim().to_string(),
            points: d.curve.clone(),
        })
    }));
    let title = format!(
        "{}: relative MSE against time",
        scene_path.file_stem().unwrap_or_default().to_string_lossy()
    );
    log_log_plot(
        &series,
        &title,
        "render time (seconds)",
        "relative MSE",
        900,
        560,
    )
    .save(&dir.join("error-vs-time.png"))?;

    let (tw, th) = thumbs.first().map_or((1, 1), |t| (t.1, t.2));
    let cells: Vec<(Vec<u8>, [String; 2])> = thumbs
        .iter()
        .map(|t| (t.0.clone(), [t.3.clone(), t.4.clone()]))
        .collect();
    let columns = match opts.vary.as_slice() {
        [] => 1,
        [one] => one.1.len() as u32,
        [.., last] => last.1.len() as u32,
    }
    .min(6);
    contact_sheet(&cells, tw, th, columns).save(&dir.join("contact-sheet.png"))?;

    let mut md = format!(
        "# Study of `{}`\n\nBase settings: {} spp, max depth {}, {} light sample(s), direct `{}`, \
         roulette {:?} from depth {}, backend `{}`, sampler `{}`, {}x{}, seed {}.\n\n\
         Reference: `{}`{}. Error is measured against it after every pass \
         (1, 2, 4, ... spp); its own noise is part of every figure.\n\n",
        scene_path.display(),
        opts.base.spp,
        opts.base.integrator.max_depth,
        opts.base.integrator.light_samples,
        opts.base.integrator.direct,
        opts.base.integrator.roulette,
        opts.base.integrator.rr_depth,
        opts.base.backend,
        opts.base.sampler,
        opts.base.resolution[0],
        opts.base.resolution[1],
        opts.base.seed,
        ref_path.display(),
        match opts.reference {
            ReferenceChoice::Auto => format!(
                " (rendered by the study: {} spp, independent sampler, seed {})",
                opts.reference_spp,
                opts.base.seed.wrapping_add(REFERENCE_SEED_OFFSET)
            ),
            ReferenceChoice::File(_) => String::new(),
        }
    );
    md += "| setting | seconds | spp | rays | RMSE | relative MSE | efficiency | Pareto |\n";
    md += "|---|---:|---:|---:|---:|---:|---:|:-:|\n";
    for r in rows {
        let _ = writeln!(
            md,
            "| {} | {:.3} | {} | {} | {:.3e} | {:.3e} | {:.3e} | {} |",
            r.label,
            r.seconds,
            r.spp,
            r.rays,
            r.rmse,
            r.rel_mse,
            r.efficiency,
            if r.pareto { "yes" } else { "" }
        );
    }
    md += "\nEfficiency is `1 / (relative MSE x seconds)`: higher is better.\n\n";
    md += "Bias: the mean error is the image's mean over the reference's, less 1; the \
           block error is the RMS difference of 8 x 8 block means relative to the \
           reference's RMS (noise averages out of it, bias does not).\n\n";
    md += "| setting | mean error | block error |";
    if opts.denoise {
        md += " denoised: seconds | RMSE | relative MSE | efficiency | mean error | block error |";
    }
    md += "\n|---|---:|---:|";
    if opts.denoise {
        md += "---:|---:|---:|---:|---:|---:|";
    }
    md.push('\n');
    for r in rows {
        let _ = write!(
            md,
            "| {} | {:+.3e} | {:.3e} |",
            r.label, r.mean_error, r.block_error
        );
        if let Some(d) = &r.denoised {
            let _ = write!(
                md,
                " {:.3} | {:.3e} | {:.3e} | {:.3e} | {:+.3e} | {:.3e} |",
                d.seconds, d.rmse, d.rel_mse, d.efficiency, d.mean_error, d.block_error
            );
        }
        md.push('\n');
    }
    md.push('\n');
    md += "![error against time](error-vs-time.png)\n\n![contact sheet](contact-sheet.png)\n\n";
    md += "## Pareto front\n\nNo other setting has both less time and less error:\n\n";
    let mut front: Vec<&StudyRow> = rows.iter().filter(|r| r.pareto).collect();
    front.sort_by(|a, b| a.seconds.total_cmp(&b.seconds));
    for r in front {
        let _ = writeln!(
            md,
            "- {}: {:.3} s, relative MSE {:.3e}",
            r.label, r.seconds, r.rel_mse
        );
    }
    write_file_atomically(&dir.join("study.md"), md.as_bytes())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn base() -> RunSettings {
        RunSettings {
            integrator: IntegratorSettings::default(),
            spp: 4,
            seed: 0,
            backend: Backend::Naive,
            sampler: SamplerKind::Independent,
            resolution: [8, 8],
            threads: 1,
        }
    }

    #[test]
    fn vary_parses_and_combines() {
        let v = vec![
            parse_vary("max-depth=0,1,2").unwrap(),
            parse_vary("sampler=independent,sobol").unwrap(),
        ];
        let c = combinations(&base(), &v).unwrap();
        assert_eq!(c.len(), 6);
        assert_eq!(c[0].0, "max_depth=0 sampler=independent");
        assert_eq!(c[5].1.integrator.max_depth, 2);
        assert_eq!(c[5].1.sampler, SamplerKind::Sobol);
        for bad in [
            "depth=1",
            "spp",
            "spp=1,,2",
            "rr=2",
            "direct=foo",
            "spp=0",
            "light_samples=0",
            "max_depth=1025",
            "spp=16777217",
        ] {
            let r = parse_vary(bad).and_then(|p| {
                combinations(&base(), &[p])
                    .map(|_| ())
                    .map_err(|e| e.to_string())
            });
            assert!(r.is_err(), "{bad}");
        }
        let twice = vec![parse_vary("spp=1").unwrap(), parse_vary("spp=2").unwrap()];
        assert!(combinations(&base(), &twice).is_err());
        let many: Vec<String> = (1..=9).map(|k| k.to_string()).collect();
        let big = vec![
            ("spp".to_string(), many.clone()),
            ("max_depth".to_string(), many),
        ];
        assert!(combinations(&base(), &big).is_err(), "81 > MAX_SETTINGS");
    }

    #[test]
    fn pareto_front_keeps_undominated_settings() {
        let row = |t: f64, e: f64| StudyRow {
            label: String::new(),
            settings: base(),
            seconds: t,
            spp: 1,
            rays: 0,
            rmse: 0.0,
            rel_mse: e,
            efficiency: 0.0,
            curve: Vec::new(),
            pareto: false,
            mean_error: 0.0,
            block_error: 0.0,
            denoised: None,
        };
        let mut rows = vec![
            row(1.0, 0.5),
            row(2.0, 0.1),
            row(2.0, 0.6),
            row(3.0, 0.1),
            row(0.5, 0.9),
        ];
        mark_pareto(&mut rows);
        let front: Vec<bool> = rows.iter().map(|r| r.pareto).collect();
        assert_eq!(front, [true, true, false, false, true]);
    }
}
