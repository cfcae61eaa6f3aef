//! Ground registration: which colliders are ground, their optional material, and the hook
//! flags the plugin adds to them (remembering the user's own).

use super::config::{ConfigError, GroundMaterial};
use super::impact_plugin::{GroundEntry, ImpactPlugin, PLUGIN_HOOKS};
use crate::rapier::prelude::{ColliderHandle, ColliderSet, RigidBodyHandle, RigidBodySet};

impl<H> ImpactPlugin<H> {
    /// Marks one collider as ground, with the materials rapier combines from the colliders.
    ///
    /// The collider must exist and be parentless, or attached to a fixed or kinematic body.
    /// Its hook flags gain `FILTER_CONTACT_PAIRS | MODIFY_SOLVER_CONTACTS`; the flags it had
    /// are kept for the user's hook.
    pub fn add_ground(
        &mut self,
        bodies: &RigidBodySet,
        colliders: &mut ColliderSet,
        collider: ColliderHandle,
    ) -> Result<(), ConfigError> {
        self.insert_ground(bodies, colliders, collider, None)
    }

    /// Marks one collider as ground with its own material, which replaces the coefficients
    /// rapier would combine (validated here).
    pub fn add_ground_with_material(
        &mut self,
        bodies: &RigidBodySet,
        colliders: &mut ColliderSet,
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
        colliders: &mut ColliderSet,
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

    /// Makes a ground an ordinary collider again (its hook flags back to the user's).
    /// Returns whether it was a ground. The all-fixed mode
    /// ([`Self::set_all_fixed_colliders_ground`]) does not mark it again; [`Self::add_ground`]
    /// does.
    pub fn remove_ground(&mut self, colliders: &mut ColliderSet, collider: ColliderHandle) -> bool {
        self.unmarked.insert(collider);
        self.unmark(colliders, collider)
    }

    /// Unmarks a ground, its hook flags back to the user's.
    fn unmark(&mut self, colliders: &mut ColliderSet, collider: ColliderHandle) -> bool {
        self.grounds_changed();
        match self.grounds.remove(&collider) {
            Some(entry) => {
                if let Some(co) = colliders.get_mut(collider) {
                    co.set_active_hooks(entry.user_hooks);
                }
                true
            }
            None => false,
        }
    }

    /// Every fixed collider (parentless, or on a fixed body) is ground, including those
    /// added later; checked at each [`Self::before_step`]. Turning it off unmarks the
    /// colliders it marked.
    pub fn set_all_fixed_colliders_ground(&mut self, colliders: &mut ColliderSet, enabled: bool) {
        self.all_fixed = enabled;
        if !enabled {
            let auto: Vec<ColliderHandle> = self
                .grounds
                .iter()
                .filter(|(_, e)| e.automatic)
                .map(|(h, _)| *h)
                .collect();
            for h in auto {
                self.unmark(colliders, h);
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
        colliders: &mut ColliderSet,
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
        let user_hooks = match self.grounds.get(&collider) {
            Some(entry) => entry.user_hooks,
            None => co.active_hooks(),
        };
        self.grounds.insert(
            collider,
            GroundEntry {
                material: material.map(GroundMaterial::to_model),
                user_hooks,
                automatic: false,
            },
        );
        if let Some(co) = colliders.get_mut(collider) {
            co.set_active_hooks(user_hooks | PLUGIN_HOOKS);
        }
        Ok(())
    }

    /// Keeps the registry in step with the sets: forgets removed colliders, marks new fixed
    /// colliders in all-fixed mode, restores the plugin's hook flags if they were overwritten.
    pub(crate) fn sync_grounds(&mut self, bodies: &RigidBodySet, colliders: &mut ColliderSet) {
        self.grounds.retain(|h, _| colliders.get(*h).is_some());
        self.unmarked.retain(|h| colliders.get(*h).is_some());
        if self.all_fixed {
            let new: Vec<ColliderHandle> = colliders
                .iter()
                .filter(|(h, co)| {
                    !self.grounds.contains_key(h)
                        && !self.unmarked.contains(h)
                        && co
                            .parent()
                            .is_none_or(|p| bodies.get(p).is_some_and(|rb| rb.is_fixed()))
                })
                .map(|(h, _)| h)
                .collect();
            for h in new {
                let user_hooks = colliders[h].active_hooks();
                self.grounds.insert(
                    h,
                    GroundEntry {
                        material: None,
                        user_hooks,
                        automatic: true,
                    },
                );
            }
        }
        for (h, entry) in self.grounds.iter_mut() {
            let flags = colliders[*h].active_hooks();
            if !flags.contains(PLUGIN_HOOKS) {
                entry.user_hooks = flags;
                if let Some(co) = colliders.get_mut(*h) {
                    co.set_active_hooks(flags | PLUGIN_HOOKS);
                }
            }
        }
    }
}
