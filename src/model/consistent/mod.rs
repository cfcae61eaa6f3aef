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

mod dop853;
mod jam;
mod swerve;
mod tangential;

use super::collision_matrix::{Compliance, ContactK};
use super::types::{Material, Regime};
use jam::jam_resolution;
use nalgebra::{Vector2, Vector3};
use swerve::swerve_segment;

/// Local error tolerance of the swerve integration, relative to the initial contact
/// speed; also the bound on the error of handing a settled slip direction back to the
/// closed form. The end state is accurate to about this, relative:
/// `tests/model_swerve_accuracy.rs` holds the impulse within ten times it of an
/// independent fixed-step RK4 reference.
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

impl Phase {
    /// The event that ends this phase.
    fn end_event(self) -> Event {
        match self {
            Phase::Compression => Event::CompressionEnded,
            Phase::Restitution { .. } => Event::Finished,
        }
    }
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

/// The consistent law's impulse on the body (world) and its regime: the integration below,
/// then Walton's tangential restitution where the material has one
/// ([`tangential::rebound`]).
pub(crate) fn consistent_impulse<K: Compliance>(
    k: &K,
    n: &Vector3<f64>,
    material: &Material,
    u1: &Vector3<f64>,
) -> (Vector3<f64>, Regime) {
    let (impulse, regime) = coulomb_impulse(k, n, material, u1);
    if material.tangential_restitution == 0.0 {
        return (impulse, regime);
    }
    tangential::rebound(k, n, material, u1, impulse, regime)
}

/// The integration with Coulomb friction and Stronge's restitution: the impulse on the body
/// (world) and the regime.
fn coulomb_impulse<K: Compliance>(
    k: &K,
    n: &Vector3<f64>,
    material: &Material,
    u1: &Vector3<f64>,
) -> (Vector3<f64>, Regime) {
    let n = *n;
    let ck = k.contact_k(&n);
    let speed = u1.norm();
    let mut run = Integration::start(&ck, material.friction, &n, u1, speed);
    let started_slipping = run.state.ut.norm_squared() > 0.0;
    let mut stuck = false;
    let mut stuck_after_slip = false;
    // Every iteration ends one segment at an event; a body goes through at most
    // stop -> (re-slip) -> compression end -> finish, so the cap is generous.
    for _ in 0..16 {
        let mode = run.mode();
        if let Mode::Stick(_) = mode {
            if !stuck && started_slipping {
                stuck_after_slip = true;
            }
            stuck = true;
        }
        let Some(event) = run.segment(mode) else {
            return jam_resolution(k, n, material, u1);
        };
        if run.ends_at(event, material.restitution) {
            break;
        }
    }

    let state = run.state;
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

/// One impact's integration, segment by segment: the state, the phase, and what a
/// segment hands on to the next.
struct Integration<'a> {
    /// The collision matrix in the contact basis.
    ck: &'a ContactK,
    /// Coulomb friction coefficient.
    mu: f64,
    /// The initial contact speed `|u1|`: every tolerance is relative to it.
    speed: f64,
    state: State,
    phase: Phase,
    /// Set once a swerve has settled onto a stable invariant direction (by its own,
    /// sharper test); the slip then keeps that direction until it stops.
    settled: bool,
    /// The last accepted swerve step, when the swerve goes on from compression into
    /// restitution: the flow is the same, only the event changes.
    step_hint: Option<f64>,
}

impl<'a> Integration<'a> {
    /// The integration's start, in compression, for the approach velocity `u1` (of norm
    /// `speed`) along the normal `n`.
    fn start(ck: &'a ContactK, mu: f64, n: &Vector3<f64>, u1: &Vector3<f64>, speed: f64) -> Self {
        let mut state = State {
            ut: ck.tangential(u1),
            un: n.dot(u1),
            work: 0.0,
            p: 0.0,
            ft: Vector2::zeros(),
        };
        // A slip below the swerve's own stop speed has stopped. This is the rounding that
        // u1 - n (n.u1) leaves for an exactly normal approach when n is not a coordinate
        // axis (~1e-16 |u1|); kept, keeps_direction (absolute in |u_t|) would accept its
        // random direction and friction would act along it for the whole impact.
        if state.ut.norm() <= 1e-3 * SWERVE_TOLERANCE * speed {
            state.ut = Vector2::zeros();
        }
        Self {
            ck,
            mu,
            speed,
            state,
            phase: Phase::Compression,
            settled: false,
            step_hint: None,
        }
    }

    /// The stick/slip decision at a segment's start. A slipping contact slips on along
    /// its slip. A contact at rest sticks when the friction per unit normal impulse that
    /// holds it, `f = -K_tt^-1 K_tn`, is inside the cone (`|f| <= mu`), else slips along
    /// the invariant direction; frictionless, it slips with no friction at all.
    fn mode(&self) -> Mode {
        let (ck, mu, ut) = (self.ck, self.mu, self.state.ut);
        if ut.norm_squared() == 0.0 {
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
            Mode::Slip(ut / ut.norm())
        }
    }

    /// Advances one segment in `mode` to its first event: in closed form while the rate
    /// `du/dp` keeps the slip direction (stick, no friction, a settled swerve, or a rate
    /// parallel to the slip), else by the swerve integrator. `None` on a jam that does not
    /// end.
    fn segment(&mut self, mode: Mode) -> Option<Event> {
        let friction = match mode {
            Mode::Stick(f) => f,
            Mode::Slip(s) => -s * self.mu,
        };
        let (gt, gn) = self.ck.rate(&friction);
        let direction_kept = match mode {
            Mode::Stick(_) => true,
            Mode::Slip(s) => {
                s == Vector2::zeros()
                    || self.settled
                    || keeps_direction(&gt, &self.state.ut, self.speed)
            }
        };
        if direction_kept {
            self.step_hint = None;
            linear_segment(&mut self.state, self.phase, gt, gn, friction, mode)
        } else {
            let (ck, mu, phase, speed) = (self.ck, self.mu, self.phase, self.speed);
            swerve_segment(ck, mu, &mut self.state, phase, speed, &mut self.step_hint)
        }
    }

    /// Carries the integration past `event`; true when it ends the impact. A stopped
    /// slip is zero from there on; compression's end (`u_n = 0`, `W = W_c`) sets
    /// restitution's target `W = (1 - e^2) W_c`, or ends a plastic impact (`e = 0`).
    fn ends_at(&mut self, event: Event, e: f64) -> bool {
        match event {
            Event::SlipStopped => {
                self.state.ut = Vector2::zeros();
                self.settled = false;
            }
            Event::DirectionSettled => self.settled = true,
            Event::CompressionEnded => {
                self.state.un = 0.0;
                if e == 0.0 {
                    return true;
                }
                self.phase = Phase::Restitution {
                    target_work: (1.0 - e * e) * self.state.work,
                };
            }
            Event::Finished => return true,
        }
        false
    }
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
