//! The step's own data: what the plan decided, carried from `before_step` through rapier's
//! step to the stages after it.

use crate::motion::{Flight, Rolling, State};
use crate::plugin::bridge::convert::vec_from_na;
use crate::plugin::config::TimingMode;
use crate::plugin::events::Diagnostic;
use crate::plugin::policy::{Policy, Role};
use crate::plugin::queries::ground_index::GroundMotion;
use crate::plugin::state::handles::{HandleMap, PairKey, SlotTable};
use crate::plugin::state::small_list::SmallList;
use crate::rapier::math::Vector;
use crate::rapier::prelude::{ActiveHooks, ColliderHandle, RigidBodyHandle};
use nalgebra::Vector3;

/// A ball's first step held at rest on a slope (`OnPlane::Held`): rapier's resting contact
/// starts without the impulses of a step before, and in its substeps lets the ball creep
/// downhill and sink before it holds it. After the step the ball is put back where it
/// stopped, if nothing else moved it, so that it rests where the closed form stopped it; from
/// the next step rapier's contact, warm-started, holds it still and sleeps it.
pub(crate) struct FirstHold {
    pub body: RigidBodyHandle,
    pub collider: ColliderHandle,
    pub ground: ColliderHandle,
    /// Where it stopped: the step's start, at rest.
    pub start: State,
    pub local_com: Vector3<f64>,
    /// The ground's normal.
    pub normal: Vector3<f64>,
    /// From its centre to the contact point (m).
    pub radius: f64,
}

/// A pair of a body collider and a ground as the plan decided it (`StepData::ground_pairs`).
#[derive(Clone, Copy)]
pub(crate) struct GroundPair {
    /// (body collider, ground collider), the key of `StepData::roles`.
    pub key: PairKey,
    pub role: Role,
    /// The hook flags the user set on the body collider (`HookFlags::recorded_user_flags`).
    pub body_user: ActiveHooks,
    /// The hook flags the user set on the two colliders (`body_user` and the ground's).
    pub user: ActiveHooks,
}

/// A managed body's start-of-step snapshot.
pub(crate) struct Candidate {
    pub body: RigidBodyHandle,
    pub start: State,
    pub flight: Flight,
    pub local_com: Vector3<f64>,
    /// Indices (in `StepData::grounds`) of the grounds its swept bounding sphere meets.
    pub near: SmallList<usize>,
    /// The ball (centre and radius, m) the plan looked for grounds in: about the body's
    /// start-of-step centre of mass, its bounding radius and its reach in the step (`near`
    /// holds what it found; radius 0 for a body not planned near a ground). An impact that
    /// sends the body beyond it looks again along its way on
    /// (`reconstruct::grounds_beyond_plan`).
    pub looked_in: (Vector3<f64>, f64),
    /// Indices (in `StepData::grounds`) of the grounds it has `Impact` pairs with.
    pub impact_grounds: SmallList<usize>,
    /// Step mode: impulses were applied at the start.
    pub touched: bool,
    /// Some pair with an `impact_grounds` ground may meet in the step (else the search from
    /// the start state would find it clear: see `geometry::cannot_close`).
    pub closing: bool,
    /// Resting pairs of a body turning fast enough that a point of it could go deeper than
    /// the resting gap in the step (a box tipping off its edge, a capsule swinging down at a
    /// wall, a ball spun fast): each ground's index (in `StepData::grounds`) and the resting
    /// contact point in the body's frame (from its centre of mass). Checked after the step
    /// (`EndCheck::TurningResting`).
    pub turning_resting: SmallList<(usize, Vector3<f64>)>,
    /// Its rotation moves its surface (it is not a single ball about its centre): see
    /// `EndCheck::TurningResting` and `AfterStep::turned_end` (`stages/bodies.rs`).
    pub turns_surface: bool,
    /// A ball sliding on a level ground (`Role::Rolling`): the ground's index (in
    /// `StepData::grounds`) and the motion. `start` then touches the ground.
    pub rolling: Option<(usize, Rolling)>,
    /// With `rolling`: the plan found the ball on level ground, over one flat face of a
    /// ground that does not move (a half-space, or a cuboid's face it stays well inside of
    /// for its whole travel in the step), with no other ground near it, its collider exactly
    /// at its centre and its coordinates within `policy::on_plane_through_rounding`. Its
    /// closed-form end then touches that face to `policy::on_plane`'s measure, and is written
    /// without a contact query (`AfterStep::roll`, when nothing else acted on it).
    pub rolls_on_one_face: bool,
    /// A ball that rolled in closed form last step and is handed to rapier's resting contact
    /// at this step's start (`EventKind::Released`, something else within reach): the
    /// ground's index (in `StepData::grounds`). rapier's end state is checked against it
    /// (`EndCheck::ReleasedResting`).
    pub released: Option<usize>,
    /// `Exact` mode's steering of a free flight (`stages/steer.rs`): rapier's step started it
    /// lower than its own velocity, by `Candidate::flight_steering`.
    pub steered: bool,
    /// The steering of a closed-form roll (`stages/steer.rs`, every mode): its index in
    /// `StepData::steered_rolls` (read through `StepData::steered_roll`); `None` for a ball
    /// not steered.
    pub steered_roll: Option<u32>,
}

/// A closed-form roll that rapier's integrator carries (`stages/steer.rs`): rapier's step
/// starts the ball with the velocities under which it lands on the roll's end. What the
/// stages after rapier's step read of it; the steering velocities themselves are the steer
/// stage's.
#[derive(Clone, Copy, Debug)]
pub(crate) struct SteeredRoll {
    /// The closed form's end of the step (from `Candidate::start`).
    pub end: State,
    /// The centre of mass rapier's step starts from (m).
    pub from: Vector3<f64>,
    /// The velocities rapier held less the ones the steering started it with (m/s, rad/s):
    /// given back to a ball something else acted on, whose end state is rapier's.
    pub offsets: (Vector3<f64>, Vector3<f64>),
}

impl Candidate {
    /// How much lower than its own velocity rapier's step started a steered flight (m/s): its
    /// acceleration times the step's `StepData::steering_lag` (`stages/steer.rs`); `None` for
    /// a candidate not steered so.
    pub fn flight_steering(&self, steering_lag: f64) -> Option<Vector3<f64>> {
        self.steered.then(|| self.flight.accel * steering_lag)
    }

    /// The linear velocity rapier's step starts a steered flight from: its start's less the
    /// steering (`flight_steering`), in rapier's precision (the steer stage writes it, and the
    /// bodies stage checks rapier's change of velocity from it); `None` for a candidate not
    /// steered so.
    pub fn steered_velocity(&self, steering_lag: f64) -> Option<Vector> {
        self.flight_steering(steering_lag)
            .map(|offset| vec_from_na(&(self.start.v - offset)))
    }

    /// Does a body that no ground can reach in the step get a (flying) candidate? In `Exact`
    /// mode, for its exact flight; a body of an `Impact` pair between bodies (`member`), for
    /// its cluster; and, in `TimeOfImpact` mode, a body opted in to impacts between bodies
    /// (`takes_pairs`), so that a cluster whose body an event sends towards it can take it in
    /// and move it in the step (without a candidate the cluster is left to the step's end).
    /// `takes_pairs` is asked only in that mode.
    pub fn wanted_in_flight(
        timing: TimingMode,
        member: bool,
        takes_pairs: impl FnOnce() -> bool,
    ) -> bool {
        match timing {
            TimingMode::Exact => true,
            TimingMode::TimeOfImpact => member || takes_pairs(),
            TimingMode::Step => member,
        }
    }

    /// A body that no ground can reach in the step (only its flight, in `Exact` mode).
    pub fn flying(
        body: RigidBodyHandle,
        start: State,
        flight: Flight,
        local_com: Vector3<f64>,
    ) -> Self {
        Self {
            body,
            start,
            flight,
            local_com,
            near: SmallList::Empty,
            looked_in: (start.com, 0.0),
            impact_grounds: SmallList::Empty,
            touched: false,
            closing: false,
            turning_resting: SmallList::Empty,
            turns_surface: false,
            rolling: None,
            rolls_on_one_face: false,
            released: None,
            steered: false,
            steered_roll: None,
        }
    }
}

/// The face of a mesh or heightfield ground a body part touched at a step's start: the
/// contact normal, from the ground into the body, and the contact's point on the ground,
/// both in the ground's frame, so that a moving mesh carries them.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(
    feature = "serde-serialize",
    derive(serde::Serialize, serde::Deserialize)
)]
pub(crate) struct MeshSide {
    pub normal: Vector3<f64>,
    pub face_point: Vector3<f64>,
}

impl MeshSide {
    pub fn is_finite(&self) -> bool {
        self.normal
            .iter()
            .chain(self.face_point.iter())
            .all(|x| x.is_finite())
    }
}

#[derive(Default)]
pub(crate) struct StepData {
    pub active: bool,
    pub dt: f64,
    /// The step's thresholds.
    pub policy: Policy,
    /// The unit direction of gravity (zero without gravity).
    pub down: Vector3<f64>,
    /// The world's gravity (m/s^2).
    pub gravity: Vector3<f64>,
    /// How much lower than the exact flight the end state that stands after a step clear
    /// of impacts can be, per unit of acceleration (s^2): in `TimeOfImpact` and `Step` modes
    /// rapier's substepped integrator, which moves a body by `(N + 1) / 2N a dt^2` in `N`
    /// substeps where the flight moves it `a dt^2 / 2`, so `dt^2 / 2N`; 0 in `Exact` mode,
    /// which flies exactly.
    pub integrator_lag: f64,
    /// How much lower than its own velocity rapier's step starts a flight that `Exact` mode
    /// steers, per unit of acceleration (s): rapier's substepped integrator moves a body by
    /// `(N + 1) / 2N a dt^2` in `N` substeps, so started from `v0 - a dt / 2N` it lands on the
    /// exact flight's `v0 dt + a dt^2 / 2`: `dt / 2N` (`stages/steer.rs`).
    pub steering_lag: f64,
    /// rapier's solver substeps in the step (`IntegrationParameters::num_solver_iterations`,
    /// at least 1).
    pub substeps: usize,
    pub roles: HandleMap<PairKey, Role>,
    /// The pairs of `roles` in the order the plan decided them, each key once and with the
    /// role `roles` holds, and the user's hook flags the plan read for them: the hooks'
    /// tables are built from this list (`Lookup::build`), not by walking the map.
    pub ground_pairs: Vec<GroundPair>,
    /// The colliders of the bodies planned against a slab's tiles one by one (a jointed body,
    /// or one whose pairs the user's filter decides): their roles are by tile; every other
    /// body's pair with a tile is its slab's, under the stand-in (`GroundIndex::stand_in`).
    pub by_tile: Vec<ColliderHandle>,
    /// `Resting` pairs of a ball the closed form holds at rest on a slope (`OnPlane::Held`):
    /// the slope's tilt (`Rolling::holding_tilt`). The hook moves rapier's contact points to
    /// where the normal force holds the ball (`hooks/mod.rs`).
    pub holds: HandleMap<PairKey, Vector3<f64>>,
    /// The side of each pair of a body with a mesh or heightfield ground at the step's start:
    /// a mesh has no inside, and a body found on the other side of that face at the next step
    /// crossed it (`Planner::mesh_side`).
    pub mesh_sides: HandleMap<PairKey, MeshSide>,
    /// The balls held at rest this step and not the last (`FirstHold`).
    pub first_holds: Vec<FirstHold>,
    /// The pairs of opted-in balls and their roles (`pair_plan.rs`).
    pub pairs: PairPlan,
    /// Every ground's motion over the step (the ground index's list). Lent to the plan
    /// (`Planner::grounds`) while it runs, and empty here meanwhile.
    pub grounds: Vec<GroundMotion>,
    pub candidates: Vec<Candidate>,
    /// The steerings of the closed-form rolls (`Candidate::steered_roll`), apart from the
    /// candidates: only the rolls rapier's integrator carries have one, and only the steer
    /// stage and the bodies stage read them.
    pub steered_rolls: Vec<SteeredRoll>,
    /// Managed bodies asleep at the start of the step (see `EndCheck::Woken`).
    pub asleep: Vec<RigidBodyHandle>,
}

impl StepData {
    /// The steering of the candidate's closed-form roll, if rapier's integrator carries it.
    pub fn steered_roll(&self, cand: &Candidate) -> Option<&SteeredRoll> {
        cand.steered_roll.map(|k| &self.steered_rolls[k as usize])
    }
}

/// A pair of bodies with a role this step.
#[derive(Clone, Copy, Debug)]
pub(crate) struct PlannedPair {
    pub a: RigidBodyHandle,
    pub b: RigidBodyHandle,
    /// The pair's key ([`pair_key`] of the two bodies' colliders).
    pub key: PairKey,
    /// Two centred balls: the line of centres is the contact normal, and `reach` the
    /// centres' distance at contact. Otherwise any shapes (`body_contact.rs` finds the
    /// contact).
    pub balls: bool,
    /// The two radii summed, skins included (m): the centres' distance at contact (balls;
    /// for other shapes, their bounding radii summed).
    pub reach: f64,
    /// Unit contact normal at the step's start, from `a` to `b` (the line of centres for
    /// balls).
    pub normal: Vector3<f64>,
    /// `b`'s centre of mass less `a`'s at the step's start (m).
    pub offset: Vector3<f64>,
    /// `b`'s velocity less `a`'s at the step's start (m/s).
    pub relative_v: Vector3<f64>,
    pub role: Role,
    /// Its bodies need the plugin's hook flags: an `Impact` pair leaves rapier's solver, and a
    /// `Resting` one that rapier would bounce higher than the resting gap gets zero
    /// restitution. A pair with hook flags is never recycled by rapier's contact detection, so
    /// only the pairs that need them are hooked.
    pub hooked: bool,
}

/// The pairs of the step.
#[derive(Default)]
pub(crate) struct PairPlan {
    pub pairs: Vec<PlannedPair>,
    /// Each pair's role by [`pair_key`].
    pub roles: HandleMap<PairKey, Role>,
    /// The bodies of the `Impact` pairs: the reconstruct stage moves them together.
    pub members: SlotTable<RigidBodyHandle, ()>,
    /// The opted-in bodies' colliders whose coefficients are out of range: no members.
    pub refused: Vec<Diagnostic>,
}
