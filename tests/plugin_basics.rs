//! The adapter's contract with rapier, scene by scene: a wrapped user hook still sees the
//! pairs that are not managed ground contacts; bodies the plugin does not manage move
//! bitwise as in rapier alone; bad settings are refused where they are set; moving ground,
//! sloped ground and every ground shape bounce by the closed form; flat landings do not spin;
//! resting bodies rest and sleep; `Exact` mode flies a damped ball in closed form.

// Precision-generic: `Real` is f32 or f64 (feature `f64`), so conversions that are
// widening in one build are identities in the other.
#![allow(clippy::useless_conversion, clippy::unnecessary_cast)]

mod plugin_support;

use approx::assert_abs_diff_eq;
use plugin_support::*;
use rapier_impact::model::Regime;
use rapier_impact::rapier::na::Unit;
use rapier_impact::rapier::parry::utils::Array2;
use rapier_impact::rapier::prelude::*;
use rapier_impact::{
    ConfigError, EventKind, GroundMaterial, ImpactConfig, ImpactPlugin, ImpactTiming,
    RestitutionCurve, RollingSettings, TimingMode,
};

#[test]
fn wrapped_user_hook_still_sees_every_non_ground_pair() {
    let mut world = PhysicsWorld::default();
    let (_, ground) = world.insert(RigidBodyBuilder::fixed(), ColliderBuilder::halfspace(up()));
    // A platform that is not ground, and a box and a ghost ball above it, both asking for the
    // user's filter; a ball above the ground asking for it too.
    let (_, platform) = world.insert(
        RigidBodyBuilder::fixed().translation(Vector::new(5.0, 0.5, 0.0)),
        ColliderBuilder::cuboid(1.0, 0.1, 1.0),
    );
    let hooks = ActiveHooks::FILTER_CONTACT_PAIRS;
    let (boxed, box_co) = world.insert(
        RigidBodyBuilder::dynamic().translation(Vector::new(5.0, 1.0, 0.0)),
        ColliderBuilder::cuboid(0.1, 0.1, 0.1).active_hooks(hooks),
    );
    let (ghost, ghost_co) = world.insert(
        RigidBodyBuilder::dynamic().translation(Vector::new(5.5, 1.0, 0.0)),
        ColliderBuilder::ball(0.1).active_hooks(hooks),
    );
    let (_, ball_co) = world.insert(
        RigidBodyBuilder::dynamic().translation(Vector::new(0.0, 0.5, 0.0)),
        ColliderBuilder::ball(0.1)
            .restitution(0.5)
            .active_hooks(hooks),
    );
    let mut p =
        ImpactPlugin::with_hooks(ImpactConfig::default(), GhostFilter::new(ghost_co)).unwrap();
    p.add_ground(&world.bodies, &world.colliders, ground)
        .unwrap();
    let mut ground_events = 0;
    for _ in 0..90 {
        p.step(&mut world);
        ground_events += p.events().len();
    }
    let seen = &p.user_hooks().seen;
    println!("pairs the user hook saw: {}", seen.lock().unwrap().len());
    assert!(
        saw(seen, box_co, platform),
        "the user hook never saw box-platform"
    );
    assert!(
        saw(seen, ghost_co, platform),
        "the user hook never saw ghost-platform"
    );
    // The user's filter is asked about the managed pair too (it decides whether there is a
    // contact: see `tests/plugin_grounds.rs`); it accepted it, so the plugin bounced the ball.
    assert!(
        saw(seen, ball_co, ground),
        "the user's filter was not asked about a managed ground pair"
    );
    assert!(ground_events > 0, "the ball never hit the ground");
    // The user's decisions still apply: the box rests on the platform, the ghost fell through
    // (onto the ground, where the plugin caught it).
    let (by, gy) = (
        world.bodies[boxed].translation().y,
        world.bodies[ghost].translation().y,
    );
    println!("box y = {by}, ghost y = {gy}");
    assert!(by > 0.65, "box fell through the platform: y = {by}");
    assert!(
        gy < 0.4,
        "ghost did not fall through the platform: y = {gy}"
    );
}

/// The scene of the bitwise test: a managed ball bouncing on the ground, and bodies the
/// plugin does not manage (excluded, or kinematic) doing rapier things beside it.
fn unmanaged_scene(world: &mut PhysicsWorld) -> (ColliderHandle, Vec<RigidBodyHandle>) {
    let (_, ground) = world.insert(
        RigidBodyBuilder::fixed(),
        ColliderBuilder::halfspace(up()).restitution(0.7),
    );
    world.insert(
        RigidBodyBuilder::fixed().translation(Vector::new(5.0, 0.5, 0.0)),
        ColliderBuilder::cuboid(1.0, 0.1, 1.0),
    );
    world.insert(
        RigidBodyBuilder::dynamic().translation(Vector::new(0.0, 1.0, 0.0)),
        ColliderBuilder::ball(0.1).restitution(0.7),
    );
    let mut others = Vec::new();
    // A stack of two boxes landing on the (non-ground) platform.
    for k in 0..2 {
        let (b, _) = world.insert(
            RigidBodyBuilder::dynamic()
                .translation(Vector::new(5.0, 0.8 + 0.25 * k as Real, 0.0))
                .rotation(Vector::new(0.0, 0.3 * k as Real, 0.1)),
            ColliderBuilder::cuboid(0.1, 0.1, 0.1).restitution(0.3),
        );
        others.push(b);
    }
    // A ball bouncing on the ground, left to rapier.
    let (b, _) = world.insert(
        RigidBodyBuilder::dynamic().translation(Vector::new(-3.0, 1.0, 0.0)),
        ColliderBuilder::ball(0.1).restitution(0.7),
    );
    others.push(b);
    // A projectile, and a kinematic body sweeping through.
    let (b, _) = world.insert(
        RigidBodyBuilder::dynamic()
            .translation(Vector::new(-10.0, 3.0, 0.0))
            .linvel(Vector::new(4.0, 3.0, 1.0))
            .angvel(Vector::new(1.0, 2.0, 3.0)),
        ColliderBuilder::cuboid(0.2, 0.1, 0.05),
    );
    others.push(b);
    let (b, _) = world.insert(
        RigidBodyBuilder::kinematic_velocity_based()
            .translation(Vector::new(-3.0, 0.3, 3.0))
            .linvel(Vector::new(0.0, 0.0, -1.0)),
        ColliderBuilder::cuboid(0.3, 0.3, 0.3),
    );
    others.push(b);
    (ground, others)
}

fn trace(world: &PhysicsWorld, bodies: &[RigidBodyHandle]) -> Vec<[Real; 13]> {
    bodies
        .iter()
        .map(|h| {
            let rb = &world.bodies[*h];
            let (p, q, v, w) = (rb.translation(), rb.rotation(), rb.linvel(), rb.angvel());
            [
                p.x, p.y, p.z, q.x, q.y, q.z, q.w, v.x, v.y, v.z, w.x, w.y, w.z,
            ]
        })
        .collect()
}

#[test]
fn unmanaged_bodies_move_bitwise_as_in_rapier_alone() {
    for timing in MODES {
        for recycling in [false, true] {
            let mut alone = PhysicsWorld::default();
            alone.integration_parameters.contact_recycling = recycling;
            let (_, others) = unmanaged_scene(&mut alone);
            let mut with = PhysicsWorld::default();
            with.integration_parameters.contact_recycling = recycling;
            let (ground, others2) = unmanaged_scene(&mut with);
            assert_eq!(others, others2);
            let mut p = plugin_on(&with, ground, timing);
            for b in &others[..4] {
                p.exclude_body(*b);
            }
            let mut first_difference = None;
            for step in 0..180 {
                alone.step();
                p.step(&mut with);
                let (a, b) = (trace(&alone, &others), trace(&with, &others));
                if a != b && first_difference.is_none() {
                    first_difference = Some((step, a, b));
                }
            }
            if let Some((step, a, b)) = first_difference {
                let differs: Vec<usize> = (0..a.len()).filter(|i| a[*i] != b[*i]).collect();
                panic!(
                    "{timing:?}, recycling {recycling}: step {step}: bodies {differs:?} differ\nrapier: {a:?}\nplugin: {b:?}"
                );
            }
            // The plugin's flags never went on the ground: the excluded ball's pair with it
            // stayed rapier's, recycled like in rapier alone.
            assert_eq!(with.colliders[ground].active_hooks(), ActiveHooks::empty());
        }
    }
}

/// The links of a multibody are rapier's: it takes a link's velocity from the multibody's own
/// generalized velocities, so a velocity written to the link's body is dropped. A dumbbell of
/// two balls on a multibody fixed joint, dropped level on the ground, in every mode: alone in
/// the world, it moves bitwise as in rapier alone; beside a managed ball bouncing 3 m away,
/// no event is ever about its links (the plugin bounced them in place every step once they
/// landed, 322 impacts in 3 s, their energy growing 51-fold). Beside that ball rapier's
/// solver orders the dumbbell's contacts differently (the ball's ground pair leaves it), and
/// the two runs part at the last bits after about 100 steps.
#[test]
fn the_links_of_a_multibody_are_left_to_rapier() {
    let scene = |world: &mut PhysicsWorld, with_ball: bool| {
        let (_, ground) = world.insert(
            RigidBodyBuilder::fixed(),
            ColliderBuilder::halfspace(up()).restitution(0.8),
        );
        let link = |world: &mut PhysicsWorld, x: Real| {
            let (b, _) = world.insert(
                RigidBodyBuilder::dynamic().translation(Vector::new(x, 0.55, 3.0)),
                ColliderBuilder::ball(0.05).restitution(0.8),
            );
            b
        };
        let links = [link(world, -0.15), link(world, 0.15)];
        let joint = FixedJointBuilder::new()
            .local_anchor1(Vector::new(0.15, 0.0, 0.0))
            .local_anchor2(Vector::new(-0.15, 0.0, 0.0));
        world
            .insert_multibody_joint(links[0], links[1], joint)
            .unwrap();
        if with_ball {
            world.insert(
                RigidBodyBuilder::dynamic().translation(Vector::new(0.0, 1.0, 0.0)),
                ColliderBuilder::ball(0.1).restitution(0.7),
            );
        }
        (ground, links)
    };
    for timing in MODES {
        for with_ball in [false, true] {
            let mut alone = PhysicsWorld::default();
            scene(&mut alone, with_ball);
            let mut with = PhysicsWorld::default();
            let (ground, links) = scene(&mut with, with_ball);
            let mut p = plugin_on(&with, ground, timing);
            let (mut events, mut ball_events) = (0, 0);
            for step in 0..180 {
                alone.step();
                p.step(&mut with);
                events += p
                    .events()
                    .iter()
                    .filter(|e| links.contains(&e.body))
                    .count();
                ball_events += p.events().len();
                if !with_ball {
                    assert_eq!(
                        trace(&alone, &links),
                        trace(&with, &links),
                        "{timing:?}, step {step}"
                    );
                }
            }
            assert_eq!(events, 0, "{timing:?}, beside a ball {with_ball}");
            // The managed ball bounced: the plugin was at work beside the links.
            assert_eq!(ball_events > 0, with_ball, "{timing:?}");
        }
    }
}

/// Where the plugin's hook flags go: on the grounds while every dynamic body is managed; on
/// the managed bodies near a ground (only) while some dynamic body is not; the user's own
/// flags survive both, and `detach` takes the plugin's off.
#[test]
fn hook_flags_follow_the_bodies_near_a_ground() {
    let mut world = PhysicsWorld::default();
    let (_, ground) = world.insert(
        RigidBodyBuilder::fixed(),
        ColliderBuilder::halfspace(up())
            .restitution(0.7)
            .active_hooks(ActiveHooks::MODIFY_SOLVER_CONTACTS),
    );
    // One ball starts 1 mm above the ground; one starts far up and stays far for the
    // first steps; a third, also near, has flags of the user's own.
    let (_, low) = world.insert(
        RigidBodyBuilder::dynamic().translation(Vector::new(0.0, 0.101, 0.0)),
        ColliderBuilder::ball(0.1).restitution(0.7),
    );
    let (_, high) = world.insert(
        RigidBodyBuilder::dynamic().translation(Vector::new(2.0, 50.0, 0.0)),
        ColliderBuilder::ball(0.1),
    );
    let (_, own) = world.insert(
        RigidBodyBuilder::dynamic().translation(Vector::new(-2.0, 0.101, 0.0)),
        ColliderBuilder::ball(0.1).active_hooks(ActiveHooks::FILTER_CONTACT_PAIRS),
    );
    let mut p = plugin_on(&world, ground, TimingMode::Exact);
    let both = ActiveHooks::FILTER_CONTACT_PAIRS | ActiveHooks::MODIFY_SOLVER_CONTACTS;
    let none = ActiveHooks::empty();
    let flags = |w: &PhysicsWorld, c: ColliderHandle| w.colliders[c].active_hooks();
    // Every dynamic body managed: the ground carries the flags, the bodies their own.
    p.step(&mut world);
    assert_eq!(flags(&world, ground), both);
    assert_eq!(flags(&world, low), none);
    assert_eq!(flags(&world, own), ActiveHooks::FILTER_CONTACT_PAIRS);
    assert_eq!(flags(&world, high), none);
    // The user changes the ground's flags between steps: the plugin adds its own to the new
    // ones (and hands the new ones back below).
    world.colliders[ground].set_active_hooks(ActiveHooks::FILTER_CONTACT_PAIRS);
    p.step(&mut world);
    assert_eq!(flags(&world, ground), both);
    // One excluded: the ground gets the user's flags back, the managed bodies near it
    // carry the plugin's, the far one and the excluded one none.
    let low_body = world.colliders[low].parent().unwrap();
    p.exclude_body(low_body);
    p.step(&mut world);
    assert_eq!(flags(&world, ground), ActiveHooks::FILTER_CONTACT_PAIRS);
    assert_eq!(flags(&world, low), none);
    assert_eq!(flags(&world, own), both);
    assert_eq!(flags(&world, high), none);
    // The user changes their flags between steps: the plugin adds its own to the new ones
    // and hands the new ones back.
    world.colliders[own].set_active_hooks(ActiveHooks::empty());
    p.step(&mut world);
    assert_eq!(flags(&world, own), both);
    let own_body = world.colliders[own].parent().unwrap();
    p.exclude_body(own_body);
    p.step(&mut world);
    assert_eq!(flags(&world, own), none);
    // All managed again: back on the ground.
    p.include_body(low_body);
    p.include_body(own_body);
    p.step(&mut world);
    assert_eq!(flags(&world, ground), both);
    assert_eq!(flags(&world, low), none);
    assert_eq!(flags(&world, own), none);
    // `detach` hands the wrapped hook back (here `()`).
    let _hooks: () = p.detach(&mut world.colliders);
    assert_eq!(flags(&world, ground), ActiveHooks::FILTER_CONTACT_PAIRS);
    assert_eq!(flags(&world, low), none);
    assert_eq!(flags(&world, own), none);
}

/// While every managed body is far from every ground and none sleeps, the grounds need no
/// hook flags: they keep the user's (rapier then calls no hook for their pairs) until a body
/// nears a ground, in time for its impact, which is the closed form's; then 30 steps after the
/// last body left. A sleeping body keeps them on.
#[test]
fn grounds_carry_no_flags_while_every_body_is_far_and_awake() {
    let mut world = PhysicsWorld::default();
    let user = ActiveHooks::MODIFY_SOLVER_CONTACTS;
    let (_, ground) = world.insert(
        RigidBodyBuilder::fixed(),
        ColliderBuilder::halfspace(up())
            .restitution(0.7)
            .friction(0.0)
            .active_hooks(user),
    );
    // Thrown up from 10 m: about two seconds before it comes back down.
    let (_, ball) = world.insert(
        RigidBodyBuilder::dynamic()
            .translation(Vector::new(0.0, 10.0, 0.0))
            .linvel(Vector::new(0.0, 5.0, 0.0)),
        ColliderBuilder::ball(0.1).restitution(0.7).friction(0.0),
    );
    let mut p = plugin_on(&world, ground, TimingMode::Exact);
    let both = ActiveHooks::FILTER_CONTACT_PAIRS | ActiveHooks::MODIFY_SOLVER_CONTACTS;
    let flags = |w: &PhysicsWorld| w.colliders[ground].active_hooks();
    for n in 1..=40 {
        p.step(&mut world);
        assert_eq!(flags(&world), user, "step {n}");
    }
    let mut bounce = None;
    for _ in 0..200 {
        p.step(&mut world);
        if let Some(e) = p.events().iter().find(|e| e.kind == EventKind::Impact) {
            assert_eq!(flags(&world), both, "flagged again for the impact");
            bounce = Some(*e);
            break;
        }
    }
    let e = bounce.expect("the ball came back down and bounced");
    assert_eq!(e.collider, ball);
    // A straight drop without spin or friction: it leaves at e times its approach speed.
    assert!(e.approach_speed > 10.0, "{e:?}");
    assert_abs_diff_eq!(e.restitution, 0.7, epsilon = 1e-7);
    assert_abs_diff_eq!(
        (e.ke_after / e.ke_before).sqrt(),
        e.restitution,
        epsilon = 1e-9
    );
    // Rising again, far from the ground after a step or two: on for 30 steps more, then off.
    let mut on_for = 0;
    while flags(&world) == both && on_for < 100 {
        p.step(&mut world);
        on_for += 1;
    }
    assert!((31..=40).contains(&on_for), "{on_for}");
    assert_eq!(flags(&world), user);

    // The same flight beside a sleeping ball: the flags stay on.
    let mut world = PhysicsWorld::default();
    let (_, ground) = world.insert(
        RigidBodyBuilder::fixed(),
        ColliderBuilder::halfspace(up()).restitution(0.7),
    );
    world.insert(
        RigidBodyBuilder::dynamic()
            .translation(Vector::new(0.0, 10.0, 0.0))
            .linvel(Vector::new(0.0, 5.0, 0.0)),
        ColliderBuilder::ball(0.1).restitution(0.7),
    );
    world.insert(
        RigidBodyBuilder::dynamic()
            .translation(Vector::new(5.0, 0.1, 0.0))
            .sleeping(true),
        ColliderBuilder::ball(0.1).restitution(0.7),
    );
    let mut p = plugin_on(&world, ground, TimingMode::Exact);
    for n in 1..=40 {
        p.step(&mut world);
        assert_eq!(world.colliders[ground].active_hooks(), both, "step {n}");
    }
}

#[test]
fn invalid_settings_are_refused_where_they_are_set() {
    let bad = |config: ImpactConfig| ImpactPlugin::new(config).err();
    assert!(matches!(
        bad(ImpactConfig::default().with_resting_speed(Some(-1.0))),
        Some(ConfigError::InvalidConfig {
            field: "resting_speed",
            ..
        })
    ));
    assert!(matches!(
        bad(ImpactConfig::default().with_flat_tolerance(f64::NAN)),
        Some(ConfigError::InvalidConfig {
            field: "flat_tolerance",
            ..
        })
    ));
    assert!(matches!(
        bad(ImpactConfig::default().with_max_impacts_per_step(0)),
        Some(ConfigError::InvalidConfig { .. })
    ));
    assert!(matches!(
        bad(ImpactConfig::default().with_resting_gap(Some(f64::INFINITY))),
        Some(ConfigError::InvalidConfig { .. })
    ));
    let mut p = plugin(TimingMode::Exact);
    assert!(
        p.set_config(ImpactConfig::default().with_resting_speed(Some(f64::NAN)))
            .is_err()
    );
    assert_eq!(p.config(), &ImpactConfig::default());

    let mut world = PhysicsWorld::default();
    let (_, ground) = world.insert(RigidBodyBuilder::fixed(), ColliderBuilder::halfspace(up()));
    let (_, dyn_co) = world.insert(RigidBodyBuilder::dynamic(), ColliderBuilder::ball(0.1));
    let empty = world.insert_body(RigidBodyBuilder::fixed());
    let (gone_body, gone) = world.insert(RigidBodyBuilder::fixed(), ColliderBuilder::ball(1.0));
    world.remove_body(gone_body);

    let material = GroundMaterial::new;
    // Refused by the model, the message says the coefficient's range too.
    for (bad, range) in [
        (material(-0.1, 0.5), "restitution takes [0, 10]"),
        (material(0.5, f64::NAN), "friction takes [0, 100]"),
    ] {
        let e = p
            .add_ground_with_material(&world.bodies, &world.colliders, ground, bad)
            .unwrap_err();
        assert!(matches!(e, ConfigError::Material(_)));
        assert!(
            e.to_string()
                .ends_with(&format!("; GroundMaterial::{range}")),
            "{e}"
        );
    }
    assert!(
        !p.is_ground(ground),
        "a refused ground must not be registered"
    );
    assert_eq!(
        p.add_ground(&world.bodies, &world.colliders, gone),
        Err(ConfigError::NotACollider(gone))
    );
    assert_eq!(
        p.add_ground_body(&world.bodies, &world.colliders, empty),
        Err(ConfigError::GroundWithoutCollider(empty))
    );
    assert_eq!(
        p.add_ground_body(&world.bodies, &world.colliders, gone_body),
        Err(ConfigError::NotABody(gone_body))
    );
    assert_eq!(
        p.add_ground(&world.bodies, &world.colliders, dyn_co),
        Err(ConfigError::DynamicGround(dyn_co))
    );
    assert_eq!(
        p.set_ground_material(ground, Some(material(0.5, 0.5))),
        Err(ConfigError::NotAGround(ground))
    );
    p.add_ground(&world.bodies, &world.colliders, ground)
        .unwrap();
    assert!(
        p.set_ground_material(ground, Some(material(0.5, -1.0)))
            .is_err()
    );
    assert!(
        p.set_ground_material(ground, Some(material(0.5, 0.2)))
            .is_ok()
    );
    // Every error displays a message naming the problem.
    for e in [
        ConfigError::NotACollider(gone),
        ConfigError::GroundWithoutCollider(empty),
        ConfigError::DynamicGround(dyn_co),
    ] {
        assert!(!e.to_string().is_empty());
    }
}

/// Velocity of the ball right after the impact of `event`, from its state at the end of
/// the step (exact flight after the impact).
fn velocity_after(world: &PhysicsWorld, ball: RigidBodyHandle, time: f64, dt: f64) -> [f64; 3] {
    let v = world.bodies[ball].linvel();
    let rest = dt - time;
    [f64::from(v.x), f64::from(v.y) + G * rest, f64::from(v.z)]
}

#[test]
fn a_rising_kinematic_platform_enters_the_model() {
    // Platform top at y = 0 at t = 0, rising at V; ball bottom 0.5 m above, at rest.
    let (v_up, e, h) = (1.0, 0.6, 0.5);
    let mut world = PhysicsWorld::default();
    let (_, ground) = world.insert(
        RigidBodyBuilder::kinematic_velocity_based()
            .translation(Vector::new(0.0, -0.5, 0.0))
            .linvel(Vector::new(0.0, v_up as Real, 0.0)),
        ColliderBuilder::cuboid(2.0, 0.5, 2.0).friction(0.0),
    );
    let (ball, _) = world.insert(
        RigidBodyBuilder::dynamic().translation(Vector::new(0.0, (0.1 + h) as Real, 0.0)),
        ColliderBuilder::ball(0.1).friction(0.0),
    );
    let mut p = plugin_with_material(&world, ground, TimingMode::Exact, e, 0.0);
    let dt = f64::from(world.integration_parameters.dt);
    // Contact when h - g t^2 / 2 = V t.
    let t_hit = (-v_up + (v_up * v_up + 2.0 * G * h).sqrt()) / G;
    let v_ball = -G * t_hit;
    let expected = v_up - e * (v_ball - v_up);
    for k in 0..120 {
        p.step(&mut world);
        if let Some(ev) = p.events().first() {
            let t = k as f64 * dt + ev.time;
            let v = velocity_after(&world, ball, ev.time, dt);
            println!(
                "impact at {t:.7} s (expected {t_hit:.7}), ball vy after {:.6} (expected {expected:.6}), approach {:.6} (expected {:.6})",
                v[1],
                ev.approach_speed,
                v_up - v_ball
            );
            let tol = if F64 { 1e-9 } else { 2e-5 };
            assert_abs_diff_eq!(t, t_hit, epsilon = tol);
            assert_abs_diff_eq!(v[1], expected, epsilon = 10.0 * tol);
            assert_abs_diff_eq!(ev.approach_speed, v_up - v_ball, epsilon = 10.0 * tol);
            return;
        }
    }
    panic!("the ball never met the platform");
}

/// Drops a frictionless ball vertically onto a plane through the origin with unit normal
/// `n` (a half-space, or a cuboid's top face), and checks `v' = v - (1 + e)(v.n) n` at the
/// impact time.
fn check_slope(ground_collider: ColliderBuilder, n: [f64; 3], label: &str) {
    let (e, h) = (0.7, 1.0);
    let mut world = PhysicsWorld::default();
    let (_, ground) = world.insert(RigidBodyBuilder::fixed(), ground_collider);
    let (ball, _) = world.insert(
        RigidBodyBuilder::dynamic().translation(Vector::new(0.0, h as Real, 0.0)),
        ColliderBuilder::ball(0.1),
    );
    let mut p = plugin_with_material(&world, ground, TimingMode::Exact, e, 0.0);
    let dt = f64::from(world.integration_parameters.dt);
    // Centre at (0, y, 0) touches when n_y y = R.
    let t_hit = (2.0 * (h - 0.1 / n[1]) / G).sqrt();
    let v = [0.0, -G * t_hit, 0.0];
    let vn = v[1] * n[1];
    let expected = [
        v[0] - (1.0 + e) * vn * n[0],
        v[1] - (1.0 + e) * vn * n[1],
        v[2] - (1.0 + e) * vn * n[2],
    ];
    for k in 0..120 {
        p.step(&mut world);
        if let Some(ev) = p.events().first() {
            let t = k as f64 * dt + ev.time;
            let after = velocity_after(&world, ball, ev.time, dt);
            let err = (0..3)
                .map(|i| (after[i] - expected[i]).abs())
                .fold(0.0, f64::max);
            println!(
                "{label}: impact {t:.7} s (expected {t_hit:.7}), v' = {after:.6?} (expected {expected:.6?}), normal {:?}",
                ev.normal
            );
            let tol = if F64 { 1e-8 } else { 2e-5 };
            assert_abs_diff_eq!(t, t_hit, epsilon = tol);
            assert!(err < 10.0 * tol, "{label}: v' {after:?} vs {expected:?}");
            return;
        }
    }
    panic!("{label}: the ball never hit");
}

#[test]
fn sloped_ground_reflects_by_its_normal() {
    let angle: f64 = 30f64.to_radians();
    let n = [-angle.sin(), angle.cos(), 0.0];
    check_slope(
        ColliderBuilder::halfspace(Unit::new_unchecked(
            Vector::new(n[0] as Real, n[1] as Real, 0.0).normalize(),
        )),
        n,
        "half-space at 30 deg",
    );
    // A cuboid whose top face passes through the origin, tilted by 30 degrees about z.
    let half = 0.5;
    check_slope(
        ColliderBuilder::cuboid(5.0, half as Real, 5.0)
            .rotation(Vector::new(0.0, 0.0, angle as Real))
            .translation(Vector::new(
                (-n[0] * half) as Real,
                (-n[1] * half) as Real,
                0.0,
            )),
        n,
        "cuboid at 30 deg",
    );
}

fn ground_shapes() -> Vec<(&'static str, ColliderBuilder)> {
    let flat_heights = Array2::new(5, 5, vec![Real::default(); 25]);
    let vertices = vec![
        Vector::new(-5.0, 0.0, -5.0),
        Vector::new(5.0, 0.0, -5.0),
        Vector::new(5.0, 0.0, 5.0),
        Vector::new(-5.0, 0.0, 5.0),
    ];
    vec![
        ("half-space", ColliderBuilder::halfspace(up())),
        (
            "cuboid",
            ColliderBuilder::cuboid(5.0, 0.5, 5.0).translation(Vector::new(0.0, -0.5, 0.0)),
        ),
        (
            "heightfield",
            ColliderBuilder::heightfield(flat_heights, Vector::new(10.0, 1.0, 10.0)),
        ),
        (
            "trimesh",
            ColliderBuilder::trimesh(vertices, vec![[0, 2, 1], [0, 3, 2]]).unwrap(),
        ),
    ]
}

#[test]
fn every_ground_shape_bounces_by_the_closed_form() {
    let (e, h0) = (0.8, 1.0);
    for (label, shape) in ground_shapes() {
        let mut world = PhysicsWorld::default();
        let (_, ground) = world.insert(RigidBodyBuilder::fixed(), shape.restitution(e as Real));
        let (ball, _) = world.insert(
            RigidBodyBuilder::dynamic().translation(Vector::new(0.3, (0.1 + h0) as Real, 0.2)),
            ColliderBuilder::ball(0.1).restitution(e as Real),
        );
        let mut p = plugin_on(&world, ground, TimingMode::Exact);
        let dt = f64::from(world.integration_parameters.dt);
        let mut impacts = Vec::new();
        let mut apex: f64 = 0.0;
        for k in 0..90 {
            p.step(&mut world);
            impacts.extend(p.events().iter().map(|ev| k as f64 * dt + ev.time));
            let rb = &world.bodies[ball];
            let (y, vy) = (f64::from(rb.translation().y), f64::from(rb.linvel().y));
            if !impacts.is_empty() && vy > 0.0 {
                apex = apex.max(y - 0.1 + vy * vy / (2.0 * G));
            }
        }
        let t1 = (2.0 * h0 / G).sqrt();
        let apex_err = apex / (e * e * h0) - 1.0;
        println!(
            "{label}: impact {:.7} s (expected {t1:.7}), apex {apex:.7} (expected {:.7}, {apex_err:+.2e})",
            impacts[0],
            e * e * h0
        );
        let tol = if F64 { 1e-9 } else { 1e-5 };
        assert_abs_diff_eq!(impacts[0], t1, epsilon = tol);
        assert_abs_diff_eq!(apex_err, 0.0, epsilon = tol);
    }
}

#[test]
fn a_box_landing_flat_does_not_spin() {
    for (label, shape) in ground_shapes() {
        let mut world = PhysicsWorld::default();
        let (_, ground) = world.insert(
            RigidBodyBuilder::fixed(),
            shape.restitution(0.5).friction(0.6),
        );
        let (cube, _) = world.insert(
            RigidBodyBuilder::dynamic().translation(Vector::new(0.3, 1.2, -0.4)),
            ColliderBuilder::cuboid(0.2, 0.2, 0.2)
                .restitution(0.5)
                .friction(0.6),
        );
        let mut p = plugin_on(&world, ground, TimingMode::Exact);
        let mut first = None;
        for _ in 0..60 {
            p.step(&mut world);
            if first.is_none() {
                first = p.events().first().copied();
            }
        }
        let ev = first.unwrap_or_else(|| panic!("{label}: the cube never landed"));
        let w = world.bodies[cube].angvel().length();
        println!(
            "{label}: {} contact points, impulse {:?}, spin after {w:.3e} rad/s",
            ev.contact_points, ev.impulse
        );
        assert_eq!(
            ev.contact_points, 4,
            "{label}: flat landing resolved at one corner"
        );
        assert_eq!(ev.timing, ImpactTiming::InStep);
        assert!(
            w < 1e-4,
            "{label}: the cube spins after a flat landing: {w} rad/s"
        );
    }
}

#[test]
fn a_box_on_an_edge_or_a_corner_lands_there() {
    // Edge: rotated 45 degrees about z. Corner: rotated so that a diagonal points down.
    let edge = Vector::new(0.0, 0.0, std::f64::consts::FRAC_PI_4 as Real);
    let corner_axis = Vector::new(1.0, 0.0, -1.0).normalize();
    let corner = corner_axis * (1.0 / 2f64.sqrt()).atan() as Real;
    for (label, rotation, points) in [("edge", edge, 2), ("corner", corner, 1)] {
        let mut world = PhysicsWorld::default();
        let (_, ground) = world.insert(RigidBodyBuilder::fixed(), ColliderBuilder::halfspace(up()));
        world.insert(
            RigidBodyBuilder::dynamic()
                .translation(Vector::new(0.0, 1.0, 0.0))
                .rotation(rotation),
            ColliderBuilder::cuboid(0.2, 0.2, 0.2).restitution(0.5),
        );
        let mut p = plugin_on(&world, ground, TimingMode::Exact);
        let mut first = None;
        for _ in 0..60 {
            p.step(&mut world);
            if first.is_none() {
                first = p.events().first().copied();
            }
        }
        let ev = first.unwrap();
        println!(
            "{label}: {} points at {:?}, regime {:?}, KE {:.4} -> {:.4}",
            ev.contact_points, ev.point, ev.regime, ev.ke_before, ev.ke_after
        );
        assert_eq!(ev.contact_points, points, "{label}");
        assert!(ev.ke_after <= ev.ke_before, "{label}: energy gained");
        assert!(ev.normal_impulse > 0.0);
        assert_ne!(ev.regime, Regime::Separating);
    }
}

/// A scene with a ball or a box landing slowly on the ground, stepped with or without the
/// plugin; returns the body's trace of (y, vy, vx) and whether it sleeps at the end, and the
/// number of impacts the plugin resolved.
fn settle(
    with_plugin: bool,
    body: ColliderBuilder,
    start: Vector,
    vx: Real,
    steps: usize,
) -> (Vec<(Real, Real, Real)>, bool, usize) {
    let mut world = PhysicsWorld::default();
    let (_, ground) = world.insert(
        RigidBodyBuilder::fixed(),
        ColliderBuilder::halfspace(up())
            .restitution(0.5)
            .friction(0.5),
    );
    let (h, _) = world.insert(
        RigidBodyBuilder::dynamic()
            .translation(start)
            .linvel(Vector::new(vx, 0.0, 0.0)),
        body.restitution(0.5).friction(0.5),
    );
    let mut p = plugin_on(&world, ground, TimingMode::Exact);
    let mut out = Vec::new();
    let mut impacts = 0;
    for _ in 0..steps {
        if with_plugin {
            p.step(&mut world);
            impacts += p.events().len();
        } else {
            world.step();
        }
        let rb = &world.bodies[h];
        out.push((rb.translation().y, rb.linvel().y, rb.linvel().x));
    }
    (out, world.bodies[h].is_sleeping(), impacts)
}

#[test]
fn slow_landings_rest_and_sleep_like_rapier_bodies_without_sinking() {
    let ball = || ColliderBuilder::ball(0.1);
    let cube = || ColliderBuilder::cuboid(0.1, 0.1, 0.1);
    let start_ball = Vector::new(0.0, 0.13, 0.0);
    let start_cube = Vector::new(0.0, 0.13, 0.0);
    for (label, body, start, vx) in [
        ("ball dropped 3 cm", ball(), start_ball, 0.0),
        ("cube dropped 3 cm", cube(), start_cube, 0.0),
        ("cube sliding at 1 m/s", cube(), start_cube, 1.0),
    ] {
        let (with, sleeps, impacts) = settle(true, body.clone(), start, vx, 600);
        let (alone, alone_sleeps, _) = settle(false, body, start, vx, 600);
        let rest = |t: &[(Real, Real, Real)]| t.last().unwrap().0;
        let lowest = with.iter().map(|s| s.0).fold(Real::MAX, Real::min);
        let tail = &with[with.len() - 60..];
        let spread = tail.iter().map(|s| s.0).fold(Real::MIN, Real::max)
            - tail.iter().map(|s| s.0).fold(Real::MAX, Real::min);
        println!(
            "{label}: impacts {impacts}, rest height {} (rapier alone {}), lowest {lowest}, last-second spread {spread:e}, sleeps {sleeps} (rapier alone {alone_sleeps})",
            rest(&with),
            rest(&alone)
        );
        assert!(impacts < 10, "{label}: micro-bounces, {impacts} impacts");
        assert!(
            lowest >= rest(&alone) - 1e-4,
            "{label}: sank to {lowest}, rapier rests at {}",
            rest(&alone)
        );
        assert!(spread < 1e-5, "{label}: jitters by {spread} m at rest");
        assert!(
            sleeps,
            "{label}: not asleep after 10 s (rapier alone: {alone_sleeps})"
        );
    }
}

#[test]
fn a_rolling_ball_rolls_at_the_model_speed_without_jitter() {
    // Landing with 1 m/s sideways and sticking: vx' = vx / (1 + 2/5) (docs/model.md, "Closed forms used in the tests"), then
    // rolling in rapier's resting contact (rapier has no rolling resistance: it rolls on).
    let (with, _, impacts) = settle(
        true,
        ColliderBuilder::ball(0.1),
        Vector::new(0.0, 0.15, 0.0),
        1.0,
        600,
    );
    let (alone, _, _) = settle(
        false,
        ColliderBuilder::ball(0.1),
        Vector::new(0.0, 0.15, 0.0),
        1.0,
        600,
    );
    let tail = &with[with.len() - 120..];
    let spread = tail.iter().map(|s| s.0).fold(Real::MIN, Real::max)
        - tail.iter().map(|s| s.0).fold(Real::MAX, Real::min);
    let vx = f64::from(with.last().unwrap().2);
    println!(
        "rolling: impacts {impacts}, vx {vx:.6} (model {:.6}, rapier alone {}), height spread {spread:e}",
        1.0 / 1.4,
        alone.last().unwrap().2
    );
    assert!(impacts < 10, "micro-bounces: {impacts} impacts");
    assert_abs_diff_eq!(vx, 1.0 / 1.4, epsilon = 1e-3);
    assert!(spread < 1e-5, "rolling ball jitters by {spread} m");
}

#[test]
fn a_falling_rod_gets_the_closed_form_impulse_and_spin() {
    // docs/model.md, "Closed forms used in the tests": rod of length L at angle phi, falling at v, frictionless:
    // J = (1 + e) v m / (1 + 3 cos^2 phi), w' = 6 (1 + e) v cos phi / (L (1 + 3 cos^2 phi)).
    // A thin cuboid (cross-section 2 mm) lands on its lower end's edge: two simultaneous
    // points, whose centroid is the rod's end.
    let (len, a, e, h) = (1.0f64, 1e-3f64, 0.5, 0.5);
    for phi_deg in [20.0f64, 45.0, 70.0] {
        let phi = phi_deg.to_radians();
        let mut world = PhysicsWorld::default();
        let (_, ground) = world.insert(RigidBodyBuilder::fixed(), ColliderBuilder::halfspace(up()));
        // The lower end (x = -L/2 cos phi) starts h above the ground.
        let y0 = h + 0.5 * len * phi.sin() + a * phi.cos();
        let (rod, _) = world.insert(
            RigidBodyBuilder::dynamic()
                .translation(Vector::new(0.0, y0 as Real, 0.0))
                .rotation(Vector::new(0.0, 0.0, phi as Real)),
            ColliderBuilder::cuboid((0.5 * len) as Real, a as Real, a as Real),
        );
        let mut p = plugin_with_material(&world, ground, TimingMode::Exact, e, 0.0);
        let mass = f64::from(world.bodies[rod].mass());
        let mut event = None;
        for _ in 0..60 {
            p.step(&mut world);
            if let Some(ev) = p.events().first() {
                event = Some(*ev);
                break;
            }
        }
        let ev = event.expect("the rod never landed");
        let v = (2.0 * G * h).sqrt();
        let c = phi.cos();
        let j = (1.0 + e) * v * mass / (1.0 + 3.0 * c * c);
        let w = 6.0 * (1.0 + e) * v * c / (len * (1.0 + 3.0 * c * c));
        let w_after = -f64::from(world.bodies[rod].angvel().z);
        // The same law for the 2 mm thick cuboid: contact at the lower edge, lever arm
        // r = L/2 cos phi - a sin phi, I = m (L^2 + 4 a^2)/12.
        let r = 0.5 * len * c - a * phi.sin();
        let inertia = mass * (len * len + 4.0 * a * a) / 12.0;
        let j_box = (1.0 + e) * v / (1.0 / mass + r * r / inertia);
        let w_box = j_box * r / inertia;
        println!(
            "rod at {phi_deg} deg: {} points, J/m = {:.6} (line rod {:.6}, thick rod {:.6}), w' = {w_after:.5} (line rod {w:.5}, thick rod {w_box:.5})",
            ev.contact_points,
            ev.normal_impulse / mass,
            j / mass,
            j_box / mass
        );
        assert_eq!(ev.contact_points, 2, "rod end edge");
        let tol = if F64 { 1e-9 } else { 2e-5 };
        let j_err = ev.normal_impulse / j_box - 1.0;
        assert_abs_diff_eq!(j_err, 0.0, epsilon = tol);
        assert_abs_diff_eq!(w_after / w_box, 1.0, epsilon = tol);
        // The line-rod closed form holds to the thickness effect, ~ 2 a tan(phi) / L.
        let thickness = 4.0 * a * phi.tan() / len;
        assert_abs_diff_eq!(ev.normal_impulse / j, 1.0, epsilon = thickness + tol);
    }
}

#[test]
fn a_cube_corner_landing_is_the_models_single_point_impact() {
    use rapier_impact::model::{Body, BodyVelocity, Contact, Law, Material, resolve};
    use rapier_impact::na::Vector3;
    let (e, mu, h, side) = (0.6, 0.5, 0.4, 0.4);
    let mut world = PhysicsWorld::default();
    let (_, ground) = world.insert(RigidBodyBuilder::fixed(), ColliderBuilder::halfspace(up()));
    let (cube, _) = world.insert(
        RigidBodyBuilder::dynamic()
            .translation(Vector::new(0.0, (h + side) as Real, 0.0))
            .rotation(Vector::new(0.35, 0.2, 0.5)),
        ColliderBuilder::cuboid(
            (side / 2.0) as Real,
            (side / 2.0) as Real,
            (side / 2.0) as Real,
        ),
    );
    let mut p = plugin_with_material(&world, ground, TimingMode::Exact, e, mu);
    let dt = f64::from(world.integration_parameters.dt);
    let mass = f64::from(world.bodies[cube].mass());
    let start = world.bodies[cube].translation();
    for k in 0..60 {
        p.step(&mut world);
        if let Some(ev) = p.events().first().copied() {
            // Free fall without rotation until the impact.
            let t = k as f64 * dt + ev.time;
            let com = Vector3::new(
                f64::from(start.x),
                f64::from(start.y) - 0.5 * G * t * t,
                f64::from(start.z),
            );
            let point = na(ev.point);
            let body = Body::isotropic(mass, mass * side * side / 6.0);
            let velocity = BodyVelocity {
                linear: Vector3::new(0.0, -G * t, 0.0),
                angular: Vector3::zeros(),
            };
            let contact = Contact::fixed(Vector3::y(), point - com);
            let material = Material::new(e, mu);
            let model = resolve(Law::Guarded, &body, &velocity, &contact, &material).unwrap();
            let got = na(ev.impulse);
            let err = (got - model.impulse).norm() / model.impulse.norm();
            println!(
                "corner: {} point, impulse {got:?}, model {:?}, relative difference {err:.2e}, regime {:?}",
                ev.contact_points, model.impulse, ev.regime
            );
            assert_eq!(ev.contact_points, 1);
            assert_eq!(ev.regime, model.regime);
            let tol = if F64 { 1e-9 } else { 1e-4 };
            assert!(
                err < tol,
                "corner impulse differs from the model by {err:e}"
            );
            return;
        }
    }
    panic!("the cube never landed");
}

#[test]
fn a_fast_ball_neither_tunnels_nor_bounces_twice() {
    // 40 m/s onto a 2 cm thick slab: 0.67 m per step at 60 Hz, far more than the slab.
    let (e, v0) = (0.5, 40.0);
    for timing in MODES {
        for bullet in [false, true] {
            let mut world = PhysicsWorld::default();
            let (_, ground) = world.insert(
                RigidBodyBuilder::fixed(),
                ColliderBuilder::cuboid(5.0, 0.01, 5.0).translation(Vector::new(0.0, -0.01, 0.0)),
            );
            let (ball, _) = world.insert(
                RigidBodyBuilder::dynamic()
                    .translation(Vector::new(0.0, 1.0, 0.0))
                    .linvel(Vector::new(0.0, -v0 as Real, 0.0))
                    .ccd_enabled(bullet),
                ColliderBuilder::ball(0.05),
            );
            let mut p = plugin_with_material(&world, ground, timing, e, 0.0);
            let mut impacts = Vec::new();
            let mut lowest = Real::MAX;
            for k in 0..12 {
                p.step(&mut world);
                impacts.extend(p.events().iter().map(|ev| (k, ev.approach_speed)));
                lowest = lowest.min(world.bodies[ball].translation().y);
            }
            let vy = f64::from(world.bodies[ball].linvel().y);
            println!(
                "{timing:?}, ccd_enabled {bullet}: impacts {impacts:?}, lowest centre {lowest}, vy after {vy:.4}"
            );
            assert!(lowest > 0.0, "{timing:?}: tunnelled to {lowest}");
            assert_eq!(impacts.len(), 1, "{timing:?}: {impacts:?}");
            // One bounce at e v (v ~ 40.1 m/s at the impact), rapier adding nothing:
            // after it, only gravity acts.
            let up = vy + G * 11.0 / 60.0;
            assert_abs_diff_eq!(up, e * impacts[0].1, epsilon = 0.2);
        }
    }
}

#[test]
fn a_fast_body_stopped_by_a_non_ground_wall_is_not_pulled_through_it() {
    // Exact mode re-integrates free flight; a body rapier's CCD stopped at a wall that is
    // not ground must keep rapier's result.
    let mut world = PhysicsWorld::default();
    let (_, ground) = world.insert(RigidBodyBuilder::fixed(), ColliderBuilder::halfspace(up()));
    world.insert(
        RigidBodyBuilder::fixed().translation(Vector::new(3.0, 1.0, 0.0)),
        ColliderBuilder::cuboid(0.01, 1.0, 1.0),
    );
    let (ball, _) = world.insert(
        RigidBodyBuilder::dynamic()
            .translation(Vector::new(0.0, 1.0, 0.0))
            .linvel(Vector::new(60.0, 0.0, 0.0)),
        ColliderBuilder::ball(0.05),
    );
    let mut p = plugin_on(&world, ground, TimingMode::Exact);
    let mut furthest = Real::MIN;
    for _ in 0..10 {
        p.step(&mut world);
        furthest = furthest.max(world.bodies[ball].translation().x);
    }
    println!("furthest x {furthest}");
    assert!(
        furthest < 3.0,
        "the ball went through the wall: x = {furthest}"
    );
}

#[test]
fn landings_on_large_flat_grounds_use_the_face_normal() {
    // parry's GJK normal for a box or capsule touching a 100 m slab or mesh is tens of
    // degrees off in f32 for a quarter of random orientations; the plugin uses the face's.
    let l: Real = 50.0;
    let heights = Array2::new(3, 3, vec![Real::default(); 9]);
    let grounds = [
        (
            "slab",
            ColliderBuilder::cuboid(l, 0.005, l).translation(Vector::new(0.0, -0.005, 0.0)),
        ),
        (
            "trimesh",
            ColliderBuilder::trimesh(
                vec![
                    Vector::new(-l, 0.0, -l),
                    Vector::new(l, 0.0, -l),
                    Vector::new(l, 0.0, l),
                    Vector::new(-l, 0.0, l),
                ],
                vec![[0, 3, 2], [0, 2, 1]],
            )
            .unwrap(),
        ),
        (
            "heightfield",
            ColliderBuilder::heightfield(heights, Vector::new(2.0 * l, 1.0, 2.0 * l)),
        ),
    ];
    let mut seed = 7u64;
    let mut rnd = move || {
        seed = seed
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((seed >> 11) as f64 / (1u64 << 53) as f64) as Real - 0.5
    };
    for (label, ground_shape) in grounds {
        let (mut worst_normal, mut lowest, mut count): (f64, Real, usize) = (0.0, 0.0, 0);
        for k in 0..40 {
            let mut world = PhysicsWorld::default();
            let (_, ground) = world.insert(RigidBodyBuilder::fixed(), ground_shape.clone());
            let body = if k % 2 == 0 {
                ColliderBuilder::cuboid(0.1, 0.1, 0.1)
            } else {
                ColliderBuilder::capsule_y(0.1, 0.05)
            };
            let (h, co) = world.insert(
                RigidBodyBuilder::dynamic()
                    .translation(Vector::new(rnd(), 0.6, rnd()))
                    .rotation(Vector::new(rnd(), rnd(), rnd()) * 6.0)
                    .angvel(Vector::new(rnd(), rnd(), rnd()) * 10.0),
                body.restitution(0.5).friction(0.4),
            );
            let mut p = plugin_on(&world, ground, TimingMode::Exact);
            for _ in 0..40 {
                p.step(&mut world);
                for ev in p.events() {
                    worst_normal = worst_normal.max(1.0 - f64::from(ev.normal.y));
                    count += 1;
                }
                let _ = h;
                lowest = lowest.min(world.colliders[co].compute_aabb().mins.y);
            }
        }
        println!(
            "{label}: {count} impacts, worst 1 - n.y = {worst_normal:.2e}, lowest point {lowest:.2e} m"
        );
        assert!(count >= 40, "{label}: only {count} impacts");
        assert!(
            worst_normal < 1e-6,
            "{label}: a normal is off by 1 - n.y = {worst_normal}"
        );
        // Resting contacts are rapier's (soft, e = 0): within its allowed linear error.
        let allowed = IntegrationParameters::default().allowed_linear_error();
        assert!(lowest > -allowed, "{label}: a body sank to {lowest} m");
    }
}

/// `replace_hooks`, as a driver whose hook lives for one system run uses it (swapped in
/// before each step, back out after): the trace is bitwise that of a plugin holding the hook
/// all along (grounds, roles and shadows carry over), and the hook swapped in is the one
/// asked (the ghost it refuses falls through the ground).
#[test]
fn a_hook_swapped_in_for_each_step_gives_the_trace_of_a_hook_held_throughout() {
    let scene = || {
        let mut world = PhysicsWorld::default();
        let (_, ground) = world.insert(
            RigidBodyBuilder::fixed(),
            ColliderBuilder::halfspace(up()).restitution(0.7),
        );
        let hooks = ActiveHooks::FILTER_CONTACT_PAIRS;
        let (ball, _) = world.insert(
            RigidBodyBuilder::dynamic().translation(Vector::new(0.0, 1.0, 0.0)),
            ColliderBuilder::ball(0.1)
                .restitution(0.7)
                .active_hooks(hooks),
        );
        let (ghost, ghost_co) = world.insert(
            RigidBodyBuilder::dynamic().translation(Vector::new(1.0, 0.5, 0.0)),
            ColliderBuilder::ball(0.1).active_hooks(hooks),
        );
        (world, ground, [ball, ghost], ghost_co)
    };
    let trace = |world: &PhysicsWorld, bodies: &[RigidBodyHandle; 2]| {
        bodies
            .iter()
            .map(|b| (world.bodies[*b].translation(), world.bodies[*b].linvel()))
            .collect::<Vec<_>>()
    };
    let (mut held_world, ground, bodies, ghost_co) = scene();
    let mut held =
        ImpactPlugin::with_hooks(ImpactConfig::default(), GhostFilter::new(ghost_co)).unwrap();
    held.add_ground(&held_world.bodies, &held_world.colliders, ground)
        .unwrap();
    let (mut swapped_world, ..) = scene();
    let mut idle = Some(ImpactPlugin::new(ImpactConfig::default()).unwrap());
    if let Some(p) = idle.as_mut() {
        p.add_ground(&swapped_world.bodies, &swapped_world.colliders, ground)
            .unwrap();
    }
    let (mut asked, mut impacts) = (0, 0);
    for i in 0..120 {
        held.step(&mut held_world);
        let (mut hooked, ()) = idle
            .take()
            .unwrap()
            .replace_hooks(GhostFilter::new(ghost_co));
        hooked.step(&mut swapped_world);
        assert_eq!(hooked.events(), held.events(), "step {i}: the same events");
        impacts += held.events().len();
        let (back, filter) = hooked.replace_hooks(());
        asked += filter.seen.lock().unwrap().len();
        idle = Some(back);
        assert_eq!(
            trace(&swapped_world, &bodies),
            trace(&held_world, &bodies),
            "step {i}: the same bodies"
        );
    }
    assert!(asked > 0, "the swapped-in hook was never asked");
    let ghost_y = swapped_world.bodies[bodies[1]].translation().y;
    assert!(
        ghost_y < 0.0,
        "the ghost fell through the ground: y = {ghost_y}"
    );
    assert!(impacts > 0, "the ball never bounced");
}

/// `Exact` mode flies a damped ball in closed form, `v(t) = g/c + (v0 - g/c) e^(-c t)`,
/// although rapier damps its own way (once a step, `(v + g dt) / (1 + c dt)`): the difference
/// (first order in `c dt`) must not take the ball for one something pushed.
#[test]
fn exact_mode_flies_a_damped_ball_in_closed_form() {
    let (c, v0, y0, dt) = (0.5, 3.0, 10.0, 1.0 / 60.0);
    let mut world = PhysicsWorld {
        gravity: Vector::new(0.0, real(-G), 0.0),
        ..Default::default()
    };
    world.integration_parameters.dt = real(dt);
    let (_, ground) = world.insert(RigidBodyBuilder::fixed(), ColliderBuilder::halfspace(up()));
    let (ball, _) = world.insert(
        RigidBodyBuilder::dynamic()
            .translation(Vector::new(0.0, real(y0), 0.0))
            .linvel(Vector::new(0.0, real(v0), 0.0))
            .linear_damping(real(c)),
        ColliderBuilder::ball(0.1),
    );
    let mut p = plugin_on(&world, ground, TimingMode::Exact);
    let steps = 60;
    for _ in 0..steps {
        p.step(&mut world);
    }
    let t = steps as f64 * dt;
    let v_inf = -G / c;
    let decay = (-c * t).exp();
    let v = v_inf + (v0 - v_inf) * decay;
    let y = y0 + v_inf * t + (v0 - v_inf) * (1.0 - decay) / c;
    let rb = &world.bodies[ball];
    let tol = if F64 { 1e-12 } else { 1e-6 };
    let (vy, yy) = (wide(rb.linvel().y), wide(rb.translation().y));
    assert_abs_diff_eq!(vy, v, epsilon = tol * v0);
    assert_abs_diff_eq!(yy, y, epsilon = tol * y0);
}

/// `Exact` mode flies a body far from every ground without moving it every step: from its
/// second step of flight, its velocity is set to `v - g dt / 2N` before rapier's step
/// (`Stage::Steer`), under which rapier's own integrator lands on the exact positions, and to
/// its own after; its translation is written only where rapier's rounding drifted beyond two
/// roundings. At every step end rapier's translation is the closed form to within two
/// roundings a coordinate and its velocity the closed form's, rounded once; a velocity the
/// user sets in flight is the body's own from there on.
#[test]
fn exact_flight_far_from_the_grounds_is_steered_not_moved() {
    let mut world = PhysicsWorld::default();
    let dt = wide(world.integration_parameters.dt);
    let (_, ground) = world.insert(RigidBodyBuilder::fixed(), ColliderBuilder::halfspace(up()));
    let (ball, _) = world.insert(
        RigidBodyBuilder::dynamic()
            .translation(Vector::new(0.3, 20.0, -0.2))
            .linvel(Vector::new(1.5, 5.0, -0.5)),
        ColliderBuilder::ball(0.1),
    );
    let mut p = plugin_on(&world, ground, TimingMode::Exact);
    p.set_profiling(true);
    let g = na(world.gravity);
    let eps = f64::from(Real::EPSILON);
    // The closed form from `(x, v)` at step `k0`, started again where the user sets a velocity.
    let rb = &world.bodies[ball];
    let (mut k0, mut xs, mut vs) = (0, na(rb.translation()), na(rb.linvel()));
    let (mut moves, mut worst_x, mut worst_v) = (Vec::new(), 0.0f64, 0.0f64);
    for k in 1..=120 {
        if k == 61 {
            let v = Vector::new(-1.0, 2.0, 0.25);
            world.bodies[ball].set_linvel(v, true);
            (k0, xs, vs) = (k - 1, na(world.bodies[ball].translation()), na(v));
        }
        p.step(&mut world);
        moves.push(p.profile().unwrap().counts.moves);
        let t = (k - k0) as f64 * dt;
        let (x, v) = (xs + vs * t + 0.5 * g * t * t, vs + g * t);
        let rb = &world.bodies[ball];
        let (held, held_v) = (na(rb.translation()), na(rb.linvel()));
        for i in 0..3 {
            worst_x = worst_x.max((held[i] - x[i]).abs() / (eps * x[i].abs()));
            worst_v = worst_v.max((held_v[i] - v[i]).abs() / (eps * v[i].abs()));
        }
        assert!(p.events().is_empty(), "step {k}: far from the ground");
    }
    let moved = |from: usize, to: usize| moves[from..to].iter().sum::<usize>();
    println!(
        "moves {moves:?}; translation within {worst_x:.2} roundings, velocity within {worst_v:.2}"
    );
    // Moved on its first step of flight, and on the first at the user's velocity; then only
    // where rapier's rounding drifted beyond two roundings (a flight written as before would
    // move it on all 118 other steps).
    assert_eq!((moves[0], moves[60]), (1, 1));
    let drifts = moved(1, 60) + moved(61, 120);
    assert!(
        drifts * 2 <= 118,
        "moved on {drifts} of 118 steps: {moves:?}"
    );
    // `f32`: two roundings carried, half of one written (and the plugin's `f64` flight's own
    // rounding); `f64`: that flight's rounding over the steps against one closed form (2e-12
    // relative).
    let (x_tol, v_tol) = if F64 {
        (1e4, 1e4)
    } else {
        (2.0 + 1e-6, 0.5 + 1e-6)
    };
    assert!(
        worst_x <= x_tol,
        "translation {worst_x} roundings off the closed form"
    );
    assert!(
        worst_v <= v_tol,
        "velocity {worst_v} roundings off the closed form"
    );
}

/// The same without gravity, 1 km from the origin at 1 m/s: each step's path (1.7 cm) is a
/// few hundred of rapier's roundings long there, and rapier's end, rounded, stands short of
/// the exact one by some of them. That is no collider stopping it: the flight stays the
/// closed form to within two roundings a coordinate (it went to rapier's own rounding, 8e-3 m
/// off after two seconds, when any shortfall beyond 0.1 % of the path was taken for a
/// collider).
#[test]
fn exact_flight_far_from_the_origin_without_gravity_is_the_closed_form() {
    let mut world = PhysicsWorld {
        gravity: Vector::ZERO,
        ..Default::default()
    };
    let dt = wide(world.integration_parameters.dt);
    let (_, ground) = world.insert(RigidBodyBuilder::fixed(), ColliderBuilder::halfspace(up()));
    let (ball, _) = world.insert(
        RigidBodyBuilder::dynamic()
            .translation(Vector::new(1000.0, 20.0, 0.0))
            .linvel(Vector::new(1.0, 0.0, 0.0)),
        ColliderBuilder::ball(0.01),
    );
    let mut p = plugin_on(&world, ground, TimingMode::Exact);
    let eps = f64::from(Real::EPSILON);
    let mut worst: f64 = 0.0;
    for k in 1..=120 {
        p.step(&mut world);
        let x = 1000.0 + k as f64 * dt;
        let held = wide(world.bodies[ball].translation().x);
        worst = worst.max((held - x).abs() / (eps * x));
    }
    println!("translation within {worst:.2} roundings of the closed form");
    let tol = if F64 { 1e4 } else { 2.0 + 1e-6 };
    assert!(
        worst <= tol,
        "translation {worst} roundings off the closed form"
    );
}

#[test]
fn values_too_large_are_refused_naming_the_field_and_its_range() {
    let mut world = PhysicsWorld::default();
    let (_, ground) = world.insert(RigidBodyBuilder::fixed(), ColliderBuilder::halfspace(up()));
    let mut p = plugin(TimingMode::Exact);
    ground_materials_out_of_range_are_refused(&world, &mut p, ground);
    configs_out_of_range_are_refused();
    body_settings_out_of_range_are_refused(&mut world, &mut p);
    invalid_curve_points_are_refused();
}

/// Each ground material field out of its range is refused when the ground is added, and the
/// ground is not kept; the ends of the ranges are taken.
fn ground_materials_out_of_range_are_refused(
    world: &PhysicsWorld,
    p: &mut ImpactPlugin,
    ground: ColliderHandle,
) {
    let with = |restitution, friction, rolling: Option<f64>| {
        let mut material = GroundMaterial::new(restitution, friction);
        material.rolling_resistance = rolling;
        material
    };
    for (material, field) in [
        (with(1e38, 0.5, None), "restitution"),
        (with(1e300, 0.5, None), "restitution"),
        (with(10.5, 0.5, None), "restitution"),
        (with(0.5, 1e3, None), "friction"),
        (with(0.5, 0.5, Some(1e300)), "rolling_resistance"),
        (with(0.5, 0.5, Some(-1.0)), "rolling_resistance"),
        (
            with(0.5, 0.5, None).with_tangential_restitution(1.5),
            "tangential_restitution",
        ),
        (
            with(0.5, 0.5, None).with_tangential_restitution(f64::NAN),
            "tangential_restitution",
        ),
        (
            with(0.5, 0.5, None).with_restitution_curve(curve(&[(0.0, 0.5), (2.0, 10.5)])),
            "restitution_curve",
        ),
    ] {
        let e = p
            .add_ground_with_material(&world.bodies, &world.colliders, ground, material.clone())
            .unwrap_err();
        assert!(
            matches!(e, ConfigError::MaterialOutOfRange { field: f, .. } if f == field),
            "{material:?}: {e:?}"
        );
        let message = e.to_string();
        assert!(
            message.contains(&format!("GroundMaterial::{field}"))
                && (message.contains("[0, ") || message.contains("[-1, 1]")),
            "{message}"
        );
    }
    assert!(!p.is_ground(ground));
    // The ends of the ranges are taken.
    p.add_ground_with_material(
        &world.bodies,
        &world.colliders,
        ground,
        with(10.0, 100.0, Some(100.0)),
    )
    .unwrap();
}

/// Each configuration field out of its range is refused by the plugin's constructor.
fn configs_out_of_range_are_refused() {
    let bad = |config: ImpactConfig| ImpactPlugin::new(config).err();
    let base = ImpactConfig::default();
    for (config, field) in [
        (
            base.clone().with_resting_speed(Some(1e300)),
            "resting_speed",
        ),
        (base.clone().with_resting_gap(Some(1e300)), "resting_gap"),
        (base.clone().with_flat_tolerance(2.0), "flat_tolerance"),
        (
            base.clone().with_rolling_resistance(1e300),
            "rolling_resistance",
        ),
        (
            base.clone().with_spinning_friction(101.0),
            "spinning_friction",
        ),
        (
            base.clone().with_tangential_restitution(-1.01),
            "tangential_restitution",
        ),
        (
            base.clone()
                .with_restitution_curve(Some(curve(&[(1.0, 12.0)]))),
            "restitution_curve",
        ),
    ] {
        let e = bad(config).expect("refused");
        assert!(
            matches!(e, ConfigError::InvalidConfig { field: f, .. } if f == field),
            "{e:?}"
        );
        let message = e.to_string();
        assert!(message.contains(&format!("ImpactConfig::{field}")), "{e}");
        // A huge value is shown in scientific notation, not as its 301 digits.
        assert!(
            message.len() < 100 && !message.contains("0000000"),
            "{message}"
        );
    }
    // So is one the model refuses, and a tiny one.
    for (value, shown) in [(-1e300, "-1e300"), (-1e-300, "-1e-300")] {
        let message = rapier_impact::model::Material::new(value, 0.5)
            .validate()
            .unwrap_err()
            .to_string();
        assert!(
            message.ends_with(&format!("got {shown}")),
            "{value:e}: {message}"
        );
    }
}

/// A body's own rolling settings, tangential restitution and restitution curve out of range
/// are refused at the call, as that setter's (its message names the setter, not
/// `ImpactConfig`), and nothing of them is kept; the ends of the ranges are taken and kept,
/// and `None` clears them.
fn body_settings_out_of_range_are_refused(world: &mut PhysicsWorld, p: &mut ImpactPlugin) {
    let (ball, _) = world.insert(RigidBodyBuilder::dynamic(), ColliderBuilder::ball(0.1));
    let refused_by = |result: Result<(), ConfigError>, setter: &str, field: &str| {
        let e = result.expect_err("refused");
        assert!(
            matches!(e, ConfigError::InvalidBodySetting { setter: s, field: f, .. }
                if s == setter && f == field),
            "{e:?}"
        );
        let message = e.to_string();
        assert!(
            message.starts_with(&format!("ImpactPlugin::{setter}: {field} is ")),
            "{message}"
        );
    };
    refused_by(
        p.set_body_rolling(ball, Some(RollingSettings::new(0.1, 1e300))),
        "set_body_rolling",
        "spinning_friction",
    );
    refused_by(
        p.set_body_rolling(ball, Some(RollingSettings::new(-0.1, 0.0))),
        "set_body_rolling",
        "rolling_resistance",
    );
    assert_eq!(p.body_rolling(ball), None);
    // A body's own tangential restitution and curve: refused at the call, nothing kept.
    for beta in [1.5, -2.0, f64::NAN, f64::INFINITY] {
        refused_by(
            p.set_body_tangential_restitution(ball, Some(beta)),
            "set_body_tangential_restitution",
            "tangential_restitution",
        );
    }
    refused_by(
        p.set_body_restitution_curve(ball, Some(curve(&[(0.5, 0.2), (1.0, 11.0)]))),
        "set_body_restitution_curve",
        "restitution_curve",
    );
    assert_eq!(p.body_tangential_restitution(ball), None);
    assert_eq!(p.body_restitution_curve(ball), None);
    p.set_body_tangential_restitution(ball, Some(-1.0)).unwrap();
    p.set_body_restitution_curve(ball, Some(curve(&[(0.0, 10.0)])))
        .unwrap();
    assert_eq!(p.body_tangential_restitution(ball), Some(-1.0));
    assert_eq!(p.body_restitution_curve(ball), Some(&curve(&[(0.0, 10.0)])));
    p.set_body_tangential_restitution(ball, None).unwrap();
    assert_eq!(p.body_tangential_restitution(ball), None);
}

fn invalid_curve_points_are_refused() {
    // A curve's own points are refused where it is built.
    for points in [
        &[][..],
        &[(1.0, 0.5), (0.5, 0.5)][..],
        &[(-1.0, 0.5)][..],
        &[(0.0, -0.1)][..],
        &[(f64::NAN, 0.5)][..],
    ] {
        assert!(
            RestitutionCurve::new(points.to_vec()).is_err(),
            "{points:?}"
        );
    }
}

/// A restitution curve through `points`, which must be valid.
fn curve(points: &[(f64, f64)]) -> RestitutionCurve {
    RestitutionCurve::new(points.to_vec()).expect("valid curve")
}

/// A ball dropped on a half-space, its collider's or the ground's friction and restitution
/// set by `set`, stepped by rapier alone (`plugin_on` `None`) or with the plugin, the ground
/// registered with its material if any: the positions of 60 steps, the diagnostics and the
/// number of events.
fn dropped_with(
    set: impl Fn(&mut PhysicsWorld, ColliderHandle, ColliderHandle),
    plugin_on: Option<Option<GroundMaterial>>,
) -> (Vec<Vector>, Vec<rapier_impact::Diagnostic>, usize) {
    let mut world = PhysicsWorld::default();
    let (_, ground) = world.insert(
        RigidBodyBuilder::fixed(),
        ColliderBuilder::halfspace(up()).restitution(0.8),
    );
    let (ball, ball_co) = world.insert(
        RigidBodyBuilder::dynamic()
            .translation(Vector::new(0.0, 0.5, 0.0))
            .linvel(Vector::new(1.0, 0.0, 0.0)),
        ColliderBuilder::ball(0.1).restitution(0.8).friction(0.5),
    );
    set(&mut world, ball_co, ground);
    // Free flight is rapier's own integrator in this mode: a pair left to rapier makes the
    // whole run rapier's.
    let mut p = plugin(TimingMode::TimeOfImpact);
    let mut positions = Vec::new();
    let mut diagnostics = Vec::new();
    let mut events = 0;
    if let Some(material) = &plugin_on {
        match material {
            Some(m) => {
                p.add_ground_with_material(&world.bodies, &world.colliders, ground, m.clone())
            }
            None => p.add_ground(&world.bodies, &world.colliders, ground),
        }
        .unwrap();
    }
    for _ in 0..60 {
        if plugin_on.is_some() {
            p.step(&mut world);
        } else {
            world.step();
        }
        diagnostics.extend_from_slice(p.diagnostics());
        events += p.events().len();
        positions.push(world.bodies[ball].translation());
    }
    (positions, diagnostics, events)
}

#[test]
fn a_collider_with_coefficients_out_of_range_is_left_to_rapier_and_reported_once() {
    type Set = fn(&mut PhysicsWorld, ColliderHandle, ColliderHandle);
    let cases: [(&str, Set, bool); 4] = [
        (
            "ball friction inf",
            |w, b, _| w.colliders[b].set_friction(Real::INFINITY),
            true,
        ),
        (
            "ground restitution NaN",
            |w, _, g| w.colliders[g].set_restitution(Real::NAN),
            false,
        ),
        (
            "ball restitution -0.5",
            |w, b, _| w.colliders[b].set_restitution(-0.5),
            true,
        ),
        (
            "ball restitution 50",
            |w, b, _| w.colliders[b].set_restitution(50.0),
            true,
        ),
    ];
    for (label, set, on_ball) in cases {
        let (alone, ..) = dropped_with(set, None);
        let (with_plugin, diagnostics, events) = dropped_with(set, Some(None));
        assert_eq!(with_plugin, alone, "{label}: not rapier's run");
        assert_eq!(events, 0, "{label}");
        assert_eq!(diagnostics.len(), 1, "{label}: {diagnostics:?}");
        let rapier_impact::Diagnostic::CoefficientsOutOfRange { collider, .. } = diagnostics[0]
        else {
            panic!("{label}: {diagnostics:?}");
        };
        // The ball's collider was inserted second.
        assert_eq!(collider.into_raw_parts().0 == 1, on_ball, "{label}");
        // A ground material of the plugin's replaces the coefficients: resolved, not reported.
        let material = Some(GroundMaterial::new(0.8, 0.5));
        let (_, diagnostics, events) = dropped_with(set, Some(material));
        assert!(
            diagnostics.is_empty() && events > 0,
            "{label}: {diagnostics:?}, {events}"
        );
    }
    // In range: resolved, not reported.
    let (_, diagnostics, events) = dropped_with(|_, _, _| {}, Some(None));
    assert!(diagnostics.is_empty() && events > 0);
}

#[test]
fn a_state_beyond_rapiers_numbers_is_not_written_and_is_reported() {
    for timing in [
        TimingMode::Step,
        TimingMode::TimeOfImpact,
        TimingMode::Exact,
    ] {
        let mut world = PhysicsWorld::default();
        let (_, ground) = world.insert(RigidBodyBuilder::fixed(), ColliderBuilder::halfspace(up()));
        // Ten times this approach speed is beyond rapier's number range.
        let speed = Real::MAX / 4.0;
        let (ball, _) = world.insert(
            RigidBodyBuilder::dynamic()
                .translation(Vector::new(0.0, 0.1, 0.0))
                .linvel(Vector::new(0.0, -speed, 0.0)),
            ColliderBuilder::ball(0.1).restitution(10.0),
        );
        let mut p = plugin(timing);
        p.add_ground_with_material(
            &world.bodies,
            &world.colliders,
            ground,
            GroundMaterial::new(10.0, 0.0),
        )
        .unwrap();
        let mut reported = false;
        for _ in 0..3 {
            p.step(&mut world);
            for d in p.diagnostics() {
                assert_eq!(
                    *d,
                    rapier_impact::Diagnostic::NonFiniteState { body: ball },
                    "{timing:?}"
                );
                reported = true;
            }
            for ev in p.events() {
                assert!(
                    ev.ke_after.is_finite() && ev.normal_impulse.is_finite(),
                    "{timing:?}: {ev:?}"
                );
            }
            let rb = &world.bodies[ball];
            assert!(
                rb.linvel().is_finite() || !reported,
                "{timing:?}: the plugin wrote {:?}",
                rb.linvel()
            );
        }
        assert!(reported, "{timing:?}: no diagnostic");
    }
}

#[test]
fn the_event_log_keeps_every_step_s_events_until_taken() {
    let mut world = PhysicsWorld::default();
    let (_, ground) = world.insert(RigidBodyBuilder::fixed(), ColliderBuilder::halfspace(up()));
    world.insert(
        RigidBodyBuilder::dynamic().translation(Vector::new(0.0, 0.6, 0.0)),
        ColliderBuilder::ball(0.1).restitution(0.8),
    );
    let mut p = plugin_on(&world, ground, TimingMode::Exact);
    // Off by default: nothing is kept.
    p.step(&mut world);
    assert!(p.take_event_log().is_empty());
    p.set_event_log(true);
    let (mut seen, mut taken) = (Vec::new(), Vec::new());
    for k in 0..240 {
        p.step(&mut world);
        seen.extend_from_slice(p.events());
        // Taken now and then, in the middle of a run of steps and right after one.
        if k % 37 == 36 {
            taken.extend(p.take_event_log());
            assert!(p.take_event_log().is_empty(), "taken twice at step {k}");
        }
    }
    taken.extend(p.take_event_log());
    assert!(seen.len() >= 5, "{} events in 4 s of bouncing", seen.len());
    assert_eq!(taken, seen, "the log holds every event once, in order");
    // Off again: its events are dropped and nothing more is kept.
    p.step(&mut world);
    p.set_event_log(false);
    p.step(&mut world);
    assert!(p.take_event_log().is_empty());
}

#[test]
fn builders_and_getters_give_back_what_was_set() {
    let curve = RestitutionCurve::threshold(0.5, 0.7).unwrap();
    let config = ImpactConfig::default()
        .with_timing(TimingMode::TimeOfImpact)
        .with_rolling_resistance(0.02)
        .with_tangential_restitution(0.3)
        .with_restitution_curve(Some(curve.clone()));
    let mut expected = ImpactConfig::default();
    expected.timing = TimingMode::TimeOfImpact;
    expected.rolling_resistance = 0.02;
    expected.tangential_restitution = 0.3;
    expected.restitution_curve = Some(curve.clone());
    assert_eq!(config, expected);
    let mut p = ImpactPlugin::new(config.clone()).unwrap();
    assert_eq!(p.config(), &config);
    let mut world = PhysicsWorld::default();
    let (_, ground) = world.insert(RigidBodyBuilder::fixed(), ColliderBuilder::halfspace(up()));
    let (ball, _) = world.insert(RigidBodyBuilder::dynamic(), ColliderBuilder::ball(0.1));
    let material = GroundMaterial::new(0.6, 0.4)
        .with_rolling_resistance(0.05)
        .with_spinning_friction(0.01)
        .with_tangential_restitution(-0.2)
        .with_restitution_curve(curve);
    p.add_ground_with_material(&world.bodies, &world.colliders, ground, material.clone())
        .unwrap();
    assert_eq!(p.ground_material(ground), Some(material));
    assert_eq!(p.body_rolling(ball), None);
    let rolling = RollingSettings::new(0.03, 0.004);
    p.set_body_rolling(ball, Some(rolling)).unwrap();
    assert_eq!(p.body_rolling(ball), Some(rolling));
    p.set_body_rolling(ball, None).unwrap();
    assert_eq!(p.body_rolling(ball), None);
    assert!(!p.is_excluded(ball));
    p.exclude_body(ball);
    assert!(p.is_excluded(ball));
    p.include_body(ball);
    assert!(!p.is_excluded(ball));
    for on in [true, false] {
        p.set_all_fixed_colliders_ground(on);
        p.set_all_dynamic_bodies_impact(on);
        assert_eq!(
            (
                p.all_fixed_colliders_ground(),
                p.all_dynamic_bodies_impact()
            ),
            (on, on)
        );
    }
}
