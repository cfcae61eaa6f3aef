//! Robustness of whole scenes where the plugin meets rapier's solver (issue 5): bodies whose
//! ground contact is pressed by other bodies. Each test prints what it measured, with rapier
//! alone beside it.
//!
//! - A pile of 125 balls in a walled box settles (every ball below 2 cm/s to the end), at
//!   60, 240 and 1000 Hz and 30 Hz, as in rapier alone: a ground pair of a body touching
//!   other bodies is not bounced below `sqrt(2 g gap)` and a resting one it had is kept in
//!   rapier's solver (it used to be taken out and bounced at the step end, 12 balls a step).
//! - A heavy box (mass ratio 1.25e6) dropped 0.5 m on a light box lying on the ground sinks
//!   it no deeper than rapier alone (it used to sink 21 cm in f64 against 11.7 cm).

mod scene_support;

use rapier_impact::rapier::prelude::*;
use rapier_impact::{ImpactPlugin, ImpactTiming, TimingMode};
use scene_support::*;

/// The deterministic generator of `examples/common` (splitmix64), for the sweep's pile.
#[path = "model_support/rng.rs"]
mod rng;
use rng::Rng;

/// What a pile run measured.
#[derive(Debug)]
struct Pile {
    /// Time from which every ball stays below 2 cm/s (None: not within 4 s).
    settle: Option<f64>,
    /// Fastest ball's speed, averaged over the last second (m/s).
    jitter: f64,
    /// Bounces (not settled events) and step-end events in the last second.
    late_bounces: usize,
    late_step_end: usize,
    stats: Stats,
}

const PILE_R: f64 = 0.05;
const PILE_T: f64 = 4.0;

/// The pile's scene at time step `dt`: the half-space ground, the four walls of the box and
/// the 125 balls in five layers above it, a little jittered.
fn pile_scene(dt: f64) -> (PhysicsWorld, ColliderHandle, Vec<RigidBodyHandle>) {
    let mut world = PhysicsWorld::default();
    world.integration_parameters.dt = real(dt);
    let (_, ground) = world.insert(
        RigidBodyBuilder::fixed(),
        ColliderBuilder::halfspace(up())
            .restitution(0.5)
            .friction(0.5),
    );
    let pitch = 2.0 * PILE_R + 0.01;
    let side = 5usize;
    let inner = 0.5 * side as f64 * pitch;
    let (h, t) = (0.5, 0.1);
    for (x, z, hx, hz) in [
        (inner + t, 0.0, t, inner + 2.0 * t),
        (-inner - t, 0.0, t, inner + 2.0 * t),
        (0.0, inner + t, inner, t),
        (0.0, -inner - t, inner, t),
    ] {
        world.insert(
            RigidBodyBuilder::fixed(),
            ColliderBuilder::cuboid(real(hx), real(h), real(hz))
                .translation(Vector::new(real(x), real(h), real(z)))
                .friction(0.5),
        );
    }
    let mut rng = Rng::like_examples(3);
    let mut balls = Vec::new();
    for i in 0..side * side * 5 {
        let (level, cell) = (i / (side * side), i % (side * side));
        let (row, col) = (cell / side, cell % side);
        let p = [
            (col as f64 + 0.5) * pitch - inner + rng.uniform(-0.01, 0.01),
            PILE_R + 0.1 + level as f64 * (pitch + 0.03),
            (row as f64 + 0.5) * pitch - inner + rng.uniform(-0.01, 0.01),
        ];
        let (b, _) = world.insert(
            RigidBodyBuilder::dynamic().translation(Vector::new(
                real(p[0]),
                real(p[1]),
                real(p[2]),
            )),
            ColliderBuilder::ball(real(PILE_R))
                .restitution(0.5)
                .friction(0.5),
        );
        balls.push(b);
    }
    (world, ground, balls)
}

/// The accuracy sweep's pile (`examples/accuracy_sweep.rs`): 125 balls R = 5 cm in five
/// layers into a walled box (the walls are not ground), e = 0.5, mu = 0.5, 4 s on a
/// half-space; with the plugin (every step checked) or rapier alone.
fn pile(dt: f64, timing: Option<TimingMode>) -> Pile {
    let label = format!("pile dt {dt:.5} {timing:?}");
    let (mut world, ground, balls) = pile_scene(dt);
    let mut plugin = timing.map(|t| plugin_on(&world, ground, t));
    let steps = (PILE_T / dt).ceil() as usize;
    let mut out = Pile {
        settle: None,
        jitter: 0.0,
        late_bounces: 0,
        late_step_end: 0,
        stats: Stats::new(),
    };
    let mut late_steps = 0;
    for k in 1..=steps {
        match plugin.as_mut() {
            Some(p) => {
                p.step(&mut world);
                out.stats.steps += 1;
                for ev in p.events() {
                    check_event(ev, &mut out.stats, &label);
                }
                assert_finite(&world, &label);
                out.stats.max_penetration = out.stats.max_penetration.max(penetration(&world, 0.0));
            }
            None => {
                world.step();
                assert_finite(&world, &label);
                out.stats.steps += 1;
                out.stats.max_penetration = out.stats.max_penetration.max(penetration(&world, 0.0));
            }
        }
        let t = k as f64 * dt;
        let fastest = balls
            .iter()
            .map(|b| wide(world.bodies[*b].linvel().length()))
            .fold(0.0, f64::max);
        match (fastest < 0.02, out.settle) {
            (true, None) => out.settle = Some(t),
            (false, Some(_)) => out.settle = None,
            _ => {}
        }
        if t > PILE_T - 1.0 {
            out.jitter += fastest;
            late_steps += 1;
            if let Some(p) = plugin.as_ref() {
                out.late_bounces += p.events().iter().filter(|e| !e.settled).count();
                out.late_step_end += p
                    .events()
                    .iter()
                    .filter(|e| e.timing == ImpactTiming::StepEnd)
                    .count();
            }
        }
    }
    out.jitter /= late_steps.max(1) as f64;
    out
}

#[test]
fn a_pile_of_balls_settles_as_in_rapier_alone() {
    // Before the pressed-contact roles: at 1000 Hz (f32) and 240 Hz (f64) the pile never
    // settled in TimeOfImpact and Exact modes (2-12 cm/s to the end, about 12 step-end
    // bounces per step at 1-10 cm/s); 6.4 mm deep at 30 Hz (rapier alone 0.9 mm).
    let allowed = 0.005;
    for (dt, name) in [
        (1.0 / 30.0, "1/30"),
        (1.0 / 60.0, "1/60"),
        (1.0 / 240.0, "1/240"),
        (1.0 / 1000.0, "1/1000"),
    ] {
        let alone = pile(dt, None);
        println!(
            "pile dt {name}, rapier alone: settled at {:?} s, jitter {:.2e} m/s, deepest {:.2} mm",
            alone.settle,
            alone.jitter,
            alone.stats.max_penetration * 1e3
        );
        for timing in [
            TimingMode::Step,
            TimingMode::TimeOfImpact,
            TimingMode::Exact,
        ] {
            let with = pile(dt, Some(timing));
            println!(
                "pile dt {name}, {timing:?}: settled at {:?} s, jitter {:.2e} m/s, last-second bounces {} (step-end events {}), deepest {:.2} mm; {}",
                with.settle,
                with.jitter,
                with.late_bounces,
                with.late_step_end,
                with.stats.max_penetration * 1e3,
                with.stats.summary()
            );
            let settle = with.settle.expect("the pile never settled");
            // Measured: 1.3-3.2 s (rapier alone 1.3-2.1 s).
            assert!(
                settle < PILE_T - 0.5,
                "{timing:?} {name}: settled at {settle} s"
            );
            assert!(with.jitter < 0.02, "jitter {}", with.jitter);
            assert_eq!(with.late_bounces, 0);
            assert_eq!(with.late_step_end, 0);
            // Within rapier's allowed linear error (5 mm). At 30 Hz a bottom ball held by
            // rapier's solver (a resting pair, e = 0) under the landing layers goes deepest:
            // 4.75 mm in Step mode, 3.9-4.3 mm in TimeOfImpact and Exact (rapier alone
            // 0.9 mm); it went 5.2 mm before the step-end energy cap, when this bound was
            // twice the allowed error. Measured at 60-1000 Hz: 0.6-1.5 mm.
            let bound = allowed;
            assert!(
                with.stats.max_penetration <= bound + penetration_rounding(1.0),
                "{timing:?} {name}: {} m deep",
                with.stats.max_penetration
            );
        }
    }
}

/// The light box's depth below the ground, worst over 10 s, with a heavy box (1.25e6 times
/// its mass) dropped on it from `drop_height`.
fn mass_ratio(drop_height: f64, timing: Option<TimingMode>) -> (f64, Stats) {
    let label = format!("mass ratio, dropped {drop_height} m, {timing:?}");
    let (_, stats) = mass_ratio_run(drop_height, timing, &label);
    (stats.max_penetration, stats)
}

#[test]
fn a_heavy_box_dropped_on_a_light_one_sinks_it_no_deeper_than_rapier_alone() {
    // Before: f64, TimeOfImpact, 0.211 m with 34 step-end events (rapier alone 0.117 m).
    for drop_height in [0.0, 0.5, 1.0] {
        let (alone, _) = mass_ratio(drop_height, None);
        for timing in [
            TimingMode::Step,
            TimingMode::TimeOfImpact,
            TimingMode::Exact,
        ] {
            let (with, stats) = mass_ratio(drop_height, Some(timing));
            println!(
                "heavy dropped {drop_height} m, {timing:?}: light box {with:.4} m deep (rapier alone {alone:.4} m); {}",
                stats.summary()
            );
            // rapier's own depth (its solver's limit at this ratio), within 1 mm.
            assert!(
                with <= alone + 1e-3,
                "{timing:?}: {with} m deep, rapier alone {alone} m"
            );
        }
    }
}

/// The workaround for mass ratios in a stack, rapier's dominance groups: the light box in a
/// group above the heavy one's is not pushed by it at all (the heavy box rests on it as on a
/// fixed body), so nothing presses it into the ground. Rapier alone and the plugin in every mode
/// then keep the light box within the allowed linear error, the heavy box dropped or not
/// (without it: 9-18 cm, above).
#[test]
fn dominance_groups_keep_a_light_box_under_a_heavy_one_out_of_the_ground() {
    for drop_height in [0.0, 0.5, 1.0] {
        for timing in [
            None,
            Some(TimingMode::Step),
            Some(TimingMode::TimeOfImpact),
            Some(TimingMode::Exact),
        ] {
            let label = format!("dominance, heavy dropped {drop_height} m, {timing:?}");
            let (_, stats) = mass_ratio_run_with(drop_height, timing, 1, &label);
            println!("{label}: {}", stats.summary());
            assert!(
                stats.max_penetration <= 5e-3,
                "{label}: {} m deep",
                stats.max_penetration
            );
        }
    }
}

/// The sweep's tumbling cube (`examples/dice.rs` throw: 10 cm, e = 0.5, friction `mu`, law
/// guarded) thrown by the seed onto a half-space at y = 0, at 60 Hz, with the plugin in
/// `timing`: the world, the cube and the plugin.
fn thrown_cube(
    seed: u64,
    mu: f64,
    timing: TimingMode,
) -> (PhysicsWorld, RigidBodyHandle, ImpactPlugin) {
    use rapier_impact::ImpactConfig;
    use rapier_impact::model::Law;
    let mut world = PhysicsWorld::default();
    world.integration_parameters.dt = real(1.0 / 60.0);
    let (_, ground) = world.insert(
        RigidBodyBuilder::fixed(),
        ColliderBuilder::halfspace(up())
            .restitution(0.5)
            .friction(real(mu)),
    );
    let mut rng = Rng::like_examples(seed);
    let height = rng.uniform(0.5, 1.0);
    let (speed, heading) = (
        rng.uniform(1.0, 3.0),
        rng.uniform(0.0, std::f64::consts::TAU),
    );
    let spin: [f64; 3] = std::array::from_fn(|_| rng.uniform(-10.0, 10.0));
    let q = loop {
        let q: [f64; 4] = std::array::from_fn(|_| rng.uniform(-1.0, 1.0));
        let n2: f64 = q.iter().map(|x| x * x).sum();
        if n2 > 1e-3 && n2 <= 1.0 {
            let n = n2.sqrt();
            break [q[0] / n, q[1] / n, q[2] / n, q[3] / n];
        }
    };
    let (cube, _) = world.insert(
        RigidBodyBuilder::dynamic()
            .pose(Pose::from_parts(
                Vector::new(0.0, real(height + CUBE_HALF * 3f64.sqrt()), 0.0),
                Rotation::from_xyzw(real(q[0]), real(q[1]), real(q[2]), real(q[3])),
            ))
            .linvel(Vector::new(
                real(speed * heading.cos()),
                0.0,
                real(speed * heading.sin()),
            ))
            .angvel(Vector::new(real(spin[0]), real(spin[1]), real(spin[2]))),
        ColliderBuilder::cuboid(real(CUBE_HALF), real(CUBE_HALF), real(CUBE_HALF))
            .restitution(0.5)
            .friction(real(mu)),
    );
    let mut p = ImpactPlugin::new(
        ImpactConfig::default()
            .with_law(Law::Guarded)
            .with_timing(timing),
    )
    .unwrap();
    p.add_ground(&world.bodies, &world.colliders, ground)
        .unwrap();
    (world, cube, p)
}

/// The thrown cube's half edge (m).
const CUBE_HALF: f64 = 0.05;

/// The share of the throw's energy (above rest) that `KE + m g y` gains over the steps with
/// the cube's lowest corner within 2 cm of the ground: [`thrown_cube`] at mu = 0.5, 3 s.
fn cube_energy_gain(seed: u64, timing: TimingMode) -> f64 {
    let label = format!("cube seed {seed} {timing:?}");
    let (mut world, cube, mut p) = thrown_cube(seed, 0.5, timing);
    let half = CUBE_HALF;
    let energy = |world: &PhysicsWorld| -> (f64, f64) {
        let rb = &world.bodies[cube];
        let m = wide(rb.mass());
        let (v, w) = (rb.linvel(), rb.angvel());
        let iw = rb.mass_properties().effective_angular_inertia() * w;
        let ke = 0.5 * m * wide(v.length_squared()) + 0.5 * wide(w.dot(iw));
        (
            ke + m * G * wide(rb.center_of_mass().y),
            -penetration(world, 0.0),
        )
    };
    let rest = wide(world.bodies[cube].mass()) * G * half;
    let e0 = energy(&world).0;
    let (mut prev, mut gained, mut stats) = (energy(&world), 0.0, Stats::new());
    for _ in 0..180 {
        step_checked(&mut world, &mut p, 0.0, &mut stats, &label);
        let now = energy(&world);
        if now.1.min(prev.1) < 0.02 && now.0 > prev.0 {
            gained += now.0 - prev.0;
        }
        prev = now;
    }
    gained / (e0 - rest)
}

#[test]
fn a_tumbling_cube_gains_no_energy_near_the_ground() {
    // Before: seed 4, f64 Exact, +3.0e-3: a settled corner impact (0.081 m/s, under the
    // resting speed) while the cube rose at 0.27 m/s held gravity off for the rest of the
    // step. Then +3.2e-4: the pivoting corner took the step's 8 settled impacts and the
    // end-of-step push-out lifted the cube (now capped to the step's start energy,
    // `capped_energy`): 2e-17. Left: 4.3e-6 (f64) and 1.3e-5 (f32) at worst, in steps with
    // no event (rapier's resting solver).
    for timing in [TimingMode::TimeOfImpact, TimingMode::Exact] {
        let gains: Vec<f64> = (1..=6).map(|seed| cube_energy_gain(seed, timing)).collect();
        let shown: Vec<String> = gains.iter().map(|g| format!("{g:.2e}")).collect();
        let worst = gains.iter().copied().fold(0.0, f64::max);
        println!(
            "tumbling cube, {timing:?}: energy gain near the ground per seed {shown:?}, worst {worst:.2e}"
        );
        assert!(worst < 1e-4, "{timing:?}: gain {worst:e}");
    }
}

/// On a frictionless ground nothing acts along it: the cube tumbles and slides on at the
/// velocity along the ground it was thrown with, through its impacts, rapier's resting
/// contact and the step-end corrections. An energy cap that took a push-out's lift from all
/// its velocities would brake it step after step, as friction does (most in `Step` mode,
/// where rapier's resting contact leaves the cube below the gap at most steps' ends). The cap
/// takes it from the velocity along the ground only for what the velocity along the normal
/// and the spin about the other axes cannot pay, and leaves nothing of those then.
#[test]
fn a_cube_thrown_onto_a_frictionless_ground_keeps_its_velocity_along_it() {
    use rapier_impact::EventKind;
    for timing in [
        TimingMode::Step,
        TimingMode::TimeOfImpact,
        TimingMode::Exact,
    ] {
        let mut paid = 0;
        for seed in 1..=4 {
            let label = format!("frictionless cube seed {seed} {timing:?}");
            let (mut world, cube, mut p) = thrown_cube(seed, 0.0, timing);
            let along = |world: &PhysicsWorld| {
                let v = world.bodies[cube].linvel();
                (v.x, v.z)
            };
            let mut before = along(&world);
            let mut stats = Stats::new();
            for n in 1..=180 {
                step_checked(&mut world, &mut p, 0.0, &mut stats, &label);
                let now = along(&world);
                if now == before {
                    continue;
                }
                // To the bit otherwise: every impulse on it is along the ground's normal, and
                // rapier's integrator changes only the vertical velocity (gravity).
                let rb = &world.bodies[cube];
                let capped = p.events().iter().any(|e| e.kind == EventKind::EnergyCap);
                let (v, w) = (rb.linvel(), rb.angvel());
                assert!(
                    capped && v.y == 0.0 && w.x == 0.0 && w.z == 0.0,
                    "{label}: step {n}: velocity along the ground {before:?} -> {now:?}, \
                     velocity {v:?}, spin {w:?}, events {:?}",
                    p.events()
                );
                paid += 1;
                before = now;
            }
        }
        println!(
            "frictionless cube, {timing:?}: {paid} caps paid from the velocity along the ground"
        );
    }
}

/// A box spinning about axes it has locked (`enabled_rotations(false, true, false)` with an
/// angular velocity on all three axes), dropped on a slab: rapier turns the box with that
/// spin, but no impulse changes it and it holds none of the box's kinetic energy. Its
/// events' energies leave it out, in every mode: finite and never below zero. In `Exact`
/// mode, the only one where this run ends a step on an event (step 61), that event's energy
/// is what was written (`check_written`, with the energy on the axes the box can turn
/// about). Before, the impulse's work against that spin was counted as the
/// box's: an impact reported 5.97e-3 -> -2.51e-3 J in `Step` mode, and in `Exact` mode a
/// step's last event 3.20e-2 J where the box held 4.93e-3 J. The spin drives the contact
/// point as a moving ground would, so an impact may give the box energy even at `e <= 1`.
#[test]
fn a_box_spinning_about_a_locked_axis_reports_the_energy_it_holds() {
    for timing in [
        TimingMode::Step,
        TimingMode::TimeOfImpact,
        TimingMode::Exact,
    ] {
        let label = format!("box spinning about locked axes, {timing:?}");
        let mut world = PhysicsWorld::default();
        let (_, ground) = world.insert(
            RigidBodyBuilder::fixed(),
            ColliderBuilder::cuboid(50.0, 0.5, 50.0)
                .translation(Vector::new(0.0, -0.5, 0.0))
                .restitution(0.8),
        );
        world.insert(
            RigidBodyBuilder::dynamic()
                .translation(Vector::new(0.0, 1.0, 0.0))
                .enabled_rotations(false, true, false)
                .angvel(Vector::new(5.0, 5.0, 5.0)),
            ColliderBuilder::cuboid(0.3, 0.05, 0.1).restitution(0.8),
        );
        let mut p = plugin_on(&world, ground, timing);
        let (mut stats, mut impacts, mut gains) = (Stats::new(), 0, 0);
        for _ in 0..120 {
            p.step(&mut world);
            stats.steps += 1;
            assert_finite(&world, &label);
            for ev in p.events() {
                assert!(
                    ev.ke_before >= 0.0 && ev.ke_after >= 0.0 && ev.ke_after.is_finite(),
                    "{label}: step {}: {ev:?}",
                    stats.steps
                );
                impacts += usize::from(ev.kind == rapier_impact::EventKind::Impact);
                gains += usize::from(ev.ke_after > ev.ke_before);
            }
            check_written(&world, p.events(), &mut stats, &label);
        }
        println!(
            "{label}: {impacts} impacts, {gains} of them gaining energy, {} writes checked",
            stats.checked_writes
        );
        assert!(impacts >= 4, "{label}: only {impacts} impacts");
        assert!(
            timing != TimingMode::Exact || stats.checked_writes >= 1,
            "{label}: no step ended on an event: nothing written was checked"
        );
    }
}
