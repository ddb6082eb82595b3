//! Random numbers and warps. Every random number in pir is a pure function of
//! (seed, iteration, domain, index, dimension): see [`Sampler`].

mod alias;
pub mod reuse;
mod rng;
mod sobol;
mod warp;

pub use alias::AliasTable;
pub use rng::{Block, Domain, Sampler, SamplerKind, Streams};
pub use warp::*;
