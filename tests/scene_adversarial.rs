//! Adversarial scenes (issue 5, proptest): random scenes of one to four spheres and boxes with
//! random sizes (2 cm to 0.5 m), densities (1e-2 to 1e3), materials (e in [0, 1], mu in
//! [0, 2], each combine rule), positions, velocities (up to 30 m/s) and spins (up to 50 rad/s),
//! in a random timing mode and dt (1/30 to 1/240), on a half-space ground; 90 steps each.
//! Asserted at every step: no panic, all finite, no impact gaining kinetic energy (relative
//! 1e-9), friction in the cone, and no body deeper below the ground than rapier's allowed
//! linear error for every body touching nothing but the ground, and, for a body another one
//! pushed in the last second (rapier's solver holds that push), no deeper than the allowed
//! error plus one step's travel of the fastest point (no tunnelling). The strict bound for
//! every body is a reported limitation: set `RAPIER_IMPACT_STRICT_PENETRATION=1` to assert
//! it (30 000 cases found a box struck downwards at 2.1 m/s by a ball, 5.4 mm deep, Step mode
//! at 30 Hz).
//!
//! Cases: 1 000 by default, drawn from a fixed seed (every run checks the same scenes); set
//! `RAPIER_IMPACT_PROPTEST_CASES` for more, and `RAPIER_IMPACT_PROPTEST_SEED` for others (a
//! whole number, or `random`). A fresh search found the case in the guide's "Not guaranteed"
//! where rapier's solver presses a light box deeper than the bound for pushed bodies.

#![allow(clippy::useless_conversion, clippy::unnecessary_cast)]

mod scene_support;

use proptest::prelude::*;
use rapier_impact::TimingMode;
use rapier_impact::rapier::prelude::*;
use scene_support::*;

#[derive(Clone, Debug)]
struct BodySpec {
    ball: bool,
    size: [f64; 3],
    density: f64,
    e: f64,
    mu: f64,
    rule: u8,
    pos: [f64; 3],
    vel: [f64; 3],
    spin: [f64; 3],
}

fn body() -> impl Strategy<Value = BodySpec> {
    (
        any::<bool>(),
        prop::array::uniform3(0.02f64..0.5),
        -2.0f64..3.0,
        0.0f64..=1.0,
        0.0f64..2.0,
        0u8..4,
        (-3.0f64..3.0, 0.0f64..3.0, -3.0f64..3.0),
        prop::array::uniform3(-30.0f64..30.0),
        prop::array::uniform3(-50.0f64..50.0),
    )
        .prop_map(
            |(ball, size, logd, e, mu, rule, (x, y, z), vel, spin)| BodySpec {
                ball,
                size,
                density: 10f64.powf(logd),
                e,
                mu,
                rule,
                pos: [x, y, z],
                vel,
                spin,
            },
        )
}

fn rule(k: u8) -> CoefficientCombineRule {
    match k {
        0 => CoefficientCombineRule::Average,
        1 => CoefficientCombineRule::Min,
        2 => CoefficientCombineRule::Multiply,
        _ => CoefficientCombineRule::Max,
    }
}

/// The half-space ground with the given material and the bodies above it, at `hz`.
fn scene(
    bodies: &[BodySpec],
    hz: f64,
    ground_e: f64,
    ground_mu: f64,
    pairs: bool,
) -> (PhysicsWorld, ColliderHandle) {
    let mut world = PhysicsWorld::default();
    world.integration_parameters.dt = real(1.0 / hz);
    let (_, ground) = world.insert(
        RigidBodyBuilder::fixed(),
        ColliderBuilder::halfspace(up())
            .restitution(real(ground_e))
            .friction(real(ground_mu)),
    );
    for (i, b) in bodies.iter().enumerate() {
        insert_body(&mut world, i, b, pairs);
    }
    (world, ground)
}

/// The `i`th body of the scene, lifted clear of the ground by 1.8 times its largest
/// half-extent (a ball's radius).
fn insert_body(world: &mut PhysicsWorld, i: usize, b: &BodySpec, pairs: bool) {
    let collider = if b.ball {
        ColliderBuilder::ball(real(b.size[0]))
    } else {
        ColliderBuilder::cuboid(real(b.size[0]), real(b.size[1]), real(b.size[2]))
    };
    let lift = b.size.iter().cloned().fold(0.0, f64::max) * 1.8;
    // Spread horizontally so that the bodies start apart; with impacts between bodies
    // opted in, close enough to meet.
    let x = b.pos[0] + if pairs { 1.2 } else { 7.0 } * i as f64;
    world.insert(
        RigidBodyBuilder::dynamic()
            .translation(Vector::new(real(x), real(b.pos[1] + lift), real(b.pos[2])))
            .linvel(Vector::new(real(b.vel[0]), real(b.vel[1]), real(b.vel[2])))
            .angvel(Vector::new(
                real(b.spin[0]),
                real(b.spin[1]),
                real(b.spin[2]),
            )),
        collider
            .density(real(b.density))
            .restitution(real(b.e))
            .friction(real(b.mu))
            .restitution_combine_rule(rule(b.rule))
            .friction_combine_rule(rule(b.rule)),
    );
}

fn run(
    bodies: &[BodySpec],
    timing: TimingMode,
    hz: f64,
    ground_e: f64,
    ground_mu: f64,
    pairs: bool,
) {
    let label = format!(
        "{timing:?} at {hz:.0} Hz, ground e {ground_e:.3} mu {ground_mu:.3}, pairs {pairs}"
    );
    let (mut world, ground) = scene(bodies, hz, ground_e, ground_mu, pairs);
    let mut p = plugin_on(&world, ground, timing);
    p.set_all_dynamic_bodies_impact(pairs);
    let mut stats = Stats::new();
    let strict = std::env::var("RAPIER_IMPACT_STRICT_PENETRATION").is_ok();
    let allowed = wide(world.integration_parameters.allowed_linear_error());
    let dt = 1.0 / hz;
    // The last step each body touched another one (rapier's contact graph).
    let mut last_touched: std::collections::HashMap<RigidBodyHandle, usize> = Default::default();
    let memory = hz as usize;
    for k in 0..90 {
        // The fastest material point of any body at the start of the step (m/s).
        let fastest = world
            .bodies
            .iter()
            .filter(|(_, rb)| rb.is_dynamic())
            .map(|(_, rb)| {
                let r = b_radius(&world, rb);
                wide(rb.linvel().length()) + wide(rb.angvel().length()) * r
            })
            .fold(0.0, f64::max);
        if strict {
            step_checked(&mut world, &mut p, 0.0, &mut stats, &label);
            continue;
        }
        p.step(&mut world);
        assert_finite(&world, &label);
        for ev in p.events() {
            check_event(ev, &mut stats, &label);
        }
        check_pair_energy(p.events(), &label);
        for (h, rb) in world.bodies.iter() {
            if !rb.is_dynamic() {
                continue;
            }
            if touches_a_body(&world, h) {
                last_touched.insert(h, k);
            }
            let depth = rb
                .colliders()
                .iter()
                .map(|c| -wide(world.colliders[*c].compute_aabb().mins.y))
                .fold(f64::NEG_INFINITY, f64::max);
            // A body touching nothing but the ground stays within rapier's allowed error. A
            // body another one pushed in the last second is held by rapier's solver (a box
            // struck downwards at 2.1 m/s by a ball went 5.4 mm deep, Step mode at 30 Hz):
            // it never goes deeper than one step's travel of the fastest point (no
            // tunnelling); `RAPIER_IMPACT_STRICT_PENETRATION=1` asserts the allowed error
            // for it too.
            let pushed = last_touched.get(&h).is_some_and(|at| k - at < memory);
            let bound = if pushed {
                allowed + fastest * dt + 1e-6
            } else {
                allowed + penetration_rounding(0.0)
            };
            prop_assert_le(depth, bound, &label, k, pushed);
        }
    }
}

fn b_radius(world: &PhysicsWorld, rb: &RigidBody) -> f64 {
    rb.colliders()
        .iter()
        .map(|c| {
            wide(
                world.colliders[*c]
                    .shape()
                    .compute_local_bounding_sphere()
                    .radius,
            )
        })
        .fold(0.0, f64::max)
}

fn prop_assert_le(depth: f64, bound: f64, label: &str, k: usize, pushed: bool) {
    let why = if pushed {
        "a step's travel (pushed by another body)"
    } else {
        "rapier's allowed linear error (touching only the ground)"
    };
    assert!(
        depth <= bound,
        "{label}: step {k}: {depth:e} m below the ground, more than {why} ({bound:e} m)"
    );
}

proptest! {
    #![proptest_config(random_scene_config("RAPIER_IMPACT_PROPTEST_CASES", 1_000))]

    #[test]
    fn random_scenes_stay_finite_above_ground_and_never_gain_energy_at_impacts(
        bodies in prop::collection::vec(body(), 1..=4),
        mode in 0usize..3,
        hz in prop::sample::select(vec![30.0, 60.0, 120.0, 240.0]),
        ground_e in 0.0f64..=1.0,
        ground_mu in 0.0f64..2.0,
    ) {
        let timing = [TimingMode::Step, TimingMode::TimeOfImpact, TimingMode::Exact][mode];
        run(&bodies, timing, hz, ground_e, ground_mu, false);
    }

    /// The same, the bodies close together and every one opted in to impacts between bodies
    /// (the balls' are the model's; boxes stay rapier's).
    #[test]
    fn random_scenes_with_impacts_between_bodies(
        bodies in prop::collection::vec(body(), 2..=4),
        mode in 0usize..3,
        hz in prop::sample::select(vec![30.0, 60.0, 120.0, 240.0]),
        ground_e in 0.0f64..=1.0,
        ground_mu in 0.0f64..2.0,
    ) {
        let timing = [TimingMode::Step, TimingMode::TimeOfImpact, TimingMode::Exact][mode];
        run(&bodies, timing, hz, ground_e, ground_mu, true);
    }
}
