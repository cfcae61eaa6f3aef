//! A jam the impulse-space integration cannot end, resolved as an impulsive impact that
//! sticks at once, within the friction cone and without gaining energy.

use crate::model::collision_matrix::Compliance;
use crate::model::types::{Material, Regime};
use nalgebra::Vector3;

/// A jam that impulse-space integration cannot end (Painleve's paradox: the normal
/// impulse would grow without bound). Resolved as an impulsive tangential impact that
/// sticks at once (Genot & Brogliato 1999 show a dynamic jam ends in sticking): the
/// sticking impulse with the restitution lowered, if needed, so that the impact does not
/// gain energy. Where that impulse lies outside the friction cone, friction takes its
/// limit along the sticking impulse's tangential direction (the slip law); where that
/// would jam or gain energy too, the impact is frictionless. Every branch stays in the
/// cone and, for `e <= 1`, dissipates.
pub(super) fn jam_resolution<K: Compliance>(
    k: &K,
    n: Vector3<f64>,
    material: &Material,
    u1: &Vector3<f64>,
) -> (Vector3<f64>, Regime) {
    let mu = material.friction;
    let un = n.dot(u1);
    let ut = u1 - n * un;
    // Energy of the contact-velocity change: dKE = 1/2 (u2.M u2 - u1.M u1), M = K^-1.
    let m_u1 = k.solve(u1);
    let m_n = k.solve(&n);
    let budget = u1.dot(&m_u1) / (n.dot(&m_n) * un * un);
    let e = material.restitution.min(budget.max(0.0).sqrt());
    let stick = k.solve(&(-(n * ((1.0 + e) * un)) - ut));
    let stick_n = stick.dot(&n);
    let stick_t = stick - n * stick_n;
    if stick_n >= 0.0 && stick_t.norm() <= mu * stick_n {
        return (stick, Regime::Stick);
    }
    // The work of an impulse P at the contact: P.(u1 + u2)/2 with u2 = u1 + K P.
    let gains = |p: &Vector3<f64>| {
        let u2 = u1 + k.apply(p);
        p.dot(&(u1 + u2)) > 0.0 && material.restitution <= 1.0
    };
    let e = material.restitution;
    let len = stick_t.norm();
    if len > 0.0 && mu > 0.0 {
        let along = n + stick_t * (mu / len);
        let denominator = k.k_form(&n, &along);
        if denominator > 0.0 {
            let slip = along * (-(1.0 + e) * un / denominator);
            if !gains(&slip) {
                return (slip, Regime::Slip);
            }
        }
    }
    let frictionless = n * (-(1.0 + e) * un / k.k_form(&n, &n));
    (frictionless, Regime::Slip)
}
