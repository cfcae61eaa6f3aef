//! Impacts between two bodies under the same laws as on ground (`docs/model.md`, "Two
//! bodies"): an impulse `P` on body `a` at the contact, `-P` on body `b`, changes the
//! relative contact velocity `u = u_a - u_b` (each body's material point at the contact)
//! by `du = (K_a + K_b) P`, with each body's `K` as in eqs. (4)-(9) at its own offset. The
//! laws see nothing but `K` and `u`, so the document's law (eqs. 10-19, errata fixed), the
//! consistent one and the guard between them apply unchanged on the sum.
//!
//! Seen from body `a`, body `b` is a ground that yields: the problem is solved in `a`'s
//! ground form, with the ground's normal `-normal` (from `b` into `a`). Against a fixed `b`
//! ([`Body::fixed`]) that is [`super::resolve`]'s problem exactly.

use super::collision_matrix::{Compliance, OneBody, TwoBodies};
use super::error::{ModelError, finite3};
use super::types::{Body, BodyVelocity, Fallback, Law, Material, Regime};
use super::{
    DocumentOutcome, consistent, document, isotropic_inverse_inertia, separating_law, unphysical,
};
use nalgebra::Vector3;

/// The contact between two bodies `a` and `b`, world frame.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(
    feature = "serde-serialize",
    derive(serde::Serialize, serde::Deserialize)
)]
pub struct PairContact {
    /// Unit normal, pointing from body `a` towards body `b`.
    pub normal: Vector3<f64>,
    /// The contact point minus `a`'s centre of mass (m).
    pub offset_a: Vector3<f64>,
    /// The contact point minus `b`'s centre of mass (m).
    pub offset_b: Vector3<f64>,
}

impl PairContact {
    /// Checks the vectors are finite and the normal has unit length (to 1e-6).
    pub fn validate(&self) -> Result<(), ModelError> {
        finite3(&self.normal, "contact.normal")?;
        finite3(&self.offset_a, "contact.offset_a")?;
        finite3(&self.offset_b, "contact.offset_b")?;
        let len2 = self.normal.norm_squared();
        if (len2 - 1.0).abs() > 2e-6 {
            return Err(ModelError::NonUnitNormal(len2.sqrt()));
        }
        Ok(())
    }
}

/// A resolved impact between two bodies.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(
    feature = "serde-serialize",
    derive(serde::Serialize, serde::Deserialize)
)]
pub struct PairImpact {
    /// Impulse on body `b` at the contact, world frame (N s); `a` receives `-impulse`.
    pub impulse: Vector3<f64>,
    /// Normal impulse `impulse.normal >= 0` (N s): it pushes `b` away from `a`.
    pub normal_impulse: f64,
    /// Tangential (friction) part of `impulse` (N s).
    pub tangent_impulse: Vector3<f64>,
    /// Velocity of body `a` after the impact.
    pub a: BodyVelocity,
    /// Velocity of body `b` after the impact.
    pub b: BodyVelocity,
    /// Stick, slip, or the sequence of the two; `Separating` when not approaching.
    pub regime: Regime,
    /// The law that produced this result (`Document` or `Consistent`; never `Guarded`).
    pub law: Law,
    /// Set when `Guarded` fell back to `Consistent`, with the reason.
    pub fallback: Option<Fallback>,
    /// Kinetic energy of both bodies before the impact (J; a fixed body counts none).
    pub ke_before: f64,
    /// Kinetic energy of both bodies after the impact (J).
    pub ke_after: f64,
}

impl PairImpact {
    /// `ke_after - ke_before` (J): negative when the impact dissipates energy.
    pub fn energy_change(&self) -> f64 {
        self.ke_after - self.ke_before
    }
}

/// Resolves one impact between body `a`, moving at `va`, and body `b`, moving at `vb`, at
/// `contact`, under `law`, on the collision matrix `K = K_a + K_b`.
///
/// The bodies approach when the relative contact velocity (`a`'s contact point minus
/// `b`'s) has a positive component along `contact.normal`; otherwise there is no impulse
/// ([`Regime::Separating`]). Either body may be [`Body::fixed`] (a wall, a kinematic
/// platform moving at its velocity), not both. Every input is validated first; a bad one
/// is a [`ModelError`] naming it (`a.mass`, `vb.angular`, `contact.offset_a`, ...).
///
/// ```
/// use rapier_impact::model::{resolve_pair, Body, BodyVelocity, Law, Material, PairContact};
/// use rapier_impact::na::Vector3;
///
/// // Two equal pool balls (m = 0.17 kg, R = 28.6 mm), head-on at 2 m/s, e = 0.95.
/// let (m, r) = (0.17, 0.0286);
/// let ball = Body::isotropic(m, 0.4 * m * r * r);
/// let va = BodyVelocity { linear: Vector3::new(2.0, 0.0, 0.0), angular: Vector3::zeros() };
/// let contact = PairContact {
///     normal: Vector3::x(),
///     offset_a: Vector3::new(r, 0.0, 0.0),
///     offset_b: Vector3::new(-r, 0.0, 0.0),
/// };
/// let material = Material::new(0.95, 0.05);
/// let hit = resolve_pair(Law::Guarded, &ball, &va, &ball, &BodyVelocity::default(), &contact, &material).unwrap();
/// // Equal masses head-on: v_a' = v (1 - e) / 2, v_b' = v (1 + e) / 2.
/// assert!((hit.a.linear.x - 2.0 * 0.05 / 2.0).abs() < 1e-12);
/// assert!((hit.b.linear.x - 2.0 * 1.95 / 2.0).abs() < 1e-12);
/// ```
pub fn resolve_pair(
    law: Law,
    a: &Body,
    va: &BodyVelocity,
    b: &Body,
    vb: &BodyVelocity,
    contact: &PairContact,
    material: &Material,
) -> Result<PairImpact, ModelError> {
    validate(a, va, b, vb, contact, material)?;
    // `a`'s ground form: the ground (`b`) normal points from `b` into `a`.
    let n = -contact.normal;
    let (ra, rb) = (&contact.offset_a, &contact.offset_b);
    let u1 = point_velocity(va, ra) - point_velocity(vb, rb);
    let un = n.dot(&u1);
    if un >= 0.0 || un.is_nan() {
        let ke = a.kinetic_energy(va) + b.kinetic_energy(vb);
        return Ok(PairImpact {
            impulse: Vector3::zeros(),
            normal_impulse: 0.0,
            tangent_impulse: Vector3::zeros(),
            a: *va,
            b: *vb,
            regime: Regime::Separating,
            law: separating_law(law),
            fallback: None,
            ke_before: ke,
            ke_after: ke,
        });
    }
    // The isotropic closed forms where `resolve` takes them (not under `Consistent`).
    let iso = |body: &Body| {
        if law == Law::Consistent {
            None
        } else {
            isotropic_inverse_inertia(body)
        }
    };
    let k = TwoBodies {
        a: OneBody {
            body: a,
            r: ra,
            iso: iso(a),
        },
        b: OneBody {
            body: b,
            r: rb,
            iso: iso(b),
        },
    };
    let side = Sides {
        a,
        va,
        b,
        vb,
        k: &k,
    };
    let consistent = |fallback| {
        let consistent_k = TwoBodies {
            a: OneBody { iso: None, ..k.a },
            b: OneBody { iso: None, ..k.b },
        };
        let (p, regime) = consistent::consistent_impulse(&consistent_k, &n, material, &u1);
        side.finish(&n, &u1, p, regime, Law::Consistent, fallback).0
    };
    match law {
        Law::Document => {
            let (p, regime, _) = document::document_impulse(&k, &n, material, &u1)?;
            Ok(side.finish(&n, &u1, p, regime, Law::Document, None).0)
        }
        Law::Consistent => Ok(consistent(None)),
        Law::Guarded => {
            let reason = match document::document_impulse(&k, &n, material, &u1) {
                Err(_) => Fallback::Jam,
                Ok((p, regime, s)) => {
                    let (impact, u2, work) = side.finish(&n, &u1, p, regime, Law::Document, None);
                    let pn = p.dot(&n);
                    let outcome = DocumentOutcome {
                        impulse: &p,
                        normal_impulse: pn,
                        regime,
                        slip: &s,
                        u1: &u1,
                        u2: &u2,
                        work,
                    };
                    match unphysical(&n, material, &outcome) {
                        None => return Ok(impact),
                        Some(reason) => reason,
                    }
                }
            };
            Ok(consistent(Some(reason)))
        }
    }
}

/// The velocity of a body's material point at `offset` from its centre of mass.
fn point_velocity(v: &BodyVelocity, offset: &Vector3<f64>) -> Vector3<f64> {
    v.linear + v.angular.cross(offset)
}

/// The two bodies of an impact and their compliance, for applying its impulse.
struct Sides<'a> {
    a: &'a Body,
    va: &'a BodyVelocity,
    b: &'a Body,
    vb: &'a BodyVelocity,
    k: &'a TwoBodies<'a>,
}

impl Sides<'_> {
    /// Applies `p` to `a` and `-p` to `b` at their offsets (eqs. 4-9 for each body), with
    /// ground-form normal `n` and relative contact velocity `u1`. Returns the impact, the
    /// relative contact velocity after it and the impulse's work `P . (u1 + u2) / 2`.
    fn finish(
        &self,
        n: &Vector3<f64>,
        u1: &Vector3<f64>,
        p: Vector3<f64>,
        regime: Regime,
        law: Law,
        fallback: Option<Fallback>,
    ) -> (PairImpact, Vector3<f64>, f64) {
        let (ka, kb) = (&self.k.a, &self.k.b);
        let (ra_p, rb_p) = (ka.r.cross(&p), kb.r.cross(&p));
        let (dva, dwa) = (p / self.a.mass, self.a.inv_inertia * ra_p);
        let (dvb, dwb) = (-p / self.b.mass, -(self.b.inv_inertia * rb_p));
        let after_a = BodyVelocity {
            linear: self.va.linear + dva,
            angular: self.va.angular + dwa,
        };
        let after_b = BodyVelocity {
            linear: self.vb.linear + dvb,
            angular: self.vb.angular + dwb,
        };
        // Each body's energy change is P . (its contact point's velocity) + P.K P / 2 with
        // its own K (a sum of non-negative terms): exact for one impulse, and free of the
        // cancellation of subtracting energies. A fixed body's is none. A spin about a
        // locked axis holds none of the body's energy (`Body::locked_spin`): its share,
        // (r × P) . w_locked, is left out, as for one body and the ground.
        let gain = |body: &Body, v: &BodyVelocity, r: &Vector3<f64>, q: &Vector3<f64>| {
            if body.is_fixed() {
                0.0
            } else {
                let rq = r.cross(q);
                q.dot(&point_velocity(v, r)) - rq.dot(&body.locked_spin(&v.angular))
                    + 0.5 * (q.norm_squared() / body.mass + rq.dot(&(body.inv_inertia * rq)))
            }
        };
        let ke_before = self.a.kinetic_energy(self.va) + self.b.kinetic_energy(self.vb);
        let ke_after =
            ke_before + gain(self.a, self.va, ka.r, &p) + gain(self.b, self.vb, kb.r, &-p);
        let du = self.k.apply(&p);
        let u2 = u1 + du;
        let work = p.dot(u1) + 0.5 * p.dot(&du);
        // On `b`: `-p`, whose component along the pair normal `-n` is `p.n`.
        let normal_impulse = p.dot(n);
        let impulse = -p;
        let impact = PairImpact {
            impulse,
            normal_impulse,
            tangent_impulse: impulse + n * normal_impulse,
            a: after_a,
            b: after_b,
            regime,
            law,
            fallback,
            ke_before,
            ke_after,
        };
        (impact, u2, work)
    }
}

/// Every check of [`resolve_pair`], in order, naming the culprit.
fn validate(
    a: &Body,
    va: &BodyVelocity,
    b: &Body,
    vb: &BodyVelocity,
    contact: &PairContact,
    material: &Material,
) -> Result<(), ModelError> {
    finite3(&va.linear, "va.linear")?;
    finite3(&va.angular, "va.angular")?;
    finite3(&vb.linear, "vb.linear")?;
    finite3(&vb.angular, "vb.angular")?;
    if a.is_fixed() && b.is_fixed() {
        return Err(ModelError::BothFixed);
    }
    if !a.is_fixed() {
        a.validate()
            .map_err(|e| named(e, "a.mass", "a.inv_inertia"))?;
    }
    if !b.is_fixed() {
        b.validate()
            .map_err(|e| named(e, "b.mass", "b.inv_inertia"))?;
    }
    contact.validate()?;
    material.validate()
}

/// `Body::validate`'s error, naming which body's field.
fn named(e: ModelError, mass: &'static str, inv_inertia: &'static str) -> ModelError {
    match e {
        ModelError::NotFinite { what: "body.mass" } => ModelError::NotFinite { what: mass },
        ModelError::NotFinite {
            what: "body.inv_inertia",
        } => ModelError::NotFinite { what: inv_inertia },
        other => other,
    }
}
