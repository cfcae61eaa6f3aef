//! Extreme sizes, densities, mass ratios and coefficients in whole scenes (issue 5), each with
//! the per-step checks (finite, no body below the ground by more than rapier's allowed linear
//! error, no impact energy gain, friction in the cone):
//! - balls of radius 1 mm and 10 m, densities 1e-3 and 1e4, dropped from 5 radii: first
//!   rebound `e v` and rest;
//! - a box of density 1e4 on a box of density 1e-2 (mass ratio over 1e6) resting on the ground,
//!   and the same heavy box dropped on it: rapier's solver itself presses the light box ~9 cm
//!   into the ground; the plugin must do no worse;
//! - e = 0 (no bounce, rest at once) and e = 1 (ten bounces, each back to the drop height);
//! - mu = 0 (the tangential velocity and spin unchanged) and mu = 10 (sticks: rolls at 5/7);
//! - rapier's restitution combine rules, used by the plugin as rapier would.

#![allow(clippy::useless_conversion, clippy::unnecessary_cast)]

mod scene_support;

use approx::assert_abs_diff_eq;
use rapier_impact::TimingMode;
use rapier_impact::rapier::prelude::*;
use scene_support::*;

/// Drops a ball of radius `r` and density `rho` from `h` (gap) with `e` on a half-space;
/// returns the events and the stats over `seconds`.
#[allow(clippy::too_many_arguments)]
fn drop(
    r: f64,
    rho: f64,
    h: f64,
    e: f64,
    mu: f64,
    vx: f64,
    seconds: f64,
    timing: TimingMode,
) -> (
    Vec<rapier_impact::ImpactEvent>,
    Stats,
    PhysicsWorld,
    RigidBodyHandle,
) {
    let label = format!("ball r {r} rho {rho} e {e} mu {mu} {timing:?}");
    let mut world = PhysicsWorld::default();
    let (_, ground) = world.insert(
        RigidBodyBuilder::fixed(),
        ColliderBuilder::halfspace(up())
            .restitution(real(e))
            .friction(real(mu)),
    );
    let (ball, _) = world.insert(
        RigidBodyBuilder::dynamic()
            .translation(Vector::new(0.0, real(r + h), 0.0))
            .linvel(Vector::new(real(vx), 0.0, 0.0)),
        ColliderBuilder::ball(real(r))
            .density(real(rho))
            .restitution(real(e))
            .friction(real(mu)),
    );
    let mut p = plugin_on(&world, ground, timing);
    let mut stats = Stats::new();
    let mut events = Vec::new();
    for _ in 0..(seconds * 60.0).ceil() as usize {
        step_checked(&mut world, &mut p, 0.0, &mut stats, &label);
        events.extend_from_slice(p.events());
    }
    (events, stats, world, ball)
}

#[test]
fn tiny_huge_light_and_dense_balls_bounce_by_e_and_rest() {
    let e = 0.6;
    for r in [1e-3, 10.0] {
        for rho in [1e-3, 1e4] {
            for timing in [TimingMode::TimeOfImpact, TimingMode::Exact] {
                let h = 5.0 * r;
                let fall = (2.0 * h / G).sqrt();
                let rest = fall * (1.0 + e) / (1.0 - e);
                let (events, stats, world, ball) = drop(r, rho, h, e, 0.5, 0.0, rest + 2.0, timing);
                let first = events.first().expect("no impact");
                let v = (2.0 * G * h).sqrt();
                let ratio = first.ke_after / first.ke_before;
                let rb = &world.bodies[ball];
                let y = wide(rb.translation().y);
                println!(
                    "r {r} m, density {rho}, {timing:?}: first approach {:.6} m/s (expected {v:.6}), KE ratio {ratio:.6} (e^2 = {:.2}), rest height {y:.6e} (r = {r}), asleep {}; {}",
                    first.approach_speed,
                    e * e,
                    rb.is_sleeping(),
                    stats.summary()
                );
                // TimeOfImpact keeps rapier's flight integrator (it loses about g dt / 2).
                let tol = match timing {
                    TimingMode::Exact => 1e-4 * v,
                    _ => 0.5 * G / 60.0,
                };
                assert_abs_diff_eq!(first.approach_speed, v, epsilon = tol);
                assert_abs_diff_eq!(ratio, e * e, epsilon = 1e-6);
                assert!(
                    wide(rb.linvel().length()) < 1e-2 * v.max(0.1),
                    "not at rest: {:?}",
                    rb.linvel()
                );
            }
        }
    }
}

/// The light box's depth below the ground under the heavy one, worst over 10 s, with the
/// plugin (checked per step) or rapier alone: `(mass ratio, depth, stats)`.
fn mass_ratio_scene(drop_height: f64, timing: Option<TimingMode>) -> (f64, f64, Stats) {
    let label = format!("mass ratio, heavy dropped {drop_height} m, {timing:?}");
    let (ratio, stats) = mass_ratio_run(drop_height, timing, &label);
    (ratio, stats.max_penetration, stats)
}

#[test]
fn a_mass_ratio_of_a_million_on_the_ground_sinks_no_deeper_than_in_rapier_alone() {
    // A 1 m box of density 1e4 (10 t) on a 2 m x 0.2 m box of density 1e-2 (8 kg): over 1e6.
    // Rapier's solver alone presses the light box about 9 cm into the ground whatever its
    // iteration count (4 to 32 measured): its limit, not the plugin's, which leaves this
    // resting pair to rapier. Asserted: finite, no energy gain, no deeper than rapier alone.
    for drop_height in [0.0, 0.5] {
        let (ratio, alone, _) = mass_ratio_scene(drop_height, None);
        for timing in [TimingMode::TimeOfImpact, TimingMode::Exact] {
            let (_, with, stats) = mass_ratio_scene(drop_height, Some(timing));
            println!(
                "heavy dropped {drop_height} m, {timing:?}: mass ratio {ratio:.2e}, deepest {with:.4} m (rapier alone {alone:.4} m); {}",
                stats.summary()
            );
            assert!(ratio > 1e6);
            assert!(
                with <= alone * 1.05 + 1e-3,
                "{timing:?}: {with} m below the ground, rapier alone {alone} m"
            );
        }
    }
}

#[test]
fn e_zero_does_not_bounce_and_e_one_keeps_its_height() {
    let h = 1.0;
    let (events, stats, world, ball) = drop(0.1, 1.0, h, 0.0, 0.5, 0.0, 3.0, TimingMode::Exact);
    let rb = &world.bodies[ball];
    println!(
        "e = 0: {} events, first KE {:.4} -> {:.3e} J, y {:.6}, asleep {}; {}",
        events.len(),
        events[0].ke_before,
        events[0].ke_after,
        rb.translation().y,
        rb.is_sleeping(),
        stats.summary()
    );
    assert_eq!(stats.bounces, 1, "e = 0: more than the landing");
    assert!(events[0].ke_after < 1e-9 * events[0].ke_before);
    let t1 = (2.0 * h / G).sqrt();
    let (events, stats, _, _) = drop(0.1, 1.0, h, 1.0, 0.5, 0.0, 20.0 * t1, TimingMode::Exact);
    let drift = events
        .iter()
        .map(|e| (e.ke_after - e.ke_before) / e.ke_before)
        .fold(0.0f64, |a, x| a.max(x.abs()));
    let speeds: Vec<f64> = events.iter().map(|e| e.approach_speed).collect();
    let v = (2.0 * G * h).sqrt();
    let worst = speeds.iter().fold(0.0f64, |a, s| a.max((s - v).abs() / v));
    println!(
        "e = 1: {} bounces, worst |dKE|/KE {drift:.2e}, approach speeds within {worst:.2e} of sqrt(2 g h); {}",
        events.len(),
        stats.summary()
    );
    assert_eq!(events.len(), 10, "e = 1: bounces {speeds:?}");
    assert!(drift < 1e-12, "e = 1 changed the energy by {drift:e}");
    assert!(
        worst < if F64 { 1e-9 } else { 1e-5 },
        "e = 1 lost height: {speeds:?}"
    );
}

#[test]
fn mu_zero_keeps_the_slide_and_mu_ten_sticks() {
    // Dropped 0.5 m with 2 m/s sideways.
    let (vx, h) = (2.0, 0.5);
    let (events, stats, _, _) = drop(0.1, 1.0, h, 0.5, 0.0, vx, 0.5, TimingMode::Exact);
    let ev = events[0];
    println!(
        "mu = 0: tangential impulse {:?}, regime {:?}; {}",
        ev.tangent_impulse,
        ev.regime,
        stats.summary()
    );
    assert_eq!(ev.tangent_impulse, Vector::ZERO);
    let (events, stats, world, ball) = drop(0.1, 1.0, h, 0.5, 10.0, vx, 0.4, TimingMode::Exact);
    let ev = events[0];
    let rb = &world.bodies[ball];
    let (vx1, wz) = (wide(rb.linvel().x), wide(rb.angvel().z));
    println!(
        "mu = 10: regime {:?}, vx after {vx1:.6} (5/7 vx = {:.6}), w r {:.6}; {}",
        ev.regime,
        5.0 / 7.0 * vx,
        -wz * 0.1,
        stats.summary()
    );
    assert_eq!(ev.regime, rapier_impact::model::Regime::Stick);
    assert_abs_diff_eq!(vx1, 5.0 / 7.0 * vx, epsilon = 1e-5);
    assert_abs_diff_eq!(vx1, -wz * 0.1, epsilon = 1e-5);
}

#[test]
fn restitution_combine_rules_are_rapiers() {
    let (eb, eg) = (0.9, 0.3);
    for (rule, expected) in [
        (CoefficientCombineRule::Average, 0.6),
        (CoefficientCombineRule::Min, 0.3),
        (CoefficientCombineRule::Multiply, 0.27),
        (CoefficientCombineRule::Max, 0.9),
    ] {
        let mut world = PhysicsWorld::default();
        let (_, ground) = world.insert(
            RigidBodyBuilder::fixed(),
            ColliderBuilder::halfspace(up()).restitution(real(eg)),
        );
        world.insert(
            RigidBodyBuilder::dynamic().translation(Vector::new(0.0, 1.1, 0.0)),
            ColliderBuilder::ball(0.1)
                .restitution(real(eb))
                .restitution_combine_rule(rule),
        );
        let mut p = plugin_on(&world, ground, TimingMode::Exact);
        let mut stats = Stats::new();
        let mut used = None;
        for _ in 0..60 {
            step_checked(&mut world, &mut p, 0.0, &mut stats, "combine");
            if let Some(ev) = p.events().first() {
                used.get_or_insert((ev.restitution, ev.ke_after / ev.ke_before));
            }
        }
        let (e, ratio) = used.expect("no impact");
        println!("{rule:?}: e used {e:.6} (expected {expected}), KE ratio {ratio:.6}");
        assert_abs_diff_eq!(e, expected, epsilon = 1e-6);
        assert_abs_diff_eq!(ratio, expected * expected, epsilon = 1e-5);
    }
}
