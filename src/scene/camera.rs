//! The scene's camera: a pinhole, or Mitsuba 3's thin lens (depth of field), looking along
//! `target − eye` with a vertical field of view (kept along another axis when the resolution
//! changes, [`FovAxis`]); image y downwards, pixel (0, 0) top-left,
//! right = normalize(forward × up). Mitsuba's near and far clip planes bound what a camera ray
//! sees (the TOML format's camera has none: `[0, ∞)`).

use glam::{Vec2, Vec3};

use crate::geometry::Ray;
use crate::sampling::concentric_disk;

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    pub eye: Vec3,
    pub target: Vec3,
    pub up: Vec3,
    /// Vertical field of view in degrees.
    pub fov_deg: f32,
    pub width: u32,
    pub height: u32,
    /// The axis along which the field of view stays when the resolution changes
    /// ([`Camera::with_resolution`]): the vertical one for the TOML format's camera, Mitsuba's
    /// `fov_axis` for a Mitsuba sensor.
    pub fov_axis: FovAxis,
    /// Distance along the view axis (`target − eye`) from the eye to the near clip plane: a
    /// camera ray sees no surface in front of it (Mitsuba's `near_clip`; 0 for none).
    pub near_clip: f32,
    /// Distance along the view axis to the far clip plane: a camera ray sees no surface behind
    /// it (Mitsuba's `far_clip`; infinite for none).
    pub far_clip: f32,
    /// The thin lens at the eye, or `None` for a pinhole.
    pub lens: Option<ThinLens>,
    /// Mitsuba's principal point offset (`principal_point_offset_x`, `_y` of a `perspective`
    /// camera): the film position of every ray is shifted by this fraction of the image's
    /// width and height (x to the right, y down), which moves the optical axis off the
    /// image's centre. Zero for none.
    pub principal_point_offset: Vec2,
}

/// The axis along which a camera's field of view is given, and kept when the resolution
/// changes: Mitsuba 3's `fov_axis` (a `focal_length` is a diagonal field of view).
/// `Smaller` and `Larger` are resolved against the film's aspect, as Mitsuba resolves them
/// against its film: a film of another aspect can hold the field of view along the other
/// axis.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum FovAxis {
    X,
    /// The vertical axis (the TOML format's).
    #[default]
    Y,
    Diagonal,
    Smaller,
    Larger,
}

impl FovAxis {
    /// The tangent of half the field of view along this axis, of a film of aspect `aspect`
    /// (width / height) whose vertical one has half-angle tangent `tan_v`.
    fn tan_half(self, tan_v: f64, aspect: f64) -> f64 {
        match self.resolved(aspect) {
            FovAxis::X => tan_v * aspect,
            FovAxis::Diagonal => tan_v * (1.0 + aspect * aspect).sqrt(),
            _ => tan_v,
        }
    }

    /// The inverse of [`FovAxis::tan_half`]: the vertical half-angle tangent of a film of
    /// aspect `aspect` whose field of view along this axis has half-angle tangent `t`.
    fn tan_half_vertical(self, t: f64, aspect: f64) -> f64 {
        match self.resolved(aspect) {
            FovAxis::X => t / aspect,
            FovAxis::Diagonal => t / (1.0 + aspect * aspect).sqrt(),
            _ => t,
        }
    }

    /// `Smaller` and `Larger` as the axis they name on a film of aspect `aspect` (Mitsuba's
    /// `parse_fov`: the vertical one is smaller where the film is wider than tall).
    fn resolved(self, aspect: f64) -> FovAxis {
        match self {
            FovAxis::Smaller if aspect > 1.0 => FovAxis::Y,
            FovAxis::Smaller => FovAxis::X,
            FovAxis::Larger if aspect > 1.0 => FovAxis::X,
            FovAxis::Larger => FovAxis::Y,
            axis => axis,
        }
    }

    /// Mitsuba's name of the axis (`fov_axis`).
    pub fn name(self) -> &'static str {
        match self {
            FovAxis::X => "x",
            FovAxis::Y => "y",
            FovAxis::Diagonal => "diagonal",
            FovAxis::Smaller => "smaller",
            FovAxis::Larger => "larger",
        }
    }
}

/// Mitsuba 3's thin lens (`thinlens`): rays leave a uniformly sampled point of a disk of
/// radius `aperture_radius` about the eye, in the plane orthogonal to the view axis, towards
/// the point where the pinhole's ray through the same film position meets the focus plane,
/// at `focus_distance` along the view axis. Surfaces on the focus plane are sharp.
///
/// Light tracing to the camera ([`CameraRays::connect`]) picks the lens point as Mitsuba's
/// `ThinLensCamera::sample_direction` does: uniformly on the aperture, the film position
/// where the ray from that point through the vertex crosses the focus plane. The aperture's
/// density is the camera rays' own, so that both see the vertex from the lens point with the
/// pinhole's direction density ([`CameraRays::direction_pdf`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ThinLens {
    /// The aperture's radius in scene units (Mitsuba's `aperture_radius`).
    pub aperture_radius: f32,
    /// Distance along the view axis from the lens to the plane in focus (Mitsuba's
    /// `focus_distance`), positive.
    pub focus_distance: f32,
}

impl Camera {
    /// A pinhole camera without clip planes (the TOML format's camera).
    pub fn pinhole(eye: Vec3, target: Vec3, up: Vec3, fov_deg: f32, width: u32, height: u32) -> Self {
        Camera {
            eye,
            target,
            up,
            fov_deg,
            width,
            height,
            near_clip: 0.0,
            far_clip: f32::INFINITY,
            lens: None,
            principal_point_offset: Vec2::ZERO,
            fov_axis: FovAxis::Y,
        }
    }

    /// The same camera at another resolution, its field of view kept along its
    /// [`Camera::fov_axis`] (as Mitsuba renders a scene whose film is given another size):
    /// where the aspect changes, the vertical field of view follows an axis other than the
    /// vertical one. (An unchanged aspect, or the vertical axis, keeps it bit for bit.)
    pub fn with_resolution(mut self, width: u32, height: u32) -> Self {
        let aspect = |w: u32, h: u32| w as f64 / h as f64;
        let same_aspect = width as u64 * self.height as u64 == self.width as u64 * height as u64;
        if !same_aspect && self.fov_axis != FovAxis::Y && width > 0 && height > 0 && self.height > 0 {
            let tan_v = (self.fov_deg as f64 / 2.0).to_radians().tan();
            let t = self.fov_axis.tan_half(tan_v, aspect(self.width, self.height));
            let tan_v = self.fov_axis.tan_half_vertical(t, aspect(width, height));
            self.fov_deg = (2.0 * tan_v.atan().to_degrees()) as f32;
        }
        self.width = width;
        self.height = height;
        self
    }

    /// The field of view in degrees along [`Camera::fov_axis`] at the camera's resolution.
    pub fn fov_along_axis(&self) -> f32 {
        if self.fov_axis == FovAxis::Y {
            return self.fov_deg;
        }
        let tan_v = (self.fov_deg as f64 / 2.0).to_radians().tan();
        let t = self.fov_axis.tan_half(tan_v, self.width as f64 / self.height.max(1) as f64);
        (2.0 * t.atan().to_degrees()) as f32
    }

    /// The ray through the image-plane position `film` (in pixels: x to the right, y down,
    /// `(0, 0)` the top-left corner of pixel (0, 0)) and the centre of the lens: the
    /// pinhole's ray. The direction is unit length; the interval is the clip planes'.
    pub fn generate_ray(&self, film: Vec2) -> Ray {
        self.rays().generate_ray(film, Vec2::splat(0.5))
    }

    /// The camera's basis and scales computed once, for generating many rays.
    pub fn rays(&self) -> CameraRays {
        let forward = (self.target - self.eye).normalize();
        let right = forward.cross(self.up).normalize();
        CameraRays {
            eye: self.eye,
            forward,
            right,
            up: right.cross(forward),
            tan_half: (self.fov_deg.to_radians() * 0.5).tan(),
            aspect: self.width as f32 / self.height as f32,
            width: self.width as f32,
            height: self.height as f32,
            near_clip: self.near_clip,
            far_clip: self.far_clip,
            lens: self.lens,
            shift: self.principal_point_offset * Vec2::new(self.width as f32, self.height as f32),
        }
    }
}

/// A [`Camera`] prepared for generating rays: its basis and the tangent of half its field of
/// view, which do not change from ray to ray.
#[derive(Clone, Copy, Debug)]
pub struct CameraRays {
    eye: Vec3,
    forward: Vec3,
    right: Vec3,
    up: Vec3,
    tan_half: f32,
    aspect: f32,
    width: f32,
    height: f32,
    near_clip: f32,
    far_clip: f32,
    lens: Option<ThinLens>,
    /// The principal point offset in pixels (zero, which changes no position, for none).
    shift: Vec2,
}

/// A point connected to the camera ([`CameraRays::connect`]): where on the lens, where on
/// the film, and how densely the camera's rays sample the direction.
#[derive(Clone, Copy, Debug)]
pub struct LensConnection {
    /// The lens point (the eye for a pinhole).
    pub lens: Vec3,
    /// The film position in pixels, as [`CameraRays::generate_ray`] takes it (x to the right,
    /// y down, the principal point offset undone), inside the image.
    pub film: Vec2,
    /// The camera's density of the direction from `lens` to the point
    /// ([`CameraRays::direction_pdf`]).
    pub pdf_dir: f32,
    /// Where the segment from the point to the lens leaves what camera rays see: the near
    /// clip plane, or the lens point without one (the end of a shadow ray).
    pub visible_end: Vec3,
}

impl CameraRays {
    /// The density with which the camera's rays sample the unit direction `dir` from their
    /// lens point, per unit solid angle, with a pixel of the film as the unit of area (a
    /// camera ray's film position is uniform in its pixel): W H / (A cos³ θ), A the image
    /// rectangle's area at unit distance along the view axis, θ the angle to the axis (zero
    /// behind the lens). The same for a pinhole and a thin lens (seen from the lens point,
    /// the focus plane's area element is the unit-distance rectangle's, scaled by f²).
    /// As in pbrt-v4's `PerspectiveCamera::PDF_We` (per pixel here, not per image) and
    /// Georgiev's vertex connection and merging (the image plane at the distance where a
    /// pixel has unit area).
    #[inline]
    pub fn direction_pdf(&self, dir: Vec3) -> f32 {
        let cos = dir.dot(self.forward) / dir.length();
        if cos.is_nan() || cos <= 0.0 {
            return 0.0;
        }
        let area = 4.0 * self.tan_half * self.tan_half * self.aspect;
        self.width * self.height / (area * cos * cos * cos)
    }

    /// The camera's view of the point `p`, seen from the lens point of the uniform `aperture`
    /// sample (ignored by a pinhole, as [`CameraRays::generate_ray`] ignores it): the film
    /// position whose rays from that lens point pass through `p`, and the direction's
    /// density; `None` where no camera ray sees `p` (behind the lens, outside the clip
    /// planes, outside the image).
    pub fn connect(&self, p: Vec3, aperture: Vec2) -> Option<LensConnection> {
        let (lens, focus) = match self.lens {
            None => (self.eye, 1.0),
            Some(l) => {
                let disk = l.aperture_radius * concentric_disk(aperture);
                (self.eye + self.up * disk.y - self.right * disk.x, l.focus_distance)
            }
        };
        let d = p - lens;
        let depth = d.dot(self.forward);
        if depth.is_nan() || depth <= 0.0 || depth < self.near_clip || depth > self.far_clip {
            return None;
        }
        // Where the ray from the lens point through p meets the focus plane, relative to the
        // eye and in units of the focus distance: the pinhole's direction of the film position.
        let q = (lens - self.eye + d * (focus / depth)) / focus;
        let (sx, sy) = (q.dot(self.right), q.dot(self.up));
        let film = Vec2::new(
            (sx / (self.tan_half * self.aspect) + 1.0) * 0.5 * self.width,
            (1.0 - sy / self.tan_half) * 0.5 * self.height,
        ) - self.shift;
        if !(film.x >= 0.0 && film.x < self.width && film.y >= 0.0 && film.y < self.height) {
            return None;
        }
        let visible_end = lens + d * (self.near_clip / depth);
        Some(LensConnection { lens, film, pdf_dir: self.direction_pdf(d), visible_end })
    }

    /// Whether a ray needs a point on the aperture ([`CameraRays::generate_ray`]'s
    /// `aperture`): a thin lens does, a pinhole does not, so that a pinhole's camera sample
    /// draws the film position alone.
    #[inline]
    pub fn has_lens(&self) -> bool {
        self.lens.is_some()
    }

    /// The film's width and height in pixels.
    pub fn film_size(&self) -> Vec2 {
        Vec2::new(self.width, self.height)
    }

    /// The ray through the image-plane position `film` (see [`Camera::generate_ray`]; shifted
    /// by the principal point offset) from the lens point of the uniform `aperture` sample in `[0, 1)²` (a pinhole ignores it), as
    /// Mitsuba 3's `thinlens` samples it: the sample mapped to the disk by the concentric
    /// map (Mitsuba's `square_to_uniform_disk_concentric`), its x to the camera's left and
    /// its y up (Mitsuba's camera space), the direction towards the focus plane's point of
    /// the film position. The direction is unit length; the ray's interval `[tmin, tmax]`
    /// lies between the clip planes, `near_clip / cos θ` to `far_clip / cos θ` with θ the
    /// angle to the view axis (Mitsuba starts the ray on the near plane; pir keeps its origin
    /// on the lens, which sees the same surfaces).
    #[inline]
    pub fn generate_ray(&self, film: Vec2, aperture: Vec2) -> Ray {
        let film = film + self.shift;
        let sx = (2.0 * film.x / self.width - 1.0) * self.tan_half * self.aspect;
        let sy = (1.0 - 2.0 * film.y / self.height) * self.tan_half;
        // The pinhole's direction, of unit length along the view axis.
        let v = self.forward + self.right * sx + self.up * sy;
        let (origin, dir) = match self.lens {
            None => (self.eye, v.normalize()),
            Some(lens) => {
                let disk = lens.aperture_radius * concentric_disk(aperture);
                let offset = self.up * disk.y - self.right * disk.x;
                (self.eye + offset, (v * lens.focus_distance - offset).normalize())
            }
        };
        let cos = dir.dot(self.forward);
        Ray { origin, dir, tmin: self.near_clip / cos, tmax: self.far_clip / cos }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cam() -> Camera {
        Camera::pinhole(Vec3::new(0.0, 1.0, 3.9), Vec3::new(0.0, 1.0, 0.0), Vec3::Y, 40.0, 200, 100)
    }

    #[test]
    fn centre_looks_at_target_and_axes_follow_the_spec() {
        let c = cam();
        let r = c.generate_ray(Vec2::new(100.0, 50.0));
        assert!((r.dir - Vec3::new(0.0, 0.0, -1.0)).length() < 1e-6);
        // Image x grows to the right of the viewer: forward (-z) × up (+y) = +x.
        let right = c.generate_ray(Vec2::new(200.0, 50.0));
        assert!(right.dir.x > 0.0);
        // Image y grows downwards.
        let top = c.generate_ray(Vec2::new(100.0, 0.0));
        assert!(top.dir.y > 0.0);
        // The vertical field of view spans the image height.
        let angle = top.dir.angle_between(r.dir).to_degrees();
        assert!((angle - 20.0).abs() < 1e-3, "{angle}");
        // The horizontal extent follows the aspect ratio.
        let tan_h = (right.dir.x / -right.dir.z).abs();
        assert!((tan_h - 2.0 * (20.0f32).to_radians().tan()).abs() < 1e-5);
    }
    /// Without clip planes or a lens, a ray is the pinhole's of before them, bit for bit,
    /// whatever the aperture sample: the TOML scenes' images do not change.
    #[test]
    fn a_pinhole_ray_is_unchanged() {
        let c = cam().rays();
        for film in [Vec2::new(0.0, 0.0), Vec2::new(13.25, 77.5), Vec2::new(199.9, 99.9)] {
            let sx = (2.0 * film.x / 200.0 - 1.0) * c.tan_half * c.aspect;
            let sy = (1.0 - 2.0 * film.y / 100.0) * c.tan_half;
            let want = Ray::new(c.eye, (c.forward + c.right * sx + c.up * sy).normalize());
            for aperture in [Vec2::ZERO, Vec2::new(0.3, 0.9)] {
                let r = c.generate_ray(film, aperture);
                let bits =
                    |r: &Ray| [r.origin.to_array(), r.dir.to_array()].concat().into_iter().map(f32::to_bits);
                assert!(bits(&r).eq(bits(&want)), "{r:?} ≠ {want:?}");
                assert_eq!((r.tmin.to_bits(), r.tmax), (0.0f32.to_bits(), f32::INFINITY));
            }
        }
    }

    /// A thin lens's rays through one film position leave points of the aperture disk (in
    /// the plane orthogonal to the view axis) and meet at the pinhole ray's point on the
    /// focus plane; the clip planes bound them along the view axis.
    #[test]
    fn thin_lens_rays_meet_on_the_focus_plane() {
        let lens = ThinLens { aperture_radius: 0.2, focus_distance: 3.0 };
        let c = Camera { lens: Some(lens), near_clip: 0.5, far_clip: 20.0, ..cam() };
        let forward = (c.target - c.eye).normalize();
        let rays = c.rays();
        assert!(rays.has_lens() && !cam().rays().has_lens());
        for film in [Vec2::new(100.0, 50.0), Vec2::new(3.0, 97.0), Vec2::new(180.0, 10.0)] {
            let pin = cam().generate_ray(film);
            let focus = pin.at(lens.focus_distance / pin.dir.dot(forward));
            for aperture in
                [Vec2::new(0.1, 0.2), Vec2::new(0.5, 0.5), Vec2::new(0.97, 0.6), Vec2::new(0.3, 0.99)]
            {
                let r = rays.generate_ray(film, aperture);
                let offset = r.origin - c.eye;
                assert!(offset.dot(forward).abs() < 1e-6 && offset.length() <= 0.2 + 1e-6, "{offset}");
                let t = (focus - r.origin).dot(r.dir);
                assert!((r.at(t) - focus).length() < 1e-5, "{} ≠ {focus}", r.at(t));
                assert!(((r.at(r.tmin) - r.origin).dot(forward) - 0.5).abs() < 1e-5);
                assert!(((r.at(r.tmax) - r.origin).dot(forward) - 20.0).abs() < 1e-4);
            }
            // The lens's centre is the pinhole.
            let centre = rays.generate_ray(film, Vec2::splat(0.5));
            assert!((centre.origin - c.eye).length() < 1e-7 && (centre.dir - pin.dir).length() < 1e-6);
        }
        // Mitsuba's camera space: the aperture sample's x to the camera's left, y up.
        let film = Vec2::new(100.0, 50.0);
        let left = rays.generate_ray(film, Vec2::new(1.0, 0.5)).origin - c.eye;
        let up = rays.generate_ray(film, Vec2::new(0.5, 1.0)).origin - c.eye;
        assert!((left - Vec3::new(-0.2, 0.0, 0.0)).length() < 1e-6, "{left}");
        assert!((up - Vec3::new(0.0, 0.2, 0.0)).length() < 1e-6, "{up}");
    }

    /// [`CameraRays::connect`] inverts [`CameraRays::generate_ray`]: a point on a camera
    /// ray, seen from the ray's lens point, is at the ray's film position, for a pinhole and
    /// a thin lens, with a principal point offset; points outside the image, behind the lens
    /// or beyond the clip planes are not seen.
    #[test]
    fn connect_finds_the_film_position_of_a_camera_ray() {
        let lens = ThinLens { aperture_radius: 0.2, focus_distance: 3.0 };
        let shifted = Camera { principal_point_offset: Vec2::new(0.1, -0.05), near_clip: 0.5, ..cam() };
        for c in [cam(), Camera { lens: Some(lens), ..cam() }, shifted] {
            let rays = c.rays();
            for (film, aperture, t) in [
                (Vec2::new(100.0, 50.0), Vec2::new(0.3, 0.8), 2.0),
                (Vec2::new(3.5, 97.25), Vec2::new(0.9, 0.1), 5.0),
                (Vec2::new(180.0, 10.0), Vec2::new(0.5, 0.5), 0.8),
            ] {
                let r = rays.generate_ray(film, aperture);
                let got = rays.connect(r.at(t), aperture).expect("a point on a camera ray is seen");
                assert!((got.film - film).length() < 2e-3, "{c:?}: {} ≠ {film}", got.film);
                assert!((got.lens - r.origin).length() < 1e-5);
                assert!((got.pdf_dir - rays.direction_pdf(r.dir)).abs() <= 1e-4 * got.pdf_dir);
                assert!(((got.visible_end - got.lens).dot(rays.forward) - c.near_clip).abs() < 1e-5);
            }
            let behind = c.eye - (c.target - c.eye);
            assert!(rays.connect(behind, Vec2::splat(0.5)).is_none());
            let outside = c.eye + (c.target - c.eye) + Vec3::new(0.0, 10.0, 0.0);
            assert!(rays.connect(outside, Vec2::splat(0.5)).is_none());
        }
        let near = Camera { near_clip: 1.0, ..cam() }.rays();
        assert!(near.connect(Vec3::new(0.0, 1.0, 3.2), Vec2::ZERO).is_none());
        assert!(near.connect(Vec3::new(0.0, 1.0, 2.8), Vec2::ZERO).is_some());
    }

    /// The direction density integrates to the film's pixel count over the directions the
    /// image sees (Monte Carlo over the unit sphere, 1 % of it).
    #[test]
    fn direction_pdf_integrates_to_the_pixel_count() {
        use crate::sampling::{Domain, Sampler};
        let rays = cam().rays();
        let mut s = Sampler::new(1, 0, Domain::LightPath, 0);
        let n = 1 << 20;
        let mut sum = 0.0f64;
        for _ in 0..n {
            let (u, v) = (s.next_f32(), s.next_f32());
            let z = 1.0 - 2.0 * u;
            let r = (1.0 - z * z).max(0.0).sqrt();
            let phi = std::f32::consts::TAU * v;
            let dir = Vec3::new(r * phi.cos(), r * phi.sin(), z);
            if rays.connect(rays.eye + dir, Vec2::ZERO).is_some() {
                sum += rays.direction_pdf(dir) as f64;
            }
        }
        let integral = sum * 4.0 * std::f64::consts::PI / n as f64;
        assert!((integral / (200.0 * 100.0) - 1.0).abs() < 0.01, "{integral}");
    }

    /// The lens points of a pixel's camera samples (the sampler's second dimension, as the
    /// render driver draws it) are uniform over the aperture: equal counts in 32 cells of
    /// equal area (4 rings × 8 sectors), within 5 standard deviations.
    #[test]
    fn lens_points_are_uniform_over_the_aperture() {
        use crate::sampling::{SamplerKind, Streams};
        let lens = ThinLens { aperture_radius: 0.5, focus_distance: 2.0 };
        let c = Camera { lens: Some(lens), ..cam() };
        let (rays, n) = (c.rays(), 1 << 14);
        let mut cells = [0u32; 32];
        for iteration in 1..=n {
            let streams = Streams::camera(SamplerKind::Sobol, 3, iteration);
            let mut sampler = streams.sampler(17);
            let _film = sampler.next_2d();
            let r = rays.generate_ray(Vec2::new(100.0, 50.0), sampler.next_2d());
            let p = (r.origin - c.eye) / lens.aperture_radius;
            let ring = ((p.length_squared() * 4.0) as usize).min(3);
            let sector = (((p.y.atan2(p.x) / std::f32::consts::TAU + 1.0) * 8.0) as usize) % 8;
            cells[ring * 8 + sector] += 1;
        }
        let expected = n as f64 / 32.0;
        let sd = (expected * (1.0 - 1.0 / 32.0)).sqrt();
        for (k, &count) in cells.iter().enumerate() {
            assert!((count as f64 - expected).abs() < 5.0 * sd, "cell {k}: {count} of {expected}");
        }
    }
}
