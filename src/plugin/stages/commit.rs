//! Commit: the one writer. Every change the step makes to a rapier body, and every event that
//! reports one, goes through [`Commit`].
//!
//! Contract: the only code that calls rapier's body setters (pose, velocities, wake-up) and
//! the only code that appends to the step's events. [`Commit::state`] sets a body's pose and
//! velocities (woken up) from an `f64` state, [`Commit::flight`] what free flight changes,
//! [`Commit::wake`] wakes a sleeping body a step must plan. In `Exact` mode a state the model
//! reconstructed ([`Origin::Model`]) is remembered as a [`Shadow`], so that the next step
//! continues from the `f64` state rather than from its rounding to rapier's precision, as long
//! as rapier still holds exactly what was written; a correction of rapier's own end state
//! ([`Origin::Correction`]) is not: rapier's precision is its truth.

use crate::motion::State;
use crate::plugin::bridge::convert::{rot_from_na, rot_to_na, to_f64, vec_from_na};
use crate::plugin::events::{Diagnostic, ImpactEvent, Reports};
use crate::plugin::profile::StepProfile;
use crate::plugin::state::handles::HandleMap;
use crate::plugin::state::memory::Shadow;
use crate::rapier::math::{Pose, Real};
use crate::rapier::prelude::{RigidBody, RigidBodyHandle, RigidBodySet};
use nalgebra::Vector3;
use std::time::Instant;

/// Where a written state comes from, which decides whether `Exact` mode keeps it.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub(crate) enum Origin {
    /// A state the plugin computed in `f64` (the model's reconstruction: a flight, a rolling
    /// ball, the impacts of the step; or a start state put back, `EventKind::Hold`): it is the
    /// next step's start in `Exact` mode.
    Model,
    /// A correction of rapier's end state (a push-out, a step-end impact, a step-start
    /// impulse): the next step starts from what rapier holds.
    Correction,
}

/// The step's writer: the events and diagnostics of the step and `Exact` mode's shadows.
pub(crate) struct Commit<'a> {
    reports: &'a mut Reports,
    shadows: &'a mut HandleMap<RigidBodyHandle, Shadow>,
    /// `Exact` mode: states of [`Origin::Model`] are remembered.
    exact: bool,
    /// The step's profile, when profiling: each write counted and timed.
    log: Option<&'a mut StepProfile>,
}

impl<'a> Commit<'a> {
    pub fn new(
        reports: &'a mut Reports,
        shadows: &'a mut HandleMap<RigidBodyHandle, Shadow>,
        exact: bool,
        log: Option<&'a mut StepProfile>,
    ) -> Self {
        Self {
            reports,
            shadows,
            exact,
            log,
        }
    }

    /// Reports one change made to a body; an event whose numbers are not all finite is
    /// dropped (its state is refused too: [`Self::state`]).
    pub fn event(&mut self, event: ImpactEvent) {
        if event.is_finite() {
            self.reports.events.push(event);
        }
    }

    /// Reports changes made to bodies, in order ([`Self::event`] each).
    pub fn events(&mut self, events: impl IntoIterator<Item = ImpactEvent>) {
        for event in events {
            self.event(event);
        }
    }

    /// Reports what the step left to rapier.
    pub fn diagnose(&mut self, diagnostic: Diagnostic) {
        self.reports.diagnostics.push(diagnostic);
    }

    /// Withdraws the events reported from index `from` on: those of an attempt that was
    /// abandoned before anything of it was written (a cluster the search gave up on).
    pub fn withdraw(&mut self, from: usize) {
        self.reports.events.truncate(from);
    }

    /// The step's events so far (a body's events of this step start at an index taken
    /// before its stage ran: `reported()`).
    pub fn reported(&self) -> &[ImpactEvent] {
        &self.reports.events
    }

    /// Writes `s` into `body` (woken up): its pose and velocities.
    pub fn state(
        &mut self,
        bodies: &mut RigidBodySet,
        body: RigidBodyHandle,
        s: &State,
        local_com: &Vector3<f64>,
        origin: Origin,
    ) {
        if !fits(s) {
            self.diagnose(Diagnostic::NonFiniteState { body });
            return;
        }
        let started = self.clock();
        let rb = &mut bodies[body];
        write_pose_and_velocities(rb, s, local_com, true);
        self.remember(body, rb, s, origin);
        self.logged(started);
    }

    /// Writes a free flight's end into `body` (woken up): the translation and linear
    /// velocity, and the spin where `exact_spin` and rapier's differs (a write queues the body
    /// for rapier's update, so an unchanged spin is not written); rapier's rotation is kept.
    pub fn flight(
        &mut self,
        bodies: &mut RigidBodySet,
        body: RigidBodyHandle,
        s: &State,
        local_com: &Vector3<f64>,
        exact_spin: bool,
    ) {
        if !fits(s) {
            self.diagnose(Diagnostic::NonFiniteState { body });
            return;
        }
        let started = self.clock();
        let rb = &mut bodies[body];
        write_pose_and_velocities(rb, s, local_com, false);
        let w = vec_from_na(&s.w);
        if exact_spin && rb.angvel() != w {
            rb.set_angvel(w, true);
        }
        self.remember(body, rb, s, Origin::Model);
        self.logged(started);
    }

    /// Wakes a sleeping body the step must plan.
    pub fn wake(&mut self, bodies: &mut RigidBodySet, body: RigidBodyHandle) {
        let started = self.clock();
        if let Some(rb) = bodies.get_mut(body) {
            rb.wake_up(true);
        }
        self.logged(started);
    }

    /// The clock at a write's start, when profiling.
    fn clock(&self) -> Option<Instant> {
        self.log.as_ref().map(|_| Instant::now())
    }

    /// One write done, started at `started`: counted and timed, when profiling.
    fn logged(&mut self, started: Option<Instant>) {
        if let (Some(log), Some(started)) = (self.log.as_deref_mut(), started) {
            log.commit_time += started.elapsed();
            log.counts.writes += 1;
        }
    }

    fn remember(&mut self, body: RigidBodyHandle, rb: &RigidBody, s: &State, origin: Origin) {
        if self.exact && origin == Origin::Model {
            self.shadows.insert(body, Shadow::of(rb, s));
        }
    }
}

/// Does the state, written as a pose and velocities, fit in rapier's numbers (every value
/// finite in `Real`)? A state that does not is refused: nothing the plugin writes is NaN or
/// infinite.
fn fits(s: &State) -> bool {
    // Half the range for the centre of mass: the translation written is the centre less the
    // body's own offset to it, which is far smaller.
    let limit = to_f64(Real::MAX);
    let (c, v, w, q) = (&s.com, &s.v, &s.w, &s.rot.coords);
    // Written out: an iterator chain here cost a write 150 instructions.
    [c.x, c.y, c.z].iter().all(|x| x.abs() <= 0.5 * limit)
        && [v.x, v.y, v.z, w.x, w.y, w.z, q.x, q.y, q.z, q.w]
            .iter()
            .all(|x| x.abs() <= limit)
}

/// Sets a body's pose and velocities (woken up) from an `f64` state: the full pose, or
/// (`full = false`) the translation only, keeping rapier's rotation, and the spin unchanged.
fn write_pose_and_velocities(rb: &mut RigidBody, s: &State, local_com: &Vector3<f64>, full: bool) {
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
