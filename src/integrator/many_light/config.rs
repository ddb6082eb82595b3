//! What a many-light method is made of, as values: the virtual lights and their bias control
//! ([`VirtualLights`], [`Clamping`], [`Radius`]), how a receiver gathers from them
//! ([`Gather`], and [`Draws`] where a vertex draws fewer, [`AFTER_COATED`]), which camera
//! vertices connect ([`Connect`]), and the default light paths.
//! The method registry builds its integrators from these.

use super::schedule::{self, clamp_bound};
use crate::material::Bsdf;

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
    /// contributions, among a random window of at most about `candidates` lights (a run of
    /// light paths, [`window`](super::window)); unbiased for the same sum
    /// ([`resample`](super::resample)).
    Resampled { candidates: usize, samples: usize },
}

/// Which camera vertices connect to the VPLs (`--connect`): the first, the first two, every
/// non-delta one, or the first and every one whose previous non-delta vertex is glossy
/// ([`glossy_vertex`]). The weights know it: a technique that connects where the rule says
/// no cannot make the path. (Limits between 2 and all would need the light subpath's sums
/// split by length.)
///
/// Why `glossy`: at a glossy vertex (a rough metal floor) few VPLs lie in the narrow lobe, so
/// the light it reflects is the BSDF sample's to find, and the vertex that sample reaches
/// (the wall seen in the floor) is where connections pay off again; elsewhere one connecting
/// vertex is enough ([`Connect::First`] against [`Connect::All`] on pir's scenes,
/// `docs/measurements.md`). A rule that depends only on the connecting vertex's camera-side
/// neighbour keeps the weights summing to one: the light subpath carries its connections
/// by whether their camera-side neighbour is glossy ([`super::subpath::MisState::dvc_glossy`],
/// [`super::subpath::MisState::dvc_last`]).
#[derive(
    Clone, Copy, Debug, Default, PartialEq, Eq, Hash, clap::ValueEnum, serde::Serialize, serde::Deserialize,
)]
#[serde(rename_all = "kebab-case")]
pub enum Connect {
    #[default]
    First,
    FirstTwo,
    All,
    Glossy,
}

/// The widest microfacet roughness (α) at which a vertex is glossy for `--connect glossy`
/// ([`glossy_vertex`]).
pub const GLOSSY_ALPHA: f32 = 0.15;

/// Whether a non-delta vertex of this BSDF makes the next one connect with `--connect
/// glossy`: a microfacet lobe of α at most [`GLOSSY_ALPHA`] ([`Bsdf::glossy_alpha`]). A
/// function of the vertex alone, so that both subpaths agree on it.
#[inline]
pub fn glossy_vertex(b: &Bsdf) -> bool {
    b.glossy_alpha().is_some_and(|a| a <= GLOSSY_ALPHA)
}

/// What a sampled gather draws at one receiver where that is fewer than its own counts
/// (`--gather-samples`, `--gather-candidates`): `samples` lights (k), for `--gather resample`
/// picked among a window of about `candidates` (m); each at least one and at most the gather's
/// own.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Draws {
    pub samples: usize,
    pub candidates: usize,
}

/// What a sampled gather (`--gather resample` or `tree`) draws at a camera vertex that
/// connects only because the non-delta vertex before it is glossy over a diffuse base
/// ([`After::Coated`], [`Connecting::fewer_picks`]): one light, among 32 candidates (at most
/// the gather's own). The weights count those draws there ([`super::subpath::Counts::at`]),
/// the light subpath too, by what the camera-side neighbour of each of its vertices is
/// ([`After`]): measured, 1.4–2.2 % lower relative MSE in the living room at the same
/// samples, and the worst pixel at 1920×1080 down from 177 and 113 to 56 and 67.
///
/// Why: such a vertex (a wall seen in a coated floor, or seen from a painted wall whose coat
/// is glossy) carries a path that the gather at the vertex before it mostly makes too, through
/// the diffuse base, so its connections pay off only where the coat's lobe sent the path, and
/// those are few; after a glossy vertex without a diffuse base (a rough metal) the vertex
/// after it is where the light is found, and it keeps the full counts. Any counts give an
/// unbiased estimate of the same sum, and the weights sum to one whatever each technique's
/// count, so the image stays unbiased and consistent; only the cost and the noise change. Measured
/// (`docs/results.md`, "Fewer picks after a coated vertex"): in the living room (painted walls
/// and floor of α 0.15) one pick of the 128 candidates gave 1.16–1.21× the efficiency at
/// 640×360 at three seeds of four (0.99 at the fourth, a firefly of its sequence) and two
/// picks 5 % less than one; one of 32 candidates 3 % more again there, and at
/// 1920×1080 `pt`'s error 3.1–3.25× sooner against 2.9–3.05× with 128 (2.4× with the full
/// counts; 3.11–3.16× once the weights count the draws, which lowers the error per
/// iteration). The dense scene lit indirectly (a plastic bunny) gains 1.02–1.05×; where no
/// glossy vertex has a diffuse base (Bitterli's veach-ajar, with its metal floor) the images
/// are the same.
pub const AFTER_COATED: Draws = Draws { samples: 1, candidates: 32 };

/// The widest microfacet roughness (α) at which a vertex is near-specular
/// ([`near_specular`]): `pir-bdpt` neither connects there nor leaves a VPL there.
///
/// Measured (`docs/results.md`, "No connections at near-specular vertices"): with the
/// threshold at 0.01 or 0.03, Bitterli's Cornell box behind a rough glass wall (α 0.001)
/// gains 2.0–2.2× in efficiency and Veach's MIS scene (plates of α 0.01 to 0.25) 1.08–1.18×;
/// at 0.06 the plate of α 0.05 is left to BSDF sampling too and veach-mis loses 1.3–1.5× against 0.01–0.03,
/// its connections there being worth their cost. 0.02 lies between.
pub const NEAR_SPECULAR_ALPHA: f32 = 0.02;

/// Whether a vertex of this BSDF is near-specular: each of its non-delta lobes a microfacet
/// lobe of α at most [`NEAR_SPECULAR_ALPHA`] ([`Bsdf::widest_alpha`]). A function of the
/// vertex alone, so that both subpaths agree on it.
///
/// Why: a connection reaches such a vertex's lobe about as often as a random direction hits
/// a cone of half-angle α, and where it does not its value is zero, while its cost (the
/// gather's candidates and shadow rays at a camera vertex, a VPL's place in every window at
/// a light vertex) is the same as anywhere; BSDF sampling finds what the lobe reflects, and
/// the weights give it nearly all of it anyway.
#[inline]
pub fn near_specular(b: &Bsdf) -> bool {
    b.widest_alpha().is_some_and(|a| a <= NEAR_SPECULAR_ALPHA)
}

/// What a non-delta vertex makes of the camera vertex after it under `--connect glossy`
/// ([`Connect::at`], [`AFTER_COATED`]): nothing, a connection with the gather's own counts
/// (glossy, [`glossy_vertex`]) or one with fewer draws (glossy over a diffuse base,
/// [`After::Coated`]). A function of the vertex alone, so that both subpaths agree on it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum After {
    Plain,
    Glossy,
    Coated,
}

impl After {
    /// What a vertex of BSDF `b` makes of the one after it, whatever the rule.
    #[inline]
    pub fn of(b: &Bsdf) -> After {
        if !glossy_vertex(b) {
            After::Plain
        } else if b.widest_alpha().is_none() {
            After::Coated
        } else {
            After::Glossy
        }
    }

    /// Whether the vertex after it connects under `--connect glossy`.
    #[inline]
    pub fn glossy(self) -> bool {
        self != After::Plain
    }
}

/// How the camera vertex after a given one connects ([`Connect::next`]): not at all, with
/// the gather's own counts, or with [`AFTER_COATED`]'s fewer draws.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Next {
    None,
    Full,
    Fewer,
}

impl Connect {
    /// The name `--connect` takes for it (clap's, from the enum).
    pub fn name(self) -> String {
        clap::ValueEnum::to_possible_value(&self).map(|v| v.get_name().to_string()).unwrap_or_default()
    }

    /// What a vertex of BSDF `b` makes of the one after it under this rule ([`After`]):
    /// [`After::Plain`] but for [`Connect::Glossy`], so that the other rules need not look at
    /// the BSDF.
    #[inline]
    pub fn after(self, b: &Bsdf) -> After {
        if self == Connect::Glossy { After::of(b) } else { After::Plain }
    }

    /// How the camera vertex after the one of rank `rank` connects ([`Next`]), `after` what
    /// that one makes of it ([`Connect::after`]): fewer draws only after a coated vertex,
    /// which only `--connect glossy` makes and after which the next vertex always connects.
    #[inline]
    pub fn next(self, rank: u32, after: After) -> Next {
        if !self.at(rank + 1, after.glossy()) {
            Next::None
        } else if after == After::Coated {
            Next::Fewer
        } else {
            Next::Full
        }
    }

    /// Whether the camera vertex of rank `rank` among its path's non-delta vertices connects
    /// (1: the first non-delta vertex, after any mirror or glass the camera ray met first,
    /// so that a wall seen in a mirror connects as one seen directly; 0: the camera itself,
    /// which light tracing always reaches), `after_glossy` saying whether the non-delta
    /// camera vertex before it is glossy ([`glossy_vertex`]).
    #[inline]
    pub fn at(self, rank: u32, after_glossy: bool) -> bool {
        match self {
            Connect::First => rank <= 1,
            Connect::FirstTwo => rank <= 2,
            Connect::All => true,
            Connect::Glossy => rank <= 1 || after_glossy,
        }
    }
}

/// Which vertices of one camera path connect to the VPLs, as its walk passes its non-delta
/// vertices one by one ([`Connect::at`]): what the camera path's weights need to know of the
/// vertices behind it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Connecting {
    /// The non-delta vertices passed: the last one's rank.
    rank: u32,
    /// Whether the last one connects, and the one before it (the camera, before any, does:
    /// light tracing reaches it).
    last: bool,
    before_last: bool,
    /// What the last one makes of the vertex after it under the rule ([`Connect::after`]).
    after: After,
    /// Whether the last one connects only because the one before it is glossy over a diffuse
    /// base ([`Connecting::fewer_picks`]), and the one before it.
    fewer: bool,
    before_fewer: bool,
}

impl Connecting {
    /// At the camera, before any vertex.
    pub const CAMERA: Connecting = Connecting {
        rank: 0,
        last: true,
        before_last: true,
        after: After::Plain,
        fewer: false,
        before_fewer: false,
    };

    /// Passes the next non-delta vertex, of BSDF `b`: whether it connects.
    #[inline]
    pub fn pass(&mut self, connect: Connect, b: &Bsdf) -> bool {
        let next = connect.next(self.rank, self.after);
        self.rank += 1;
        self.before_last = self.last;
        self.last = next != Next::None;
        self.before_fewer = self.fewer;
        self.fewer = next == Next::Fewer;
        self.after = connect.after(b);
        self.last
    }

    /// Whether the last non-delta vertex connects only because the one before it is glossy
    /// over a diffuse base ([`After::Coated`]): its sampled gather draws as [`AFTER_COATED`]
    /// says.
    #[inline]
    pub fn fewer_picks(&self) -> bool {
        self.fewer
    }

    /// [`Connecting::fewer_picks`] of the non-delta vertex before the last one (false for the
    /// camera): the count of its connection to the last one ([`super::subpath::Counts::at`]).
    #[inline]
    pub fn previous_fewer(&self) -> bool {
        self.before_fewer
    }

    /// What the last non-delta vertex makes of the one after it ([`After`]).
    #[inline]
    pub fn after(&self) -> After {
        self.after
    }

    /// The last non-delta vertex's rank (0 before any).
    #[inline]
    pub fn rank(&self) -> u32 {
        self.rank
    }

    /// Whether the last non-delta vertex (or the camera, before any) connects.
    #[inline]
    pub fn connects(&self) -> bool {
        self.last
    }

    /// Whether the non-delta vertex before the last one (or the camera) connects: whether the
    /// connection from it to the last one is a technique.
    #[inline]
    pub fn previous_connects(&self) -> bool {
        self.before_last
    }
}

impl Default for Connecting {
    fn default() -> Self {
        Connecting::CAMERA
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    const DIFFUSE: Bsdf = Bsdf::Diffuse { albedo: Vec3::splat(0.5) };
    /// Glossy over a diffuse base, and glossy without one (a rough metal).
    const COATED: Bsdf =
        Bsdf::Glossy { albedo: Vec3::splat(0.2), specular: Vec3::splat(0.6), roughness: 0.15 };
    const METAL: Bsdf = Bsdf::Glossy { albedo: Vec3::ZERO, specular: Vec3::splat(0.9), roughness: 0.1 };
    /// A coat too rough to be glossy.
    const ROUGH: Bsdf = Bsdf::Glossy { albedo: Vec3::splat(0.2), specular: Vec3::splat(0.6), roughness: 0.3 };

    /// Per vertex of the path, whether it connects and whether it picks fewer lights;
    /// checking on the way that [`Connecting::previous_fewer`] is the vertex before's.
    fn walk(connect: Connect, path: &[Bsdf]) -> Vec<(bool, bool)> {
        let mut c = Connecting::CAMERA;
        let mut before = false;
        path.iter()
            .map(|b| {
                let step = (c.pass(connect, b), c.fewer_picks());
                assert_eq!(c.previous_fewer(), before);
                before = step.1;
                step
            })
            .collect()
    }

    #[test]
    fn a_vertex_connecting_after_a_coated_one_picks_fewer_lights_and_after_a_metal_its_own_count() {
        let coated = |b: &Bsdf| After::of(b) == After::Coated;
        assert!(coated(&COATED) && !coated(&METAL) && !coated(&ROUGH));
        assert!(!coated(&DIFFUSE) && glossy_vertex(&METAL));
        let (no, full, fewer) = ((false, false), (true, false), (true, true));
        // The first vertex keeps its count even when coated; the vertex after a coated one
        // picks fewer; after a metal, the full count; after a diffuse or rough one, no connection.
        assert_eq!(walk(Connect::Glossy, &[COATED, DIFFUSE, DIFFUSE]), [full, fewer, no]);
        assert_eq!(
            walk(Connect::Glossy, &[METAL, DIFFUSE, COATED, COATED, ROUGH]),
            [full, full, no, fewer, fewer]
        );
        assert_eq!(
            walk(Connect::Glossy, &[DIFFUSE, ROUGH, METAL, COATED, DIFFUSE]),
            [full, no, no, full, fewer]
        );
        // The other rules connect where they always did, each with its own count.
        assert_eq!(walk(Connect::All, &[COATED, COATED, DIFFUSE]), [full, full, full]);
        assert_eq!(walk(Connect::FirstTwo, &[COATED, COATED, DIFFUSE]), [full, full, no]);
        assert_eq!(walk(Connect::First, &[COATED, COATED]), [full, no]);
    }

    /// The vertex after a camera vertex connects in full after a metal under `glossy`, after
    /// the first under `first-two`, always under `all`; after a coated vertex it draws fewer,
    /// and under `first` none after the first connects ([`Connect::next`]; where it connects
    /// in full, the weighed gather leaves a glossy receiver's lobe out of its draw).
    #[test]
    fn the_next_vertex_connects_in_full_after_a_metal_or_where_the_rule_connects_it() {
        let after = |b: &Bsdf| Connect::Glossy.after(b);
        assert_eq!(Connect::Glossy.next(1, after(&METAL)), Next::Full);
        assert_eq!(Connect::Glossy.next(3, after(&METAL)), Next::Full);
        assert_ne!(Connect::Glossy.next(1, after(&COATED)), Next::Full);
        assert_ne!(Connect::Glossy.next(1, after(&DIFFUSE)), Next::Full);
        assert_ne!(Connect::Glossy.next(2, after(&ROUGH)), Next::Full);
        for b in [METAL, COATED, DIFFUSE] {
            let plain = Connect::First.after(&b);
            assert_ne!(Connect::First.next(1, plain), Next::Full);
            assert_eq!(Connect::FirstTwo.next(1, plain), Next::Full);
            assert_ne!(Connect::FirstTwo.next(2, plain), Next::Full);
            assert_eq!(Connect::All.next(4, plain), Next::Full);
        }
    }
}
