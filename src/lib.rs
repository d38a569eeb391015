//! # hsph — hybrid MPI + threads smoothed-particle hydrodynamics
//!
//! A weakly compressible δ-SPH solver for violent free-surface flow, in 2D and 3D, built so
//! that one rank per subdomain (seed 000's dynamic domain decomposition) can later share the
//! same step loop. See `ARCHITECTURE.md` for the map of modules and the glossary.
//!
//! Units are SI throughout (m, s, kg, Pa). Dimension is a const generic `D` (2 or 3).
#![warn(missing_docs)]
#![deny(unsafe_code)]

pub mod affinity;
pub mod bench;
pub mod boundary;
pub mod cells;
pub mod checkpoint;
pub mod cli;
pub mod comm;
pub mod decomp;
pub mod driver;
pub mod error;
pub mod exact;
pub mod files;
pub mod halo;
pub mod ids;
pub mod joblayout;
pub mod jobscript;
pub mod kernel;
pub mod layout;
pub mod limits;
pub mod material;
pub mod memory;
pub mod model;
pub mod output;
pub mod particles;
pub mod physics;
pub mod placement;
pub mod plan;
pub mod probes;
pub mod progress;
pub mod reference;
pub mod report;
pub mod scene;
pub mod setup;
pub mod signals;
pub mod sim;
pub mod stokes_cavity;
pub mod topology;
pub mod validate;

/// Fixed-size position/velocity vector in `D` dimensions (m, m/s, ...).
pub type Vector<const D: usize> = nalgebra::SVector<f64, D>;
/// `D`×`D` matrix (renormalisation matrices, velocity gradients).
pub type Matrix<const D: usize> = nalgebra::SMatrix<f64, D, D>;
/// A `D`×`D` tensor (stresses, Pa; stored whole, sent as its upper triangle when symmetric).
pub type Tensor<const D: usize> = Matrix<D>;

/// Evaluate `$body` with `$D` bound to a dimension known at run time (2 or 3) as a `const`,
/// so generic code over `const D: usize` is called once per dimension; any other dimension is
/// an input error on key `dimension`. The one dimension dispatcher of the crate:
/// `with_dim!(scene.dimension, D => run::<D>(scene))`.
#[macro_export]
macro_rules! with_dim {
    ($dim:expr, $D:ident => $body:expr) => {
        match $dim {
            2 => {
                const $D: usize = 2;
                $body
            }
            3 => {
                const $D: usize = 3;
                $body
            }
            d => Err($crate::error::Error::input(
                "dimension",
                format!("must be 2 or 3, got {d}"),
            )),
        }
    };
}
