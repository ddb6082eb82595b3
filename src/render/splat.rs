//! Splatting an iteration's samples through the film's reconstruction filter
//! ([`crate::scene::Filter`]): every pixel gathers the samples of the pixels within the filter's
//! reach, each weighted by f(dx) f(dy) of its offset from the pixel's centre, and divides by the
//! weights' expected sum (the filter's integral over the image around the pixel), so that the
//! iteration's value is an unbiased estimate of the filtered image. Each pixel sums its
//! neighbours in a fixed order, whatever the threads, so the image is the same bit for bit.
//!
//! Light traced to the camera ([`FilmSplat`]) goes through the same filter: a splat at a film
//! position adds to every pixel within reach its value times the weight a camera sample at
//! that position would have there ([`light_image`]), the splats in their given order.

use glam::{DVec3, Vec2, Vec3};
use rayon::prelude::*;

use super::Film;
use crate::integrator::FilmSplat;
use crate::scene::Filter;

pub struct Splat {
    filter: Filter,
    width: usize,
    height: usize,
    reach: usize,
    /// This iteration's sample of every pixel: its radiance and its offset within the pixel;
    /// `None` where it was dropped (not finite).
    samples: Vec<Option<(Vec3, Vec2)>>,
    /// 1 / the expected weight sum of each column and row.
    inv_x: Vec<f64>,
    inv_y: Vec<f64>,
}

impl Splat {
    pub fn new(filter: Filter, width: usize, height: usize) -> Splat {
        let inv = |n: usize| (0..n).map(|i| 1.0 / filter.coverage(i, n)).collect::<Vec<f64>>();
        Splat {
            filter,
            width,
            height,
            reach: filter.reach(),
            samples: vec![None; width * height],
            inv_x: inv(width),
            inv_y: inv(height),
        }
    }

    /// Forgets the last iteration's samples.
    pub fn clear(&mut self) {
        self.samples.fill(None);
    }

    /// Pixel (x, y)'s sample: radiance `v` at `offset` ∈ [0, 1)² within the pixel.
    pub fn put(&mut self, x: usize, y: usize, offset: Vec2, v: Vec3) {
        self.samples[y * self.width + x] = Some((v, offset));
    }

    /// Adds the iteration's filtered value of every pixel to `film`, plus `light`'s
    /// ([`light_image`]) where given.
    pub fn develop(&self, film: &mut Film, light: Option<&[Vec3]>) {
        let (w, h, r) = (self.width, self.height, self.reach as isize);
        let rows: Vec<Vec<Vec3>> = (0..h)
            .into_par_iter()
            .map(|py| {
                (0..w)
                    .map(|px| {
                        let mut acc = DVec3::ZERO;
                        for dy in -r..=r {
                            let jy = py as isize + dy;
                            if jy < 0 || jy >= h as isize {
                                continue;
                            }
                            for dx in -r..=r {
                                let jx = px as isize + dx;
                                if jx < 0 || jx >= w as isize {
                                    continue;
                                }
                                let Some((v, o)) = self.samples[jy as usize * w + jx as usize] else {
                                    continue;
                                };
                                let wx = self.filter.eval(dx as f32 + o.x - 0.5);
                                let wy = self.filter.eval(dy as f32 + o.y - 0.5);
                                acc += v.as_dvec3() * (wx * wy) as f64;
                            }
                        }
                        (acc * self.inv_x[px] * self.inv_y[py]).as_vec3()
                    })
                    .collect()
            })
            .collect();
        for (py, row) in rows.into_iter().enumerate() {
            for (px, v) in row.into_iter().enumerate() {
                let i = py * w + px;
                film.add(i, light.map_or(v, |l| v + l[i]));
            }
        }
    }

    /// Adds the light of `value` at film position `pos` to the pixels within the filter's
    /// reach, each with the weight a camera sample there has ([`Splat::develop`]).
    fn spread(&self, pos: Vec2, value: Vec3, out: &mut [Vec3]) {
        let (w, h, r) = (self.width as isize, self.height as isize, self.reach as isize);
        let (cx, cy) = (pos.x.floor() as isize, pos.y.floor() as isize);
        for py in (cy - r).max(0)..=(cy + r).min(h - 1) {
            let wy = self.filter.eval(pos.y - (py as f32 + 0.5)) as f64 * self.inv_y[py as usize];
            for px in (cx - r).max(0)..=(cx + r).min(w - 1) {
                let wx = self.filter.eval(pos.x - (px as f32 + 0.5)) as f64 * self.inv_x[px as usize];
                out[(py * w + px) as usize] += value * (wx * wy) as f32;
            }
        }
    }
}

/// The image of an iteration's light traced to the camera, `width` × `height` pixels: each
/// splat through the film's filter (`filter`; `None` for the box, which puts it in its pixel
/// alone), in the splats' order. Splats that are not finite are left out and counted in the
/// second value, the first with its pixel in the third.
pub fn light_image(
    splats: &[FilmSplat],
    filter: Option<&Splat>,
    width: usize,
    height: usize,
) -> (Vec<Vec3>, u64, Option<(usize, usize)>) {
    let mut out = vec![Vec3::ZERO; width * height];
    let (mut dropped, mut first) = (0, None);
    for s in splats {
        let (x, y) =
            ((s.film.x.max(0.0) as usize).min(width - 1), (s.film.y.max(0.0) as usize).min(height - 1));
        if !s.value.is_finite() {
            dropped += 1;
            first.get_or_insert((x, y));
            continue;
        }
        match filter {
            Some(f) => f.spread(s.film, s.value, &mut out),
            None => out[y * width + x] += s.value,
        }
    }
    (out, dropped, first)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A light splat goes through the filter exactly as a camera sample at the same film
    /// position: the same image to rounding, at the edges too, for the box (its pixel alone)
    /// and wider filters.
    #[test]
    fn a_light_splat_develops_as_a_camera_sample_there() {
        let (w, h) = (9, 7);
        for filter in [Filter::Box, Filter::Tent { radius: 1.5 }, Filter::Gaussian { stddev: 0.5 }] {
            let splat = Splat::new(filter, w, h);
            for (x, y, o) in
                [(4, 3, Vec2::new(0.25, 0.8)), (0, 0, Vec2::new(0.1, 0.05)), (8, 6, Vec2::splat(0.99))]
            {
                let v = Vec3::new(1.0, 2.0, 3.0);
                let mut camera = Splat::new(filter, w, h);
                camera.put(x, y, o, v);
                let mut want = Film::new(w, h);
                camera.develop(&mut want, None);
                let light = [FilmSplat { film: Vec2::new(x as f32, y as f32) + o, value: v }];
                let boxed = (filter != Filter::Box).then_some(&splat);
                let (image, dropped, _) = light_image(&light, boxed, w, h);
                assert_eq!(dropped, 0);
                let mut got = Film::new(w, h);
                // The box's Splat develops as the box does without one: the same pixel.
                Splat::new(filter, w, h).develop(&mut got, Some(&image));
                for (a, b) in got.sums().iter().zip(want.sums()) {
                    assert!((*a - *b).abs().max_element() < 1e-5, "{filter:?} at ({x}, {y}): {a} ≠ {b}");
                }
            }
        }
    }

    /// A constant image stays constant (to rounding) through any filter, at the edges too, on
    /// average over the offsets; one bright pixel spreads its light over its neighbours with
    /// the filter's weights and loses none of it away from the edges.
    #[test]
    fn constant_stays_constant_and_light_is_kept() {
        let (w, h) = (15, 13);
        for filter in
            [Filter::Tent { radius: 1.0 }, Filter::Gaussian { stddev: 0.5 }, Filter::Tent { radius: 2.3 }]
        {
            let mut splat = Splat::new(filter, w, h);
            let mut film = Film::new(w, h);
            // Offsets on a grid: the average over them is the expectation.
            let n = 16;
            for a in 0..n {
                for b in 0..n {
                    let o = Vec2::new((a as f32 + 0.5) / n as f32, (b as f32 + 0.5) / n as f32);
                    splat.clear();
                    for y in 0..h {
                        for x in 0..w {
                            splat.put(x, y, o, Vec3::ONE);
                        }
                    }
                    splat.develop(&mut film, None);
                    film.end_iteration();
                }
            }
            let img = film.image();
            for p in &img.pixels {
                assert!((p.x - 1.0).abs() < 2e-3, "{filter:?}: {p}");
            }
            // One bright pixel in the middle.
            let mut film = Film::new(w, h);
            for a in 0..n {
                for b in 0..n {
                    let o = Vec2::new((a as f32 + 0.5) / n as f32, (b as f32 + 0.5) / n as f32);
                    splat.clear();
                    for y in 0..h {
                        for x in 0..w {
                            splat.put(x, y, o, if (x, y) == (7, 6) { Vec3::ONE } else { Vec3::ZERO });
                        }
                    }
                    splat.develop(&mut film, None);
                    film.end_iteration();
                }
            }
            let total: f32 = film.image().pixels.iter().map(|p| p.x).sum();
            assert!((total - 1.0).abs() < 2e-3, "{filter:?}: {total}");
        }
    }
}
