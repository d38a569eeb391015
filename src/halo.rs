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

use crate::comm::{Comm, Phase, Tag};
use crate::decomp::Decomposition;
use crate::error::{Error, Result};
use crate::ghosts::{AxisOp, ImageSpace};
use crate::particles::{Kind, Particles, IMAGE_BITS};
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

    /// The rank that owns position `x` (total: see [`Decomposition::block_of`]).
    pub fn owner(&self, x: &Vector<D>) -> usize {
        self.block_to_rank[self.decomp.block_of(x)]
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
/// particles at `x` (`fluid[i]`: gets mirror images), owned by `map.owner`: the counting half
/// of [`HaloPlan::build`] with no communication, so that `hsph plan` predicts a run's halo
/// traffic exactly.
pub fn ghost_counts<const D: usize>(
    x: &[Vector<D>],
    fluid: &[bool],
    space: &ImageSpace<D>,
    map: &Ranks<D>,
    boxes: &[(Vector<D>, Vector<D>)],
    support: f64,
) -> Vec<u64> {
    let p = map.ranks();
    // a few large chunks: each holds a dense P × P counter; integer sums, so any split agrees
    let chunk = x.len().div_ceil(8).max(1);
    x.par_chunks(chunk)
        .zip(fluid.par_chunks(chunk))
        .map(|(xs, fl)| {
            let mut counts = vec![0u64; p * p];
            let mut options: Vec<Vec<AxisOp>> = vec![Vec::with_capacity(3); D];
            let mut imgs = Vec::with_capacity(8);
            let mut dst = Vec::new();
            for (xi, &f) in xs.iter().zip(fl) {
                let me = map.owner(xi);
                images(xi, f, space, support, &mut options, &mut imgs);
                for ops in &imgs {
                    let plain = ops.iter().all(|o| *o == AxisOp::Keep);
                    let (xg, _) = apply(xi, ops, space);
                    if plain && deep_inside(&xg, &boxes[me], support) {
                        continue;
                    }
                    map.destinations(&xg, support, boxes, &mut dst);
                    for &r in &dst {
                        if !(plain && r == me) {
                            counts[me * p + r] += 1;
                        }
                    }
                }
            }
            counts
        })
        .reduce(
            || vec![0u64; p * p],
            |mut a, b| {
                a.iter_mut().zip(b).for_each(|(u, v)| *u += v);
                a
            },
        )
}

/// Payload bytes of one ghost in the whole-record build message.
pub fn record_bytes(d: usize) -> u64 {
    (record_words(d) * 8) as u64
}

/// Payload bytes of one ghost in a refresh of `fields`.
pub fn field_bytes(fields: Fields, d: usize) -> u64 {
    (fields.words(d) * 8) as u64
}

/// Tags of the halo protocol.
const TAG_GHOSTS: Tag = 102;
const TAG_REFRESH: Tag = 103;
const TAG_MIGRATE: Tag = 104;

/// Particle fields a pass needs fresh on ghosts (a bit set).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Fields(u8);

impl Fields {
    /// Velocity v (m/s).
    pub const V: Fields = Fields(1);
    /// Density ρ (kg/m³).
    pub const RHO: Fields = Fields(2);
    /// Pressure p (Pa).
    pub const P: Fields = Fields(4);
    /// Wall velocity seen in viscous terms v_w (m/s).
    pub const VW: Fields = Fields(8);
    /// Renormalised density gradient ⟨∇ρ⟩^L (kg/m⁴).
    pub const GRAD_RHO: Fields = Fields(16);

    /// Union of two sets.
    pub const fn or(self, o: Fields) -> Fields {
        Fields(self.0 | o.0)
    }

    fn has(self, o: Fields) -> bool {
        self.0 & o.0 != 0
    }

    /// f64 words per particle.
    fn words(self, d: usize) -> usize {
        let mut w = 0;
        if self.has(Fields::V) {
            w += d;
        }
        if self.has(Fields::RHO) {
            w += 1;
        }
        if self.has(Fields::P) {
            w += 1;
        }
        if self.has(Fields::VW) {
            w += d;
        }
        if self.has(Fields::GRAD_RHO) {
            w += d;
        }
        w
    }
}

/// Every mutable field.
pub const ALL_FIELDS: Fields = Fields(31);

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

/// The image operations of a particle at `x` (the plain one first), in a fixed order.
fn images<const D: usize>(
    x: &Vector<D>,
    fluid: bool,
    space: &ImageSpace<D>,
    support: f64,
    options: &mut [Vec<AxisOp>],
    out: &mut Vec<[AxisOp; D]>,
) {
    out.clear();
    for (a, opts) in options.iter_mut().enumerate() {
        opts.clear();
        opts.push(AxisOp::Keep);
        if space.periodic[a] {
            let l = space.max[a] - space.min[a];
            if x[a] - space.min[a] < support {
                opts.push(AxisOp::Shift(l));
            }
            if space.max[a] - x[a] <= support {
                opts.push(AxisOp::Shift(-l));
            }
        }
        if fluid {
            for (k, pl) in space.planes.iter().enumerate() {
                let d = x[a] - pl.at;
                if pl.axis == a
                    && ((pl.fluid_above && d >= 0.0) || (!pl.fluid_above && d <= 0.0))
                    && d.abs() < support
                {
                    opts.push(AxisOp::Mirror(k));
                }
            }
        }
    }
    let total: usize = options.iter().map(|o| o.len()).product();
    for combo in 0..total {
        let mut r = combo;
        let mut ops = [AxisOp::Keep; D];
        for a in (0..D).rev() {
            let n = options[a].len();
            ops[a] = options[a][r % n];
            r /= n;
        }
        out.push(ops);
    }
}

/// Position and sort-key image code of `x` under `ops`.
fn apply<const D: usize>(x: &Vector<D>, ops: &[AxisOp; D], space: &ImageSpace<D>) -> (Vector<D>, u64) {
    let mut xg = *x;
    let mut code = 0u64;
    for a in 0..D {
        match ops[a] {
            AxisOp::Keep => {}
            AxisOp::Shift(s) => xg[a] += s,
            AxisOp::Mirror(k) => xg[a] = 2.0 * space.planes[k].at - xg[a],
        }
        code |= ops[a].code(&space.planes) << (3 * a);
    }
    debug_assert!(code < (1 << IMAGE_BITS));
    (xg, code)
}

/// Transform a vector field (velocity or gradient) by the image operation; `velocity` selects
/// the wall-velocity reflection rule of mirror planes.
fn transform<const D: usize>(
    v: &Vector<D>,
    ops: &[AxisOp; D],
    space: &ImageSpace<D>,
    velocity: bool,
) -> Vector<D> {
    let mut v = *v;
    for (a, op) in ops.iter().enumerate() {
        if let AxisOp::Mirror(k) = *op {
            let pl = &space.planes[k];
            if !velocity {
                v[a] = -v[a];
            } else if pl.no_slip {
                v = 2.0 * pl.wall_velocity - v;
            } else {
                v[a] = 2.0 * pl.wall_velocity[a] - v[a];
            }
        }
    }
    v
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

fn push_f(buf: &mut Vec<u8>, x: f64) {
    buf.extend_from_slice(&x.to_le_bytes());
}
fn push_u(buf: &mut Vec<u8>, x: u64) {
    buf.extend_from_slice(&x.to_le_bytes());
}
fn push_v<const D: usize>(buf: &mut Vec<u8>, v: &Vector<D>) {
    for c in v.iter() {
        push_f(buf, *c);
    }
}

/// Reads 8-byte words from a message.
struct Reader<'a> {
    b: &'a [u8],
    at: usize,
}

impl Reader<'_> {
    fn u(&mut self) -> u64 {
        let w = u64::from_le_bytes(self.b[self.at..self.at + 8].try_into().expect("8 bytes"));
        self.at += 8;
        w
    }
    fn f(&mut self) -> f64 {
        f64::from_bits(self.u())
    }
    fn v<const D: usize>(&mut self) -> Vector<D> {
        Vector::from_fn(|_, _| self.f())
    }
}

/// Words of a whole particle record: id, key, kind|body|mat, x, v, mass, ρ, p, v_w, ∇ρ.
fn record_words(d: usize) -> usize {
    6 + 4 * d
}

fn kind_of(code: u64) -> Result<Kind> {
    match code {
        0 => Ok(Kind::Fluid),
        1 => Ok(Kind::Dummy),
        2 => Ok(Kind::Repulsive),
        k => Err(Error::run(format!("halo: corrupt particle kind {k}"))),
    }
}

/// Append a whole particle record (used for ghosts and migration).
fn pack_record<const D: usize>(
    buf: &mut Vec<u8>,
    p: &Particles<D>,
    i: usize,
    x: &Vector<D>,
    key: u64,
    v: &Vector<D>,
    grad: &Vector<D>,
) {
    push_u(buf, p.id[i]);
    push_u(buf, key);
    push_u(
        buf,
        p.kind[i].code() as u64 | (p.body[i] as u64) << 8 | (p.mat[i] as u64) << 24,
    );
    push_v(buf, x);
    push_v(buf, v);
    push_f(buf, p.mass[i]);
    push_f(buf, p.rho[i]);
    push_f(buf, p.p[i]);
    push_v(buf, &p.vw[i]);
    push_v(buf, grad);
}

/// Read one whole record and append it as a ghost (or, with `owned`, as an owned particle).
fn unpack_record<const D: usize>(r: &mut Reader, p: &mut Particles<D>, owned: bool) -> Result<()> {
    let id = r.u();
    let key = r.u();
    let kbm = r.u();
    let kind = kind_of(kbm & 0xff)?;
    let body = ((kbm >> 8) & 0xffff) as u16;
    let mat = ((kbm >> 24) & 0xffff) as u16;
    let x = r.v::<D>();
    let v = r.v::<D>();
    let mass = r.f();
    let rho = r.f();
    let pr = r.f();
    let vw = r.v::<D>();
    let grad = r.v::<D>();
    if owned {
        p.push_owned(id, kind, body, mat, x, v, mass, rho);
    } else {
        p.push_ghost_record(id, key, kind, body, mat, x, v, mass, rho);
    }
    let i = p.len() - 1;
    p.p[i] = pr;
    p.vw[i] = vw;
    p.grad_rho[i] = grad;
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

    /// Rebuild every ghost of `p` (dropping the old ones) with every field set: plan, counts,
    /// whole records. `boxes[r]` is rank r's box (from `map`); this rank is `comm.rank()`.
    pub fn build(
        &mut self,
        p: &mut Particles<D>,
        space: &ImageSpace<D>,
        map: &Ranks<D>,
        boxes: &[(Vector<D>, Vector<D>)],
        support: f64,
        comm: &dyn Comm,
    ) -> Result<()> {
        let me = comm.rank();
        let size = comm.size();
        let prev = comm.set_phase(Phase::Halo);
        p.truncate_ghosts();
        let mut per_dst: Vec<Vec<Entry<D>>> = vec![Vec::new(); size];
        let mut options: Vec<Vec<AxisOp>> = vec![Vec::with_capacity(3); D];
        let mut imgs = Vec::with_capacity(8);
        let mut dst = Vec::new();
        let mine = boxes[me];
        for i in 0..p.n_owned {
            let x = p.x[i];
            images(
                &x,
                p.kind[i] == Kind::Fluid,
                space,
                support,
                &mut options,
                &mut imgs,
            );
            for ops in &imgs {
                let plain = ops.iter().all(|o| *o == AxisOp::Keep);
                let (xg, _) = apply(&x, ops, space);
                if plain && deep_inside(&xg, &mine, support) {
                    continue;
                }
                map.destinations(&xg, support, boxes, &mut dst);
                for &r in &dst {
                    if !(plain && r == me) {
                        per_dst[r].push(Entry {
                            src: i as u32,
                            ops: *ops,
                        });
                    }
                }
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
        let words = record_words(D);
        let sends: Vec<(usize, Vec<u8>)> = self
            .out
            .iter()
            .map(|(dst, list)| {
                let mut buf = Vec::with_capacity(list.len() * words * 8);
                for e in list {
                    let i = e.src as usize;
                    let (xg, code) = apply(&p.x[i], &e.ops, space);
                    let v = transform(&p.v[i], &e.ops, space, true);
                    let g = transform(&p.grad_rho[i], &e.ops, space, false);
                    pack_record(&mut buf, p, i, &xg, (p.id[i] << IMAGE_BITS) | code, &v, &g);
                }
                (*dst, buf)
            })
            .collect();
        let from: Vec<usize> = self.inc.iter().map(|(s, _)| *s).collect();
        let msgs = comm.exchange(sends, &from, TAG_GHOSTS)?;
        for ((_, n), m) in self.inc.iter().zip(&msgs) {
            if m.len() != n * words * 8 {
                return Err(Error::run("halo: ghost message of unexpected length"));
            }
            let mut r = Reader { b: m, at: 0 };
            for _ in 0..*n {
                unpack_record(&mut r, p, false)?;
            }
        }
        comm.set_phase(prev);
        Ok(())
    }

    /// Send the current `fields` of every planned ghost and overwrite the ghosts' copies.
    pub fn refresh(
        &self,
        p: &mut Particles<D>,
        space: &ImageSpace<D>,
        fields: Fields,
        comm: &dyn Comm,
    ) -> Result<()> {
        let prev = comm.set_phase(Phase::Halo);
        let words = fields.words(D);
        let sends: Vec<(usize, Vec<u8>)> = self
            .out
            .iter()
            .map(|(dst, list)| {
                let mut buf = Vec::with_capacity(list.len() * words * 8);
                for e in list {
                    let i = e.src as usize;
                    if fields.has(Fields::V) {
                        push_v(&mut buf, &transform(&p.v[i], &e.ops, space, true));
                    }
                    if fields.has(Fields::RHO) {
                        push_f(&mut buf, p.rho[i]);
                    }
                    if fields.has(Fields::P) {
                        push_f(&mut buf, p.p[i]);
                    }
                    if fields.has(Fields::VW) {
                        push_v(&mut buf, &p.vw[i]);
                    }
                    if fields.has(Fields::GRAD_RHO) {
                        push_v(&mut buf, &transform(&p.grad_rho[i], &e.ops, space, false));
                    }
                }
                (*dst, buf)
            })
            .collect();
        let from: Vec<usize> = self.inc.iter().map(|(s, _)| *s).collect();
        let msgs = comm.exchange(sends, &from, TAG_REFRESH)?;
        let mut g = p.n_owned;
        for ((_, n), m) in self.inc.iter().zip(&msgs) {
            if m.len() != n * words * 8 {
                return Err(Error::run("halo: refresh message of unexpected length"));
            }
            let mut r = Reader { b: m, at: 0 };
            for _ in 0..*n {
                if fields.has(Fields::V) {
                    p.v[g] = r.v();
                }
                if fields.has(Fields::RHO) {
                    p.rho[g] = r.f();
                }
                if fields.has(Fields::P) {
                    p.p[g] = r.f();
                }
                if fields.has(Fields::VW) {
                    p.vw[g] = r.v();
                }
                if fields.has(Fields::GRAD_RHO) {
                    p.grad_rho[g] = r.v();
                }
                g += 1;
            }
        }
        comm.set_phase(prev);
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
        if (0..D).all(|a| x[a] >= mine.0[a] && x[a] < mine.1[a]) {
            continue;
        }
        let r = map.owner(x);
        if r != me {
            per_dst[r].push(i);
        }
    }
    let counts = incoming_counts(per_dst.iter().map(|l| l.len()), comm)?;
    let from: Vec<usize> = (0..size)
        .filter(|&s| s != me && counts[s * size + me] > 0)
        .collect();
    let sent: usize = per_dst.iter().map(|l| l.len()).sum();
    let words = record_words(D);
    let sends: Vec<(usize, Vec<u8>)> = per_dst
        .iter()
        .enumerate()
        .filter(|(_, l)| !l.is_empty())
        .map(|(dst, list)| {
            let mut buf = Vec::with_capacity(list.len() * words * 8);
            for &i in list {
                pack_record(&mut buf, p, i, &p.x[i], p.key[i], &p.v[i], &p.grad_rho[i]);
            }
            (dst, buf)
        })
        .collect();
    let msgs = comm.exchange(sends, &from, TAG_MIGRATE)?;
    // drop the emigrants (keeping the others in order), then append the immigrants
    let mut leaving = vec![false; p.n_owned];
    for l in &per_dst {
        for &i in l {
            leaving[i] = true;
        }
    }
    if sent > 0 {
        let keep: Vec<usize> = (0..p.n_owned).filter(|&i| !leaving[i]).collect();
        p.permute_owned(&keep);
    }
    for (s, m) in from.iter().zip(&msgs) {
        let n = counts[s * size + me] as usize;
        if m.len() != n * words * 8 {
            return Err(Error::run("migration: message of unexpected length"));
        }
        let mut r = Reader { b: m, at: 0 };
        for _ in 0..n {
            unpack_record(&mut r, p, true)?;
        }
    }
    comm.set_phase(prev);
    Ok(sent)
}

/// Every owned particle as whole records (for gathering output on one rank).
pub fn pack_owned<const D: usize>(p: &Particles<D>) -> Vec<u8> {
    let mut buf = Vec::with_capacity(p.n_owned * record_words(D) * 8);
    for i in 0..p.n_owned {
        pack_record(&mut buf, p, i, &p.x[i], p.key[i], &p.v[i], &p.grad_rho[i]);
    }
    buf
}

/// Append the records of [`pack_owned`] to `p` as owned particles (no ghosts may exist).
pub fn unpack_owned<const D: usize>(bytes: &[u8], p: &mut Particles<D>) -> Result<()> {
    let w = record_words(D) * 8;
    if bytes.len() % w != 0 {
        return Err(Error::run("gather: message of unexpected length"));
    }
    let mut r = Reader { b: bytes, at: 0 };
    for _ in 0..bytes.len() / w {
        unpack_record(&mut r, p, true)?;
    }
    Ok(())
}
