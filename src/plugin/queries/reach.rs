//! Reach: can anything besides a rolling ball's grounds touch it within the step?
//!
//! Contract: [`within_reach_of_other`] reads rapier's contact graph, colliders and bodies (each
//! body as the step's writes so far leave it) and writes nothing of rapier's or the plugin's
//! state besides its own memo. What it reads of a neighbouring ball ([`Neighbour`]: its place,
//! its size, how fast its body can close on anything) is the same for every ball it
//! neighbours, so it is read once a plan and kept in [`NeighbourReads`] until the plan ends or
//! its body is written again (a `Step` impulse of an earlier body's plan); the bound each ball
//! then draws from it is the one read afresh would give, to the bit. A ground (a floor under
//! every ball) is skipped before it is read; any other shape (a wall) is read afresh each
//! time. Two balls are first held to the sum of how far each can move in the step in any
//! direction ([`closing_bound_of_reaches`], never below the exact bound along their line of
//! centres): a neighbour beyond it is beyond the exact bound too, so the answer is the exact
//! test's, and most neighbours of a rolling ball are settled so.

use crate::parry::query;
use crate::parry::shape::Ball;
use crate::plugin::bridge::convert::{to_f64, vec_to_na};
use crate::plugin::policy::SPIN_UP_ALLOWANCE;
use crate::plugin::queries::observe::Scene;
use crate::plugin::state::handles::slot_of;
use crate::plugin::state::writes::Writes;
use crate::rapier::math::{Real, Vector};
use crate::rapier::prelude::{Collider, ColliderHandle, RigidBody, RigidBodyHandle};
use nalgebra::Vector3;

/// A centred ball's motion over the step `dt` as [`within_reach_of_other`] bounds it: its
/// velocity (m/s), its acceleration in flight (`accel`: gravity and the user's force over its
/// mass), and what its ground adds to that: a push along the ground's `normal` of `pressed`
/// (m/s^2), and a drag of at most `dragged` (m/s^2) against one of the unit directions
/// `drag_along` (on level ground: friction against the slip, whose direction stays, then
/// rolling resistance against the motion), or in any direction (`None`: on a slope the ball's
/// path curves).
#[derive(Clone, Copy, Debug)]
pub(crate) struct OwnMotion {
    pub v: Vector3<f64>,
    pub accel: Vector3<f64>,
    pub normal: Vector3<f64>,
    pub pressed: f64,
    pub dragged: f64,
    pub drag_along: Option<[Vector3<f64>; 2]>,
    /// The world's gravity (m/s^2), which the other body feels times its gravity scale.
    pub gravity: Vector3<f64>,
    /// The step (s).
    pub dt: f64,
}

/// How fast a collider's surface can move over the step, from its body's motion: what
/// [`closing_bound`] needs of the other side of a pair, whoever the ball on this side is.
#[derive(Clone, Copy, Debug)]
enum OtherMotion {
    /// A collider without a body: it stays where it is.
    Still,
    /// A collider of a body (a value that is not finite makes the bound infinite).
    Body {
        /// Its body's linear velocity (m/s).
        linvel: Vector3<f64>,
        /// How fast turning moves its surface (m/s): spin times the surface's distance from
        /// the centre of mass, grown for an anisotropic body's spin-up and a user torque.
        turn: f64,
        /// A dynamic body's acceleration in flight (gravity times its scale and the user's
        /// force over its mass; m/s^2); `None` for a body that does not fall.
        accel: Option<Vector3<f64>>,
        /// A position-based kinematic body's centre-of-mass shift to its next pose over the
        /// step (m/s), whatever its velocity.
        kinematic_shift: Option<f64>,
    },
}

/// The rolling ball's collider as its plan holds it (rapier's collider of `handle` and its
/// ball), which the test then takes rather than looking it up again.
#[derive(Clone, Copy)]
pub(crate) struct OwnCollider<'c> {
    pub handle: ColliderHandle,
    pub collider: &'c Collider,
    pub ball: &'c Ball,
}

/// A ball of rapier's contact graph as the reach test reads it.
#[derive(Clone, Copy, Debug)]
struct Neighbour {
    handle: ColliderHandle,
    /// Its body, if it has one that exists.
    body: Option<RigidBodyHandle>,
    /// Its body's write mark when it was read (`Writes::mark`; 0 without a body).
    mark: u32,
    enabled: bool,
    skin: Real,
    translation: Vector,
    radius: Real,
    motion: OtherMotion,
    /// Its side of [`closing_bound_of_reaches`]: how far its surface can move in the step,
    /// whatever the direction.
    reach: f64,
}

/// A collider of rapier's contact graph, as [`NeighbourReads::read`] gives it.
enum Read<'n, 'c> {
    /// A ball, as this plan reads it.
    Ball(&'n Neighbour),
    /// Any other shape but a ground's (a wall), read afresh and not kept.
    Other(&'c Collider),
}

/// The balls read in this plan (see the module's contract), found by collider slot. Kept by
/// the plugin across steps for its storage only: each plan starts empty. Its size follows the
/// balls read in a plan, and 4 bytes a collider slot.
#[derive(Default)]
pub(crate) struct NeighbourReads {
    /// The balls read in this plan, in the order read.
    read: Vec<Neighbour>,
    /// By collider slot: where in `read` that slot's ball is, if it was read in this plan.
    by_slot: Vec<u32>,
    /// The plan's world gravity (m/s^2) and step (s), which a neighbour's motion is read with.
    gravity: Vector3<f64>,
    dt: f64,
}

impl NeighbourReads {
    /// A new plan, of a step of `dt` (s) under the world's `gravity` (m/s^2): every neighbour
    /// is read afresh.
    pub fn begin_plan(&mut self, gravity: Vector3<f64>, dt: f64) {
        (self.gravity, self.dt) = (gravity, dt);
        self.read.clear();
    }

    /// The collider `handle`: a ball as this plan reads it (its motion as the writes so far
    /// leave its body), looked up by slot once read; any other shape from rapier's set;
    /// `None` if it no longer exists.
    fn read<'n, 'c>(
        &'n mut self,
        handle: ColliderHandle,
        scene: &Scene<'c>,
    ) -> Option<Read<'n, 'c>> {
        let slot = slot_of(handle);
        // Its entry in this plan, if it has one (an index left from an earlier plan points
        // past `read`'s end or to another collider).
        let entry = self
            .by_slot
            .get(slot)
            .map(|k| *k as usize)
            .filter(|k| self.read.get(*k).is_some_and(|n| n.handle == handle));
        let fresh = entry.filter(|k| {
            let n = &self.read[*k];
            n.mark == n.body.map_or(0, |b| scene.writes.mark(b))
        });
        if let Some(k) = fresh {
            return Some(Read::Ball(&self.read[k]));
        }
        let oc = scene.colliders.get(handle)?;
        let Some(radius) = oc.shape().as_ball().map(|b| b.radius) else {
            return Some(Read::Other(oc));
        };
        let body = oc.parent().and_then(|p| Some((p, scene.bodies.get(p)?)));
        let motion = other_motion(oc, true, body, (self.gravity, self.dt), scene.writes);
        let neighbour = Neighbour {
            handle,
            body: body.map(|(p, _)| p),
            mark: body.map_or(0, |(p, _)| scene.writes.mark(p)),
            enabled: oc.is_enabled(),
            skin: oc.contact_skin(),
            translation: oc.position().translation,
            radius,
            motion,
            reach: motion.reach(self.dt),
        };
        // Read again after a write to its body: in place.
        let k = match entry {
            Some(k) => {
                self.read[k] = neighbour;
                k
            }
            None => {
                if slot >= self.by_slot.len() {
                    self.by_slot.resize(slot + 1, u32::MAX);
                }
                self.by_slot[slot] = self.read.len() as u32;
                self.read.push(neighbour);
                self.read.len() - 1
            }
        };
        Some(Read::Ball(&self.read[k]))
    }
}

/// Can a collider besides the body's grounds touch it within the step? rapier's broad phase
/// pairs a body with everything whose fattened bounding box overlaps its own (up to about
/// 10 cm apart at rapier's default length unit), and its narrow phase makes speculative
/// solver contacts up to its prediction distance (2 cm) apart, which push nothing unless the
/// two close: neither says the two touch. For each such pair: the gap between the two
/// colliders now, against how far the two can close in the step ([`closing_bound`]). The
/// pairs are rapier's as its last step's start found them: a body more than about 10 cm away
/// then, that closes that much in two steps, is not seen (it meets the ball as it would
/// under rapier alone, a step late, and the ball is rapier's from the next step). What a third
/// body does to the other one during the step is not bounded either: the reconstruct stage
/// reads rapier's contact impulses after the step
/// ([`pushed_by_other`](crate::plugin::queries::observe::pushed_by_other)). For a centred ball
/// (`rb` must be one, `ball_collider` its collider as the caller holds it: its own spin is not
/// counted); a pair parry cannot measure, and any joint (`jointed`: the body has one, as
/// `Sets::jointed` says), is within reach.
pub(crate) fn within_reach_of_other(
    rb: &RigidBody,
    ball_collider: OwnCollider,
    jointed: bool,
    own: &OwnMotion,
    scene: &Scene,
    neighbours: &mut NeighbourReads,
) -> bool {
    let Scene {
        colliders,
        sets,
        registry,
        ..
    } = *scene;
    // The memo's motions are read with the plan's gravity and step, which every ball shares.
    debug_assert!(own.gravity == neighbours.gravity && own.dt == neighbours.dt);
    if jointed {
        return true;
    }
    // Each side's reach is drawn with the plan's step, which a neighbour's was read with.
    let own_reach = if own.dt == neighbours.dt {
        own.reach()
    } else {
        f64::INFINITY
    };
    let index = &registry.index;
    let is_ground = |c: &ColliderHandle| {
        index
            .entry(*c)
            .map_or_else(|()| registry.grounds.contains_key(c), |e| e.is_some())
    };
    // The walks are `any` rather than loops: rapier's iterator over a collider's pairs then
    // runs as one fold, not a call per pair.
    rb.colliders().iter().any(|ch| {
        let (co, ball) = if *ch == ball_collider.handle {
            (ball_collider.collider, Some(ball_collider.ball))
        } else {
            let Some(co) = colliders.get(*ch) else {
                return false;
            };
            (co, co.shape().as_ball())
        };
        sets.narrow_phase.contact_pairs_with(*ch).any(|pair| {
            let other = if pair.collider1 == *ch {
                pair.collider2
            } else {
                pair.collider1
            };
            // A ground (a floor under every ball) is the plan's to meet, whatever its shape:
            // skipped before anything else of it is read.
            !is_ground(&other)
                && neighbour_within_reach(other, (co, ball), (own, own_reach), scene, neighbours)
        })
    })
}

/// Can the collider `other` (not a ground) touch the own collider `co` (`ball`, if it is a
/// ball) within the step, `own` and `own_reach` the own ball's motion and reach? A ball as
/// `neighbours` holds it; any other shape read afresh (see [`within_reach_of_other`]).
#[inline]
fn neighbour_within_reach(
    other: ColliderHandle,
    (co, ball): (&Collider, Option<&Ball>),
    (own, own_reach): (&OwnMotion, f64),
    scene: &Scene,
    neighbours: &mut NeighbourReads,
) -> bool {
    let Scene {
        bodies,
        colliders,
        writes,
        ..
    } = *scene;
    match neighbours.read(other, scene) {
        None => false,
        Some(Read::Ball(near)) => {
            if !near.enabled {
                return false;
            }
            let skins = to_f64(co.contact_skin()) + to_f64(near.skin);
            match ball {
                Some(a) => balls_within_reach((co, a), near, skins, own, own_reach),
                None => colliders
                    .get(other)
                    .is_some_and(|oc| reached_through_parry(co, oc, skins, own, &near.motion)),
            }
        }
        Some(Read::Other(oc)) => {
            if !oc.is_enabled() {
                return false;
            }
            let skins = to_f64(co.contact_skin()) + to_f64(oc.contact_skin());
            let body = oc.parent().and_then(|p| Some((p, bodies.get(p)?)));
            let motion = other_motion(oc, false, body, (own.gravity, own.dt), writes);
            reached_through_parry(co, oc, skins, own, &motion)
        }
    }
}

/// Two balls (most neighbours in a crowd), the own ball `a` of collider `co` and the
/// neighbour `near`, `skins` their contact skins summed: can they touch within the step,
/// `own` and `own_reach` the own ball's motion and reach? By their centres, without parry;
/// a bound that is NaN is within reach.
#[inline]
fn balls_within_reach(
    (co, a): (&Collider, &Ball),
    near: &Neighbour,
    skins: f64,
    own: &OwnMotion,
    own_reach: f64,
) -> bool {
    let d = vec_to_na(near.translation - co.position().translation);
    let len = d.norm();
    let gap = len - to_f64(a.radius) - to_f64(near.radius) - skins;
    // Most neighbours are out of reach by the two reaches alone, which spares the exact bound
    // (the same answer: the exact bound never exceeds this one along a line of unit length,
    // which `len` gives unless tiny or infinite).
    if (UNDERFLOW_LENGTH..f64::INFINITY).contains(&len)
        && gap > closing_bound_of_reaches(own_reach, near.reach)
    {
        return false;
    }
    // Two centres close no faster than along their line now:
    // |d + x| >= |d| + x.d/|d| for any relative displacement x.
    let line = (len > 0.0).then(|| d / len);
    if gap > closing_bound(own, &near.motion, line) {
        return false;
    }
    true
}

/// parry's distance between the collider `co` (of the ball) and `other`, less their `skins`
/// (m), against how far the two can close in any direction ([`closing_bound`]); a pair parry
/// cannot measure is within reach.
fn reached_through_parry(
    co: &Collider,
    other: &Collider,
    skins: f64,
    own: &OwnMotion,
    motion: &OtherMotion,
) -> bool {
    match query::distance(co.position(), co.shape(), other.position(), other.shape()) {
        Ok(found) => to_f64(found.distance) - skins <= closing_bound(own, motion, None),
        Err(_) => true,
    }
}

/// What [`closing_bound`] needs of the collider `other` (`other_ball`: it is a ball) and its
/// body, if it has one (`body`, its handle and rapier's body), read through the writes so
/// far, in a step of `dt` (s) under the world's `gravity` (m/s^2).
fn other_motion(
    other: &Collider,
    other_ball: bool,
    body: Option<(RigidBodyHandle, &RigidBody)>,
    (gravity, dt): (Vector3<f64>, f64),
    writes: &Writes,
) -> OtherMotion {
    let Some((handle, ob)) = body else {
        return OtherMotion::Still;
    };
    let (com, linvel, angvel) = writes.motion(handle, ob);
    // How far its surface lies from its centre of mass: a ball turning about its centre does
    // not move its surface.
    let arm = if other_ball {
        to_f64((other.position().translation - com).length())
    } else {
        let bs = other.shape().compute_local_bounding_sphere();
        to_f64((other.position().transform_point(bs.center) - com).length() + bs.radius)
    };
    let mut turn = to_f64(angvel.length()) * arm;
    let mut accel = None;
    let mut kinematic_shift = None;
    if ob.is_dynamic() {
        accel = Some(
            gravity * to_f64(ob.gravity_scale()) + vec_to_na(ob.user_force()) / to_f64(ob.mass()),
        );
        // Torque-free, an anisotropic body's spin grows by at most I_max / I_min; a user
        // torque adds at most |tau| / I_min over the step.
        let inv = ob.mass_properties().local_mprops.inv_principal_inertia;
        if !other_ball && inv.min_element() > 0.0 {
            let spin_up = inv.max_element() / inv.min_element();
            let torque = to_f64(ob.user_torque().length() * inv.max_element());
            turn = (turn * to_f64(spin_up) + torque * dt * arm) * SPIN_UP_ALLOWANCE;
        }
    } else if ob.is_kinematic() {
        // A position-based kinematic body is moved to its next pose whatever its velocity:
        // its centre of mass's shift, and its turn.
        let local = ob.local_center_of_mass();
        let next = ob.next_position();
        let shift = vec_to_na(next.transform_point(local) - ob.position().transform_point(local));
        kinematic_shift = Some(shift.norm() / dt);
        let turned = to_f64(next.rotation.angle_between(ob.position().rotation));
        turn = turn.max(turned / dt * arm);
    }
    OtherMotion::Body {
        linvel: vec_to_na(linvel),
        turn,
        accel,
        kinematic_shift,
    }
}

/// A length (m) far above what `norm` can lose to its squares' underflow: a coordinate's square
/// below `f64::MIN_POSITIVE` loses up to 2^-1075, so a length computed falls short of the true
/// one by at most `sqrt(3 * 2^-1075)`, below 3e-162, besides its rounding. A line of centres at
/// least this long is of unit length to within rounding, and a length computed plus this one
/// is never below the true length.
const UNDERFLOW_LENGTH: f64 = 1e-150;

/// A vector's length as [`closing_bound_of_reaches`] counts it: never below its dot product
/// with a unit vector, whatever its size (`UNDERFLOW_LENGTH`).
fn size(x: Vector3<f64>) -> f64 {
    x.norm() + UNDERFLOW_LENGTH
}

impl OwnMotion {
    /// Its side of [`closing_bound_of_reaches`]: how far the ball can move in the step, in any
    /// direction. `pressed` and `dragged` are taken at their size, which bounds them only
    /// along the unit directions `normal` and `drag_along` the exact bound takes them along:
    /// a direction longer than that (not finite, or normalised from a vector too short for
    /// its square), or a step that is not a non-negative number, gives no bound.
    fn reach(&self) -> f64 {
        let unit = |u: &Vector3<f64>| u.norm_squared() <= 1.0 + 1e-12;
        let directions =
            unit(&self.normal) && self.drag_along.is_none_or(|[a, b]| unit(&a) && unit(&b));
        let dt = self.dt;
        if !directions || dt.is_nan() || dt < 0.0 {
            return f64::INFINITY;
        }
        size(self.v) * dt + (size(self.accel) + self.pressed.abs() + self.dragged.abs()) * dt * dt
    }
}

impl OtherMotion {
    /// Its side of [`closing_bound_of_reaches`] over a step of `dt` (s): how far the collider's
    /// surface can move in the step, in any direction (zero for a still one).
    fn reach(&self, dt: f64) -> f64 {
        match *self {
            OtherMotion::Still => 0.0,
            OtherMotion::Body {
                linvel,
                turn,
                accel,
                kinematic_shift,
            } => {
                (size(linvel) + turn.abs() + kinematic_shift.map_or(0.0, f64::abs)) * dt
                    + accel.map_or(0.0, size) * dt * dt
            }
        }
    }
}

/// A bound that [`closing_bound`] never exceeds along a line of unit length (or none), from
/// each side's reach alone (`OwnMotion::reach`, `OtherMotion::reach` with the same step):
/// every term of the exact bound is a dot product with a unit vector (at most the vector's
/// length) or a length, of a difference (at most the sum of the lengths), and the kinematic
/// shift and the ground's push and drag enter at their size (`pressed` and `dragged` along
/// unit directions). The room covers the two computations' rounding: a few `f64::EPSILON` of
/// the operands' sizes, which the reaches bound, and near the smallest numbers, where terms
/// round to subnormals, a few of those. So where a gap exceeds it, the gap exceeds the exact
/// bound too. A side that is NaN or infinite (a motion that is not finite, or
/// directions the reach cannot vouch for) gives a bound no gap exceeds.
fn closing_bound_of_reaches(own: f64, other: f64) -> f64 {
    const ROUNDING_ROOM: f64 = 1e-9;
    (own + other) * (1.0 + ROUNDING_ROOM) + 1e-300
}

/// How much a body of motion `own` (a centred ball) and a collider whose surface moves as
/// `other` can close in the step `own.dt` (see [`within_reach_of_other`]), along `line` (the
/// unit line of centres of two balls) or in any direction; infinite when the other's motion
/// is not finite. The relative speed of the centres of mass, the other's spin times how far
/// its surface lies from its centre of mass, and the step squared times the accelerations'
/// difference and what `own`'s ground adds: rapier's substeps move a body by
/// `(N + 1) / 2N a dt^2` in a step, at most `a dt^2`. Pure.
fn closing_bound(own: &OwnMotion, other: &OtherMotion, line: Option<Vector3<f64>>) -> f64 {
    let dt = own.dt;
    // Along the line, the part of a vector that closes the gap; else its length.
    let closing = |x: Vector3<f64>| line.map_or(x.norm(), |l| x.dot(&l).max(0.0));
    let across = |x: Vector3<f64>| line.map_or(x.norm(), |l| x.dot(&l).abs());
    let pushed = match line {
        Some(l) => {
            let drag = own
                .drag_along
                .map_or(1.0, |[a, b]| a.dot(&l).abs().max(b.dot(&l).abs()));
            own.pressed * own.normal.dot(&l).abs() + own.dragged * drag
        }
        None => own.pressed + own.dragged,
    };
    let OtherMotion::Body {
        linvel,
        turn,
        accel,
        kinematic_shift,
    } = *other
    else {
        return closing(own.v) * dt + (across(own.accel) + pushed) * dt * dt;
    };
    let mut approach = closing(own.v - linvel);
    if let Some(shift) = kinematic_shift {
        approach = approach.max(own.v.norm() + shift);
    }
    let accel = across(accel.map_or(own.accel, |theirs| own.accel - theirs));
    let bound = (approach + turn) * dt + (accel + pushed) * dt * dt;
    if bound.is_finite() {
        bound
    } else {
        f64::INFINITY
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::plugin::bridge::convert::to_real;
    use crate::plugin::queries::observe::Sets;
    use crate::plugin::state::registry::Registry;
    use crate::plugin::state::writes::Write;
    use crate::rapier::prelude::{
        ColliderBuilder, ColliderSet, ImpulseJointSet, IslandManager, MultibodyJointSet,
        NarrowPhase, RigidBodyBuilder, RigidBodySet, SoftBodySet,
    };
    use proptest::prelude::*;

    fn own() -> OwnMotion {
        OwnMotion {
            v: Vector3::zeros(),
            accel: Vector3::new(0.0, -9.81, 0.0),
            normal: Vector3::y(),
            pressed: 9.81,
            dragged: 0.0,
            drag_along: None,
            gravity: Vector3::new(0.0, -9.81, 0.0),
            dt: 1.0 / 60.0,
        }
    }

    /// A number of any size and sign, now and then zero, infinite, NaN or subnormal.
    fn number() -> impl Strategy<Value = f64> {
        let special = prop::sample::select(vec![
            0.0,
            -0.0,
            f64::NAN,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::MAX,
            f64::MIN_POSITIVE,
            5e-324,
        ]);
        prop_oneof![
            8 => (-1.0..=1.0, -330..=310).prop_map(|(m, k): (f64, i32)| m * 10f64.powi(k)),
            4 => -30.0..30.0,
            1 => special,
        ]
    }

    /// A vector of such numbers, or of one size in any direction.
    fn vector() -> impl Strategy<Value = Vector3<f64>> {
        prop_oneof![
            prop::array::uniform3(number()).prop_map(Vector3::from),
            (prop::array::uniform3(-1.0..=1.0), -330..=310)
                .prop_map(|(v, k): ([f64; 3], i32)| Vector3::from(v) * 10f64.powi(k)),
        ]
    }

    /// A unit vector (a fixed one where the draw is too short to normalise).
    fn unit() -> impl Strategy<Value = Vector3<f64>> {
        prop::array::uniform3(-1.0..=1.0).prop_map(|v: [f64; 3]| {
            Vector3::from(v)
                .try_normalize(1e-3)
                .unwrap_or_else(Vector3::x)
        })
    }

    /// A direction as the rolling plan makes one of a slip or a velocity: normalised however
    /// short (so not always of unit length), zero where it cannot be.
    fn direction() -> impl Strategy<Value = Vector3<f64>> {
        vector().prop_map(|v| v.try_normalize(0.0).unwrap_or_else(Vector3::zeros))
    }

    fn own_motion() -> impl Strategy<Value = OwnMotion> {
        let drag = prop::option::of((direction(), direction()).prop_map(|(a, b)| [a, b]));
        let dt = prop_oneof![1e-4..0.5, (-12..=3).prop_map(|k: i32| 10f64.powi(k))];
        let normal = prop_oneof![4 => unit(), 1 => direction()];
        ((vector(), vector(), normal, number(), number()), drag, dt).prop_map(
            |((v, accel, normal, pressed, dragged), drag_along, dt)| OwnMotion {
                v,
                accel,
                normal,
                pressed,
                dragged,
                drag_along,
                gravity: Vector3::new(0.0, -9.81, 0.0),
                dt,
            },
        )
    }

    fn other_motion_of_any_kind() -> impl Strategy<Value = OtherMotion> {
        let body = (
            vector(),
            number(),
            prop::option::of(vector()),
            prop::option::of(number()),
        )
            .prop_map(|(linvel, turn, accel, kinematic_shift)| OtherMotion::Body {
                linvel,
                turn,
                accel,
                kinematic_shift,
            });
        prop_oneof![1 => Just(OtherMotion::Still), 4 => body]
    }

    /// What the reach test relies on: where a gap exceeds the reaches' bound, it exceeds the
    /// exact bound (so a finite reaches' bound must not be below the exact bound, nor face an
    /// exact bound that is NaN).
    fn skips_as_the_exact_bound(
        own: &OwnMotion,
        other: &OtherMotion,
        line: Option<Vector3<f64>>,
    ) -> Result<(), String> {
        let exact = closing_bound(own, other, line);
        let reaches = closing_bound_of_reaches(own.reach(), other.reach(own.dt));
        if !reaches.is_finite() || exact <= reaches {
            Ok(())
        } else {
            Err(format!("exact {exact:e} > reaches {reaches:e}"))
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig {
            cases: 40_000,
            rng_algorithm: prop::test_runner::RngAlgorithm::ChaCha,
            rng_seed: prop::test_runner::RngSeed::Fixed(0x5eed_0031),
            failure_persistence: None,
            ..ProptestConfig::default()
        })]

        /// The reach test skips the exact bound where the gap exceeds the reaches' bound: the
        /// same answer for every motion, of any size, NaN and infinity included, along any
        /// line of centres of unit length or none.
        #[test]
        fn the_bound_of_reaches_skips_only_what_the_exact_bound_does(
            own in own_motion(),
            other in other_motion_of_any_kind(),
            line in prop::option::of(unit()),
        ) {
            prop_assert!(skips_as_the_exact_bound(&own, &other, line).is_ok(), "{:?}",
                skips_as_the_exact_bound(&own, &other, line));
        }
    }

    /// The cases the reaches must vouch for by hand: a ground whose velocity is not finite
    /// (the ball's drag directions NaN, the exact bound NaN), a drag direction normalised from
    /// a slip too short for its square (longer than 1), speeds too small for theirs (their
    /// `norm` zero), and a step that is negative or NaN.
    #[test]
    fn the_reaches_vouch_for_degenerate_directions_and_tiny_speeds() {
        let x = Vector3::x();
        let ball = |v: Vector3<f64>, drag_along| OwnMotion {
            v,
            accel: Vector3::new(0.0, -9.81, 0.0),
            normal: Vector3::y(),
            pressed: 9.81,
            dragged: 98.1,
            drag_along,
            gravity: Vector3::new(0.0, -9.81, 0.0),
            dt: 1.0 / 60.0,
        };
        let nan = (x - Vector3::new(f64::NAN, 0.0, 0.0))
            .try_normalize(0.0)
            .unwrap_or_else(Vector3::zeros);
        let long = Vector3::new(2.72e-162, 0.0, 0.0)
            .try_normalize(0.0)
            .unwrap_or_else(Vector3::zeros);
        assert!(long.norm() > 1.1, "a direction of length {}", long.norm());
        let tiny = Vector3::new(1e-170, 0.0, 0.0);
        let still = OtherMotion::Still;
        let moving = OtherMotion::Body {
            linvel: -tiny,
            turn: 0.0,
            accel: Some(-tiny),
            kinematic_shift: None,
        };
        // A step that is not a non-negative number: no bound at all.
        for dt in [-1.0 / 60.0, f64::NAN] {
            assert_eq!(
                OwnMotion {
                    dt,
                    ..ball(x, None)
                }
                .reach(),
                f64::INFINITY
            );
        }
        let lines = (0..=100).map(|k| {
            let a = k as f64 / 100.0 * std::f64::consts::PI;
            Vector3::new(a.cos(), a.sin(), 0.0)
        });
        for line in lines {
            for (own, other) in [
                (ball(x, Some([nan, nan])), still),
                (ball(x, Some([nan, nan])), moving),
                (
                    ball(Vector3::zeros(), Some([long, Vector3::zeros()])),
                    still,
                ),
                (
                    OwnMotion {
                        accel: Vector3::zeros(),
                        pressed: 0.0,
                        dragged: 0.0,
                        ..ball(tiny, None)
                    },
                    still,
                ),
                (
                    OwnMotion {
                        v: Vector3::zeros(),
                        accel: Vector3::zeros(),
                        pressed: 0.0,
                        dragged: 0.0,
                        ..ball(tiny, None)
                    },
                    moving,
                ),
            ] {
                if let Err(e) = skips_as_the_exact_bound(&own, &other, Some(line)) {
                    panic!("{own:?} against {other:?} along {line:?}: {e}");
                }
            }
        }
    }

    /// Where every term lines up (the ball and its neighbour moving, turning, falling and
    /// pushed straight at each other along the line of centres, the neighbour also shifted
    /// as a kinematic body), the exact bound reaches the reaches' bound: it stays within its
    /// rounding room.
    #[test]
    fn where_every_term_lines_up_the_bounds_meet() {
        let x = Vector3::x();
        for (dt, shift) in [
            (1.0 / 60.0, None),
            (1.0 / 240.0, None),
            (0.1, None),
            (1.0 / 60.0, Some(7.0)),
        ] {
            let own = OwnMotion {
                v: x * 5.0,
                accel: x * 4.0,
                normal: x,
                pressed: 9.81,
                dragged: 4.9,
                drag_along: Some([x, x]),
                gravity: Vector3::new(0.0, -9.81, 0.0),
                dt,
            };
            // The shift counts in full where the body has no velocity of its own.
            let other = OtherMotion::Body {
                linvel: if shift.is_some() {
                    Vector3::zeros()
                } else {
                    -x * 3.0
                },
                turn: 2.0,
                accel: Some(-x * 6.0),
                kinematic_shift: shift,
            };
            let exact = closing_bound(&own, &other, Some(x));
            let reaches = closing_bound_of_reaches(own.reach(), other.reach(dt));
            let sum = own.reach() + other.reach(dt);
            assert!(exact <= reaches, "exact {exact} > reaches {reaches}");
            assert!(
                (exact - sum).abs() <= 1e-12 * sum,
                "exact {exact}, sides {sum}"
            );
        }
    }

    fn linvel(n: &Neighbour) -> Vector3<f64> {
        match n.motion {
            OtherMotion::Body { linvel, .. } => linvel,
            OtherMotion::Still => panic!("a ball of a body read as still"),
        }
    }

    /// A neighbouring ball is read once a plan, read again once its body is written (what a
    /// ball planned after a `Step` impulse of its neighbour sees is the neighbour after it),
    /// read afresh in the next plan, and never taken for another collider in its slot.
    #[test]
    fn a_neighbour_is_read_once_a_plan_and_again_after_a_write_to_its_body() {
        // One ball moving along x at `vx`: the same handles in every set built so.
        let world = |vx: f64| {
            let mut bodies = RigidBodySet::new();
            let mut colliders = ColliderSet::new();
            let body = bodies.insert(
                RigidBodyBuilder::dynamic()
                    .translation(Vector::new(0.1, 0.0, 0.0))
                    .linvel(Vector::new(to_real(vx), 0.0, 0.0)),
            );
            let ball = colliders.insert_with_parent(ColliderBuilder::ball(0.02), body, &mut bodies);
            (bodies, colliders, body, ball)
        };
        let (bodies, colliders, body, ball) = world(0.0);
        let (narrow_phase, joints, multibody) = (
            NarrowPhase::new(),
            ImpulseJointSet::new(),
            MultibodyJointSet::new(),
        );
        let sets = Sets::new(&narrow_phase, &joints, &multibody);
        let registry = Registry::default();
        let mut neighbours = NeighbourReads::default();
        let (gravity, dt) = (own().gravity, own().dt);
        // The ball `handle` as the plan reads it: its linear velocity and radius.
        let read = |neighbours: &mut NeighbourReads,
                    handle: ColliderHandle,
                    bodies: &RigidBodySet,
                    colliders: &ColliderSet,
                    writes: &Writes| {
            let scene = Scene {
                bodies,
                colliders,
                sets: &sets,
                registry: &registry,
                grounds: &[],
                writes,
            };
            match neighbours.read(handle, &scene) {
                Some(Read::Ball(n)) => (linvel(n), n.radius),
                _ => panic!("the ball is not read as one"),
            }
        };
        let v = |x: f64| x * Vector3::x();

        let mut writes = Writes::default();
        neighbours.begin_plan(gravity, dt);
        assert_eq!(
            read(&mut neighbours, ball, &bodies, &colliders, &writes).0,
            v(0.0)
        );
        // rapier's body changed behind the plan's back (nothing does so within a plan): the
        // plan's first reading stands until the next plan.
        let (mut bodies, mut colliders, _, _) = world(-1.0);
        assert_eq!(
            read(&mut neighbours, ball, &bodies, &colliders, &writes).0,
            v(0.0)
        );
        neighbours.begin_plan(gravity, dt);
        assert_eq!(
            read(&mut neighbours, ball, &bodies, &colliders, &writes).0,
            v(-1.0)
        );
        // A write recorded in the plan: read again, as the writes leave it.
        writes.record(body, Write::Velocity(Vector::new(-3.0, 0.0, 0.0)));
        assert_eq!(
            read(&mut neighbours, ball, &bodies, &colliders, &writes).0,
            v(-3.0)
        );
        writes.record(body, Write::Velocity(Vector::new(-5.0, 0.0, 0.0)));
        assert_eq!(
            read(&mut neighbours, ball, &bodies, &colliders, &writes).0,
            v(-5.0)
        );
        // Another ball in the removed one's slot, within the same plan: read as itself.
        let (mut islands, mut soft) = (IslandManager::new(), SoftBodySet::new());
        colliders.remove(ball, &mut islands, &mut bodies, &mut soft, false);
        let other = colliders.insert_with_parent(ColliderBuilder::ball(0.05), body, &mut bodies);
        assert_eq!(other.into_raw_parts().0, ball.into_raw_parts().0);
        assert_eq!(
            read(&mut neighbours, other, &bodies, &colliders, &writes).1,
            0.05
        );
    }
}
