//! Steer: before rapier's step, the closed-form rolls (in every mode) and, in `Exact` mode,
//! the free flights that rapier's own integrator can carry onto the exact poses, so that such
//! a body has its velocities set, and not its pose (a pose write makes rapier update the
//! body's colliders and wake every body they have a contact pair with).
//!
//! Contract: rapier's substepped integrator moves a body of velocity `v0` under a constant
//! acceleration `a` by `v0 dt + (N + 1) / 2N a dt^2` in `N` substeps (velocity first, then
//! position, in each), and turns it in each substep by the normalised quaternion step
//! `(w h / 2, 1)`, an angle of `2 atan(|w| h / 2)` about `w` (`h = dt / N`).
//! - A free flight (`Exact` mode): started from `v0 - a dt / 2N` instead of `v0`, it lands
//!   on the exact position. This stage writes that velocity, and marks the candidate
//!   steered (`Candidate::steered`; its offset `a dt / 2N` is `Candidate::flight_steering`,
//!   read again where needed), for every flying candidate that rapier integrates so: a
//!   dynamic body with no ground within reach, no linear damping, no locked axis and no
//!   joint, not a ball of an impact between bodies, whose last step's end was the plugin's
//!   (its `f64` shadow still held: a body whose end rapier's contacts decided, a ball
//!   resting on others, is left alone). After rapier's step the bodies stage gives the body
//!   its own velocity back, and writes its exact translation only where rapier's drifted
//!   beyond a few roundings (`bodies.rs`, `fly_exactly`; `policy::carries`); a steered body
//!   that something else touched gets the offset back on rapier's end velocity.
//! - A closed-form roll (every mode) alone over one flat face of a still ground
//!   (`Candidate::rolls_on_one_face`), of a ball rapier integrates as above (also no
//!   angular damping and no user torque): the roll's end of the step is computed here, and
//!   rapier's step starts the ball from where rapier holds it with the linear velocity that
//!   lands on the end's centre, `(c1 - c0) / dt - (N + 1) / 2N a dt`, and the spin that
//!   turns it onto the end's rotation, `(2N / dt) tan(theta / 2N)` about the axis of the
//!   turn `theta`. Starting from rapier's pose, not the plan's, keeps rapier's rounding
//!   from adding up over the steps. Not steered: a ball with more substeps of its own
//!   (`additional_solver_iterations`). A ball whose spin rapier would cap (an eighth of a
//!   turn a step, unless it allows fast rotation) keeps its spin and has only its centre
//!   steered: with its ground's contact out of the solver it would otherwise fall through
//!   the step, which rapier's CCD cuts short. The bodies stage writes the end's velocities,
//!   and its pose only where rapier's drifted beyond a few roundings (`policy::carries`,
//!   `policy::carries_turn`), and keeps the end's `f64` state as the ball's shadow in every
//!   mode, from which its next step continues (`Commit::rolled`); a ball something else
//!   acted on keeps rapier's end state, the steering's offsets given back on its velocities
//!   (the steering is kept in `StepData::steered_rolls`, which only this stage appends to,
//!   the candidate holding its index, `Candidate::steered_roll`): its velocities are then
//!   an unsteered ball's, which flew without its ground, and the bodies stage's check
//!   (`EndCheck::DisturbedRolling`) gives it the ground's support and friction over the
//!   step as for one, though it ends on its plane rather than below it.
//!
//! Between steps rapier holds the body's own velocities, always.

use crate::motion::State;
use crate::plugin::bridge::convert::{rot_to_na, to_real, vec_from_na, vec_to_na};
use crate::plugin::config::TimingMode;
use crate::plugin::impact_plugin::ImpactPlugin;
use crate::plugin::queries::observe::Sets;
use crate::plugin::stages::commit::Commit;
use crate::plugin::state::memory::LastStep;
use crate::plugin::state::step::{Candidate, SteeredRoll, StepData};
use crate::plugin::state::writes::Now;
use crate::rapier::math::Vector;
use crate::rapier::prelude::{LockedAxes, RigidBody, RigidBodySet};
use nalgebra::Vector3;

/// A linear and an angular velocity (m/s, rad/s).
type Velocities = (Vector3<f64>, Vector3<f64>);

impl<H> ImpactPlugin<H> {
    /// The steer stage (see the module's contract): records the steering velocities of this
    /// step's free flights and closed-form rolls.
    pub(super) fn steer(
        &mut self,
        step: &mut StepData,
        bodies: &RigidBodySet,
        sets: &Sets,
        last: &LastStep,
    ) {
        // Flights are steered in `Exact` mode only: the other modes leave them to rapier's
        // integrator.
        let exact = self.config.timing == TimingMode::Exact;
        let mut commit = self.writer();
        let (dt, substeps) = (step.dt, step.substeps as f64);
        for cand in step.candidates.iter_mut() {
            let rolls = cand.rolls_on_one_face;
            if !(rolls || exact && flying(cand)) || step.pairs.members.contains(cand.body) {
                continue;
            }
            let Some(rb) = bodies
                .get(cand.body)
                .filter(|rb| integrated_alone(cand, rb, sets))
            else {
                continue;
            };
            let now = commit.now(cand.body, rb);
            if rolls {
                let integrated = rb.angular_damping() == 0.0
                    && rb.user_torque() == Vector::ZERO
                    && rb.additional_solver_iterations() == 0;
                if integrated {
                    let steered = &mut step.steered_rolls;
                    steer_roll(&mut commit, (cand, steered), rb, &now, (dt, substeps));
                }
                continue;
            }
            if !last
                .shadows
                .get(&cand.body)
                .is_some_and(|sh| sh.held_by(&now))
            {
                continue;
            }
            cand.steered = true;
            let held = cand.steered_velocity(step.steering_lag);
            if let Some(held) = held.filter(|v| *v != now.linvel()) {
                commit.velocity(cand.body, held);
            }
        }
    }
}

/// Records the steering velocities of the rolling candidate `cand` (`rb`, held as `now`) and
/// keeps the steering in `steered` (`StepData::steered_rolls`), its index in the candidate,
/// where [`steered_roll`] steers it and rapier leaves the spin as it is.
fn steer_roll(
    commit: &mut Commit,
    (cand, steered): (&mut Candidate, &mut Vec<SteeredRoll>),
    rb: &RigidBody,
    now: &Now,
    (dt, substeps): (f64, f64),
) {
    let fast = rb.is_fast_rotation_allowed();
    let Some((steering, (linvel, angvel))) = steered_roll(cand, now, (dt, substeps), fast) else {
        return;
    };
    let Ok(index) = u32::try_from(steered.len()) else {
        return;
    };
    let (linvel, angvel) = (vec_from_na(&linvel), vec_from_na(&angvel));
    if commit.velocities(cand.body, linvel, angvel) {
        steered.push(steering);
        cand.steered_roll = Some(index);
    }
}

/// The steering of a closed-form roll (see the module's contract) for the ball as rapier holds
/// it (`now`), in a step of `dt` seconds and `substeps` substeps, and the velocities rapier's
/// step starts it with (m/s, rad/s); `None` without a roll. Its spin is steered onto the
/// roll's end rotation where rapier leaves that spin as it is (`steered_spin`); else it keeps
/// its own and only its centre is steered: the bodies stage then writes the end's pose, but
/// the ball does not fall through its step (its ground's contact is out of rapier's solver),
/// which rapier's CCD, sweeping it against the ground, would cut short. Pure.
fn steered_roll(
    cand: &Candidate,
    now: &Now,
    (dt, substeps): (f64, f64),
    fast_rotation: bool,
) -> Option<(SteeredRoll, Velocities)> {
    let (_, motion) = cand.rolling.as_ref()?;
    let end: State = motion.advance(&cand.start, dt);
    let from = vec_to_na(now.center_of_mass());
    let linvel =
        (end.com - from) / dt - cand.flight.accel * dt * (substeps + 1.0) / (2.0 * substeps);
    let angvel = steered_spin(&end, now, (dt, substeps), fast_rotation)
        .unwrap_or_else(|| vec_to_na(now.angvel()));
    let offsets = (
        vec_to_na(now.linvel()) - linvel,
        vec_to_na(now.angvel()) - angvel,
    );
    let steered = SteeredRoll { end, from, offsets };
    Some((steered, (linvel, angvel)))
}

/// The spin that turns the ball from its rotation as rapier holds it (`now`) onto `end`'s in
/// rapier's `substeps` linear quaternion steps of a step of `dt` seconds; `None` where the
/// turn is a quarter turn a substep or more (one linear quaternion step cannot reach it), or
/// rapier would cap that spin (`within_spin_cap`, unless the body allows fast rotation).
fn steered_spin(
    end: &State,
    now: &Now,
    (dt, substeps): (f64, f64),
    fast_rotation: bool,
) -> Option<Vector3<f64>> {
    let turn = (end.rot * rot_to_na(now.rotation()).inverse()).scaled_axis();
    let angle = turn.norm();
    let per_substep = angle / (2.0 * substeps);
    if per_substep >= std::f64::consts::FRAC_PI_4 {
        return None;
    }
    let angvel = if angle > 0.0 {
        turn / angle * (2.0 * substeps / dt) * per_substep.tan()
    } else {
        Vector3::zeros()
    };
    (fast_rotation || within_spin_cap(&angvel, dt)).then_some(angvel)
}

/// Does rapier leave the steered spin `angvel` as it is? rapier caps a body's spin at an
/// eighth of a turn a step (`MAX_ROTATION`, pi/4 rad, times the step's inverse, in its
/// precision) unless the body allows fast rotation; a faster roll has only its centre
/// steered, and the bodies stage writes its end.
fn within_spin_cap(angvel: &Vector3<f64>, dt: f64) -> bool {
    let cap = to_real(std::f64::consts::FRAC_PI_4) * (1.0 / to_real(dt));
    vec_from_na(angvel).length() <= cap
}

/// A candidate that no ground can reach in the step.
fn flying(cand: &Candidate) -> bool {
    cand.near.is_empty() && cand.rolling.is_none() && !cand.touched
}

/// Does rapier integrate the body's step as the steering assumes: a dynamic body under a
/// constant acceleration alone (no linear damping, locked axis or joint)?
fn integrated_alone(cand: &Candidate, rb: &RigidBody, sets: &Sets) -> bool {
    rb.is_dynamic()
        && rb.is_enabled()
        && rb.linear_damping() == 0.0
        && rb.locked_axes() == LockedAxes::empty()
        && !sets.jointed(cand.body)
}
