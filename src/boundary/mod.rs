//! Boundary methods, one file each, and the image geometry they share.
//!
//! | method | file | how |
//! |---|---|---|
//! | dummy walls | [`dummy`] | fixed particles whose p, ρ and viscous velocity are extrapolated
//! from the fluid (Adami et al. 2012) | | dynamic walls | [`dynamic`] | fixed particles whose ρ
//! follows the continuity equation and p the EOS (Crespo et al. 2007; DualSPHysics's boundary) | |
//! repulsive walls | [`repulsive`] | a pair force from wall particles (Monaghan 1994) | | mirror
//! walls | [`mirror`] | image particles reflected across a container's inner faces | | periodic
//! axes | [`periodic`] | wrap and image particles shifted by the box length | | moving walls |
//! [`motion`] | motion laws applied to wall bodies | | wall surfaces | [`geometry`] | distances to
//! a wall's surface (Morris et al. 1997 no-slip); fluid that a drift carries through a dummy wall's
//! face bounces back |
//!
//! Image particles (periodic and mirror) are ghosts: [`images`] holds their geometry and
//! [`crate::halo`] makes and refreshes them with the other ranks' ghosts.
//!
//! A wall method with particles of its own says which particle kind it fills its body with
//! (`scene::WallMethod::particle_kind`: the kind is how the fluid's pair kernels treat the
//! particle) and, if the particles' p, ρ and v_w follow the fluid, gives the per-particle
//! kernel [`update_walls`] dispatches to (one arm below). Adding such a method touches its
//! file here, this dispatch and its `WallMethod` variant with its key checks in
//! `scene/walls.rs`; the test-only `toy` method proves it.

pub mod axis_op;
pub mod dummy;
pub mod dynamic;
pub mod geometry;
pub mod images;
pub mod mirror;
pub mod motion;
pub mod periodic;
pub mod repulsive;
#[cfg(test)]
mod toy;

pub use images::{AxisOp, ImageSpace};
pub use mirror::MirrorPlane;

use crate::cells::Neighbours;
use crate::kernel::Kernel;
use crate::material::MaterialModel;
use crate::particles::Particles;
use crate::scene::{Scene, WallMethod};
use crate::Vector;
use rayon::prelude::*;

/// What wall kernels read besides the particles (the physics model lends it).
pub struct WallContext<'a, const D: usize> {
    /// The step (s) over which a wall that integrates its density does so; 0 at the set-up.
    pub dt: f64,
    /// The smoothing kernel.
    pub kernel: &'a Kernel,
    /// The kernels of pairs of sizes, in a scene of several (`[[refine]]`).
    pub sizes: Option<&'a crate::kernel::sizes::Sizes>,
    /// Material models by material index (the EOS inverse gives ρ_w from p_w).
    pub materials: &'a [MaterialModel],
    /// Body force g (m/s²).
    pub g: Vector<D>,
    /// Boundary method of each wall body, by body index.
    pub methods: &'a [WallMethod],
    /// Acceleration a_w of each wall body (m/s²), by body index.
    pub wall_acc: &'a [Vector<D>],
    /// No-slip (`true`) or free-slip walls, by body index.
    pub no_slip: &'a [bool],
}

/// True if `method`'s particles take their p, ρ and v_w from the fluid each step (a kernel
/// in [`update_walls`]).
pub fn updates(method: WallMethod) -> bool {
    match method {
        WallMethod::Dummy | WallMethod::Dynamic => true,
        #[cfg(test)]
        WallMethod::Toy => true,
        WallMethod::Repulsive | WallMethod::Mirror => false,
    }
}

/// Particles whose new wall values are held at once by [`update_walls`]: its buffer (40 B per
/// particle in 3D) is one wave's, not the whole table's, so it does not add to the step's peak
/// of memory beside the neighbour lists (docs/benchmark-log.md, "The step's lists freed before a
/// view").
const WAVE: usize = 1 << 14;

/// Set p, ρ and v_w of every owned wall particle whose method [`updates`] them, each by its
/// wall body's method from its neighbours; other particles keep theirs. A wall's values are
/// read from its fluid neighbours and its own (a dynamic wall's ρ) only, so computing a wave of
/// particles and writing it back before the next gives the bits of one sweep.
pub fn update_walls<const D: usize, N: Neighbours>(p: &mut Particles<D>, nl: &N, c: &WallContext<D>) {
    update_walls_in_waves(p, nl, c, WAVE);
}

/// [`update_walls`] in waves of `wave` particles (≥ 1).
pub(crate) fn update_walls_in_waves<const D: usize, N: Neighbours>(
    p: &mut Particles<D>,
    nl: &N,
    c: &WallContext<D>,
    wave: usize,
) {
    let n = p.n_owned;
    let mut out: Vec<(f64, f64, Vector<D>)> = Vec::with_capacity(wave.min(n));
    let sizes = c.sizes.filter(|s| s.varies_h);
    for start in (0..n).step_by(wave) {
        let end = (start + wave).min(n);
        {
            let p = &*p;
            crate::with_pair_kernel!(sizes, *c.kernel, D, kern => {
                (start..end)
                    .into_par_iter()
                    .map(|w| {
                        let keep = (p.p[w], p.rho[w], p.vw[w]);
                        if !p.kind[w].is_wall() || !nl.visits(w) {
                            return keep;
                        }
                        match c.methods[p.body[w] as usize] {
                            WallMethod::Dummy => dummy::extrapolated(p, w, nl.iter(w), c, kern),
                            WallMethod::Dynamic => dynamic::integrated(p, w, nl.iter(w), c, kern),
                            #[cfg(test)]
                            WallMethod::Toy => toy::shepard_pressure(p, w, nl.iter(w), c),
                            WallMethod::Repulsive | WallMethod::Mirror => keep,
                        }
                    })
                    .collect_into_vec(&mut out)
            })
        }
        let (pp, rr, vv) = (
            &mut p.p[start..end],
            &mut p.rho[start..end],
            &mut p.vw[start..end],
        );
        (pp.par_iter_mut()
            .zip(rr.par_iter_mut())
            .zip(vv.par_iter_mut())
            .zip(out.par_iter()))
        .for_each(|(((pw, rw), vw), o)| (*pw, *rw, *vw) = *o);
    }
}

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
