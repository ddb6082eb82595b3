//! Closest-hit and any-hit traversal of the 8-wide tree.
//!
//! At a node the ray is tested against all eight child boxes at once. One hit child is entered
//! directly; with several, they are sorted by entry distance, the nearest is entered and the
//! others are pushed (farthest first) with their entry distance, which closest-hit checks again
//! when it pops them: anything starting beyond the closest hit so far is skipped. Any-hit,
//! which stops at the first hit, sorts two hit children the same way (and by exit distance
//! where their entries are equal) but three or more by exit distance: the box the ray leaves
//! first is entered first (below).
//!
//! **Any-hit's order.** Large, overlapping boxes (those of wall-, floor- and table-sized
//! triangles, as in the conference room) are crossed by many rays from near their start to far
//! along them; entered first by nearest entry, they cost much and rarely hold the occluder.
//! Ranking three or more hit children by exit distance puts the boxes the ray leaves soonest
//! first and the long crossings last. Two hit children keep the nearest-entry order, and at
//! equal entries (both boxes hold the ray's origin, so both entries are `tmin`: a gather point
//! in open space lies inside many of the upper levels' boxes) go by exit distance.
//!
//! **Ranks, not a sort.** Each of three or more hit children goes straight to its slot: its
//! rank is the number of hit children farther than it, or as far and in an earlier lane (its
//! distance compared with all lanes both ways by the box test's 8-wide mask, and a popcount),
//! which gives a sort's order without a branch per comparison ([`push_sorted`]). Two hit
//! children take one comparison.
//!
//! **Versions picked at run time.** The default build targets plain x86-64 (SSE2), where eight
//! lanes take two 4-wide operations. The two entry points are therefore compiled more than
//! once with the `multiversion` crate: for AVX2 + FMA, and for AVX-512 (only on CPUs with Ice
//! Lake's set of AVX-512 extensions or more, leaving out the older server CPUs that slow down
//! under it; its 32 vector registers keep the ray's splatted origin and inverse direction out of
//! the stack); the version the CPU supports is picked at run time (safe code; the choice is
//! cached). The box test is written as plain loops over `[f32; 8]` lanes, which LLVM turns
//! into one `ymm` operation per plane in the AVX versions, except the lanes' mask, which they
//! take from one 8-wide comparison ([`mask_avx`], an intrinsic called where AVX is enabled):
//! with the mask made from two 4-lane halves, as the SSE2 version does, LLVM also computed the
//! exit distances in halves. What the versions do differently is listed at [`Isa`]. All
//! versions give identical hits: their arithmetic is the same IEEE operations (Rust never fuses
//! a multiply and an add on its own), their integer minima and maxima give the same entries
//! and masks but for boxes behind the ray ([`RayBoxes::enter`]), and [`hit_pair_avx`] the
//! lanes of two [`Tri4::hit`]s. The AVX versions also prefetch the children they push, on
//! trees larger than a core's L2 cache: traversal mostly waits on node and leaf loads, and a
//! deferred child is usually visited later (always by any-hit); on a tiny scene prefetching
//! costs more than it saves, hence the size threshold.
//!
//! **The slab test** picks each axis' near and far planes from the direction's sign, as an
//! index (`bounds[axis][negative]`, the minima and maxima of an axis being adjacent arrays)
//! rather than a select of two addresses per axis and node. The inverse direction is kept
//! finite (±`f32::MAX` for a zero component, whose `1 / ±0` is ±∞), so no plane distance is
//! the NaN of `0 · ∞`: a ray parallel to a slab gets the distances (plane − origin) ·
//! `f32::MAX` from its planes, 0 for a plane it lies in and of the order of `f32::MAX` times
//! its gap to the others, which leave its interval alone when it lies within the slab and
//! empty it when it lies outside; in a face plane it counts as inside when its zero's sign
//! points into the box. What makes this safe is the boxes' padding (at least
//! `f32::MIN_POSITIVE` plus 1e-5 of the coordinate): no triangle reaches its box's faces, and a
//! parallel ray just inside a face gets an exit distance far beyond any scene. With no NaN,
//! each lane's entry and exit are a tree of maxima and minima over the three axes, two
//! operations deep, and the mask a comparison of the two, which keeps the chain of dependent
//! operations from a node's load to its child's short. The far planes' distances are widened
//! by a few ulps (Ize 2013, their inverse multiplied by [`EXIT_SCALE`] once per ray) so
//! rounding cannot cull a box the exact ray touches.
//!
//! Batches (`occluded_batch`, which the renderer's gathers call) are traced ray by ray, with
//! the tree's arrays borrowed once per batch. The traversal waits on loads and on the
//! node-to-node chain more than on instruction throughput: changes that only cut instructions
//! have rarely bought time here.
//!
//! Measurements of these choices, and of the alternatives tried and not kept (Embree's lane
//! order, leaf children first, packets, interleaved rays, an occluder cache, octant-ordered
//! lanes, fused slab tests, quantised nodes and others): `docs/accel/traversal.md`.

use glam::Vec4;
use multiversion::multiversion;
use multiversion::target::match_target;

use super::Bvh;
use super::build::MAX_DEPTH;
#[cfg(all(target_arch = "x86_64", not(target_feature = "avx2")))]
use super::leaf::hit_pair_avx;
use super::leaf::{Hits8, Ray4, Tri4};
use super::wide::{ChildRef, Node8, WIDTH};
use crate::accel::Hit;
use crate::geometry::Ray;

/// Widening of the exit distance: 1 + 2γ₃ rounded up generously.
const EXIT_SCALE: f32 = 1.0 + 1e-6;
/// Stack entries of the fast path. Each wide level pushes at most `WIDTH − 1` children, but a
/// ray rarely enters more than two or three boxes of a node, so a tree over millions of
/// triangles needs far fewer than the worst case; the stack is kept small because it is
/// initialised for every ray (a larger one was no faster: `docs/accel/traversal.md`).
const STACK: usize = 32;
/// Stack entries that no tree can exceed: the binary depth bounds the wide depth. A ray that
/// would overflow the fast path's stack is traced again with this one.
const STACK_MAX: usize = (WIDTH - 1) * MAX_DEPTH + WIDTH;

/// The fast path's stack would overflow.
struct Overflow;

/// A ray prepared for box tests: origin, inverse direction (finite: see [`RayBoxes::new`]),
/// the far planes' inverse widened by [`EXIT_SCALE`], and direction signs.
struct RayBoxes {
    o: [f32; 3],
    inv: [f32; 3],
    inv_far: [f32; 3],
    neg: [bool; 3],
    tmin: f32,
}

/// `a` if it is larger, else `b` (`maxps`, which the lanes compile to; no NaN reaches it).
#[inline(always)]
fn max(a: f32, b: f32) -> f32 {
    if a > b { a } else { b }
}

/// `a` if it is smaller, else `b` (`minps`).
#[inline(always)]
fn min(a: f32, b: f32) -> f32 {
    if a < b { a } else { b }
}

impl RayBoxes {
    /// The inverse direction is kept finite, ±`f32::MAX` for a zero component (`1 / ±0 =
    /// ±∞`), so that no plane distance is `0 · ∞ = NaN` (see the module docs); and non-zero:
    /// under flush-to-zero, which rendering threads set, a component beyond 2¹²⁶ has a
    /// subnormal inverse, flushed to ±0, and the empty lanes' infinite planes would then give
    /// `∞ · 0` (with all three components that large, the float version entered the empty
    /// lanes, whose child is the root). Such an inverse becomes ±`f32::MIN_POSITIVE`, the
    /// nearest value flush-to-zero can hold: that axis' distances come out up to four times the
    /// exact ones (the exact inverse is at least 2⁻¹²⁸), which is not conservative (a box the
    /// ray enters could in principle be culled), on rays whose triangle tests are at the edge of
    /// `f32`'s range anyway. A `tmin` of −0 becomes +0 (`−0 + 0 = +0`), whose
    /// bits are the smallest of any `f32` at least 0: the entry distances' integer maxima in
    /// [`RayBoxes::enter`] need that.
    #[inline]
    fn new(ray: &Ray) -> Self {
        let inv = (1.0 / ray.dir).to_array().map(|i| {
            // (`== 0.0` is also true of a subnormal under denormals-are-zero.)
            if i == 0.0 { f32::MIN_POSITIVE.copysign(i) } else { i.clamp(-f32::MAX, f32::MAX) }
        });
        RayBoxes {
            o: ray.origin.to_array(),
            inv,
            inv_far: inv.map(|i| (i * EXIT_SCALE).clamp(-f32::MAX, f32::MAX)),
            neg: [ray.dir.x.is_sign_negative(), ray.dir.y.is_sign_negative(), ray.dir.z.is_sign_negative()],
            tmin: ray.tmin + 0.0,
        }
    }

    /// Which of `n`'s boxes the ray enters within `(tmin, tmax)` (bit per lane), and the entry
    /// and exit distances. Plain loops over the lanes, which LLVM turns into one vector
    /// operation per plane (two SSE or one AVX operation for eight lanes); the three axes'
    /// distances are combined as a tree of minima and maxima, two deep, since the node-to-node
    /// chain of dependent operations is what a traversal waits on.
    ///
    /// With `integer_minmax` (the AVX2 and AVX-512 versions) the minima and maxima are taken
    /// of the distances' bits as `i32` (`vpminsd`, one cycle, against two or more for `vminps`;
    /// Embree does the same). For floats at least +0 the order of their bits is theirs, and
    /// every entry includes `tmin`, made +0 or more, which the float maxima return over a
    /// candidate −0: the entries are the float test's, bit for bit. Among negative floats the
    /// order of the bits is reversed, and −0 is the least `i32` of all, so an exit with a
    /// negative or −0 candidate comes out as some negative float or −0 instead of the most
    /// negative: a box that the float test culls as behind the ray may then be entered when
    /// its entry is +0 (the ray leaves it through a face its origin lies on, exit −0). Nothing
    /// in such a box lies in `(tmin, tmax)`. On the lanes both enter, the exits are equal as
    /// floats (a zero's sign may differ). So any-hit's order may differ, never an answer, and
    /// hits stay those of the float test, bit for bit (`box_test_versions_agree`,
    /// `all_versions_agree`).
    #[inline(always)]
    fn enter(
        &self,
        n: &Node8,
        tmax: f32,
        isa: &Isa<impl Prefetch, impl LaneMask, impl PairTest>,
    ) -> (u32, [f32; WIDTH], [f32; WIDTH]) {
        let mut t0 = [[0.0; WIDTH]; 3];
        let mut t1 = [[0.0; WIDTH]; 3];
        for a in 0..3 {
            let (near, far) =
                (&n.bounds[a][usize::from(self.neg[a])], &n.bounds[a][usize::from(!self.neg[a])]);
            for l in 0..WIDTH {
                t0[a][l] = (near[l] - self.o[a]) * self.inv[a];
                t1[a][l] = (far[l] - self.o[a]) * self.inv_far[a];
            }
        }
        let tmax = tmax * EXIT_SCALE;
        let mut entry = [0.0; WIDTH];
        let mut exit = [0.0; WIDTH];
        if isa.integer_minmax {
            let (b, f) = (|x: f32| x.to_bits() as i32, |x: i32| f32::from_bits(x as u32));
            for l in 0..WIDTH {
                entry[l] = f(b(t0[0][l]).max(b(t0[1][l])).max(b(t0[2][l]).max(b(self.tmin))));
                exit[l] = f(b(t1[0][l]).min(b(t1[1][l])).min(b(t1[2][l]).min(b(tmax))));
            }
        } else {
            for l in 0..WIDTH {
                entry[l] = max(max(t0[0][l], t0[1][l]), max(t0[2][l], self.tmin));
                exit[l] = min(min(t1[0][l], t1[1][l]), min(t1[2][l], tmax));
            }
        }
        ((isa.mask)(&entry, &exit), entry, exit)
    }
}

/// Pushes all hit children of `n` (lanes in `mask`, at least two) on the stack with their entry
/// distances, the child to visit last first, and returns the one to visit first, which is not
/// pushed. Two children go by `entry`, the nearer first, and at the same entry by `order`;
/// three or more by `order`, its least first. Closest-hit passes the entry distances (nearest
/// first), any-hit the exit distances (the box the ray leaves first, first: see the module
/// docs).
#[inline(always)]
fn push_sorted<const N: usize>(
    isa: &Isa<impl Prefetch, impl LaneMask, impl PairTest>,
    n: &Node8,
    mut mask: u32,
    entry: &[f32; WIDTH],
    order: &[f32; WIDTH],
    stack: &mut [(ChildRef, f32); N],
    sp: &mut usize,
) -> ChildRef {
    // Two children, the most common case after one: a comparison (ties of both keys as below).
    let first = mask.trailing_zeros() as usize;
    let rest = mask & (mask - 1);
    if rest & (rest - 1) == 0 {
        let second = rest.trailing_zeros() as usize;
        let first_nearer =
            entry[first] < entry[second] || (entry[first] == entry[second] && order[first] < order[second]);
        let (near, far) = if first_nearer { (first, second) } else { (second, first) };
        stack[*sp] = (n.child[far], entry[far]);
        (isa.prefetch)(n.child[far]);
        *sp += 1;
        return n.child[near];
    }
    // Three or more: each hit child goes straight to its place, the greatest `order` first,
    // its rank the number of hit children that come before it (a greater `order`, or as great
    // and in an earlier lane): no data-dependent loop, whose exits a branch predictor misses.
    // The box test's mask compares the key with all lanes, both ways (no distance is NaN): the
    // lanes at least as great (`ge`) and at most as great (`le`); greater is `ge` but not `le`.
    let all = mask;
    let k = all.count_ones() as usize;
    while mask != 0 {
        let lane = mask.trailing_zeros() as usize;
        mask &= mask - 1;
        let o = order[lane];
        let ge = (isa.mask)(&[o; WIDTH], order);
        let le = (isa.mask)(order, &[o; WIDTH]);
        let before = (1u32 << lane) - 1;
        let rank = (all & ge & (!le | before)).count_ones() as usize;
        stack[*sp + rank] = (n.child[lane], entry[lane]);
    }
    for &(c, _) in &stack[*sp..*sp + k - 1] {
        (isa.prefetch)(c);
    }
    *sp += k - 1;
    stack[*sp].0
}

/// What the traversal's versions (see [`closest_hit_dispatch`]) do differently:
/// - `prefetch` a deferred child ([`prefetch_child`] in the AVX2 and AVX-512 versions, nothing
///   otherwise);
/// - make the `mask` of the lanes whose first distances are at most the second ([`mask_avx`] or
///   [`mask_sse`]: the box test's entry against exit, and the ranks of [`push_sorted`]);
/// - test both packs of a two-pack leaf (`pair`: [`hit_pair_avx`], eight lanes per operation,
///   or [`pair_sse`], two four-lane tests with the same `tmax`, as the eight lanes have: on
///   CPUs without AVX2, and in builds whose target has it, see [`prefetch_child`]);
/// - combine a box's plane distances with `integer_minmax` (see [`RayBoxes::enter`]).
struct Isa<P, M, H> {
    prefetch: P,
    mask: M,
    pair: H,
    integer_minmax: bool,
}

/// [`Isa::prefetch`]'s signature.
trait Prefetch: Fn(ChildRef) {}
impl<F: Fn(ChildRef)> Prefetch for F {}
/// [`Isa::mask`]'s signature.
trait LaneMask: Fn(&[f32; WIDTH], &[f32; WIDTH]) -> u32 {}
impl<F: Fn(&[f32; WIDTH], &[f32; WIDTH]) -> u32> LaneMask for F {}
/// [`Isa::pair`]'s signature: two packs, the ray, `tmin`, `tmax`.
trait PairTest: Fn(&Tri4, &Tri4, &Ray4, f32, f32) -> Hits8 {}
impl<F: Fn(&Tri4, &Tri4, &Ray4, f32, f32) -> Hits8> PairTest for F {}

/// A two-pack leaf's test as two [`Tri4::hit`]s.
#[inline(always)]
fn pair_sse(p: &Tri4, q: &Tri4, r: &Ray4, tmin: f32, tmax: f32) -> Hits8 {
    Hits8::from_halves(p.hit(r, tmin, tmax), q.hit(r, tmin, tmax))
}

impl Isa<fn(ChildRef), fn(&[f32; WIDTH], &[f32; WIDTH]) -> u32, fn(&Tri4, &Tri4, &Ray4, f32, f32) -> Hits8> {
    /// The version for the build's target, which the tests compare the dispatched one with.
    #[cfg(test)]
    const BASELINE: Self = Isa { prefetch: |_| {}, mask: mask_sse, pair: pair_sse, integer_minmax: false };
}

/// Bit `l` set where `entry[l] <= exit[l]`, four lanes at a time with glam's `bitmask`
/// (`movmskps`): LLVM does not turn a loop of per-lane bits into a mask instruction.
#[inline(always)]
fn mask_sse(entry: &[f32; WIDTH], exit: &[f32; WIDTH]) -> u32 {
    let mut mask = 0;
    for k in 0..WIDTH / 4 {
        let (e, x) = (Vec4::from_slice(&entry[4 * k..]), Vec4::from_slice(&exit[4 * k..]));
        mask |= e.cmple(x).bitmask() << (4 * k);
    }
    mask
}

/// [`mask_sse`] on all eight lanes at once (`vcmpps`, `vmovmskps` on `ymm`), for the AVX2
/// version. Besides saving the second comparison, it lets LLVM keep the exit distances in one
/// `ymm` register per step: with the 4-lane mask it computed them as two halves, a dozen
/// instructions more per node. The intrinsics are safe to call here, where AVX is enabled.
#[cfg(target_arch = "x86_64")]
#[cfg_attr(target_feature = "avx2", allow(dead_code))]
#[target_feature(enable = "avx")]
#[inline]
fn mask_avx(entry: &[f32; WIDTH], exit: &[f32; WIDTH]) -> u32 {
    use std::arch::x86_64::{__m256, _CMP_LE_OQ, _mm256_cmp_ps, _mm256_movemask_ps};
    let (e, x): (__m256, __m256) = (bytemuck::cast(*entry), bytemuck::cast(*exit));
    _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LE_OQ>(e, x)) as u32
}

/// Prefetches the node or the triangle packs of a deferred child (four cache lines: a node, or
/// a leaf's first pack and a half) on trees large enough to profit (`Bvh::prefetch`). Called
/// from the AVX2 and AVX-512 versions only, where it was measured to pay; the intrinsic, and so
/// this function, is safe to call only where the target features are enabled, as in those
/// versions.
///
/// A build whose own target already has AVX2 (`RUSTFLAGS="-C target-cpu=native"` on such a
/// CPU) does not prefetch: `multiversion` then compiles its baseline version without a
/// `#[target_feature]` context, from which the intrinsic cannot be called in safe code, and the
/// `cfg` that keeps the call out of it applies to every version of that build (its AVX2 and
/// AVX-512 versions also take the 4-lane mask and test a two-pack leaf as two 4-lane tests
/// with [`pair_sse`] instead of one 8-lane test, at a cost not measured).
#[cfg(target_arch = "x86_64")]
#[cfg_attr(target_feature = "avx2", allow(dead_code))]
#[target_feature(enable = "sse")]
#[inline]
fn prefetch_child(v: View, c: ChildRef) {
    use std::arch::x86_64::{_MM_HINT_T0, _mm_prefetch};
    if !v.prefetch {
        return;
    }
    let p = if c.is_leaf() {
        v.packs.as_ptr().wrapping_add(c.index as usize).cast::<i8>()
    } else {
        v.nodes.as_ptr().wrapping_add(c.index as usize).cast::<i8>()
    };
    // Four lines either way: a fixed count unrolls into four instructions without a loop
    // branch, and a leaf's second pack starts at byte 160, in its third line. (Two lines more
    // for a two-pack leaf, all of its 320 bytes, were no faster: `docs/accel/traversal.md`.)
    _mm_prefetch::<_MM_HINT_T0>(p);
    _mm_prefetch::<_MM_HINT_T0>(p.wrapping_add(64));
    _mm_prefetch::<_MM_HINT_T0>(p.wrapping_add(128));
    _mm_prefetch::<_MM_HINT_T0>(p.wrapping_add(192));
}

/// The [`Isa`] of the version it is expanded in (inside a `#[multiversion]` function, whose
/// `match_target!` it uses): the AVX2 and AVX-512 versions prefetch deferred children of `$v`,
/// take the mask from one 8-wide comparison, test two-pack leaves eight lanes at once and take
/// the box test's minima and maxima as integers.
macro_rules! isa {
    ($v:ident) => {
        match_target! {
            "x86_64+avx2" => Isa {
                prefetch: |c: ChildRef| {
                    #[cfg(not(target_feature = "avx2"))]
                    prefetch_child($v, c);
                    #[cfg(target_feature = "avx2")]
                    let _ = ($v, c);
                },
                mask: |e: &[f32; WIDTH], x: &[f32; WIDTH]| {
                    #[cfg(not(target_feature = "avx2"))]
                    return mask_avx(e, x);
                    #[cfg(target_feature = "avx2")]
                    mask_sse(e, x)
                },
                pair: |p: &Tri4, q: &Tri4, r: &Ray4, tmin: f32, tmax: f32| {
                    #[cfg(not(target_feature = "avx2"))]
                    return hit_pair_avx(p, q, r, tmin, tmax);
                    #[cfg(target_feature = "avx2")]
                    pair_sse(p, q, r, tmin, tmax)
                },
                integer_minmax: true,
            },
            _ => Isa { prefetch: |_: ChildRef| {}, mask: mask_sse, pair: pair_sse, integer_minmax: false },
        }
    };
}

/// The function given, compiled as the traversal's versions (see [`closest_hit_dispatch`]):
/// for AVX-512, for AVX2 and for the build's target, the version picked at run time. The one
/// list of those versions, for the entry points and for the tests' calls into them.
macro_rules! versions {
    ($($item:tt)*) => {
        #[multiversion(targets(
            "x86_64+avx512f+avx512bw+avx512vl+avx512dq+avx2+fma+bmi1+bmi2+lzcnt+popcnt",
            "x86_64+avx2+fma+bmi1+bmi2+lzcnt+popcnt"
        ))]
        $($item)*
    };
}

versions! {
    /// [`Bvh::closest_hit`], compiled for AVX-512 and AVX2 as well as for the build's target and
    /// picked at run time by the CPU's features (see the module docs); the versions differ in their
    /// [`Isa`] (the AVX-512 version takes the AVX2 one's). `multiversion` adds Ice Lake's AVX-512
    /// extensions (VBMI, VNNI, GFNI and others) to the features listed for the AVX-512 version, so
    /// older AVX-512 CPUs, which slow down under it, get the AVX2 version. Both list the scalar bit
    /// instructions of x86-64-v3 (BMI1, BMI2, LZCNT, POPCNT), which every AVX2 CPU has: without
    /// them `count_ones` in [`push_sorted`] compiled to a sequence of five instructions, two of
    /// them multiplications, instead of `popcnt`.
    fn closest_hit_dispatch(v: View, ray: &Ray) -> Option<Hit> {
        let isa = isa!(v);
        match v.closest_hit_with::<STACK>(ray, &isa) {
            Ok(hit) => hit,
            Err(Overflow) => v.closest_hit_with::<STACK_MAX>(ray, &isa).ok().flatten(),
        }
    }
}

versions! {
    /// [`Bvh::any_hit`], compiled as [`closest_hit_dispatch`] is.
    fn any_hit_dispatch(v: View, ray: &Ray) -> bool {
        let isa = isa!(v);
        match v.any_hit_with::<STACK>(ray, &isa) {
            Ok(hit) => hit,
            Err(Overflow) => v.any_hit_with::<STACK_MAX>(ray, &isa).unwrap_or(true),
        }
    }
}

/// The arrays a traversal reads, borrowed from the [`Bvh`] once per query or batch of
/// queries: viewing a [`Pages`](super::pages::Pages) array as a slice checks its mapping's
/// size and alignment, some thirty instructions, which per node visit, or even three times per
/// ray, showed under callgrind (6 % of an occlusion ray's instructions on the bunny).
#[derive(Clone, Copy)]
pub(super) struct View<'a> {
    nodes: &'a [Node8],
    packs: &'a [Tri4],
    prefetch: bool,
}

impl Bvh {
    /// The tree's arrays, for the queries below.
    pub(super) fn view(&self) -> View<'_> {
        View { nodes: &self.nodes, packs: &self.packs, prefetch: self.prefetch }
    }
}

impl View<'_> {
    /// The closest hit of a valid ray.
    pub(super) fn closest_hit(self, ray: &Ray) -> Option<Hit> {
        closest_hit_dispatch(self, ray)
    }

    /// Whether a valid ray hits anything.
    pub(super) fn any_hit(self, ray: &Ray) -> bool {
        any_hit_dispatch(self, ray)
    }

    /// Closest-hit traversal with an `N`-entry stack.
    #[inline(always)]
    fn closest_hit_with<const N: usize>(
        self,
        ray: &Ray,
        isa: &Isa<impl Prefetch, impl LaneMask, impl PairTest>,
    ) -> Result<Option<Hit>, Overflow> {
        let (nodes, packs) = (self.nodes, self.packs);
        let rb = RayBoxes::new(ray);
        let r4 = Ray4::new(ray.origin, ray.dir);
        let mut best: Option<Hit> = None;
        let mut tmax = ray.tmax;
        let mut stack = [(ChildRef::default(), 0f32); N];
        let mut sp = 0;
        let mut cur = ChildRef { index: 0, count: 0 };
        loop {
            if cur.is_leaf() {
                let first = cur.index as usize;
                if cur.count == 2 {
                    let (p, q) = (&packs[first], &packs[first + 1]);
                    let h = (isa.pair)(p, q, &r4, ray.tmin, tmax);
                    if h.mask != 0 {
                        let lane = h.nearest();
                        tmax = h.t[lane];
                        let prim = if lane < 4 { p.id[lane] } else { q.id[lane - 4] };
                        best = Some(Hit { t: tmax, prim, u: h.u[lane], v: h.v[lane] });
                    }
                } else {
                    for pack in &packs[first..first + cur.count as usize] {
                        let h = pack.hit(&r4, ray.tmin, tmax);
                        if h.mask != 0 {
                            let lane = h.nearest();
                            tmax = h.t[lane];
                            best = Some(Hit { t: tmax, prim: pack.id[lane], u: h.u[lane], v: h.v[lane] });
                        }
                    }
                }
            } else {
                let n = &nodes[cur.index as usize];
                let (mask, entry, _) = rb.enter(n, tmax, isa);
                if mask != 0 {
                    cur = if mask & (mask - 1) == 0 {
                        n.child[mask.trailing_zeros() as usize]
                    } else if sp + WIDTH > N {
                        return Err(Overflow);
                    } else {
                        push_sorted(isa, n, mask, &entry, &entry, &mut stack, &mut sp)
                    };
                    continue;
                }
            }
            // Pop the next child that starts before the closest hit.
            loop {
                if sp == 0 {
                    return Ok(best);
                }
                sp -= 1;
                let (c, t) = stack[sp];
                if t <= tmax * EXIT_SCALE {
                    cur = c;
                    break;
                }
            }
        }
    }

    /// Any-hit traversal with an `N`-entry stack.
    #[inline(always)]
    fn any_hit_with<const N: usize>(
        self,
        ray: &Ray,
        isa: &Isa<impl Prefetch, impl LaneMask, impl PairTest>,
    ) -> Result<bool, Overflow> {
        let (nodes, packs) = (self.nodes, self.packs);
        let rb = RayBoxes::new(ray);
        let r4 = Ray4::new(ray.origin, ray.dir);
        let tmax = ray.tmax;
        let mut stack = [(ChildRef::default(), 0f32); N];
        let mut sp = 0;
        let mut cur = ChildRef { index: 0, count: 0 };
        loop {
            if cur.is_leaf() {
                let first = cur.index as usize;
                if cur.count == 2 {
                    if (isa.pair)(&packs[first], &packs[first + 1], &r4, ray.tmin, tmax).mask != 0 {
                        return Ok(true);
                    }
                } else {
                    for pack in &packs[first..first + cur.count as usize] {
                        if pack.hit(&r4, ray.tmin, tmax).mask != 0 {
                            return Ok(true);
                        }
                    }
                }
            } else {
                let n = &nodes[cur.index as usize];
                let (mask, entry, exit) = rb.enter(n, tmax, isa);
                if mask != 0 {
                    cur = if mask & (mask - 1) == 0 {
                        n.child[mask.trailing_zeros() as usize]
                    } else if sp + WIDTH > N {
                        return Err(Overflow);
                    } else {
                        push_sorted(isa, n, mask, &entry, &exit, &mut stack, &mut sp)
                    };
                    continue;
                }
            }
            if sp == 0 {
                return Ok(false);
            }
            sp -= 1;
            cur = stack[sp].0;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::accel::testmesh;
    use glam::Vec3;

    /// A zero direction component makes no NaN: a ray parallel to a slab enters the box when
    /// it lies strictly within the slab, whichever the zero's sign, and not when it lies
    /// outside it; in a face plane (`0 · ∞`) it counts as inside when the zero's sign points
    /// into the box (+0 on the minimum's face, −0 on the maximum's), which padded boxes make
    /// safe (no triangle reaches its box's faces). Empty lanes are never entered. The build's
    /// version and the dispatched one agree.
    #[test]
    fn slab_test_handles_zero_direction_components() {
        let mut n = Node8::EMPTY;
        for a in 0..3 {
            n.bounds[a][0][0] = 0.0;
            n.bounds[a][1][0] = 1.0;
        }
        let bvh = Bvh::new(&testmesh::cornell_like().positions, &testmesh::cornell_like().indices);
        let enters = |o: Vec3, d: Vec3| {
            let rb = RayBoxes::new(&Ray::new(o, d));
            let mask = rb.enter(&n, f32::INFINITY, &Isa::BASELINE).0;
            assert_eq!(enter_dispatched(bvh.view(), &rb, &n, f32::INFINITY).0, mask, "{o} {d}");
            mask
        };
        for zero in [0.0, -0.0] {
            assert_eq!(enters(Vec3::new(0.5, 0.5, -1.0), Vec3::new(zero, zero, 1.0)), 1, "{zero}");
            assert_eq!(enters(Vec3::new(0.5, 2.0, 0.5), Vec3::new(1.0, zero, zero)), 0, "{zero}");
            assert_eq!(enters(Vec3::new(-1e-6, 0.5, -1.0), Vec3::new(zero, 0.0, 1.0)), 0, "{zero}");
            assert_eq!(enters(Vec3::new(0.5, 0.5, 2.0), Vec3::new(zero, zero, 1.0)), 0, "behind: {zero}");
        }
        assert_eq!(enters(Vec3::new(0.0, 0.5, -1.0), Vec3::new(0.0, 0.0, 1.0)), 1, "on the minimum's face");
        assert_eq!(enters(Vec3::new(1.0, 0.5, 2.0), Vec3::new(-0.0, 0.0, -1.0)), 1, "on the maximum's face");
        assert_eq!(enters(Vec3::new(0.0, 0.0, -1.0), Vec3::Z), 1, "along an edge");
        assert_eq!(enters(Vec3::new(1.0, 1.0, 2.0), -Vec3::Z), 1, "along an edge, backwards");
        assert_eq!(enters(Vec3::new(1.0 + 1e-6, 0.5, -1.0), Vec3::Z), 0, "outside the x slab");
        assert_eq!(enters(Vec3::new(0.5, 0.5, 2.0), Vec3::Z), 0, "box behind the ray");
    }

    /// Under flush-to-zero a direction component beyond 2¹²⁶, whose inverse is subnormal, has an
    /// inverse of 0, and the empty lanes' infinite planes then gave `∞ · 0 = NaN`: with all
    /// three components that large, the float version entered the empty lanes (their child is
    /// the root, so the traversal looped until its stack overflowed and any-hit answered "hit").
    /// The BVH must answer as brute force does, in the build's version and the dispatched one.
    #[test]
    fn huge_directions_under_flush_to_zero() {
        use crate::accel::Accelerator;
        // Built here, not on the thread that sets flush-to-zero: the build may start rayon's
        // pool, whose threads would inherit the setting for the rest of the test binary.
        let m = testmesh::sphere(12, 24);
        let bvh = Bvh::new(&m.positions, &m.indices);
        let brute = crate::accel::BruteForce::new(&m.positions, &m.indices);
        std::thread::scope(|scope| {
            scope.spawn(|| {
                crate::accel::set_flush_denormals();
                #[cfg(target_arch = "x86_64")]
                assert!(crate::accel::flush_denormals_enabled());
                // (Through `black_box`, so that no inverse is computed at compile time.)
                let big = std::hint::black_box(2f32.powi(127));
                let (mut hits, mut tried) = (0, 0);
                // Origins near the unit sphere, so that the triangle test's products stay finite.
                let dirs = [Vec3::splat(big), Vec3::new(-big, big, big), Vec3::new(big, 1.0, -big)];
                for o in [
                    Vec3::ZERO,
                    Vec3::splat(0.1),
                    Vec3::splat(-1.5),
                    Vec3::new(1.5, -1.5, -1.5),
                    Vec3::new(-2.0, 0.3, 2.0),
                ] {
                    for d in dirs {
                        let r = Ray::new(o, d);
                        // (Brute force may pick another triangle at the same distance: an edge.)
                        let hit = brute.intersect(&r);
                        assert!(hit.is_none_or(|h| h.u.is_finite() && h.v.is_finite()), "{o} {d}");
                        let want = (hit.map(|h| h.t.to_bits()), brute.occluded(&r));
                        let base =
                            bvh.view().closest_hit_with::<STACK_MAX>(&r, &Isa::BASELINE).ok().flatten();
                        let base_any = bvh.view().any_hit_with::<STACK_MAX>(&r, &Isa::BASELINE).ok();
                        assert_eq!(
                            (base.map(|h| h.t.to_bits()), base_any),
                            (want.0, Some(want.1)),
                            "{o} {d}"
                        );
                        assert_eq!(
                            (bvh.view().closest_hit(&r), bvh.view().any_hit(&r)),
                            (base, want.1),
                            "{o} {d}"
                        );
                        hits += usize::from(want.1);
                        tried += 1;
                    }
                }
                assert!(hits >= 3 && hits < tried, "{hits} of {tried}");
            });
        });
    }

    versions! {
        /// [`RayBoxes::enter`] in the version the entry points dispatch to (with integer minima and
        /// maxima on a CPU with AVX2).
        fn enter_dispatched(v: View, rb: &RayBoxes, n: &Node8, tmax: f32) -> (u32, [f32; WIDTH], [f32; WIDTH]) {
            let isa = isa!(v);
            let _ = v; // (unused by the baseline version's `Isa`)
            rb.enter(n, tmax, &isa)
        }
    }

    versions! {
        /// A two-pack leaf's test in the version the entry points dispatch to ([`hit_pair_avx`] on
        /// a CPU with AVX2).
        fn pair_dispatched(v: View, p: &Tri4, q: &Tri4, r: &Ray4, tmin: f32, tmax: f32) -> Hits8 {
            let isa = isa!(v);
            let _ = v; // (unused by the baseline version's `Isa`)
            (isa.pair)(p, q, r, tmin, tmax)
        }
    }

    /// The dispatched two-pack test gives bit for bit what two [`Tri4::hit`]s give, in every
    /// lane (hit or not): random rays and axis-aligned ones against a dense sphere's triangles
    /// and degenerate, axis-aligned and unused (padding) lanes, on open and bounded intervals.
    #[test]
    fn pair_test_matches_two_pack_tests() {
        let m = testmesh::sphere(12, 24);
        let mut tris: Vec<[Vec3; 3]> = (0..m.indices.len()).map(|i| m.triangle(i)).collect();
        tris.push([Vec3::ZERO; 3]);
        tris.push([Vec3::ZERO, Vec3::X, Vec3::X * 2.0]);
        tris.push([Vec3::ZERO, Vec3::X, Vec3::Y]);
        let packs: Vec<Tri4> = tris.chunks(4).map(|c| Tri4::new(c.iter().map(|&t| (t, 0)))).collect();
        let padded = Tri4::new([([Vec3::ZERO, Vec3::X, Vec3::Y], 7)]);
        let bvh = Bvh::new(&m.positions, &m.indices);
        let mut rays = testmesh::random_rays(&m.bounds(), 300, 4);
        for d in [Vec3::X, Vec3::Y, Vec3::Z, -Vec3::X, -Vec3::Y, -Vec3::Z] {
            rays.push(Ray::new(Vec3::new(0.25, 0.25, 0.25) - d * 3.0, d));
        }
        let mut hits = 0;
        for r in &rays {
            let r4 = Ray4::new(r.origin, r.dir);
            for (p, q) in packs.iter().zip(packs.iter().skip(1).chain([&padded])) {
                for tmax in [r.tmax, 1.5] {
                    let want = pair_sse(p, q, &r4, r.tmin, tmax);
                    let got = pair_dispatched(bvh.view(), p, q, &r4, r.tmin, tmax);
                    assert_eq!(got.mask, want.mask);
                    for (g, w) in [(got.t, want.t), (got.u, want.u), (got.v, want.v)] {
                        assert_eq!(g.map(f32::to_bits), w.map(f32::to_bits));
                    }
                    hits += want.mask.count_ones();
                }
            }
        }
        assert!(hits > 100, "{hits}");
    }

    versions! {
        /// [`push_sorted`] in the version the entry points dispatch to (with [`mask_avx`] on a CPU
        /// with AVX2).
        fn push_dispatched(
            v: View,
            n: &Node8,
            mask: u32,
            entry: &[f32; WIDTH],
            order: &[f32; WIDTH],
            stack: &mut [(ChildRef, f32); 16],
            sp: &mut usize,
        ) -> ChildRef {
            let isa = isa!(v);
            let _ = v; // (unused by the baseline version's `Isa`)
            push_sorted(&isa, n, mask, entry, order, stack, sp)
        }
    }

    /// Hit children are pushed with their entry distances, the greatest key first, ties in lane
    /// order, and the least is returned; the key is the entry distance for two children (then
    /// `order` where their entries are equal) and `order` for three or more: for every set of
    /// two or more hit lanes, over distances with many ties (zeros of both signs, which compare
    /// equal, and an infinity), with `order` the entries themselves (closest-hit) and other
    /// distances (any-hit's exits), in the build's version and the dispatched one.
    #[test]
    fn push_sorted_orders_children_by_key() {
        let bvh = Bvh::new(&testmesh::cornell_like().positions, &testmesh::cornell_like().indices);
        let mut n = Node8::EMPTY;
        for (lane, c) in n.child.iter_mut().enumerate() {
            *c = ChildRef { index: 100 + lane as u32, count: 0 };
        }
        let entries: [[f32; WIDTH]; 2] =
            [[2.0, 1.0, 2.0, 0.5, 1.0, 3.0, 1.0, 0.0], [0.0, -0.0, 1.0, f32::INFINITY, 0.0, 1.0, -0.0, 1.0]];
        let pairs = [
            (&entries[0], &entries[0]),
            (&entries[1], &entries[1]),
            (&entries[0], &entries[1]),
            (&entries[1], &entries[0]),
        ];
        for (entry, order) in pairs {
            for mask in 0u32..256 {
                if mask.count_ones() < 2 {
                    continue;
                }
                // Two: by entry, then by order; three or more: by order; then by lane.
                let (first, then) = if mask.count_ones() == 2 { (entry, order) } else { (order, order) };
                let mut want: Vec<usize> = (0..WIDTH).filter(|&l| mask >> l & 1 == 1).collect();
                want.sort_by(|&a, &b| {
                    let by = |k: &[f32; WIDTH]| k[b].partial_cmp(&k[a]).unwrap();
                    by(first).then(by(then)).then(a.cmp(&b))
                });
                let isa = Isa::BASELINE;
                let baseline =
                    |stack: &mut _, sp: &mut _| push_sorted(&isa, &n, mask, entry, order, stack, sp);
                let dispatched = |stack: &mut _, sp: &mut _| {
                    push_dispatched(bvh.view(), &n, mask, entry, order, stack, sp)
                };
                for push in [&baseline as &dyn Fn(&mut _, &mut _) -> ChildRef, &dispatched] {
                    let mut stack = [(ChildRef::default(), 0f32); 16];
                    let mut sp = 3;
                    let near = push(&mut stack, &mut sp);
                    assert_eq!(sp, 3 + want.len() - 1, "{mask:08b}");
                    assert_eq!(near, n.child[*want.last().unwrap()], "{mask:08b}");
                    for (k, &lane) in want[..want.len() - 1].iter().enumerate() {
                        let (c, t) = stack[3 + k];
                        assert_eq!(
                            (c, t.to_bits()),
                            (n.child[lane], entry[lane].to_bits()),
                            "{mask:08b}: {k}"
                        );
                    }
                }
            }
        }
    }

    /// `b` scaled by two about the origin: a box around a mesh centred there, for rays that
    /// start outside it.
    fn doubled(b: crate::geometry::Aabb) -> crate::geometry::Aabb {
        crate::geometry::Aabb { min: b.min * 2.0, max: b.max * 2.0 }
    }

    /// Whether the entry points dispatch to a version with integer minima and maxima (on this
    /// CPU: the AVX2 and AVX-512 versions, or every version of a build whose target has AVX2).
    fn dispatches_integer_minmax() -> bool {
        #[cfg(target_arch = "x86_64")]
        {
            use std::arch::is_x86_feature_detected as has;
            has!("avx2") && has!("fma") && has!("bmi1") && has!("bmi2") && has!("lzcnt") && has!("popcnt")
        }
        #[cfg(not(target_arch = "x86_64"))]
        false
    }

    /// Rays that leave one of `n`'s boxes at `t = 0` through one face (their origin on it, the
    /// exit distance −0) with the box behind them along another axis: the float test culls
    /// the box, the integer minima (which take −0 as the least) enter it (see
    /// [`RayBoxes::enter`]). One ray per non-empty lane.
    fn behind_the_ray(n: &Node8) -> Vec<Ray> {
        (0..WIDTH)
            .filter(|&l| n.bounds[0][0][l] <= n.bounds[0][1][l])
            .map(|l| {
                let b = |a: usize, side: usize| n.bounds[a][side][l];
                let o = Vec3::new(b(0, 0), 0.5 * (b(1, 0) + b(1, 1)), b(2, 1) + 0.5);
                Ray::new(o, Vec3::new(-1.0, 0.0, 1.0))
            })
            .collect()
    }

    /// The box test's versions agree: every lane the float test enters, the dispatched version
    /// enters at the same entry and exit distances (equal as floats: an exit of zero may differ
    /// in its sign); a lane only the integer version enters is one the ray left at or before
    /// `tmin` (entry +0, exit at most 0; the float exit negative). Every node of a tree, random
    /// rays, segments and the rays of [`behind_the_ray`], which make the versions differ.
    #[test]
    fn box_test_versions_agree() {
        let m = testmesh::sphere(20, 40);
        let bvh = Bvh::new(&m.positions, &m.indices);
        let b = m.bounds();
        let grown = doubled(b);
        let mut rays = testmesh::random_rays(&grown, 300, 11);
        rays.extend(testmesh::gather_rays(&m, b.max * 1.5, 100, 12));
        rays.extend(bvh.view().nodes.iter().flat_map(behind_the_ray));
        let (mut entered, mut differ) = (0, 0);
        for r in &rays {
            let rb = RayBoxes::new(r);
            for n in bvh.view().nodes.iter() {
                for tmax in [r.tmax, 0.5] {
                    let (mask, entry, exit) = rb.enter(n, tmax, &Isa::BASELINE);
                    let (got, got_entry, got_exit) = enter_dispatched(bvh.view(), &rb, n, tmax);
                    assert_eq!(got & mask, mask, "{r:?}");
                    for l in (0..WIDTH).filter(|l| mask >> l & 1 == 1) {
                        assert_eq!(got_entry[l].to_bits(), entry[l].to_bits(), "{r:?} {l}");
                        assert_eq!(got_exit[l], exit[l], "{r:?} {l}");
                    }
                    for l in (0..WIDTH).filter(|l| (got ^ mask) >> l & 1 == 1) {
                        assert!(got_entry[l].to_bits() == 0 && got_exit[l] <= 0.0 && exit[l] < 0.0, "{r:?}");
                    }
                    entered += mask.count_ones();
                    differ += (got ^ mask).count_ones();
                }
            }
        }
        assert!(entered > 1000, "{entered}");
        assert_eq!(differ > 0, dispatches_integer_minmax(), "{differ} lanes differ");
    }

    /// The dispatched entry points (the AVX-512 or AVX2 version on a CPU that has it) give the
    /// same hits, bit for bit, as the traversal compiled for the build's target, which this
    /// test calls directly; random rays, axis-aligned rays that meet boxes' faces edge-on, the
    /// gather pattern, the rays of [`behind_the_ray`] (where the versions enter different
    /// boxes), and the same mesh with every triangle twice (ties between packs and leaves, which
    /// the versions must break alike).
    #[test]
    fn all_versions_agree() {
        let m = testmesh::sphere(40, 80);
        let twice = testmesh::Mesh { positions: m.positions.clone(), indices: m.indices.repeat(2) };
        for m in [m, twice] {
            versions_agree_on(&m);
        }
    }

    fn versions_agree_on(m: &testmesh::Mesh) {
        let bvh = Bvh::new(&m.positions, &m.indices);
        let b = m.bounds();
        let grown = doubled(b);
        let mut rays = testmesh::random_rays(&grown, 2_000, 5);
        for d in [Vec3::X, Vec3::Y, Vec3::Z, -Vec3::X, -Vec3::Y, -Vec3::Z] {
            for k in 0..50 {
                let o = b.min.lerp(b.max, k as f32 / 49.0) - d * 3.0;
                rays.push(Ray::new(o, d));
            }
        }
        // The gather pattern: segments ending just short of the surface, from outside and inside.
        rays.extend(testmesh::gather_rays(m, b.max * 1.5, 500, 8));
        rays.extend(testmesh::gather_rays(m, b.min.lerp(b.max, 0.4), 500, 9));
        rays.extend(bvh.view().nodes.iter().flat_map(behind_the_ray));
        let mut hits = 0;
        for r in &rays {
            let base = bvh.view().closest_hit_with::<STACK_MAX>(r, &Isa::BASELINE).ok().flatten();
            let got = bvh.view().closest_hit(r);
            let bits = |h: Hit| (h.t.to_bits(), h.prim, h.u.to_bits(), h.v.to_bits());
            assert_eq!(got.map(bits), base.map(bits));
            assert_eq!(
                bvh.view().any_hit(r),
                bvh.view().any_hit_with::<STACK_MAX>(r, &Isa::BASELINE).ok() == Some(true)
            );
            hits += usize::from(got.is_some());
        }
        assert!(hits > 300, "{hits}");
    }

    /// A tiny stack overflows on a dense mesh; the overflow is reported, never a wrong answer,
    /// and the large stack gives the same result as the fast path whenever both finish.
    #[test]
    fn small_stack_overflow_is_detected() {
        let m = testmesh::sphere(60, 120);
        let bvh = Bvh::new(&m.positions, &m.indices);
        let b = m.bounds();
        let grown = doubled(b);
        let mut overflows = 0;
        for r in testmesh::random_rays(&grown, 2_000, 9) {
            let full = bvh.view().closest_hit_with::<STACK_MAX>(&r, &Isa::BASELINE).ok().flatten();
            assert_eq!(bvh.view().closest_hit_with::<STACK>(&r, &Isa::BASELINE).ok(), Some(full));
            match bvh.view().closest_hit_with::<4>(&r, &Isa::BASELINE) {
                Ok(h) => assert_eq!(h, full),
                Err(Overflow) => overflows += 1,
            }
            let occ = bvh.view().any_hit_with::<STACK_MAX>(&r, &Isa::BASELINE).ok();
            assert_eq!(occ, Some(full.is_some()));
            if let Ok(o) = bvh.view().any_hit_with::<4>(&r, &Isa::BASELINE) {
                assert_eq!(Some(o), occ);
            }
        }
        assert!(overflows > 0);
    }
}
