//! Nothing ends under the ground: thin and small bodies thrown hard at every ground kind,
//! in every timing mode at 30 and 60 Hz, end no step below a ground they were resolved
//! against and never fall through; the reproductions of the cases that did (a spinning plate
//! pushed out through a slab's far face, a ball left below a half-space by rapier's
//! integrator at dt = 0.5 s, a light ball struck by a heavy one next to a thin slab).
//!
//! Every ground's top is at `y = 0`; the throws print, per case, how many bodies rapier alone
//! and the plugin leave below it at the end. Throws per case: 25; set
//! `RAPIER_IMPACT_THROWS` for more.

#![allow(clippy::useless_conversion, clippy::unnecessary_cast)]

mod scene_support;

use rapier_impact::na::Vector3;
use rapier_impact::rapier::na::Unit;
use rapier_impact::rapier::prelude::*;
use rapier_impact::{EventKind, ImpactTiming, TimingMode};
use scene_support::*;

const MODES: [TimingMode; 3] = [
    TimingMode::Step,
    TimingMode::TimeOfImpact,
    TimingMode::Exact,
];

/// The grounds, each with its top at `y = 0`.
fn ground(kind: &str) -> ColliderBuilder {
    let builder = match kind {
        // 0.65 m thick, as in the report.
        "cuboid" => ColliderBuilder::cuboid(100.0, 0.3263522, 100.0)
            .translation(Vector::new(0.0, -0.3263522, 0.0)),
        // Wide enough that no throw leaves it in the 1.5 s of a run (at most 45 m).
        "slab" => slab_ground(100.0, 0.01),
        "trimesh" => trimesh_ground(100.0),
        "heightfield" => ColliderBuilder::heightfield(
            rapier_impact::rapier::parry::utils::Array2::zeros(8, 8),
            Vector::new(200.0, 1.0, 200.0),
        ),
        _ => ColliderBuilder::halfspace(Unit::new_unchecked(Vector::Y)),
    };
    builder.restitution(0.5).friction(0.8)
}

/// The lowest point of a body (m).
fn bottom(world: &PhysicsWorld, body: RigidBodyHandle) -> f64 {
    world.bodies[body]
        .colliders()
        .iter()
        .map(|c| wide(world.colliders[*c].compute_aabb().mins.y))
        .fold(f64::INFINITY, f64::min)
}

/// One throw of `body` at the ground `kind`, `steps` steps of `dt`, by rapier alone (`None`)
/// or the plugin: whether the body ends below the ground. With the plugin, asserts at every
/// step that a body resolved against the ground in the step ends above it (within rapier's
/// allowed linear error).
fn throw(
    kind: &str,
    body: (RigidBodyBuilder, ColliderBuilder),
    dt: f64,
    steps: usize,
    timing: Option<TimingMode>,
    label: &str,
) -> bool {
    let mut world = PhysicsWorld::default();
    world.integration_parameters.dt = real(dt);
    let (_, g) = world.insert(RigidBodyBuilder::fixed(), ground(kind));
    let (b, _) = world.insert(body.0, body.1);
    let mut plugin = timing.map(|timing| plugin_on(&world, g, timing));
    let allowed = wide(world.integration_parameters.allowed_linear_error());
    for k in 0..steps {
        match plugin.as_mut() {
            Some(p) => {
                p.step(&mut world);
                assert_finite(&world, label);
                if p.events().iter().any(|e| e.body == b) {
                    let depth = -bottom(&world, b);
                    assert!(
                        depth <= allowed + penetration_rounding(1.0),
                        "{label}: step {}: {depth:e} m below the ground it was resolved against: {:?}",
                        k + 1,
                        p.events()
                    );
                }
            }
            None => world.step(),
        }
    }
    // Fallen through: its centre below the surface.
    wide(world.bodies[b].translation().y) < 0.0
}

fn throws() -> usize {
    std::env::var("RAPIER_IMPACT_THROWS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(25)
}

/// The `k`-th thrown body: a plate (0.53 x 0.036 x 0.33 m half extents) or a capsule of
/// radius 4-10 mm, 0.7 m up, thrown down at up to 40 m/s with spins up to 60 rad/s.
fn thrown(plate: bool, k: usize) -> (RigidBodyBuilder, ColliderBuilder) {
    let mut r = jitter(0x9e37_79b9_7f4a_7c15 ^ ((k as u64 + 1) * 0x2545_f491), 1.0);
    let v = Vector::new(
        real(20.0 * r()),
        real(-20.0 - 20.0 * r().abs()),
        real(20.0 * r()),
    );
    let w = Vector::new(real(60.0 * r()), real(60.0 * r()), real(60.0 * r()));
    let rot = Vector::new(real(3.0 * r()), real(3.0 * r()), real(3.0 * r()));
    let rb = RigidBodyBuilder::dynamic()
        .translation(Vector::new(0.0, 0.7, 0.0))
        .rotation(rot)
        .linvel(v)
        .angvel(w);
    let co = if plate {
        ColliderBuilder::cuboid(0.5296442, 0.03566227, 0.32917637)
    } else {
        let radius = 0.007 + 0.003 * r();
        ColliderBuilder::capsule_y(real(0.02 + 0.03 * r().abs()), real(radius))
    };
    (rb, co.restitution(0.5).friction(0.8))
}

#[test]
fn thin_plates_and_small_capsules_thrown_at_every_ground_never_end_under_it() {
    let n = throws();
    for kind in ["cuboid", "slab", "trimesh", "heightfield"] {
        for plate in [true, false] {
            let shape = if plate { "plate" } else { "capsule" };
            for hz in [30.0, 60.0] {
                let dt = 1.0 / hz;
                let steps = (1.5 / dt) as usize;
                let alone = (0..n)
                    .filter(|k| throw(kind, thrown(plate, *k), dt, steps, None, ""))
                    .count();
                let mut counts = Vec::new();
                for timing in MODES {
                    let fell = (0..n)
                        .filter(|k| {
                            let label =
                                format!("{shape} on {kind} at {hz} Hz, {timing:?}, throw {k}");
                            throw(kind, thrown(plate, *k), dt, steps, Some(timing), &label)
                        })
                        .count();
                    counts.push(fell);
                }
                println!(
                    "{shape} on {kind} at {hz} Hz: below at the end of {n} throws: rapier alone {alone}, Step/TimeOfImpact/Exact {counts:?}"
                );
                assert_eq!(counts, [0, 0, 0], "{shape} on {kind} at {hz} Hz");
            }
        }
    }
}

#[test]
fn the_reported_plate_bounces_back_up_in_step_mode() {
    // The reproduction of the report: `Step`, dt = 1/30, a plate pushed out through its
    // ground's far face at the second step and falling for good.
    let tilt = Rotation::from_xyzw(0.5862187, 0.21144369, 0.7815203, -0.029413436);
    let rb = RigidBodyBuilder::dynamic()
        .translation(Vector::new(0.0, 0.6791001, 0.0))
        .rotation(tilt.to_scaled_axis())
        .linvel(Vector::new(8.711226, -39.290848, 19.714771))
        .angvel(Vector::new(-60.935722, -28.231802, 13.872842));
    let co = ColliderBuilder::cuboid(0.5296442, 0.03566227, 0.32917637)
        .restitution(0.5)
        .friction(0.8);
    for timing in MODES {
        let label = format!("reported plate, {timing:?}");
        let fell = throw(
            "cuboid",
            (rb.clone(), co.clone()),
            1.0 / 30.0,
            60,
            Some(timing),
            &label,
        );
        assert!(!fell, "{label}");
    }
}

#[test]
fn a_ball_at_half_a_second_a_step_never_ends_under_its_ground() {
    for timing in MODES {
        let label = format!("dt = 0.5 s, {timing:?}");
        let rb = RigidBodyBuilder::dynamic()
            .translation(Vector::new(0.0, 1.0, 0.0))
            .linvel(Vector::new(1.0, -2.0, 0.0))
            .angvel(Vector::new(0.0, 0.0, 5.0));
        let co = ColliderBuilder::ball(0.1).restitution(0.8);
        let mut world = PhysicsWorld::default();
        world.integration_parameters.dt = 0.5;
        let (_, g) = world.insert(
            RigidBodyBuilder::fixed(),
            ground("halfspace").restitution(0.8),
        );
        let (b, _) = world.insert(rb, co);
        let mut p = plugin_on(&world, g, timing);
        let allowed = wide(world.integration_parameters.allowed_linear_error());
        for k in 0..20 {
            p.step(&mut world);
            let depth = -bottom(&world, b);
            assert!(
                depth <= allowed + penetration_rounding(1.0),
                "{label}: step {}: {depth:e} m under",
                k + 1
            );
        }
    }
}

#[test]
fn a_light_ball_struck_by_a_heavy_one_over_a_thin_slab_stays_on_it() {
    // A 5 g ball on a 2 cm slab (no floor under it), struck from above by a 40 kg ball at
    // speeds up to 8 m/s, in every mode at 30 Hz.
    for timing in MODES {
        for k in 0..8 {
            let speed = 1.0 + k as f64;
            let label = format!("{timing:?}, heavy ball at {speed} m/s");
            let mut world = PhysicsWorld::default();
            world.integration_parameters.dt = 1.0 / 30.0;
            let (_, g) = world.insert(RigidBodyBuilder::fixed(), ground("slab"));
            let r_light = 0.0106;
            let (light, _) = world.insert(
                RigidBodyBuilder::dynamic().translation(Vector::new(0.0, real(r_light), 0.0)),
                ColliderBuilder::ball(real(r_light))
                    .density(1000.0)
                    .restitution(0.5),
            );
            let (heavy, _) = world.insert(
                RigidBodyBuilder::dynamic()
                    .translation(Vector::new(0.03, 0.4, 0.0))
                    .linvel(Vector::new(0.0, real(-speed), 0.0)),
                ColliderBuilder::ball(0.2).density(1194.0).restitution(0.5),
            );
            let mut p = plugin_on(&world, g, timing);
            for _ in 0..60 {
                p.step(&mut world);
                assert_finite(&world, &label);
            }
            for body in [light, heavy] {
                assert!(
                    wide(world.bodies[body].translation().y) > 0.0,
                    "{label}: {body:?} fell through"
                );
            }
        }
    }
}

#[test]
fn a_capsule_rapiers_resting_contact_lets_through_a_mesh_is_put_back_on_top() {
    // Throw 262 of the capsules at the trimesh, `Step` mode, 30 Hz (`f32`): at one step
    // rapier's resting contact lets it through the mesh. The next step finds it on the other
    // side of the mesh than it was and puts it back. (Of the first 400 throws, 262, 354 and
    // 379 cross so.)
    let mut world = PhysicsWorld::default();
    world.integration_parameters.dt = real(1.0 / 30.0);
    let (_, g) = world.insert(RigidBodyBuilder::fixed(), ground("trimesh"));
    let (rb, co) = thrown(false, 262);
    let (b, _) = world.insert(rb, co);
    let mut p = plugin_on(&world, g, TimingMode::Step);
    let mut put_back = 0;
    for _ in 0..45 {
        p.step(&mut world);
        put_back += p
            .events()
            .iter()
            .filter(|e| e.kind == EventKind::PushOut && e.timing == ImpactTiming::StepStart)
            .count();
    }
    // The crossing is this throw's in `f32`; in `f64` it comes to rest elsewhere, and only
    // the checks below apply.
    if !F64 {
        assert!(
            put_back > 0,
            "the capsule never crossed the mesh: the case is gone"
        );
    }
    assert!(wide(world.bodies[b].translation().y) > 0.0, "fell through");
    assert!(bottom(&world, b) >= -wide(world.integration_parameters.allowed_linear_error()));
}

/// A V-shaped crease, two faces `y = |x| tan(theta)` meeting along z, of one trimesh or one
/// heightfield, at 55 and 60 degrees, 60 Hz, every mode: a ball (r = 0.1 m) and a cube (half
/// side 0.1 m) dropped into it from 1 m come to rest in it, with no push-out at a step's
/// start. Resting against both faces, the body's contact turns from one face to the other
/// between steps; where the faces' normals are more than 90 degrees apart (slopes over 45
/// degrees) that turn was taken for the body crossing the mesh, and it was moved out through
/// the face it touched: 0.2 m under the mesh, falling for good.
///
/// The ball is never deeper in either face than rapier's allowed linear error, and rests
/// where it touches both, its centre `r / cos(theta)` up (0.2 m at 60 degrees), as under
/// rapier alone. The cube ends no deeper than that error, but while it bounces in the crease
/// its impacts meet one face at a time (one contact a ground), and it goes up to 3.3 cm into
/// the other in the in-step modes (rapier alone: 0.2 mm in the trimesh, 2.9 cm in the
/// 60-degree heightfield): asserted only to keep its centre over both faces, by half its half
/// side (the guide's "Not guaranteed").
#[test]
fn a_body_resting_in_a_steep_crease_of_a_mesh_stays_in_it() {
    let allowed = wide(
        PhysicsWorld::default()
            .integration_parameters
            .allowed_linear_error(),
    );
    for degrees in [55.0f64, 60.0] {
        let (tan, cos) = (degrees.to_radians().tan(), degrees.to_radians().cos());
        // Unit normals of the two faces, into the crease: a point's height over each face.
        let normals = [
            Vector3::new(-tan, 1.0, 0.0) * cos,
            Vector3::new(tan, 1.0, 0.0) * cos,
        ];
        let over = |q: &Vector3<f64>| normals.map(|n| n.dot(q));
        for mesh in ["trimesh", "heightfield"] {
            let crease = if mesh == "trimesh" {
                crease_trimesh(2.0, tan)
            } else {
                let n = 17;
                let heights = (0..n * n)
                    .map(|k| real((-4.0 + 8.0 * (k / n) as f64 / (n - 1) as f64).abs() * tan))
                    .collect();
                ColliderBuilder::heightfield(
                    rapier_impact::rapier::parry::utils::Array2::new(n, n, heights),
                    Vector::new(8.0, 1.0, 8.0),
                )
            };
            for body in ["ball", "cube"] {
                for timing in MODES {
                    let label = format!("{body} in a {degrees}-degree {mesh} crease, {timing:?}");
                    let mut world = PhysicsWorld::default();
                    let (_, g) = world.insert(
                        RigidBodyBuilder::fixed(),
                        crease.clone().restitution(0.8).friction(0.5),
                    );
                    let shape = if body == "ball" {
                        ColliderBuilder::ball(0.1)
                    } else {
                        ColliderBuilder::cuboid(0.1, 0.1, 0.1)
                    };
                    let (b, _) = world.insert(
                        RigidBodyBuilder::dynamic()
                            .translation(Vector::new(0.0, 1.0, 0.0))
                            .rotation(Vector::new(0.0, 0.0, 0.3)),
                        shape.restitution(0.8).friction(0.5),
                    );
                    let mut p = plugin_on(&world, g, timing);
                    // The centre, and the body's depth in each face: the ball's centre less
                    // its radius, the cube's lowest vertex.
                    let measure = |world: &PhysicsWorld| {
                        let rb = &world.bodies[b];
                        let at = |local: Vector| {
                            let v = rb.rotation() * local + rb.translation();
                            Vector3::new(wide(v.x), wide(v.y), wide(v.z))
                        };
                        let centre = at(Vector::ZERO);
                        let depth = if body == "ball" {
                            over(&centre).map(|h| 0.1 - h)
                        } else {
                            let corners: Vec<_> = (0..8)
                                .map(|k| {
                                    let sign = |bit: i32| if k & bit == 0 { -0.1 } else { 0.1 };
                                    over(&at(Vector::new(sign(1), sign(2), sign(4))))
                                })
                                .collect();
                            [0, 1].map(|f| corners.iter().map(|h| -h[f]).fold(f64::MIN, f64::max))
                        };
                        (centre, depth)
                    };
                    let mut deepest: f64 = 0.0;
                    for k in 1..=180 {
                        p.step(&mut world);
                        let put_back = p.events().iter().any(|e| {
                            e.kind == EventKind::PushOut && e.timing == ImpactTiming::StepStart
                        });
                        assert!(!put_back, "{label}: step {k}: {:?}", p.events());
                        let (centre, depth) = measure(&world);
                        deepest = deepest.max(depth[0]).max(depth[1]);
                        if body == "ball" {
                            assert!(deepest < allowed, "{label}: step {k}: {depth:?} m deep");
                        } else {
                            let lowest = over(&centre).into_iter().fold(f64::MAX, f64::min);
                            assert!(lowest > 0.05, "{label}: step {k}: centre {centre:?}");
                        }
                    }
                    let (centre, depth) = measure(&world);
                    println!("{label}: ends at {centre:?}, {depth:?} m deep, {deepest:e} at worst");
                    assert!(
                        depth.iter().all(|d| *d < allowed),
                        "{label}: ends {depth:?} deep"
                    );
                    if body == "ball" {
                        assert!(
                            (centre.y - 0.1 / cos).abs() < allowed && centre.x.abs() < allowed,
                            "{label}: ends at {centre:?}"
                        );
                    }
                }
            }
        }
    }
}
