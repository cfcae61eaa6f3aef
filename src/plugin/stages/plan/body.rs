//! One body's start: the grounds near its snapshot and geometry (nearest first for a ball at
//! a seam; the snapshot and geometry made by the plan and lent), the plan that the pairs'
//! roles fill in, and the candidate it ends as.

use super::Planner;
use crate::motion::{Flight, Rolling, State};
use crate::parry::query::Unsupported;
use crate::plugin::bridge::convert::{to_f64, to_real, vec_from_na};
use crate::plugin::config::TimingMode;
use crate::plugin::queries::geometry::{
    BodyGeom, GroundGeom, PairContact, contact_checked, part_pose,
};
use crate::plugin::queries::observe::{Scene, centred_ball, ground_geom, meets_tiles};
use crate::plugin::state::handles::PairKey;
use crate::plugin::state::memory::LastStep;
use crate::plugin::state::small_list::SmallList;
use crate::plugin::state::step::{Candidate, StepData};
use crate::rapier::math::Vector;
use crate::rapier::parry::bounding_volume::Aabb;
use crate::rapier::prelude::{ColliderHandle, PhysicsHooks, RigidBody, RigidBodyHandle};
use nalgebra::Vector3;

/// A ground's contact with a body part at the step's start, as `contact_checked` answers.
pub(super) type StartContact = Result<Option<PairContact>, Unsupported>;

/// What is known of a body near a ground before any of its pairs is decided: read-only for
/// the stages of its plan. Its start and geometry are lent by the plan (`BodyStart`).
pub(super) struct BodyNear<'q, 'c> {
    pub handle: RigidBodyHandle,
    /// rapier's body (read as the step's writes leave it through `start`; looked up once).
    pub rb: &'c RigidBody,
    /// Its state at the step's start (before any `Step` impulse).
    pub start: &'q State,
    pub flight: &'q Flight,
    pub local_com: Vector3<f64>,
    pub geom: &'q BodyGeom<'c>,
    /// A bound on the speed of any point of the body over the step (m/s).
    pub speed: f64,
    /// How far beyond its bounding sphere the body can reach a still ground in the step (m):
    /// a moving ground's reach adds its own travel ([`BodyNear::reach_to`]).
    pub reach: f64,
    /// The step's length (s).
    pub dt: f64,
    /// The grounds near it (indices in `StepData::grounds`).
    pub near: SmallList<usize>,
    /// A ball of an impact between bodies: it needs its candidate in every mode.
    pub member: bool,
    /// Not one centred ball: turning moves its contact point over its surface.
    pub turns_surface: bool,
    /// It has a joint (which may disable its contacts with a ground's body).
    pub jointed: bool,
    /// The grounds near it with their geometry, the one a ball rests on first.
    pub grounds: SmallList<(usize, GroundGeom<'c>)>,
    /// For a ball near several grounds: its contact with each of `grounds` at the start, in
    /// the same order, where `nearest_first` queried it (read through
    /// [`BodyNear::start_contact`]); empty otherwise.
    pub start_contacts: SmallList<Option<StartContact>>,
}

/// A body's start-of-step snapshot (`observe::snapshot`: its state, flight and centre of
/// mass in its own frame) and its colliders: large values, made in the plan's frame and lent
/// to its `BodyNear`, never moved.
pub(super) type BodyStart<'q, 'c> = (&'q (State, Flight, Vector3<f64>), &'q BodyGeom<'c>);

/// What one body's plan reads and never writes: the body near its grounds, rapier's world,
/// and what the plugin kept of the last step.
#[derive(Clone, Copy)]
pub(super) struct BodyReads<'q, 'c> {
    pub body: &'q BodyNear<'q, 'c>,
    pub scene: &'q Scene<'c>,
    pub last: &'q LastStep,
}

/// The body's plan in progress, filled in by its pairs' roles in the grounds' order.
pub(super) struct BodyPlan {
    /// Its state: the start, after any `Step` impulse, or put on the plane it rolls on.
    pub state: State,
    /// A `Step` impulse changed its state (to be written).
    pub touched: bool,
    /// The grounds the search after the step runs against.
    pub impact_grounds: SmallList<usize>,
    /// One of those grounds may close in the step (`geometry::cannot_close` does not rule it
    /// out).
    pub closing: bool,
    /// Its resting contacts whose point turning can slide beyond the resting gap: the ground
    /// and the point in the body frame.
    pub turning_resting: SmallList<(usize, Vector3<f64>)>,
    /// The closed-form rolling on the ground of this index.
    pub rolling: Option<(usize, Rolling)>,
    /// The rolling stays over its ground's one flat face (`Candidate::rolls_on_one_face`).
    pub rolls_on_one_face: bool,
    /// Held at rest on a slope (`OnPlane::Held`): its pairs are rapier's.
    pub held: bool,
    /// The grounds of the plane it rolls on (`rolling_of`): their pairs are the rolling's.
    pub rolling_pieces: Option<SmallList<ColliderHandle>>,
    /// Released from last step's rolling at the start (`Candidate::released`).
    pub released: Option<usize>,
    /// The pairs `Step` mode's impulses resolved at the step's start.
    pub resolved_at_start: SmallList<PairKey>,
}

impl BodyNear<'_, '_> {
    /// The plan before any pair is decided: the start state, nothing found.
    pub fn plan(&self) -> BodyPlan {
        BodyPlan {
            state: *self.start,
            touched: false,
            impact_grounds: SmallList::Empty,
            closing: false,
            turning_resting: SmallList::Empty,
            rolling: None,
            rolls_on_one_face: false,
            held: false,
            rolling_pieces: None,
            released: None,
            resolved_at_start: SmallList::Empty,
        }
    }

    /// The ball's contact with its `k`-th ground at the step's start, for a ball near several
    /// grounds (`None` for any other body): the one `nearest_first` found, else queried now,
    /// with the same arguments, so the same answer.
    #[inline]
    pub fn start_contact(&self, k: usize) -> Option<StartContact> {
        match self.start_contacts.get(k)? {
            Some(found) => Some(*found),
            None => Some(contact_checked(
                &self.geom.parts[0],
                &self.grounds[k].1,
                self.start,
                0.0,
                self.reach_to(&self.grounds[k].1),
            )),
        }
    }

    /// How far beyond its bounding sphere the body can reach the ground `gg` in the step
    /// (m): its own reach, and the ground's travel near it ([`ground_reach`]).
    #[inline]
    pub fn reach_to(&self, gg: &GroundGeom) -> f64 {
        ground_reach(self.reach, (self.start, self.geom), gg, self.dt)
    }

    /// How far a point of the body can move relative to a resting contact point in the step
    /// by turning, from the state `s` (for a ball about its centre: how fast rapier's contact
    /// point slides off its bottom). Pure.
    ///
    /// Inlined: asked of every resting pair.
    #[inline]
    pub fn turning_reach(&self, s: &State, dt: f64) -> f64 {
        self.flight.max_angular_speed(s) * 2.0 * self.geom.radius * dt
    }
}

impl<H: PhysicsHooks> Planner<'_, H> {
    /// The grounds near the body `handle` (`rb`) from its start `(snap, geom)` (the cheap
    /// test: its bounding sphere swept over the step against the grounds' boxes), filling
    /// `out`. `None` when no ground is near it, and then, in `Exact` mode or for a ball of an
    /// impact between bodies, its flying candidate is pushed. Reads rapier; writes only
    /// `step.candidates`.
    pub(super) fn start_body<'q, 'c, 'o>(
        &self,
        (handle, rb): (RigidBodyHandle, &'c RigidBody),
        scene: &Scene<'c>,
        (snap, geom): BodyStart<'q, 'c>,
        step: &mut StepData,
        out: &'o mut Option<BodyNear<'q, 'c>>,
    ) -> Option<&'o mut BodyNear<'q, 'c>> {
        let (start, flight, local_com) = (&snap.0, &snap.1, snap.2);
        let dt = step.dt;
        let speed = flight.max_speed(start, dt) + flight.max_angular_speed(start) * geom.radius;
        let reach = speed * dt + step.policy.contact_margin();
        let sphere = Aabb::from_half_extents(
            vec_from_na(&start.com),
            Vector::splat(to_real(geom.radius + reach)),
        );
        let index = &self.registry.index;
        let (centre, radius) = (sphere.center(), sphere.half_extents().x);
        // Where slabs are, whether it has a joint decides which grounds it meets; asked once.
        let (near, jointed) = if index.has_slabs() {
            let jointed = scene.sets.jointed(handle);
            let near = self.near_slabs(jointed, scene, geom, (centre, radius), step);
            (near, Some(jointed))
        } else {
            (index.near_ball(scene.grounds, centre, radius), None)
        };
        let member = step.pairs.members.contains(handle);
        if near.is_empty() {
            self.push_flying((handle, rb), snap, member, step);
            return None;
        }
        let turns_surface = !(geom.parts.len() == 1 && centred_ball(&geom.parts[0]));
        let jointed = jointed.unwrap_or_else(|| scene.sets.jointed(handle));
        // Most bodies are near one ground: taken as it is, not collected through an iterator.
        let grounds = match &near {
            SmallList::One(i) => ground_geom(&scene.grounds[*i], scene.colliders)
                .map_or(SmallList::Empty, |gg| SmallList::One((*i, gg))),
            near => grounds_of(near, scene),
        };
        // Filled in place: a body's start is a large value, and every move of it a copy.
        let body = out.get_or_insert_with(|| BodyNear {
            handle,
            rb,
            start,
            flight,
            local_com,
            geom,
            speed,
            reach,
            dt,
            near,
            member,
            turns_surface,
            jointed,
            grounds,
            start_contacts: SmallList::Empty,
        });
        if !turns_surface && body.grounds.len() > 1 {
            body.start_contacts = nearest_first(body.geom, &mut body.grounds, start, (reach, dt));
        }
        Some(body)
    }

    /// The flying candidate of a body near no ground (`snap` its start), pushed to
    /// `step.candidates` where the stages after rapier's step want it (`Exact` mode, a ball
    /// of an impact between bodies: `member`). Out of line: most bodies the plan takes are
    /// near a ground.
    #[cold]
    #[inline(never)]
    fn push_flying(
        &self,
        (handle, rb): (RigidBodyHandle, &RigidBody),
        snap: &(State, Flight, Vector3<f64>),
        member: bool,
        step: &mut StepData,
    ) {
        let takes_pairs = || self.registry.takes_pairs(handle, rb);
        if Candidate::wanted_in_flight(self.config.timing, member, takes_pairs) {
            step.candidates
                .push(Candidate::flying(handle, snap.0, snap.1.clone(), snap.2));
        }
    }

    /// The grounds near the body's bounding ball where some grounds are slabs: a slab, or its
    /// tiles for a body that meets them one by one (`meets_tiles`), whose colliders are then
    /// noted in `step.by_tile` (the hooks look their pairs up by tile). `jointed`: whether the
    /// body has a joint.
    #[inline(never)]
    fn near_slabs(
        &self,
        jointed: bool,
        scene: &Scene,
        geom: &BodyGeom,
        (centre, radius): (Vector, crate::rapier::math::Real),
        step: &mut StepData,
    ) -> SmallList<usize> {
        let index = &self.registry.index;
        if meets_tiles(jointed, &geom.parts, |c| {
            self.flags.recorded_user_flags(scene.colliders, c)
        }) {
            step.by_tile
                .extend(geom.parts.iter().map(|part| part.handle));
            index.near_ball_tiles(scene.grounds, centre, radius)
        } else {
            index.near_ball(scene.grounds, centre, radius)
        }
    }

    /// The body's candidate for the stages after rapier's step, pushed to `step.candidates`
    /// if they have anything to do with it: grounds to search, resting contacts that turn, a
    /// rolling, `Exact` mode, or a ball of an impact between bodies. Takes the body's and the
    /// plan's lists (both are done with; taken, not copied); writes nothing else.
    pub(super) fn push_candidate(
        &self,
        body: &mut BodyNear,
        plan: &mut BodyPlan,
        step: &mut StepData,
    ) {
        let wanted = !plan.impact_grounds.is_empty()
            || !plan.turning_resting.is_empty()
            || plan.rolling.is_some()
            || plan.released.is_some()
            || self.config.timing == TimingMode::Exact
            || body.member;
        if !wanted {
            return;
        }
        step.candidates.push(Candidate {
            body: body.handle,
            start: plan.state,
            flight: body.flight.clone(),
            local_com: body.local_com,
            near: std::mem::take(&mut body.near),
            looked_in: (body.start.com, body.geom.radius + body.reach),
            impact_grounds: std::mem::take(&mut plan.impact_grounds),
            touched: plan.touched,
            closing: plan.closing,
            turning_resting: std::mem::take(&mut plan.turning_resting),
            turns_surface: body.turns_surface,
            rolling: plan.rolling.take(),
            rolls_on_one_face: plan.rolls_on_one_face,
            released: plan.released,
            steered: false,
            steered_roll: None,
        });
    }
}

/// The geometry of each ground of `near` (several) whose collider still exists, in
/// `near`'s order. Out of line: most bodies are near one ground.
#[inline(never)]
fn grounds_of<'c>(near: &[usize], scene: &Scene<'c>) -> SmallList<(usize, GroundGeom<'c>)> {
    near.iter()
        .filter_map(|i| Some((*i, ground_geom(&scene.grounds[*i], scene.colliders)?)))
        .collect()
}

/// How far beyond its bounding sphere a body (`reach` its own, from `start` with `geom`) can
/// reach the ground `gg` in a step of length `dt`: its own reach, and what the ground travels
/// near it (`GroundGeom::travel_near`: 0 for a still ground).
#[inline]
fn ground_reach(reach: f64, (start, geom): (&State, &BodyGeom), gg: &GroundGeom, dt: f64) -> f64 {
    reach + gg.travel_near(&start.com, geom.radius + reach, dt)
}

/// A ball (`geom`, one centred ball) near several grounds (a seam between floor tiles): the
/// ground it rests on (least `|gap|` at `start`, the first in `grounds`' order on a tie) moved
/// first in `grounds`, so that if it rolls there on one plane with the others, the rest are
/// only that plane's pieces. Returns its contact with each ground at `start` that it queried,
/// in the new order: the pairs' roles reuse them while the ball has not moved (a `Step`
/// impulse changes only its velocity). A ground whose box keeps the ball farther than the
/// least `|gap|` already found (`GroundGeom::gap_bound`) cannot be the nearest, and is not
/// queried here: a ball rolling on one tile of a floor queries that tile alone.
#[inline(never)]
fn nearest_first(
    geom: &BodyGeom,
    grounds: &mut SmallList<(usize, GroundGeom)>,
    start: &State,
    (reach, dt): (f64, f64),
) -> SmallList<Option<StartContact>> {
    let part = &geom.parts[0];
    let centre = part_pose(part, start).translation.vector;
    let radius = part.shape.as_ball().map_or(0.0, |b| to_f64(b.radius)) + part.skin;
    let gap = |found: &StartContact| match found {
        Ok(Some((dist, ..))) => f64::abs(*dist),
        _ => f64::INFINITY,
    };
    // The least `|gap|` the ball can have to each ground.
    let bounds: SmallList<f64> = grounds
        .iter()
        .map(|(_, gg)| gg.gap_bound(&centre, radius).max(0.0))
        .collect();
    let mut start_contacts: SmallList<Option<StartContact>> =
        grounds.iter().map(|_| None).collect();
    let mut least = f64::INFINITY;
    // The ground with the least bound first (most often the one the ball rests on): its gap
    // then rules out the others.
    let first = (0..bounds.len())
        .min_by(|a, b| bounds[*a].total_cmp(&bounds[*b]))
        .unwrap_or(0);
    for k in std::iter::once(first).chain((0..grounds.len()).filter(|k| *k != first)) {
        if bounds[k] > least {
            continue;
        }
        let gg = &grounds[k].1;
        let found = contact_checked(
            part,
            gg,
            start,
            0.0,
            ground_reach(reach, (start, geom), gg, dt),
        );
        least = least.min(gap(&found));
        start_contacts[k] = Some(found);
    }
    // Every ground whose `|gap|` can equal the least was queried: the first of them.
    let nearest = start_contacts
        .iter()
        .position(|found| found.as_ref().is_some_and(|f| gap(f) == least))
        .unwrap_or(0);
    grounds.swap(0, nearest);
    start_contacts.swap(0, nearest);
    start_contacts
}
