//! [`Embree`] behind pir's [`Accelerator`] trait: the name, the render summary's description,
//! and the four queries, which `query.rs` answers.

use super::scene::Embree;
use super::sys;
use crate::accel::{Accelerator, Hit};
use crate::geometry::Ray;

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
        let d = self.device();
        let natives: Vec<String> = d.native_packet_widths().iter().map(|w| w.to_string()).collect();
        format!(
            "embree {} (API {}, CPU ISA {}, native packets {}, tasking {}): {} triangles, {} quality, \
             built in {:.1} ms, {} buffers, batches in {}-wide packets (a short tail narrower)",
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
        self.scene.intersect1(ray)
    }

    fn occluded(&self, ray: &Ray) -> bool {
        self.scene.occluded1(ray)
    }

    fn intersect_batch(&self, rays: &[Ray], hits: &mut [Option<Hit>]) {
        self.scene.intersect_batch(self.width, rays, hits);
    }

    fn occluded_batch(&self, rays: &[Ray], occluded: &mut [bool]) {
        self.scene.occluded_batch(self.width, rays, occluded);
    }
}
