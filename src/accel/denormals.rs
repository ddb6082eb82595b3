//! Flush-to-zero and denormals-are-zero (FTZ/DAZ) for the threads that trace rays.
//!
//! Embree asks every thread that traces rays to set FTZ/DAZ; pir sets it on every rendering
//! thread whatever the backend, so that a render does not depend on the backend in this
//! respect either. On x86_64 these are two bits of the MXCSR register, which Rust can only
//! read and write with `stmxcsr`/`ldmxcsr` in inline assembly (`_mm_getcsr`/`_mm_setcsr` are
//! deprecated and `unsafe` too): this file is therefore, besides the Embree wrapper, the only
//! place allowed `unsafe` code, two one-instruction blocks.

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
