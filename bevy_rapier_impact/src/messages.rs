//! What the plugin tells the app, as Bevy messages: the core crate's events with entities in
//! place of rapier handles, and the registrations or settings it refused.
//!
//! Contract: one [`ImpactMessage`] per `rapier_impact::ImpactEvent`, written right after the
//! rapier step that produced it (so in step order, several steps per frame included), read
//! with a `MessageReader<ImpactMessage>` in any later system. Entities come from the
//! `user_data` bevy_rapier stores on every rapier body and collider it creates; an object
//! made without bevy_rapier (no entity in its `user_data`) is named `Entity::PLACEHOLDER`.
//!
//! Reflection: both messages derive `Reflect` (registered by [`crate::RapierImpactPlugin`]),
//! with their entities and step index; the core crate's `ImpactEvent` and `ConfigError` are
//! not `Reflect` and are left out (`#[reflect(ignore)]`).

use bevy::prelude::{Entity, Message};
use bevy::reflect::Reflect;
use rapier_impact::{ConfigError, ImpactEvent};

/// One change the plugin made to a body in one rapier step: an impact or a correction (see
/// [`rapier_impact::EventKind`]), named by entities.
///
/// Reflected: the entities and the step; not `event` (the core crate's `ImpactEvent`).
#[derive(Message, Reflect, Clone, Copy, Debug, PartialEq)]
#[reflect(Debug, PartialEq, Clone, from_reflect = false)]
pub struct ImpactMessage {
    /// The rapier context (bevy_rapier's context entity) the step ran in.
    pub context: Entity,
    /// Index of the rapier step in that context, counted from 0 over the app's life: the
    /// steps of one frame have consecutive indices.
    pub step: u64,
    /// The rigid-body entity the change was made to.
    pub body: Entity,
    /// The entity of the body's collider that touched.
    pub collider: Entity,
    /// The ground collider's entity, or in an impact between bodies the other body's
    /// collider.
    pub ground: Entity,
    /// In an impact between bodies, the other body's entity; `None` for a ground.
    pub body2: Option<Entity>,
    /// The core crate's event: times, impulses, energies, and the rapier handles.
    #[reflect(ignore, clone)]
    pub event: ImpactEvent,
}

/// A ground, a setting or a configuration the plugin refused, and why. Written once per
/// refusal (a refused `Ground` is not tried again until its collider changes, a refused
/// component value until the component changes).
///
/// Reflected: the entities; not `error` (the core crate's `ConfigError`).
#[derive(Message, Reflect, Clone, Debug, PartialEq)]
#[reflect(Debug, PartialEq, Clone, from_reflect = false)]
pub struct ImpactErrorMessage {
    /// The rapier context.
    pub context: Entity,
    /// The entity whose ground marker or component was refused, or `None` for the settings.
    pub entity: Option<Entity>,
    /// The core crate's reason.
    #[reflect(ignore, clone)]
    pub error: ConfigError,
}
