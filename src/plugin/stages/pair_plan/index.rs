//! The pair index: a BVH over the opted-in bodies' swept spheres, kept from step to step, and
//! the pairs of bodies whose swept boxes overlap (the pairs that may meet in the step).
//!
//! Invariant: between [`PairIndex::update`] and [`PairIndex::clear_list`] every body of the
//! step's list has one leaf, keyed by its body's slot, and `ball_of` maps that slot to its
//! index in the list; outside that window the list is empty and only the tree is kept.

use super::gather::Members;
use crate::plugin::state::handles::Slotted;
use crate::rapier::parry::bounding_volume::Aabb;
use crate::rapier::parry::partitioning::{Bvh, BvhWorkspace};
use crate::rapier::prelude::RigidBodyHandle;

/// The opted-in balls' swept spheres, kept from step to step: each step updates every ball's
/// leaf (keyed by its body's slot) and refits the tree, so a step's cost follows the leaves
/// that moved rather than a rebuild over every ball.
#[derive(Default)]
pub(crate) struct PairIndex {
    tree: Bvh,
    workspace: BvhWorkspace,
    /// The step's pairs by their first ball, for the order of the list.
    buckets: PairBuckets,
    /// How many pairs the last traversal found: the next one's list is sized for a few
    /// more, rather than grown (and copied) pair by pair.
    last_found: usize,
    /// How many times the tree was updated: its shape is optimised every other update.
    updates: u64,
    /// The body slots with a leaf in the tree: the last update's list.
    listed: Vec<u32>,
    /// This step's ball (index in its list) by body slot, `u32::MAX` for none.
    ball_of: Vec<u32>,
}

impl PairIndex {
    /// The tree over these leaves (body slot, swept box): leaves of bodies no longer listed
    /// are removed.
    pub(super) fn update(&mut self, leaves: &[(u32, Aabb)]) {
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
        // The leaves are the last list's: those not listed again go.
        for slot in &self.listed {
            if self
                .ball_of
                .get(*slot as usize)
                .is_none_or(|b| *b == u32::MAX)
            {
                self.tree.remove(*slot);
            }
        }
        self.listed.clear();
        for (slot, aabb) in leaves {
            self.tree.insert_or_update_partially(*aabb, *slot, 0.0);
            self.listed.push(*slot);
        }
        // The boxes are refitted in place: a full refit also copies the whole tree into
        // depth-first order in memory, which changes no query's result nor the tree's shape
        // (which the incremental optimisation keeps balanced).
        self.tree.refit_without_opt();
        // Optimising the shape every other step costs less than the little work it saves the
        // traversals in the step between (the balls move little in a step); a query's result
        // does not depend on the shape.
        self.updates += 1;
        if self.updates % 2 == 0 {
            self.tree.optimize_incremental(&mut self.workspace);
        }
    }

    /// Every pair of the `balls` balls (indices in this step's list, the smaller first) whose
    /// boxes meet, in increasing order: one traversal of the tree against itself. (The tree's
    /// own order depends on its history, which a restored plugin does not have.)
    fn overlapping(&mut self, balls: usize) -> Vec<(usize, usize)> {
        let (ball_of, buckets) = (&self.ball_of, &mut self.buckets);
        buckets.prepare(balls);
        self.tree
            .traverse_bvtt_single_tree::<false>(&mut self.workspace, &mut |s1, s2| {
                buckets.add(ball_of[s1 as usize] as usize, ball_of[s2 as usize] as usize);
            });
        self.drain_pairs(balls)
    }

    /// The bucketed pairs of `balls` balls, in increasing order (the buckets left empty).
    fn drain_pairs(&mut self, balls: usize) -> Vec<(usize, usize)> {
        let mut out = Vec::with_capacity(self.last_found + self.last_found / 4 + 16);
        self.buckets.drain_into(balls, &mut out);
        self.last_found = out.len();
        out
    }

    /// This step's ball (index in its list) of a body in it.
    pub(super) fn ball_of_body(&self, body: RigidBodyHandle) -> usize {
        self.ball_of[body.slot()] as usize
    }

    /// The balls (indices in this step's list) whose boxes meet `aabb`.
    pub(super) fn meeting<'a>(&'a self, aabb: &'a Aabb) -> impl Iterator<Item = usize> + 'a {
        self.tree
            .intersect_aabb(aabb)
            .map(|slot| self.ball_of[slot as usize] as usize)
    }

    /// The body slots and swept boxes of this step's members whose boxes meet `aabb`, read
    /// after the plan (the tree keeps the step's leaves until the next step's plan): each
    /// box bounds its body's travel over the step from its start-of-step motion.
    pub(crate) fn leaves_meeting<'a>(
        &'a self,
        aabb: &'a Aabb,
    ) -> impl Iterator<Item = (u32, Aabb)> + 'a {
        self.tree.intersect_aabb(aabb).filter_map(|slot| {
            let node = self.tree.leaf_node(slot)?;
            Some((slot, node.aabb()))
        })
    }

    /// Forgets this step's list (the tree stays).
    pub(super) fn clear_list(&mut self, leaves: &[(u32, Aabb)]) {
        for (slot, _) in leaves {
            self.ball_of[*slot as usize] = u32::MAX;
        }
    }
}

/// The pairs whose swept boxes overlap, as each ball's list of the others (both ways).
pub(super) struct Overlaps {
    /// Ball `k`'s others are `others[end[k - 1]..end[k]]` (from 0 for the first ball).
    end: Vec<u32>,
    others: Vec<u32>,
}

impl Overlaps {
    /// The lists of `balls` balls from the overlapping `pairs` (each once, either order).
    pub(super) fn new(balls: usize, pairs: &[(usize, usize)]) -> Self {
        // Each ball's count, then where its list starts, then (filled) where it ends.
        let mut end = vec![0u32; balls];
        for (i, j) in pairs {
            end[*i] += 1;
            end[*j] += 1;
        }
        let mut sum = 0;
        for at in end.iter_mut() {
            let count = *at;
            *at = sum;
            sum += count;
        }
        let mut others = vec![0u32; sum as usize];
        for (i, j) in pairs {
            for (from, to) in [(*i, *j), (*j, *i)] {
                others[end[from] as usize] = to as u32;
                end[from] += 1;
            }
        }
        Overlaps { end, others }
    }

    /// The balls whose swept boxes overlap ball `k`'s.
    pub(super) fn of(&self, k: usize) -> impl Iterator<Item = usize> + '_ {
        let from = if k == 0 { 0 } else { self.end[k - 1] as usize };
        self.others[from..self.end[k] as usize]
            .iter()
            .map(|j| *j as usize)
    }
}

/// The pairs that may meet in the step, found in the index once `update`d with the members'
/// leaves.
pub(super) struct Candidates {
    /// Pairs of balls (indices in the members' list, the smaller first) in increasing order:
    /// every overlapping pair when the tree was traversed against itself (`traversed`), else
    /// those with a mover.
    pub pairs: Vec<(usize, usize)>,
    /// `pairs` is every overlapping pair: the chains read each ball's neighbours from it
    /// instead of querying the tree again.
    pub traversed: bool,
}

impl Candidates {
    /// The pairs to evaluate, in the order the plan evaluates them: every overlapping pair
    /// with a mover (any pair where a restitution can reach 1).
    pub(super) fn to_evaluate<'c>(
        &'c self,
        members: &'c Members,
    ) -> impl Iterator<Item = (usize, usize)> + 'c {
        // Without a traversal the list holds only pairs with a mover.
        let every = members.any_elastic || !self.traversed;
        self.pairs
            .iter()
            .copied()
            .filter(move |(i, j)| every || members.is_mover[*i] || members.is_mover[*j])
    }
}

/// The step's candidate pairs. Reads the index (its list must be the members') and the
/// members' movers; mutates only the index's traversal workspace. One traversal of the tree
/// against itself costs about as much as three single-ball queries per ball, so it is chosen
/// when more than a third of the balls move or a restitution can reach 1; otherwise each
/// mover's box is queried, and a pair of two movers is listed once, from the first.
pub(super) fn candidates(index: &mut PairIndex, members: &Members) -> Candidates {
    let mover = |k: usize| members.is_mover[k];
    let balls = members.balls.len();
    if members.any_elastic || 3 * members.movers > balls {
        return Candidates {
            pairs: index.overlapping(balls),
            traversed: true,
        };
    }
    let (tree, ball_of, buckets) = (&index.tree, &index.ball_of, &mut index.buckets);
    buckets.prepare(balls);
    for m in (0..balls).filter(|m| mover(*m)) {
        for slot in tree.intersect_aabb(&members.leaves[m].1) {
            let j = ball_of[slot as usize] as usize;
            if j != m && (j > m || !mover(j)) {
                buckets.add(m, j);
            }
        }
    }
    // In increasing order, as the traversal's: not the tree's, which depends on its history.
    Candidates {
        pairs: index.drain_pairs(balls),
        traversed: false,
    }
}

/// The pairs of a step's balls by their first (smaller) ball: each ball's bucket holds the
/// seconds of its pairs as they are found, so that the pairs come out in increasing order by
/// walking the buckets in order, each (a ball's few neighbours) sorted by the second. The
/// cost is O(pairs and balls), where comparing whole pairs costs a factor of log(pairs), and
/// no pass counts the buckets first. The buckets are kept from step to step (`PairIndex`),
/// so that a step's pairs allocate nothing once they have grown.
#[derive(Default)]
struct PairBuckets {
    /// By first ball: the second balls of its pairs (`u32`, as the step's balls are numbered
    /// in `PairIndex::ball_of`).
    seconds: Vec<Vec<u32>>,
}

impl PairBuckets {
    /// Room for the pairs of `balls` balls (the buckets are empty).
    fn prepare(&mut self, balls: usize) {
        if self.seconds.len() < balls {
            self.seconds.resize_with(balls, Vec::new);
        }
    }

    /// Adds the pair of balls `i` and `j` (either order, distinct).
    fn add(&mut self, i: usize, j: usize) {
        self.seconds[i.min(j)].push(i.max(j) as u32);
    }

    /// Appends the pairs `(i, j)`, `i < j < balls`, in increasing order, and empties the
    /// buckets.
    fn drain_into(&mut self, balls: usize, out: &mut Vec<(usize, usize)>) {
        for (i, seconds) in self.seconds[..balls].iter_mut().enumerate() {
            // Most buckets hold one pair or none.
            if seconds.len() > 1 {
                seconds.sort_unstable();
            }
            out.extend(seconds.iter().map(|j| (i, *j as usize)));
            seconds.clear();
        }
    }
}

/// Each ball's neighbours in the tree for the chains: from the traversal's pairs when there
/// was one (built once, on first use), else by a query of the tree.
pub(super) struct Around<'p> {
    index: &'p PairIndex,
    traversed: Option<Vec<(usize, usize)>>,
    overlaps: std::cell::OnceCell<Overlaps>,
}

impl<'p> Around<'p> {
    pub(super) fn new(index: &'p PairIndex, traversed: Option<Vec<(usize, usize)>>) -> Self {
        Self {
            index,
            traversed,
            overlaps: std::cell::OnceCell::new(),
        }
    }

    /// Appends ball `m`'s neighbours to `out`, in increasing order.
    pub(super) fn of(&self, m: usize, members: &Members, out: &mut Vec<usize>) {
        match &self.traversed {
            Some(pairs) => out.extend(
                self.overlaps
                    .get_or_init(|| Overlaps::new(members.balls.len(), pairs))
                    .of(m),
            ),
            None => {
                let from = out.len();
                out.extend(self.index.meeting(&members.leaves[m].1));
                out[from..].sort_unstable();
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::PairBuckets;

    /// The buckets give pairs in the order a comparison sort of the tuples does, empty
    /// buckets, pairs given either way round and a last ball without pairs included.
    #[test]
    fn bucketed_pairs_order_as_tuples() {
        let balls = 40;
        // A fixed scramble of every pair of a few balls, and some of the others.
        let mut pairs: Vec<(usize, usize)> = (0..balls)
            .flat_map(|i| (i + 1..balls - 1).map(move |j| (i, j)))
            .filter(|(i, j)| (i * 7 + j * 13) % 5 != 0 && (*i < 6 || (i + j) % 9 == 0))
            .collect();
        pairs.reverse();
        let third = pairs.len() / 3;
        pairs.rotate_left(third);
        let mut expected = pairs.clone();
        expected.sort_unstable();
        let mut buckets = PairBuckets::default();
        buckets.prepare(balls);
        for (k, (i, j)) in pairs.iter().enumerate() {
            if k % 2 == 0 {
                buckets.add(*i, *j);
            } else {
                buckets.add(*j, *i);
            }
        }
        let mut out = Vec::new();
        buckets.drain_into(balls, &mut out);
        assert_eq!(out, expected);
        let mut none = Vec::new();
        buckets.drain_into(balls, &mut none);
        assert!(none.is_empty());
    }
}
