//! The swerving slip: the one segment of the consistent law that is not linear in the
//! impulse, integrated numerically in the slip's own time `tau` (`dp = |u_t| dtau`).

use super::dop853::{Dense, Step, dense_root, dop853_step};
use super::{Event, Phase, SWERVE_TOLERANCE, State, keeps_direction};
use crate::model::collision_matrix::ContactK;
use nalgebra::Vector2;
use std::ops::ControlFlow;

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
pub(super) fn swerve_segment(
    ck: &ContactK,
    mu: f64,
    state: &mut State,
    phase: Phase,
    speed: f64,
    step_hint: &mut Option<f64>,
) -> Option<Event> {
    let swerve = Swerve::new(ck, mu, state, phase, speed);
    let mut z: Z = [0.0; 4];
    let mut k1 = swerve.flow.rate(&z);
    let mut h = step_hint.take().unwrap_or(swerve.first_step());
    for _iter in 0..10_000 {
        let rho = match swerve.end_before_step(&z, state) {
            ControlFlow::Break(end) => return end,
            ControlFlow::Continue(rho) => rho,
        };
        let h_planned = h;
        let landing = swerve.landing_step(state, &z, &k1, rho, h);
        if let Some(short) = landing {
            h = short;
        }
        let step = dop853_step(&swerve.flow, &z, &k1, h);
        let err_norm = swerve.error_norm(&step, h);
        if err_norm > SWERVE_TOLERANCE || err_norm.is_nan() {
            h *= shrink_factor(err_norm);
            continue;
        }
        // The point the segment ends at, and the step restitution starts with if it goes
        // on along the same flow.
        let end = if swerve.crossed_event(state, &step.z) {
            Some((swerve.locate_crossed_event(state, &z, &k1, &step, h), h))
        } else if landing.is_some() {
            swerve
                .closing_step(state, &step.z, &step.rate)
                .map(|z_event| (z_event, h_planned))
        } else {
            None
        };
        if let Some((z_event, hint)) = end {
            swerve.store(&z_event, state);
            let event = phase.end_event();
            if event == Event::CompressionEnded {
                *step_hint = Some(hint);
            }
            return Some(event);
        }
        z = step.z;
        k1 = step.rate;
        h = if landing.is_some() {
            h_planned
        } else {
            h * grow_factor(err_norm)
        };
    }
    None
}

/// What stays fixed over one swerving segment: its flow, the event that ends it, and the
/// scales its tests and steps are measured against.
struct Swerve {
    flow: Flow,
    phase: Phase,
    /// The initial contact speed (positive): every tolerance is relative to it.
    scale: f64,
    /// The normal impulse past which the segment is a jam that does not end.
    p_cap: f64,
    /// The slip speed at and below which the slip has stopped.
    stop_speed: f64,
    /// The flow's fastest rate, `|K_tn| + mu |K_tt|`: the direction turns and the slip
    /// decays at rates of this order.
    turn: f64,
    /// Bounds the rate of `u_n` per unit slip: `|du_n/dtau| <= |u_t| (K_nn + mu |K_tn|)`.
    normal_rates: f64,
}

impl Swerve {
    /// The swerve from `state` under `phase`, `speed` the impact's initial contact speed.
    fn new(ck: &ContactK, mu: f64, state: &State, phase: Phase, speed: f64) -> Self {
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
        let turn = flow.ktn.norm() + mu * (flow.k11.abs() + flow.k22.abs() + 2.0 * flow.k12.abs());
        Self {
            p_cap: 1e8 * scale / ck.knn,
            stop_speed: 1e-3 * SWERVE_TOLERANCE * scale,
            turn,
            normal_rates: flow.knn + mu * flow.ktn.norm(),
            flow,
            phase,
            scale,
        }
    }

    /// The first step when none is carried over: half the flow's fastest time scale
    /// `1 / turn`. Its error is then a fair share of the tolerance: a shorter one leaves
    /// the controller steps to catch up, a longer one spends the whole tolerance on it.
    fn first_step(&self) -> f64 {
        0.5 / self.turn.max(1e-300)
    }

    /// Stores the impulse increment `z` into `state`: the contact velocity after it, and
    /// the work, friction and normal impulse added.
    fn store(&self, z: &Z, state: &mut State) {
        let (ut, un) = self.flow.velocity(z);
        state.ut = ut;
        state.un = un;
        state.work += z[DW];
        state.ft += Vector2::new(z[DF1], z[DF2]);
        state.p += z[DP];
    }

    /// The tests before a step from `z`: `Break` with the event the segment ends at here,
    /// `state` stored (`Break(None)`: a jam, the normal impulse past its cap), else
    /// `Continue` with the slip speed `|u_t|` at `z`.
    fn end_before_step(&self, z: &Z, state: &mut State) -> ControlFlow<Option<Event>, f64> {
        let (ut, _) = self.flow.velocity(z);
        // Once the slip has turned onto a direction it keeps (the invariant direction
        // of K), the rest of the segment is linear: hand it back to the closed form.
        if let Some(turn) = self.flow.settled(&ut, self.scale) {
            // Onto the invariant direction itself, so that the closed form's constant
            // rate is parallel to the slip (the rotation moves u_t by less than the
            // tolerance).
            self.store(z, state);
            let (sin, cos) = crate::math::sin_cos(turn);
            state.ut = Vector2::new(cos * ut.x - sin * ut.y, sin * ut.x + cos * ut.y);
            return ControlFlow::Break(Some(Event::DirectionSettled));
        }
        if keeps_direction(&self.flow.slip_rate(&ut), &ut, self.scale) {
            self.store(z, state);
            return ControlFlow::Break(Some(Event::DirectionSettled));
        }
        let rho = ut.norm();
        if rho <= self.stop_speed {
            self.store(z, state);
            return ControlFlow::Break(Some(Event::SlipStopped));
        }
        if state.p + z[DP] > self.p_cap {
            return ControlFlow::Break(None);
        }
        ControlFlow::Continue(rho)
    }

    /// The step from `z` (rate `k1`, slip speed `rho`) shortened to end just before an
    /// event within reach of the planned step `h`, so that a short closing step
    /// ([`Self::closing_step`]) can reach it instead of a step past it being thrown away;
    /// `None` when no event is predicted within `h`. The prediction: the first zero of
    /// the event's quadratic Taylor polynomial, one classic RK4 step to it, and a Newton
    /// step from there; the step ends at [`LANDING`] of that.
    fn landing_step(&self, state: &State, z: &Z, k1: &Z, rho: f64, h: f64) -> Option<f64> {
        let (g, g_rate) = event_value(&self.flow, self.phase, state, z, k1);
        // |d^2 g/dtau^2| is at most |u_t| times the rates' scale squared: when even that
        // bound cannot bring the event within the step (a distant event, a dying slip),
        // the second derivative is not computed.
        let curve_bound = rho
            * match self.phase {
                Phase::Compression => self.turn * self.normal_rates,
                Phase::Restitution { .. } => {
                    rho * self.normal_rates + self.flow.velocity(z).1.abs() * self.turn
                }
            };
        let quadratic = if -g <= h * g_rate.max(0.0) + 0.5 * h * h * curve_bound {
            let g_curve = event_curve(&self.flow, self.phase, z, k1);
            quadratic_root(g, g_rate, g_curve)
        } else {
            f64::INFINITY
        };
        if quadratic <= h {
            let guess = quadratic;
            let z_guess = rk4_step(&self.flow, z, k1, guess);
            let k_guess = self.flow.rate(&z_guess);
            let (g1, g1_rate) = event_value(&self.flow, self.phase, state, &z_guess, &k_guess);
            let predicted = guess - g1 / g1_rate;
            if g1_rate > 0.0 && predicted > 0.0 && LANDING * predicted <= h {
                return Some(LANDING * predicted);
            }
        }
        None
    }

    /// Hairer's DOP853 error estimate of `step` (over `h`) from its 5th- and 3rd-order
    /// embedded pairs, measured on the contact velocity relative to the initial speed:
    /// the step is accepted when it is at most [`SWERVE_TOLERANCE`].
    fn error_norm(&self, step: &Step, h: f64) -> f64 {
        let e5 = self.flow.error_size(&step.err5) / self.scale;
        let e3 = self.flow.error_size(&step.err3) / self.scale;
        let denominator = (e5 * e5 + 0.01 * e3 * e3).sqrt();
        if denominator > 0.0 {
            h * e5 * e5 / denominator
        } else {
            0.0
        }
    }

    /// True when the accepted step that ends at `z_new` has crossed the phase's event:
    /// `u_n >= 0` in compression, the work given back reached in restitution.
    fn crossed_event(&self, state: &State, z_new: &Z) -> bool {
        let un_new = self.flow.velocity(z_new).1;
        match self.phase {
            Phase::Compression => un_new >= 0.0,
            Phase::Restitution { target_work } => state.work + z_new[DW] >= target_work,
        }
    }

    /// The point of an event inside the accepted `step` from `z` (rate `k1`) over `h`,
    /// not anticipated by [`Self::landing_step`]: located on DOP853's 7th-order dense
    /// output (Hairer's contd8: three more stages) by Newton's method on its polynomial,
    /// then reached by a step and one Newton correction.
    fn locate_crossed_event(&self, state: &State, z: &Z, k1: &Z, step: &Step, h: f64) -> Z {
        let flow = &self.flow;
        let dense = Dense::new(flow, z, &step.z, &step.stages, &step.rate, h);
        // The event's value as a polynomial in the step fraction x, zero at the event:
        // u_n (linear in z) or the work given back so far minus its target.
        let (base, coefficients) = match self.phase {
            Phase::Compression => {
                let un = |c: &Z| flow.knn * c[DP] + flow.ktn.x * c[DF1] + flow.ktn.y * c[DF2];
                (flow.velocity(z).1, dense.f.map(|c| un(&c)))
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
        let mut z_event = dop853_step(flow, z, k1, dh).z;
        let (v, slope) = match self.phase {
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
        z_event
    }

    /// The event's point after a landing step that ended at `z_new` (rate `k_new`), or
    /// `None` when it is not within [`CLOSING_REACH`] ahead. The distance comes from the
    /// event's quadratic Taylor polynomial, so that what is left after the closing step
    /// (the cubic term, ~1e-4 of the distance) is small enough for a first-order Newton
    /// correction.
    fn closing_step(&self, state: &State, z_new: &Z, k_new: &Z) -> Option<Z> {
        let (g, g_rate) = event_value(&self.flow, self.phase, state, z_new, k_new);
        let g_curve = event_curve(&self.flow, self.phase, z_new, k_new);
        let rest = quadratic_root(g, g_rate, g_curve);
        if !(g_rate > 0.0 && rest >= 0.0 && rest * self.turn <= CLOSING_REACH) {
            return None;
        }
        // The closing step: classic RK4 over `rest` (its local error is of order
        // (rest L)^5 / 120 ~ 3e-11 for rates of the flow's scale L), then one Newton
        // correction on the event's value along the rate there (of ~1e-4 of `rest`, so
        // its neglected curvature is ~1e-8 of that).
        let mut z_event = rk4_step(&self.flow, z_new, k_new, rest);
        let k_event = self.flow.rate(&z_event);
        let (g, g_rate) = event_value(&self.flow, self.phase, state, &z_event, &k_event);
        if g_rate > 0.0 && g_rate.is_finite() {
            let shift = -g / g_rate;
            for (zi, ri) in z_event.iter_mut().zip(k_event) {
                *zi += ri * shift;
            }
        }
        Some(z_event)
    }
}

/// The first zero `x >= 0` of the event's quadratic Taylor polynomial
/// `g + g_rate x + g_curve x^2 / 2` (`g < 0` before the event), in the form that does not
/// cancel; infinite when it has none ahead.
#[inline(always)]
fn quadratic_root(g: f64, g_rate: f64, g_curve: f64) -> f64 {
    let disc = g_rate * g_rate - 2.0 * g_curve * g;
    if disc >= 0.0 && g_rate + disc.sqrt() > 0.0 {
        -2.0 * g / (g_rate + disc.sqrt())
    } else {
        f64::INFINITY
    }
}

/// The step-size factor after a rejected step of error `err_norm` (above the
/// tolerance, or NaN): the controller's `0.9 (tol / err)^(1/8)`, within `[0.1, 0.9]`.
#[inline(always)]
fn shrink_factor(err_norm: f64) -> f64 {
    if err_norm.is_finite() {
        (0.9 * eighth_root(SWERVE_TOLERANCE / err_norm)).clamp(0.1, 0.9)
    } else {
        0.1
    }
}

/// The step-size factor after an accepted step of error `err_norm`: the controller's
/// `0.9 (tol / err)^(1/8)`, within `[0.333, 6]`.
#[inline(always)]
fn grow_factor(err_norm: f64) -> f64 {
    if err_norm > 0.0 {
        (0.9 * eighth_root(SWERVE_TOLERANCE / err_norm)).clamp(0.333, 6.0)
    } else {
        6.0
    }
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
pub(super) type Z = [f64; 4];
const DP: usize = 0;
const DF1: usize = 1;
const DF2: usize = 2;
const DW: usize = 3;

/// The swerving slip's flow in `tau` (see [`swerve_segment`]), in the contact basis.
pub(super) struct Flow {
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
    pub(super) fn rate(&self, z: &Z) -> Z {
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
