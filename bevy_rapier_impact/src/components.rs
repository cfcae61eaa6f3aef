//! What the user adds to the world: the [`Ground`] marker, the [`ImpactSettings`] resource;
//! and what the plugin keeps per rapier context: [`ImpactSimulation`].
//!
//! Contract: a collider entity with [`Ground`] is a ground of the core plugin from the first
//! physics frame at which bevy_rapier has created its rapier collider (after
//! `PhysicsSet::SyncBackend`), until the component or the entity is removed. The settings are
//! applied at each frame where they differ from those applied last.

use bevy::platform::collections::{HashMap, HashSet};
use bevy::prelude::{Component, Entity, Resource};
use bevy_rapier3d::rapier::prelude::ColliderHandle;
use rapier_impact::{ImpactConfig, ImpactPlugin};

/// Marks a collider entity as ground: its contacts with dynamic bodies are resolved by the
/// impact model. It must be parentless or on a fixed or kinematic body (else an
/// [`crate::ImpactErrorMessage`] with `ConfigError::DynamicGround`). Removing the component
/// makes it an ordinary collider again, even with
/// [`ImpactSettings::all_fixed_colliders_ground`] on.
#[derive(Component, Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Ground;

/// The plugin's settings, for every rapier context. Inserted by
/// [`crate::RapierImpactPlugin`]; change it at any time (a bad configuration is refused with
/// an [`crate::ImpactErrorMessage`] and the last good one is kept).
#[derive(Resource, Clone, Copy, Debug, Default, PartialEq)]
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
