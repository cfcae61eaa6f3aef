//! [`ImpactPlugin`]: the per-step driver around rapier's step.
//!
//! Contract, per step:
//! - [`ImpactPlugin::before_step`] reads every awake managed dynamic body (state, and which
//!   grounds its swept bounding sphere can reach), assigns each body-ground collider pair a
//!   role (`Impact`: taken from rapier's solver; `Resting`: rapier's, with `e = 0`), and in
//!   `Step` mode applies the impulses of the contacts that close in this step.
//! - During rapier's step, the plugin is the `&dyn PhysicsHooks`: it applies the roles and
//!   hands every other pair to the user's hook unchanged.
//! - [`ImpactPlugin::after_step`] routes each body: reconstruct (the in-step impacts from the
//!   start-of-step state, the clusters of impacts between balls, a rolling ball's closed
//!   form, `Exact` mode's free flight), then
//!   the settle stage's one check of the end state (`Settle::check`, with the reason it is
//!   checked: `EndCheck`), then the commit of one state per body (woken up), and moves the
//!   colliders.

use crate::motion::{Rolling, State};
use crate::plugin::bridge::convert::{pose_to_na, rot_to_na, to_f64, vec_to_na};
use crate::plugin::bridge::resolve::{ImpactInput, Inertia, Site, correction, released, resolve};
use crate::plugin::config::GroundMaterial;
use crate::plugin::config::{ConfigError, ImpactConfig, TimingMode};
use crate::plugin::events::{EventKind, ImpactEvent, ImpactTiming};
use crate::plugin::hooks::flags::HookFlags;
use crate::plugin::hooks::lookup::{Looked, Lookup};
use crate::plugin::policy::{EndAction, EndCheck, IN_PLANE_TOLERANCE, Policy, Role};
use crate::plugin::queries::filter;
use crate::plugin::queries::geometry::{BodyGeom, GroundGeom, Hit, Search, closest, first_impact};
use crate::plugin::queries::observe::{
    Sets, body_geom, pushed_by_other, rapier_state, snapshot, surely_far, touched_besides_grounds,
    touches_other,
};
use crate::plugin::stages::commit::{write_flight, write_state};
use crate::plugin::stages::pair_plan::{self, PairIndex, pair_key};
use crate::plugin::stages::pair_reconstruct;
use crate::plugin::stages::plan::Planner;
use crate::plugin::stages::reconstruct::{self, ccd_consistent};
use crate::plugin::stages::settle::{Checked, Settle};
use crate::plugin::state::handles::PairKey;
use crate::plugin::state::handles::{HandleMap, HandleSet, slot_of};
use crate::plugin::state::memory::Shadow;
use crate::plugin::state::registry::Registry;
use crate::plugin::state::small_list::SmallList;
use crate::plugin::state::step::Candidate;
use crate::plugin::state::step::EndOfStep;
use crate::plugin::state::step::FirstHold;
use crate::plugin::state::step::StepData;
use crate::rapier::math::Vector;
use crate::rapier::prelude::{
    ActiveHooks, ColliderHandle, ColliderSet, EventHandler, ImpulseJointSet, IntegrationParameters,
    LockedAxes, MultibodyJointSet, NarrowPhase, PhysicsHooks, PhysicsWorld, RigidBodyHandle,
    RigidBodySet,
};
use nalgebra::Vector3;

/// Tables a step fills again: kept from the step before so that their allocations are.
#[derive(Default)]
struct Spare {
    shadows: HandleMap<RigidBodyHandle, Shadow>,
    roles: HandleMap<PairKey, Role>,
    candidates: Vec<Candidate>,
}

/// Ground impacts resolved by the impact model inside a rapier simulation: the physics hook
/// and the per-step driver.
///
/// Mark colliders as ground, then either call [`ImpactPlugin::step`] on a [`PhysicsWorld`],
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
/// use rapier_impact::{EventKind, ImpactConfig, ImpactPlugin, TimingMode};
///
/// let mut bodies = RigidBodySet::new();
/// let mut colliders = ColliderSet::new();
/// let ground = colliders.insert(ColliderBuilder::cuboid(10.0, 0.5, 10.0).translation(Vector::new(0.0, -0.5, 0.0)));
/// let ball = bodies.insert(RigidBodyBuilder::dynamic().translation(Vector::new(0.0, 1.1, 0.0)));
/// colliders.insert_with_parent(ColliderBuilder::ball(0.1).restitution(0.8), ball, &mut bodies);
///
/// let config = ImpactConfig { timing: TimingMode::TimeOfImpact, ..Default::default() };
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
///     plugin.before_step(gravity, &params, &mut bodies, &mut colliders, &narrow_phase, &impulse_joints, &multibody_joints);
///     pipeline.step(
///         gravity, &params, &mut islands, &mut broad_phase, &mut narrow_phase,
///         &mut bodies, &mut colliders, &mut impulse_joints, &mut multibody_joints,
///         &mut soft_bodies, &mut ccd, &plugin, &(),
///     );
///     plugin.after_step(&mut bodies, &mut colliders, &narrow_phase, &impulse_joints, &multibody_joints);
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
    /// Where the plugin's hook flags are (see `hooks/flags.rs`).
    pub(crate) flags: HookFlags,
    shadows: HandleMap<RigidBodyHandle, Shadow>,
    /// Last step's tables, cleared and filled again by the next (their allocations kept).
    spare: Spare,
    /// The roles of the last step (for the resting hysteresis).
    prev_roles: HandleMap<PairKey, Role>,
    /// Last step's roles of the pairs between bodies (`pair_plan.rs`).
    prev_pair_roles: HandleMap<PairKey, Role>,
    /// The pairs held at rest last step (`StepData::holds`).
    prev_holds: HandleSet<PairKey>,
    /// The opted-in balls' swept spheres, refitted each step (`pair_plan.rs`).
    pair_index: PairIndex,
    events: Vec<ImpactEvent>,
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
            flags: HookFlags::default(),
            shadows: HandleMap::default(),
            spare: Spare::default(),
            prev_roles: HandleMap::default(),
            prev_pair_roles: HandleMap::default(),
            prev_holds: HandleSet::default(),
            pair_index: PairIndex::default(),
            events: Vec::new(),
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
            flags,
            shadows,
            spare,
            prev_roles,
            prev_pair_roles,
            prev_holds,
            pair_index,
            events,
        } = self;
        let plugin = ImpactPlugin {
            config,
            registry,
            user_hooks,
            step,
            flags,
            shadows,
            spare,
            prev_roles,
            prev_pair_roles,
            prev_holds,
            pair_index,
            events,
        };
        (plugin, old)
    }

    /// Every change the plugin made to a body in the last step: the impacts and the
    /// corrections (see [`crate::EventKind`]), cleared by the next [`Self::before_step`].
    pub fn events(&self) -> &[ImpactEvent] {
        &self.events
    }

    /// Leaves `body` to rapier entirely: its ground contacts are rapier's, bounce included.
    pub fn exclude_body(&mut self, body: RigidBodyHandle) {
        self.registry.excluded.insert(body);
    }

    /// Undoes [`Self::exclude_body`].
    pub fn include_body(&mut self, body: RigidBodyHandle) {
        self.registry.excluded.remove(&body);
    }

    /// A ball's own rolling resistance and spinning friction (dimensionless, finite and
    /// `>= 0`; `None` for the configuration's): used on every ground without an override of
    /// its own (see [`ImpactConfig::rolling_resistance`]).
    pub fn set_body_rolling(
        &mut self,
        body: RigidBodyHandle,
        coefficients: Option<(f64, f64)>,
    ) -> Result<(), ConfigError> {
        match coefficients {
            Some((rr, sp)) => {
                for (field, value) in [("rolling_resistance", rr), ("spinning_friction", sp)] {
                    if !(value.is_finite() && value >= 0.0) {
                        return Err(ConfigError::InvalidConfig { field, value });
                    }
                }
                self.registry.body_rolling.insert(body, (rr, sp));
            }
            None => {
                self.registry.body_rolling.remove(&body);
            }
        }
        Ok(())
    }

    /// Opts `body` in to impacts between bodies: its impacts with another opted-in body are
    /// resolved by the model ([`crate::model::resolve_pair`]) at their time in the step,
    /// like ground impacts. The body must be dynamic (else [`ConfigError::NotDynamic`]).
    /// Which pairs and how: `docs/integration.md`, "Impacts between bodies".
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

    /// Does `body` take part in impacts between bodies (opted in, and managed)?
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
        self.registry.add_ground_body(bodies, colliders, body)
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

    /// Is this collider a ground?
    pub fn is_ground(&self, collider: ColliderHandle) -> bool {
        self.registry.is_ground(collider)
    }

    /// The role of a managed pair in the current step (`Resting` when unknown: a pair the
    /// plugin did not see coming, e.g. of a body woken during the step, is left to rapier's
    /// solver without bounce).
    pub(crate) fn role(&self, key: &PairKey) -> Role {
        let lookup = &self.step.lookup;
        if lookup.roles_built {
            match lookup.roles.get(slot_of(key.0)) {
                Some(Some(slot)) if slot.body == key.0 => {
                    if slot.ground == key.1 {
                        return slot.role;
                    }
                    if !slot.more {
                        return Role::Resting;
                    }
                }
                _ => return Role::Resting,
            }
        }
        self.step.roles.get(key).copied().unwrap_or(Role::Resting)
    }

    /// `Exact` mode, a body that flew free all step: its translation and linear velocity
    /// from the exact flight. Its rotation stays rapier's, and so does the spin of an
    /// anisotropic body or of one with a locked rotation axis (rapier turns it its own way,
    /// and the two must agree); a body whose spin keeps its axis (isotropic inertia, or
    /// rapier's gyroscopic forces off) gets the exact spin too, which rapier's `f32`
    /// integrator lets drift by about 2e-7 relative a step (1.2e-5 on a hollow ball's spin
    /// after 40 steps at 1 000 Hz).
    fn fly_exactly(&mut self, bodies: &mut RigidBodySet, cand: &Candidate, dt: f64) {
        let end = cand.flight.advance(&cand.start, dt);
        let rb = &mut bodies[cand.body];
        let exact_spin =
            cand.flight.gyro.is_none() && !rb.locked_axes().intersects(LockedAxes::ROTATION_LOCKED);
        let s = State {
            rot: rot_to_na(*rb.rotation()),
            w: if exact_spin {
                end.w
            } else {
                vec_to_na(rb.angvel())
            },
            ..end
        };
        write_flight(rb, &s, &cand.local_com, exact_spin);
        self.settle().remember(cand.body, rb, &s);
    }

    /// A ball's first step held at rest on a slope (`FirstHold`): put back where it stopped,
    /// at rest, with its `EventKind::Hold` event, unless something else touched it in the step
    /// (or it leaves faster than the resting speed), or rapier put it to sleep.
    fn put_back_held(&mut self, bodies: &mut RigidBodySet, hold: &FirstHold, step: &EndOfStep) {
        let Some(rb) = bodies.get(hold.body) else {
            return;
        };
        let end = rapier_state(rb);
        let slow = step.policy.resting_speed;
        let still = end.v.norm() <= slow && end.w.norm() * hold.radius <= slow;
        if rb.is_sleeping()
            || !still
            || (end.com == hold.start.com && end.rot == hold.start.rot)
            || touched_besides_grounds(hold.body, rb, &step.sets, &self.registry)
        {
            return;
        }
        let dt = step.dt;
        let rb = &mut bodies[hold.body];
        write_state(rb, &hold.start, &hold.local_com, true);
        let site = Site {
            body: hold.body,
            collider: hold.collider,
            ground: hold.ground,
            body2: None,
            normal: hold.normal,
            point: hold.start.com - hold.normal * hold.radius,
        };
        let inertia = Inertia::of(rb);
        let event = correction(EventKind::Hold, &site, &inertia, &end, &hold.start, dt);
        self.events.push(event);
        if self.config.timing == TimingMode::Exact {
            self.settle()
                .remember(hold.body, &bodies[hold.body], &hold.start);
        }
    }

    /// The end-of-step stage's view of the plugin.
    fn settle(&mut self) -> Settle<'_> {
        Settle {
            config: &self.config,
            registry: &self.registry,
            flags: &self.flags,
            roles: &self.prev_roles,
            events: &mut self.events,
            shadows: &mut self.shadows,
        }
    }

    /// A rolling ball that meets another ground in the step, at `touch`
    /// (`reconstruct::rolling_touch`): the impact there, by the model. Left on that ground (e = 0)
    /// and leaving its own plane (rolling off a slope onto the level ground at its foot), it rolls
    /// on in closed form on the new ground to the step's end; otherwise it goes on through the
    /// impacts the search finds, as any impact's body does, and the settle stage checks where it
    /// ends. `grounds`: every ground near it, `obstacles` among them.
    #[allow(clippy::too_many_arguments)]
    fn rolled_into(
        &mut self,
        bodies: &mut RigidBodySet,
        colliders: &ColliderSet,
        cand: &Candidate,
        motion: &Rolling,
        geom: &BodyGeom,
        grounds: &[GroundGeom],
        obstacles: &[GroundGeom],
        touch: (f64, State, Hit),
        step: &EndOfStep,
    ) {
        let (t, s, hit) = touch;
        let inertia = Inertia::of(&bodies[cand.body]);
        let part = &geom.parts[hit.part];
        let og = &obstacles[hit.ground];
        let material = self.registry.material_of(colliders, part.handle, og.handle);
        let input = ImpactInput {
            body: cand.body,
            inertia: &inertia,
            law: self.config.law,
            material,
            resting_speed: step.policy.resting_speed,
            force_settle: false,
            timing: ImpactTiming::InStep,
        };
        let n = hit.normal;
        let rolls_on =
            resolve(&input, geom, og, &s, t, &hit, hit.point, 1).and_then(|(after, event)| {
                // e = 0 (the materials', or a settled impact's) leaves it on the new ground.
                let onto = (event.settled || event.restitution == 0.0)
                    && after.v.dot(&motion.normal) > 0.0
                    && n.dot(&motion.accel) < 0.0;
                // A new ground that turns, or moves off its plane, is not rolled on.
                let in_plane = og.w == Vector3::zeros()
                    && og.v.dot(&n).abs() <= IN_PLANE_TOLERANCE * og.v.norm();
                let ball = part.shape.as_ball().filter(|_| onto && in_plane)?;
                let radius = to_f64(ball.radius) + part.skin + og.skin;
                let default = (
                    self.config.rolling_resistance,
                    self.config.spinning_friction,
                );
                let (rolling_resistance, spinning_friction) =
                    self.registry.rolling_of(cand.body, og.handle, default);
                let on_new = Rolling {
                    normal: n,
                    radius,
                    inertia_ratio: inertia.ball_ratio(radius)?,
                    friction: material.friction,
                    rolling_resistance,
                    spinning_friction,
                    accel: motion.accel,
                    ground_velocity: og.v,
                };
                let end = on_new.advance_checked(&after, step.dt - t)?;
                // Still on the new ground's plane at the end, and in no other ground.
                let reach = step.policy.resting_gap.max(step.policy.prediction);
                let last = closest(geom, grounds, &end, step.dt, reach)?;
                let on_plane =
                    last.dist.abs() <= 1e-9 * radius.max(1.0) && last.normal.dot(&n) >= 1.0 - 1e-9;
                on_plane.then_some((end, event))
            });
        if let Some((end, event)) = rolls_on {
            self.events.push(event);
            let rb = &mut bodies[cand.body];
            write_state(rb, &end, &cand.local_com, true);
            if self.config.timing == TimingMode::Exact {
                self.settle().remember(cand.body, rb, &end);
            }
            return;
        }
        let Some(index) = grounds.iter().position(|g| g.handle == og.handle) else {
            return;
        };
        let first = Search::Hit(
            t,
            s,
            Hit {
                ground: index,
                ..hit
            },
        );
        self.fly_through_impacts(
            bodies, colliders, cand, geom, grounds, &inertia, first, step,
        );
    }

    /// A candidate moved by the reconstruct stage through the impacts from `first` on to the
    /// step's end, checked by the settle stage there (never left inside a ground, nor lifted
    /// out with energy gained: a cube pivoting on a corner through the step's last allowed
    /// impact gained 3.2e-4 of a throw's energy without the cap), and committed.
    #[allow(clippy::too_many_arguments)]
    fn fly_through_impacts(
        &mut self,
        bodies: &mut RigidBodySet,
        colliders: &ColliderSet,
        cand: &Candidate,
        geom: &BodyGeom,
        grounds: &[GroundGeom],
        inertia: &Inertia,
        first: Search,
        step: &EndOfStep,
    ) {
        let from = self.events.len();
        let flown = reconstruct::through_impacts(
            &mut self.settle(),
            colliders,
            cand,
            geom,
            grounds,
            inertia,
            first,
            step,
        );
        let checked = Checked {
            body: cand.body,
            geom,
            inertia,
            cand: Some(cand),
        };
        let (_, settled) = self.settle().check(
            bodies,
            colliders,
            &checked,
            &flown,
            EndCheck::Flown,
            grounds,
            step,
            from,
        );
        let end = settled.unwrap_or(flown);
        let rb = &mut bodies[cand.body];
        write_state(rb, &end, &cand.local_com, true);
        if self.config.timing == TimingMode::Exact {
            self.settle().remember(cand.body, rb, &end);
        }
    }

    /// The settle stage's check of rapier's end state of a candidate against `grounds` for
    /// `why`, and the commit of what it corrected; returns the action it took.
    #[allow(clippy::too_many_arguments)]
    fn settle_rapier_end(
        &mut self,
        bodies: &mut RigidBodySet,
        colliders: &ColliderSet,
        cand: &Candidate,
        geom: &BodyGeom,
        grounds: &[GroundGeom],
        why: EndCheck,
        step: &EndOfStep,
    ) -> EndAction {
        let rb = &bodies[cand.body];
        let inertia = Inertia::of(rb);
        let checked = Checked {
            body: cand.body,
            geom,
            inertia: &inertia,
            cand: Some(cand),
        };
        let from = self.events.len();
        let end = rapier_state(rb);
        let (action, settled) = self
            .settle()
            .check(bodies, colliders, &checked, &end, why, grounds, step, from);
        if let Some(s) = settled {
            write_state(&mut bodies[cand.body], &s, &cand.local_com, true);
        }
        action
    }

    /// After a step the search found clear, for a body whose rotation moves its surface (not
    /// a ball about its centre): the search flies it torque-free, rapier's integrator turns
    /// it its own way (and `Exact` mode keeps rapier's rotation), and for a fast tumble the
    /// two part by centimetres at the corners (a 0.9 m rod at 21 rad/s, 30 Hz: 6 cm deep).
    /// What rapier's end pose holds in its `Impact` grounds is checked (`RapierEnd`).
    fn turned_end(
        &mut self,
        bodies: &mut RigidBodySet,
        colliders: &ColliderSet,
        cand: &Candidate,
        step: &EndOfStep,
    ) {
        if !cand.turns_surface {
            return;
        }
        let geom = body_geom(&bodies[cand.body], colliders, &cand.local_com);
        let grounds = self
            .settle()
            .impact_ground_geoms(cand, &geom, colliders, step);
        let why = EndCheck::RapierEnd;
        self.settle_rapier_end(bodies, colliders, cand, &geom, &grounds, why, step);
    }

    /// The pair as the plugin sees it in rapier's step: `Some((key, role, user flags))` for a
    /// managed body-ground pair, `None` for another pair. The step's table answers the pairs
    /// `before_step` gave a role (most of them) without looking at the sets; the others are
    /// checked (a pair the plugin did not see coming is `Resting`).
    pub(crate) fn pair_in_step(
        &self,
        bodies: &RigidBodySet,
        colliders: &ColliderSet,
        c1: ColliderHandle,
        c2: ColliderHandle,
    ) -> Option<(PairKey, Role, ActiveHooks)> {
        // The table holds the registry as `before_step` saw it; a ground marked or unmarked
        // since is checked against the sets.
        // A pair of opted-in balls.
        if !self.step.pairs.roles.is_empty() {
            let key = pair_key(c1, c2);
            if let Some(role) = self.step.pairs.roles.get(&key) {
                let user = self.user_flags(colliders, c1) | self.user_flags(colliders, c2);
                return Some((key, *role, user));
            }
        }
        let current = self.registry.index.entry(c1).is_ok();
        match current.then(|| self.step.lookup.pair(c1, c2)).flatten() {
            Some(Looked::Pair(key, slot)) => {
                // A body collider that is itself marked as ground (its body turned dynamic
                // after it was marked) makes the pair two grounds: not the plugin's, as
                // `managed_pair` says.
                if self.registry.entry(key.0).is_none() {
                    return Some((key, slot.role, slot.user));
                }
                return None;
            }
            // A body with no ground in reach against a managed ground (not on a dynamic
            // body, as `managed_pair` asks): `Resting`, as every pair the plugin gave no role.
            Some(Looked::Far(key, user)) => {
                let ground_managed = self.registry.entry(key.1).is_some()
                    && self.registry.entry(key.0).is_none()
                    && colliders.get(key.1).is_some_and(|co| {
                        co.parent()
                            .is_none_or(|p| bodies.get(p).is_some_and(|rb| !rb.is_dynamic()))
                    });
                return ground_managed
                    .then(|| (key, Role::Resting, user | self.user_flags(colliders, key.1)));
            }
            None => {}
        }
        self.managed_pair(bodies, colliders, c1, c2).map(|key| {
            (
                key,
                self.role(&key),
                self.user_flags(colliders, c1) | self.user_flags(colliders, c2),
            )
        })
    }

    /// The hook flags the user asked for on a collider.
    pub(crate) fn user_flags(&self, colliders: &ColliderSet, c: ColliderHandle) -> ActiveHooks {
        self.step_user_flags(c)
            .unwrap_or_else(|| self.flags.recorded_user_flags(colliders, c))
    }

    /// `Some((body collider, ground collider))` when the pair is a managed body against a
    /// ground.
    pub(crate) fn managed_pair(
        &self,
        bodies: &RigidBodySet,
        colliders: &ColliderSet,
        c1: ColliderHandle,
        c2: ColliderHandle,
    ) -> Option<PairKey> {
        let (body, ground) = match (
            self.registry.entry(c1).is_some(),
            self.registry.entry(c2).is_some(),
        ) {
            (true, false) => (c2, c1),
            (false, true) => (c1, c2),
            _ => return None,
        };
        if let Some(parent) = colliders.get(ground)?.parent() {
            if bodies.get(parent).is_none_or(|rb| rb.is_dynamic()) {
                return None;
            }
        }
        let parent = colliders.get(body)?.parent()?;
        let rb = bodies.get(parent)?;
        self.registry.manages(parent, rb).then_some((body, ground))
    }

    /// Takes the plugin's hook flags off every collider (the user's flags back) and returns
    /// the wrapped hook. Use it to go on without the plugin: otherwise the flags it left make
    /// rapier call the next hook for pairs the user never asked about.
    pub fn detach(mut self, colliders: &mut ColliderSet) -> H {
        self.flags.restore_all(colliders);
        self.user_hooks
    }

    /// Inside rapier's step: the user's flags of a collider the plugin flagged, `None` for
    /// another collider (its flags are the user's) or outside the step's tables.
    pub(crate) fn step_user_flags(&self, c: ColliderHandle) -> Option<ActiveHooks> {
        match self.step.lookup.user_flags.get(slot_of(c)) {
            Some(Some((h, user))) if *h == c => Some(*user),
            _ => None,
        }
    }

    /// Steps `world` once with the plugin: [`Self::before_step`], rapier's step with the
    /// plugin as hooks, [`Self::after_step`].
    pub fn step(&mut self, world: &mut PhysicsWorld)
    where
        H: crate::rapier::pipeline::PhysicsHooks,
    {
        self.step_with_events(world, &());
    }

    /// [`Self::step`] with rapier's event handler `events`.
    pub fn step_with_events(&mut self, world: &mut PhysicsWorld, events: &dyn EventHandler)
    where
        H: crate::rapier::pipeline::PhysicsHooks,
    {
        self.before_step(
            world.gravity,
            &world.integration_parameters,
            &mut world.bodies,
            &mut world.colliders,
            &world.narrow_phase,
            &world.impulse_joints,
            &world.multibody_joints,
        );
        world.step_with_events(&*self, events);
        self.after_step(
            &mut world.bodies,
            &mut world.colliders,
            &world.narrow_phase,
            &world.impulse_joints,
            &world.multibody_joints,
        );
    }

    /// Prepares a step: call it right before rapier's `PhysicsPipeline::step` with the same
    /// gravity, parameters and sets. Clears the events, reads the managed bodies near a
    /// ground, and in `Step` mode applies the impulses of the contacts that close in this
    /// step. The joints are read for rapier's pair filtering (a joint can disable its bodies'
    /// contacts).
    // The sets rapier's own `PhysicsPipeline::step` takes, which has the same allowance.
    #[allow(clippy::too_many_arguments)]
    pub fn before_step(
        &mut self,
        gravity: Vector,
        params: &IntegrationParameters,
        bodies: &mut RigidBodySet,
        colliders: &mut ColliderSet,
        narrow_phase: &NarrowPhase,
        impulse_joints: &ImpulseJointSet,
        multibody_joints: &MultibodyJointSet,
    ) where
        H: PhysicsHooks,
    {
        self.events.clear();
        let sets = Sets {
            narrow_phase,
            impulse_joints,
            multibody_joints,
        };
        // The hooks' tables are rebuilt at the end.
        self.step.lookup = Lookup::default();
        self.registry.sync(bodies, colliders);
        let dt = to_f64(params.dt);
        let g = vec_to_na(gravity);
        let mut step = StepData {
            active: dt > 0.0,
            dt,
            policy: Policy::new(
                &self.config,
                g.norm(),
                dt,
                to_f64(params.allowed_linear_error()),
                to_f64(params.prediction_distance()),
            ),
            down: g.try_normalize(0.0).unwrap_or_else(Vector3::zeros),
            gravity: g,
            ..Default::default()
        };
        if !step.active {
            self.step = step;
            return;
        }
        self.registry.index.refresh(
            &self.registry.grounds,
            bodies,
            colliders,
            dt,
            step.policy.resting_gap,
        );
        // Lent to the step; given back at its end (`Self::after_step`).
        step.grounds = std::mem::take(&mut self.registry.index.motions);
        // Last step's shadows and roles are read while this step's are written into the
        // spare tables.
        let shadows = std::mem::replace(&mut self.shadows, std::mem::take(&mut self.spare.shadows));
        self.shadows.clear();
        let prev_roles = std::mem::take(&mut self.prev_roles);
        step.roles = std::mem::take(&mut self.spare.roles);
        step.roles.clear();
        step.candidates = std::mem::take(&mut self.spare.candidates);
        step.candidates.clear();
        // The awake managed bodies that may reach a ground. A body surely far from every
        // ground needs no snapshot, inertia or geometry (only its flight in `Exact` mode); a
        // body without collider is skipped.
        let margin = crate::plugin::bridge::convert::to_real(
            step.policy.resting_gap.max(step.policy.prediction),
        );
        let g_len = gravity.length();
        // The pairs of opted-in balls first: a sleeping ball a pair may reach is woken, and the
        // balls of `Impact` pairs are planned whatever their distance to the grounds.
        let prev_pairs = std::mem::take(&mut self.prev_pair_roles);
        step.pairs = pair_plan::plan_pairs(
            &mut self.pair_index,
            bodies,
            &pair_plan::PairInputs {
                registry: &self.registry,
                flags: &self.flags,
                user_hooks: &self.user_hooks,
                colliders,
                sets: &sets,
                prev: &prev_pairs,
                grounds: &step.grounds,
                gravity: g,
                dt,
                policy: &step.policy,
            },
        );
        if self.config.timing == TimingMode::Step && !step.pairs.members.is_empty() {
            let events = pair_plan::step_start_impulses(
                &mut step.pairs,
                bodies,
                &pair_plan::StepStart {
                    colliders,
                    law: self.config.law,
                    max_impacts: self.config.max_impacts_per_step,
                    flat_tolerance: self.config.flat_tolerance,
                    policy: &step.policy,
                    dt,
                },
            );
            self.events.extend(events);
        }
        let mut handles: Vec<RigidBodyHandle> = Vec::new();
        // Awake managed bodies with no ground in reach: no roles (see `Lookup::roles`).
        let mut far_bodies: Vec<RigidBodyHandle> = Vec::new();
        // A dynamic body the plugin does not manage decides where the hook flags go.
        let mut unmanaged = false;
        for (handle, rb) in bodies.iter() {
            if !self.registry.manages(handle, rb) {
                unmanaged |= rb.is_dynamic() && rb.is_enabled();
                continue;
            }
            if rb.is_sleeping() {
                step.asleep.push(handle);
                continue;
            }
            if step.pairs.members.contains(&handle) {
                handles.push(handle);
                continue;
            }
            match surely_far(
                rb,
                colliders,
                g_len,
                params.dt,
                margin,
                &self.registry.index,
                &step.grounds,
            ) {
                Some(true) => {
                    far_bodies.push(handle);
                    if self.config.timing == TimingMode::Exact {
                        let (start, flight, local_com) = snapshot(rb, g, dt, shadows.get(&handle));
                        step.candidates
                            .push(Candidate::flying(handle, start, flight, local_com));
                    }
                }
                Some(false) => handles.push(handle),
                None => {}
            }
        }
        let mut near_bodies = Vec::with_capacity(self.flags.hooked().len());
        let mut planner = Planner {
            config: &self.config,
            registry: &self.registry,
            flags: &self.flags,
            user_hooks: &self.user_hooks,
            prev_holds: &self.prev_holds,
            events: &mut self.events,
        };
        for handle in handles {
            let near = planner.plan_body(
                handle,
                bodies,
                colliders,
                &sets,
                &shadows,
                &prev_roles,
                g,
                dt,
                &mut step,
            );
            if near {
                near_bodies.push(handle);
            } else {
                far_bodies.push(handle);
            }
        }
        // The planned pairs that need the hooks (`PlannedPair::hooked`): `Impact` pairs leave
        // rapier's solver, `Resting` ones rapier would bounce get zero restitution. rapier
        // hooks a pair when either collider is flagged, and every pair of a flagged ball loses
        // its recycling: one ball of each pair is flagged, one already flagged where there is
        // one (a flag put on or taken off is a change rapier's next step processes).
        let mut chosen: HandleSet<RigidBodyHandle> = HandleSet::default();
        let mut members: Vec<RigidBodyHandle> = Vec::new();
        for pair in step.pairs.pairs.iter().filter(|pair| pair.hooked) {
            if chosen.contains(&pair.a) || chosen.contains(&pair.b) {
                continue;
            }
            let body = if self.flags.hooked().contains_key(&pair.b) {
                pair.b
            } else {
                pair.a
            };
            chosen.insert(body);
            members.push(body);
        }
        self.flags.update(
            &self.registry,
            &near_bodies,
            &members,
            unmanaged,
            bodies,
            colliders,
        );
        self.registry.flags_stale = false;
        let flags = &self.flags;
        let far_colliders: Vec<ColliderHandle> = far_bodies
            .iter()
            .filter_map(|h| bodies.get(*h))
            .flat_map(|rb| rb.colliders().iter().copied())
            .collect();
        step.lookup = Lookup::build(&step.roles, &far_colliders, flags.hooked(), |c| {
            flags.recorded_user_flags(colliders, c)
        });
        self.spare.shadows = shadows;
        self.spare.roles = prev_roles;
        self.step = step;
    }

    /// Finishes a step: call it right after rapier's `PhysicsPipeline::step`. Resolves the
    /// managed impacts, writes poses and velocities back (bodies woken up), moves their
    /// colliders, and records the [`ImpactEvent`]s.
    pub fn after_step(
        &mut self,
        bodies: &mut RigidBodySet,
        colliders: &mut ColliderSet,
        narrow_phase: &NarrowPhase,
        impulse_joints: &ImpulseJointSet,
        multibody_joints: &MultibodyJointSet,
    ) where
        H: PhysicsHooks,
    {
        let sets = Sets {
            narrow_phase,
            impulse_joints,
            multibody_joints,
        };
        let mut step = EndOfStep {
            data: std::mem::take(&mut self.step),
            sets,
        };
        if !step.active {
            return;
        }
        step.active = false;
        self.prev_roles = std::mem::take(&mut step.roles);
        self.prev_pair_roles = std::mem::take(&mut step.data.pairs.roles);
        self.prev_holds.clear();
        self.prev_holds.extend(step.holds.keys().copied());
        // The grounds' actual motion over the step.
        let dt = step.dt;
        for i in self.registry.index.moving() {
            let gm = &mut step.data.grounds[*i];
            if let Some(bh) = gm.body {
                if let Some(rb) = bodies.get(bh) {
                    if !rb.is_fixed() {
                        let end = pose_to_na(rb.position());
                        let com1 =
                            end * nalgebra::Point3::from(vec_to_na(rb.local_center_of_mass()));
                        let rot1 = end.rotation;
                        gm.v = (com1.coords - gm.com0) / dt;
                        gm.w = (rot1 * gm.rot0.inverse()).scaled_axis() / dt;
                    }
                }
            }
        }
        for handle in &step.asleep {
            let Some(rb) = bodies.get(*handle) else {
                continue;
            };
            if rb.is_sleeping() || !self.registry.manages(*handle, rb) {
                continue;
            }
            // Asleep at the start, it has no roles: the joints and the user's filter are asked
            // here (rapier's own filters in `Settle::woken_geoms`).
            let (user_hooks, flags) = (&self.user_hooks, &self.flags);
            let refused = |bodies: &RigidBodySet, part: ColliderHandle, ground: ColliderHandle| {
                let user = flags.recorded_user_flags(colliders, part)
                    | flags.recorded_user_flags(colliders, ground);
                colliders[ground].parent().is_some_and(|ground_body| {
                    filter::joint_disables_contacts(
                        impulse_joints,
                        multibody_joints,
                        *handle,
                        ground_body,
                    )
                }) || filter::user_refuses(user_hooks, user, bodies, colliders, (part, ground))
            };
            // `Self::settle` would borrow the user's hook that `refused` reads.
            let mut settle = Settle {
                config: &self.config,
                registry: &self.registry,
                flags: &self.flags,
                roles: &self.prev_roles,
                events: &mut self.events,
                shadows: &mut self.shadows,
            };
            let local_com = vec_to_na(rb.local_center_of_mass());
            let geom = body_geom(rb, colliders, &local_com);
            let grounds = settle.woken_geoms(
                bodies,
                colliders,
                rb.center_of_mass(),
                &geom,
                &step,
                &refused,
            );
            let inertia = Inertia::of(rb);
            let checked = Checked {
                body: *handle,
                geom: &geom,
                inertia: &inertia,
                cand: None,
            };
            let from = settle.events.len();
            let end = rapier_state(rb);
            let (_, settled) = settle.check(
                bodies,
                colliders,
                &checked,
                &end,
                EndCheck::Woken,
                &grounds,
                &step,
                from,
            );
            if let Some(s) = settled {
                write_state(&mut bodies[*handle], &s, &local_com, true);
            }
        }
        let mode = self.config.timing;
        // The balls of impacts between bodies, moved together where they moved alone.
        let moved_together =
            pair_reconstruct::move_clusters(&mut self.settle(), bodies, colliders, &step);
        for cand in &step.candidates {
            // A body rapier put to sleep in this step rests: rapier zeroed its velocities, and
            // its contacts have left the solver's graph, so it would look free and fall for a
            // step in `Exact` mode (a box resting flat went 6.9 mm into the ground at 30 Hz).
            if moved_together.contains(&cand.body)
                || !bodies
                    .get(cand.body)
                    .is_some_and(|rb| self.registry.manages(cand.body, rb) && !rb.is_sleeping())
            {
                continue;
            }
            let rb = &bodies[cand.body];
            if let Some((ground, motion)) = &cand.rolling {
                let geom = body_geom(rb, colliders, &cand.local_com);
                let settle = self.settle();
                let Some(gg) = settle.pair_geom(&step.grounds[*ground], &geom, colliders) else {
                    continue;
                };
                // With the other grounds near it (the pieces of its plane, if it rolls across
                // a seam), each without the pairs rapier's or the user's filter refused.
                let grounds: SmallList<_> = std::iter::once(gg)
                    .chain(
                        cand.near
                            .iter()
                            .filter(|i| *i != ground)
                            .filter_map(|i| settle.pair_geom(&step.grounds[*i], &geom, colliders)),
                    )
                    .collect();
                // Something else acted on it in the step: a contact, a joint, or rapier's CCD
                // stopping it short (against a thin body).
                let disturbed = impulse_joints.attached_joints(cand.body).next().is_some()
                    || multibody_joints.rigid_body_link(cand.body).is_some()
                    || pushed_by_other(rb, narrow_phase)
                    || !ccd_consistent(rb, cand, step.dt, step.dt, &step);
                if !disturbed && !cand.impact_grounds.is_empty() {
                    // A ground it may roll into: where it does, that impact, and on from
                    // there.
                    let obstacles = self
                        .settle()
                        .impact_ground_geoms(cand, &geom, colliders, &step);
                    if let Some(touch) =
                        reconstruct::rolling_touch(cand, motion, &geom, &obstacles, &step)
                    {
                        self.rolled_into(
                            bodies, colliders, cand, motion, &geom, &grounds, &obstacles, touch,
                            &step,
                        );
                        continue;
                    }
                }
                let rolled = (!disturbed)
                    .then(|| reconstruct::rolled(cand, motion, &geom, &grounds, &step))
                    .flatten();
                if let Some(end) = rolled {
                    let rb = &mut bodies[cand.body];
                    write_state(rb, &end, &cand.local_com, true);
                    if mode == TimingMode::Exact {
                        self.settle().remember(cand.body, rb, &end);
                    }
                } else {
                    // rapier's end state stands, in which the ball flew without its ground.
                    if let (true, Some(part)) = (disturbed, geom.parts.first()) {
                        let key = (part.handle, grounds[0].handle);
                        let rb = &bodies[cand.body];
                        self.events
                            .push(released_at_end(cand, rb, key, motion, step.dt));
                        // Released here: the next step's plan, finding it within reach,
                        // does not release it again.
                        self.prev_roles.insert(key, Role::Resting);
                    }
                    let fall = -motion.accel.dot(&motion.normal) * step.dt;
                    let why = EndCheck::DisturbedRolling { fall };
                    self.settle_rapier_end(bodies, colliders, cand, &geom, &grounds, why, &step);
                }
                continue;
            }
            let has_grounds = cand
                .impact_grounds
                .iter()
                .any(|i| colliders.get(step.grounds[*i].handle).is_some());
            if !has_grounds && !cand.turning_resting.is_empty() {
                let geom = body_geom(rb, colliders, &cand.local_com);
                let grounds = self
                    .settle()
                    .turning_resting_geoms(cand, &geom, colliders, &step);
                let why = EndCheck::TurningResting {
                    turns_surface: cand.turns_surface,
                };
                // Corrected (rapier's end state then stands), no flight is written over it.
                if self.settle_rapier_end(bodies, colliders, cand, &geom, &grounds, why, &step)
                    != EndAction::Keep
                {
                    continue;
                }
            }
            let rb = &bodies[cand.body];
            // Nothing but its flight moved it: no contact in rapier's solver, joint, torque or
            // `Step` impulse. A body whose linear velocity rapier changed otherwise than its
            // flight does was pushed (a ball resting in a pile), and its contacts are not
            // walked (that walk of rapier's contact graph for every body of a pile was 14 % of
            // an `Exact` run).
            let free = (has_grounds || reconstruct::moved_as_flown(rb, cand, step.dt))
                && impulse_joints.attached_joints(cand.body).next().is_none()
                && multibody_joints.rigid_body_link(cand.body).is_none()
                && rb.user_torque() == Vector::ZERO
                && !cand.touched
                && !touches_other(rb, narrow_phase);
            // Before any geometry: a body with no ground left to search, or whose search
            // would find the step clear (`Candidate::closing`) and that rapier's CCD did not
            // cut short, only flies (exactly, in `Exact` mode).
            let clear = mode != TimingMode::Step
                && free
                && has_grounds
                && !cand.closing
                && ccd_consistent(rb, cand, step.dt, step.dt, &step);
            if !has_grounds || clear {
                if mode == TimingMode::Exact
                    && free
                    && (clear || ccd_consistent(rb, cand, step.dt, step.dt, &step))
                {
                    self.fly_exactly(bodies, cand, step.dt);
                }
                if has_grounds {
                    self.turned_end(bodies, colliders, cand, &step);
                }
                continue;
            }
            let geom = body_geom(rb, colliders, &cand.local_com);
            let grounds = self
                .settle()
                .impact_ground_geoms(cand, &geom, colliders, &step);
            let inertia = Inertia::of(rb);
            // In-step resolution from the start-of-step state, unless the body touched
            // something else (or the mode is `Step`), or rapier's CCD cut its motion short
            // before the first impact: then the step-end check of rapier's end state.
            let first = (mode != TimingMode::Step && free).then(|| {
                if cand.closing {
                    first_impact(
                        &geom,
                        &grounds,
                        &cand.flight,
                        &cand.start,
                        0.0,
                        0.0,
                        step.dt,
                    )
                } else {
                    Search::Clear
                }
            });
            let first = first.filter(|f| {
                let t_first = match f {
                    Search::Hit(t, ..) | Search::Stalled(t, _) => *t,
                    Search::Clear => step.dt,
                };
                ccd_consistent(rb, cand, t_first, step.dt, &step)
            });
            let Some(first) = first else {
                let why = EndCheck::RapierEnd;
                self.settle_rapier_end(bodies, colliders, cand, &geom, &grounds, why, &step);
                continue;
            };
            if let Search::Clear = first {
                if mode == TimingMode::Exact {
                    self.fly_exactly(bodies, cand, step.dt);
                }
                self.turned_end(bodies, colliders, cand, &step);
                continue;
            }
            self.fly_through_impacts(
                bodies, colliders, cand, &geom, &grounds, &inertia, first, &step,
            );
        }
        // The pairs not moved together: rapier's end state (the pair out of its solver),
        // checked at the step's end.
        for pair in &step.pairs.pairs {
            if pair.role == Role::Impact
                && !(moved_together.contains(&pair.a) && moved_together.contains(&pair.b))
            {
                self.settle().pair_end(bodies, colliders, pair, &step);
            }
        }
        for hold in &step.first_holds {
            self.put_back_held(bodies, hold, &step);
        }
        bodies.propagate_modified_body_positions_to_colliders(colliders);
        self.registry.index.motions = std::mem::take(&mut step.data.grounds);
        self.spare.candidates = std::mem::take(&mut step.data.candidates);
    }
}

/// The [`EventKind::Released`] event of a rolling ball that something besides its ground
/// touched in the step: rapier's end state, unchanged.
fn released_at_end(
    cand: &Candidate,
    rb: &crate::rapier::prelude::RigidBody,
    (collider, ground): PairKey,
    motion: &Rolling,
    dt: f64,
) -> ImpactEvent {
    let end = rapier_state(rb);
    let site = Site {
        body: cand.body,
        collider,
        ground,
        body2: None,
        normal: motion.normal,
        point: end.com - motion.normal * motion.radius,
    };
    released(&site, &Inertia::of(rb), &end, dt)
}
