//! Observe: what the step reads of rapier, in `f64`, before anything is decided or written.
//!
//! Contract: every function here reads rapier's sets (and the plugin's own memory of what it
//! wrote, [`Shadow`]) and writes nothing. A body's start-of-step state and flight
//! ([`snapshot`]), its colliders in its centre-of-mass frame ([`body_geom`]), a ground's
//! geometry for the queries ([`ground_geom`]), the cheap far-from-every-ground test
//! ([`surely_far`]), and what touches a body besides its grounds in rapier's contact graph
//! ([`non_ground_contacts`], [`touches_other`]).

use crate::motion::{Flight, Gyro, State};
use crate::plugin::bridge::convert::{rot_to_na, to_f64, to_real, vec_to_na};
use crate::plugin::policy::LOADED_COS;
use crate::plugin::policy::{
    CENTRED_TOLERANCE, FAR_TEST_GROWTH, FAR_TEST_MARGIN, SPIN_UP_ALLOWANCE,
};
use crate::plugin::queries::geometry::{BodyGeom, BodyPart, GroundGeom};
use crate::plugin::queries::ground_index::{GroundEntry, GroundIndex, GroundMotion};
use crate::plugin::state::handles::HandleMap;
use crate::plugin::state::memory::Shadow;
use crate::plugin::state::registry::Registry;
use crate::plugin::state::small_list::SmallList;
use crate::plugin::state::writes::{Now, Writes};
use crate::rapier::math::{Real, Rotation, Vector};
use crate::rapier::prelude::{
    ActiveHooks, ColliderHandle, ColliderSet, ContactManifold, ContactPair, ImpulseJointSet,
    LockedAxes, MultibodyJointSet, NarrowPhase, RigidBody, RigidBodyHandle, RigidBodySet,
    SolverFlags,
};
use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};

/// The cheap test before any snapshot or geometry, in rapier's precision from what rapier
/// holds: `Some(true)` when the body's swept bounding sphere, grown beyond the one
/// [`ImpactPlugin::before_step`] tests (speed bounds over the step, a relative `1e-4` for
/// rounding and the `f64` shadow), misses every ground's AABB, so that test would find no
/// ground near either; `None` when the body has no collider to query (as [`body_geom`]).
///
/// [`ImpactPlugin::before_step`]: crate::plugin::impact_plugin::ImpactPlugin::before_step
pub(crate) fn surely_far(
    rb: &RigidBody,
    colliders: &ColliderSet,
    gravity: Real,
    dt: Real,
    margin: Real,
    index: &GroundIndex,
    grounds: &[GroundMotion],
) -> Option<bool> {
    let local_com = rb.local_center_of_mass();
    let mut radius: Option<Real> = None;
    for ch in rb.colliders() {
        let Some(co) = colliders.get(*ch) else {
            continue;
        };
        if !co.is_enabled() || co.is_sensor() {
            continue;
        }
        let bs = co.shape().compute_local_bounding_sphere();
        let center = match co.position_wrt_parent() {
            Some(pose) if bs.center == Vector::ZERO => pose.translation,
            Some(pose) => pose.transform_point(bs.center),
            None => bs.center,
        };
        let r = (center - local_com).length() + bs.radius + co.contact_skin();
        radius = Some(radius.map_or(r, |x| x.max(r)));
    }
    let radius = radius?;
    let com = rb.center_of_mass();
    let (v, w, force) = (rb.linvel(), rb.angvel(), rb.user_force());
    let mut accel = gravity * rb.gravity_scale().abs();
    if force != Vector::ZERO {
        accel += force.length() / rb.mass();
    }
    let mut speed = v.length() + accel * dt;
    if w != Vector::ZERO {
        // Torque-free motion speeds an anisotropic body's spin up by at most I_max / I_min.
        let inv = rb.mass_properties().local_mprops.inv_principal_inertia;
        let spin_up = if inv.is_finite() && inv.min_element() > 0.0 {
            to_real(SPIN_UP_ALLOWANCE) * inv.max_element() / inv.min_element()
        } else {
            1.0
        };
        speed += spin_up * w.length() * radius;
    }
    let half = (radius + speed * dt + margin) * to_real(FAR_TEST_GROWTH)
        + to_real(FAR_TEST_MARGIN) * (1.0 + com.abs().max_element() + local_com.length());
    if !half.is_finite() || !com.is_finite() {
        return Some(false);
    }
    Some(!index.any_near(grounds, com, half))
}

/// The start-of-step state of a body: its `f64` shadow if rapier still holds exactly what
/// the plugin wrote, else rapier's values.
pub(crate) fn snapshot(
    now: &Now,
    gravity: Vector3<f64>,
    dt: f64,
    shadow: Option<&Shadow>,
) -> (State, Flight, Vector3<f64>) {
    let rb = now.rb();
    let local_com = vec_to_na(rb.local_center_of_mass());
    let mut state = now.state();
    if let Some(sh) = shadow {
        if sh.held_by(now) {
            state.com = sh.com;
            state.v = sh.v;
            // The spin too, where rapier left it as written (its gyroscopic step changes an
            // anisotropic body's).
            if sh.written_angvel == now.angvel() {
                state.w = sh.w;
            }
        }
    }
    let mass = to_f64(rb.mass());
    let flight = Flight {
        accel: gravity * to_f64(rb.gravity_scale()) + vec_to_na(rb.user_force()) / mass,
        linear_damping: to_f64(rb.linear_damping()).max(0.0),
        angular_damping: to_f64(rb.angular_damping()).max(0.0),
        gyro: gyro_of(rb, dt).map(Box::new),
    };
    (state, flight, local_com)
}

/// The torque-free rotation of a body, as rapier treats it: `None` (constant-axis spin)
/// when rapier's gyroscopic forces are off for the body (it then keeps `w` constant in
/// flight), a rotation axis is locked, or the inertia is isotropic.
pub(crate) fn gyro_of(rb: &RigidBody, dt: f64) -> Option<Gyro> {
    if !rb.gyroscopic_forces_enabled() || rb.locked_axes().intersects(LockedAxes::ROTATION_LOCKED) {
        return None;
    }
    let mp = &rb.mass_properties().local_mprops;
    let raw = mp.inv_principal_inertia;
    // Isotropic inertia (every ball): constant-axis spin, nothing to set up.
    if raw.x == raw.y && raw.y == raw.z {
        return None;
    }
    let inv = vec_to_na(raw);
    Gyro::new(
        inv.map(|x| 1.0 / x),
        rot_to_na(mp.principal_inertia_local_frame),
        dt,
    )
}

/// The body's enabled, non-sensor colliders in its centre-of-mass frame.
pub(crate) fn body_geom<'a>(
    rb: &RigidBody,
    colliders: &'a ColliderSet,
    local_com: &Vector3<f64>,
) -> BodyGeom<'a> {
    let mut parts = SmallList::Empty;
    let mut radius: f64 = 0.0;
    for ch in rb.colliders() {
        let Some(co) = colliders.get(*ch) else {
            continue;
        };
        if !co.is_enabled() || co.is_sensor() {
            continue;
        }
        // The collider's pose in the body's centre-of-mass frame: its pose in the body's
        // frame, shifted by the centre of mass (no rotation between the two frames).
        let local = match co.position_wrt_parent() {
            Some(pose) => {
                // A collider not turned on its body (most): its rotation in `f64` is the
                // identity, bit for bit what `rot_to_na` renormalises it to (a norm of 1),
                // taken without the square root and divisions.
                let unturned = pose.rotation.to_array().map(Real::to_bits)
                    == Rotation::IDENTITY.to_array().map(Real::to_bits);
                let rotation = if unturned {
                    UnitQuaternion::identity()
                } else {
                    rot_to_na(pose.rotation)
                };
                Isometry3::from_parts(
                    Translation3::from(vec_to_na(pose.translation) - local_com),
                    rotation,
                )
            }
            None => {
                Isometry3::from_parts(Translation3::from(-local_com), UnitQuaternion::identity())
            }
        };
        let bs = co.shape().compute_local_bounding_sphere();
        let center = if bs.center == Vector::ZERO {
            local.translation.vector
        } else {
            (local * nalgebra::Point3::from(vec_to_na(bs.center))).coords
        };
        let skin = to_f64(co.contact_skin());
        radius = radius.max(center.norm() + to_f64(bs.radius) + skin);
        parts.push(BodyPart {
            handle: *ch,
            shape: co.shape(),
            local,
            skin,
        });
    }
    BodyGeom { parts, radius }
}

/// The body's state as rapier holds it, in `f64`.
pub(crate) fn rapier_state(rb: &RigidBody) -> State {
    State {
        com: vec_to_na(rb.center_of_mass()),
        rot: rot_to_na(*rb.rotation()),
        v: vec_to_na(rb.linvel()),
        w: vec_to_na(rb.angvel()),
    }
}

/// Is the part a ball centred on the body's centre of mass (it cannot swing about a
/// contact)?
///
/// Inlined: the plan asks it of every body near a ground.
#[inline]
pub(crate) fn centred_ball(part: &BodyPart) -> bool {
    part.shape
        .as_ball()
        .is_some_and(|b| centred(&part.local.translation.vector, to_f64(b.radius)))
}

/// Is a ball of `radius` whose centre lies `offset` from the body's centre of mass centred
/// on it (to rounding of the body frame's coordinates)?
pub(crate) fn centred(offset: &Vector3<f64>, radius: f64) -> bool {
    offset.norm() <= CENTRED_TOLERANCE * radius
}

/// Does a body meet a slab's tiles one by one rather than the slab (`GroundIndex`)? When it
/// has a joint (`jointed`: a joint may disable its contacts with one tile's body), or one of
/// its `parts` asks for the user's contact filter (`user_flags`: the filter may refuse its
/// pair with one tile).
pub(crate) fn meets_tiles(
    jointed: bool,
    parts: &[BodyPart],
    user_flags: impl Fn(ColliderHandle) -> ActiveHooks,
) -> bool {
    jointed
        || parts
            .iter()
            .any(|part| user_flags(part.handle).contains(ActiveHooks::FILTER_CONTACT_PAIRS))
}

/// A ground's geometry for the queries, if its collider still exists (a slab's: the box of
/// its tiles, with its first tile's skin).
///
/// Inlined: the plan asks it of every body near a ground.
#[inline]
pub(crate) fn ground_geom<'a>(
    gm: &'a GroundMotion,
    colliders: &'a ColliderSet,
) -> Option<GroundGeom<'a>> {
    let co = colliders.get(gm.handle)?;
    Some(GroundGeom {
        handle: gm.handle,
        shape: match &gm.slab {
            Some(slab) => slab,
            None => co.shape(),
        },
        skin: to_f64(co.contact_skin()),
        motion: gm,
        skip: Vec::new(),
    })
}

/// Does rapier's solver hold `body` in contact with anything but `partner` after the last
/// step, a ground included (a die lying on the table, a pin standing on the lane), or has it
/// a joint? Such a body cannot be moved alone through an impact with `partner`, and its pair
/// with it is left to rapier (`pair_plan.rs`).
pub(crate) fn held_besides(
    body: RigidBodyHandle,
    rb: &RigidBody,
    partner: ColliderHandle,
    sets: &Sets,
) -> bool {
    solver_contact_besides(body, rb, Some(partner), sets, |_| true)
}

/// Was the body pushed, by rapier's solver in the last step, by anything but a ground and
/// the collider `partner` (a ball's pair partner, if any), or does it have a joint? What
/// presses a pair of balls is a third body; a speculative contact that stayed open (zero
/// impulse, a ball lying a few millimetres from the next one) presses nothing.
pub(crate) fn pressed_besides(
    body: RigidBodyHandle,
    rb: &RigidBody,
    partner: Option<ColliderHandle>,
    sets: &Sets,
    registry: &Registry,
) -> bool {
    sets.jointed(body)
        || any_pair(rb, sets.narrow_phase, |other, pair| {
            Some(other) != partner && registry.entry(other).is_none() && pushes(pair)
        })
}

/// Did rapier's solver, in the last step, push the body through a contact with a body that
/// is neither a ground nor `partner`, along gravity's line (within [`LOADED_COS`] of `down`:
/// something lies on it; or of up: it lies on something)? Such a body is part of a stack or a
/// pile: rapier's solver will push it again in the step, so it cannot be moved alone through
/// an impact with `partner`. Balls side by side (a cradle on a table) push each other
/// sideways, and a speculative contact that stayed open pushes nothing. Without gravity
/// (`down` zero) nothing stacks.
pub(crate) fn stacked_besides(
    rb: &RigidBody,
    partner: ColliderHandle,
    sets: &Sets,
    registry: &Registry,
    down: &Vector3<f64>,
) -> bool {
    if *down == Vector3::zeros() {
        return false;
    }
    any_pair(rb, sets.narrow_phase, |other, pair| {
        if other == partner || registry.entry(other).is_some() {
            return false;
        }
        // rapier pushes the first collider's body along -normal, the second's along +normal.
        let sign = if pair.collider1 == other { 1.0 } else { -1.0 };
        solver_manifolds(pair)
            .iter()
            .filter(|m| solved(m) && m.points.iter().any(|p| p.data.impulse != 0.0))
            .any(|m| (vec_to_na(m.data.normal) * sign).dot(down).abs() > LOADED_COS)
    })
}

/// Did the body touch, in rapier's solver after the last step, anything but a ground, or
/// does it have a joint? [`pressed_besides`] without a partner: the walk stops at the first
/// contact.
pub(crate) fn touched_besides_grounds(
    body: RigidBodyHandle,
    rb: &RigidBody,
    sets: &Sets,
    registry: &Registry,
) -> bool {
    solver_contact_besides(body, rb, None, sets, |other| {
        registry.entry(other).is_none()
    })
}

/// Has the body a joint, or a pair in rapier's solver after the last step (solver contacts
/// with rigid impulses) with a collider other than `partner` that `counts`?
fn solver_contact_besides(
    body: RigidBodyHandle,
    rb: &RigidBody,
    partner: Option<ColliderHandle>,
    sets: &Sets,
    counts: impl Fn(ColliderHandle) -> bool,
) -> bool {
    sets.jointed(body)
        || any_pair(rb, sets.narrow_phase, |other, pair| {
            Some(other) != partner && counts(other) && in_solver(pair)
        })
}

/// Does any of rapier's contact pairs of the body's colliders pass `test` (given the other
/// collider and the pair)?
fn any_pair(
    rb: &RigidBody,
    narrow_phase: &NarrowPhase,
    test: impl Fn(ColliderHandle, &ContactPair) -> bool,
) -> bool {
    rb.colliders().iter().any(|ch| {
        narrow_phase
            .contact_pairs_with(*ch)
            .any(|pair| test(other_collider(pair, *ch), pair))
    })
}

/// The collider of the pair that is not `own`.
fn other_collider(pair: &ContactPair, own: ColliderHandle) -> ColliderHandle {
    if pair.collider1 == own {
        pair.collider2
    } else {
        pair.collider1
    }
}

/// The pair's manifolds as rapier's solver saw them: rapier's `ContactPair::solver_manifolds`,
/// taken through the two accessors it is made of, which are inlined here where it is a call
/// (the walks ask it of every pair they meet); a pair of two soft surfaces has none.
fn solver_manifolds(pair: &ContactPair) -> &[ContactManifold] {
    pair.rigid().map_or(&[], |rigid| rigid.solver_manifolds())
}

/// Has the pair solver contacts with rigid impulses (rapier's solver holds it)?
fn in_solver(pair: &ContactPair) -> bool {
    solver_manifolds(pair).iter().any(solved)
}

/// Has the manifold solver contacts with rigid impulses?
///
/// The count of solver contacts is read first: most manifolds walked have none (a neighbour
/// within the broad phase's margin but beyond rapier's prediction distance outnumbers the
/// pairs the hooks take out of the solver, whose contacts rapier still makes), and in
/// rapier 0.36's `ContactManifold` it lies by the points' pointer, which a solved manifold's
/// impulses are read through, while the flags mostly lie on another cache line.
fn solved(m: &ContactManifold) -> bool {
    !m.data.solver_contacts.is_empty()
        && m.data
            .solver_flags
            .contains(SolverFlags::COMPUTE_RIGID_IMPULSES)
}

/// Does the body have a contact in rapier's solver this step (other than the pairs taken
/// from it)?
pub(crate) fn touches_other(rb: &RigidBody, narrow_phase: &NarrowPhase) -> bool {
    rb.colliders()
        .iter()
        .any(|ch| narrow_phase.contact_pairs_with(*ch).any(in_solver))
}

/// Did rapier's solver push the body in the step through a contact it kept (a pair the plugin
/// did not take out of the solver)? A speculative contact that stayed open has zero impulse.
pub(crate) fn pushed_by_other(rb: &RigidBody, narrow_phase: &NarrowPhase) -> bool {
    rb.colliders()
        .iter()
        .any(|ch| narrow_phase.contact_pairs_with(*ch).any(pushes))
}

/// Did rapier's solver push the body in the step through a contact it kept, or does it hold
/// the body in any contact, even a speculative one that stayed open, with a collider that
/// `looked_for` does not cover (one the caller cannot see the body reach)?
pub(crate) fn held_or_by_unseen(
    rb: &RigidBody,
    narrow_phase: &NarrowPhase,
    looked_for: impl Fn(ColliderHandle) -> bool,
) -> bool {
    // The other collider is read only for an open pair: the pair's handles mostly lie on
    // another cache line of rapier's graph edge than what the walk and the manifolds read.
    rb.colliders().iter().any(|ch| {
        narrow_phase
            .contact_pairs_with(*ch)
            .any(|pair| match solver_part(pair) {
                SolverPart::Pushed => true,
                SolverPart::Open => !looked_for(other_collider(pair, *ch)),
                SolverPart::Out => false,
            })
    })
}

/// A contact pair's part in rapier's solver in its last step, read in one pass over its
/// manifolds: [`pushes`] asks for `Pushed`; [`in_solver`] holds for `Open` and `Pushed`.
#[derive(Clone, Copy, PartialEq, Eq)]
enum SolverPart {
    /// No solver contact with rigid impulses.
    Out,
    /// Solver contacts, every impulse zero (a speculative contact that stayed open).
    Open,
    /// A solver contact with a nonzero impulse.
    Pushed,
}

/// The pair's [`SolverPart`].
fn solver_part(pair: &ContactPair) -> SolverPart {
    let mut part = SolverPart::Out;
    for m in solver_manifolds(pair).iter().filter(|m| solved(m)) {
        if m.points.iter().any(|p| p.data.impulse != 0.0) {
            return SolverPart::Pushed;
        }
        part = SolverPart::Open;
    }
    part
}

/// Did rapier's solver push the pair apart in its last step (a solver contact with a nonzero
/// impulse)?
fn pushes(pair: &ContactPair) -> bool {
    solver_part(pair) == SolverPart::Pushed
}

/// What touches a body besides its grounds, from rapier's contact graph after a step.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(crate) struct NonGround {
    /// A pair with something other than a ground (another body, a wall) with solver contacts.
    pub touching: bool,
    /// One of those contacts pushes the body within 60 degrees of `down` (something lies on
    /// it), or any does without gravity (`down` zero). Balls side by side or a wall push it
    /// sideways or up.
    pub loaded: bool,
}

impl NonGround {
    /// A body with a joint: treated as touched and loaded.
    pub const JOINTED: Self = Self {
        touching: true,
        loaded: true,
    };
}

/// The body's pairs with colliders that are not grounds, in rapier's narrow phase after a step
/// (see [`NonGround`]), walked until something is found lying on it.
fn non_ground_contacts(
    rb: &RigidBody,
    narrow_phase: &NarrowPhase,
    index: &GroundIndex,
    grounds: &HandleMap<ColliderHandle, GroundEntry>,
    down: &Vector3<f64>,
) -> NonGround {
    let is_ground = |c: &ColliderHandle| {
        index
            .entry(*c)
            .map_or_else(|()| grounds.contains_key(c), |e| e.is_some())
    };
    let mut found = NonGround::default();
    for ch in rb.colliders() {
        for pair in narrow_phase.contact_pairs_with(*ch) {
            let (other, first) = if pair.collider1 == *ch {
                (pair.collider2, true)
            } else {
                (pair.collider1, false)
            };
            if is_ground(&other) {
                continue;
            }
            for m in solver_manifolds(pair).iter().filter(|m| solved(m)) {
                found.touching = true;
                // rapier pushes the first collider's body along -normal, the second's along
                // +normal.
                let normal = vec_to_na(m.data.normal);
                let push = if first { -normal } else { normal };
                if *down == Vector3::zeros() || push.dot(down) > LOADED_COS {
                    found.loaded = true;
                    return found;
                }
            }
        }
    }
    found
}

/// rapier's contact graph and joints, as the step's decisions read them.
#[derive(Clone, Copy)]
pub(crate) struct Sets<'a> {
    pub narrow_phase: &'a NarrowPhase,
    pub impulse_joints: &'a ImpulseJointSet,
    pub multibody_joints: &'a MultibodyJointSet,
}

impl<'a> Sets<'a> {
    /// Has `body` a joint (an impulse joint attached, or a link of a multibody)?
    ///
    /// Inlined: the plan asks it of every body near a ground.
    #[inline]
    pub fn jointed(&self, body: RigidBodyHandle) -> bool {
        self.impulse_joints.attached_joints(body).next().is_some()
            || self.multibody_joints.rigid_body_link(body).is_some()
    }

    pub fn new(
        narrow_phase: &'a NarrowPhase,
        impulse_joints: &'a ImpulseJointSet,
        multibody_joints: &'a MultibodyJointSet,
    ) -> Self {
        Self {
            narrow_phase,
            impulse_joints,
            multibody_joints,
        }
    }
}

/// What touches the body besides its grounds in rapier's contact graph as the last
/// step left it (the same graph between `after_step` and the next `before_step`): asked
/// only where a decision needs it, so a step costs nothing for the bodies that need none.
pub(crate) fn neighbours(
    body: RigidBodyHandle,
    rb: &RigidBody,
    sets: &Sets,
    registry: &Registry,
    down: &Vector3<f64>,
) -> NonGround {
    let jointed = sets.jointed(body);
    if jointed {
        return NonGround::JOINTED;
    }
    non_ground_contacts(
        rb,
        sets.narrow_phase,
        &registry.index,
        &registry.grounds,
        down,
    )
}

/// What a decision before rapier's step reads of the world: rapier's bodies, colliders,
/// contact graph and joints, and the plugin's registry (which colliders are grounds). Read
/// only.
#[derive(Clone, Copy)]
pub(crate) struct Scene<'s> {
    pub bodies: &'s RigidBodySet,
    pub colliders: &'s ColliderSet,
    pub sets: &'s Sets<'s>,
    pub registry: &'s Registry,
    /// The grounds' motions over the step (`StepData::grounds`).
    pub grounds: &'s [GroundMotion],
    /// The writes recorded so far in the step (a body is read as they leave it).
    pub writes: &'s Writes,
}
