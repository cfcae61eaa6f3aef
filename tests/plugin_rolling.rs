//! Rolling resistance and spinning friction in the plugin: a ball rolling on a level ground
//! stops at the closed-form distance and sleeps; at rest on a slope gentler than `mu_r` it
//! stays (rapier alone rolls it down); the coefficients come from the ground, the ball or the
//! configuration, in that order, and bad values are refused.

mod plugin_support;

use approx::abs_diff_eq;
use plugin_support::{F64, G, MODES, na, real, wide};
use rapier_impact::na::Vector3;
use rapier_impact::rapier::prelude::*;
use rapier_impact::{
    ConfigError, EventKind, GroundMaterial, ImpactConfig, ImpactPlugin, RollingSettings,
    TimingMode, model::Regime,
};

const R: f64 = 0.05;

/// The goal on stopping distances, met in every mode: each continues a roll from its
/// `f64` end (measured: up to 3.9e-7 in `f32`, 9.7e-15 in `f64`).
const X_TOL: f64 = if F64 { 1e-12 } else { 1e-6 };

fn config(mode: TimingMode, mu_r: f64, mu_sp: f64) -> ImpactConfig {
    ImpactConfig::default()
        .with_timing(mode)
        .with_rolling_resistance(mu_r)
        .with_spinning_friction(mu_sp)
}

/// A world with a half-space ground tilted by `slope` degrees about z (downhill +x), and a
/// solid ball resting on it at the origin's contact point, rolling downhill at `v0`.
fn scene(slope: f64, v0: f64) -> (PhysicsWorld, ColliderHandle, RigidBodyHandle, Vector3<f64>) {
    let th = slope.to_radians();
    scene_moving(slope, Vector3::new(th.cos(), -th.sin(), 0.0) * v0)
}

/// [`scene`] with the ball rolling at `v` (along the ground).
fn scene_moving(
    slope: f64,
    v: Vector3<f64>,
) -> (PhysicsWorld, ColliderHandle, RigidBodyHandle, Vector3<f64>) {
    let mut w = PhysicsWorld {
        gravity: Vector::new(0.0, real(-G), 0.0),
        ..Default::default()
    };
    let th = slope.to_radians();
    let n = Vector3::new(th.sin(), th.cos(), 0.0);
    let down = Vector3::new(th.cos(), -th.sin(), 0.0);
    let (_, ground) = w.insert(
        RigidBodyBuilder::fixed(),
        ColliderBuilder::halfspace(rapier_impact::rapier::na::Unit::new_unchecked(
            Vector::new(real(n.x), real(n.y), 0.0).normalize(),
        ))
        .friction(0.5),
    );
    let at = n * R;
    let spin = n.cross(&v) / R;
    let (ball, _) = w.insert(
        RigidBodyBuilder::dynamic()
            .translation(Vector::new(real(at.x), real(at.y), 0.0))
            .linvel(Vector::new(real(v.x), real(v.y), real(v.z)))
            .angvel(Vector::new(real(spin.x), real(spin.y), real(spin.z))),
        ColliderBuilder::ball(real(R)).friction(0.5),
    );
    (w, ground, ball, down)
}

/// A ball's run to rest on a slope that holds it: where the closed form stopped it (the
/// first step that ends at rest: it writes zero velocities, rapier's contact never does) and
/// the plugin's events.
#[derive(Default)]
struct ToRest {
    stop: Option<Vector3<f64>>,
    holds: usize,
    others: usize,
}

impl ToRest {
    /// Steps `w` `steps` times, watching `ball`.
    fn run(
        p: &mut ImpactPlugin,
        w: &mut PhysicsWorld,
        ball: RigidBodyHandle,
        steps: usize,
    ) -> Self {
        let mut run = Self::default();
        for _ in 0..steps {
            p.step(w);
            let rb = &w.bodies[ball];
            if run.stop.is_none() && rb.linvel() == Vector::ZERO && rb.angvel() == Vector::ZERO {
                run.stop = Some(na(rb.center_of_mass()));
            }
            for e in p.events() {
                if e.kind == EventKind::Hold {
                    run.holds += 1;
                } else {
                    run.others += 1;
                }
            }
        }
        run
    }

    /// Where the closed form stopped the ball.
    fn stop(&self, at: &str) -> Vector3<f64> {
        self.stop.unwrap_or_else(|| panic!("{at}: never stopped"))
    }

    /// After the stop the ball is rapier's, held by its resting contact with the normal force
    /// moved downhill (`Rolling::holding_tilt`), and asleep. Put back where it stopped after
    /// its first step there (one `Hold` event), it then sinks to rapier's resting depth
    /// (7e-5 m), and moves along the slope at most as a vertical sink would, the depth times
    /// `tan(theta)` (measured: up to that, 3.6e-6 m on 3 degrees at 240 Hz; 2.6e-8 m at 30 Hz
    /// in `Exact`), within the rounding of the positions.
    fn assert_held(&self, at: &str, w: &PhysicsWorld, ball: RigidBodyHandle, n: &Vector3<f64>) {
        let rb = &w.bodies[ball];
        assert!(rb.is_sleeping(), "{at}: asleep");
        assert_eq!(na(rb.linvel()), Vector3::zeros(), "{at}");
        assert_eq!(self.holds, 1, "{at}: put back once");
        let shift = na(rb.center_of_mass()) - self.stop(at);
        let sink = -shift.dot(n);
        let creep = (shift + n * sink).norm();
        let tan = n.y.acos().tan();
        let rounding = 2.0 * self.stop(at).norm() * wide(Real::EPSILON);
        // rapier's resting depth is below 1e-4 m, and sinking is all it does along `n`.
        assert!((-rounding..1e-4).contains(&sink), "{at}: sank {sink}");
        assert!(
            creep <= tan * sink + rounding,
            "{at}: crept {creep} sinking {sink}"
        );
    }
}

#[test]
fn a_rolling_ball_stops_at_the_closed_form_distance_and_sleeps() {
    let (v0, mu_r) = (1.2, 0.03);
    let k = 0.4;
    let distance = v0 * v0 * (1.0 + k) / (2.0 * mu_r * G);
    let t_stop = v0 * (1.0 + k) / (mu_r * G);
    for hz in [30.0, 60.0, 240.0] {
        for mode in [
            TimingMode::Step,
            TimingMode::TimeOfImpact,
            TimingMode::Exact,
        ] {
            let (mut w, ground, ball, _) = scene(0.0, v0);
            w.integration_parameters.dt = real(1.0 / hz);
            let mut p = ImpactPlugin::new(config(mode, mu_r, 0.0)).unwrap();
            p.add_ground(&w.bodies, &w.colliders, ground).unwrap();
            // Stopped, then rapier's resting contact puts it to sleep (2 s of rest at most).
            let steps = ((t_stop + 3.0) * hz) as usize;
            for _ in 0..steps {
                p.step(&mut w);
            }
            let rb = &w.bodies[ball];
            let x = na(rb.center_of_mass()).x;
            // Every mode continues a roll from its `f64` end (`Origin::Roll`), steered or not:
            // at 30 Hz the first steps turn the ball faster than rapier's spin cap and are
            // written, not steered. Measured in `f32`: within 7.9e-8 of the distance in every
            // mode and rate.
            let tol = X_TOL;
            assert!(
                abs_diff_eq!(x, distance, epsilon = tol * distance),
                "{mode:?} at {hz} Hz: stopped at {x}, closed form {distance}"
            );
            assert!(rb.is_sleeping(), "{mode:?} at {hz} Hz: asleep once stopped");
            assert_eq!(na(rb.linvel()), Vector3::zeros());
        }
    }
}

/// On a table, near an edge: a ball rolling without slip keeps to the straight line it
/// heads along, so its closed form needs the table only under that line. Rolling along
/// the edge with its contact 0.3 mm inside it, or stopping 0.3 mm short of the edge at
/// 30 Hz (0.1 mm at 60 Hz), it stops at the closed-form distance and sleeps on the table
/// (the curvature a sliding ball's path may have, about 0.7 mm at 30 Hz, was asked of it).
#[test]
fn near_a_tables_edge_a_rolling_ball_stops_at_the_closed_form_distance() {
    let (v0, mu_r, k) = (1.2, 0.03, 0.4);
    let distance = v0 * v0 * (1.0 + k) / (2.0 * mu_r * G);
    let t_stop = v0 * (1.0 + k) / (mu_r * G);
    for (hz, short) in [(30.0, 3e-4), (60.0, 1e-4)] {
        // (the table's half extents and centre, the ball's start)
        let along = ([20.0, 0.5, 0.5], [0.0, -0.5, 0.0], [0.0, R, 0.5 - 3e-4]);
        let edge = distance + short;
        let across = (
            [0.5 * edge + 1.0, 0.5, 2.0],
            [0.5 * edge - 1.0, -0.5, 0.0],
            [0.0, R, 0.0],
        );
        for (half, centre, start) in [along, across] {
            let mut w = PhysicsWorld::default();
            w.integration_parameters.dt = real(1.0 / hz);
            let table = ColliderBuilder::cuboid(real(half[0]), real(half[1]), real(half[2]))
                .translation(Vector::new(
                    real(centre[0]),
                    real(centre[1]),
                    real(centre[2]),
                ))
                .friction(0.5);
            let (_, ground) = w.insert(RigidBodyBuilder::fixed(), table);
            let spin = -v0 / R;
            let (ball, _) = w.insert(
                RigidBodyBuilder::dynamic()
                    .translation(Vector::new(real(start[0]), real(start[1]), real(start[2])))
                    .linvel(Vector::new(real(v0), 0.0, 0.0))
                    .angvel(Vector::new(0.0, 0.0, real(spin))),
                ColliderBuilder::ball(real(R)).friction(0.5),
            );
            let mut p = ImpactPlugin::new(config(TimingMode::Exact, mu_r, 0.0)).unwrap();
            p.add_ground(&w.bodies, &w.colliders, ground).unwrap();
            for _ in 0..((t_stop + 3.0) * hz) as usize {
                p.step(&mut w);
            }
            let rb = &w.bodies[ball];
            let x = na(rb.center_of_mass()).x;
            assert!(
                abs_diff_eq!(x, distance, epsilon = X_TOL * distance),
                "at {hz} Hz, table {half:?}: stopped at {x}, closed form {distance}"
            );
            assert!(rb.is_sleeping(), "at {hz} Hz, table {half:?}: asleep");
        }
    }
}

#[test]
fn on_a_slope_gentler_than_mu_r_a_ball_at_rest_stays_and_sleeps() {
    let mu_r: f64 = 0.04;
    let slope = (0.5 * mu_r).atan().to_degrees();
    for hz in [30.0, 60.0, 240.0] {
        for mode in [
            None,
            Some(TimingMode::Step),
            Some(TimingMode::TimeOfImpact),
            Some(TimingMode::Exact),
        ] {
            let (mut w, ground, ball, down) = scene(slope, 0.0);
            w.integration_parameters.dt = real(1.0 / hz);
            let mut p =
                ImpactPlugin::new(config(mode.unwrap_or(TimingMode::Exact), mu_r, 0.0)).unwrap();
            p.add_ground(&w.bodies, &w.colliders, ground).unwrap();
            let start = na(w.bodies[ball].center_of_mass());
            let steps = (2.0 * hz) as usize;
            if mode.is_some() {
                // Set at rest, it is at once rapier's, held and put to sleep.
                let run = ToRest {
                    stop: Some(start),
                    ..ToRest::run(&mut p, &mut w, ball, steps)
                };
                let at = format!("{mode:?} at {hz} Hz");
                run.assert_held(
                    &at,
                    &w,
                    ball,
                    &Vector3::new(slope.to_radians().sin(), slope.to_radians().cos(), 0.0),
                );
                assert_eq!(run.others, 0, "{at}");
            } else {
                for _ in 0..steps {
                    w.step();
                }
                let moved = (na(w.bodies[ball].center_of_mass()) - start).dot(&down);
                // rapier alone has no rolling resistance: it rolls down.
                assert!(moved > 1e-3, "at {hz} Hz: rapier alone rolled {moved}");
            }
        }
    }
}

/// The ugly case of the hold: a ball held asleep on a slope and then set rolling downhill
/// (woken by the user) leaves the hold, rolls to the closed-form stop from where it lay, and is
/// held and asleep again.
#[test]
fn a_held_ball_set_rolling_again_stops_where_the_closed_form_says_and_is_held_again() {
    let (mu_r, slope, v1) = (0.08f64, 3.0f64, 0.6);
    let th = slope.to_radians();
    let n = Vector3::new(th.sin(), th.cos(), 0.0);
    let a = G * (mu_r * th.cos() - th.sin()) / (1.0 + 0.4);
    for hz in [30.0, 240.0] {
        for mode in MODES {
            let (mut w, ground, ball, down) = scene(slope, 0.0);
            w.integration_parameters.dt = real(1.0 / hz);
            let mut p = ImpactPlugin::new(config(mode, mu_r, 0.0)).unwrap();
            p.add_ground(&w.bodies, &w.colliders, ground).unwrap();
            let at = format!("{mode:?} at {hz} Hz");
            ToRest::run(&mut p, &mut w, ball, hz as usize);
            assert!(w.bodies[ball].is_sleeping(), "{at}: held and asleep first");
            let from = na(w.bodies[ball].center_of_mass());
            let v = down * v1;
            let spin = n.cross(&v) / R;
            let rb = &mut w.bodies[ball];
            rb.set_linvel(Vector::new(real(v.x), real(v.y), 0.0), true);
            rb.set_angvel(Vector::new(0.0, 0.0, real(spin.z)), true);
            let t_stop = v1 / a;
            let run = ToRest::run(&mut p, &mut w, ball, ((t_stop + 1.5) * hz) as usize);
            let travelled = (run.stop(&at) - from).dot(&down);
            let expected = v1 * v1 / (2.0 * a);
            let tol = X_TOL;
            assert!(
                abs_diff_eq!(travelled, expected, epsilon = tol * expected),
                "{at}: {travelled} vs {expected}"
            );
            run.assert_held(&at, &w, ball, &n);
            assert_eq!(run.others, 0, "{at}");
        }
    }
}

#[test]
fn the_ground_overrides_the_ball_which_overrides_the_configuration() {
    let v0 = 1.0;
    let stop = |mu_r: f64| v0 * v0 * 1.4 / (2.0 * mu_r * G);
    let run = |ground_mu_r: Option<f64>, body_mu_r: Option<f64>| {
        let (mut w, ground, ball, _) = scene(0.0, v0);
        let mut p = ImpactPlugin::new(config(TimingMode::Exact, 0.05, 0.0)).unwrap();
        let mut material = GroundMaterial::new(0.0, 0.5);
        material.rolling_resistance = ground_mu_r;
        p.add_ground_with_material(&w.bodies, &w.colliders, ground, material)
            .unwrap();
        p.set_body_rolling(ball, body_mu_r.map(|m| RollingSettings::new(m, 0.0)))
            .unwrap();
        for _ in 0..300 {
            p.step(&mut w);
        }
        wide(w.bodies[ball].center_of_mass().x)
    };
    for (ground, body, expected) in [
        (None, None, 0.05),
        (None, Some(0.1), 0.1),
        (Some(0.2), Some(0.1), 0.2),
    ] {
        let x = run(ground, body);
        assert!(
            abs_diff_eq!(x, stop(expected), epsilon = X_TOL * stop(expected)),
            "{ground:?} {body:?}: {x}"
        );
    }
}

#[test]
fn bad_rolling_coefficients_are_refused() {
    assert_eq!(
        ImpactPlugin::new(config(TimingMode::Exact, -0.1, 0.0)).err(),
        Some(ConfigError::InvalidConfig {
            field: "rolling_resistance",
            value: -0.1
        })
    );
    assert!(matches!(
        ImpactPlugin::new(config(TimingMode::Exact, 0.0, f64::NAN)).err(),
        Some(ConfigError::InvalidConfig {
            field: "spinning_friction",
            ..
        })
    ));
    let (w, ground, ball, _) = scene(0.0, 0.0);
    let mut p = ImpactPlugin::new(ImpactConfig::default()).unwrap();
    let material = GroundMaterial::new(0.5, 0.5).with_spinning_friction(-1.0);
    assert!(
        p.add_ground_with_material(&w.bodies, &w.colliders, ground, material)
            .is_err()
    );
    assert!(
        p.set_body_rolling(ball, Some(RollingSettings::new(f64::INFINITY, 0.0)))
            .is_err()
    );
}

/// Up a 3-degree slope at 1.5 m/s with `mu_r = 0.08` (> tan 3 deg): the ball slows at
/// `g (sin + mu_r cos)/(1 + k)`, stops at the closed-form height and stays; down the same
/// slope it slows at `g (mu_r cos - sin)/(1 + k)` to its stop.
#[test]
fn up_and_down_a_slope_it_stops_where_the_closed_form_says() {
    let (mu_r, slope, v0) = (0.08f64, 3.0f64, 1.5);
    let th = slope.to_radians();
    let k = 0.4;
    for (uphill, a) in [
        (true, G * (th.sin() + mu_r * th.cos()) / (1.0 + k)),
        (false, G * (mu_r * th.cos() - th.sin()) / (1.0 + k)),
    ] {
        for hz in [30.0, 60.0, 240.0] {
            for mode in MODES {
                let (mut w, ground, ball, down) = scene(slope, if uphill { -v0 } else { v0 });
                w.integration_parameters.dt = real(1.0 / hz);
                let mut p = ImpactPlugin::new(config(mode, mu_r, 0.0)).unwrap();
                p.add_ground(&w.bodies, &w.colliders, ground).unwrap();
                let start = na(w.bodies[ball].center_of_mass());
                let t_stop = v0 / a;
                // Stopped, then held by rapier's contact, which sleeps it.
                let run = ToRest::run(&mut p, &mut w, ball, ((t_stop + 2.0) * hz) as usize);
                let at = format!("{mode:?} at {hz} Hz, uphill {uphill}");
                let travelled = (run.stop(&at) - start).dot(&down).abs();
                let expected = v0 * v0 / (2.0 * a);
                // Every mode continues a roll from its `f64` end (measured in `f32`: 2.9e-8;
                // continued from rapier's `f32` state instead, down the slope at 240 Hz, 1 865
                // steps, 2.2e-5).
                let tol = X_TOL;
                assert!(
                    abs_diff_eq!(travelled, expected, epsilon = tol * expected),
                    "{at}: {travelled} vs {expected}"
                );
                run.assert_held(&at, &w, ball, &Vector3::new(th.sin(), th.cos(), 0.0));
            }
        }
    }
}

/// Spun about the normal at 30 rad/s while rolling, with spinning friction 0.05: the spin
/// decays at `5 mu_sp g / (2 R)` to zero at its closed-form time, and the rolling is
/// untouched by it.
#[test]
fn the_spin_about_the_normal_decays_at_the_closed_form_rate() {
    let (mu_sp, w0, v0) = (0.05, 30.0, 0.5);
    let rate = 5.0 * mu_sp * G / (2.0 * R);
    let t0 = w0 / rate;
    for hz in [30.0, 60.0, 240.0] {
        for mode in MODES {
            let (mut w, ground, ball, _) = scene(0.0, v0);
            w.integration_parameters.dt = real(1.0 / hz);
            let spin = w.bodies[ball].angvel() + Vector::new(0.0, real(w0), 0.0);
            w.bodies[ball].set_angvel(spin, true);
            let mut p = ImpactPlugin::new(config(mode, 0.0, mu_sp)).unwrap();
            p.add_ground(&w.bodies, &w.colliders, ground).unwrap();
            let half = (0.5 * t0 * hz).round() as usize;
            for _ in 0..half {
                p.step(&mut w);
            }
            let t = half as f64 / hz;
            let wy = wide(w.bodies[ball].angvel().y);
            let tol = X_TOL;
            assert!(
                abs_diff_eq!(wy, w0 - rate * t, epsilon = tol * w0),
                "{mode:?} at {hz} Hz: {wy} at {t} s"
            );
            // Rolling on at v0, no resistance.
            assert!(
                abs_diff_eq!(wide(w.bodies[ball].linvel().x), v0, epsilon = tol * v0),
                "{mode:?} at {hz} Hz: rolls on at v0"
            );
            for _ in 0..(t0 * hz) as usize {
                p.step(&mut w);
            }
            assert_eq!(
                wide(w.bodies[ball].angvel().y),
                0.0,
                "{mode:?} at {hz} Hz: stopped spinning"
            );
        }
    }
}

/// Rolling at 0.8 m/s square to the fall line of a 5-degree slope with `mu_r = 0.12`
/// (> tan 5 deg): the ball curves down the slope and stops where the pursuit curve's capture
/// says, `v0^2 A / (4 (B^2 - A^2))` down the slope and `2 v0^2 B / (4 B^2 - A^2)` across,
/// `A = g sin / (1 + k)`, `B = mu_r g cos / (1 + k)`. Rapier alone would roll it on down.
#[test]
fn rolling_across_a_slope_it_curves_down_and_stops_where_the_pursuit_curve_says() {
    let (mu_r, slope, v0, k) = (0.12f64, 5.0f64, 0.8, 0.4);
    let th = slope.to_radians();
    let (a, b) = (G * th.sin() / (1.0 + k), mu_r * G * th.cos() / (1.0 + k));
    let along = v0 * v0 * a / (4.0 * (b * b - a * a));
    let across = 2.0 * v0 * v0 * b / (4.0 * b * b - a * a);
    let stop = v0 * b / (b * b - a * a);
    // `Step` and `TimeOfImpact` move the ball in closed form from rapier's stored state each
    // step, `Exact` from its own `f64` state (measured in `f32` at 30 to 240 Hz: up to 8.9e-7
    // and 1.1e-8; in `f64` 1.3e-15).
    for hz in [30.0, 60.0, 240.0] {
        for mode in MODES {
            let (mut w, ground, ball, down) = scene_moving(slope, Vector3::z() * v0);
            w.integration_parameters.dt = real(1.0 / hz);
            let mut p = ImpactPlugin::new(config(mode, mu_r, 0.0)).unwrap();
            p.add_ground(&w.bodies, &w.colliders, ground).unwrap();
            let start = na(w.bodies[ball].center_of_mass());
            let run = ToRest::run(&mut p, &mut w, ball, ((stop + 1.0) * hz) as usize);
            let at = format!("{mode:?} at {hz} Hz");
            let moved = run.stop(&at) - start;
            let tol = X_TOL;
            assert!(
                abs_diff_eq!(moved.dot(&down), along, epsilon = tol * along),
                "{mode:?} at {hz} Hz: down {} vs {along}",
                moved.dot(&down)
            );
            assert!(
                abs_diff_eq!(moved.z, across, epsilon = tol * across),
                "{mode:?} at {hz} Hz: across {} vs {across}",
                moved.z
            );
            run.assert_held(&at, &w, ball, &Vector3::new(th.sin(), th.cos(), 0.0));
        }
    }
}

/// Two cuboids side by side, their tops level and flush (a seam at x = `seam`), and a ball
/// rolling across the seam at `v0`: `mu_r` stops it.
fn two_cuboids(seam: f64, v0: f64) -> (PhysicsWorld, [ColliderHandle; 2], RigidBodyHandle) {
    let mut w = PhysicsWorld {
        gravity: Vector::new(0.0, real(-G), 0.0),
        ..Default::default()
    };
    let mut grounds = [ColliderHandle::invalid(); 2];
    for (i, centre) in [seam - 5.0, seam + 5.0].into_iter().enumerate() {
        grounds[i] = w
            .insert(
                RigidBodyBuilder::fixed(),
                ColliderBuilder::cuboid(5.0, 0.5, 2.0)
                    .translation(Vector::new(real(centre), -0.5, 0.0))
                    .friction(0.5),
            )
            .1;
    }
    let (ball, _) = w.insert(
        RigidBodyBuilder::dynamic()
            .translation(Vector::new(0.0, real(R), 0.0))
            .linvel(Vector::new(real(v0), 0.0, 0.0))
            .angvel(Vector::new(0.0, 0.0, real(-v0 / R))),
        ColliderBuilder::ball(real(R)).friction(0.5),
    );
    (w, grounds, ball)
}

/// Rolling across the flush seam between two floor tiles at 1.2 m/s with `mu_r = 0.03`: the
/// ball stops where it would on one plane, `v0^2 (1 + k) / (2 mu_r g)`, without a hop, in
/// every mode and at 30, 60 and 240 Hz. (Before the plugin took the seam as one plane, rapier's
/// contact with the second tile's edge threw the ball up 1.2 cm in `Step` mode, 34 % short,
/// and rolled it on without resistance near the seam in the others, 5 % long.)
#[test]
fn across_a_seam_between_two_tiles_it_stops_as_on_one_plane() {
    let (v0, mu_r, k) = (1.2, 0.03, 0.4);
    let distance = v0 * v0 * (1.0 + k) / (2.0 * mu_r * G);
    let t_stop = v0 * (1.0 + k) / (mu_r * G);
    for hz in [30.0, 60.0, 240.0] {
        for mode in MODES {
            let (mut w, grounds, ball) = two_cuboids(0.7, v0);
            w.integration_parameters.dt = real(1.0 / hz);
            let mut p = ImpactPlugin::new(config(mode, mu_r, 0.0)).unwrap();
            for g in grounds {
                p.add_ground(&w.bodies, &w.colliders, g).unwrap();
            }
            let mut highest: f64 = 0.0;
            for _ in 0..((t_stop + 3.0) * hz) as usize {
                p.step(&mut w);
                highest = highest.max(wide(w.bodies[ball].translation().y) - R);
            }
            let x = na(w.bodies[ball].center_of_mass()).x;
            // As on one plane (`a_rolling_ball_stops_at_the_closed_form_distance_and_sleeps`):
            // measured in `f32`, 7.9e-8 in every mode.
            let tol = X_TOL;
            assert!(
                abs_diff_eq!(x, distance, epsilon = tol * distance),
                "{mode:?} at {hz} Hz: stopped at {x}, closed form {distance}"
            );
            assert!(highest <= 1e-6, "{mode:?} at {hz} Hz: hopped {highest} m");
            assert!(w.bodies[ball].is_sleeping(), "{mode:?} at {hz} Hz: asleep");
        }
    }
}

/// A world with a slope of `slope` degrees (a cuboid whose top face falls towards +x and
/// ends at the origin) and level ground beyond it (a cuboid's top face at y = 0, from the
/// origin on), both with e = 0, and a solid ball rolling down the slope at `v0`, `l` up it
/// from the crease.
fn slope_into_level(
    slope: f64,
    l: f64,
    v0: f64,
) -> (PhysicsWorld, [ColliderHandle; 2], RigidBodyHandle) {
    let th = slope.to_radians();
    let mut w = PhysicsWorld {
        gravity: Vector::new(0.0, real(-G), 0.0),
        ..Default::default()
    };
    let (hx, hy) = (2.0, 0.5);
    let rot = rapier_impact::na::UnitQuaternion::from_axis_angle(&Vector3::z_axis(), -th);
    let centre = rot * Vector3::new(-hx, -hy, 0.0);
    let (_, slope_ground) = w.insert(
        RigidBodyBuilder::fixed(),
        ColliderBuilder::cuboid(real(hx), real(hy), 2.0)
            .position(Pose::from_parts(
                Vector::new(real(centre.x), real(centre.y), 0.0),
                Rotation::from_rotation_z(real(-th)),
            ))
            .friction(0.5)
            .restitution(0.0),
    );
    let (_, level) = w.insert(
        RigidBodyBuilder::fixed(),
        ColliderBuilder::cuboid(5.0, 0.5, 2.0)
            .translation(Vector::new(5.0, -0.5, 0.0))
            .friction(0.5)
            .restitution(0.0),
    );
    let n = Vector3::new(th.sin(), th.cos(), 0.0);
    let down = Vector3::new(th.cos(), -th.sin(), 0.0);
    let at = -down * l + n * R;
    let v = down * v0;
    let spin = n.cross(&v) / R;
    let (ball, _) = w.insert(
        RigidBodyBuilder::dynamic()
            .translation(Vector::new(real(at.x), real(at.y), 0.0))
            .linvel(Vector::new(real(v.x), real(v.y), 0.0))
            .angvel(Vector::new(0.0, 0.0, real(spin.z))),
        ColliderBuilder::ball(real(R))
            .friction(0.5)
            .restitution(0.0),
    );
    (w, [slope_ground, level], ball)
}

/// Rolling down a 5 degree slope onto the level ground at its foot (e = 0): the touch with
/// the level face at the crease is found inside the step, the impact there sticks at the
/// closed-form speed `v_c sin(theta)`, and the ball rolls on to the closed-form stop, in every
/// mode and at 30, 60 and 240 Hz. (Before, the slope's edge ended the closed form a step
/// early: at 60 Hz `Step` mode met the level cuboid's edge at the step's start and stopped
/// 4.7 % short with a 0.7 mm hop, the others met the face at the step's end 1.4 mm deep
/// and stopped 0.6 % short.)
#[test]
fn down_a_slope_onto_level_ground_it_meets_the_crease_and_stops_where_the_closed_form_says() {
    let (slope, l, v0, mu_r, k) = (5.0f64, 0.5, 0.3, 0.01, 0.4);
    let th = slope.to_radians();
    // Rolling down (`a_ball_rolling_down_a_slope_...`: a = g (sin - mu_r cos) / (1 + k)) the
    // length l - R tan(theta/2) its contact point has to the crease, where it touches the
    // level face at v_c sin(theta). The impact (e = 0, sticking: angular momentum about the
    // contact point is kept) leaves it rolling at v_c (cos(theta) + k) / (1 + k); from the
    // crease's centre position R tan(theta/2), it rolls v1^2 (1 + k) / (2 mu_r g) on.
    let a = G * (th.sin() - mu_r * th.cos()) / (1.0 + k);
    let s = l - R * (th / 2.0).tan();
    let vc = (v0 * v0 + 2.0 * a * s).sqrt();
    let t_crease = (vc - v0) / a;
    let v1 = vc * (th.cos() + k) / (1.0 + k);
    let x_end = R * (th / 2.0).tan() + v1 * v1 * (1.0 + k) / (2.0 * mu_r * G);
    let t_stop = t_crease + v1 * (1.0 + k) / (mu_r * G);
    for hz in [30.0, 60.0, 240.0] {
        for mode in MODES {
            let (mut w, grounds, ball) = slope_into_level(slope, l, v0);
            w.integration_parameters.dt = real(1.0 / hz);
            let dt = wide(w.integration_parameters.dt);
            let mut p = ImpactPlugin::new(config(mode, mu_r, 0.0)).unwrap();
            for g in grounds {
                p.add_ground(&w.bodies, &w.colliders, g).unwrap();
            }
            let mut impacts = Vec::new();
            let mut highest: f64 = 0.0;
            for i in 0..((t_stop + 3.0) * hz) as usize {
                let had_impact = !impacts.is_empty();
                p.step(&mut w);
                impacts.extend(
                    p.events()
                        .iter()
                        .filter(|e| e.kind == EventKind::Impact)
                        .map(|e| (i as f64 * dt + e.time, *e)),
                );
                if had_impact {
                    highest = highest.max(na(w.bodies[ball].center_of_mass()).y - R);
                }
            }
            let x = na(w.bodies[ball].center_of_mass()).x;
            // Measured in `f32`, every mode alike: stopping point 3.9e-7, the impact's time
            // 1.5e-7, its speed 1.1e-7. In `f64`: all below 1e-12.
            let tol = X_TOL;
            let at = format!("{mode:?} at {hz} Hz");
            assert!(
                abs_diff_eq!(x, x_end, epsilon = tol * x_end),
                "{at}: stopped at {x}, closed form {x_end}"
            );
            let [(t, impact)] = impacts.as_slice() else {
                panic!("{at}: one impact, at the crease: {impacts:?}");
            };
            assert_eq!(
                impact.ground, grounds[1],
                "{at}: the impact is with the level ground"
            );
            assert!(
                abs_diff_eq!(*t, t_crease, epsilon = tol * t_crease),
                "{at}: the impact at {t} s, closed form {t_crease} s"
            );
            let approach = vc * th.sin();
            assert!(
                abs_diff_eq!(impact.approach_speed, approach, epsilon = tol * approach),
                "{at}: approach {} m/s, closed form {approach}",
                impact.approach_speed
            );
            assert_eq!(impact.regime, Regime::Stick, "{at}: sticks at the crease");
            assert!(highest <= 1e-6, "{at}: hopped {highest} m after the crease");
            assert!(w.bodies[ball].is_sleeping(), "{at}: asleep");
        }
    }
}

/// Rolling into a wall (a cuboid ground, e = 0.5): the impact with the wall is the model's,
/// at the time and speed rolling with resistance gives (`x = v0 t - a t^2 / 2`,
/// `a = mu_r g / (1 + k)`); its friction (the spin drags the contact point down the wall)
/// throws the ball up, and it flies as a ball thrown up: it lands `2 v_y / g` later at the
/// speed `v_y` it left with, an impact with the floor. In `Exact` mode (the others fly it
/// with rapier's integrator between steps). (Before, the wall was met only at the step's
/// end, 1.4 mm deep in the floor; and after the plugin found the wall in the step, the
/// resting hysteresis took the ball, 3 mm up, for resting and put it back on the floor.)
#[test]
fn into_a_wall_it_bounces_off_by_the_model_and_flies_as_a_ball_thrown_up() {
    let (v0, mu_r, k, gap) = (1.0, 0.01, 0.4, 0.95);
    let a = mu_r * G / (1.0 + k);
    let t_wall = (v0 - (v0 * v0 - 2.0 * a * gap).sqrt()) / a;
    let approach = v0 - a * t_wall;
    for hz in [30.0, 60.0, 240.0] {
        let mut w = PhysicsWorld {
            gravity: Vector::new(0.0, real(-G), 0.0),
            ..Default::default()
        };
        w.integration_parameters.dt = real(1.0 / hz);
        let (_, floor) = w.insert(
            RigidBodyBuilder::fixed(),
            ColliderBuilder::halfspace(rapier_impact::rapier::na::Unit::new_unchecked(Vector::Y))
                .friction(0.5)
                .restitution(0.5),
        );
        let (_, wall) = w.insert(
            RigidBodyBuilder::fixed(),
            ColliderBuilder::cuboid(0.5, 1.0, 1.0)
                .translation(Vector::new(real(gap + R + 0.5), 1.0, 0.0))
                .friction(0.5)
                .restitution(0.5),
        );
        let (ball, _) = w.insert(
            RigidBodyBuilder::dynamic()
                .translation(Vector::new(0.0, real(R), 0.0))
                .linvel(Vector::new(real(v0), 0.0, 0.0))
                .angvel(Vector::new(0.0, 0.0, real(-v0 / R))),
            ColliderBuilder::ball(real(R))
                .friction(0.5)
                .restitution(0.5),
        );
        let mass = wide(w.bodies[ball].mass());
        let mut p = ImpactPlugin::new(config(TimingMode::Exact, mu_r, 0.0)).unwrap();
        p.add_ground(&w.bodies, &w.colliders, floor).unwrap();
        p.add_ground(&w.bodies, &w.colliders, wall).unwrap();
        let dt = wide(w.integration_parameters.dt);
        let mut impacts = Vec::new();
        let mut highest: f64 = 0.0;
        for i in 0..(2.0 * hz) as usize {
            p.step(&mut w);
            impacts.extend(p.events().iter().map(|e| (i as f64 * dt + e.time, *e)));
            highest = highest.max(na(w.bodies[ball].center_of_mass()).y - R);
            if impacts.len() >= 2 {
                break;
            }
        }
        let at = format!("at {hz} Hz");
        let [(t1, hit), (t2, landing), ..] = impacts.as_slice() else {
            panic!("{at}: the wall's impact and a landing: {impacts:?}");
        };
        assert_eq!(
            (hit.kind, hit.ground, landing.kind, landing.ground),
            (EventKind::Impact, wall, EventKind::Impact, floor),
            "{at}: the wall, then the floor"
        );
        // Measured in `f32`: below 6e-8; in `f64`: below 1e-14.
        assert!(
            abs_diff_eq!(*t1, t_wall, epsilon = X_TOL * t_wall),
            "{at}: the wall at {t1} s, closed form {t_wall}"
        );
        assert!(
            abs_diff_eq!(hit.approach_speed, approach, epsilon = X_TOL * approach),
            "{at}: into the wall at {} m/s, closed form {approach}",
            hit.approach_speed
        );
        let vy = wide(hit.impulse.y) / mass;
        assert!(vy > 0.0, "{at}: the wall's friction throws it up");
        let flight = 2.0 * vy / G;
        assert!(
            abs_diff_eq!(t2 - t1, flight, epsilon = X_TOL * flight),
            "{at}: landed after {} s, thrown up at {vy} m/s: {flight} s",
            t2 - t1
        );
        assert!(
            abs_diff_eq!(landing.approach_speed, vy, epsilon = X_TOL * vy),
            "{at}: landed at {} m/s, thrown up at {vy}",
            landing.approach_speed
        );
        let apex = vy * vy / (2.0 * G);
        assert!(
            highest <= apex * (1.0 + X_TOL),
            "{at}: rose {highest} m, apex {apex} m"
        );
    }
}

/// A 1-degree slope as a triangle mesh (a grid of 0.25 m squares, two triangles each, the
/// tilt baked into its `f32` vertices) or as a heightfield (flat, 0.5 m cells, tilted by its
/// pose): a ball rolling down it across many triangles' edges with `mu_r = 0.03`
/// (> tan 1 deg) slows at `g (mu_r cos - sin)/(1 + k)` and stops where it would on one plane,
/// in every mode and at 30, 60 and 240 Hz, with nothing for the plugin to correct.
#[test]
fn down_a_flat_mesh_or_heightfield_it_stops_as_on_one_plane() {
    let (v0, mu_r, k, slope) = (0.8, 0.03, 0.4, 1.0f64);
    let th = slope.to_radians();
    let a = G * (mu_r * th.cos() - th.sin()) / (1.0 + k);
    let distance = v0 * v0 / (2.0 * a);
    let t_stop = v0 / a;
    let tilt = rapier_impact::na::UnitQuaternion::from_axis_angle(&Vector3::z_axis(), -th);
    let (cells, side) = (40, 0.25);
    let mut vertices = Vec::new();
    let mut indices = Vec::new();
    for i in 0..=cells {
        for j in 0..=cells {
            let v = tilt * Vector3::new(i as f64 * side - 1.0, 0.0, j as f64 * side - 5.0);
            vertices.push(Vector::new(real(v.x), real(v.y), real(v.z)));
        }
    }
    let at = |i: usize, j: usize| (i * (cells + 1) + j) as u32;
    for i in 0..cells {
        for j in 0..cells {
            indices.push([at(i, j), at(i, j + 1), at(i + 1, j + 1)]);
            indices.push([at(i, j), at(i + 1, j + 1), at(i + 1, j)]);
        }
    }
    let heights = rapier_impact::rapier::parry::utils::Array2::new(21, 21, vec![0.0; 21 * 21]);
    let floors = [
        (
            "mesh",
            ColliderBuilder::trimesh(vertices, indices)
                .unwrap()
                .friction(0.5),
        ),
        (
            "heightfield",
            ColliderBuilder::heightfield(heights, Vector::new(10.0, 1.0, 10.0))
                .position(Pose::from_parts(
                    Vector::new(real(4.0 * th.cos()), real(-4.0 * th.sin()), 0.0),
                    Rotation::from_rotation_z(real(-th)),
                ))
                .friction(0.5),
        ),
    ];
    let n = Vector3::new(th.sin(), th.cos(), 0.0);
    let down = Vector3::new(th.cos(), -th.sin(), 0.0);
    for (name, floor) in floors {
        for hz in [30.0, 60.0, 240.0] {
            for mode in MODES {
                let mut w = PhysicsWorld {
                    gravity: Vector::new(0.0, real(-G), 0.0),
                    ..Default::default()
                };
                w.integration_parameters.dt = real(1.0 / hz);
                let (_, ground) = w.insert(RigidBodyBuilder::fixed(), floor.clone());
                let c = Vector3::new(0.0, 0.0, 0.13) + n * R;
                let v = down * v0;
                let spin = n.cross(&v) / R;
                let (ball, _) = w.insert(
                    RigidBodyBuilder::dynamic()
                        .translation(Vector::new(real(c.x), real(c.y), real(c.z)))
                        .linvel(Vector::new(real(v.x), real(v.y), 0.0))
                        .angvel(Vector::new(0.0, 0.0, real(spin.z))),
                    ColliderBuilder::ball(real(R)).friction(0.5),
                );
                let mut p = ImpactPlugin::new(config(mode, mu_r, 0.0)).unwrap();
                p.add_ground(&w.bodies, &w.colliders, ground).unwrap();
                let start = na(w.bodies[ball].center_of_mass());
                let run = ToRest::run(&mut p, &mut w, ball, ((t_stop + 2.0) * hz) as usize);
                let at = format!("{name}, {mode:?} at {hz} Hz");
                let moved = (run.stop(&at) - start).dot(&down);
                // Measured in `f32`: 7.3e-8 in every mode. In `f64`: 3.8e-14.
                let tol = X_TOL;
                assert!(
                    abs_diff_eq!(moved, distance, epsilon = tol * distance),
                    "{at}: stopped after {moved} m, closed form {distance}"
                );
                assert_eq!(run.others, 0, "{at}: nothing to correct");
                run.assert_held(&at, &w, ball, &n);
            }
        }
    }
}

/// The ugly case of the one above: a hole in a level mesh floor (one 0.25 m square, two
/// triangles, left out) across the ball's path. The closed form must not carry the ball over
/// it: it falls in, in every mode.
#[test]
fn a_hole_in_a_mesh_floor_is_not_rolled_over() {
    let (cells, side) = (16, 0.25);
    let mut vertices = Vec::new();
    for i in 0..=cells {
        for j in 0..=cells {
            vertices.push(Vector::new(
                real(i as f64 * side - 1.0),
                0.0,
                real(j as f64 * side - 2.0),
            ));
        }
    }
    let at = |i: usize, j: usize| (i * (cells + 1) + j) as u32;
    let mut indices = Vec::new();
    for i in 0..cells {
        // The square from x = 0.5 to 0.75, z = 0 to 0.25 is left out.
        for j in (0..cells).filter(|j| (i, *j) != (6, 8)) {
            indices.push([at(i, j), at(i, j + 1), at(i + 1, j + 1)]);
            indices.push([at(i, j), at(i + 1, j + 1), at(i + 1, j)]);
        }
    }
    for mode in MODES {
        let mut w = PhysicsWorld {
            gravity: Vector::new(0.0, real(-G), 0.0),
            ..Default::default()
        };
        let (_, ground) = w.insert(
            RigidBodyBuilder::fixed(),
            ColliderBuilder::trimesh(vertices.clone(), indices.clone())
                .unwrap()
                .friction(0.5),
        );
        let v0 = 1.0;
        let (ball, _) = w.insert(
            RigidBodyBuilder::dynamic()
                .translation(Vector::new(0.0, real(R), 0.125))
                .linvel(Vector::new(real(v0), 0.0, 0.0))
                .angvel(Vector::new(0.0, 0.0, real(-v0 / R))),
            ColliderBuilder::ball(real(R)).friction(0.5),
        );
        let mut p = ImpactPlugin::new(config(mode, 0.01, 0.0)).unwrap();
        p.add_ground(&w.bodies, &w.colliders, ground).unwrap();
        for _ in 0..60 {
            p.step(&mut w);
        }
        let y = wide(w.bodies[ball].translation().y);
        assert!(y < -R, "{mode:?}: fell into the hole, y = {y}");
    }
}

/// The ugly case between steps: two mesh floors with a 6 cm slot between them, and a ball
/// rolling across at 3 m/s at 30 Hz (10 cm a step: the slot lies inside one step's path, so
/// neither end of the step is over it). The closed form must not carry the ball over the slot
/// as if it were flat: the ball dips into it (by 2 mm in free fall over the 20 ms it takes),
/// meets the far edge and rolls on. In `TimeOfImpact` and `Exact`: `Step` mode resolves the
/// edge's impact at the step's start, 8 cm before the edge, along the normal from there (it
/// bounces the ball 14 cm up at 2.5 m/s instead of 0.5).
#[test]
fn a_slot_between_two_mesh_floors_inside_one_step_is_not_rolled_over() {
    let quad = |x0: f64, x1: f64| {
        let vertices = [(x0, -1.0), (x1, -1.0), (x1, 1.0), (x0, 1.0)]
            .map(|(x, z)| Vector::new(real(x), 0.0, real(z)))
            .to_vec();
        ColliderBuilder::trimesh(vertices, vec![[0, 2, 1], [0, 3, 2]])
            .unwrap()
            .friction(0.5)
    };
    let v0 = 3.0;
    for mode in [TimingMode::TimeOfImpact, TimingMode::Exact] {
        let mut w = PhysicsWorld {
            gravity: Vector::new(0.0, real(-G), 0.0),
            ..Default::default()
        };
        w.integration_parameters.dt = real(1.0 / 30.0);
        let (_, near) = w.insert(RigidBodyBuilder::fixed(), quad(-1.0, 0.52));
        let (_, far) = w.insert(RigidBodyBuilder::fixed(), quad(0.58, 3.0));
        let (ball, _) = w.insert(
            RigidBodyBuilder::dynamic()
                .translation(Vector::new(0.0, real(R), 0.0))
                .linvel(Vector::new(real(v0), 0.0, 0.0))
                .angvel(Vector::new(0.0, 0.0, real(-v0 / R))),
            ColliderBuilder::ball(real(R)).friction(0.5),
        );
        let mut p = ImpactPlugin::new(config(mode, 0.01, 0.0)).unwrap();
        p.add_ground(&w.bodies, &w.colliders, near).unwrap();
        p.add_ground(&w.bodies, &w.colliders, far).unwrap();
        let mut lowest = f64::INFINITY;
        for _ in 0..12 {
            p.step(&mut w);
            lowest = lowest.min(wide(w.bodies[ball].translation().y));
        }
        assert!(
            wide(w.bodies[ball].translation().x) > 1.0,
            "{mode:?}: crossed the slot"
        );
        assert!(
            lowest < R - 1e-4,
            "{mode:?}: dipped into the slot, lowest centre {lowest}"
        );
    }
}

/// A ball set at rest on a conveyor belt (a kinematic cuboid moving at 0.8 m/s along x): the
/// belt's friction drags it to rolling at `u k / (1 + k)` after `u k / ((1 + k) mu g)`, the
/// rolling resistance then brings it to rest on the belt, and the belt carries it. Where it is
/// at the end, in every mode and at 30, 60 and 240 Hz, is the closed form's (the unit test of
/// `motion::rolling` derives it in the world frame).
#[test]
fn set_on_a_conveyor_it_is_dragged_to_rolling_and_then_carried_as_the_closed_form_says() {
    let (u, mu, mu_r, k) = (0.8, 0.3, 0.02, 0.4);
    let t1 = u * k / ((1.0 + k) * mu * G);
    let rel = u / (1.0 + k);
    let t2 = rel * (1.0 + k) / (mu_r * G);
    let total = t1 + t2 + 1.0;
    for hz in [30.0, 60.0, 240.0] {
        for mode in MODES {
            let mut w = PhysicsWorld {
                gravity: Vector::new(0.0, real(-G), 0.0),
                ..Default::default()
            };
            w.integration_parameters.dt = real(1.0 / hz);
            let (_, belt) = w.insert(
                RigidBodyBuilder::kinematic_velocity_based()
                    .translation(Vector::new(0.0, -0.5, 0.0))
                    .linvel(Vector::new(real(u), 0.0, 0.0)),
                ColliderBuilder::cuboid(20.0, 0.5, 2.0).friction(real(mu)),
            );
            let (ball, _) = w.insert(
                RigidBodyBuilder::dynamic().translation(Vector::new(0.0, real(R), 0.0)),
                ColliderBuilder::ball(real(R)).friction(real(mu)),
            );
            let mut p = ImpactPlugin::new(config(mode, mu_r, 0.0)).unwrap();
            p.add_ground(&w.bodies, &w.colliders, belt).unwrap();
            let steps = (total * hz).round() as usize;
            let mut events = 0;
            for _ in 0..steps {
                p.step(&mut w);
                events += p.events().len();
            }
            let t = steps as f64 / wide(w.integration_parameters.dt).recip();
            let x1 = 0.5 * mu * G * t1 * t1;
            let expected = x1 + u * (t - t1) - rel * t2 / 2.0;
            let x = na(w.bodies[ball].center_of_mass()).x;
            // Measured in `f32`: 2.4e-8 in every mode; in `f64` 1.9e-14.
            let tol = X_TOL;
            let at = format!("{mode:?} at {hz} Hz");
            assert!(
                abs_diff_eq!(x, expected, epsilon = tol * expected),
                "{at}: at {x} m, closed form {expected}"
            );
            assert_eq!(events, 0, "{at}: nothing to correct");
            let (v, y) = (
                na(w.bodies[ball].linvel()),
                wide(w.bodies[ball].translation().y),
            );
            assert!(
                (v - Vector3::new(u, 0.0, 0.0)).norm() <= 1e-6,
                "{at}: carried at the belt's speed, {v:?}"
            );
            assert!(
                abs_diff_eq!(y, R, epsilon = 1e-6),
                "{at}: on the belt, y = {y}"
            );
        }
    }
}

/// One closed-form case on a half-space: the ground's slope (degrees, downhill +x), the
/// ball's start speed down it and its spin as a multiple of the rolling spin `v0 / R`
/// (1: rolling, 0: sliding without spin, below 0: backspin, above 1: topspin), the
/// friction, rolling resistance and `k = I / (m R^2)`, and the motion along +x as phases of
/// constant acceleration `(duration, a)` after which the ball is at rest (the last may be
/// endless).
struct AlongCase {
    name: &'static str,
    slope: f64,
    v0: f64,
    spin: f64,
    mu: f64,
    mu_r: f64,
    k: f64,
    phases: Vec<(f64, f64)>,
}

impl AlongCase {
    /// On level ground: a slide from slip `v0 (1 - spin)` (friction `mu g` against it, which
    /// it loses at `mu g (1 + 1/k)`), then rolling slowed at `mu_r g / (1 + k)` to rest.
    fn level(name: &'static str, v0: f64, spin: f64, mu: f64, mu_r: f64, k: f64) -> Self {
        let slip = v0 * (1.0 - spin);
        let t1 = slip.abs() / (mu * G * (1.0 + 1.0 / k));
        let v1 = v0 - mu * G * t1 * slip.signum();
        let b = mu_r * G / (1.0 + k);
        let phases = vec![(t1, -mu * G * slip.signum()), (v1 / b, -b)];
        Self {
            name,
            slope: 0.0,
            v0,
            spin,
            mu,
            mu_r,
            k,
            phases,
        }
    }

    /// Displacement and speed along the slope at `t`.
    fn at(&self, t: f64) -> (f64, f64) {
        let (mut x, mut v, mut left) = (0.0, self.v0, t);
        for (duration, a) in &self.phases {
            let h = duration.min(left);
            x += v * h + 0.5 * a * h * h;
            v += a * h;
            left -= h;
            if left <= 0.0 {
                return (x, v);
            }
        }
        (x, 0.0)
    }

    /// When to compare: in the first phase that lasts, in the last, and after the stop (or, with an
    /// endless last phase, at 0.5 s and 1 s).
    fn times(&self) -> [f64; 3] {
        let total: f64 = self.phases.iter().map(|p| p.0).sum();
        // A ball that starts rolling has a slide of no duration.
        let first = self
            .phases
            .iter()
            .map(|p| p.0)
            .find(|d| *d > 0.0)
            .unwrap_or(total);
        if total.is_finite() {
            [0.5 * first, 0.5 * (first + total), total + 0.5]
        } else {
            [0.5 * first.min(0.5), 0.5, 1.0]
        }
    }
}

/// Every phase of a ball on a plane in the plugin, against the closed form, in every mode and
/// at 30, 60 and 240 Hz: sliding without spin (solid and hollow), with backspin and with
/// topspin to rolling and then to a stop on level ground (position and speed in the slide,
/// in the roll and after the stop: the slide-to-roll time and speed, the stop's time and
/// distance), a ball at rest on a slope steeper than `mu_r` rolling down, and one on a slope
/// too steep to roll sliding down it; and the energy never rises from one step to the next.
/// Measured in `f32`: within 2.3e-7 in every mode (the same at every rate: each phase is
/// exact, whatever the step, and every mode continues a roll from its `f64` end); in `f64`
/// 7.6e-14. The energy rose at no step.
#[test]
fn every_phase_follows_the_closed_form_at_its_times_in_every_mode() {
    let (mu, mu_r, solid, hollow) = (0.3, 0.02, 0.4, 2.0 / 3.0);
    let (five, forty) = (5.0f64.to_radians(), 40.0f64.to_radians());
    let cases = [
        AlongCase::level("rolling", 1.2, 1.0, mu, mu_r, solid),
        AlongCase::level("sliding without spin", 1.2, 0.0, mu, mu_r, solid),
        AlongCase::level("hollow, sliding without spin", 1.2, 0.0, mu, mu_r, hollow),
        AlongCase::level("backspin", 1.2, -1.0, mu, mu_r, solid),
        AlongCase::level("topspin", 1.2, 3.0, mu, mu_r, solid),
        AlongCase {
            name: "at rest on 5 degrees, rolling down",
            slope: 5.0,
            v0: 0.0,
            spin: 1.0,
            mu,
            mu_r,
            k: solid,
            phases: vec![(
                f64::INFINITY,
                G * (five.sin() - mu_r * five.cos()) / (1.0 + solid),
            )],
        },
        AlongCase {
            // Rolling needs k tan / (1 + k) = 0.24 of g_n > mu = 0.2.
            name: "sliding down 40 degrees",
            slope: 40.0,
            v0: 0.5,
            spin: 0.0,
            mu: 0.2,
            mu_r: 0.0,
            k: solid,
            phases: vec![(f64::INFINITY, G * (forty.sin() - 0.2 * forty.cos()))],
        },
    ];
    for case in &cases {
        for hz in [30.0, 60.0, 240.0] {
            for mode in MODES {
                follows_the_closed_form(case, hz, mode);
            }
        }
    }
}

/// One case at one rate in one mode: the ball's position and speed along the slope at the
/// case's times against the closed form, and its energy at every step.
fn follows_the_closed_form(case: &AlongCase, hz: f64, mode: TimingMode) {
    let th = case.slope.to_radians();
    let (n, down) = (
        Vector3::new(th.sin(), th.cos(), 0.0),
        Vector3::new(th.cos(), -th.sin(), 0.0),
    );
    let (mut w, ground, ball, _) = scene(case.slope, case.v0);
    w.integration_parameters.dt = real(1.0 / hz);
    for (_, co) in w.colliders.iter_mut() {
        co.set_friction(real(case.mu));
    }
    let m = wide(w.bodies[ball].mass());
    let ball_collider = w.bodies[ball].colliders()[0];
    w.colliders[ball_collider].set_mass_properties(MassProperties::new(
        Vector::ZERO,
        real(m),
        Vector::splat(real(case.k * m * R * R)),
    ));
    let spin = n.cross(&(down * case.v0)) / R * case.spin;
    let rb = &mut w.bodies[ball];
    rb.recompute_mass_properties_from_colliders(&w.colliders);
    rb.set_angvel(Vector::new(0.0, 0.0, real(spin.z)), true);
    let mut p = ImpactPlugin::new(config(mode, case.mu_r, 0.0)).unwrap();
    p.add_ground(&w.bodies, &w.colliders, ground).unwrap();
    let start = na(w.bodies[ball].center_of_mass());
    let energy = |w: &PhysicsWorld| {
        let rb = &w.bodies[ball];
        let (v, om) = (na(rb.linvel()), na(rb.angvel()));
        0.5 * m * v.norm_squared()
            + 0.5 * case.k * m * R * R * om.norm_squared()
            + m * G * na(rb.center_of_mass()).y
    };
    // The energy's scale: the start's kinetic energy and a fall of a radius.
    let e_scale = 0.5 * (1.0 + case.k) * m * case.v0 * case.v0 + m * G * R;
    let mut e_last = energy(&w);
    let mut done = 0;
    for t in case.times() {
        let steps = (t * hz).round() as usize;
        let tol = X_TOL;
        let at = |t: f64| format!("{}, {mode:?} at {hz} Hz, t = {t}", case.name);
        for i in done..steps {
            p.step(&mut w);
            let e = energy(&w);
            assert!(
                e <= e_last + X_TOL * e_scale,
                "{}: the energy rose by {:e} of its scale",
                at(i as f64 / hz),
                (e - e_last) / e_scale
            );
            e_last = e;
        }
        done = steps;
        let t = steps as f64 / hz;
        let (x_cf, v_cf) = case.at(t);
        let x = (na(w.bodies[ball].center_of_mass()) - start).dot(&down);
        let v = na(w.bodies[ball].linvel()).dot(&down);
        // Relative to the speed (at least 1 m/s: near a stop, to the start's).
        let scale = v_cf.abs().max(case.v0).max(1.0);
        assert!(
            abs_diff_eq!(x, x_cf, epsilon = tol * x_cf.abs().max(1e-3)),
            "{}: x {x} vs {x_cf}",
            at(t)
        );
        assert!(
            abs_diff_eq!(v, v_cf, epsilon = tol * scale),
            "{}: v {v} vs {v_cf}",
            at(t)
        );
    }
}

/// In every mode a ball rolling alone on level ground is steered, not moved: rapier's step
/// starts it with the velocities that carry it onto the closed form's end, and the end's
/// velocities alone are written, its pose only where rapier's rounding drifted beyond a few
/// roundings (`stages/steer.rs`); the next step continues from the end's `f64` state. Every
/// step it is where the closed form puts it, to a few roundings of each coordinate, with the
/// closed form's velocities to a rounding or two. Measured in `f32`, each mode alike: no pose
/// written in 120 steps, the centre within 2.1 roundings, the velocities within 0.7 (a roll
/// written every step moves the ball every step; one continued from rapier's `f32` state
/// drifts by up to two roundings a step). In `f64` the closed form the plugin advances step
/// by step and the one evaluated here at once part by about a rounding a step: 11.7 and 40
/// roundings after 120 steps.
#[test]
fn rolling_is_steered_not_moved() {
    let (v0, mu_r, k) = (1.2, 0.02, 0.4);
    for mode in MODES {
        let (mut w, ground, ball, down) = scene(0.0, v0);
        w.bodies[ball].set_translation(Vector::new(0.3, real(R), -0.2), true);
        let dt = wide(w.integration_parameters.dt);
        let mut p = ImpactPlugin::new(config(mode, mu_r, 0.0)).unwrap();
        p.add_ground(&w.bodies, &w.colliders, ground).unwrap();
        p.set_profiling(true);
        let start = na(w.bodies[ball].center_of_mass());
        // Rolling without slip, rolling resistance brakes it by mu_r g / (1 + k) until it
        // stops.
        let brake = mu_r * G / (1.0 + k);
        let stop = v0 / brake;
        let eps = wide(Real::EPSILON);
        let (mut moves, mut worst_x, mut worst_v) = (0, 0.0f64, 0.0f64);
        let steps = 120;
        for n in 1..=steps {
            p.step(&mut w);
            moves += p.profile().unwrap().counts.moves;
            let t = (n as f64 * dt).min(stop);
            let (x_cf, v_cf) = (v0 * t - 0.5 * brake * t * t, v0 - brake * t);
            let (x, v) = (start + down * x_cf, down * v_cf);
            let w_cf = Vector3::y().cross(&v) / R;
            let rb = &w.bodies[ball];
            let (held, held_v, held_w) =
                (na(rb.center_of_mass()), na(rb.linvel()), na(rb.angvel()));
            for i in 0..3 {
                let scale = |x: f64| eps * x.abs().max(f64::MIN_POSITIVE);
                worst_x = worst_x.max((held[i] - x[i]).abs() / scale(x[i]));
                let dv = (held_v[i] - v[i])
                    .abs()
                    .max((held_w[i] - w_cf[i]).abs() / 20.0);
                worst_v = worst_v.max(dv / scale(v0));
            }
            assert!(
                p.events().is_empty(),
                "{mode:?}, step {n}: alone on the ground"
            );
        }
        println!(
            "{mode:?}: moves {moves} of {steps}; centre within {worst_x:.2} roundings, \
             velocity {worst_v:.2}"
        );
        assert!(
            moves <= steps / 10,
            "{mode:?}: moved on {moves} of {steps} steps"
        );
        let (x_bound, v_bound) = if F64 { (24.0, 80.0) } else { (4.0, 2.0) };
        assert!(
            worst_x <= x_bound,
            "{mode:?}: the centre drifted {worst_x} roundings"
        );
        assert!(
            worst_v <= v_bound,
            "{mode:?}: the velocities are {worst_v} roundings off"
        );
    }
}

/// A steered roll that something else pushes within the step (a ball knocked into it by a
/// third, which the plan cannot see coming) keeps rapier's end state, released, with the
/// steering's offsets given back on its velocities: it ends as the same push leaves an
/// unsteered roll, of a ball with a solver iteration of its own (which the steering leaves
/// alone; rapier gives the whole group of bodies in contact with it, the three balls, one
/// more substep). Measured in `f32`: 0.4 % apart in speed, 1.0 % in spin (the two steps
/// differ in the velocities rapier's solver starts from, and in its substeps); without the
/// offsets given back 3.1 % in speed and 8.7 % in spin, and the test fails. Every mode steers
/// the roll, and ends it alike.
#[test]
fn a_steered_roll_pushed_by_a_third_ball_ends_as_an_unsteered_one() {
    let after_hit = |mode: TimingMode, steered: bool| {
        let (mut w, ground, a, _) = scene(0.0, 1.0);
        if !steered {
            w.bodies[a].set_additional_solver_iterations(1);
        }
        // B rests 0.2 mm behind A; C, ten times as heavy, touches B and drives it into A.
        w.insert(
            RigidBodyBuilder::dynamic().translation(Vector::new(-0.14163, 0.1, 0.0)),
            ColliderBuilder::ball(0.1),
        );
        w.insert(
            RigidBodyBuilder::dynamic()
                .translation(Vector::new(-0.34173, 0.1, 0.0))
                .linvel(Vector::new(3.0, 0.0, 0.0)),
            ColliderBuilder::ball(0.1).density(10.0),
        );
        let mut p = ImpactPlugin::new(config(mode, 0.0, 0.0)).unwrap();
        p.add_ground(&w.bodies, &w.colliders, ground).unwrap();
        p.set_profiling(true);
        p.step(&mut w);
        let released = p
            .events()
            .iter()
            .any(|e| e.kind == EventKind::Released && e.body == a);
        assert!(released, "{mode:?}: the pushed ball is released");
        let writes = p.profile().unwrap().counts.writes;
        let rb = &w.bodies[a];
        (na(rb.linvel()), na(rb.angvel()), writes)
    };
    let apart = |a: Vector3<f64>, b: Vector3<f64>| (a - b).norm() / b.norm();
    for mode in MODES {
        let (v, w, writes) = after_hit(mode, true);
        let (v_ref, w_ref, writes_ref) = after_hit(mode, false);
        // Steered: its steering velocities before rapier's step, the offsets given back after.
        assert_eq!(writes, writes_ref + 2, "{mode:?}: steered and given back");
        println!(
            "{mode:?}: speed {:.4} apart, spin {:.4}",
            apart(v, v_ref),
            apart(w, w_ref)
        );
        // The push nearly doubles its speed: the hit is in the step.
        assert!(v_ref.x > 1.5, "{mode:?}: {v_ref:?}");
        assert!(apart(v, v_ref) < 0.02, "{mode:?}: {v:?} against {v_ref:?}");
        assert!(apart(w, w_ref) < 0.04, "{mode:?}: {w:?} against {w_ref:?}");
    }
}

/// A roll whose spin rapier would cap (an eighth of a turn a step unless the body allows fast
/// rotation: 2.4 m/s for a 5 cm ball at 60 Hz) has only its centre steered (a velocity write
/// before rapier's step, so that it does not fall through the step), and its pose written
/// every step: rapier's capped spin misses the roll's end rotation. Allowed to turn fast, it
/// is steered, spin too, and its pose is rarely written.
#[test]
fn a_roll_faster_than_rapiers_spin_cap_is_written_with_its_centre_steered() {
    for (v0, fast_rotation, steered) in [(3.0, false, false), (3.0, true, true)] {
        let (mut w, ground, ball, _) = scene(0.0, v0);
        if fast_rotation {
            w.bodies[ball].set_allow_fast_rotation(true);
        }
        let mut p = ImpactPlugin::new(config(TimingMode::Exact, 0.0, 0.0)).unwrap();
        p.add_ground(&w.bodies, &w.colliders, ground).unwrap();
        p.set_profiling(true);
        let (mut writes, mut moves) = (0, 0);
        let steps = 30;
        for _ in 0..steps {
            p.step(&mut w);
            let counts = &p.profile().unwrap().counts;
            (writes, moves) = (writes + counts.writes, moves + counts.moves);
        }
        let at = format!("{v0} m/s, fast rotation {fast_rotation}");
        if steered {
            // Its pose is written where rapier's rounding of the fast turn drifts beyond four
            // roundings: measured on 3 of 30 steps in `f32`, 6 in `f64`, 10 with libm.
            assert!(moves < steps / 2, "{at}: {moves} moves");
        } else {
            assert_eq!((writes, moves), (2 * steps, steps), "{at}");
        }
    }
}

/// At 30 Hz rapier caps a ball's spin at 23.6 rad/s: a 10 cm ball rolling at 5 m/s (50 rad/s)
/// cannot be steered onto its roll's end rotation. Its centre is, so it does not fall
/// through rapier's step with its ground's contact out of the solver, which rapier's CCD,
/// sweeping the fast ball against the floor, cut short: the ball was released every step,
/// and rolled on at 5 m/s with neither friction nor rolling resistance. In every mode it
/// keeps the closed form, `v(t) = v0 - mu_r g t / (1 + k)` and its distance
/// `v0 t - mu_r g t^2 / 2 (1 + k)` (`k = 2/5`), with no event, for 1 s.
#[test]
fn a_roll_faster_than_the_spin_cap_at_30_hz_keeps_its_closed_form() {
    let (v0, r, mu_r, g) = (5.0, 0.1, 0.01, 9.81);
    for mode in MODES {
        let mut w = PhysicsWorld::default();
        w.integration_parameters.dt = 1.0 / 30.0;
        let (_, ground) = w.insert(
            RigidBodyBuilder::fixed().translation(Vector::new(0.0, -0.5, 0.0)),
            ColliderBuilder::cuboid(50.0, 0.5, 50.0).friction(0.5),
        );
        let (b, _) = w.insert(
            RigidBodyBuilder::dynamic()
                .translation(Vector::new(0.0, real(r), 0.0))
                .linvel(Vector::new(real(v0), 0.0, 0.0))
                .angvel(Vector::new(0.0, 0.0, real(-v0 / r))),
            ColliderBuilder::ball(real(r)).friction(0.5),
        );
        let mut p = ImpactPlugin::new(config(mode, mu_r, 0.0)).unwrap();
        p.add_ground(&w.bodies, &w.colliders, ground).unwrap();
        let mut events = 0;
        for _ in 0..30 {
            p.step(&mut w);
            events += p.events().len();
        }
        let t = 1.0;
        let decel = mu_r * g / 1.4;
        let (v, x) = (v0 - decel * t, v0 * t - 0.5 * decel * t * t);
        let rb = &w.bodies[b];
        let (at, vel) = (na(rb.translation()), na(rb.linvel()));
        println!(
            "{mode:?}: at {at:.6?}, v {vel:.6?}; closed form x {x:.6}, v {v:.6}; {events} events"
        );
        assert_eq!(events, 0, "{mode:?}");
        assert!(
            (at.x - x).abs() < 1e-5 * x,
            "{mode:?}: x {} against {x}",
            at.x
        );
        assert!(
            (vel.x - v).abs() < 1e-5 * v,
            "{mode:?}: v {} against {v}",
            vel.x
        );
        assert!((at.y - r).abs() < 1e-6, "{mode:?}: y {}", at.y);
    }
}
