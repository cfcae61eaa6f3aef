//! Plan: what the step decides for each body and pair before rapier's step, and the data it
//! carries to the stages after it.
//!
//! Contract: [`Planner::plan_body`] takes one awake managed body that may reach a ground and gives
//! each of its pairs with the grounds near it a role (`Role`, decided by
//! `crate::plugin::policy::Policy`: rapier's filtering first, then resting, rolling or impact), and
//! the body a [`Candidate`](crate::plugin::state::step::Candidate) (its start state, flight, and
//! which grounds may reach it) for the stages after rapier's step, and the balls held at rest on a
//! slope their first step (`StepData::first_holds`). It writes into rapier only through the commit:
//! in `Step` mode the impulses of the contacts that close in the step, each with its event; and it
//! reports a rolling ball that something can now reach (`EventKind::Released`, nothing written). It
//! reads rapier and the registry and calls the user's filter where the colliders ask for it;
//! [`StepData`] carries the step's thresholds, roles and candidates.
//!
//! The parts, by what each decides: the body's start, the grounds near it and its candidate
//! (`plan/body.rs`); one pair's role (`plan/role.rs`); `Step` mode's start-of-step impulse
//! (`plan/impulse.rs`); whether a resting ball rolls, is held or is reached (`plan/rolling.rs`).

mod body;
mod impulse;
mod role;
mod rolling;

use crate::plugin::config::ImpactConfig;
use crate::plugin::hooks::flags::HookFlags;
use crate::plugin::queries::ground_index::GroundMotion;
use crate::plugin::queries::observe::{Scene, Sets};
use crate::plugin::stages::commit::{Commit, Origin};
use crate::plugin::state::handles::{HandleSet, PairKey};
use crate::plugin::state::memory::LastStep;
use crate::plugin::state::registry::Registry;
use crate::plugin::state::step::StepData;
use crate::rapier::prelude::{ColliderSet, PhysicsHooks, RigidBodyHandle, RigidBodySet};
use body::BodyReads;

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

/// The plan stage's view of the plugin: what it reads, and the events of `Step` mode's
/// step-start impulses.
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
    pub commit: Commit<'a>,
}

impl<H: PhysicsHooks> Planner<'_, H> {
    /// Plans one awake managed body that may reach a ground (see the module's contract):
    /// the roles of its pairs with the grounds near it (in `step.roles`), its candidate (in
    /// `step.candidates`), and in `Step` mode the impulses of the contacts that close in the
    /// step (written, with their events). The step's gravity and length are `step.gravity`
    /// and `step.dt`. Returns whether a ground is near it (its colliders then need the
    /// plugin's hook flags in the bodies arrangement).
    pub fn plan_body(
        &mut self,
        handle: RigidBodyHandle,
        bodies: &mut RigidBodySet,
        colliders: &ColliderSet,
        sets: &Sets,
        last: &LastStep,
        step: &mut StepData,
    ) -> bool {
        let scene = Scene {
            bodies,
            colliders,
            sets,
            registry: self.registry,
            grounds: self.grounds,
        };
        // Used in place: a body's start is a large value, and every move of it a copy.
        let mut started = None;
        let Some(body) = self.start_body(handle, &scene, last, step, &mut started) else {
            return false;
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
        let (local_com, state, touched) = (body.local_com, plan.state, plan.touched);
        self.push_candidate(body, &mut plan, step);
        if touched {
            self.commit
                .state(bodies, handle, &state, &local_com, Origin::Correction);
        }
        true
    }
}
