//! Steer: in `Exact` mode, before rapier's step, the free flights that rapier's own integrator
//! can carry onto the exact positions, so that a body flying far from every ground has its
//! velocity set, and not its pose.
//!
//! Contract: rapier's substepped integrator moves a body of velocity `v0` under a constant
//! acceleration `a` by `v0 dt + (N + 1) / 2N a dt^2` in `N` substeps (velocity first, then
//! position, in each), where the exact flight moves it `v0 dt + a dt^2 / 2`. Started from
//! `v0 - a dt / 2N` instead, it lands on the exact position. This stage records that velocity
//! (`Candidate::steer`) for every flying candidate that rapier integrates so: a dynamic body
//! with no ground within reach, no linear damping, no locked axis and no joint, not a ball of
//! an impact between bodies, whose last step's end was the plugin's (its `f64` shadow still
//! held: a body whose end rapier's contacts decided, a ball resting on others, is left
//! alone). After rapier's step the bodies stage gives the body its own velocity back, and
//! writes its exact translation only where rapier's drifted beyond a few roundings
//! (`bodies.rs`, `fly_exactly`; `policy::carries`); a steered body that something else
//! touched in the step gets the offset back on rapier's end velocity. Between steps rapier
//! holds the body's own velocity, always.

use crate::plugin::config::TimingMode;
use crate::plugin::impact_plugin::ImpactPlugin;
use crate::plugin::queries::observe::Sets;
use crate::plugin::stages::commit::Commit;
use crate::plugin::state::memory::LastStep;
use crate::plugin::state::step::{Candidate, StepData};
use crate::rapier::prelude::{LockedAxes, RigidBody, RigidBodySet};

impl<H> ImpactPlugin<H> {
    /// The steer stage (see the module's contract): records the steering velocities of this
    /// step's free flights.
    pub(super) fn steer(
        &mut self,
        step: &mut StepData,
        bodies: &RigidBodySet,
        sets: &Sets,
        last: &LastStep,
    ) {
        if self.config.timing != TimingMode::Exact {
            return;
        }
        let mut commit = Commit::new(
            &mut self.writes,
            &mut self.reports,
            &mut self.memory.shadows,
            true,
        );
        let lag = step.dt / (2.0 * step.substeps as f64);
        for cand in step.candidates.iter_mut() {
            if !flying(cand) || step.pairs.members.contains(&cand.body) {
                continue;
            }
            let Some(rb) = bodies
                .get(cand.body)
                .filter(|rb| integrated_alone(cand, rb, sets))
            else {
                continue;
            };
            let now = commit.now(cand.body, rb);
            if !last
                .shadows
                .get(&cand.body)
                .is_some_and(|sh| sh.held_by(&now))
            {
                continue;
            }
            cand.steer = Some(cand.flight.accel * lag);
            if let Some(held) = cand.steered_velocity().filter(|v| *v != now.linvel()) {
                commit.velocity(cand.body, held);
            }
        }
    }
}

/// A candidate that no ground can reach in the step.
fn flying(cand: &Candidate) -> bool {
    cand.near.is_empty() && cand.rolling.is_none() && !cand.touched
}

/// Does rapier integrate the body's step as the steering assumes: a dynamic body under a
/// constant acceleration alone (no linear damping, locked axis or joint)?
fn integrated_alone(cand: &Candidate, rb: &RigidBody, sets: &Sets) -> bool {
    rb.is_dynamic()
        && rb.is_enabled()
        && rb.linear_damping() == 0.0
        && rb.locked_axes() == LockedAxes::empty()
        && !sets.jointed(cand.body)
}
