//! Headless Bevy apps for the tests and their measurements: the core crate's drop scene
//! (a ball of radius 0.1 m dropped from 1 m onto a half-space, e = 0.8, mu = 0.5, g = 9.81)
//! spawned as bevy_rapier entities, the messages recorded, the ball's state read from the
//! rapier set (the exact `f32` values, not the written-back `Transform`).

#![allow(dead_code)]

use bevy::ecs::system::SystemParam;
use bevy::prelude::*;
use bevy::time::TimeUpdateStrategy;
use bevy_rapier_impact::{
    Ground, ImpactConfig, ImpactErrorMessage, ImpactMessage, ImpactSettings, ImpactSimulation,
    RapierImpactPlugin,
};
use bevy_rapier3d::pipeline::{
    BevyPhysicsHooks, ContactModificationContextView, PairFilterContextView,
};
use bevy_rapier3d::prelude::*;
use std::sync::Mutex;
use std::time::Duration;

pub const H0: f64 = 1.0;
pub const E: f64 = 0.8;
pub const RADIUS: f64 = 0.1;
pub const G: f64 = 9.81;

/// Apex `n` of the closed form: `e^(2n) h0`.
pub fn apex(n: usize) -> f64 {
    E.powi(2 * n as i32) * H0
}

/// Impact `k` (from 0) of the closed form: `t1 + 2 t1 e (1 - e^k)/(1 - e)`.
pub fn impact_time(k: usize) -> f64 {
    let t1 = (2.0 * H0 / G).sqrt();
    t1 + 2.0 * t1 * E * (1.0 - E.powi(k as i32)) / (1.0 - E)
}

/// Messages recorded by the app, in order.
#[derive(Resource, Default)]
pub struct Recorded {
    pub impacts: Vec<ImpactMessage>,
    pub errors: Vec<ImpactErrorMessage>,
}

fn record(
    mut rec: ResMut<Recorded>,
    mut impacts: MessageReader<ImpactMessage>,
    mut errors: MessageReader<ImpactErrorMessage>,
) {
    rec.impacts.extend(impacts.read().copied());
    rec.errors.extend(errors.read().cloned());
}

/// An app with bevy's minimal plugins (no window), the impact plugin with the hooks `H`, a
/// frame of `frame` seconds of `Time`, and `mode` as bevy_rapier's timestep mode.
pub fn app<H>(plugin: RapierImpactPlugin<H>, mode: TimestepMode, frame: f64) -> App
where
    H: 'static + BevyPhysicsHooks,
    for<'w, 's> bevy::ecs::system::SystemParamItem<'w, 's, H>: BevyPhysicsHooks,
{
    app_with(plugin, mode, frame, |_| {})
}

/// [`app`], with `more` adding the test's own plugins before the app is finished.
pub fn app_with<H>(
    plugin: RapierImpactPlugin<H>,
    mode: TimestepMode,
    frame: f64,
    more: impl FnOnce(&mut App),
) -> App
where
    H: 'static + BevyPhysicsHooks,
    for<'w, 's> bevy::ecs::system::SystemParamItem<'w, 's, H>: BevyPhysicsHooks,
{
    let mut app = App::new();
    app.add_plugins((MinimalPlugins, TransformPlugin, plugin));
    more(&mut app);
    app.insert_resource(mode)
        .insert_resource(TimeUpdateStrategy::ManualDuration(Duration::from_secs_f64(
            frame,
        )))
        .init_resource::<Recorded>()
        .add_systems(Last, record);
    app.finish();
    app.cleanup();
    app
}

/// The default plugin: `Exact` mode, no user hooks.
pub fn plugin() -> RapierImpactPlugin<NoUserData> {
    RapierImpactPlugin::new(ImpactConfig::default()).unwrap()
}

/// The drop scene's ground: a half-space at y = 0 (marked `Ground` if `ground`).
pub fn spawn_ground(app: &mut App, ground: bool) -> Entity {
    let mut e = app.world_mut().spawn((
        Transform::default(),
        Collider::halfspace(Vec3::Y).unwrap(),
        Restitution::coefficient(E as f32),
        Friction::coefficient(0.5),
    ));
    if ground {
        e.insert(Ground);
    }
    e.id()
}

/// The drop scene's ball, its bottom `H0` above the ground.
pub fn spawn_ball(app: &mut App) -> Entity {
    app.world_mut()
        .spawn((
            Transform::from_xyz(0.0, (RADIUS + H0) as f32, 0.0),
            RigidBody::Dynamic,
            Collider::ball(RADIUS as f32),
            Restitution::coefficient(E as f32),
            Friction::coefficient(0.5),
        ))
        .id()
}

/// The ball's rapier state: centre of mass and linear velocity.
pub fn ball_state(app: &mut App, ball: Entity) -> (Vec3, Vec3) {
    let handle = app.world().get::<RapierRigidBodyHandle>(ball).unwrap().0;
    let mut q = app.world_mut().query::<&RapierRigidBodySet>();
    let set = q.single(app.world()).unwrap();
    let rb = &set.bodies[handle];
    (rb.center_of_mass(), rb.linvel())
}

/// The rapier collider handle bevy_rapier gave an entity.
pub fn collider_handle(app: &App, e: Entity) -> bevy_rapier3d::rapier::prelude::ColliderHandle {
    app.world().get::<RapierColliderHandle>(e).unwrap().0
}

/// The default context's entity and its impact state.
pub fn context(app: &mut App) -> Entity {
    let mut q = app
        .world_mut()
        .query_filtered::<Entity, With<DefaultRapierContext>>();
    q.single(app.world()).unwrap()
}

pub fn simulation(app: &mut App) -> &ImpactSimulation {
    let ctx = context(app);
    app.world().get::<ImpactSimulation>(ctx).unwrap()
}

pub fn settings(app: &mut App) -> Mut<'_, ImpactSettings> {
    app.world_mut().resource_mut::<ImpactSettings>()
}

/// The apex of each flight after a bounce, from one sample of the ball's centre height and
/// vertical speed per step or frame: `y - R + vy^2/(2g)` at the flight's highest sample
/// (exact for ballistic flight, whatever the sample).
#[derive(Debug, Default)]
pub struct Apexes {
    pub apexes: Vec<f64>,
    top: Option<(f64, f64)>,
    prev_vy: f64,
    flights: usize,
}

impl Apexes {
    pub fn sample(&mut self, y: f64, vy: f64) {
        // A bounce: the flight before it ends (the drop itself is not a flight after one).
        if self.prev_vy < 0.0
            && vy > 0.0
            && let Some((ty, tvy)) = self.top.take()
        {
            if self.flights > 0 {
                self.apexes.push(ty - RADIUS + tvy * tvy / (2.0 * G));
            }
            self.flights += 1;
        }
        if vy.abs() > 1e-9 && self.top.is_none_or(|(ty, _)| y > ty) {
            self.top = Some((y, vy));
        }
        self.prev_vy = vy;
    }
}

/// A drop's apexes after each bounce and its impact times, one sample per frame.
#[derive(Debug, Default)]
pub struct Bounces {
    pub apexes: Vec<f64>,
    pub impacts: Vec<f64>,
}

/// Runs `frames` frames of a drop app and measures its bounces: [`Apexes`] sampled once a
/// frame; impact times are the messages' `step * dt + time`.
pub fn measure(app: &mut App, ball: Entity, frames: usize, dt: f64) -> Bounces {
    let mut apexes = Apexes::default();
    for _ in 0..frames {
        app.update();
        let (c, v) = ball_state(app, ball);
        apexes.sample(f64::from(c.y), f64::from(v.y));
    }
    let rec = app.world().resource::<Recorded>();
    let impacts = rec
        .impacts
        .iter()
        .filter(|m| m.event.kind == bevy_rapier_impact::EventKind::Impact && !m.event.settled)
        .map(|m| m.step as f64 * dt + m.event.time)
        .collect();
    Bounces {
        apexes: apexes.apexes,
        impacts,
    }
}

/// Ball states at the start of each rapier step, recorded by the user's intersection filter
/// on a sensor around the scene (rapier asks it once per step while the ball is awake).
#[derive(Resource, Default)]
pub struct StepTrace(pub Mutex<Vec<[u32; 6]>>);

/// Hook calls, and the collider whose contacts the user refuses.
#[derive(Resource)]
pub struct HookLog {
    pub contact_calls: Mutex<usize>,
    pub modify_calls: Mutex<usize>,
    pub ghost: Entity,
}

impl HookLog {
    /// Counts the calls; refuses the contacts of `ghost`.
    pub fn refusing(ghost: Entity) -> Self {
        Self {
            contact_calls: Mutex::new(0),
            modify_calls: Mutex::new(0),
            ghost,
        }
    }
}

/// The user's Bevy hooks in the tests: records the ball's state from the sensor's
/// intersection filter, counts contact filter calls and refuses the ghost's contacts.
#[derive(SystemParam)]
pub struct TestHooks<'w> {
    pub trace: Option<Res<'w, StepTrace>>,
    pub log: Option<Res<'w, HookLog>>,
}

impl BevyPhysicsHooks for TestHooks<'_> {
    fn filter_contact_pair(&self, context: PairFilterContextView) -> Option<SolverFlags> {
        let Some(log) = &self.log else {
            return Some(SolverFlags::COMPUTE_RIGID_IMPULSES);
        };
        *log.contact_calls.lock().unwrap() += 1;
        if context.collider1() == log.ghost || context.collider2() == log.ghost {
            None
        } else {
            Some(SolverFlags::COMPUTE_RIGID_IMPULSES)
        }
    }

    fn modify_solver_contacts(&self, _context: ContactModificationContextView) {
        if let Some(log) = &self.log {
            *log.modify_calls.lock().unwrap() += 1;
        }
    }

    fn filter_intersection_pair(&self, context: PairFilterContextView) -> bool {
        if let Some(trace) = &self.trace {
            let raw = context.raw;
            for rb in [raw.rigid_body1, raw.rigid_body2].into_iter().flatten() {
                let body = &raw.bodies[rb];
                let (p, v) = (body.translation(), body.linvel());
                trace.0.lock().unwrap().push([
                    p.x.to_bits(),
                    p.y.to_bits(),
                    p.z.to_bits(),
                    v.x.to_bits(),
                    v.y.to_bits(),
                    v.z.to_bits(),
                ]);
            }
        }
        true
    }
}
