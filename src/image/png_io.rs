//! 8-bit sRGB PNG output: previews of linear renders (with an exposure in stops) and
//! false-colour maps.

use anyhow::Result;
use glam::Vec3;
use std::path::Path;

use super::{RgbImage, write_atomically};

/// The sRGB transfer function of a linear value in [0, 1].
fn srgb_encode(v: f32) -> f32 {
    if v <= 0.003_130_8 { 12.92 * v } else { 1.055 * v.powf(1.0 / 2.4) - 0.055 }
}

fn to_u8(v: f32) -> u8 {
    if v.is_nan() { 0 } else { (v.clamp(0.0, 1.0) * 255.0 + 0.5) as u8 }
}

/// Writes 8-bit RGB pixels (already display-encoded, each in [0, 1]) as a PNG.
pub fn write_png(path: &Path, width: usize, height: usize, pixels: &[Vec3]) -> Result<()> {
    let data: Vec<u8> = pixels.iter().flat_map(|p| [to_u8(p.x), to_u8(p.y), to_u8(p.z)]).collect();
    write_atomically(path, |out| {
        let mut enc = png::Encoder::new(out, width as u32, height as u32);
        enc.set_color(png::ColorType::Rgb);
        enc.set_depth(png::BitDepth::Eight);
        enc.set_source_srgb(png::SrgbRenderingIntent::Perceptual);
        let mut w = enc.write_header()?;
        w.write_image_data(&data)?;
        w.finish()?;
        Ok(())
    })
}

/// Writes a preview of a linear image: scaled by 2^exposure, clamped, sRGB-encoded.
pub fn write_preview(path: &Path, img: &RgbImage, exposure: f32) -> Result<()> {
    let scale = exposure.exp2();
    let px: Vec<Vec3> = img
        .pixels
        .iter()
        .map(|p| {
            let v = *p * scale;
            Vec3::new(
                srgb_encode(v.x.clamp(0.0, 1.0)),
                srgb_encode(v.y.clamp(0.0, 1.0)),
                srgb_encode(v.z.clamp(0.0, 1.0)),
            )
        })
        .collect();
    write_png(path, img.width, img.height, &px)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn srgb_endpoints_and_midpoint() {
        assert_eq!(srgb_encode(0.0), 0.0);
        assert!((srgb_encode(1.0) - 1.0).abs() < 1e-6);
        assert!((srgb_encode(0.214) - 0.5).abs() < 2e-3);
        assert_eq!(to_u8(f32::NAN), 0);
        assert_eq!(to_u8(2.0), 255);
    }
}
