//! The progressive driver shared by every method: iterations of one sample per pixel, a
//! running mean, budgets, tiles over rayon, deterministic sampling.

mod driver;
mod film;
pub mod memory;
pub mod state;

pub use driver::{Budget, Control, RenderSettings, RenderStats, render, render_from};
pub use film::Film;
