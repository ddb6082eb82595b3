//! The triangle mesh that the PLY ([`super::ply`]) and Mitsuba `.serialized`
//! ([`super::serialized`]) readers return: what the file stores, in the file's own (object)
//! space, before any transform, normalisation or material is applied.

use glam::{Vec2, Vec3};

/// A triangle mesh as a file stores it, in the file's (object) space.
///
/// The readers guarantee: every position is finite; `normals` and `uvs` are each empty or
/// have one finite entry per position; every triangle index is below `positions.len()`.
/// Degenerate (zero-area) triangles are kept as stored.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct MeshData {
    pub positions: Vec<Vec3>,
    /// Empty, or one per position (as stored; not necessarily unit).
    pub normals: Vec<Vec3>,
    /// Empty, or one per position.
    pub uvs: Vec<Vec2>,
    pub triangles: Vec<[u32; 3]>,
    /// Mitsuba's FaceNormals flag (.serialized) : the mesh asks for flat shading.
    pub face_normals: bool,
}

/// Deterministic mutations of valid files for the readers' robustness tests: the mutated
/// bytes must make a reader return `Ok` or `Err`, never panic, hang or allocate beyond what
/// the input justifies.
#[cfg(test)]
pub(crate) mod mutation {
    use std::panic::{AssertUnwindSafe, catch_unwind};
    use std::time::{Duration, Instant};

    /// A file to mutate: its name, its bytes, and whether it is text (for text mutations).
    pub type Input<'a> = (&'a str, Vec<u8>, bool);

    /// xorshift64*: small, deterministic, good enough to pick mutations.
    pub struct Rng(u64);

    impl Rng {
        pub fn new(seed: u64) -> Rng {
            Rng(seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1)
        }
        pub fn next(&mut self) -> u64 {
            self.0 ^= self.0 >> 12;
            self.0 ^= self.0 << 25;
            self.0 ^= self.0 >> 27;
            self.0.wrapping_mul(0x2545_F491_4F6C_DD1D)
        }
        /// Uniform in `0..n` (`n > 0`).
        pub fn below(&mut self, n: usize) -> usize {
            (self.next() % n.max(1) as u64) as usize
        }
    }

    /// Values that break counts and sizes when written over a field.
    const HUGE: [u64; 8] = [
        u64::MAX,
        u32::MAX as u64,
        0x7FFF_FFFF,
        0x8000_0000,
        1 << 40,
        0x0000_0001_0000_0000,
        1_000_000_000_000,
        0xFFFF_FFFF_FFFF_FFF0,
    ];

    /// Texts that break counts, numbers and keywords of text formats.
    const HUGE_TEXT: [&str; 10] = [
        "1000000000000",
        "18446744073709551615",
        "99999999999999999999999",
        "-1",
        "4294967296",
        "nan",
        "inf",
        "1e39",
        "list",
        "\n",
    ];

    /// One to three random byte and structure mutations of `data`.
    pub fn mutate(rng: &mut Rng, data: &[u8], text: bool) -> Vec<u8> {
        let mut d = data.to_vec();
        for _ in 0..1 + rng.below(3) {
            let len = d.len();
            match rng.below(8) {
                // Flip a few bits.
                0 => {
                    for _ in 0..1 + rng.below(4) {
                        if len > 0 {
                            let i = rng.below(len);
                            d[i] ^= 1 << rng.below(8);
                        }
                    }
                }
                // Overwrite a few bytes with random values.
                1 => {
                    for _ in 0..1 + rng.below(4) {
                        if len > 0 {
                            let i = rng.below(len);
                            d[i] = rng.next() as u8;
                        }
                    }
                }
                // Truncate.
                2 => d.truncate(rng.below(len + 1)),
                // Overwrite a field with a huge value (little or big endian, 4 or 8 bytes).
                3 => {
                    let v = HUGE[rng.below(HUGE.len())];
                    let bytes = if rng.below(2) == 0 { v.to_le_bytes() } else { v.to_be_bytes() };
                    let w = if rng.below(2) == 0 { 4 } else { 8 };
                    if len >= w {
                        let at = rng.below(len - w + 1);
                        d[at..at + w].copy_from_slice(&bytes[..w]);
                    }
                }
                // Duplicate a chunk.
                4 => {
                    if len > 0 {
                        let a = rng.below(len);
                        let b = (a + 1 + rng.below(64)).min(len);
                        let chunk = d[a..b].to_vec();
                        let at = rng.below(len + 1);
                        d.splice(at..at, chunk);
                    }
                }
                // Delete a chunk.
                5 => {
                    if len > 0 {
                        let a = rng.below(len);
                        let b = (a + 1 + rng.below(64)).min(len);
                        d.drain(a..b);
                    }
                }
                // Text: replace a run of digits (a count or a number) with a huge or bad token.
                6 if text => {
                    let starts: Vec<usize> = (0..len)
                        .filter(|&i| d[i].is_ascii_digit() && (i == 0 || !d[i - 1].is_ascii_digit()))
                        .collect();
                    if !starts.is_empty() {
                        let a = starts[rng.below(starts.len())];
                        let b = (a..len).find(|&i| !d[i].is_ascii_digit()).unwrap_or(len);
                        let t = HUGE_TEXT[rng.below(HUGE_TEXT.len())].as_bytes().to_vec();
                        d.splice(a..b, t);
                    }
                }
                // Text: swap two lines.
                7 if text => {
                    let breaks: Vec<usize> = (0..len).filter(|&i| d[i] == b'\n').collect();
                    if breaks.len() >= 3 {
                        let k = rng.below(breaks.len() - 2);
                        let (a, b, c) = (breaks[k] + 1, breaks[k + 1] + 1, breaks[k + 2] + 1);
                        let mut swapped = d[b..c].to_vec();
                        swapped.extend_from_slice(&d[a..b]);
                        d.splice(a..c, swapped);
                    }
                }
                // Binary: insert random bytes.
                _ => {
                    let at = rng.below(len + 1);
                    let n = 1 + rng.below(8);
                    let ins: Vec<u8> = (0..n).map(|_| rng.next() as u8).collect();
                    d.splice(at..at, ins);
                }
            }
        }
        d
    }

    /// Runs `read` on `cases` mutations of the inputs (name, bytes, is text); panics naming the
    /// first case that panicked, took a second or more, or returned more than `ratio` elements
    /// (as `size` counts them) per input byte. Returns (Ok count, Err count).
    pub fn survive<T>(
        label: &str,
        inputs: &[Input],
        cases: usize,
        seed: u64,
        ratio: usize,
        read: impl Fn(&[u8]) -> Result<T, crate::scene::SceneError>,
        size: impl Fn(&T) -> usize,
    ) -> (usize, usize) {
        let mut rng = Rng::new(seed);
        let (mut ok, mut err) = (0, 0);
        let mut slowest = Duration::ZERO;
        for case in 0..cases {
            let (name, input, text) = &inputs[case % inputs.len()];
            let mutated = mutate(&mut rng, input, *text);
            let start = Instant::now();
            let result = catch_unwind(AssertUnwindSafe(|| read(&mutated)));
            let took = start.elapsed();
            slowest = slowest.max(took);
            match result {
                Err(_) => panic!("{label}: case {case} (mutated {name}, seed {seed}) panicked"),
                Ok(Ok(v)) => {
                    // Everything a reader returns comes from bytes of the input.
                    assert!(
                        size(&v) <= ratio * mutated.len(),
                        "{label}: case {case} (mutated {name}) returned {} elements from {} bytes",
                        size(&v),
                        mutated.len()
                    );
                    ok += 1
                }
                Ok(Err(e)) => {
                    assert!(!e.to_string().is_empty());
                    err += 1
                }
            }
            assert!(took < Duration::from_secs(1), "{label}: case {case} (mutated {name}) took {took:?}");
        }
        eprintln!("{label}: {cases} mutations: {ok} Ok, {err} Err, slowest {slowest:?}");
        (ok, err)
    }
}
