//! [`RapierImpactPlugin`]: bevy_rapier's plugin with its step replaced by one that runs the
//! core plugin around every rapier step.
//!
//! Contract: building it adds bevy_rapier's `RapierPhysicsPlugin` (in the same schedule, with
//! its `SyncBackend` and `Writeback` systems and without its `StepSimulation` one), the
//! [`ImpactSettings`] resource (unless the app has one), the messages, [`ImpactSimulation`]
//! as a required component of every rapier context, the reflection of every public
//! component, resource and message of the crate (`App::register_type`), and, in
//! `PhysicsSet::StepSimulation`, the set [`ImpactSet::Step`]: the step system, then the
//! quarantine's mirror.

use crate::components::{
    Ground, GroundMaterial, ImpactBody, ImpactSettings, ImpactSimulation, RestitutionBySpeed,
    Rolling, TangentialRestitution,
};
use crate::messages::{ImpactErrorMessage, ImpactMessage};
use crate::step::{mirror_quarantine, step_with_impacts};
use bevy::ecs::intern::Interned;
use bevy::ecs::schedule::ScheduleLabel;
use bevy::ecs::system::SystemParamItem;
use bevy::platform::collections::HashSet;
use bevy::prelude::*;
use bevy_rapier3d::pipeline::BevyPhysicsHooks;
use bevy_rapier3d::plugin::context::RapierContextSimulation;
use bevy_rapier3d::plugin::{NoUserData, PhysicsSet, RapierPhysicsPlugin};
use rapier_impact::{ConfigError, ImpactConfig};
use std::marker::PhantomData;

/// The set of the plugin's systems, inside bevy_rapier's `PhysicsSet::StepSimulation`.
#[derive(SystemSet, Debug, Clone, PartialEq, Eq, Hash)]
pub enum ImpactSet {
    /// The rapier steps of the frame, each between `before_step` and `after_step`, and the
    /// [`ImpactMessage`]s; then the quarantine mirrored on the entities.
    Step,
}

/// How the user adjusts bevy_rapier's plugin before it is added.
type RapierSetup =
    Box<dyn Fn(RapierPhysicsPlugin<NoUserData>) -> RapierPhysicsPlugin<NoUserData> + Send + Sync>;

/// bevy_rapier's physics with ground impacts resolved by the impact model. Add it instead of
/// `RapierPhysicsPlugin`: it adds that plugin itself, with its step replaced.
///
/// `H` is the app's own `BevyPhysicsHooks` (what it would give `RapierPhysicsPlugin<H>`);
/// it is called for every pair the plugin does not take, as bevy_rapier would call it.
///
/// ```no_run
/// use bevy::prelude::*;
/// use bevy_rapier3d::prelude::*;
/// use bevy_rapier_impact::{Ground, ImpactConfig, ImpactMessage, RapierImpactPlugin};
///
/// fn setup(mut commands: Commands) {
///     commands.spawn((Transform::default(), Collider::halfspace(Vec3::Y).unwrap(), Ground));
///     commands.spawn((
///         Transform::from_xyz(0.0, 1.1, 0.0),
///         RigidBody::Dynamic,
///         Collider::ball(0.1),
///         Restitution::coefficient(0.8),
///     ));
/// }
///
/// fn bounces(mut impacts: MessageReader<ImpactMessage>) {
///     for m in impacts.read() {
///         println!("{:?} hit {:?}: {:.3} N s", m.body, m.ground, m.event.normal_impulse);
///     }
/// }
///
/// App::new()
///     .add_plugins((MinimalPlugins, TransformPlugin))
///     .add_plugins(RapierImpactPlugin::<NoUserData>::new(ImpactConfig::default()).unwrap())
///     .add_systems(Startup, setup)
///     .add_systems(Update, bounces)
///     .run();
/// ```
pub struct RapierImpactPlugin<H = NoUserData> {
    settings: ImpactSettings,
    schedule: Interned<dyn ScheduleLabel>,
    rapier: RapierSetup,
    _hooks: PhantomData<fn() -> H>,
}

impl<H> RapierImpactPlugin<H>
where
    H: 'static + BevyPhysicsHooks,
    for<'w, 's> SystemParamItem<'w, 's, H>: BevyPhysicsHooks,
{
    /// The plugin with `config`, checked here (`ConfigError` for a value out of range). Its
    /// systems run in `PostUpdate`, bevy_rapier's default.
    pub fn new(config: ImpactConfig) -> Result<Self, ConfigError> {
        config.validate()?;
        Ok(Self {
            settings: ImpactSettings {
                config,
                all_fixed_colliders_ground: false,
            },
            schedule: PostUpdate.intern(),
            rapier: Box::new(|rapier| rapier),
            _hooks: PhantomData,
        })
    }

    /// Every fixed collider is ground, without a [`crate::Ground`] marker (the initial value
    /// of [`ImpactSettings::all_fixed_colliders_ground`]).
    pub fn with_all_fixed_colliders_ground(mut self, enabled: bool) -> Self {
        self.settings.all_fixed_colliders_ground = enabled;
        self
    }

    /// Runs bevy_rapier's systems and the plugin's in `schedule` (as
    /// `RapierPhysicsPlugin::in_schedule`).
    pub fn in_schedule(mut self, schedule: impl ScheduleLabel) -> Self {
        self.schedule = schedule.intern();
        self
    }

    /// Runs them in `FixedUpdate` (as `RapierPhysicsPlugin::in_fixed_schedule`).
    pub fn in_fixed_schedule(self) -> Self {
        self.in_schedule(FixedUpdate)
    }

    /// Adjusts bevy_rapier's plugin before it is added (its length unit, its context
    /// initialization). The schedule and the sets of systems are then set by this plugin.
    pub fn with_rapier(
        mut self,
        setup: impl Fn(RapierPhysicsPlugin<NoUserData>) -> RapierPhysicsPlugin<NoUserData>
        + Send
        + Sync
        + 'static,
    ) -> Self {
        self.rapier = Box::new(setup);
        self
    }
}

impl<H> Plugin for RapierImpactPlugin<H>
where
    H: 'static + BevyPhysicsHooks,
    for<'w, 's> SystemParamItem<'w, 's, H>: BevyPhysicsHooks,
{
    fn build(&self, app: &mut App) {
        // bevy_rapier's hooks type only serves its own step system, which is left out: the
        // user's hooks go to this plugin's step.
        let rapier = (self.rapier)(RapierPhysicsPlugin::<NoUserData>::default())
            .in_schedule(self.schedule)
            .with_physics_sets_systems(HashSet::from_iter([
                PhysicsSet::SyncBackend,
                PhysicsSet::Writeback,
            ]));
        app.add_plugins(rapier);
        if !app.world().contains_resource::<ImpactSettings>() {
            app.insert_resource(self.settings.clone());
        }
        app.add_message::<ImpactMessage>()
            .add_message::<ImpactErrorMessage>()
            .register_type::<Ground>()
            .register_type::<GroundMaterial>()
            .register_type::<ImpactBody>()
            .register_type::<TangentialRestitution>()
            .register_type::<RestitutionBySpeed>()
            .register_type::<Rolling>()
            .register_type::<ImpactSettings>()
            .register_type::<ImpactSimulation>()
            .register_type::<ImpactMessage>()
            .register_type::<ImpactErrorMessage>()
            .register_required_components::<RapierContextSimulation, ImpactSimulation>()
            .configure_sets(
                self.schedule,
                ImpactSet::Step.in_set(PhysicsSet::StepSimulation),
            )
            .add_systems(
                self.schedule,
                (step_with_impacts::<H>, mirror_quarantine)
                    .chain()
                    .in_set(ImpactSet::Step),
            );
    }
}
