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
//! # The components and the core plugin
//!
//! Each frame, before its rapier steps, the step system compares each context's entities with
//! what it last gave that context's core plugin (kept in [`ImpactSimulation`]) and calls the
//! core API for what changed only: `add_ground` / `remove_ground` and `set_ground_material`
//! for [`Ground`] and [`GroundMaterial`]; `add_impact_body` / `remove_impact_body`,
//! `set_body_tangential_restitution`, `set_body_restitution_curve` and `set_body_rolling` for
//! [`ImpactBody`], [`TangentialRestitution`], [`RestitutionBySpeed`] and [`Rolling`]. A
//! component removed, or its entity despawned, is given back the core default (`None`, or
//! out of the set). A new rapier object for the same entity (bevy_rapier recreates one when,
//! say, its collider shape is replaced) is given everything again. So a change made by
//! reflection (an inspector) is applied like one made by a system. A value changed through
//! [`ImpactSimulation::plugin_mut`] for an entity that has the matching component is set from
//! the component again only when the component changes.
//!
//! # Features
//!
//! `debug-plugin` (default): `ImpactDebugPlugin` and `ImpactGizmos`, with Bevy's
//! `bevy_gizmos` feature (no renderer). Without it the crate needs no Bevy feature at all.
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
#[cfg(feature = "debug-plugin")]
mod debug;
mod hooks;
mod messages;
mod plugin;
mod step;
mod timestep;

pub use components::{
    Ground, GroundMaterial, ImpactBody, ImpactSettings, ImpactSimulation, RestitutionBySpeed,
    Rolling, TangentialRestitution,
};
#[cfg(feature = "debug-plugin")]
pub use debug::{ImpactDebugPlugin, ImpactGizmos};
pub use hooks::UserHooks;
pub use messages::{ImpactErrorMessage, ImpactMessage};
pub use plugin::{ImpactSet, RapierImpactPlugin};
/// The core crate, for what has no Bevy form here (`ImpactSimulation::plugin_mut`'s API, its
/// `GroundMaterial`, `RollingSettings`, `ImpactPlugin`).
pub use rapier_impact;
pub use rapier_impact::{
    ConfigError, EventKind, ImpactConfig, ImpactEvent, ImpactTiming, RestitutionCurve, TimingMode,
};

/// What an app uses: the plugin, the components, the settings and the messages.
pub mod prelude {
    pub use crate::{
        Ground, GroundMaterial, ImpactBody, ImpactConfig, ImpactErrorMessage, ImpactMessage,
        ImpactSet, ImpactSettings, ImpactSimulation, RapierImpactPlugin, RestitutionBySpeed,
        RestitutionCurve, Rolling, TangentialRestitution,
    };
    #[cfg(feature = "debug-plugin")]
    pub use crate::{ImpactDebugPlugin, ImpactGizmos};
}
