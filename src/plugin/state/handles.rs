//! Hash maps and sets keyed by rapier handles.

use std::collections::{BTreeMap, HashMap, HashSet};
use std::hash::{BuildHasherDefault, Hasher};

/// A small multiplicative hasher for handle keys (looked up in every hook call): the
/// default SipHash is several times slower and its DoS resistance is not needed here.
#[derive(Default)]
pub(crate) struct HandleHasher(u64);

impl Hasher for HandleHasher {
    fn finish(&self) -> u64 {
        self.0
    }

    fn write(&mut self, bytes: &[u8]) {
        for b in bytes {
            self.write_u64(u64::from(*b));
        }
    }

    fn write_u32(&mut self, i: u32) {
        self.write_u64(u64::from(i));
    }

    fn write_u64(&mut self, i: u64) {
        self.0 = (self.0.rotate_left(5) ^ i).wrapping_mul(0x51_7c_c1_b7_27_22_0a_95);
    }

    fn write_usize(&mut self, i: usize) {
        self.write_u64(i as u64);
    }
}

/// Hash map keyed by rapier handles.
pub(crate) type HandleMap<K, V> = HashMap<K, V, BuildHasherDefault<HandleHasher>>;
/// Hash set of rapier handles.
pub(crate) type HandleSet<K> = HashSet<K, BuildHasherDefault<HandleHasher>>;

use crate::rapier::prelude::{ColliderHandle, RigidBodyHandle};

/// A collider handle's index in its arena.
#[inline]
pub(crate) fn slot_of(c: ColliderHandle) -> usize {
    c.into_raw_parts().0 as usize
}

/// A rapier handle's arena slot: what the plugin's tables by handle index (a [`SlotTable`], the
/// writes' log, the pair index's leaves), the generation told apart by the handle itself.
pub(crate) trait Slotted: Copy + Eq {
    /// The handle's index in its arena.
    fn slot(self) -> usize;
}

impl Slotted for ColliderHandle {
    #[inline]
    fn slot(self) -> usize {
        slot_of(self)
    }
}

impl Slotted for RigidBodyHandle {
    #[inline]
    fn slot(self) -> usize {
        self.into_raw_parts().0 as usize
    }
}

/// Whether a table indexed by arena slot ([`SlotTable`], `Shadows`), whose vector holds
/// `held` slots and which has `entries` entries with the new one, keeps an entry read from a
/// snapshot at `slot` in its vector (grown to it if need be): a slot it holds, any below
/// `SLOT_SLACK`, and `SLOTS_PER_ENTRY` more for each entry. A world's handles need no bound
/// (rapier's arenas hand slots out from 0 up, so the world holds as many entries as the
/// slot), but a snapshot is only data: one edited by hand can name a slot near `u32::MAX`.
/// Such an entry is kept aside, by slot, so that the memory a snapshot costs follows its
/// entries, not the largest slot it names.
pub(crate) fn restored_in_vector(slot: usize, held: usize, entries: usize) -> bool {
    const SLOT_SLACK: usize = 1 << 16;
    const SLOTS_PER_ENTRY: usize = 64;
    slot < held || slot < SLOT_SLACK.saturating_add(entries.saturating_mul(SLOTS_PER_ENTRY))
}

/// Moves into `slots` (just grown) the entries kept aside in `far` that it now reaches, as
/// `into` makes them. Every entry left in `far` is then beyond `slots`.
pub(crate) fn take_in_far<T, U>(
    slots: &mut [U],
    far: &mut BTreeMap<usize, T>,
    into: impl Fn(T) -> U,
) {
    while let Some(entry) = far.first_entry() {
        if *entry.key() >= slots.len() {
            break;
        }
        let (at, moved) = entry.remove_entry();
        slots[at] = into(moved);
    }
}

/// Values by handle, in a vector indexed by the handle's arena slot: a lookup is an index and
/// a handle compare, for the tables asked in every hook call or of every body in a step.
///
/// Invariant: an entry is in `slots` at its slot, or in `far` when its slot is at least
/// `slots.len()` (a restored entry not [`restored_in_vector`]); growing the vector moves in
/// the far entries it reaches.
#[derive(Clone, Debug)]
pub(crate) struct SlotTable<K, V> {
    slots: Vec<Option<(K, V)>>,
    far: BTreeMap<usize, (K, V)>,
    len: usize,
}

impl<K, V> Default for SlotTable<K, V> {
    fn default() -> Self {
        Self {
            slots: Vec::new(),
            far: BTreeMap::new(),
            len: 0,
        }
    }
}

impl<K: Slotted, V: Copy> SlotTable<K, V> {
    /// The value of `k`, if it has one.
    #[inline]
    pub fn get(&self, k: K) -> Option<&V> {
        let entry = match self.slots.get(k.slot()) {
            Some(entry) => entry.as_ref(),
            None if self.far.is_empty() => None,
            None => self.far.get(&k.slot()),
        };
        match entry {
            Some((h, v)) if *h == k => Some(v),
            _ => None,
        }
    }

    /// Does `k` have a value?
    #[inline]
    pub fn contains(&self, k: K) -> bool {
        self.get(k).is_some()
    }

    /// Sets the value of `k`, a world's handle (a handle of the same slot and another
    /// generation is replaced); `true` if `k` had none.
    pub fn insert(&mut self, k: K, v: V) -> bool {
        let i = k.slot();
        if i >= self.slots.len() {
            self.grow_to(i);
        }
        let slot = &mut self.slots[i];
        let new = !matches!(slot, Some((h, _)) if *h == k);
        if slot.is_none() {
            self.len += 1;
        }
        *slot = Some((k, v));
        new
    }

    /// The vector grown to hold slot `i`, the far entries it reaches moved in.
    #[cold]
    fn grow_to(&mut self, i: usize) {
        self.slots.resize(i + 1, None);
        take_in_far(&mut self.slots, &mut self.far, Some);
    }

    /// Sets the value of `k`, a handle read from a snapshot, which may name a slot no world
    /// holds: beyond [`restored_in_vector`] it is kept aside. As [`Self::insert`] otherwise.
    pub fn insert_restored(&mut self, k: K, v: V) -> bool {
        let i = k.slot();
        if restored_in_vector(i, self.slots.len(), self.len + 1) {
            return self.insert(k, v);
        }
        let replaced = self.far.insert(i, (k, v));
        if replaced.is_none() {
            self.len += 1;
        }
        !matches!(replaced, Some((h, _)) if h == k)
    }

    /// Removes the value of `k`, if it has one.
    pub fn remove(&mut self, k: K) {
        let i = k.slot();
        match self.slots.get_mut(i) {
            Some(slot) => {
                if matches!(slot, Some((h, _)) if *h == k) {
                    *slot = None;
                    self.len -= 1;
                }
            }
            None => {
                if matches!(self.far.get(&i), Some((h, _)) if *h == k) {
                    self.far.remove(&i);
                    self.len -= 1;
                }
            }
        }
    }

    /// Every entry, by slot.
    pub fn iter(&self) -> impl Iterator<Item = (&K, &V)> {
        self.slots
            .iter()
            .flatten()
            .chain(self.far.values())
            .map(|(h, v)| (h, v))
    }

    /// How many handles have a value.
    pub fn len(&self) -> usize {
        self.len
    }

    /// Is the table empty?
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// How many slots the vector holds (its memory, for the tests).
    #[cfg(test)]
    pub fn slots_held(&self) -> usize {
        self.slots.len()
    }
}

/// The collider handle pair key of a body collider and a ground collider.
pub(crate) type PairKey = (ColliderHandle, ColliderHandle);

/// A handle's (or a pair of handles') arena position, the order snapshots list tables in: a
/// hash map's own order depends on its history.
pub(crate) trait ArenaOrder {
    /// The key to sort by.
    fn arena_order(&self) -> [u32; 4];
}

impl ArenaOrder for ColliderHandle {
    fn arena_order(&self) -> [u32; 4] {
        let (i, g) = self.into_raw_parts();
        [i, g, 0, 0]
    }
}

impl ArenaOrder for RigidBodyHandle {
    fn arena_order(&self) -> [u32; 4] {
        let (i, g) = self.into_raw_parts();
        [i, g, 0, 0]
    }
}

impl ArenaOrder for PairKey {
    fn arena_order(&self) -> [u32; 4] {
        let ([a, b, ..], [c, d, ..]) = (self.0.arena_order(), self.1.arena_order());
        [a, b, c, d]
    }
}

/// A map's entries in arena order.
pub(crate) fn sorted_entries<K: ArenaOrder + Copy, V: Clone>(map: &HandleMap<K, V>) -> Vec<(K, V)> {
    let mut entries: Vec<(K, V)> = map.iter().map(|(k, v)| (*k, v.clone())).collect();
    entries.sort_unstable_by_key(|(k, _)| k.arena_order());
    entries
}

/// A set's members in arena order.
pub(crate) fn sorted_members<K: ArenaOrder + Copy>(set: &HandleSet<K>) -> Vec<K> {
    let mut members: Vec<K> = set.iter().copied().collect();
    members.sort_unstable_by_key(ArenaOrder::arena_order);
    members
}

#[cfg(test)]
mod tests {
    use super::SlotTable;
    use crate::rapier::prelude::RigidBodyHandle;

    /// A handle has one entry, by its whole handle: not another generation in its slot, which
    /// replaces it; the count follows inserts, replacements and removals.
    #[test]
    fn a_slot_table_keeps_one_entry_a_handle() {
        let (a, a_next, b) = (
            RigidBodyHandle::from_raw_parts(4, 0),
            RigidBodyHandle::from_raw_parts(4, 1),
            RigidBodyHandle::from_raw_parts(9, 0),
        );
        let mut table = SlotTable::default();
        assert!(table.is_empty() && !table.contains(a));
        assert!(table.insert(a, 1));
        assert!(!table.insert(a, 2), "a second insert finds it there");
        assert_eq!(table.get(a), Some(&2));
        assert!(table.insert(b, 3));
        assert_eq!(table.len(), 2);
        assert!(!table.contains(a_next));
        assert!(!table.contains(RigidBodyHandle::from_raw_parts(40, 0)));
        assert!(table.insert(a_next, 4), "another generation is new");
        assert!(!table.contains(a) && table.len() == 2);
        table.remove(a);
        assert!(
            table.contains(a_next),
            "another generation's removal leaves it"
        );
        table.remove(b);
        assert_eq!((table.len(), table.contains(b)), (1, false));
        table.remove(b);
        assert_eq!(table.len(), 1, "removing what is not there changes nothing");
    }

    /// A restored entry at a slot far beyond the others' (a forged snapshot's) is kept aside:
    /// the vector does not grow to it; it is found, replaced, counted, listed by slot and removed
    /// like any other, and moved in when the vector grows to its slot.
    #[test]
    fn a_slot_table_keeps_a_far_entry_aside() {
        let h = |slot, generation| RigidBodyHandle::from_raw_parts(slot, generation);
        let far = u32::MAX - 1;
        let mut table = SlotTable::default();
        assert!(table.insert_restored(h(far, 0), 1));
        assert!(table.insert(h(2, 0), 2));
        assert_eq!(table.slots_held(), 3);
        assert_eq!(
            (table.get(h(far, 0)), table.get(h(far, 1))),
            (Some(&1), None)
        );
        assert!(!table.insert_restored(h(far, 0), 3), "found again");
        assert!(
            table.insert_restored(h(far, 1), 4),
            "another generation is new"
        );
        assert_eq!((table.len(), table.get(h(far, 0))), (2, None));
        assert!(table.insert_restored(h(200_000, 0), 5));
        let listed: Vec<_> = table.iter().map(|(k, v)| (*k, *v)).collect();
        assert_eq!(
            listed,
            vec![(h(2, 0), 2), (h(200_000, 0), 5), (h(far, 1), 4)]
        );
        // Enough entries bring 200 000 within reach: the vector grows and takes it in.
        for k in 0..3000 {
            table.insert_restored(h(10 + k, 0), 0);
        }
        assert!(table.insert_restored(h(199_999, 0), 6));
        assert_eq!(table.slots_held(), 200_000);
        // A world's handle grows the vector whatever the count.
        assert!(table.insert(h(200_001, 0), 7));
        assert_eq!(table.slots_held(), 200_002);
        assert_eq!(table.get(h(200_000, 0)), Some(&5), "taken in");
        table.remove(h(200_000, 0));
        table.remove(h(far, 0));
        assert_eq!(table.len(), 3004, "another generation's removal leaves it");
        table.remove(h(far, 1));
        assert_eq!((table.len(), table.get(h(far, 1))), (3003, None));
    }
}
