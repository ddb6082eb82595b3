//! The Embree backend: Intel's ray-tracing kernels through FFI.
//!
//! This module is the only place in pir with `unsafe` code; every `unsafe` block carries a
//! `// SAFETY:` comment and every `unsafe impl Send/Sync` cites the Embree rule it relies on.
//!
//! Layout:
//! - `sys`: bindgen output over the installed Embree headers and the `ffi/pir_embree.c` shim
//!   (which hides the Embree 3/4 differences: context/arguments initialisation and the
//!   argument order of `rtcIntersect*`/`rtcOccluded*`).
//! - `device`: [`Device`], one Embree device with an error callback, RAII release.
//! - `scene`: [`Embree`], a committed triangle scene implementing
//!   [`Accelerator`](super::Accelerator), with single-ray and 4/8/16-wide packet queries.
//!
//! Parts that exist whether or not Embree was found at build time: [`embree_status`] (for the
//! render summary) and [`set_flush_denormals`] (for rayon's `start_handler`).
//!
//! Building: `build.rs` looks for Embree 4, then 3 (`EMBREE_DIR`, else `/usr/include`,
//! `/usr/local/include`). `PIR_NO_EMBREE=1` forces the pure-Rust build, `PIR_REQUIRE_EMBREE=1`
//! makes a missing Embree a build error. On Debian/Ubuntu:
//! `apt-get install libembree-dev libclang-dev`.

#[cfg(pir_embree)]
mod device;
#[cfg(pir_embree)]
mod scene;
#[cfg(pir_embree)]
mod sys;

#[cfg(pir_embree)]
pub use device::Device;
#[cfg(pir_embree)]
pub use scene::{BuildQuality, Embree, EmbreeSettings, PacketWidth};

/// True when pir was built with Embree.
pub const AVAILABLE: bool = cfg!(pir_embree);

/// One line for the render summary: the Embree version and header directory pir was built
/// against, or why it was built without Embree and how to get it.
pub fn embree_status() -> &'static str {
    env!("PIR_EMBREE_STATUS")
}

/// The Embree version pir was built against (`"3.13.5"`), if any. This is the version of the
/// headers; [`Embree::describe`](super::Accelerator::describe) reports the library's.
pub fn embree_build_version() -> Option<&'static str> {
    Some(env!("PIR_EMBREE_VERSION")).filter(|v| !v.is_empty())
}

/// MXCSR bit 15: flush denormal results to zero.
#[cfg(target_arch = "x86_64")]
const MXCSR_FTZ: u32 = 1 << 15;
/// MXCSR bit 6: treat denormal inputs as zero.
#[cfg(target_arch = "x86_64")]
const MXCSR_DAZ: u32 = 1 << 6;

#[cfg(target_arch = "x86_64")]
fn read_mxcsr() -> u32 {
    let mut csr: u32 = 0;
    // SAFETY: `stmxcsr` stores the 32-bit MXCSR register into the 4 bytes at the given address,
    // which is a valid, writable, 4-aligned `u32` on our stack. SSE is part of the x86_64
    // baseline, so the instruction always exists. It touches no other state.
    unsafe {
        std::arch::asm!("stmxcsr [{}]", in(reg) &mut csr as *mut u32, options(nostack, preserves_flags));
    }
    csr
}

/// Sets flush-to-zero and denormals-are-zero (FTZ/DAZ) for the calling thread, as Embree asks
/// of every thread that traces rays. Call it from rayon's `start_handler` and on the main
/// thread. Denormals then read and compute as zero on this thread, for all code (pir's own
/// float code included); nothing in pir depends on denormals. A no-op off x86_64.
pub fn set_flush_denormals() {
    #[cfg(target_arch = "x86_64")]
    {
        let csr = read_mxcsr() | MXCSR_FTZ | MXCSR_DAZ;
        // SAFETY: `ldmxcsr` loads MXCSR from a valid, 4-aligned `u32` that was read from MXCSR
        // just above with only the FTZ and DAZ bits added; reserved bits are unchanged, so the
        // load cannot fault. Changing the rounding/denormal mode of this thread is the purpose.
        unsafe {
            std::arch::asm!("ldmxcsr [{}]", in(reg) &csr as *const u32, options(nostack, preserves_flags, readonly));
        }
    }
}

/// Whether FTZ and DAZ are both set on the calling thread (always false off x86_64).
pub fn flush_denormals_enabled() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        read_mxcsr() & (MXCSR_FTZ | MXCSR_DAZ) == (MXCSR_FTZ | MXCSR_DAZ)
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn status_matches_build() {
        let s = embree_status();
        assert_eq!(AVAILABLE, embree_build_version().is_some(), "{s}");
        if AVAILABLE {
            assert!(s.starts_with("embree "), "{s}");
        } else {
            assert!(s.contains("libembree-dev"), "{s}");
        }
    }

    #[cfg(target_arch = "x86_64")]
    #[test]
    fn flush_denormals_sets_ftz_daz_on_this_thread_only() {
        std::thread::spawn(|| {
            set_flush_denormals();
            assert!(flush_denormals_enabled());
            // DAZ: a denormal input reads as zero.
            let tiny = std::hint::black_box(f32::from_bits(1));
            assert_eq!(std::hint::black_box(tiny * 1.0), 0.0);
        })
        .join()
        .unwrap();
        std::thread::spawn(|| assert!(!flush_denormals_enabled())).join().unwrap();
    }
}
