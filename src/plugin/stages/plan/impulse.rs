//! `Step` mode's start-of-step impulse: a contact that closes within the step is resolved at
//! the step's start, its event pushed, and the pair's role follows from how the contact point
//! leaves. A pair decided `Resting` before a later ground's impulse changed the body's state is
//! decided again from the new state (`Planner::redecide_resting`): a bat's impulse that drives
//! a ball into the floor it rests on closes the floor's contact too.

use super::Planner;
use super::body::{BodyPlan, BodyReads};
use super::role::{Pair, decided_again};
use crate::plugin::bridge::resolve::{GroundContactAt, ImpactInput, Inertia, resolve};
use crate::plugin::events::ImpactTiming;
use crate::plugin::policy::Role;
use crate::plugin::policy::rests_at;
use crate::plugin::queries::geometry::{
    BodyPart, Hit, body_landing_point, body_velocity_at, contact_checked,
};
use crate::plugin::state::step::{GroundPair, StepData};
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
        let Pair {
            k, part, gg, key, ..
        } = pair;
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
                plan.resolved_at_start.push(key);
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

    /// After `Step` mode's impulses changed the body's state (`plan.touched`): its pairs still
    /// `Resting` were decided from the state before (a floor planned before the bat that
    /// drives the ball into it) and are decided again from `plan.state`, as
    /// [`Self::touching_role`] decides them. A pair the new state closes takes its own
    /// impulse and role (`Impact` joins the search after the step); one the new state lifts
    /// off is `Impact` (out of rapier's solver, as the first decision would have made it);
    /// one that still rests keeps its role and everything its first decision recorded. A pair
    /// already resolved by its own impulse in the step keeps the role that impulse gave: one
    /// impulse a pair and step. Rounds until one makes no impulse, so at most one round a
    /// resting pair. A body rolling in closed form or held on a slope keeps its plan (its
    /// pairs are the rolling's or rapier's). Out of line: only a `Step` impulse
    /// (`plan.resolved_at_start`) calls it.
    #[cold]
    #[inline(never)]
    pub(super) fn redecide_resting(
        &mut self,
        reads: BodyReads,
        plan: &mut BodyPlan,
        step: &mut StepData,
    ) {
        if plan.rolling.is_some() || plan.held || plan.rolling_pieces.is_some() {
            return;
        }
        let body = reads.body;
        let pairs = body.grounds.len() * body.geom.parts.len();
        for _ in 0..pairs {
            let impulses = self.reports.events.len();
            for k in 0..body.grounds.len() {
                let (gi, gg) = &body.grounds[k];
                for (part_index, part) in body.geom.parts.iter().enumerate() {
                    let key = (part.handle, gg.handle);
                    if step.roles.get(&key) != Some(&Role::Resting)
                        || plan.resolved_at_start.contains(&key)
                    {
                        continue;
                    }
                    let Some(&planned) = step.ground_pairs.iter().rfind(|p| p.key == key) else {
                        continue;
                    };
                    let Ok(Some(contact)) =
                        contact_checked(part, gg, &plan.state, 0.0, body.reach_to(gg))
                    else {
                        continue;
                    };
                    let pair = Pair {
                        k,
                        part,
                        part_index,
                        gg,
                        key,
                        colliders: (&reads.scene.colliders[key.0], &reads.scene.colliders[key.1]),
                        user: planned.user,
                    };
                    let role = self.touching_role(reads, plan, pair, contact, step);
                    if role == Role::Resting {
                        continue;
                    }
                    step.roles.insert(key, role);
                    decided_again(step, GroundPair { role, ..planned });
                    if role == Role::Impact && !plan.impact_grounds.contains(gi) {
                        plan.impact_grounds.push(*gi);
                        plan.closing = true;
                    }
                }
            }
            if self.reports.events.len() == impulses {
                break;
            }
        }
    }
}
