//! The time of impact inside a step: the first touch along one closed-form path
//! ([`earliest_touch`]), and the search along a flight for the first contact that closes
//! ([`first_impact`]: conservative advancement, then Newton's method and regula falsi in
//! [`polish`]), with its closed form for a ball over flat grounds and the test that a pair
//! provably cannot close ([`cannot_close`]).

use super::instant::{closest, plane_contact_on};
use super::plane::flat_relative;
use super::{BodyGeom, BodyPart, GroundGeom, Hit};
use crate::motion::{Flight, State};
use crate::plugin::policy::{
    ADVANCE_STEPS, CLEAR_SEARCH_STEPS, FLIGHT_SPEED_FLOOR, POSITION_ROUNDING, ROOT_ITERATIONS,
    ROOT_STEP, touch_tolerance,
};
use nalgebra::Vector3;

/// The first time in `(0, dt]` at which `touches` holds, for a body moving smoothly along
/// one closed-form path (a rolling ball): `touches` is asked at `TOUCH_SAMPLES` evenly
/// spaced times and the first touch bisected to rounding. A path that grazes a ground
/// between two samples is not found: the caller's end check must catch it.
pub(crate) fn earliest_touch(dt: f64, touches: impl Fn(f64) -> bool) -> Option<f64> {
    let mut lo = 0.0;
    for i in 1..=TOUCH_SAMPLES {
        let t = dt * i as f64 / TOUCH_SAMPLES as f64;
        if touches(t) {
            let mut hi = t;
            // 64 halvings take a step's interval to rounding (f64's 53 bits and margin).
            for _ in 0..64 {
                let mid = 0.5 * (lo + hi);
                if mid <= lo || mid >= hi {
                    break;
                }
                if touches(mid) {
                    hi = mid;
                } else {
                    lo = mid;
                }
            }
            return Some(hi);
        }
        lo = t;
    }
    None
}

/// How many times in the step [`earliest_touch`] asks: a rolling ball moves straight or nearly
/// (its path bows by under `(|a_t| + mu g_n) dt^2 / 8`), so it meets a plane or a cuboid's
/// face once, and a sample every 16th of a step finds it.
const TOUCH_SAMPLES: usize = 16;

/// [`first_impact`] in closed form for a ball (one collider, a ball centred on the centre of mass,
/// so its rotation does not move it) without linear damping against grounds whose every query over
/// the flight is one face's plane ([`flat_relative`] of a still ground) and towards which the
/// acceleration does not point (`n.a <= 0`: a concave gap, so the approach, once started, ends on
/// the ground): the gap to each plane is `d + un t + an t^2 / 2`, exactly, and the impact is its
/// downward root. `None` where that does not apply, or where the search could decide otherwise (a
/// start inside a ground and separating; a contact within the touching tolerance at the end of the
/// interval): the search then runs.
fn ball_on_flat(fly: &Flying, t_from: f64, t_to: f64) -> Option<Search> {
    let Flying {
        body,
        grounds,
        flight,
        s0,
        t0,
    } = *fly;
    let [part] = &body.parts[..] else {
        return None;
    };
    if part.shape.as_ball().is_none()
        || part.local.translation.vector != Vector3::zeros()
        || flight.linear_damping != 0.0
        || t_from != t0
        || t_to < t_from
        || t_to.is_nan()
    {
        return None;
    }
    let span = t_to - t0;
    let travel = flight.max_speed(s0, span) * span;
    let close = touch_tolerance(body.radius);
    let center = s0.com;
    let mut first: Option<f64> = None;
    for ground in grounds {
        if ground.skip.contains(&part.handle) {
            continue;
        }
        if ground.motion.v != Vector3::zeros()
            || !flat_relative(part, ground, s0, travel, body.radius)
        {
            return None;
        }
        let (d, n, _) = plane_contact_on(part, ground, s0, t0, center, None).ok()?;
        let (vn, an) = (n.dot(&s0.v), n.dot(&flight.accel));
        if an > 0.0 || !an.is_finite() || !d.is_finite() || !vn.is_finite() {
            return None;
        }
        // The downward root of `d + vn t + an t^2 / 2`, if any.
        let root = if d < 0.0 {
            if vn < 0.0 {
                0.0
            } else {
                return None;
            }
        } else if an == 0.0 {
            if vn < 0.0 { d / -vn } else { continue }
        } else {
            let sq = (vn * vn - 2.0 * an * d).sqrt();
            if vn < 0.0 {
                2.0 * d / (sq - vn)
            } else {
                (vn + sq) / -an
            }
        };
        if root > span || root.is_nan() {
            // No impact in the interval, unless within the touching tolerance at its end.
            if d + vn * span + 0.5 * an * span * span <= close {
                return None;
            }
            continue;
        }
        first = Some(first.map_or(root, |f: f64| f.min(root)));
    }
    let Some(tau) = first else {
        return Some(Search::Clear);
    };
    let t = t0 + tau;
    let s = flight.advance(s0, tau);
    let h = closest(body, grounds, &s, t, close)?;
    (h.un < 0.0).then_some(Search::Hit(t, s, h))
}

/// A body's motion over a step as [`cannot_close`] bounds it: the flight from `s` over
/// `[0, dt]`, the radius of a sphere about the centre of mass holding the body, and `speed`,
/// the body's approach bound over the step (`Flight::max_speed + Flight::max_angular_speed x
/// radius`, as [`approach_bound`] for a fixed ground).
#[derive(Clone, Copy)]
pub(crate) struct Sweep<'q> {
    pub flight: &'q Flight,
    pub s: &'q State,
    pub dt: f64,
    pub radius: f64,
    pub speed: f64,
    /// How much further than the flight the state that stands at the step's end may have
    /// gone, per unit of acceleration (s^2): `StepData::integrator_lag`; a pair is clear
    /// only if that state ends no deeper than `gap` (m, the resting gap) either.
    pub lag: f64,
    pub gap: f64,
}

/// Can the pair provably not meet in `[0, dt]` of the `sweep` from `s`, so that
/// [`first_impact`] would find it `Clear`? `(dist, n)`: the pair's contact at `s` (signed
/// distance, normal). Reads only; pure.
///
/// Only for a ground that does not move (no velocity) and is a half-space, or a cuboid whose
/// face under the part stays the face the direct query picks, with the body's support point
/// over it, wherever the part goes in the step: every query of the search is then the direct
/// plane query, and for a convex ground the gap along the face normal (translation of the
/// centre of mass, less what the rotation can bring any point of the body closer) bounds the
/// distance from below. `true` when that bound stays above the search's touching tolerance
/// over the whole step, by enough that the conservative advancement crosses the step in well
/// under its step limit.
pub(crate) fn cannot_close(
    part: &BodyPart,
    ground: &GroundGeom,
    sweep: &Sweep,
    (dist, n): (f64, Vector3<f64>),
) -> bool {
    let Sweep {
        flight,
        s,
        dt,
        radius,
        speed,
        lag,
        gap,
    } = *sweep;
    if !(dt >= 0.0 && speed.is_finite() && radius.is_finite() && dist.is_finite()) {
        return false;
    }
    // Any point of the body moves at most this far in the step.
    let travel = speed.max(FLIGHT_SPEED_FLOOR) * dt;
    if ground.motion.v != Vector3::zeros() || !flat_relative(part, ground, s, travel, radius) {
        return false;
    }
    // The lowest the centre of mass's flight goes along `n` in the step:
    // `n.(v phi1 + a phi2)`, with `phi1 = t` and `phi2 = t^2 / 2` undamped, and
    // `0 <= phi1 <= t`, `0 <= phi2 <= t^2 / 2` under damping.
    let (vn, an) = (n.dot(&s.v), n.dot(&flight.accel));
    let sink = if flight.linear_damping == 0.0 {
        let at = |t: f64| vn * t + 0.5 * an * t * t;
        let mut low = at(dt).min(0.0);
        if an > 0.0 && vn < 0.0 && -vn / an < dt {
            low = low.min(at(-vn / an));
        }
        low
    } else {
        vn.min(0.0) * dt + 0.5 * an.min(0.0) * dt * dt
    };
    let turn = flight.max_angular_speed(s) * dt * radius;
    let rounding = POSITION_ROUNDING * (1.0 + s.com.norm() + dist.abs());
    // The integrator's lag counts where it could carry the end state deeper than the gap.
    let lagged = (lag * an.min(0.0) + gap).min(0.0);
    let low = dist + sink + lagged - turn - rounding;
    low > touch_tolerance(radius) && travel <= CLEAR_SEARCH_STEPS * low
}

/// A body's flight against the grounds, as the search asks it: the body's parts, the grounds
/// (indices of [`Hit::ground`]), and the flight from `s0`, the body's state at time `t0`.
#[derive(Clone, Copy)]
struct Flying<'q, 'a> {
    body: &'q BodyGeom<'a>,
    grounds: &'q [GroundGeom<'a>],
    flight: &'q Flight,
    s0: &'q State,
    t0: f64,
}

/// A bound on the speed at which any point of the body can approach any ground during
/// `[t0, t0 + span]` of the flight `fly`.
fn approach_bound(fly: &Flying, span: f64) -> f64 {
    let (body, flight, s0) = (fly.body, fly.flight, fly.s0);
    let lin = flight.max_speed(s0, span);
    let body_bound = lin + flight.max_angular_speed(s0) * body.radius;
    let travel = lin * span + body.radius;
    let ground_bound = fly
        .grounds
        .iter()
        .map(|g| g.max_speed((s0.com - g.com_at(fly.t0)).norm() + travel))
        .fold(0.0, f64::max);
    (body_bound + ground_bound).max(FLIGHT_SPEED_FLOOR)
}

/// What the search for the next impact found.
pub(crate) enum Search {
    /// A contact at this time, with the state there and the contact.
    Hit(f64, State, Hit),
    /// No contact until the end of the interval.
    Clear,
    /// The search gave up at this time (a body spinning fast against the ground can need
    /// thousands of conservative steps); the state there touches no ground.
    Stalled(f64, State),
}

/// The earliest time in `[t_from, t_to]` at which the body, flying from `s0` (its state at
/// `t0 <= t_from`), touches a ground while approaching it.
///
/// Conservative advancement (steps of `dist / bound`, which cannot pass a contact) brings
/// the body within `close` of the ground; Newton's method and regula falsi on the signed
/// distance, whose time derivative is the normal velocity `un` at the contact point, then
/// find the contact time to rounding. A touching contact that separates is stepped over.
pub(crate) fn first_impact(
    body: &BodyGeom,
    grounds: &[GroundGeom],
    flight: &Flight,
    s0: &State,
    t0: f64,
    t_from: f64,
    t_to: f64,
) -> Search {
    let fly = Flying {
        body,
        grounds,
        flight,
        s0,
        t0,
    };
    if let Some(found) = ball_on_flat(&fly, t_from, t_to) {
        return found;
    }
    let bound = approach_bound(&fly, t_to - t0);
    let close = touch_tolerance(body.radius);
    let mut t = t_from;
    let mut last = (t, flight.advance(s0, t - t0));
    for _ in 0..ADVANCE_STEPS {
        let s = flight.advance(s0, t - t0);
        let reach = bound * (t_to - t) + close;
        let Some(h) = closest(body, grounds, &s, t, reach) else {
            return Search::Clear;
        };
        if h.dist <= close {
            if h.un < 0.0 {
                let (t, s, h) = polish(&fly, (t_from, t_to), (t, s, h));
                return Search::Hit(t, s, h);
            }
            if h.dist >= 0.0 {
                last = (t, s);
            }
            t += close.max(h.dist) / bound;
        } else {
            last = (t, s);
            t += h.dist / bound;
        }
        if t > t_to {
            return Search::Clear;
        }
    }
    Search::Stalled(last.0, last.1)
}

/// A contact as the search for its time sees it.
pub(crate) trait Gap: Copy {
    /// Signed distance (m): negative when penetrating.
    fn gap(&self) -> f64;
    /// The distance's time derivative (m/s): negative when approaching.
    fn rate(&self) -> f64;
}

impl Gap for (State, Hit) {
    fn gap(&self) -> f64 {
        self.1.dist
    }
    fn rate(&self) -> f64 {
        self.1.un
    }
}

/// The contact time to rounding, from `start = (t, c)` at most the touching tolerance from
/// contact: Newton's method on the gap (its time derivative is the rate) until an iterate
/// penetrates, then regula falsi (Illinois) on the bracket, never past `t_end`, at most
/// `ROOT_ITERATIONS` iterates, and none closer than `ROOT_STEP` to the last. `at(t)` is the
/// contact at time `t` (`None`: out of the search's reach, and the search stops). Returns the
/// last iterate outside (`gap >= 0`): there the normal is the closest-point direction, well
/// defined even against a single triangle of a mesh, where a penetration normal may point
/// sideways through the triangle's edge. A start already inside is returned as it is: the
/// contact is now. The one root search of a contact time: with a ground (`first_impact`) and
/// between two bodies (`body_contact::first_body_touch`).
pub(crate) fn touch_time<C: Gap>(
    start: (f64, C),
    t_end: f64,
    mut at: impl FnMut(f64) -> Option<C>,
) -> (f64, C) {
    if start.1.gap() < 0.0 {
        return start;
    }
    let mut out = start;
    // Bracket ends for regula falsi: distances as used (Illinois halves a stale one), and the
    // penetrating end once found.
    let mut d_a = start.1.gap();
    let mut inside: Option<(f64, f64)> = None;
    let mut last_side = 0i8; // +1: the last iterate was outside, -1: inside
    for _ in 0..ROOT_ITERATIONS {
        let t_a = out.0;
        if out.1.gap() == 0.0 {
            break;
        }
        let t_new = match inside {
            None if out.1.rate() < 0.0 => (t_a + out.1.gap() / -out.1.rate()).min(t_end),
            None => break,
            Some((t_b, d_b)) => t_a + d_a * (t_b - t_a) / (d_a - d_b),
        };
        if t_new.is_nan() || t_new <= t_a || (t_new - t_a) <= ROOT_STEP * (1.0 + t_a.abs()) {
            break;
        }
        let Some(c_new) = at(t_new) else {
            break;
        };
        if c_new.gap() >= 0.0 {
            out = (t_new, c_new);
            d_a = c_new.gap();
            if let (Some((_, d_b)), 1) = (inside.as_mut(), last_side) {
                *d_b *= 0.5;
            }
            last_side = 1;
        } else {
            if inside.is_some() && last_side == -1 {
                d_a *= 0.5;
            }
            inside = Some((t_new, c_new.gap()));
            last_side = -1;
        }
        if let Some((t_b, _)) = inside {
            if t_b - out.0 <= ROOT_STEP * (1.0 + t_b.abs()) {
                break;
            }
        }
    }
    out
}

/// [`touch_time`] of a flight's contact with the grounds, from `(t, s, h)` at most `close`
/// from a ground, within `range`.
fn polish(fly: &Flying, range: (f64, f64), (t, s, h): (f64, State, Hit)) -> (f64, State, Hit) {
    let (body, grounds, flight, s0, t0) = (fly.body, fly.grounds, fly.flight, fly.s0, fly.t0);
    let reach = 4.0 * h.dist + 1e-3 * body.radius + 1e-9;
    let at = |t_new: f64| {
        let s_new = flight.advance(s0, t_new - t0);
        closest(body, grounds, &s_new, t_new, reach).map(|h_new| (s_new, h_new))
    };
    let (t, (s, h)) = touch_time((t, (s, h)), range.1, at);
    (t, s, h)
}
