//! What a many-light method is made of, as values: the virtual lights and their bias control
//! ([`VirtualLights`], [`Clamping`], [`Radius`]), how a receiver gathers from them
//! ([`Gather`]), which camera vertices connect ([`Connect`]), and the default light paths.
//! The method registry builds its integrators from these.

use super::schedule::{self, clamp_bound};

/// Light paths per iteration when `--vpls` is not given. An iteration costs pixels × VPLs
/// shadow rays and the progressive schedules advance once per iteration, so many cheap
/// iterations beat few rich ones (measured in `docs/measurements.md`); 32 keeps a few VPLs
/// per iteration for glossy and spherical lights too.
pub const DEFAULT_PATHS: usize = 32;

/// How the geometry term of point lights is bounded.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Clamping {
    /// `ir`: no bound.
    None,
    /// `ir-clamp`: a constant bound b.
    Constant { b: f32 },
    /// `pir-clamp`: b_i = b_1 · i^α.
    Progressive { b1: f32, alpha: f32 },
}

impl Clamping {
    /// The default b (or b_1) for a scene of the given diagonal: 100 / diagonal².
    pub fn default_bound(scene_diagonal: f32) -> f32 {
        100.0 / (scene_diagonal * scene_diagonal).max(1e-12)
    }

    /// Progressive clamping with the default α.
    pub fn progressive(b1: f32) -> Self {
        Clamping::Progressive { b1, alpha: schedule::DEFAULT_ALPHA }
    }

    /// The bound of iteration `iteration` (from 1).
    pub fn bound(&self, iteration: u64) -> f32 {
        match *self {
            Clamping::None => f32::INFINITY,
            Clamping::Constant { b } => b,
            Clamping::Progressive { b1, alpha } => clamp_bound(b1, alpha, iteration),
        }
    }
}

/// The radius of virtual spherical lights (r, or r_1 for the progressive schedule).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Radius {
    /// One radius for every light.
    Global(f32),
    /// Per light, from the density of the iteration's VPLs (see [`spheres`](super::spheres)).
    Density,
}

/// Which virtual lights, with which bias control: the parameters of a many-light method.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum VirtualLights {
    Points(Clamping),
    /// Points whose connections are weighed against a BSDF-sampled bounce ([`mis`](super::mis)), the
    /// clamping applied to the weighted connection instead of to G.
    WeighedPoints(Clamping),
    /// Points connected from every vertex of a full camera path, every technique weighed
    /// against the others ([`bidirectional`](super::bidirectional)), the clamping applied to the weighted connection.
    Bidirectional(Clamping, Connect),
    /// Spheres; with `alpha` the radius shrinks as r_1 · i^((α−1)/2).
    Spheres {
        radius: Radius,
        alpha: Option<f32>,
    },
}

/// How a receiver gathers from the iteration's virtual lights.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Gather {
    /// From every light, one shadow ray each ([`gather`](super::gather)).
    #[default]
    All,
    /// From `samples` lights drawn per receiver from a light tree in proportion to a bound on
    /// their contribution, each weighted by its inverse probability: unbiased for the same
    /// sum ([`light_tree`](super::light_tree), [`tree_gather`](super::tree_gather)).
    Tree { samples: usize },
    /// From `samples` lights picked per receiver, in proportion to their unoccluded
    /// contributions, among a random window of `candidates` lights; unbiased for the same sum
    /// ([`resample`](super::resample)).
    Resampled { candidates: usize, samples: usize },
}

/// Which camera vertices connect to the VPLs (`--connect`): the first, the first two, or
/// every non-delta one. The weights know it: a technique that connects deeper cannot make
/// the path. (Limits between 2 and all would need the light subpath's sums split by length.)
#[derive(
    Clone, Copy, Debug, Default, PartialEq, Eq, Hash, clap::ValueEnum, serde::Serialize, serde::Deserialize,
)]
#[serde(rename_all = "kebab-case")]
pub enum Connect {
    #[default]
    First,
    FirstTwo,
    All,
}

impl Connect {
    /// Whether the camera vertex of rank `rank` among its path's non-delta vertices connects
    /// (1: the first non-delta vertex, after any mirror or glass the camera ray met first,
    /// so that a wall seen in a mirror connects as one seen directly; 0: the camera itself,
    /// which light tracing always reaches).
    #[inline]
    pub fn at(self, rank: u32) -> bool {
        match self {
            Connect::First => rank <= 1,
            Connect::FirstTwo => rank <= 2,
            Connect::All => true,
        }
    }
}
