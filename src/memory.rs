//! How much memory a run will take, estimated before anything is allocated, and how much the
//! process may use. `hsph run` refuses (exit 2) a layout whose estimate exceeds what is
//! available; `hsph check` prints the estimate.
//!
//! The model follows what the code allocates today, per rank:
//! - **set-up** (distributed, docs/performance_model.md, "Memory per rank"): a rank streams
//!   its share of the lattice to count loads, without storing it, then builds only the sites
//!   it owns ([`crate::setup::SiteSource::build`]): its particle store in growing vectors, a
//!   label (4 B) and a sort index (8 B) per particle, and the sorted copy beside the old one
//!   for a moment; placement adds a P × P table of halo volumes;
//! - **halo and migration counts**: a P × P table of u64 all-reduced (two copies) per rank;
//! - **running**: the owned particles and their ghosts (a fraction of the owned ones), the
//!   cell list and the neighbour lists (4 B per neighbour, kept by fluid and solid particles,
//!   each pair once in pair mode, none with `neighbours = "cells"`);
//! - **meshes** (`shape = "mesh"`): each placed mesh and its indexes, held once per process
//!   (the ranks of one process share the scene) from the load to the end;
//! - **the process itself** ([`PROCESS_BASE`]): the binary's resident pages, the runtime and
//!   the thread pool, whatever the scene.
//!
//! Ranks of the local back end share one process, so their estimates add up; under MPI each
//! process holds one rank. Limits apply per process.

use crate::particles::Particles;
use crate::physics::solid::dynamics::SolidScratch;
use crate::scene::lattice::BodySites;
use crate::scene::Scene;

/// Neighbours per particle in the estimate: the lattice's
/// ([`crate::scene::Discretisation::lattice_neighbours`]) times the mean list length of the
/// scene's particles ([`crate::scene::lattice::list_weight`]: a refined particle with the
/// scene's h lists 2^(ℓD) times as many).
fn neighbours<const D: usize>(scene: &Scene, sites: &[BodySites]) -> f64 {
    scene.discretisation.lattice_neighbours(D) * crate::scene::lattice::list_weight(sites)
}

/// The shares of the scene's particles whose key starts with each of `prefixes` (`fluid`,
/// `solid`, `wall`), from the lattice's counts (`sites`).
fn shares<const K: usize>(sites: &[BodySites], prefixes: [&str; K]) -> [f64; K] {
    let all = sites.iter().map(|b| b.sites).sum::<u64>().max(1) as f64;
    prefixes.map(|pre| {
        let of: u64 = (sites.iter())
            .filter(|b| b.key.starts_with(pre))
            .map(|b| b.sites)
            .sum();
        of as f64 / all
    })
}

/// The share of the scene's particles that keep neighbour lists of their own: its fluid and
/// solid particles (walls keep none, or only their fluid neighbours). On the shipped scenes the
/// stored entries are 0.90–1.12 of these particles times the lattice's neighbours (pair mode:
/// half).
fn listing_share(sites: &[BodySites]) -> f64 {
    let [walls] = shares(sites, ["wall"]);
    1.0 - walls
}

/// Bytes per rank of the cell grid: a start (u32) and an interior flag per cell of the window
/// the particles occupy ([`crate::cells::CellGrid::window`]), taken as the bodies' box grown by
/// an edge (a wall's layers lie outside its box) within the domain. A debris cloud's window
/// grows as it spreads, up to the whole domain.
fn grid_bytes<const D: usize>(scene: &Scene, sites: &[BodySites], edge: f64) -> f64 {
    let (lo, hi) = bodies_box::<D>(scene, sites);
    let lo = crate::Vector::<D>::from_fn(|a, _| (lo[a] - edge).max(scene.domain.min[a]));
    let hi = crate::Vector::<D>::from_fn(|a, _| (hi[a] + edge).min(scene.domain.max[a]));
    crate::cells::CellGrid::<D>::with_reach(&lo, &hi, edge, edge).len() as f64 * 5.0
}

/// The box of the bodies that have particles (`sites`: fluid, solid and wall boxes), or the
/// domain without any.
fn bodies_box<const D: usize>(scene: &Scene, sites: &[BodySites]) -> ([f64; D], [f64; D]) {
    let (mut lo, mut hi) = ([f64::INFINITY; D], [f64::NEG_INFINITY; D]);
    for b in sites {
        for a in 0..D {
            lo[a] = lo[a].min(b.min[a]);
            hi[a] = hi[a].max(b.max[a]);
        }
    }
    if (0..D).all(|a| hi[a] > lo[a]) {
        (lo, hi)
    } else {
        (
            std::array::from_fn(|a| scene.domain.min[a]),
            std::array::from_fn(|a| scene.domain.max[a]),
        )
    }
}

/// Per axis: the faces of the busiest rank's block that receive ghosts, and the most
/// particles per metre along the axis (1/m) a face may cut.
///
/// - **Faces:** two for a block in the middle of the factorisation `Nx·Ny(·Nz) = ranks` the
///   decomposition chooses for the bodies' extents, one at an end of two blocks, none for a
///   single block; two on a periodic axis or with mirror walls, whose images are ghosts too.
/// - **Particles per metre:** each body's sites spread evenly over its box along the axis,
///   summed where the boxes overlap, at the densest place. A face's ghosts are a slab
///   `layers · dx` deep of that density: a cut through the water column of a dam break
///   holds the column's cross-section, whatever the share of the tank the block spans.
fn ghost_faces<const D: usize>(scene: &Scene, sites: &[BodySites], ranks: usize) -> [(f64, f64); D] {
    let bodies: Vec<(&[f64], &[f64], f64)> = (sites.iter())
        .map(|b| (&b.min[..], &b.max[..], b.sites as f64))
        .collect();
    let (lo, hi) = bodies_box::<D>(scene, sites);
    let extent: [f64; D] = std::array::from_fn(|a| hi[a] - lo[a]);
    let blocks = crate::decomp::factorise(ranks, &extent);
    let mirror = scene.walls.iter().any(|w| w.method.makes_images());
    let dx = scene.discretisation.dx;
    std::array::from_fn(|a| {
        let faces = match blocks[a] {
            _ if scene.domain.periodic[a] || mirror => 2.0,
            1 => 0.0,
            2 => 1.0,
            _ => 2.0,
        };
        // the density just past each box's lower face is the densest the profile gets
        let density = |at: f64| -> f64 {
            (bodies.iter())
                .filter(|b| b.0[a] <= at && at < b.1[a].max(b.0[a] + dx))
                .map(|b| b.2 / (b.1[a] - b.0[a]).max(dx))
                .sum()
        };
        let densest = bodies.iter().map(|b| density(b.0[a])).fold(0.0, f64::max);
        (faces, densest)
    })
}

/// Bytes a process holds whatever its scene: the binary's resident pages, the allocator's and
/// the thread pool's (the smallest shipped scenes, 1 336–1 802 particles, peak at 12.8–14.5 MB
/// on one rank, of which their heap is under 1 MB; the Lobovsky dam break's heap is 2.7 MB of
/// 16.3; `tools/memory_estimate.py`, docs/performance_model.md).
pub const PROCESS_BASE: f64 = 13e6;

/// One running rank's memory by part (bytes), as `summary.json`'s `memory_parts_bytes`
/// measures them (which counts the ghosts in the table and the halo's buffers nowhere).
#[derive(Debug, Clone, Copy)]
pub struct Parts {
    /// The owned particles' rows of the particle table.
    pub table: f64,
    /// The ghosts' rows, and their records in the halo's send and receive buffers.
    pub ghosts: f64,
    /// The neighbour lists (none with `neighbours = "cells"`).
    pub lists: f64,
    /// The cell list: a slot per particle and the grid's cells over the whole domain.
    pub cells: f64,
    /// The passes' scratch: pair mode's accumulators (fluid and solid) and the solids'
    /// per-particle rates and stress terms.
    pub scratch: f64,
}

/// A memory estimate (bytes).
#[derive(Debug, Clone, Copy)]
pub struct Estimate {
    /// Particles of the scene.
    pub particles: u64,
    /// Peak bytes of one rank during the set-up.
    pub rank_setup: f64,
    /// Bytes of one rank while running.
    pub rank_run: f64,
    /// What one rank holds while running, by part.
    pub parts: Parts,
    /// Particles one rank owns at most.
    pub rank_owned: f64,
    /// Ranks sharing this process.
    pub ranks_in_process: usize,
    /// Peak bytes of the process: every rank of it at the larger of its set-up peak and its
    /// running state (the running state reuses what the set-up freed: the measured peak is the
    /// set-up's on the large shipped scenes), plus the meshes and [`PROCESS_BASE`].
    pub process: f64,
}

/// Estimate a run of `scene` (`particles` counted by [`crate::scene::lattice::count_particles`]) on
/// `ranks` ranks of which `ranks_in_process` share this process.
pub fn estimate<const D: usize>(
    scene: &Scene,
    particles: u64,
    ranks: usize,
    ranks_in_process: usize,
) -> Estimate {
    let n = particles as f64;
    let p = ranks.max(1) as f64;
    let dropped = crate::setup::dropped_fields(scene);
    // the lattice's counts per body, walked once (a lattice pass for polygon and mesh bodies)
    let sites = crate::scene::lattice::body_sites::<D>(scene);
    let store = Particles::<D>::bytes_per_particle_carried(dropped) as f64;
    let counts = 2.0 * 8.0 * p * p;
    // a block holds up to (1 + 2η)^D of the mean count (decomp docs): 1.05 in 3D, or, balanced
    // on pairs, up to the count cap `balance.max_count`
    let cap = scene.balance.count_cap().unwrap_or(1.0).max(1.05);
    // Verlet lists reach support·(1 + skin): (1 + skin)^D the neighbours
    let verlet = scene.performance.neighbours == crate::scene::NeighbourMode::Verlet;
    let reach = if verlet { 1.0 + scene.performance.skin } else { 1.0 };
    // list entries per particle: fluid and solid particles list their neighbours (pair mode:
    // each pair once); walls list none or only their fluid neighbours, a small share
    let pairs = scene.performance.interactions == crate::scene::Interactions::Pairs;
    let listed = match scene.performance.neighbours {
        crate::scene::NeighbourMode::Cells => 0.0,
        _ => {
            neighbours::<D>(scene, &sites) * reach.powi(D as i32) * listing_share(&sites)
                / if pairs { 2.0 } else { 1.0 }
        }
    };
    // ghosts: the layers of a support (with the lists' skin) on the faces of a rank's block
    // that have a neighbour or images ([`ghost_faces`])
    let faces = ghost_faces::<D>(scene, &sites, ranks.max(1));
    let [solids, fluid] = shares(&sites, ["solid", "fluid"]);
    // a stored entry: a u32 slot, or in pair mode about 2 B (the half lists are delta-encoded,
    // with their offsets: 26 MB for the 12.9 M pairs of the 3D DualSPHysics dam break)
    let entry_bytes = if pairs { 2.0 } else { 4.0 };
    // every slot (owned or ghost): the cell-order copy of its position, a fluid flag, the
    // fluid before it, and a list offset and flags; with solids in pair mode the receiving
    // slots before it too
    let slot_bytes = 8.0 * D as f64 + 10.0 + if pairs && solids > 0.0 { 4.0 } else { 0.0 };
    // pair mode: V_j and p_j/ρ_j² per slot, and per receiving slot the largest pass's
    // accumulators (fluid: dv/dt with the gradient's symmetric matrix and vector, D + D(D+1)/2
    // + D values; solid: the rates' velocity gradient and two works, D² + 2)
    let fluid_acc = (D + D * (D + 1) / 2 + D) as f64;
    let pair_scratch = match pairs {
        true => 16.0 + fluid * 8.0 * fluid_acc + solids * 8.0 * (D * D + 2) as f64,
        false => 0.0,
    };
    // δ⁺ shifting keeps each owned particle's displacement and Taylor increments (2D + 1
    // values) between steps
    let shift_bytes = match scene.physics.shifting {
        crate::scene::ShiftingKind::DeltaPlus => {
            std::mem::size_of::<crate::physics::shifting::Shift<D>>() as f64
        }
        crate::scene::ShiftingKind::None => 0.0,
    };
    let grid = grid_bytes::<D>(scene, &sites, scene.discretisation.support() * reach);
    let layers = (scene.discretisation.support() * reach / scene.discretisation.dx).ceil();
    let per_rank = |owned: f64| {
        // the store, a label and a sort index per particle, and the sorted copy (pages a
        // vector reserves but never writes are not resident)
        let setup = owned * (2.0 * store + 4.0 + 8.0) + counts;
        let layer =
            |(faces, density): (f64, f64)| faces * (layers * scene.discretisation.dx * density).min(owned);
        let ghosts = match faces.iter().any(|f| f.0 > 0.0) {
            true => faces.iter().copied().map(layer).sum::<f64>().min(owned.min(n)) + 1000.0,
            false => 0.0,
        };
        let parts = Parts {
            table: owned * store,
            // the ghosts, and their records in the halo's send and receive buffers
            ghosts: 2.0 * ghosts * Particles::<D>::bytes_per_ghost_carried(dropped) as f64,
            lists: owned * listed * entry_bytes + (owned + ghosts) * slot_bytes,
            cells: grid + (owned + ghosts) * 8.0,
            scratch: (owned + ghosts)
                * (solids * SolidScratch::<D>::BYTES_PER_PARTICLE as f64 + pair_scratch)
                + owned * shift_bytes,
        };
        let run = parts.table + parts.ghosts + parts.lists + parts.cells + parts.scratch + counts;
        (setup, run, parts)
    };
    let meshes = crate::scene::mesh_file::mesh_bytes(scene) as f64;
    let owned = (n / p * cap).min(n * 1.05);
    let (rank_setup, rank_run, parts) = per_rank(owned);
    let (rank_setup, rank_run) = (rank_setup + meshes, rank_run + meshes);
    // the ranks of one process own at most every particle between them
    let k = ranks_in_process.max(1) as f64;
    let (setup, run, _) = per_rank((n / p * cap * k).min(n * 1.05) / k);
    Estimate {
        particles,
        parts,
        rank_owned: owned,
        rank_setup,
        rank_run,
        ranks_in_process: ranks_in_process.max(1),
        process: k * setup.max(run) + meshes + PROCESS_BASE,
    }
}

/// Bytes as "1.5 GB".
pub fn human(b: f64) -> String {
    let units = ["B", "kB", "MB", "GB", "TB", "PB"];
    let mut x = b;
    let mut u = 0;
    while x >= 1000.0 && u + 1 < units.len() {
        x /= 1000.0;
        u += 1;
    }
    format!("{x:.1} {}", units[u])
}

/// Parse a size such as `4G`, `512M`, `2.5GB`, `1000000` (bytes; k, M, G, T are powers of
/// 1000, Ki, Mi, Gi, Ti of 1024).
pub fn parse_size(s: &str) -> Option<f64> {
    let t = s.trim();
    let split = t
        .find(|c: char| !(c.is_ascii_digit() || c == '.'))
        .unwrap_or(t.len());
    let (num, unit) = t.split_at(split);
    let x: f64 = num.parse().ok()?;
    let mult = match unit
        .trim()
        .trim_end_matches(['B', 'b'])
        .to_ascii_lowercase()
        .as_str()
    {
        "" => 1.0,
        "k" => 1e3,
        "m" => 1e6,
        "g" => 1e9,
        "t" => 1e12,
        "ki" => 1024.0,
        "mi" => 1024f64.powi(2),
        "gi" => 1024f64.powi(3),
        "ti" => 1024f64.powi(4),
        _ => return None,
    };
    (x.is_finite() && x > 0.0).then_some(x * mult)
}

/// The memory this process may use (bytes) and where the limit comes from: the smallest of
/// the cgroup limit (`memory.max`), the memory available (`MemAvailable`) and the address-space
/// limit (`ulimit -v`), or `None` if none can be read.
pub fn available() -> Option<(f64, &'static str)> {
    let mut best: Option<(f64, &'static str)> = None;
    let mut take = |v: Option<f64>, what: &'static str| {
        if let Some(v) = v {
            if best.is_none_or(|(b, _)| v < b) {
                best = Some((v, what));
            }
        }
    };
    let read = |p: &str| std::fs::read_to_string(p).ok();
    take(
        read("/sys/fs/cgroup/memory.max").and_then(|s| s.trim().parse().ok()),
        "the cgroup memory limit",
    );
    take(
        read("/proc/meminfo").and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("MemAvailable:"))
                .and_then(|l| l.split_whitespace().nth(1))
                .and_then(|kb| kb.parse::<f64>().ok())
                .map(|kb| kb * 1024.0)
        }),
        "the memory available",
    );
    take(
        read("/proc/self/limits").and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("Max address space"))
                .and_then(|l| l.split_whitespace().nth(3))
                .and_then(|v| v.parse().ok())
        }),
        "the address-space limit (ulimit -v)",
    );
    best
}

/// This process's peak resident set size so far (bytes), from `VmHWM` in `/proc/self/status`
/// (Linux); `None` where that is unavailable. Local ranks share one process: it is their sum.
pub fn peak_rss() -> Option<u64> {
    status_bytes("VmHWM:")
}

/// This process's resident set size now (bytes), from `/proc/self/status` (Linux).
pub fn rss() -> Option<u64> {
    status_bytes("VmRSS:")
}

/// A `kB` line of `/proc/self/status` in bytes.
fn status_bytes(key: &str) -> Option<u64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with(key))?;
    let kb: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb * 1024)
}

/// Reset this process's peak resident set size to its current size (Linux ≥ 4.0: `5` to
/// `/proc/self/clear_refs`), so that [`peak_rss`] afterwards measures what came after, e.g. the
/// step loop without the set-up's transient peak. False where the kernel refuses.
pub fn reset_peak() -> bool {
    std::fs::write("/proc/self/clear_refs", "5").is_ok()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Verlet lists add the skin's neighbours to the list term: (1 + skin)^D − 1 of it, here
    /// in 3D at skin 0.3 (owned · listed · 4 B, one rank), less the cells their wider reach
    /// saves.
    #[test]
    fn verlet_lists_count_the_skins_neighbours() {
        let text = std::fs::read_to_string(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/tests/data/dam_break_3d_small.toml"
        ))
        .unwrap();
        let path = std::path::Path::new("small.toml");
        let (mut scene, _) = crate::scene::load_scene_str(&text, path, "s", &[]).unwrap();
        let n = 10_000u64;
        let lists = estimate::<3>(&scene, n, 1, 1).rank_run;
        scene.performance.neighbours = crate::scene::NeighbourMode::Verlet;
        scene.performance.skin = 0.3;
        let verlet = estimate::<3>(&scene, n, 1, 1).rank_run;
        let owned = n as f64 * 1.05;
        let sites = crate::scene::lattice::body_sites::<3>(&scene);
        let share = listing_share(&sites);
        assert!(share > 0.0 && share < 1.0, "fluid and repulsive walls: {share}");
        let support = scene.discretisation.support();
        // the cells grow with the lists' reach: fewer of them
        let cells = grid_bytes::<3>(&scene, &sites, 1.3 * support) - grid_bytes::<3>(&scene, &sites, support);
        assert!(cells < 0.0, "{cells}");
        let term = owned * neighbours::<3>(&scene, &sites) * share * 4.0 * (1.3f64.powi(3) - 1.0) + cells;
        assert!(
            ((verlet - lists) / term - 1.0).abs() < 1e-12,
            "{verlet} {lists} {term}"
        );
    }

    #[test]
    fn sizes_parse() {
        assert_eq!(parse_size("4G"), Some(4e9));
        assert_eq!(parse_size("512MiB"), Some(512.0 * 1024.0 * 1024.0));
        assert_eq!(parse_size("1000"), Some(1000.0));
        assert_eq!(parse_size("2.5 GB"), Some(2.5e9));
        assert_eq!(parse_size("lots"), None);
        assert_eq!(parse_size("-1G"), None);
        assert_eq!(human(1.5e9), "1.5 GB");
    }
}
