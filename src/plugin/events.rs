//! What the plugin reports after each step: one [`ImpactEvent`] per change it made to a
//! body (an impact, or a correction of rapier's end-of-step state; see [`EventKind`]).

use crate::model::{Fallback, Law, Regime};
use crate::rapier::math::Vector;
use crate::rapier::prelude::{ColliderHandle, RigidBodyHandle};

/// When in the step an impact was applied (see [`crate::TimingMode`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[cfg_attr(
    feature = "serde-serialize",
    derive(serde::Serialize, serde::Deserialize)
)]
#[non_exhaustive]
pub enum ImpactTiming {
    /// At its exact time inside the step (`TimeOfImpact` and `Exact` modes).
    InStep,
    /// At the start of the step, to the start-of-step velocity (`Step` mode).
    StepStart,
    /// At the end of the step, on rapier's end-of-step state: an impact of the fallback for a
    /// body that also touched something else (another body, a non-ground collider through
    /// rapier's CCD), had a joint or a torque in the step, so that its flight could not be
    /// re-integrated alone (the body pushed out of the ground along the normal), or of the
    /// settle stage's checks; and every push-out and energy cap.
    StepEnd,
}

/// What changed a body.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[cfg_attr(
    feature = "serde-serialize",
    derive(serde::Serialize, serde::Deserialize)
)]
#[non_exhaustive]
pub enum EventKind {
    /// A ground impact resolved by the model: an impulse at the contact point.
    Impact,
    /// Right after a settled in-step impact (`settled`), the body's remaining speed into the
    /// ground removed (an `e = 0` normal impulse through its centre of mass), so that it rests.
    Settle,
    /// The body moved out of the ground along the normal at the end of the step (rapier's
    /// resting contact, or its integrator, left it deeper than the resting gap); for a ball,
    /// also its speed into the ground removed.
    PushOut,
    /// The body's velocity along the normal and the part of its spin that carries no angular
    /// momentum about the normal scaled down by one factor (its velocity along the ground and
    /// that momentum too, by a factor of their own, only where those cannot pay), so that a
    /// push-out does not add energy: its mechanical energy is held to the step start's.
    EnergyCap,
    /// A ball the closed form stopped on a slope that holds it (`tan(theta) <= mu_r` and
    /// `<= mu`) put back where it stopped, at rest, after its first step in rapier's resting
    /// contact: that contact starts without the impulses of a step before and lets the ball
    /// creep downhill in that step. From then on rapier's contact holds it and sleeps it.
    Hold,
    /// A ball the closed form rolled (rolling resistance, spinning friction, sliding) handed
    /// to rapier's resting contact: another body or collider can touch it within the step
    /// (`timing` `StepStart`: nothing is written; rapier's end state is checked against the
    /// ground for another body pushing it in deeper than the resting gap), or in the step a
    /// contact pushed it, a joint held it or rapier's CCD stopped it short (`StepEnd`:
    /// rapier's end state stands, corrected only as the settle stage corrects any). The
    /// closed form takes the ball again once nothing can reach it. `impulse` zero,
    /// `ke_before` equal to `ke_after`.
    Released,
}

/// One change the plugin made to a body in the last step: a ground impact resolved by the
/// model, or a correction ([`EventKind`]). World frame, y-up or not: the frame is rapier's.
///
/// `ke_after` is the kinetic energy of the state the change left; where it is the last change
/// in the step and no flight follows (`timing` `StepEnd`), that state is what was written into
/// rapier. For the corrections (`kind` not `Impact`), `regime` is `Separating`, `law`
/// `Consistent`, `contact_points` 0, `restitution`, `friction` and `tangential_restitution` 0,
/// `settled` true, and `impulse` the change of linear momentum (zero for a change of pose
/// only).
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(
    feature = "serde-serialize",
    derive(serde::Serialize, serde::Deserialize)
)]
#[non_exhaustive]
pub struct ImpactEvent {
    /// What changed the body.
    pub kind: EventKind,
    /// The body the change was made to: the body that hit the ground, or one of the two
    /// bodies of an impact between bodies.
    pub body: RigidBodyHandle,
    /// The body's collider that touched (of a level landing of several colliders, the one
    /// that touched first).
    pub collider: ColliderHandle,
    /// The ground collider (on a floor of flush tiles the plugin takes as one box, the tile
    /// under `point`), or in an impact between bodies the other body's collider.
    pub ground: ColliderHandle,
    /// In an impact between bodies, the other body (which has its own event for the same
    /// impact); `None` for a ground.
    pub body2: Option<RigidBodyHandle>,
    /// Time of the impact after the start of the step (s), in `[0, dt]`.
    pub time: f64,
    /// How the time was found.
    pub timing: ImpactTiming,
    /// Contact point on the body (m): the single deepest point, the centroid of the
    /// simultaneous contact points of a flat or edge landing, or, for a level landing of
    /// several colliders, the centre of mass projected on the contact plane (within their
    /// points' hull, maybe between the colliders).
    pub point: Vector,
    /// Unit contact normal, from the ground (or the other body) into the body.
    pub normal: Vector,
    /// Number of contact points resolved as one simultaneous impact (1 for a single point;
    /// of a level landing of several colliders, all of theirs).
    pub contact_points: usize,
    /// Approach speed `-u.n > 0` of the contact point relative to the ground (m/s).
    pub approach_speed: f64,
    /// Impulse on the body at `point` (N s); the other body of a pair receives its opposite.
    pub impulse: Vector,
    /// Normal impulse `P.n` (N s): `>= 0` for an impact; for a correction, the change of
    /// linear momentum along the normal (an energy cap's may be negative).
    pub normal_impulse: f64,
    /// Tangential (friction) impulse (N s).
    pub tangent_impulse: Vector,
    /// Stick, slip, or slip then stick.
    pub regime: Regime,
    /// The law that produced the impulse (`Document` or `Consistent`).
    pub law: Law,
    /// Why the document's closed form was left for `Consistent`, if it was: by `Guarded` where
    /// it is unphysical, or by `Document` at a jam (no solution).
    pub fallback: Option<Fallback>,
    /// `true` when the approach was below the resting speed and the impact was resolved with
    /// `e = 0`: the body came to rest on the ground.
    pub settled: bool,
    /// Restitution coefficient used: rapier's combination of the colliders', a ground's
    /// override, or a restitution curve's `e` at this `approach_speed` (0 when `settled`).
    pub restitution: f64,
    /// Friction coefficient used.
    pub friction: f64,
    /// Walton's tangential restitution `beta0` used (0 is Coulomb's stick).
    pub tangential_restitution: f64,
    /// Kinetic energy of the body before the impact (J); a spin about a locked rotation axis
    /// holds none ([`crate::model::Body::locked_spin`]).
    pub ke_before: f64,
    /// Kinetic energy of the body after the impact (J); a spin about a locked rotation axis
    /// holds none.
    pub ke_after: f64,
}

impl ImpactEvent {
    /// Every number finite (an event whose numbers are not is never reported: the writer
    /// refuses the state it comes with, [`Diagnostic::NonFiniteState`]).
    pub(crate) fn is_finite(&self) -> bool {
        [self.point, self.normal, self.impulse, self.tangent_impulse]
            .iter()
            .all(|v| v.is_finite())
            && [
                self.time,
                self.approach_speed,
                self.normal_impulse,
                self.restitution,
                self.friction,
                self.tangential_restitution,
                self.ke_before,
                self.ke_after,
            ]
            .iter()
            .all(|x| x.is_finite())
    }
}

/// Something the plugin left to rapier instead of resolving it, reported after the step it
/// happened in ([`crate::ImpactPlugin::diagnostics`]). Not a change to a body: nothing was
/// written for it.
#[derive(Clone, Copy, Debug, PartialEq)]
#[non_exhaustive]
#[cfg_attr(
    feature = "serde-serialize",
    derive(serde::Serialize, serde::Deserialize)
)]
pub enum Diagnostic {
    /// The collider's restitution or friction is outside the plugin's ranges (NaN,
    /// infinite, negative, restitution above 10 or friction above 100): every pair of it
    /// without a ground material of the plugin's stays rapier's, unchanged, rather than being
    /// resolved with a value the plugin made up. Reported once per collider, the first step
    /// the plugin meets it in a pair.
    CoefficientsOutOfRange {
        /// The collider.
        collider: ColliderHandle,
        /// Its restitution, as set.
        restitution: f64,
        /// Its friction, as set.
        friction: f64,
    },
    /// A state the plugin computed for the body was not finite, or beyond rapier's number
    /// range (an impulse from an extreme input): it was not written, no event reports it, and
    /// the body keeps the state rapier gave it for this step.
    NonFiniteState {
        /// The body.
        body: RigidBodyHandle,
    },
}

/// What a step reports: its events and its diagnostics, cleared when the next step starts;
/// and, while the event log is on, the events of earlier steps not yet taken.
#[derive(Clone, Debug, Default)]
pub(crate) struct Reports {
    pub events: Vec<ImpactEvent>,
    pub diagnostics: Vec<Diagnostic>,
    /// The event log ([`crate::ImpactPlugin::set_event_log`]): the events of the steps before
    /// the current one that were not taken yet; `None` while it is off.
    log: Option<Vec<ImpactEvent>>,
    /// How many of `events` were taken with the log already (they are not logged again).
    taken: usize,
}

impl Reports {
    /// A new step reports afresh; the last step's events not taken go to the log, if on.
    pub fn clear(&mut self) {
        if let Some(log) = &mut self.log {
            log.extend_from_slice(&self.events[self.taken.min(self.events.len())..]);
        }
        self.taken = 0;
        self.events.clear();
        self.diagnostics.clear();
    }

    /// A restored plugin reports the saved step's `events` and no diagnostic; its event log,
    /// if on, starts empty (the saved step's events were the saved run's to take), so that it
    /// holds only the events of the steps after the restore.
    pub fn restore(&mut self, events: &[ImpactEvent]) {
        self.events.clear();
        self.events.extend_from_slice(events);
        self.diagnostics.clear();
        if let Some(log) = &mut self.log {
            log.clear();
        }
        self.taken = self.events.len();
    }

    /// Turns the event log on (kept if it already is) or off (its events dropped).
    pub fn set_log(&mut self, on: bool) {
        match (on, &self.log) {
            (true, None) => {
                self.log = Some(Vec::new());
                self.taken = self.events.len();
            }
            (false, _) => self.log = None,
            (true, Some(_)) => {}
        }
    }

    /// The logged events and the current step's not taken yet, in order; the log is left
    /// empty. Nothing while the log is off.
    pub fn take_log(&mut self) -> Vec<ImpactEvent> {
        let Some(log) = &mut self.log else {
            return Vec::new();
        };
        let mut all = std::mem::take(log);
        all.extend_from_slice(&self.events[self.taken.min(self.events.len())..]);
        self.taken = self.events.len();
        all
    }
}
