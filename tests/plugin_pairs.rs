//! Impacts between bodies in the plugin (`add_impact_body`): two balls meeting in flight, a
//! cue ball rolling into an object ball on a table, a row of touching balls (Newton's
//! cradle), against the closed forms; both bodies named in the events; opt-in, rapier's
//! filtering, and every mode.

mod plugin_support;

use approx::{abs_diff_eq, assert_abs_diff_eq};
use plugin_support::{F64, G, MODES, na, real, wide, world_with_gravity};
use rapier_impact::na::Vector3;
use rapier_impact::rapier::prelude::*;
use rapier_impact::{ConfigError, EventKind, ImpactConfig, ImpactPlugin, ImpactTiming, TimingMode};

/// Tolerance on velocities, relative to the speed, where rapier's precision is the limit.
const V_TOL: f64 = if F64 { 1e-12 } else { 2e-6 };

fn ball(
    world: &mut PhysicsWorld,
    at: Vector3<f64>,
    v: Vector3<f64>,
    w: Vector3<f64>,
    r: f64,
    e: f64,
    mu: f64,
) -> (RigidBodyHandle, ColliderHandle) {
    world.insert(
        RigidBodyBuilder::dynamic()
            .translation(Vector::new(real(at.x), real(at.y), real(at.z)))
            .linvel(Vector::new(real(v.x), real(v.y), real(v.z)))
            .angvel(Vector::new(real(w.x), real(w.y), real(w.z)))
            .can_sleep(false),
        ColliderBuilder::ball(real(r))
            .density(real(0.17 / (4.0 / 3.0 * std::f64::consts::PI * r * r * r)))
            .restitution(real(e))
            .friction(real(mu)),
    )
}

/// Two frictionless 5 cm balls 0.4 m apart on the x axis, the first moving at 2 m/s towards
/// the second at rest, restitution `e`.
fn closing_pair(
    w: &mut PhysicsWorld,
    e: f64,
) -> (
    (RigidBodyHandle, ColliderHandle),
    (RigidBodyHandle, ColliderHandle),
) {
    let v = Vector3::new(2.0, 0.0, 0.0);
    let zero = Vector3::zeros();
    let a = ball(w, zero, v, zero, 0.05, e, 0.0);
    let b = ball(w, Vector3::new(0.4, 0.0, 0.0), zero, zero, 0.05, e, 0.0);
    (a, b)
}

fn plugin(mode: TimingMode) -> ImpactPlugin {
    ImpactPlugin::new(ImpactConfig::default().with_timing(mode)).unwrap()
}

fn pair_events(plugin: &ImpactPlugin) -> Vec<rapier_impact::ImpactEvent> {
    plugin
        .events()
        .iter()
        .filter(|e| e.kind == EventKind::Impact && e.body2.is_some())
        .copied()
        .collect()
}

/// The momentum along x of these bodies (handle, mass) (kg m/s).
fn momentum_x(w: &PhysicsWorld, masses: &[(RigidBodyHandle, f64)]) -> f64 {
    masses
        .iter()
        .map(|(h, m)| m * na(w.bodies[*h].linvel()).x)
        .sum()
}

/// The kinetic energy of these balls' centres (handle, mass) (J).
fn translational_energy(w: &PhysicsWorld, masses: &[(RigidBodyHandle, f64)]) -> f64 {
    masses
        .iter()
        .map(|(h, m)| 0.5 * m * na(w.bodies[*h].linvel()).norm_squared())
        .sum()
}

/// A row of `count` still balls of radius `r` (e = 1, frictionless), touching along x from
/// `x` on, their centres at height `y`.
fn touching_row(
    w: &mut PhysicsWorld,
    x: f64,
    y: f64,
    r: f64,
    count: usize,
) -> Vec<RigidBodyHandle> {
    let zero = Vector3::zeros();
    (0..count)
        .map(|k| {
            ball(
                w,
                Vector3::new(x + 2.0 * r * k as f64, y, 0.0),
                zero,
                zero,
                r,
                1.0,
                0.0,
            )
            .0
        })
        .collect()
}

/// Asserts that there are events and that every one is in the step.
fn assert_in_step(events: &[rapier_impact::ImpactEvent], label: &str) {
    let timings: Vec<_> = events.iter().map(|e| e.timing).collect();
    assert!(
        !events.is_empty() && timings.iter().all(|t| *t == ImpactTiming::InStep),
        "{label}: {timings:?}"
    );
}

/// A fixed half-space floor, its normal up, of restitution `e` and friction `mu`.
fn floor(w: &mut PhysicsWorld, e: f64, mu: f64) -> ColliderHandle {
    let up = rapier_impact::rapier::na::Unit::new_unchecked(Vector::Y);
    let builder = ColliderBuilder::halfspace(up)
        .restitution(real(e))
        .friction(real(mu));
    w.insert(RigidBodyBuilder::fixed(), builder).1
}

/// Steps until a step reports impacts between bodies (at most `steps`), and returns them.
fn first_pair_events(
    p: &mut ImpactPlugin,
    w: &mut PhysicsWorld,
    steps: usize,
) -> Vec<rapier_impact::ImpactEvent> {
    for _ in 0..steps {
        p.step(w);
        let seen = pair_events(p);
        if !seen.is_empty() {
            return seen;
        }
    }
    Vec::new()
}

/// A pair approaching slower than the resting speed is no impact: rapier's contact as it is,
/// its own restitution included (its bounce, `e` times an approach below the resting speed,
/// cannot rise above the resting gap), so the plugin neither moves the balls nor hooks the
/// pair, and rapier recycles its contacts. At a combined restitution of 1 (one ball's, or two
/// halves summed) rapier would bounce it whenever it approaches, and the plugin hooks it:
/// zero restitution.
#[test]
fn a_slow_pair_is_rapiers_contact_as_it_is_unless_rapier_bounces_it_for_ever() {
    // Without gravity the resting speed is 1 mm/s: 0.4 mm/s is below half of it (neither
    // ball is fast enough for the pair to be an impact).
    let slow = 4e-4;
    for (e, rule, elastic) in [
        (0.8, CoefficientCombineRule::Average, false),
        (1.0, CoefficientCombineRule::Average, true),
        (0.5, CoefficientCombineRule::ClampedSum, true),
    ] {
        for mode in MODES {
            let make = || {
                let mut w = world_with_gravity(0.0);
                let zero = Vector3::zeros();
                let a = ball(&mut w, zero, Vector3::x() * slow, zero, 0.05, e, 0.0);
                let b = ball(&mut w, Vector3::x() * 0.1005, zero, zero, 0.05, e, 0.0);
                for (_, co) in w.colliders.iter_mut() {
                    co.set_restitution_combine_rule(rule);
                }
                (w, a, b)
            };
            let (mut alone, (a0, _), (b0, _)) = make();
            let (mut w, (a, ca), (b, cb)) = make();
            let mut p = plugin(mode);
            p.set_all_dynamic_bodies_impact(true);
            for _ in 0..120 {
                alone.step();
                p.step(&mut w);
                assert!(pair_events(&p).is_empty(), "{mode:?}, e {e}: no impact");
                let hooked = w.colliders[ca].active_hooks() | w.colliders[cb].active_hooks();
                if !elastic {
                    assert_eq!(hooked, ActiveHooks::empty(), "{mode:?}: never hooked");
                }
            }
            let (va, vb) = (na(w.bodies[a].linvel()).x, na(w.bodies[b].linvel()).x);
            if !elastic {
                // rapier's contact, bitwise: rapier's own bounce.
                assert_eq!(
                    (va, vb),
                    (
                        na(alone.bodies[a0].linvel()).x,
                        na(alone.bodies[b0].linvel()).x
                    )
                );
                assert!(vb > 0.5 * slow, "{mode:?}: rapier bounced it, {va} {vb}");
            } else {
                // Hooked while approaching, zero restitution: they move on together.
                assert!(
                    abs_diff_eq!(va, vb, epsilon = 1e-3 * slow),
                    "{mode:?}: {va} {vb}"
                );
                assert!(
                    abs_diff_eq!(va + vb, slow, epsilon = 1e-3 * slow),
                    "{mode:?}: momentum"
                );
            }
        }
    }
}

#[test]
fn only_dynamic_bodies_opt_in() {
    let mut w = world_with_gravity(0.0);
    let (fixed, _) = w.insert(RigidBodyBuilder::fixed(), ColliderBuilder::ball(0.1));
    let (b, _) = ball(
        &mut w,
        Vector3::zeros(),
        Vector3::zeros(),
        Vector3::zeros(),
        0.1,
        1.0,
        0.0,
    );
    let mut p = plugin(TimingMode::Exact);
    assert_eq!(
        p.add_impact_body(&w.bodies, fixed),
        Err(ConfigError::NotDynamic(fixed))
    );
    assert!(!p.is_impact_body(&w.bodies, b));
    p.add_impact_body(&w.bodies, b).unwrap();
    assert!(p.is_impact_body(&w.bodies, b));
    assert!(p.remove_impact_body(b));
    assert!(!p.is_impact_body(&w.bodies, b));
    p.set_all_dynamic_bodies_impact(true);
    assert!(p.is_impact_body(&w.bodies, b) && !p.is_impact_body(&w.bodies, fixed));
}

/// Two equal balls (R = 28.575 mm, 0.17 kg) head-on in free space, 0.5 m apart, closing at
/// 3 m/s: they touch at (0.5 - 2R) / 3 s, and leave at v (1 -+ e) / 2 about the mean.
#[test]
fn two_balls_meet_at_the_closed_form_time_and_exchange_speed() {
    let r = 0.028_575;
    let e = 0.9;
    for mode in [TimingMode::TimeOfImpact, TimingMode::Exact] {
        let mut w = world_with_gravity(0.0);
        let (a, _) = ball(
            &mut w,
            Vector3::zeros(),
            Vector3::new(2.0, 0.0, 0.0),
            Vector3::zeros(),
            r,
            e,
            0.0,
        );
        let (b, _) = ball(
            &mut w,
            Vector3::new(0.5, 0.0, 0.0),
            Vector3::new(-1.0, 0.0, 0.0),
            Vector3::zeros(),
            r,
            e,
            0.0,
        );
        let mut p = plugin(mode);
        p.set_all_dynamic_bodies_impact(true);
        let dt = wide(w.integration_parameters.dt);
        let t_touch = (0.5 - 2.0 * r) / 3.0;
        let mut seen = Vec::new();
        for k in 0..20 {
            p.step(&mut w);
            for ev in pair_events(&p) {
                seen.push((k as f64 * dt + ev.time, ev));
            }
        }
        assert_eq!(
            seen.len(),
            2,
            "{mode:?}: one impact, an event per ball: {seen:?}"
        );
        for (t, ev) in &seen {
            assert!(
                abs_diff_eq!(*t, t_touch, epsilon = 1e-6),
                "{mode:?}: at {t}, expected {t_touch}"
            );
            assert_eq!(ev.timing, ImpactTiming::InStep);
            let other = if ev.body == a { b } else { a };
            assert_eq!(ev.body2, Some(other));
        }
        // Momentum 0.17 (2 - 1) kg m/s; relative speed 3 m/s becomes 2.7 m/s apart.
        let (va, vb) = (na(w.bodies[a].linvel()).x, na(w.bodies[b].linvel()).x);
        let mean = 0.5;
        assert!(
            abs_diff_eq!(va, mean - 1.5 * e, epsilon = V_TOL * 3.0),
            "{mode:?}: va {va}"
        );
        assert!(
            abs_diff_eq!(vb, mean + 1.5 * e, epsilon = V_TOL * 3.0),
            "{mode:?}: vb {vb}"
        );
    }
}

/// rapier hooks a pair when either collider asks for it, and never recycles the contacts of
/// any pair of a flagged collider: the plugin flags one ball of a pair it takes out of
/// rapier's solver, and the impact is the model's all the same.
#[test]
fn one_ball_of_an_impact_pair_carries_the_hook_flags() {
    let e = 0.9;
    let plugin_flags = ActiveHooks::FILTER_CONTACT_PAIRS | ActiveHooks::MODIFY_SOLVER_CONTACTS;
    for mode in [TimingMode::TimeOfImpact, TimingMode::Exact] {
        let mut w = world_with_gravity(0.0);
        let ((a, ca), (b, cb)) = closing_pair(&mut w, e);
        let mut p = plugin(mode);
        p.set_all_dynamic_bodies_impact(true);
        let mut impact_steps = 0;
        for k in 0..20 {
            p.step(&mut w);
            let flagged = [ca, cb]
                .iter()
                .filter(|c| w.colliders[**c].active_hooks().contains(plugin_flags))
                .count();
            if pair_events(&p).is_empty() {
                assert!(flagged <= 1, "{mode:?}, step {k}: {flagged} balls flagged");
            } else {
                impact_steps += 1;
                assert_eq!(flagged, 1, "{mode:?}, step {k}: the impact's step");
            }
        }
        assert_eq!(impact_steps, 1, "{mode:?}: one impact");
        // Equal masses, head on: (1 -+ e)/2 of the 2 m/s.
        let (va, vb) = (na(w.bodies[a].linvel()).x, na(w.bodies[b].linvel()).x);
        assert!(
            abs_diff_eq!(va, 1.0 - e, epsilon = V_TOL * 2.0),
            "{mode:?}: va {va}"
        );
        assert!(
            abs_diff_eq!(vb, 1.0 + e, epsilon = V_TOL * 2.0),
            "{mode:?}: vb {vb}"
        );
    }
}

#[test]
fn balls_not_opted_in_or_filtered_out_are_rapiers() {
    let run = |opt_in: bool, groups: bool| {
        let mut w = world_with_gravity(0.0);
        let ((a, ca), (_, cb)) = closing_pair(&mut w, 0.9);
        if groups {
            for c in [ca, cb] {
                w.colliders[c].set_collision_groups(InteractionGroups::new(
                    Group::GROUP_1,
                    Group::GROUP_2,
                    InteractionTestMode::And,
                ));
            }
        }
        let mut p = plugin(TimingMode::Exact);
        p.set_all_dynamic_bodies_impact(opt_in);
        let mut pair = 0;
        for _ in 0..30 {
            p.step(&mut w);
            pair += pair_events(&p).len();
        }
        (pair, na(w.bodies[a].linvel()).x)
    };
    assert_eq!(run(true, false).0, 2, "opted in: the plugin's impact");
    let (events, va) = run(false, false);
    assert_eq!(events, 0);
    // rapier's own response: a bounce, not the model's (the cue ball keeps moving forward
    // or stops, but it hit something).
    assert!(va < 2.0);
    // Groups that exclude the pair: they pass through each other, as in rapier alone.
    let (events, va) = run(true, true);
    assert_eq!(events, 0);
    assert_abs_diff_eq!(va, 2.0, epsilon = 1e-6);
}

/// A chain passes an impact on only along links rapier would solve: in a row of touching
/// balls struck at e = 1, the last ball's solver groups leave its contact with the row
/// without impulses (rapier computes it, and solves none), so the ball before it leaves with
/// the striker's speed and the last one stays at rest, as in rapier alone.
#[test]
fn a_chain_stops_at_a_link_rapier_would_not_solve() {
    let (r, e) = (0.02, 1.0);
    let apart = InteractionGroups::new(Group::GROUP_1, Group::NONE, InteractionTestMode::And);
    for mode in [TimingMode::TimeOfImpact, TimingMode::Exact] {
        let mut w = world_with_gravity(0.0);
        let zero = Vector3::zeros();
        let striker = Vector3::new(-2.0 * r - 0.1, 0.0, 0.0);
        let mut balls = vec![ball(
            &mut w,
            striker,
            Vector3::new(1.0, 0.0, 0.0),
            zero,
            r,
            e,
            0.0,
        )];
        for k in 0..3 {
            let at = Vector3::new(2.0 * r * k as f64, 0.0, 0.0);
            balls.push(ball(&mut w, at, zero, zero, r, e, 0.0));
        }
        w.colliders[balls[3].1].set_solver_groups(apart);
        let mut p = plugin(mode);
        p.set_all_dynamic_bodies_impact(true);
        let seen = first_pair_events(&mut p, &mut w, 7);
        assert_eq!(
            seen.len(),
            4,
            "{mode:?}: two impacts, two events each: {seen:?}"
        );
        assert!(
            seen.iter().all(|ev| ev.body != balls[3].0),
            "{mode:?}: the last ball is in no impact"
        );
        let vx: Vec<f64> = balls
            .iter()
            .map(|(h, _)| na(w.bodies[*h].linvel()).x)
            .collect();
        for (k, expected) in [0.0, 0.0, 1.0, 0.0].into_iter().enumerate() {
            assert!(
                abs_diff_eq!(vx[k], expected, epsilon = V_TOL),
                "{mode:?}: ball {k} at {}, expected {expected}",
                vx[k]
            );
        }
    }
}

/// A cue ball rolling at 2 m/s into an object ball at rest on a table (pool balls, e = 0.95,
/// no ball-ball friction): right after the impact the object ball leaves at (1 + e) / 2 v =
/// 1.95 m/s and the cue ball keeps (1 - e) / 2 v = 0.05 m/s with all its topspin.
#[test]
fn a_rolling_cue_ball_sends_the_object_ball_off_at_the_closed_form_speed() {
    let (r, m, e, v) = (0.028_575, 0.17, 0.95, 2.0);
    for mode in [TimingMode::TimeOfImpact, TimingMode::Exact] {
        let mut w = world_with_gravity(G);
        let (_, table) = w.insert(
            RigidBodyBuilder::fixed(),
            ColliderBuilder::halfspace(rapier_impact::rapier::na::Unit::new_unchecked(Vector::Y))
                .friction(0.2),
        );
        // Rolling along +x: w = v / R about -z.
        let (cue, _) = ball(
            &mut w,
            Vector3::new(0.0, r, 0.0),
            Vector3::new(v, 0.0, 0.0),
            Vector3::new(0.0, 0.0, -v / r),
            r,
            e,
            0.0,
        );
        let (object, _) = ball(
            &mut w,
            Vector3::new(0.3, r, 0.0),
            Vector3::zeros(),
            Vector3::zeros(),
            r,
            e,
            0.0,
        );
        let mut p = plugin(mode);
        p.add_ground(&w.bodies, &w.colliders, table).unwrap();
        p.add_impact_body(&w.bodies, cue).unwrap();
        p.add_impact_body(&w.bodies, object).unwrap();
        let mut hit = Vec::new();
        for _ in 0..30 {
            p.step(&mut w);
            hit.extend(pair_events(&p));
        }
        assert_eq!(hit.len(), 2, "{mode:?}: {hit:?}");
        assert!(
            hit.iter().all(|ev| ev.timing == ImpactTiming::InStep),
            "{mode:?}"
        );
        let on_object = hit.iter().find(|ev| ev.body == object).unwrap();
        let on_cue = hit.iter().find(|ev| ev.body == cue).unwrap();
        // The object ball's momentum after is the impulse on it.
        let speed = wide(on_object.impulse.x) / m;
        assert!(
            abs_diff_eq!(speed, (1.0 + e) / 2.0 * v, epsilon = V_TOL * v),
            "{mode:?}: object ball {speed}"
        );
        let kept = v + wide(on_cue.impulse.x) / m;
        assert!(
            abs_diff_eq!(kept, (1.0 - e) / 2.0 * v, epsilon = V_TOL * v),
            "{mode:?}: cue ball {kept}"
        );
        assert_abs_diff_eq!(wide(on_object.impulse.y), 0.0, epsilon = V_TOL * m * v);
    }
}

/// Newton's cradle: five equal balls touching in a row, the first arriving at 1 m/s (or
/// gently, at 0.25 m/s), frictionless, in free space and lying on a frictionless ground. The
/// impact passes along the row inside the step, one pair after the other: at e = 1 the last
/// ball leaves with the first one's speed and the others stop; at e = 0.9 each ball keeps
/// (1 - e)/2 of the speed it was hit with.
#[test]
fn newtons_cradle_passes_the_impact_along_the_row() {
    let r = 0.02;
    // At 1 m/s, and at 0.25 m/s: on the floor that is below the pressed speed (0.31 m/s at
    // 60 Hz), a gentle strike that still passes along the row.
    for (gravity, e, v0) in [
        (0.0, 1.0, 1.0),
        (G, 1.0, 1.0),
        (G, 0.9, 1.0),
        (G, 1.0, 0.25),
        (G, 0.9, 0.25),
    ] {
        for mode in [TimingMode::TimeOfImpact, TimingMode::Exact] {
            let mut w = world_with_gravity(gravity);
            let first = Vector3::new(-2.0 * r - 0.1, r, 0.0);
            let mut balls = vec![
                ball(
                    &mut w,
                    first,
                    Vector3::new(v0, 0.0, 0.0),
                    Vector3::zeros(),
                    r,
                    e,
                    0.0,
                )
                .0,
            ];
            for k in 0..4 {
                balls.push(
                    ball(
                        &mut w,
                        Vector3::new(2.0 * r * k as f64, r, 0.0),
                        Vector3::zeros(),
                        Vector3::zeros(),
                        r,
                        e,
                        0.0,
                    )
                    .0,
                );
            }
            let mut p = plugin(mode);
            if gravity > 0.0 {
                let (_, floor) = w.insert(
                    RigidBodyBuilder::fixed(),
                    ColliderBuilder::halfspace(rapier_impact::rapier::na::Unit::new_unchecked(
                        Vector::Y,
                    ))
                    .friction(0.0),
                );
                p.add_ground(&w.bodies, &w.colliders, floor).unwrap();
            }
            p.set_all_dynamic_bodies_impact(true);
            // The first ball reaches the row in 0.1 s (0.4 s at 0.25 m/s); the chain is over in
            // that step, and the velocities are read right after it (the balls left touching
            // slowly behind it are rapier's resting contacts from the next step, with e = 0).
            let seen = first_pair_events(&mut p, &mut w, 30);
            let case = format!("{mode:?}, g = {gravity}, e = {e}, v0 = {v0}");
            assert_eq!(
                seen.len(),
                8,
                "{case}: four impacts along the row, two events each: {seen:?}"
            );
            assert!(
                seen.iter().all(|ev| ev.timing == ImpactTiming::InStep),
                "{case}"
            );
            let mut hit = v0;
            for (k, h) in balls.iter().enumerate() {
                let vx = na(w.bodies[*h].linvel()).x;
                let expected = if k == 4 { hit } else { (1.0 - e) / 2.0 * hit };
                assert!(
                    abs_diff_eq!(vx, expected, epsilon = V_TOL * v0),
                    "{case}: ball {k} at {vx}, expected {expected}"
                );
                hit *= (1.0 + e) / 2.0;
            }
        }
    }
}

#[test]
fn step_mode_resolves_a_pair_at_the_step_start() {
    let mut w = world_with_gravity(0.0);
    let ((a, _), (b, _)) = closing_pair(&mut w, 1.0);
    let mut p = plugin(MODES[0]);
    p.set_all_dynamic_bodies_impact(true);
    let mut kinds = Vec::new();
    for _ in 0..30 {
        p.step(&mut w);
        kinds.extend(
            p.events()
                .iter()
                .filter(|e| e.body2.is_some())
                .map(|e| (e.kind, e.timing)),
        );
    }
    // As for grounds: the impulse at the start of the step in which the pair closes, once,
    // to the velocities there.
    assert_eq!(
        kinds,
        vec![(EventKind::Impact, ImpactTiming::StepStart); 2],
        "{kinds:?}"
    );
    // Elastic and equal: the speeds exchanged.
    let (va, vb) = (na(w.bodies[a].linvel()).x, na(w.bodies[b].linvel()).x);
    assert_abs_diff_eq!(va, 0.0, epsilon = V_TOL);
    assert_abs_diff_eq!(vb, 2.0, epsilon = V_TOL * 2.0);
}

/// A pile: 100 opted-in balls (5 cm, e = 0.7) dropped into a walled box bounce off each other
/// and come to rest, asleep, none through the floor or a wall: the pressed and slow pairs
/// stay rapier's resting contacts, and chains pass only along balls nothing lies on. The
/// balls have a little spinning friction (`mu_sp` = 0.01): the friction of an impact between
/// two balls can leave one spinning about the vertical on the floor, which rapier's point
/// contact does not brake, nor the closed form without spinning friction, and rapier then
/// never puts the pile to sleep (so it ended in the `libm` build, a ball spinning at 1.6
/// rad/s).
#[test]
fn a_pile_of_opted_in_balls_comes_to_rest() {
    let r = 0.05;
    for mode in [MODES[1], MODES[2], MODES[0]] {
        let mut w = world_with_gravity(G);
        let (_, floor) = w.insert(
            RigidBodyBuilder::fixed(),
            ColliderBuilder::halfspace(rapier_impact::rapier::na::Unit::new_unchecked(Vector::Y))
                .restitution(0.7)
                .friction(0.5),
        );
        let half = 0.3;
        plugin_support::walled_box(&mut w, half);
        let mut balls = Vec::new();
        for k in 0..100 {
            let (layer, cell) = (k / 25, k % 25);
            let at = Vector3::new(
                (cell % 5) as f64 * 0.11 - 0.22 + 0.003 * (k % 3) as f64,
                0.3 + layer as f64 * 0.11,
                (cell / 5) as f64 * 0.11 - 0.22 - 0.002 * (k % 2) as f64,
            );
            let (h, _) = w.insert(
                RigidBodyBuilder::dynamic().translation(Vector::new(
                    real(at.x),
                    real(at.y),
                    real(at.z),
                )),
                ColliderBuilder::ball(real(r))
                    .restitution(0.7)
                    .friction(0.5),
            );
            balls.push(h);
        }
        let mut p = ImpactPlugin::new(
            ImpactConfig::default()
                .with_timing(mode)
                .with_spinning_friction(0.01),
        )
        .unwrap();
        p.add_ground(&w.bodies, &w.colliders, floor).unwrap();
        p.set_all_dynamic_bodies_impact(true);
        let mut pair_impacts = 0;
        for _ in 0..600 {
            p.step(&mut w);
            pair_impacts += pair_events(&p).len();
        }
        assert!(pair_impacts > 0, "{mode:?}: the balls hit each other");
        let awake = balls
            .iter()
            .filter(|h| !w.bodies[**h].is_sleeping())
            .count();
        assert_eq!(
            awake, 0,
            "{mode:?}: all asleep after 10 s ({pair_impacts} pair events)"
        );
        for h in &balls {
            let c = na(w.bodies[*h].center_of_mass());
            assert!(c.y > r - 0.01, "{mode:?}: into the floor: {c:?}");
            assert!(
                c.x.abs() < half && c.z.abs() < half,
                "{mode:?}: through a wall: {c:?}"
            );
        }
    }
}

/// Hard cases: a ball at 100 m/s (6 diameters per step at 60 Hz) does not pass through the
/// ball it meets; a 1e6 mass ratio follows Newton's rule; balls created overlapping, or
/// grazing, or both at rest and touching, give no NaN and no impulse that adds energy.
#[test]
fn fast_heavy_overlapping_and_grazing_pairs() {
    let r = 0.05;
    for mode in [TimingMode::TimeOfImpact, TimingMode::Exact] {
        a_fast_ball_does_not_pass_through_the_ball_it_meets(mode, r);
        a_light_ball_bounces_off_a_heavy_one_by_newtons_rule(mode, r);
        overlapping_grazing_and_touching_balls_gain_no_energy(mode, r);
    }
}

/// Balls of radius `r`, 1 m apart, one at 100 m/s: they meet once, exchange their velocities
/// and end in their order.
fn a_fast_ball_does_not_pass_through_the_ball_it_meets(mode: TimingMode, r: f64) {
    let mut w = world_with_gravity(0.0);
    let zero = Vector3::zeros();
    let (a, _) = ball(
        &mut w,
        zero,
        Vector3::new(100.0, 0.0, 0.0),
        zero,
        r,
        1.0,
        0.0,
    );
    let (b, _) = ball(&mut w, Vector3::new(1.0, 0.0, 0.0), zero, zero, r, 1.0, 0.0);
    let mut p = plugin(mode);
    p.set_all_dynamic_bodies_impact(true);
    let mut hits = 0;
    for _ in 0..3 {
        p.step(&mut w);
        hits += pair_events(&p).len();
    }
    assert_eq!(hits, 2, "{mode:?}: the fast ball hit once");
    let (va, vb) = (na(w.bodies[a].linvel()).x, na(w.bodies[b].linvel()).x);
    assert!(
        abs_diff_eq!(va, 0.0, epsilon = 100.0 * V_TOL)
            && abs_diff_eq!(vb, 100.0, epsilon = 100.0 * V_TOL),
        "{mode:?}: {va} {vb}"
    );
    assert!(na(w.bodies[a].center_of_mass()).x < na(w.bodies[b].center_of_mass()).x);
}

fn a_light_ball_bounces_off_a_heavy_one_by_newtons_rule(mode: TimingMode, r: f64) {
    // A 1e6 mass ratio: the light ball bounces off the heavy one at -e v + (1 + e) V.
    let mut w = world_with_gravity(0.0);
    let light = w.insert(
        RigidBodyBuilder::dynamic()
            .linvel(Vector::new(1.0, 0.0, 0.0))
            .can_sleep(false),
        ColliderBuilder::ball(real(r))
            .density(1.0)
            .restitution(0.5)
            .friction(0.0),
    );
    let heavy = w.insert(
        RigidBodyBuilder::dynamic()
            .translation(Vector::new(0.2, 0.0, 0.0))
            .can_sleep(false),
        ColliderBuilder::ball(real(r))
            .density(1e6)
            .restitution(0.5)
            .friction(0.0),
    );
    let mut p = plugin(mode);
    p.set_all_dynamic_bodies_impact(true);
    for _ in 0..10 {
        p.step(&mut w);
    }
    let (ml, mh) = (
        wide(w.bodies[light.0].mass()),
        wide(w.bodies[heavy.0].mass()),
    );
    let vl = na(w.bodies[light.0].linvel()).x;
    let vh = na(w.bodies[heavy.0].linvel()).x;
    let expected_l = (ml - 0.5 * mh) / (ml + mh);
    let expected_h = (1.5 * ml) / (ml + mh);
    assert!(
        abs_diff_eq!(vl, expected_l, epsilon = V_TOL * 10.0),
        "{mode:?}: light {vl}, expected {expected_l}"
    );
    assert!(
        abs_diff_eq!(vh, expected_h, epsilon = 1e-9 + V_TOL * expected_h),
        "{mode:?}: heavy {vh}, expected {expected_h}"
    );
}

fn overlapping_grazing_and_touching_balls_gain_no_energy(mode: TimingMode, r: f64) {
    let zero = Vector3::zeros();
    // Overlapping by half a radius at creation, approaching; grazing (offset by the
    // sum of the radii less 1e-9); touching at rest.
    let cases = [
        (Vector3::new(0.075, 0.0, 0.0), Vector3::new(0.5, 0.0, 0.0)),
        (
            Vector3::new(0.5, 2.0 * r - 1e-9, 0.0),
            Vector3::new(3.0, 0.0, 0.0),
        ),
        (Vector3::new(2.0 * r, 0.0, 0.0), Vector3::zeros()),
    ];
    for (at, v) in cases {
        let mut w = world_with_gravity(0.0);
        let (a, _) = ball(&mut w, zero, v, zero, r, 0.8, 0.3);
        let (b, _) = ball(&mut w, at, zero, zero, r, 0.8, 0.3);
        let mut p = plugin(mode);
        p.set_all_dynamic_bodies_impact(true);
        let energy = |w: &PhysicsWorld| {
            [a, b]
                .iter()
                .map(|h| {
                    let rb = &w.bodies[*h];
                    0.5 * wide(rb.mass()) * na(rb.linvel()).norm_squared()
                        + 0.5 * wide(rb.mass()) * 0.4 * r * r * na(rb.angvel()).norm_squared()
                })
                .sum::<f64>()
        };
        let e0 = energy(&w);
        for _ in 0..30 {
            p.step(&mut w);
            for ev in p.events() {
                assert!(
                    ev.ke_after.is_finite() && ev.impulse.is_finite(),
                    "{mode:?} {at:?}: {ev:?}"
                );
            }
            let e = energy(&w);
            assert!(
                e.is_finite() && e <= e0 * (1.0 + 1e-5) + 1e-12,
                "{mode:?} {at:?}: energy {e} from {e0}"
            );
        }
    }
}

/// A damped cue ball (so not moved in closed form: the step-end path) at 10 m/s into an
/// object ball 5 cm ahead on a table, 60 Hz: out of rapier's solver the balls pass right
/// through each other in the step; the step end still gives the impact, and puts them back on
/// the sides they started on.
#[test]
fn balls_that_pass_through_each_other_in_the_step_end_path_still_meet() {
    let r = 0.028_575;
    for mode in [TimingMode::TimeOfImpact, TimingMode::Exact] {
        let mut w = world_with_gravity(G);
        let (_, table) = w.insert(
            RigidBodyBuilder::fixed(),
            ColliderBuilder::halfspace(rapier_impact::rapier::na::Unit::new_unchecked(Vector::Y))
                .friction(0.2),
        );
        let (cue, _) = w.insert(
            RigidBodyBuilder::dynamic()
                .translation(Vector::new(0.0, real(r), 0.0))
                .linvel(Vector::new(10.0, 0.0, 0.0))
                .angvel(Vector::new(0.0, 0.0, real(-10.0 / r)))
                .linear_damping(0.01),
            ColliderBuilder::ball(real(r))
                .restitution(0.95)
                .friction(0.0),
        );
        let (object, _) = w.insert(
            RigidBodyBuilder::dynamic().translation(Vector::new(
                real(2.0 * r + 0.05),
                real(r),
                0.0,
            )),
            ColliderBuilder::ball(real(r))
                .restitution(0.95)
                .friction(0.0),
        );
        let mut p = plugin(mode);
        p.add_ground(&w.bodies, &w.colliders, table).unwrap();
        p.set_all_dynamic_bodies_impact(true);
        let mut impacts = 0;
        for _ in 0..3 {
            p.step(&mut w);
            impacts += pair_events(&p).len();
        }
        assert_eq!(impacts, 2, "{mode:?}: the impact, one event per ball");
        let (xc, xo) = (
            na(w.bodies[cue].center_of_mass()).x,
            na(w.bodies[object].center_of_mass()).x,
        );
        assert!(xc < xo, "{mode:?}: the cue ball stays behind: {xc} {xo}");
        let (vc, vo) = (
            na(w.bodies[cue].linvel()).x,
            na(w.bodies[object].linvel()).x,
        );
        assert!(
            vo > 9.0 && vc.abs() < 1.0,
            "{mode:?}: speeds exchanged: {vc} {vo}"
        );
    }
}

#[test]
fn a_pair_with_coefficients_out_of_range_is_rapiers_and_reported_once() {
    let run = |with_plugin: bool| {
        let mut w = world_with_gravity(0.0);
        let (a, ca) = ball(
            &mut w,
            Vector3::zeros(),
            Vector3::x(),
            Vector3::zeros(),
            0.1,
            0.9,
            0.2,
        );
        let (b, _) = ball(
            &mut w,
            Vector3::new(0.5, 0.0, 0.0),
            Vector3::zeros(),
            Vector3::zeros(),
            0.1,
            0.9,
            0.2,
        );
        w.colliders[ca].set_friction(real(f64::NAN));
        let mut p =
            ImpactPlugin::new(ImpactConfig::default().with_timing(TimingMode::TimeOfImpact))
                .unwrap();
        p.add_impact_body(&w.bodies, a).unwrap();
        p.add_impact_body(&w.bodies, b).unwrap();
        let mut diagnostics = Vec::new();
        let mut events = 0;
        for _ in 0..60 {
            if with_plugin {
                p.step(&mut w);
            } else {
                w.step();
            }
            diagnostics.extend_from_slice(p.diagnostics());
            events += p.events().len();
        }
        let v = |h: RigidBodyHandle| w.bodies[h].linvel();
        ((v(a), v(b)), diagnostics, events)
    };
    let (alone, ..) = run(false);
    let (with_plugin, diagnostics, events) = run(true);
    // The balls met (rapier's bounce moved the second).
    assert!(wide(alone.1.x) > 0.5, "{alone:?}");
    assert_eq!(with_plugin, alone);
    assert_eq!(events, 0);
    assert!(
        matches!(
            diagnostics[..],
            [rapier_impact::Diagnostic::CoefficientsOutOfRange { restitution, .. }]
                if (restitution - 0.9).abs() < 1e-6
        ),
        "{diagnostics:?}"
    );
}

/// Two opted-in balls of two dominance groups: rapier lets their contact push only the
/// lower one, as if the other's mass were infinite, and the pair stays rapier's: no event,
/// and both balls end as in rapier alone, the dominant one still at its speed (the model
/// would have stopped it).
#[test]
fn a_pair_of_two_dominance_groups_is_rapiers() {
    for mode in MODES {
        let run = |plugin: bool| {
            let mut w = world_with_gravity(0.0);
            let ((a, _), (b, _)) = closing_pair(&mut w, 0.9);
            w.bodies[a].set_dominance_group(10);
            let mut p = self::plugin(mode);
            p.set_all_dynamic_bodies_impact(true);
            let mut events = 0;
            for _ in 0..30 {
                if plugin {
                    p.step(&mut w);
                    events += pair_events(&p).len();
                } else {
                    w.step();
                }
            }
            let v = |h: RigidBodyHandle| na(w.bodies[h].linvel()).x;
            (events, v(a), v(b))
        };
        let (events, va, vb) = run(true);
        let (_, alone_a, alone_b) = run(false);
        assert_eq!(events, 0, "{mode:?}");
        assert_eq!((va, vb), (alone_a, alone_b), "{mode:?}: as in rapier alone");
        assert_abs_diff_eq!(va, 2.0, epsilon = 1e-6);
    }
}

/// A heavy ball strikes a light one lying 3 cm in front of a second light one (e = 1, no
/// friction), in free space and on a floor: the struck ball leaves at nearly twice the
/// striker's speed and meets the second one inside the same step. It must hit it, never pass
/// through it. In free space the second ball has a flight to move by (in `TimeOfImpact` mode
/// too, as an opted-in body), and the three move together: every impact is in the step, at
/// its closed form (the second ball leaves with the struck ball's speed), and momentum and
/// energy are kept. Resting on the floor, held by rapier's contact, it cannot be moved with
/// them: the strike is left to the step's end, and the struck ball meets the second one in
/// the next step.
#[test]
fn a_ball_sent_by_an_impact_meets_the_ball_in_front_of_it() {
    let (r, v, m_light, m_heavy) = (0.02, 6.0, 0.17, 50.0 * 0.17);
    let heavy = |w: &mut PhysicsWorld, y: f64| {
        let volume = 4.0 / 3.0 * std::f64::consts::PI * r * r * r;
        w.insert(
            RigidBodyBuilder::dynamic()
                .translation(Vector::new(real(-0.2), real(y), 0.0))
                .linvel(Vector::new(real(v), 0.0, 0.0))
                .can_sleep(false),
            ColliderBuilder::ball(real(r))
                .density(real(m_heavy / volume))
                .restitution(1.0)
                .friction(0.0),
        )
        .0
    };
    for on_floor in [false, true] {
        for mode in [TimingMode::TimeOfImpact, TimingMode::Exact] {
            let label = format!("{mode:?}, on the floor: {on_floor}");
            let (gravity, y) = if on_floor { (G, r) } else { (0.0, 0.0) };
            let mut w = world_with_gravity(gravity);
            let mut p = plugin(mode);
            if on_floor {
                let floor = floor(&mut w, 1.0, 0.0);
                p.add_ground(&w.bodies, &w.colliders, floor).unwrap();
            }
            let zero = Vector3::zeros();
            let a = heavy(&mut w, y);
            let (b, _) = ball(&mut w, Vector3::new(0.0, y, 0.0), zero, zero, r, 1.0, 0.0);
            let (c, _) = ball(&mut w, Vector3::new(0.07, y, 0.0), zero, zero, r, 1.0, 0.0);
            p.set_all_dynamic_bodies_impact(true);
            let masses = [(a, m_heavy), (b, m_light), (c, m_light)];
            let x_momentum = |w: &PhysicsWorld| momentum_x(w, &masses);
            let energy = |w: &PhysicsWorld| translational_energy(w, &masses);
            let (p0, e0) = (x_momentum(&w), energy(&w));
            let (mut first_ab, mut bc) = (None, Vec::new());
            for n in 0..6 {
                p.step(&mut w);
                for ev in pair_events(&p) {
                    if ev.body == b && ev.body2 == Some(a) && first_ab.is_none() {
                        first_ab = Some(n);
                    }
                    if ev.body == c && ev.body2 == Some(b) {
                        bc.push((n, ev));
                    }
                }
                let x = |h: RigidBodyHandle| na(w.bodies[h].translation()).x;
                assert!(
                    x(b) < x(c),
                    "{label}: step {n}: B at {} passed C at {}",
                    x(b),
                    x(c)
                );
                assert!(
                    energy(&w) <= e0 * (1.0 + V_TOL),
                    "{label}: step {n}: energy {} from {e0}",
                    energy(&w)
                );
                if !on_floor {
                    let p1 = x_momentum(&w);
                    assert!(
                        abs_diff_eq!(p1, p0, epsilon = V_TOL * p0),
                        "{label}: step {n}: momentum {p1} from {p0}"
                    );
                }
            }
            let first_ab = first_ab.unwrap_or_else(|| panic!("{label}: A never hit B"));
            let &(n, hit) = bc
                .first()
                .unwrap_or_else(|| panic!("{label}: B never hit C"));
            if !on_floor {
                // The struck ball's speed, 2 m_A / (m_A + m_B) v, passed on whole to C.
                let sent = 2.0 * m_heavy / (m_heavy + m_light) * v;
                let speed = wide(hit.impulse.x) / m_light;
                assert_eq!(n, first_ab, "{label}: B met C a step late");
                assert_eq!(hit.timing, ImpactTiming::InStep, "{label}");
                assert!(
                    abs_diff_eq!(speed, sent, epsilon = V_TOL * sent),
                    "{label}: C leaves at {speed}, the closed form {sent}"
                );
                assert!(
                    abs_diff_eq!(energy(&w), e0, epsilon = V_TOL * e0),
                    "{label}: energy {} from {e0}",
                    energy(&w)
                );
            } else {
                assert_eq!(n, first_ab + 1, "{label}");
            }
        }
    }
}

/// Two billiard balls on a table pass each other 0.5 mm apart and never touch, the cue ball
/// damped (so that the pair takes the step's-end path): no impact. Their centres cross the
/// line of centres they started on, which alone does not make them meet; in `Step` mode,
/// their gap closing within the step's reach does not either.
#[test]
fn balls_passing_each_other_without_touching_get_no_impact() {
    let r = 0.028_575;
    let runs = [
        (TimingMode::TimeOfImpact, 10.0),
        (TimingMode::Exact, 10.0),
        (TimingMode::Step, 4.0),
    ];
    for (mode, v) in runs {
        let mut w = world_with_gravity(G);
        let table = floor(&mut w, 0.5, 0.2);
        let mut p = plugin(mode);
        p.add_ground(&w.bodies, &w.colliders, table).unwrap();
        w.insert(
            RigidBodyBuilder::dynamic()
                .translation(Vector::new(0.0, real(r), 0.0))
                .linvel(Vector::new(real(v), 0.0, 0.0))
                .angvel(Vector::new(0.0, 0.0, real(-v / r)))
                .linear_damping(0.01),
            ColliderBuilder::ball(real(r))
                .restitution(0.95)
                .friction(0.05),
        );
        w.insert(
            RigidBodyBuilder::dynamic().translation(Vector::new(
                0.2,
                real(r),
                real(2.0 * r + 0.0005),
            )),
            ColliderBuilder::ball(real(r))
                .restitution(0.95)
                .friction(0.05),
        );
        p.set_all_dynamic_bodies_impact(true);
        let mut seen = Vec::new();
        for _ in 0..8 {
            p.step(&mut w);
            seen.extend(
                p.events()
                    .iter()
                    .filter(|e| e.body2.is_some())
                    .map(|e| e.kind),
            );
        }
        assert!(seen.is_empty(), "{mode:?}: {seen:?}");
    }
}

/// Newton's cradle with gaps: five 2 cm balls 8 mm apart in free space (within rapier's
/// prediction distance, so that each lies in a speculative contact with the next that pushes
/// nothing), e = 1, the first arriving at 1 m/s. Each ball passes the whole speed on to the
/// next: the last leaves at 1 m/s and the others stop, the energy kept. A contact that pushed
/// nothing is no contact: the struck ball is moved alone, not left to rapier's solver, whose
/// resting contacts would share the speed among the last three (a third each). In `Exact`
/// mode every impact is in the step.
#[test]
fn a_cradle_with_gaps_passes_the_whole_speed_along() {
    let (r, gap, v) = (0.02, 0.008, 1.0);
    for mode in [TimingMode::TimeOfImpact, TimingMode::Exact] {
        let mut w = world_with_gravity(0.0);
        let zero = Vector3::zeros();
        let mut balls = vec![
            ball(
                &mut w,
                Vector3::new(-0.14, 0.0, 0.0),
                Vector3::x() * v,
                zero,
                r,
                1.0,
                0.0,
            )
            .0,
        ];
        for k in 0..4 {
            let at = Vector3::new((2.0 * r + gap) * k as f64, 0.0, 0.0);
            balls.push(ball(&mut w, at, zero, zero, r, 1.0, 0.0).0);
        }
        let mut p = plugin(mode);
        p.set_all_dynamic_bodies_impact(true);
        let mut timings = Vec::new();
        for _ in 0..20 {
            p.step(&mut w);
            timings.extend(pair_events(&p).iter().map(|e| e.timing));
        }
        let vs: Vec<f64> = balls.iter().map(|h| na(w.bodies[*h].linvel()).x).collect();
        let want = [0.0, 0.0, 0.0, 0.0, v];
        assert!(
            vs.iter()
                .zip(want)
                .all(|(got, want)| abs_diff_eq!(*got, want, epsilon = V_TOL * v)),
            "{mode:?}: velocities {vs:?}"
        );
        assert_eq!(timings.len(), 8, "{mode:?}: {timings:?}");
        if mode == TimingMode::Exact {
            assert!(
                timings.iter().all(|t| *t == ImpactTiming::InStep),
                "{timings:?}"
            );
        }
    }
}

/// A heavy ball of `m` = 50 x 0.17 kg (r = 2 cm, e = 1, frictionless) at `x` moving at `v`
/// along x.
fn heavy_ball(w: &mut PhysicsWorld, x: f64, v: f64) -> RigidBodyHandle {
    let (r, m) = (0.02, 50.0 * 0.17);
    let volume = 4.0 / 3.0 * std::f64::consts::PI * r * r * r;
    w.insert(
        RigidBodyBuilder::dynamic()
            .translation(Vector::new(real(x), 0.0, 0.0))
            .linvel(Vector::new(real(v), 0.0, 0.0))
            .can_sleep(false),
        ColliderBuilder::ball(real(r))
            .density(real(m / volume))
            .restitution(1.0)
            .friction(0.0),
    )
    .0
}

/// Two strikes from either side send their light balls into one free ball between them in
/// the same step, at different times (free space, e = 1, `Exact`): each joins it on its way,
/// one after the other. Momentum is kept: the free ball moved with the first strike is
/// never moved again from its start by the second.
#[test]
fn a_ball_reached_by_two_strikes_in_one_step_keeps_the_momentum() {
    let r = 0.02;
    let zero = Vector3::zeros();
    let mut w = world_with_gravity(0.0);
    let mut p = plugin(TimingMode::Exact);
    let a1 = heavy_ball(&mut w, -0.141, 3.0);
    let (b1, _) = ball(
        &mut w,
        Vector3::new(-0.1, 0.0, 0.0),
        zero,
        zero,
        r,
        1.0,
        0.0,
    );
    let (x, _) = ball(&mut w, zero, zero, zero, r, 1.0, 0.0);
    let (b2, _) = ball(
        &mut w,
        Vector3::new(0.125, 0.0, 0.0),
        zero,
        zero,
        r,
        1.0,
        0.0,
    );
    let a2 = heavy_ball(&mut w, 0.185, -4.0);
    p.set_all_dynamic_bodies_impact(true);
    let (heavy, light) = (50.0 * 0.17, 0.17);
    let masses = [
        (a1, heavy),
        (b1, light),
        (x, light),
        (b2, light),
        (a2, heavy),
    ];
    let momentum = |w: &PhysicsWorld| momentum_x(w, &masses);
    let before = momentum(&w);
    let mut hit_x = 0;
    for _ in 0..3 {
        p.step(&mut w);
        hit_x += pair_events(&p).iter().filter(|e| e.body == x).count();
        let now = momentum(&w);
        assert!(
            abs_diff_eq!(now, before, epsilon = V_TOL * before.abs()),
            "momentum {before} -> {now}"
        );
    }
    assert!(hit_x > 0, "the free ball was never struck");
}

/// Newton's cradle of up to eleven touching balls struck at 5 m/s (free space, e = 1): the
/// impact passes along the row inside the step, however many balls a struck ball's way on
/// reaches beyond its neighbour; the last leaves at 5 m/s.
#[test]
fn a_long_fast_cradle_stays_in_the_step() {
    let (r, v) = (0.02, 5.0);
    for n in [6usize, 11] {
        for mode in [TimingMode::TimeOfImpact, TimingMode::Exact] {
            let mut w = world_with_gravity(0.0);
            let zero = Vector3::zeros();
            let first = Vector3::new(-2.0 * r - 0.1, 0.0, 0.0);
            ball(&mut w, first, Vector3::x() * v, zero, r, 1.0, 0.0);
            let row = touching_row(&mut w, 0.0, 0.0, r, n - 1);
            let mut p = plugin(mode);
            p.set_all_dynamic_bodies_impact(true);
            let seen = first_pair_events(&mut p, &mut w, 30);
            let label = format!("{mode:?}, {n} balls");
            assert_eq!(seen.len(), 2 * (n - 1), "{label}");
            assert_in_step(&seen, &label);
            let last = na(w.bodies[row[n - 2]].linvel()).x;
            assert!(
                abs_diff_eq!(last, v, epsilon = V_TOL * v),
                "{mode:?}, {n} balls: the last leaves at {last}"
            );
        }
    }
}

/// A ball passes right through another (the other turned by a user torque, so that the
/// pair takes the step's-end path) and bounces off the floor within the same step: their
/// relative motion bent on the way, and the pair met (the impact at the step's end).
#[test]
fn a_ball_through_a_ball_then_off_the_floor_meets_it() {
    let r = 0.02;
    let (h, d, v) = (0.07, 0.06, 12.0);
    let zero = Vector3::zeros();
    for mode in [TimingMode::TimeOfImpact, TimingMode::Exact] {
        let mut w = world_with_gravity(0.0);
        let mut p = plugin(mode);
        let floor = floor(&mut w, 1.0, 0.0);
        p.add_ground(&w.bodies, &w.colliders, floor).unwrap();
        let at = Vector3::new(-d, h + d, 0.0);
        ball(&mut w, at, Vector3::new(v, -v, 0.0), zero, r, 1.0, 0.0);
        let (b, _) = ball(&mut w, Vector3::new(0.0, h, 0.0), zero, zero, r, 1.0, 0.0);
        w.bodies[b].add_torque(Vector::new(0.0, 0.0, real(1e-4)), true);
        p.set_all_dynamic_bodies_impact(true);
        p.step(&mut w);
        assert!(
            !pair_events(&p).is_empty(),
            "{mode:?}: passed through, no impact"
        );
    }
}

/// Two 5 cm balls placed overlapping by 2.5 cm, one approaching at 0.5 m/s with a sideways
/// slip, the other spinning (mu = 0.5, e = 0.8, free space): the impact at the step's start
/// is the spheres' closed form, each lever arm the ball's radius, so the struck ball's spin
/// about z ends at 18.75 rad/s (the overlap taken off its lever arm gives 24.88).
#[test]
fn overlapping_balls_turn_about_their_radii() {
    let r = 0.05;
    let zero = Vector3::zeros();
    for mode in MODES {
        let mut w = world_with_gravity(0.0);
        let mut p = plugin(mode);
        let v = Vector3::new(0.5, 0.3, 0.0);
        ball(&mut w, zero, v, zero, r, 0.8, 0.5);
        let spin = Vector3::new(0.0, 0.0, 30.0);
        let (b, _) = ball(
            &mut w,
            Vector3::new(0.075, 0.0, 0.0),
            zero,
            spin,
            r,
            0.8,
            0.5,
        );
        p.set_all_dynamic_bodies_impact(true);
        p.step(&mut w);
        let wz = na(w.bodies[b].angvel()).z;
        assert!(
            abs_diff_eq!(wz, 18.75, epsilon = V_TOL * 18.75),
            "{mode:?}: spin {wz}, the closed form 18.75"
        );
    }
}

/// A ball rolling at 1 m/s into a row of four balls lying touching on a table with friction
/// (e = 1 between the balls, frictionless between them): the search for the first touch of
/// two neighbours lying a rounding apart does not stall, every impact is in the step, and
/// the last ball leaves with the whole speed (its impulse is m v).
#[test]
fn a_cradle_on_a_table_with_friction_is_resolved_in_the_step() {
    let (r, v, m) = (0.02, 1.0, 0.17);
    for mode in [TimingMode::TimeOfImpact, TimingMode::Exact] {
        let mut w = world_with_gravity(G);
        let table = floor(&mut w, 0.5, 0.2);
        let mut p = plugin(mode);
        p.add_ground(&w.bodies, &w.colliders, table).unwrap();
        let spin = Vector3::new(0.0, 0.0, -v / r);
        ball(
            &mut w,
            Vector3::new(-0.1, r, 0.0),
            Vector3::x() * v,
            spin,
            r,
            1.0,
            0.0,
        );
        let last = touching_row(&mut w, 0.05, r, r, 4)[3];
        p.set_all_dynamic_bodies_impact(true);
        let mut seen = Vec::new();
        for _ in 0..10 {
            p.step(&mut w);
            seen.extend(pair_events(&p));
        }
        assert_in_step(&seen, &format!("{mode:?}"));
        let on_last = seen.iter().find(|e| e.body == last).unwrap();
        let speed = wide(on_last.impulse.x) / m;
        assert!(
            abs_diff_eq!(speed, v, epsilon = V_TOL * v),
            "{mode:?}: the last ball leaves at {speed}"
        );
    }
}

/// Two strikes in one step: a heavy ball sends a light one off at nearly twice its speed,
/// while a light ball strikes the next one, which the first then meets in that step (free
/// space, e = 1, `Exact`). The two clusters of impacts become one: every impact is in the
/// step, and momentum and energy are kept.
#[test]
fn two_strikes_whose_balls_meet_are_moved_together() {
    let r = 0.02;
    let zero = Vector3::zeros();
    let mut w = world_with_gravity(0.0);
    let mut p = plugin(TimingMode::Exact);
    let a = heavy_ball(&mut w, -0.2, 6.0);
    let (b, _) = ball(&mut w, zero, zero, zero, r, 1.0, 0.0);
    let (c, _) = ball(
        &mut w,
        Vector3::new(0.07, 0.0, 0.0),
        zero,
        zero,
        r,
        1.0,
        0.0,
    );
    let at = Vector3::new(0.07 + 2.0 * r + 0.0283, 0.0, 0.0);
    let (d, _) = ball(&mut w, at, Vector3::new(-1.0, 0.0, 0.0), zero, r, 1.0, 0.0);
    p.set_all_dynamic_bodies_impact(true);
    let masses = [(a, 50.0 * 0.17), (b, 0.17), (c, 0.17), (d, 0.17)];
    let momentum = |w: &PhysicsWorld| momentum_x(w, &masses);
    let energy = |w: &PhysicsWorld| translational_energy(w, &masses);
    let (p0, e0) = (momentum(&w), energy(&w));
    let seen = first_pair_events(&mut p, &mut w, 5);
    let pairs: Vec<_> = seen.iter().map(|e| (e.body, e.body2, e.timing)).collect();
    assert!(
        seen.iter().any(|e| e.body == d && e.body2 == Some(c))
            && seen.iter().any(|e| e.body == b && e.body2 == Some(c)),
        "the strikes and B meeting C are not all in one step: {pairs:?}"
    );
    assert!(
        seen.iter().all(|e| e.timing == ImpactTiming::InStep),
        "{pairs:?}"
    );
    let scale = 50.0 * 0.17 * 6.0;
    assert!(abs_diff_eq!(momentum(&w), p0, epsilon = V_TOL * scale));
    assert!(
        abs_diff_eq!(energy(&w), e0, epsilon = V_TOL * e0),
        "{} from {e0}",
        energy(&w)
    );
}

/// A ball catches up with one an impact has just slowed, within the step (free space,
/// e = 1): J and K at 3 m/s one behind the other, K catching A at 1 m/s. K leaves at
/// 1 m/s and J meets it in the same step: in `Exact` mode every impact is in the step at
/// its closed form (J ends at 1 m/s, K and A at 3 m/s), and in either mode J never ends
/// inside K.
#[test]
fn a_ball_catching_up_with_a_slowed_ball_meets_it() {
    let r = 0.02;
    let zero = Vector3::zeros();
    for mode in [TimingMode::TimeOfImpact, TimingMode::Exact] {
        let mut w = world_with_gravity(0.0);
        let mut p = plugin(mode);
        let v = |x: f64| Vector3::new(x, 0.0, 0.0);
        let (j, _) = ball(&mut w, zero, v(3.0), zero, r, 1.0, 0.0);
        let (k, _) = ball(&mut w, v(0.05), v(3.0), zero, r, 1.0, 0.0);
        let (a, _) = ball(&mut w, v(0.095), v(1.0), zero, r, 1.0, 0.0);
        p.set_all_dynamic_bodies_impact(true);
        let mut seen = Vec::new();
        for n in 0..3 {
            p.step(&mut w);
            seen.extend(pair_events(&p).iter().map(|e| e.timing));
            let gap = na(w.bodies[k].translation()).x - na(w.bodies[j].translation()).x;
            // In `TimeOfImpact` mode J, which has no plan of its own in free space, is not
            // moved with K and A: the impact is left to the step's end, where J may lie
            // inside K (by 4 mm here) until the next step resolves them.
            let least = if mode == TimingMode::Exact {
                2.0 * r - 1e-4
            } else {
                0.0
            };
            assert!(gap > least, "{mode:?}: step {n}: J {gap} behind K");
        }
        if mode == TimingMode::Exact {
            assert!(seen.iter().all(|t| *t == ImpactTiming::InStep), "{seen:?}");
            let vx = |h: RigidBodyHandle| na(w.bodies[h].linvel()).x;
            for (h, want) in [(j, 1.0), (k, 3.0), (a, 3.0)] {
                assert!(
                    abs_diff_eq!(vx(h), want, epsilon = V_TOL * 3.0),
                    "{}",
                    vx(h)
                );
            }
        }
    }
}

/// A ball struck towards one its collision groups let it pass (free space, e = 1): rapier
/// would not solve that pair, so the struck ball passes it, in the step, untouched.
#[test]
fn a_ball_sent_off_passes_a_ball_its_groups_let_through() {
    let r = 0.02;
    let zero = Vector3::zeros();
    for mode in [TimingMode::TimeOfImpact, TimingMode::Exact] {
        let mut w = world_with_gravity(0.0);
        let mut p = plugin(mode);
        ball(&mut w, zero, Vector3::x() * 6.0, zero, r, 1.0, 0.0);
        let (b, cb) = ball(
            &mut w,
            Vector3::new(0.06, 0.0, 0.0),
            zero,
            zero,
            r,
            1.0,
            0.0,
        );
        let (c, cc) = ball(
            &mut w,
            Vector3::new(0.12, 0.0, 0.0),
            zero,
            zero,
            r,
            1.0,
            0.0,
        );
        let groups =
            |member, filter| InteractionGroups::new(member, filter, InteractionTestMode::And);
        w.colliders[cb].set_collision_groups(groups(Group::GROUP_2, Group::ALL));
        w.colliders[cc].set_collision_groups(groups(Group::GROUP_3, Group::GROUP_1));
        p.set_all_dynamic_bodies_impact(true);
        for _ in 0..3 {
            p.step(&mut w);
            let met = pair_events(&p)
                .iter()
                .any(|e| e.body == c || e.body2 == Some(c));
            assert!(!met, "{mode:?}: B and C met");
        }
        assert!(
            na(w.bodies[b].translation()).x > 0.2,
            "{mode:?}: B did not pass C"
        );
        assert_eq!(na(w.bodies[c].linvel()).x, 0.0, "{mode:?}");
    }
}

/// A ball at 6 m/s strikes the first of a row of six lying 1.5 cm apart in free space (e = 1,
/// no friction, equal masses): the speed passes along the whole row within the step, the
/// striker and each ball stopping as it passes it on, momentum and energy kept. The balls
/// beyond the striker's reach at the step's start are in no pair of the plan; each is met
/// by a ball an impact sends off, and joins the cluster's run where it is met: one run for
/// the whole row (moved again from the start for each ball met, the row cost the square of
/// its length).
#[test]
fn a_row_struck_in_free_space_passes_the_speed_along_in_one_run() {
    let (r, gap, v) = (0.02, 0.015, 6.0);
    for mode in [TimingMode::TimeOfImpact, TimingMode::Exact] {
        let mut w = world_with_gravity(0.0);
        let zero = Vector3::zeros();
        let striker = Vector3::new(-2.0 * r - 0.005, 0.0, 0.0);
        let mut balls = vec![ball(&mut w, striker, Vector3::x() * v, zero, r, 1.0, 0.0).0];
        for k in 0..6 {
            let at = Vector3::new((2.0 * r + gap) * k as f64, 0.0, 0.0);
            balls.push(ball(&mut w, at, zero, zero, r, 1.0, 0.0).0);
        }
        let mut p = plugin(mode);
        p.set_all_dynamic_bodies_impact(true);
        p.set_profiling(true);
        let masses: Vec<_> = balls.iter().map(|h| (*h, 0.17)).collect();
        let (p0, e0) = (momentum_x(&w, &masses), translational_energy(&w, &masses));
        p.step(&mut w);
        let label = format!("{mode:?}");
        let events = pair_events(&p);
        assert_in_step(&events, &label);
        // Two events an impact, one for each ball of the row passing the speed on.
        assert_eq!(events.len(), 2 * 6, "{label}: {events:?}");
        let runs = p.profile().unwrap().counts.cluster_runs;
        assert_eq!(runs, 1, "{label}: the row moved {runs} times");
        let vs: Vec<f64> = balls.iter().map(|h| na(w.bodies[*h].linvel()).x).collect();
        let mut want = [0.0; 7];
        want[6] = v;
        assert!(
            vs.iter()
                .zip(want)
                .all(|(got, want)| abs_diff_eq!(*got, want, epsilon = V_TOL * v)),
            "{label}: velocities {vs:?}"
        );
        let (p1, e1) = (momentum_x(&w, &masses), translational_energy(&w, &masses));
        assert_abs_diff_eq!(p1, p0, epsilon = V_TOL * p0);
        assert_abs_diff_eq!(e1, e0, epsilon = V_TOL * e0);
    }
}

/// The stacked-ball drop: a tennis ball (3.3 cm, 57 g) on a basketball (12 cm, 600 g), both
/// dropped from rest, touching or 3 cm apart, e = 1, no friction. The basketball bounces off
/// the floor and meets the tennis ball, still falling, in the same step: they approach at
/// twice the basketball's landing speed (both fell alike), and the impulse is the closed form
/// `(1 + e) mu w` (`mu` the reduced mass), which launches the tennis ball at
/// `(3 M - m) / (M + m)` times the landing speed. At the step's start the two were not
/// approaching: the basketball's bounce turns it onto the tennis ball, so the pair is planned
/// as an impact. In `Exact` mode, 3 cm apart, the basketball flies alone to the floor and the
/// approach is the closed form of the drop, `2 sqrt(2 g h)`. Never do the balls overlap.
#[test]
fn a_ball_dropped_on_a_ball_is_launched_in_the_step_of_the_bounce() {
    let (big_r, big_m, small_r, small_m) = (0.12, 0.6, 0.033, 0.057);
    let reduced = big_m * small_m / (big_m + small_m);
    let landing = (2.0 * G * (1.0 - big_r)).sqrt();
    for gap in [0.0, 0.03] {
        for mode in [TimingMode::TimeOfImpact, TimingMode::Exact] {
            let label = format!("{mode:?}, {gap} m apart");
            let mut w = world_with_gravity(G);
            let floor = floor(&mut w, 1.0, 0.0);
            let ball_of = |w: &mut PhysicsWorld, y: f64, r: f64, m: f64| {
                let volume = 4.0 / 3.0 * std::f64::consts::PI * r * r * r;
                w.insert(
                    RigidBodyBuilder::dynamic()
                        .translation(Vector::new(0.0, real(y), 0.0))
                        .can_sleep(false),
                    ColliderBuilder::ball(real(r))
                        .density(real(m / volume))
                        .restitution(1.0)
                        .friction(0.0),
                )
                .0
            };
            let big = ball_of(&mut w, 1.0, big_r, big_m);
            let small = ball_of(&mut w, 1.0 + big_r + small_r + gap, small_r, small_m);
            let mut p = plugin(mode);
            p.add_ground(&w.bodies, &w.colliders, floor).unwrap();
            p.set_all_dynamic_bodies_impact(true);
            let mut landed = None;
            let mut launched = None;
            for n in 0..60 {
                p.step(&mut w);
                for e in p.events().iter().filter(|e| e.kind == EventKind::Impact) {
                    match (e.body, e.body2) {
                        (b, None) if b == big && landed.is_none() => landed = Some((n, *e)),
                        (s, Some(_)) if s == small && launched.is_none() => {
                            launched = Some((n, *e))
                        }
                        _ => {}
                    }
                }
                let (a, b) = (
                    na(w.bodies[big].translation()),
                    na(w.bodies[small].translation()),
                );
                let overlap = big_r + small_r - (b - a).norm();
                assert!(overlap < 1e-4, "{label}: step {n}: overlap {overlap}");
            }
            let (n_landed, landing_event) = landed.unwrap_or_else(|| panic!("{label}: no landing"));
            let (n_launched, hit) = launched.unwrap_or_else(|| panic!("{label}: no launch"));
            assert_eq!(n_launched, n_landed, "{label}: launched a step late");
            assert_eq!(hit.timing, ImpactTiming::InStep, "{label}");
            assert!(
                hit.time >= landing_event.time,
                "{label}: met before the landing"
            );
            // Both fell alike: the approach is twice the basketball's landing speed.
            let w_pair = 2.0 * landing_event.approach_speed;
            assert!(
                abs_diff_eq!(hit.approach_speed, w_pair, epsilon = V_TOL * w_pair),
                "{label}: approach {} against {w_pair}",
                hit.approach_speed
            );
            let impulse = 2.0 * reduced * hit.approach_speed;
            assert!(
                abs_diff_eq!(hit.normal_impulse, impulse, epsilon = V_TOL * impulse),
                "{label}: impulse {} against {impulse}",
                hit.normal_impulse
            );
            if mode == TimingMode::Exact && gap > 0.0 {
                assert!(
                    abs_diff_eq!(hit.approach_speed, 2.0 * landing, epsilon = V_TOL * landing),
                    "{label}: approach {} against the drop's {}",
                    hit.approach_speed,
                    2.0 * landing
                );
            }
        }
    }
}

/// A ball dropped from 0.8 m onto a stack of two resting on the floor (5 cm balls, e = 0.7):
/// the top ball of the stack lies on the bottom one, which the floor holds. Neither can be
/// moved alone through the impact, so the pair is rapier's, which resolves it with the
/// stack's other contacts: through the landing (the 25 steps after the drop) the plugin
/// resolves no impact between the balls and they never sink into each other beyond rapier's
/// own resting depth (rapier alone: 2.7 mm). Out of rapier's solver, the landing left the
/// balls 8 to 10 cm inside each other. (The bounces that follow still leave up to 2 cm for a
/// few steps where a pair pushed apart at the step's end is pushed into the third ball.)
#[test]
fn a_ball_dropped_on_a_stack_is_rapiers_resting_contact() {
    let r = 0.05;
    for mode in [TimingMode::TimeOfImpact, TimingMode::Exact] {
        let mut w = world_with_gravity(G);
        let floor = floor(&mut w, 0.7, 0.5);
        let zero = Vector3::zeros();
        let bottom = ball(&mut w, Vector3::new(0.0, r, 0.0), zero, zero, r, 0.7, 0.5).0;
        let top = ball(
            &mut w,
            Vector3::new(0.0, 3.0 * r, 0.0),
            zero,
            zero,
            r,
            0.7,
            0.5,
        )
        .0;
        let mut p = plugin(mode);
        p.add_ground(&w.bodies, &w.colliders, floor).unwrap();
        p.set_all_dynamic_bodies_impact(true);
        for _ in 0..30 {
            p.step(&mut w);
        }
        let dropped = ball(&mut w, Vector3::new(0.0, 0.8, 0.0), zero, zero, r, 0.7, 0.5).0;
        let balls = [bottom, top, dropped];
        let mut met = false;
        for n in 0..25 {
            p.step(&mut w);
            assert!(
                pair_events(&p).is_empty(),
                "{mode:?}: step {n}: {:?}",
                pair_events(&p)
            );
            for (i, a) in balls.iter().enumerate() {
                for b in &balls[i + 1..] {
                    let d =
                        (na(w.bodies[*a].translation()) - na(w.bodies[*b].translation())).norm();
                    let overlap = 2.0 * r - d;
                    met |= overlap > 0.0 && *b == dropped;
                    assert!(overlap < 0.005, "{mode:?}: step {n}: overlap {overlap}");
                }
            }
        }
        assert!(met, "{mode:?}: the dropped ball never reached the stack");
    }
}

/// A ball dropped from 30 cm exactly onto a ball resting on the floor (5 cm balls): after its
/// bounces it comes to rest balanced on it, as under rapier alone, never more than rapier's
/// resting depth into it. Its last slow impacts leave it approaching the lower ball by what
/// gravity adds over the rest of a step; lying on a ball that lies on the ground, the pair
/// then rests in rapier's solver, and rapier, which recycles a pair's contacts while its
/// bodies hardly move, solves it with fresh contacts rather than the ones the plugin emptied
/// while it was an impact. (It sank 7 cm into the lower ball, a step's fall at a time.)
#[test]
fn a_ball_dropped_on_a_ball_comes_to_rest_on_it() {
    let r = 0.05;
    for e in [0.7, 0.0] {
        for mode in [TimingMode::TimeOfImpact, TimingMode::Exact] {
            let mut w = world_with_gravity(G);
            let floor = floor(&mut w, e, 0.5);
            let zero = Vector3::zeros();
            let lower = ball(&mut w, Vector3::new(0.0, r, 0.0), zero, zero, r, e, 0.5).0;
            let mut p = plugin(mode);
            p.add_ground(&w.bodies, &w.colliders, floor).unwrap();
            p.set_all_dynamic_bodies_impact(true);
            for _ in 0..10 {
                p.step(&mut w);
            }
            let upper = ball(
                &mut w,
                Vector3::new(0.0, 2.0 * r + 0.3, 0.0),
                zero,
                zero,
                r,
                e,
                0.5,
            )
            .0;
            for n in 0..200 {
                p.step(&mut w);
                let d =
                    (na(w.bodies[upper].translation()) - na(w.bodies[lower].translation())).norm();
                let overlap = 2.0 * r - d;
                assert!(
                    overlap < 0.005,
                    "e = {e}, {mode:?}: step {n}: overlap {overlap}"
                );
            }
            let y = na(w.bodies[upper].translation()).y;
            assert!(
                y > 3.0 * r - 0.005,
                "e = {e}, {mode:?}: the upper ball ends at {y}"
            );
        }
    }
}

/// Three balls stacked touching and dropped (a basketball, a tennis ball, a ping-pong ball;
/// e = 1, no friction): the bounce passes up the stack in the step of the landing, the
/// ping-pong ball sent up at many times the landing speed. It must never pass the tennis
/// ball: the cluster follows the light ball up and away from the floor (a bound on where it
/// can go that ignored its direction found the floor below it, and gave the whole stack up
/// to the step's end, where the ping-pong ball ended below the tennis ball).
#[test]
fn a_stack_of_three_balls_passes_the_bounce_up_in_the_step() {
    let radii = [0.12, 0.033, 0.02];
    let masses = [0.6, 0.057, 0.0027];
    for mode in [TimingMode::TimeOfImpact, TimingMode::Exact] {
        let mut w = world_with_gravity(G);
        let floor = floor(&mut w, 1.0, 0.0);
        let mut y = 1.0;
        let mut balls = Vec::new();
        for (k, (r, m)) in radii.iter().zip(masses).enumerate() {
            if k > 0 {
                y += radii[k - 1] + r;
            }
            let volume = 4.0 / 3.0 * std::f64::consts::PI * r * r * r;
            let (h, _) = w.insert(
                RigidBodyBuilder::dynamic()
                    .translation(Vector::new(0.0, real(y), 0.0))
                    .can_sleep(false),
                ColliderBuilder::ball(real(*r))
                    .density(real(m / volume))
                    .restitution(1.0)
                    .friction(0.0),
            );
            balls.push(h);
        }
        let mut p = plugin(mode);
        p.add_ground(&w.bodies, &w.colliders, floor).unwrap();
        p.set_all_dynamic_bodies_impact(true);
        let mut launched = false;
        for n in 0..40 {
            p.step(&mut w);
            let ys: Vec<f64> = balls
                .iter()
                .map(|h| na(w.bodies[*h].translation()).y)
                .collect();
            for k in 0..2 {
                let gap = ys[k + 1] - ys[k] - radii[k] - radii[k + 1];
                assert!(
                    gap > -0.005,
                    "{mode:?}: step {n}: balls {k}, {}: gap {gap}",
                    k + 1
                );
            }
            let top_events = pair_events(&p).into_iter().filter(|e| e.body == balls[2]);
            if top_events.count() > 0 {
                assert!(
                    pair_events(&p)
                        .iter()
                        .all(|e| e.timing == ImpactTiming::InStep),
                    "{mode:?}: step {n}"
                );
                launched |= na(w.bodies[balls[2]].linvel()).y > 10.0;
            }
        }
        assert!(
            launched,
            "{mode:?}: the ping-pong ball was not launched in the step"
        );
    }
}

/// A floor (`e = 0.5`, frictionless) up to an elastic, frictionless wall whose face is at
/// `x = 1`, under gravity: the world, the wall's and the floor's colliders.
fn floor_to_a_wall() -> (PhysicsWorld, ColliderHandle, ColliderHandle) {
    let mut w = world_with_gravity(G);
    let (_, wall) = w.insert(
        RigidBodyBuilder::fixed().translation(Vector::new(1.1, 0.5, 0.0)),
        ColliderBuilder::cuboid(0.1, 0.5, 0.5)
            .restitution(1.0)
            .friction(0.0),
    );
    let floor = floor(&mut w, 0.5, 0.0);
    (w, wall, floor)
}

/// Two balls rolling touching at 4 m/s into a wall (a ground): the first bounces off the wall
/// into the second. Each lies on the floor (rapier's resting contact, which leaves it sinking
/// at up to about `g dt`), so neither is planned to bounce onto the other: the first ball's
/// wall impact is resolved alone, and the pair is rapier's, which parts the two within half a
/// second (to under rapier's resting depth of 3 mm), both moving away at 4 m/s. (Planned as
/// an impact, the wall was missed by the cluster, which rolled a ball on its one plane, and
/// the two were left 4 cm inside each other for good; in `f64` the pair's impact then sent
/// the first ball back into the wall, and the end check stopped it there, `e = 0`.)
#[test]
fn balls_rolling_into_a_wall_part() {
    let r = 0.05;
    for mode in [TimingMode::TimeOfImpact, TimingMode::Exact] {
        let (mut w, wall, floor) = floor_to_a_wall();
        let v = Vector3::x() * 4.0;
        let spin = Vector3::new(0.0, 0.0, -4.0 / r);
        let a = ball(&mut w, Vector3::new(0.5, r, 0.0), v, spin, r, 1.0, 0.0).0;
        let b = ball(&mut w, Vector3::new(0.4, r, 0.0), v, spin, r, 1.0, 0.0).0;
        let mut p = plugin(mode);
        p.add_ground(&w.bodies, &w.colliders, wall).unwrap();
        p.add_ground(&w.bodies, &w.colliders, floor).unwrap();
        p.set_all_dynamic_bodies_impact(true);
        for _ in 0..30 {
            p.step(&mut w);
        }
        let d = (na(w.bodies[a].translation()) - na(w.bodies[b].translation())).norm();
        assert!(2.0 * r - d < 0.003, "{mode:?}: overlap {}", 2.0 * r - d);
        // Everything elastic: both end moving away from the wall at 4 m/s (to rapier's solve
        // of the pair, 4e-5 in `f32`).
        for h in [a, b] {
            let vx = wide(w.bodies[h].linvel().x);
            assert_abs_diff_eq!(vx, -4.0, epsilon = 1e-4);
        }
    }
}

/// A ball rolling at 1 m/s, 2 cm from a wall (a ground, `e = 1`), struck from behind by a ball
/// rolling at 4 m/s (balls frictionless, `e = 1`): in the first step the struck ball goes off
/// at 4 m/s, bounces off the wall, and meets the other again, which it sends back at 4 m/s;
/// it reaches the wall again in the next step. Elastic throughout, the balls end moving away
/// at 1 and 4 m/s. (A ball of a pair's cluster rolled on its one plane and missed the wall:
/// it was pushed out at the step's end still driving into it, and the closed form was lost.)
#[test]
fn a_ball_struck_into_a_wall_bounces_off_it_in_the_step() {
    let r = 0.05;
    for mode in [TimingMode::TimeOfImpact, TimingMode::Exact] {
        let (mut w, wall, floor) = floor_to_a_wall();
        let rolling = |v: f64| (Vector3::x() * v, Vector3::new(0.0, 0.0, -v / r));
        let ((va, wa), (vb, wb)) = (rolling(1.0), rolling(4.0));
        let a = ball(&mut w, Vector3::new(0.93, r, 0.0), va, wa, r, 1.0, 0.0).0;
        let b = ball(&mut w, Vector3::new(0.829, r, 0.0), vb, wb, r, 1.0, 0.0).0;
        let x = |w: &PhysicsWorld, h: RigidBodyHandle| wide(w.bodies[h].translation().x);
        // The closed form of the first step, from the positions as stored: the balls meet
        // when their 1 mm gap closes at 3 m/s; the struck ball then has the wall's gap left.
        let (xa, xb) = (x(&w, a), x(&w, b));
        let meet = (xa - xb - 2.0 * r) / 3.0;
        let wall_hit = meet + (1.0 - r - (xa + meet)) / 4.0;
        let mut p = plugin(mode);
        p.add_ground(&w.bodies, &w.colliders, wall).unwrap();
        p.add_ground(&w.bodies, &w.colliders, floor).unwrap();
        p.set_all_dynamic_bodies_impact(true);
        p.step(&mut w);
        let of_a: Vec<_> = p.events().iter().filter(|e| e.body == a).collect();
        let kinds: Vec<_> = of_a.iter().map(|e| e.body2.is_some()).collect();
        assert_eq!(kinds, [true, false, true], "{mode:?}: {of_a:#?}");
        assert!(
            of_a.iter().all(|e| e.timing == ImpactTiming::InStep),
            "{mode:?}: {of_a:#?}"
        );
        let off_wall = of_a[1];
        assert_eq!(off_wall.ground, wall, "{mode:?}");
        assert_abs_diff_eq!(off_wall.time, wall_hit, epsilon = 1e-7);
        assert_abs_diff_eq!(off_wall.approach_speed, 4.0, epsilon = 1e-6);
        for _ in 0..9 {
            p.step(&mut w);
            assert!(
                x(&w, a) + r <= 1.0 + 1e-4,
                "{mode:?}: in the wall at {}",
                x(&w, a)
            );
        }
        let vx = |h: RigidBodyHandle| wide(w.bodies[h].linvel().x);
        assert_abs_diff_eq!(vx(a), -1.0, epsilon = 1e-6);
        assert_abs_diff_eq!(vx(b), -4.0, epsilon = 1e-6);
    }
}

/// A ball rolling at 2 m/s, 2 cm from a wall (a ground, `e = 1`), with a ball rolling at
/// 3 m/s touching it from behind; neither opted in, so rapier's solver resolves the two
/// (frictionless balls, `e = 1`), and the struck ball, its rolling disturbed, ends the step in
/// the wall. It bounces off the wall with the wall's restitution, as a ball rapier's step
/// leaves in a ground does, and the two end moving away. (The disturbed rolling ball's rule,
/// written for its own plane, settled it on the wall, `e = 0`, and stopped it there.)
#[test]
fn a_rolling_ball_pushed_into_a_wall_by_rapier_bounces_off_it() {
    let r = 0.05;
    for mode in [TimingMode::TimeOfImpact, TimingMode::Exact] {
        let (mut w, wall, floor) = floor_to_a_wall();
        let rolling = |v: f64| (Vector3::x() * v, Vector3::new(0.0, 0.0, -v / r));
        let ((va, wa), (vc, wc)) = (rolling(2.0), rolling(3.0));
        let a = ball(&mut w, Vector3::new(0.93, r, 0.0), va, wa, r, 1.0, 0.0).0;
        let c = ball(&mut w, Vector3::new(0.83, r, 0.0), vc, wc, r, 1.0, 0.0).0;
        let mut p = plugin(mode);
        p.add_ground(&w.bodies, &w.colliders, wall).unwrap();
        p.add_ground(&w.bodies, &w.colliders, floor).unwrap();
        p.step(&mut w);
        let off_wall = p
            .events()
            .iter()
            .find(|e| e.body == a && e.ground == wall && e.kind == EventKind::Impact)
            .unwrap_or_else(|| panic!("{mode:?}: no wall impact: {:#?}", p.events()));
        assert!(
            !off_wall.settled && off_wall.restitution == 1.0,
            "{mode:?}: {off_wall:?}"
        );
        let vx = |w: &PhysicsWorld, h: RigidBodyHandle| wide(w.bodies[h].linvel().x);
        assert!(off_wall.approach_speed > 2.0, "{mode:?}: {off_wall:?}");
        assert_abs_diff_eq!(vx(&w, a), -off_wall.approach_speed, epsilon = 1e-6);
        for _ in 0..5 {
            p.step(&mut w);
        }
        assert!(
            vx(&w, a) < 0.0 && vx(&w, c) < 0.0,
            "{mode:?}: both move away"
        );
    }
}

/// A ball at 3 m/s strikes a ball at rest off-centre (no gravity, smooth, `e = 1`); a torque
/// on the striker (a user's) keeps the pair out of the in-step motion, so the impact is
/// resolved at the step's end, where the balls have run 2 cm into each other. The impulse
/// is along the line of centres where they touched, `(0.8, 0.6, 0)`, as in the step: the
/// closed-form velocities. (The line of centres at the step's end is 4 degrees off it; in a
/// crowd landing on itself, with overlaps of several centimetres, tens of degrees, which
/// sent balls sideways faster than any impact could.)
#[test]
fn a_pair_resolved_at_the_step_end_is_struck_along_the_line_where_the_balls_touched() {
    let r = 0.05;
    for mode in [TimingMode::TimeOfImpact, TimingMode::Exact] {
        let mut w = world_with_gravity(0.0);
        let v = Vector3::x() * 3.0;
        let a = ball(&mut w, Vector3::zeros(), v, Vector3::zeros(), r, 1.0, 0.0).0;
        let at = Vector3::new(0.12, 0.06, 0.0);
        let b = ball(&mut w, at, Vector3::zeros(), Vector3::zeros(), r, 1.0, 0.0).0;
        w.bodies[a].add_torque(Vector::new(0.0, 0.0, real(1e-6)), true);
        let mut p = plugin(mode);
        p.set_all_dynamic_bodies_impact(true);
        p.step(&mut w);
        let hit = p
            .events()
            .iter()
            .find(|e| e.body == b && e.kind == EventKind::Impact)
            .unwrap_or_else(|| panic!("{mode:?}: no impact: {:#?}", p.events()));
        assert_eq!(hit.timing, ImpactTiming::StepEnd, "{mode:?}");
        let n = Vector3::new(0.8, 0.6, 0.0);
        assert!((na(hit.normal) - n).norm() < 1e-6, "{mode:?}: {hit:?}");
        assert_abs_diff_eq!(hit.approach_speed, v.dot(&n), epsilon = 1e-6);
        // Equal masses, smooth, elastic: the struck ball takes the normal part.
        let (va, vb) = (na(w.bodies[a].linvel()), na(w.bodies[b].linvel()));
        assert!((vb - n * v.dot(&n)).norm() < 1e-6, "{mode:?}: {vb:?}");
        assert!((va - (v - n * v.dot(&n))).norm() < 1e-6, "{mode:?}: {va:?}");
    }
}

/// A ball with a torque on it (so that its pair is left to the step's end) falls at 5 m/s
/// beside a ball lying on the floor, lands on the floor in the step and ends 9.5 cm from the
/// other's centre, level with it. It came down onto the other's shoulder: the pair's line at
/// the step's end is the one where they touched on the way down, pointing down into the
/// lying ball, and after the landing's bounce the two part along it (pushed apart, no
/// impulse). (Taken back along the end's relative velocity, after the bounce, the line
/// pointed up: the lying ball was launched and the falling one driven into the floor.)
#[test]
fn a_ball_landing_on_a_balls_shoulder_never_launches_it_at_the_step_end() {
    let r = 0.05;
    for mode in [TimingMode::TimeOfImpact, TimingMode::Exact] {
        let mut w = world_with_gravity(G);
        let floor = floor(&mut w, 0.5, 0.0);
        let zero = Vector3::zeros();
        let lying = ball(&mut w, Vector3::new(0.0, r, 0.0), zero, zero, r, 0.5, 0.0).0;
        let at = Vector3::new(-0.095, r + 0.06, 0.0);
        let down = Vector3::new(0.0, -5.0, 0.0);
        let falling = ball(&mut w, at, down, zero, r, 0.5, 0.0).0;
        w.bodies[falling].add_torque(Vector::new(0.0, 0.0, real(1e-6)), true);
        let mut p = plugin(mode);
        p.add_ground(&w.bodies, &w.colliders, floor).unwrap();
        p.set_all_dynamic_bodies_impact(true);
        p.step(&mut w);
        // Any impulse on the lying ball pushes it down, never up.
        for e in p
            .events()
            .iter()
            .filter(|e| e.body == lying && e.body2.is_some())
        {
            assert!(e.normal.y <= 0.0, "{mode:?}: struck from below: {e:?}");
        }
        let y = |h: RigidBodyHandle| wide(w.bodies[h].translation().y);
        assert!(
            y(falling) >= r - 1e-4,
            "{mode:?}: in the floor at {}",
            y(falling)
        );
        let vy = wide(w.bodies[lying].linvel().y);
        assert!(vy <= 1e-3, "{mode:?}: the lying ball launched at {vy}");
    }
}

/// Two balls struck into a dead wall (`e = 0` everywhere, friction 0.3): the struck ball
/// stops at the wall, and the striker, which its first impact left touching it at rest,
/// runs into it again in the step. They never end inside each other. (The pair was left
/// resting after the first impact and not searched again when the wall stopped the ball:
/// 2-5 cm deep at the step's ends.)
#[test]
fn balls_struck_into_a_dead_wall_stay_apart() {
    let r = 0.05;
    for mode in [TimingMode::TimeOfImpact, TimingMode::Exact] {
        let mut w = world_with_gravity(G);
        let (_, wall) = w.insert(
            RigidBodyBuilder::fixed().translation(Vector::new(1.1, 0.5, 0.0)),
            ColliderBuilder::cuboid(0.1, 0.5, 0.5)
                .restitution(0.0)
                .friction(0.3),
        );
        let floor = floor(&mut w, 0.0, 0.3);
        let rolling = |v: f64| (Vector3::x() * v, Vector3::new(0.0, 0.0, -v / r));
        let ((va, wa), (vb, wb)) = (rolling(1.0), rolling(4.0));
        let a = ball(&mut w, Vector3::new(0.93, r, 0.0), va, wa, r, 0.0, 0.3).0;
        let b = ball(&mut w, Vector3::new(0.829, r, 0.0), vb, wb, r, 0.0, 0.3).0;
        let mut p = plugin(mode);
        p.add_ground(&w.bodies, &w.colliders, wall).unwrap();
        p.add_ground(&w.bodies, &w.colliders, floor).unwrap();
        p.set_all_dynamic_bodies_impact(true);
        for step in 0..5 {
            p.step(&mut w);
            let d = (na(w.bodies[a].translation()) - na(w.bodies[b].translation())).norm();
            assert!(
                2.0 * r - d < 1e-3,
                "{mode:?} step {step}: {} deep",
                2.0 * r - d
            );
        }
    }
}
