//! Light tracing to the camera (`pir-bdpt`): every non-delta vertex y of a light path is
//! connected to the lens and its light splatted into the film where the camera sees y, one
//! more technique among `pir-bdpt`'s ([`super::bidirectional`], t = 0 camera vertices after
//! the lens). It is the one technique that makes the caustics seen directly (light → glass or
//! mirror → diffuse → camera): the camera finds those only by BSDF sampling towards the light
//! through the delta chain, no VPL carries them (their first camera vertex would have to
//! connect to a delta vertex), and light tracing makes them as easily as any other path.
//!
//! The splat's value is the light path's throughput (flux over N) times the BSDF at y towards
//! the lens (with its cosine) times the camera's importance over the lens point's density,
//! cos θ_c / d² · W H / (A cos⁴ θ_c) = pdf_dir / d² (pbrt-v4's `PerspectiveCamera::SampleWi`,
//! with a pixel as the film's unit of area: [`crate::scene::CameraRays::direction_pdf`]). The
//! driver adds it to the film through the reconstruction filter, as a camera sample at the
//! same film position (`crate::render`). A thin lens's point is drawn from the light path's
//! sampler, uniform on the aperture as the camera rays draw theirs; a pinhole draws none, so
//! that light tracing leaves the light paths' numbers and their VPLs as they were.
//!
//! Each light path's splats are a function of the seed, the iteration and the path's index,
//! collected in path order ([`super::light_paths`]), so the image does not depend on the
//! threads.

use glam::{Vec2, Vec3};

use super::bidirectional::camera_weight;
use super::config::Connect;
use super::subpath::MisState;
use crate::integrator::{FilmSplat, RenderContext, shadow_ray};
use crate::material::{Bsdf, PreparedBsdf, TransportMode};
use crate::scene::{CameraRays, SurfacePoint};

/// What light tracing to the camera needs: the camera at the film's resolution, and what the
/// weights need of the camera path's techniques.
#[derive(Clone, Copy, Debug)]
pub struct ToCamera {
    pub camera: CameraRays,
    /// Which camera vertices connect to the VPLs.
    pub connect: Connect,
    /// The light samples at the camera path's first vertex.
    pub light_samples: u32,
    /// Whether the splats are weighed against the camera path's techniques (`pir-bdpt`), or
    /// are the whole estimate of every path light tracing makes (a plain light tracer, which
    /// the tests compare with the furnace's exact value).
    pub weighed: bool,
}

/// A light path's vertex, as light tracing to the camera sees it.
pub struct LightVertex<'a> {
    pub sp: &'a SurfacePoint,
    pub bsdf: &'a Bsdf,
    /// Unit direction towards the previous vertex of the light path.
    pub w_in: Vec3,
    /// The light path's throughput at the vertex (flux over N).
    pub beta: Vec3,
    /// The light subpath's sums on arriving here, as its VPL has them.
    pub mis: &'a MisState,
    /// Segments from the emitter.
    pub depth: u32,
    /// [`super::Vpl::count_out`]: the count of the connection from here to the previous
    /// vertex's VPL.
    pub count_out: f32,
}

impl ToCamera {
    /// Whether the aperture needs a sample ([`ToCamera::splat`]'s `aperture`): a thin lens.
    #[inline]
    pub fn draws_aperture(&self) -> bool {
        self.camera.has_lens()
    }

    /// The splat of the light arriving at `v` towards the lens point of the uniform
    /// `aperture` sample, weighed; `None` where no camera ray sees the vertex, its BSDF sends
    /// nothing towards the lens, or something is in the way (`shadow_rays` counts the
    /// occlusion queries).
    pub fn splat(
        &self,
        ctx: &RenderContext,
        v: &LightVertex,
        aperture: Vec2,
        shadow_rays: &mut u64,
    ) -> Option<FilmSplat> {
        let sp = v.sp;
        let lens = self.camera.connect(sp.p, aperture)?;
        let d = lens.lens - sp.p;
        let dist2 = d.length_squared();
        let w = d / dist2.sqrt();
        let geometry = sp.geometry();
        let f = PreparedBsdf::new(*v.bsdf, geometry, v.w_in, TransportMode::Importance).eval(w);
        if f.max_element() <= 0.0 {
            return None;
        }
        let weight = if self.weighed {
            let pdf_camera = lens.pdf_dir * sp.ng.dot(w).abs() / dist2;
            // The reverse density only where the sums it multiplies are not zero.
            let light_rev = if v.mis.dvc > 0.0 { v.bsdf.pdf(&geometry, w, v.w_in) } else { 0.0 };
            let n = self.light_samples as f32;
            let after = self.connect.after(v.bsdf);
            camera_weight(v.mis, v.depth, after, v.count_out, pdf_camera, light_rev, self.connect, n)
        } else {
            1.0
        };
        if weight <= 0.0 {
            return None;
        }
        *shadow_rays += 1;
        if ctx.accel.occluded(&shadow_ray(sp.p, sp.ng, lens.visible_end, Vec3::ZERO)) {
            return None;
        }
        Some(FilmSplat { film: lens.film, value: v.beta * f * (lens.pdf_dir / dist2 * weight) })
    }
}
