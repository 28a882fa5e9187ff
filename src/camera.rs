//! The perspective camera: a pinhole by default, a thin lens on request
//! (pbrt-v4 section 5.2.3, "The Thin Lens Model and Depth of Field").
//!
//! Film coordinates are in pixels, x to the right and y downwards, `(0, 0)` at
//! the top-left corner of the image.
//!
//! Thin lens: the lens is a disk of radius `aperture_radius` centred on the
//! camera origin, perpendicular to the view direction; the plane in focus lies
//! at distance `focus_distance` along the view direction. The ray for film
//! position `p` and lens sample `u` starts at the point of the lens that
//! Shirley and Chiu's concentric map sends `u` to, and passes through the point
//! where the pinhole ray through `p` meets the plane in focus. So every lens
//! sample of one film position converges on the same point of that plane: it
//! is sharp there, and blurred in proportion to the aperture elsewhere.
//! With `aperture_radius == 0` the lens is never sampled and the ray is the
//! pinhole ray, bit for bit.

use crate::error::{Error, Result};
use crate::math::{Ray, Vec2, Vec3};
use crate::sampling::square_to_concentric_disk;

/// The pinhole camera as a scene file describes it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CameraDesc {
    /// Eye position.
    pub origin: Vec3,
    /// Point looked at.
    pub target: Vec3,
    /// Up direction (need not be orthogonal to the view direction).
    pub up: Vec3,
    /// Vertical field of view in degrees.
    pub fov_y: f32,
}

/// The lens of a [`Camera`]: aperture radius and focus distance, both in scene
/// units.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ThinLens {
    /// Radius of the lens disk; 0 is a pinhole.
    pub aperture_radius: f32,
    /// Distance from the lens to the plane in focus, along the view direction.
    pub focus_distance: f32,
}

impl ThinLens {
    /// A pinhole: nothing is blurred (the focus distance is then irrelevant).
    pub const PINHOLE: ThinLens = ThinLens {
        aperture_radius: 0.0,
        focus_distance: 1.0,
    };

    /// A lens with the given aperture radius (finite, `>= 0`) and focus
    /// distance (finite, `> 0`).
    pub fn new(aperture_radius: f32, focus_distance: f32) -> Result<Self> {
        if !(aperture_radius >= 0.0) || !aperture_radius.is_finite() {
            return Err(Error::Settings(format!(
                "aperture_radius must be a finite number >= 0, got {aperture_radius}"
            )));
        }
        if !(focus_distance > 0.0) || !focus_distance.is_finite() {
            return Err(Error::Settings(format!(
                "focus_distance must be a finite number > 0, got {focus_distance}"
            )));
        }
        Ok(ThinLens {
            aperture_radius,
            focus_distance,
        })
    }

    /// Whether this lens is a pinhole (its rays need no lens sample).
    pub fn is_pinhole(&self) -> bool {
        self.aperture_radius == 0.0
    }
}

/// A perspective camera for a given image size.
#[derive(Debug, Clone, Copy)]
pub struct Camera {
    origin: Vec3,
    /// Direction to the top-left corner of the image plane at distance 1.
    corner: Vec3,
    /// Image-plane step per pixel to the right.
    dx: Vec3,
    /// Image-plane step per pixel downwards.
    dy: Vec3,
    /// Unit vector to the right of the view (the lens's first axis).
    right: Vec3,
    /// Unit vector up in the image (the lens's second axis).
    up: Vec3,
    lens: ThinLens,
    /// The focus distance and the aperture radius over the larger of the
    /// two ([`Camera::generate_ray_lens`]'s scale, so that neither
    /// overflows nor underflows).
    lens_scale: (f32, f32),
}

impl Camera {
    /// The pinhole camera described by `desc` for a `width` x `height` image.
    pub fn new(desc: &CameraDesc, width: u32, height: u32) -> Self {
        Self::with_lens(desc, width, height, ThinLens::PINHOLE)
    }

    /// The camera described by `desc` with lens `lens`, for a `width` x
    /// `height` image. With [`ThinLens::PINHOLE`] this is [`Camera::new`].
    pub fn with_lens(desc: &CameraDesc, width: u32, height: u32, lens: ThinLens) -> Self {
        let forward = (desc.target - desc.origin).normalize();
        let right = forward.cross(desc.up).normalize();
        let up = right.cross(forward);
        let half_h = (0.5 * desc.fov_y.to_radians()).tan();
        let half_w = half_h * width as f32 / height as f32;
        Camera {
            origin: desc.origin,
            corner: forward - half_w * right + half_h * up,
            dx: right * (2.0 * half_w / width as f32),
            dy: -up * (2.0 * half_h / height as f32),
            right,
            up,
            lens,
            lens_scale: {
                let (f, a) = (lens.focus_distance, lens.aperture_radius);
                let s = f.max(a);
                (f / s, a / s)
            },
        }
    }

    /// The camera's lens.
    pub fn lens(&self) -> ThinLens {
        self.lens
    }

    /// The pinhole ray through film position `p` (pixels). It ignores the
    /// lens: use [`Camera::generate_ray_lens`] for a thin-lens camera.
    #[inline]
    pub fn generate_ray(&self, p: Vec2) -> Ray {
        let d = self.corner + p.x * self.dx + p.y * self.dy;
        Ray::new(self.origin, d.normalize())
    }

    /// The ray through film position `p` (pixels) and the lens point chosen by
    /// `u_lens` in `[0, 1)^2`. For a pinhole lens `u_lens` is not used and the
    /// ray equals [`Camera::generate_ray`]'s bit for bit.
    #[inline]
    pub fn generate_ray_lens(&self, p: Vec2, u_lens: Vec2) -> Ray {
        if self.lens.is_pinhole() {
            return self.generate_ray(p);
        }
        // The pinhole direction has component 1 along the view axis, so the
        // plane in focus is reached at `focus_distance` times it.
        // Lens point to focus point, relative to the camera origin: in world
        // space, far from the origin (1e18), the two round to the same
        // position and their difference to zero. Both terms are scaled by
        // the larger of the two lengths so that neither overflows (focus
        // 3e38) nor the squared length underflows (focus 1e-38, aperture
        // 1e-30); the direction is unchanged by the scale.
        let d = self.corner + p.x * self.dx + p.y * self.dy;
        let disk = square_to_concentric_disk(u_lens);
        let (focus, aperture) = self.lens_scale;
        let v = focus * d - aperture * (disk.x * self.right + disk.y * self.up);
        let m = v.abs().max_element();
        // `m == 0` only when the scaled focus distance underflows and the
        // lens point is the centre: the pinhole ray
        let dir = if m > 0.0 { v / m } else { d };
        let l = self.lens.aperture_radius * disk;
        Ray::new(
            self.origin + l.x * self.right + l.y * self.up,
            dir.normalize(),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn centre_and_corners() {
        let desc = CameraDesc {
            origin: Vec3::ZERO,
            target: -Vec3::Z,
            up: Vec3::Y,
            fov_y: 90.0,
        };
        let cam = Camera::new(&desc, 200, 100);
        let c = cam.generate_ray(Vec2::new(100.0, 50.0));
        assert!((c.d - -Vec3::Z).length() < 1e-6);
        // top edge centre is 45 degrees up
        let top = cam.generate_ray(Vec2::new(100.0, 0.0));
        assert!((top.d - Vec3::new(0.0, 1.0, -1.0).normalize()).length() < 1e-6);
        // left edge: aspect 2 -> x = -2 at distance 1
        let left = cam.generate_ray(Vec2::new(0.0, 50.0));
        assert!((left.d - Vec3::new(-2.0, 0.0, -1.0).normalize()).length() < 1e-6);
    }

    fn tilted() -> CameraDesc {
        CameraDesc {
            origin: Vec3::new(0.3, 1.7, 4.2),
            target: Vec3::new(-0.2, 0.9, -1.0),
            up: Vec3::new(0.1, 1.0, 0.0),
            fov_y: 37.5,
        }
    }

    /// The pinhole rays of a tilted camera, as the bits the camera produced
    /// before the thin lens was added (recorded from commit 743d052).
    #[test]
    fn pinhole_rays_are_bit_identical_to_before() {
        let golden: [(Vec2, [u32; 3]); 4] = [
            (Vec2::new(0.0, 0.0), [0xbee5475a, 0x3e4aa3a6, 0xbf5f3873]),
            (
                Vec2::new(160.5, 120.25),
                [0xbdbf02b8, 0xbe1bdd22, 0xbf7be355],
            ),
            (
                Vec2::new(319.9, 239.9),
                [0x3e90de4f, 0xbeec22e7, 0xbf5749e5],
            ),
            (
                Vec2::new(17.125, 201.75),
                [0xbeef256e, 0xbe9d37b0, 0xbf54455a],
            ),
        ];
        let desc = tilted();
        let pinhole = Camera::new(&desc, 320, 240);
        let lens0 = Camera::with_lens(&desc, 320, 240, ThinLens::new(0.0, 3.0).unwrap());
        for (p, d) in golden {
            for r in [
                pinhole.generate_ray(p),
                pinhole.generate_ray_lens(p, Vec2::new(0.9, 0.1)),
                lens0.generate_ray(p),
                lens0.generate_ray_lens(p, Vec2::new(0.3, 0.7)),
            ] {
                assert_eq!(
                    r.o.to_array().map(f32::to_bits),
                    desc.origin.to_array().map(f32::to_bits)
                );
                assert_eq!(r.d.to_array().map(f32::to_bits), d, "ray through {p:?}");
                assert_eq!(r.t_max, f32::INFINITY);
            }
        }
    }

    /// Every lens sample through one film position meets the plane in focus
    /// at the same point as the pinhole ray.
    #[test]
    fn the_plane_in_focus_is_sharp() {
        let desc = tilted();
        let focus_distance = 4.5;
        let lens = ThinLens::new(0.25, focus_distance).unwrap();
        let cam = Camera::with_lens(&desc, 320, 240, lens);
        let pin = Camera::new(&desc, 320, 240);
        let forward = (desc.target - desc.origin).normalize();
        let ex = [0.0, 1.4e-45, 0.5, 1.0 - 5.96e-8, 1.0];
        let mut seen_off_axis = false;
        for p in [
            Vec2::new(0.0, 0.0),
            Vec2::new(160.5, 120.25),
            Vec2::new(301.0, 17.5),
        ] {
            let r0 = pin.generate_ray(p);
            // the pinhole ray's point on the plane in focus
            let target = r0.at(focus_distance / r0.d.dot(forward));
            let mut us: Vec<Vec2> = ex
                .iter()
                .flat_map(|&a| ex.iter().map(move |&b| Vec2::new(a, b)))
                .collect();
            us.extend(
                (0..64).map(|i| Vec2::new((i as f32 + 0.5) / 64.0, ((i * 37) % 64) as f32 / 64.0)),
            );
            for u in us {
                let r = cam.generate_ray_lens(p, u);
                assert!(r.is_finite() && (r.d.length() - 1.0).abs() < 1e-6);
                // the origin lies on the lens disk, in the plane of the lens
                let off = r.o - desc.origin;
                assert!(
                    off.dot(forward).abs() < 1e-6,
                    "{u:?}: origin off the lens plane"
                );
                assert!(
                    off.length() <= 0.25 * (1.0 + 1e-6),
                    "{u:?}: origin off the disk"
                );
                seen_off_axis |= off.length() > 0.2;
                let t =
                    (desc.origin + focus_distance * forward - r.o).dot(forward) / r.d.dot(forward);
                let hit = r.at(t);
                // f32 rounding in the ray (a few ulps of the ~5-unit
                // coordinates, amplified by the distance): 1e-5 relative
                assert!(
                    (hit - target).length() < 1e-5 * target.length(),
                    "{p:?} {u:?}: {hit:?} vs {target:?}"
                );
            }
        }
        assert!(seen_off_axis, "lens samples should reach the rim");
    }

    /// Far from the world origin, or with extreme lenses, every lens ray
    /// stays finite and unit length (a fuzzed scene once sent Embree a NaN
    /// direction: the camera at 1.8e18, focus 1e-38).
    #[test]
    fn extreme_lenses_give_finite_rays() {
        let far = CameraDesc {
            origin: Vec3::new(1.8e18, -1.8e18, 1.8e18),
            target: Vec3::ZERO,
            up: Vec3::Y,
            fov_y: 179.99,
        };
        for desc in [far, tilted()] {
            for (aperture, focus) in [
                (1e3, 1e-38),
                (1e-30, 1e-38),
                (3e38, 1.4e-45),
                (1e-38, 3e38),
                (3e38, 3e38),
            ] {
                let cam = Camera::with_lens(&desc, 64, 16, ThinLens::new(aperture, focus).unwrap());
                for u in [Vec2::ZERO, Vec2::splat(0.5), Vec2::new(0.9, 0.1)] {
                    for p in [Vec2::ZERO, Vec2::new(32.0, 8.0), Vec2::new(64.0, 16.0)] {
                        let r = cam.generate_ray_lens(p, u);
                        assert!(
                            r.d.is_finite() && (r.d.length() - 1.0).abs() < 1e-5,
                            "aperture {aperture}, focus {focus}, {p:?} {u:?}: {r:?}"
                        );
                    }
                }
            }
        }
    }

    #[test]
    fn bad_lenses_are_rejected() {
        assert!(ThinLens::new(-0.1, 1.0).is_err());
        assert!(ThinLens::new(f32::NAN, 1.0).is_err());
        assert!(ThinLens::new(0.1, 0.0).is_err());
        assert!(ThinLens::new(0.1, f32::INFINITY).is_err());
        assert!(ThinLens::new(0.0, 1.0).unwrap().is_pinhole());
    }
}
