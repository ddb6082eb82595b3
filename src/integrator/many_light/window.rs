//! The resampled gather's window ([`super::resample`]): which of an iteration's lights are a
//! receiver's candidates. A window is an aligned run of g consecutive light paths, g a power
//! of two, with every light those paths left; a receiver's window is one of the W = ⌈N / g⌉
//! runs of the iteration's N paths, drawn uniformly.
//!
//! **Unbiased.** Every light lies in exactly one run, and each run is drawn with probability
//! 1 / W, so W · Σ_{j ∈ window} c_j V_j estimates the iteration's full sum Σ_j c_j V_j
//! (Horvitz–Thompson with inclusion probability 1 / W). Windows of W ≤ 2 runs are widened
//! to all the lights: that costs at most twice the candidates, and the runs they would leave
//! out only add the variance of the factor W.
//!
//! **Why runs of light paths, aligned and of a power of two.** With Sobol points an
//! iteration's light paths are the points of one scrambled sequence, path k its point k
//! ([`crate::sampling::Streams::light_paths`]), and every aligned block of 2^j points is a
//! net (`src/sampling/sobol.rs`): its paths leave the emitters as evenly as an
//! iteration of 2^j paths does. Any other subset is less even: before this rule a window was
//! about m candidates from a uniform start, and in the diffuse corner (64×64, 512 iterations,
//! seeds 1–3) a window of 36 candidates among 256 paths' 282 VPLs gave 1.21–1.59e-5 in
//! relative MSE where every VPL of 32 paths gave 0.73–0.99e-5 for the same cost; with
//! independent numbers the two were level (4.9e-5 and 5.0e-5), so the difference is the
//! stratification alone (`docs/results.md`, "Windows of aligned light paths"). Aligned runs
//! keep it, and the iteration keeps its many paths, so that neighbouring receivers still
//! draw different windows and the error stays grain, not blotches
//! (`docs/measurements.md`, "At least 256 light paths for `pir-bdpt`").
//!
//! **The run's length.** g is the largest power of two whose paths leave at most m
//! candidates on average (m / y paths, y the iteration's lights per path), at least one
//! path: a window holds between m / 2 and m candidates on average, fewer where its paths
//! happen to leave fewer.

use std::ops::Range;

use crate::sampling::Sampler;

/// A uniform index below `n` (0 when `n` is 0), from one number of `sampler`: Lemire's
/// multiply-shift, uniform up to 2^-64, far below the noise.
fn uniform_index(n: usize, sampler: &mut Sampler) -> usize {
    ((sampler.next_u64() as u128 * n as u128) >> 64) as usize
}

/// An iteration's lights by the light path that left them: path i's are the lights from the
/// end of path i − 1's (0 for the first) to its own end, in light order.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct LightPaths {
    /// Each path's end: one past its last light (as its start where it left none).
    ends: Vec<u32>,
}

impl LightPaths {
    /// The paths whose lights end at `ends` (one per path, non-decreasing).
    pub fn new(ends: Vec<u32>) -> Self {
        assert!(ends.windows(2).all(|e| e[0] <= e[1]), "light paths out of order");
        LightPaths { ends }
    }

    /// `lights` lights, each from a path of its own (tests and benchmarks).
    pub fn one_each(lights: usize) -> Self {
        LightPaths { ends: (1..=lights as u32).collect() }
    }

    /// N, the paths.
    pub fn paths(&self) -> usize {
        self.ends.len()
    }

    /// The lights of all paths.
    pub fn lights(&self) -> usize {
        self.ends.last().map_or(0, |&e| e as usize)
    }

    /// Where path `path`'s lights start (the lights' count for `path` = N).
    fn start(&self, path: usize) -> usize {
        match path {
            0 => 0,
            p => self.ends[p - 1] as usize,
        }
    }

    /// g, the paths of a window for about `m` candidates (see the module docs).
    pub fn window_paths(&self, m: usize) -> usize {
        let (n, lights) = (self.paths(), self.lights());
        if lights == 0 {
            return n.max(1);
        }
        // m / y paths, y = lights / n; the largest power of two at most that, at least 1.
        // (In 64 bits: this runs per receiver, and a 128-bit division is a library call.)
        let fit = ((m.max(1) as u64).saturating_mul(n as u64) / lights as u64).max(1);
        1 << fit.ilog2().min(usize::BITS - 2)
    }

    /// A window of runs of `g` paths (a power of two): one of the W = ⌈N / g⌉ aligned runs,
    /// uniformly, or all the lights where W ≤ 2; one number of `sampler`, always.
    pub fn draw(&self, g: usize, sampler: &mut Sampler) -> Window {
        let g = g.max(1);
        let runs = self.paths().div_ceil(g);
        let run = uniform_index(runs, sampler);
        if runs <= 2 {
            return Window::all(self.lights());
        }
        let (first, last) = (run * g, ((run + 1) * g).min(self.paths()));
        Window { lights: self.start(first)..self.start(last), scale: runs as f32 }
    }
}

/// A receiver's candidates: a run of the iteration's lights and the factor that makes their
/// sum unbiased for all of them.
#[derive(Clone, Debug, PartialEq)]
pub struct Window {
    /// The lights of the window's paths.
    pub lights: Range<usize>,
    /// W, the windows there are (1: all the lights).
    pub scale: f32,
}

impl Window {
    /// Every one of `lights` lights.
    pub fn all(lights: usize) -> Window {
        Window { lights: 0..lights, scale: 1.0 }
    }

    /// The chunks of `LANES` lights that hold the window's lights, each with the lanes that
    /// are in the window: the first and last chunk may hold lights of other windows.
    pub fn chunks<const LANES: usize>(&self) -> impl Iterator<Item = (usize, [bool; LANES])> + '_ {
        let (lo, hi) = (self.lights.start, self.lights.end);
        (lo / LANES..hi.div_ceil(LANES)).map(move |c| (c, self.inside(c * LANES)))
    }

    /// Which of the `N` lights from `first` on are in the window.
    #[inline]
    pub fn inside<const N: usize>(&self, first: usize) -> [bool; N] {
        std::array::from_fn(|l| self.lights.contains(&(first + l)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::Domain;

    /// Paths that leave 0 to 3 lights each.
    fn paths(n: usize) -> LightPaths {
        let mut end = 0;
        LightPaths::new(
            (0..n)
                .map(|i| {
                    end += ((i * 7 + 3) % 5).min(3) as u32;
                    end
                })
                .collect(),
        )
    }

    /// Every light lies in exactly one of the runs, each run is drawn equally often, and its
    /// factor is the runs' count: the window's sum is unbiased for every light's.
    #[test]
    fn windows_cover_every_light_once_and_equally() {
        let lp = paths(100);
        let lights = lp.lights();
        assert!(lights > 100);
        for g in [1, 4, 16, 32, 64, 128] {
            let runs = 100usize.div_ceil(g);
            let mut hits = vec![0usize; lights];
            let mut drawn = std::collections::BTreeMap::new();
            let mut s = Sampler::new(1, 0, Domain::LightPath, 0);
            let draws = 20_000;
            for _ in 0..draws {
                let w = lp.draw(g, &mut s);
                if runs <= 2 {
                    assert_eq!(w, Window::all(lights));
                } else {
                    assert_eq!(w.scale, runs as f32);
                }
                for j in w.lights.clone() {
                    hits[j] += 1;
                }
                *drawn.entry(w.lights.start).or_insert(0usize) += 1;
            }
            if runs <= 2 {
                assert!(hits.iter().all(|&h| h == draws));
                continue;
            }
            // Each light in one run: hit as often as its run is drawn, about draws / runs.
            let expect = draws as f64 / runs as f64;
            for (j, &h) in hits.iter().enumerate() {
                assert!((h as f64 - expect).abs() < 5.0 * expect.sqrt(), "g {g} light {j}: {h} of {expect}");
            }
            // The runs partition the lights: each starts where the one before ends.
            let mut s = Sampler::new(2, 0, Domain::LightPath, 0);
            let mut runs_seen: Vec<Range<usize>> = (0..draws).map(|_| lp.draw(g, &mut s).lights).collect();
            runs_seen.sort_by_key(|r| (r.start, r.end));
            runs_seen.dedup();
            let nonempty: Vec<_> = runs_seen.iter().filter(|r| !r.is_empty()).collect();
            assert_eq!(nonempty.first().unwrap().start, 0);
            assert_eq!(nonempty.last().unwrap().end, lights);
            assert!(nonempty.windows(2).all(|p| p[0].end == p[1].start), "g {g}: {runs_seen:?}");
        }
    }

    /// A run's paths are aligned: run r holds paths r·g to (r + 1)·g (fewer in the last).
    #[test]
    fn runs_are_aligned_blocks_of_paths() {
        let lp = LightPaths::new(vec![2, 2, 5, 6, 6, 6, 9, 10, 12, 12]);
        let mut s = Sampler::new(3, 0, Domain::LightPath, 0);
        let mut seen = std::collections::BTreeSet::new();
        for _ in 0..1000 {
            let w = lp.draw(4, &mut s);
            assert_eq!(w.scale, 3.0);
            seen.insert((w.lights.start, w.lights.end));
        }
        // Paths 0–3: lights 0..6; paths 4–7: 6..10; paths 8–9: 10..12.
        assert_eq!(seen.into_iter().collect::<Vec<_>>(), vec![(0, 6), (6, 10), (10, 12)]);
    }

    /// g is the largest power of two whose paths leave at most m lights on average.
    #[test]
    fn run_length_fits_the_candidates() {
        // 256 paths, 282 lights (the diffuse corner): y = 1.1, m = 128: 116 paths → 64.
        let mut ends: Vec<u32> = (1..=256).collect();
        for e in ends.iter_mut().skip(230) {
            *e += 26;
        }
        let lp = LightPaths::new(ends);
        assert_eq!(lp.lights(), 256 + 26);
        assert_eq!(lp.window_paths(128), 64);
        assert_eq!(lp.window_paths(32), 16);
        assert_eq!(lp.window_paths(1), 1);
        // Many lights per path: at least one path.
        assert_eq!(LightPaths::new(vec![500, 1000]).window_paths(64), 1);
        // No lights: every path, and the window is empty.
        let none = LightPaths::new(vec![0; 8]);
        assert_eq!(none.window_paths(64), 8);
        let mut s = Sampler::new(4, 0, Domain::LightPath, 0);
        assert_eq!(none.draw(8, &mut s), Window::all(0));
    }

    /// The chunks of a window, with the lanes inside it.
    #[test]
    fn chunks_mask_the_lights_of_other_windows() {
        let w = Window { lights: 3..9, scale: 2.0 };
        let chunks: Vec<_> = w.chunks::<4>().collect();
        assert_eq!(
            chunks,
            vec![(0, [false, false, false, true]), (1, [true; 4]), (2, [true, false, false, false])]
        );
        assert_eq!(Window::all(0).chunks::<4>().count(), 0);
        assert_eq!(Window::all(8).chunks::<4>().collect::<Vec<_>>(), vec![(0, [true; 4]), (1, [true; 4])]);
    }
}
