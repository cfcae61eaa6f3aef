//! Plan, for impacts between bodies: which pairs of opted-in balls may meet in the step, and
//! what each pair's role is.
//!
//! Contract: [`plan_pairs`] reads the bodies opted in to impacts between bodies
//! (`Registry::takes_pairs`) that are one centred ball each, finds the pairs whose spheres, swept
//! over the step, overlap (a BVH over the swept spheres: the cost grows with the pairs that can
//! meet, not with the square of the bodies), skips the pairs rapier would not solve or the user's
//! filter refuses, and gives every other pair a role: `Resting` (touching and slow, or pressed, as
//! `Policy::rests` decides for a ground: rapier's solver keeps it with zero restitution) or
//! `Impact` (it may meet in the step: out of rapier's solver, resolved by the reconstruct stage,
//! `pair_reconstruct.rs`); a resting pair side by side with a ball of an `Impact` pair joins it (a
//! chain, [`CHAIN_MAX_TILT_SIN`]). Its one write into rapier: a sleeping ball an `Impact` pair may
//! reach is woken, so that the step plans it as an awake body.

use super::convert::{to_f64, to_real, vec_from_na, vec_to_na};
use super::filter;
use super::ground_index::build_bvh;
use super::handles::{HandleMap, HandleSet, slot_of};
use super::hook_flags::HookFlags;
use super::observe::{Sets, neighbours, pressed_besides};
use super::policy::{CHAIN_MAX_TILT_SIN, Policy, Role};
use super::registry::Registry;
use super::resolve::PairKey;
use crate::motion::State;
use crate::rapier::math::Vector;
use crate::rapier::parry::bounding_volume::Aabb;
use crate::rapier::prelude::{
    ActiveHooks, ColliderHandle, ColliderSet, PhysicsHooks, RigidBodyHandle, RigidBodySet,
};
use nalgebra::Vector3;

/// A pair of balls with a role this step.
#[derive(Clone, Copy, Debug)]
pub(crate) struct PlannedPair {
    pub a: RigidBodyHandle,
    pub b: RigidBodyHandle,
    /// The pair's key ([`pair_key`] of the two ball colliders).
    pub key: PairKey,
    /// The two radii summed, skins included (m): the centres' distance at contact.
    pub reach: f64,
    /// Unit line of centres at the step's start, from `a` to `b`.
    pub normal: Vector3<f64>,
    pub role: Role,
}

/// The pairs of the step.
#[derive(Default)]
pub(crate) struct PairPlan {
    pub pairs: Vec<PlannedPair>,
    /// Each pair's role by [`pair_key`].
    pub roles: HandleMap<PairKey, Role>,
    /// The bodies of the `Impact` pairs: the reconstruct stage moves them together.
    pub members: HandleSet<RigidBodyHandle>,
}

/// The key of the pair of two body colliders, the same whichever comes first.
pub(crate) fn pair_key(c1: ColliderHandle, c2: ColliderHandle) -> PairKey {
    if (slot_of(c1), c1.into_raw_parts().1) <= (slot_of(c2), c2.into_raw_parts().1) {
        (c1, c2)
    } else {
        (c2, c1)
    }
}

/// A ball that takes part in impacts between bodies, as the plan sees it at the step start.
struct Ball {
    body: RigidBodyHandle,
    collider: ColliderHandle,
    com: Vector3<f64>,
    v: Vector3<f64>,
    /// Radius, skin included (m).
    radius: f64,
    asleep: bool,
    /// The hook flags the user set on its collider.
    user: ActiveHooks,
    /// It has a joint (only then can a joint disable its contacts).
    jointed: bool,
    /// The acceleration of its user force (m/s^2).
    force_accel: f64,
}

/// The step's pairs (see the module's contract). `prev` are last step's pair roles (a pair
/// rapier held at rest stays resting unless clearly hit, as for grounds).
#[allow(clippy::too_many_arguments)]
pub(crate) fn plan_pairs<H: PhysicsHooks>(
    registry: &Registry,
    flags: &HookFlags,
    user_hooks: &H,
    bodies: &mut RigidBodySet,
    colliders: &ColliderSet,
    sets: &Sets,
    prev: &HandleMap<PairKey, Role>,
    gravity: Vector3<f64>,
    dt: f64,
    policy: &Policy,
) -> PairPlan {
    let mut plan = PairPlan::default();
    if !registry.any_pairs() {
        return plan;
    }
    let balls: Vec<Ball> = bodies
        .iter()
        .filter(|(handle, rb)| registry.takes_pairs(*handle, rb))
        .filter_map(|(handle, rb)| {
            // One enabled, solid ball collider, centred on the centre of mass.
            let [collider] = rb.colliders() else {
                return None;
            };
            let co = colliders.get(*collider)?;
            let ball = co.shape().as_ball()?;
            let radius = to_f64(ball.radius);
            // In the body's frame, where both are exact.
            let centre = co
                .position_wrt_parent()
                .map_or(Vector3::zeros(), |pose| vec_to_na(pose.translation));
            let off_centre = (centre - vec_to_na(rb.local_center_of_mass())).norm();
            if !co.is_enabled() || co.is_sensor() || off_centre > 1e-9 * radius {
                return None;
            }
            let com = vec_to_na(rb.center_of_mass());
            Some(Ball {
                body: handle,
                collider: *collider,
                com,
                v: vec_to_na(rb.linvel()),
                radius: radius + to_f64(co.contact_skin()),
                asleep: rb.is_sleeping(),
                user: flags.recorded_user_flags(colliders, *collider),
                jointed: sets.impulse_joints.attached_joints(handle).next().is_some()
                    || sets.multibody_joints.rigid_body_link(handle).is_some(),
                force_accel: to_f64(rb.user_force().length()) / to_f64(rb.mass()),
            })
        })
        .collect();
    // Two sleeping balls cannot meet: with none awake, no pair.
    if balls.len() < 2 || balls.iter().all(|b| b.asleep) {
        return plan;
    }
    // Each ball's sphere swept over the step: its travel under gravity and any force is at
    // most |v| dt + |a| dt^2 (a generous bound for a user force too, checked per pair below).
    let margin = policy.resting_gap.max(policy.prediction);
    let swept =
        |b: &Ball| b.radius + b.v.norm() * dt + (gravity.norm() + b.force_accel) * dt * dt + margin;
    let leaves: Vec<(usize, Aabb)> = balls
        .iter()
        .enumerate()
        .map(|(i, b)| {
            let half = to_real(swept(b));
            (
                i,
                Aabb::from_half_extents(vec_from_na(&b.com), Vector::splat(half)),
            )
        })
        .collect();
    let tree = build_bvh(leaves.clone());
    let down = gravity.try_normalize(0.0).unwrap_or_else(Vector3::zeros);
    // The pair of balls `i < j` with its role, or `None` when rapier would not solve it, the
    // user's filter refuses it, or it cannot meet in the step.
    let evaluate = |i: usize, j: usize| -> Option<PlannedPair> {
        let (a, b) = (&balls[i], &balls[j]);
        let reach = a.radius + b.radius;
        let d = b.com - a.com;
        let len = d.norm();
        let gap = len - reach;
        // Beyond reach: their spheres' travel cannot close the gap in the step.
        let travel = swept(a) - a.radius + swept(b) - b.radius;
        if gap > travel {
            return None;
        }
        let (ca, cb) = (&colliders[a.collider], &colliders[b.collider]);
        let user = a.user | b.user;
        if !filter::rapier_solves(bodies, ca, cb)
            || a.jointed
                && b.jointed
                && filter::joint_disables_contacts(
                    sets.impulse_joints,
                    sets.multibody_joints,
                    a.body,
                    b.body,
                )
            || filter::user_refuses(
                user_hooks,
                user,
                bodies,
                colliders,
                (a.collider, b.collider),
            )
        {
            return None;
        }
        let key = pair_key(a.collider, b.collider);
        // Closing speed along the line of centres (a ball's spin does not move its surface
        // along the normal).
        let closing = if len > 0.0 {
            (a.v - b.v).dot(&(d / len))
        } else {
            0.0
        };
        let was_resting = prev.get(&key) == Some(&Role::Resting);
        // Pressed, as a ground pair is: a ball that touched something else after the last
        // step (a ball in a pile) is pushed by it, and rapier's solver holds the pile.
        // (Not by each other: their own contact does not press them together.)
        let pressed = || {
            pressed_besides(a.body, &bodies[a.body], b.collider, sets, registry)
                || pressed_besides(b.body, &bodies[b.body], a.collider, sets, registry)
        };
        // An impact: approaching faster than the resting speed, closing the gap within the
        // step (both balls fall alike; a user force adds its acceleration), and not resting
        // or pressed. Anything slower is rapier's with e = 0 (`Resting`), as a slow ground
        // contact is: a pile's neighbours, balls drifting together.
        let forces = a.force_accel + b.force_accel;
        let closes = gap <= closing * dt + 0.5 * forces * dt * dt + margin;
        let impact = closing > policy.resting_speed
            && closes
            && !policy.rests(gap, closing, was_resting, pressed);
        Some(PlannedPair {
            a: a.body,
            b: b.body,
            key,
            reach,
            normal: if len > 0.0 { d / len } else { Vector3::zeros() },
            role: if impact { Role::Impact } else { Role::Resting },
        })
    };
    let mut woken: Vec<RigidBodyHandle> = Vec::new();
    let join = |plan: &mut PairPlan, woken: &mut Vec<RigidBodyHandle>, body: RigidBodyHandle| {
        if plan.members.insert(body) && bodies[body].is_sleeping() {
            woken.push(body);
        }
    };
    let add = |plan: &mut PairPlan, woken: &mut Vec<RigidBodyHandle>, pair: PlannedPair| {
        if pair.role == Role::Impact {
            join(plan, woken, pair.a);
            join(plan, woken, pair.b);
        }
        plan.roles.insert(pair.key, pair.role);
        plan.pairs.push(pair);
    };
    // Every pair with an awake ball (two sleeping balls cannot meet, unless a chain reaches
    // them: below).
    for (i, aabb) in &leaves {
        for j in tree.intersect_aabb(aabb) {
            let j = j as usize;
            if j <= *i || balls[*i].asleep && balls[j].asleep {
                continue;
            }
            if let Some(pair) = evaluate(*i, j) {
                add(&mut plan, &mut woken, pair);
            }
        }
    }
    // Chains: a resting pair side by side with a ball of an impact joins it (the ball hit
    // passes the impact on inside the step: Newton's cradle, a row of balls on a table),
    // and so on along the row, sleeping balls included. A ball lying on another stays
    // rapier's, and so does a ball something lies on: a pile's layers are held by rapier's
    // solver.
    let mut loaded: HandleMap<RigidBodyHandle, bool> = HandleMap::default();
    // (Without gravity nothing lies on anything.)
    let mut is_loaded = |h: RigidBodyHandle| {
        down != Vector3::zeros()
            && *loaded
                .entry(h)
                .or_insert_with(|| neighbours(h, &bodies[h], sets, registry, &down).loaded)
    };
    let mut expanded: HandleSet<RigidBodyHandle> = HandleSet::default();
    // Built only for a chain: the balls by body, and the pairs of two sleeping balls seen.
    let index: HandleMap<RigidBodyHandle, usize> = if plan.members.is_empty() {
        HandleMap::default()
    } else {
        balls.iter().enumerate().map(|(i, b)| (b.body, i)).collect()
    };
    let mut sleeping_seen: Vec<(usize, usize)> = Vec::new();
    loop {
        // The pairs around each new member that the first pass left out (two sleeping balls).
        let fresh: Vec<RigidBodyHandle> = plan
            .members
            .iter()
            .filter(|h| !expanded.contains(*h))
            .copied()
            .collect();
        for h in fresh {
            expanded.insert(h);
            let m = index[&h];
            for j in tree.intersect_aabb(&leaves[m].1) {
                // The first pass took every pair with an awake ball.
                let (i, j) = (m.min(j as usize), m.max(j as usize));
                if i != j && balls[i].asleep && balls[j].asleep && !sleeping_seen.contains(&(i, j))
                {
                    sleeping_seen.push((i, j));
                    if let Some(pair) = evaluate(i, j) {
                        add(&mut plan, &mut woken, pair);
                    }
                }
            }
        }
        let mut grown = false;
        for k in 0..plan.pairs.len() {
            let pair = plan.pairs[k];
            let joins = pair.role == Role::Resting
                && (plan.members.contains(&pair.a) || plan.members.contains(&pair.b))
                && pair.normal.dot(&down).abs() <= CHAIN_MAX_TILT_SIN
                && !is_loaded(pair.a)
                && !is_loaded(pair.b);
            if joins {
                plan.pairs[k].role = Role::Impact;
                plan.roles.insert(pair.key, Role::Impact);
                join(&mut plan, &mut woken, pair.a);
                join(&mut plan, &mut woken, pair.b);
                grown = true;
            }
        }
        if !grown && plan.members.iter().all(|h| expanded.contains(h)) {
            break;
        }
    }
    for handle in woken {
        if let Some(rb) = bodies.get_mut(handle) {
            rb.wake_up(true);
        }
    }
    plan
}

/// `Step` mode: the impulses of the step's `Impact` pairs at the step's start, to the
/// velocities there (as for grounds, `ImpactTiming::StepStart`): every pair that closes
/// within the step and approaches faster than the resting speed gets the model's impulse,
/// in the plan's order, and again in turn while one approaches (a chain along a row), at
/// most `max_impacts` per ball. The pairs are then rapier's resting contacts for the step
/// (`Resting`, e = 0), so it never bounces them a second time. Returns the events.
#[allow(clippy::too_many_arguments)]
pub(crate) fn step_start_impulses(
    plan: &mut PairPlan,
    bodies: &mut RigidBodySet,
    colliders: &ColliderSet,
    law: crate::model::Law,
    max_impacts: usize,
    policy: &Policy,
    dt: f64,
) -> Vec<super::events::ImpactEvent> {
    use super::commit::write_state;
    use super::observe::rapier_state;
    use super::resolve::{ImpactInput, Inertia, PairSide, material, resolve_balls};
    let mut events = Vec::new();
    let impacts: Vec<usize> = (0..plan.pairs.len())
        .filter(|k| plan.pairs[*k].role == Role::Impact)
        .collect();
    let cap = max_impacts * plan.members.len().max(1);
    let margin = policy.resting_gap.max(policy.prediction);
    'passes: for _ in 0..cap {
        let mut any = false;
        for k in &impacts {
            let pair = plan.pairs[*k];
            let (ra, rb) = (&bodies[pair.a], &bodies[pair.b]);
            let (sa, sb) = (rapier_state(ra), rapier_state(rb));
            let d = sb.com - sa.com;
            let len = d.norm();
            if len == 0.0 {
                continue;
            }
            let closing = (sa.v - sb.v).dot(&(d / len));
            let gap = len - pair.reach;
            if closing <= policy.resting_speed || gap > closing * dt + margin {
                continue;
            }
            // The key orders the colliders by slot: match them to the bodies.
            let (ca, cb) = if ra.colliders().contains(&pair.key.0) {
                pair.key
            } else {
                (pair.key.1, pair.key.0)
            };
            let (ia, ib) = (Inertia::of(ra), Inertia::of(rb));
            let radius = |c: ColliderHandle| {
                colliders.get(c).and_then(|co| {
                    Some(to_f64(co.shape().as_ball()?.radius) + to_f64(co.contact_skin()))
                })
            };
            let (Some(rad_a), Some(rad_b)) = (radius(ca), radius(cb)) else {
                continue;
            };
            let input = ImpactInput {
                body: pair.a,
                inertia: &ia,
                law,
                material: material(&colliders[ca], &colliders[cb], None),
                resting_speed: policy.resting_speed,
                force_settle: false,
                timing: super::events::ImpactTiming::StepStart,
            };
            // At the contact: the states moved along the line of centres to touching.
            let shift = d / len * (gap.max(0.0) * 0.5);
            let side = |body, collider, inertia, state: State, radius, shift| PairSide {
                body,
                collider,
                inertia,
                state: State {
                    com: state.com + shift,
                    ..state
                },
                radius,
            };
            let Some((after_a, after_b, pair_events)) = resolve_balls(
                &input,
                &side(pair.a, ca, &ia, sa, rad_a, shift),
                &side(pair.b, cb, &ib, sb, rad_b, -shift),
                0.0,
            ) else {
                continue;
            };
            events.extend(pair_events);
            for (h, s, after) in [(pair.a, sa, after_a), (pair.b, sb, after_b)] {
                let rb = &mut bodies[h];
                let local_com = vec_to_na(rb.local_center_of_mass());
                // The velocities only: the pose stays rapier's.
                write_state(
                    rb,
                    &State {
                        v: after.v,
                        w: after.w,
                        ..s
                    },
                    &local_com,
                    true,
                );
            }
            any = true;
            if events.len() >= 2 * cap {
                break 'passes;
            }
        }
        if !any {
            break;
        }
    }
    for k in impacts {
        plan.pairs[k].role = Role::Resting;
        plan.roles.insert(plan.pairs[k].key, Role::Resting);
    }
    events
}
