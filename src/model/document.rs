//! The document's law in the general form: any inertia tensor, any ground normal,
//! a moving ground (`docs/model.md`, "The general form").
//!
//! With the relative contact velocity `u1 = v + w × r - u_ground` and `u_n = n.u1 < 0`:
//!
//! - sticking (eqs. 10-12): `P = K^-1 (-(1+e) u_n n - (1+beta0) u_t)`, the impulse that
//!   leaves the contact velocity at `-e u_n n - beta0 u_t` (Walton's tangential
//!   restitution; `beta0 = 0` is the document's stick to zero slip), accepted when
//!   `P.n >= 0` and `|P_t| <= mu P.n` (erratum 3);
//! - slipping (eqs. 13-19): `P = p (n - mu s)` with `s` the unit initial slip and
//!   `p = -(1+e) u_n / (n.K (n - mu s))` (eq. 19 corrected, erratum 1). With zero initial
//!   slip, `s` is the invariant slip direction (erratum 2), which for an isotropic body
//!   is the sticking impulse's tangential direction.
//!
//! With `I_w^-1 = E/I` and `n = +z` this is [`super::seed::solve`] exactly.

use super::collision_matrix::Compliance;
use super::consistent::SWERVE_TOLERANCE;
use super::error::ModelError;
use super::types::{Material, Regime};
use nalgebra::{Vector2, Vector3};

/// The document's impulse on the body (world frame), its regime and the unit slip
/// direction it used (zero when sticking or frictionless), for an approaching contact of
/// unit normal `n` and compliance `k`. `u1` is the relative contact velocity.
#[inline(always)]
pub(crate) fn document_impulse<K: Compliance>(
    k: &K,
    n: &Vector3<f64>,
    material: &Material,
    u1: &Vector3<f64>,
) -> Result<(Vector3<f64>, Regime, Vector3<f64>), ModelError> {
    let (e, mu, beta) = (
        material.restitution,
        material.friction,
        material.tangential_restitution,
    );
    let un = n.dot(u1);
    let ut = u1 - n * un;

    // Sticking, eqs. (10)-(12): target contact velocity -e u_n n - beta0 u_t. With
    // beta0 = 0 the factor is exactly 1 and `d` is the document's, bit for bit.
    let d = -(n * ((1.0 + e) * un)) - ut * (1.0 + beta);
    let stick = k.solve(&d);
    let stick_n = stick.dot(n);
    let stick_t = stick - n * stick_n;
    if stick_n >= 0.0 && stick_t.norm_squared() <= (mu * stick_n) * (mu * stick_n) {
        return Ok((stick, Regime::Stick, Vector3::zeros()));
    }

    // Slipping, eqs. (13)-(19). A frictionless contact needs no direction: P = p n.
    let (s, along, denominator) = if mu == 0.0 {
        (Vector3::zeros(), *n, k.k_form(n, n))
    } else {
        // Zero slip (erratum 2) includes a slip at rounding level: u1 - n (n.u1) leaves
        // ~1e-16 |u1| in a random direction for an exactly normal approach when n is
        // not a coordinate axis, and eqs. (13)-(15) would take that noise as the slip
        // direction. The level is the consistent law's, where its slip stops.
        let zero = 1e-3 * SWERVE_TOLERANCE;
        let len2 = ut.norm_squared();
        let slipping = len2 > zero * zero * u1.norm_squared();
        let s = if slipping && len2 > 1e-200 && len2.is_finite() {
            // The common case, inline: the unit initial slip (eqs. 13-15 as atan2).
            ut * (1.0 / len2.sqrt())
        } else {
            let ut = if slipping { ut } else { Vector3::zeros() };
            slip_direction(k, n, &ut, mu)
        };
        let along = n - s * mu;
        let denominator = k.k_form(n, &along);
        (s, along, denominator)
    };
    if denominator <= 0.0 || !denominator.is_finite() {
        return Err(ModelError::Jam { denominator });
    }
    let p = -(1.0 + e) * un / denominator;
    Ok((along * p, Regime::Slip, s))
}

/// The unit slip direction at the start of the impact: the initial tangential contact
/// velocity (eqs. 13-15 as atan2), or, when it is exactly zero, the direction in which
/// slip grows from rest (erratum 2). Out of line: [`document_impulse`] takes the common
/// case (a slip of normal size) itself, so that its registers stay live.
#[cold]
#[inline(never)]
pub(crate) fn slip_direction<K: Compliance>(
    k: &K,
    n: &Vector3<f64>,
    ut: &Vector3<f64>,
    mu: f64,
) -> Vector3<f64> {
    let len2 = ut.norm_squared();
    if len2 > 1e-200 && len2.is_finite() {
        return ut * (1.0 / len2.sqrt());
    }
    let len = ut.norm();
    if len > 0.0 && len.is_finite() {
        // Rescale before normalising so subnormal slips keep their direction.
        let scaled = ut / ut.amax();
        return scaled / scaled.norm();
    }
    let ck = k.contact_k(n);
    let s: Vector2<f64> = ck.invariant_slip_direction(mu);
    ck.world(&s)
}
