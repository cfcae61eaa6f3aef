//! Hash maps and sets keyed by rapier handles.

use std::collections::{HashMap, HashSet};
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

/// Values by handle, in a vector indexed by the handle's arena slot: a lookup is an index and
/// a handle compare, for the tables asked in every hook call or of every body in a step.
#[derive(Clone, Debug)]
pub(crate) struct SlotTable<K, V> {
    slots: Vec<Option<(K, V)>>,
    len: usize,
}

impl<K, V> Default for SlotTable<K, V> {
    fn default() -> Self {
        Self {
            slots: Vec::new(),
            len: 0,
        }
    }
}

impl<K: Slotted, V: Copy> SlotTable<K, V> {
    /// The value of `k`, if it has one.
    #[inline]
    pub fn get(&self, k: K) -> Option<&V> {
        match self.slots.get(k.slot()) {
            Some(Some((h, v))) if *h == k => Some(v),
            _ => None,
        }
    }

    /// Does `k` have a value?
    #[inline]
    pub fn contains(&self, k: K) -> bool {
        self.get(k).is_some()
    }

    /// Sets the value of `k` (a handle of the same slot and another generation is replaced);
    /// `true` if `k` had none.
    pub fn insert(&mut self, k: K, v: V) -> bool {
        let i = k.slot();
        if i >= self.slots.len() {
            self.slots.resize(i + 1, None);
        }
        let slot = &mut self.slots[i];
        let new = !matches!(slot, Some((h, _)) if *h == k);
        if slot.is_none() {
            self.len += 1;
        }
        *slot = Some((k, v));
        new
    }

    /// Removes the value of `k`, if it has one.
    pub fn remove(&mut self, k: K) {
        if let Some(slot) = self.slots.get_mut(k.slot()) {
            if matches!(slot, Some((h, _)) if *h == k) {
                *slot = None;
                self.len -= 1;
            }
        }
    }

    /// Every entry, by slot.
    pub fn iter(&self) -> impl Iterator<Item = (&K, &V)> {
        self.slots.iter().flatten().map(|(h, v)| (h, v))
    }

    /// How many handles have a value.
    pub fn len(&self) -> usize {
        self.len
    }

    /// Is the table empty?
    pub fn is_empty(&self) -> bool {
        self.len == 0
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
}
