//! Moving walls: a wall body with a motion law is displaced rigidly; its particles carry the
//! law's velocity (seen by the fluid) and its acceleration enters the dummy-wall pressure
//! extrapolation. Laws: `sine` d(t) = A [sin(ωt + φ) − sin φ], ω = 2π/T; `constant_velocity`
//! d(t) = u t (a piston); `solitary` Goring's (1978) wave maker, [`Goring`].

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
    /// Gravity |g| (m/s²) of the scene, which sets a solitary wave's celerity.
    pub g: f64,
}

/// Goring's (1978) piston law for one solitary wave of height A on depth h: the paddle moves
/// with the depth-averaged speed under the wave, dX/dt = c η/(h + η), where
/// η = A sech²θ, θ = k (c t − X − λ), k = √(3A/(4h³)) (1/m), c = √(g (h + A)) (m/s). The
/// integral is X = (A/(k h)) (tanh θ + tanh kλ), solved for X by Newton's method; the stroke is
/// S = 2A/(k h) (less 0.05 %: the lead). The lead λ puts the paddle kλ = [`Goring::LEAD`] wave numbers ahead of the crest
/// at t = 0, where η = A sech²(3.8) = 0.2 % of A: the crest leaves the paddle's rest position
/// at t = λ/c and passes a point x metres in front of it at t = (x + λ)/c.
#[derive(Debug, Clone, Copy)]
pub struct Goring {
    /// A (m).
    pub a: f64,
    /// h (m).
    pub h: f64,
    /// k (1/m).
    pub k: f64,
    /// c (m/s).
    pub c: f64,
}

impl Goring {
    /// kλ: how far ahead of the crest the paddle starts, in wave numbers.
    pub const LEAD: f64 = 3.8;

    /// The law for height `a` (m) on depth `h` (m) under gravity `g` (m/s²).
    pub fn new(a: f64, h: f64, g: f64) -> Self {
        Goring {
            a,
            h,
            k: (3.0 * a / (4.0 * h * h * h)).sqrt(),
            c: (g * (h + a)).sqrt(),
        }
    }

    /// λ (m).
    pub fn lead(&self) -> f64 {
        Self::LEAD / self.k
    }

    /// Time (s) at which the generated crest passes `x` metres in front of the paddle's rest
    /// position, for a wave of permanent form.
    pub fn crest_time(&self, x: f64) -> f64 {
        (x + self.lead()) / self.c
    }

    /// Paddle displacement X (m), velocity (m/s) and acceleration (m/s²) at time `t` (s).
    pub fn at(&self, t: f64) -> (f64, f64, f64) {
        let (a, h, k, c) = (self.a, self.h, self.k, self.c);
        let s = a / (k * h);
        let t0 = Self::LEAD.tanh();
        // f(X) = X − s (tanh θ + tanh kλ) is increasing in X (f' = 1 + (A/h) sech²θ ≥ 1)
        let mut x = 0.0;
        for _ in 0..60 {
            let th = k * (c * t - x) - Self::LEAD;
            let sech2 = 1.0 / th.cosh().powi(2);
            let dx = (x - s * (th.tanh() + t0)) / (1.0 + a / h * sech2);
            x -= dx;
            if dx.abs() <= 1e-15 * s {
                break;
            }
        }
        let th = k * (c * t - x) - Self::LEAD;
        let eta = a / th.cosh().powi(2);
        let v = c * eta / (h + eta);
        let dth = k * c * h / (h + eta);
        let deta = -2.0 * eta * th.tanh() * dth;
        let acc = c * h / (h + eta).powi(2) * deta;
        (x, v, acc)
    }
}

impl WallKinematics {
    /// Every wall of the scene that has a motion law.
    pub fn of(scene: &Scene) -> Vec<WallKinematics> {
        scene
            .walls
            .iter()
            .enumerate()
            .filter_map(|(b, w)| {
                w.motion.clone().map(|m| WallKinematics {
                    body: b,
                    motion: m,
                    g: scene.physics.body_force.iter().map(|x| x * x).sum::<f64>().sqrt(),
                })
            })
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
            Motion::Solitary {
                amplitude,
                depth,
                direction,
            } => {
                let e = Vector::<D>::from_fn(|k, _| direction[k]);
                let (x, v, a) = Goring::new(*amplitude, *depth, self.g).at(t);
                (e * x, e * v, e * a)
            }
        }
    }
}

/// Move the owned wall particles of every moving wall from time `t0` to `t1` (s) and record
/// each wall's acceleration and displacement from rest at `t1` in `wall_acc` and
/// `wall_shift` (indexed by wall body).
pub fn move_walls<const D: usize>(
    walls: &[WallKinematics],
    p: &mut Particles<D>,
    t0: f64,
    t1: f64,
    wall_acc: &mut [Vector<D>],
    wall_shift: &mut [Vector<D>],
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
        wall_shift[k.body] = d1;
    }
}

#[cfg(test)]
mod tests {
    use super::Goring;

    /// The paddle's speed is c η/(h + η) with η the wave's elevation at the paddle, its stroke
    /// 2A/(kh) (Goring 1978), and velocity and acceleration are the derivatives of the
    /// displacement (central differences).
    #[test]
    fn goring_paddle_follows_the_wave_it_makes() {
        let w = Goring::new(0.05, 0.25, 9.81);
        // 2A/(kh) from θ = −∞ to ∞; the paddle starts kλ = 3.8 wave numbers ahead of the crest
        let stroke = w.a / (w.k * w.h) * (1.0 + Goring::LEAD.tanh());
        let (x0, v0, _) = w.at(0.0);
        assert!(x0.abs() < 1e-15, "starts at rest position: {x0}");
        assert!(v0 < 2e-3 * w.c * w.a / w.h, "starts almost at rest: {v0}");
        let (xe, ve, _) = w.at(20.0);
        assert!(
            (xe - stroke).abs() < 1e-6 * stroke && ve < 1e-6,
            "{xe} {stroke} {ve}"
        );
        let dt = 1e-5;
        let mut vmax: f64 = 0.0;
        for n in 1..400 {
            let t = n as f64 * 0.01;
            let (x, v, a) = w.at(t);
            let (xm, vm, _) = w.at(t - dt);
            let (xp, vp, _) = w.at(t + dt);
            assert!((v - (xp - xm) / (2.0 * dt)).abs() < 1e-6, "t={t}");
            assert!((a - (vp - vm) / (2.0 * dt)).abs() < 1e-5, "t={t}");
            let th = w.k * (w.c * t - x) - Goring::LEAD;
            let eta = w.a / th.cosh().powi(2);
            assert!((v - w.c * eta / (w.h + eta)).abs() < 1e-12);
            vmax = vmax.max(v);
        }
        // the top speed, under the crest: c A/(h + A)
        assert!((vmax - w.c * w.a / (w.h + w.a)).abs() < 1e-3 * vmax, "{vmax}");
        assert!((w.crest_time(8.0) - (8.0 + 3.8 / w.k) / w.c).abs() < 1e-12);
    }
}
