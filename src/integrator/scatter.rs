//! How every path, camera or light, continues from a vertex: BSDF sampling with the
//! throughput update, and Russian roulette. Written once for the camera walker
//! ([`super::walker`]) and the light tracer ([`super::many_light`]).

use glam::{Vec2, Vec3};

use crate::material::{Bsdf, BsdfSample, TransportMode};
use crate::sampling::Sampler;
use crate::scene::SurfacePoint;

/// Samples the BSDF at `sp` for the direction `wo` (pointing back along the path) and
/// multiplies the throughput `beta` by the sample's weight. `None` ends the path: no sample,
/// or a throughput that is zero or not finite. Always draws three numbers from `sampler`.
#[inline(always)]
pub fn scatter(
    bsdf: &Bsdf,
    sp: &SurfacePoint,
    wo: Vec3,
    mode: TransportMode,
    sampler: &mut Sampler,
    beta: &mut Vec3,
) -> Option<BsdfSample> {
    let (u_lobe, u) = bsdf_numbers(sampler);
    let s = bsdf.sample(&sp.geometry(), wo, u_lobe, u, mode)?;
    *beta *= s.weight;
    (beta.max_element() > 0.0 && beta.is_finite()).then_some(s)
}

/// A BSDF sample's numbers, `u_lobe` and `u`, as [`Bsdf::sample`] takes them: three draws, in
/// this order.
#[inline(always)]
pub fn bsdf_numbers(sampler: &mut Sampler) -> (f32, Vec2) {
    let u_lobe = sampler.next_f32();
    (u_lobe, sampler.next_2d())
}

/// Russian roulette: the path survives with probability q = min(0.95, `survival`), and a
/// survivor's throughput is divided by q, which keeps the estimate unbiased. Draws one number.
#[inline]
pub fn survives_roulette(survival: f32, beta: &mut Vec3, sampler: &mut Sampler) -> bool {
    let q = survival.min(0.95);
    if sampler.next_f32() >= q {
        return false;
    }
    *beta /= q;
    true
}
