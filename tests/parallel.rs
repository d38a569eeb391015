//! The parallel engine (issue 3) on the local back end: `timeseries.csv` and `final.csv` are
//! bitwise identical on 1, 2, 3, 4, 7 and 8 ranks and with 1 or 2 threads per rank, while
//! particles migrate and the cut planes are rebalanced; ghost sets give every particle exactly
//! the neighbours it has on one rank (including subdomains thinner than the support radius);
//! a failing rank stops the run with one message naming it, without hanging.

use crate::common;

use hsph::comm::local::run_local;
use hsph::comm::Comm;
use hsph::driver::{run_scene, Backend, Fault, FaultKind, RunOptions};
use hsph::scene::{load_scene, load_scene_str, Scene};
use hsph::sim::Simulation;
use std::collections::BTreeMap;
use std::fs;
use std::path::{Path, PathBuf};
use std::time::Instant;

fn scene(rel: &str, overrides: &[&str]) -> Scene {
    let o: Vec<String> = overrides.iter().map(|s| s.to_string()).collect();
    load_scene(&common::repo_path(rel), &o).unwrap().0
}

fn run(scene: &Scene, ranks: usize, threads: usize, tag: &str) -> (PathBuf, serde_json::Value) {
    let out = common::temp_dir(tag).join("run");
    let opts = RunOptions {
        out: Some(out.clone()),
        threads,
        quiet: true,
        ranks,
        backend: if ranks == 1 {
            Backend::Serial
        } else {
            Backend::Local
        },
        ..Default::default()
    };
    run_scene(scene, &opts).unwrap_or_else(|e| panic!("{tag}: {e}"));
    let summary = serde_json::from_str(&fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    (out, summary)
}

fn read(dir: &Path, name: &str) -> String {
    fs::read_to_string(dir.join(name)).unwrap_or_else(|e| panic!("{}/{name}: {e}", dir.display()))
}

/// Runs `scene` on every rank count and checks identical bits, migration, rebalancing and
/// balance. With `flow_axis = Some(a)` (a laminar flow along axis a) particles can only change
/// rank where that axis is cut, so migration is required only there.
fn same_bits_on_any_rank_count(scene: &Scene, tag: &str, flow_axis: Option<usize>) {
    // loads balance freely here: these small scenes' wall blocks would meet the count cap
    // (tested in decomp and tests/scaleout.rs) before the load bound asserted below
    let mut scene = scene.clone();
    scene.balance.max_count = 8.0;
    let scene = &scene;
    let (base, s1) = run(scene, 1, 1, &format!("{tag}-r1"));
    let ts = read(&base, "timeseries.csv");
    let fin = read(&base, "final.csv");
    let n = s1["particles"].as_u64().unwrap() as f64;
    for (ranks, threads) in [(2, 1), (3, 1), (4, 1), (4, 2), (7, 1), (8, 1)] {
        let (dir, s) = run(scene, ranks, threads, &format!("{tag}-r{ranks}t{threads}"));
        assert_eq!(s["ranks"].as_u64(), Some(ranks as u64));
        assert_eq!(s["threads"].as_u64(), Some(threads as u64));
        assert!(
            read(&dir, "timeseries.csv") == ts,
            "{tag}: timeseries.csv differs on {ranks} ranks × {threads} threads"
        );
        assert!(
            read(&dir, "final.csv") == fin,
            "{tag}: final.csv differs on {ranks} ranks × {threads} threads"
        );
        let cut = flow_axis.is_none_or(|a| s["decomposition"][a].as_u64().unwrap() > 1);
        if cut {
            assert!(
                s["migrations"].as_u64().unwrap() > 0,
                "{tag} on {ranks} ranks: no particle migrated: {s}"
            );
        }
        // every rank owns roughly N/P particles (the lattice rows limit the balance of small
        // runs); a rebalance (planes that moved) must have happened unless the loads stayed
        // within the search's own tolerance, (1 + 2η)^D
        let imb = s["imbalance"].as_f64().unwrap();
        let tolerance = hsph::decomp::BalanceParams::default().bound(scene.dimension);
        assert!(
            s["rebalances"].as_u64().unwrap() >= 1 || imb <= tolerance,
            "{tag} on {ranks} ranks: no rebalance: {s}"
        );
        assert!(
            imb <= 1.25,
            "{tag} on {ranks} ranks: max/mean load {imb} (N = {n})"
        );
    }
}

#[test]
fn dam_break_2d_same_bits_on_1_to_8_ranks() {
    let s = scene(
        "inputs/dam_break_2d.toml",
        &[
            "time.t_end=0.08",
            "output.format=\"none\"",
            "balance.check_every=10",
            "balance.threshold=1.05",
        ],
    );
    same_bits_on_any_rank_count(&s, "par-db2", None);
}

/// Dynamic walls (DualSPHysics's boundary) integrate their density from the fluid round them:
/// a wall particle's ρ is state that migrates, is sent to ghosts and is summed in the order of
/// its neighbours' ids on any layout.
#[test]
fn dynamic_walls_same_bits_on_1_to_8_ranks() {
    let s = scene(
        "inputs/dam_break_2d.toml",
        &[
            "time.t_end=0.04",
            "output.format=\"none\"",
            "balance.check_every=10",
            "balance.threshold=1.05",
            "wall[0].method=\"dynamic\"",
        ],
    );
    // the shipped tank is free-slip: v_w is the fluid's mean round each wall particle
    assert_eq!(s.walls[0].method, hsph::scene::WallMethod::Dynamic);
    same_bits_on_any_rank_count(&s, "par-dynamic", None);
}

/// The Poiseuille channel with 100 × the body force, so that particles travel a few spacings
/// along the periodic axis, round the seam and across the slabs, in a short run that
/// rebalances often.
const FAST_POISEUILLE: &[&str] = &[
    "time.t_end=0.12",
    "physics.body_force=[0.02,0.0]",
    "material[0].c0=0.05",
    "reference.times=[0.1]",
    "balance.check_every=5",
    "balance.threshold=1.0",
];

#[test]
fn poiseuille_same_bits_on_1_to_8_ranks() {
    let s = scene("inputs/poiseuille_2d.toml", FAST_POISEUILLE);
    same_bits_on_any_rank_count(&s, "par-poiseuille", Some(0));
}

#[test]
fn renormalised_viscous_operator_and_morris_walls_same_bits_on_1_to_8_ranks() {
    // the lattice moment is a pass of its own whose result reaches ghosts before momentum;
    // Morris's no-slip measures depths to the plates from images across the periodic seam
    let mut sets = FAST_POISEUILLE.to_vec();
    sets.extend([
        "physics.viscous_operator=\"renormalised\"",
        "wall[0].no_slip=\"morris\"",
        "wall[1].no_slip=\"morris\"",
    ]);
    let s = scene("inputs/poiseuille_2d.toml", &sets);
    same_bits_on_any_rank_count(&s, "par-poiseuille-corrected", Some(0));
}

#[test]
fn morris_mirror_walls_same_bits_on_1_to_8_ranks() {
    // Morris's no-slip reads the plane an image was reflected across from its sort key and
    // both depths from positions: the same on every rank that holds the image
    let mut sets = FAST_POISEUILLE.to_vec();
    sets.extend([
        "physics.viscous_operator=\"renormalised\"",
        "wall[0].no_slip=\"morris\"",
        "discretisation.kernel=\"cubic_spline\"",
        "discretisation.h_over_dx=2.0",
    ]);
    let s = scene("inputs/poiseuille_2d_mirror.toml", &sets);
    same_bits_on_any_rank_count(&s, "par-poiseuille-mirror-morris", Some(0));
}

#[test]
fn dam_break_3d_same_bits_on_1_to_8_ranks() {
    // the shipped scene (repulsive walls), coarsened to dx = 5 cm for CI
    let s = scene(
        "inputs/dam_break_3d.toml",
        &[
            "discretisation.dx=0.05",
            "time.t_end=0.1",
            "balance.check_every=5",
            "balance.threshold=1.01",
        ],
    );
    same_bits_on_any_rank_count(&s, "par-db3", None);
    // and the small tank with dummy walls (three layers, extrapolated pressure)
    let s = scene(
        "tests/data/dam_break_3d_small.toml",
        &[
            "time.t_end=0.1",
            "balance.check_every=5",
            // the walls are most of the particles, and planes that split their layers
            // balance them to 1.001: any excess rebalances, so the rebalance is exercised
            "balance.threshold=1.0",
        ],
    );
    same_bits_on_any_rank_count(&s, "par-db3-dummy", None);
}

/// For every owned particle on every rank: (id → (fluid?, sorted neighbour keys)), taken after
/// the first neighbour build of `P` ranks (a dummy wall particle lists its fluid neighbours
/// only).
fn neighbour_keys(scene: &Scene, ranks: usize) -> BTreeMap<u64, (bool, Vec<u64>)> {
    #[allow(clippy::type_complexity)]
    fn on_rank<const D: usize>(
        scene: &Scene,
        comm: &dyn Comm,
    ) -> hsph::error::Result<Vec<(u64, (bool, Vec<u64>))>> {
        let sim = Simulation::<D>::new(scene, comm)?;
        // ghosts are unique by (id, image code)
        let mut keys: Vec<u64> = sim.p.key.clone();
        keys.sort_unstable();
        let before = keys.len();
        keys.dedup();
        assert_eq!(
            keys.len(),
            before,
            "rank {}: a ghost arrived twice with the same image",
            comm.rank()
        );
        Ok((0..sim.p.n_owned)
            .map(|i| {
                let mut k: Vec<u64> = sim.nl.of(i).iter().map(|&j| sim.p.key[j as usize]).collect();
                k.sort_unstable();
                (sim.p.id[i], (sim.p.kind[i].is_fluid(), k))
            })
            .collect())
    }
    let per_rank = run_local(ranks, 1, |comm| match scene.dimension {
        2 => on_rank::<2>(scene, comm),
        _ => on_rank::<3>(scene, comm),
    })
    .unwrap();
    let mut all = BTreeMap::new();
    for (id, k) in per_rank.into_iter().flatten() {
        assert!(all.insert(id, k).is_none(), "particle {id} owned by two ranks");
    }
    all
}

fn periodic_box(dim: usize, n: usize, jitter_seed: u64) -> Scene {
    // a fully periodic box of n lattice sites per axis with jittered velocities is enough: the
    // neighbour sets depend on positions, which are on the lattice here
    let dx = 0.1;
    let l = n as f64 * dx;
    let v = |k: usize| {
        vec![k as f64; dim]
            .iter()
            .map(|x| format!("{x}"))
            .collect::<Vec<_>>()
            .join(",")
    };
    let _ = jitter_seed;
    let text = format!(
        "dimension = {dim}\n[domain]\nmin = [{}]\nmax = [{}]\nperiodic = [{}]\n\
         [discretisation]\ndx = {dx}\nh_over_dx = 1.3\n\
         [[material]]\nname = \"w\"\nrho0 = 1000.0\nc0 = 10.0\n\
         [[fluid]]\nname = \"f\"\nmaterial = \"w\"\nmin = [{}]\nmax = [{}]\n\
         [time]\nt_end = 0.1\n",
        v(0),
        vec![format!("{l}"); dim].join(","),
        vec!["true"; dim].join(","),
        v(0),
        vec![format!("{l}"); dim].join(","),
    );
    load_scene_str(&text, Path::new("box.toml"), "box", &[])
        .unwrap()
        .0
}

#[test]
fn ghosts_give_every_particle_its_one_rank_neighbours() {
    let cases: Vec<(Scene, Vec<usize>)> = vec![
        // periodic 2D box: support 0.26 m, 1.2 m wide: 8 ranks make blocks thinner than the support
        (periodic_box(2, 12, 1), vec![2, 3, 4, 5, 8]),
        // 3D periodic box: 27 ranks make blocks of 0.3 m against a support of 0.26 m, 64 ranks 0.225 m
        (periodic_box(3, 9, 2), vec![2, 8, 27, 64]),
        // walls, free surface, no periodicity
        (scene("inputs/dam_break_2d.toml", &[]), vec![3, 7]),
        (scene("tests/data/dam_break_3d_small.toml", &[]), vec![4, 6]),
        (scene("tests/data/periodic_channel_2d.toml", &[]), vec![2, 5, 8]),
    ];
    for (s, rank_counts) in cases {
        let serial = neighbour_keys(&s, 1);
        // every fluid particle has neighbours; a wall may have none (no fluid near it)
        assert!(serial.values().all(|(fluid, k)| !fluid || !k.is_empty()));
        for p in rank_counts {
            let par = neighbour_keys(&s, p);
            assert_eq!(par.len(), serial.len(), "{} on {p} ranks: particle count", s.name);
            for (id, k) in &serial {
                assert_eq!(
                    par.get(id),
                    Some(k),
                    "{} on {p} ranks: neighbours of particle {id}",
                    s.name
                );
            }
        }
    }
}

fn fails_cleanly(kind: FaultKind) -> String {
    let s = scene(
        "inputs/dam_break_2d.toml",
        &["time.t_end=0.05", "output.format=\"none\""],
    );
    let out = common::temp_dir("par-fault").join("run");
    let opts = RunOptions {
        out: Some(out.clone()),
        threads: 1,
        quiet: true,
        ranks: 4,
        backend: Backend::Local,
        fault: Some(Fault {
            rank: 2,
            step: 7,
            kind,
        }),
        ..Default::default()
    };
    let t0 = Instant::now();
    let err = run_scene(&s, &opts).expect_err("an injected fault must fail the run");
    assert!(t0.elapsed().as_secs_f64() < 60.0, "the failure took too long");
    assert!(
        !out.join("summary.json").exists(),
        "a failed run must not write summary.json"
    );
    assert_eq!(err.exit_code(), 1);
    err.to_string()
}

#[test]
fn a_panicking_rank_stops_the_run_with_its_name() {
    let msg = fails_cleanly(FaultKind::Panic);
    assert!(msg.contains("rank 2"), "{msg}");
    assert!(msg.contains("step 7"), "{msg}");
}

#[test]
fn a_particle_blowing_up_names_rank_step_id_and_position() {
    let msg = fails_cleanly(FaultKind::Nan);
    assert!(msg.contains("rank 2"), "{msg}");
    assert!(msg.contains("step 7"), "{msg}");
    assert!(msg.contains("particle id"), "{msg}");
    assert!(msg.contains("position"), "{msg}");
}

#[test]
fn speed_weights_and_pair_loads_shape_the_balance() {
    // rank 1 is declared three times as fast: after the first check it owns ~3× the load
    for load in ["particles", "pairs"] {
        let s = scene(
            "inputs/dam_break_2d.toml",
            &[
                "balance.check_every=5",
                "balance.threshold=1.02",
                "balance.weights=[1.0,3.0]",
                &format!("balance.load=\"{load}\""),
            ],
        );
        let loads = run_local(2, 1, |comm| {
            let mut sim = Simulation::<2>::new(&s, comm)?;
            for _ in 0..6 {
                sim.advance(comm)?;
            }
            let n = sim.p.n_owned;
            let pairs: usize = (0..n).map(|i| 1 + sim.nl.of(i).len()).sum();
            Ok((n, pairs, sim.balance.rebalance_steps.len()))
        })
        .unwrap();
        assert!(loads.iter().all(|l| l.2 >= 1), "{load}: no rebalance: {loads:?}");
        let (a, b) = if load == "pairs" {
            (loads[0].1, loads[1].1)
        } else {
            (loads[0].0, loads[1].0)
        };
        let ratio = b as f64 / a as f64;
        assert!(
            (ratio - 3.0).abs() < 0.3,
            "{load}: load ratio {ratio} for speeds 1:3 ({loads:?})"
        );
    }
}

#[test]
fn migration_conserves_ids_mass_momentum_and_energy_exactly() {
    // every particle of the dam break is pushed 3 cm along x and 2 cm along y (a third of
    // them change rank), then migrated: the gathered state must be the same bits
    let s = scene("inputs/dam_break_2d.toml", &[]);
    let out = run_local(4, 1, |comm| {
        let mut sim = Simulation::<2>::new(&s, comm)?;
        for i in 0..sim.p.n_owned {
            sim.p.x[i] += hsph::Vector::<2>::new(0.03, 0.02);
        }
        let before = sim.gather(comm)?.map(|v| v.p.into_owned());
        let o0 = sim.observables(comm)?;
        sim.p.truncate_ghosts();
        let sent = hsph::halo::migrate(&mut sim.p, &sim.map, &sim.boxes, comm)?;
        let o1 = sim.observables(comm)?;
        let after = sim.gather(comm)?.map(|v| v.p.into_owned());
        let mine_ok = (0..sim.p.n_owned).all(|i| sim.map.owner(&sim.p.x[i], sim.p.id[i]) == comm.rank());
        Ok((before, after, sent, mine_ok, o0, o1))
    })
    .unwrap();
    let moved: usize = out.iter().map(|o| o.2).sum();
    assert!(
        moved > 100,
        "the shift must move particles between ranks ({moved})"
    );
    assert!(out.iter().all(|o| o.3), "every particle must end on its owner");
    for o in &out {
        assert_eq!(o.4.kinetic_energy.to_bits(), o.5.kinetic_energy.to_bits());
        assert_eq!(o.4.momentum, o.5.momentum);
    }
    let (b, a) = (out[0].0.as_ref().unwrap(), out[0].1.as_ref().unwrap());
    assert_eq!(a.id, b.id, "ids lost or duplicated");
    assert_eq!(a.x, b.x);
    assert_eq!(a.v, b.v);
    assert_eq!(a.mass, b.mass);
    assert_eq!(a.rho, b.rho);
    assert_eq!(a.kind, b.kind);
}

#[test]
fn corner_eighth_cloud_stays_balanced_on_8_ranks() {
    // 46³ = 97 336 particles on the lattice of the corner eighth of a periodic unit cube, pushed
    // towards the far corner; max/mean ≤ 1.05 after the decomposition and every rebalance
    let text = "dimension = 3\n[domain]\nmin = [0.0, 0.0, 0.0]\nmax = [1.0, 1.0, 1.0]\n\
                periodic = [true, true, true]\n[discretisation]\ndx = 0.010869565217391304\n\
                [[material]]\nname = \"w\"\nrho0 = 1000.0\nc0 = 20.0\n[physics]\n\
                body_force = [3000.0, 3000.0, 3000.0]\n[[fluid]]\nname = \"f\"\nmaterial = \"w\"\n\
                min = [0.0, 0.0, 0.0]\nmax = [0.5, 0.5, 0.5]\n[time]\nt_end = 1.0\n\
                [balance]\ncheck_every = 2\nthreshold = 1.0\n";
    let s = load_scene_str(text, Path::new("corner.toml"), "corner", &[])
        .unwrap()
        .0;
    let hist = run_local(8, 1, |comm| {
        let mut sim = Simulation::<3>::new(&s, comm)?;
        for _ in 0..30 {
            sim.advance(comm)?;
        }
        Ok((sim.p.n_owned, sim.balance.imbalance_history.clone()))
    })
    .unwrap();
    let total: usize = hist.iter().map(|h| h.0).sum();
    assert_eq!(total, 46 * 46 * 46);
    let h = &hist[0].1;
    assert!(h.len() >= 2, "decomposition and at least one rebalance: {h:?}");
    assert!(h.iter().all(|&x| x <= 1.05), "max/mean loads {h:?}");
}

/// The final gather of a lone rank lends its table (put in id order, ghosts dropped) instead of
/// copying it, and that table is the state the copying gather gives and the state 4 ranks
/// gather, bit for bit (the dam break after 20 steps).
#[test]
fn a_lone_rank_lends_its_settled_table_to_the_final_view() {
    let s = scene("inputs/dam_break_2d.toml", &[]);
    let steps = |sim: &mut Simulation<2>, comm: &dyn Comm| -> hsph::error::Result<()> {
        for _ in 0..20 {
            sim.advance(comm)?;
        }
        Ok(())
    };
    let four = run_local(4, 1, |comm| {
        let mut sim = Simulation::<2>::new(&s, comm)?;
        steps(&mut sim, comm)?;
        Ok(sim.gather(comm)?.map(|v| v.p.into_owned()))
    })
    .unwrap();
    let four = four[0].as_ref().unwrap();
    let one = run_local(1, 1, |comm| {
        let mut sim = Simulation::<2>::new(&s, comm)?;
        steps(&mut sim, comm)?;
        let copied = sim.gather(comm)?.unwrap().p;
        assert!(
            matches!(copied, std::borrow::Cow::Owned(_)),
            "the table is in cell order: a copy"
        );
        let copied = copied.into_owned();
        sim.settle_for_gather();
        let lent = sim.gather(comm)?.unwrap().p;
        assert!(
            matches!(lent, std::borrow::Cow::Borrowed(t) if std::ptr::eq(t, &sim.p)),
            "the settled table must be lent"
        );
        Ok((copied, lent.into_owned()))
    })
    .unwrap();
    let (copied, lent) = &one[0];
    for (name, t) in [("lent", lent), ("4 ranks", four)] {
        assert_eq!(t.n_owned, copied.n_owned, "{name}");
        assert_eq!(t.len(), t.n_owned, "{name}: ghosts in a view");
        assert_eq!(t.id, copied.id, "{name}");
        assert_eq!(t.x, copied.x, "{name}");
        assert_eq!(t.v, copied.v, "{name}");
        assert_eq!(t.rho, copied.rho, "{name}");
        assert_eq!(t.p, copied.p, "{name}");
    }
}

/// Overlap (issue 34): a pass that reads refreshed ghost fields computes the interior while
/// they travel, then the rest. The files are those of the run without overlap, on 1, 3 and 8
/// ranks and 1–2 threads, for fluids with dummy walls (2D and 3D, δ-SPH), the periodic channel
/// with the renormalised laminar term, Morris's walls and shifting, particles of several sizes
/// and an elastic plate; and pair mode, whose passes without a pair kernel overlap.
#[test]
fn overlap_changes_no_bit() {
    let cases: [(&str, &[&str]); 6] = [
        ("inputs/dam_break_2d.toml", &["time.t_end=0.04"]),
        (
            "inputs/dam_break_2d.toml",
            &["time.t_end=0.04", "performance.interactions=\"pairs\""],
        ),
        (
            "inputs/poiseuille_2d.toml",
            &[
                "time.t_end=0.04",
                "reference.times=[0.04]",
                "physics.viscous_operator=\"renormalised\"",
                "wall[0].no_slip=\"morris\"",
                "physics.shifting=\"delta_plus\"",
            ],
        ),
        ("tests/data/dam_break_3d_small.toml", &["time.t_end=0.04"]),
        ("inputs/hydrostatic_2d_refined.toml", &["time.t_end=0.04"]),
        ("inputs/oscillating_plate.toml", &["time.t_end=0.02"]),
    ];
    for (k, (path, sets)) in cases.iter().enumerate() {
        let mut off = sets.to_vec();
        off.extend(["output.format=\"none\"", "performance.overlap=\"off\""]);
        let (base, _) = run(&scene(path, &off), 3, 1, &format!("ov{k}-off"));
        let (ts, fin) = (read(&base, "timeseries.csv"), read(&base, "final.csv"));
        let mut on = sets.to_vec();
        on.extend(["output.format=\"none\"", "performance.overlap=\"on\""]);
        let on = scene(path, &on);
        for (ranks, threads) in [(1, 1), (3, 1), (3, 2), (8, 1)] {
            let (dir, _) = run(&on, ranks, threads, &format!("ov{k}-r{ranks}t{threads}"));
            let same = read(&dir, "timeseries.csv") == ts && read(&dir, "final.csv") == fin;
            assert!(
                same,
                "{path} {sets:?}: overlap changed the bits on {ranks} ranks × {threads} threads"
            );
        }
    }
}

/// The interior a pass computes while ghosts travel holds no particle with a ghost neighbour,
/// and on 3 ranks it is neither empty nor everything (so the overlap test splits passes).
#[test]
fn the_interior_has_no_ghost_neighbour() {
    fn on_rank<const D: usize>(scene: &Scene, comm: &dyn Comm) -> hsph::error::Result<(usize, usize)> {
        let sim = Simulation::<D>::new(scene, comm)?;
        let n = sim.p.n_owned;
        let interior = sim.interior();
        assert_eq!(interior.len(), n, "rank {}: interior not marked", comm.rank());
        for (i, _) in interior.iter().enumerate().filter(|(_, &b)| b) {
            let ghost = sim.nl.of(i).iter().find(|&&j| j as usize >= n);
            assert!(
                ghost.is_none(),
                "rank {}: interior particle {i} has ghost neighbour {ghost:?}",
                comm.rank()
            );
        }
        Ok((interior.iter().filter(|&&b| b).count(), n))
    }
    for path in ["inputs/dam_break_2d.toml", "tests/data/dam_break_3d_small.toml"] {
        let s = scene(path, &["performance.overlap=\"on\""]);
        let parts = run_local(3, 1, |comm| match s.dimension {
            2 => on_rank::<2>(&s, comm),
            _ => on_rank::<3>(&s, comm),
        })
        .unwrap();
        let (inner, all) = parts.iter().fold((0, 0), |(a, b), (i, n)| (a + i, b + n));
        assert!(inner > 0 && inner < all, "{path}: interior {inner} of {all}");
    }
}

/// The ghost set's skin (`performance.skin`, `sim::skin`) changes no bit: ghosts kept between
/// builds, migration deferred to the builds, the same `timeseries.csv` and `final.csv` as a
/// build every step — fluids with dummy walls (gather and pairs, 2D and 3D, the list-free
/// scan), a periodic channel with shifting and the renormalised viscous term, mirror walls, a
/// moving lid, particles of several sizes, an elastic plate — on 1, 3 and 8 ranks × 1–2
/// threads. The skin is used on several ranks: fewer builds than steps, and a build every step
/// without it.
#[test]
fn the_skin_changes_no_bit() {
    let cases: [(&str, &[&str]); 8] = [
        ("inputs/dam_break_2d.toml", &["time.t_end=0.05"]),
        (
            "inputs/dam_break_2d.toml",
            &[
                "time.t_end=0.05",
                "performance.interactions=\"pairs\"",
                "performance.neighbours=\"cells\"",
            ],
        ),
        (
            "inputs/poiseuille_2d.toml",
            &[
                "time.t_end=0.04",
                "reference.times=[0.04]",
                "physics.viscous_operator=\"renormalised\"",
                "physics.shifting=\"delta_plus\"",
            ],
        ),
        (
            "inputs/couette_2d_mirror.toml",
            &["time.t_end=0.04", "reference.times=[0.04]"],
        ),
        ("inputs/cavity_re100.toml", &["time.max_steps=100"]),
        (
            "tests/data/dam_break_3d_small.toml",
            &["time.t_end=0.03", "performance.interactions=\"pairs\""],
        ),
        ("inputs/hydrostatic_2d_refined.toml", &["time.t_end=0.04"]),
        ("inputs/oscillating_plate.toml", &["time.t_end=0.02"]),
    ];
    for (k, (path, sets)) in cases.iter().enumerate() {
        let with = |skin: &str| {
            let mut s = sets.to_vec();
            let skin = format!("performance.skin={skin}");
            s.extend(["output.format=\"none\"", skin.as_str()]);
            scene(path, &s)
        };
        let (base, s0) = run(&with("0"), 3, 1, &format!("sk{k}-none"));
        let steps = s0["steps"].as_u64().unwrap();
        assert_eq!(
            s0["ghost_builds"].as_u64(),
            Some(steps + 1),
            "{path}: no skin builds every step"
        );
        let (ts, fin) = (read(&base, "timeseries.csv"), read(&base, "final.csv"));
        let skinned = with("0.3");
        for (ranks, threads) in [(1, 1), (3, 1), (3, 2), (8, 1)] {
            let (dir, s) = run(&skinned, ranks, threads, &format!("sk{k}-r{ranks}t{threads}"));
            let same = read(&dir, "timeseries.csv") == ts && read(&dir, "final.csv") == fin;
            assert!(
                same,
                "{path} {sets:?}: the skin changed the bits on {ranks} ranks × {threads} threads"
            );
            // (one rank keeps no skin where it has no ghost: no periodic axis, no mirror)
            let builds = s["ghost_builds"].as_u64().unwrap();
            assert!(
                ranks == 1 || builds < steps / 2,
                "{path}: {builds} ghost builds in {steps} steps with a skin"
            );
        }
    }
}

/// Ghosts kept between builds give every particle, at every step, the neighbours a fresh
/// build gives it: the same keys in the same order at the same positions (bitwise) with the
/// same kind, mass, h and body, and the same ρ, p, v_w and ∇ρ as the passes left them
/// (kept ghosts get only what changed, and only their class's refreshes), on 3 ranks of a
/// dam break (particles migrate), 2 of a periodic
/// channel (particles wrap) and 4 of a 3D dam break, with a skin of the whole support (so the
/// ghosts are kept for several steps) against none.
#[test]
fn kept_ghosts_give_every_particle_the_neighbours_of_a_fresh_build() {
    type Lists = BTreeMap<u64, Vec<String>>;
    fn on_rank<const D: usize>(
        scene: &Scene,
        steps: usize,
        comm: &dyn Comm,
    ) -> hsph::error::Result<(Vec<Lists>, u64, u64)> {
        let mut sim = Simulation::<D>::new(scene, comm)?;
        let mut out = Vec::new();
        for _ in 0..steps {
            sim.advance(comm)?;
            let lists: Lists = (0..sim.p.n_owned)
                .map(|i| {
                    // what a list is made of: who the neighbour is and where, and the fields
                    // the passes refreshed as the step left them (not v: the last kick moves
                    // an owned neighbour's on, not a ghost's, and a particle owned in one run
                    // may still be a kept ghost in the other until the next build)
                    let nb = sim.nl.of(i).iter().map(|&j| {
                        let r = sim.p.record(j as usize);
                        format!(
                            "{} {:?} {:?} {} {} {} {} {} {:?} {:?}",
                            r.key, r.kind, r.x, r.mass, r.h, r.body, r.rho, r.p, r.vw, r.grad_rho
                        )
                    });
                    (sim.p.id[i], nb.collect())
                })
                .collect();
            out.push(lists);
        }
        Ok((out, sim.ghost_builds(), sim.balance.migrated))
    }
    let cases = [
        ("inputs/dam_break_2d.toml", 3, 60),
        ("tests/data/periodic_channel_2d.toml", 2, 60),
        ("tests/data/dam_break_3d_small.toml", 4, 25),
    ];
    for (path, ranks, steps) in cases {
        let lists = |skin: &str| {
            let s = scene(path, &[&format!("performance.skin={skin}")]);
            let per_rank = run_local(ranks, 1, |comm| match s.dimension {
                2 => on_rank::<2>(&s, steps, comm),
                _ => on_rank::<3>(&s, steps, comm),
            })
            .unwrap();
            let (builds, migrated) = (per_rank[0].1, per_rank.iter().map(|r| r.2).sum::<u64>());
            let mut at_step: Vec<Lists> = vec![Lists::new(); steps];
            for (rank_lists, _, _) in per_rank {
                for (k, l) in rank_lists.into_iter().enumerate() {
                    for (id, nb) in l {
                        assert!(
                            at_step[k].insert(id, nb).is_none(),
                            "{path}: particle {id} owned twice"
                        );
                    }
                }
            }
            (at_step, builds, migrated)
        };
        let (fresh, builds0, migrated) = lists("0");
        let (kept, builds, _) = lists("1");
        assert_eq!(builds0, steps as u64 + 1, "{path}");
        assert!(
            builds < steps as u64 / 3,
            "{path}: {builds} builds in {steps} steps"
        );
        if ranks > 1 && !path.contains("periodic") {
            assert!(migrated > 0, "{path}: nothing migrated");
        }
        for (k, (a, b)) in fresh.iter().zip(&kept).enumerate() {
            assert_eq!(a.len(), b.len(), "{path} step {}: particle count", k + 1);
            for (id, nb) in a {
                if b.get(id) != Some(nb) {
                    let other = b.get(id).cloned().unwrap_or_default();
                    let diff: Vec<_> = nb.iter().zip(&other).filter(|(x, y)| x != y).take(2).collect();
                    panic!(
                        "{path} step {}: neighbours of particle {id} differ: {diff:?}",
                        k + 1
                    );
                }
            }
        }
    }
}

/// With `balance.load = "pairs"` (the default) a scene of one size splits at set-up by each
/// site's expected neighbours (a dummy wall site weighs 2/(3π) of a fluid one in 2D, 3/16 in
/// 3D), no rank owning more than `balance.max_count` (1.5) times the mean count: the pair
/// imbalance after set-up of the dam breaks on 3 ranks is 1.13 and 1.50, where a split by
/// counts gave 1.43 and 1.89 (measured before the change); counted in particles the split is
/// what it was.
#[test]
fn a_scene_of_one_size_splits_by_expected_pairs() {
    fn on_rank<const D: usize>(scene: &Scene, comm: &dyn Comm) -> hsph::error::Result<(f64, usize)> {
        let sim = Simulation::<D>::new(scene, comm)?;
        Ok((sim.balance.imbalance, sim.p.n_owned))
    }
    for (path, bound) in [
        ("inputs/dam_break_2d.toml", 1.2),
        ("tests/data/dam_break_3d_small.toml", 1.6),
    ] {
        for (load, ok) in [("pairs", bound), ("particles", 1.02)] {
            let s = scene(path, &[&format!("balance.load=\"{load}\"")]);
            let out = run_local(3, 1, |comm| match s.dimension {
                2 => on_rank::<2>(&s, comm),
                _ => on_rank::<3>(&s, comm),
            })
            .unwrap();
            let imb = out[0].0;
            assert!(imb <= ok, "{path}: {load} imbalance after set-up {imb} > {ok}");
            let n: usize = out.iter().map(|o| o.1).sum();
            let most = out.iter().map(|o| o.1).max().unwrap();
            let cap = s.balance.max_count * n as f64 / 3.0;
            assert!(
                most as f64 <= cap + 3.0,
                "{path}: {load}: a rank owns {most} > {cap}"
            );
        }
    }
}
