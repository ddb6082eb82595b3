//! Radiance HDR (RGBE) textures: the `#?RADIANCE` / `#?RGBE` header, the `32-bit_rle_rgbe`
//! format, a `-Y height +X width` resolution line, and scanlines flat, old-style run-length
//! encoded or new-style (per component) run-length encoded; values are linear, m · 2^(e − 136)
//! as Mitsuba reads them (Walter's `rgbe.c`: no half-unit offset; e = 0 is black).

use super::texels::{Texels, check_size};

/// Pixels per byte a Radiance file can encode at most: a new-style run of 127 pixels of one
/// component takes two bytes, four components per pixel; an old-style repeat run can
/// repeat more, bounded by the shift of consecutive runs (refused beyond 3 here).
const PER_BYTE: u64 = 1 << 12;

pub fn decode(bytes: &[u8]) -> Result<Texels, String> {
    let mut at = 0usize;
    let mut line = || -> Result<&[u8], String> {
        let rest = &bytes[at..];
        let end = rest.iter().position(|&b| b == b'\n').ok_or("the header ends early")?;
        at += end + 1;
        Ok(&rest[..end])
    };
    let magic = line()?;
    if !(magic.starts_with(b"#?RADIANCE") || magic.starts_with(b"#?RGBE")) {
        return Err("no #?RADIANCE or #?RGBE signature".into());
    }
    loop {
        let l = line()?;
        if l.is_empty() {
            break;
        }
        if let Some(f) = l.strip_prefix(b"FORMAT=")
            && f != b"32-bit_rle_rgbe"
        {
            return Err(format!(
                "format {}: pir reads 32-bit_rle_rgbe (RGB), not XYZ",
                String::from_utf8_lossy(f)
            ));
        }
    }
    let res = String::from_utf8_lossy(line()?).into_owned();
    let parts: Vec<&str> = res.split_whitespace().collect();
    let (height, width) = match parts.as_slice() {
        ["-Y", h, "+X", w] => (
            h.parse::<u32>().map_err(|_| format!("resolution line {res:?}: bad height"))?,
            w.parse::<u32>().map_err(|_| format!("resolution line {res:?}: bad width"))?,
        ),
        _ => {
            return Err(format!("resolution line {res:?}: pir reads \"-Y height +X width\" (top to bottom)"));
        }
    };
    check_size(width as u64, height as u64, bytes.len(), PER_BYTE)?;
    let (w, h) = (width as usize, height as usize);
    let mut rgbe = vec![[0u8; 4]; w * h];
    let mut data = &bytes[at..];
    let short = || "the pixel data end early".to_string();
    for y in 0..h {
        let row = &mut rgbe[y * w..(y + 1) * w];
        let new_rle = (8..=0x7FFF).contains(&w)
            && data.len() >= 4
            && data[0] == 2
            && data[1] == 2
            && data[2] & 0x80 == 0
            && ((data[2] as usize) << 8 | data[3] as usize) == w;
        if new_rle {
            data = &data[4..];
            for c in 0..4 {
                let mut x = 0;
                while x < w {
                    let (&count, rest) = data.split_first().ok_or_else(short)?;
                    data = rest;
                    if count > 128 {
                        let n = (count - 128) as usize;
                        let (&v, rest) = data.split_first().ok_or_else(short)?;
                        data = rest;
                        if x + n > w {
                            return Err(format!("row {y}: a run crosses the end of the row"));
                        }
                        row[x..x + n].iter_mut().for_each(|p| p[c] = v);
                        x += n;
                    } else {
                        let n = count as usize;
                        if n == 0 || x + n > w {
                            return Err(format!("row {y}: a literal run of {n} bytes at pixel {x}"));
                        }
                        let lit = data.get(..n).ok_or_else(short)?;
                        row[x..x + n].iter_mut().zip(lit).for_each(|(p, &v)| p[c] = v);
                        data = &data[n..];
                        x += n;
                    }
                }
            }
        } else {
            // Flat pixels, with old-style runs (1, 1, 1, n): the previous pixel n << shift times.
            let (mut x, mut shift) = (0usize, 0u32);
            while x < w {
                let p: [u8; 4] = data.get(..4).ok_or_else(short)?.try_into().map_err(|_| short())?;
                data = &data[4..];
                if p[0] == 1 && p[1] == 1 && p[2] == 1 {
                    if x == 0 || shift > 16 {
                        return Err(format!("row {y}: a repeat run without a previous pixel or too long"));
                    }
                    let n = (p[3] as usize) << shift;
                    if x + n > w {
                        return Err(format!("row {y}: a repeat run crosses the end of the row"));
                    }
                    let prev = row[x - 1];
                    row[x..x + n].iter_mut().for_each(|q| *q = prev);
                    x += n;
                    shift += 8;
                } else {
                    row[x] = p;
                    x += 1;
                    shift = 0;
                }
            }
        }
    }
    let mut out = Vec::with_capacity(w * h * 3);
    for p in rgbe {
        if p[3] == 0 {
            out.extend([0.0; 3]);
        } else {
            let f = 2f32.powi(p[3] as i32 - 136);
            out.extend([p[0] as f32 * f, p[1] as f32 * f, p[2] as f32 * f]);
        }
    }
    Ok(Texels { width, height, channels: 3, data: out, srgb: false })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Written by Mitsuba 3.9.1 (run-length encoded): pixel (x, y) = (x / 2, 2y + ¼, 1).
    #[test]
    fn rle_file_as_mitsuba_wrote_it() {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/textures/ramp-9x3.hdr");
        let t = decode(&std::fs::read(path).unwrap()).unwrap();
        assert_eq!((t.width, t.height, t.channels, t.srgb), (9, 3, 3, false));
        for y in 0..3 {
            for x in 0..9 {
                let i = 3 * (y * 9 + x);
                assert_eq!(t.data[i..i + 3], [x as f32 * 0.5, y as f32 * 2.0 + 0.25, 1.0], "({x}, {y})");
            }
        }
    }

    /// A flat file with an old-style repeat run: pixels (128, 64, 0, 129) = (1, 0.5, 0),
    /// repeated 2 more times, then black.
    #[test]
    fn flat_and_old_rle_files() {
        let mut f = b"#?RADIANCE\nEXPOSURE=1\n\n-Y 1 +X 4\n".to_vec();
        f.extend([128, 64, 0, 129, 1, 1, 1, 2, 0, 0, 0, 0]);
        let t = decode(&f).unwrap();
        assert_eq!(t.data, [1.0, 0.5, 0.0, 1.0, 0.5, 0.0, 1.0, 0.5, 0.0, 0.0, 0.0, 0.0]);
        assert!(decode(&f[..f.len() - 1]).unwrap_err().contains("end early"));
        let mut xyz = f.clone();
        xyz.splice(11..11, b"FORMAT=32-bit_rle_xyze\n".iter().copied());
        assert!(decode(&xyz).unwrap_err().contains("xyze"));
        let flipped = String::from_utf8_lossy(&f).replace("-Y 1 +X 4", "+Y 1 +X 4");
        assert!(decode(flipped.as_bytes()).is_err());
        let huge = b"#?RADIANCE\n\n-Y 100000 +X 100000\n";
        assert!(decode(huge).unwrap_err().contains("pixels"));
    }
}
