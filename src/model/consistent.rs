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
//! numerically, by Dormand and Prince's 8th-order method (DOP853) with a relative
//! tolerance of [`SWERVE_TOLERANCE`] on the contact velocity.

use super::collision_matrix::{Compliance, ContactK};
use super::types::{Material, Regime};
use nalgebra::{Vector2, Vector3};

/// Local error tolerance of the swerve integration, relative to the initial contact
/// speed; also the bound on the error of handing a settled slip direction back to the
/// closed form. The end state is accurate to about this, relative: against an
/// independent fixed-step RK4 reference the impulse agrees to 3.2e-11
/// (`tests/model_swerve_accuracy.rs`).
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
pub(crate) fn consistent_impulse<K: Compliance>(
    k: &K,
    n: &Vector3<f64>,
    material: &Material,
    u1: &Vector3<f64>,
) -> (Vector3<f64>, Regime) {
    let n = *n;
    let ck = k.contact_k(&n);
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
    // Set once a swerve has settled onto a stable invariant direction (by its own,
    // sharper test); the slip then keeps that direction until it stops.
    let mut settled = false;
    // The last accepted swerve step, when the swerve goes on from compression into
    // restitution: the flow is the same, only the event changes.
    let mut step_hint = None;

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
            Mode::Slip(s) => {
                s == Vector2::zeros() || settled || keeps_direction(&gt, &state.ut, speed)
            }
        };
        let event = if direction_kept {
            step_hint = None;
            match linear_segment(&mut state, phase, gt, gn, friction, mode) {
                Some(ev) => ev,
                None => return jam_resolution(k, &n, material, u1),
            }
        } else {
            match swerve_segment(&ck, mu, &mut state, phase, speed, &mut step_hint) {
                Some(ev) => ev,
                None => return jam_resolution(k, &n, material, u1),
            }
        };
        match event {
            Event::SlipStopped => {
                state.ut = Vector2::zeros();
                settled = false;
            }
            Event::DirectionSettled => settled = true,
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
/// invariant direction, and every rate below is Lipschitz.
///
/// The contact velocity is linear in the impulse, `u = u_0 + K (dp n + dF_t)`, so the
/// integrated state is only the impulse and the work, `z = (dp, dF_t, dW)` counted from
/// the segment's start, and `u_t`, `u_n` are evaluated from it exactly:
///
/// ```text
/// dp/dtau = |u_t|      dF_t/dtau = -mu u_t      dW/dtau = u_n |u_t|
/// u_t = u_t0 + K_tn dp + K_tt dF_t              u_n = u_n0 + K_nn dp + K_tn . dF_t
/// ```
///
/// The error of a step is measured on `u_t` and `u_n` (the image of the impulse error
/// under `K`), as the tolerance is stated on the contact velocity.
///
/// Events (compression's end `u_n = 0`, restitution's `W = (1 - e^2) W_c`) are
/// anticipated: when the event's quadratic Taylor polynomial reaches zero within the
/// next step, one classic RK4 step and a Newton step predict where, the DOP853 step is
/// shortened to end at 99 % of that, and a closing RK4 step over the rest (at most
/// 0.02 of the flow's time scale, its distance again from the quadratic polynomial)
/// and a Newton correction land on the event. A step that crosses an event anyway is
/// thrown away and the event located on its dense output (below).
fn swerve_segment(
    ck: &ContactK,
    mu: f64,
    state: &mut State,
    phase: Phase,
    speed: f64,
    step_hint: &mut Option<f64>,
) -> Option<Event> {
    let scale = speed.max(f64::MIN_POSITIVE);
    let flow = Flow {
        ut0: state.ut,
        un0: state.un,
        k11: ck.ktt.m11,
        k12: ck.ktt.m12,
        k22: ck.ktt.m22,
        ktn: ck.ktn,
        knn: ck.knn,
        mu,
    };
    let p_cap = 1e8 * scale / ck.knn;
    let stop_speed = 1e-3 * SWERVE_TOLERANCE * scale;
    let mut z: Z = [0.0; 4];
    let mut k1 = flow.rate(&z);
    // A first step of a fraction of the flow's fastest time scale (the direction turns
    // and the slip decays at rates of order |K_tn| + mu |K_tt|). Half of it: with a
    // quarter the first step's error was ~1e-15..1e-14, far under the tolerance, and
    // the controller spent a step catching up; with three quarters the swerve test's
    // end error doubled (the first step then uses the whole tolerance).
    let turn = flow.ktn.norm() + mu * (flow.k11.abs() + flow.k22.abs() + 2.0 * flow.k12.abs());
    let mut h = step_hint.take().unwrap_or(0.5 / turn.max(1e-300));
    // Bounds the rate of u_n per unit slip: |du_n/dtau| <= |u_t| (K_nn + mu |K_tn|).
    let normal_rates = flow.knn + mu * flow.ktn.norm();
    let store = |z: &Z, state: &mut State| {
        let (ut, un) = flow.velocity(z);
        state.ut = ut;
        state.un = un;
        state.work += z[DW];
        state.ft += Vector2::new(z[DF1], z[DF2]);
        state.p += z[DP];
    };
    for _iter in 0..10_000 {
        let (ut, _) = flow.velocity(&z);
        // Once the slip has turned onto a direction it keeps (the invariant direction
        // of K), the rest of the segment is linear: hand it back to the closed form.
        if let Some(turn) = flow.settled(&ut, scale) {
            // Onto the invariant direction itself, so that the closed form's constant
            // rate is parallel to the slip (the rotation moves u_t by less than the
            // tolerance).
            store(&z, state);
            let (sin, cos) = crate::math::sin_cos(turn);
            state.ut = Vector2::new(cos * ut.x - sin * ut.y, sin * ut.x + cos * ut.y);
            return Some(Event::DirectionSettled);
        }
        if keeps_direction(&flow.slip_rate(&ut), &ut, scale) {
            store(&z, state);
            return Some(Event::DirectionSettled);
        }
        let rho = ut.norm();
        if rho <= stop_speed {
            store(&z, state);
            return Some(Event::SlipStopped);
        }
        if state.p + z[DP] > p_cap {
            return None;
        }
        // An event within reach of this step: predict where, and shorten the step to
        // end just before it, so that a short closing step can reach it (below)
        // instead of a step past it being thrown away.
        let mut landing = false;
        let h_planned = h;
        let (g, g_rate) = event_value(&flow, phase, state, &z, &k1);
        // |d^2 g/dtau^2| is at most |u_t| times the rates' scale squared: when even that
        // bound cannot bring the event within the step (a distant event, a dying slip),
        // the second derivative is not computed.
        let curve_bound = rho
            * match phase {
                Phase::Compression => turn * normal_rates,
                Phase::Restitution { .. } => rho * normal_rates + flow.velocity(&z).1.abs() * turn,
            };
        let quadratic = if -g <= h * g_rate.max(0.0) + 0.5 * h * h * curve_bound {
            // The first zero of the event's quadratic Taylor polynomial.
            let g_curve = event_curve(&flow, phase, &z, &k1);
            let disc = g_rate * g_rate - 2.0 * g_curve * g;
            if disc >= 0.0 && g_rate + disc.sqrt() > 0.0 {
                -2.0 * g / (g_rate + disc.sqrt())
            } else {
                f64::INFINITY
            }
        } else {
            f64::INFINITY
        };
        if quadratic <= h {
            // One classic RK4 step to that guess, then a Newton step from there.
            let guess = quadratic;
            let z_guess = rk4_step(&flow, &z, &k1, guess);
            let k_guess = flow.rate(&z_guess);
            let (g1, g1_rate) = event_value(&flow, phase, state, &z_guess, &k_guess);
            let predicted = guess - g1 / g1_rate;
            if g1_rate > 0.0 && predicted > 0.0 && LANDING * predicted <= h {
                h = LANDING * predicted;
                landing = true;
            }
        }
        let (z_new, err5, err3, k_new, k) = dop853_step(&flow, &z, &k1, h);
        // Hairer's DOP853 error estimate from the 5th- and 3rd-order embedded pairs.
        let e5 = flow.error_size(&err5) / scale;
        let e3 = flow.error_size(&err3) / scale;
        let denominator = (e5 * e5 + 0.01 * e3 * e3).sqrt();
        let err_norm = if denominator > 0.0 {
            h * e5 * e5 / denominator
        } else {
            0.0
        };
        if err_norm > SWERVE_TOLERANCE || err_norm.is_nan() {
            let factor = if err_norm.is_finite() {
                (0.9 * eighth_root(SWERVE_TOLERANCE / err_norm)).clamp(0.1, 0.9)
            } else {
                0.1
            };
            h *= factor;
            continue;
        }
        let grow = if err_norm > 0.0 {
            (0.9 * eighth_root(SWERVE_TOLERANCE / err_norm)).clamp(0.333, 6.0)
        } else {
            6.0
        };
        // Events inside the accepted step (not anticipated above), located on DOP853's
        // 7th-order dense output (Hairer's contd8: three more stages), by Newton's
        // method on its polynomial.
        let un_new = flow.velocity(&z_new).1;
        let event = match phase {
            Phase::Compression if un_new >= 0.0 => Some(Event::CompressionEnded),
            Phase::Restitution { target_work } if state.work + z_new[DW] >= target_work => {
                Some(Event::Finished)
            }
            _ => None,
        };
        if let Some(event) = event {
            let dense = Dense::new(&flow, &z, &z_new, &k, &k_new, h);
            // The event's value as a polynomial in the step fraction x, zero at the event:
            // u_n (linear in z) or the work given back so far minus its target.
            let (base, coefficients) = match phase {
                Phase::Compression => {
                    let un = |c: &Z| flow.knn * c[DP] + flow.ktn.x * c[DF1] + flow.ktn.y * c[DF2];
                    (flow.velocity(&z).1, dense.f.map(|c| un(&c)))
                }
                Phase::Restitution { target_work } => {
                    (z[DW] - (target_work - state.work), dense.f.map(|c| c[DW]))
                }
            };
            let dh = h * dense_root(base, &coefficients);
            // The dense output is an order less accurate than a step: take one step to
            // the located point, then one Newton correction on the integrated value
            // itself, along the rate there (its shift is of the dense output's error,
            // ~1e-10 of the step, so the neglected curvature is ~1e-20 of it).
            let mut z_event = dop853_step(&flow, &z, &k1, dh).0;
            let (v, slope) = match phase {
                Phase::Compression => (flow.velocity(&z_event).1, flow.normal_rate(&z_event)),
                Phase::Restitution { target_work } => (
                    z_event[DW] - (target_work - state.work),
                    flow.rate(&z_event)[DW],
                ),
            };
            if slope > 0.0 && slope.is_finite() {
                let shift = (-v / slope).clamp(-dh, h - dh);
                let rate = flow.rate(&z_event);
                for (zi, ri) in z_event.iter_mut().zip(rate) {
                    *zi += ri * shift;
                }
            }
            store(&z_event, state);
            if event == Event::CompressionEnded {
                // Restitution goes on along the same flow: start it with this step.
                *step_hint = Some(h);
            }
            return Some(event);
        }
        if landing {
            let (g, g_rate) = event_value(&flow, phase, state, &z_new, &k_new);
            // The distance to the event from its quadratic Taylor polynomial: what is
            // left after the closing step (the cubic term, ~1e-4 of the distance) is
            // then small enough for a first-order Newton correction.
            let g_curve = event_curve(&flow, phase, &z_new, &k_new);
            let disc = g_rate * g_rate - 2.0 * g_curve * g;
            let rest = if disc >= 0.0 && g_rate + disc.sqrt() > 0.0 {
                -2.0 * g / (g_rate + disc.sqrt())
            } else {
                f64::INFINITY
            };
            if g_rate > 0.0 && rest >= 0.0 && rest * turn <= CLOSING_REACH {
                // The closing step: classic RK4 over `rest` (its local error is of order
                // (rest L)^5 / 120 ~ 3e-11 for rates of the flow's scale L; on the swerve
                // tests it agrees with a DOP853 step over `rest` to ~1e-15 of the speed),
                // then one Newton correction on the event's value along the rate there
                // (of ~1e-4 of `rest`, so its neglected curvature is ~1e-8 of that).
                let mut z_event = rk4_step(&flow, &z_new, &k_new, rest);
                let k_event = flow.rate(&z_event);
                let (g, g_rate) = event_value(&flow, phase, state, &z_event, &k_event);
                if g_rate > 0.0 && g_rate.is_finite() {
                    let shift = -g / g_rate;
                    for (zi, ri) in z_event.iter_mut().zip(k_event) {
                        *zi += ri * shift;
                    }
                }
                store(&z_event, state);
                let event = match phase {
                    Phase::Compression => Event::CompressionEnded,
                    Phase::Restitution { .. } => Event::Finished,
                };
                if event == Event::CompressionEnded {
                    *step_hint = Some(h_planned);
                }
                return Some(event);
            }
        }
        z = z_new;
        k1 = k_new;
        h = if landing { h_planned } else { h * grow };
    }
    None
}

/// How far (in `tau` times the flow's rate scale) the closing step of an event may
/// reach: classic RK4's local error there is of order `0.02^5 / 120 = 3e-11`.
const CLOSING_REACH: f64 = 0.02;

/// Where the step before an event aims, as a fraction of the predicted distance: short
/// of it, so that the prediction's error (RK4 over the distance, then Newton) leaves the
/// event after the step's end and within the closing step's reach.
const LANDING: f64 = 0.99;

/// The event's value `g` (negative before it, zero at it) and its rate `dg/dtau` at the
/// state `z` with rate `k`: `u_n` in compression, the work still to give back (negated)
/// in restitution.
#[inline(always)]
fn event_value(flow: &Flow, phase: Phase, state: &State, z: &Z, k: &Z) -> (f64, f64) {
    match phase {
        Phase::Compression => (
            flow.velocity(z).1,
            flow.knn * k[DP] + flow.ktn.x * k[DF1] + flow.ktn.y * k[DF2],
        ),
        Phase::Restitution { target_work } => (z[DW] - (target_work - state.work), k[DW]),
    }
}

/// The event's second derivative `d^2 g/dtau^2` at `z` (rate `k` there).
#[inline(always)]
fn event_curve(flow: &Flow, phase: Phase, z: &Z, k: &Z) -> f64 {
    let (ut, un) = flow.velocity(z);
    let rho = ut.norm();
    // du_t/dtau = K_tn dp/dtau + K_tt dF/dtau, and likewise u_n; d|u_t|/dtau = s.du_t/dtau.
    let dut = Vector2::new(
        flow.ktn.x * k[DP] + flow.k11 * k[DF1] + flow.k12 * k[DF2],
        flow.ktn.y * k[DP] + flow.k12 * k[DF1] + flow.k22 * k[DF2],
    );
    let dun = flow.knn * k[DP] + flow.ktn.x * k[DF1] + flow.ktn.y * k[DF2];
    let drho = if rho > 0.0 { ut.dot(&dut) / rho } else { 0.0 };
    match phase {
        // d^2 u_n/dtau^2 = K_nn d^2p/dtau^2 + K_tn . d^2F/dtau^2, d^2F/dtau^2 = -mu du_t/dtau.
        Phase::Compression => flow.knn * drho - flow.mu * flow.ktn.dot(&dut),
        // d^2 W/dtau^2 = d(u_n |u_t|)/dtau.
        Phase::Restitution { .. } => dun * rho + un * drho,
    }
}

/// One step of the classic fourth-order Runge-Kutta method of the swerve flow from `z`
/// (rate `k1` there) over `h`.
#[inline(always)]
fn rk4_step(flow: &Flow, z: &Z, k1: &Z, h: f64) -> Z {
    let at = |k: &Z, c: f64| {
        let mut out = *z;
        for (o, ki) in out.iter_mut().zip(k) {
            *o += c * h * ki;
        }
        out
    };
    let k2 = flow.rate(&at(k1, 0.5));
    let k3 = flow.rate(&at(&k2, 0.5));
    let k4 = flow.rate(&at(&k3, 1.0));
    let mut out = *z;
    for j in 0..4 {
        out[j] += h / 6.0 * (k1[j] + 2.0 * (k2[j] + k3[j]) + k4[j]);
    }
    out
}

/// `x^(1/8)` by three square roots (the step-size controller's exponent; far cheaper
/// than `powf`).
#[inline(always)]
fn eighth_root(x: f64) -> f64 {
    x.sqrt().sqrt().sqrt()
}

/// The swerve state, counted from the segment's start: normal impulse, friction
/// impulse (2), normal work.
type Z = [f64; 4];
const DP: usize = 0;
const DF1: usize = 1;
const DF2: usize = 2;
const DW: usize = 3;

/// The swerving slip's flow in `tau` (see [`swerve_segment`]), in the contact basis.
struct Flow {
    ut0: Vector2<f64>,
    un0: f64,
    k11: f64,
    k12: f64,
    k22: f64,
    ktn: Vector2<f64>,
    knn: f64,
    mu: f64,
}

impl Flow {
    /// The contact velocity `(u_t, u_n)` after the impulse increment `z`.
    #[inline(always)]
    fn velocity(&self, z: &Z) -> (Vector2<f64>, f64) {
        let (p, f1, f2) = (z[DP], z[DF1], z[DF2]);
        let ut = Vector2::new(
            self.ut0.x + self.ktn.x * p + self.k11 * f1 + self.k12 * f2,
            self.ut0.y + self.ktn.y * p + self.k12 * f1 + self.k22 * f2,
        );
        let un = self.un0 + self.knn * p + self.ktn.x * f1 + self.ktn.y * f2;
        (ut, un)
    }

    /// `dz/dtau`.
    #[inline(always)]
    fn rate(&self, z: &Z) -> Z {
        let (ut, un) = self.velocity(z);
        let rho = (ut.x * ut.x + ut.y * ut.y).sqrt();
        [rho, -self.mu * ut.x, -self.mu * ut.y, un * rho]
    }

    /// `du_t/dtau = |u_t| K_tn - mu K_tt u_t`.
    #[inline(always)]
    fn slip_rate(&self, ut: &Vector2<f64>) -> Vector2<f64> {
        let rho = ut.norm();
        Vector2::new(
            rho * self.ktn.x - self.mu * (self.k11 * ut.x + self.k12 * ut.y),
            rho * self.ktn.y - self.mu * (self.k12 * ut.x + self.k22 * ut.y),
        )
    }

    /// True when the slip `u_t` is so close to a stable invariant direction that
    /// following that direction in closed form moves the end state by less than
    /// [`SWERVE_TOLERANCE`] times `speed`.
    ///
    /// With `u_t = rho (cos phi, sin phi)` the direction obeys `dphi/dtau = G(phi)` and
    /// the slip `d ln rho/dtau = H(phi)`, where, with `s = (cos, sin)`, `s' = (-sin, cos)`,
    /// `G = s'.(K_tn - mu K_tt s)` and `H = s.(K_tn - mu K_tt s)`. Near a stable root
    /// `phi*` of `G` (`lambda = -G'(phi*) > 0`) the angle still to turn is
    /// `theta = G/lambda` (a Newton step), it decays like `exp(-lambda tau)` while the
    /// slip grows like `exp(H tau)`, so the slip that still turns integrates to at most
    /// `rho theta L/(lambda - H)` on the contact velocity, `L = |K_tn| + mu |K_tt|`
    /// bounding every rate. That bound, with a factor 2 to spare, is the test; it
    /// requires `lambda > H` (the turning part of the slip dies out). Near a strongly
    /// attracting direction it settles at once where the sine of the angle between the
    /// slip and its rate, which the stiff flow keeps near rounding times
    /// `lambda/|H|`, would not.
    ///
    /// Returns the angle to turn `u_t` by to reach that direction.
    #[inline]
    fn settled(&self, ut: &Vector2<f64>, speed: f64) -> Option<f64> {
        let rho = ut.norm();
        if rho == 0.0 {
            return None;
        }
        let s = ut / rho;
        let sp = Vector2::new(-s.y, s.x);
        let ks = Vector2::new(
            self.k11 * s.x + self.k12 * s.y,
            self.k12 * s.x + self.k22 * s.y,
        );
        let ksp = Vector2::new(
            self.k11 * sp.x + self.k12 * sp.y,
            self.k12 * sp.x + self.k22 * sp.y,
        );
        let g = sp.dot(&self.ktn) - self.mu * sp.dot(&ks);
        let h = s.dot(&self.ktn) - self.mu * s.dot(&ks);
        // dG/dphi = -s.K_tn + mu (s.K_tt s - s'.K_tt s').
        let lambda = s.dot(&self.ktn) - self.mu * (s.dot(&ks) - sp.dot(&ksp));
        if lambda <= h.max(0.0) {
            return None;
        }
        let turn = g / lambda;
        let theta = turn.abs();
        let rates =
            self.ktn.norm() + self.mu * (self.k11.abs() + self.k22.abs() + 2.0 * self.k12.abs());
        (theta <= 1e-3 && 2.0 * rho * theta * rates <= SWERVE_TOLERANCE * speed * (lambda - h))
            .then_some(turn)
    }

    /// `du_n/dtau = |u_t| K_nn - mu K_tn . u_t`.
    #[inline(always)]
    fn normal_rate(&self, z: &Z) -> f64 {
        let (ut, _) = self.velocity(z);
        ut.norm() * self.knn - self.mu * self.ktn.dot(&ut)
    }

    /// Size of an impulse error on the contact velocity: `max(|K_t e|, |K_n e|)`.
    #[inline(always)]
    fn error_size(&self, e: &Z) -> f64 {
        let (p, f1, f2) = (e[DP], e[DF1], e[DF2]);
        let et1 = self.ktn.x * p + self.k11 * f1 + self.k12 * f2;
        let et2 = self.ktn.y * p + self.k12 * f1 + self.k22 * f2;
        let en = self.knn * p + self.ktn.x * f1 + self.ktn.y * f2;
        (et1 * et1 + et2 * et2).sqrt().max(en.abs())
    }
}

/// `z + h * sum(c_i k_i)` over the stages `i` listed with their coefficients `c_i` (the
/// step's twelve, or the dense output's sixteen).
#[inline(always)]
fn stage<const N: usize, const M: usize>(z: &Z, h: f64, c: &[(usize, f64); N], k: &[Z; M]) -> Z {
    let mut out = *z;
    for j in 0..4 {
        let mut acc = 0.0;
        for &(i, ci) in c {
            acc += ci * k[i][j];
        }
        out[j] += h * acc;
    }
    out
}

/// One step of Dormand and Prince's 8th-order method with 5th- and 3rd-order error
/// estimates (DOP853: Hairer, Norsett & Wanner, "Solving ODEs I", 2nd ed., II.10;
/// coefficients of Hairer's `dop853`). Returns the 8th-order solution, the 5th- and
/// 3rd-order error vectors (without the factor `h`, as in Hairer's estimate), and the
/// rate at the new point, and the twelve stages (for the dense output).
#[inline(always)]
fn dop853_step(flow: &Flow, z: &Z, k1: &Z, h: f64) -> (Z, Z, Z, Z, [Z; 12]) {
    let mut k = [[0.0; 4]; 12];
    k[0] = *k1;
    k[1] = flow.rate(&stage(z, h, &A2, &k));
    k[2] = flow.rate(&stage(z, h, &A3, &k));
    k[3] = flow.rate(&stage(z, h, &A4, &k));
    k[4] = flow.rate(&stage(z, h, &A5, &k));
    k[5] = flow.rate(&stage(z, h, &A6, &k));
    k[6] = flow.rate(&stage(z, h, &A7, &k));
    k[7] = flow.rate(&stage(z, h, &A8, &k));
    k[8] = flow.rate(&stage(z, h, &A9, &k));
    k[9] = flow.rate(&stage(z, h, &A10, &k));
    k[10] = flow.rate(&stage(z, h, &A11, &k));
    k[11] = flow.rate(&stage(z, h, &A12, &k));
    let z_new = stage(z, h, &B, &k);
    let err5 = stage(&[0.0; 4], 1.0, &E5, &k);
    let err3 = stage(&[0.0; 4], 1.0, &E3, &k);
    let k_new = flow.rate(&z_new);
    (z_new, err5, err3, k_new, k)
}

/// DOP853's dense output over one accepted step from `z` (Hairer's contd8): with
/// `x` the fraction of the step, `z(x) = z + x (f0 + (1-x) (f1 + x (f2 + (1-x) (f3 +
/// x (f4 + (1-x) (f5 + x f6))))))`, of order 7.
struct Dense {
    f: [Z; 7],
}

impl Dense {
    fn new(flow: &Flow, z: &Z, z_new: &Z, k: &[Z; 12], k_new: &Z, h: f64) -> Self {
        let mut ext = [[0.0; 4]; 16];
        ext[..12].copy_from_slice(k);
        ext[12] = *k_new;
        ext[13] = flow.rate(&stage(z, h, &A14, &ext));
        ext[14] = flow.rate(&stage(z, h, &A15, &ext));
        ext[15] = flow.rate(&stage(z, h, &A16, &ext));
        let mut f = [[0.0; 4]; 7];
        for j in 0..4 {
            let dz = z_new[j] - z[j];
            f[0][j] = dz;
            f[1][j] = h * ext[0][j] - dz;
            f[2][j] = 2.0 * dz - h * (ext[0][j] + ext[12][j]);
            for (row, d) in [&D4[..], &D5[..], &D6[..], &D7[..]].iter().enumerate() {
                let mut acc = 0.0;
                for &(i, c) in d.iter() {
                    acc += c * ext[i][j];
                }
                f[3 + row][j] = h * acc;
            }
        }
        Self { f }
    }
}

/// The dense-output polynomial with coefficients `f` at `x`, and its derivative in `x`.
#[inline(always)]
fn dense_value(f: &[f64; 7], x: f64) -> (f64, f64) {
    let x1 = 1.0 - x;
    // Horner from the inside out, alternating factors x and 1 - x, with the derivative.
    let (mut y, mut dy) = (f[6] * x, f[6]);
    for (i, &c) in f[..6].iter().enumerate().rev() {
        y += c;
        if i % 2 == 1 {
            (y, dy) = (y * x1, dy * x1 - y);
        } else {
            (y, dy) = (y * x, dy * x + y);
        }
    }
    (y, dy)
}

/// The fraction `x` in `[0, 1]` of the step where `base + p(x)` crosses zero upwards,
/// with `p` the dense-output polynomial with coefficients `f` (`base < 0 <= base +
/// p(1)`): Newton's method, safeguarded by bisection on the bracket.
fn dense_root(base: f64, f: &[f64; 7]) -> f64 {
    let (mut lo, mut hi) = (0.0f64, 1.0f64);
    // The secant through the ends as the first guess.
    let end = base + dense_value(f, 1.0).0;
    let mut x = if end > base {
        -base / (end - base)
    } else {
        1.0
    };
    for _ in 0..60 {
        let (p, dp) = dense_value(f, x);
        let v = base + p;
        if v < 0.0 {
            lo = x;
        } else {
            hi = x;
        }
        let newton = if dp > 0.0 { x - v / dp } else { f64::NAN };
        // Converged when Newton's step is at rounding level. Tested before the bracket:
        // at the root the step is a few ulps and may land on the bracket's end just
        // moved to x, where bisecting would throw the converged x away.
        if (newton - x).abs() <= 1e-15 {
            return newton.clamp(lo, hi);
        }
        let next = if newton > lo && newton < hi {
            newton
        } else {
            0.5 * (lo + hi)
        };
        if hi - lo <= 1e-15 {
            return next;
        }
        x = next;
    }
    hi
}

// DOP853 tableau (Hairer's dop853.f, to double precision), nonzero entries only as
// (stage, coefficient): the rows of A (stages 2-12), the weights B, and the error
// weights E5 = b - b5, E3 = b - b3.
const A2: [(usize, f64); 1] = [(0, 0.05260015195876773)];
const A3: [(usize, f64); 2] = [(0, 0.0197250569845379), (1, 0.0591751709536137)];
const A4: [(usize, f64); 2] = [(0, 0.02958758547680685), (2, 0.08876275643042054)];
const A5: [(usize, f64); 3] = [
    (0, 0.2413651341592667),
    (2, -0.8845494793282861),
    (3, 0.924834003261792),
];
const A6: [(usize, f64); 3] = [
    (0, 0.037037037037037035),
    (3, 0.17082860872947386),
    (4, 0.12546768756682242),
];
const A7: [(usize, f64); 4] = [
    (0, 0.037109375),
    (3, 0.17025221101954405),
    (4, 0.06021653898045596),
    (5, -0.017578125),
];
const A8: [(usize, f64); 5] = [
    (0, 0.03709200011850479),
    (3, 0.17038392571223998),
    (4, 0.10726203044637328),
    (5, -0.015319437748624402),
    (6, 0.008273789163814023),
];
const A9: [(usize, f64); 6] = [
    (0, 0.6241109587160757),
    (3, -3.3608926294469414),
    (4, -0.868219346841726),
    (5, 27.59209969944671),
    (6, 20.154067550477894),
    (7, -43.48988418106996),
];
const A10: [(usize, f64); 7] = [
    (0, 0.47766253643826434),
    (3, -2.4881146199716677),
    (4, -0.590290826836843),
    (5, 21.230051448181193),
    (6, 15.279233632882423),
    (7, -33.28821096898486),
    (8, -0.020331201708508627),
];
const A11: [(usize, f64); 8] = [
    (0, -0.9371424300859873),
    (3, 5.186372428844064),
    (4, 1.0914373489967295),
    (5, -8.149787010746927),
    (6, -18.52006565999696),
    (7, 22.739487099350505),
    (8, 2.4936055526796523),
    (9, -3.0467644718982196),
];
const A12: [(usize, f64); 9] = [
    (0, 2.273310147516538),
    (3, -10.53449546673725),
    (4, -2.0008720582248625),
    (5, -17.9589318631188),
    (6, 27.94888452941996),
    (7, -2.8589982771350235),
    (8, -8.87285693353063),
    (9, 12.360567175794303),
    (10, 0.6433927460157636),
];
const B: [(usize, f64); 8] = [
    (0, 0.054293734116568765),
    (5, 4.450312892752409),
    (6, 1.8915178993145003),
    (7, -5.801203960010585),
    (8, 0.3111643669578199),
    (9, -0.1521609496625161),
    (10, 0.20136540080403034),
    (11, 0.04471061572777259),
];
const E5: [(usize, f64); 8] = [
    (0, 0.01312004499419488),
    (5, -1.2251564463762044),
    (6, -0.4957589496572502),
    (7, 1.6643771824549864),
    (8, -0.35032884874997366),
    (9, 0.3341791187130175),
    (10, 0.08192320648511571),
    (11, -0.022355307863886294),
];
const E3: [(usize, f64); 8] = [
    (0, -0.18980075407240762),
    (5, 4.450312892752409),
    (6, 1.8915178993145003),
    (7, -5.801203960010585),
    (8, -0.42268232132379197),
    (9, -0.1521609496625161),
    (10, 0.20136540080403034),
    (11, 0.022651792198360825),
];

// DOP853's dense output (Hairer's dop853.f, contd8): the three extra stages 14-16
// (rows of A, over the twelve stages and the rate at the step's end, stage 13), and
// the coefficients d4-d7 of the interpolant.
const A14: [(usize, f64); 8] = [
    (0, 5.616750228304795e-2),
    (6, 2.535002102166248e-1),
    (7, -2.462390374708025e-1),
    (8, -1.2419142326381637e-1),
    (9, 1.532917982787657e-1),
    (10, 8.20105229563469e-3),
    (11, 7.5678976605457e-3),
    (12, -8.298e-3),
];
const A15: [(usize, f64); 8] = [
    (0, 3.183464816350214e-2),
    (5, 2.8300909672366776e-2),
    (6, 5.354198830743857e-2),
    (7, -5.492374857139099e-2),
    (10, -1.0834732869724932e-4),
    (11, 3.825710908356584e-4),
    (12, -3.4046500868740456e-4),
    (13, 1.413124436746325e-1),
];
const A16: [(usize, f64); 8] = [
    (0, -4.288963015837919e-1),
    (5, -4.697621415361164),
    (6, 7.683421196062599),
    (7, 4.06898981839711),
    (8, 3.567271874552811e-1),
    (12, -1.3990241651590146e-3),
    (13, 2.9475147891527723),
    (14, -9.15095847217987),
];
const D4: [(usize, f64); 12] = [
    (0, -8.428938276109013),
    (5, 5.667149535193778e-1),
    (6, -3.0689499459498917),
    (7, 2.38466765651207),
    (8, 2.1170345824450283),
    (9, -8.71391583777973e-1),
    (10, 2.2404374302607883),
    (11, 6.315787787694688e-1),
    (12, -8.899033645133331e-2),
    (13, 18.148505520854727),
    (14, -9.194632392478356),
    (15, -4.436036387594894),
];
const D5: [(usize, f64); 12] = [
    (0, 10.427508642579134),
    (5, 242.28349177525817),
    (6, 165.20045171727028),
    (7, -374.5467547226902),
    (8, -22.113666853125306),
    (9, 7.733432668472264),
    (10, -30.674084731089398),
    (11, -9.332130526430229),
    (12, 15.697238121770845),
    (13, -31.139403219565178),
    (14, -9.35292435884448),
    (15, 35.81684148639408),
];
const D6: [(usize, f64); 12] = [
    (0, 19.985053242002433),
    (5, -387.0373087493518),
    (6, -189.17813819516758),
    (7, 527.8081592054236),
    (8, -11.573902539959631),
    (9, 6.8812326946963),
    (10, -1.0006050966910838),
    (11, 7.777137798053443e-1),
    (12, -2.778205752353508),
    (13, -60.19669523126412),
    (14, 84.32040550667716),
    (15, 11.99229113618279),
];
const D7: [(usize, f64); 12] = [
    (0, -25.69393346270375),
    (5, -154.18974869023643),
    (6, -231.5293791760455),
    (7, 357.6391179106141),
    (8, 93.40532418362432),
    (9, -37.45832313645163),
    (10, 104.09964950896231),
    (11, 29.840293426660504),
    (12, -43.53345659001114),
    (13, 96.32455395918828),
    (14, -39.17726167561544),
    (15, -149.72683625798564),
];

/// A jam that impulse-space integration cannot end (Painleve's paradox: the normal
/// impulse would grow without bound). Resolved as an impulsive tangential impact that
/// sticks at once (Genot & Brogliato 1999 show a dynamic jam ends in sticking): the
/// sticking impulse with the restitution lowered, if needed, so that the impact does not
/// gain energy. Where that impulse lies outside the friction cone, friction takes its
/// limit along the sticking impulse's tangential direction (the slip law); where that
/// would jam or gain energy too, the impact is frictionless. Every branch stays in the
/// cone and, for `e <= 1`, dissipates.
fn jam_resolution<K: Compliance>(
    k: &K,
    n: &Vector3<f64>,
    material: &Material,
    u1: &Vector3<f64>,
) -> (Vector3<f64>, Regime) {
    let n = *n;
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
