//! `Step` mode's impulses between bodies: applied to the velocities at the step's start (as
//! for grounds, `ImpactTiming::StepStart`), after which the pairs are rapier's resting
//! contacts for the step.

use crate::model::Law;
use crate::motion::State;
use crate::plugin::bridge::convert::{to_f64, vec_to_na};
use crate::plugin::bridge::resolve::{
    BodyContactAt, ImpactInput, Inertia, PairSide, resolve_balls, resolve_bodies,
};
use crate::plugin::config::ImpactConfig;
use crate::plugin::events::{ImpactEvent, ImpactTiming};
use crate::plugin::policy::rests_at;
use crate::plugin::policy::{Policy, Role};
use crate::plugin::queries::body_contact::{body_contact, touch_point};
use crate::plugin::queries::observe::body_geom;
use crate::plugin::stages::commit::{Commit, Origin};
use crate::plugin::state::registry::Registry;
use crate::plugin::state::step::{PairPlan, PlannedPair};
use crate::rapier::prelude::{
    ColliderHandle, ColliderSet, RigidBody, RigidBodyHandle, RigidBodySet,
};
use nalgebra::Vector3;

/// What `Step` mode's impulses between bodies read besides the plan and the bodies: the
/// colliders, the model, the configuration's caps and tolerances, and the step.
pub(crate) struct StepStart<'a> {
    pub colliders: &'a ColliderSet,
    /// The materials' homes: the registry and the configuration.
    pub registry: &'a Registry,
    pub config: &'a ImpactConfig,
    pub law: Law,
    /// At most this many impulses per member (`ImpactConfig::max_impacts_per_step`).
    pub max_impacts: usize,
    /// The tolerance of a flat landing (`ImpactConfig::flat_tolerance`).
    pub flat_tolerance: f64,
    pub policy: &'a Policy,
    pub dt: f64,
}

/// A pair's impulse: both states after, and the two events.
type Resolved = Option<(State, State, [ImpactEvent; 2])>;

/// `Step` mode: the impulses of the step's `Impact` pairs at the step's start, to the velocities
/// there: every pair that closes within the step and approaches faster than the resting speed gets
/// the model's impulse, in the plan's order, and again in turn while one approaches (a chain along
/// a row), at most `max_impacts` passes per member and twice that many events. Writes the bodies'
/// velocities (their poses written back as read); the pairs are then rapier's resting contacts for
/// the step (`Resting`, e = 0), so it never bounces them a second time. Writes and reports through
/// `commit`.
pub(crate) fn step_start_impulses(
    plan: &mut PairPlan,
    bodies: &RigidBodySet,
    commit: &mut Commit,
    inputs: &StepStart,
) {
    let mut events = Vec::new();
    let impacts: Vec<usize> = (0..plan.pairs.len())
        .filter(|k| plan.pairs[*k].role == Role::Impact)
        .collect();
    let cap = inputs.max_impacts * plan.members.len().max(1);
    'passes: for _ in 0..cap {
        let mut any = false;
        for k in &impacts {
            let pair = plan.pairs[*k];
            // Each body as the pairs before wrote it.
            let (Some(na), Some(nb)) = (commit.body(bodies, pair.a), commit.body(bodies, pair.b))
            else {
                continue;
            };
            let (sa, sb) = (na.state(), nb.state());
            let states = (sa, sb);
            let resolved = if pair.balls {
                step_start_balls(&pair, states, (na.rb(), nb.rb()), inputs)
            } else {
                step_start_bodies(&pair, states, (na.rb(), nb.rb()), inputs)
            };
            let Some((after_a, after_b, pair_events)) = resolved else {
                continue;
            };
            events.extend(pair_events);
            write_velocities(
                commit,
                bodies,
                [(pair.a, sa, after_a), (pair.b, sb, after_b)],
            );
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
    commit.events(events);
}

/// Writes each body's velocities after a step-start impulse, with its pose as read (its
/// `f64` round trip, `Commit::state`).
fn write_velocities<const N: usize>(
    commit: &mut Commit,
    bodies: &RigidBodySet,
    written: [(RigidBodyHandle, State, State); N],
) {
    for (h, s, after) in written {
        let local_com = vec_to_na(bodies[h].local_center_of_mass());
        let s = State {
            v: after.v,
            w: after.w,
            ..s
        };
        commit.state(h, &s, &local_com, Origin::Correction);
    }
}

/// The impulse of a pair of centred balls: along their line of centres, the states moved
/// along it to touching, if they approach faster than the resting speed and close the gap
/// within the step. Reads only.
fn step_start_balls(
    pair: &PlannedPair,
    (sa, sb): (State, State),
    (ra, rb): (&RigidBody, &RigidBody),
    inputs: &StepStart,
) -> Resolved {
    let (colliders, policy, dt) = (inputs.colliders, inputs.policy, inputs.dt);
    let margin = policy.contact_margin();
    let d = sb.com - sa.com;
    let len = d.norm();
    if len == 0.0 {
        return None;
    }
    let closing = (sa.v - sb.v).dot(&(d / len));
    let gap = len - pair.reach;
    if rests_at(closing, policy.resting_speed) || gap > closing * dt + margin {
        return None;
    }
    // Moving straight relative to each other, balls whose line of relative motion passes
    // farther from the other's centre than the reach pass each other without touching.
    let dv = sb.v - sa.v;
    let miss = d - dv * (d.dot(&dv) / dv.norm_squared());
    if len > pair.reach && miss.norm() >= pair.reach {
        return None;
    }
    // The key orders the colliders by slot: match them to the bodies.
    let (ca, cb) = if ra.colliders().contains(&pair.key.0) {
        pair.key
    } else {
        (pair.key.1, pair.key.0)
    };
    let (ia, ib) = (Inertia::of(ra), Inertia::of(rb));
    let radius = |c: ColliderHandle| {
        colliders
            .get(c)
            .and_then(|co| Some(to_f64(co.shape().as_ball()?.radius) + to_f64(co.contact_skin())))
    };
    let (Some(rad_a), Some(rad_b)) = (radius(ca), radius(cb)) else {
        return None;
    };
    // At the contact: the states moved along the line of centres to touching.
    let shift = d / len * (gap.max(0.0) * 0.5);
    let moved = |s: State, by: Vector3<f64>| State {
        com: s.com + by,
        ..s
    };
    let side_a = PairSide::new(pair.a, ca, &ia, moved(sa, shift), rad_a);
    let side_b = PairSide::new(pair.b, cb, &ib, moved(sb, -shift), rad_b);
    let input = ImpactInput::between(
        &side_a,
        inputs.law,
        inputs
            .registry
            .pair_material_of(colliders, ca, cb, inputs.config),
        policy.resting_speed,
        ImpactTiming::StepStart,
    );
    resolve_balls(&input, &side_a, &side_b, 0.0)
}

/// The impulse of a pair of bodies not both centred balls: at their contact at the step's
/// start (parry's, with the flat-landing points of `touch_point`), if they approach faster
/// than the resting speed there and close the gap within the step. Reads only.
fn step_start_bodies(
    pair: &PlannedPair,
    (sa, sb): (State, State),
    (ra, rb): (&RigidBody, &RigidBody),
    inputs: &StepStart,
) -> Resolved {
    let (colliders, policy, dt) = (inputs.colliders, inputs.policy, inputs.dt);
    let (la, lb) = (
        vec_to_na(ra.local_center_of_mass()),
        vec_to_na(rb.local_center_of_mass()),
    );
    let (ga, gb) = (body_geom(ra, colliders, &la), body_geom(rb, colliders, &lb));
    let margin = policy.contact_margin();
    let turn = (sa.w.norm() * ga.radius + sb.w.norm() * gb.radius) * dt;
    let reach = (sa.v - sb.v).norm() * dt + turn + margin;
    let touch = body_contact(&ga, &sa, &gb, &sb, reach)?;
    let closing = -touch.rate;
    if rests_at(closing, policy.resting_speed) || touch.dist > closing * dt + turn + margin {
        return None;
    }
    let (ca, cb) = (
        ga.parts[touch.parts.0].handle,
        gb.parts[touch.parts.1].handle,
    );
    let (point, points) = touch_point(&ga, &sa, &gb, &sb, &touch, inputs.flat_tolerance);
    let (ia, ib) = (Inertia::of(ra), Inertia::of(rb));
    let (side_a, side_b) = (
        PairSide::new(pair.a, ca, &ia, sa, 0.0),
        PairSide::new(pair.b, cb, &ib, sb, 0.0),
    );
    let input = ImpactInput::between(
        &side_a,
        inputs.law,
        inputs
            .registry
            .pair_material_of(colliders, ca, cb, inputs.config),
        policy.resting_speed,
        ImpactTiming::StepStart,
    );
    resolve_bodies(
        &input,
        &side_a,
        &side_b,
        &BodyContactAt {
            normal: touch.normal,
            point,
            points,
        },
        0.0,
    )
}
