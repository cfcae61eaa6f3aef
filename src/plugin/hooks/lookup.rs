//! Lookup: the per-step tables rapier's hooks read during its step.
//!
//! Contract: built at the end of `before_step` from the plan's roles, as the plan listed them
//! with the user's hook flags it read (`StepData::ground_pairs`: what `HookFlags::
//! recorded_user_flags` answers is the user's flags, the same before and after
//! `HookFlags::update` puts the plugin's in place), the colliders of the pairs of opted-in
//! balls and the hook flags; read (never written) by the `PhysicsHooks` impl (`hooks/mod.rs`)
//! while rapier steps; a lookup is an index and a handle compare, not a hash. The hook flags
//! themselves are put in place by `hooks/flags.rs`.

use crate::plugin::policy::Role;
use crate::plugin::state::handles::PairKey;
use crate::plugin::state::handles::{HandleMap, slot_of};
use crate::plugin::state::step::GroundPair;
use crate::rapier::prelude::{ActiveHooks, ColliderHandle};

/// What the hooks ask for every ground pair inside rapier's step, by collider index instead
/// of hashing: the roles as they are at the end of [`ImpactPlugin::before_step`] (they do not
/// change until [`ImpactPlugin::after_step`]), and the user's hook flags on the managed
/// bodies' colliders. (The grounds' table is the ground index's.)
#[derive(Default)]
pub(crate) struct Lookup {
    /// `roles` holds what `StepData::roles` holds.
    pub roles_built: bool,
    /// By body collider index: one of its pairs, with its others in `rest`; or, for a
    /// collider of a body `before_step` found with no ground in reach, that all its ground
    /// pairs are `Resting` (rapier's broad phase still pairs it with the grounds whose bounds
    /// it overlaps, a half-space with every body). Every pair of `StepData::roles` is here.
    pub roles: Vec<Option<RoleSlot>>,
    /// A body collider's pairs after the first, together (`RoleSlot::rest`): the ground, the
    /// role, and the user's flags on the two colliders.
    pub rest: Vec<(ColliderHandle, Role, ActiveHooks)>,
    /// By collider index: the hook flags the user set on a collider the plugin flagged.
    pub user_flags: Vec<Option<(ColliderHandle, ActiveHooks)>>,
    /// By collider index: `true` where a collider of that index is in a pair of opted-in
    /// balls (`PairPlan::roles`), so that a pair with any other collider (a ball and its
    /// ground) is told apart from those pairs without hashing its key.
    pub pair_members: Vec<bool>,
}

#[derive(Clone, Copy)]
pub(crate) struct RoleSlot {
    pub body: ColliderHandle,
    pub ground: ColliderHandle,
    pub role: Role,
    /// The hook flags the user set on the two colliders (what rapier would have seen).
    pub user: ActiveHooks,
    /// The hook flags the user set on the body collider alone.
    pub body_user: ActiveHooks,
    /// Its pairs with a slab's tiles are by tile (`StepData::by_tile`), not under the slab's
    /// stand-in.
    pub by_tile: bool,
    /// Its other pairs: `Lookup::rest[rest.0..rest.1]`.
    pub rest: (u32, u32),
}

/// What the table says of a pair (see [`Lookup::pair`]).
#[derive(Clone, Copy)]
pub(crate) enum Looked {
    /// A pair the table holds: its key, role and the user's flags on both colliders.
    Pair(PairKey, Role, ActiveHooks),
    /// `key.0` is a collider of a body with no ground in reach, or none but those of its
    /// pairs in the table: if `key.1` is a managed ground, the pair is `Resting`; `user` is
    /// the user's flags on `key.0` only.
    Far(PairKey, ActiveHooks),
}

impl Lookup {
    /// How many slots the table of the user's flags holds (its memory, for the tests).
    #[cfg(test)]
    pub fn user_flags_slots(&self) -> usize {
        self.user_flags.len()
    }

    /// `roles`: the plan's pairs with grounds, each with the user's flags the plan read
    /// (`StepData::ground_pairs`); `user_flags`: the hook flags the user set on a collider;
    /// `far`: the colliders of the bodies with no ground in reach (no roles); `ball_pairs`:
    /// the roles of the pairs of opted-in balls.
    pub fn build(
        (roles, by_tile): (&[GroundPair], &[ColliderHandle]),
        ball_pairs: &HandleMap<PairKey, Role>,
        far: &[ColliderHandle],
        hooked: impl Iterator<Item = ColliderHandle>,
        user_flags: impl Fn(ColliderHandle) -> ActiveHooks,
    ) -> Self {
        let len = |it: &mut dyn Iterator<Item = ColliderHandle>| {
            it.map(slot_of).max().map_or(0, |m| m + 1)
        };
        let mut out = Self {
            roles_built: true,
            roles: vec![None; len(&mut roles.iter().map(|p| p.key.0).chain(far.iter().copied()))],
            ..Self::default()
        };
        // Each table is sized as it is filled: the maps are walked once.
        for c in ball_pairs.keys().flat_map(|k| [k.0, k.1]) {
            *grown(&mut out.pair_members, slot_of(c)) = true;
        }
        for c in hooked {
            *grown(&mut out.user_flags, slot_of(c)) = Some((c, user_flags(c)));
        }
        for body in far {
            let user = user_flags(*body);
            out.roles[slot_of(*body)] = Some(RoleSlot {
                body: *body,
                ground: ColliderHandle::invalid(),
                role: Role::Resting,
                user,
                body_user: user,
                by_tile: false,
                rest: (0, 0),
            });
        }
        // The pairs after a collider's first, by its slot, then gathered slot by slot.
        let mut rest = Vec::new();
        for pair in roles {
            let ((body, ground), role) = (pair.key, pair.role);
            let slot = &mut out.roles[slot_of(body)];
            match slot {
                Some(_) => rest.push((slot_of(body), (ground, role, pair.user))),
                None => {
                    *slot = Some(RoleSlot {
                        body,
                        ground,
                        role,
                        user: pair.user,
                        body_user: pair.body_user,
                        by_tile: false,
                        rest: (0, 0),
                    })
                }
            }
        }
        for body in by_tile {
            if let Some(Some(slot)) = out.roles.get_mut(slot_of(*body)) {
                slot.by_tile |= slot.body == *body;
            }
        }
        rest.sort_unstable_by_key(|(slot, _)| *slot);
        for (k, (slot, _)) in rest.iter().enumerate() {
            if let Some(first) = &mut out.roles[*slot] {
                if first.rest.1 == 0 {
                    first.rest.0 = k as u32;
                }
                first.rest.1 = k as u32 + 1;
            }
        }
        out.rest = rest.into_iter().map(|(_, pair)| pair).collect();
        out
    }

    /// May `(c1, c2)` be a pair of opted-in balls (`PairPlan::roles`)? `false` only where
    /// the table is built and one of the two is in no such pair.
    #[inline]
    pub fn may_pair_balls(&self, c1: ColliderHandle, c2: ColliderHandle) -> bool {
        let member = |c| self.pair_members.get(slot_of(c)).copied().unwrap_or(false);
        !self.roles_built || member(c1) && member(c2)
    }

    /// The role and user flags of the body collider's pair with `ground`, if the table holds
    /// it.
    #[inline]
    fn held(&self, slot: &RoleSlot, ground: ColliderHandle) -> Option<(Role, ActiveHooks)> {
        if slot.ground == ground {
            return Some((slot.role, slot.user));
        }
        let (from, to) = (slot.rest.0 as usize, slot.rest.1 as usize);
        self.rest
            .get(from..to)?
            .iter()
            .find(|(g, ..)| *g == ground)
            .map(|(_, role, user)| (*role, *user))
    }

    /// The role of the pair (body collider, ground collider) as the table holds it; `Resting`
    /// for a pair it does not hold (a pair the plan did not see coming).
    pub fn role(&self, key: &PairKey) -> Role {
        match self.roles.get(slot_of(key.0)) {
            Some(Some(slot)) if slot.body == key.0 => self
                .held(slot, key.1)
                .map_or(Role::Resting, |(role, _)| role),
            _ => Role::Resting,
        }
    }

    /// Does the body collider `c` meet a slab's tiles one by one this step
    /// (`StepData::by_tile`)?
    pub fn by_tile(&self, c: ColliderHandle) -> bool {
        matches!(self.roles.get(slot_of(c)), Some(Some(slot)) if slot.body == c && slot.by_tile)
    }

    /// The pair `key` (body collider, ground collider) as the step's roles name it: a slab's
    /// tile under the slab's stand-in (`stand_in`), unless the body's pairs are by tile.
    pub fn keyed(
        &self,
        key: PairKey,
        stand_in: impl Fn(ColliderHandle) -> ColliderHandle,
    ) -> PairKey {
        match self.roles.get(slot_of(key.0)) {
            Some(Some(slot)) if slot.body == key.0 && slot.by_tile => key,
            _ => (key.0, stand_in(key.1)),
        }
    }

    /// The pair `(c1, c2)` in either order (body collider, ground collider): as the table
    /// holds it, or `Far` for a body collider the table knows with a ground it does not hold;
    /// `None` when neither collider is a body collider of the table. A slab's tile is looked
    /// up as `stand_in` names it, unless the body's pairs are by tile.
    #[inline(always)]
    pub fn pair(
        &self,
        c1: ColliderHandle,
        c2: ColliderHandle,
        stand_in: impl Fn(ColliderHandle) -> ColliderHandle,
    ) -> Option<Looked> {
        if !self.roles_built {
            return None;
        }
        self.pair_of_body(c1, c2, &stand_in)
            .or_else(|| self.pair_of_body(c2, c1, &stand_in))
    }

    /// [`Self::pair`] with `body` as the body collider, `None` when the table does not know
    /// it as one.
    #[inline]
    fn pair_of_body(
        &self,
        body: ColliderHandle,
        ground: ColliderHandle,
        stand_in: &impl Fn(ColliderHandle) -> ColliderHandle,
    ) -> Option<Looked> {
        match self.roles.get(slot_of(body)) {
            Some(Some(slot)) if slot.body == body => {
                let ground = if slot.by_tile {
                    ground
                } else {
                    stand_in(ground)
                };
                Some(match self.held(slot, ground) {
                    Some((role, user)) => Looked::Pair((body, ground), role, user),
                    None => Looked::Far((body, ground), slot.body_user),
                })
            }
            _ => None,
        }
    }
}

/// `table[slot]`, the table first grown with default entries to hold it.
fn grown<T: Clone + Default>(table: &mut Vec<T>, slot: usize) -> &mut T {
    if table.len() <= slot {
        table.resize(slot + 1, T::default());
    }
    &mut table[slot]
}
