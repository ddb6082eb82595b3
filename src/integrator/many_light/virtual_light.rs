//! The one interface of virtual lights: what a gather needs of one iteration's lights of one
//! kind (points, [`super::points`]; spheres, [`super::spheres`]), so that the three
//! selections of [`super::gather`] (every light, k drawn from the light tree, k resampled
//! from a window of candidates) are written once for every kind.
//!
//! How a connection is weighed is a second, independent choice ([`Weigh`]): the thesis'
//! methods take every connection in full ([`Plain`], for every kind); `pir-mis` and
//! `pir-bdpt` weigh point lights against their other techniques ([`super::mis::Weighing`],
//! for points only), so a weighed gather of spheres does not type-check.

use glam::Vec3;

use super::bidirectional::DrawWeights;
use super::light_tree::TreeLight;
use super::lobe::Lobe;
use super::resample::{Candidates, LANES};
use super::tree_gather::Kernel;
use super::window::Window;
use crate::geometry::OffsetPoint;
use crate::integrator::RenderContext;
use crate::integrator::walker::Vertex;
use crate::sampling::Sampler;

/// One iteration's virtual lights of one kind, in chunks of [`LANES`] lights.
///
/// Contributions are Φ f_y cos_y f_x cos_x / d² for a point (G bounded as the iteration says),
/// the same integrated over the sphere's cone for a sphere; without visibility, which the
/// gather adds with one shadow ray to [`Lights::end`].
pub trait Lights: Send + Sync {
    /// A camera vertex prepared once for all the lights it gathers from.
    type Receiver<'a>
    where
        Self: 'a;

    /// The vertex `v` as a receiver of the lights of at most `max_vpl_depth` segments, with
    /// its lobe for the sampled gathers' estimates.
    fn receiver<'a>(
        &'a self,
        v: &'a Vertex<'a>,
        max_vpl_depth: u32,
        lobe: Option<Lobe>,
    ) -> Self::Receiver<'a>;

    /// Whether the receiver reflects anything towards its `wo` (else every contribution is 0).
    fn is_active(rx: &Self::Receiver<'_>) -> bool;

    /// The lights.
    fn count(&self) -> usize;

    /// Chunks of [`LANES`] lights (the last one may be partly empty).
    fn chunks(&self) -> usize;

    /// Where the shadow ray to light `j` ends.
    fn end(&self, j: usize) -> &OffsetPoint;

    /// The contributions of chunk `chunk`'s lights within the receiver's depth (0 for the
    /// others and past the last light), each drawing its numbers as it would alone, in light
    /// order.
    fn chunk_contributions(
        &self,
        chunk: usize,
        rx: &Self::Receiver<'_>,
        sampler: &mut Sampler,
    ) -> [Vec3; LANES];

    /// Light `j`'s contribution (a drawn light: the tree respects the depth).
    fn contribution(&self, j: usize, rx: &Self::Receiver<'_>, sampler: &mut Sampler) -> Vec3;

    /// The resampled gather's candidates: the estimates of the window's lights, in light order,
    /// with the connections' weights where `weights` gives the receiver's side (point
    /// lights; [`Weigh::draw_weights`]).
    fn push_estimates(
        &self,
        cands: &mut Candidates,
        window: &Window,
        rx: &Self::Receiver<'_>,
        weights: Option<DrawWeights>,
        sampler: &mut Sampler,
    );

    /// A picked candidate's contribution, after [`Lights::push_estimates`] of its window.
    fn picked(&self, j: usize, rx: &Self::Receiver<'_>, sampler: &mut Sampler) -> Vec3 {
        self.contribution(j, rx, sampler)
    }

    /// How the light tree bounds a contribution of this kind.
    fn kernel(&self) -> Kernel;

    /// The lights as the light tree sees them, in light order.
    fn tree_lights(&self, ctx: &RenderContext) -> Vec<TreeLight>;
}

/// How a gather weighs the connection to light `j` of `L`.
pub trait Weigh<L: Lights> {
    /// The receiver's lobe for the sampled gathers' estimates, where the weighted value
    /// follows it.
    fn lobe(&self, v: &Vertex) -> Option<Lobe>;

    /// The receiver's side of the connection weight for the resampled gather's estimates
    /// ([`DrawWeights`]), where the weight is the balance heuristic's of `pir-bdpt`.
    #[inline]
    fn draw_weights(&self) -> Option<DrawWeights> {
        None
    }

    /// The weighted contribution `c` of light `j` at the receiver `x`.
    fn weigh(&self, lights: &L, j: usize, x: Vec3, c: Vec3) -> Vec3;

    /// The weighted contribution of light `j` picked by the resampled gather at the receiver
    /// `rx` at `x` ([`weighed_pick`]: [`Lights::picked`], then [`Weigh::weigh`]); `None`
    /// where its contribution is zero (no shadow ray). A weighing may compute both at once.
    #[inline]
    fn picked(
        &self,
        lights: &L,
        j: usize,
        rx: &L::Receiver<'_>,
        x: Vec3,
        sampler: &mut Sampler,
    ) -> Option<Vec3> {
        weighed_pick(self, lights, j, rx, x, sampler)
    }
}

/// [`Weigh::picked`] as two steps: light `j`'s contribution, then its weight.
#[inline]
pub fn weighed_pick<L: Lights, W: Weigh<L> + ?Sized>(
    weighing: &W,
    lights: &L,
    j: usize,
    rx: &L::Receiver<'_>,
    x: Vec3,
    sampler: &mut Sampler,
) -> Option<Vec3> {
    let c = lights.picked(j, rx, sampler);
    (c != Vec3::ZERO).then(|| weighing.weigh(lights, j, x, c))
}

/// The thesis' methods: every connection counts in full.
#[derive(Clone, Copy, Debug)]
pub struct Plain;

impl<L: Lights> Weigh<L> for Plain {
    #[inline]
    fn lobe(&self, v: &Vertex) -> Option<Lobe> {
        Lobe::of(v.bsdf, v.sp.frame.n, v.wo)
    }

    #[inline]
    fn weigh(&self, _: &L, _: usize, _: Vec3, c: Vec3) -> Vec3 {
        c
    }
}
