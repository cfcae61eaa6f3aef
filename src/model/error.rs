//! The one error type of the model: which input value is wrong, and why.

use core::fmt;

/// An input the impact model refuses, naming the value that is wrong.
///
/// Every public entry point of [`crate::model`] validates its input before any
/// arithmetic, so a bad value is reported at the call that supplied it and never
/// turns into a NaN further down.
#[derive(Clone, Debug, PartialEq)]
// Serialize only: the field names it carries are `&'static str`, which no deserializer can
// give back.
#[cfg_attr(feature = "serde-serialize", derive(serde::Serialize))]
#[non_exhaustive]
pub enum ModelError {
    /// A value that must be finite is NaN or infinite. `what` names the field.
    NotFinite {
        /// The field, e.g. `"u1.x"` or `"contact.offset"`.
        what: &'static str,
    },
    /// The mass is zero or negative (kg). The model needs `mass > 0`.
    NonPositiveMass(f64),
    /// The scalar moment of inertia is zero or negative (kg m^2). The model needs `inertia > 0`.
    NonPositiveInertia(f64),
    /// The inverse inertia tensor is not symmetric (relative asymmetry given).
    AsymmetricInertia(f64),
    /// The inverse inertia tensor is not positive semi-definite: a principal minor is negative.
    NotPositiveSemiDefiniteInertia,
    /// The coefficient of restitution is negative. The model needs `e >= 0`.
    NegativeRestitution(f64),
    /// The coefficient of friction is negative. The model needs `mu >= 0`.
    NegativeFriction(f64),
    /// The tangential restitution `beta0` is outside `[-1, 1]` (or not finite).
    TangentialRestitutionOutOfRange(f64),
    /// A restitution curve has no point: it needs at least one `(speed, e)`.
    EmptyRestitutionCurve,
    /// A point of a restitution curve is refused: a speed or an `e` that is not finite or
    /// is negative, or a speed below the previous point's (the points go by increasing
    /// speed).
    InvalidCurvePoint {
        /// The point's index in the curve.
        index: usize,
        /// Its approach speed (m/s).
        speed: f64,
        /// Its coefficient of restitution.
        restitution: f64,
    },
    /// The contact normal is not of unit length (its length is given).
    NonUnitNormal(f64),
    /// The document's slip law has no solution: its denominator (eq. 19, corrected)
    /// `D = n.K(n - mu s)` is zero or negative, so the normal impulse would pull or be
    /// infinite. This is the Painleve-like jam (`docs/model.md`, "Where the document's law is not
    /// physical"); the `Consistent` and `Guarded` laws resolve it, the `Document` law
    /// reports it.
    Jam {
        /// The slip denominator in the model's units (1/kg).
        denominator: f64,
    },
    /// Both bodies of a pair impact are fixed ([`super::Body::fixed`]): nothing can move.
    BothFixed,
}

impl fmt::Display for ModelError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::NotFinite { what } => write!(f, "{what} is not finite (NaN or infinite)"),
            Self::NonPositiveMass(m) => write!(f, "mass must be > 0 kg, got {}", Shown(*m)),
            Self::NonPositiveInertia(i) => {
                write!(f, "moment of inertia must be > 0 kg m^2, got {}", Shown(*i))
            }
            Self::AsymmetricInertia(a) => {
                write!(
                    f,
                    "inverse inertia tensor is not symmetric (relative asymmetry {a:e})"
                )
            }
            Self::NotPositiveSemiDefiniteInertia => {
                write!(f, "inverse inertia tensor is not positive semi-definite")
            }
            Self::NegativeRestitution(e) => {
                write!(
                    f,
                    "coefficient of restitution must be >= 0, got {}",
                    Shown(*e)
                )
            }
            Self::NegativeFriction(mu) => {
                write!(
                    f,
                    "coefficient of friction must be >= 0, got {}",
                    Shown(*mu)
                )
            }
            Self::TangentialRestitutionOutOfRange(b) => {
                write!(
                    f,
                    "tangential restitution must be in [-1, 1], got {}",
                    Shown(*b)
                )
            }
            Self::EmptyRestitutionCurve => {
                write!(f, "a restitution curve needs at least one (speed, e) point")
            }
            Self::InvalidCurvePoint {
                index,
                speed,
                restitution,
            } => write!(
                f,
                "restitution curve point {index} (speed {} m/s, e {}) is refused: \
                 speeds and e must be finite and >= 0, speeds in increasing order",
                Shown(*speed),
                Shown(*restitution)
            ),
            Self::NonUnitNormal(len) => {
                write!(
                    f,
                    "contact normal must have unit length, got length {}",
                    Shown(*len)
                )
            }
            Self::Jam { denominator } => write!(
                f,
                "the document's slip law jams: denominator n.K(n - mu s) = {denominator:e} <= 0"
            ),
            Self::BothFixed => write!(f, "both bodies of the pair are fixed: neither can move"),
        }
    }
}

impl std::error::Error for ModelError {}

/// A value as an error message shows it: as Rust prints it where that is short, and in
/// scientific notation where that would run to many digits (Rust prints `1e300` with all
/// 301 of them, `1e-300` with 299 zeros after the point).
pub(crate) struct Shown(pub f64);

impl fmt::Display for Shown {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let a = self.0.abs();
        if a == 0.0 || !a.is_finite() || (1e-4..1e9).contains(&a) {
            write!(f, "{}", self.0)
        } else {
            write!(f, "{:e}", self.0)
        }
    }
}

/// `Ok(())` if `x` is finite, else [`ModelError::NotFinite`] naming `what`.
pub(crate) fn finite(x: f64, what: &'static str) -> Result<(), ModelError> {
    if x.is_finite() {
        Ok(())
    } else {
        Err(ModelError::NotFinite { what })
    }
}

/// Checks every component of a vector is finite.
pub(crate) fn finite3(v: &nalgebra::Vector3<f64>, what: &'static str) -> Result<(), ModelError> {
    if v.iter().all(|c| c.is_finite()) {
        Ok(())
    } else {
        Err(ModelError::NotFinite { what })
    }
}

/// Checks a restitution and a friction coefficient.
pub(crate) fn check_coefficients(restitution: f64, friction: f64) -> Result<(), ModelError> {
    finite(restitution, "restitution")?;
    finite(friction, "friction")?;
    if restitution < 0.0 {
        return Err(ModelError::NegativeRestitution(restitution));
    }
    if friction < 0.0 {
        return Err(ModelError::NegativeFriction(friction));
    }
    Ok(())
}

/// Checks a tangential restitution: finite and in `[-1, 1]`.
pub(crate) fn check_tangential_restitution(beta0: f64) -> Result<(), ModelError> {
    if (-1.0..=1.0).contains(&beta0) {
        Ok(())
    } else {
        Err(ModelError::TangentialRestitutionOutOfRange(beta0))
    }
}
