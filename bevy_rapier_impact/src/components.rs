//! What the user adds to the world: on a collider, the [`Ground`] marker and its
//! [`GroundMaterial`]; on a rigid body, the [`ImpactBody`] marker and its own
//! [`TangentialRestitution`], [`RestitutionBySpeed`] and [`Rolling`]; the [`ImpactSettings`]
//! resource; and what the plugin keeps per rapier context: [`ImpactSimulation`].
//!
//! Contract: a collider entity with [`Ground`] is a ground of the core plugin from the first
//! physics frame at which bevy_rapier has created its rapier collider (after
//! `PhysicsSet::SyncBackend`), until the component or the entity is removed; its
//! [`GroundMaterial`] is the ground's material from that frame on, updated at each frame where
//! it changed, and taken back (rapier's coefficients again) when removed. A rigid body
//! entity's [`ImpactBody`], [`TangentialRestitution`], [`RestitutionBySpeed`] and [`Rolling`]
//! are its own in the core plugin from the frame its rapier body exists, updated at each frame
//! where they changed, until the component or the entity is removed (the core plugin's default
//! then applies). A value the core plugin refuses is reported once as an
//! [`crate::ImpactErrorMessage`] and leaves what was applied before. The settings are applied
//! at each frame where they differ from those applied last.
//!
//! Reflection: every component, resource and message here derives `Reflect` and is registered
//! by [`crate::RapierImpactPlugin`]. The core crate's types are not `Reflect` (it has no Bevy
//! dependency): [`ImpactSettings::config`] and [`ImpactSimulation`]'s core plugin are left out
//! of reflection; the per-entity components hold plain numbers, so all of their fields are
//! reflected.

use bevy::platform::collections::{HashMap, HashSet};
use bevy::prelude::{
    Component, Entity, ReflectComponent, ReflectDefault, ReflectResource, Resource,
};
use bevy::reflect::Reflect;
use bevy_rapier3d::rapier::prelude::{ColliderHandle, RigidBodyHandle};
use rapier_impact::model::ModelError;
use rapier_impact::{ConfigError, ImpactConfig, ImpactPlugin, RestitutionCurve, RollingSettings};

/// Marks a collider entity as ground: its contacts with dynamic bodies are resolved by the
/// impact model. It must be parentless or on a fixed or kinematic body (else an
/// [`crate::ImpactErrorMessage`] with `ConfigError::DynamicGround`). Removing the component
/// makes it an ordinary collider again, even with
/// [`ImpactSettings::all_fixed_colliders_ground`] on.
#[derive(Component, Reflect, Clone, Copy, Debug, Default, PartialEq, Eq)]
#[reflect(Component, Default, Debug, PartialEq, Clone)]
pub struct Ground;

/// A ground's own material: its coefficients replace, in its impacts, those rapier combines
/// from the two colliders' `Restitution` and `Friction`, and its optional overrides win over
/// the body's and the configuration's (`ImpactPlugin::set_ground_material`).
///
/// The Bevy form of the core crate's [`rapier_impact::GroundMaterial`], with plain fields (all
/// reflected: an inspector edits each of them) and the restitution curve as its points. It
/// requires [`Ground`] (inserted with it); it applies while the entity is a ground, and
/// removing it gives the ground back rapier's coefficients. A material the core plugin
/// refuses (a coefficient out of range, an invalid curve: `ConfigError::MaterialOutOfRange`,
/// `ConfigError::Material`) is reported once as an [`crate::ImpactErrorMessage`] naming the
/// entity, and the ground keeps the material it had (none for a new ground).
///
/// ```
/// use bevy_rapier_impact::GroundMaterial;
///
/// // A wooden floor that returns less energy at high speed.
/// let floor = GroundMaterial::new(0.6, 0.4)
///     .with_rolling_resistance(0.01)
///     .with_restitution_curve([(0.0, 0.7), (5.0, 0.5)]);
/// assert!(floor.to_core().is_ok());
/// ```
#[derive(Component, Reflect, Clone, Debug, PartialEq)]
#[reflect(Component, Default, Debug, PartialEq, Clone)]
#[require(Ground)]
pub struct GroundMaterial {
    /// Coefficient of restitution `e`, in `[0, 10]` (1 = elastic; above 1 the contact adds
    /// energy).
    pub restitution: f64,
    /// Coefficient of friction `mu`, in `[0, 100]`.
    pub friction: f64,
    /// Rolling resistance `mu_r` on this ground, in `[0, 100]`, or `None` for the body's
    /// ([`Rolling`]) or the configuration's.
    pub rolling_resistance: Option<f64>,
    /// Spinning friction `mu_sp` on this ground, in `[0, 100]`, or `None` for the body's or
    /// the configuration's.
    pub spinning_friction: Option<f64>,
    /// Walton's tangential restitution `beta0` on this ground, in `[-1, 1]`, or `None` for the
    /// body's ([`TangentialRestitution`]) or the configuration's.
    pub tangential_restitution: Option<f64>,
    /// Restitution as a function of the impact speed on this ground, as the points
    /// `(speed in m/s, e)` of a [`RestitutionCurve`] (by non-decreasing speed, each `e` at most
    /// 10), replacing `restitution`; `None` for the body's ([`RestitutionBySpeed`]) or the
    /// configuration's, else `restitution`.
    pub restitution_curve: Option<Vec<(f64, f64)>>,
}

impl Default for GroundMaterial {
    /// rapier's default coefficients of a collider: `e = 0`, `mu = 0.5`, and no override.
    fn default() -> Self {
        Self::new(0.0, 0.5)
    }
}

impl GroundMaterial {
    /// Restitution and friction, and no other coefficient of its own.
    pub fn new(restitution: f64, friction: f64) -> Self {
        Self {
            restitution,
            friction,
            rolling_resistance: None,
            spinning_friction: None,
            tangential_restitution: None,
            restitution_curve: None,
        }
    }

    /// The same material with this ground's own rolling resistance `mu_r`.
    pub fn with_rolling_resistance(self, rolling_resistance: f64) -> Self {
        Self {
            rolling_resistance: Some(rolling_resistance),
            ..self
        }
    }

    /// The same material with this ground's own spinning friction `mu_sp`.
    pub fn with_spinning_friction(self, spinning_friction: f64) -> Self {
        Self {
            spinning_friction: Some(spinning_friction),
            ..self
        }
    }

    /// The same material with Walton's tangential restitution `beta0` on this ground.
    pub fn with_tangential_restitution(self, beta0: f64) -> Self {
        Self {
            tangential_restitution: Some(beta0),
            ..self
        }
    }

    /// The same material with a restitution that depends on the impact speed: the points
    /// `(speed, e)`, or a [`RestitutionCurve`].
    pub fn with_restitution_curve(self, curve: impl Into<Vec<(f64, f64)>>) -> Self {
        Self {
            restitution_curve: Some(curve.into()),
            ..self
        }
    }

    /// The core crate's material, with its curve built from the points; checked as the core
    /// plugin checks it (`rapier_impact::GroundMaterial::validate`).
    pub fn to_core(&self) -> Result<rapier_impact::GroundMaterial, ConfigError> {
        let mut m = rapier_impact::GroundMaterial::new(self.restitution, self.friction);
        if let Some(v) = self.rolling_resistance {
            m = m.with_rolling_resistance(v);
        }
        if let Some(v) = self.spinning_friction {
            m = m.with_spinning_friction(v);
        }
        if let Some(v) = self.tangential_restitution {
            m = m.with_tangential_restitution(v);
        }
        if let Some(points) = &self.restitution_curve {
            m = m.with_restitution_curve(curve_of(points)?);
        }
        m.validate()?;
        Ok(m)
    }
}

impl From<rapier_impact::GroundMaterial> for GroundMaterial {
    fn from(m: rapier_impact::GroundMaterial) -> Self {
        Self {
            restitution: m.restitution,
            friction: m.friction,
            rolling_resistance: m.rolling_resistance,
            spinning_friction: m.spinning_friction,
            tangential_restitution: m.tangential_restitution,
            restitution_curve: m.restitution_curve.map(Vec::from),
        }
    }
}

/// The curve through `points`; points that make none give `ConfigError::Material`, whose
/// message names the point and what is wrong with it.
pub(crate) fn curve_of(points: &[(f64, f64)]) -> Result<RestitutionCurve, ConfigError> {
    RestitutionCurve::new(points).map_err(ConfigError::Material)
}

/// Opts a dynamic rigid body in to impacts between bodies (`ImpactPlugin::add_impact_body`):
/// its impacts with another body that has it are resolved by the model at their time in the
/// step, as ground impacts are, and reported as [`crate::ImpactMessage`]s with `body2` set.
/// On a body that is not dynamic it is refused (`ConfigError::NotDynamic`, once) and tried
/// again when the body becomes dynamic. Removing it leaves the body's contacts with other
/// bodies to rapier (`ImpactPlugin::remove_impact_body`).
#[derive(Component, Reflect, Clone, Copy, Debug, Default, PartialEq, Eq)]
#[reflect(Component, Default, Debug, PartialEq, Clone)]
pub struct ImpactBody;

/// A rigid body's own Walton tangential restitution `beta0` in `[-1, 1]`
/// (`ImpactPlugin::set_body_tangential_restitution`): in its impacts, a contact that grips
/// leaves with `-beta0` times its incoming tangential velocity where friction allows (1: a
/// superball). A ground's own value wins over it; without it, the configuration's applies. A
/// value out of range is refused with an [`crate::ImpactErrorMessage`].
#[derive(Component, Reflect, Clone, Copy, Debug, Default, PartialEq)]
#[reflect(Component, Default, Debug, PartialEq, Clone)]
pub struct TangentialRestitution(pub f64);

/// A rigid body's own restitution as a function of the impact speed
/// (`ImpactPlugin::set_body_restitution_curve`), replacing the constant `Restitution` in its
/// impacts: the points `(speed in m/s, e)` of a [`RestitutionCurve`], by non-decreasing speed,
/// each `e` at most 10. A ground's own curve wins over it; without it, the configuration's
/// applies. Points that make no curve are refused with an [`crate::ImpactErrorMessage`]
/// (`ConfigError::Material` with the `ModelError`), and the body keeps the curve it had.
///
/// ```
/// use bevy_rapier_impact::{RestitutionBySpeed, RestitutionCurve};
///
/// // No bounce below 0.5 m/s, e = 0.8 from there on.
/// let threshold = RestitutionBySpeed::from(RestitutionCurve::threshold(0.5, 0.8).unwrap());
/// assert_eq!(threshold, RestitutionBySpeed(vec![(0.5, 0.0), (0.5, 0.8)]));
/// ```
#[derive(Component, Reflect, Clone, Debug, Default, PartialEq)]
#[reflect(Component, Default, Debug, PartialEq, Clone)]
pub struct RestitutionBySpeed(pub Vec<(f64, f64)>);

impl RestitutionBySpeed {
    /// The curve through these points, as [`RestitutionCurve::new`] builds it.
    pub fn curve(&self) -> Result<RestitutionCurve, ModelError> {
        RestitutionCurve::new(self.0.as_slice())
    }
}

impl From<RestitutionCurve> for RestitutionBySpeed {
    fn from(curve: RestitutionCurve) -> Self {
        Self(curve.into())
    }
}

/// A ball's own rolling resistance `mu_r` and spinning friction `mu_sp`
/// (`ImpactPlugin::set_body_rolling`), each dimensionless in `[0, 100]`: while the closed form
/// rolls the ball, torques `mu_r R N` and `mu_sp R N` oppose its rolling and its spin about
/// the ground normal. Used on every ground without its own ([`GroundMaterial`]); without it,
/// the configuration's (`ImpactConfig::rolling_resistance`, `spinning_friction`) apply. A
/// value out of range is refused with an [`crate::ImpactErrorMessage`] and the body keeps
/// the values it had.
#[derive(Component, Reflect, Clone, Copy, Debug, Default, PartialEq)]
#[reflect(Component, Default, Debug, PartialEq, Clone)]
pub struct Rolling {
    /// Rolling resistance `mu_r`: while the ball rolls, a torque `mu_r R N` opposes it.
    pub rolling_resistance: f64,
    /// Spinning friction `mu_sp`: a torque `mu_sp R N` opposes its spin about the normal.
    pub spinning_friction: f64,
}

impl Rolling {
    /// Rolling resistance `mu_r` and spinning friction `mu_sp`.
    pub fn new(rolling_resistance: f64, spinning_friction: f64) -> Self {
        Self {
            rolling_resistance,
            spinning_friction,
        }
    }
}

impl From<Rolling> for RollingSettings {
    fn from(r: Rolling) -> Self {
        RollingSettings::new(r.rolling_resistance, r.spinning_friction)
    }
}

impl From<RollingSettings> for Rolling {
    fn from(r: RollingSettings) -> Self {
        Self::new(r.rolling_resistance, r.spinning_friction)
    }
}

/// The plugin's settings, for every rapier context. Inserted by
/// [`crate::RapierImpactPlugin`]; change it at any time (a bad configuration is refused with
/// an [`crate::ImpactErrorMessage`] and the last good one is kept).
///
/// Reflected: `all_fixed_colliders_ground`. Not reflected: `config` (the core crate's
/// `ImpactConfig` is not `Reflect`); change it from a system.
#[derive(Resource, Reflect, Clone, Debug, Default, PartialEq)]
#[reflect(Resource, Default, Debug, PartialEq, Clone)]
pub struct ImpactSettings {
    /// The core plugin's configuration (law, timing mode, resting thresholds, rolling).
    #[reflect(ignore, clone)]
    pub config: ImpactConfig,
    /// Every fixed collider (parentless, or on a fixed body) is ground, without a
    /// [`Ground`] marker: `ImpactPlugin::set_all_fixed_colliders_ground`.
    pub all_fixed_colliders_ground: bool,
}

/// The core plugin of one rapier context, with what the Bevy side remembers of it. Added to
/// every entity with bevy_rapier's `RapierContextSimulation` (a required component).
///
/// [`Self::plugin`] gives the core plugin's state (`is_ground`, `ground_material`,
/// `is_impact_body`, `body_rolling`, ...); [`Self::plugin_mut`] the core API that has no Bevy
/// form here (excluded bodies, every dynamic body in impacts between bodies, profiling); its
/// handles are those of the context's rapier sets (`RapierRigidBodyHandle`,
/// `RapierColliderHandle` on the entities). What the components set is theirs: a value set
/// here through the core API for an entity that has the matching component is set again from
/// the component only when the component changes.
///
/// Reflected: [`Self::steps`] only (the core plugin is not `Reflect`).
#[derive(Component, Reflect)]
#[reflect(Component, Default, from_reflect = false)]
pub struct ImpactSimulation {
    /// `None` only while the step system has it (its hook swapped for the frame's).
    #[reflect(ignore)]
    pub(crate) plugin: Option<ImpactPlugin>,
    /// Ground entities and their collider, with what was applied.
    #[reflect(ignore)]
    pub(crate) grounds: HashMap<Entity, GroundState>,
    /// Scratch set of the entities seen this frame (kept for its allocation).
    #[reflect(ignore)]
    pub(crate) seen: HashSet<Entity>,
    /// Body entities with settings of their own (an [`ImpactBody`] marker, a tangential
    /// restitution, a restitution curve, rolling coefficients), with their rapier body and
    /// what was applied.
    #[reflect(ignore)]
    pub(crate) bodies: HashMap<Entity, BodyState>,
    /// The settings last applied (or refused), to apply a change once.
    #[reflect(ignore)]
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
            bodies: HashMap::default(),
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

/// A ground entity as last seen: its rapier collider, whether the core plugin took it as
/// ground, and the material given (or refused).
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct GroundState {
    pub handle: ColliderHandle,
    pub taken: bool,
    pub material: Option<GroundMaterial>,
}

/// A body entity's own settings as last given to the core plugin (applied or refused), with
/// its rapier body.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct BodyState {
    pub handle: RigidBodyHandle,
    pub settings: BodySettings,
}

/// A body's own settings, as its components give them.
#[derive(Clone, Debug, Default, PartialEq)]
pub(crate) struct BodySettings {
    /// With an [`ImpactBody`] marker: whether the rapier body was dynamic (a change tries the
    /// marker again).
    pub impact: Option<bool>,
    pub tangential_restitution: Option<f64>,
    pub restitution_curve: Option<Vec<(f64, f64)>>,
    pub rolling: Option<Rolling>,
}
