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

/// The collider handle pair key of a body collider and a ground collider.
pub(crate) type PairKey = (ColliderHandle, ColliderHandle);
