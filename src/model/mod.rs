//! The impact model: pure `f64` mathematics on nalgebra, with no rapier type.
//!
//! - [`seed`]: the document's law in its own notation (eqs. 1-19), errata fixed.
//! - [`resolve`]: the general form (any inertia tensor, any ground normal, a moving
//!   ground) under one of three [`Law`]s.
//! - [`resolve_pair`]: the same laws between two bodies, on the sum of their collision
//!   matrices.
//!
//! The derivation, the errata and the laws are in the crate's `docs/model.md`, shown
//! in [`crate::docs::model`].

mod approx_eq;
mod collision_matrix;
mod consistent;
mod document;
mod error;
mod pair;
mod restitution;
pub mod seed;
mod types;

pub use consistent::SWERVE_TOLERANCE;
pub use error::ModelError;
pub(crate) use error::Shown;
pub use pair::{PairContact, PairImpact, resolve_pair};
pub use restitution::RestitutionCurve;
pub use types::{Body, BodyVelocity, Contact, Fallback, Impact, Law, Material, Regime};

use collision_matrix::OneBody;
use nalgebra::{Matrix3, Vector3};

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
/// let material = Material::new(0.8, 0.5);
/// let impact = resolve(Law::Guarded, &body, &velocity, &contact, &material).unwrap();
/// assert_eq!(impact.regime, Regime::Stick);
/// // Rolling after the bounce: vx' = vx / (1 + 2/5) (`docs/model.md`, closed forms).
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
    let diagonal = off_diagonal_is_zero(&body.inv_inertia);
    if !inputs_plainly_valid(body, velocity, contact, material, diagonal) {
        validate_one_by_one(body, velocity, contact, material)?;
    }
    resolve_classified(law, body, velocity, contact, material, diagonal)
}

/// Runs every check of [`resolve`] one by one, in order, to name the culprit (the
/// cheap sufficient test of [`inputs_plainly_valid`] failed, so some check may fail).
#[cold]
#[inline(never)]
fn validate_one_by_one(
    body: &Body,
    velocity: &BodyVelocity,
    contact: &Contact,
    material: &Material,
) -> Result<(), ModelError> {
    // One sum of the velocities is finite iff all of them are.
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
    material.validate()
}

/// A sufficient condition for every check of [`resolve`] to pass, cheap enough to run
/// on every impact: every input is finite (one sum of all of them is finite iff each
/// is; summed as a tree of 3-vectors, so it takes a few vector additions), `m > 0`,
/// `e, mu >= 0`, a unit normal, and a valid inverse inertia (a diagonal one with a
/// non-negative diagonal, else the full check of [`Body::validate`]). `diagonal` says
/// whether the inverse inertia's off-diagonal entries are all zero.
#[inline(always)]
fn inputs_plainly_valid(
    body: &Body,
    velocity: &BodyVelocity,
    contact: &Contact,
    material: &Material,
    diagonal: bool,
) -> bool {
    let (l, w) = (&velocity.linear, &velocity.angular);
    let (n, o, g) = (&contact.normal, &contact.offset, &contact.ground_velocity);
    let a = &body.inv_inertia;
    let (e, mu, beta) = (
        material.restitution,
        material.friction,
        material.tangential_restitution,
    );
    // Whole 3-vectors (and the tensor's columns), added as a tree.
    let vectors = ((l + w) + (n + o)) + (g + a.column(0));
    let columns = a.column(1) + a.column(2);
    let all = vectors + columns;
    let sum = (all.x + all.y) + (all.z + body.mass) + ((e + mu) + beta);
    if !(sum.is_finite()
        && body.mass > 0.0
        && e >= 0.0
        && mu >= 0.0
        && beta.abs() <= 1.0
        && (n.norm_squared() - 1.0).abs() <= 2e-6)
    {
        return false;
    }
    if diagonal {
        a.m11 >= 0.0 && a.m22 >= 0.0 && a.m33 >= 0.0
    } else {
        body.validate().is_ok()
    }
}

/// [`resolve`] without validation, for callers that validated the body, contact and
/// material once (the rapier adapter validates materials when they are set).
#[inline]
pub fn resolve_unchecked(
    law: Law,
    body: &Body,
    velocity: &BodyVelocity,
    contact: &Contact,
    material: &Material,
) -> Result<Impact, ModelError> {
    let diagonal = off_diagonal_is_zero(&body.inv_inertia);
    resolve_classified(law, body, velocity, contact, material, diagonal)
}

/// [`resolve_unchecked`], told whether the inverse inertia is diagonal.
#[inline(always)]
fn resolve_classified(
    law: Law,
    body: &Body,
    velocity: &BodyVelocity,
    contact: &Contact,
    material: &Material,
    diagonal: bool,
) -> Result<Impact, ModelError> {
    let n = &contact.normal;
    let r = &contact.offset;
    let u1 = velocity.linear + velocity.angular.cross(r) - contact.ground_velocity;
    let un = n.dot(&u1);
    if un >= 0.0 || un.is_nan() {
        return Ok(separating(law, body, velocity));
    }
    let a = &body.inv_inertia;
    if law != Law::Consistent && diagonal && a.m11 == a.m22 && a.m22 == a.m33 && a.m11 > 0.0 {
        // The document's law for a sphere or a cube, with `iso` a constant: its own
        // small code path, where every step is a closed form.
        return resolve_approaching(law, body, Some(a.m11), velocity, contact, material, &u1);
    }
    if law != Law::Consistent && diagonal && a.m11 == 0.0 && a.m22 == 0.0 && a.m33 == 0.0 {
        return resolve_non_rotating(law, body, velocity, contact, material, &u1);
    }
    resolve_general(law, body, velocity, contact, material, &u1)
}

/// A contact that does not approach: no impulse ([`Regime::Separating`]).
#[cold]
#[inline(never)]
fn separating(law: Law, body: &Body, velocity: &BodyVelocity) -> Impact {
    let ke = body.kinetic_energy(velocity);
    Impact {
        impulse: Vector3::zeros(),
        normal_impulse: 0.0,
        tangent_impulse: Vector3::zeros(),
        velocity: *velocity,
        regime: Regime::Separating,
        law: separating_law(law),
        fallback: None,
        ke_before: ke,
        ke_after: ke,
    }
}

/// The document's law for a body that does not rotate (zero inverse inertia): the
/// isotropic closed forms with `a = 0` (`K = E/m`), in a copy of its own so that the
/// sphere's path keeps knowing `a > 0`.
#[inline(never)]
fn resolve_non_rotating(
    law: Law,
    body: &Body,
    velocity: &BodyVelocity,
    contact: &Contact,
    material: &Material,
    u1: &Vector3<f64>,
) -> Result<Impact, ModelError> {
    resolve_approaching(law, body, Some(0.0), velocity, contact, material, u1)
}

/// Every body and law the isotropic path does not take.
#[inline(never)]
fn resolve_general(
    law: Law,
    body: &Body,
    velocity: &BodyVelocity,
    contact: &Contact,
    material: &Material,
    u1: &Vector3<f64>,
) -> Result<Impact, ModelError> {
    let iso = isotropic_inverse_inertia(body);
    resolve_approaching(law, body, iso, velocity, contact, material, u1)
}

/// Resolves an approaching contact (`n.u1 < 0`) under `law`.
#[inline(always)]
fn resolve_approaching(
    law: Law,
    body: &Body,
    iso: Option<f64>,
    velocity: &BodyVelocity,
    contact: &Contact,
    material: &Material,
    u1: &Vector3<f64>,
) -> Result<Impact, ModelError> {
    let u1 = *u1;
    let approach = Approach {
        body,
        iso,
        velocity,
        contact,
        u1,
    };
    let k = OneBody {
        body,
        r: &contact.offset,
        iso,
    };
    let n = &contact.normal;
    match law {
        Law::Document => {
            let (impulse, regime, _) = document::document_impulse(&k, n, material, &u1)?;
            let (impact, _, _) = approach.finish(impulse, regime, Law::Document, None);
            Ok(impact)
        }
        Law::Consistent => Ok(approach.consistent_impact(material, None)),
        Law::Guarded => {
            let reason = match document::document_impulse(&k, n, material, &u1) {
                Err(_) => Fallback::Jam,
                Ok((impulse, regime, s)) => {
                    let (impact, u2, work) = approach.finish(impulse, regime, Law::Document, None);
                    let outcome = DocumentOutcome {
                        impulse: &impact.impulse,
                        normal_impulse: impact.normal_impulse,
                        regime: impact.regime,
                        slip: &s,
                        u1: &u1,
                        u2: &u2,
                        work,
                    };
                    match unphysical(n, material, &outcome) {
                        None => return Ok(impact),
                        Some(reason) => reason,
                    }
                }
            };
            Ok(approach.consistent_impact(material, Some(reason)))
        }
    }
}

/// One body's approach to the ground, all that applying an impulse to it needs: the
/// body, its isotropic inverse inertia `a` if it has one, its velocity, the contact, and
/// the relative contact velocity there, `u1 = v + w × r - u_ground` (`n.u1 < 0`).
struct Approach<'a> {
    body: &'a Body,
    iso: Option<f64>,
    velocity: &'a BodyVelocity,
    contact: &'a Contact,
    u1: Vector3<f64>,
}

impl Approach<'_> {
    /// The consistent law's impact (`fallback` set when `Guarded` fell back to it).
    #[inline(never)]
    fn consistent_impact(&self, material: &Material, fallback: Option<Fallback>) -> Impact {
        let k = OneBody {
            body: self.body,
            r: &self.contact.offset,
            iso: None,
        };
        let (impulse, regime) =
            consistent::consistent_impulse(&k, &self.contact.normal, material, &self.u1);
        self.finish(impulse, regime, Law::Consistent, fallback).0
    }

    /// Applies the impulse: `v2 = v1 + P/m`, `w2 = w1 + I_w^-1 (r × P)` (eqs. 4-9).
    /// Returns the impact (under `law`, its `regime` and `fallback` as given), the
    /// relative contact velocity after it, and the impulse's work `P . (u1 + u2) / 2`.
    #[inline(always)]
    fn finish(
        &self,
        impulse: Vector3<f64>,
        regime: Regime,
        law: Law,
        fallback: Option<Fallback>,
    ) -> (Impact, Vector3<f64>, f64) {
        let (body, iso, velocity, contact, u1) =
            (self.body, self.iso, self.velocity, self.contact, &self.u1);
        let r = &contact.offset;
        let inv_m = 1.0 / body.mass;
        let r_p = r.cross(&impulse);
        let (dw, ke_before) = match iso {
            Some(a) => (
                r_p * a,
                // With a = 0 (a body that does not rotate) the angular velocity carries no
                // energy, as in `Body::kinetic_energy`.
                0.5 * (body.mass * velocity.linear.norm_squared()
                    + if a > 0.0 {
                        velocity.angular.norm_squared() / a
                    } else {
                        0.0
                    }),
            ),
            None => (body.inv_inertia * r_p, body.kinetic_energy(velocity)),
        };
        let dv = impulse * inv_m;
        let after = BodyVelocity {
            linear: velocity.linear + dv,
            angular: velocity.angular + dw,
        };
        let normal_impulse = impulse.dot(&contact.normal);
        // dKE = P . (u_B1 + u_B2) / 2, u_B the body's contact-point velocities: exact for
        // one impulse at r, and free of the cancellation of subtracting two energies. With
        // u_B2 = u_B1 + K P it is P . u_B1 + P . K P / 2, and P . K P = |P|^2/m + (r × P) . dw,
        // a sum of non-negative terms. A spin about a locked axis (`Body::locked_spin`) moves
        // the contact point but holds no energy of the body's: its share of the work,
        // P . (w_locked × r) = (r × P) . w_locked, is left out.
        let mut point_work = impulse.dot(&(u1 + contact.ground_velocity));
        match iso {
            Some(a) if a > 0.0 => {}
            Some(_) => point_work -= r_p.dot(&velocity.angular),
            None => point_work -= r_p.dot(&body.locked_spin(&velocity.angular)),
        }
        let pkp = impulse.dot(&dv) + r_p.dot(&dw);
        let u2 = u1 + dv + dw.cross(r);
        let impact = Impact {
            impulse,
            normal_impulse,
            tangent_impulse: impulse - contact.normal * normal_impulse,
            velocity: after,
            regime,
            law,
            fallback,
            ke_before,
            ke_after: ke_before + (point_work + 0.5 * pkp),
        };
        // The impulse's work in the frame of the ground's contact point: P . (u1 + u2) / 2.
        let work = impulse.dot(u1) + 0.5 * pkp;
        (impact, u2, work)
    }
}

/// The law a separating contact reports under `law`: `Guarded` never names itself.
pub(crate) fn separating_law(law: Law) -> Law {
    if law == Law::Consistent {
        Law::Consistent
    } else {
        Law::Document
    }
}

/// `a` when the inverse inertia tensor is `a E` with `a > 0` (spheres, cubes), the
/// case every step below has a cheaper closed form for.
#[inline]
pub(crate) fn isotropic_inverse_inertia(body: &Body) -> Option<f64> {
    let a = &body.inv_inertia;
    let isotropic = a.m11 == a.m22 && a.m22 == a.m33 && a.m11 > 0.0 && off_diagonal_is_zero(a);
    isotropic.then_some(a.m11)
}

/// True when all six off-diagonal entries are `+0.0` or `-0.0`: their bits, without
/// the sign, are all zero (one test instead of six).
#[inline]
fn off_diagonal_is_zero(a: &Matrix3<f64>) -> bool {
    let bits = a.m12.to_bits()
        | a.m13.to_bits()
        | a.m23.to_bits()
        | a.m21.to_bits()
        | a.m31.to_bits()
        | a.m32.to_bits();
    bits << 1 == 0
}

/// The document's result as the `Guarded` law judges it.
pub(crate) struct DocumentOutcome<'a> {
    /// The impulse (N s).
    pub(crate) impulse: &'a Vector3<f64>,
    /// Its normal part.
    pub(crate) normal_impulse: f64,
    pub(crate) regime: Regime,
    /// The unit slip direction the document used.
    pub(crate) slip: &'a Vector3<f64>,
    /// The relative contact velocity before the impact.
    pub(crate) u1: &'a Vector3<f64>,
    /// The relative contact velocity after it.
    pub(crate) u2: &'a Vector3<f64>,
    /// The impulse's work `P . (u1 + u2) / 2`.
    pub(crate) work: f64,
}

/// Why the document's result `outcome` at the contact of normal `n` is unphysical, if it
/// is (the `Guarded` law's test): a normal impulse that pulls, a slip the friction
/// reverses, or (for `e <= 1`) an energy gain beyond rounding.
pub(crate) fn unphysical(
    n: &Vector3<f64>,
    material: &Material,
    outcome: &DocumentOutcome,
) -> Option<Fallback> {
    let DocumentOutcome {
        impulse,
        normal_impulse,
        regime,
        slip,
        u1,
        u2,
        work,
    } = *outcome;
    if normal_impulse < 0.0 {
        return Some(Fallback::PullingNormalImpulse);
    }
    if regime == Regime::Slip && material.friction > 0.0 {
        // Friction may turn the slip back as far as the tangential restitution gives back
        // (Walton's slip regime: the reversal a grip with beta0 > 0 would have had), no
        // further.
        let along_after = (u2 - n * n.dot(u2)).dot(slip);
        let beta = material.tangential_restitution;
        let given_back = if beta > 0.0 {
            beta * (u1 - n * n.dot(u1)).dot(slip)
        } else {
            0.0
        };
        if along_after < -given_back - 1e-12 * u1.norm() {
            return Some(Fallback::SlipReversal);
        }
    }
    if material.restitution <= 1.0 {
        // The work of the impulse in the frame moving with the ground's contact point,
        // where a fixed ground's work-energy balance holds for a translating platform
        // too: dKE = P . (u1 + u2) / 2 with u the relative contact velocities (`work`).
        if work > ENERGY_GAIN_TOLERANCE * impulse.norm() * u1.norm() {
            return Some(Fallback::EnergyGain);
        }
    }
    None
}
