//! Random numbers and warps. Every random number in pir is a pure function of
//! (seed, iteration, domain, index, dimension): see [`Sampler`].

mod alias;
mod rng;
mod warp;

pub use alias::AliasTable;
pub use rng::{Domain, Sampler, Streams};
pub use warp::*;
