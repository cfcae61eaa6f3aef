//! A hard case never freezes a body: under `Law::Document`, an impact where the document's
//! slip law has no solution (its eq. 19 denominator `<= 0`, the Painleve-like jam of
//! docs/model.md) is resolved by the consistent law, and the event says so.
//!
//! What went wrong: the adapter dropped the model's `Jam` error and wrote the body at the
//! contact with its approach velocity, step after step, with no event.

mod model_support;
mod plugin_support;

use model_support::{Rng, anisotropic_body};
use plugin_support::{MODES, real, wide};
use rapier_impact::model::{BodyVelocity, Contact, Fallback, Law, Material, ModelError, resolve};
use rapier_impact::na::{Matrix3, Rotation3, UnitQuaternion, Vector3};
use rapier_impact::rapier::prelude::*;
use rapier_impact::{EventKind, ImpactConfig, ImpactPlugin, ImpactTiming};

/// A body, a contact offset below its centre of mass and a velocity for which the document's
/// law jams on a ground with normal +y, by a clear margin (so that the few milliseconds of
/// flight to the contact do not undo it): found by a seeded search over random anisotropic
/// bodies with high friction.
struct Jam {
    mass: f64,
    moments: Vector3<f64>,
    axes: Matrix3<f64>,
    offset: Vector3<f64>,
    velocity: BodyVelocity,
    material: Material,
}

fn find_jam() -> Jam {
    let mut rng = Rng::new(0x7A11);
    let n = Vector3::y();
    for _ in 0..2_000_000 {
        let mass = 1.0;
        let moments = Vector3::new(
            mass * rng.uniform(0.02, 0.5).powi(2),
            mass * rng.uniform(0.02, 0.5).powi(2),
            mass * rng.uniform(0.02, 0.5).powi(2),
        );
        let axes = rng.rotation();
        let (body, _) = anisotropic_body(mass, &moments, &axes);
        let mut offset = rng.vector(0.5);
        offset.y = -offset.y.abs() - 0.02;
        let mut velocity = BodyVelocity {
            linear: rng.vector(3.0),
            angular: rng.vector(1.0),
        };
        // Approaching at 1 to 3 m/s at the contact point.
        let un = n.dot(&(velocity.linear + velocity.angular.cross(&offset)));
        velocity.linear -= n * (un + rng.uniform(1.0, 3.0));
        let material = Material::new(0.3, rng.uniform(1.0, 3.0));
        let contact = Contact::fixed(n, offset);
        if let Err(ModelError::Jam { denominator }) =
            resolve(Law::Document, &body, &velocity, &contact, &material)
        {
            if denominator < -0.2 / mass {
                return Jam {
                    mass,
                    moments,
                    axes,
                    offset,
                    velocity,
                    material,
                };
            }
        }
    }
    panic!("no jam found: the search must find one");
}

fn vector(v: &Vector3<f64>) -> Vector {
    Vector::new(real(v.x), real(v.y), real(v.z))
}

#[test]
fn a_jam_under_the_document_law_falls_back_to_the_consistent_law_and_says_so() {
    let jam = find_jam();
    // A small ball at the contact point carries the collision; the inertia is the body's own.
    let radius = 0.01;
    let gap = 1e-3;
    let frame = UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(jam.axes));
    for timing in MODES {
        let mut world = PhysicsWorld {
            gravity: Vector::ZERO,
            ..Default::default()
        };
        let (_, ground) = world.insert(
            RigidBodyBuilder::fixed(),
            ColliderBuilder::halfspace(plugin_support::up())
                .friction(real(jam.material.friction))
                .restitution(real(jam.material.restitution))
                .friction_combine_rule(CoefficientCombineRule::Max)
                .restitution_combine_rule(CoefficientCombineRule::Max),
        );
        let q = frame.quaternion();
        let principal_frame = Rotation::from_xyzw(real(q.i), real(q.j), real(q.k), real(q.w));
        let (body, _) = world.insert(
            RigidBodyBuilder::dynamic()
                .translation(Vector::new(0.0, real(-jam.offset.y + gap), 0.0))
                .linvel(vector(&jam.velocity.linear))
                .angvel(vector(&jam.velocity.angular))
                .additional_mass_properties(MassProperties::with_principal_inertia_frame(
                    Vector::ZERO,
                    real(jam.mass),
                    vector(&jam.moments),
                    principal_frame,
                )),
            ColliderBuilder::ball(real(radius))
                .translation(vector(&(jam.offset + Vector3::y() * radius)))
                .density(0.0)
                .friction(0.0)
                .restitution(0.0),
        );
        // rapier applies additional mass properties at its next step; the plugin needs the
        // mass in this one.
        world.bodies[body].recompute_mass_properties_from_colliders(&world.colliders);
        let mut plugin = ImpactPlugin::new(
            ImpactConfig::default()
                .with_law(Law::Document)
                .with_timing(timing),
        )
        .unwrap();
        plugin
            .add_ground(&world.bodies, &world.colliders, ground)
            .unwrap();
        plugin.step(&mut world);
        let impacts: Vec<_> = plugin
            .events()
            .iter()
            .filter(|e| e.kind == EventKind::Impact)
            .collect();
        assert!(
            !impacts.is_empty(),
            "{timing:?}: the jammed landing must be resolved, not dropped"
        );
        let e = impacts[0];
        println!(
            "{timing:?}: {:?} at {:?}, law {:?}, fallback {:?}, normal impulse {:.4} N s, KE {:.4} -> {:.4} J",
            e.regime, e.timing, e.law, e.fallback, e.normal_impulse, e.ke_before, e.ke_after
        );
        assert_eq!(
            (e.law, e.fallback),
            (Law::Consistent, Some(Fallback::Jam)),
            "{timing:?}: the event must say the jam fell back"
        );
        assert!(
            e.normal_impulse > 0.0 && e.ke_after <= e.ke_before * (1.0 + 1e-9),
            "{timing:?}: {e:?}"
        );
        if timing != rapier_impact::TimingMode::Step {
            assert_eq!(e.timing, ImpactTiming::InStep);
        }
        // Never a freeze at the contact: over the next half second the small ball never goes
        // deeper than rapier's allowed error, and the state stays finite.
        let allowed = wide(world.integration_parameters.allowed_linear_error());
        for _ in 0..30 {
            plugin.step(&mut world);
            let rb = &world.bodies[body];
            let centre = rb
                .position()
                .transform_point(vector(&(jam.offset + Vector3::y() * radius)));
            let depth = radius - wide(centre.y);
            assert!(
                depth <= allowed + 1e-6 && rb.linvel().is_finite() && rb.angvel().is_finite(),
                "{timing:?}: the ball is {depth:e} m deep (allowed {allowed:e})"
            );
        }
    }
}
