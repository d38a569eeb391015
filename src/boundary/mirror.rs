//! Mirror walls: the inner faces of a container with `method = "mirror"` reflect fluid
//! particles within the support into image particles. An image's position is reflected across
//! the plane, polar vectors flip their normal component, and its velocity is reflected about
//! the wall's surface velocity u_w: no-slip v' = 2u_w − v (every component), free-slip only
//! the normal component v'_n = 2u_w,n − v_n.

use super::axis_op::AxisOp;
use crate::scene::{Scene, Slip, WallShape};
use crate::Vector;

/// A mirror wall plane: the inner face of a container with `method = "mirror"`.
#[derive(Debug, Clone)]
pub struct MirrorPlane<const D: usize> {
    /// Axis normal to the plane.
    pub axis: usize,
    /// Plane position along the axis (m).
    pub at: f64,
    /// True if the fluid lies on the + side (the plane is a lower face).
    pub fluid_above: bool,
    /// Surface velocity of the wall (m/s).
    pub wall_velocity: Vector<D>,
    /// No-slip (reflect the whole velocity about the wall's) or free-slip (normal only).
    pub no_slip: bool,
    /// Morris et al.'s no-slip in the laminar term (`no_slip = "morris"`): the fluid sees an
    /// image with v_i − v_j′ = β (v_i − u_w), β = 1 + d_j′/d_i, instead of the reflected
    /// velocity ([`crate::physics::viscous`]).
    pub morris: bool,
    /// The container's corners (m): the face spans them on the other axes.
    pub lo: Vector<D>,
    /// See `lo`.
    pub hi: Vector<D>,
}

impl<const D: usize> MirrorPlane<D> {
    /// Reflection of coordinate `c` (along the plane's axis) across the plane (m).
    #[inline]
    pub fn reflect(&self, c: f64) -> f64 {
        2.0 * self.at - c
    }

    /// True if coordinate `c` along the axis lies on the wall's side of the plane.
    #[inline]
    fn beyond(&self, c: f64) -> bool {
        if self.fluid_above {
            c < self.at
        } else {
            c > self.at
        }
    }

    /// A fluid particle that this drift carried from `old` through the face to `x` bounces
    /// back: its position is reflected across the plane and its normal velocity about the
    /// wall's, v_n ← 2u_w,n − v_n (a specular bounce; the tangential velocity is kept). Without
    /// it a jet running into a corner can leave through a mirror wall, which has no particles
    /// to stop it. Returns true if it bounced.
    #[inline]
    pub fn bounce(&self, old: &Vector<D>, x: &mut Vector<D>, v: &mut Vector<D>) -> bool {
        let a = self.axis;
        let on_face = (0..D).all(|k| k == a || (self.lo[k]..=self.hi[k]).contains(&x[k]));
        if self.beyond(old[a]) || !self.beyond(x[a]) || !on_face {
            return false;
        }
        x[a] = self.reflect(x[a]);
        v[a] = 2.0 * self.wall_velocity[a] - v[a];
        true
    }

    /// Velocity of the image of a particle moving at `v` (m/s).
    #[inline]
    pub fn reflect_velocity(&self, v: &Vector<D>) -> Vector<D> {
        let mut v = *v;
        if self.no_slip {
            v = 2.0 * self.wall_velocity - v;
        } else {
            v[self.axis] = 2.0 * self.wall_velocity[self.axis] - v[self.axis];
        }
        v
    }
}

/// The mirror planes of a scene: every closed inner face of every mirror container.
pub fn planes_of<const D: usize>(scene: &Scene) -> Vec<MirrorPlane<D>> {
    let mut planes = Vec::new();
    for w in &scene.walls {
        if !w.method.makes_images() || w.shape != WallShape::Container {
            continue;
        }
        for a in 0..D {
            for up in [false, true] {
                if w.open
                    .iter()
                    .any(|o| crate::scene::face_of(o, D) == Some((a, up)))
                {
                    continue;
                }
                planes.push(MirrorPlane {
                    axis: a,
                    at: if up { w.max[a] } else { w.min[a] },
                    fluid_above: !up,
                    wall_velocity: Vector::from_fn(|k, _| w.velocity[k]),
                    no_slip: w.slip == Slip::NoSlip,
                    morris: w.slip == Slip::NoSlip && w.no_slip == crate::scene::NoSlipMethod::Morris,
                    lo: Vector::from_fn(|k, _| w.min[k]),
                    hi: Vector::from_fn(|k, _| w.max[k]),
                });
            }
        }
    }
    planes
}

/// Bounce a fluid particle that drifted from `old` to `x` through any mirror face
/// ([`MirrorPlane::bounce`]), at most once per plane.
pub fn bounce_all<const D: usize>(
    planes: &[MirrorPlane<D>],
    old: &Vector<D>,
    x: &mut Vector<D>,
    v: &mut Vector<D>,
) {
    for pl in planes {
        pl.bounce(old, x, v);
    }
}

/// Reflections of `x` along axis `a`: every plane normal to `a` with `x` on its fluid side
/// (inclusive) and closer than the support, appended to `out`.
#[inline]
pub fn reflections<const D: usize>(
    x: &Vector<D>,
    a: usize,
    planes: &[MirrorPlane<D>],
    support: f64,
    out: &mut Vec<AxisOp>,
) {
    for (k, pl) in planes.iter().enumerate() {
        let d = x[a] - pl.at;
        if pl.axis == a
            && ((pl.fluid_above && d >= 0.0) || (!pl.fluid_above && d <= 0.0))
            && d.abs() < support
        {
            out.push(AxisOp::Mirror(k));
        }
    }
}
