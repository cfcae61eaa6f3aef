//! Plan, for impacts between bodies: which pairs of opted-in bodies may meet in the step, and
//! what each pair's role is.
//!
//! Contract: [`plan_pairs`] reads the bodies opted in to impacts between bodies
//! (`Registry::takes_pairs`) that have one enabled, solid collider each (a ball centred on the
//! centre of mass, met in closed form; or any other convex shape, a die or a pin, met through
//! parry's contact, `body_contact.rs`; for those, a pair whose body rapier's solver held
//! against anything else last step, or that lies within the resting gap of a ground by
//! parry's distance, is rapier's), finds the pairs of a body faster than half the resting speed
//! whose bounding spheres, swept over the step, overlap (a BVH over the swept spheres, refitted
//! from step to step, [`PairIndex`]: the cost grows with the pairs that can meet, not with the
//! square of the bodies), skips the pairs it would change (an impact, a zeroed restitution, a
//! chain's) that rapier would not solve or the user's filter refuses (a resting pair left as
//! it is, rapier's whatever they say, is not asked), and gives every other pair a role:
//! `Resting` (pressed or held, as `Policy::rests` decides for a ground: rapier's solver keeps
//! it, with zero restitution where rapier would bounce it
//! above the resting gap; a pair slower than the resting speed is rapier's as it is, and not
//! planned unless a chain reaches it) or `Impact` (it may meet in the step: out of rapier's
//! solver, resolved by the reconstruct stage, `pair_reconstruct.rs`); a resting pair side by
//! side with a body of an `Impact` pair that can pass it on joins it, touching at the step's
//! start (a chain, [`CHAIN_MAX_TILT_SIN`]; two balls closing slower than the pressed speed
//! start none). A pair's
//! closing speed is along the line of centres for two balls, and for other shapes the contact
//! points' along parry's normal plus what the bodies' turning can add (angular speed times
//! bounding radius). Its one write into rapier: a sleeping body an `Impact` pair may reach is
//! woken, so that the step plans it as an awake body.

use crate::motion::State;
use crate::plugin::bridge::convert::{to_f64, to_real, vec_from_na, vec_to_na};
use crate::plugin::bridge::resolve::material;
use crate::plugin::hooks::flags::HookFlags;
use crate::plugin::policy::{CHAIN_MAX_TILT_SIN, Policy, Role};
use crate::plugin::queries::body_contact::body_contact;
use crate::plugin::queries::filter;
use crate::plugin::queries::geometry::{BodyGeom, contact};
use crate::plugin::queries::ground_index::GroundMotion;
use crate::plugin::queries::observe::{
    Sets, body_geom, centred, ground_geom, held_besides, neighbours, pressed_besides, rapier_state,
};
use crate::plugin::stages::commit::{Commit, Origin};
use crate::plugin::state::handles::PairKey;
use crate::plugin::state::handles::{HandleMap, HandleSet, slot_of};
use crate::plugin::state::registry::Registry;
use crate::rapier::math::Vector;
use crate::rapier::parry::bounding_volume::Aabb;
use crate::rapier::parry::partitioning::{Bvh, BvhWorkspace};
use crate::rapier::prelude::{
    CoefficientCombineRule, ColliderHandle, ColliderSet, PhysicsHooks, RigidBodyHandle,
    RigidBodySet,
};
use nalgebra::Vector3;
use std::cell::OnceCell;

/// A pair of bodies with a role this step.
#[derive(Clone, Copy, Debug)]
pub(crate) struct PlannedPair {
    pub a: RigidBodyHandle,
    pub b: RigidBodyHandle,
    /// The pair's key ([`pair_key`] of the two bodies' colliders).
    pub key: PairKey,
    /// Two centred balls: the line of centres is the contact normal, and `reach` the
    /// centres' distance at contact. Otherwise any shapes (`body_contact.rs` finds the
    /// contact).
    pub balls: bool,
    /// The two radii summed, skins included (m): the centres' distance at contact (balls;
    /// for other shapes, their bounding radii summed).
    pub reach: f64,
    /// Unit contact normal at the step's start, from `a` to `b` (the line of centres for
    /// balls).
    pub normal: Vector3<f64>,
    pub role: Role,
    /// Its bodies need the plugin's hook flags: an `Impact` pair leaves rapier's solver, and a
    /// `Resting` one that rapier would bounce higher than the resting gap gets zero
    /// restitution. A pair with hook flags is never recycled by rapier: flagging every
    /// resting pair of a pile made rapier's contact detection 2.8 times as costly.
    pub hooked: bool,
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

/// The opted-in balls' swept spheres, kept from step to step: each step updates every ball's
/// leaf (keyed by its body's slot) and refits the tree (a binned rebuild over 1 000 balls every
/// step was two thirds of the plan's cost).
#[derive(Default)]
pub(crate) struct PairIndex {
    tree: Bvh,
    workspace: BvhWorkspace,
    /// The body slots with a leaf in the tree.
    slots: Vec<bool>,
    /// This step's ball (index in its list) by body slot, `u32::MAX` for none.
    ball_of: Vec<u32>,
}

impl PairIndex {
    /// The tree over these leaves (body slot, swept box): leaves of bodies no longer listed
    /// are removed.
    fn update(&mut self, leaves: &[(u32, Aabb)]) {
        let len = leaves
            .iter()
            .map(|(s, _)| *s as usize + 1)
            .max()
            .unwrap_or(0);
        if self.ball_of.len() < len {
            self.ball_of.resize(len, u32::MAX);
        }
        for (k, (slot, _)) in leaves.iter().enumerate() {
            self.ball_of[*slot as usize] = k as u32;
        }
        for slot in 0..self.slots.len() {
            let listed = self.ball_of.get(slot).is_some_and(|b| *b != u32::MAX);
            if self.slots[slot] && !listed {
                self.tree.remove(slot as u32);
                self.slots[slot] = false;
            }
        }
        if self.slots.len() < len {
            self.slots.resize(len, false);
        }
        for (slot, aabb) in leaves {
            self.tree.insert_or_update_partially(*aabb, *slot, 0.0);
            self.slots[*slot as usize] = true;
        }
        self.tree.refit(&mut self.workspace);
        self.tree.optimize_incremental(&mut self.workspace);
    }

    /// Every pair of balls (indices in this step's list, the smaller first) whose boxes meet:
    /// one traversal of the tree against itself.
    fn overlapping(&mut self) -> Vec<(usize, usize)> {
        let mut out = Vec::new();
        let ball_of = &self.ball_of;
        self.tree
            .traverse_bvtt_single_tree::<false>(&mut self.workspace, &mut |s1, s2| {
                let (i, j) = (ball_of[s1 as usize] as usize, ball_of[s2 as usize] as usize);
                out.push((i.min(j), i.max(j)));
            });
        out
    }

    /// This step's ball (index in its list) of a body in it.
    fn ball_of_body(&self, body: RigidBodyHandle) -> usize {
        self.ball_of[slot_of_body(body) as usize] as usize
    }

    /// The balls (indices in this step's list) whose boxes meet `aabb`.
    fn meeting<'a>(&'a self, aabb: &'a Aabb) -> impl Iterator<Item = usize> + 'a {
        self.tree
            .intersect_aabb(aabb)
            .map(|slot| self.ball_of[slot as usize] as usize)
    }

    /// Forgets this step's list (the tree stays).
    fn clear_list(&mut self, leaves: &[(u32, Aabb)]) {
        for (slot, _) in leaves {
            self.ball_of[*slot as usize] = u32::MAX;
        }
    }
}

/// The pairs whose swept boxes overlap, as each ball's list of the others (both ways).
struct Overlaps {
    /// Ball `k`'s others are `others[start[k]..start[k + 1]]`.
    start: Vec<u32>,
    others: Vec<u32>,
}

impl Overlaps {
    fn new(balls: usize, pairs: &[(usize, usize)]) -> Self {
        let mut start = vec![0u32; balls + 1];
        for (i, j) in pairs {
            start[*i + 1] += 1;
            start[*j + 1] += 1;
        }
        for k in 0..balls {
            start[k + 1] += start[k];
        }
        let mut next = start.clone();
        let mut others = vec![0u32; start[balls] as usize];
        for (i, j) in pairs {
            for (from, to) in [(*i, *j), (*j, *i)] {
                others[next[from] as usize] = to as u32;
                next[from] += 1;
            }
        }
        Overlaps { start, others }
    }

    /// The balls whose swept boxes overlap ball `k`'s.
    fn of(&self, k: usize) -> impl Iterator<Item = usize> + '_ {
        let range = self.start[k] as usize..self.start[k + 1] as usize;
        self.others[range].iter().map(|j| *j as usize)
    }
}

/// The key of the pair of two body colliders, the same whichever comes first.
pub(crate) fn pair_key(c1: ColliderHandle, c2: ColliderHandle) -> PairKey {
    if (slot_of(c1), c1.into_raw_parts().1) <= (slot_of(c2), c2.into_raw_parts().1) {
        (c1, c2)
    } else {
        (c2, c1)
    }
}

/// A body that takes part in impacts between bodies, as the plan sees it at the step start
/// (named for the common case).
struct Ball<'a> {
    body: RigidBodyHandle,
    collider: ColliderHandle,
    com: Vector3<f64>,
    v: Vector3<f64>,
    /// Radius, skin included (m): a centred ball's, or for any other shape the radius of a
    /// sphere about the centre of mass that holds it (its rotation stays inside).
    radius: f64,
    asleep: bool,
    /// The acceleration of its user force (m/s^2).
    force_accel: f64,
    /// How fast its turning can move a surface point: the angular speed times the radius for
    /// a shape that is not a ball, 0 for a ball (m/s).
    turn_speed: f64,
    /// Not a centred ball: its collider and state, for the contact queries (boxed: the list
    /// of a thousand balls is built every step, and stays small).
    shape: Option<Box<(BodyGeom<'a>, State)>>,
}

/// The step's pairs (see the module's contract). `prev` are last step's pair roles (a pair
/// rapier held at rest stays resting unless clearly hit, as for grounds).
#[allow(clippy::too_many_arguments)]
pub(crate) fn plan_pairs<H: PhysicsHooks>(
    index: &mut PairIndex,
    registry: &Registry,
    flags: &HookFlags,
    user_hooks: &H,
    bodies: &mut RigidBodySet,
    colliders: &ColliderSet,
    sets: &Sets,
    prev: &HandleMap<PairKey, Role>,
    grounds: &[GroundMotion],
    gravity: Vector3<f64>,
    dt: f64,
    policy: &Policy,
) -> PairPlan {
    let mut plan = PairPlan::default();
    // Two sleeping balls cannot meet: with none awake, no pair.
    if !registry.any_pairs()
        || !bodies
            .iter()
            .any(|(handle, rb)| !rb.is_sleeping() && registry.takes_pairs(handle, rb))
    {
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
            if !co.is_enabled() || co.is_sensor() {
                return None;
            }
            // A ball centred on the centre of mass (in the body's frame, where both are
            // exact) is met in closed form; any other shape through parry.
            let centre = co
                .position_wrt_parent()
                .map_or(Vector3::zeros(), |pose| vec_to_na(pose.translation));
            let local_com = vec_to_na(rb.local_center_of_mass());
            let ball = co
                .shape()
                .as_ball()
                .map(|b| to_f64(b.radius))
                .filter(|r| centred(&(centre - local_com), *r));
            let (radius, shape) = match ball {
                Some(r) => (r + to_f64(co.contact_skin()), None),
                // A compound or a mesh is rapier's: parry's contact manifolds between them are
                // in their pieces' frames.
                None if !co.shape().is_convex() => return None,
                None => {
                    let geom = body_geom(rb, colliders, &local_com);
                    (geom.radius, Some(Box::new((geom, rapier_state(rb)))))
                }
            };
            let com = vec_to_na(rb.center_of_mass());
            Some(Ball {
                body: handle,
                collider: *collider,
                com,
                v: vec_to_na(rb.linvel()),
                radius,
                asleep: rb.is_sleeping(),
                force_accel: to_f64(rb.user_force().length()) / to_f64(rb.mass()),
                turn_speed: match shape {
                    Some(_) => to_f64(rb.angvel().length()) * radius,
                    None => 0.0,
                },
                shape,
            })
        })
        .collect();
    // Two sleeping balls cannot meet: with none awake, no pair.
    if balls.len() < 2 || balls.iter().all(|b| b.asleep) {
        return plan;
    }
    // The pairs that may be impacts, or that rapier would bounce: approaching faster than
    // the resting speed, so with a body faster than half of it (a mover: its centre's speed
    // and its turn's reach, `turn_speed`), unless a pair's combined restitution can reach 1
    // (rapier then bounces any approach: a ball's own restitution of 1, or two summed). Two
    // sleeping balls cannot meet, unless a chain reaches them (below).
    let is_mover: Vec<bool> = balls
        .iter()
        .map(|b| 2.0 * (b.v.norm() + b.turn_speed) > policy.resting_speed)
        .collect();
    let mover = |k: usize| is_mover[k];
    let any_elastic = balls.iter().any(|b| {
        let co = &colliders[b.collider];
        co.restitution() >= 1.0
            || co.restitution_combine_rule() == CoefficientCombineRule::ClampedSum
    });
    let movers = is_mover.iter().filter(|m| **m).count();
    // Each ball's sphere swept over the step: its travel under gravity and any force is at
    // most |v| dt + |a| dt^2 (a generous bound for a user force too, checked per pair below).
    // Asked of every pair looked at (thousands a step in a pile): computed once a ball.
    let margin = policy.resting_gap.max(policy.prediction);
    let g_len = gravity.norm();
    let swept: Vec<f64> = balls
        .iter()
        .map(|b| b.radius + b.v.norm() * dt + (g_len + b.force_accel) * dt * dt + margin)
        .collect();
    // A body that is not a ball lying within the resting gap of a ground (parry's distance
    // to the grounds near it): its pairs are rapier's (see `evaluate`). Asked only of the
    // bodies of a pair looked at, once a step each.
    let lying: Vec<OnceCell<bool>> = balls.iter().map(|_| OnceCell::new()).collect();
    let on_ground = |k: usize| {
        *lying[k].get_or_init(|| {
            let m = &balls[k];
            let Some(shape) = &m.shape else {
                return false;
            };
            let (geom, state) = (&shape.0, &shape.1);
            let half = to_real(m.radius + policy.resting_gap);
            registry
                .index
                .near(grounds, vec_from_na(&m.com), half)
                .iter()
                .any(|g| {
                    ground_geom(&grounds[*g], colliders).is_some_and(|gg| {
                        geom.parts.iter().any(|part| {
                            contact(part, &gg, state, 0.0, policy.resting_gap).is_some()
                        })
                    })
                })
        })
    };
    let leaves: Vec<(u32, Aabb)> = balls
        .iter()
        .zip(&swept)
        .map(|(b, swept)| {
            let half = to_real(*swept);
            (
                slot_of_body(b.body),
                Aabb::from_half_extents(vec_from_na(&b.com), Vector::splat(half)),
            )
        })
        .collect();
    index.update(&leaves);
    let down = gravity.try_normalize(0.0).unwrap_or_else(Vector3::zeros);
    // Has rapier's solver held the pair in contact (an impulse last step)?
    let held = |a: &Ball, b: &Ball| {
        sets.narrow_phase
            .contact_pair(a.collider, b.collider)
            .is_some_and(|pair| {
                pair.manifolds()
                    .iter()
                    .any(|m| m.points.iter().any(|p| p.data.impulse > 0.0))
            })
    };
    // Would rapier not solve the pair `key` of the bodies' colliders, or the user's filter
    // refuse it? (`filter.rs`; every test there is symmetric in the two.)
    let refused = |key: PairKey, a: RigidBodyHandle, b: RigidBodyHandle| {
        let user = flags.recorded_user_flags(colliders, key.0)
            | flags.recorded_user_flags(colliders, key.1);
        !filter::rapier_solves(bodies, &colliders[key.0], &colliders[key.1])
            || filter::joint_disables_contacts(sets.impulse_joints, sets.multibody_joints, a, b)
            || filter::user_refuses(user_hooks, user, bodies, colliders, key)
    };
    // The pair of balls `i < j` with its role, or `None` when it cannot meet in the step, it is
    // slow and rapier's resting contact as it is (unless `chain`: side by side with a ball of
    // an impact, it may pass the impact on), or it is hooked and rapier would not solve it or
    // the user's filter refuses it.
    let evaluate = |i: usize, j: usize, chain: bool| -> Option<PlannedPair> {
        let (a, b) = (&balls[i], &balls[j]);
        let d = b.com - a.com;
        // Beyond reach: their spheres' travel cannot close the gap in the step.
        let (reach, reach_swept) = (a.radius + b.radius, swept[i] + swept[j]);
        if d.norm_squared() > reach_swept * reach_swept {
            return None;
        }
        let len = d.norm();
        let travel = reach_swept - reach;
        let forces = a.force_accel + b.force_accel;
        let balls_only = a.shape.is_none() && b.shape.is_none();
        let (gap, closing, normal) = if balls_only {
            // Closing speed along the line of centres (a ball's spin does not move its
            // surface along the normal).
            let closing = if len > 0.0 {
                (a.v - b.v).dot(&(d / len))
            } else {
                0.0
            };
            let normal = if len > 0.0 { d / len } else { Vector3::zeros() };
            (len - reach, closing, normal)
        } else {
            // A body rapier's solver holds against something else (a die lying on the table,
            // a pin standing on the lane) cannot be moved alone through the impact, and out
            // of rapier's solver the pair would be checked only at the step's end, where a
            // fast die may have passed through: the pair is rapier's, as it is.
            // So is one within the resting gap of a ground at the step's start (rapier's
            // narrow phase may not hold the contact yet: a die just put on the table).
            if on_ground(i)
                || on_ground(j)
                || held_besides(a.body, &bodies[a.body], b.collider, sets)
                || held_besides(b.body, &bodies[b.body], a.collider, sets)
            {
                return None;
            }
            // Any shapes: parry's contact at the step's start, and the contact points'
            // closing speed; a turning body can bring a point closer by its angular speed
            // times its radius.
            let ((ga, sa), (gb, sb)) = (
                geom_state(a, bodies, colliders),
                geom_state(b, bodies, colliders),
            );
            let turn = |m: &Ball, s: &State| match m.shape {
                Some(_) => s.w.norm() * m.radius * dt,
                None => 0.0,
            };
            let turn = turn(a, &sa) + turn(b, &sb);
            let touch = body_contact(ga.get(), &sa, gb.get(), &sb, travel + turn + margin)?;
            // The closest points' closing speed, and what a turn can add to it along the
            // normal (the spin about the normal adds nothing): a turning body's other corner
            // may swing in first (a cube that hit a cube with its corner, spun by the impact,
            // meets it again). Without turning (a die lying on a die) it is the closest
            // points' speed.
            let n = touch.normal;
            let tilt = |m: &Ball, s: &State| match m.shape {
                Some(_) => (s.w - n * n.dot(&s.w)).norm() * m.radius,
                None => 0.0,
            };
            let closing = -touch.rate + tilt(a, &sa) + tilt(b, &sb);
            (touch.dist, closing, n)
        };
        let slow = closing <= policy.resting_speed;
        // Slow, and with every restitution below 1: rapier's bounce of it (`e` times the
        // approach) stays below the pressed speed, so `rapier_bounces` below is false and the
        // pair is not planned. A pile's resting neighbours leave here, before their colliders
        // and contacts are read.
        if slow && !chain && !any_elastic {
            return None;
        }
        let closes = gap <= closing * dt + 0.5 * forces * dt * dt + margin;
        let (ca, cb) = (&colliders[a.collider], &colliders[b.collider]);
        // Asked by both rapier's bounce and the pair's rest below: a walk of rapier's graph.
        let held_last_step = OnceCell::new();
        let held_pair = || *held_last_step.get_or_init(|| held(a, b));
        // rapier's own bounce of a pair it solves: `e` times the approach, the step the
        // contact is new (no impulse the step before), or every step at `e >= 1`. Where that
        // cannot rise above the resting gap (below the pressed speed) it is rapier's resting
        // noise, and the pair keeps rapier's restitution.
        let rapier_bounces = closing > 0.0 && closes && {
            let e = material(ca, cb, None).restitution;
            e >= 1.0 || e * closing > policy.pressed_speed && !held_pair()
        };
        // Slower than the resting speed it is no impact: rapier's resting contact (a pile's
        // neighbours, balls drifting together), left as it is where rapier's bounce of it is
        // noise, and not planned (most pairs of a pile: their planning was most of its cost).
        if slow && !chain && !rapier_bounces {
            return None;
        }
        let key = pair_key(a.collider, b.collider);
        // Held at rest last step: planned `Resting`, or (slow pairs are not planned) touching
        // in rapier's solver.
        let was_resting = || prev.get(&key) == Some(&Role::Resting) || held_pair();
        // Pressed, as a ground pair is: a ball that touched something else after the last
        // step (a ball in a pile) is pushed by it, and rapier's solver holds the pile.
        // (Not by each other: their own contact does not press them together.)
        let pressed = || {
            pressed_besides(a.body, &bodies[a.body], b.collider, sets, registry)
                || pressed_besides(b.body, &bodies[b.body], a.collider, sets, registry)
        };
        // An impact: approaching faster than the resting speed, closing the gap within the
        // step (both balls fall alike; a user force adds its acceleration), and not resting
        // or pressed. Anything else is rapier's (`Resting`), with e = 0 where rapier would
        // bounce it.
        let impact = !slow && closes && !policy.rests(gap, closing, was_resting(), pressed);
        let hooked = impact || rapier_bounces;
        // rapier's filtering and the user's decide a pair the plugin takes out of rapier's
        // solver or changes: an impact, a pair it zeroes (and one a chain takes, asked there).
        // A resting pair it leaves as it is stays rapier's whatever they say (the hooks ask
        // the user's filter of it, `hooks/mod.rs`); most of a pile's planned pairs are such.
        if hooked && refused(key, a.body, b.body) {
            return None;
        }
        Some(PlannedPair {
            a: a.body,
            b: b.body,
            key,
            balls: balls_only,
            reach,
            normal,
            role: if impact { Role::Impact } else { Role::Resting },
            hooked,
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
    // One traversal of the tree against itself costs about as much as three balls' queries
    // per ball (measured on a pile of 1 000). Its pairs are kept for the chains below, as each
    // ball's neighbours once a chain asks (a query of the tree per member of a chain cost
    // more than the traversal itself).
    let mut traversed: Option<Vec<(usize, usize)>> = None;
    let candidates: Vec<(usize, usize)> = if any_elastic || 3 * movers > balls.len() {
        let all = index.overlapping();
        let candidates = all
            .iter()
            .copied()
            .filter(|(i, j)| any_elastic || mover(*i) || mover(*j))
            .collect();
        traversed = Some(all);
        candidates
    } else {
        let mut out = Vec::new();
        for m in (0..balls.len()).filter(|m| mover(*m)) {
            for j in index.meeting(&leaves[m].1) {
                // A pair of two movers once, from the first.
                if j != m && (j > m || !mover(j)) {
                    out.push((m.min(j), m.max(j)));
                }
            }
        }
        out
    };
    for (i, j) in candidates {
        if balls[i].asleep && balls[j].asleep {
            continue;
        }
        if let Some(pair) = evaluate(i, j, false) {
            add(&mut plan, &mut woken, pair);
        }
    }
    // Chains: a resting pair side by side with a ball of an impact joins it (the ball hit
    // passes the impact on inside the step: Newton's cradle, a row of balls on a table),
    // and so on along the row, sleeping balls included. A ball lying on another stays
    // rapier's, and so does a ball something lies on: a pile's layers are held by rapier's
    // solver. A chain is the balls an impact reaches within the step: only a pair touching
    // at the step's start (within the resting gap) carries it on. An impact of bodies other
    // than two balls, or of two balls closing faster than the pressed speed, passes on to
    // every side (a rack broken by the cue ball); a slower impact of two balls side by side
    // passes on only along its own line (a cradle struck gently, not every ball touching the
    // struck one in a crowd on the floor, whose contacts rapier's solver holds); a slower
    // landing of a ball on another passes nothing on.
    let closing_gap = |a: RigidBodyHandle, b: RigidBodyHandle| {
        let (ba, bb) = (&balls[index.ball_of_body(a)], &balls[index.ball_of_body(b)]);
        let d = bb.com - ba.com;
        let len = d.norm();
        let closing = if len > 0.0 {
            (ba.v - bb.v).dot(&(d / len))
        } else {
            0.0
        };
        (closing, len - (ba.radius + bb.radius))
    };
    // The balls an impact reaches that can pass it on, and the line it passes along (`None`:
    // every side).
    let mut carriers: HandleMap<RigidBodyHandle, Option<Vector3<f64>>> = HandleMap::default();
    for p in plan.pairs.iter().filter(|p| p.role == Role::Impact) {
        let along = if !p.balls || closing_gap(p.a, p.b).0 > policy.pressed_speed {
            None
        } else if p.normal.dot(&down).abs() <= CHAIN_MAX_TILT_SIN {
            Some(p.normal)
        } else {
            continue;
        };
        for ball in [p.a, p.b] {
            let line = carriers.entry(ball).or_insert(along);
            if along.is_none() {
                *line = None;
            }
        }
    }
    // Can a carrier's impact pass to the pair of this normal?
    let passes = |line: &Option<Vector3<f64>>, normal: &Vector3<f64>| {
        line.is_none_or(|d| d.cross(normal).norm() <= CHAIN_MAX_TILT_SIN)
    };
    let mut loaded: HandleMap<RigidBodyHandle, bool> = HandleMap::default();
    // (Without gravity nothing lies on anything.)
    let mut is_loaded = |h: RigidBodyHandle| {
        down != Vector3::zeros()
            && *loaded
                .entry(h)
                .or_insert_with(|| neighbours(h, &bodies[h], sets, registry, &down).loaded)
    };
    // The carriers whose pairs were all planned, by index in `balls`, and those still to
    // expand, in the order they became carriers.
    let mut expanded = vec![false; balls.len()];
    let mut to_expand: Vec<RigidBodyHandle> = carriers.keys().copied().collect();
    let mut around: Vec<usize> = Vec::new();
    let overlaps: OnceCell<Overlaps> = OnceCell::new();
    // The level resting pairs (side by side: a level normal, by index in `plan.pairs`) that
    // wait for a ball of theirs to become a carrier, by ball; `listed` pairs were looked at,
    // and a pair beside a carrier is decided once (`decided`).
    let mut waiting: HandleMap<RigidBodyHandle, Vec<usize>> = HandleMap::default();
    let mut decided: Vec<bool> = Vec::new();
    let mut ready: Vec<usize> = Vec::new();
    let mut listed = 0;
    // Each carrier is expanded once and each pair decided once: the chain grows in time
    // linear in its pairs.
    while !to_expand.is_empty() {
        // The pairs around each new carrier that the first pass left out (slow ones, and two
        // sleeping balls): each once, from the carrier expanded first.
        for h in std::mem::take(&mut to_expand) {
            let m = index.ball_of_body(h);
            if expanded[m] {
                continue;
            }
            expanded[m] = true;
            around.clear();
            match &traversed {
                Some(pairs) => around.extend(
                    overlaps
                        .get_or_init(|| Overlaps::new(balls.len(), pairs))
                        .of(m),
                ),
                None => around.extend(index.meeting(&leaves[m].1)),
            }
            for &j in &around {
                let (lo, hi) = (m.min(j), m.max(j));
                if j == m || expanded[j] {
                    continue;
                }
                let key = pair_key(balls[lo].collider, balls[hi].collider);
                if !plan.roles.contains_key(&key) {
                    if let Some(pair) = evaluate(lo, hi, true) {
                        add(&mut plan, &mut woken, pair);
                    }
                }
            }
        }
        // The level resting pairs planned since: decided now if a ball of theirs carries a
        // chain, else waiting for one to.
        decided.resize(plan.pairs.len(), false);
        ready.extend((listed..plan.pairs.len()).filter(|k| {
            let pair = &plan.pairs[*k];
            pair.role == Role::Resting && pair.normal.dot(&down).abs() <= CHAIN_MAX_TILT_SIN
        }));
        listed = plan.pairs.len();
        // A pair beside a carrier joins, or it never will (it is apart, something lies on a
        // ball, or rapier or the user's filter would not solve it).
        while let Some(k) = ready.pop() {
            let PlannedPair { a, b, key, .. } = plan.pairs[k];
            if decided[k] {
                continue;
            }
            let normal = plan.pairs[k].normal;
            // The line the impact reaches it along, from the ball of the pair that passes it
            // on (every side first).
            let from = [a, b]
                .iter()
                .filter_map(|ball| carriers.get(ball))
                .filter(|line| passes(line, &normal))
                .min_by_key(|line| line.is_some())
                .copied();
            let Some(along) = from else {
                // Until a ball of the pair carries an impact that passes to it.
                waiting.entry(a).or_default().push(k);
                waiting.entry(b).or_default().push(k);
                continue;
            };
            decided[k] = true;
            let apart = plan.pairs[k].balls && closing_gap(a, b).1 > policy.resting_gap;
            if apart || is_loaded(a) || is_loaded(b) || refused(key, a, b) {
                continue;
            }
            plan.pairs[k].role = Role::Impact;
            plan.pairs[k].hooked = true;
            plan.roles.insert(key, Role::Impact);
            join(&mut plan, &mut woken, a);
            join(&mut plan, &mut woken, b);
            for ball in [a, b] {
                // A new carrier, or one that now passes on to every side.
                let was = carriers.get(&ball).copied();
                if was.is_none() || was.is_some_and(|line| line.is_some() && along.is_none()) {
                    carriers.insert(ball, along);
                    to_expand.push(ball);
                    ready.extend(waiting.remove(&ball).unwrap_or_default());
                }
            }
        }
    }
    index.clear_list(&leaves);
    for handle in woken {
        if let Some(rb) = bodies.get_mut(handle) {
            Commit::wake(rb);
        }
    }
    plan
}

/// A body's slot in the body set, the key of its leaf in the `PairIndex`.
fn slot_of_body(handle: RigidBodyHandle) -> u32 {
    handle.into_raw_parts().0
}

/// `Step` mode: the impulses of the step's `Impact` pairs at the step's start, to the
/// velocities there (as for grounds, `ImpactTiming::StepStart`): every pair that closes
/// within the step and approaches faster than the resting speed gets the model's impulse,
/// in the plan's order, and again in turn while one approaches (a chain along a row), at
/// most `max_impacts` per ball. The pairs are then rapier's resting contacts for the step
/// (`Resting`, e = 0), so it never bounces them a second time. Writes and reports through
/// `commit`.
#[allow(clippy::too_many_arguments)]
pub(crate) fn step_start_impulses(
    plan: &mut PairPlan,
    bodies: &mut RigidBodySet,
    commit: &mut Commit,
    colliders: &ColliderSet,
    law: crate::model::Law,
    max_impacts: usize,
    flat_tolerance: f64,
    policy: &Policy,
    dt: f64,
) {
    let mut events = Vec::new();
    let impacts: Vec<usize> = (0..plan.pairs.len())
        .filter(|k| plan.pairs[*k].role == Role::Impact)
        .collect();
    let cap = max_impacts * plan.members.len().max(1);
    'passes: for _ in 0..cap {
        let mut any = false;
        for k in &impacts {
            let pair = plan.pairs[*k];
            let (sa, sb) = (rapier_state(&bodies[pair.a]), rapier_state(&bodies[pair.b]));
            let states = (sa, sb);
            let resolved = if pair.balls {
                step_start_balls(&pair, states, bodies, colliders, law, policy, dt)
            } else {
                step_start_bodies(
                    &pair,
                    states,
                    bodies,
                    colliders,
                    law,
                    flat_tolerance,
                    policy,
                    dt,
                )
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

/// Writes each body's velocities after a step-start impulse; the pose stays rapier's.
fn write_velocities<const N: usize>(
    commit: &mut Commit,
    bodies: &mut RigidBodySet,
    written: [(RigidBodyHandle, State, State); N],
) {
    for (h, s, after) in written {
        let local_com = vec_to_na(bodies[h].local_center_of_mass());
        let s = State {
            v: after.v,
            w: after.w,
            ..s
        };
        commit.state(bodies, h, &s, &local_com, Origin::Correction);
    }
}

/// `Step` mode's impulse for a pair of centred balls: along their line of centres, the
/// states moved along it to touching, if they approach faster than the resting speed and
/// close the gap within the step. Both states after and the events.
fn step_start_balls(
    pair: &PlannedPair,
    (sa, sb): (State, State),
    bodies: &RigidBodySet,
    colliders: &ColliderSet,
    law: crate::model::Law,
    policy: &Policy,
    dt: f64,
) -> Option<(State, State, [crate::plugin::events::ImpactEvent; 2])> {
    use crate::plugin::bridge::resolve::{ImpactInput, Inertia, PairSide, material, resolve_balls};
    let (ra, rb) = (bodies.get(pair.a)?, bodies.get(pair.b)?);
    let margin = policy.resting_gap.max(policy.prediction);
    let d = sb.com - sa.com;
    let len = d.norm();
    if len == 0.0 {
        return None;
    }
    let closing = (sa.v - sb.v).dot(&(d / len));
    let gap = len - pair.reach;
    if closing <= policy.resting_speed || gap > closing * dt + margin {
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
        law,
        material(&colliders[ca], &colliders[cb], None),
        policy.resting_speed,
        crate::plugin::events::ImpactTiming::StepStart,
    );
    resolve_balls(&input, &side_a, &side_b, 0.0)
}

/// `Step` mode's impulse for a pair of bodies not both centred balls: at their contact at
/// the step's start (parry's, with the flat-landing points of `touch_point`), if they approach
/// faster than the resting speed there and close the gap within the step. Both states after
/// and the events.
#[allow(clippy::too_many_arguments)]
fn step_start_bodies(
    pair: &PlannedPair,
    (sa, sb): (State, State),
    bodies: &RigidBodySet,
    colliders: &ColliderSet,
    law: crate::model::Law,
    flat_tolerance: f64,
    policy: &Policy,
    dt: f64,
) -> Option<(State, State, [crate::plugin::events::ImpactEvent; 2])> {
    use crate::plugin::bridge::resolve::{
        BodyContactAt, ImpactInput, Inertia, PairSide, material, resolve_bodies,
    };
    use crate::plugin::queries::body_contact::touch_point;
    let (ra, rb) = (bodies.get(pair.a)?, bodies.get(pair.b)?);
    let (la, lb) = (
        vec_to_na(ra.local_center_of_mass()),
        vec_to_na(rb.local_center_of_mass()),
    );
    let (ga, gb) = (body_geom(ra, colliders, &la), body_geom(rb, colliders, &lb));
    let margin = policy.resting_gap.max(policy.prediction);
    let turn = (sa.w.norm() * ga.radius + sb.w.norm() * gb.radius) * dt;
    let reach = (sa.v - sb.v).norm() * dt + turn + margin;
    let touch = body_contact(&ga, &sa, &gb, &sb, reach)?;
    let closing = -touch.rate;
    if closing <= policy.resting_speed || touch.dist > closing * dt + turn + margin {
        return None;
    }
    let (ca, cb) = (
        ga.parts[touch.parts.0].handle,
        gb.parts[touch.parts.1].handle,
    );
    let (point, points) = touch_point(&ga, &sa, &gb, &sb, &touch, flat_tolerance);
    let (ia, ib) = (Inertia::of(ra), Inertia::of(rb));
    let (side_a, side_b) = (
        PairSide::new(pair.a, ca, &ia, sa, 0.0),
        PairSide::new(pair.b, cb, &ib, sb, 0.0),
    );
    let input = ImpactInput::between(
        &side_a,
        law,
        material(&colliders[ca], &colliders[cb], None),
        policy.resting_speed,
        crate::plugin::events::ImpactTiming::StepStart,
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

/// A member's colliders and state for a contact query.
fn geom_state<'g, 'a>(
    m: &'g Ball<'a>,
    bodies: &RigidBodySet,
    colliders: &'a ColliderSet,
) -> (GeomRef<'g, 'a>, State) {
    match &m.shape {
        Some(shape) => (GeomRef::Borrowed(&shape.0), shape.1),
        None => {
            let rb = &bodies[m.body];
            let local_com = vec_to_na(rb.local_center_of_mass());
            (
                GeomRef::Owned(body_geom(rb, colliders, &local_com)),
                rapier_state(rb),
            )
        }
    }
}

/// A body's colliders for a contact query: kept in the plan's list, or made for the query.
enum GeomRef<'g, 'a> {
    Borrowed(&'g BodyGeom<'a>),
    Owned(BodyGeom<'a>),
}

impl<'a> GeomRef<'_, 'a> {
    fn get(&self) -> &BodyGeom<'a> {
        match self {
            GeomRef::Borrowed(g) => g,
            GeomRef::Owned(g) => g,
        }
    }
}
