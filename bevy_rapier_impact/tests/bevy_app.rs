//! The plugin in headless Bevy apps (minimal plugins, no window): the core crate's drop scene
//! bounces as it does there, events arrive as messages naming the spawned entities, the
//! user's hooks still run, substeps give the same trace as single steps of the same length,
//! the `Ground` marker, the all-fixed switch and a body's own tangential restitution and
//! restitution curve take effect.

mod support;

use bevy::prelude::*;
use bevy_rapier_impact::{
    ConfigError, EventKind, Ground, ImpactConfig, RapierImpactPlugin, RestitutionBySpeed,
    RestitutionCurve, TangentialRestitution, TimingMode,
};
use bevy_rapier3d::prelude::*;
use rapier_impact::ImpactPlugin;
use rapier_impact::rapier::prelude as rp;
use support::*;

const DT: f32 = 1.0 / 60.0;

fn fixed(dt: f32, substeps: usize) -> TimestepMode {
    TimestepMode::Fixed { dt, substeps }
}

/// The core crate's drop scene in a bare `PhysicsWorld` (as `tests/plugin_drop.rs` of the
/// core crate builds it), measured as the Bevy app is: apexes after each bounce.
fn core_apexes(steps: usize) -> Vec<f64> {
    let mut world = rp::PhysicsWorld::default();
    world.integration_parameters.dt = DT;
    let (_, ground) = world.insert(
        rp::RigidBodyBuilder::fixed(),
        rp::ColliderBuilder::halfspace(rapier_impact::rapier::na::Unit::new_unchecked(
            rp::Vector::Y,
        ))
        .restitution(E as f32)
        .friction(0.5),
    );
    let (ball, _) = world.insert(
        rp::RigidBodyBuilder::dynamic().translation(rp::Vector::new(0.0, 1.1, 0.0)),
        rp::ColliderBuilder::ball(RADIUS as f32)
            .restitution(E as f32)
            .friction(0.5),
    );
    let mut plugin = ImpactPlugin::new(ImpactConfig::default()).unwrap();
    plugin
        .add_ground(&world.bodies, &world.colliders, ground)
        .unwrap();
    let mut apexes = Apexes::default();
    for _ in 0..steps {
        plugin.step(&mut world);
        let rb = &world.bodies[ball];
        apexes.sample(f64::from(rb.center_of_mass().y), f64::from(rb.linvel().y));
    }
    apexes.apexes
}

#[test]
fn dropped_ball_apexes_follow_e_squared_as_in_the_core_crate() {
    let mut app = app(plugin(), fixed(DT, 1), f64::from(DT));
    spawn_ground(&mut app, true);
    let ball = spawn_ball(&mut app);
    // 4.6 s, as the core crate's drop test.
    let frames = 276;
    let bounces = measure(&mut app, ball, frames, f64::from(DT));
    let core = core_apexes(frames);
    println!(
        "{:>3} {:>11} {:>11} {:>10} | {:>10} {:>10} {:>10}",
        "n", "t_impact", "expected", "err s", "apex", "expected", "rel err"
    );
    let (mut worst_apex, mut worst_time, mut worst_core) = (0.0f64, 0.0f64, 0.0f64);
    for n in 1..=10 {
        let (t, te) = (bounces.impacts.get(n - 1).copied(), impact_time(n - 1));
        let (a, ae) = (bounces.apexes.get(n - 1).copied(), apex(n));
        let c = core.get(n - 1).copied();
        println!(
            "{n:>3} {:>11.7} {te:>11.7} {:>+10.2e} | {:>10.7} {ae:>10.7} {:>+10.2e}  core {:?}",
            t.unwrap_or(f64::NAN),
            t.map_or(f64::NAN, |t| t - te),
            a.unwrap_or(f64::NAN),
            a.map_or(f64::NAN, |a| a / ae - 1.0),
            c
        );
        worst_time = worst_time.max(t.map_or(f64::INFINITY, |t| (t - te).abs()));
        worst_apex = worst_apex.max(a.map_or(f64::INFINITY, |a| (a / ae - 1.0).abs()));
        worst_core = worst_core.max(match (a, c) {
            (Some(a), Some(c)) => (a / c - 1.0).abs(),
            _ => f64::INFINITY,
        });
    }
    println!(
        "worst: apex {worst_apex:.2e} relative, impact time {worst_time:.2e} s, \
         apex vs the core crate {worst_core:.2e}"
    );
    // The core crate's `exact` tolerances in f32 (tests/plugin_drop.rs).
    assert!(
        worst_apex <= 1e-6,
        "apexes: worst relative error {worst_apex:.3e}, tolerance 1e-6"
    );
    assert!(
        worst_time <= 5e-7,
        "impact times: worst error {worst_time:.3e} s, tolerance 5e-7 s"
    );
    assert!(
        worst_core <= 1e-6,
        "apexes against the core crate's run: worst relative difference {worst_core:.3e}, tolerance 1e-6"
    );
}

#[test]
fn impact_messages_name_the_spawned_entities() {
    let mut app = app(plugin(), fixed(DT, 1), f64::from(DT));
    let ground = spawn_ground(&mut app, true);
    // The collider on a child entity: body and collider are two entities.
    let ball = app
        .world_mut()
        .spawn((Transform::from_xyz(0.0, 1.1, 0.0), RigidBody::Dynamic))
        .id();
    let part = app
        .world_mut()
        .spawn((
            Transform::default(),
            Collider::ball(RADIUS as f32),
            Restitution::coefficient(E as f32),
            ChildOf(ball),
        ))
        .id();
    for _ in 0..60 {
        app.update();
    }
    let ctx = context(&mut app);
    let rec = app.world().resource::<Recorded>();
    let impacts: Vec<_> = rec
        .impacts
        .iter()
        .filter(|m| m.event.kind == EventKind::Impact)
        .collect();
    println!(
        "{} impact messages; first: {:?}",
        impacts.len(),
        impacts.first()
    );
    assert!(
        !impacts.is_empty(),
        "no impact message in 1 s of a 1 m drop"
    );
    for m in &impacts {
        assert_eq!(
            (m.context, m.body, m.collider, m.ground, m.body2),
            (ctx, ball, part, ground, None),
            "message entities (context, body, collider, ground, body2)"
        );
    }
    // The first bounce is at t1 = 0.4515 s: in step 27 at 60 Hz.
    assert_eq!(impacts[0].step, 27, "step index of the first impact");
}

#[test]
fn user_hooks_still_filter_the_pairs_the_plugin_does_not_take() {
    let mut world_app = app(
        RapierImpactPlugin::<TestHooks>::new(ImpactConfig::default()).unwrap(),
        fixed(DT, 1),
        f64::from(DT),
    );
    let app = &mut world_app;
    let ground = spawn_ground(app, true);
    // A fixed platform half-way down, not a ground: the user's filter refuses its contacts.
    let ghost = app
        .world_mut()
        .spawn((
            Transform::from_xyz(0.0, 0.5, 0.0),
            Collider::cuboid(1.0, 0.05, 1.0),
        ))
        .id();
    app.insert_resource(HookLog::refusing(ghost));
    let ball = spawn_ball(app);
    app.world_mut()
        .entity_mut(ball)
        .insert(ActiveHooks::FILTER_CONTACT_PAIRS);
    let mut lowest = f32::INFINITY;
    for _ in 0..40 {
        app.update();
        lowest = lowest.min(ball_state(app, ball).0.y);
    }
    let calls = *app
        .world()
        .resource::<HookLog>()
        .contact_calls
        .lock()
        .unwrap();
    let rec = app.world().resource::<Recorded>();
    let hit_ground = rec
        .impacts
        .iter()
        .any(|m| m.event.kind == EventKind::Impact && m.ground == ground);
    println!("filter calls {calls}, lowest centre {lowest:.4} m, ground impact {hit_ground}");
    assert!(calls > 0, "the user's contact filter was never called");
    // Through the refused platform (its top at 0.55 m) down to the ground.
    assert!(
        lowest < 0.2,
        "the ball stopped at {lowest:.4} m: the user's filter did not take effect"
    );
    assert!(
        hit_ground,
        "no impact with the ground under the ghost platform"
    );
}

#[test]
fn hook_flags_the_app_sets_at_run_time_keep_the_plugin_s_bounces() {
    // bevy_rapier copies a changed `ActiveHooks` into rapier, over the flags the plugin put
    // on the ground: the plugin must take them as the user's and add its own again.
    let mut app = app(
        RapierImpactPlugin::<TestHooks>::new(ImpactConfig::default()).unwrap(),
        fixed(DT, 1),
        f64::from(DT),
    );
    app.insert_resource(HookLog::refusing(Entity::PLACEHOLDER));
    let ground = spawn_ground(&mut app, true);
    let ball = spawn_ball(&mut app);
    for _ in 0..10 {
        app.update();
    }
    app.world_mut()
        .entity_mut(ground)
        .insert(ActiveHooks::MODIFY_SOLVER_CONTACTS);
    // To 4.6 s: ten bounces, then at rest from 4.06 s.
    let bounces = measure(&mut app, ball, 266, f64::from(DT));
    let worst = (1..=10)
        .map(|n| {
            bounces
                .apexes
                .get(n - 1)
                .map_or(f64::INFINITY, |a| (a / apex(n) - 1.0).abs())
        })
        .fold(0.0, f64::max);
    let modify = *app
        .world()
        .resource::<HookLog>()
        .modify_calls
        .lock()
        .unwrap();
    println!("worst apex error {worst:.2e}; the user's modify_solver_contacts calls {modify}");
    assert!(
        worst <= 1e-6,
        "apexes: worst relative error {worst:.3e}, tolerance 1e-6"
    );
    // The resting ball's contact is rapier's: handed to the user's hook first.
    assert!(
        modify > 0,
        "the user's modify_solver_contacts was never called"
    );
}

/// The bits of a ball state (position, velocity) at the start of a rapier step.
type StateBits = [u32; 6];
/// The step of an impact message and the bits of its time, normal impulse, kinetic energy
/// after, approach speed.
type EventBits = (u64, [u64; 4]);

/// Ball states at the start of each of `steps` rapier steps, and the impact messages, with
/// the timestep `mode` and frames of `frame` seconds.
fn trace(mode: TimestepMode, frame: f64, steps: u64) -> (Vec<StateBits>, Vec<EventBits>) {
    let mut app = app(
        RapierImpactPlugin::<TestHooks>::new(ImpactConfig::default()).unwrap(),
        mode,
        frame,
    );
    app.init_resource::<StepTrace>();
    spawn_ground(&mut app, true);
    spawn_ball(&mut app);
    // A sensor around the scene, whose intersection filter samples the ball each step.
    app.world_mut().spawn((
        Transform::from_xyz(0.0, 1.0, 0.0),
        Collider::cuboid(2.0, 2.0, 2.0),
        Sensor,
        ActiveHooks::FILTER_INTERSECTION_PAIR,
    ));
    // The context is spawned by the first frame.
    app.update();
    let mut frames = 1;
    while frames < 10 * steps && simulation(&mut app).steps() < steps {
        app.update();
        frames += 1;
    }
    let mut states = std::mem::take(&mut *app.world().resource::<StepTrace>().0.lock().unwrap());
    states.truncate(steps as usize);
    let rec = app.world().resource::<Recorded>();
    let events = rec
        .impacts
        .iter()
        .filter(|m| m.step < steps)
        .map(|m| {
            let e = &m.event;
            (
                m.step,
                [
                    e.time.to_bits(),
                    e.normal_impulse.to_bits(),
                    e.ke_after.to_bits(),
                    e.approach_speed.to_bits(),
                ],
            )
        })
        .collect();
    (states, events)
}

#[test]
fn substeps_give_the_trace_of_single_steps_of_the_same_length() {
    // Powers of two: the frame over 4 substeps is 1/256 s exactly, in every mode.
    let steps = 600;
    let single = trace(fixed(1.0 / 256.0, 1), 1.0 / 256.0, steps);
    let variants = [
        ("Fixed, 4 substeps", fixed(1.0 / 64.0, 4), 1.0 / 64.0),
        (
            "Variable, 4 substeps",
            TimestepMode::Variable {
                max_dt: 1.0 / 64.0,
                time_scale: 1.0,
                substeps: 4,
            },
            1.0 / 64.0,
        ),
        (
            "Interpolated, 4 steps of catch-up per frame",
            TimestepMode::Interpolated {
                dt: 1.0 / 256.0,
                time_scale: 1.0,
                substeps: 1,
            },
            1.0 / 64.0,
        ),
    ];
    assert_eq!(single.0.len(), steps as usize, "single-step samples");
    // One sample per step, not one per frame repeated: the ball moves at every step.
    assert!(
        single.0.windows(2).all(|w| w[0] != w[1]),
        "a repeated sample"
    );
    // 2.3 s: the first bounces at least.
    assert!(
        single.1.len() >= 3,
        "impacts in the single-step run: {}",
        single.1.len()
    );
    for (name, mode, frame) in variants {
        let (states, events) = trace(mode, frame, steps);
        let first_diff = states.iter().zip(&single.0).position(|(a, b)| a != b);
        println!(
            "{name}: {} samples, {} events; first differing step {first_diff:?}",
            states.len(),
            events.len()
        );
        assert_eq!(states.len(), single.0.len(), "{name}: samples");
        assert_eq!(first_diff, None, "{name}: states differ from single steps");
        assert_eq!(
            events, single.1,
            "{name}: impact messages (step, time, impulse, energy, speed)"
        );
    }
}

#[test]
fn removing_the_ground_marker_hands_the_ground_back_to_rapier() {
    let mut app = app(plugin(), fixed(DT, 1), f64::from(DT));
    let ground = spawn_ground(&mut app, true);
    let ball = spawn_ball(&mut app);
    // Until the first bounce.
    for _ in 0..40 {
        app.update();
    }
    let handle = collider_handle(&app, ground);
    let before = app.world().resource::<Recorded>().impacts.len();
    assert!(before > 0 && simulation(&mut app).plugin().unwrap().is_ground(handle));
    app.world_mut().entity_mut(ground).remove::<Ground>();
    let mut rose = false;
    let mut prev_vy = 0.0;
    for _ in 0..60 {
        app.update();
        let vy = ball_state(&mut app, ball).1.y;
        rose |= prev_vy < 0.0 && vy > 0.0;
        prev_vy = vy;
    }
    let after = app.world().resource::<Recorded>().impacts.len();
    println!("messages before removal {before}, after {after}; rapier bounced: {rose}");
    assert!(
        !simulation(&mut app).plugin().unwrap().is_ground(handle),
        "still a ground"
    );
    assert!(rose, "the ball did not bounce on rapier's ground");
    assert_eq!(
        after, before,
        "impact messages after the marker was removed"
    );
}

#[test]
fn all_fixed_switch_makes_unmarked_fixed_colliders_ground() {
    let mut app = app(
        plugin().with_all_fixed_colliders_ground(true),
        fixed(DT, 1),
        f64::from(DT),
    );
    let ground = spawn_ground(&mut app, false);
    spawn_ball(&mut app);
    for _ in 0..40 {
        app.update();
    }
    let handle = collider_handle(&app, ground);
    let rec = app.world().resource::<Recorded>();
    let n = rec.impacts.len();
    assert!(
        n > 0,
        "no impact on an unmarked fixed ground with the switch on"
    );
    assert!(
        rec.impacts.iter().all(|m| m.ground == ground),
        "ground entity"
    );
    // Off at run time: the collider it marked is an ordinary one again.
    settings(&mut app).all_fixed_colliders_ground = false;
    for _ in 0..60 {
        app.update();
    }
    let sim = simulation(&mut app);
    assert!(
        !sim.plugin().unwrap().is_ground(handle),
        "still a ground with the switch off"
    );
    let after = app.world().resource::<Recorded>().impacts.len();
    assert_eq!(after, n, "impact messages with the switch off");
}

#[test]
fn a_ground_on_a_dynamic_body_and_a_bad_config_are_refused_with_a_message() {
    let mut app = app(plugin(), fixed(DT, 1), f64::from(DT));
    let bad = app
        .world_mut()
        .spawn((
            Transform::from_xyz(3.0, 1.0, 0.0),
            RigidBody::Dynamic,
            Collider::ball(0.1),
            Ground,
        ))
        .id();
    app.update();
    let handle = collider_handle(&app, bad);
    let ctx = context(&mut app);
    settings(&mut app).config.flat_tolerance = -1.0;
    app.update();
    app.update();
    let rec = app.world().resource::<Recorded>();
    println!("{:?}", rec.errors);
    assert_eq!(rec.errors.len(), 2, "one message per refusal");
    assert_eq!(rec.errors[0].entity, Some(bad));
    assert_eq!(rec.errors[0].context, ctx);
    assert_eq!(rec.errors[0].error, ConfigError::DynamicGround(handle));
    assert_eq!(rec.errors[1].entity, None);
    assert!(matches!(
        rec.errors[1].error,
        ConfigError::InvalidConfig {
            field: "flat_tolerance",
            ..
        }
    ));
    let kept = simulation(&mut app)
        .plugin()
        .unwrap()
        .config()
        .flat_tolerance;
    assert_eq!(
        kept,
        ImpactConfig::default().flat_tolerance,
        "the last good config is kept"
    );
    assert_eq!(ImpactConfig::default().timing, TimingMode::Exact);
}

#[test]
fn a_body_s_own_tangential_restitution_and_curve_reach_its_impacts() {
    let mut app = app(plugin(), fixed(DT, 1), f64::from(DT));
    spawn_ground(&mut app, true);
    settings(&mut app).config.tangential_restitution = 0.5;
    let curve = RestitutionCurve::new(vec![(0.0, 0.3), (10.0, 0.7)]).unwrap();
    let ball = spawn_ball(&mut app);
    app.world_mut().entity_mut(ball).insert((
        TangentialRestitution(1.0),
        RestitutionBySpeed::from(curve.clone()),
        Velocity::linear(Vec3::new(1.0, 0.0, 0.0)),
    ));
    let first = |app: &mut App| {
        for _ in 0..120 {
            app.update();
            let rec = app.world().resource::<Recorded>();
            if let Some(m) = rec
                .impacts
                .iter()
                .find(|m| m.event.kind == EventKind::Impact)
            {
                return m.event;
            }
        }
        panic!("no impact in 2 s");
    };
    let event = first(&mut app);
    assert_eq!(event.tangential_restitution, 1.0);
    assert_eq!(event.restitution, curve.at(event.approach_speed));
    // Removed, the configuration's value applies to the next impacts; a value out of range is
    // refused with a message.
    app.world_mut()
        .entity_mut(ball)
        .remove::<(TangentialRestitution, RestitutionBySpeed)>();
    app.world_mut().resource_mut::<Recorded>().impacts.clear();
    let event = first(&mut app);
    assert_eq!(
        (event.tangential_restitution, event.restitution),
        (0.5, f64::from(E as f32))
    );
    app.world_mut()
        .entity_mut(ball)
        .insert(TangentialRestitution(2.0));
    app.update();
    let rec = app.world().resource::<Recorded>();
    assert!(
        matches!(
            rec.errors.last().map(|m| &m.error),
            Some(ConfigError::InvalidBodySetting {
                setter: "set_body_tangential_restitution",
                field: "tangential_restitution",
                ..
            })
        ),
        "{:?}",
        rec.errors
    );
}
