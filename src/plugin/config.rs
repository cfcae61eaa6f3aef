//! The plugin's configuration, the per-ground material override, and the error a bad
//! setting or registration returns at the call that made it.

use crate::model::{Law, Material, ModelError, RestitutionCurve, Shown};
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

/// The largest restitution the plugin takes, from a ground material or a collider: above 1 a
/// contact adds energy (a game's bumper may); 10 already multiplies each approach speed
/// tenfold, and much larger values overflow rapier's `f32` velocities within a few bounces.
pub(crate) const MAX_RESTITUTION: f64 = 10.0;
/// The largest friction, rolling-resistance and spinning-friction coefficient the plugin
/// takes: beyond a few every contact grips and every roll stops at once, so larger values
/// change nothing and are taken for a mistake.
pub(crate) const MAX_FRICTION: f64 = 100.0;
/// The largest resting speed (m/s) and resting gap (m): a threshold of that size makes every
/// contact rest.
pub(crate) const MAX_THRESHOLD: f64 = 1e3;
/// The largest flat-landing tolerance (a tilt, rad): at 1 every face lands flat.
pub(crate) const MAX_FLAT_TOLERANCE: f64 = 1.0;

/// Is `value` in `[0, max]` (so finite)?
fn in_range(value: f64, max: f64) -> bool {
    (0.0..=max).contains(&value)
}

/// Checks a tangential restitution (in `[-1, 1]`) and a restitution curve (every `e` at most
/// [`MAX_RESTITUTION`]; the curve checked its own points when it was built); `error` builds
/// the error from the field's name and the value refused.
fn check_bounce(
    tangential_restitution: Option<f64>,
    restitution_curve: Option<&RestitutionCurve>,
    error: impl Fn(&'static str, f64) -> ConfigError,
) -> Result<(), ConfigError> {
    if let Some(beta) = tangential_restitution {
        if !(-1.0..=1.0).contains(&beta) {
            return Err(error("tangential_restitution", beta));
        }
    }
    if let Some(curve) = restitution_curve {
        if curve.max() > MAX_RESTITUTION {
            return Err(error("restitution_curve", curve.max()));
        }
    }
    Ok(())
}

/// Checks a body's own tangential restitution and restitution curve
/// ([`crate::ImpactPlugin::set_body_tangential_restitution`],
/// [`crate::ImpactPlugin::set_body_restitution_curve`]), refused as that setter's.
pub(crate) fn body_bounce(
    tangential_restitution: Option<f64>,
    restitution_curve: Option<&RestitutionCurve>,
) -> Result<(), ConfigError> {
    check_bounce(tangential_restitution, restitution_curve, |field, value| {
        let setter = match field {
            "tangential_restitution" => "set_body_tangential_restitution",
            _ => "set_body_restitution_curve",
        };
        ConfigError::InvalidBodySetting {
            setter,
            field,
            value,
        }
    })
}

/// Are a collider's (or a material's) restitution and friction in the plugin's ranges
/// (`[0, 10]` and `[0, 100]`)? A collider outside them is left to rapier
/// ([`crate::Diagnostic::CoefficientsOutOfRange`]).
pub(crate) fn coefficients_in_range(restitution: f64, friction: f64) -> bool {
    in_range(restitution, MAX_RESTITUTION) && in_range(friction, MAX_FRICTION)
}

/// A material that replaces, for one ground, the coefficients rapier would combine from the
/// two colliders. Build it with [`GroundMaterial::new`] and the `with_` methods (it is
/// `#[non_exhaustive]`, so that a coefficient added later breaks no caller).
#[derive(Clone, Debug, PartialEq)]
#[cfg_attr(
    feature = "serde-serialize",
    derive(serde::Serialize, serde::Deserialize)
)]
#[non_exhaustive]
pub struct GroundMaterial {
    /// Coefficient of restitution `e`, in `[0, 10]` (1 = elastic; above 1 the contact adds
    /// energy).
    pub restitution: f64,
    /// Coefficient of friction `mu`, in `[0, 100]`.
    pub friction: f64,
    /// Rolling resistance `mu_r` on this ground (dimensionless, in `[0, 100]`), or `None`
    /// for the body's or the configuration's (see [`ImpactConfig::rolling_resistance`]).
    pub rolling_resistance: Option<f64>,
    /// Spinning friction `mu_sp` on this ground, or `None` (see
    /// [`ImpactConfig::spinning_friction`]).
    pub spinning_friction: Option<f64>,
    /// Walton's tangential restitution `beta0` on this ground, in `[-1, 1]`, or `None` for the
    /// body's or the configuration's (see [`ImpactConfig::tangential_restitution`]).
    #[cfg_attr(feature = "serde-serialize", serde(default))]
    pub tangential_restitution: Option<f64>,
    /// Restitution as a function of the impact speed on this ground, replacing `restitution`,
    /// or `None` for the body's or the configuration's, else `restitution` (see
    /// [`ImpactConfig::restitution_curve`]).
    #[cfg_attr(feature = "serde-serialize", serde(default))]
    pub restitution_curve: Option<RestitutionCurve>,
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

    /// The same material with a restitution that depends on the impact speed on this ground.
    pub fn with_restitution_curve(self, curve: RestitutionCurve) -> Self {
        Self {
            restitution_curve: Some(curve),
            ..self
        }
    }

    /// Checks every coefficient's range: `e` in `[0, 10]` (the curve's too), `mu`, `mu_r` and
    /// `mu_sp` in `[0, 100]`, `beta0` in `[-1, 1]` (NaN and infinities refused).
    pub fn validate(&self) -> Result<(), ConfigError> {
        self.to_model().validate().map_err(ConfigError::Material)?;
        let out = |field, value| ConfigError::MaterialOutOfRange { field, value };
        if !in_range(self.restitution, MAX_RESTITUTION) {
            return Err(out("restitution", self.restitution));
        }
        if !in_range(self.friction, MAX_FRICTION) {
            return Err(out("friction", self.friction));
        }
        for (field, value) in [
            ("rolling_resistance", self.rolling_resistance),
            ("spinning_friction", self.spinning_friction),
        ] {
            match value {
                Some(v) if !in_range(v, MAX_FRICTION) => return Err(out(field, v)),
                _ => {}
            }
        }
        check_bounce(
            self.tangential_restitution,
            self.restitution_curve.as_ref(),
            out,
        )
    }

    /// The constant coefficients it overrides (its tangential restitution is kept apart: when
    /// it has none, the body's or the configuration's applies).
    pub(crate) fn to_model(&self) -> Material {
        Material::new(self.restitution, self.friction)
    }
}

/// How the plugin resolves ground impacts. Build it with [`Default`] and the `with_` methods
/// (or change the fields of a default one: it is `#[non_exhaustive]`, so that a setting added
/// later breaks no caller); [`ImpactConfig::validate`] (called by the plugin whenever a config
/// is set) rejects values out of range.
///
/// ```
/// use rapier_impact::{ImpactConfig, TimingMode};
///
/// let config = ImpactConfig::default()
///     .with_timing(TimingMode::TimeOfImpact)
///     .with_rolling_resistance(0.01);
/// assert!(config.validate().is_ok());
/// ```
#[derive(Clone, Debug, PartialEq)]
#[cfg_attr(
    feature = "serde-serialize",
    derive(serde::Serialize, serde::Deserialize)
)]
#[non_exhaustive]
pub struct ImpactConfig {
    /// The impact law (default [`Law::Guarded`]: the document's closed form, falling back to
    /// the consistent law where the closed form is unphysical).
    pub law: Law,
    /// When inside a step impacts are resolved (default [`TimingMode::Exact`]).
    pub timing: TimingMode,
    /// Resting approach speed (m/s), in `[0, 1000]`, or `None` for the automatic value
    /// `max(0.5 |g| dt, 1e-3)`: the speed gravity adds in half a step.
    ///
    /// A contact within [`ImpactConfig::resting_gap`] of the ground whose normal speed at the
    /// contact point is at most this (approaching or separating) is handed to rapier's solver
    /// with zero restitution, so it rests, rolls, slides and sleeps as in rapier, without
    /// jitter or micro-bounces. An impact found inside a step with an approach speed below
    /// this is resolved with `e = 0` (friction still by the model), after which the contact is
    /// a resting one.
    pub resting_speed: Option<f64>,
    /// Resting gap (m), in `[0, 1000]`, or `None` for rapier's allowed linear error
    /// (`IntegrationParameters::allowed_linear_error()`, 5 mm at the default length unit):
    /// how close to the ground a slow contact must be to count as resting.
    pub resting_gap: Option<f64>,
    /// Flat-landing tolerance (dimensionless, height difference over the size of the landing
    /// face: the tilt in radians), in `[0, 1]`, default `1e-3`.
    ///
    /// When a polyhedral face or edge lands, its vertices whose height above the contact plane
    /// is within this tolerance and that approach the ground are one simultaneous impact at
    /// their centroid (`docs/guide.md`, "Contact geometry"); otherwise the impact is at
    /// the single deepest point.
    pub flat_tolerance: f64,
    /// Most impacts resolved for one body in one step (`>= 1`, default 8). The last one allowed
    /// is resolved with `e = 0`, so a body caught in a rapid sequence of impacts comes to rest
    /// on the ground instead of bouncing indefinitely.
    pub max_impacts_per_step: usize,
    /// Rolling resistance `mu_r` (dimensionless, in `[0, 100]`, default 0): while a ball
    /// the plugin rolls in closed form rolls without slip, a torque `mu_r R N` opposes it
    /// (`docs/model.md`). Which value a ball gets: the ground's
    /// ([`GroundMaterial::rolling_resistance`]), else the ball's
    /// ([`crate::ImpactPlugin::set_body_rolling`]), else this.
    pub rolling_resistance: f64,
    /// Spinning friction `mu_sp` (dimensionless, in `[0, 100]`, default 0): a torque
    /// `mu_sp R N` about the ground normal opposes a rolling ball's spin about it. Chosen as
    /// [`ImpactConfig::rolling_resistance`] is.
    pub spinning_friction: f64,
    /// Walton's tangential restitution `beta0`, in `[-1, 1]`, default 0 (Coulomb's stick): a
    /// contact that grips leaves with `-beta0` times its incoming tangential contact velocity
    /// when the friction cone allows it ([`crate::model::Material::tangential_restitution`]).
    /// Which value an impact gets: the ground's ([`GroundMaterial::tangential_restitution`]),
    /// else the body's ([`crate::ImpactPlugin::set_body_tangential_restitution`]; between two
    /// bodies, the mean of those that have one), else this.
    #[cfg_attr(feature = "serde-serialize", serde(default))]
    pub tangential_restitution: f64,
    /// Restitution as a function of the normal approach speed of the contact point
    /// ([`RestitutionCurve`]), replacing the constant `e` of the colliders (or of a
    /// [`GroundMaterial`]) where set, default `None`. Which curve an impact gets: the ground's
    /// ([`GroundMaterial::restitution_curve`]), else the body's
    /// ([`crate::ImpactPlugin::set_body_restitution_curve`]; between two bodies that both
    /// have one, the mean of the two), else this; with none, the constant `e`. Every `e` of
    /// a curve is at most 10.
    #[cfg_attr(feature = "serde-serialize", serde(default))]
    pub restitution_curve: Option<RestitutionCurve>,
}

/// A ball's own rolling coefficients ([`crate::ImpactPlugin::set_body_rolling`]), each
/// dimensionless in `[0, 100]`: used on every ground without its own (see
/// [`ImpactConfig::rolling_resistance`]).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[cfg_attr(
    feature = "serde-serialize",
    derive(serde::Serialize, serde::Deserialize)
)]
#[non_exhaustive]
pub struct RollingSettings {
    /// Rolling resistance `mu_r`: while the ball rolls, a torque `mu_r R N` opposes it.
    pub rolling_resistance: f64,
    /// Spinning friction `mu_sp`: a torque `mu_sp R N` opposes its spin about the normal.
    pub spinning_friction: f64,
}

impl RollingSettings {
    /// Rolling resistance `mu_r` and spinning friction `mu_sp`.
    pub fn new(rolling_resistance: f64, spinning_friction: f64) -> Self {
        Self {
            rolling_resistance,
            spinning_friction,
        }
    }

    /// Checks both coefficients: in `[0, 100]`, else
    /// [`ConfigError::InvalidBodySetting`] of [`crate::ImpactPlugin::set_body_rolling`].
    pub fn validate(&self) -> Result<(), ConfigError> {
        let own = |field, value| ConfigError::InvalidBodySetting {
            setter: "set_body_rolling",
            field,
            value,
        };
        rolling_coefficient("rolling_resistance", self.rolling_resistance, own)?;
        rolling_coefficient("spinning_friction", self.spinning_friction, own)
    }
}

/// Checks a body's or the configuration's rolling coefficient: in `[0, 100]`; `error` builds
/// the error from the field's name and the value refused.
fn rolling_coefficient(
    field: &'static str,
    value: f64,
    error: impl Fn(&'static str, f64) -> ConfigError,
) -> Result<(), ConfigError> {
    if in_range(value, MAX_FRICTION) {
        Ok(())
    } else {
        Err(error(field, value))
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
            tangential_restitution: 0.0,
            restitution_curve: None,
        }
    }
}

/// One builder method per field of [`ImpactConfig`]: `with_<field>(value)` returns the
/// configuration with that field set.
macro_rules! with_fields {
    ($($(#[$doc:meta])* $name:ident: $field:ident: $ty:ty;)*) => {
        $(
            $(#[$doc])*
            pub fn $name(self, $field: $ty) -> Self {
                Self { $field, ..self }
            }
        )*
    };
}

impl ImpactConfig {
    with_fields! {
        /// With the impact law [`ImpactConfig::law`].
        with_law: law: Law;
        /// With the timing mode [`ImpactConfig::timing`].
        with_timing: timing: TimingMode;
        /// With the resting speed [`ImpactConfig::resting_speed`] (m/s; `None`: automatic).
        with_resting_speed: resting_speed: Option<f64>;
        /// With the resting gap [`ImpactConfig::resting_gap`] (m; `None`: rapier's).
        with_resting_gap: resting_gap: Option<f64>;
        /// With the flat-landing tolerance [`ImpactConfig::flat_tolerance`].
        with_flat_tolerance: flat_tolerance: f64;
        /// With [`ImpactConfig::max_impacts_per_step`].
        with_max_impacts_per_step: max_impacts_per_step: usize;
        /// With the rolling resistance [`ImpactConfig::rolling_resistance`].
        with_rolling_resistance: rolling_resistance: f64;
        /// With the spinning friction [`ImpactConfig::spinning_friction`].
        with_spinning_friction: spinning_friction: f64;
        /// With Walton's tangential restitution [`ImpactConfig::tangential_restitution`].
        with_tangential_restitution: tangential_restitution: f64;
        /// With the restitution curve [`ImpactConfig::restitution_curve`] (`None`: the
        /// constant `e`).
        with_restitution_curve: restitution_curve: Option<RestitutionCurve>;
    }

    /// Checks every field's range.
    pub fn validate(&self) -> Result<(), ConfigError> {
        let check = |field: &'static str, value: f64, max: f64| {
            if in_range(value, max) {
                Ok(())
            } else {
                Err(ConfigError::InvalidConfig { field, value })
            }
        };
        if let Some(v) = self.resting_speed {
            check("resting_speed", v, MAX_THRESHOLD)?;
        }
        if let Some(v) = self.resting_gap {
            check("resting_gap", v, MAX_THRESHOLD)?;
        }
        check("flat_tolerance", self.flat_tolerance, MAX_FLAT_TOLERANCE)?;
        let own = |field, value| ConfigError::InvalidConfig { field, value };
        rolling_coefficient("rolling_resistance", self.rolling_resistance, own)?;
        rolling_coefficient("spinning_friction", self.spinning_friction, own)?;
        check_bounce(
            Some(self.tangential_restitution),
            self.restitution_curve.as_ref(),
            own,
        )?;
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
#[non_exhaustive]
pub enum ConfigError {
    /// A config field is outside its documented range (NaN, infinite, negative, too large,
    /// or zero where `>= 1`).
    InvalidConfig {
        /// The field of [`ImpactConfig`].
        field: &'static str,
        /// The value refused.
        value: f64,
    },
    /// A body's own setting is outside its documented range (NaN, infinite, or beyond its
    /// ends), refused by the setter named, a method of [`crate::ImpactPlugin`]: a field of
    /// [`RollingSettings`] (`set_body_rolling`), a tangential restitution
    /// (`set_body_tangential_restitution`), or a restitution curve with an `e` above 10
    /// (`set_body_restitution_curve`). [`crate::ImpactPlugin::restore`] refuses a snapshot
    /// holding such a setting with it too.
    InvalidBodySetting {
        /// The method of [`crate::ImpactPlugin`] whose argument it is.
        setter: &'static str,
        /// The setting: `rolling_resistance`, `spinning_friction`, `tangential_restitution` or
        /// `restitution_curve`.
        field: &'static str,
        /// The value refused (a curve's largest `e`).
        value: f64,
    },
    /// The model refuses a material: a ground material's restitution or friction is negative
    /// or not finite, or points given for a restitution curve make none (the Bevy crate's
    /// curve components build theirs from points).
    Material(ModelError),
    /// A ground material's coefficient is above its documented range (or, for the rolling
    /// coefficients, outside it).
    MaterialOutOfRange {
        /// The field of [`GroundMaterial`].
        field: &'static str,
        /// The value refused.
        value: f64,
    },
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
            Self::InvalidConfig { field, value } => write!(
                f,
                "ImpactConfig::{field} is {}, outside its range {}",
                Shown(*value),
                range_of(field)
            ),
            Self::InvalidBodySetting {
                setter,
                field,
                value,
            } => write!(
                f,
                "ImpactPlugin::{setter}: {field} is {}, outside its range {}",
                Shown(*value),
                range_of(field)
            ),
            Self::Material(e) => {
                write!(f, "invalid material: {e}")?;
                // A coefficient the model refuses (NaN, infinite, negative) is one of a
                // `GroundMaterial`'s: its range is said too.
                let field = match e {
                    ModelError::NegativeRestitution(_) => Some("restitution"),
                    ModelError::NegativeFriction(_) => Some("friction"),
                    ModelError::NotFinite { what } => {
                        Some(*what).filter(|w| matches!(*w, "restitution" | "friction"))
                    }
                    _ => None,
                };
                match field {
                    Some(field) => write!(f, "; GroundMaterial::{field} takes {}", range_of(field)),
                    None => Ok(()),
                }
            }
            Self::MaterialOutOfRange { field, value } => write!(
                f,
                "GroundMaterial::{field} is {}, outside its range {}",
                Shown(*value),
                range_of(field)
            ),
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

/// A field's documented range, for the error's message.
fn range_of(field: &str) -> String {
    let max = match field {
        "restitution" => MAX_RESTITUTION,
        "friction" | "rolling_resistance" | "spinning_friction" => MAX_FRICTION,
        "resting_speed" | "resting_gap" => MAX_THRESHOLD,
        "flat_tolerance" => MAX_FLAT_TOLERANCE,
        "tangential_restitution" => return "[-1, 1]".to_string(),
        "restitution_curve" => return format!("(each e) [0, {MAX_RESTITUTION}]"),
        _ => return ">= 1".to_string(),
    };
    format!("[0, {max}]")
}

impl std::error::Error for ConfigError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match self {
            Self::Material(e) => Some(e),
            _ => None,
        }
    }
}
