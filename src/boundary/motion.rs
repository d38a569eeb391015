//! Moving walls: a wall body with a motion law is displaced rigidly; its particles carry the
//! law's velocity (seen by the fluid) and its acceleration enters the dummy-wall pressure
//! extrapolation. Laws: `sine` d(t) = A [sin(ωt + φ) − sin φ], ω = 2π/T; `constant_velocity`
//! d(t) = u t (a piston).

use crate::particles::Particles;
use crate::scene::{Motion, Scene};
use crate::Vector;

/// Prescribed motion of one wall body.
#[derive(Debug, Clone)]
pub struct WallKinematics {
    /// Wall body index.
    pub body: usize,
    /// Its law.
    pub motion: Motion,
}

impl WallKinematics {
    /// Every wall of the scene that has a motion law.
    pub fn of(scene: &Scene) -> Vec<WallKinematics> {
        scene
            .walls
            .iter()
            .enumerate()
            .filter_map(|(b, w)| w.motion.clone().map(|m| WallKinematics { body: b, motion: m }))
            .collect()
    }

    /// Displacement (m), velocity (m/s) and acceleration (m/s²) at time t (s).
    pub fn at<const D: usize>(&self, t: f64) -> (Vector<D>, Vector<D>, Vector<D>) {
        match &self.motion {
            Motion::Sine {
                amplitude,
                period,
                phase,
            } => {
                let w = 2.0 * std::f64::consts::PI / period;
                let a = Vector::<D>::from_fn(|k, _| amplitude[k]);
                let arg = w * t + phase;
                (
                    a * (arg.sin() - phase.sin()),
                    a * (w * arg.cos()),
                    a * (-w * w * arg.sin()),
                )
            }
            Motion::ConstantVelocity { velocity } => {
                let u = Vector::<D>::from_fn(|k, _| velocity[k]);
                (u * t, u, Vector::zeros())
            }
        }
    }
}

/// Move the owned wall particles of every moving wall from time `t0` to `t1` (s) and record
/// each wall's acceleration at `t1` in `wall_acc` (indexed by wall body).
pub fn move_walls<const D: usize>(
    walls: &[WallKinematics],
    p: &mut Particles<D>,
    t0: f64,
    t1: f64,
    wall_acc: &mut [Vector<D>],
) {
    for k in walls {
        let (d0, _, _) = k.at::<D>(t0);
        let (d1, v1, a1) = k.at::<D>(t1);
        let dd = d1 - d0;
        for i in 0..p.n_owned {
            if p.kind[i].is_wall() && p.body[i] as usize == k.body {
                p.x[i] += dd;
                p.v[i] = v1;
            }
        }
        wall_acc[k.body] = a1;
    }
}
