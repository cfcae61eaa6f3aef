//! rapier-impact: closed-form ground impacts for rapier3d.
#![deny(missing_docs)]

pub use nalgebra as na;

pub mod model;

/// Long-form documentation.
pub mod docs {
    #![doc = include_str!("../docs/model.md")]
    /// The model's derivation.
    pub mod model {}
}
