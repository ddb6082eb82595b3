//! The many-light methods: instant radiosity with virtual point lights, plain, clamped and
//! progressively clamped, virtual spherical lights of constant or progressively shrinking
//! radius, and pir's own weighed connections.
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
//! The parameters (`--vpls`, `--clamp`, `--radius`, `--alpha`, `--gather`, …) and their
//! defaults belong to the methods' registry (`pir render --help` lists them); α is the
//! exponent of every progressive schedule ([`schedule`]): `pir-clamp`'s, `pir-vsl`'s and the
//! bound on the weighted connection of `pir-mis` and `pir-bdpt`.
//!
//! An iteration ([`instant_radiosity`]) traces the light paths ([`light_paths`]: a VPL at
//! every non-delta vertex that reflects the light it receives), makes the iteration's light
//! set from their VPLs ([`light_set`]), and every camera path, followed by the walker of
//! [`super::walker`], gathers from the set at its non-delta vertices. The walker's split of
//! the path space (emitters, virtual lights, delta chains) makes every method render exactly
//! the path space of `pt` for the same `max_depth`: a VPL of s segments from its emitter
//! serves a camera vertex of d segments when d + 1 + s ≤ max_depth.
//!
//! The files, by concept:
//! - the method's values: [`config`] (virtual lights, bias control, gather, connections),
//!   [`schedule`] (the progressive schedules), [`path_count`] (light paths chosen by a
//!   pilot);
//! - light tracing: [`light_paths`] (the [`Vpl`]), [`subpath`] (the running sums and counts
//!   of bidirectional weights that both subpaths carry), [`to_camera`] (`pir-bdpt`'s light
//!   paths splatted into the film);
//! - the lights, one interface ([`virtual_light::Lights`]) and two kinds: [`points`] (with
//!   [`lanes`], the four-wide kernel) and [`spheres`] (the cone integral, with
//!   [`sphere_lanes`] and [`knn`] for the radii);
//! - the gather, written once for every kind ([`gather`]): every light, k drawn from a light
//!   tree ([`light_tree`], [`tree_gather`], [`lobe`]), or k resampled from a window of
//!   candidates ([`resample`], whose window is a run of light paths: [`window`]); shadow
//!   rays in batches ([`shadow_batch`]);
//! - the camera paths, estimators of the walker: [`gathering`] (the thesis' methods and
//!   `pir-mis`, whose weights are [`mis`]) and [`bdpt_path`] (`pir-bdpt`, whose weights are
//!   [`bidirectional`]);
//! - the integrator: [`instant_radiosity`].
//!
//! Measurements behind the defaults: `docs/measurements.md`.

pub mod bdpt_path;
pub mod bidirectional;
pub mod config;
pub mod gather;
pub mod gathering;
pub mod importance;
pub mod instant_radiosity;
pub mod knn;
pub mod lanes;
pub mod light_paths;
pub mod light_set;
pub mod light_tree;
pub mod lobe;
pub mod merging;
pub mod mis;
pub mod path_count;
pub mod points;
pub mod resample;
pub mod schedule;
pub mod shadow_batch;
pub mod sphere_lanes;
pub mod spheres;
pub mod subpath;
pub mod to_camera;
pub mod tree_gather;
pub mod view_pilot;
pub mod virtual_light;
pub mod window;

pub use config::{Clamping, Connect, DEFAULT_PATHS, Gather, Radius, VirtualLights};
pub use instant_radiosity::InstantRadiosity;
pub use light_paths::{Vpl, trace_vpls};
pub use light_set::LightSet;
pub use path_count::{AutoPaths, Pilot, Pilots};
pub use window::LightPaths;
