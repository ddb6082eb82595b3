//! pir: Progressive Instant Radiosity.
//!
//! A renderer that converges to the exact image of a scene with virtual point lights whose
//! bias shrinks progressively, with a path tracer as its ground truth.
//!
//! `unsafe` code is denied outside the Embree FFI wrapper ([`accel::embree`]) and the two
//! MXCSR instructions behind [`accel::set_flush_denormals`].

#![deny(unsafe_code)]

pub mod accel;
pub mod geometry;
pub mod hash;
pub mod image;
pub mod integrator;
pub mod light;
pub mod material;
pub mod render;
pub mod sampling;
pub mod scene;
pub mod study;
pub mod texture;
pub mod wide;
