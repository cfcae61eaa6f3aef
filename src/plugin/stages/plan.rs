//! Plan: what the step decides for each body and pair before rapier's step, and the data it
//! carries to the stages after it.
//!
//! Contract: [`Planner::plan_body`] takes one awake managed body that may reach a ground and gives
//! each of its pairs with the grounds near it a role (`Role`, decided by
//! `crate::plugin::policy::Policy`: rapier's filtering first, then resting, rolling or impact), and
//! the body a [`Candidate`](crate::plugin::state::step::Candidate) (its start state, flight, and
//! which grounds may reach it) for the stages after rapier's step, and the balls held at rest on a
//! slope their first step (`StepData::first_holds`). It records nothing itself: it leaves in
//! [`PlanReports`], in `Step` mode, the body's state after the impulses of the contacts that
//! close in the step with their events, and a rolling ball that something can now reach
//! (`EventKind::Released`, nothing written); the stage's loop records them through the commit.
//! It reads rapier (each body as the step's writes so far leave it, `Scene::writes`) and the
//! registry, and calls the user's filter where the colliders ask for it; [`StepData`] carries
//! the step's thresholds, roles and candidates.
//!
//! The parts, by what each decides: the grounds near the body's start (its snapshot and
//! colliders, taken by `Planner::plan_body`) and its candidate (`plan/body.rs`); one pair's
//! role (`plan/role.rs`); `Step` mode's start-of-step impulse (`plan/impulse.rs`); whether a
//! resting ball rolls, is held or is reached (`plan/rolling.rs`).

mod body;
mod impulse;
mod role;
mod rolling;

use crate::motion::State;
use crate::plugin::config::ImpactConfig;
use crate::plugin::events::{Diagnostic, ImpactEvent};
use crate::plugin::hooks::flags::HookFlags;
use crate::plugin::queries::ground_index::GroundMotion;
use crate::plugin::queries::observe::{Scene, Sets, body_geom, snapshot};
use crate::plugin::queries::reach::NeighbourReads;
use crate::plugin::state::handles::{HandleSet, PairKey};
use crate::plugin::state::memory::LastStep;
use crate::plugin::state::registry::Registry;
use crate::plugin::state::step::StepData;
use crate::plugin::state::writes::Writes;
use crate::rapier::prelude::{ColliderSet, PhysicsHooks, RigidBodyHandle, RigidBodySet};
use body::BodyReads;
use nalgebra::Vector3;
pub(crate) use role::GroundSide;

/// Does the contact, at gap `dist` (m) with normal speed `un` and normal acceleration `an`,
/// close within `dt`? `dist + un t + an t^2 / 2 <= 0` for some `t` in `[0, dt]`.
pub(crate) fn closes_within(dist: f64, un: f64, an: f64, dt: f64) -> bool {
    let at = |t: f64| dist + un * t + 0.5 * an * t * t;
    if at(0.0) <= 0.0 || at(dt) <= 0.0 {
        return true;
    }
    if an > 0.0 {
        let t = -un / an;
        return t > 0.0 && t < dt && at(t) <= 0.0;
    }
    false
}

/// The plan stage's view of the plugin: what it reads, and where a body's plan reports its
/// events and diagnostics.
pub(crate) struct Planner<'a, H> {
    pub config: &'a ImpactConfig,
    pub registry: &'a Registry,
    pub flags: &'a HookFlags,
    pub user_hooks: &'a H,
    /// The pairs held at rest last step (`StepData::holds`).
    pub prev_holds: &'a HandleSet<PairKey>,
    /// The grounds' motions over the step (`StepData::grounds`, lent to the plan while it
    /// writes the rest of the step's values: the bodies it plans hold them).
    pub grounds: &'a [GroundMotion],
    /// The writes recorded so far in the step (a body is read as they leave it).
    pub writes: &'a Writes,
    /// The events and diagnostics of the body being planned, committed after its plan.
    pub reports: &'a mut PlanReports,
    /// What the plan read so far of the balls next to its rolling balls.
    pub neighbours: &'a mut NeighbourReads,
    /// The side of the last ground whose pairs were planned (`plan/role.rs`), kept over the
    /// stage.
    pub ground_side: &'a mut Option<GroundSide>,
}

/// What one body's plan leaves to be recorded through the commit, in order, once it is done:
/// `Step` mode's step-start impulses and push-outs, a rolling ball released, a collider's
/// coefficients out of range, and the state to write.
#[derive(Default)]
pub(crate) struct PlanReports {
    pub events: Vec<ImpactEvent>,
    pub diagnostics: Vec<Diagnostic>,
    /// In `Step` mode, the body's state after the step-start impulses of the contacts that
    /// close in the step (its centre of mass in its own frame with it).
    pub touched: Option<(State, Vector3<f64>)>,
}

impl PlanReports {
    /// Nothing to record.
    pub fn is_empty(&self) -> bool {
        self.events.is_empty() && self.diagnostics.is_empty() && self.touched.is_none()
    }
}

impl<H: PhysicsHooks> Planner<'_, H> {
    /// Plans one awake managed body that may reach a ground (see the module's contract):
    /// the roles of its pairs with the grounds near it (in `step.roles`), its candidate (in
    /// `step.candidates`), and in `Step` mode the impulses of the contacts that close in the
    /// step (written, with their events). The step's gravity and length are `step.gravity`
    /// and `step.dt`. Returns whether a ground is near it (its colliders then need the
    /// plugin's hook flags in the bodies arrangement), `None` for a body without a collider
    /// to query; its state to write, if touched, is in `self.reports`.
    pub fn plan_body(
        &mut self,
        handle: RigidBodyHandle,
        bodies: &RigidBodySet,
        colliders: &ColliderSet,
        sets: &Sets,
        last: &LastStep,
        step: &mut StepData,
    ) -> Option<bool> {
        let scene = Scene {
            bodies,
            colliders,
            sets,
            registry: self.registry,
            grounds: self.grounds,
            writes: self.writes,
        };
        let rb = &bodies[handle];
        // The body's snapshot and colliders are made in this frame and lent to its
        // `BodyNear`, which is filled in place: large values, and every move of one a copy.
        let now = self.writes.now(handle, rb);
        let snap = snapshot(&now, step.gravity, step.dt, last.shadows.get(&handle));
        let geom = body_geom(rb, colliders, &snap.2);
        if geom.parts.is_empty() {
            return None;
        }
        let mut started = None;
        let Some(body) = self.start_body((handle, rb), &scene, (&snap, &geom), step, &mut started)
        else {
            return Some(false);
        };
        let mut plan = body.plan();
        let reads = BodyReads {
            body,
            scene: &scene,
            last,
        };
        for k in 0..body.grounds.len() {
            self.plan_ground(reads, &mut plan, k, step);
        }
        if plan.touched {
            if !plan.resolved_at_start.is_empty() {
                self.redecide_resting(reads, &mut plan, step);
            }
            self.report_touched(&plan, body.local_com);
        }
        self.push_candidate(body, &mut plan, step);
        Some(true)
    }

    /// The state a `Step` impulse or a push-out left the body in (`plan.state`, with its
    /// centre of mass in its own frame `local_com`), reported to be written. Out of line: the
    /// other modes' plans, and most of `Step` mode's, touch no body.
    #[cold]
    #[inline(never)]
    fn report_touched(&mut self, plan: &body::BodyPlan, local_com: Vector3<f64>) {
        self.reports.touched = Some((plan.state, local_com));
    }
}
