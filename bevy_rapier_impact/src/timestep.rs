//! How many rapier steps a frame runs, and of which length: bevy_rapier's
//! `RapierContextSimulation::step_simulation` schedule, computed ahead so that the plugin can
//! run each rapier step itself between `before_step` and `after_step`.
//!
//! Contract: for a [`TimestepMode`], the frame's `Time::delta_secs()` and the context's
//! `SimulationToRenderTime::diff`, [`FramePlan::new`] gives the same number of steps, the same
//! step length (the same `f32` operations, so bitwise the same) and the same update of `diff`
//! as bevy_rapier 0.37 would. It never loops without end: an `Interpolated` mode with a
//! non-positive or NaN `dt` runs no step and leaves `diff` alone (bevy_rapier would spin).

use bevy_rapier3d::plugin::TimestepMode;

/// The rapier steps of one frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct FramePlan {
    /// The `IntegrationParameters::dt` bevy_rapier leaves in the context after the frame
    /// (the frame's length, not the step's, in its substepping modes).
    pub frame_dt: f32,
    /// Length of each rapier step (s).
    pub step_dt: f32,
    /// Rapier steps per round (the mode's `substeps`, or 0 when `step_dt` is not positive).
    pub per_round: usize,
    /// Rounds: 1, or in `Interpolated` mode the number of `dt` the simulation catches up.
    pub rounds: usize,
    /// The round before which the interpolation start poses are taken (`Interpolated` mode:
    /// the last round).
    pub interpolation_round: Option<usize>,
}

impl FramePlan {
    /// The plan of one frame of `delta` seconds; `diff` is the context's simulation-to-render
    /// lag, updated as bevy_rapier updates it.
    pub fn new(mode: TimestepMode, delta: f32, diff: &mut f32) -> Self {
        // Written as bevy_rapier writes them, so that the step length is the same bits.
        let count = |step_dt: f32, substeps: usize| if step_dt > 0.0 { substeps } else { 0 };
        match mode {
            TimestepMode::Fixed { dt, substeps } => {
                let step_dt = dt / (substeps as f32);
                Self {
                    frame_dt: dt,
                    step_dt,
                    per_round: count(step_dt, substeps),
                    rounds: 1,
                    interpolation_round: None,
                }
            }
            TimestepMode::Variable {
                max_dt,
                time_scale,
                substeps,
            } => {
                let frame_dt = (delta * time_scale).min(max_dt);
                let step_dt = frame_dt / (substeps as f32);
                Self {
                    frame_dt,
                    step_dt,
                    per_round: count(step_dt, substeps),
                    rounds: 1,
                    interpolation_round: None,
                }
            }
            TimestepMode::Interpolated {
                dt,
                time_scale,
                substeps,
            } => {
                let step_dt = dt / (substeps as f32) * time_scale;
                let mut plan = Self {
                    frame_dt: dt,
                    step_dt,
                    per_round: count(step_dt, substeps),
                    rounds: 0,
                    interpolation_round: None,
                };
                if dt.is_nan() || dt <= 0.0 {
                    return plan;
                }
                *diff += delta;
                while *diff > 0.0 {
                    if *diff - dt <= 0.0 {
                        plan.interpolation_round = Some(plan.rounds);
                    }
                    plan.rounds += 1;
                    *diff -= dt;
                }
                plan
            }
        }
    }

    /// Rapier steps in the frame.
    pub fn steps(&self) -> usize {
        self.per_round * self.rounds
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fixed_mode_runs_its_substeps_of_dt_over_substeps() {
        let mut diff = 0.0;
        let plan = FramePlan::new(
            TimestepMode::Fixed {
                dt: 1.0 / 64.0,
                substeps: 4,
            },
            0.5,
            &mut diff,
        );
        assert_eq!(
            (plan.steps(), plan.step_dt, plan.frame_dt),
            (4, 1.0 / 256.0, 1.0 / 64.0)
        );
        assert_eq!(diff, 0.0);
    }

    #[test]
    fn variable_mode_clamps_the_frame_and_skips_a_zero_frame() {
        let mode = TimestepMode::Variable {
            max_dt: 1.0 / 60.0,
            time_scale: 1.0,
            substeps: 2,
        };
        let plan = FramePlan::new(mode, 0.1, &mut 0.0);
        assert_eq!((plan.steps(), plan.frame_dt), (2, 1.0 / 60.0));
        assert_eq!(plan.step_dt, (1.0f32 / 60.0) / 2.0);
        assert_eq!(FramePlan::new(mode, 0.0, &mut 0.0).steps(), 0);
    }

    #[test]
    fn interpolated_mode_catches_up_and_interpolates_before_the_last_round() {
        let mode = TimestepMode::Interpolated {
            dt: 1.0 / 256.0,
            time_scale: 1.0,
            substeps: 1,
        };
        let mut diff = 0.0;
        let plan = FramePlan::new(mode, 4.0 / 256.0, &mut diff);
        assert_eq!((plan.rounds, plan.interpolation_round), (4, Some(3)));
        assert_eq!(diff, 0.0);
        // Half a step: one step now, the simulation half a step ahead after it.
        let plan = FramePlan::new(mode, 0.5 / 256.0, &mut diff);
        assert_eq!((plan.rounds, diff), (1, -0.5 / 256.0));
        let plan = FramePlan::new(mode, 0.25 / 256.0, &mut diff);
        assert_eq!((plan.rounds, diff), (0, -0.25 / 256.0));
    }

    #[test]
    fn interpolated_mode_with_a_zero_dt_runs_nothing_instead_of_spinning() {
        let mode = TimestepMode::Interpolated {
            dt: 0.0,
            time_scale: 1.0,
            substeps: 1,
        };
        let mut diff = 0.0;
        assert_eq!(FramePlan::new(mode, 1.0 / 60.0, &mut diff).steps(), 0);
        assert_eq!(diff, 0.0);
    }
}
