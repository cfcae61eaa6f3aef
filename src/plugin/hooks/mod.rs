//! The plugin as rapier's `PhysicsHooks`.
//!
//! Called by rapier's narrow phase (every step, for every pair with a hook flag: the plugin sets
//! `FILTER_CONTACT_PAIRS | MODIFY_SOLVER_CONTACTS` on the grounds, or on the colliders of the
//! managed bodies near a ground, see `hooks/flags.rs`) and by its CCD. It reads the roles
//! [`ImpactPlugin::before_step`] assigned:
//! - a managed dynamic body against a ground with role `Impact`: `filter_contact_pair`
//!   returns `Some(SolverFlags::empty())`. rapier still computes the manifold and reports its
//!   collision events, but neither its solver nor its restitution pass sees the pair;
//! - role `Rolling` (a ball sliding on a level fixed ground): the same; the plugin moves the
//!   ball in closed form after the step;
//! - role `Resting` (or a pair the plugin did not see coming): rapier's solver keeps it (the
//!   user's filter still decides, when the colliders ask for it), and
//!   `modify_solver_contacts` hands it to the user's hook first (a conveyor ground, a one-way
//!   platform), then sets its restitution to 0 (and the ground's friction override, if any)
//!   where it has solver contacts: the plugin owns every bounce off a ground. A ball the
//!   closed form holds at rest on a slope (`StepData::holds`) also has its contact points
//!   moved to where the ground's normal force acts, so that rapier's solver holds it still
//!   and rapier sleeps it;
//! - a pair of two opted-in balls (`pair_plan.rs`): `Impact` out of rapier's solver as above
//!   (the reconstruct stage moves the two together), `Resting` in it with zero restitution (only
//!   the resting pairs rapier would bounce above the resting gap are hooked: `pair_plan.rs`);
//! - role `Filtered` (rapier would not solve the pair, or the user's filter refused it in
//!   `before_step`): the user's hook and rapier have it, unchanged, and the plugin resolves
//!   no impact for it;
//! - every other pair goes to the user's hook unchanged, exactly when the colliders' own
//!   hook flags (those the user set, before the plugin added its own) ask for it; otherwise
//!   rapier's default applies.

pub(crate) mod flags;
pub(crate) mod lookup;

use crate::plugin::impact_plugin::ImpactPlugin;
use crate::plugin::policy::Role;
use crate::plugin::stages::pair_plan::pair_key;
use crate::plugin::state::handles::{PairKey, slot_of};
use crate::rapier::prelude::{
    ActiveHooks, ColliderHandle, ColliderSet, ContactModificationContext, PairFilterContext,
    PhysicsHooks, RigidBodySet, SolverFlags,
};
use lookup::Looked;
use nalgebra::Vector3;

impl<H: PhysicsHooks> PhysicsHooks for ImpactPlugin<H> {
    fn filter_contact_pair(&self, context: &PairFilterContext) -> Option<SolverFlags> {
        let (bodies, colliders) = (context.bodies, context.colliders);
        let managed = self.pair_in_step(bodies, colliders, context.collider1, context.collider2);
        match managed {
            Some((_, Role::Impact | Role::Rolling, _)) => Some(SolverFlags::empty()),
            // Resting (in rapier's solver), refused by the user, or not managed: the user's
            // filter when the colliders ask for it, as rapier would.
            _ => {
                let flags = managed.map(|(_, _, user)| user).unwrap_or_else(|| {
                    self.pair_user_flags(colliders, context.collider1, context.collider2)
                });
                if flags.contains(ActiveHooks::FILTER_CONTACT_PAIRS) {
                    self.user_hooks.filter_contact_pair(context)
                } else {
                    Some(SolverFlags::default())
                }
            }
        }
    }

    fn filter_intersection_pair(&self, context: &PairFilterContext) -> bool {
        // The plugin never sets FILTER_INTERSECTION_PAIR: rapier only calls this for the
        // user's flags.
        self.user_hooks.filter_intersection_pair(context)
    }

    fn modify_solver_contacts(&self, context: &mut ContactModificationContext) {
        let (bodies, colliders) = (context.bodies, context.colliders);
        let (c1, c2) = (context.collider1, context.collider2);
        // A manifold without solver contacts (rapier asks for every manifold of a hooked pair,
        // near or not): no role changes anything the solver reads, and the manifold's material
        // is made again at rapier's next update of the pair. Only the user's own modification
        // can apply, and only if one of the colliders asks for it.
        let no_contacts = context
            .rigid()
            .is_some_and(|m| m.solver_contacts.is_empty());
        if no_contacts
            && !self
                .pair_user_flags(colliders, c1, c2)
                .contains(ActiveHooks::MODIFY_SOLVER_CONTACTS)
        {
            return;
        }
        let managed = self.pair_in_step(bodies, colliders, c1, c2);
        match managed {
            Some((_, Role::Impact | Role::Rolling, _)) => {}
            Some((key, Role::Resting, flags)) => {
                // The user's contact modification first (a conveyor ground, a one-way
                // platform), then the plugin's: no bounce by rapier.
                if flags.contains(ActiveHooks::MODIFY_SOLVER_CONTACTS) {
                    self.user_hooks.modify_solver_contacts(context);
                }
                let over = self.registry.entry(key.1).and_then(|g| g.material);
                // Asked of every resting pair every step: nothing more while none is held.
                let centre = || {
                    let ball = colliders.get(key.0).and_then(|co| co.parent())?;
                    Some(bodies.get(ball)?.center_of_mass())
                };
                let hold = (!self.step.holds.is_empty())
                    .then(|| Some((*self.step.holds.get(&key)?, centre()?)))
                    .flatten();
                let slab = self.slab_contact(colliders, (c1, c2), key, context.rigid());
                if let Some(rigid) = context.rigid_mut() {
                    *rigid.restitution = 0.0;
                    if let Some(m) = over {
                        *rigid.friction = crate::plugin::bridge::convert::to_real(m.friction);
                    }
                    if let Some(contact) = slab {
                        contact.write(rigid);
                    }
                    // A ball held at rest on a slope: the normal force acts `h tan(theta)`
                    // downhill of the contact point, as the rolling resistance's contact patch
                    // presses it (`Rolling::holding_tilt`), `h` the friction's lever: rapier's
                    // solver applies a contact at the midpoint of its two anchors (the gap
                    // closed), so `h` is less than the radius by half the penetration. Both
                    // anchors move alike: the gap along the normal is unchanged.
                    if let Some((tilt, centre)) = hold {
                        let normal = *rigid.normal;
                        for contact in rigid.solver_contacts.iter_mut() {
                            let closed = contact.anchor1
                                + normal
                                    * ((contact.anchor2 - contact.anchor1).dot(normal)
                                        - contact.dist);
                            let point = (closed + contact.anchor2) * 0.5;
                            let lever = crate::plugin::bridge::convert::to_f64(
                                (centre - point).dot(normal).abs(),
                            );
                            let offset =
                                crate::plugin::bridge::convert::vec_from_na(&(tilt * lever));
                            contact.anchor1 += offset;
                            contact.anchor2 += offset;
                        }
                    }
                }
            }
            Some((_, Role::Rapier | Role::Filtered, flags)) => {
                if flags.contains(ActiveHooks::MODIFY_SOLVER_CONTACTS) {
                    self.user_hooks.modify_solver_contacts(context);
                }
            }
            None => {
                let flags = self.pair_user_flags(colliders, c1, c2);
                if flags.contains(ActiveHooks::MODIFY_SOLVER_CONTACTS) {
                    self.user_hooks.modify_solver_contacts(context);
                }
            }
        }
    }
}

/// The step's answers to rapier's hook calls: which pairs are the plugin's, with what role.
impl<H> ImpactPlugin<H> {
    /// The role of a managed pair in the current step (`Resting` when unknown: a pair the
    /// plugin did not see coming, e.g. of a body woken during the step, is left to rapier's
    /// solver without bounce).
    fn role(&self, key: &PairKey) -> Role {
        if self.lookup.roles_built {
            return self.lookup.role(key);
        }
        self.step.roles.get(key).copied().unwrap_or(Role::Resting)
    }

    /// The pair as the plugin sees it in rapier's step: `Some((key, role, user flags))` for a
    /// managed body-ground pair, `None` for another pair. The step's table answers the pairs
    /// `before_step` gave a role (most of them) without looking at the sets; the others are
    /// checked (a pair the plugin did not see coming is `Resting`).
    #[inline(always)]
    fn pair_in_step(
        &self,
        bodies: &RigidBodySet,
        colliders: &ColliderSet,
        c1: ColliderHandle,
        c2: ColliderHandle,
    ) -> Option<(PairKey, Role, ActiveHooks)> {
        // The table holds the registry as `before_step` saw it; a ground marked or unmarked
        // since is checked against the sets.
        // A pair of opted-in balls.
        if !self.step.pairs.roles.is_empty() && self.lookup.may_pair_balls(c1, c2) {
            let key = pair_key(c1, c2);
            if let Some(role) = self.step.pairs.roles.get(&key) {
                let user = self.pair_user_flags(colliders, c1, c2);
                return Some((key, *role, user));
            }
        }
        let current = self.registry.index.entry(c1).is_ok();
        // A slab's tile: the plan gave the pair's role to the slab's stand-in (a ball meets
        // the slab), unless the body met the tiles one by one.
        let index = &self.registry.index;
        let looked = current
            .then(|| self.lookup.pair(c1, c2, |c| index.stand_in(c)))
            .flatten();
        match looked {
            Some(Looked::Pair(key, role, user)) => {
                // A body collider that is itself marked as ground (its body turned dynamic
                // after it was marked) makes the pair two grounds: not the plugin's, as
                // `managed_pair` says.
                if self.registry.entry(key.0).is_none() {
                    return Some((key, role, user));
                }
                return None;
            }
            // A body with no ground in reach, or none but its pairs in the table, against a
            // managed ground (not on a dynamic body, as `managed_pair` asks): `Resting`, as
            // every pair the plugin gave no role.
            Some(Looked::Far(key, user)) => {
                let ground_managed = self.registry.entry(key.1).is_some()
                    && self.registry.entry(key.0).is_none()
                    && colliders.get(key.1).is_some_and(|co| {
                        co.parent()
                            .is_none_or(|p| bodies.get(p).is_some_and(|rb| !rb.is_dynamic()))
                    });
                return ground_managed
                    .then(|| (key, Role::Resting, user | self.user_flags(colliders, key.1)));
            }
            None => {}
        }
        // Checked against the sets (a ground marked or unmarked since `before_step`): a tile
        // is still named as the step's roles name it.
        self.managed_pair(bodies, colliders, c1, c2).map(|key| {
            let key = self.lookup.keyed(key, |c| index.stand_in(c));
            (
                key,
                self.role(&key),
                self.pair_user_flags(colliders, c1, c2),
            )
        })
    }

    /// The hook flags the user asked for on either collider of a pair.
    fn pair_user_flags(
        &self,
        colliders: &ColliderSet,
        c1: ColliderHandle,
        c2: ColliderHandle,
    ) -> ActiveHooks {
        self.user_flags(colliders, c1) | self.user_flags(colliders, c2)
    }

    /// The hook flags the user asked for on a collider.
    fn user_flags(&self, colliders: &ColliderSet, c: ColliderHandle) -> ActiveHooks {
        self.step_user_flags(c)
            .unwrap_or_else(|| self.flags.recorded_user_flags(colliders, c))
    }

    /// `Some((body collider, ground collider))` when the pair is a managed body against a
    /// ground.
    fn managed_pair(
        &self,
        bodies: &RigidBodySet,
        colliders: &ColliderSet,
        c1: ColliderHandle,
        c2: ColliderHandle,
    ) -> Option<PairKey> {
        let (body, ground) = match (
            self.registry.entry(c1).is_some(),
            self.registry.entry(c2).is_some(),
        ) {
            (true, false) => (c2, c1),
            (false, true) => (c1, c2),
            _ => return None,
        };
        if let Some(parent) = colliders.get(ground)?.parent() {
            if bodies.get(parent).is_none_or(|rb| rb.is_dynamic()) {
                return None;
            }
        }
        let parent = colliders.get(body)?.parent()?;
        let rb = bodies.get(parent)?;
        self.registry.manages(parent, rb).then_some((body, ground))
    }

    /// Inside rapier's step: the user's flags of a collider the plugin flagged, `None` for
    /// another collider (its flags are the user's) or outside the step's tables.
    fn step_user_flags(&self, c: ColliderHandle) -> Option<ActiveHooks> {
        match self.lookup.user_flags.get(slot_of(c)) {
            Some(Some((h, user))) if *h == c => Some(*user),
            _ => None,
        }
    }
}

/// A ball's resting contact with a slab's tile, as its contact with the slab: the slab's face
/// normal, the ball's point nearest the face and that point's foot on the face.
struct SlabContact {
    /// The face's outward normal, from the first collider to the second as rapier's is.
    normal: Vector3<f64>,
    /// The contact's points on the first and the second collider.
    points: (Vector3<f64>, Vector3<f64>),
    /// Their separation along `normal`, the contact skins deducted.
    dist: f64,
}

impl SlabContact {
    /// Writes it over every solver contact of `rigid`.
    fn write(&self, rigid: &mut crate::rapier::prelude::ModifiableManifold) {
        use crate::plugin::bridge::convert::{to_real, vec_from_na};
        *rigid.normal = vec_from_na(&self.normal);
        for c in rigid.solver_contacts.iter_mut() {
            c.anchor1 = vec_from_na(&self.points.0);
            c.anchor2 = vec_from_na(&self.points.1);
            c.dist = to_real(self.dist);
        }
    }
}

impl<H> ImpactPlugin<H> {
    /// The resting contact of the pair `key` (body collider, ground) between `c1` and `c2`,
    /// where the ground is a slab's tile, the body collider a ball, and the contact's points
    /// on the tile and the ball's foot lie inside one face of the slab: as with the slab. Flush
    /// tiles make one flat face, but rapier's contact with the next tile's edge, under a ball
    /// on a seam, is tilted and beside the ball's foot, and rolls it off the seam. Not for a
    /// body that meets the tiles one by one (a filter may refuse the next tile: its edge is
    /// then a real one).
    fn slab_contact(
        &self,
        colliders: &ColliderSet,
        (c1, c2): (ColliderHandle, ColliderHandle),
        key: PairKey,
        rigid: Option<&crate::rapier::prelude::ModifiableManifold>,
    ) -> Option<SlabContact> {
        use crate::plugin::bridge::convert::{to_f64, vec_to_na};
        let index = &self.registry.index;
        if !index.has_slabs() || self.lookup.by_tile(key.0) {
            return None;
        }
        let tile_first = c1 != key.0;
        let tile = if tile_first { c1 } else { c2 };
        let ball = colliders.get(key.0)?;
        let radius = to_f64(ball.shape().as_ball()?.radius);
        let on_tile = rigid?
            .solver_contacts
            .iter()
            .map(|c| vec_to_na(if tile_first { c.anchor1 } else { c.anchor2 }));
        let slab = index.slab_of(tile)?;
        let (n, offset) = slab.face_plane_of(on_tile)?;
        let under = vec_to_na(ball.position().translation) - n * radius;
        let foot = under - n * (n.dot(&under) - offset);
        if slab.face_plane_at(&foot).map(|(m, _)| m) != Some(n) {
            return None;
        }
        let skins = to_f64(ball.contact_skin()) + to_f64(colliders.get(tile)?.contact_skin());
        let dist = n.dot(&(under - foot)) - skins;
        Some(if tile_first {
            SlabContact {
                normal: n,
                points: (foot, under),
                dist,
            }
        } else {
            SlabContact {
                normal: -n,
                points: (under, foot),
                dist,
            }
        })
    }
}
