//! Halos and migration between ranks: who sends which particle, under which image operation,
//! to whom — built once per re-binning and reused by every ghost refresh of the step.
//!
//! A ghost is an owned particle seen through an image operation (per axis: nothing, a periodic
//! shift by ±L, or a reflection across a mirror wall plane) and identified by its sort key
//! `id << IMAGE_BITS | image code`. The owner of a particle makes every image the geometry
//! asks for (periodic shift when it lies within the support of a periodic face, reflection when
//! it lies within the support of a mirror plane) and sends each image — the plain particle
//! included — to every rank whose box, widened by the support radius, contains the image's
//! position, itself included except for the plain particle. So a particle can arrive twice with
//! different shifts, a rank can be its own periodic neighbour, ghosts come from every rank whose
//! widened box overlaps (not only face neighbours), and one rank behaves exactly like many:
//! the serial back end sends its periodic and mirror images to itself.
//!
//! Messages are received from peers in ascending rank order. Results never depend on that order
//! anyway: every gather loop sums neighbours by global cell and key.

use crate::boundary::images::{images_of, is_plain, AxisOp, ImageSpace};
use crate::comm::{Comm, Pending, Phase, Tag};
use crate::decomp::{fold_parts, Cloud, Decomposition};
use crate::error::{Error, Result};
use crate::particles::wire::{Reader, Words};
use crate::particles::{Fields, Kinds, Particles, Record};
use crate::Vector;
use rayon::prelude::*;

/// Which rank owns which region: the decomposition's blocks and their placement on ranks.
#[derive(Debug, Clone)]
pub struct RankMap<T> {
    /// The decomposition (blocks and cut planes).
    pub decomp: T,
    /// Rank of each block (a permutation, fixed for the run).
    pub block_to_rank: Vec<usize>,
}

/// The rank map of a `D`-dimensional run.
pub type Ranks<const D: usize> = RankMap<Decomposition<D>>;

/// Rank counts up to which destinations are found by testing every rank's box; above, the
/// decomposition's block search proposes candidates (same exact test, so same result).
const BRUTE_FORCE_RANKS: usize = 32;

impl<const D: usize> RankMap<Decomposition<D>> {
    /// Blocks on ranks by `block_to_rank`.
    pub fn new(decomp: Decomposition<D>, block_to_rank: Vec<usize>) -> Self {
        RankMap {
            decomp,
            block_to_rank,
        }
    }

    /// Number of ranks.
    pub fn ranks(&self) -> usize {
        self.block_to_rank.len()
    }

    /// Boxes `[min, max)` (m) of every rank's block, indexed by rank.
    pub fn boxes(&self) -> Vec<(Vector<D>, Vector<D>)> {
        let mut out = vec![(Vector::zeros(), Vector::zeros()); self.ranks()];
        for (b, &r) in self.block_to_rank.iter().enumerate() {
            out[r] = self.decomp.block_box(b);
        }
        out
    }

    /// The rank that owns the particle `id` at position `x` (total: see
    /// [`Decomposition::block_of`]).
    pub fn owner(&self, x: &Vector<D>, id: u64) -> usize {
        self.block_to_rank[self.decomp.block_of(x, id)]
    }

    /// Every rank whose box widened by `r` contains `x` (ascending), into `out`.
    pub fn destinations(
        &self,
        x: &Vector<D>,
        r: f64,
        boxes: &[(Vector<D>, Vector<D>)],
        out: &mut Vec<usize>,
    ) {
        out.clear();
        if boxes.len() <= BRUTE_FORCE_RANKS {
            out.extend((0..boxes.len()).filter(|&k| in_widened(x, &boxes[k], r)));
            return;
        }
        // a slightly larger query box makes the candidates a superset despite rounding
        let w = Vector::<D>::repeat(1.001 * r);
        for b in self.decomp.blocks_overlapping(&(x - w), &(x + w)) {
            let k = self.block_to_rank[b];
            if in_widened(x, &boxes[k], r) {
                out.push(k);
            }
        }
        out.sort_unstable();
    }
}

/// Ghosts each rank sends each other rank (`counts[src * P + dst]`, self-sends included) for
/// the particles of `cloud` (fluid ones have mirror images), owned by `map.owner`: the
/// counting half of [`HaloPlan::build`] with no communication (the same [`Targets`] rule), so
/// that `hsph plan` predicts a run's halo traffic exactly.
pub fn ghost_counts<const D: usize, C: Cloud<D>>(
    cloud: &C,
    space: &ImageSpace<D>,
    map: &Ranks<D>,
    boxes: &[(Vector<D>, Vector<D>)],
    support: f64,
) -> Vec<u64> {
    let p = map.ranks();
    // each rayon task holds a dense P × P counter; integer sums, so any split agrees
    fold_parts(
        cloud,
        || (vec![0u64; p * p], Targets::new()),
        |(counts, targets), k| {
            cloud.visit(k, |xi, id, f| {
                let me = map.owner(xi, id);
                targets.each(xi, f, me, space, map, boxes, support, |r, _| {
                    counts[me * p + r] += 1
                });
            })
        },
        |mut a, b| {
            a.0.iter_mut().zip(b.0).for_each(|(u, v)| *u += v);
            a
        },
    )
    .0
}

/// Payload bytes of one ghost in the build message of a store without the
/// `dropped` fields.
pub fn record_bytes<const D: usize>(dropped: Fields) -> u64 {
    (Record::<D>::words_carried(dropped) * 8) as u64
}

/// Payload bytes of one ghost in a refresh of `fields`.
pub fn field_bytes<const D: usize>(fields: Fields) -> u64 {
    (Particles::<D>::field_words(fields) * 8) as u64
}

/// Owned particles per parallel task when a ghost build finds each particle's ghosts.
const HALO_CHUNK: usize = 4096;

/// Tags of the halo protocol.
const TAG_GHOSTS: Tag = 102;
const TAG_REFRESH: Tag = 103;
const TAG_MIGRATE: Tag = 104;
const TAG_ROUTE: Tag = 105;
const TAG_HAND_OVER: Tag = 106;

/// One planned ghost: owned source index and image operation.
#[derive(Debug, Clone, Copy)]
struct Entry<const D: usize> {
    src: u32,
    ops: [AxisOp; D],
}

/// The halo plan of one rank.
#[derive(Debug, Clone, Default)]
pub struct HaloPlan<const D: usize> {
    /// Outgoing ghosts per destination rank (ascending), in send order.
    out: Vec<(usize, Vec<Entry<D>>)>,
    /// Incoming ghost counts per source rank (ascending), in receive (and storage) order.
    inc: Vec<(usize, usize)>,
    /// Ghosts received from other ranks (not from this rank).
    remote: usize,
}

/// True if `x` lies in the box `[min, max)` widened by `r`: `min − r ≤ x < max + r` (every
/// point within `r` of an owned particle, which lies in `[min, max)`, passes).
#[inline]
fn in_widened<const D: usize>(x: &Vector<D>, b: &(Vector<D>, Vector<D>), r: f64) -> bool {
    (0..D).all(|a| x[a] >= b.0[a] - r && x[a] < b.1[a] + r)
}

/// True if `x` is farther than `r` from every face of the box (so no other box's widened
/// region can contain it).
#[inline]
fn deep_inside<const D: usize>(x: &Vector<D>, b: &(Vector<D>, Vector<D>), r: f64) -> bool {
    (0..D).all(|a| x[a] - b.0[a] > r && b.1[a] - x[a] > r)
}

/// Scratch space and the rule of who receives which image of a particle: every image (the
/// plain particle included) goes to every rank whose widened box holds it, except the plain
/// particle to its owner. Shared by [`HaloPlan::build`] and [`ghost_counts`].
struct Targets<const D: usize> {
    options: Vec<Vec<AxisOp>>,
    imgs: Vec<[AxisOp; D]>,
    dst: Vec<usize>,
}

impl<const D: usize> Targets<D> {
    fn new() -> Self {
        Targets {
            options: vec![Vec::with_capacity(3); D],
            imgs: Vec::with_capacity(8),
            dst: Vec::new(),
        }
    }

    /// Call `f(rank, ops)` for every ghost of the particle at `x` owned by `me`.
    #[allow(clippy::too_many_arguments)]
    #[inline]
    fn each(
        &mut self,
        x: &Vector<D>,
        mirrored: bool,
        me: usize,
        space: &ImageSpace<D>,
        map: &Ranks<D>,
        boxes: &[(Vector<D>, Vector<D>)],
        support: f64,
        mut f: impl FnMut(usize, &[AxisOp; D]),
    ) {
        images_of(x, mirrored, space, support, &mut self.options, &mut self.imgs);
        for ops in &self.imgs {
            let plain = is_plain(ops);
            let (xg, _) = space.apply(x, ops);
            if plain && deep_inside(&xg, &boxes[me], support) {
                continue;
            }
            map.destinations(&xg, support, boxes, &mut self.dst);
            for &r in &self.dst {
                if !(plain && r == me) {
                    f(r, ops);
                }
            }
        }
    }
}

/// Read `n` records without the `dropped` fields from a message of exactly that length and
/// append each with `push`.
fn read_records<const D: usize>(
    m: &[u8],
    n: usize,
    dropped: Fields,
    what: &str,
    mut push: impl FnMut(Record<D>),
) -> Result<()> {
    if m.len() != n * Record::<D>::words_carried(dropped) * 8 {
        return Err(Error::run(format!("{what}: message of unexpected length")));
    }
    let mut r = Reader::new(m);
    for _ in 0..n {
        push(Record::get_carried(dropped, &mut r)?);
    }
    Ok(())
}

impl<const D: usize> HaloPlan<D> {
    /// Number of ghosts (from this rank's own images and from other ranks).
    pub fn len(&self) -> usize {
        self.inc.iter().map(|(_, n)| n).sum()
    }

    /// True if there are no ghosts.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Ghosts received from other ranks.
    pub fn remote(&self) -> usize {
        self.remote
    }

    /// Rebuild every ghost of `p` (dropping the old ones): plan, counts, and records of the
    /// fields `sent` (the others read as zero until a refresh sends them). `boxes[r]` is rank
    /// r's box (from `map`); this rank is `comm.rank()`.
    #[allow(clippy::too_many_arguments)]
    pub fn build(
        &mut self,
        p: &mut Particles<D>,
        space: &ImageSpace<D>,
        map: &Ranks<D>,
        boxes: &[(Vector<D>, Vector<D>)],
        support: f64,
        sent: Fields,
        comm: &dyn Comm,
    ) -> Result<()> {
        let (me, size) = (comm.rank(), comm.size());
        let prev = comm.set_phase(Phase::Halo);
        p.truncate_ghosts();
        // the owned particles' ghosts found by chunks in parallel, each chunk's lists joined
        // in chunk order: the lists of a serial sweep, on any number of threads
        let n = p.n_owned;
        let chunks: Vec<Vec<Vec<Entry<D>>>> = (0..n.div_ceil(HALO_CHUNK))
            .into_par_iter()
            .map(|c| {
                let mut local: Vec<Vec<Entry<D>>> = vec![Vec::new(); size];
                let mut targets = Targets::new();
                for i in c * HALO_CHUNK..((c + 1) * HALO_CHUNK).min(n) {
                    let to = |r: usize, ops: &[AxisOp; D]| {
                        local[r].push(Entry {
                            src: i as u32,
                            ops: *ops,
                        })
                    };
                    targets.each(&p.x[i], p.kind[i].is_fluid(), me, space, map, boxes, support, to);
                }
                local
            })
            .collect();
        let mut per_dst: Vec<Vec<Entry<D>>> = (0..size)
            .map(|r| Vec::with_capacity(chunks.iter().map(|c| c[r].len()).sum()))
            .collect();
        for chunk in chunks {
            for (all, part) in per_dst.iter_mut().zip(chunk) {
                all.extend(part);
            }
        }
        let counts = incoming_counts(per_dst.iter().map(|l| l.len()), comm)?;
        self.inc = (0..size)
            .filter_map(|s| {
                let n = counts[s * size + me] as usize;
                (n > 0).then_some((s, n))
            })
            .collect();
        self.remote = self.inc.iter().filter(|(s, _)| *s != me).map(|(_, n)| n).sum();
        self.out = per_dst
            .into_iter()
            .enumerate()
            .filter(|(_, l)| !l.is_empty())
            .collect();
        let dropped = p.dropped.or(Fields::ALL.without(sent));
        let words = Record::<D>::words_carried(dropped);
        let sends = self.pack(
            words,
            |_| true,
            |buf, e| {
                let i = e.src as usize;
                p.record(i)
                    .imaged(&space.image(p.id[i], &e.ops))
                    .put_carried(dropped, &mut Words::new(buf));
            },
        );
        let msgs = comm.exchange(sends, &self.sources(), TAG_GHOSTS)?;
        p.grow_for(self.inc.iter().map(|(_, n)| n).sum());
        for ((_, n), m) in self.inc.iter().zip(&msgs) {
            read_records::<D>(m, *n, dropped, "halo", |r| p.push_ghost(&r))?;
        }
        comm.set_phase(prev);
        Ok(())
    }

    /// One message per destination: `words` words per planned ghost that `keep` selects,
    /// written by `put`.
    fn pack(
        &self,
        words: usize,
        keep: impl Fn(&Entry<D>) -> bool,
        mut put: impl FnMut(&mut Vec<u8>, &Entry<D>),
    ) -> Vec<(usize, Vec<u8>)> {
        self.out
            .iter()
            .map(|(dst, list)| {
                let mut buf = Vec::with_capacity(list.len() * words * 8);
                for e in list.iter().filter(|e| keep(e)) {
                    put(&mut buf, e);
                }
                (*dst, buf)
            })
            .collect()
    }

    /// Source ranks of the incoming ghosts, ascending.
    fn sources(&self) -> Vec<usize> {
        self.inc.iter().map(|(s, _)| *s).collect()
    }

    /// Send the current `fields` of every planned ghost of the classes `kinds` and overwrite
    /// the ghosts' copies (a ghost's kind is its owner's, so both sides select the same
    /// ghosts, in plan order). One blocking exchange: no thread waits for the messages, which
    /// under MPI costs a third of the split form's time when nothing is computed between
    /// (docs/benchmark-log.md, "A split by pairs under a count cap, and kept ghosts refreshed by
    /// class").
    pub fn refresh(
        &self,
        p: &mut Particles<D>,
        space: &ImageSpace<D>,
        need: (Fields, Kinds),
        comm: &dyn Comm,
    ) -> Result<()> {
        let prev = comm.set_phase(Phase::Halo);
        let sends = self.pack_refresh(p, space, need);
        let msgs = comm.exchange(sends, &self.sources(), TAG_REFRESH);
        comm.set_phase(prev);
        self.unpack_refresh(p, need, msgs?)
    }

    /// The first half of [`HaloPlan::refresh`] split for overlap: pack and send the current
    /// `fields` of every planned ghost of the classes `kinds`. Until
    /// [`HaloPlan::finish_refresh`] the ghosts keep their old copies and the owned particles'
    /// `fields` must not change.
    pub fn start_refresh(
        &self,
        p: &Particles<D>,
        space: &ImageSpace<D>,
        need: (Fields, Kinds),
        comm: &dyn Comm,
    ) -> Result<Pending> {
        let prev = comm.set_phase(Phase::Halo);
        let sends = self.pack_refresh(p, space, need);
        let pending = comm.start_exchange(sends, &self.sources(), TAG_REFRESH);
        comm.set_phase(prev);
        pending
    }

    /// The second half of [`HaloPlan::refresh`] split for overlap: receive `fields` of every
    /// ghost (waiting for them) and overwrite the ghosts' copies.
    pub fn finish_refresh(
        &self,
        p: &mut Particles<D>,
        need: (Fields, Kinds),
        pending: Pending,
        comm: &dyn Comm,
    ) -> Result<()> {
        let prev = comm.set_phase(Phase::Halo);
        let msgs = comm.finish_exchange(pending);
        comm.set_phase(prev);
        self.unpack_refresh(p, need, msgs?)
    }

    /// One message per destination with the `fields` of its ghosts of the classes `kinds`.
    fn pack_refresh(
        &self,
        p: &Particles<D>,
        space: &ImageSpace<D>,
        (fields, kinds): (Fields, Kinds),
    ) -> Vec<(usize, Vec<u8>)> {
        let words = Particles::<D>::field_words(fields);
        let keep = |e: &Entry<D>| kinds.has(p.kind[e.src as usize]);
        self.pack(words, keep, |buf, e| {
            let i = e.src as usize;
            p.put_fields(i, fields, &space.image(p.id[i], &e.ops), &mut Words::new(buf));
        })
    }

    /// Overwrite the `fields` of the ghosts of the classes `kinds` from one message per
    /// source, in plan order.
    fn unpack_refresh(
        &self,
        p: &mut Particles<D>,
        (fields, kinds): (Fields, Kinds),
        msgs: Vec<Vec<u8>>,
    ) -> Result<()> {
        let words = Particles::<D>::field_words(fields);
        let mut g = p.n_owned;
        for ((_, n), m) in self.inc.iter().zip(&msgs) {
            let ghosts = g..g + n;
            g += n;
            let selected = ghosts.clone().filter(|&k| kinds.has(p.kind[k])).count();
            if m.len() != selected * words * 8 {
                return Err(Error::run("halo: refresh message of unexpected length"));
            }
            let mut r = Reader::new(m);
            for k in ghosts {
                if kinds.has(p.kind[k]) {
                    p.get_fields(k, fields, &mut r)?;
                }
            }
        }
        Ok(())
    }
}

/// Every rank's outgoing counts (`counts[src * P + dst]`), learnt by an integer all-reduce of
/// this rank's `outgoing` per destination. Logged as phase `other`: counts are not payload.
fn incoming_counts(outgoing: impl Iterator<Item = usize>, comm: &dyn Comm) -> Result<Vec<u64>> {
    let (me, size) = (comm.rank(), comm.size());
    let mut counts = vec![0u64; size * size];
    for (r, n) in outgoing.enumerate() {
        counts[me * size + r] = n as u64;
    }
    let prev = comm.set_phase(Phase::Other);
    comm.all_reduce_sum_u64(&mut counts)?;
    comm.set_phase(prev);
    Ok(counts)
}

/// Send `out[r]`, which holds `n_out[r]` items, to each rank r whose buffer is not empty, and
/// receive from every rank that sends here (learnt by [`incoming_counts`]): returns
/// `(items, message)` per source rank, in rank order.
fn exchange_counted(
    out: Vec<Vec<u8>>,
    n_out: &[usize],
    tag: Tag,
    comm: &dyn Comm,
) -> Result<Vec<(usize, Vec<u8>)>> {
    let (me, size) = (comm.rank(), comm.size());
    let counts = incoming_counts(n_out.iter().copied(), comm)?;
    let from: Vec<usize> = (0..size)
        .filter(|&s| s != me && counts[s * size + me] > 0)
        .collect();
    let sends: Vec<(usize, Vec<u8>)> = out
        .into_iter()
        .enumerate()
        .filter(|(_, b)| !b.is_empty())
        .collect();
    let msgs = comm.exchange(sends, &from, tag)?;
    Ok(from
        .iter()
        .map(|&s| counts[s * size + me] as usize)
        .zip(msgs)
        .collect())
}

/// Send `value[i]` of each owned particle of `p` to the rank that owns it under `map`, and
/// return the values this rank receives or keeps, as `(id, value)` sorted by id: what does not
/// travel in the particle records (a restart's accelerations) follows its particles.
pub fn route_to_owners<const D: usize>(
    p: &Particles<D>,
    value: &[Vector<D>],
    map: &Ranks<D>,
    comm: &dyn Comm,
) -> Result<Vec<(u64, Vector<D>)>> {
    let (me, size) = (comm.rank(), comm.size());
    let prev = comm.set_phase(Phase::Migration);
    let mut kept = Vec::new();
    let mut out: Vec<Vec<u8>> = vec![Vec::new(); size];
    let mut n_out = vec![0usize; size];
    for (i, v) in value.iter().enumerate().take(p.n_owned) {
        let r = map.owner(&p.x[i], p.id[i]);
        if r == me {
            kept.push((p.id[i], *v));
            continue;
        }
        out[r].extend_from_slice(&p.id[i].to_le_bytes());
        for c in v.iter() {
            out[r].extend_from_slice(&c.to_le_bytes());
        }
        n_out[r] += 1;
    }
    let msgs = exchange_counted(out, &n_out, TAG_ROUTE, comm)?;
    let width = 8 * (D + 1);
    for (_, m) in &msgs {
        if m.len() % width != 0 {
            return Err(Error::run("routing to owners: a message of the wrong length"));
        }
        for c in m.chunks_exact(width) {
            let word = |k: usize| c[8 * k..8 * k + 8].try_into().expect("8 bytes");
            let v = Vector::<D>::from_fn(|a, _| f64::from_le_bytes(word(a + 1)));
            kept.push((u64::from_le_bytes(word(0)), v));
        }
    }
    comm.set_phase(prev);
    kept.sort_unstable_by_key(|e| e.0);
    Ok(kept)
}

/// Send the owned particles `to` lists, as `(index, rank)` with rank ≠ this one, to those
/// ranks, each as its carried record and its acceleration, and return what this rank
/// receives, sorted by id. The senders keep their particles: what the receiver makes of them
/// (a merge, `sim/merge.rs`) is the caller's.
pub fn hand_over<const D: usize>(
    p: &Particles<D>,
    to: &[(usize, usize)],
    comm: &dyn Comm,
) -> Result<Vec<(Record<D>, Vector<D>)>> {
    let (me, size) = (comm.rank(), comm.size());
    let prev = comm.set_phase(Phase::Migration);
    let dropped = p.dropped;
    let mut out: Vec<Vec<u8>> = vec![Vec::new(); size];
    let mut n_out = vec![0usize; size];
    for &(i, r) in to {
        debug_assert!(r != me && i < p.n_owned);
        p.record(i).put_carried(dropped, &mut Words::new(&mut out[r]));
        for c in p.acc[i].iter() {
            out[r].extend_from_slice(&c.to_le_bytes());
        }
        n_out[r] += 1;
    }
    let msgs = exchange_counted(out, &n_out, TAG_HAND_OVER, comm)?;
    let rec = Record::<D>::words_carried(dropped) * 8;
    let width = rec + 8 * D;
    let mut got = Vec::new();
    for (n, m) in &msgs {
        if m.len() != n * width {
            return Err(Error::run(
                "handing particles over: a message of the wrong length",
            ));
        }
        for c in m.chunks_exact(width) {
            let r = Record::get_carried(dropped, &mut Reader::new(&c[..rec]))?;
            let word = |k: usize| c[rec + 8 * k..rec + 8 * k + 8].try_into().expect("8 bytes");
            got.push((r, Vector::<D>::from_fn(|a, _| f64::from_le_bytes(word(a)))));
        }
    }
    comm.set_phase(prev);
    got.sort_unstable_by_key(|e| e.0.id);
    Ok(got)
}

/// Move every owned particle that left this rank's box to its owner (ghosts must have been
/// dropped). Returns the number of particles sent. Positions must already be wrapped into
/// the periodic box; a particle outside every box is an error naming it.
pub fn migrate<const D: usize>(
    p: &mut Particles<D>,
    map: &Ranks<D>,
    boxes: &[(Vector<D>, Vector<D>)],
    comm: &dyn Comm,
) -> Result<usize> {
    let me = comm.rank();
    let size = comm.size();
    let prev = comm.set_phase(Phase::Migration);
    debug_assert_eq!(p.len(), p.n_owned);
    let mine = boxes[me];
    let mut per_dst: Vec<Vec<usize>> = vec![Vec::new(); size];
    for i in 0..p.n_owned {
        let x = &p.x[i];
        // strictly inside: a particle on a face may belong to the neighbour (a plane's tie)
        if (0..D).all(|a| x[a] > mine.0[a] && x[a] < mine.1[a]) {
            continue;
        }
        let r = map.owner(x, p.id[i]);
        if r != me {
            per_dst[r].push(i);
        }
    }
    let sent: usize = per_dst.iter().map(|l| l.len()).sum();
    let dropped = p.dropped;
    let words = Record::<D>::words_carried(dropped);
    let out: Vec<Vec<u8>> = per_dst
        .iter()
        .map(|list| {
            let mut buf = Vec::with_capacity(list.len() * words * 8);
            for &i in list {
                p.record(i).put_carried(dropped, &mut Words::new(&mut buf));
            }
            buf
        })
        .collect();
    let n_out: Vec<usize> = per_dst.iter().map(|l| l.len()).collect();
    let msgs = exchange_counted(out, &n_out, TAG_MIGRATE, comm)?;
    // drop the emigrants (keeping the others in order), then append the immigrants
    if sent > 0 {
        let mut leaving = vec![false; p.n_owned];
        per_dst.iter().flatten().for_each(|&i| leaving[i] = true);
        let keep: Vec<usize> = (0..p.n_owned).filter(|&i| !leaving[i]).collect();
        p.permute_owned(&keep);
    }
    for (n, m) in &msgs {
        read_records::<D>(m, *n, dropped, "migration", |r| p.push_owned(r))?;
    }
    comm.set_phase(prev);
    Ok(sent)
}

/// Every owned particle as whole records (for gathering output on one rank).
pub fn pack_owned<const D: usize>(p: &Particles<D>) -> Vec<u8> {
    pack_owned_where(p, &|_, _| true, p.dropped)
}

/// The records of the owned particles `keep` selects, in storage order, without the
/// `dropped` fields (a field `p` drops but `dropped` does not is sent as zero): what
/// [`unpack_owned`] reads into a store that drops the same.
pub fn pack_owned_where<const D: usize>(
    p: &Particles<D>,
    keep: &dyn Fn(&Particles<D>, usize) -> bool,
    dropped: Fields,
) -> Vec<u8> {
    let kept: Vec<usize> = (0..p.n_owned).filter(|&i| keep(p, i)).collect();
    let mut buf = Vec::with_capacity(kept.len() * Record::<D>::words_carried(dropped) * 8);
    for i in kept {
        p.record(i).put_carried(dropped, &mut Words::new(&mut buf));
    }
    buf
}

/// Append the records of [`pack_owned`] to `p` as owned particles (no ghosts may exist; `p`
/// drops the fields the sender's store dropped).
pub fn unpack_owned<const D: usize>(bytes: &[u8], p: &mut Particles<D>) -> Result<()> {
    let dropped = p.dropped;
    let w = Record::<D>::words_carried(dropped) * 8;
    if !bytes.len().is_multiple_of(w) {
        return Err(Error::run("gather: message of unexpected length"));
    }
    p.reserve(bytes.len() / w);
    read_records::<D>(bytes, bytes.len() / w, dropped, "gather", |r| p.push_owned(r))
}
