//! The step's own data: what the plan decided, carried from `before_step` through rapier's
//! step to the stages after it.

use crate::motion::{Flight, Rolling, State};
use crate::plugin::config::{ImpactConfig, TimingMode};
use crate::plugin::events::ImpactEvent;
use crate::plugin::hooks::flags::HookFlags;
use crate::plugin::hooks::lookup::Lookup;
use crate::plugin::policy::{Policy, Role};
use crate::plugin::queries::ground_index::GroundMotion;
use crate::plugin::queries::observe::Sets;
use crate::plugin::stages::commit::Commit;
use crate::plugin::stages::pair_plan::PairPlan;
use crate::plugin::state::handles::{HandleMap, PairKey};
use crate::plugin::state::memory::Memory;
use crate::plugin::state::registry::Registry;
use crate::plugin::state::small_list::SmallList;
use crate::rapier::prelude::{ColliderHandle, RigidBodyHandle};
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

/// A managed body's start-of-step snapshot.
pub(crate) struct Candidate {
    pub body: RigidBodyHandle,
    pub start: State,
    pub flight: Flight,
    pub local_com: Vector3<f64>,
    /// Indices (in `StepData::grounds`) of the grounds its swept bounding sphere meets.
    pub near: SmallList<usize>,
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
}

impl Candidate {
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
            impact_grounds: SmallList::Empty,
            touched: false,
            closing: false,
            turning_resting: SmallList::Empty,
            turns_surface: false,
            rolling: None,
        }
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
    pub roles: HandleMap<PairKey, Role>,
    /// `Resting` pairs of a ball the closed form holds at rest on a slope (`OnPlane::Held`):
    /// the slope's tilt (`Rolling::holding_tilt`). The hook moves rapier's contact points to
    /// where the normal force holds the ball (`hooks/mod.rs`).
    pub holds: HandleMap<PairKey, Vector3<f64>>,
    /// The balls held at rest this step and not the last (`FirstHold`).
    pub first_holds: Vec<FirstHold>,
    /// The pairs of opted-in balls and their roles (`pair_plan.rs`).
    pub pairs: PairPlan,
    pub grounds: Vec<GroundMotion>,
    pub candidates: Vec<Candidate>,
    /// Managed bodies asleep at the start of the step (see `EndCheck::Woken`).
    pub asleep: Vec<RigidBodyHandle>,
    pub lookup: Lookup,
}

/// The step's data in `after_step`, with rapier's sets after its step.
pub(crate) struct EndOfStep<'a> {
    pub data: StepData,
    pub sets: Sets<'a>,
}

impl std::ops::Deref for EndOfStep<'_> {
    type Target = StepData;
    fn deref(&self) -> &StepData {
        &self.data
    }
}

impl std::ops::DerefMut for EndOfStep<'_> {
    fn deref_mut(&mut self) -> &mut StepData {
        &mut self.data
    }
}

/// What the stages after rapier's step read of the plugin (the configuration, the registry,
/// the hook flags, this step's roles of the pairs with grounds) and the one writer they
/// write through.
pub(crate) struct AfterStep<'a> {
    pub config: &'a ImpactConfig,
    pub registry: &'a Registry,
    pub flags: &'a HookFlags,
    pub roles: &'a HandleMap<PairKey, Role>,
    pub commit: Commit<'a>,
    /// The pairs of rolling balls released at the step's end (`EventKind::Released`): their
    /// role becomes `Resting`, so that the next step's plan, finding them within reach, does
    /// not release them again.
    pub released: Vec<PairKey>,
}

impl<'a> AfterStep<'a> {
    /// The view of a plugin's parts; `exact`: `TimingMode::Exact` (see `Commit`).
    pub fn new(
        (config, registry, flags): (&'a ImpactConfig, &'a Registry, &'a HookFlags),
        memory: &'a mut Memory,
        events: &'a mut Vec<ImpactEvent>,
    ) -> Self {
        let exact = config.timing == TimingMode::Exact;
        Self {
            config,
            registry,
            flags,
            roles: &memory.roles,
            commit: Commit::new(events, &mut memory.shadows, exact),
            released: Vec::new(),
        }
    }
}
