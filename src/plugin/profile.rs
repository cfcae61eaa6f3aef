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
    /// The pairs of opted-in bodies that may meet, and their roles.
    PairPlan,
    /// Which managed bodies are asleep, far from every ground, or to be planned.
    Survey,
    /// The planned bodies' pairs with the grounds near them, and their candidates.
    Plan,
    /// The hook flags and the tables rapier's hook calls read.
    Install,
    /// rapier's own step, with the plugin's hooks (timed only when
    /// [`ImpactPlugin::step`](crate::ImpactPlugin::step) drives it).
    Rapier,
    /// The bodies asleep at the start that rapier woke, checked.
    Woken,
    /// The clusters of impacts between bodies, moved together.
    PairClusters,
    /// Every other candidate, reconstructed and checked at the step's end.
    Bodies,
    /// The pairs between bodies not moved together, checked at the step's end.
    PairEnds,
    /// The balls held at rest on a slope, put back; the colliders moved to their bodies.
    Holds,
}

impl Stage {
    /// Every stage, in the order they run.
    pub const ALL: [Stage; 11] = [
        Stage::Prepare,
        Stage::PairPlan,
        Stage::Survey,
        Stage::Plan,
        Stage::Install,
        Stage::Rapier,
        Stage::Woken,
        Stage::PairClusters,
        Stage::Bodies,
        Stage::PairEnds,
        Stage::Holds,
    ];

    /// The stage's name, as `docs/architecture.md` writes it.
    pub fn name(self) -> &'static str {
        match self {
            Stage::Prepare => "prepare",
            Stage::PairPlan => "pair plan",
            Stage::Survey => "survey",
            Stage::Plan => "plan",
            Stage::Install => "install",
            Stage::Rapier => "rapier",
            Stage::Woken => "woken",
            Stage::PairClusters => "pair clusters",
            Stage::Bodies => "bodies",
            Stage::PairEnds => "pair ends",
            Stage::Holds => "holds",
        }
    }

    fn index(self) -> usize {
        Stage::ALL
            .iter()
            .position(|s| *s == self)
            .expect("every stage is in Stage::ALL")
    }
}

/// How many managed bodies each stage took in one step, and what the step wrote.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[non_exhaustive]
pub struct BodyCounts {
    /// Asleep at the step's start: nothing read but their sleep state.
    pub asleep: usize,
    /// Surely far from every ground (the survey's bound): not planned.
    pub far: usize,
    /// Planned (near a ground by the survey's bound, or a member of a pair between bodies).
    pub planned: usize,
    /// Planned and with a ground within its swept bounding sphere.
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
    /// Bodies with the plugin's hook flags on their colliders at rapier's step.
    pub hooked_bodies: usize,
    /// Writes into rapier's bodies (a state, a flight's end, a wake-up): each costs rapier
    /// an update of the body in its next step.
    pub writes: usize,
    /// Events reported.
    pub events: usize,
}

/// One step's profile: the time of each stage and the counts.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct StepProfile {
    times: [Duration; Stage::ALL.len()],
    /// The bodies and pairs each stage took.
    pub counts: BodyCounts,
    /// The time spent inside the one writer (part of the stages' times): the setters only;
    /// what a write costs rapier shows in its next step.
    pub commit: Duration,
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
        self.commit += other.commit;
        let (c, o) = (&mut self.counts, &other.counts);
        c.asleep += o.asleep;
        c.far += o.far;
        c.planned += o.planned;
        c.near += o.near;
        c.candidates += o.candidates;
        c.impact_pairs += o.impact_pairs;
        c.resting_pairs += o.resting_pairs;
        c.rolling_pairs += o.rolling_pairs;
        c.rapier_pairs += o.rapier_pairs;
        c.body_pairs += o.body_pairs;
        c.hooked_bodies += o.hooked_bodies;
        c.writes += o.writes;
        c.events += o.events;
    }
}

/// The step's stopwatch: `None` while profiling is off (no clock read).
#[derive(Default)]
pub(crate) struct Stopwatch {
    profile: Option<StepProfile>,
    lap: Option<Instant>,
}

impl Stopwatch {
    pub fn set_on(&mut self, on: bool) {
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
    pub fn count(&mut self, f: impl FnOnce(&mut BodyCounts)) {
        if let Some(p) = self.profile.as_mut() {
            f(&mut p.counts);
        }
    }

    /// The writer's log for this step, when profiling.
    pub fn commit_log(&mut self) -> Option<&mut StepProfile> {
        self.profile.as_mut()
    }
}
