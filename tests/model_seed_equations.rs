//! One test per equation (1)-(19) of the source document (Cloete 2020), checked against
//! `rapier_impact::model::seed` by plugging its results back into the equations as
//! printed, component by component, or into an independent form of them
//! (`u_T = u + w × r`, `m du = P`, `I dw = r × P` with `P = (-J_x, -J_y, J_z)`).

mod model_support;

use approx::abs_diff_eq;
use model_support::*;
use rapier_impact::model::Regime;
use rapier_impact::model::seed::{
    SeedInput, apply_impulse, contact_velocity, slip_angle, slip_impulse, solve, sticking_impulse,
};
use rapier_impact::na::Vector3;
use std::f64::consts::PI;

const STATES: usize = 20_000;

/// A hand-checked state with exactly representable numbers.
fn hand_state() -> SeedInput {
    SeedInput {
        mass: 2.0,
        inertia: 0.5,
        lx: 0.25,
        ly: -0.5,
        h: 0.75,
        restitution: 0.5,
        friction: 0.25,
        u1: Vector3::new(1.5, -2.0, -3.0),
        w1: Vector3::new(0.5, 2.0, -1.0),
    }
}

#[test]
fn eq1_to_3_contact_velocity_matches_hand_values() {
    let s = hand_state();
    let u = contact_velocity(&s, &s.u1, &s.w1);
    // (1) u_x1T = 1.5 - 2(0.75) - (-1)(-0.5) = -0.5
    // (2) u_y1T = -2 + 0.5(0.75) + (-1)(0.25) = -1.875
    // (3) u_z1T = -3 - 2(0.25) + 0.5(-0.5) = -3.75
    assert_eq!(u.x, -0.5, "eq (1) u_x1T: measured {}, expected -0.5", u.x);
    assert_eq!(
        u.y, -1.875,
        "eq (2) u_y1T: measured {}, expected -1.875",
        u.y
    );
    assert_eq!(u.z, -3.75, "eq (3) u_z1T: measured {}, expected -3.75", u.z);
}

#[test]
fn eq1_to_3_contact_velocity_is_v_plus_w_cross_r() {
    let mut rng = Rng::new(1);
    for k in 0..STATES {
        let s = random_seed_input(&mut rng);
        let r = s.offset();
        let expected = s.u1 + s.w1.cross(&r);
        let measured = contact_velocity(&s, &s.u1, &s.w1);
        let scale = s.u1.norm() + s.w1.norm() * r.norm();
        assert_vec_close(
            &format!("state {k}: u_1T"),
            &measured,
            &expected,
            1e-15,
            scale,
        );
    }
}

#[test]
fn eq4_to_6_linear_momentum_changes_by_minus_jx_minus_jy_plus_jz() {
    let s = hand_state();
    let j = Vector3::new(0.5, -0.75, 2.0);
    let (u2, _) = apply_impulse(&s, &j);
    // (4) 1.5 - 0.5/2, (5) -2 + 0.75/2, (6) -3 + 2/2: exact in binary.
    assert_eq!(u2.x, 1.25, "eq (4) u_x2: measured {}, expected 1.25", u2.x);
    assert_eq!(
        u2.y, -1.625,
        "eq (5) u_y2: measured {}, expected -1.625",
        u2.y
    );
    assert_eq!(u2.z, -2.0, "eq (6) u_z2: measured {}, expected -2", u2.z);

    let mut rng = Rng::new(2);
    for k in 0..STATES {
        let s = random_seed_input(&mut rng);
        let j = rng.vector(10.0);
        let (u2, _) = apply_impulse(&s, &j);
        let expected = body_impulse(&j);
        let measured = (u2 - s.u1) * s.mass;
        assert_vec_close(
            &format!("state {k}: m (u2 - u1)"),
            &measured,
            &expected,
            1e-13,
            j.norm() + s.mass * s.u1.norm(),
        );
    }
}

#[test]
fn eq7_to_9_angular_momentum_changes_by_r_cross_impulse() {
    let s = hand_state();
    let j = Vector3::new(0.5, -0.75, 2.0);
    let (_, w2) = apply_impulse(&s, &j);
    // (7) 0.5 + (2(-0.5) - (-0.75)(0.75))/0.5 = 0.5 + (-1 + 0.5625)/0.5 = -0.375
    // (8) 2 + (-2(0.25) + 0.5(0.75))/0.5 = 2 + (-0.5 + 0.375)/0.5 = 1.75
    // (9) -1 + (0.5(-0.5) - (-0.75)(0.25))/0.5 = -1 + (-0.25 + 0.1875)/0.5 = -1.125
    assert_eq!(
        w2.x, -0.375,
        "eq (7) w_x2: measured {}, expected -0.375",
        w2.x
    );
    assert_eq!(w2.y, 1.75, "eq (8) w_y2: measured {}, expected 1.75", w2.y);
    assert_eq!(
        w2.z, -1.125,
        "eq (9) w_z2: measured {}, expected -1.125",
        w2.z
    );

    let mut rng = Rng::new(3);
    for k in 0..STATES {
        let s = random_seed_input(&mut rng);
        let j = rng.vector(10.0);
        let (_, w2) = apply_impulse(&s, &j);
        let r = s.offset();
        let expected = r.cross(&body_impulse(&j));
        let measured = (w2 - s.w1) * s.inertia;
        let scale = r.norm() * j.norm() + s.inertia * s.w1.norm();
        assert_vec_close(
            &format!("state {k}: I (w2 - w1)"),
            &measured,
            &expected,
            1e-13,
            scale,
        );
    }
}

/// Residuals of (10)-(12) as printed, each relative to the size of its terms.
fn residuals_10_to_12(s: &SeedInput, u1t: &Vector3<f64>, j: &Vector3<f64>) -> [f64; 3] {
    let (i, m, lx, ly, h, e) = (s.inertia, s.mass, s.lx, s.ly, s.h, s.restitution);
    let rows = [
        [
            j.x * (-i / m - h * h - ly * ly),
            j.y * (lx * ly),
            j.z * (h * lx),
            u1t.x * i, // moved to the left: + u_x1T I
        ],
        [
            j.x * (lx * ly),
            j.y * (-i / m - h * h - lx * lx),
            j.z * (h * ly),
            u1t.y * i,
        ],
        [
            j.x * (-h * lx),
            j.y * (-h * ly),
            j.z * (i / m + lx * lx + ly * ly),
            (1.0 + e) * u1t.z * i,
        ],
    ];
    rows.map(|t| {
        let sum: f64 = t.iter().sum();
        let size: f64 = t.iter().map(|x| x.abs()).sum();
        sum.abs() / size
    })
}

#[test]
fn eq10_to_12_sticking_impulse_satisfies_the_printed_system() {
    let mut rng = Rng::new(4);
    let mut worst = [0.0f64; 3];
    for k in 0..STATES {
        let s = random_seed_input(&mut rng);
        let u1t = contact_velocity(&s, &s.u1, &s.w1);
        let j = sticking_impulse(&s, &u1t);
        let res = residuals_10_to_12(&s, &u1t, &j);
        for (row, r) in res.iter().enumerate() {
            worst[row] = worst[row].max(*r);
            assert!(
                *r <= 1e-14,
                "state {k}: eq ({}) residual {r:.3e} relative to its terms, expected <= 1e-14; J = {j:?}",
                10 + row
            );
        }
    }
    eprintln!("eqs (10)-(12): worst relative residuals {worst:?} on {STATES} states");
}

#[test]
fn eq10_to_12_sticking_impulse_stops_the_slip_and_restores_e_times_the_approach() {
    let mut rng = Rng::new(5);
    for k in 0..STATES {
        let s = random_seed_input(&mut rng);
        let u1t = contact_velocity(&s, &s.u1, &s.w1);
        let j = sticking_impulse(&s, &u1t);
        let (u2, w2) = apply_impulse(&s, &j);
        let u2t = contact_velocity(&s, &u2, &w2);
        let expected = Vector3::new(0.0, 0.0, -s.restitution * u1t.z);
        // Velocity scale of the terms that cancel: |u1T| plus what J contributes.
        let r = s.offset();
        let scale = u1t.norm() + j.norm() * (1.0 / s.mass + r.norm_squared() / s.inertia);
        assert_vec_close(
            &format!("state {k}: u_2T after sticking"),
            &u2t,
            &expected,
            1e-13,
            scale,
        );
    }
}

#[test]
fn eq13_to_15_slip_angle_equals_the_documents_cases_away_from_their_edges() {
    let mut rng = Rng::new(6);
    for k in 0..STATES {
        let ux = rng.uniform(-5.0, 5.0);
        let uy = rng.uniform(-5.0, 5.0);
        if ux == 0.0 || uy == 0.0 {
            continue;
        }
        let document = if uy > 0.0 && ux < 0.0 {
            PI + (uy / ux).atan() // (13)
        } else if uy < 0.0 && ux < 0.0 {
            -PI + (uy / ux).atan() // (14)
        } else {
            (uy / ux).atan() // (15)
        };
        let theta = slip_angle(&Vector3::new(ux, uy, -1.0)).expect("non-zero slip has a direction");
        assert!(
            abs_diff_eq!(theta, document, epsilon = 1e-15 * PI),
            "case {k}: theta for u_1T = ({ux}, {uy}) is {theta:?}, the document's {document:?}"
        );
        // theta is the direction of the slip, which friction opposes through (16)-(17).
        let norm = ux.hypot(uy);
        assert!(
            abs_diff_eq!(theta.cos(), ux / norm, epsilon = 1e-15),
            "case {k}: cos theta {:?} vs {:?}",
            theta.cos(),
            ux / norm
        );
        assert!(
            abs_diff_eq!(theta.sin(), uy / norm, epsilon = 1e-15),
            "case {k}: sin theta {:?} vs {:?}",
            theta.sin(),
            uy / norm
        );
    }
}

/// The random states approaching the ground (`u_z1T < 0`) among `STATES` draws: the draw's
/// index, the state, its contact velocity `u_1T` and a random slip angle (drawn after the state,
/// for the approaching ones only).
fn approaching_slips(mut rng: Rng) -> impl Iterator<Item = (usize, SeedInput, Vector3<f64>, f64)> {
    (0..STATES).filter_map(move |k| {
        let s = random_seed_input(&mut rng);
        let u1t = contact_velocity(&s, &s.u1, &s.w1);
        if u1t.z >= 0.0 {
            return None;
        }
        Some((k, s, u1t, rng.uniform(-PI, PI)))
    })
}

#[test]
fn eq16_17_slip_friction_is_mu_jz_along_theta() {
    for (k, s, u1t, theta) in approaching_slips(Rng::new(7)) {
        let Ok(j) = slip_impulse(&s, &u1t, theta) else {
            continue; // a jam is tested elsewhere
        };
        let mu = s.friction;
        let tol = 1e-15 * (mu * j.z.abs());
        assert!(
            abs_diff_eq!(j.x, mu * j.z * theta.cos(), epsilon = tol),
            "state {k}: eq (16) J_x = {:?}, expected {:?}",
            j.x,
            mu * j.z * theta.cos()
        );
        assert!(
            abs_diff_eq!(j.y, mu * j.z * theta.sin(), epsilon = tol),
            "state {k}: eq (17) J_y = {:?}, expected {:?}",
            j.y,
            mu * j.z * theta.sin()
        );
    }
}

#[test]
fn eq18_slip_normal_impulse_balances_the_substituted_eq12() {
    for (k, s, u1t, theta) in approaching_slips(Rng::new(8)) {
        let Ok(j) = slip_impulse(&s, &u1t, theta) else {
            continue;
        };
        let (i, m, lx, ly, h, mu, e) = notation(&s);
        // (18): J_z (l_x^2 + l_y^2 + I/m) = mu h J_z (l_x cos + l_y sin) - (1+e) u_z1T I
        let lhs = j.z * (lx * lx + ly * ly + i / m);
        let friction_term = mu * h * j.z * (lx * theta.cos() + ly * theta.sin());
        let newton_term = -(1.0 + e) * u1t.z * i;
        let size = lhs.abs() + friction_term.abs() + newton_term.abs();
        assert!(
            abs_diff_eq!(lhs, friction_term + newton_term, epsilon = 1e-14 * size),
            "state {k}: eq (18) {lhs:?} vs {:?} (terms of size {size:?})",
            friction_term + newton_term
        );
    }
}

#[test]
fn eq19_corrected_normal_impulse_and_newtons_law_hold_while_slipping() {
    let mut checked = 0;
    for (k, s, u1t, theta) in approaching_slips(Rng::new(9)) {
        let (i, m, lx, ly, h, mu, e) = notation(&s);
        let denominator =
            lx * lx + ly * ly + i / m - mu * h * (lx * theta.cos() + ly * theta.sin());
        let result = slip_impulse(&s, &u1t, theta);
        if denominator <= 0.0 {
            assert!(
                result.is_err(),
                "state {k}: denominator {denominator:e} <= 0 must be a jam, got {result:?}"
            );
            continue;
        }
        let j = result.expect("positive denominator");
        let expected = -(1.0 + e) * u1t.z * i / denominator;
        // The denominator cancels terms: allow for that in the scale.
        let size = (lx * lx + ly * ly + i / m + mu * h * (lx.abs() + ly.abs())) / denominator;
        assert!(
            abs_diff_eq!(j.z, expected, epsilon = 1e-14 * (expected.abs() * size)),
            "state {k}: eq (19) J_z = {:?}, expected {expected:?}",
            j.z
        );
        // The slip impulse still obeys Newton's law, eq (12) with (16)-(17).
        let (u2, w2) = apply_impulse(&s, &j);
        let u2t = contact_velocity(&s, &u2, &w2);
        let scale = u1t.norm() + j.norm() * (1.0 / m + s.offset().norm_squared() / i);
        assert!(
            abs_diff_eq!(u2t.z, -e * u1t.z, epsilon = 1e-13 * scale),
            "state {k}: u_z2T after slip {:?}, expected {:?}",
            u2t.z,
            -e * u1t.z
        );
        checked += 1;
    }
    assert!(checked > STATES / 2, "only {checked} slip impulses checked");
}

#[test]
fn solve_takes_case_a_inside_the_cone_and_case_b_outside() {
    let mut rng = Rng::new(10);
    let (mut stick, mut slip, mut separating) = (0, 0, 0);
    for k in 0..STATES {
        let s = random_seed_input(&mut rng);
        let out = solve(&s).unwrap_or_else(|e| panic!("state {k}: {e}"));
        let u1t = contact_velocity(&s, &s.u1, &s.w1);
        assert_eq!(out.contact_velocity_before, u1t, "state {k}: u_1T");
        let j_stick = sticking_impulse(&s, &u1t);
        let inside = j_stick.z >= 0.0 && j_stick.x.hypot(j_stick.y) <= s.friction * j_stick.z;
        match out.regime {
            Regime::Separating => {
                assert!(u1t.z >= 0.0, "state {k}: separating with u_z1T = {}", u1t.z);
                assert_eq!(out.impulse, Vector3::zeros());
                separating += 1;
            }
            Regime::Stick => {
                assert!(
                    u1t.z < 0.0 && inside,
                    "state {k}: case A taken with J = {j_stick:?}, mu = {}",
                    s.friction
                );
                assert_eq!(out.impulse, j_stick, "state {k}: case A impulse");
                stick += 1;
            }
            Regime::Slip => {
                assert!(
                    u1t.z < 0.0 && !inside,
                    "state {k}: case B taken with J = {j_stick:?}, mu = {}",
                    s.friction
                );
                let theta = atan2(u1t.y, u1t.x);
                assert_eq!(out.theta, Some(theta), "state {k}: theta");
                let expected = slip_impulse(&s, &u1t, theta).expect("isotropic bodies do not jam");
                assert_eq!(out.impulse, expected, "state {k}: case B impulse");
                slip += 1;
            }
            Regime::SlipThenStick => panic!("state {k}: the document has no slip-then-stick"),
        }
        // Eqs (4)-(9) give the state after, (1)-(3) its contact velocity.
        let (u2, w2) = apply_impulse(&s, &out.impulse);
        assert_eq!((out.u2, out.w2), (u2, w2), "state {k}: velocities after");
        assert_eq!(out.contact_velocity_after, contact_velocity(&s, &u2, &w2));
        let (ke1, ke2) = (seed_energy(&s, &s.u1, &s.w1), seed_energy(&s, &u2, &w2));
        assert!(
            abs_diff_eq!(out.ke_before, ke1, epsilon = 1e-15 * ke1),
            "state {k}: ke_before {:?}, expected {ke1:?}",
            out.ke_before
        );
        assert!(
            abs_diff_eq!(out.energy_change(), ke2 - ke1, epsilon = 1e-14 * ke1),
            "state {k}: energy change {:?}, expected {:?}",
            out.energy_change(),
            ke2 - ke1
        );
    }
    eprintln!("{stick} stick, {slip} slip, {separating} separating of {STATES}");
    assert!(
        stick > 1000 && slip > 1000 && separating > 100,
        "{stick} stick, {slip} slip, {separating} separating"
    );
}

/// The `atan2` the model calls: the platform's, or libm's with `enhanced-determinism`.
fn atan2(y: f64, x: f64) -> f64 {
    #[cfg(feature = "enhanced-determinism")]
    return libm::atan2(y, x);
    #[cfg(not(feature = "enhanced-determinism"))]
    return y.atan2(x);
}
