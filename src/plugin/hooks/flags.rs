//! The plugin's hook flags: on the grounds, or on the managed bodies near a ground.
//!
//! rapier calls the hooks of a contact pair when either collider has the flag, and never
//! recycles the contacts of such a pair (`IntegrationParameters::contact_recycling`: a pair
//! with hook flags is fully updated every step). Where the flags go is a trade:
//! - on the grounds: only ground pairs are hooked, and every contact between bodies keeps
//!   rapier's recycling and speed; but a dynamic body the plugin does not manage (excluded,
//!   translation locked) would have its ground pairs hooked too, and so no longer move
//!   exactly as in rapier alone;
//! - on the colliders of each managed body whose bounding sphere can reach a ground in the
//!   step (found in [`ImpactPlugin::before_step`]; kept while it sleeps, taken off once it is
//!   far, unmanaged or gone): every pair of an unmanaged body stays exactly rapier's, but the
//!   contacts between managed bodies near a ground are hooked as well (a pile's bottom
//!   layer: not recycled, and the hooks called).
//!
//! Flagging only the bodies about to impact (an `Impact` or `Rolling` ground pair; a rolled
//! ball leaves rapier's solver too) is the second with fewer bodies, and measured no cheaper
//! than the first: their contacts with the balls around them are hooked instead of the
//! resting ground pairs (docs/guide.md, "Filtering and hooks").
//!
//! The plugin takes the first while every dynamic body in the world is managed (the usual
//! scene), and the second from the first step some dynamic, enabled body is not. In the
//! first, a scene whose managed bodies all stay far from every ground and awake (balls in
//! flight high above it) needs no flags at all: the grounds get none until a first body nears
//! a ground (or sleeps), and lose them after `GROUND_FLAGS_IDLE_STEPS` such steps in a row;
//! rapier then calls no hook for their pairs, until a body nears a ground again. In either,
//! one ball of each of the step's impacts between bodies, and of each resting pair rapier
//! would bounce above the resting gap (`pair_plan.rs`, `PlannedPair::hooked`), is flagged
//! too (rapier hooks a pair when either collider asks): the plugin takes the impact pairs
//! from rapier's solver and zeroes the others' restitution. The flags the user had set are
//! recorded and handed back: the wrapped hook is called exactly when they ask for it.

use crate::plugin::policy::GROUND_FLAGS_IDLE_STEPS;
use crate::plugin::state::handles::{ArenaOrder, HandleMap, PairKey, SlotTable};
use crate::plugin::state::registry::Registry;
use crate::plugin::state::small_list::SmallList;
use crate::rapier::prelude::{
    ActiveHooks, ColliderHandle, ColliderSet, RigidBody, RigidBodyHandle, RigidBodySet,
};

/// The hook flags the plugin needs on a managed body's colliders near a ground.
pub(crate) const PLUGIN_HOOKS: ActiveHooks =
    ActiveHooks::FILTER_CONTACT_PAIRS.union(ActiveHooks::MODIFY_SOLVER_CONTACTS);

/// A body whose colliders carry the plugin's flags.
#[derive(Clone, Debug, Default)]
pub(crate) struct HookedBody {
    /// Each flagged collider with the flags the user had set on it.
    pub colliders: SmallList<(ColliderHandle, ActiveHooks)>,
    /// The step (`HookFlags::stamp`) that last needed the flags.
    stamp: u64,
}

/// Where the plugin's hook flags are, and the user's flags they replaced.
#[derive(Default)]
pub(crate) struct HookFlags {
    /// Managed bodies whose colliders carry the plugin's hook flags.
    hooked: HandleMap<RigidBodyHandle, HookedBody>,
    /// Grounds carrying the plugin's hook flags, with the flags the user had set.
    grounds: SlotTable<ColliderHandle, ActiveHooks>,
    /// Counts the steps, to find the hooked bodies no step needs any more.
    stamp: u64,
    /// Steps since one needed the grounds' flags (a managed body near a ground or asleep),
    /// `None` before any did: the flags are off beyond [`GROUND_FLAGS_IDLE_STEPS`], and
    /// until a first step needs them.
    since_needed: Option<u32>,
    /// This step's arrangement flags the grounds.
    grounds_on: bool,
}

impl HookFlags {
    /// The managed bodies whose colliders carry the plugin's flags.
    pub fn hooked(&self) -> &HandleMap<RigidBodyHandle, HookedBody> {
        &self.hooked
    }

    /// Puts the flags where this step needs them (see the module's documentation):
    /// `near` are the managed bodies that can reach a ground in the step, `pairs` a body of
    /// each of the step's hooked pairs between bodies (`PlannedPair::hooked`: flagged in either
    /// arrangement), `unmanaged` whether the world holds a dynamic, enabled body the plugin
    /// does not manage, `idle` whether no managed body is near a ground or asleep this step.
    /// `registry.flags_stale` is read here and cleared by the caller.
    pub fn update(
        &mut self,
        registry: &Registry,
        (near, pairs): (&[RigidBodyHandle], &[RigidBodyHandle]),
        (unmanaged, idle): (bool, bool),
        bodies: &RigidBodySet,
        colliders: &mut ColliderSet,
    ) {
        // Grounds: flagged in the first arrangement, and never once unmarked, nor before a
        // step needs them or after `GROUND_FLAGS_IDLE_STEPS` idle steps in a row (no contact
        // of a ground pair is then the plugin's: a body far from every ground by the survey's
        // bound cannot touch one in the step, and a sleeping one keeps the flags on). Which
        // grounds keep their flags changes only with the registry, the arrangement or
        // idleness.
        self.since_needed = match (idle, self.since_needed) {
            (false, _) => Some(0),
            (true, since) => since.map(|n| n.saturating_add(1)),
        };
        let idle_too_long = self
            .since_needed
            .is_none_or(|n| n > GROUND_FLAGS_IDLE_STEPS);
        let off = unmanaged || idle_too_long;
        let were_on = self.grounds_on;
        self.grounds_on = !off;
        let grounds = &registry.grounds;
        if off || registry.flags_stale {
            self.grounds.retain(|c, user| {
                let keep = !off && grounds.contains_key(c);
                if !keep {
                    restore(colliders, *c, *user);
                }
                keep
            });
        }
        if !off {
            let mut flag = |c: ColliderHandle| {
                // Read first: `ColliderSet::get_mut` queues the collider for rapier's broad
                // and narrow phase updates, which for every ground every step cost more
                // than the rest of the plugin on a floor of 4 096 tiles.
                let Some(flags) = colliders.get(c).map(|co| co.active_hooks()) else {
                    return;
                };
                if !flags.contains(PLUGIN_HOOKS) {
                    // New, or the user set the flags since the last step: theirs now.
                    self.grounds.insert(c, flags);
                    set_flags(colliders, c, flags | PLUGIN_HOOKS);
                }
            };
            // Every ground when they were off or the grounds changed; else only those whose
            // flags the ground index's pass found changed this step (the user's doing, or
            // the plugin's own from the last step).
            match registry.index.hooks_changed() {
                Some(changed) if were_on && !registry.flags_stale => {
                    changed.iter().for_each(|c| flag(*c))
                }
                _ => registry.grounds.keys().for_each(|c| flag(*c)),
            }
        }
        // Bodies: flagged in the second.
        self.stamp = self.stamp.wrapping_add(1);
        let stamp = self.stamp;
        let near = if unmanaged { near } else { &[] };
        for handle in near.iter().chain(pairs) {
            let Some(rb) = bodies.get(*handle) else {
                continue;
            };
            let entry = self.hooked.entry(*handle).or_default();
            entry.stamp = stamp;
            flag_body(entry, rb, colliders);
        }
        if self.hooked.is_empty() {
            return;
        }
        let mut hooked = std::mem::take(&mut self.hooked);
        hooked.retain(|handle, entry| {
            if entry.stamp == stamp {
                return true;
            }
            if unmanaged
                && bodies
                    .get(*handle)
                    .is_some_and(|rb| rb.is_sleeping() && registry.manages(*handle, rb))
            {
                entry.stamp = stamp;
                return true;
            }
            for (c, user) in entry.colliders.iter() {
                restore(colliders, *c, *user);
            }
            false
        });
        self.hooked = hooked;
    }

    /// Do grounds carry the plugin's flags this step (the first arrangement, not idle)?
    pub fn grounds_flagged(&self) -> bool {
        self.grounds_on
    }

    /// The hook flags the user set on a collider (those rapier would have seen without the
    /// plugin).
    pub fn recorded_user_flags(&self, colliders: &ColliderSet, c: ColliderHandle) -> ActiveHooks {
        let Some(co) = colliders.get(c) else {
            return ActiveHooks::empty();
        };
        let flags = co.active_hooks();
        if !flags.contains(PLUGIN_HOOKS) {
            // Not flagged by the plugin, or the user has set new flags since.
            return flags;
        }
        if let Some(user) = self.grounds.get(c) {
            return *user;
        }
        co.parent()
            .and_then(|p| self.hooked.get(&p))
            .and_then(|e| e.colliders.iter().find(|(h, _)| *h == c))
            .map_or(flags, |(_, user)| *user)
    }

    /// The hook flags the user set on either collider of the pair `key` (what rapier would
    /// have seen for the pair without the plugin).
    pub fn recorded_pair_flags(&self, colliders: &ColliderSet, key: PairKey) -> ActiveHooks {
        self.recorded_user_flags(colliders, key.0) | self.recorded_user_flags(colliders, key.1)
    }

    /// Takes the plugin's hook flags off every collider: the user's flags back.
    pub fn restore_all(&mut self, colliders: &mut ColliderSet) {
        for (c, user) in self.grounds.iter() {
            restore(colliders, *c, *user);
        }
        for entry in self.hooked.values() {
            for (c, user) in entry.colliders.iter() {
                restore(colliders, *c, *user);
            }
        }
        self.hooked.clear();
        self.grounds = SlotTable::default();
    }
}

/// Flags the body's colliders (new ones included) and gives back those detached from it.
fn flag_body(entry: &mut HookedBody, rb: &RigidBody, colliders: &mut ColliderSet) {
    let attached = rb.colliders();
    let same = entry.colliders.len() == attached.len()
        && entry
            .colliders
            .iter()
            .zip(attached)
            .all(|((h, _), a)| h == a);
    if !same {
        for (c, user) in entry.colliders.iter() {
            if !attached.contains(c) {
                restore(colliders, *c, *user);
            }
        }
        let old = std::mem::take(&mut entry.colliders);
        for c in attached {
            let user = old
                .iter()
                .find(|(h, _)| h == c)
                .map(|(_, u)| *u)
                .or_else(|| colliders.get(*c).map(|co| co.active_hooks()));
            if let Some(user) = user {
                entry.colliders.push((*c, user));
            }
        }
    }
    for (c, user) in entry.colliders.iter_mut() {
        let Some(flags) = colliders.get(*c).map(|co| co.active_hooks()) else {
            continue;
        };
        if !flags.contains(PLUGIN_HOOKS) {
            // New, or the user set the flags since the last step: theirs now.
            *user = flags;
            set_flags(colliders, *c, flags | PLUGIN_HOOKS);
        }
    }
}

/// What [`HookFlags`] carries to the next step, in arena order (`snapshot.rs`): which
/// colliders carry the plugin's flags, and the user's flags (bits of `ActiveHooks`) each
/// replaced.
#[derive(Clone, Debug, PartialEq)]
#[cfg_attr(
    feature = "serde-serialize",
    derive(serde::Serialize, serde::Deserialize)
)]
pub(crate) struct SavedFlags {
    hooked: Vec<SavedHookedBody>,
    grounds: Vec<(ColliderHandle, u32)>,
    stamp: u64,
    #[cfg_attr(feature = "serde-serialize", serde(default))]
    since_needed: Option<u32>,
}

/// A hooked body: its flagged colliders with the user's flags, and its stamp.
type SavedHookedBody = (RigidBodyHandle, Vec<(ColliderHandle, u32)>, u64);

impl HookFlags {
    /// Where the flags are and whose they replaced.
    pub fn save(&self) -> SavedFlags {
        let mut hooked: Vec<_> = self
            .hooked
            .iter()
            .map(|(body, entry)| {
                let colliders = entry.colliders.iter().map(|(c, u)| (*c, u.bits()));
                (*body, colliders.collect(), entry.stamp)
            })
            .collect();
        hooked.sort_unstable_by_key(|(body, ..)| body.arena_order());
        SavedFlags {
            hooked,
            grounds: self.grounds.iter().map(|(c, u)| (*c, u.bits())).collect(),
            stamp: self.stamp,
            since_needed: self.since_needed,
        }
    }

    /// The record `saved` was taken from: the plugin's flags on a restored world's colliders
    /// are known as the plugin's again, and the user's handed back as before.
    pub fn from_saved(saved: &SavedFlags) -> Self {
        let user = ActiveHooks::from_bits_retain;
        let mut flags = Self {
            stamp: saved.stamp,
            since_needed: saved.since_needed,
            ..Self::default()
        };
        for (body, colliders, stamp) in &saved.hooked {
            let colliders = colliders.iter().map(|(c, u)| (*c, user(*u))).collect();
            let entry = HookedBody {
                colliders,
                stamp: *stamp,
            };
            flags.hooked.insert(*body, entry);
        }
        for (c, u) in &saved.grounds {
            flags.grounds.insert(*c, user(*u));
        }
        flags
    }
}

/// The user's flags back on a collider, if it still exists.
fn restore(colliders: &mut ColliderSet, c: ColliderHandle, user: ActiveHooks) {
    set_flags(colliders, c, user);
}

/// Sets a collider's hook flags where they differ (a mutable access queues the collider for
/// rapier's updates).
fn set_flags(colliders: &mut ColliderSet, c: ColliderHandle, flags: ActiveHooks) {
    if colliders
        .get(c)
        .is_some_and(|co| co.active_hooks() != flags)
    {
        if let Some(co) = colliders.get_mut(c) {
            co.set_active_hooks(flags);
        }
    }
}
