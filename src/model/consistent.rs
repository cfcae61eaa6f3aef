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

use super::collision_matrix::{ContactK, k_form, solve_k};
use super::types::{Body, Contact, Material, Regime};
use nalgebra::{Vector2, Vector3};

/// Local error tolerance of the swerve integration, relative to the initial contact
/// speed. The end state is accurate to about 1e-10 of it.
pub const SWERVE_TOLERANCE: f64 = 1e-10;

/// Which way the impact is going.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Phase {
    Compression,
    /// Restitution until `W` reaches the stored target.
    Restitution {
        target_work: f64,
    },
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
    /// (swerve only) The slip direction stopped turning: continue in closed form.
    DirectionSettled,
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
    // A slip below the swerve's own stop speed has stopped. This is the rounding that
    // u1 - n (n.u1) leaves for an exactly normal approach when n is not a coordinate
    // axis (~1e-16 |u1|); kept, keeps_direction (absolute in |u_t|) would accept its
    // random direction and friction would act along it for the whole impact.
    if state.ut.norm() <= 1e-3 * SWERVE_TOLERANCE * speed {
        state.ut = Vector2::zeros();
    }
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
            Mode::Slip(s) => s == Vector2::zeros() || keeps_direction(&gt, &state.ut, speed),
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
            Event::DirectionSettled => {}
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

/// True when the slip rate `gt` is parallel to the slip `ut` closely enough that
/// treating the slip direction as fixed moves the end state by less than
/// [`SWERVE_TOLERANCE`] times the initial contact speed `speed`: then `u` is linear in
/// `p` until the next event.
fn keeps_direction(gt: &Vector2<f64>, ut: &Vector2<f64>, speed: f64) -> bool {
    let cross = gt.x * ut.y - gt.y * ut.x;
    cross.abs() <= SWERVE_TOLERANCE * speed * gt.norm()
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
            let to_end = if state.un < 0.0 && gn <= 0.0 {
                // A swerve re-compressed the contact (u_n < 0) and u_n is not rising:
                // the impact cannot end in this segment. (The branches below would end
                // it while still approaching, or at x = u_n / -gn < 0, stepping the
                // normal impulse back.) Another event (slip stop, jam) ends the segment.
                f64::INFINITY
            } else if disc >= 0.0 {
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
    // While stuck the slip is zero by definition; adding the rate (zero up to rounding)
    // would leave a slip of 1e-17 whose direction is noise.
    if let Mode::Slip(_) = mode {
        state.ut += gt * dp;
    }
    state.un += gn * dp;
    state.p += dp;
    state.ft += friction * dp;
    Some(event)
}

/// Integrates a swerving slip numerically to its first event. `None` on a jam that
/// does not end (the normal impulse grows without bound).
///
/// The independent variable is not `p` but `tau` with `dp = |u_t| dtau`. In `p` the slip
/// turns at a rate `~1/|u_t|` that grows without bound as the slip dies out; in `tau`
/// the direction obeys an autonomous, smooth flow that settles exponentially onto the
/// invariant direction, and every rate below is Lipschitz:
///
/// ```text
/// du_t/dtau = |u_t| K_tn - mu K_tt u_t      du_n/dtau = |u_t| K_nn - mu K_tn . u_t
/// dW/dtau   = u_n |u_t|                     dF_t/dtau = -mu u_t       dp/dtau = |u_t|
/// ```
fn swerve_segment(
    ck: &ContactK,
    mu: f64,
    state: &mut State,
    phase: Phase,
    speed: f64,
) -> Option<Event> {
    let scale = speed.max(f64::MIN_POSITIVE);
    let (ktt, ktn, knn) = (ck.ktt, ck.ktn, ck.knn);
    let rate = |y: &Y| -> Y {
        let ut = Vector2::new(y[UT1], y[UT2]);
        let rho = ut.norm();
        let dut = ktn * rho - ktt * ut * mu;
        [
            dut.x,
            dut.y,
            rho * knn - mu * ktn.dot(&ut),
            y[UN] * rho,
            -mu * ut.x,
            -mu * ut.y,
            rho,
        ]
    };
    let p_cap = 1e8 * scale / knn;
    let stop_speed = 1e-3 * SWERVE_TOLERANCE * scale;
    let mut y: Y = [
        state.ut.x, state.ut.y, state.un, state.work, state.ft.x, state.ft.y, state.p,
    ];
    let mut k1 = rate(&y);
    // A first step that turns the slip by a fraction of a radian.
    let mut h = 0.05
        / (Vector2::new(k1[UT1], k1[UT2]).norm() / Vector2::new(y[UT1], y[UT2]).norm()).max(1e-300);
    let store = |y: &Y, state: &mut State| {
        state.ut = Vector2::new(y[UT1], y[UT2]);
        state.un = y[UN];
        state.work = y[WORK];
        state.ft = Vector2::new(y[FT1], y[FT2]);
        state.p = y[P];
    };
    for _iter in 0..10_000 {
        let ut = Vector2::new(y[UT1], y[UT2]);
        let gt = Vector2::new(k1[UT1], k1[UT2]);
        // Once the slip has turned onto a direction it keeps (the invariant direction
        // of K), the rest of the segment is linear: hand it back to the closed form.
        if keeps_direction(&gt, &ut, scale) {
            return Some(Event::DirectionSettled);
        }
        if ut.norm() <= stop_speed {
            return Some(Event::SlipStopped);
        }
        if y[P] > p_cap {
            return None;
        }
        let (y_new, err, k7) = dormand_prince_step(&rate, &y, &k1, h);
        let err_norm = err[UT1].hypot(err[UT2]).max(err[UN].abs()) / scale;
        if err_norm > SWERVE_TOLERANCE || err_norm.is_nan() {
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
            Phase::Compression if y_new[UN] >= 0.0 => Some((
                hermite_root(y[UN], k1[UN], y_new[UN], k7[UN], h, 0.0),
                Event::CompressionEnded,
            )),
            Phase::Restitution { target_work } if y_new[WORK] >= target_work => Some((
                hermite_root(y[WORK], k1[WORK], y_new[WORK], k7[WORK], h, target_work),
                Event::Finished,
            )),
            _ => None,
        };
        if let Some((guess, event)) = crossing {
            // The cubic interpolant is only third-order accurate: polish the location
            // by Newton's method on the integrated value itself (each iterate is one
            // step from the start of the accepted step, which is well inside its
            // error control).
            let (index, level) = match phase {
                Phase::Compression => (UN, 0.0),
                Phase::Restitution { target_work } => (WORK, target_work),
            };
            let mut dh = guess;
            let mut y_event = dormand_prince_step(&rate, &y, &k1, dh).0;
            for _ in 0..4 {
                let slope = rate(&y_event)[index];
                if slope <= 0.0 || slope.is_nan() {
                    break;
                }
                let next = (dh - (y_event[index] - level) / slope).clamp(0.0, h);
                if next == dh {
                    break;
                }
                dh = next;
                y_event = dormand_prince_step(&rate, &y, &k1, dh).0;
            }
            store(&y_event, state);
            return Some(event);
        }
        store(&y_new, state);
        y = y_new;
        k1 = k7;
        let grow = if err_norm > 0.0 {
            (0.9 * (SWERVE_TOLERANCE / err_norm).powf(0.2)).clamp(0.2, 5.0)
        } else {
            5.0
        };
        h *= grow;
    }
    None
}

/// The swerve state: tangential slip (2), normal velocity, normal work, friction
/// impulse (2), normal impulse.
type Y = [f64; 7];
const UT1: usize = 0;
const UT2: usize = 1;
const UN: usize = 2;
const WORK: usize = 3;
const FT1: usize = 4;
const FT2: usize = 5;
const P: usize = 6;

/// `y + h * sum(c_i k_i)`.
#[inline]
fn combine(y: &Y, h: f64, ks: &[(&Y, f64)]) -> Y {
    let mut out = *y;
    for (k, c) in ks {
        let hc = h * c;
        for (o, ki) in out.iter_mut().zip(k.iter()) {
            *o += hc * ki;
        }
    }
    out
}

/// One Dormand-Prince 5(4) step (Dormand & Prince 1980; Hairer, Norsett & Wanner,
/// "Solving ODEs I", table II.5.5): the 5th-order solution, the error estimate, and
/// the rate at the new point (first-same-as-last).
fn dormand_prince_step(rate: &impl Fn(&Y) -> Y, y: &Y, k1: &Y, h: f64) -> (Y, Y, Y) {
    let k2 = rate(&combine(y, h, &[(k1, 1.0 / 5.0)]));
    let k3 = rate(&combine(y, h, &[(k1, 3.0 / 40.0), (&k2, 9.0 / 40.0)]));
    let k4 = rate(&combine(
        y,
        h,
        &[(k1, 44.0 / 45.0), (&k2, -56.0 / 15.0), (&k3, 32.0 / 9.0)],
    ));
    let k5 = rate(&combine(
        y,
        h,
        &[
            (k1, 19372.0 / 6561.0),
            (&k2, -25360.0 / 2187.0),
            (&k3, 64448.0 / 6561.0),
            (&k4, -212.0 / 729.0),
        ],
    ));
    let k6 = rate(&combine(
        y,
        h,
        &[
            (k1, 9017.0 / 3168.0),
            (&k2, -355.0 / 33.0),
            (&k3, 46732.0 / 5247.0),
            (&k4, 49.0 / 176.0),
            (&k5, -5103.0 / 18656.0),
        ],
    ));
    let y5 = combine(
        y,
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
    let err = combine(
        &[0.0; 7],
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
/// sticks at once (Genot & Brogliato 1999 show a dynamic jam ends in sticking): the
/// sticking impulse with the restitution lowered, if needed, so that the impact does not
/// gain energy. Where that impulse lies outside the friction cone, friction takes its
/// limit along the sticking impulse's tangential direction (the slip law); where that
/// would jam or gain energy too, the impact is frictionless. Every branch stays in the
/// cone and, for `e <= 1`, dissipates.
fn jam_resolution(
    body: &Body,
    contact: &Contact,
    material: &Material,
    u1: &Vector3<f64>,
) -> (Vector3<f64>, Regime) {
    let n = contact.normal;
    let r = contact.offset;
    let mu = material.friction;
    let un = n.dot(u1);
    let ut = u1 - n * un;
    // Energy of the contact-velocity change: dKE = 1/2 (u2.M u2 - u1.M u1), M = K^-1.
    let m_u1 = solve_k(body, &r, u1);
    let m_n = solve_k(body, &r, &n);
    let budget = u1.dot(&m_u1) / (n.dot(&m_n) * un * un);
    let e = material.restitution.min(budget.max(0.0).sqrt());
    let stick = solve_k(body, &r, &(-(n * ((1.0 + e) * un)) - ut));
    let stick_n = stick.dot(&n);
    let stick_t = stick - n * stick_n;
    if stick_n >= 0.0 && stick_t.norm() <= mu * stick_n {
        return (stick, Regime::Stick);
    }
    // The work of an impulse P at the contact: P.(u1 + u2)/2 with u2 = u1 + K P.
    let gains = |p: &Vector3<f64>| {
        let u2 = u1 + p / body.mass + (body.inv_inertia * r.cross(p)).cross(&r);
        p.dot(&(u1 + u2)) > 0.0 && material.restitution <= 1.0
    };
    let e = material.restitution;
    let len = stick_t.norm();
    if len > 0.0 && mu > 0.0 {
        let along = n + stick_t * (mu / len);
        let denominator = k_form(body, &r, &n, &along);
        if denominator > 0.0 {
            let slip = along * (-(1.0 + e) * un / denominator);
            if !gains(&slip) {
                return (slip, Regime::Slip);
            }
        }
    }
    let frictionless = n * (-(1.0 + e) * un / k_form(body, &r, &n, &n));
    (frictionless, Regime::Slip)
}
