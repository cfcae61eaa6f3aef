//! What the plugin remembers from one step to the next.

use crate::motion::State;
use crate::plugin::bridge::convert::vec_to_na;
use crate::plugin::events::Diagnostic;
use crate::plugin::policy::Role;
use crate::plugin::state::handles::{
    ArenaOrder, HandleMap, HandleSet, PairKey, SlotTable, Slotted, restored_in_vector,
    sorted_entries, sorted_members, take_in_far,
};
use crate::plugin::state::step::{Candidate, GroundPair, MeshSide, SteeredRoll, StepData};
use crate::plugin::state::writes::Now;
use crate::rapier::math::{Rotation, Vector};
use crate::rapier::prelude::{ColliderHandle, RigidBodyHandle};
use nalgebra::Vector3;
use std::collections::BTreeMap;

/// The `f64` state of a body as last written (`Exact` mode's states of the model, and in
/// every mode a closed-form roll's end), so the next step continues from it rather than from
/// its rounding.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(
    feature = "serde-serialize",
    derive(serde::Serialize, serde::Deserialize)
)]
pub(crate) struct Shadow {
    pub com: Vector3<f64>,
    pub v: Vector3<f64>,
    pub w: Vector3<f64>,
    /// The centre of mass in the body's frame that `com` was placed with: the body's
    /// translation is `com - rot * local_com`.
    pub local_com: Vector3<f64>,
    pub written_translation: Vector,
    pub written_rotation: Rotation,
    pub written_linvel: Vector,
    pub written_angvel: Vector,
}

impl Shadow {
    /// Does rapier still hold what was written (its translation, rotation and linear velocity
    /// as `now` reads them, and the centre of mass in the body's frame `com` was placed
    /// with)? Then the `f64` state is the body's; else something (the user, a contact)
    /// changed it since. A rotation or a change of mass properties moves the centre of mass
    /// without moving the translation (a body turned about its origin, a collider added):
    /// `com` is then not the body's.
    #[inline]
    pub fn held_by(&self, now: &Now) -> bool {
        self.written_translation == now.translation()
            && self.written_linvel == now.linvel()
            && self.written_rotation == now.rotation()
            && self.local_com == vec_to_na(now.rb().local_center_of_mass())
    }

    /// Every number finite (a snapshot's shadow is checked before it is restored).
    pub fn is_finite(&self) -> bool {
        let written = [
            self.written_translation,
            self.written_linvel,
            self.written_angvel,
        ];
        [self.com, self.v, self.w, self.local_com]
            .iter()
            .all(|v| v.iter().all(|x| x.is_finite()))
            && written.iter().all(|v| v.is_finite())
            && self.written_rotation.is_finite()
    }

    /// The shadow of the state `s` (placed with the centre of mass `local_com` in the body's
    /// frame), written into a dynamic body as `written` (its translation, rotation, linear
    /// and angular velocities: what rapier holds of them once the write is applied).
    pub fn of(
        s: &State,
        local_com: &Vector3<f64>,
        written: (Vector, Rotation, Vector, Vector),
    ) -> Self {
        let (written_translation, written_rotation, written_linvel, written_angvel) = written;
        Self {
            com: s.com,
            v: s.v,
            w: s.w,
            local_com: *local_com,
            written_translation,
            written_rotation,
            written_linvel,
            written_angvel,
        }
    }
}

/// The shadows of the states a step wrote, by body: their entries in two vectors (the bodies,
/// and their shadows in the same order), and each entry's place by the body handle's arena
/// slot, so that a write's insert and a plan's read are an index and a handle compare (every
/// rolling ball's shadow is written and read each step). The bodies are kept apart from the
/// shadows so that emptying the table, once a step, reads 8 bytes an entry rather than each
/// 152-byte shadow (in `f32`). The entries' order is their history's: a snapshot lists them
/// in arena order ([`Self::sorted`]).
///
/// Invariant: `bodies` and `shadows` have one length; an entry's place is in `places` at its
/// body's slot, or in `far` when that slot is at least `places.len()` (a restored shadow not
/// [`restored_in_vector`]); growing `places` moves in the far places it reaches.
#[derive(Default)]
pub(crate) struct Shadows {
    /// The body of each entry.
    bodies: Vec<RigidBodyHandle>,
    /// The shadow of each entry.
    shadows: Vec<Shadow>,
    /// By a body handle's arena slot: 1 + the place of the body's entry, or 0.
    places: Vec<u32>,
    /// The same, for the slots beyond `places`.
    far: BTreeMap<usize, u32>,
}

impl Shadows {
    /// 1 + the place of the entry of the body in arena slot `slot`, or 0.
    #[inline]
    fn place_at(&self, slot: usize) -> usize {
        match self.places.get(slot) {
            Some(k) => *k as usize,
            None if self.far.is_empty() => 0,
            None => self.far.get(&slot).map_or(0, |k| *k as usize),
        }
    }

    /// Records `k` (1 + an entry's place, or 0 for none) for arena slot `slot`.
    fn set_place(&mut self, slot: usize, k: usize) {
        match self.places.get_mut(slot) {
            Some(at) => *at = k as u32,
            None if k == 0 => {
                self.far.remove(&slot);
            }
            None => {
                self.far.insert(slot, k as u32);
            }
        }
    }

    /// The place of `body`'s entry, if it has one.
    #[inline]
    fn place(&self, body: RigidBodyHandle) -> Option<usize> {
        let k = self.place_at(body.slot());
        (k > 0 && self.bodies[k - 1] == body).then(|| k - 1)
    }

    /// `body`'s shadow, if it has one.
    #[inline]
    pub fn get(&self, body: &RigidBodyHandle) -> Option<&Shadow> {
        self.place(*body).map(|k| &self.shadows[k])
    }

    /// Sets `body`'s shadow, `body` a world's handle. A body of another generation in the same
    /// slot (one rapier removed) loses its own: rapier never hands its handle out again.
    pub fn insert(&mut self, body: RigidBodyHandle, shadow: Shadow) {
        let slot = body.slot();
        if slot >= self.places.len() {
            self.grow_to(slot);
        }
        match self.places[slot] as usize {
            0 => {
                self.push(body, shadow);
                self.places[slot] = self.bodies.len() as u32;
            }
            k => self.set(k - 1, body, shadow),
        }
    }

    /// A new entry, last.
    fn push(&mut self, body: RigidBodyHandle, shadow: Shadow) {
        self.bodies.push(body);
        self.shadows.push(shadow);
    }

    /// The entry at place `k` replaced.
    fn set(&mut self, k: usize, body: RigidBodyHandle, shadow: Shadow) {
        self.bodies[k] = body;
        self.shadows[k] = shadow;
    }

    /// `places` grown to hold `slot`, the far places it reaches moved in.
    #[cold]
    fn grow_to(&mut self, slot: usize) {
        self.places.resize(slot + 1, 0);
        take_in_far(&mut self.places, &mut self.far, |k| k);
    }

    /// The shadows read from a snapshot, which may name a slot no world holds: beyond
    /// [`restored_in_vector`] a shadow's place is kept aside.
    pub fn restored(shadows: impl IntoIterator<Item = (RigidBodyHandle, Shadow)>) -> Self {
        let mut out = Self::default();
        for (body, shadow) in shadows {
            let slot = body.slot();
            if restored_in_vector(slot, out.places.len(), out.bodies.len() + 1) {
                out.insert(body, shadow);
            } else {
                out.put_far(slot, body, shadow);
            }
        }
        out
    }

    /// Sets the shadow of `body`, whose arena slot `slot` lies beyond `places`: its place is
    /// kept in `far`.
    fn put_far(&mut self, slot: usize, body: RigidBodyHandle, shadow: Shadow) {
        match self.far.get(&slot) {
            Some(k) => self.set(*k as usize - 1, body, shadow),
            None => {
                self.push(body, shadow);
                self.far.insert(slot, self.bodies.len() as u32);
            }
        }
    }

    /// Removes `body`'s shadow, if it has one.
    pub fn remove(&mut self, body: &RigidBodyHandle) {
        let Some(k) = self.place(*body) else {
            return;
        };
        self.set_place(body.slot(), 0);
        self.bodies.swap_remove(k);
        self.shadows.swap_remove(k);
        if let Some(moved) = self.bodies.get(k) {
            self.set_place(moved.slot(), k + 1);
        }
    }

    /// Removes every shadow, at a cost of their number (not of the slots').
    pub fn clear(&mut self) {
        for body in &self.bodies {
            if let Some(at) = self.places.get_mut(body.slot()) {
                *at = 0;
            }
        }
        self.far.clear();
        self.bodies.clear();
        self.shadows.clear();
    }

    /// The shadows in arena order.
    pub fn sorted(&self) -> Vec<(RigidBodyHandle, Shadow)> {
        let mut entries: Vec<_> = self.entries().collect();
        entries.sort_unstable_by_key(|(body, _)| body.arena_order());
        entries
    }

    /// Every entry, in the table's order.
    fn entries(&self) -> impl Iterator<Item = (RigidBodyHandle, Shadow)> + '_ {
        self.bodies
            .iter()
            .copied()
            .zip(self.shadows.iter().copied())
    }

    /// How many slots `places` holds (its memory, for the tests).
    #[cfg(test)]
    pub fn slots_held(&self) -> usize {
        self.places.len()
    }
}

/// What one step leaves for the next: the shadows and the roles and holds of its
/// pairs (the hysteresis of the resting and rolling decisions), and the step's tables kept for
/// their allocations.
#[derive(Default)]
pub(crate) struct Memory {
    /// The shadows of the states written in the step (read by the next step's plan).
    pub shadows: Shadows,
    /// The roles of the pairs with grounds.
    pub roles: HandleMap<PairKey, Role>,
    /// The roles of the pairs between opted-in bodies.
    pub pair_roles: HandleMap<PairKey, Role>,
    /// The pairs held at rest (`StepData::holds`).
    pub holds: HandleSet<PairKey>,
    /// The colliders reported for coefficients out of range (`Diagnostic`), each once.
    pub reported: HandleSet<ColliderHandle>,
    /// The side of each mesh or heightfield ground its bodies were on at the last step's
    /// start (`StepData::mesh_sides`).
    pub mesh_sides: HandleMap<PairKey, MeshSide>,
    /// Tables a step fills again, kept from the step before so that their allocations are.
    pub spare: Spare,
    /// The bodies the last step's plan found near a ground (`NearMarks`).
    pub near: NearMarks,
}

/// The bodies a step's plan found near a ground, by body slot, for the next step's survey (the
/// next that runs: a step with `dt == 0` plans nothing and keeps the marks): a body near a
/// ground is most often near still, and the survey plans it without its test of being far (a
/// filter only: a body that is far after all is found not near by its plan). Saved nowhere: a
/// restored plugin surveys every body afresh, to the same results (`tests/snapshot.rs`).
#[derive(Default)]
pub(crate) struct NearMarks {
    /// The step each body was last found near a ground in.
    marks: SlotTable<RigidBodyHandle, u64>,
    /// The current step's number.
    step: u64,
}

impl NearMarks {
    /// A new step: the marks made so far are the last step's.
    pub fn begin_step(&mut self) {
        self.step = self.step.wrapping_add(1);
    }

    /// Did the last step's plan find `body` near a ground?
    #[inline]
    pub fn was_near(&self, body: RigidBodyHandle) -> bool {
        self.marks
            .get(body)
            .is_some_and(|step| step.wrapping_add(1) == self.step)
    }

    /// This step's plan found `body` near a ground.
    pub fn mark(&mut self, body: RigidBodyHandle) {
        self.marks.insert(body, self.step);
    }
}

/// Last step's memory, read by this step's plan while this step's is written.
pub(crate) struct LastStep {
    pub shadows: Shadows,
    pub roles: HandleMap<PairKey, Role>,
    pub pair_roles: HandleMap<PairKey, Role>,
    pub mesh_sides: HandleMap<PairKey, MeshSide>,
}

/// Tables a step fills again, kept from the step before.
#[derive(Default)]
pub(crate) struct Spare {
    pub shadows: Shadows,
    pub roles: HandleMap<PairKey, Role>,
    pub ground_pairs: Vec<GroundPair>,
    pub candidates: Vec<Candidate>,
    pub steered_rolls: Vec<SteeredRoll>,
}

impl Memory {
    /// Opens a step's plan: hands over last step's shadows and roles to be read (and its
    /// near marks, `NearMarks::was_near`), and gives `step` the cleared tables to fill (the
    /// roles and their list, the candidates).
    pub fn begin_step(&mut self, step: &mut StepData) -> LastStep {
        self.near.begin_step();
        let shadows = std::mem::replace(&mut self.shadows, std::mem::take(&mut self.spare.shadows));
        self.shadows.clear();
        let roles = std::mem::take(&mut self.roles);
        step.roles = std::mem::take(&mut self.spare.roles);
        step.roles.clear();
        step.ground_pairs = std::mem::take(&mut self.spare.ground_pairs);
        step.ground_pairs.clear();
        step.candidates = std::mem::take(&mut self.spare.candidates);
        step.candidates.clear();
        step.steered_rolls = std::mem::take(&mut self.spare.steered_rolls);
        step.steered_rolls.clear();
        let pair_roles = std::mem::take(&mut self.pair_roles);
        let mesh_sides = std::mem::take(&mut self.mesh_sides);
        LastStep {
            shadows,
            roles,
            pair_roles,
            mesh_sides,
        }
    }

    /// Closes a step's plan: last step's tables become spare.
    pub fn end_planning(&mut self, last: LastStep) {
        self.spare.shadows = last.shadows;
        self.spare.roles = last.roles;
    }

    /// The pairs of rolling balls released at the step's end (`EventKind::Released`) become
    /// `Resting`: the next step's plan, finding them within reach, does not release them again.
    pub fn release(&mut self, pairs: Vec<PairKey>) {
        for key in pairs {
            self.roles.insert(key, Role::Resting);
        }
    }

    /// Keeps each collider's first report of coefficients out of range only: a collider is
    /// met in a pair at every step until its coefficients change.
    pub fn report_once(&mut self, diagnostics: &mut Vec<Diagnostic>) {
        diagnostics.retain(|d| match d {
            Diagnostic::CoefficientsOutOfRange { collider, .. } => self.reported.insert(*collider),
            _ => true,
        });
    }

    /// After rapier's step: this step's roles and holds become what the next step reads (the
    /// roles' list, read by the hooks only, is kept for the next step to fill).
    pub fn keep_roles(&mut self, step: &mut StepData) {
        self.roles = std::mem::take(&mut step.roles);
        self.spare.ground_pairs = std::mem::take(&mut step.ground_pairs);
        self.pair_roles = std::mem::take(&mut step.pairs.roles);
        self.mesh_sides = std::mem::take(&mut step.mesh_sides);
        self.holds.clear();
        self.holds.extend(step.holds.keys().copied());
    }
}

/// What [`Memory`] carries to the next step, in arena order (`snapshot.rs`); the spare
/// tables are allocations only.
#[derive(Clone, Debug, PartialEq)]
#[cfg_attr(
    feature = "serde-serialize",
    derive(serde::Serialize, serde::Deserialize)
)]
pub(crate) struct SavedMemory {
    pub shadows: Vec<(RigidBodyHandle, Shadow)>,
    pub roles: Vec<(PairKey, Role)>,
    pub pair_roles: Vec<(PairKey, Role)>,
    pub holds: Vec<PairKey>,
    pub reported: Vec<ColliderHandle>,
    pub mesh_sides: Vec<(PairKey, MeshSide)>,
}

impl Memory {
    /// What the next step would read.
    pub fn save(&self) -> SavedMemory {
        SavedMemory {
            shadows: self.shadows.sorted(),
            roles: sorted_entries(&self.roles),
            pair_roles: sorted_entries(&self.pair_roles),
            holds: sorted_members(&self.holds),
            reported: sorted_members(&self.reported),
            mesh_sides: sorted_entries(&self.mesh_sides),
        }
    }

    /// The memory `saved` was taken from (less its spare allocations).
    pub fn from_saved(saved: &SavedMemory) -> Self {
        Self {
            shadows: Shadows::restored(saved.shadows.iter().copied()),
            roles: saved.roles.iter().copied().collect(),
            pair_roles: saved.pair_roles.iter().copied().collect(),
            holds: saved.holds.iter().copied().collect(),
            reported: saved.reported.iter().copied().collect(),
            mesh_sides: saved.mesh_sides.iter().copied().collect(),
            spare: Spare::default(),
            near: NearMarks::default(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::{NearMarks, Shadow, Shadows};
    use crate::rapier::math::{Rotation, Vector};
    use crate::rapier::prelude::RigidBodyHandle;
    use nalgebra::Vector3;

    /// A shadow told apart by its centre's `x`.
    fn shadow(x: f64) -> Shadow {
        Shadow {
            com: Vector3::new(x, 0.0, 0.0),
            v: Vector3::zeros(),
            w: Vector3::zeros(),
            local_com: Vector3::zeros(),
            written_translation: Vector::ZERO,
            written_rotation: Rotation::IDENTITY,
            written_linvel: Vector::ZERO,
            written_angvel: Vector::ZERO,
        }
    }

    /// A shadow is found by its whole handle, after others are removed around it (an entry
    /// moved into a removed one's place), replaced by another generation of its slot, and
    /// listed in arena order whatever the order of the inserts.
    #[test]
    fn a_shadow_is_found_by_its_handle_and_listed_in_arena_order() {
        let h = |slot, generation| RigidBodyHandle::from_raw_parts(slot, generation);
        let mut shadows = Shadows::restored([(h(7, 0), shadow(7.0)), (h(2, 0), shadow(2.0))]);
        shadows.insert(h(5, 0), shadow(5.0));
        shadows.insert(h(2, 0), shadow(2.5));
        assert_eq!(shadows.get(&h(2, 0)), Some(&shadow(2.5)), "replaced");
        assert_eq!(shadows.get(&h(2, 1)), None, "another generation");
        assert_eq!(shadows.get(&h(40, 0)), None, "beyond the slots");
        shadows.remove(&h(7, 0));
        shadows.remove(&h(7, 0));
        assert_eq!(shadows.get(&h(7, 0)), None);
        assert_eq!(
            shadows.get(&h(5, 0)),
            Some(&shadow(5.0)),
            "moved in its place"
        );
        shadows.insert(h(5, 1), shadow(5.5));
        assert_eq!(
            shadows.get(&h(5, 0)),
            None,
            "its slot taken by another generation"
        );
        let listed = shadows.sorted();
        assert_eq!(listed, vec![(h(2, 0), shadow(2.5)), (h(5, 1), shadow(5.5))]);
        shadows.clear();
        assert!(shadows.sorted().is_empty() && shadows.get(&h(2, 0)).is_none());
        shadows.insert(h(2, 0), shadow(1.0));
        assert_eq!(shadows.sorted(), vec![(h(2, 0), shadow(1.0))]);
    }

    /// A restored shadow at a slot far beyond the others' (a forged snapshot's) is kept
    /// aside: the table's slots do not grow to it; it is found, replaced, moved and removed
    /// like any other, and moved in when the table grows to its slot.
    #[test]
    fn a_shadow_far_beyond_the_others_is_kept_aside() {
        let h = |slot, generation| RigidBodyHandle::from_raw_parts(slot, generation);
        let (far, other) = (u32::MAX - 1, u32::MAX - 7);
        let shadows = Shadows::restored([
            (h(far, 0), shadow(1.0)),
            (h(3, 0), shadow(3.0)),
            (h(other, 0), shadow(9.0)),
        ]);
        assert_eq!(shadows.slots_held(), 4);
        assert_eq!(shadows.get(&h(far, 0)), Some(&shadow(1.0)));
        assert_eq!(shadows.get(&h(far, 1)), None, "another generation");
        assert_eq!(shadows.get(&h(far - 1, 0)), None, "another far slot");
        let mut shadows = Shadows::restored(shadows.entries().chain([(h(far, 1), shadow(2.0))]));
        assert_eq!(shadows.get(&h(far, 0)), None, "its slot taken");
        assert_eq!(shadows.get(&h(far, 1)), Some(&shadow(2.0)));
        // The far shadow is first in the entries: removing it moves the last, also far, into
        // its place.
        shadows.remove(&h(far, 1));
        assert_eq!(shadows.get(&h(far, 1)), None);
        assert_eq!(shadows.get(&h(other, 0)), Some(&shadow(9.0)), "moved");
        assert_eq!(shadows.get(&h(3, 0)), Some(&shadow(3.0)));
        shadows.remove(&h(other, 0));
        assert_eq!(shadows.get(&h(other, 0)), None);
        assert_eq!(shadows.sorted(), vec![(h(3, 0), shadow(3.0))]);
        // Restored entries enough bring a far slot within reach: the table grows to it.
        let mut shadows = Shadows::restored(
            (0..600)
                .map(|k| (h(10 + k, 0), shadow(0.0)))
                .chain([(h(100_000, 0), shadow(4.0))]),
        );
        assert_eq!(shadows.slots_held(), 100_001);
        let mut shadows_few = Shadows::restored([(h(100_000, 0), shadow(4.0))]);
        assert_eq!(shadows_few.slots_held(), 0, "beyond reach of one entry");
        // A world's handle grows the table whatever the count, and takes the far one in.
        shadows_few.insert(h(100_000, 1), shadow(6.0));
        assert_eq!(shadows_few.slots_held(), 100_001);
        assert_eq!(
            shadows_few.get(&h(100_000, 0)),
            None,
            "taken in, then replaced"
        );
        assert_eq!(shadows_few.get(&h(100_000, 1)), Some(&shadow(6.0)));
        assert_eq!(shadows_few.sorted().len(), 1);
        shadows.clear();
        assert!(shadows.sorted().is_empty() && shadows.get(&h(100_000, 0)).is_none());
        let mut shadows = Shadows::restored([(h(far, 0), shadow(7.0)), (h(3, 0), shadow(3.0))]);
        shadows.clear();
        assert!(shadows.sorted().is_empty() && shadows.get(&h(far, 0)).is_none());
        shadows.insert(h(5, 0), shadow(8.0));
        assert_eq!(shadows.sorted(), vec![(h(5, 0), shadow(8.0))]);
    }

    /// A mark answers for the next step only, and only for its own body: not for a body
    /// that took its slot, not two steps on, not before the plan made it.
    #[test]
    fn a_near_mark_holds_for_the_next_step_and_its_own_body() {
        let (a, b) = (
            RigidBodyHandle::from_raw_parts(3, 0),
            RigidBodyHandle::from_raw_parts(3, 1),
        );
        let mut near = NearMarks::default();
        near.begin_step();
        near.mark(a);
        assert!(!near.was_near(a), "marked this step, not the last");
        near.begin_step();
        assert!(near.was_near(a));
        assert!(!near.was_near(b), "another body in the same slot");
        assert!(!near.was_near(RigidBodyHandle::from_raw_parts(7, 0)));
        near.begin_step();
        assert!(!near.was_near(a), "two steps on");
    }
}
