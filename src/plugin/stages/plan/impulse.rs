//! `Step` mode's start-of-step impulse: a contact that closes within the step is resolved at
//! the step's start, its event pushed, and the pair's role follows from how the contact point
//! leaves.

use super::Planner;
use super::body::{BodyPlan, BodyReads};
use super::role::Pair;
use crate::plugin::bridge::resolve::{GroundContactAt, ImpactInput, Inertia, resolve};
use crate::plugin::events::ImpactTiming;
use crate::plugin::policy::Role;
use crate::plugin::policy::rests_at;
use crate::plugin::queries::geometry::{BodyPart, Hit, body_landing_point, body_velocity_at};
use crate::plugin::state::step::StepData;
use crate::rapier::prelude::PhysicsHooks;

impl<H: PhysicsHooks> Planner<'_, H> {
    /// Resolves the pair's contact `hit` (closing within the step, at the step's start; its
    /// part the pair's) as one impact at its landing point (`body_landing_point`: the part's,
    /// with the body's other parts landing level with it), with the body's state
    /// `plan.state`. On an impulse: the new state in `plan.state`
    /// (`plan.touched`), its event pushed, and the pair `Resting` if the point now leaves
    /// slower than the resting speed, else `Impact` (out of rapier's solver: a touching pair
    /// kept in the solver after the impulse would let a heavy body landing on this one in
    /// the same step press it into the ground). No impulse: `Resting`. Writes nothing to
    /// rapier (the plan returns the state, recorded through the commit once the body's plan is
    /// done).
    #[inline(never)]
    pub(super) fn step_start_impulse(
        &mut self,
        reads: BodyReads,
        plan: &mut BodyPlan,
        pair: Pair,
        hit: &Hit,
        step: &StepData,
    ) -> Role {
        let BodyReads { body, scene, .. } = reads;
        let Pair { k, part, gg, .. } = pair;
        let n = hit.normal;
        let inertia = Inertia::of(body.rb);
        let material =
            self.registry
                .material_of(scene.colliders, part.handle, gg.handle, self.config);
        // The body's other parts landing with this one join its impact (a dumbbell landing
        // level), where their pairs are the plugin's and of the same material.
        let joins = |_, other: &BodyPart| {
            !self.part_refused(body, scene, other, k)
                && self
                    .registry
                    .material_of(scene.colliders, other.handle, gg.handle, self.config)
                    == material
        };
        let flat = self.config.flat_tolerance;
        let (point, count) =
            body_landing_point(body.geom, gg, (&plan.state, 0.0), hit, flat, joins);
        let (law, resting_speed) = (self.config.law, step.policy.resting_speed);
        let timing = ImpactTiming::StepStart;
        let input = ImpactInput::new(body.handle, &inertia, law, material, resting_speed, timing);
        match resolve(
            &input,
            body.geom,
            gg,
            &plan.state,
            0.0,
            &GroundContactAt::new(hit, point, count),
        ) {
            Some((after, event)) => {
                plan.state = after;
                plan.touched = true;
                self.reports.events.push(event);
                let un2 =
                    n.dot(&(body_velocity_at(&plan.state, &point) - gg.velocity_at(&point, 0.0)));
                if rests_at(un2, step.policy.resting_speed) {
                    Role::Resting
                } else {
                    Role::Impact
                }
            }
            None => Role::Resting,
        }
    }
}
