//! Settle: the corrections of rapier's end-of-step state that do no impulse algebra, as pure
//! functions of states.
//!
//! Contract: [`put_on_ground`] moves a state out of the ground along a contact normal (and for
//! a ball, removes its speed into the ground); [`capped_energy`] scales a state's velocities so
//! that its mechanical energy is no more than another's. Neither reads rapier; the adapter
//! reports each change it writes as an event (`EventKind::PushOut`, `EventKind::EnergyCap`).

use super::convert::to_f64;
use super::resolve::Inertia;
use crate::motion::{Flight, State};
use crate::rapier::math::Real;

/// `s` moved out of the ground along `hit`'s normal and, if `stop`, without its speed into
/// the ground: what a resting contact holds a ball at (for a ball, an `e = 0` frictionless
/// normal impulse, through its centre).
pub(crate) fn put_on_ground(s: &mut State, hit: &super::geometry::Hit, stop: bool) {
    s.com -= hit.normal * hit.dist;
    let vn = hit.normal.dot(&s.v);
    if stop && vn < 0.0 {
        s.v -= hit.normal * vn;
    }
}

/// `end` with its velocities scaled down by one factor (directions kept) so that its
/// mechanical energy `1/2 m v^2 + 1/2 w.I w - m a.x` (`a` the flight's constant acceleration)
/// is no more than `start`'s, or `None` when it already is (within the rounding of the
/// potential at rapier's precision, so that `f32` positions far from the origin do not
/// drain a slow body). When even the potential energy exceeds the start's energy, the body
/// is left at rest.
pub(crate) fn capped_energy(
    start: &State,
    end: &State,
    flight: &Flight,
    inertia: &Inertia,
) -> Option<State> {
    let energy = |s: &State| {
        let velocity = crate::model::BodyVelocity {
            linear: s.v,
            angular: s.w,
        };
        let kinetic = inertia.body_at(&s.rot).kinetic_energy(&velocity);
        (kinetic, kinetic - inertia.mass * flight.accel.dot(&s.com))
    };
    let (_, start_total) = energy(start);
    let (end_kinetic, end_total) = energy(end);
    let rounding = inertia.mass
        * flight.accel.norm()
        * to_f64(Real::EPSILON)
        * (1.0 + start.com.norm() + end.com.norm());
    if !(end_total > start_total + rounding && end_kinetic > 0.0) {
        return None;
    }
    let scale = ((end_kinetic - (end_total - start_total)).max(0.0) / end_kinetic).sqrt();
    Some(State {
        v: end.v * scale,
        w: end.w * scale,
        ..*end
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rapier::prelude::{ColliderBuilder, RigidBodyBuilder};
    use nalgebra::{UnitQuaternion, Vector3};

    /// A 0.3 x 0.2 x 0.1 m brick (density 1): its inertia, and the flight under gravity.
    fn brick() -> (Inertia, Flight) {
        let mut world = crate::rapier::prelude::PhysicsWorld::default();
        let (handle, _) = world.insert(
            RigidBodyBuilder::dynamic(),
            ColliderBuilder::cuboid(0.15, 0.1, 0.05),
        );
        let flight = Flight {
            accel: Vector3::new(0.0, -9.81, 0.0),
            linear_damping: 0.0,
            angular_damping: 0.0,
            gyro: None,
        };
        (Inertia::of(&world.bodies[handle]), flight)
    }

    fn total_energy(s: &State, inertia: &Inertia, flight: &Flight) -> f64 {
        let velocity = crate::model::BodyVelocity {
            linear: s.v,
            angular: s.w,
        };
        inertia.body_at(&s.rot).kinetic_energy(&velocity) - inertia.mass * flight.accel.dot(&s.com)
    }

    #[test]
    fn a_lift_that_adds_energy_is_paid_from_the_speeds() {
        let (inertia, flight) = brick();
        let rot = UnitQuaternion::from_euler_angles(0.3, -0.2, 0.7);
        let start = State {
            com: Vector3::new(0.0, 0.1, 0.0),
            rot,
            v: Vector3::new(0.5, -0.2, 0.1),
            w: Vector3::new(1.0, 2.0, -3.0),
        };
        // Pushed 4 mm up at the end with the start's velocities: more energy than at start.
        let end = State {
            com: Vector3::new(0.01, 0.104, 0.0),
            ..start
        };
        let capped = capped_energy(&start, &end, &flight, &inertia).expect("energy was gained");
        let (e0, e1) = (
            total_energy(&start, &inertia, &flight),
            total_energy(&capped, &inertia, &flight),
        );
        assert!((e1 - e0).abs() <= 1e-12 * e0.abs(), "{e0} -> {e1}");
        // One factor for both velocities, below 1; the pose untouched.
        let k = capped.v.norm() / end.v.norm();
        assert!(k < 1.0 && k > 0.0);
        assert!((capped.v - end.v * k).norm() < 1e-15 && (capped.w - end.w * k).norm() < 1e-14);
        assert_eq!((capped.com, capped.rot), (end.com, end.rot));
    }

    #[test]
    fn a_state_without_gain_is_left_alone_and_a_lift_beyond_the_energy_stops_the_body() {
        let (inertia, flight) = brick();
        let start = State {
            com: Vector3::new(0.0, 0.1, 0.0),
            rot: UnitQuaternion::identity(),
            v: Vector3::new(0.0, -0.3, 0.0),
            w: Vector3::zeros(),
        };
        // Lower and as fast: energy lost.
        let lower = State {
            com: Vector3::new(0.0, 0.09, 0.0),
            ..start
        };
        assert_eq!(capped_energy(&start, &lower, &flight, &inertia), None);
        // Lifted 1 cm: more than 1/2 v^2 / g = 4.6 mm can pay for.
        let lifted = State {
            com: Vector3::new(0.0, 0.11, 0.0),
            ..start
        };
        let capped = capped_energy(&start, &lifted, &flight, &inertia).unwrap();
        assert_eq!((capped.v, capped.w), (Vector3::zeros(), Vector3::zeros()));
        // At rest and lifted: nothing to scale, nothing done.
        let resting = State {
            v: Vector3::zeros(),
            ..lifted
        };
        assert_eq!(capped_energy(&start, &resting, &flight, &inertia), None);
    }
}
