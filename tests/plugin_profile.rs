//! The step's profile (`ImpactPlugin::set_profiling`): off by default; when on, its counts
//! are what the step did (every event and every write counted once, every managed body in
//! one of the survey's groups) and the stages that ran took time.

mod plugin_support;

use plugin_support::MODES;
use rapier_impact::rapier::prelude::*;
use rapier_impact::{ImpactConfig, ImpactPlugin, Stage, StepProfile};

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
        let config = ImpactConfig {
            timing,
            ..Default::default()
        };
        let mut plugin = ImpactPlugin::new(config).unwrap();
        plugin
            .add_ground(&world.bodies, &world.colliders, ground)
            .unwrap();
        plugin.step(&mut world);
        assert!(plugin.profile().is_none(), "{timing:?}: off by default");
        plugin.set_profiling(true);
        let mut run = StepProfile::default();
        let mut events = 0;
        for _ in 0..60 {
            plugin.step(&mut world);
            let p = plugin.profile().expect("profiling is on");
            let c = &p.counts;
            assert_eq!(c.events, plugin.events().len(), "{timing:?}");
            assert_eq!(c.asleep + c.far + c.planned, 2, "{timing:?}: {c:?}");
            assert!(
                c.near <= c.planned && c.candidates <= 2,
                "{timing:?}: {c:?}"
            );
            events += plugin.events().len();
            run.accumulate(p);
        }
        let c = &run.counts;
        assert!(events > 0 && c.events == events, "{timing:?}: {c:?}");
        // Every event reports a change written into a body.
        assert!(
            c.writes >= events && c.impact_pairs > 0,
            "{timing:?}: {c:?}"
        );
        // The high ball is far every step; the low one is near a ground at its impacts.
        assert!(c.far >= 60 && c.near >= c.impact_pairs, "{timing:?}: {c:?}");
        for stage in [Stage::Plan, Stage::Rapier, Stage::Bodies] {
            assert!(
                run.time(stage) > std::time::Duration::ZERO,
                "{timing:?} {stage:?}"
            );
        }
        assert!(run.plugin_time() + run.time(Stage::Rapier) >= run.time(Stage::Plan));
        plugin.set_profiling(false);
        plugin.step(&mut world);
        assert!(plugin.profile().is_none(), "{timing:?}: off again");
    }
}
