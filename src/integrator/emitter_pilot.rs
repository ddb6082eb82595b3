//! Whether next-event estimation's choice by importance pays in a scene
//! (`--emitter-choice auto`, the default): a pilot before the render weighs its variance and
//! its cost against the choice by power.
//!
//! **Why.** The choice by importance ([`crate::light::spatial`]) bounds what each emitter can
//! send to a receiver, but not whether it is in view. Where the lights are apart and seen (the
//! conference room's six panels) it leaves 2.3× less variance at equal time; where they sit
//! together it evaluates its bounds for nothing (the living room: 5–10 % slower, level per
//! sample); and where the emitters that it prefers are hidden (Bitterli's veach-bidir, a lamp
//! inside its shade) it sends more shadow rays towards them, which the shade stops: `pt` 34 %
//! slower per sample for 10 % less variance (`docs/results.md`).
//!
//! **How.** [`PILOT_RAYS`] camera rays through points of the film find their first
//! non-emitting, non-delta surface; from each, [`SAMPLES`] light samples by each choice, from
//! the same numbers, each traced to the emitter where it faces the receiver, give the
//! irradiance's estimates (a Lambertian receiver's light: what the BSDF does with it is the
//! same for both choices). As many cosine-weighted bounces, each with a light sample by power
//! where it lands, estimate the light that arrives after one more bounce, whose variance
//! dilutes the choice's gain in the image (the living room's first surfaces are lit as much
//! indirectly as directly). Summed over the points, each point's variance relative to its
//! squared mean (the relative MSE that an image's error is measured by), plus a floor that
//! every sample carries either way ([`FLOOR`]), estimates a choice's variance per sample; the
//! cost of a sample is modelled as one path vertex plus the shadow
//! rays it traced ([`SHADOW_COST`] each) plus, by importance, its bounds ([`BOUND_COST`]). The
//! choice by importance is taken where its efficiency (1 / variance · cost) is above
//! [`MARGIN`] times the power table's.
//!
//! The pilot's numbers are a stream of their own, independent of the seed, so that the choice
//! is a function of the scene, its camera and the accelerator alone: every render, resumed
//! or sharded, of a scene makes the same, and the job records it (a render's estimator is
//! fixed before its first sample, so either choice leaves it unbiased).

use glam::{Vec2, Vec3};

use super::direct::shadow_ray;
use crate::accel::{Accelerator, Hit};
use crate::geometry::{Frame, Ray, offset_origin};
use crate::light::{EmitterSample, Emitters};
use crate::sampling::{Domain, Streams, cosine_hemisphere};
use crate::scene::{CameraRays, Scene};

/// Camera rays of the pilot.
pub const PILOT_RAYS: usize = 4096;

/// Light samples per point and choice.
pub const SAMPLES: usize = 4;

/// A shadow ray's cost in units of a path vertex (a closest hit and its shading), and the
/// choice by importance's bounds' per sixteen entries (fitted to veach-bidir's `pt`: 1.16 µs
/// against 1.56 µs per path, 0.47 against 0.73 shadow rays per vertex, 4.1 vertices).
pub const SHADOW_COST: f64 = 1.5;
pub const BOUND_COST: f64 = 0.2;

/// How much more efficient the choice by importance must look to be taken: the model's
/// margin of error.
pub const MARGIN: f64 = 1.2;

/// The variance per sample, relative to a point's squared mean, that every sample carries
/// besides its light sample's, for both choices alike: where in the pixel it lands, the
/// BSDF's own samples, textures. Without it a point whose light samples vary little either
/// way would decide by the ratio of two negligible variances (three small lamps side by
/// side: 3.6× by the light samples' variances alone, 1.3× with it, 1.10× in the image's).
/// The real scenes measured do not depend on it (0.02 to 0.1: the conference room 1.52× to
/// 1.47×, the living room 1.00× to 0.99×, veach-bidir 0.82×).
pub const FLOOR: f64 = 0.05;

/// The stream of the pilot's numbers: an iteration number no render reaches (nor the other
/// pilots), under a seed of its own.
const PILOT_ITERATION: u64 = u64::MAX - 4;
const PILOT_SEED: u64 = 0x656d_6974_7465_7273;

/// What the pilot found: the efficiency of the choice by importance relative to the choice
/// by power (above one: importance is better), and the points it measured.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Verdict {
    pub gain: f64,
    pub points: usize,
}

impl Verdict {
    /// Whether the choice by importance pays.
    pub fn importance_pays(&self) -> bool {
        self.gain > MARGIN
    }
}

/// Each choice's sums over a point's samples.
#[derive(Clone, Copy, Default)]
struct Sums {
    sum: f64,
    sum2: f64,
    shadow_rays: u64,
}

impl Sums {
    fn add(&mut self, e: f64) {
        self.sum += e;
        self.sum2 += e * e;
    }
}

/// The pilot for `emitters` (which pick by importance: [`Emitters::is_spatial`]) in `scene`
/// seen by `camera` through `accel`, for paths of at most `max_depth` segments (the bounce
/// needs three).
pub fn run(
    scene: &Scene,
    accel: &dyn Accelerator,
    emitters: &Emitters,
    camera: &CameraRays,
    max_depth: u32,
) -> Verdict {
    let bounces = if max_depth >= 3 { SAMPLES } else { 0 };
    let streams = Streams::new(PILOT_SEED, PILOT_ITERATION, Domain::Acceptance);
    let film = camera.film_size();
    let mut points: Vec<Point> = Vec::new();
    // The shadow rays each choice traced.
    let (mut shadows_importance, mut shadows_power) = (0u64, 0u64);
    for j in 0..PILOT_RAYS {
        let mut sampler = streams.sampler(j as u64);
        let ray = camera.generate_ray(sampler.next_2d() * film, sampler.next_2d());
        let Some(hit) = accel.intersect(&ray).filter(|h| reflects(scene, h)) else { continue };
        let sp = scene.surface_of_hit(&hit, ray.dir);
        let ng = sp.facing(ray.dir);
        let (mut imp, mut pow) = (Sums::default(), Sums::default());
        for k in 0..SAMPLES {
            // Stratified in the number that picks the emitter.
            let u_select = sampler.next_f32();
            let u = Vec2::new((k as f32 + sampler.next_f32()) / SAMPLES as f32, sampler.next_f32());
            for (importance, sums) in [(true, &mut imp), (false, &mut pow)] {
                let es = if importance {
                    emitters.sample_from(scene, sp.p, u_select, u)
                } else {
                    emitters.sample(scene, u_select, u)
                };
                let d = es.point.p - sp.p;
                if ng.dot(d) > 0.0 && es.point.ng.dot(d) < 0.0 {
                    sums.shadow_rays += 1;
                }
                if let Some(e) = irradiance(accel, sp.p, ng, es) {
                    sums.add(e);
                }
            }
        }
        // The light after one more bounce: cosine-weighted directions, a light sample by power
        // where they land on a surface that reflects (a Lambertian one of its reflectance).
        let mut bounced = Sums::default();
        let frame = Frame::from_normal(ng);
        for _ in 0..bounces {
            let wi = frame.to_world(cosine_hemisphere(sampler.next_2d()));
            let (u_select, u) = (sampler.next_f32(), sampler.next_2d());
            let next = Ray::new(offset_origin(sp.p, ng, wi), wi);
            let Some(hit) = accel.intersect(&next).filter(|h| reflects(scene, h)) else { continue };
            let y = scene.surface_of_hit(&hit, wi);
            let ny = y.facing(wi);
            let albedo = scene.bsdf_at(&y).reflectance().dot(Vec3::splat(1.0 / 3.0)) as f64;
            if let Some(e) = irradiance(accel, y.p, ny, emitters.sample(scene, u_select, u)) {
                bounced.add(albedo * e);
            }
        }
        let n = SAMPLES as f64;
        let variance = |s: &Sums| (s.sum2 / n - (s.sum / n).powi(2)).max(0.0);
        points.push(Point {
            mean: (imp.sum + pow.sum) / (2.0 * n) + bounced.sum / n,
            importance: variance(&imp),
            power: variance(&pow),
            bounced: variance(&bounced),
        });
        shadows_importance += imp.shadow_rays;
        shadows_power += pow.shadow_rays;
    }
    let bound_cost = BOUND_COST * emitters.spatial_entries().unwrap_or(0).div_ceil(16) as f64;
    verdict(&points, shadows_importance, shadows_power, bound_cost)
}

/// Whether the surface that `hit` finds reflects light that the pilot measures: neither an
/// emitter nor a mirror or glass.
fn reflects(scene: &Scene, hit: &Hit) -> bool {
    let material = scene.material_of(hit.prim);
    !material.is_emitter() && !material.bsdf.is_delta()
}

/// The irradiance that the emitter sample `es` estimates at the point `p` of geometric
/// normal `ng` (mean over the channels): `None` where the sample faces away from `p`, or `p`
/// from it, or something stops its shadow ray.
fn irradiance(accel: &dyn Accelerator, p: Vec3, ng: Vec3, es: EmitterSample) -> Option<f64> {
    let d = es.point.p - p;
    let dist2 = d.length_squared();
    let (cos_r, cos_e) = (ng.dot(d), -es.point.ng.dot(d));
    if !(cos_r > 0.0 && cos_e > 0.0 && dist2 > 0.0)
        || accel.occluded(&shadow_ray(p, ng, es.point.p, es.point.ng))
    {
        return None;
    }
    // (The cosines are of the unnormalised direction: dist2² below.)
    let e = (es.radiance.dot(Vec3::splat(1.0 / 3.0)) * cos_r * cos_e / (dist2 * dist2 * es.pdf_area)) as f64;
    e.is_finite().then_some(e)
}

/// A point of the pilot: the mean of its light (both choices' direct light and the light
/// after one more bounce), the variances of the direct light's estimates by importance and by
/// power, and of the bounced light's.
#[derive(Clone, Copy, Debug)]
struct Point {
    mean: f64,
    importance: f64,
    power: f64,
    bounced: f64,
}

/// The verdict from the pilot's points and the shadow rays each choice traced: relative
/// variances (the direct light's by the choice, plus the bounced light's and the [`FLOOR`]
/// common to both) summed over the points (the squared mean padded by a twentieth of the points' average mean, so that the
/// dark points do not decide), each times its modelled cost.
fn verdict(points: &[Point], shadows_importance: u64, shadows_power: u64, bound_cost: f64) -> Verdict {
    let samples = (points.len() * SAMPLES).max(1) as f64;
    let average = points.iter().map(|p| p.mean).sum::<f64>() / points.len().max(1) as f64;
    let pad = (0.05 * average).powi(2);
    let (mut v_imp, mut v_pow) = (0.0f64, 0.0f64);
    for p in points {
        let norm = p.mean * p.mean + pad;
        if norm > 0.0 {
            let common = p.bounced + FLOOR * p.mean * p.mean;
            v_imp += (p.importance + common) / norm;
            v_pow += (p.power + common) / norm;
        }
    }
    let cost_imp = 1.0 + SHADOW_COST * shadows_importance as f64 / samples + bound_cost;
    let cost_pow = 1.0 + SHADOW_COST * shadows_power as f64 / samples;
    let gain = if v_imp > 0.0 { (v_pow * cost_pow) / (v_imp * cost_imp) } else { 1.0 };
    Verdict { gain: if gain.is_finite() { gain } else { 1.0 }, points: points.len() }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Equal variances: the importance's extra cost loses; a variance halved wins, unless
    /// its shadow rays cost more than it saves.
    fn points(n: usize, mean: f64, importance: f64, power: f64, bounced: f64) -> Vec<Point> {
        vec![Point { mean, importance, power, bounced }; n]
    }

    #[test]
    fn the_verdict_weighs_variance_against_cost() {
        let v = verdict(&points(100, 1.0, 0.5, 0.5, 0.0), 200, 200, BOUND_COST);
        assert!(v.gain < 1.0 && !v.importance_pays(), "{v:?}");
        let halved = points(100, 1.0, 0.15, 0.5, 0.0);
        assert!(verdict(&halved, 200, 200, BOUND_COST).importance_pays());
        // Four times the shadow rays per sample (2 against 0.5): 4.2 against 1.75 in cost,
        // for 2.4x less variance.
        assert!(!verdict(&halved, 800, 200, BOUND_COST).importance_pays());
        // The bounced light's variance dilutes the gain.
        assert!(!verdict(&points(100, 1.0, 0.15, 0.5, 1.0), 200, 200, BOUND_COST).importance_pays());
        // So does the floor: 0.15 against 0.2 in variance (0.1 against 0.15 alone would pay).
        assert!(!verdict(&points(100, 1.0, 0.1, 0.15, 0.0), 200, 200, BOUND_COST).importance_pays());
        // Dark points weigh little; no points, or no variance, keep the power table.
        let dark = points(100, 0.0, 1e-6, 0.0, 0.0);
        assert!(verdict(&[halved.clone(), dark].concat(), 200, 200, BOUND_COST).importance_pays());
        assert!(!verdict(&[], 0, 0, BOUND_COST).importance_pays());
        assert!(!verdict(&points(1, 1.0, 0.0, 0.0, 0.0), 1, 1, BOUND_COST).importance_pays());
    }
}
