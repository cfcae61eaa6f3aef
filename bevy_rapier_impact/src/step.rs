//! The step system: bevy_rapier's `PhysicsSet::StepSimulation`, with the core plugin around
//! every rapier step.
//!
//! Contract, per frame and per rapier context, in `PhysicsSet::StepSimulation` (after
//! bevy_rapier's `SyncBackend` has created and updated the rapier objects, before its
//! `Writeback` copies them to the components):
//! 1. apply [`ImpactSettings`] if they changed; mark the colliders with [`Ground`] that are
//!    not grounds yet, unmark those whose marker or entity is gone;
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
    BodyBounce, Ground, ImpactSettings, ImpactSimulation, RestitutionBySpeed, TangentialRestitution,
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
use bevy_rapier3d::rapier::prelude::{ColliderSet, PhysicsHooks, RigidBodySet};
use rapier_impact::{ImpactConfig, ImpactPlugin};

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

/// The collider entities marked [`Ground`] that bevy_rapier has created, with their context.
type Grounds<'w, 's> = Query<
    'w,
    's,
    (
        Entity,
        &'static RapierColliderHandle,
        &'static RapierContextEntityLink,
    ),
    With<Ground>,
>;

/// The rigid body entities with their own tangential restitution or restitution curve that
/// bevy_rapier has created, with their context.
type Bounces<'w, 's> = Query<
    'w,
    's,
    (
        Entity,
        &'static RapierRigidBodyHandle,
        &'static RapierContextEntityLink,
        Option<&'static TangentialRestitution>,
        Option<&'static RestitutionBySpeed>,
    ),
    Or<(With<TangentialRestitution>, With<RestitutionBySpeed>)>,
>;

/// Advances every rapier context by one frame, the core plugin around each rapier step (see
/// the module's contract). Replaces bevy_rapier's `step_simulation::<H>`.
pub(crate) fn step_with_impacts<H>(
    mut contexts: Contexts,
    grounds: Grounds,
    bounces: Bounces,
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
                impact.bounces.clear();
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
        sync_bounces(ctx, &bounces, impact, &mut plugin, &mut writers.errors);
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
                    hooked.before_step(
                        config.gravity,
                        &params,
                        &mut bodies.bodies,
                        &mut colliders.colliders,
                        &sim.narrow_phase,
                        &joints.impulse_joints,
                        &joints.multibody_joints,
                    );
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
                    hooked.after_step(
                        &mut bodies.bodies,
                        &mut colliders.colliders,
                        &sim.narrow_phase,
                        &joints.impulse_joints,
                        &joints.multibody_joints,
                    );
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

/// Marks the context's new [`Ground`] colliders and unmarks the ones whose marker, entity or
/// rapier collider is gone.
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
    for (entity, handle, link) in grounds.iter() {
        if link.0 != ctx {
            continue;
        }
        impact.seen.insert(entity);
        let known = impact.grounds.get(&entity).copied();
        if known.is_some_and(|(h, _)| h == handle.0) {
            continue;
        }
        // New, or bevy_rapier made it a new rapier collider: the old one is no ground.
        if let Some((old, true)) = known {
            plugin.remove_ground(old);
        }
        let taken = plugin.add_ground(bodies, colliders, handle.0);
        if let Err(error) = &taken {
            errors.write(ImpactErrorMessage {
                context: ctx,
                entity: Some(entity),
                error: error.clone(),
            });
        }
        impact.grounds.insert(entity, (handle.0, taken.is_ok()));
    }
    let seen = &impact.seen;
    impact.grounds.retain(|entity, (handle, taken)| {
        let keep = seen.contains(entity);
        if !keep && *taken {
            plugin.remove_ground(*handle);
        }
        keep
    });
}

/// Gives the core plugin the context's bodies' own tangential restitution and restitution
/// curve where they changed, and takes them back from the bodies whose components, entity or
/// rapier body are gone.
fn sync_bounces(
    ctx: Entity,
    bounces: &Bounces,
    impact: &mut ImpactSimulation,
    plugin: &mut ImpactPlugin,
    errors: &mut MessageWriter<ImpactErrorMessage>,
) {
    impact.seen.clear();
    for (entity, handle, link, beta, curve) in bounces.iter() {
        if link.0 != ctx {
            continue;
        }
        impact.seen.insert(entity);
        let wanted = BodyBounce {
            tangential_restitution: beta.map(|b| b.0),
            restitution_curve: curve.map(|c| c.0.clone()),
        };
        let known = impact.bounces.get(&entity);
        if known.is_some_and(|(h, applied)| *h == handle.0 && *applied == wanted) {
            continue;
        }
        if let Some((old, _)) = known.filter(|(h, _)| *h != handle.0) {
            forget_bounce(plugin, *old);
        }
        let set = plugin
            .set_body_tangential_restitution(handle.0, wanted.tangential_restitution)
            .and_then(|()| {
                plugin.set_body_restitution_curve(handle.0, wanted.restitution_curve.clone())
            });
        if let Err(error) = set {
            errors.write(ImpactErrorMessage {
                context: ctx,
                entity: Some(entity),
                error,
            });
        }
        impact.bounces.insert(entity, (handle.0, wanted));
    }
    let seen = &impact.seen;
    impact.bounces.retain(|entity, (handle, _)| {
        let keep = seen.contains(entity);
        if !keep {
            forget_bounce(plugin, *handle);
        }
        keep
    });
}

/// Takes a body's own tangential restitution and restitution curve back (never refused).
fn forget_bounce(plugin: &mut ImpactPlugin, body: bevy_rapier3d::rapier::prelude::RigidBodyHandle) {
    let _ = plugin.set_body_tangential_restitution(body, None);
    let _ = plugin.set_body_restitution_curve(body, None);
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
