//! Boundary methods, one file each, and the image geometry they share.
//!
//! | method | file | how |
//! |---|---|---|
//! | dummy walls | [`dummy`] | fixed particles whose p, ρ and viscous velocity are extrapolated from the fluid (Adami et al. 2012) |
//! | repulsive walls | [`repulsive`] | a pair force from wall particles (Monaghan 1994) |
//! | mirror walls | [`mirror`] | image particles reflected across a container's inner faces |
//! | periodic axes | [`periodic`] | wrap and image particles shifted by the box length |
//! | moving walls | [`motion`] | motion laws applied to wall bodies |
//! | wall surfaces | [`geometry`] | distances to a wall's surface (Morris et al. 1997 no-slip) |
//!
//! Image particles (periodic and mirror) are ghosts: [`images`] holds their geometry and
//! [`crate::halo`] makes and refreshes them with the other ranks' ghosts.

pub mod axis_op;
pub mod dummy;
pub mod geometry;
pub mod images;
pub mod mirror;
pub mod motion;
pub mod periodic;
pub mod repulsive;

pub use images::{AxisOp, ImageSpace};
pub use mirror::MirrorPlane;

use crate::scene::Scene;
use crate::Vector;

/// The periodic box and mirror planes of a scene.
pub fn image_space<const D: usize>(scene: &Scene) -> ImageSpace<D> {
    let mut periodic = [false; D];
    for (a, per) in periodic.iter_mut().enumerate() {
        *per = scene.domain.periodic[a];
    }
    ImageSpace {
        min: Vector::from_fn(|a, _| scene.domain.min[a]),
        max: Vector::from_fn(|a, _| scene.domain.max[a]),
        periodic,
        planes: mirror::planes_of(scene),
    }
}
