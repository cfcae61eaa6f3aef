//! Grounds the first version of the adapter left untested, each against a closed form or the
//! model at the contact's normal and ground velocity:
//! - every fixed collider as ground (including one added later), a manual ground kept when
//!   that mode is turned off, and `remove_ground` (flags restored, rapier's bounce back, and
//!   the collider not re-marked by the all-fixed mode);
//! - a position-based kinematic platform rising at `V`: contact time and `v' = V - e (v - V)`;
//!   in `Step` mode, `v' = V - e (v0 - V)` from the velocity at the step boundary;
//! - a bat (position-based, up to 30 m/s) and a blade (turning at 30 rad/s) swung onto a ball
//!   at rest: met by their own motion, at the contact's time, the ball leaving at `(1 + e)`
//!   times the approach speed;
//! - a kinematic turntable spinning about the vertical: in the platform frame the contact's
//!   tangential velocity `u_t = v_t - w x r` is left at `5/7 u_t` (stick, solid ball) or cut
//!   by `mu (1 + e) |u_n|` (slip), and the normal speed is reversed times `e`;
//! - a heightfield ramp and a trimesh ramp at 20 deg: the event's normal is the slope's, and
//!   the velocities after are `model::resolve` at that normal (friction included);
//! - a wrapped user hook: its `filter_contact_pair` and `modify_solver_contacts` are still
//!   called for every pair that is not a managed ground contact (a conveyor platform that
//!   moves a box, an excluded body on a ground), and its filter decides whether a ball and a
//!   ground touch at all (a ghost ball falls through a ground the plugin would bounce);
//!   a conveyor ground still conveys a box resting on it;
//! - a floor of flush tiles: one ground to the plan (balls bounce exactly as on one cuboid,
//!   each event names the tile under its point), and the tiles one by one for a ball whose
//!   pairs the user's filter decides (a refused tile lets it through, also when rapier wakes
//!   it inside that tile).
//!
//! Every test prints measured against expected.

// Precision-generic: `Real` is f32 or f64 (feature `f64`), so conversions that are
// widening in one build are identities in the other.
#![allow(clippy::useless_conversion, clippy::unnecessary_cast)]

mod plugin_support;

use approx::assert_abs_diff_eq;
use plugin_support::*;
use rapier_impact::model::{self, Body, BodyVelocity, Contact, Law, Material};
use rapier_impact::na::{Matrix3, Vector3};
use rapier_impact::rapier::parry::utils::Array2;
use rapier_impact::rapier::prelude::*;
use rapier_impact::{
    EventKind, GroundMaterial, ImpactConfig, ImpactEvent, ImpactPlugin, ImpactTiming, TimingMode,
};

/// Tolerances `(time (s), velocity (m/s))` of an exact in-step impact.
fn tol() -> (f64, f64) {
    if F64 { (1e-9, 1e-8) } else { (2e-5, 2e-4) }
}

/// A ball of radius `r` at `at`, with restitution and friction `e`, `mu`.
fn ball(world: &mut PhysicsWorld, at: [f64; 3], r: f64, e: f64, mu: f64) -> RigidBodyHandle {
    world
        .insert(
            RigidBodyBuilder::dynamic().translation(Vector::new(
                real(at[0]),
                real(at[1]),
                real(at[2]),
            )),
            ColliderBuilder::ball(real(r))
                .restitution(real(e))
                .friction(real(mu)),
        )
        .0
}

/// The first impact time of a ball whose bottom is `h` above the ground at `t0`, at rest.
fn fall_time(h: f64) -> f64 {
    (2.0 * h / G).sqrt()
}

/// Steps until the plugin reports an impact (120 steps at most): the impact's time (s) and
/// event, and the ball's velocity and spin right after it (the step-end velocity carried back
/// to the impact: free flight under gravity).
fn first_impact(
    world: &mut PhysicsWorld,
    p: &mut ImpactPlugin,
    ball: RigidBodyHandle,
) -> Option<(f64, ImpactEvent, Vector3<f64>, Vector3<f64>)> {
    let dt = wide(world.integration_parameters.dt);
    for k in 0..120 {
        p.step(world);
        if let Some(ev) = p.events().first().copied() {
            let rb = &world.bodies[ball];
            let v = na(rb.linvel()) + Vector3::new(0.0, G * (dt - ev.time), 0.0);
            return Some((k as f64 * dt + ev.time, ev, v, na(rb.angvel())));
        }
    }
    None
}

// ---------------------------------------------------------------------------------------
// Ground registration
// ---------------------------------------------------------------------------------------

#[test]
fn every_fixed_collider_is_ground_and_turning_the_mode_off_unmarks_only_those() {
    let (e, h) = (0.8, 0.5);
    let mut world = PhysicsWorld::default();
    let (grounds, balls) = grounds_of_each_kind_with_a_ball_over_each(&mut world, e, h);
    let [g_body, g_free, g_kin] = grounds;
    let mut p = plugin(TimingMode::Exact);
    p.set_all_fixed_colliders_ground(true);
    p.step(&mut world);
    println!(
        "after one step: fixed body's collider {}, parentless {}, kinematic {}",
        p.is_ground(g_body),
        p.is_ground(g_free),
        p.is_ground(g_kin)
    );
    assert!(p.is_ground(g_body) && p.is_ground(g_free) && !p.is_ground(g_kin));
    assert!(balls.iter().all(|b| {
        world.bodies[*b]
            .colliders()
            .iter()
            .all(|c| !p.is_ground(*c))
    }));
    p.add_ground(&world.bodies, &world.colliders, g_kin)
        .unwrap();
    // A fixed ground added later, with a ball over it.
    let (_, g_late) = world.insert(
        RigidBodyBuilder::fixed().translation(Vector::new(60.0, -0.5, 0.0)),
        ColliderBuilder::cuboid(2.0, 0.5, 2.0).restitution(real(e)),
    );
    let late = ball(&mut world, [60.0, 0.1 + h, 0.0], 0.1, e, 0.0);
    let dt = wide(world.integration_parameters.dt);
    let first = first_impact_times(&mut p, &mut world, [balls[0], balls[1], balls[2], late]);
    assert!(
        p.is_ground(g_late),
        "a fixed collider added later is not ground"
    );
    let t1 = fall_time(h);
    // The late ball was released at the end of the first step.
    let expected = [t1, t1, t1, t1 + dt];
    let (tt, _) = tol();
    for (i, label) in [
        "fixed body",
        "parentless",
        "kinematic (by hand)",
        "added later",
    ]
    .iter()
    .enumerate()
    {
        let expected = expected[i];
        println!(
            "{label}: first impact {:?} s, expected {expected:.7}",
            first[i]
        );
        let got = first[i].unwrap_or(f64::NAN);
        assert_abs_diff_eq!(got, expected, epsilon = tt);
    }
    turning_the_mode_off_unmarks_only_the_automatic_grounds(
        &mut p,
        &mut world,
        [g_body, g_free, g_late, g_kin],
        balls[2],
    );
}

/// A fixed body's box, a parentless box and a kinematic platform (20 m apart, their tops at
/// y = 0), with a ball `h` above each: the grounds and the balls.
fn grounds_of_each_kind_with_a_ball_over_each(
    world: &mut PhysicsWorld,
    e: f64,
    h: f64,
) -> ([ColliderHandle; 3], [RigidBodyHandle; 3]) {
    // A fixed body's box (balls far apart so each lands on its own ground).
    let (_, g_body) = world.insert(
        RigidBodyBuilder::fixed(),
        ColliderBuilder::cuboid(2.0, 0.5, 2.0)
            .translation(Vector::new(0.0, -0.5, 0.0))
            .restitution(real(e)),
    );
    // ... a parentless collider ...
    let g_free = world.colliders.insert(
        ColliderBuilder::cuboid(2.0, 0.5, 2.0)
            .translation(Vector::new(20.0, -0.5, 0.0))
            .restitution(real(e)),
    );
    // ... and a kinematic platform, not fixed: ground only when marked by hand.
    let (_, g_kin) = world.insert(
        RigidBodyBuilder::kinematic_velocity_based().translation(Vector::new(40.0, -0.5, 0.0)),
        ColliderBuilder::cuboid(2.0, 0.5, 2.0).restitution(real(e)),
    );
    let balls = [0.0, 20.0, 40.0].map(|x| ball(world, [x, 0.1 + h, 0.0], 0.1, e, 0.0));
    ([g_body, g_free, g_kin], balls)
}

/// Steps 59 times after the first step: each ball's first impact time, counted from the
/// start of the first step.
fn first_impact_times(
    p: &mut ImpactPlugin,
    world: &mut PhysicsWorld,
    all: [RigidBodyHandle; 4],
) -> Vec<Option<f64>> {
    let dt = wide(world.integration_parameters.dt);
    let mut first: Vec<Option<f64>> = vec![None; 4];
    for k in 1..60 {
        p.step(world);
        for ev in p.events() {
            let i = all.iter().position(|b| *b == ev.body).unwrap();
            first[i].get_or_insert(k as f64 * dt + ev.time);
        }
    }
    first
}

/// Off: the automatic grounds are ordinary colliders again, their flags back to the user's
/// from the next step; the ground marked by hand stays, and only the ball on it (`on_kept`)
/// still has plugin impacts.
fn turning_the_mode_off_unmarks_only_the_automatic_grounds(
    p: &mut ImpactPlugin,
    world: &mut PhysicsWorld,
    [g_body, g_free, g_late, g_kin]: [ColliderHandle; 4],
    on_kept: RigidBodyHandle,
) {
    p.set_all_fixed_colliders_ground(false);
    p.step(world);
    for (label, c, ground) in [
        ("fixed body", g_body, false),
        ("parentless", g_free, false),
        ("added later", g_late, false),
        ("kinematic (by hand)", g_kin, true),
    ] {
        let flags = world.colliders[c].active_hooks();
        println!(
            "mode off: {label}: ground {}, hook flags {flags:?}",
            p.is_ground(c)
        );
        assert_eq!(p.is_ground(c), ground, "{label}");
        if !ground {
            assert_eq!(flags, ActiveHooks::empty(), "{label}: flags not restored");
        }
    }
    let mut later = Vec::new();
    for _ in 0..120 {
        p.step(world);
        later.extend(p.events().iter().map(|ev| ev.body));
    }
    println!("events after the mode is off, by body: {later:?}");
    assert!(
        later.iter().all(|b| *b == on_kept),
        "a ball on an unmarked ground still got plugin impacts"
    );
}

#[test]
fn remove_ground_restores_the_users_flags_and_rapiers_bounce() {
    let (e, h) = (0.8, 0.5);
    let mut world = PhysicsWorld::default();
    let user = ActiveHooks::MODIFY_SOLVER_CONTACTS;
    let (_, ground) = world.insert(
        RigidBodyBuilder::fixed(),
        ColliderBuilder::halfspace(up())
            .restitution(real(e))
            .active_hooks(user),
    );
    let b = ball(&mut world, [0.0, 0.1 + h, 0.0], 0.1, e, 0.0);
    let mut p = plugin_on(&world, ground, TimingMode::Exact);
    assert!(world.colliders[ground].active_hooks().contains(user));
    assert!(p.remove_ground(ground));
    assert!(!p.remove_ground(ground));
    let flags = world.colliders[ground].active_hooks();
    println!(
        "after remove_ground: ground {}, flags {flags:?}",
        p.is_ground(ground)
    );
    assert_eq!(flags, user);
    assert!(!p.is_ground(ground));
    let (mut events, mut rose) = (0, false);
    for _ in 0..60 {
        p.step(&mut world);
        events += p.events().len();
        rose |= world.bodies[b].linvel().y > 0.0;
    }
    println!("plugin events after removal: {events}; the ball bounced (rapier): {rose}");
    assert!(events == 0 && rose);

    // In the all-fixed mode, a ground removed by hand stays removed; `add_ground` marks it
    // again.
    let mut world = PhysicsWorld::default();
    let (_, ground) = world.insert(
        RigidBodyBuilder::fixed(),
        ColliderBuilder::halfspace(up()).restitution(real(e)),
    );
    ball(&mut world, [0.0, 0.1 + h, 0.0], 0.1, e, 0.0);
    let mut p = plugin(TimingMode::Exact);
    p.set_all_fixed_colliders_ground(true);
    p.step(&mut world);
    assert!(p.is_ground(ground));
    assert!(p.remove_ground(ground));
    let mut events = 0;
    for _ in 0..60 {
        p.step(&mut world);
        events += p.events().len();
    }
    println!(
        "all-fixed mode, removed by hand: ground {} after 60 steps, {events} plugin events",
        p.is_ground(ground)
    );
    assert!(!p.is_ground(ground) && events == 0);
    p.add_ground(&world.bodies, &world.colliders, ground)
        .unwrap();
    p.step(&mut world);
    assert!(p.is_ground(ground));
}

// ---------------------------------------------------------------------------------------
// Moving grounds
// ---------------------------------------------------------------------------------------

/// A position-based platform (top at y = 0 at t = 0), moved by [`move_platform`] before each
/// step. A ball's bottom `h` above, at rest. Returns the world, the plugin, the ball and the
/// platform body.
fn rising_position_platform(
    timing: TimingMode,
    e: f64,
    h: f64,
) -> (PhysicsWorld, ImpactPlugin, RigidBodyHandle, RigidBodyHandle) {
    let mut world = PhysicsWorld::default();
    let (platform, ground) = world.insert(
        RigidBodyBuilder::kinematic_position_based().translation(Vector::new(0.0, -0.5, 0.0)),
        ColliderBuilder::cuboid(2.0, 0.5, 2.0).friction(0.0),
    );
    let b = ball(&mut world, [0.0, 0.1 + h, 0.0], 0.1, 0.0, 0.0);
    let p = plugin_with_material(&world, ground, timing, e, 0.0);
    (world, p, b, platform)
}

fn move_platform(world: &mut PhysicsWorld, platform: RigidBodyHandle, k: usize, v_up: f64) {
    let dt = wide(world.integration_parameters.dt);
    let y = -0.5 + v_up * (k + 1) as f64 * dt;
    world.bodies[platform].set_next_kinematic_translation(Vector::new(0.0, real(y), 0.0));
}

#[test]
fn a_position_based_rising_platform_enters_the_model() {
    let (v_up, e, h) = (1.0, 0.6, 0.5);
    let (mut world, mut p, b, platform) = rising_position_platform(TimingMode::Exact, e, h);
    let dt = wide(world.integration_parameters.dt);
    // Contact when h - g t^2 / 2 = V t.
    let t_hit = (-v_up + (v_up * v_up + 2.0 * G * h).sqrt()) / G;
    let v_ball = -G * t_hit;
    let expected = v_up - e * (v_ball - v_up);
    let (tt, tv) = tol();
    for k in 0..120 {
        move_platform(&mut world, platform, k, v_up);
        p.step(&mut world);
        if let Some(ev) = p.events().first() {
            let t = k as f64 * dt + ev.time;
            let vy = wide(world.bodies[b].linvel().y) + G * (dt - ev.time);
            println!(
                "position-based platform: impact {t:.7} s (expected {t_hit:.7}), vy after {vy:.6} (expected {expected:.6}), approach {:.6} (expected {:.6})",
                ev.approach_speed,
                v_up - v_ball
            );
            assert_abs_diff_eq!(t, t_hit, epsilon = tt);
            assert_abs_diff_eq!(vy, expected, epsilon = tv);
            assert_abs_diff_eq!(ev.approach_speed, v_up - v_ball, epsilon = tv);
            return;
        }
    }
    panic!("the ball never met the platform");
}

/// The impact `ev` was met at the start of its step in `Step` mode, else in the step at
/// `time` (to `tt`).
fn met_at(ev: &ImpactEvent, timing: TimingMode, time: f64, tt: f64) {
    if timing == TimingMode::Step {
        assert_eq!(ev.timing, ImpactTiming::StepStart);
    } else {
        assert_eq!(ev.timing, ImpactTiming::InStep);
        assert_abs_diff_eq!(ev.time, time, epsilon = tt);
    }
}

/// A world without gravity.
fn weightless() -> PhysicsWorld {
    PhysicsWorld {
        gravity: Vector::ZERO,
        ..Default::default()
    }
}

/// A bat: a position-based kinematic box 10 cm thick (friction 0, restitution `e`), at
/// height `y`, swung along x at `v` onto a ball of radius `r` at the origin, its face 2.4
/// steps' travel from the ball at the start.
struct Bat {
    body: RigidBodyHandle,
    face: ColliderHandle,
    v: f64,
    r: f64,
    y: f64,
    dt: f64,
}

impl Bat {
    const HALF: f64 = 0.05;

    fn insert(world: &mut PhysicsWorld, (v, r, y, e): (f64, f64, f64, f64)) -> Self {
        let dt = wide(world.integration_parameters.dt);
        let mut bat = Bat {
            body: RigidBodyHandle::invalid(),
            face: ColliderHandle::invalid(),
            v,
            r,
            y,
            dt,
        };
        (bat.body, bat.face) = world.insert(
            RigidBodyBuilder::kinematic_position_based().translation(bat.at(0)),
            ColliderBuilder::cuboid(real(Self::HALF), 0.3, 0.3)
                .friction(0.0)
                .restitution(real(e)),
        );
        bat
    }

    /// Its centre after `k` steps.
    fn at(&self, k: usize) -> Vector {
        let x = -self.r - Self::HALF - 2.4 * self.v * self.dt + self.v * k as f64 * self.dt;
        Vector::new(real(x), real(self.y), 0.0)
    }

    /// Five steps of the swing, each from its start: the impacts against it (step, event),
    /// the ball `b` never inside it at a step's end.
    fn swing(
        &self,
        world: &mut PhysicsWorld,
        p: &mut ImpactPlugin,
        b: RigidBodyHandle,
        label: &str,
    ) -> Vec<(usize, ImpactEvent)> {
        let mut hits = Vec::new();
        for k in 0..5 {
            world.bodies[self.body].set_next_kinematic_translation(self.at(k + 1));
            p.step(world);
            hits.extend(
                p.events()
                    .iter()
                    .filter(|ev| ev.ground == self.face)
                    .map(|ev| (k, *ev)),
            );
            let face = wide(self.at(k + 1).x) + Self::HALF;
            let gap = wide(world.bodies[b].translation().x) - self.r - face;
            assert!(
                gap > -1e-5,
                "{label}: step {k} ends with the ball {gap:e} m into the bat"
            );
        }
        hits
    }
}

/// The bat swung at `V` up to 30 m/s onto a ball at rest, without gravity: the ball does not
/// move, so only the bat's own motion brings them together. In the in-step modes one impact,
/// at `2.4 dt`, leaves the ball at `(1 + e) V` (the bat's mass is infinite); in `Step` mode
/// the impulse at the start of the step it closes in does. The ball is never inside the bat
/// at a step's end.
#[test]
fn a_fast_bat_meets_a_ball_at_rest_in_the_step() {
    let (e, r) = (0.5, 0.1);
    let (tt, tv) = tol();
    for v in [3.0, 12.0, 30.0] {
        for timing in MODES {
            let mut world = weightless();
            let dt = wide(world.integration_parameters.dt);
            let bat = Bat::insert(&mut world, (v, r, 0.0, 0.0));
            let b = ball(&mut world, [0.0, 0.0, 0.0], r, 0.0, 0.0);
            let mut p = plugin_with_material(&world, bat.face, timing, e, 0.0);
            let at = format!("{timing:?}, bat at {v} m/s");
            let hits = bat.swing(&mut world, &mut p, b, &at);
            let vx = wide(world.bodies[b].linvel().x);
            println!(
                "{at}: impacts {:?}, ball vx {vx:.6} (expected {:.6})",
                hits.iter()
                    .map(|(k, ev)| (*k, ev.timing, ev.time / dt))
                    .collect::<Vec<_>>(),
                (1.0 + e) * v
            );
            assert_eq!(hits.len(), 1, "{at}");
            let (k, ev) = hits[0];
            assert_eq!(k, 2, "{at}");
            met_at(&ev, timing, 0.4 * dt, tt);
            assert_abs_diff_eq!(ev.approach_speed, v, epsilon = tv * v);
            assert_abs_diff_eq!(vx, (1.0 + e) * v, epsilon = tv * v);
        }
    }
}

/// The bat at 12 and 30 m/s onto a ball resting on the floor (e = 0.5, mu = 0.5), awake or
/// asleep (on a tee: rapier would not wake it before the bat is through): the floor's contact
/// is rapier's, so the bat's impact is the step-end one (`StepStart` in `Step` mode), once,
/// and the ball leaves ahead of the bat, never inside it at a step's end.
#[test]
fn a_fast_bat_meets_a_ball_resting_on_the_floor() {
    let (e, r) = (0.5, 0.1);
    for (v, asleep) in [(12.0, false), (30.0, false), (12.0, true), (30.0, true)] {
        for timing in MODES {
            let mut world = PhysicsWorld::default();
            let (_, floor) = world.insert(
                RigidBodyBuilder::fixed(),
                ColliderBuilder::halfspace(up()).friction(0.5),
            );
            let bat = Bat::insert(&mut world, (v, r, 0.3, e));
            let b = ball(&mut world, [0.0, r, 0.0], r, e, 0.5);
            let mut p = plugin_with_material(&world, floor, timing, e, 0.5);
            p.add_ground(&world.bodies, &world.colliders, bat.face)
                .unwrap();
            if asleep {
                // Put to sleep once the insertions' wake-ups are past, the bat standing still.
                for k in 0..3 {
                    if k == 2 {
                        world.bodies[b].sleep();
                    }
                    world.bodies[bat.body].set_next_kinematic_translation(bat.at(0));
                    p.step(&mut world);
                }
                assert!(world.bodies[b].is_sleeping(), "the ball is awake");
            }
            let at = format!("{timing:?}, bat at {v} m/s onto a resting ball, asleep {asleep}");
            let hits: Vec<_> = bat
                .swing(&mut world, &mut p, b, &at)
                .into_iter()
                .map(|(k, ev)| (k, ev.timing))
                .collect();
            let vx = wide(world.bodies[b].linvel().x);
            println!("{at}: impacts {hits:?}, ball vx {vx:.4}");
            let expected = if timing == TimingMode::Step {
                ImpactTiming::StepStart
            } else {
                ImpactTiming::StepEnd
            };
            assert_eq!(hits, vec![(2, expected)], "{at}");
            assert!(vx > v, "{at}: the ball left at {vx}");
        }
    }
}

/// What refuses the wall's pairs in [`bat_into_wall`].
#[derive(Clone, Copy, Debug, PartialEq)]
enum WallRefused {
    No,
    /// Collision groups: rapier's own filtering.
    ByGroups,
    /// The user's filter, which the wall's collider asks for.
    ByUserFilter,
}

/// What [`bat_into_wall`] measured: the events (step, on the wall, event), the ball's end
/// velocity `(vx, vz)`, and at each step's end how deep the ball is in the bat and the wall
/// (m, negative outside).
type WallRun = (Vec<(usize, bool, ImpactEvent)>, (f64, f64), Vec<(f64, f64)>);

/// The wall run of [`a_ball_a_fast_bat_sends_into_a_wall_meets_it_in_the_step`]: three steps
/// of the bat at `v` in `timing`, the wall's pairs refused or not. Its face is met once the
/// ball's centre has gone `0.75 v dt`; `slanted`, it is a slab 10 cm thick turned 45 degrees
/// about the vertical, its normal `(-1, 0, -1) / sqrt(2)`, whose box holds the ball at rest
/// (the plan finds it near, and out of reach), else a block 1 m thick facing the ball.
fn bat_into_wall(v: f64, timing: TimingMode, refused: WallRefused, slanted: bool) -> WallRun {
    let (e, e_wall, r) = (0.5, 0.5, 0.1);
    let mut world = weightless();
    let dt = wide(world.integration_parameters.dt);
    let gap = 0.75 * v * dt;
    let bat = Bat::insert(&mut world, (v, r, 0.0, 0.0));
    // The face's unit normal (towards the ball) and a point of it.
    let (n, q) = if slanted {
        let n = Vector3::new(-1.0, 0.0, -1.0) / 2f64.sqrt();
        (n, Vector3::new(gap + r * 2f64.sqrt(), 0.0, 0.0))
    } else {
        (-Vector3::x(), Vector3::new(gap + r, 0.0, 0.0))
    };
    let (half, turn) = if slanted {
        (0.05, -std::f64::consts::FRAC_PI_4)
    } else {
        (0.5, 0.0)
    };
    let centre = q - n * half;
    let mut wall_co = ColliderBuilder::cuboid(real(half), 1.0, 1.0).friction(0.0);
    wall_co = match refused {
        WallRefused::No => wall_co,
        WallRefused::ByGroups => wall_co.collision_groups(InteractionGroups::new(
            Group::GROUP_2,
            Group::NONE,
            InteractionTestMode::And,
        )),
        WallRefused::ByUserFilter => wall_co.active_hooks(ActiveHooks::FILTER_CONTACT_PAIRS),
    };
    let (_, wall) = world.insert(
        RigidBodyBuilder::fixed()
            .translation(Vector::new(real(centre.x), 0.0, real(centre.z)))
            .rotation(Vector::new(0.0, real(turn), 0.0)),
        wall_co,
    );
    let b = ball(&mut world, [0.0, 0.0, 0.0], r, 0.0, 0.0);
    let config = ImpactConfig::default().with_timing(timing);
    let mut p = ImpactPlugin::with_hooks(config, GhostFilter::new(wall)).unwrap();
    let (bodies, colliders) = (&world.bodies, &world.colliders);
    p.add_ground_with_material(bodies, colliders, bat.face, GroundMaterial::new(e, 0.0))
        .unwrap();
    p.add_ground_with_material(bodies, colliders, wall, GroundMaterial::new(e_wall, 0.0))
        .unwrap();
    let (mut hits, mut inside) = (Vec::new(), Vec::new());
    for k in 0..3 {
        world.bodies[bat.body].set_next_kinematic_translation(bat.at(k + 1));
        p.step(&mut world);
        hits.extend(p.events().iter().map(|ev| (k, ev.ground == wall, *ev)));
        let at = na(world.bodies[b].translation());
        let into_bat = wide(bat.at(k + 1).x) + Bat::HALF - (at.x - r);
        inside.push((into_bat, r - n.dot(&(at - q))));
    }
    let end = na(world.bodies[b].linvel());
    (hits, (end.x, end.z), inside)
}

/// The bat at 12 and 30 m/s onto a ball at rest, without gravity, with a still wall
/// (friction 0, restitution 0.5) `0.75 V dt` behind the ball (15 and 37.5 cm): far beyond
/// anything the ball at rest could reach in a step, so only the bat's impact brings the wall
/// within reach. In the in-step modes the ball meets the wall in the same step, at `0.9 dt`,
/// at `(1 + e) V`, and leaves it at `e_w (1 + e) V`, and nothing else happens in the step
/// (the bat is then `0.25 V dt` from it, closing at `1.75 V`). In `Step` mode, after the
/// bat's impulse at the step's start, the wall's impact is the step's end one, at
/// `(1 + e) V`, with the same velocity after. Never inside the wall or the bat at a step's
/// end. The same wall slanted at 45 degrees, its box around the ball at rest (found near,
/// out of reach): met at `(1 + e) V / sqrt(2)`, leaving at `(1 + e) V (1/4, 0, -3/4)`. A
/// wall whose pairs rapier's collision groups or the user's filter refuse is passed through,
/// as in rapier alone: the bat's is the one impact. Stepped to the end of the impacts' step
/// only: the bat then pins the ball against the wall, which no closed form describes.
#[test]
fn a_ball_a_fast_bat_sends_into_a_wall_meets_it_in_the_step() {
    let e = 0.5;
    let (tt, tv) = tol();
    let walls = [
        (WallRefused::No, false),
        (WallRefused::No, true),
        (WallRefused::ByGroups, false),
        (WallRefused::ByUserFilter, false),
    ];
    for (v, (refused, slanted)) in [12.0, 30.0].into_iter().flat_map(|v| walls.map(|w| (v, w))) {
        for timing in MODES {
            let dt = wide(PhysicsWorld::default().integration_parameters.dt);
            let (hits, (vx, vz), inside) = bat_into_wall(v, timing, refused, slanted);
            let at = format!(
                "{timing:?}, bat at {v} m/s, a wall behind, refused {refused:?}, slanted {slanted}"
            );
            println!(
                "{at}: impacts (step, on the wall, timing, time / dt, approach) {:?}, ball \
                 (vx, vz) ({vx:.6}, {vz:.6})",
                hits.iter()
                    .map(|(k, w, ev)| (*k, *w, ev.timing, ev.time / dt, ev.approach_speed))
                    .collect::<Vec<_>>(),
            );
            let struck = (1.0 + e) * v;
            let (k_bat, on_wall, by_bat) = hits[0];
            assert_eq!((k_bat, on_wall), (2, false), "{at}");
            met_at(&by_bat, timing, 0.4 * dt, tt);
            assert_abs_diff_eq!(by_bat.approach_speed, v, epsilon = tv * v);
            if refused != WallRefused::No {
                assert_eq!(hits.len(), 1, "{at}");
                assert_abs_diff_eq!(vx, struck, epsilon = tv * v);
                continue;
            }
            for (k, (into_bat, into_wall)) in inside.into_iter().enumerate() {
                assert!(
                    into_bat < 1e-5,
                    "{at}: step {k} ends {into_bat:e} m into the bat"
                );
                assert!(
                    into_wall < 1e-5,
                    "{at}: step {k} ends {into_wall:e} m into the wall"
                );
            }
            assert_eq!(hits.len(), 2, "{at}");
            let (k_wall, on_wall, by_wall) = hits[1];
            assert_eq!((k_wall, on_wall), (2, true), "{at}");
            if timing == TimingMode::Step {
                assert_eq!(by_wall.timing, ImpactTiming::StepEnd, "{at}");
            } else {
                met_at(&by_wall, timing, 0.9 * dt, tt);
            }
            let (approach, after) = if slanted {
                (struck / 2f64.sqrt(), (0.25 * struck, -0.75 * struck))
            } else {
                (struck, (-0.5 * struck, 0.0))
            };
            assert_abs_diff_eq!(by_wall.approach_speed, approach, epsilon = tv * v);
            assert_abs_diff_eq!(vx, after.0, epsilon = tv * v);
            assert_abs_diff_eq!(vz, after.1, epsilon = tv * v);
        }
    }
}

/// A bat whose face is tilted 30 degrees down, moving along its normal
/// `(cos 30, -sin 30, 0)` at 30 m/s (and stopped after the step of the hit), onto a ball
/// resting on a floor, a half-space or a slab 2 cm thick (e = 0.5 everywhere): in the in-step
/// modes the floor's pair is rapier's resting contact, so the bat's is the step-end impact,
/// whose move out of the bat along its normal is 30 cm, down into the floor. The ball never
/// ends a step under the floor or through the slab (1e-4 m), and leaves along x. In `Step`
/// mode the floor's contact takes its bounce at the start of the bat's step
/// ([`bat_and_floor_at_one_start`]).
#[test]
fn a_bat_swung_down_onto_a_ball_resting_on_the_floor_never_drives_it_under() {
    let (r, v) = (0.1, 30.0);
    let cases = [30.0, 60.0]
        .into_iter()
        .flat_map(|tilt| [(tilt, false), (tilt, true)]);
    for (tilt, slab) in cases {
        let a = f64::to_radians(tilt);
        let n = Vector3::new(a.cos(), -a.sin(), 0.0);
        for timing in MODES {
            let mut world = PhysicsWorld::default();
            let dt = wide(world.integration_parameters.dt);
            let floor = if slab {
                ColliderBuilder::cuboid(5.0, 0.01, 5.0).translation(Vector::new(0.0, -0.01, 0.0))
            } else {
                ColliderBuilder::halfspace(up())
            };
            let (_, floor) = world.insert(RigidBodyBuilder::fixed(), floor.restitution(0.5));
            let b = ball(&mut world, [0.0, r, 0.0], r, 0.5, 0.5);
            // The face meets the ball 8 cm above its own centre, 2.4 steps in.
            let along_face = Vector3::new(a.sin(), a.cos(), 0.0);
            let centre = |k: f64| {
                let c = Vector3::new(0.0, r, 0.0) - n * (r + 0.05) + along_face * 0.08
                    - n * v * dt * (2.4 - k.min(3.0));
                Vector::new(real(c.x), real(c.y), real(c.z))
            };
            let (bat, face) = world.insert(
                RigidBodyBuilder::kinematic_position_based()
                    .translation(centre(0.0))
                    .rotation(Vector::new(0.0, 0.0, real(-a))),
                ColliderBuilder::cuboid(0.05, 0.12, 0.3)
                    .restitution(0.5)
                    .friction(0.0),
            );
            let mut p = plugin_on(&world, floor, timing);
            p.add_ground(&world.bodies, &world.colliders, face).unwrap();
            let at = format!("{timing:?}, tilted {tilt} degrees, slab {slab}");
            let mut ends = Vec::new();
            let mut starts = Vec::new();
            for k in 0..6 {
                world.bodies[bat].set_next_kinematic_translation(centre(k as f64 + 1.0));
                p.step(&mut world);
                let rb = &world.bodies[b];
                ends.push((wide(rb.translation().y), na(rb.linvel())));
                starts.extend(
                    p.events()
                        .iter()
                        .filter(|e| e.timing == ImpactTiming::StepStart)
                        .map(|e| (k, e.ground == face, *e)),
                );
            }
            println!("{at}: (y, v) at each step's end {ends:.4?}");
            if timing == TimingMode::Step {
                let m = wide(world.bodies[b].mass());
                bat_and_floor_at_one_start(&at, &starts, (v, a, m));
            }
            for (k, (y, _)) in ends.iter().enumerate() {
                assert!(
                    *y - r > -1e-4,
                    "{at}: step {k} ends {:e} m under the floor",
                    r - y
                );
            }
            let (_, v_end) = ends[5];
            // The bat's `(1 + e) V cos(tilt)` along x, 5/7 of it left by the floor's sticking
            // impact.
            let along = 1.5 * v * a.cos() * 5.0 / 7.0;
            assert!(v_end.x > 0.8 * along, "{at}: the ball left at {v_end:?}");
        }
    }
}

/// `Step` mode's impulses in
/// [`a_bat_swung_down_onto_a_ball_resting_on_the_floor_never_drives_it_under`] (`starts`: the
/// step, whether on the bat, and the event of each `StepStart` impulse; bat speed `v`, tilt
/// `a`, ball mass `m`): the bat's at the start of the step it closes in (2.4 steps: the
/// third), the ball leaving it at `(1 + e) V n`; the floor's contact, which that drives into
/// the floor, closes at the same start: its impulse reverses `(1 + e) V sin(tilt)` times e,
/// and the ball sticks (solid ball: 2/7 of the slip taken,
/// `(2/7) (1 + e) V cos(tilt) <= mu (1 + e) (1 + e) V sin(tilt)`).
fn bat_and_floor_at_one_start(
    at: &str,
    starts: &[(usize, bool, ImpactEvent)],
    (v, a, m): (f64, f64, f64),
) {
    let e = 0.5;
    let down = (1.0 + e) * v * a.sin();
    let along = (1.0 + e) * v * a.cos();
    let floor_dv = Vector3::new(-2.0 / 7.0 * along, (1.0 + e) * down, 0.0);
    for (k, on_bat, ev) in starts {
        println!(
            "{at}: step {k}, {}: approach {:.6}, impulse / m {:.6?}",
            if *on_bat { "bat" } else { "floor" },
            ev.approach_speed,
            na(ev.impulse) / m
        );
    }
    assert_eq!(starts.len(), 2, "{at}: {starts:?}");
    let ((k0, on_bat, by_bat), (k1, on_floor, by_floor)) = (starts[0], starts[1]);
    assert_eq!((k0, on_bat, k1, on_floor), (2, true, 2, false), "{at}");
    assert_abs_diff_eq!(by_bat.approach_speed, v, epsilon = 1e-4 * v);
    assert_abs_diff_eq!(by_floor.approach_speed, down, epsilon = 1e-4 * v);
    let dv = na(by_floor.impulse) / m;
    assert!(
        (dv - floor_dv).norm() < 1e-4 * v,
        "{at}: {dv:?} against {floor_dv:?}"
    );
}

/// A ball asleep beside fast kinematic grounds that cannot reach it: on the floor, a bat 1 cm
/// away receding at 12 m/s, one passing along it at 12 m/s, and one swung through it at
/// 12 m/s whose collision groups refuse it; and on a platform sliding under it at 1 m/s (a
/// conveyor). The plugin wakes it no more than rapier alone does: after
/// 10 steps it sleeps exactly when it sleeps in rapier alone.
#[test]
fn a_ball_asleep_beside_a_fast_ground_that_cannot_reach_it_stays_asleep() {
    let r = 0.1;
    // (label, the ground's centre, its velocity, its half extents, the ball's lowest point,
    // whether the ground's collision groups refuse the ball)
    let bat = [0.05, 0.3, 0.3];
    let cases = [
        (
            "a bat receding",
            [-r - 0.06, r, 0.0],
            [-12.0, 0.0, 0.0],
            bat,
            0.0,
            false,
        ),
        (
            "a bat the collision groups pass through the ball",
            [-r - 0.06, r, 0.0],
            [12.0, 0.0, 0.0],
            bat,
            0.0,
            true,
        ),
        (
            "a bat passing",
            [-r - 0.06, r, 0.0],
            [0.0, 0.0, 12.0],
            bat,
            0.0,
            false,
        ),
        (
            "a conveyor under it",
            [0.0, -0.04, 0.0],
            [1.0, 0.0, 0.0],
            [2.0, 0.05, 2.0],
            0.01,
            false,
        ),
    ];
    for (label, at, v, half, bottom, refused) in cases {
        let run = |mode: Option<TimingMode>| {
            let mut world = PhysicsWorld::default();
            let (_, floor) =
                world.insert(RigidBodyBuilder::fixed(), ColliderBuilder::halfspace(up()));
            let (platform, ground) = world.insert(
                RigidBodyBuilder::kinematic_velocity_based().translation(Vector::new(
                    real(at[0]),
                    real(at[1]),
                    real(at[2]),
                )),
                ColliderBuilder::cuboid(real(half[0]), real(half[1]), real(half[2]))
                    .collision_groups(if refused {
                        InteractionGroups::new(
                            Group::GROUP_2,
                            Group::NONE,
                            InteractionTestMode::And,
                        )
                    } else {
                        InteractionGroups::all()
                    }),
            );
            let b = ball(&mut world, [0.0, bottom + r, 0.0], r, 0.0, 0.5);
            let mut p = mode.map(|timing| {
                let mut p = plugin_on(&world, floor, timing);
                p.add_ground(&world.bodies, &world.colliders, ground)
                    .unwrap();
                p
            });
            let mut step = |world: &mut PhysicsWorld| match p.as_mut() {
                Some(p) => p.step(world),
                None => world.step(),
            };
            // Asleep once the insertions' wake-ups are past, the ground standing still; then
            // the ground starts.
            for k in 0..3 {
                if k == 2 {
                    world.bodies[b].sleep();
                }
                step(&mut world);
            }
            assert!(world.bodies[b].is_sleeping(), "{label}: the ball is awake");
            let v = Vector::new(real(v[0]), real(v[1]), real(v[2]));
            world.bodies[platform].set_linvel(v, true);
            for _ in 0..10 {
                step(&mut world);
            }
            world.bodies[b].is_sleeping()
        };
        let alone = run(None);
        for mode in MODES {
            let with = run(Some(mode));
            println!("{label}, {mode:?}: asleep {with} (rapier alone {alone})");
            assert_eq!(with, alone, "{label}, {mode:?}");
        }
    }
}

/// A blade (a position-based kinematic box 1 m long, 10 cm thick, friction 0) spun about its
/// middle at 30 rad/s (half a radian a step) onto a ball at rest 0.35 m from its axis,
/// without gravity: only the blade's turn brings them together. One impact leaves the ball
/// at `(1 + e)` times the approach speed (the blade's mass is infinite); in the in-step modes
/// at 1.4 steps, where the face is `r + h` from the ball's centre, the approach speed being
/// the turn's at the contact, `omega R cos(asin((r + h) / R))`. The ball is never inside the
/// blade at a step's end.
#[test]
fn a_fast_blade_meets_a_ball_at_rest_in_the_step() {
    let (e, r, h, reach, omega) = (0.5, 0.05, 0.05, 0.35, 30.0);
    let (tt, tv) = tol();
    let touch = ((r + h) / reach).asin();
    let approach = omega * reach * touch.cos();
    for timing in MODES {
        let mut world = weightless();
        let dt = wide(world.integration_parameters.dt);
        // The blade lies along x at angle `angle(k)` after `k` steps; the ball at angle 0.
        let angle = |k: usize| -touch - 1.4 * omega * dt + omega * k as f64 * dt;
        let turned = |k: usize| Rotation::from_rotation_z(real(angle(k)));
        let (blade, face) = world.insert(
            RigidBodyBuilder::kinematic_position_based().rotation(turned(0).to_scaled_axis()),
            ColliderBuilder::cuboid(0.5, real(h), 0.3).friction(0.0),
        );
        let b = ball(&mut world, [reach, 0.0, 0.0], r, 0.0, 0.0);
        let mut p = plugin_with_material(&world, face, timing, e, 0.0);
        let mut hits = Vec::new();
        for k in 0..4 {
            world.bodies[blade].set_next_kinematic_rotation(turned(k + 1));
            p.step(&mut world);
            hits.extend(p.events().iter().map(|ev| (k, *ev)));
            let (bc, fc) = (
                &world.colliders[world.bodies[b].colliders()[0]],
                &world.colliders[face],
            );
            // The deepest penetration, if they overlap (parry's signed distance).
            let depth = rapier_impact::rapier::parry::query::contact(
                fc.position(),
                fc.shape(),
                bc.position(),
                bc.shape(),
                0.0,
            )
            .unwrap()
            .map_or(0.0, |c| -wide(c.dist));
            assert!(
                depth < 1e-5,
                "{timing:?}: step {k} ends with the ball {depth:e} m inside the blade"
            );
        }
        let speed = wide(world.bodies[b].linvel().length());
        println!(
            "{timing:?}, blade at {omega} rad/s: impacts {:?}, ball speed {speed:.6} (expected {:.6} in-step)",
            hits.iter()
                .map(|(k, ev)| (*k, ev.timing, ev.time / dt, ev.approach_speed))
                .collect::<Vec<_>>(),
            (1.0 + e) * approach
        );
        assert_eq!(hits.len(), 1, "{timing:?}");
        let (k, ev) = hits[0];
        assert_eq!(k, 1, "{timing:?}");
        assert_abs_diff_eq!(speed, (1.0 + e) * ev.approach_speed, epsilon = tv * speed);
        met_at(&ev, timing, 0.4 * dt, tt);
        if timing != TimingMode::Step {
            assert_abs_diff_eq!(ev.approach_speed, approach, epsilon = tv * approach);
        }
    }
}

#[test]
fn step_mode_on_a_rising_platform_uses_the_step_boundary_velocity() {
    let (v_up, e, h) = (1.0, 0.6, 0.5);
    let (mut world, mut p, b, platform) = rising_position_platform(TimingMode::Step, e, h);
    let dt = wide(world.integration_parameters.dt);
    let (_, tv) = tol();
    let mut bounced_at = None;
    for k in 0..120 {
        let v0 = wide(world.bodies[b].linvel().y);
        move_platform(&mut world, platform, k, v_up);
        p.step(&mut world);
        let events: Vec<_> = p.events().to_vec();
        if let Some(ev) = events.first() {
            if let Some(k0) = bounced_at {
                panic!("a second impact {} steps after the first: {ev:?}", k - k0);
            }
            // The impulse at the step start, on the velocity there; rapier then adds g dt.
            let expected = v_up - e * (v0 - v_up);
            let vy = wide(world.bodies[b].linvel().y) + G * dt;
            println!(
                "Step mode, platform at {v_up} m/s: {:?}, vy after {vy:.6} (expected {expected:.6}), approach {:.6} (expected {:.6})",
                ev.timing,
                ev.approach_speed,
                v_up - v0
            );
            assert_eq!(events.len(), 1);
            assert_eq!(ev.timing, ImpactTiming::StepStart);
            assert_abs_diff_eq!(vy, expected, epsilon = tv.max(1e-5));
            assert_abs_diff_eq!(ev.approach_speed, v_up - v0, epsilon = tv.max(1e-5));
            bounced_at = Some(k);
        }
        // Rising with the ball: the ball leaves it and must not be bounced by rapier on the
        // way (its speed after is the model's, checked above) nor sink into it.
        if let Some(k0) = bounced_at {
            let rb = &world.bodies[b];
            let top = -0.5 + v_up * (k + 1) as f64 * dt + 0.5;
            let gap = wide(rb.translation().y) - 0.1 - top;
            assert!(
                gap > -5e-3,
                "step {k}: the ball is {gap} m into the platform"
            );
            if k > k0 + 10 {
                return;
            }
        }
    }
    panic!("the ball never met the platform");
}

/// A turntable (kinematic, velocity-based, top face at y = 0) spinning at `omega` about the
/// vertical through the origin; a solid ball (no spin) dropped at `(r, h, 0)` meets it where
/// the table moves at `w x r = (0, 0, -omega r)`.
fn turntable(mu: f64) {
    let (omega, r_pos, e, h, radius) = (2.0, 1.0, 0.6, 0.5, 0.1);
    let table = |world: &mut PhysicsWorld| {
        world.insert(
            RigidBodyBuilder::kinematic_velocity_based()
                .translation(Vector::new(0.0, -0.5, 0.0))
                .angvel(Vector::new(0.0, real(omega), 0.0)),
            ColliderBuilder::cuboid(3.0, 0.5, 3.0),
        )
    };
    // rapier turns a velocity-based kinematic body by its substeps' linearised rotations:
    // slightly less than `omega dt` per step (5.8e-6 relative here). The plugin takes the
    // ground's velocity from its actual motion over the step, so the closed form does too.
    let omega_eff = {
        let mut world = PhysicsWorld::default();
        let (body, _) = table(&mut world);
        world.step();
        let q = world.bodies[body].rotation();
        2.0 * wide(q.y).atan2(wide(q.w)) / wide(world.integration_parameters.dt)
    };
    println!("turntable: nominal {omega} rad/s, rapier turns it at {omega_eff:.9} rad/s");
    let mut world = PhysicsWorld::default();
    let (_, ground) = table(&mut world);
    let b = ball(&mut world, [r_pos, radius + h, 0.0], radius, 0.0, 0.0);
    let mut p = plugin_with_material(&world, ground, TimingMode::Exact, e, mu);
    let t_hit = fall_time(h);
    let un = G * t_hit;
    // Platform frame: the contact's tangential velocity is u_t = v_t - v_ground = omega r z.
    let ut = omega_eff * r_pos;
    let stick = mu * (1.0 + e) * un >= 2.0 / 7.0 * ut;
    // Stick: J_t = -2/7 m u_t; slip: |J_t| = mu (1 + e) m u_n.
    let dvz = if stick {
        -2.0 / 7.0 * ut
    } else {
        -mu * (1.0 + e) * un
    };
    let expected_v = Vector3::new(0.0, e * un, dvz);
    // Spin from the tangential impulse at the offset -R y: w_x = -5/2 dvz / R.
    let expected_w = Vector3::new(-2.5 * dvz / radius, 0.0, 0.0);
    let (tt, tv) = tol();
    let (t, ev, v, w) =
        first_impact(&mut world, &mut p, b).expect("the ball never met the turntable");
    let slip_after = v.z - w.x * radius + omega_eff * r_pos;
    println!(
        "turntable mu {mu} ({}): impact {t:.7} s (expected {t_hit:.7}), v' {v:.6?} (expected {expected_v:.6?}), w' {w:.5?} (expected {expected_w:.5?}), contact slip after (platform frame) {slip_after:.2e}, regime {:?}",
        if stick { "stick" } else { "slip" },
        ev.regime
    );
    assert_abs_diff_eq!(t, t_hit, epsilon = tt);
    assert!((v - expected_v).norm() < tv, "v' {v:?} vs {expected_v:?}");
    assert!(
        (w - expected_w).norm() < tv / radius,
        "w' {w:?} vs {expected_w:?}"
    );
}

#[test]
fn a_turntable_grips_a_ball_by_its_surface_velocity() {
    turntable(0.5);
}

#[test]
fn a_turntable_drags_a_slipping_ball_by_its_surface_velocity() {
    turntable(0.05);
}

// ---------------------------------------------------------------------------------------
// Sloped heightfield and trimesh
// ---------------------------------------------------------------------------------------

/// The slope: `y = -x tan(a)`, normal `(sin a, cos a, 0)`.
const SLOPE_DEG: f64 = 20.0;

fn slope_normal() -> Vector3<f64> {
    let a = SLOPE_DEG.to_radians();
    Vector3::new(a.sin(), a.cos(), 0.0)
}

fn ramp_heightfield() -> ColliderBuilder {
    // 5 x 5 samples over 10 m x 10 m; rows along z, columns along x (parry's layout).
    let tan = SLOPE_DEG.to_radians().tan();
    let (n, size) = (5, 10.0);
    let mut heights = vec![Real::default(); n * n];
    for j in 0..n {
        let x = (-0.5 + j as f64 / (n - 1) as f64) * size;
        for i in 0..n {
            heights[i + j * n] = real(-x * tan);
        }
    }
    ColliderBuilder::heightfield(
        Array2::new(n, n, heights),
        Vector::new(real(size), 1.0, real(size)),
    )
}

fn ramp_trimesh() -> ColliderBuilder {
    let tan = SLOPE_DEG.to_radians().tan();
    let l = 5.0;
    let v = |x: f64, z: f64| Vector::new(real(x), real(-x * tan), real(z));
    ColliderBuilder::trimesh(
        vec![v(-l, -l), v(l, -l), v(l, l), v(-l, l)],
        vec![[0, 2, 1], [0, 3, 2]],
    )
    .unwrap()
}

fn check_ramp(label: &str, shape: ColliderBuilder) {
    let (e, mu, h, radius, x0) = (0.7, 0.3, 1.0, 0.1, 0.3);
    let mut world = PhysicsWorld::default();
    let (_, ground) = world.insert(RigidBodyBuilder::fixed(), shape);
    let b = ball(&mut world, [x0, h, 0.2], radius, 0.0, 0.0);
    let mut p = plugin_with_material(&world, ground, TimingMode::Exact, e, mu);
    let n = slope_normal();
    // The centre touches when n . c = R: sin(a) x0 + cos(a) y = R.
    let y_hit = (radius - n.x * x0) / n.y;
    let t_hit = (2.0 * (h - y_hit) / G).sqrt();
    let m = 4.0 / 3.0 * std::f64::consts::PI * radius.powi(3);
    let body = Body::from_inertia(m, Matrix3::identity() * (0.4 * m * radius * radius)).unwrap();
    let impact = model::resolve(
        Law::Guarded,
        &body,
        &BodyVelocity {
            linear: Vector3::new(0.0, -G * t_hit, 0.0),
            angular: Vector3::zeros(),
        },
        &Contact::fixed(n, -n * radius),
        &Material::new(e, mu),
    )
    .unwrap();
    let (tt, tv) = tol();
    let (t, ev, v, w) = first_impact(&mut world, &mut p, b)
        .unwrap_or_else(|| panic!("{label}: the ball never hit"));
    let normal = na(ev.normal);
    let (dir, speed) = (v.normalize(), v.norm());
    let (dir_m, speed_m) = (
        impact.velocity.linear.normalize(),
        impact.velocity.linear.norm(),
    );
    println!(
        "{label} at {SLOPE_DEG} deg: impact {t:.7} s (expected {t_hit:.7}), normal {normal:.6?} (expected {n:.6?}), bounce direction {dir:.6?} (model {dir_m:.6?}), speed {speed:.6} (model {speed_m:.6}), w' {w:.4?} (model {:.4?}), regime {:?} (model {:?})",
        impact.velocity.angular, ev.regime, impact.regime
    );
    assert_abs_diff_eq!(t, t_hit, epsilon = tt);
    assert!(
        (normal - n).norm() < 1e-5,
        "{label}: normal {normal:?} vs {n:?}"
    );
    assert!(
        (v - impact.velocity.linear).norm() < tv,
        "{label}: v' {v:?} vs {:?}",
        impact.velocity.linear
    );
    assert!(
        (w - impact.velocity.angular).norm() < tv / radius,
        "{label}: w' {w:?} vs {:?}",
        impact.velocity.angular
    );
    assert_eq!(ev.regime, impact.regime, "{label}");
}

#[test]
fn a_sloped_heightfield_bounces_by_the_model_at_its_normal() {
    check_ramp("heightfield ramp", ramp_heightfield());
}

#[test]
fn a_sloped_trimesh_bounces_by_the_model_at_its_normal() {
    check_ramp("trimesh ramp", ramp_trimesh());
}

// ---------------------------------------------------------------------------------------
// A wrapped user hook
// ---------------------------------------------------------------------------------------

/// A user hook: a conveyor (every contact it modifies gets a tangent velocity of 1 m/s
/// along x) and a filter that refuses the pairs of one "ghost" collider; both record the
/// pairs they are asked about.
struct Conveyor {
    filter: GhostFilter,
    modified: Pairs,
}

impl PhysicsHooks for Conveyor {
    fn filter_contact_pair(&self, context: &PairFilterContext) -> Option<SolverFlags> {
        self.filter.filter(context)
    }

    fn modify_solver_contacts(&self, context: &mut ContactModificationContext) {
        // Recorded when there is a contact to modify: rapier also calls the hook for a
        // pair whose manifold has none (a ball far above a half-space ground, whose AABB
        // every body meets), as it would without the plugin.
        let has_contacts = context
            .rigid_mut()
            .is_some_and(|m| !m.solver_contacts.is_empty());
        if has_contacts {
            self.modified
                .lock()
                .unwrap()
                .push((context.collider1, context.collider2));
        }
        if let Some(m) = context.rigid_mut() {
            for c in m.solver_contacts.iter_mut() {
                c.tangent_velocity = Vector::new(1.0, 0.0, 0.0);
            }
        }
    }
}

/// The conveyor scene: the bodies and colliders the checks read.
struct ConveyorScene {
    world: PhysicsWorld,
    /// The managed ground, a conveyor too.
    ground: ColliderHandle,
    /// A conveyor platform that is not ground, and the box resting on it.
    platform: ColliderHandle,
    on_platform: RigidBodyHandle,
    on_platform_co: ColliderHandle,
    /// A box resting on the ground (a managed resting pair).
    on_ground: RigidBodyHandle,
    /// A box on the ground that the plugin is to exclude.
    excluded: RigidBodyHandle,
    excluded_co: ColliderHandle,
    /// A ball that bounces on the ground.
    bouncer: RigidBodyHandle,
    bouncer_co: ColliderHandle,
    /// A ball the user's filter lets fall through the ground.
    ghost: RigidBodyHandle,
    ghost_co: ColliderHandle,
}

fn conveyor_scene() -> ConveyorScene {
    let both = ActiveHooks::FILTER_CONTACT_PAIRS | ActiveHooks::MODIFY_SOLVER_CONTACTS;
    let mut world = PhysicsWorld::default();
    // The managed ground, a conveyor ground too (its user flags ask for both hooks).
    let (_, ground) = world.insert(
        RigidBodyBuilder::fixed(),
        ColliderBuilder::halfspace(up())
            .restitution(0.5)
            .active_hooks(both),
    );
    // A conveyor platform that is not ground, with a box resting on it.
    let (_, platform) = world.insert(
        RigidBodyBuilder::fixed().translation(Vector::new(10.0, 1.0, 0.0)),
        ColliderBuilder::cuboid(3.0, 0.1, 1.0).active_hooks(both),
    );
    let (on_platform, on_platform_co) = world.insert(
        RigidBodyBuilder::dynamic().translation(Vector::new(10.0, 1.2, 0.0)),
        ColliderBuilder::cuboid(0.1, 0.1, 0.1),
    );
    // A box resting on the conveyor ground (a managed resting pair), a body the plugin
    // excludes on the ground, a ball that bounces on it, and a ghost ball the user's filter
    // lets fall through it.
    let (on_ground, _) = world.insert(
        RigidBodyBuilder::dynamic().translation(Vector::new(-10.0, 0.1, 0.0)),
        ColliderBuilder::cuboid(0.1, 0.1, 0.1),
    );
    let (excluded, excluded_co) = world.insert(
        RigidBodyBuilder::dynamic().translation(Vector::new(-20.0, 0.1, 0.0)),
        ColliderBuilder::cuboid(0.1, 0.1, 0.1),
    );
    let (bouncer, bouncer_co) = world.insert(
        RigidBodyBuilder::dynamic().translation(Vector::new(0.0, 0.6, 0.0)),
        ColliderBuilder::ball(0.1).restitution(0.5),
    );
    let (ghost, ghost_co) = world.insert(
        RigidBodyBuilder::dynamic().translation(Vector::new(5.0, 0.6, 0.0)),
        ColliderBuilder::ball(0.1).restitution(0.5),
    );
    ConveyorScene {
        world,
        ground,
        platform,
        on_platform,
        on_platform_co,
        on_ground,
        excluded,
        excluded_co,
        bouncer,
        bouncer_co,
        ghost,
        ghost_co,
    }
}

#[test]
fn a_wrapped_hooks_filter_and_contact_modification_still_apply() {
    let ConveyorScene {
        mut world,
        ground,
        platform,
        on_platform,
        on_platform_co,
        on_ground,
        excluded,
        excluded_co,
        bouncer,
        bouncer_co,
        ghost,
        ghost_co,
    } = conveyor_scene();
    let hooks = Conveyor {
        filter: GhostFilter::new(ghost_co),
        modified: Pairs::default(),
    };
    let mut p = ImpactPlugin::with_hooks(ImpactConfig::default(), hooks).unwrap();
    p.add_ground(&world.bodies, &world.colliders, ground)
        .unwrap();
    p.exclude_body(excluded);
    let (mut bounces, mut modified_in_impact) = (0, false);
    for _ in 0..60 {
        p.step(&mut world);
        let n = p.events().iter().filter(|e| e.body == bouncer).count();
        bounces += n;
        // Up to its first bounce the ball's pair is a managed impact: never the user's to
        // modify (resting on the conveyor ground later, it is).
        if bounces == n {
            modified_in_impact |= saw(&p.user_hooks().modified, ground, bouncer_co);
        }
        assert!(
            p.events().iter().all(|e| e.body != ghost),
            "the ghost was bounced"
        );
    }
    let h = p.user_hooks();
    let x = |b: RigidBodyHandle| wide(world.bodies[b].translation().x);
    let ghost_y = wide(world.bodies[ghost].translation().y);
    println!(
        "user hook: filter saw platform-box {}, excluded-ground {}, ghost-ground {}, bouncer-ground {}; modify saw platform-box {}, excluded-ground {}",
        saw(&h.filter.seen, platform, on_platform_co),
        saw(&h.filter.seen, ground, excluded_co),
        saw(&h.filter.seen, ground, ghost_co),
        saw(&h.filter.seen, ground, bouncer_co),
        saw(&h.modified, platform, on_platform_co),
        saw(&h.modified, ground, excluded_co),
    );
    println!(
        "conveyed over 1 s: box on the platform {:+.3} m, box on the conveyor ground {:+.3} m, excluded box {:+.3} m (belt 1 m/s); ghost y {ghost_y:.3}; {bounces} bounce(s) of the ball",
        x(on_platform) - 10.0,
        x(on_ground) + 10.0,
        x(excluded) + 20.0
    );
    assert!(saw(&h.filter.seen, platform, on_platform_co));
    assert!(saw(&h.modified, platform, on_platform_co));
    assert!(saw(&h.filter.seen, ground, excluded_co));
    assert!(saw(&h.modified, ground, excluded_co));
    assert!(
        !modified_in_impact,
        "the user's contact modification ran on a managed impact"
    );
    // The belts move what rests on them (rapier's friction drags a box towards 1 m/s).
    assert!(
        x(on_platform) - 10.0 > 0.3,
        "the platform conveyor did not convey"
    );
    assert!(
        x(excluded) + 20.0 > 0.3,
        "the ground conveyor did not convey an excluded box"
    );
    assert!(
        x(on_ground) + 10.0 > 0.3,
        "the ground conveyor did not convey a resting managed box"
    );
    assert!(
        ghost_y < -1.0,
        "the ghost did not fall through the ground: y = {ghost_y}"
    );
    assert!(bounces >= 1, "the ball never bounced");
}

// ---------------------------------------------------------------------------------------
// A floor of flush tiles: one ground to the plan
// ---------------------------------------------------------------------------------------

/// Side of the tiled floor (m), and of one of its `TILES x TILES` tiles.
const FLOOR: f64 = 2.0;
const TILES: usize = 8;

/// The floor, top at y = 0, 0.5 m thick, centred on the origin: one cuboid (`tiled` false)
/// or `TILES x TILES` flush tiles, each on a fixed body of its own, in rows of increasing
/// `x` then `z` (returned in that order).
fn floor(world: &mut PhysicsWorld, tiled: bool) -> Vec<ColliderHandle> {
    let n = if tiled { TILES } else { 1 };
    let side = FLOOR / n as f64;
    let mut out = Vec::new();
    for i in 0..n {
        for k in 0..n {
            let centre = |j: usize| -0.5 * FLOOR + (j as f64 + 0.5) * side;
            out.push(
                world
                    .insert(
                        RigidBodyBuilder::fixed(),
                        ColliderBuilder::cuboid(real(0.5 * side), 0.25, real(0.5 * side))
                            .translation(Vector::new(real(centre(i)), -0.25, real(centre(k))))
                            .restitution(0.6)
                            .friction(0.4),
                    )
                    .1,
            );
        }
    }
    out
}

/// The tile of `floor(_, true)` under the point `(x, z)`.
fn tile_under(tiles: &[ColliderHandle], x: f64, z: f64) -> ColliderHandle {
    let side = FLOOR / TILES as f64;
    let at = |c: f64| (((c + 0.5 * FLOOR) / side).floor() as usize).min(TILES - 1);
    tiles[at(x) * TILES + at(z)]
}

/// What `thrown_on_floor` measured: the balls' states after every step, the events (each
/// with its ball's number), the most ground pairs planned as impacts in a step, the grounds.
type Thrown = (
    Vec<Vec<[f64; 6]>>,
    Vec<(usize, ImpactEvent)>,
    usize,
    Vec<ColliderHandle>,
);

/// Balls thrown onto the floor at seams, at a corner where four tiles meet, and mid-tile,
/// with spin.
fn thrown_on_floor(mode: TimingMode, tiled: bool) -> Thrown {
    let mut world = PhysicsWorld::default();
    let grounds = floor(&mut world, tiled);
    let side = FLOOR / TILES as f64;
    let starts = [
        (0.0, 0.0),                // the corner of four tiles
        (side, 0.3 * side),        // a seam along z
        (0.4 * side, -side),       // a seam along x
        (-0.5 * side, 0.5 * side), // mid-tile
        (0.7, -0.7),
    ];
    let balls: Vec<RigidBodyHandle> = starts
        .iter()
        .enumerate()
        .map(|(k, (x, z))| {
            world
                .insert(
                    RigidBodyBuilder::dynamic()
                        .translation(Vector::new(real(*x), real(0.3 + 0.07 * k as f64), real(*z)))
                        .linvel(Vector::new(
                            real(0.8 - 0.3 * k as f64),
                            0.0,
                            real(0.2 * k as f64),
                        ))
                        .angvel(Vector::new(real(3.0), real(-1.0), real(2.0 * k as f64))),
                    ColliderBuilder::ball(0.05).restitution(0.6).friction(0.4),
                )
                .0
        })
        .collect();
    let mut p = ImpactPlugin::new(ImpactConfig::default().with_timing(mode)).unwrap();
    for g in &grounds {
        p.add_ground(&world.bodies, &world.colliders, *g).unwrap();
    }
    p.set_profiling(true);
    let (mut states, mut events, mut impact_pairs) = (Vec::new(), Vec::new(), 0);
    for _ in 0..50 {
        p.step(&mut world);
        states.push(
            balls
                .iter()
                .map(|b| {
                    let rb = &world.bodies[*b];
                    let (t, v) = (rb.translation(), rb.linvel());
                    [t.x, t.y, t.z, v.x, v.y, v.z].map(wide)
                })
                .collect(),
        );
        for e in p.events() {
            let k = balls.iter().position(|b| *b == e.body).unwrap();
            events.push((k, *e));
        }
        impact_pairs = impact_pairs.max(p.profile().unwrap().counts.impact_pairs);
    }
    (states, events, impact_pairs, grounds)
}

/// A floor of 8 x 8 flush tiles of one material is one ground to the plan (one box): balls
/// thrown onto its seams and onto the corner where four tiles meet bounce exactly as on one
/// cuboid of the floor's size, in every mode, each with one ground pair planned as an
/// impact, not one per tile within its reach; each event names the tile under its point.
#[test]
fn a_floor_of_flush_tiles_bounces_as_one_cuboid() {
    for mode in [
        TimingMode::Step,
        TimingMode::TimeOfImpact,
        TimingMode::Exact,
    ] {
        let (one, one_events, one_pairs, _) = thrown_on_floor(mode, false);
        let (tiled, events, pairs, tiles) = thrown_on_floor(mode, true);
        let mut worst: f64 = 0.0;
        for (a, b) in one.iter().zip(&tiled) {
            for (sa, sb) in a.iter().zip(b) {
                for (x, y) in sa.iter().zip(sb) {
                    worst = worst.max((x - y).abs());
                }
            }
        }
        let impacts = events
            .iter()
            .filter(|(_, e)| e.kind == EventKind::Impact)
            .count();
        println!(
            "{mode:?}: tiled floor vs one cuboid, largest difference of a coordinate or velocity {worst:e}; {impacts} impacts ({} on one cuboid); impact pairs a step at most {pairs} ({one_pairs} on one cuboid)",
            one_events
                .iter()
                .filter(|(_, e)| e.kind == EventKind::Impact)
                .count()
        );
        assert_eq!(
            worst, 0.0,
            "{mode:?}: the tiled floor moved a ball differently"
        );
        assert!(impacts >= 5, "{mode:?}: only {impacts} impacts");
        assert_eq!(events.len(), one_events.len());
        for ((k, e), (j, o)) in events.iter().zip(&one_events) {
            assert_eq!((k, e.kind, e.time), (j, o.kind, o.time));
            let (x, z) = (wide(e.point.x), wide(e.point.z));
            assert_eq!(e.ground, tile_under(&tiles, x, z), "{mode:?}: {e:?}");
        }
        assert_eq!(pairs, one_pairs, "{mode:?}: a pair per tile");
    }
}

/// The user's filter decides a body's pairs one by one: a ball whose collider asks for it
/// meets the tiles, not their box. The filter refuses the floor's first tile (the one that
/// stands for the slab in the plugin's tables): the asking ball dropped over it falls
/// through; the asking ball over the next tile, and a ball that does not ask dropped over
/// the refused tile, bounce, each off the tile under it.
#[test]
fn a_users_filter_refusing_one_tile_lets_a_ball_through_that_tile_only() {
    let mut world = PhysicsWorld::default();
    let tiles = floor(&mut world, true);
    let side = FLOOR / TILES as f64;
    let (x_ghost, x_next, z) = (-0.5 * FLOOR + 0.5 * side, -0.5 * FLOOR + 1.5 * side, -0.9);
    let ghost_tile = tile_under(&tiles, x_ghost, z);
    assert_eq!(ghost_tile, tiles[0]);
    let drop = |world: &mut PhysicsWorld, x: f64, hooks: ActiveHooks| {
        world
            .insert(
                RigidBodyBuilder::dynamic().translation(Vector::new(real(x), 0.3, real(z))),
                ColliderBuilder::ball(0.05)
                    .restitution(0.6)
                    .active_hooks(hooks),
            )
            .0
    };
    let asks = ActiveHooks::FILTER_CONTACT_PAIRS;
    let through = drop(&mut world, x_ghost, asks);
    let bouncers = [
        (
            drop(&mut world, x_next, asks),
            tile_under(&tiles, x_next, z),
        ),
        (drop(&mut world, x_ghost, ActiveHooks::empty()), ghost_tile),
    ];
    let mut p =
        ImpactPlugin::with_hooks(ImpactConfig::default(), GhostFilter::new(ghost_tile)).unwrap();
    for g in &tiles {
        p.add_ground(&world.bodies, &world.colliders, *g).unwrap();
    }
    let mut bounced_on = Vec::new();
    for _ in 0..60 {
        p.step(&mut world);
        for e in p.events() {
            assert_ne!(
                e.body, through,
                "the ball over the refused tile was bounced"
            );
            bounced_on.push((e.body, e.ground));
        }
    }
    let y = wide(world.bodies[through].translation().y);
    println!(
        "through the refused tile: y = {y:.3} m; {} bounces of the other two",
        bounced_on.len()
    );
    assert!(
        y < -0.6,
        "the ball did not fall through the refused tile: y = {y}"
    );
    for (ball, tile) in bouncers {
        assert!(
            bounced_on.iter().any(|(b, _)| *b == ball),
            "{ball:?} never bounced"
        );
        assert!(
            bounced_on.iter().all(|(b, g)| *b != ball || *g == tile),
            "{bounced_on:?}"
        );
        assert!(wide(world.bodies[ball].translation().y) > 0.0);
    }
}

/// A body rapier wakes meets the tiles one by one when the user's filter decides its pairs:
/// a ghost ball asleep inside a tile its filter refuses, woken by a ball dropped on it, is
/// not pushed out of the floor (the slab's box holds it, the tile does not), and falls
/// through that tile.
#[test]
fn a_woken_ghost_inside_a_refused_tile_is_left_to_fall_through_it() {
    let mut world = PhysicsWorld::default();
    let tiles = floor(&mut world, true);
    let side = FLOOR / TILES as f64;
    let (x, z) = (1.5 * side, 1.5 * side);
    let ghost_tile = tile_under(&tiles, x, z);
    assert_ne!(ghost_tile, tiles[0]);
    let (ghost, _) = world.insert(
        RigidBodyBuilder::dynamic()
            .translation(Vector::new(real(x), -0.02, real(z)))
            .sleeping(true),
        ColliderBuilder::ball(0.05).active_hooks(ActiveHooks::FILTER_CONTACT_PAIRS),
    );
    let (dropped, _) = world.insert(
        RigidBodyBuilder::dynamic().translation(Vector::new(real(x), 0.4, real(z))),
        ColliderBuilder::ball(0.05),
    );
    let mut p =
        ImpactPlugin::with_hooks(ImpactConfig::default(), GhostFilter::new(ghost_tile)).unwrap();
    for g in &tiles {
        p.add_ground(&world.bodies, &world.colliders, *g).unwrap();
    }
    let mut woken = None;
    for n in 0..90 {
        p.step(&mut world);
        if woken.is_none() && !world.bodies[ghost].is_sleeping() {
            woken = Some(n);
        }
        for e in p.events() {
            assert_ne!(e.body, ghost, "step {n}: the ghost was moved: {e:?}");
        }
    }
    let y = wide(world.bodies[ghost].translation().y);
    println!(
        "ghost woken at step {woken:?}, ends at y = {y:.3} m; the dropped ball at y = {:.3} m",
        wide(world.bodies[dropped].translation().y)
    );
    assert!(woken.is_some(), "the ghost was never woken");
    assert!(y < -0.6, "the ghost did not fall through its tile: y = {y}");
}

/// A ball at rest on the seam between two tiles of a floor of flush tiles stays where it is
/// and sleeps, as on one cuboid: its resting contact with the next tile's edge is taken as
/// its contact with the floor. Under rapier alone that contact is tilted and beside the
/// ball's foot, and rolls it off the seam.
#[test]
fn a_ball_at_rest_on_a_seam_between_tiles_stays_there() {
    let side = FLOOR / TILES as f64;
    let (x, z) = (side + 1e-3, 0.5 * side);
    let run = |plugin: bool| {
        let mut world = PhysicsWorld::default();
        let tiles = floor(&mut world, true);
        let (ball, _) = world.insert(
            RigidBodyBuilder::dynamic().translation(Vector::new(real(x), 0.05, real(z))),
            ColliderBuilder::ball(0.05).friction(0.4),
        );
        let mut p = plugin.then(|| {
            let mut p = ImpactPlugin::new(ImpactConfig::default()).unwrap();
            for g in &tiles {
                p.add_ground(&world.bodies, &world.colliders, *g).unwrap();
            }
            p
        });
        for _ in 0..120 {
            match p.as_mut() {
                Some(p) => p.step(&mut world),
                None => world.step(),
            }
        }
        let rb = &world.bodies[ball];
        let (dx, dz) = (wide(rb.translation().x) - x, wide(rb.translation().z) - z);
        ((dx * dx + dz * dz).sqrt(), rb.is_sleeping())
    };
    let (alone, _) = run(false);
    let (moved, asleep) = run(true);
    println!("on a seam: moved {moved:e} m with the plugin, {alone:e} m under rapier alone");
    assert!(
        alone > 1e-3,
        "rapier alone moved it {alone} m: no seam push to take away"
    );
    assert!(moved < 1e-6 && asleep, "moved {moved} m, asleep {asleep}");
}

/// A run's events (step, kind, ground, approach speed's bits) and the ball's height after
/// each step.
type DropRun = (Vec<(usize, EventKind, ColliderHandle, u64)>, Vec<f64>);

/// A ball dropped from 0.3 m (radius 5 cm) towards `(x, z)`; before step `moved_at`, `move_it`
/// moves the ground (rapier moves a fixed body's colliders only inside its next step).
fn dropped_while_a_ground_moves(
    world: &mut PhysicsWorld,
    grounds: &[ColliderHandle],
    (x, z): (f64, f64),
    moved_at: usize,
    move_it: &dyn Fn(&mut PhysicsWorld),
) -> DropRun {
    let ball = world
        .insert(
            RigidBodyBuilder::dynamic().translation(Vector::new(real(x), 0.3, real(z))),
            ColliderBuilder::ball(0.05).friction(0.4).restitution(0.6),
        )
        .0;
    let mut p = ImpactPlugin::new(ImpactConfig::default()).unwrap();
    for g in grounds {
        p.add_ground(&world.bodies, &world.colliders, *g).unwrap();
    }
    let (mut events, mut heights) = (Vec::new(), Vec::new());
    for step in 0..40 {
        if step == moved_at {
            move_it(world);
        }
        p.step(world);
        let log = p.events().iter();
        events.extend(log.map(|e| (step, e.kind, e.ground, e.approach_speed.to_bits())));
        heights.push(wide(world.bodies[ball].translation().y));
    }
    (events, heights)
}

/// A ground on a fixed body moved between two steps is met where rapier will have it,
/// though its collider still says where it was: moved in under a falling ball just before
/// the landing, it is met exactly as a collider without a body moved there; a floor's tile
/// moved away from under a landing ball (a trapdoor) lets the ball through, as under rapier
/// alone.
#[test]
fn a_ground_whose_fixed_body_moved_between_steps_is_met_where_it_now_is() {
    // The ball lands in step 13 (a fall of 0.25 m takes 13.5 steps).
    let landing = 13;
    let slab = |w: &mut PhysicsWorld, on_body: bool| {
        let shape = ColliderBuilder::cuboid(0.5, 0.25, 0.5)
            .translation(Vector::new(5.0, -0.25, 0.0))
            .restitution(0.6)
            .friction(0.4);
        if on_body {
            w.insert(RigidBodyBuilder::fixed(), shape).1
        } else {
            w.colliders.insert(shape)
        }
    };
    let mut runs = Vec::new();
    for on_body in [false, true] {
        let mut w = PhysicsWorld::default();
        let g = slab(&mut w, on_body);
        let move_in = move |w: &mut PhysicsWorld| match w.colliders[g].parent() {
            Some(body) => w.bodies[body].set_translation(Vector::new(-5.0, 0.0, 0.0), true),
            None => w.colliders[g].set_translation(Vector::new(0.0, -0.25, 0.0)),
        };
        runs.push(dropped_while_a_ground_moves(
            &mut w,
            &[g],
            (0.0, 0.0),
            landing,
            &move_in,
        ));
    }
    let (parentless, on_body) = (&runs[0], &runs[1]);
    println!("moved in: events {:?} / {:?}", parentless.0, on_body.0);
    assert!(
        parentless
            .0
            .first()
            .is_some_and(|e| e.0 == landing && e.1 == EventKind::Impact),
        "the landing is an impact: {:?}",
        parentless.0
    );
    let kinds = |run: &DropRun| run.0.iter().map(|e| (e.0, e.1, e.3)).collect::<Vec<_>>();
    assert_eq!(kinds(on_body), kinds(parentless), "the same impacts");
    assert_eq!(on_body.1, parentless.1, "the same flight");

    // The trapdoor: the tile under the ball, on its fixed body, moved 5 m aside.
    let mut w = PhysicsWorld::default();
    let tiles = floor(&mut w, true);
    let (x, z) = (0.375, 0.125);
    let door = tile_under(&tiles, x, z);
    let open = move |w: &mut PhysicsWorld| {
        let body = w.colliders[door].parent().unwrap();
        let at = w.bodies[body].translation() + Vector::new(5.0, 0.0, 0.0);
        w.bodies[body].set_translation(at, true);
    };
    let (events, heights) = dropped_while_a_ground_moves(&mut w, &tiles, (x, z), landing, &open);
    println!(
        "trapdoor: events {events:?}, height at the end {:?}",
        heights.last()
    );
    assert!(
        events.iter().all(|e| e.2 != door),
        "no bounce off the moved tile: {events:?}"
    );
    assert!(
        heights.last().is_some_and(|y| *y < -0.5),
        "fell through: {heights:?}"
    );
}

/// A blade 1 m long (10 cm thick) turning half a radian in one step about a pivot 0.8 m off
/// the path of a ball flying by at 45 m/s, without gravity: the ball never comes within
/// 0.28 m of it, and no mode reports an impact or changes its flight. (The in-step modes'
/// end check took the ball, which ends behind the blade's face plane with its foot on the
/// face, for one that went through the blade: in the blade's frame its path goes round the
/// blade's end. `Step` mode's start-of-step decision bounced it: the start contact's gap,
/// carried along its normal, closes within the step.)
#[test]
fn a_ball_flying_past_a_turning_blade_it_never_touches_flies_on() {
    for mode in [
        TimingMode::Step,
        TimingMode::TimeOfImpact,
        TimingMode::Exact,
    ] {
        let mut world = weightless();
        let pivot = Vector::new(0.5, 0.0, 0.8);
        let (blade, face) = world.insert(
            RigidBodyBuilder::kinematic_position_based()
                .translation(pivot)
                .rotation(Vector::new(0.0, -1.2, 0.0)),
            ColliderBuilder::cuboid(0.5, 0.3, 0.05).friction(0.0),
        );
        let b = ball(&mut world, [0.0, 0.0, 0.0], 0.1, 0.5, 0.0);
        world.bodies[b].set_linvel(Vector::new(45.0, 0.0, 0.0), true);
        let mut p = plugin_on(&world, face, mode);
        let turned = Pose::from_parts(pivot, Rotation::from_rotation_y(-0.7));
        world.bodies[blade].set_next_kinematic_position(turned);
        p.step(&mut world);
        let rb = &world.bodies[b];
        let (at, v) = (na(rb.translation()), na(rb.linvel()));
        println!(
            "{mode:?}: ends at {at:?} at {v:?}, events {}",
            p.events().len()
        );
        assert!(p.events().is_empty(), "{mode:?}: {:?}", p.events());
        assert!(
            (v - Vector3::new(45.0, 0.0, 0.0)).norm() < 1e-4,
            "{mode:?}: v {v:?}"
        );
        assert!(at.z.abs() < 1e-6, "{mode:?}: at {at:?}");
    }
}

/// A ball flying past a fixed box's edge it never touches, in every mode: it approaches the
/// edge at the step's start (the start contact's normal speed is negative and its gap closes
/// along that normal well within the step), but its path passes 5 cm over the box's top face.
/// No mode bounces it: rapier alone lets it fly on, and so does each of the plugin's modes.
/// The same ball 10 cm lower clips the edge: one impact in every mode, in the in-step modes
/// at the edge's normal at the touch, `n = (sqrt(3)/2, 0, 1/2)` (`v' = v - (1 + e) (v.n) n`,
/// no friction); `Step` mode resolves it at the step's start, at the start contact's normal
/// `(4, 0, 1) / sqrt(17)`.
#[test]
fn a_ball_flying_past_a_box_edge_it_never_touches_flies_on() {
    let e = 0.5;
    for mode in [
        TimingMode::Step,
        TimingMode::TimeOfImpact,
        TimingMode::Exact,
    ] {
        for height in [0.65, 0.55] {
            let mut world = weightless();
            let (_, block) = world.insert(
                RigidBodyBuilder::fixed(),
                ColliderBuilder::cuboid(0.5, 0.5, 0.5)
                    .restitution(real(e))
                    .friction(0.0),
            );
            let b = ball(&mut world, [0.7, 0.0, height], 0.1, e, 0.0);
            let v0 = Vector3::new(-30.0, 0.0, 0.0);
            world.bodies[b].set_linvel(Vector::new(-30.0, 0.0, 0.0), true);
            let mut p = plugin_on(&world, block, mode);
            let mut events = 0;
            for _ in 0..4 {
                p.step(&mut world);
                events += p.events().len();
            }
            let rb = &world.bodies[b];
            let (at, v) = (na(rb.translation()), na(rb.linvel()));
            println!("{mode:?}, {height}: ends at {at:?} at {v:?}, events {events}");
            if height > 0.6 {
                assert_eq!(events, 0, "{mode:?}");
                assert!((v - v0).norm() < 1e-4, "{mode:?}: v {v:?}");
                assert!((at.z - height).abs() < 1e-5, "{mode:?}: at {at:?}");
                continue;
            }
            assert_eq!(events, 1, "{mode:?}: clipping the edge");
            // The start contact's normal, from the edge to the centre (0.2, 0, 0.05) away.
            let n = if mode == TimingMode::Step {
                Vector3::new(4.0, 0.0, 1.0) / 17f64.sqrt()
            } else {
                Vector3::new(0.75f64.sqrt(), 0.0, 0.5)
            };
            let expected = v0 - (1.0 + e) * v0.dot(&n) * n;
            assert!(
                (v - expected).norm() < tol().1 * v0.norm(),
                "{mode:?}: v {v:?} against {expected:?}"
            );
        }
    }
}

/// Long bodies on a hinge whose end strikes a small ground cuboid, 60 Hz, every mode: a
/// hinged flap (1 m x 4 cm, hinge 0.5 m from its centre) falling onto a stop under its end,
/// and onto a stop 2 cm thick, and a door (1 m wide, vertical hinge) swung at 3 rad/s into
/// a post. The joint keeps rapier moving the body, so the contact is met at the step's end,
/// deep in the stop or post. That
/// contact is out of the face the body's end came in by: the flap's out of the stop's top,
/// the door's out of the post's side facing it. It was out of the face the body's centre lies
/// beyond, across the whole body: the flap was moved 0.2 m sideways off its hinge and the
/// joint flung it back (its energy 9.4-fold), the door was moved 0.86 m through the post and
/// swung on to 170 degrees. Here neither gains energy (1e-3 relative: rapier's joint
/// corrections), and the door never swings past the post's corner, at 60 and 30 Hz and at
/// twice the spin (a first fix moved it 0.84 m through the post at the next round of the
/// check, and the joint flung it back at 20 rad/s).
#[test]
fn a_hinged_body_striking_a_post_with_its_end_is_not_pushed_out_across_itself() {
    let energy = |world: &PhysicsWorld, b: RigidBodyHandle| {
        let rb = &world.bodies[b];
        wide(rb.kinetic_energy()) + wide(rb.mass()) * 9.81 * wide(rb.center_of_mass().y)
    };
    for timing in MODES {
        // The flap, from just before its end lands on the stop.
        let (mut world, flap, stop) = flap_over_stop(
            0.24,
            RigidBodyBuilder::dynamic()
                .translation(Vector::new(0.49974108, 0.5024977, 0.0))
                .rotation(Vector::new(0.0, 0.0, 0.0050018))
                .linvel(Vector::new(0.0029262938, -2.5301492, 0.0))
                .angvel(Vector::new(0.0, 0.0, -5.0603013)),
        );
        let mut p = plugin_on(&world, stop, timing);
        let start = energy(&world, flap);
        let mut most = start;
        for _ in 0..60 {
            p.step(&mut world);
            most = most.max(energy(&world, flap));
        }
        println!("{timing:?}: flap energy {start:.6} J at the start, at most {most:.6} J");
        assert!(
            most <= start * (1.0 + 1e-3),
            "{timing:?}: flap {start} -> {most} J"
        );

        // A flap swung at 3 rad/s onto a stop 2 cm thick, 60 Hz: its tip goes down through
        // the stop's top within one step, and it is put back out by the top it came in by,
        // not out by the stop's side, which is nearer but which its tip moved away from (it
        // was then pulled under the stop and swung on round its hinge). It turns back before
        // 28 degrees below its hinge, where it lies on the stop, as in rapier alone.
        let (mut world, flap, thin) = flap_over_stop(
            0.01,
            RigidBodyBuilder::dynamic()
                .translation(Vector::new(0.5, 0.5, 0.0))
                .linvel(Vector::new(0.0, -1.5, 0.0))
                .angvel(Vector::new(0.0, 0.0, -3.0)),
        );
        let mut p = plugin_on(&world, thin, timing);
        let mut lowest: f64 = 0.0;
        for _ in 0..60 {
            p.step(&mut world);
            let at = world.bodies[flap].translation();
            lowest = lowest.min((wide(at.y) - 0.5).atan2(wide(at.x)).to_degrees());
        }
        println!("{timing:?}: flap onto a 2 cm stop down to {lowest:.1} degrees");
        assert!(
            lowest > -30.0,
            "{timing:?}: the flap went through the stop: {lowest}"
        );

        // The door, at 60 Hz and at 30 Hz, and at twice the spin.
        for (hz, spin) in [(60.0, 3.0), (30.0, 3.0), (60.0, 6.0)] {
            let label = format!("{timing:?}, door at {spin} rad/s, {hz} Hz");
            let (mut world, door, post) = door_swung_into_post(hz, spin, 0.05);
            let mut p = plugin_on(&world, post, timing);
            // The door's edge meets the post's corner (0.85, 0.45) at 26.5 degrees; the
            // corner itself stands at 27.9 degrees about the hinge.
            let corner = 0.45f64.atan2(0.85).to_degrees();
            let start = energy(&world, door);
            let (mut widest, mut most): (f64, f64) = (0.0, start);
            for _ in 0..hz as usize {
                p.step(&mut world);
                let at = world.bodies[door].translation();
                widest = widest.max(wide(at.z).atan2(wide(at.x)).to_degrees());
                most = most.max(energy(&world, door));
            }
            println!(
                "{label}: swung to {widest:.1} degrees at most; energy {start:.6} -> at most {most:.6} J"
            );
            assert!(
                widest < corner,
                "{label}: the door passed the post: {widest} degrees"
            );
            assert!(
                most <= start * (1.0 + 1e-3),
                "{label}: energy {start} -> {most} J"
            );
        }
    }
}

/// A plank resting across a table's edge, its end out past the side, 30 and 60 Hz, every
/// mode: a 1.2 m plank over a table cuboid 1 m thick (0.1 m out, dropped 5 cm, and from
/// rest) and over a 2 cm slab (0.3 m out, dropped 10 cm). Its resting contact is the top's,
/// and its end's point lies a rounding under the top, out past the side: that is no entry by
/// the side, and it rests on the table as under rapier alone (a first fix of the hinged flap
/// above took it for one and threw the plank 1.1 m off the table). It never leaves the spot
/// by more than 5 cm along the table, nor ends under the top by more than rapier's allowed
/// error.
#[test]
fn a_plank_resting_across_a_tables_edge_stays_on_the_table() {
    let allowed = wide(
        PhysicsWorld::default()
            .integration_parameters
            .allowed_linear_error(),
    );
    for (over, drop, thick) in [(0.1, 0.05, 0.5), (0.1, 0.0, 0.5), (0.3, 0.1, 0.01)] {
        for hz in [30.0, 60.0] {
            for timing in MODES {
                let label =
                    format!("{timing:?}, {over} m out, dropped {drop} m, table {thick} m, {hz} Hz");
                let mut world = PhysicsWorld::default();
                world.integration_parameters.dt = real(1.0 / hz);
                let (_, table) = world.insert(
                    RigidBodyBuilder::fixed(),
                    ColliderBuilder::cuboid(1.0, real(thick), 1.0)
                        .translation(Vector::new(0.0, real(1.0 - thick), 0.0))
                        .restitution(0.3)
                        .friction(0.6),
                );
                let x0 = -1.0 - over + 0.6;
                let (plank, _) = world.insert(
                    RigidBodyBuilder::dynamic().translation(Vector::new(
                        real(x0),
                        real(1.02 + drop),
                        0.0,
                    )),
                    ColliderBuilder::cuboid(0.6, 0.02, 0.05)
                        .restitution(0.3)
                        .friction(0.6),
                );
                let mut p = plugin_on(&world, table, timing);
                for k in 1..=(2.0 * hz) as usize {
                    p.step(&mut world);
                    let at = world.bodies[plank].translation();
                    assert!(
                        (wide(at.x) - x0).abs() < 0.05 && wide(at.y) > 1.02 - allowed,
                        "{label}: step {k}: at {at:?}"
                    );
                }
            }
        }
    }
}

/// A long body past a ground cuboid's edge, every mode: a 1.2 m rod leaning 0.2 rad over a
/// 2 cm slab's edge, its centre 5 mm and 2 cm below the slab's mid-plane, drifting into the
/// edge at 0.3 m/s (60 and 240 Hz), and a plank shoved off a 1 m table's edge at 5 m/s (30
/// and 60 Hz). The rod's far end lies over the slab and behind its underside's plane from
/// the start: it went beside the slab, not through it. The plank's centre passes beyond
/// both the side and the top, its near end a rounding under the top: it is in by the top,
/// not by the side across its length. Before the fix the rod was moved 0.46 m down out of
/// the underside and the plank 0.42-0.48 m out of the side in one step. And a plank
/// pivoting over a 2 cm slab's edge at 5.8 rad/s (30 Hz), 4 mm into the edge, its far end
/// beyond the edge and below the top's plane from the step's start: it was lifted 0.39 m
/// onto the top's plane. No step moves any of them by more than 3 cm beyond what its
/// velocity carries (rapier alone: 2.1 cm at most, the rod's bounces).
#[test]
fn a_long_body_past_a_ground_cuboids_edge_is_not_moved_across_itself() {
    let run = |label: &str, hz: f64, timing, table: (f64, f64), body: ColliderBuilder, rb| {
        let (half, top) = table;
        let mut world = PhysicsWorld::default();
        world.integration_parameters.dt = real(1.0 / hz);
        let (_, ground) = world.insert(
            RigidBodyBuilder::fixed(),
            ColliderBuilder::cuboid(1.0, real(half), 1.0)
                .translation(Vector::new(0.0, real(top - half), 0.0))
                .restitution(0.3)
                .friction(0.6),
        );
        let (b, _) = world.insert(rb, body);
        let mut p = plugin_on(&world, ground, timing);
        let dt = 1.0 / hz;
        let mut worst: f64 = 0.0;
        for _ in 0..(hz / 2.0) as usize {
            let (at, v) = (world.bodies[b].translation(), world.bodies[b].linvel());
            p.step(&mut world);
            let moved = world.bodies[b].translation() - at - v * real(dt);
            worst = worst.max(wide(moved.length()));
        }
        println!("{label}, {timing:?}: {worst:.4} m beyond its velocity's carry at most");
        assert!(
            worst < 0.03,
            "{label}, {timing:?}: moved {worst} m in one step"
        );
    };
    for timing in MODES {
        for hz in [60.0, 240.0] {
            for dy in [-0.005, -0.02] {
                let tilt: f64 = 0.2;
                let x = 1.001 + 0.6 * tilt.sin() + 0.02 * tilt.cos();
                run(
                    &format!("rod at {hz} Hz, {dy} m below the slab's middle"),
                    hz,
                    timing,
                    (0.01, 1.01),
                    ColliderBuilder::cuboid(0.02, 0.6, 0.02).restitution(0.5),
                    RigidBodyBuilder::dynamic()
                        .translation(Vector::new(real(x), real(1.0 + dy), 0.0))
                        .rotation(Vector::new(0.0, 0.0, real(tilt)))
                        .linvel(Vector::new(-0.3, 0.0, 0.0)),
                );
            }
        }
        run(
            "plank pivoting over a slab's edge at 30 Hz",
            30.0,
            timing,
            (0.01, 1.01),
            ColliderBuilder::cuboid(0.6, 0.02, 0.05)
                .restitution(0.5)
                .friction(0.5),
            RigidBodyBuilder::dynamic()
                .translation(Vector::new(0.926_308_45, 1.109_314_9, -0.280_097_2))
                .rotation(Vector::new(-0.081_192_32, -0.181_777_12, -0.771_101_1))
                .linvel(Vector::new(0.375_200_63, 0.365_620_2, 0.178_964_93))
                .angvel(Vector::new(0.209_159_85, 2.257_921_2, -5.827_307_7)),
        );
        for hz in [30.0, 60.0] {
            run(
                &format!("plank off a table at {hz} Hz"),
                hz,
                timing,
                (0.5, 1.0),
                ColliderBuilder::cuboid(0.6, 0.02, 0.05)
                    .restitution(0.3)
                    .friction(0.6),
                RigidBodyBuilder::dynamic()
                    .translation(Vector::new(0.3, 1.02, 0.0))
                    .linvel(Vector::new(5.0, 0.0, 0.0)),
            );
        }
    }
}

/// Bodies without a joint dropped at 10 m/s onto a thin slab's edge at 30 Hz, their outer end
/// tilted down past the edge (a board on a 5 cm slab, tiles on 2 and 1 cm slabs; states from
/// a sweep of random drops). In `Step` mode the step-start impulse leaves each nearly through
/// the slab at the step's end, its contact on the underside shallower than the slab's half
/// thickness, and the top's plane measures the outer end, below that plane from the start:
/// no face came in, and the underside's contact, whose point did not either, must not
/// stand (it was, in a first form of the rule, and pushed them out under the slab). No step
/// takes a body's centre from above the slab's top to below its underside within its
/// extent, in any mode (rapier alone: none does).
#[test]
fn a_body_nearly_through_a_thin_slabs_edge_is_not_put_out_under_it() {
    let cases = [
        (
            0.025,
            [0.3, 0.01, 0.1],
            0.196_805_03,
            [0.954_698, 1.026_341_6, 0.006_733_17],
            [0.017_750_023, -0.168_474_57, -0.209_438_82],
            [0.344_885_1, -10.0, -0.205_535_65],
            [0.0, 0.0, 0.0],
        ),
        (
            0.01,
            [0.1, 0.004, 0.1],
            0.564_785_96,
            [0.969_030_44, 1.044_506_8, -0.458_137_66],
            [-0.056_617_506, 0.256_217_87, -0.432_483_23],
            [0.405_373_5, -10.0, -0.406_305],
            [0.0, 0.0, 0.0],
        ),
        (
            0.005,
            [0.1, 0.004, 0.1],
            0.563_092_9,
            [0.947_346_8, 1.058_383_8, 0.382_154_2],
            [-0.044_338_1, 0.162_838_32, -0.530_432_05],
            [0.189_803, -10.0, 0.252_518_18],
            [-0.515_693_66, -0.008_953_365, 6.365_402],
        ),
    ];
    let vec = |a: [f64; 3]| Vector::new(real(a[0]), real(a[1]), real(a[2]));
    for timing in MODES {
        for (half, body, e, at, turned, v, w) in cases {
            let mut world = PhysicsWorld::default();
            world.integration_parameters.dt = real(1.0 / 30.0);
            let (_, slab) = world.insert(
                RigidBodyBuilder::fixed(),
                ColliderBuilder::cuboid(1.0, real(half), 1.0)
                    .translation(Vector::new(0.0, real(1.0 - half), 0.0))
                    .restitution(0.3)
                    .friction(0.6),
            );
            let (b, _) = world.insert(
                RigidBodyBuilder::dynamic()
                    .translation(vec(at))
                    .rotation(vec(turned))
                    .linvel(vec(v))
                    .angvel(vec(w)),
                ColliderBuilder::cuboid(real(body[0]), real(body[1]), real(body[2]))
                    .restitution(real(e))
                    .friction(0.5),
            );
            let mut p = plugin_on(&world, slab, timing);
            for k in 0..30 {
                let before = wide(world.bodies[b].translation().y);
                p.step(&mut world);
                let after = world.bodies[b].translation();
                let over = wide(after.x).abs() < 1.0 && wide(after.z).abs() < 1.0;
                assert!(
                    !(over && before > 1.0 && wide(after.y) < 1.0 - 2.0 * half),
                    "{timing:?}, a slab {} cm thick: step {k} took the body from {before} \
                     to {after:?}, through the slab",
                    200.0 * half
                );
            }
        }
    }
}

/// A flap 1 m x 4 cm x 40 cm on a horizontal hinge (about z) at (0, 0.5, 0), 0.5 m from its
/// centre, of the body `flap` (its pose and velocities), over a fixed stop 20 cm x 60 cm of
/// half thickness `half` (m) standing on the plane y = 0, 0.9 m out under the flap's end:
/// the world (60 Hz), the flap, and the stop's collider. `e = 0.8` both.
fn flap_over_stop(
    half: f64,
    flap: RigidBodyBuilder,
) -> (PhysicsWorld, RigidBodyHandle, ColliderHandle) {
    let mut world = PhysicsWorld::default();
    let (_, stop) = world.insert(
        RigidBodyBuilder::fixed(),
        ColliderBuilder::cuboid(0.1, real(half), 0.3)
            .translation(Vector::new(0.9, real(half), 0.0))
            .restitution(0.8),
    );
    let flap = hinged(
        &mut world,
        (Vector::new(0.0, 0.5, 0.0), Vector::Z),
        flap,
        ColliderBuilder::cuboid(0.5, 0.02, 0.2).restitution(0.8),
    );
    (world, flap, stop)
}

/// Inserts a body (`body`, `collider`) on a revolute joint about `axis` to a fixed hinge at
/// `at`, the joint 0.5 m along the body's -x from its centre (a 1 m door's or flap's edge).
fn hinged(
    world: &mut PhysicsWorld,
    (at, axis): (Vector, Vector),
    body: RigidBodyBuilder,
    collider: ColliderBuilder,
) -> RigidBodyHandle {
    let hinge = world.insert_body(RigidBodyBuilder::fixed().translation(at));
    let (handle, _) = world.insert(body, collider);
    world.insert_impulse_joint(
        hinge,
        handle,
        RevoluteJointBuilder::new(axis).local_anchor2(Vector::new(-0.5, 0.0, 0.0)),
    );
    handle
}

/// A door 1 m wide and 2 m tall on a vertical hinge at the origin (1.05 m up), swung at
/// `spin` rad/s towards a fixed post 2 m tall of half thickness `half` (m) whose near face
/// is 0.45 m along z and whose middle is 0.8 m along x, at `hz` steps a second: the world,
/// the door, and the post's collider. `e = 0.8` both.
fn door_swung_into_post(
    hz: f64,
    spin: f64,
    half: f64,
) -> (PhysicsWorld, RigidBodyHandle, ColliderHandle) {
    let mut world = PhysicsWorld::default();
    world.integration_parameters.dt = real(1.0 / hz);
    let (_, post) = world.insert(
        RigidBodyBuilder::fixed(),
        ColliderBuilder::cuboid(real(half), 1.0, real(half))
            .translation(Vector::new(0.8, 1.05, real(0.45 + half)))
            .restitution(0.8),
    );
    let door = hinged(
        &mut world,
        (Vector::new(0.0, 1.05, 0.0), Vector::Y),
        RigidBodyBuilder::dynamic()
            .translation(Vector::new(0.5, 1.05, 0.0))
            .linvel(Vector::new(0.0, 0.0, real(spin / 2.0)))
            .angvel(Vector::new(0.0, real(-spin), 0.0)),
        ColliderBuilder::cuboid(0.5, 1.0, 0.02).restitution(0.8),
    );
    (world, door, post)
}
