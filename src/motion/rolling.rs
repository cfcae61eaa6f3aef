//! A ball sliding and rolling on a plane ground in closed form, in `f64`: the motion between
//! a landing and rest that rapier's resting contact gets wrong at 60 Hz (its contact point
//! turns with the ball, which then hops and slips on). No rapier types.

use super::flight::State;
use nalgebra::{UnitQuaternion, Vector3};

/// A ball sliding or rolling on a fixed flat ground, the ground pressing it with the force
/// that cancels the normal acceleration: what rapier's resting contact should give a ball and
/// does not at 60 Hz (its contact point turns with the ball, which then hops and slips on).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Rolling {
    /// Unit ground normal, out of the ground.
    pub normal: Vector3<f64>,
    /// Ball radius (m), from its centre to the contact point.
    pub radius: f64,
    /// `I / (m r^2)`: 2/5 for a solid ball.
    pub inertia_ratio: f64,
    /// Coulomb friction coefficient.
    pub friction: f64,
    /// Constant acceleration, along `-normal` (gravity on a level ground).
    pub accel: Vector3<f64>,
}

impl Rolling {
    /// The state `dt` seconds after `s`, which touches the ground (`v . n = 0`).
    ///
    /// The ground's normal force is `N = -m a.n`; the contact point slips at
    /// `s = v + w x (-r n)`. While it slips, kinetic friction `F = -mu N s/|s|` acts there:
    /// `dv/dt = F/m`, `dw/dt = (-r n) x F / I`, so `ds/dt = F (1 + 1/k) / m` keeps its direction
    /// and the slip decays at `mu |a.n| (1 + 1/k)`, reaching zero at
    /// `t_roll = |s| / (mu |a.n| (1 + 1/k))`. From then on the ball rolls without friction
    /// (no tangential force on a level ground) at constant `v` and `w`. For a ball launched
    /// sliding without spin, `v = 5/7 v0` at `t_roll = 2 v0 / (7 mu g)`. Every step of this
    /// is exact; the orientation is turned by the integral of `w`, exact when `w` keeps its
    /// axis (a ball sliding straight, with top- or backspin) and second order in the step
    /// otherwise (side spin about the normal).
    pub fn advance(&self, s: &State, dt: f64) -> State {
        let n = self.normal;
        let r = self.radius;
        let an = self.accel.dot(&n).min(0.0);
        let slip = s.v - r * s.w.cross(&n);
        let slip_speed = slip.norm();
        // Slip deceleration and how long the slip lasts.
        let decay = -self.friction * an * (1.0 + 1.0 / self.inertia_ratio);
        let sliding = if slip_speed > 0.0 && decay > 0.0 {
            (slip_speed / decay).min(dt)
        } else {
            0.0
        };
        let (mut v, mut w, mut turned) = (s.v, s.w, Vector3::zeros());
        let mut com = s.com;
        if sliding > 0.0 {
            let dir = slip / slip_speed;
            // Friction's accelerations: linear along -dir, angular about n x dir.
            let lin = self.friction * an * dir;
            let ang = n.cross(&dir) * (-self.friction * an / (r * self.inertia_ratio));
            com += v * sliding + 0.5 * lin * sliding * sliding;
            turned += w * sliding + 0.5 * ang * sliding * sliding;
            v += lin * sliding;
            w += ang * sliding;
        }
        let rest = dt - sliding;
        com += v * rest;
        turned += w * rest;
        State {
            com,
            rot: UnitQuaternion::from_scaled_axis(turned) * s.rot,
            v,
            w,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sliding_ball(v0: Vector3<f64>, w0: Vector3<f64>, mu: f64) -> (Rolling, State) {
        let rolling = Rolling {
            normal: Vector3::y(),
            radius: 0.1,
            inertia_ratio: 0.4,
            friction: mu,
            accel: Vector3::new(0.0, -9.81, 0.0),
        };
        let s = State {
            com: Vector3::new(0.0, 0.1, 0.0),
            rot: UnitQuaternion::identity(),
            v: v0,
            w: w0,
        };
        (rolling, s)
    }

    #[test]
    fn a_ball_launched_sliding_rolls_at_five_sevenths_at_the_closed_form_time() {
        let (v0, mu, g) = (2.0, 0.3, 9.81);
        let (rolling, s) = sliding_ball(Vector3::new(v0, 0.0, 0.0), Vector3::zeros(), mu);
        let t_roll = 2.0 * v0 / (7.0 * mu * g);
        // Half-way: v = v0 - mu g t, w r = 5/2 mu g t (w about -z for motion along +x).
        let half = rolling.advance(&s, 0.5 * t_roll);
        assert!((half.v.x - (v0 - mu * g * 0.5 * t_roll)).abs() < 1e-14);
        assert!((half.w.z * 0.1 + 2.5 * mu * g * 0.5 * t_roll).abs() < 1e-14);
        assert!(
            (half.com.x - (v0 * 0.5 * t_roll - 0.25 * mu * g * t_roll * t_roll / 2.0)).abs()
                < 1e-14
        );
        // Past the rolling time, in one step or in many: 5/7 v0, rolling, same place.
        let one = rolling.advance(&s, 3.0 * t_roll);
        let mut many = s;
        for _ in 0..30 {
            many = rolling.advance(&many, 0.1 * t_roll);
        }
        for end in [one, many] {
            assert!((end.v.x - 5.0 / 7.0 * v0).abs() < 1e-14, "{:?}", end.v);
            assert!(
                (end.v.x + end.w.z * 0.1).abs() < 1e-14,
                "slip {:?} {:?}",
                end.v,
                end.w
            );
            assert_eq!((end.v.y, end.v.z, end.com.y), (0.0, 0.0, 0.1));
        }
        // Distance: sliding (v0 + 5/7 v0)/2 t_roll, then rolling 2 t_roll.
        let x = 6.0 / 7.0 * v0 * t_roll + 5.0 / 7.0 * v0 * 2.0 * t_roll;
        assert!((one.com.x - x).abs() < 1e-14 && (many.com.x - x).abs() < 1e-13);
        // The orientation turned by the integral of w about -z.
        let turned = Vector3::z() * (0.5 * one.w.z * t_roll + one.w.z * 2.0 * t_roll);
        assert!(one.rot.angle_to(&UnitQuaternion::from_scaled_axis(turned)) < 1e-12);
    }

    #[test]
    fn backspin_and_side_slip_conserve_momentum_about_the_contact_and_lose_energy() {
        let (v0, r) = (2.0, 0.1);
        // Backspin as fast as the motion: the ball ends rolling at (1 - 2/5)/(7/5) v0 = 3/7 v0.
        let (rolling, s) = sliding_ball(
            Vector3::new(v0, 0.0, 0.0),
            Vector3::new(0.0, 0.0, v0 / r),
            0.2,
        );
        let end = rolling.advance(&s, 2.0);
        assert!((end.v.x - 3.0 / 7.0 * v0).abs() < 1e-14, "{:?}", end.v);
        // A slip across the motion (side spin about x): every direction by the same law.
        let (rolling, s) = sliding_ball(
            Vector3::new(1.0, 0.0, 0.5),
            Vector3::new(7.0, 3.0, -2.0),
            0.5,
        );
        let energy = |s: &State| 0.5 * s.v.norm_squared() + 0.5 * 0.4 * r * r * s.w.norm_squared();
        let mut prev = s;
        for _ in 0..20 {
            let next = rolling.advance(&prev, 0.01);
            assert!(energy(&next) <= energy(&prev) * (1.0 + 1e-15));
            prev = next;
        }
        let slip = prev.v - r * prev.w.cross(&Vector3::y());
        assert!(slip.norm() < 1e-13, "{slip:?}");
        // Angular momentum about the contact point, m (r n x v) + I w, along the ground.
        let l = |s: &State| Vector3::y().cross(&s.v) * r + 0.4 * r * r * s.w;
        let (l0, l1) = (l(&s), l(&prev));
        assert!((l0.x - l1.x).abs() < 1e-14 && (l0.z - l1.z).abs() < 1e-14);
        // The spin about the normal is untouched.
        assert_eq!(prev.w.y, 3.0);
    }

    #[test]
    fn without_friction_the_ball_keeps_its_velocities() {
        let (rolling, s) = sliding_ball(
            Vector3::new(1.0, 0.0, 0.0),
            Vector3::new(0.0, 0.0, 4.0),
            0.0,
        );
        let end = rolling.advance(&s, 0.5);
        assert_eq!((end.v, end.w), (s.v, s.w));
        assert!((end.com.x - 0.5).abs() < 1e-15);
    }
}
