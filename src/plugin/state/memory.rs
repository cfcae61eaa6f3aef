//! What the plugin remembers from one step to the next.

use crate::motion::State;
use crate::rapier::math::Vector;
use crate::rapier::prelude::RigidBody;
use nalgebra::Vector3;

/// Exact-mode `f64` state of a body as last written, so the next step continues from it
/// rather than from its rounding.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Shadow {
    pub com: Vector3<f64>,
    pub v: Vector3<f64>,
    pub w: Vector3<f64>,
    pub written_translation: Vector,
    pub written_linvel: Vector,
    pub written_angvel: Vector,
}

impl Shadow {
    /// The shadow of the state `s` just written into `rb`.
    pub fn of(rb: &RigidBody, s: &State) -> Self {
        Self {
            com: s.com,
            v: s.v,
            w: s.w,
            written_translation: rb.translation(),
            written_linvel: rb.linvel(),
            written_angvel: rb.angvel(),
        }
    }
}
