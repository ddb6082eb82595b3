//! Images read as textures: the decoded [`Texels`] (linear or sRGB-encoded floats, one or three
//! channels, rows from the top), the file-format dispatch by magic bytes, and the limits every
//! reader checks before it allocates.
//!
//! Every failure is an `Err` whose message names the file and the problem; no reader panics.
//! Readers refuse, before allocating, images of more than [`MAX_PIXELS`] pixels and images
//! larger than the file's bytes could encode (per format; see each reader).

use std::path::Path;

/// The most pixels a texture may have (2²⁷, 134 million: 16384 × 8192).
pub const MAX_PIXELS: u64 = 1 << 27;

/// A decoded image as Mitsuba's `Bitmap` holds it after loading: one channel (Y, from gray or
/// gray + alpha) or three (RGB, from RGB, RGBA or a palette), alpha dropped, row-major from
/// the top-left pixel.
#[derive(Clone, Debug, PartialEq)]
pub struct Texels {
    pub width: u32,
    pub height: u32,
    /// 1 or 3.
    pub channels: u32,
    /// `width · height · channels` values.
    pub data: Vec<f32>,
    /// The values are sRGB-encoded (8- and 16-bit PNG and JPEG), not linear (EXR, HDR).
    pub srgb: bool,
}

impl Texels {
    /// The texels as a linear RGB image (one channel repeated to three); call
    /// [`Texels::linearize`] first for sRGB-encoded ones.
    pub fn to_rgb(&self) -> super::RgbImage {
        let c = self.channels as usize;
        let pixels = self
            .data
            .chunks_exact(c)
            .map(|t| if c == 1 { glam::Vec3::splat(t[0]) } else { glam::Vec3::new(t[0], t[1], t[2]) })
            .collect();
        super::RgbImage { width: self.width as usize, height: self.height as usize, pixels }
    }

    /// Converts sRGB-encoded values to linear ones (the exact sRGB curve, as Mitsuba's
    /// `Bitmap::convert`); linear images are left as they are.
    pub fn linearize(&mut self) {
        if self.srgb {
            for v in &mut self.data {
                *v = srgb_to_linear(*v);
            }
            self.srgb = false;
        }
    }
}

/// The sRGB transfer curve's inverse.
pub fn srgb_to_linear(v: f32) -> f32 {
    if v <= 0.04045 { v / 12.92 } else { ((v + 0.055) / 1.055).powf(2.4) }
}

/// Checks a decoder's claimed size against [`MAX_PIXELS`] and against `per_byte` pixels per
/// byte of the `len`-byte file (what the format's best compression can encode), before any
/// allocation of that size.
pub(crate) fn check_size(width: u64, height: u64, len: usize, per_byte: u64) -> Result<(), String> {
    if width == 0 || height == 0 {
        return Err(format!("an image of {width} × {height} pixels"));
    }
    let pixels = width.saturating_mul(height);
    if pixels > MAX_PIXELS {
        return Err(format!("{width} × {height} pixels: more than pir reads ({MAX_PIXELS} pixels)"));
    }
    if pixels > (len as u64).saturating_mul(per_byte).max(64) {
        return Err(format!("{width} × {height} pixels cannot be encoded in a file of {len} bytes"));
    }
    Ok(())
}

/// Decodes an image file's bytes, the format chosen by its magic bytes.
pub fn decode(bytes: &[u8]) -> Result<Texels, String> {
    let t = if bytes.starts_with(b"\x89PNG") {
        super::png_read::decode(bytes).map_err(|e| format!("PNG: {e}"))?
    } else if bytes.starts_with(&[0xFF, 0xD8]) {
        super::jpeg_read::decode(bytes).map_err(|e| format!("JPEG: {e}"))?
    } else if bytes.starts_with(&[0x76, 0x2F, 0x31, 0x01]) {
        super::exr_read::decode(bytes).map_err(|e| format!("OpenEXR: {e}"))?
    } else if bytes.starts_with(b"#?") {
        super::hdr_read::decode(bytes).map_err(|e| format!("Radiance HDR: {e}"))?
    } else {
        return Err("not a PNG, JPEG, OpenEXR or Radiance HDR (RGBE) file".into());
    };
    debug_assert_eq!(t.data.len() as u64, t.width as u64 * t.height as u64 * t.channels as u64);
    Ok(t)
}

/// Reads and decodes an image file; the error names the file.
pub fn read_texels(path: &Path) -> Result<Texels, String> {
    let bytes = std::fs::read(path).map_err(|e| format!("{}: cannot read: {e}", path.display()))?;
    decode(&bytes).map_err(|e| format!("{}: {e}", path.display()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn unknown_formats_and_absurd_sizes_are_errors() {
        assert!(decode(b"GIF89a").unwrap_err().contains("not a PNG"));
        assert!(decode(b"").is_err());
        assert!(check_size(1 << 20, 1 << 20, 1 << 30, 1 << 20).unwrap_err().contains("more than pir reads"));
        assert!(check_size(1000, 1000, 10, 4).unwrap_err().contains("cannot be encoded"));
        assert!(check_size(0, 5, 10, 4).is_err());
        assert!(check_size(100, 100, 10000, 1).is_ok());
        let e = read_texels(Path::new("/nonexistent/t.png")).unwrap_err();
        assert!(e.starts_with("/nonexistent/t.png: cannot read"), "{e}");
    }

    /// Small valid files of every format and variant the readers take.
    fn inputs() -> Vec<(&'static str, Vec<u8>, bool)> {
        use crate::image::png_read::tests::encode;
        use png::{BitDepth as D, ColorType as C};
        let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/textures");
        let file = |n: &str| std::fs::read(dir.join(n)).unwrap();
        let mut flat_hdr = b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 2 +X 3\n".to_vec();
        flat_hdr.extend([128, 64, 0, 129, 1, 1, 1, 2, 9, 9, 9, 130, 0, 0, 0, 0, 1, 2, 3, 128, 1, 1, 1, 1]);
        let mut exr = std::io::Cursor::new(Vec::new());
        {
            use exr::prelude::*;
            Image::from_channels(
                (5, 3),
                SpecificChannels::rgb(|p: Vec2<usize>| (p.x() as f32, p.y() as f32, 0.5f32)),
            )
            .write()
            .to_buffered(&mut exr)
            .unwrap();
        }
        vec![
            ("rgb8.png", encode(3, 2, C::Rgb, D::Eight, None, &[7; 18]), false),
            ("gray16.png", encode(2, 2, C::Grayscale, D::Sixteen, None, &[1, 2, 3, 4, 5, 6, 7, 8]), false),
            (
                "palette.png",
                encode(4, 1, C::Indexed, D::Two, Some(vec![1, 2, 3, 4, 5, 6]), &[0b0001_0100]),
                false,
            ),
            ("rgba.png", encode(2, 1, C::Rgba, D::Eight, None, &[1, 2, 3, 4, 5, 6, 7, 8]), false),
            ("rgb.jpg", file("rgb-8x4.jpg"), false),
            ("gray.jpg", file("gray-8x4.jpg"), false),
            ("rle.hdr", file("ramp-9x3.hdr"), false),
            ("flat.hdr", flat_hdr, false),
            ("rgb.exr", exr.into_inner(), false),
        ]
    }

    fn mutations(cases: usize, seed: u64) {
        use crate::scene::mesh_data::mutation::survive;
        let (ok, err) = survive(
            "texture images",
            &inputs(),
            cases,
            seed,
            1 << 18,
            |b| decode(b).map_err(|e| crate::scene::SceneError::syntax(Path::new("t"), None, e)),
            |t| t.data.len(),
        );
        assert!(ok > 0 && err > cases / 10, "{ok} Ok, {err} Err");
    }

    /// Random byte and structure mutations of valid files of every format: each gives an image
    /// or an error, never a panic, a hang or an allocation beyond what the file justifies.
    #[test]
    fn mutated_images_are_read_or_refused() {
        mutations(3000, 1);
    }

    /// The same on 100,000 cases (`cargo test --release --lib -- --ignored mutated_images`).
    #[test]
    #[ignore]
    fn mutated_images_are_read_or_refused_100k() {
        mutations(100_000, 2);
    }

    #[test]
    fn srgb_curve_matches_the_standard() {
        assert_eq!(srgb_to_linear(0.0), 0.0);
        assert!((srgb_to_linear(1.0) - 1.0).abs() < 1e-6);
        assert!((srgb_to_linear(0.5) - 0.214_041_14).abs() < 1e-6);
        assert!((srgb_to_linear(0.04) - 0.04 / 12.92).abs() < 1e-9);
    }
}
