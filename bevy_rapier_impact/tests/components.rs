//! The per-entity components in headless Bevy apps, each added, changed and removed (the
//! core plugin's state read through `ImpactSimulation::plugin()`, the impacts through their
//! messages), a refused value reported once; their reflection; the debug plugin with Bevy's
//! gizmos and without them.

mod support;

use bevy::prelude::*;
use bevy_rapier_impact::rapier_impact::RollingSettings;
use bevy_rapier_impact::rapier_impact::model::ModelError;
use bevy_rapier_impact::{
    ConfigError, EventKind, Ground, GroundMaterial, ImpactBody, ImpactEvent, ImpactSettings,
    ImpactSimulation, RestitutionBySpeed, RestitutionCurve, Rolling, TangentialRestitution,
};
use bevy_rapier3d::prelude::*;
use std::any::TypeId;
use support::*;

const DT: f64 = 1.0 / 60.0;

fn new_app() -> App {
    app(
        plugin(),
        TimestepMode::Fixed {
            dt: DT as f32,
            substeps: 1,
        },
        DT,
    )
}

/// Runs frames until an impact message arrives (recorded messages cleared first).
fn next_impact(app: &mut App) -> ImpactEvent {
    app.world_mut().resource_mut::<Recorded>().impacts.clear();
    for _ in 0..120 {
        app.update();
        let rec = app.world().resource::<Recorded>();
        if let Some(m) = rec
            .impacts
            .iter()
            .find(|m| m.event.kind == EventKind::Impact)
        {
            return m.event;
        }
    }
    panic!("no impact in 2 s");
}

/// The errors recorded so far, taken.
fn take_errors(app: &mut App) -> Vec<(Option<Entity>, ConfigError)> {
    let mut rec = app.world_mut().resource_mut::<Recorded>();
    rec.errors.drain(..).map(|m| (m.entity, m.error)).collect()
}

/// A ball of the drop scene, its bottom `h` above the ground.
fn ball_at(app: &mut App, h: f32) -> Entity {
    let ball = spawn_ball(app);
    app.world_mut()
        .entity_mut(ball)
        .insert(Transform::from_xyz(0.0, RADIUS as f32 + h, 0.0));
    ball
}

fn body_handle(app: &App, e: Entity) -> bevy_rapier3d::rapier::prelude::RigidBodyHandle {
    app.world().get::<RapierRigidBodyHandle>(e).unwrap().0
}

#[test]
fn ground_material_is_given_changed_refused_and_taken_back() {
    let mut app = new_app();
    // The material alone: `Ground` comes with it (a required component).
    let material = GroundMaterial::new(0.5, 0.3).with_rolling_resistance(0.02);
    let ground = app
        .world_mut()
        .spawn((
            Transform::default(),
            Collider::halfspace(Vec3::Y).unwrap(),
            Restitution::coefficient(E as f32),
            Friction::coefficient(0.5),
            material.clone(),
        ))
        .id();
    ball_at(&mut app, 0.2);
    app.update();
    assert!(app.world().get::<Ground>(ground).is_some(), "no Ground");
    let h = collider_handle(&app, ground);
    let given = |app: &mut App| simulation(app).plugin().unwrap().ground_material(h);
    assert_eq!(given(&mut app), Some(material.to_core().unwrap()), "added");
    let hit = next_impact(&mut app);
    assert_eq!((hit.restitution, hit.friction), (0.5, 0.3), "first impact");

    // Changed: a restitution curve, used from the next impact on.
    let points = vec![(0.0, 0.9), (10.0, 0.6)];
    app.world_mut()
        .get_mut::<GroundMaterial>(ground)
        .unwrap()
        .restitution_curve = Some(points.clone());
    let hit = next_impact(&mut app);
    let curve = RestitutionCurve::new(points).unwrap();
    assert_eq!(
        given(&mut app).and_then(|m| m.restitution_curve),
        Some(curve.clone())
    );
    assert_eq!(hit.restitution, curve.at(hit.approach_speed), "curve's e");

    // Refused (once, over several frames): the ground keeps the material it had.
    app.world_mut()
        .get_mut::<GroundMaterial>(ground)
        .unwrap()
        .restitution = 20.0;
    app.update();
    app.update();
    let errors = take_errors(&mut app);
    println!("refused material: {errors:?}");
    assert!(
        matches!(
            errors.as_slice(),
            [(Some(e), ConfigError::MaterialOutOfRange { field: "restitution", .. })]
                if *e == ground
        ),
        "{errors:?}"
    );
    assert_eq!(given(&mut app).map(|m| m.restitution), Some(0.5), "kept");

    // Removed: still a ground, with rapier's combined coefficients again.
    app.world_mut()
        .entity_mut(ground)
        .remove::<GroundMaterial>();
    let hit = next_impact(&mut app);
    assert!(simulation(&mut app).plugin().unwrap().is_ground(h));
    assert_eq!(given(&mut app), None, "removed");
    assert_eq!(
        (hit.restitution, hit.friction),
        (f64::from(E as f32), 0.5),
        "rapier's coefficients"
    );
    // Ground removed too: no longer a ground; no error at all from these changes.
    app.world_mut().entity_mut(ground).remove::<Ground>();
    app.update();
    assert!(!simulation(&mut app).plugin().unwrap().is_ground(h));
    assert_eq!(take_errors(&mut app), vec![]);
}

#[test]
fn impact_body_marker_opts_bodies_in_and_out() {
    let mut app = new_app();
    // Two balls high above everything, thrown at each other: they meet in 0.2 s.
    let ball = |app: &mut App, x: f32, vx: f32| {
        app.world_mut()
            .spawn((
                Transform::from_xyz(x, 5.0, 0.0),
                RigidBody::Dynamic,
                Collider::ball(RADIUS as f32),
                Restitution::coefficient(E as f32),
                Velocity::linear(Vec3::new(vx, 0.0, 0.0)),
                ImpactBody,
            ))
            .id()
    };
    let (a, b) = (ball(&mut app, -0.5, 2.0), ball(&mut app, 0.5, -2.0));
    // A fixed body is refused, then taken once it is dynamic.
    let c = app
        .world_mut()
        .spawn((
            Transform::from_xyz(3.0, 0.0, 0.0),
            RigidBody::Fixed,
            Collider::ball(RADIUS as f32),
            ImpactBody,
        ))
        .id();
    app.update();
    let is_impact = |app: &mut App, e: Entity| {
        let h = body_handle(app, e);
        let ctx = context(app);
        let sim = app.world().get::<ImpactSimulation>(ctx).unwrap();
        let set = app.world().get::<RapierRigidBodySet>(ctx).unwrap();
        sim.plugin().unwrap().is_impact_body(&set.bodies, h)
    };
    assert!(is_impact(&mut app, a) && is_impact(&mut app, b), "added");
    let errors = take_errors(&mut app);
    assert_eq!(
        errors,
        vec![(Some(c), ConfigError::NotDynamic(body_handle(&app, c)))]
    );
    let hit = next_impact(&mut app);
    let rec = app.world().resource::<Recorded>();
    let pair = rec
        .impacts
        .iter()
        .find(|m| m.body == a)
        .expect("no message for the first ball");
    println!("impact between bodies: {pair:?}");
    assert_eq!(
        (pair.body2, pair.ground),
        (Some(b), b),
        "the other body and its collider"
    );
    assert!(hit.normal_impulse > 0.0);

    // Removed from one ball: it is out, the other stays in.
    app.world_mut().entity_mut(a).remove::<ImpactBody>();
    app.world_mut().entity_mut(c).insert(RigidBody::Dynamic);
    app.update();
    assert!(!is_impact(&mut app, a), "removed");
    assert!(is_impact(&mut app, b), "the other one");
    assert!(is_impact(&mut app, c), "dynamic now");
    assert_eq!(take_errors(&mut app), vec![]);
}

#[test]
fn a_body_s_own_settings_are_given_changed_refused_and_taken_back() {
    let mut app = new_app();
    let ball = spawn_ball(&mut app);
    app.world_mut().entity_mut(ball).insert((
        Rolling::new(0.02, 0.01),
        TangentialRestitution(0.5),
        RestitutionBySpeed(vec![(0.0, 0.9), (5.0, 0.7)]),
    ));
    app.update();
    let h = body_handle(&app, ball);
    let rolling = |app: &mut App| simulation(app).plugin().unwrap().body_rolling(h);
    let curve = |app: &mut App| {
        simulation(app)
            .plugin()
            .unwrap()
            .body_restitution_curve(h)
            .cloned()
    };
    assert_eq!(rolling(&mut app), Some(RollingSettings::new(0.02, 0.01)));
    assert_eq!(
        curve(&mut app),
        Some(RestitutionCurve::new(vec![(0.0, 0.9), (5.0, 0.7)]).unwrap())
    );

    // Changed.
    app.world_mut()
        .get_mut::<Rolling>(ball)
        .unwrap()
        .rolling_resistance = 0.05;
    app.update();
    assert_eq!(rolling(&mut app), Some(RollingSettings::new(0.05, 0.01)));

    // Refused, once each: a coefficient out of range, points out of order. The body keeps
    // what it had; its other settings are unaffected.
    app.world_mut().entity_mut(ball).insert((
        Rolling::new(-1.0, 0.01),
        RestitutionBySpeed(vec![(5.0, 0.9), (1.0, 0.7)]),
    ));
    app.update();
    app.update();
    let errors = take_errors(&mut app);
    println!("refused: {errors:?}");
    assert_eq!(errors.len(), 2, "{errors:?}");
    assert!(errors.contains(&(
        Some(ball),
        ConfigError::Material(ModelError::InvalidCurvePoint {
            index: 1,
            speed: 1.0,
            restitution: 0.7
        })
    )));
    assert!(errors.iter().any(|(e, error)| *e == Some(ball)
        && matches!(
            error,
            ConfigError::InvalidBodySetting {
                setter: "set_body_rolling",
                field: "rolling_resistance",
                ..
            }
        )));
    assert_eq!(rolling(&mut app), Some(RollingSettings::new(0.05, 0.01)));
    assert!(curve(&mut app).is_some());
    let beta = |app: &mut App| {
        simulation(app)
            .plugin()
            .unwrap()
            .body_tangential_restitution(h)
    };
    assert_eq!(beta(&mut app), Some(0.5));

    // One removed: only its setting is taken back. Then the entity: all of them.
    app.world_mut().entity_mut(ball).remove::<Rolling>();
    app.update();
    assert_eq!(rolling(&mut app), None);
    assert_eq!(beta(&mut app), Some(0.5));
    app.world_mut().entity_mut(ball).despawn();
    app.update();
    assert_eq!((beta(&mut app), curve(&mut app)), (None, None), "despawned");
    assert_eq!(take_errors(&mut app), vec![]);
}

#[test]
fn components_resource_and_messages_are_reflected_and_an_edit_by_reflection_applies() {
    let mut app = new_app();
    let registry = app.world().resource::<AppTypeRegistry>().clone();
    {
        let registry = registry.read();
        let components = [
            TypeId::of::<Ground>(),
            TypeId::of::<GroundMaterial>(),
            TypeId::of::<ImpactBody>(),
            TypeId::of::<TangentialRestitution>(),
            TypeId::of::<RestitutionBySpeed>(),
            TypeId::of::<Rolling>(),
            TypeId::of::<ImpactSimulation>(),
        ];
        for id in components {
            let reg = registry.get(id).expect("not registered");
            assert!(
                reg.data::<ReflectComponent>().is_some(),
                "{}",
                reg.type_info().type_path()
            );
        }
        assert!(
            registry
                .get_type_data::<ReflectResource>(TypeId::of::<ImpactSettings>())
                .is_some()
        );
        for id in [
            TypeId::of::<bevy_rapier_impact::ImpactMessage>(),
            TypeId::of::<bevy_rapier_impact::ImpactErrorMessage>(),
        ] {
            assert!(registry.get(id).is_some(), "message not registered");
        }
    }
    // As an inspector edits a field: through `ReflectComponent`, in place.
    let ground = spawn_ground(&mut app, true);
    app.world_mut()
        .entity_mut(ground)
        .insert(GroundMaterial::new(0.5, 0.3));
    app.update();
    {
        let registry = registry.read();
        let reflect = registry
            .get_type_data::<ReflectComponent>(TypeId::of::<GroundMaterial>())
            .unwrap();
        let mut material = reflect
            .reflect_mut(app.world_mut().entity_mut(ground))
            .unwrap();
        *material.path_mut::<f64>("restitution").unwrap() = 0.25;
        *material
            .path_mut::<Option<Vec<(f64, f64)>>>("restitution_curve")
            .unwrap() = Some(vec![(0.0, 0.4)]);
    }
    app.update();
    let h = collider_handle(&app, ground);
    let m = simulation(&mut app)
        .plugin()
        .unwrap()
        .ground_material(h)
        .unwrap();
    assert_eq!(m.restitution, 0.25);
    assert_eq!(
        m.restitution_curve,
        Some(RestitutionCurve::new([(0.0, 0.4)]).unwrap())
    );
}

#[cfg(feature = "debug-plugin")]
#[test]
fn debug_plugin_draws_the_impacts_with_gizmos_and_is_inert_without_them() {
    use bevy::asset::AssetPlugin;
    use bevy::gizmos::{GizmoAsset, GizmoHandles, GizmoPlugin};
    use bevy::mesh::MeshPlugin;
    use bevy_rapier_impact::{ImpactDebugPlugin, ImpactGizmos};

    let mode = TimestepMode::Fixed {
        dt: DT as f32,
        substeps: 1,
    };
    // Headless, with what Bevy's gizmos need beyond `MinimalPlugins`: assets, meshes (for
    // its skinned-mesh bounds) and the gizmo plugin.
    let mut app = app_with(plugin(), mode, DT, |app| {
        app.add_plugins((
            AssetPlugin::default(),
            MeshPlugin,
            GizmoPlugin,
            ImpactDebugPlugin,
        ));
    });
    spawn_ground(&mut app, true);
    ball_at(&mut app, 0.2);
    let lines = |app: &App| {
        let handles = app.world().resource::<GizmoHandles>();
        let handle = handles
            .handles()
            .get(&TypeId::of::<ImpactGizmos>())?
            .clone()?;
        let assets = app.world().resource::<Assets<GizmoAsset>>();
        Some(assets.get(&handle)?.buffer().list_positions.len())
    };
    assert_eq!(lines(&app), None, "drawn before any impact");
    next_impact(&mut app);
    let drawn = lines(&app);
    println!("line vertices drawn in the frame of the first impact: {drawn:?}");
    assert!(drawn.is_some_and(|n| n > 0), "nothing drawn");
    // Still drawn within its lifetime (1 s), no longer after it.
    for _ in 0..10 {
        app.update();
    }
    assert!(
        lines(&app).is_some_and(|n| n > 0),
        "gone within its lifetime"
    );
    app.world_mut()
        .resource_mut::<GizmoConfigStore>()
        .config_mut::<ImpactGizmos>()
        .1
        .lifetime = 0.0;
    // Frames without an impact: the ball is in flight (0.18 s after the first bounce).
    app.update();
    assert_eq!(lines(&app), None, "drawn after its lifetime");

    // `MinimalPlugins` alone: the plugin adds nothing and the app runs.
    let mut bare = app_with(plugin(), mode, DT, |app| {
        app.add_plugins(ImpactDebugPlugin);
    });
    spawn_ground(&mut bare, true);
    ball_at(&mut bare, 0.2);
    next_impact(&mut bare);
    assert!(!bare.world().contains_resource::<GizmoConfigStore>());
}
