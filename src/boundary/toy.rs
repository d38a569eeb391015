//! A test-only wall method (`method = "toy"`): dummy-like wall particles holding the Shepard
//! mean of the fluid pressure round them, p_w = Σ_f p_f W_wf / Σ_f W_wf (Pa), with no
//! body-force term (Adami's hydrostatic correction left out, so a toy wall under water reads
//! less than a dummy wall), ρ_w from the EOS inverse (kg/m³) and v_w = u_wall (m/s): the fluid
//! sees the wall's own velocity. A wall particle with no fluid neighbour keeps p = 0, ρ = ρ0.
//!
//! It exists to prove that a wall method is this file, one arm of
//! [`super::update_walls`] and a `WallMethod` variant in `scene/walls.rs`.

use super::WallContext;
use crate::particles::Particles;
use crate::Vector;

/// The toy's p_w, ρ_w and v_w of wall particle `w` from its `neighbours`.
pub fn shepard_pressure<const D: usize>(
    p: &Particles<D>,
    w: usize,
    neighbours: impl Iterator<Item = u32>,
    c: &WallContext<D>,
) -> (f64, f64, Vector<D>) {
    let mat = &c.materials[p.mat[w] as usize];
    let (mut sw, mut sp) = (0.0, 0.0);
    for f in neighbours.map(|f| f as usize).filter(|&f| p.kind[f].is_fluid()) {
        let wgt = c.kernel.w((p.x[w] - p.x[f]).norm());
        sw += wgt;
        sp += p.p[f] * wgt;
    }
    let pw = if sw > 0.0 { sp / sw } else { 0.0 };
    let rho = if sw > 0.0 { mat.density(pw) } else { mat.rho0() };
    (pw, rho, p.v[w])
}

#[cfg(test)]
mod tests {
    use crate::comm::serial::SerialComm;
    use crate::particles::Kind;
    use crate::scene::WallMethod;
    use crate::sim::Simulation;

    /// The hydrostatic tank of `inputs/hydrostatic_2d.toml` with its wall's method replaced.
    fn tank(method: &str) -> crate::scene::Scene {
        let text = std::fs::read_to_string("inputs/hydrostatic_2d.toml")
            .unwrap()
            .replace("method = \"dummy\"", &format!("method = \"{method}\""));
        crate::scene::load_scene_str(&text, std::path::Path::new("toy.toml"), "toy", &[])
            .unwrap()
            .0
    }

    /// A scene file selects the toy method; its particles are built like dummy particles, its
    /// kernel runs in the step's wall pass and gives every wall particle the Shepard mean of
    /// the fluid pressure round it (against a brute-force sum over every particle), and the
    /// toy walls hold the water: after 100 steps no fluid particle has entered the walls and
    /// the bottom wall, lacking Adami's hydrostatic term, reads less than dummy walls do.
    #[test]
    fn a_wall_method_added_in_its_file_runs_from_a_scene() {
        let comm = SerialComm::new();
        let (toy, dummy) = (tank("toy"), tank("dummy"));
        assert_eq!(toy.walls[0].method, WallMethod::Toy);
        let mut sims = [
            Simulation::<2>::new(&toy, &comm).unwrap(),
            Simulation::<2>::new(&dummy, &comm).unwrap(),
        ];
        let walls = |s: &Simulation<2>| -> Vec<usize> {
            (0..s.p.n_owned).filter(|&i| s.p.kind[i] == Kind::Dummy).collect()
        };
        assert_eq!(walls(&sims[0]).len(), walls(&sims[1]).len());
        assert!(!walls(&sims[0]).is_empty());
        let names: Vec<&str> = crate::physics::passes::schedule(&sims[0].model)
            .iter()
            .map(|p| p.name())
            .collect();
        assert!(names.contains(&"wall_extrapolation"), "{names:?}");
        for sim in sims.iter_mut() {
            for _ in 0..100 {
                sim.advance(&comm).unwrap();
            }
        }
        // the oracle: every particle of the tank within the support, no neighbour list
        let s = &mut sims[0];
        let c = s.model.wall_context(0.0);
        let support = s.model.kernel.support;
        let all: Vec<u32> = (0..s.p.n_owned as u32).collect();
        for &w in &walls(s) {
            let near = all
                .iter()
                .copied()
                .filter(|&f| (s.p.x[w] - s.p.x[f as usize]).norm() < support);
            let (pw, rho, vw) = super::shepard_pressure(&s.p, w, near, &c);
            let (mut sw, mut sp) = (0.0, 0.0);
            for f in 0..s.p.n_owned {
                let r = (s.p.x[w] - s.p.x[f]).norm();
                if s.p.kind[f].is_fluid() && r < support {
                    sw += c.kernel.w(r);
                    sp += c.kernel.w(r) * s.p.p[f];
                }
            }
            let want = if sw > 0.0 { sp / sw } else { 0.0 };
            assert!(
                (pw - want).abs() <= 1e-9 * want.abs().max(1.0),
                "wall {w}: {pw} against {want}"
            );
            assert_eq!(rho, c.materials[s.p.mat[w] as usize].density(pw));
            assert_eq!(vw, s.p.v[w]);
        }
        let bottom = |s: &Simulation<2>| {
            let (mut sum, mut n) = (0.0, 0);
            for i in walls(s)
                .into_iter()
                .filter(|&i| s.p.x[i][1] < 0.0 && s.p.x[i][1] > -s.model.dx)
            {
                sum += s.p.p[i];
                n += 1;
            }
            sum / n as f64
        };
        let (p_toy, p_dummy) = (bottom(&sims[0]), bottom(&sims[1]));
        assert!(
            p_toy > 0.0 && p_toy < p_dummy,
            "bottom wall: toy {p_toy} Pa, dummy {p_dummy} Pa"
        );
        for sim in &sims {
            let inside = (0..sim.p.n_owned)
                .filter(|&i| sim.p.kind[i].is_fluid())
                .all(|i| sim.p.x[i][1] > 0.0 && sim.p.x[i][0] > 0.0 && sim.p.x[i][0] < 1.0);
            assert!(inside, "fluid left the tank");
        }
    }
}
