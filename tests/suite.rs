//! The test suite in one binary: each file of tests/ is a module here, so that the crate,
//! rapier and the shared support are compiled and linked once for all of them instead of
//! once per file. `golden_traces` and `scene_parallel` stay binaries of their own (CI runs
//! the second alone with rapier's `parallel` feature). Run one file's tests with its module
//! name as the filter: `cargo test --release --test suite plugin_drop`.
// Each file declares the support module it uses, as it did as a binary of its own.
#![allow(clippy::duplicate_mod)]

#[path = "model_closed_forms.rs"]
mod model_closed_forms;
#[path = "model_errata.rs"]
mod model_errata;
#[path = "model_general.rs"]
mod model_general;
#[path = "model_hard_cases.rs"]
mod model_hard_cases;
#[path = "model_jam.rs"]
mod model_jam;
#[path = "model_pair.rs"]
mod model_pair;
#[path = "model_properties.rs"]
mod model_properties;
#[path = "model_seed_equations.rs"]
mod model_seed_equations;
#[path = "model_swerve_accuracy.rs"]
mod model_swerve_accuracy;
#[path = "model_tangential.rs"]
mod model_tangential;
#[path = "plugin_basics.rs"]
mod plugin_basics;
#[path = "plugin_bodies.rs"]
mod plugin_bodies;
#[path = "plugin_drop.rs"]
mod plugin_drop;
#[path = "plugin_events.rs"]
mod plugin_events;
#[path = "plugin_filtering.rs"]
mod plugin_filtering;
#[path = "plugin_grounds.rs"]
mod plugin_grounds;
#[path = "plugin_hook_flags.rs"]
mod plugin_hook_flags;
#[path = "plugin_pair_shapes.rs"]
mod plugin_pair_shapes;
#[path = "plugin_pairs.rs"]
mod plugin_pairs;
#[path = "plugin_profile.rs"]
mod plugin_profile;
#[path = "plugin_restitution.rs"]
mod plugin_restitution;
#[path = "plugin_rolling.rs"]
mod plugin_rolling;
#[path = "plugin_rolling_crowd.rs"]
mod plugin_rolling_crowd;
#[path = "plugin_spin.rs"]
mod plugin_spin;
#[path = "scene_adversarial.rs"]
mod scene_adversarial;
#[path = "scene_crowd.rs"]
mod scene_crowd;
#[path = "scene_extremes.rs"]
mod scene_extremes;
#[path = "scene_fast_bodies.rs"]
mod scene_fast_bodies;
#[path = "scene_lifecycle.rs"]
mod scene_lifecycle;
#[path = "scene_long_run.rs"]
mod scene_long_run;
#[path = "scene_resting.rs"]
mod scene_resting;
#[path = "scene_robustness.rs"]
mod scene_robustness;
#[path = "scene_thin_bodies.rs"]
mod scene_thin_bodies;
#[path = "serde_roundtrip.rs"]
mod serde_roundtrip;
#[path = "snapshot.rs"]
mod snapshot;
#[path = "stress.rs"]
mod stress;
