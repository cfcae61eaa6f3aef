//! When two balls moving between impacts first touch, in `f64`, with no rapier types.
//!
//! Each ball's centre moves by its own motion ([`Motion`]: free flight or rolling on a
//! plane). Under the same constant acceleration and no damping, the relative motion of the
//! centres is uniform, and the first touch solves `|dx + dv t| = S` in closed form.
//! Otherwise the gap `f(t) = |x_b(t) - x_a(t)| - S` is searched by conservative advancement
//! (the gap shrinks no faster than the relative speed can grow to) and refined by Newton's
//! method from the outside, so the search cannot step over a touch.

use super::{Flight, Rolling, State};
use nalgebra::Vector3;

/// How a ball moves between impacts.
#[derive(Clone, Debug, PartialEq)]
pub(crate) enum Motion {
    Flight(Flight),
    Rolling(Rolling),
}

impl Motion {
    /// The state `t` seconds after `s`.
    pub fn advance(&self, s: &State, t: f64) -> State {
        match self {
            Motion::Flight(f) => f.advance(s, t),
            Motion::Rolling(r) => r.advance(s, t),
        }
    }

    /// A bound on how fast the centre's velocity changes (m/s^2), from `s` on.
    pub fn accel_bound(&self, s: &State) -> f64 {
        match self {
            Motion::Flight(f) => f.accel.norm() + f.linear_damping * (s.v.norm() + 1.0),
            // The pull along a slope and kinetic friction at most: |a_t| + mu |a.n|.
            Motion::Rolling(r) => {
                let an = r.accel.dot(&r.normal);
                (r.accel - r.normal * an).norm() + r.friction * an.abs()
            }
        }
    }

    /// A bound on the angular speed (rad/s) from `s` on: a flight's (`Flight::max_angular_speed`);
    /// a rolling ball's spin changes, but a centred ball's spin moves none of its surface
    /// towards anything, so callers do not ask it of one.
    pub fn max_angular_speed(&self, s: &State) -> f64 {
        match self {
            Motion::Flight(f) => f.max_angular_speed(s),
            Motion::Rolling(_) => s.w.norm(),
        }
    }

    /// The constant acceleration of a flight without damping, if that is the motion.
    fn uniform_accel(&self) -> Option<Vector3<f64>> {
        match self {
            Motion::Flight(f) if f.linear_damping == 0.0 => Some(f.accel),
            _ => None,
        }
    }
}

/// A ball between impacts: its state at `t0` and how it moves from there.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Moving {
    pub state: State,
    pub t0: f64,
    pub motion: Motion,
}

impl Moving {
    /// The state at time `t >= t0`.
    pub fn at(&self, t: f64) -> State {
        self.motion.advance(&self.state, t - self.t0)
    }
}

/// Gap (m) below which two balls count as touching, for balls whose radii sum to `reach`.
pub(crate) fn touch_tolerance(reach: f64) -> f64 {
    1e-12 * (1.0 + reach)
}

/// The search gave up: a glancing approach that closes too slowly for the steps allowed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct Stalled;

/// The most steps of the search (each closes the gap by a bounded fraction).
const MAX_STEPS: usize = 10_000;

/// The first time in `[t, t_end]` at which balls `a` and `b`, whose radii sum to `reach`,
/// touch while approaching, `Ok(None)` if they do not, or [`Stalled`]. A pair already
/// touching and approaching at `t` touches at `t`. `states` are the balls' states at `t`
/// (`a.at(t)`, `b.at(t)`: a caller searching several pairs of a ball advances it once).
pub(crate) fn first_touch(
    (a, b): (&Moving, &Moving),
    states: (State, State),
    reach: f64,
    t: f64,
    t_end: f64,
) -> Result<Option<f64>, Stalled> {
    let tol = touch_tolerance(reach);
    // The gap and its rate where the balls are at `sa` and `sb`.
    let gap_of = |(sa, sb): &(State, State)| {
        let d = sb.com - sa.com;
        let len = d.norm();
        let rate = if len > 0.0 {
            d.dot(&(sb.v - sa.v)) / len
        } else {
            0.0
        };
        (len - reach, rate)
    };
    // The gap and its rate at `t`, with both states there (the search's next step reads them).
    let gap_at = |t: f64| {
        let states = (a.at(t), b.at(t));
        let (gap, rate) = gap_of(&states);
        (gap, rate, states)
    };
    let (gap, rate) = gap_of(&states);
    if gap <= tol {
        return Ok((rate < 0.0).then_some(t));
    }
    if let (Some(aa), Some(ab)) = (a.motion.uniform_accel(), b.motion.uniform_accel()) {
        if aa == ab {
            return Ok(uniform_touch(&states, reach, t, t_end));
        }
    }
    // Conservative advancement: from t the relative speed grows by at most the accelerations'
    // bound times the time, so it stays below `dv + accel (t_end - t)` until the step's end,
    // and over [t, t + h] the gap closes by at most `dv h + accel h^2 / 2`. Each bound gives
    // a step that cannot close the gap; the longer is taken (the first reaches the step's
    // end from afar, the second steps a pair lying a rounding apart, neither closing, by the
    // square root of the gap rather than by the gap).
    let mut t = t;
    let mut gap = gap;
    let mut rate = rate;
    let mut states = states;
    for _ in 0..MAX_STEPS {
        if gap <= tol {
            return Ok(Some(t));
        }
        let (sa, sb) = &states;
        let accel = a.motion.accel_bound(sa) + b.motion.accel_bound(sb);
        let dv = (sb.v - sa.v).norm();
        if dv <= 0.0 && accel <= 0.0 {
            return Ok(None);
        }
        // The positive root of accel h^2 / 2 + dv h = gap, without cancellation.
        let quadratic = 2.0 * gap / (dv + (dv * dv + 2.0 * accel * gap).sqrt());
        let h = quadratic.max(gap / (dv + accel * (t_end - t)));
        // Newton's step from the outside when the gap closes; kept only if it stays outside
        // (a gap convex in time, as under uniform relative motion, never overshoots).
        let safe = t + h;
        let mut next = safe;
        if rate < 0.0 {
            let newton = t - gap / rate;
            if newton > safe && newton <= t_end {
                let (g, r, s) = gap_at(newton);
                if g >= -tol {
                    (t, gap, rate, states) = (newton, g, r, s);
                    continue;
                }
            }
        }
        if next > t_end {
            next = t_end;
            let (g, r, s) = gap_at(next);
            if g > tol {
                return Ok(None);
            }
            (t, gap, rate, states) = (next, g, r, s);
            continue;
        }
        (t, gap, rate, states) = {
            let (g, r, s) = gap_at(next);
            (next, g, r, s)
        };
    }
    Err(Stalled)
}

/// [`first_touch`] for a uniform relative motion, from both balls' states at `t`: the
/// smaller root of `|dx + dv s|^2 = reach^2`, written without cancellation.
fn uniform_touch((sa, sb): &(State, State), reach: f64, t: f64, t_end: f64) -> Option<f64> {
    let dx = sb.com - sa.com;
    let dv = sb.v - sa.v;
    let qa = dv.norm_squared();
    let qb = dx.dot(&dv);
    let qc = dx.norm_squared() - reach * reach;
    if qb >= 0.0 || qa == 0.0 {
        return None;
    }
    let disc = qb * qb - qa * qc;
    if disc < 0.0 {
        return None;
    }
    // s = (-qb - sqrt(disc)) / qa = qc / (-qb + sqrt(disc)).
    let s = qc / (-qb + disc.sqrt());
    let hit = t + s.max(0.0);
    (hit <= t_end).then_some(hit)
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::UnitQuaternion;

    fn ball(com: Vector3<f64>, v: Vector3<f64>, motion: Motion) -> Moving {
        Moving {
            state: State {
                com,
                rot: UnitQuaternion::identity(),
                v,
                w: Vector3::zeros(),
            },
            t0: 0.0,
            motion,
        }
    }

    /// [`first_touch`] from the balls' states at `t`.
    fn touch(
        a: &Moving,
        b: &Moving,
        reach: f64,
        t: f64,
        t_end: f64,
    ) -> Result<Option<f64>, Stalled> {
        first_touch((a, b), (a.at(t), b.at(t)), reach, t, t_end)
    }

    fn falling() -> Motion {
        Motion::Flight(Flight {
            accel: Vector3::new(0.0, -9.81, 0.0),
            linear_damping: 0.0,
            angular_damping: 0.0,
            gyro: None,
        })
    }

    #[test]
    fn two_falling_balls_meet_when_the_closed_form_says() {
        // 0.5 m apart, closing at 3 m/s, radii 0.1 each: 0.3 m of gap in 0.1 s.
        let a = ball(Vector3::zeros(), Vector3::new(2.0, 0.0, 0.0), falling());
        let b = ball(
            Vector3::new(0.5, 0.0, 0.0),
            Vector3::new(-1.0, 0.0, 0.0),
            falling(),
        );
        let t = touch(&a, &b, 0.2, 0.0, 1.0).unwrap().unwrap();
        assert!((t - 0.1).abs() < 1e-15, "{t}");
        assert_eq!(touch(&a, &b, 0.2, 0.0, 0.09), Ok(None));
        // Moving apart: never.
        let c = ball(
            Vector3::new(0.5, 0.0, 0.0),
            Vector3::new(3.0, 0.0, 0.0),
            falling(),
        );
        assert_eq!(touch(&a, &c, 0.2, 0.0, 1.0), Ok(None));
    }

    #[test]
    fn the_search_finds_a_touch_under_different_accelerations() {
        // One ball in flight, one sliding on the floor (friction slows it): no closed form.
        let slide = Motion::Rolling(Rolling {
            normal: Vector3::y(),
            radius: 0.1,
            inertia_ratio: 0.4,
            friction: 0.3,
            rolling_resistance: 0.0,
            spinning_friction: 0.0,
            accel: Vector3::new(0.0, -9.81, 0.0),
            ground_velocity: Vector3::zeros(),
        });
        let a = ball(
            Vector3::new(0.0, 0.1, 0.0),
            Vector3::new(3.0, 0.0, 0.0),
            slide.clone(),
        );
        let b = ball(Vector3::new(0.6, 0.1, 0.0), Vector3::zeros(), slide);
        let t = touch(&a, &b, 0.2, 0.0, 1.0).unwrap().unwrap();
        let gap = (b.at(t).com - a.at(t).com).norm() - 0.2;
        // Touching to rounding (Newton's last step may land a rounding error inside).
        assert!(gap.abs() <= touch_tolerance(0.2), "gap {gap:e} at {t}");
        // Just before, they do not touch.
        let before = (b.at(t - 1e-9).com - a.at(t - 1e-9).com).norm() - 0.2;
        assert!(before > 0.0);
        // Against uniform motion where the closed form applies, the search agrees.
        let f = |m| {
            Motion::Flight(Flight {
                accel: Vector3::zeros(),
                linear_damping: m,
                angular_damping: 0.0,
                gyro: None,
            })
        };
        let a = ball(Vector3::zeros(), Vector3::new(2.0, 0.3, 0.0), f(1e-300));
        let b = ball(Vector3::new(0.5, 0.0, 0.0), Vector3::zeros(), f(0.0));
        let searched = touch(&a, &b, 0.2, 0.0, 1.0).unwrap().unwrap();
        let b0 = ball(Vector3::new(0.5, 0.0, 0.0), Vector3::zeros(), f(0.0));
        let a0 = ball(Vector3::zeros(), Vector3::new(2.0, 0.3, 0.0), f(0.0));
        let closed = touch(&a0, &b0, 0.2, 0.0, 1.0).unwrap().unwrap();
        assert!((searched - closed).abs() < 1e-12, "{searched} vs {closed}");
    }
}
