//! Which colliders are ground (and their material overrides), and which bodies the plugin
//! manages.
//!
//! Contract: the only state here is what the user registered (grounds, the all-fixed mode,
//! exclusions), the ground index built from it, and the multibody links read at each step's
//! start; marking a ground changes nothing in the collider set (the plugin's hook flags are
//! put on at each step, `hooks/flags.rs`). Every registration is validated at the call that
//! makes it ([`ConfigError`]).

use crate::model::{Material, RestitutionCurve};
use crate::plugin::bridge::convert::to_f64;
use crate::plugin::bridge::resolve::{ContactMaterial, combined_friction, material};
use crate::plugin::config::{
    ConfigError, GroundMaterial, ImpactConfig, RollingSettings, body_bounce, coefficients_in_range,
};
use crate::plugin::queries::ground_index::{GroundEntry, GroundIndex};
use crate::plugin::state::handles::{
    HandleMap, HandleSet, PairKey, sorted_entries, sorted_members,
};
use crate::rapier::prelude::{
    Collider, ColliderHandle, ColliderSet, LockedAxes, MultibodyJointSet, RigidBody,
    RigidBodyHandle, RigidBodySet,
};

/// The grounds and the managed bodies (see the module's contract).
#[derive(Default)]
pub(crate) struct Registry {
    pub grounds: HandleMap<ColliderHandle, GroundEntry>,
    /// Every fixed collider is ground ([`crate::ImpactPlugin::set_all_fixed_colliders_ground`]).
    pub all_fixed: bool,
    /// Colliders unmarked by `remove_ground`: the all-fixed mode leaves them alone until
    /// `add_ground` marks them again.
    pub unmarked: HandleSet<ColliderHandle>,
    /// Bodies left to rapier entirely.
    pub excluded: HandleSet<RigidBodyHandle>,
    /// The links of rapier's multibodies as of the step's start ([`Self::sync_links`]), left
    /// to rapier: a multibody takes its links' velocities from its own generalized
    /// velocities, so a velocity written to a link's body is dropped.
    pub multibody_links: HandleSet<RigidBodyHandle>,
    /// Balls' own rolling resistance and spinning friction
    /// ([`crate::ImpactPlugin::set_body_rolling`]).
    pub body_rolling: HandleMap<RigidBodyHandle, (f64, f64)>,
    /// Grounds' restitution curves ([`GroundMaterial::restitution_curve`]), kept out of
    /// [`GroundEntry`] so that the index's copy of the entries stays plain data.
    pub ground_curves: HandleMap<ColliderHandle, RestitutionCurve>,
    /// Bodies' own tangential restitution and restitution curve
    /// ([`crate::ImpactPlugin::set_body_tangential_restitution`],
    /// [`crate::ImpactPlugin::set_body_restitution_curve`]).
    pub body_bounce: HandleMap<RigidBodyHandle, BodyBounce>,
    /// Bodies whose impacts with each other the plugin resolves
    /// ([`crate::ImpactPlugin::add_impact_body`]).
    pub impact_bodies: HandleSet<RigidBodyHandle>,
    /// Every managed body takes part in impacts between bodies
    /// ([`crate::ImpactPlugin::set_all_dynamic_bodies_impact`]).
    pub all_impact: bool,
    /// The grounds' motions over the step and the BVH that finds those near a body.
    pub index: GroundIndex,
    /// A ground was unmarked since the grounds' hook flags were last put in place.
    pub flags_stale: bool,
}

impl Registry {
    /// The colliders [`crate::ImpactPlugin::add_ground_body`] marks: every collider of
    /// `body`, which must exist, have one, and not be dynamic.
    pub fn ground_body_colliders(
        bodies: &RigidBodySet,
        body: RigidBodyHandle,
    ) -> Result<Vec<ColliderHandle>, ConfigError> {
        let rb = bodies.get(body).ok_or(ConfigError::NotABody(body))?;
        let handles: Vec<ColliderHandle> = rb.colliders().to_vec();
        let Some(first) = handles.first() else {
            return Err(ConfigError::GroundWithoutCollider(body));
        };
        if rb.is_dynamic() {
            return Err(ConfigError::DynamicGround(*first));
        }
        Ok(handles)
    }

    /// [`crate::ImpactPlugin::set_ground_material`].
    pub fn set_ground_material(
        &mut self,
        collider: ColliderHandle,
        material: Option<GroundMaterial>,
    ) -> Result<(), ConfigError> {
        if let Some(m) = &material {
            m.validate()?;
        }
        let entry = self
            .grounds
            .get_mut(&collider)
            .ok_or(ConfigError::NotAGround(collider))?;
        entry.material = material.as_ref().map(GroundMaterial::to_model);
        entry.rolling = rolling_of_material(material.as_ref());
        entry.tangential = material.as_ref().and_then(|m| m.tangential_restitution);
        // The hooks' table holds the materials; the index is rebuilt only where the slabs
        // may change (`GroundIndex::set_entry`).
        self.index.set_entry(collider, *entry);
        self.set_ground_curve(collider, material);
        Ok(())
    }

    /// Keeps a ground's restitution curve, or forgets it.
    fn set_ground_curve(&mut self, collider: ColliderHandle, material: Option<GroundMaterial>) {
        match material.and_then(|m| m.restitution_curve) {
            Some(curve) => {
                self.ground_curves.insert(collider, curve);
            }
            None => {
                self.ground_curves.remove(&collider);
            }
        }
    }

    /// [`crate::ImpactPlugin::remove_ground`].
    pub fn remove_ground(&mut self, collider: ColliderHandle) -> bool {
        self.unmarked.insert(collider);
        self.unmark(collider)
    }

    pub fn unmark(&mut self, collider: ColliderHandle) -> bool {
        self.changed();
        self.ground_curves.remove(&collider);
        self.grounds.remove(&collider).is_some()
    }

    /// [`crate::ImpactPlugin::set_all_fixed_colliders_ground`].
    pub fn set_all_fixed_colliders_ground(&mut self, enabled: bool) {
        self.all_fixed = enabled;
        if !enabled {
            let auto: Vec<ColliderHandle> = self
                .grounds
                .iter()
                .filter(|(_, e)| e.automatic)
                .map(|(h, _)| *h)
                .collect();
            for h in auto {
                self.unmark(h);
            }
        }
    }

    /// Is this collider a ground?
    pub fn is_ground(&self, collider: ColliderHandle) -> bool {
        self.grounds.contains_key(&collider)
    }

    /// Marks one collider as ground, with its material override if any (validated by the
    /// caller): [`crate::ImpactPlugin::add_ground`].
    pub fn insert_ground(
        &mut self,
        bodies: &RigidBodySet,
        colliders: &ColliderSet,
        collider: ColliderHandle,
        material: Option<GroundMaterial>,
    ) -> Result<(), ConfigError> {
        self.changed();
        let co = colliders
            .get(collider)
            .ok_or(ConfigError::NotACollider(collider))?;
        self.unmarked.remove(&collider);
        if let Some(parent) = co.parent() {
            if bodies.get(parent).is_none_or(|rb| rb.is_dynamic()) {
                return Err(ConfigError::DynamicGround(collider));
            }
        }
        self.grounds.insert(
            collider,
            GroundEntry {
                material: material.as_ref().map(GroundMaterial::to_model),
                rolling: rolling_of_material(material.as_ref()),
                tangential: material.as_ref().and_then(|m| m.tangential_restitution),
                automatic: false,
            },
        );
        self.set_ground_curve(collider, material);
        Ok(())
    }

    /// Brings the ground index to this step (`GroundIndex::update`, else
    /// `GroundIndex::rebuild`). A removed ground collider is seen by the index's pass over the
    /// grounds, which then has to be rebuilt: the registry forgets removed colliders first,
    /// so it never loops over its grounds in a step where none changed. `lone`: the grounds
    /// the caller keeps out of slabs (besides those with a restitution curve of their own).
    pub fn refresh_index(
        &mut self,
        bodies: &RigidBodySet,
        colliders: &ColliderSet,
        (dt, gap): (f64, f64),
        lone: &dyn Fn(ColliderHandle) -> bool,
    ) {
        let curves = &self.ground_curves;
        if self.index.update(bodies, colliders, (dt, gap), &|c| {
            curves.contains_key(&c) || lone(c)
        }) {
            return;
        }
        self.grounds.retain(|h, _| colliders.get(*h).is_some());
        if !self.ground_curves.is_empty() {
            self.ground_curves
                .retain(|h, _| colliders.get(*h).is_some());
        }
        self.unmarked.retain(|h| colliders.get(*h).is_some());
        let curves = &self.ground_curves;
        self.index
            .rebuild(&self.grounds, bodies, colliders, (dt, gap), &|c| {
                curves.contains_key(&c) || lone(c)
            });
    }

    /// Marks new fixed colliders in all-fixed mode (removed ones are forgotten by
    /// [`Self::refresh_index`]).
    pub fn sync(&mut self, bodies: &RigidBodySet, colliders: &ColliderSet) {
        if self.all_fixed {
            let new: Vec<ColliderHandle> = colliders
                .iter()
                .filter(|(h, co)| {
                    // The index's table first: a hash lookup per collider per step cost as
                    // much as the rest of the plugin on a floor of 4 096 tiles.
                    let marked = self
                        .index
                        .entry(*h)
                        .map_or_else(|()| self.grounds.contains_key(h), |e| e.is_some());
                    !marked
                        && (self.unmarked.is_empty() || !self.unmarked.contains(h))
                        && co
                            .parent()
                            .is_none_or(|p| bodies.get(p).is_some_and(|rb| rb.is_fixed()))
                })
                .map(|(h, _)| h)
                .collect();
            if !new.is_empty() {
                self.changed();
            }
            for h in new {
                self.grounds.insert(
                    h,
                    GroundEntry {
                        material: None,
                        rolling: (None, None),
                        tangential: None,
                        automatic: true,
                    },
                );
            }
        }
    }

    /// A ground was marked, unmarked or given a material: the index and the hooks' ground
    /// table are stale.
    pub fn changed(&mut self) {
        self.index.invalidate();
        self.flags_stale = true;
    }

    /// The ground entry of a collider, `None` when it is not a ground.
    #[inline]
    pub fn entry(&self, c: ColliderHandle) -> Option<&GroundEntry> {
        self.index
            .entry(c)
            .unwrap_or_else(|()| self.grounds.get(&c))
    }

    /// Is the body's ground contact resolved by the plugin? Dynamic, enabled, with a
    /// positive finite mass, no locked translation, not a soft-body frame, not a multibody's
    /// link, not excluded.
    pub fn manages(&self, handle: RigidBodyHandle, rb: &RigidBody) -> bool {
        let mass = to_f64(rb.mass());
        rb.is_dynamic()
            && rb.is_enabled()
            && !rb.is_soft_frame()
            && mass > 0.0
            && mass.is_finite()
            && !rb.locked_axes().intersects(LockedAxes::TRANSLATION_LOCKED)
            && (self.excluded.is_empty() || !self.excluded.contains(&handle))
            && (self.multibody_links.is_empty() || !self.multibody_links.contains(&handle))
    }

    /// Reads the links of rapier's multibodies at the step's start (none in most worlds: an
    /// empty set's walk).
    pub fn sync_links(&mut self, multibody_joints: &MultibodyJointSet) {
        self.multibody_links.clear();
        for multibody in multibody_joints.multibodies() {
            self.multibody_links
                .extend(multibody.links().map(|link| link.rigid_body_handle()));
        }
    }

    /// Does the body take part in impacts between bodies: managed, and opted in?
    pub fn takes_pairs(&self, handle: RigidBodyHandle, rb: &RigidBody) -> bool {
        (self.all_impact || self.impact_bodies.contains(&handle)) && self.manages(handle, rb)
    }

    /// Has any body been opted in to impacts between bodies?
    pub fn any_pairs(&self) -> bool {
        self.all_impact || !self.impact_bodies.is_empty()
    }

    /// At most how many of a world's `bodies` bodies take impacts between bodies: every body
    /// where all are opted in, else those opted in one by one.
    pub fn pairs_capacity(&self, bodies: usize) -> usize {
        if self.all_impact {
            bodies
        } else {
            self.impact_bodies.len().min(bodies)
        }
    }

    /// The rolling resistance and spinning friction of a ball on a ground: each the ground's
    /// override, else the ball's, else the configuration's `default`.
    pub fn rolling_of(
        &self,
        body: RigidBodyHandle,
        ground: ColliderHandle,
        default: (f64, f64),
    ) -> (f64, f64) {
        // Most worlds give no ball its own: no lookup then.
        let own = if self.body_rolling.is_empty() {
            default
        } else {
            self.body_rolling.get(&body).copied().unwrap_or(default)
        };
        let over = self.entry(ground).map_or((None, None), |g| g.rolling);
        (over.0.unwrap_or(own.0), over.1.unwrap_or(own.1))
    }

    /// Does the ground `ground`'s own material (`add_ground_with_material`) replace the
    /// coefficients of its colliders' pairs?
    pub fn replaces_coefficients(&self, ground: ColliderHandle) -> bool {
        self.entry(ground).is_some_and(|g| g.material.is_some())
    }

    /// Is a collider of the pair `key` (body collider, ground collider) out of the plugin's
    /// coefficient ranges (`config::coefficients_in_range`), with no ground material to
    /// replace them? Such a pair is rapier's, as a filtered one is. The plan decides it with
    /// what it read of the ground once, and diagnoses it (`plan/role.rs`); this is the same
    /// rule for a pair with no role, read afresh, diagnosing nothing.
    pub fn coefficients_refused(&self, colliders: &ColliderSet, key: PairKey) -> bool {
        let out = |c| {
            colliders.get(c).is_some_and(|co| {
                !coefficients_in_range(to_f64(co.restitution()), to_f64(co.friction()))
            })
        };
        (out(key.0) || out(key.1)) && !self.replaces_coefficients(key.1)
    }

    /// The material a ground was given, rebuilt from its entry and its curve.
    pub fn ground_material(&self, collider: ColliderHandle) -> Option<GroundMaterial> {
        let entry = self.grounds.get(&collider)?;
        let m = entry.material?;
        Some(GroundMaterial {
            restitution: m.restitution,
            friction: m.friction,
            rolling_resistance: entry.rolling.0,
            spinning_friction: entry.rolling.1,
            tangential_restitution: entry.tangential,
            restitution_curve: self.ground_curves.get(&collider).cloned(),
        })
    }

    /// The friction coefficient of a body collider against a ground collider: the ground's
    /// override, else rapier's combination.
    pub fn friction_of(
        &self,
        colliders: &ColliderSet,
        body: ColliderHandle,
        ground: ColliderHandle,
    ) -> f64 {
        match (colliders.get(body), colliders.get(ground)) {
            (Some(b), Some(g)) => self.friction_between(b, g, ground),
            _ => self
                .entry(ground)
                .and_then(|g| g.material)
                .map_or(0.0, |m| m.friction),
        }
    }

    /// [`Self::friction_of`] for the body collider `body` and the ground collider `ground`
    /// (of handle `ground_handle`), both already looked up.
    pub fn friction_between(
        &self,
        body: &Collider,
        ground: &Collider,
        ground_handle: ColliderHandle,
    ) -> f64 {
        if let Some(over) = self.entry(ground_handle).and_then(|g| g.material) {
            return over.friction;
        }
        combined_friction(body, ground)
    }

    /// The material of a body collider against a ground collider: the constant coefficients
    /// (the ground's override, else rapier's combination), the tangential restitution and
    /// the restitution curve (each the ground's, else the body's, else `config`'s).
    pub fn material_of<'a>(
        &'a self,
        colliders: &ColliderSet,
        body: ColliderHandle,
        ground: ColliderHandle,
        config: &'a ImpactConfig,
    ) -> ContactMaterial<'a> {
        let entry = self.grounds.get(&ground);
        let over = entry.and_then(|g| g.material);
        let body_collider = colliders.get(body);
        let constant = match (body_collider, colliders.get(ground)) {
            (Some(b), Some(g)) => material(b, g, over),
            _ => over.unwrap_or(Material::new(0.0, 0.0)),
        };
        let own = self.bounce_of(body_collider.and_then(|co| co.parent()));
        let ground_curve = if self.ground_curves.is_empty() {
            None
        } else {
            self.ground_curves.get(&ground)
        };
        let beta = entry
            .and_then(|g| g.tangential)
            .or(own.and_then(|b| b.tangential_restitution))
            .unwrap_or(config.tangential_restitution);
        let curve = ground_curve
            .or(own.and_then(|b| b.restitution_curve.as_ref()))
            .or(config.restitution_curve.as_ref());
        ContactMaterial::new(constant.with_tangential_restitution(beta), [curve, None])
    }

    /// The material of an impact between the bodies of colliders `a` and `b`: rapier's
    /// combination of their constant coefficients; the tangential restitution and the
    /// restitution curve each the bodies' own (the mean of the two when both have one), else
    /// `config`'s.
    pub fn pair_material_of<'a>(
        &'a self,
        colliders: &ColliderSet,
        a: ColliderHandle,
        b: ColliderHandle,
        config: &'a ImpactConfig,
    ) -> ContactMaterial<'a> {
        let (ca, cb) = (&colliders[a], &colliders[b]);
        let constant = material(ca, cb, None);
        let (own_a, own_b) = (self.bounce_of(ca.parent()), self.bounce_of(cb.parent()));
        let beta_a = own_a.and_then(|o| o.tangential_restitution);
        let beta_b = own_b.and_then(|o| o.tangential_restitution);
        let beta = match (beta_a, beta_b) {
            (Some(x), Some(y)) => 0.5 * (x + y),
            (Some(x), None) | (None, Some(x)) => x,
            (None, None) => config.tangential_restitution,
        };
        let curve_a = own_a.and_then(|o| o.restitution_curve.as_ref());
        let curve_b = own_b.and_then(|o| o.restitution_curve.as_ref());
        let curves = match (curve_a, curve_b) {
            (None, None) => [config.restitution_curve.as_ref(), None],
            (Some(c), None) | (None, Some(c)) => [Some(c), None],
            (Some(x), Some(y)) => [Some(x), Some(y)],
        };
        ContactMaterial::new(constant.with_tangential_restitution(beta), curves)
    }

    /// A body's own tangential restitution and restitution curve, if it has either.
    #[inline]
    fn bounce_of(&self, body: Option<RigidBodyHandle>) -> Option<&BodyBounce> {
        if self.body_bounce.is_empty() {
            return None;
        }
        self.body_bounce.get(&body?)
    }

    /// [`crate::ImpactPlugin::set_body_tangential_restitution`].
    pub fn set_body_tangential_restitution(
        &mut self,
        body: RigidBodyHandle,
        beta0: Option<f64>,
    ) -> Result<(), ConfigError> {
        body_bounce(beta0, None)?;
        self.update_bounce(body, |b| b.tangential_restitution = beta0);
        Ok(())
    }

    /// [`crate::ImpactPlugin::set_body_restitution_curve`].
    pub fn set_body_restitution_curve(
        &mut self,
        body: RigidBodyHandle,
        curve: Option<RestitutionCurve>,
    ) -> Result<(), ConfigError> {
        body_bounce(None, curve.as_ref())?;
        self.update_bounce(body, |b| b.restitution_curve = curve);
        Ok(())
    }

    /// Changes a body's own settings, forgetting the body when it has none left.
    fn update_bounce(&mut self, body: RigidBodyHandle, change: impl FnOnce(&mut BodyBounce)) {
        let mut bounce = self.body_bounce.remove(&body).unwrap_or_default();
        change(&mut bounce);
        if bounce != BodyBounce::default() {
            self.body_bounce.insert(body, bounce);
        }
    }
}

/// A body's own tangential restitution and restitution curve, each `None` for the
/// configuration's.
#[derive(Clone, Debug, Default, PartialEq)]
#[cfg_attr(
    feature = "serde-serialize",
    derive(serde::Serialize, serde::Deserialize)
)]
pub(crate) struct BodyBounce {
    pub tangential_restitution: Option<f64>,
    pub restitution_curve: Option<RestitutionCurve>,
}

/// What the user registered ([`Registry`] less its index, which is built from it), in arena
/// order (`snapshot.rs`).
#[derive(Clone, Debug, PartialEq)]
#[cfg_attr(
    feature = "serde-serialize",
    derive(serde::Serialize, serde::Deserialize)
)]
pub(crate) struct SavedRegistry {
    grounds: Vec<(ColliderHandle, GroundEntry)>,
    all_fixed: bool,
    unmarked: Vec<ColliderHandle>,
    excluded: Vec<RigidBodyHandle>,
    body_rolling: Vec<(RigidBodyHandle, (f64, f64))>,
    ground_curves: Vec<(ColliderHandle, RestitutionCurve)>,
    body_bounce: Vec<(RigidBodyHandle, BodyBounce)>,
    impact_bodies: Vec<RigidBodyHandle>,
    all_impact: bool,
    flags_stale: bool,
}

#[cfg(test)]
impl SavedRegistry {
    /// With collider `c` also a ground, with the first ground's entry (a hand-edited
    /// snapshot's).
    pub fn with_ground_like_first(mut self, c: ColliderHandle) -> Self {
        let entry = self.grounds[0].1;
        self.grounds.push((c, entry));
        self
    }

    /// With body `b`'s own rolling coefficients `(rr, sp)` (a hand-edited snapshot's).
    pub fn with_body_rolling(mut self, b: RigidBodyHandle, rr: f64, sp: f64) -> Self {
        self.body_rolling.push((b, (rr, sp)));
        self
    }
}

impl Registry {
    /// The registrations.
    pub fn save(&self) -> SavedRegistry {
        SavedRegistry {
            grounds: sorted_entries(&self.grounds),
            all_fixed: self.all_fixed,
            unmarked: sorted_members(&self.unmarked),
            excluded: sorted_members(&self.excluded),
            body_rolling: sorted_entries(&self.body_rolling),
            ground_curves: sorted_entries(&self.ground_curves),
            body_bounce: sorted_entries(&self.body_bounce),
            impact_bodies: sorted_members(&self.impact_bodies),
            all_impact: self.all_impact,
            flags_stale: self.flags_stale,
        }
    }

    /// The registry `saved` was taken from, its index to be built at the next step; every
    /// coefficient checked as its setter checks it.
    pub fn from_saved(saved: &SavedRegistry) -> Result<Self, ConfigError> {
        for (_, entry) in &saved.grounds {
            let m = entry.material.unwrap_or(Material::new(0.0, 0.0));
            let material = GroundMaterial {
                restitution: m.restitution,
                friction: m.friction,
                rolling_resistance: entry.rolling.0,
                spinning_friction: entry.rolling.1,
                tangential_restitution: entry.tangential,
                restitution_curve: None,
            };
            material.validate()?;
        }
        for (_, curve) in &saved.ground_curves {
            GroundMaterial::new(0.0, 0.0)
                .with_restitution_curve(curve.clone())
                .validate()?;
        }
        for (_, (rr, sp)) in &saved.body_rolling {
            RollingSettings::new(*rr, *sp).validate()?;
        }
        for (_, own) in &saved.body_bounce {
            body_bounce(own.tangential_restitution, own.restitution_curve.as_ref())?;
        }
        let mut registry = Self {
            grounds: saved.grounds.iter().copied().collect(),
            all_fixed: saved.all_fixed,
            unmarked: saved.unmarked.iter().copied().collect(),
            excluded: saved.excluded.iter().copied().collect(),
            // Read again at the next step's start, as every step does.
            multibody_links: HandleSet::default(),
            body_rolling: saved.body_rolling.iter().copied().collect(),
            ground_curves: saved.ground_curves.iter().cloned().collect(),
            body_bounce: saved.body_bounce.iter().cloned().collect(),
            impact_bodies: saved.impact_bodies.iter().copied().collect(),
            all_impact: saved.all_impact,
            index: GroundIndex::default(),
            flags_stale: saved.flags_stale,
        };
        registry.index.invalidate();
        Ok(registry)
    }
}

/// A ground material's rolling overrides.
fn rolling_of_material(material: Option<&GroundMaterial>) -> (Option<f64>, Option<f64>) {
    material.map_or((None, None), |m| {
        (m.rolling_resistance, m.spinning_friction)
    })
}
