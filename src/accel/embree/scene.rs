//! [`Embree`]: the Embree backend's public type, a committed triangle scene.
//!
//! This file checks the mesh, picks the packet width and keeps what the render summary
//! reports. The scene itself is a [`CommittedScene`], made by [`build`](super::build) (every
//! call that creates or changes Embree state) and traced by [`query`](super::query) (nothing
//! but `rtcIntersect*`/`rtcOccluded*`); [`accelerator`](super::accelerator) puts it behind
//! pir's [`Accelerator`](crate::accel::Accelerator) trait.
//!
//! ## Geometry
//! One triangle geometry. [`Embree::shared`] (what the renderer uses) hands Embree the scene's
//! own vertex and index arrays without a copy: they stay borrowed, so unchanged and alive, for
//! the lifetime `'a` of the [`Embree`] value. [`Embree::new`] takes any slices and copies them
//! into buffers that Embree allocates. Indices are checked against the vertex count here,
//! before Embree sees them (Embree does not check). An empty mesh gives an empty committed
//! scene.
//!
//! ## Threads
//! [`Embree`] is `Send + Sync` because its [`CommittedScene`] is (the argument is stated
//! there, in `build.rs`); it needs no locking for queries. Call
//! [`set_flush_denormals`](crate::accel::set_flush_denormals) on each tracing thread.

use std::sync::Arc;
use std::time::{Duration, Instant};

use glam::Vec3;

use super::build::CommittedScene;
use super::device::Device;
use super::settings::EmbreeSettings;
use crate::geometry::VertexBuffer;

/// The Embree backend: a committed triangle scene, borrowing its vertex and index arrays for
/// `'a` when built with [`Embree::shared`] (`'static` when built with copies).
pub struct Embree<'a> {
    pub(super) scene: CommittedScene<'a>,
    pub(super) settings: EmbreeSettings,
    /// The packet width of the batch queries (4, 8 or 16).
    pub(super) width: usize,
    pub(super) triangles: usize,
    pub(super) build_time: Duration,
    /// Whether the scene reads the caller's arrays (zero-copy) rather than its own copies.
    pub(super) shared: bool,
}

const _: () = {
    const fn assert_send<T: Send>() {}
    const fn assert_sync<T: Sync>() {}
    assert_send::<Embree<'static>>();
    assert_sync::<Embree<'static>>();
    assert_send::<Device>();
    assert_sync::<Device>();
    assert_send::<Arc<Device>>();
};

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
        let width = settings.packet_width.lanes(&device.native_packet_widths());
        let start = Instant::now();
        let scene = CommittedScene::build(device, positions, indices, share, settings.quality)?;
        Ok(Embree {
            scene,
            settings,
            width,
            triangles: indices.len(),
            build_time: start.elapsed(),
            shared: share.is_some(),
        })
    }

    /// The settings the scene was built with.
    pub fn settings(&self) -> EmbreeSettings {
        self.settings
    }

    /// The wall-clock time of the build (buffer fill and commit).
    pub fn build_time(&self) -> Duration {
        self.build_time
    }

    /// The device the scene lives on.
    pub fn device(&self) -> &Arc<Device> {
        self.scene.device()
    }
}

/// A two-triangle unit quad in the z = 0 plane, for the unit tests of this module.
#[cfg(test)]
pub(super) fn test_quad() -> (Vec<Vec3>, Vec<[u32; 3]>) {
    let p = vec![
        Vec3::new(-1.0, -1.0, 0.0),
        Vec3::new(1.0, -1.0, 0.0),
        Vec3::new(1.0, 1.0, 0.0),
        Vec3::new(-1.0, 1.0, 0.0),
    ];
    (p, vec![[0, 1, 2], [0, 2, 3]])
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::accel::Accelerator;
    use crate::geometry::Ray;

    #[test]
    fn bad_indices_are_an_error() {
        let (p, _) = test_quad();
        let err = Embree::new(&p, &[[0, 1, 4]]).err().unwrap();
        assert!(err.contains("out of range"), "{err}");
    }

    #[test]
    fn own_device_is_released_after_its_scenes() {
        let (p, i) = test_quad();
        let device = Device::new().unwrap();
        let e = Embree::with_device(device, &p, &i, EmbreeSettings::default()).unwrap();
        // The scene keeps the device alive; dropping `e` releases scene, then device.
        assert!(e.intersect(&Ray::new(Vec3::new(0.0, 0.0, 1.0), Vec3::NEG_Z)).is_some());
        assert_eq!(e.device().error_count(), 0);
        drop(e);
    }
}
