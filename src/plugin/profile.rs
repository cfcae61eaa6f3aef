//! Where a step's time goes: the time of each stage of the step (`docs/architecture.md`), the
//! bodies each stage took, and the writes into rapier. Off by default
//! ([`ImpactPlugin::set_profiling`](crate::ImpactPlugin::set_profiling)): reading the clock
//! costs about as much as a far body's whole survey.

use std::time::{Duration, Instant};

/// A stage of the step, in the order the stages run (see `docs/architecture.md`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[non_exhaustive]
pub enum Stage {
    /// The step's thresholds and the grounds' poses over the step.
    Prepare,
    /// The pairs of opted-in bodies that may meet, and their roles (with last step's memory
    /// handed to the plan).
    PairPlan,
    /// Which managed bodies are asleep, far from every ground, or to be planned.
    Survey,
    /// The planned bodies' pairs with the grounds near them, and their candidates.
    Plan,
    /// `Exact` mode's free flights far from the grounds given the velocity under which
    /// rapier's integrator lands on the exact positions.
    Steer,
    /// The writes the stages recorded, applied to rapier's bodies. It closes each half of the
    /// step's work on bodies, so it runs twice (after the plan, and after the holds); its time
    /// is both runs'.
    Commit,
    /// The hook flags and the tables rapier's hook calls read (with the plan's memory put
    /// back).
    Install,
    /// rapier's own step, with the plugin's hooks (timed only when
    /// [`ImpactPlugin::step`](crate::ImpactPlugin::step) drives it).
    Rapier,
    /// The bodies asleep at the start that rapier woke, checked (with this step's roles kept
    /// for the next and the moving grounds' motion measured, which come first).
    Woken,
    /// The clusters of impacts between bodies, moved together.
    PairClusters,
    /// Every other candidate, reconstructed and checked at the step's end.
    Bodies,
    /// The pairs between bodies not moved together, checked at the step's end.
    PairEnds,
    /// The balls held at rest on a slope, put back.
    Holds,
}

impl Stage {
    /// Every stage, in the order they run.
    pub const ALL: &'static [Stage] = &[
        Stage::Prepare,
        Stage::PairPlan,
        Stage::Survey,
        Stage::Plan,
        Stage::Steer,
        Stage::Commit,
        Stage::Install,
        Stage::Rapier,
        Stage::Woken,
        Stage::PairClusters,
        Stage::Bodies,
        Stage::PairEnds,
        Stage::Holds,
    ];

    /// How many stages there are.
    const COUNT: usize = Stage::Holds as usize + 1;

    /// The stage's name, as `docs/architecture.md` writes it.
    pub fn name(self) -> &'static str {
        match self {
            Stage::Prepare => "prepare",
            Stage::PairPlan => "pair plan",
            Stage::Survey => "survey",
            Stage::Plan => "plan",
            Stage::Steer => "steer",
            Stage::Commit => "commit",
            Stage::Install => "install",
            Stage::Rapier => "rapier",
            Stage::Woken => "woken",
            Stage::PairClusters => "pair clusters",
            Stage::Bodies => "bodies",
            Stage::PairEnds => "pair ends",
            Stage::Holds => "holds",
        }
    }

    /// The stage's place in [`Stage::ALL`] (the variants are declared in that order).
    fn index(self) -> usize {
        self as usize
    }
}

/// What one step did, counted: the managed bodies the stages before rapier's step sorted, the
/// pairs by role, the hooked bodies, the writes into rapier and the events.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[non_exhaustive]
pub struct StepCounts {
    /// Asleep at the step's start: nothing read but their sleep state.
    pub asleep: usize,
    /// Surely far from every ground (the survey's bound): not planned.
    pub far: usize,
    /// Planned: near a ground by the survey's bound, a member of a pair between bodies, or
    /// (outside slabs) found near a ground by the last step's plan, which the survey does not
    /// test (such a body may be far now: planned, not `near`).
    pub planned: usize,
    /// Planned and with a ground near it (within its swept bounding sphere; a lone ground
    /// within the sphere's bounding cube counts).
    pub near: usize,
    /// With a candidate for the stages after rapier's step.
    pub candidates: usize,
    /// The pairs with grounds given each role this step: `Impact`, `Resting`, `Rolling`,
    /// and those left to rapier (`Filtered`, or a shape parry cannot query).
    pub impact_pairs: usize,
    /// See [`Self::impact_pairs`].
    pub resting_pairs: usize,
    /// See [`Self::impact_pairs`].
    pub rolling_pairs: usize,
    /// See [`Self::impact_pairs`].
    pub rapier_pairs: usize,
    /// Pairs between opted-in bodies with a role this step.
    pub body_pairs: usize,
    /// Runs of the clusters of impacts between bodies, each moving its cluster from the
    /// step's start: one a cluster, and one more each time a body it reached on the way could
    /// not join the run where it was met (it had an event of its own before): the cluster is
    /// moved again with it.
    pub cluster_runs: usize,
    /// Bodies with the plugin's hook flags on their colliders at rapier's step. While every
    /// dynamic body is managed the flags are on the grounds instead (`docs/guide.md`,
    /// "Filtering and hooks"), and this counts only the balls flagged for pairs between
    /// bodies.
    pub hooked_bodies: usize,
    /// Writes into rapier's bodies (a state, a flight's end, a velocity, a wake-up): each
    /// costs rapier an update of the body in its next step.
    pub writes: usize,
    /// Of the writes, those that move a body (a pose or a translation): rapier then also
    /// updates its colliders, wakes the bodies they have contact pairs with, and updates its
    /// broad phase, several times what a velocity costs it.
    pub moves: usize,
    /// Events reported.
    pub events: usize,
}

impl std::ops::AddAssign for StepCounts {
    fn add_assign(&mut self, o: StepCounts) {
        // Destructured whole, so that a new count cannot be left out.
        let StepCounts {
            asleep,
            far,
            planned,
            near,
            candidates,
            impact_pairs,
            resting_pairs,
            rolling_pairs,
            rapier_pairs,
            body_pairs,
            cluster_runs,
            hooked_bodies,
            writes,
            moves,
            events,
        } = o;
        for (total, add) in [
            (&mut self.asleep, asleep),
            (&mut self.far, far),
            (&mut self.planned, planned),
            (&mut self.near, near),
            (&mut self.candidates, candidates),
            (&mut self.impact_pairs, impact_pairs),
            (&mut self.resting_pairs, resting_pairs),
            (&mut self.rolling_pairs, rolling_pairs),
            (&mut self.rapier_pairs, rapier_pairs),
            (&mut self.body_pairs, body_pairs),
            (&mut self.cluster_runs, cluster_runs),
            (&mut self.hooked_bodies, hooked_bodies),
            (&mut self.writes, writes),
            (&mut self.moves, moves),
            (&mut self.events, events),
        ] {
            *total += add;
        }
    }
}

/// One step's profile: the time of each stage and the counts.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct StepProfile {
    times: [Duration; Stage::COUNT],
    /// What the step did, counted.
    pub counts: StepCounts,
}

impl StepProfile {
    /// The time spent in `stage`.
    pub fn time(&self, stage: Stage) -> Duration {
        self.times[stage.index()]
    }

    /// The plugin's own time: every stage but rapier's step.
    pub fn plugin_time(&self) -> Duration {
        Stage::ALL
            .iter()
            .filter(|s| **s != Stage::Rapier)
            .map(|s| self.time(*s))
            .sum()
    }

    /// Adds `other`'s times and counts to this one (a run's totals).
    pub fn accumulate(&mut self, other: &StepProfile) {
        for (t, o) in self.times.iter_mut().zip(other.times) {
            *t += o;
        }
        self.counts += other.counts;
    }
}

/// The step's stopwatch: `None` while profiling is off (no clock read).
#[derive(Default)]
pub(crate) struct Stopwatch {
    profile: Option<StepProfile>,
    lap: Option<Instant>,
}

impl Stopwatch {
    /// Profiling on or off; turning it on when it is on keeps the last step's profile.
    pub fn set_on(&mut self, on: bool) {
        if on == self.profile.is_some() {
            return;
        }
        self.profile = on.then(StepProfile::default);
        self.lap = None;
    }

    pub fn profile(&self) -> Option<&StepProfile> {
        self.profile.as_ref()
    }

    /// A new step: times and counts back to zero, the clock started.
    pub fn start_step(&mut self) {
        if let Some(p) = self.profile.as_mut() {
            *p = StepProfile::default();
            self.lap = Some(Instant::now());
        }
    }

    /// The time since the last lap goes to `stage`.
    pub fn lap(&mut self, stage: Stage) {
        if let (Some(p), Some(lap)) = (self.profile.as_mut(), self.lap.as_mut()) {
            let now = Instant::now();
            p.times[stage.index()] += now - *lap;
            *lap = now;
        }
    }

    /// The clock restarted without charging any stage (time outside the step's stages).
    pub fn restart(&mut self) {
        if self.profile.is_some() {
            self.lap = Some(Instant::now());
        }
    }

    /// Records counts, when profiling.
    pub fn count(&mut self, f: impl FnOnce(&mut StepCounts)) {
        if let Some(p) = self.profile.as_mut() {
            f(&mut p.counts);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_stage_is_listed_once_in_its_place() {
        assert_eq!(Stage::ALL.len(), Stage::COUNT);
        for (i, stage) in Stage::ALL.iter().enumerate() {
            assert_eq!(stage.index(), i, "{stage:?}");
        }
        let mut names: Vec<&str> = Stage::ALL.iter().map(|s| s.name()).collect();
        names.sort_unstable();
        names.dedup();
        assert_eq!(names.len(), Stage::COUNT);
    }

    #[test]
    fn accumulating_adds_every_count_and_time() {
        let mut step = StepProfile::default();
        step.times[Stage::Plan.index()] = Duration::from_micros(3);
        step.times[Stage::Commit.index()] = Duration::from_micros(1);
        step.counts.far = 2;
        step.counts.events = 5;
        let mut run = StepProfile::default();
        run.accumulate(&step);
        run.accumulate(&step);
        assert_eq!(run.time(Stage::Plan), Duration::from_micros(6));
        assert_eq!(run.time(Stage::Commit), Duration::from_micros(2));
        assert_eq!(run.plugin_time(), Duration::from_micros(8));
        assert_eq!((run.counts.far, run.counts.events), (4, 10));
    }
}
