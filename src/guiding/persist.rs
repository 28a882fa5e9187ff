//! A trained [`Guide`] as bytes, so that a checkpoint carries the guide its
//! render sampled from and a resumed render samples from the same one
//! without training again (issue 38: "the guide is saved with the
//! accumulation state").
//!
//! The format is the guide's own numbers, little-endian, every `f32` by its
//! bits, so the guide read back is equal to the one written, and so is
//! every path sampled from it:
//!
//! - the magic `embertrace-guide` and a format version (`u32`);
//! - the spatial trees: the cube's corner (3 x `f32`), `1 / side` (`f32`),
//!   the node count (`u32`) and per node a tag (`u8`: 0 a leaf, `1 + axis`
//!   a split) and its leaf or first child (`u32`);
//! - the leaf count (`u32`) and per leaf its quadtree
//!   ([`super::dtree::SampleTree`]'s nodes), mean radiance, BSDF share and
//!   whether the share is saturated;
//! - the training images' pixel estimates, when there are any;
//! - an FNV-1a digest of everything before it.
//!
//! A checkpoint is a file, and a file is untrusted: [`Guide::from_bytes`]
//! checks every index and number that sampling relies on (children after
//! their parents, so every walk ends; quadtrees no deeper than the pdf's
//! bit walk reads; probabilities in `[0, 1]`), and answers a one-line
//! error instead of a guide that could panic or loop.

use super::bytes::{Reader, Writer};
use super::{Guide, NORMAL_CLASSES, PixelEstimate, SpatialNode, SpatialTree};
use crate::math::Vec3;

/// The first bytes of a saved guide.
const MAGIC: &[u8; 16] = b"embertrace-guide";

/// The format's version: a reader refuses others.
const VERSION: u32 = 1;

/// The FNV-1a digest of `bytes` ([`crate::hash::Fnv`]).
fn digest(bytes: &[u8]) -> u64 {
    let mut h = crate::hash::Fnv::default();
    h.bytes(bytes);
    h.finish()
}

impl Guide {
    /// The guide as bytes ([`Guide::from_bytes`] reads them back equal).
    pub fn to_bytes(&self) -> Vec<u8> {
        let mut w = Writer::default();
        w.bytes(MAGIC);
        w.u32(VERSION);
        let t = &self.tree;
        for v in t.origin.to_array() {
            w.f32(v);
        }
        w.f32(t.inv_size);
        w.len(t.nodes().len());
        for n in t.nodes() {
            match *n {
                SpatialNode::Leaf(l) => {
                    w.u8(0);
                    w.u32(l);
                }
                SpatialNode::Split { axis, child } => {
                    w.u8(1 + axis);
                    w.u32(child);
                }
            }
        }
        w.len(self.leaves.len());
        for (i, leaf) in self.leaves.iter().enumerate() {
            leaf.write(&mut w);
            w.f32(self.radiance[i]);
            w.f32(self.bsdf_shares[i]);
            w.u8(u8::from(self.bsdf_only[i]));
        }
        match &self.pixels {
            None => w.u8(0),
            Some(p) => {
                w.u8(1);
                w.u32(p.resolution[0]);
                w.u32(p.resolution[1]);
                for &m in &p.mean {
                    w.f32(m);
                }
            }
        }
        let d = digest(w.as_slice());
        w.bytes(&d.to_le_bytes());
        w.into_vec()
    }

    /// The guide [`Guide::to_bytes`] wrote, or why `bytes` are not one.
    pub fn from_bytes(bytes: &[u8]) -> Result<Guide, String> {
        let Some((body, sum)) = bytes.split_last_chunk::<8>() else {
            return Err("too short to be a guide".into());
        };
        if !body.starts_with(MAGIC) {
            return Err("not a saved guide (no `embertrace-guide` magic)".into());
        }
        if digest(body) != u64::from_le_bytes(*sum) {
            return Err("the saved guide is corrupt (its digest does not match)".into());
        }
        let mut r = Reader::new(body, MAGIC.len());
        let version = r.u32()?;
        if version != VERSION {
            return Err(format!(
                "saved guide format {version}, this build reads {VERSION}"
            ));
        }
        let origin = Vec3::new(r.f32()?, r.f32()?, r.f32()?);
        let inv_size = r.f32()?;
        if !(origin.is_finite() && inv_size > 0.0 && inv_size.is_finite()) {
            return Err("the guide's box is not finite".into());
        }
        let n_nodes = r.count("spatial nodes", 5)?;
        let mut nodes = Vec::with_capacity(n_nodes);
        for _ in 0..n_nodes {
            let (tag, v) = (r.u8()?, r.u32()?);
            nodes.push(match tag {
                0 => SpatialNode::Leaf(v),
                1..=3 => SpatialNode::Split {
                    axis: tag - 1,
                    child: v,
                },
                _ => return Err(format!("spatial node tag {tag}")),
            });
        }
        let n_leaves = r.count("leaves", 25)?;
        // every walk from a root ends at a leaf: children come after their
        // node, both within the tree; leaves name leaves that exist
        if nodes.len() < NORMAL_CLASSES {
            return Err(format!(
                "{} spatial nodes, fewer than the roots",
                nodes.len()
            ));
        }
        for (i, n) in nodes.iter().enumerate() {
            let ok = match *n {
                SpatialNode::Leaf(l) => (l as usize) < n_leaves,
                SpatialNode::Split { child, .. } => {
                    (child as usize) > i && (child as usize) + 1 < nodes.len()
                }
            };
            if !ok {
                return Err(format!("spatial node {i} points outside the tree"));
            }
        }
        let mut leaves = Vec::with_capacity(n_leaves);
        let (mut radiance, mut shares, mut only) = (vec![], vec![], vec![]);
        for i in 0..n_leaves {
            leaves.push(
                super::dtree::SampleTree::read(&mut r).map_err(|e| format!("leaf {i}: {e}"))?,
            );
            let (rad, share, sat) = (r.f32()?, r.f32()?, r.u8()?);
            // negative: nothing learned; else a finite mean
            if !rad.is_finite() || !(0.0..=1.0).contains(&share) || sat > 1 {
                return Err(format!("leaf {i}: radiance {rad}, BSDF share {share}"));
            }
            radiance.push(rad);
            shares.push(share);
            only.push(sat == 1);
        }
        let pixels = match r.u8()? {
            0 => None,
            1 => {
                let resolution = [r.u32()?, r.u32()?];
                let n = resolution[0] as u64 * resolution[1] as u64;
                if n > crate::limits::MAX_PIXELS {
                    return Err(format!(
                        "{}x{} pixel estimates",
                        resolution[0], resolution[1]
                    ));
                }
                let n = r.count_exact(n as usize, 4)?;
                let mut mean = Vec::with_capacity(n);
                for _ in 0..n {
                    mean.push(r.f32()?);
                }
                Some(PixelEstimate { resolution, mean })
            }
            t => return Err(format!("pixel estimate tag {t}")),
        };
        if r.left() != 0 {
            return Err(format!("{} bytes after the guide", r.left()));
        }
        Ok(Guide {
            tree: SpatialTree::from_parts(origin, inv_size, nodes)?,
            leaves,
            radiance,
            pixels,
            bsdf_shares: shares,
            bsdf_only: only,
            reused: None,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::super::dtree::dir_to_square;
    use super::super::fraction::FractionSample;
    use super::super::{GuideBuilder, Record};
    use super::*;
    use crate::sampler::mix64;

    /// A guide trained on made-up records: light from one direction on
    /// the floor, another on a wall, over three iterations (so that leaves
    /// split and quadtrees refine), with pixel estimates.
    pub(crate) fn trained() -> Guide {
        let mut b = GuideBuilder::new(Vec3::ZERO, Vec3::ONE);
        let mut guide = None;
        let unit = |k: u64, s: u32| (mix64(k ^ u64::from(s)) >> 40) as f32 / (1u64 << 24) as f32;
        for it in 0..3 {
            // a few times the split limit, so that leaves split but the
            // guide stays small (the resealing test reads it byte by byte)
            let records: Vec<Record> = (0..5_000u64)
                .map(|k| {
                    let p = Vec3::new(unit(k, 1), unit(k, 2), unit(k, 3));
                    let floor = k % 3 != 0;
                    let n = if floor { Vec3::Y } else { Vec3::X };
                    let dir = Vec3::new(0.3 + 0.1 * unit(k, 4), 1.0, 0.2 * unit(k, 5)).normalize();
                    Record {
                        p,
                        n,
                        dir: if floor { dir } else { -dir },
                        value: 1.0 + unit(k, 6),
                        radiance: if k % 7 == 0 { -1.0 } else { unit(k, 7) },
                        fraction: (k % 2 == 0).then_some(FractionSample {
                            weight: unit(k, 8),
                            bsdf_pdf: 0.1 + unit(k, 9),
                            guide_pdf: 0.2 + unit(k, 10),
                        }),
                    }
                })
                .collect();
            b.deposit(&records);
            guide = Some(b.finish_iteration(it));
        }
        guide.unwrap().with_pixels(PixelEstimate {
            resolution: [3, 2],
            mean: vec![0.5, 1.0, 0.0, 2.5, 3.0, -0.0],
        })
    }

    #[test]
    fn a_guide_reads_back_equal() {
        let g = trained();
        assert!(
            g.leaf_count() > NORMAL_CLASSES,
            "the leaves should have split"
        );
        assert!(
            g.node_count() > 2 * g.leaf_count(),
            "the quadtrees should have refined"
        );
        let bytes = g.to_bytes();
        let back = Guide::from_bytes(&bytes).unwrap();
        assert_eq!(back, g);
        // and samples the same bits
        let d = Vec3::new(0.3, 1.0, 0.1).normalize();
        for i in 0..g.leaf_count() as u32 {
            assert_eq!(g.leaf(i).pdf(d).to_bits(), back.leaf(i).pdf(d).to_bits());
        }
        assert!(dir_to_square(d).is_finite());
    }

    /// Every truncation, and a flipped byte anywhere, is refused with a
    /// message, never a panic or a different guide.
    #[test]
    fn damaged_bytes_are_refused() {
        let bytes = trained().to_bytes();
        for n in [0, 7, 8, 16, 20, 100, bytes.len() / 2, bytes.len() - 1] {
            assert!(Guide::from_bytes(&bytes[..n]).is_err(), "{n} bytes");
        }
        for at in (0..bytes.len()).step_by(97) {
            let mut b = bytes.clone();
            b[at] ^= 0x10;
            let e = Guide::from_bytes(&b).unwrap_err();
            assert!(!e.contains('\n'), "{e}");
        }
    }

    /// Bytes that pass the digest but describe a guide sampling cannot walk
    /// safely (a cycle, a child out of range, a probability above one) are
    /// refused too: the digest is no defence against a file made on purpose.
    #[test]
    fn well_formed_but_unsafe_guides_are_refused() {
        let g = trained();
        let reseal = |mut body: Vec<u8>| {
            body.truncate(body.len() - 8);
            let d = digest(&body);
            body.extend_from_slice(&d.to_le_bytes());
            body
        };
        // the first spatial node's value: after magic, version, box (16 + 4 + 16)
        // and the node count (4), then its tag (1)
        let first_value = 16 + 4 + 16 + 4 + 1;
        let mut cyclic = g.to_bytes();
        cyclic[first_value - 1] = 1; // a split along x
        cyclic[first_value..first_value + 4].copy_from_slice(&0u32.to_le_bytes()); // onto itself
        let e = Guide::from_bytes(&reseal(cyclic)).unwrap_err();
        assert!(e.contains("spatial node 0"), "{e}");

        let mut bad_leaf = g.to_bytes();
        bad_leaf[first_value - 1] = 0;
        bad_leaf[first_value..first_value + 4].copy_from_slice(&u32::MAX.to_le_bytes());
        assert!(Guide::from_bytes(&reseal(bad_leaf)).is_err());

        let mut huge = g.to_bytes();
        huge[first_value - 5..first_value - 1].copy_from_slice(&u32::MAX.to_le_bytes());
        let e = Guide::from_bytes(&reseal(huge)).unwrap_err();
        assert!(e.contains("more than the file holds"), "{e}");
        assert_eq!(Guide::from_bytes(&reseal(g.to_bytes())).unwrap(), g);
    }

    /// Any byte changed and the digest remade: the guide is refused, or
    /// every lookup, draw and density of it ends without a panic.
    #[test]
    fn resealed_changes_anywhere_are_refused_or_safe_to_sample() {
        let bytes = trained().to_bytes();
        let (mut refused, mut read) = (0, 0);
        for at in (0..bytes.len() - 8).step_by(7) {
            for flip in [0x01u8, 0x80, 0xff] {
                let mut b = bytes[..bytes.len() - 8].to_vec();
                b[at] ^= flip;
                let d = digest(&b);
                b.extend_from_slice(&d.to_le_bytes());
                let Ok(g) = Guide::from_bytes(&b) else {
                    refused += 1;
                    continue;
                };
                read += 1;
                for k in 0..16u64 {
                    let u = |s: u32| {
                        (mix64(k ^ (u64::from(s) << 32)) >> 40) as f32 / (1u64 << 24) as f32
                    };
                    let p = Vec3::new(u(1), u(2), u(3)) * 3.0 - 1.0;
                    let n = Vec3::new(u(4) - 0.5, u(5) - 0.5, u(6) - 0.5);
                    let i = g.leaf_index(p, n);
                    let leaf = g.leaf(i);
                    if leaf.is_usable() {
                        let (dir, pdf) = leaf.sample(crate::math::Vec2::new(u(7), u(8)));
                        assert!(pdf >= 0.0 && leaf.pdf(dir) >= 0.0);
                    }
                    let _ = (g.leaf_radiance(i), g.bsdf_share(i), g.bsdf_only(i));
                    let _ = g.roulette_scale(k as u32 % 4, k as u32 % 3);
                }
            }
        }
        assert!(refused > 0 && read > 0, "refused {refused}, read {read}");
    }
}
