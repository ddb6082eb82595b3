//! Mitsuba 3's `mask` of a diffuse BSDF (the mask of any other BSDF is a
//! [`super::composite::Composite`]): with probability 1 − opacity light passes straight
//! through the surface (a null interaction, a delta lobe of weight 1 in either direction);
//! otherwise it meets the Lambertian surface, f · cos θi = opacity · albedo / π · cos θi.
//! The opacity is a scalar (Mitsuba evaluates the opacity texture's luminance).
//!
//! Shadow rays are blocked by masked surfaces, as in Mitsuba 3's `path` integrator: only
//! sampled paths pass through them.
