//! rapier's own pair filtering, asked of every pair the plugin could resolve: a pair that
//! rapier would not solve is never the plugin's.
//!
//! Contract: reads two colliders, their bodies and the joints; writes nothing; answers
//! whether rapier 0.36's narrow phase would give the pair rigid impulses, before any hook
//! (`src/geometry/narrow_phase/pair_update.rs` in rapier, whose CCD applies the same tests):
//! - both colliders enabled, neither a sensor, and their bodies enabled (rapier disables a
//!   disabled body's colliders at the start of its step);
//! - the active collision types of one of the two colliders accept the pair of body types;
//! - the collision groups accept each other;
//! - the solver groups accept each other (otherwise rapier computes contacts and events but
//!   applies no impulse);
//! - no joint between the two bodies disables their contacts ([`joint_disables_contacts`]).
//!
//! What these tests read of one collider is a value ([`FilterSide`]): a caller that meets one
//! collider in many pairs (the plan, a floor) reads it once.
//!
//! The user's filter (`PhysicsHooks::filter_contact_pair`) is asked separately
//! ([`user_refuses`]), where the colliders' hook flags ask for it, as rapier would.

use crate::plugin::hooks::flags::HookFlags;
use crate::plugin::queries::observe::Sets;
use crate::plugin::state::handles::PairKey;
use crate::rapier::prelude::{
    ActiveCollisionTypes, ActiveHooks, Collider, ColliderSet, ImpulseJointSet, InteractionGroups,
    MultibodyJointSet, PairFilterContext, PhysicsHooks, RigidBody, RigidBodyHandle, RigidBodySet,
    RigidBodyType, SolverFlags,
};

/// Would rapier solve the pair of colliders, before the hooks and the joints? (See the
/// module's contract.)
pub(crate) fn rapier_solves(bodies: &RigidBodySet, a: &Collider, b: &Collider) -> bool {
    if !(a.is_enabled() && b.is_enabled()) || a.is_sensor() || b.is_sensor() {
        return false;
    }
    sides_solve(&FilterSide::of(bodies, a), &FilterSide::of(bodies, b))
}

/// What rapier's filtering reads of one collider of a pair (see the module's contract): a
/// value, so that the side of a collider met by many pairs (a floor) is read once.
#[derive(Clone, Copy)]
pub(crate) struct FilterSide {
    /// Enabled and not a sensor.
    takes_part: bool,
    /// Its body's enabled flag and type (a parentless collider: enabled, fixed).
    body: (bool, RigidBodyType),
    types: ActiveCollisionTypes,
    collision_groups: InteractionGroups,
    solver_groups: InteractionGroups,
}

impl FilterSide {
    /// The side of `co`, its body looked up in `bodies`.
    #[inline]
    pub fn of(bodies: &RigidBodySet, co: &Collider) -> Self {
        Self::with_parent(co, co.parent().and_then(|p| bodies.get(p)))
    }

    /// The side of `co`, whose body is `parent` (`None`: parentless, or its body gone): for a
    /// caller that holds the body already, without looking it up again.
    #[inline]
    pub fn with_parent(co: &Collider, parent: Option<&RigidBody>) -> Self {
        Self {
            takes_part: co.is_enabled() && !co.is_sensor(),
            body: match parent {
                Some(rb) => (rb.is_enabled(), rb.body_type()),
                None => (true, RigidBodyType::Fixed),
            },
            types: co.active_collision_types(),
            collision_groups: co.collision_groups(),
            solver_groups: co.solver_groups(),
        }
    }
}

/// [`rapier_solves`] from the two colliders' sides.
#[inline]
pub(crate) fn sides_solve(a: &FilterSide, b: &FilterSide) -> bool {
    let ((enabled_a, type_a), (enabled_b, type_b)) = (a.body, b.body);
    a.takes_part
        && b.takes_part
        && enabled_a
        && enabled_b
        && (a.types.test(type_a, type_b) || b.types.test(type_a, type_b))
        && a.collision_groups.test(b.collision_groups)
        && a.solver_groups.test(b.solver_groups)
}

/// Does a joint between the two bodies disable their contacts (an impulse joint, or a link
/// of one multibody, as rapier tests them)?
pub(crate) fn joint_disables_contacts(
    impulse_joints: &ImpulseJointSet,
    multibody_joints: &MultibodyJointSet,
    a: RigidBodyHandle,
    b: RigidBodyHandle,
) -> bool {
    if impulse_joints
        .joints_between(a, b)
        .any(|(_, joint)| !joint.data.contacts_enabled)
    {
        return true;
    }
    let (Some(link_a), Some(link_b)) = (
        multibody_joints.rigid_body_link(a),
        multibody_joints.rigid_body_link(b),
    ) else {
        return false;
    };
    if link_a.multibody != link_b.multibody {
        return false;
    }
    multibody_joints
        .get_multibody(link_a.multibody)
        .is_some_and(|mb| !mb.self_contacts_enabled())
        || multibody_joints
            .joint_between(a, b)
            .is_some_and(|(_, _, link)| !link.joint.data.contacts_enabled)
}

/// Would rapier not solve the pair `key` of two bodies' colliders (`a` and `b` their bodies),
/// a joint between the bodies disable its contacts, or the user's filter refuse it (asked
/// where the user's flags recorded in `flags` ask for it)? Every test is symmetric in the
/// two.
pub(crate) fn pair_refused<H: PhysicsHooks + ?Sized>(
    (user_hooks, flags): (&H, &HookFlags),
    (bodies, colliders, sets): (&RigidBodySet, &ColliderSet, &Sets),
    key: PairKey,
    (a, b): (RigidBodyHandle, RigidBodyHandle),
) -> bool {
    let user = flags.recorded_pair_flags(colliders, key);
    !rapier_solves(bodies, &colliders[key.0], &colliders[key.1])
        || joint_disables_contacts(sets.impulse_joints, sets.multibody_joints, a, b)
        || user_refuses(user_hooks, user, bodies, colliders, key)
}

/// Would rapier not solve the pair `key` (the collider of the body `body`, a ground's
/// collider), a joint between the body and the ground's body disable its contacts, or the
/// user's filter refuse it (asked where the user's flags recorded in `flags` ask for it)? For
/// a pair the plan gave no role (the body was asleep, or the step sent it beyond its plan's
/// reach): the plugin resolves it only where rapier would solve it.
pub(crate) fn ground_pair_refused<H: PhysicsHooks + ?Sized>(
    (user_hooks, flags): (&H, &HookFlags),
    (bodies, colliders, sets): (&RigidBodySet, &ColliderSet, &Sets),
    body: RigidBodyHandle,
    key: PairKey,
) -> bool {
    let (Some(body_co), Some(ground_co)) = (colliders.get(key.0), colliders.get(key.1)) else {
        return true;
    };
    let user = flags.recorded_pair_flags(colliders, key);
    !rapier_solves(bodies, body_co, ground_co)
        || ground_co.parent().is_some_and(|ground_body| {
            joint_disables_contacts(
                sets.impulse_joints,
                sets.multibody_joints,
                body,
                ground_body,
            )
        })
        || user_refuses(user_hooks, user, bodies, colliders, key)
}

/// Does the user's filter refuse the pair `key` (body collider, ground collider)? Asked only
/// when the colliders' own hook flags (`user_flags`, those the user set) ask for it; a refusal
/// is `None`, or flags without rigid impulses.
pub(crate) fn user_refuses<H: PhysicsHooks + ?Sized>(
    user_hooks: &H,
    user_flags: ActiveHooks,
    bodies: &RigidBodySet,
    colliders: &ColliderSet,
    key: PairKey,
) -> bool {
    if !user_flags.contains(ActiveHooks::FILTER_CONTACT_PAIRS) {
        return false;
    }
    let context = PairFilterContext {
        bodies,
        colliders,
        collider1: key.0,
        collider2: key.1,
        rigid_body1: colliders.get(key.0).and_then(|c| c.parent()),
        rigid_body2: colliders.get(key.1).and_then(|c| c.parent()),
    };
    !user_hooks
        .filter_contact_pair(&context)
        .is_some_and(|f| f.contains(SolverFlags::COMPUTE_RIGID_IMPULSES))
}
