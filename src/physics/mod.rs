//! SPH physics: pure functions of particle fields and neighbour lists. Physics never calls a
//! communicator; the step loop (`sim`) refreshes ghosts between passes.
//!
//! The passes of a step, what each reads from ghosts and writes, and their order, are declared
//! in [`passes`]; each is a gather loop over owned particles (parallel with rayon, each
//! particle summing its neighbours in the fixed order of [`crate::cells::NeighbourList`]):
//! [`delta::renormalised_gradient`] (⟨∇ρ⟩^L for Antuono's δ-SPH), [`fluid::continuity`],
//! [`crate::boundary::update_walls`] (wall particles' p, ρ, v_w) and [`fluid::momentum`].
//! Materials answer through [`crate::material::MaterialModel`].

mod batch;
pub mod delta;
pub mod fluid;
pub mod moment;
pub mod pairs;
pub mod passes;
pub mod shifting;
pub mod solid;
pub mod viscous;

use crate::boundary::repulsive::Repulsion;
use crate::kernel::sizes::Sizes;
use crate::kernel::Kernel;
use crate::material::MaterialModel;
use crate::particles::Particles;
use crate::scene::{DensityDiffusion, Scene, WallMethod};
use crate::Vector;

/// Everything the passes need to know about the model (no particle data).
#[derive(Debug, Clone)]
pub struct Model<const D: usize> {
    /// Kernel with the smoothing length.
    pub kernel: Kernel,
    /// Model per material (indexed like the scene's materials).
    pub materials: Vec<MaterialModel>,
    /// Density diffusion variant.
    pub diffusion: DensityDiffusion,
    /// Antuono's gradient is the previous step's, computed with the momentum pass
    /// (`physics.density_gradient = "lagged"`).
    pub lagged_gradient: bool,
    /// Where a fluid particle's support holds several smoothing lengths and is full, its
    /// pressure term is the renormalised difference form (`physics.pressure_gradient =
    /// "difference"`, [`fluid::PressureDifference`]).
    pub difference_pressure: bool,
    /// Approaching pairs of smoothed particles are damped by the dissipative part of the
    /// Riemann solver's interface pressure (`physics.pressure_gradient = "riemann"`,
    /// [`fluid::riemann_dissipation`]).
    pub riemann_dissipation: bool,
    /// δ coefficient.
    pub delta: f64,
    /// Monaghan α.
    pub alpha: f64,
    /// Quadratic artificial viscosity β of solids.
    pub beta: f64,
    /// Artificial-stress coefficient ε of solids (0 = off).
    pub artificial_stress: f64,
    /// Lattice spacing Δp (m), the artificial stress's reference distance.
    pub dx: f64,
    /// The scene has fluid bodies (the fluid passes run).
    pub has_fluid: bool,
    /// The scene has solid bodies (the solid passes run).
    pub has_solid: bool,
    /// Kinematic viscosity ν (m²/s).
    pub nu: f64,
    /// Body force g (m/s²).
    pub g: Vector<D>,
    /// Repulsive wall force (Monaghan 1994).
    pub repulsive: Repulsion,
    /// Boundary method per wall body.
    pub wall_methods: Vec<WallMethod>,
    /// True if a wall's particles take p, ρ and v_w from the fluid (the wall pass runs).
    pub updates_walls: bool,
    /// Slip condition per wall body: true = no-slip.
    pub wall_no_slip: Vec<bool>,
    /// Dummy walls whose particles keep their lattice cell's volume (`volume = "lattice"`),
    /// by wall body index: the `wall_volume` row sets m = ρ_w (dx/2^ℓ)^D after each
    /// extrapolation.
    pub wall_lattice_volume: Vec<bool>,
    /// Wall acceleration per wall body (m/s²), updated by the step loop for moving walls.
    pub wall_acc: Vec<Vector<D>>,
    /// Wall displacement from rest per wall body (m), updated with `wall_acc`.
    pub wall_shift: Vec<Vector<D>>,
    /// The laminar term's operator and no-slip method ([`viscous`]).
    pub viscous: viscous::Viscous<D>,
    /// Largest c0 of all materials (m/s).
    pub c_max: f64,
    /// Particle shifting of fluid particles, if the scene asks for it.
    pub shifting: Option<shifting::Shifting>,
    /// The set-up relaxation's shift and its iterations (`discretisation.relax`), if any.
    pub relaxation: Option<(shifting::Shifting, u32)>,
    /// Kernels of pairs of particle sizes, if the scene has refinement regions (`None`: every
    /// particle has the size of `kernel`).
    pub sizes: Option<Sizes>,
}

impl<const D: usize> Model<D> {
    /// What wall kernels read to set their particles' p, ρ and v_w in a step of `dt` (s; 0 at
    /// the set-up, when a wall whose density is integrated keeps it).
    pub fn wall_context(&self, dt: f64) -> crate::boundary::WallContext<'_, D> {
        crate::boundary::WallContext {
            dt,
            kernel: &self.kernel,
            sizes: self.sizes.as_ref(),
            materials: &self.materials,
            g: self.g,
            methods: &self.wall_methods,
            wall_acc: &self.wall_acc,
            no_slip: &self.wall_no_slip,
        }
    }

    /// The model a scene asks for.
    pub fn new(s: &Scene) -> Self {
        let h = s.discretisation.h_over_dx * s.discretisation.dx;
        let materials: Vec<MaterialModel> = s.materials.iter().map(|m| m.model()).collect();
        let c_max = materials.iter().fold(0.0f64, |m, e| m.max(e.c0()));
        let has_solid = !s.solids.is_empty();
        let kernel = Kernel::new(s.discretisation.kernel, h, D);
        let dx = s.discretisation.dx;
        let shifting =
            (s.physics.shifting == crate::scene::ShiftingKind::DeltaPlus && c_max > 0.0).then(|| {
                let u = crate::scene::expected_speed(s);
                shifting::Shifting::new(h, dx, s.time.cfl, u, c_max, kernel.w(dx))
            });
        Model {
            kernel,
            diffusion: s.physics.density_diffusion,
            lagged_gradient: s.physics.density_diffusion.needs_gradient()
                && s.physics.density_gradient == crate::scene::DensityGradient::Lagged,
            difference_pressure: s.physics.pressure_gradient.is_difference(),
            riemann_dissipation: s.physics.pressure_gradient.riemann_dissipation(),
            delta: s.physics.delta,
            alpha: s.physics.artificial_viscosity,
            beta: s.physics.artificial_viscosity_beta,
            artificial_stress: s.physics.artificial_stress,
            dx: s.discretisation.dx,
            has_fluid: !s.fluids.is_empty(),
            has_solid,
            nu: s.physics.laminar_viscosity,
            g: Vector::from_fn(|a, _| s.physics.body_force[a]),
            repulsive: Repulsion::new(c_max, s.discretisation.dx),
            wall_methods: s.walls.iter().map(|w| w.method).collect(),
            updates_walls: s.walls.iter().any(|w| crate::boundary::updates(w.method)),
            wall_no_slip: s
                .walls
                .iter()
                .map(|w| w.slip == crate::scene::Slip::NoSlip)
                .collect(),
            wall_lattice_volume: s
                .walls
                .iter()
                .map(|w| w.volume == crate::scene::WallVolume::Lattice)
                .collect(),
            wall_acc: vec![Vector::zeros(); s.walls.len()],
            wall_shift: vec![Vector::zeros(); s.walls.len()],
            viscous: viscous::Viscous::new(s),
            materials,
            c_max,
            shifting,
            relaxation: (s.discretisation.relax > 0).then(|| {
                // the smallest ∇·r of a full support on the scene's lattices: a level of the
                // scene's h has h/Δp 2^ℓ times the scene's, one of its own h the scene's ratio
                let finest = s.refine.iter().map(|r| r.level).max().unwrap_or(0);
                let full = (0..=finest)
                    .map(|l| shifting::lattice_divergence(&kernel, dx / f64::from(1u32 << l), D))
                    .fold(f64::INFINITY, f64::min);
                let near = shifting::RELAX_NEAR * full;
                (
                    shifting::Shifting::relaxation(h, dx, kernel.w(dx), near),
                    s.discretisation.relax,
                )
            }),
            sizes: crate::scene::refine::sizes(s),
        }
    }

    /// The kernel of the pair (i, j): the scene's, or for particles of several sizes the
    /// kernel of their mean smoothing length ([`crate::kernel::sizes`]).
    #[inline(always)]
    pub fn pair_kernel(&self, p: &Particles<D>, i: usize, j: usize) -> Kernel {
        match self.varying() {
            None => self.kernel,
            Some(s) => s.kernel::<D>(p.h[i], p.h[j]),
        }
    }

    /// W_ij(Δp_ij) of the pair (i, j) whose kernel is `k` (m⁻ᴰ): `uniform` (the caller's
    /// W(dx)) for particles of one size, else W_ij at the pair's mean spacing.
    #[inline(always)]
    pub fn pair_w_dp(&self, p: &Particles<D>, i: usize, j: usize, k: &Kernel, uniform: f64) -> f64 {
        match &self.sizes {
            None => uniform,
            Some(s) => k.w(s.spacing(p.level[i], p.level[j])),
        }
    }

    /// The artificial stress's pair factor f_ijⁿ = (W_ij(r)/W_ij(Δp_ij))⁴ (Monaghan 2000,
    /// n = 4; dimensionless) of the pair (i, j) at distance `r` (m), whose kernel is `k`;
    /// `uniform` as for [`Model::pair_w_dp`].
    #[inline(always)]
    pub fn artificial_factor(
        &self,
        p: &Particles<D>,
        i: usize,
        j: usize,
        k: &Kernel,
        r: f64,
        uniform: f64,
    ) -> f64 {
        let f = k.w(r) / self.pair_w_dp(p, i, j, k, uniform);
        let f2 = f * f;
        f2 * f2
    }

    /// Refinement level of particle `i` (0 for a scene of one size).
    #[inline(always)]
    pub fn level(&self, p: &Particles<D>, i: usize) -> u16 {
        if self.sizes.is_some() {
            p.level[i]
        } else {
            0
        }
    }

    /// Smallest smoothing length of the scene (m): the time step's length scale.
    pub fn h_min(&self) -> f64 {
        match &self.sizes {
            None => self.kernel.h,
            Some(s) => s.h[s.finest_h as usize],
        }
    }

    /// The sizes of a scene whose particles' smoothing lengths differ (a region with
    /// `smoothing_length = "level"`), else `None`: every pair then takes `kernel`.
    #[inline(always)]
    pub fn varying(&self) -> Option<&Sizes> {
        self.sizes.as_ref().filter(|s| s.varies_h)
    }

    /// Names of the physics this model runs (for `hsph check` and logs).
    pub fn describe(&self) -> Vec<String> {
        let mut v = vec![format!(
            "kernel {} (h = {:.4e} m, support {:.4e} m)",
            self.kernel.kind.name(),
            self.kernel.h,
            self.kernel.support
        )];
        if let Some(s) = &self.sizes {
            v.push(if s.varies_h {
                format!(
                    "particles of several sizes: pairs take the kernel of their mean h, h from {:.4e} m (time step from it)",
                    s.h[s.finest_h as usize]
                )
            } else {
                "particles of several spacings, one h (refinement regions with the scene's h)".into()
            });
        }
        if self.has_fluid {
            v.push("continuity equation + EOS (weakly compressible)".into());
        }
        if self.has_fluid && self.difference_pressure && self.varying().is_some() {
            v.push(
                "pressure term: the renormalised difference form where a full support without walls \
                 holds several h (not conservative there), the symmetric form elsewhere"
                    .into(),
            );
        }
        if self.has_solid {
            v.push(
                "elastic-plastic solids: Mie-Grüneisen EOS, Jaumann stress rate, energy equation \
                 (docs/solids.md)"
                    .into(),
            );
            if self.beta > 0.0 {
                v.push(format!("solid artificial viscosity β = {}", self.beta));
            }
            if self.artificial_stress > 0.0 {
                v.push(format!(
                    "artificial stress ε = {} (n = 4)",
                    self.artificial_stress
                ));
            }
        }
        v.extend(fluid::diffusion_line(
            self.diffusion,
            self.delta,
            self.lagged_gradient,
        ));
        if self.riemann_dissipation {
            v.push(
                "Riemann-solver pressure dissipation ½ ρ̄ β ΔU, β = min(3ΔU, c̄) (Zhang, Hu & Adams 2017)"
                    .into(),
            );
        }
        if self.alpha > 0.0 {
            v.push(format!("Monaghan artificial viscosity α = {}", self.alpha));
        }
        if self.nu > 0.0 {
            v.push(format!("Morris laminar viscosity ν = {:e} m²/s", self.nu));
            if self.viscous.renormalised {
                v.push("viscous operator renormalised by the lattice moment 2/(L_i + L_j)".into());
            }
            match (self.viscous.any_morris, self.viscous.any_mirror_morris) {
                (false, false) => {}
                (dummy, mirror) => v.push(format!(
                    "no-slip by Morris et al.'s distance ratio on the {} walls that ask for it",
                    match (dummy, mirror) {
                        (true, true) => "dummy and mirror",
                        (true, false) => "dummy",
                        _ => "mirror",
                    }
                )),
            }
        }
        if self.g.norm() > 0.0 {
            v.push(format!("body force {:?} m/s²", self.g.as_slice()));
        }
        if let Some(s) = &self.shifting {
            v.push(format!(
                "δ⁺-SPH particle shifting (Sun et al. 2017), β(2h)² = {:.3e} m², |δr| ≤ {:.2e} m, \
                 fields Taylor-corrected",
                s.coefficient, s.cap
            ));
        }
        if let Some((s, n)) = &self.relaxation {
            v.push(format!(
                "set-up relaxation: {n} iterations of δr = −{:.3e} m² Σ V_j ∇W_ij (fluid, at rest; \
                 held where ∇·r < {:.4} D, a support cut by the free surface)",
                s.coefficient, s.near
            ));
        }
        v
    }
}
