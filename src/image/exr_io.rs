//! EXR output and input: linear RGB float32, with pir's render description stored as text
//! attributes in the header (`pir.method`, `pir.seed`, …).

use anyhow::{Context, Result, bail};
use exr::meta::attribute::{AttributeValue, Text};
use exr::prelude::*;
use glam::Vec3;
use std::path::Path;

use super::{RgbImage, write_atomically};

/// Writes `img` to `path` atomically, with `attributes` as text attributes of the layer.
pub fn write_exr(path: &Path, img: &RgbImage, attributes: &[(String, String)]) -> Result<()> {
    write_exr_with_channels(path, img, attributes, Vec::new())
}

/// Writes `img` (channels R, G, B as float32) and `extra` channels of 32-bit unsigned integers
/// (one value per pixel, row-major) to `path` atomically, with `attributes` as text attributes.
pub fn write_exr_with_channels(
    path: &Path,
    img: &RgbImage,
    attributes: &[(String, String)],
    extra: Vec<(String, Vec<u32>)>,
) -> Result<()> {
    let mut attrs = LayerAttributes::named("");
    attrs.software_name = Some(Text::from(concat!("pir ", env!("CARGO_PKG_VERSION"))));
    for (k, v) in attributes {
        let key =
            Text::new_or_none(k).with_context(|| format!("attribute name {k:?} is not valid EXR text"))?;
        let val =
            Text::new_or_none(v).with_context(|| format!("attribute {k} = {v:?} is not valid EXR text"))?;
        attrs.other.insert(key, AttributeValue::Text(val));
    }
    let (w, h) = (img.width, img.height);
    let mut list: SmallVec<[AnyChannel<FlatSamples>; 4]> = SmallVec::new();
    for (name, c) in [("R", 0), ("G", 1), ("B", 2)] {
        list.push(AnyChannel::new(name, FlatSamples::F32(img.pixels.iter().map(|p| p[c]).collect())));
    }
    for (name, values) in extra {
        if values.len() != w * h {
            bail!("channel {name}: {} values for {w}×{h} pixels", values.len());
        }
        let name = Text::new_or_none(&name)
            .with_context(|| format!("channel name {name:?} is not valid EXR text"))?;
        list.push(AnyChannel::new(name, FlatSamples::U32(values)));
    }
    let layer = Layer::new((w, h), attrs, Encoding::SMALL_LOSSLESS, AnyChannels::sort(list));
    let image = Image::from_layer(layer);
    write_atomically(path, |out| {
        image.write().non_parallel().to_buffered(out).map_err(|e| anyhow::anyhow!("EXR encoding: {e}"))
    })
}

/// Reads the first layer of an EXR file written by [`write_exr_with_channels`]: its RGB image,
/// text attributes and 32-bit unsigned integer channels by name.
pub fn read_exr_with_channels(path: &Path) -> Result<ReadExr> {
    if !path.exists() {
        bail!("{}: no such file", path.display());
    }
    let image = read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .first_valid_layer()
        .all_attributes()
        .from_file(path)
        .map_err(|e| anyhow::anyhow!("{}: not a readable EXR image: {e}", path.display()))?;
    let layer = image.layer_data;
    let (w, h) = (layer.size.width(), layer.size.height());
    let mut img = RgbImage::new(w, h);
    let mut found = 0;
    let mut channels = Vec::new();
    for ch in &layer.channel_data.list {
        let name = ch.name.to_string();
        let c = match name.as_str() {
            "R" => 0,
            "G" => 1,
            "B" => 2,
            _ => {
                if let FlatSamples::U32(v) = &ch.sample_data {
                    channels.push((name, v.clone()));
                }
                continue;
            }
        };
        found += 1;
        for (p, v) in img.pixels.iter_mut().zip(ch.sample_data.values_as_f32()) {
            p[c] = v;
        }
    }
    if found != 3 {
        bail!("{}: no R, G and B channels", path.display());
    }
    let attributes = text_attributes(&layer.attributes);
    Ok(ReadExr { image: img, attributes, channels })
}

/// A layer's text attributes, sorted by name.
fn text_attributes(attributes: &LayerAttributes) -> Vec<(String, String)> {
    let mut v: Vec<(String, String)> = attributes
        .other
        .iter()
        .filter_map(|(k, v)| match v {
            AttributeValue::Text(t) => Some((k.to_string(), t.to_string())),
            _ => None,
        })
        .collect();
    v.sort();
    v
}

/// What [`read_exr_with_channels`] returns.
pub struct ReadExr {
    pub image: RgbImage,
    pub attributes: Vec<(String, String)>,
    pub channels: Vec<(String, Vec<u32>)>,
}

/// Reads the first RGB(A) layer of an EXR file and its text attributes.
pub fn read_exr(path: &Path) -> Result<(RgbImage, Vec<(String, String)>)> {
    if !path.exists() {
        bail!("{}: no such file", path.display());
    }
    let image = read_first_rgba_layer_from_file(
        path,
        |res, _| RgbImage::new(res.width(), res.height()),
        |img: &mut RgbImage, pos, (r, g, b, _a): (f32, f32, f32, f32)| {
            let w = img.width;
            img.pixels[pos.y() * w + pos.x()] = Vec3::new(r, g, b);
        },
    )
    .map_err(|e| anyhow::anyhow!("{}: not a readable RGB EXR image: {e}", path.display()))?;
    let attributes = text_attributes(&image.layer_data.attributes);
    Ok((image.layer_data.channel_data.pixels, attributes))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn roundtrip_keeps_pixels_and_attributes() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("a.exr");
        let mut img = RgbImage::new(5, 3);
        for (i, p) in img.pixels.iter_mut().enumerate() {
            *p = Vec3::new(i as f32, 0.5 * i as f32, 1e-3 * i as f32);
        }
        let attrs =
            vec![("pir.method".to_string(), "pt".to_string()), ("pir.seed".to_string(), "7".to_string())];
        write_exr(&path, &img, &attrs).unwrap();
        let (back, got) = read_exr(&path).unwrap();
        assert_eq!(back, img);
        for a in &attrs {
            assert!(got.contains(a), "{a:?} missing from {got:?}");
        }
    }

    #[test]
    fn extra_integer_channels_roundtrip_bit_exactly() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("s.exr");
        let mut img = RgbImage::new(3, 2);
        img.pixels[4] = Vec3::new(1.0, 2.0, 3.0);
        let bits: Vec<u32> = (0..6).map(|i| 0xDEAD_0000 + i).collect();
        write_exr_with_channels(
            &path,
            &img,
            &[("k".into(), "v".into())],
            vec![("pir.x".into(), bits.clone())],
        )
        .unwrap();
        let r = read_exr_with_channels(&path).unwrap();
        assert_eq!(r.image, img);
        assert_eq!(r.channels, vec![("pir.x".to_string(), bits)]);
        assert!(r.attributes.contains(&("k".to_string(), "v".to_string())));
        // The plain reader still sees an RGB image.
        assert_eq!(read_exr(&path).unwrap().0, img);
    }

    #[test]
    fn missing_or_broken_files_are_errors_naming_the_file() {
        let dir = tempfile::tempdir().unwrap();
        let missing = dir.path().join("none.exr");
        let e = read_exr(&missing).unwrap_err().to_string();
        assert!(e.contains("none.exr"), "{e}");
        let junk = dir.path().join("junk.exr");
        std::fs::write(&junk, b"not an exr").unwrap();
        let e = read_exr(&junk).unwrap_err().to_string();
        assert!(e.contains("junk.exr"), "{e}");
    }
}
