//! Install: the stage before rapier's step that puts the plugin's hook flags where this step
//! needs them and builds the tables rapier's hook calls read (after the commit, which has
//! written the bodies).
//!
//! Contract: reads the plan (the roles of the pairs with grounds and between opted-in
//! bodies, which bodies are near a ground and which far); writes the hook flags on the
//! colliders (`hooks/flags.rs`; the other changes to rapier before its step are the commit's:
//! the sleeping bodies the pair plan wakes, and `Step` mode's impulses) and the step's
//! [`Lookup`]. Decides nothing about any pair.

use crate::plugin::hooks::lookup::Lookup;
use crate::plugin::impact_plugin::ImpactPlugin;
use crate::plugin::policy::Role;
use crate::plugin::state::handles::{HandleMap, HandleSet, PairKey};
use crate::plugin::state::step::StepData;
use crate::rapier::prelude::{ColliderHandle, ColliderSet, RigidBodyHandle, RigidBodySet};

impl<H> ImpactPlugin<H> {
    /// Flags the colliders the step's hooks need and builds the hooks' tables. `near`: the
    /// planned bodies with a ground near them; `far`: the awake managed bodies with none.
    pub(super) fn install(
        &mut self,
        step: &StepData,
        last_pairs: &HandleMap<PairKey, Role>,
        (bodies, colliders): (&RigidBodySet, &mut ColliderSet),
        (near, far): (&[RigidBodyHandle], &[RigidBodyHandle]),
        unmanaged: bool,
    ) {
        let members = self.hooked_pair_members(step, last_pairs, colliders);
        // Idle: no managed body near a ground, none asleep (`HookFlags::update`).
        let idle = near.is_empty() && step.asleep.is_empty();
        let (flagged, arrangement) = ((near, members.as_slice()), (unmanaged, idle));
        self.flags
            .update(&mut self.registry, flagged, arrangement, bodies, colliders);
        self.registry.flags_stale = false;
        let flags = &self.flags;
        // The far bodies' ground pairs are hooked only through flagged grounds.
        let far = if flags.grounds_flagged() { far } else { &[] };
        let far_colliders: Vec<ColliderHandle> = far
            .iter()
            .filter_map(|h| bodies.get(*h))
            .flat_map(|rb| rb.colliders().iter().copied())
            .collect();
        self.lookup = Lookup::build(
            (&step.ground_pairs, &step.by_tile),
            &step.pairs.roles,
            &far_colliders,
            // A collider not in the world meets nothing (a snapshot may list one): its flags
            // are never asked, and its slot may be any number.
            flags
                .hooked()
                .values()
                .flat_map(|e| e.colliders.iter().copied())
                .filter(|c| colliders.get(*c).is_some()),
            |c| flags.recorded_user_flags(colliders, c),
        );
    }

    /// The bodies whose colliders carry the hook flags of the planned pairs that need the
    /// hooks (`PlannedPair::hooked`): `Impact` pairs leave rapier's solver, `Resting` ones
    /// rapier would bounce get zero restitution. rapier hooks a pair when either collider is
    /// flagged, and every pair of a flagged body loses its contact recycling: so one body of
    /// each pair is flagged, one already flagged where there is one.
    ///
    /// rapier recycles an unhooked pair's contacts while its bodies stay within its recycle
    /// distance (5 cm at its defaults) of where its last full update found them, and a full
    /// update of a hooked pair records the contacts as the hooks left them: taking the flag
    /// off (no change rapier tracks) right after the plugin emptied an `Impact` pair's
    /// contacts would leave rapier solving the pair with none, two balls sinking into each
    /// other. So a pair that was an `Impact` last step stays hooked for one more step, in
    /// which the hooks leave it as rapier makes it.
    fn hooked_pair_members(
        &self,
        step: &StepData,
        last_pairs: &HandleMap<PairKey, Role>,
        colliders: &ColliderSet,
    ) -> Vec<RigidBodyHandle> {
        let mut chosen: HandleSet<RigidBodyHandle> = HandleSet::default();
        let mut members: Vec<RigidBodyHandle> = Vec::new();
        let body_of = |c: ColliderHandle| colliders.get(c).and_then(|co| co.parent());
        let hooked_now: Vec<_> = step.pairs.pairs.iter().filter(|pair| pair.hooked).collect();
        let hooked_keys: HandleSet<PairKey> = hooked_now.iter().map(|pair| pair.key).collect();
        let emptied_last_step = last_pairs
            .iter()
            .filter(|(key, role)| **role == Role::Impact && !hooked_keys.contains(key))
            .filter_map(|((c1, c2), _)| Some((body_of(*c1)?, body_of(*c2)?)));
        let hooked_now = hooked_now.iter().map(|pair| (pair.a, pair.b));
        for (a, b) in hooked_now.chain(emptied_last_step) {
            if chosen.contains(&a) || chosen.contains(&b) {
                continue;
            }
            let body = if self.flags.hooked().contains_key(&b) {
                b
            } else {
                a
            };
            chosen.insert(body);
            members.push(body);
        }
        members
    }
}
