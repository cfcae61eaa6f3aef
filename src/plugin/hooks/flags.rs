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
//! recorded and handed back: the wrapped hook is called exactly when they ask for it. Flags
//! the user sets on a collider while it carries the plugin's are theirs from then on (told
//! from the plugin's by comparing with what the plugin wrote), whatever bits they hold, and
//! a ground's new flags reach the ground index, which knows what the plugin wrote
//! (`GroundIndex::noted_hooks`): its next pass reports them, and the ground is flagged again.

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
    /// The colliders it holds flagged: exactly those whose [`Carried::body`] it is.
    pub colliders: SmallList<ColliderHandle>,
    /// The step (`HookFlags::stamp`) that last needed the flags.
    stamp: u64,
}

/// A collider carrying the plugin's flags: the user's flags they replaced, and who holds
/// them there (the grounds' arrangement, a hooked body, or both: a body's collider marked
/// as ground).
#[derive(Clone, Copy, Debug)]
struct Carried {
    /// The flags the user set on the collider (what rapier would see without the plugin).
    user: ActiveHooks,
    /// Held as a ground.
    ground: bool,
    /// The hooked body that lists it, if any.
    body: Option<RigidBodyHandle>,
}

impl Carried {
    /// What the plugin last wrote on the collider: the user's flags and its own.
    fn written(&self) -> ActiveHooks {
        self.user | PLUGIN_HOOKS
    }
}

/// Who asks a collider to carry the plugin's flags.
#[derive(Clone, Copy, PartialEq)]
enum Holder {
    Ground,
    Body(RigidBodyHandle),
}

/// Where the plugin's hook flags are, and the user's flags they replaced.
///
/// Invariant: a collider carries flags written by the plugin exactly while `carried` holds
/// it, and then its flags are [`Carried::written`] unless the user set others since (found
/// by comparing with that value: theirs, then, and kept as the user's). A collider the user
/// sets to exactly that value is taken as unchanged.
#[derive(Default)]
pub(crate) struct HookFlags {
    /// Managed bodies whose colliders carry the plugin's hook flags.
    hooked: HandleMap<RigidBodyHandle, HookedBody>,
    /// Every collider carrying the plugin's flags.
    carried: SlotTable<ColliderHandle, Carried>,
    /// How many of `carried` are held as grounds.
    grounds: usize,
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
    /// How many slots the table of flagged colliders holds (its memory, for the tests).
    #[cfg(test)]
    pub fn slots_held(&self) -> usize {
        self.carried.slots_held()
    }

    /// The managed bodies whose colliders carry the plugin's flags.
    pub fn hooked(&self) -> &HandleMap<RigidBodyHandle, HookedBody> {
        &self.hooked
    }

    /// Puts the flags where this step needs them (see the module's documentation):
    /// `near` are the managed bodies that can reach a ground in the step, `pairs` a body of
    /// each of the step's hooked pairs between bodies (`PlannedPair::hooked`: flagged in either
    /// arrangement), `unmanaged` whether the world holds a dynamic, enabled body the plugin
    /// does not manage, `idle` whether no managed body is near a ground or asleep this step.
    /// `registry.flags_stale` is read here and cleared by the caller; the ground index is told
    /// every ground's flags written (`GroundIndex::noted_hooks`), so that its next pass finds
    /// whatever the user sets after this step.
    pub fn update(
        &mut self,
        registry: &mut Registry,
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
        if (off || registry.flags_stale) && self.grounds > 0 {
            let mut dropped = Vec::new();
            for (c, carried) in self.carried.iter() {
                if carried.ground && (off || !registry.grounds.contains_key(c)) {
                    dropped.push(*c);
                }
            }
            for c in dropped {
                self.release(colliders, registry, c, Holder::Ground);
            }
        }
        if !off {
            // Every ground when they were off or the grounds changed; else only those whose
            // flags the ground index's pass found changed this step (the user's doing: the
            // index knows the flags the plugin wrote).
            let changed = match registry.index.hooks_changed() {
                Some(changed) if were_on && !registry.flags_stale => changed.to_vec(),
                _ => registry.grounds.keys().copied().collect(),
            };
            for c in changed {
                self.hold(colliders, registry, c, Holder::Ground);
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
            self.hooked.entry(*handle).or_default().stamp = stamp;
            self.flag_body(*handle, rb, registry, colliders);
        }
        if self.hooked.is_empty() {
            return;
        }
        let mut gone = Vec::new();
        for (handle, entry) in self.hooked.iter_mut() {
            if entry.stamp == stamp {
                continue;
            }
            if unmanaged
                && bodies
                    .get(*handle)
                    .is_some_and(|rb| rb.is_sleeping() && registry.manages(*handle, rb))
            {
                entry.stamp = stamp;
                continue;
            }
            gone.push(*handle);
        }
        for handle in gone {
            if let Some(entry) = self.hooked.remove(&handle) {
                for c in entry.colliders.iter() {
                    self.release(colliders, registry, *c, Holder::Body(handle));
                }
            }
        }
    }

    /// Do grounds carry the plugin's flags this step (the first arrangement, not idle)?
    pub fn grounds_flagged(&self) -> bool {
        self.grounds_on
    }

    /// The hook flags the user set on a collider (those rapier would have seen without the
    /// plugin).
    #[inline]
    pub fn recorded_user_flags(&self, colliders: &ColliderSet, c: ColliderHandle) -> ActiveHooks {
        let Some(co) = colliders.get(c) else {
            return ActiveHooks::empty();
        };
        let flags = co.active_hooks();
        match self.carried.get(c) {
            Some(carried) if flags == carried.written() => carried.user,
            // Not flagged by the plugin, or the user has set new flags since.
            _ => flags,
        }
    }

    /// The hook flags the user set on either collider of the pair `key` (what rapier would
    /// have seen for the pair without the plugin).
    #[inline]
    pub fn recorded_pair_flags(&self, colliders: &ColliderSet, key: PairKey) -> ActiveHooks {
        self.recorded_user_flags(colliders, key.0) | self.recorded_user_flags(colliders, key.1)
    }

    /// Takes the plugin's hook flags off every collider: the user's flags back (where the
    /// user has not set others since).
    pub fn restore_all(&mut self, colliders: &mut ColliderSet) {
        for (c, carried) in self.carried.iter() {
            give_back(colliders, *c, carried);
        }
        *self = Self::default();
    }

    /// `holder` asks `c` to carry the plugin's flags: recorded with the user's flags (those
    /// found on it, unless they are what the plugin wrote) and flagged.
    fn hold(
        &mut self,
        colliders: &mut ColliderSet,
        registry: &mut Registry,
        c: ColliderHandle,
        holder: Holder,
    ) {
        // Read first: `ColliderSet::get_mut` queues the collider for rapier's broad and
        // narrow phase updates, which for every ground every step cost more than the rest of
        // the plugin on a floor of 4 096 tiles.
        let Some(flags) = colliders.get(c).map(|co| co.active_hooks()) else {
            return;
        };
        let mut carried = match self.carried.get(c) {
            // The user set new flags since the plugin wrote them: theirs now.
            Some(carried) if flags != carried.written() => Carried {
                user: flags,
                ..*carried
            },
            Some(carried) => *carried,
            None => Carried {
                user: flags,
                ground: false,
                body: None,
            },
        };
        match holder {
            Holder::Ground => {
                if !carried.ground {
                    self.grounds += 1;
                }
                carried.ground = true;
            }
            Holder::Body(body) => {
                // A collider moved to this body from another hooked body: that one no
                // longer lists it.
                if let Some(other) = carried.body.filter(|b| *b != body) {
                    if let Some(entry) = self.hooked.get_mut(&other) {
                        entry.colliders = entry
                            .colliders
                            .iter()
                            .copied()
                            .filter(|h| *h != c)
                            .collect();
                    }
                }
                carried.body = Some(body);
            }
        }
        self.carried.insert(c, carried);
        let written = carried.written();
        if flags != written {
            set_flags(colliders, c, written);
        }
        if carried.ground {
            registry.index.noted_hooks(c, written);
        }
    }

    /// `holder` no longer asks `c` for the plugin's flags: once nothing does, the user's
    /// flags are given back.
    fn release(
        &mut self,
        colliders: &mut ColliderSet,
        registry: &mut Registry,
        c: ColliderHandle,
        holder: Holder,
    ) {
        let Some(mut carried) = self.carried.get(c).copied() else {
            return;
        };
        match holder {
            Holder::Ground if carried.ground => {
                carried.ground = false;
                self.grounds -= 1;
            }
            Holder::Body(body) if carried.body == Some(body) => carried.body = None,
            // Not held so (a collider another body has taken over).
            _ => return,
        }
        if carried.ground || carried.body.is_some() {
            self.carried.insert(c, carried);
            return;
        }
        self.carried.remove(c);
        if let Some(flags) = give_back(colliders, c, &carried) {
            registry.index.noted_hooks(c, flags);
        }
    }

    /// Flags the body's colliders (new ones included) and gives back those detached from it;
    /// its entry in `hooked` is the caller's to make.
    fn flag_body(
        &mut self,
        handle: RigidBodyHandle,
        rb: &RigidBody,
        registry: &mut Registry,
        colliders: &mut ColliderSet,
    ) {
        let attached = rb.colliders();
        let Some(entry) = self.hooked.get_mut(&handle) else {
            return;
        };
        let listed = &entry.colliders;
        let same =
            listed.len() == attached.len() && listed.iter().zip(attached).all(|(h, a)| h == a);
        if !same {
            let now = attached.iter().copied();
            let now = now.filter(|c| colliders.get(*c).is_some()).collect();
            let old = std::mem::replace(&mut entry.colliders, now);
            for c in old.iter().filter(|c| !attached.contains(c)) {
                self.release(colliders, registry, *c, Holder::Body(handle));
            }
        }
        for c in attached {
            self.hold(colliders, registry, *c, Holder::Body(handle));
        }
    }
}

/// The user's flags back on a collider that still carries what the plugin wrote (others are
/// the user's, set since, and stay); the flags it is left with, if it still exists.
fn give_back(
    colliders: &mut ColliderSet,
    c: ColliderHandle,
    carried: &Carried,
) -> Option<ActiveHooks> {
    let flags = colliders.get(c)?.active_hooks();
    if flags == carried.written() {
        set_flags(colliders, c, carried.user);
        Some(carried.user)
    } else {
        Some(flags)
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

#[cfg(test)]
impl SavedFlags {
    /// With the plugin's flags also on ground collider `c` (a hand-edited snapshot's).
    pub fn with_ground(mut self, c: crate::rapier::prelude::ColliderHandle) -> Self {
        self.grounds.push((c, 0));
        self
    }

    /// With `body` hooked, the plugin's flags on collider `c`, stamped as the next step will
    /// stamp the bodies it flags (a hand-edited snapshot's).
    pub fn with_hooked_next(
        mut self,
        body: RigidBodyHandle,
        c: crate::rapier::prelude::ColliderHandle,
    ) -> Self {
        self.hooked.push((body, vec![(c, 0)], self.stamp + 1));
        self
    }
}

impl HookFlags {
    /// Where the flags are and whose they replaced.
    pub fn save(&self) -> SavedFlags {
        let user = |c: &ColliderHandle| self.carried.get(*c).map_or(0, |k| k.user.bits());
        let mut hooked: Vec<_> = self
            .hooked
            .iter()
            .map(|(body, entry)| {
                let colliders = entry.colliders.iter().map(|c| (*c, user(c)));
                (*body, colliders.collect(), entry.stamp)
            })
            .collect();
        hooked.sort_unstable_by_key(|(body, ..)| body.arena_order());
        let grounds = self.carried.iter().filter(|(_, k)| k.ground);
        SavedFlags {
            hooked,
            grounds: grounds.map(|(c, k)| (*c, k.user.bits())).collect(),
            stamp: self.stamp,
            since_needed: self.since_needed,
        }
    }

    /// The record `saved` was taken from: the plugin's flags on a restored world's colliders
    /// are known as the plugin's again, and the user's handed back as before. (A collider
    /// listed twice, which only an earlier version could save, keeps its first record.)
    pub fn from_saved(saved: &SavedFlags) -> Self {
        let user = ActiveHooks::from_bits_retain;
        let mut flags = Self {
            stamp: saved.stamp,
            since_needed: saved.since_needed,
            ..Self::default()
        };
        for (c, u) in &saved.grounds {
            let carried = Carried {
                user: user(*u),
                ground: true,
                body: None,
            };
            if flags.carried.insert_restored(*c, carried) {
                flags.grounds += 1;
            }
        }
        for (body, colliders, stamp) in &saved.hooked {
            let mut entry = HookedBody {
                colliders: SmallList::default(),
                stamp: *stamp,
            };
            for (c, u) in colliders {
                let carried = match flags.carried.get(*c) {
                    Some(k) if k.body.is_some() => continue,
                    Some(k) => Carried {
                        body: Some(*body),
                        ..*k
                    },
                    None => Carried {
                        user: user(*u),
                        ground: false,
                        body: Some(*body),
                    },
                };
                flags.carried.insert_restored(*c, carried);
                entry.colliders.push(*c);
            }
            flags.hooked.insert(*body, entry);
        }
        flags
    }
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
