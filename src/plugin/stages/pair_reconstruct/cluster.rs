//! A cluster moved over the step, event by event: each body by its own motion to the
//! cluster's earliest event (a ground impact or two bodies touching), resolved by the model,
//! then on to the next (see the parent module's contract).

use super::agenda::{Agenda, Next};
use super::pairs_of::PairsOf;
use super::{ClusterBall, Group, NearBodies};
use crate::motion::meeting::first_touch;
use crate::motion::{Flight, Motion, Moving, State};
use crate::plugin::bridge::convert::{to_real, vec_from_na, vec_to_na};
use crate::plugin::bridge::resolve::{
    BodyContactAt, GroundContactAt, ImpactInput, PairSide, Site, correction, resolve,
    resolve_balls, resolve_bodies,
};
use crate::plugin::events::{EventKind, ImpactEvent, ImpactTiming};
use crate::plugin::policy::TIME_ULP_FLOOR;
use crate::plugin::policy::on_plane;
use crate::plugin::policy::rests_at;
use crate::plugin::queries::body_contact::{BodyTouch, Mover, first_body_touch, touch_point};
use crate::plugin::queries::geometry::{
    Hit, Search, WayBound, closest, earliest_touch, first_impact, landing_point,
};
use crate::plugin::stages::reconstruct::rest_on_ground;
use crate::plugin::stages::view::AfterStep;
use crate::plugin::stages::view::EndOfStep;
use crate::plugin::state::handles::{HandleMap, Slotted};
use crate::rapier::parry::bounding_volume::Aabb;
use crate::rapier::prelude::{ColliderSet, RigidBodyHandle};

/// Why a cluster was not moved alone.
pub(crate) enum Unmoved {
    /// A search gave up, or the cluster met what it cannot move (see [`move_cluster`]).
    GaveUp,
    /// Member `member`, sent off by an event, may meet `other`, a member of the pair plan it
    /// has no pair with in the cluster: moved as planned, it could pass into or through
    /// `other`. The caller moves the cluster again with that pair, or leaves it. Where
    /// `other` came with bodies that can be moved with the cluster but had an event of their
    /// own before the meeting, their balls and searches from the start are the last of
    /// [`Moved`]'s (a run again with them has them already).
    Meets {
        member: usize,
        other: RigidBodyHandle,
    },
}

/// The bodies that come with a body a member of a moving cluster reaches from outside it
/// (the body met, alone or with the rest of its own cluster), where they can be moved with
/// the cluster, their balls pushed onto the run's (the last argument), in the group's order;
/// `None`, the run's balls as they were, where they cannot.
pub(crate) type Admit<'x, 's> =
    dyn Fn(&AfterStep, RigidBodyHandle, &mut Vec<ClusterBall<'s>>) -> Option<Group<'static>> + 'x;

/// The bodies from outside a cluster that join it on the way.
pub(crate) struct Joining<'x, 's> {
    pub admit: &'x Admit<'x, 's>,
}

/// Bodies that joined a cluster's run: the member that met them, and what was admitted (its
/// balls given to the run).
pub(crate) struct Joined {
    pub member: usize,
    pub group: Group<'static>,
}

/// What moving a cluster gave: its bodies (those it started with, then those that joined it
/// on the way, `joined`, in that order, then those admitted that could not join, see
/// [`Unmoved::Meets`]), and their states at the step's end, or why it could not be moved
/// alone; and its searches from the step's start, for a run again.
pub(crate) struct Moved<'s> {
    pub balls: Vec<ClusterBall<'s>>,
    pub joined: Vec<Joined>,
    pub ends: Result<Vec<State>, Unmoved>,
    pub starts: StartSearches,
}

/// The first events, searched from the step's start, of a cluster's bodies' grounds and of
/// its pairs, in the order of its members and of its pairs as the cluster grows (the
/// bodies and pairs it started with, then for each group that joined it on the way, its
/// bodies and pairs and the pair of the member that met it, then those of a group admitted
/// that could not join, [`Unmoved::Meets`]): a cluster moved again from its
/// start with more bodies searches only theirs (each search is a function of the bodies'
/// start states alone).
#[derive(Default)]
pub(crate) struct StartSearches {
    grounds: Vec<Option<(f64, Next)>>,
    /// `None` for a pair not searched from the start (a member and the body it met).
    touches: Vec<Option<Option<(f64, Next)>>>,
}

impl StartSearches {
    /// No searches, with room for those of clusters of up to `bodies` bodies and `pairs`
    /// pairs ([`run_room`]).
    pub fn with_room(bodies: usize, pairs: usize) -> Self {
        let (bodies_room, pairs_room) = run_room(bodies, pairs);
        Self {
            grounds: Vec::with_capacity(bodies_room),
            touches: Vec::with_capacity(pairs_room),
        }
    }

    /// No searches, the lists' room kept (for another cluster).
    pub fn clear(&mut self) {
        self.grounds.clear();
        self.touches.clear();
    }
}

/// The cluster's states at the step's end (see the module's contract). `pairs` are the cluster's
/// `Impact` pairs as indices into `balls`; `near` finds the pair plan's members a body sent off by
/// an event may meet. A body so met from outside the cluster, alone or with the rest of its own
/// cluster as `joining` admits it, joins the run there where none of them has an event of its own
/// before the meeting (the run goes on: moved again from the start with them, it would be the same
/// run); any other ends the run (`Unmoved::Meets`). Pushes the cluster's events into the step's
/// events (`view.commit`), and withdraws them all when the cluster is not moved; writes nothing
/// into rapier.
pub(crate) fn through_pair_impacts<'s>(
    view: &mut AfterStep,
    (colliders, near, step): (&ColliderSet, &NearBodies, &EndOfStep),
    (balls, pairs): (Vec<ClusterBall<'s>>, &[(usize, usize)]),
    (mut starts, lists): (StartSearches, &mut RunLists),
    joining: &Joining<'_, 's>,
) -> Moved<'s> {
    let events_from = view.commit.reported().len();
    let context = Context {
        colliders,
        near,
        step,
    };
    let Some(eventful) = lists.search_from_start(&context, (&balls, pairs), &mut starts) else {
        // Not started: no event was pushed.
        return Moved {
            balls: Vec::new(),
            joined: Vec::new(),
            ends: Err(Unmoved::GaveUp),
            starts: StartSearches::default(),
        };
    };
    if !eventful {
        // No event in the step: the run's agenda would be empty, its ends the bodies' own.
        let ends = ends_of(step, &balls, &lists.tables.moving).ok_or(Unmoved::GaveUp);
        return Moved {
            balls,
            joined: Vec::new(),
            ends,
            starts,
        };
    }
    let mut run = Run::start(context, (balls, pairs), starts, lists);
    let mut meets = None;
    let ends = move_cluster(view, &mut run, joining, &mut lists.way, &mut meets);
    if ends.is_none() {
        view.commit.withdraw(events_from);
    }
    let ends = match (ends, meets) {
        (Some(ends), _) => Ok(ends),
        (None, Some((member, other))) => Err(Unmoved::Meets { member, other }),
        (None, None) => Err(Unmoved::GaveUp),
    };
    let (balls, joined, starts) = run.finish(lists);
    Moved {
        balls,
        joined,
        ends,
        starts,
    }
}

/// The cluster's events in time order, until the step's end or the cluster cannot be moved
/// alone (`None`: more than `max_impacts_per_step` events per body, a search that stalls, a
/// body reaching a ground it was not planned against or, into `meets`, a member of the pair
/// plan it has no pair with that cannot join, a rolling ball off its plane). Pushes events
/// into the step's events (`view.commit`) without withdrawing them (the caller does).
fn move_cluster<'s>(
    view: &mut AfterStep,
    run: &mut Run<'_, 's>,
    joining: &Joining<'_, 's>,
    way: &mut WayOn,
    meets: &mut Option<(usize, RigidBodyHandle)>,
) -> Option<Vec<State>> {
    let mut events = 0usize;
    while let Some((te, event)) = run.tables.agenda.pop() {
        events += 1;
        // Each body's share, the bodies joined on the way included.
        if events > view.config.max_impacts_per_step * run.balls.len() {
            return None;
        }
        // The bodies whose motion changed: their ground and pairs are searched again.
        let (changed, count) = match event {
            Next::Ground(k, s, hit) => {
                run.ground_event(view, k, &s, te, &hit)?;
                ([k, k], 1)
            }
            Next::Touch(p, touch) => run.touch_event(view, p, touch, te)?,
        };
        // A body sent off may reach a body it has no pair with: a member of the cluster, or
        // one that joins it, pairs with it in a search from here (until then, both moved as
        // the pair plan had them apart); any other moves the cluster again with it. The
        // pairs from `searched` on are those, searched from `te` as they are added.
        let searched = run.tables.pairs.len();
        let mut at_event = AtEvent::new(&changed[..count], te);
        for &k in &changed[..count] {
            let s = at_event.state(&run.tables.moving, k);
            run.way_on(k, &s, te, way);
            while let Some(other) = run.meets_other_body(k, way) {
                let j = match other {
                    Reached::Member(j) => j,
                    Reached::Outside(body) => match run.join(view, joining, k, body, te)? {
                        Some(j) => j,
                        None => {
                            *meets = Some((k, body));
                            return None;
                        }
                    },
                };
                run.add_pair(k, j, &mut at_event)?;
            }
        }
        run.search_again(searched, &mut at_event)?;
    }
    run.ends()
}

/// What a cluster's motion reads and never changes: the colliders, the bodies it may reach
/// and the step.
#[derive(Clone, Copy)]
struct Context<'c> {
    colliders: &'c ColliderSet,
    near: &'c NearBodies<'c>,
    step: &'c EndOfStep<'c>,
}

/// A cluster's motion's reads: its colliders, its step and its bodies as they stand.
#[derive(Clone, Copy)]
struct Cluster<'c, 'a> {
    colliders: &'c ColliderSet,
    balls: &'c [ClusterBall<'a>],
    step: &'c EndOfStep<'c>,
}

impl<'c, 'a> Cluster<'c, 'a> {
    fn of(context: &Context<'c>, balls: &'c [ClusterBall<'a>]) -> Self {
        Cluster {
            colliders: context.colliders,
            balls,
            step: context.step,
        }
    }
}

/// The bodies an event changed (one or two) and the event's time `t`, and their states at
/// `t`, each advanced there once for its way on and all its pairs' searches (`Moving::at` is
/// a function of the motion and the time: the same state however often it is asked). The
/// time is the event's own, so that a kept state is never handed out for another time.
struct AtEvent<'e> {
    changed: &'e [usize],
    t: f64,
    states: [Option<State>; 2],
}

impl<'e> AtEvent<'e> {
    fn new(changed: &'e [usize], t: f64) -> Self {
        Self {
            changed,
            t,
            states: [None, None],
        }
    }

    /// Body `b`'s state at the event's time, as `moving` has it.
    fn state(&mut self, moving: &[Moving], b: usize) -> State {
        let t = self.t;
        match self.changed.iter().position(|k| *k == b) {
            Some(n) => *self.states[n].get_or_insert_with(|| moving[b].at(t)),
            None => moving[b].at(t),
        }
    }
}

/// A body that a body of the cluster sent off may reach, and has no pair with.
enum Reached {
    /// A member of the cluster (its index).
    Member(usize),
    /// A member of the pair plan outside the cluster.
    Outside(RigidBodyHandle),
}

/// A changed body's way on: its centre and velocity where its motion changed, the pair
/// plan's members near the way ([`Run::way_on`]), and how far [`Run::meets_other_body`] went
/// through them.
///
/// Invariant: every leaf of `near` before `next` is met by no body (`meets_other_body` would
/// pass it by), and `partners` holds, sorted, the slots of the bodies the changed body has a
/// pair with in the cluster (left empty while `near` is). So each search goes on from where the
/// last one stopped, and asks of a leaf whether it is a partner by a binary search: a search
/// from the first leaf each time, through every pair, would cost the square of the bodies
/// near a fast body's way, times its pairs.
pub(super) struct WayOn {
    com: nalgebra::Vector3<f64>,
    v: nalgebra::Vector3<f64>,
    near: Vec<NearLeaf>,
    next: usize,
    partners: Vec<u32>,
}

impl Default for WayOn {
    fn default() -> Self {
        Self {
            com: nalgebra::Vector3::zeros(),
            v: nalgebra::Vector3::zeros(),
            near: Vec::new(),
            next: 0,
            partners: Vec::new(),
        }
    }
}

/// A member of the pair plan near a body's way on: its slot and swept box, and whether its
/// pair with the body may be the model's, once asked.
struct NearLeaf {
    slot: u32,
    aabb: Aabb,
    may_pair: Option<bool>,
}

/// A touch slower than the resting speed: a resting contact from there on.
struct SlowTouch;

/// A pair's impulse: both states after, and the two events; `None` where the model finds the
/// bodies not approaching (a graze at rounding level).
type Resolved = Option<(State, State, [ImpactEvent; 2])>;

/// A run's lists: each body's motion and flight, the pairs and which of them rest, each
/// body's pairs and its index by slot, and the agenda.
#[derive(Default)]
struct RunTables {
    moving: Vec<Moving>,
    /// Each body's flight (gravity, and its user force), held off by a settled ground impact.
    flights: Vec<Flight>,
    /// Pairs left touching slowly: resting for the rest of the step.
    resting: Vec<bool>,
    /// The cluster's pairs (indices into `balls`): its `Impact` pairs, then those its bodies
    /// reached on the way.
    pairs: Vec<(usize, usize)>,
    /// Each body's pairs, by index in `pairs`.
    pairs_of: PairsOf,
    /// Each body's index by its body's slot.
    by_slot: HandleMap<u32, usize>,
    agenda: Agenda,
}

/// The lists of a cluster's run, handed on to the next run: cleared and filled again, a run
/// allocates only where it outgrows the runs before it.
#[derive(Default)]
pub(crate) struct RunLists {
    tables: RunTables,
    /// The bodies' states at the step's start, as [`Run::start`] advances them.
    at_start: Vec<Option<State>>,
    way: WayOn,
}

impl RunLists {
    /// Empty lists with room for the runs of clusters of up to `bodies` bodies and `pairs`
    /// pairs ([`run_room`]): a step's runs allocate only where they outgrow that.
    pub fn with_room(bodies: usize, pairs: usize) -> Self {
        let (bodies_room, pairs_room) = run_room(bodies, pairs);
        let mut by_slot = HandleMap::default();
        by_slot.reserve(bodies_room);
        RunLists {
            tables: RunTables {
                moving: Vec::with_capacity(bodies_room),
                flights: Vec::with_capacity(bodies_room),
                resting: Vec::with_capacity(pairs_room),
                pairs: Vec::with_capacity(pairs_room),
                pairs_of: PairsOf::with_room(bodies_room, pairs_room),
                by_slot,
                agenda: Agenda::with_room(bodies_room, pairs_room),
            },
            at_start: Vec::with_capacity(bodies),
            way: WayOn::default(),
        }
    }

    /// Every body at its start state, rolling or flying (into `tables.moving`), and the first
    /// event of each body's ground and of each pair: those in `starts` as found there, the
    /// others searched and kept in it. Whether any body or pair has an event in the step;
    /// `None` where a search gave up.
    fn search_from_start(
        &mut self,
        context: &Context,
        (balls, pairs): (&[ClusterBall], &[(usize, usize)]),
        starts: &mut StartSearches,
    ) -> Option<bool> {
        let cluster = Cluster::of(context, balls);
        let moving = &mut self.tables.moving;
        moving.clear();
        moving.reserve(run_room(balls.len(), pairs.len()).0);
        moving.extend(balls.iter().map(start_moving));
        starts.grounds.reserve(balls.len() - starts.grounds.len());
        for (k, m) in moving.iter().enumerate() {
            if starts.grounds.get(k).is_none() {
                let found = cluster.ground(k, m, 0.0).ok()?;
                starts.grounds.push(found);
            }
        }
        starts
            .touches
            .resize(starts.touches.len().max(pairs.len()), None);
        // Each body at the start, advanced once for all its pairs.
        let at_start = &mut self.at_start;
        at_start.clear();
        at_start.resize(balls.len(), None);
        let moving = &*moving;
        let mut at = |k: usize| *at_start[k].get_or_insert_with(|| moving[k].at(0.0));
        for (p, pair) in pairs.iter().enumerate() {
            if starts.touches[p].is_none() {
                let found = cluster.touch_from(p, *pair, moving, 0.0, &mut at).ok()?;
                starts.touches[p] = Some(found);
            }
        }
        let grounds = starts.grounds[..balls.len()].iter().any(Option::is_some);
        Some(
            grounds
                || starts.touches[..pairs.len()]
                    .iter()
                    .any(|t| t.flatten().is_some()),
        )
    }
}

/// The room a run of a cluster of `bodies` bodies and `pairs` pairs keeps in its lists, of
/// bodies and of pairs: as many bodies again, and as many pairs again as bodies (a run meets
/// a few on the way, `join`, `add_pair`, and its lists then do not grow).
pub(crate) fn run_room(bodies: usize, pairs: usize) -> (usize, usize) {
    (2 * bodies, pairs + bodies)
}

/// A cluster in motion: each body's motion from its last event, and the agenda of what
/// happens next.
struct Run<'c, 'a> {
    context: Context<'c>,
    /// Its bodies: those it started with, then those that joined it on the way.
    balls: Vec<ClusterBall<'a>>,
    /// The bodies that joined it on the way.
    joined: Vec<Joined>,
    tables: RunTables,
    starts: StartSearches,
}

impl<'c, 'a> Run<'c, 'a> {
    /// The run from every body's start state (`lists.tables.moving`, as
    /// [`RunLists::search_from_start`] left it), with the first event of each body's ground
    /// and of each pair in its agenda, as found in `starts`, which holds them all.
    fn start(
        context: Context<'c>,
        (balls, pairs): (Vec<ClusterBall<'a>>, &[(usize, usize)]),
        starts: StartSearches,
        lists: &mut RunLists,
    ) -> Self {
        let (bodies_room, pairs_room) = run_room(balls.len(), pairs.len());
        let mut tables = std::mem::take(&mut lists.tables);
        let RunTables {
            moving: _,
            flights,
            resting,
            pairs: run_pairs,
            pairs_of,
            by_slot,
            agenda,
        } = &mut tables;
        flights.clear();
        flights.reserve(bodies_room);
        flights.extend(balls.iter().map(|b| b.cand.flight.clone()));
        pairs_of.reset(balls.len());
        for (p, (i, j)) in pairs.iter().enumerate() {
            pairs_of.push(*i, p);
            pairs_of.push(*j, p);
        }
        agenda.reset((balls.len(), pairs.len()), (bodies_room, pairs_room));
        for (k, found) in starts.grounds[..balls.len()].iter().enumerate() {
            agenda.ground(k, *found);
        }
        for (p, found) in starts.touches[..pairs.len()].iter().enumerate() {
            agenda.touch(p, found.flatten());
        }
        by_slot.clear();
        by_slot.extend(
            balls
                .iter()
                .enumerate()
                .map(|(k, b)| (b.cand.body.slot() as u32, k)),
        );
        resting.clear();
        resting.reserve(pairs_room);
        resting.resize(pairs.len(), false);
        run_pairs.clear();
        run_pairs.reserve(pairs_room);
        run_pairs.extend_from_slice(pairs);
        Run {
            context,
            balls,
            joined: Vec::new(),
            tables,
            starts,
        }
    }

    /// The run's bodies, those that joined it and its searches from the start; its lists
    /// handed back to `lists`, for the next run.
    fn finish(self, lists: &mut RunLists) -> (Vec<ClusterBall<'a>>, Vec<Joined>, StartSearches) {
        lists.tables = self.tables;
        (self.balls, self.joined, self.starts)
    }

    /// Body `k`'s ground impact at `t` (state `s`, `hit`), as `reconstruct::through_impacts`
    /// resolves one: it flies on from there; a settled impact holds gravity off the rest of
    /// the step. A ball rolling into another ground (a wall) moves on as after an impact with
    /// a body ([`Cluster::on_after_touch`]): on its plane it rolls on, lifted off it flies.
    /// Pushes the events; `None` where the model gives none.
    fn ground_event(
        &mut self,
        view: &mut AfterStep,
        k: usize,
        s: &State,
        t: f64,
        hit: &Hit,
    ) -> Option<()> {
        let (ball, step) = (&self.balls[k], self.context.step);
        let part = &ball.geom.parts[hit.part];
        let gg = &ball.grounds[hit.ground];
        let (point, points) = landing_point(part, gg, s, t, hit, view.config.flat_tolerance);
        let material =
            view.registry
                .material_of(self.context.colliders, part.handle, gg.handle, view.config);
        let (law, resting_speed) = (view.config.law, step.policy.resting_speed);
        let (body, timing) = (ball.cand.body, ImpactTiming::InStep);
        let input = ImpactInput::new(body, &ball.inertia, law, material, resting_speed, timing);
        let (mut after, event) = resolve(
            &input,
            &ball.geom,
            gg,
            s,
            t,
            &GroundContactAt::new(hit, point, points),
        )?;
        let settled = event.settled;
        view.commit.event(event);
        // A ball sent off may drive into a pair it rested in.
        for q in self.tables.pairs_of.of(k) {
            self.tables.resting[q] = false;
        }
        if let Motion::Rolling(_) = self.tables.moving[k].motion {
            let before = self.tables.moving[k].clone();
            let cluster = Cluster::of(&self.context, &self.balls);
            self.tables.moving[k] = cluster.on_after_touch(view, k, &before, after, t)?;
            return Some(());
        }
        let flight = &mut self.tables.flights[k];
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
        self.tables.moving[k] = Moving {
            state: after,
            t0: t,
            motion: Motion::Flight(self.tables.flights[k].clone()),
        };
        Some(())
    }

    /// Pair `p` touching at `te` (`touch`: parry's contact, for a pair not both centred
    /// balls). Returns the bodies whose motion changed (the first `count` of the array: none
    /// for a resting touch or a graze, both bodies after an impact), or `None` where the
    /// cluster cannot be moved alone. Pushes the impact's events.
    fn touch_event(
        &mut self,
        view: &mut AfterStep,
        p: usize,
        touch: Option<BodyTouch>,
        te: f64,
    ) -> Option<([usize; 2], usize)> {
        let cluster = Cluster::of(&self.context, &self.balls);
        let (i, j) = self.tables.pairs[p];
        let resolved = cluster.pair_impact(view, (i, j), &touch, &self.tables.moving, te);
        let Ok(resolved) = resolved else {
            self.tables.resting[p] = true;
            return Some(([i, j], 0));
        };
        let Some((after_i, after_j, pair_events)) = resolved else {
            // A graze is stepped over: the pair's next search starts after it.
            let found = cluster
                .touch(p, (i, j), &self.tables.moving, next_after(te))
                .ok()?;
            self.tables.agenda.touch(p, found);
            return Some(([i, j], 0));
        };
        view.commit.events(pair_events);
        for (k, after) in [(i, after_i), (j, after_j)] {
            if cluster.reaches_other_grounds(view, k, &after, cluster.step.dt - te) {
                return None;
            }
            self.tables.moving[k] =
                cluster.on_after_touch(view, k, &self.tables.moving[k], after, te)?;
        }
        // A ball that moved on may drive into a pair it rested in.
        for q in self.tables.pairs_of.of(i).chain(self.tables.pairs_of.of(j)) {
            self.tables.resting[q] = false;
        }
        Some(([i, j], 2))
    }

    /// Searches again, from the event's time `te`, the ground of each body the event changed
    /// (`at_event`) and each of its pairs but those from index `searched` on (added at `te`
    /// by [`Run::add_pair`], which searched them from there with the same states: the same
    /// search), the pair of two changed bodies once; a resting pair has no touch. `None`
    /// where a search gave up.
    fn search_again(&mut self, searched: usize, at_event: &mut AtEvent) -> Option<()> {
        let (changed, te) = (at_event.changed, at_event.t);
        let cluster = Cluster::of(&self.context, &self.balls);
        for &k in changed {
            self.tables
                .agenda
                .ground(k, cluster.ground(k, &self.tables.moving[k], te).ok()?);
        }
        let moving = &self.tables.moving;
        let mut at = |b: usize| at_event.state(moving, b);
        for (n, &k) in changed.iter().enumerate() {
            for q in self.tables.pairs_of.of(k).filter(|q| *q < searched) {
                let (a, b) = self.tables.pairs[q];
                if n == 1 && (a == changed[0] || b == changed[0]) {
                    continue;
                }
                let found = if self.tables.resting[q] {
                    None
                } else {
                    cluster.touch_from(q, (a, b), moving, te, &mut at).ok()?
                };
                self.tables.agenda.touch(q, found);
            }
        }
        Some(())
    }

    /// The pair plan's members near body `k`'s way on from `t` (its state there `s`), its
    /// motion changed there, into `way` (see [`Run::meets_other_body`]): those whose swept
    /// box in the pair index (its travel over the step from its start-of-step motion, the
    /// plan's margin included), widened by `k`'s bounding radius and its acceleration's bow,
    /// the segment of `k`'s way on (from its centre at `t` along its velocity to the step's
    /// end) crosses, `k` itself left out, in the order of their slots; and, where there are
    /// any, the slots of the bodies `k` has a pair with in the cluster, sorted. Reads only.
    fn way_on(&self, k: usize, s: &State, t: f64, way: &mut WayOn) {
        let (ball, step) = (&self.balls[k], self.context.step);
        let left = step.dt - t;
        let widen = ball.geom.radius + ball.cand.flight.accel.norm() * left * left;
        let path = s.v * left;
        let end = s.com + path;
        let query = Aabb::new(
            vec_from_na(&s.com.inf(&end).add_scalar(-widen)),
            vec_from_na(&s.com.sup(&end).add_scalar(widen)),
        );
        let own = ball.cand.body.slot() as u32;
        (way.com, way.v) = (s.com, s.v);
        way.next = 0;
        way.partners.clear();
        way.near.clear();
        way.near.extend(
            self.context
                .near
                .index
                .leaves_meeting(&query)
                .filter(|(slot, aabb)| *slot != own && segment_crosses(&s.com, &path, aabb, widen))
                .map(|(slot, aabb)| NearLeaf {
                    slot,
                    aabb,
                    may_pair: None,
                }),
        );
        // The lowest slot first, whatever order the index gives them in.
        way.near.sort_unstable_by_key(|leaf| leaf.slot);
        if !way.near.is_empty() {
            way.partners.extend(self.tables.pairs_of.of(k).map(|q| {
                let (a, b) = self.tables.pairs[q];
                self.balls[if a == k { b } else { a }].cand.body.slot() as u32
            }));
            way.partners.sort_unstable();
        }
    }

    /// A body that body `k`, its motion changed where `way` was found ([`Run::way_on`]), may
    /// reach before the step's end and has no pair with in the cluster, if any: the one of
    /// lowest slot among those near its way on. A body of the cluster so found joins a pair
    /// whose search decides; one outside it must also be closing on `k` (its velocity as
    /// rapier's step leaves it), as moving it with the cluster moves the whole cluster
    /// again. Whether a pair may be the model's is asked once per body near the way (kept in
    /// `way`), as the cluster grows by what this finds. The caller pairs `k` with the body
    /// found (or ends the run): `way` counts it a partner from here, and the next search goes
    /// on after it where it is a member (the pair changes nothing the leaves before it were
    /// passed by for), or from the first leaf where it joins from outside (a body that joins
    /// with it may be one passed by for not closing, now a member). Reads only, besides `way`.
    fn meets_other_body(&self, k: usize, way: &mut WayOn) -> Option<Reached> {
        let body_k = self.balls[k].cand.body;
        let WayOn {
            com,
            v,
            near: leaves,
            next,
            partners,
        } = way;
        let (com, v, partners) = (*com, *v, &*partners);
        let found = leaves[*next..]
            .iter_mut()
            .enumerate()
            .find_map(|(i, leaf)| {
                if partners.binary_search(&leaf.slot).is_ok() {
                    return None;
                }
                let reached = self.reaches(body_k, leaf, (com, v))?;
                Some((i, leaf.slot, reached))
            });
        let (i, slot, reached) = found?;
        // Not a partner yet (partners are passed by above): kept sorted.
        let at = way.partners.partition_point(|p| *p < slot);
        way.partners.insert(at, slot);
        way.next = match reached {
            Reached::Member(_) => way.next + i + 1,
            Reached::Outside(_) => 0,
        };
        Some(reached)
    }

    /// Whether a body whose way on starts at `com` with velocity `v` (m, m/s) may reach the
    /// body of `leaf`, which is not its partner (see [`Run::meets_other_body`]): a member of
    /// the cluster whose pair with `body_k` may be the model's, or a body outside it also
    /// closing on it. The pair's answer is kept in `leaf`.
    fn reaches(
        &self,
        body_k: RigidBodyHandle,
        leaf: &mut NearLeaf,
        (com, v): (nalgebra::Vector3<f64>, nalgebra::Vector3<f64>),
    ) -> Option<Reached> {
        let near = self.context.near;
        let (rb, body) = near.bodies.get_unknown_gen(leaf.slot)?;
        let mut may_pair = || {
            *leaf
                .may_pair
                .get_or_insert_with(|| near.may_pair(body_k, body))
        };
        match self.tables.by_slot.get(&leaf.slot) {
            Some(j) => may_pair().then_some(Reached::Member(*j)),
            None => {
                let towards = vec_to_na(leaf.aabb.center()) - com;
                let closing = towards.dot(&(v - vec_to_na(rb.linvel()))) > 0.0;
                (closing && may_pair()).then_some(Reached::Outside(body))
            }
        }
    }

    /// Takes `body` into the cluster, a body from outside it that member `k`, its motion
    /// changed at `te`, may reach, with what `joining` admits with it (the rest of its own
    /// cluster), where none of them has an event of its own before `te` (a ground impact, or
    /// a touch of two of them): each moves from its start-of-step state by its own motion, as
    /// it would in the cluster moved again from the start with them (until `te` nothing of
    /// the cluster reached them). The met body's index in the cluster; `Some(None)` where it
    /// cannot join here (where admitted, its group's balls and searches from the start are
    /// kept last in the run's, for a run again with them: the run ends); `None` where a
    /// search gave up.
    fn join(
        &mut self,
        view: &AfterStep,
        joining: &Joining<'_, 'a>,
        k: usize,
        body: RigidBodyHandle,
        te: f64,
    ) -> Option<Option<usize>> {
        let base = self.balls.len();
        let Some(group) = (joining.admit)(view, body, &mut self.balls) else {
            return Some(None);
        };
        let admitted = &self.balls[base..];
        self.tables.moving.extend(admitted.iter().map(start_moving));
        // Searched from the start, as a run again with them would: kept for it in `starts`,
        // each pair named by its index among the cluster's pairs in a run again.
        debug_assert_eq!(self.starts.grounds.len(), base);
        let again = self.starts.touches.len();
        {
            let cluster = Cluster::of(&self.context, &self.balls);
            for j in base..self.balls.len() {
                let found = cluster.ground(j, &self.tables.moving[j], 0.0).ok()?;
                self.starts.grounds.push(found);
            }
            for (q, (i, j)) in group.pairs.iter().enumerate() {
                let pair = (base + i, base + j);
                let found = cluster
                    .touch(again + q, pair, &self.tables.moving, 0.0)
                    .ok()?;
                self.starts.touches.push(Some(found));
            }
        }
        let before = |e: &Option<(f64, Next)>| e.as_ref().is_some_and(|(t, _)| *t < te);
        let mut touches = self.starts.touches[again..].iter().flatten();
        if self.starts.grounds[base..].iter().any(before) || touches.any(before) {
            return Some(None);
        }
        // The pair of `k` and the body met is searched from `te`, not from the start.
        self.starts.touches.push(None);
        for j in base..self.balls.len() {
            self.tables.flights.push(self.balls[j].cand.flight.clone());
            self.tables.pairs_of.add_body();
            self.tables
                .by_slot
                .insert(self.balls[j].cand.body.slot() as u32, j);
            self.tables.agenda.add_body();
            self.tables.agenda.ground(j, self.starts.grounds[j]);
        }
        for (q, (i, j)) in group.pairs.iter().enumerate() {
            let p = self.tables.pairs.len();
            self.tables.pairs.push((base + i, base + j));
            self.tables.pairs_of.push(base + i, p);
            self.tables.pairs_of.push(base + j, p);
            self.tables.resting.push(false);
            self.tables.agenda.add_pair();
            let found = self.starts.touches[again + q].flatten();
            self.tables
                .agenda
                .touch(p, found.map(|(t, next)| (t, next.as_pair(p))));
        }
        let met = base + group.met;
        self.joined.push(Joined { member: k, group });
        Some(Some(met))
    }

    /// Joins bodies `k` and `j` of the cluster in a pair searched from the time of the event
    /// that changed `at_event`'s bodies (before, each moved as the pair plan had them
    /// apart). `None` where the search gave up.
    fn add_pair(&mut self, k: usize, j: usize, at_event: &mut AtEvent) -> Option<()> {
        let t = at_event.t;
        let p = self.tables.pairs.len();
        self.tables.pairs.push((k, j));
        self.tables.pairs_of.push(k, p);
        self.tables.pairs_of.push(j, p);
        self.tables.resting.push(false);
        self.tables.agenda.add_pair();
        let cluster = Cluster::of(&self.context, &self.balls);
        let moving = &self.tables.moving;
        let mut at = |b: usize| at_event.state(moving, b);
        let found = cluster.touch_from(p, (k, j), moving, t, &mut at).ok()?;
        self.tables.agenda.touch(p, found);
        Some(())
    }

    /// Every body's state at the step's end, or `None` when a rolling ball is no longer on
    /// its plane there (a cuboid's face it left, or a mesh, would need the ground's other
    /// faces).
    fn ends(&self) -> Option<Vec<State>> {
        ends_of(self.context.step, &self.balls, &self.tables.moving)
    }
}

/// Every body's state at the step's end, each moving as `moving` has it (see [`Run::ends`]).
fn ends_of(step: &EndOfStep, balls: &[ClusterBall], moving: &[Moving]) -> Option<Vec<State>> {
    let dt = step.dt;
    let ends: Vec<State> = moving.iter().map(|m| m.at(dt)).collect();
    for (k, ball) in balls.iter().enumerate() {
        if let (Motion::Rolling(rolling), Some(g)) = (&moving[k].motion, ball.rolling_on) {
            let hit = closest(
                &ball.geom,
                &ball.grounds[g..=g],
                &ends[k],
                dt,
                step.policy.resting_gap,
            )?;
            if !on_plane(hit.dist, &hit.normal, &rolling.normal, rolling.radius) {
                return None;
            }
        }
    }
    Some(ends)
}

impl Cluster<'_, '_> {
    /// Body `k`'s first ground impact after `t`, `Err` where the search gave up (the cluster
    /// is not moved alone). A rolling ball meets its other grounds (a wall, a slope's foot)
    /// along its rolling, as the bodies stage's rolling ball does (`rolling_touch`), and
    /// never its own plane.
    fn ground(&self, k: usize, m: &Moving, t: f64) -> Result<Option<(f64, Next)>, ()> {
        let ball = &self.balls[k];
        let flight = match &m.motion {
            Motion::Flight(flight) => flight,
            Motion::Rolling(_) => return Ok(self.rolled_into(k, m, t)),
        };
        if ball.grounds.is_empty() {
            return Ok(None);
        }
        match first_impact(
            &ball.geom,
            &ball.grounds,
            flight,
            &m.state,
            m.t0,
            t,
            self.step.dt,
        ) {
            Search::Hit(th, s, hit) => Ok(Some((th, Next::Ground(k, s, hit)))),
            Search::Stalled(..) => Err(()),
            Search::Clear => Ok(None),
        }
    }

    /// Pair `p` of bodies `i` and `j`: its first touch after `t` while approaching, `Err`
    /// where the search gave up.
    fn touch(
        &self,
        p: usize,
        pair: (usize, usize),
        moving: &[Moving],
        t: f64,
    ) -> Result<Option<(f64, Next)>, ()> {
        self.touch_from(p, pair, moving, t, &mut |k| moving[k].at(t))
    }

    /// [`Cluster::touch`], where `at` gives a body's state at `t` (`moving[k].at(t)`, kept
    /// by a caller searching several pairs of a body from `t`).
    fn touch_from(
        &self,
        p: usize,
        (i, j): (usize, usize),
        moving: &[Moving],
        t: f64,
        at: &mut impl FnMut(usize) -> State,
    ) -> Result<Option<(f64, Next)>, ()> {
        let (bi, bj) = (&self.balls[i], &self.balls[j]);
        let dt = self.step.dt;
        let found = match (bi.radius, bj.radius) {
            (Some(ri), Some(rj)) => {
                let (a, b) = (&moving[i], &moving[j]);
                first_touch((a, b), (at(i), at(j)), ri + rj, t, dt)
                    .map_err(|_| ())?
                    .map(|tc| (tc, None))
            }
            _ => {
                let mover = |k: usize| Mover {
                    geom: &self.balls[k].geom,
                    moving: &moving[k],
                    turns: self.balls[k].radius.is_none(),
                };
                first_body_touch(&mover(i), &mover(j), t, dt)
                    .map_err(|_| ())?
                    .map(|(tc, touch)| (tc, Some(touch)))
            }
        };
        Ok(found.map(|(tc, touch)| (tc, Next::Touch(p, touch))))
    }

    /// The model's impulse for the pair of bodies `i` and `j` touching at `te`, the bodies where
    /// `moving` has them then: along the line of centres for two centred balls, at parry's contact
    /// `touch` (with the flat-landing points of `touch_point`) otherwise; `Err` for a touch slower
    /// than the resting speed. Reads only.
    ///
    /// A touch slower than the resting speed is a resting contact from here: the next step
    /// hands it to rapier's solver (`Resting`). Resolving it with e = 0 would not end:
    /// bodies left touching at nearly the same speed behind a chain would meet again and
    /// again, in ever smaller impacts.
    fn pair_impact(
        &self,
        view: &AfterStep,
        (i, j): (usize, usize),
        touch: &Option<BodyTouch>,
        moving: &[Moving],
        te: f64,
    ) -> Result<Resolved, SlowTouch> {
        let balls = self.balls;
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
            view.registry.pair_material_of(
                self.colliders,
                balls[i].collider,
                balls[j].collider,
                view.config,
            ),
            self.step.policy.resting_speed,
            ImpactTiming::InStep,
        );
        let closing = match touch {
            None => {
                let line = (sj.state.com - si.state.com).normalize();
                (si.state.v - sj.state.v).dot(&line)
            }
            Some(touch) => -touch.rate,
        };
        if rests_at(closing, self.step.policy.resting_speed) {
            return Err(SlowTouch);
        }
        Ok(match touch {
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
        })
    }

    /// Rolling body `k`'s first touch after `t` with one of its grounds besides the one it
    /// rolls on (they come first in its list), while closing on it: sampled along the
    /// rolling ([`earliest_touch`], which a graze between two samples passes: the end check
    /// catches it).
    fn rolled_into(&self, k: usize, m: &Moving, t: f64) -> Option<(f64, Next)> {
        let (ball, step) = (&self.balls[k], self.step);
        let others = &ball.grounds[..ball.rolling_on?];
        let left = step.dt - t;
        if others.is_empty() || left <= 0.0 {
            return None;
        }
        let reach = step.policy.contact_margin();
        let at = |after: f64| {
            let s = m.at(t + after);
            let hit = closest(&ball.geom, others, &s, t + after, reach);
            (s, hit)
        };
        let after = earliest_touch(left, |after| at(after).1.is_some_and(|h| h.dist <= 0.0))?;
        let (s, hit) = at(after);
        let hit = hit.filter(|h| h.un < 0.0)?;
        Some((t + after, Next::Ground(k, s, hit)))
    }

    /// Can body `k`, leaving an impact at `s` with `left` seconds of the step to go, reach a
    /// ground it was not planned against, along its way on? Its grounds came from its
    /// start-of-step speed, and a hit from a heavier body can send it much faster; the
    /// cluster cannot be moved alone then. Reads only.
    fn reaches_other_grounds(&self, view: &AfterStep, k: usize, s: &State, left: f64) -> bool {
        let (ball, step) = (&self.balls[k], self.step);
        let accel = ball.cand.flight.accel.norm();
        let margin = step.policy.contact_margin();
        let way = WayBound::new(s, accel, ball.geom.radius, left, margin);
        let (centre, half) = (vec_from_na(&way.centre), to_real(way.cube_half()));
        // A ball that met a slab's tiles one by one has tiles among its grounds.
        let tiles = ball
            .geom
            .parts
            .iter()
            .any(|part| step.by_tile.contains(&part.handle));
        view.registry
            .index
            .near_cube(&step.grounds, centre, half, tiles)
            .iter()
            .any(|i| {
                !ball
                    .grounds
                    .iter()
                    .any(|g| g.handle == step.grounds[*i].handle)
            })
    }

    /// How body `k` moves on after an impact with another body (or, rolling, with a ground besides
    /// its plane) left it at `after` (time `t`): as before, but a ball rolling on its ground flies
    /// when lifted off it, and rolls on when pressed into it (the ground takes the normal speed: a
    /// `Settle` event, pushed). `None` where the closed form of its rolling does not reach the
    /// step's end.
    fn on_after_touch(
        &self,
        view: &mut AfterStep,
        k: usize,
        before: &Moving,
        mut after: State,
        t: f64,
    ) -> Option<Moving> {
        let ball = &self.balls[k];
        let (Motion::Rolling(rolling), Some(g)) = (&before.motion, ball.rolling_on) else {
            return Some(Moving {
                state: after,
                t0: t,
                motion: before.motion.clone(),
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
                motion: Motion::Flight(ball.cand.flight.clone()),
            });
        }
        // Rolling on, where the closed form reaches (on a slope: along the fall line).
        let on_ground = State {
            v: after.v - n * vn,
            ..after
        };
        rolling.advance_checked(&on_ground, self.step.dt - t)?;
        if vn < 0.0 {
            // Pressed into the ground: the ground takes the normal speed (an impulse through
            // the centre, e = 0).
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
            motion: Motion::Rolling(*rolling),
        })
    }
}

/// A body of the cluster at its start-of-step state, rolling in closed form on its ground or
/// flying.
fn start_moving(ball: &ClusterBall) -> Moving {
    Moving {
        state: ball.cand.start,
        t0: 0.0,
        motion: match &ball.cand.rolling {
            Some((_, rolling)) => Motion::Rolling(*rolling),
            None => Motion::Flight(ball.cand.flight.clone()),
        },
    }
}

/// Does the segment from `from` along `way` cross the box `aabb` widened by `widen` on every
/// side (the slabs' test)?
fn segment_crosses(
    from: &nalgebra::Vector3<f64>,
    way: &nalgebra::Vector3<f64>,
    aabb: &Aabb,
    widen: f64,
) -> bool {
    let (lo, hi) = (vec_to_na(aabb.mins), vec_to_na(aabb.maxs));
    let (mut enter, mut leave) = (0.0f64, 1.0f64);
    for axis in 0..3 {
        let (lo, hi) = (lo[axis] - widen, hi[axis] + widen);
        let (p, d) = (from[axis], way[axis]);
        if d == 0.0 {
            if p < lo || p > hi {
                return false;
            }
            continue;
        }
        let (a, b) = ((lo - p) / d, (hi - p) / d);
        enter = enter.max(a.min(b));
        leave = leave.min(a.max(b));
        if enter > leave {
            return false;
        }
    }
    true
}

/// The smallest time after `t` that differs from it.
fn next_after(t: f64) -> f64 {
    t + f64::EPSILON * t.abs().max(TIME_ULP_FLOOR)
}
