//! One test per erratum of docs/model.md ("Errata, and what the crate does"), with its numbers. Each test first shows what the
//! document as printed gives (so the erratum is real) and then that the crate does not.

mod model_support;

use approx::{abs_diff_eq, assert_abs_diff_eq};
use model_support::*;
use rapier_impact::model::seed::{
    SeedInput, apply_impulse, contact_velocity, slip_angle, slip_impulse, solve, sticking_impulse,
};
use rapier_impact::model::{Law, Regime, resolve};
use rapier_impact::na::{Matrix3, Vector3};
use std::f64::consts::PI;

/// The document's (13)-(15) exactly as printed.
fn printed_theta(ux: f64, uy: f64) -> f64 {
    if uy > 0.0 && ux < 0.0 {
        PI + (uy / ux).atan()
    } else if uy < 0.0 && ux < 0.0 {
        -PI + (uy / ux).atan()
    } else {
        (uy / ux).atan()
    }
}

/// Kinetic energy change of applying `j` in the document's law.
fn energy_change(s: &SeedInput, j: &Vector3<f64>) -> f64 {
    let (u2, w2) = apply_impulse(s, j);
    seed_energy(s, &u2, &w2) - seed_energy(s, &s.u1, &s.w1)
}

fn solid_unit_sphere(e: f64, mu: f64, u1: Vector3<f64>) -> SeedInput {
    SeedInput {
        mass: 1.0,
        inertia: 0.4,
        lx: 0.0,
        ly: 0.0,
        h: 1.0,
        restitution: e,
        friction: mu,
        u1,
        w1: Vector3::zeros(),
    }
}

/// A thin rod (m = 1 kg, L = 1 m, I = m L^2 / 12) at 45 degrees, lower end at +x of
/// its centre, sliding fast towards -x while barely approaching.
fn sliding_rod(uz: f64, mu: f64) -> SeedInput {
    let phi = PI / 4.0;
    SeedInput {
        mass: 1.0,
        inertia: 1.0 / 12.0,
        lx: 0.5 * phi.cos(),
        ly: 0.0,
        h: 0.5 * phi.sin(),
        restitution: 0.5,
        friction: mu,
        u1: Vector3::new(-5.0, 0.0, uz),
        w1: Vector3::zeros(),
    }
}

#[test]
fn erratum1_eq19_as_printed_is_not_the_solution_of_eq18() {
    // A slipping impact where the friction term of (18) is not zero.
    let s = sliding_rod(-1.0, 0.3);
    let u1t = contact_velocity(&s, &s.u1, &s.w1);
    let out = solve(&s).expect("valid input");
    assert_eq!(out.regime, Regime::Slip);
    let jz = out.impulse.z;
    let theta = out.theta.expect("slip has a direction");
    let (i, m, lx, ly, h, mu, e) = notation(&s);
    let c = lx * theta.cos() + ly * theta.sin();
    // (18) holds for the crate's J_z ...
    let lhs18 = jz * (lx * lx + ly * ly + i / m);
    let rhs18 = mu * h * jz * c - (1.0 + e) * u1t.z * i;
    assert_abs_diff_eq!(lhs18, rhs18, epsilon = 1e-15 * lhs18.abs());
    // ... and equals the corrected (19) ...
    let corrected = -(1.0 + e) * u1t.z * i / (lx * lx + ly * ly + i / m - mu * h * c);
    assert_abs_diff_eq!(jz, corrected, epsilon = 1e-15 * corrected.abs());
    // ... while (19) as printed, with J_z inside its denominator, does not return it.
    let printed = -(1.0 + e) * u1t.z * i / (lx * lx + ly * ly + i / m - mu * h * jz * c);
    assert!(
        (printed - jz).abs() > 1e-2 * jz.abs(),
        "printed eq (19) at J_z = {jz}: {printed}; expected it to differ (the erratum)"
    );
}

#[test]
fn erratum2_slip_along_minus_x_loses_3_25_j_instead_of_gaining_6_75() {
    // Sphere, e = 1, mu = 0.1, v = (-5, 0, -5): u_y1T = 0 with u_x1T < 0.
    let s = solid_unit_sphere(1.0, 0.1, Vector3::new(-5.0, 0.0, -5.0));
    let u1t = contact_velocity(&s, &s.u1, &s.w1);
    // As printed: neither (13) nor (14) applies, (15) gives theta = 0.
    let theta_printed = printed_theta(u1t.x, u1t.y);
    assert_eq!(theta_printed, 0.0, "printed theta for u_1T = {u1t:?}");
    let j_printed = slip_impulse(&s, &u1t, theta_printed).expect("sphere does not jam");
    // The printed law's energy change (J).
    assert_abs_diff_eq!(energy_change(&s, &j_printed), 6.75, epsilon = 1e-14 * 6.75);

    let out = solve(&s).expect("valid input");
    assert_eq!(out.regime, Regime::Slip);
    assert_eq!(out.theta, Some(PI), "theta for slip along -x");
    assert_abs_diff_eq!(out.energy_change(), -3.25, epsilon = 1e-14 * 3.25);
    // Friction pushes towards +x, against the slip: u_x2 = -5 + mu (1+e) 5 = -4.
    assert_abs_diff_eq!(out.u2.x, -4.0, epsilon = 1e-15 * 4.0);
    assert_abs_diff_eq!(out.u2.z, 5.0, epsilon = 1e-15 * 5.0);

    // The general form, every law: a sphere is where they all agree.
    let (body, v, c, mat) = general_from_seed(&s);
    for law in [Law::Document, Law::Guarded, Law::Consistent] {
        let imp = resolve(law, &body, &v, &c, &mat).expect("valid input");
        assert!(
            abs_diff_eq!(imp.energy_change(), -3.25, epsilon = 1e-13 * 3.25),
            "{law:?}: energy change {:?} J, expected -3.25",
            imp.energy_change()
        );
    }
}

#[test]
fn erratum2_negative_zero_slip_component_keeps_the_friction_against_the_slip() {
    for uy in [2.0, -2.0] {
        // u_x1T = -0.0 - 0 h - 0 l_y = -0.0 exactly.
        // e = 1: the normal impulse alone keeps the energy, friction decides its sign.
        let s = solid_unit_sphere(1.0, 0.05, Vector3::new(-0.0, uy, -3.0));
        let u1t = contact_velocity(&s, &s.u1, &s.w1);
        assert!(
            u1t.x == 0.0 && u1t.x.is_sign_negative(),
            "u_x1T = {:?}, expected -0.0",
            u1t.x
        );
        let expected = uy.signum() * PI / 2.0;
        // As printed, -0.0 < 0 is false: (15) gives atan(u_y / -0.0), the wrong sign.
        let printed = printed_theta(u1t.x, u1t.y);
        assert_eq!(printed, -expected, "printed theta for u_1T = {u1t:?}");
        let j_printed = slip_impulse(&s, &u1t, printed).expect("sphere does not jam");
        let gain = energy_change(&s, &j_printed);
        assert!(
            gain > 0.0,
            "printed law with u_y1T = {uy}: energy change {gain}, expected a gain"
        );

        let out = solve(&s).expect("valid input");
        assert_eq!(out.regime, Regime::Slip);
        assert_eq!(out.theta, Some(expected), "theta for u_1T = {u1t:?}");
        assert_eq!(slip_angle(&u1t), Some(expected));
        // J_y counts against +y: it has the sign of the slip.
        assert!(
            out.impulse.y * uy > 0.0,
            "J_y = {} for slip u_y1T = {uy}",
            out.impulse.y
        );
        assert!(
            out.energy_change() < 0.0,
            "energy change {}",
            out.energy_change()
        );
    }
}

#[test]
fn erratum2_zero_slip_outside_the_cone_slides_along_the_sticking_impulse_without_nan() {
    // Offset contact, dropped straight down without spin: u_x1T = u_y1T = 0.
    for mu in [0.0, 0.1] {
        let s = SeedInput {
            mass: 1.0,
            inertia: 0.4,
            lx: 0.3,
            ly: 0.4,
            h: 0.5,
            restitution: 0.5,
            friction: mu,
            u1: Vector3::new(0.0, 0.0, -1.0),
            w1: Vector3::zeros(),
        };
        let u1t = contact_velocity(&s, &s.u1, &s.w1);
        assert_eq!((u1t.x, u1t.y), (0.0, 0.0));
        assert!(printed_theta(u1t.x, u1t.y).is_nan(), "printed theta is 0/0");
        assert_eq!(slip_angle(&u1t), None);
        // The sticking impulse leaves the cone: |J_t|/J_z = m |l| h / (I + m h^2) = 0.385 > mu.
        let stick = sticking_impulse(&s, &u1t);
        let ratio = stick.x.hypot(stick.y) / stick.z;
        assert!(
            abs_diff_eq!(ratio, 0.25 / 0.65, epsilon = 1e-15),
            "mu = {mu}: sticking |J_t|/J_z = {ratio:?}, expected 0.25/0.65"
        );

        let out = solve(&s).expect("valid input");
        assert_eq!(out.regime, Regime::Slip, "mu = {mu}");
        let all = [out.impulse, out.u2, out.w2, out.contact_velocity_after];
        assert!(
            all.iter().all(|v| v.iter().all(|c| c.is_finite())),
            "mu = {mu}: {out:?}"
        );
        let theta = out.theta.expect("case B has a direction");
        assert!(
            abs_diff_eq!(theta, stick.y.atan2(stick.x), epsilon = 1e-15 * PI),
            "mu = {mu}: theta {theta:?} vs the sticking impulse's {:?}",
            stick.y.atan2(stick.x)
        );
        assert!(
            abs_diff_eq!(theta, 0.4f64.atan2(0.3), epsilon = 1e-15 * PI),
            "mu = {mu}: theta {theta:?} vs l's {:?}",
            0.4f64.atan2(0.3)
        );
        // J_z: eq (19) corrected, with l_x cos + l_y sin = |l| = 0.5.
        let jz = 1.5 * 0.4 / (0.25 + 0.4 - mu * 0.5 * 0.5);
        assert!(
            abs_diff_eq!(out.impulse.z, jz, epsilon = 1e-15 * jz),
            "mu = {mu}: J_z = {:?}, expected {jz:?}",
            out.impulse.z
        );
        let jt = out.impulse.x.hypot(out.impulse.y);
        assert!(
            abs_diff_eq!(jt, mu * jz, epsilon = 1e-15 * jz),
            "mu = {mu}: |J_t| = {jt:?}, expected {:?}",
            mu * jz
        );
        // The slip that friction opposes is the one the impact starts (isotropic body).
        let u2t = out.contact_velocity_after;
        let along = u2t.x * theta.cos() + u2t.y * theta.sin();
        let across = -u2t.x * theta.sin() + u2t.y * theta.cos();
        assert!(along > 0.0, "mu = {mu}: slip after along theta {along}");
        assert!(
            abs_diff_eq!(across, 0.0, epsilon = 1e-15 * along),
            "mu = {mu}: slip after across theta {across:?}, along {along:?}"
        );
    }
}

#[test]
fn erratum3_cone_test_rejects_a_pulling_sticking_impulse() {
    let s = sliding_rod(-0.1, 2.0);
    let u1t = contact_velocity(&s, &s.u1, &s.w1);
    let stick = sticking_impulse(&s, &u1t);
    // The printed test sqrt(J_x^2 + J_y^2) <= |mu J_z| accepts it although J_z < 0.
    assert!(stick.z < 0.0, "sticking J_z = {}, expected < 0", stick.z);
    assert!(
        stick.x.hypot(stick.y) <= (s.friction * stick.z).abs(),
        "printed test accepts {stick:?}"
    );
    let out = solve(&s).expect("valid input");
    assert_eq!(out.regime, Regime::Slip, "J_z < 0 must not be case A");
    assert!(out.impulse.z > 0.0, "J_z = {}", out.impulse.z);
    // Slip along -x: D = l_x^2 + I/m + mu h l_x.
    let d = s.lx * s.lx + s.inertia / s.mass + s.friction * s.h * s.lx;
    let jz = 1.5 * 0.1 * s.inertia / d;
    assert_abs_diff_eq!(out.impulse.z, jz, epsilon = 1e-15 * jz);
}

#[test]
fn erratum3_random_planar_rods_never_stick_with_a_pulling_ground() {
    let mut rng = Rng::new(33);
    let (mut printed_pulls, mut approaching) = (0, 0);
    let n = 76_830;
    for k in 0..n {
        let phi = rng.uniform(0.0, PI / 2.0);
        let len = rng.log_uniform(0.1, 10.0);
        let mass = rng.log_uniform(0.1, 10.0);
        let side = if rng.unit() < 0.5 { -1.0 } else { 1.0 };
        let s = SeedInput {
            mass,
            inertia: mass * len * len / 12.0,
            lx: side * 0.5 * len * phi.cos(),
            ly: 0.0,
            h: 0.5 * len * phi.sin(),
            restitution: rng.unit(),
            friction: rng.uniform(0.0, 4.0),
            u1: Vector3::new(rng.uniform(-5.0, 5.0), 0.0, rng.uniform(-5.0, 0.0)),
            w1: Vector3::new(0.0, rng.uniform(-10.0, 10.0) / len, 0.0),
        };
        let u1t = contact_velocity(&s, &s.u1, &s.w1);
        if u1t.z >= 0.0 {
            continue;
        }
        approaching += 1;
        let stick = sticking_impulse(&s, &u1t);
        if stick.z < 0.0 && stick.x.hypot(stick.y) <= (s.friction * stick.z).abs() {
            printed_pulls += 1;
        }
        let out = solve(&s).expect("valid input");
        assert!(
            out.impulse.z >= 0.0,
            "rod {k}: J_z = {} < 0, regime {:?}",
            out.impulse.z,
            out.regime
        );
        if out.regime == Regime::Stick {
            assert!(
                stick.z >= 0.0,
                "rod {k}: case A with sticking J_z = {}",
                stick.z
            );
        }
    }
    eprintln!(
        "printed cone test accepts a pulling ground in {printed_pulls} of {approaching} approaching rod impacts"
    );
    assert!(
        printed_pulls > 100,
        "the sweep must contain the erratum: {printed_pulls} of {approaching}"
    );
}

#[test]
fn erratum3_grazing_impulse_goes_continuously_to_zero() {
    let mut previous = f64::INFINITY;
    for k in 1..=12 {
        let eps = 10f64.powi(-k);
        let s = sliding_rod(-eps, 2.0);
        let u1t = contact_velocity(&s, &s.u1, &s.w1);
        // As printed, the pulling sticking impulse is accepted and does not vanish.
        let stick = sticking_impulse(&s, &u1t);
        assert!(
            stick.norm() > 1.0,
            "u_z = -{eps:e}: printed law's |J| = {}",
            stick.norm()
        );
        let out = solve(&s).expect("valid input");
        let size = out.impulse.norm();
        // Slip along -x: |J| = sqrt(1 + mu^2) J_z with J_z linear in u_z1T.
        let d = s.lx * s.lx + s.inertia / s.mass + s.friction * s.h * s.lx;
        let expected = (1.0 + 4.0f64).sqrt() * 1.5 * eps * s.inertia / d;
        assert!(
            abs_diff_eq!(size, expected, epsilon = 1e-14 * expected),
            "u_z = -{eps:e}: |J| = {size:?}, expected {expected:?}"
        );
        assert!(
            size < previous,
            "|J| must fall with u_z: {size} after {previous}"
        );
        previous = size;
    }
}

/// The document's (10)-(12) as printed, in f64.
fn printed_matrix(s: &SeedInput) -> Matrix3<f64> {
    let (i, m, lx, ly, h) = (s.inertia, s.mass, s.lx, s.ly, s.h);
    Matrix3::new(
        -i / m - h * h - ly * ly,
        lx * ly,
        h * lx,
        lx * ly,
        -i / m - h * h - lx * lx,
        h * ly,
        -h * lx,
        -h * ly,
        i / m + lx * lx + ly * ly,
    )
}

#[test]
fn erratum4_sticking_solve_keeps_its_digits_where_plain_lu_loses_them() {
    let mut worst_crate = 0.0f64;
    let mut lu_at_tiny = 0.0f64;
    for k in 0..=18 {
        let ratio = 10f64.powi(6 - k); // I/m from 1e6 down to 1e-12
        let s = SeedInput {
            mass: 1.0,
            inertia: ratio,
            lx: 0.3,
            ly: -0.2,
            h: 0.5,
            restitution: 0.5,
            friction: 0.5,
            u1: Vector3::new(1.0, -0.5, -2.0),
            w1: Vector3::new(0.3, 0.7, -0.2),
        };
        let u1t = contact_velocity(&s, &s.u1, &s.w1);
        let reference = dd_document_sticking(&s, &u1t);
        let crate_err = rel(&sticking_impulse(&s, &u1t), &reference);
        let b = Vector3::new(
            -u1t.x * s.inertia,
            -u1t.y * s.inertia,
            -(1.0 + s.restitution) * u1t.z * s.inertia,
        );
        let lu = printed_matrix(&s).lu().solve(&b).expect("non-singular");
        let lu_err = rel(&lu, &reference);
        eprintln!("I/m = {ratio:.0e}: crate {crate_err:.2e}, plain LU {lu_err:.2e}");
        assert!(
            crate_err <= 1e-15,
            "I/m = {ratio:e}: sticking impulse relative error {crate_err:e} > 1e-15"
        );
        worst_crate = worst_crate.max(crate_err);
        if k == 18 {
            lu_at_tiny = lu_err;
        }
    }
    // The erratum itself: the printed system solved by plain LU loses digits at 1e-12.
    assert!(
        lu_at_tiny > 1e-9,
        "plain LU at I/m = 1e-12: relative error {lu_at_tiny:e}, expected > 1e-9"
    );
    eprintln!("worst crate error {worst_crate:.2e}");
}

#[test]
fn erratum5_separating_or_resting_contact_gets_no_impulse() {
    for uz in [1.0, 0.0, -0.0, 1e-300] {
        let s = solid_unit_sphere(0.5, 0.5, Vector3::new(3.0, 1.0, uz));
        let out = solve(&s).expect("valid input");
        assert_eq!(out.regime, Regime::Separating, "u_z1T = {uz}");
        assert_eq!(out.impulse, Vector3::zeros(), "u_z1T = {uz}");
        assert_eq!((out.u2, out.w2), (s.u1, s.w1), "u_z1T = {uz}");
        assert_eq!(out.energy_change(), 0.0);
        // As printed, the sticking impulse would pull a separating contact back.
        if uz > 0.0 {
            let stick = sticking_impulse(&s, &contact_velocity(&s, &s.u1, &s.w1));
            assert!(stick.z < 0.0, "printed law's J_z = {}", stick.z);
        }
    }
}
