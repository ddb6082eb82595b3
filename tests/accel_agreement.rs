//! Every backend must agree with the brute-force oracle: same hit or miss, same primitive (or
//! the same distance when two primitives tie on a shared edge), the same distance and
//! barycentrics, and `occluded` equal to "`intersect` found something".

use glam::Vec3;
use pir::accel::testmesh::{self, Mesh};
use pir::accel::{Accelerator, BruteForce, Bvh};
use pir::geometry::Ray;
use pir::sampling::{Domain, Sampler};

/// The backends under test, built over `m`.
fn backends(m: &Mesh) -> Vec<Box<dyn Accelerator>> {
    vec![Box::new(Bvh::new(&m.positions, &m.indices))]
}

fn oracle(m: &Mesh) -> BruteForce {
    BruteForce::new(&m.positions, &m.indices)
}

fn close(a: f32, b: f32, rel: f32) -> bool {
    a == b || (a - b).abs() <= rel * a.abs().max(b.abs()).max(1e-30)
}

/// Checks one ray against the oracle; returns whether it hit.
fn check(acc: &dyn Accelerator, brute: &BruteForce, ray: &Ray, what: &str) -> bool {
    let got = acc.intersect(ray);
    let want = brute.intersect(ray);
    match (got, want) {
        (None, None) => {}
        (Some(g), Some(w)) => {
            assert!(
                close(g.t, w.t, 1e-5),
                "{what}: {} t {} vs brute {} ({ray:?}, {g:?} vs {w:?})",
                acc.name(),
                g.t,
                w.t
            );
            if g.prim == w.prim {
                assert!(
                    (g.u - w.u).abs() < 1e-4 && (g.v - w.v).abs() < 1e-4,
                    "{what}: {} barycentrics {g:?} vs brute {w:?} ({ray:?})",
                    acc.name()
                );
            }
        }
        (g, w) => panic!("{what}: {} gives {g:?}, brute {w:?} for {ray:?}", acc.name()),
    }
    let occ = acc.occluded(ray);
    assert_eq!(occ, want.is_some(), "{what}: {} occluded vs brute intersect for {ray:?}", acc.name());
    assert_eq!(occ, brute.occluded(ray), "{what}: {} occluded vs brute occluded", acc.name());
    want.is_some()
}

/// Checks all `rays` on every backend; returns the number of hits.
fn check_all(m: &Mesh, rays: &[Ray], what: &str) -> usize {
    let brute = oracle(m);
    let mut hits = 0;
    for acc in backends(m) {
        hits = rays.iter().filter(|r| check(acc.as_ref(), &brute, r, what)).count();
        // The batched forms give the same answers.
        let mut batch = vec![None; rays.len()];
        acc.intersect_batch(rays, &mut batch);
        let mut occ = vec![false; rays.len()];
        acc.occluded_batch(rays, &mut occ);
        for (i, r) in rays.iter().enumerate() {
            assert_eq!(batch[i], acc.intersect(r), "{what}: batch");
            assert_eq!(occ[i], batch[i].is_some(), "{what}: occluded batch");
        }
    }
    hits
}

fn sampler(k: u64) -> Sampler {
    Sampler::new(0xB1A5, 0, Domain::Iteration, k)
}

#[test]
fn cornell_random_rays_agree() {
    let m = testmesh::cornell_like();
    let rays = testmesh::random_rays(&m.bounds(), 20_000, 1);
    // The box is closed: every ray from inside hits something.
    assert_eq!(check_all(&m, &rays, "cornell random"), rays.len());
}

#[test]
fn cornell_segments_and_gather_agree() {
    let m = testmesh::cornell_like();
    let segs = testmesh::random_segments(&m.bounds(), 20_000, 2);
    let hits = check_all(&m, &segs, "cornell segments");
    assert!(hits > 0 && hits < segs.len(), "{hits} of {} segments blocked", segs.len());
    let gather = testmesh::gather_rays(&m, Vec3::new(0.5, 0.9, 0.5), 4_096, 3);
    check_all(&m, &gather, "cornell gather");
}

#[test]
fn dense_sphere_agrees() {
    let m = testmesh::sphere(70, 140);
    assert!(m.indices.len() > 19_000);
    let b = m.bounds();
    // Origins inside and around the sphere.
    let grown = pir::geometry::Aabb { min: b.min * 1.5, max: b.max * 1.5 };
    let rays = testmesh::random_rays(&grown, 3_000, 4);
    let hits = check_all(&m, &rays, "sphere random");
    assert!(hits > 500, "{hits} hits");
    let segs = testmesh::random_segments(&grown, 3_000, 5);
    check_all(&m, &segs, "sphere segments");
}

#[test]
fn dense_heightfield_agrees() {
    let m = testmesh::heightfield(100);
    assert_eq!(m.indices.len(), 20_000);
    // Rays from above, mostly downwards and some nearly grazing.
    let rays: Vec<Ray> = (0..3_000)
        .map(|k| {
            let mut s = sampler(k);
            let o = Vec3::new(2.4 * s.next_f32() - 1.2, 0.5, 2.4 * s.next_f32() - 1.2);
            let mut d = testmesh::uniform_direction(&mut s);
            d.y = -d.y.abs() * if k % 4 == 0 { 0.05 } else { 1.0 };
            Ray::new(o, d)
        })
        .collect();
    let hits = check_all(&m, &rays, "heightfield");
    assert!(hits > 500, "{hits} hits");
}

#[test]
fn rays_starting_on_surfaces_agree() {
    for m in [testmesh::cornell_like(), testmesh::sphere(40, 80)] {
        let rays: Vec<Ray> = (0..5_000)
            .map(|k| {
                let mut s = sampler(k);
                let (p, _) = testmesh::point_on_mesh(&m, &mut s);
                Ray::new(p, testmesh::uniform_direction(&mut s))
            })
            .collect();
        check_all(&m, &rays, "from surface");
    }
}

#[test]
fn rays_through_vertices_and_edges_agree() {
    for m in [testmesh::cornell_like(), testmesh::sphere(30, 60)] {
        let b = m.bounds();
        let rays: Vec<Ray> = (0..6_000)
            .map(|k| {
                let mut s = sampler(k);
                let tri = m.triangle(k as usize % m.indices.len());
                // A vertex, an edge midpoint or a point on an edge.
                let target = match k % 3 {
                    0 => tri[(k / 3) as usize % 3],
                    1 => (tri[0] + tri[1]) * 0.5,
                    _ => tri[1].lerp(tri[2], s.next_f32()),
                };
                let o = testmesh::point_in(&b, &mut s);
                Ray::new(o, target - o)
            })
            .collect();
        check_all(&m, &rays, "vertices and edges");
    }
}

#[test]
fn axis_aligned_directions_agree() {
    let m = testmesh::cornell_like();
    let dirs = [Vec3::X, -Vec3::X, Vec3::Y, -Vec3::Y, Vec3::Z, -Vec3::Z, Vec3::new(0.0, -0.0, -1.0)];
    let mut rays = Vec::new();
    for k in 0..2_000u64 {
        let mut s = sampler(k);
        let mut o = testmesh::point_in(&m.bounds(), &mut s);
        // Snap some coordinates onto the wall grid (multiples of 1/4): rays in the planes of
        // box faces and along mesh edges.
        if k % 2 == 0 {
            o.x = (o.x * 4.0).round() / 4.0;
        }
        if k % 3 == 0 {
            o.y = (o.y * 4.0).round() / 4.0;
        }
        if k % 5 == 0 {
            o.z = (o.z * 4.0).round() / 4.0;
        }
        rays.push(Ray::new(o, dirs[k as usize % dirs.len()]));
        // Two zero components out of three, plus a diagonal in an axis plane.
        rays.push(Ray::new(o, Vec3::new(1.0, 0.0, -1.0)));
    }
    // Rays lying in the floor and wall planes.
    rays.push(Ray::new(Vec3::new(0.5, 0.0, 0.5), Vec3::X));
    rays.push(Ray::new(Vec3::new(0.0, 0.5, 0.5), Vec3::Z));
    rays.push(Ray::new(Vec3::new(0.0, 0.0, 0.5), -Vec3::Z));
    rays.push(Ray::new(Vec3::new(1.0, 1.0, 1.0), -Vec3::X));
    check_all(&m, &rays, "axis directions");
}

#[test]
fn interval_edge_cases_agree() {
    let m = testmesh::cornell_like();
    let base = testmesh::random_rays(&m.bounds(), 2_000, 6);
    let brute = oracle(&m);
    let mut rays = Vec::new();
    for r in &base {
        let t = brute.intersect(r).expect("closed box").t;
        let with = |tmin: f32, tmax: f32| Ray { tmin, tmax, ..*r };
        rays.extend([
            with(0.0, 0.0),
            with(0.5 * t, 0.5 * t),
            with(t, t),
            with(0.0, t),           // open interval: the hit at t itself is excluded
            with(t, f32::INFINITY), // likewise at the start
            with(0.0, f32::INFINITY),
            with(0.0, f32::MAX),
            with(0.5 * t, 2.0 * t),
            Ray::segment(r.origin, r.dir * t, 1.0 - 1e-4),
        ]);
    }
    check_all(&m, &rays, "interval edges");
    // An empty interval never hits.
    for acc in backends(&m) {
        for r in &base {
            let empty = Ray { tmin: 0.3, tmax: 0.3, ..*r };
            assert!(acc.intersect(&empty).is_none() && !acc.occluded(&empty));
        }
    }
}

#[test]
fn invalid_rays_miss() {
    let m = testmesh::cornell_like();
    let o = Vec3::splat(0.5);
    let invalid = [
        Ray::new(Vec3::new(f32::NAN, 0.5, 0.5), Vec3::X),
        Ray::new(o, Vec3::ZERO),
        Ray::new(o, Vec3::new(-0.0, 0.0, -0.0)),
        Ray::new(o, Vec3::new(f32::NAN, 1.0, 0.0)),
        Ray::new(o, Vec3::new(f32::INFINITY, 1.0, 0.0)),
        Ray::new(Vec3::new(f32::INFINITY, 0.5, 0.5), -Vec3::X),
        Ray { tmin: -1.0, ..Ray::new(o, Vec3::X) },
        Ray { tmin: 2.0, tmax: 1.0, ..Ray::new(o, Vec3::X) },
        Ray { tmax: f32::NAN, ..Ray::new(o, Vec3::X) },
        Ray { tmin: f32::NAN, ..Ray::new(o, Vec3::X) },
    ];
    for acc in backends(&m) {
        for r in &invalid {
            assert!(acc.intersect(r).is_none(), "{}: {r:?} hit", acc.name());
            assert!(!acc.occluded(r), "{}: {r:?} occluded", acc.name());
        }
    }
}

#[test]
fn empty_and_degenerate_scenes() {
    let rays = testmesh::random_rays(&testmesh::cornell_like().bounds(), 500, 7);
    let empty = Mesh::default();
    for acc in backends(&empty) {
        assert!(rays.iter().all(|r| acc.intersect(r).is_none() && !acc.occluded(r)));
        assert!(!acc.describe().is_empty());
    }
    // Zero-area triangles: repeated vertices, collinear vertices, a triangle of one point,
    // and triangles with non-finite vertices.
    let positions = vec![
        Vec3::new(0.1, 0.1, 0.1),
        Vec3::new(0.9, 0.9, 0.9),
        Vec3::new(0.5, 0.5, 0.5),
        Vec3::new(0.2, 0.8, 0.3),
        Vec3::new(f32::NAN, 0.0, 0.0),
        Vec3::new(f32::INFINITY, 0.0, 0.0),
    ];
    let indices = vec![[0, 1, 2], [0, 0, 1], [3, 3, 3], [2, 1, 0], [4, 0, 1], [5, 0, 1], [4, 5, 3]];
    let degenerate = Mesh { positions, indices };
    check_all(&degenerate, &rays, "degenerate");
    // Rays along the degenerate segment itself.
    let along = [
        Ray::new(Vec3::ZERO, Vec3::ONE),
        Ray::new(Vec3::splat(0.5), Vec3::new(1.0, 0.0, 0.0)),
        Ray::new(Vec3::new(0.2, 0.8, 0.0), Vec3::Z),
    ];
    check_all(&degenerate, &along, "degenerate along");
}

#[test]
fn hits_report_original_triangle_indices() {
    let m = testmesh::sphere(20, 40);
    let bvh = Bvh::new(&m.positions, &m.indices);
    for k in 0..500u64 {
        let mut s = sampler(k);
        let (p, tri) = testmesh::point_on_mesh(&m, &mut s);
        // From the centre through a point inside a triangle: the sphere is star-shaped, so the
        // first hit is that triangle.
        let h = bvh.intersect(&Ray::new(Vec3::ZERO, p)).expect("hit");
        let [a, b, c] = m.triangle(h.prim as usize);
        let q = a * (1.0 - h.u - h.v) + b * h.u + c * h.v;
        assert!((q - p).length() < 1e-4, "prim {} vs {tri}: {q} vs {p}", h.prim);
        assert!((h.t - 1.0).abs() < 1e-4);
    }
}

#[test]
fn scenes_far_from_the_origin_agree() {
    // Large coordinates make float spacing coarse relative to the scene: the box test's
    // padding must still never cull a triangle that the triangle test hits.
    let mut m = testmesh::cornell_like();
    for p in &mut m.positions {
        *p = *p * 100.0 + Vec3::new(1.0e4, -5.0e3, 2.0e3);
    }
    let b = m.bounds();
    let mut rays = testmesh::random_rays(&b, 5_000, 10);
    for k in 0..5_000u64 {
        let mut s = sampler(k);
        let tri = m.triangle(k as usize % m.indices.len());
        let target = if k % 2 == 0 { tri[(k / 2) as usize % 3] } else { tri[0].lerp(tri[2], s.next_f32()) };
        let o = testmesh::point_in(&b, &mut s);
        rays.push(Ray::new(o, target - o));
        rays.push(Ray::segment(o, target - o, 1.0));
    }
    check_all(&m, &rays, "far from origin");
}
