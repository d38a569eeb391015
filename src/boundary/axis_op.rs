//! The per-axis image operations ghosts are made of, below the modules that make them
//! (periodic shifts, mirror reflections) and the one that combines them (`images`).

/// What happens to a particle along one axis to make an image.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum AxisOp {
    /// Unchanged.
    Keep,
    /// Periodic shift by this amount (m).
    Shift(f64),
    /// Reflection across mirror plane number `usize`.
    Mirror(usize),
}
