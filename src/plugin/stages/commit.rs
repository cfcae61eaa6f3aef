//! Commit: the one writer. Every change the step makes to a rapier body is recorded through
//! [`Commit`] by the stage that decides it, and applied by the commit stage ([`apply`]), which
//! closes each half of the step's work on bodies (before rapier's step, only the install of
//! the hook flags on colliders follows it); every event that reports a change is appended
//! through [`Commit`] too.
//!
//! Contract: the only code that calls rapier's body setters (pose, velocities, wake-up), in
//! [`apply`] alone (the stages take rapier's bodies read-only), and the only code that
//! appends to the step's events. [`Commit::state`] records a body's pose and velocities
//! (woken up) from an `f64` state, [`Commit::flight`] what free flight changes,
//! [`Commit::rolled`] a steered roll's end (its velocities, or its state where rapier's pose
//! drifted), [`Commit::velocity`] and [`Commit::velocities`] a steering's velocities,
//! [`Commit::wake`] a wake-up of a sleeping body a step must plan; a stage reads a body the
//! step may already have written through [`Commit::body`], which gives what rapier will hold
//! once the writes so far are applied (`state/writes.rs`). In `Exact`
//! mode a state the model reconstructed ([`Origin::Model`]) is remembered as a [`Shadow`], and
//! in every mode a closed-form roll's end ([`Origin::Roll`]), so that the next step continues
//! from the `f64` state rather than from its rounding to rapier's precision, as long as
//! rapier still holds exactly what was written; a correction of rapier's own end state
//! ([`Origin::Correction`]) is not: rapier's precision is its truth.

use crate::motion::State;
use crate::plugin::bridge::convert::{rot_from_na, rot_to_na, to_f64, vec_from_na, vec_to_na};
use crate::plugin::events::{Diagnostic, ImpactEvent, Reports};
use crate::plugin::policy::{carries, carries_turn};
use crate::plugin::state::memory::{Shadow, Shadows};
use crate::plugin::state::writes::{Now, Place, Write, Writes};
use crate::rapier::math::{Pose, Real, Vector};
use crate::rapier::prelude::{RigidBody, RigidBodyHandle, RigidBodySet};
use nalgebra::Vector3;

/// Where a written state comes from, which decides whether it is kept as the next step's
/// start (a [`Shadow`]).
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub(crate) enum Origin {
    /// A closed-form roll's end (the bodies stage's rolls, steered or not): the next step's
    /// start in every mode, as long as the ball rolls on. Continued from rapier's rounding
    /// instead, a long roll would add up a rounding of its position each step.
    Roll,
    /// Any other state the plugin computed in `f64` (the model's reconstruction: a flight,
    /// the impacts of the step; or a start state put back, `EventKind::Hold`): the next
    /// step's start in `Exact` mode.
    Model,
    /// A correction of rapier's end state (a push-out, a step-end impact, a step-start
    /// impulse): the next step starts from what rapier holds.
    Correction,
}

/// The commit stage: applies the writes recorded in this half of the step to rapier's
/// bodies, in the order recorded, and returns how many there were and how many of them move
/// a body (a write to a body that no longer exists is dropped).
pub(crate) fn apply(writes: &mut Writes, bodies: &mut RigidBodySet) -> (usize, usize) {
    let count = writes.len();
    let mut moves = 0;
    writes.apply_all(|body, write| {
        moves += usize::from(matches!(write, Write::Move { .. }));
        if let Some(rb) = bodies.get_mut(body) {
            apply_one(write, rb);
        }
    });
    (count, moves)
}

/// Applies one write to `rb` through rapier's setters, in the order [`Write`] gives (every
/// read of the body before the commit mirrors this: `state/writes.rs`'s `Held`).
fn apply_one(write: &Write, rb: &mut RigidBody) {
    let (to, linvel, angvel) = match *write {
        Write::Move { to, linvel, angvel } => (to, linvel, angvel),
        Write::Velocity(linvel) => {
            rb.set_linvel(linvel, true);
            return;
        }
        Write::Velocities { linvel, angvel } => {
            rb.set_linvel(linvel, true);
            rb.set_angvel(angvel, true);
            return;
        }
        Write::Wake => {
            rb.wake_up(true);
            return;
        }
    };
    match to {
        Place::Pose(pose) => rb.set_position(pose, true),
        Place::Translation(t) => rb.set_translation(t, true),
    }
    rb.set_linvel(linvel, true);
    if let Some(w) = angvel {
        rb.set_angvel(w, true);
    }
}

/// The step's writer: records the writes (applied by [`apply`]), reports the events and
/// diagnostics of the step, and keeps the shadows of the states it writes.
pub(crate) struct Commit<'a> {
    writes: &'a mut Writes,
    reports: &'a mut Reports,
    shadows: &'a mut Shadows,
    /// `Exact` mode: states of [`Origin::Model`] are remembered (of [`Origin::Roll`], in every
    /// mode).
    exact: bool,
}

impl<'a> Commit<'a> {
    pub fn new(
        writes: &'a mut Writes,
        reports: &'a mut Reports,
        shadows: &'a mut Shadows,
        exact: bool,
    ) -> Self {
        Self {
            writes,
            reports,
            shadows,
            exact,
        }
    }

    /// Reports one change made to a body; an event whose numbers are not all finite is
    /// dropped (its state is refused too: [`Self::state`]).
    pub fn event(&mut self, event: ImpactEvent) {
        if event.is_finite() {
            self.reports.events.push(event);
        }
    }

    /// Reports changes made to bodies, in order ([`Self::event`] each).
    pub fn events(&mut self, events: impl IntoIterator<Item = ImpactEvent>) {
        for event in events {
            self.event(event);
        }
    }

    /// Reports what the step left to rapier.
    pub fn diagnose(&mut self, diagnostic: Diagnostic) {
        self.reports.diagnostics.push(diagnostic);
    }

    /// Withdraws the events reported from index `from` on: those of an attempt that was
    /// abandoned before anything of it was written (a cluster the search gave up on).
    pub fn withdraw(&mut self, from: usize) {
        self.reports.events.truncate(from);
    }

    /// The step's events so far (a body's events of this step start at an index taken
    /// before its stage ran: `reported()`).
    pub fn reported(&self) -> &[ImpactEvent] {
        &self.reports.events
    }

    /// `body` as rapier will hold it once the writes so far are applied, if it exists.
    pub fn body<'b>(&self, bodies: &'b RigidBodySet, body: RigidBodyHandle) -> Option<Now<'b>> {
        self.writes.body(bodies, body)
    }

    /// `body` (`rb`, as rapier holds it now) as rapier will hold it once the writes so far
    /// are applied.
    pub fn now<'b>(&self, body: RigidBodyHandle, rb: &'b RigidBody) -> Now<'b> {
        self.writes.now(body, rb)
    }

    /// Is `body` (`rb`, as rapier holds it now) asleep once the writes so far are applied?
    pub fn is_sleeping(&self, body: RigidBodyHandle, rb: &RigidBody) -> bool {
        self.writes.is_sleeping(body, rb)
    }

    /// Writes `s` into `body` (woken up): its pose and velocities.
    pub fn state(
        &mut self,
        body: RigidBodyHandle,
        s: &State,
        local_com: &Vector3<f64>,
        origin: Origin,
    ) {
        if !fits(s) {
            self.diagnose(Diagnostic::NonFiniteState { body });
            return;
        }
        let translation = s.com - s.rot * local_com;
        let (pose, angvel, linvel) = (
            Pose::from_parts(vec_from_na(&translation), rot_from_na(&s.rot)),
            vec_from_na(&s.w),
            vec_from_na(&s.v),
        );
        let (to, spin) = (Place::Pose(pose), Some(angvel));
        let write = Write::Move {
            to,
            linvel,
            angvel: spin,
        };
        self.writes.record(body, write);
        let kept = match origin {
            Origin::Roll => true,
            Origin::Model => self.exact,
            Origin::Correction => false,
        };
        if kept {
            let written = (pose.translation, pose.rotation, linvel, angvel);
            self.shadows.insert(body, Shadow::of(s, local_com, written));
        } else {
            // A shadow from an earlier write of the step is not this state.
            self.shadows.remove(&body);
        }
    }

    /// Writes a free flight's end into `body` (woken up): the translation and linear
    /// velocity, and the spin where `exact_spin` and rapier's differs (a write queues the body
    /// for rapier's update, so an unchanged spin is not written); rapier's rotation is kept.
    /// Of a flight `steered` onto the exact positions (`steer.rs`), the translation is kept
    /// where rapier's carries the flight's (within a few roundings: `policy::carries`) and
    /// the spin needs no write: only the velocity is written, which a pose write would cost
    /// rapier much more than. `before`: the body as the writes so far leave it
    /// ([`Self::body`]).
    pub fn flight(
        &mut self,
        (body, before): (RigidBodyHandle, &Now),
        s: &State,
        local_com: &Vector3<f64>,
        (exact_spin, steered): (bool, bool),
    ) {
        if !fits(s) {
            self.diagnose(Diagnostic::NonFiniteState { body });
            return;
        }
        let exact = s.com - rot_to_na(before.rotation()) * local_com;
        let (linvel, w) = (vec_from_na(&s.v), vec_from_na(&s.w));
        let angvel = (exact_spin && before.angvel() != w).then_some(w);
        let spin = angvel.unwrap_or(before.angvel());
        let held = before.translation();
        let translation = if steered && angvel.is_none() && carries(&vec_to_na(held), &exact) {
            if before.linvel() != linvel {
                self.writes.record(body, Write::Velocity(linvel));
            }
            held
        } else {
            let translation = vec_from_na(&exact);
            let to = Place::Translation(translation);
            self.writes.record(body, Write::Move { to, linvel, angvel });
            translation
        };
        if self.exact {
            let written = (translation, before.rotation(), linvel, spin);
            self.shadows.insert(body, Shadow::of(s, local_com, written));
        }
    }

    /// Sets `body`'s linear velocity alone (woken up): a free flight steered, or its
    /// steering's offset given back (`steer.rs`).
    pub fn velocity(&mut self, body: RigidBodyHandle, linvel: Vector) {
        if linvel.is_finite() {
            self.writes.record(body, Write::Velocity(linvel));
            // No state of the step's is then what rapier holds.
            self.shadows.remove(&body);
        } else {
            self.diagnose(Diagnostic::NonFiniteState { body });
        }
    }

    /// Sets `body`'s two velocities (woken up): a closed-form roll steered (`steer.rs`), or a
    /// steered roll something else acted on given the steering's offsets back. Returns
    /// whether it was recorded (velocities that are not finite in rapier's precision are
    /// refused, and diagnosed).
    pub fn velocities(&mut self, body: RigidBodyHandle, linvel: Vector, angvel: Vector) -> bool {
        if !(linvel.is_finite() && angvel.is_finite()) {
            self.diagnose(Diagnostic::NonFiniteState { body });
            return false;
        }
        self.writes
            .record(body, Write::Velocities { linvel, angvel });
        // No state of the step's is then what rapier holds.
        self.shadows.remove(&body);
        true
    }

    /// Writes a steered roll's closed-form end `s` into `body` (`before`: as the writes so far
    /// leave it): its velocities alone where rapier's integrator carried its pose (the
    /// translation by `policy::carries`, the rotation by `policy::carries_turn`), else the
    /// whole state. The state is remembered either way, in every mode: rapier's integrator
    /// carries the pose within a few roundings, and the roll's next step continues from the
    /// `f64` end rather than from that, so that the roundings do not add up over the steps.
    pub fn rolled(
        &mut self,
        (body, before): (RigidBodyHandle, &Now),
        s: &State,
        local_com: &Vector3<f64>,
    ) {
        if !fits(s) {
            self.diagnose(Diagnostic::NonFiniteState { body });
            return;
        }
        let exact = s.com - s.rot * local_com;
        let held = before.translation();
        let carried = carries(&vec_to_na(held), &exact)
            && carries_turn(&rot_to_na(before.rotation()), &s.rot);
        if !carried {
            self.state(body, s, local_com, Origin::Roll);
            return;
        }
        let (linvel, angvel) = (vec_from_na(&s.v), vec_from_na(&s.w));
        if (before.linvel(), before.angvel()) != (linvel, angvel) {
            self.writes
                .record(body, Write::Velocities { linvel, angvel });
        }
        let written = (held, before.rotation(), linvel, angvel);
        self.shadows.insert(body, Shadow::of(s, local_com, written));
    }

    /// Wakes a sleeping body the step must plan.
    pub fn wake(&mut self, body: RigidBodyHandle) {
        self.writes.record(body, Write::Wake);
    }
}

/// Does the state, written as a pose and velocities, fit in rapier's numbers (every value
/// finite in `Real`)? A state that does not is refused: nothing the plugin writes is NaN or
/// infinite.
fn fits(s: &State) -> bool {
    // Half the range for the centre of mass: the translation written is the centre less the
    // body's own offset to it, which is far smaller.
    let limit = to_f64(Real::MAX);
    let (c, v, w, q) = (&s.com, &s.v, &s.w, &s.rot.coords);
    // Written out: an iterator chain here cost a write 150 instructions.
    [c.x, c.y, c.z].iter().all(|x| x.abs() <= 0.5 * limit)
        && [v.x, v.y, v.z, w.x, w.y, w.z, q.x, q.y, q.z, q.w]
            .iter()
            .all(|x| x.abs() <= limit)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::plugin::bridge::convert::vec_to_na;
    use crate::rapier::prelude::{ColliderBuilder, ColliderSet, RigidBodyBuilder};
    use nalgebra::UnitQuaternion;

    /// What a stage reads of a body: pose, next pose, centre of mass, velocities, sleep.
    type Read = (Pose, Pose, crate::rapier::math::Vector, [Real; 6], bool);

    fn read_now(now: &Now) -> Read {
        let (v, w) = (now.linvel(), now.angvel());
        // `Now` has no next pose: a pose write moves both, and the commit's reads after it
        // check that.
        (
            now.position(),
            now.position(),
            now.center_of_mass(),
            [v.x, v.y, v.z, w.x, w.y, w.z],
            now.is_sleeping(),
        )
    }

    fn read_rapier(rb: &RigidBody) -> Read {
        let (v, w) = (rb.linvel(), rb.angvel());
        (
            *rb.position(),
            *rb.next_position(),
            rb.center_of_mass(),
            [v.x, v.y, v.z, w.x, w.y, w.z],
            rb.is_sleeping(),
        )
    }

    /// A body whose centre of mass is off its origin (an offset box), of one of four kinds:
    /// dynamic awake, dynamic asleep, velocity-based kinematic, fixed and asleep (a pose
    /// write wakes the dynamic one only).
    fn body(kind: usize) -> (RigidBodySet, RigidBodyHandle) {
        let mut bodies = RigidBodySet::new();
        let mut colliders = ColliderSet::new();
        let builder = match kind {
            0 | 1 => RigidBodyBuilder::dynamic(),
            2 => RigidBodyBuilder::kinematic_velocity_based(),
            _ => RigidBodyBuilder::fixed(),
        };
        let h = bodies.insert(
            builder
                .translation(crate::rapier::math::Vector::new(0.3, 1.0, -0.2))
                .rotation(crate::rapier::math::Vector::new(0.1, 0.2, 0.3))
                .linvel(crate::rapier::math::Vector::new(1.0, -2.0, 0.5))
                .angvel(crate::rapier::math::Vector::new(0.0, 3.0, -1.0)),
        );
        colliders.insert_with_parent(
            ColliderBuilder::cuboid(0.1, 0.2, 0.3)
                .translation(crate::rapier::math::Vector::new(0.05, -0.02, 0.01))
                .density(2.0),
            h,
            &mut bodies,
        );
        if kind == 1 || kind == 3 {
            bodies[h].sleep();
        }
        (bodies, h)
    }

    /// The kinds of write [`record`] makes.
    const KINDS: usize = 7;

    /// One of the writes a stage records, by number: a full state (twice the same, the
    /// second changing nothing), a flight's end with and without its spin, a steered
    /// flight's end where the body is (its velocity alone, where rapier's translation carries
    /// it), a velocity alone, a wake-up.
    fn record(commit: &mut Commit, bodies: &RigidBodySet, h: RigidBodyHandle, k: usize) {
        let local_com = vec_to_na(bodies[h].local_center_of_mass());
        let mut s = State {
            com: Vector3::new(0.7, 1.3 + 0.1 * k as f64, -0.4),
            rot: UnitQuaternion::from_euler_angles(0.3, -0.2, 0.1 * k as f64),
            v: Vector3::new(0.2, -(k as f64), 0.3),
            w: Vector3::new(4.0, 0.0, 1.0 + k as f64),
        };
        match k % KINDS {
            0 | 1 => commit.state(h, &s, &local_com, Origin::Model),
            2 | 3 => {
                let before = commit.body(bodies, h).unwrap();
                commit.flight((h, &before), &s, &local_com, (k % KINDS == 2, false));
            }
            4 => {
                let before = commit.body(bodies, h).unwrap();
                s.com = vec_to_na(before.center_of_mass());
                commit.flight((h, &before), &s, &local_com, (false, true));
            }
            5 => commit.velocity(h, vec_from_na(&s.v)),
            _ => commit.wake(h),
        }
    }

    #[test]
    fn a_body_read_before_the_commit_reads_as_after_it() {
        // Every sequence of up to four writes (of every kind, repeats included), on each kind
        // of body: what a stage reads before the commit (`Now`) is what rapier holds after
        // it, bit for bit, and the next pose moves with the pose.
        let kinds: Vec<Vec<usize>> = (0..KINDS.pow(4))
            .flat_map(|n| {
                (1..=4).map(move |len| (0..len).map(|i| n / KINDS.pow(i) % KINDS).collect())
            })
            .collect();
        for kind in 0..4 {
            for seq in &kinds {
                let (mut bodies, h) = body(kind);
                let mut writes = Writes::default();
                let (mut reports, mut shadows) = (Reports::default(), Shadows::default());
                let mut commit = Commit::new(&mut writes, &mut reports, &mut shadows, true);
                for (i, k) in seq.iter().enumerate() {
                    record(&mut commit, &bodies, h, *k + i);
                }
                let before = read_now(&commit.body(&bodies, h).unwrap());
                apply(&mut writes, &mut bodies);
                let after = read_rapier(&bodies[h]);
                assert_eq!(before, after, "kind {kind}, writes {seq:?}");
                // The plugin writes only managed bodies, which are dynamic.
                if let (Some(sh), true) = (shadows.get(&h), kind <= 1) {
                    let rb = &bodies[h];
                    assert_eq!(
                        (sh.written_translation, sh.written_linvel, sh.written_angvel),
                        (rb.translation(), rb.linvel(), rb.angvel()),
                        "kind {kind}, writes {seq:?}: the shadow holds what was written"
                    );
                }
            }
        }
    }

    #[test]
    fn nothing_is_written_before_the_commit() {
        let (bodies, h) = body(0);
        let was = read_rapier(&bodies[h]);
        let mut writes = Writes::default();
        let (mut reports, mut shadows) = (Reports::default(), Shadows::default());
        let mut commit = Commit::new(&mut writes, &mut reports, &mut shadows, false);
        record(&mut commit, &bodies, h, 0);
        assert_ne!(read_now(&commit.body(&bodies, h).unwrap()), was);
        assert_eq!(read_rapier(&bodies[h]), was);
        assert_eq!(writes.len(), 1);
    }
}
