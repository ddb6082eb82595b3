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
    let layer = Layer::new(
        (w, h),
        attrs,
        Encoding::SMALL_LOSSLESS,
        SpecificChannels::rgb(|pos: Vec2<usize>| {
            let p = img.pixels[pos.y() * w + pos.x()];
            (p.x, p.y, p.z)
        }),
    );
    let image = Image::from_layer(layer);
    write_atomically(path, |out| {
        image.write().non_parallel().to_buffered(out).map_err(|e| anyhow::anyhow!("EXR encoding: {e}"))
    })
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
    let mut attributes: Vec<(String, String)> = image
        .layer_data
        .attributes
        .other
        .iter()
        .filter_map(|(k, v)| match v {
            AttributeValue::Text(t) => Some((k.to_string(), t.to_string())),
            _ => None,
        })
        .collect();
    attributes.sort();
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
