//! Plan: what the step decided for each body and pair before rapier's step, and the data it
//! carries to the stages after it.
//!
//! Contract: [`Candidate`] is what the plan knows of one managed body at the step's start (its state, flight, and which
//! grounds may reach it), [`StepData`] the step's thresholds, roles and candidates. The
//! decisions themselves are [`super::policy::Policy`]'s; this file holds no rapier call.

use super::geometry::SmallList;
use super::ground_index::GroundMotion;
use super::handles::HandleMap;
use super::install::Lookup;
use super::observe::Sets;
use super::policy::{Policy, Role};
use super::resolve::PairKey;
use crate::motion::{Flight, Rolling, State};
use crate::rapier::prelude::RigidBodyHandle;
use nalgebra::Vector3;

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
    /// (see `Settle::resting_end`).
    pub turning_resting: SmallList<(usize, Vector3<f64>)>,
    /// Its rotation moves its surface (it is not a single ball about its centre): see
    /// `Settle::resting_end` and `Settle::turned_end`.
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
    pub roles: HandleMap<PairKey, Role>,
    pub grounds: Vec<GroundMotion>,
    pub candidates: Vec<Candidate>,
    /// Managed bodies asleep at the start of the step (see `Settle::woken_end`).
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

/// Does the contact, at gap `dist` (m) with normal speed `un` and normal acceleration `an`,
/// close within `dt`? `dist + un t + an t^2 / 2 <= 0` for some `t` in `[0, dt]`.
pub(crate) fn closes_within(dist: f64, un: f64, an: f64, dt: f64) -> bool {
    let at = |t: f64| dist + un * t + 0.5 * an * t * t;
    if at(0.0) <= 0.0 || at(dt) <= 0.0 {
        return true;
    }
    if an > 0.0 {
        let t = -un / an;
        return t > 0.0 && t < dt && at(t) <= 0.0;
    }
    false
}
