//! rapier's pair filtering holds for the plugin: a ball whose pair with the ground rapier
//! would not solve (collision groups, solver groups, active collision types, a sensor, a
//! disabled collider or body, a joint that disables contacts) falls through the ground with
//! the plugin exactly as it does in rapier alone, in every timing mode, and the plugin
//! reports no event for it. Each scene runs once with the filter and once without, so a
//! plugin that ignores the filter fails (the ball bounces), and so does a scene that tests
//! nothing (rapier alone must bounce without the filter too).

mod plugin_support;

use plugin_support::{MODES, plugin_on, real, wide};
use rapier_impact::rapier::prelude::*;

/// How a scene keeps rapier from solving the ball-ground pair.
#[derive(Clone, Copy, Debug)]
enum Filter {
    CollisionGroups,
    SolverGroups,
    ActiveCollisionTypes,
    SensorGround,
    DisabledGround,
    DisabledGroundBody,
    JointWithoutContacts,
}

const FILTERS: [Filter; 7] = [
    Filter::CollisionGroups,
    Filter::SolverGroups,
    Filter::ActiveCollisionTypes,
    Filter::SensorGround,
    Filter::DisabledGround,
    Filter::DisabledGroundBody,
    Filter::JointWithoutContacts,
];

/// A 10 cm ball (e = 0.8) dropped from 1 m onto a fixed cuboid ground (top at y = 0), with
/// `filter` applied or not. Returns the world, the ground collider and the ball.
fn scene(filter: Option<Filter>) -> (PhysicsWorld, ColliderHandle, RigidBodyHandle) {
    let mut world = PhysicsWorld::default();
    // A member of group 1 that interacts with no group.
    let apart = InteractionGroups::new(Group::GROUP_1, Group::NONE, InteractionTestMode::And);
    let mut ground = ColliderBuilder::cuboid(5.0, 0.5, 5.0)
        .translation(Vector::new(0.0, -0.5, 0.0))
        .restitution(0.8);
    let mut ball = ColliderBuilder::ball(0.1).restitution(0.8);
    match filter {
        Some(Filter::CollisionGroups) => ball = ball.collision_groups(apart),
        Some(Filter::SolverGroups) => ball = ball.solver_groups(apart),
        Some(Filter::ActiveCollisionTypes) => {
            // Neither collider accepts a dynamic-fixed pair.
            ball = ball.active_collision_types(ActiveCollisionTypes::DYNAMIC_DYNAMIC);
            ground = ground.active_collision_types(ActiveCollisionTypes::DYNAMIC_DYNAMIC);
        }
        Some(Filter::SensorGround) => ground = ground.sensor(true),
        _ => {}
    }
    let (ground_body, ground) = world.insert(RigidBodyBuilder::fixed(), ground);
    let (ball_body, _) = world.insert(
        RigidBodyBuilder::dynamic().translation(Vector::new(0.0, 1.1, 0.0)),
        ball,
    );
    match filter {
        Some(Filter::DisabledGround) => world.colliders[ground].set_enabled(false),
        Some(Filter::DisabledGroundBody) => world.bodies[ground_body].set_enabled(false),
        Some(Filter::JointWithoutContacts) => {
            // A rope long enough never to pull in the run.
            let rope = RopeJointBuilder::new(real(50.0)).contacts_enabled(false);
            world.insert_impulse_joint(ground_body, ball_body, rope);
        }
        _ => {}
    }
    (world, ground, ball_body)
}

/// Steps 1.5 s (the ball reaches the ground at 0.45 s) with the plugin in `timing`, or
/// rapier alone (`None`). Returns the ball's lowest height and the plugin's event count.
fn run(filter: Option<Filter>, timing: Option<rapier_impact::TimingMode>) -> (f64, usize) {
    let (mut world, ground, ball) = scene(filter);
    let mut plugin = timing.map(|t| plugin_on(&world, ground, t));
    let (mut lowest, mut events) = (f64::INFINITY, 0);
    for _ in 0..90 {
        match plugin.as_mut() {
            Some(p) => {
                p.step(&mut world);
                events += p.events().len();
            }
            None => world.step(),
        }
        lowest = lowest.min(wide(world.bodies[ball].translation().y));
    }
    (lowest, events)
}

#[test]
fn a_pair_rapier_does_not_solve_is_not_the_plugins() {
    // Through the ground: the ball's centre ends below its top (y = 0) by more than its
    // radius; bounced, it never goes below its radius less rapier's allowed error.
    let through = |lowest: f64| lowest < -0.5;
    let (unfiltered, _) = run(None, None);
    assert!(
        !through(unfiltered),
        "rapier alone, no filter: the ball must bounce (lowest {unfiltered:.3} m)"
    );
    for timing in MODES {
        let (lowest, events) = run(None, Some(timing));
        assert!(
            !through(lowest) && events > 0,
            "{timing:?}, no filter: lowest {lowest:.3} m, {events} events; the plugin must bounce it"
        );
    }
    for filter in FILTERS {
        let (alone, _) = run(Some(filter), None);
        assert!(
            through(alone),
            "{filter:?}: rapier alone must let the ball through (lowest {alone:.3} m)"
        );
        for timing in MODES {
            let (lowest, events) = run(Some(filter), Some(timing));
            assert!(
                through(lowest) && events == 0,
                "{filter:?}, {timing:?}: lowest {lowest:.3} m (rapier alone {alone:.3} m), \
                 {events} events; rapier does not solve the pair, so the plugin must not"
            );
        }
    }
}
