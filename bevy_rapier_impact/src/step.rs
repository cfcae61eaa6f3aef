//! The step system: bevy_rapier's `PhysicsSet::StepSimulation`, with the core plugin around
//! every rapier step.
//!
//! Contract, per frame and per rapier context, in `PhysicsSet::StepSimulation` (after
//! bevy_rapier's `SyncBackend` has created and updated the rapier objects, before its
//! `Writeback` copies them to the components):
//! 1. apply [`ImpactSettings`] if they changed; mark the colliders with [`Ground`] that are
//!    not grounds yet, unmark those whose marker or entity is gone, give each its
//!    [`GroundMaterial`] where it changed; give the bodies their own settings ([`ImpactBody`],
//!    [`TangentialRestitution`], [`RestitutionBySpeed`], [`Rolling`]) where they changed, and
//!    take them back from the bodies whose components or entity are gone;
//! 2. plan the frame's rapier steps as bevy_rapier would ([`FramePlan`]: its timestep mode,
//!    substeps and interpolation catch-up);
//! 3. for each rapier step: `ImpactPlugin::before_step`, one rapier step through bevy_rapier's
//!    `RapierContextSimulation::step_simulation` (as `TimestepMode::Fixed` with one substep of
//!    the planned length, the plugin as the hooks), `ImpactPlugin::after_step`, then the step's
//!    collision and contact-force messages and its [`ImpactMessage`]s;
//! 4. what bevy_rapier's step system does after its steps: the frame's `dt` back in the
//!    integration parameters, colliders moved if no step ran, the quarantine reported and
//!    mirrored on the entities ([`mirror_quarantine`]).
//!
//! Why not bevy_rapier's own step system: it runs all the frame's rapier steps inside one call
//! of `step_simulation`, whose only callbacks (the hooks and the event handler) get read-only
//! bodies, so nothing can run `after_step` between two of its substeps.
//! Nothing here panics on the world's state: a missing entity is `Entity::PLACEHOLDER` in a
//! message, a refused ground or setting an [`ImpactErrorMessage`].

use crate::components::{
    BodySettings, BodyState, Ground, GroundMaterial, GroundState, ImpactBody, ImpactSettings,
    ImpactSimulation, RestitutionBySpeed, Rolling, TangentialRestitution, curve_of,
};
use crate::hooks::UserHooks;
use crate::messages::{ImpactErrorMessage, ImpactMessage};
use crate::timestep::FramePlan;
use bevy::ecs::system::{StaticSystemParam, SystemParam, SystemParamItem};
use bevy::prelude::*;
use bevy_rapier3d::geometry::ColliderDisabled;
use bevy_rapier3d::pipeline::{
    BevyPhysicsHooks, CollisionEvent, ContactForceEvent, PhysicsQuarantineEvent,
};
use bevy_rapier3d::plugin::context::{
    RapierContextColliders, RapierContextEntityLink, RapierContextJoints, RapierContextSimulation,
    RapierRigidBodySet, SimulationToRenderTime,
};
use bevy_rapier3d::plugin::{RapierConfiguration, SimulationMode, TimestepMode};
use bevy_rapier3d::prelude::{
    RapierColliderHandle, RapierRigidBodyHandle, RigidBodyDisabled, SoftBodyDisabled,
    TransformInterpolation,
};
use bevy_rapier3d::rapier::prelude::{
    ColliderHandle, ColliderSet, PhysicsHooks, RigidBodyHandle, RigidBodySet,
};
use rapier_impact::{ConfigError, ImpactConfig, ImpactPlugin, StepSets};

/// The messages the step writes.
#[derive(SystemParam)]
pub(crate) struct StepWriters<'w> {
    collisions: MessageWriter<'w, CollisionEvent>,
    contact_forces: MessageWriter<'w, ContactForceEvent>,
    quarantine: MessageWriter<'w, PhysicsQuarantineEvent>,
    impacts: MessageWriter<'w, ImpactMessage>,
    errors: MessageWriter<'w, ImpactErrorMessage>,
}

/// What the frame is: the settings, bevy_rapier's timestep mode, and Bevy's clock.
#[derive(SystemParam)]
pub(crate) struct FrameInputs<'w> {
    settings: Res<'w, ImpactSettings>,
    timestep_mode: Res<'w, TimestepMode>,
    time: Res<'w, Time>,
}

/// A rapier context's components, as bevy_rapier's step system reads them, and the plugin's.
type Contexts<'w, 's> = Query<
    'w,
    's,
    (
        Entity,
        &'static mut RapierContextSimulation,
        &'static mut RapierContextColliders,
        &'static mut RapierContextJoints,
        &'static mut RapierRigidBodySet,
        &'static RapierConfiguration,
        &'static mut SimulationToRenderTime,
        &'static mut ImpactSimulation,
    ),
>;

/// The collider entities marked [`Ground`] that bevy_rapier has created, with their context
/// and material.
type Grounds<'w, 's> = Query<
    'w,
    's,
    (
        Entity,
        &'static RapierColliderHandle,
        &'static RapierContextEntityLink,
        Option<&'static GroundMaterial>,
    ),
    With<Ground>,
>;

/// The rigid body entities with settings of their own that bevy_rapier has created, with
/// their context.
type Bodies<'w, 's> = Query<
    'w,
    's,
    (
        Entity,
        &'static RapierRigidBodyHandle,
        &'static RapierContextEntityLink,
        (
            Has<ImpactBody>,
            Option<&'static TangentialRestitution>,
            Option<&'static RestitutionBySpeed>,
            Option<&'static Rolling>,
        ),
    ),
    Or<(
        With<ImpactBody>,
        With<TangentialRestitution>,
        With<RestitutionBySpeed>,
        With<Rolling>,
    )>,
>;

/// Advances every rapier context by one frame, the core plugin around each rapier step (see
/// the module's contract). Replaces bevy_rapier's `step_simulation::<H>`.
pub(crate) fn step_with_impacts<H>(
    mut contexts: Contexts,
    grounds: Grounds,
    own: Bodies,
    frame: FrameInputs,
    hooks: StaticSystemParam<H>,
    mut writers: StepWriters,
    mut interpolation: Query<(&RapierRigidBodyHandle, &mut TransformInterpolation)>,
) where
    H: 'static + BevyPhysicsHooks,
    for<'w, 's> SystemParamItem<'w, 's, H>: BevyPhysicsHooks,
{
    let user_hooks = hooks.into_inner();
    let (settings, time) = (&*frame.settings, &*frame.time);
    for (ctx, mut sim, mut colliders, mut joints, mut bodies, config, mut lag, mut impact) in
        contexts.iter_mut()
    {
        let (sim, colliders, joints, bodies) =
            (&mut *sim, &mut *colliders, &mut *joints, &mut *bodies);
        let impact = &mut *impact;
        // Out of its component for the hook swap, put back below. It is missing only if a
        // frame was cut short (a user hook panicked): start again from a new plugin, to which
        // the settings and the grounds are applied anew.
        let mut plugin = match impact.plugin.take() {
            Some(plugin) => plugin,
            None => {
                let Ok(fresh) = ImpactPlugin::new(ImpactConfig::default()) else {
                    continue;
                };
                impact.grounds.clear();
                impact.bodies.clear();
                impact.applied = None;
                fresh
            }
        };
        apply_settings(ctx, settings, impact, &mut plugin, &mut writers.errors);
        sync_grounds(
            ctx,
            &grounds,
            impact,
            &mut plugin,
            &bodies.bodies,
            &colliders.colliders,
            &mut writers.errors,
        );
        sync_bodies(
            ctx,
            &own,
            impact,
            &mut plugin,
            &bodies.bodies,
            &mut writers.errors,
        );
        if !config.physics_pipeline_active {
            bodies.propagate_modified_body_positions_to_colliders(colliders);
            impact.plugin = Some(plugin);
            sim.send_quarantine_events(ctx, &mut writers.quarantine);
            continue;
        }
        sim.set_num_threads(config.num_threads);
        let plan = FramePlan::new(*frame.timestep_mode, time.delta_secs(), &mut lag.diff);
        let full = config.simulation_mode == SimulationMode::Full;
        // The frame's hook in the plugin: the user's Bevy hooks, borrowed for this run.
        let (mut hooked, ()) = plugin.replace_hooks(UserHooks(&user_hooks));
        // bevy_rapier's interpolation lag is ours (updated by the plan); this one is only
        // what its `Fixed` mode asks for and leaves alone.
        let mut unused_lag = SimulationToRenderTime::default();
        for round in 0..plan.rounds {
            if plan.interpolation_round == Some(round) {
                for (handle, mut interp) in interpolation.iter_mut() {
                    if let Some(rb) = bodies.bodies.get(handle.0) {
                        interp.start = Some(*rb.position());
                        interp.end = None;
                    }
                }
            }
            for _ in 0..plan.per_round {
                let mut params = sim.integration_parameters;
                params.dt = plan.step_dt;
                if full {
                    let sets = StepSets::new(
                        &mut bodies.bodies,
                        &mut colliders.colliders,
                        &sim.narrow_phase,
                        &joints.impulse_joints,
                        &joints.multibody_joints,
                    );
                    hooked.before_step(config.gravity, &params, sets);
                }
                // Without dynamics (`CollisionOnly`) the plugin has nothing to resolve; the
                // user's hooks still see every pair.
                let step_hooks: &dyn PhysicsHooks =
                    if full { &hooked } else { hooked.user_hooks() };
                sim.step_simulation(
                    colliders,
                    joints,
                    bodies,
                    config.gravity,
                    config.simulation_mode,
                    TimestepMode::Fixed {
                        dt: plan.step_dt,
                        substeps: 1,
                    },
                    Some((&writers.collisions, &writers.contact_forces)),
                    step_hooks,
                    time,
                    &mut unused_lag,
                    None,
                );
                // Each call replaces the previous call's pending events: send them now.
                sim.send_bevy_events(&mut writers.collisions, &mut writers.contact_forces);
                if full {
                    hooked.after_step(StepSets::new(
                        &mut bodies.bodies,
                        &mut colliders.colliders,
                        &sim.narrow_phase,
                        &joints.impulse_joints,
                        &joints.multibody_joints,
                    ));
                    write_impacts(
                        ctx,
                        impact.steps,
                        &hooked,
                        &bodies.bodies,
                        &colliders.colliders,
                        &mut writers.impacts,
                    );
                }
                impact.steps += 1;
            }
        }
        let (plugin, _) = hooked.replace_hooks(());
        impact.plugin = Some(plugin);
        // As bevy_rapier leaves it: the frame's length, not the last step's.
        sim.integration_parameters.dt = plan.frame_dt;
        if plan.steps() == 0 {
            // As bevy_rapier: colliders follow bodies the user moved, even without a step.
            bodies.propagate_modified_body_positions_to_colliders(colliders);
        }
        sim.send_quarantine_events(ctx, &mut writers.quarantine);
    }
}

/// Applies the settings if they changed since they were last applied to this context.
fn apply_settings(
    ctx: Entity,
    settings: &ImpactSettings,
    impact: &mut ImpactSimulation,
    plugin: &mut ImpactPlugin,
    errors: &mut MessageWriter<ImpactErrorMessage>,
) {
    if impact.applied.as_ref() == Some(settings) {
        return;
    }
    impact.applied = Some(settings.clone());
    if *plugin.config() != settings.config
        && let Err(error) = plugin.set_config(settings.config.clone())
    {
        errors.write(ImpactErrorMessage {
            context: ctx,
            entity: None,
            error,
        });
    }
    plugin.set_all_fixed_colliders_ground(settings.all_fixed_colliders_ground);
}

/// Reports a refusal of the core plugin.
fn report(
    errors: &mut MessageWriter<ImpactErrorMessage>,
    ctx: Entity,
    entity: Option<Entity>,
    result: Result<(), ConfigError>,
) {
    if let Err(error) = result {
        errors.write(ImpactErrorMessage {
            context: ctx,
            entity,
            error,
        });
    }
}

/// Marks the context's new [`Ground`] colliders, gives each its [`GroundMaterial`] where it
/// changed, and unmarks the ones whose marker, entity or rapier collider is gone.
fn sync_grounds(
    ctx: Entity,
    grounds: &Grounds,
    impact: &mut ImpactSimulation,
    plugin: &mut ImpactPlugin,
    bodies: &RigidBodySet,
    colliders: &ColliderSet,
    errors: &mut MessageWriter<ImpactErrorMessage>,
) {
    impact.seen.clear();
    for (entity, handle, link, material) in grounds.iter() {
        if link.0 != ctx {
            continue;
        }
        impact.seen.insert(entity);
        let handle = handle.0;
        let known = impact.grounds.get_mut(&entity);
        match known {
            Some(known) if known.handle == handle => {
                if known.material.as_ref() == material {
                    continue;
                }
                // Only the material changed; a refused ground has none to change.
                if known.taken {
                    let set = set_material(plugin, handle, material);
                    report(errors, ctx, Some(entity), set);
                }
                known.material = material.cloned();
            }
            _ => {
                // New, or bevy_rapier made it a new rapier collider: the old one is no ground.
                if let Some(old) = known.filter(|old| old.taken) {
                    plugin.remove_ground(old.handle);
                }
                let taken = plugin.add_ground(bodies, colliders, handle);
                let ok = taken.is_ok();
                report(errors, ctx, Some(entity), taken);
                if ok && material.is_some() {
                    let set = set_material(plugin, handle, material);
                    report(errors, ctx, Some(entity), set);
                }
                let state = GroundState {
                    handle,
                    taken: ok,
                    material: material.cloned(),
                };
                impact.grounds.insert(entity, state);
            }
        }
    }
    let seen = &impact.seen;
    impact.grounds.retain(|entity, state| {
        let keep = seen.contains(entity);
        if !keep && state.taken {
            plugin.remove_ground(state.handle);
        }
        keep
    });
}

/// Gives a ground its material, or takes it back (`None`).
fn set_material(
    plugin: &mut ImpactPlugin,
    ground: ColliderHandle,
    material: Option<&GroundMaterial>,
) -> Result<(), ConfigError> {
    let material = material.map(GroundMaterial::to_core).transpose()?;
    plugin.set_ground_material(ground, material)
}

/// Gives the core plugin the context's bodies' own settings where they changed, and takes
/// them back from the bodies whose components, entity or rapier body are gone.
fn sync_bodies(
    ctx: Entity,
    own: &Bodies,
    impact: &mut ImpactSimulation,
    plugin: &mut ImpactPlugin,
    bodies: &RigidBodySet,
    errors: &mut MessageWriter<ImpactErrorMessage>,
) {
    impact.seen.clear();
    for (entity, handle, link, (impact_body, beta, curve, rolling)) in own.iter() {
        if link.0 != ctx {
            continue;
        }
        impact.seen.insert(entity);
        let handle = handle.0;
        let dynamic = bodies.get(handle).is_some_and(|rb| rb.is_dynamic());
        let (impact_body, beta, curve, rolling) = (
            impact_body.then_some(dynamic),
            beta.map(|b| b.0),
            curve.map(|c| c.0.as_slice()),
            rolling.copied(),
        );
        let known = impact.bodies.get(&entity);
        let applied = match known {
            Some(known) if known.handle == handle => {
                let s = &known.settings;
                if (
                    s.impact,
                    s.tangential_restitution,
                    s.restitution_curve.as_deref(),
                    s.rolling,
                ) == (impact_body, beta, curve, rolling)
                {
                    continue;
                }
                s.clone()
            }
            Some(known) => {
                // bevy_rapier made it a new rapier body: the old one has nothing of its own.
                forget_body(plugin, known.handle);
                BodySettings::default()
            }
            None => BodySettings::default(),
        };
        let wanted = BodySettings {
            impact: impact_body,
            tangential_restitution: beta,
            restitution_curve: curve.map(<[_]>::to_vec),
            rolling,
        };
        let mut refused = |result| report(errors, ctx, Some(entity), result);
        if wanted.impact != applied.impact {
            refused(match wanted.impact {
                Some(_) => plugin.add_impact_body(bodies, handle).inspect_err(|_| {
                    plugin.remove_impact_body(handle);
                }),
                None => {
                    plugin.remove_impact_body(handle);
                    Ok(())
                }
            });
        }
        if wanted.tangential_restitution != applied.tangential_restitution {
            refused(plugin.set_body_tangential_restitution(handle, wanted.tangential_restitution));
        }
        if wanted.restitution_curve != applied.restitution_curve {
            let curve = wanted
                .restitution_curve
                .as_deref()
                .map(curve_of)
                .transpose();
            refused(curve.and_then(|curve| plugin.set_body_restitution_curve(handle, curve)));
        }
        if wanted.rolling != applied.rolling {
            let rolling = wanted.rolling.map(Into::into);
            refused(plugin.set_body_rolling(handle, rolling));
        }
        impact.bodies.insert(
            entity,
            BodyState {
                handle,
                settings: wanted,
            },
        );
    }
    let seen = &impact.seen;
    impact.bodies.retain(|entity, state| {
        let keep = seen.contains(entity);
        if !keep {
            forget_body(plugin, state.handle);
        }
        keep
    });
}

/// Takes a body's own settings back (never refused): the core plugin's defaults apply.
fn forget_body(plugin: &mut ImpactPlugin, body: RigidBodyHandle) {
    plugin.remove_impact_body(body);
    let _ = plugin.set_body_tangential_restitution(body, None);
    let _ = plugin.set_body_restitution_curve(body, None);
    let _ = plugin.set_body_rolling(body, None);
}

/// The last step's core events as messages, handles turned into entities.
fn write_impacts<H>(
    ctx: Entity,
    step: u64,
    plugin: &ImpactPlugin<H>,
    bodies: &RigidBodySet,
    colliders: &ColliderSet,
    impacts: &mut MessageWriter<ImpactMessage>,
) {
    // bevy_rapier stores each object's entity bits in its `user_data`.
    let body_entity = |h| {
        bodies
            .get(h)
            .and_then(|rb| Entity::try_from_bits(rb.user_data as u64))
            .unwrap_or(Entity::PLACEHOLDER)
    };
    let collider_entity = |h| {
        colliders
            .get(h)
            .and_then(|co| Entity::try_from_bits(co.user_data as u64))
            .unwrap_or(Entity::PLACEHOLDER)
    };
    for event in plugin.events() {
        impacts.write(ImpactMessage {
            context: ctx,
            step,
            body: body_entity(event.body),
            collider: collider_entity(event.collider),
            ground: collider_entity(event.ground),
            body2: event.body2.map(body_entity),
            event: *event,
        });
    }
}

/// Disables the entities rapier quarantined (non-finite state), as bevy_rapier's step system
/// does; it reads the quarantine lists directly, which are private to it, so this reads the
/// messages the step wrote instead.
pub(crate) fn mirror_quarantine(
    mut commands: Commands,
    mut quarantine: MessageReader<PhysicsQuarantineEvent>,
) {
    for event in quarantine.read() {
        for entity in &event.bodies {
            commands.entity(*entity).try_insert(RigidBodyDisabled);
        }
        for entity in &event.colliders {
            commands.entity(*entity).try_insert(ColliderDisabled);
        }
        for entity in &event.soft_bodies {
            commands.entity(*entity).try_insert(SoftBodyDisabled);
        }
    }
}
