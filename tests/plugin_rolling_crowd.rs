//! Rolling resistance among other balls: a ball rolls to its closed-form stop beside others
//! exactly as it does alone, as long as nothing can touch it; one that something can touch is
//! handed to rapier's contact with an `EventKind::Released` event.
//!
//! rapier's broad phase pairs every two balls whose fattened bounding boxes overlap (up to
//! about 10 cm apart), so a pair in its contact graph is no sign of contact: the plugin
//! measures the gap against how far the two can close in the step.

mod plugin_support;

use plugin_support::{F64, G, jitter, na, real};
use rapier_impact::rapier::prelude::*;
use rapier_impact::{EventKind, ImpactConfig, ImpactPlugin, ImpactTiming, TimingMode};

const R: f64 = 0.05;
/// Solid balls: `I = k m R^2`.
const K: f64 = 0.4;
const MU_R: f64 = 0.05;

/// The closed form's stopping distance of a ball rolling without slip at `v0` on level
/// ground under rolling resistance `MU_R`: `v0^2 (1 + k) / (2 mu_r g)`.
fn stopping_distance(v0: f64) -> f64 {
    v0 * v0 * (1.0 + K) / (2.0 * MU_R * G)
}

/// The bound on a stop in `Exact` mode, relative to the distance.
const X_TOL: f64 = if F64 { 1e-12 } else { 1e-5 };

/// The ground under the balls: a half-space marked as ground, or (as `many_balls --tiles 2`)
/// a floor of 2 x 2 flush tiles, 4 m square and 0.5 m thick, top at y = 0, on one fixed body,
/// with every fixed collider a ground.
#[derive(Clone, Copy)]
enum Floor {
    HalfSpace,
    Tiles,
}

/// Balls of radius `R` at `starts` (x, z) on a half-space ground, each rolling along +x
/// without slip at `v0`; the plugin in `Exact` mode with rolling resistance `MU_R`.
fn scene(starts: &[(f64, f64)], v0: f64) -> (PhysicsWorld, ImpactPlugin, Vec<RigidBodyHandle>) {
    scene_on(Floor::HalfSpace, starts, v0)
}

/// [`scene`] on `floor`.
fn scene_on(
    floor: Floor,
    starts: &[(f64, f64)],
    v0: f64,
) -> (PhysicsWorld, ImpactPlugin, Vec<RigidBodyHandle>) {
    let mut w = PhysicsWorld {
        gravity: Vector::new(0.0, real(-G), 0.0),
        ..Default::default()
    };
    let ground = match floor {
        Floor::HalfSpace => Some(
            w.insert(
                RigidBodyBuilder::fixed(),
                ColliderBuilder::halfspace(plugin_support::up()).friction(0.5),
            )
            .1,
        ),
        Floor::Tiles => {
            let body = w.bodies.insert(RigidBodyBuilder::fixed());
            for (x, z) in [(-2.0, -2.0), (-2.0, 2.0), (2.0, -2.0), (2.0, 2.0)] {
                w.colliders.insert_with_parent(
                    ColliderBuilder::cuboid(2.0, 0.25, 2.0)
                        .translation(Vector::new(x, -0.25, z))
                        .friction(0.5),
                    body,
                    &mut w.bodies,
                );
            }
            None
        }
    };
    let balls = starts
        .iter()
        .map(|&(x, z)| {
            w.insert(
                RigidBodyBuilder::dynamic()
                    .translation(Vector::new(real(x), real(R), real(z)))
                    .linvel(Vector::new(real(v0), 0.0, 0.0))
                    .angvel(Vector::new(0.0, 0.0, real(-v0 / R))),
                ColliderBuilder::ball(real(R)).friction(0.5),
            )
            .0
        })
        .collect();
    let mut p = ImpactPlugin::new(
        ImpactConfig::default()
            .with_timing(TimingMode::Exact)
            .with_rolling_resistance(MU_R),
    )
    .unwrap();
    match ground {
        Some(ground) => p.add_ground(&w.bodies, &w.colliders, ground).unwrap(),
        None => p.set_all_fixed_colliders_ground(true),
    }
    (w, p, balls)
}

/// What a run did: steps with some ball awake, and the plugin's events by kind.
#[derive(Debug, Default)]
struct Run {
    awake_steps: usize,
    released: usize,
    others: usize,
}

fn run(w: &mut PhysicsWorld, p: &mut ImpactPlugin, steps: usize) -> Run {
    let mut run = Run::default();
    for _ in 0..steps {
        p.step(w);
        for e in p.events() {
            match e.kind {
                EventKind::Released => run.released += 1,
                _ => run.others += 1,
            }
        }
        if w.bodies
            .iter()
            .any(|(_, rb)| rb.is_dynamic() && !rb.is_sleeping())
        {
            run.awake_steps += 1;
        }
    }
    run
}

/// Every ball stopped `stopping_distance(v0)` along +x from where it started, within
/// `X_TOL`, asleep, and nothing else moved it (no event).
fn assert_each_stopped_at_the_closed_form(
    label: &str,
    w: &PhysicsWorld,
    balls: &[RigidBodyHandle],
    starts: &[(f64, f64)],
    v0: f64,
    run: &Run,
) {
    let d = stopping_distance(v0);
    let mut worst = 0.0f64;
    for (ball, &(x0, z0)) in balls.iter().zip(starts) {
        let rb = &w.bodies[*ball];
        let at = na(rb.center_of_mass());
        let err = ((at.x - x0 - d) / d).abs().max(((at.z - z0) / d).abs());
        worst = worst.max(err);
        assert!(
            err <= X_TOL,
            "{label}: ball from ({x0}, {z0}) stopped at x - x0 = {}, closed form {d} (relative {err:.2e})",
            at.x - x0
        );
        assert!(rb.is_sleeping(), "{label}: ball from ({x0}, {z0}) asleep");
    }
    assert_eq!((run.released, run.others), (0, 0), "{label}: {run:?}");
    println!("{label}: worst relative stop error {worst:.2e}, {run:?}");
}

/// The steps to the stop, then 2 s of rapier's rest to sleep.
fn steps_to_sleep(v0: f64) -> usize {
    ((v0 * (1.0 + K) / (MU_R * G) + 2.0) * 60.0) as usize
}

/// Balls at `starts` on `floor`, rolling along +x at 1 m/s, run for `steps_to_sleep`: each
/// stopped at its closed form and asleep ([`assert_each_stopped_at_the_closed_form`]).
fn roll_to_their_stops(label: &str, floor: Floor, starts: &[(f64, f64)]) {
    let v0 = 1.0;
    let (mut w, mut p, balls) = scene_on(floor, starts, v0);
    let run = run(&mut w, &mut p, steps_to_sleep(v0));
    assert_each_stopped_at_the_closed_form(label, &w, &balls, starts, v0, &run);
}

#[test]
fn two_balls_side_by_side_roll_to_their_closed_form_stops() {
    // 5 cm, 1 cm, 1 mm apart: rapier's broad phase pairs all three, and its narrow phase
    // makes speculative contacts (up to 2 cm) for the last two. Side by side they close along
    // their line of centres no faster than their relative velocity there (none), whatever
    // their ground and rapier's step (in which a ball taken from its ground falls) do across
    // it.
    for gap in [0.05, 0.01, 0.001] {
        let starts = [(0.0, 0.0), (0.0, 2.0 * R + gap)];
        let label = format!("side by side, {gap} m apart");
        roll_to_their_stops(&label, Floor::HalfSpace, &starts);
    }
}

#[test]
fn a_row_of_ten_balls_one_behind_the_other_rolls_to_the_closed_form_stops() {
    let starts: Vec<_> = (0..10).map(|i| (0.15 * i as f64, 0.0)).collect();
    roll_to_their_stops("a row of ten", Floor::HalfSpace, &starts);
}

/// `many_balls --scene rolling --count 500 --rolling-resistance 0.05`: a 23 x 23 grid, 15 cm
/// apart, each ball jittered by up to 2 cm (so down to 1 cm apart).
#[test]
fn five_hundred_balls_on_a_grid_each_stop_at_the_closed_form_and_sleep() {
    let mut jitter = jitter(0x2545_f491_4f6c_dd1du64, 0.02);
    let per_row = 23;
    let starts: Vec<_> = (0..500)
        .map(|i| {
            let (row, col) = (i / per_row, i % per_row);
            (0.15 * col as f64 + jitter(), 0.15 * row as f64 + jitter())
        })
        .collect();
    roll_to_their_stops("500 balls", Floor::HalfSpace, &starts);
}

/// On a floor of flush tiles, balls roll to their closed-form stops and sleep as on a
/// half-space. At rest in rapier's contact, a ball picks up the solver's rounding in its
/// tile's frame (about 1e-7 m/s, and a spin about the normal of 1e-12 rad/s); the plan took
/// that back into the closed form, which put it at rest and wrote it every other step, so
/// that it never slept (`many_balls --scene rolling --tiles 2`: 3 of 200 asleep after 10 s).
#[test]
fn balls_rolling_to_a_stop_on_a_tiled_floor_stop_at_the_closed_form_and_sleep() {
    let starts: Vec<_> = [-1.3, -0.6, 0.1, 0.8]
        .iter()
        .flat_map(|x| [-1.1, -0.35, 0.4, 1.15].map(|z| (*x, z)))
        .collect();
    roll_to_their_stops("16 balls on tiles", Floor::Tiles, &starts);
}

/// A ball at rest in rapier's contact, nudged faster than the held speed (1e-4 m/s), is the
/// closed form's: it stops where the closed form says, `v^2 (1 + k) / (2 mu_r g)`, and sleeps,
/// whether or not one step of the rolling resistance's braking (`mu_r g dt / (1 + k)`,
/// 5.8 mm/s) would take the nudge away. Nudged slower than the held speed, it is rapier's (as is
/// the drift rapier's own resting contact gives a ball at rest): rapier, which has no rolling
/// resistance, lets it roll on until it sleeps it, 0.5 s at its defaults.
#[test]
fn a_resting_ball_nudged_past_the_held_speed_stops_at_the_closed_form() {
    let braking = MU_R * G / (1.0 + K) / 60.0;
    let held = 1e-4;
    for nudge in [1.5 * braking, 0.5 * braking, 0.5 * held] {
        let (mut w, mut p, balls) = scene(&[(0.3, 0.2)], 0.0);
        let ball = balls[0];
        // At rest, then three steps in rapier's resting contact.
        for _ in 0..3 {
            p.step(&mut w);
        }
        assert!(w.bodies[ball].linvel().length() < 1e-6);
        let at = na(w.bodies[ball].translation());
        w.bodies[ball].set_linvel(Vector::new(real(nudge), 0.0, 0.0), true);
        w.bodies[ball].set_angvel(Vector::new(0.0, 0.0, real(-nudge / R)), true);
        let run = run(&mut w, &mut p, steps_to_sleep(nudge));
        let rb = &w.bodies[ball];
        let moved = na(rb.translation()) - at;
        let d = stopping_distance(nudge);
        println!(
            "nudged at {nudge:e} m/s: moved {:e} m, closed form {d:e} m, {run:?}",
            moved.x
        );
        assert!(rb.is_sleeping(), "{run:?}");
        if nudge > held {
            // Positions near 0.3 m round to 3e-8 m in `f32`.
            let tol = if F64 { 1e-15 } else { 1e-7 };
            assert!(
                (moved.x - d).abs() <= tol,
                "moved {} m, closed form {d} m",
                moved.x
            );
        } else {
            // rapier's: on at the nudge until it sleeps (a step's rounding of the count).
            assert!(
                moved.x > d && moved.x <= nudge * (0.5 + 2.0 / 60.0),
                "{}",
                moved.x
            );
        }
    }
}

/// A ball rolling into a ball at rest is handed to rapier's contact before it can touch it
/// (one `Released` event, at the step's start), and the other ball is pushed: rapier's
/// collision. Nothing is rolled through the other ball.
#[test]
fn a_ball_rolling_into_a_ball_at_rest_is_released_to_rapier_before_it_touches() {
    let v0 = 1.0;
    let starts = [(0.0, 0.0), (0.3, 0.0)];
    let (mut w, mut p, balls) = scene(&starts, v0);
    w.bodies[balls[1]].set_linvel(Vector::ZERO, true);
    w.bodies[balls[1]].set_angvel(Vector::ZERO, true);
    let mut released = Vec::new();
    let mut closest = f64::INFINITY;
    let mut pushed = 0.0f64;
    for n in 0..120 {
        let gap_before = (na(w.bodies[balls[1]].center_of_mass())
            - na(w.bodies[balls[0]].center_of_mass()))
        .norm()
            - 2.0 * R;
        p.step(&mut w);
        for e in p.events() {
            assert_eq!(e.kind, EventKind::Released, "step {n}: {e:?}");
            assert_eq!(e.body, balls[0]);
            assert_eq!(e.timing, ImpactTiming::StepStart, "step {n}: {e:?}");
            assert_eq!(e.ke_before, e.ke_after);
            assert!(
                gap_before > 0.0,
                "step {n}: released at a gap of {gap_before}"
            );
            released.push(n);
        }
        let gap = (na(w.bodies[balls[1]].center_of_mass())
            - na(w.bodies[balls[0]].center_of_mass()))
        .norm()
            - 2.0 * R;
        closest = closest.min(gap);
        pushed = pushed.max(na(w.bodies[balls[1]].linvel()).x);
    }
    assert_eq!(released.len(), 1, "released in steps {released:?}");
    assert!(pushed > 0.3 * v0, "the ball at rest was struck: {pushed}");
    // rapier's contact lets balls overlap by its allowed error (1 mm) at most.
    assert!(closest > -2e-3, "closest approach {closest}");
}

/// A rolling ball beside a ball at rest (3 mm apart, across its path) is in closed form; a
/// third ball, rapier's, strikes the resting one into it within a step. rapier's solver
/// pushes the rolling ball through their speculative contact: it is released at the step's
/// end, once (the next step's plan, finding the struck ball within reach, does not release it
/// again), and rapier's end state stands.
#[test]
fn a_rolling_ball_pushed_within_the_step_is_released_at_the_step_end_once() {
    let v0 = 1.0;
    let side = 2.0 * R + 0.003;
    let starts = [(0.0, 0.0), (0.0, side), (0.0, 2.0 * side + 0.01)];
    let (mut w, mut p, balls) = scene(&starts, v0);
    for (k, v) in [(1, 0.0), (2, -3.0)] {
        w.bodies[balls[k]].set_linvel(Vector::new(0.0, 0.0, real(v)), true);
        w.bodies[balls[k]].set_angvel(Vector::ZERO, true);
    }
    p.remove_impact_body(balls[2]);
    let mut released = Vec::new();
    for n in 0..30 {
        p.step(&mut w);
        // (The striker, sliding in closed form itself, is released as it strikes; rapier's end
        // state of the pushed ball, flown without its ground, is put back on it: `PushOut`.)
        for e in p.events().iter().filter(|e| e.body == balls[0]) {
            if e.kind == EventKind::Released {
                assert_eq!(e.ke_before, e.ke_after);
                released.push((n, e.timing));
            }
        }
    }
    assert_eq!(
        released,
        [(0, ImpactTiming::StepEnd)],
        "released once, at the end of the step of the strike"
    );
    // Struck towards -z, through the resting ball.
    let vz = na(w.bodies[balls[0]].linvel()).z;
    assert!(vz < -0.1, "the rolling ball was pushed: vz {vz}");
}
