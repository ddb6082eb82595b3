//! Mitsuba 3's BSDFs made of other BSDFs: `blendbsdf` of any two and `mask` of any one (the
//! mask of a diffuse BSDF keeps its own variant, [`Bsdf::Mask`]).
//!
//! - Blend of weight w: f = (1 − w) f₀ + w f₁, pdf = (1 − w) p₀ + w p₁; a sample picks part 1
//!   with probability w, part 0 otherwise, and samples it.
//! - Mask of opacity w: f = w f₁, pdf = w p₁; a sample passes straight through the surface
//!   (a null interaction: a delta lobe of weight 1, `wi = −wo`) with probability 1 − w,
//!   otherwise samples the nested BSDF. Both are the blend with a null part 0.
//!
//! w may be a texture (a number: Mitsuba's `eval_1`, clamped to [0, 1]) and so may the parts'
//! own parameters. [`Bsdf`] stays `Copy`: [`Bsdf::Composite`] holds the parts by a shared
//! reference ([`Composite::intern`]) and the texture coordinates at which to resolve them
//! ([`Part::at`]), which [`super::Textured::apply`] sets.
//!
//! A non-delta sample has the mixed pdf and the weight mixed f / mixed pdf (what the
//! public [`Bsdf::eval`] and [`Bsdf::pdf`] give, as every non-delta sample in pir); a delta
//! sample of part i has the part's weight and its probability times the part's share.
//! (Mitsuba 3.9.1's blend mixes a delta sample's discrete probability with the other part's
//! density at that direction, which pir does not copy; its images agree where the parts are
//! both non-delta or both delta.)

use std::sync::{Arc, Mutex, OnceLock};

use glam::{Vec2, Vec3};

use super::{Bsdf, BsdfSample, LocalGeometry, PreparedBsdf, Textured, TransportMode, finite_sample};
use crate::sampling::reuse::choose;

/// A nested BSDF with its textures (`None` for a constant one).
#[derive(Clone, PartialEq)]
pub struct Part {
    pub bsdf: Bsdf,
    pub textures: Option<Arc<Textured>>,
}

impl Part {
    /// The BSDF at texture coordinates `uv`, or with its textures at their means (`None`).
    #[inline]
    pub fn at(&self, uv: Option<Vec2>) -> Bsdf {
        match (&self.textures, uv) {
            (None, _) => self.bsdf,
            (Some(t), Some(uv)) => t.apply(self.bsdf, uv),
            (Some(t), None) => t.apply_mean(self.bsdf),
        }
    }
}

/// What a [`Bsdf::Composite`] is made of.
#[derive(Clone, PartialEq)]
pub enum Composite {
    /// `blendbsdf`: the first part weighted 1 − w, the second w.
    Blend([Part; 2]),
    /// `mask`: the nested BSDF weighted w (the opacity), a null interaction otherwise.
    Mask(Part),
}

/// The Debug form names the parts and the slots of their textures (not their texels): it is
/// part of the scene fingerprint's material line, which hashes the textures separately
/// ([`Composite::hash_textures`]).
impl std::fmt::Debug for Composite {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let part = |p: &Part| {
            let slots: Vec<&str> =
                p.textures.iter().flat_map(|t| t.slots.iter().map(|(s, _)| s.name())).collect();
            format!("{:?} textured {slots:?}", p.bsdf)
        };
        match self {
            Composite::Blend([a, b]) => write!(f, "Blend({}, {})", part(a), part(b)),
            Composite::Mask(p) => write!(f, "Mask({})", part(p)),
        }
    }
}

impl Composite {
    /// The one shared copy of a composite equal to `self`, kept for the program's life (as
    /// the rough plastic's tables are): [`Bsdf`] is `Copy` and refers to it.
    pub fn intern(self) -> &'static Composite {
        static ALL: OnceLock<Mutex<Vec<&'static Composite>>> = OnceLock::new();
        let mut all = ALL.get_or_init(Default::default).lock().unwrap_or_else(|e| e.into_inner());
        if let Some(c) = all.iter().find(|c| ***c == self) {
            return c;
        }
        let c: &'static Composite = Box::leak(Box::new(self));
        all.push(c);
        c
    }

    /// The nested parts' untextured BSDFs (for what their textures do not change: which lobes
    /// they have).
    fn bsdfs(&self) -> impl Iterator<Item = &Bsdf> {
        let parts: &[Part] = match self {
            Composite::Blend(parts) => parts,
            Composite::Mask(part) => std::slice::from_ref(part),
        };
        parts.iter().map(|p| &p.bsdf)
    }

    /// The two parts at `uv` with their shares for weight `w`; `None` is the mask's null part.
    #[inline]
    pub fn parts(&self, w: f32, uv: Option<Vec2>) -> [(f32, Option<Bsdf>); 2] {
        let w = w.clamp(0.0, 1.0);
        match self {
            Composite::Blend([a, b]) => [(1.0 - w, Some(a.at(uv))), (w, Some(b.at(uv)))],
            Composite::Mask(inner) => [(1.0 - w, None), (w, Some(inner.at(uv)))],
        }
    }

    /// Whether every lobe is a delta one (the mask's null lobe is).
    pub fn is_delta(&self) -> bool {
        self.bsdfs().all(Bsdf::is_delta)
    }

    /// Whether some lobe is a delta one.
    pub fn has_delta(&self) -> bool {
        matches!(self, Composite::Mask(_)) || self.bsdfs().any(Bsdf::has_delta)
    }

    /// Whether a non-delta lobe transmits ([`Bsdf::transmits`]).
    pub fn transmits(&self) -> bool {
        self.bsdfs().any(Bsdf::transmits)
    }

    /// Feeds the parts' textures to `put` (the scene fingerprint).
    pub fn hash_textures(&self, put: &mut dyn FnMut(&[u8])) {
        let parts: &[Part] = match self {
            Composite::Blend(parts) => parts,
            Composite::Mask(part) => std::slice::from_ref(part),
        };
        for p in parts {
            if let Bsdf::Composite { parts, .. } = p.bsdf {
                parts.hash_textures(put);
            }
            for (slot, texture) in p.textures.iter().flat_map(|t| t.slots.iter()) {
                put(slot.name().as_bytes());
                texture.hash_into(put);
            }
        }
    }
}

/// f · |cos θi| and (where `with_pdf`, else 0) the pdf of a composite of weight `w` at `uv`:
/// the parts' public values, mixed by their shares.
pub(super) fn eval_pdf(
    c: &Composite,
    (w, uv): (f32, Option<Vec2>),
    g: &LocalGeometry,
    wo: Vec3,
    wi: Vec3,
    mode: TransportMode,
    with_pdf: bool,
) -> (Vec3, f32) {
    let (mut f, mut pdf) = (Vec3::ZERO, 0.0);
    for (share, part) in c.parts(w, uv) {
        if let Some(b) = part
            && share > 0.0
        {
            let prepared = PreparedBsdf::new(b, *g, wo, mode);
            let (fp, pp) = if with_pdf { prepared.eval_pdf(wi) } else { (prepared.eval(wi), 0.0) };
            f += share * fp;
            pdf += share * pp;
        }
    }
    (f, pdf)
}

/// Samples a composite: `u_lobe` picks the part (and, rescaled, goes on to it), the part
/// samples with `u`.
pub(super) fn sample(
    c: &Composite,
    (w, uv): (f32, Option<Vec2>),
    g: &LocalGeometry,
    wo: Vec3,
    u_lobe: f32,
    u: Vec2,
    mode: TransportMode,
) -> Option<BsdfSample> {
    let parts = c.parts(w, uv);
    let (first, u_lobe) = choose(u_lobe as f64, parts[0].0);
    let (share, part) = parts[usize::from(!first)];
    let Some(bsdf) = part else {
        // The mask's null interaction: straight on, unchanged.
        return finite_sample(-wo, Vec3::ONE, share, true, 1.0);
    };
    let s = bsdf.sample(g, wo, u_lobe, u, mode)?;
    if s.delta {
        return finite_sample(s.wi, s.weight, s.pdf * share, true, s.eta);
    }
    // (`finite_sample` refuses a zero pdf.)
    let (f, pdf) = eval_pdf(c, (w, uv), g, wo, s.wi, mode, true);
    finite_sample(s.wi, f / pdf, pdf, false, s.eta)
}

/// The reflectance ρ̄ ([`Bsdf::reflectance`]): the parts' mixed by their shares.
pub(super) fn reflectance(c: &Composite, w: f32, uv: Option<Vec2>) -> Vec3 {
    c.parts(w, uv).iter().filter_map(|(share, b)| b.map(|b| *share * b.reflectance())).sum()
}

/// The narrowest α of the parts' microfacet lobes ([`Bsdf::glossy_alpha`]).
pub(super) fn glossy_alpha(c: &Composite, w: f32, uv: Option<Vec2>) -> Option<f32> {
    c.parts(w, uv).iter().filter_map(|(_, b)| b.and_then(|b| b.glossy_alpha())).reduce(f32::min)
}

/// The widest α of the parts' non-delta lobes where each is a microfacet lobe
/// ([`Bsdf::widest_alpha`]): the mask's null part and delta parts have none, a part with a
/// lobe of another kind makes it `None`, and so does a composite of delta parts alone.
pub(super) fn widest_alpha(c: &Composite, w: f32, uv: Option<Vec2>) -> Option<f32> {
    let mut widest: Option<f32> = None;
    for (share, b) in c.parts(w, uv) {
        match b {
            Some(b) if share > 0.0 && !b.is_delta() => {
                let a = b.widest_alpha()?;
                widest = Some(widest.map_or(a, |w| w.max(a)));
            }
            _ => {}
        }
    }
    widest
}

/// Whether light from `w` can leave by a non-delta lobe of some part ([`Bsdf::reflects_from`]).
pub(super) fn reflects_from(
    c: &Composite,
    weight: f32,
    uv: Option<Vec2>,
    g: &LocalGeometry,
    w: Vec3,
) -> bool {
    c.parts(weight, uv).iter().any(|(share, b)| *share > 0.0 && b.is_some_and(|b| b.reflects_from(g, w)))
}
