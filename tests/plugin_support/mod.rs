//! Helpers shared by the `plugin_*` integration tests: the precision conversions, the ground
//! normal and the plugin constructors of `tests/scene_support` (re-exported here, not
//! copied), `f64` nalgebra vectors from rapier's, and a user hook that records the pairs it is
//! asked about.

// Precision-generic: `Real` is f32 or f64 (feature `f64`), so conversions that are
// widening in one build are identities in the other.
#![allow(
    clippy::useless_conversion,
    clippy::unnecessary_cast,
    dead_code,
    unused_imports
)]

#[path = "../scene_support/mod.rs"]
mod scene_support;

use rapier_impact::na::Vector3;
use rapier_impact::rapier::prelude::*;
use std::sync::Mutex;

pub use scene_support::{
    F64, G, jitter, plugin, plugin_on, plugin_with_material, real, up, walled_box, wide,
    world_with_gravity,
};

/// The three timing modes.
pub const MODES: [rapier_impact::TimingMode; 3] = [
    rapier_impact::TimingMode::Step,
    rapier_impact::TimingMode::TimeOfImpact,
    rapier_impact::TimingMode::Exact,
];

/// A rapier vector in `f64`.
pub fn na(v: Vector) -> Vector3<f64> {
    Vector3::new(wide(v.x), wide(v.y), wide(v.z))
}

/// Collider pairs a user hook was asked about, in order.
pub type Pairs = Mutex<Vec<(ColliderHandle, ColliderHandle)>>;

/// Was the pair `(a, b)` (either way round) asked about?
pub fn saw(list: &Pairs, a: ColliderHandle, b: ColliderHandle) -> bool {
    list.lock()
        .unwrap()
        .iter()
        .any(|&(x, y)| (x, y) == (a, b) || (x, y) == (b, a))
}

/// A user hook recording the pairs its filter is asked about, and refusing the pairs of one
/// "ghost" collider.
pub struct GhostFilter {
    pub seen: Pairs,
    pub ghost: ColliderHandle,
}

impl GhostFilter {
    /// A filter refusing the pairs of `ghost`.
    pub fn new(ghost: ColliderHandle) -> Self {
        Self {
            seen: Pairs::default(),
            ghost,
        }
    }

    /// Records the pair; `None` (no contact) if it is the ghost's, rigid impulses otherwise.
    pub fn filter(&self, context: &PairFilterContext) -> Option<SolverFlags> {
        self.seen
            .lock()
            .unwrap()
            .push((context.collider1, context.collider2));
        if self.ghost == context.collider1 || self.ghost == context.collider2 {
            None
        } else {
            Some(SolverFlags::COMPUTE_RIGID_IMPULSES)
        }
    }
}

impl PhysicsHooks for GhostFilter {
    fn filter_contact_pair(&self, context: &PairFilterContext) -> Option<SolverFlags> {
        self.filter(context)
    }
}
