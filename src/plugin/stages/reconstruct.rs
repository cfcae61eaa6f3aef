//! Reconstruct: a body's motion over the step from its start state, through the impacts the
//! in-step search finds, as it would have been had rapier not solved its ground contacts;
//! and a rolling ball's closed-form motion ([`rolled`]).
//!
//! Contract: [`through_impacts`] takes a body that flew alone in the step (no other contact,
//! joint or torque, rapier's CCD consistent with its flight) and the first impact the search
//! found; it flies the body to each impact (`crate::motion`), resolves it with the model
//! (`resolve.rs`), and flies on, up to `ImpactConfig::max_impacts_per_step` impacts (the last
//! with `e = 0`); an impact slower than the resting speed settles the body. An impact that
//! sends the body beyond its plan's reach (a bat's hit) adds the grounds along its new way to
//! the search ([`grounds_beyond_plan`]). It returns the state at the step's end, with the
//! grounds searched, and reports every impulse and correction as an event. It writes
//! nothing into rapier: the caller has the settle stage check that state (`EndCheck::Flown`:
//! a body never left inside a ground) and commits it.

use crate::motion::{Flight, Rolling, State};
use crate::plugin::bridge::convert::{to_f64, to_real, vec_from_na, vec_to_na};
use crate::plugin::bridge::resolve::{
    GroundContactAt, ImpactInput, Inertia, Site, correction, resolve,
};
use crate::plugin::events::{EventKind, ImpactEvent, ImpactTiming};
use crate::plugin::policy::on_plane;
use crate::plugin::policy::{
    CCD_ROUNDINGS, CCD_SLACK, GAP_BOUND_SLACK, MOVED_AS_FLOWN_ROUNDING, Role, STILL_TRAVEL_SQUARED,
};
use crate::plugin::queries::geometry::{
    BodyGeom, BodyPart, GroundGeom, Hit, Search, WayBound, closest, earliest_touch, first_impact,
};
use crate::plugin::queries::observe::Sets;
use crate::plugin::stages::view::AfterStep;
use crate::plugin::stages::view::EndOfStep;
use crate::plugin::state::step::StepData;
use crate::plugin::state::step::{Candidate, SteeredRoll};
use crate::plugin::state::writes::Now;
use crate::rapier::math::Real;
use crate::rapier::prelude::{ColliderHandle, ColliderSet, RigidBodySet};
use nalgebra::Vector3;

/// One candidate as this stage reconstructs it: the plan's candidate, its colliders, the
/// grounds it is checked against, and the step.
pub(crate) struct Subject<'s> {
    pub cand: &'s Candidate,
    pub geom: &'s BodyGeom<'s>,
    pub grounds: &'s [GroundGeom<'s>],
    /// The grounds from this index on are checked only deeper than the resting gap
    /// (`Checked::joined`).
    pub joined: usize,
    pub step: &'s EndOfStep<'s>,
}

impl<'s> Subject<'s> {
    pub fn new(
        cand: &'s Candidate,
        geom: &'s BodyGeom<'s>,
        grounds: &'s [GroundGeom<'s>],
        step: &'s EndOfStep<'s>,
    ) -> Self {
        Self {
            cand,
            geom,
            grounds,
            joined: grounds.len(),
            step,
        }
    }
}

/// The body's state at the step's end after the impacts from `first` on (see the module's
/// contract), and the grounds searched, where an impact sent the body beyond its plan's
/// reach (`None`: `subject.grounds`); `view` receives the events.
pub(crate) fn through_impacts<'s>(
    view: &mut AfterStep,
    (bodies, colliders): (&RigidBodySet, &'s ColliderSet),
    subject: &Subject<'s>,
    inertia: &Inertia,
    first: Search,
) -> (State, Option<Vec<GroundGeom<'s>>>) {
    let (cand, geom, step) = (subject.cand, subject.geom, subject.step);
    let mut widened: Option<Vec<GroundGeom<'s>>> = None;
    let mut next = first;
    let mut flight = cand.flight.clone();
    let mut seg = cand.start;
    let mut seg_t0 = 0.0;
    // Where the flight stops short of the step's end, if it does.
    let mut stop: Option<State> = None;
    let mut count = 0usize;
    loop {
        let (t, s, hit) = match next {
            Search::Clear => break,
            // Never fly past a contact the search could not resolve: the rest of the
            // step is dropped for this body (it touches no ground there).
            Search::Stalled(_, s) => {
                stop = Some(s);
                break;
            }
            Search::Hit(t, s, hit) => (t, s, hit),
        };
        let grounds = widened.as_deref().unwrap_or(subject.grounds);
        let part = &geom.parts[hit.part];
        let gg = &grounds[hit.ground];
        let (material, point, points) = view.landing(colliders, (geom, gg), (&s, t), &hit);
        let (law, resting_speed) = (view.config.law, step.policy.resting_speed);
        let last_allowed = count + 1 >= view.config.max_impacts_per_step;
        let input = ImpactInput::new(
            cand.body,
            inertia,
            law,
            material,
            resting_speed,
            ImpactTiming::InStep,
        )
        .forced_to_settle(last_allowed);
        count += 1;
        seg = s;
        seg_t0 = t;
        // If neither its landing point nor its deepest point approaches, the flight stops.
        let Some((after, event)) =
            resolve_landing(&input, (geom, gg), (&s, t), &hit, point, points)
        else {
            stop = Some(s);
            break;
        };
        seg = after;
        let settled = event.settled;
        view.commit.event(event);
        // A settled impact on a body whose centre of mass leaves the ground (a
        // spinning cube's corner swinging down while it rises) does not rest it: holding
        // gravity off would lift it, with energy gained, for the rest of the step. It flies
        // on, with gravity, to its next impact.
        let site = Site {
            body: cand.body,
            collider: part.handle,
            ground: gg.handle,
            body2: None,
            normal: hit.normal,
            point,
        };
        let rests = settled && rest_on_ground(view, &site, inertia, &mut flight, &mut seg, t, step);
        // The grounds its way on may reach, for the search and for the settle stage's check.
        let sets = (bodies, colliders, &step.sets);
        if let Some(all) = grounds_beyond_plan(view, sets, subject, grounds, (&seg, &flight, t)) {
            widened = Some(all);
        }
        // The last impact allowed in the step (forced settled) on a leaving body: it flies
        // on; the settle stage's check keeps it out of the ground.
        if rests || count >= view.config.max_impacts_per_step {
            break;
        }
        let grounds = widened.as_deref().unwrap_or(subject.grounds);
        next = first_impact(geom, grounds, &flight, &seg, seg_t0, seg_t0, step.dt);
    }
    let end = stop.unwrap_or_else(|| flight.advance(&seg, step.dt - seg_t0));
    (end, widened)
}

/// The impact of the body (`geom`, at `s`, time `t`) on `gg` at `hit`, at its landing point
/// `point` (the centroid of `points` contact points), or, if that does not approach, at the
/// deepest point; `None` if neither approaches.
fn resolve_landing(
    input: &ImpactInput,
    (geom, gg): (&BodyGeom, &GroundGeom),
    (s, t): (&State, f64),
    hit: &Hit,
    point: Vector3<f64>,
    points: usize,
) -> Option<(State, ImpactEvent)> {
    resolve(
        input,
        geom,
        gg,
        s,
        t,
        &GroundContactAt::new(hit, point, points),
    )
    .or_else(|| {
        resolve(
            input,
            geom,
            gg,
            s,
            t,
            &GroundContactAt::new(hit, hit.point, 1),
        )
    })
}

/// `searched` and the grounds that a body leaving an impact at `s` (time `t`, flying on by
/// `flight`; in `Step` mode, the step's start after its impulses) may reach in the rest of
/// the step that `searched` does not hold; `None` if there are none. Its plan looked for
/// grounds as far as its start-of-step motion could take it (`Candidate::looked_in`), and
/// an impact with a moving ground (a bat) can send it much faster, into a wall beyond that:
/// - while its way on leaves that ball, the grounds along the way that the plan did not find
///   (no role: the pairs rapier would not solve, or a joint or the user's filter refuses, or
///   whose coefficients are the plugin's to refuse, are skipped; `AfterStep::unplanned_geom`);
/// - the grounds the plan found out of reach (all their pairs `Impact`, out of rapier's
///   solver, but not searched), where its way on leaves that ball or its turn moves its
///   surface (a spin from the impact can swing a rod's end farther than the plan's bound).
///
/// Reads only.
pub(crate) fn grounds_beyond_plan<'s>(
    view: &AfterStep,
    sets: (&RigidBodySet, &'s ColliderSet, &Sets),
    subject: &Subject<'s>,
    searched: &[GroundGeom<'s>],
    (s, flight, t): (&State, &Flight, f64),
) -> Option<Vec<GroundGeom<'s>>> {
    let (cand, geom, step) = (subject.cand, subject.geom, subject.step);
    let margin = step.policy.contact_margin();
    let way = WayBound::new(s, flight.accel.norm(), geom.radius, step.dt - t, margin);
    // Within the ball the plan looked in (queried in rapier's precision: its rounding
    // allowed for), no ground it did not find.
    let (looked_centre, looked_radius) = cand.looked_in;
    let rounding = GAP_BOUND_SLACK * (1.0 + looked_centre.norm());
    let beyond = (way.centre - looked_centre).norm() + way.ball_radius() > looked_radius - rounding;
    if !beyond && !cand.turns_surface {
        return None;
    }
    let unsearched = |handle: ColliderHandle| !searched.iter().any(|g| g.handle == handle);
    let mut more: Vec<_> = cand
        .near
        .iter()
        .filter(|i| !cand.impact_grounds.contains(i) && unsearched(step.grounds[**i].handle))
        .filter(|i| out_of_reach_impacts(view, geom, step.grounds[**i].handle))
        .filter_map(|i| view.pair_geom(&step.grounds[*i], geom, sets.1))
        .collect();
    // A non-finite way (parry's tree cannot take it) has no ground to add.
    let (centre, half) = (vec_from_na(&way.centre), to_real(way.cube_half()));
    if beyond && centre.is_finite() && half.is_finite() {
        let tiles = geom
            .parts
            .iter()
            .any(|part| step.by_tile.contains(&part.handle));
        let found = view
            .registry
            .index
            .near_cube(&step.grounds, centre, half, tiles);
        more.extend(
            found
                .iter()
                .filter(|i| !cand.near.contains(i) && unsearched(step.grounds[**i].handle))
                .filter_map(|i| view.unplanned_geom(&step.grounds[*i], sets, cand.body, geom)),
        );
    }
    (!more.is_empty()).then(|| searched.iter().cloned().chain(more).collect())
}

/// Did the plan find the ground `ground` out of the body's (`geom`) reach: every pair of it
/// with the body `Impact` or `Filtered`, one at least `Impact`? (Such a ground is out of
/// rapier's solver and not among the candidate's `Impact` grounds.)
fn out_of_reach_impacts(view: &AfterStep, geom: &BodyGeom, ground: ColliderHandle) -> bool {
    let role = |part: &BodyPart| view.roles.get(&(part.handle, ground)).copied();
    geom.parts
        .iter()
        .all(|part| matches!(role(part), Some(Role::Impact | Role::Filtered)))
        && geom
            .parts
            .iter()
            .any(|part| role(part) == Some(Role::Impact))
}

/// A `Role::Rolling` ball's closed-form motion over the step from its start (which touches
/// the ground), if nothing else acted on it: its end state, when it still touches the same
/// ground plane there (`None`: rapier's end state stands, for the settle stage to check).
pub(crate) fn rolled(
    cand: &Candidate,
    motion: &Rolling,
    geom: &BodyGeom,
    grounds: &[GroundGeom],
    step: &EndOfStep,
) -> Option<State> {
    let end = motion.advance(&cand.start, step.dt);
    let hit = closest(geom, grounds, &end, step.dt, step.policy.resting_gap)?;
    let on_plane = on_plane(hit.dist, &hit.normal, &motion.normal, motion.radius);

    on_plane.then_some(end)
}

/// The first time in the step a `Role::Rolling` ball, moved by `motion` from the candidate's
/// start, touches one of `obstacles` (the grounds near it not of its plane: a slope's foot,
/// a wall), with its state and the contact there ([`earliest_touch`]; a graze between two
/// samples is left to the end check, `rolled`, which then finds the ball off its plane).
pub(crate) fn rolling_touch(
    cand: &Candidate,
    motion: &Rolling,
    geom: &BodyGeom,
    obstacles: &[GroundGeom],
    step: &EndOfStep,
) -> Option<(f64, State, Hit)> {
    let reach = step.policy.contact_margin();
    let at = |t: f64| {
        let s = motion.advance(&cand.start, t);
        let hit = closest(geom, obstacles, &s, t, reach);
        (s, hit)
    };
    let t = earliest_touch(step.dt, |t| at(t).1.is_some_and(|h| h.dist <= 0.0))?;
    let (s, hit) = at(t);
    Some((t, s, hit?))
}

/// After a settled impact at `site` (time `t`): unless the state `s` leaves the ground faster
/// than the resting speed, the body rests from there: the contact holds the acceleration into
/// the ground for the rest of the step (`flight`), and the remaining speed into the ground is
/// removed (a `Settle` event). Returns whether it rests.
pub(crate) fn rest_on_ground(
    view: &mut AfterStep,
    site: &Site,
    inertia: &Inertia,
    flight: &mut Flight,
    s: &mut State,
    t: f64,
    step: &EndOfStep,
) -> bool {
    let n = site.normal;
    if n.dot(&s.v) > step.policy.resting_speed {
        return false;
    }
    let an = n.dot(&flight.accel);
    if an < 0.0 {
        flight.accel -= n * an;
    }
    let vn = n.dot(&s.v);
    if vn < 0.0 {
        let before = *s;
        s.v -= n * vn;
        view.commit
            .event(correction(EventKind::Settle, site, inertia, &before, s, t));
    }
    true
}

/// A candidate's free flight over the whole step from its start state, as far as its checks
/// and `Exact` mode's flight read it: the centre of mass's end, computed once, when first
/// asked (several checks of one body read it), and the end spin of a body whose spin keeps
/// its axis. No reader takes the flight's end rotation (`Exact` mode keeps rapier's), which
/// costs most of the flight to compute.
pub(crate) struct FlownEnd<'c> {
    cand: &'c Candidate,
    dt: f64,
    centre: std::cell::OnceCell<(Vector3<f64>, Vector3<f64>)>,
}

impl<'c> FlownEnd<'c> {
    pub fn new(cand: &'c Candidate, dt: f64) -> Self {
        Self {
            cand,
            dt,
            centre: std::cell::OnceCell::new(),
        }
    }

    /// The candidate that flies.
    pub fn candidate(&self) -> &'c Candidate {
        self.cand
    }

    /// The centre of mass's position and velocity the flight reaches at the step's end (those
    /// of `Flight::advance`).
    pub fn centre(&self) -> &(Vector3<f64>, Vector3<f64>) {
        self.centre
            .get_or_init(|| self.cand.flight.advance_centre(&self.cand.start, self.dt))
    }

    /// The spin at the step's end of a body whose spin keeps its axis (no gyroscopic
    /// motion: `Flight::gyro` `None`), that of `Flight::advance`.
    pub fn spin_keeping_axis(&self) -> Vector3<f64> {
        self.cand
            .flight
            .spin_keeping_axis(&self.cand.start.w, self.dt)
    }
}

/// Did rapier's step change the body's linear velocity only as its flight does (gravity and
/// any force, damping), to rapier's rounding? An impulse from a contact shows as more: a
/// resting contact takes back all of `|g| dt`.
pub(crate) fn moved_as_flown(body: &Now, flown: &FlownEnd, step: &StepData) -> bool {
    let (cand, dt) = (flown.cand, flown.dt);
    let flown = flown.centre().1;
    let actual = vec_to_na(body.linvel());
    // A steered flight (`steer.rs`) changes rapier's velocity as the flight changes its own,
    // from the velocity rapier held.
    let (from, expected) = match cand.steered_velocity(step.steering_lag).map(vec_to_na) {
        None => (cand.start.v, flown),
        Some(held) => (held, held + (flown - cand.start.v)),
    };
    // rapier adds the step's velocity change in its substeps, in its precision, and damps
    // once at the step's end, `(v0 + a dt) / (1 + c dt)`, where the flight decays exactly:
    // `v0 (c dt)^2 / 2` and `|a| dt c dt / 2` apart (twice those allowed).
    let scale = from.norm() + expected.norm() + cand.flight.accel.norm() * dt;
    let x = cand.flight.linear_damping * dt;
    let damping = x * x * from.norm() + x * cand.flight.accel.norm() * dt;
    (actual - expected).norm() <= MOVED_AS_FLOWN_ROUNDING * scale + damping
}

/// Was the body's motion in the step cut short by rapier's CCD only at (or after) its first
/// ground impact at `t_first`? If rapier clamped it earlier, something other than a ground
/// stopped it, and re-integrating its flight would undo that.
pub(crate) fn ccd_consistent(body: &Now, flown: &FlownEnd, t_first: f64, step: &StepData) -> bool {
    let (cand, dt) = (flown.cand, flown.dt);
    if !body.rb().is_ccd_active() {
        return true;
    }
    let path = (&cand.start.com, &flown.centre().0);
    let accel = cand.flight.accel.norm();
    ccd_reached(
        body,
        path,
        (t_first / dt, accel, step.policy.prediction),
        step,
    )
}

/// [`ccd_consistent`] for a body with no ground to search (no `Impact` pair: none in reach,
/// or only pairs rapier's solver has, which a body that flew alone does not touch): rapier's
/// CCD had no ground to stop it a prediction distance before, so it must have carried the
/// body the whole way, but for the integration difference and rounding. Any shorter is a
/// collider that is not a ground (a table the body falls onto), whose contact rapier's end
/// state keeps.
pub(crate) fn ccd_consistent_far(body: &Now, flown: &FlownEnd, step: &StepData) -> bool {
    let cand = flown.cand;
    if !body.rb().is_ccd_active() {
        return true;
    }
    let path = (&cand.start.com, &flown.centre().0);
    ccd_reached(body, path, (1.0, cand.flight.accel.norm(), 0.0), step)
}

/// A steered roll's [`ccd_consistent`]: did rapier's CCD leave the ball where the steering
/// took it, its roll's end (`steer.rs`)?
pub(crate) fn ccd_consistent_steered(
    body: &Now,
    cand: &Candidate,
    steered: &SteeredRoll,
    step: &StepData,
) -> bool {
    if !body.rb().is_ccd_active() {
        return true;
    }
    let path = (&steered.from, &steered.end.com);
    let accel = cand.flight.accel.norm();
    ccd_reached(body, path, (1.0, accel, step.policy.prediction), step)
}

/// Did the body (`body`, at the step's end) get at least the fraction `reached` of the way
/// from `from` to `to`, its path in the step, under an acceleration of magnitude `accel`, but
/// for stopping up to `before` (m) short of a contact (rapier's prediction distance, where a
/// ground may have stopped it)? A path shorter than rounding always does.
fn ccd_reached(
    body: &Now,
    (from, to): (&Vector3<f64>, &Vector3<f64>),
    (reached, accel, before): (f64, f64, f64),
    step: &StepData,
) -> bool {
    let exact = to - from;
    let len2 = exact.norm_squared();
    if len2 < STILL_TRAVEL_SQUARED {
        return true;
    }
    let dt = step.dt;
    let actual = vec_to_na(body.center_of_mass()) - from;
    let fraction = actual.dot(&exact) / len2;
    // rapier's flight differs from the exact one by about |a| dt^2 / 2, its CCD stops a
    // body up to about a prediction distance before the contact, and it holds the end in its
    // precision.
    let rounding = CCD_ROUNDINGS * to_f64(Real::EPSILON) * (from.amax() + to.amax());
    let slack = (accel * dt * dt + before + rounding) / len2.sqrt() + CCD_SLACK;
    fraction >= reached - slack
}
