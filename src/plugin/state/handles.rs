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

/// Values by collider, in a vector indexed by the handle's arena slot: a lookup is an index
/// and a handle compare, for the tables asked in every hook call.
#[derive(Clone, Debug)]
pub(crate) struct SlotTable<V> {
    slots: Vec<Option<(ColliderHandle, V)>>,
}

impl<V> Default for SlotTable<V> {
    fn default() -> Self {
        Self { slots: Vec::new() }
    }
}

impl<V: Copy> SlotTable<V> {
    /// The value of `c`, if it has one.
    #[inline]
    pub fn get(&self, c: ColliderHandle) -> Option<&V> {
        match self.slots.get(slot_of(c)) {
            Some(Some((h, v))) if *h == c => Some(v),
            _ => None,
        }
    }

    /// Sets the value of `c` (a handle of the same slot and another generation is replaced).
    pub fn insert(&mut self, c: ColliderHandle, v: V) {
        let i = slot_of(c);
        if i >= self.slots.len() {
            self.slots.resize(i + 1, None);
        }
        self.slots[i] = Some((c, v));
    }

    /// Keeps the entries for which `keep` answers `true`.
    pub fn retain(&mut self, mut keep: impl FnMut(&ColliderHandle, &mut V) -> bool) {
        for slot in &mut self.slots {
            if let Some((h, v)) = slot {
                if !keep(h, v) {
                    *slot = None;
                }
            }
        }
    }

    /// Every entry, by slot.
    pub fn iter(&self) -> impl Iterator<Item = (&ColliderHandle, &V)> {
        self.slots.iter().flatten().map(|(h, v)| (h, v))
    }
}

/// A set of rigid bodies as a table by arena slot: a lookup is an index and a handle compare,
/// for a set asked of every body in several stages of a step.
#[derive(Clone, Debug, Default)]
pub(crate) struct BodySlots {
    slots: Vec<Option<RigidBodyHandle>>,
    len: usize,
}

impl BodySlots {
    /// Adds `body`; `false` if it was in the set already. A body of another generation in
    /// the same slot is replaced (the set outlives no body removal: it is rebuilt each step).
    pub fn insert(&mut self, body: RigidBodyHandle) -> bool {
        let i = body.into_raw_parts().0 as usize;
        if i >= self.slots.len() {
            self.slots.resize(i + 1, None);
        }
        let slot = &mut self.slots[i];
        if *slot == Some(body) {
            return false;
        }
        if slot.is_none() {
            self.len += 1;
        }
        *slot = Some(body);
        true
    }

    /// Is `body` in the set?
    #[inline]
    pub fn contains(&self, body: &RigidBodyHandle) -> bool {
        matches!(self.slots.get(body.into_raw_parts().0 as usize), Some(Some(b)) if b == body)
    }

    /// How many bodies the set holds.
    pub fn len(&self) -> usize {
        self.len
    }

    /// Is the set empty?
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
    use super::BodySlots;
    use crate::rapier::prelude::RigidBodyHandle;

    /// A body is in the set once, by its whole handle: not another generation in its slot.
    #[test]
    fn body_slots_hold_each_body_once_by_its_handle() {
        let (a, a_next, b) = (
            RigidBodyHandle::from_raw_parts(4, 0),
            RigidBodyHandle::from_raw_parts(4, 1),
            RigidBodyHandle::from_raw_parts(9, 0),
        );
        let mut set = BodySlots::default();
        assert!(set.is_empty() && !set.contains(&a));
        assert!(set.insert(a));
        assert!(!set.insert(a), "a second insert finds it there");
        assert!(set.insert(b));
        assert_eq!(set.len(), 2);
        assert!(set.contains(&a) && set.contains(&b));
        assert!(!set.contains(&a_next));
        assert!(!set.contains(&RigidBodyHandle::from_raw_parts(40, 0)));
    }
}
