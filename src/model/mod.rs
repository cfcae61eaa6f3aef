//! The impact model: pure `f64` mathematics on nalgebra, with no rapier type.
//!
//! - [`seed`]: the document's law in its own notation (eqs. 1-19), errata fixed.
//! - [`resolve`]: the general form (any inertia tensor, any ground normal, a moving
//!   ground) under one of three [`Law`]s.
//!
//! The derivation, the errata and the laws are in the crate's `docs/model.md`, shown
//! in [`crate::docs::model`].

mod collision_matrix;
mod consistent;
mod document;
mod error;
pub mod seed;
mod types;

pub use consistent::SWERVE_TOLERANCE;
pub use error::ModelError;
pub use types::{Body, BodyVelocity, Contact, Fallback, Impact, Law, Material, Regime};

use nalgebra::Vector3;

/// Size of an energy gain, relative to the impulse times the contact speed
/// (`|P| |u1|`, the scale of the energy exchanged), that `Guarded` treats as real
/// rather than rounding.
pub const ENERGY_GAIN_TOLERANCE: f64 = 1e-12;

/// Resolves one impact of `body`, moving at `velocity`, against the ground at `contact`.
///
/// Returns the impulse, the velocity after and what happened. A contact that does not
/// approach (`n.(v + w × r - u_ground) >= 0`) gets no impulse ([`Regime::Separating`]).
/// Every input is validated first; a bad one is a [`ModelError`] naming it.
///
/// ```
/// use rapier_impact::model::{resolve, Body, BodyVelocity, Contact, Law, Material, Regime};
/// use rapier_impact::na::Vector3;
///
/// // A solid ball (m = 1 kg, R = 0.1 m) lands at 5 m/s sideways, 5 m/s down, on z = 0.
/// let body = Body::isotropic(1.0, 0.4 * 0.1 * 0.1);
/// let contact = Contact::fixed(Vector3::z(), Vector3::new(0.0, 0.0, -0.1));
/// let velocity = BodyVelocity { linear: Vector3::new(5.0, 0.0, -5.0), angular: Vector3::zeros() };
/// let material = Material { restitution: 0.8, friction: 0.5 };
/// let impact = resolve(Law::Guarded, &body, &velocity, &contact, &material).unwrap();
/// assert_eq!(impact.regime, Regime::Stick);
/// // Rolling after the bounce: vx' = vx / (1 + 2/5) (MODEL-NOTES, closed forms).
/// assert!((impact.velocity.linear.x - 5.0 / 1.4).abs() < 1e-12);
/// assert!((impact.velocity.linear.z - 4.0).abs() < 1e-12);
/// ```
pub fn resolve(
    law: Law,
    body: &Body,
    velocity: &BodyVelocity,
    contact: &Contact,
    material: &Material,
) -> Result<Impact, ModelError> {
    // One sum of every input is finite iff all of them are; only when it is not are the
    // fields checked one by one, to name the culprit.
    let sum = velocity.linear.sum()
        + velocity.angular.sum()
        + contact.ground_velocity.sum()
        + contact.offset.sum();
    if !sum.is_finite() {
        error::finite3(&velocity.linear, "velocity.linear")?;
        error::finite3(&velocity.angular, "velocity.angular")?;
    }
    body.validate()?;
    contact.validate()?;
    material.validate()?;
    resolve_unchecked(law, body, velocity, contact, material)
}

/// [`resolve`] without validation, for callers that validated the body, contact and
/// material once (the rapier adapter validates materials when they are set).
pub fn resolve_unchecked(
    law: Law,
    body: &Body,
    velocity: &BodyVelocity,
    contact: &Contact,
    material: &Material,
) -> Result<Impact, ModelError> {
    let n = &contact.normal;
    let r = &contact.offset;
    let u1 = velocity.linear + velocity.angular.cross(r) - contact.ground_velocity;
    let un = n.dot(&u1);
    if !(un < 0.0) {
        let ke = body.kinetic_energy(velocity);
        return Ok(Impact {
            impulse: Vector3::zeros(),
            normal_impulse: 0.0,
            tangent_impulse: Vector3::zeros(),
            velocity: *velocity,
            regime: Regime::Separating,
            law: if law == Law::Consistent {
                Law::Consistent
            } else {
                Law::Document
            },
            fallback: None,
            ke_before: ke,
            ke_after: ke,
        });
    }
    match law {
        Law::Document => {
            let (impulse, regime, _) = document::document_impulse(body, contact, material, &u1)?;
            Ok(finish(
                body,
                velocity,
                &u1,
                contact,
                impulse,
                regime,
                Law::Document,
                None,
            ))
        }
        Law::Consistent => {
            let (impulse, regime) = consistent::consistent_impulse(body, contact, material, &u1);
            Ok(finish(
                body,
                velocity,
                &u1,
                contact,
                impulse,
                regime,
                Law::Consistent,
                None,
            ))
        }
        Law::Guarded => {
            let reason = match document::document_impulse(body, contact, material, &u1) {
                Err(_) => Fallback::Jam,
                Ok((impulse, regime, s)) => {
                    let impact = finish(
                        body,
                        velocity,
                        &u1,
                        contact,
                        impulse,
                        regime,
                        Law::Document,
                        None,
                    );
                    match unphysical(velocity, contact, material, &impact, &s) {
                        None => return Ok(impact),
                        Some(reason) => reason,
                    }
                }
            };
            let (impulse, regime) = consistent::consistent_impulse(body, contact, material, &u1);
            Ok(finish(
                body,
                velocity,
                &u1,
                contact,
                impulse,
                regime,
                Law::Consistent,
                Some(reason),
            ))
        }
    }
}

/// Why the document's result is unphysical, if it is (the `Guarded` law's test).
fn unphysical(
    before: &BodyVelocity,
    contact: &Contact,
    material: &Material,
    impact: &Impact,
    slip: &Vector3<f64>,
) -> Option<Fallback> {
    if impact.normal_impulse < 0.0 {
        return Some(Fallback::PullingNormalImpulse);
    }
    let n = &contact.normal;
    let r = &contact.offset;
    if impact.regime == Regime::Slip && material.friction > 0.0 {
        let after = &impact.velocity;
        let u2 = after.linear + after.angular.cross(r) - contact.ground_velocity;
        let u1 = before.linear + before.angular.cross(r) - contact.ground_velocity;
        let along_after = (u2 - n * n.dot(&u2)).dot(slip);
        if along_after < -1e-12 * u1.norm() {
            return Some(Fallback::SlipReversal);
        }
    }
    if material.restitution <= 1.0 {
        // The work of the impulse in the frame moving with the ground's contact point,
        // where a fixed ground's work-energy balance holds for a translating platform
        // too: dKE = P . (u1 + u2) / 2 with u the relative contact velocities.
        let u1 = before.linear + before.angular.cross(r) - contact.ground_velocity;
        let after = &impact.velocity;
        let u2 = after.linear + after.angular.cross(r) - contact.ground_velocity;
        let gain = 0.5 * impact.impulse.dot(&(u1 + u2));
        if gain > ENERGY_GAIN_TOLERANCE * impact.impulse.norm() * u1.norm() {
            return Some(Fallback::EnergyGain);
        }
    }
    None
}

/// Applies the impulse: `v2 = v1 + P/m`, `w2 = w1 + I_w^-1 (r × P)` (eqs. 4-9).
/// `u1` is the relative contact velocity before the impact.
fn finish(
    body: &Body,
    velocity: &BodyVelocity,
    u1: &Vector3<f64>,
    contact: &Contact,
    impulse: Vector3<f64>,
    regime: Regime,
    law: Law,
    fallback: Option<Fallback>,
) -> Impact {
    let after = BodyVelocity {
        linear: velocity.linear + impulse / body.mass,
        angular: velocity.angular + body.inv_inertia * contact.offset.cross(&impulse),
    };
    let normal_impulse = impulse.dot(&contact.normal);
    // dKE = P . (u_B1 + u_B2) / 2, u_B the body's contact-point velocities: exact for
    // one impulse at r, and free of the cancellation of subtracting two energies.
    let r = &contact.offset;
    let point_velocities = u1 + contact.ground_velocity + after.linear + after.angular.cross(r);
    let ke_before = body.kinetic_energy(velocity);
    Impact {
        impulse,
        normal_impulse,
        tangent_impulse: impulse - contact.normal * normal_impulse,
        velocity: after,
        regime,
        law,
        fallback,
        ke_before,
        ke_after: ke_before + 0.5 * impulse.dot(&point_velocities),
    }
}
