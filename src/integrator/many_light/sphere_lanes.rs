//! Virtual spherical lights [`LANES`] at a time: diffuse pairs in closed form, and cones
//! without light.
//!
//! [`super::spheres`] integrates a sphere's light over its cone in closed form when both ends
//! are Lambertian and the cone lies in front of both surfaces, and returns zero without
//! sampling when the cone holds no light (`no_light_in`); written per sphere, those paths are a
//! chain of calls (the cone, the two prepared BSDFs, the tests) that costs more than the
//! shadow ray. Here the same computations run on a chunk of four spheres at once with glam's
//! `Vec4` (SSE), as [`super::lanes`] does for point lights. Every lane performs exactly the
//! floating-point operations of `Cone::new`, `diffuse_pair`, `no_light_in` and
//! `prepared_contribution` in the same order (SSE arithmetic, square root and division are
//! IEEE per lane, and Rust never fuses or reorders), so a lane's value and every decision are
//! bit for bit the scalar ones (`matches_the_scalar_closed_form` below). A lane is *done* only
//! where the scalar code would take the closed form or return zero without sampling (no cone,
//! or no light in it), for any BSDF at either end; everywhere else (a cone across a horizon
//! with light in it, a glossy end in front, a receiver inside the sphere, anything not finite)
//! the caller evaluates the sphere one by one, as before, so the sampled cone integrals draw
//! the same numbers in the same order and the image does not change.

use glam::{BVec4A, Vec3, Vec4};
use std::f32::consts::PI;

use super::lanes::{LANES, VplCoords};
use super::light_paths::Vpl;
use crate::material::{Bsdf, LocalGeometry, PreparedBsdf};

/// [`LANES`] spheres, coordinate by coordinate.
#[derive(Clone, Copy)]
struct Chunk {
    /// The sphere's centre, normals and flux.
    vpl: VplCoords,
    radius: Vec4,
    /// π r² as the scalar code forms it, `(π · r) · r`.
    area: Vec4,
    /// |ω_in · n_s| / |ω_in · n_g| as `in_ns / in_ng`.
    ratio: Vec4,
    albedo: [Vec4; 3],
    /// 1 where the sphere can take the closed form (Lambertian, lit from in front of both its
    /// normals), 0 elsewhere.
    diffuse: Vec4,
    /// Segments from the emitter, as a float (exact below 2^24); infinite in lanes without an
    /// active sphere (padding, or one that reflects nothing), so that the depth test masks
    /// them.
    depth: Vec4,
}

const EMPTY_CHUNK: Chunk = Chunk {
    vpl: VplCoords::ZERO,
    radius: Vec4::ZERO,
    area: Vec4::ZERO,
    ratio: Vec4::ZERO,
    albedo: [Vec4::ZERO; 3],
    diffuse: Vec4::ZERO,
    depth: Vec4::INFINITY,
};

/// The receiver, the other end of every lane: its point, normals, and its albedo when it can
/// take the closed form (Lambertian, `wo` in front of both its normals).
#[derive(Clone, Copy, Debug)]
pub struct ReceiverEnd {
    x: Vec3,
    ng: Vec3,
    /// Shading normal.
    n: Vec3,
    diffuse: Option<Vec3>,
}

impl ReceiverEnd {
    /// The receiver at `x` (geometry `g`, BSDF `bsdf`, outgoing direction `wo`), whose BSDF
    /// reflects something towards `wo`.
    pub fn new(x: Vec3, g: &LocalGeometry, bsdf: &Bsdf, wo: Vec3) -> Self {
        let n = g.frame.n;
        let diffuse = match *bsdf {
            Bsdf::Diffuse { albedo } if wo.dot(g.ng) > 0.0 && wo.dot(n) > 0.0 => Some(albedo),
            _ => None,
        };
        ReceiverEnd { x, ng: g.ng, n, diffuse }
    }
}

/// The spheres of one iteration in chunks of [`LANES`].
#[derive(Default)]
pub struct SphereLanes {
    chunks: Vec<Chunk>,
}

impl SphereLanes {
    /// `bsdfs[j]`, `emitting[j]` and `radii[j]` are sphere j's BSDF, the same prepared for its
    /// incoming direction, and its radius.
    pub fn new(vpls: &[Vpl], bsdfs: &[Bsdf], emitting: &[PreparedBsdf], radii: &[f32]) -> Self {
        assert!(bsdfs.len() == vpls.len() && emitting.len() == vpls.len() && radii.len() == vpls.len());
        let mut chunks = vec![EMPTY_CHUNK; vpls.len().div_ceil(LANES)];
        for (j, v) in vpls.iter().enumerate() {
            let (c, i) = (&mut chunks[j / LANES], j % LANES);
            // An inactive sphere contributes nothing and is skipped by the caller.
            if !emitting[j].is_active() {
                continue;
            }
            let r = radii[j];
            c.vpl.set(i, v);
            c.radius[i] = r;
            c.depth[i] = v.depth as f32;
            // The scalar closed form's conditions at the sphere.
            let (in_ns, in_ng) = (v.w_in.dot(v.frame.n), v.w_in.dot(v.ng));
            if let Bsdf::Diffuse { albedo } = bsdfs[j]
                && in_ns > 0.0
                && in_ng > 0.0
            {
                for k in 0..3 {
                    c.albedo[k][i] = albedo[k];
                }
                c.area[i] = PI * r * r;
                c.ratio[i] = in_ns / in_ng;
                c.diffuse[i] = 1.0;
            }
        }
        SphereLanes { chunks }
    }

    pub fn chunks(&self) -> usize {
        self.chunks.len()
    }

    /// Φ / (π r²) · ∫_cone f_x cos_x f_p cos_p dω of the spheres of chunk `chunk` with at most
    /// `max_depth` segments, at the receiver `x`, where it has the closed form or is zero
    /// without sampling: red, green and blue by lane, and the lanes done (bit per lane). The
    /// other lanes are zero and left to the caller.
    #[inline]
    pub fn without_sampling(&self, chunk: usize, x: &ReceiverEnd, max_depth: u32) -> ([Vec4; 3], u32) {
        let q = &self.chunks[chunk];
        let s = Vec4::splat;
        // Cone::new: d = centre − x, its length, sin θ_max = r / |d|, 1 − cos θ_max, the axis.
        let d = [q.vpl.p[0] - s(x.x.x), q.vpl.p[1] - s(x.x.y), q.vpl.p[2] - s(x.x.z)];
        let dist2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
        let dist = dist2.sqrt();
        let sin_max = q.radius / dist;
        let cos_max = (s(1.0) - sin_max * sin_max).sqrt();
        let t = sin_max * sin_max / (s(1.0) + cos_max);
        let axis = [d[0] / dist, d[1] / dist, d[2] / dist];
        // diffuse_pair: the cone in front of both normals at both ends, by a margin.
        let lim = sin_max + s(1e-4);
        let dot_axis = |v: Vec3| s(v.x) * axis[0] + s(v.y) * axis[1] + s(v.z) * axis[2];
        let dot_lanes = |v: &[Vec4; 3]| v[0] * axis[0] + v[1] * axis[1] + v[2] * axis[2];
        let (n, m) = (x.n, [-q.vpl.ng[0], -q.vpl.ng[1], -q.vpl.ng[2]]);
        // The axis against the four planes: the receiver's normals, the sphere's reversed.
        let (ga, na) = (dot_axis(x.ng), dot_axis(n));
        let (ma, sa) = (dot_lanes(&m), -dot_lanes(&q.vpl.ns));
        let in_front = ga.cmpgt(lim) & na.cmpgt(lim) & ma.cmpgt(lim) & sa.cmpgt(lim);
        let a = s(PI) * t * t * (s(1.0) - t / s(3.0));
        let b = s(2.0 * PI) * t * (s(1.0) - t + t * t / s(3.0));
        let nm = s(n.x) * m[0] + s(n.y) * m[1] + s(n.z) * m[2];
        let integral = a * (nm - na * ma) + b * na * ma;
        let scale = q.ratio * integral / s(PI * PI);
        let albedo_x = x.diffuse.unwrap_or(Vec3::ZERO);
        let v = [0, 1, 2].map(|k| s(albedo_x[k]) * q.albedo[k] * scale);
        let finite = v[0].is_finite_mask() & v[1].is_finite_mask() & v[2].is_finite_mask();
        let closed = BVec4A::splat(x.diffuse.is_some())
            & q.diffuse.cmpgt(Vec4::ZERO)
            & dist2.cmpgt(Vec4::ZERO)
            & q.radius.cmpgt(Vec4::ZERO)
            & sin_max.cmplt(s(1.0))
            & in_front
            & finite
            & integral.cmpge(Vec4::ZERO);
        // Zero where the scalar code returns zero before sampling: no cone (d = 0 or r ≤ 0), or
        // no light in it (`no_light_in`: the same geometric normal at both ends, or the cone
        // behind one of the four planes).
        let no_cone = dist2.cmple(Vec4::ZERO) | q.radius.cmple(Vec4::ZERO);
        let same_normal =
            q.vpl.ng[0].cmpeq(s(x.ng.x)) & q.vpl.ng[1].cmpeq(s(x.ng.y)) & q.vpl.ng[2].cmpeq(s(x.ng.z));
        let behind = -lim;
        let no_light =
            same_normal | ga.cmplt(behind) | na.cmplt(behind) | ma.cmplt(behind) | sa.cmplt(behind);
        let done = q.depth.cmple(s(max_depth as f32)) & (closed | no_cone | no_light);
        let out = [0, 1, 2].map(|k| Vec4::select(closed & done, q.vpl.flux[k] * v[k] / q.area, Vec4::ZERO));
        (out, done.bitmask())
    }
}

#[cfg(test)]
mod tests {
    use super::super::spheres::contribution;
    use super::*;
    use crate::geometry::Frame;
    use crate::material::TransportMode;
    use crate::sampling::{Domain, Sampler};

    fn unit(s: &mut Sampler) -> Vec3 {
        let v = Vec3::new(s.next_f32() - 0.5, s.next_f32() - 0.5, s.next_f32() - 0.5);
        v.normalize_or(Vec3::Z)
    }

    /// A geometric normal near `towards` and a shading normal tilted from it.
    fn normals(towards: Vec3, s: &mut Sampler) -> (Vec3, Frame) {
        let ng = (towards + 0.6 * unit(s)).normalize_or(towards);
        let ns = (ng + 0.2 * unit(s)).normalize_or(ng);
        (ng, Frame::from_normal(ns))
    }

    /// Every lane done gives bit for bit the scalar contribution, and the scalar code draws no
    /// number (takes the closed form or returns zero) exactly where a lane the kernel holds is
    /// done: spheres in front and across horizons, on the receiver's plane, around the
    /// receiver, on its point, glossy spheres, light from behind, zero radii, depths beyond the
    /// limit.
    #[test]
    fn matches_the_scalar_closed_form() {
        let mut s = Sampler::new(5, 0, Domain::LightPath, 0);
        let (mut done_count, mut zero_count, mut left) = (0, 0, 0);
        for round in 0..300 {
            let n = 1 + round % 37;
            let x = Vec3::new(0.1, -0.2, 0.3);
            let (ngx, frame_x) = normals(Vec3::Z, &mut s);
            let gx = LocalGeometry { ng: ngx, frame: frame_x };
            let albedo_x = Vec3::new(0.8, 0.4, s.next_f32());
            let bsdf_x = if round % 3 == 2 {
                Bsdf::Glossy { albedo: albedo_x, specular: Vec3::splat(0.4), roughness: 0.2 }
            } else {
                Bsdf::Diffuse { albedo: albedo_x }
            };
            let wo = (ngx + 0.5 * unit(&mut s)).normalize();
            let vpls: Vec<Vpl> = (0..n)
                .map(|j| {
                    let p = match j % 9 {
                        0 => x,
                        1 => x + 1e-3 * unit(&mut s),
                        2 => x + 0.5 * unit(&mut s),
                        // On the receiver's plane (its normal too, below).
                        3 => x + Frame::from_normal(ngx).to_world(Vec3::new(s.next_f32(), s.next_f32(), 0.0)),
                        _ => {
                            x + Vec3::new(s.next_f32() - 0.5, s.next_f32() - 0.5, 1.0) * (0.3 + s.next_f32())
                        }
                    };
                    let (ng, frame) = normals((x - p).normalize_or(Vec3::Z), &mut s);
                    let (ng, frame) = if j % 9 == 3 { (ngx, Frame::from_normal(ngx)) } else { (ng, frame) };
                    Vpl {
                        p,
                        ng,
                        frame,
                        w_in: (ng + 0.8 * unit(&mut s)).normalize_or(ng),
                        material: 0,
                        flux: Vec3::new(s.next_f32(), s.next_f32(), 0.5),
                        depth: (j % 4) as u32,
                        arrival: 1.0,
                        survival: 1.0,
                        nee_pdf: 0.0,
                        mis: Default::default(),
                    }
                })
                .collect();
            let bsdfs: Vec<Bsdf> = (0..n)
                .map(|j| {
                    let albedo = Vec3::new(0.5, s.next_f32(), 0.9);
                    if j % 11 == 10 {
                        Bsdf::Glossy { albedo, specular: Vec3::splat(0.2), roughness: 0.3 }
                    } else {
                        Bsdf::Diffuse { albedo }
                    }
                })
                .collect();
            let emitting: Vec<PreparedBsdf> = vpls
                .iter()
                .zip(&bsdfs)
                .map(|(v, b)| PreparedBsdf::new(*b, v.geometry(), v.w_in, TransportMode::Importance))
                .collect();
            let radii: Vec<f32> =
                (0..n).map(|j| if j % 13 == 12 { 0.0 } else { [0.01, 0.1, 0.4, 1.5][j % 4] }).collect();
            let lanes = SphereLanes::new(&vpls, &bsdfs, &emitting, &radii);
            let end = ReceiverEnd::new(x, &gx, &bsdf_x, wo);
            let max_depth = 2;
            for c in 0..lanes.chunks() {
                let (rgb, done) = lanes.without_sampling(c, &end, max_depth);
                let values: [Vec3; LANES] =
                    std::array::from_fn(|i| Vec3::new(rgb[0][i], rgb[1][i], rgb[2][i]));
                for (i, got) in values.into_iter().enumerate() {
                    let j = c * LANES + i;
                    // The scalar code, and whether it drew any number.
                    let scalar = |j: usize| {
                        let mut s = Sampler::new(1, 0, Domain::LightPath, 0);
                        let c = contribution(&gx, x, &bsdf_x, wo, &vpls[j], &bsdfs[j], radii[j], &mut s);
                        (c, s.next_u64() != Sampler::new(1, 0, Domain::LightPath, 0).next_u64())
                    };
                    if done >> i & 1 == 0 {
                        assert_eq!(got, Vec3::ZERO);
                        let v = vpls.get(j);
                        // A sphere the lanes hold (diffuse, lit from the front) is left only
                        // where the scalar code samples.
                        if let Some(v) =
                            v.filter(|v| v.depth <= max_depth && lanes.chunks[c].depth[i].is_finite())
                        {
                            assert!(scalar(j).1, "{j} at {}", v.p);
                            left += 1;
                        }
                        continue;
                    }
                    assert!(j < n && vpls[j].depth <= max_depth && emitting[j].is_active(), "{j}");
                    let (want, drew) = scalar(j);
                    assert_eq!(got.to_array().map(f32::to_bits), want.to_array().map(f32::to_bits), "{j}");
                    assert!(!drew, "{j}");
                    if got == Vec3::ZERO {
                        zero_count += 1;
                    } else {
                        done_count += 1;
                    }
                }
            }
        }
        assert!(
            done_count > 1000 && zero_count > 300 && left > 300,
            "{done_count} in closed form, {zero_count} zero, {left} left"
        );
    }
}
