//! Moving walls checked against the domain before a run: the box a wall's particles fill,
//! swept by its motion law over `[0, time.t_end]`, must stay inside it (a wall particle that
//! leaves the domain stops the run mid-way).

use crate::boundary::motion::WallKinematics;
use crate::error::{Error, Result};
use crate::scene::{num, Motion, Scene, WallShape};

/// The box a wall's particles fill: a container's inner box grown by its built layers on
/// every closed face, a block's own box.
fn built_box(s: &Scene, w: &crate::scene::WallBody) -> (Vec<f64>, Vec<f64>) {
    match w.shape {
        WallShape::Container => crate::scene::lattice::container_outer(s, w),
        WallShape::Block | WallShape::Polygon | WallShape::Mesh => (w.min.clone(), w.max.clone()),
    }
}

/// The smallest and largest displacement (m) per axis of `motion` over `[0, t_end]`: the law
/// at 2 000 instants, the end, and (a sine) every extremum of its phase inside the interval,
/// so that a sine's peaks are found exactly.
fn displacement_range<const D: usize>(k: &WallKinematics, t_end: f64) -> ([f64; D], [f64; D]) {
    const SAMPLES: usize = 2000;
    let mut times: Vec<f64> = (0..=SAMPLES).map(|j| t_end * j as f64 / SAMPLES as f64).collect();
    if let Motion::Sine { period, phase, .. } = &k.motion {
        // sin(ωt + φ) = ±1 at ωt + φ = π/2 + jπ
        let w = 2.0 * std::f64::consts::PI / period;
        let first = ((phase - std::f64::consts::FRAC_PI_2) / std::f64::consts::PI).floor() as i64;
        let last = ((w * t_end + phase - std::f64::consts::FRAC_PI_2) / std::f64::consts::PI).ceil() as i64;
        for j in first..=last.min(first + 100_000) {
            let t = (std::f64::consts::FRAC_PI_2 + j as f64 * std::f64::consts::PI - phase) / w;
            if (0.0..=t_end).contains(&t) {
                times.push(t);
            }
        }
    }
    let (mut lo, mut hi) = ([0.0; D], [0.0; D]);
    for t in times {
        let (x, _, _) = k.at::<D>(t);
        for a in 0..D {
            lo[a] = f64::min(lo[a], x[a]);
            hi[a] = f64::max(hi[a], x[a]);
        }
    }
    (lo, hi)
}

/// A moving wall must stay in the domain over the whole run (`time.t_end`): its particles
/// would otherwise leave it mid-run and stop the run there. The box its particles fill, swept
/// by the motion law's displacement, is checked against the domain before anything is built.
pub(super) fn check_wall_sweeps(s: &Scene) -> Result<()> {
    crate::with_dim!(s.dimension, D => wall_sweeps::<D>(s))
}

fn wall_sweeps<const D: usize>(s: &Scene) -> Result<()> {
    let dom = &s.domain;
    let tol = 1e-9 * crate::scene::disc_scale(dom);
    for k in WallKinematics::of(s) {
        let w = &s.walls[k.body];
        let (lo, hi) = built_box(s, w);
        let (dlo, dhi) = displacement_range::<D>(&k, s.time.t_end);
        for a in 0..D {
            if dom.periodic[a] {
                continue;
            }
            let axis = ["x", "y", "z"][a];
            let (reach_lo, reach_hi) = (lo[a] + dlo[a], hi[a] + dhi[a]);
            let (bound, side, cmp, reach, limit) = if reach_lo < dom.min[a] - tol {
                ("min", "below", "≤", reach_lo, dom.min[a])
            } else if reach_hi > dom.max[a] + tol {
                ("max", "above", "≥", reach_hi, dom.max[a])
            } else {
                continue;
            };
            return Err(Error::input(
                format!("wall[{}].motion", k.body),
                format!(
                    "wall `{}` (its particles fill [{}, {}] m along {axis}) moves by {} to {} m along \
                     {axis} before time.t_end = {} s, so its particles would reach {axis} = {} m, \
                     {side} domain.{bound}[{a}] = {} m, and stop the run there; set \
                     domain.{bound}[{a}] {cmp} {}, or shorten the motion or the run",
                    w.name,
                    num(lo[a]),
                    num(hi[a]),
                    num(dlo[a]),
                    num(dhi[a]),
                    num(s.time.t_end),
                    num(reach),
                    num(limit),
                    num(reach),
                ),
            ));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn kin(motion: Motion) -> WallKinematics {
        WallKinematics {
            body: 0,
            motion,
            g: 9.81,
        }
    }

    /// A sine's crest is found exactly inside the run, a constant velocity's reach at its
    /// end, and the rest position bounds both ranges.
    #[test]
    fn the_displacement_range_holds_the_crest_and_the_end() {
        let sine = kin(Motion::Sine {
            amplitude: vec![1.0, -2.0],
            period: 1.0,
            phase: 0.0,
        });
        let (lo, hi) = displacement_range::<2>(&sine, 0.3);
        assert_eq!((lo[0], hi[0]), (0.0, 1.0));
        assert_eq!((lo[1], hi[1]), (-2.0, 0.0));
        let (lo, hi) = displacement_range::<2>(&sine, 0.2);
        assert_eq!(hi[0], (0.4 * std::f64::consts::PI).sin());
        assert_eq!(lo[0], 0.0);
        let u = kin(Motion::ConstantVelocity {
            velocity: vec![-2.0, 0.5],
        });
        let (lo, hi) = displacement_range::<2>(&u, 0.5);
        assert_eq!((lo[0], hi[0], lo[1], hi[1]), (-1.0, 0.0, 0.0, 0.25));
    }
}
