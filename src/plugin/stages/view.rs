//! What the stages after rapier's step see: the step's data with rapier's sets after its
//! step ([`EndOfStep`]), and the plugin as they read it, with the one writer
//! ([`AfterStep`]).

use crate::motion::State;
use crate::plugin::bridge::resolve::ContactMaterial;
use crate::plugin::config::{ImpactConfig, TimingMode};
use crate::plugin::events::Reports;
use crate::plugin::hooks::flags::HookFlags;
use crate::plugin::policy::Role;
use crate::plugin::queries::filter;
use crate::plugin::queries::geometry::{BodyGeom, BodyPart, GroundGeom, Hit, body_landing_point};
use crate::plugin::queries::observe::Sets;
use crate::plugin::stages::commit::Commit;
use crate::plugin::state::handles::{HandleMap, HandleSet, PairKey};
use crate::plugin::state::memory::Memory;
use crate::plugin::state::registry::Registry;
use crate::plugin::state::step::StepData;
use crate::plugin::state::writes::Writes;
use crate::rapier::prelude::{ColliderSet, PhysicsHooks, RigidBodyHandle, RigidBodySet};
use nalgebra::Vector3;

/// The step's data in `after_step`, with rapier's sets after its step.
pub(crate) struct EndOfStep<'a> {
    pub data: StepData,
    pub sets: Sets<'a>,
    /// The bodies the pair clusters moved together (`pair_reconstruct::move_clusters`): the
    /// later stages leave them alone.
    pub moved_together: HandleSet<RigidBodyHandle>,
}

impl std::ops::Deref for EndOfStep<'_> {
    type Target = StepData;
    fn deref(&self) -> &StepData {
        &self.data
    }
}

impl std::ops::DerefMut for EndOfStep<'_> {
    fn deref_mut(&mut self) -> &mut StepData {
        &mut self.data
    }
}

/// What the stages after rapier's step read of the plugin (the configuration, the registry,
/// the hook flags, the user's hooks, this step's roles of the pairs with grounds) and the one
/// writer they write through.
pub(crate) struct AfterStep<'a> {
    pub config: &'a ImpactConfig,
    pub registry: &'a Registry,
    pub flags: &'a HookFlags,
    /// The user's hooks: their filter decides the pairs with grounds that have no role
    /// ([`AfterStep::refuses`]).
    pub user_hooks: &'a dyn PhysicsHooks,
    pub roles: &'a HandleMap<PairKey, Role>,
    pub commit: Commit<'a>,
    /// The pairs of rolling balls released at the step's end (`EventKind::Released`): their
    /// role becomes `Resting`, so that the next step's plan, finding them within reach, does
    /// not release them again.
    pub released: Vec<PairKey>,
}

impl<'a> AfterStep<'a> {
    /// The view of a plugin's parts; `exact`: `TimingMode::Exact` (see `Commit`).
    pub fn new(
        (config, registry, flags): (&'a ImpactConfig, &'a Registry, &'a HookFlags),
        user_hooks: &'a dyn PhysicsHooks,
        memory: &'a mut Memory,
        (writes, reports): (&'a mut Writes, &'a mut Reports),
    ) -> Self {
        let exact = config.timing == TimingMode::Exact;
        Self {
            config,
            registry,
            flags,
            user_hooks,
            roles: &memory.roles,
            commit: Commit::new(writes, reports, &mut memory.shadows, exact),
            released: Vec::new(),
        }
    }

    /// Is the pair `key` (a collider of the body `body`, a ground's collider), which has no
    /// role this step, rapier's whatever happens: rapier, a joint or the user's filter refuse
    /// it (`filter::ground_pair_refused`), or its coefficients are out of the plugin's ranges
    /// (`Registry::coefficients_refused`)?
    pub fn refuses(
        &self,
        (bodies, colliders, sets): (&RigidBodySet, &ColliderSet, &Sets),
        body: RigidBodyHandle,
        key: PairKey,
    ) -> bool {
        let hooks = (self.user_hooks, self.flags);
        filter::ground_pair_refused(hooks, (bodies, colliders, sets), body, key)
            || self.registry.coefficients_refused(colliders, key)
    }

    /// The material of the contact `hit` of the body (`geom`, at `s`, time `t`) with the ground
    /// `gg`, and its landing: the point and the count of contact points of the one impact
    /// (`geometry::body_landing_point`: the hit part's vertices, and the body's other parts
    /// of that material landing with it).
    pub fn landing(
        &self,
        colliders: &ColliderSet,
        (geom, gg): (&BodyGeom, &GroundGeom),
        (s, t): (&State, f64),
        hit: &Hit,
    ) -> (ContactMaterial<'a>, Vector3<f64>, usize) {
        let (registry, config) = (self.registry, self.config);
        let material_of =
            |part: &BodyPart| registry.material_of(colliders, part.handle, gg.handle, config);
        let material = material_of(&geom.parts[hit.part]);
        let same_material = |_, other: &BodyPart| material_of(other) == material;
        let flat = config.flat_tolerance;
        let (point, points) = body_landing_point(geom, gg, (s, t), hit, flat, same_material);
        (material, point, points)
    }
}
