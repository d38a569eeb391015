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

/// A wave gauge: the elevation (m, along the last axis) of the free surface of the continuous
/// water column under `point`. The column starts on the bed — the top of the wall particles
/// under the gauge, or the domain's floor — and rises while the kernel-interpolated fraction of
/// matter φ(z) = Σ_j W(x − x_j) V_j (fluid and wall particles) stays at or above ½; the
/// surface is where φ crosses ½, interpolated linearly between samples dx/4 apart. Spray above
/// the first crossing is not water under the gauge. A gauge whose first fluid row is not wet
/// (φ < ½ at dx/2 above the bed) is dry and reads 0.
fn gauge<const D: usize>(sim: &View<D>, order: &[usize], point: &[f64]) -> f64 {
    let p = &sim.p;
    let k = &sim.model.kernel;
    let dx = sim.scene.discretisation.dx;
    let up = D - 1;
    let under = |i: usize| (0..up).all(|a| (p.x[i][a] - point[a]).abs() < 0.5 * dx);
    let bed = order
        .iter()
        .copied()
        .filter(|&i| p.kind[i].is_wall() && under(i))
        .map(|i| p.x[i][up] + 0.5 * dx)
        .fold(sim.scene.domain.min[up], f64::max);
    let phi = |z: f64| {
        let at = Vector::<D>::from_fn(|a, _| if a == up { z } else { point[a] });
        let mut s = 0.0;
        for &i in order {
            let r = (at - p.x[i]).norm();
            if r < k.support {
                s += k.w(r) * p.mass[i] / p.rho[i];
            }
        }
        s
    };
    let top = sim.scene.domain.max[up];
    let (mut z, mut f) = (bed + 0.5 * dx, phi(bed + 0.5 * dx));
    if f < 0.5 {
        return 0.0;
    }
    let step = 0.25 * dx;
    while z + step <= top {
        let (z1, f1) = (z + step, phi(z + step));
        if f1 < 0.5 {
            return z + step * (f - 0.5) / (f - f1);
        }
        (z, f) = (z1, f1);
    }
    top
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
        Probe::Gauge { point, .. } => vec![gauge(sim, order, point)],
        Probe::Front { axis, .. } => {
            vec![fluid().map(|i| p.x[i][*axis]).fold(f64::NEG_INFINITY, f64::max)]
        }
    }
}
