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
    /// The buffers of the traversal's sort of its pairs.
    sort: PairSort,
    /// How many pairs the last traversal found: the next one's list is sized for a few
    /// more, rather than grown (and copied) pair by pair.
    last_found: usize,
    /// How many times the tree was updated: its shape is optimised every other update.
    updates: u64,
    /// The body slots with a leaf in the tree.
    slots: Vec<bool>,
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
        let mut out = Vec::with_capacity(self.last_found + self.last_found / 4 + 16);
        let ball_of = &self.ball_of;
        self.tree
            .traverse_bvtt_single_tree::<false>(&mut self.workspace, &mut |s1, s2| {
                let (i, j) = (ball_of[s1 as usize] as usize, ball_of[s2 as usize] as usize);
                out.push((i.min(j), i.max(j)));
            });
        self.sort.sort(&mut out, balls);
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
    let mut pairs = Vec::new();
    for m in (0..balls).filter(|m| mover(*m)) {
        for j in index.meeting(&members.leaves[m].1) {
            if j != m && (j > m || !mover(j)) {
                pairs.push((m.min(j), m.max(j)));
            }
        }
    }
    // In increasing order, as the traversal's: not the tree's, which depends on its history.
    index.sort.sort(&mut pairs, balls);
    Candidates {
        pairs,
        traversed: false,
    }
}

/// Sorts pairs of ball indices `(i, j)`, `i < j < balls`, in increasing order: placed in
/// one bucket per first index (counted, then filled), then each bucket, a ball's few
/// neighbours, sorted by the second. O(pairs + balls), where comparing whole pairs costs a
/// factor of log(pairs). Its buffers are kept from step to step (`PairIndex`), so that a
/// step's sort allocates nothing once they have grown.
#[derive(Default)]
struct PairSort {
    /// Each first index's count, then where its bucket starts, then (filled) where it ends
    /// (`u32`, half the bytes to clear each step, as the step's balls are numbered in
    /// `PairIndex::ball_of`'s `u32`s).
    bucket_end: Vec<u32>,
    /// The pairs' second indices, bucket after bucket.
    seconds: Vec<u32>,
}

impl PairSort {
    fn sort(&mut self, pairs: &mut [(usize, usize)], balls: usize) {
        // More pairs than a `u32` counts: compared whole.
        if u32::try_from(pairs.len()).is_err() {
            pairs.sort_unstable();
            return;
        }
        let bucket_end = &mut self.bucket_end;
        bucket_end.clear();
        bucket_end.resize(balls, 0);
        for (i, _) in pairs.iter() {
            bucket_end[*i] += 1;
        }
        let mut sum = 0;
        for end in bucket_end.iter_mut() {
            let count = *end;
            *end = sum;
            sum += count;
        }
        // Every entry is written below before it is read.
        let seconds = &mut self.seconds;
        if seconds.len() < pairs.len() {
            seconds.resize(pairs.len(), 0);
        }
        for (i, j) in pairs.iter() {
            seconds[bucket_end[*i] as usize] = *j as u32;
            bucket_end[*i] += 1;
        }
        let mut k = 0;
        for (i, end) in bucket_end.iter().enumerate() {
            let end = *end as usize;
            // Most buckets hold one pair or none.
            if end > k + 1 {
                seconds[k..end].sort_unstable();
            }
            while k < end {
                pairs[k] = (i, seconds[k] as usize);
                k += 1;
            }
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
    use super::PairSort;

    /// The bucket sort orders pairs as a comparison sort of the tuples does, empty buckets,
    /// repeated first indices and a last ball without pairs included.
    #[test]
    fn sort_pairs_orders_as_tuples() {
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
        let mut sort = PairSort::default();
        sort.sort(&mut pairs, balls);
        assert_eq!(pairs, expected);
        let mut none: Vec<(usize, usize)> = Vec::new();
        sort.sort(&mut none, balls);
        assert!(none.is_empty());
    }
}
