//! Closed forms of docs/model.md ("Closed forms used in the tests") and a cube-corner impact
//! derived by hand, to 1e-12, through `seed::solve` and every law of the general form,
//! upright and with the whole problem rotated (any ground normal).

mod model_support;

use approx::{abs_diff_eq, assert_abs_diff_eq};
use model_support::*;
use rapier_impact::model::seed::{self, SeedInput};
use rapier_impact::model::{Body, BodyVelocity, Contact, Impact, Law, Material, Regime, resolve};
use rapier_impact::na::{Matrix3, Rotation3, Vector3};
use std::f64::consts::PI;

const LAWS: [Law; 3] = [Law::Document, Law::Consistent, Law::Guarded];

/// Every law, upright and in a random frame, with the result mapped back upright.
fn all_laws(
    body: &Body,
    vel: &BodyVelocity,
    c: &Contact,
    m: &Material,
    q: &Matrix3<f64>,
) -> Vec<(String, Impact)> {
    let mut out = vec![];
    let (b2, v2, c2) = rotate_problem(q, body, vel, c);
    for law in LAWS {
        out.push((
            format!("{law:?}"),
            resolve(law, body, vel, c, m).expect("valid"),
        ));
        let mut i = resolve(law, &b2, &v2, &c2, m).expect("valid");
        let qt = q.transpose();
        i.impulse = qt * i.impulse;
        i.velocity.linear = qt * i.velocity.linear;
        i.velocity.angular = qt * i.velocity.angular;
        out.push((format!("{law:?} rotated"), i));
    }
    out
}

/// A ball-like body rolling in the x-z plane about y: `k = I_yy / (m R^2)`.
struct Ball {
    name: &'static str,
    k: f64,
    /// Moments about x and z over `m R^2` (the axes across the rolling axis).
    across: f64,
}

const BALLS: [Ball; 4] = [
    Ball {
        name: "solid sphere",
        k: 2.0 / 5.0,
        across: 2.0 / 5.0,
    },
    Ball {
        name: "hollow sphere",
        k: 2.0 / 3.0,
        across: 2.0 / 3.0,
    },
    Ball {
        name: "disc",
        k: 1.0 / 2.0,
        across: 1.0 / 4.0,
    },
    Ball {
        name: "ring",
        k: 1.0,
        across: 1.0 / 2.0,
    },
];

/// docs/model.md: sticks iff |u| <= mu (1+e) |vz| (1+k)/k with u = vx - R w_y; then
/// vx' = (vx + k R w_y)/(1+k), w_y' = vx'/R; else vx' = vx - mu (1+e)|vz| sgn(u),
/// w_y' = w_y + mu (1+e)|vz| sgn(u)/(k R); vz' = -e vz.
fn ball_closed_form(
    k: f64,
    radius: f64,
    vx: f64,
    vz: f64,
    wy: f64,
    e: f64,
    mu: f64,
) -> (bool, f64, f64, f64) {
    let u = vx - radius * wy;
    let stick = u.abs() <= mu * (1.0 + e) * vz.abs() * (1.0 + k) / k;
    if stick {
        let vx2 = (vx + k * radius * wy) / (1.0 + k);
        (true, vx2, -e * vz, vx2 / radius)
    } else {
        let f = mu * (1.0 + e) * vz.abs() * u.signum();
        (false, vx - f, -e * vz, wy + f / (k * radius))
    }
}

// One argument per quantity of the closed form, as docs/model.md writes it.
#[allow(clippy::too_many_arguments)]
fn check_ball(
    ball: &Ball,
    mass: f64,
    radius: f64,
    vx: f64,
    vz: f64,
    wy: f64,
    e: f64,
    mu: f64,
    q: &Matrix3<f64>,
) -> bool {
    let (stick, vx2, vz2, wy2) = ball_closed_form(ball.k, radius, vx, vz, wy, e, mu);
    let expected_regime = if stick { Regime::Stick } else { Regime::Slip };
    let tag = format!(
        "{} (k = {}), v = ({vx}, {vz}), w_y = {wy}, e = {e}, mu = {mu}",
        ball.name, ball.k
    );
    let vscale = vx.abs() + vz.abs() + radius * wy.abs();
    // The document's notation needs isotropic inertia: the spheres; for the disc and
    // ring only I_yy acts in this planar impact, so I = k m R^2 reproduces it too.
    let s = SeedInput {
        mass,
        inertia: ball.k * mass * radius * radius,
        lx: 0.0,
        ly: 0.0,
        h: radius,
        restitution: e,
        friction: mu,
        u1: Vector3::new(vx, 0.0, vz),
        w1: Vector3::new(0.0, wy, 0.0),
    };
    let out = seed::solve(&s).expect("valid");
    assert_eq!(out.regime, expected_regime, "seed: {tag}");
    let tol = 1e-12 * vscale;
    assert!(
        abs_diff_eq!(out.u2.x, vx2, epsilon = tol),
        "seed vx': {:?} vs {vx2:?}; {tag}",
        out.u2.x
    );
    assert!(
        abs_diff_eq!(out.u2.z, vz2, epsilon = tol),
        "seed vz': {:?} vs {vz2:?}; {tag}",
        out.u2.z
    );
    assert!(
        abs_diff_eq!(out.w2.y * radius, wy2 * radius, epsilon = tol),
        "seed w_y' R: {:?} vs {:?}; {tag}",
        out.w2.y * radius,
        wy2 * radius
    );
    // The general form with the body's own tensor (anisotropic for the disc and ring).
    let mr2 = mass * radius * radius;
    let moments = Vector3::new(ball.across * mr2, ball.k * mr2, ball.across * mr2);
    let (body, _) = anisotropic_body(mass, &moments, &Matrix3::identity());
    let vel = BodyVelocity {
        linear: Vector3::new(vx, 0.0, vz),
        angular: Vector3::new(0.0, wy, 0.0),
    };
    let c = Contact::fixed(Vector3::z(), Vector3::new(0.0, 0.0, -radius));
    let m = Material::new(e, mu);
    for (law, i) in all_laws(&body, &vel, &c, &m, q) {
        let expected: Vec<Regime> = if stick {
            vec![Regime::Stick, Regime::SlipThenStick]
        } else {
            vec![Regime::Slip]
        };
        assert!(
            expected.contains(&i.regime),
            "{law}: regime {:?}: {tag}",
            i.regime
        );
        // Component by component, each to the same absolute tolerance.
        let v_expected = Vector3::new(vx2, 0.0, vz2);
        assert!(
            abs_diff_eq!(i.velocity.linear, v_expected, epsilon = tol),
            "{law} v': {:?} vs {v_expected:?}; {tag}",
            i.velocity.linear
        );
        assert!(
            abs_diff_eq!(i.velocity.angular.y * radius, wy2 * radius, epsilon = tol),
            "{law} w_y' R: {:?} vs {:?}; {tag}",
            i.velocity.angular.y * radius,
            wy2 * radius
        );
        let w_off = i.velocity.angular.x.hypot(i.velocity.angular.z) * radius;
        assert!(
            abs_diff_eq!(w_off, 0.0, epsilon = tol),
            "{law} |(w_x, w_z)| R: {w_off:?} vs 0; {tag}"
        );
    }
    stick
}

#[test]
fn solid_sphere_rolls_off_at_five_sevenths_and_slides_off_at_4_1() {
    // docs/model.md: vx = 5, vz = -5, e = 0.8; mu = 0.5 sticks: vx' = 3.571429; mu = 0.1
    // slides: vx' = 4.1.
    let id = Matrix3::identity();
    for (mu, vx2, stick) in [(0.5, 3.571429, true), (0.1, 4.1, false)] {
        let s = SeedInput {
            mass: 1.0,
            inertia: 0.4 * 0.1 * 0.1,
            lx: 0.0,
            ly: 0.0,
            h: 0.1,
            restitution: 0.8,
            friction: mu,
            u1: Vector3::new(5.0, 0.0, -5.0),
            w1: Vector3::zeros(),
        };
        let out = seed::solve(&s).expect("valid");
        assert!(
            (out.u2.x - vx2).abs() < 5e-7,
            "mu = {mu}: vx' = {:.7}, the closed form gives {vx2}",
            out.u2.x
        );
        assert!(
            abs_diff_eq!(out.u2.z, 4.0, epsilon = 1e-15 * 4.0),
            "mu = {mu}: u_z2 = {:?}, expected 4",
            out.u2.z
        );
        let got = check_ball(&BALLS[0], 1.0, 0.1, 5.0, -5.0, 0.0, 0.8, mu, &id);
        assert_eq!(got, stick, "mu = {mu}");
    }
    // 5/7 of 5 m/s.
    assert_abs_diff_eq!(5.0 / 1.4, 25.0 / 7.0, epsilon = 1e-15);
}

#[test]
fn spinning_balls_discs_and_rings_land_by_the_closed_forms() {
    let mut rng = Rng::new(300);
    for ball in &BALLS {
        let (mut stick, mut slip) = (0, 0);
        for _ in 0..500 {
            let mass = rng.log_uniform(1e-2, 1e2);
            let radius = rng.log_uniform(1e-2, 1e1);
            let vx = rng.uniform(-10.0, 10.0);
            let vz = -rng.uniform(0.01, 10.0);
            let wy = rng.uniform(-10.0, 10.0) / radius;
            let e = rng.unit();
            let mu = rng.uniform(0.0, 1.0);
            let q = rng.rotation();
            // Stay off the stick/slip boundary, where the regimes meet continuously but
            // rounding may pick either.
            let u = vx - radius * wy;
            let limit = mu * (1.0 + e) * vz.abs() * (1.0 + ball.k) / ball.k;
            if (u.abs() - limit).abs() < 1e-9 * limit {
                continue;
            }
            if check_ball(ball, mass, radius, vx, vz, wy, e, mu, &q) {
                stick += 1;
            } else {
                slip += 1;
            }
        }
        assert!(
            stick > 50 && slip > 50,
            "{}: {stick} stick, {slip} slip",
            ball.name
        );
    }
}

/// A thin rod of length `len`, mass `mass`, at `phi` above the ground, axis in the x-z
/// plane, lower end at `-x`; a small axial inertia (it does not act: `r × P` is across
/// the axis).
fn rod(mass: f64, len: f64, phi: f64) -> (Body, Vector3<f64>) {
    let axis = Vector3::new(phi.cos(), 0.0, phi.sin());
    let across = Vector3::new(-phi.sin(), 0.0, phi.cos());
    let axes = Matrix3::from_columns(&[axis, Vector3::y(), across]);
    let i = mass * len * len / 12.0;
    let (body, _) = anisotropic_body(mass, &Vector3::new(1e-3 * i, i, i), &axes);
    (body, -axis * (0.5 * len))
}

#[test]
fn frictionless_rod_bounces_by_the_closed_form_at_every_angle() {
    let mut rng = Rng::new(301);
    for k in 0..500 {
        let phi = rng.uniform(0.01, PI / 2.0 - 0.01);
        let (mass, len, speed, e) = (
            rng.log_uniform(1e-2, 1e2),
            rng.log_uniform(1e-2, 1e2),
            rng.uniform(0.1, 10.0),
            [0.0, 1.0, rng.unit()][k % 3],
        );
        let c2 = phi.cos().powi(2);
        let p = (1.0 + e) * speed * mass / (1.0 + 3.0 * c2);
        let w = 6.0 * (1.0 + e) * speed * phi.cos() / (len * (1.0 + 3.0 * c2));
        let tag = format!("rod m = {mass}, L = {len}, phi = {phi}, v = {speed}, e = {e}");
        // The document's notation: isotropic I = m L^2 / 12 acts the same (torque across the axis).
        let s = SeedInput {
            mass,
            inertia: mass * len * len / 12.0,
            lx: -0.5 * len * phi.cos(),
            ly: 0.0,
            h: 0.5 * len * phi.sin(),
            restitution: e,
            friction: 0.0,
            u1: Vector3::new(0.0, 0.0, -speed),
            w1: Vector3::zeros(),
        };
        let out = seed::solve(&s).expect("valid");
        assert!(
            abs_diff_eq!(out.impulse.z, p, epsilon = 1e-12 * p),
            "seed J_z: {:?} vs {p:?}; {tag}",
            out.impulse.z
        );
        assert!(
            abs_diff_eq!(out.w2.y, w, epsilon = 1e-12 * w),
            "seed w_y': {:?} vs {w:?}; {tag}",
            out.w2.y
        );
        let (body, r) = rod(mass, len, phi);
        let vel = BodyVelocity {
            linear: Vector3::new(0.0, 0.0, -speed),
            angular: Vector3::zeros(),
        };
        let c = Contact::fixed(Vector3::z(), r);
        let m = Material::new(e, 0.0);
        for (law, i) in all_laws(&body, &vel, &c, &m, &rng.rotation()) {
            assert!(
                abs_diff_eq!(i.impulse.z, p, epsilon = 1e-12 * p),
                "{law} normal impulse: {:?} vs {p:?}; {tag}",
                i.impulse.z
            );
            assert!(
                abs_diff_eq!(i.impulse.xy().norm(), 0.0, epsilon = 1e-12 * p),
                "{law} |P_t|: {:?} vs 0; {tag}",
                i.impulse.xy().norm()
            );
            assert!(
                abs_diff_eq!(i.velocity.angular.y, w, epsilon = 1e-12 * w),
                "{law} w_y': {:?} vs {w:?}; {tag}",
                i.velocity.angular.y
            );
            let vz2 = -speed + p / mass;
            assert!(
                abs_diff_eq!(i.velocity.linear.z, vz2, epsilon = 1e-12 * speed),
                "{law} v_z': {:?} vs {vz2:?}; {tag}",
                i.velocity.linear.z
            );
        }
    }
}

/// A cube of side `a` turned by `rot`: the offset of its lowest corner.
fn lowest_corner(a: f64, rot: &Matrix3<f64>) -> Vector3<f64> {
    let mut best = Vector3::new(0.0, 0.0, f64::INFINITY);
    for i in 0..8 {
        let corner = Vector3::new(
            if i & 1 == 0 { -0.5 } else { 0.5 },
            if i & 2 == 0 { -0.5 } else { 0.5 },
            if i & 4 == 0 { -0.5 } else { 0.5 },
        ) * a;
        let r = rot * corner;
        if r.z < best.z {
            best = r;
        }
    }
    best
}

/// Hand derivation for a cube (I = m a^2 / 6, |r|^2 = 3 a^2 / 4) dropped at speed v onto
/// its lowest corner, at height h below the centre and lateral offset d:
/// - frictionless: P_n = (1+e) v m / (1 + 6 d^2/a^2);
/// - K^-1 = (2m/11) E + (12 m / (11 a^2)) r r^T, so sticking gives
///   P = (1+e) v m ((2/11) z - (12 h / (11 a^2)) r), inside the cone iff
///   mu >= 6 h d / (a^2 + 6 h^2);
/// - otherwise the corner slides outwards along s = r_t/d from rest:
///   P = p (z - mu s), p = (1+e) v m / (1 + 6 (d^2 - mu d h) / a^2).
fn cube_corner_closed_form(
    m: f64,
    a: f64,
    r: &Vector3<f64>,
    v: f64,
    e: f64,
    mu: f64,
) -> (Regime, Vector3<f64>) {
    let h = -r.z;
    let rt = Vector3::new(r.x, r.y, 0.0);
    let d = rt.norm();
    let z = Vector3::z();
    if mu == 0.0 {
        return (
            Regime::Slip,
            z * ((1.0 + e) * v * m / (1.0 + 6.0 * d * d / (a * a))),
        );
    }
    if mu >= 6.0 * h * d / (a * a + 6.0 * h * h) {
        let p = (z * (2.0 / 11.0) - r * (12.0 * h / (11.0 * a * a))) * ((1.0 + e) * v * m);
        return (Regime::Stick, p);
    }
    let s = rt / d;
    let p = (1.0 + e) * v * m / (1.0 + 6.0 * (d * d - mu * d * h) / (a * a));
    (Regime::Slip, (z - s * mu) * p)
}

#[test]
fn cube_landing_on_a_corner_matches_the_hand_derivation() {
    let mut rng = Rng::new(302);
    let (mut stick, mut slip, mut frictionless) = (0, 0, 0);
    for k in 0..600 {
        let (mass, a, speed, e) = (
            rng.log_uniform(1e-2, 1e2),
            rng.log_uniform(1e-2, 1e2),
            rng.uniform(0.1, 10.0),
            rng.unit(),
        );
        let rot = rng.rotation();
        let r = lowest_corner(a, &rot);
        let h = -r.z;
        let d = r.xy().norm();
        let critical = 6.0 * h * d / (a * a + 6.0 * h * h);
        let mu = match k % 3 {
            0 => 0.0,
            1 => critical * rng.uniform(0.0, 0.95),
            _ => critical * rng.uniform(1.05, 3.0),
        };
        let (regime, p) = cube_corner_closed_form(mass, a, &r, speed, e, mu);
        match (regime, mu == 0.0) {
            (_, true) => frictionless += 1,
            (Regime::Stick, _) => stick += 1,
            _ => slip += 1,
        }
        let tag =
            format!("cube m = {mass}, a = {a}, h = {h}, d = {d}, v = {speed}, e = {e}, mu = {mu}");
        let pscale = p.norm();
        let w_expected = r.cross(&p) / (mass * a * a / 6.0);
        // The document's notation: the cube's inertia is isotropic.
        let s = SeedInput {
            mass,
            inertia: mass * a * a / 6.0,
            lx: r.x,
            ly: r.y,
            h,
            restitution: e,
            friction: mu,
            u1: Vector3::new(0.0, 0.0, -speed),
            w1: Vector3::zeros(),
        };
        let out = seed::solve(&s).expect("valid");
        assert_eq!(out.regime, regime, "seed: {tag}");
        assert_vec_close(
            &format!("seed impulse: {tag}"),
            &body_impulse(&out.impulse),
            &p,
            1e-12,
            pscale,
        );
        // The general form with the cube's tensor built as R (m a^2/6 E) R^T and inverted
        // by the crate.
        let tensor = rot * Matrix3::from_diagonal_element(mass * a * a / 6.0) * rot.transpose();
        let body = Body::from_inertia(mass, (tensor + tensor.transpose()) * 0.5).expect("SPD");
        let vel = BodyVelocity {
            linear: Vector3::new(0.0, 0.0, -speed),
            angular: Vector3::zeros(),
        };
        let c = Contact::fixed(Vector3::z(), r);
        let m = Material::new(e, mu);
        for (law, i) in all_laws(&body, &vel, &c, &m, &rng.rotation()) {
            assert_vec_close(
                &format!("{law} impulse: {tag}"),
                &i.impulse,
                &p,
                1e-12,
                pscale,
            );
            assert_vec_close(
                &format!("{law} w': {tag}"),
                &i.velocity.angular,
                &w_expected,
                1e-12,
                w_expected.norm() + 1.0 / a,
            );
        }
    }
    assert!(
        stick > 100 && slip > 100 && frictionless > 100,
        "{stick} stick, {slip} slip, {frictionless} frictionless"
    );
}

#[test]
fn cube_balanced_on_its_diagonal_bounces_like_a_point_mass() {
    // Body diagonal vertical: d = 0, no torque, P = (1+e) v m whatever mu.
    let rot = Rotation3::rotation_between(&Vector3::new(-1.0, -1.0, -1.0), &-Vector3::z())
        .expect("rotation");
    let r = lowest_corner(2.0, rot.matrix());
    // The corner under the centre.
    assert_abs_diff_eq!(r.xy().norm(), 0.0, epsilon = 1e-15);
    for mu in [0.0, 0.3, 1e6] {
        let s = SeedInput {
            mass: 3.0,
            inertia: 3.0 * 4.0 / 6.0,
            lx: r.x,
            ly: r.y,
            h: -r.z,
            restitution: 0.6,
            friction: mu,
            u1: Vector3::new(0.0, 0.0, -2.0),
            w1: Vector3::zeros(),
        };
        let out = seed::solve(&s).expect("valid");
        assert!(
            abs_diff_eq!(out.impulse.z, 1.6 * 2.0 * 3.0, epsilon = 1e-14 * 9.6),
            "mu = {mu}: J_z = {:?}, expected 9.6",
            out.impulse.z
        );
        assert!(
            abs_diff_eq!(out.u2.z, 1.2, epsilon = 1e-14 * 1.2),
            "mu = {mu}: u_z2 = {:?}, expected 1.2",
            out.u2.z
        );
        assert!(
            abs_diff_eq!(out.w2.norm(), 0.0, epsilon = 1e-14),
            "mu = {mu}: |w2| = {:?}, expected 0",
            out.w2.norm()
        );
    }
}

/// A body that does not rotate (zero inverse inertia tensor): `K = E/m`, so the sticking
/// impulse is `m (-(1+e) u_n n - u_t)`, accepted iff `|u_t| <= mu (1+e) |u_n|`, and the
/// slipping one `m (1+e) |u_n| (n - mu s)` (eqs. 10-12 and 16-19 with `I -> inf`).
/// The angular velocity is unchanged and carries no energy (every axis is locked), so the
/// energy after is `m |v_2|^2 / 2`: the impulse's work against the spin's share of the
/// contact-point velocity is not the body's. Document and Guarded take the isotropic path
/// with `a = 0`; Consistent takes the general path and must agree.
#[test]
fn non_rotating_body_is_a_point_mass_at_the_contact() {
    let mut rng = Rng::new(0x0A0B);
    let (mut sticks, mut slips) = (0, 0);
    for k in 0..2000 {
        let mass = rng.log_uniform(0.1, 10.0);
        let body = Body {
            mass,
            inv_inertia: Matrix3::zeros(),
        };
        let n = rng.unit_vector();
        let c = Contact::fixed(n, -n * rng.uniform(0.1, 1.0) + rng.vector(0.5));
        let vel = BodyVelocity {
            linear: -n * rng.uniform(0.5, 5.0) + rng.vector(3.0),
            angular: rng.vector(2.0),
        };
        let m = Material::new(rng.uniform(0.0, 1.0), rng.uniform(0.0, 1.0));
        let u1 = contact_velocity(&vel, &c);
        let un = n.dot(&u1);
        if un >= -1e-3 {
            continue;
        }
        let ut = u1 - n * un;
        let (e, mu) = (m.restitution, m.friction);
        let limit = mu * (1.0 + e) * -un;
        // Away from the stick/slip boundary, where rounding picks the regime.
        if (ut.norm() - limit).abs() <= 1e-9 * u1.norm() {
            continue;
        }
        let stick = ut.norm() <= limit;
        let expected = if stick {
            sticks += 1;
            (-(n * ((1.0 + e) * un)) - ut) * mass
        } else {
            slips += 1;
            (n - ut / ut.norm() * mu) * (mass * (1.0 + e) * -un)
        };
        let v2 = vel.linear + expected / mass;
        let ke1 = 0.5 * mass * vel.linear.norm_squared();
        let ke2 = 0.5 * mass * v2.norm_squared();
        let consistent = resolve(Law::Consistent, &body, &vel, &c, &m).expect("valid");
        for law in [Law::Document, Law::Guarded, Law::Consistent] {
            let i = resolve(law, &body, &vel, &c, &m).expect("valid");
            let tag = format!("case {k}, {law:?}");
            let scale = expected.norm();
            assert!(
                rel_to(&i.impulse, &expected, scale) <= 1e-12,
                "{tag}: impulse {:?}, expected {expected:?}",
                i.impulse
            );
            let vscale = vel.linear.norm().max(v2.norm());
            let dv = rel_to(&i.velocity.linear, &v2, vscale);
            assert!(dv <= 1e-12, "{tag}: v2 relative error {dv:e}");
            assert_eq!(i.velocity.angular, vel.angular, "{tag}: w2");
            assert!(
                abs_diff_eq!(i.ke_before, ke1, epsilon = 1e-14 * ke1),
                "{tag}: KE before {:?} vs {ke1:?}",
                i.ke_before
            );
            assert!(
                abs_diff_eq!(i.ke_after, ke2, epsilon = 1e-12 * ke1),
                "{tag}: KE after {:?} vs {ke2:?}",
                i.ke_after
            );
            assert!(
                abs_diff_eq!(i.ke_after, consistent.ke_after, epsilon = 1e-12 * ke1),
                "{tag}: KE after {:?} vs Consistent's {:?}",
                i.ke_after,
                consistent.ke_after
            );
            if law == Law::Document {
                let regime = if stick { Regime::Stick } else { Regime::Slip };
                assert_eq!(i.regime, regime, "{tag}: regime");
            }
        }
    }
    assert!(
        sticks >= 100 && slips >= 100,
        "{sticks} sticks, {slips} slips"
    );
}
