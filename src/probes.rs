//! Probes sampled at output steps; each writes `probes/<name>.csv` (first column `t`).
//!
//! Interpolated values use Shepard's normalisation over fluid particles:
//! f(x) = Σ_j f_j W(x − x_j) V_j / Σ_j W(x − x_j) V_j, summed in id order.

use crate::scene::Probe;
use crate::sim::View;
use crate::Vector;

/// Column names of a probe (after `t`).
pub fn columns(probe: &Probe, dim: usize) -> Vec<String> {
    let comps = ["vx", "vy", "vz"];
    match probe {
        Probe::Pressure { .. } => vec!["p".into()],
        Probe::VelocityLine { points, .. } => (0..*points)
            .flat_map(|k| comps[..dim].iter().map(move |c| format!("s{k}_{c}")))
            .collect(),
        Probe::Gauge { .. } => vec!["eta".into()],
        Probe::Front { .. } => vec!["front".into()],
    }
}

/// Sample a probe.
pub fn sample<const D: usize>(sim: &View<D>, order: &[usize], probe: &Probe) -> Vec<f64> {
    let p = &sim.p;
    let fluid = || order.iter().copied().filter(|&i| p.kind[i].is_fluid());
    let shepard = |at: Vector<D>, f: &dyn Fn(usize) -> Vector<D>| -> Option<Vector<D>> {
        let k = &sim.model.kernel;
        let (mut sw, mut s) = (0.0, Vector::<D>::zeros());
        for i in fluid() {
            let r = (at - p.x[i]).norm();
            if r < k.support {
                let w = k.w(r) * p.mass[i] / p.rho[i];
                sw += w;
                s += f(i) * w;
            }
        }
        (sw > 0.0).then(|| s / sw)
    };
    let vec_of = |v: &[f64]| Vector::<D>::from_fn(|a, _| v[a]);
    match probe {
        Probe::Pressure { point, .. } => {
            let v = shepard(vec_of(point), &|i| Vector::from_element(p.p[i]));
            vec![v.map(|v| v[0]).unwrap_or(0.0)]
        }
        Probe::VelocityLine { from, to, points, .. } => {
            let (a, b) = (vec_of(from), vec_of(to));
            let mut out = Vec::with_capacity(points * D);
            for k in 0..*points {
                let s = k as f64 / (*points - 1) as f64;
                let v = shepard(a + (b - a) * s, &|i| p.v[i]).unwrap_or_else(Vector::zeros);
                out.extend(v.iter());
            }
            out
        }
        Probe::Gauge { point, .. } => {
            let dx = sim.scene.discretisation.dx;
            let eta = fluid()
                .filter(|&i| (0..D - 1).all(|a| (p.x[i][a] - point[a]).abs() < dx))
                .map(|i| p.x[i][D - 1] + 0.5 * dx)
                .fold(f64::NAN, f64::max);
            vec![if eta.is_nan() {
                sim.scene.domain.min[D - 1]
            } else {
                eta
            }]
        }
        Probe::Front { axis, .. } => {
            vec![fluid().map(|i| p.x[i][*axis]).fold(f64::NEG_INFINITY, f64::max)]
        }
    }
}
