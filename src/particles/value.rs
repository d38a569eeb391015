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

/// A symmetric D×D tensor as a particle field (a stress, Pa): stored whole, sent and written as
/// its upper triangle. A newtype so that its rules (wire, images) differ from a vector's.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sym<const D: usize>(pub Tensor<D>);

impl<const D: usize> Default for Sym<D> {
    fn default() -> Self {
        Sym(Tensor::zeros())
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
                t[i].0[(r, c)]
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
        Sym(Tensor::zeros())
    }
    /// The upper triangle only.
    #[inline]
    fn put(&self, s: &mut impl Sink) {
        for r in 0..D {
            for c in r..D {
                s.word(self.0[(r, c)].to_bits());
            }
        }
    }
    #[inline]
    fn get(r: &mut Reader) -> Result<Self> {
        let mut t = Tensor::<D>::zeros();
        for a in 0..D {
            for b in a..D {
                let v = f64::from_bits(r.word()?);
                t[(a, b)] = v;
                t[(b, a)] = v;
            }
        }
        Ok(Sym(t))
    }
    #[inline]
    fn imaged(&self, rule: ImageRule, im: &impl Imager<D>) -> Self {
        match rule {
            ImageRule::Tensor => Sym(im.tensor(&self.0)),
            _ => *self,
        }
    }
    fn column(v: &[Self]) -> Column<'_, D> {
        Column::Tensor(v)
    }
}
