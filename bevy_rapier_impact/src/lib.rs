#![doc = include_str!("../README.md")]
//!
//! # How the steps are run
//!
//! The plugin runs its **own step system** in bevy_rapier's `PhysicsSet::StepSimulation`, in
//! place of bevy_rapier's (which it leaves out when it adds `RapierPhysicsPlugin`).
//! bevy_rapier's step system runs every rapier step of a frame (`TimestepMode`'s substeps,
//! `Interpolated`'s catch-up) inside one call, with no way to run code between two of them;
//! the core plugin's `after_step` must run right after each rapier step. So this system plans
//! the frame's steps exactly as bevy_rapier does (same count, same `f32` step length) and
//! runs each one through bevy_rapier's own `RapierContextSimulation::step_simulation` (one
//! substep at a time), between `before_step` and `after_step`. bevy_rapier's `SyncBackend`
//! and `Writeback` sets are its own, unchanged.
//!
//! # What else it does as bevy_rapier does
//!
//! Collision and contact-force messages, the quarantine of non-finite bodies (mirrored as
//! `RigidBodyDisabled` and the like), transform interpolation, `physics_pipeline_active`,
//! `SimulationMode::CollisionOnly` (the plugin then does nothing; the user's hooks still run)
//! and several contexts (one core plugin per context: [`ImpactSimulation`]).
//! One difference: bevy_rapier's step statistics (`RapierContextSimulation::step_stats`)
//! count only the frame's last rapier step, as each step is its own call.
//!
//! # The user's hooks
//!
//! Give the app's `BevyPhysicsHooks` as `RapierImpactPlugin<H>` (as it would give
//! `RapierPhysicsPlugin<H>`). The core plugin is the hook rapier sees; it wraps the user's
//! ([`UserHooks`]) and hands it every pair it does not take out of rapier's solver (a
//! resting ground contact included, before its restitution is zeroed), when the colliders'
//! `ActiveHooks` ask for it, so filters and one-way platforms keep working. bevy_rapier copies
//! an `ActiveHooks` component into rapier only when the component changes, and the core
//! plugin takes such a change as the user's new flags: the flags it adds are not lost.
//!
//! # Toolchain
//!
//! bevy 0.20 declares `rust-version = 1.97.1`. Until the toolchain reaches it, build this
//! crate with `--ignore-rust-version` (it builds and passes its tests with rustc 1.95).
#![deny(missing_docs)]

mod components;
mod hooks;
mod messages;
mod plugin;
mod step;
mod timestep;

pub use components::{
    Ground, ImpactSettings, ImpactSimulation, RestitutionBySpeed, TangentialRestitution,
};
pub use hooks::UserHooks;
pub use messages::{ImpactErrorMessage, ImpactMessage};
pub use plugin::{ImpactSet, RapierImpactPlugin};
pub use rapier_impact::{
    ConfigError, EventKind, GroundMaterial, ImpactConfig, ImpactEvent, ImpactTiming,
    RestitutionCurve, TimingMode,
};
