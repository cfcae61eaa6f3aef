//! What the user adds to the world: the [`Ground`] marker, a body's own
//! [`TangentialRestitution`] and [`RestitutionBySpeed`], the [`ImpactSettings`] resource; and
//! what the plugin keeps per rapier context: [`ImpactSimulation`].
//!
//! Contract: a collider entity with [`Ground`] is a ground of the core plugin from the first
//! physics frame at which bevy_rapier has created its rapier collider (after
//! `PhysicsSet::SyncBackend`), until the component or the entity is removed. A rigid body
//! entity's [`TangentialRestitution`] and [`RestitutionBySpeed`] are its own in the core plugin
//! from the frame its rapier body exists, updated at each frame where they changed, until the
//! component or the entity is removed. The settings are applied at each frame where they
//! differ from those applied last.

use bevy::platform::collections::{HashMap, HashSet};
use bevy::prelude::{Component, Entity, Resource};
use bevy_rapier3d::rapier::prelude::{ColliderHandle, RigidBodyHandle};
use rapier_impact::{ImpactConfig, ImpactPlugin, RestitutionCurve};

/// Marks a collider entity as ground: its contacts with dynamic bodies are resolved by the
/// impact model. It must be parentless or on a fixed or kinematic body (else an
/// [`crate::ImpactErrorMessage`] with `ConfigError::DynamicGround`). Removing the component
/// makes it an ordinary collider again, even with
/// [`ImpactSettings::all_fixed_colliders_ground`] on.
#[derive(Component, Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Ground;

/// A rigid body's own Walton tangential restitution `beta0` in `[-1, 1]`
/// (`ImpactPlugin::set_body_tangential_restitution`): in its impacts, a contact that grips
/// leaves with `-beta0` times its incoming tangential velocity where friction allows (1: a
/// superball). A ground's own value wins over it; without it, the configuration's applies. A
/// value out of range is refused with an [`crate::ImpactErrorMessage`].
#[derive(Component, Clone, Copy, Debug, Default, PartialEq)]
pub struct TangentialRestitution(pub f64);

/// A rigid body's own restitution as a function of the impact speed
/// (`ImpactPlugin::set_body_restitution_curve`), replacing the constant `Restitution` in its
/// impacts. A ground's own curve wins over it; without it, the configuration's applies.
#[derive(Component, Clone, Debug, PartialEq)]
pub struct RestitutionBySpeed(pub RestitutionCurve);

/// The plugin's settings, for every rapier context. Inserted by
/// [`crate::RapierImpactPlugin`]; change it at any time (a bad configuration is refused with
/// an [`crate::ImpactErrorMessage`] and the last good one is kept).
#[derive(Resource, Clone, Debug, Default, PartialEq)]
pub struct ImpactSettings {
    /// The core plugin's configuration (law, timing mode, resting thresholds, rolling).
    pub config: ImpactConfig,
    /// Every fixed collider (parentless, or on a fixed body) is ground, without a
    /// [`Ground`] marker: `ImpactPlugin::set_all_fixed_colliders_ground`.
    pub all_fixed_colliders_ground: bool,
}

/// The core plugin of one rapier context, with what the Bevy side remembers of it. Added to
/// every entity with bevy_rapier's `RapierContextSimulation` (a required component).
///
/// [`Self::plugin_mut`] gives the core API that has no Bevy form here (impact bodies, ground
/// materials, excluded bodies); its handles are those of the context's rapier sets
/// (`RapierRigidBodyHandle`, `RapierColliderHandle` on the entities).
#[derive(Component)]
pub struct ImpactSimulation {
    /// `None` only while the step system has it (its hook swapped for the frame's).
    pub(crate) plugin: Option<ImpactPlugin>,
    /// Ground entities and their collider, with whether the plugin took them.
    pub(crate) grounds: HashMap<Entity, (ColliderHandle, bool)>,
    /// Scratch set of the ground entities seen this frame (kept for its allocation).
    pub(crate) seen: HashSet<Entity>,
    /// Body entities with their own tangential restitution or restitution curve, with their
    /// rapier body and the values applied.
    pub(crate) bounces: HashMap<Entity, (RigidBodyHandle, BodyBounce)>,
    /// The settings last applied (or refused), to apply a change once.
    pub(crate) applied: Option<ImpactSettings>,
    /// Rapier steps run in this context through the plugin.
    pub(crate) steps: u64,
}

impl Default for ImpactSimulation {
    fn default() -> Self {
        Self {
            // The default configuration is valid: `ok()` only avoids a panic path.
            plugin: ImpactPlugin::new(ImpactConfig::default()).ok(),
            grounds: HashMap::default(),
            seen: HashSet::default(),
            bounces: HashMap::default(),
            applied: None,
            steps: 0,
        }
    }
}

impl ImpactSimulation {
    /// The core plugin.
    pub fn plugin(&self) -> Option<&ImpactPlugin> {
        self.plugin.as_ref()
    }

    /// The core plugin, mutably.
    pub fn plugin_mut(&mut self) -> Option<&mut ImpactPlugin> {
        self.plugin.as_mut()
    }

    /// Rapier steps run in this context so far (all frames, all substeps).
    pub fn steps(&self) -> u64 {
        self.steps
    }
}

/// A body's own settings as last applied to the core plugin.
#[derive(Clone, Debug, Default, PartialEq)]
pub(crate) struct BodyBounce {
    pub tangential_restitution: Option<f64>,
    pub restitution_curve: Option<RestitutionCurve>,
}
