//! Impacts between bodies that are not both balls (dice, a ball into a die): at their time of
//! impact inside the step, at the contact parry finds, with the model's two-body form; against
//! the closed forms (equal cubes face on: `(1 -+ e)/2`, no spin), against the model called on
//! the analytic contact (a ball into a cube's face off its centre, with friction and spin), and
//! against conservation (a cube's corner into a cube: momentum and angular momentum); a face
//! turning flat onto a face is struck at the corners that approach only.

mod plugin_support;

use approx::{abs_diff_eq, assert_abs_diff_eq};
use plugin_support::{F64, MODES, na, real, wide};
use rapier_impact::model::{self, Body, BodyVelocity, Material, PairContact, PairImpact};
use rapier_impact::na::{Matrix3, UnitQuaternion, Vector3};
use rapier_impact::rapier::prelude::*;
use rapier_impact::{
    Diagnostic, EventKind, ImpactConfig, ImpactEvent, ImpactPlugin, ImpactTiming, TimingMode,
};

/// Tolerance on velocities, relative to the speed: parry's contact in rapier's precision.
const V_TOL: f64 = if F64 { 1e-12 } else { 2e-6 };
/// Tolerance on the impact time (s): parry's distance in rapier's precision over 2 m/s.
const T_TOL: f64 = if F64 { 1e-12 } else { 1e-7 };

fn world() -> PhysicsWorld {
    PhysicsWorld {
        gravity: Vector::ZERO,
        ..Default::default()
    }
}

fn v3(v: Vector3<f64>) -> Vector {
    Vector::new(real(v.x), real(v.y), real(v.z))
}

/// A dynamic body with one collider at `at`, rotated by `rot`, moving at `v`, spinning at `w`.
fn body(
    w: &mut PhysicsWorld,
    collider: ColliderBuilder,
    at: Vector3<f64>,
    rot: UnitQuaternion<f64>,
    v: Vector3<f64>,
    spin: Vector3<f64>,
) -> (RigidBodyHandle, ColliderHandle) {
    let q = rot.quaternion();
    w.insert(
        RigidBodyBuilder::dynamic()
            .pose(Pose::from_parts(
                v3(at),
                Rotation::from_xyzw(real(q.i), real(q.j), real(q.k), real(q.w)),
            ))
            .linvel(v3(v))
            .angvel(v3(spin))
            .can_sleep(false),
        collider,
    )
}

fn cube(h: f64, e: f64, mu: f64) -> ColliderBuilder {
    ColliderBuilder::cuboid(real(h), real(h), real(h))
        .density(1000.0)
        .restitution(real(e))
        .friction(real(mu))
}

fn plugin(mode: TimingMode) -> ImpactPlugin {
    let mut p = ImpactPlugin::new(ImpactConfig::default().with_timing(mode)).unwrap();
    p.set_all_dynamic_bodies_impact(true);
    p
}

/// The pair impacts of the run, each with its time from the run's start.
fn run(p: &mut ImpactPlugin, w: &mut PhysicsWorld, steps: usize) -> Vec<(f64, ImpactEvent)> {
    let dt = wide(w.integration_parameters.dt);
    let mut seen = Vec::new();
    for k in 0..steps {
        p.step(w);
        for ev in p.events() {
            if ev.body2.is_some() && ev.kind == EventKind::Impact {
                seen.push((k as f64 * dt + ev.time, *ev));
            }
        }
    }
    seen
}

fn rot_of(rb: &RigidBody) -> UnitQuaternion<f64> {
    let q = *rb.rotation();
    UnitQuaternion::from_quaternion(rapier_impact::na::Quaternion::new(
        wide(q.w),
        wide(q.x),
        wide(q.y),
        wide(q.z),
    ))
}

fn velocity(w: &PhysicsWorld, h: RigidBodyHandle) -> (Vector3<f64>, Vector3<f64>) {
    (na(w.bodies[h].linvel()), na(w.bodies[h].angvel()))
}

/// The model's body for a rapier body: mass and world inertia (its principal inertia about
/// the principal frame, turned to the world).
fn model_body(w: &PhysicsWorld, h: RigidBodyHandle) -> Body {
    Body::from_inertia(wide(w.bodies[h].mass()), world_inertia(w, h)).unwrap()
}

/// The model's impact (the plugin's law) of body `a` moving at `v`, turning at `w`, into
/// body `b` at rest, at `contact`, restitution `e` and friction `mu`.
fn struck_at_rest(
    a: &Body,
    v: Vector3<f64>,
    w: Vector3<f64>,
    b: &Body,
    contact: &PairContact,
    e: f64,
    mu: f64,
) -> PairImpact {
    let before_a = BodyVelocity {
        linear: v,
        angular: w,
    };
    let material = Material::new(e, mu);
    let law = ImpactConfig::default().law;
    model::resolve_pair(
        law,
        a,
        &before_a,
        b,
        &BodyVelocity::default(),
        contact,
        &material,
    )
    .unwrap()
}

/// A rapier body's inertia tensor about its centre of mass in the world frame.
fn world_inertia(w: &PhysicsWorld, h: RigidBodyHandle) -> Matrix3<f64> {
    let rb = &w.bodies[h];
    let props = rb.mass_properties().local_mprops;
    let frame = props.principal_inertia_local_frame;
    let rot = *rb.rotation() * frame;
    let r = UnitQuaternion::from_quaternion(rapier_impact::na::Quaternion::new(
        wide(rot.w),
        wide(rot.x),
        wide(rot.y),
        wide(rot.z),
    ))
    .to_rotation_matrix();
    let d = na(props.principal_inertia());
    r.matrix() * Matrix3::from_diagonal(&d) * r.matrix().transpose()
}

/// Two equal cubes face on, the first at 2 m/s into the second at rest, frictionless: they
/// touch when the gap has closed, and leave at `(1 -+ e)/2` of the speed with no spin (the
/// four corners of the touching faces give one impact at the face centre).
#[test]
fn equal_cubes_face_on_exchange_speed_by_the_closed_form() {
    // Centres 0.41 m apart: the touch falls inside a step (9.3 steps at 60 Hz).
    let (h, e, speed, gap0) = (0.05, 0.8, 2.0, 0.41);
    for mode in [TimingMode::TimeOfImpact, TimingMode::Exact] {
        let mut w = world();
        let none = UnitQuaternion::identity();
        let zero = Vector3::zeros();
        let (a, _) = body(
            &mut w,
            cube(h, e, 0.0),
            zero,
            none,
            Vector3::x() * speed,
            zero,
        );
        let (b, _) = body(
            &mut w,
            cube(h, e, 0.0),
            Vector3::x() * gap0,
            none,
            zero,
            zero,
        );
        let mut p = plugin(mode);
        let seen = run(&mut p, &mut w, 30);
        assert_eq!(
            seen.len(),
            2,
            "{mode:?}: one impact, an event each: {seen:?}"
        );
        let t_touch = (gap0 - 2.0 * h) / speed;
        for (t, ev) in &seen {
            assert!(
                abs_diff_eq!(*t, t_touch, epsilon = T_TOL),
                "{mode:?}: at {t}, expected {t_touch}"
            );
            assert_eq!(ev.timing, ImpactTiming::InStep);
            assert_eq!(ev.contact_points, 4, "{mode:?}: the four corners of a face");
            let point = na(ev.point);
            let expected = Vector3::new(h + speed * t_touch, 0.0, 0.0);
            assert!(
                (point - expected).norm() <= T_TOL * speed * 10.0,
                "{mode:?}: at {point}, expected {expected}"
            );
        }
        let ((va, wa), (vb, wb)) = (velocity(&w, a), velocity(&w, b));
        let tol = V_TOL * speed;
        assert!(
            (va - Vector3::x() * (1.0 - e) / 2.0 * speed).norm() <= tol,
            "{mode:?}: {va}"
        );
        assert!(
            (vb - Vector3::x() * (1.0 + e) / 2.0 * speed).norm() <= tol,
            "{mode:?}: {vb}"
        );
        assert!(
            wa.norm() <= tol / h && wb.norm() <= tol / h,
            "{mode:?}: no spin {wa} {wb}"
        );
        // And flown on exactly after the impact: the gap opened at e times the approach.
        let gap = na(w.bodies[b].translation()).x - na(w.bodies[a].translation()).x - 2.0 * h;
        let t_end = 30.0 * wide(w.integration_parameters.dt);
        let expected = e * speed * (t_end - t_touch);
        assert!(
            abs_diff_eq!(gap, expected, epsilon = 10.0 * T_TOL * speed),
            "{mode:?}: gap {gap}, {expected}"
        );
    }
}

/// A spinning ball with friction into the face of a cube at rest, off the face's centre: the
/// plugin's velocities after the impact are the model's on the analytic contact (the ball's
/// centre projected on the face, normal along the face's).
#[test]
fn a_ball_into_a_cube_face_off_centre_is_the_models_impact_at_the_analytic_contact() {
    let (r, h, e, mu) = (0.03, 0.05, 0.7, 0.4);
    let (offset, speed) = (0.02, 2.0);
    let spin = Vector3::new(0.0, 30.0, -20.0);
    for mode in [TimingMode::TimeOfImpact, TimingMode::Exact] {
        let mut w = world();
        let none = UnitQuaternion::identity();
        let zero = Vector3::zeros();
        let ball = ColliderBuilder::ball(real(r))
            .density(1000.0)
            .restitution(real(e))
            .friction(real(mu));
        let start = Vector3::new(0.0, offset, 0.0);
        let (a, _) = body(&mut w, ball, start, none, Vector3::x() * speed, spin);
        let (b, _) = body(&mut w, cube(h, e, mu), Vector3::x() * 0.4, none, zero, zero);
        // The model on the analytic contact, with the states just before it.
        let (body_a, body_b) = (model_body(&w, a), model_body(&w, b));
        let mut p = plugin(mode);
        let seen = run(&mut p, &mut w, 30);
        assert_eq!(seen.len(), 2, "{mode:?}: {seen:?}");
        let t_touch = (0.4 - h - r) / speed;
        assert!(
            abs_diff_eq!(seen[0].0, t_touch, epsilon = T_TOL),
            "{mode:?}: at {}",
            seen[0].0
        );
        let point = Vector3::new(0.4 - h, offset, 0.0);
        let centre_a = start + Vector3::x() * speed * t_touch;
        let contact = PairContact {
            normal: Vector3::x(),
            offset_a: point - centre_a,
            offset_b: point - Vector3::x() * 0.4,
        };
        let expected = struck_at_rest(
            &body_a,
            Vector3::x() * speed,
            spin,
            &body_b,
            &contact,
            e,
            mu,
        );
        let ((va, wa), (vb, wb)) = (velocity(&w, a), velocity(&w, b));
        let tol = V_TOL * speed;
        assert!(
            (va - expected.a.linear).norm() <= tol,
            "{mode:?}: {va} {}",
            expected.a.linear
        );
        assert!(
            (vb - expected.b.linear).norm() <= tol,
            "{mode:?}: {vb} {}",
            expected.b.linear
        );
        assert!(
            (wa - expected.a.angular).norm() <= tol / r,
            "{mode:?}: {wa}"
        );
        assert!(
            (wb - expected.b.angular).norm() <= tol / h,
            "{mode:?}: {wb}"
        );
        // The impulse is the model's, and the events' energies are the states written (no
        // gravity: the velocities after the impact are the step's end ones).
        let ev_b = seen.iter().find(|(_, ev)| ev.body == b).unwrap().1;
        assert!((na(ev_b.impulse) - expected.impulse).norm() <= tol * wide(w.bodies[a].mass()));
        for (_, ev) in &seen {
            let (v, om) = velocity(&w, ev.body);
            let m = wide(w.bodies[ev.body].mass());
            let ke = 0.5 * m * v.norm_squared() + 0.5 * om.dot(&(world_inertia(&w, ev.body) * om));
            let rel = if F64 { 1e-12 } else { 1e-5 };
            assert!(
                abs_diff_eq!(ev.ke_after, ke, epsilon = rel * ke),
                "{mode:?}: {} written {ke}",
                ev.ke_after
            );
        }
    }
}

/// A spinning cube turned on its corner into the face of a cube at rest, with friction: the
/// first impact is at the analytic time and corner, with `model::resolve_pair`'s impulse and
/// velocities on that contact; linear and angular momentum about the origin are conserved
/// through both impacts, no energy is gained, and the cube hit turns.
#[test]
fn a_cube_corner_into_a_cube_conserves_momentum_and_meets_at_the_corner() {
    let (h, e, mu, speed) = (0.05, 0.6, 0.5, 2.0);
    let tilt = UnitQuaternion::from_euler_angles(0.3, 0.5, 0.7);
    for mode in [TimingMode::TimeOfImpact, TimingMode::Exact] {
        let (mut w, a, b) = cube_corner_scene(h, e, mu, speed, tilt);
        let (p0, l0, e0) = momenta(&w, [a, b]);
        let mut p = plugin(mode);
        let (mut seen, steps, before) = up_to_the_first_impact(&mut p, &mut w, a);
        assert_eq!(
            seen.len(),
            2,
            "{mode:?}: the first impact, an event each: {seen:?}"
        );
        let (c0, q0, v0, w0) = before.unwrap();
        let dt = wide(w.integration_parameters.dt);
        let (hi, point, centre) = first_corner_touch((c0, q0, v0, w0), h, dt);
        let ev = seen[0].1;
        assert!(
            abs_diff_eq!(ev.time, hi, epsilon = T_TOL),
            "{mode:?}: at {}, analytic {hi}",
            ev.time
        );
        assert!(
            point.y.abs() < h && point.z.abs() < h,
            "a corner on the face"
        );
        assert!(
            (na(ev.point) - point).norm() <= 10.0 * T_TOL * speed,
            "{mode:?}: at {} not {point}",
            na(ev.point)
        );
        // The model on the analytic contact: the impulse, and the velocities written.
        let contact = PairContact {
            normal: Vector3::x(),
            offset_a: point - centre,
            offset_b: point - Vector3::x() * 0.4,
        };
        let (body_a, body_b) = (model_body(&w, a), model_body(&w, b));
        let expected = struck_at_rest(&body_a, v0, w0, &body_b, &contact, e, mu);
        let tol = V_TOL * speed;
        let ev_b = seen.iter().find(|(_, ev)| ev.body == b).unwrap().1;
        let mass = wide(w.bodies[a].mass());
        assert!(
            (na(ev_b.impulse) - expected.impulse).norm() <= tol * mass,
            "{mode:?}: impulse {} not {}",
            na(ev_b.impulse),
            expected.impulse
        );
        let ((va, wa), (vb, wb)) = (velocity(&w, a), velocity(&w, b));
        assert!((va - expected.a.linear).norm() <= tol, "{mode:?}: {va}");
        assert!((vb - expected.b.linear).norm() <= tol, "{mode:?}: {vb}");
        assert!(
            (wa - expected.a.angular).norm() <= tol / h,
            "{mode:?}: {wa}"
        );
        assert!(
            (wb - expected.b.angular).norm() <= tol / h,
            "{mode:?}: {wb}"
        );
        seen.extend(run(&mut p, &mut w, 30 - steps));
        // The corner's impact spins the cube, whose next corner meets the other cube in the
        // next step: two impacts, each the model's (rapier's contact would not conserve the
        // angular momentum: its speculative impulses act at two points apart).
        assert_eq!(seen.len(), 4, "{mode:?}: {seen:?}");
        let (p1, l1, e1) = momenta(&w, [a, b]);
        let scale = p0.norm();
        let tol = if F64 { 1e-12 } else { 1e-5 };
        assert!((p1 - p0).norm() <= tol * scale, "{mode:?}: p {p0} -> {p1}");
        assert!((l1 - l0).norm() <= tol * scale, "{mode:?}: L {l0} -> {l1}");
        assert!(e1 <= e0 * (1.0 + tol), "{mode:?}: energy {e0} -> {e1}");
        assert!(e1 < e0 * 0.999, "{mode:?}: some energy lost at e = {e}");
        assert_eq!(
            seen[0].1.contact_points, 1,
            "{mode:?}: a corner is one point"
        );
        assert!(
            velocity(&w, b).1.norm() > 0.1,
            "{mode:?}: the cube hit turns"
        );
    }
}

/// A cube of half side `h` turned by `tilt` and spinning, at `speed` along x towards a cube at
/// rest 0.4 m away, its centre slightly off the other's axis.
fn cube_corner_scene(
    h: f64,
    e: f64,
    mu: f64,
    speed: f64,
    tilt: UnitQuaternion<f64>,
) -> (PhysicsWorld, RigidBodyHandle, RigidBodyHandle) {
    let mut w = world();
    let zero = Vector3::zeros();
    let spin = Vector3::new(1.0, -2.0, 3.0);
    let (a, _) = body(
        &mut w,
        cube(h, e, mu),
        Vector3::new(0.0, 0.01, -0.02),
        tilt,
        Vector3::x() * speed,
        spin,
    );
    let (b, _) = body(
        &mut w,
        cube(h, e, mu),
        Vector3::x() * 0.4,
        UnitQuaternion::identity(),
        zero,
        zero,
    );
    (w, a, b)
}

/// The linear and angular momentum (about the origin) and the kinetic energy of `bodies`.
fn momenta(w: &PhysicsWorld, bodies: [RigidBodyHandle; 2]) -> (Vector3<f64>, Vector3<f64>, f64) {
    let mut p = Vector3::zeros();
    let mut l = Vector3::zeros();
    let mut energy = 0.0;
    for h in bodies {
        let rb = &w.bodies[h];
        let (m, inertia) = (wide(rb.mass()), world_inertia(w, h));
        let (v, om) = (na(rb.linvel()), na(rb.angvel()));
        let c = na(rb.center_of_mass());
        p += v * m;
        l += c.cross(&(v * m)) + inertia * om;
        energy += 0.5 * m * v.norm_squared() + 0.5 * om.dot(&(inertia * om));
    }
    (p, l, energy)
}

/// The cube's state at the start of a step: its centre, orientation, velocity and spin.
type Motion = (
    Vector3<f64>,
    UnitQuaternion<f64>,
    Vector3<f64>,
    Vector3<f64>,
);

/// Steps up to the step of the first impact (at most 30): its events, the steps taken, and the
/// state of `a` before that step.
fn up_to_the_first_impact(
    p: &mut ImpactPlugin,
    w: &mut PhysicsWorld,
    a: RigidBodyHandle,
) -> (Vec<(f64, ImpactEvent)>, usize, Option<Motion>) {
    let mut seen = Vec::new();
    let mut steps = 0;
    let mut before = None;
    while seen.is_empty() && steps < 30 {
        let rb = &w.bodies[a];
        before = Some((
            na(rb.center_of_mass()),
            rot_of(rb),
            na(rb.linvel()),
            na(rb.angvel()),
        ));
        seen = run(p, w, 1);
        steps += 1;
    }
    (seen, steps, before)
}

/// The analytic first touch from the state `before` a step of `dt` (no gravity: the centre
/// moves straight, the isotropic cube turns at constant spin): the corner farthest along x reaches
/// the face of the cube at rest, found by bisection. The time, the corner and the centre then.
fn first_corner_touch(before: Motion, h: f64, dt: f64) -> (f64, Vector3<f64>, Vector3<f64>) {
    let (c0, q0, v0, w0) = before;
    let corner = |t: f64| {
        let q = UnitQuaternion::from_scaled_axis(w0 * t) * q0;
        let c = c0 + v0 * t;
        let mut best = Vector3::repeat(f64::INFINITY);
        for k in 0..8 {
            let sign = |bit: usize| if k & bit == 0 { -h } else { h };
            let x = c + q * Vector3::new(sign(1), sign(2), sign(4));
            if x.x > best.x || best.x.is_infinite() {
                best = x;
            }
        }
        (best, c)
    };
    let face = 0.4 - h;
    let (mut lo, mut hi) = (0.0, dt);
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if corner(mid).0.x < face {
            lo = mid
        } else {
            hi = mid
        }
    }
    let (point, centre) = corner(hi);
    (hi, point, centre)
}

/// `Step` mode resolves the pair at the step's start; the cubes then leave at the closed-form
/// speeds, rapier's resting contact holding them apart for that step.
#[test]
fn step_mode_resolves_a_cube_pair_at_the_step_start() {
    let (h, e, speed) = (0.05, 0.8, 2.0);
    let mut w = world();
    let none = UnitQuaternion::identity();
    let zero = Vector3::zeros();
    let (a, _) = body(
        &mut w,
        cube(h, e, 0.0),
        zero,
        none,
        Vector3::x() * speed,
        zero,
    );
    let (b, _) = body(
        &mut w,
        cube(h, e, 0.0),
        Vector3::x() * 0.4,
        none,
        zero,
        zero,
    );
    let mut p = plugin(TimingMode::Step);
    let seen = run(&mut p, &mut w, 30);
    assert_eq!(seen.len(), 2, "{seen:?}");
    assert!(
        seen.iter()
            .all(|(_, ev)| ev.timing == ImpactTiming::StepStart)
    );
    let (va, vb) = (velocity(&w, a).0.x, velocity(&w, b).0.x);
    let tol = V_TOL * speed;
    assert_abs_diff_eq!(va, (1.0 - e) / 2.0 * speed, epsilon = tol);
    assert_abs_diff_eq!(vb, (1.0 + e) / 2.0 * speed, epsilon = tol);
}

/// Two cubes whose collision groups exclude each other pass through each other in rapier
/// alone, and with the plugin: no event, the first cube beyond the second at its speed.
#[test]
fn cubes_filtered_out_by_collision_groups_are_rapiers() {
    for mode in MODES {
        let mut w = world();
        let none = UnitQuaternion::identity();
        let zero = Vector3::zeros();
        let groups =
            InteractionGroups::new(Group::GROUP_1, Group::GROUP_2, InteractionTestMode::And);
        let cube = || cube(0.05, 0.8, 0.0).collision_groups(groups);
        let (a, _) = body(&mut w, cube(), zero, none, Vector3::x() * 2.0, zero);
        let (b, _) = body(&mut w, cube(), Vector3::x() * 0.4, none, zero, zero);
        let mut p = plugin(mode);
        let seen = run(&mut p, &mut w, 30);
        assert!(seen.is_empty(), "{mode:?}: {seen:?}");
        let (xa, xb) = (
            na(w.bodies[a].translation()).x,
            na(w.bodies[b].translation()).x,
        );
        assert!(xa > xb + 0.5, "{mode:?}: passed through, {xa} {xb}");
        assert_eq!(velocity(&w, a).0, Vector3::x() * 2.0, "{mode:?}");
    }
}

/// Two dice falling under gravity, the lower one thrown up into the one above, face on:
/// gravity moves both alike, so they meet when the closed form says and leave at
/// `(1 -+ e)/2` of their relative speed, with no spin.
#[test]
fn dice_meeting_in_the_air_follow_the_closed_form() {
    let (h, e, up) = (0.01, 0.5, 3.0);
    for mode in [TimingMode::TimeOfImpact, TimingMode::Exact] {
        let mut w = PhysicsWorld {
            gravity: Vector::new(0.0, -9.81, 0.0),
            ..Default::default()
        };
        let none = UnitQuaternion::identity();
        let zero = Vector3::zeros();
        let (low, _) = body(
            &mut w,
            cube(h, e, 0.3),
            Vector3::y() * 1.0,
            none,
            Vector3::y() * up,
            zero,
        );
        let (high, _) = body(
            &mut w,
            cube(h, e, 0.3),
            Vector3::y() * 1.123,
            none,
            zero,
            zero,
        );
        let mut p = plugin(mode);
        let seen = run(&mut p, &mut w, 6);
        assert_eq!(seen.len(), 2, "{mode:?}: {seen:?}");
        let t_touch = (0.123 - 2.0 * h) / up;
        assert!(
            abs_diff_eq!(seen[0].0, t_touch, epsilon = T_TOL),
            "{mode:?}: at {}",
            seen[0].0
        );
        assert_eq!(seen[0].1.contact_points, 4, "{mode:?}");
        // Both fell alike; relative to their common motion, `low` arrived at `up`.
        let t_end = 6.0 * wide(w.integration_parameters.dt);
        let fall = -9.81 * t_end;
        let (vl, wl) = velocity(&w, low);
        let (vh, wh) = velocity(&w, high);
        let tol = V_TOL * up;
        assert!(
            abs_diff_eq!(vl.y, fall + (1.0 - e) / 2.0 * up, epsilon = tol),
            "{mode:?}: {vl}"
        );
        assert!(
            abs_diff_eq!(vh.y, fall + (1.0 + e) / 2.0 * up, epsilon = tol),
            "{mode:?}: {vh}"
        );
        assert!(
            wl.norm() <= tol / h && wh.norm() <= tol / h,
            "{mode:?}: {wl} {wh}"
        );
    }
}

fn lane_world() -> (PhysicsWorld, ColliderHandle) {
    let mut w = PhysicsWorld {
        gravity: Vector::new(0.0, -9.81, 0.0),
        ..Default::default()
    };
    let (_, lane) = w.insert(
        RigidBodyBuilder::fixed(),
        ColliderBuilder::halfspace(plugin_support::up()).friction(0.3),
    );
    (w, lane)
}

/// A ball rolling on the lane into a pin standing on it (a box on the ground): rapier's
/// solver holds the pin on the lane, so the plugin cannot move it alone through the impact,
/// and the pair is rapier's contact, as it is: no pair event while the pin stands, none at
/// the step's end. The pin is sent off, nothing is NaN, no energy is made, and the two end
/// apart.
#[test]
fn a_ball_into_a_pin_standing_on_the_lane_is_rapiers_contact() {
    for mode in MODES {
        let (mut w, lane) = lane_world();
        let r = 0.1;
        let ball = ColliderBuilder::ball(real(r))
            .density(1000.0)
            .restitution(0.6)
            .friction(0.2);
        let (b, cb) = body(
            &mut w,
            ball,
            Vector3::new(0.0, r, 0.0),
            UnitQuaternion::identity(),
            Vector3::x() * 4.0,
            Vector3::z() * (-4.0 / r),
        );
        let pin = ColliderBuilder::cuboid(0.03, 0.15, 0.03)
            .density(500.0)
            .restitution(0.6)
            .friction(0.2);
        let (pin, cp) = body(
            &mut w,
            pin,
            Vector3::new(0.6, 0.15, 0.0),
            UnitQuaternion::identity(),
            Vector3::zeros(),
            Vector3::zeros(),
        );
        let mut p = plugin(mode);
        p.add_ground(&w.bodies, &w.colliders, lane).unwrap();
        let energy = |w: &PhysicsWorld| -> f64 {
            [b, pin]
                .iter()
                .map(|h| {
                    let rb = &w.bodies[*h];
                    let (m, v, om) = (wide(rb.mass()), na(rb.linvel()), na(rb.angvel()));
                    let y = na(rb.center_of_mass()).y;
                    0.5 * m * v.norm_squared()
                        + 0.5 * om.dot(&(world_inertia(w, *h) * om))
                        + m * 9.81 * y
                })
                .sum()
        };
        let e0 = energy(&w);
        let mut knocked = false;
        for _ in 0..30 {
            let seen = run(&mut p, &mut w, 1);
            let standing = !knocked;
            knocked |= na(w.bodies[pin].linvel()).norm() > 0.1;
            if standing {
                assert!(
                    seen.is_empty(),
                    "{mode:?}: the standing pin's pair is rapier's: {seen:?}"
                );
            }
            assert!(
                seen.iter()
                    .all(|(_, ev)| ev.timing != ImpactTiming::StepEnd),
                "{mode:?}: {seen:?}"
            );
        }
        assert!(
            knocked && na(w.bodies[pin].linvel()).x > 0.5,
            "{mode:?}: the pin is sent off"
        );
        for h in [b, pin] {
            let rb = &w.bodies[h];
            assert!(na(rb.linvel()).iter().all(|x| x.is_finite()), "{mode:?}");
            assert!(
                na(rb.translation()).iter().all(|x| x.is_finite()),
                "{mode:?}"
            );
        }
        let e1 = energy(&w);
        assert!(e1 <= e0 * (1.0 + 1e-3), "{mode:?}: energy {e0} -> {e1}");
        let d = parry_distance(&w, cb, cp);
        assert!(d > -1e-3, "{mode:?}: overlap {d}");
    }
}

/// parry's signed distance between two colliders at their current poses (m).
fn parry_distance(w: &PhysicsWorld, c1: ColliderHandle, c2: ColliderHandle) -> f64 {
    let (a, b) = (&w.colliders[c1], &w.colliders[c2]);
    rapier_impact::parry::query::contact(a.position(), a.shape(), b.position(), b.shape(), 1.0)
        .unwrap()
        .map_or(1.0, |c| wide(c.dist))
}

/// The kinetic and potential energy of some bodies (J, gravity 9.81 m/s^2 along -y).
fn energy_of(w: &PhysicsWorld, bodies: &[RigidBodyHandle]) -> f64 {
    bodies
        .iter()
        .map(|h| {
            let rb = &w.bodies[*h];
            let (m, v, om) = (wide(rb.mass()), na(rb.linvel()), na(rb.angvel()));
            0.5 * m * v.norm_squared()
                + 0.5 * om.dot(&(world_inertia(w, *h) * om))
                + m * 9.81 * na(rb.center_of_mass()).y
        })
        .sum()
}

/// A die thrown fast (5 m/s: five of its sizes a step at 60 Hz) at a die just put on the
/// table, touching it at the start of the second step: the lying die is within the resting
/// gap of the table (rapier's narrow phase has no contact for it yet), so the pair is
/// rapier's contact: no step-end resolution, the die hit is pushed on, the thrown one stays
/// behind it, they end no deeper in each other than rapier's allowed error, and no energy
/// is made.
#[test]
fn a_die_thrown_at_a_die_lying_on_the_table_is_rapiers_contact() {
    let h = 0.008;
    for mode in MODES {
        let (mut w, table) = lane_world();
        let none = UnitQuaternion::identity();
        let zero = Vector3::zeros();
        let lying_at = Vector3::new(0.1, h, 0.0);
        let (lying, cl) = body(&mut w, cube(h, 0.5, 0.3), lying_at, none, zero, zero);
        let thrown_at = Vector3::new(0.0, h + 0.002, 0.0);
        let (thrown, ct) = body(
            &mut w,
            cube(h, 0.5, 0.3),
            thrown_at,
            none,
            Vector3::x() * 5.0,
            zero,
        );
        let mut p = plugin(mode);
        p.add_ground(&w.bodies, &w.colliders, table).unwrap();
        let e0 = energy_of(&w, &[lying, thrown]);
        let seen = run(&mut p, &mut w, 12);
        assert!(seen.is_empty(), "{mode:?}: rapier's contact: {seen:?}");
        let (xl, xt) = (
            na(w.bodies[lying].translation()).x,
            na(w.bodies[thrown].translation()).x,
        );
        assert!(xl > 0.1 + 0.01, "{mode:?}: the die hit moved on, at {xl}");
        assert!(xt < xl, "{mode:?}: no pass-through, {xt} {xl}");
        let allowed = wide(w.integration_parameters.allowed_linear_error());
        let d = parry_distance(&w, cl, ct);
        assert!(d > -allowed, "{mode:?}: {d} deep");
        let e1 = energy_of(&w, &[lying, thrown]);
        assert!(e1 <= e0 * (1.0 + 1e-6), "{mode:?}: energy {e0} -> {e1}");
    }
}

/// A die resting on a fixed box that is not a ground, struck by a die thrown along the box:
/// rapier's solver holds the resting die on the box, so the pair is rapier's contact (no
/// event), not one checked only at the step's end.
#[test]
fn a_die_held_on_a_body_that_is_not_ground_is_rapiers_contact() {
    let h = 0.01;
    for mode in MODES {
        let mut w = PhysicsWorld {
            gravity: Vector::new(0.0, -9.81, 0.0),
            ..Default::default()
        };
        w.insert(
            RigidBodyBuilder::fixed().translation(Vector::new(0.0, -0.5, 0.0)),
            ColliderBuilder::cuboid(2.0, 0.5, 2.0),
        );
        let none = UnitQuaternion::identity();
        let zero = Vector3::zeros();
        let (lying, _) = body(
            &mut w,
            cube(h, 0.5, 0.3),
            Vector3::new(0.3, h, 0.0),
            none,
            zero,
            zero,
        );
        let (thrown, _) = body(
            &mut w,
            cube(h, 0.5, 0.3),
            Vector3::new(0.0, h + 0.001, 0.0),
            none,
            Vector3::x() * 2.0,
            zero,
        );
        let mut p = plugin(mode);
        let seen = run(&mut p, &mut w, 20);
        assert!(seen.is_empty(), "{mode:?}: rapier's contact: {seen:?}");
        let (xl, xt) = (
            na(w.bodies[lying].translation()).x,
            na(w.bodies[thrown].translation()).x,
        );
        assert!(
            xl > 0.3 + 0.01 && xt < xl,
            "{mode:?}: hit and pushed on, {xt} {xl}"
        );
    }
}

/// Two compound dice (each two cuboids) meeting in the air: parry's manifolds between
/// compounds are in their pieces' frames, so such bodies are rapier's (no event), and they
/// still bounce apart.
#[test]
fn compound_bodies_are_rapiers() {
    for mode in MODES {
        let mut w = world();
        let piece = |y: f64| {
            (
                Pose::from_translation(Vector::new(0.0, real(y), 0.0)),
                SharedShape::cuboid(0.05, 0.025, 0.05),
            )
        };
        let compound = || {
            ColliderBuilder::compound(vec![piece(0.025), piece(-0.025)])
                .density(1000.0)
                .restitution(0.8)
        };
        let none = UnitQuaternion::identity();
        let zero = Vector3::zeros();
        let (a, _) = body(&mut w, compound(), zero, none, Vector3::x() * 2.0, zero);
        let (b, _) = body(&mut w, compound(), Vector3::x() * 0.41, none, zero, zero);
        let mut p = plugin(mode);
        let seen = run(&mut p, &mut w, 30);
        assert!(seen.is_empty(), "{mode:?}: {seen:?}");
        assert!(
            velocity(&w, b).0.x > 1.0 && velocity(&w, a).0.x < 1.0,
            "{mode:?}: rapier's bounce"
        );
    }
}

/// A stack of three opted-in dice dropped a little onto the ground: after the landing
/// impacts the dice lie on each other, and those pairs stay rapier's resting contacts (no
/// impact between them once at rest, no hook on them), the stack stands where rapier alone
/// leaves it, and sleeps.
#[test]
fn a_stack_of_dice_lies_still_as_rapiers_resting_contact() {
    let h = 0.02;
    let make = || {
        let mut w = PhysicsWorld {
            gravity: Vector::new(0.0, -9.81, 0.0),
            ..Default::default()
        };
        let (_, ground) = w.insert(
            RigidBodyBuilder::fixed(),
            ColliderBuilder::halfspace(plugin_support::up()),
        );
        let dice: Vec<RigidBodyHandle> = (0..3)
            .map(|k| {
                let y = h + k as f64 * (2.0 * h + 1e-4);
                let (b, _) = w.insert(
                    RigidBodyBuilder::dynamic().translation(Vector::new(0.0, real(y), 0.0)),
                    cube(h, 0.5, 0.5),
                );
                b
            })
            .collect();
        (w, ground, dice)
    };
    for mode in MODES {
        let (mut alone, _, dice0) = make();
        let (mut w, ground, dice) = make();
        let mut p = plugin(mode);
        p.add_ground(&w.bodies, &w.colliders, ground).unwrap();
        let mut late = Vec::new();
        for k in 0..240 {
            alone.step();
            let seen = run(&mut p, &mut w, 1);
            if k >= 30 {
                late.extend(seen);
                for d in &dice {
                    let c = w.bodies[*d].colliders()[0];
                    assert_eq!(
                        w.colliders[c].active_hooks(),
                        ActiveHooks::empty(),
                        "{mode:?}"
                    );
                }
            }
        }
        assert!(
            late.is_empty(),
            "{mode:?}: no impact between dice at rest: {late:?}"
        );
        for (d, d0) in dice.iter().zip(&dice0) {
            let (y, y0) = (
                na(w.bodies[*d].translation()).y,
                na(alone.bodies[*d0].translation()).y,
            );
            assert!(
                abs_diff_eq!(y, y0, epsilon = 1e-4),
                "{mode:?}: at {y}, rapier alone {y0}"
            );
            assert!(w.bodies[*d].is_sleeping(), "{mode:?}: asleep");
        }
    }
}

/// A die spinning in place beside a die at rest, neither moving: its corner swings into the
/// other's face. The spin makes it a body that can meet another (its corners move at the
/// angular speed times its radius), so the impact is the model's, inside the step, and
/// conserves angular momentum.
#[test]
fn a_die_spinning_in_place_hits_the_one_beside_it() {
    let h = 0.05;
    for mode in [TimingMode::TimeOfImpact, TimingMode::Exact] {
        let mut w = world();
        let none = UnitQuaternion::identity();
        let zero = Vector3::zeros();
        let spin = Vector3::z() * 20.0;
        let (a, _) = body(&mut w, cube(h, 0.5, 0.2), zero, none, zero, spin);
        let (b, _) = body(
            &mut w,
            cube(h, 0.5, 0.2),
            Vector3::x() * 0.115,
            none,
            zero,
            zero,
        );
        let l0 = world_inertia(&w, a) * spin;
        let mut p = plugin(mode);
        let seen = run(&mut p, &mut w, 6);
        assert!(
            !seen.is_empty(),
            "{mode:?}: the corner's impact is the model's"
        );
        assert_eq!(seen[0].1.timing, ImpactTiming::InStep, "{mode:?}");
        // The corner (radius h sqrt 2) reaches the face at x = 0.065 when it has turned
        // 45 - acos(0.065 / (h sqrt 2)) degrees.
        let turn = std::f64::consts::FRAC_PI_4 - (0.065 / (h * 2f64.sqrt())).acos();
        assert!(
            abs_diff_eq!(seen[0].0, turn / 20.0, epsilon = 1e-6),
            "{mode:?}: at {}",
            seen[0].0
        );
        let mut l1 = Vector3::zeros();
        for hnd in [a, b] {
            let rb = &w.bodies[hnd];
            let (m, v, om) = (wide(rb.mass()), na(rb.linvel()), na(rb.angvel()));
            l1 += na(rb.center_of_mass()).cross(&(v * m)) + world_inertia(&w, hnd) * om;
        }
        let tol = if F64 { 1e-12 } else { 1e-5 };
        assert!(
            (l1 - l0).norm() <= tol * l0.norm(),
            "{mode:?}: L {l0} -> {l1}"
        );
    }
}

/// A die lying face on against another (no gravity), spinning at 20 rad/s: about the contact
/// normal its corners sweep along the face and none comes closer, so the pair is no impact
/// and stays rapier's resting contact, unhooked; about an axis across the normal the same
/// spin drives a corner into the face at once, an impact the plugin takes out of rapier's
/// solver (hooked) and resolves. The closing speed of a turning body counts the spin across
/// the normal only.
#[test]
fn a_die_spinning_about_the_contact_normal_does_not_close_on_the_face_it_touches() {
    let h = 0.05;
    let plugin_flags = ActiveHooks::FILTER_CONTACT_PAIRS | ActiveHooks::MODIFY_SOLVER_CONTACTS;
    // (hooked in the first step, pair impacts over three steps) for a spin about `axis`.
    let run_spin = |mode: TimingMode, axis: Vector3<f64>| {
        let mut w = world();
        let none = UnitQuaternion::identity();
        let zero = Vector3::zeros();
        // Touching to within a tenth of a millimetre: inside rapier's prediction distance,
        // so rapier holds the contact from the first step.
        let (_, ca) = body(&mut w, cube(h, 0.5, 0.2), zero, none, zero, axis * 20.0);
        let (_, cb) = body(
            &mut w,
            cube(h, 0.5, 0.2),
            Vector3::y() * (2.0 * h + 1e-4),
            none,
            zero,
            zero,
        );
        let mut p = plugin(mode);
        let mut hooked = false;
        let mut impacts = 0;
        for k in 0..3 {
            p.step(&mut w);
            if k == 0 {
                hooked = [ca, cb]
                    .iter()
                    .any(|c| w.colliders[*c].active_hooks().contains(plugin_flags));
            }
            impacts += p
                .events()
                .iter()
                .filter(|ev| ev.body2.is_some() && ev.kind == EventKind::Impact)
                .count();
        }
        (hooked, impacts)
    };
    for mode in [TimingMode::TimeOfImpact, TimingMode::Exact] {
        let (hooked, impacts) = run_spin(mode, Vector3::y());
        assert!(!hooked, "{mode:?}: a spin about the normal hooked the pair");
        assert_eq!(
            impacts, 0,
            "{mode:?}: a spin about the normal made an impact"
        );
        let (hooked, impacts) = run_spin(mode, Vector3::x());
        assert!(hooked, "{mode:?}: a spin across the normal is not planned");
        assert!(
            impacts > 0,
            "{mode:?}: a spin across the normal made no impact"
        );
    }
}

/// A die with a non-finite spin (the user's, which the plan reads as it is) falling beside a
/// ball onto the table, 5 mm apart side by side, both 1 cm above it at 2 m/s: the pair's
/// closing speed at the step's start, which counts what the die's turn adds, is NaN. In the
/// modes that resolve impacts in the step the pair is then judged by its members' bounces
/// off the table, which it meets in the step: both straight up, across the pair's level
/// normal, so the pair stays slower than the resting speed and is in no plan, as without
/// the spin: in these modes a NaN closing speed decides no pair by itself. (`Step` mode
/// resolves pairs at the step's start, before any bounce, and plans this pair `Resting`.)
/// What the plugin does with the die's own non-finite state is not this test's concern; the
/// ball's must stay finite.
#[test]
fn a_pair_with_a_non_finite_spin_is_judged_by_its_bounces_off_the_table() {
    let h = 0.05;
    for mode in [TimingMode::TimeOfImpact, TimingMode::Exact] {
        for turn in [0.0, f64::INFINITY] {
            let (mut w, table) = lane_world();
            let none = UnitQuaternion::identity();
            let down = Vector3::y() * -2.0;
            let above = h + 0.01;
            let spin = Vector3::new(0.0, 0.0, turn);
            body(
                &mut w,
                cube(h, 0.5, 0.3),
                Vector3::y() * above,
                none,
                down,
                spin,
            );
            let ball = ColliderBuilder::ball(real(h)).restitution(0.5);
            let at = Vector3::new(2.0 * h + 0.005, above, 0.0);
            let (ball, _) = body(&mut w, ball, at, none, down, Vector3::zeros());
            let mut p = plugin(mode);
            p.add_ground(&w.bodies, &w.colliders, table).unwrap();
            p.set_profiling(true);
            let seen = run(&mut p, &mut w, 1);
            let label = format!("{mode:?}, spin {turn} rad/s");
            let planned = p.profile().unwrap().counts.body_pairs;
            assert_eq!(planned, 0, "{label}: the pair is planned");
            assert!(seen.is_empty(), "{label}: {seen:?}");
            let of_ball =
                |d: &&Diagnostic| matches!(d, Diagnostic::NonFiniteState { body } if *body == ball);
            let ball_refused: Vec<_> = p.diagnostics().iter().filter(of_ball).collect();
            assert!(ball_refused.is_empty(), "{label}: {ball_refused:?}");
            let (v, om) = velocity(&w, ball);
            assert!(
                v.iter().chain(om.iter()).all(|x| x.is_finite()) && v.y > 0.0,
                "{label}: the ball left the table at {v}, {om}"
            );
        }
    }
}

/// A cube turning fast against the face of a cube it touches, in `Step` mode (the impulse at
/// the step's start, where the two touch): its face is flat on the other's to within the flat
/// tolerance, but its turn (about the axis across the normal) drives the face's one edge in
/// at 3 m/s while the other edge leaves at 1 m/s. The impact is at the midpoint of the edge
/// that approaches, its two corners, with `model::resolve_pair`'s impulse there: the corners
/// that leave are no part of a landing. Counted with them it would be the face's centre.
#[test]
fn a_face_turning_flat_onto_a_face_is_struck_at_the_corners_that_approach() {
    let (h, e, mu, speed, turn) = (0.05, 0.6, 0.3, 1.0, 40.0);
    // Turned about z so that the edge at -y leads, by 5e-6 m: well inside the flat tolerance
    // (1e-3 of the cube's 8.7 cm bounding radius).
    let tilt: f64 = 5e-5;
    let lead = h * tilt.cos() + h * tilt.sin();
    let gap = 1e-7;
    let mut w = world();
    let spin = Vector3::z() * turn;
    let (a, _) = body(
        &mut w,
        cube(h, e, mu),
        Vector3::zeros(),
        UnitQuaternion::from_axis_angle(&Vector3::z_axis(), tilt),
        Vector3::x() * speed,
        spin,
    );
    let centre_b = Vector3::x() * (lead + h + gap);
    let none = UnitQuaternion::identity();
    let (b, _) = body(
        &mut w,
        cube(h, e, mu),
        centre_b,
        none,
        Vector3::zeros(),
        Vector3::zeros(),
    );
    let (body_a, body_b) = (model_body(&w, a), model_body(&w, b));
    let mut p = plugin(TimingMode::Step);
    p.step(&mut w);
    let seen: Vec<ImpactEvent> = p
        .events()
        .iter()
        .filter(|ev| ev.body2.is_some() && ev.kind == EventKind::Impact)
        .copied()
        .collect();
    assert_eq!(seen.len(), 2, "one impact, an event each: {seen:?}");
    // The midpoint of the leading edge's two corners, in the middle of the gap.
    let corner = |z: f64| Vector3::new(lead, -h * tilt.cos() + h * tilt.sin(), z);
    let point = 0.5 * (corner(h) + corner(-h)) + Vector3::x() * gap / 2.0;
    let tol_point = if F64 { 1e-9 } else { 1e-6 };
    for ev in &seen {
        assert_eq!(ev.timing, ImpactTiming::StepStart);
        assert_eq!(
            ev.contact_points, 2,
            "the two corners that approach: {ev:?}"
        );
        assert!(
            (na(ev.point) - point).norm() <= tol_point,
            "at {}, expected {point}",
            na(ev.point)
        );
    }
    // The normal is either face's (parry takes one as the reference face, `f32` and `f64`
    // differ): both are a landing's normal within the flat tolerance. The model is asked on
    // the one reported.
    let ev_b = *seen.iter().find(|ev| ev.body == b).unwrap();
    let normal = na(ev_b.normal);
    let faces = [Vector3::x(), Vector3::new(tilt.cos(), tilt.sin(), 0.0)];
    let tol_normal = if F64 { 1e-12 } else { 1e-6 };
    assert!(
        faces.iter().any(|f| (normal - f).norm() <= tol_normal),
        "normal {normal}"
    );
    let contact = PairContact {
        normal,
        offset_a: point,
        offset_b: point - centre_b,
    };
    let expected = struck_at_rest(
        &body_a,
        Vector3::x() * speed,
        spin,
        &body_b,
        &contact,
        e,
        mu,
    );
    let scale = wide(w.bodies[a].mass()) * speed;
    assert!(
        (na(ev_b.impulse) - expected.impulse).norm() <= V_TOL * scale,
        "{} expected {}",
        na(ev_b.impulse),
        expected.impulse
    );
    // Struck off its centre, the cube hit turns.
    assert!(expected.b.angular.z.abs() > 1.0, "{}", expected.b.angular);
}
