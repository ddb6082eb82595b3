//! The many-light integrator: each iteration traces the light paths, makes the iteration's
//! light set from their VPLs, and walks every camera path with the method's estimator
//! ([`super::gathering`] or [`super::bdpt_path`]), the driver's batches of camera rays by the
//! batched walker ([`walk_batch`]); `pir-bdpt`'s light paths also splat into the film
//! ([`super::to_camera`]).

use glam::Vec3;

use super::bdpt_path::Bidirectional;
use super::bidirectional;
use super::config::{Clamping, Gather, VirtualLights};
use super::gathering::{Gathering, WeighedGathering};
use super::importance::{self, Acceptance};
use super::light_paths::{Vpl, trace_light_paths};
use super::light_set::LightSet;
use super::merging::Merging;
use super::path_count::{AutoPaths, Pilot};
use super::points::PointLights;
use super::spheres::SphereLights;
use super::subpath::Counts;
use super::to_camera::ToCamera;
use super::view_pilot;
use super::window::LightPaths;
use crate::geometry::Ray;
use crate::integrator::walker::{Estimator, walk};
use crate::integrator::wavefront::walk_batch;
use crate::integrator::{Counters, FilmSplat, Integrator, RenderContext};
use crate::sampling::Sampler;
use crate::scene::CameraRays;

/// A many-light method: its parameters, and the light set of the current iteration.
pub struct InstantRadiosity {
    lights: VirtualLights,
    paths: usize,
    /// Light paths chosen by the scene's yield of VPLs ([`path_count`](super::path_count)) when
    /// [`Integrator::prepare`] runs, instead of `paths`.
    auto: Option<AutoPaths>,
    /// What the pilot measured ([`Integrator::prepare`]), for methods that need it.
    pilot: Option<Pilot>,
    gather: Gather,
    /// [`VirtualLights::Bidirectional`]: light samples at the camera path's first vertex.
    light_samples: u32,
    /// Whether [`Integrator::prepare`] chooses `light_samples` by the pilot's visibility of
    /// the emitters ([`bidirectional::light_samples_for`], with `light_samples` the base).
    auto_light_samples: bool,
    /// Whether [`Integrator::prepare`] chooses which camera vertices of
    /// [`VirtualLights::Bidirectional`] connect ([`view_pilot`]), and the share of lit points
    /// its pilot found.
    auto_connect: bool,
    lit_share: Option<f32>,
    /// The camera at the film's resolution ([`Integrator::set_camera`]): `pir-bdpt` traces
    /// light to it (none given: no light tracing to the camera, which the weights then leave
    /// out).
    camera: Option<CameraRays>,
    set: IterationLights,
    /// The current iteration's light traced to the camera, in path order.
    splats: Vec<FilmSplat>,
    /// [`VirtualLights::Bidirectional`] with a camera: vertex merging's r_1 in pixels and the
    /// exponent α of its schedule ([`super::merging`]; none: no merging).
    merge: Option<(f32, f32)>,
    /// The current iteration's photons.
    merging: Option<Merging>,
    /// Whether [`Integrator::prepare`] may keep the VPLs by their share of the image
    /// ([`super::importance`]; with light paths chosen by the scene and a camera), and the
    /// plan it chose.
    auto_acceptance: bool,
    acceptance: Option<Acceptance>,
    /// Whether the plan may also raise the resampled gather's picks
    /// ([`super::importance::picks_for`]).
    auto_picks: bool,
}

/// The current iteration's lights (none before the first iteration).
enum IterationLights {
    None,
    /// Points, and the weights' counts and bound on the weighted connection of the weighed
    /// methods (their bound is not on G).
    Points {
        set: LightSet<PointLights>,
        counts: Counts,
        bound: f32,
    },
    Spheres(LightSet<SphereLights>),
}

impl InstantRadiosity {
    pub fn new(lights: VirtualLights, paths: usize) -> Self {
        InstantRadiosity {
            lights,
            paths,
            auto: None,
            pilot: None,
            gather: Gather::All,
            light_samples: 1,
            auto_light_samples: false,
            auto_connect: false,
            lit_share: None,
            camera: None,
            set: IterationLights::None,
            splats: Vec::new(),
            merge: None,
            merging: None,
            auto_acceptance: false,
            acceptance: None,
            auto_picks: false,
        }
    }

    /// The same method keeping its VPLs by their share of the image where the scene's pilot
    /// says most of them light what the camera does not see ([`super::importance`]); only
    /// with light paths chosen by the scene ([`InstantRadiosity::with_auto_paths`]). With
    /// `picks`, where the plan keeps few of them the resampled gather picks more of its
    /// candidates too ([`super::importance::picks_for`]).
    pub fn with_auto_acceptance(self, picks: bool) -> Self {
        InstantRadiosity { auto_acceptance: true, auto_picks: picks, ..self }
    }

    /// The same method merging the caustics seen through delta surfaces (for
    /// [`VirtualLights::Bidirectional`]) within `pixels` pixels' footprint, shrunk by the
    /// schedule of exponent `alpha` ([`super::merging`]); 0 pixels: no merging.
    pub fn with_merging(self, pixels: f32, alpha: f32) -> Self {
        let merge = (pixels > 0.0).then_some((pixels, alpha));
        InstantRadiosity { merge, ..self }
    }

    /// The same method with its light paths chosen by the scene's yield of VPLs; `paths`
    /// until [`Integrator::prepare`] chooses them.
    pub fn with_auto_paths(self, auto: AutoPaths) -> Self {
        InstantRadiosity { auto: Some(auto), ..self }
    }

    /// The same method gathering as `gather` says.
    pub fn with_gather(self, gather: Gather) -> Self {
        InstantRadiosity { gather, ..self }
    }

    /// The same method taking `n` light samples at the camera path's first vertex (for
    /// [`VirtualLights::Bidirectional`]; the others take one), 1 to
    /// [`MAX_LIGHT_SAMPLES`](crate::integrator::MAX_LIGHT_SAMPLES).
    pub fn with_light_samples(self, n: u32) -> Self {
        let n = n.clamp(1, crate::integrator::MAX_LIGHT_SAMPLES);
        InstantRadiosity { light_samples: n, auto_light_samples: false, ..self }
    }

    /// The same method with its light samples chosen by the scene when [`Integrator::prepare`]
    /// runs: `base` where the emitters are in view, more where they are hidden
    /// ([`bidirectional::light_samples_for`]).
    pub fn with_auto_light_samples(self, base: u32) -> Self {
        InstantRadiosity { auto_light_samples: true, ..self.with_light_samples(base) }
    }

    /// Which camera vertices connect ([`VirtualLights::Bidirectional`]) chosen by the share
    /// of the points the camera sees that the emitters light directly ([`view_pilot`]).
    pub fn with_auto_connect(self) -> Self {
        InstantRadiosity { auto_connect: true, ..self }
    }

    /// Point lights with the given clamping.
    pub fn points(clamping: Clamping, paths: usize) -> Self {
        Self::new(VirtualLights::Points(clamping), paths)
    }
}

impl Integrator for InstantRadiosity {
    fn film_splats(&self) -> &[FilmSplat] {
        &self.splats
    }

    /// The light paths per iteration, and for [`VirtualLights::Bidirectional`] the light
    /// samples at the first vertex and the pilot's visibility of the emitters (what the
    /// weights' counts used, [`Pilot`]).
    fn measured(&self) -> Vec<(String, String)> {
        let mut m = vec![("vpls".to_string(), self.paths.to_string())];
        if matches!(self.lights, VirtualLights::Bidirectional(..)) {
            if let VirtualLights::Bidirectional(_, connect) = self.lights {
                m.push(("connect".into(), connect.name()));
            }
            if let Some(share) = self.lit_share {
                m.push(("lit-share".into(), format!("{share:.3}")));
            }
            m.push(("light-samples".into(), self.light_samples.to_string()));
            if let Some(pilot) = self.pilot {
                m.push(("emitter-visibility".into(), format!("{:.3}", pilot.visibility)));
            }
            if let Some(a) = &self.acceptance {
                m.push(("vpl-acceptance".into(), format!("{:.3}", a.mean)));
                if let Gather::Resampled { samples, .. } = self.gather {
                    m.push(("gather-samples".into(), samples.to_string()));
                }
            }
        }
        m
    }

    /// The pilot, once, for counts chosen by the scene or the bidirectional weights.
    fn prepare(&mut self, ctx: &RenderContext, counters: &mut Counters) {
        if let (VirtualLights::Bidirectional(clamping, _), Some(camera)) = (self.lights, self.camera)
            && std::mem::take(&mut self.auto_connect)
        {
            let share = view_pilot::lit_share(ctx, &camera, counters);
            self.lights = VirtualLights::Bidirectional(clamping, view_pilot::connect_for(share));
            self.lit_share = Some(share);
        }
        let bidirectional = matches!(self.lights, VirtualLights::Bidirectional(..));
        if self.pilot.is_some() || !(bidirectional || self.auto.is_some()) {
            return;
        }
        let pilot = Pilot::run(ctx, counters);
        if let Some(auto) = self.auto.take() {
            self.paths = auto.for_yield(pilot.per_path, pilot.caustic_per_path);
            if bidirectional && std::mem::take(&mut self.auto_acceptance) {
                self.plan_acceptance(ctx, auto.at_most, counters);
            }
        }
        if std::mem::take(&mut self.auto_light_samples) {
            self.light_samples = bidirectional::light_samples_for(self.light_samples, pilot.visibility);
        }
        self.pilot = Some(pilot);
    }

    fn set_camera(&mut self, camera: CameraRays) {
        self.camera = Some(camera);
    }

    fn begin_iteration(&mut self, ctx: &RenderContext, iteration: u64, counters: &mut Counters) {
        // A VPL of s segments serves a camera vertex of d ≥ 1 segments when d + 1 + s ≤ max_depth.
        let max_vpl_depth = ctx.max_depth.saturating_sub(2);
        let visibility = self.pilot.map_or(1.0, |p| p.visibility);
        let counts = Counts::new(self.paths, self.gather, visibility);
        // (`pir-bdpt` makes no connection at a near-specular vertex; the thesis' methods do.)
        let bidirectional = matches!(self.lights, VirtualLights::Bidirectional(..));
        let counts = if bidirectional { counts.skipping_near_specular() } else { counts };
        let to_camera = match (self.lights, self.camera) {
            (VirtualLights::Bidirectional(_, connect), Some(camera)) => {
                Some(ToCamera { camera, connect, light_samples: self.light_samples, weighed: true })
            }
            _ => None,
        };
        let merge = self.merge.filter(|_| to_camera.is_some());
        let traced = trace_light_paths(
            ctx,
            iteration,
            self.paths,
            counts,
            max_vpl_depth,
            to_camera.as_ref(),
            merge.is_some(),
            self.acceptance.as_ref(),
        );
        let (vpls, rays) = (traced.vpls, traced.rays);
        let paths = LightPaths::new(traced.path_ends);
        self.splats = traced.splats;
        self.merging = merge.map(|(pixels, alpha)| {
            counters.photons += traced.photons.len() as u64;
            Merging::new(traced.photons, counts.paths, pixels, alpha, iteration)
        });
        counters.light_rays += rays;
        counters.shadow_rays += traced.shadow_rays;
        counters.light_paths += self.paths as u64;
        counters.vpls += vpls.len() as u64;
        let gather = self.gather;
        self.set = match self.lights {
            VirtualLights::Points(clamping) => {
                let points = PointLights::new(vpls, clamping, iteration, ctx, None);
                IterationLights::Points {
                    set: LightSet::new(ctx, points, gather, paths),
                    counts,
                    bound: f32::INFINITY,
                }
            }
            // The bound applies to the weighted connection ([`super::mis`]), not to G;
            // `pir-mis` counts every light path for every connection.
            VirtualLights::WeighedPoints(clamping) | VirtualLights::Bidirectional(clamping, _) => {
                // (Only the resampled gather's estimates read the weights' terms.)
                let weighed = match (self.lights, gather) {
                    (VirtualLights::Bidirectional(_, connect), Gather::Resampled { .. }) => Some(connect),
                    _ => None,
                };
                let points = PointLights::new(vpls, Clamping::None, iteration, ctx, weighed);
                let counts = match self.lights {
                    VirtualLights::WeighedPoints(_) => Counts::uniform(counts.paths),
                    _ => counts,
                };
                let bound = clamping.bound(iteration);
                IterationLights::Points { set: LightSet::new(ctx, points, gather, paths), counts, bound }
            }
            VirtualLights::Spheres { radius, alpha } => {
                let diagonal = ctx.scene.bounds().diagonal();
                let bsdf = |v: &Vpl| v.bsdf(ctx.scene);
                let spheres = SphereLights::new(vpls, bsdf, radius, alpha, iteration, diagonal);
                IterationLights::Spheres(LightSet::new(ctx, spheres, gather, paths))
            }
        };
    }

    fn radiance(
        &self,
        ctx: &RenderContext,
        ray: Ray,
        sampler: &mut Sampler,
        counters: &mut Counters,
    ) -> Vec3 {
        let mut out = Vec3::ZERO;
        self.walk_with(&mut ScalarWalk { ray, sampler, counters, out: &mut out }, ctx);
        out
    }

    /// The paths of the batch together ([`walk_batch`]), each the same as
    /// [`InstantRadiosity::radiance`]'s.
    fn radiance_batch(
        &self,
        ctx: &RenderContext,
        rays: &[Ray],
        samplers: &mut [Sampler],
        counters: &mut Counters,
        out: &mut [Vec3],
    ) {
        out.fill(Vec3::ZERO);
        self.walk_with(&mut BatchWalk { rays, samplers, counters, out }, ctx);
    }
}

/// How the camera paths are walked with the method's estimator: one path by the scalar
/// walker, or a batch by the batched walker.
trait Walk {
    fn walk<E: Estimator>(&mut self, ctx: &RenderContext, estimator: &E);
}

/// One camera path by [`walk`].
struct ScalarWalk<'a, 's> {
    ray: Ray,
    sampler: &'a mut Sampler<'s>,
    counters: &'a mut Counters,
    out: &'a mut Vec3,
}

impl Walk for ScalarWalk<'_, '_> {
    fn walk<E: Estimator>(&mut self, ctx: &RenderContext, estimator: &E) {
        *self.out = walk(ctx, self.ray, estimator, self.sampler, self.counters);
    }
}

/// A batch of camera paths by [`walk_batch`].
struct BatchWalk<'a, 's> {
    rays: &'a [Ray],
    samplers: &'a mut [Sampler<'s>],
    counters: &'a mut Counters,
    out: &'a mut [Vec3],
}

impl Walk for BatchWalk<'_, '_> {
    fn walk<E: Estimator>(&mut self, ctx: &RenderContext, estimator: &E) {
        walk_batch(ctx, estimator, self.rays, self.samplers, self.counters, self.out);
    }
}

impl InstantRadiosity {
    /// Keeps the VPLs by their share of the image where [`Acceptance::plan`] says so and the
    /// light paths can grow by its whole factor within `at_most`; raises the resampled
    /// gather's picks with it where `auto_picks` allows ([`importance::picks_for`]).
    fn plan_acceptance(&mut self, ctx: &RenderContext, at_most: usize, counters: &mut Counters) {
        let Some(camera) = self.camera else { return };
        let view = view_pilot::view(ctx, &camera, counters);
        let max_vpl_depth = ctx.max_depth.saturating_sub(2);
        let Some((acceptance, more)) = Acceptance::plan(ctx, view, max_vpl_depth, counters) else { return };
        let paths = (self.paths as f32 * more).ceil() as usize;
        if paths > at_most {
            return;
        }
        self.paths = paths;
        if let Gather::Resampled { candidates, samples } = self.gather
            && self.auto_picks
        {
            let samples = importance::picks_for(samples, acceptance.mean);
            self.gather = Gather::Resampled { candidates, samples };
        }
        self.acceptance = Some(acceptance);
    }

    /// Walks the camera paths of `w` with the estimator of the method on the iteration's
    /// lights (none before the first iteration: nothing, zero).
    fn walk_with(&self, w: &mut impl Walk, ctx: &RenderContext) {
        // Weighed connections exist for points only, so a weighed gather of spheres does not
        // type-check.
        match (&self.set, self.lights) {
            (IterationLights::None, _) => {}
            (IterationLights::Spheres(set), _) => w.walk(ctx, &Gathering { set }),
            (IterationLights::Points { set, counts, bound }, lights) => match lights {
                VirtualLights::Bidirectional(_, connect) => {
                    let light_samples = self.light_samples;
                    let camera = self.camera.as_ref();
                    let merging = self.merging.as_ref();
                    let camera_path = Bidirectional {
                        set,
                        connect,
                        light_samples,
                        counts: *counts,
                        bound: *bound,
                        camera,
                        merging,
                    };
                    w.walk(ctx, &camera_path);
                }
                VirtualLights::WeighedPoints(_) => {
                    let weighed = WeighedGathering { set, paths: counts.paths, bound: *bound };
                    w.walk(ctx, &weighed);
                }
                VirtualLights::Points(_) | VirtualLights::Spheres { .. } => w.walk(ctx, &Gathering { set }),
            },
        }
    }
}
