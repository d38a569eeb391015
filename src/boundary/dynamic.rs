//! Dynamic wall particles (Crespo, Gómez-Gesteira & Dalrymple 2007, Comput. Mater. Continua
//! 5, 173; the boundary of DualSPHysics, Domínguez et al. 2022): fixed particles whose
//! density follows the continuity equation from the fluid round them, and whose pressure is
//! the EOS's at that density. A fluid particle that comes near raises the wall's density and
//! so its pressure, which pushes it back; the fluid's own sums treat the wall particle as a
//! neighbour with that p and ρ (`crate::physics::fluid`). One layer holds the fluid where
//! dummy walls need the kernel's reach (three at h = √3 dx in 3D), so a tank costs a third of
//! the wall particles (DualSPHysics's layout), but the row beside it lacks part of its support:
//! in the still tank it sinks half a spacing onto the wall and its pressure is far off. In the
//! rows the support reaches the still tank reads its pressure better than on dummy walls
//! (docs/methods.md §2).
//!
//! Over a step of dt (s), for wall particle w and its fluid neighbours f, x_wf = x_w − x_f:
//!   dρ_w/dt = Σ_f m_f (u_w − v_f) · ∇_w W_wf,   ∇_w W_wf = (1/r ∂W/∂r) x_wf   (kg m⁻³ s⁻¹),
//!   ρ_w ← max(ρ0, ρ_w + dt dρ_w/dt),   p_w = p(ρ_w) (Pa),
//! u_w the wall's velocity. The floor at ρ0 keeps a wall from pulling (DualSPHysics bounds its
//! boundary density the same way). The velocity the fluid sees in its viscous terms is
//! v_w = u_w on a no-slip wall (DualSPHysics's: its artificial viscosity acts against the wall)
//! and on a free-slip wall the kernel-weighted mean of the fluid velocities round it,
//! ṽ_w = Σ_f v_f W_wf / Σ_f W_wf (m/s), as for free-slip dummy walls. At the set-up (dt = 0)
//! a wall starts from the density of Adami's extrapolated pressure (`super::dummy`), floored
//! at ρ0: with `hydrostatic = true` the wall holds the water's weight from the first step
//! instead of being compressed into it (a restart does not run the set-up and keeps the
//! checkpoint's ρ_w).

use super::WallContext;
use crate::particles::Particles;
use crate::Vector;

/// dρ_w/dt (kg m⁻³ s⁻¹) of wall particle `w` from the fluid among its `neighbours` (module
/// docs) and, if `shepard`, the kernel-weighted mean ṽ_w (m/s) of their velocities (`None`
/// without fluid round it, or without `shepard`).
#[inline]
pub fn density_rate<const D: usize>(
    p: &Particles<D>,
    w: usize,
    neighbours: impl Iterator<Item = u32>,
    kern: impl crate::kernel::sizes::PairKernel,
    shepard: bool,
) -> (f64, Option<Vector<D>>) {
    let u_w = p.v[w];
    let mut rate = 0.0;
    let (mut sw, mut sv) = (0.0, Vector::<D>::zeros());
    for f in neighbours {
        let f = f as usize;
        if !p.kind[f].is_fluid() {
            continue;
        }
        let x_wf = p.x[w] - p.x[f];
        let r = x_wf.norm();
        let k = kern.of(&p.h, w, f);
        rate += p.mass[f] * k.dw_dr_over_r(r) * (u_w - p.v[f]).dot(&x_wf);
        if shepard {
            let wgt = k.w(r);
            sw += wgt;
            sv += p.v[f] * wgt;
        }
    }
    (rate, (sw > 0.0).then(|| sv / sw))
}

/// p_w, ρ_w and v_w of dynamic wall particle `w` after a step of `c.dt` (module docs).
#[inline]
pub fn integrated<const D: usize>(
    p: &Particles<D>,
    w: usize,
    neighbours: impl Iterator<Item = u32>,
    c: &WallContext<D>,
    kern: impl crate::kernel::sizes::PairKernel,
) -> (f64, f64, Vector<D>) {
    let mat = &c.materials[p.mat[w] as usize];
    let u_w = p.v[w];
    let free_slip = !c.no_slip[p.body[w] as usize];
    let (rho, vw) = if c.dt > 0.0 {
        let (rate, mean) = density_rate(p, w, neighbours, kern, free_slip);
        (p.rho[w] + c.dt * rate, mean.unwrap_or(u_w))
    } else {
        // the set-up: Adami's density; its free-slip v_w is the Shepard mean
        let (_, rho, vt) = super::dummy::extrapolated(p, w, neighbours, c, kern);
        (rho, if free_slip { vt } else { u_w })
    };
    let rho = rho.max(mat.rho0());
    (mat.pressure(rho, 0.0), rho, vw)
}

#[cfg(test)]
mod tests {
    use crate::comm::serial::SerialComm;
    use crate::particles::Kind;
    use crate::sim::Simulation;

    /// The hydrostatic tank of `inputs/hydrostatic_2d.toml` with its wall's method replaced.
    fn tank(method: &str, slip: &str) -> crate::scene::Scene {
        let text = std::fs::read_to_string("inputs/hydrostatic_2d.toml")
            .unwrap()
            .replace("method = \"dummy\"", &format!("method = \"{method}\""))
            .replace("slip = \"free_slip\"", &format!("slip = \"{slip}\""));
        crate::scene::load_scene_str(&text, std::path::Path::new("dynamic.toml"), "dynamic", &[])
            .unwrap()
            .0
    }

    fn walls(s: &Simulation<2>) -> Vec<usize> {
        (0..s.p.n_owned).filter(|&i| s.p.kind[i] == Kind::Dummy).collect()
    }

    /// At the set-up a dynamic wall holds the density of Adami's extrapolated pressure,
    /// floored at ρ0: particle for particle the dummy tank's wall density where it exceeds ρ0,
    /// so the bottom wall starts under the water's weight.
    #[test]
    fn a_dynamic_wall_starts_from_the_extrapolated_density() {
        let comm = SerialComm::new();
        let dynamic = Simulation::<2>::new(&tank("dynamic", "no_slip"), &comm).unwrap();
        let dummy = Simulation::<2>::new(&tank("dummy", "no_slip"), &comm).unwrap();
        let (wd, wa) = (walls(&dynamic), walls(&dummy));
        assert_eq!(wd.len(), wa.len());
        let rho0 = 1000.0;
        let mut loaded = 0;
        for (&a, &b) in wd.iter().zip(&wa) {
            assert_eq!(dynamic.p.id[a], dummy.p.id[b]);
            assert_eq!(
                dynamic.p.rho[a],
                dummy.p.rho[b].max(rho0),
                "wall id {}",
                dynamic.p.id[a]
            );
            loaded += usize::from(dynamic.p.rho[a] > rho0);
        }
        assert!(
            loaded > 50,
            "only {loaded} wall particles carry the water's weight"
        );
    }

    /// A step's wall density is ρ_w + dt Σ_f m_f (u_w − v_f)·∇_w W_wf over every fluid particle
    /// within the support (a brute-force sum, no neighbour list), floored at ρ0, and v_w is
    /// the wall's velocity (no-slip) or the W-weighted mean of the fluid's (free-slip); after
    /// 60 steps of still water some walls are above the floor and the rate is not zero.
    #[test]
    fn the_wall_density_follows_continuity_from_the_fluid() {
        let comm = SerialComm::new();
        for slip in ["no_slip", "free_slip"] {
            let mut s = Simulation::<2>::new(&tank("dynamic", slip), &comm).unwrap();
            for _ in 0..60 {
                s.advance(&comm).unwrap();
            }
            let dt = 1e-4;
            let c = s.model.wall_context(dt);
            let k = &s.model.kernel;
            let all: Vec<u32> = (0..s.p.n_owned as u32).collect();
            let (mut moved, mut above) = (0, 0);
            for &w in &walls(&s) {
                let near = all
                    .iter()
                    .copied()
                    .filter(|&f| (s.p.x[w] - s.p.x[f as usize]).norm() < k.support);
                let kern = crate::kernel::sizes::OneKernel(*k);
                let (pw, rho, vw) = super::integrated(&s.p, w, near, &c, kern);
                let (mut rate, mut sw, mut sv) = (0.0, 0.0, crate::Vector::<2>::zeros());
                for f in (0..s.p.n_owned).filter(|&f| s.p.kind[f].is_fluid()) {
                    let x = s.p.x[w] - s.p.x[f];
                    let r = x.norm();
                    if r < k.support {
                        rate += s.p.mass[f] * k.dw_dr(r) / r * (s.p.v[w] - s.p.v[f]).dot(&x);
                        sw += k.w(r);
                        sv += s.p.v[f] * k.w(r);
                    }
                }
                let want = (s.p.rho[w] + dt * rate).max(1000.0);
                assert!(
                    (rho - want).abs() <= 1e-12 * want,
                    "{slip} wall {w}: {rho} against {want}"
                );
                assert_eq!(pw, c.materials[0].pressure(rho, 0.0));
                let want_v = if slip == "no_slip" || sw == 0.0 {
                    s.p.v[w]
                } else {
                    sv / sw
                };
                assert!(
                    (vw - want_v).norm() <= 1e-12 * (1.0 + want_v.norm()),
                    "{slip} wall {w}"
                );
                moved += usize::from(rate != 0.0);
                above += usize::from(rho > 1000.0);
            }
            assert!(
                moved > 50 && above > 50,
                "{slip}: rates {moved}, above ρ0 {above}"
            );
        }
    }
}
