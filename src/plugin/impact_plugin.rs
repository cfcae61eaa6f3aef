//! [`ImpactPlugin`]: the plugin's public face: construction, configuration, registration of
//! grounds and bodies, and the events of the last step.
//!
//! The step itself is in `stages/` (`before_step`, `after_step`: a list of stage calls each),
//! the hook calls rapier makes during its step in `hooks/`.

use crate::model::RestitutionCurve;
use crate::plugin::config::{ConfigError, GroundMaterial, ImpactConfig, RollingSettings};
use crate::plugin::events::{Diagnostic, ImpactEvent, Reports};
use crate::plugin::hooks::flags::HookFlags;
use crate::plugin::hooks::lookup::Lookup;
use crate::plugin::profile::{StepProfile, Stopwatch};
use crate::plugin::queries::observe::Sets;
use crate::plugin::queries::reach::NeighbourReads;
use crate::plugin::stages::pair_plan::PairIndex;
use crate::plugin::state::memory::Memory;
use crate::plugin::state::registry::Registry;
use crate::plugin::state::step::StepData;
use crate::plugin::state::writes::Writes;
use crate::rapier::prelude::{
    ActiveHooks, ColliderHandle, ColliderSet, ImpulseJointSet, MultibodyJointSet, NarrowPhase,
    PhysicsWorld, RigidBodyHandle, RigidBodySet,
};

/// Ground impacts resolved by the impact model inside a rapier simulation: the physics hook
/// and the per-step driver.
///
/// Mark colliders as ground, then either call [`ImpactPlugin::step`] on a [`PhysicsWorld`](crate::rapier::prelude::PhysicsWorld),
/// or call [`ImpactPlugin::before_step`], rapier's `PhysicsPipeline::step` with the plugin as
/// its hooks argument, and [`ImpactPlugin::after_step`]. A hook you already use is given at
/// construction ([`ImpactPlugin::with_hooks`]) and receives every pair that is not a managed
/// ground contact unchanged.
///
/// # Stepping a `PhysicsWorld`
/// ```
/// use rapier_impact::rapier::prelude::*;
/// use rapier_impact::{ImpactConfig, ImpactPlugin};
///
/// let mut world = PhysicsWorld::default();
/// let (_, ground) = world.insert(RigidBodyBuilder::fixed(), ColliderBuilder::halfspace(rapier_impact::rapier::na::Unit::new_unchecked(Vector::Y)));
/// let (ball, _) = world.insert(
///     RigidBodyBuilder::dynamic().translation(Vector::new(0.0, 1.1, 0.0)),
///     ColliderBuilder::ball(0.1).restitution(0.8),
/// );
/// world.colliders[ground].set_restitution(0.8);
///
/// let mut plugin = ImpactPlugin::new(ImpactConfig::default()).unwrap();
/// plugin.add_ground(&world.bodies, &world.colliders, ground).unwrap();
/// let mut bounced = false;
/// for _ in 0..30 {
///     // Half a second: the ball hits the ground at 0.45 s and rises.
///     plugin.step(&mut world);
///     bounced |= !plugin.events().is_empty();
/// }
/// assert!(bounced && world.bodies[ball].linvel().y > 0.0);
/// ```
///
/// # Around your own `PhysicsPipeline::step`
/// ```
/// use rapier_impact::rapier::prelude::*;
/// use rapier_impact::{EventKind, ImpactConfig, ImpactPlugin, StepSets, TimingMode};
///
/// let mut bodies = RigidBodySet::new();
/// let mut colliders = ColliderSet::new();
/// let ground = colliders.insert(ColliderBuilder::cuboid(10.0, 0.5, 10.0).translation(Vector::new(0.0, -0.5, 0.0)));
/// let ball = bodies.insert(RigidBodyBuilder::dynamic().translation(Vector::new(0.0, 1.1, 0.0)));
/// colliders.insert_with_parent(ColliderBuilder::ball(0.1).restitution(0.8), ball, &mut bodies);
///
/// let config = ImpactConfig::default().with_timing(TimingMode::TimeOfImpact);
/// // `()` stands for the hook the simulation already had.
/// let mut plugin = ImpactPlugin::with_hooks(config, ()).unwrap();
/// plugin.add_ground(&bodies, &colliders, ground).unwrap();
///
/// let (mut pipeline, mut islands, mut broad_phase, mut narrow_phase) =
///     (PhysicsPipeline::new(), IslandManager::new(), BroadPhaseBvh::new(), NarrowPhase::new());
/// let (mut impulse_joints, mut multibody_joints, mut soft_bodies, mut ccd) =
///     (ImpulseJointSet::new(), MultibodyJointSet::new(), SoftBodySet::new(), CCDSolver::new());
/// let params = IntegrationParameters::default();
/// let gravity = Vector::new(0.0, -9.81, 0.0);
/// for _ in 0..60 {
///     let sets = StepSets::new(&mut bodies, &mut colliders, &narrow_phase, &impulse_joints, &multibody_joints);
///     plugin.before_step(gravity, &params, sets);
///     pipeline.step(
///         gravity, &params, &mut islands, &mut broad_phase, &mut narrow_phase,
///         &mut bodies, &mut colliders, &mut impulse_joints, &mut multibody_joints,
///         &mut soft_bodies, &mut ccd, &plugin, &(),
///     );
///     let sets = StepSets::new(&mut bodies, &mut colliders, &narrow_phase, &impulse_joints, &multibody_joints);
///     plugin.after_step(sets);
///     for event in plugin.events() {
///         // Impacts push; the corrections (push-outs, energy caps) report their own kind.
///         assert!(event.kind != EventKind::Impact || event.normal_impulse > 0.0);
///     }
/// }
/// assert!(bodies[ball].translation().y > 0.1);
/// ```
pub struct ImpactPlugin<H = ()> {
    pub(crate) config: ImpactConfig,
    /// The grounds, the managed bodies and the ground index.
    pub(crate) registry: Registry,
    pub(crate) user_hooks: H,
    pub(crate) step: StepData,
    /// The tables rapier's hook calls read during its step (`hooks/lookup.rs`), built by the
    /// install stage.
    pub(crate) lookup: Lookup,
    /// Where the plugin's hook flags are (see `hooks/flags.rs`).
    pub(crate) flags: HookFlags,
    /// What the last step left for the next (`state/memory.rs`).
    pub(crate) memory: Memory,
    /// The opted-in balls' swept boxes of the step (`stages/pair_plan/index.rs`).
    pub(crate) pair_index: PairIndex,
    /// The last step's events and diagnostics.
    pub(crate) reports: Reports,
    /// The step's profile, when profiling is on.
    pub(crate) stopwatch: Stopwatch,
    /// The writes recorded in the current half of the step, for the commit stage
    /// (`state/writes.rs`).
    pub(crate) writes: Writes,
    /// What the plan read of the balls next to its rolling balls (`queries/reach.rs`),
    /// kept for its storage.
    pub(crate) neighbours: NeighbourReads,
}

/// The sets of a rapier world that [`ImpactPlugin::before_step`] and
/// [`ImpactPlugin::after_step`] read and write: the same sets, in the same state, that
/// rapier's `PhysicsPipeline::step` takes right after (or took right before). The joints are
/// read for rapier's pair filtering (a joint can disable its bodies' contacts); the narrow
/// phase for the contacts rapier found.
pub struct StepSets<'w> {
    /// The rigid bodies: read, and written where the plugin resolves an impact.
    pub bodies: &'w mut RigidBodySet,
    /// The colliders: read, and their poses updated with the bodies the plugin moves.
    pub colliders: &'w mut ColliderSet,
    /// rapier's narrow phase: its contact graph.
    pub narrow_phase: &'w NarrowPhase,
    /// The impulse joints.
    pub impulse_joints: &'w ImpulseJointSet,
    /// The multibody joints.
    pub multibody_joints: &'w MultibodyJointSet,
}

impl<'w> StepSets<'w> {
    /// The sets, in the order `PhysicsPipeline::step` takes them.
    pub fn new(
        bodies: &'w mut RigidBodySet,
        colliders: &'w mut ColliderSet,
        narrow_phase: &'w NarrowPhase,
        impulse_joints: &'w ImpulseJointSet,
        multibody_joints: &'w MultibodyJointSet,
    ) -> Self {
        Self {
            bodies,
            colliders,
            narrow_phase,
            impulse_joints,
            multibody_joints,
        }
    }
}

impl<'w> StepSets<'w> {
    /// The sets the stages write, and those they only read.
    pub(crate) fn into_parts(self) -> (&'w mut RigidBodySet, &'w mut ColliderSet, Sets<'w>) {
        let sets = Sets::new(
            self.narrow_phase,
            self.impulse_joints,
            self.multibody_joints,
        );
        (self.bodies, self.colliders, sets)
    }
}

impl<'w> From<&'w mut PhysicsWorld> for StepSets<'w> {
    /// The world's own sets.
    fn from(world: &'w mut PhysicsWorld) -> Self {
        Self::new(
            &mut world.bodies,
            &mut world.colliders,
            &world.narrow_phase,
            &world.impulse_joints,
            &world.multibody_joints,
        )
    }
}

impl ImpactPlugin<()> {
    /// A plugin with no user hook.
    pub fn new(config: ImpactConfig) -> Result<Self, ConfigError> {
        Self::with_hooks(config, ())
    }
}

impl<H> ImpactPlugin<H> {
    /// A plugin wrapping the simulation's existing hook `user_hooks`: every contact pair that
    /// is not a managed ground contact is handed to it unchanged (when its colliders' hook
    /// flags ask for it, as rapier would).
    pub fn with_hooks(config: ImpactConfig, user_hooks: H) -> Result<Self, ConfigError> {
        config.validate()?;
        Ok(Self {
            config,
            registry: Registry {
                flags_stale: true,
                ..Default::default()
            },
            user_hooks,
            step: StepData::default(),
            lookup: Lookup::default(),
            flags: HookFlags::default(),
            memory: Memory::default(),
            pair_index: PairIndex::default(),
            reports: Reports::default(),
            stopwatch: Stopwatch::default(),
            writes: Writes::default(),
            neighbours: NeighbourReads::default(),
        })
    }

    /// The configuration.
    pub fn config(&self) -> &ImpactConfig {
        &self.config
    }

    /// Replaces the configuration, after validating it.
    pub fn set_config(&mut self, config: ImpactConfig) -> Result<(), ConfigError> {
        config.validate()?;
        self.config = config;
        Ok(())
    }

    /// The wrapped user hook.
    pub fn user_hooks(&self) -> &H {
        &self.user_hooks
    }

    /// The wrapped user hook, mutably.
    pub fn user_hooks_mut(&mut self) -> &mut H {
        &mut self.user_hooks
    }

    /// The hook flags you set on `collider`: what rapier would see without the plugin, while
    /// the collider carries the plugin's own too (empty for a collider not in `colliders`).
    /// To add a flag to yours, set `user_active_hooks(..) | flag`: the collider's own
    /// `active_hooks() | flag` may be exactly what the plugin wrote, which reads as no change.
    pub fn user_active_hooks(
        &self,
        colliders: &ColliderSet,
        collider: ColliderHandle,
    ) -> ActiveHooks {
        self.flags.recorded_user_flags(colliders, collider)
    }

    /// The same plugin wrapping `user_hooks` instead, and the hook it wrapped: every other
    /// piece of state (grounds, bodies, last step's roles) carries over. For a driver whose
    /// hook lives for one system run only (a Bevy `SystemParam` borrows the world): swap it
    /// in before [`Self::before_step`] and back after [`Self::after_step`].
    pub fn replace_hooks<H2>(self, user_hooks: H2) -> (ImpactPlugin<H2>, H) {
        // Every field named, so that a new one cannot be forgotten here.
        let Self {
            config,
            registry,
            user_hooks: old,
            step,
            lookup,
            flags,
            memory,
            pair_index,
            reports,
            stopwatch,
            writes,
            neighbours,
        } = self;
        let plugin = ImpactPlugin {
            config,
            registry,
            user_hooks,
            step,
            lookup,
            flags,
            memory,
            pair_index,
            reports,
            stopwatch,
            writes,
            neighbours,
        };
        (plugin, old)
    }

    /// Turns the step's profile on or off (off by default): with it on, each step records the
    /// time of each of its stages, the bodies and pairs each took and the writes into rapier
    /// ([`Self::profile`]).
    pub fn set_profiling(&mut self, on: bool) {
        self.stopwatch.set_on(on);
    }

    /// The last step's profile, while profiling is on ([`Self::set_profiling`]).
    pub fn profile(&self) -> Option<&StepProfile> {
        self.stopwatch.profile()
    }

    /// Every change the plugin made to a body in the last step: the impacts and the
    /// corrections (see [`crate::EventKind`]), cleared by the next [`Self::before_step`]. To
    /// read the events of several steps at once, turn the event log on
    /// ([`Self::set_event_log`]).
    pub fn events(&self) -> &[ImpactEvent] {
        &self.reports.events
    }

    /// Turns the event log on or off (default off). While it is on, every event is kept until
    /// [`Self::take_event_log`] takes it, however many steps run in between (a game stepping
    /// several times per frame reads them once per frame); turned off, the log's events are
    /// dropped. The log is not part of a snapshot.
    pub fn set_event_log(&mut self, on: bool) {
        self.reports.set_log(on);
    }

    /// The events since the log was turned on or last taken, oldest first, the last step's
    /// included; the log is then empty. Empty while the log is off.
    pub fn take_event_log(&mut self) -> Vec<ImpactEvent> {
        self.reports.take_log()
    }

    /// What the plugin left to rapier in the last step instead of resolving it (a collider
    /// whose coefficients are out of range, reported once; a state that was not finite),
    /// cleared by the next [`Self::before_step`]. Nothing was written for them.
    pub fn diagnostics(&self) -> &[Diagnostic] {
        &self.reports.diagnostics
    }

    /// Leaves `body` to rapier entirely: its ground contacts are rapier's, bounce included.
    pub fn exclude_body(&mut self, body: RigidBodyHandle) {
        self.registry.excluded.insert(body);
    }

    /// Undoes [`Self::exclude_body`].
    pub fn include_body(&mut self, body: RigidBodyHandle) {
        self.registry.excluded.remove(&body);
    }

    /// Was `body` left to rapier with [`Self::exclude_body`]?
    pub fn is_excluded(&self, body: RigidBodyHandle) -> bool {
        self.registry.excluded.contains(&body)
    }

    /// A ball's own rolling resistance and spinning friction (`None` for the configuration's):
    /// used on every ground without its own (see [`ImpactConfig::rolling_resistance`]). Each
    /// coefficient in `[0, 100]`, else [`ConfigError::InvalidBodySetting`] and nothing changes.
    pub fn set_body_rolling(
        &mut self,
        body: RigidBodyHandle,
        settings: Option<RollingSettings>,
    ) -> Result<(), ConfigError> {
        match settings {
            Some(rolling) => {
                rolling.validate()?;
                let pair = (rolling.rolling_resistance, rolling.spinning_friction);
                self.registry.body_rolling.insert(body, pair);
            }
            None => {
                self.registry.body_rolling.remove(&body);
            }
        }
        Ok(())
    }

    /// The material a ground was given ([`Self::add_ground_with_material`],
    /// [`Self::set_ground_material`]), if it is a ground and has one.
    pub fn ground_material(&self, collider: ColliderHandle) -> Option<GroundMaterial> {
        self.registry.ground_material(collider)
    }

    /// The rolling resistance and spinning friction `body` has of its own
    /// ([`Self::set_body_rolling`]), if any.
    pub fn body_rolling(&self, body: RigidBodyHandle) -> Option<RollingSettings> {
        let &(rr, sp) = self.registry.body_rolling.get(&body)?;
        Some(RollingSettings::new(rr, sp))
    }

    /// A body's own tangential restitution `beta0` (Walton's, in `[-1, 1]`; `None` for the
    /// configuration's): used in its impacts on every ground without one of its own, and in
    /// its impacts with other bodies (the mean of the two bodies' where both have one). See
    /// [`ImpactConfig::tangential_restitution`]. Outside `[-1, 1]`,
    /// [`ConfigError::InvalidBodySetting`] and nothing changes.
    pub fn set_body_tangential_restitution(
        &mut self,
        body: RigidBodyHandle,
        beta0: Option<f64>,
    ) -> Result<(), ConfigError> {
        self.registry.set_body_tangential_restitution(body, beta0)
    }

    /// A body's own tangential restitution ([`Self::set_body_tangential_restitution`]).
    pub fn body_tangential_restitution(&self, body: RigidBodyHandle) -> Option<f64> {
        self.registry
            .body_bounce
            .get(&body)
            .and_then(|b| b.tangential_restitution)
    }

    /// A body's own restitution as a function of the impact speed (`None` for the
    /// configuration's): replaces the constant `e` in its impacts on every ground without a
    /// curve of its own, and in its impacts with other bodies (the mean of the two curves where
    /// both bodies have one). Every `e` of the curve must be at most 10, else
    /// [`ConfigError::InvalidBodySetting`] and nothing changes. See
    /// [`ImpactConfig::restitution_curve`].
    pub fn set_body_restitution_curve(
        &mut self,
        body: RigidBodyHandle,
        curve: Option<RestitutionCurve>,
    ) -> Result<(), ConfigError> {
        self.registry.set_body_restitution_curve(body, curve)
    }

    /// A body's own restitution curve ([`Self::set_body_restitution_curve`]).
    pub fn body_restitution_curve(&self, body: RigidBodyHandle) -> Option<&RestitutionCurve> {
        self.registry
            .body_bounce
            .get(&body)
            .and_then(|b| b.restitution_curve.as_ref())
    }

    /// Opts `body` in to impacts between bodies: its impacts with another opted-in body are
    /// resolved by the model ([`crate::model::resolve_pair`]) at their time in the step,
    /// like ground impacts. The body must be dynamic (else [`ConfigError::NotDynamic`]).
    /// Which pairs and how: `docs/guide.md`, "Impacts between bodies".
    pub fn add_impact_body(
        &mut self,
        bodies: &RigidBodySet,
        body: RigidBodyHandle,
    ) -> Result<(), ConfigError> {
        let rb = bodies.get(body).ok_or(ConfigError::NotABody(body))?;
        if !rb.is_dynamic() {
            return Err(ConfigError::NotDynamic(body));
        }
        self.registry.impact_bodies.insert(body);
        Ok(())
    }

    /// Undoes [`Self::add_impact_body`]; `false` if the body was not opted in.
    pub fn remove_impact_body(&mut self, body: RigidBodyHandle) -> bool {
        self.registry.impact_bodies.remove(&body)
    }

    /// Opts every dynamic body the plugin manages in to impacts between bodies (`true`), or
    /// only those given to [`Self::add_impact_body`] (`false`, the default).
    pub fn set_all_dynamic_bodies_impact(&mut self, enabled: bool) {
        self.registry.all_impact = enabled;
    }

    /// Is [`Self::set_all_dynamic_bodies_impact`] on?
    pub fn all_dynamic_bodies_impact(&self) -> bool {
        self.registry.all_impact
    }

    /// Does `body` take part in impacts between bodies (opted in, and managed; whether it is a
    /// multibody's link, as rapier's sets held it at the last step's start, none read yet
    /// after a `restore`)?
    pub fn is_impact_body(&self, bodies: &RigidBodySet, body: RigidBodyHandle) -> bool {
        bodies
            .get(body)
            .is_some_and(|rb| self.registry.takes_pairs(body, rb))
    }

    /// Marks one collider as ground, with the materials rapier combines from the colliders.
    ///
    /// The collider must exist and be parentless, or attached to a fixed or kinematic body.
    /// Its hook flags are the user's: the plugin adds its own at each step where needed and
    /// hands the user's to the wrapped hook.
    pub fn add_ground(
        &mut self,
        bodies: &RigidBodySet,
        colliders: &ColliderSet,
        collider: ColliderHandle,
    ) -> Result<(), ConfigError> {
        self.registry
            .insert_ground(bodies, colliders, collider, None)
    }

    /// Marks one collider as ground with its own material, which replaces the coefficients
    /// rapier would combine (validated here).
    pub fn add_ground_with_material(
        &mut self,
        bodies: &RigidBodySet,
        colliders: &ColliderSet,
        collider: ColliderHandle,
        material: GroundMaterial,
    ) -> Result<(), ConfigError> {
        material.validate()?;
        self.registry
            .insert_ground(bodies, colliders, collider, Some(material))
    }

    /// Marks every collider of a fixed or kinematic body as ground.
    pub fn add_ground_body(
        &mut self,
        bodies: &RigidBodySet,
        colliders: &ColliderSet,
        body: RigidBodyHandle,
    ) -> Result<(), ConfigError> {
        for h in Registry::ground_body_colliders(bodies, body)? {
            self.registry.insert_ground(bodies, colliders, h, None)?;
        }
        Ok(())
    }

    /// Sets or clears (`None`) the material override of a ground.
    pub fn set_ground_material(
        &mut self,
        collider: ColliderHandle,
        material: Option<GroundMaterial>,
    ) -> Result<(), ConfigError> {
        self.registry.set_ground_material(collider, material)
    }

    /// Makes a ground an ordinary collider again. Returns whether it was a ground. The
    /// all-fixed mode ([`Self::set_all_fixed_colliders_ground`]) does not mark it again;
    /// [`Self::add_ground`] does.
    pub fn remove_ground(&mut self, collider: ColliderHandle) -> bool {
        self.registry.remove_ground(collider)
    }

    /// Every fixed collider (parentless, or on a fixed body) is ground, including those
    /// added later; checked at each [`Self::before_step`]. Turning it off unmarks the
    /// colliders it marked.
    pub fn set_all_fixed_colliders_ground(&mut self, enabled: bool) {
        self.registry.set_all_fixed_colliders_ground(enabled);
    }

    /// Is [`Self::set_all_fixed_colliders_ground`] on?
    pub fn all_fixed_colliders_ground(&self) -> bool {
        self.registry.all_fixed
    }

    /// Is this collider a ground?
    pub fn is_ground(&self, collider: ColliderHandle) -> bool {
        self.registry.is_ground(collider)
    }

    /// Takes the plugin's hook flags off every collider (the user's flags back) and returns
    /// the wrapped hook. Use it to go on without the plugin: otherwise the flags it left make
    /// rapier call the next hook for pairs the user never asked about.
    pub fn detach(mut self, colliders: &mut ColliderSet) -> H {
        self.flags.restore_all(colliders);
        self.user_hooks
    }
}
