//! Commit: the one place the step writes a body's state into rapier, and what the plugin
//! remembers of what it wrote.
//!
//! Contract: the only code that calls rapier's body setters. [`write_state`] sets a body's
//! pose and velocities (woken up) from an `f64` state, [`write_flight`] what free flight
//! changes, [`wake`] wakes a sleeping body a step must plan;
//! [`Shadow`] keeps, for `Exact` mode, the `f64` state behind what was written, so that the
//! next step continues from it rather than from its rounding to rapier's precision, as long
//! as rapier still holds exactly what was written.

use crate::motion::State;
use crate::plugin::bridge::convert::{rot_from_na, rot_to_na, vec_from_na};
use crate::rapier::math::Pose;
use crate::rapier::prelude::RigidBody;
use nalgebra::Vector3;

/// Writes a state into rapier (woken up): the full pose and velocities, or (`full = false`)
/// the translation and linear velocity only, keeping rapier's rotation.
pub(crate) fn write_state(rb: &mut RigidBody, s: &State, local_com: &Vector3<f64>, full: bool) {
    if full {
        let translation = s.com - s.rot * local_com;
        rb.set_position(
            Pose::from_parts(vec_from_na(&translation), rot_from_na(&s.rot)),
            true,
        );
        rb.set_angvel(vec_from_na(&s.w), true);
    } else {
        let rot = rot_to_na(*rb.rotation());
        let translation = s.com - rot * local_com;
        rb.set_translation(vec_from_na(&translation), true);
    }
    rb.set_linvel(vec_from_na(&s.v), true);
}

/// Writes a free flight's end (woken up): the translation and linear velocity, and the spin
/// where `exact_spin` and rapier's differs (a write queues the body for rapier's update, so
/// an unchanged spin is not written); rapier's rotation is kept.
pub(crate) fn write_flight(
    rb: &mut RigidBody,
    s: &State,
    local_com: &Vector3<f64>,
    exact_spin: bool,
) {
    write_state(rb, s, local_com, false);
    let w = vec_from_na(&s.w);
    if exact_spin && rb.angvel() != w {
        rb.set_angvel(w, true);
    }
}

/// Wakes a sleeping body up.
pub(crate) fn wake(rb: &mut RigidBody) {
    rb.wake_up(true);
}
