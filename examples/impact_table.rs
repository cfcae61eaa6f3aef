//! Prints a table of the three impact laws on named cases, with their energy change.
//!
//! ```text
//! cargo run --release --example impact_table
//! ```
//!
//! Every case is a single impact against a fixed ground with normal +z, resolved by
//! `rapier_impact::model::resolve`. The columns are the post-impact centre-of-mass
//! velocity, the angular velocity about the axis that matters for the case, the regime,
//! and the kinetic energy change in percent of the energy before.

use clap::Parser;
use rapier_impact::model::{Body, BodyVelocity, Contact, Law, Material, resolve};
use rapier_impact::na::{Matrix3, Rotation3, Vector3};

/// The three impact laws (document, consistent, guarded) side by side on named cases, each a
/// single impact against a fixed ground with normal +z: the velocity and spin after, the
/// regime, the kinetic energy change in percent, the fallback the guarded law took, and the
/// closed form expected. It has no flags.
#[derive(Parser, Debug)]
#[command(
    name = "impact_table",
    after_help = "Example: cargo run --release --example impact_table"
)]
struct Args {}

struct Case {
    name: &'static str,
    note: &'static str,
    body: Body,
    contact: Contact,
    velocity: BodyVelocity,
    material: Material,
}

fn cases() -> Vec<Case> {
    let z = Vector3::z();
    let mut out = Vec::new();

    // Solid sphere, m = 1 kg, R = 0.1 m: lands sliding at 5 m/s, 5 m/s down.
    let ball = Body::isotropic(1.0, 0.4 * 0.01);
    let ball_contact = Contact::fixed(z, Vector3::new(0.0, 0.0, -0.1));
    let landing = BodyVelocity {
        linear: Vector3::new(5.0, 0.0, -5.0),
        angular: Vector3::zeros(),
    };
    out.push(Case {
        name: "sphere, stick",
        note: "vx' = vx/(1+k) = 3.571429",
        body: ball,
        contact: ball_contact,
        velocity: landing,
        material: Material::new(0.8, 0.5),
    });
    out.push(Case {
        name: "sphere, slip",
        note: "vx' = vx - mu(1+e)|vz| = 4.1",
        body: ball,
        contact: ball_contact,
        velocity: landing,
        material: Material::new(0.8, 0.1),
    });

    // Thin rod, m = 1 kg, L = 1 m, at 45 deg, landing on its lower end (planar: only
    // rotation about y matters; inertia m L^2/12 about the perpendicular axes).
    let phi = std::f64::consts::FRAC_PI_4;
    let rod_axis = Vector3::new(phi.cos(), 0.0, phi.sin());
    let rod_inertia = {
        let i_perp = 1.0 / 12.0;
        let i_axial = 1e-6 * i_perp;
        let along = rod_axis * rod_axis.transpose();
        Matrix3::identity() * i_perp + along * (i_axial - i_perp)
    };
    let rod = Body::from_inertia(1.0, rod_inertia).expect("rod inertia is SPD");
    let rod_contact = Contact::fixed(z, -rod_axis * 0.5);
    out.push(Case {
        name: "rod 45 deg, frictionless",
        note: "Jn = (1+e) v m/(1+3cos^2) = 0.72",
        body: rod,
        contact: rod_contact,
        velocity: BodyVelocity {
            linear: Vector3::new(0.0, 0.0, -1.0),
            angular: Vector3::zeros(),
        },
        material: Material::new(0.8, 0.0),
    });
    out.push(Case {
        name: "rod 45 deg, energy gain",
        note: "document: KE 0.680 -> 0.7925",
        body: rod,
        contact: rod_contact,
        velocity: BodyVelocity {
            linear: Vector3::new(0.6, 0.0, -1.0),
            angular: Vector3::zeros(),
        },
        material: Material::new(1.0, 1.0),
    });

    // Unit cube, m = 1 kg, a = 1 m, tilted so a corner is lowest; isotropic I = m a^2/6.
    let cube = Body::isotropic(1.0, 1.0 / 6.0);
    let tilt = Rotation3::rotation_between(&Vector3::new(-1.0, -1.0, -1.0).normalize(), &-z)
        .expect("not antiparallel");
    let corner = tilt * Vector3::new(-0.5, -0.5, -0.5);
    let tilted_corner = Rotation3::from_axis_angle(&Vector3::y_axis(), 0.3) * corner;
    out.push(Case {
        name: "cube corner",
        note: "single-point impact",
        body: cube,
        contact: Contact::fixed(z, tilted_corner),
        velocity: BodyVelocity {
            linear: Vector3::new(1.0, 0.5, -3.0),
            angular: Vector3::new(0.0, 2.0, 0.0),
        },
        material: Material::new(0.5, 0.3),
    });

    // A swerving slip: the contact offset is not in the plane of the slip.
    out.push(Case {
        name: "cube corner, swerve",
        note: "3-D coupling turns the slip",
        body: cube,
        contact: Contact::fixed(z, tilted_corner),
        velocity: BodyVelocity {
            linear: Vector3::new(0.3, -0.4, -2.0),
            angular: Vector3::new(1.0, 0.0, 0.5),
        },
        material: Material::new(0.7, 0.6),
    });
    out
}

fn main() {
    // Nothing to set: parsed for `--help` and to refuse unknown flags.
    Args::parse();
    println!(
        "{:<26} {:<10} {:>10} {:>10} {:>10} {:>10} {:>14} {:>9} {:>12}  expected",
        "case", "law", "vx'", "vy'", "vz'", "wy'", "regime", "dKE %", "fallback"
    );
    for case in cases() {
        for law in [Law::Document, Law::Consistent, Law::Guarded] {
            let row = match resolve(
                law,
                &case.body,
                &case.velocity,
                &case.contact,
                &case.material,
            ) {
                Ok(impact) => {
                    let v = impact.velocity.linear;
                    let fallback = match impact.fallback {
                        Some(reason) => format!("{reason:?}"),
                        None => "-".to_string(),
                    };
                    format!(
                        "{:>10.6} {:>10.6} {:>10.6} {:>10.6} {:>14} {:>+9.3} {:>12}",
                        v.x,
                        v.y,
                        v.z,
                        impact.velocity.angular.y,
                        format!("{:?}", impact.regime),
                        100.0 * impact.energy_change() / impact.ke_before,
                        fallback
                    )
                }
                Err(err) => format!("error: {err}"),
            };
            println!(
                "{:<26} {:<10} {row}  {}",
                case.name,
                format!("{law:?}"),
                case.note
            );
        }
    }
    println!("\nfallback: why Guarded left the document's result for the consistent law.");
}
