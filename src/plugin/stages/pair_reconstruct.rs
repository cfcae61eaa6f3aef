//! Reconstruct, for impacts between bodies: a cluster of bodies (those joined by the step's
//! `Impact` pairs) moved together over the step from their start states, as they would have
//! moved had rapier not solved those pairs.
//!
//! Contract: [`move_clusters`] finds the clusters whose every body moved alone in the step and
//! commits what [`through_pair_impacts`] gives for each; [`through_pair_impacts`] takes a cluster
//! each of whose bodies moved alone in the step (no contact rapier's solver pushed it by, no joint
//! or torque: checked by the caller) and moves every body by its own motion (`crate::motion`: free
//! flight, or for a ball rolling in closed form on its level ground) to the cluster's earliest
//! event: a body's ground impact (the in-step search of `queries/geometry/impact_time.rs`) or two
//! bodies touching (two centred balls in closed form, `motion::meeting`; any other pair by
//! conservative advancement on parry's distance, `body_contact.rs`), resolved by the model
//! (`resolve.rs`; a flat face on a face as one impact at the centroid of their overlap's corners),
//! then on to the next, in time order, both bodies of a pair updated between events (each body's
//! and pair's next event is searched once and again only when one of its bodies changed, so an
//! event costs the searches of its two bodies, not of the whole cluster): a chain (a ball passing
//! an impact on to the one it touches) is a sequence of impacts at the same time, in the order the
//! touches are found; a touch slower than the resting speed is a resting contact from there on
//! (rapier's next step). A ball rolling on its ground that an impact lifts flies from there;
//! pressed into the ground, the ground takes the normal speed (a `Settle` event) and it rolls on.
//! It returns every body's state at the step's end and reports every impulse as an event, or why
//! the cluster cannot be moved alone as it is (`Unmoved`): a search that stalls, more events than
//! `max_impacts_per_step` per body, a rolling ball leaving its plane, a body sent off by an event
//! reaching a ground it was not planned against, or reaching a member of the pair plan it has no
//! pair with (by that body's swept box in the pair index). In that last case the body, alone or
//! with the whole of its own cluster, joins the run where it is met, with the pair, when they can
//! be moved with the cluster and none of them has an event of its own before (nothing of the
//! cluster reached them sooner: the same run as the cluster moved again from its start with them);
//! where one has, [`move_clusters`] adds them and the pair and moves the cluster again; otherwise,
//! and in every other case, the cluster's events are withdrawn, rapier's end state stands, and the
//! settle stage checks the pairs. It writes nothing into rapier.
//!
//! Its parts: forming the clusters and committing their end states (here), the cluster's
//! motion event by event (`cluster.rs`), the agenda of its next events (`agenda.rs`), and
//! each body's pairs in a run (`pairs_of.rs`).

mod agenda;
mod cluster;
mod pairs_of;

pub(crate) use cluster::through_pair_impacts;
use cluster::{Joined, Joining, RunLists, StartSearches, Unmoved, run_room};

use crate::motion::State;
use crate::plugin::bridge::convert::to_f64;
use crate::plugin::bridge::resolve::Inertia;
use crate::plugin::config::TimingMode;
use crate::plugin::policy::{EndCheck, Role, model_may_pair};
use crate::plugin::queries::geometry::{BodyGeom, GroundGeom};
use crate::plugin::queries::observe::{body_geom, centred_ball, held_or_by_unseen};
use crate::plugin::stages::commit::Origin;
use crate::plugin::stages::pair_plan::PairIndex;
use crate::plugin::stages::reconstruct::{FlownEnd, ccd_consistent};
use crate::plugin::stages::settle::Checked;
use crate::plugin::stages::view::AfterStep;
use crate::plugin::stages::view::EndOfStep;
use crate::plugin::state::handles::{HandleMap, HandleSet, Slotted};
use crate::plugin::state::small_list::SmallList;
use crate::plugin::state::step::Candidate;
use crate::plugin::state::step::PlannedPair;
use crate::rapier::math::Vector;
use crate::rapier::prelude::{ColliderHandle, ColliderSet, RigidBodyHandle, RigidBodySet};
use std::borrow::Cow;

/// Where a cluster finds the bodies outside its pairs that a body it sends off may meet: the
/// pair plan's members, by their swept boxes (`PairIndex`), and rapier's bodies, for the
/// handle of a box's slot; and whether a pair so found may be the model's.
pub(crate) struct NearBodies<'a> {
    pub index: &'a PairIndex,
    pub bodies: &'a RigidBodySet,
    /// Would rapier not solve the pair of the two bodies, or the user's filter refuse it?
    pub refused: &'a dyn Fn(RigidBodyHandle, RigidBodyHandle) -> bool,
}

impl NearBodies<'_> {
    /// May the pair of `a` and `b`, not planned, be the model's: rapier would solve it, the
    /// user's filter accepts it, and their dominance groups allow it (`model_may_pair`)?
    pub fn may_pair(&self, a: RigidBodyHandle, b: RigidBodyHandle) -> bool {
        let group =
            |h: RigidBodyHandle| self.bodies.get(h).map(|rb| rb.effective_dominance_group());
        let groups = group(a).zip(group(b));
        groups.is_some_and(|(ga, gb)| model_may_pair(ga, gb)) && !(self.refused)(a, b)
    }
}

/// How many times a cluster is moved again from its start with a body from outside it (a
/// body of another cluster, taken in with the whole of its cluster, or one that had an event
/// of its own before it was met) before it is left to the settle stage, its next impacts in
/// the next step: each run costs the whole cluster. A body in no cluster joins the run it is
/// met in, at the cost of its own searches, and does not count, nor does a body of the
/// cluster reached on the way (it joins a pair).
const MAX_CLUSTER_RESTARTS: usize = 8;

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
/// bodies) whose every body moved alone in the step (no contact rapier's solver pushed it by, no
/// joint, torque or `Step` impulse, rapier's CCD consistent with its motion), in
/// `TimeOfImpact` and `Exact` modes: moved together from their start states
/// ([`through_pair_impacts`]), checked against their grounds (`EndCheck::Flown`) and
/// written. A body an event sends towards another member of the pair plan it has no pair
/// with grows the cluster by that pair, where rapier would solve it and the other body (with
/// its later cluster, if it has one) can be moved with the cluster: it joins the run there
/// (`admit` below), or where it had an event of its own before, the cluster is moved again
/// with it ([`Growing::take_in`]); otherwise the cluster is left to the settle stage. Returns
/// the bodies written, and how many runs moved the clusters.
pub(crate) fn move_clusters(
    view: &mut AfterStep,
    bodies: &RigidBodySet,
    colliders: &ColliderSet,
    near: &NearBodies,
    step: &EndOfStep,
) -> (HandleSet<RigidBodyHandle>, usize) {
    let mut written = HandleSet::default();
    let mut runs = 0;
    let impacts: Vec<_> = step
        .pairs
        .pairs
        .iter()
        .filter(|p| p.role == Role::Impact)
        .collect();
    if impacts.is_empty() || view.config.timing == TimingMode::Step {
        return (written, runs);
    }
    let cands = CandidatesByBody::new(step);
    let clusters = Clusters::of(&impacts);
    // The later clusters taken in whole by an earlier one (moved with it).
    let mut absorbed = vec![false; clusters.len()];
    // The runs' lists, and the clusters' searches from the start, handed from one run to
    // the next, with room for the largest cluster's.
    let (most_members, most_pairs) = clusters.largest();
    let mut lists = RunLists::with_room(most_members, most_pairs);
    let mut starts = StartSearches::with_room(most_members, most_pairs);
    // The list of a cluster's balls, emptied for the next cluster once it is done with.
    let mut spare_balls = Vec::with_capacity(run_room(most_members, most_pairs).0);
    let reads = StageReads {
        bodies,
        colliders,
        near,
        step,
        cands: &cands,
        clusters: &clusters,
    };
    for c in 0..clusters.len() {
        if absorbed[c] {
            continue;
        }
        let (members, pairs) = (clusters.members(c), clusters.pairs(c));
        let mut growing = Growing::new(c, members, pairs);
        let from = view.commit.reported().len();
        // The balls of the members so far, in their order: a cluster moved again keeps them
        // (nothing they read changes before the clusters are written) and checks and
        // builds only the bodies it took in.
        let mut balls = std::mem::take(&mut spare_balls);
        starts.clear();
        let tables = (&mut lists, &mut starts, &mut absorbed);
        let moved = run_cluster(view, &reads, &mut growing, &mut balls, tables, &written);
        runs += moved.runs;
        match moved.ends {
            Some(ends) => {
                let sets = (bodies, colliders, step);
                commit_moved(view, sets, (&balls, ends), from, &mut written);
            }
            // Not moved: each cluster it took in is moved on its own.
            None => {
                for later in growing.taken {
                    absorbed[later] = false;
                }
            }
        }
        spare_balls = balls;
        spare_balls.clear();
    }
    (written, runs)
}

/// What every run of a step's clusters reads: rapier's sets, the bodies near the clusters,
/// the step, its candidates by body and its clusters.
struct StageReads<'r, 's> {
    bodies: &'r RigidBodySet,
    colliders: &'s ColliderSet,
    near: &'r NearBodies<'r>,
    step: &'r EndOfStep<'s>,
    cands: &'r CandidatesByBody<'s>,
    clusters: &'r Clusters,
}

/// A cluster's runs: how many were made, and the end states of its balls (left in `balls`)
/// where the last one moved it (`None`: it is not moved).
struct ClusterRuns {
    runs: usize,
    ends: Option<Vec<State>>,
}

/// Moves `growing` from its start with `balls` (those of its first members already built),
/// again each time it meets a body it can take in ([`Growing::take_in`]), until it is
/// moved, gives up or meets a body it cannot take in. `tables`: the runs' lists and start
/// searches handed from run to run, and the clusters taken in whole so far.
fn run_cluster<'r, 's>(
    view: &mut AfterStep,
    reads: &StageReads<'r, 's>,
    growing: &mut Growing<'r>,
    balls: &mut Vec<ClusterBall<'s>>,
    (lists, starts, absorbed): (&mut RunLists, &mut StartSearches, &mut Vec<bool>),
    written: &HandleSet<RigidBodyHandle>,
) -> ClusterRuns {
    let StageReads {
        bodies,
        colliders,
        near,
        step,
        cands,
        clusters,
    } = *reads;
    let c = growing.cluster;
    let mut runs = 0;
    let ends = loop {
        let taken_in = &growing.members[balls.len()..];
        if !moves_alone(view, (bodies, colliders), cands, taken_in) {
            break None;
        }
        let sets = (bodies, colliders);
        if cluster_balls(view, sets, cands, taken_in, balls).is_none() {
            break None;
        }
        // A body met on the way, alone or with its later cluster, that moves alone and
        // was not moved yet, joins the run.
        let admit = |view: &AfterStep, other: RigidBodyHandle, balls: &mut Vec<_>| {
            let sets = (clusters, cands, written);
            admitted(view, (bodies, colliders), sets, absorbed, (c, other), balls)
        };
        let joining = Joining { admit: &admit };
        let context = (colliders, near, step);
        runs += 1;
        let started = (std::mem::take(balls), &growing.pairs[..]);
        let searched = (std::mem::take(starts), &mut *lists);
        let moved = through_pair_impacts(view, context, started, searched, &joining);
        growing.joined(moved.joined, absorbed);
        *starts = moved.starts;
        *balls = moved.balls;
        match moved.ends {
            Ok(ends) => break Some(ends),
            Err(Unmoved::GaveUp) => break None,
            Err(Unmoved::Meets { member, other }) => {
                // The run's balls: the members', those that joined it included, and
                // those of `other`'s group where it was admitted (the group `take_in`
                // adds: nothing it reads changed), which are then not built again.
                debug_assert!(balls.len() >= growing.members.len());
                let sets = (clusters, cands, written);
                if !growing.take_in(sets, absorbed, member, other) {
                    break None;
                }
                debug_assert!(balls.len() <= growing.members.len());
            }
        }
    };
    ClusterRuns { runs, ends }
}

/// What comes with `other`, met by a body of cluster `c` from outside it, where all of it
/// moves alone and can be moved with the cluster ([`group_of`]): its bodies, their balls
/// pushed onto `balls` (the run's, left as they were where it cannot).
fn admitted<'c>(
    view: &AfterStep,
    (bodies, colliders): (&RigidBodySet, &'c ColliderSet),
    sets: (
        &Clusters,
        &CandidatesByBody<'c>,
        &HandleSet<RigidBodyHandle>,
    ),
    absorbed: &[bool],
    (c, other): (usize, RigidBodyHandle),
    balls: &mut Vec<ClusterBall<'c>>,
) -> Option<Group<'static>> {
    let cands = sets.1;
    let group = group_of(sets, absorbed, c, other)?;
    let members = &group.bodies[..];
    if !moves_alone(view, (bodies, colliders), cands, members) {
        return None;
    }
    let base = balls.len();
    if cluster_balls(view, (bodies, colliders), cands, members, balls).is_none() {
        // The members before the one that failed were added.
        balls.truncate(base);
        return None;
    }
    Some(group.into_owned())
}

/// Records a moved cluster's end states (`ends`, in `balls`' order; its events are the
/// commit's from `from` on), each checked against its grounds first, and adds its bodies to
/// `written`.
fn commit_moved(
    view: &mut AfterStep,
    (bodies, colliders, step): (&RigidBodySet, &ColliderSet, &EndOfStep),
    (balls, ends): (&[ClusterBall], Vec<State>),
    from: usize,
    written: &mut HandleSet<RigidBodyHandle>,
) {
    for (ball, end) in balls.iter().zip(ends) {
        // Never left inside a ground. No energy cap: an impact between bodies passes
        // energy from one to the other, so the body hit may end above its start energy.
        let checked = Checked {
            body: ball.cand.body,
            geom: &ball.geom,
            inertia: &ball.inertia,
            cand: None,
            grounds: &ball.grounds,
            joined: ball.grounds.len(),
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

/// A cluster as it grows by the bodies its events send its bodies towards: its members and
/// pairs (the plan's, then those taken in), and the later clusters it took in whole.
struct Growing<'c> {
    /// Its index among the step's clusters.
    cluster: usize,
    members: Cow<'c, [RigidBodyHandle]>,
    pairs: Cow<'c, [(usize, usize)]>,
    /// How many times it was moved again from its start with bodies from outside it.
    restarts: usize,
    taken: Vec<usize>,
}

impl<'c> Growing<'c> {
    fn new(cluster: usize, members: &'c [RigidBodyHandle], pairs: &'c [(usize, usize)]) -> Self {
        Self {
            cluster,
            members: Cow::Borrowed(members),
            pairs: Cow::Borrowed(pairs),
            restarts: 0,
            taken: Vec::new(),
        }
    }

    /// The bodies that joined the cluster on the way (`through_pair_impacts`), in the order
    /// they joined: a cluster moved again starts with them.
    fn joined(&mut self, joined: Vec<Joined>, absorbed: &mut [bool]) {
        for Joined { member, group } in joined {
            self.add(member, &group, absorbed);
        }
    }

    /// Takes in `other`, which member `member` may reach (a pair that may be the model's:
    /// `meets_other_body` found only such), with their pair and the rest of its later
    /// cluster (`group_of`), moving the cluster again from its start, at most
    /// [`MAX_CLUSTER_RESTARTS`] times. `false` where it cannot.
    fn take_in(
        &mut self,
        sets: (&'c Clusters, &CandidatesByBody, &HandleSet<RigidBodyHandle>),
        absorbed: &mut [bool],
        member: usize,
        other: RigidBodyHandle,
    ) -> bool {
        if self.restarts >= MAX_CLUSTER_RESTARTS {
            return false;
        }
        let Some(group) = group_of(sets, absorbed, self.cluster, other) else {
            return false;
        };
        self.restarts += 1;
        self.add(member, &group, absorbed);
        true
    }

    /// Adds `group`'s bodies and pairs, and its pair with member `member`; a later cluster
    /// it is is taken in whole (moved with this one).
    fn add(&mut self, member: usize, group: &Group, absorbed: &mut [bool]) {
        let offset = self.members.len();
        self.members.to_mut().extend(group.bodies.iter());
        let shifted = group.pairs.iter().map(|(i, j)| (i + offset, j + offset));
        self.pairs.to_mut().extend(shifted);
        self.pairs.to_mut().push((member, offset + group.met));
        if let Some(later) = group.cluster {
            absorbed[later] = true;
            self.taken.push(later);
        }
    }
}

/// The bodies that come with a body met from outside a cluster: it alone, or the whole of
/// its later cluster.
pub(crate) struct Group<'c> {
    pub bodies: Cow<'c, [RigidBodyHandle]>,
    /// Their `Impact` pairs, as indices into `bodies`.
    pub pairs: Cow<'c, [(usize, usize)]>,
    /// The body met, as an index in `bodies`.
    pub met: usize,
    /// Its cluster, if it has one (a later one).
    pub cluster: Option<usize>,
}

impl Group<'_> {
    /// The same group, owning its lists (kept past the step's clusters' borrow).
    fn into_owned(self) -> Group<'static> {
        Group {
            bodies: Cow::Owned(self.bodies.into_owned()),
            pairs: Cow::Owned(self.pairs.into_owned()),
            met: self.met,
            cluster: self.cluster,
        }
    }
}

/// What comes with `other`, met by a body of cluster `cluster`, where it can be moved with
/// it: a body with a plan in no cluster, alone; a body of a later cluster not taken in
/// yet, with the whole of it; never a body another cluster moved already. `None` otherwise.
fn group_of<'c>(
    (clusters, cands, written): (&'c Clusters, &CandidatesByBody, &HandleSet<RigidBodyHandle>),
    absorbed: &[bool],
    cluster: usize,
    other: RigidBodyHandle,
) -> Option<Group<'c>> {
    if written.contains(&other) {
        return None;
    }
    match clusters.of_body(&other) {
        None => cands.get(&other).map(|_| Group {
            bodies: Cow::Owned(vec![other]),
            pairs: Cow::Borrowed(&[]),
            met: 0,
            cluster: None,
        }),
        Some(later) if later > cluster && !absorbed[later] => {
            let bodies = clusters.members(later);
            Some(Group {
                bodies: Cow::Borrowed(bodies),
                pairs: Cow::Borrowed(clusters.pairs(later)),
                met: bodies.iter().position(|h| *h == other)?,
                cluster: Some(later),
            })
        }
        Some(_) => None,
    }
}

/// The step's candidates by body.
struct CandidatesByBody<'s> {
    step: &'s EndOfStep<'s>,
    index: CandidateIndex,
}

/// Where each body's candidate is in the step's list (the last, should a body have two).
enum CandidateIndex {
    /// By the body's slot (`u32::MAX`: none), where the candidates' slots are few enough
    /// next to their number that the table costs no more than they do.
    BySlot(Vec<u32>),
    /// By body, where the slots are spread out.
    ByBody(HandleMap<RigidBodyHandle, usize>),
}

/// The most slots a [`CandidateIndex::BySlot`] table has per candidate.
const SLOTS_PER_CANDIDATE: usize = 4;

impl<'s> CandidatesByBody<'s> {
    fn new(step: &'s EndOfStep<'s>) -> Self {
        let cands = &step.candidates;
        let slots = cands.iter().map(|c| c.body.slot() + 1).max().unwrap_or(0);
        let dense = slots <= SLOTS_PER_CANDIDATE * cands.len() && cands.len() < u32::MAX as usize;
        let index = dense
            .then(|| Self::by_slot(cands, slots))
            .flatten()
            .unwrap_or_else(|| {
                let by_body = cands.iter().enumerate().map(|(k, c)| (c.body, k)).collect();
                CandidateIndex::ByBody(by_body)
            });
        Self { step, index }
    }

    /// The index by slot of `cands`, whose slots are below `slots`; `None` where two bodies
    /// of one slot have candidates (two generations: a table by body tells them apart).
    fn by_slot(cands: &[Candidate], slots: usize) -> Option<CandidateIndex> {
        let mut by_slot = vec![u32::MAX; slots];
        for (k, c) in cands.iter().enumerate() {
            let entry = &mut by_slot[c.body.slot()];
            if cands
                .get(*entry as usize)
                .is_some_and(|was| was.body != c.body)
            {
                return None;
            }
            *entry = k as u32;
        }
        Some(CandidateIndex::BySlot(by_slot))
    }

    /// The candidate of `body`, if it has one.
    fn get(&self, body: &RigidBodyHandle) -> Option<&'s Candidate> {
        let cands = &self.step.candidates;
        match &self.index {
            CandidateIndex::BySlot(by_slot) => {
                let k = *by_slot.get(body.slot())?;
                // A slot's candidate is another generation's body, or none (`u32::MAX`).
                cands.get(k as usize).filter(|c| c.body == *body)
            }
            CandidateIndex::ByBody(by_body) => by_body.get(body).map(|k| &cands[*k]),
        }
    }

    /// The candidate of `body`, which must have one.
    fn of(&self, body: &RigidBodyHandle) -> &'s Candidate {
        self.get(body).expect("every member has a candidate")
    }
}

/// The connected sets of bodies joined by `Impact` pairs.
struct Clusters {
    /// Each cluster's members, cluster after cluster, each in the order the pairs first list
    /// them.
    members: Vec<RigidBodyHandle>,
    /// Where each cluster's members start in `members`, and their end last.
    member_starts: Vec<usize>,
    /// Each cluster's pairs, cluster after cluster, each in the plan's order, as indices into
    /// its members.
    pairs: Vec<(usize, usize)>,
    /// Where each cluster's pairs start in `pairs`, and their end last.
    pair_starts: Vec<usize>,
    /// Each body's number, in the order the pairs first list them.
    number: HandleMap<RigidBodyHandle, usize>,
    /// Each body's cluster, by its number.
    cluster: Vec<usize>,
}

impl Clusters {
    /// The clusters of these pairs, by union-find over them; clusters are numbered in the
    /// order the pairs first reach them, so the order is the plan's every run (whichever body
    /// the union-find makes a set's root). The bodies are numbered once, and the rest runs
    /// on their numbers.
    fn of(impacts: &[&PlannedPair]) -> Self {
        let mut number: HandleMap<RigidBodyHandle, usize> =
            HandleMap::with_capacity_and_hasher(2 * impacts.len(), Default::default());
        let mut bodies = Vec::with_capacity(2 * impacts.len());
        let mut number_of = |body: RigidBodyHandle| {
            *number.entry(body).or_insert_with(|| {
                bodies.push(body);
                bodies.len() - 1
            })
        };
        let ends: Vec<(usize, usize)> = impacts
            .iter()
            .map(|pair| (number_of(pair.a), number_of(pair.b)))
            .collect();
        let mut sets = Sets::new(bodies.len());
        for (a, b) in &ends {
            sets.join(*a, *b);
        }
        // The bodies by number are in the order the pairs first list them: each joins its
        // cluster's members there.
        let mut cluster_of_root = vec![usize::MAX; bodies.len()];
        let (mut cluster, mut place) = (Vec::with_capacity(bodies.len()), Vec::new());
        let mut sizes: Vec<usize> = Vec::new();
        place.reserve(bodies.len());
        for body in 0..bodies.len() {
            let root = sets.root(body);
            if cluster_of_root[root] == usize::MAX {
                cluster_of_root[root] = sizes.len();
                sizes.push(0);
            }
            let c = cluster_of_root[root];
            cluster.push(c);
            place.push(sizes[c]);
            sizes[c] += 1;
        }
        let member_starts = starts_of(&sizes);
        let mut members = vec![RigidBodyHandle::invalid(); bodies.len()];
        for (body, handle) in bodies.iter().enumerate() {
            members[member_starts[cluster[body]] + place[body]] = *handle;
        }
        let mut pair_counts = vec![0; sizes.len()];
        for (a, _) in &ends {
            pair_counts[cluster[*a]] += 1;
        }
        let pair_starts = starts_of(&pair_counts);
        let mut next = pair_starts.clone();
        let mut pairs = vec![(0, 0); ends.len()];
        for (a, b) in &ends {
            let slot = &mut next[cluster[*a]];
            pairs[*slot] = (place[*a], place[*b]);
            *slot += 1;
        }
        Clusters {
            members,
            member_starts,
            pairs,
            pair_starts,
            number,
            cluster,
        }
    }

    /// How many clusters there are.
    fn len(&self) -> usize {
        self.member_starts.len() - 1
    }

    /// Cluster `c`'s members.
    fn members(&self, c: usize) -> &[RigidBodyHandle] {
        &self.members[self.member_starts[c]..self.member_starts[c + 1]]
    }

    /// The most members, and the most pairs, of a cluster.
    fn largest(&self) -> (usize, usize) {
        let most = |starts: &[usize]| starts.windows(2).map(|w| w[1] - w[0]).max();
        let members = most(&self.member_starts).unwrap_or(0);
        (members, most(&self.pair_starts).unwrap_or(0))
    }

    /// Cluster `c`'s pairs, as indices into its members.
    fn pairs(&self, c: usize) -> &[(usize, usize)] {
        &self.pairs[self.pair_starts[c]..self.pair_starts[c + 1]]
    }

    /// The cluster of `body`, if it is in one.
    fn of_body(&self, body: &RigidBodyHandle) -> Option<usize> {
        self.number.get(body).map(|n| self.cluster[*n])
    }
}

/// Where each of lists of these lengths starts, laid one after another, and their end last.
fn starts_of(lengths: &[usize]) -> Vec<usize> {
    let mut starts = Vec::with_capacity(lengths.len() + 1);
    starts.push(0);
    for length in lengths {
        starts.push(starts[starts.len() - 1] + length);
    }
    starts
}

/// Disjoint sets of numbered bodies (union-find): the smaller set joins the larger, and every
/// walk to a root points the bodies it passed at the root, so `n` joins and finds over a
/// cluster of `n` bodies cost about `n` steps, not `n^2` (a row of balls struck at one end
/// lists its pairs in the order that would chain a naive union's roots).
struct Sets {
    /// Each body's parent in its set's tree (a root is its own).
    parent: Vec<usize>,
    /// Each root's set size.
    size: Vec<u32>,
}

impl Sets {
    /// Bodies `0..n`, each alone.
    fn new(n: usize) -> Self {
        Self {
            parent: (0..n).collect(),
            size: vec![1; n],
        }
    }

    /// The root of `body`'s set.
    fn root(&mut self, body: usize) -> usize {
        let mut r = body;
        while self.parent[r] != r {
            r = self.parent[r];
        }
        let mut k = body;
        while k != r {
            k = std::mem::replace(&mut self.parent[k], r);
        }
        r
    }

    /// Joins the sets of `a` and `b`.
    fn join(&mut self, a: usize, b: usize) {
        let (ra, rb) = (self.root(a), self.root(b));
        if ra == rb {
            return;
        }
        let (small, large) = if self.size[ra] < self.size[rb] {
            (ra, rb)
        } else {
            (rb, ra)
        };
        self.parent[small] = large;
        self.size[large] += self.size[small];
    }

    /// The longest walk from a body to its root (a test's measure of the trees' height).
    #[cfg(test)]
    fn height(&self) -> usize {
        let depth = |mut k: usize| {
            let mut n = 0;
            while self.parent[k] != k {
                (k, n) = (self.parent[k], n + 1);
            }
            n
        };
        (0..self.parent.len()).map(depth).max().unwrap_or(0)
    }
}

/// Did every body of the cluster move alone in the step: managed and awake, not pushed by
/// any contact rapier's solver kept (a speculative contact that stayed open pushes nothing),
/// nor held in one, even open, with a collider the cluster does not look for (neither a
/// ground nor an opted-in body: a wall), no joint, no user torque, no `Step` impulse, and
/// rapier's CCD consistent with its motion? Reads only.
fn moves_alone(
    view: &AfterStep,
    (bodies, colliders): (&RigidBodySet, &ColliderSet),
    cands: &CandidatesByBody,
    members: &[RigidBodyHandle],
) -> bool {
    let step = cands.step;
    let sets = &step.sets;
    let registry = view.registry;
    let looked_for = |c: ColliderHandle| {
        registry.entry(c).is_some()
            || colliders
                .get(c)
                .and_then(|co| co.parent())
                .and_then(|b| Some((b, bodies.get(b)?)))
                .is_some_and(|(b, rb)| registry.takes_pairs(b, rb))
    };
    members.iter().all(|h| {
        let (Some(now), Some(cand)) = (view.commit.body(bodies, *h), cands.get(h)) else {
            return false;
        };
        let rb = now.rb();
        view.registry.manages(*h, rb)
            && !now.is_sleeping()
            && !held_or_by_unseen(rb, sets.narrow_phase, looked_for)
            && !sets.jointed(*h)
            && rb.user_torque() == Vector::ZERO
            && !cand.touched
            && ccd_consistent(&now, &FlownEnd::new(cand, step.dt), step.dt, step)
    })
}

/// Each member's [`ClusterBall`], in the members' order, after those of `balls`: its
/// collider, its radius if it is a centred ball, its `Impact` grounds and the ground it rolls
/// on. `None` when a member has no collider or its rolling ground has no geometry (the
/// members before it added). Every member must have a candidate (as [`moves_alone`] checks).
/// Reads only.
fn cluster_balls<'s>(
    view: &AfterStep,
    (bodies, colliders): (&RigidBodySet, &'s ColliderSet),
    cands: &CandidatesByBody<'s>,
    members: &[RigidBodyHandle],
    balls: &mut Vec<ClusterBall<'s>>,
) -> Option<()> {
    let step = cands.step;
    balls.reserve(members.len());
    for h in members {
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
        let mut grounds = view.impact_ground_geoms(&cand.impact_grounds, &geom, colliders, step);
        let rolling_on = match &cand.rolling {
            Some((g, _)) => {
                grounds.push(view.pair_geom(&step.grounds[*g], &geom, colliders)?);
                Some(grounds.len() - 1)
            }
            None => None,
        };
        balls.push(ClusterBall {
            cand,
            collider,
            radius,
            geom,
            grounds,
            rolling_on,
            inertia: Inertia::of(rb),
        });
    }
    Some(())
}

#[cfg(test)]
mod tests {
    use super::Sets;

    /// A row of bodies joined pair by pair from one end, and from the other, and two rows
    /// joined in a random order: one set each, whose trees stay shallow (a naive union makes
    /// a row's tree as tall as the row, and walks it once a pair).
    #[test]
    fn a_row_joined_pair_by_pair_is_one_shallow_set() {
        let n = 1024usize;
        let orders: [Vec<usize>; 2] = [(0..n - 1).collect(), (0..n - 1).rev().collect()];
        for order in orders {
            let mut sets = Sets::new(n);
            for i in order {
                sets.join(i, i + 1);
            }
            assert!(sets.height() <= 10, "height {}", sets.height());
            let root = sets.root(0);
            assert!((0..n).all(|i| sets.root(i) == root));
        }
        // Two rows, their pairs shuffled (a fixed sequence): two sets.
        let mut pairs: Vec<(usize, usize)> = (0..n / 2 - 1).map(|i| (i, i + 1)).collect();
        pairs.extend((n / 2..n - 1).map(|i| (i, i + 1)));
        let mut x = 0x9e37_79b9u64;
        for k in (1..pairs.len()).rev() {
            x = x
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            pairs.swap(k, (x >> 33) as usize % (k + 1));
        }
        let mut sets = Sets::new(n);
        for (a, b) in pairs {
            sets.join(a, b);
        }
        let (first, second) = (sets.root(0), sets.root(n - 1));
        assert_ne!(first, second);
        assert!((0..n / 2).all(|i| sets.root(i) == first));
        assert!((n / 2..n).all(|i| sets.root(i) == second));
        assert!(sets.height() <= 10, "height {}", sets.height());
    }
}
