//! The step, as its stages in the order they run (see `docs/architecture.md`).
//!
//! Before rapier's step ([`ImpactPlugin::before_step`]):
//! 1. prepare (`prepare.rs`): the step's thresholds and the grounds' poses over the step;
//!    last step's memory handed to the plan (`state/memory.rs`, `Memory::begin_step`).
//! 2. pair plan (`pair_plan/`): the pairs of opted-in bodies that may meet and their roles;
//!    their sleeping bodies woken, and in `Step` mode their impulses at the step's start.
//! 3. survey (`prepare.rs`): which managed bodies are asleep (those a fast moving ground
//!    reaches woken), far from every ground (in `Exact` mode a flying candidate each), or to
//!    be planned (outside slabs, a body the last
//!    step's plan found near a ground without the far test: `NearMarks`; in `Exact` mode,
//!    after the plan, such a body found far gets its flight in the survey's place).
//! 4. plan (`plan/`): each planned body's pairs with the grounds near it get a role, the body
//!    a candidate (and in `Step` mode the impulses of the contacts that close in the step).
//! 5. steer (`steer.rs`): the balls rolling alone over one flat face given the velocities
//!    under which rapier's integrator lands them on the roll's end, and in `Exact` mode the
//!    free flights far from the grounds the velocity that lands them on the exact positions.
//! 6. commit (`commit.rs`): the writes recorded so far (the wake-ups, the steering velocities
//!    and, in `Step` mode, the impulses) applied to rapier's bodies.
//! 7. install (`install.rs`): the hook flags and the tables rapier's hook calls read.
//!
//! During rapier's step the plugin is its `PhysicsHooks` (`hooks/`).
//!
//! After rapier's step ([`ImpactPlugin::after_step`]):
//! 1. this step's roles kept for the next (`Memory::keep_roles`; from here the stages read
//!    them as `AfterStep::roles`), and the grounds' actual motion over the step (`prepare.rs`).
//! 2. woken (`woken.rs`): the bodies asleep at the start that rapier woke, checked at the
//!    step's end.
//! 3. pair clusters (`pair_reconstruct/`): the clusters of impacts between bodies, moved
//!    together.
//! 4. bodies (`bodies.rs`): every other candidate, routed to its reconstruction
//!    (`reconstruct.rs`: a rolling ball's closed form, `Exact` mode's flight, the in-step
//!    impacts) and checked at the step's end (`settle.rs`).
//! 5. pair ends (`pair_settle.rs`): the pairs between bodies not moved together, checked at
//!    the step's end, after their bodies' own checks.
//! 6. holds (`bodies.rs`): the balls held at rest on a slope for their first step, put back.
//! 7. commit (`commit.rs`): the writes recorded after rapier's step applied, and the colliders
//!    moved to their bodies' poses; the step's tables kept for the next.
//!
//! The stages take rapier's bodies read-only: every write is recorded through the one writer
//! (`commit.rs`), and applied, in the order recorded, by the commit stage alone; a stage
//! reads a body the step may have written as those writes leave it (`Commit::body`). Every
//! event goes through the same writer.

mod bodies;
mod commit;
mod install;
pub(crate) mod pair_plan;
mod pair_reconstruct;
mod pair_settle;
mod plan;
mod prepare;
mod reconstruct;
mod settle;
mod steer;
mod view;
mod woken;

use crate::plugin::bridge::convert::vec_to_na;
use crate::plugin::config::TimingMode;
use crate::plugin::impact_plugin::{ImpactPlugin, StepSets};
use crate::plugin::policy::Role;
use crate::plugin::profile::{Stage, StepCounts};
use crate::plugin::queries::filter;
use crate::plugin::queries::observe::Sets;
use crate::plugin::stages::commit::{Commit, Origin};
use crate::plugin::stages::pair_plan::{PairInputs, StepStart, pair_key};
use crate::plugin::stages::pair_reconstruct::NearBodies;
use crate::plugin::stages::plan::{PlanReports, Planner};
use crate::plugin::stages::prepare::UntestedFlights;
use crate::plugin::stages::view::AfterStep;
use crate::plugin::stages::view::EndOfStep;
use crate::plugin::state::handles::HandleSet;
use crate::plugin::state::memory::LastStep;
use crate::plugin::state::step::StepData;
use crate::rapier::math::Vector;
use crate::rapier::prelude::{
    ColliderHandle, ColliderSet, EventHandler, IntegrationParameters, PhysicsHooks, PhysicsWorld,
    RigidBodyHandle, RigidBodySet,
};

/// The step: its entry points, each a list of stage calls.
impl<H: PhysicsHooks> ImpactPlugin<H> {
    /// Steps `world` once with the plugin: [`Self::before_step`], rapier's step with the
    /// plugin as hooks, [`Self::after_step`].
    pub fn step(&mut self, world: &mut PhysicsWorld) {
        self.step_with_events(world, &());
    }

    /// [`Self::step`] with rapier's event handler `events`.
    pub fn step_with_events(&mut self, world: &mut PhysicsWorld, events: &dyn EventHandler) {
        let (gravity, params) = (world.gravity, world.integration_parameters);
        self.before_step(gravity, &params, StepSets::from(&mut *world));
        world.step_with_events(&*self, events);
        self.stopwatch.lap(Stage::Rapier);
        self.after_step(StepSets::from(world));
    }

    /// Prepares a step: call it right before rapier's `PhysicsPipeline::step` with the same
    /// gravity, parameters and sets. Clears the events, reads the managed bodies near a
    /// ground, and in `Step` mode applies the impulses of the contacts that close in this
    /// step.
    pub fn before_step(&mut self, gravity: Vector, params: &IntegrationParameters, sets: StepSets) {
        self.stopwatch.start_step();
        let (bodies, colliders, sets) = sets.into_parts();
        // rapier's step first moves the colliders of the bodies moved since the last one (a
        // fixed body the user moved; the plugin's own writes were carried at the last step's
        // end): the same now, so that the plan meets every collider where rapier's step will.
        bodies.propagate_modified_body_positions_to_colliders(colliders);
        let mut step = self.prepare(gravity, params, (bodies, colliders), sets.multibody_joints);
        self.stopwatch.lap(Stage::Prepare);
        if !step.active {
            self.step = step;
            return;
        }
        let last = self.memory.begin_step(&mut step);
        self.plan_pairs(&mut step, bodies, colliders, &sets, &last);
        self.stopwatch.lap(Stage::PairPlan);
        let rapier_gravity = (gravity, params.dt);
        let scene = (&*bodies, &*colliders, &sets);
        let mut survey = self.survey(&mut step, rapier_gravity, scene, &last);
        self.wake(&survey.woken);
        self.stopwatch.lap(Stage::Survey);
        let to_plan = std::mem::take(&mut survey.to_plan);
        let planned_count = to_plan.len();
        let planning = (to_plan, &mut survey.untested);
        let (near, not_near) =
            self.plan_bodies(&mut step, planning, bodies, colliders, &sets, &last);
        Self::place_untested_flights(&mut step, &mut survey.untested);
        self.stopwatch.lap(Stage::Plan);
        self.stopwatch.count(|c| {
            (c.asleep, c.far, c.planned) = (step.asleep.len(), survey.far.len(), planned_count);
            (c.near, c.candidates) = (near.len(), step.candidates.len());
        });
        survey.far.extend(not_near);
        self.steer(&mut step, bodies, &sets, &last);
        self.stopwatch.lap(Stage::Steer);
        if !self.reports.diagnostics.is_empty() {
            self.memory.report_once(&mut self.reports.diagnostics);
        }
        self.commit(bodies, None);
        let planned = (near.as_slice(), survey.far.as_slice());
        let last_pairs = &last.pair_roles;
        self.install(
            &step,
            last_pairs,
            (bodies, colliders),
            planned,
            survey.unmanaged,
        );
        self.memory.end_planning(last);
        self.stopwatch.lap(Stage::Install);
        let hooked = self.flags.hooked().len();
        self.stopwatch.count(|c| count_roles(c, &step, hooked));
        // The counting is the profile's own cost, charged to no stage.
        self.stopwatch.restart();
        self.step = step;
    }

    /// Finishes a step: call it right after rapier's `PhysicsPipeline::step`. Resolves the
    /// managed impacts, writes poses and velocities back (bodies woken up), moves their
    /// colliders, and records the [`crate::ImpactEvent`]s.
    pub fn after_step(&mut self, sets: StepSets) {
        let (bodies, colliders, sets) = sets.into_parts();
        let mut step = EndOfStep {
            data: std::mem::take(&mut self.step),
            sets,
            moved_together: HandleSet::default(),
        };
        if !step.active {
            return;
        }
        self.stopwatch.restart();
        self.memory.keep_roles(&mut step);
        self.measure_ground_motion(&mut step, bodies);
        self.check_woken(&step, bodies, colliders);
        self.stopwatch.lap(Stage::Woken);
        let (moved_together, cluster_runs) = self.move_clusters(&step, bodies, colliders);
        step.moved_together = moved_together;
        self.stopwatch.count(|c| c.cluster_runs = cluster_runs);
        self.stopwatch.lap(Stage::PairClusters);
        self.reconstruct_bodies(&step, bodies, colliders);
        self.stopwatch.lap(Stage::Bodies);
        self.settle_pairs(&step, bodies, colliders);
        self.stopwatch.lap(Stage::PairEnds);
        self.put_back_held(&step, bodies);
        self.stopwatch.lap(Stage::Holds);
        self.commit(bodies, Some(colliders));
        self.name_tiles(&step.data.by_tile);
        let events = self.reports.events.len();
        self.stopwatch.count(|c| c.events = events);
        self.registry.index.motions = std::mem::take(&mut step.data.grounds);
        self.memory.spare.candidates = std::mem::take(&mut step.data.candidates);
        self.memory.spare.steered_rolls = std::mem::take(&mut step.data.steered_rolls);
    }
}

impl<H: PhysicsHooks> ImpactPlugin<H> {
    /// The clusters of `Impact` pairs between bodies (`pair_reconstruct.rs`); a pair found on
    /// the way joins a cluster only where rapier would solve it and the user's filter
    /// accepts it (`queries/filter.rs`, as the pair plan asks). Returns the bodies moved, and
    /// the clusters' runs.
    fn move_clusters(
        &mut self,
        step: &EndOfStep,
        bodies: &RigidBodySet,
        colliders: &ColliderSet,
    ) -> (HandleSet<RigidBodyHandle>, usize) {
        let hooks = (&self.user_hooks, &self.flags);
        let refused = |a: RigidBodyHandle, b: RigidBodyHandle| {
            let collider =
                |h: RigidBodyHandle| bodies.get(h).and_then(|rb| rb.colliders().first().copied());
            let (Some(ca), Some(cb)) = (collider(a), collider(b)) else {
                return true;
            };
            let sets = (bodies, colliders, &step.sets);
            filter::pair_refused(hooks, sets, pair_key(ca, cb), (a, b))
        };
        let near = NearBodies {
            index: &self.pair_index,
            bodies,
            refused: &refused,
        };
        let mut view = AfterStep::new(
            (&self.config, &self.registry, &self.flags),
            &self.user_hooks,
            &mut self.memory,
            (&mut self.writes, &mut self.reports),
        );
        pair_reconstruct::move_clusters(&mut view, bodies, colliders, &near, step)
    }

    /// What the stages after rapier's step read of the plugin, and the writer.
    fn after_view(&mut self) -> AfterStep<'_> {
        let reads = (&self.config, &self.registry, &self.flags);
        let writes = (&mut self.writes, &mut self.reports);
        AfterStep::new(reads, &self.user_hooks, &mut self.memory, writes)
    }
}

/// The stage calls that hand the plugin's state to the stages.
impl<H> ImpactPlugin<H> {
    /// The step's events name the tile under their point where the stages named a slab by
    /// its stand-in tile (a body that met the tiles one by one, `by_tile`, names its own).
    fn name_tiles(&mut self, by_tile: &[ColliderHandle]) {
        let index = &self.registry.index;
        if !index.has_slabs() {
            return;
        }
        for event in self.reports.events.iter_mut() {
            if event.body2.is_none() && !by_tile.contains(&event.collider) {
                event.ground = index.tile_at(event.ground, &vec_to_na(event.point));
            }
        }
    }

    /// The pairs of opted-in bodies first (`pair_plan.rs`): a sleeping ball a pair may reach
    /// is woken, and the bodies of `Impact` pairs are planned whatever their distance to the
    /// grounds. In `Step` mode, the impulses of the pairs that close in the step.
    fn plan_pairs(
        &mut self,
        step: &mut StepData,
        bodies: &RigidBodySet,
        colliders: &ColliderSet,
        sets: &Sets,
        last: &LastStep,
    ) where
        H: PhysicsHooks,
    {
        let inputs = PairInputs {
            registry: &self.registry,
            flags: &self.flags,
            user_hooks: &self.user_hooks,
            colliders,
            sets,
            prev: &last.pair_roles,
            grounds: &step.grounds,
            gravity: step.gravity,
            dt: step.dt,
            policy: &step.policy,
            in_step: self.config.timing != TimingMode::Step,
        };
        let (pairs, woken) = pair_plan::plan_pairs(&mut self.pair_index, bodies, &inputs);
        step.pairs = pairs;
        let config = &self.config;
        let exact = config.timing == TimingMode::Exact;
        let mut commit = Commit::new(
            &mut self.writes,
            &mut self.reports,
            &mut self.memory.shadows,
            exact,
        );
        for diagnostic in std::mem::take(&mut step.pairs.refused) {
            commit.diagnose(diagnostic);
        }
        for body in woken {
            commit.wake(body);
        }
        if config.timing == TimingMode::Step && !step.pairs.members.is_empty() {
            let inputs = StepStart {
                colliders,
                registry: &self.registry,
                config,
                law: config.law,
                max_impacts: config.max_impacts_per_step,
                flat_tolerance: config.flat_tolerance,
                policy: &step.policy,
                dt: step.dt,
            };
            pair_plan::step_start_impulses(&mut step.pairs, bodies, &mut commit, &inputs);
        }
    }

    /// Records the wake-ups of the asleep bodies the survey found a moving ground reaches, so
    /// that the plan reads them awake.
    fn wake(&mut self, woken: &[RigidBodyHandle]) {
        if woken.is_empty() {
            return;
        }
        let mut commit = self.writer();
        for body in woken {
            commit.wake(*body);
        }
    }

    /// The one writer (`commit.rs`) over the plugin's writes, reports and shadows, for a stage
    /// that reads nothing else of the plugin while it records.
    fn writer(&mut self) -> Commit<'_> {
        let exact = self.config.timing == TimingMode::Exact;
        Commit::new(
            &mut self.writes,
            &mut self.reports,
            &mut self.memory.shadows,
            exact,
        )
    }

    /// Plans each body of `to_plan` (`plan/`) and records what its plan wrote and reported;
    /// returns those with a ground near them (marked for the next step's survey, `NearMarks`)
    /// and the others but those without a collider to query, each in the order planned. Of
    /// those, a body the survey planned untested gets its flight back into `untested` where
    /// the survey would have found it far (`prepare.rs`, `Exact` mode).
    fn plan_bodies(
        &mut self,
        step: &mut StepData,
        (to_plan, untested): (Vec<RigidBodyHandle>, &mut UntestedFlights),
        bodies: &RigidBodySet,
        colliders: &ColliderSet,
        sets: &Sets,
        last: &LastStep,
    ) -> (Vec<RigidBodyHandle>, Vec<RigidBodyHandle>)
    where
        H: PhysicsHooks,
    {
        let mut near = Vec::with_capacity(self.flags.hooked().len());
        let mut not_near = Vec::new();
        let exact = self.config.timing == TimingMode::Exact;
        let grounds = std::mem::take(&mut step.grounds);
        let mut reports = PlanReports::default();
        let mut ground_side = None;
        self.neighbours.begin_plan(step.gravity, step.dt);
        for handle in to_plan {
            let mut planner = Planner {
                config: &self.config,
                registry: &self.registry,
                flags: &self.flags,
                user_hooks: &self.user_hooks,
                prev_holds: &self.memory.holds,
                grounds: &grounds,
                writes: &self.writes,
                reports: &mut reports,
                neighbours: &mut self.neighbours,
                ground_side: &mut ground_side,
            };
            let found = planner.plan_body(handle, bodies, colliders, sets, last, step);
            if !reports.is_empty() {
                let mut commit = Commit::new(
                    &mut self.writes,
                    &mut self.reports,
                    &mut self.memory.shadows,
                    exact,
                );
                commit.events(reports.events.drain(..));
                for diagnostic in reports.diagnostics.drain(..) {
                    commit.diagnose(diagnostic);
                }
                if let Some((state, local_com)) = reports.touched.take() {
                    commit.state(handle, &state, &local_com, Origin::Correction);
                }
            }
            match found {
                Some(true) => {
                    near.push(handle);
                    self.memory.near.mark(handle);
                }
                Some(false) => {
                    let sets = (bodies, colliders);
                    self.take_untested_flight(untested, (step, &grounds), handle, sets);
                    not_near.push(handle);
                }
                None => {}
            }
        }
        step.grounds = grounds;
        (near, not_near)
    }

    /// The commit stage, closing each half of the step's work on bodies: the writes recorded
    /// in the half applied to rapier's bodies (`commit.rs`); after rapier's step, the
    /// colliders moved with their bodies (before it, rapier's step moves them), as the plan
    /// of the next step reads them.
    fn commit(&mut self, bodies: &mut RigidBodySet, colliders: Option<&mut ColliderSet>) {
        let (applied, moves) = commit::apply(&mut self.writes, bodies);
        if let Some(colliders) = colliders {
            bodies.propagate_modified_body_positions_to_colliders(colliders);
        }
        self.stopwatch
            .count(|c| (c.writes, c.moves) = (c.writes + applied, c.moves + moves));
        self.stopwatch.lap(Stage::Commit);
    }
}

/// The step's pairs by role, and the hooked bodies, into the profile's counts.
fn count_roles(counts: &mut StepCounts, step: &StepData, hooked: usize) {
    for role in step.roles.values() {
        match role {
            Role::Impact => counts.impact_pairs += 1,
            Role::Resting => counts.resting_pairs += 1,
            Role::Rolling => counts.rolling_pairs += 1,
            Role::Rapier | Role::Filtered => counts.rapier_pairs += 1,
        }
    }
    counts.body_pairs = step.pairs.pairs.len();
    counts.hooked_bodies = hooked;
}
