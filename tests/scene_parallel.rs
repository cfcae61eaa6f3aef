//! Rapier's `parallel` feature (issue 5): the plugin is the `&dyn PhysicsHooks` that rapier's
//! worker threads call, so it must be `Sync` (checked in every build); with the crate's
//! `parallel` feature (rapier on rayon), a scene of many bodies in several islands, stepped in
//! a rayon pool of 1, 2 and 4 threads, gives bitwise the same trace (poses, velocities, sleep
//! states, impact events at every step), with the per-step checks.
//!
//! Balls only, in `TimeOfImpact` and `Exact` modes; boxes tumbling off balls, in every mode,
//! are `scene_resting.rs`'s.
//!
//! Run: `cargo test --release --features parallel --test scene_parallel` (and with
//! `--features f64,parallel`).

#![allow(clippy::useless_conversion, clippy::unnecessary_cast)]

mod scene_support;

use rapier_impact::rapier::prelude::*;
use rapier_impact::{ImpactPlugin, TimingMode};
use scene_support::*;

#[test]
fn the_plugin_is_a_sync_send_hook() {
    fn sync_send<T: Sync + Send>() {}
    sync_send::<ImpactPlugin>();
    sync_send::<ImpactPlugin<()>>();
    // It is what rapier's step takes.
    let p = plugin(TimingMode::Exact);
    let _hooks: &(dyn PhysicsHooks + Sync) = &p;
}

/// Steps a scene of balls in separate piles (separate islands) and returns its
/// per-step trace.
fn trace(timing: TimingMode, steps: usize) -> (Vec<u64>, Stats) {
    let label = format!("parallel {timing:?}");
    let mut world = PhysicsWorld::default();
    let (_, ground) = world.insert(
        RigidBodyBuilder::fixed(),
        ColliderBuilder::halfspace(up())
            .restitution(0.6)
            .friction(0.5),
    );
    for i in 0..8 {
        for j in 0..8 {
            let (x, z) = (real(3.0 * i as f64), real(3.0 * j as f64));
            let k = (i * 8 + j) as f64;
            let collider = ColliderBuilder::ball(real(0.15 + 0.01 * ((i + j) % 5) as f64));
            // Two bodies per pile: one lands on the other (rapier's contact) and the ground.
            for level in 0..2 {
                world.insert(
                    RigidBodyBuilder::dynamic()
                        .translation(Vector::new(x, real(0.5 + 0.6 * level as f64 + 0.01 * k), z))
                        .linvel(Vector::new(real(0.1 * (k % 3.0)), 0.0, 0.0))
                        .angvel(Vector::new(real(0.5 * (k % 5.0)), 0.0, 1.0)),
                    collider.clone().restitution(0.6).friction(0.5),
                );
            }
        }
    }
    let mut p = plugin_on(&world, ground, timing);
    let mut stats = Stats::new();
    let mut out = Vec::with_capacity(steps);
    for _ in 0..steps {
        step_checked(&mut world, &mut p, 0.0, &mut stats, &label);
        out.push(state_hash(&world) ^ events_hash(p.events()).rotate_left(1));
    }
    (out, stats)
}

#[test]
fn the_piles_pass_the_checks_in_the_default_build() {
    for timing in [TimingMode::TimeOfImpact, TimingMode::Exact] {
        let (_, stats) = trace(timing, 600);
        println!("{timing:?}: {}", stats.summary());
    }
}

#[cfg(feature = "parallel")]
#[test]
fn rapier_on_several_threads_gives_the_single_threaded_trace() {
    use rapier_impact::rapier::rayon::ThreadPoolBuilder;
    for timing in [TimingMode::TimeOfImpact, TimingMode::Exact] {
        let run = |threads: usize| {
            ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap()
                .install(|| trace(timing, 600))
        };
        let (single, stats) = run(1);
        for threads in [2, 4] {
            let (multi, _) = run(threads);
            let first = single.iter().zip(&multi).position(|(a, b)| a != b);
            println!(
                "{timing:?}: {threads} threads vs 1: first difference at step {first:?}; {}",
                stats.summary()
            );
            assert_eq!(first, None, "{timing:?}: {threads} threads differ");
        }
        assert!(stats.bounces > 64, "{timing:?}: {}", stats.summary());
    }
}
