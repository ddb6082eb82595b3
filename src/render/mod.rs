//! Rendering: the [`Renderer`] that every command drives (in `renderer.rs`), the options it
//! takes, the progressive driver shared by every method (iterations of one sample per pixel,
//! a running mean, budgets, tiles over rayon, deterministic sampling), the film, resumable
//! state and the memory estimate.

mod driver;
mod film;
pub mod memory;
mod options;
mod renderer;
mod splat;
pub mod state;

pub use driver::{Budget, Control, RenderSettings, RenderStats, TILE_SIZE, render, render_from};
pub use film::Film;
pub use options::{MAX_PIXELS, MAX_SIDE, SceneOptions, check_resolution};
pub use renderer::{Renderer, worker_pool};
