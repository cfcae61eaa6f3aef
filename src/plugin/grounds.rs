//! Ground registration: which colliders are ground, and their optional material.
//!
//! Marking a ground changes nothing in the collider set: the plugin's hook flags are put on
//! at each step (see `hook_flags.rs`).

use super::config::{ConfigError, GroundMaterial};
use super::ground_index::GroundEntry;
use super::impact_plugin::ImpactPlugin;
use crate::rapier::prelude::{ColliderHandle, ColliderSet, RigidBodyHandle, RigidBodySet};

impl<H> ImpactPlugin<H> {
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
        self.insert_ground(bodies, colliders, collider, None)
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
        self.insert_ground(bodies, colliders, collider, Some(material))
    }

    /// Marks every collider of a fixed or kinematic body as ground.
    pub fn add_ground_body(
        &mut self,
        bodies: &RigidBodySet,
        colliders: &ColliderSet,
        body: RigidBodyHandle,
    ) -> Result<(), ConfigError> {
        let rb = bodies.get(body).ok_or(ConfigError::NotABody(body))?;
        let handles: Vec<ColliderHandle> = rb.colliders().to_vec();
        let Some(first) = handles.first() else {
            return Err(ConfigError::GroundWithoutCollider(body));
        };
        if rb.is_dynamic() {
            return Err(ConfigError::DynamicGround(*first));
        }
        for h in handles {
            self.insert_ground(bodies, colliders, h, None)?;
        }
        Ok(())
    }

    /// Sets or clears (`None`) the material override of a ground.
    pub fn set_ground_material(
        &mut self,
        collider: ColliderHandle,
        material: Option<GroundMaterial>,
    ) -> Result<(), ConfigError> {
        if let Some(m) = &material {
            m.validate()?;
        }
        self.grounds_changed();
        let entry = self
            .grounds
            .get_mut(&collider)
            .ok_or(ConfigError::NotAGround(collider))?;
        entry.material = material.map(GroundMaterial::to_model);
        Ok(())
    }

    /// Makes a ground an ordinary collider again. Returns whether it was a ground. The all-fixed mode
    /// ([`Self::set_all_fixed_colliders_ground`]) does not mark it again; [`Self::add_ground`]
    /// does.
    pub fn remove_ground(&mut self, collider: ColliderHandle) -> bool {
        self.unmarked.insert(collider);
        self.unmark(collider)
    }

    fn unmark(&mut self, collider: ColliderHandle) -> bool {
        self.grounds_changed();
        self.grounds.remove(&collider).is_some()
    }

    /// Every fixed collider (parentless, or on a fixed body) is ground, including those
    /// added later; checked at each [`Self::before_step`]. Turning it off unmarks the
    /// colliders it marked.
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

    fn insert_ground(
        &mut self,
        bodies: &RigidBodySet,
        colliders: &ColliderSet,
        collider: ColliderHandle,
        material: Option<GroundMaterial>,
    ) -> Result<(), ConfigError> {
        self.grounds_changed();
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
                automatic: false,
            },
        );
        Ok(())
    }

    /// Keeps the registry in step with the sets: forgets removed colliders, marks new fixed
    /// colliders in all-fixed mode.
    pub(crate) fn sync_grounds(&mut self, bodies: &RigidBodySet, colliders: &ColliderSet) {
        self.grounds.retain(|h, _| colliders.get(*h).is_some());
        self.unmarked.retain(|h| colliders.get(*h).is_some());
        if self.all_fixed {
            let new: Vec<ColliderHandle> = colliders
                .iter()
                .filter(|(h, co)| {
                    // The index's table first: a hash lookup per collider per step cost as
                    // much as the rest of the plugin on a floor of 4 096 tiles.
                    let marked = self
                        .ground_index
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
                self.grounds_changed();
            }
            for h in new {
                self.grounds.insert(
                    h,
                    GroundEntry {
                        material: None,
                        automatic: true,
                    },
                );
            }
        }
    }
}
