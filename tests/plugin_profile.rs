//! The step's profile (`ImpactPlugin::set_profiling`): off by default; when on, its counts
//! are what the step did (every managed body in one of the survey's groups, no write for a
//! body nothing happens to, and in `Exact` mode a flight far from the grounds moved only where
//! it starts) and the stages that ran took time; rapier's step is timed only when the plugin
//! drives it.

mod plugin_support;

use plugin_support::MODES;
use rapier_impact::rapier::prelude::*;
use rapier_impact::{ImpactConfig, ImpactPlugin, Stage, StepProfile, StepSets, TimingMode};
use std::time::Duration;

#[test]
fn the_profile_counts_what_the_step_did() {
    for timing in MODES {
        let mut world = PhysicsWorld::default();
        let (_, ground) = world.insert(
            RigidBodyBuilder::fixed(),
            ColliderBuilder::cuboid(10.0, 0.5, 10.0)
                .translation(Vector::new(0.0, -0.5, 0.0))
                .restitution(0.8),
        );
        // One ball that bounces, one that stays far above the ground all run.
        for y in [0.6, 40.0] {
            world.insert(
                RigidBodyBuilder::dynamic().translation(Vector::new(0.0, y, 0.0)),
                ColliderBuilder::ball(0.1).restitution(0.8),
            );
        }
        let config = ImpactConfig::default().with_timing(timing);
        let mut plugin = ImpactPlugin::new(config).unwrap();
        plugin
            .add_ground(&world.bodies, &world.colliders, ground)
            .unwrap();
        plugin.step(&mut world);
        assert!(plugin.profile().is_none(), "{timing:?}: off by default");
        plugin.set_profiling(true);
        let mut run = StepProfile::default();
        let (mut far_steps, mut far_moves) = (0, 0);
        for _ in 0..60 {
            plugin.step(&mut world);
            let p = plugin.profile().expect("profiling is on");
            let c = &p.counts;
            assert_eq!(c.asleep + c.far + c.planned, 2, "{timing:?}: {c:?}");
            assert!(
                c.near <= c.planned && c.candidates <= 2,
                "{timing:?}: {c:?}"
            );
            // Nothing happens to a body: no write. In `Exact` a flight far from the grounds is
            // steered onto the exact positions (`Stage::Steer`): its velocity is written, and
            // it is moved only where it starts or where rapier's integrator drifted a few
            // roundings from it.
            match timing {
                TimingMode::Exact if c.near == 0 => {
                    far_steps += 1;
                    far_moves += c.moves;
                }
                TimingMode::Exact => {}
                _ if c.events == 0 => assert_eq!(c.writes, 0, "{timing:?}: {c:?}"),
                _ => {}
            }
            run.accumulate(p);
        }
        assert!(
            far_moves * 5 <= far_steps,
            "{timing:?}: {far_moves} moves in {far_steps} steps with both balls far"
        );
        let c = &run.counts;
        assert!(c.events > 0 && c.impact_pairs > 0, "{timing:?}: {c:?}");
        // The high ball is far every step; the low one is near a ground at its impacts.
        assert!(c.far >= 60 && c.near >= c.impact_pairs, "{timing:?}: {c:?}");
        for stage in [Stage::Plan, Stage::Commit, Stage::Rapier, Stage::Bodies] {
            assert!(run.time(stage) > Duration::ZERO, "{timing:?} {stage:?}");
        }
        // Turned on again while on: the last step's profile stays.
        let last = plugin.profile().cloned();
        plugin.set_profiling(true);
        assert_eq!(plugin.profile().cloned(), last, "{timing:?}");
        plugin.set_profiling(false);
        plugin.step(&mut world);
        assert!(plugin.profile().is_none(), "{timing:?}: off again");
    }
}

#[test]
fn rapier_is_timed_only_when_the_plugin_steps_it() {
    let mut world = PhysicsWorld::default();
    let (_, ground) = world.insert(
        RigidBodyBuilder::fixed(),
        ColliderBuilder::cuboid(10.0, 0.5, 10.0).translation(Vector::new(0.0, -0.5, 0.0)),
    );
    world.insert(
        RigidBodyBuilder::dynamic().translation(Vector::new(0.0, 0.3, 0.0)),
        ColliderBuilder::ball(0.1),
    );
    let mut plugin = ImpactPlugin::new(ImpactConfig::default()).unwrap();
    plugin
        .add_ground(&world.bodies, &world.colliders, ground)
        .unwrap();
    plugin.set_profiling(true);
    for _ in 0..10 {
        let (gravity, params) = (world.gravity, world.integration_parameters);
        plugin.before_step(gravity, &params, StepSets::from(&mut world));
        world.step_with_events(&plugin, &());
        plugin.after_step(StepSets::from(&mut world));
        let p = plugin.profile().expect("profiling is on");
        assert_eq!(p.time(Stage::Rapier), Duration::ZERO);
        assert!(p.time(Stage::Plan) > Duration::ZERO);
    }
}
