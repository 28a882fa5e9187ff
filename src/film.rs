//! TEMPORARY stand-in, replaced by the real film module.
#![allow(missing_docs)]
use crate::error::{Error, Result};
use crate::math::Vec3;
use std::path::Path;

#[derive(Debug, Clone, Copy, Default)]
pub struct Pixel { pub sum: [f64; 3], pub sum_sq: [f64; 3], pub count: u64 }
#[derive(Debug, Clone, Copy)]
pub struct TileBounds { pub x0: u32, pub y0: u32, pub width: u32, pub height: u32 }
#[derive(Debug)]
pub struct Film { width: u32, height: u32, pixels: Vec<Pixel> }
#[derive(Debug)]
pub struct Tile { b: TileBounds, pixels: Vec<Pixel> }
impl Tile {
    pub fn new(b: TileBounds) -> Self { Tile { b, pixels: vec![Pixel::default(); (b.width * b.height) as usize] } }
    pub fn bounds(&self) -> TileBounds { self.b }
    pub fn add_sample(&mut self, x: u32, y: u32, c: Vec3) {
        let p = &mut self.pixels[((y - self.b.y0) * self.b.width + x - self.b.x0) as usize];
        for i in 0..3 { p.sum[i] += c[i] as f64; p.sum_sq[i] += (c[i] as f64).powi(2); } p.count += 1;
    }
}
impl Film {
    pub fn new(width: u32, height: u32) -> Self { Film { width, height, pixels: vec![Pixel::default(); (width * height) as usize] } }
    pub fn tiles(&self, s: u32) -> Vec<TileBounds> {
        let mut v = vec![];
        for y0 in (0..self.height).step_by(s as usize) { for x0 in (0..self.width).step_by(s as usize) {
            v.push(TileBounds { x0, y0, width: s.min(self.width - x0), height: s.min(self.height - y0) }); } }
        v
    }
    pub fn merge_tile(&mut self, t: &Tile) {
        for y in 0..t.b.height { for x in 0..t.b.width {
            let s = t.pixels[(y * t.b.width + x) as usize];
            let d = &mut self.pixels[((y + t.b.y0) * self.width + x + t.b.x0) as usize];
            for i in 0..3 { d.sum[i] += s.sum[i]; d.sum_sq[i] += s.sum_sq[i]; } d.count += s.count; } }
    }
    pub fn mean(&self, x: u32, y: u32) -> Vec3 { let p = self.pixels[(y * self.width + x) as usize]; if p.count == 0 { Vec3::ZERO } else { Vec3::new((p.sum[0] / p.count as f64) as f32, (p.sum[1] / p.count as f64) as f32, (p.sum[2] / p.count as f64) as f32) } }
    pub fn variance_of_mean(&self, x: u32, y: u32) -> Vec3 { let p = self.pixels[(y * self.width + x) as usize]; let n = p.count as f64; if n < 2.0 { return Vec3::ZERO; }
        let f = |i: usize| (((p.sum_sq[i] - p.sum[i] * p.sum[i] / n) / (n - 1.0)).max(0.0) / n) as f32; Vec3::new(f(0), f(1), f(2)) }
    pub fn mean_rgb(&self) -> [f64; 3] { let mut m = [0.0; 3]; for y in 0..self.height { for x in 0..self.width { let c = self.mean(x, y); for i in 0..3 { m[i] += c[i] as f64; } } } m.map(|v| v / (self.width * self.height) as f64) }
    pub fn to_rgb_f32(&self) -> Vec<f32> { let mut v = vec![]; for y in 0..self.height { for x in 0..self.width { let c = self.mean(x, y); v.extend([c.x, c.y, c.z]); } } v }
    pub fn width(&self) -> u32 { self.width }
    pub fn height(&self) -> u32 { self.height }
}
#[derive(Default)]
pub struct OutputOptions { pub exposure: f32, pub metadata: Vec<(String, String)> }
pub fn check_output_path(path: &Path) -> Result<()> {
    let ext = path.extension().and_then(|e| e.to_str()).unwrap_or("").to_ascii_lowercase();
    if !["png", "exr", "pfm"].contains(&ext.as_str()) { return Err(Error::Settings(format!("{}: unknown output format `.{ext}` (expected .png, .exr or .pfm)", path.display()))); }
    let parent = path.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new("."));
    if !parent.is_dir() { return Err(Error::Settings(format!("{}: directory {} does not exist", path.display(), parent.display()))); }
    Ok(())
}
pub fn write_file_atomically(path: &Path, bytes: &[u8]) -> Result<()> { std::fs::write(path, bytes).map_err(|e| Error::io(path, e)) }
pub fn write_image(path: &Path, film: &Film, o: &OutputOptions) -> Result<()> {
    let ext = path.extension().and_then(|e| e.to_str()).unwrap_or("").to_ascii_lowercase();
    if ext == "pfm" {
        let mut b = format!("PF\n{} {}\n-1.0\n", film.width, film.height).into_bytes();
        let d = film.to_rgb_f32();
        for y in (0..film.height).rev() { for x in 0..film.width * 3 { b.extend(d[(y * film.width * 3 + x) as usize].to_le_bytes()); } }
        return write_file_atomically(path, &b);
    }
    let k = 2f32.powf(o.exposure);
    let img = image::RgbImage::from_fn(film.width, film.height, |x, y| { let c = film.mean(x, y) * k;
        let e = |v: f32| { let v = v.clamp(0.0, 1.0); let s = if v <= 0.0031308 { 12.92 * v } else { 1.055 * v.powf(1.0 / 2.4) - 0.055 }; (s * 255.0).round() as u8 };
        image::Rgb([e(c.x), e(c.y), e(c.z)]) });
    img.save(path).map_err(|e| Error::Settings(e.to_string()))
}
pub fn read_pfm(path: &Path) -> Result<(u32, u32, Vec<f32>)> {
    let b = std::fs::read(path).map_err(|e| Error::io(path, e))?; let s = String::from_utf8_lossy(&b[..20]); let mut it = s.split_whitespace(); it.next();
    let w: u32 = it.next().unwrap().parse().unwrap(); let h: u32 = it.next().unwrap().parse().unwrap(); Ok((w, h, vec![]))
}
