//! Path guiding: the estimator learns, during the render, where light
//! arrives from, and samples directions from a mixture of the BSDF and that
//! learned distribution, weighted by multiple importance sampling.
//!
//! The learned distribution is an SD-tree (Müller, Gross and Novák 2017,
//! "Practical Path Guiding for Efficient Light-Transport Simulation"): a
//! binary tree over space (this module) whose leaves each hold a quadtree
//! over directions ([`dtree`]). Training runs in iterations of `1, 2, 4,
//! ...` samples per pixel ([`crate::integrator::training`]); each iteration renders with the
//! previous iteration's guide, records at every non-delta bounce the
//! radiance that arrived along the sampled direction divided by the density
//! it was sampled with, and leaves the next guide. A spatial leaf that
//! received more than `c sqrt(2^k)` records in iteration `k` is halved
//! (`c = 1500`, [`SPLIT_RECORDS`]; Müller et al.'s 12000); each quadtree is
//! refined by [`dtree::BuildTree::refined`]; a record is spread over the
//! quadtree cells that a box of its cell's size overlaps (Müller 2019's
//! directional filter, [`dtree::BuildTree::add_filtered`]). Surfaces are
//! first told apart by their normal's class ([`NORMAL_CLASSES`]), a choice
//! of ours.
//!
//! Why the SD-tree rather than Open PGL's parallax-aware mixtures: it is
//! exact to reduce in a fixed order (records are summed in the order the
//! pixel blocks come, whatever the thread count, so the guide and the image
//! are functions of the scene, the settings and the seed), it needs no
//! expectation-maximisation whose result depends on the order of its
//! updates, and it is the method the done-when is stated against.
//!
//! A guided render's Russian roulette is adjoint-driven (Vorba and
//! Křivánek 2016): each leaf also learns the radiance leaving it
//! ([`Guide::leaf_radiance`]) and the guide carries the training images'
//! pixel estimates ([`PixelEstimate`]), and a path goes on with a
//! probability set by its expected contribution against its pixel's
//! ([`WEIGHT_WINDOW`], [`ROULETTE_FLOOR`]).
//!
//! The share of BSDF samples at a guided bounce is learned per leaf
//! (Müller 2019, [`fraction`]), starting from one half ([`BSDF_FRACTION`]).
//!
//! Where the bias is: none. The guide changes only which directions are
//! sampled and with what density, and which paths roulette ends; every
//! sample is weighted by the mixture's density and every survivor by its
//! probability of going on (never below [`ROULETTE_FLOOR`]), so the
//! estimator stays unbiased for any guide. The last training iterations'
//! samples are added to the render's film with the weight of a render
//! sample ([`Guide::reused`], [`crate::integrator::training::REUSED_ITERATIONS`]):
//! each is an unbiased estimate of its pixel, so the sum is too. Müller
//! 2019 weights the iterations' images by their estimated inverse
//! variance instead, which the estimated weights bias (slightly); equal
//! weights keep the estimator unbiased, and on the door scene the last two
//! iterations gave 0.929x the mean square error (more iterations, noisier
//! for their earlier guides, gave less).

mod bytes;
pub mod dtree;
pub mod fraction;
mod persist;
mod spatial;

use crate::math::Vec3;
use dtree::{BuildTree, SampleTree};
use fraction::{Fraction, FractionSample};
use rayon::prelude::*;
use spatial::{MAX_SPATIAL_DEPTH, NORMAL_CLASSES, SpatialNode, SpatialTree};
use std::fmt;
use std::str::FromStr;

/// Whether the render is guided (`--guiding`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum GuidingMode {
    /// Guided when a pre-pass finds that guiding pays
    /// ([`crate::integrator::training::prepare`]).
    #[default]
    Auto,
    /// Always guided.
    On,
    /// Never guided.
    Off,
}

impl FromStr for GuidingMode {
    type Err = String;
    fn from_str(s: &str) -> std::result::Result<Self, String> {
        match s {
            "auto" => Ok(GuidingMode::Auto),
            "on" => Ok(GuidingMode::On),
            "off" => Ok(GuidingMode::Off),
            _ => Err(format!(
                "unknown guiding mode `{s}` (expected auto, on or off)"
            )),
        }
    }
}

impl fmt::Display for GuidingMode {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            GuidingMode::Auto => "auto",
            GuidingMode::On => "on",
            GuidingMode::Off => "off",
        })
    }
}

/// The share of samples the BSDF draws at a guided bounce before a leaf has
/// learned its own ([`fraction`]); the guide draws the rest (Müller et al.
/// 2017 use one half throughout).
pub const BSDF_FRACTION: f32 = 0.5;

/// Records above which a spatial leaf splits after the first iteration
/// (Müller et al. 2017's `c`, which is 12000 there). Lower here, since the
/// learned share takes a step per 4 records ([`fraction::BATCH`]) and so
/// no longer needs a large leaf to learn in: against 12000, noise (RMSE of
/// seeds 1 and 2 over the square root of 2, `--guiding on`, 2 threads) on
/// `benches/race/hard/door-ajar.xml` 0.01937 against 0.02329 at 64 spp
/// (0.69x the variance, the same time) and 0.00788 against 0.00943 at 256
/// (0.70x, 1.10x the time); `glossy-env` 0.01272 against 0.01272 at 64
/// spp. Smaller leaves separate the light through a gap from the shadow
/// beside it. Around 1500 (64 spp): 2500 gave 0.02051 on the door, 1000
/// gave 0.01995 (and 0.01312 on `glossy-env`).
pub const SPLIT_RECORDS: f64 = 1_500.0;

/// What one spatial leaf holds while training.
#[derive(Debug, Clone, PartialEq)]
struct LeafState {
    /// The distribution this iteration samples from.
    sampling: SampleTree,
    /// This iteration's records.
    build: BuildTree,
    /// Records this iteration.
    count: u64,
    /// Sum of the records' outgoing radiance ([`Record::radiance`]), all
    /// iterations so far (a leaf's halves each keep their parent's).
    radiance_sum: f64,
    /// Records with a finite outgoing radiance, all iterations so far.
    radiance_count: u64,
    /// The learned share of BSDF samples, all iterations so far.
    fraction: Fraction,
}

impl LeafState {
    /// Add one record of this leaf.
    #[inline]
    fn add(&mut self, r: &Record) {
        self.count += 1;
        if r.radiance >= 0.0 && r.radiance.is_finite() {
            self.radiance_sum += r.radiance as f64;
            self.radiance_count += 1;
        }
        if r.value > 0.0 && r.value.is_finite() {
            self.build
                .add_filtered(dtree::dir_to_square(r.dir), r.value as f64);
        }
        if let Some(f) = &r.fraction {
            self.fraction.add(f);
        }
    }
}

/// One record of training: at `p`, on a surface of normal `n`, radiance
/// arrived along `dir` (world) whose luminance divided by the density the
/// direction was sampled with is `value`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Record {
    /// Where the bounce was.
    pub p: Vec3,
    /// The geometric normal there, on the side the path came from.
    pub n: Vec3,
    /// The sampled direction, unit length.
    pub dir: Vec3,
    /// Luminance of the incident radiance over the sampling density.
    pub value: f32,
    /// Luminance of the radiance the path gathered from this bounce on
    /// (light sampled here and everything after), over the throughput
    /// that arrived: an estimate of the radiance leaving `p` towards where
    /// the path came from, which efficiency-aware roulette weighs paths
    /// by ([`Guide::leaf_radiance`]). Negative where it was not finite.
    pub radiance: f32,
    /// At a guided bounce, what the leaf's share of BSDF samples learns
    /// from ([`fraction`]); `None` at an unguided one.
    pub fraction: Option<FractionSample>,
}

/// The guide a render samples from: the spatial tree and one frozen
/// directional distribution per leaf.
#[derive(Debug, Clone, PartialEq)]
pub struct Guide {
    tree: SpatialTree,
    leaves: Vec<SampleTree>,
    /// Each leaf's mean outgoing radiance ([`Record::radiance`]); negative
    /// where no record said.
    radiance: Vec<f32>,
    /// The pixels' estimates, for roulette ([`Guide::roulette_scale`]).
    pixels: Option<PixelEstimate>,
    /// Each leaf's learned share of BSDF samples ([`fraction`]).
    bsdf_shares: Vec<f32>,
    /// Each leaf's share at its upper limit ([`Guide::bsdf_only`]).
    bsdf_only: Vec<bool>,
    /// The samples of the training iterations the render keeps
    /// ([`Guide::reused`]); not saved with the guide.
    reused: Option<std::sync::Arc<crate::film::Film>>,
}

/// What training's images estimate each pixel to be: the mean luminance of
/// all their samples, row by row from the top.
#[derive(Debug, Clone, PartialEq)]
pub struct PixelEstimate {
    /// The image's width and height.
    pub resolution: [u32; 2],
    /// Mean sample luminance per pixel.
    pub mean: Vec<f32>,
}

/// The weight window `s` of adjoint-driven roulette (Vorba and Křivánek
/// 2016): a path whose expected contribution (its throughput times the
/// guide's estimate of the radiance leaving its vertex) is at least
/// `2 / (1 + s)` of its pixel's estimate always goes on; below that it goes
/// on with probability in proportion. (Their splitting above the window
/// was built and measured slower to the same error on the door scene at
/// every setting tried, so it is left out: `docs/guide/guiding.md`.) They
/// use `s = 5`; with
/// our coarse per-leaf estimates it ended too many paths that mattered.
/// Measured on `benches/race/hard/door-ajar.xml`, 256 spp, guided, efficiency
/// `1 / (noise MSE x time)`: 355 at `s = 5`, 571 at 19, 559 at 49, 552 at
/// 199 (unguided: 350); at 64 spp 19 was also ahead of 5 and level with 99.
pub const WEIGHT_WINDOW: f32 = 19.0;

/// The least probability with which adjoint-driven roulette lets a path go
/// on: a floor, so that a path the guide's estimates call worthless, which
/// could still carry light the training missed, keeps a chance (and the
/// estimator stays unbiased), and no survivor is weighted by more than
/// `1 / ROULETTE_FLOOR`.
pub const ROULETTE_FLOOR: f32 = 0.05;

impl Guide {
    /// The directional distribution at point `p` of a surface of normal
    /// `n`, when it has learned anything there.
    #[inline]
    pub fn at(&self, p: Vec3, n: Vec3) -> Option<&SampleTree> {
        let t = &self.leaves[self.tree.leaf(p, n)];
        t.is_usable().then_some(t)
    }

    /// The index of the leaf holding `p` (normal `n`).
    #[inline]
    pub fn leaf_index(&self, p: Vec3, n: Vec3) -> u32 {
        self.tree.leaf(p, n) as u32
    }

    /// Leaf `i`'s directional distribution.
    #[inline]
    pub fn leaf(&self, i: u32) -> &SampleTree {
        &self.leaves[i as usize]
    }

    /// Leaf `i`'s mean luminance of the radiance leaving its surfaces
    /// towards where paths came from, over training's paths, when any path
    /// there said.
    #[inline]
    pub fn leaf_radiance(&self, i: u32) -> Option<f32> {
        let r = self.radiance[i as usize];
        (r >= 0.0).then_some(r)
    }

    /// Leaf `i`'s share of BSDF samples at a guided bounce ([`fraction`]).
    #[inline]
    pub fn bsdf_share(&self, i: u32) -> f32 {
        self.bsdf_shares[i as usize]
    }

    /// Whether leaf `i`'s share of BSDF samples reached its upper limit
    /// (0.982): a render then samples the leaf's bounces by the BSDF alone
    /// and skips the guide's density at every light sample there. Training
    /// keeps the mixture, so that the share can still come down. On the
    /// rough metals of `glossy-env` every leaf gets there.
    #[inline]
    pub fn bsdf_only(&self, i: u32) -> bool {
        self.bsdf_only[i as usize]
    }

    /// This guide with `film`, the samples of the training iterations
    /// that the render adds to its own ([`Guide::reused`]).
    pub fn with_reused(mut self, film: crate::film::Film) -> Self {
        self.reused = Some(std::sync::Arc::new(film));
        self
    }

    /// The samples of the last training iterations, which the render adds
    /// to its film once (the part of a render that begins at sample 0
    /// adds them; a resumed one already holds them): every one an unbiased
    /// estimate of its pixel, as the render's are, drawn with an earlier
    /// guide. `None` for a guide read back from a checkpoint.
    pub fn reused(&self) -> Option<&crate::film::Film> {
        self.reused.as_deref()
    }

    /// This guide with `pixels`, the training images' estimates.
    pub fn with_pixels(mut self, pixels: PixelEstimate) -> Self {
        self.pixels = Some(pixels);
        self
    }

    /// For the path of pixel `[x, y]`: the factor that turns its expected
    /// contribution (throughput luminance times [`Guide::leaf_radiance`]) into
    /// adjoint-driven roulette's probability of going on, `(1 + s) / (2 I)`
    /// with `I` the pixel's estimate and `s` the [`WEIGHT_WINDOW`]; 0 where
    /// there is no estimate or it is 0 (then the roulette is by
    /// throughput).
    #[inline]
    pub fn roulette_scale(&self, x: u32, y: u32) -> f32 {
        let Some(px) = &self.pixels else {
            return 0.0;
        };
        let [w, h] = px.resolution;
        if x >= w || y >= h {
            return 0.0;
        }
        let i = px.mean[(y * w + x) as usize];
        if i > 0.0 && i.is_finite() {
            (1.0 + WEIGHT_WINDOW) / (2.0 * i)
        } else {
            0.0
        }
    }

    /// Spatial leaves.
    pub fn leaf_count(&self) -> usize {
        self.leaves.len()
    }

    /// Directional nodes, all leaves together.
    pub fn node_count(&self) -> usize {
        self.leaves.iter().map(SampleTree::node_count).sum()
    }
}

/// The SD-tree while it trains.
#[derive(Debug, Clone, PartialEq)]
pub struct GuideBuilder {
    tree: SpatialTree,
    leaves: Vec<LeafState>,
    /// Records above which a leaf splits, before the `sqrt(2^k)` growth.
    split_records: f64,
}

impl GuideBuilder {
    /// An untrained guide over the box `min..max`.
    pub fn new(min: Vec3, max: Vec3) -> Self {
        // a leaf needs that many records for its quadtree to be more than
        // the directions a few lucky paths took, whatever the image's size
        let split_records = SPLIT_RECORDS;
        GuideBuilder {
            tree: SpatialTree::new(min, max),
            leaves: vec![
                LeafState {
                    sampling: SampleTree::default(),
                    build: BuildTree::default(),
                    count: 0,
                    radiance_sum: 0.0,
                    radiance_count: 0,
                    fraction: Fraction::default(),
                };
                NORMAL_CLASSES
            ],
            split_records,
        }
    }

    /// Add `records`, in their order.
    pub fn deposit(&mut self, records: &[Record]) {
        for r in records {
            let leaf = self.leaf_of(r);
            self.leaves[leaf].add(r);
        }
    }

    /// The leaf [`GuideBuilder::deposit`] adds `record` to (the spatial
    /// tree changes only when an iteration ends).
    #[inline]
    pub fn leaf_of(&self, record: &Record) -> usize {
        self.tree.leaf(record.p, record.n)
    }

    /// [`GuideBuilder::deposit`] of the records of `batches` in their order,
    /// each batch's records beside their leaves ([`GuideBuilder::leaf_of`],
    /// which the callers find in parallel), with the leaves filled in
    /// parallel on the current `rayon` pool. A leaf takes its records in the
    /// same order as the serial deposit and nothing is shared between
    /// leaves, so the sums are the same bits for any thread count.
    pub fn deposit_by_leaf<'a>(
        &mut self,
        batches: impl IntoIterator<Item = (&'a [Record], &'a [u32])> + Clone,
    ) {
        let pairs = || {
            batches.clone().into_iter().flat_map(|(records, leaves)| {
                assert_eq!(records.len(), leaves.len(), "a leaf per record");
                records.iter().zip(leaves)
            })
        };
        // on one thread nothing fills in parallel to pay for sorting (a
        // first version that grouped the records on one thread as well
        // measured 1.018x the guided door's time)
        if rayon::current_num_threads() == 1 {
            for (r, &leaf) in pairs() {
                self.leaves[leaf as usize].add(r);
            }
            return;
        }
        // the records ordered by leaf, each leaf's in their order (a
        // counting sort), then each leaf's run added on its own
        let mut start = vec![0usize; self.leaves.len() + 1];
        for (_, &leaf) in pairs() {
            start[leaf as usize + 1] += 1;
        }
        for i in 1..start.len() {
            start[i] += start[i - 1];
        }
        let mut next = start.clone();
        let mut sorted: Vec<Option<&Record>> = vec![None; start[self.leaves.len()]];
        for (r, &leaf) in pairs() {
            sorted[next[leaf as usize]] = Some(r);
            next[leaf as usize] += 1;
        }
        self.leaves
            .par_iter_mut()
            .enumerate()
            .for_each(|(i, leaf)| {
                for r in sorted[start[i]..start[i + 1]].iter().flatten() {
                    leaf.add(r);
                }
            });
    }

    /// End training iteration `iteration` (0 first): every leaf's records
    /// become its sampling distribution; leaves with too many records are
    /// halved (each half keeping the distribution) and every leaf's
    /// quadtree is refined for the next iteration's records. Returns the
    /// guide to sample from.
    pub fn finish_iteration(&mut self, iteration: u32) -> Guide {
        for leaf in &mut self.leaves {
            leaf.sampling = leaf.build.to_sampling();
        }
        let limit = self.split_records * 2f64.powf(0.5 * iteration as f64);
        self.split(limit);
        for leaf in &mut self.leaves {
            leaf.build = leaf.build.refined();
            leaf.count = 0;
        }
        Guide {
            tree: self.tree.clone(),
            leaves: self.leaves.iter().map(|l| l.sampling.clone()).collect(),
            radiance: self
                .leaves
                .iter()
                .map(|l| {
                    if l.radiance_count > 0 {
                        (l.radiance_sum / l.radiance_count as f64) as f32
                    } else {
                        -1.0
                    }
                })
                .collect(),
            pixels: None,
            bsdf_shares: self
                .leaves
                .iter()
                .map(|l| l.fraction.bsdf_share())
                .collect(),
            bsdf_only: self.leaves.iter().map(|l| l.fraction.saturated()).collect(),
            reused: None,
        }
    }

    /// Halve every leaf with more than `limit` records, recursively (a
    /// half is taken to hold half the records), cycling the axes x, y, z
    /// down the tree.
    fn split(&mut self, limit: f64) {
        // (node, depth)
        let mut stack: Vec<(usize, u32)> = (0..NORMAL_CLASSES).map(|c| (c, 0)).collect();
        while let Some((node, depth)) = stack.pop() {
            match self.tree.nodes()[node] {
                SpatialNode::Split { child, .. } => {
                    stack.push((child as usize, depth + 1));
                    stack.push((child as usize + 1, depth + 1));
                }
                SpatialNode::Leaf(l) => {
                    let l = l as usize;
                    if (self.leaves[l].count as f64) <= limit || depth >= MAX_SPATIAL_DEPTH {
                        continue;
                    }
                    self.leaves[l].count /= 2;
                    let twin = self.leaves[l].clone();
                    let l2 = self.leaves.len();
                    self.leaves.push(twin);
                    let child = self.tree.halve(node, depth, l as u32, l2 as u32);
                    stack.push((child, depth + 1));
                    stack.push((child + 1, depth + 1));
                }
            }
        }
        self.tree.tabulate();
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampler::mix64;

    /// Records by leaf on pools of one and three threads, in batches of
    /// uneven sizes, train the guide the serial deposit trains, bit for
    /// bit, over iterations whose leaves split (so the leaves differ from
    /// one iteration to the next).
    #[test]
    fn depositing_by_leaf_in_parallel_trains_the_serial_guide() {
        let unit = |k: u64, s: u64| (mix64(k ^ s << 40) >> 40) as f32 / (1u64 << 24) as f32;
        let records = |it: u64| -> Vec<Record> {
            (0..60_000u64)
                .map(|i| {
                    let k = i + 100_000 * it;
                    let n = [Vec3::Y, Vec3::Y, -Vec3::X, Vec3::Z][(k % 4) as usize];
                    Record {
                        // crowded in one corner, so leaves there split
                        p: Vec3::new(unit(k, 1), unit(k, 2), unit(k, 3)).powf(3.0),
                        n,
                        dir: Vec3::new(unit(k, 4) - 0.5, 1.0, unit(k, 5) - 0.5).normalize(),
                        value: if k % 11 == 0 { 0.0 } else { unit(k, 6) * 4.0 },
                        radiance: if k % 7 == 0 { f32::NAN } else { unit(k, 7) },
                        fraction: (k % 2 == 0).then_some(FractionSample {
                            weight: unit(k, 8),
                            bsdf_pdf: 0.1 + unit(k, 9),
                            guide_pdf: 0.2 + unit(k, 10),
                        }),
                    }
                })
                .collect()
        };
        for threads in [1, 3] {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .expect("a pool");
            let mut serial = GuideBuilder::new(Vec3::ZERO, Vec3::ONE);
            let mut by_leaf = serial.clone();
            for it in 0..3 {
                let records = records(it as u64);
                serial.deposit(&records);
                let leaves: Vec<u32> = records.iter().map(|r| by_leaf.leaf_of(r) as u32).collect();
                // batches of 1, 2, 3, ... records
                let mut batches = Vec::new();
                let (mut at, mut size) = (0, 1);
                while at < records.len() {
                    let end = (at + size).min(records.len());
                    batches.push((&records[at..end], &leaves[at..end]));
                    (at, size) = (end, size + 1);
                }
                pool.install(|| by_leaf.deposit_by_leaf(batches.iter().copied()));
                let (a, b) = (serial.finish_iteration(it), by_leaf.finish_iteration(it));
                assert_eq!(a, b, "{threads} threads, iteration {it}");
                assert!(it == 0 || a.leaf_count() > NORMAL_CLASSES, "leaves split");
            }
        }
    }

    #[test]
    fn a_crowded_leaf_splits_and_points_find_their_halves() {
        let mut b = GuideBuilder::new(Vec3::ZERO, Vec3::ONE);
        let records: Vec<Record> = (0..40_000)
            .map(|i| Record {
                p: Vec3::new((i % 100) as f32 / 100.0, 0.5, 0.5),
                n: Vec3::Y,
                dir: Vec3::Z,
                value: 1.0,
                radiance: 0.5,
                // the BSDF's density far above the guide's where light was
                fraction: Some(FractionSample {
                    weight: 1.0,
                    bsdf_pdf: 5.0,
                    guide_pdf: 0.1,
                }),
            })
            .collect();
        b.deposit(&records);
        let g = b.finish_iteration(0);
        // the +y leaves (halves keep their parent's share) learned to favour
        // the BSDF; the others never saw a record
        let leaf = g.leaf_index(Vec3::new(0.1, 0.5, 0.5), Vec3::Y);
        assert!(g.bsdf_share(leaf) > 0.9, "{}", g.bsdf_share(leaf));
        assert!(
            g.bsdf_only(leaf),
            "10000 steps the same way reach the limit"
        );
        let other = g.leaf_index(Vec3::new(0.1, 0.5, 0.5), -Vec3::Y);
        assert_eq!(g.bsdf_share(other), BSDF_FRACTION);
        assert!(!g.bsdf_only(other));
        // 40000 records against the limit: split down to the limit or
        // less, in the +y class's tree only
        let least = 5 + (40_000.0 / SPLIT_RECORDS).ceil() as usize;
        assert!(g.leaf_count() >= least, "{} leaves", g.leaf_count());
        let a = g.tree.leaf(Vec3::new(0.1, 0.5, 0.5), Vec3::Y);
        let c = g.tree.leaf(Vec3::new(0.9, 0.5, 0.5), Vec3::Y);
        assert_ne!(a, c);
        // every leaf learned the one direction
        let t = g
            .at(Vec3::new(0.1, 0.5, 0.5), Vec3::Y)
            .expect("a trained leaf");
        assert!(t.pdf(Vec3::Z) > t.pdf(-Vec3::Z));
        // the other side of the surface learned nothing
        assert!(g.at(Vec3::new(0.1, 0.5, 0.5), -Vec3::Y).is_none());
        assert_eq!(spatial::normal_class(Vec3::new(0.2, -0.9, 0.3)), 3);
    }

    #[test]
    fn leaves_average_their_outgoing_radiance_and_pixels_set_the_roulette_scale() {
        let mut b = GuideBuilder::new(Vec3::ZERO, Vec3::ONE);
        let at = |p: Vec3, radiance: f32| Record {
            p,
            n: Vec3::Z,
            dir: Vec3::Z,
            value: 1.0,
            radiance,
            fraction: None,
        };
        let p = Vec3::splat(0.5);
        // a non-finite estimate (negative) is left out of the mean
        b.deposit(&[at(p, 1.0), at(p, 3.0), at(p, -1.0)]);
        let g = b.finish_iteration(0);
        let l = g.leaf_index(p, Vec3::Z);
        assert_eq!(g.leaf_radiance(l), Some(2.0));
        // the other side learned nothing: no estimate, not a zero one
        assert_eq!(g.leaf_radiance(g.leaf_index(p, -Vec3::Z)), None);
        // a later iteration adds to what the leaf knew
        b.deposit(&[at(p, 5.0)]);
        let g = b.finish_iteration(1);
        assert_eq!(g.leaf_radiance(g.leaf_index(p, Vec3::Z)), Some(3.0));
        // no pixel estimates: roulette by the settings' rule
        assert_eq!(g.roulette_scale(0, 0), 0.0);
        let g = g.with_pixels(PixelEstimate {
            resolution: [2, 1],
            mean: vec![0.25, 0.0],
        });
        assert_eq!(g.roulette_scale(0, 0), (1.0 + WEIGHT_WINDOW) / 0.5);
        // a black pixel, or one outside the image, has no window
        assert_eq!(g.roulette_scale(1, 0), 0.0);
        assert_eq!(g.roulette_scale(2, 0), 0.0);
    }
}
