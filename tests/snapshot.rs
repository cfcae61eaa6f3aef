//! Save and resume: rapier's world and the plugin's snapshot saved at a step and given back
//! to a new plugin go on bit for bit as the run they were taken from, in every timing mode,
//! with impacts between bodies, rolling balls, a ball held on a slope, a moving ground, a cube
//! bouncing in a mesh's crease and a body the plugin does not manage, tangential restitutions and restitution curves of the
//! configuration, of bodies and of a ground; with the `serde-serialize` feature, through CBOR too.
//! A new plugin that is not restored does not (so the scenes exercise what the snapshot
//! carries), and the user's hook flags come back as they were set.

mod scene_support;

use rapier_impact::rapier::prelude::*;
use rapier_impact::{
    GroundMaterial, ImpactConfig, ImpactEvent, ImpactPlugin, ImpactSnapshot, RestitutionCurve,
    RollingSettings, TimingMode,
};
use scene_support::{
    crease_trimesh, events_hash, jitter, real, saved_world, state_hash, walled_box,
};

const STEPS: usize = 240;
/// The steps after which the run is saved and resumed: the first, one in the thick of the
/// impacts, one as the scene settles.
const SAVES: [usize; 3] = [1, 45, 160];
const MODES: [TimingMode; 3] = [
    TimingMode::Step,
    TimingMode::TimeOfImpact,
    TimingMode::Exact,
];

/// The scene: a floor, a box of walls, a crowd of opted-in balls dropped into it, boxes,
/// two rolling balls (one with its own rolling resistance), a ball at rest on a 10-degree
/// slope, a kinematic platform moving under a ball, a cube dropped into a trimesh crease, and
/// a ball the plugin leaves to rapier.
/// The last has user hook flags, as has the floor.
fn scene(timing: TimingMode) -> (PhysicsWorld, ImpactPlugin) {
    let mut world = PhysicsWorld::default();
    let (_, floor) = world.insert(
        RigidBodyBuilder::fixed().translation(Vector::new(0.0, -0.5, 0.0)),
        ColliderBuilder::cuboid(20.0, 0.5, 20.0)
            .restitution(0.8)
            .friction(0.6)
            .active_hooks(ActiveHooks::FILTER_INTERSECTION_PAIR),
    );
    walled_box(&mut world, 0.6);
    let config = ImpactConfig::default()
        .with_timing(timing)
        .with_rolling_resistance(0.02)
        .with_tangential_restitution(0.2);
    let mut plugin = ImpactPlugin::new(config).unwrap();
    drop_crowd(&mut world, &mut plugin);
    add_boxes_with_their_own_restitution(&mut world, &mut plugin);
    add_rolling_balls(&mut world, &mut plugin);
    let slope = add_slope_with_a_ball_at_rest(&mut world);
    let platform = add_moving_platform_with_a_ball_over_it(&mut world);
    let crease = add_crease_with_a_cube_over_it(&mut world);
    add_ball_left_to_rapier(&mut world, &mut plugin);
    for ground in [floor, slope, crease] {
        plugin
            .add_ground(&world.bodies, &world.colliders, ground)
            .unwrap();
    }
    // A ground with its own tangential restitution and curve.
    let material = GroundMaterial::new(0.6, 0.5)
        .with_tangential_restitution(0.7)
        .with_restitution_curve(RestitutionCurve::threshold(0.3, 0.8).unwrap());
    plugin
        .add_ground_with_material(&world.bodies, &world.colliders, platform, material)
        .unwrap();
    (world, plugin)
}

/// 24 opted-in balls dropped into the box of walls, thrown sideways and spinning.
fn drop_crowd(world: &mut PhysicsWorld, plugin: &mut ImpactPlugin) {
    let mut next = jitter(7, 0.05);
    for i in 0..24 {
        let (x, z) = (
            real(-0.45 + 0.3 * (i % 4) as f64),
            real(-0.3 + 0.3 * (i / 4 % 3) as f64),
        );
        let y = real(0.3 + 0.25 * (i / 12) as f64 + next().abs());
        let (body, _) = world.insert(
            RigidBodyBuilder::dynamic()
                .translation(Vector::new(x, y, z))
                .linvel(Vector::new(
                    real(next() * 20.0),
                    real(-1.0),
                    real(next() * 20.0),
                ))
                .angvel(Vector::new(0.0, real(next() * 40.0), 0.0)),
            ColliderBuilder::ball(0.1).restitution(0.9).friction(0.3),
        );
        plugin.add_impact_body(&world.bodies, body).unwrap();
    }
}

/// Boxes with their own tangential restitution and restitution curve.
fn add_boxes_with_their_own_restitution(world: &mut PhysicsWorld, plugin: &mut ImpactPlugin) {
    let curve = RestitutionCurve::new(vec![(0.5, 0.0), (0.5, 0.6), (4.0, 0.3)]).unwrap();
    for i in 0..3 {
        let (body, _) = world.insert(
            RigidBodyBuilder::dynamic()
                .translation(Vector::new(real(3.0 + i as f64), 0.8, 2.0))
                .angvel(Vector::new(3.0, 1.0, real(i as f64))),
            ColliderBuilder::cuboid(0.2, 0.05, 0.15).restitution(0.5),
        );
        plugin
            .set_body_tangential_restitution(body, Some(-0.3))
            .unwrap();
        plugin
            .set_body_restitution_curve(body, Some(curve.clone()))
            .unwrap();
    }
}

/// Two balls rolling on the floor, the first with its own rolling resistance.
fn add_rolling_balls(world: &mut PhysicsWorld, plugin: &mut ImpactPlugin) {
    let (slow, _) = world.insert(
        RigidBodyBuilder::dynamic()
            .translation(Vector::new(-3.0, 0.1, -3.0))
            .linvel(Vector::new(1.5, 0.0, 0.0))
            .angvel(Vector::new(0.0, 0.0, -15.0)),
        ColliderBuilder::ball(0.1).restitution(0.8),
    );
    plugin
        .set_body_rolling(slow, Some(RollingSettings::new(0.05, 0.01)))
        .unwrap();
    world.insert(
        RigidBodyBuilder::dynamic()
            .translation(Vector::new(-3.0, 0.1, -5.0))
            .linvel(Vector::new(0.0, 0.0, 2.0))
            .angvel(Vector::new(20.0, 0.0, 0.0)),
        ColliderBuilder::ball(0.1).restitution(0.8),
    );
}

/// A fixed 10-degree slope with a ball at rest on it: the slope, a ground to be.
fn add_slope_with_a_ball_at_rest(world: &mut PhysicsWorld) -> ColliderHandle {
    let tilt = Vector::new(0.0, 0.0, real(10f64.to_radians()));
    let (_, slope) = world.insert(
        RigidBodyBuilder::fixed()
            .translation(Vector::new(6.0, 0.5, -4.0))
            .rotation(tilt),
        ColliderBuilder::cuboid(1.0, 0.05, 1.0).friction(0.9),
    );
    let n = Rotation::from_scaled_axis(tilt) * Vector::Y;
    world.insert(
        RigidBodyBuilder::dynamic().translation(Vector::new(6.0, 0.5, -4.0) + n * 0.15),
        ColliderBuilder::ball(0.1).restitution(0.3).friction(0.9),
    );
    slope
}

/// A kinematic platform moving under a ball: the platform, a ground to be.
fn add_moving_platform_with_a_ball_over_it(world: &mut PhysicsWorld) -> ColliderHandle {
    let (_, platform) = world.insert(
        RigidBodyBuilder::kinematic_velocity_based()
            .translation(Vector::new(-6.0, 0.3, 4.0))
            .linvel(Vector::new(0.2, 0.1, 0.0)),
        ColliderBuilder::cuboid(1.0, 0.05, 1.0).restitution(0.6),
    );
    world.insert(
        RigidBodyBuilder::dynamic().translation(Vector::new(-6.0, 1.0, 4.0)),
        ColliderBuilder::ball(0.1).restitution(0.7),
    );
    platform
}

/// A trimesh crease of two 60-degree faces standing on the floor, with a tilted cube dropped
/// into it: the crease, a ground to be. (The side of the mesh the cube touched is kept and
/// saved, but matters only to a body that crosses the mesh, which this one does not: the
/// run resumes the same without it.)
fn add_crease_with_a_cube_over_it(world: &mut PhysicsWorld) -> ColliderHandle {
    let (_, crease) = world.insert(
        RigidBodyBuilder::fixed().translation(Vector::new(-6.0, 0.0, -4.0)),
        crease_trimesh(0.5, 60f64.to_radians().tan())
            .restitution(0.6)
            .friction(0.5),
    );
    world.insert(
        RigidBodyBuilder::dynamic()
            .translation(Vector::new(-5.97, 1.2, -4.0))
            .rotation(Vector::new(0.0, 0.2, 0.3)),
        ColliderBuilder::cuboid(0.08, 0.08, 0.08).restitution(0.6),
    );
    crease
}

/// A ball with user hook flags that the plugin excludes.
fn add_ball_left_to_rapier(world: &mut PhysicsWorld, plugin: &mut ImpactPlugin) {
    let (left, _) = world.insert(
        RigidBodyBuilder::dynamic().translation(Vector::new(6.0, 1.5, 6.0)),
        ColliderBuilder::ball(0.1)
            .restitution(0.7)
            .active_hooks(ActiveHooks::MODIFY_SOLVER_CONTACTS),
    );
    plugin.exclude_body(left);
}

/// A step's record: every body bit for bit, the events bit for bit and as values.
type Record = (u64, u64, Vec<ImpactEvent>);

fn step(world: &mut PhysicsWorld, plugin: &mut ImpactPlugin) -> Record {
    plugin.step(world);
    let events = plugin.events().to_vec();
    (state_hash(world), events_hash(&events), events)
}

/// The run's records, and the world and snapshot saved after each step of `SAVES`.
fn reference(timing: TimingMode) -> (Vec<Record>, Vec<(PhysicsWorld, ImpactSnapshot)>) {
    let (mut world, mut plugin) = scene(timing);
    let mut records = Vec::new();
    let mut saved = Vec::new();
    for k in 1..=STEPS {
        records.push(step(&mut world, &mut plugin));
        if SAVES.contains(&k) {
            saved.push((saved_world(&world), plugin.snapshot()));
        }
    }
    (records, saved)
}

/// The records of a run resumed after step `from` with `plugin`.
fn resume(mut world: PhysicsWorld, mut plugin: ImpactPlugin, from: usize) -> Vec<Record> {
    (from..STEPS)
        .map(|_| step(&mut world, &mut plugin))
        .collect()
}

/// The first step (1-based) at which `resumed` leaves `records`, if any.
fn first_difference(records: &[Record], resumed: &[Record], from: usize) -> Option<usize> {
    let tail = &records[from..];
    assert_eq!(tail.len(), resumed.len());
    tail.iter()
        .zip(resumed)
        .position(|(a, b)| a != b)
        .map(|k| from + k + 1)
}

fn fresh(timing: TimingMode) -> ImpactPlugin {
    ImpactPlugin::new(ImpactConfig::default().with_timing(timing)).unwrap()
}

#[test]
fn a_restored_plugin_goes_on_bit_for_bit_in_every_mode() {
    for timing in MODES {
        let (records, saved) = reference(timing);
        let events: usize = records.iter().map(|r| r.2.len()).sum();
        assert!(events > 100, "{timing:?}: the scene has {events} events");
        let mut fresh_diverged = false;
        for ((world, snapshot), from) in saved.into_iter().zip(SAVES) {
            let mut plugin = fresh(timing);
            plugin.restore(&snapshot).unwrap();
            assert_eq!(plugin.events(), &records[from - 1].2[..]);
            assert_eq!(
                plugin.snapshot(),
                snapshot,
                "{timing:?}: restore then snapshot"
            );
            let resumed = resume(saved_world(&world), plugin, from);
            assert_eq!(
                first_difference(&records, &resumed, from),
                None,
                "{timing:?}, resumed after step {from}: first step that differs"
            );
            // The same world with a new plugin that is not restored (its registrations
            // made again): what the snapshot carries is what keeps the run.
            let (_, again) = scene(timing);
            let unrestored = resume(world, again, from);
            fresh_diverged |= first_difference(&records, &unrestored, from).is_some();
        }
        assert!(
            fresh_diverged,
            "{timing:?}: a plugin that is not restored goes on as well; the scene does not test the snapshot"
        );
    }
}

#[test]
fn the_user_hook_flags_come_back_after_a_restore() {
    let (mut world, mut plugin) = scene(TimingMode::Exact);
    for _ in 0..30 {
        plugin.step(&mut world);
    }
    // The plugin's flags are on the floor and on the bodies near a ground (a body is left to
    // rapier, so both arrangements are in use).
    let user = |world: &PhysicsWorld| -> Vec<(ColliderHandle, ActiveHooks)> {
        world
            .colliders
            .iter()
            .map(|(h, co)| (h, co.active_hooks()))
            .collect()
    };
    let flagged = user(&world);
    let snapshot = plugin.snapshot();
    let expected = user(&{
        let mut w = saved_world(&world);
        plugin.detach(&mut w.colliders);
        w
    });
    assert_ne!(flagged, expected, "the plugin had set no flags");
    let mut restored = fresh(TimingMode::Exact);
    restored.restore(&snapshot).unwrap();
    let mut w = saved_world(&world);
    restored.detach(&mut w.colliders);
    assert_eq!(user(&w), expected);
    // A plugin that is not restored takes the flags it finds for the user's own.
    let mut w = saved_world(&world);
    let (_, mut unrestored) = scene(TimingMode::Exact);
    unrestored.step(&mut w);
    unrestored.detach(&mut w.colliders);
    assert_ne!(user(&w), expected);
}

#[cfg(feature = "serde-serialize")]
mod serialized {
    use super::*;

    fn cbor<T: serde::Serialize + serde::de::DeserializeOwned>(value: &T) -> T {
        let mut bytes = Vec::new();
        ciborium::into_writer(value, &mut bytes).expect("serializes");
        ciborium::from_reader(bytes.as_slice()).expect("deserializes")
    }

    #[test]
    fn a_run_saved_and_read_back_through_cbor_goes_on_bit_for_bit() {
        for timing in MODES {
            let (records, saved) = reference(timing);
            for ((world, snapshot), from) in saved.into_iter().zip(SAVES) {
                let world: PhysicsWorld = cbor(&world);
                let back: ImpactSnapshot = cbor(&snapshot);
                assert_eq!(back, snapshot);
                // The snapshot alone holds only finite numbers: JSON keeps it too.
                let json = serde_json::to_string(&snapshot).unwrap();
                let from_json: ImpactSnapshot = serde_json::from_str(&json).unwrap();
                assert_eq!(from_json, snapshot);
                let mut plugin = fresh(timing);
                plugin.restore(&back).unwrap();
                let resumed = resume(world, plugin, from);
                assert_eq!(
                    first_difference(&records, &resumed, from),
                    None,
                    "{timing:?}, resumed from CBOR after step {from}: first step that differs"
                );
            }
        }
    }
}

/// The control: rapier alone resumes bit for bit from the same copy of its world, so a
/// difference above is the plugin's.
#[test]
fn rapier_alone_resumes_bit_for_bit() {
    let (mut world, _) = scene(TimingMode::Exact);
    let mut hashes = Vec::new();
    let mut saved = None;
    for k in 1..=STEPS {
        world.step();
        hashes.push(state_hash(&world));
        if k == SAVES[0] {
            saved = Some(saved_world(&world));
        }
    }
    let mut world = saved.unwrap();
    for (k, expected) in hashes.iter().enumerate().skip(SAVES[0]) {
        world.step();
        assert_eq!(state_hash(&world), *expected, "step {}", k + 1);
    }
}

/// A body the last step's plan found near a ground is planned without the survey's test that
/// it is far (outside slabs). Lifted far above the floor, or left without a
/// collider to query (made a sensor, or disabled) between steps, it steps exactly as a
/// restored plugin steps it, whose survey tests every body afresh (a snapshot carries no such
/// marks); the profile's counts say that the two took different paths.
#[test]
fn a_body_near_a_ground_last_step_steps_as_after_a_restore() {
    for timing in [
        TimingMode::Step,
        TimingMode::TimeOfImpact,
        TimingMode::Exact,
    ] {
        let mut world = PhysicsWorld::default();
        let (_, floor) = world.insert(
            RigidBodyBuilder::fixed(),
            ColliderBuilder::cuboid(20.0, 0.5, 20.0).translation(Vector::new(0.0, -0.5, 0.0)),
        );
        let mut plugin = ImpactPlugin::new(ImpactConfig::default().with_timing(timing)).unwrap();
        plugin
            .add_ground(&world.bodies, &world.colliders, floor)
            .unwrap();
        // Five balls rolling on the floor: three to be changed, two left as they are.
        let balls: Vec<(RigidBodyHandle, ColliderHandle)> = (0..5)
            .map(|i| {
                let (body, collider) = world.insert(
                    RigidBodyBuilder::dynamic()
                        .translation(Vector::new(real(-2.0 + i as f64), 0.1, 0.0))
                        .linvel(Vector::new(1.0, 0.0, 0.0))
                        .angvel(Vector::new(0.0, 0.0, -10.0)),
                    ColliderBuilder::ball(0.1).restitution(0.7),
                );
                plugin.add_impact_body(&world.bodies, body).unwrap();
                (body, collider)
            })
            .collect();
        for _ in 0..10 {
            plugin.step(&mut world);
        }
        let mut restored = fresh(timing);
        restored.restore(&plugin.snapshot()).unwrap();
        let mut copy = saved_world(&world);
        let edit = |world: &mut PhysicsWorld| {
            world.bodies[balls[0].0].set_translation(Vector::new(-2.0, 50.0, 0.0), true);
            world.colliders[balls[1].1].set_sensor(true);
            world.colliders[balls[2].1].set_enabled(false);
        };
        edit(&mut world);
        edit(&mut copy);
        plugin.set_profiling(true);
        restored.set_profiling(true);
        for k in 0..30 {
            let (a, b) = (
                step(&mut world, &mut plugin),
                step(&mut copy, &mut restored),
            );
            assert_eq!(a, b, "{timing:?}: step {k} after the change");
            if k == 0 {
                let (marked, surveyed) = (
                    plugin.profile().unwrap().counts,
                    restored.profile().unwrap().counts,
                );
                // Lifted: planned, not near; without a collider to query: planned, no more.
                assert_eq!(marked.planned, surveyed.planned + 3, "{timing:?}");
                assert_eq!(marked.far + 1, surveyed.far, "{timing:?}");
                assert_eq!(marked.near, surveyed.near, "{timing:?}");
            }
        }
    }
}

/// The event log across a restore: a restored plugin's log, if on, starts empty and then
/// holds exactly the events of the steps after the restore, as the saved run's log did after
/// it was taken at the save; so does a plugin that ran ahead, with events left in its log,
/// and is restored back.
#[test]
fn a_restored_plugins_event_log_holds_only_later_steps() {
    let timing = TimingMode::TimeOfImpact;
    let (mut world, mut plugin) = scene(timing);
    plugin.set_event_log(true);
    let logs = |world: &mut PhysicsWorld, plugin: &mut ImpactPlugin| {
        (0..20)
            .map(|_| {
                plugin.step(world);
                plugin.take_event_log()
            })
            .collect::<Vec<_>>()
    };
    // Saved after the first step with events (the crowd landing), the log taken there.
    while plugin.events().is_empty() {
        plugin.step(&mut world);
    }
    plugin.take_event_log();
    let (saved, snapshot) = (saved_world(&world), plugin.snapshot());
    let expected = logs(&mut world, &mut plugin);
    assert!(
        expected.iter().any(|l| !l.is_empty()),
        "events after the save"
    );

    let mut restored = fresh(timing);
    restored.set_event_log(true);
    restored.restore(&snapshot).unwrap();
    assert!(
        restored.take_event_log().is_empty(),
        "a new plugin's log starts empty"
    );
    let mut world = saved_world(&saved);
    assert_eq!(logs(&mut world, &mut restored), expected);

    // The plugin that ran ahead, its last steps' events not taken, restored back.
    for _ in 0..3 {
        plugin.step(&mut world);
    }
    plugin.restore(&snapshot).unwrap();
    assert!(
        plugin.take_event_log().is_empty(),
        "a rewound plugin's log starts empty"
    );
    let mut world = saved_world(&saved);
    assert_eq!(logs(&mut world, &mut plugin), expected);
}
