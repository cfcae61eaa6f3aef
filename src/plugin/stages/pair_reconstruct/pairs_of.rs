//! Each body's pairs in a cluster's run, in the order they were added, as chains through one
//! list: a run's lists stay flat, cleared and filled again by the next run without allocating.

/// No link: the end of a chain, or a body without pairs.
const NONE: usize = usize::MAX;

/// Each body's pairs (indices into the run's pairs), in the order added.
#[derive(Default)]
pub(super) struct PairsOf {
    /// Each body's first and last link (`NONE` for a body without pairs).
    ends: Vec<(usize, usize)>,
    /// Each link: its pair, and the next link of the same body.
    links: Vec<(usize, usize)>,
}

impl PairsOf {
    /// No bodies, with room for `bodies` bodies and `pairs` pairs.
    pub(super) fn with_room(bodies: usize, pairs: usize) -> Self {
        Self {
            ends: Vec::with_capacity(bodies),
            links: Vec::with_capacity(2 * pairs),
        }
    }

    /// `bodies` bodies without pairs, the lists' room kept.
    pub(super) fn reset(&mut self, bodies: usize) {
        self.ends.clear();
        self.ends.resize(bodies, (NONE, NONE));
        self.links.clear();
    }

    /// One more body (the next index), without pairs.
    pub(super) fn add_body(&mut self) {
        self.ends.push((NONE, NONE));
    }

    /// Pair `p` is one of body `k`'s, after those it has.
    pub(super) fn push(&mut self, k: usize, p: usize) {
        let link = self.links.len();
        self.links.push((p, NONE));
        let (first, last) = &mut self.ends[k];
        if *first == NONE {
            *first = link;
        } else {
            self.links[*last].1 = link;
        }
        *last = link;
    }

    /// Body `k`'s pairs, in the order added.
    pub(super) fn of(&self, k: usize) -> impl Iterator<Item = usize> + '_ {
        let mut link = self.ends[k].0;
        std::iter::from_fn(move || {
            let (p, next) = *self.links.get(link)?;
            link = next;
            Some(p)
        })
    }
}

#[cfg(test)]
mod tests {
    use super::PairsOf;

    #[test]
    fn each_body_lists_its_pairs_in_the_order_added() {
        let mut pairs_of = PairsOf::default();
        pairs_of.reset(3);
        for (p, (i, j)) in [(0, 1), (1, 2), (0, 2)].into_iter().enumerate() {
            pairs_of.push(i, p);
            pairs_of.push(j, p);
        }
        pairs_of.add_body();
        pairs_of.push(3, 3);
        pairs_of.push(1, 3);
        let of = |k| pairs_of.of(k).collect::<Vec<_>>();
        assert_eq!(
            [of(0), of(1), of(2), of(3)],
            [vec![0, 2], vec![0, 1, 3], vec![1, 2], vec![3]]
        );
        pairs_of.reset(2);
        assert!(pairs_of.of(0).next().is_none() && pairs_of.of(1).next().is_none());
    }
}
