//! Contact geometry along a body's flight, with parry: the signed distance to the grounds,
//! the earliest time of impact inside a step, and the landing points of a flat face.
//!
//! All arithmetic is `f64`; poses are rounded to rapier's precision only to call parry.

use super::convert::{pose_from_na, to_f64, vec_to_na};
use super::flight::{Flight, State};
use crate::parry::query;
use crate::parry::shape::{PolygonalFeature, Shape};
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
    pub parts: Vec<BodyPart<'a>>,
    /// Radius of a sphere about the centre of mass that holds every collider (m).
    pub radius: f64,
}

/// A ground collider moving at constant velocity over the step (zero for fixed ground).
pub(crate) struct GroundGeom<'a> {
    pub handle: ColliderHandle,
    pub shape: &'a dyn Shape,
    pub skin: f64,
    /// Centre of mass of the ground body at the start of the step (the collider's origin for
    /// fixed ground).
    pub com0: Vector3<f64>,
    /// Orientation of the ground's centre-of-mass frame at the start of the step.
    pub rot0: UnitQuaternion<f64>,
    /// Collider pose in the ground's centre-of-mass frame.
    pub local: Isometry3<f64>,
    /// Ground linear velocity at its centre of mass (m/s).
    pub v: Vector3<f64>,
    /// Ground angular velocity (rad/s).
    pub w: Vector3<f64>,
}

impl GroundGeom<'_> {
    fn com_at(&self, t: f64) -> Vector3<f64> {
        self.com0 + self.v * t
    }

    /// The collider's world pose at time `t` of the step.
    pub fn pose_at(&self, t: f64) -> Isometry3<f64> {
        let rot = UnitQuaternion::from_scaled_axis(self.w * t) * self.rot0;
        Isometry3::from_parts(Translation3::from(self.com_at(t)), rot) * self.local
    }

    /// Velocity of the ground's material point at `p` at time `t` (m/s).
    pub fn velocity_at(&self, p: &Vector3<f64>, t: f64) -> Vector3<f64> {
        self.v + self.w.cross(&(p - self.com_at(t)))
    }

    /// A bound on the speed of the ground's points within `reach` of its centre of mass.
    fn max_speed(&self, reach: f64) -> f64 {
        self.v.norm() + self.w.norm() * reach
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

/// The collider's world pose for the body at `s`.
pub(crate) fn part_pose(part: &BodyPart, s: &State) -> Isometry3<f64> {
    Isometry3::from_parts(Translation3::from(s.com), s.rot) * part.local
}

/// Velocity of the body's material point at `p` (m/s).
pub(crate) fn body_velocity_at(s: &State, p: &Vector3<f64>) -> Vector3<f64> {
    s.v + s.w.cross(&(p - s.com))
}

/// Signed distance (m, skins deducted), unit normal from the ground into the body, and the
/// contact point on the body (m).
pub(crate) type PairContact = (f64, Vector3<f64>, Vector3<f64>);

/// Contact of one body part and one ground at time `t`, if within `prediction` (m):
/// signed distance (skins deducted), normal from the ground into the body, point on the body.
pub(crate) fn contact(
    part: &BodyPart,
    ground: &GroundGeom,
    s: &State,
    t: f64,
    prediction: f64,
) -> Option<PairContact> {
    contact_checked(part, ground, s, t, prediction)
        .ok()
        .flatten()
}

/// [`contact`], telling apart a pair parry cannot query (`Err`).
pub(crate) fn contact_checked(
    part: &BodyPart,
    ground: &GroundGeom,
    s: &State,
    t: f64,
    prediction: f64,
) -> Result<Option<PairContact>, query::Unsupported> {
    let skins = part.skin + ground.skin;
    let pose_g = pose_from_na(&ground.pose_at(t));
    let pose_b = pose_from_na(&part_pose(part, s));
    let Some(c) = query::contact(
        &pose_g,
        ground.shape,
        &pose_b,
        part.shape,
        super::convert::to_real(prediction + skins),
    )?
    else {
        return Ok(None);
    };
    let n = vec_to_na(c.normal1);
    let norm = n.norm();
    if norm.is_nan() || norm <= 0.5 {
        return Ok(None);
    }
    let n = n / norm;
    let point = vec_to_na(c.point2) - n * part.skin;
    Ok(Some((to_f64(c.dist) - skins, n, point)))
}

/// The closest contact over every body part and ground (indices in `grounds`), at `t`.
pub(crate) fn closest(
    body: &BodyGeom,
    grounds: &[GroundGeom],
    s: &State,
    t: f64,
    prediction: f64,
) -> Option<Hit> {
    let mut best: Option<Hit> = None;
    for (i, part) in body.parts.iter().enumerate() {
        for (j, ground) in grounds.iter().enumerate() {
            if let Some((dist, normal, point)) = contact(part, ground, s, t, prediction) {
                if best.is_none_or(|b| dist < b.dist) {
                    let u = body_velocity_at(s, &point) - ground.velocity_at(&point, t);
                    best = Some(Hit {
                        part: i,
                        ground: j,
                        dist,
                        normal,
                        point,
                        un: normal.dot(&u),
                    });
                }
            }
        }
    }
    best
}

/// A bound on the speed at which any point of the body can approach any ground during
/// `[t0, t0 + span]` of the flight from `s0` at `t0`.
fn approach_bound(
    body: &BodyGeom,
    grounds: &[GroundGeom],
    flight: &Flight,
    s0: &State,
    t0: f64,
    span: f64,
) -> f64 {
    let lin = flight.max_speed(s0, span);
    let body_bound = lin + s0.w.norm() * body.radius;
    let travel = lin * span + body.radius;
    let ground_bound = grounds
        .iter()
        .map(|g| g.max_speed((s0.com - g.com_at(t0)).norm() + travel))
        .fold(0.0, f64::max);
    (body_bound + ground_bound).max(1e-9)
}

/// The earliest time in `[t_from, t_to]` at which the body, flying from `s0` (its state at
/// `t0 <= t_from`), touches a ground while approaching it.
///
/// Conservative advancement (steps of `dist / bound`, which cannot pass a contact) brings
/// the body within `close` of the ground; Newton's method on the signed distance, whose time
/// derivative is the normal velocity `un` at the contact point, then finds the contact time
/// to rounding. A touching contact that separates is stepped over.
#[allow(clippy::too_many_arguments)]
pub(crate) fn first_impact(
    body: &BodyGeom,
    grounds: &[GroundGeom],
    flight: &Flight,
    s0: &State,
    t0: f64,
    t_from: f64,
    t_to: f64,
) -> Option<(f64, State, Hit)> {
    const MAX_ADVANCE: usize = 256;
    let bound = approach_bound(body, grounds, flight, s0, t0, t_to - t0);
    let close = (1e-3 * body.radius).clamp(1e-7, 1e-3);
    let mut t = t_from;
    for _ in 0..MAX_ADVANCE {
        let s = flight.advance(s0, t - t0);
        let reach = bound * (t_to - t) + close;
        let h = closest(body, grounds, &s, t, reach)?;
        if h.dist <= close {
            if h.un < 0.0 {
                return Some(polish(
                    body,
                    grounds,
                    flight,
                    s0,
                    t0,
                    (t_from, t_to),
                    t,
                    s,
                    h,
                ));
            }
            t += close.max(h.dist) / bound;
        } else {
            t += h.dist / bound;
        }
        if t > t_to {
            return None;
        }
    }
    None
}

/// Newton's method on the signed distance from `(t, h)`, within `range`; returns the iterate
/// with the smallest `|dist|`.
#[allow(clippy::too_many_arguments)]
fn polish(
    body: &BodyGeom,
    grounds: &[GroundGeom],
    flight: &Flight,
    s0: &State,
    t0: f64,
    range: (f64, f64),
    mut t: f64,
    mut s: State,
    mut h: Hit,
) -> (f64, State, Hit) {
    let mut best = (t, s, h);
    for _ in 0..16 {
        if h.un >= 0.0 {
            break;
        }
        let t_new = (t + h.dist / -h.un).clamp(range.0, range.1);
        if (t_new - t).abs() <= 1e-15 * (1.0 + t.abs()) {
            break;
        }
        let s_new = flight.advance(s0, t_new - t0);
        let reach = 2.0 * h.dist.abs() + 1e-3 * body.radius + 1e-9;
        let Some(h_new) = closest(body, grounds, &s_new, t_new, reach) else {
            break;
        };
        t = t_new;
        s = s_new;
        h = h_new;
        if h.dist.abs() < best.2.dist.abs() {
            best = (t, s, h);
        }
    }
    best
}

/// The contact points of a landing, resolved as one impact (see the integration guide):
/// the vertices of the body's support face towards the ground (parry's polygonal feature)
/// that lie within `flat_tolerance x face size` of the contact plane and approach the
/// ground. Two or more give one impact at their centroid, projected on the contact plane;
/// otherwise the impact is at the deepest point. Returns the point and the count.
pub(crate) fn landing_point(
    part: &BodyPart,
    ground: &GroundGeom,
    s: &State,
    t: f64,
    h: &Hit,
    flat_tolerance: f64,
) -> (Vector3<f64>, usize) {
    let Some((pfm, border)) = part.shape.as_polygonal_feature_map() else {
        return (h.point, 1);
    };
    let pose = part_pose(part, s);
    let dir_local = pose.rotation.inverse() * (-h.normal);
    let mut feature = PolygonalFeature::default();
    pfm.local_support_feature(super::convert::vec_from_na(&dir_local), &mut feature);
    let count = feature.num_vertices.min(4);
    if count < 2 {
        return (h.point, 1);
    }
    let verts: Vec<Vector3<f64>> = feature.vertices[..count]
        .iter()
        .map(|v| pose * nalgebra::Point3::from(vec_to_na(*v)))
        .map(|p| p.coords)
        .collect();
    let heights: Vec<f64> = verts.iter().map(|x| h.normal.dot(&(x - h.point))).collect();
    let h_min = heights.iter().copied().fold(f64::INFINITY, f64::min);
    let mut size: f64 = 0.0;
    for a in &verts {
        for b in &verts {
            size = size.max((a - b).norm());
        }
    }
    let tol = flat_tolerance * size + 1e-6 * (size + 1e-3);
    // The face must be the one touching: its lowest vertex at the contact point (a rounded
    // shape's core vertices sit `border` above its surface).
    if (h_min - to_f64(border)).abs() > tol + 1e-6 * (1.0 + size) {
        return (h.point, 1);
    }
    let mut sum = Vector3::zeros();
    let mut n = 0usize;
    for (x, hx) in verts.iter().zip(&heights) {
        if hx - h_min <= tol {
            let u = body_velocity_at(s, x) - ground.velocity_at(x, t);
            if h.normal.dot(&u) < 0.0 {
                sum += x;
                n += 1;
            }
        }
    }
    if n < 2 {
        return (h.point, 1);
    }
    let c = sum / n as f64;
    (c - h.normal * h.normal.dot(&(c - h.point)), n)
}
