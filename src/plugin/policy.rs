//! Every threshold the step's decisions use, named once with its unit, and the decisions that
//! are pure functions of them.
//!
//! Contract: [`Role`] is the decision for one body-ground collider pair; [`Policy::new`] derives the step's thresholds from the configuration, gravity and
//! rapier's integration parameters once per step; the decisions (the plan's
//! [`Policy::rests`]; the settle stage's [`Policy::deep_resting_body`],
//! [`Policy::step_end_contact`], [`Policy::woken_contact`], [`Policy::disturbed_rolling`]) read
//! nothing else and write nothing, so they are unit-tested on synthetic inputs below.

use super::config::ImpactConfig;

/// Slip speed (m/s) below which a ball on the ground counts as rolling without slip: a
/// rolling ball slower than the resting speed is left to rapier's resting contact, which
/// brings it to rest and to sleep.
pub(crate) const ROLLING_MIN_SLIP: f64 = 1e-3;

/// Cosine of the widest angle (60 degrees) between gravity's direction and a contact's push
/// on a body for that contact to count as something lying on the body.
pub(crate) const LOADED_COS: f64 = 0.5;

/// What the plugin does with a body-ground collider pair during the step.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Role {
    /// Out of rapier's solver (and its restitution pass): the plugin resolves it.
    Impact,
    /// In rapier's solver with zero restitution: a resting contact, or a body rolling or
    /// sliding that `Rolling` does not take.
    Resting,
    /// A ball sliding on a level fixed ground, touching nothing else: out of rapier's solver,
    /// moved in closed form after the step (`motion::Rolling`, `Settle::rolling_end`).
    Rolling,
    /// Left to rapier unchanged, bounce included: parry cannot query the pair.
    Rapier,
    /// A pair rapier would not solve (collision or solver groups, active collision types,
    /// a joint that disables the bodies' contacts: `filter.rs`) or that the user's filter
    /// refuses (`None`, or no rigid impulses): no ground contact for the plugin; rapier and
    /// the user's hook have the pair, unchanged.
    Filtered,
}

/// The thresholds of one step. Speeds are normal speeds of a contact point relative to the
/// ground; lengths are along the contact normal.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(crate) struct Policy {
    /// Resting speed (m/s): a contact within the resting gap that approaches no faster than
    /// this is a resting contact (rapier's, with `e = 0`); an impact found slower is resolved
    /// with `e = 0`. `ImpactConfig::resting_speed`, or `max(|g| dt / 2, 1 mm/s)`: the speed
    /// gravity adds in half a step.
    pub resting_speed: f64,
    /// Resting gap (m): how close to the ground a slow contact must be to rest.
    /// `ImpactConfig::resting_gap`, or rapier's allowed linear error.
    pub resting_gap: f64,
    /// Pressed speed (m/s), `max(sqrt(2 |g| gap), resting_speed)`: the speed of a fall
    /// through the resting gap. A body touching another body that arrives no faster stays
    /// resting: its bounce would rise less than the gap and could only be resolved at the
    /// step end, against rapier's solver holding the body on it.
    pub pressed_speed: f64,
    /// Held speed (m/s), `max(4 resting_speed, 2 |g| dt)`: the hysteresis of a pair rapier
    /// held at rest last step. rapier's solver leaves normal speeds up to about `g dt` (more
    /// for a fast-rolling ball) at rest, so such a pair stays resting unless clearly hit.
    pub held_speed: f64,
    /// rapier's prediction distance (m): its CCD stops a body up to this short of a contact.
    pub prediction: f64,
}

/// What becomes of a body whose ground pairs were all resting while it turned, and that
/// ends the step deeper than the resting gap (see [`Policy::deep_resting_body`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum DeepResting {
    /// Not deeper than the resting gap: nothing to do.
    Within,
    /// A point swung down into the ground: resolved as a step-end impact, settled (`e = 0`)
    /// when it approaches slower than a fall through the gap.
    Resolve { settle: bool },
    /// Rapier's contact under-supported it with nothing lying on it: moved out.
    PushOut,
    /// Something lies on it, or it is pressed: rapier's solver holds it.
    LeaveToRapier,
}

/// What the settle stage does with a body's deepest point against a ground at the step's end
/// (see [`Policy::step_end_contact`], [`Policy::woken_contact`], [`Policy::disturbed_rolling`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum EndContact {
    /// Nothing to correct.
    Keep,
    /// Moved out of the ground along the normal (a ball's speed into it removed).
    PushOut,
    /// The model's impulse on rapier's end state, then moved out.
    Impact,
}

impl Policy {
    /// The step-end fallback's decision for the deepest point, at `dist` (m, negative inside)
    /// with normal speed `un` (m/s, negative approaching): an impact when it touches and
    /// approaches; a push-out, velocity kept, when it leaves from deeper than the resting gap
    /// (it swung through the ground inside the step); else nothing.
    pub fn step_end_contact(&self, dist: f64, un: f64) -> EndContact {
        if dist <= 0.0 && un < 0.0 {
            EndContact::Impact
        } else if dist < -self.resting_gap {
            EndContact::PushOut
        } else {
            EndContact::Keep
        }
    }

    /// A body woken inside the step (rapier solved it without its ground contacts): an
    /// impact with `e = 0` when its deepest point is deeper than the resting gap and
    /// approaching, else nothing.
    pub fn woken_contact(&self, dist: f64, un: f64) -> EndContact {
        if dist < -self.resting_gap && un < 0.0 {
            EndContact::Impact
        } else {
            EndContact::Keep
        }
    }

    /// A rolling ball that something else acted on, in rapier's end state where it flew
    /// without its ground: put back on the ground when it moves into it (`un`, m/s) no faster
    /// than the step's fall `fall` (m/s, `|a.n| dt`) plus the resting speed, as rapier's
    /// resting contact would have held it; else (something pushed it down) an impact with
    /// `e = 0`.
    pub fn disturbed_rolling(&self, un: f64, fall: f64) -> EndContact {
        if un >= -(fall + self.resting_speed) {
            EndContact::PushOut
        } else {
            EndContact::Impact
        }
    }

    /// The thresholds for a step of `dt` seconds under gravity of magnitude `g` (m/s^2), with
    /// rapier's allowed linear error and prediction distance (m).
    pub fn new(
        config: &ImpactConfig,
        g: f64,
        dt: f64,
        allowed_linear_error: f64,
        prediction: f64,
    ) -> Self {
        let resting_speed = config.resting_speed.unwrap_or((0.5 * g * dt).max(1e-3));
        let resting_gap = config.resting_gap.unwrap_or(allowed_linear_error);
        Self {
            resting_speed,
            resting_gap,
            pressed_speed: (2.0 * g * resting_gap).sqrt().max(resting_speed),
            held_speed: (4.0 * resting_speed).max(2.0 * g * dt),
            prediction,
        }
    }

    /// Does a body-ground pair at gap `dist` (m, negative inside) rest this step, arriving at
    /// the ground at normal speed `arrival` (m/s, `>= 0`)? `was_resting`: rapier held the
    /// pair at rest last step. `pressed`: asked only where it decides, whether the body
    /// touched another body (or a wall, or has a joint) after the last step.
    pub fn rests(
        &self,
        dist: f64,
        arrival: f64,
        was_resting: bool,
        pressed: impl FnOnce() -> bool,
    ) -> bool {
        if dist > self.resting_gap {
            return false;
        }
        let limit = if was_resting {
            self.held_speed
        } else {
            self.resting_speed
        };
        arrival <= limit || (was_resting || arrival <= self.pressed_speed) && pressed()
    }

    /// The end-of-step decision for a body whose ground pairs were all resting while it
    /// turned fast, from its deepest point at the step's end: `dist` (m, negative inside)
    /// and its normal speed `un` (m/s, negative approaching). `turns_surface`: its rotation
    /// moves its surface (not a ball about its centre). `pivot_pushed`: its resting contact
    /// point itself is pushed into the ground faster than the pressed speed (a body pressed
    /// from above, not turning about the contact). `touching` and `loaded`: another body
    /// touches it, lies on it.
    pub fn deep_resting_body(
        &self,
        dist: f64,
        un: f64,
        turns_surface: bool,
        pivot_pushed: impl FnOnce() -> bool,
        touching: bool,
        loaded: bool,
    ) -> DeepResting {
        if dist >= -self.resting_gap {
            return DeepResting::Within;
        }
        if turns_surface && un < 0.0 {
            let slow = un >= -self.pressed_speed;
            if !(slow && touching || pivot_pushed()) {
                return DeepResting::Resolve { settle: slow };
            }
        }
        if loaded {
            DeepResting::LeaveToRapier
        } else {
            DeepResting::PushOut
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// 60 Hz under 9.81 m/s^2, a 5 mm gap: resting speed 0.082 m/s, pressed 0.313 m/s, held
    /// 0.327 m/s.
    fn policy() -> Policy {
        Policy::new(&ImpactConfig::default(), 9.81, 1.0 / 60.0, 0.005, 0.002)
    }

    #[test]
    fn thresholds_follow_gravity_the_step_and_the_gap() {
        let p = policy();
        assert_eq!(p.resting_speed, 0.5 * 9.81 / 60.0);
        assert_eq!(p.resting_gap, 0.005);
        assert_eq!(p.pressed_speed, (2.0f64 * 9.81 * 0.005).sqrt());
        assert_eq!(p.held_speed, 2.0 * 9.81 / 60.0);
        // Without gravity, the floors.
        let free = Policy::new(&ImpactConfig::default(), 0.0, 1.0 / 60.0, 0.005, 0.002);
        assert_eq!((free.resting_speed, free.pressed_speed), (1e-3, 1e-3));
        // The configuration's values win.
        let config = ImpactConfig {
            resting_speed: Some(0.5),
            resting_gap: Some(0.01),
            ..Default::default()
        };
        let set = Policy::new(&config, 9.81, 1.0 / 60.0, 0.005, 0.002);
        assert_eq!(
            (set.resting_speed, set.resting_gap, set.held_speed),
            (0.5, 0.01, 2.0)
        );
    }

    #[test]
    fn a_slow_pair_within_the_gap_rests_and_a_fast_or_far_one_does_not() {
        let p = policy();
        let never = || panic!("the neighbours are not asked here");
        assert!(p.rests(0.004, 0.05, false, never));
        assert!(p.rests(-0.02, 0.0, false, never));
        assert!(!p.rests(0.006, 0.0, false, never));
        // Faster than the resting speed, alone: an impact.
        assert!(!p.rests(0.0, 0.2, false, || false));
    }

    #[test]
    fn a_pair_held_at_rest_stays_resting_below_the_held_speed() {
        let p = policy();
        assert!(p.rests(0.0, 0.3, true, || false));
        assert!(!p.rests(0.0, 0.4, true, || false));
        assert!(!p.rests(0.0, 0.3, false, || false));
    }

    #[test]
    fn a_pressed_body_rests_below_a_fall_through_the_gap_or_when_held() {
        let p = policy();
        assert!(p.rests(0.0, 0.3, false, || true));
        assert!(!p.rests(0.0, 0.32, false, || true));
        // Held at rest last step and pressed: rests however fast it is pushed.
        assert!(p.rests(0.0, 5.0, true, || true));
        // Beyond the gap the neighbours do not matter.
        assert!(!p.rests(0.01, 0.0, true, || true));
    }

    #[test]
    fn the_step_end_contacts_are_impacts_push_outs_or_nothing() {
        let p = policy();
        // Touching and approaching: an impact, however shallow.
        assert_eq!(p.step_end_contact(0.0, -0.01), EndContact::Impact);
        assert_eq!(p.step_end_contact(-0.02, -1.0), EndContact::Impact);
        // Leaving: moved out only from deeper than the gap.
        assert_eq!(p.step_end_contact(-0.02, 0.5), EndContact::PushOut);
        assert_eq!(p.step_end_contact(-0.004, 0.5), EndContact::Keep);
        assert_eq!(p.step_end_contact(0.001, -1.0), EndContact::Keep);
        // A woken body: only deeper than the gap and approaching.
        assert_eq!(p.woken_contact(-0.006, -0.1), EndContact::Impact);
        assert_eq!(p.woken_contact(-0.004, -0.1), EndContact::Keep);
        assert_eq!(p.woken_contact(-0.006, 0.1), EndContact::Keep);
        // A disturbed rolling ball: a step's fall (0.164 m/s at 60 Hz) plus the resting speed
        // puts it back; faster is a push.
        let fall = 9.81 / 60.0;
        assert_eq!(p.disturbed_rolling(-0.2, fall), EndContact::PushOut);
        assert_eq!(p.disturbed_rolling(-0.3, fall), EndContact::Impact);
    }

    #[test]
    fn a_deep_body_is_resolved_pushed_out_or_left_by_what_holds_it() {
        let p = policy();
        let never = || panic!("the pivot is not asked here");
        // Within the gap: nothing.
        assert_eq!(
            p.deep_resting_body(-0.004, -1.0, true, never, false, false),
            DeepResting::Within
        );
        // A box's corner swinging down fast, alone: a step-end impact with its bounce.
        assert_eq!(
            p.deep_resting_body(-0.01, -1.0, true, || false, false, false),
            DeepResting::Resolve { settle: false }
        );
        // Slowly, alone: settled.
        assert_eq!(
            p.deep_resting_body(-0.01, -0.1, true, || false, false, false),
            DeepResting::Resolve { settle: true }
        );
        // Slowly while touching another body: rapier's, unless nothing lies on it.
        assert_eq!(
            p.deep_resting_body(-0.01, -0.1, true, never, true, true),
            DeepResting::LeaveToRapier
        );
        assert_eq!(
            p.deep_resting_body(-0.01, -0.1, true, never, true, false),
            DeepResting::PushOut
        );
        // Pushed down at its pivot (pressed from above): not an impact.
        assert_eq!(
            p.deep_resting_body(-0.01, -1.0, true, || true, false, true),
            DeepResting::LeaveToRapier
        );
        // A ball riding low (its surface does not turn): pushed out unless loaded.
        assert_eq!(
            p.deep_resting_body(-0.01, -1.0, false, never, true, false),
            DeepResting::PushOut
        );
        assert_eq!(
            p.deep_resting_body(-0.01, -1.0, false, never, false, true),
            DeepResting::LeaveToRapier
        );
    }
}
