//! The bookkeeping of bidirectional weights that both subpaths carry (`pir-bdpt`, after
//! Georgiev's vertex connection and merging): the running sums [`MisState`] that each BSDF
//! sample ([`Scatter`]) extends, and how many samples each connection technique counts
//! ([`Counts`]). Light tracing fills them in at every VPL and the camera path along its walk;
//! [`super::bidirectional`] finishes the weights from them.

use std::f32::consts::PI;

use super::config::{AFTER_COATED, After, Connect, Gather, Next, near_specular};
use crate::material::Bsdf;

/// What a pick of the resampled gather counts, where the emitters are in view, in a
/// connection between two Lambertian ends ([`Counts`]): 4, so that its k picks count 4k.
///
/// Why 4 rather than the 2 of a glossy end: the picks' VPLs are shared by the pixels whose
/// windows hold them, and a larger count makes their shared error (blotches) a larger part
/// of the image's; since an iteration traces at least 256 light paths and a window holds
/// a few dozen of them (the Cornell box: 32 of 256 paths, about 80 of their 650 VPLs),
/// neighbouring pixels share far fewer of them than with 64 paths, where the window was
/// every VPL (`docs/integrator-measurements.md`, "Lambertian connections count 4k").
pub const LAMBERTIAN_PICK_COUNT: f32 = 4.0;

/// How many samples the weights count for a connection technique: a function of the
/// iteration's light paths, the gather, the connection's two ends and how often next-event
/// estimation finds the emitters unoccluded.
///
/// Any non-negative counts keep the weights of every path summing to one (a zero count: a
/// technique not used, whose connections are not made), as long as both
/// subpaths use the same count for the same connection (the running sums carry each
/// connection's factor from where it is folded in). The counts only balance the techniques:
/// - **The exhaustive gather** makes N connections per vertex, N samples of the technique:
///   every connection counts N.
/// - **A sampled gather** (k shadow rays to VPLs picked by an estimate of their
///   contribution) counts at most 2k (the resampled gather between Lambertian ends 4k / v,
///   next item): its picks are k samples, and the VPLs they pick are shared by every pixel,
///   so that a larger count trades per-pixel noise for blotches. A camera vertex that
///   draws fewer, after a coated one ([`AFTER_COATED`]), counts its own draws the same way
///   ([`Counts::at`]; the light subpath carries that count for the connection whose
///   camera-side neighbour is coated, [`MisState::dvc_last_fewer`]).
///   Measured: `docs/integrator-measurements.md`, "Counts of the sampled gathers".
/// - **Between two Lambertian ends, the resampled gather** counts
///   [`LAMBERTIAN_PICK_COUNT`] · k / v (4k / v), at most N, with v
///   the probability that next-event estimation from a point that light reaches directly
///   finds its emitter point unoccluded (measured by the pilot of
///   [`super::path_count::Pilot`]). The competitor of such a connection z_1 → z_2 is
///   next-event estimation at z_2, whose samples are mostly wasted where the emitters are
///   hidden behind an opening (the slit room: v = 0.15–0.18), and whose effective count is then v
///   samples, not one; the connection's estimate is the unoccluded contribution itself but
///   for the albedos' colours (power × the geometry term, [`super::resample`]), so its picks
///   are well placed. Where the emitters are in view (v ≈ 1) this is 4k. A glossy
///   end keeps 2k: the estimate leaves the lobe out.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Counts {
    /// N, the light paths of the iteration: the emitter techniques count once against it,
    /// and the connections' counts are relative to it.
    pub paths: f32,
    /// The count of a connection between two Lambertian ends, relative to `paths` (in (0, 1]).
    pub lambertian: f32,
    /// The count of a connection with a glossy end, relative to `paths` (in (0, 1]).
    pub glossy: f32,
    /// The same two where the camera vertex draws fewer ([`AFTER_COATED`]).
    pub fewer_lambertian: f32,
    pub fewer_glossy: f32,
    /// Whether a connection with a near-specular end ([`near_specular`]) counts zero: the
    /// technique is not used (no gather at such a camera vertex, no VPL at such a light
    /// vertex), and the weights leave it out (`pir-bdpt`).
    pub skip_near_specular: bool,
}

impl Counts {
    /// The counts of an iteration of `paths` light paths gathered as `gather` says, in a
    /// scene where next-event estimation from the points that light reaches directly finds
    /// its emitter point unoccluded with probability `visibility` (the pilot's,
    /// [`super::path_count::Pilot`]; 1 when not measured).
    pub fn new(paths: usize, gather: Gather, visibility: f32) -> Counts {
        let n = (paths as f32).max(1.0);
        let of = |samples: usize| -> (f32, f32) {
            let (glossy, lambertian) = match gather {
                Gather::All => (n, n),
                Gather::Tree { .. } => (n.min(2.0 * samples as f32), n.min(2.0 * samples as f32)),
                Gather::Resampled { .. } => {
                    let k2 = 2.0 * samples as f32;
                    let in_view = LAMBERTIAN_PICK_COUNT * samples as f32;
                    // Not measured: as if in view; measured and nothing in view: N.
                    let lambertian = match visibility {
                        v if v.is_nan() => in_view,
                        v if v <= 0.0 => n,
                        v => in_view / v.min(1.0),
                    };
                    (n.min(k2), n.min(lambertian))
                }
            };
            let relative = |c: f32| (c / n).clamp(f32::MIN_POSITIVE, 1.0);
            (relative(glossy), relative(lambertian))
        };
        let samples = match gather {
            Gather::All => 1,
            Gather::Tree { samples } | Gather::Resampled { samples, .. } => samples.max(1),
        };
        let (glossy, lambertian) = of(samples);
        let (fewer_glossy, fewer_lambertian) = of(AFTER_COATED.samples.min(samples));
        Counts { paths: n, lambertian, glossy, fewer_lambertian, fewer_glossy, skip_near_specular: false }
    }

    /// Every connection counted as `paths` (the tests' weights, and [`Gather::All`]).
    pub fn uniform(paths: f32) -> Counts {
        Counts {
            paths,
            lambertian: 1.0,
            glossy: 1.0,
            fewer_lambertian: 1.0,
            fewer_glossy: 1.0,
            skip_near_specular: false,
        }
    }

    /// The same counts, with the connections that have a near-specular end counted zero
    /// ([`Counts::skip_near_specular`]).
    pub fn skipping_near_specular(self) -> Counts {
        Counts { skip_near_specular: true, ..self }
    }

    /// Whether a vertex of BSDF `b` connects at all (as a camera vertex or as a VPL): not
    /// where it is near-specular and the counts skip those.
    #[inline]
    pub fn connects_at(&self, b: &Bsdf) -> bool {
        !(self.skip_near_specular && near_specular(b))
    }

    /// The count of the connection between a vertex of BSDF `b` and the vertex before it
    /// on the same subpath, of BSDF `a` (none at the camera or the emitter: 1, the term it
    /// would multiply being zero or next-event estimation's), relative to [`Counts::paths`].
    /// What both subpaths fold into their sums, along the camera path ([`super::bdpt_path`]) and in light tracing.
    #[inline]
    pub fn between(&self, a: Option<&Bsdf>, b: &Bsdf) -> f32 {
        a.map_or(1.0, |a| self.factor(a, b))
    }

    /// The count of the connection between a vertex of BSDF `a` and one of BSDF `b`,
    /// relative to [`Counts::paths`]; zero where either end is near-specular and the counts
    /// skip those ([`Counts::skip_near_specular`]).
    #[inline]
    pub fn factor(&self, a: &Bsdf, b: &Bsdf) -> f32 {
        self.at(a, b, false)
    }

    /// [`Counts::factor`] where the camera vertex (either end) draws fewer (`fewer`: after a
    /// coated one, [`AFTER_COATED`]) or not.
    #[inline]
    pub fn at(&self, a: &Bsdf, b: &Bsdf, fewer: bool) -> f32 {
        let (full, with_fewer) = self.both(a, b);
        if fewer { with_fewer } else { full }
    }

    /// [`Counts::at`] without and with fewer draws, from one look at the two ends.
    #[inline]
    fn both(&self, a: &Bsdf, b: &Bsdf) -> (f32, f32) {
        if lambertian(a) && lambertian(b) {
            (self.lambertian, self.fewer_lambertian)
        } else if self.connects_at(a) && self.connects_at(b) {
            (self.glossy, self.fewer_glossy)
        } else {
            (0.0, 0.0)
        }
    }

    /// [`Counts::between`] where the camera end of the connection draws fewer or not.
    #[inline]
    pub fn between_at(&self, a: Option<&Bsdf>, b: &Bsdf, fewer: bool) -> f32 {
        a.map_or(1.0, |a| self.at(a, b, fewer))
    }

    /// [`Counts::between`] without and with fewer draws at the camera end (what a light
    /// subpath's vertex keeps of both), from one look at the two ends.
    #[inline]
    pub fn between_both(&self, a: Option<&Bsdf>, b: &Bsdf) -> (f32, f32) {
        a.map_or((1.0, 1.0), |a| self.both(a, b))
    }
}

/// Whether a connection at a vertex of this BSDF is picked as well as a Lambertian one
/// ([`Counts`]): a diffuse material.
#[inline]
fn lambertian(b: &Bsdf) -> bool {
    matches!(b, Bsdf::Diffuse { .. })
}

/// The count of light tracing to the camera in the weights, relative to N, where the light
/// path's vertex that it connects to the lens is lit directly (a path of two segments, the
/// light the camera sees lit directly): a quarter of its paths, although each of the N
/// light paths splats once ([`light_tracing_count`]). From a vertex further along a light
/// path it counts N.
///
/// **Why less than its paths.** The balance heuristic weighs techniques by their densities,
/// as if every sample of each were independent. The camera's are not: a pixel's camera
/// samples, its light samples among them, are stratified over the iterations (`--sampler
/// sobol`), and a light sample from a point the camera sees is as good as light tracing's
/// splat of the same path where both densities are alike. Light tracing's splats land where
/// the light paths happen to reach, a few per pixel and iteration, and no stratification
/// spreads them over a pixel; so where light tracing takes half the weight of the light
/// that the camera sees directly lit, its noise is most of the pixel's. In the diffuse
/// corner (`scenes/stress/corner/diffuse.toml`, 64×64, light at close range) `pir-bdpt`'s
/// error in direct light alone (`--max-depth 2`, 10 s) was 24 times `pt`'s, with no light
/// tracing level with it, and with light tracing counted a quarter 1.9 times. Any counts
/// give weights that sum to one, so the estimate stays unbiased and consistent whatever
/// this factor; it only moves light from one technique to another where both make the same
/// path. Paths of more segments keep light tracing's full count: there it competes with
/// BSDF-sampled emitter hits, not with light samples, and a quarter everywhere gave Veach's
/// plates (glossy caustics seen directly) fireflies and 4–21 % more error
/// (`docs/results.md`, "Light tracing counts a quarter where it meets light samples").
pub const LIGHT_TRACING_COUNT: f32 = 0.25;

/// Light tracing's count relative to N from a light path's vertex `depth` segments from the
/// emitter: [`LIGHT_TRACING_COUNT`] at a vertex lit directly, else 1.
#[inline]
pub fn light_tracing_count(depth: u32) -> f32 {
    if depth == 1 { LIGHT_TRACING_COUNT } else { 1.0 }
}

/// The running sums of one subpath's MIS weights (see the module docs).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct MisState {
    /// The density ratio of the technique that ends the other subpath at the previous vertex.
    pub dvcm: f32,
    /// The sum over the techniques that end it earlier still.
    pub dvc: f32,
    /// The part of `dvc` that the two emitter techniques contribute (light subpaths only):
    /// what is left of `dvc` when the camera may not connect further along the path
    /// ([`Connect`]).
    pub dvc_emitter: f32,
    /// The part of `dvc` that the connection folded in last contributes (light subpaths
    /// only): the camera connecting at the light subpath's previous non-delta vertex, which
    /// `--connect first-two` allows where light tracing makes the camera's first vertex here,
    /// and `--connect glossy` where the camera's vertex here is glossy.
    pub dvc_last: f32,
    /// The part of `dvc` that the connections before it contribute whose camera-side
    /// neighbour (the next non-delta vertex towards here) is glossy
    /// ([`super::config::glossy_vertex`]; light subpaths only): those `--connect glossy` allows.
    pub dvc_glossy: f32,
    /// `dvc_last` with the connection counted as a camera vertex that draws fewer counts it
    /// ([`Counts::at`]): what it contributes where its camera-side neighbour is coated
    /// ([`After::Coated`]; light subpaths only).
    pub dvc_last_fewer: f32,
}

impl MisState {
    /// A camera subpath without light tracing to the camera: no technique reaches the
    /// camera from the light side.
    pub const CAMERA: MisState = MisState {
        dvcm: 0.0,
        dvc: 0.0,
        dvc_emitter: 0.0,
        dvc_last: 0.0,
        dvc_glossy: 0.0,
        dvc_last_fewer: 0.0,
    };

    /// A camera subpath whose first ray's direction the camera sampled with density `pdf_dir`
    /// per unit solid angle, a pixel the unit of the film's area
    /// ([`crate::scene::CameraRays::direction_pdf`]), where light tracing to the camera
    /// competes: its N light paths each splat, so relative to N it counts once, and `dvcm`
    /// starts at 1 / `pdf_dir` (Georgiev's light subpath count over the camera's density,
    /// in pir's sums relative to N). Where light tracing counts less (a path of two
    /// segments, [`LIGHT_TRACING_COUNT`]), the two techniques that end such a path on the
    /// camera's side scale its term as they read it ([`MisState::for_light_sample`], [`MisState::for_hit`]).
    pub fn from_camera(pdf_dir: f32) -> MisState {
        MisState { dvcm: finite(1.0 / pdf_dir), ..MisState::CAMERA }
    }

    /// The camera subpath's sums as next-event estimation at the camera vertex of depth
    /// `depth` weighs them: at the first vertex (depth 1, where `dvcm` is light tracing's term
    /// alone and `dvc` zero) with light tracing counted [`LIGHT_TRACING_COUNT`], since the
    /// path has two segments; elsewhere as they are.
    #[inline]
    pub fn for_light_sample(self, depth: u32) -> MisState {
        MisState { dvcm: self.dvcm * light_tracing_count(depth), ..self }
    }

    /// The camera subpath's sums as an emitter hit (or an escape to a light at infinity) at
    /// depth `depth` weighs them: at depth 2 (the ray from the first vertex, where `dvc` is
    /// light tracing's term alone) with light tracing counted [`LIGHT_TRACING_COUNT`], since
    /// the path has two segments; elsewhere as they are.
    #[inline]
    pub fn for_hit(self, depth: u32) -> MisState {
        MisState { dvc: self.dvc * light_tracing_count(depth.saturating_sub(1)), ..self }
    }

    /// A light subpath of `paths` per iteration, started at an emitter point of area density
    /// `pdf_area` (as next-event estimation picks it, but where it picks by importance, which
    /// the light path's first vertex corrects) in a cosine-distributed direction of
    /// cosine `cos_e`: the emitter techniques (next-event estimation, `dvcm`, and an
    /// emitter hit, `dvc`) count once against the connections' N.
    pub fn light(pdf_area: f32, cos_e: f32, paths: f32) -> MisState {
        let dvc = PI / (pdf_area * paths);
        MisState { dvcm: PI / (cos_e * paths), dvc, dvc_emitter: dvc, ..MisState::CAMERA }
    }

    /// A light subpath of `paths` per iteration, started at a light that is not a triangle
    /// ([`crate::light::Light::emit`]): its start picks, beyond what next-event estimation
    /// picks of the same light, with density `emission` (the [`crate::light::Emission`]'s:
    /// per unit area of the first receiver, without its cosine and without 1 / d² for a
    /// light at a position); next-event estimation picks the light's point or direction with
    /// density `nee` (an environment's selection probability times its solid-angle density
    /// of the direction), infinite for a delta light, which no BSDF sample hits (so the hit
    /// technique, `dvc`, is zero). As Georgiev's report initialises its light subpaths
    /// (eqs. 31–33, with the cosine at the light 1 for lights at infinity); the first
    /// [`MisState::arrive`] of a light at infinity takes no distance, its density already per
    /// unit area.
    pub fn light_source(nee: f32, emission: f32, paths: f32) -> MisState {
        let dvc = if nee.is_infinite() { 0.0 } else { finite(1.0 / (nee * emission * paths)) };
        MisState { dvcm: finite(1.0 / (emission * paths)), dvc, dvc_emitter: dvc, ..MisState::CAMERA }
    }

    /// The subpath reaches its next vertex, at squared distance `dist2`, where the cosine to
    /// where it came from is `cos`.
    #[inline]
    pub fn arrive(&mut self, dist2: f32, cos: f32) {
        self.dvcm = finite(self.dvcm * dist2 / cos);
        self.dvc = finite(self.dvc / cos);
        self.dvc_emitter = finite(self.dvc_emitter / cos);
        self.dvc_last = finite(self.dvc_last / cos);
        self.dvc_glossy = finite(self.dvc_glossy / cos);
        self.dvc_last_fewer = finite(self.dvc_last_fewer / cos);
    }

    /// The part of a light subpath's `dvc` at its vertex y (the techniques that extend the
    /// camera subpath two or more vertices into the light subpath, past y) whose techniques
    /// `connect` lets make the path, where y is the camera's vertex of rank `rank`
    /// ([`Connect::at`]; 1 for light tracing to the camera) and `after` says what y makes of
    /// the camera vertex after it ([`After`]; `Plain` but for `--connect glossy`).
    #[inline]
    pub fn beyond(&self, connect: Connect, rank: u32, after: After) -> f32 {
        // (`last` is zero where the next vertex does not connect.)
        match connect {
            Connect::All => self.dvc,
            Connect::Glossy => self.dvc_emitter + self.dvc_glossy + self.last(connect.next(rank, after)),
            _ => self.dvc_emitter + self.last(connect.next(rank, after)),
        }
    }

    /// The connection folded in last as the vertex after its camera-side neighbour makes it
    /// ([`Next`]): none, with the gather's counts (`dvc_last`) or with fewer draws
    /// (`dvc_last_fewer`).
    #[inline]
    fn last(&self, next: Next) -> f32 {
        match next {
            Next::None => 0.0,
            Next::Full => self.dvc_last,
            Next::Fewer => self.dvc_last_fewer,
        }
    }

    /// The subpath continues from a vertex by BSDF sampling: density `pdf` (per solid angle;
    /// a delta lobe's probability), `pdf_rev` the density of sampling the way back from the
    /// new direction, `cos_out` the cosine of the new direction at the vertex. `fold` says
    /// whether the technique `dvcm` stands for can make the path (a camera subpath: whether
    /// the previous vertex may connect); `emitter` whether it is next-event estimation (a
    /// light subpath's first vertex after the emitter).
    #[inline]
    pub fn scatter(&mut self, s: Scatter) {
        if s.delta {
            // (Nothing is folded in: a delta vertex connects to nothing. The camera's next
            // connecting vertex is the next non-delta one, [`Connect::at`], so the connection
            // folded in last waits for it.)
            self.dvcm = 0.0;
            self.dvc = finite(self.dvc * s.cos_out);
            self.dvc_emitter = finite(self.dvc_emitter * s.cos_out);
            self.dvc_last = finite(self.dvc_last * s.cos_out);
            self.dvc_glossy = finite(self.dvc_glossy * s.cos_out);
            self.dvc_last_fewer = finite(self.dvc_last_fewer * s.cos_out);
        } else {
            let k = s.cos_out / s.pdf;
            let dvcm = if s.fold { self.dvcm * s.count } else { 0.0 };
            let emitter = if s.emitter { self.dvcm } else { 0.0 };
            self.dvc = finite(k * (self.dvc * s.pdf_rev + dvcm));
            // The connection folded in last has this vertex as its camera-side neighbour.
            // (The glossy sum holds what `--connect glossy` connects after this vertex, which
            // is never the first: rank 1 here stands for any.)
            let last = self.last(Connect::Glossy.next(1, s.after));
            self.dvc_glossy = finite(k * (self.dvc_glossy + last) * s.pdf_rev);
            let (connection, fewer) =
                if s.emitter || !s.fold { (0.0, 0.0) } else { (dvcm, self.dvcm * s.count_fewer) };
            self.dvc_last = finite(k * connection);
            self.dvc_last_fewer = finite(k * fewer);
            self.dvc_emitter = finite(k * (self.dvc_emitter * s.pdf_rev + emitter));
            self.dvcm = finite(1.0 / s.pdf);
        }
    }
}

/// One BSDF sample as [`MisState::scatter`] needs it.
#[derive(Clone, Copy, Debug)]
pub struct Scatter {
    pub pdf: f32,
    pub pdf_rev: f32,
    pub cos_out: f32,
    pub delta: bool,
    pub fold: bool,
    pub emitter: bool,
    /// The count of the technique `dvcm` stands for, relative to [`Counts::paths`] (1 for
    /// next-event estimation): what it is weighed with once folded into `dvc`; and the same
    /// where its camera vertex draws fewer ([`Counts::at`]; light subpaths only).
    pub count: f32,
    pub count_fewer: f32,
    /// What the vertex makes of the camera vertex after it ([`After::of`]; light subpaths
    /// only).
    pub after: After,
}

impl Scatter {
    /// A camera subpath's sample at a vertex: `fold` says whether the camera vertex before it
    /// (its previous non-delta one, or the camera, which light tracing reaches) connects
    /// ([`Connect::at`]; any for a delta vertex, whose sample folds nothing in), and then its
    /// connection to this vertex counts `count` times ([`Counts::factor`] of the two).
    #[inline]
    pub fn camera(pdf: f32, pdf_rev: f32, cos_out: f32, delta: bool, fold: bool, count: f32) -> Self {
        Scatter {
            pdf,
            pdf_rev,
            cos_out,
            delta,
            fold,
            emitter: false,
            count,
            count_fewer: 0.0,
            after: After::Plain,
        }
    }

    /// A light subpath's sample at its vertex of `depth` segments from the emitter: at the
    /// first, the technique `dvcm` stands for is next-event estimation; further on, the
    /// connection of this vertex (as a camera vertex) to the previous one's VPL, which counts
    /// `count` times ([`Counts::between`] this vertex and the previous one, which is 1 at
    /// the first vertex, whose previous one is the emitter), `count_fewer` the same where this
    /// vertex as a camera vertex draws fewer ([`Counts::between_at`]); `after` what the vertex
    /// makes of the camera vertex after it ([`After::of`]).
    #[inline]
    #[allow(clippy::too_many_arguments)]
    pub fn light(
        pdf: f32,
        pdf_rev: f32,
        cos_out: f32,
        delta: bool,
        depth: u32,
        count: f32,
        count_fewer: f32,
        after: After,
    ) -> Self {
        Scatter { pdf, pdf_rev, cos_out, delta, fold: true, emitter: depth == 1, count, count_fewer, after }
    }
}

/// A ratio that overflowed counts as zero: the technique it stands for is negligible (or
/// cannot make the path), and the weights stay finite.
#[inline]
fn finite(x: f32) -> f32 {
    if x.is_finite() { x } else { 0.0 }
}
