//! The Embree backend: Intel's ray-tracing kernels through FFI.
//!
//! This module is where pir's `unsafe` code lives (the crate denies `unsafe_code` everywhere
//! else, except the two MXCSR instructions of [`set_flush_denormals`](super::set_flush_denormals));
//! every `unsafe` block carries a `// SAFETY:` comment and every `unsafe impl Send/Sync` cites
//! the Embree rule it relies on.
//!
//! Layout, one concern per file:
//! - `sys`: bindgen output over the installed Embree headers and the `ffi/pir_embree.c` shim
//!   (which hides the Embree 3/4 differences: context/arguments initialisation, the argument
//!   order of `rtcIntersect*`/`rtcOccluded*`, and `RTC_INVALID_GEOMETRY_ID`).
//! - `device`: [`Device`], one Embree device with an error callback, RAII release.
//! - `settings`: [`EmbreeSettings`] (build quality, packet width) and their defaults.
//! - `scene`: [`Embree`], the public type: mesh checks, constructors, accessors.
//! - `build`: the committed scene and every call that creates, changes or releases Embree
//!   scene state (buffers shared or copied, commit); its `Sync` argument.
//! - `query`: the ray and packet setup and the only calls on a committed scene,
//!   `rtcIntersect*`/`rtcOccluded*` (single rays and 4/8/16-wide packets).
//! - `accelerator`: [`Embree`] behind [`Accelerator`](super::Accelerator).
//!
//! Parts that exist whether or not Embree was found at build time: [`AVAILABLE`] and
//! [`embree_status`] (for the render summary).
//!
//! Building: `build.rs` looks for Embree 4, then 3 (`EMBREE_DIR`, else `/usr/include`,
//! `/usr/local/include`). `PIR_NO_EMBREE=1` forces the pure-Rust build, `PIR_REQUIRE_EMBREE=1`
//! makes a missing Embree a build error. On Debian/Ubuntu:
//! `apt-get install libembree-dev libclang-dev`.

#[cfg(pir_embree)]
mod accelerator;
#[cfg(pir_embree)]
mod build;
#[cfg(pir_embree)]
mod device;
#[cfg(pir_embree)]
mod query;
#[cfg(pir_embree)]
mod scene;
#[cfg(pir_embree)]
mod settings;
#[cfg(pir_embree)]
mod sys;

#[cfg(pir_embree)]
pub use device::Device;
#[cfg(pir_embree)]
pub use scene::Embree;
#[cfg(pir_embree)]
pub use settings::{BuildQuality, EmbreeSettings, PacketWidth};

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
}
