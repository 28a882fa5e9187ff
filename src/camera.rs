//! The pinhole camera: a ray through each film position (pbrt-v4 section 5.2,
//! without the lens). Film coordinates are in pixels, x to the right and y
//! downwards, `(0, 0)` at the top-left corner of the image.

use crate::math::{Ray, Vec2, Vec3};
use crate::scene::CameraDesc;

/// A pinhole camera for a given image size.
#[derive(Debug, Clone, Copy)]
pub struct Camera {
    origin: Vec3,
    /// Direction to the top-left corner of the image plane at distance 1.
    corner: Vec3,
    /// Image-plane step per pixel to the right.
    dx: Vec3,
    /// Image-plane step per pixel downwards.
    dy: Vec3,
}

impl Camera {
    /// The camera described by `desc` for a `width` x `height` image.
    pub fn new(desc: &CameraDesc, width: u32, height: u32) -> Self {
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
        }
    }

    /// The primary ray through film position `p` (pixels).
    #[inline]
    pub fn generate_ray(&self, p: Vec2) -> Ray {
        let d = self.corner + p.x * self.dx + p.y * self.dy;
        Ray::new(self.origin, d.normalize())
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
}
