//! The step's writes into rapier's bodies, recorded by the stages (through
//! `stages/commit.rs`'s `Commit`) and applied by the commit stage (`commit::apply`), which
//! closes each half of the step's work on bodies, in the order they were recorded.
//!
//! Until then rapier's bodies hold what they held when the half began; a stage that reads a
//! body the step may already have written reads it through [`Writes::now`], which gives the
//! values rapier will hold once the writes so far are applied: the body's writes replayed
//! over rapier's values, its setters mirrored value for value ([`Held`]), so that a read
//! before the commit equals the same read after it, bit for bit.

use crate::motion::State;
use crate::plugin::bridge::convert::{rot_to_na, vec_to_na};
use crate::plugin::state::handles::Slotted;
use crate::rapier::math::{Pose, Rotation, Vector};
use crate::rapier::prelude::{RigidBody, RigidBodyHandle, RigidBodySet, RigidBodyType};

/// One recorded write: rapier's setters, called in this order when the commit stage applies
/// it (`stages/commit.rs`).
#[derive(Clone, Copy, Debug)]
pub(crate) enum Write {
    /// The pose or translation, the linear velocity, and the spin where given (woken up):
    /// a state, or a free flight's end with rapier's rotation (and perhaps its spin) kept.
    Move {
        to: Place,
        linvel: Vector,
        angvel: Option<Vector>,
    },
    /// The linear velocity alone (woken up): `Exact` mode's steering of a free flight
    /// (`stages/steer.rs`).
    Velocity(Vector),
    /// Both velocities (woken up): the steering of a closed-form roll, and its end where
    /// rapier's integrator carried the pose (`stages/steer.rs`).
    Velocities { linvel: Vector, angvel: Vector },
    /// `wake_up`.
    Wake,
}

/// Where a [`Write::Move`] puts the body: `set_position` or `set_translation`.
#[derive(Clone, Copy, Debug)]
pub(crate) enum Place {
    Pose(Pose),
    Translation(Vector),
}

/// What rapier will hold of a written body once the writes recorded so far are applied: the
/// values its setters change, changed as they change them (`RigidBody::set_position` and
/// `set_translation` move the pose and the next pose together and recompute the centre of
/// mass from the pose; a setter that changes a value wakes the body; a dynamic body's
/// velocities are set as given).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Held {
    position: Pose,
    next_position: Pose,
    com: Vector,
    linvel: Vector,
    angvel: Vector,
    sleeping: bool,
}

impl Held {
    fn of(rb: &RigidBody) -> Self {
        Self {
            position: *rb.position(),
            next_position: *rb.next_position(),
            com: rb.center_of_mass(),
            linvel: rb.linvel(),
            angvel: rb.angvel(),
            sleeping: rb.is_sleeping(),
        }
    }

    /// `write` as rapier's setters would apply it to the body `rb` (read for what decides
    /// them: its type and mass properties). They leave a soft frame alone, set velocities
    /// only of dynamic and velocity-based kinematic bodies, and wake on a pose only dynamic
    /// and kinematic ones.
    fn apply(&mut self, write: &Write, rb: &RigidBody) {
        let (to, linvel, angvel) = match *write {
            Write::Move { to, linvel, angvel } => (Some(to), linvel, angvel),
            Write::Velocity(linvel) => (None, linvel, None),
            Write::Velocities { linvel, angvel } => (None, linvel, Some(angvel)),
            Write::Wake => {
                self.sleeping = false;
                return;
            }
        };
        if rb.is_soft_frame() {
            return;
        }
        if let Some(to) = to {
            self.move_to(to, rb);
        }
        let takes_velocities = matches!(
            rb.body_type(),
            RigidBodyType::Dynamic | RigidBodyType::KinematicVelocityBased
        );
        let set = |held: &mut Vector, v: Vector, sleeping: &mut bool| {
            if takes_velocities && *held != v {
                *held = v;
                *sleeping = false;
            }
        };
        set(&mut self.linvel, linvel, &mut self.sleeping);
        if let Some(w) = angvel {
            set(&mut self.angvel, w, &mut self.sleeping);
        }
    }

    /// rapier's `set_position` / `set_translation` on the body `rb`.
    fn move_to(&mut self, to: Place, rb: &RigidBody) {
        let new = match to {
            Place::Pose(pose) => (pose, pose),
            Place::Translation(t) => (
                Pose::from_parts(t, self.position.rotation),
                Pose::from_parts(t, self.next_position.rotation),
            ),
        };
        if (self.position, self.next_position) != new {
            (self.position, self.next_position) = new;
            // rapier's `RigidBodyMassProps::update_world_mass_properties`.
            self.com = rb.mass_properties().local_mprops.world_com(&self.position);
            self.sleeping &= !rb.is_dynamic_or_kinematic();
        }
    }
}

/// The step's writes, recorded in order. A read of a body the half has written replays that
/// body's writes over what rapier holds (most written bodies are not read again in the half,
/// so nothing is mirrored at the write).
#[derive(Default)]
pub(crate) struct Writes {
    log: Vec<Entry>,
    /// By a body handle's arena slot: 1 + the place in `log` of the body's last write, or 0
    /// (a read of a body nothing wrote is an index, not a hash).
    slots: Vec<u32>,
}

/// One write in the log, linked to the same body's write before it.
#[derive(Clone, Copy, Debug)]
struct Entry {
    body: RigidBodyHandle,
    write: Write,
    /// 1 + the place in the log of the body's previous write, or 0.
    prev: u32,
}

impl Writes {
    /// Records `write` to `body`.
    pub fn record(&mut self, body: RigidBodyHandle, write: Write) {
        let slot = body.slot();
        if slot >= self.slots.len() {
            self.slots.resize(slot + 1, 0);
        }
        let prev = self.last_of(body).map_or(0, |k| k as u32 + 1);
        self.log.push(Entry { body, write, prev });
        self.slots[slot] = self.log.len() as u32;
    }

    /// The place in the log of `body`'s last write, if it has one.
    #[inline]
    fn last_of(&self, body: RigidBodyHandle) -> Option<usize> {
        if self.log.is_empty() {
            return None;
        }
        match self.slots.get(body.slot()) {
            Some(&k) if k > 0 && self.log[k as usize - 1].body == body => Some(k as usize - 1),
            _ => None,
        }
    }

    /// A mark of `body`'s writes so far: it changes whenever a write to the body is
    /// recorded (0 while it has none), so a value read through the writes stays good while
    /// the mark stays.
    #[inline]
    pub fn mark(&self, body: RigidBodyHandle) -> u32 {
        self.last_of(body).map_or(0, |k| k as u32 + 1)
    }

    /// `body` (`rb`, as rapier holds it now) as it will be once the writes so far are
    /// applied.
    #[inline]
    pub fn now<'a>(&self, body: RigidBodyHandle, rb: &'a RigidBody) -> Now<'a> {
        Now {
            rb,
            held: self
                .last_of(body)
                .map(|last| Box::new(self.replay(last, rb))),
        }
    }

    /// What rapier will hold of the body of the log's entry `last` after its writes up to
    /// that one.
    #[cold]
    fn replay(&self, last: usize, rb: &RigidBody) -> Held {
        let mut chain = vec![last];
        let mut k = self.log[last].prev;
        while k > 0 {
            chain.push(k as usize - 1);
            k = self.log[k as usize - 1].prev;
        }
        let mut held = Held::of(rb);
        for k in chain.iter().rev() {
            held.apply(&self.log[*k].write, rb);
        }
        held
    }

    /// [`Self::now`] for a body of `bodies`, if it exists.
    #[inline]
    pub fn body<'a>(&self, bodies: &'a RigidBodySet, body: RigidBodyHandle) -> Option<Now<'a>> {
        bodies.get(body).map(|rb| self.now(body, rb))
    }

    /// The centre of mass and the linear and angular velocities of `body` (`rb`, as rapier
    /// holds it now) once the writes so far are applied: [`Self::now`]'s, without building
    /// it (a neighbour's motion, read for every contact pair of a planned ball).
    #[inline]
    pub fn motion(&self, body: RigidBodyHandle, rb: &RigidBody) -> (Vector, Vector, Vector) {
        match self.last_of(body) {
            None => (rb.center_of_mass(), rb.linvel(), rb.angvel()),
            Some(last) => {
                let held = self.replay(last, rb);
                (held.com, held.linvel, held.angvel)
            }
        }
    }

    /// Is `body` (`rb`, as rapier holds it now) asleep once the writes so far are applied?
    /// A write only wakes: a body rapier holds awake is read no further.
    #[inline]
    pub fn is_sleeping(&self, body: RigidBodyHandle, rb: &RigidBody) -> bool {
        rb.is_sleeping() && self.now(body, rb).is_sleeping()
    }

    /// How many writes are recorded.
    pub fn len(&self) -> usize {
        self.log.len()
    }

    /// Hands each write to `apply`, in the order recorded, and empties the table.
    pub fn apply_all(&mut self, mut apply: impl FnMut(RigidBodyHandle, &Write)) {
        for e in &self.log {
            if let Some(k) = self.slots.get_mut(e.body.slot()) {
                *k = 0;
            }
            apply(e.body, &e.write);
        }
        self.log.clear();
    }
}

/// A body as the step's writes so far leave it ([`Writes::now`]): the pose, centre of mass,
/// velocities and sleep those writes change, and everything else as rapier holds it.
#[derive(Clone)]
pub(crate) struct Now<'a> {
    rb: &'a RigidBody,
    /// Boxed: a body the half wrote is rarely read again, and the common `Now` stays two
    /// words.
    held: Option<Box<Held>>,
}

impl<'a> Now<'a> {
    /// rapier's body, for what the step does not write (its colliders, mass properties,
    /// type, forces, damping).
    #[inline]
    pub fn rb(&self) -> &'a RigidBody {
        self.rb
    }

    #[inline]
    pub fn center_of_mass(&self) -> Vector {
        self.held
            .as_ref()
            .map_or_else(|| self.rb.center_of_mass(), |h| h.com)
    }

    #[inline]
    pub fn position(&self) -> Pose {
        self.held
            .as_ref()
            .map_or_else(|| *self.rb.position(), |h| h.position)
    }

    #[inline]
    pub fn rotation(&self) -> Rotation {
        self.position().rotation
    }

    #[inline]
    pub fn translation(&self) -> Vector {
        self.position().translation
    }

    #[inline]
    pub fn linvel(&self) -> Vector {
        self.held
            .as_ref()
            .map_or_else(|| self.rb.linvel(), |h| h.linvel)
    }

    #[inline]
    pub fn angvel(&self) -> Vector {
        self.held
            .as_ref()
            .map_or_else(|| self.rb.angvel(), |h| h.angvel)
    }

    #[inline]
    pub fn is_sleeping(&self) -> bool {
        self.held
            .as_ref()
            .map_or_else(|| self.rb.is_sleeping(), |h| h.sleeping)
    }

    /// The body's state in the model's `f64` terms.
    pub fn state(&self) -> State {
        State {
            com: vec_to_na(self.center_of_mass()),
            rot: rot_to_na(self.rotation()),
            v: vec_to_na(self.linvel()),
            w: vec_to_na(self.angvel()),
        }
    }
}
