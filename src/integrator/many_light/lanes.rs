//! This iteration's point lights laid out in lanes (structure of arrays, [`LANES`] lights per
//! chunk) for the gather's hot loop: one receiver against every VPL.
//!
//! The common case, a Lambertian receiver and a Lambertian VPL, is computed for a whole chunk
//! at once with glam's `Vec4` (SSE), without branches: written per VPL with
//! [`PreparedBsdf::eval`] it is a chain of calls, early returns and `Vec3`s passed through
//! memory that cost more than the shadow rays themselves, and written as plain per-lane code
//! the compiler does not vectorise it (profile in `docs/measurements.md`). Every lane
//! performs exactly the floating-point operations of `points::point_contribution` in the
//! same order (SSE
//! arithmetic is IEEE per lane, and Rust never fuses or reorders), and a failed check
//! anywhere masks the lane to zero where the scalar code returns zero early, so the result is
//! bit-identical (`matches_the_scalar_contribution` below). Other VPLs (glossy ones) are
//! [`LaneKind::Other`]: the caller evaluates them one by one.

use glam::{Vec3, Vec4};
use std::f32::consts::FRAC_1_PI;

use multiversion::multiversion;

use super::bidirectional::DrawWeights;
use super::light_paths::Vpl;
use super::lobe::Lobe;
use super::resample::Candidates;
use super::window::Window;
use crate::geometry::OffsetPoint;
use crate::material::{PreparedBsdf, PreparedDiffuse, TransportMode, shading_correction};
use crate::scene::SurfacePoint;

pub use super::resample::LANES;

/// How a lane's light is evaluated.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LaneKind {
    /// No light (padding of the last chunk) or one whose BSDF emits nothing.
    Empty,
    /// A Lambertian VPL: computed by [`VplLanes::diffuse_contributions`].
    Diffuse,
    /// Any other BSDF: the caller evaluates it.
    Other,
}

/// What every kind of lane takes from its VPL, a coordinate per `Vec4`: position, geometric
/// and shading normals, and flux. Shared by these lanes and the spheres'
/// ([`super::sphere_lanes`]).
#[derive(Clone, Copy, Debug)]
pub(super) struct VplCoords {
    pub p: [Vec4; 3],
    pub ng: [Vec4; 3],
    /// Shading normal.
    pub ns: [Vec4; 3],
    pub flux: [Vec4; 3],
}

impl VplCoords {
    pub const ZERO: VplCoords =
        VplCoords { p: [Vec4::ZERO; 3], ng: [Vec4::ZERO; 3], ns: [Vec4::ZERO; 3], flux: [Vec4::ZERO; 3] };

    /// Lane `i` from `v`.
    pub fn set(&mut self, i: usize, v: &Vpl) {
        for k in 0..3 {
            self.p[k][i] = v.p[k];
            self.ng[k][i] = v.ng[k];
            self.ns[k][i] = v.frame.n[k];
            self.flux[k][i] = v.flux[k];
        }
    }
}

/// [`LANES`] lights, coordinate by coordinate.
#[derive(Clone, Copy)]
struct Chunk {
    vpl: VplCoords,
    /// The emitting BSDF ([`PreparedDiffuse`], importance mode).
    albedo: [Vec4; 3],
    wo_cos_shading: Vec4,
    wo_cos_geometric: Vec4,
    /// Segments from the emitter, as a float (exact below 2^24); infinite in lanes that are
    /// not [`LaneKind::Diffuse`], so that the depth test masks them too.
    depth: Vec4,
    kind: [LaneKind; LANES],
    /// Σ over RGB of Φ × the BSDF's reflectance ([`super::light_set::tree_light`]'s
    /// intensity; 0 for a light that emits nothing), for the resampled gather's estimates.
    power: Vec4,
    /// Segments from the emitter, every non-empty lane; infinite in empty ones.
    any_depth: Vec4,
    /// 1 where the light's BSDF transmits ([`crate::material::Bsdf::transmits`]: it emits
    /// to both sides of its surface), else 0.
    transmits: Vec4,
    /// The light's side of the connection weight in the estimates
    /// ([`super::bidirectional::draw_term`]; zeros where the gather does not weigh).
    weight_terms: Vec4,
}

/// The range of the scale of a glossy light's estimate by its lobe ([`PairLobes`]): at least
/// 2⁻²⁰, so that a light that contributes keeps a positive estimate, and at most 2²⁰, so
/// that it stays finite (a non-finite estimate is left out).
const LOBE_SCALE: (f32, f32) = (1.0 / 1_048_576.0, 1_048_576.0);

const EMPTY_CHUNK: Chunk = Chunk {
    vpl: VplCoords::ZERO,
    albedo: [Vec4::ZERO; 3],
    wo_cos_shading: Vec4::ZERO,
    wo_cos_geometric: Vec4::ZERO,
    depth: Vec4::INFINITY,
    kind: [LaneKind::Empty; LANES],
    power: Vec4::ZERO,
    any_depth: Vec4::INFINITY,
    transmits: Vec4::ZERO,
    weight_terms: Vec4::ZERO,
};

/// A Lambertian receiver in radiance mode, the other end of every lane.
#[derive(Clone, Copy, Debug)]
pub struct DiffuseReceiver {
    p: Vec3,
    ng: Vec3,
    ns: Vec3,
    albedo: Vec3,
}

impl DiffuseReceiver {
    /// `None` unless `fx` (the receiver's BSDF prepared for its `wo`) is an active
    /// Lambertian BSDF in radiance mode.
    pub fn new(sp: &SurfacePoint, fx: &PreparedBsdf) -> Option<Self> {
        let d = fx.as_diffuse().filter(|d| d.mode == TransportMode::Radiance)?;
        Some(DiffuseReceiver { p: sp.p, ng: sp.ng, ns: sp.frame.n, albedo: d.albedo })
    }
}

/// The VPLs of one iteration in chunks of [`LANES`], with the offset ends of their shadow
/// rays.
#[derive(Default)]
pub struct VplLanes {
    chunks: Vec<Chunk>,
    ends: Vec<OffsetPoint>,
    /// Chunk `c`'s and `c + 1`'s lanes, for every chunk `c`.
    pairs: Vec<PairLanes>,
    /// Their lobes, for every chunk `c` (empty where no light has one).
    pair_lobes: Vec<PairLobes>,
}

/// What the resampled gather's estimates read ([`VplLanes::push_estimates`]) of two
/// consecutive chunks, `c` and `c + 1`, lane by lane: eight lanes, one 8-wide load per
/// coordinate. Every chunk has its pair (the last one's second half is empty), so that a
/// window can take its chunks two at a time from any chunk on; each lane is stored twice,
/// some 350 bytes per chunk.
#[derive(Clone, Copy)]
struct PairLanes {
    p: [[f32; 8]; 3],
    ng: [[f32; 8]; 3],
    /// Shading normal.
    ns: [[f32; 8]; 3],
    /// As [`Chunk::power`].
    power: [f32; 8],
    /// As [`Chunk::any_depth`].
    any_depth: [f32; 8],
    /// As [`Chunk::transmits`].
    transmits: [f32; 8],
    /// Whether any of its lights transmits.
    any_transmits: bool,
    /// As [`Chunk::weight_terms`].
    weight_terms: [f32; 8],
    /// Whether any of its lights has a lobe ([`PairLobes`]).
    any_lobe: bool,
}

/// The lobes of the glossy lights of two consecutive chunks, lane by lane as [`PairLanes`]
/// (kept apart from them: read only where a pair has a glossy light), for the resampled
/// gather's estimates. A light's power there takes the BSDF's reflectance ρ̄ (channel mean)
/// for π f, which a lobe's f misses by far both ways; with its lobe ([`Lobe`] of its BSDF for
/// its incoming direction, by reciprocity the lobe it reflects into), π f ≈ ρ_d + π f_lobe,
/// f_lobe its bound towards the receiver ([`Lobe::bound`] over the light's cosine), so the
/// power is scaled by (ρ_d / π + f_lobe) π / ρ̄. Lanes without a lobe scale by exactly 1.
#[derive(Clone, Copy)]
struct PairLobes {
    /// 1 where the light has a lobe, else 0.
    glossy: [f32; 8],
    mirror: [[f32; 8]; 3],
    inv_alpha2: [f32; 8],
    /// The lobe's peak ([`Lobe::peak`]) times π / ρ̄.
    peak: [f32; 8],
    /// ρ_d / π times π / ρ̄.
    diffuse: [f32; 8],
}

impl PairLobes {
    /// The lanes of chunks `c` and `c + 1`, lights 4c to 4c + 7, from each light's lobe and
    /// mean reflectance ρ̄ (none past the last light or where it has no lobe).
    fn new(lobes: &[Option<(Lobe, f32)>], c: usize) -> Self {
        let lane = |l: usize| lobes.get(c * LANES + l).copied().flatten();
        let scaled = |l: usize, f: fn(&Lobe) -> f32, none: f32| {
            lane(l).map_or(none, |(lobe, rho)| f(&lobe) * (std::f32::consts::PI / rho))
        };
        PairLobes {
            glossy: std::array::from_fn(|l| if lane(l).is_some() { 1.0 } else { 0.0 }),
            mirror: std::array::from_fn(|k| {
                std::array::from_fn(|l| lane(l).map_or(0.0, |(o, _)| o.mirror()[k]))
            }),
            inv_alpha2: std::array::from_fn(|l| lane(l).map_or(1.0, |(o, _)| o.inv_alpha2())),
            peak: std::array::from_fn(|l| scaled(l, Lobe::peak, 0.0)),
            diffuse: std::array::from_fn(|l| scaled(l, Lobe::diffuse, 1.0)),
        }
    }
}

/// Lanes `x` then `y`, eight wide.
fn join(x: Vec4, y: Vec4) -> [f32; 8] {
    let (x, y) = (x.to_array(), y.to_array());
    std::array::from_fn(|l| if l < LANES { x[l] } else { y[l - LANES] })
}

impl PairLanes {
    /// The pair of chunks `c` and `c + 1` of `chunks` (an empty chunk past the last), with a
    /// glossy light among them where `any_lobe`.
    fn new(chunks: &[Chunk], c: usize, any_lobe: bool) -> Self {
        let (a, b) = (&chunks[c], chunks.get(c + 1).unwrap_or(&EMPTY_CHUNK));
        PairLanes {
            p: std::array::from_fn(|k| join(a.vpl.p[k], b.vpl.p[k])),
            ng: std::array::from_fn(|k| join(a.vpl.ng[k], b.vpl.ng[k])),
            ns: std::array::from_fn(|k| join(a.vpl.ns[k], b.vpl.ns[k])),
            power: join(a.power, b.power),
            any_depth: join(a.any_depth, b.any_depth),
            transmits: join(a.transmits, b.transmits),
            any_transmits: (a.transmits + b.transmits).max_element() > 0.0,
            weight_terms: join(a.weight_terms, b.weight_terms),
            any_lobe,
        }
    }
}

/// The receiver's side of the resampled gather's estimates ([`VplLanes::push_estimates`]):
/// its position, geometric and shading normals, the iteration's bound, the deepest light it
/// gathers from and its glossy lobe, if any.
#[derive(Clone, Copy)]
pub struct EstimateReceiver<'a> {
    pub x: Vec3,
    pub ng: Vec3,
    pub ns: Vec3,
    pub bound: f32,
    pub max_depth: u32,
    pub lobe: Option<&'a Lobe>,
    /// Whether its BSDF transmits ([`crate::material::Bsdf::transmits`]): it receives from
    /// both sides of its surface.
    pub transmits: bool,
    /// The receiver's side of the connection weight, where the estimates include it
    /// (`pir-bdpt`, [`DrawWeights`]).
    pub weights: Option<DrawWeights>,
}

/// The smallest connection weight the resampled gather's estimates take
/// ([`DrawWeights`]): 2⁻²⁰.
pub const MIN_DRAW_WEIGHT: f32 = 1.0 / 1_048_576.0;

/// `a` if it is smaller, else `b`: SSE's `minps`, which glam's `Vec4::min` is.
#[inline(always)]
fn min(a: f32, b: f32) -> f32 {
    if a < b { a } else { b }
}

/// `a` if it is larger, else `b`: SSE's `maxps`, which glam's `Vec4::max` is.
#[inline(always)]
fn max(a: f32, b: f32) -> f32 {
    if a > b { a } else { b }
}

/// [`VplLanes::push_estimates`], compiled for AVX2 as well as for the build's target and
/// picked at run time by the CPU's features, as the BVH's traversal is: the kernel's plain
/// loops over eight lanes become one `ymm` operation per step in the AVX2 version and two
/// SSE operations in the other, the same IEEE operations either way (no fused multiply-add:
/// Rust never contracts), so both give the same estimates bit for bit.
#[multiversion(targets("x86_64+avx2+fma"))]
fn push_estimates_dispatch(lanes: &VplLanes, cands: &mut Candidates, window: &Window, r: &EstimateReceiver) {
    let (lo, hi) = (window.lights.start, window.lights.end);
    let end = hi.div_ceil(LANES);
    for b in (lo / LANES..end).step_by(2) {
        // Ends that transmit are rare: the kernel for them only where there are some.
        let mut p = if r.transmits || lanes.pairs[b].any_transmits {
            lanes.estimates8::<true>(b, r)
        } else {
            lanes.estimates8::<false>(b, r)
        };
        // The window's first and last pair may hold lights of other windows: left out.
        let first = b * LANES;
        if first < lo || first + 2 * LANES > hi {
            for (p, inside) in p.iter_mut().zip(window.inside::<8>(first)) {
                if !inside {
                    *p = 0.0;
                }
            }
        }
        cands.push(first, Vec4::from_slice(&p[..LANES]));
        if b + 1 < end {
            cands.push(first + LANES, Vec4::from_slice(&p[LANES..]));
        }
    }
}

impl VplLanes {
    /// `emitting[j]` is VPL `j`'s BSDF prepared for its incoming direction (importance mode),
    /// `power[j]` its power for the estimates ([`Self::push_estimates`]), `weight_terms[j]`
    /// its side of the connection weight there (empty: none,
    /// [`super::bidirectional::draw_term`]).
    pub fn new(vpls: &[Vpl], emitting: &[PreparedBsdf], power: &[f32], weight_terms: &[f32]) -> Self {
        assert_eq!(vpls.len(), emitting.len());
        assert_eq!(vpls.len(), power.len());
        assert!(weight_terms.is_empty() || weight_terms.len() == vpls.len());
        let mut chunks = vec![EMPTY_CHUNK; vpls.len().div_ceil(LANES)];
        // Each light's lobe with its BSDF's mean reflectance, where it has one ([`PairLobes`]).
        let mut lobes: Vec<Option<(Lobe, f32)>> = vec![None; vpls.len()];
        for (j, (v, e)) in vpls.iter().zip(emitting).enumerate() {
            let (c, i) = (&mut chunks[j / LANES], j % LANES);
            c.vpl.set(i, v);
            c.kind[i] = match e.as_diffuse() {
                Some(d) if d.mode == TransportMode::Importance => {
                    Self::set_diffuse(c, i, &d);
                    c.depth[i] = v.depth as f32;
                    LaneKind::Diffuse
                }
                _ if e.is_active() => LaneKind::Other,
                _ => LaneKind::Empty,
            };
            if c.kind[i] != LaneKind::Empty {
                c.power[i] = power[j];
                c.any_depth[i] = v.depth as f32;
                let bsdf = e.bsdf();
                c.transmits[i] = if bsdf.transmits() { 1.0 } else { 0.0 };
                c.weight_terms[i] = weight_terms.get(j).copied().unwrap_or(0.0);
                let rho = bsdf.reflectance().max(Vec3::ZERO).element_sum() / 3.0;
                lobes[j] = Lobe::of(bsdf, v.frame.n, v.w_in)
                    .filter(|_| rho > 0.0 && rho.is_finite())
                    .map(|o| (o, rho));
            }
        }
        let ends = vpls.iter().map(|v| OffsetPoint::new(v.p, v.ng)).collect();
        let pair_lobes: Vec<PairLobes> = if lobes.iter().any(Option::is_some) {
            (0..chunks.len()).map(|c| PairLobes::new(&lobes, c)).collect()
        } else {
            Vec::new()
        };
        let pairs = (0..chunks.len())
            .map(|c| PairLanes::new(&chunks, c, pair_lobes.get(c).is_some_and(|o| o.glossy.contains(&1.0))))
            .collect();
        VplLanes { chunks, ends, pairs, pair_lobes }
    }

    fn set_diffuse(c: &mut Chunk, i: usize, d: &PreparedDiffuse) {
        for k in 0..3 {
            c.albedo[k][i] = d.albedo[k];
        }
        c.wo_cos_shading[i] = d.wo_cos_shading;
        c.wo_cos_geometric[i] = d.wo_cos_geometric;
    }

    pub fn chunks(&self) -> usize {
        self.chunks.len()
    }

    /// How VPL `j` is evaluated.
    pub fn kind(&self, j: usize) -> LaneKind {
        self.chunks[j / LANES].kind[j % LANES]
    }

    /// Whether chunk `chunk` has a [`LaneKind::Other`] light, which the kernel leaves out.
    #[inline]
    pub fn has_other(&self, chunk: usize) -> bool {
        self.chunks[chunk].kind.contains(&LaneKind::Other)
    }

    /// A cheap estimate p̂ of each lane's contribution at a receiver at `x` with geometric
    /// normal `ng` and shading normal `ns`, for the resampled gather
    /// ([`super::resample`]): power × min(G, `bound`), with G = cos_x cos_p / d², cos_x from
    /// the receiver's shading normal and cos_p from the light's geometric one (power holds the
    /// light's adjoint correction factor, [`super::light_set::tree_light`]: together the
    /// light's side is exact for a Lambertian VPL), where both shading and both geometric
    /// cosines are positive and the light has at most `max_depth` segments; zero elsewhere. With a receiver's `lobe`
    /// ([`Lobe`]) the receiver's f enters: power × (ρ_d/π · min(G, `bound`) + ρ_s D(θ/2) /
    /// (4 cos θ_o) · min(G, `bound`) / cos θ_x), θ the angle between the direction to the light
    /// and the mirror direction, the lobe's bound on f · cos θ_i (unclamped, an upper bound of
    /// the receiver's side). It leaves out the shape of a glossy VPL's BSDF, so it is not the
    /// contribution, but it is positive wherever the
    /// contribution is (every BSDF of a VPL or a receiver reflects only into the hemisphere of
    /// both its normals), which is all that unbiasedness needs.
    ///
    /// Chunks `chunk` and `chunk + 1` (zeros past the last), as plain loops over their eight
    /// lanes that LLVM vectorises: without a lobe, every lane performs the operations of the
    /// four-wide kernel (glam's `Vec4`) this replaced, in its order (glam's `Vec4::min`, `max`
    /// and `clamp` are `minps` and `maxps`, [`min`] and [`max`] here), so the estimates, and
    /// the picks and images, are the same bit for bit (the gain:
    /// `docs/integrator-measurements.md`, "Eight-wide estimates"). With a lobe the bound is
    /// computed with one division and one square root per lane instead of three and one (the
    /// same number up to rounding): it made the gather's estimates nearly twice as costly,
    /// 13.6 % of a `pir-bdpt` render of the glossy corner against 24.4 % (`perf`).
    ///
    /// With the receiver's `weights` (`pir-bdpt`), the value is times the connection's weight
    /// 1 / (1 + h) ([`DrawWeights`]), at least [`MIN_DRAW_WEIGHT`], without a lobe as one
    /// quotient G / (1 + h). That costs
    /// the estimates a division on the path to their result: 3–4 % of a render in the
    /// diffuse corner (`docs/results.md`, "The connection's weight in the gather's draw").
    #[inline(always)]
    fn estimates8<const TRANSMITS: bool>(&self, chunk: usize, r: &EstimateReceiver) -> [f32; 8] {
        const W: usize = 2 * LANES;
        let q = &self.pairs[chunk];
        let ([px, py, pz], [gx, gy, gz], [sx, sy, sz]) = (q.p, q.ng, q.ns);
        let (power, any_depth, transmits) = (q.power, q.any_depth, q.transmits);
        let (x, ng, ns) = (r.x, r.ng, r.ns);
        // The connections' weights without a lobe or a bound on G (`pir-bdpt` at a Lambertian
        // or wide glossy receiver) enter G in one quotient; with a lobe, after it.
        let plain = r.weights.filter(|_| r.lobe.is_none() && r.bound == f32::INFINITY);
        let terms = q.weight_terms;
        let (mut dx, mut dy, mut dz, mut dist2) = ([0.0; W], [0.0; W], [0.0; W], [0.0; W]);
        let (mut x_ng, mut x_ns, mut p_ng, mut p_ns, mut g) =
            ([0.0; W], [0.0; W], [0.0; W], [0.0; W], [0.0; W]);
        // Lane `l`'s offset to the light, its squared length and the four cosines times |d|.
        // Written into each case's loop, so that each stays one loop that LLVM vectorises
        // eight wide (as two loops, the geometry's and G's, it went four wide: 5 % slower).
        macro_rules! geometry {
            ($l:ident) => {
                dx[$l] = px[$l] - x.x;
                dy[$l] = py[$l] - x.y;
                dz[$l] = pz[$l] - x.z;
                dist2[$l] = dx[$l] * dx[$l] + dy[$l] * dy[$l] + dz[$l] * dz[$l];
                x_ng[$l] = dx[$l] * ng.x + dy[$l] * ng.y + dz[$l] * ng.z;
                x_ns[$l] = dx[$l] * ns.x + dy[$l] * ns.y + dz[$l] * ns.z;
                p_ng[$l] = -(dx[$l] * gx[$l] + dy[$l] * gy[$l] + dz[$l] * gz[$l]);
                p_ns[$l] = -(dx[$l] * sx[$l] + dy[$l] * sy[$l] + dz[$l] * sz[$l]);
            };
        }
        if let Some(wt) = plain {
            for l in 0..W {
                geometry!(l);
                // G / (1 + h), h the weight's ([`DrawWeights`]), = cos_x^s cos_y^g / (d⁴ +
                // cos_x^s cos_y^g T_y L + cos_y^s cos_x^g C_x) with the cosines times |d|: one
                // division. The weight is taken at least [`MIN_DRAW_WEIGHT`] (the denominator
                // at most d⁴ / it; a NaN one becomes that too), so that a light that
                // contributes keeps at least that share of its estimate without the weight,
                // which an estimated weight may miss by far (a glossy end); a quotient that
                // underflows keeps the smallest positive number (`max`). A light whose G
                // overflows stays infinite (left out, as without the weights).
                // (Absolute values: the same numbers where the lanes face each other, and the
                // transmitting ends' where they face away.)
                let d4 = dist2[l] * dist2[l];
                let a = (x_ns[l] * p_ng[l]).abs();
                let b = (p_ns[l] * x_ng[l]).abs();
                // (Summed in this order so that the terms that do not wait for `a` go first:
                // the quotient ends a shorter chain.)
                let den = min((d4 + b * wt.camera) + a * (terms[l] * wt.light), d4 * (1.0 / MIN_DRAW_WEIGHT));
                let weighted = max(a / den, min(a, f32::MIN_POSITIVE));
                g[l] = if a <= d4 * f32::MAX { weighted } else { f32::INFINITY };
            }
        } else {
            for l in 0..W {
                geometry!(l);
                g[l] = if TRANSMITS {
                    // The geometry term as the contribution clamps it, with the shading cosines;
                    // the light's shading cosine times its adjoint correction is its geometric
                    // cosine times the correction's constant factor, which `power` holds, so the
                    // clamped term is scaled by cos_g / cos_s at the light (exactly 1 where the
                    // normals agree). Where an end may transmit (`TRANSMITS`), absolute values:
                    // it sees the other end from behind (the same numbers where the cosines are
                    // positive).
                    min((x_ns[l] * p_ns[l]).abs() / (dist2[l] * dist2[l]), r.bound)
                        * (p_ng[l] / p_ns[l]).abs()
                } else {
                    min(x_ns[l] * p_ns[l] / (dist2[l] * dist2[l]), r.bound) * (p_ng[l] / p_ns[l])
                };
            }
        }
        let mut value = g;
        // The receiver's sampling density towards each light over a Lambertian one's (1
        // without a lobe), for the weights below.
        let mut sampling = [1.0; W];
        if let Some(lobe) = r.lobe {
            let m = lobe.mirror();
            let diffuse = lobe.diffuse();
            let (peak, inv_a2) = (lobe.peak(), lobe.inv_alpha2());
            for l in 0..W {
                // Inactive lanes (dist2 = 0 among them) are masked below.
                let dist = dist2[l].sqrt();
                // [`Lobe::bound`] of cos θ = r·d / |d| is peak / t², t = (1 − cos θ)/α² +
                // 1 + cos θ; here t |d|, from r·d without dividing (each part at least 0, as
                // the clamp of cos θ to [−1, 1] keeps them).
                let along = dx[l] * m.x + dy[l] * m.y + dz[l] * m.z;
                let t = max(dist - along, 0.0) * inv_a2 + max(dist + along, 0.0);
                // The lobe's bound holds the receiver's cosine (f · cos θ_x): the clamped
                // term without it, g |d| / (d·n_x), so that the bound holds when clamped too;
                // with the bound's 1/t², one division: g · peak |d|³ / ((t |d|)² (d·n_x)).
                // (At least the smallest normal float, so that where |d|³ / α⁴ overflows, a
                // light tens of millions of units away from a receiver of the smallest α, the
                // lobe's term cannot become 0 and leave out a light that contributes.)
                let cos_x = if TRANSMITS { x_ns[l].abs() } else { x_ns[l] };
                let lobe_term = max(peak * dist2[l] * dist / (t * t * cos_x), f32::MIN_POSITIVE);
                value[l] = diffuse * g[l] + g[l] * lobe_term;
                sampling[l] = lobe.sampling(lobe_term);
            }
        }
        if let Some(wt) = r.weights.filter(|_| plain.is_none()) {
            // The weight after the lobe: 1 / (1 + h), h = (cos_x^s cos_y^g T_y L + cos_y^s
            // cos_x^g C_x) / d⁴ (the cosines times |d|), with the same bound and care for
            // overflow as above; at a glossy receiver the first term times its sampling
            // density over a Lambertian one's (BSDF sampling takes the paths in its lobe).
            for l in 0..W {
                let light = terms[l] * wt.light * sampling[l];
                let h = (x_ns[l] * p_ng[l] * light + p_ns[l] * x_ng[l] * wt.camera) / (dist2[l] * dist2[l]);
                let h = min(if TRANSMITS { h.abs() } else { h }, 1.0 / MIN_DRAW_WEIGHT);
                let weighted = max(value[l] / (1.0 + h), min(value[l], f32::MIN_POSITIVE));
                value[l] = if value[l] < f32::INFINITY { weighted } else { value[l] };
            }
        }
        if q.any_lobe {
            // Glossy lights by their lobes ([`PairLobes`]): the power times (ρ_d / π + f_lobe)
            // π / ρ̄, f_lobe = peak / (t² cos_y) as the receiver's lobe above (t |d| here,
            // from the light's mirror direction and the way to the receiver, −d).
            let o = &self.pair_lobes[chunk];
            for l in 0..W {
                let dist = dist2[l].sqrt();
                let along = -(dx[l] * o.mirror[0][l] + dy[l] * o.mirror[1][l] + dz[l] * o.mirror[2][l]);
                let t = max(dist - along, 0.0) * o.inv_alpha2[l] + max(dist + along, 0.0);
                let cos_y = if TRANSMITS { p_ns[l].abs() } else { p_ns[l] };
                let scale = o.diffuse[l] + o.peak[l] * dist2[l] * dist / (t * t * cos_y);
                // (A NaN, where the lane is inactive, becomes the least.)
                let scale = min(max(scale, LOBE_SCALE.0), LOBE_SCALE.1);
                value[l] = if o.glossy[l] != 0.0 { value[l] * scale } else { value[l] };
            }
        }
        let max_depth = r.max_depth as f32;
        let mut out = [0.0; W];
        for l in 0..W {
            // Each end in front of the other, or behind it where that end transmits (on the
            // same side of both its normals either way).
            let (x_side, p_side) = if TRANSMITS {
                (
                    ((x_ng[l] > 0.0) & (x_ns[l] > 0.0)) | (r.transmits & (x_ng[l] < 0.0) & (x_ns[l] < 0.0)),
                    ((p_ng[l] > 0.0) & (p_ns[l] > 0.0))
                        | ((transmits[l] != 0.0) & (p_ng[l] < 0.0) & (p_ns[l] < 0.0)),
                )
            } else {
                ((x_ng[l] > 0.0) & (x_ns[l] > 0.0), (p_ng[l] > 0.0) & (p_ns[l] > 0.0))
            };
            let active = (any_depth[l] <= max_depth) & x_side & p_side & (dist2[l] > 0.0);
            out[l] = if active { power[l] * value[l] } else { 0.0 };
        }
        out
    }

    /// [`Self::estimates8`] of one chunk, for the tests.
    #[cfg(test)]
    #[allow(clippy::too_many_arguments)]
    pub fn estimates(
        &self,
        chunk: usize,
        x: Vec3,
        ng: Vec3,
        ns: Vec3,
        bound: f32,
        max_depth: u32,
        lobe: Option<&Lobe>,
    ) -> Vec4 {
        let r = EstimateReceiver { x, ng, ns, bound, max_depth, lobe, transmits: false, weights: None };
        Vec4::from_slice(&self.estimates_for(chunk, &r)[..LANES])
    }

    /// The estimates of chunks `chunk` and `chunk + 1` at the receiver `r`, for the tests.
    #[cfg(test)]
    pub fn estimates_for(&self, chunk: usize, r: &EstimateReceiver) -> [f32; 8] {
        self.estimates8::<false>(chunk, r)
    }

    /// Pushes the estimates p̂ of the window's lights to `cands` (the private `estimates8`
    /// says what they are), in light order, two chunks at a time.
    pub fn push_estimates(&self, cands: &mut Candidates, window: &Window, r: &EstimateReceiver) {
        push_estimates_dispatch(self, cands, window, r);
    }

    /// VPL `j`'s end of its shadow rays.
    pub fn end(&self, j: usize) -> &OffsetPoint {
        &self.ends[j]
    }

    /// Φ f_p cos_p f_x cos_x / d², G clamped at `bound`, of every [`LaneKind::Diffuse`] light
    /// of chunk `chunk` of at most `max_depth` segments at receiver `x`, lane by
    /// lane; zero in the other lanes. Bit-identical to `points::point_contribution`.
    #[inline]
    pub fn diffuse_contributions(
        &self,
        chunk: usize,
        x: &DiffuseReceiver,
        bound: f32,
        max_depth: u32,
    ) -> [Vec3; LANES] {
        let [r, g, b] = self.diffuse_channels(chunk, x, bound, max_depth);
        std::array::from_fn(|i| Vec3::new(r[i], g[i], b[i]))
    }

    /// [`Self::diffuse_contributions`] channel by channel: red, green and blue of the lanes.
    #[inline]
    pub fn diffuse_channels(
        &self,
        chunk: usize,
        x: &DiffuseReceiver,
        bound: f32,
        max_depth: u32,
    ) -> [Vec4; 3] {
        let q = &self.chunks[chunk];
        let s = Vec4::splat;
        let zero = Vec4::ZERO;
        // d = vpl.p − x, w = d / |d|.
        let dx = q.vpl.p[0] - s(x.p.x);
        let dy = q.vpl.p[1] - s(x.p.y);
        let dz = q.vpl.p[2] - s(x.p.z);
        let dist2 = dx * dx + dy * dy + dz * dz;
        let len = dist2.sqrt();
        let (wx, wy, wz) = (dx / len, dy / len, dz / len);

        // The receiver's f cos towards w (radiance mode). `max` is SSE's, which returns its
        // second operand unless the first is greater: glam's `Vec3::max` exactly.
        let x_ng = wx * s(x.ng.x) + wy * s(x.ng.y) + wz * s(x.ng.z);
        let x_ns = wx * s(x.ns.x) + wy * s(x.ns.y) + wz * s(x.ns.z);
        let kx = s(FRAC_1_PI) * x_ns.max(zero);
        let fx = [s(x.albedo.x) * kx, s(x.albedo.y) * kx, s(x.albedo.z) * kx];
        let fx_ok = fx[0].is_finite_mask() & fx[1].is_finite_mask() & fx[2].is_finite_mask();
        let fx = fx.map(|v| v.max(zero));

        // The VPL's f cos towards −w (importance mode, adjoint shading-normal factor).
        let (vx, vy, vz) = (-wx, -wy, -wz);
        let p_ng = vx * q.vpl.ng[0] + vy * q.vpl.ng[1] + vz * q.vpl.ng[2];
        let p_ns = vx * q.vpl.ns[0] + vy * q.vpl.ns[1] + vz * q.vpl.ns[2];
        let kp = s(FRAC_1_PI) * p_ns.max(zero);
        let factor = shading_correction(q.wo_cos_shading, q.wo_cos_geometric, p_ng, p_ns);
        let fp = [q.albedo[0] * kp * factor, q.albedo[1] * kp * factor, q.albedo[2] * kp * factor];
        let fp_ok = fp[0].is_finite_mask() & fp[1].is_finite_mask() & fp[2].is_finite_mask();
        let fp = fp.map(|v| v.max(zero));

        // Every early return of the scalar code, as a mask.
        let active = q.depth.cmple(s(max_depth as f32))
            & !dist2.cmple(zero)
            & x_ng.cmpgt(zero)
            & x_ns.cmpgt(zero)
            & fx_ok
            & (fx[0].cmpne(zero) | fx[1].cmpne(zero) | fx[2].cmpne(zero))
            & p_ng.cmpgt(zero)
            & p_ns.cmpgt(zero)
            & fp_ok
            & (fp[0].cmpne(zero) | fp[1].cmpne(zero) | fp[2].cmpne(zero));

        // G = |cos_x| |cos_p| / d², clamped at the bound (never above an infinite one).
        let g = x_ns.abs() * p_ns.abs() / dist2;
        let clamped = g.cmpgt(s(bound));
        let scale = s(bound) / g;
        [0, 1, 2].map(|k| {
            let c = q.vpl.flux[k] * fx[k] * fp[k] / dist2;
            Vec4::select(active, Vec4::select(clamped, c * scale, c), zero)
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::Frame;
    use crate::integrator::many_light::points::point_contribution;
    use crate::material::{Bsdf, LocalGeometry};
    use crate::sampling::{Domain, Sampler};
    use glam::BVec4A;
    use std::f32::consts::PI;

    fn unit(s: &mut Sampler) -> Vec3 {
        let v = Vec3::new(s.next_f32() - 0.5, s.next_f32() - 0.5, s.next_f32() - 0.5);
        v.normalize_or(Vec3::Z)
    }

    /// A normal and a shading normal tilted from it, both random.
    fn normals(s: &mut Sampler) -> (Vec3, Frame) {
        let ng = unit(s);
        let ns = (ng + 0.3 * unit(s)).normalize_or(ng);
        (ng, Frame::from_normal(ns))
    }

    #[test]
    fn matches_the_scalar_contribution() {
        let mut s = Sampler::new(7, 0, Domain::LightPath, 0);
        let mut nonzero = 0;
        for round in 0..400 {
            let n = 1 + round % 40;
            let vpls: Vec<Vpl> = (0..n)
                .map(|j| {
                    let (ng, frame) = normals(&mut s);
                    // Some VPLs on the receiver itself (d = 0) and some very close (large G).
                    let p = match j % 7 {
                        0 => Vec3::ZERO,
                        1 => 1e-3 * unit(&mut s),
                        _ => 2.0 * unit(&mut s),
                    };
                    let w_in = unit(&mut s);
                    Vpl::for_test(
                        p,
                        ng,
                        frame,
                        w_in,
                        Vec3::new(s.next_f32(), s.next_f32(), 0.0),
                        (j % 4) as u32,
                    )
                })
                .collect();
            let albedo = Vec3::new(0.7, 0.2, s.next_f32());
            let bsdf = if round % 5 == 4 {
                Bsdf::Glossy { albedo, specular: Vec3::splat(0.3), roughness: 0.2 }
            } else {
                Bsdf::Diffuse { albedo }
            };
            let emitting: Vec<PreparedBsdf> = vpls
                .iter()
                .map(|v| PreparedBsdf::new(bsdf, v.geometry(), v.w_in, TransportMode::Importance))
                .collect();
            let lanes = VplLanes::new(&vpls, &emitting, &vec![1.0; vpls.len()], &[]);
            let (ng, frame) = normals(&mut s);
            let sp = SurfacePoint {
                p: Vec3::ZERO,
                ng,
                frame,
                prim: 0,
                material: 0,
                uv: glam::Vec2::ZERO,
                back: false,
            };
            let gx = LocalGeometry { ng, frame };
            let fx = PreparedBsdf::new(Bsdf::Diffuse { albedo }, gx, unit(&mut s), TransportMode::Radiance);
            let Some(x) = DiffuseReceiver::new(&sp, &fx) else { continue };
            let bound = [f32::INFINITY, 1.0, 50.0][round % 3];
            let max_depth = 2;
            for c in 0..lanes.chunks() {
                let out = lanes.diffuse_contributions(c, &x, bound, max_depth);
                for (i, &got) in out.iter().enumerate() {
                    let j = c * LANES + i;
                    if j >= n || lanes.kind(j) != LaneKind::Diffuse || vpls[j].depth > max_depth {
                        assert_eq!(got, Vec3::ZERO);
                        continue;
                    }
                    let want = point_contribution(sp.p, frame.n, &fx, &vpls[j], &emitting[j], bound);
                    assert_eq!(got.to_array().map(f32::to_bits), want.to_array().map(f32::to_bits), "{j}");
                    nonzero += usize::from(want != Vec3::ZERO);
                }
            }
        }
        assert!(nonzero > 100, "{nonzero}");
    }

    /// The resampled gather's estimate is positive wherever the contribution is not zero, for
    /// diffuse and glossy receivers and lights seen from either side, with the connections'
    /// weights in it or not (down to weights that underflow).
    #[test]
    fn estimates_cover_every_contribution() {
        let mut s = Sampler::new(11, 0, Domain::LightPath, 0);
        let (mut nonzero, mut zero) = (0, 0);
        for round in 0..600 {
            let n = 1 + round % 23;
            let glossy = |albedo| Bsdf::Glossy { albedo, specular: Vec3::splat(0.4), roughness: 0.1 };
            let bsdf_p = if round % 3 == 0 {
                glossy(Vec3::splat(0.2))
            } else {
                Bsdf::Diffuse { albedo: Vec3::splat(0.5) }
            };
            let vpls: Vec<Vpl> = (0..n)
                .map(|j| {
                    let (ng, frame) = normals(&mut s);
                    let p = if j % 9 == 0 { 1e-3 * unit(&mut s) } else { 2.0 * unit(&mut s) };
                    let w_in = unit(&mut s);
                    Vpl::for_test(
                        p,
                        ng,
                        frame,
                        w_in,
                        Vec3::new(s.next_f32(), s.next_f32(), 0.1),
                        (j % 4) as u32,
                    )
                })
                .collect();
            let emitting: Vec<PreparedBsdf> = vpls
                .iter()
                .map(|v| PreparedBsdf::new(bsdf_p, v.geometry(), v.w_in, TransportMode::Importance))
                .collect();
            let power: Vec<f32> = emitting.iter().map(|e| if e.is_active() { 1.0 } else { 0.0 }).collect();
            // Half the rounds with the connections' weights in the estimates, their terms up
            // to sizes that make h overflow.
            let weighed = round % 2 == 1;
            let terms: Vec<f32> = if weighed {
                (0..n).map(|_| s.next_f32() * 10f32.powi((s.next_f32() * 40.0) as i32)).collect()
            } else {
                Vec::new()
            };
            let lanes = VplLanes::new(&vpls, &emitting, &power, &terms);
            let (ng, frame) = normals(&mut s);
            let bsdf_x = match round % 4 {
                0 => glossy(Vec3::splat(0.3)),
                // Near-mirror, down to GGX's smallest α.
                2 => Bsdf::Glossy {
                    albedo: Vec3::ZERO,
                    specular: Vec3::ONE,
                    roughness: [0.01, 0.0][round / 4 % 2],
                },
                _ => Bsdf::Diffuse { albedo: Vec3::ONE },
            };
            let wo = unit(&mut s);
            let fx = PreparedBsdf::new(bsdf_x, LocalGeometry { ng, frame }, wo, TransportMode::Radiance);
            let lobe = Lobe::of(&bsdf_x, frame.n, wo);
            let bound = [f32::INFINITY, 1.0, 0.05][round % 3];
            let r = EstimateReceiver {
                x: Vec3::ZERO,
                ng,
                ns: frame.n,
                bound,
                max_depth: 2,
                lobe: lobe.as_ref(),
                transmits: false,
                weights: weighed.then(|| DrawWeights { light: s.next_f32(), camera: s.next_f32() }),
            };
            for c in 0..lanes.chunks() {
                let est = lanes.estimates_for(c, &r);
                for (i, &e) in est.iter().enumerate().take(LANES) {
                    let j = c * LANES + i;
                    if j >= n {
                        assert_eq!(e, 0.0);
                        continue;
                    }
                    let want = point_contribution(Vec3::ZERO, frame.n, &fx, &vpls[j], &emitting[j], bound);
                    if want != Vec3::ZERO && vpls[j].depth <= 2 {
                        assert!(e > 0.0 && e.is_finite(), "round {round} light {j}: {want} but {e}");
                        nonzero += 1;
                    } else {
                        zero += 1;
                    }
                }
            }
            // The gather's pushes, two chunks at a time in the version the CPU runs (AVX2 on
            // CPUs that have it), give the blocks that the build's own version gives chunk by
            // chunk, bit for bit, for windows of every light to every other, the lanes of other
            // windows left out.
            let lo = round % n;
            for (lo, hi) in [(0, n), (lo, n), (lo / 2, n - (n - lo) / 2), (lo, (lo + 1 + round % 7).min(n))] {
                let window = Window { lights: lo..hi, scale: 1.0 };
                let (mut got, mut want) = (Candidates::new(), Candidates::new());
                lanes.push_estimates(&mut got, &window, &r);
                for (b, inside) in window.chunks::<LANES>() {
                    let p = Vec4::from_slice(&lanes.estimates_for(b, &r)[..LANES]);
                    want.push(b * LANES, Vec4::select(BVec4A::from_array(inside), p, Vec4::ZERO));
                }
                let bits = |c: &Candidates| {
                    c.blocks().map(|(j, p)| (j, p.to_array().map(f32::to_bits))).collect::<Vec<_>>()
                };
                assert_eq!(bits(&got), bits(&want), "round {round}, window {window:?}");
                assert_eq!(got.total().to_bits(), want.total().to_bits());
            }
        }
        assert!(nonzero > 200 && zero > 200, "{nonzero} {zero}");
    }

    /// Eight VPLs of the Lambertian `bsdf` at `position`s, with tilted shading normals and
    /// incoming light near their faces' planes (adjoint corrections far from 1), their
    /// emitting BSDFs, and their lanes with the tree's power.
    fn grazing_lambertian_lights(
        s: &mut Sampler,
        bsdf: Bsdf,
        mut position: impl FnMut(&mut Sampler) -> Vec3,
    ) -> (Vec<Vpl>, Vec<PreparedBsdf>, VplLanes) {
        let vpls: Vec<Vpl> = (0..8)
            .map(|j| {
                let (ng, frame) = normals(s);
                let p = position(s);
                let w_in = (unit(s) + 3.0 * s.next_f32() * ng).normalize();
                Vpl::for_test(p, ng, frame, w_in, Vec3::new(s.next_f32(), s.next_f32(), 0.5), (j % 2) as u32)
            })
            .collect();
        let emitting: Vec<PreparedBsdf> = vpls
            .iter()
            .map(|v| PreparedBsdf::new(bsdf, v.geometry(), v.w_in, TransportMode::Importance))
            .collect();
        let power: Vec<f32> = vpls
            .iter()
            .zip(&emitting)
            .map(|(v, e)| super::super::light_set::tree_light(v, &bsdf, e.is_active(), 0.0).intensity)
            .collect();
        let lanes = VplLanes::new(&vpls, &emitting, &power, &[]);
        (vpls, emitting, lanes)
    }

    /// A glossy light's estimate follows its lobe ([`PairLobes`]): at white Lambertian
    /// receivers, over glossy lights of α 0.05 to 0.5 with the tree's power (light arriving
    /// near grazing, where the bound is loosest), the log of the estimate over the
    /// contribution (channel sum) spreads at most 0.7 times as much as it did with the light
    /// taken as Lambertian of its reflectance (the same power, no lobe: the estimate before
    /// the lobes), whose f misses the lobe's by up to its peak (0.41 against 0.73 when
    /// written).
    #[test]
    fn glossy_lights_are_estimated_by_their_lobes() {
        let mut s = Sampler::new(23, 0, Domain::LightPath, 0);
        let (albedo, specular) = (Vec3::new(0.3, 0.2, 0.1), Vec3::splat(0.6));
        let (mut lobed, mut plain) = (Vec::new(), Vec::new());
        for round in 0..1500 {
            let roughness = [0.05, 0.1, 0.2, 0.5][round % 4];
            let glossy = Bsdf::Glossy { albedo, specular, roughness };
            // The same reflectance, Lambertian: the same power in the estimates.
            let lambertian = Bsdf::Diffuse { albedo: albedo + specular };
            // (The same lights: the same numbers.)
            let (_, _, as_lambertian) =
                grazing_lambertian_lights(&mut s.clone(), lambertian, |s| 2.0 * unit(s));
            let (vpls, emitting, lanes) = grazing_lambertian_lights(&mut s, glossy, |s| 2.0 * unit(s));
            let (ng, frame) = normals(&mut s);
            let white = Bsdf::Diffuse { albedo: Vec3::ONE };
            let fx =
                PreparedBsdf::new(white, LocalGeometry { ng, frame }, unit(&mut s), TransportMode::Radiance);
            for c in 0..lanes.chunks() {
                let est = lanes.estimates(c, Vec3::ZERO, ng, frame.n, f32::INFINITY, 2, None);
                let before = as_lambertian.estimates(c, Vec3::ZERO, ng, frame.n, f32::INFINITY, 2, None);
                for i in 0..LANES {
                    let j = c * LANES + i;
                    let want =
                        point_contribution(Vec3::ZERO, frame.n, &fx, &vpls[j], &emitting[j], f32::INFINITY)
                            .element_sum();
                    if want > 0.0 {
                        assert!(est[i] > 0.0 && est[i].is_finite(), "round {round} light {j}: {}", est[i]);
                        lobed.push((est[i] / want).ln() as f64);
                        plain.push((before[i] / want).ln() as f64);
                    }
                }
            }
        }
        let spread = |v: &[f64]| {
            let mean = v.iter().sum::<f64>() / v.len() as f64;
            (v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / v.len() as f64).sqrt()
        };
        let (lobed_spread, plain_spread) = (spread(&lobed), spread(&plain));
        eprintln!(
            "{} lights: spread of ln(estimate / contribution) {lobed_spread:.3} with their lobes, {plain_spread:.3} as Lambertian",
            lobed.len()
        );
        assert!(lobed.len() > 800, "{} lights", lobed.len());
        assert!(lobed_spread < 0.7 * plain_spread, "{lobed_spread} against {plain_spread}");
    }

    /// For Lambertian VPLs with tilted shading normals and a white Lambertian receiver, the
    /// estimate with the tree's power (which holds the light's adjoint correction factor) is
    /// the contribution's channel sum times π² exactly, unclamped and clamped: the light's
    /// side of the estimate is exact, so a resampled pick's weight does not grow with the
    /// correction (it did when the estimate took the light's shading cosine without it).
    #[test]
    fn the_estimate_is_exact_for_lambertian_lights() {
        let mut s = Sampler::new(9, 0, Domain::LightPath, 0);
        let (mut checked, mut clamped) = (0, 0);
        for round in 0..1000 {
            let bsdf = Bsdf::Diffuse { albedo: Vec3::new(0.7, 0.2, s.next_f32()) };
            let (vpls, emitting, lanes) = grazing_lambertian_lights(&mut s, bsdf, |s| 2.0 * unit(s));
            let (ng, frame) = normals(&mut s);
            let white = Bsdf::Diffuse { albedo: Vec3::ONE };
            let fx =
                PreparedBsdf::new(white, LocalGeometry { ng, frame }, unit(&mut s), TransportMode::Radiance);
            // G ≤ 1/4 at distance 2: a bound of 0.05 clamps most lights it is used for.
            let bound = [f32::INFINITY, 0.05][round % 2];
            for c in 0..lanes.chunks() {
                let est = lanes.estimates(c, Vec3::ZERO, ng, frame.n, bound, 2, None);
                for i in 0..LANES {
                    let j = c * LANES + i;
                    let want = point_contribution(Vec3::ZERO, frame.n, &fx, &vpls[j], &emitting[j], bound)
                        .element_sum()
                        * PI
                        * PI;
                    if want == 0.0 {
                        continue;
                    }
                    let unclamped =
                        point_contribution(Vec3::ZERO, frame.n, &fx, &vpls[j], &emitting[j], f32::INFINITY);
                    clamped += usize::from(unclamped.element_sum() * PI * PI > want * 1.01);
                    assert!(
                        (est[i] - want).abs() <= 1e-4 * want,
                        "round {round} light {j}: estimate {} against {want}",
                        est[i]
                    );
                    checked += 1;
                }
            }
        }
        assert!(checked > 400 && clamped > 100, "{checked} {clamped}");
    }

    /// With a glossy receiver the eight-wide kernel's one-division form of the lobe's term is
    /// [`Lobe::bound`]'s: the estimate equals power × (ρ_d/π · g + bound(cos θ) · g |d| /
    /// (d·n_x)) to f32 rounding (of cos θ over α², near the narrowest lobe's peak), with g the estimate without a lobe, from near-mirror lobes
    /// (α 0.005, whose 1/α⁴ would show any lost factor of |d|) to wide ones, lights near and
    /// far (0.05 to 50 units, where a wrong power of |d| shows), clamped and not.
    #[test]
    fn the_lobe_term_is_the_bound_of_the_half_angle() {
        let mut s = Sampler::new(17, 0, Domain::LightPath, 0);
        let mut checked = 0;
        for round in 0..1500 {
            let bsdf = Bsdf::Diffuse { albedo: Vec3::splat(0.5) };
            let scale = [0.05, 1.0, 50.0][round % 3];
            let (vpls, _, lanes) = grazing_lambertian_lights(&mut s, bsdf, |s| scale * unit(s));
            let (ng, frame) = normals(&mut s);
            let roughness = [0.005, 0.05, 0.15, 0.6][round % 4];
            let glossy = Bsdf::Glossy { albedo: Vec3::splat(0.2), specular: Vec3::splat(0.7), roughness };
            let wo = unit(&mut s);
            let Some(lobe) = Lobe::of(&glossy, frame.n, wo) else { continue };
            let bound = [f32::INFINITY, 0.5][round / 3 % 2];
            for c in 0..lanes.chunks() {
                let with = lanes.estimates(c, Vec3::ZERO, ng, frame.n, bound, 2, Some(&lobe));
                let without = lanes.estimates(c, Vec3::ZERO, ng, frame.n, bound, 2, None);
                for i in 0..LANES {
                    let j = c * LANES + i;
                    if without[i] == 0.0 {
                        assert_eq!(with[i], 0.0, "round {round} light {j}");
                        continue;
                    }
                    let d = vpls[j].p;
                    let cos_t = d.dot(lobe.mirror()) / d.length();
                    let want = without[i]
                        * (lobe.diffuse() + lobe.bound(cos_t.clamp(-1.0, 1.0)) * d.length() / d.dot(frame.n));
                    // (Near the peak of the narrowest lobe the two forms round (1 − cos θ)/α²
                    // differently: a few ulps of cos θ over α².)
                    let tolerance = 1e-4 + 8.0 * f32::EPSILON / (roughness * roughness);
                    assert!(
                        (with[i] - want).abs() <= tolerance * want,
                        "round {round} light {j}, α {roughness}, |d| {}: {} against {want}",
                        d.length(),
                        with[i]
                    );
                    checked += 1;
                }
            }
        }
        assert!(checked > 1000, "{checked}");
    }

    /// For a grey glossy receiver and Lambertian VPLs with tilted shading normals, the
    /// estimate with the tree's power bounds π times the contribution's channel sum from
    /// above, clamped or not, at every roughness: the receiver's side is its Lambertian part
    /// plus the lobe's bound ([`Lobe`]), and the light's side is exact. (The bound failed
    /// when clamped while the lobe's term took the clamp without the receiver's cosine.)
    #[test]
    fn the_estimate_bounds_a_glossy_receivers_contribution() {
        let mut s = Sampler::new(13, 0, Domain::LightPath, 0);
        let (mut checked, mut clamped) = (0, 0);
        for round in 0..1500 {
            let bsdf = Bsdf::Diffuse { albedo: Vec3::new(0.7, 0.2, s.next_f32()) };
            let (vpls, emitting, lanes) =
                grazing_lambertian_lights(&mut s, bsdf, |s| (0.5 + 1.5 * s.next_f32()) * unit(s));
            let (ng, frame) = normals(&mut s);
            let roughness = [0.05, 0.2, 0.6][round % 3];
            let grey = Bsdf::Glossy { albedo: Vec3::splat(0.3), specular: Vec3::splat(0.6), roughness };
            let wo = unit(&mut s);
            let fx = PreparedBsdf::new(grey, LocalGeometry { ng, frame }, wo, TransportMode::Radiance);
            let Some(lobe) = Lobe::of(&grey, frame.n, wo) else { continue };
            let bound = [f32::INFINITY, 0.2][round % 2];
            for c in 0..lanes.chunks() {
                let est = lanes.estimates(c, Vec3::ZERO, ng, frame.n, bound, 2, Some(&lobe));
                for i in 0..LANES {
                    let j = c * LANES + i;
                    let got = point_contribution(Vec3::ZERO, frame.n, &fx, &vpls[j], &emitting[j], bound);
                    let want = got.element_sum() * PI;
                    if want == 0.0 {
                        continue;
                    }
                    assert!(est[i] >= want * (1.0 - 1e-4), "round {round} light {j}: {} < {want}", est[i]);
                    let full =
                        point_contribution(Vec3::ZERO, frame.n, &fx, &vpls[j], &emitting[j], f32::INFINITY);
                    clamped += usize::from(full.element_sum() > got.element_sum() * 1.01);
                    checked += 1;
                }
            }
        }
        assert!(checked > 1000 && clamped > 200, "{checked} {clamped}");
    }
}
