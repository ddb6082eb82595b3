//! [`Embree`]: a committed Embree triangle scene behind pir's [`Accelerator`] trait.
//!
//! ## Settings ([`EmbreeSettings`])
//! | field | type | default | meaning |
//! |---|---|---|---|
//! | `quality` | [`BuildQuality`] | `Medium` | BVH build quality (`High` ≈ 5× slower build, for long renders) |
//! | `packet_width` | [`PacketWidth`] | `Auto` | width of the packets used by the batch queries (`Auto`: widest native) |
//!
//! ## Geometry
//! One triangle geometry. [`Embree::shared`] (what the renderer uses) hands Embree the scene's
//! own vertex and index arrays without a copy (`rtcSetSharedGeometryBuffer`): the vertices come
//! as a [`VertexBuffer`], which keeps a padding vertex after the last one for Embree's 16-byte
//! loads, and both arrays stay borrowed, so unchanged and alive, for the lifetime `'a` of the
//! [`Embree`] value. [`Embree::new`] takes any slices and copies them into buffers that Embree
//! allocates and pads (`rtcSetNewGeometryBuffer`). Indices are checked against the vertex
//! count before Embree sees them (Embree does not check). An empty mesh gives an empty
//! committed scene.
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
//!   RTC_INVALID_GEOMETRY_ID`; a hit is `geomID != RTC_INVALID_GEOMETRY_ID`, an occluded ray
//!   comes back with `tfar = -inf` (tested as `tfar < 0`).
//! - Embree's `u, v` are the barycentrics of the triangle's vertices 1 and 2: the same
//!   convention as [`Hit`]. `primID` is the index into the `indices` slice.
//! - Queries use the INCOHERENT flag (set in the C shim): COHERENT was ~2× slower for
//!   divergent shadow rays here.
//!
//! ## Threads
//! Building holds the device's build lock; a committed scene is never modified again, and
//! Embree allows any number of threads to trace a committed scene at once, so [`Embree`] is
//! `Send + Sync` and needs no locking for queries. Call
//! [`set_flush_denormals`](super::set_flush_denormals) on each tracing thread.

use std::fmt;
use std::marker::PhantomData;
use std::str::FromStr;
use std::sync::Arc;
use std::time::{Duration, Instant};

use glam::Vec3;

use super::device::Device;
use super::sys;
use crate::accel::{Accelerator, Hit};
use crate::geometry::{Ray, VertexBuffer};

/// `RTC_INVALID_GEOMETRY_ID`, a macro bindgen cannot translate.
const INVALID_ID: u32 = u32::MAX;

/// Embree's `FLT_LARGE`: its ray validity check rejects larger origin/direction components.
const FLT_LARGE: f32 = 1.844e18;

/// BVH build quality (`RTC_BUILD_QUALITY_*`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum BuildQuality {
    /// Fastest build, slower traversal (dynamic scenes).
    Low,
    /// Embree's default: a good build for most renders.
    #[default]
    Medium,
    /// Spatial splits: ~5× slower to build, faster traversal on long renders.
    High,
}

impl BuildQuality {
    fn raw(self) -> sys::RTCBuildQuality {
        match self {
            BuildQuality::Low => sys::RTCBuildQuality::RTC_BUILD_QUALITY_LOW,
            BuildQuality::Medium => sys::RTCBuildQuality::RTC_BUILD_QUALITY_MEDIUM,
            BuildQuality::High => sys::RTCBuildQuality::RTC_BUILD_QUALITY_HIGH,
        }
    }
}

impl fmt::Display for BuildQuality {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            BuildQuality::Low => "low",
            BuildQuality::Medium => "medium",
            BuildQuality::High => "high",
        })
    }
}

impl FromStr for BuildQuality {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s.to_ascii_lowercase().as_str() {
            "low" => Ok(BuildQuality::Low),
            "medium" => Ok(BuildQuality::Medium),
            "high" => Ok(BuildQuality::High),
            _ => Err(format!("unknown Embree build quality {s:?} (expected low, medium or high)")),
        }
    }
}

/// The packet width used by `intersect_batch` / `occluded_batch`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum PacketWidth {
    /// The widest width the device supports natively (16 with AVX-512, 8 with AVX2, else 4).
    #[default]
    Auto,
    W4,
    W8,
    W16,
}

/// Settings of the Embree backend; see the module docs for the table of defaults.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct EmbreeSettings {
    pub quality: BuildQuality,
    pub packet_width: PacketWidth,
}

/// An owned `RTCScene`, released on drop. Keeps its device alive.
struct SceneHandle {
    raw: sys::RTCScene,
    device: Arc<Device>,
}

impl Drop for SceneHandle {
    fn drop(&mut self) {
        let _guard = self.device.build_guard();
        // SAFETY: `raw` came from `rtcNewScene` and is released exactly once, here, while the
        // device is alive (we hold an `Arc`) and under the device's build lock.
        unsafe { sys::rtcReleaseScene(self.raw) };
    }
}

/// A scene being built: released on drop *without* taking the build lock, because it only
/// exists inside `Embree::build`, which holds that lock.
struct UnfinishedScene(sys::RTCScene);

impl Drop for UnfinishedScene {
    fn drop(&mut self) {
        // SAFETY: the handle came from `rtcNewScene`, is released exactly once (the success
        // path `forget`s it and hands it to a `SceneHandle`), under the build lock held by
        // `Embree::build`; the device is alive because `build` holds an `Arc` to it.
        unsafe { sys::rtcReleaseScene(self.0) };
    }
}

/// An owned `RTCGeometry`, released on drop (the scene keeps its own reference once attached).
struct GeometryHandle(sys::RTCGeometry);

impl Drop for GeometryHandle {
    fn drop(&mut self) {
        // SAFETY: the handle came from `rtcNewGeometry` and is released exactly once, here; it
        // is only ever dropped inside `Embree::build`, under the device's build lock.
        unsafe { sys::rtcReleaseGeometry(self.0) };
    }
}

/// The Embree backend: a committed triangle scene, borrowing its vertex and index arrays for
/// `'a` when built with [`Embree::shared`] (`'static` when built with copies).
pub struct Embree<'a> {
    scene: SceneHandle,
    settings: EmbreeSettings,
    width: usize,
    triangles: usize,
    build_time: Duration,
    /// Whether the scene reads the caller's arrays (zero-copy) rather than its own copies.
    shared: bool,
    _borrow: PhantomData<&'a [Vec3]>,
}

// SAFETY: the scene handle points to a heap object not tied to any thread; it is released
// under the device's build lock, and `Device` is itself `Send + Sync`. Shared arrays are
// borrowed immutably (`&'a [Vec3]`, which is `Send`), so moving the scene to another thread
// moves only a reader of data that cannot change while the borrow lasts.
unsafe impl Send for Embree<'_> {}
// SAFETY: Embree's rule (rtcCommitScene(3)): "The modification of a geometry, committing the
// scene, and tracing of rays must always happen sequentially, and never at the same time."
// The scene is modified and committed only inside `Embree::build`, before any `Embree` value
// exists; afterwards `&Embree` gives access to nothing but `rtcIntersect*`/`rtcOccluded*` on
// the committed scene (which Embree allows from any number of threads at once, see
// RenderKit/embree#207) and to read-only fields. There is no `&mut self` method that touches
// the scene, so no modification can race with tracing.
unsafe impl Sync for Embree<'_> {}

const _: () = {
    const fn assert_send<T: Send>() {}
    const fn assert_sync<T: Sync>() {}
    assert_send::<Embree<'static>>();
    assert_sync::<Embree<'static>>();
    assert_send::<Device>();
    assert_sync::<Device>();
    assert_send::<Arc<Device>>();
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

impl<'a> Embree<'a> {
    /// Builds a scene that reads `positions` and `indices` where they are, without copying
    /// them (default settings, the process-wide [`Device::shared`] device). They stay borrowed
    /// for as long as the scene exists.
    pub fn shared(positions: &'a VertexBuffer, indices: &'a [[u32; 3]]) -> Result<Embree<'a>, String> {
        Embree::create(
            Device::shared()?,
            positions,
            indices,
            Some((positions.padded(), indices)),
            EmbreeSettings::default(),
        )
    }
}

impl Embree<'static> {
    /// Builds a scene of the triangles `indices` over `positions` with default settings on the
    /// process-wide [`Device::shared`] device, copying both into Embree's own buffers.
    pub fn new(positions: &[Vec3], indices: &[[u32; 3]]) -> Result<Embree<'static>, String> {
        Embree::with_settings(positions, indices, EmbreeSettings::default())
    }

    /// As [`Embree::new`], with explicit settings.
    pub fn with_settings(
        positions: &[Vec3],
        indices: &[[u32; 3]],
        settings: EmbreeSettings,
    ) -> Result<Embree<'static>, String> {
        Embree::with_device(Device::shared()?, positions, indices, settings)
    }

    /// As [`Embree::with_settings`], on a given device.
    pub fn with_device(
        device: Arc<Device>,
        positions: &[Vec3],
        indices: &[[u32; 3]],
        settings: EmbreeSettings,
    ) -> Result<Embree<'static>, String> {
        Embree::create(device, positions, indices, None, settings)
    }
}

impl<'a> Embree<'a> {
    /// Checks the mesh and builds the scene: from `share` (the vertices followed by at least
    /// one more vertex, and the indices, borrowed for `'a`) without copies when given, else
    /// from copies of `positions` and `indices`.
    fn create(
        device: Arc<Device>,
        positions: &[Vec3],
        indices: &[[u32; 3]],
        share: Option<(&'a [Vec3], &'a [[u32; 3]])>,
        settings: EmbreeSettings,
    ) -> Result<Embree<'a>, String> {
        if let Some((i, t)) =
            indices.iter().enumerate().find(|(_, t)| t.iter().any(|&v| v as usize >= positions.len()))
        {
            return Err(format!(
                "triangle {i} has vertex index {t:?} out of range ({} vertices)",
                positions.len()
            ));
        }
        if u32::try_from(indices.len()).is_err() || u32::try_from(positions.len()).is_err() {
            return Err("more than 2^32 triangles or vertices".into());
        }
        let natives = device.native_packet_widths();
        let width = match settings.packet_width {
            PacketWidth::Auto => natives.last().copied().unwrap_or(4),
            PacketWidth::W4 => 4,
            PacketWidth::W8 => 8,
            PacketWidth::W16 => 16,
        };
        let start = Instant::now();
        let scene = Embree::build(device, positions, indices, share, settings.quality)?;
        Ok(Embree {
            scene,
            settings,
            width,
            triangles: indices.len(),
            build_time: start.elapsed(),
            shared: share.is_some(),
            _borrow: PhantomData,
        })
    }

    fn build(
        device: Arc<Device>,
        positions: &[Vec3],
        indices: &[[u32; 3]],
        share: Option<(&'a [Vec3], &'a [[u32; 3]])>,
        quality: BuildQuality,
    ) -> Result<SceneHandle, String> {
        let guard = device.build_guard();
        let errors_before = device.error_count();
        // SAFETY: the device is live (we hold an `Arc`); creation is done under its build lock.
        let raw = unsafe { sys::rtcNewScene(device.raw()) };
        if raw.is_null() {
            return Err(format!("rtcNewScene failed: {:?}", device.errors_since(errors_before)));
        }
        // Declared after `guard`, so dropped (released) first on every early return or
        // unwind, while the lock is still held.
        let scene = UnfinishedScene(raw);
        // SAFETY: `scene.0` is a live scene not yet shared with anyone.
        unsafe { sys::rtcSetSceneBuildQuality(scene.0, quality.raw()) };

        if !indices.is_empty() {
            // SAFETY: live device, under the build lock.
            let geom = unsafe {
                sys::rtcNewGeometry(device.raw(), sys::RTCGeometryType::RTC_GEOMETRY_TYPE_TRIANGLE)
            };
            if geom.is_null() {
                return Err(format!("rtcNewGeometry failed: {:?}", device.errors_since(errors_before)));
            }
            let geom = GeometryHandle(geom);
            // SAFETY: live geometry not yet attached to anything.
            unsafe { sys::rtcSetGeometryBuildQuality(geom.0, quality.raw()) };
            match share {
                Some((padded, indices)) => {
                    Embree::share_buffers(&device, &geom, positions.len(), padded, indices)?
                }
                None => Embree::copy_buffers(&device, &geom, positions, indices)?,
            }
            // SAFETY: live geometry with both buffers filled; all indices were checked to be in
            // range above. Attaching gives the scene its own reference; ours is released when
            // `geom` drops at the end of this block, still under the build lock.
            unsafe {
                sys::rtcCommitGeometry(geom.0);
                sys::rtcAttachGeometry(scene.0, geom.0);
            }
        }
        // SAFETY: live scene, all its geometries committed; nothing traces it yet.
        unsafe { sys::rtcCommitScene(scene.0) };
        let errors = device.errors_since(errors_before);
        if !errors.is_empty() {
            return Err(format!("building the Embree scene failed: {}", errors.join("; ")));
        }
        let raw = scene.0;
        std::mem::forget(scene);
        drop(guard);
        Ok(SceneHandle { raw, device })
    }

    /// Binds the caller's arrays as the geometry's vertex and index buffers (no copy).
    fn share_buffers(
        device: &Device,
        geom: &GeometryHandle,
        vertices: usize,
        padded: &'a [Vec3],
        indices: &'a [[u32; 3]],
    ) -> Result<(), String> {
        assert!(padded.len() > vertices, "the shared vertex array must be padded");
        let errors_before = device.error_count();
        // SAFETY: live geometry, under the build lock. `padded` holds `vertices` FLOAT3 items at
        // a 12-byte stride (`Vec3` is three packed f32s, 4-byte aligned) followed by at least one
        // more vertex, so the 16-byte load of the last item stays inside the slice, as
        // rtcSetSharedGeometryBuffer(3) requires of vertex buffers. `indices` holds
        // `indices.len()` UINT3 items at a 12-byte stride. Both are borrowed for `'a`, which
        // the returned `Embree<'a>` carries: they are neither freed nor changed while Embree can
        // read them (the scene is released when the `Embree` drops, before the borrow ends).
        unsafe {
            sys::rtcSetSharedGeometryBuffer(
                geom.0,
                sys::RTCBufferType::RTC_BUFFER_TYPE_VERTEX,
                0,
                sys::RTCFormat::RTC_FORMAT_FLOAT3,
                padded.as_ptr().cast(),
                0,
                12,
                vertices,
            );
            sys::rtcSetSharedGeometryBuffer(
                geom.0,
                sys::RTCBufferType::RTC_BUFFER_TYPE_INDEX,
                0,
                sys::RTCFormat::RTC_FORMAT_UINT3,
                indices.as_ptr().cast(),
                0,
                12,
                indices.len(),
            );
        }
        let errors = device.errors_since(errors_before);
        if errors.is_empty() { Ok(()) } else { Err(format!("rtcSetSharedGeometryBuffer failed: {errors:?}")) }
    }

    /// Copies the arrays into buffers that Embree allocates (and pads) for the geometry.
    fn copy_buffers(
        device: &Device,
        geom: &GeometryHandle,
        positions: &[Vec3],
        indices: &[[u32; 3]],
    ) -> Result<(), String> {
        let errors_before = device.error_count();
        // SAFETY: live geometry; FLOAT3 with a 12-byte stride and `positions.len()` items.
        // Embree allocates (and pads) the buffer and returns its address, or null on error.
        let vb = unsafe {
            sys::rtcSetNewGeometryBuffer(
                geom.0,
                sys::RTCBufferType::RTC_BUFFER_TYPE_VERTEX,
                0,
                sys::RTCFormat::RTC_FORMAT_FLOAT3,
                12,
                positions.len(),
            )
        } as *mut f32;
        // SAFETY: as above, UINT3 with a 12-byte stride and `indices.len()` items.
        let ib = unsafe {
            sys::rtcSetNewGeometryBuffer(
                geom.0,
                sys::RTCBufferType::RTC_BUFFER_TYPE_INDEX,
                0,
                sys::RTCFormat::RTC_FORMAT_UINT3,
                12,
                indices.len(),
            )
        } as *mut u32;
        if vb.is_null() || ib.is_null() {
            return Err(format!("rtcSetNewGeometryBuffer failed: {:?}", device.errors_since(errors_before)));
        }
        // SAFETY: Embree returned a buffer of at least `3 * positions.len()` f32s (12-byte
        // stride), aligned to at least 16 bytes, owned by the geometry, which is alive and
        // not accessed by Embree until commit. No other reference to it exists.
        let verts = unsafe { std::slice::from_raw_parts_mut(vb, 3 * positions.len()) };
        for (dst, p) in verts.chunks_exact_mut(3).zip(positions) {
            dst.copy_from_slice(&p.to_array());
        }
        // SAFETY: same for the index buffer, `3 * indices.len()` u32s.
        let idx = unsafe { std::slice::from_raw_parts_mut(ib, 3 * indices.len()) };
        for (dst, t) in idx.chunks_exact_mut(3).zip(indices) {
            dst.copy_from_slice(t);
        }
        Ok(())
    }

    /// The settings the scene was built with.
    pub fn settings(&self) -> EmbreeSettings {
        self.settings
    }

    /// The packet width the batch queries use (4, 8 or 16).
    pub fn packet_width(&self) -> usize {
        self.width
    }

    /// The wall-clock time of the build (buffer fill and commit).
    pub fn build_time(&self) -> Duration {
        self.build_time
    }

    /// The device the scene lives on.
    pub fn device(&self) -> &Arc<Device> {
        &self.scene.device
    }

    fn single_rayhit(ray: &Ray) -> sys::RTCRayHit {
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
        rh.hit.geomID = INVALID_ID;
        rh.hit.primID = INVALID_ID;
        rh.hit.instID.fill(INVALID_ID);
        rh
    }
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
        impl Embree<'_> {
            fn $intersect_fn(&self, rays: &[Ray], hits: &mut [Option<Hit>]) {
                let mut valid = ValidMask::<$n>([0; $n]);
                let mut rh = <$rayhit>::default();
                for (rays, hits) in rays.chunks($n).zip(hits.chunks_mut($n)) {
                    let mut active = false;
                    for i in 0..$n {
                        let ray = rays.get(i).filter(|r| traceable(r));
                        valid.0[i] = if ray.is_some() { -1 } else { 0 };
                        active |= ray.is_some();
                        set_lane!(rh.ray, i, ray);
                        rh.hit.geomID[i] = INVALID_ID;
                        rh.hit.primID[i] = INVALID_ID;
                        for level in rh.hit.instID.iter_mut() {
                            level[i] = INVALID_ID;
                        }
                    }
                    if active {
                        // SAFETY: the scene is committed and never modified again (so it may
                        // be traced from any thread); `valid` and `rh` are live, exclusively
                        // borrowed and aligned as this width requires (compile-time checked);
                        // every active lane holds a ray that passed `traceable`, inactive lanes
                        // are padded with finite values.
                        unsafe { sys::$c_intersect(valid.0.as_ptr(), self.scene.raw, &mut rh) };
                    }
                    for (i, h) in hits.iter_mut().enumerate() {
                        *h = (valid.0[i] != 0 && rh.hit.geomID[i] != INVALID_ID).then(|| Hit {
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
                        unsafe { sys::$c_occluded(valid.0.as_ptr(), self.scene.raw, &mut r) };
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

/// The best SIMD ISA of this CPU among those Embree has kernels for (Embree picks the best
/// one it was compiled with at run time; Debian's build has all of them).
fn cpu_isa() -> &'static str {
    #[cfg(target_arch = "x86_64")]
    {
        if std::arch::is_x86_feature_detected!("avx512f") {
            "AVX-512"
        } else if std::arch::is_x86_feature_detected!("avx2") {
            "AVX2"
        } else if std::arch::is_x86_feature_detected!("avx") {
            "AVX"
        } else if std::arch::is_x86_feature_detected!("sse4.2") {
            "SSE4.2"
        } else {
            "SSE2"
        }
    }
    #[cfg(target_arch = "aarch64")]
    {
        "NEON"
    }
    #[cfg(not(any(target_arch = "x86_64", target_arch = "aarch64")))]
    {
        "unknown"
    }
}

impl Accelerator for Embree<'_> {
    fn name(&self) -> &str {
        "embree"
    }

    fn describe(&self) -> String {
        let d = &self.scene.device;
        let natives: Vec<String> = d.native_packet_widths().iter().map(|w| w.to_string()).collect();
        format!(
            "embree {} (API {}, CPU ISA {}, native packets {}, tasking {}): {} triangles, {} quality, \
             built in {:.1} ms, {} buffers, {}-wide batches",
            d.version(),
            // SAFETY: a pure function of the shim returning a constant.
            unsafe { sys::pir_embree_major() },
            cpu_isa(),
            if natives.is_empty() { "none".to_string() } else { natives.join("/") },
            d.tasking_system(),
            self.triangles,
            self.settings.quality,
            self.build_time.as_secs_f64() * 1e3,
            if self.shared { "shared" } else { "copied" },
            self.width,
        )
    }

    fn intersect(&self, ray: &Ray) -> Option<Hit> {
        if !traceable(ray) {
            return None;
        }
        let mut rh = Embree::single_rayhit(ray);
        // SAFETY: the scene is committed and never modified again, so it may be traced from
        // any thread; `rh` is a live, 16-byte aligned (bindgen keeps RTC_ALIGN(16)) ray/hit
        // with a ray that passed `traceable`, mask/flags/time set and the ids invalidated.
        unsafe { sys::pir_intersect1(self.scene.raw, &mut rh) };
        (rh.hit.geomID != INVALID_ID).then_some(Hit {
            t: rh.ray.tfar,
            prim: rh.hit.primID,
            u: rh.hit.u,
            v: rh.hit.v,
        })
    }

    fn occluded(&self, ray: &Ray) -> bool {
        if !traceable(ray) {
            return false;
        }
        let mut rh = Embree::single_rayhit(ray);
        // SAFETY: as in `intersect`; `rh.ray` is the `RTCRay` part of the struct (16-byte
        // aligned); Embree writes only its `tfar`.
        unsafe { sys::pir_occluded1(self.scene.raw, &mut rh.ray) };
        rh.ray.tfar < 0.0
    }

    fn intersect_batch(&self, rays: &[Ray], hits: &mut [Option<Hit>]) {
        assert_eq!(rays.len(), hits.len());
        match self.width {
            16 => self.intersect16(rays, hits),
            8 => self.intersect8(rays, hits),
            _ => self.intersect4(rays, hits),
        }
    }

    fn occluded_batch(&self, rays: &[Ray], occluded: &mut [bool]) {
        assert_eq!(rays.len(), occluded.len());
        match self.width {
            16 => self.occluded16(rays, occluded),
            8 => self.occluded8(rays, occluded),
            _ => self.occluded4(rays, occluded),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn quad() -> (Vec<Vec3>, Vec<[u32; 3]>) {
        let p = vec![
            Vec3::new(-1.0, -1.0, 0.0),
            Vec3::new(1.0, -1.0, 0.0),
            Vec3::new(1.0, 1.0, 0.0),
            Vec3::new(-1.0, 1.0, 0.0),
        ];
        (p, vec![[0, 1, 2], [0, 2, 3]])
    }

    #[test]
    fn tfar_is_the_float_below_tmax() {
        assert!(tfar_of(1.0) < 1.0 && tfar_of(1.0) > 0.99999);
        assert_eq!(tfar_of(f32::INFINITY), f32::INFINITY);
        assert!(tfar_of(f32::MIN_POSITIVE) > 0.0);
    }

    #[test]
    fn hit_fields_and_open_far_end() {
        let (p, i) = quad();
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
        let (p, i) = quad();
        let e = Embree::new(&p, &i).unwrap();
        let o = Vec3::new(0.5, -0.25, 2.0);
        let at_tmin = Ray { origin: o, dir: Vec3::NEG_Z, tmin: 2.0, tmax: 3.0 };
        assert_eq!(e.intersect(&at_tmin), None);
        assert!(!e.occluded(&at_tmin));
        let past = Ray { origin: o, dir: Vec3::NEG_Z, tmin: 0.0, tmax: f32::from_bits(2.0f32.to_bits() + 1) };
        assert_eq!(e.intersect(&past).map(|h| h.t), Some(2.0));
        assert!(e.occluded(&past));
    }

    #[test]
    fn embree_errors_reach_the_callback() {
        let device = Device::new().unwrap();
        assert_eq!(device.error_count(), 0);
        {
            let _guard = device.build_guard();
            // SAFETY: a live device, under its build lock; the geometry is released by its
            // handle. A UINT3 vertex buffer is an invalid operation: Embree reports it through
            // the error callback and returns null, which is not dereferenced.
            let buffer = unsafe {
                let geom = GeometryHandle(sys::rtcNewGeometry(
                    device.raw(),
                    sys::RTCGeometryType::RTC_GEOMETRY_TYPE_TRIANGLE,
                ));
                sys::rtcSetNewGeometryBuffer(
                    geom.0,
                    sys::RTCBufferType::RTC_BUFFER_TYPE_VERTEX,
                    0,
                    sys::RTCFormat::RTC_FORMAT_UINT3,
                    12,
                    3,
                )
            };
            assert!(buffer.is_null());
        }
        assert_eq!(device.error_count(), 1);
        let errors = device.errors_since(0);
        assert!(errors.len() == 1 && errors[0].starts_with("Embree error"), "{errors:?}");
        assert!(device.errors_since(1).is_empty());
    }

    #[test]
    fn shared_scene_reads_the_callers_arrays_in_place() {
        let (p, i) = quad();
        let vertices = VertexBuffer::from(p.to_vec());
        let e = Embree::shared(&vertices, &i).unwrap();
        // SAFETY: the scene is committed and alive (borrowed from `e`); geometry 0 is the mesh,
        // and asking for its buffers' addresses reads no buffer data.
        let (vb, ib) = unsafe {
            let geom = sys::rtcGetGeometry(e.scene.raw, 0);
            (
                sys::rtcGetGeometryBufferData(geom, sys::RTCBufferType::RTC_BUFFER_TYPE_VERTEX, 0),
                sys::rtcGetGeometryBufferData(geom, sys::RTCBufferType::RTC_BUFFER_TYPE_INDEX, 0),
            )
        };
        assert_eq!(vb as *const Vec3, vertices.padded().as_ptr());
        assert_eq!(ib as *const [u32; 3], i.as_ptr());
        assert!(e.intersect(&Ray::new(Vec3::new(0.0, 0.0, 1.0), Vec3::NEG_Z)).is_some());
        assert!(e.describe().contains("shared buffers"), "{}", e.describe());
        assert!(Embree::new(&p, &i).unwrap().describe().contains("copied buffers"));
    }

    #[test]
    fn bad_indices_are_an_error() {
        let (p, _) = quad();
        let err = Embree::new(&p, &[[0, 1, 4]]).err().unwrap();
        assert!(err.contains("out of range"), "{err}");
    }

    #[test]
    fn own_device_is_released_after_its_scenes() {
        let (p, i) = quad();
        let device = Device::new().unwrap();
        let e = Embree::with_device(device, &p, &i, EmbreeSettings::default()).unwrap();
        // The scene keeps the device alive; dropping `e` releases scene, then device.
        assert!(e.intersect(&Ray::new(Vec3::new(0.0, 0.0, 1.0), Vec3::NEG_Z)).is_some());
        assert_eq!(e.device().error_count(), 0);
        drop(e);
    }

    #[test]
    fn quality_parses_and_all_qualities_build() {
        let (p, i) = quad();
        for q in ["low", "Medium", "HIGH"] {
            let quality: BuildQuality = q.parse().unwrap();
            let e = Embree::with_settings(&p, &i, EmbreeSettings { quality, ..Default::default() }).unwrap();
            assert!(e.occluded(&Ray::new(Vec3::new(0.0, 0.0, 1.0), Vec3::NEG_Z)));
            assert!(e.describe().contains(&format!("{quality} quality")), "{}", e.describe());
        }
        assert!("ultra".parse::<BuildQuality>().is_err());
    }
}
