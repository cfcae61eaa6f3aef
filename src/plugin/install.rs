//! Install: the per-step tables rapier's hooks read during its step.
//!
//! Contract: built at the end of `before_step` from the plan's roles and the hook flags, read
//! (never written) by the `PhysicsHooks` impl (`hooks.rs`) while rapier steps; a lookup is an
//! index and a handle compare, not a hash. The hook flags themselves are put in place by
//! `hook_flags.rs`.

use super::handles::{HandleMap, slot_of};
use super::hook_flags::HookedBody;
use super::plan::Role;
use super::resolve::PairKey;
use crate::rapier::prelude::{ActiveHooks, ColliderHandle, RigidBodyHandle};

/// What the hooks ask for every ground pair inside rapier's step, by collider index instead
/// of hashing: the roles as they are at the end of [`ImpactPlugin::before_step`] (they do not
/// change until [`ImpactPlugin::after_step`]), and the user's hook flags on the managed
/// bodies' colliders. (The grounds' table is the ground index's.)
#[derive(Default)]
pub(crate) struct Lookup {
    /// `roles` holds what `StepData::roles` holds.
    pub roles_built: bool,
    /// By body collider index: one of its pairs, and whether it has others (then in
    /// `StepData::roles`).
    pub roles: Vec<Option<RoleSlot>>,
    /// By collider index: the hook flags the user set on a collider the plugin flagged.
    pub user_flags: Vec<Option<(ColliderHandle, ActiveHooks)>>,
}

#[derive(Clone, Copy)]
pub(crate) struct RoleSlot {
    pub body: ColliderHandle,
    pub ground: ColliderHandle,
    pub role: Role,
    pub more: bool,
}

impl Lookup {
    pub fn build(
        roles: &HandleMap<PairKey, Role>,
        hooked: &HandleMap<RigidBodyHandle, HookedBody>,
    ) -> Self {
        let len = |it: &mut dyn Iterator<Item = ColliderHandle>| {
            it.map(slot_of).max().map_or(0, |m| m + 1)
        };
        let mut out = Self {
            roles_built: true,
            roles: vec![None; len(&mut roles.keys().map(|k| k.0))],
            user_flags: vec![
                None;
                len(&mut hooked
                    .values()
                    .flat_map(|e| e.colliders.iter().map(|(c, _)| *c)))
            ],
        };
        for (c, user) in hooked.values().flat_map(|e| e.colliders.iter().copied()) {
            out.user_flags[slot_of(c)] = Some((c, user));
        }
        for ((body, ground), role) in roles {
            let slot = &mut out.roles[slot_of(*body)];
            match slot {
                Some(first) => first.more = true,
                None => {
                    *slot = Some(RoleSlot {
                        body: *body,
                        ground: *ground,
                        role: *role,
                        more: false,
                    })
                }
            }
        }
        out
    }
}
