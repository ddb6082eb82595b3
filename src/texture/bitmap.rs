//! Mitsuba 3's `bitmap` texture: an image looked up at (u, v) = to_uv(uv) scaled by its size,
//! u along the width from the first column, v along the height from the first (top) row.
//!
//! - `nearest`: the texel floor(u · width), floor(v · height);
//! - `bilinear` (the default): texel centres at half-integers, (u · width − ½, v · height − ½)
//!   interpolated between its four neighbours;
//! - wrap modes for texels outside the image: `repeat` (the default) tiles it, `mirror`
//!   reflects it at its edges (…, 1, 0 | 0, 1, …, n − 1 | n − 1, …), `clamp` repeats the edge;
//! - values are linear (sRGB files converted unless `raw`); a one-channel image gives equal
//!   channels; [`Bitmap::eval_1`] gives a one-channel image's value, an RGB one's luminance.
//!
//! Mitsuba stores 8- and 16-bit images in half precision by default (`format` auto); pir keeps
//! single precision (differences below 0.05 %). An image narrower or shorter than 2 pixels is
//! widened to 2 by repeating it (Mitsuba resamples it with a tent filter, which for one pixel
//! repeats it too).

use std::sync::Arc;

use glam::{Affine2, Vec2, Vec3};

use crate::image::Texels;

/// How values between texel centres are found.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Filter {
    Bilinear,
    Nearest,
}

/// What lies outside the image.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Wrap {
    Repeat,
    Mirror,
    Clamp,
}

/// A bitmap texture, ready to evaluate: its image (shared by every texture of the same file)
/// and how it is looked up.
#[derive(Clone, Debug, PartialEq)]
pub struct Bitmap {
    image: Arc<Image>,
    filter: Filter,
    wrap: Wrap,
    to_uv: Affine2,
}

/// A texture's image: linear values (unless read `raw`), at least 2 × 2 texels.
#[derive(Clone, Debug, PartialEq)]
pub struct Image {
    width: u32,
    height: u32,
    /// 1 or 3.
    channels: u32,
    data: Vec<f32>,
    mean: Vec3,
    range: (f32, f32),
    /// Read without the sRGB-to-linear conversion.
    raw: bool,
}

impl Image {
    /// The image of `texels`, linearized here unless `raw`.
    pub fn new(mut texels: Texels, raw: bool) -> Image {
        if !raw {
            texels.linearize();
        }
        let Texels { mut width, mut height, channels, mut data, .. } = texels;
        let c = channels as usize;
        if width == 1 {
            data = data.chunks_exact(c).flat_map(|p| [p, p]).flatten().copied().collect();
            width = 2;
        }
        if height == 1 {
            data = data.repeat(2);
            height = 2;
        }
        let n = (width as usize * height as usize).max(1);
        let mut sum = [0f64; 3];
        let mut range = (f32::INFINITY, f32::NEG_INFINITY);
        for p in data.chunks_exact(c) {
            for k in 0..3 {
                sum[k] += p[k.min(c - 1)] as f64;
            }
            for &v in p {
                range = (range.0.min(v), range.1.max(v));
            }
        }
        let mean = Vec3::new(sum[0] as f32, sum[1] as f32, sum[2] as f32) / n as f32;
        Image { width, height, channels, data, mean, range, raw }
    }
}

impl Bitmap {
    pub fn new(image: Arc<Image>, filter: Filter, wrap: Wrap, to_uv: Affine2) -> Bitmap {
        Bitmap { image, filter, wrap, to_uv }
    }

    pub fn size(&self) -> (u32, u32) {
        (self.image.width, self.image.height)
    }

    /// 1 or 3.
    pub fn channels(&self) -> u32 {
        self.image.channels
    }

    /// Whether its values are the file's, not converted from sRGB (Mitsuba's `raw`).
    pub fn is_raw(&self) -> bool {
        self.image.raw
    }

    /// The mean texel.
    pub fn mean(&self) -> Vec3 {
        self.image.mean
    }

    /// The smallest and largest texel value of any channel.
    pub fn range(&self) -> (f32, f32) {
        self.image.range
    }

    /// The colour at `uv`.
    #[inline]
    pub fn eval(&self, uv: Vec2) -> Vec3 {
        self.lookup(uv, |b, i| b.texel(i))
    }

    /// The number at `uv`: a one-channel image's value, an RGB image's luminance (of the
    /// interpolated colour, as Mitsuba).
    pub fn eval_1(&self, uv: Vec2) -> f32 {
        let c = self.eval(uv);
        if self.image.channels == 1 { c.x } else { super::luminance(c) }
    }

    /// The gradient (∂/∂u, ∂/∂v) of [`Bitmap::eval_1`] at `uv`, as Mitsuba 3's `eval_1_grad`
    /// defines it (what a `bumpmap` reads): zero for `nearest` (piecewise constant); for
    /// `bilinear` the partials of the interpolation between the four texels around `uv` (their
    /// values, or luminances), in pixels, taken through `to_uv`'s linear part by its transpose
    /// and scaled by the resolution per axis, in Mitsuba's order (which is the exact chain rule
    /// when `to_uv` does not mix u and v or the image is square).
    pub fn eval_1_grad(&self, uv: Vec2) -> Vec2 {
        if self.filter == Filter::Nearest {
            return Vec2::ZERO;
        }
        let st = self.to_uv.transform_point2(uv);
        let (w, h) = (self.image.width, self.image.height);
        let res = Vec2::new(w as f32, h as f32);
        let one = |x: i64, y: i64| {
            let (x, y) = (wrap(x, w, self.wrap), wrap(y, h, self.wrap));
            let c = self.texel(y * w as usize + x);
            if self.image.channels == 1 { c.x } else { super::luminance(c) }
        };
        let (x, y, w0, w1) = bilinear_cell(st, res);
        let (f00, f10, f01, f11) = (one(x, y), one(x + 1, y), one(x, y + 1), one(x + 1, y + 1));
        let df = Vec2::new(w0.y * (f10 - f00) + w1.y * (f11 - f01), w0.x * (f01 - f00) + w1.x * (f11 - f10));
        let m = self.to_uv.matrix2;
        Vec2::new(m.x_axis.dot(df), m.y_axis.dot(df)) * res
    }

    /// The texel at index `i` (of the wrapped coordinates).
    #[inline]
    fn texel(&self, i: usize) -> Vec3 {
        let d = &self.image.data;
        if self.image.channels == 1 {
            Vec3::splat(d[i])
        } else {
            Vec3::new(d[3 * i], d[3 * i + 1], d[3 * i + 2])
        }
    }

    #[inline]
    fn lookup(&self, uv: Vec2, texel: impl Fn(&Self, usize) -> Vec3) -> Vec3 {
        let uv = self.to_uv.transform_point2(uv);
        let (w, h) = (self.image.width, self.image.height);
        let res = Vec2::new(w as f32, h as f32);
        let at = |x: i64, y: i64| {
            let (x, y) = (wrap(x, w, self.wrap), wrap(y, h, self.wrap));
            texel(self, y * w as usize + x)
        };
        match self.filter {
            Filter::Nearest => {
                let p = (uv * res).floor();
                at(p.x as i64, p.y as i64)
            }
            Filter::Bilinear => {
                let (x, y, w0, w1) = bilinear_cell(uv, res);
                let (v00, v10, v01, v11) = (at(x, y), at(x + 1, y), at(x, y + 1), at(x + 1, y + 1));
                let c0 = w0.x * v00 + w1.x * v10;
                let c1 = w0.x * v01 + w1.x * v11;
                w0.y * c0 + w1.y * c1
            }
        }
    }

    /// Feeds the texture's size, texels and lookup settings to `put` (the scene fingerprint).
    pub fn hash_into(&self, put: &mut dyn FnMut(&[u8])) {
        put(b"bitmap");
        let i = &self.image;
        for v in [i.width, i.height, i.channels, self.filter as u32, self.wrap as u32] {
            put(&v.to_le_bytes());
        }
        self.to_uv.to_cols_array().iter().for_each(|v| put(&v.to_le_bytes()));
        put(bytemuck::cast_slice(&i.data));
    }
}

/// Texel coordinate `i` of a side of `n` texels, wrapped into `0..n`.
#[inline]
fn wrap(i: i64, n: u32, mode: Wrap) -> usize {
    let n = n as i64;
    (match mode {
        Wrap::Repeat => i.rem_euclid(n),
        Wrap::Clamp => i.clamp(0, n - 1),
        Wrap::Mirror => {
            let m = i.rem_euclid(2 * n);
            if m >= n { 2 * n - 1 - m } else { m }
        }
    }) as usize
}

/// The cell of a bilinear lookup at texture coordinates `st` of an image of `res` texels:
/// the texel at its lower corner (texel centres at half-integers, as Mitsuba's) and the
/// weights of the lower (`w0`) and upper (`w1`) neighbours per axis.
#[inline]
fn bilinear_cell(st: Vec2, res: Vec2) -> (i64, i64, Vec2, Vec2) {
    let p = st * res - 0.5;
    let f = p.floor();
    let w1 = p - f;
    (f.x as i64, f.y as i64, 1.0 - w1, w1)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 4 × 2 one-channel image of values 0, 1, …, 7 (row-major from the top).
    fn ramp(filter: Filter, wrap: Wrap) -> Bitmap {
        let t = Texels {
            width: 4,
            height: 2,
            channels: 1,
            data: (0..8).map(|v| v as f32).collect(),
            srgb: false,
        };
        bitmap(t, false, filter, wrap, Affine2::IDENTITY)
    }

    fn bitmap(t: Texels, raw: bool, filter: Filter, wrap: Wrap, to_uv: Affine2) -> Bitmap {
        Bitmap::new(Arc::new(Image::new(t, raw)), filter, wrap, to_uv)
    }

    fn at(b: &Bitmap, u: f32, v: f32) -> f32 {
        b.eval(Vec2::new(u, v)).x
    }

    #[test]
    fn wrap_modes_follow_mitsuba() {
        let seq = |mode| (-5..9).map(|i| wrap(i, 3, mode)).collect::<Vec<_>>();
        assert_eq!(seq(Wrap::Repeat), [1, 2, 0, 1, 2, 0, 1, 2, 0, 1, 2, 0, 1, 2]);
        assert_eq!(seq(Wrap::Clamp), [0, 0, 0, 0, 0, 0, 1, 2, 2, 2, 2, 2, 2, 2]);
        assert_eq!(seq(Wrap::Mirror), [1, 2, 2, 1, 0, 0, 1, 2, 2, 1, 0, 0, 1, 2]);
    }

    /// Hand-computed values of Mitsuba's lookups: texel centres at (i + ½) / n, v from the top.
    #[test]
    fn nearest_and_bilinear_lookups() {
        let n = ramp(Filter::Nearest, Wrap::Repeat);
        assert_eq!(at(&n, 0.0, 0.0), 0.0);
        assert_eq!(at(&n, 0.26, 0.1), 1.0);
        assert_eq!(at(&n, 0.99, 0.6), 7.0);
        assert_eq!(at(&n, 1.01, 0.6), 4.0);
        let b = ramp(Filter::Bilinear, Wrap::Repeat);
        // Texel centres give the texel.
        assert_eq!(at(&b, 0.375, 0.25), 1.0);
        assert_eq!(at(&b, 0.625, 0.75), 6.0);
        // Half-way between texels 1 and 2 of the top row and the rows.
        assert!((at(&b, 0.5, 0.25) - 1.5).abs() < 1e-6);
        assert!((at(&b, 0.5, 0.5) - 3.5).abs() < 1e-6);
        // At u = 0 repeat blends the last column and the first: (3 + 0) / 2 on the top row.
        assert!((at(&b, 0.0, 0.25) - 1.5).abs() < 1e-6);
        // Clamp keeps the edge texel; mirror blends the edge texel with itself.
        assert!((at(&ramp(Filter::Bilinear, Wrap::Clamp), 0.0, 0.25) - 0.0).abs() < 1e-6);
        assert!((at(&ramp(Filter::Bilinear, Wrap::Mirror), 0.0, 0.25) - 0.0).abs() < 1e-6);
        // v = 0: repeat blends the top row with the bottom one: (0 + 4) / 2 at u of texel 0.
        assert!((at(&b, 0.125, 0.0) - 2.0).abs() < 1e-6);
        // A general point: u·w − ½ = 0.9, v·h − ½ = 0.3 → texels (0, 0), (1, 0), (0, 1), (1, 1).
        let (u, v) = (1.4 / 4.0, 0.8 / 2.0);
        let want = 0.7 * (0.1 * 0.0 + 0.9 * 1.0) + 0.3 * (0.1 * 4.0 + 0.9 * 5.0);
        assert!((at(&b, u, v) - want).abs() < 1e-5, "{} {want}", at(&b, u, v));
    }

    #[test]
    fn to_uv_srgb_and_means() {
        let t = Texels { width: 2, height: 2, channels: 3, data: vec![0.5; 12], srgb: true };
        let lin = bitmap(t.clone(), false, Filter::Nearest, Wrap::Repeat, Affine2::IDENTITY);
        assert!((lin.eval(Vec2::splat(0.3)).x - 0.214_041_14).abs() < 1e-6);
        assert!((lin.eval_1(Vec2::splat(0.3)) - 0.214_041_14).abs() < 1e-6);
        let raw = bitmap(t, true, Filter::Nearest, Wrap::Repeat, Affine2::IDENTITY);
        assert_eq!(raw.eval(Vec2::splat(0.3)), Vec3::splat(0.5));
        // to_uv scales before the lookup: u = 0.1 · 4 = 0.4 lands on texel 1.
        let scaled = bitmap(
            ramp_texels(),
            false,
            Filter::Nearest,
            Wrap::Repeat,
            Affine2::from_scale(Vec2::new(4.0, 1.0)),
        );
        assert_eq!(scaled.eval(Vec2::new(0.1, 0.1)).x, 1.0);
        assert_eq!(ramp(Filter::Nearest, Wrap::Repeat).mean(), Vec3::splat(3.5));
        assert_eq!(ramp(Filter::Nearest, Wrap::Repeat).range(), (0.0, 7.0));
        // A one-pixel-high image is repeated to two rows.
        let row = Texels { width: 2, height: 1, channels: 1, data: vec![1.0, 2.0], srgb: false };
        let b = bitmap(row, true, Filter::Nearest, Wrap::Repeat, Affine2::IDENTITY);
        assert_eq!((b.size(), b.eval(Vec2::new(0.75, 0.9)).x), ((2, 2), 2.0));
    }

    /// The gradient is the finite difference of the lookup inside a texel cell (where the
    /// bilinear interpolation is smooth), for one-channel and RGB images, with a `to_uv` scale,
    /// and zero for `nearest`.
    #[test]
    fn gradient_is_the_finite_difference_of_the_lookup() {
        let rgb = Texels {
            width: 3,
            height: 4,
            channels: 3,
            data: (0..36).map(|i| ((i * 7 % 11) as f32) / 10.0).collect(),
            srgb: false,
        };
        let scale = Affine2::from_scale(Vec2::new(2.0, 2.0));
        for (t, to_uv) in [
            (ramp_texels(), Affine2::IDENTITY),
            (rgb.clone(), Affine2::IDENTITY),
            (rgb, scale),
            (ramp_texels(), Affine2::from_translation(Vec2::new(0.3, -0.1))),
        ] {
            for wrap in [Wrap::Repeat, Wrap::Mirror, Wrap::Clamp] {
                let b = bitmap(t.clone(), true, Filter::Bilinear, wrap, to_uv);
                for uv in [Vec2::new(0.31, 0.22), Vec2::new(0.77, 0.61), Vec2::new(0.52, 0.93)] {
                    let e = 1e-3;
                    let fd = Vec2::new(
                        (b.eval_1(uv + Vec2::X * e) - b.eval_1(uv - Vec2::X * e)) / (2.0 * e),
                        (b.eval_1(uv + Vec2::Y * e) - b.eval_1(uv - Vec2::Y * e)) / (2.0 * e),
                    );
                    let g = b.eval_1_grad(uv);
                    assert!((g - fd).abs().max_element() < 2e-2 * (1.0 + fd.abs().max_element()), "{g} {fd}");
                }
            }
        }
        let n = ramp(Filter::Nearest, Wrap::Repeat);
        assert_eq!(n.eval_1_grad(Vec2::new(0.3, 0.3)), Vec2::ZERO);
        // On the ramp, one texel to the right adds 1 and one down adds 4: per unit of u and v,
        // times the width (4) and the height (2), inside a cell.
        let b = ramp(Filter::Bilinear, Wrap::Clamp);
        assert!((b.eval_1_grad(Vec2::new(0.4, 0.5)) - Vec2::new(4.0, 8.0)).abs().max_element() < 1e-5);
    }

    fn ramp_texels() -> Texels {
        Texels { width: 4, height: 2, channels: 1, data: (0..8).map(|v| v as f32).collect(), srgb: false }
    }
}
