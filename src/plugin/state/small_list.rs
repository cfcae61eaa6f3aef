//! A list that keeps one element inline: the adapter's per-body and per-step lists.

/// The capacity a list takes when it spills to a `Vec`.
const SPILL_CAPACITY: usize = 8;

/// A list that keeps one element inline and spills to a `Vec` beyond: most bodies have one
/// collider and touch one ground, and the per-step lists of the adapter then allocate nothing.
#[derive(Clone, Debug, Default)]
pub(crate) enum SmallList<T> {
    #[default]
    Empty,
    One(T),
    Many(Vec<T>),
}

impl<T> SmallList<T> {
    #[inline]
    pub fn push(&mut self, x: T) {
        match self {
            Self::Empty => *self = Self::One(x),
            Self::One(_) => self.spill(x),
            Self::Many(v) => v.push(x),
        }
    }

    /// A second element: the list spills to a `Vec`. Out of line, so that the lists of one
    /// element (most) keep their callers' code short.
    #[cold]
    #[inline(never)]
    fn spill(&mut self, x: T) {
        if let Self::One(a) = std::mem::take(self) {
            // Room for a few more: a ball over a tiled floor is near several tiles, and
            // growing one by one reallocates at each.
            let mut v = Vec::with_capacity(SPILL_CAPACITY);
            v.extend([a, x]);
            *self = Self::Many(v);
        }
    }
}

impl<T> std::ops::Deref for SmallList<T> {
    type Target = [T];

    #[inline]
    fn deref(&self) -> &[T] {
        match self {
            Self::Empty => &[],
            Self::One(a) => std::slice::from_ref(a),
            Self::Many(v) => v,
        }
    }
}

impl<T> std::ops::DerefMut for SmallList<T> {
    #[inline]
    fn deref_mut(&mut self) -> &mut [T] {
        match self {
            Self::Empty => &mut [],
            Self::One(a) => std::slice::from_mut(a),
            Self::Many(v) => v,
        }
    }
}

impl<'s, T> IntoIterator for &'s SmallList<T> {
    type Item = &'s T;
    type IntoIter = std::slice::Iter<'s, T>;

    fn into_iter(self) -> Self::IntoIter {
        self.iter()
    }
}

impl<T> FromIterator<T> for SmallList<T> {
    fn from_iter<I: IntoIterator<Item = T>>(iter: I) -> Self {
        let iter = iter.into_iter();
        let (at_least, _) = iter.size_hint();
        if at_least > 1 {
            let mut v = Vec::with_capacity(at_least.max(SPILL_CAPACITY));
            v.extend(iter);
            return Self::Many(v);
        }
        let mut list = Self::Empty;
        for x in iter {
            list.push(x);
        }
        list
    }
}
