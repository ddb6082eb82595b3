//! The Embree backend against the brute-force oracle: closest hits, occlusion, 4/8/16-wide
//! packets with padded tails, invalid and degenerate rays, rays on surfaces and grazing
//! edges, concurrent use from rayon threads, empty scenes. Only built when pir was built with
//! Embree (`cfg(pir_embree)`); without it, `no_embree_build_reports_how_to_get_it` runs.
//!
//! Agreement is exact where it can be and explained where it cannot: two float intersectors
//! may disagree on a ray that passes within rounding of an edge (tie between neighbours, or
//! hit vs miss) or whose hit is within rounding of `tmin`/`tmax`. Such cases are allowed, all
//! other disagreements fail, and the allowed ones must stay rare.

#[cfg(not(pir_embree))]
#[test]
fn no_embree_build_reports_how_to_get_it() {
    use pir::accel::{Backend, build_accelerator, embree_status};
    assert!(embree_status().contains("apt-get install libembree-dev libclang-dev"));
    assert_eq!(Backend::default_available(), Backend::Bvh);
    let empty = pir::geometry::VertexBuffer::default();
    let err = build_accelerator(Backend::Embree, &empty, &[]).err().unwrap();
    assert!(err.contains("pir was built without Embree; install libembree-dev libclang-dev and rebuild"));
}

#[cfg(pir_embree)]
mod with_embree {
    use glam::Vec3;
    use pir::accel::embree::{Embree, EmbreeSettings, PacketWidth};
    use pir::accel::{
        Accelerator, Backend, BruteForce, Hit, build_accelerator, embree_status, flush_denormals_enabled,
        set_flush_denormals,
    };
    use pir::geometry::{Ray, VertexBuffer};
    use pir::sampling::{Domain, Sampler};
    use rayon::prelude::*;

    // ---------------------------------------------------------------- scenes

    /// Appends an axis-aligned box (12 triangles).
    fn add_box(p: &mut Vec<Vec3>, t: &mut Vec<[u32; 3]>, lo: Vec3, hi: Vec3) {
        let b = p.len() as u32;
        for i in 0..8 {
            p.push(Vec3::new(
                if i & 1 == 0 { lo.x } else { hi.x },
                if i & 2 == 0 { lo.y } else { hi.y },
                if i & 4 == 0 { lo.z } else { hi.z },
            ));
        }
        for q in [[0, 1, 3, 2], [4, 6, 7, 5], [0, 4, 5, 1], [2, 3, 7, 6], [0, 2, 6, 4], [1, 5, 7, 3]] {
            t.push([b + q[0], b + q[1], b + q[2]]);
            t.push([b + q[0], b + q[2], b + q[3]]);
        }
    }

    /// A closed room [-2, 2]^3 with three inner boxes.
    fn boxes() -> (Vec<Vec3>, Vec<[u32; 3]>) {
        let (mut p, mut t) = (Vec::new(), Vec::new());
        add_box(&mut p, &mut t, Vec3::splat(-2.0), Vec3::splat(2.0));
        add_box(&mut p, &mut t, Vec3::new(-1.5, -2.0, -1.5), Vec3::new(-0.5, -0.5, -0.5));
        add_box(&mut p, &mut t, Vec3::new(0.2, -2.0, 0.1), Vec3::new(1.2, 1.0, 1.1));
        add_box(&mut p, &mut t, Vec3::new(-0.3, 0.8, -1.0), Vec3::new(0.3, 1.4, 1.7));
        (p, t)
    }

    /// The boxes plus a bumpy sphere of 100 x 100 x 2 = 20,000 triangles.
    fn dense() -> (Vec<Vec3>, Vec<[u32; 3]>) {
        let (mut p, mut t) = boxes();
        let n = 100u32;
        let base = p.len() as u32;
        let mut s = Sampler::new(11, 0, Domain::Iteration, 0);
        for i in 0..=n {
            let theta = std::f32::consts::PI * i as f32 / n as f32;
            for j in 0..=n {
                let phi = 2.0 * std::f32::consts::PI * j as f32 / n as f32;
                let r = 0.6 + 0.02 * s.next_f32();
                let d = Vec3::new(theta.sin() * phi.cos(), theta.cos(), theta.sin() * phi.sin());
                p.push(Vec3::new(-0.6, 0.6, 0.9) + d * r);
            }
        }
        for i in 0..n {
            for j in 0..n {
                let a = base + i * (n + 1) + j;
                let (b, c, d) = (a + 1, a + n + 1, a + n + 2);
                t.push([a, c, b]);
                t.push([b, c, d]);
            }
        }
        (p, t)
    }

    // ---------------------------------------------------------------- rays

    fn unit_dir(s: &mut Sampler) -> Vec3 {
        let z = 1.0 - 2.0 * s.next_f32();
        let r = (1.0 - z * z).max(0.0).sqrt();
        let phi = 2.0 * std::f32::consts::PI * s.next_f32();
        Vec3::new(r * phi.cos(), r * phi.sin(), z)
    }

    /// Random rays inside the room: mixed lengths, some unnormalised directions, some segments.
    fn random_rays(seed: u64, n: usize) -> Vec<Ray> {
        (0..n)
            .map(|k| {
                let mut s = Sampler::new(seed, 0, Domain::Iteration, k as u64);
                let o = Vec3::new(s.next_f32(), s.next_f32(), s.next_f32()) * 3.8 - 1.9;
                let d = unit_dir(&mut s) * (0.25 + 2.0 * s.next_f32());
                let tmax = match k % 3 {
                    0 => f32::INFINITY,
                    1 => 0.1 + 3.0 * s.next_f32(),
                    _ => 1e30,
                };
                let tmin = if k % 5 == 0 { 0.05 * s.next_f32() } else { 0.0 };
                Ray { origin: o, dir: d, tmin, tmax }
            })
            .collect()
    }

    // ---------------------------------------------------------------- agreement

    /// Barycentric distance of a hit to its triangle's boundary.
    fn edge_distance(h: &Hit) -> f32 {
        h.u.min(h.v).min(1.0 - h.u - h.v)
    }

    fn near(a: f32, b: f32, rel: f32) -> bool {
        (a - b).abs() <= rel * a.abs().max(b.abs()).max(1e-3)
    }

    /// Why a hit may legitimately be missed by the other intersector: it is within rounding
    /// of an edge or of the interval's ends.
    fn borderline(h: &Hit, r: &Ray) -> bool {
        edge_distance(h) < 1e-4 || near(h.t, r.tmin, 1e-4) || (r.tmax.is_finite() && near(h.t, r.tmax, 1e-4))
    }

    #[derive(Default, Debug)]
    struct Tally {
        exact: usize,
        allowed: usize,
        bad: Vec<String>,
    }

    impl Tally {
        fn check_hit(&mut self, r: &Ray, want: Option<Hit>, got: Option<Hit>) {
            match (want, got) {
                (None, None) => self.exact += 1,
                (Some(w), Some(g)) if w.prim == g.prim => {
                    if near(w.t, g.t, 1e-4) && (w.u - g.u).abs() < 1e-3 && (w.v - g.v).abs() < 1e-3 {
                        self.exact += 1;
                    } else {
                        self.bad.push(format!("{r:?}: want {w:?}, got {g:?}"));
                    }
                }
                // A tie: the same distance on two triangles (sharing an edge or a vertex, or
                // coplanar, like a box standing on the floor).
                (Some(w), Some(g)) if near(w.t, g.t, 1e-5) => self.allowed += 1,
                // One intersector saw a borderline hit that the other missed, finding the
                // next surface behind it.
                (Some(w), Some(g)) if borderline(if w.t < g.t { &w } else { &g }, r) => self.allowed += 1,
                (Some(h), None) | (None, Some(h)) if borderline(&h, r) => self.allowed += 1,
                (w, g) => self.bad.push(format!("{r:?}: want {w:?}, got {g:?}")),
            }
        }

        fn check_occluded(&mut self, r: &Ray, want: bool, got: bool, closest: Option<Hit>) {
            if want == got {
                self.exact += 1;
            } else if closest.is_some_and(|h| borderline(&h, r)) {
                self.allowed += 1;
            } else {
                self.bad.push(format!("{r:?}: occluded want {want}, got {got}, closest {closest:?}"));
            }
        }

        fn assert_ok(&self, what: &str) {
            let total = self.exact + self.allowed + self.bad.len();
            assert!(
                self.bad.is_empty(),
                "{what}: {} of {total} disagree:\n{}",
                self.bad.len(),
                self.bad.join("\n")
            );
            assert!(self.allowed * 200 <= total, "{what}: too many borderline cases: {self:?}");
        }
    }

    fn compare_with_brute(p: &[Vec3], t: &[[u32; 3]], rays: &[Ray], what: &str) {
        let brute = BruteForce::new(p, t);
        let e = Embree::new(p, t).unwrap();
        let (mut hits, mut occ) = (Tally::default(), Tally::default());
        let mut n_hits = 0;
        for r in rays {
            let want = brute.intersect(r);
            n_hits += want.is_some() as usize;
            hits.check_hit(r, want, e.intersect(r));
            occ.check_occluded(r, brute.occluded(r), e.occluded(r), want);
        }
        hits.assert_ok(&format!("{what} intersect"));
        occ.assert_ok(&format!("{what} occluded"));
        // The rays must exercise both outcomes.
        assert!(n_hits > rays.len() / 4 && n_hits < rays.len(), "{what}: {n_hits} hits of {}", rays.len());
        assert_eq!(e.device().error_count(), 0, "{:?}", e.device().errors());
    }

    // ---------------------------------------------------------------- tests

    #[test]
    fn status_names_the_version() {
        assert!(embree_status().starts_with("embree "), "{}", embree_status());
        assert_eq!(Backend::default_available(), Backend::Embree);
        let (p, t) = boxes();
        let p = VertexBuffer::from(p);
        let a = build_accelerator(Backend::Embree, &p, &t).unwrap();
        assert_eq!(a.name(), "embree");
        let d = a.describe();
        assert!(d.starts_with("embree ") && d.contains("triangles") && d.contains("built in"), "{d}");
        assert!(d.contains("shared buffers"), "the renderer's Embree scene must not copy the mesh: {d}");
    }

    /// The zero-copy scene (what the renderer builds) answers exactly as the copying one.
    #[test]
    fn shared_and_copied_buffers_agree() {
        let (p, t) = boxes();
        let copied = Embree::new(&p, &t).unwrap();
        let vertices = VertexBuffer::from(p);
        let shared = Embree::shared(&vertices, &t).unwrap();
        for r in random_rays(7, 2000) {
            assert_eq!(shared.intersect(&r), copied.intersect(&r));
            assert_eq!(shared.occluded(&r), copied.occluded(&r));
        }
    }

    #[test]
    fn agrees_with_brute_force_on_boxes() {
        let (p, t) = boxes();
        compare_with_brute(&p, &t, &random_rays(1, 4000), "boxes");
    }

    #[test]
    fn agrees_with_brute_force_on_dense_mesh() {
        let (p, t) = dense();
        assert!(t.len() > 20_000);
        // Aim half of the rays at the sphere so its triangles are really exercised.
        let mut rays = random_rays(2, 600);
        for (k, r) in rays.iter_mut().enumerate().filter(|(k, _)| k % 2 == 0) {
            let mut s = Sampler::new(3, 0, Domain::Iteration, k as u64);
            let target = Vec3::new(-0.6, 0.6, 0.9) + unit_dir(&mut s) * 0.55;
            r.dir = target - r.origin;
        }
        compare_with_brute(&p, &t, &rays, "dense");
    }

    /// Batched queries (every width, lengths that leave padded tails) agree with single rays.
    #[test]
    fn packets_agree_with_single_rays() {
        let (p, t) = dense();
        let mut rays = random_rays(4, 100);
        // Sprinkle invalid rays so that inactive lanes sit between active ones.
        rays[3].dir = Vec3::ZERO;
        rays[20].origin.x = f32::NAN;
        rays[33].tmin = 5.0;
        rays[33].tmax = 1.0;
        for width in [PacketWidth::W4, PacketWidth::W8, PacketWidth::W16, PacketWidth::Auto] {
            let e =
                Embree::with_settings(&p, &t, EmbreeSettings { packet_width: width, ..Default::default() })
                    .unwrap();
            for len in [1, 3, 15, 16, 17, 100] {
                let rays = &rays[..len];
                let mut hits = vec![None; len];
                let mut occ = vec![true; len];
                e.intersect_batch(rays, &mut hits);
                e.occluded_batch(rays, &mut occ);
                let (mut th, mut to) = (Tally::default(), Tally::default());
                for (i, r) in rays.iter().enumerate() {
                    let single = e.intersect(r);
                    th.check_hit(r, single, hits[i]);
                    to.check_occluded(r, e.occluded(r), occ[i], single);
                }
                th.assert_ok(&format!("{width:?} x {len} intersect"));
                to.assert_ok(&format!("{width:?} x {len} occluded"));
            }
        }
    }

    #[test]
    fn invalid_rays_miss_without_aborting() {
        let (p, t) = boxes();
        let e = Embree::new(&p, &t).unwrap();
        let o = Vec3::ZERO;
        let bad = [
            Ray::new(Vec3::new(f32::NAN, 0.0, 0.0), Vec3::X),
            Ray::new(o, Vec3::new(0.0, f32::NAN, 1.0)),
            Ray::new(o, Vec3::new(f32::INFINITY, 0.0, 0.0)),
            Ray::new(Vec3::new(0.0, f32::NEG_INFINITY, 0.0), Vec3::Y),
            Ray::new(o, Vec3::ZERO),
            // A zero-length shadow ray between two equal points.
            Ray::segment(o, (o - o).normalize_or_zero(), (o - o).length()),
            Ray::segment(o, (o - o).normalize(), 1.0),
            Ray { origin: o, dir: Vec3::X, tmin: 5.0, tmax: 1.0 },
            Ray { origin: o, dir: Vec3::X, tmin: 1.0, tmax: 1.0 },
            Ray { origin: o, dir: Vec3::X, tmin: -1.0, tmax: 10.0 },
            Ray { origin: o, dir: Vec3::X, tmin: f32::NAN, tmax: 10.0 },
            Ray { origin: o, dir: Vec3::X, tmin: 0.0, tmax: f32::NAN },
            Ray { origin: o, dir: Vec3::X, tmin: f32::INFINITY, tmax: f32::INFINITY },
            // Beyond Embree's FLT_LARGE: its validity check would abort.
            Ray::new(Vec3::new(1e30, 0.0, 0.0), Vec3::NEG_X),
            Ray::new(o, Vec3::new(1e30, 1.0, 0.0)),
        ];
        for r in &bad {
            assert_eq!(e.intersect(r), None, "{r:?}");
            assert!(!e.occluded(r), "{r:?}");
        }
        // In batches, mixed with valid rays, for every width.
        let good = Ray::new(o, Vec3::X);
        let mixed: Vec<Ray> = bad.iter().flat_map(|r| [*r, good]).collect();
        for width in [PacketWidth::W4, PacketWidth::W8, PacketWidth::W16] {
            let e =
                Embree::with_settings(&p, &t, EmbreeSettings { packet_width: width, ..Default::default() })
                    .unwrap();
            let mut hits = vec![None; mixed.len()];
            let mut occ = vec![false; mixed.len()];
            e.intersect_batch(&mixed, &mut hits);
            e.occluded_batch(&mixed, &mut occ);
            for i in 0..mixed.len() {
                assert_eq!(hits[i].is_some(), i % 2 == 1, "{width:?} {i}");
                assert_eq!(occ[i], i % 2 == 1, "{width:?} {i}");
            }
            // All-invalid batches make no Embree call at all.
            let mut hits = vec![Some(Hit { t: 1.0, prim: 0, u: 0.0, v: 0.0 }); bad.len()];
            e.intersect_batch(&bad, &mut hits);
            assert!(hits.iter().all(Option::is_none));
        }
        assert_eq!(e.device().error_count(), 0);
    }

    /// Axis-aligned directions (zero components), rays starting on surfaces and rays grazing
    /// edges or lying in a face's plane.
    #[test]
    fn degenerate_geometry_cases_agree() {
        let (p, t) = boxes();
        let brute = BruteForce::new(&p, &t);
        let e = Embree::new(&p, &t).unwrap();
        let mut rays = Vec::new();
        let axes = [Vec3::X, Vec3::NEG_X, Vec3::Y, Vec3::NEG_Y, Vec3::Z, Vec3::NEG_Z];
        for k in 0..200u64 {
            let mut s = Sampler::new(5, 0, Domain::Iteration, k);
            let o = Vec3::new(s.next_f32(), s.next_f32(), s.next_f32()) * 3.8 - 1.9;
            rays.push(Ray::new(o, axes[k as usize % 6]));
            // From a random point on a random triangle, in a random direction.
            let tri = t[(s.next_u64() % t.len() as u64) as usize];
            let (u, v) = (s.next_f32() * 0.5, s.next_f32() * 0.5);
            let on = p[tri[0] as usize] * (1.0 - u - v) + p[tri[1] as usize] * u + p[tri[2] as usize] * v;
            rays.push(Ray::new(on, unit_dir(&mut s)));
            rays.push(Ray { origin: on, dir: unit_dir(&mut s), tmin: 1e-3, tmax: f32::INFINITY });
        }
        // Along the room's edges and in its faces' planes, and through shared box corners.
        for &(o, d) in &[
            (Vec3::new(-2.0, -2.0, 0.0), Vec3::X),
            (Vec3::new(-2.0, 0.0, -2.0), Vec3::Z),
            (Vec3::new(0.0, -2.0, 0.0), Vec3::new(1.0, 0.0, 0.3)),
            (Vec3::new(0.0, 0.0, 0.0), Vec3::new(1.0, 1.0, 1.0)),
            (Vec3::new(0.0, 0.0, 0.0), Vec3::new(-1.0, -1.0, -1.0)),
            (Vec3::new(-1.0, -0.5, 0.0), Vec3::new(0.0, 0.0, -1.0)),
            (Vec3::new(1.2, 0.0, 0.1), Vec3::new(0.0, 1.0, 0.0)),
        ] {
            rays.push(Ray::new(o, d));
            rays.push(Ray::new(o, -d));
        }
        let (mut th, mut to) = (Tally::default(), Tally::default());
        for r in &rays {
            let want = brute.intersect(r);
            let got = e.intersect(r);
            // A ray leaving a surface may or may not see that surface at t ≈ 0.
            let at_start = |h: &Option<Hit>| h.is_some_and(|h| h.t < 1e-4);
            if at_start(&want) || at_start(&got) {
                th.allowed += 1;
                continue;
            }
            th.check_hit(r, want, got);
            to.check_occluded(r, brute.occluded(r), e.occluded(r), want);
        }
        assert!(th.bad.is_empty() && to.bad.is_empty(), "{th:?}\n{to:?}");
        assert!(th.allowed < rays.len() / 5, "{th:?}");
    }

    #[test]
    fn concurrent_queries_give_the_same_answers() {
        let (p, t) = dense();
        let e = Embree::new(&p, &t).unwrap();
        let rays = random_rays(6, 2000);
        let seq_hits: Vec<_> = rays.iter().map(|r| e.intersect(r)).collect();
        let seq_occ: Vec<_> = rays.iter().map(|r| e.occluded(r)).collect();
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(4)
            .start_handler(|_| set_flush_denormals())
            .build()
            .unwrap();
        let acc: &dyn Accelerator = &e;
        let (par_hits, par_occ, batched): (Vec<_>, Vec<_>, Vec<_>) = pool.install(|| {
            assert!(flush_denormals_enabled());
            let h: Vec<_> = rays.par_iter().map(|r| acc.intersect(r)).collect();
            let o: Vec<_> = rays.par_iter().map(|r| acc.occluded(r)).collect();
            let b: Vec<_> = rays
                .par_chunks(37)
                .flat_map_iter(|c| {
                    let mut hits = vec![None; c.len()];
                    acc.intersect_batch(c, &mut hits);
                    hits
                })
                .collect();
            (h, o, b)
        });
        // FTZ/DAZ cannot change anything here (no denormals in this scene).
        assert_eq!(seq_hits, par_hits);
        assert_eq!(seq_occ, par_occ);
        let mut tally = Tally::default();
        for (i, r) in rays.iter().enumerate() {
            tally.check_hit(r, seq_hits[i], batched[i]);
        }
        tally.assert_ok("threaded batches");
        // The accelerator itself can move to another thread and be dropped there.
        std::thread::spawn(move || drop(e)).join().unwrap();
    }

    /// Broken input meshes (non-finite or huge vertices, degenerate triangles) build, and the
    /// good triangles still agree with the oracle (Embree drops invalid primitives).
    #[test]
    fn broken_triangles_are_ignored() {
        let (mut p, mut t) = boxes();
        let n = p.len() as u32;
        p.extend([
            Vec3::new(f32::NAN, 0.0, 0.0),
            Vec3::new(0.0, f32::INFINITY, 0.0),
            Vec3::splat(1e30),
            Vec3::ZERO,
        ]);
        t.extend([[n, n + 3, 0], [n + 1, n + 3, 1], [n + 2, n + 3, 2], [n + 3, n + 3, n + 3], [0, 0, 1]]);
        compare_with_brute(&p, &t, &random_rays(8, 1000), "broken");
    }

    #[test]
    fn empty_scenes_build_and_miss() {
        for (p, t) in [(vec![], vec![]), (vec![Vec3::ZERO, Vec3::X, Vec3::Y], vec![])] {
            let e = Embree::new(&p, &t).unwrap();
            let rays = random_rays(7, 20);
            for r in &rays {
                assert_eq!(e.intersect(r), None);
                assert!(!e.occluded(r));
            }
            let mut hits = vec![None; rays.len()];
            let mut occ = vec![true; rays.len()];
            e.intersect_batch(&rays, &mut hits);
            e.occluded_batch(&rays, &mut occ);
            assert!(hits.iter().all(Option::is_none) && occ.iter().all(|o| !o));
            assert!(e.describe().contains(" 0 triangles"), "{}", e.describe());
            assert_eq!(e.device().error_count(), 0);
        }
        let empty = VertexBuffer::default();
        let a = build_accelerator(Backend::Embree, &empty, &[]).unwrap();
        assert_eq!(a.intersect(&Ray::new(Vec3::ZERO, Vec3::X)), None);
    }

    /// A quick single-thread rate check (not a benchmark): `cargo test --release --test embree
    /// -- --ignored --nocapture rates`.
    #[test]
    #[ignore]
    fn rates() {
        use std::time::Instant;
        let (p, t) = dense();
        let e = Embree::new(&p, &t).unwrap();
        let brute = BruteForce::new(&p, &t);
        let rays = random_rays(9, 200_000);
        let rate = |name: &str, n: usize, f: &mut dyn FnMut() -> usize| {
            let start = Instant::now();
            let hits = f();
            let s = start.elapsed().as_secs_f64();
            println!("{name:32} {:8.3} Mrays/s ({hits} of {n})", n as f64 / s / 1e6);
        };
        set_flush_denormals();
        rate("embree intersect, single", rays.len(), &mut || {
            rays.iter().filter(|r| e.intersect(r).is_some()).count()
        });
        rate("embree occluded, single", rays.len(), &mut || rays.iter().filter(|r| e.occluded(r)).count());
        let mut hits = vec![None; rays.len()];
        let mut occ = vec![false; rays.len()];
        rate("embree intersect, batch", rays.len(), &mut || {
            e.intersect_batch(&rays, &mut hits);
            hits.iter().filter(|h| h.is_some()).count()
        });
        rate("embree occluded, batch", rays.len(), &mut || {
            e.occluded_batch(&rays, &mut occ);
            occ.iter().filter(|o| **o).count()
        });
        let few = &rays[..2000];
        rate("brute intersect, single", few.len(), &mut || {
            few.iter().filter(|r| brute.intersect(r).is_some()).count()
        });
        println!("{}", e.describe());
    }
}
