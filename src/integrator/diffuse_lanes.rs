//! `pt`'s Lambertian vertices shaded sixteen at a time: the batched walker's
//! ([`super::wavefront`]) structure-of-arrays kernel for the most common vertex of all.
//!
//! At a Lambertian vertex `pt` does two things that are arithmetic from end to end once the
//! vertex's random numbers are drawn and its emitter point picked: next-event estimation
//! ([`connect_emitters_at`](super::direct::connect_emitters_at) for a triangle emitter, the
//! power heuristic against BSDF sampling, the shadow segment) and the BSDF sample
//! (`Bsdf::sample`'s Lambertian case: the concentric map, the frame, the checks, the
//! throughput, the next ray's origin). The walker draws the numbers and picks the emitter
//! point for each vertex in its order, with the scalar code ([`Lanes::push`]); [`Lanes::shade`]
//! then computes both for sixteen vertices per step, a coordinate per vector register
//! ([`crate::wide`]); the walker hands the results back to each path in its order
//! ([`Lanes::light_sample`], [`Lanes::scattered`]).
//!
//! Every lane performs the scalar code's floating-point operations in the same order, its
//! early returns replaced by masks, so each vertex's light sample, throughput and next ray
//! are bit for bit the scalar walker's (`matches_the_scalar_vertex` below, and the images of
//! `tests/wavefront.rs`).

use glam::{Vec2, Vec3};
use std::f32::consts::{FRAC_1_PI, PI};

use super::RenderContext;
use super::direct::emitter_numbers;
use super::scatter::bsdf_numbers;
use crate::geometry::{OFFSET_SCALE, Ray};
use crate::light::EmitterSample;
use crate::sampling::Sampler;
use crate::scene::SurfacePoint;
use crate::wide::{F16, M16, V16, W};

/// What a vertex brings to the kernel, sixteen vertices per chunk.
#[derive(Clone, Copy)]
struct Vertices {
    p: V16,
    ng: V16,
    /// The shading frame.
    s: V16,
    t: V16,
    n: V16,
    /// Unit direction back along the path.
    wo: V16,
    albedo: V16,
    /// The path's throughput at the vertex.
    beta: V16,
    /// The emitter point of the light sample: position, normal, radiance, area density.
    q: V16,
    nq: V16,
    le: V16,
    pdf_area: F16,
    /// The BSDF sample's two numbers.
    ux: F16,
    uy: F16,
}

impl Vertices {
    const ZERO: Vertices = Vertices {
        p: V16::ZERO,
        ng: V16::ZERO,
        s: V16::ZERO,
        t: V16::ZERO,
        n: V16::ZERO,
        wo: V16::ZERO,
        albedo: V16::ZERO,
        beta: V16::ZERO,
        q: V16::ZERO,
        nq: V16::ZERO,
        le: V16::ZERO,
        pdf_area: F16::ZERO,
        ux: F16::ZERO,
        uy: F16::ZERO,
    };
}

/// What the kernel gives back for sixteen vertices.
#[derive(Clone, Copy)]
struct Shaded {
    /// The light sample connects (`connect_emitters_at` is `Some`): its shadow segment and
    /// its value where unoccluded, MIS-weighted.
    connects: M16,
    shadow_origin: V16,
    shadow_dir: V16,
    value: V16,
    /// The BSDF sample leaves the path alive (`scatter` is `Some`): the new throughput, the
    /// direction, its density and the next ray's origin.
    alive: M16,
    beta: V16,
    wi: V16,
    pdf: F16,
    origin: V16,
}

impl Shaded {
    const ZERO: Shaded = Shaded {
        connects: M16::NONE,
        shadow_origin: V16::ZERO,
        shadow_dir: V16::ZERO,
        value: V16::ZERO,
        alive: M16::NONE,
        beta: V16::ZERO,
        wi: V16::ZERO,
        pdf: F16::ZERO,
        origin: V16::ZERO,
    };
}

/// The Lambertian vertices of one bounce of a batch, in the order the walker gave them;
/// buffers kept across bounces and batches.
#[derive(Default)]
pub struct Lanes {
    /// The walker's number of each vertex (its path's place in the bounce's list).
    slots: Vec<u32>,
    /// The chunks of vertices; those past the current bounce's are left from earlier ones
    /// (so that a chunk is initialised once, when the buffer grows).
    vertices: Vec<Vertices>,
    shaded: Vec<Shaded>,
}

/// A vertex's light sample as the scalar code would give it to the walker's terms.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LightTerm {
    /// The shadow segment, where the sample connects.
    pub shadow: Option<Ray>,
    /// Its value where unoccluded (zero where it does not connect).
    pub value: Vec3,
}

/// A vertex's BSDF sample, where the path goes on.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Scattered {
    pub beta: Vec3,
    pub wi: Vec3,
    pub pdf: f32,
    /// The next ray's origin, off the surface on `wi`'s side.
    pub origin: Vec3,
}

impl Lanes {
    /// No vertices.
    pub fn clear(&mut self) {
        self.slots.clear();
    }

    /// The chunks holding the vertices pushed.
    #[inline(always)]
    fn chunks(&self) -> usize {
        self.slots.len().div_ceil(W)
    }

    pub fn len(&self) -> usize {
        self.slots.len()
    }

    pub fn is_empty(&self) -> bool {
        self.slots.is_empty()
    }

    /// The walker's number of vertex `k`.
    #[inline(always)]
    pub fn slot(&self, k: usize) -> u32 {
        self.slots[k]
    }

    /// `pt`'s Lambertian vertex `sp` (reflectance `albedo`, throughput `beta`, `wo` the unit
    /// direction back along the path), numbered `slot` by the walker: its draws in `pt`'s
    /// order (the light sample's numbers and emitter point, then the BSDF sample's), then
    /// [`Lanes::push`].
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    pub fn draw(
        &mut self,
        ctx: &RenderContext,
        slot: u32,
        sp: &SurfacePoint,
        wo: Vec3,
        albedo: Vec3,
        beta: Vec3,
        sampler: &mut Sampler,
    ) {
        let (u_select, u) = emitter_numbers(sampler);
        let es = ctx.emitters.sample_from(ctx.scene, sp.p, u_select, u);
        let (_, u) = bsdf_numbers(sampler);
        self.push(slot, sp, wo, albedo, beta, &es, u);
    }

    /// A Lambertian vertex numbered `slot` (as [`Lanes::draw`] says) whose light sample
    /// picked `es` and whose BSDF sample draws `u`.
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    pub fn push(
        &mut self,
        slot: u32,
        sp: &SurfacePoint,
        wo: Vec3,
        albedo: Vec3,
        beta: Vec3,
        es: &EmitterSample,
        u: Vec2,
    ) {
        let k = self.slots.len();
        if k == self.vertices.len() * W {
            self.vertices.push(Vertices::ZERO);
        }
        self.slots.push(slot);
        let (v, i) = (&mut self.vertices[k / W], k % W);
        v.p.set(i, sp.p);
        v.ng.set(i, sp.ng);
        v.s.set(i, sp.frame.s);
        v.t.set(i, sp.frame.t);
        v.n.set(i, sp.frame.n);
        v.wo.set(i, wo);
        v.albedo.set(i, albedo);
        v.beta.set(i, beta);
        v.q.set(i, es.point.p);
        v.nq.set(i, es.point.ng);
        v.le.set(i, es.radiance);
        v.pdf_area.0[i] = es.pdf_area;
        v.ux.0[i] = u.x;
        v.uy.0[i] = u.y;
    }

    /// Shades every vertex pushed (the lanes past the last vertex compute on what an earlier
    /// bounce left there, unused).
    #[inline(always)]
    pub fn shade(&mut self) {
        let n = self.chunks();
        if self.shaded.len() < n {
            self.shaded.resize(n, Shaded::ZERO);
        }
        for (v, out) in self.vertices[..n].iter().zip(&mut self.shaded[..n]) {
            *out = shade(v);
        }
    }

    /// Vertex `k`'s light sample (after [`Lanes::shade`]).
    #[inline(always)]
    pub fn light_sample(&self, k: usize) -> LightTerm {
        let (s, i) = (&self.shaded[k / W], k % W);
        if !s.connects.lane(i) {
            return LightTerm { shadow: None, value: Vec3::ZERO };
        }
        let ray = Ray { origin: s.shadow_origin.get(i), dir: s.shadow_dir.get(i), tmin: 0.0, tmax: 1.0 };
        LightTerm { shadow: Some(ray), value: s.value.get(i) }
    }

    /// Vertex `k`'s BSDF sample, `None` where the path ends there (after [`Lanes::shade`]).
    #[inline(always)]
    pub fn scattered(&self, k: usize) -> Option<Scattered> {
        let (s, i) = (&self.shaded[k / W], k % W);
        s.alive.lane(i).then(|| Scattered {
            beta: s.beta.get(i),
            wi: s.wi.get(i),
            pdf: s.pdf.0[i],
            origin: s.origin.get(i),
        })
    }

    /// The throughput vertex `k` was pushed with.
    #[inline(always)]
    pub fn beta(&self, k: usize) -> Vec3 {
        self.vertices[k / W].beta.get(k % W)
    }

    /// The position of vertex `k`.
    #[inline(always)]
    pub fn point(&self, k: usize) -> Vec3 {
        self.vertices[k / W].p.get(k % W)
    }
}

/// `offset_origin(p, ng, w)` of sixteen points.
#[inline(always)]
fn offset_origin(p: V16, ng: V16, w: V16) -> V16 {
    let eps = (1.0 + p.abs().max_element()) * OFFSET_SCALE;
    ng.dot(w).ge(F16::ZERO).select3(p + ng * eps, p - ng * eps)
}

/// `diffuse::eval_pdf_cos(albedo, cos_i)` given `albedo.max_element()`: the factor cos θi / π
/// of the value (`albedo` times it) and the density.
#[inline(always)]
fn diffuse_pdf(albedo_max: F16, cos_i: F16) -> (F16, F16) {
    let c = FRAC_1_PI * cos_i.max(F16::ZERO);
    (c, (albedo_max.gt(F16::ZERO) & c.is_finite()).select(c, F16::ZERO))
}

/// `prepared::finish` in radiance mode: `value` where finite (at least 0), else 0.
#[inline(always)]
fn finish(value: V16) -> V16 {
    value.is_finite().select3(value.max_glam(V16::ZERO), V16::ZERO)
}

/// `warp::sin_cos_quarter`.
#[inline(always)]
fn sin_cos_quarter(x: F16) -> (F16, F16) {
    let x2 = x * x;
    let sin =
        x * (1.0 + x2 * (-1.0 / 6.0 + x2 * (1.0 / 120.0 + x2 * (-1.0 / 5040.0 + x2 * (1.0 / 362_880.0)))));
    let cos = 1.0 + x2 * (-0.5 + x2 * (1.0 / 24.0 + x2 * (-1.0 / 720.0 + x2 * (1.0 / 40_320.0))));
    (sin, cos)
}

/// `warp::cosine_hemisphere`, through `warp::concentric_disk`.
#[inline(always)]
fn cosine_hemisphere(ux: F16, uy: F16) -> V16 {
    let (ox, oy) = (2.0 * ux - 1.0, 2.0 * uy - 1.0);
    let centre = ox.eq(F16::ZERO) & oy.eq(F16::ZERO);
    let x_major = ox.abs().gt(oy.abs());
    let (rx, ry) = (x_major.select(ox, oy), x_major.select(oy, ox));
    let (sin, cos) = sin_cos_quarter((PI / 4.0) * (ry / rx));
    let (dx, dy) = (x_major.select(cos, sin), x_major.select(sin, cos));
    let (dx, dy) = (centre.select(F16::ZERO, rx * dx), centre.select(F16::ZERO, rx * dy));
    let z = (1.0 - (dx * dx + dy * dy)).max(F16::ZERO).sqrt();
    V16 { x: dx, y: dy, z }
}

/// Sixteen vertices' light samples and BSDF samples.
#[inline(always)]
fn shade(v: &Vertices) -> Shaded {
    let wo_ng = v.wo.dot(v.ng);
    let wo_ns = v.wo.dot(v.n);
    let albedo_max = v.albedo.max_element();

    // ---- Next-event estimation: `connect_emitters_at` with a triangle's point.
    let d = v.q - v.p;
    let dist2 = d.length_squared();
    let mut connects = dist2.gt(F16::ZERO) & dist2.is_finite();
    let wi = d / dist2.sqrt();
    let cos_light = v.nq.dot(-wi);
    // (Not `cos_light > 0`: the scalar code returns where `cos_light <= 0`, so a NaN goes on.)
    connects = connects & !F16::ZERO.ge(cos_light);
    // `PreparedBsdf::new` (active: both cosines of `wo` positive) and `eval_pdf`'s
    // `incident_cosines`.
    let wi_ng = wi.dot(v.ng);
    let wi_ns = wi.dot(v.n);
    connects =
        connects & wo_ng.gt(F16::ZERO) & wo_ns.gt(F16::ZERO) & wi_ng.gt(F16::ZERO) & wi_ns.gt(F16::ZERO);
    let (c, pdf_bsdf) = diffuse_pdf(albedo_max, wi_ns);
    let f = finish(v.albedo * c);
    connects = connects & !(f.x.eq(F16::ZERO) & f.y.eq(F16::ZERO) & f.z.eq(F16::ZERO));
    let pdf_light = v.pdf_area * dist2 / cos_light;
    // `power_heuristic(pdf_light, pdf_bsdf)`, and `Connection::value`.
    let (a2, b2) = (pdf_light * pdf_light, pdf_bsdf * pdf_bsdf);
    let sum = a2 + b2;
    let weight = a2.is_infinite().select(F16::splat(1.0), sum.gt(F16::ZERO).select(a2 / sum, F16::ZERO));
    let value = f.mul_v(v.le) * (weight / pdf_light);
    // `shadow_ray(p, ng, q, nq)`.
    let shadow_origin = offset_origin(v.p, v.ng, v.q - v.p);
    let shadow_end = offset_origin(v.q, v.nq, v.p - v.q);

    // ---- BSDF sampling: `sample_diffuse`, then `scatter`'s throughput.
    let local = cosine_hemisphere(v.ux, v.uy);
    let wi_s = v.s * local.x + v.t * local.y + v.n * local.z;
    let (wi_s_ng, wi_s_ns) = (wi_s.dot(v.ng), wi_s.dot(v.n));
    let (_, pdf) = diffuse_pdf(albedo_max, wi_s_ns);
    let weight_s = finish(v.albedo);
    let sampled = wo_ng.gt(F16::ZERO)
        & wo_ns.gt(F16::ZERO)
        & albedo_max.gt(F16::ZERO)
        & wi_s_ng.gt(F16::ZERO)
        & wi_s_ns.gt(F16::ZERO)
        & pdf.gt(F16::ZERO)
        // `finite_sample`.
        & weight_s.is_finite()
        & pdf.is_finite()
        & wi_s.is_finite();
    let beta = v.beta.mul_v(weight_s.max_glam(V16::ZERO));
    let alive = sampled & beta.max_element().gt(F16::ZERO) & beta.is_finite();

    Shaded {
        connects,
        shadow_origin,
        shadow_dir: shadow_end - shadow_origin,
        value,
        alive,
        beta,
        wi: wi_s,
        pdf,
        origin: offset_origin(v.p, v.ng, wi_s),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::{Frame, offset_origin as offset_origin_scalar};
    use crate::integrator::direct::{connect_point, power_heuristic};
    use crate::light::EmitterPoint;
    use crate::material::{Bsdf, TransportMode};
    use crate::sampling::{Domain, Sampler, cosine_hemisphere as cosine_scalar};

    /// The scalar code's light sample and BSDF sample at a Lambertian vertex: the walker's
    /// `connect_point` with `pt`'s power heuristic, and its `scatter`.
    fn scalar(
        sp: &SurfacePoint,
        wo: Vec3,
        albedo: Vec3,
        beta: Vec3,
        es: &EmitterSample,
        u: Vec2,
    ) -> (LightTerm, Option<Scattered>) {
        let bsdf = Bsdf::Diffuse { albedo };
        let light = match connect_point(sp, &bsdf, wo, es) {
            Some(c) => {
                LightTerm { shadow: c.shadow, value: c.value(|s| power_heuristic(s.pdf_light, s.pdf_bsdf)) }
            }
            None => LightTerm { shadow: None, value: Vec3::ZERO },
        };
        // (`scatter` with the numbers given: the sample, then the throughput's checks.)
        let scattered = bsdf.sample(&sp.geometry(), wo, 0.5, u, TransportMode::Radiance).and_then(|s| {
            let beta = beta * s.weight;
            (beta.max_element() > 0.0 && beta.is_finite()).then(|| Scattered {
                beta,
                wi: s.wi,
                pdf: s.pdf,
                origin: offset_origin_scalar(sp.p, sp.ng, s.wi),
            })
        });
        (light, scattered)
    }

    fn unit(rng: &mut Sampler) -> Vec3 {
        loop {
            let v = 2.0 * Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) - 1.0;
            if v.length_squared() > 0.01 {
                return v.normalize();
            }
        }
    }

    /// The same bits, or both NaN (whose payload depends on the order of an instruction's
    /// operands, which the compiler may swap; a NaN is dropped from the image either way).
    fn same_bits(a: Vec3, b: Vec3) -> bool {
        a.to_array()
            .iter()
            .zip(b.to_array())
            .all(|(x, y)| x.to_bits() == y.to_bits() || (x.is_nan() && y.is_nan()))
    }

    /// Random vertices, emitter points and numbers, with the awkward cases mixed in (`wo`
    /// and the emitter behind the surface, a shading normal off the geometric one, black
    /// and non-finite albedos, the emitter point on the vertex, the disk's centre): each lane
    /// gives what the scalar code gives, bit for bit.
    #[test]
    fn matches_the_scalar_vertex() {
        let mut rng = Sampler::new(7, 1, Domain::Iteration, 0);
        let (mut connecting, mut alive) = (0, 0);
        for round in 0..400 {
            let mut lanes = Lanes::default();
            let mut cases = Vec::new();
            for k in 0..37 {
                let ng = unit(&mut rng);
                let ns = if k % 3 == 0 { (ng + 0.3 * unit(&mut rng)).normalize() } else { ng };
                let p = 10.0 * (Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) - 0.5);
                let sp = SurfacePoint {
                    p,
                    ng,
                    frame: Frame::from_normal(ns),
                    prim: 0,
                    material: 0,
                    uv: Vec2::ZERO,
                    back: false,
                };
                let wo = if k % 5 == 0 { unit(&mut rng) } else { (ng + unit(&mut rng)).normalize() };
                let albedo = match k % 11 {
                    0 => Vec3::ZERO,
                    1 => Vec3::new(f32::INFINITY, 0.5, 0.5),
                    _ => Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()),
                };
                let q = if k % 13 == 0 {
                    p
                } else {
                    10.0 * (Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) - 0.5)
                };
                let nq = match k % 19 {
                    0 => Vec3::new(f32::NAN, 0.0, 1.0),
                    1 => Vec3::new(-0.0, -0.0, -1.0),
                    _ => unit(&mut rng),
                };
                let radiance = match k % 23 {
                    0 => Vec3::new(f32::INFINITY, 1.0, 1.0),
                    _ => Vec3::new(1.0 + rng.next_f32(), 2.0, 3.0 * rng.next_f32()),
                };
                let pdf_area = match k % 29 {
                    0 => 0.0,
                    1 => f32::INFINITY,
                    _ => 0.1 + rng.next_f32(),
                };
                let es = EmitterSample {
                    point: EmitterPoint { p: q, ng: nq, prim: 0 },
                    radiance,
                    pdf_area,
                    // (Next-event estimation's density differs from the light paths' where
                    // it picks by importance; the lanes take the former, as the scalar code.)
                    pdf_start: if k % 3 == 0 { 2.0 * pdf_area } else { pdf_area },
                };
                let u =
                    if k % 17 == 0 { Vec2::splat(0.5) } else { Vec2::new(rng.next_f32(), rng.next_f32()) };
                let beta = Vec3::new(rng.next_f32(), 1.0, if round % 7 == 0 { f32::NAN } else { 0.5 });
                lanes.push(k as u32, &sp, wo, albedo, beta, &es, u);
                cases.push((sp, wo, albedo, beta, es, u));
            }
            lanes.shade();
            for (k, (sp, wo, albedo, beta, es, u)) in cases.iter().enumerate() {
                let (light, scattered) = scalar(sp, *wo, *albedo, *beta, es, *u);
                let lane = lanes.light_sample(k);
                assert_eq!(lane.shadow.is_some(), light.shadow.is_some(), "round {round}, vertex {k}");
                if let (Some(a), Some(b)) = (lane.shadow, light.shadow) {
                    assert!(
                        same_bits(a.origin, b.origin) && same_bits(a.dir, b.dir),
                        "round {round}, vertex {k}"
                    );
                    assert!(same_bits(Vec3::new(a.tmin, a.tmax, 0.0), Vec3::new(b.tmin, b.tmax, 0.0)));
                    connecting += 1;
                }
                assert!(same_bits(lane.value, light.value), "round {round}, vertex {k}: {lane:?} {light:?}");
                let lane = lanes.scattered(k);
                assert_eq!(lane.is_some(), scattered.is_some(), "round {round}, vertex {k}");
                if let (Some(a), Some(b)) = (lane, scattered) {
                    assert!(
                        same_bits(a.beta, b.beta)
                            && same_bits(a.wi, b.wi)
                            && same_bits(Vec3::splat(a.pdf), Vec3::splat(b.pdf))
                            && same_bits(a.origin, b.origin),
                        "round {round}, vertex {k}: {a:?} {b:?}"
                    );
                    alive += 1;
                }
                assert!(same_bits(lanes.beta(k), *beta) && lanes.point(k) == sp.p);
            }
        }
        // Both outcomes of both samples were taken many times.
        assert!(connecting > 2000 && connecting < 12000, "{connecting}");
        assert!(alive > 2000 && alive < 12000, "{alive}");
    }

    /// The lanes' cosine-weighted directions are the scalar warp's, bit for bit, over a grid
    /// of the unit square with its edges and centre.
    #[test]
    fn cosine_directions_are_the_scalar_ones() {
        let n = 65;
        let grid: Vec<Vec2> =
            (0..n * n).map(|k| Vec2::new((k % n) as f32, (k / n) as f32) / (n - 1) as f32).collect();
        for chunk in grid.chunks(W) {
            let (mut ux, mut uy) = (F16::ZERO, F16::ZERO);
            for (i, u) in chunk.iter().enumerate() {
                (ux.0[i], uy.0[i]) = (u.x, u.y);
            }
            let d = cosine_hemisphere(ux, uy);
            for (i, &u) in chunk.iter().enumerate() {
                assert!(
                    same_bits(d.get(i), cosine_scalar(u)),
                    "{u}: {} against {}",
                    d.get(i),
                    cosine_scalar(u)
                );
            }
        }
    }
}
