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
    /// Φ ∘ ρ̄ / π by channel, ρ̄ the BSDF's reflectance (albedo, plus the specular colour of a
    /// glossy one), times the adjoint correction's |ω_in · n_s| / |ω_in · n_g|, for
    /// [`SphereLanes::estimates`].
    reflected: [Vec4; 3],
    /// 1 where the sphere's BSDF has a narrow lobe ([`has_narrow_lobe`]), 0 elsewhere.
    narrow: Vec4,
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
    /// 1 where the sphere's BSDF transmits ([`Bsdf::transmits`]): its planes rule out no
    /// light, as in `no_light_in`.
    transmits: Vec4,
}

const EMPTY_CHUNK: Chunk = Chunk {
    vpl: VplCoords::ZERO,
    reflected: [Vec4::ZERO; 3],
    narrow: Vec4::ZERO,
    radius: Vec4::ZERO,
    area: Vec4::ZERO,
    ratio: Vec4::ZERO,
    albedo: [Vec4::ZERO; 3],
    diffuse: Vec4::ZERO,
    depth: Vec4::INFINITY,
    transmits: Vec4::ZERO,
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
    /// ρ̄ / π of its BSDF, and whether it has a narrow lobe, for [`SphereLanes::estimates`].
    reflected: Vec3,
    narrow: bool,
    /// Whether its BSDF transmits: its planes rule out no light.
    transmits: bool,
}

/// GGX alphas below this make a lobe narrow: [`SphereLanes::estimates`] leaves the spheres it
/// touches to their exact integrals.
pub const NARROW_LOBE: f32 = 0.2;

/// Whether `bsdf` has a lobe narrower than [`NARROW_LOBE`].
fn has_narrow_lobe(bsdf: &Bsdf) -> bool {
    matches!(*bsdf, Bsdf::Glossy { roughness, .. } if roughness < NARROW_LOBE)
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
        ReceiverEnd {
            x,
            ng: g.ng,
            n,
            diffuse,
            reflected: bsdf.reflectance() / PI,
            narrow: has_narrow_lobe(bsdf),
            transmits: bsdf.transmits(),
        }
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
            let (in_ns, in_ng) = (v.w_in.dot(v.frame.n), v.w_in.dot(v.ng));
            // The light's adjoint shading-normal correction turns its shading cosine towards
            // the receiver into the geometric one times |ω_in · n_s| / |ω_in · n_g|.
            let correction = (in_ns / in_ng).abs();
            let correction = if correction.is_finite() { correction } else { 0.0 };
            let reflected = v.flux * bsdfs[j].reflectance() * (correction / PI);
            for k in 0..3 {
                c.reflected[k][i] = reflected[k];
            }
            c.narrow[i] = if has_narrow_lobe(&bsdfs[j]) { 1.0 } else { 0.0 };
            c.radius[i] = r;
            c.depth[i] = v.depth as f32;
            c.transmits[i] = if bsdfs[j].transmits() { 1.0 } else { 0.0 };
            // The scalar closed form's conditions at the sphere.
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

    /// A cheap estimate p̂ of each lane's contribution at the receiver `x`, for the resampled
    /// gather ([`super::resample`]), in the contribution's units: the integral with both ends
    /// taken as Lambertian of their reflectance ρ̄ and each cosine at its largest over the
    /// cone, Σ over channels of Φ ∘ ρ̄_p / π ∘ ρ̄_x / π × cos_x × cos_p × Ω / (π r²) (Ω the
    /// cone's solid angle: 1 / d² far away, 2 / r² around the receiver). For a Lambertian pair
    /// it bounds the contribution from above (both cosines bounded, the rest exact), so a
    /// pick's weight is at most T / k; a glossy end whose lobe is wider than [`NARROW_LOBE`]
    /// exceeds it by a bounded factor (its peak over its reflectance). The spheres with a
    /// narrower lobe at either end have no such bound and are returned in the mask (bit per
    /// lane): the caller evaluates their contributions and uses those as p̂. Zero for the
    /// spheres with more than `max_depth` segments and where [`Self::without_sampling`] is
    /// done with a zero (no cone, or no light in it); positive wherever the contribution can
    /// be, where the cone reaches in front of all four planes (each cosine is floored at a
    /// tiny positive number in the margin that `no_light_in` leaves), which is all that
    /// unbiasedness needs.
    #[inline]
    pub fn estimates(&self, chunk: usize, x: &ReceiverEnd, max_depth: u32) -> (Vec4, u32) {
        let q = &self.chunks[chunk];
        let s = Vec4::splat;
        let d = [q.vpl.p[0] - s(x.x.x), q.vpl.p[1] - s(x.x.y), q.vpl.p[2] - s(x.x.z)];
        let dist2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
        let dist = dist2.sqrt();
        let sin_max = q.radius / dist;
        let inside = sin_max.cmpge(s(1.0));
        let sin_cone = sin_max.min(s(1.0));
        let cos_cone = (s(1.0) - sin_cone * sin_cone).max(Vec4::ZERO).sqrt();
        let axis = [d[0] / dist, d[1] / dist, d[2] / dist];
        let dot_axis = |v: Vec3| s(v.x) * axis[0] + s(v.y) * axis[1] + s(v.z) * axis[2];
        let dot_lanes = |v: &[Vec4; 3]| -(v[0] * axis[0] + v[1] * axis[1] + v[2] * axis[2]);
        // The cosines of the axis with the four planes' normals (the sphere's reversed).
        let (ga, na) = (dot_axis(x.ng), dot_axis(x.n));
        let (ma, sa) = (dot_lanes(&q.vpl.ng), dot_lanes(&q.vpl.ns));
        // The largest cosine over the cone: cos(max(θ − θ_max, 0)).
        let widest = |c: Vec4| {
            let sin = (s(1.0) - c * c).max(Vec4::ZERO).sqrt();
            Vec4::select(c.cmpge(cos_cone), s(1.0), c * cos_cone + sin * sin_cone)
        };
        // Ω / (π r²) = 2 (1 − cos θ_max) / r² = 2 / (d² (1 + cos θ_max)) outside the sphere.
        let solid =
            Vec4::select(inside, s(2.0) / (q.radius * q.radius), s(2.0) / (dist2 * (s(1.0) + cos_cone)));
        let floor = s(1e-6);
        let rho = x.reflected;
        let reflected = q.reflected[0] * s(rho.x) + q.reflected[1] * s(rho.y) + q.reflected[2] * s(rho.z);
        // Whether each end transmits: its cosines count on either side, as no_light_in's planes.
        let (tx, tp) = (BVec4A::splat(x.transmits), q.transmits.cmpgt(Vec4::ZERO));
        // The receiver's shading cosine, the sphere's geometric one (the adjoint correction).
        let (na_side, ma_side) = (Vec4::select(tx, na.abs(), na), Vec4::select(tp, ma.abs(), ma));
        let p = reflected * widest(na_side).max(floor) * widest(ma_side).max(floor) * solid;
        // Where without_sampling returns zero; the same margin as no_light_in.
        let behind = -(sin_max + s(1e-4));
        let same_normal =
            q.vpl.ng[0].cmpeq(s(x.ng.x)) & q.vpl.ng[1].cmpeq(s(x.ng.y)) & q.vpl.ng[2].cmpeq(s(x.ng.z));
        let dark = dist2.cmple(Vec4::ZERO)
            | q.radius.cmple(Vec4::ZERO)
            | (same_normal & !(tx | tp))
            | (!tx & (ga.cmplt(behind) | na.cmplt(behind)))
            | (!tp & (ma.cmplt(behind) | sa.cmplt(behind)));
        let active = q.depth.cmple(s(max_depth as f32)) & !dark;
        let narrow = active & (q.narrow.cmpgt(Vec4::ZERO) | BVec4A::splat(x.narrow));
        (Vec4::select(active & p.is_finite_mask(), p, Vec4::ZERO), narrow.bitmask())
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
        let (tx, tp) = (BVec4A::splat(x.transmits), q.transmits.cmpgt(Vec4::ZERO));
        let no_light = (same_normal & !(tx | tp))
            | (!tx & (ga.cmplt(behind) | na.cmplt(behind)))
            | (!tp & (ma.cmplt(behind) | sa.cmplt(behind)));
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

    /// A receiver and its spheres, the cases of the tests below: round `round` of a
    /// sequence that covers spheres in front and across horizons, on the receiver's plane,
    /// around the receiver, on its point, glossy spheres and receivers, light from behind,
    /// zero radii and depths beyond 2.
    struct Case {
        x: Vec3,
        gx: LocalGeometry,
        bsdf_x: Bsdf,
        wo: Vec3,
        vpls: Vec<Vpl>,
        bsdfs: Vec<Bsdf>,
        emitting: Vec<PreparedBsdf>,
        radii: Vec<f32>,
    }

    impl Case {
        fn new(round: usize, s: &mut Sampler) -> Case {
            let n = 1 + round % 37;
            let x = Vec3::new(0.1, -0.2, 0.3);
            let (ngx, frame_x) = normals(Vec3::Z, s);
            let gx = LocalGeometry { ng: ngx, frame: frame_x };
            let albedo_x = Vec3::new(0.8, 0.4, s.next_f32());
            let bsdf_x = if round % 3 == 2 {
                Bsdf::Glossy { albedo: albedo_x, specular: Vec3::splat(0.4), roughness: 0.2 }
            } else {
                Bsdf::Diffuse { albedo: albedo_x }
            };
            let wo = (ngx + 0.5 * unit(s)).normalize();
            let vpls: Vec<Vpl> = (0..n)
                .map(|j| {
                    let p = match j % 9 {
                        0 => x,
                        1 => x + 1e-3 * unit(s),
                        2 => x + 0.5 * unit(s),
                        // On the receiver's plane (its normal too, below).
                        3 => x + Frame::from_normal(ngx).to_world(Vec3::new(s.next_f32(), s.next_f32(), 0.0)),
                        _ => {
                            x + Vec3::new(s.next_f32() - 0.5, s.next_f32() - 0.5, 1.0) * (0.3 + s.next_f32())
                        }
                    };
                    let (ng, frame) = normals((x - p).normalize_or(Vec3::Z), s);
                    let (ng, frame) = if j % 9 == 3 { (ngx, Frame::from_normal(ngx)) } else { (ng, frame) };
                    let w_in = (ng + 0.8 * unit(s)).normalize_or(ng);
                    Vpl::for_test(
                        p,
                        ng,
                        frame,
                        w_in,
                        Vec3::new(s.next_f32(), s.next_f32(), 0.5),
                        (j % 4) as u32,
                    )
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
            Case { x, gx, bsdf_x, wo, vpls, bsdfs, emitting, radii }
        }

        fn lanes(&self) -> SphereLanes {
            SphereLanes::new(&self.vpls, &self.bsdfs, &self.emitting, &self.radii)
        }

        fn end(&self) -> ReceiverEnd {
            ReceiverEnd::new(self.x, &self.gx, &self.bsdf_x, self.wo)
        }

        /// The scalar contribution of sphere j with the numbers of `seed`, and whether it drew any.
        fn scalar(&self, j: usize, seed: u64) -> (Vec3, bool) {
            let mut s = Sampler::new(seed, 0, Domain::LightPath, 0);
            let c = contribution(
                &self.gx,
                self.x,
                &self.bsdf_x,
                self.wo,
                &self.vpls[j],
                &self.bsdfs[j],
                self.radii[j],
                &mut s,
            );
            (c, s.next_u64() != Sampler::new(seed, 0, Domain::LightPath, 0).next_u64())
        }
    }

    /// Every lane done gives bit for bit the scalar contribution, and the scalar code draws no
    /// number (takes the closed form or returns zero) exactly where a lane the kernel holds is
    /// done (the cases of [`Case`]).
    #[test]
    fn matches_the_scalar_closed_form() {
        let mut s = Sampler::new(5, 0, Domain::LightPath, 0);
        let (mut done_count, mut zero_count, mut left) = (0, 0, 0);
        for round in 0..300 {
            let case = Case::new(round, &mut s);
            let (lanes, end, n) = (case.lanes(), case.end(), case.vpls.len());
            let max_depth = 2;
            for c in 0..lanes.chunks() {
                let (rgb, done) = lanes.without_sampling(c, &end, max_depth);
                let values: [Vec3; LANES] =
                    std::array::from_fn(|i| Vec3::new(rgb[0][i], rgb[1][i], rgb[2][i]));
                for (i, got) in values.into_iter().enumerate() {
                    let j = c * LANES + i;
                    if done >> i & 1 == 0 {
                        assert_eq!(got, Vec3::ZERO);
                        let v = case.vpls.get(j);
                        // A sphere the lanes hold (diffuse, lit from the front) is left only
                        // where the scalar code samples.
                        if let Some(v) =
                            v.filter(|v| v.depth <= max_depth && lanes.chunks[c].depth[i].is_finite())
                        {
                            assert!(case.scalar(j, 1).1, "{j} at {}", v.p);
                            left += 1;
                        }
                        continue;
                    }
                    assert!(j < n && case.vpls[j].depth <= max_depth && case.emitting[j].is_active(), "{j}");
                    let (want, drew) = case.scalar(j, 1);
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

    /// The resampled gather's estimates are positive wherever a sphere's contribution can be
    /// (so that no light with light to give is left out: unbiasedness), and zero for the
    /// spheres beyond the depth, the inactive ones, and where the lanes are done with a zero;
    /// they bound a Lambertian pair's contribution from above, and name exactly the spheres
    /// with a narrow lobe at either end for exact evaluation (the cases of [`Case`], each
    /// sampled sphere's contribution drawn with several seeds).
    #[test]
    fn estimates_are_positive_wherever_a_sphere_gives_light() {
        let mut s = Sampler::new(6, 0, Domain::LightPath, 0);
        let (mut lit, mut dark, mut narrow_count) = (0, 0, 0);
        for round in 0..300 {
            let mut case = Case::new(round, &mut s);
            // Narrow lobes at some receivers and some spheres.
            if round % 5 == 4
                && let Bsdf::Glossy { ref mut roughness, .. } = case.bsdf_x
            {
                *roughness = 0.05;
            }
            for (j, b) in case.bsdfs.iter_mut().enumerate() {
                if let Bsdf::Glossy { ref mut roughness, .. } = *b
                    && j % 2 == 0
                {
                    *roughness = 0.1;
                }
            }
            let (lanes, end) = (case.lanes(), case.end());
            let max_depth = 2;
            for c in 0..lanes.chunks() {
                let (p, narrow) = lanes.estimates(c, &end, max_depth);
                let (_, done) = lanes.without_sampling(c, &end, max_depth);
                for i in 0..LANES {
                    let j = c * LANES + i;
                    assert!(p[i] >= 0.0 && p[i].is_finite(), "{j}: {}", p[i]);
                    let beyond = case.vpls.get(j).is_none_or(|v| v.depth > max_depth);
                    if beyond || !case.emitting[j].is_active() {
                        assert_eq!((p[i], narrow >> i & 1), (0.0, 0), "{j}");
                        continue;
                    }
                    let draws: Vec<Vec3> = (1..=8).map(|seed| case.scalar(j, seed).0).collect();
                    if draws.iter().any(|&c| c != Vec3::ZERO) {
                        assert!(p[i] > 0.0, "{j}: lights the receiver but has no estimate");
                        lit += 1;
                    } else {
                        dark += 1;
                    }
                    if done >> i & 1 == 1 && draws[0] == Vec3::ZERO {
                        assert_eq!(p[i], 0.0, "{j}: no light in its cone, yet an estimate");
                    }
                    let want_narrow =
                        p[i] > 0.0 && (has_narrow_lobe(&case.bsdf_x) || has_narrow_lobe(&case.bsdfs[j]));
                    assert_eq!(narrow >> i & 1 == 1, want_narrow, "{j}");
                    narrow_count += usize::from(want_narrow);
                    // A Lambertian pair's closed form stays below its estimate.
                    if done >> i & 1 == 1 && draws[0] != Vec3::ZERO {
                        assert!(draws[0].element_sum() <= p[i] * 1.0001, "{j}: {} > {}", draws[0], p[i]);
                    }
                }
            }
        }
        assert!(
            lit > 1000 && dark > 300 && narrow_count > 100,
            "{lit} lit, {dark} dark, {narrow_count} narrow"
        );
    }
}
