//! Building an Embree scene: every call that creates, changes or releases Embree scene state
//! (`rtcNewScene`, `rtcNewGeometry`, the buffer calls, `rtcCommit*`, `rtcAttachGeometry`,
//! `rtcRelease*`) is in this file, made under the device's build lock. The result is a
//! [`CommittedScene`], which is never modified again: tracing it is [`query`](super::query)'s
//! job, and that is all anyone else does with it. This is what makes it `Sync` (see the
//! `unsafe impl` below).
//!
//! ## Buffers
//! - Shared (zero-copy, `rtcSetSharedGeometryBuffer`): the caller's vertex array, followed by
//!   at least one more vertex for Embree's 16-byte loads (a
//!   [`VertexBuffer`](crate::geometry::VertexBuffer)'s padded slice), and index array, both
//!   borrowed for `'a`, which the [`CommittedScene<'a>`] carries: they are neither freed nor
//!   changed while Embree can read them.
//! - Copied (`rtcSetNewGeometryBuffer`): buffers that Embree allocates and pads, filled here.
//!
//! The caller ([`Embree`](super::Embree)'s constructors) has checked every index against the
//! vertex count and both counts against `u32`.

use std::marker::PhantomData;
use std::sync::Arc;

use glam::Vec3;

use super::device::Device;
use super::settings::BuildQuality;
use super::sys;

/// An owned, committed `RTCScene`, released on drop; keeps its device alive and borrows the
/// arrays a shared scene reads for `'a`.
pub(super) struct CommittedScene<'a> {
    raw: sys::RTCScene,
    device: Arc<Device>,
    /// `RTC_INVALID_GEOMETRY_ID`, read once from the shim (`pir_invalid_geometry_id`) for the
    /// queries, which compare with it on every ray.
    invalid_id: u32,
    _borrow: PhantomData<&'a [Vec3]>,
}

// SAFETY: the scene handle points to a heap object not tied to any thread (Embree's reference
// counts are atomic); it is released in `Drop` under the device's build lock, and the device
// is held through an `Arc<Device>`, which is `Send + Sync`. The arrays a shared scene reads
// are borrowed immutably for `'a` (`PhantomData<&'a [Vec3]>`, `Send` because `[Vec3]` is
// `Sync`), so moving the scene to another thread moves only a reader of data that cannot
// change while the borrow lasts.
unsafe impl Send for CommittedScene<'_> {}
// SAFETY: Embree's rule (rtcCommitScene(3)): "The modification of a geometry, committing the
// scene, and tracing of rays must always happen sequentially, and never at the same time."
// Checkable in this file: the scene is modified and committed only inside
// `CommittedScene::build`, before any `CommittedScene` value exists, and released only by
// `Drop`, which needs ownership. `&CommittedScene` gives access to read-only fields and to
// `raw()`, which only `query.rs` uses, and only for `rtcIntersect*`/`rtcOccluded*` on the
// committed scene (Embree allows those from any number of threads at once, see
// RenderKit/embree#207). There is no `&mut self` method, so no modification can race with
// tracing.
unsafe impl Sync for CommittedScene<'_> {}

const _: () = {
    const fn assert_send<T: Send>() {}
    const fn assert_sync<T: Sync>() {}
    assert_send::<CommittedScene<'static>>();
    assert_sync::<CommittedScene<'static>>();
};

impl Drop for CommittedScene<'_> {
    fn drop(&mut self) {
        let _guard = self.device.build_guard();
        // SAFETY: `raw` came from `rtcNewScene` and is released exactly once, here, while the
        // device is alive (we hold an `Arc`) and under the device's build lock.
        unsafe { sys::rtcReleaseScene(self.raw) };
    }
}

/// A scene being built: released on drop *without* taking the build lock, because it only
/// exists inside `CommittedScene::build`, which holds that lock.
struct UnfinishedScene(sys::RTCScene);

impl Drop for UnfinishedScene {
    fn drop(&mut self) {
        // SAFETY: the handle came from `rtcNewScene`, is released exactly once (the success
        // path `forget`s it and hands it to a `CommittedScene`), under the build lock held by
        // `CommittedScene::build`; the device is alive because `build` holds an `Arc` to it.
        unsafe { sys::rtcReleaseScene(self.0) };
    }
}

/// An owned `RTCGeometry`, released on drop (the scene keeps its own reference once attached).
struct GeometryHandle(sys::RTCGeometry);

impl Drop for GeometryHandle {
    fn drop(&mut self) {
        // SAFETY: the handle came from `rtcNewGeometry` and is released exactly once, here; it
        // is only ever dropped inside `CommittedScene::build` (or a test of this file), under
        // the device's build lock.
        unsafe { sys::rtcReleaseGeometry(self.0) };
    }
}

impl<'a> CommittedScene<'a> {
    /// Builds and commits a scene of one triangle geometry (none when `indices` is empty):
    /// from `share` (the vertices followed by at least one more vertex, and the indices,
    /// borrowed for `'a`) without copies when given, else from copies of `positions` and
    /// `indices`. Every index must be below `positions.len()` (checked by the caller).
    pub(super) fn build(
        device: Arc<Device>,
        positions: &[Vec3],
        indices: &[[u32; 3]],
        share: Option<(&'a [Vec3], &'a [[u32; 3]])>,
        quality: BuildQuality,
    ) -> Result<CommittedScene<'a>, String> {
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
                Some((padded, indices)) => share_buffers(&device, &geom, positions.len(), padded, indices)?,
                None => copy_buffers(&device, &geom, positions, indices)?,
            }
            // SAFETY: live geometry with both buffers filled; all indices were checked to be in
            // range by the caller. Attaching gives the scene its own reference; ours is
            // released when `geom` drops at the end of this block, still under the build lock.
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
        // SAFETY: a pure function of the shim returning the constant RTC_INVALID_GEOMETRY_ID.
        let invalid_id = unsafe { sys::pir_invalid_geometry_id() };
        let raw = scene.0;
        std::mem::forget(scene);
        drop(guard);
        Ok(CommittedScene { raw, device, invalid_id, _borrow: PhantomData })
    }

    /// The committed scene's handle, for `query.rs`: to be passed to `rtcIntersect*` and
    /// `rtcOccluded*` only (the `Sync` argument above relies on it).
    pub(super) fn raw(&self) -> sys::RTCScene {
        self.raw
    }

    /// `RTC_INVALID_GEOMETRY_ID`: a ray's `geomID` before tracing, and after a miss.
    pub(super) fn invalid_id(&self) -> u32 {
        self.invalid_id
    }

    /// The device the scene lives on.
    pub(super) fn device(&self) -> &Arc<Device> {
        &self.device
    }
}

/// Binds the caller's arrays as the geometry's vertex and index buffers (no copy).
fn share_buffers<'a>(
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
    // `indices.len()` UINT3 items at a 12-byte stride. Both are borrowed for `'a`, which the
    // `CommittedScene<'a>` built from this geometry carries: they are neither freed nor
    // changed while Embree can read them (the scene is released when it drops, before the
    // borrow ends).
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
    // SAFETY: live geometry, under the build lock; FLOAT3 with a 12-byte stride and
    // `positions.len()` items. Embree allocates (and pads) the buffer and returns its
    // address, or null on error.
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::accel::Accelerator;
    use crate::accel::embree::Embree;
    use crate::accel::embree::scene::test_quad;
    use crate::geometry::{Ray, VertexBuffer};

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
        let (p, i) = test_quad();
        let vertices = VertexBuffer::from(p.to_vec());
        let e = Embree::shared(&vertices, &i).unwrap();
        // SAFETY: the scene is committed and alive (borrowed from `e`); geometry 0 is the mesh,
        // and asking for its buffers' addresses reads no buffer data and changes nothing.
        let (vb, ib) = unsafe {
            let geom = sys::rtcGetGeometry(e.scene.raw(), 0);
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
    fn the_invalid_id_comes_from_the_shim() {
        let (p, i) = test_quad();
        // RTC_INVALID_GEOMETRY_ID is documented as all bits set.
        assert_eq!(Embree::new(&p, &i).unwrap().scene.invalid_id(), u32::MAX);
    }
}
