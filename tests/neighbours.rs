//! Neighbour lists (cell list + ghosts) against brute-force oracles, 2D and 3D, periodic and
//! not, on lattices (many pairs exactly at the support radius) and jittered particles.

use crate::common;

use common::Rng;
use hsph::boundary::ImageSpace;
use hsph::cells::{brute_force, CellGrid, CellList, NeighbourList, Wants};
use hsph::comm::serial::SerialComm;
use hsph::decomp::Decomposition;
use hsph::halo::{HaloPlan, Ranks};
use hsph::particles::{Fields, Kind, Particles, Record};
use hsph::scene::load_scene_str;
use hsph::sim::Simulation;
use hsph::Vector;
use std::path::Path;

struct Built<const D: usize> {
    p: Particles<D>,
    nl: NeighbourList,
    space: ImageSpace<D>,
}

/// Owned particles at `xs` (dummy wall particles where x[0] < `walls_below`, fluid elsewhere),
/// ghosts, cell list and neighbour lists, built directly: a wall particle's list holds fluid
/// neighbours only ([`Wants::Fluid`]).
fn build<const D: usize>(
    xs: &[Vector<D>],
    min: Vector<D>,
    max: Vector<D>,
    periodic: [bool; D],
    support: f64,
    walls_below: f64,
) -> Built<D> {
    let mut p = Particles::<D>::default();
    for (k, x) in xs.iter().enumerate() {
        p.push_owned(Record::new(
            k as u64,
            if x[0] < walls_below {
                Kind::Dummy
            } else {
                Kind::Fluid
            },
            0,
            0,
            *x,
            Vector::zeros(),
            1.0,
            1.0,
        ));
    }
    let space = ImageSpace {
        min,
        max,
        periodic,
        planes: Vec::new(),
    };
    // one rank: the periodic images go to the rank itself through the halo's own path
    let map = Ranks::new(Decomposition::uniform(min, max, [1; D]), vec![0]);
    let mut plan = HaloPlan::default();
    plan.build(
        &mut p,
        &space,
        &map,
        &map.boxes(),
        support,
        Fields::ALL,
        &SerialComm::new(),
    )
    .unwrap();
    let grid = CellGrid::new(&min, &max, support);
    let mut cells = CellList::default();
    cells
        .build(&grid, &p)
        .unwrap_or_else(|i| panic!("particle {i} at {:?} left the grid", p.x[i]));
    let mut nl = NeighbourList::default();
    let kind = &p.kind;
    nl.build(&grid, &cells, &p, support, |i| {
        if kind[i].is_wall() {
            Wants::Fluid
        } else {
            Wants::All
        }
    });
    Built { p, nl, space }
}

fn sorted(v: &[u32]) -> Vec<u32> {
    let mut v = v.to_vec();
    v.sort_unstable();
    v
}

/// Neighbour lists equal the brute-force oracle over owned + ghost particles.
fn assert_matches_brute_force<const D: usize>(
    p: &Particles<D>,
    nl: &NeighbourList,
    support: f64,
    what: &str,
) -> usize {
    let bf = brute_force(p, support);
    let mut pairs = 0;
    for (i, expect) in bf.iter().enumerate() {
        let got = sorted(nl.of(i));
        let expect: &Vec<u32> = &if p.kind[i].is_wall() {
            expect
                .iter()
                .copied()
                .filter(|&j| p.kind[j as usize].is_fluid())
                .collect()
        } else {
            expect.clone()
        };
        assert_eq!(&got, expect, "{what}: neighbours of particle {i} at {:?}", p.x[i]);
        pairs += got.len();
    }
    assert_eq!(nl.entries(), pairs, "{what}: no stray entries");
    pairs
}

/// Independent oracle for the periodic images: for owned i, every (owned j, image shift)
/// with |x_i − (x_j + shift)| < support, shift ∈ {−L, 0, L} per periodic axis, computed the
/// way a ghost's position is (x_j[a] + L[a]). Compared with the neighbour list mapped back
/// to (source id, shift), this checks that the ghost plan makes every needed image once.
fn assert_matches_image_oracle<const D: usize>(b: &Built<D>, support: f64, what: &str) -> usize {
    let p = &b.p;
    let n = p.n_owned;
    let l: Vector<D> = b.space.max - b.space.min;
    let n_shifts = 3usize.pow(D as u32);
    let r2 = support * support;
    let mut exact_hits = 0;
    for i in 0..n {
        let mut expect: Vec<(u64, [i8; D])> = Vec::new();
        for j in 0..n {
            for code in 0..n_shifts {
                let mut s = [0i8; D];
                let mut c = code;
                let mut ok = true;
                for (a, sa) in s.iter_mut().enumerate() {
                    *sa = (c % 3) as i8 - 1;
                    c /= 3;
                    ok &= *sa == 0 || b.space.periodic[a];
                }
                if !ok || (j == i && s.iter().all(|&x| x == 0)) {
                    continue;
                }
                let mut xj = p.x[j];
                for a in 0..D {
                    if s[a] != 0 {
                        xj[a] += f64::from(s[a]) * l[a];
                    }
                }
                let d2 = (p.x[i] - xj).norm_squared();
                if d2 == r2 {
                    exact_hits += 1;
                }
                if d2 < r2 && (p.kind[j].is_fluid() || !p.kind[i].is_wall()) {
                    expect.push((p.id[j], s));
                }
            }
        }
        let mut got: Vec<(u64, [i8; D])> =
            b.nl.of(i)
                .iter()
                .map(|&k| {
                    let k = k as usize;
                    let src = if k < n { k } else { b.p.id[k] as usize }; // id = owned index here
                    let mut s = [0i8; D];
                    for a in 0..D {
                        s[a] = ((p.x[k][a] - p.x[src][a]) / l[a]).round() as i8;
                    }
                    (p.id[k], s)
                })
                .collect();
        expect.sort_unstable();
        got.sort_unstable();
        assert_eq!(got, expect, "{what}: images seen by particle {i} at {:?}", p.x[i]);
    }
    exact_hits
}

/// Lattice sites (k + ½) dx from `min`, `n` per axis.
fn lattice<const D: usize>(min: Vector<D>, dx: f64, n: usize) -> Vec<Vector<D>> {
    let total = n.pow(D as u32);
    (0..total)
        .map(|mut k| {
            let mut x = min;
            for a in 0..D {
                x[a] += ((k % n) as f64 + 0.5) * dx;
                k /= n;
            }
            x
        })
        .collect()
}

fn jitter<const D: usize>(xs: &mut [Vector<D>], space: &ImageSpace<D>, amp: f64, rng: &mut Rng) {
    for x in xs.iter_mut() {
        for a in 0..D {
            x[a] += rng.range(-amp, amp);
        }
        space.wrap(x);
        for a in 0..D {
            x[a] = x[a].clamp(space.min[a], space.max[a]);
        }
    }
}

/// Runs every configuration of one dimension; returns (pairs, pairs exactly at the support).
fn cases<const D: usize>() -> (usize, usize) {
    let mut rng = Rng(0x5eed_0000 + D as u64);
    let (mut pairs, mut exact) = (0, 0);
    // dyadic lattice: support = 2 dx exactly, so many pairs sit exactly at the support radius
    let dx = 0.125;
    let support = 0.25;
    let n = if D == 2 { 14 } else { 8 };
    let min = Vector::<D>::from_element(0.0);
    let max = Vector::<D>::from_element(n as f64 * dx);
    let periodic_sets: Vec<[bool; D]> = vec![[false; D], [true; D], {
        let mut m = [false; D];
        m[0] = true;
        m
    }];
    for per in &periodic_sets {
        let what = format!("{D}D lattice periodic {per:?}");
        let xs = lattice(min, dx, n);
        let b = build(&xs, min, max, *per, support, f64::NEG_INFINITY);
        pairs += assert_matches_brute_force(&b.p, &b.nl, support, &what);
        let hits = assert_matches_image_oracle(&b, support, &what);
        assert!(
            hits > 0,
            "{what}: the lattice must have pairs exactly at the support"
        );
        exact += hits;
        // jittered copies of the same lattice
        for rep in 0..2 {
            let mut xs = lattice(min, dx, n);
            jitter(&mut xs, &b.space, 0.4 * dx, &mut rng);
            let what = format!("{what}, jitter {rep}");
            let b = build(&xs, min, max, *per, support, f64::NEG_INFINITY);
            pairs += assert_matches_brute_force(&b.p, &b.nl, support, &what);
            assert_matches_image_oracle(&b, support, &what);
        }
    }
    // non-dyadic, non-commensurate box and support, random particles (including some placed
    // exactly on cell boundaries and at the domain faces)
    for rep in 0..4 {
        let support = rng.range(0.05, 0.12);
        let min = Vector::<D>::from_fn(|_, _| rng.range(-1.0, 1.0));
        let len = Vector::<D>::from_fn(|_, _| {
            if rep % 2 == 0 {
                // an exact multiple of the support in decimal, not in binary
                support * (3 + rng.below(3)) as f64
            } else {
                rng.range(3.0 * support, 6.0 * support)
            }
        });
        let max = min + len;
        let per: [bool; D] = std::array::from_fn(|_| rng.below(2) == 0);
        let count = if D == 2 { 400 } else { 700 };
        let mut xs: Vec<Vector<D>> = (0..count)
            .map(|_| Vector::<D>::from_fn(|a, _| rng.range(min[a], max[a])))
            .collect();
        let grid = CellGrid::<D>::new(&min, &max, support);
        for x in xs.iter_mut().take(40) {
            let a = rng.below(D);
            let c = 1 + rng.below(grid.dims[a] - 2);
            x[a] = grid.origin[a] + c as f64 * grid.edge[a];
        }
        xs[40] = min;
        // a partner exactly `support` away along an axis, when it stays inside
        for k in 0..60 {
            let mut y = xs[k];
            let a = rng.below(D);
            y[a] += support;
            if y[a] < max[a] {
                xs.push(y);
            }
        }
        let space = ImageSpace {
            min,
            max,
            periodic: per,
            planes: Vec::new(),
        };
        for x in xs.iter_mut() {
            space.wrap(x);
        }
        // the lower part of the box is dummy wall, whose lists hold fluid only; walls more
        // than a cell from the fluid have no fluid in their stencil at all
        let walls_below = min[0] + 0.45 * len[0];
        let what =
            format!("{D}D random box {rep} periodic {per:?}, support {support}, walls below {walls_below}");
        let b = build(&xs, min, max, per, support, walls_below);
        pairs += assert_matches_brute_force(&b.p, &b.nl, support, &what);
        exact += assert_matches_image_oracle(&b, support, &what);
    }
    (pairs, exact)
}

#[test]
fn cell_list_matches_oracles_2d() {
    let (pairs, exact) = cases::<2>();
    eprintln!("2D: {pairs} directed pairs checked, {exact} exactly at the support");
    assert!(pairs > 10_000);
}

#[test]
fn cell_list_matches_oracles_3d() {
    let (pairs, exact) = cases::<3>();
    eprintln!("3D: {pairs} directed pairs checked, {exact} exactly at the support");
    assert!(pairs > 10_000);
}

const CHANNEL_2D: &str = r#"
dimension = 2
[domain]
min = [0.0, -0.0625]
max = [0.25, 0.3125]
periodic = [true, false]
[discretisation]
dx = 0.015625
h_over_dx = 1.0
[[material]]
name = "water"
rho0 = 1000.0
c0 = 10.0
[[fluid]]
name = "f"
material = "water"
min = [0.0, 0.0]
max = [0.25, 0.25]
[[wall]]
name = "plates"
shape = "container"
min = [0.0, 0.0]
max = [0.25, 0.25]
open = ["x-", "x+"]
method = "METHOD"
[time]
t_end = 0.01
"#;

const BOX_3D: &str = r#"
dimension = 3
[domain]
min = [0.0, 0.0, 0.0]
max = [0.125, 0.125, 0.15625]
periodic = [true, true, PER_Z]
[discretisation]
dx = 0.015625
h_over_dx = 1.0
[[material]]
name = "water"
rho0 = 1000.0
c0 = 10.0
[[fluid]]
name = "f"
material = "water"
min = [0.0, 0.0, 0.0]
max = [0.125, 0.125, 0.125]
[time]
t_end = 0.01
"#;

/// Neighbour lists the step loop builds (ghosts from periodic axes, mirror walls and dummy
/// walls) equal the oracle, on the lattice and after jittering the fluid.
/// Move every fluid particle by up to ±0.3 `dx` per axis (seeded), wrap it into the periodic
/// domain and rebuild ghosts and lists through a density-rate pass.
fn jitter_fluid<const D: usize>(sim: &mut Simulation<D>, dx: f64, seed: u64) {
    let mut rng = Rng(seed);
    for i in 0..sim.p.n_owned {
        if sim.p.kind[i] == Kind::Fluid {
            let mut x = sim.p.x[i];
            for a in 0..D {
                x[a] += rng.range(-0.3 * dx, 0.3 * dx);
            }
            sim.space.wrap(&mut x);
            sim.p.x[i] = x;
        }
    }
    sim.compute_density_rate(&SerialComm::new()).unwrap();
}

fn check_sim<const D: usize>(text: &str, what: &str) -> usize {
    let (scene, _) = load_scene_str(text, Path::new("test.toml"), "t", &[]).unwrap();
    let mut sim = Simulation::<D>::new(&scene, &SerialComm::new()).unwrap();
    let support = sim.model.kernel.support;
    let check = |sim: &Simulation<D>, what: &str| {
        let bf = brute_force(&sim.p, support);
        let mut pairs = 0;
        for (i, expect) in bf.iter().enumerate() {
            if sim.p.kind[i] == Kind::Repulsive {
                continue;
            }
            // a dummy wall particle's list holds its fluid neighbours only
            let expect: Vec<u32> = if sim.p.kind[i].is_wall() {
                expect
                    .iter()
                    .copied()
                    .filter(|&j| sim.p.kind[j as usize].is_fluid())
                    .collect()
            } else {
                expect.clone()
            };
            assert_eq!(
                sorted(sim.nl.of(i)),
                expect,
                "{what}: particle {i} at {:?}",
                sim.p.x[i]
            );
            pairs += expect.len();
        }
        pairs
    };
    let mut pairs = check(&sim, what);
    jitter_fluid(&mut sim, scene.discretisation.dx, 0xab5e_71ce);
    pairs += check(&sim, &format!("{what}, jittered"));
    assert!(!sim.halo.is_empty(), "{what}: the scene must make ghosts");
    pairs
}

#[test]
fn simulation_lists_match_brute_force() {
    let mut total = 0;
    for method in ["dummy", "mirror", "repulsive"] {
        total += check_sim::<2>(
            &CHANNEL_2D.replace("METHOD", method),
            &format!("2D channel, {method} walls"),
        );
    }
    for per_z in ["true", "false"] {
        total += check_sim::<3>(
            &BOX_3D.replace("PER_Z", per_z),
            &format!("3D box, periodic z {per_z}"),
        );
    }
    assert!(total > 10_000);
}

/// A refined periodic channel in a simulation (issue 36): the cell list orders each cell by
/// sub-cell, ghosts and periodic images included, and every stored list holds exactly the
/// pairs within their own support κ (h_i + h_j)/2 (Wendland: κ = 2) of an oracle over every
/// held particle, fluid and dummy wall lists alike, before and after the fluid is jittered.
#[test]
fn refined_simulation_lists_match_a_sized_oracle() {
    let text = CHANNEL_2D.replace("METHOD", "dummy")
        + r#"
[[refine]]
min = [0.08, -0.0625]
max = [0.17, 0.3125]
level = 1
bodies = ["f", "plates"]
smoothing_length = "level"
"#;
    let (scene, _) = load_scene_str(&text, Path::new("test.toml"), "t", &[]).unwrap();
    let mut sim = Simulation::<2>::new(&scene, &SerialComm::new()).unwrap();
    let check = |sim: &Simulation<2>, what: &str| {
        let p = &sim.p;
        assert_eq!(sim.cells.sub_cell_split(), 2, "{what}: sub-cells in use");
        let mut pairs = 0;
        let mut fine = 0;
        for i in 0..p.n_owned {
            let expect: Vec<u32> = (0..p.len())
                .filter(|&j| j != i && (p.kind[j].is_fluid() || !p.kind[i].is_wall()))
                .filter(|&j| (p.x[i] - p.x[j]).norm() < p.h[i] + p.h[j])
                .map(|j| j as u32)
                .collect();
            assert_eq!(
                sorted(sim.nl.of(i)),
                expect,
                "{what}: particle {i} at {:?}",
                p.x[i]
            );
            pairs += expect.len();
            fine += usize::from(p.h[i] < 0.9 * scene.discretisation.dx);
        }
        assert!(
            fine > 50 && pairs > 5_000,
            "{what}: {fine} fine particles, {pairs} pairs"
        );
    };
    sim.compute_density_rate(&SerialComm::new()).unwrap();
    check(&sim, "refined channel");
    jitter_fluid(&mut sim, scene.discretisation.dx, 0x5b_ce11);
    check(&sim, "refined channel, jittered");
    assert!(!sim.halo.is_empty(), "the scene must make ghosts");
}

/// Pair mode's half lists of particles of several sizes `walls` (walls list fluid, fluid lists
/// halves) equal the brute-force oracle's pairs within each pair's support `within(h_i, h_j)`,
/// each under its lower slot, ascending, wall–wall pairs left out.
fn check_half_lists<const D: usize>(
    nl: &mut NeighbourList,
    grid: &CellGrid<D>,
    cells: &CellList,
    walls: &Particles<D>,
    support: f64,
    within: &dyn Fn(f64, f64) -> f64,
) {
    let half = |i: usize| {
        if walls.kind[i].is_fluid() {
            Wants::Half
        } else {
            Wants::Fluid
        }
    };
    nl.build(grid, cells, walls, support, half);
    let ha = nl.half(grid, cells).unwrap();
    let order = ha.order();
    let mut listed = 0;
    for k in 0..ha.slots() {
        let i = order[k] as usize;
        let expect: Vec<u32> = (k as u32 + 1..order.len() as u32)
            .filter(|&t| {
                let j = order[t as usize] as usize;
                let fluid = walls.kind[i].is_fluid() || walls.kind[j].is_fluid();
                fluid && (walls.x[i] - walls.x[j]).norm() < within(walls.h[i], walls.h[j])
            })
            .collect();
        let got: Vec<u32> = ha.stored(k).unwrap().collect();
        assert_eq!(got, expect, "{D}D: half list of slot {k}");
        listed += expect.len();
    }
    assert!(listed > 0, "{D}D: half lists built");
}

/// Particles of several smoothing lengths (issue 35): with `with_sizes(κ/2, false)` a pair is
/// listed only within its own support κ (h_i + h_j)/2, the support of its mean-h kernel, and
/// with `with_sizes(κ, true)` within κ max(h_i, h_j), that of the larger h's
/// (`discretisation.pair_h = "max"`); the lists equal a brute-force oracle over every pair, in
/// 2D and 3D, with h of three levels mixed at random over jittered particles (κ = 2, the
/// grid's support that of the largest h).
#[test]
fn lists_of_several_sizes_keep_each_pair_within_its_own_support() {
    fn check<const D: usize>(seed: u64, larger: bool) {
        // reach per h and the pair's support of the rule (κ = 2)
        let reach_per_h = if larger { 2.0 } else { 1.0 };
        let within = |hi: f64, hj: f64| if larger { 2.0 * hi.max(hj) } else { hi + hj };
        let mut rng = Rng(seed);
        let h0 = 0.05;
        let support = 2.0 * h0;
        let n = if D == 2 { 900 } else { 1500 };
        let mut p = Particles::<D>::default();
        for k in 0..n {
            let x = Vector::<D>::from_fn(|_, _| rng.range(0.0, 1.0));
            let mut r = Record::new(k as u64, Kind::Fluid, 0, 0, x, Vector::zeros(), 1.0, 1.0);
            r.h = h0 / f64::from(1u32 << rng.below(3));
            p.push_owned(r);
        }
        let (min, max) = (Vector::<D>::zeros(), Vector::<D>::from_element(1.0));
        let grid = CellGrid::new(&min, &max, support);
        // sub-cells about as wide as the smallest pair support (reach κh/2 = h here)
        let mut cells = CellList::with_sub_cells(&grid, reach_per_h * h0 / 4.0);
        cells.build(&grid, &p).unwrap();
        let mut nl = NeighbourList::default().with_sizes(reach_per_h, larger);
        nl.build(&grid, &cells, &p, support, |_| Wants::All);
        // the sub-cells (edge ≤ the smallest support: 4 per axis of a cell here) list every
        // particle's neighbours in the coarse scan's order, entry for entry, for lists of all
        // neighbours and of fluid ones only (the dummy walls' lists)
        assert!(nl.sub_cell_split() >= 2, "{D}D: sub-cells in use");
        let mut coarse = NeighbourList::default()
            .with_sizes(reach_per_h, larger)
            .without_sub_cells();
        coarse.build(&grid, &cells, &p, support, |_| Wants::All);
        assert_eq!(coarse.sub_cell_split(), 0);
        for i in 0..n {
            assert_eq!(nl.of(i), coarse.of(i), "{D}D: order of particle {i}'s list");
        }
        let wants = |i: usize| {
            if i.is_multiple_of(3) {
                Wants::Fluid
            } else {
                Wants::All
            }
        };
        let mut walls = p.clone();
        for i in (0..n).step_by(5) {
            walls.kind[i] = Kind::Dummy;
        }
        let (mut a, mut b) = (nl.clone(), coarse.clone());
        a.build(&grid, &cells, &walls, support, wants);
        b.build(&grid, &cells, &walls, support, wants);
        let mut fluid_only = 0;
        for i in 0..n {
            assert_eq!(a.of(i), b.of(i), "{D}D: order of particle {i}'s list, walls");
            if i.is_multiple_of(3) {
                assert!(a.of(i).iter().all(|&j| walls.kind[j as usize].is_fluid()));
                fluid_only += nl.of(i).len() - a.of(i).len();
            }
        }
        assert!(fluid_only > 0, "{D}D: some wall neighbour was left out");
        check_half_lists(&mut a, &grid, &cells, &walls, support, &within);
        let mut pairs = 0;
        for i in 0..n {
            let expect: Vec<u32> = (0..n as u32)
                .filter(|&j| {
                    let j = j as usize;
                    j != i && (p.x[i] - p.x[j]).norm() < within(p.h[i], p.h[j])
                })
                .collect();
            assert_eq!(sorted(nl.of(i)), expect, "{D}D: neighbours of particle {i}");
            pairs += expect.len();
        }
        assert_eq!(nl.entries(), pairs, "{D}D: no stray entries");
        // and the uniform lists would hold more (twice as many with the mean h): the filter
        // did work
        let uniform = brute_force(&p, support).iter().map(Vec::len).sum::<usize>();
        assert!(
            pairs < if larger { uniform * 9 / 10 } else { uniform / 2 },
            "{D}D: {pairs} of {uniform}"
        );
    }
    for larger in [false, true] {
        check::<2>(35, larger);
        check::<3>(36, larger);
    }
}

/// A cell list binned in the window of the grid its particles occupy
/// ([`CellGrid::window`]) gives every particle the same neighbours in the same order as one
/// binned on the whole grid, with far fewer cells: jittered particles in a corner of a large
/// domain (a debris cloud's), with walls, 2D and 3D.
#[test]
fn a_window_of_the_grid_lists_the_same_neighbours_in_the_same_order() {
    fn case<const D: usize>(rng: &mut Rng) {
        let (dx, support) = (0.1, 0.25);
        let min = Vector::<D>::from_element(-5.0);
        let max = Vector::<D>::from_element(5.0);
        let n: usize = if D == 2 { 20 } else { 8 };
        let count = n.pow(D as u32);
        let xs: Vec<Vector<D>> = (0..count)
            .map(|k| {
                let mut x = Vector::<D>::zeros();
                let mut r = k;
                for a in 0..D {
                    x[a] = 1.03 + (r % n) as f64 * dx + rng.range(-0.3 * dx, 0.3 * dx);
                    r /= n;
                }
                x
            })
            .collect();
        let b = build(&xs, min, max, [false; D], support, 1.03 + 2.0 * dx);
        let grid = CellGrid::new(&min, &max, support);
        let window = grid.window(&b.p.x);
        assert!(
            window.len() * 20 < grid.len(),
            "{D}D: the window holds {} of {} cells",
            window.len(),
            grid.len()
        );
        let kind = &b.p.kind;
        let wants = |i: usize| {
            if kind[i].is_wall() {
                Wants::Fluid
            } else {
                Wants::All
            }
        };
        let lists = |g: &CellGrid<D>| {
            let mut cells = CellList::default();
            cells.build(g, &b.p).unwrap();
            let mut nl = NeighbourList::default();
            nl.build(g, &cells, &b.p, support, wants);
            (0..b.p.n_owned).map(|i| nl.of(i).to_vec()).collect::<Vec<_>>()
        };
        let (whole, win) = (lists(&grid), lists(&window));
        assert!(
            whole.iter().map(Vec::len).sum::<usize>() > count,
            "{D}D: pairs listed"
        );
        assert_eq!(whole, win, "{D}D: the window's lists and order");
        // every particle is in the window's cell that holds its position, whose bounds are
        // the whole grid's cell's
        for x in &b.p.x {
            let (cw, cg) = (window.coords(x).unwrap(), grid.coords(x).unwrap());
            assert_eq!(window.cell_lo(&cw), grid.cell_lo(&cg), "{D}D: cell of {x:?}");
        }
    }
    let mut rng = Rng(0x3d_0017);
    case::<2>(&mut rng);
    case::<3>(&mut rng);
}
