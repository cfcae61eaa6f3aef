//! Every threshold the step's decisions use, named once with its unit, and the decisions that
//! are pure functions of them.
//!
//! Contract: [`Role`] is the decision for one body-ground collider pair; [`Policy::new`] derives
//! the step's thresholds from the configuration, gravity and rapier's integration parameters once
//! per step; the decisions (the plan's [`Policy::rests`], the settle stage's table
//! [`Policy::end_action`]) read nothing else and write nothing, so they are unit-tested on
//! synthetic inputs below.

use crate::plugin::bridge::convert::to_f64;
use crate::plugin::config::ImpactConfig;
use crate::rapier::math::Real;

/// Slip speed (m/s) below which a ball on the ground counts as rolling without slip: a
/// rolling ball slower than the resting speed is left to rapier's resting contact, which
/// brings it to rest and to sleep.
pub(crate) const ROLLING_MIN_SLIP: f64 = 1e-3;

/// Speed (m/s) of a ball's centre, and of its surface about the centre, below which a ball on
/// a slope that holds it (`motion::Rolling::holding_tilt`) counts as at rest and is left to
/// rapier's resting contact, which holds it there and sleeps it. The closed form stops it
/// exactly (zero); rapier's contact leaves a held ball up to 1.1e-6 m/s while it sinks to its
/// resting depth (measured on a 3-degree slope at 30 Hz), which must not hand it back. A ball
/// the closed form would still roll, slower than this, stops at most `v^2 (1 + k) / (2 a)`
/// short (`a` its deceleration): 2.3e-8 m at 0.3 m/s^2. On level ground, a ball rapier held at
/// rest last step that moves slower than this (and than the closed form brakes away in a
/// step) stays rapier's too: rapier's solver leaves about 1e-7 m/s on a tile in `f32`.
pub(crate) const HELD_SPEED: f64 = 1e-4;

/// Largest velocity along a ground's normal, relative to its speed, for the ground to count as
/// moving along its own plane (a conveyor, a sliding platform) that a ball can roll on in
/// closed form: the rounding of an in-plane velocity given in `f32`.
pub(crate) const IN_PLANE_TOLERANCE: f64 = 1e-6;

/// Cosine of the widest angle (60 degrees) between gravity's direction and a contact's push
/// on a body for that contact to count as something lying on the body.
pub(crate) const LOADED_COS: f64 = 0.5;

/// Sine of the steepest tilt from the horizontal (the plane normal to gravity) of a touching
/// pair's line of centres for the pair to join a chain of impacts between bodies (a row of
/// balls on a table, Newton's cradle); steeper, one ball lies on the other (a stack) and the
/// pair stays rapier's resting contact.
pub(crate) const CHAIN_MAX_TILT_SIN: f64 = 0.1;

/// May an impact between two bodies of these dominance groups (rapier's effective groups) be
/// the model's? Only of one group: rapier lets a contact between bodies of two groups push
/// only the lower one, as if the other's mass were infinite, so such a pair stays rapier's.
pub(crate) fn model_may_pair(dominance_a: i16, dominance_b: i16) -> bool {
    dominance_a == dominance_b
}

/// A pair of bodies out of rapier's solver whose relative velocity changed over the step by
/// more than this fraction of it (a bounce off the ground, a third body's impact) did not
/// move straight relative to each other: at the step's end, centres that crossed the line
/// of centres they started on may have met on the bent way. Below it, only a straight
/// relative motion that came within reach is a meeting (two balls passing a few
/// millimetres apart do not meet). Damping and friction change it by far less in a step.
pub(crate) const BENT_RELATIVE_MOTION: f64 = 0.1;

/// Relative tolerance of the plane test ([`on_plane`]): a ball that rolled in closed form is
/// still on its plane when its closest ground contact is within this many metres per metre of
/// radius (at least per metre) and the contact's normal is the plane's to this many parts of
/// one (the rounding of the closed form's `f64` arithmetic, far below any real gap).
const ON_PLANE_TOLERANCE: f64 = 1e-9;

/// Is a ball of contact radius `radius` (m), whose closest ground contact is at gap `dist`
/// (m) with unit normal `normal`, still on the plane of unit normal `plane`?
pub(crate) fn on_plane(
    dist: f64,
    normal: &nalgebra::Vector3<f64>,
    plane: &nalgebra::Vector3<f64>,
    radius: f64,
) -> bool {
    dist.abs() <= ON_PLANE_TOLERANCE * radius.max(1.0)
        && normal.dot(plane) >= 1.0 - ON_PLANE_TOLERANCE
}

/// Does a ball of radius `radius` (m) centred at `com`, put on a plane and rolled along it in
/// closed form, stay within [`on_plane`]'s gap through the `f64` rounding of its coordinates?
/// Yes while 64 roundings of its largest coordinate stay below half the tolerance (up to
/// about 35 km from the origin for a ball of 1 m or less): putting it on the plane, the
/// step's phases and the plane query each round by a few. Farther out the rounding alone can
/// leave it off the plane to that measure (2e-9 m at 2e7 m).
pub(crate) fn on_plane_through_rounding(com: &nalgebra::Vector3<f64>, radius: f64) -> bool {
    64.0 * f64::EPSILON * com.amax() <= 0.5 * ON_PLANE_TOLERANCE * radius.max(1.0)
}

// Numerical tolerances of the geometry and of the searches: each the rounding of the
// arithmetic it guards (rapier's `f32` poses, the model's `f64` products), far below any
// physical gap, so that no decision turns on a rounding.

/// Part of an acceleration along a plane, relative to the acceleration, below which the
/// acceleration counts as normal to the plane (a level ground): the rounding of `f64` products
/// of unit vectors.
pub(crate) const LEVEL_TOLERANCE: f64 = 1e-9;

/// Spread of a body's principal inverse inertias, relative to the largest, within which its
/// inertia counts as isotropic (a ball about its centre): rapier computes a ball's three
/// principal inertias alike, so only the rounding of a body built otherwise is allowed.
pub(crate) const ISOTROPIC_TOLERANCE: f64 = 1e-12;

/// Distance (m per m of radius) of a ball's centre from its body's centre of mass within which
/// the ball counts as centred on it: the rounding of the body frame's coordinates.
pub(crate) const CENTRED_TOLERANCE: f64 = 1e-9;

/// How close to a ground counts as touching for the searches, per metre of the body's size,
/// and its bounds (m): small beside rapier's contact skin and prediction distance, large beside
/// the rounding of a contact query in `f32`.
const TOUCH_TOLERANCE: f64 = 1e-3;
/// See [`TOUCH_TOLERANCE`] (m).
const TOUCH_TOLERANCE_MIN: f64 = 1e-7;
/// See [`TOUCH_TOLERANCE`] (m).
const TOUCH_TOLERANCE_MAX: f64 = 1e-3;

/// How close to a ground counts as touching (m) for a body of bounding radius `radius` (m).
pub(crate) fn touch_tolerance(radius: f64) -> f64 {
    (TOUCH_TOLERANCE * radius).clamp(TOUCH_TOLERANCE_MIN, TOUCH_TOLERANCE_MAX)
}

/// Smallest time step (relative to the time, plus 1 s) a root search of a contact time takes
/// before it stops: a few ulps of an `f64` time, where the iterates stop moving.
pub(crate) const ROOT_STEP: f64 = 1e-15;

/// Most conservative-advancement steps a search of the first contact in a step takes, with a
/// ground (`first_impact`) or between two bodies (`first_body_touch`), before it gives up
/// (`Search::Stalled`, `BodyStalled`): a body spinning fast against a ground can need
/// thousands, and the step's end check then keeps it out of the ground.
pub(crate) const ADVANCE_STEPS: usize = 1024;

/// Most iterates of the root search of a contact time (`touch_time`): regula falsi with the
/// Illinois step converges superlinearly, so it reaches `ROOT_STEP` long before.
pub(crate) const ROOT_ITERATIONS: usize = 48;

/// Floor (m/s) of the approach-speed bound of a flight's conservative advancement, so that a
/// body at rest still advances: a thousandth of a micrometre per millisecond.
pub(crate) const FLIGHT_SPEED_FLOOR: f64 = 1e-9;

/// Floor (m/s) of the closing-speed bound of two bodies' conservative advancement, so that two
/// bodies at rest relative to each other still advance.
pub(crate) const BODIES_SPEED_FLOOR: f64 = 1e-12;

/// Relative difference of two balls' centre distance from the sum of their radii within which
/// they touch as found or placed (a pair placed touching in `f32` is off by a few 1e-7 of
/// it); beyond it they overlap, and are resolved as touching ([`resolve_balls`]).
///
/// [`resolve_balls`]: crate::plugin::bridge::resolve::resolve_balls
pub(crate) const TOUCHING_ROUNDING: f64 = 1e-6;

/// Rounding (m per m of distance from the origin, and per m of gap) of a flight's positions
/// and of a contact query's distance, allowed for when a search decides a step is clear.
pub(crate) const POSITION_ROUNDING: f64 = 1e-9;

/// Most conservative-advancement steps a search may need across a step for it to be worth
/// deciding the step clear without searching: the travel of the body's fastest point over its
/// lowest gap.
pub(crate) const CLEAR_SEARCH_STEPS: f64 = 256.0;

/// Rounding (m per m of distance from the origin) of `f32` poses in a face test of parry's
/// shapes (a point on a cuboid face, a support point over a face).
pub(crate) const FACE_ROUNDING: f64 = 1e-6;

/// The face size (m) below which a flat face's rounding allowance stops shrinking.
pub(crate) const FACE_SIZE_FLOOR: f64 = 1e-3;

/// The bounding-sphere test's margin for rapier's `f32` arithmetic: the sphere grown by the
/// factor [`FAR_TEST_GROWTH`], and by this many metres per metre of distance from the origin.
pub(crate) const FAR_TEST_MARGIN: f64 = 1e-4;
/// See [`FAR_TEST_MARGIN`].
pub(crate) const FAR_TEST_GROWTH: f64 = 1.0001;

/// How far (m, plus as many per metre of distance from the origin) a ball's gap to a still
/// ground, as a contact query gives it, may fall below its distance to the ground's box less
/// its radius: the box's `f32` corners and parry's `f32` distance. `GroundGeom::gap_bound`
/// subtracts it; a ground whose bound exceeds the gap that would be taken is not queried.
pub(crate) const GAP_BOUND_SLACK: f64 = 1e-4;

/// Allowance on a torque-free spin's growth bound `I_max / I_min` for the rounding of rapier's
/// `f32` inertias (2 per cent).
pub(crate) const SPIN_UP_ALLOWANCE: f64 = 1.02;

/// How far (relative to the speeds) rapier's linear velocity may differ from a free flight's
/// for the body to count as having flown freely: twenty times rapier's `f32` rounding over
/// its substeps (a few ulps), far below a contact's impulse (all of `|g| dt` at rest).
pub(crate) const MOVED_AS_FLOWN_ROUNDING: f64 = 1e-5;

/// The smallest time (s) whose `f64` spacing the search steps past a time by: below it, the
/// spacing at 1 ms, so that a time near zero still moves.
pub(crate) const TIME_ULP_FLOOR: f64 = 1e-3;

/// A translation below which (m^2, squared) a flight counts as not moving, for comparing it
/// with rapier's CCD-clamped motion.
pub(crate) const STILL_TRAVEL_SQUARED: f64 = 1e-24;

/// Fraction of a step's travel rapier's CCD may stop short of the exact flight besides its
/// integration difference and prediction distance: its own time-of-impact rounding.
pub(crate) const CCD_SLACK: f64 = 1e-3;

/// How many of rapier's roundings of a position (its precision's epsilon, per m of the
/// largest coordinate of the step's path) its end may stand short of the exact flight's
/// besides [`CCD_SLACK`]: far from the origin a slow body's path is a few roundings long.
pub(crate) const CCD_ROUNDINGS: f64 = 4.0;

/// Steps in a row with no managed body near any ground and none asleep after which the
/// grounds' hook flags come off (they go on the first step a body nears a ground, and are
/// not put on before): no ground pair can then have a contact the plugin changes, and each
/// hooked pair would cost a hook call every step. A flag put on or taken off costs rapier an
/// update of the ground's collider, so a scene whose bodies near the ground now and then does
/// not toggle it each time (half a second at 60 Hz).
pub(crate) const GROUND_FLAGS_IDLE_STEPS: u32 = 30;

/// Rest versus bounce, the one rule: a contact approaching at `approach` (m/s) no faster than
/// `floor` (the step's resting speed, or its pressed speed for a body touching something else,
/// [`Policy::bounce_floor`]) rests rather than bounces: it is resolved with `e = 0`, or left to
/// rapier's resting contact. Applied to ground impacts (`ImpactInput::material_at`), to the
/// impulses at the step's start (`plan/impulse.rs`, `pair_plan/step_start.rs`) and to impacts
/// between bodies (`pair_plan/decide.rs`, `pair_reconstruct/cluster.rs`).
pub(crate) fn rests_at(approach: f64, floor: f64) -> bool {
    approach <= floor
}

/// What the plugin does with a body-ground collider pair during the step.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(
    feature = "serde-serialize",
    derive(serde::Serialize, serde::Deserialize)
)]
pub(crate) enum Role {
    /// Out of rapier's solver (and its restitution pass): the plugin resolves it.
    Impact,
    /// In rapier's solver with zero restitution: a resting contact, or a body rolling or
    /// sliding that `Rolling` does not take.
    Resting,
    /// A ball sliding on a level fixed ground, touching nothing else: out of rapier's solver,
    /// moved in closed form after the step (`motion::Rolling`, `reconstruct::rolled`).
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

/// Why the settle stage checks a body's state at the step's end: the rows of its table
/// ([`Policy::end_action`]), one per way a step can leave a body in a ground.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum EndCheck {
    /// The end state of the in-step impacts (`reconstruct.rs`): a safety net.
    Flown,
    /// rapier's end state of a body the search could not fly alone (it touched another body
    /// or a wall, had a joint or a torque, or rapier's CCD cut it short), or of a tumbling
    /// body whose step the search found clear (rapier's integrator turns it its own way).
    RapierEnd,
    /// rapier's end state of a body whose ground pairs were all resting while it turned
    /// fast; `turns_surface`: its rotation moves its surface (not a ball about its centre).
    TurningResting { turns_surface: bool },
    /// rapier's end state of a body asleep at the start and woken inside the step (rapier
    /// solved it without its ground contacts).
    Woken,
    /// rapier's end state of a body whose flight the search found clear, where rapier's
    /// integrator ends lower than that flight (`TimeOfImpact` mode, `StepData::integrator_lag`).
    Lagged,
    /// rapier's end state of a rolling ball something else acted on, in which it flew
    /// without its ground (a steered roll ends on its plane, with the velocities of one that
    /// flew); `fall` (m/s) is the step's fall, `|a.n| dt`, and `plane` the unit normal of the
    /// plane it rolled on. Its row is that plane's ([`EndCheck::row_for`]).
    DisturbedRolling {
        fall: f64,
        plane: nalgebra::Vector3<f64>,
    },
    /// rapier's end state of a ball handed from its closed-form rolling to rapier's resting
    /// contact at the step's start (something else within reach): rapier keeps its resting
    /// depth, but what pushes it in harder (another body) is checked.
    ReleasedResting,
}

impl EndCheck {
    /// The row of the table ([`Policy::end_action`]) for the `k`-th contact the check
    /// resolves (from 0), of unit normal `normal`: the check's own for its first contact,
    /// `RapierEnd` for every later one. A disturbed rolling ball's row is for its plane only,
    /// where a step's fall or a push from above drove it in: any other ground it ended in (a
    /// wall it was pushed into) is met as rapier's end state meets it, with its restitution.
    pub fn row_for(self, k: usize, normal: &nalgebra::Vector3<f64>) -> EndCheck {
        match self {
            _ if k > 0 => EndCheck::RapierEnd,
            EndCheck::DisturbedRolling { plane, .. } if normal.dot(&plane) < PLANE_NORMAL_COS => {
                EndCheck::RapierEnd
            }
            why => why,
        }
    }
}

/// How near a contact's normal is to a disturbed rolling ball's plane normal (the cosine of
/// the angle between them) for the contact to be on its plane ([`EndCheck::row_for`]): the
/// rounding of a face normal from rapier's `f32` vertices, far below any slope's or wall's
/// angle.
const PLANE_NORMAL_COS: f64 = 1.0 - 1e-6;

/// What holds a resting body that turned, asked only when [`EndCheck::TurningResting`] needs
/// it.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(crate) struct Surroundings {
    /// Another body (or a wall, or a joint) touches it.
    pub touching: bool,
    /// Something lies on it (a contact pushing it within [`LOADED_COS`] of gravity).
    pub loaded: bool,
    /// Its resting contact point itself is pushed into the ground faster than the pressed
    /// speed (a body pressed from above, not turning about the contact).
    pub pivot_pushed: bool,
}

/// What the settle stage does with a body's deepest point in a ground at the step's end.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum EndAction {
    /// Nothing to correct (rapier's solver holds it, or it is within the resting gap).
    Keep,
    /// Moved out of the ground along the normal; `stop`: its speed into the ground removed.
    PushOut { stop: bool },
    /// The model's impulse on the end state (`e = 0` if `settle`), then moved out; repeated
    /// on the next deepest point under the `RapierEnd` row.
    Impact { settle: bool },
}

/// How many of rapier's roundings (its precision's epsilon times the coordinate) a steered
/// flight's translation may drift from the exact flight's before the exact one is written
/// ([`carries`]). At 2, the apexes and impact times of the drop tests are those of a
/// flight written every step (rounded to half of one); at 4 the apexes at 1000 Hz lose a
/// third of their accuracy, and each halving costs more writes (idle scene, 1 000 balls:
/// 42, 49, 71 and 242 writes a step at 4, 2, 1 and 0.5).
pub(crate) const STEERED_DRIFT_ROUNDINGS: f64 = 2.0;

/// Does rapier's translation `held` of a steered flight (`stages/steer.rs`) stand for the
/// exact flight's `exact` without a write: each coordinate within
/// [`STEERED_DRIFT_ROUNDINGS`] of rapier's roundings of that coordinate? Beyond it, the exact
/// translation is written.
pub(crate) fn carries(held: &nalgebra::Vector3<f64>, exact: &nalgebra::Vector3<f64>) -> bool {
    let rounding = STEERED_DRIFT_ROUNDINGS * to_f64(Real::EPSILON);
    (0..3).all(|i| (held[i] - exact[i]).abs() <= rounding * exact[i].abs())
}

/// How many of rapier's roundings (its precision's epsilon, in radians) a steered roll's
/// rotation may turn from the closed form's before the closed form's is written
/// ([`carries_turn`]). rapier turns a body by a normalised linear quaternion step in each
/// substep, each rounded in its precision.
pub(crate) const STEERED_TURN_ROUNDINGS: f64 = 4.0;

/// Does rapier's rotation `held` of a steered roll (`stages/steer.rs`) stand for the closed
/// form's `exact` without a write: within [`STEERED_TURN_ROUNDINGS`] roundings of it?
pub(crate) fn carries_turn(
    held: &nalgebra::UnitQuaternion<f64>,
    exact: &nalgebra::UnitQuaternion<f64>,
) -> bool {
    let limit = STEERED_TURN_ROUNDINGS * to_f64(Real::EPSILON);
    let turn = held.rotation_to(exact);
    // The turn's angle is `2 atan(s / c)` (`s`, `c`: the sine and cosine of its half, the
    // quaternion's vector's norm and its scalar's magnitude), and `x (1 - x^2 / 3) <= atan(x)
    // <= x`: half the limit is below 1e-6 rad, where `x^2 / 3` is below 1e-12, so a ratio a
    // millionth inside or outside it decides as the angle does, whatever the roundings of
    // either (a few parts in 1e16). Only between, or where the ratio is not a number, is the
    // angle taken (an arctangent costs a hundred times the ratio).
    let ratio = turn.imag().norm() / turn.scalar().abs();
    let half = 0.5 * limit;
    if ratio <= half * (1.0 - 1e-6) {
        return true;
    }
    if ratio >= half * (1.0 + 1e-6) {
        return false;
    }
    turn.angle() <= limit
}

impl Policy {
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

    /// How far beyond touching a contact is looked for (m): the resting gap or rapier's
    /// prediction distance, whichever is larger (what rapier's narrow phase can report).
    pub fn contact_margin(&self) -> f64 {
        self.resting_gap.max(self.prediction)
    }

    /// Is a ball of contact radius `radius` (m) at rest in `s`: its centre, and its surface
    /// about the centre, no faster than the resting speed?
    pub fn is_still(&self, s: &crate::motion::State, radius: f64) -> bool {
        s.v.norm() <= self.resting_speed && s.w.norm() * radius <= self.resting_speed
    }

    /// The speed below which an impact rests rather than bounces ([`rests_at`]): the pressed
    /// speed for a body that touched another body or a wall in the step (its bounce would
    /// rise less than the resting gap, against rapier's solver holding it), else the resting
    /// speed.
    pub fn bounce_floor(&self, touching: bool) -> f64 {
        if touching {
            self.pressed_speed
        } else {
            self.resting_speed
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

    /// The settle stage's decision table: what becomes of a body checked for `why`, whose
    /// deepest point in a ground is at `dist` (m, negative inside) with normal speed `un`
    /// (m/s, negative approaching). `around` is asked only for a deep turning resting body.
    ///
    /// | why | found | action |
    /// | --- | --- | --- |
    /// | `Flown` | inside | push out, velocity kept |
    /// | `RapierEnd` | touching, approaching | impact |
    /// | `RapierEnd` | deeper than the gap, leaving (it swung through the ground) | push out, velocity kept |
    /// | `Woken` | deeper than the gap, approaching | impact, `e = 0` |
    /// | `Lagged` | deeper than the gap, approaching | impact |
    /// | `Lagged` | deeper than the gap, leaving | push out, velocity kept |
    /// | `DisturbedRolling` | into its plane no faster than the step's fall plus the resting speed | push out, stopped |
    /// | `DisturbedRolling` | faster (something pushed it down) | impact, `e = 0` |
    /// | `DisturbedRolling` | any other ground | as `RapierEnd` ([`EndCheck::row_for`]) |
    /// | `ReleasedResting` | deeper than the gap, approaching | impact, `e = 0` |
    /// | `ReleasedResting` | deeper than the gap, leaving | push out, velocity kept |
    /// | `TurningResting` | deeper than the gap, a point swinging down, not (slow and touching) and not pressed at its pivot | impact, `e = 0` if slower than a fall through the gap |
    /// | `TurningResting` | deeper than the gap otherwise, nothing lying on it | push out (a ball's speed into the ground removed) |
    /// | any | otherwise | keep |
    pub fn end_action(
        &self,
        why: EndCheck,
        dist: f64,
        un: f64,
        around: impl FnOnce() -> Surroundings,
    ) -> EndAction {
        let deep = dist < -self.resting_gap;
        let approaching = un < 0.0;
        match why {
            EndCheck::Flown if dist < 0.0 => EndAction::PushOut { stop: false },
            EndCheck::RapierEnd if dist <= 0.0 && approaching => {
                EndAction::Impact { settle: false }
            }
            EndCheck::RapierEnd if deep => EndAction::PushOut { stop: false },
            EndCheck::Woken if deep && approaching => EndAction::Impact { settle: true },
            EndCheck::Lagged if deep && approaching => EndAction::Impact { settle: false },
            EndCheck::Lagged if deep => EndAction::PushOut { stop: false },
            EndCheck::ReleasedResting if deep && approaching => EndAction::Impact { settle: true },
            EndCheck::ReleasedResting if deep => EndAction::PushOut { stop: false },
            EndCheck::DisturbedRolling { fall, .. } => {
                if un >= -(fall + self.resting_speed) {
                    EndAction::PushOut { stop: true }
                } else {
                    EndAction::Impact { settle: true }
                }
            }
            EndCheck::TurningResting { turns_surface } if deep => {
                let around = around();
                if turns_surface && approaching {
                    let slow = un >= -self.pressed_speed;
                    if !(slow && around.touching || around.pivot_pushed) {
                        return EndAction::Impact { settle: slow };
                    }
                }
                if around.loaded {
                    EndAction::Keep
                } else {
                    EndAction::PushOut {
                        stop: !turns_surface,
                    }
                }
            }
            _ => EndAction::Keep,
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

    fn alone() -> Surroundings {
        Surroundings::default()
    }

    fn never() -> Surroundings {
        panic!("the surroundings are not asked here")
    }

    #[test]
    fn rapiers_end_state_gets_an_impact_a_push_out_or_nothing() {
        let p = policy();
        let rapier_end = |dist, un| p.end_action(EndCheck::RapierEnd, dist, un, never);
        // Touching and approaching: an impact, however shallow.
        assert_eq!(rapier_end(0.0, -0.01), EndAction::Impact { settle: false });
        assert_eq!(rapier_end(-0.02, -1.0), EndAction::Impact { settle: false });
        // Leaving: moved out only from deeper than the gap.
        assert_eq!(rapier_end(-0.02, 0.5), EndAction::PushOut { stop: false });
        assert_eq!(rapier_end(-0.004, 0.5), EndAction::Keep);
        assert_eq!(rapier_end(0.001, -1.0), EndAction::Keep);
        // The in-step flight's end: any depth is moved out, its velocity kept.
        let flown = |dist, un| p.end_action(EndCheck::Flown, dist, un, never);
        assert_eq!(flown(-1e-6, 0.5), EndAction::PushOut { stop: false });
        assert_eq!(flown(0.0, -1.0), EndAction::Keep);
    }

    #[test]
    fn a_woken_body_and_a_disturbed_rolling_ball_are_settled() {
        let p = policy();
        let woken = |dist, un| p.end_action(EndCheck::Woken, dist, un, never);
        // Only deeper than the gap and approaching.
        assert_eq!(woken(-0.006, -0.1), EndAction::Impact { settle: true });
        assert_eq!(woken(-0.004, -0.1), EndAction::Keep);
        assert_eq!(woken(-0.006, 0.1), EndAction::Keep);
        // A step's fall (0.164 m/s at 60 Hz) plus the resting speed puts the ball back;
        // faster is a push.
        let fall = 9.81 / 60.0;
        let plane = nalgebra::Vector3::y();
        let why = EndCheck::DisturbedRolling { fall, plane };
        let rolling = |un| p.end_action(why.row_for(0, &plane), -0.001, un, never);
        assert_eq!(rolling(-0.2), EndAction::PushOut { stop: true });
        assert_eq!(rolling(-0.3), EndAction::Impact { settle: true });
        // Another ground it was pushed into (a wall) is rapier's end state's: an impact
        // with its restitution. So is every contact after the first.
        let wall = nalgebra::Vector3::x();
        assert_eq!(why.row_for(0, &wall), EndCheck::RapierEnd);
        assert_eq!(why.row_for(1, &plane), EndCheck::RapierEnd);
        let into_wall = p.end_action(why.row_for(0, &wall), -0.01, -3.0, never);
        assert_eq!(into_wall, EndAction::Impact { settle: false });
        // A ball released at the start keeps rapier's resting depth; deeper than the gap it
        // is settled if still going in, else moved out.
        let released = |dist, un| p.end_action(EndCheck::ReleasedResting, dist, un, never);
        assert_eq!(released(-0.004, -1.0), EndAction::Keep);
        assert_eq!(released(-0.016, -1.5), EndAction::Impact { settle: true });
        assert_eq!(released(-0.016, 0.1), EndAction::PushOut { stop: false });
    }

    #[test]
    fn a_deep_turning_body_is_resolved_pushed_out_or_left_by_what_holds_it() {
        let p = policy();
        let turned = |dist, un, turns_surface, around: Surroundings| {
            p.end_action(EndCheck::TurningResting { turns_surface }, dist, un, || {
                around
            })
        };
        let touching = Surroundings {
            touching: true,
            ..alone()
        };
        let loaded = Surroundings {
            touching: true,
            loaded: true,
            ..alone()
        };
        // Within the gap: nothing, and nothing asked.
        let box_within = EndCheck::TurningResting {
            turns_surface: true,
        };
        assert_eq!(
            p.end_action(box_within, -0.004, -1.0, never),
            EndAction::Keep
        );
        // A box's corner swinging down fast, alone: a step-end impact with its bounce.
        assert_eq!(
            turned(-0.01, -1.0, true, alone()),
            EndAction::Impact { settle: false }
        );
        // Slowly, alone: settled.
        assert_eq!(
            turned(-0.01, -0.1, true, alone()),
            EndAction::Impact { settle: true }
        );
        // Slowly while touching another body: rapier's, unless nothing lies on it.
        assert_eq!(turned(-0.01, -0.1, true, loaded), EndAction::Keep);
        assert_eq!(
            turned(-0.01, -0.1, true, touching),
            EndAction::PushOut { stop: false }
        );
        // Pushed down at its pivot (pressed from above): not an impact.
        let pressed = Surroundings {
            pivot_pushed: true,
            loaded: true,
            ..alone()
        };
        assert_eq!(turned(-0.01, -1.0, true, pressed), EndAction::Keep);
        // A ball riding low (its surface does not turn): pushed out, its speed into the
        // ground removed, unless loaded.
        assert_eq!(
            turned(-0.01, -1.0, false, touching),
            EndAction::PushOut { stop: true }
        );
        assert_eq!(turned(-0.01, -1.0, false, loaded), EndAction::Keep);
    }

    /// `on_plane_through_rounding`'s promise: a ball it admits, put on a level plane as the
    /// plan puts it (`com - n gap`) and rolled one step in closed form (sliding with spin,
    /// rolling resistance, spinning friction), ends within `on_plane`'s gap of the plane, at
    /// the largest coordinates it admits and under tilted normals.
    #[test]
    fn a_ball_on_a_plane_stays_on_it_through_rounding_where_admitted() {
        use crate::motion::{Rolling, State};
        use nalgebra::{UnitQuaternion, Vector3};
        let mut seed = 0x9e37_79b9_7f4a_7c15_u64;
        let mut next = || {
            seed = seed.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1);
            (seed >> 11) as f64 / (1u64 << 53) as f64
        };
        let mut worst: f64 = 0.0;
        for case in 0..2000 {
            let radius = 0.01 + next();
            let mut unit = || Vector3::new(next() - 0.5, next() - 0.5, next() - 0.5);
            let n = (unit() + Vector3::new(0.0, 1.0, 0.0)).normalize();
            let (v0, w0, dir) = (unit() * 4.0, unit() * 40.0, unit().normalize());
            // At the edge of what is admitted: its largest coordinate within 1 % of the bound.
            let dir = dir / dir.amax();
            let mut edge = 1e12;
            while !on_plane_through_rounding(&(dir * edge), radius) {
                edge *= 0.99;
            }
            let com = dir * edge * (0.99 + 0.01 * next());
            // The plane under it, through a point of the face near it, and the ball put on it.
            let height = n.dot(&com) - radius - 0.01 * (next() - 0.5);
            let gap = |c: &Vector3<f64>| n.dot(c) - height - radius;
            let start = State {
                com: com - n * gap(&com),
                v: v0 - n * n.dot(&v0),
                w: w0,
                rot: UnitQuaternion::identity(),
            };
            let motion = Rolling {
                normal: n,
                radius,
                inertia_ratio: 0.4,
                friction: 0.5,
                rolling_resistance: if case % 2 == 0 { 0.05 } else { 0.0 },
                spinning_friction: if case % 3 == 0 { 0.01 } else { 0.0 },
                accel: n * -9.81,
                ground_velocity: Vector3::zeros(),
            };
            let end = motion.advance(&start, 1.0 / 60.0);
            worst = worst.max(gap(&end.com).abs() / (ON_PLANE_TOLERANCE * radius.max(1.0)));
            assert!(
                on_plane(gap(&end.com), &n, &n, radius),
                "case {case}: {:e}",
                gap(&end.com)
            );
        }
        // The bound keeps a margin: the worst end is well inside the tolerance.
        assert!(worst < 0.5, "worst gap {worst} of the tolerance");
    }

    /// The turn's test decides as the angle between the two rotations does, about the limit
    /// (within a hundredth of it either way, the millionth where the arctangent is taken),
    /// far from it, and at a half turn.
    #[test]
    fn the_turn_test_decides_as_the_angle() {
        use nalgebra::{Unit, UnitQuaternion, Vector3};
        let limit = STEERED_TURN_ROUNDINGS * to_f64(Real::EPSILON);
        let mut seed = 0x2545_f491_4f6c_dd1du64;
        let mut next = || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 11) as f64 / (1u64 << 53) as f64
        };
        let scales = [0.0, 0.5, 0.99, 1.0 - 1e-6, 1.0, 1.0 + 1e-6, 1.01, 2.0, 1e6];
        for case in 0..4000 {
            let axis = Vector3::new(next() - 0.5, next() - 0.5, next() - 0.5);
            let Some(axis) = Unit::try_new(axis, 1e-6) else {
                continue;
            };
            let held = UnitQuaternion::from_euler_angles(7.0 * next(), 7.0 * next(), 7.0 * next());
            let scale = scales[case % scales.len()] * (1.0 + 1e-7 * (next() - 0.5));
            let angle = (limit * scale).min(std::f64::consts::PI);
            let exact = UnitQuaternion::from_axis_angle(&axis, angle) * held;
            assert_eq!(
                carries_turn(&held, &exact),
                held.angle_to(&exact) <= limit,
                "case {case}: angle {:e} of {limit:e}",
                held.angle_to(&exact)
            );
        }
    }
}
