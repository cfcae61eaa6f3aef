//! Save and resume: [`ImpactSnapshot`], taken by [`ImpactPlugin::snapshot`] and given back
//! by [`ImpactPlugin::restore`].
//!
//! Contract: a snapshot holds everything one step leaves for the next (the configuration, the
//! registrations, the `f64` shadows, the roles and holds of last step's pairs, where the plugin's
//! hook flags are and the user's flags they replaced, the colliders already reported out of range,
//! and the last step's events), and nothing that is built again from it and the world (the ground
//! index, the pair index, the hooks' tables, the step's own tables): a plugin restored from it,
//! stepping the world saved with it, steps bit for bit as the plugin it was taken from. Its tables
//! are listed in arena order, so that the same state gives the same snapshot whatever the history
//! of the hash maps it came from. The user's hook and the profile are not part of it. Every value a
//! setter would refuse is refused by [`ImpactPlugin::restore`] too, before anything changes.

use crate::plugin::config::{ConfigError, ImpactConfig};
use crate::plugin::events::ImpactEvent;
use crate::plugin::hooks::flags::{HookFlags, SavedFlags};
use crate::plugin::hooks::lookup::Lookup;
use crate::plugin::impact_plugin::ImpactPlugin;
use crate::plugin::stages::pair_plan::PairIndex;
use crate::plugin::state::memory::{Memory, SavedMemory};
use crate::plugin::state::registry::{Registry, SavedRegistry};
use crate::plugin::state::step::StepData;
use core::fmt;

/// The layout of [`ImpactSnapshot`]: a snapshot of another layout is refused by
/// [`ImpactPlugin::restore`] rather than misread: raised with every change of what the
/// snapshot holds.
const LAYOUT: u32 = 5;

/// The plugin's state between two steps, to resume a simulation bit for bit: save it beside
/// rapier's world, and give both back ([`ImpactPlugin::restore`] and the world as it was
/// saved) to go on exactly where the run was.
///
/// `Clone`, and with the `serde-serialize` feature `Serialize` and `Deserialize`. Its
/// contents are the plugin's own and may change between versions of this crate; a snapshot
/// of another layout is refused, not misread: by [`ImpactPlugin::restore`]
/// ([`RestoreError::Layout`]), or already by serde where the other layout lacks a field this
/// one has. `restore` cannot see rapier's world: give it the world saved with the snapshot
/// (another one is not detected, and the plugin may then take hook flags of its own left on
/// that world's colliders for yours). rapier's world holds infinities (a fixed body's
/// mass properties), so save it in a format that keeps them (CBOR, bincode, MessagePack; not
/// JSON). The snapshot itself holds only finite numbers: it keeps the last step's events but
/// not its diagnostics (they may quote a collider's NaN, and the collider is in the world).
///
/// ```
/// use rapier_impact::rapier::prelude::*;
/// use rapier_impact::{ImpactConfig, ImpactPlugin};
///
/// let mut world = PhysicsWorld::default();
/// let (_, ground) = world.insert(RigidBodyBuilder::fixed(), ColliderBuilder::cuboid(5.0, 0.1, 5.0));
/// let (ball, _) = world.insert(
///     RigidBodyBuilder::dynamic().translation(Vector::new(0.0, 1.0, 0.0)),
///     ColliderBuilder::ball(0.1).restitution(0.8),
/// );
/// let mut plugin = ImpactPlugin::new(ImpactConfig::default()).unwrap();
/// plugin.add_ground(&world.bodies, &world.colliders, ground).unwrap();
/// for _ in 0..20 {
///     plugin.step(&mut world);
/// }
/// // Save. With `serde-serialize`: serialize `world` and the snapshot in a format that keeps
/// // infinities. Here, a copy of what rapier's serialization keeps.
/// let saved_world = PhysicsWorld {
///     gravity: world.gravity,
///     integration_parameters: world.integration_parameters,
///     islands: world.islands.clone(),
///     broad_phase: world.broad_phase.clone(),
///     narrow_phase: world.narrow_phase.clone(),
///     bodies: world.bodies.clone(),
///     colliders: world.colliders.clone(),
///     impulse_joints: world.impulse_joints.clone(),
///     multibody_joints: world.multibody_joints.clone(),
///     soft_bodies: world.soft_bodies.clone(),
///     ..PhysicsWorld::default()
/// };
/// let saved = plugin.snapshot();
/// for _ in 0..40 {
///     plugin.step(&mut world);
/// }
/// // Resume, in another plugin: the same 40 steps, bit for bit.
/// let (mut resumed_world, mut resumed) = (saved_world, ImpactPlugin::new(ImpactConfig::default()).unwrap());
/// resumed.restore(&saved).unwrap();
/// for _ in 0..40 {
///     resumed.step(&mut resumed_world);
/// }
/// assert_eq!(resumed_world.bodies[ball].translation(), world.bodies[ball].translation());
/// assert_eq!(resumed_world.bodies[ball].linvel(), world.bodies[ball].linvel());
/// ```
#[derive(Clone, Debug, PartialEq)]
#[cfg_attr(
    feature = "serde-serialize",
    derive(serde::Serialize, serde::Deserialize)
)]
pub struct ImpactSnapshot {
    layout: u32,
    /// Taken between `before_step` and `after_step` (refused by `restore`).
    mid_step: bool,
    config: ImpactConfig,
    registry: SavedRegistry,
    memory: SavedMemory,
    flags: SavedFlags,
    events: Vec<ImpactEvent>,
}

/// Why [`ImpactPlugin::restore`] refused a snapshot; the plugin is left as it was.
#[derive(Clone, Debug, PartialEq)]
#[non_exhaustive]
pub enum RestoreError {
    /// The snapshot was taken by a version of this crate with another layout.
    Layout {
        /// The snapshot's layout.
        found: u32,
        /// The layout this version reads.
        expected: u32,
    },
    /// The snapshot was taken between [`ImpactPlugin::before_step`] and
    /// [`ImpactPlugin::after_step`]: the step in progress cannot be resumed.
    MidStep,
    /// A value the plugin's setters would refuse (an edited or corrupted snapshot).
    Invalid(ConfigError),
    /// A stored body state holds a number that is not finite.
    NotFinite,
}

impl fmt::Display for RestoreError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Layout { found, expected } => write!(
                f,
                "the snapshot's layout is {found}; this version of rapier-impact reads {expected}"
            ),
            Self::MidStep => write!(
                f,
                "the snapshot was taken between before_step and after_step; take it between steps"
            ),
            Self::Invalid(e) => write!(f, "the snapshot holds a value out of range: {e}"),
            Self::NotFinite => write!(f, "the snapshot holds a body state that is not finite"),
        }
    }
}

impl std::error::Error for RestoreError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match self {
            Self::Invalid(e) => Some(e),
            _ => None,
        }
    }
}

impl<H> ImpactPlugin<H> {
    /// The plugin's state, to resume from with [`Self::restore`] (see [`ImpactSnapshot`]).
    /// Take it between steps (after [`Self::after_step`], or [`Self::step`]), together with
    /// rapier's world: a snapshot taken inside a step is refused by [`Self::restore`].
    pub fn snapshot(&self) -> ImpactSnapshot {
        ImpactSnapshot {
            layout: LAYOUT,
            mid_step: self.step.active,
            config: self.config.clone(),
            registry: self.registry.save(),
            memory: self.memory.save(),
            flags: self.flags.save(),
            events: self.reports.events.clone(),
        }
    }

    /// Puts the plugin in the state `snapshot` was taken in, its hook and profiling aside: stepping
    /// the world saved with it then goes on bit for bit as the run it was taken from. Everything
    /// the plugin held before is replaced ([`Self::diagnostics`] is empty). Refused, with the
    /// plugin left as it was, when the snapshot has another layout, was taken inside a step, or
    /// holds a value the setters refuse.
    pub fn restore(&mut self, snapshot: &ImpactSnapshot) -> Result<(), RestoreError> {
        if snapshot.layout != LAYOUT {
            return Err(RestoreError::Layout {
                found: snapshot.layout,
                expected: LAYOUT,
            });
        }
        if snapshot.mid_step {
            return Err(RestoreError::MidStep);
        }
        snapshot.config.validate().map_err(RestoreError::Invalid)?;
        let sides_finite = snapshot
            .memory
            .mesh_sides
            .iter()
            .all(|(_, side)| side.is_finite());
        if !sides_finite || !snapshot.memory.shadows.iter().all(|(_, s)| s.is_finite()) {
            return Err(RestoreError::NotFinite);
        }
        let registry = Registry::from_saved(&snapshot.registry).map_err(RestoreError::Invalid)?;
        self.config = snapshot.config.clone();
        self.registry = registry;
        self.flags = HookFlags::from_saved(&snapshot.flags);
        self.memory = Memory::from_saved(&snapshot.memory);
        self.reports.restore(&snapshot.events);
        // Built again at the next step.
        self.step = StepData::default();
        self.lookup = Lookup::default();
        self.pair_index = PairIndex::default();
        Ok(())
    }
}

/// For the tests of this module: a snapshot with its layout changed.
#[cfg(test)]
impl ImpactSnapshot {
    fn with_layout(mut self, layout: u32) -> Self {
        self.layout = layout;
        self
    }

    fn taken_mid_step(mut self) -> Self {
        self.mid_step = true;
        self
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn another_layout_or_a_step_in_progress_is_refused_and_nothing_changes() {
        let mut plugin = ImpactPlugin::new(ImpactConfig::default()).unwrap();
        let config = ImpactConfig {
            max_impacts_per_step: 3,
            ..ImpactConfig::default()
        };
        let other = ImpactPlugin::new(config).unwrap().snapshot();
        let refused = plugin.restore(&other.clone().with_layout(LAYOUT + 1));
        assert_eq!(
            refused,
            Err(RestoreError::Layout {
                found: LAYOUT + 1,
                expected: LAYOUT
            })
        );
        assert_eq!(
            plugin.restore(&other.clone().taken_mid_step()),
            Err(RestoreError::MidStep)
        );
        assert_eq!(*plugin.config(), ImpactConfig::default());
        plugin.restore(&other).unwrap();
        assert_eq!(plugin.config().max_impacts_per_step, 3);
    }

    #[test]
    fn a_value_a_setter_refuses_is_refused_and_nothing_changes() {
        use crate::plugin::state::memory::Shadow;
        use crate::rapier::math::Vector;
        use crate::rapier::prelude::RigidBodyHandle;
        use nalgebra::Vector3;

        let mut plugin = ImpactPlugin::new(ImpactConfig::default()).unwrap();
        let mut edited = plugin.snapshot();
        edited.config.flat_tolerance = f64::NAN;
        edited.config.max_impacts_per_step = 9;
        assert!(matches!(
            plugin.restore(&edited),
            Err(RestoreError::Invalid(ConfigError::InvalidConfig {
                field: "flat_tolerance",
                ..
            }))
        ));
        let mut edited = plugin.snapshot();
        edited.config.max_impacts_per_step = 9;
        let shadow = Shadow {
            com: Vector3::new(0.0, f64::INFINITY, 0.0),
            v: Vector3::zeros(),
            w: Vector3::zeros(),
            local_com: Vector3::zeros(),
            written_translation: Vector::ZERO,
            written_rotation: crate::rapier::math::Rotation::IDENTITY,
            written_linvel: Vector::ZERO,
            written_angvel: Vector::ZERO,
        };
        let body = RigidBodyHandle::from_raw_parts(0, 0);
        edited.memory.shadows.push((body, shadow));
        assert_eq!(plugin.restore(&edited), Err(RestoreError::NotFinite));
        assert_eq!(*plugin.config(), ImpactConfig::default());
        // A body's own setting is refused as its setter refuses it.
        let mut edited = plugin.snapshot();
        edited.config.max_impacts_per_step = 9;
        edited.registry = edited.registry.with_body_rolling(body, 0.1, f64::NAN);
        assert_eq!(
            plugin.restore(&edited).map_err(|e| e.to_string()),
            Err(RestoreError::Invalid(ConfigError::InvalidBodySetting {
                setter: "set_body_rolling",
                field: "spinning_friction",
                value: f64::NAN,
            })
            .to_string())
        );
        assert_eq!(plugin.body_rolling(body), None);
        assert_eq!(*plugin.config(), ImpactConfig::default());
    }

    /// A hand-edited snapshot naming bodies and colliders at slots near `u32::MAX` (no world
    /// holds them: a shadow, a ground, a ground's flags, a hooked body not in the world and
    /// a flagged collider of the world's ball, both stamped for the next step) is restored
    /// without the plugin's tables growing to those slots, is saved again as it was given,
    /// and steps the world bit for bit as the snapshot it was edited from: what names
    /// nothing in the world changes nothing.
    #[test]
    fn handles_far_beyond_the_world_cost_no_memory_and_change_nothing() {
        use crate::plugin::state::memory::Shadow;
        use crate::rapier::math::Vector;
        use crate::rapier::prelude::*;
        use nalgebra::Vector3;

        // A ball dropped on a ground, stepped 5 times: built the same, bit for bit, each call.
        let scene = || {
            let mut world = PhysicsWorld::default();
            let (_, ground) = world.insert(
                RigidBodyBuilder::fixed(),
                ColliderBuilder::cuboid(5.0, 0.1, 5.0),
            );
            let (ball, _) = world.insert(
                RigidBodyBuilder::dynamic().translation(Vector::new(0.0, 0.5, 0.0)),
                ColliderBuilder::ball(0.1).restitution(0.8),
            );
            let mut plugin = ImpactPlugin::new(ImpactConfig::default()).unwrap();
            plugin
                .add_ground(&world.bodies, &world.colliders, ground)
                .unwrap();
            for _ in 0..5 {
                plugin.step(&mut world);
            }
            (world, ball, plugin.snapshot())
        };
        let (_, ball, saved) = scene();
        let far = u32::MAX - 1;
        let mut edited = saved.clone();
        let shadow = Shadow {
            com: Vector3::new(1.0, 2.0, 3.0),
            v: Vector3::zeros(),
            w: Vector3::zeros(),
            local_com: Vector3::zeros(),
            written_translation: Vector::ZERO,
            written_rotation: crate::rapier::math::Rotation::IDENTITY,
            written_linvel: Vector::ZERO,
            written_angvel: Vector::ZERO,
        };
        let (far_body, far_collider) = (
            RigidBodyHandle::from_raw_parts(far, 0),
            ColliderHandle::from_raw_parts(far, 0),
        );
        edited.memory.shadows.push((far_body, shadow));
        edited.registry = edited.registry.with_ground_like_first(far_collider);
        edited.flags = edited
            .flags
            .with_ground(far_collider)
            .with_hooked_next(ball, ColliderHandle::from_raw_parts(far - 2, 0))
            .with_hooked_next(far_body, ColliderHandle::from_raw_parts(far - 1, 0));
        let run = |snapshot: &ImpactSnapshot| {
            let (mut world, ..) = scene();
            let mut plugin = ImpactPlugin::new(ImpactConfig::default()).unwrap();
            plugin.restore(snapshot).unwrap();
            assert_eq!(plugin.snapshot(), *snapshot, "saved again as given");
            let (mut trace, mut held) = (Vec::new(), 0);
            for _ in 0..60 {
                plugin.step(&mut world);
                trace.extend(
                    world
                        .bodies
                        .iter()
                        .map(|(_, rb)| (*rb.position(), rb.linvel())),
                );
                held = held
                    .max(plugin.memory.shadows.slots_held())
                    .max(plugin.flags.slots_held())
                    .max(plugin.lookup.user_flags_slots());
            }
            (trace, held)
        };
        let (edited_trace, held) = run(&edited);
        assert!(held < 1 << 20, "a table held {held} slots");
        assert_eq!(edited_trace, run(&saved).0);
    }
}
