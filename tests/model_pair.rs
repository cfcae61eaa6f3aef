//! `resolve_pair`, impacts between two bodies, against closed forms and invariants:
//! - against a fixed body at rest it is `resolve` on ground (1e-12, every law, random
//!   anisotropic bodies), whichever of the two is fixed;
//! - two spheres: head-on with equal and unequal masses (`(1 -+ e)/2` and the general
//!   Newton form), the 90-degree rule of equal frictionless elastic spheres, stick and
//!   slip decided with the tangential compliance `1/m_a + 1/m_b + R_a^2/I_a + R_b^2/I_b`,
//!   and the throw of cut and spin shots;
//! - momentum (linear, and angular about a fixed point) conserved to 1e-12 relative and
//!   no energy gain for `e <= 1` under `Consistent` and `Guarded`, over proptest states of
//!   two random anisotropic bodies;
//! - the same invalid-input errors as `resolve`, naming which body.
//!
//! The references are written here from the closed forms, not from the model's code.

mod model_support;

use approx::{abs_diff_eq, assert_abs_diff_eq};
use model_support::{
    Dd, Rng, assert_vec_close, dd_solve3, kinetic_energy, random_body, random_general,
};
use proptest::prelude::*;
use proptest::test_runner::{Config, RngAlgorithm, RngSeed};
use rapier_impact::model::{
    Body, BodyVelocity, Contact, Law, Material, ModelError, PairContact, PairImpact, Regime,
    resolve, resolve_pair,
};
use rapier_impact::na::{Matrix3, Rotation3, Vector3};

const LAWS: [Law; 3] = [Law::Document, Law::Consistent, Law::Guarded];

/// A pool ball: 0.17 kg, 28.575 mm radius, solid.
const BALL_MASS: f64 = 0.17;
const BALL_RADIUS: f64 = 0.028_575;

fn solid_ball(mass: f64, radius: f64) -> Body {
    Body::isotropic(mass, 0.4 * mass * radius * radius)
}

fn still() -> BodyVelocity {
    BodyVelocity::default()
}

fn moving(linear: Vector3<f64>, angular: Vector3<f64>) -> BodyVelocity {
    BodyVelocity { linear, angular }
}

/// Ball `a` of radius `ra` at the origin touching ball `b` of radius `rb` along the unit
/// `normal` (from `a` to `b`).
fn spheres(normal: Vector3<f64>, ra: f64, rb: f64) -> PairContact {
    PairContact {
        normal,
        offset_a: normal * ra,
        offset_b: -normal * rb,
    }
}

fn material(e: f64, mu: f64) -> Material {
    Material::new(e, mu)
}

#[track_caller]
fn pair(
    law: Law,
    a: &Body,
    va: &BodyVelocity,
    b: &Body,
    vb: &BodyVelocity,
    c: &PairContact,
    m: &Material,
) -> PairImpact {
    resolve_pair(law, a, va, b, vb, c, m).expect("a valid pair impact")
}

#[test]
fn against_a_fixed_body_at_rest_it_is_the_ground_impact() {
    let mut rng = Rng::new(0x9a1);
    let mut worst: f64 = 0.0;
    for _ in 0..20_000 {
        let (body, _, v, contact, m) = random_general(&mut rng);
        // a the body, b the ground: the pair normal points from the body into the ground.
        let as_a = PairContact {
            normal: -contact.normal,
            offset_a: contact.offset,
            offset_b: rng.vector(1.0),
        };
        // b the body, a the ground.
        let as_b = PairContact {
            normal: contact.normal,
            offset_a: rng.vector(1.0),
            offset_b: contact.offset,
        };
        for law in LAWS {
            let Ok(ground) = resolve(law, &body, &v, &contact, &m) else {
                assert!(resolve_pair(law, &body, &v, &Body::fixed(), &still(), &as_a, &m).is_err());
                continue;
            };
            let scale_v = v.linear.norm() + v.angular.norm() * contact.offset.norm();
            let scale_p = ground.impulse.norm().max(body.mass * scale_v);
            let check =
                |hit: &PairImpact, after: &BodyVelocity, on_body: Vector3<f64>, worst: &mut f64| {
                    assert_eq!(hit.regime, ground.regime, "{law:?}");
                    assert_eq!(
                        (hit.law, hit.fallback),
                        (ground.law, ground.fallback),
                        "{law:?}"
                    );
                    let errors = [
                        (after.linear - ground.velocity.linear).norm() / scale_v,
                        (after.angular - ground.velocity.angular).norm() * contact.offset.norm()
                            / scale_v,
                        (on_body - ground.impulse).norm() / scale_p,
                        (hit.ke_after - ground.ke_after).abs() / ground.ke_before,
                        (hit.ke_before - ground.ke_before).abs() / ground.ke_before,
                        (hit.normal_impulse - ground.normal_impulse).abs() / scale_p,
                    ];
                    for e in errors {
                        assert!(
                            e <= 1e-12,
                            "{law:?}: relative error {e:e}: {hit:?} vs {ground:?}"
                        );
                        *worst = worst.max(e);
                    }
                };
            let hit = pair(law, &body, &v, &Body::fixed(), &still(), &as_a, &m);
            // The ground's reaction is on a, the opposite of the impulse on b.
            check(&hit, &hit.a, -hit.impulse, &mut worst);
            assert_eq!(hit.b, still());
            let hit = pair(law, &Body::fixed(), &still(), &body, &v, &as_b, &m);
            check(&hit, &hit.b, hit.impulse, &mut worst);
            assert_eq!(hit.a, still());
        }
    }
    println!("worst relative difference to the ground impact: {worst:e}");
}

#[test]
fn against_a_moving_fixed_body_it_is_the_moving_ground_impact() {
    let mut rng = Rng::new(0x9a2);
    for _ in 0..2_000 {
        let (body, _, v, mut contact, m) = random_general(&mut rng);
        // A platform translating and turning: its contact point's velocity is the ground's.
        let offset_b = rng.vector(1.0);
        let platform = moving(rng.vector(2.0), rng.vector(2.0));
        contact.ground_velocity = platform.linear + platform.angular.cross(&offset_b);
        let c = PairContact {
            normal: -contact.normal,
            offset_a: contact.offset,
            offset_b,
        };
        for law in LAWS {
            let (Ok(ground), Ok(hit)) = (
                resolve(law, &body, &v, &contact, &m),
                resolve_pair(law, &body, &v, &Body::fixed(), &platform, &c, &m),
            ) else {
                continue;
            };
            let scale = v.linear.norm() + contact.ground_velocity.norm() + 1e-3;
            assert_vec_close("v'", &hit.a.linear, &ground.velocity.linear, 1e-12, scale);
            assert_eq!(hit.regime, ground.regime);
            // The platform's energy is not counted, as on ground.
            assert!(
                abs_diff_eq!(
                    hit.ke_after,
                    ground.ke_after,
                    epsilon = 1e-12 * ground.ke_before
                ),
                "{law:?}: KE' {:?} vs {:?} on ground",
                hit.ke_after,
                ground.ke_after
            );
            assert_eq!(hit.b, platform);
        }
    }
}

#[test]
fn equal_spheres_head_on_exchange_speed_by_restitution() {
    let ball = solid_ball(BALL_MASS, BALL_RADIUS);
    let c = spheres(Vector3::x(), BALL_RADIUS, BALL_RADIUS);
    for e in [0.0, 0.3, 0.95, 1.0] {
        for law in LAWS {
            let v = 2.0;
            let hit = pair(
                law,
                &ball,
                &moving(Vector3::x() * v, Vector3::zeros()),
                &ball,
                &still(),
                &c,
                &material(e, 0.2),
            );
            // v_a' = v (1 - e) / 2, v_b' = v (1 + e) / 2, no spin: nothing tangential.
            assert_vec_close(
                "a",
                &hit.a.linear,
                &(Vector3::x() * (v * (1.0 - e) / 2.0)),
                1e-14,
                v,
            );
            assert_vec_close(
                "b",
                &hit.b.linear,
                &(Vector3::x() * (v * (1.0 + e) / 2.0)),
                1e-14,
                v,
            );
            assert_eq!(
                (hit.a.angular, hit.b.angular),
                (Vector3::zeros(), Vector3::zeros())
            );
            let j = BALL_MASS * v * (1.0 + e) / 2.0;
            assert!(
                abs_diff_eq!(hit.normal_impulse, j, epsilon = 1e-14 * (BALL_MASS * v)),
                "e = {e}, {law:?}: J = {:?}, expected {j:?}",
                hit.normal_impulse
            );
            let ke = 0.5 * BALL_MASS * v * v;
            let ke_after = ke * (1.0 + e * e) / 2.0;
            assert!(
                abs_diff_eq!(hit.ke_after, ke_after, epsilon = 1e-14 * ke),
                "e = {e}, {law:?}: KE' = {:?}, expected {ke_after:?}",
                hit.ke_after
            );
        }
    }
}

#[test]
fn unequal_spheres_head_on_follow_newtons_rule() {
    // A bowling ball (7 kg, 0.109 m) into a pin-sized ball (1.5 kg, 0.06 m) coming back.
    let (ma, ra, mb, rb) = (7.0, 0.109, 1.5, 0.06);
    let (a, b) = (solid_ball(ma, ra), solid_ball(mb, rb));
    let n = Vector3::new(1.0, 2.0, -0.5).normalize();
    let c = spheres(n, ra, rb);
    let (ua, ub) = (6.0, -1.0);
    for e in [0.0, 0.5, 0.9, 1.0] {
        for law in LAWS {
            let hit = pair(
                law,
                &a,
                &moving(n * ua, Vector3::zeros()),
                &b,
                &moving(n * ub, Vector3::zeros()),
                &c,
                &material(e, 0.3),
            );
            let after_a = (ma * ua + mb * ub - mb * e * (ua - ub)) / (ma + mb);
            let after_b = (ma * ua + mb * ub + ma * e * (ua - ub)) / (ma + mb);
            assert_vec_close("a", &hit.a.linear, &(n * after_a), 1e-14, ua);
            assert_vec_close("b", &hit.b.linear, &(n * after_b), 1e-14, ua);
            // No spin from a central impact (to rounding at the scale u / R).
            let spin = |w: Vector3<f64>, r: f64| w.norm() <= 1e-14 * ua / r;
            assert!(
                spin(hit.a.angular, ra) && spin(hit.b.angular, rb),
                "{:?} {:?}",
                hit.a.angular,
                hit.b.angular
            );
        }
    }
}

#[test]
fn equal_frictionless_elastic_spheres_part_at_ninety_degrees() {
    let ball = solid_ball(BALL_MASS, BALL_RADIUS);
    let v = Vector3::new(1.5, 0.0, 0.0);
    for cut_deg in [5.0f64, 30.0, 45.0, 60.0, 85.0] {
        let cut = cut_deg.to_radians();
        // The line of centres at the cut angle to the cue ball's path.
        let n = Vector3::new(cut.cos(), cut.sin(), 0.0);
        let c = spheres(n, BALL_RADIUS, BALL_RADIUS);
        for law in LAWS {
            let hit = pair(
                law,
                &ball,
                &moving(v, Vector3::zeros()),
                &ball,
                &still(),
                &c,
                &material(1.0, 0.0),
            );
            let (a, b) = (hit.a.linear, hit.b.linear);
            // The object ball leaves along the line of centres at v cos(cut), the cue ball
            // at right angles to it at v sin(cut).
            assert_vec_close(
                "object ball",
                &b,
                &(n * (v.norm() * cut.cos())),
                1e-14,
                v.norm(),
            );
            let tag = format!("cut {cut_deg} deg, {law:?}");
            assert!(
                abs_diff_eq!(a.norm(), v.norm() * cut.sin(), epsilon = 1e-14 * v.norm()),
                "{tag}: cue speed {:?}, expected {:?}",
                a.norm(),
                v.norm() * cut.sin()
            );
            assert!(
                abs_diff_eq!(a.dot(&b), 0.0, epsilon = 1e-14 * v.norm_squared()),
                "{tag}: not at right angles: {a:?} . {b:?} = {:?}",
                a.dot(&b)
            );
            assert!(
                abs_diff_eq!(hit.ke_after, hit.ke_before, epsilon = 1e-14 * hit.ke_before),
                "{tag}: KE {:?} after, {:?} before",
                hit.ke_after,
                hit.ke_before
            );
        }
    }
}

/// The closed form of an oblique impact of two spheres with friction: the normal impulse
/// `(1 + e) |u_n| / C_n`, `C_n = 1/m_a + 1/m_b`; sticking (the tangential contact velocity
/// brought to zero) needs `|u_t| / C_t`, `C_t = C_n + R_a^2/I_a + R_b^2/I_b`; within
/// `mu P_n` it sticks, else it slips with `mu P_n` against `u_t`. Returns the impulse on
/// `b` and whether it sticks.
fn sphere_impulse(
    (ma, ia, ra): (f64, f64, f64),
    (mb, ib, rb): (f64, f64, f64),
    n: &Vector3<f64>,
    u: &Vector3<f64>,
    m: &Material,
) -> (Vector3<f64>, bool) {
    let un = n.dot(u);
    let ut = u - n * un;
    let cn = 1.0 / ma + 1.0 / mb;
    let ct = cn + ra * ra / ia + rb * rb / ib;
    let pn = (1.0 + m.restitution) * un / cn;
    let stick = ut.norm() / ct <= m.friction * pn;
    let pt = if stick {
        ut / ct
    } else {
        ut.normalize() * (m.friction * pn)
    };
    (n * pn + pt, stick)
}

#[test]
fn spheres_stick_or_slip_by_the_tangential_compliance() {
    let (ma, ra, mb, rb) = (0.17, 0.028_575, 0.16, 0.026);
    let (ia, ib) = (0.4 * ma * ra * ra, 0.4 * mb * rb * rb);
    let (a, b) = (Body::isotropic(ma, ia), Body::isotropic(mb, ib));
    let mut rng = Rng::new(0x57c);
    let (mut sticks, mut slips) = (0, 0);
    for _ in 0..2_000 {
        let n = rng.unit_vector();
        let c = spheres(n, ra, rb);
        let va = moving(
            n * rng.uniform(0.1, 3.0) + rng.vector(2.0),
            rng.vector(100.0),
        );
        let vb = moving(rng.vector(1.0), rng.vector(100.0));
        let u =
            va.linear + va.angular.cross(&c.offset_a) - vb.linear - vb.angular.cross(&c.offset_b);
        if n.dot(&u) <= 1e-3 {
            continue;
        }
        let m = material(rng.unit(), rng.uniform(0.0, 0.4));
        let (p, stick) = sphere_impulse((ma, ia, ra), (mb, ib, rb), &n, &u, &m);
        if stick {
            sticks += 1
        } else {
            slips += 1
        }
        // Spheres decouple: the document's law is exact and the guard keeps it.
        for law in [Law::Document, Law::Guarded, Law::Consistent] {
            let hit = pair(law, &a, &va, &b, &vb, &c, &m);
            let scale = p.norm().max(ma * u.norm() * 1e-3);
            assert_vec_close(&format!("{law:?} impulse"), &hit.impulse, &p, 1e-12, scale);
            let expected = if stick { Regime::Stick } else { Regime::Slip };
            // The consistent law sees a slip that stops as slip-then-stick.
            let regime_ok = hit.regime == expected
                || law == Law::Consistent && stick && hit.regime == Regime::SlipThenStick;
            assert!(
                regime_ok,
                "{law:?}: {:?}, expected {expected:?}",
                hit.regime
            );
            // Each body takes the impulse at its contact point.
            let lin_a = va.linear - p / ma;
            let ang_a = va.angular - c.offset_a.cross(&p) / ia;
            let lin_b = vb.linear + p / mb;
            let ang_b = vb.angular + c.offset_b.cross(&p) / ib;
            let vs = u.norm();
            assert_vec_close("va'", &hit.a.linear, &lin_a, 1e-12, vs);
            assert_vec_close("wa'", &hit.a.angular, &ang_a, 1e-12, vs / ra);
            assert_vec_close("vb'", &hit.b.linear, &lin_b, 1e-12, vs);
            assert_vec_close("wb'", &hit.b.angular, &ang_b, 1e-12, vs / rb);
        }
    }
    assert!(
        sticks > 100 && slips > 100,
        "both regimes drawn: {sticks} sticks, {slips} slips"
    );
}

/// The throw angle of the object ball off the line of centres, from its velocity.
fn throw_of(hit: &PairImpact, n: &Vector3<f64>) -> f64 {
    let v = hit.b.linear;
    (v - n * n.dot(&v)).norm().atan2(n.dot(&v))
}

#[test]
fn cut_shots_throw_the_object_ball_by_friction() {
    // A stun cut shot (cue ball sliding without spin) with equal balls: the throw is
    // tan(throw) = min(mu, 2 tan(cut) / (7 (1 + e))) (C_n = 2/m, C_t = 7/m for solid balls),
    // the known stun-shot throw, tan(cut) / 7 at e = 1 while it sticks.
    let ball = solid_ball(BALL_MASS, BALL_RADIUS);
    let (e, mu) = (0.95, 0.06);
    for cut_deg in [2.0f64, 5.0, 10.0, 20.0, 30.0, 45.0, 60.0] {
        let cut = cut_deg.to_radians();
        let n = Vector3::new(cut.cos(), cut.sin(), 0.0);
        let c = spheres(n, BALL_RADIUS, BALL_RADIUS);
        let hit = pair(
            Law::Guarded,
            &ball,
            &moving(Vector3::x() * 2.0, Vector3::zeros()),
            &ball,
            &still(),
            &c,
            &material(e, mu),
        );
        let expected = (2.0 * cut.tan() / (7.0 * (1.0 + e))).min(mu).atan();
        assert!(
            abs_diff_eq!(throw_of(&hit, &n), expected, epsilon = 1e-13),
            "throw at {cut_deg} deg: {:?}, expected {expected:?}",
            throw_of(&hit, &n)
        );
        let sticks = 2.0 * cut.tan() / (7.0 * (1.0 + e)) <= mu;
        assert_eq!(
            hit.regime,
            if sticks { Regime::Stick } else { Regime::Slip },
            "{cut_deg} deg"
        );
    }
}

#[test]
fn side_spin_throws_a_straight_shot() {
    // A full-ball hit with side spin w about the vertical: the contact point slips sideways
    // at w R, and the object ball is thrown by tan(throw) = min(mu, 2 w R / (7 (1 + e) v)),
    // away from the side the spin drags the contact.
    let ball = solid_ball(BALL_MASS, BALL_RADIUS);
    let (v, e, mu) = (1.0, 0.95, 0.06);
    let n = Vector3::x();
    let c = spheres(n, BALL_RADIUS, BALL_RADIUS);
    for w in [1.0, 5.0, 20.0, 60.0] {
        let va = moving(n * v, Vector3::z() * w);
        let hit = pair(
            Law::Guarded,
            &ball,
            &va,
            &ball,
            &still(),
            &c,
            &material(e, mu),
        );
        let slide = w * BALL_RADIUS;
        let expected = (2.0 * slide / (7.0 * (1.0 + e) * v)).min(mu).atan();
        assert!(
            abs_diff_eq!(throw_of(&hit, &n), expected, epsilon = 1e-13),
            "throw at {w} rad/s: {:?}, expected {expected:?}",
            throw_of(&hit, &n)
        );
        // w along +z moves a's contact point (at +x R) towards +y: friction drags b along +y.
        assert!(
            hit.b.linear.y > 0.0,
            "thrown towards +y: {:?}",
            hit.b.linear
        );
        // The object ball picks up spin of the opposite sense of rotation about z.
        assert!(hit.b.angular.z < 0.0 && hit.a.angular.z < w);
    }
}

#[test]
fn separating_bodies_get_no_impulse() {
    let ball = solid_ball(1.0, 0.1);
    let c = spheres(Vector3::y(), 0.1, 0.1);
    let va = moving(Vector3::new(3.0, -1.0, 0.0), Vector3::new(0.0, 0.0, 4.0));
    for law in LAWS {
        let hit = pair(law, &ball, &va, &ball, &still(), &c, &material(0.8, 0.5));
        assert_eq!(hit.regime, Regime::Separating);
        assert_eq!((hit.a, hit.b, hit.impulse), (va, still(), Vector3::zeros()));
        assert_eq!(hit.ke_after, hit.ke_before);
    }
}

#[test]
fn bad_input_is_refused_naming_the_body() {
    let ball = solid_ball(1.0, 0.1);
    let c = spheres(Vector3::y(), 0.1, 0.1);
    let va = moving(Vector3::y(), Vector3::zeros());
    let ok = material(0.5, 0.5);
    let run =
        |a: &Body,
         va: &BodyVelocity,
         b: &Body,
         vb: &BodyVelocity,
         c: &PairContact,
         m: &Material| { resolve_pair(Law::Guarded, a, va, b, vb, c, m).unwrap_err() };
    let nan = Vector3::new(f64::NAN, 0.0, 0.0);
    assert_eq!(
        run(
            &ball,
            &moving(nan, Vector3::zeros()),
            &ball,
            &still(),
            &c,
            &ok
        ),
        ModelError::NotFinite { what: "va.linear" }
    );
    assert_eq!(
        run(&ball, &va, &ball, &moving(Vector3::zeros(), nan), &c, &ok),
        ModelError::NotFinite { what: "vb.angular" }
    );
    let light = Body { mass: -1.0, ..ball };
    assert_eq!(
        run(&ball, &va, &light, &still(), &c, &ok),
        ModelError::NonPositiveMass(-1.0)
    );
    let infinite = Body {
        mass: f64::INFINITY,
        ..ball
    };
    assert_eq!(
        run(&infinite, &va, &ball, &still(), &c, &ok),
        ModelError::NotFinite { what: "a.mass" }
    );
    let skew = Body {
        inv_inertia: Matrix3::new(1.0, 0.5, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0),
        ..ball
    };
    assert!(matches!(
        run(&ball, &va, &skew, &still(), &c, &ok),
        ModelError::AsymmetricInertia(_)
    ));
    let negative = Body {
        inv_inertia: -Matrix3::identity(),
        ..ball
    };
    assert_eq!(
        run(&negative, &va, &ball, &still(), &c, &ok),
        ModelError::NotPositiveSemiDefiniteInertia
    );
    let long = PairContact {
        normal: Vector3::y() * 2.0,
        ..c
    };
    assert_eq!(
        run(&ball, &va, &ball, &still(), &long, &ok),
        ModelError::NonUnitNormal(2.0)
    );
    let off = PairContact { offset_b: nan, ..c };
    assert_eq!(
        run(&ball, &va, &ball, &still(), &off, &ok),
        ModelError::NotFinite {
            what: "contact.offset_b"
        }
    );
    assert_eq!(
        run(&ball, &va, &ball, &still(), &c, &material(-0.1, 0.5)),
        ModelError::NegativeRestitution(-0.1)
    );
    assert_eq!(
        run(&ball, &va, &ball, &still(), &c, &material(0.5, -2.0)),
        ModelError::NegativeFriction(-2.0)
    );
    assert_eq!(
        run(&Body::fixed(), &va, &Body::fixed(), &still(), &c, &ok),
        ModelError::BothFixed
    );
    // The ground form refuses a fixed body as the one that hits.
    let ground = Contact::fixed(Vector3::y(), Vector3::new(0.0, -0.1, 0.0));
    assert_eq!(
        resolve(Law::Guarded, &Body::fixed(), &va, &ground, &ok).unwrap_err(),
        ModelError::NotFinite { what: "body.mass" }
    );
}

// --- Invariants over random pairs of anisotropic bodies. ---

fn config(cases: u32) -> Config {
    Config {
        cases,
        rng_algorithm: RngAlgorithm::ChaCha,
        rng_seed: RngSeed::Fixed(0x5eed_0011),
        failure_persistence: None,
        ..Config::default()
    }
}

#[derive(Clone, Debug)]
struct PairCase {
    a: (Body, Matrix3<f64>),
    b: (Body, Matrix3<f64>),
    /// Centres of mass (m): a at the origin shifted by `x_a`, b at `x_b`.
    x_a: Vector3<f64>,
    x_b: Vector3<f64>,
    va: BodyVelocity,
    vb: BodyVelocity,
    contact: PairContact,
    material: Material,
}

prop_compose! {
    /// Two random anisotropic bodies (`model_support::random_body`) meeting at a contact
    /// point with random offsets on either side of the contact plane, approaching at
    /// [1e-3, 5] m/s; `e` in [0, 1], `mu` in [0, 2].
    fn arb_pair()(seed in any::<u64>(), approach in 1e-3..5.0f64, e in 0.0..=1.0f64, mu in 0.0..=2.0f64) -> PairCase {
        let mut rng = Rng::new(seed);
        let a = random_body(&mut rng, 0.5);
        let b = random_body(&mut rng, 0.5);
        let normal = rng.unit_vector();
        let point = rng.vector(2.0);
        // a's centre behind the contact plane, b's in front.
        let mut offset_a = rng.vector(1.0);
        if offset_a.dot(&normal) < 0.0 { offset_a -= normal * (2.0 * offset_a.dot(&normal)); }
        let mut offset_b = rng.vector(1.0);
        if offset_b.dot(&normal) > 0.0 { offset_b -= normal * (2.0 * offset_b.dot(&normal)); }
        let mut va = moving(rng.vector(5.0), rng.vector(5.0));
        let vb = moving(rng.vector(5.0), rng.vector(5.0));
        let u = va.linear + va.angular.cross(&offset_a) - vb.linear - vb.angular.cross(&offset_b);
        va.linear += normal * (approach - normal.dot(&u));
        PairCase {
            a, b,
            x_a: point - offset_a,
            x_b: point - offset_b,
            va, vb,
            contact: PairContact { normal, offset_a, offset_b },
            material: material(e, mu),
        }
    }
}

/// Linear momentum and angular momentum about the origin of both bodies.
fn momenta(c: &PairCase, va: &BodyVelocity, vb: &BodyVelocity) -> (Vector3<f64>, Vector3<f64>) {
    let (ma, ia) = (c.a.0.mass, &c.a.1);
    let (mb, ib) = (c.b.0.mass, &c.b.1);
    let p = va.linear * ma + vb.linear * mb;
    let l = c.x_a.cross(&(va.linear * ma))
        + ia * va.angular
        + c.x_b.cross(&(vb.linear * mb))
        + ib * vb.angular;
    (p, l)
}

fn energy(c: &PairCase, va: &BodyVelocity, vb: &BodyVelocity) -> f64 {
    kinetic_energy(c.a.0.mass, &c.a.1, va) + kinetic_energy(c.b.0.mass, &c.b.1, vb)
}

proptest! {
    #![proptest_config(config(20_000))]

    #[test]
    fn momentum_is_conserved_and_energy_never_gained(c in arb_pair()) {
        let (p0, l0) = momenta(&c, &c.va, &c.vb);
        let ke0 = energy(&c, &c.va, &c.vb);
        for law in LAWS {
            let Ok(hit) = resolve_pair(law, &c.a.0, &c.va, &c.b.0, &c.vb, &c.contact, &c.material) else {
                // Only the document's law may jam.
                prop_assert_eq!(law, Law::Document);
                continue;
            };
            let finite = [hit.a.linear, hit.a.angular, hit.b.linear, hit.b.angular, hit.impulse];
            prop_assert!(finite.iter().all(|v| v.iter().all(|x| x.is_finite())), "{:?}: {:?}", law, hit);
            prop_assert!(hit.normal_impulse >= 0.0 || law == Law::Document, "{:?}: {:?}", law, hit);
            let (p1, l1) = momenta(&c, &hit.a, &hit.b);
            // Relative to the momenta the bodies carry (either may be near zero in total).
            let p_scale = c.a.0.mass * c.va.linear.norm() + c.b.0.mass * c.vb.linear.norm();
            let l_scale = (c.x_a.norm() + 1.0) * c.a.0.mass * (c.va.linear.norm() + c.va.angular.norm())
                + (c.x_b.norm() + 1.0) * c.b.0.mass * (c.vb.linear.norm() + c.vb.angular.norm());
            prop_assert!((p1 - p0).norm() <= 1e-12 * p_scale, "{:?}: momentum {:e}", law, (p1 - p0).norm() / p_scale);
            prop_assert!((l1 - l0).norm() <= 1e-12 * l_scale, "{:?}: angular momentum {:e}", law, (l1 - l0).norm() / l_scale);
            // The reported energies are the bodies' own. The model's come from the inverse
            // inertia, these from the inertia: two roundings of one tensor (R D^-1 R^T and
            // R D R^T), each within about eps cond(I), cond(I) up to 1 600 here.
            let ke1 = energy(&c, &hit.a, &hit.b);
            prop_assert!(abs_diff_eq!(hit.ke_before, ke0, epsilon = 1e-11 * ke0), "{:?}: ke before {:e}", law, (hit.ke_before - ke0) / ke0);
            prop_assert!(abs_diff_eq!(hit.ke_after, ke1, epsilon = 1e-11 * ke0), "{:?}: ke after {:e}", law, (hit.ke_after - ke1) / ke0);
            if law != Law::Document {
                prop_assert!(ke1 - ke0 <= 1e-12 * ke0, "{:?}: energy gain {:e}", law, (ke1 - ke0) / ke0);
            }
        }
    }

    #[test]
    fn the_pair_is_the_same_seen_from_either_body(c in arb_pair()) {
        // Swapping a and b (and the normal) swaps the results: the impulse on the new b is
        // the opposite.
        let swapped = PairContact { normal: -c.contact.normal, offset_a: c.contact.offset_b, offset_b: c.contact.offset_a };
        for law in [Law::Consistent, Law::Guarded] {
            let (Ok(one), Ok(other)) = (
                resolve_pair(law, &c.a.0, &c.va, &c.b.0, &c.vb, &c.contact, &c.material),
                resolve_pair(law, &c.b.0, &c.vb, &c.a.0, &c.va, &swapped, &c.material),
            ) else { continue };
            let scale = one.impulse.norm().max(1e-300);
            prop_assert!((one.impulse + other.impulse).norm() <= 1e-12 * scale, "{:?}: {:?} vs {:?}", law, one.impulse, other.impulse);
        }
    }
}

/// `K = K_a + K_b` of two isotropic bodies (mass, inertia, offset) in double-double.
fn dd_pair_k(bodies: [(f64, f64, Vector3<f64>); 2]) -> [[Dd; 3]; 3] {
    let mut k = [[Dd::new(0.0); 3]; 3];
    for (m, inertia, r) in bodies {
        let r = [Dd::new(r.x), Dd::new(r.y), Dd::new(r.z)];
        let r2 = r[0].mul(r[0]).add(r[1].mul(r[1])).add(r[2].mul(r[2]));
        for i in 0..3 {
            for j in 0..3 {
                // (1/m) E - [r]x [r]x / I = (1/m) E + (|r|^2 E - r r^T) / I.
                let diagonal = if i == j {
                    Dd::new(1.0).div(Dd::new(m)).add(r2.div(Dd::new(inertia)))
                } else {
                    Dd::new(0.0)
                };
                k[i][j] = k[i][j]
                    .add(diagonal)
                    .sub(r[i].mul(r[j]).div(Dd::new(inertia)));
            }
        }
    }
    k
}

#[test]
fn a_needle_on_a_ball_sticks_to_the_last_digits() {
    // A 1e-4 kg rod, radius of gyration 1 mm, landing on its end (0.5 m from its centre)
    // on a 10 kg ball: along the rod its compliance is 1/m = 1e4 /kg, across it r^2/I =
    // 2.5e9 /kg, so a formed K (in a frame not along the rod) keeps only about 5 digits of
    // the 1e4 that sets the normal impulse. The document's sticking impulse `K^-1 d`
    // against a double-double solve of the same K.
    let (m_rod, i_rod) = (1e-4, 1e-4 * 1e-6);
    let (m_ball, r_ball) = (10.0, 0.2);
    let rod = Body::isotropic(m_rod, i_rod);
    let ball = solid_ball(m_ball, r_ball);
    let turn = Rotation3::from_euler_angles(0.3, -0.7, 1.1);
    let n = turn * Vector3::y();
    let c = PairContact {
        normal: n,
        offset_a: n * 0.5,
        offset_b: -n * r_ball,
    };
    // Approaching at 1 m/s, sliding across the rod at 0.3 m/s.
    let va = moving(turn * Vector3::new(0.3, 1.0, 0.0), Vector3::zeros());
    let e = 0.5;
    let k = dd_pair_k([
        (m_rod, i_rod, c.offset_a),
        (m_ball, 0.4 * m_ball * r_ball * r_ball, c.offset_b),
    ]);
    // The impulse on the rod sends its contact velocity u = u_rod - u_ball to -e u_n n:
    // K P = d with d = -e u_n n - u (u_n = u.n along the pair normal).
    let u = va.linear;
    let d = -(n * (e * u.dot(&n))) - u;
    let p = dd_solve3(k, [Dd::new(d.x), Dd::new(d.y), Dd::new(d.z)]);
    let on_rod = Vector3::new(p[0].to_f64(), p[1].to_f64(), p[2].to_f64());
    for law in [Law::Document, Law::Guarded] {
        let hit = pair(law, &rod, &va, &ball, &still(), &c, &material(e, 10.0));
        assert_eq!(hit.regime, Regime::Stick, "{law:?}");
        assert_vec_close(
            "impulse on the rod",
            &-hit.impulse,
            &on_rod,
            1e-14,
            on_rod.norm(),
        );
    }
}

#[test]
fn a_rod_struck_across_takes_the_closed_form_normal_impulse() {
    // The same rod struck across, 0.5 m from its centre, on a 10 kg ball, frictionless
    // in effect (no slip to oppose): the normal impulse is (1 + e) u_n / (n.K_a n + n.K_b n),
    // and the same in a turned frame.
    let rod = Body::isotropic(1e-4, 1e-4 * 1e-6);
    let ball = solid_ball(10.0, 0.2);
    let n = Vector3::y();
    let c = PairContact {
        normal: n,
        offset_a: Vector3::new(0.5, 0.0, 0.0),
        offset_b: -n * 0.2,
    };
    let va = moving(n * 1.0, Vector3::zeros());
    let hit = pair(
        Law::Guarded,
        &rod,
        &va,
        &ball,
        &still(),
        &c,
        &material(0.5, 10.0),
    );
    // The rod's tip takes the whole velocity change; along n its compliance is
    // 1/m + r^2/I = 1e4 + 0.25e10 (r perpendicular to n): P_n = (1+e) u_n / (K_nn a + K_nn b).
    let kn = 1.0 / 1e-4 + 0.25 / 1e-10 + 1.0 / 10.0;
    assert_abs_diff_eq!(hit.normal_impulse, 1.5 / kn, epsilon = 1e-12 * (1.5 / kn));
    let r = Rotation3::from_axis_angle(&Vector3::z_axis(), 0.3);
    let turned = PairContact {
        normal: r * c.normal,
        offset_a: r * c.offset_a,
        offset_b: r * c.offset_b,
    };
    let again = pair(
        Law::Guarded,
        &rod,
        &moving(r * va.linear, Vector3::zeros()),
        &ball,
        &still(),
        &turned,
        &material(0.5, 10.0),
    );
    assert_abs_diff_eq!(
        again.normal_impulse,
        hit.normal_impulse,
        epsilon = 1e-12 * hit.normal_impulse
    );
}
