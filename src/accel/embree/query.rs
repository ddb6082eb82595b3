//! Tracing a [`CommittedScene`]: the ray and packet setup and the only Embree calls made on a
//! committed scene, `rtcIntersect{1,4,8,16}` and `rtcOccluded{1,4,8,16}` (through the shim's
//! `pir_intersect*`/`pir_occluded*`). Nothing here changes Embree state, so any number of
//! threads may run these functions on one scene at once (see the `Sync` argument in
//! `build.rs`).
//!
//! ## Ray conventions and differences from the trait's open interval
//! - Rays failing [`Ray::is_valid`], with an empty interval (`tmin >= tmax`) or with a
//!   coordinate beyond Embree's `FLT_LARGE` (1.844e18) never reach Embree (Debian's build
//!   asserts on them and aborts): they miss and are not occluded. In packets they are
//!   inactive lanes.
//! - Embree's documentation speaks of the segment `[tnear, tfar]`; its triangle test (checked
//!   by `interval_ends_are_open` below) accepts `tnear < t <= tfar`. The trait asks for the
//!   open `(tmin, tmax)`, so pir passes `tfar =` the largest float below a finite `tmax`: both
//!   ends are then open. Embree compares scaled values (`T <= tfar * |det|`), so hits within
//!   rounding of either end may still differ from the brute-force oracle; no caller can rely
//!   on those anyway.
//! - Each ray: `mask = u32::MAX`, `flags = 0`, `time = 0`, `geomID = primID = instID[*] =
//!   RTC_INVALID_GEOMETRY_ID` (from the shim's `pir_invalid_geometry_id`); a hit is
//!   `geomID != RTC_INVALID_GEOMETRY_ID`, an occluded ray comes back with `tfar = -inf`
//!   (tested as `tfar < 0`).
//! - Embree's `u, v` are the barycentrics of the triangle's vertices 1 and 2: the same
//!   convention as [`Hit`]. `primID` is the index into the `indices` slice.
//! - Queries use the INCOHERENT flag (set in the C shim): COHERENT was ~2× slower for
//!   divergent shadow rays here.
//! - Batches are cut into packets of the configured width (4, 8 or 16 rays), the tail into
//!   the narrowest packet that holds it (padded with inactive lanes), one Embree call per
//!   packet that has an active lane.

use glam::Vec3;

use super::build::CommittedScene;
use super::sys;
use crate::accel::Hit;
use crate::geometry::Ray;

/// Embree's `FLT_LARGE`: its ray validity check rejects larger origin/direction components.
const FLT_LARGE: f32 = 1.844e18;

const _: () = {
    // Alignment the packet calls require (16/32/64 bytes); bindgen keeps RTC_ALIGN.
    assert!(std::mem::align_of::<sys::RTCRayHit>() >= 16);
    assert!(std::mem::align_of::<sys::RTCRay>() >= 16);
    assert!(std::mem::align_of::<sys::RTCRayHit4>() >= 16);
    assert!(std::mem::align_of::<sys::RTCRay4>() >= 16);
    assert!(std::mem::align_of::<sys::RTCRayHit8>() >= 32);
    assert!(std::mem::align_of::<sys::RTCRay8>() >= 32);
    assert!(std::mem::align_of::<sys::RTCRayHit16>() >= 64);
    assert!(std::mem::align_of::<sys::RTCRay16>() >= 64);
    assert!(std::mem::align_of::<ValidMask<16>>() >= 64);
};

/// A packet's valid mask: −1 for an active lane, 0 for an inactive one. 64-byte aligned, which
/// covers the 16/32/64-byte alignment of the 4/8/16-wide calls.
#[repr(C, align(64))]
struct ValidMask<const N: usize>([i32; N]);

/// Whether a ray may be given to Embree (see the module docs): [`Ray::is_valid`], a non-empty
/// interval and no coordinate beyond `FLT_LARGE`. Written as one chain of `&` (no early
/// exits), since the packet loops run it for every ray and its branches cost about as much
/// as filling the packet: `|x| <= FLT_LARGE` is false for NaN and infinities (so it covers
/// finiteness), `tmin >= 0` and `tmin < tmax` are false when either is NaN.
#[inline]
fn traceable(ray: &Ray) -> bool {
    let small = |v: Vec3| (v.x.abs() <= FLT_LARGE) & (v.y.abs() <= FLT_LARGE) & (v.z.abs() <= FLT_LARGE);
    let ok = small(ray.origin)
        & small(ray.dir)
        & ((ray.dir.x != 0.0) | (ray.dir.y != 0.0) | (ray.dir.z != 0.0))
        & (ray.tmin >= 0.0)
        & (ray.tmin < ray.tmax);
    debug_assert_eq!(
        ok,
        ray.is_valid()
            && ray.tmin < ray.tmax
            && ray.origin.abs().max_element() <= FLT_LARGE
            && ray.dir.abs().max_element() <= FLT_LARGE
    );
    ok
}

/// Embree's `tfar` for the open end of `(tmin, tmax)`: the largest float below a finite `tmax`.
/// Requires `tmax > tmin >= 0`, so the result is `>= tmin`.
#[inline]
fn tfar_of(tmax: f32) -> f32 {
    if tmax.is_finite() { f32::from_bits(tmax.to_bits() - 1) } else { tmax }
}

/// A single ray/hit for `ray`, the hit's ids set to `invalid` (`RTC_INVALID_GEOMETRY_ID`).
fn single_rayhit(ray: &Ray, invalid: u32) -> sys::RTCRayHit {
    let mut rh = sys::RTCRayHit::default();
    let r = &mut rh.ray;
    (r.org_x, r.org_y, r.org_z) = (ray.origin.x, ray.origin.y, ray.origin.z);
    (r.dir_x, r.dir_y, r.dir_z) = (ray.dir.x, ray.dir.y, ray.dir.z);
    r.tnear = ray.tmin;
    r.tfar = tfar_of(ray.tmax);
    r.time = 0.0;
    r.mask = u32::MAX;
    r.flags = 0;
    r.id = 0;
    rh.hit.geomID = invalid;
    rh.hit.primID = invalid;
    rh.hit.instID.fill(invalid);
    rh
}

impl CommittedScene<'_> {
    /// The closest hit in `(ray.tmin, ray.tmax)`, if any (`rtcIntersect1`).
    pub(super) fn intersect1(&self, ray: &Ray) -> Option<Hit> {
        if !traceable(ray) {
            return None;
        }
        let invalid = self.invalid_id();
        let mut rh = single_rayhit(ray, invalid);
        // SAFETY: the scene is committed and never modified again, so it may be traced from
        // any thread; `rh` is a live, 16-byte aligned (bindgen keeps RTC_ALIGN(16)) ray/hit
        // with a ray that passed `traceable`, mask/flags/time set and the ids invalidated.
        unsafe { sys::pir_intersect1(self.raw(), &mut rh) };
        (rh.hit.geomID != invalid).then_some(Hit {
            t: rh.ray.tfar,
            prim: rh.hit.primID,
            u: rh.hit.u,
            v: rh.hit.v,
        })
    }

    /// Whether anything is hit in `(ray.tmin, ray.tmax)` (`rtcOccluded1`).
    pub(super) fn occluded1(&self, ray: &Ray) -> bool {
        if !traceable(ray) {
            return false;
        }
        let mut rh = single_rayhit(ray, self.invalid_id());
        // SAFETY: as in `intersect1`; `rh.ray` is the `RTCRay` part of the struct (16-byte
        // aligned); Embree writes only its `tfar`.
        unsafe { sys::pir_occluded1(self.raw(), &mut rh.ray) };
        rh.ray.tfar < 0.0
    }

    /// Closest hits for a batch, in packets of `width` (4, 8 or 16) rays, the tail in the
    /// narrowest packet that holds it ([`tail_width`]).
    pub(super) fn intersect_batch(&self, width: usize, rays: &[Ray], hits: &mut [Option<Hit>]) {
        by_packets(width, rays, hits, |w, rays, hits| match w {
            16 => self.intersect16(rays, hits),
            8 => self.intersect8(rays, hits),
            _ => self.intersect4(rays, hits),
        });
    }

    /// Occlusion for a batch, in packets of `width` (4, 8 or 16) rays, the tail in the
    /// narrowest packet that holds it ([`tail_width`]).
    pub(super) fn occluded_batch(&self, width: usize, rays: &[Ray], occluded: &mut [bool]) {
        by_packets(width, rays, occluded, |w, rays, occluded| match w {
            16 => self.occluded16(rays, occluded),
            8 => self.occluded8(rays, occluded),
            _ => self.occluded4(rays, occluded),
        });
    }
}

/// Traces `rays` into `out` run by run ([`packet_runs`] of `width`), handing `trace` each
/// run's packet width and its rays and results.
#[inline(always)]
fn by_packets<T>(width: usize, rays: &[Ray], out: &mut [T], mut trace: impl FnMut(usize, &[Ray], &mut [T])) {
    assert_eq!(rays.len(), out.len());
    for (w, range) in packet_runs(rays.len(), width) {
        trace(w, &rays[range.clone()], &mut out[range]);
    }
}

/// The packet width for the last `rest` rays of a batch traced `width` at a time (`rest` <
/// `width`): the narrowest of 4, 8 and 16 that holds them. Why: Embree traverses a packet's
/// tree once for all its lanes, so a 16-wide packet costs about as much whether 4 of its lanes
/// are active or 16, and the resampled gather (`pir-mis`, `pir-bdpt`, and the thesis'
/// methods with `--gather resample`) queues only its k = 4 shadow rays per receiver. With a
/// 16-wide packet for them, `pir-bdpt` on the Cornell box (AVX-512, 256², 64 iterations)
/// took 9.5 CPU seconds; with 4-wide ones 8.8 (single rays: 8.7), for the same image. A
/// width narrower than a native one is native too (a device's native widths are 4; 4 and 8;
/// or 4, 8 and 16), and `width` itself is one of the candidates, so the pick never exceeds it.
fn tail_width(rest: usize, width: usize) -> usize {
    [4, 8, 16].into_iter().find(|&w| w >= rest).unwrap_or(width)
}

/// The runs of a batch of `len` rays in packets of `width`: the whole packets as one run of
/// `width`, then the tail as one run of [`tail_width`] (either may be missing).
fn packet_runs(len: usize, width: usize) -> impl Iterator<Item = (usize, std::ops::Range<usize>)> {
    let whole = len / width * width;
    let head = (whole > 0).then_some((width, 0..whole));
    let tail = (whole < len).then(|| (tail_width(len - whole, width), whole..len));
    head.into_iter().chain(tail)
}

/// Fills lane `$i` of a packet's ray part from `$ray`, or pads it (inactive: empty interval,
/// zero mask) when `$ray` is `None`.
macro_rules! set_lane {
    ($r:expr, $i:expr, $ray:expr) => {
        match $ray {
            Some(ray) => {
                $r.org_x[$i] = ray.origin.x;
                $r.org_y[$i] = ray.origin.y;
                $r.org_z[$i] = ray.origin.z;
                $r.dir_x[$i] = ray.dir.x;
                $r.dir_y[$i] = ray.dir.y;
                $r.dir_z[$i] = ray.dir.z;
                $r.tnear[$i] = ray.tmin;
                $r.tfar[$i] = tfar_of(ray.tmax);
                $r.mask[$i] = u32::MAX;
            }
            None => {
                $r.org_x[$i] = 0.0;
                $r.org_y[$i] = 0.0;
                $r.org_z[$i] = 0.0;
                $r.dir_x[$i] = 0.0;
                $r.dir_y[$i] = 0.0;
                $r.dir_z[$i] = 1.0;
                $r.tnear[$i] = 0.0;
                $r.tfar[$i] = f32::NEG_INFINITY;
                $r.mask[$i] = 0;
            }
        }
        $r.time[$i] = 0.0;
        $r.flags[$i] = 0;
        $r.id[$i] = $i as u32;
    };
}

/// Batched queries with `$n`-wide packets: chunks of `$n` rays, the tail padded with inactive
/// lanes, one Embree call per chunk that has an active lane.
macro_rules! packet_queries {
    ($n:literal, $intersect_fn:ident, $occluded_fn:ident, $rayhit:ty, $rayty:ty, $c_intersect:ident, $c_occluded:ident) => {
        impl CommittedScene<'_> {
            fn $intersect_fn(&self, rays: &[Ray], hits: &mut [Option<Hit>]) {
                let invalid = self.invalid_id();
                let mut valid = ValidMask::<$n>([0; $n]);
                let mut rh = <$rayhit>::default();
                for (rays, hits) in rays.chunks($n).zip(hits.chunks_mut($n)) {
                    let mut active = false;
                    for i in 0..$n {
                        let ray = rays.get(i).filter(|r| traceable(r));
                        valid.0[i] = if ray.is_some() { -1 } else { 0 };
                        active |= ray.is_some();
                        set_lane!(rh.ray, i, ray);
                        rh.hit.geomID[i] = invalid;
                        rh.hit.primID[i] = invalid;
                        for level in rh.hit.instID.iter_mut() {
                            level[i] = invalid;
                        }
                    }
                    if active {
                        // SAFETY: the scene is committed and never modified again (so it may
                        // be traced from any thread); `valid` and `rh` are live, exclusively
                        // borrowed and aligned as this width requires (compile-time checked);
                        // every active lane holds a ray that passed `traceable`, inactive lanes
                        // are padded with finite values.
                        unsafe { sys::$c_intersect(valid.0.as_ptr(), self.raw(), &mut rh) };
                    }
                    for (i, h) in hits.iter_mut().enumerate() {
                        *h = (valid.0[i] != 0 && rh.hit.geomID[i] != invalid).then(|| Hit {
                            t: rh.ray.tfar[i],
                            prim: rh.hit.primID[i],
                            u: rh.hit.u[i],
                            v: rh.hit.v[i],
                        });
                    }
                }
            }

            fn $occluded_fn(&self, rays: &[Ray], occluded: &mut [bool]) {
                let mut valid = ValidMask::<$n>([0; $n]);
                let mut r = <$rayty>::default();
                for (rays, occluded) in rays.chunks($n).zip(occluded.chunks_mut($n)) {
                    let mut active = false;
                    for i in 0..$n {
                        let ray = rays.get(i).filter(|r| traceable(r));
                        valid.0[i] = if ray.is_some() { -1 } else { 0 };
                        active |= ray.is_some();
                        set_lane!(r, i, ray);
                    }
                    if active {
                        // SAFETY: as for the intersect packet above.
                        unsafe { sys::$c_occluded(valid.0.as_ptr(), self.raw(), &mut r) };
                    }
                    for (i, o) in occluded.iter_mut().enumerate() {
                        *o = (valid.0[i] != 0) & (r.tfar[i] < 0.0);
                    }
                }
            }
        }
    };
}

packet_queries!(4, intersect4, occluded4, sys::RTCRayHit4, sys::RTCRay4, pir_intersect4, pir_occluded4);
packet_queries!(8, intersect8, occluded8, sys::RTCRayHit8, sys::RTCRay8, pir_intersect8, pir_occluded8);
packet_queries!(
    16,
    intersect16,
    occluded16,
    sys::RTCRayHit16,
    sys::RTCRay16,
    pir_intersect16,
    pir_occluded16
);

#[cfg(test)]
mod tests {
    use super::*;
    use crate::accel::Accelerator;
    use crate::accel::embree::Embree;
    use crate::accel::embree::scene::test_quad;

    /// Whole packets at the configured width, the tail in the narrowest packet that holds it.
    #[test]
    fn batches_split_into_whole_packets_and_a_narrow_tail() {
        let runs = |len, width| packet_runs(len, width).collect::<Vec<_>>();
        assert_eq!(runs(0, 16), vec![]);
        assert_eq!(runs(3, 16), vec![(4, 0..3)]);
        assert_eq!(runs(4, 16), vec![(4, 0..4)]);
        assert_eq!(runs(5, 16), vec![(8, 0..5)]);
        assert_eq!(runs(9, 16), vec![(16, 0..9)]);
        assert_eq!(runs(16, 16), vec![(16, 0..16)]);
        assert_eq!(runs(37, 16), vec![(16, 0..32), (8, 32..37)]);
        assert_eq!(runs(64, 16), vec![(16, 0..64)]);
        assert_eq!(runs(6, 8), vec![(8, 0..6)]);
        assert_eq!(runs(10, 8), vec![(8, 0..8), (4, 8..10)]);
        assert_eq!(runs(7, 4), vec![(4, 0..4), (4, 4..7)]);
    }

    #[test]
    fn tfar_is_the_float_below_tmax() {
        assert!(tfar_of(1.0) < 1.0 && tfar_of(1.0) > 0.99999);
        assert_eq!(tfar_of(f32::INFINITY), f32::INFINITY);
        assert!(tfar_of(f32::MIN_POSITIVE) > 0.0);
    }

    #[test]
    fn hit_fields_and_open_far_end() {
        let (p, i) = test_quad();
        let e = Embree::new(&p, &i).unwrap();
        let ray = Ray::new(Vec3::new(0.5, -0.25, 2.0), Vec3::new(0.0, 0.0, -1.0));
        let h = e.intersect(&ray).unwrap();
        assert!((h.t - 2.0).abs() < 1e-6);
        assert_eq!(h.prim, 0);
        // Point = (1-u-v) a + u b + v c.
        let pt = p[0] * (1.0 - h.u - h.v) + p[1] * h.u + p[2] * h.v;
        assert!((pt - ray.at(h.t)).length() < 1e-5, "{pt}");
        // The hit at exactly t = 2 is outside the open interval (0, 2).
        assert!(e.intersect(&Ray::segment(ray.origin, ray.dir, 2.0)).is_none());
        assert!(!e.occluded(&Ray::segment(ray.origin, ray.dir, 2.0)));
        assert!(e.occluded(&Ray::segment(ray.origin, ray.dir, 2.001)));
    }

    /// Both ends of the interval are open, as the trait asks: Embree's near end is open by
    /// itself, the far end through `tfar_of`.
    #[test]
    fn interval_ends_are_open() {
        let (p, i) = test_quad();
        let e = Embree::new(&p, &i).unwrap();
        let o = Vec3::new(0.5, -0.25, 2.0);
        let at_tmin = Ray { origin: o, dir: Vec3::NEG_Z, tmin: 2.0, tmax: 3.0 };
        assert_eq!(e.intersect(&at_tmin), None);
        assert!(!e.occluded(&at_tmin));
        let past = Ray { origin: o, dir: Vec3::NEG_Z, tmin: 0.0, tmax: f32::from_bits(2.0f32.to_bits() + 1) };
        // Embree's `t` may be rounded by an ulp (1.9999999 with its AVX-512 kernels here).
        let h = e.intersect(&past).expect("the hit at t = 2 lies inside (0, 2 + ulp)");
        assert!((h.t - 2.0).abs() <= 2.0 * f32::EPSILON, "{h:?}");
        assert!(e.occluded(&past));
    }
}
