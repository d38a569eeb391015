//! What a type must provide to be a per-particle field of the table: its wire encoding, how it
//! changes under an image operation (periodic shift, mirror reflection), and how output
//! writers read it (a typed [`Column`]).

use super::wire::{Reader, Sink};
use super::Kind;
use crate::error::{Error, Result};
use crate::{Tensor, Vector};
use std::fmt::Write as _;

/// How a field changes when a particle is seen through an image operation.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ImageRule {
    /// Invariant (ids, masses, densities, pressures, codes).
    Same,
    /// The sort key: `id << IMAGE_BITS | image code` of the image.
    Key,
    /// A position: shifted by a periodic image, reflected across a mirror plane.
    Position,
    /// A velocity: a mirror reflects it about the wall's velocity (no-slip: every component,
    /// free-slip: the normal one); periodic shifts leave it.
    Velocity,
    /// A polar vector such as a gradient: a mirror flips the normal component.
    Vector,
    /// A symmetric second-order tensor such as a stress: a mirror across the plane normal to
    /// axis a flips the components T_ab with b ≠ a (T' = R T Rᵀ).
    Tensor,
}

/// One image operation applied to fields (implemented by the boundary image geometry).
pub trait Imager<const D: usize> {
    /// Sort key of the image.
    fn key(&self) -> u64;
    /// Image of a position (m).
    fn position(&self, x: &Vector<D>) -> Vector<D>;
    /// Image of a velocity (m/s).
    fn velocity(&self, v: &Vector<D>) -> Vector<D>;
    /// Image of a polar vector.
    fn vector(&self, v: &Vector<D>) -> Vector<D>;
    /// Image of a symmetric tensor.
    fn tensor(&self, t: &Tensor<D>) -> Tensor<D>;
}

/// A whole field of the store, typed, for output writers.
#[derive(Debug, Clone, Copy)]
pub enum Column<'a, const D: usize> {
    /// Unsigned integers (ids).
    U64(&'a [u64]),
    /// Small unsigned integers (body, material indices).
    U16(&'a [u16]),
    /// Particle kinds (written as their codes).
    Kind(&'a [Kind]),
    /// Scalars.
    F64(&'a [f64]),
    /// Vectors of `D` components.
    Vector(&'a [Vector<D>]),
    /// Symmetric tensors, written as their D(D+1)/2 upper-triangle components.
    Tensor(&'a [Sym<D>]),
}

/// A symmetric D×D tensor as a particle field (a stress, Pa): its D(D+1)/2 distinct components
/// only (6 in 3D where a `Tensor` holds 9), stored, sent and written as its upper triangle. Its
/// own type so that its rules (wire, images) differ from a vector's.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sym<const D: usize> {
    /// T_aa.
    diag: [f64; D],
    /// The components above the diagonal row by row (xy[, xz, yz]): D(D−1)/2 of them, which is
    /// at most D for D ≤ 3; the rest stay 0.
    off: [f64; D],
}

impl<const D: usize> Default for Sym<D> {
    fn default() -> Self {
        Sym {
            diag: [0.0; D],
            off: [0.0; D],
        }
    }
}

impl<const D: usize> Sym<D> {
    /// Place of T_rc, r < c, in `off`.
    #[inline(always)]
    const fn off_index(r: usize, c: usize) -> usize {
        r * D - r * (r + 1) / 2 + (c - r - 1)
    }

    /// The tensor of `t`'s upper triangle (T_rc for r ≤ c): `t` itself when it is symmetric to
    /// the last bit, as every stored stress and correction is.
    #[inline]
    pub fn from_upper(t: &Tensor<D>) -> Self {
        const { assert!(D <= 3, "a symmetric tensor of more than three dimensions") };
        let mut s = Sym::default();
        for r in 0..D {
            s.diag[r] = t[(r, r)];
            for c in r + 1..D {
                s.off[Self::off_index(r, c)] = t[(r, c)];
            }
        }
        s
    }

    /// Component (r, c) (either order).
    #[inline(always)]
    pub fn get(&self, r: usize, c: usize) -> f64 {
        match r.cmp(&c) {
            std::cmp::Ordering::Equal => self.diag[r],
            std::cmp::Ordering::Less => self.off[Self::off_index(r, c)],
            std::cmp::Ordering::Greater => self.off[Self::off_index(c, r)],
        }
    }

    /// The whole D×D tensor.
    #[inline]
    pub fn tensor(&self) -> Tensor<D> {
        Tensor::<D>::from_fn(|r, c| self.get(r, c))
    }
}

impl<const D: usize> std::ops::Add for Sym<D> {
    type Output = Sym<D>;

    /// Component by component: the same sums as the two tensors' (`(a + b).tensor() ==
    /// a.tensor() + b.tensor()` to the bit).
    #[inline(always)]
    fn add(self, o: Sym<D>) -> Sym<D> {
        Sym {
            diag: std::array::from_fn(|a| self.diag[a] + o.diag[a]),
            off: std::array::from_fn(|a| self.off[a] + o.off[a]),
        }
    }
}

/// Row and column of component `k` of a symmetric tensor's upper triangle (xx, xy[, xz], yy[,
/// yz, zz]).
pub fn tensor_component<const D: usize>(k: usize) -> (usize, usize) {
    let mut k = k;
    for r in 0..D {
        if k < D - r {
            return (r, r + k);
        }
        k -= D - r;
    }
    panic!("tensor component {k} out of range")
}

impl<const D: usize> Column<'_, D> {
    /// CSV column names: `stem` for a scalar, `stem` + axis name for a vector.
    pub fn headers(&self, stem: &str) -> Vec<String> {
        match self {
            Column::Vector(_) => ["x", "y", "z"][..D]
                .iter()
                .map(|a| format!("{stem}{a}"))
                .collect(),
            Column::Tensor(_) => (0..self.components())
                .map(|k| {
                    let (r, c) = tensor_component::<D>(k);
                    format!("{stem}{}{}", ["x", "y", "z"][r], ["x", "y", "z"][c])
                })
                .collect(),
            _ => vec![stem.to_string()],
        }
    }

    /// Components per particle.
    pub fn components(&self) -> usize {
        match self {
            Column::Vector(_) => D,
            Column::Tensor(_) => D * (D + 1) / 2,
            _ => 1,
        }
    }

    /// Append particle `i` as CSV text (components comma separated, shortest round-trip
    /// floats).
    pub fn csv(&self, i: usize, out: &mut String) {
        match self {
            Column::U64(v) => write!(out, "{}", v[i]),
            Column::U16(v) => write!(out, "{}", v[i]),
            Column::Kind(v) => write!(out, "{}", v[i].code()),
            Column::F64(v) => write!(out, "{}", v[i]),
            Column::Vector(v) => {
                for (a, c) in v[i].iter().enumerate() {
                    if a > 0 {
                        out.push(',');
                    }
                    let _ = write!(out, "{c}");
                }
                Ok(())
            }
            Column::Tensor(_) => {
                for k in 0..self.components() {
                    if k > 0 {
                        out.push(',');
                    }
                    let _ = write!(out, "{}", self.value(i, k));
                }
                Ok(())
            }
        }
        .expect("writing to a String");
    }

    /// Component `a` of particle `i` as a float (integers converted exactly up to 2⁵³).
    pub fn value(&self, i: usize, a: usize) -> f64 {
        match self {
            Column::U64(v) => v[i] as f64,
            Column::U16(v) => v[i] as f64,
            Column::Kind(v) => v[i].code() as f64,
            Column::F64(v) => v[i],
            Column::Vector(v) => v[i][a],
            Column::Tensor(t) => {
                let (r, c) = tensor_component::<D>(a);
                t[i].get(r, c)
            }
        }
    }
}

/// A type that can be a per-particle field.
pub trait FieldValue<const D: usize>: Copy + Send + Sync + 'static {
    /// The value of a new particle before anything sets it.
    fn zero() -> Self;
    /// Write to a record.
    fn put(&self, s: &mut impl Sink);
    /// Read from a record.
    fn get(r: &mut Reader) -> Result<Self>;
    /// The value seen through an image operation under `rule`.
    fn imaged(&self, rule: ImageRule, im: &impl Imager<D>) -> Self;
    /// The whole field as a typed column.
    fn column(v: &[Self]) -> Column<'_, D>;
}

impl<const D: usize> FieldValue<D> for u64 {
    fn zero() -> Self {
        0
    }
    #[inline]
    fn put(&self, s: &mut impl Sink) {
        s.word(*self)
    }
    #[inline]
    fn get(r: &mut Reader) -> Result<Self> {
        r.word()
    }
    #[inline]
    fn imaged(&self, rule: ImageRule, im: &impl Imager<D>) -> Self {
        if rule == ImageRule::Key {
            im.key()
        } else {
            *self
        }
    }
    fn column(v: &[Self]) -> Column<'_, D> {
        Column::U64(v)
    }
}

impl<const D: usize> FieldValue<D> for u16 {
    fn zero() -> Self {
        0
    }
    #[inline]
    fn put(&self, s: &mut impl Sink) {
        s.bits(*self as u64, 16)
    }
    #[inline]
    fn get(r: &mut Reader) -> Result<Self> {
        Ok(r.bits(16)? as u16)
    }
    #[inline]
    fn imaged(&self, _rule: ImageRule, _im: &impl Imager<D>) -> Self {
        *self
    }
    fn column(v: &[Self]) -> Column<'_, D> {
        Column::U16(v)
    }
}

impl<const D: usize> FieldValue<D> for Kind {
    fn zero() -> Self {
        Kind::Fluid
    }
    #[inline]
    fn put(&self, s: &mut impl Sink) {
        s.bits(self.code() as u64, 8)
    }
    #[inline]
    fn get(r: &mut Reader) -> Result<Self> {
        let c = r.bits(8)?;
        Kind::from_code(c as u8)
            .ok_or_else(|| Error::run(format!("particle record: corrupt particle kind {c}")))
    }
    #[inline]
    fn imaged(&self, _rule: ImageRule, _im: &impl Imager<D>) -> Self {
        *self
    }
    fn column(v: &[Self]) -> Column<'_, D> {
        Column::Kind(v)
    }
}

impl<const D: usize> FieldValue<D> for f64 {
    fn zero() -> Self {
        0.0
    }
    #[inline]
    fn put(&self, s: &mut impl Sink) {
        s.word(self.to_bits())
    }
    #[inline]
    fn get(r: &mut Reader) -> Result<Self> {
        Ok(f64::from_bits(r.word()?))
    }
    #[inline]
    fn imaged(&self, _rule: ImageRule, _im: &impl Imager<D>) -> Self {
        *self
    }
    fn column(v: &[Self]) -> Column<'_, D> {
        Column::F64(v)
    }
}

impl<const D: usize> FieldValue<D> for Vector<D> {
    fn zero() -> Self {
        Vector::zeros()
    }
    #[inline]
    fn put(&self, s: &mut impl Sink) {
        for c in self.iter() {
            s.word(c.to_bits());
        }
    }
    #[inline]
    fn get(r: &mut Reader) -> Result<Self> {
        let mut v = Vector::<D>::zeros();
        for c in v.iter_mut() {
            *c = f64::from_bits(r.word()?);
        }
        Ok(v)
    }
    #[inline]
    fn imaged(&self, rule: ImageRule, im: &impl Imager<D>) -> Self {
        match rule {
            ImageRule::Same | ImageRule::Key => *self,
            ImageRule::Position => im.position(self),
            ImageRule::Velocity => im.velocity(self),
            ImageRule::Vector | ImageRule::Tensor => im.vector(self),
        }
    }
    fn column(v: &[Self]) -> Column<'_, D> {
        Column::Vector(v)
    }
}

impl<const D: usize> FieldValue<D> for Sym<D> {
    fn zero() -> Self {
        Sym::default()
    }
    /// The upper triangle only.
    #[inline]
    fn put(&self, s: &mut impl Sink) {
        for r in 0..D {
            for c in r..D {
                s.word(self.get(r, c).to_bits());
            }
        }
    }
    #[inline]
    fn get(r: &mut Reader) -> Result<Self> {
        let mut t = Sym::default();
        for a in 0..D {
            t.diag[a] = f64::from_bits(r.word()?);
            for b in a + 1..D {
                t.off[Self::off_index(a, b)] = f64::from_bits(r.word()?);
            }
        }
        Ok(t)
    }
    #[inline]
    fn imaged(&self, rule: ImageRule, im: &impl Imager<D>) -> Self {
        match rule {
            ImageRule::Tensor => Sym::from_upper(&im.tensor(&self.tensor())),
            _ => *self,
        }
    }
    fn column(v: &[Self]) -> Column<'_, D> {
        Column::Tensor(v)
    }
}
