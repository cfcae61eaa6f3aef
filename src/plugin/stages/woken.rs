//! Woken: the managed bodies asleep at the step's start that rapier woke during it. They had
//! no plan and no roles, so rapier's solver had all their ground contacts, bounce included:
//! their end state is checked as any other (`EndCheck::Woken`).
//!
//! Contract: reads rapier's end state of each such body and the grounds near it, without the
//! pairs rapier would not solve, that a joint disables or that the user's filter refuses
//! (asked here, as the body had no roles); commits what the settle stage corrected.

use crate::plugin::bridge::convert::vec_to_na;
use crate::plugin::bridge::resolve::Inertia;
use crate::plugin::impact_plugin::ImpactPlugin;
use crate::plugin::policy::EndCheck;
use crate::plugin::queries::observe::{body_geom, meets_tiles};
use crate::plugin::stages::commit::Origin;
use crate::plugin::stages::settle::Checked;
use crate::plugin::stages::view::AfterStep;
use crate::plugin::stages::view::EndOfStep;
use crate::rapier::prelude::{ColliderSet, PhysicsHooks, RigidBodySet};

impl<H: PhysicsHooks> ImpactPlugin<H> {
    /// Checks every body asleep at the start and awake at the end (see the module's
    /// contract).
    pub(super) fn check_woken(
        &mut self,
        step: &EndOfStep,
        bodies: &RigidBodySet,
        colliders: &ColliderSet,
    ) {
        let reads = (&self.config, &self.registry, &self.flags);
        let writes = (&mut self.writes, &mut self.reports);
        let mut view = AfterStep::new(reads, &self.user_hooks, &mut self.memory, writes);
        for handle in &step.asleep {
            let Some(rb) = bodies.get(*handle) else {
                continue;
            };
            if view.commit.is_sleeping(*handle, rb) || !view.registry.manages(*handle, rb) {
                continue;
            }
            let now = view.commit.now(*handle, rb);
            let (end, com) = (now.state(), now.center_of_mass());
            let local_com = vec_to_na(rb.local_center_of_mass());
            let geom = body_geom(rb, colliders, &local_com);
            let tiles = meets_tiles(step.sets.jointed(*handle), &geom.parts, |c| {
                view.flags.recorded_user_flags(colliders, c)
            });
            let grounds = view.woken_geoms((bodies, colliders), *handle, (com, &geom), step, tiles);
            let inertia = Inertia::of(rb);
            let checked = Checked {
                body: *handle,
                geom: &geom,
                inertia: &inertia,
                cand: None,
                grounds: &grounds,
                joined: grounds.len(),
                events_from: view.commit.reported().len(),
            };
            let why = EndCheck::Woken;
            let (_, settled) = view.check(bodies, colliders, &checked, &end, why, step);
            if let Some(s) = settled {
                view.commit
                    .state(*handle, &s, &local_com, Origin::Correction);
            }
        }
    }
}
