//! A cluster's agenda: the next event of each body's ground and of each pair, searched once
//! and again only when one of its bodies changed, taken earliest first.
//!
//! Invariant: ties go to a ground impact before a touch, then to the lowest index, so the
//! order of events is the same every run.

use crate::motion::State;
use crate::plugin::queries::body_contact::BodyTouch;
use crate::plugin::queries::geometry::Hit;
use std::cmp::Reverse;
use std::collections::BinaryHeap;

/// What happens next in the cluster.
#[derive(Clone, Copy)]
pub(super) enum Next {
    /// Body `k`'s ground impact: its state there, and the hit.
    Ground(usize, State, Hit),
    /// The pair of this index in the cluster's pairs, with parry's contact for a pair not
    /// both centred balls.
    Touch(usize, Option<BodyTouch>),
}

impl Next {
    /// The same event, a pair's touch named as pair `p`.
    pub(super) fn as_pair(self, p: usize) -> Self {
        match self {
            Next::Touch(_, touch) => Next::Touch(p, touch),
            ground => ground,
        }
    }
}

/// A cluster's next events, each found once and searched again only when one of its bodies
/// changed: an event costs the searches of its bodies' ground and pairs, not of every pair of
/// the cluster. The earliest comes first; ties go to a ground impact before a touch, then to
/// the lowest index, the same every run.
#[derive(Default)]
pub(super) struct Agenda {
    queue: BinaryHeap<Reverse<Due>>,
    /// The event found for each body's ground, and the number of its search: an entry in the
    /// queue from an earlier search is stale.
    grounds: Vec<(u32, Option<Next>)>,
    /// The same for each pair's touch.
    touches: Vec<(u32, Option<Next>)>,
}

/// An entry of the [`Agenda`]'s queue.
#[derive(Clone, Copy, Debug)]
struct Due {
    t: f64,
    /// A body's ground impact comes before a pair's touch at the same time.
    kind: Kind,
    /// The body's or the pair's index.
    index: usize,
    search: u32,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
enum Kind {
    Ground,
    Touch,
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
            .then(self.kind.cmp(&other.kind))
            .then(self.index.cmp(&other.index))
            .then(self.search.cmp(&other.search))
    }
}

impl Agenda {
    /// An empty agenda with room for `bodies` bodies and `pairs` pairs.
    pub(super) fn with_room(bodies: usize, pairs: usize) -> Self {
        Self {
            queue: BinaryHeap::with_capacity(bodies + pairs),
            grounds: Vec::with_capacity(bodies),
            touches: Vec::with_capacity(pairs),
        }
    }

    /// Empties the agenda, for `bodies` bodies and `pairs` pairs, with room for `room` of
    /// each (those added on the way); the lists' room is kept.
    pub(super) fn reset(&mut self, (bodies, pairs): (usize, usize), room: (usize, usize)) {
        self.queue.clear();
        self.queue.reserve(bodies + pairs);
        self.grounds.clear();
        self.grounds.reserve(room.0);
        self.grounds.resize_with(bodies, || (0, None));
        self.touches.clear();
        self.touches.reserve(room.1);
        self.touches.resize_with(pairs, || (0, None));
    }

    /// Room for one more body (the next index), with no event yet.
    pub(super) fn add_body(&mut self) {
        self.grounds.push((0, None));
    }

    /// Room for one more pair (the next index), with no event yet.
    pub(super) fn add_pair(&mut self) {
        self.touches.push((0, None));
    }

    /// Body `k`'s ground impact, as last searched.
    pub(super) fn ground(&mut self, k: usize, next: Option<(f64, Next)>) {
        self.set(Kind::Ground, k, next);
    }

    /// Pair `p`'s touch, as last searched (`None` also for a pair resting from here).
    pub(super) fn touch(&mut self, p: usize, next: Option<(f64, Next)>) {
        self.set(Kind::Touch, p, next);
    }

    fn entry(&mut self, kind: Kind, index: usize) -> &mut (u32, Option<Next>) {
        match kind {
            Kind::Ground => &mut self.grounds[index],
            Kind::Touch => &mut self.touches[index],
        }
    }

    /// Replaces the event of a body's ground or a pair's touch: its earlier entry in the
    /// queue becomes stale.
    fn set(&mut self, kind: Kind, index: usize, next: Option<(f64, Next)>) {
        let entry = self.entry(kind, index);
        entry.0 += 1;
        entry.1 = None;
        let search = entry.0;
        if let Some((t, event)) = next {
            entry.1 = Some(event);
            self.queue.push(Reverse(Due {
                t,
                kind,
                index,
                search,
            }));
        }
    }

    /// The earliest event still current, taken off the agenda.
    pub(super) fn pop(&mut self) -> Option<(f64, Next)> {
        while let Some(Reverse(due)) = self.queue.pop() {
            let entry = self.entry(due.kind, due.index);
            if entry.0 == due.search {
                if let Some(event) = entry.1.take() {
                    return Some((due.t, event));
                }
            }
        }
        None
    }
}
