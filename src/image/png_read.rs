//! PNG textures: 1-, 2-, 4-, 8- and 16-bit gray, gray + alpha, RGB, RGBA and palette images
//! (expanded by the `png` crate), as sRGB-encoded values in [0, 1]; alpha is dropped.

use std::io::Cursor;

use super::texels::{Texels, check_size};

/// Pixels per byte a PNG can encode at most: deflate's best ratio (1032:1) times eight 1-bit
/// pixels per byte.
const PER_BYTE: u64 = 8 * 1032;

pub fn decode(bytes: &[u8]) -> Result<Texels, String> {
    let mut decoder = png::Decoder::new(Cursor::new(bytes));
    decoder.set_transformations(png::Transformations::EXPAND);
    decoder.set_limits(png::Limits { bytes: 1 << 31 });
    let header = decoder.read_header_info().map_err(|e| e.to_string())?;
    check_size(header.width as u64, header.height as u64, bytes.len(), PER_BYTE)?;
    let mut reader = decoder.read_info().map_err(|e| e.to_string())?;
    let size = reader.output_buffer_size().ok_or("the image is too large")?;
    let mut buf = vec![0u8; size];
    let out = reader.next_frame(&mut buf).map_err(|e| e.to_string())?;
    let (width, height) = (out.width, out.height);
    let bytes_per_sample = if out.bit_depth == png::BitDepth::Sixteen { 2 } else { 1 };
    let samples = out.color_type.samples();
    let (keep, channels) = match out.color_type {
        png::ColorType::Grayscale | png::ColorType::GrayscaleAlpha => (1, 1),
        png::ColorType::Rgb | png::ColorType::Rgba => (3, 3),
        png::ColorType::Indexed => return Err("a palette image was not expanded".into()),
    };
    let mut data = Vec::with_capacity(width as usize * height as usize * channels);
    for row in buf[..out.buffer_size()].chunks_exact(out.line_size).take(height as usize) {
        for px in row.chunks_exact(samples * bytes_per_sample).take(width as usize) {
            for c in 0..keep {
                let v = if bytes_per_sample == 2 {
                    u16::from_be_bytes([px[2 * c], px[2 * c + 1]]) as f32 / 65535.0
                } else {
                    px[c] as f32 / 255.0
                };
                data.push(v);
            }
        }
    }
    if data.len() != width as usize * height as usize * channels {
        return Err("the decoded rows are shorter than the header's size".into());
    }
    Ok(Texels { width, height, channels: channels as u32, data, srgb: true })
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    /// A PNG of `data` in the given colour type and depth (palette: `palette` RGB entries).
    pub(crate) fn encode(
        w: u32,
        h: u32,
        color: png::ColorType,
        depth: png::BitDepth,
        palette: Option<Vec<u8>>,
        data: &[u8],
    ) -> Vec<u8> {
        let mut out = Vec::new();
        {
            let mut e = png::Encoder::new(&mut out, w, h);
            e.set_color(color);
            e.set_depth(depth);
            if let Some(p) = palette {
                e.set_palette(p);
            }
            let mut writer = e.write_header().unwrap();
            writer.write_image_data(data).unwrap();
        }
        out
    }

    #[test]
    fn every_colour_type_and_depth() {
        use png::{BitDepth as D, ColorType as C};
        let t = decode(&encode(2, 1, C::Rgb, D::Eight, None, &[255, 0, 51, 0, 255, 102])).unwrap();
        assert_eq!((t.width, t.height, t.channels, t.srgb), (2, 1, 3, true));
        assert_eq!(t.data, [1.0, 0.0, 0.2, 0.0, 1.0, 0.4]);
        let t = decode(&encode(1, 2, C::Rgba, D::Eight, None, &[255, 0, 0, 7, 0, 0, 255, 9])).unwrap();
        assert_eq!((t.channels, t.data.as_slice()), (3, [1.0, 0.0, 0.0, 0.0, 0.0, 1.0].as_slice()));
        let t = decode(&encode(2, 1, C::Grayscale, D::Sixteen, None, &[0xFF, 0xFF, 0x80, 0x00])).unwrap();
        assert_eq!((t.channels, t.data[0]), (1, 1.0));
        assert!((t.data[1] - 32768.0 / 65535.0).abs() < 1e-7);
        let t = decode(&encode(2, 1, C::GrayscaleAlpha, D::Eight, None, &[51, 1, 102, 2])).unwrap();
        assert_eq!((t.channels, t.data.as_slice()), (1, [0.2, 0.4].as_slice()));
        // 1-bit gray: 0b1010_0000 → 1, 0, 1.
        let t = decode(&encode(3, 1, C::Grayscale, D::One, None, &[0b1010_0000])).unwrap();
        assert_eq!(t.data, [1.0, 0.0, 1.0]);
        // A 4-bit palette of two entries.
        let t =
            decode(&encode(2, 1, C::Indexed, D::Four, Some(vec![255, 0, 0, 0, 0, 255]), &[0x10])).unwrap();
        assert_eq!((t.channels, t.data.as_slice()), (3, [0.0, 0.0, 1.0, 1.0, 0.0, 0.0].as_slice()));
    }

    #[test]
    fn broken_files_are_errors() {
        let good = encode(2, 2, png::ColorType::Rgb, png::BitDepth::Eight, None, &[9; 12]);
        assert!(decode(&good[..good.len() - 20]).is_err());
        assert!(decode(&good[..30]).is_err());
        // An absurd width in the header (its CRC fixed so that only the size is wrong).
        let mut huge = good.clone();
        huge[16..20].copy_from_slice(&0x7FFF_FFFFu32.to_be_bytes());
        let crc = crc32(&huge[12..29]);
        huge[29..33].copy_from_slice(&crc.to_be_bytes());
        let e = decode(&huge).unwrap_err();
        assert!(e.contains("pixels") || e.contains("width"), "{e}");
    }

    fn crc32(data: &[u8]) -> u32 {
        let mut c = !0u32;
        for &b in data {
            c ^= b as u32;
            for _ in 0..8 {
                c = if c & 1 != 0 { 0xEDB8_8320 ^ (c >> 1) } else { c >> 1 };
            }
        }
        !c
    }
}
