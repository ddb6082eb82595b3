//! JPEG textures (baseline and progressive, by `zune-jpeg`), as sRGB-encoded RGB values in
//! [0, 1]; gray JPEGs come back as RGB of equal channels, which evaluates as Mitsuba's
//! one-channel image does.

use std::io::Cursor;

use zune_jpeg::JpegDecoder;
use zune_jpeg::zune_core::colorspace::ColorSpace;
use zune_jpeg::zune_core::options::DecoderOptions;

use super::texels::{MAX_PIXELS, Texels, check_size};

/// Pixels per byte a JPEG can encode at most: a progressive scan's end-of-band runs skip up
/// to 32767 empty blocks in a few bits, so the bound is loose; [`MAX_PIXELS`] is the cap that
/// matters.
const PER_BYTE: u64 = 1 << 16;

pub fn decode(bytes: &[u8]) -> Result<Texels, String> {
    let side = (MAX_PIXELS as usize).min(u16::MAX as usize);
    let options = DecoderOptions::default()
        .set_max_width(side)
        .set_max_height(side)
        .jpeg_set_out_colorspace(ColorSpace::RGB);
    let mut decoder = JpegDecoder::new_with_options(Cursor::new(bytes), options);
    decoder.decode_headers().map_err(|e| e.to_string())?;
    let info = decoder.info().ok_or("no image header")?;
    let (width, height) = (info.width as u32, info.height as u32);
    check_size(width as u64, height as u64, bytes.len(), PER_BYTE)?;
    let pixels = decoder.decode().map_err(|e| e.to_string())?;
    let channels = decoder.output_colorspace().map_or(3, |c| c.num_components());
    if channels != 3 || pixels.len() != width as usize * height as usize * 3 {
        return Err(format!("decoded {} values for {width} × {height} RGB pixels", pixels.len()));
    }
    let data = pixels.iter().map(|&v| v as f32 / 255.0).collect();
    Ok(Texels { width, height, channels: 3, data, srgb: true })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn fixture(name: &str) -> Vec<u8> {
        std::fs::read(std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/textures").join(name))
            .unwrap()
    }

    /// The fixtures were written and read back by Mitsuba 3.9.1 (libjpeg): its first pixels
    /// of the RGB one are (1, 0, 128), (32, 0, 129), (65, 0, 128), (96, 0, 130); decoders may
    /// differ by a unit or two in the last bit of the inverse DCT.
    #[test]
    fn rgb_and_gray_jpegs_decode_as_mitsuba() {
        let t = decode(&fixture("rgb-8x4.jpg")).unwrap();
        assert_eq!((t.width, t.height, t.channels, t.srgb), (8, 4, 3, true));
        let want = [1.0, 0.0, 128.0, 32.0, 0.0, 129.0, 65.0, 0.0, 128.0, 96.0, 0.0, 130.0];
        for (got, want) in t.data.iter().zip(want) {
            assert!((got * 255.0 - want).abs() <= 2.0, "{:?}", &t.data[..12]);
        }
        let g = decode(&fixture("gray-8x4.jpg")).unwrap();
        assert!(g.data.iter().all(|&v| (v * 255.0 - 100.0).abs() <= 1.0), "{:?}", &g.data[..6]);
        let bytes = fixture("rgb-8x4.jpg");
        assert!(decode(&bytes[..20]).is_err());
    }
}
