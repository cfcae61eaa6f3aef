//! Prepare: the step's own data before anything is planned, the survey of the managed bodies,
//! and, after rapier's step, the grounds' actual motion over it.
//!
//! Contract: [`ImpactPlugin::prepare`] clears the last step's events and hook tables, brings
//! the registry up to date with rapier's sets, and returns the step's data: its thresholds
//! ([`Policy`], from the configuration, gravity and rapier's integration parameters) and every
//! ground's pose over the step (the ground index, lent to the step until its end).
//! [`ImpactPlugin::survey`] sorts the managed bodies: asleep (checked at the step's end if
//! rapier wakes them; woken and planned if a fast moving ground reaches them), surely far
//! from every ground (no plan; only their flight in `Exact` mode), or to be planned (outside slabs, a body the last step's plan found near a ground,
//! without the far test: most often it is near still, and the plan finds one that is not
//! near, as the test would have found it far). In `Exact` mode, where the candidates' order is
//! the order of the writes their flights make, such a body found far gets its flying
//! candidate where the survey's test would have put it ([`UntestedFlights`]).
//! [`ImpactPlugin::measure_ground_motion`] reads where the moving grounds went. Nothing here
//! writes into rapier.

use crate::plugin::bridge::convert::{pose_to_na, to_f64, to_real, vec_from_na, vec_to_na};
use crate::plugin::config::{TimingMode, coefficients_in_range};
use crate::plugin::hooks::lookup::Lookup;
use crate::plugin::impact_plugin::ImpactPlugin;
use crate::plugin::policy::Policy;
use crate::plugin::queries::filter;
use crate::plugin::queries::geometry::{BodyPart, contact_checked};
use crate::plugin::queries::ground_index::{GroundIndex, GroundMotion};
use crate::plugin::queries::observe::{Sets, body_geom, ground_geom, snapshot, surely_far};
use crate::plugin::stages::view::EndOfStep;
use crate::plugin::state::handles::Slotted;
use crate::plugin::state::memory::LastStep;
use crate::plugin::state::step::{Candidate, StepData};
use crate::rapier::math::{Real, Vector};
use crate::rapier::prelude::{
    ColliderHandle, ColliderSet, IntegrationParameters, MultibodyJointSet, PhysicsHooks, RigidBody,
    RigidBodyHandle, RigidBodySet,
};
use nalgebra::Vector3;

/// The flying candidates of the bodies the survey planned untested (`NearMarks`) that its far
/// test finds surely far: in `Exact` mode, where the candidates' order is that of the writes
/// their flights make, each goes where the survey would have pushed it.
pub(super) struct UntestedFlights {
    /// `Exact` mode, and the survey planned near-marked bodies untested (no slabs).
    taken_back: bool,
    /// How many flying candidates the survey pushed: the first of `StepData::candidates`, in
    /// rapier's order of the bodies.
    flights: usize,
    /// The survey's far test, to run for a body it did not test.
    far_test: FarTest,
    /// The candidates taken back from the plan's, in the plan's order (rapier's too).
    surveyed_far: Vec<Candidate>,
}

/// The survey's test that a body is surely far from every ground ([`surely_far`]), with the
/// step's terms in rapier's precision, as the bound on a body's travel is taken in it.
#[derive(Clone, Copy)]
struct FarTest {
    /// The length of rapier's gravity.
    g_len: Real,
    dt: Real,
    /// The policy's contact margin.
    margin: Real,
}

impl FarTest {
    /// `surely_far` of the body `rb` against the grounds `grounds` of the registry's index.
    fn of(
        &self,
        rb: &RigidBody,
        colliders: &ColliderSet,
        index: &GroundIndex,
        grounds: &[GroundMotion],
    ) -> Option<bool> {
        surely_far(
            rb,
            colliders,
            self.g_len,
            self.dt,
            self.margin,
            index,
            grounds,
        )
    }
}

/// The managed bodies as the survey sorted them.
pub(super) struct Survey {
    /// Awake bodies that may reach a ground (or a pair of opted-in bodies), and those the last
    /// step's plan found near a ground, untested (`NearMarks`): planned.
    pub to_plan: Vec<RigidBodyHandle>,
    /// Awake bodies with no ground in reach: no roles (see `Lookup::roles`). The survey's;
    /// `ImpactPlugin::before_step` adds those the plan found not near.
    pub far: Vec<RigidBodyHandle>,
    /// `Exact` mode's flights of the bodies planned untested, to be put in the survey's order.
    pub untested: UntestedFlights,
    /// A dynamic body the plugin does not manage: it decides where the hook flags go.
    pub unmanaged: bool,
    /// Asleep bodies a moving ground reaches in the step ([`ImpactPlugin::moving_ground_reaches`]):
    /// to be woken (recorded by the caller) and planned.
    pub woken: Vec<RigidBodyHandle>,
}

impl<H: PhysicsHooks> ImpactPlugin<H> {
    /// The step's data, `active` when the step has a positive `dt`.
    pub(super) fn prepare(
        &mut self,
        gravity: Vector,
        params: &IntegrationParameters,
        (bodies, colliders): (&RigidBodySet, &ColliderSet),
        multibody_joints: &MultibodyJointSet,
    ) -> StepData {
        self.reports.clear();
        // The hooks' tables are rebuilt at the end of the plan.
        self.lookup = Lookup::default();
        self.registry.sync(bodies, colliders);
        self.registry.sync_links(multibody_joints);
        let dt = to_f64(params.dt);
        let g = vec_to_na(gravity);
        let mut step = StepData {
            active: dt > 0.0,
            dt,
            policy: Policy::new(
                &self.config,
                g.norm(),
                dt,
                to_f64(params.allowed_linear_error()),
                to_f64(params.prediction_distance()),
            ),
            integrator_lag: match self.config.timing {
                TimingMode::TimeOfImpact | TimingMode::Step => {
                    dt * dt / (2.0 * params.num_solver_iterations.max(1) as f64)
                }
                TimingMode::Exact => 0.0,
            },
            steering_lag: dt / (2.0 * params.num_solver_iterations.max(1) as f64),
            substeps: params.num_solver_iterations.max(1),
            down: g.try_normalize(0.0).unwrap_or_else(Vector3::zeros),
            gravity: g,
            ..Default::default()
        };
        if !step.active {
            // rapier's step applies the relative poses written since, without the index's
            // pass.
            self.registry.index.note_relative_poses(colliders);
            return step;
        }
        // A tile whose contacts its slab's stand-in would not carry stays a ground of its own:
        // hook flags of the user's (the user's filter or contact modification is asked about
        // each tile), coefficients the plan refuses (diagnosed per collider); and a
        // restitution curve of its own (the registry's).
        let flags = &self.flags;
        let lone = |c: ColliderHandle| {
            !flags.recorded_user_flags(colliders, c).is_empty()
                || colliders.get(c).is_some_and(|co| {
                    !coefficients_in_range(to_f64(co.restitution()), to_f64(co.friction()))
                })
        };
        self.registry
            .refresh_index(bodies, colliders, (dt, step.policy.resting_gap), &lone);
        // Lent to the step; given back at its end (`Self::after_step`).
        step.grounds = std::mem::take(&mut self.registry.index.motions);
        step
    }

    /// Sorts the managed bodies (see [`Survey`]). A body surely far from every ground needs
    /// no snapshot, inertia or geometry: it gets a flying candidate where
    /// [`Candidate::wanted_in_flight`] asks for one (in `Exact` mode, always); a body
    /// without collider is skipped. The members of the step's pairs are planned whatever
    /// their distance to the grounds, and outside slabs so is a body the last step's plan
    /// found near a ground, untested: if it is far after all, its plan finds it not near and
    /// it joins the far bodies (in `Exact` mode its flight is then put in the survey's place,
    /// [`UntestedFlights`]), or it has no collider to query and is skipped, as
    /// after the test. `gravity` and `dt` are rapier's, in its precision, as the bound on a
    /// body's travel is taken in it.
    pub(super) fn survey(
        &self,
        step: &mut StepData,
        (gravity, dt): (Vector, Real),
        (bodies, colliders, sets): (&RigidBodySet, &ColliderSet, &Sets),
        last: &LastStep,
    ) -> Survey {
        let far_test = FarTest {
            g_len: gravity.length(),
            dt,
            margin: to_real(step.policy.contact_margin()),
        };
        let plan_near_again = !self.registry.index.has_slabs();
        let mut survey = Survey {
            to_plan: Vec::new(),
            far: Vec::new(),
            untested: UntestedFlights {
                taken_back: plan_near_again && self.config.timing == TimingMode::Exact,
                flights: 0,
                far_test,
                surveyed_far: Vec::new(),
            },
            unmanaged: false,
            woken: Vec::new(),
        };
        for (handle, rb) in bodies.iter() {
            if !self.registry.manages(handle, rb) {
                survey.unmanaged |= rb.is_dynamic() && rb.is_enabled();
                continue;
            }
            // Asleep unless the pair plan woke it (written at this half's commit), or a moving
            // ground reaches it.
            if self.writes.is_sleeping(handle, rb) {
                if self.moving_ground_reaches((handle, rb), (bodies, colliders, sets), step) {
                    survey.woken.push(handle);
                    survey.to_plan.push(handle);
                } else {
                    step.asleep.push(handle);
                }
                continue;
            }
            if step.pairs.members.contains(handle) {
                survey.to_plan.push(handle);
                continue;
            }
            let index = &self.registry.index;
            // Near a ground last step: planned without the test (`NearMarks`). Not where slabs
            // are, as a body that meets tiles one by one lists its colliders for the hooks
            // once planned.
            if plan_near_again && self.memory.near.was_near(handle) {
                survey.to_plan.push(handle);
                continue;
            }
            match far_test.of(rb, colliders, index, &step.grounds) {
                Some(true) => {
                    survey.far.push(handle);
                    let takes_pairs = || self.registry.takes_pairs(handle, rb);
                    if Candidate::wanted_in_flight(self.config.timing, false, takes_pairs) {
                        let shadow = last.shadows.get(&handle);
                        let (start, flight, local_com) =
                            snapshot(&self.writes.now(handle, rb), step.gravity, step.dt, shadow);
                        step.candidates
                            .push(Candidate::flying(handle, start, flight, local_com));
                    }
                }
                Some(false) => survey.to_plan.push(handle),
                None => {}
            }
        }
        survey.untested.flights = step.candidates.len();
        survey
    }

    /// Does a moving ground reach the asleep body `handle` (`rb`) in the step where rapier
    /// would not wake it first? rapier wakes a body a kinematic body touches only as their
    /// contact starts, within its prediction distance: a bat crossing a ball on a tee in one
    /// step passed through it. Such a ground moves farther near the body in the step than the
    /// contact margin (slower, rapier meets it in time), its box over the step meets the
    /// body, and at the step's start it lies within that travel of one of the body's
    /// colliders and closes on it there (its point's velocity along the contact normal), in
    /// a pair the plugin would resolve: not refused by rapier's filtering, a joint or the
    /// user's filter (`filter::ground_pair_refused`), nor out of the coefficients' ranges
    /// (`Registry::coefficients_refused`). A pile resting on a platform that slides, or
    /// beside one that passes or recedes, is left asleep, and so is a ball the bat's
    /// collision groups pass through. Reads only; a step with no ground that moves pays a look
    /// at the moving list.
    fn moving_ground_reaches(
        &self,
        (handle, rb): (RigidBodyHandle, &RigidBody),
        (bodies, colliders, sets): (&RigidBodySet, &ColliderSet, &Sets),
        step: &StepData,
    ) -> bool {
        let moves = |m: &&GroundMotion| m.v != Vector3::zeros() || m.w != Vector3::zeros();
        let mut moving = self
            .registry
            .index
            .moving()
            .iter()
            .map(|i| &step.grounds[*i])
            .filter(moves)
            .peekable();
        if moving.peek().is_none() {
            return false;
        }
        let state = self.writes.now(handle, rb).state();
        let geom = body_geom(rb, colliders, &vec_to_na(rb.local_center_of_mass()));
        let margin = step.policy.contact_margin();
        moving.any(|motion| {
            let Some(gg) = ground_geom(motion, colliders) else {
                return false;
            };
            let travel = gg.travel_near(&state.com, geom.radius + margin, step.dt);
            let half = to_real(geom.radius + travel + margin);
            let closing = |part: &BodyPart| {
                let refused = || {
                    let hooks = (&self.user_hooks, &self.flags);
                    let key = (part.handle, gg.handle);
                    filter::ground_pair_refused(hooks, (bodies, colliders, sets), handle, key)
                        || self.registry.coefficients_refused(colliders, key)
                };
                match contact_checked(part, &gg, &state, 0.0, travel + margin) {
                    Ok(Some((_, n, p))) => n.dot(&gg.velocity_at(&p, 0.0)) > 0.0 && !refused(),
                    _ => false,
                }
            };
            travel > margin
                && !motion.misses_cube(vec_from_na(&state.com), half)
                && geom.parts.iter().any(closing)
        })
    }

    /// `Exact` mode, right after the plan of `handle` found no ground near it: if the survey
    /// planned it untested (`NearMarks`) and its far test finds it surely far, as the
    /// survey's would have, its flying candidate (the plan's last) is taken back to go among
    /// the survey's ([`Self::place_untested_flights`]); one the test does not find surely far
    /// would have been planned, and its candidate stays where its plan put it. The test reads
    /// what the survey's would have: rapier's bodies and the grounds, neither written before
    /// the commit.
    pub(super) fn take_untested_flight(
        &self,
        untested: &mut UntestedFlights,
        (step, grounds): (&mut StepData, &[GroundMotion]),
        handle: RigidBodyHandle,
        (bodies, colliders): (&RigidBodySet, &ColliderSet),
    ) {
        if !untested.taken_back
            || step.pairs.members.contains(handle)
            || !self.memory.near.was_near(handle)
            || !step.candidates.last().is_some_and(|c| c.body == handle)
        {
            return;
        }
        let index = &self.registry.index;
        let far = bodies
            .get(handle)
            .is_some_and(|rb| untested.far_test.of(rb, colliders, index, grounds) == Some(true));
        if far {
            untested.surveyed_far.extend(step.candidates.pop());
        }
    }

    /// `Exact` mode: the flights [`Self::take_untested_flight`] took back put among the
    /// survey's, each before the first of a higher slot (the survey pushes in rapier's order,
    /// by slot), so that the candidates, and the writes their flights make, come in the order
    /// testing every body gives. The plan's candidates are moved once, as one block.
    pub(super) fn place_untested_flights(step: &mut StepData, untested: &mut UntestedFlights) {
        if untested.surveyed_far.is_empty() {
            return;
        }
        let flights = untested.flights;
        let late = std::mem::take(&mut untested.surveyed_far);
        let placed = flights + late.len();
        step.candidates.splice(flights..flights, late);
        // Two runs in slot order, merged (a body has one candidate: no two slots are equal).
        step.candidates[..placed].sort_by_key(|c| c.body.slot());
    }

    /// The moving grounds' actual velocities over the step, from their poses after it.
    pub(super) fn measure_ground_motion(&self, step: &mut EndOfStep, bodies: &RigidBodySet) {
        let dt = step.dt;
        for i in self.registry.index.moving() {
            let gm = &mut step.data.grounds[*i];
            let Some(rb) = gm.body.and_then(|bh| bodies.get(bh)) else {
                continue;
            };
            if rb.is_fixed() {
                continue;
            }
            let end = pose_to_na(rb.position());
            let com1 = end * nalgebra::Point3::from(vec_to_na(rb.local_center_of_mass()));
            let rot1 = end.rotation;
            gm.v = (com1.coords - gm.com0) / dt;
            gm.w = (rot1 * gm.rot0.inverse()).scaled_axis() / dt;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::{FarTest, ImpactPlugin, UntestedFlights};
    use crate::motion::{Flight, State};
    use crate::plugin::state::step::{Candidate, StepData};
    use crate::rapier::math::Vector;
    use crate::rapier::prelude::RigidBodyHandle;
    use nalgebra::{UnitQuaternion, Vector3};

    fn flying(slot: u32) -> Candidate {
        let start = State {
            com: Vector3::new(f64::from(slot), 1.0, 0.0),
            rot: UnitQuaternion::identity(),
            v: Vector3::zeros(),
            w: Vector3::zeros(),
        };
        let flight = Flight {
            accel: Vector3::new(0.0, -9.81, 0.0),
            linear_damping: 0.0,
            angular_damping: 0.0,
            gyro: None,
        };
        let body = RigidBodyHandle::from_raw_parts(slot, 0);
        Candidate::flying(body, start, flight, Vector3::zeros())
    }

    fn slots(step: &StepData) -> Vec<u32> {
        let slot = |c: &Candidate| c.body.into_raw_parts().0;
        step.candidates.iter().map(slot).collect()
    }

    /// The flights taken back from the plan go among the survey's in slot order (before,
    /// between and after them), and the plan's candidates keep theirs, after all of them.
    #[test]
    fn untested_flights_go_among_the_surveys_in_slot_order() {
        let mut step = StepData {
            candidates: [2, 5, 9, 1, 4, 8].map(flying).into(),
            ..Default::default()
        };
        let mut untested = UntestedFlights {
            taken_back: true,
            flights: 3,
            far_test: FarTest {
                g_len: 0.0,
                dt: 0.0,
                margin: 0.0,
            },
            surveyed_far: [0, 3, 6, 10].map(flying).into(),
        };
        ImpactPlugin::<()>::place_untested_flights(&mut step, &mut untested);
        assert_eq!(slots(&step), [0, 2, 3, 5, 6, 9, 10, 1, 4, 8]);
        assert!(untested.surveyed_far.is_empty());
        // Nothing taken back: nothing moves.
        ImpactPlugin::<()>::place_untested_flights(&mut step, &mut untested);
        assert_eq!(slots(&step), [0, 2, 3, 5, 6, 9, 10, 1, 4, 8]);
    }

    /// In `Exact` mode a ball the last step found near a ground, lifted far before the next,
    /// is planned untested, and its flight still takes the place the survey's far test gives
    /// it: first, before the balls still near, although its slot is the highest.
    #[test]
    fn a_lifted_ball_s_flight_takes_the_survey_s_place() {
        use crate::plugin::bridge::convert::to_real;
        use crate::plugin::impact_plugin::StepSets;
        use crate::rapier::prelude::{ColliderBuilder, PhysicsWorld, RigidBodyBuilder};
        use crate::{ImpactConfig, TimingMode};
        let mut world = PhysicsWorld::default();
        let (_, floor) = world.insert(
            RigidBodyBuilder::fixed(),
            ColliderBuilder::cuboid(20.0, 0.5, 20.0).translation(Vector::new(0.0, -0.5, 0.0)),
        );
        let config = ImpactConfig::default().with_timing(TimingMode::Exact);
        let mut plugin = ImpactPlugin::<()>::new(config).unwrap();
        plugin
            .add_ground(&world.bodies, &world.colliders, floor)
            .unwrap();
        let balls: Vec<RigidBodyHandle> = (0..5)
            .map(|i| {
                let ball = RigidBodyBuilder::dynamic()
                    .translation(Vector::new(to_real(-2.0 + f64::from(i)), 0.1, 0.0))
                    .linvel(Vector::new(1.0, 0.0, 0.0));
                world.insert(ball, ColliderBuilder::ball(0.1)).0
            })
            .collect();
        for _ in 0..10 {
            plugin.step(&mut world);
        }
        world.bodies[balls[4]].set_translation(Vector::new(2.0, 50.0, 0.0), true);
        let (gravity, params) = (world.gravity, world.integration_parameters);
        plugin.before_step(gravity, &params, StepSets::from(&mut world));
        let order: Vec<_> = plugin.step.candidates.iter().map(|c| c.body).collect();
        assert_eq!(order, [balls[4], balls[0], balls[1], balls[2], balls[3]]);
    }
}
