//! With the `serde-serialize` feature: the configuration, the materials, the events of a
//! real scene and the model's inputs and outputs survive a JSON round trip unchanged (every
//! `f64` bit for bit: serde_json writes the shortest representation that reads back to the
//! same number, and reads it back correctly rounded with its `float_roundtrip` feature); the model's errors serialize.
#![cfg(feature = "serde-serialize")]

use rapier_impact::model::seed::{SeedInput, solve};
use rapier_impact::model::{
    Body, BodyVelocity, Contact, Law, Material, ModelError, PairContact, resolve, resolve_pair,
};
use rapier_impact::na::{Matrix3, Vector3};
use rapier_impact::rapier::prelude::*;
use rapier_impact::{GroundMaterial, ImpactConfig, ImpactPlugin, RestitutionCurve, TimingMode};
use serde::Serialize;
use serde::de::DeserializeOwned;

#[track_caller]
fn round_trip<T: Serialize + DeserializeOwned + PartialEq + std::fmt::Debug>(value: &T) -> String {
    let json = serde_json::to_string(value).expect("serializes");
    let back: T = serde_json::from_str(&json).expect("deserializes");
    assert_eq!(&back, value, "through {json}");
    json
}

#[test]
fn configuration_and_materials_round_trip() {
    let config = ImpactConfig::default()
        .with_law(Law::Consistent)
        .with_timing(TimingMode::TimeOfImpact)
        .with_resting_speed(Some(0.0625))
        .with_resting_gap(None)
        .with_flat_tolerance(0.0123)
        .with_max_impacts_per_step(7)
        .with_rolling_resistance(0.015)
        .with_spinning_friction(0.02)
        .with_tangential_restitution(-0.35)
        .with_restitution_curve(Some(
            RestitutionCurve::new(vec![(0.2, 0.0), (0.2, 0.9), (7.5, 0.55)]).unwrap(),
        ));
    let json = round_trip(&config);
    assert!(json.contains("TimeOfImpact"), "{json}");
    // A curve is its points; one whose points are refused is refused on the way in too.
    assert!(json.contains("[[0.2,0.0],[0.2,0.9],[7.5,0.55]]"), "{json}");
    let unsorted = json.replace("[7.5,0.55]", "[0.1,0.55]");
    let err = serde_json::from_str::<ImpactConfig>(&unsorted).unwrap_err();
    assert!(
        err.to_string().contains("restitution curve point 2"),
        "{err}"
    );
    // A configuration written before the two fields existed reads with their defaults.
    let older = serde_json::to_string(&ImpactConfig::default())
        .unwrap()
        .replace(
            ",\"tangential_restitution\":0.0,\"restitution_curve\":null",
            "",
        );
    assert!(!older.contains("tangential"), "{older}");
    assert_eq!(
        serde_json::from_str::<ImpactConfig>(&older).unwrap(),
        ImpactConfig::default()
    );
    round_trip(&ImpactConfig::default());
    round_trip(&GroundMaterial::new(0.35, 1.0 / 3.0));
    round_trip(
        &GroundMaterial::new(0.35, 1.0 / 3.0)
            .with_rolling_resistance(0.012)
            .with_spinning_friction(0.3),
    );
    round_trip(
        &GroundMaterial::new(0.35, 1.0 / 3.0)
            .with_tangential_restitution(0.5)
            .with_restitution_curve(RestitutionCurve::threshold(1.0, 0.6).unwrap()),
    );
}

#[test]
fn model_inputs_and_outputs_round_trip() {
    let body = Body {
        mass: 0.17,
        inv_inertia: Matrix3::new(1.0 / 3.0, 0.1, 0.0, 0.1, 0.5, -0.02, 0.0, -0.02, 2.0),
    };
    let velocity = BodyVelocity {
        linear: Vector3::new(1.5, -2.25, 0.1),
        angular: Vector3::new(-3.0, 0.7, 11.0),
    };
    let contact = Contact::fixed(
        Vector3::new(0.0, 0.6, 0.8),
        Vector3::new(0.01, -0.03, -0.02),
    );
    let material = Material::new(0.8, 0.3).with_tangential_restitution(0.25);
    round_trip(&body);
    round_trip(&velocity);
    round_trip(&contact);
    round_trip(&material);
    for law in [Law::Document, Law::Consistent, Law::Guarded] {
        round_trip(&law);
        round_trip(&resolve(law, &body, &velocity, &contact, &material).unwrap());
    }
    let pair = PairContact {
        normal: Vector3::x(),
        offset_a: Vector3::new(0.0286, 0.0, 0.0),
        offset_b: Vector3::new(-0.0286, 0.0, 0.0),
    };
    round_trip(&pair);
    // JSON has no infinity: a fixed body's mass is written as null, and read back as an
    // error, not as a finite mass (a format with infinities, such as bincode, keeps it).
    let fixed = serde_json::to_string(&Body::fixed()).unwrap();
    assert!(serde_json::from_str::<Body>(&fixed).is_err(), "{fixed}");
    let hit = resolve_pair(
        Law::Guarded,
        &body,
        &velocity,
        &Body::fixed(),
        &BodyVelocity::default(),
        &pair,
        &material,
    )
    .unwrap();
    round_trip(&hit);
    let seed = SeedInput {
        mass: 1.0,
        inertia: 0.004,
        lx: 0.0,
        ly: 0.0,
        h: 0.1,
        friction: 0.5,
        restitution: 0.8,
        u1: Vector3::new(5.0, 0.0, -5.0),
        w1: Vector3::zeros(),
    };
    round_trip(&seed);
    round_trip(&solve(&seed).unwrap());
    // Errors serialize (for logs and reports), naming the field; they do not deserialize
    // (their field names are `&'static str`).
    let error = resolve(
        Law::Guarded,
        &body,
        &velocity,
        &Contact::fixed(Vector3::x() * 2.0, contact.offset),
        &material,
    )
    .unwrap_err();
    assert_eq!(error, ModelError::NonUnitNormal(2.0));
    assert_eq!(
        serde_json::to_string(&error).unwrap(),
        r#"{"NonUnitNormal":2.0}"#
    );
    let nan = BodyVelocity {
        linear: Vector3::new(f64::NAN, 0.0, 0.0),
        ..velocity
    };
    let error = resolve(Law::Guarded, &body, &nan, &contact, &material).unwrap_err();
    assert_eq!(
        serde_json::to_string(&error).unwrap(),
        r#"{"NotFinite":{"what":"velocity.linear"}}"#
    );
}

#[test]
fn the_events_of_a_scene_round_trip() {
    let mut world = PhysicsWorld::default();
    let (_, ground) = world.insert(
        RigidBodyBuilder::fixed(),
        ColliderBuilder::cuboid(10.0, 0.5, 10.0).translation(Vector::new(0.0, -0.5, 0.0)),
    );
    world.insert(
        RigidBodyBuilder::dynamic()
            .translation(Vector::new(0.0, 1.1, 0.0))
            .linvel(Vector::new(2.0, 0.0, 0.0))
            .angvel(Vector::new(0.0, 0.0, 5.0)),
        ColliderBuilder::ball(0.1).restitution(0.8).friction(0.5),
    );
    let mut plugin = ImpactPlugin::new(ImpactConfig::default()).unwrap();
    plugin
        .add_ground(&world.bodies, &world.colliders, ground)
        .unwrap();
    let mut seen = 0;
    for _ in 0..120 {
        plugin.step(&mut world);
        for event in plugin.events() {
            round_trip(event);
            seen += 1;
        }
    }
    assert!(seen >= 3, "the ball bounced: {seen} events");
}
