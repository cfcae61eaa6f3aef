//! Lookup: the per-step tables rapier's hooks read during its step.
//!
//! Contract: built at the end of `before_step` from the plan's roles and the hook flags, read
//! (never written) by the `PhysicsHooks` impl (`hooks/mod.rs`) while rapier steps; a lookup is an
//! index and a handle compare, not a hash. The hook flags themselves are put in place by
//! `hooks/flags.rs`.

use crate::plugin::hooks::flags::HookedBody;
use crate::plugin::policy::Role;
use crate::plugin::state::handles::PairKey;
use crate::plugin::state::handles::{HandleMap, slot_of};
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
    /// `StepData::roles`); or, for a collider of a body `before_step` found with no ground
    /// in reach, that all its ground pairs are `Resting` (rapier's broad phase still pairs
    /// it with the grounds whose bounds it overlaps, a half-space with every body).
    pub roles: Vec<Option<RoleSlot>>,
    /// By collider index: the hook flags the user set on a collider the plugin flagged.
    pub user_flags: Vec<Option<(ColliderHandle, ActiveHooks)>>,
}

#[derive(Clone, Copy)]
pub(crate) struct RoleSlot {
    pub body: ColliderHandle,
    pub ground: ColliderHandle,
    pub role: Role,
    /// The hook flags the user set on the two colliders (what rapier would have seen).
    pub user: ActiveHooks,
    pub more: bool,
}

/// What the table says of a pair (see [`Lookup::pair`]).
#[derive(Clone, Copy)]
pub(crate) enum Looked {
    /// A pair the table holds: its key, role and the user's flags on both colliders.
    Pair(PairKey, RoleSlot),
    /// `key.0` is a collider of a body with no ground in reach: if `key.1` is a managed
    /// ground, the pair is `Resting`; `user` is the user's flags on `key.0` only.
    Far(PairKey, ActiveHooks),
}

impl Lookup {
    /// `user_flags`: the hook flags the user set on a collider; `far`: the colliders of the
    /// bodies with no ground in reach (no roles).
    pub fn build(
        roles: &HandleMap<PairKey, Role>,
        far: &[ColliderHandle],
        hooked: &HandleMap<RigidBodyHandle, HookedBody>,
        user_flags: impl Fn(ColliderHandle) -> ActiveHooks,
    ) -> Self {
        let len = |it: &mut dyn Iterator<Item = ColliderHandle>| {
            it.map(slot_of).max().map_or(0, |m| m + 1)
        };
        let mut out = Self {
            roles_built: true,
            roles: vec![None; len(&mut roles.keys().map(|k| k.0).chain(far.iter().copied()))],
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
        for body in far {
            out.roles[slot_of(*body)] = Some(RoleSlot {
                body: *body,
                ground: ColliderHandle::invalid(),
                role: Role::Resting,
                user: user_flags(*body),
                more: false,
            });
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
                        user: user_flags(*body) | user_flags(*ground),
                        more: false,
                    })
                }
            }
        }
        out
    }

    /// The pair `(c1, c2)` in either order as the table holds it (body collider, ground
    /// collider), if it holds it alone.
    #[inline]
    pub fn pair(&self, c1: ColliderHandle, c2: ColliderHandle) -> Option<Looked> {
        if !self.roles_built {
            return None;
        }
        [(c1, c2), (c2, c1)].into_iter().find_map(|(body, ground)| {
            match self.roles.get(slot_of(body)) {
                Some(Some(slot)) if slot.body == body && slot.ground == ground => {
                    Some(Looked::Pair((body, ground), *slot))
                }
                Some(Some(slot))
                    if slot.body == body && slot.ground == ColliderHandle::invalid() =>
                {
                    Some(Looked::Far((body, ground), slot.user))
                }
                _ => None,
            }
        })
    }
}
