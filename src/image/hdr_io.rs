//! Radiance RGBE (`.hdr`) images in: the header, the resolution line (`-Y H +X W`, rows from
//! the top), and flat or run-length-encoded scanlines, decoded as Mitsuba 3 decodes them
//! (Bruce Walter's `rgbe.c`: a channel is its byte × 2^(e − 136), black when e is 0).

use std::path::Path;

use anyhow::Result;
use glam::Vec3;

use super::RgbImage;

/// The most pixels an `.hdr` file may declare (a 32k × 16k map).
const MAX_PIXELS: usize = 1 << 29;

/// Reads a Radiance `.hdr` image; the error names the file and the problem.
pub fn read_hdr(path: &Path) -> Result<RgbImage> {
    let bytes = std::fs::read(path).map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?;
    decode(&bytes).map_err(|problem| {
        anyhow::anyhow!("{}: not a readable Radiance HDR image: {problem}", path.display())
    })
}

fn decode(bytes: &[u8]) -> Result<RgbImage, String> {
    let mut pos = 0;
    let mut line = || -> Result<&[u8], String> {
        let rest = &bytes[pos..];
        let end = rest.iter().position(|&b| b == b'\n').ok_or("the header ends early")?;
        pos += end + 1;
        Ok(&rest[..end])
    };
    let first = line()?;
    if !first.starts_with(b"#?") {
        return Err("no #? signature".into());
    }
    loop {
        let l = line()?;
        if l.is_empty() {
            break;
        }
        if let Some(format) = l.strip_prefix(b"FORMAT=")
            && format != b"32-bit_rle_rgbe"
        {
            return Err(format!("format {}: only 32-bit_rle_rgbe is read", String::from_utf8_lossy(format)));
        }
    }
    let res = String::from_utf8_lossy(line()?).into_owned();
    let (height, width) = match res.split_whitespace().collect::<Vec<_>>().as_slice() {
        ["-Y", h, "+X", w] => (
            h.parse::<usize>().map_err(|_| format!("resolution \"{res}\""))?,
            w.parse::<usize>().map_err(|_| format!("resolution \"{res}\""))?,
        ),
        _ => return Err(format!("resolution \"{res}\": only -Y H +X W (rows from the top) is read")),
    };
    if width == 0 || height == 0 || width.saturating_mul(height) > MAX_PIXELS {
        return Err(format!("resolution {width}×{height}"));
    }
    let data = &bytes[pos..];
    // A run encodes at most 127 pixels of a channel in two bytes: a file declaring more pixels
    // than its bytes can hold is refused before anything is allocated for them.
    if width * height > data.len().saturating_mul(64) {
        return Err(format!("{width}×{height} pixels in {} bytes", data.len()));
    }
    let mut at = 0usize;
    let mut byte = || -> Result<u8, String> {
        let b = *data.get(at).ok_or("the pixels end early")?;
        at += 1;
        Ok(b)
    };
    let mut img = RgbImage::new(width, height);
    let mut scan = vec![[0u8; 4]; width];
    for y in 0..height {
        let head = [byte()?, byte()?, byte()?, byte()?];
        let rle = (8..0x8000).contains(&width) && head[0] == 2 && head[1] == 2 && head[2] & 0x80 == 0;
        if rle {
            if ((head[2] as usize) << 8 | head[3] as usize) != width {
                return Err(format!("scanline {y}: its width does not match"));
            }
            for c in 0..4 {
                let mut x = 0;
                while x < width {
                    let count = byte()? as usize;
                    if count > 128 {
                        let n = count - 128;
                        let v = byte()?;
                        if x + n > width {
                            return Err(format!("scanline {y}: a run overflows it"));
                        }
                        scan[x..x + n].iter_mut().for_each(|p| p[c] = v);
                        x += n;
                    } else {
                        if count == 0 || x + count > width {
                            return Err(format!("scanline {y}: a bad run"));
                        }
                        for p in &mut scan[x..x + count] {
                            p[c] = byte()?;
                        }
                        x += count;
                    }
                }
            }
        } else {
            // Flat pixels (the old run-length encoding is not read).
            scan[0] = head;
            for p in scan.iter_mut().skip(1) {
                *p = [byte()?, byte()?, byte()?, byte()?];
            }
            if scan.iter().any(|p| p[0] == 1 && p[1] == 1 && p[2] == 1) {
                return Err("old-style run-length encoding is not read".into());
            }
        }
        for (out, p) in img.pixels[y * width..(y + 1) * width].iter_mut().zip(&scan) {
            *out = if p[3] == 0 {
                Vec3::ZERO
            } else {
                let f = 2f32.powi(p[3] as i32 - 136);
                Vec3::new(p[0] as f32, p[1] as f32, p[2] as f32) * f
            };
        }
    }
    Ok(img)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Mitsuba 3's `.hdr` of `tests/data/emitters/sky.exr` reads back as Mitsuba reads it
    /// (within RGBE's 8 bits of mantissa of the EXR's values; two values Mitsuba printed).
    #[test]
    fn mitsubas_hdr_reads_back() {
        let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/emitters");
        let hdr = read_hdr(&dir.join("sky.hdr")).unwrap();
        let (exr, _) = crate::image::read_exr(&dir.join("sky.exr")).unwrap();
        assert_eq!((hdr.width, hdr.height), (exr.width, exr.height));
        for (a, b) in hdr.pixels.iter().zip(&exr.pixels) {
            assert!((*a - *b).abs().max_element() <= b.max_element() / 128.0, "{a} {b}");
        }
        assert_eq!(hdr.pixels[0], Vec3::new(0.304_687_5, 0.507_812_5, 1.0));
        assert_eq!(hdr.pixels[7 * 48 + 10], Vec3::new(40.0, 36.0, 30.0));
    }

    #[test]
    fn broken_files_are_errors() {
        for bytes in
            [&b"P6\n"[..], b"#?RADIANCE\n\n-Y 2 +X 2\n\x01\x02", b"#?RADIANCE\n\n+X 2 -Y 2\n", b"#?RGBE\n"]
        {
            assert!(decode(bytes).is_err(), "{bytes:?}");
        }
        let flat = b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 1 +X 2\n\x80\x40\x20\x81\x00\x00\x00\x00";
        let img = decode(flat).unwrap();
        assert_eq!(img.pixels, vec![Vec3::new(1.0, 0.5, 0.25), Vec3::ZERO]);
    }
}
