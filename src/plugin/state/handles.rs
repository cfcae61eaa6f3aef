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

use crate::rapier::prelude::ColliderHandle;

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

/// The collider handle pair key of a body collider and a ground collider.
pub(crate) type PairKey = (ColliderHandle, ColliderHandle);
