//! The plugin's configuration, the per-ground material override, and the error a bad
//! setting or registration returns at the call that made it.

use crate::model::{Law, Material, ModelError};
use crate::rapier::prelude::{ColliderHandle, RigidBodyHandle};
use core::fmt;

/// When, inside a step, a ground impact is resolved. Accuracy costs time.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
#[cfg_attr(
    feature = "serde-serialize",
    derive(serde::Serialize, serde::Deserialize)
)]
pub enum TimingMode {
    /// The impulse is applied at the start of the step in which the contact closes, to the
    /// velocity the body has at that step boundary (rapier's own timing, like its speculative
    /// contacts). One contact query per body near a ground per step: the cheapest mode.
    /// Bounces start up to one step early, from up to one step's travel above the ground.
    Step,
    /// The impact is resolved at its exact time inside the step: the body flies from its
    /// start-of-step state to the contact (with its rotation), receives the impulse and flies
    /// on for the rest of the step, possibly hitting again. Between impacts, free flight is
    /// rapier's own integrator.
    TimeOfImpact,
    /// As [`TimingMode::TimeOfImpact`], and the free flight of every managed body with no
    /// other contact, joint or torque in the step is integrated exactly under gravity (and
    /// constant force and damping) in `f64`, replacing rapier's integrator.
    #[default]
    Exact,
}

/// A material that replaces, for one ground, the coefficients rapier would combine from the
/// two colliders.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(
    feature = "serde-serialize",
    derive(serde::Serialize, serde::Deserialize)
)]
pub struct GroundMaterial {
    /// Coefficient of restitution `e`, finite and `>= 0` (1 = elastic).
    pub restitution: f64,
    /// Coefficient of friction `mu`, finite and `>= 0`.
    pub friction: f64,
    /// Rolling resistance `mu_r` on this ground (dimensionless, finite and `>= 0`), or `None`
    /// for the body's or the configuration's (see [`ImpactConfig::rolling_resistance`]).
    pub rolling_resistance: Option<f64>,
    /// Spinning friction `mu_sp` on this ground, or `None` (see
    /// [`ImpactConfig::spinning_friction`]).
    pub spinning_friction: Option<f64>,
}

impl GroundMaterial {
    /// Restitution and friction, and no rolling coefficients of its own.
    pub fn new(restitution: f64, friction: f64) -> Self {
        Self {
            restitution,
            friction,
            rolling_resistance: None,
            spinning_friction: None,
        }
    }

    /// Checks `e >= 0`, `mu >= 0`, `mu_r >= 0`, `mu_sp >= 0`, all finite.
    pub fn validate(&self) -> Result<(), ConfigError> {
        self.to_model().validate().map_err(ConfigError::Material)?;
        rolling_coefficient("rolling_resistance", self.rolling_resistance)?;
        rolling_coefficient("spinning_friction", self.spinning_friction)
    }

    pub(crate) fn to_model(self) -> Material {
        Material::new(self.restitution, self.friction)
    }
}

/// How the plugin resolves ground impacts. Build it with [`Default`] and change the fields
/// you need; [`ImpactConfig::validate`] (called by the plugin whenever a config is set)
/// rejects values out of range.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(
    feature = "serde-serialize",
    derive(serde::Serialize, serde::Deserialize)
)]
pub struct ImpactConfig {
    /// The impact law (default [`Law::Guarded`]: the document's closed form, falling back to
    /// the consistent law where the closed form is unphysical).
    pub law: Law,
    /// When inside a step impacts are resolved (default [`TimingMode::Exact`]).
    pub timing: TimingMode,
    /// Resting approach speed (m/s), finite and `>= 0`, or `None` for the automatic value
    /// `max(0.5 |g| dt, 1e-3)`: the speed gravity adds in half a step.
    ///
    /// A contact within [`ImpactConfig::resting_gap`] of the ground whose normal speed at the
    /// contact point is at most this (approaching or separating) is handed to rapier's solver
    /// with zero restitution, so it rests, rolls, slides and sleeps as in rapier, without
    /// jitter or micro-bounces. An impact found inside a step with an approach speed below
    /// this is resolved with `e = 0` (friction still by the model), after which the contact is
    /// a resting one.
    pub resting_speed: Option<f64>,
    /// Resting gap (m), finite and `>= 0`, or `None` for rapier's allowed linear error
    /// (`IntegrationParameters::allowed_linear_error()`, 5 mm at the default length unit):
    /// how close to the ground a slow contact must be to count as resting.
    pub resting_gap: Option<f64>,
    /// Flat-landing tolerance (dimensionless, height difference over the size of the landing
    /// face: the tilt in radians), finite and `>= 0`, default `1e-3`.
    ///
    /// When a polyhedral face or edge lands, its vertices whose height above the contact plane
    /// is within this tolerance and that approach the ground are one simultaneous impact at
    /// their centroid (see the integration guide); otherwise the impact is at the single
    /// deepest point.
    pub flat_tolerance: f64,
    /// Most impacts resolved for one body in one step (`>= 1`, default 8). The last one allowed
    /// is resolved with `e = 0`, so a body caught in a rapid sequence of impacts comes to rest
    /// on the ground instead of bouncing indefinitely.
    pub max_impacts_per_step: usize,
    /// Rolling resistance `mu_r` (dimensionless, finite and `>= 0`, default 0): while a ball
    /// the plugin rolls in closed form rolls without slip, a torque `mu_r R N` opposes it
    /// (`docs/model.md`). Which value a ball gets: the ground's
    /// ([`GroundMaterial::rolling_resistance`]), else the ball's
    /// ([`crate::ImpactPlugin::set_body_rolling`]), else this.
    pub rolling_resistance: f64,
    /// Spinning friction `mu_sp` (dimensionless, finite and `>= 0`, default 0): a torque
    /// `mu_sp R N` about the ground normal opposes a rolling ball's spin about it. Chosen as
    /// [`ImpactConfig::rolling_resistance`] is.
    pub spinning_friction: f64,
}

/// Checks a rolling coefficient: finite and `>= 0`.
pub(crate) fn rolling_coefficient(
    field: &'static str,
    value: Option<f64>,
) -> Result<(), ConfigError> {
    match value {
        Some(v) if !(v.is_finite() && v >= 0.0) => {
            Err(ConfigError::InvalidConfig { field, value: v })
        }
        _ => Ok(()),
    }
}

impl Default for ImpactConfig {
    fn default() -> Self {
        Self {
            law: Law::Guarded,
            timing: TimingMode::Exact,
            resting_speed: None,
            resting_gap: None,
            flat_tolerance: 1e-3,
            max_impacts_per_step: 8,
            rolling_resistance: 0.0,
            spinning_friction: 0.0,
        }
    }
}

impl ImpactConfig {
    /// Checks every field's range.
    pub fn validate(&self) -> Result<(), ConfigError> {
        let check = |field: &'static str, value: f64| {
            if value.is_finite() && value >= 0.0 {
                Ok(())
            } else {
                Err(ConfigError::InvalidConfig { field, value })
            }
        };
        if let Some(v) = self.resting_speed {
            check("resting_speed", v)?;
        }
        if let Some(v) = self.resting_gap {
            check("resting_gap", v)?;
        }
        check("flat_tolerance", self.flat_tolerance)?;
        check("rolling_resistance", self.rolling_resistance)?;
        check("spinning_friction", self.spinning_friction)?;
        if self.max_impacts_per_step == 0 {
            return Err(ConfigError::InvalidConfig {
                field: "max_impacts_per_step",
                value: 0.0,
            });
        }
        Ok(())
    }
}

/// A configuration value or a registration the plugin refuses, returned by the call that
/// set it. Nothing is validated inside a step, and nothing there panics.
#[derive(Clone, Debug, PartialEq)]
pub enum ConfigError {
    /// A config field is out of range (NaN, infinite, negative, or zero where `>= 1`).
    InvalidConfig {
        /// The field of [`ImpactConfig`].
        field: &'static str,
        /// The value refused.
        value: f64,
    },
    /// A ground material's coefficient is negative or not finite.
    Material(ModelError),
    /// The handle is not a collider of the set (never inserted, or removed).
    NotACollider(ColliderHandle),
    /// The collider is not a ground of this plugin.
    NotAGround(ColliderHandle),
    /// The handle is not a rigid body of the set.
    NotABody(RigidBodyHandle),
    /// The ground body has no collider to be ground.
    GroundWithoutCollider(RigidBodyHandle),
    /// The collider is attached to a dynamic body: a ground must be fixed, kinematic, or
    /// parentless.
    DynamicGround(ColliderHandle),
    /// The body is not dynamic: only dynamic bodies take part in impacts between bodies.
    NotDynamic(RigidBodyHandle),
}

impl fmt::Display for ConfigError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::InvalidConfig { field, value } => {
                write!(f, "ImpactConfig::{field} is out of range: {value}")
            }
            Self::Material(e) => write!(f, "invalid ground material: {e}"),
            Self::NotACollider(h) => write!(f, "{h:?} is not a collider of this collider set"),
            Self::NotAGround(h) => write!(f, "collider {h:?} is not a ground of this plugin"),
            Self::NotABody(h) => write!(f, "{h:?} is not a rigid body of this body set"),
            Self::GroundWithoutCollider(h) => {
                write!(f, "ground body {h:?} has no collider")
            }
            Self::DynamicGround(h) => write!(
                f,
                "collider {h:?} belongs to a dynamic body; a ground must be fixed or kinematic"
            ),
            Self::NotDynamic(h) => write!(
                f,
                "body {h:?} is not dynamic; only dynamic bodies take part in impacts between bodies"
            ),
        }
    }
}

impl std::error::Error for ConfigError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match self {
            Self::Material(e) => Some(e),
            _ => None,
        }
    }
}
