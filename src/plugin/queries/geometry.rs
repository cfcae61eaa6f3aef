//! Contact geometry along a body's flight, with parry: the body and ground geometry the
//! queries share (here), the contact at one instant (`instant.rs`), the earliest time of
//! impact inside a step (`impact_time.rs`), and flat faces: a plane under a rolling ball and
//! the landing points of a flat face (`plane.rs`).
//!
//! All arithmetic is `f64`; poses are rounded to rapier's precision only to call parry.

mod impact_time;
mod instant;
mod plane;

pub(crate) use impact_time::{
    Gap, Search, Sweep, cannot_close, earliest_touch, first_impact, touch_time,
};
pub(crate) use instant::{
    closest, contact, contact_checked, contact_from_side, entry_face_contact,
};
pub(crate) use plane::{
    COPLANAR_TOLERANCE, PlaneNear, body_landing_point, flat_relative, landing_point,
    one_plane_under, plane_piece_of,
};

use crate::motion::State;
use crate::parry::shape::Shape;
use crate::plugin::bridge::convert::vec_to_na;
use crate::plugin::policy::GAP_BOUND_SLACK;
use crate::plugin::queries::ground_index::GroundMotion;
use crate::plugin::state::small_list::SmallList;
use crate::rapier::prelude::ColliderHandle;
use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};

/// One collider of a body, placed relative to the body's centre-of-mass frame (the frame at
/// the centre of mass with the body's orientation).
#[derive(Clone, Copy)]
pub(crate) struct BodyPart<'a> {
    pub handle: ColliderHandle,
    pub shape: &'a dyn Shape,
    /// Collider pose in the centre-of-mass frame.
    pub local: Isometry3<f64>,
    /// rapier's contact skin of the collider (m).
    pub skin: f64,
}

/// The colliders of a body and a bound on their distance from its centre of mass.
pub(crate) struct BodyGeom<'a> {
    pub parts: SmallList<BodyPart<'a>>,
    /// Radius of a sphere about the centre of mass that holds every collider (m).
    pub radius: f64,
}

/// A ground collider moving at constant velocity over the step (zero for fixed ground).
#[derive(Clone)]
pub(crate) struct GroundGeom<'a> {
    pub handle: ColliderHandle,
    pub shape: &'a dyn Shape,
    pub skin: f64,
    /// Its motion over the step (the ground index's): centre of mass, orientation and
    /// velocities at the start, the collider's pose in that frame and in the world, and a
    /// box holding it.
    pub motion: &'a GroundMotion,
    /// Body colliders that have no contact with this ground for the plugin (the pair is
    /// `Filtered`: rapier's filtering or the user's filter refuses it).
    pub skip: Vec<ColliderHandle>,
}

impl GroundGeom<'_> {
    /// A lower bound of the gap (m, as a contact query gives it: skins off, negative inside)
    /// between a still ground and a ball of centre `centre` and radius `radius` (its skin
    /// included): the ball's distance to the ground's box ([`GroundMotion::aabb`]), less
    /// `GAP_BOUND_SLACK * (1 + |centre|)` for the box's `f32` corners and parry's `f32`
    /// distance. The box is loosened by the resting gap and the ground's skin, and the
    /// bound subtracts neither: that is its margin. `-inf` (no bound) for a moving ground,
    /// whose box holds its whole sweep over the step, not its pose at the start, and is
    /// taken from its collider, which rapier moves with a body the user moved only in its
    /// step; `-inf` also with the centre in the box.
    pub fn gap_bound(&self, centre: &Vector3<f64>, radius: f64) -> f64 {
        if !self.motion.is_still() {
            return f64::NEG_INFINITY;
        }
        let (lo, hi) = (
            vec_to_na(self.motion.aabb.mins),
            vec_to_na(self.motion.aabb.maxs),
        );
        // `max` then `min`, not `clamp`: an empty or NaN box gives no bound, and no panic.
        let nearest = centre.zip_zip_map(&lo, &hi, |c, l, h| c.max(l).min(h));
        let outside = (nearest - centre).norm();
        if outside > 0.0 {
            outside - radius - GAP_BOUND_SLACK * (1.0 + centre.norm())
        } else {
            f64::NEG_INFINITY
        }
    }

    fn com_at(&self, t: f64) -> Vector3<f64> {
        self.motion.com0 + self.motion.v * t
    }

    /// The collider's world pose at time `t` of the step.
    pub fn pose_at(&self, t: f64) -> Isometry3<f64> {
        if self.motion.v == Vector3::zeros() && self.motion.w == Vector3::zeros() {
            return self.motion.pose0;
        }
        // A ground that does not turn: no rotation to compose.
        let rot = if self.motion.w == Vector3::zeros() {
            self.motion.rot0
        } else {
            UnitQuaternion::from_scaled_axis(self.motion.w * t) * self.motion.rot0
        };
        Isometry3::from_parts(Translation3::from(self.com_at(t)), rot) * self.motion.local
    }

    /// Velocity of the ground's material point at `p` at time `t` (m/s).
    ///
    /// Inlined: the plan asks it of every contact it rates.
    #[inline]
    pub fn velocity_at(&self, p: &Vector3<f64>, t: f64) -> Vector3<f64> {
        self.motion.v + self.motion.w.cross(&(p - self.com_at(t)))
    }

    /// A bound on the speed of the ground's points within `reach` of its centre of mass.
    fn max_speed(&self, reach: f64) -> f64 {
        self.motion.v.norm() + self.motion.w.norm() * reach
    }

    /// How far, over a step of length `dt`, any point of the ground moves that can come
    /// within `radius` of `centre` in it (m): 0 for a still ground. A body's reach of a
    /// moving ground adds it, as the search along a flight adds the ground's speed: a
    /// kinematic bat swung onto a ball at rest reaches it by its own motion. A turn keeps a
    /// point's distance `|r|` to the centre of mass, which moves by `|v| dt`, so such a point
    /// has `|r| <= |centre - com| + radius + |v| dt` and moves by at most `(|v| + |w| |r|) dt`.
    pub fn travel_near(&self, centre: &Vector3<f64>, radius: f64, dt: f64) -> f64 {
        if self.motion.is_still() {
            return 0.0;
        }
        let v = self.motion.v.norm();
        let r = (centre - self.com_at(0.0)).norm() + radius + v * dt;
        self.max_speed(r) * dt
    }
}

/// The closest (or deepest) contact between a body and the grounds at one instant.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Hit {
    /// Index of the body part.
    pub part: usize,
    /// Index of the ground.
    pub ground: usize,
    /// Signed distance, skins deducted (m): negative when penetrating.
    pub dist: f64,
    /// Unit normal from the ground into the body.
    pub normal: Vector3<f64>,
    /// Contact point on the body's surface (m).
    pub point: Vector3<f64>,
    /// Normal component of the contact point's velocity relative to the ground (m/s);
    /// negative when approaching.
    pub un: f64,
}

impl Hit {
    /// The hit of part `part` on ground `ground` (indices), at the contact `(dist, normal,
    /// point)` of the body at `s`, time `t`: its normal speed from the two velocities there.
    pub fn at(
        (part, ground): (usize, usize),
        gg: &GroundGeom,
        s: &State,
        t: f64,
        (dist, normal, point): PairContact,
    ) -> Self {
        let u = body_velocity_at(s, &point) - gg.velocity_at(&point, t);
        Hit {
            part,
            ground,
            dist,
            normal,
            point,
            un: normal.dot(&u),
        }
    }
}

/// The collider's world pose for the body at `s`.
pub(crate) fn part_pose(part: &BodyPart, s: &State) -> Isometry3<f64> {
    Isometry3::from_parts(Translation3::from(s.com), s.rot) * part.local
}

/// Velocity of the body's material point at `p` (m/s).
///
/// Inlined: the plan asks it of every contact it rates.
#[inline]
pub(crate) fn body_velocity_at(s: &State, p: &Vector3<f64>) -> Vector3<f64> {
    s.v + s.w.cross(&(p - s.com))
}

/// Where a body of bounding radius `radius` (about its centre of mass) can be over the next
/// `left` seconds from `s`, under an acceleration of magnitude at most `accel`, loosened by
/// `margin`: its centre's way is the segment along `s.v`, bowed by at most
/// `accel left^2 / 2` (twice that is allowed), and the body is held about the segment's
/// middle, so that a ball sent up from a floor does not reach back down to it.
pub(crate) struct WayBound {
    /// The segment's middle (m).
    pub centre: Vector3<f64>,
    /// The segment (m).
    way: Vector3<f64>,
    /// The body's radius, the bow's allowance and the margin (m), summed in that order.
    radius: f64,
    bow: f64,
    margin: f64,
}

impl WayBound {
    pub fn new(s: &State, accel: f64, radius: f64, left: f64, margin: f64) -> Self {
        let way = s.v * left;
        Self {
            centre: s.com + 0.5 * way,
            way,
            radius,
            bow: accel * left * left,
            margin,
        }
    }

    /// The half side of a cube about `centre` that holds the body (m).
    pub fn cube_half(&self) -> f64 {
        0.5 * self.way.amax() + self.radius + self.bow + self.margin
    }

    /// The radius of a ball about `centre` that holds the body (m).
    pub fn ball_radius(&self) -> f64 {
        0.5 * self.way.norm() + self.radius + self.bow + self.margin
    }
}

/// Signed distance (m, skins deducted), unit normal from the ground into the body, and the
/// contact point on the body (m).
pub(crate) type PairContact = (f64, Vector3<f64>, Vector3<f64>);
