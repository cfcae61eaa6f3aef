//! Plan, for impacts between bodies: which pairs of opted-in bodies may meet in the step, and
//! what each pair's role is.
//!
//! Contract: [`plan_pairs`] reads the bodies opted in to impacts between bodies
//! (`Registry::takes_pairs`) that have one enabled, solid collider each (a ball centred on the
//! centre of mass, met in closed form; or any other convex shape, a die or a pin, met through
//! parry's contact, `body_contact.rs`; for those, a pair whose body rapier's solver held
//! against anything else last step, or that lies within the resting gap of a ground by
//! parry's distance, is rapier's), finds the pairs of a body faster than half the resting speed
//! whose bounding spheres, swept over the step, overlap (the swept spheres' boxes in rows of a
//! grid, [`PairIndex`]: the cost grows with the bodies and the pairs that can meet, not with the
//! square of the bodies), skips the pairs it would change (an impact, a zeroed restitution, a
//! chain's) that rapier would not solve or the user's filter refuses (a resting pair left as
//! it is, rapier's whatever they say, is not asked), and gives every other pair a role:
//! `Resting` (pressed or held, as `Policy::rests` decides for a ground: rapier's solver keeps
//! it, with zero restitution where rapier would bounce it above the resting gap; a pair slower
//! than the resting speed is rapier's as it is, and not planned unless a chain reaches it) or
//! `Impact` (it may meet in the step: out of rapier's solver, resolved by the reconstruct
//! stage, `pair_reconstruct.rs`); a resting pair side by side with a body of an `Impact` pair
//! that can pass it on joins it, touching at the step's start (a chain,
//! [`CHAIN_MAX_TILT_SIN`](crate::plugin::policy::CHAIN_MAX_TILT_SIN); two balls closing slower
//! than the pressed speed start none). A pair's closing speed is along the line of centres for
//! two balls, and for other shapes the contact points' along parry's normal plus what the
//! bodies' turning can add (angular speed times bounding radius); in `TimeOfImpact` and
//! `Exact` modes also after a member's bounce off a ground it flies onto in the step, and
//! there a pair with a body of a stack or a pile (pushed by rapier's solver last step against
//! a third body along gravity's line) is rapier's, and a ball lying on a ball that lies on a
//! ground rests as a pair held last step does (`decide.rs`). It writes nothing into
//! rapier: it returns the sleeping bodies an `Impact` pair may reach, whose wake-ups the caller
//! records through the commit, so that the step plans them as awake bodies.
//!
//! Its parts, in the order they run: gather the members (`gather.rs`), find the pairs that
//! may meet (`index.rs`), decide each pair's role (`decide.rs`), expand the chains of
//! carriers (`chain.rs`), then list the sleeping members to wake. `Step` mode's impulses at
//! the step's start are `step_start.rs`.

mod chain;
mod decide;
mod gather;
mod index;
mod step_start;

pub(crate) use index::PairIndex;
pub(crate) use step_start::{StepStart, step_start_impulses};

use crate::plugin::hooks::flags::HookFlags;
use crate::plugin::policy::{Policy, Role};
use crate::plugin::queries::ground_index::GroundMotion;
use crate::plugin::queries::observe::Sets;
use crate::plugin::state::handles::PairKey;
use crate::plugin::state::handles::{HandleMap, slot_of};
use crate::plugin::state::registry::Registry;
use crate::plugin::state::step::PairPlan;
use crate::rapier::prelude::{
    ColliderHandle, ColliderSet, PhysicsHooks, RigidBodyHandle, RigidBodySet,
};
use chain::expand_chains;
use decide::{Judge, Planned};
use gather::Members;
use index::{Around, Candidates, candidates};
use nalgebra::Vector3;

/// The key of the pair of two body colliders, the same whichever comes first.
pub(crate) fn pair_key(c1: ColliderHandle, c2: ColliderHandle) -> PairKey {
    if (slot_of(c1), c1.into_raw_parts().1) <= (slot_of(c2), c2.into_raw_parts().1) {
        (c1, c2)
    } else {
        (c2, c1)
    }
}

/// What the plan reads besides the pair index and the bodies: the registry and hook state,
/// the user's hooks, the colliders and rapier's contact and joint sets, last step's pair roles,
/// the grounds, and the step's gravity, length and policy.
pub(crate) struct PairInputs<'a, H> {
    pub registry: &'a Registry,
    pub flags: &'a HookFlags,
    pub user_hooks: &'a H,
    pub colliders: &'a ColliderSet,
    pub sets: &'a Sets<'a>,
    /// Last step's pair roles: a pair rapier held at rest stays resting unless clearly hit,
    /// as for grounds.
    pub prev: &'a HandleMap<PairKey, Role>,
    pub grounds: &'a [GroundMotion],
    pub gravity: Vector3<f64>,
    pub dt: f64,
    pub policy: &'a Policy,
    /// Impacts are resolved in the step (`TimeOfImpact`, `Exact`): a cluster moves its bodies
    /// through their ground impacts, so a pair may be planned for a meeting after one.
    pub in_step: bool,
}

/// The step's pairs (see the module's contract), and the sleeping members of their `Impact`
/// pairs, which the step must wake to plan them as awake bodies. Replaces the pair index's
/// boxes with the step's (kept for the clusters after rapier's step); writes nothing into
/// rapier.
pub(crate) fn plan_pairs<H: PhysicsHooks>(
    index: &mut PairIndex,
    bodies: &RigidBodySet,
    inputs: &PairInputs<H>,
) -> (PairPlan, Vec<RigidBodyHandle>) {
    let mut refused = Vec::new();
    let Some(members) = Members::gather(bodies, inputs, &mut refused) else {
        let plan = PairPlan {
            refused,
            ..PairPlan::default()
        };
        return (plan, Vec::new());
    };
    index.update(&members.leaves);
    let found = candidates(index, &members);
    let Planned { mut plan, woken } = plan_members(index, bodies, inputs, &members, found);
    index.clear_list(&members.leaves);
    plan.refused = refused;
    (plan, woken)
}

/// The plan of the candidate pairs and of the chains they start, with the sleeping bodies
/// to wake. Reads the index (its list the members'), the bodies and the inputs; writes
/// nothing. The candidates are decided in their order, two sleeping bodies skipped (they
/// cannot meet unless a chain reaches them).
fn plan_members<H: PhysicsHooks>(
    index: &PairIndex,
    bodies: &RigidBodySet,
    inputs: &PairInputs<H>,
    members: &Members,
    found: Candidates,
) -> Planned {
    let judge = Judge::new(inputs, bodies, members, index);
    let mut planned = Planned::default();
    // Sized for last step's count, which the step's is most often close to, rather than
    // grown (and copied) pair by pair. (Not the roles' map: the order it is walked in, read
    // by the next step's install, depends on its capacity.)
    planned.plan.pairs.reserve(inputs.prev.len());
    for (i, j) in found.to_evaluate(members) {
        if members.balls[i].asleep && members.balls[j].asleep {
            continue;
        }
        if let Some(pair) = judge.evaluate(i, j, false) {
            planned.add(bodies, pair);
        }
    }
    let traversed = found.traversed.then_some(found.pairs);
    expand_chains(&judge, &mut planned, &Around::new(index, traversed));
    planned
}
