//! Reconstruct, for impacts between bodies: a cluster of bodies (those joined by the step's
//! `Impact` pairs) moved together over the step from their start states, as they would have
//! moved had rapier not solved those pairs.
//!
//! Contract: [`move_clusters`] finds the clusters whose every body moved alone in the step and
//! commits what [`through_pair_impacts`] gives for each; [`through_pair_impacts`] takes a cluster
//! each of whose bodies moved alone in the step (no contact in rapier's solver, no joint or
//! torque: checked by the caller) and moves every body by its own motion (`crate::motion`: free
//! flight, or for a ball rolling in closed form on its level ground) to the cluster's earliest
//! event: a body's ground impact (the in-step search of `queries/geometry/impact_time.rs`) or two bodies touching
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
//!
//! Its parts: forming the clusters and committing their end states (here), the cluster's
//! motion event by event (`cluster.rs`), and the agenda of its next events (`agenda.rs`).

mod agenda;
mod cluster;

pub(crate) use cluster::through_pair_impacts;

use crate::plugin::bridge::convert::to_f64;
use crate::plugin::bridge::resolve::Inertia;
use crate::plugin::config::TimingMode;
use crate::plugin::policy::{EndCheck, Role};
use crate::plugin::queries::geometry::{BodyGeom, GroundGeom};
use crate::plugin::queries::observe::{body_geom, centred_ball, touches_other};
use crate::plugin::stages::commit::Origin;
use crate::plugin::stages::reconstruct::{FlownEnd, ccd_consistent};
use crate::plugin::stages::settle::Checked;
use crate::plugin::stages::view::AfterStep;
use crate::plugin::stages::view::EndOfStep;
use crate::plugin::state::handles::{HandleMap, HandleSet};
use crate::plugin::state::small_list::SmallList;
use crate::plugin::state::step::Candidate;
use crate::plugin::state::step::PlannedPair;
use crate::rapier::math::Vector;
use crate::rapier::prelude::{ColliderHandle, ColliderSet, RigidBodyHandle, RigidBodySet};

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
/// ([`through_pair_impacts`]), checked against their grounds (`EndCheck::Flown`) and
/// written. Returns the bodies written.
pub(crate) fn move_clusters(
    view: &mut AfterStep,
    bodies: &RigidBodySet,
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
    let cands = CandidatesByBody::new(step);
    let clusters = Clusters::of(&impacts);
    for (members, pairs) in clusters.members.iter().zip(&clusters.pairs) {
        if !moves_alone(view, bodies, &cands, members) {
            continue;
        }
        let Some(balls) = cluster_balls(view, bodies, colliders, &cands, members) else {
            continue;
        };
        let from = view.commit.reported().len();
        let Some(ends) = through_pair_impacts(view, colliders, &balls, pairs, step) else {
            continue;
        };
        for (ball, end) in balls.iter().zip(ends) {
            // Never left inside a ground. No energy cap: an impact between bodies passes
            // energy from one to the other, so the body hit may end above its start energy.
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
            view.commit.state(body, &end, local_com, Origin::Model);
            written.insert(ball.cand.body);
        }
    }
    written
}

/// The step's candidates by body.
struct CandidatesByBody<'s> {
    step: &'s EndOfStep<'s>,
    index: HandleMap<RigidBodyHandle, usize>,
}

impl<'s> CandidatesByBody<'s> {
    fn new(step: &'s EndOfStep<'s>) -> Self {
        let index = step
            .candidates
            .iter()
            .enumerate()
            .map(|(k, c)| (c.body, k))
            .collect();
        Self { step, index }
    }

    /// The candidate of `body`, if it has one.
    fn get(&self, body: &RigidBodyHandle) -> Option<&'s Candidate> {
        self.index.get(body).map(|k| &self.step.candidates[*k])
    }

    /// The candidate of `body`, which must have one.
    fn of(&self, body: &RigidBodyHandle) -> &'s Candidate {
        &self.step.candidates[self.index[body]]
    }
}

/// The connected sets of bodies joined by `Impact` pairs.
struct Clusters {
    /// Each cluster's members, in the order the pairs first list them.
    members: Vec<Vec<RigidBodyHandle>>,
    /// Each cluster's pairs, in the plan's order, as indices into its members.
    pairs: Vec<Vec<(usize, usize)>>,
}

impl Clusters {
    /// The clusters of these pairs, by union-find over them; clusters are numbered in the
    /// order the pairs first reach them, so the order is the plan's every run.
    fn of(impacts: &[&PlannedPair]) -> Self {
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
        for pair in impacts {
            let (ra, rb) = (root(&mut parent, pair.a), root(&mut parent, pair.b));
            if ra != rb {
                parent.insert(ra, rb);
            }
        }
        let mut members: Vec<Vec<RigidBodyHandle>> = Vec::new();
        let mut cluster_of: HandleMap<RigidBodyHandle, usize> = HandleMap::default();
        let mut place: HandleMap<RigidBodyHandle, usize> = HandleMap::default();
        for pair in impacts {
            for body in [pair.a, pair.b] {
                if place.contains_key(&body) {
                    continue;
                }
                let r = root(&mut parent, body);
                let c = *cluster_of.entry(r).or_insert_with(|| {
                    members.push(Vec::new());
                    members.len() - 1
                });
                place.insert(body, members[c].len());
                members[c].push(body);
            }
        }
        let mut pairs: Vec<Vec<(usize, usize)>> = vec![Vec::new(); members.len()];
        for pair in impacts {
            let c = cluster_of[&root(&mut parent, pair.a)];
            pairs[c].push((place[&pair.a], place[&pair.b]));
        }
        Clusters { members, pairs }
    }
}

/// Did every body of the cluster move alone in the step: managed and awake, no contact in
/// rapier's solver besides its grounds, no joint, no user torque, no `Step` impulse, and
/// rapier's CCD consistent with its motion? Reads only.
fn moves_alone(
    view: &AfterStep,
    bodies: &RigidBodySet,
    cands: &CandidatesByBody,
    members: &[RigidBodyHandle],
) -> bool {
    let step = cands.step;
    let sets = &step.sets;
    members.iter().all(|h| {
        let (Some(now), Some(cand)) = (view.commit.body(bodies, *h), cands.get(h)) else {
            return false;
        };
        let rb = now.rb();
        view.registry.manages(*h, rb)
            && !now.is_sleeping()
            && !touches_other(rb, sets.narrow_phase)
            && !sets.jointed(*h)
            && rb.user_torque() == Vector::ZERO
            && !cand.touched
            && ccd_consistent(&now, &FlownEnd::new(cand, step.dt), step.dt, step)
    })
}

/// Each member's [`ClusterBall`], in the members' order: its collider, its radius if it is a
/// centred ball, its `Impact` grounds and the ground it rolls on. `None` when a member has no
/// collider or its rolling ground has no geometry. Every member must have a candidate (as
/// [`moves_alone`] checks). Reads only.
fn cluster_balls<'s>(
    view: &AfterStep,
    bodies: &RigidBodySet,
    colliders: &'s ColliderSet,
    cands: &CandidatesByBody<'s>,
    members: &[RigidBodyHandle],
) -> Option<Vec<ClusterBall<'s>>> {
    let step = cands.step;
    members
        .iter()
        .map(|h| {
            let cand = cands.of(h);
            let rb = &bodies[*h];
            let geom = body_geom(rb, colliders, &cand.local_com);
            let part = geom.parts.first()?;
            let radius = part
                .shape
                .as_ball()
                .filter(|_| centred_ball(part))
                .map(|b| to_f64(b.radius) + part.skin);
            let collider = part.handle;
            let mut grounds =
                view.impact_ground_geoms(&cand.impact_grounds, &geom, colliders, step);
            let rolling_on = match &cand.rolling {
                Some((g, _)) => {
                    grounds.push(view.pair_geom(&step.grounds[*g], &geom, colliders)?);
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
        .collect()
}
