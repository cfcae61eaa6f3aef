//! Walton's tangential restitution `beta0` against closed forms: a sphere on the ground and
//! two spheres, in both regimes, under every law; the superball; the hard cases (`beta0` at
//! its ends, grazing, spinning, jams, swerves); and `Guarded`'s fallback where the
//! document's form would gain energy.

mod model_support;

use approx::{abs_diff_eq, assert_abs_diff_eq};
use model_support::{Rng, anisotropic_body, jam_prone_impact};
use rapier_impact::model::{
    Body, BodyVelocity, Contact, Fallback, Law, Material, PairContact, Regime, resolve,
    resolve_pair,
};
use rapier_impact::na::Vector3;

const LAWS: [Law; 3] = [Law::Document, Law::Consistent, Law::Guarded];
const BETAS: [f64; 7] = [-1.0, -0.6, -0.2, 0.0, 0.3, 0.7, 1.0];

/// A sphere of mass `m`, radius `r` and inertia `k m r^2` on the ground `y = 0`, arriving at
/// `(vx, -vy, 0)` with spin `wz` about `+z`.
struct Ball {
    m: f64,
    r: f64,
    k: f64,
}

/// The closed form of Walton's model for a sphere struck along its radius: the velocity and
/// spin after, and whether the contact sticks (the friction needed is inside the cone).
fn walton_sphere(
    b: &Ball,
    mat: (f64, f64, f64),
    vx: f64,
    vy: f64,
    wz: f64,
) -> (Vector3<f64>, f64, bool) {
    let (e, mu, beta) = mat;
    let inertia = b.k * b.m * b.r * b.r;
    // Contact point: v + w x (-r y) = (vx + wz r) x.
    let ut = vx + wz * b.r;
    let ktt = 1.0 / b.m + b.r * b.r / inertia;
    let pn = b.m * (1.0 + e) * vy;
    let stick = -(1.0 + beta) * ut / ktt;
    let (pt, sticks) = if stick.abs() <= mu * pn {
        (stick, true)
    } else {
        (-mu * pn * ut.signum(), false)
    };
    let v = Vector3::new(vx + pt / b.m, e * vy, 0.0);
    (v, wz + b.r * pt / inertia, sticks)
}

fn sphere_case(b: &Ball, vx: f64, vy: f64, wz: f64) -> (Body, BodyVelocity, Contact) {
    let body = Body::isotropic(b.m, b.k * b.m * b.r * b.r);
    let velocity = BodyVelocity {
        linear: Vector3::new(vx, -vy, 0.0),
        angular: Vector3::new(0.0, 0.0, wz),
    };
    (
        body,
        velocity,
        Contact::fixed(Vector3::y(), Vector3::new(0.0, -b.r, 0.0)),
    )
}

#[test]
fn a_sphere_meets_walton_closed_form_in_both_regimes() {
    let balls = [
        Ball {
            m: 0.057,
            r: 0.0335,
            k: 0.4,
        },
        Ball {
            m: 2.0,
            r: 0.11,
            k: 2.0 / 3.0,
        },
    ];
    let (mut worst, mut cases, mut sticks, mut slips) = (0.0f64, 0, 0, 0);
    for b in &balls {
        for &beta in &BETAS {
            for deg in (5..=85).step_by(5) {
                for wz in [0.0, 40.0, -25.0] {
                    let a = (deg as f64).to_radians();
                    let (vx, vy) = (3.9 * a.sin(), 3.9 * a.cos());
                    let (e, mu) = (0.9, 0.3);
                    let (v, w, stick) = walton_sphere(b, (e, mu, beta), vx, vy, wz);
                    // A case at the boundary between the regimes is the same in both to
                    // rounding, but the regime's name can go either way: skip it.
                    let ut = vx + wz * b.r;
                    let ratio = (1.0 + beta) * ut.abs() / (1.0 + 1.0 / b.k) / ((1.0 + e) * vy * mu);
                    if (ratio - 1.0).abs() < 1e-9 {
                        continue;
                    }
                    let (body, velocity, contact) = sphere_case(b, vx, vy, wz);
                    let material = Material::new(e, mu).with_tangential_restitution(beta);
                    for law in LAWS {
                        let i = resolve(law, &body, &velocity, &contact, &material).unwrap();
                        let scale = 3.9 + wz.abs() * b.r;
                        let dv = (i.velocity.linear - v).norm() / scale;
                        let dw = (i.velocity.angular.z - w).abs() * b.r / scale;
                        worst = worst.max(dv).max(dw);
                        assert!(
                            dv <= 1e-12 && dw <= 1e-12,
                            "{law:?} beta {beta} at {deg} deg, spin {wz}: v {:?} vs {v:?}, w {} vs {w}",
                            i.velocity.linear,
                            i.velocity.angular.z
                        );
                        assert_eq!(
                            i.regime != Regime::Slip,
                            stick,
                            "{law:?} beta {beta} at {deg} deg"
                        );
                        assert_eq!(i.fallback, None, "{law:?} beta {beta} at {deg} deg");
                        assert!(i.energy_change() <= 1e-12 * i.ke_before);
                    }
                    cases += 1;
                    if stick {
                        sticks += 1;
                    } else {
                        slips += 1;
                    }
                }
            }
        }
    }
    assert!(
        sticks > 50 && slips > 50,
        "{sticks} sticking and {slips} slipping cases"
    );
    println!("{cases} sphere cases ({sticks} stick, {slips} slip): worst relative error {worst:e}");
}

#[test]
fn a_superball_comes_back_with_its_contact_velocity_reversed() {
    // A solid rubber ball (e = 0.9, gripping: mu = 1) thrown without spin at 45 degrees.
    let b = Ball {
        m: 0.05,
        r: 0.025,
        k: 0.4,
    };
    let (body, velocity, contact) = sphere_case(&b, 2.0, 2.0, 0.0);
    let material = Material::new(0.9, 1.0).with_tangential_restitution(1.0);
    let i = resolve(Law::Guarded, &body, &velocity, &contact, &material).unwrap();
    let ut_after = i.velocity.linear.x + i.velocity.angular.z * b.r;
    // The contact point's tangential velocity reverses: -beta0 times 2 m/s.
    assert!(
        (ut_after + 2.0).abs() < 1e-12,
        "contact velocity after {ut_after}"
    );
    // The centre comes back: vx' = vx (1 - (1 + beta0) / (1 + 1/k)) = 2 (1 - 2/3.5) > 0
    // for a solid ball, and the spin is backspin (wz < 0 with this sign).
    let expected = 2.0 * (1.0 - 2.0 / 3.5);
    assert!(
        (i.velocity.linear.x - expected).abs() < 1e-12,
        "{}",
        i.velocity.linear.x
    );
    assert!(i.velocity.angular.z < 0.0);
    // Under a table (a ceiling, normal -y, touched at +r y) that backspin sends the ball back
    // towards the thrower, as Garwin's superball does; with Coulomb's stick (beta0 = 0) it
    // goes on forwards.
    let ceiling = Contact::fixed(-Vector3::y(), Vector3::new(0.0, b.r, 0.0));
    let under = |material: &Material| {
        let floor = resolve(Law::Guarded, &body, &velocity, &contact, material).unwrap();
        resolve(Law::Guarded, &body, &floor.velocity, &ceiling, material).unwrap()
    };
    let back = under(&material);
    // Closed form: the floor left the spin wz r = -4/1.4, so the ceiling meets the contact
    // velocity vx - wz r = 2 (1 - 2/3.5) + 4/1.4, and turns it round.
    let at_ceiling = expected + 4.0 / 1.4;
    let vx_back = expected - 2.0 * at_ceiling / 3.5;
    assert!(
        (back.velocity.linear.x - vx_back).abs() < 1e-12 && vx_back < 0.0,
        "{}",
        back.velocity.linear.x
    );
    let coulomb = under(&Material::new(0.9, 1.0));
    assert!(
        coulomb.velocity.linear.x > 0.0,
        "{}",
        coulomb.velocity.linear.x
    );
    // Elastic both ways (e = 1, beta0 = 1): the sphere keeps all its energy.
    let elastic = Material::new(1.0, 1.0).with_tangential_restitution(1.0);
    let k = resolve(Law::Guarded, &body, &velocity, &contact, &elastic).unwrap();
    assert_abs_diff_eq!(k.energy_change(), 0.0, epsilon = 1e-12 * k.ke_before);
}

#[test]
fn beta_minus_one_leaves_the_tangential_velocity_alone() {
    let b = Ball {
        m: 1.0,
        r: 0.1,
        k: 0.4,
    };
    for (vx, wz) in [(3.0, 0.0), (0.5, -20.0), (-1.0, 7.0)] {
        let (body, velocity, contact) = sphere_case(&b, vx, 2.0, wz);
        let material = Material::new(0.5, 0.4).with_tangential_restitution(-1.0);
        for law in LAWS {
            let i = resolve(law, &body, &velocity, &contact, &material).unwrap();
            assert!(
                i.tangent_impulse.norm() <= 1e-15,
                "{law:?}: {:?}",
                i.tangent_impulse
            );
            let tag = format!("{law:?}, v_x = {vx}, w_z = {wz}");
            assert!(
                abs_diff_eq!(i.velocity.linear.x, vx, epsilon = 1e-15),
                "{tag}: v_x after {:?}",
                i.velocity.linear.x
            );
            assert!(
                abs_diff_eq!(i.velocity.angular.z, wz, epsilon = 1e-13),
                "{tag}: w_z after {:?}",
                i.velocity.angular.z
            );
            assert!(
                abs_diff_eq!(i.velocity.linear.y, 1.0, epsilon = 1e-15),
                "{tag}: v_y after {:?}, expected 1",
                i.velocity.linear.y
            );
        }
    }
}

/// Two spheres: `a` at `(vn, vt, 0)` with spin `wza`, `b` at rest, touching along `+x`.
#[test]
fn two_spheres_meet_walton_closed_form() {
    let (ma, ra, mb, rb, k) = (0.17, 0.0286, 0.25, 0.04, 0.4);
    let (ia, ib) = (k * ma * ra * ra, k * mb * rb * rb);
    let a = Body::isotropic(ma, ia);
    let b = Body::isotropic(mb, ib);
    let contact = PairContact {
        normal: Vector3::x(),
        offset_a: Vector3::new(ra, 0.0, 0.0),
        offset_b: Vector3::new(-rb, 0.0, 0.0),
    };
    let (e, mu) = (0.93, 0.2);
    let (mut sticks, mut slips) = (0, 0);
    for &beta in &BETAS {
        for (vn, vt, wza) in [
            (2.0, 0.3, 0.0),
            (1.0, 1.5, 0.0),
            (1.5, 0.0, 30.0),
            (0.8, -0.4, -10.0),
        ] {
            let ut = vt + wza * ra;
            let knn = 1.0 / ma + 1.0 / mb;
            let ktt = knn + ra * ra / ia + rb * rb / ib;
            let pn = (1.0 + e) * vn / knn;
            let stick = (1.0 + beta) * ut / ktt;
            let (pt, sticking) = if stick.abs() <= mu * pn {
                (stick, true)
            } else {
                (mu * pn * ut.signum(), false)
            };
            let va2 = Vector3::new(vn - pn / ma, vt - pt / ma, 0.0);
            let vb2 = Vector3::new(pn / mb, pt / mb, 0.0);
            let (wa2, wb2) = (wza - ra * pt / ia, -rb * pt / ib);
            let va = BodyVelocity {
                linear: Vector3::new(vn, vt, 0.0),
                angular: Vector3::new(0.0, 0.0, wza),
            };
            let material = Material::new(e, mu).with_tangential_restitution(beta);
            for law in LAWS {
                let hit = resolve_pair(
                    law,
                    &a,
                    &va,
                    &b,
                    &BodyVelocity::default(),
                    &contact,
                    &material,
                )
                .unwrap();
                let scale = vn.hypot(vt) + wza.abs() * ra;
                let err = [
                    (hit.a.linear - va2).norm(),
                    (hit.b.linear - vb2).norm(),
                    (hit.a.angular.z - wa2).abs() * ra,
                    (hit.b.angular.z - wb2).abs() * rb,
                ]
                .into_iter()
                .fold(0.0f64, f64::max)
                    / scale;
                assert!(
                    err <= 1e-12,
                    "{law:?} beta {beta} ({vn}, {vt}, {wza}): relative error {err:e}; {hit:?}"
                );
                assert_eq!(
                    hit.regime != Regime::Slip,
                    sticking,
                    "{law:?} beta {beta} ({vn}, {vt}, {wza})"
                );
                assert!(hit.energy_change() <= 1e-12 * hit.ke_before);
            }
            if sticking {
                sticks += 1;
            } else {
                slips += 1;
            }
        }
    }
    assert!(
        sticks >= 5 && slips >= 5,
        "{sticks} sticking, {slips} slipping"
    );
}

#[test]
fn hard_cases_keep_the_guarantees() {
    let mut rng = Rng::new(0xB0_7A);
    let (mut jams, mut checked) = (0, 0);
    let check = |what: &str,
                 body: &Body,
                 velocity: &BodyVelocity,
                 contact: &Contact,
                 material: &Material| {
        let n = contact.normal;
        let un1 = n.dot(&(velocity.linear + velocity.angular.cross(&contact.offset)));
        let mut jam = false;
        for law in [Law::Consistent, Law::Guarded] {
            let i = resolve(law, body, velocity, contact, material).expect("valid input");
            let all = [i.impulse, i.velocity.linear, i.velocity.angular];
            assert!(
                all.iter().all(|v| v.iter().all(|x| x.is_finite())),
                "{what} {law:?}: {i:?}"
            );
            assert!(
                i.energy_change() <= 1e-12 * i.ke_before,
                "{what} {law:?}: gain {:e} of {:e}",
                i.energy_change(),
                i.ke_before
            );
            let bound =
                material.friction * i.normal_impulse * (1.0 + 1e-12) + 1e-15 * i.impulse.norm();
            assert!(
                i.normal_impulse >= 0.0 && i.tangent_impulse.norm() <= bound,
                "{what} {law:?}: outside the cone {i:?}"
            );
            let un2 = n.dot(&(i.velocity.linear + i.velocity.angular.cross(&contact.offset)));
            assert!(
                un2 >= -1e-12 * un1.abs(),
                "{what} {law:?}: approaches after, {un2:e}"
            );
            jam |= i.fallback == Some(Fallback::Jam);
        }
        jam
    };
    for beta in [-1.0, 1.0] {
        // Grazing: 89.9 degrees from the normal, with and without spin.
        let b = Ball {
            m: 1.0,
            r: 0.1,
            k: 0.4,
        };
        for wz in [0.0, 300.0, -300.0] {
            let a = 89.9f64.to_radians();
            let (body, velocity, contact) = sphere_case(&b, 5.0 * a.sin(), 5.0 * a.cos(), wz);
            check(
                "grazing",
                &body,
                &velocity,
                &contact,
                &Material::new(0.8, 0.4).with_tangential_restitution(beta),
            );
            checked += 1;
        }
        // Swerving slips: cube corners slipping across their offset.
        for _ in 0..200 {
            let corner = Vector3::new(rng.uniform(-0.5, 0.5), rng.uniform(-0.5, 0.5), -0.5);
            let across = Vector3::new(-corner.y, corner.x, 0.0).normalize() * rng.uniform(1.0, 3.0);
            let velocity = BodyVelocity {
                linear: across + Vector3::new(0.0, 0.0, rng.uniform(-3.0, -1.0)),
                angular: Vector3::zeros(),
            };
            let material = Material::new(rng.uniform(0.0, 1.0), rng.uniform(0.1, 0.3))
                .with_tangential_restitution(beta);
            check(
                "swerve",
                &Body::isotropic(1.0, 1.0 / 6.0),
                &velocity,
                &Contact::fixed(Vector3::z(), corner),
                &material,
            );
            checked += 1;
        }
        // Jams: thin and flat bodies with high friction, hit on their lower side.
        for _ in 0..40_000 {
            let (body, velocity, contact) = jam_prone_impact(&mut rng);
            let material = Material::new(rng.uniform(0.0, 1.0), rng.uniform(1.0, 3.0))
                .with_tangential_restitution(beta);
            if check("random", &body, &velocity, &contact, &material) {
                jams += 1;
            }
            checked += 1;
        }
    }
    assert!(jams >= 5, "only {jams} jams among {checked} hard cases");
    println!("{checked} hard cases, {jams} of them jams");
}

#[test]
fn guarded_falls_back_where_the_document_form_gains_energy() {
    // A long bar (radii of gyration 0.05, 1, 1 m) struck at one end, obliquely: the contact's
    // tangential and normal motions are coupled (K_tn != 0). With e = 1 and beta0 = -1 the
    // document's target u2 = (u_t, -u_n) changes the energy by -2 u_t u_n (K^-1)_tn, a gain
    // for one sign of the slip.
    let mass = 1.0;
    let moments = Vector3::new(mass * 0.05 * 0.05, mass, mass);
    let (body, _) = anisotropic_body(mass, &moments, &nalgebra_identity());
    let contact = Contact::fixed(Vector3::z(), Vector3::new(0.9, 0.0, -0.3));
    let material = Material::new(1.0, 5.0).with_tangential_restitution(-1.0);
    let mut fell_back = 0;
    for vx in [-2.0, -1.0, 1.0, 2.0] {
        let velocity = BodyVelocity {
            linear: Vector3::new(vx, 0.0, -2.0),
            angular: Vector3::zeros(),
        };
        let document = resolve(Law::Document, &body, &velocity, &contact, &material).unwrap();
        let guarded = resolve(Law::Guarded, &body, &velocity, &contact, &material).unwrap();
        assert!(guarded.energy_change() <= 1e-12 * guarded.ke_before);
        if document.energy_change() > 1e-9 * document.ke_before {
            assert_eq!(guarded.fallback, Some(Fallback::EnergyGain), "vx {vx}");
            assert_eq!(guarded.law, Law::Consistent);
            fell_back += 1;
        } else {
            assert_eq!(guarded, document, "vx {vx}");
        }
    }
    assert!(
        fell_back >= 1,
        "the document's form gained energy in no case"
    );
}

fn nalgebra_identity() -> rapier_impact::na::Matrix3<f64> {
    rapier_impact::na::Matrix3::identity()
}

#[test]
fn tangential_restitution_is_validated() {
    let body = Body::isotropic(1.0, 0.004);
    let (_, velocity, contact) = sphere_case(
        &Ball {
            m: 1.0,
            r: 0.1,
            k: 0.4,
        },
        1.0,
        1.0,
        0.0,
    );
    for beta in [1.0000001, -1.5, f64::NAN, f64::INFINITY] {
        let material = Material::new(0.5, 0.5).with_tangential_restitution(beta);
        let err = resolve(Law::Guarded, &body, &velocity, &contact, &material).unwrap_err();
        assert!(
            matches!(err, rapier_impact::model::ModelError::TangentialRestitutionOutOfRange(b) if b.to_bits() == beta.to_bits()),
            "{beta}: {err}"
        );
        assert!(err.to_string().contains("[-1, 1]"));
    }
}
