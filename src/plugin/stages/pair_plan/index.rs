//! The pair index: the opted-in bodies' swept boxes of the step, by width in levels, each
//! level in rows of a grid, and the pairs of bodies whose boxes overlap (the pairs that may
//! meet in the step).
//!
//! Invariant: between [`PairIndex::update`] and [`PairIndex::clear_list`] every body of the
//! step's list has its box, keyed by its body's slot, and `ball_of` maps that slot to its
//! index in the list; outside that window `ball_of` maps no slot, and the boxes stay until the
//! next update (the clusters after rapier's step read them).
//!
//! The rows: a level's boxes are cut into rows across the axis their low ends spread most
//! along, each row at least as wide as the level's widest box along that axis, so that two
//! boxes that meet lie in the same row or in neighbouring ones; within a row they are sorted
//! by their low ends along the axis they spread second most along. A box then meets only
//! boxes of its row after it whose low end is not past its high end, and boxes of the next
//! row from the first whose row reaches its low end (a running maximum of the high ends) to
//! the last whose low end is not past its high end. The levels: a box up to twice as wide as
//! the narrowest box of positive width is in the first level (and so is a box of no width),
//! and each level after holds boxes up to four times as wide as the bound of the one before
//! (levels left empty are dropped), so that a few wide boxes (fast balls) do not widen every
//! row; a box is compared with its own level's as above, and queried against each narrower
//! level. In a crowd on a floor (one level) each ball so compares its box with the few around
//! it; the levels and rows are counted out rather than sorted, and each row (a few dozen
//! balls) is sorted on its own, so a step's cost follows the balls and the pairs, with no tree
//! to keep from step to step. Two boxes meet as parry's `Aabb::intersects` has it (closed
//! boxes: touching counts); a box with a coordinate that is not a number meets none and is
//! left out.

use super::gather::Members;
use crate::plugin::bridge::convert::to_f64;
use crate::plugin::state::handles::Slotted;
use crate::rapier::math::Real;
use crate::rapier::parry::bounding_volume::{Aabb, BoundingVolume};
use crate::rapier::prelude::RigidBodyHandle;

/// The opted-in balls' swept boxes of the step, by width in levels, each level in rows (see
/// the module's doc). The lists are kept from step to step for their storage only.
#[derive(Default)]
pub(crate) struct PairIndex {
    /// The step's boxes and their bodies' slots, by ball (index in the step's list).
    boxes: Vec<(u32, Aabb)>,
    /// The step's levels, narrowest boxes first: `levels[..level_count]` (the others are kept
    /// for their storage).
    levels: Vec<Level>,
    level_count: usize,
    /// The balls whose boxes can meet others (every coordinate a number), level by level in
    /// the list's order (scratch of `update`).
    by_level: Vec<u32>,
    /// Where each level's balls end in `by_level`.
    level_end: Vec<u32>,
    /// Each ball's box's width (m), not a number for a box that meets none, and its level,
    /// `u32::MAX` for that box (scratch of `update`).
    widths: Vec<f64>,
    level_of: Vec<u32>,
    /// The pairs found, put in order when drained.
    found: FoundPairs,
    /// How many pairs the last search found: the next one's list is sized for a few more,
    /// rather than grown (and copied) pair by pair.
    last_found: usize,
    /// This step's ball (index in its list) by body slot, `u32::MAX` for none.
    ball_of: Vec<u32>,
}

/// The boxes of one range of widths, in rows.
#[derive(Default)]
struct Level {
    rows: Rows,
    /// The level's balls, row by row, each row by its boxes' low ends along the sweep axis.
    sorted: Vec<Sorted>,
    /// Row `r` is `sorted[row_start[r]..row_start[r + 1]]`.
    row_start: Vec<u32>,
    /// Each of the level's balls' row, in the level's order (scratch of `build`).
    row_of: Vec<u32>,
}

/// One ball of a row: what its row is sorted and swept by (its box is in `boxes`, read only
/// for the few the sweep reaches).
#[derive(Clone, Copy)]
struct Sorted {
    /// Its box's low end along the sweep axis.
    low: Real,
    /// The highest high end along the sweep axis of this box and every box before it in its
    /// row: no box before a query's low end by this reaches it.
    reach: Real,
    ball: u32,
}

/// A level's rows: across which axis, from where, how wide, how many, and the axis each row
/// is sorted along.
#[derive(Clone, Copy, Debug)]
struct Rows {
    /// The axis the rows are cut across (their low ends spread most along it).
    across: usize,
    /// The axis each row is sorted and swept along (the second spread).
    sweep: usize,
    /// The lowest low end along `across` (m).
    origin: f64,
    /// A row's width along `across` (m): above the level's widest box's along it.
    width: f64,
    /// How many rows (1: every box in one).
    count: usize,
}

impl Default for Rows {
    fn default() -> Self {
        Rows {
            across: 0,
            sweep: 1,
            origin: 0.0,
            width: f64::INFINITY,
            count: 1,
        }
    }
}

/// A row's width over the widest box's: room for the rounding of a row's index, which is
/// below 2^-15 of a row while there are fewer than 2^35 rows (see [`Rows::of`]).
const ROW_ROOM: f64 = 1.0 / 256.0;

/// At most this many rows a box: more would leave most of them empty.
const ROWS_PER_BOX: f64 = 4.0;

impl Rows {
    /// The rows of these boxes (those that can meet others): across the axis their low ends
    /// spread most along, each sorted along the second (the first of equals).
    ///
    /// Two boxes that meet lie in the same row or in neighbouring ones: of the two, the one
    /// with the higher low end along `across` starts within the other's width along it, at
    /// most the widest box's, which a row's width exceeds by `ROW_ROOM`; a row index computed
    /// in `f64` (a subtraction and a division, at most `ROWS_PER_BOX n + 1` rows) is off by
    /// far less than that room, so the two indices differ by at most one. Boxes without end,
    /// or all of one point along `across`, lie in one row.
    fn of<'a>(boxes: impl Iterator<Item = &'a Aabb>) -> Rows {
        let mut n = 0usize;
        let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
        let mut widest = [0.0f64; 3];
        for aabb in boxes {
            n += 1;
            for k in 0..3 {
                let (min, max) = (to_f64(aabb.mins[k]), to_f64(aabb.maxs[k]));
                lo[k] = lo[k].min(min);
                hi[k] = hi[k].max(min);
                widest[k] = widest[k].max(max - min);
            }
        }
        let spread = [hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]];
        let mut axes = [0, 1, 2];
        // A stable sort: the first of equals stays first.
        axes.sort_by(|a, b| spread[*b].total_cmp(&spread[*a]));
        let (across, sweep) = (axes[0], axes[1]);
        let one = Rows {
            across,
            sweep,
            ..Rows::default()
        };
        let width = (widest[across] * (1.0 + ROW_ROOM))
            .max(spread[across] / (ROWS_PER_BOX * n.max(1) as f64));
        if !(width.is_finite() && width > 0.0 && spread[across].is_finite()) {
            return one;
        }
        Rows {
            origin: lo[across],
            width,
            count: (spread[across] / width).floor() as usize + 1,
            ..one
        }
    }

    /// The row (unclamped, not a number for `x` not a number) of a low end `x` along
    /// `across`.
    fn at(&self, x: Real) -> f64 {
        if self.count == 1 {
            return 0.0;
        }
        ((to_f64(x) - self.origin) / self.width).floor()
    }

    /// The row of a low end `x` (a number) along `across`, clamped to the rows.
    fn index(&self, x: f64) -> usize {
        // `x` below 0 (or not a number) is the first row; `as` saturates.
        (x.max(0.0) as usize).min(self.count - 1)
    }
}

/// The base 2 logarithm of how many times the widths a level holds reach past the bound of
/// the level before (4 times).
const LEVEL_RATIO_LOG2: f64 = 2.0;

/// The last level: it holds every box wider than the levels below hold (an unbounded one
/// included).
const MAX_LEVEL: usize = 32;

/// The width (m) of a box whose coordinates are numbers: its largest extent along an axis
/// (below zero for a box inverted along every axis). The members' boxes are cubes, as wide
/// along every axis, so whichever axes a level's rows are cut across and swept along, this is
/// their width along them.
fn width(aabb: &Aabb) -> f64 {
    (0..3)
        .map(|k| to_f64(aabb.maxs[k]) - to_f64(aabb.mins[k]))
        .fold(f64::NEG_INFINITY, f64::max)
}

/// The level of a box `width` wide, `base` the narrowest positive width of the step's boxes:
/// 0 up to twice `base`, then one more each time the width grows `2^LEVEL_RATIO_LOG2` times,
/// up to `MAX_LEVEL`. Only the cost depends on it: each level's rows are as wide as its own
/// widest box.
fn level_of_width(width: f64, base: f64) -> usize {
    if width <= 2.0 * base {
        return 0;
    }
    // Above 1, and infinite for an unbounded box, whose level `as` saturates to the last.
    let levels = ((width / (2.0 * base)).log2() / LEVEL_RATIO_LOG2).ceil();
    (levels as usize).min(MAX_LEVEL)
}

impl PairIndex {
    /// The index over these leaves (body slot, swept box), by ball: they replace the last
    /// step's.
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
        self.boxes.clear();
        self.boxes.extend_from_slice(leaves);
        self.sort_into_levels();
        let mut from = 0;
        for l in 0..self.level_count {
            let to = self.level_end[l] as usize;
            self.levels[l].build(&self.by_level[from..to], &self.boxes);
            from = to;
        }
    }

    /// Sorts the balls that can meet others into their levels (`by_level`, each level's
    /// balls in the list's order), counted out, and sets `level_count`.
    fn sort_into_levels(&mut self) {
        // Each box's width (not a number for one that meets none), the narrowest positive and
        // the widest.
        self.widths.clear();
        let (mut base, mut widest) = (f64::INFINITY, f64::NEG_INFINITY);
        for (_, b) in &self.boxes {
            let w = if comparable(b) { width(b) } else { f64::NAN };
            if w > 0.0 {
                base = base.min(w);
            }
            widest = widest.max(w);
            self.widths.push(w);
        }
        if widest <= 2.0 * base {
            // Every box in the first level (a crowd of balls alike): no need to count them out.
            self.by_level.clear();
            let balls = self.widths.iter().enumerate().filter(|(_, w)| !w.is_nan());
            self.by_level.extend(balls.map(|(k, _)| k as u32));
            self.level_end.clear();
            self.level_count = 0;
            if !self.by_level.is_empty() {
                self.level_end.push(self.by_level.len() as u32);
                self.level_count = 1;
            }
            if self.levels.is_empty() {
                self.levels.push(Level::default());
            }
            return;
        }
        self.level_of.clear();
        self.level_count = 0;
        for w in &self.widths {
            let level = if w.is_nan() {
                u32::MAX
            } else {
                let l = level_of_width(*w, base);
                self.level_count = self.level_count.max(l + 1);
                l as u32
            };
            self.level_of.push(level);
        }
        // Each level's count; the empty levels are dropped (a query would visit them).
        let ends = &mut self.level_end;
        ends.clear();
        ends.resize(self.level_count, 0);
        for l in self.level_of.iter().filter(|l| **l != u32::MAX) {
            ends[*l as usize] += 1;
        }
        if ends.contains(&0) {
            let mut kept = [u32::MAX; MAX_LEVEL + 1];
            let mut next = 0;
            for (l, count) in ends.iter().enumerate() {
                if *count > 0 {
                    kept[l] = next;
                    next += 1;
                }
            }
            ends.retain(|count| *count > 0);
            for l in self.level_of.iter_mut().filter(|l| **l != u32::MAX) {
                *l = kept[*l as usize];
            }
            self.level_count = next as usize;
        }
        if self.levels.len() < self.level_count {
            self.levels.resize_with(self.level_count, Level::default);
        }
        // Where each level's balls go, then (once they are put in place, in the list's order)
        // where each level ends.
        let mut sum = 0;
        for at in ends.iter_mut() {
            (*at, sum) = (sum, sum + *at);
        }
        self.by_level.clear();
        self.by_level.resize(sum as usize, u32::MAX);
        for (k, l) in self.level_of.iter().enumerate() {
            if let Some(at) = ends.get_mut(*l as usize) {
                self.by_level[*at as usize] = k as u32;
                *at += 1;
            }
        }
    }

    /// Every pair of the `balls` balls (indices in this step's list, the smaller first) whose
    /// boxes meet, in increasing order: in each level, each box against those after it in its
    /// row and those of the next row that reach it; and each box against the narrower levels
    /// (queried with its box).
    fn overlapping(&mut self, balls: usize) -> Vec<(usize, usize)> {
        let mut found = std::mem::take(&mut self.found);
        found.prepare(balls);
        let (levels, boxes) = (&self.levels[..self.level_count], &self.boxes);
        for (l, level) in levels.iter().enumerate() {
            level.pairs_within(boxes, &mut found);
            // The first level has none narrower (a crowd of balls alike has only it).
            if l == 0 {
                continue;
            }
            for a in &level.sorted {
                let a_box = &boxes[a.ball as usize].1;
                for narrower in &levels[..l] {
                    for b in narrower.meeting(a_box, boxes) {
                        found.add(a.ball as usize, b);
                    }
                }
            }
        }
        self.found = found;
        self.drain_pairs(balls)
    }

    /// The pairs found, in increasing order (none are held after).
    fn drain_pairs(&mut self, balls: usize) -> Vec<(usize, usize)> {
        let mut out = Vec::with_capacity(self.last_found + self.last_found / 4 + 16);
        self.found.drain_into(balls, &mut out);
        self.last_found = out.len();
        out
    }

    /// This step's ball (index in its list) of a body in it.
    pub(super) fn ball_of_body(&self, body: RigidBodyHandle) -> usize {
        self.ball_of[body.slot()] as usize
    }

    /// The balls (indices in this step's list) whose boxes meet `aabb`, level by level.
    fn meeting<'a>(&'a self, aabb: &'a Aabb) -> impl Iterator<Item = usize> + 'a {
        self.levels[..self.level_count]
            .iter()
            .flat_map(move |level| level.meeting(aabb, &self.boxes))
    }

    /// The body slots and swept boxes of this step's members whose boxes meet `aabb`, read
    /// after the plan (the index keeps the step's boxes until the next step's plan): each
    /// box bounds its body's travel over the step from its start-of-step motion. In no
    /// particular order.
    pub(crate) fn leaves_meeting<'a>(
        &'a self,
        aabb: &'a Aabb,
    ) -> impl Iterator<Item = (u32, Aabb)> + 'a {
        self.meeting(aabb).map(|k| self.boxes[k])
    }

    /// Forgets this step's list (the boxes stay).
    pub(super) fn clear_list(&mut self, leaves: &[(u32, Aabb)]) {
        for (slot, _) in leaves {
            self.ball_of[*slot as usize] = u32::MAX;
        }
    }
}

impl Level {
    /// The level of these balls (indices in the step's list) of `boxes`: each put in its row,
    /// in the balls' order within each (counted out: each row's size, then where each ends,
    /// then the balls put in place from each row's end back, so that `row_start` ends up at
    /// each row's start); then each row sorted by its boxes' low ends along the sweep axis,
    /// with its running maximum of their high ends.
    fn build(&mut self, balls: &[u32], boxes: &[(u32, Aabb)]) {
        let rows = Rows::of(balls.iter().map(|k| &boxes[*k as usize].1));
        self.rows = rows;
        self.row_of.clear();
        self.row_start.clear();
        self.row_start.resize(rows.count + 1, 0);
        for k in balls {
            let r = rows.index(rows.at(boxes[*k as usize].1.mins[rows.across]));
            self.row_start[r] += 1;
            self.row_of.push(r as u32);
        }
        let mut end = 0;
        for at in &mut self.row_start[..rows.count] {
            end += *at;
            *at = end;
        }
        self.row_start[rows.count] = end;
        let unplaced = Sorted {
            low: Real::NAN,
            reach: Real::NAN,
            ball: u32::MAX,
        };
        self.sorted.clear();
        self.sorted.resize(end as usize, unplaced);
        for (i, k) in balls.iter().enumerate().rev() {
            let aabb = &boxes[*k as usize].1;
            let at = &mut self.row_start[self.row_of[i] as usize];
            *at -= 1;
            self.sorted[*at as usize] = Sorted {
                low: aabb.mins[rows.sweep],
                reach: aabb.maxs[rows.sweep],
                ball: *k,
            };
        }
        for r in 0..rows.count {
            let row = &mut self.sorted[self.row_start[r] as usize..self.row_start[r + 1] as usize];
            row.sort_unstable_by(|a, b| a.low.total_cmp(&b.low));
            // Each entry's `reach` was placed as its own high end.
            let mut reach = Real::NEG_INFINITY;
            for entry in row {
                reach = reach.max(entry.reach);
                entry.reach = reach;
            }
        }
    }

    /// Row `r`'s balls (empty past the last row).
    fn row(&self, r: usize) -> &[Sorted] {
        match (self.row_start.get(r), self.row_start.get(r + 1)) {
            (Some(from), Some(to)) => &self.sorted[*from as usize..*to as usize],
            _ => &[],
        }
    }

    /// Adds to `found` every pair of the level's balls whose `boxes` meet: each box against
    /// those after it in its row and those of the next row that reach it.
    fn pairs_within(&self, boxes: &[(u32, Aabb)], found: &mut FoundPairs) {
        let sweep = self.rows.sweep;
        for r in 0..self.rows.count {
            let (row, next) = (self.row(r), self.row(r + 1));
            for (i, a) in row.iter().enumerate() {
                let a_box = &boxes[a.ball as usize].1;
                let high = a_box.maxs[sweep];
                let from = next.partition_point(|e| e.reach < a.low);
                // Each part is sorted by low end: its scan ends at the first past `high`.
                for b in row[i + 1..]
                    .iter()
                    .take_while(|b| b.low <= high)
                    .chain(next[from..].iter().take_while(|b| b.low <= high))
                {
                    if a_box.intersects(&boxes[b.ball as usize].1) {
                        found.add(a.ball as usize, b.ball as usize);
                    }
                }
            }
        }
    }

    /// The level's balls whose `boxes` meet `aabb`: in each row that can hold one (from the
    /// row before its low end's to its high end's), from the first whose row so far reaches
    /// its low end to the last whose low end is not past its high end. Row by row, each in
    /// its order.
    fn meeting<'a>(
        &'a self,
        aabb: &'a Aabb,
        boxes: &'a [(u32, Aabb)],
    ) -> impl Iterator<Item = usize> + 'a {
        let rows = &self.rows;
        let rows_met = if comparable(aabb) {
            let first = rows.index(rows.at(aabb.mins[rows.across]) - 1.0);
            let last = rows.index(rows.at(aabb.maxs[rows.across]));
            first..last + 1
        } else {
            0..0
        };
        let sweep = rows.sweep;
        rows_met.flat_map(move |r| {
            let row = self.row(r);
            let from = row.partition_point(|e| e.reach < aabb.mins[sweep]);
            row[from..]
                .iter()
                .take_while(move |e| e.low <= aabb.maxs[sweep])
                .map(|e| e.ball as usize)
                .filter(move |k| boxes[*k].1.intersects(aabb))
        })
    }
}

/// Can the box meet any (is every coordinate a number)? One that is not meets none.
fn comparable(aabb: &Aabb) -> bool {
    !(aabb.mins.is_nan() || aabb.maxs.is_nan())
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
    /// every overlapping pair when the whole index was searched (`traversed`), else those
    /// with a mover.
    pub pairs: Vec<(usize, usize)>,
    /// `pairs` is every overlapping pair: the chains read each ball's neighbours from it
    /// instead of querying the index again.
    pub traversed: bool,
}

impl Candidates {
    /// The pairs to evaluate, in the order the plan evaluates them: every overlapping pair
    /// with a mover (any pair where a restitution can reach 1).
    pub(super) fn to_evaluate<'c>(
        &'c self,
        members: &'c Members,
    ) -> impl Iterator<Item = (usize, usize)> + 'c {
        // Without a whole search the list holds only pairs with a mover.
        let every = members.any_elastic || !self.traversed;
        self.pairs
            .iter()
            .copied()
            .filter(move |(i, j)| every || members.is_mover[*i] || members.is_mover[*j])
    }
}

/// The step's candidate pairs. Reads the index (its list must be the members') and the
/// members' movers; mutates only the index's found pairs and their count. The whole index is
/// searched when more than a third of the balls move or a restitution can reach 1 (its pairs
/// then also give the chains each carrier's neighbours, which would otherwise query the index
/// again; searched only from two thirds, the pair plan of `many_balls --pairs --count 500
/// --mode exact` ran 4 % more instructions); otherwise each mover's box is queried, and a
/// pair of two movers is listed once, from the first.
pub(super) fn candidates(index: &mut PairIndex, members: &Members) -> Candidates {
    let mover = |k: usize| members.is_mover[k];
    let balls = members.balls.len();
    if members.any_elastic || 3 * members.movers > balls {
        return Candidates {
            pairs: index.overlapping(balls),
            traversed: true,
        };
    }
    let mut found = std::mem::take(&mut index.found);
    found.prepare(balls);
    for m in (0..balls).filter(|m| mover(*m)) {
        for j in index.meeting(&members.leaves[m].1) {
            if j != m && (j > m || !mover(j)) {
                found.add(m, j);
            }
        }
    }
    index.found = found;
    // In increasing order, as the whole search's.
    Candidates {
        pairs: index.drain_pairs(balls),
        traversed: false,
    }
}

/// The pairs of a step's balls as they are found, put in increasing order when drained: two
/// stable counting passes, by the second ball and then by the first. The cost is O(pairs and
/// balls), where comparing whole pairs costs a factor of log(pairs), and no branch depends on
/// the pairs' values (sorting each ball's few pairs instead mispredicts the branches of its
/// small sorts). The lists are kept from step to step (`PairIndex`), so that a step's pairs
/// allocate nothing once they have grown.
#[derive(Default)]
struct FoundPairs {
    /// The pairs as found, the smaller ball first (`u32`, as the step's balls are numbered
    /// in `PairIndex::ball_of`).
    pairs: Vec<(u32, u32)>,
    /// The pairs by their second ball (the first pass's result).
    by_second: Vec<(u32, u32)>,
    /// Each ball's count, then where its pairs go.
    starts: Vec<u32>,
}

impl FoundPairs {
    /// Room for the pairs of `balls` balls (none are held).
    fn prepare(&mut self, balls: usize) {
        debug_assert!(self.pairs.is_empty());
        if self.starts.len() < balls {
            self.starts.resize(balls, 0);
        }
    }

    /// Adds the pair of balls `i` and `j` (either order, distinct).
    fn add(&mut self, i: usize, j: usize) {
        self.pairs.push((i.min(j) as u32, i.max(j) as u32));
    }

    /// Appends the pairs `(i, j)`, `i < j < balls`, in increasing order, and forgets them.
    fn drain_into(&mut self, balls: usize, out: &mut Vec<(usize, usize)>) {
        let starts = &mut self.starts[..balls];
        self.by_second.clear();
        self.by_second.resize(self.pairs.len(), (0, 0));
        let by_second = &mut self.by_second;
        counting_pass(&self.pairs, |p| p.1, starts, |at, p| by_second[at] = p);
        let base = out.len();
        out.resize(base + self.pairs.len(), (0, 0));
        let sorted = &mut out[base..];
        counting_pass(
            &self.by_second,
            |p| p.0,
            starts,
            |at, (i, j)| {
                sorted[at] = (i as usize, j as usize);
            },
        );
        self.pairs.clear();
    }
}

/// One stable counting pass of `pairs` by `key` (below `starts.len()`): `put` is given each
/// pair's place in the order, in the pairs' order. `starts` is left zeroed.
fn counting_pass(
    pairs: &[(u32, u32)],
    key: impl Fn(&(u32, u32)) -> u32,
    starts: &mut [u32],
    mut put: impl FnMut(usize, (u32, u32)),
) {
    for p in pairs {
        starts[key(p) as usize] += 1;
    }
    let mut sum = 0;
    for at in starts.iter_mut() {
        let count = *at;
        *at = sum;
        sum += count;
    }
    for p in pairs {
        let at = &mut starts[key(p) as usize];
        put(*at as usize, *p);
        *at += 1;
    }
    starts.fill(0);
}

/// Each ball's neighbours in the index for the chains: from the whole search's pairs when
/// there was one (built once, on first use), else by a query of the index.
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
    use super::{FoundPairs, PairIndex, ROW_ROOM};
    use crate::rapier::math::{Real, Vector};
    use crate::rapier::parry::bounding_volume::{Aabb, BoundingVolume};
    use proptest::prelude::*;

    /// A box on a grid of `step` (m), so that boxes often touch exactly, of half-sizes drawn
    /// from `halves`; now and then one with a coordinate that is not a number.
    fn grid_box(step: Real, halves: Vec<Real>) -> impl Strategy<Value = Aabb> {
        let coordinate = (-16i32..16).prop_map(move |k| k as Real * step);
        let half = prop::sample::select(halves);
        let special = prop::sample::select(vec![0u8, 0, 0, 0, 0, 0, 0, 0, 0, 1, 2]);
        (
            [coordinate.clone(), coordinate.clone(), coordinate],
            [half.clone(), half.clone(), half],
            special,
            0usize..3,
        )
            .prop_map(|(c, h, special, axis)| {
                let (mut mins, mut maxs) = (
                    Vector::new(c[0] - h[0], c[1] - h[1], c[2] - h[2]),
                    Vector::new(c[0] + h[0], c[1] + h[1], c[2] + h[2]),
                );
                match special {
                    1 => mins[axis] = Real::NAN,
                    2 => maxs[axis] = Real::NAN,
                    _ => {}
                }
                Aabb::new(mins, maxs)
            })
    }

    /// Lists of boxes: small ones spread over many rows (a crowd), or boxes of every size
    /// (several levels, an unbounded box in the last); some of them flat or inverted along an
    /// axis.
    fn boxes(len: std::ops::Range<usize>) -> impl Strategy<Value = Vec<Aabb>> {
        prop_oneof![
            prop::collection::vec(
                grid_box(0.25, vec![-0.125, 0.0, 0.125, 0.25, 0.375]),
                len.clone()
            ),
            prop::collection::vec(
                grid_box(0.25, vec![-0.125, 0.0, 0.25, 0.5, 1.0, 3.0, Real::INFINITY]),
                len
            ),
        ]
    }

    /// Every pair of `boxes` that meet, by comparing each with each.
    fn every_pair(boxes: &[Aabb]) -> Vec<(usize, usize)> {
        let mut pairs = Vec::new();
        for i in 0..boxes.len() {
            for j in i + 1..boxes.len() {
                if boxes[i].intersects(&boxes[j]) {
                    pairs.push((i, j));
                }
            }
        }
        pairs
    }

    /// Leaves of distinct slots (in a scrambled order) with these boxes.
    fn leaves(boxes: &[Aabb]) -> Vec<(u32, Aabb)> {
        boxes
            .iter()
            .enumerate()
            .map(|(k, b)| (((k * 37 + 11) % 211) as u32, *b))
            .collect()
    }

    proptest! {
        #![proptest_config(ProptestConfig {
            cases: 600,
            rng_algorithm: prop::test_runner::RngAlgorithm::ChaCha,
            rng_seed: prop::test_runner::RngSeed::Fixed(0x5eed_0067),
            failure_persistence: None,
            ..ProptestConfig::default()
        })]

        /// The whole search finds every pair of boxes that parry's `Aabb::intersects` says
        /// meet, and no other, in increasing order; a query finds every box that meets the
        /// query's box: touching (at a box's high corner, and at its low corner from below,
        /// where a row's bounds are tight), unbounded and not-a-number boxes included. The
        /// index is updated twice, so that the second list replaces the first.
        #[test]
        fn the_rows_find_what_comparing_every_pair_finds(
            first in boxes(0..20),
            boxes in boxes(0..80),
            queries in prop::collection::vec(
                grid_box(0.5, vec![-0.5, 0.0, 0.5, 2.0, Real::INFINITY]),
                1..6,
            ),
        ) {
            let mut index = PairIndex::default();
            let old = leaves(&first);
            index.update(&old);
            prop_assert_eq!(index.overlapping(first.len()), every_pair(&first));
            index.clear_list(&old);
            let leaves = leaves(&boxes);
            index.update(&leaves);
            prop_assert_eq!(index.overlapping(boxes.len()), every_pair(&boxes));
            // Besides the drawn queries, one touching each box at its high corner, and one
            // at its low corner.
            let corners = boxes.iter().flat_map(|b| {
                [
                    Aabb::new(b.maxs, b.maxs + Vector::splat(1.0)),
                    Aabb::new(b.mins - Vector::splat(0.125), b.mins),
                ]
            });
            for query in queries.iter().copied().chain(corners) {
                let query = &query;
                let mut found: Vec<u32> = index.leaves_meeting(query).map(|(s, _)| s).collect();
                found.sort_unstable();
                let mut expected: Vec<u32> = leaves
                    .iter()
                    .filter(|(_, b)| b.intersects(query))
                    .map(|(s, _)| *s)
                    .collect();
                expected.sort_unstable();
                prop_assert_eq!(found, expected);
            }
            for (k, (slot, _)) in leaves.iter().enumerate() {
                let handle = crate::rapier::prelude::RigidBodyHandle::from_raw_parts(*slot, 0);
                prop_assert_eq!(index.ball_of_body(handle), k);
            }
        }
    }

    /// A crowd of small boxes far from the origin is cut into many rows, and the whole search
    /// still finds each overlapping pair, across rows too: the rows are what the search
    /// relies on, so this checks they are there. A few boxes 40 times as wide (fast balls)
    /// are put in levels of their own rather than widening every row, and meet the crowd
    /// there.
    #[test]
    fn a_crowd_far_out_lies_in_many_rows_and_every_overlapping_pair_is_found() {
        let (n, half, gap): (usize, Real, Real) = (400, 0.06, 0.1);
        let mut boxes: Vec<Aabb> = (0..n)
            .map(|k| {
                let (i, j) = ((k % 20) as Real, (k / 20) as Real);
                let c = Vector::new(1.0e4 + i * gap, 0.5, -3.0e3 + j * gap);
                Aabb::from_half_extents(c, Vector::splat(half))
            })
            .collect();
        // Each box overlaps its neighbours along the grid and along its diagonals.
        assert_eq!(every_pair(&boxes).len(), 2 * 20 * 19 + 2 * 19 * 19);
        let mut index = PairIndex::default();
        index.update(&leaves(&boxes));
        assert_eq!(index.level_count, 1);
        assert!(
            index.levels[0].rows.count >= 10,
            "{:?}",
            index.levels[0].rows
        );
        assert_eq!(index.overlapping(n), every_pair(&boxes));
        for k in [3, 171, 398] {
            let c = boxes[k].center();
            boxes.push(Aabb::from_half_extents(c, Vector::splat(40.0 * half)));
        }
        index.update(&leaves(&boxes));
        // The crowd, and the wide boxes three levels up (the two between, empty, dropped).
        assert_eq!(index.level_count, 2);
        assert_eq!(index.levels[1].sorted.len(), 3);
        assert!(
            index.levels[0].rows.count >= 10,
            "{:?}",
            index.levels[0].rows
        );
        assert_eq!(index.overlapping(boxes.len()), every_pair(&boxes));
    }

    /// Boxes far apart along the axis they spread along make more rows than boxes, most of
    /// them empty, each wider than the widest box: the pairs and queries are still found.
    #[test]
    fn rows_wider_than_the_boxes_with_empty_rows_between_find_every_pair() {
        let point = |x: Real| Aabb::new(Vector::new(x, 0.0, 0.0), Vector::new(x, 0.0, 0.0));
        let small =
            |x: Real| Aabb::from_half_extents(Vector::new(x, 0.0, 0.0), Vector::splat(1.0 / 128.0));
        let boxes = vec![
            point(0.0),
            small(0.0),
            point(100.0),
            small(100.0 + 1.0 / 128.0),
            small(37.5),
        ];
        let mut index = PairIndex::default();
        index.update(&leaves(&boxes));
        let rows = index.levels[0].rows;
        assert!(rows.count > boxes.len(), "{rows:?}");
        assert!(rows.width > (1.0 / 64.0) * (1.0 + ROW_ROOM), "{rows:?}");
        assert_eq!(index.overlapping(boxes.len()), every_pair(&boxes));
        let query = Aabb::new(Vector::new(99.0, -1.0, -1.0), Vector::new(100.0, 1.0, 1.0));
        let mut found: Vec<u32> = index.leaves_meeting(&query).map(|(s, _)| s).collect();
        found.sort_unstable();
        let mut expected: Vec<u32> = leaves(&boxes)
            .iter()
            .filter(|(_, b)| b.intersects(&query))
            .map(|(s, _)| *s)
            .collect();
        expected.sort_unstable();
        assert_eq!(found.len(), 2);
        assert_eq!(found, expected);
    }

    /// The found pairs drain in the order a comparison sort of the tuples gives, balls
    /// without pairs, pairs given either way round and a last ball without pairs included.
    #[test]
    fn found_pairs_drain_in_the_order_of_tuples() {
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
        let mut found = FoundPairs::default();
        found.prepare(balls);
        for (k, (i, j)) in pairs.iter().enumerate() {
            if k % 2 == 0 {
                found.add(*i, *j);
            } else {
                found.add(*j, *i);
            }
        }
        let mut out = Vec::new();
        found.drain_into(balls, &mut out);
        assert_eq!(out, expected);
        let mut none = Vec::new();
        found.drain_into(balls, &mut none);
        assert!(none.is_empty());
    }
}
