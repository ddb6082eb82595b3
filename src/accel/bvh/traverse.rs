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
//! **Any-hit's order for three or more hit children (2026-12-05).** The conference room
//! (`scenes/conference-room`, 331k triangles, added to `accel_ratio` for this) showed the
//! nearest-first order at its worst: the BVH ran its gather pattern at 0.60 of Embree's rate,
//! and Embree's own order (lane order: the last hit lane entered, the others pushed, no
//! distances) at 0.87. Lane order lost elsewhere, though (the 1M scene's gather 1.43 → 0.93).
//! The room's wall-, floor- and table-sized triangles make large, overlapping boxes, many of
//! which a ray crosses from near its start to far along it; entered first by nearest entry,
//! they cost much and rarely hold the occluder. Ranking three or more hit children by exit
//! distance instead puts the boxes the ray leaves soonest first, and the long crossings last.
//! Two children keep the entry order (by exit, the bunny's gather fell 0.958 → 0.920). Binaries
//! alternating, `RAYS=3000000 accel_ratio ratio SCENE WORKLOAD 7`, two runs each, medians, BVH
//! over Embree's rate, entry → exit order for three or more:
//! - gather pattern: conference room 0.604 → 0.752 (0.770 in a third run), 1M scene 1.426 →
//!   1.486, bunny 0.948 → 0.938 (0.933 → 0.938 in a third pair), dragon 0.984 → 0.984, box
//!   1.000 → 0.974 (its runs scatter by ±3 %);
//! - occlusion: conference room 0.908 → 0.906, 1M scene 0.893 → 0.971, bunny 0.867 → 0.887,
//!   dragon 0.833 → 0.841, box 0.891 → 0.891.
//!
//! Two hit children at the same entry distance (typically both boxes hold the ray's origin,
//! which makes their entries `tmin`) were entered in lane order, the higher lane first. By exit
//! distance instead, on top of the above (same command, two runs for the gather pattern, one
//! for occlusion): gather pattern bunny 0.929 → 1.022, dragon 0.984 → 1.050, 1M scene 1.374 →
//! 1.574, conference room 0.746 → 0.766, box 1.026 → 1.028; occlusion bunny 0.898 → 0.885,
//! dragon 0.861 → 0.851, 1M scene 0.975 → 0.970, conference room 0.917 → 0.897, box 0.891 →
//! 0.877 (single runs, within their scatter). A gather point in open space lies inside many
//! of the upper levels' boxes, whose entries are then all `tmin`.
//!
//! Measured the same day for three or more, one run each (conference room, bunny, 1M scene
//! gather): lane order 0.85, 0.98, 1.01; the farthest entry first 0.65, 0.51, 0.71; the longest
//! crossing (exit − entry) first 0.57, 0.77, 1.20, the shortest first 0.70, 0.72, 0.87; the
//! crossing's midpoint 0.56, 0.89, 1.28; lane order for any number of hit children 0.87, 0.90,
//! 0.93.
//!
//! Lane order for three or more hit children, measured again on top of today's rules for two
//! (2026-12-05, evening, not kept): the highest hit lane entered, the others pushed in lane
//! order, as Embree's kernel does. `RAYS=3000000 accel_ratio ratio SCENE WORKLOAD 5`, two runs
//! each, exit order → lane order: it is the largest gain found for the conference room and the
//! occlusion workloads (conference room gather 0.77 → 0.84–0.88, occlusion dragon 0.85–0.87 →
//! 0.91–0.94, bunny 0.88 → 0.93, 1M scene 0.94–0.99 → 1.01; bunny gather 1.01–1.03 →
//! 1.03–1.05), but the dragon's gather pattern falls 1.04 → 0.95 and the 1M scene's 1.38–1.57 →
//! 0.99–1.00, two of issue 15's bars. Halfway forms lost everywhere or kept both losses (one
//! run each; conference room gather, 1M scene and dragon gather, dragon occlusion, bunny
//! gather): lane order for four or more hit children only 0.78, 1.08, 1.00, 0.87, 1.02, for
//! three only 0.80, 1.37, 0.96, 0.88, 1.00; exit distances rounded to a power of two (ties in
//! lane order) 0.73, 0.87, 0.84, 0.81, 0.89, to two mantissa bits 0.73, 1.31, 0.90, 0.74, 0.92;
//! the boxes that hold the ray's origin (entry at `tmin`) by exit and the others in lane order,
//! after them 0.73, 1.08, 0.84, 0.79, 0.89, before them 0.77, 0.88, 0.84, 0.79, 0.88. Lane
//! order for the batched queries only (`occluded_batch`, which the renderer's gathers call; the
//! single-ray query kept the exit order, and with it the bars): the renderer's gather (`pir
//! render SCENE --method pir-clamp --threads 1 --spp 2 --accel bvh`, two runs each,
//! alternating, shadow rays a second) went 4.46 → 4.64 M in the conference room, 15.7 → 16.2 M
//! in the Cornell box, 11.7 → 11.9 M in the bunny's Cornell box, and stayed level in
//! `scenes/dense/indirect.toml` (8.14 → 8.06, 8.20), with the dragon in that box (9.58, 9.41 →
//! 9.88, 9.15) and with the 1M scene's bumpy sphere there (6.95, 6.96 → 7.29, 6.87); the accel
//! bench's batched gather pattern (`gather-batch`, against Embree's packets) went 0.58 → 0.64
//! (conference room) and 0.60 → 0.70 (box), but 0.88 → 0.81 (dragon) and 1.33 → 0.86 (1M
//! scene). 2–4 % on half the scenes measured, against a second any-hit order to keep and a
//! third of the batched rate lost on one pattern: not kept.
//!
//! Leaf children first, measured again on today's order (2026-12-05, not kept): any-hit's key
//! for a leaf lane `−1 / exit` (every leaf before every interior child, leaves by exit among
//! themselves), in the hope that the conference room's large triangles, which the SAH leaves in
//! leaves high up, would be tried first. Gather pattern, `RAYS=3000000 accel_ratio ratio SCENE
//! gather 5` (two runs each), without → with: conference room 0.765 → 0.728, bunny 1.011 →
//! 0.925, dragon 1.042 → 0.957, 1M scene 1.555 → 1.454.
//!
//! **Where the time goes, and two changes to the AVX versions (2026-12-05).** On the AMD EPYC
//! (Zen 4) machine, with `accel_ratio`'s `SPLIT` and `REPEAT` (see its docs): the bunny's
//! gather pattern is 73 % occluded rays, at 0.91 of Embree's rate, and 27 % unoccluded ones, at
//! 0.83, which test 2.45 leaves (3.6 packs) each. With every ray traced eight times in a row
//! (caches warm) the BVH fell to 0.79 of Embree's rate, so what it lacks is work per ray, not
//! memory traffic; and with the triangle tests of the unoccluded rays skipped (a timing
//! experiment: their answer is "no hit" either way) it ran at 1.27 of Embree's full rate, so
//! the leaves took a third of the time. Kept:
//! - The box test's minima and maxima of the AVX versions are taken of the distances' bits as
//!   integers (see [`RayBoxes::enter`]), a cycle each on the node-to-node chain instead of two
//!   or more.
//! - A two-pack leaf is tested eight lanes at once ([`hit_pair_avx`]) instead of as two packs:
//!   half the arithmetic, and one branch on the result instead of two.
//!
//! `accel_ratio ratio SCENE WORKLOAD 7` with 3 M rays a round, binaries alternating, two runs
//! each, BVH/Embree rate before (popcnt enabled) → after: integers alone, gather pattern bunny
//! 0.910 → 0.939, dragon 0.954 → 0.977 (the dragon's occlusion 0.850 → 0.819 and closest hit
//! 1.074 → 1.006, within these runs' scatter: the comparison below has them higher); the
//! two-pack test on top, gather bunny 0.920 → 0.938, dragon 0.984 → 1.000, closest hit bunny
//! 1.00 → 1.035. All three changes of the day (with `popcnt`, below) against the traversal
//! before them, same command: gather pattern bunny 0.884 → 0.948, dragon 0.933 → 1.008, 1M
//! scene 1.335 → 1.426, box 0.905 → 0.975; occlusion 0.845 → 0.874, 0.826 → 0.838, 0.953 →
//! 1.031, 0.851 → 0.905; closest hit 1.035 → 1.036, 1.000 → 1.030, 1.051 → 1.122, 1.000 →
//! 1.097. Measured and not kept
//! the same day: the mask, too, from an integer comparison (`vpcmpd` to a mask register; one
//! more ray splat spilled to the stack, gather 2–3 % slower); Embree's fused form of the slab
//! test in the AVX-512 version, with its 32 registers (unguarded, so not conservative: only to
//! see the gain, which was none, gather 0.930 → 0.919); one 8-lane test for every leaf, a
//! one-pack leaf's pack tested twice, to save the branch on the pack count (gather 0.958 →
//! 0.910, bunny, and 1.000 → 0.977, dragon); lane order instead of the nearest first for two
//! hit children (bunny gather 0.92 → 0.84, dragon 0.97 → 0.91, occlusion level).
//!
//! **Instructions on par with Embree's AVX-512 kernel (2026-12-05, later).** Counted with
//! `docs/stepcount.py`, which single-steps the real code in gdb (valgrind cannot run AVX-512):
//! the first 256 rays of the bunny's gather pattern take 819 instructions each in this
//! traversal's AVX-512 version, from the dispatch on, and 794 in Embree's, from
//! `rtcOccluded1` on. This traversal visits fewer nodes (6.7 a ray against 7.6) and tests more
//! packs (2.9, a two-pack leaf counted as two, against 2.36). (After any-hit's exit order,
//! above: 849 against 794, and 658 against 577 for random segments, though the gather pattern
//! runs faster than it did with 819. The dragon's random segments: 763 against 639, with 6.66
//! node visits a segment against Embree's 6.84, the node test 34 instructions against 24.)
//! Embree's kernel, read from the same trace:
//! - the slab test in the FMA form, and the entry-exit comparison on the integer bits into a
//!   mask register (`vpcmpled`);
//! - any-hit in lane order: the last hit lane entered, the others pushed unsorted, every child
//!   prefetched;
//! - a four-wide leaf test that checks `U`, `V` and the determinant first and leaves before
//!   computing `T` when no lane passes.
//!
//! With each ray traced eight times in a row (caches warm, `REPEAT=8`) the BVH now runs at 0.89
//! and 0.90 of Embree's rate (0.79 before the changes above), 0.94–0.95 cold. So what is left
//! lies in how fast the same number of instructions runs (mispredicted branches, the
//! node-to-node chain), which this VM cannot measure: it has no performance counters.
//!
//! Measured the same day, not kept (binaries alternating, `RAYS=3000000 accel_ratio ratio
//! SCENE WORKLOAD 7`, two or three runs, medians, before → after):
//! - Embree's leaf exit before `T` (the same hits: a lane that fails `u`, `v` or the
//!   determinant fails either way). Bunny gather 0.939 → 0.939, occlusion 0.874 → 0.889, but
//!   the box's gather 1.027 → 0.863 and 0.950: its large triangles pass `u` and `v` often, and
//!   the exit branch then mispredicts.
//! - Any-hit as a loop down the nodes with the leaf test after it, as Embree's kernel has it,
//!   so that reaching a child by descent and by a pop are separate branches: bunny gather
//!   0.948 → 0.952, the box's 1.027 → 0.974.
//! - Both: bunny gather 0.939 → 0.949, dragon 0.976 → 0.992, the box's gather 1.027 → 0.905
//!   and occlusion 0.879 → 0.826.
//! - The FMA slab test in the AVX versions on top of both, without the guards that make it
//!   conservative (only to see the gain), compiled to six `vfmadd` per node: bunny gather
//!   0.949 → 0.948. Two cycles fewer on the node-to-node chain bought nothing measurable.
//! - Two prefetched lines instead of four: bunny gather 0.937 → 0.951, dragon occlusion
//!   0.829 → 0.799.
//!
//! **The dragon's random segments (2026-12-05, afternoon),** the workload whose ratio to
//! Embree varies most between runs. Split by brute force (`SPLIT`), the 69 % of segments that
//! are occluded run at 0.85 of Embree's rate and the others at 0.97; with caches warm
//! (`REPEAT=8`) the whole workload runs at 0.88 and its occluded segments at 0.85, so the gap
//! is work per segment, not memory: 763 instructions against Embree's 639 (`stepcount.py`,
//! the first 256 segments), of which the node tests take 226 against 164 (34 instructions a
//! node against 24, as many nodes) plus some 50 of dispatch and loads of the next child, the
//! ranks and pushes of three or more hit children about 130 (once a segment, 3.4 children),
//! the setup 114 against Embree's 127 (its API checks included), the leaves 97 against 105.
//! The work per segment also decides how the ratio moves when the machine is busy: with a
//! loop of fused multiply-adds running on the VM's other core (`taskset`, so not on the same
//! virtual core) the BVH's rate fell by 14 % (4.0 → 3.45 M segments a second) and Embree's by
//! 7 % (4.4 → 4.1), ratio 0.90 → 0.87 (two runs each way). A memory-bound loop there (random
//! reads over 512 MB) slowed both by 13 %, ratio 0.905 → 0.877; one over 16 MB, 0.915.
//! Measured the same day, not kept (binaries alternating, `RAYS=3000000 accel_ratio ratio
//! dragon occluded 7`, three runs, medians):
//! - The fused slab test with the same inverse direction for both planes and one product of
//!   origin and inverse per axis (nine broadcast values, as many as the unfused test holds, so
//!   nothing spills; not conservative without guards, only to bound the gain): 0.857 → 0.873,
//!   warm 0.889 → 0.915. Guards that make it conservative (the product moved outwards by the
//!   rounding of the largest distance that matters, a per-ray fallback to the unfused form for
//!   rays whose product overflows) would take part of that 2–3 % back. The first try, with
//!   twelve broadcast values (a widened inverse for the far planes), spilled six of them to the
//!   stack and ran at 0.815 against 0.901.
//! - For three or more hit children, only the one the ray leaves first found (a horizontal
//!   minimum) and the others pushed in lane order: dragon occlusion 0.864 → 0.801, bunny
//!   gather 1.009 → 1.024. The order of the deferred children matters on these segments.
//! - Ranks from unique keys (a distance's bits with its lane in the lowest three, so one
//!   comparison a lane instead of two both ways: 16 instructions a hit child instead of 21):
//!   dragon occlusion 0.855 → 0.809, bunny gather 1.017 → 0.951, conference room gather 0.764
//!   → 0.735, 1M scene gather 1.534 → 1.514 (one run each for the last two). The keys are made
//!   before the first rank, and the ranks are on the chain from the node test to the next node
//!   (the child to visit is read back from the top of the stack they write).
//! - That child taken from the ranks instead (a conditional move on `rank == k − 1`), off the
//!   stack's store and reload: dragon occlusion 0.813 → 0.823 and 0.909 → 0.825 (two series of
//!   three pairs, medians), bunny gather 1.031 → 1.038, conference room gather 0.777 → 0.799
//!   (one run): no gain on the workload it was for.
//! - The plane distances as `(o − plane) · (−inv)` instead of `(plane − o) · inv`: the same
//!   distances bit for bit but for the sign of a zero (rounding is symmetric), and the node's
//!   plane is then the subtraction's second operand, so its load folds into it: six
//!   instructions fewer per node (the AVX-512 any-hit compiled to `vsubps (mem)`). Dragon
//!   occlusion 0.884 → 0.871 (six alternating pairs, medians), bunny gather 1.003 → 1.013,
//!   1M scene occlusion 0.969 → 0.979, dragon closest hit 1.016 → 0.992 (three and two pairs):
//!   nothing beyond the runs' scatter, like every other cut in the node test's instructions.
//!
//! **Sorting without a branch per comparison (2026-12-04).** Two hit children take one
//! comparison. Three or more were sorted by insertion, whose inner loop ends after a number of
//! steps that depends on the distances; valgrind's branch simulation counted 9.4 mispredicted
//! branches per occlusion ray on the bunny against Embree's 7.3, 1.3 of them in that loop. Each
//! hit child now goes straight to its slot: its rank is the number of hit children farther than
//! it, or as far and in an earlier lane (its distance compared with all lanes both ways by the
//! box test's 8-wide mask, and a popcount), which gives the same order. Same trees, same hits; 3.6 % fewer
//! instructions (bunny occlusion 55.7 → 53.8 M under callgrind), and on the AMD EPYC (Zen 4)
//! machine, `RAYS=1000000 accel_ratio ratio SCENE WORKLOAD 5`, two pairs of runs, old → new
//! BVH/Embree rate: occlusion bunny 0.71, 0.74 → 0.80, 0.82, dragon 0.74, 0.71 → 0.81, 0.80;
//! closest hit bunny 0.93, 0.93 → 0.97, 0.98, dragon 0.93, 0.93 → 1.02, 0.97; the gather pattern
//! bunny 0.84, 0.84 → 0.72, 0.81 (0.84 in two later runs), dragon 0.86, 0.88 → 0.89, 0.88.
//! Ranking two hit children as well (no branch on the count) was worse everywhere: occlusion
//! 0.81 → 0.71–0.77 (bunny), 0.82–0.85 → 0.67–0.70 (dragon), gather 0.84 → 0.72–0.74 and 0.88
//! → 0.79. So was one branch-free path for one and two hit children (the second lane the
//! mask's highest bit, the farther child always written and the stack pointer advanced by 0 or
//! 1), with the AVX-512 version below: valgrind's simulation counted 40 % fewer mispredicted
//! branches, but the machine ran the gather pattern at 0.86, 0.88 → 0.80, 0.80 (bunny) and
//! 0.91, 0.89 → 0.85, 0.80 (dragon) of Embree's rate and the rest level to 7 % slower: the hardware
//! predicts that branch far better than the simulation does.
//!
//! Measured the same day, before the ranks, and not kept: a tree whose leaves are split further
//! while the wide node they land in has free lanes (Embree's builder does this: a node, once split,
//! splits its largest children until it has eight, whatever the SAH says of a child; pir's binary
//! SAH made a leaf of up to eight triangles whenever it was cheaper than a split, and the collapse
//! never opens a leaf). With such "soft" splits, undone into one leaf where the wide node is full,
//! the trees' statistics matched Embree's own (`verbose=2`: bunny 17,698 leaves against 17,779, SAH
//! of the leaves 2.54 against 2.55 instead of 3.36; dragon 4.19 against 4.10 instead of 4.91),
//! instructions fell 2–3 %, and the rates did not move (occlusion bunny 0.72, 0.71 → 0.73, 0.73;
//! dragon 0.74, 0.72 → 0.72, 0.69; closest hit 1–8 % lower). The slab test's minimum-and-maximum
//! form (see below) was measured again on this machine: 10 % fewer instructions, occlusion bunny
//! 0.74, 0.73 → 0.72, 0.72, dragon 0.75, 0.73 → 0.67, 0.70.
//!
//! **AVX-512 at run time (2026-12-04).** A third version of the two entry points is compiled
//! for AVX-512, which `multiversion` picks only on CPUs with Ice Lake's set of AVX-512
//! extensions or more (it leaves out the older server CPUs that slow down under AVX-512). The
//! code is the same; the version has 32 vector registers, so the ray's splatted origin and
//! inverse direction stay in registers instead of being reloaded from the stack at every node.
//! On the AMD EPYC (Zen 4) machine, after the ranks above, two pairs of runs, AVX2 → AVX-512
//! version: occlusion bunny 0.81, 0.81 → 0.86, 0.84, dragon 0.79, 0.80 → 0.83, 0.82; gather
//! pattern bunny 0.84, 0.85 → 0.86, 0.86, dragon 0.86, 0.89 → 0.93, 0.93; closest hit bunny
//! 0.95, 0.95 → 0.97, 1.00, dragon 1.00, 0.97 → 0.98, 1.00. On the Intel machine kind an
//! earlier measurement (before the ranks) was level on average (below); not measured there
//! since. Any-hit used
//! the same nearest-first order then (see above for three or more hit children) and stops at
//! the first hit: visiting children unordered was
//! about 1.3× faster for random segments but 2.3× slower for the gather pattern (one point to
//! many surface points), which is the renderer's hot loop; testing a node's leaf children
//! before its interior ones did not pay either, nor did pushing the children other than the
//! nearest unsorted. Embree's any-hit order was measured too (2026-12-02): lanes sorted at
//! collapse time by subtree size, largest first, and the last hit lane entered with the others
//! pushed unsorted, so that the smallest subtree is tried first. On random segments it cut the
//! instructions per ray by 6–10 % and the (simulated) branch mispredictions by a fifth on the
//! bunny and dragon and ran 1.1–1.25× as fast there, but on the 1M scene it visited 8 % more
//! nodes for random segments and 30 % more (with 1.6× the leaf packs) for the gather pattern,
//! which ran at 0.65–0.75× the nearest-first rate; nearest-first for two hit children and lane
//! order for more lost about as much on the gather. Batches are traced ray by ray (the BVH's
//! `occluded_batch` borrows the tree's arrays once and calls the single-ray query): a packet traversal of up to 64 rays sharing node visits (a ray
//! mask per stack entry, each ray tested with this box test; 1.36× the instructions per ray)
//! ran the gather pattern at 0.66–0.76× the single-ray rate on the bunny, dragon and 1M scene
//! (1.4× on the 296-triangle box), 0.4–0.6× with the rays sorted by direction octant first;
//! tracing each batch of 64 one by one in direction order was slower than in the given order
//! too.
//!
//! Interleaved rays were measured too (2026-12-04): `occluded_batch` tracing eight rays of a
//! batch at once, each a traversal paused between node visits and taking a step in turn, so
//! that one ray's wait for its next node is filled by the others' work (batches of fewer than
//! 16 ray by ray). On the benchmark's incoherent rays it paid: BVH rates, one thread, median of
//! five rounds of 2 M rays (`RAYS=2000000 accel_ratio ratio SCENE WORKLOAD 5`), ray by ray →
//! interleaved: random segments, bunny 4.92 → 6.07, dragon 3.07 → 4.51 M rays/s (0.79, 0.98
//! and, on the 1M scene, 0.88 of Embree's 16-wide packets); gather pattern, bunny 5.55 → 6.17,
//! dragon 3.99 → 4.76. In the renderer it did not: `pir-clamp --accel bvh`, whose gather queues
//! every VPL of the iteration from one point in batches of 64, gathered at 0.93–0.96× the rate
//! on the bunny's Cornell box and `scenes/dense/indirect.toml` with two threads (1.04× and
//! 0.93× with one; four and two rays at a time: 0.94–1.0×). Rays from one point share their
//! nodes, which stay in cache, so there is little wait to fill, and each step reloads its ray's
//! state from memory. Not kept.
//!
//! An occluder cache for batches was measured too (2026-12-05, not kept): `occluded_batch`
//! testing first the leaf in which the batch's last occluded ray had found its hit (the same
//! answers: a hit there is a hit, and otherwise the whole tree is searched), after the shadow
//! caches of classic ray tracers, since a gather's rays leave one point. The rays of one
//! receiver do not share occluders often enough to pay for the extra leaf test: `RAYS=1000000
//! accel_ratio ratio SCENE gather-batch 5` (two runs each, BVH over Embree's 16-wide packets),
//! without → with the cache, box 0.60 → 0.51, bunny 0.79 → 0.70, dragon 0.88 → 0.79, 1M scene
//! 1.45 → 1.35, conference room 0.59 → 0.56; in the renderer (`pir render SCENE --method
//! pir-clamp --threads 1 --spp 2 --resolution 256 256 --accel bvh`, two runs each) the gather's
//! shadow rays a second went 15.4 → 14.5 M (Cornell box), 4.43 → 4.23 M (conference room; 4.40
//! against Embree's 5.72 M in the README's later runs) and 8.1 → 7.5 M
//! (`scenes/dense/indirect.toml`).
//!
//! Octant-ordered lanes (Ylitie, Karras and Laine's compressed wide BVH) were measured too
//! (2026-12-04): at collapse each child takes the lane of the direction octant for which it
//! comes earliest (greedy on its centre's offset along the octant's diagonal), and any-hit
//! visits its hit lanes in the order `position ^ octant` with no distances: 1.2× the
//! instructions of nearest-first on the bunny's random segments and 1.37× on its gather
//! pattern. With nearest-first kept for two hit children and the octant order for three or
//! more, occlusion took 4–6 % fewer instructions on the bunny and dragon and ran 1.0–1.07×
//! as fast (interleaved `accel_ratio`, three runs of 15 rounds), but the 1M scene's gather
//! pattern fell from 1.48 to 0.97× Embree's rate in the same runs: not kept.
//!
//! **AVX2 at run time.** The default build targets plain x86-64 (SSE2), where eight lanes take two
//! 4-wide operations. The two entry points are therefore compiled more than once with the
//! `multiversion` crate, once more for AVX2 + FMA (and for AVX-512: see above), and the version the
//! CPU supports is picked at run time (safe code; the choice is cached). The box test is written as
//! plain loops over `[f32; 8]` lanes, which LLVM turns into one `ymm` operation per plane in the
//! AVX2 version, except the lanes' mask, which that version takes from one 8-wide comparison
//! ([`mask_avx`], an intrinsic called where AVX is enabled): with the mask made from two 4-lane
//! halves, as the SSE2 version does, LLVM also computed the exit distances in halves, and a node's
//! test took about 60 instructions instead of 38. Under callgrind the bunny's occlusion went from
//! 61.5 to 55.7 M instructions; interleaved `accel_ratio` rounds (2026-12-04, one thread, 1 M rays,
//! median of five) gave closest hit 0.80 → 0.83 (bunny), 0.76 → 0.80 (dragon), 0.78 → 0.83 (1M
//! scene) of Embree's rate, the bunny's occlusion 0.73 → 0.77 and its gather pattern 0.83 → 0.89;
//! the dragon's and the 1M scene's occlusion and gather, which wait on memory, level. A third
//! version for AVX-512 (F, BW, VL, DQ), which this machine kind's Intel CPUs have, was measured
//! there the same day and not kept then: bunny occlusion 0.74 → 0.71 and closest hit 0.77 → 0.73,
//! dragon 0.70 → 0.72 and 0.74 → 0.77 (it is now, see above). Nor was a traversal specialised for
//! each of the eight direction octants (the near and far planes' offsets constants, a match on the
//! octant per ray, eight copies of the loop): interleaved `accel_ratio` rounds, current →
//! specialised, closest hit 0.83 → 0.74 (bunny), 0.84 → 0.76 (dragon), 0.84 → 0.80 (1M scene),
//! occlusion 1–4 % lower, the gather pattern 0.91 → 0.93, 0.94 → 1.05, 1.66 → 1.71. All versions
//! give identical hits: their arithmetic is the same IEEE operations (Rust never fuses a
//! multiply and an add on its own), their integer minima and maxima give the same entries and
//! masks but for boxes behind the ray ([`RayBoxes::enter`]), and [`hit_pair_avx`] the lanes of
//! two [`Tri4::hit`]s. The AVX2 and AVX-512 versions also prefetch the children they push, on
//! trees larger than a core's L2 cache: traversal mostly waits on node and leaf loads, and a
//! deferred child is usually visited later (always by any-hit). That gave 1.05–1.2× on the bunny,
//! dragon and 1M scene and cost a few percent on a tiny scene, hence the size threshold.
//!
//! The slab test picks each axis' near and far planes from the direction's sign, as an index
//! (`bounds[axis][negative]`, the minima and maxima of an axis being adjacent arrays) rather
//! than a select of two addresses per axis and node: 3 % fewer instructions for the bunny's
//! random segments under callgrind (63.3 → 61.5 M), interleaved `accel_ratio` rounds level to
//! +4 % (2026-12-04). The inverse direction is kept finite (±`f32::MAX` for a zero component,
//! whose `1 / ±0` is ±∞), so no plane distance is the NaN of `0 · ∞`: a ray parallel to a slab
//! gets the distances (plane − origin) · `f32::MAX` from its planes, 0 for a plane it lies in
//! and of the order of `f32::MAX` times its gap to the others, which leave its interval alone
//! when it lies within the slab and empty it when it lies outside; in a face plane it counts as
//! inside when its zero's sign points into the box. What makes this safe is the boxes' padding
//! (at least `f32::MIN_POSITIVE` plus 1e-5 of the coordinate): no triangle reaches its box's
//! faces, and a parallel ray just inside a face gets an exit distance far beyond any scene.
//! With no NaN, each lane's entry and exit are a tree of maxima and minima over the three axes,
//! two operations deep, and the mask a comparison of the two: the chain of dependent operations
//! from a node's load to its child's is shorter than when the distances were folded in one by
//! one, the NaN ignored by each select's operand order (three maxima deep), and the mask read
//! from lanes set to NaN (a select and a comparison more). Interleaved `accel_ratio` rounds
//! (2026-12-04, idle machine, one thread, 1 M rays per round, median of five): closest hit 0.71
//! → 0.75 (bunny), 0.72 → 0.78 (dragon), 0.74 → 0.78 (1M scene), 0.74 → 0.77 (box) of Embree's
//! rate; occlusion 0.69 → 0.69, 0.68 → 0.69, 0.69 → 0.72, 0.67 → 0.59; the gather pattern 0.77
//! → 0.73, 0.85 → 0.89, 1.49 → 1.54, 0.80 → 0.86 (two pairs of runs on the bunny and dragon);
//! `pt --accel bvh` on the bunny's Cornell box 1.01–1.05× as fast. The far planes' distances
//! are widened by a few ulps (Ize 2013, their inverse multiplied by [`EXIT_SCALE`] once per
//! ray) so rounding cannot cull a box the exact ray touches. Embree's form `lower · inv −
//! origin · inv`, one FMA per plane, was measured with that bound kept: the fused product is
//! exact, so moving `origin · inv` outwards by 4 ulps (one copy for the near planes, one for
//! the far) covers the only error it adds, and rays with an infinite `inv` or `origin · inv`
//! kept this form. The node test went from 45 to 37 instructions, but the per-ray setup grew by
//! more than that saved (bunny, instructions per ray in traversal: occlusion 884 → 912, closest
//! hit 707 → 755, gather 1,143 → 1,162) and interleaved timings showed no gain (bunny occlusion
//! 0.72–0.79 → 0.69–0.70 of Embree's rate), so it is not used. Measured again after the shorter
//! chain above (2026-12-04), in the AVX2 version only (the SSE2 one has no FMA), with rays
//! whose direction has a component below 10⁻⁸ of the largest left to the unfused form (their `o
//! · inv` could overflow): one loop per form, chosen per ray, against the unfused test,
//! `RAYS=1000000 accel_ratio ratio SCENE WORKLOAD 5`: bunny closest hit 0.78 → 0.72, dragon
//! 0.73 → 0.76, occlusion level (0.72 → 0.70, 0.73 → 0.71); with the form chosen per node
//! instead, 0.67–0.78× the unfused rates. A first version without the overflow guard or the
//! widening (not conservative, so not usable) had run 1.0–1.17× as fast, which puts the cost in
//! the per-ray choice and setup: not kept.
//!
//! **Fewer instructions did not buy time (2026-12-03).** Two changes cut the traversal's
//! instructions under callgrind by 10 % for occlusion and 5 % for closest hit (bunny: 55.0 →
//! 49.9 M and 45.6 → 43.1 M; dragon 70.0 → 63.0 M and 52.2 → 49.5 M), and were not kept:
//! the slab test ordering each axis' two plane distances with a min and a max instead of
//! picking the near and far plane by the direction's sign (no per-axis select; empty lanes
//! must then be the point at `+∞` with a finite cap on the exit distance, since an inverted
//! box counts as a full one once ordered), and any-hit's stack holding child references only,
//! its three or more hit children sorted as `u32` keys (the entry distance's bits with the
//! lane in the lowest three). Interleaved `accel_ratio` rounds on the idle machine (one
//! thread), old → new BVH/Embree rate, two runs of 7 rounds each: bunny occlusion 0.715,
//! 0.759 → 0.676, 0.727; dragon occlusion 0.683, 0.750 → 0.750, 0.735; bunny closest hit
//! 0.750, 0.770 → 0.773, 0.792; dragon closest hit 0.838, 0.815 → 0.837, 0.833 (a first
//! pair of runs, with the other core busy, had closest hit 3–6 % slower and occlusion level):
//! no change beyond the rounds' scatter. Traversal here waits on loads and on the
//! node-to-node dependency chain more than on instruction throughput, so Embree's 614
//! instructions per occlusion ray on the bunny against these 840 (with the same simulated
//! D1 misses per ray, 15) are not where its lead comes from.

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
/// initialised for every ray. Sixteen entries instead (2026-12-04, interleaved `accel_ratio`
/// rounds on the bunny and the 1M scene) made no difference beyond the rounds' scatter.
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
    // for a two-pack leaf, all of its 320 bytes: dragon occlusion 0.848 → 0.849 of Embree's
    // rate, `accel_ratio`, three alternating pairs, 2026-12-05; not kept.)
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
