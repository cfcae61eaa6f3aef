//! Prepare: the step's own data before anything is planned, the survey of the managed bodies,
//! and, after rapier's step, the grounds' actual motion over it.
//!
//! Contract: [`ImpactPlugin::prepare`] clears the last step's events and hook tables, brings
//! the registry up to date with rapier's sets, and returns the step's data: its thresholds
//! ([`Policy`], from the configuration, gravity and rapier's integration parameters) and every
//! ground's pose over the step (the ground index, lent to the step until its end).
//! [`ImpactPlugin::survey`] sorts the managed bodies: asleep (checked at the step's end if
//! rapier wakes them), surely far from every ground (no plan; only their flight in `Exact`
//! mode), or to be planned (outside `Exact` mode and slabs, a body the last step's plan found
//! near a ground, without the far test: most often it is near still, and the plan finds one
//! that is not near, as the test would have found it far).
//! [`ImpactPlugin::measure_ground_motion`] reads where the moving grounds went. Nothing here
//! writes into rapier.

use crate::plugin::bridge::convert::{pose_to_na, to_f64, to_real, vec_to_na};
use crate::plugin::config::{TimingMode, coefficients_in_range};
use crate::plugin::hooks::lookup::Lookup;
use crate::plugin::impact_plugin::ImpactPlugin;
use crate::plugin::policy::Policy;
use crate::plugin::queries::observe::{snapshot, surely_far};
use crate::plugin::stages::view::EndOfStep;
use crate::plugin::state::memory::LastStep;
use crate::plugin::state::step::{Candidate, StepData};
use crate::rapier::math::Vector;
use crate::rapier::prelude::{
    ColliderHandle, ColliderSet, IntegrationParameters, RigidBodyHandle, RigidBodySet,
};
use nalgebra::Vector3;

/// The managed bodies as the survey sorted them.
pub(super) struct Survey {
    /// Awake bodies that may reach a ground (or a pair of opted-in bodies), and those the last
    /// step's plan found near a ground, untested (`NearMarks`): planned.
    pub to_plan: Vec<RigidBodyHandle>,
    /// Awake bodies with no ground in reach: no roles (see `Lookup::roles`). The survey's;
    /// `ImpactPlugin::before_step` adds those the plan found not near.
    pub far: Vec<RigidBodyHandle>,
    /// A dynamic body the plugin does not manage: it decides where the hook flags go.
    pub unmanaged: bool,
}

impl<H> ImpactPlugin<H> {
    /// The step's data, `active` when the step has a positive `dt`.
    pub(super) fn prepare(
        &mut self,
        gravity: Vector,
        params: &IntegrationParameters,
        bodies: &RigidBodySet,
        colliders: &ColliderSet,
    ) -> StepData {
        self.reports.clear();
        // The hooks' tables are rebuilt at the end of the plan.
        self.lookup = Lookup::default();
        self.registry.sync(bodies, colliders);
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
                TimingMode::TimeOfImpact => {
                    dt * dt / (2.0 * params.num_solver_iterations.max(1) as f64)
                }
                TimingMode::Step | TimingMode::Exact => 0.0,
            },
            substeps: params.num_solver_iterations.max(1),
            down: g.try_normalize(0.0).unwrap_or_else(Vector3::zeros),
            gravity: g,
            ..Default::default()
        };
        if !step.active {
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
    /// their distance to the grounds, and outside `Exact` mode and slabs so is a body the last
    /// step's plan found near a ground, untested: if it is far after all, its plan finds it not
    /// near and it joins the far bodies, or it has no collider to query and is skipped, as
    /// after the test. `gravity` and `dt` are rapier's, in its precision, as the bound on a
    /// body's travel is taken in it.
    pub(super) fn survey(
        &self,
        step: &mut StepData,
        (gravity, dt): (Vector, crate::rapier::math::Real),
        bodies: &RigidBodySet,
        colliders: &ColliderSet,
        last: &LastStep,
    ) -> Survey {
        let margin = to_real(step.policy.contact_margin());
        let g_len = gravity.length();
        let plan_near_again =
            self.config.timing != TimingMode::Exact && !self.registry.index.has_slabs();
        let mut survey = Survey {
            to_plan: Vec::new(),
            far: Vec::new(),
            unmanaged: false,
        };
        for (handle, rb) in bodies.iter() {
            if !self.registry.manages(handle, rb) {
                survey.unmanaged |= rb.is_dynamic() && rb.is_enabled();
                continue;
            }
            // Asleep unless the pair plan woke it (written at this half's commit).
            if self.writes.is_sleeping(handle, rb) {
                step.asleep.push(handle);
                continue;
            }
            if step.pairs.members.contains(handle) {
                survey.to_plan.push(handle);
                continue;
            }
            let index = &self.registry.index;
            // Near a ground last step: planned without the test (`NearMarks`). Not in `Exact`
            // mode, whose far bodies get their candidates here, in the survey's order; nor
            // where slabs are, as a body that meets tiles one by one lists its colliders for
            // the hooks once planned.
            if plan_near_again && self.memory.near.was_near(handle) {
                survey.to_plan.push(handle);
                continue;
            }
            match surely_far(rb, colliders, g_len, dt, margin, index, &step.grounds) {
                Some(true) => {
                    survey.far.push(handle);
                    let takes_pairs = self.registry.takes_pairs(handle, rb);
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
        survey
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
