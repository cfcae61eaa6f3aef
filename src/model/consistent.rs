//! The consistent law: impulse-space integration (Routh's method; Keller 1986;
//! Stronge, "Impact Mechanics", ch. 5) with Stronge's energetic coefficient of
//! restitution.
//!
//! The normal impulse `p` is the independent variable. While the contact slips along
//! the unit tangential slip `s`, the relative contact velocity obeys
//!
//! ```text
//! du/dp = K (n - mu s(u)),           W(p) = ∫ u_n dp  (work of the normal impulse)
//! ```
//!
//! Compression ends where `u_n = 0` (`W = W_c < 0`); restitution ends where the normal
//! impulse has given back `e^2` of the compression work: `W = (1 - e^2) W_c`. When the
//! slip stops, the contact sticks if the friction per unit normal impulse that holds it,
//! `f = -K_tt^-1 K_tn`, is inside the cone (`|f| <= mu`); otherwise it slips again along
//! the invariant direction (see [`ContactK::invariant_slip_direction`]).
//!
//! Whenever the rate `du/dp` keeps the slip direction (stick; planar and symmetric
//! cases; slip from rest along the invariant direction) `u` is linear in `p` and each
//! segment is solved in closed form. Only a swerving slip (3-D coupling) is integrated
//! numerically, by Dormand-Prince 5(4) with a relative tolerance of [`SWERVE_TOLERANCE`]
//! on the contact velocity.

use super::collision_matrix::{ContactK, solve_k};
use super::types::{Body, Contact, Material, Regime};
use nalgebra::{Vector2, Vector3};

/// Local error tolerance of the swerve integration, relative to the initial contact
/// speed. The end state is accurate to about 1e-10 of it.
pub const SWERVE_TOLERANCE: f64 = 1e-12;

/// Which way the impact is going.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Phase {
    Compression,
    /// Restitution until `W` reaches the stored target.
    Restitution { target_work: f64 },
}

/// Integration state, in the contact basis `(t1, t2, n)`.
#[derive(Clone, Copy, Debug)]
struct State {
    /// Tangential relative contact velocity.
    ut: Vector2<f64>,
    /// Normal relative contact velocity.
    un: f64,
    /// Work of the normal impulse so far, `∫ u_n dp` (J).
    work: f64,
    /// Normal impulse so far (N s).
    p: f64,
    /// Friction impulse so far, tangential (N s).
    ft: Vector2<f64>,
}

/// What stopped a segment.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Event {
    SlipStopped,
    CompressionEnded,
    Finished,
}

/// Result of the integration: the impulse on the body (world) and the regime.
pub(crate) fn consistent_impulse(
    body: &Body,
    contact: &Contact,
    material: &Material,
    u1: &Vector3<f64>,
) -> (Vector3<f64>, Regime) {
    let n = contact.normal;
    let ck = ContactK::new(body, &contact.offset, &n);
    let (e, mu) = (material.restitution, material.friction);
    let mut state = State {
        ut: ck.tangential(u1),
        un: n.dot(u1),
        work: 0.0,
        p: 0.0,
        ft: Vector2::zeros(),
    };
    let speed = u1.norm();
    let mut phase = Phase::Compression;
    let started_slipping = state.ut.norm_squared() > 0.0;
    let mut stuck = false;
    let mut stuck_after_slip = false;

    // Every iteration ends one segment at an event; a body goes through at most
    // stop -> (re-slip) -> compression end -> finish, so the cap is generous.
    for _ in 0..16 {
        let mode = if state.ut.norm_squared() == 0.0 {
            let f = ck.sticking_friction_ratio();
            if f.norm() <= mu {
                Mode::Stick(f)
            } else if mu == 0.0 {
                Mode::Slip(Vector2::zeros())
            } else {
                Mode::Slip(ck.invariant_slip_direction(mu))
            }
        } else if mu == 0.0 {
            Mode::Slip(Vector2::zeros())
        } else {
            Mode::Slip(state.ut / state.ut.norm())
        };
        if let Mode::Stick(_) = mode {
            if !stuck && started_slipping {
                stuck_after_slip = true;
            }
            stuck = true;
        }
        let friction = match mode {
            Mode::Stick(f) => f,
            Mode::Slip(s) => -s * mu,
        };
        let (gt, gn) = ck.rate(&friction);
        let direction_kept = match mode {
            Mode::Stick(_) => true,
            Mode::Slip(s) => s == Vector2::zeros() || keeps_direction(&gt, &s),
        };
        let event = if direction_kept {
            match linear_segment(&mut state, phase, gt, gn, friction, mode) {
                Some(ev) => ev,
                None => return jam_resolution(body, contact, material, u1),
            }
        } else {
            match swerve_segment(&ck, mu, &mut state, phase, speed) {
                Some(ev) => ev,
                None => return jam_resolution(body, contact, material, u1),
            }
        };
        match event {
            Event::SlipStopped => state.ut = Vector2::zeros(),
            Event::CompressionEnded => {
                state.un = 0.0;
                if e == 0.0 {
                    break;
                }
                phase = Phase::Restitution {
                    target_work: (1.0 - e * e) * state.work,
                };
            }
            Event::Finished => break,
        }
    }

    let impulse = n * state.p + ck.world(&state.ft);
    let regime = if stuck_after_slip {
        Regime::SlipThenStick
    } else if stuck {
        Regime::Stick
    } else {
        Regime::Slip
    };
    (impulse, regime)
}

#[derive(Clone, Copy, Debug)]
enum Mode {
    /// Friction per unit normal impulse that holds the slip at zero.
    Stick(Vector2<f64>),
    /// Slipping along this unit direction (zero when frictionless).
    Slip(Vector2<f64>),
}

/// True when the slip rate `gt` is parallel to the slip `s`, so that the slip keeps its
/// direction and `u` is linear in `p` until the next event.
fn keeps_direction(gt: &Vector2<f64>, s: &Vector2<f64>) -> bool {
    let cross = gt.x * s.y - gt.y * s.x;
    cross.abs() <= 1e-14 * gt.norm()
}

/// Advances a segment over which `du/dp = (gt, gn)` is constant, to its first event.
/// `None` when the segment never ends (a jam: compression that deepens while the slip
/// does not slow down).
fn linear_segment(
    state: &mut State,
    phase: Phase,
    gt: Vector2<f64>,
    gn: f64,
    friction: Vector2<f64>,
    mode: Mode,
) -> Option<Event> {
    let mut dp = f64::INFINITY;
    let mut event = None;
    if let Mode::Slip(s) = mode {
        let decel = -gt.dot(&s);
        if s != Vector2::zeros() && decel > 0.0 {
            dp = state.ut.norm() / decel;
            event = Some(Event::SlipStopped);
        }
    }
    match phase {
        Phase::Compression => {
            if gn > 0.0 {
                let to_end = -state.un / gn;
                if to_end <= dp {
                    dp = to_end;
                    event = Some(Event::CompressionEnded);
                }
            }
        }
        Phase::Restitution { target_work } => {
            // W(p0 + x) = W0 + u_n x + gn x^2 / 2 = target, smallest x >= 0.
            let rest = (target_work - state.work).max(0.0);
            let disc = state.un * state.un + 2.0 * gn * rest;
            let to_end = if disc >= 0.0 {
                let root = state.un + disc.sqrt();
                if root > 0.0 { 2.0 * rest / root } else { 0.0 }
            } else {
                // u_n falls back to zero before the work is given back: the contact
                // stops separating there, which ends the impact.
                state.un / -gn
            };
            if to_end <= dp {
                dp = to_end;
                event = Some(Event::Finished);
            }
        }
    }
    let event = event?;
    state.work += state.un * dp + 0.5 * gn * dp * dp;
    state.ut += gt * dp;
    state.un += gn * dp;
    state.p += dp;
    state.ft += friction * dp;
    Some(event)
}

/// Integrates a swerving slip numerically to its first event. `None` on a jam that
/// does not end (the normal impulse grows without bound).
fn swerve_segment(ck: &ContactK, mu: f64, state: &mut State, phase: Phase, speed: f64) -> Option<Event> {
    let scale = speed.max(f64::MIN_POSITIVE);
    let rate = |y: &Y| -> Y {
        let len = y.ut.norm();
        let s = if len > 0.0 { y.ut / len } else { Vector2::zeros() };
        let f = -s * mu;
        let (gt, gn) = ck.rate(&f);
        Y {
            ut: gt,
            un: gn,
            work: y.un,
            ft: f,
        }
    };
    let p_scale = scale / ck.knn;
    let mut h = 0.05 * p_scale;
    let p_cap = 1e8 * p_scale;
    let stop_speed = 1e-13 * scale;
    let mut y = Y::from(state);
    let mut k1 = rate(&y);
    for _ in 0..100_000 {
        if state.p > p_cap {
            return None;
        }
        // Do not step past the point where the slip would stop at its current rate:
        // the rate is discontinuous there.
        let slip = y.ut.norm();
        let decel = -k1.ut.dot(&(y.ut / slip));
        if decel > 0.0 {
            h = h.min(0.9 * slip / decel);
        }
        let (y_new, err, k7) = dormand_prince_step(&rate, &y, &k1, h);
        let err_norm = (err.ut.norm().max(err.un.abs())) / scale;
        if !(err_norm <= SWERVE_TOLERANCE) {
            let factor = if err_norm.is_finite() {
                (0.9 * (SWERVE_TOLERANCE / err_norm).powf(0.2)).clamp(0.1, 0.9)
            } else {
                0.1
            };
            h *= factor;
            continue;
        }
        // Events inside the accepted step, located on the cubic Hermite interpolant.
        let crossing = match phase {
            Phase::Compression if y_new.un >= 0.0 => Some((
                hermite_root(y.un, k1.un, y_new.un, k7.un, h, 0.0),
                Event::CompressionEnded,
            )),
            Phase::Restitution { target_work } if y_new.work >= target_work => Some((
                hermite_root(y.work, k1.work, y_new.work, k7.work, h, target_work),
                Event::Finished,
            )),
            _ => None,
        };
        if let Some((dh, event)) = crossing {
            let (y_event, _, _) = dormand_prince_step(&rate, &y, &k1, dh);
            y_event.store(state, state.p + dh);
            return Some(event);
        }
        y_new.store(state, state.p + h);
        y = y_new;
        k1 = k7;
        if y.ut.norm() <= stop_speed {
            return Some(Event::SlipStopped);
        }
        let grow = if err_norm > 0.0 {
            (0.9 * (SWERVE_TOLERANCE / err_norm).powf(0.2)).clamp(0.2, 5.0)
        } else {
            5.0
        };
        h *= grow;
    }
    None
}

/// The integrated quantities of the swerve ODE.
#[derive(Clone, Copy, Debug)]
struct Y {
    ut: Vector2<f64>,
    un: f64,
    work: f64,
    ft: Vector2<f64>,
}

impl Y {
    fn from(s: &State) -> Self {
        Self {
            ut: s.ut,
            un: s.un,
            work: s.work,
            ft: s.ft,
        }
    }
    fn store(&self, s: &mut State, p: f64) {
        s.ut = self.ut;
        s.un = self.un;
        s.work = self.work;
        s.ft = self.ft;
        s.p = p;
    }
    fn axpy(&self, a: f64, k: &Y) -> Y {
        Y {
            ut: self.ut + k.ut * a,
            un: self.un + k.un * a,
            work: self.work + k.work * a,
            ft: self.ft + k.ft * a,
        }
    }
    fn combine(&self, h: f64, ks: &[(&Y, f64)]) -> Y {
        let mut out = *self;
        for (k, c) in ks {
            out = out.axpy(h * c, k);
        }
        out
    }
}

/// One Dormand-Prince 5(4) step (Dormand & Prince 1980, Hairer-Norsett-Wanner table
/// II.5.5): the 5th-order solution, the error estimate, and the rate at the new point
/// (first-same-as-last).
fn dormand_prince_step(rate: &impl Fn(&Y) -> Y, y: &Y, k1: &Y, h: f64) -> (Y, Y, Y) {
    let k2 = rate(&y.combine(h, &[(k1, 1.0 / 5.0)]));
    let k3 = rate(&y.combine(h, &[(k1, 3.0 / 40.0), (&k2, 9.0 / 40.0)]));
    let k4 = rate(&y.combine(h, &[(k1, 44.0 / 45.0), (&k2, -56.0 / 15.0), (&k3, 32.0 / 9.0)]));
    let k5 = rate(&y.combine(
        h,
        &[
            (k1, 19372.0 / 6561.0),
            (&k2, -25360.0 / 2187.0),
            (&k3, 64448.0 / 6561.0),
            (&k4, -212.0 / 729.0),
        ],
    ));
    let k6 = rate(&y.combine(
        h,
        &[
            (k1, 9017.0 / 3168.0),
            (&k2, -355.0 / 33.0),
            (&k3, 46732.0 / 5247.0),
            (&k4, 49.0 / 176.0),
            (&k5, -5103.0 / 18656.0),
        ],
    ));
    let y5 = y.combine(
        h,
        &[
            (k1, 35.0 / 384.0),
            (&k3, 500.0 / 1113.0),
            (&k4, 125.0 / 192.0),
            (&k5, -2187.0 / 6784.0),
            (&k6, 11.0 / 84.0),
        ],
    );
    let k7 = rate(&y5);
    // Difference between the 5th- and 4th-order weights.
    let zero = Y {
        ut: Vector2::zeros(),
        un: 0.0,
        work: 0.0,
        ft: Vector2::zeros(),
    };
    let err = zero.combine(
        h,
        &[
            (k1, 71.0 / 57600.0),
            (&k3, -71.0 / 16695.0),
            (&k4, 71.0 / 1920.0),
            (&k5, -17253.0 / 339200.0),
            (&k6, 22.0 / 525.0),
            (&k7, -1.0 / 40.0),
        ],
    );
    (y5, err, k7)
}

/// The offset `x` in `[0, h]` where the cubic Hermite interpolant through
/// `(0, a, da)` and `(h, b, db)` reaches `level` (`a < level <= b`), by bisection.
fn hermite_root(a: f64, da: f64, b: f64, db: f64, h: f64, level: f64) -> f64 {
    let value = |x: f64| {
        let t = x / h;
        let (t2, t3) = (t * t, t * t * t);
        (2.0 * t3 - 3.0 * t2 + 1.0) * a
            + (t3 - 2.0 * t2 + t) * h * da
            + (-2.0 * t3 + 3.0 * t2) * b
            + (t3 - t2) * h * db
            - level
    };
    let (mut lo, mut hi) = (0.0, h);
    for _ in 0..60 {
        let mid = 0.5 * (lo + hi);
        if value(mid) < 0.0 {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    hi
}

/// A jam that impulse-space integration cannot end (Painleve's paradox: the normal
/// impulse would grow without bound). Resolved as an impulsive tangential impact that
/// sticks at once: the sticking impulse with the restitution lowered, if needed, so the
/// impact does not gain energy (Genot & Brogliato 1999 show a dynamic jam ends in
/// sticking).
fn jam_resolution(body: &Body, contact: &Contact, material: &Material, u1: &Vector3<f64>) -> (Vector3<f64>, Regime) {
    let n = contact.normal;
    let r = contact.offset;
    let un = n.dot(u1);
    let ut = u1 - n * un;
    // Energy of the contact-velocity change: dKE = 1/2 (u2.M u2 - u1.M u1), M = K^-1.
    let m_u1 = solve_k(body, &r, u1);
    let m_n = solve_k(body, &r, &n);
    let budget = u1.dot(&m_u1) / (n.dot(&m_n) * un * un);
    let e = material.restitution.min(budget.max(0.0).sqrt());
    let impulse = solve_k(body, &r, &(-(n * ((1.0 + e) * un)) - ut));
    (impulse, Regime::Stick)
}
