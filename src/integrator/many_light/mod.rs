//! The many-light methods: instant radiosity with virtual point lights, plain, clamped and
//! progressively clamped, and virtual spherical lights of constant or progressively
//! shrinking radius.
//!
//! | `--method` | virtual light | bias | reference |
//! |---|---|---|---|
//! | `ir` | point, G unclamped | none, but spiky near creases and on glossy surfaces | Keller 1997 |
//! | `ir-clamp` | point, G' = min(G, b) | too dark, for ever | Keller; pbrt-v2 `igi` |
//! | `pir-clamp` | point, G' = min(G, b_i), b_i = b_1 · i^α | vanishes: consistent | thesis 4.2.1 |
//! | `vsl` | sphere of radius r | blur, for ever | Hašan et al. 2009 |
//! | `pir-vsl` | sphere, r_i = r_1 · i^((α−1)/2) | vanishes: consistent | thesis 4.2.2 |
//! | `pir-mis` | point, connection weighed against a BSDF-sampled bounce, weighted connection bounded by b_i | vanishes: consistent (none without the bound) | pir's own ([`mis`]) |
//! | `pir-bdpt` | point, connected from a full path tracer's camera path, every technique weighed against the others, weighted connection bounded by b_i | vanishes: consistent (none without the bound) | pir's own ([`bidirectional`]) |
//!
//! Parameters (flags of `pir render`):
//! - `--vpls N` light paths per iteration (default [`DEFAULT_PATHS`]; `pir-bdpt`
//!   [`BDPT_PATHS`](crate::integrator::BDPT_PATHS), or more where they leave fewer than
//!   [`BDPT_VPLS`](crate::integrator::BDPT_VPLS) VPLs, chosen by the scene: [`path_count`]).
//!   Each leaves a virtual light at every non-delta vertex that reflects the light it
//!   receives.
//! - `--clamp B` the bound b (`ir-clamp`) or b_1 (`pir-clamp`), in 1/length². Default
//!   ([`Clamping::default_bound`]): 100 / diagonal², the G of two facing surfaces a tenth of
//!   the scene's diagonal apart, so the default needs no tuning whatever the scene's units.
//! - `--radius R` the radius r (`vsl`) or r_1 (`pir-vsl`), one for all lights. Default: per
//!   light from the VPL density (see [`spheres`]).
//! - `--alpha A` the schedule exponent of `pir-clamp` and `pir-vsl` (default 0.6, the
//!   thesis' best; see [`schedule`]).
//!
//! An iteration traces the light paths ([`light_paths`]), makes this iteration's light set
//! from their vertices ([`light_set`]: points with their G bound, or spheres with their
//! radii), and every camera path, followed by the walker of [`super::walker`], gathers from
//! the set at its non-delta vertices ([`gather`]). The walker's split of the path space
//! (emitters, virtual lights, delta chains) makes every method render exactly the path
//! space of `pt` for the same `max_depth`: a VPL of s segments from its emitter serves a
//! camera vertex of d segments when d + 1 + s ≤ max_depth.
//!
//! The files: [`light_paths`] (light tracing, the [`Vpl`]), [`light_set`] (the per-iteration
//! set, points or spheres), [`gather`] (one receiver against the set, shadow rays in
//! batches: [`shadow_batch`]), [`lanes`] (the four-wide kernel of diffuse point lights),
//! [`spheres`] (virtual spherical lights: radii and the cone integral, with [`knn`]),
//! [`schedule`] (the progressive schedules), [`path_count`] (light paths chosen by the
//! scene), [`mis`] (the weighed connections of `pir-mis`),
//! [`bidirectional`] (the camera walk and weights of `pir-bdpt`), and for the sampled gather ([`Gather::Tree`]):
//! [`light_tree`] (the per-iteration tree over the lights) and [`tree_gather`] (drawing k
//! lights per receiver from it, unbiased); for the resampled gather ([`Gather::Resampled`]):
//! [`resample`] (k lights picked among a window of m candidates by their estimated light,
//! unbiased). Measurements behind the defaults are in
//! `docs/measurements.md`.

pub mod bdpt_path;
pub mod bidirectional;
pub mod config;
pub mod gather;
pub mod gathering;
pub mod instant_radiosity;
pub mod knn;
pub mod lanes;
pub mod light_paths;
pub mod light_set;
pub mod light_tree;
pub mod lobe;
pub mod mis;
pub mod path_count;
pub mod resample;
pub mod schedule;
pub mod shadow_batch;
pub mod sphere_lanes;
pub mod spheres;
pub mod subpath;
pub mod tree_gather;

pub use config::{Clamping, Connect, DEFAULT_PATHS, Gather, Radius, VirtualLights};
pub use instant_radiosity::InstantRadiosity;
pub use light_paths::{Vpl, trace_vpls};
pub use light_set::LightSet;
pub use path_count::{AutoPaths, Pilot};
