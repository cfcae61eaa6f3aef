//! The document's law in the document's own notation (Cloete 2020, eqs. 1-19), with the
//! errata of `docs/model.md` fixed and nothing else changed.
//!
//! Notation (figure 1 of the document): z up; `B` the centre of mass, `A` the contact
//! point, `r = A - B = (l_x, l_y, -h)`; isotropic inertia `I`; `J_x`, `J_y` the friction
//! impulses counted against `+x`, `+y`; `J_z` the normal impulse, upward. The impulse on
//! the body is therefore `P = (-J_x, -J_y, J_z)`. State 1 is before the impact, state 2
//! after.
//!
//! Use this module to check the crate against the paper; the general form
//! ([`crate::model::resolve`]) is the same law for any body and ground.

use super::error::{ModelError, check_coefficients, finite, finite3};
use super::types::Regime;
use nalgebra::Vector3;

/// One impact in the document's notation. Units are SI.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(
    feature = "serde-serialize",
    derive(serde::Serialize, serde::Deserialize)
)]
pub struct SeedInput {
    /// `m`, the body's mass (kg), `> 0`.
    pub mass: f64,
    /// `I`, the body's isotropic moment of inertia about `B` (kg m^2), `> 0`.
    pub inertia: f64,
    /// `l_x`: x offset of the contact point `A` from the centre of mass (m).
    pub lx: f64,
    /// `l_y`: y offset of `A` from `B` (m).
    pub ly: f64,
    /// `h`: height of `B` above `A` (m); `A` is at `z = -h` relative to `B`.
    pub h: f64,
    /// `e`, Newton's coefficient of restitution, `>= 0`.
    pub restitution: f64,
    /// `mu`, Coulomb's coefficient of friction, `>= 0`.
    pub friction: f64,
    /// `(u_x1, u_y1, u_z1)`: velocity of `B` before the impact (m/s).
    pub u1: Vector3<f64>,
    /// `(w_x1, w_y1, w_z1)`: angular velocity before the impact (rad/s).
    pub w1: Vector3<f64>,
}

impl Default for SeedInput {
    /// A solid unit sphere (m = 1 kg, R = 1 m, I = 2/5 m R^2) falling straight down at
    /// 1 m/s onto its lowest point, e = 0.5, mu = 0.5.
    fn default() -> Self {
        Self {
            mass: 1.0,
            inertia: 0.4,
            lx: 0.0,
            ly: 0.0,
            h: 1.0,
            restitution: 0.5,
            friction: 0.5,
            u1: Vector3::new(0.0, 0.0, -1.0),
            w1: Vector3::zeros(),
        }
    }
}

/// The document's result for one impact.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(
    feature = "serde-serialize",
    derive(serde::Serialize, serde::Deserialize)
)]
pub struct SeedOutcome {
    /// `(J_x, J_y, J_z)` in the document's sign convention (N s).
    pub impulse: Vector3<f64>,
    /// `(u_x2, u_y2, u_z2)`: velocity of `B` after the impact (m/s), eqs. (4)-(6).
    pub u2: Vector3<f64>,
    /// `(w_x2, w_y2, w_z2)`: angular velocity after the impact (rad/s), eqs. (7)-(9).
    pub w2: Vector3<f64>,
    /// Case A ([`Regime::Stick`]), case B ([`Regime::Slip`]), or
    /// [`Regime::Separating`] when the contact does not approach (erratum 5).
    pub regime: Regime,
    /// `(u_x1T, u_y1T, u_z1T)`: contact-point velocity before the impact, eqs. (1)-(3).
    pub contact_velocity_before: Vector3<f64>,
    /// `(u_x2T, u_y2T, u_z2T)`: contact-point velocity after the impact.
    pub contact_velocity_after: Vector3<f64>,
    /// `theta`, the direction of the friction impulse in case B (rad), by `atan2`.
    /// `None` in case A and when separating.
    pub theta: Option<f64>,
    /// Kinetic energy before (J): `1/2 m |u1|^2 + 1/2 I |w1|^2`.
    pub ke_before: f64,
    /// Kinetic energy after (J).
    pub ke_after: f64,
}

impl SeedOutcome {
    /// `ke_after - ke_before` (J).
    pub fn energy_change(&self) -> f64 {
        self.ke_after - self.ke_before
    }
}

impl SeedInput {
    /// Checks every field: finite, `m > 0`, `I > 0`, `e >= 0`, `mu >= 0`.
    pub fn validate(&self) -> Result<(), ModelError> {
        finite(self.mass, "mass")?;
        finite(self.inertia, "inertia")?;
        finite(self.lx, "lx")?;
        finite(self.ly, "ly")?;
        finite(self.h, "h")?;
        finite3(&self.u1, "u1")?;
        finite3(&self.w1, "w1")?;
        check_coefficients(self.restitution, self.friction)?;
        if self.mass <= 0.0 {
            return Err(ModelError::NonPositiveMass(self.mass));
        }
        if self.inertia <= 0.0 {
            return Err(ModelError::NonPositiveInertia(self.inertia));
        }
        Ok(())
    }

    /// `r = A - B = (l_x, l_y, -h)`.
    pub fn offset(&self) -> Vector3<f64> {
        Vector3::new(self.lx, self.ly, -self.h)
    }

    fn kinetic_energy(&self, u: &Vector3<f64>, w: &Vector3<f64>) -> f64 {
        0.5 * self.mass * u.norm_squared() + 0.5 * self.inertia * w.norm_squared()
    }
}

/// Eqs. (1)-(3): the contact-point velocity `u_T = u + w × r`, written out:
/// `u_xT = u_x - w_y h - w_z l_y`, `u_yT = u_y + w_x h + w_z l_x`,
/// `u_zT = u_z - w_y l_x + w_x l_y`.
pub fn contact_velocity(input: &SeedInput, u: &Vector3<f64>, w: &Vector3<f64>) -> Vector3<f64> {
    let (lx, ly, h) = (input.lx, input.ly, input.h);
    Vector3::new(
        u.x - w.y * h - w.z * ly,
        u.y + w.x * h + w.z * lx,
        u.z - w.y * lx + w.x * ly,
    )
}

/// Eqs. (4)-(9): velocities after applying `J = (J_x, J_y, J_z)`:
/// `u2 = u1 + (-J_x, -J_y, J_z)/m` and
/// `w2 = w1 + ((J_z l_y - J_y h), (-J_z l_x + J_x h), (J_x l_y - J_y l_x))/I`.
pub fn apply_impulse(input: &SeedInput, j: &Vector3<f64>) -> (Vector3<f64>, Vector3<f64>) {
    let (m, i) = (input.mass, input.inertia);
    let (lx, ly, h) = (input.lx, input.ly, input.h);
    let u2 = input.u1 + Vector3::new(-j.x, -j.y, j.z) / m;
    let w2 =
        input.w1 + Vector3::new(j.z * ly - j.y * h, -j.z * lx + j.x * h, j.x * ly - j.y * lx) / i;
    (u2, w2)
}

/// Eqs. (10)-(12): the sticking impulse, from `u_x2T = u_y2T = 0` and
/// `u_z2T = -e u_z1T`.
///
/// The system is `K P = -(u_x1T, u_y1T, (1+e) u_z1T)` with `P = (-J_x, -J_y, J_z)` and
/// `K = E/m + (|r|^2 E - r r^T)/I`; (10)-(12) are its rows multiplied by `I`. It is solved
/// by the closed form `K^-1 = m (I E + m r r^T) / (I + m |r|^2)` (`docs/model.md`, erratum 4),
/// accurate to rounding at every `I/m`, where a general 3x3 solve loses digits.
pub fn sticking_impulse(input: &SeedInput, u1t: &Vector3<f64>) -> Vector3<f64> {
    let (m, i) = (input.mass, input.inertia);
    let r = input.offset();
    let d = Vector3::new(-u1t.x, -u1t.y, -(1.0 + input.restitution) * u1t.z);
    let p = (d * i + r * (m * r.dot(&d))) * (m / (i + m * r.norm_squared()));
    Vector3::new(-p.x, -p.y, p.z)
}

/// Eqs. (13)-(15): the direction `theta` of the friction impulse, which opposes the
/// initial slip `(u_x1T, u_y1T)`. The document's three cases are `atan2` written by hand
/// and miss its edge cases (`u_y1T = 0` with `u_x1T < 0`, `u_x1T = -0.0`); this is
/// `atan2(u_y1T, u_x1T)` (`docs/model.md`, erratum 2). `None` when there is no slip.
pub fn slip_angle(u1t: &Vector3<f64>) -> Option<f64> {
    if u1t.x == 0.0 && u1t.y == 0.0 {
        None
    } else {
        Some(crate::math::atan2(u1t.y, u1t.x))
    }
}

/// Eqs. (16)-(19): the slipping impulse `J_x = mu J_z cos(theta)`,
/// `J_y = mu J_z sin(theta)` with, from (18),
/// `J_z = -(1+e) u_z1T I / (l_x^2 + l_y^2 + I/m - mu h (l_x cos theta + l_y sin theta))`.
/// The document's (19) has a stray `J_z` in the denominator (`docs/model.md`, erratum 1).
///
/// Returns [`ModelError::Jam`] when the denominator is `<= 0`.
pub fn slip_impulse(
    input: &SeedInput,
    u1t: &Vector3<f64>,
    theta: f64,
) -> Result<Vector3<f64>, ModelError> {
    let (m, i, mu) = (input.mass, input.inertia, input.friction);
    let (lx, ly, h) = (input.lx, input.ly, input.h);
    let (sin, cos) = crate::math::sin_cos(theta);
    let denominator = lx * lx + ly * ly + i / m - mu * h * (lx * cos + ly * sin);
    if denominator <= 0.0 || !denominator.is_finite() {
        return Err(ModelError::Jam {
            denominator: denominator / i,
        });
    }
    let jz = -(1.0 + input.restitution) * u1t.z * i / denominator;
    Ok(Vector3::new(mu * jz * cos, mu * jz * sin, jz))
}

/// Resolves one impact by the document's law (eqs. 1-19), errata fixed.
///
/// 1. Contact velocity, eqs. (1)-(3). If `u_z1T >= 0` the contact does not approach:
///    no impulse (erratum 5).
/// 2. Sticking impulse, eqs. (10)-(12). Case A if `J_z >= 0` and
///    `sqrt(J_x^2 + J_y^2) <= mu J_z` (erratum 3: the document's `|mu J_z|` accepts a
///    pulling ground).
/// 3. Otherwise case B: `theta` by eqs. (13)-(15) as `atan2` (erratum 2); with zero
///    initial slip, along the sticking impulse's tangential direction; `J` by
///    eqs. (16)-(19) (erratum 1).
/// 4. Velocities after, eqs. (4)-(9).
pub fn solve(input: &SeedInput) -> Result<SeedOutcome, ModelError> {
    input.validate()?;
    let u1t = contact_velocity(input, &input.u1, &input.w1);
    let ke_before = input.kinetic_energy(&input.u1, &input.w1);
    if u1t.z >= 0.0 {
        return Ok(SeedOutcome {
            impulse: Vector3::zeros(),
            u2: input.u1,
            w2: input.w1,
            regime: Regime::Separating,
            contact_velocity_before: u1t,
            contact_velocity_after: u1t,
            theta: None,
            ke_before,
            ke_after: ke_before,
        });
    }
    let stick = sticking_impulse(input, &u1t);
    let tangential = crate::math::hypot(stick.x, stick.y);
    let (impulse, regime, theta) = if stick.z >= 0.0 && tangential <= input.friction * stick.z {
        (stick, Regime::Stick, None)
    } else {
        // With zero initial slip the friction impulse takes the sticking impulse's
        // tangential direction (erratum 2); J_x, J_y count against +x, +y, so that
        // direction is atan2(J_y, J_x) in the same convention as eq. (15).
        let theta = slip_angle(&u1t).unwrap_or_else(|| crate::math::atan2(stick.y, stick.x));
        (slip_impulse(input, &u1t, theta)?, Regime::Slip, Some(theta))
    };
    let (u2, w2) = apply_impulse(input, &impulse);
    Ok(SeedOutcome {
        impulse,
        u2,
        w2,
        regime,
        contact_velocity_before: u1t,
        contact_velocity_after: contact_velocity(input, &u2, &w2),
        theta,
        ke_before,
        ke_after: input.kinetic_energy(&u2, &w2),
    })
}
