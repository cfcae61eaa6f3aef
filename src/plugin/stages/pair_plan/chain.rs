//! The chain rule: a resting pair side by side with a body of an `Impact` pair joins it (the
//! body hit passes the impact on inside the step: Newton's cradle, a row of balls on a table),
//! and so on along the row, sleeping bodies included.
//!
//! Invariants:
//! - Only a pair touching at the step's start (two balls within the resting gap) carries an
//!   impact on: a chain is the bodies an impact reaches within the step.
//! - A body lying on another stays rapier's, and so does a body something lies on (it is
//!   `loaded`): a pile's layers are held by rapier's solver.
//! - An impact of bodies other than two balls, or of two balls closing faster than the pressed
//!   speed, passes on to every side; a slower impact of two balls side by side (its normal
//!   within [`CHAIN_MAX_TILT_SIN`] of level) passes on only along its own line, to pairs whose
//!   normal is within `CHAIN_MAX_TILT_SIN` of it; a slower landing of a ball on another passes
//!   nothing on.
//! - Each carrier is expanded once and each pair beside a carrier decided once: the chain
//!   grows in time linear in its pairs.
//! - Pairs are added and carriers expanded in a fixed order (the order they became carriers,
//!   the plan's order of pairs), so the plan is the same every run.

use super::decide::{Judge, Planned};
use super::index::Around;
use super::pair_key;
use crate::plugin::policy::{CHAIN_MAX_TILT_SIN, Role};
use crate::plugin::queries::observe::neighbours;
use crate::plugin::state::handles::HandleMap;
use crate::plugin::state::step::PlannedPair;
use crate::rapier::prelude::{PhysicsHooks, RigidBodyHandle};
use nalgebra::Vector3;

/// The chain expansion's worklists.
struct Chains {
    /// The bodies an impact reaches that can pass it on, and the line it passes along
    /// (`None`: every side).
    carriers: HandleMap<RigidBodyHandle, Option<Vector3<f64>>>,
    /// Whether something lies on a body (asked once a body, only with gravity).
    loaded: HandleMap<RigidBodyHandle, bool>,
    /// The carriers whose pairs were all planned, by member index.
    expanded: Vec<bool>,
    /// The carriers still to expand, in the order they became carriers.
    to_expand: Vec<RigidBodyHandle>,
    /// A carrier's neighbours in the pair index (a buffer reused from carrier to carrier).
    around: Vec<usize>,
    /// The level resting pairs (by index in the plan's pairs) that wait for a body of theirs
    /// to become a carrier, by body.
    waiting: HandleMap<RigidBodyHandle, Vec<usize>>,
    /// The pairs beside a carrier already decided, by index in the plan's pairs.
    decided: Vec<bool>,
    /// The level resting pairs to decide now.
    ready: Vec<usize>,
    /// The plan's pairs before this index were looked at for `ready`.
    listed: usize,
}

/// Can a carrier's impact, passed along `line`, pass to the pair of this normal?
fn passes(line: &Option<Vector3<f64>>, normal: &Vector3<f64>) -> bool {
    line.is_none_or(|d| d.cross(normal).norm() <= CHAIN_MAX_TILT_SIN)
}

/// Grows the plan's `Impact` pairs along the chains (see the module's invariants). Reads what
/// the judge reads and the pair index's neighbours; adds pairs to `planned` and turns some of
/// its `Resting` pairs into `Impact` ones (and their bodies into members); never removes a
/// pair nor writes into rapier.
pub(super) fn expand_chains<H: PhysicsHooks>(
    judge: &Judge<H>,
    planned: &mut Planned,
    neighbours: &Around,
) {
    let mut chains = Chains::new(judge, &planned.plan.pairs);
    while !chains.to_expand.is_empty() {
        chains.expand(judge, planned, neighbours);
        chains.list_level_resting(judge, &planned.plan.pairs);
        chains.decide_ready(judge, planned);
    }
}

impl Chains {
    /// The first carriers: the bodies of the first pass's `Impact` pairs that can pass an
    /// impact on, with the line they pass it along.
    fn new<H: PhysicsHooks>(judge: &Judge<H>, pairs: &[PlannedPair]) -> Self {
        let policy = judge.inputs.policy;
        let mut carriers: HandleMap<RigidBodyHandle, Option<Vector3<f64>>> = HandleMap::default();
        for p in pairs.iter().filter(|p| p.role == Role::Impact) {
            let along = if !p.balls || judge.closing_gap(p.a, p.b).0 > policy.pressed_speed {
                None
            } else if p.normal.dot(&judge.down).abs() <= CHAIN_MAX_TILT_SIN {
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
        let to_expand: Vec<RigidBodyHandle> = carriers.keys().copied().collect();
        Chains {
            carriers,
            loaded: HandleMap::default(),
            expanded: vec![false; judge.members.balls.len()],
            to_expand,
            around: Vec::new(),
            waiting: HandleMap::default(),
            decided: Vec::new(),
            ready: Vec::new(),
            listed: 0,
        }
    }

    /// Plans the pairs around each new carrier that the first pass left out (slow ones, and
    /// two sleeping bodies): each once, from the carrier expanded first. Empties `to_expand`.
    fn expand<H: PhysicsHooks>(
        &mut self,
        judge: &Judge<H>,
        planned: &mut Planned,
        neighbours: &Around,
    ) {
        let balls = &judge.members.balls;
        for h in std::mem::take(&mut self.to_expand) {
            let m = judge.index.ball_of_body(h);
            if self.expanded[m] {
                continue;
            }
            self.expanded[m] = true;
            self.around.clear();
            neighbours.of(m, judge.members, &mut self.around);
            for &j in &self.around {
                let (lo, hi) = (m.min(j), m.max(j));
                if j == m || self.expanded[j] {
                    continue;
                }
                let key = pair_key(balls[lo].collider, balls[hi].collider);
                if !planned.plan.roles.contains_key(&key) {
                    if let Some(pair) = judge.evaluate(lo, hi, true) {
                        planned.add(judge.bodies, pair);
                    }
                }
            }
        }
    }

    /// Lists the level resting pairs planned since the last call as ready to decide.
    fn list_level_resting<H>(&mut self, judge: &Judge<H>, pairs: &[PlannedPair]) {
        self.decided.resize(pairs.len(), false);
        self.ready.extend((self.listed..pairs.len()).filter(|k| {
            let pair = &pairs[*k];
            pair.role == Role::Resting && pair.normal.dot(&judge.down).abs() <= CHAIN_MAX_TILT_SIN
        }));
        self.listed = pairs.len();
    }

    /// Does something lie on body `h`? (Without gravity nothing lies on anything.)
    fn is_loaded<H>(&mut self, judge: &Judge<H>, h: RigidBodyHandle) -> bool {
        let (inputs, down) = (judge.inputs, judge.down);
        down != Vector3::zeros()
            && *self.loaded.entry(h).or_insert_with(|| {
                neighbours(h, &judge.bodies[h], inputs.sets, inputs.registry, &down).loaded
            })
    }

    /// Decides every ready pair: a pair beside a carrier whose impact passes to it joins, or
    /// it never will (it is apart, something lies on a body, or rapier or the user's filter
    /// would not solve it); a pair beside no such carrier waits for one. A body of a pair
    /// that joins becomes a carrier (or one passing to every side) to expand.
    fn decide_ready<H: PhysicsHooks>(&mut self, judge: &Judge<H>, planned: &mut Planned) {
        while let Some(k) = self.ready.pop() {
            let PlannedPair { a, b, key, .. } = planned.plan.pairs[k];
            if self.decided[k] {
                continue;
            }
            let normal = planned.plan.pairs[k].normal;
            // The line the impact reaches it along, from the body of the pair that passes it
            // on (every side first).
            let from = [a, b]
                .iter()
                .filter_map(|ball| self.carriers.get(ball))
                .filter(|line| passes(line, &normal))
                .min_by_key(|line| line.is_some())
                .copied();
            let Some(along) = from else {
                self.waiting.entry(a).or_default().push(k);
                self.waiting.entry(b).or_default().push(k);
                continue;
            };
            self.decided[k] = true;
            let apart = planned.plan.pairs[k].balls
                && judge.closing_gap(a, b).1 > judge.inputs.policy.resting_gap;
            if apart || self.is_loaded(judge, a) || self.is_loaded(judge, b) {
                continue;
            }
            if judge.refused(key, a, b) {
                continue;
            }
            let pair = &mut planned.plan.pairs[k];
            pair.role = Role::Impact;
            pair.hooked = true;
            planned.plan.roles.insert(key, Role::Impact);
            planned.join(judge.bodies, a);
            planned.join(judge.bodies, b);
            for ball in [a, b] {
                // A new carrier, or one that now passes on to every side.
                let was = self.carriers.get(&ball).copied();
                if was.is_none() || was.is_some_and(|line| line.is_some() && along.is_none()) {
                    self.carriers.insert(ball, along);
                    self.to_expand.push(ball);
                    self.ready
                        .extend(self.waiting.remove(&ball).unwrap_or_default());
                }
            }
        }
    }
}
