//! Walton's tangential restitution and restitution curves in the plugin: a ball shot at the
//! ground and two balls meeting in flight against Walton's closed forms, a drop whose every
//! bounce takes the curve's `e` at its impact speed, which setting wins (ground, body,
//! configuration), and the events that report them.
//!
//! No gravity in the oblique shots: the state after the impact's step is the state right after
//! the impact, so the comparison measures the impact, not the flight.

mod plugin_support;

use approx::{abs_diff_eq, assert_abs_diff_eq};
use plugin_support::{F64, na, real, up, wide, world_with_gravity};
use rapier_impact::na::Vector3;
use rapier_impact::rapier::prelude::*;
use rapier_impact::{
    EventKind, GroundMaterial, ImpactConfig, ImpactEvent, ImpactPlugin, RestitutionCurve,
};

/// Tolerance on velocities after an impact, relative to the speed: rapier's `f32` storage,
/// or `f64` rounding.
const V_TOL: f64 = if F64 { 1e-12 } else { 1e-6 };

/// A ball of radius `r` and inertia `k m r^2` (m = 1 kg) at `at`, moving at `v` with spin `w`.
fn ball(
    world: &mut PhysicsWorld,
    at: Vector3<f64>,
    v: Vector3<f64>,
    w: Vector3<f64>,
    r: f64,
    k: f64,
) -> RigidBodyHandle {
    world
        .insert(
            RigidBodyBuilder::dynamic()
                .translation(Vector::new(real(at.x), real(at.y), real(at.z)))
                .linvel(Vector::new(real(v.x), real(v.y), real(v.z)))
                .angvel(Vector::new(real(w.x), real(w.y), real(w.z)))
                .allow_fast_rotation(true)
                .can_sleep(false),
            ColliderBuilder::ball(real(r)).mass_properties(MassProperties::new(
                Vector::ZERO,
                real(1.0),
                Vector::splat(real(k * r * r)),
            )),
        )
        .0
}

fn ground(world: &mut PhysicsWorld) -> ColliderHandle {
    world
        .insert(RigidBodyBuilder::fixed(), ColliderBuilder::halfspace(up()))
        .1
}

fn curve(points: &[(f64, f64)]) -> RestitutionCurve {
    RestitutionCurve::new(points.to_vec()).expect("valid curve")
}

/// Steps until the plugin reports an impact of `body`; returns it (the world is then at the
/// end of that step).
fn step_to_impact(
    world: &mut PhysicsWorld,
    p: &mut ImpactPlugin,
    body: RigidBodyHandle,
    steps: usize,
) -> ImpactEvent {
    for _ in 0..steps {
        p.step(world);
        if let Some(e) = p
            .events()
            .iter()
            .find(|e| e.body == body && e.kind == EventKind::Impact)
        {
            return *e;
        }
    }
    panic!("no impact in {steps} steps");
}

/// Walton's closed form for a sphere (m = 1 kg) on the ground `y = 0` meeting it at
/// `(vx, -vy)` with spin `wz`: `[vx', vy', wz']` and whether it sticks.
fn walton_ground(
    k: f64,
    r: f64,
    (e, mu, beta): (f64, f64, f64),
    vx: f64,
    vy: f64,
    wz: f64,
) -> ([f64; 3], bool) {
    let ut = vx + wz * r;
    let ktt = 1.0 + 1.0 / k;
    let pn = (1.0 + e) * vy;
    let stick = -(1.0 + beta) * ut / ktt;
    let (pt, sticks) = if stick.abs() <= mu * pn {
        (stick, true)
    } else {
        (-mu * pn * ut.signum(), false)
    };
    ([vx + pt, e * vy, wz + pt / (k * r)], sticks)
}

#[test]
fn a_ball_shot_at_the_ground_meets_walton_closed_form() {
    let (r, k) = (0.05, 0.4);
    let (e, mu) = (0.9, 0.15);
    let (mut worst, mut sticks, mut slips) = (0.0f64, 0, 0);
    for beta in [-1.0, -0.4, 0.0, 0.5, 1.0] {
        for deg in [10.0f64, 30.0, 55.0, 75.0] {
            for spin in [0.0, -60.0] {
                let mut w = world_with_gravity(0.0);
                let g = ground(&mut w);
                let a = deg.to_radians();
                let v = Vector3::new(3.0 * a.sin(), -3.0 * a.cos(), 0.0);
                let b = ball(
                    &mut w,
                    Vector3::new(0.0, 0.3, 0.0),
                    v,
                    Vector3::new(0.0, 0.0, spin),
                    r,
                    k,
                );
                let mut p = ImpactPlugin::new(ImpactConfig::default()).unwrap();
                let material = GroundMaterial::new(e, mu).with_tangential_restitution(beta);
                p.add_ground_with_material(&w.bodies, &w.colliders, g, material)
                    .unwrap();
                // The closed form on the rounded release state.
                let rb = &w.bodies[b];
                let (vx, vy, wz) = (
                    wide(rb.linvel().x),
                    -wide(rb.linvel().y),
                    wide(rb.angvel().z),
                );
                let (expected, stick) = walton_ground(k, r, (e, mu, beta), vx, vy, wz);
                let event = step_to_impact(&mut w, &mut p, b, 60);
                let rb = &w.bodies[b];
                let got = [
                    wide(rb.linvel().x),
                    wide(rb.linvel().y),
                    wide(rb.angvel().z) * r,
                ];
                let want = [expected[0], expected[1], expected[2] * r];
                let speed = vx.hypot(vy) + (wz * r).abs();
                let err = (0..3).map(|i| (got[i] - want[i]).abs()).fold(0.0, f64::max) / speed;
                worst = worst.max(err);
                assert!(
                    err <= V_TOL,
                    "beta {beta}, {deg} deg, spin {spin}: {got:?} vs {want:?} ({err:e})"
                );
                assert_eq!(
                    event.regime != rapier_impact::model::Regime::Slip,
                    stick,
                    "beta {beta}, {deg} deg"
                );
                assert_eq!((event.tangential_restitution, event.restitution), (beta, e));
                if stick {
                    sticks += 1;
                } else {
                    slips += 1;
                }
            }
        }
    }
    assert!(
        sticks >= 5 && slips >= 5,
        "{sticks} sticking, {slips} slipping"
    );
    println!("ball shot at the ground: worst error {worst:e} of the speed");
}

#[test]
fn two_balls_meet_walton_closed_form() {
    let (r, k, e, mu) = (0.05, 0.4, 0.95, 0.3);
    let mut worst = 0.0f64;
    for beta in [-0.5, 0.0, 0.6, 1.0] {
        for (offset, spin) in [(0.03, 0.0), (0.07, 0.0), (0.02, 40.0)] {
            let mut w = world_with_gravity(0.0);
            let zero = Vector3::zeros();
            let a = ball(
                &mut w,
                zero,
                Vector3::new(2.0, 0.0, 0.0),
                Vector3::new(0.0, 0.0, spin),
                r,
                k,
            );
            let b = ball(&mut w, Vector3::new(0.4, offset, 0.0), zero, zero, r, k);
            for h in [a, b] {
                let co = w.bodies[h].colliders()[0];
                w.colliders[co].set_restitution(real(e));
                w.colliders[co].set_friction(real(mu));
            }
            let mut p =
                ImpactPlugin::new(ImpactConfig::default().with_tangential_restitution(beta))
                    .unwrap();
            p.add_impact_body(&w.bodies, a).unwrap();
            p.add_impact_body(&w.bodies, b).unwrap();
            // The closed form on the rounded state: where the centres are 2r apart, the
            // normal along them, and Walton's impulse on the pair's collision matrix.
            let state = |w: &PhysicsWorld, h: RigidBodyHandle| {
                let rb = &w.bodies[h];
                (na(rb.translation()), na(rb.linvel()), na(rb.angvel()))
            };
            let ((xa, va, wa), (xb, vb, wb)) = (state(&w, a), state(&w, b));
            let (d0, dv) = (xb - xa, vb - va);
            let (qa, qb, qc) = (
                dv.norm_squared(),
                2.0 * d0.dot(&dv),
                d0.norm_squared() - 4.0 * r * r,
            );
            let tc = (-qb - (qb * qb - 4.0 * qa * qc).sqrt()) / (2.0 * qa);
            let n = (d0 + dv * tc) / (2.0 * r);
            let u = (va + wa.cross(&(n * r))) - (vb + wb.cross(&(-n * r)));
            let un = u.dot(&n);
            let ut = u - n * un;
            let (knn, ktt) = (2.0, 2.0 * (1.0 + 1.0 / k));
            let pn = (1.0 + e) * un / knn;
            let stick = ut * ((1.0 + beta) / ktt);
            let pt = if stick.norm() <= mu * pn {
                stick
            } else {
                ut * (mu * pn / ut.norm())
            };
            let p_b = n * pn + pt;
            let inertia = k * r * r;
            let want = [
                va - p_b,
                vb + p_b,
                (wa + (n * r).cross(&-p_b) / inertia) * r,
                (wb + (-n * r).cross(&p_b) / inertia) * r,
            ];
            step_to_impact(&mut w, &mut p, a, 60);
            let (_, va2, wa2) = state(&w, a);
            let (_, vb2, wb2) = state(&w, b);
            let got = [va2, vb2, wa2 * r, wb2 * r];
            let speed = 2.0 + spin.abs() * r;
            let err = (0..4)
                .map(|i| (got[i] - want[i]).norm())
                .fold(0.0, f64::max)
                / speed;
            worst = worst.max(err);
            assert!(
                err <= V_TOL,
                "beta {beta}, offset {offset}, spin {spin}: {got:?} vs {want:?} ({err:e})"
            );
            let events: Vec<_> = p
                .events()
                .iter()
                .filter(|e| e.kind == EventKind::Impact)
                .collect();
            assert!(
                events.iter().all(|e| e.tangential_restitution == beta),
                "{events:?}"
            );
        }
    }
    println!("two balls: worst error {worst:e} of the speed");
}

#[test]
fn each_bounce_takes_the_curve_at_its_impact_speed() {
    // No bounce below 0.5 m/s, then e falling from 0.9 to 0.6 as impacts get harder.
    let e_of = curve(&[(0.5, 0.0), (0.5, 0.9), (2.0, 0.85), (6.0, 0.6)]);
    let g = 9.81;
    let mut w = world_with_gravity(g);
    let gr = ground(&mut w);
    let r = 0.05;
    let b = ball(
        &mut w,
        Vector3::new(0.0, r + 1.5, 0.0),
        Vector3::zeros(),
        Vector3::zeros(),
        r,
        0.4,
    );
    let mut p = ImpactPlugin::new(ImpactConfig::default()).unwrap();
    p.add_ground(&w.bodies, &w.colliders, gr).unwrap();
    p.set_body_restitution_curve(b, Some(e_of.clone())).unwrap();
    let mut impacts = Vec::new();
    for _ in 0..600 {
        p.step(&mut w);
        impacts.extend(
            p.events()
                .iter()
                .filter(|e| e.kind == EventKind::Impact)
                .copied(),
        );
    }
    // The first impact speed from the drop height; each next one is e(v) v (the flight up and
    // back down is exact in `Exact` mode); below 0.5 m/s nothing bounces.
    let mut v = (2.0 * g * 1.5f64).sqrt();
    let mut bounces = 0;
    for (k, event) in impacts.iter().enumerate() {
        let speed = event.approach_speed;
        assert!(
            abs_diff_eq!(speed, v, epsilon = 1e-5 * v.max(1.0)),
            "impact {k}: {speed} m/s, closed form {v}"
        );
        let e = if event.settled { 0.0 } else { e_of.at(speed) };
        assert_eq!(event.restitution, e, "impact {k} at {speed} m/s");
        if e == 0.0 {
            break;
        }
        bounces += 1;
        v *= e;
    }
    assert!(bounces >= 8, "{bounces} bounces: {impacts:?}");
    // It ends at rest on the ground.
    let rb = &w.bodies[b];
    assert!(na(rb.linvel()).norm() < 1e-3);
    assert_abs_diff_eq!(wide(rb.translation().y), r, epsilon = 5e-3);
    println!("{bounces} bounces, each at the curve's e for its speed");
}

#[test]
fn the_ground_wins_then_the_body_then_the_configuration() {
    let config_curve = curve(&[(0.0, 0.3)]);
    let body_curve = curve(&[(0.0, 0.5)]);
    let ground_curve = curve(&[(0.0, 0.7)]);
    // (ground override, body's own) -> (beta0, e) used.
    let cases = [
        ((None, None), (0.9, 0.3)),
        ((None, Some((-0.5, body_curve.clone()))), (-0.5, 0.5)),
        (
            (
                Some((0.25, ground_curve.clone())),
                Some((-0.5, body_curve.clone())),
            ),
            (0.25, 0.7),
        ),
        ((Some((0.25, ground_curve.clone())), None), (0.25, 0.7)),
    ];
    for ((over, own), (beta, e)) in cases {
        let mut w = world_with_gravity(9.81);
        let gr = ground(&mut w);
        let v = Vector3::new(1.0, -2.0, 0.0);
        let b = ball(
            &mut w,
            Vector3::new(0.0, 0.2, 0.0),
            v,
            Vector3::zeros(),
            0.05,
            0.4,
        );
        let mut p = ImpactPlugin::new(
            ImpactConfig::default()
                .with_tangential_restitution(0.9)
                .with_restitution_curve(Some(config_curve.clone())),
        )
        .unwrap();
        match &over {
            Some((beta, c)) => {
                let m = GroundMaterial::new(0.1, 0.5)
                    .with_tangential_restitution(*beta)
                    .with_restitution_curve(c.clone());
                p.add_ground_with_material(&w.bodies, &w.colliders, gr, m.clone())
                    .unwrap();
                assert_eq!(p.ground_material(gr), Some(m));
            }
            None => p.add_ground(&w.bodies, &w.colliders, gr).unwrap(),
        }
        if let Some((beta, c)) = &own {
            p.set_body_tangential_restitution(b, Some(*beta)).unwrap();
            p.set_body_restitution_curve(b, Some(c.clone())).unwrap();
        }
        let event = step_to_impact(&mut w, &mut p, b, 60);
        assert_eq!(
            (event.tangential_restitution, event.restitution),
            (beta, e),
            "{over:?} {own:?}"
        );
    }
}

#[test]
fn a_constant_material_pays_nothing_and_changes_nothing() {
    // beta0 = 0 and no curve set explicitly at every level: the run is the default run, bit
    // for bit (the golden traces check the default run against its recording).
    let run = |explicit: bool| {
        let mut w = world_with_gravity(9.81);
        let gr = ground(&mut w);
        let b = ball(
            &mut w,
            Vector3::new(0.0, 0.5, 0.0),
            Vector3::new(1.0, 0.0, 0.0),
            Vector3::new(0.0, 0.0, 5.0),
            0.05,
            0.4,
        );
        let config = ImpactConfig::default()
            .with_tangential_restitution(0.0)
            .with_restitution_curve(None);
        let mut p = ImpactPlugin::new(if explicit {
            config
        } else {
            ImpactConfig::default()
        })
        .unwrap();
        let m = GroundMaterial::new(0.8, 0.4);
        let m = if explicit {
            m.with_tangential_restitution(0.0)
        } else {
            m
        };
        p.add_ground_with_material(&w.bodies, &w.colliders, gr, m)
            .unwrap();
        if explicit {
            p.set_body_tangential_restitution(b, Some(0.0)).unwrap();
        }
        let mut trace = Vec::new();
        for _ in 0..120 {
            p.step(&mut w);
            let rb = &w.bodies[b];
            trace.push((rb.translation(), rb.linvel(), rb.angvel()));
        }
        trace
    };
    assert_eq!(run(true), run(false));
}
