//! The rapier adapter: everything that touches rapier types. The impulses come from
//! [`crate::model`]; the motions between impacts from `crate::motion`. See
//! `docs/architecture.md` for the stage list and [`crate::docs::guide`] for what a step does.
//!
//! - [`ImpactPlugin`] (`impact_plugin.rs`), its configuration (`config.rs`) and its events
//!   (`events.rs`): the public face.
//! - `stages/`: the step, as its stages in order (plan before rapier's step; reconstruct and
//!   settle after it), and the one writer every stage writes through (`stages/commit.rs`).
//! - `hooks/`: what runs inside rapier's step (the `PhysicsHooks` impl, its flags and tables).
//! - `queries/`: read-only questions the stages share (contact geometry and time of impact,
//!   the ground index, rapier's filtering, what the step observes of rapier).
//! - `state/`: what the plugin keeps (the registry of grounds and bodies, the memory between
//!   steps, the step's data, handle-keyed tables).
//! - `bridge/`: the hand-over to the model and the conversions between rapier's and the
//!   model's numbers.
//! - `policy.rs`: every threshold, named once.
//! - `profile.rs`: the step's profile (time per stage, bodies per role, writes), when on.
//! - `snapshot.rs`: save and resume ([`ImpactSnapshot`]).

mod bridge;
mod config;
mod events;
mod hooks;
mod impact_plugin;
mod policy;
mod profile;
mod queries;
mod snapshot;
mod stages;
mod state;

pub use config::{ConfigError, GroundMaterial, ImpactConfig, RollingSettings, TimingMode};
pub use events::{Diagnostic, EventKind, ImpactEvent, ImpactTiming};
pub use impact_plugin::{ImpactPlugin, StepSets};
pub use profile::{Stage, StepCounts, StepProfile};
pub use snapshot::{ImpactSnapshot, RestoreError};
