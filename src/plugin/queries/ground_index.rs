//! The grounds as a step sees them, and which of them a body may meet.
//!
//! Contract:
//! - reads the registry (which colliders are ground) and rapier's bodies and colliders;
//!   writes nothing of rapier's;
//! - [`GroundIndex::update`] (else [`GroundIndex::rebuild`]; `Registry::refresh_index` calls
//!   them), once per step before anything asks: every ground's pose over the step
//!   ([`GroundMotion`]: start pose, velocities, swept AABB; a still half-space's unit normal,
//!   which every contact query on it would compute the same). A still ground (parentless or on
//!   a fixed body) is computed once and kept until its collider's pose, shape, flags,
//!   coefficients or filtering change (one comparison per ground and step; a fixed body the
//!   user moved since the last step has its colliders moved before this pass,
//!   `ImpactPlugin::before_step`); a ground on a kinematic body is computed afresh each step,
//!   and a change of the step's length recomputes only those;
//! - [`GroundIndex::near`]: the grounds whose swept AABB meets a cube, from a BVH over the
//!   still bounded grounds (parry's) and a short list of the others (half-spaces, whose AABB
//!   is the whole number range, and moving grounds). Its cost grows with the grounds near the
//!   cube and the log of their number, never with the number of grounds;
//!   [`GroundIndex::near_ball`]: the same, less the grounds in the cube's corners that the
//!   ball inside it misses (the plan's grounds near a body);
//! - flush coplanar tiles are one ground (`slabs.rs`): at a rebuild, the still cuboid grounds
//!   that form one box with the same material and filtering become a *slab*, a motion of its
//!   own after the grounds' (its shape the box, [`GroundMotion::slab`]; its handle its first
//!   tile's, which stands for every tile of it in the plugin's tables:
//!   [`GroundIndex::stand_in`]). The BVH holds the slab, not its tiles, so a body over a tiled
//!   floor meets one ground; [`GroundIndex::near_ball_tiles`] answers with the tiles instead,
//!   for a body whose pairs the user's filter decides one by one, and
//!   [`GroundIndex::tile_at`] names the tile under an event's point. The slabs never depend
//!   on the grounds' history: a change that splits one rebuilds the index, and so does a
//!   change of a cuboid in the BVH that meets another cuboid or a slab (which may let it
//!   join one again);
//! - the motions are in a deterministic order (by collider handle, then the slabs by their
//!   first tile), and an index into [`GroundIndex::motions`] names a ground for the whole
//!   step.

use crate::model::Material;
use crate::plugin::bridge::convert::{
    pose_from_na, pose_to_na, to_f64, to_real, vec_from_na, vec_to_na,
};
use crate::plugin::queries::slabs::{Slab, Tile, find_slabs};
use crate::plugin::state::small_list::SmallList;
use crate::rapier::data::HasModifiedFlag;
use crate::rapier::math::{Pose, Real, Vector};
use crate::rapier::parry::bounding_volume::{Aabb, BoundingVolume};
use crate::rapier::parry::partitioning::{Bvh, BvhBuildStrategy};
use crate::rapier::parry::shape::Cuboid;
use crate::rapier::prelude::{
    ActiveCollisionTypes, ActiveHooks, CoefficientCombineRule, Collider, ColliderHandle,
    ColliderSet, InteractionGroups, RigidBodyHandle, RigidBodySet, RigidBodyType,
};
use nalgebra::{Isometry3, Point3, Translation3, UnitQuaternion, Vector3};
use std::collections::HashMap;
use std::hash::BuildHasherDefault;

use crate::plugin::state::handles::{HandleHasher, slot_of};

/// A registered ground collider.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(
    feature = "serde-serialize",
    derive(serde::Serialize, serde::Deserialize)
)]
pub(crate) struct GroundEntry {
    /// Material override.
    pub material: Option<Material>,
    /// Rolling resistance and spinning friction overrides (`GroundMaterial`).
    pub rolling: (Option<f64>, Option<f64>),
    /// Tangential restitution override (`GroundMaterial`); the ground's restitution curve,
    /// if any, is the registry's (`Registry::ground_curves`).
    pub tangential: Option<f64>,
    /// Marked by the all-fixed-colliders mode rather than by the user.
    pub automatic: bool,
}

/// A ground's motion over the step: start pose of its centre-of-mass frame, velocities.
#[derive(Clone, Copy, Debug)]
pub(crate) struct GroundMotion {
    pub handle: ColliderHandle,
    /// The kinematic body it rides, if it moves.
    pub body: Option<RigidBodyHandle>,
    pub com0: Vector3<f64>,
    pub rot0: UnitQuaternion<f64>,
    pub local: Isometry3<f64>,
    /// The collider's world pose at the step's start (`com0`, `rot0` and `local` composed):
    /// every query of a still ground asks for it, so it is composed once per motion.
    pub pose0: Isometry3<f64>,
    pub v: Vector3<f64>,
    pub w: Vector3<f64>,
    /// World AABB of the collider's poses over the step (for a turning ground, its start's
    /// box loosened by the farthest any of its points travels), loosened by the resting gap
    /// and the collider's contact skin.
    pub aabb: Aabb,
    /// A half-space ground that does not turn in the step: its world outward normal `n` and
    /// the offset `d` with `n·x <= d` for every point of it over the step. (parry gives a
    /// half-space an AABB as large as the number range, which every body meets.)
    pub plane: Option<(Vector, Real)>,
    /// A slab of tiles: the box they form (its pose `pose0`), the shape every query asks for
    /// in place of the collider's (`handle` is its first tile).
    pub slab: Option<Cuboid>,
    /// A still half-space: the shape's normal and its world unit normal in `f64` (`pose0`'s
    /// rotation of it, divided by its norm, where that is positive), as every contact query
    /// of a body on it would compute it (`GroundMotion::still_unit_normal`).
    pub unit_normal: Option<(Vector, Vector3<f64>)>,
}

impl GroundMotion {
    /// Does the ground miss the axis-aligned cube `centre ± half` over the whole step? Inlined:
    /// the ground index asks it of every listed ground for every body it is asked about.
    #[inline]
    pub fn misses_cube(&self, centre: Vector, half: Real) -> bool {
        let (lo, hi) = (centre - Vector::splat(half), centre + Vector::splat(half));
        if hi.cmplt(self.aabb.mins).any() || lo.cmpgt(self.aabb.maxs).any() {
            return true;
        }
        // The cube's lowest point along n is `n·centre - half |n|_1`.
        self.plane
            .is_some_and(|(n, d)| n.dot(centre) - half * n.abs().element_sum() > d)
    }

    /// Does the ground miss the ball `centre ± radius` over the whole step (its swept box,
    /// and its plane, beyond the ball)? A ground that misses the cube of the same half-width
    /// misses the ball.
    #[inline]
    pub fn misses_ball(&self, centre: Vector, radius: Real) -> bool {
        let nearest = centre.clamp(self.aabb.mins, self.aabb.maxs);
        if (nearest - centre).length_squared() > radius * radius {
            return true;
        }
        self.plane
            .is_some_and(|(n, d)| n.dot(centre) - radius * n.length() > d)
    }

    /// Is the ground still over the step (parentless or on a fixed body)?
    pub fn is_still(&self) -> bool {
        self.body.is_none()
    }

    /// The world unit normal of a still half-space whose shape's normal is `normal`, as
    /// computed once with its motion (`None`: not a still half-space, its normal has changed
    /// in place since, or it has no direction). A still ground's pose at any time of the
    /// step is `pose0`. The normals are compared bit for bit: `-0.0 == 0.0`, but a rotation
    /// can carry the sign of a zero into the computed normal.
    #[inline]
    pub fn still_unit_normal(&self, normal: Vector) -> Option<Vector3<f64>> {
        let bits = |v: Vector| v.to_array().map(Real::to_bits);
        self.unit_normal
            .filter(|(local, _)| bits(*local) == bits(normal))
            .map(|(_, n)| n)
    }
}

/// The world unit normal of a half-space of shape normal `normal` at the pose `pose`, the
/// division by its norm done as the contact queries do it; `None` where the norm is NaN or
/// not positive.
pub(crate) fn half_space_unit_normal(
    pose: &Isometry3<f64>,
    normal: Vector,
) -> Option<Vector3<f64>> {
    let n = pose.rotation * vec_to_na(normal);
    let len = n.norm();
    if len.is_nan() || len <= 0.0 {
        return None;
    }
    Some(n / len)
}

/// What a ground's motion and place were computed from. A change of `class` (the shape,
/// enabled or sensor flags, the parent's type, the collider itself) moves the ground to
/// another place or out: the index is rebuilt. A change of `pose` or `skin` of a still ground
/// is computed again in place. (A shape edited in place through `Collider::shape_mut` keeps its
/// address and is not seen: set a new shape, or mark the ground again.)
#[derive(Clone, Copy, PartialEq)]
struct Basis {
    class: Class,
    /// The pose rapier's step gives it (`pose_in_step`).
    pose: Pose,
    /// Its pose relative to its body, if it has one.
    relative: Option<Pose>,
    skin: Real,
    /// What a slab's tiles must share beyond their shape: a change moves a tile out of (or
    /// into) a slab, so a tile of one rebuilds the index.
    props: Props,
}

/// A ground's coefficients and filtering, as rapier's contacts with it read them.
#[derive(Clone, Copy, PartialEq)]
struct Props {
    friction: Real,
    restitution: Real,
    combine: (CoefficientCombineRule, CoefficientCombineRule),
    groups: (InteractionGroups, InteractionGroups),
    types: ActiveCollisionTypes,
    hooks: ActiveHooks,
}

#[derive(Clone, Copy, PartialEq)]
struct Class {
    /// The collider's shape, by address (rapier replaces the shared shape on `set_shape`).
    shape: *const (),
    enabled: bool,
    sensor: bool,
    /// The parent's type (`None`: parentless), and whether the parent is enabled.
    parent: Option<(RigidBodyType, bool)>,
}

// SAFETY of `Send`/`Sync`: `shape` is only ever compared, never dereferenced.
unsafe impl Send for Class {}
unsafe impl Sync for Class {}

impl Basis {
    /// What a ground's motion is computed from: the collider `co`, its body in `bodies`, and
    /// the pose rapier's step gives it (`pose_in_step`).
    fn of(co: &Collider, bodies: &RigidBodySet, pose: Pose) -> Self {
        Self {
            class: Class {
                shape: co.shape() as *const _ as *const (),
                enabled: co.is_enabled(),
                sensor: co.is_sensor(),
                parent: co
                    .parent()
                    .and_then(|p| bodies.get(p))
                    .map(|rb| (rb.body_type(), rb.is_enabled())),
            },
            pose,
            relative: co.position_wrt_parent().copied(),
            skin: co.contact_skin(),
            props: Props {
                friction: co.friction(),
                restitution: co.restitution(),
                combine: (co.friction_combine_rule(), co.restitution_combine_rule()),
                groups: (co.collision_groups(), co.solver_groups()),
                types: co.active_collision_types(),
                hooks: co.active_hooks(),
            },
        }
    }

    /// Is `co` still what this was taken from (`Basis::of` of it, its body and its step pose,
    /// equal to `self`)? Field by field from the collider, without building a second basis:
    /// the index's pass asks it of every ground every step. While its relative pose is the
    /// one taken, its step pose is its own (`pose_in_step`); a relative pose changes only by
    /// a write, which rapier flags until its step applies it and so moves the collider.
    #[inline]
    fn matches(&self, co: &Collider, bodies: &RigidBodySet) -> bool {
        let (class, props) = (&self.class, &self.props);
        *co.position() == self.pose
            && (!co.has_modified_flag() || co.position_wrt_parent() == self.relative.as_ref())
            && co.contact_skin() == self.skin
            && std::ptr::eq(co.shape() as *const _ as *const (), class.shape)
            && co.is_enabled() == class.enabled
            && co.is_sensor() == class.sensor
            && co.friction() == props.friction
            && co.restitution() == props.restitution
            && (co.friction_combine_rule(), co.restitution_combine_rule()) == props.combine
            && (co.collision_groups(), co.solver_groups()) == props.groups
            && co.active_collision_types() == props.types
            && co.active_hooks() == props.hooks
            && co
                .parent()
                .and_then(|p| bodies.get(p))
                .map(|rb| (rb.body_type(), rb.is_enabled()))
                == class.parent
    }
}

/// Where a ground sits in the index.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Place {
    /// Not queried this step (disabled, a sensor, on a dynamic body, or removed).
    Absent,
    /// A leaf of the BVH (still and bounded).
    Tree,
    /// In the short list tested one by one (a half-space, or moving).
    Listed,
    /// A tile of a slab: the slab is in the BVH, the tile in `GroundIndex::tiles`.
    Tile,
}

/// Every ground's motion over the step and a BVH to find those near a body (see the module's
/// contract).
#[derive(Default)]
pub(crate) struct GroundIndex {
    /// By index: the ground's motion this step (meaningful where `places` is not `Absent`).
    pub motions: Vec<GroundMotion>,
    places: Vec<Place>,
    /// By index: what the motion was computed from (`None`: the collider was gone).
    bases: Vec<Option<Basis>>,
    /// Indices of the `Listed` grounds.
    listed: Vec<usize>,
    /// Indices of the grounds on kinematic bodies (recomputed every step).
    moving: Vec<usize>,
    tree: Bvh,
    /// The registry changed since the last rebuild.
    stale: bool,
    /// The step length and loosening the motions were computed with.
    dt: f64,
    gap: f64,
    /// By collider slot: the ground's handle and entry, for the hooks' lookups.
    by_slot: Vec<Option<Slot>>,
    /// The slabs; slab `k`'s motion is `motions[bases.len() + k]`.
    slabs: Vec<Slab>,
    /// A BVH over the slabs' tiles (leaves: their indices), for the queries that need them.
    tiles: Bvh,
    /// By index: the ground's collider (the motions are lent to the step while it runs).
    handles: Vec<ColliderHandle>,
    /// The grounds whose hook flags the last pass found changed (`hooks_known`: the pass
    /// compared every ground; after a rebuild, any may have changed).
    hooks_changed: Vec<ColliderHandle>,
    hooks_known: bool,
}

/// A ground's entry in the hooks' table, and the slab it is a tile of (the slab's index and
/// the handle standing for its tiles).
#[derive(Clone, Copy)]
struct Slot {
    handle: ColliderHandle,
    entry: GroundEntry,
    slab: Option<(u32, ColliderHandle)>,
    /// The ground's index (in `handles`, `bases`).
    index: u32,
}

type Registry = HashMap<ColliderHandle, GroundEntry, BuildHasherDefault<HandleHasher>>;

impl GroundIndex {
    /// The registry changed (a ground marked, unmarked, or given a material): rebuilt at the
    /// next [`Self::rebuild`]; until then [`Self::entry`] answers `None` (ask the registry).
    pub fn invalidate(&mut self) {
        self.stale = true;
    }

    /// The ground entry of a collider from the table built with the index, or `Err(())` when
    /// the table is stale (the registry must answer).
    #[inline]
    pub fn entry(&self, c: ColliderHandle) -> Result<Option<&GroundEntry>, ()> {
        if self.stale {
            return Err(());
        }
        Ok(match self.by_slot.get(slot_of(c)) {
            Some(Some(slot)) if slot.handle == c => Some(&slot.entry),
            _ => None,
        })
    }

    /// The handle that stands for a collider in the plugin's tables: a slab's first tile for
    /// each of its tiles, else the collider itself.
    #[inline]
    pub fn stand_in(&self, c: ColliderHandle) -> ColliderHandle {
        if self.slabs.is_empty() {
            return c;
        }
        match self.by_slot.get(slot_of(c)) {
            Some(Some(Slot {
                handle,
                slab: Some((_, first)),
                ..
            })) if *handle == c => *first,
            _ => c,
        }
    }

    /// The ground an event at the world point `point` names: for the handle standing for a
    /// slab's tiles, the tile under the point (`Slab::tile_at`); else `c` itself.
    pub fn tile_at(&self, c: ColliderHandle, point: &Vector3<f64>) -> ColliderHandle {
        match self.by_slot.get(slot_of(c)) {
            Some(Some(Slot {
                handle,
                slab: Some((k, first)),
                ..
            })) if *handle == c && *first == c => {
                self.handles[self.slabs[*k as usize].tile_at(point)]
            }
            _ => c,
        }
    }

    /// The slab the collider `c` is a tile of, if any.
    pub fn slab_of(&self, c: ColliderHandle) -> Option<&Slab> {
        match self.by_slot.get(slot_of(c)) {
            Some(Some(Slot {
                handle,
                slab: Some((k, _)),
                ..
            })) if *handle == c => self.slabs.get(*k as usize),
            _ => None,
        }
    }

    /// A ground's entry changed (its material): the hooks' table follows, if it holds the
    /// ground (else it is rebuilt from the registry at the next refresh anyway). A tile of a
    /// slab may no longer share its slab's material, and a ground in the BVH may share a
    /// neighbour's again: the index is rebuilt.
    pub fn set_entry(&mut self, c: ColliderHandle, entry: GroundEntry) {
        if let Some(Some(slot)) = self.by_slot.get_mut(slot_of(c)) {
            if slot.handle == c {
                slot.entry = entry;
                // A tile may no longer share its slab's material, and a ground in the BVH may
                // share it again (a material set, then taken off).
                let in_tree = self.places.get(slot.index as usize) == Some(&Place::Tree);
                if slot.slab.is_some() || in_tree {
                    self.stale = true;
                }
            }
        }
    }

    /// Brings every ground's motion to this step (see the module's contract): [`Self::update`],
    /// else [`Self::rebuild`]. The step's own call is `Registry::refresh_index`, which forgets
    /// removed colliders before a rebuild; this one is the unit tests'. `lone` says which
    /// grounds may not be a slab's tile whatever their shape (what a tile's stand-in would not
    /// carry: a restitution curve of their own, hook flags the user set).
    #[cfg(test)]
    pub fn refresh(
        &mut self,
        registry: &Registry,
        bodies: &RigidBodySet,
        colliders: &ColliderSet,
        (dt, gap): (f64, f64),
        lone: &dyn Fn(ColliderHandle) -> bool,
    ) {
        if !self.update(bodies, colliders, (dt, gap), lone) {
            self.rebuild(registry, bodies, colliders, (dt, gap), lone);
        }
    }

    /// Brings every ground's motion to this step in place, if it can: `false` when the index
    /// must be rebuilt instead (the registry changed, or a ground changed its place: its
    /// collider removed, disabled, given a new shape, its body's type switched, a tile of a
    /// slab moved or changed). One comparison per ground: what its motion was computed from.
    pub fn update(
        &mut self,
        bodies: &RigidBodySet,
        colliders: &ColliderSet,
        (dt, gap): (f64, f64),
        lone: &dyn Fn(ColliderHandle) -> bool,
    ) -> bool {
        let complete = self.motions.len() == self.bases.len() + self.slabs.len();
        if self.stale || !complete || gap != self.gap {
            return false;
        }
        // A still ground's motion and the slabs do not depend on the step's length (a frame
        // time that varies): only the moving grounds', computed below with it.
        self.dt = dt;
        self.hooks_changed.clear();
        // Written once the pass has gone through: a pass that fails leaves them for the
        // rebuild to read. A moving or absent ground's is kept as it was taken (a moving
        // ground's pose changes every step; its motion is taken afresh below).
        let mut new_bases = Vec::new();
        for i in 0..self.bases.len() {
            let handle = self.handles[i];
            let (before, co) = match (&self.bases[i], colliders.get(handle)) {
                (Some(before), Some(co)) => (before, co),
                // Gone when the index was built, and still gone.
                (None, None) => continue,
                // Removed, or back.
                _ => return false,
            };
            if before.matches(co, bodies) {
                continue;
            }
            let pose = pose_in_step(co, bodies, before.relative.as_ref());
            let now = Basis::of(co, bodies, pose);
            if now.props.hooks != before.props.hooks {
                self.hooks_changed.push(handle);
            }
            if now.class != before.class {
                return false;
            }
            if self.places[i] == Place::Tile {
                // The plugin's own hook flags put on or taken off (idle grounds lose them): the
                // tile stays its slab's while the user's flags on it stay none.
                let hooks_only = Basis {
                    props: Props {
                        hooks: before.props.hooks,
                        ..now.props
                    },
                    ..now
                } == *before;
                if hooks_only && !lone(handle) {
                    new_bases.push((i, now));
                    continue;
                }
                return false;
            }
            // Moving grounds are computed below; absent ones have nothing to compute.
            if self.places[i] == Place::Absent || !self.motions[i].is_still() {
                continue;
            }
            // A still ground moved, or changed its skin or coefficients: computed again in
            // place.
            let Some(m) = motion_of(handle, (co, pose), bodies, dt, gap) else {
                return false;
            };
            // A cuboid that may now form a slab with a cuboid it meets (a change undone, a
            // tile put back in line): the index is built again, as the slabs must not depend
            // on the grounds' history.
            if self.places[i] == Place::Tree
                && co.shape().as_cuboid().is_some()
                && !lone(handle)
                && self.meets_cuboid(i, &m.aabb, colliders)
            {
                return false;
            }
            self.motions[i] = m;
            new_bases.push((i, now));
            if self.places[i] == Place::Tree {
                self.tree.remove(i as u32);
                self.tree.insert(m.aabb, i as u32);
            }
        }
        for k in 0..self.moving.len() {
            let i = self.moving[k];
            let handle = self.handles[i];
            let last = self.bases[i].as_ref().and_then(|b| b.relative.as_ref());
            match colliders.get(handle).and_then(|co| {
                let pose = pose_in_step(co, bodies, last);
                motion_of(handle, (co, pose), bodies, dt, gap)
            }) {
                Some(m) if !m.is_still() => self.motions[i] = m,
                _ => return false,
            }
        }
        for (i, basis) in new_bases {
            self.bases[i] = Some(basis);
        }
        self.hooks_known = true;
        true
    }

    /// Does the box `aabb` of ground `i` meet a slab or another cuboid ground in the BVH?
    fn meets_cuboid(&self, i: usize, aabb: &Aabb, colliders: &ColliderSet) -> bool {
        self.tree.intersect_aabb(aabb).any(|leaf| {
            let j = leaf as usize;
            j != i
                && (j >= self.bases.len()
                    || colliders
                        .get(self.handles[j])
                        .is_some_and(|co| co.shape().as_cuboid().is_some()))
        })
    }

    /// The plugin wrote `hooks` as a ground's flags (after this step's pass): the next pass
    /// compares the ground's flags with them, so that it finds any the user sets since, even
    /// the flags the ground had before the plugin's.
    pub fn noted_hooks(&mut self, c: ColliderHandle, hooks: ActiveHooks) {
        let Some(Some(slot)) = self.by_slot.get(slot_of(c)) else {
            return;
        };
        if slot.handle != c {
            return;
        }
        if let Some(Some(base)) = self.bases.get_mut(slot.index as usize) {
            base.props.hooks = hooks;
        }
    }

    /// rapier is about to take a step without this index's pass (a step of no length): that
    /// step applies the relative poses written since the last pass, so each ground's is
    /// noted as seen (`pose_in_step` compares the next writes with them).
    pub fn note_relative_poses(&mut self, colliders: &ColliderSet) {
        for (base, handle) in self.bases.iter_mut().zip(&self.handles) {
            if let (Some(base), Some(co)) = (base.as_mut(), colliders.get(*handle)) {
                base.relative = co.position_wrt_parent().copied();
            }
        }
    }

    /// The pose relative to its body that the index's last build or pass saw for the ground
    /// `c`, if it was one and has a body.
    fn last_relative(&self, c: ColliderHandle) -> Option<Pose> {
        match self.by_slot.get(slot_of(c)) {
            Some(Some(slot)) if slot.handle == c => {
                self.bases.get(slot.index as usize)?.as_ref()?.relative
            }
            _ => None,
        }
    }

    /// The grounds whose hook flags the user changed since the plugin last wrote them (or,
    /// for a ground the plugin has not written, since the last step's pass), or `None` when
    /// that is not known (the index was rebuilt since).
    pub fn hooks_changed(&self) -> Option<&[ColliderHandle]> {
        self.hooks_known.then_some(self.hooks_changed.as_slice())
    }

    /// Builds the index afresh from the registry (see the module's contract).
    pub fn rebuild(
        &mut self,
        registry: &Registry,
        bodies: &RigidBodySet,
        colliders: &ColliderSet,
        (dt, gap): (f64, f64),
        lone: &dyn Fn(ColliderHandle) -> bool,
    ) {
        let mut handles: Vec<ColliderHandle> = registry.keys().copied().collect();
        // Deterministic order, whatever the hash map's.
        handles.sort_by_key(|h| h.into_raw_parts());
        // The relative poses the last build or pass saw (`pose_in_step` finds a relative
        // pose waiting for the step by them).
        let last: Vec<Option<Pose>> = handles.iter().map(|h| self.last_relative(*h)).collect();
        self.motions.clear();
        self.places.clear();
        self.bases.clear();
        self.listed.clear();
        self.moving.clear();
        let mut leaves = Vec::new();
        for (&handle, last) in handles.iter().zip(&last) {
            let co = colliders.get(handle);
            let pose = co.map(|co| pose_in_step(co, bodies, last.as_ref()));
            let motion = co
                .zip(pose)
                .and_then(|(co, pose)| motion_of(handle, (co, pose), bodies, dt, gap));
            let i = self.motions.len();
            let (motion, place) = match motion {
                Some(m) if m.is_still() && m.plane.is_none() => {
                    leaves.push((i, m.aabb));
                    (m, Place::Tree)
                }
                Some(m) => {
                    self.listed.push(i);
                    if !m.is_still() {
                        self.moving.push(i);
                    }
                    (m, Place::Listed)
                }
                None => (absent(handle), Place::Absent),
            };
            self.motions.push(motion);
            self.places.push(place);
            // Absent grounds keep what they were computed from too, so that a change (the
            // collider enabled again) is seen.
            self.bases
                .push(co.zip(pose).map(|(co, pose)| Basis::of(co, bodies, pose)));
        }
        self.slabs = self.find_slabs(registry, colliders, &handles, lone);
        let tiles = self.place_slabs(gap, &mut leaves);
        leaves.retain(|(i, _)| self.places[*i] == Place::Tree);
        self.tree = build_bvh(leaves);
        self.tiles = build_bvh(tiles);
        let len = registry.keys().map(|h| slot_of(*h) + 1).max().unwrap_or(0);
        self.by_slot.clear();
        self.by_slot.resize(len, None);
        for (i, h) in handles.iter().enumerate() {
            self.by_slot[slot_of(*h)] = Some(Slot {
                handle: *h,
                entry: registry[h],
                slab: None,
                index: i as u32,
            });
        }
        for (k, slab) in self.slabs.iter().enumerate() {
            let first = handles[slab.members[0]];
            for &m in &slab.members {
                if let Some(Some(slot)) = self.by_slot.get_mut(slot_of(handles[m])) {
                    slot.slab = Some((k as u32, first));
                }
            }
        }
        self.handles = handles;
        self.hooks_known = false;
        self.stale = false;
        self.dt = dt;
        self.gap = gap;
    }

    /// Each slab just found (`self.slabs`) as a ground of its own after the others (its
    /// motion its first tile's, its shape the box, loosened by `gap` and the tiles' skin), a
    /// leaf of the BVH in `leaves`; its tiles taken out of the BVH (`Place::Tile`). Returns
    /// the tiles' leaves, for the BVH over them.
    fn place_slabs(&mut self, gap: f64, leaves: &mut Vec<(usize, Aabb)>) -> Vec<(usize, Aabb)> {
        let mut tiles = Vec::new();
        for slab in &self.slabs {
            let s = self.motions.len();
            let first = self.motions[slab.members[0]];
            let cuboid = Cuboid::new(vec_from_na(&slab.half));
            let mut aabb = cuboid.aabb(&pose_from_na(&slab.pose));
            // Loosened as each tile's box is (the same skin, by the slab's rule).
            let skin = self.bases[slab.members[0]].map_or(0.0, |b| to_f64(b.skin));
            aabb = aabb.loosened(to_real(gap + skin));
            self.motions.push(GroundMotion {
                com0: slab.pose.translation.vector,
                rot0: slab.pose.rotation,
                local: Isometry3::identity(),
                pose0: slab.pose,
                aabb,
                slab: Some(cuboid),
                unit_normal: None,
                ..first
            });
            self.places.push(Place::Tree);
            leaves.push((s, aabb));
            for &m in &slab.members {
                self.places[m] = Place::Tile;
                tiles.push((m, self.motions[m].aabb));
            }
        }
        tiles
    }

    /// The slabs among the still cuboid grounds just placed in the BVH (`slabs.rs`): tiles
    /// with the same entry, coefficients, filtering and skin, not `lone`. (Their parents
    /// may differ: a fixed body's only other say is a joint, and a jointed body meets the
    /// tiles one by one.)
    fn find_slabs(
        &self,
        registry: &Registry,
        colliders: &ColliderSet,
        handles: &[ColliderHandle],
        lone: &dyn Fn(ColliderHandle) -> bool,
    ) -> Vec<Slab> {
        // Each distinct (entry, coefficients and filtering, skin) gets a class number: the
        // tiles' key.
        let mut classes: Vec<(GroundEntry, Props, Real)> = Vec::new();
        let mut tiles = Vec::new();
        for (i, handle) in handles.iter().enumerate() {
            let (Some(Some(basis)), Some(co), Some(entry)) = (
                self.bases.get(i),
                colliders.get(*handle),
                registry.get(handle),
            ) else {
                continue;
            };
            let Some(cuboid) = co.shape().as_cuboid() else {
                continue;
            };
            if self.places[i] != Place::Tree || lone(*handle) {
                continue;
            }
            let mut entry = *entry;
            entry.automatic = false;
            // Hook flags: the user's are none (not `lone`); the plugin's own come and go.
            let props = Props {
                hooks: ActiveHooks::empty(),
                ..basis.props
            };
            let class = (entry, props, basis.skin);
            let id = match classes.iter().position(|c| *c == class) {
                Some(id) => id,
                None => {
                    classes.push(class);
                    classes.len() - 1
                }
            };
            tiles.push(Tile {
                index: i,
                pose: self.motions[i].pose0,
                half: vec_to_na(cuboid.half_extents),
                key: id,
            });
        }
        if tiles.len() < 2 {
            return Vec::new();
        }
        find_slabs(&tiles)
    }

    /// The grounds on kinematic bodies (their motion is measured again after the step).
    pub fn moving(&self) -> &[usize] {
        &self.moving
    }

    /// Does any ground's swept AABB meet the cube `centre ± half`?
    pub fn any_near(&self, motions: &[GroundMotion], centre: Vector, half: Real) -> bool {
        let cube = Aabb::from_half_extents(centre, Vector::splat(half));
        // An empty tree (only half-spaces and moving grounds) is not traversed: setting up
        // the traversal costs as much as the rest of a far body's survey.
        self.listed
            .iter()
            .any(|i| !motions[*i].misses_cube(centre, half))
            || !self.tree.is_empty() && self.tree.intersect_aabb(&cube).next().is_some()
    }

    /// The indices of the grounds whose swept AABB (and plane) meets the ball `centre ±
    /// radius`, in increasing order: [`Self::near`], less the grounds in the cube's corners
    /// when it meets several (the tiles of a floor around a ball resting on one; a lone ground
    /// near the cube is kept, as the test would cost about what it saves).
    #[inline]
    pub fn near_ball(
        &self,
        motions: &[GroundMotion],
        centre: Vector,
        radius: Real,
    ) -> SmallList<usize> {
        let mut near = self.near(motions, centre, radius);
        // Several grounds are a spilled list, filtered where it is.
        if let SmallList::Many(list) = &mut near {
            list.retain(|i| !motions[*i].misses_ball(centre, radius));
        }
        near
    }

    /// [`Self::near_ball`] with each slab's tiles in place of the slab.
    pub fn near_ball_tiles(
        &self,
        motions: &[GroundMotion],
        centre: Vector,
        radius: Real,
    ) -> SmallList<usize> {
        self.near_in(motions, centre, radius, true)
            .iter()
            .copied()
            .filter(|i| !motions[*i].misses_ball(centre, radius))
            .collect()
    }

    /// [`Self::near`], or with `tiles` each slab's tiles in place of the slab (for a body
    /// that meets the tiles one by one, `observe::meets_tiles`).
    pub fn near_cube(
        &self,
        motions: &[GroundMotion],
        centre: Vector,
        half: Real,
        tiles: bool,
    ) -> SmallList<usize> {
        self.near_in(motions, centre, half, tiles && self.has_slabs())
    }

    /// Are some grounds tiles of a slab?
    pub fn has_slabs(&self) -> bool {
        !self.slabs.is_empty()
    }

    /// The indices of the grounds whose swept AABB meets the cube `centre ± half`, in
    /// increasing order.
    #[inline]
    pub fn near(&self, motions: &[GroundMotion], centre: Vector, half: Real) -> SmallList<usize> {
        self.near_in(motions, centre, half, false)
    }

    /// [`Self::near`], with `tiles` each slab's tiles in place of the slab.
    #[inline]
    fn near_in(
        &self,
        motions: &[GroundMotion],
        centre: Vector,
        half: Real,
        tiles: bool,
    ) -> SmallList<usize> {
        let cube = Aabb::from_half_extents(centre, Vector::splat(half));
        // A loop, not an iterator chain collected: this runs for every body near a ground
        // every step, most often over one listed half-space.
        let mut out = SmallList::Empty;
        for &i in &self.listed {
            if !motions[i].misses_cube(centre, half) {
                out.push(i);
            }
        }
        // Only a tree with leaves is traversed: its traversal state is a large value, and the
        // grounds are most often all listed (a half-space floor).
        if !self.tree.is_empty() {
            // The slabs' leaves come after the grounds'.
            let grounds = self.bases.len();
            for leaf in self.tree.intersect_aabb(&cube) {
                if !(tiles && leaf as usize >= grounds) {
                    out.push(leaf as usize);
                }
            }
        }
        if tiles && !self.tiles.is_empty() {
            for leaf in self.tiles.intersect_aabb(&cube) {
                out.push(leaf as usize);
            }
        }
        if out.len() > 1 {
            out.sort_unstable();
        }
        out
    }
}

/// A BVH over `leaves` (index, box). parry 0.31's `Bvh::from_iter` indexes its leaf table by
/// position for one or two leaves (it panics when their indices are not 0 and 1): those are
/// inserted one by one.
pub(crate) fn build_bvh(leaves: Vec<(usize, Aabb)>) -> Bvh {
    if leaves.len() > 2 {
        Bvh::from_iter(BvhBuildStrategy::Binned, leaves)
    } else {
        let mut tree = Bvh::new();
        for (i, aabb) in leaves {
            tree.insert(aabb, i as u32);
        }
        tree
    }
}

/// The collider's world pose from its centre-of-mass frame's (`com0`, `rot0`) and its pose
/// `local` in that frame.
fn start_pose(
    com0: Vector3<f64>,
    rot0: UnitQuaternion<f64>,
    local: &Isometry3<f64>,
) -> Isometry3<f64> {
    Isometry3::from_parts(Translation3::from(com0), rot0) * local
}

/// The place-holder motion of a ground not queried this step.
fn absent(handle: ColliderHandle) -> GroundMotion {
    GroundMotion {
        handle,
        body: None,
        com0: Vector3::zeros(),
        rot0: UnitQuaternion::identity(),
        local: Isometry3::identity(),
        pose0: Isometry3::identity(),
        v: Vector3::zeros(),
        w: Vector3::zeros(),
        aabb: Aabb::new_invalid(),
        plane: None,
        slab: None,
        unit_normal: None,
    }
}

/// The pose rapier's step gives the collider `co`, whose pose relative to its body the index
/// last saw as `last_relative` (`None`: not known, or it has no body). A pose set relative to
/// the body reaches the collider's world pose only in rapier's step
/// (`set_position_wrt_parent`: the step moves it to its body's pose times the relative pose);
/// a world pose set on it, or its body's (carried to it before the pass,
/// `ImpactPlugin::before_step`), is its own at once and kept. So the step's pose is its own,
/// unless the collider was written since rapier's last step (it is then flagged as modified,
/// `HasModifiedFlag`) and its relative pose differs from `last_relative` (kept through steps
/// without a pass, [`GroundIndex::note_relative_poses`]): then its body's pose times that
/// relative pose, as rapier computes it.
///
/// rapier's own record of a relative pose waiting for its step is not public, and two writes
/// look from here like the world pose they are not: a relative pose written with the value it
/// already had, after a world pose was written on the collider directly (which rapier's docs
/// reserve for colliders without a body); and a relative pose written in the step the
/// collider is first marked as ground (`last_relative` unknown). rapier's step gives each its
/// relative pose; the index takes it a step late.
#[inline]
fn pose_in_step(co: &Collider, bodies: &RigidBodySet, last_relative: Option<&Pose>) -> Pose {
    if let (Some(last), Some(relative)) = (last_relative, co.position_wrt_parent()) {
        if relative != last && co.has_modified_flag() {
            if let Some(rb) = co.parent().and_then(|p| bodies.get(p)) {
                return *rb.position() * *relative;
            }
        }
    }
    *co.position()
}

/// The box of a moving ground's collider `co` over a step of length `dt`: the box of its
/// start (`start`, loosened by `loosen`) merged with its end's (at the pose `end`, loosened
/// alike); for a ground turning at `w`, also the start's box loosened by the farthest any of
/// its points travels (`local_frame`: the collider in its body's centre-of-mass frame), as a
/// turn carries the points along arcs that can leave the boxes of its two ends (a flipper's
/// tip at mid-turn).
fn swept_box(
    co: &Collider,
    (start, end): (Aabb, &Pose),
    loosen: Real,
    (v, w, dt): (Vector3<f64>, Vector3<f64>, f64),
    local_frame: &Isometry3<f64>,
) -> Aabb {
    let mut aabb = start;
    aabb.merge(&co.shape().compute_aabb(end).loosened(loosen));
    if w != Vector3::zeros() {
        let sphere = co.shape().compute_local_bounding_sphere();
        let centre = local_frame * Point3::from(vec_to_na(sphere.center));
        let farthest = centre.coords.norm() + to_f64(sphere.radius);
        let travel = (v.norm() + w.norm() * farthest) * dt;
        // A velocity the user set to NaN or infinity travels nowhere that a box can hold: the
        // box of the ends is kept, rather than parry's refusal of the amount (a panic).
        if travel.is_finite() {
            aabb.merge(&start.loosened(to_real(travel)));
        }
    }
    aabb
}

/// A ground's start-of-step pose, predicted velocities and swept AABB, or `None` when rapier
/// would not collide with it this step (disabled, a sensor, on a disabled body) or it is on a
/// dynamic body.
fn motion_of(
    handle: ColliderHandle,
    (co, pose): (&Collider, Pose),
    bodies: &RigidBodySet,
    dt: f64,
    gap: f64,
) -> Option<GroundMotion> {
    if !co.is_enabled() || co.is_sensor() {
        return None;
    }
    let parent = co.parent().and_then(|p| bodies.get(p).map(|rb| (p, rb)));
    let loosen = to_real(gap + to_f64(co.contact_skin()));
    let aabb = co.shape().compute_aabb(&pose).loosened(loosen);
    // The half-space's bound at a collider pose: `n·x <= d`, loosened like the AABB.
    let half_space = co.shape().as_halfspace();
    let plane_at = |pose: &Pose| {
        half_space.map(|hs| {
            let n = pose.rotation * hs.normal;
            (n, n.dot(pose.translation) + loosen)
        })
    };
    match parent {
        Some((_, rb)) if rb.is_dynamic() || !rb.is_enabled() => None,
        Some((bh, rb)) if !rb.is_fixed() => {
            let frame0 = pose_to_na(rb.position());
            let local_com = vec_to_na(rb.local_center_of_mass());
            let com0 = (frame0 * Point3::from(local_com)).coords;
            let (v, w) = if rb.body_type() == RigidBodyType::KinematicPositionBased {
                let frame1 = pose_to_na(rb.next_position());
                let com1 = (frame1 * Point3::from(local_com)).coords;
                (
                    (com1 - com0) / dt,
                    (frame1.rotation * frame0.rotation.inverse()).scaled_axis() / dt,
                )
            } else {
                (vec_to_na(rb.linvel()), vec_to_na(rb.angvel()))
            };
            let local_frame =
                Isometry3::from_parts(Translation3::from(-local_com), UnitQuaternion::identity())
                    * co.position_wrt_parent()
                        .map_or(Isometry3::identity(), pose_to_na);
            let end = Isometry3::from_parts(
                Translation3::from(com0 + v * dt),
                UnitQuaternion::from_scaled_axis(w * dt) * frame0.rotation,
            ) * local_frame;
            let end_pose = pose_from_na(&end);
            let aabb = swept_box(co, (aabb, &end_pose), loosen, (v, w, dt), &local_frame);
            // A turning half-space sweeps too much for one plane: AABB only.
            let plane = match (plane_at(&pose), plane_at(&end_pose)) {
                (Some((n, d0)), Some((_, d1))) if w == Vector3::zeros() => Some((n, d0.max(d1))),
                _ => None,
            };
            Some(GroundMotion {
                handle,
                body: Some(bh),
                com0,
                rot0: frame0.rotation,
                local: local_frame,
                pose0: start_pose(com0, frame0.rotation, &local_frame),
                v,
                w,
                aabb,
                plane,
                slab: None,
                unit_normal: None,
            })
        }
        _ => {
            let plane = plane_at(&pose);
            let pose = pose_to_na(&pose);
            let (com0, rot0, local) = (
                pose.translation.vector,
                pose.rotation,
                Isometry3::identity(),
            );
            let pose0 = start_pose(com0, rot0, &local);
            let unit_normal = half_space
                .and_then(|hs| Some((hs.normal, half_space_unit_normal(&pose0, hs.normal)?)));
            Some(GroundMotion {
                handle,
                body: None,
                com0,
                rot0,
                local,
                pose0,
                v: Vector3::zeros(),
                w: Vector3::zeros(),
                aabb,
                plane,
                slab: None,
                unit_normal,
            })
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rapier::prelude::{ColliderBuilder, PhysicsWorld, RigidBodyBuilder};

    const DT: f64 = 1.0 / 60.0;
    const GAP: f64 = 0.005;

    fn registry(grounds: &[ColliderHandle]) -> Registry {
        grounds
            .iter()
            .map(|h| {
                (
                    *h,
                    GroundEntry {
                        material: None,
                        rolling: (None, None),
                        tangential: None,
                        automatic: false,
                    },
                )
            })
            .collect()
    }

    /// The grounds within 10 cm of `at`, by collider handle.
    fn near_at(index: &GroundIndex, at: Vector) -> Vec<ColliderHandle> {
        index
            .near(&index.motions, at, 0.1)
            .iter()
            .map(|i| index.motions[*i].handle)
            .collect()
    }

    /// Four tiles 0.2 m wide meeting at the origin, tops at y = 0.
    fn four_tiles(world: &mut PhysicsWorld) -> Vec<ColliderHandle> {
        [(-0.1, -0.1), (0.1, -0.1), (-0.1, 0.1), (0.1, 0.1)]
            .iter()
            .map(|(x, z)| {
                world.colliders.insert(
                    ColliderBuilder::cuboid(0.1, 0.1, 0.1).translation(Vector::new(*x, -0.1, *z)),
                )
            })
            .collect()
    }

    #[test]
    fn the_ball_query_leaves_out_the_tiles_in_the_cubes_corners_only() {
        let mut world = PhysicsWorld::default();
        let tiles = four_tiles(&mut world);
        let reg = registry(&tiles);
        let mut index = GroundIndex::default();
        index.refresh(&reg, &world.bodies, &world.colliders, (DT, GAP), &|_| true);
        let handles = |list: &[usize]| -> Vec<ColliderHandle> {
            list.iter().map(|i| index.motions[*i].handle).collect()
        };
        let found = |at: Vector, r: Real| {
            let cube = handles(&index.near(&index.motions, at, r));
            let ball = handles(&index.near_ball(&index.motions, at, r));
            // The ball is inside the cube: never a ground the cube misses.
            assert!(
                ball.iter().all(|h| cube.contains(h)),
                "{ball:?} of {cube:?}"
            );
            (cube, ball)
        };
        // 4 cm from the corner of the first tile, 6 cm up, reach 7 cm: the cube reaches the
        // three others' boxes (loosened by the gap), the ball the one under it and the two
        // beside it, not the one across the corner (6.5 cm to the two beside it, 7.4 cm to the
        // one across).
        let at = Vector::new(-0.1 + 0.06, 0.06, -0.1 + 0.06);
        let (cube, ball) = found(at, 0.07);
        assert_eq!(cube, tiles);
        assert_eq!(ball, tiles[..3].to_vec());
        // Over a tile's middle far from the others it is that tile alone; at the corner where
        // the four meet, all four.
        assert_eq!(
            found(Vector::new(-0.15, 0.05, -0.15), 0.06).1,
            vec![tiles[0]]
        );
        assert_eq!(found(Vector::new(0.0, 0.05, 0.0), 0.06).1, tiles);
    }

    #[test]
    fn flush_tiles_are_one_slab_until_one_moves_or_stands_alone() {
        let mut world = PhysicsWorld::default();
        let tiles = four_tiles(&mut world);
        // One tile already carries the plugin's hook flags (a tile added to a floor the
        // plugin flagged): the flags the user set are what counts (`lone`), none here.
        world.colliders[tiles[2]].set_active_hooks(ActiveHooks::all());
        let reg = registry(&tiles);
        let mut index = GroundIndex::default();
        index.refresh(&reg, &world.bodies, &world.colliders, (DT, GAP), &|_| false);
        // A ball over the corner where the four meet meets one ground: their box.
        let at = Vector::new(0.0, 0.05, 0.0);
        let near = index.near_ball(&index.motions, at, 0.06);
        assert_eq!(near.len(), 1);
        let slab = index.motions[near[0]];
        let cuboid = slab.slab.expect("a slab");
        assert_eq!(cuboid.half_extents, Vector::new(0.2, 0.1, 0.2));
        assert_eq!(slab.handle, tiles[0]);
        assert!(tiles.iter().all(|t| index.stand_in(*t) == tiles[0]));
        // The tiles on demand, and the tile under a point.
        let each: Vec<ColliderHandle> = index
            .near_ball_tiles(&index.motions, at, 0.06)
            .iter()
            .map(|i| index.motions[*i].handle)
            .collect();
        assert_eq!(each, tiles);
        for (k, (x, z)) in [(-0.05, -0.15), (0.15, -0.05), (-0.15, 0.05), (0.05, 0.15)]
            .iter()
            .enumerate()
        {
            let p = Vector3::new(*x, 0.0, *z);
            assert_eq!(index.tile_at(tiles[0], &p), tiles[k]);
            // Only the stand-in is renamed.
            assert_eq!(index.tile_at(tiles[1], &p), tiles[1]);
        }
        // The plugin's hook flags put on the tiles (as on grounds near a body): updated in
        // place, the slab kept; a tile whose flags are the user's leaves it.
        for t in &tiles {
            world.colliders[*t].set_active_hooks(ActiveHooks::FILTER_CONTACT_PAIRS);
        }
        assert!(index.update(&world.bodies, &world.colliders, (DT, GAP), &|_| false));
        assert!(tiles.iter().all(|t| index.stand_in(*t) == tiles[0]));
        world.colliders[tiles[1]].set_active_hooks(ActiveHooks::empty());
        assert!(
            !index.update(&world.bodies, &world.colliders, (DT, GAP), &|c| c
                == tiles[1])
        );
        index.refresh(&reg, &world.bodies, &world.colliders, (DT, GAP), &|_| false);
        // One tile moved away: it is a ground of its own again, and the others no longer
        // form a box with it.
        world.colliders[tiles[3]].set_translation(Vector::new(5.0, -0.1, 5.0));
        index.refresh(&reg, &world.bodies, &world.colliders, (DT, GAP), &|_| false);
        assert_eq!(index.stand_in(tiles[3]), tiles[3]);
        let near = index.near_ball(&index.motions, Vector::new(5.0, 0.05, 5.0), 0.06);
        assert_eq!(near.len(), 1);
        assert_eq!(index.motions[near[0]].handle, tiles[3]);
        assert!(index.motions[near[0]].slab.is_none());
        // Put back, but one tile must stand alone (the caller's rule): it is not merged.
        world.colliders[tiles[3]].set_translation(Vector::new(0.1, -0.1, 0.1));
        index.refresh(&reg, &world.bodies, &world.colliders, (DT, GAP), &|c| {
            c == tiles[1]
        });
        assert_eq!(index.stand_in(tiles[1]), tiles[1]);
        assert!(index.has_slabs());
    }

    /// Whether a floor is one slab never depends on its history: a tile moved away, given
    /// other coefficients, flags of the user's own or a material, then put back as it was,
    /// is one of the slab's tiles again, as in an index built afresh.
    #[test]
    fn a_floor_changed_and_put_back_is_one_slab_again() {
        type Change = (&'static str, fn(&mut Collider, bool));
        let changes: [Change; 3] = [
            ("moved away", |co, back| {
                let x = if back { 0.1 } else { 5.0 };
                co.set_translation(Vector::new(x, -0.1, 0.1));
            }),
            ("friction", |co, back| {
                co.set_friction(if back { 0.5 } else { 0.9 })
            }),
            ("user flags", |co, back| {
                let flags = if back {
                    ActiveHooks::empty()
                } else {
                    ActiveHooks::MODIFY_SOLVER_CONTACTS
                };
                co.set_active_hooks(flags);
            }),
        ];
        for (what, change) in changes {
            let mut world = PhysicsWorld::default();
            let tiles = four_tiles(&mut world);
            let reg = registry(&tiles);
            let mut index = GroundIndex::default();
            // `lone` as the plugin asks it: flags of the user's own.
            let refresh = |index: &mut GroundIndex, world: &PhysicsWorld| {
                let lone = |c: ColliderHandle| !world.colliders[c].active_hooks().is_empty();
                index.refresh(&reg, &world.bodies, &world.colliders, (DT, GAP), &lone);
            };
            refresh(&mut index, &world);
            assert_eq!(index.stand_in(tiles[3]), tiles[0], "{what}: one slab");
            change(&mut world.colliders[tiles[3]], false);
            refresh(&mut index, &world);
            assert_eq!(index.stand_in(tiles[3]), tiles[3], "{what}: split");
            change(&mut world.colliders[tiles[3]], true);
            refresh(&mut index, &world);
            assert!(
                tiles.iter().all(|t| index.stand_in(*t) == tiles[0]),
                "{what}: put back, one slab again"
            );
        }
        // A material set on a tile, then taken off.
        let mut world = PhysicsWorld::default();
        let tiles = four_tiles(&mut world);
        let mut reg = registry(&tiles);
        let mut index = GroundIndex::default();
        let (bodies, colliders) = (&world.bodies, &world.colliders);
        index.refresh(&reg, bodies, colliders, (DT, GAP), &|_| false);
        let plain = reg[&tiles[3]];
        let own = GroundEntry {
            material: Some(Material::new(0.2, 0.9)),
            ..plain
        };
        for (entry, slab) in [(own, tiles[3]), (plain, tiles[0])] {
            reg.insert(tiles[3], entry);
            index.set_entry(tiles[3], entry);
            index.refresh(&reg, bodies, colliders, (DT, GAP), &|_| false);
            assert_eq!(index.stand_in(tiles[3]), slab);
        }
    }

    /// A turning ground's box holds its collider at every time of the step, as the plan and
    /// the search move it (its centre of mass along `v`, turning at `w` about it): blades 2 m
    /// long swung through half a radian in a step, about their middle and (their mass at a
    /// hub) about their end, whose tips at mid-turn lie up to 6 cm beyond the boxes of the
    /// step's two ends. A turn at a NaN rate leaves a box, not a panic.
    #[test]
    fn a_turning_grounds_box_holds_it_at_every_time_of_the_step() {
        use crate::rapier::math::Rotation;
        use crate::rapier::prelude::MassProperties;
        let mut world = PhysicsWorld::default();
        let spin = 30.0;
        // At -0.25 rad after the step below, turning to +0.25 in the next.
        let half_turn = Rotation::from_rotation_z(-0.75);
        let (_, middle) = world.insert(
            RigidBodyBuilder::kinematic_velocity_based()
                .rotation(half_turn.to_scaled_axis())
                .angvel(Vector::new(0.0, 0.0, spin)),
            ColliderBuilder::cuboid(1.0, 0.05, 0.3),
        );
        let hub = MassProperties::new(Vector::ZERO, 10.0, Vector::splat(1.0));
        let (_, end) = world.insert(
            RigidBodyBuilder::kinematic_velocity_based()
                .translation(Vector::new(5.0, 0.0, 0.0))
                .rotation(half_turn.to_scaled_axis())
                .additional_mass_properties(hub)
                .linvel(Vector::new(0.0, 3.0, 0.0))
                .angvel(Vector::new(0.0, 0.0, spin)),
            ColliderBuilder::cuboid(1.0, 0.05, 0.3)
                .translation(Vector::new(1.0, 0.0, 0.0))
                .density(0.0),
        );
        let (turned_nan, nan) = world.insert(
            RigidBodyBuilder::kinematic_velocity_based().translation(Vector::new(-5.0, 0.0, 0.0)),
            ColliderBuilder::cuboid(1.0, 0.05, 0.3),
        );
        // rapier computes the bodies' mass properties from their colliders and the hub in
        // its step.
        world.step();
        world.bodies[turned_nan].set_angvel(Vector::new(0.0, 0.0, Real::NAN), true);
        let grounds = [middle, end, nan];
        let reg = registry(&grounds);
        let mut index = GroundIndex::default();
        index.refresh(&reg, &world.bodies, &world.colliders, (DT, GAP), &|_| false);
        let end_com = index.motions[1].com0;
        let hub_at = vec_to_na(world.bodies[world.colliders[end].parent().unwrap()].translation());
        assert!(
            (end_com - hub_at).norm() < 1e-6,
            "the second blade turns about {end_com:?}, not its end"
        );
        for (k, m) in index.motions.iter().enumerate().take(2) {
            let co = &world.colliders[grounds[k]];
            for i in 0..=16 {
                let t = DT * f64::from(i) / 16.0;
                let frame = Isometry3::from_parts(
                    Translation3::from(m.com0 + m.v * t),
                    UnitQuaternion::from_scaled_axis(m.w * t) * m.rot0,
                );
                let held = co.shape().compute_aabb(&pose_from_na(&(frame * m.local)));
                assert!(
                    m.aabb.contains(&held),
                    "ground {k} at {i}/16 of the step: {held:?} beyond {:?}",
                    m.aabb
                );
            }
        }
    }

    /// A step of another length (a frame time that varies) recomputes the moving grounds
    /// with it, in place: the still ones and the slabs do not depend on it.
    #[test]
    fn a_step_of_another_length_moves_only_the_moving_grounds() {
        let mut world = PhysicsWorld::default();
        let mut tiles = four_tiles(&mut world);
        let (_, platform) = world.insert(
            RigidBodyBuilder::kinematic_velocity_based()
                .translation(Vector::new(3.0, 0.0, 0.0))
                .linvel(Vector::new(6.0, 0.0, 0.0)),
            ColliderBuilder::cuboid(0.5, 0.1, 0.5),
        );
        tiles.push(platform);
        let reg = registry(&tiles);
        let mut index = GroundIndex::default();
        let swept = |index: &GroundIndex| index.motions[4].aabb.maxs.x;
        index.refresh(&reg, &world.bodies, &world.colliders, (DT, GAP), &|_| false);
        let (short, long) = (swept(&index), 2.0 * DT);
        assert!(index.update(&world.bodies, &world.colliders, (long, GAP), &|_| false));
        assert!(index.has_slabs());
        assert_eq!(index.motions[4].handle, platform);
        let grown = swept(&index) - short;
        assert!(
            (to_f64(grown) - 6.0 * DT).abs() < 1e-4,
            "swept {grown} further"
        );
        // Another gap loosens every box: built again.
        assert!(
            !index.update(&world.bodies, &world.colliders, (long, 2.0 * GAP), &|_| {
                false
            })
        );
    }

    #[test]
    fn the_pass_over_the_grounds_sees_every_change_a_basis_holds() {
        use crate::rapier::prelude::{Group, SharedShape};
        let mut world = PhysicsWorld::default();
        let (_, c) = world.insert(
            RigidBodyBuilder::fixed(),
            ColliderBuilder::cuboid(0.5, 0.1, 0.5),
        );
        type Change = (&'static str, fn(&mut Collider));
        let changes: Vec<Change> = vec![
            ("pose", |co| co.set_translation(Vector::new(0.0, 1e-6, 0.0))),
            ("pose relative to the body", |co| {
                co.set_translation_wrt_parent(Vector::new(0.0, 1e-6, 0.0))
            }),
            ("skin", |co| co.set_contact_skin(0.01)),
            ("shape", |co| {
                co.set_shape(SharedShape::cuboid(0.5, 0.1, 0.5))
            }),
            ("enabled", |co| co.set_enabled(false)),
            ("sensor", |co| co.set_sensor(true)),
            ("friction", |co| co.set_friction(0.3)),
            ("restitution", |co| co.set_restitution(0.3)),
            ("combine", |co| {
                co.set_friction_combine_rule(CoefficientCombineRule::Max)
            }),
            ("groups", |co| {
                co.set_collision_groups(InteractionGroups::new(
                    Group::GROUP_2,
                    Group::ALL,
                    Default::default(),
                ))
            }),
            ("types", |co| {
                co.set_active_collision_types(ActiveCollisionTypes::all())
            }),
            ("hooks", |co| {
                co.set_active_hooks(ActiveHooks::FILTER_CONTACT_PAIRS)
            }),
        ];
        for (what, change) in changes {
            let mut w = PhysicsWorld::default();
            let (_, c) = w.insert(
                RigidBodyBuilder::fixed(),
                ColliderBuilder::cuboid(0.5, 0.1, 0.5),
            );
            let before = Basis::of(&w.colliders[c], &w.bodies, *w.colliders[c].position());
            assert!(before.matches(&w.colliders[c], &w.bodies), "{what}");
            change(&mut w.colliders[c]);
            let co = &w.colliders[c];
            assert!(!before.matches(co, &w.bodies), "{what} not seen");
            let pose = pose_in_step(co, &w.bodies, before.relative.as_ref());
            assert!(Basis::of(co, &w.bodies, pose) != before, "{what}");
        }
        // The parent's type.
        let before = Basis::of(
            &world.colliders[c],
            &world.bodies,
            *world.colliders[c].position(),
        );
        let parent = world.colliders[c].parent().unwrap();
        world.bodies[parent].set_body_type(RigidBodyType::KinematicPositionBased, true);
        assert!(!before.matches(&world.colliders[c], &world.bodies));
    }

    /// The index plans each step with the pose rapier's step gives a ground on a fixed body
    /// (compared after that step), when its pose relative to the body is set (which rapier
    /// applies in the step), when a world pose set directly on it is kept by rapier and the
    /// collider is then written again for something else, when the pass that sees the
    /// relative pose fails on another ground and the index is rebuilt, and when a step of no
    /// length (no pass, as in `prepare`) applies a relative pose before the next write.
    #[test]
    fn a_ground_is_planned_where_rapiers_step_puts_it() {
        // Writes `a` (and `b`) before step `k`; `true`: step `k` has no length.
        type Write = fn(&mut PhysicsWorld, ColliderHandle, ColliderHandle, usize) -> bool;
        let cases: [(&str, Write); 5] = [
            ("relative pose", |w, a, _, k| {
                if k == 1 {
                    w.colliders[a].set_translation_wrt_parent(Vector::new(0.0, 1.0, 0.0));
                }
                false
            }),
            ("world pose, then friction", |w, a, _, k| {
                match k {
                    1 => w.colliders[a].set_translation(Vector::new(0.0, 1.0, 0.0)),
                    3 => w.colliders[a].set_friction(0.3),
                    _ => {}
                }
                false
            }),
            ("relative pose, the pass failing after it", |w, a, b, k| {
                if k == 1 {
                    w.colliders[a].set_translation_wrt_parent(Vector::new(0.0, 1.0, 0.0));
                    w.colliders[b].set_enabled(false);
                }
                false
            }),
            (
                "relative pose, a step of no length, the relative pose back",
                |w, a, _, k| {
                    match k {
                        1 => w.colliders[a].set_translation_wrt_parent(Vector::new(0.0, 1.0, 0.0)),
                        2 => w.colliders[a].set_translation_wrt_parent(Vector::ZERO),
                        _ => {}
                    }
                    k == 1
                },
            ),
            (
                "relative pose, a step of no length, a world pose",
                |w, a, _, k| {
                    match k {
                        1 => w.colliders[a].set_translation_wrt_parent(Vector::new(0.0, 1.0, 0.0)),
                        2 => w.colliders[a].set_translation(Vector::new(0.0, 2.0, 0.0)),
                        _ => {}
                    }
                    k == 1
                },
            ),
        ];
        for (what, write) in cases {
            let mut world = PhysicsWorld::default();
            let (_, a) = world.insert(
                RigidBodyBuilder::fixed(),
                ColliderBuilder::cuboid(0.5, 0.1, 0.5),
            );
            let b = world.colliders.insert(
                ColliderBuilder::cuboid(0.5, 0.1, 0.5).translation(Vector::new(3.0, 0.0, 0.0)),
            );
            let reg = registry(&[a, b]);
            let mut index = GroundIndex::default();
            index.refresh(&reg, &world.bodies, &world.colliders, (DT, GAP), &|_| true);
            world.step();
            for k in 1..6 {
                if write(&mut world, a, b, k) {
                    index.note_relative_poses(&world.colliders);
                    world.integration_parameters.dt = 0.0;
                    world.step();
                    world.integration_parameters.dt = to_real(DT);
                    continue;
                }
                index.refresh(&reg, &world.bodies, &world.colliders, (DT, GAP), &|_| true);
                let planned = index.motions[0].pose0.translation.vector.y;
                world.step();
                let stepped = to_f64(world.colliders[a].translation().y);
                assert_eq!(planned, stepped, "{what}, step {k}");
            }
        }
    }

    #[test]
    fn a_moved_still_ground_is_found_where_it_now_is() {
        let mut world = PhysicsWorld::default();
        let a = world
            .colliders
            .insert(ColliderBuilder::cuboid(0.5, 0.1, 0.5));
        let b = world
            .colliders
            .insert(ColliderBuilder::cuboid(0.5, 0.1, 0.5).translation(Vector::new(3.0, 0.0, 0.0)));
        let reg = registry(&[a, b]);
        let mut index = GroundIndex::default();
        index.refresh(&reg, &world.bodies, &world.colliders, (DT, GAP), &|_| true);
        assert_eq!(near_at(&index, Vector::new(3.0, 0.2, 0.0)), vec![b]);
        world.colliders[b].set_translation(Vector::new(10.0, 0.0, 0.0));
        index.refresh(&reg, &world.bodies, &world.colliders, (DT, GAP), &|_| true);
        assert_eq!(near_at(&index, Vector::new(3.0, 0.2, 0.0)), vec![]);
        assert_eq!(near_at(&index, Vector::new(10.0, 0.2, 0.0)), vec![b]);
        assert_eq!(near_at(&index, Vector::new(0.0, 0.2, 0.0)), vec![a]);
    }

    #[test]
    fn a_kinematic_ground_disabled_and_enabled_again_is_found_again() {
        let mut world = PhysicsWorld::default();
        let (_, platform) = world.insert(
            RigidBodyBuilder::kinematic_velocity_based(),
            ColliderBuilder::cuboid(0.5, 0.1, 0.5),
        );
        let reg = registry(&[platform]);
        let mut index = GroundIndex::default();
        index.refresh(&reg, &world.bodies, &world.colliders, (DT, GAP), &|_| true);
        let above = Vector::new(0.0, 0.2, 0.0);
        assert_eq!(near_at(&index, above), vec![platform]);
        world.colliders[platform].set_enabled(false);
        index.refresh(&reg, &world.bodies, &world.colliders, (DT, GAP), &|_| true);
        assert_eq!(near_at(&index, above), vec![]);
        world.colliders[platform].set_enabled(true);
        index.refresh(&reg, &world.bodies, &world.colliders, (DT, GAP), &|_| true);
        assert_eq!(near_at(&index, above), vec![platform]);
        assert_eq!(index.moving(), &[0]);
    }

    #[test]
    fn a_half_space_given_a_box_shape_is_listed_once_as_a_box() {
        let mut world = PhysicsWorld::default();
        let ground = world.colliders.insert(ColliderBuilder::halfspace(
            crate::rapier::na::Unit::new_unchecked(Vector::Y),
        ));
        let reg = registry(&[ground]);
        let mut index = GroundIndex::default();
        index.refresh(&reg, &world.bodies, &world.colliders, (DT, GAP), &|_| true);
        // A half-space is everywhere below its plane.
        assert_eq!(
            near_at(&index, Vector::new(50.0, 0.05, -40.0)),
            vec![ground]
        );
        world.colliders[ground]
            .set_shape(crate::rapier::prelude::SharedShape::cuboid(1.0, 0.1, 1.0));
        index.refresh(&reg, &world.bodies, &world.colliders, (DT, GAP), &|_| true);
        assert_eq!(near_at(&index, Vector::new(50.0, 0.05, -40.0)), vec![]);
        assert_eq!(near_at(&index, Vector::new(0.0, 0.15, 0.0)), vec![ground]);
    }

    /// A still half-space's kept world normal stands only for the shape's normal it was
    /// computed from, to the bit: a zero component edited in place to `-0.0` (equal as a
    /// float, not as bits) is computed again, as the contact query computes it, which a
    /// rotation with a negative scalar part turns into a different sign of zero.
    #[test]
    fn a_half_spaces_kept_normal_answers_for_its_own_normal_bits_only() {
        let mut world = PhysicsWorld::default();
        let turn = crate::rapier::math::Rotation::from_xyzw(0.0, -0.0, -0.0, -1.0);
        let ground = world.colliders.insert(
            ColliderBuilder::new(crate::rapier::prelude::SharedShape::halfspace(Vector::Y))
                .position(Pose::from_parts(Vector::ZERO, turn)),
        );
        let co = &world.colliders[ground];
        let motion = motion_of(ground, (co, *co.position()), &world.bodies, DT, GAP).unwrap();
        let bits = |n: Vector3<f64>| n.map(f64::to_bits);
        let kept = motion.still_unit_normal(Vector::Y).map(bits);
        assert_eq!(
            kept,
            half_space_unit_normal(&motion.pose0, Vector::Y).map(bits)
        );
        let edited = Vector::new(-0.0, 1.0, -0.0);
        let fresh = half_space_unit_normal(&motion.pose0, edited).map(bits);
        assert_ne!(fresh, kept, "the edit changes the computed normal's bits");
        assert_eq!(motion.still_unit_normal(edited), None);
    }

    #[test]
    fn a_ground_on_a_body_turned_dynamic_or_removed_is_no_longer_found() {
        let mut world = PhysicsWorld::default();
        let (body, ground) = world.insert(
            RigidBodyBuilder::fixed(),
            ColliderBuilder::cuboid(0.5, 0.1, 0.5),
        );
        let other = world
            .colliders
            .insert(ColliderBuilder::cuboid(0.5, 0.1, 0.5).translation(Vector::new(3.0, 0.0, 0.0)));
        let reg = registry(&[ground, other]);
        let mut index = GroundIndex::default();
        index.refresh(&reg, &world.bodies, &world.colliders, (DT, GAP), &|_| true);
        let above = Vector::new(0.0, 0.2, 0.0);
        assert_eq!(near_at(&index, above), vec![ground]);
        world.bodies[body].set_body_type(RigidBodyType::Dynamic, true);
        index.refresh(&reg, &world.bodies, &world.colliders, (DT, GAP), &|_| true);
        assert_eq!(near_at(&index, above), vec![]);
        world.colliders.remove(
            other,
            &mut world.islands,
            &mut world.bodies,
            &mut world.soft_bodies,
            true,
        );
        index.refresh(&reg, &world.bodies, &world.colliders, (DT, GAP), &|_| true);
        assert_eq!(near_at(&index, Vector::new(3.0, 0.2, 0.0)), vec![]);
    }

    /// The first-impact search skips a ground by its box only where the box holds it at
    /// every instant: a bar turning through the step sweeps outside the boxes of its poses
    /// at the step's ends, and a ball 1 mm from its tip at mid-step is found beside a far
    /// second ground as it is with the bar alone. A still tile's bound stays below its gap.
    #[test]
    fn the_first_impact_search_skips_only_grounds_its_box_holds() {
        use crate::motion::State;
        use crate::plugin::queries::geometry::{GroundGeom, closest};
        use crate::plugin::queries::observe::{body_geom, ground_geom};
        use crate::rapier::prelude::RigidBodyType;
        let mut world = PhysicsWorld::default();
        let spin = 24.0;
        // A 2 m bar along y, turning about x, upright at mid-step.
        let tilt = -0.5 * spin * DT;
        let (_, bar) = world.insert(
            RigidBodyBuilder::new(RigidBodyType::KinematicVelocityBased)
                .rotation(Vector::new(to_real(tilt), 0.0, 0.0))
                .angvel(Vector::new(to_real(spin), 0.0, 0.0)),
            ColliderBuilder::cuboid(0.005, 1.0, 0.005),
        );
        let far = world.colliders.insert(
            ColliderBuilder::cuboid(0.5, 0.1, 0.5).translation(Vector::new(10.0, 0.0, 0.0)),
        );
        let (radius, gap) = (0.1, 0.001);
        let (ball, _) = world.insert(
            RigidBodyBuilder::dynamic().translation(Vector::new(
                0.0,
                to_real(1.0 + radius + gap),
                0.0,
            )),
            ColliderBuilder::ball(to_real(radius)),
        );
        let reg = registry(&[bar, far]);
        let mut index = GroundIndex::default();
        index.refresh(&reg, &world.bodies, &world.colliders, (DT, GAP), &|_| true);
        let geoms: Vec<GroundGeom> = index
            .motions
            .iter()
            .map(|m| ground_geom(m, &world.colliders).unwrap())
            .collect();
        let rb = &world.bodies[ball];
        let geom = body_geom(rb, &world.colliders, &Vector3::zeros());
        let s = State {
            com: Vector3::new(0.0, 1.0 + radius + gap, 0.0),
            rot: UnitQuaternion::identity(),
            v: Vector3::zeros(),
            w: Vector3::zeros(),
        };
        let hit = |grounds: &[GroundGeom]| {
            closest(&geom, grounds, &s, 0.5 * DT, 0.002).map(|h| (grounds[h.ground].handle, h.dist))
        };
        let bar_only: Vec<GroundGeom> = index.motions[..1]
            .iter()
            .map(|m| ground_geom(m, &world.colliders).unwrap())
            .collect();
        assert_eq!(bar_only[0].handle, bar);
        let alone = hit(&bar_only).expect("the bar alone is found");
        assert_eq!(alone.0, bar);
        assert!((alone.1 - gap).abs() < 1e-4, "gap {}", alone.1);
        assert_eq!(hit(&geoms), Some(alone));
        // The still tile: its bound stays at or below the gap the query finds, above, beside
        // and in its corner (alone, `closest` queries it without the bound).
        let tile = geoms.iter().find(|g| g.handle == far).unwrap();
        for (x, y) in [(10.0, 0.2 + gap), (10.6 + gap, 0.0), (10.55, 0.15)] {
            let centre = Vector3::new(x, y, 0.0);
            let state = State { com: centre, ..s };
            let found = closest(&geom, std::slice::from_ref(tile), &state, 0.0, 1.0).unwrap();
            assert!(
                tile.gap_bound(&centre, radius) <= found.dist,
                "at ({x}, {y})"
            );
        }
    }
}
