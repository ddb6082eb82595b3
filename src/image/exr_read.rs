//! OpenEXR textures (by the `exr` crate): the first layer's `R`, `G`, `B` channels, or its
//! `Y` channel alone, as linear values; alpha and other channels are dropped.

use std::io::Cursor;
use std::panic::{AssertUnwindSafe, catch_unwind};

use exr::prelude::*;

use super::texels::{Texels, check_size};

/// Pixels per byte an EXR can encode at most: deflate's best ratio over 16-bit samples of
/// one channel (the crate's RLE and other codecs compress less).
const PER_BYTE: u64 = 1032 / 2 + 1;

pub fn decode(bytes: &[u8]) -> std::result::Result<Texels, String> {
    let meta =
        exr::meta::MetaData::read_from_buffered(Cursor::new(bytes), false).map_err(|e| e.to_string())?;
    let header = meta.headers.first().ok_or("no layer")?;
    let size = header.layer_size;
    check_size(size.width() as u64, size.height() as u64, bytes.len(), PER_BYTE)?;
    // The crate is robust against malformed files as far as its own tests go; a panic inside
    // it still becomes this reader's error.
    let image = catch_unwind(AssertUnwindSafe(|| {
        read()
            .no_deep_data()
            .largest_resolution_level()
            .all_channels()
            .first_valid_layer()
            .all_attributes()
            .from_buffered(Cursor::new(bytes))
    }))
    .map_err(|_| "the decoder failed on a malformed file".to_string())?
    .map_err(|e| e.to_string())?;
    let layer = image.layer_data;
    let (w, h) = (layer.size.width(), layer.size.height());
    check_size(w as u64, h as u64, bytes.len(), PER_BYTE)?;
    let channel = |name: &str| layer.channel_data.list.iter().find(|c| c.name.to_string() == name);
    let planes: Vec<_> = match (channel("R"), channel("G"), channel("B"), channel("Y")) {
        (Some(r), Some(g), Some(b), _) => vec![r, g, b],
        (_, _, _, Some(y)) => vec![y],
        _ => return Err("no R, G and B channels and no Y channel".into()),
    };
    let n = w * h;
    let values: Vec<Vec<f32>> =
        planes.iter().map(|c| c.sample_data.values_as_f32().take(n).collect()).collect();
    if values.iter().any(|v| v.len() != n) {
        return Err("a channel has fewer samples than the image has pixels".into());
    }
    let channels = values.len();
    let mut data = Vec::with_capacity(n * channels);
    for i in 0..n {
        data.extend(values.iter().map(|v| v[i]));
    }
    Ok(Texels { width: w as u32, height: h as u32, channels: channels as u32, data, srgb: false })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn encode(w: usize, h: usize, gray: bool) -> Vec<u8> {
        let mut out = std::io::Cursor::new(Vec::new());
        if gray {
            let ch = AnyChannel::new("Y", FlatSamples::F32((0..w * h).map(|i| i as f32).collect()));
            let image = Image::from_channels((w, h), AnyChannels::sort(SmallVec::from_vec(vec![ch])));
            image.write().to_buffered(&mut out).unwrap();
        } else {
            let image = Image::from_channels(
                (w, h),
                SpecificChannels::rgb(|p: Vec2<usize>| (p.x() as f32, p.y() as f32, 0.5f32)),
            );
            image.write().to_buffered(&mut out).unwrap();
        }
        out.into_inner()
    }

    #[test]
    fn rgb_and_y_layers() {
        let t = decode(&encode(3, 2, false)).unwrap();
        assert_eq!((t.width, t.height, t.channels, t.srgb), (3, 2, 3, false));
        assert_eq!(t.data[3 * 5..], [2.0, 1.0, 0.5]);
        let y = decode(&encode(3, 2, true)).unwrap();
        assert_eq!((y.channels, y.data.as_slice()), (1, [0.0, 1.0, 2.0, 3.0, 4.0, 5.0].as_slice()));
        let bytes = encode(3, 2, false);
        assert!(decode(&bytes[..bytes.len() - 8]).is_err());
    }
}
