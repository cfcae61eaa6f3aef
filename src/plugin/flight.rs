//! Free flight of a rigid body in closed form, in `f64`: the motion between impacts.
//!
//! Translation: `dv/dt = a - c v` (constant acceleration `a` = gravity x gravity scale +
//! user force / mass, linear damping `c`), solved exactly:
//! `v(t) = v0 e^(-ct) + a phi1(t)`, `x(t) = x0 + v0 phi1(t) + a phi2(t)` with
//! `phi1 = (1 - e^(-ct))/c` and `phi2 = (t - phi1)/c` (`t` and `t^2/2` when `c = 0`).
//!
//! Rotation: constant-axis spin `w(t) = w0 e^(-c_w t)`, turned through `w0 phi1_w(t)`.
//! This is torque-free motion exactly for isotropic inertia or a spin about a principal
//! axis; for other bodies it neglects the precession inside one step (second order in
//! `|w| dt`). Only the step of an impact uses it; free flight in `Exact` mode overwrites
//! translation only and leaves rotation to rapier.

use nalgebra::{UnitQuaternion, Vector3};

/// The kinematic state of a body: centre of mass, orientation, velocities (world frame).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct State {
    /// World centre of mass (m).
    pub com: Vector3<f64>,
    /// Orientation of the body frame.
    pub rot: UnitQuaternion<f64>,
    /// Linear velocity of the centre of mass (m/s).
    pub v: Vector3<f64>,
    /// Angular velocity (rad/s).
    pub w: Vector3<f64>,
}

/// What acts on a body in free flight.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Flight {
    /// Constant linear acceleration (m/s^2).
    pub accel: Vector3<f64>,
    /// Linear damping coefficient `c` (1/s).
    pub linear_damping: f64,
    /// Angular damping coefficient (1/s).
    pub angular_damping: f64,
}

/// `(1 - e^(-c t)) / c` and `(t - phi1) / c`, with their `c -> 0` limits.
fn phis(c: f64, t: f64) -> (f64, f64) {
    if c == 0.0 {
        return (t, 0.5 * t * t);
    }
    let x = c * t;
    if x.abs() < 1e-4 {
        // Series: phi1 = t (1 - x/2 + x^2/6 - x^3/24), phi2 = t^2 (1/2 - x/6 + x^2/24).
        let phi1 = t * (1.0 - x / 2.0 + x * x / 6.0 - x * x * x / 24.0);
        let phi2 = t * t * (0.5 - x / 6.0 + x * x / 24.0 - x * x * x / 120.0);
        (phi1, phi2)
    } else {
        let phi1 = -(-x).exp_m1() / c;
        (phi1, (t - phi1) / c)
    }
}

impl Flight {
    /// The state `tau` seconds after `s`.
    pub fn advance(&self, s: &State, tau: f64) -> State {
        let (phi1, phi2) = phis(self.linear_damping, tau);
        let decay = if self.linear_damping == 0.0 {
            1.0
        } else {
            (-self.linear_damping * tau).exp()
        };
        let (phi1_w, _) = phis(self.angular_damping, tau);
        let decay_w = if self.angular_damping == 0.0 {
            1.0
        } else {
            (-self.angular_damping * tau).exp()
        };
        let turn = s.w * phi1_w;
        State {
            com: s.com + s.v * phi1 + self.accel * phi2,
            rot: UnitQuaternion::from_scaled_axis(turn) * s.rot,
            v: s.v * decay + self.accel * phi1,
            w: s.w * decay_w,
        }
    }

    /// An upper bound of the centre-of-mass speed over `[0, tau]` from `s`.
    pub fn max_speed(&self, s: &State, tau: f64) -> f64 {
        s.v.norm() + self.accel.norm() * tau
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn undamped_flight_is_the_parabola() {
        let f = Flight {
            accel: Vector3::new(0.0, -9.81, 0.0),
            linear_damping: 0.0,
            angular_damping: 0.0,
        };
        let s = State {
            com: Vector3::new(0.0, 1.0, 0.0),
            rot: UnitQuaternion::identity(),
            v: Vector3::new(1.0, 2.0, 0.0),
            w: Vector3::new(0.0, 0.0, 3.0),
        };
        let e = f.advance(&s, 0.5);
        assert!((e.com.y - (1.0 + 1.0 - 0.5 * 9.81 * 0.25)).abs() < 1e-15);
        assert!((e.v.y - (2.0 - 9.81 * 0.5)).abs() < 1e-15);
        assert!((e.rot.angle() - 1.5).abs() < 1e-12);
    }

    #[test]
    fn damped_flight_matches_the_ode_limit() {
        let f = Flight {
            accel: Vector3::new(0.0, -9.81, 0.0),
            linear_damping: 0.7,
            angular_damping: 0.0,
        };
        let s = State {
            com: Vector3::zeros(),
            rot: UnitQuaternion::identity(),
            v: Vector3::new(0.0, 3.0, 0.0),
            w: Vector3::zeros(),
        };
        // Two half steps equal one step (semigroup property of the exact solution).
        let a = f.advance(&f.advance(&s, 0.2), 0.2);
        let b = f.advance(&s, 0.4);
        assert!((a.com - b.com).norm() < 1e-14 && (a.v - b.v).norm() < 1e-14);
        // Small damping agrees with the series branch.
        let g = Flight {
            linear_damping: 1e-7,
            ..f
        };
        let c = g.advance(&s, 0.4);
        let d = Flight {
            linear_damping: 0.0,
            ..f
        }
        .advance(&s, 0.4);
        assert!((c.com - d.com).norm() < 1e-6);
    }
}
