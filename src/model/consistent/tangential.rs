//! Walton's tangential restitution `beta0` on the consistent law's impulse.
//!
//! Reads: the compliance `K`, the normal, the material, the approach velocity `u1` and the
//! impulse `P_c` and regime the Coulomb integration (`mod.rs`) gave. Returns the impulse and
//! regime with the tangential restitution applied. Never leaves the friction cone and, for
//! `e <= 1`, never makes the impulse's work positive (no energy gain).
//!
//! A contact that grips ends the Coulomb integration with zero slip. Tangential compliance
//! gives some of that motion back (Maw, Barber & Fawcett, Wear 38, 1976): in Walton's model
//! the contact leaves with the tangential velocity `u_t2 = -beta0 u_t1` when the friction
//! cone allows it. From `P_c`, whose contact velocity after is `u_c`, the impulse moves along
//!
//! ```text
//! dP = K^-1 (-beta0 u_t1 - u_ct),      P = P_c + lambda dP,
//! ```
//!
//! which takes the tangential contact velocity to the target and leaves the normal one as it
//! was, as far as `lambda` in `[0, 1]` may go: `P` stays in the cone `|P_t| <= mu P_n`, and
//! for `e <= 1` the work `W(P) = P.u1 + P.K P / 2` stays `<= 0`. Each condition holds on an
//! interval of `lambda` containing 0 (the cone is convex and holds `P_c`; `W` is a convex
//! quadratic in `lambda` and `W(P_c) <= 0`), so `lambda` is the end of their intersection,
//! in closed form.
//!
//! It applies where Walton's sticking impulse could be the answer: the contact gripped
//! during the impact (`Stick`, `SlipThenStick`), or, for `beta0 < 0`, it slipped throughout
//! but Coulomb friction took more tangential velocity than the target leaves
//! (`u_ct . u_t1 < -beta0 |u_t1|^2`). A contact that slips throughout with `beta0 > 0`
//! slips as in Coulomb's law, as Walton's model says.
//!
//! For a sphere struck along a radius (`K` diagonal in the contact frame) the result is
//! Walton's exactly: the target when `(1 + beta0) |u_t1| / K_tt <= mu P_n`, else the slip
//! impulse `P_n (n - mu s)` (the cone's edge along the slip), so the consistent law and the
//! document's form agree there as they do with `beta0 = 0`.

use crate::model::collision_matrix::Compliance;
use crate::model::types::{Material, Regime};
use nalgebra::Vector3;

/// The impulse and regime of the Coulomb integration (`impulse`, `regime`), with Walton's
/// tangential restitution applied (see the module's contract).
pub(super) fn rebound<K: Compliance>(
    k: &K,
    n: &Vector3<f64>,
    material: &Material,
    u1: &Vector3<f64>,
    impulse: Vector3<f64>,
    regime: Regime,
) -> (Vector3<f64>, Regime) {
    let (e, mu, beta) = (
        material.restitution,
        material.friction,
        material.tangential_restitution,
    );
    let ut1 = u1 - n * n.dot(u1);
    let uc = u1 + k.apply(&impulse);
    let uct = uc - n * n.dot(&uc);
    let target = -ut1 * beta;
    let gripped = regime != Regime::Slip;
    let over_slowed = beta < 0.0 && uct.dot(&ut1) < target.dot(&ut1);
    if mu == 0.0 || !(gripped || over_slowed) {
        return (impulse, regime);
    }
    let du = target - uct;
    let dp = k.solve(&du);
    let cone = cone_limit(n, mu, &impulse, &dp);
    let energy = if e <= 1.0 {
        let work = impulse.dot(u1) + 0.5 * impulse.dot(&(uc - u1));
        work_limit(work, dp.dot(&uc), dp.dot(&du))
    } else {
        1.0
    };
    let lambda = cone.min(energy);
    if lambda <= 0.0 {
        return (impulse, regime);
    }
    let regime = if cone < 1.0 && cone <= energy {
        // Friction at the cone's edge: the contact slips (Walton's second regime).
        Regime::Slip
    } else if regime == Regime::Slip {
        Regime::Stick
    } else {
        regime
    };
    (impulse + dp * lambda, regime)
}

/// The largest `lambda` in `[0, 1]` for which `P + lambda dP` is in the friction cone of
/// normal `n` and coefficient `mu > 0`, given `P` in it (to rounding).
fn cone_limit(n: &Vector3<f64>, mu: f64, p: &Vector3<f64>, dp: &Vector3<f64>) -> f64 {
    let (pn, dpn) = (n.dot(p), n.dot(dp));
    let (pt, dpt) = (p - n * pn, dp - n * dpn);
    let end = p + dp;
    let end_n = n.dot(&end);
    if (end - n * end_n).norm() <= mu * end_n {
        return 1.0;
    }
    // |P_t(l)|^2 - mu^2 P_n(l)^2 = a l^2 + b l + c: the line leaves the cone at a root.
    let mu2 = mu * mu;
    let a = dpt.norm_squared() - mu2 * dpn * dpn;
    let b = 2.0 * (pt.dot(&dpt) - mu2 * pn * dpn);
    let c = pt.norm_squared() - mu2 * pn * pn;
    let exit = if a == 0.0 {
        if b > 0.0 { -c / b } else { 1.0 }
    } else {
        let disc = b * b - 4.0 * a * c;
        if disc < 0.0 {
            // No crossing: the whole line is on one side; P is inside, so all of it is.
            1.0
        } else {
            // The two roots without cancellation; inside is between them when a > 0
            // (the exit is the larger), outside between them when a < 0 (the smaller).
            let q = -0.5 * (b + b.signum() * disc.sqrt());
            let (r1, r2) = if q == 0.0 { (0.0, 0.0) } else { (q / a, c / q) };
            let (lo, hi) = if r1 <= r2 { (r1, r2) } else { (r2, r1) };
            if a > 0.0 { hi } else { lo }
        }
    };
    exit.clamp(0.0, 1.0)
}

/// The largest `lambda` in `[0, 1]` with `W(lambda) = w0 + a lambda + b lambda^2 / 2 <= 0`,
/// given `w0 <= 0` (0 when `w0 > 0`: the start already gains, by rounding) and `b >= 0`.
fn work_limit(w0: f64, a: f64, b: f64) -> f64 {
    if w0 > 0.0 {
        return 0.0;
    }
    if w0 + a + 0.5 * b <= 0.0 {
        return 1.0;
    }
    // The positive root of b l^2 / 2 + a l + w0 = 0, written without cancellation.
    let disc = (a * a - 2.0 * b * w0).sqrt();
    let root = if a >= 0.0 {
        -2.0 * w0 / (a + disc)
    } else {
        (disc - a) / b
    };
    root.clamp(0.0, 1.0)
}
