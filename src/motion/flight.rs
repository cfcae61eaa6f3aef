//! Free flight of a rigid body in closed form, in `f64`: the motion between impacts.
//!
//! Translation: `dv/dt = a - c v` (constant acceleration `a` = gravity x gravity scale +
//! user force / mass, linear damping `c`), solved exactly:
//! `v(t) = v0 e^(-ct) + a phi1(t)`, `x(t) = x0 + v0 phi1(t) + a phi2(t)` with
//! `phi1 = (1 - e^(-ct))/c` and `phi2 = (t - phi1)/c` (`t` and `t^2/2` when `c = 0`).
//!
//! Rotation: torque-free. The world angular momentum `L = I_w(q) w` is conserved (scaled by
//! `e^(-c_w t)` under angular damping `c_w`, which only slows the motion down: the orientation
//! follows the undamped motion over the time `phi1_w(t)`), and `w(t) = I_w(q(t))^-1 L(t)`.
//! For isotropic inertia this is constant-axis spin, in closed form. Otherwise the
//! orientation is integrated by the splitting of the free rigid body (McLachlan 1993;
//! Dullweber, Leimkuhler & McLachlan 1997): each substep is, in Strang order, the exact
//! rotations about the principal axes 1 (half), 2 (half), 3, 2 (half), 1 (half) at the rates
//! `L_i / I_i` of the body-frame momentum, which turns under each rotation the opposite way.
//! Every sub-flow is exact, so `L` is conserved to rounding whatever the substep, the
//! method is symplectic and second order in the orientation; substeps turn at most
//! [`MAX_SUBSTEP_ANGLE`]. rapier 0.36 integrates the same motion with one explicit
//! gyroscopic correction of `w` per solver substep (`|L|` renormalised, its direction
//! first-order), so this flight is at least as faithful as rapier's own. A body with
//! rapier's gyroscopic forces disabled (or locked rotation axes) keeps constant-axis spin,
//! as rapier flies it.

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
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Flight {
    /// Constant linear acceleration (m/s^2).
    pub accel: Vector3<f64>,
    /// Linear damping coefficient `c` (1/s).
    pub linear_damping: f64,
    /// Angular damping coefficient (1/s).
    pub angular_damping: f64,
    /// Torque-free rotation of an anisotropic body; `None`: constant-axis spin (isotropic
    /// inertia, gyroscopic forces disabled, or locked rotation axes). Boxed: most bodies
    /// (every ball) have none, and a flight is copied into each of the step's candidates.
    pub gyro: Option<Box<Gyro>>,
}

/// The largest angle (rad) one substep turns about the asymmetry axis (the part of the motion
/// the splitting does not solve exactly; none for a symmetric top). The orientation error
/// is second order in it: 2.6e-7 rad over a 60 Hz step for a 0.3 x 0.2 x 0.1 m brick
/// spinning at 14 rad/s off its axes (11 substeps), against a fine Runge-Kutta solution.
pub(crate) const MAX_SUBSTEP_ANGLE: f64 = 0.005;

/// Most substeps of one flight (a body turning more than 20 rad in a step).
const MAX_SUBSTEPS: usize = 1024;

/// The inertia of an anisotropic body, for its torque-free rotation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Gyro {
    /// Principal moments of inertia (kg m^2), positive and finite.
    inertia: Vector3<f64>,
    /// The principal axes in the body frame.
    frame: UnitQuaternion<f64>,
    /// The principal axes `[a, b, c]`: `a` and `b` the pair of closest inverse moments (the
    /// symmetric top the splitting solves exactly), `c` the third.
    order: [usize; 3],
    /// The longest flight asked of one state (the step, s): it fixes the substep count of
    /// every flight from that state, so the pose is a smooth function of the flight time
    /// (the impact search differentiates it).
    span: f64,
}

impl Gyro {
    /// `None` when constant-axis spin is exact (isotropic inertia to 1e-12) or the moments
    /// are not all positive and finite (a body without rotational inertia).
    pub fn new(inertia: Vector3<f64>, frame: UnitQuaternion<f64>, span: f64) -> Option<Self> {
        if !inertia.iter().all(|i| i.is_finite() && *i > 0.0) || !span.is_finite() {
            return None;
        }
        let (lo, hi) = (inertia.min(), inertia.max());
        if hi - lo <= 1e-12 * hi {
            return None;
        }
        let inv = inertia.map(|i| 1.0 / i);
        let order = [[0, 1, 2], [1, 2, 0], [0, 2, 1]]
            .into_iter()
            .min_by(|p, q| {
                (inv[p[0]] - inv[p[1]])
                    .abs()
                    .total_cmp(&(inv[q[0]] - inv[q[1]]).abs())
            })
            .unwrap_or([0, 1, 2]);
        Some(Self {
            inertia,
            frame,
            order,
            span: span.max(0.0),
        })
    }

    /// The orientation of the principal axes in the world for the body orientation `rot`.
    fn axes(&self, rot: &UnitQuaternion<f64>) -> UnitQuaternion<f64> {
        rot * self.frame
    }

    /// The angular momentum in the principal frame of a body at `rot` spinning at `w`.
    fn momentum(&self, rot: &UnitQuaternion<f64>, w: &Vector3<f64>) -> Vector3<f64> {
        (self.axes(rot).inverse() * w).component_mul(&self.inertia)
    }

    /// The world angular momentum `I_w(rot) w` (kg m^2/s).
    #[cfg(test)]
    pub fn world_momentum(&self, rot: &UnitQuaternion<f64>, w: &Vector3<f64>) -> Vector3<f64> {
        self.axes(rot) * self.momentum(rot, w)
    }

    /// The largest angular speed the torque-free motion from `(rot, w)` reaches: the maximum
    /// of `|w|^2 = sum L_i^2 / I_i^2` over the body-frame momenta with the same `|L|` and
    /// kinetic energy (a linear programme in `L_i^2`, solved at its vertices).
    fn max_speed(&self, rot: &UnitQuaternion<f64>, w: &Vector3<f64>) -> f64 {
        let l = self.momentum(rot, w);
        let l2 = l.norm_squared();
        let e2: f64 = (0..3).map(|i| l[i] * l[i] / self.inertia[i]).sum();
        let mut best = w.norm_squared();
        for (i, j) in [(0, 1), (1, 2), (0, 2)] {
            let (ai, aj) = (1.0 / self.inertia[i], 1.0 / self.inertia[j]);
            if ai == aj {
                continue;
            }
            // x_i + x_j = l2, ai x_i + aj x_j = e2.
            let xi = (e2 - aj * l2) / (ai - aj);
            let xj = l2 - xi;
            if xi >= 0.0 && xj >= 0.0 {
                best = best.max(xi * ai * ai + xj * aj * aj);
            }
        }
        // The splitting keeps |L| exactly and the energy to second order.
        best.sqrt() * 1.01
    }

    /// Turns a body at `rot` with principal-frame momentum `l` for the time `s` (undamped):
    /// the orientation and the principal-frame momentum after.
    ///
    /// Splitting `T = T_sym + T_b` with `T_sym = |L|^2 / (2 I_a) + (1/I_c - 1/I_a) L_c^2 / 2`
    /// (a symmetric top, solved exactly: a turn about the world `L` at the rate `|L| / I_a`
    /// and one about the body axis `c` at `(1/I_c - 1/I_a) L_c`, which commute) and
    /// `T_b = (1/I_b - 1/I_a) L_b^2 / 2` (a turn about the body axis `b`), in Strang order.
    /// Exact for a symmetric top (`T_b = 0`); otherwise second order with an error
    /// proportional to the asymmetry `1/I_b - 1/I_a`.
    fn rotate(
        &self,
        rot: &UnitQuaternion<f64>,
        l: Vector3<f64>,
        s: f64,
    ) -> (UnitQuaternion<f64>, Vector3<f64>) {
        let [a, b, c] = self.order;
        let (ka, kb, kc) = (
            1.0 / self.inertia[a],
            1.0 / self.inertia[b] - 1.0 / self.inertia[a],
            1.0 / self.inertia[c] - 1.0 / self.inertia[a],
        );
        let turn = (kb * l.norm() * s.abs().max(self.span)).abs();
        let n = if kb == 0.0 || !turn.is_finite() {
            1
        } else {
            ((turn / MAX_SUBSTEP_ANGLE).ceil() as usize).clamp(1, MAX_SUBSTEPS)
        };
        let h = s / n as f64;
        let mut axes = self.axes(rot);
        let mut l = l;
        let axis = [Vector3::x_axis(), Vector3::y_axis(), Vector3::z_axis()];
        // A turn of the body about its own principal axis `i` by `theta`: the body-frame
        // momentum turns the other way, the world momentum stays.
        let body_turn =
            |axes: &mut UnitQuaternion<f64>, l: &mut Vector3<f64>, i: usize, theta: f64| {
                if theta != 0.0 {
                    let r = UnitQuaternion::from_axis_angle(&axis[i], theta);
                    *axes *= r;
                    *l = r.inverse() * *l;
                }
            };
        let world = axes * l;
        let world_axis = nalgebra::Unit::try_new(world, 0.0);
        let world_rate = world.norm() * ka;
        for _ in 0..n {
            let lb = l[b];
            body_turn(&mut axes, &mut l, b, 0.5 * kb * lb * h);
            // The symmetric top: about the world momentum, and about the body axis c.
            if let Some(u) = world_axis {
                axes = UnitQuaternion::from_axis_angle(&u, world_rate * h) * axes;
            }
            let lc = l[c];
            body_turn(&mut axes, &mut l, c, kc * lc * h);
            let lb = l[b];
            body_turn(&mut axes, &mut l, b, 0.5 * kb * lb * h);
        }
        let rot = UnitQuaternion::new_normalize(*(axes * self.frame.inverse()).quaternion());
        (rot, l)
    }
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
        let phi1 = -crate::math::exp_m1(-x) / c;
        (phi1, (t - phi1) / c)
    }
}

impl Flight {
    /// The state `tau` seconds after `s`.
    pub fn advance(&self, s: &State, tau: f64) -> State {
        let (com, v) = self.advance_centre(s, tau);
        let (phi1_w, _) = phis(self.angular_damping, tau);
        let (rot, w) = match &self.gyro {
            Some(gyro) if s.w != Vector3::zeros() => {
                let (rot, l) = gyro.rotate(&s.rot, gyro.momentum(&s.rot, &s.w), phi1_w);
                (
                    rot,
                    gyro.axes(&rot) * l.component_div(&gyro.inertia) * self.spin_decay(tau),
                )
            }
            _ => (
                UnitQuaternion::from_scaled_axis(s.w * phi1_w) * s.rot,
                self.spin_keeping_axis(&s.w, tau),
            ),
        };
        State { com, rot, v, w }
    }

    /// The centre of mass's position and velocity `tau` seconds after `s`: those of
    /// [`Self::advance`], without its rotation.
    #[inline]
    pub fn advance_centre(&self, s: &State, tau: f64) -> (Vector3<f64>, Vector3<f64>) {
        let (phi1, phi2) = phis(self.linear_damping, tau);
        let decay = if self.linear_damping == 0.0 {
            1.0
        } else {
            crate::math::exp(-self.linear_damping * tau)
        };
        (
            s.com + s.v * phi1 + self.accel * phi2,
            s.v * decay + self.accel * phi1,
        )
    }

    /// The spin `tau` seconds after the spin `w` of a body whose spin keeps its axis (no
    /// gyroscopic motion, `gyro` `None`): that of [`Self::advance`].
    #[inline]
    pub fn spin_keeping_axis(&self, w: &Vector3<f64>, tau: f64) -> Vector3<f64> {
        w * self.spin_decay(tau)
    }

    /// The factor angular damping leaves of the angular momentum after `tau` seconds.
    #[inline]
    fn spin_decay(&self, tau: f64) -> f64 {
        if self.angular_damping == 0.0 {
            1.0
        } else {
            crate::math::exp(-self.angular_damping * tau)
        }
    }

    /// An upper bound of the centre-of-mass speed over `[0, tau]` from `s`.
    #[inline]
    pub fn max_speed(&self, s: &State, tau: f64) -> f64 {
        s.v.norm() + self.accel.norm() * tau
    }

    /// An upper bound of the angular speed over any flight from `s` (torque-free motion
    /// can speed up the spin of an anisotropic body at constant `L` and energy).
    #[inline]
    pub fn max_angular_speed(&self, s: &State) -> f64 {
        match &self.gyro {
            Some(gyro) => gyro.max_speed(&s.rot, &s.w),
            None => s.w.norm(),
        }
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
            gyro: None,
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
            gyro: None,
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
            ..f.clone()
        };
        let c = g.advance(&s, 0.4);
        let d = Flight {
            linear_damping: 0.0,
            ..f
        }
        .advance(&s, 0.4);
        assert!((c.com - d.com).norm() < 1e-6);
    }

    /// A cuboid of half extents `half` at density 1, tilted, spinning off its principal axes.
    fn cuboid(half: [f64; 3], span: f64, angular_damping: f64) -> (Flight, State) {
        let [x, y, z] = half.map(|h| 2.0 * h);
        let m = x * y * z;
        let inertia = Vector3::new(y * y + z * z, x * x + z * z, x * x + y * y) * (m / 12.0);
        let f = Flight {
            accel: Vector3::new(0.0, -9.81, 0.0),
            linear_damping: 0.0,
            angular_damping,
            gyro: Gyro::new(inertia, UnitQuaternion::identity(), span).map(Box::new),
        };
        let s = State {
            com: Vector3::zeros(),
            rot: UnitQuaternion::from_euler_angles(0.3, 0.0, 0.0)
                * UnitQuaternion::from_euler_angles(0.0, 0.0, 0.6),
            v: Vector3::zeros(),
            w: Vector3::new(3.0, -12.0, 6.5),
        };
        (f, s)
    }

    /// The thin rod of `tests/plugin_bodies.rs` (1 x 0.02 x 0.02 m): a symmetric top.
    const ROD: [f64; 3] = [0.5, 0.01, 0.01];
    /// A brick with three distinct moments (0.3 x 0.2 x 0.1 m).
    const BRICK: [f64; 3] = [0.15, 0.1, 0.05];

    /// Euler's equations in the body frame by classical RK4 at a tiny step: the reference.
    fn reference(f: &Flight, s: &State, tau: f64) -> (UnitQuaternion<f64>, Vector3<f64>) {
        let g = f.gyro.as_deref().unwrap();
        let n = 200_000;
        let h = tau / n as f64;
        // Body-frame angular velocity and world orientation of the principal axes.
        let mut q = *(s.rot * g.frame).quaternion();
        let mut wb = (s.rot * g.frame).inverse() * s.w;
        let i = g.inertia;
        let dw = |w: &Vector3<f64>| -> Vector3<f64> {
            Vector3::new(
                (i.y - i.z) * w.y * w.z / i.x,
                (i.z - i.x) * w.z * w.x / i.y,
                (i.x - i.y) * w.x * w.y / i.z,
            )
        };
        let dq = |q: &nalgebra::Quaternion<f64>, w: &Vector3<f64>| {
            q * nalgebra::Quaternion::from_parts(0.0, *w) * 0.5
        };
        for _ in 0..n {
            let (k1w, k1q) = (dw(&wb), dq(&q, &wb));
            let w2 = wb + k1w * (h / 2.0);
            let (k2w, k2q) = (dw(&w2), dq(&(q + k1q * (h / 2.0)), &w2));
            let w3 = wb + k2w * (h / 2.0);
            let (k3w, k3q) = (dw(&w3), dq(&(q + k2q * (h / 2.0)), &w3));
            let w4 = wb + k3w * h;
            let (k4w, k4q) = (dw(&w4), dq(&(q + k3q * h), &w4));
            wb += (k1w + k2w * 2.0 + k3w * 2.0 + k4w) * (h / 6.0);
            q += (k1q + k2q * 2.0 + k3q * 2.0 + k4q) * (h / 6.0);
        }
        let axes = UnitQuaternion::new_normalize(q);
        (axes * g.frame.inverse(), axes * wb)
    }

    #[test]
    fn torque_free_flight_keeps_the_angular_momentum_and_follows_eulers_equations() {
        let dt = 1.0 / 60.0;
        // (body, orientation and relative w tolerance): exact for the symmetric rod, second
        // order in the substep for the brick.
        for (half, tol) in [(ROD, 1e-12), (BRICK, 1e-6)] {
            let (f, s) = cuboid(half, dt, 0.0);
            let g = f.gyro.as_deref().unwrap();
            let l0 = g.world_momentum(&s.rot, &s.w);
            for tau in [0.3 * dt, dt] {
                let e = f.advance(&s, tau);
                let l = g.world_momentum(&e.rot, &e.w);
                let (rot, w) = reference(&f, &s, tau);
                let dl = (l - l0).norm() / l0.norm();
                let angle = (e.rot.inverse() * rot).angle();
                let dw = (e.w - w).norm() / w.norm();
                println!(
                    "{half:?} tau {tau:.4}: |dL|/|L| {dl:.1e}, orientation {angle:.1e} rad, |dw|/|w| {dw:.1e}"
                );
                assert!(dl < 1e-13, "angular momentum drifts: {dl:.3e}");
                assert!(
                    angle < tol && dw < tol,
                    "orientation {angle:.3e} rad, w {dw:.3e}"
                );
                // The bound of the search holds along the way.
                assert!(e.w.norm() <= f.max_angular_speed(&s));
            }
            // Constant-axis spin, for comparison: the momentum it leaves with is off at first
            // order in |w| tau.
            let constant = Flight {
                gyro: None,
                ..f.clone()
            }
            .advance(&s, dt);
            let off = (g.world_momentum(&constant.rot, &constant.w) - l0).norm() / l0.norm();
            println!("{half:?} constant-axis spin: |dL|/|L| {off:.2e}");
            assert!(off > 0.01, "{off}");
        }
    }

    #[test]
    fn damped_torque_free_flight_scales_the_momentum() {
        let dt = 1.0 / 60.0;
        let (f, s) = cuboid(BRICK, dt, 2.0);
        let g = f.gyro.as_deref().unwrap();
        let l0 = g.world_momentum(&s.rot, &s.w);
        let e = f.advance(&s, dt);
        let l = g.world_momentum(&e.rot, &e.w);
        assert!((l - l0 * (-2.0 * dt).exp()).norm() < 1e-13 * l0.norm());
    }

    #[test]
    fn principal_and_isotropic_spins_are_constant_axis() {
        let dt = 1.0 / 60.0;
        let (f, mut s) = cuboid(BRICK, dt, 0.0);
        let axis = s.rot * Vector3::y();
        s.w = axis * 14.0;
        let e = f.advance(&s, dt);
        let c = Flight {
            gyro: None,
            ..f.clone()
        }
        .advance(&s, dt);
        assert!((e.w - c.w).norm() < 1e-12 && (e.rot.inverse() * c.rot).angle() < 1e-12);
        assert!(Gyro::new(Vector3::repeat(0.5), UnitQuaternion::identity(), dt).is_none());
        assert!(Gyro::new(Vector3::new(0.5, 0.0, 1.0), UnitQuaternion::identity(), dt).is_none());
    }
}
