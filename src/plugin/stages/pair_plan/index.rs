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
        self.tree.refit(&mut self.workspace);
        self.tree.optimize_incremental(&mut self.workspace);
    }

    /// Every pair of balls (indices in this step's list, the smaller first) whose boxes meet,
    /// in increasing order: one traversal of the tree against itself. (The tree's own order
    /// depends on its history, which a restored plugin does not have.)
    fn overlapping(&mut self) -> Vec<(usize, usize)> {
        let mut out = Vec::new();
        let ball_of = &self.ball_of;
        self.tree
            .traverse_bvtt_single_tree::<false>(&mut self.workspace, &mut |s1, s2| {
                let (i, j) = (ball_of[s1 as usize] as usize, ball_of[s2 as usize] as usize);
                out.push((i.min(j), i.max(j)));
            });
        sort_pairs(&mut out);
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
    /// Ball `k`'s others are `others[start[k]..start[k + 1]]`.
    start: Vec<u32>,
    others: Vec<u32>,
}

impl Overlaps {
    /// The lists of `balls` balls from the overlapping `pairs` (each once, either order).
    pub(super) fn new(balls: usize, pairs: &[(usize, usize)]) -> Self {
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
    pub(super) fn of(&self, k: usize) -> impl Iterator<Item = usize> + '_ {
        let range = self.start[k] as usize..self.start[k + 1] as usize;
        self.others[range].iter().map(|j| *j as usize)
    }
}

/// The pairs that may meet in the step, found in the index once `update`d with the members'
/// leaves.
pub(super) struct Candidates {
    /// The pairs to evaluate (indices in the members' list, the smaller first), in the order
    /// the plan evaluates them: every overlapping pair with a mover (any pair where a
    /// restitution can reach 1).
    pub pairs: Vec<(usize, usize)>,
    /// Every overlapping pair, when the tree was traversed against itself: the chains read
    /// each ball's neighbours from it instead of querying the tree again.
    pub traversed: Option<Vec<(usize, usize)>>,
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
        let all = index.overlapping();
        // At most every overlapping pair: sized once rather than grown.
        let mut pairs = Vec::with_capacity(all.len());
        pairs.extend(
            all.iter()
                .copied()
                .filter(|(i, j)| members.any_elastic || mover(*i) || mover(*j)),
        );
        return Candidates {
            pairs,
            traversed: Some(all),
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
    sort_pairs(&mut pairs);
    Candidates {
        pairs,
        traversed: None,
    }
}

/// Sorts pairs of ball indices in increasing order, as one `u64` key each (`i` high, `j`
/// low: the same order as the tuples', at a fraction of the comparisons' cost). The indices
/// fit in 32 bits: a step's balls are numbered in `PairIndex::ball_of`'s `u32`s.
fn sort_pairs(pairs: &mut [(usize, usize)]) {
    let key = |(i, j): (usize, usize)| ((i as u64) << 32) | j as u64;
    let mut keys: Vec<u64> = pairs.iter().map(|p| key(*p)).collect();
    keys.sort_unstable();
    for (p, k) in pairs.iter_mut().zip(keys) {
        *p = ((k >> 32) as usize, (k & u64::from(u32::MAX)) as usize);
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
