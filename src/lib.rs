//! rapier-impact: closed-form ground impacts for rapier3d.
//!
//! - [`model`]: the impact model, pure `f64` mathematics on nalgebra, no rapier type.
//! - [`ImpactPlugin`]: the rapier adapter. Contacts between dynamic bodies and the
//!   colliders marked as ground are taken from rapier's solver and resolved by the model
//!   at their time of impact inside the step; every other contact stays rapier's.
//!   See [`docs::integration`] for the few lines that add it to a simulation.
//!
//! Precision follows the cargo features: `f32` (default) builds on `rapier3d`, `f64` on
//! `rapier3d-f64`; [`rapier`] and [`parry`] name whichever is in use.
#![deny(missing_docs)]

#[cfg(not(any(feature = "f32", feature = "f64")))]
compile_error!("rapier-impact needs one of the features `f32` (rapier3d) or `f64` (rapier3d-f64)");

pub use nalgebra as na;

/// The rapier crate in use: `rapier3d-f64` with the `f64` feature, else `rapier3d`.
#[cfg(all(feature = "f32", not(feature = "f64")))]
pub use rapier3d as rapier;
/// The rapier crate in use: `rapier3d-f64` with the `f64` feature, else `rapier3d`.
#[cfg(feature = "f64")]
pub use rapier3d_f64 as rapier;

/// The parry crate in use: `parry3d-f64` with the `f64` feature, else `parry3d`.
#[cfg(all(feature = "f32", not(feature = "f64")))]
pub use parry3d as parry;
/// The parry crate in use: `parry3d-f64` with the `f64` feature, else `parry3d`.
#[cfg(feature = "f64")]
pub use parry3d_f64 as parry;

mod math;
pub mod model;
mod motion;
pub mod plugin;

pub use model::RestitutionCurve;
pub use plugin::{
    ConfigError, Diagnostic, EventKind, GroundMaterial, ImpactConfig, ImpactEvent, ImpactPlugin,
    ImpactSnapshot, ImpactTiming, RestoreError, Stage, StepCounts, StepProfile, TimingMode,
};

/// Long-form documentation: the model's derivation and the integration guide.
pub mod docs {
    /// The impact model: the document's equations, the errata, the general form and the
    /// three laws.
    pub mod model {
        #![doc = include_str!("../docs/model.md")]
    }
    /// Adding the plugin to a rapier simulation: what happens in a step, the modes, the
    /// guarantees.
    pub mod integration {
        #![doc = include_str!("../docs/integration.md")]
    }
}

// The README's code blocks run as doctests, so its quick start cannot rot.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
struct ReadmeDoctests;
