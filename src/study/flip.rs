//! HDR-FLIP, the perceptual error metric of the studies, built on NVIDIA's LDR-FLIP.
//!
//! The `nv-flip` crate wraps NVIDIA's reference C++ implementation of LDR-FLIP (Andersson et
//! al. 2020), which compares two 8-bit sRGB images. HDR-FLIP (Andersson et al. 2021) is
//! computed here exactly as the paper and NVIDIA's tool define it, on top of that:
//!
//! 1. the exposure range [c_start, c_stop] comes from the *reference*: with the ACES filmic
//!    tone curve T of FLIP (Narkowicz's fit, pre-scaled by 0.6) and x_max the input for which
//!    T(x_max) = 0.85, c_start = log2(x_max / Y_max) and c_stop = log2(x_max / Y_median), Y
//!    being the luminance (Rec. 709 weights);
//! 2. n = max(2, ⌈c_stop − c_start⌉) exposures evenly spaced over that range;
//! 3. at each exposure c both images are scaled by 2^c, tone-mapped with T, clamped to [0, 1]
//!    and LDR-FLIP'd (default 67 pixels per degree: a 0.7 m wide 4K monitor at 0.7 m);
//! 4. the HDR-FLIP map is the per-pixel maximum over the exposures, and the reported value is
//!    its mean over all pixels (0 = identical, 1 = worst).
//!
//! The one departure from NVIDIA's tool: `nv-flip` takes 8-bit sRGB input, so the tone-mapped
//! images are quantised to 8 bits (sRGB-encoded, which FLIP decodes again) before comparison.
//! This floors differences below about one 8-bit step, well under the visibility threshold
//! FLIP models.

use crate::image::RgbImage;
use glam::Vec3;

/// The coefficients of FLIP's ACES tone curve, T(x) = (a x² + b x + c) / (d x² + e x + f).
const ACES: [f32; 6] = [0.6 * 0.6 * 2.51, 0.6 * 0.03, 0.0, 0.6 * 0.6 * 2.43, 0.6 * 0.59, 0.14];

fn tone(x: f32) -> f32 {
    let [a, b, c, d, e, f] = ACES;
    let x = x.max(0.0);
    ((x * (a * x + b) + c) / (x * (d * x + e) + f)).clamp(0.0, 1.0)
}

fn luminance(p: Vec3) -> f32 {
    0.2126 * p.x + 0.7152 * p.y + 0.0722 * p.z
}

fn srgb_u8(v: f32) -> u8 {
    let v = v.clamp(0.0, 1.0);
    let e = if v <= 0.003_130_8 { 12.92 * v } else { 1.055 * v.powf(1.0 / 2.4) - 0.055 };
    (e * 255.0 + 0.5) as u8
}

/// The exposures (in stops) at which HDR-FLIP compares, from the reference's luminances.
pub fn exposures(reference: &RgbImage) -> Vec<f32> {
    // x_max: T(x) = 0.85 solved for x (a quadratic).
    let [a, b, c, d, e, f] = ACES;
    let t = 0.85f32;
    let (qa, qb, qc) = (a - t * d, b - t * e, c - t * f);
    let x_max = ((-qb + (qb * qb - 4.0 * qa * qc).sqrt()) / (2.0 * qa)).max(0.0);
    let mut lum: Vec<f32> =
        reference.pixels.iter().map(|p| luminance(*p).max(0.0)).filter(|y| y.is_finite()).collect();
    if lum.is_empty() {
        return vec![0.0, 0.0];
    }
    lum.sort_by(f32::total_cmp);
    let y_max = lum[lum.len() - 1];
    let y_median = lum[lum.len() / 2];
    if y_max <= 0.0 {
        return vec![0.0, 0.0];
    }
    // A black median (e.g. a mostly black background) would make c_stop infinite: use the
    // smallest positive luminance instead.
    let y_median =
        if y_median > 0.0 { y_median } else { lum.iter().copied().find(|y| *y > 0.0).unwrap_or(y_max) };
    let start = (x_max / y_max).log2();
    let stop = (x_max / y_median).log2();
    let n = ((stop - start).ceil() as usize).max(2);
    let step = (stop - start) / (n - 1) as f32;
    (0..n).map(|i| start + i as f32 * step).collect()
}

fn tone_mapped(img: &RgbImage, exposure: f32) -> nv_flip::FlipImageRgb8 {
    let s = exposure.exp2();
    let data: Vec<u8> = img
        .pixels
        .iter()
        .flat_map(|p| {
            let v = *p * s;
            [srgb_u8(tone(v.x)), srgb_u8(tone(v.y)), srgb_u8(tone(v.z))]
        })
        .collect();
    nv_flip::FlipImageRgb8::with_data(img.width as u32, img.height as u32, &data)
}

/// The per-pixel HDR-FLIP error map (each in [0, 1]) of `img` against `reference`, at the
/// given exposures (see [`exposures`]). Panics if the sizes differ.
pub fn hdr_flip_map(img: &RgbImage, reference: &RgbImage, exposures: &[f32]) -> Vec<f32> {
    assert_eq!((img.width, img.height), (reference.width, reference.height), "HDR-FLIP: size mismatch");
    let mut map = vec![0.0f32; img.pixels.len()];
    for &c in exposures {
        let e =
            nv_flip::flip(tone_mapped(reference, c), tone_mapped(img, c), nv_flip::DEFAULT_PIXELS_PER_DEGREE);
        for (m, v) in map.iter_mut().zip(e.to_vec()) {
            *m = m.max(v);
        }
    }
    map
}

/// Mean HDR-FLIP of `img` against `reference` (0 = identical).
pub fn hdr_flip(img: &RgbImage, reference: &RgbImage, exposures: &[f32]) -> f64 {
    let map = hdr_flip_map(img, reference, exposures);
    map.iter().map(|v| *v as f64).sum::<f64>() / map.len().max(1) as f64
}

#[cfg(test)]
mod tests {
    use super::*;

    fn gradient() -> RgbImage {
        let mut img = RgbImage::new(32, 32);
        for (i, p) in img.pixels.iter_mut().enumerate() {
            *p = Vec3::new((i % 32) as f32 / 8.0, (i / 32) as f32 / 16.0, 0.3);
        }
        img
    }

    #[test]
    fn tone_curve_maps_zero_to_zero_and_x_max_to_0_85() {
        assert_eq!(tone(0.0), 0.0);
        assert!(tone(1e6) <= 1.0);
        let img = gradient();
        let ex = exposures(&img);
        assert!(ex.len() >= 2 && ex.windows(2).all(|w| w[0] <= w[1]));
        // The first exposure maps the brightest pixel's luminance to 0.85.
        let y_max = img.pixels.iter().map(|p| luminance(*p)).fold(0.0f32, f32::max);
        assert!((tone(y_max * ex[0].exp2()) - 0.85).abs() < 1e-4);
    }

    #[test]
    fn identical_images_score_zero_and_noise_raises_the_score() {
        let r = gradient();
        let ex = exposures(&r);
        assert_eq!(hdr_flip(&r, &r, &ex), 0.0);
        let noisy = |amp: f32| {
            let mut n = r.clone();
            for (i, p) in n.pixels.iter_mut().enumerate() {
                let h = ((i as u32).wrapping_mul(2_654_435_761) >> 16) as f32 / 65_536.0 - 0.5;
                *p = (*p * (1.0 + amp * h)).max(Vec3::ZERO);
            }
            n
        };
        let small = hdr_flip(&noisy(0.1), &r, &ex);
        let large = hdr_flip(&noisy(1.0), &r, &ex);
        assert!(small > 0.0 && large > small, "{small} {large}");
    }
}
