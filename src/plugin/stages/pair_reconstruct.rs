//! Reconstruct, for impacts between bodies: a cluster of bodies (those joined by the step's
//! `Impact` pairs) moved together over the step from their start states, as they would have
//! moved had rapier not solved those pairs.
//!
//! Contract: [`move_clusters`] finds the clusters whose every body moved alone in the step and
//! commits what [`through_pair_impacts`] gives for each; [`through_pair_impacts`] takes a cluster
//! each of whose bodies moved alone in the step (no contact in rapier's solver, no joint or
//! torque: checked by the caller) and moves every body by its own motion (`crate::motion`: free
//! flight, or for a ball rolling in closed form on its level ground) to the cluster's earliest
//! event: a body's ground impact (the in-step search of `geometry.rs`) or two bodies touching
//! (two centred balls in closed form, `motion::meeting`; any other pair by conservative
//! advancement on parry's distance, `body_contact.rs`), resolved by the model (`resolve.rs`; a
//! flat face on a face as one impact at the centroid of their overlap's corners), then on to the
//! next, in time order, both bodies of a pair updated between events (each body's and pair's
//! next event is searched once and again only when one of its bodies changed, so an event
//! costs the searches of its two bodies, not of the whole cluster): a chain (a ball passing an
//! impact on to the one it touches) is a sequence of impacts at the same time, in the order the
//! touches are found; a touch slower than the resting speed is a resting contact from there on
//! (rapier's next step). A ball rolling on its ground that an impact lifts flies from there;
//! pressed into the ground, the ground takes the normal speed (a `Settle` event) and it rolls
//! on. It returns every body's state at the step's end and reports every impulse as an event,
//! or `None` when the cluster cannot be moved alone (a search that stalls, more events than
//! `max_impacts_per_step` per body, a rolling ball leaving its plane): its events are then
//! withdrawn, rapier's end state stands, and the settle stage checks the pairs. It writes
//! nothing into rapier.

use crate::motion::meeting::first_touch;
use crate::motion::{Flight, Motion, Moving, State};
use crate::plugin::bridge::convert::to_f64;
use crate::plugin::bridge::resolve::{
    BodyContactAt, ImpactInput, Inertia, PairSide, Site, correction, material, resolve,
    resolve_balls, resolve_bodies,
};
use crate::plugin::config::TimingMode;
use crate::plugin::events::{EventKind, ImpactTiming};
use crate::plugin::policy::on_plane;
use crate::plugin::policy::{EndCheck, Role};
use crate::plugin::queries::body_contact::{BodyTouch, Mover, first_body_touch, touch_point};
use crate::plugin::queries::geometry::{
    BodyGeom, GroundGeom, Search, closest, first_impact, landing_point,
};
use crate::plugin::queries::observe::{body_geom, centred_ball, touches_other};
use crate::plugin::stages::commit::Origin;
use crate::plugin::stages::reconstruct::ccd_consistent;
use crate::plugin::stages::reconstruct::rest_on_ground;
use crate::plugin::stages::settle::Checked;
use crate::plugin::state::handles::{HandleMap, HandleSet};
use crate::plugin::state::small_list::SmallList;
use crate::plugin::state::step::AfterStep;
use crate::plugin::state::step::Candidate;
use crate::plugin::state::step::EndOfStep;
use crate::rapier::math::Vector;
use crate::rapier::prelude::{ColliderHandle, ColliderSet, RigidBodyHandle, RigidBodySet};
use std::cmp::Reverse;
use std::collections::BinaryHeap;

/// A body of a cluster (a ball, a die, a pin) and what its motion needs.
pub(crate) struct ClusterBall<'a> {
    pub cand: &'a Candidate,
    pub collider: ColliderHandle,
    /// A ball centred on its centre of mass: its radius to the contact point, skin included
    /// (m). Two such balls meet in closed form (`motion::meeting`); any other pair through
    /// parry (`body_contact.rs`).
    pub radius: Option<f64>,
    pub geom: BodyGeom<'a>,
    /// Its grounds: the `Impact` grounds, and the ground it rolls on (last).
    pub grounds: SmallList<GroundGeom<'a>>,
    /// The ground it rolls on, as an index in `grounds`.
    pub rolling_on: Option<usize>,
    pub inertia: Inertia,
}

/// The clusters of the step's `Impact` pairs between bodies (joined through shared
/// bodies) whose every body moved alone in the step (no contact in rapier's solver, no
/// joint, torque or `Step` impulse, rapier's CCD consistent with its motion), in
/// `TimeOfImpact` and `Exact` modes: moved together from their start states
/// (`pair_reconstruct.rs`), checked against their grounds (`EndCheck::Flown`) and
/// written. Returns the bodies written.
pub(crate) fn move_clusters(
    view: &mut AfterStep,
    bodies: &mut RigidBodySet,
    colliders: &ColliderSet,
    step: &EndOfStep,
) -> HandleSet<RigidBodyHandle> {
    let mut written = HandleSet::default();
    let impacts: Vec<_> = step
        .pairs
        .pairs
        .iter()
        .filter(|p| p.role == Role::Impact)
        .collect();
    if impacts.is_empty() || view.config.timing == TimingMode::Step {
        return written;
    }
    let index: HandleMap<RigidBodyHandle, usize> = step
        .candidates
        .iter()
        .enumerate()
        .map(|(k, c)| (c.body, k))
        .collect();
    // Clusters: the connected sets of balls, by union-find over the pairs.
    let mut parent: HandleMap<RigidBodyHandle, RigidBodyHandle> = HandleMap::default();
    fn root(
        parent: &mut HandleMap<RigidBodyHandle, RigidBodyHandle>,
        h: RigidBodyHandle,
    ) -> RigidBodyHandle {
        let mut r = h;
        while let Some(p) = parent.get(&r).copied().filter(|p| *p != r) {
            r = p;
        }
        parent.insert(h, r);
        r
    }
    for pair in &impacts {
        let (ra, rb) = (root(&mut parent, pair.a), root(&mut parent, pair.b));
        if ra != rb {
            parent.insert(ra, rb);
        }
    }
    // Each cluster's members in the order the pairs list them, and each body's place there.
    let mut clusters: Vec<Vec<RigidBodyHandle>> = Vec::new();
    let mut cluster_of: HandleMap<RigidBodyHandle, usize> = HandleMap::default();
    let mut place: HandleMap<RigidBodyHandle, usize> = HandleMap::default();
    for pair in &impacts {
        for body in [pair.a, pair.b] {
            if place.contains_key(&body) {
                continue;
            }
            let r = root(&mut parent, body);
            let c = *cluster_of.entry(r).or_insert_with(|| {
                clusters.push(Vec::new());
                clusters.len() - 1
            });
            place.insert(body, clusters[c].len());
            clusters[c].push(body);
        }
    }
    // Each cluster's pairs, as indices into its members.
    let mut cluster_pairs: Vec<Vec<(usize, usize)>> = vec![Vec::new(); clusters.len()];
    for pair in &impacts {
        let c = cluster_of[&root(&mut parent, pair.a)];
        cluster_pairs[c].push((place[&pair.a], place[&pair.b]));
    }
    let sets = &step.sets;
    for (members, pairs) in clusters.iter().zip(&cluster_pairs) {
        let free = members.iter().all(|h| {
            let (Some(rb), Some(k)) = (bodies.get(*h), index.get(h)) else {
                return false;
            };
            let cand = &step.candidates[*k];
            view.registry.manages(*h, rb)
                && !rb.is_sleeping()
                && !touches_other(rb, sets.narrow_phase)
                && sets.impulse_joints.attached_joints(*h).next().is_none()
                && sets.multibody_joints.rigid_body_link(*h).is_none()
                && rb.user_torque() == Vector::ZERO
                && !cand.touched
                && ccd_consistent(rb, cand, step.dt, step.dt, step)
        });
        if !free {
            continue;
        }
        let settle = &*view;
        let balls: Option<Vec<ClusterBall>> = members
            .iter()
            .map(|h| {
                let cand = &step.candidates[index[h]];
                let rb = &bodies[*h];
                let geom = body_geom(rb, colliders, &cand.local_com);
                let part = geom.parts.first()?;
                let radius = part
                    .shape
                    .as_ball()
                    .filter(|_| centred_ball(part))
                    .map(|b| to_f64(b.radius) + part.skin);
                let collider = part.handle;
                let mut grounds = settle.impact_ground_geoms(cand, &geom, colliders, step);
                let rolling_on = match &cand.rolling {
                    Some((g, _)) => {
                        grounds.push(settle.pair_geom(&step.grounds[*g], &geom, colliders)?);
                        Some(grounds.len() - 1)
                    }
                    None => None,
                };
                Some(ClusterBall {
                    cand,
                    collider,
                    radius,
                    geom,
                    grounds,
                    rolling_on,
                    inertia: Inertia::of(rb),
                })
            })
            .collect();
        let Some(balls) = balls else {
            continue;
        };
        let from = view.commit.reported().len();
        let Some(ends) = through_pair_impacts(view, colliders, &balls, pairs, step) else {
            continue;
        };
        for (ball, end) in balls.iter().zip(ends) {
            // Never left inside a ground. No energy cap: an impact between balls passes
            // energy from one to the other, so the ball hit may end above its start energy.
            let checked = Checked {
                body: ball.cand.body,
                geom: &ball.geom,
                inertia: &ball.inertia,
                cand: None,
                grounds: &ball.grounds,
                events_from: from,
            };
            let why = EndCheck::Flown;
            let (_, settled) = view.check(bodies, colliders, &checked, &end, why, step);
            let end = settled.unwrap_or(end);
            let (body, local_com) = (ball.cand.body, &ball.cand.local_com);
            view.commit
                .state(bodies, body, &end, local_com, Origin::Model);
            written.insert(ball.cand.body);
        }
    }
    written
}

/// What happens next in the cluster.
enum Next {
    Ground(usize, State, crate::plugin::queries::geometry::Hit),
    /// The pair of this index in the cluster's pairs, with parry's contact for a pair not
    /// both centred balls.
    Touch(usize, Option<BodyTouch>),
}

/// The cluster's states at the step's end (see the module's contract). `pairs` are the
/// cluster's `Impact` pairs as indices into `balls`.
pub(crate) fn through_pair_impacts(
    view: &mut AfterStep,
    colliders: &ColliderSet,
    balls: &[ClusterBall],
    pairs: &[(usize, usize)],
    step: &EndOfStep,
) -> Option<Vec<State>> {
    let events_from = view.commit.reported().len();
    let moved = move_cluster(view, colliders, balls, pairs, step);
    if moved.is_none() {
        view.commit.withdraw(events_from);
    }
    moved
}

fn move_cluster(
    view: &mut AfterStep,
    colliders: &ColliderSet,
    balls: &[ClusterBall],
    pairs: &[(usize, usize)],
    step: &EndOfStep,
) -> Option<Vec<State>> {
    let dt = step.dt;
    let mut moving: Vec<Moving> = balls
        .iter()
        .map(|b| Moving {
            state: b.cand.start,
            t0: 0.0,
            motion: match &b.cand.rolling {
                Some((_, rolling)) => Motion::Rolling(*rolling),
                None => Motion::Flight(b.cand.flight),
            },
        })
        .collect();
    let mut flights: Vec<Flight> = balls.iter().map(|b| b.cand.flight).collect();
    // Pairs left touching slowly: resting for the rest of the step.
    let mut resting = vec![false; pairs.len()];
    // Each body's pairs, by index in `pairs`.
    let mut pairs_of: Vec<Vec<usize>> = vec![Vec::new(); balls.len()];
    for (p, (i, j)) in pairs.iter().enumerate() {
        pairs_of[*i].push(p);
        pairs_of[*j].push(p);
    }
    let max_events = view.config.max_impacts_per_step * balls.len();
    let mut events = 0usize;
    let mut agenda = Agenda::new(balls.len(), pairs.len());
    let search = Searches { balls, pairs, dt };
    for (k, m) in moving.iter().enumerate() {
        agenda.ground(k, search.ground(k, m, 0.0).ok()?);
    }
    for p in 0..pairs.len() {
        agenda.touch(p, search.touch(p, &moving, 0.0).ok()?);
    }
    while let Some((te, event)) = agenda.pop() {
        events += 1;
        if events > max_events {
            return None;
        }
        // The bodies whose motion changed: their ground and pairs are searched again.
        let (changed, count) = match event {
            Next::Ground(k, s, hit) => {
                let ball = &balls[k];
                let after =
                    ground_impact(view, colliders, ball, &mut flights[k], &s, te, &hit, step)?;
                moving[k] = Moving {
                    state: after,
                    t0: te,
                    motion: Motion::Flight(flights[k]),
                };
                ([k, k], 1)
            }
            Next::Touch(p, touch) => {
                let (i, j) = pairs[p];
                let side = |k: usize| {
                    let ball = &balls[k];
                    let radius = ball.radius.unwrap_or(0.0);
                    let state = moving[k].at(te);
                    PairSide::new(ball.cand.body, ball.collider, &ball.inertia, state, radius)
                };
                let (si, sj) = (side(i), side(j));
                let input = ImpactInput::between(
                    &si,
                    view.config.law,
                    material(
                        &colliders[balls[i].collider],
                        &colliders[balls[j].collider],
                        None,
                    ),
                    step.policy.resting_speed,
                    ImpactTiming::InStep,
                );
                // A touch slower than the resting speed is a resting contact from here: the
                // next step hands it to rapier's solver (`Resting`). Resolving it with e = 0
                // would not end: balls left touching at nearly the same speed behind a chain
                // meet again and again, in ever smaller impacts.
                let closing = match &touch {
                    None => {
                        let line = (sj.state.com - si.state.com).normalize();
                        (si.state.v - sj.state.v).dot(&line)
                    }
                    Some(touch) => -touch.rate,
                };
                if closing < step.policy.resting_speed {
                    resting[p] = true;
                    continue;
                }
                // A touch the model finds not approaching (a graze at rounding level) is
                // stepped over: the pair's next search starts after it.
                let resolved = match &touch {
                    None => resolve_balls(&input, &si, &sj, te),
                    Some(touch) => {
                        let (point, points) = touch_point(
                            &balls[i].geom,
                            &si.state,
                            &balls[j].geom,
                            &sj.state,
                            touch,
                            view.config.flat_tolerance,
                        );
                        let at = BodyContactAt {
                            normal: touch.normal,
                            point,
                            points,
                        };
                        resolve_bodies(&input, &si, &sj, &at, te)
                    }
                };
                let Some((after_i, after_j, pair_events)) = resolved else {
                    agenda.touch(p, search.touch(p, &moving, next_after(te)).ok()?);
                    continue;
                };
                view.commit.events(pair_events);
                for (k, after) in [(i, after_i), (j, after_j)] {
                    if reaches_other_grounds(view, &balls[k], &after, dt - te, step) {
                        return None;
                    }
                    moving[k] = on_after_touch(view, balls, k, &moving[k], after, te, step)?;
                }
                // A ball that moved on may drive into a pair it rested in.
                for q in pairs_of[i].iter().chain(&pairs_of[j]) {
                    resting[*q] = false;
                }
                ([i, j], 2)
            }
        };
        let changed = &changed[..count];
        for &k in changed {
            agenda.ground(k, search.ground(k, &moving[k], te).ok()?);
        }
        for (n, &k) in changed.iter().enumerate() {
            for &q in &pairs_of[k] {
                // The pair of the two changed bodies once.
                let (a, b) = pairs[q];
                if n == 1 && (a == changed[0] || b == changed[0]) {
                    continue;
                }
                let found = if resting[q] {
                    None
                } else {
                    search.touch(q, &moving, te).ok()?
                };
                agenda.touch(q, found);
            }
        }
    }
    let ends: Vec<State> = moving.iter().map(|m| m.at(dt)).collect();
    // A rolling ball still on its plane at the end (a cuboid's face it left, or a mesh,
    // would need the ground's other faces).
    for (k, ball) in balls.iter().enumerate() {
        if let (Motion::Rolling(rolling), Some(g)) = (moving[k].motion, ball.rolling_on) {
            let hit = closest(
                &ball.geom,
                &ball.grounds[g..=g],
                &ends[k],
                dt,
                step.policy.resting_gap,
            )?;
            let on_plane = on_plane(hit.dist, &hit.normal, &rolling.normal, rolling.radius);
            if !on_plane {
                return None;
            }
        }
    }
    Some(ends)
}

/// The searches for a cluster's next events, over what is left of the step.
struct Searches<'c, 'a> {
    balls: &'c [ClusterBall<'a>],
    pairs: &'c [(usize, usize)],
    dt: f64,
}

impl Searches<'_, '_> {
    /// Body `k`'s first ground impact after `t` (none while it rolls: its one plane is all it
    /// meets), `Err` where the search gave up (the cluster is not moved alone).
    fn ground(&self, k: usize, m: &Moving, t: f64) -> Result<Option<(f64, Next)>, ()> {
        let ball = &self.balls[k];
        let Motion::Flight(flight) = m.motion else {
            return Ok(None);
        };
        if ball.grounds.is_empty() {
            return Ok(None);
        }
        match first_impact(
            &ball.geom,
            &ball.grounds,
            &flight,
            &m.state,
            m.t0,
            t,
            self.dt,
        ) {
            Search::Hit(th, s, hit) => Ok(Some((th, Next::Ground(k, s, hit)))),
            Search::Stalled(..) => Err(()),
            Search::Clear => Ok(None),
        }
    }

    /// Pair `p`'s first touch after `t` while approaching, `Err` where the search gave up.
    fn touch(&self, p: usize, moving: &[Moving], t: f64) -> Result<Option<(f64, Next)>, ()> {
        let (i, j) = self.pairs[p];
        let (bi, bj) = (&self.balls[i], &self.balls[j]);
        let found = match (bi.radius, bj.radius) {
            (Some(ri), Some(rj)) => first_touch(&moving[i], &moving[j], ri + rj, t, self.dt)
                .map_err(|_| ())?
                .map(|tc| (tc, None)),
            _ => {
                let mover = |k: usize| Mover {
                    geom: &self.balls[k].geom,
                    moving: &moving[k],
                    turns: self.balls[k].radius.is_none(),
                };
                first_body_touch(&mover(i), &mover(j), t, self.dt)
                    .map_err(|_| ())?
                    .map(|(tc, touch)| (tc, Some(touch)))
            }
        };
        Ok(found.map(|(tc, touch)| (tc, Next::Touch(p, touch))))
    }
}

/// A cluster's next events, each found once and searched again only when one of its bodies
/// changed: an event costs the searches of its bodies' ground and pairs, not of every pair of
/// the cluster. The earliest comes first; ties go to a ground impact before a touch, then to
/// the lowest index, the same every run.
struct Agenda {
    queue: BinaryHeap<Reverse<Due>>,
    /// The event found for each body's ground, then for each pair (by `Due::slot`), and the
    /// number of its search: an entry in the queue from an earlier search is stale.
    found: Vec<(u32, Option<Next>)>,
    bodies: usize,
}

/// An entry of the [`Agenda`]'s queue.
#[derive(Clone, Copy, Debug)]
struct Due {
    t: f64,
    /// A body's ground impact (its index) before a pair's touch (the body count plus its index).
    slot: usize,
    search: u32,
}

impl PartialEq for Due {
    fn eq(&self, other: &Self) -> bool {
        self.cmp(other) == std::cmp::Ordering::Equal
    }
}

impl Eq for Due {}

impl PartialOrd for Due {
    fn partial_cmp(&self, other: &Self) -> Option<std::cmp::Ordering> {
        Some(self.cmp(other))
    }
}

impl Ord for Due {
    fn cmp(&self, other: &Self) -> std::cmp::Ordering {
        self.t
            .total_cmp(&other.t)
            .then(self.slot.cmp(&other.slot))
            .then(self.search.cmp(&other.search))
    }
}

impl Agenda {
    fn new(bodies: usize, pairs: usize) -> Self {
        Self {
            queue: BinaryHeap::with_capacity(bodies + pairs),
            found: (0..bodies + pairs).map(|_| (0, None)).collect(),
            bodies,
        }
    }

    /// Body `k`'s ground impact, as last searched.
    fn ground(&mut self, k: usize, next: Option<(f64, Next)>) {
        self.set(k, next);
    }

    /// Pair `p`'s touch, as last searched (`None` also for a pair resting from here).
    fn touch(&mut self, p: usize, next: Option<(f64, Next)>) {
        self.set(self.bodies + p, next);
    }

    fn set(&mut self, slot: usize, next: Option<(f64, Next)>) {
        let entry = &mut self.found[slot];
        entry.0 += 1;
        entry.1 = None;
        if let Some((t, event)) = next {
            entry.1 = Some(event);
            self.queue.push(Reverse(Due {
                t,
                slot,
                search: entry.0,
            }));
        }
    }

    /// The earliest event still current, taken off the agenda.
    fn pop(&mut self) -> Option<(f64, Next)> {
        while let Some(Reverse(due)) = self.queue.pop() {
            let entry = &mut self.found[due.slot];
            if entry.0 == due.search {
                if let Some(event) = entry.1.take() {
                    return Some((due.t, event));
                }
            }
        }
        None
    }
}

/// Can ball `ball`, leaving an impact at `s` with `left` seconds of the step to go, reach a
/// ground it was not planned against? Its grounds came from its start-of-step speed; a hit
/// from a heavier ball can send it much faster (a light ball struck down into the floor), and
/// the cluster cannot be moved alone then.
fn reaches_other_grounds(
    view: &AfterStep,
    ball: &ClusterBall,
    s: &State,
    left: f64,
    step: &EndOfStep,
) -> bool {
    let accel = ball.cand.flight.accel.norm();
    let reach = ball.geom.radius
        + s.v.norm() * left
        + accel * left * left
        + step.policy.resting_gap.max(step.policy.prediction);
    let half = crate::plugin::bridge::convert::to_real(reach);
    let centre = crate::plugin::bridge::convert::vec_from_na(&s.com);
    view.registry
        .index
        .near(&step.grounds, centre, half)
        .iter()
        .any(|i| {
            !ball
                .grounds
                .iter()
                .any(|g| g.handle == step.grounds[*i].handle)
        })
}

/// The smallest time after `t` that differs from it.
fn next_after(t: f64) -> f64 {
    t + f64::EPSILON * t.abs().max(1e-3)
}

/// A ball's ground impact inside the cluster's step, as `reconstruct::through_impacts`
/// resolves one; a settled impact holds gravity off the rest of the step (`flight`).
#[allow(clippy::too_many_arguments)]
fn ground_impact(
    view: &mut AfterStep,
    colliders: &ColliderSet,
    ball: &ClusterBall,
    flight: &mut Flight,
    s: &State,
    t: f64,
    hit: &crate::plugin::queries::geometry::Hit,
    step: &EndOfStep,
) -> Option<State> {
    let part = &ball.geom.parts[hit.part];
    let gg = &ball.grounds[hit.ground];
    let (point, points) = landing_point(part, gg, s, t, hit, view.config.flat_tolerance);
    let input = ImpactInput {
        body: ball.cand.body,
        inertia: &ball.inertia,
        law: view.config.law,
        material: view.registry.material_of(colliders, part.handle, gg.handle),
        resting_speed: step.policy.resting_speed,
        force_settle: false,
        timing: ImpactTiming::InStep,
    };
    let (mut after, event) = resolve(&input, &ball.geom, gg, s, t, hit, point, points)?;
    let settled = event.settled;
    view.commit.event(event);
    if settled {
        let site = Site {
            body: ball.cand.body,
            collider: part.handle,
            ground: gg.handle,
            body2: None,
            normal: hit.normal,
            point,
        };
        rest_on_ground(view, &site, &ball.inertia, flight, &mut after, t, step);
    }
    Some(after)
}

/// How ball `k` moves on after an impact with another ball left it at `after` (time `t`).
fn on_after_touch(
    view: &mut AfterStep,
    balls: &[ClusterBall],
    k: usize,
    before: &Moving,
    mut after: State,
    t: f64,
    step: &EndOfStep,
) -> Option<Moving> {
    let ball = &balls[k];
    let (Motion::Rolling(rolling), Some(g)) = (before.motion, ball.rolling_on) else {
        return Some(Moving {
            state: after,
            t0: t,
            motion: before.motion,
        });
    };
    let n = rolling.normal;
    let vn = n.dot(&after.v);
    if vn > 0.0 {
        // Lifted off its ground, however little (the ground cannot pull): it flies, and may
        // land on it again.
        return Some(Moving {
            state: after,
            t0: t,
            motion: Motion::Flight(ball.cand.flight),
        });
    }
    // Rolling on, where the closed form reaches (on a slope: along the fall line).
    let on_ground = State {
        v: after.v - n * vn,
        ..after
    };
    rolling.advance_checked(&on_ground, step.dt - t)?;
    if vn < 0.0 {
        // Pressed into the ground: the ground takes the normal speed (an impulse through the
        // centre, e = 0).
        let prior = after;
        after.v -= n * vn;
        let site = Site {
            body: ball.cand.body,
            collider: ball.collider,
            ground: ball.grounds[g].handle,
            body2: None,
            normal: n,
            point: after.com - n * rolling.radius,
        };
        view.commit.event(correction(
            EventKind::Settle,
            &site,
            &ball.inertia,
            &prior,
            &after,
            t,
        ));
    }
    Some(Moving {
        state: after,
        t0: t,
        motion: Motion::Rolling(rolling),
    })
}
