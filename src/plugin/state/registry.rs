//! Which colliders are ground (and their material overrides), and which bodies the plugin
//! manages.
//!
//! Contract: the only state here is what the user registered (grounds, the all-fixed mode,
//! exclusions) and the ground index built from it; marking a ground changes nothing in the
//! collider set (the plugin's hook flags are put on at each step, `hooks/flags.rs`). Every
//! registration is validated at the call that makes it ([`ConfigError`]).

use crate::model::Material;
use crate::plugin::bridge::convert::to_f64;
use crate::plugin::bridge::resolve::material;
use crate::plugin::config::{ConfigError, GroundMaterial, rolling_coefficient};
use crate::plugin::queries::ground_index::{GroundEntry, GroundIndex};
use crate::plugin::state::handles::{HandleMap, HandleSet, sorted_entries, sorted_members};
use crate::rapier::prelude::{
    ColliderHandle, ColliderSet, LockedAxes, RigidBody, RigidBodyHandle, RigidBodySet,
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
    /// Balls' own rolling resistance and spinning friction
    /// ([`crate::ImpactPlugin::set_body_rolling`]).
    pub body_rolling: HandleMap<RigidBodyHandle, (f64, f64)>,
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
        entry.material = material.map(GroundMaterial::to_model);
        entry.rolling = rolling_of_material(material.as_ref());
        // Only the hooks' table holds materials: no rebuild of the index.
        self.index.set_entry(collider, *entry);
        Ok(())
    }

    /// [`crate::ImpactPlugin::remove_ground`].
    pub fn remove_ground(&mut self, collider: ColliderHandle) -> bool {
        self.unmarked.insert(collider);
        self.unmark(collider)
    }

    pub fn unmark(&mut self, collider: ColliderHandle) -> bool {
        self.changed();
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
                material: material.map(GroundMaterial::to_model),
                rolling: rolling_of_material(material.as_ref()),
                automatic: false,
            },
        );
        Ok(())
    }

    /// Keeps the registry in step with the sets: forgets removed colliders, marks new fixed
    /// colliders in all-fixed mode.
    pub fn sync(&mut self, bodies: &RigidBodySet, colliders: &ColliderSet) {
        self.grounds.retain(|h, _| colliders.get(*h).is_some());
        self.unmarked.retain(|h| colliders.get(*h).is_some());
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
    /// positive finite mass, no locked translation, not a soft-body frame, not excluded.
    pub fn manages(&self, handle: RigidBodyHandle, rb: &RigidBody) -> bool {
        let mass = to_f64(rb.mass());
        rb.is_dynamic()
            && rb.is_enabled()
            && !rb.is_soft_frame()
            && mass > 0.0
            && mass.is_finite()
            && !rb.locked_axes().intersects(LockedAxes::TRANSLATION_LOCKED)
            && (self.excluded.is_empty() || !self.excluded.contains(&handle))
    }

    /// Does the body take part in impacts between bodies: managed, and opted in?
    pub fn takes_pairs(&self, handle: RigidBodyHandle, rb: &RigidBody) -> bool {
        (self.all_impact || self.impact_bodies.contains(&handle)) && self.manages(handle, rb)
    }

    /// Has any body been opted in to impacts between bodies?
    pub fn any_pairs(&self) -> bool {
        self.all_impact || !self.impact_bodies.is_empty()
    }

    /// The rolling resistance and spinning friction of a ball on a ground: each the ground's
    /// override, else the ball's, else the configuration's `default`.
    pub fn rolling_of(
        &self,
        body: RigidBodyHandle,
        ground: ColliderHandle,
        default: (f64, f64),
    ) -> (f64, f64) {
        let own = self.body_rolling.get(&body).copied().unwrap_or(default);
        let over = self
            .grounds
            .get(&ground)
            .map_or((None, None), |g| g.rolling);
        (over.0.unwrap_or(own.0), over.1.unwrap_or(own.1))
    }

    /// The material of a body collider against a ground collider.
    pub fn material_of(
        &self,
        colliders: &ColliderSet,
        body: ColliderHandle,
        ground: ColliderHandle,
    ) -> Material {
        let over = self.grounds.get(&ground).and_then(|g| g.material);
        match (colliders.get(body), colliders.get(ground)) {
            (Some(b), Some(g)) => material(b, g, over),
            _ => over.unwrap_or(Material::new(0.0, 0.0)),
        }
    }
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
    impact_bodies: Vec<RigidBodyHandle>,
    all_impact: bool,
    flags_stale: bool,
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
            };
            material.validate()?;
        }
        for (_, (rr, sp)) in &saved.body_rolling {
            rolling_coefficient("rolling_resistance", *rr)?;
            rolling_coefficient("spinning_friction", *sp)?;
        }
        let mut registry = Self {
            grounds: saved.grounds.iter().copied().collect(),
            all_fixed: saved.all_fixed,
            unmarked: saved.unmarked.iter().copied().collect(),
            excluded: saved.excluded.iter().copied().collect(),
            body_rolling: saved.body_rolling.iter().copied().collect(),
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
