//! The user's `BevyPhysicsHooks` as a rapier `PhysicsHooks`, for the core plugin to wrap.
//!
//! Contract: [`UserHooks`] forwards each of rapier's three hook calls to the Bevy hooks it
//! borrows, through the same views (`PairFilterContextView`, `ContactModificationContextView`)
//! bevy_rapier gives them, so a one-way platform or a contact filter written for bevy_rapier
//! runs unchanged. The core plugin decides which pairs reach it: every pair that is not a
//! ground contact it manages, exactly when the colliders' own `ActiveHooks` ask for it (see
//! `rapier_impact::ImpactPlugin::with_hooks`).

use bevy_rapier3d::pipeline::{
    BevyPhysicsHooks, ContactModificationContextView, PairFilterContextView,
};
use bevy_rapier3d::rapier::pipeline::{ContactModificationContext, PairFilterContext};
use bevy_rapier3d::rapier::prelude::{PhysicsHooks, SolverFlags};

/// The user's Bevy hooks, borrowed for one system run, as rapier's `PhysicsHooks`.
///
/// bevy_rapier's own adapter is private to it; this one does the same. The plugin builds one
/// per frame from the hooks `SystemParam` given to [`crate::RapierImpactPlugin`].
pub struct UserHooks<'a, T>(pub &'a T);

impl<T: BevyPhysicsHooks> PhysicsHooks for UserHooks<'_, T> {
    fn filter_contact_pair(&self, context: &PairFilterContext) -> Option<SolverFlags> {
        self.0
            .filter_contact_pair(PairFilterContextView { raw: context })
    }

    fn filter_intersection_pair(&self, context: &PairFilterContext) -> bool {
        self.0
            .filter_intersection_pair(PairFilterContextView { raw: context })
    }

    fn modify_solver_contacts(&self, context: &mut ContactModificationContext) {
        self.0
            .modify_solver_contacts(ContactModificationContextView { raw: context })
    }
}
