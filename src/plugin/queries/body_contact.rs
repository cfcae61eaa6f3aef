//! Contact geometry between two moving bodies of any shape (dice, pins, a ball and a die),
//! with parry: their signed distance at one instant, the contact points of a flat landing of
//! one on the other, and the first time inside a step at which they touch while approaching.
//!
//! Contract: every function reads shapes and `f64` states and returns `f64` geometry; nothing
//! here writes anything or knows about roles. The normal is always the one of
//! `model::PairContact`: from body `a` towards body `b`. parry is asked with body `a`'s collider
//! at the origin and `b`'s placed relative to it, so that `f32` rounding applies to the small
//! relative pose and not to world coordinates.

use crate::motion::{Moving, State};
use crate::parry::query::{
    self, ContactManifold, DefaultQueryDispatcher, PersistentQueryDispatcher,
};
use crate::plugin::bridge::convert::{pose_from_na, to_f64, to_real, vec_to_na};
use crate::plugin::policy::{
    ADVANCE_STEPS, BODIES_SPEED_FLOOR, POSITION_ROUNDING, touch_tolerance,
};
use crate::plugin::queries::geometry::{
    BodyGeom, BodyPart, Gap, body_velocity_at, part_pose, touch_time,
};
use nalgebra::{Isometry3, Point3, Vector3};

/// The closest (or deepest) contact of two bodies at one instant.
#[derive(Clone, Copy, Debug)]
pub(crate) struct BodyTouch {
    /// Indices of the parts (colliders) of `a` and `b` in contact.
    pub parts: (usize, usize),
    /// Signed distance, skins deducted (m): negative when penetrating.
    pub dist: f64,
    /// Unit normal from `a` towards `b`.
    pub normal: Vector3<f64>,
    /// Contact point: the midpoint of the two surfaces' closest points, skins deducted (m).
    pub point: Vector3<f64>,
    /// Rate of change of `dist` (m/s): the normal component of `b`'s contact-point velocity
    /// less `a`'s; negative when approaching.
    pub rate: f64,
}

/// One part against one part: distance, normal (a to b), point, if within `prediction`.
///
/// Two shapes with flat faces (dice, boxes, hulls) are asked for parry's contact manifold,
/// whose normal comes from its face-clipping: parry's closest-contact query between two boxes
/// face on and aligned returns a side face's normal when their gap is below about 1e-6 m (in
/// `f32` and `f64` alike), which would turn a face-on impact sideways. A ball takes parry's
/// contact query, exact for it.
fn part_contact(
    pa: &BodyPart,
    sa: &State,
    pb: &BodyPart,
    sb: &State,
    prediction: f64,
) -> Option<(f64, Vector3<f64>, Vector3<f64>)> {
    let (pose_a, pose_b) = (part_pose(pa, sa), part_pose(pb, sb));
    let rel = pose_a.inverse() * pose_b;
    let skins = pa.skin + pb.skin;
    let ball = pa.shape.as_ball().is_some() || pb.shape.as_ball().is_some();
    if !ball {
        if let Some(found) = manifold_contact(pa, pb, &pose_a, &rel, prediction + skins) {
            let (dist, normal, p1, p2) = found;
            let (p1, p2) = (p1 + normal * pa.skin, p2 - normal * pb.skin);
            return Some((dist - skins, normal, 0.5 * (p1 + p2)));
        }
    }
    let c = query::contact(
        &pose_from_na(&Isometry3::identity()),
        pa.shape,
        &pose_from_na(&rel),
        pb.shape,
        to_real(prediction + skins),
    )
    .ok()
    .flatten()?;
    let n_local = vec_to_na(c.normal1);
    let norm = n_local.norm();
    if norm.is_nan() || norm <= 0.5 {
        return None;
    }
    let normal = pose_a.rotation * (n_local / norm);
    let p1 = pose_a * Point3::from(vec_to_na(c.point1));
    let p2 = pose_a * Point3::from(vec_to_na(c.point2));
    // The surfaces less their skins: a's point moves out along n by its skin, b's back.
    let (p1, p2) = (p1.coords + normal * pa.skin, p2.coords - normal * pb.skin);
    Some((to_f64(c.dist) - skins, normal, 0.5 * (p1 + p2)))
}

/// A contact manifold's point: distance (skins not deducted), world normal from a to b, the
/// points on a and on b.
type ManifoldPoint = (f64, Vector3<f64>, Vector3<f64>, Vector3<f64>);

/// The points of parry's contact manifolds of two parts (`rel`: b's pose in a's frame) within
/// `prediction`, in the world frame. `None` when parry has no manifold for the pair.
fn manifold_points(
    pa: &BodyPart,
    pb: &BodyPart,
    pose_a: &Isometry3<f64>,
    rel: &Isometry3<f64>,
    prediction: f64,
) -> Option<Vec<ManifoldPoint>> {
    let mut manifolds: Vec<ContactManifold<(), ()>> = Vec::new();
    DefaultQueryDispatcher
        .contact_manifolds(
            &pose_from_na(rel),
            pa.shape,
            pb.shape,
            to_real(prediction),
            &mut manifolds,
            &mut None,
        )
        .ok()?;
    let mut points = Vec::new();
    for m in &manifolds {
        let Some(n) = vec_to_na(m.local_n1).try_normalize(0.5) else {
            continue;
        };
        for p in &m.points {
            let p1 = pose_a * Point3::from(vec_to_na(p.local_p1));
            let p2 = pose_a * (rel * Point3::from(vec_to_na(p.local_p2)));
            points.push((to_f64(p.dist), pose_a.rotation * n, p1.coords, p2.coords));
        }
    }
    Some(points)
}

/// The deepest of [`manifold_points`] within `prediction`, or `None` (the caller asks parry's
/// contact query then).
fn manifold_contact(
    pa: &BodyPart,
    pb: &BodyPart,
    pose_a: &Isometry3<f64>,
    rel: &Isometry3<f64>,
    prediction: f64,
) -> Option<ManifoldPoint> {
    manifold_points(pa, pb, pose_a, rel, prediction)?
        .into_iter()
        .filter(|p| p.0 <= prediction)
        .min_by(|p, q| p.0.total_cmp(&q.0))
}

/// The closest contact over every part of `a` and `b` at states `sa`, `sb`, if within
/// `prediction` (m).
pub(crate) fn body_contact(
    a: &BodyGeom,
    sa: &State,
    b: &BodyGeom,
    sb: &State,
    prediction: f64,
) -> Option<BodyTouch> {
    let mut best: Option<BodyTouch> = None;
    for (i, pa) in a.parts.iter().enumerate() {
        for (j, pb) in b.parts.iter().enumerate() {
            let Some((dist, normal, point)) = part_contact(pa, sa, pb, sb, prediction) else {
                continue;
            };
            if best.is_none_or(|t| dist < t.dist) {
                let u = body_velocity_at(sb, &point) - body_velocity_at(sa, &point);
                best = Some(BodyTouch {
                    parts: (i, j),
                    dist,
                    normal,
                    point,
                    rate: normal.dot(&u),
                });
            }
        }
    }
    best
}

/// A body of a pair search: its colliders, how it moves, and whether its shape turns with it
/// (a centred ball's does not: its spin moves no surface point along any normal).
pub(crate) struct Mover<'a> {
    pub geom: &'a BodyGeom<'a>,
    pub moving: &'a Moving,
    pub turns: bool,
}

/// The search gave up (a glancing approach closing too slowly for the steps allowed).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct BodyStalled;

/// The first time in `[t, t_end]` at which `a` and `b` touch while approaching, with the
/// contact there, `Ok(None)` if they do not, or [`BodyStalled`].
///
/// Conservative advancement on the signed distance (steps of `dist / bound`, where `bound`
/// caps how fast any two surface points can approach over what is left of the interval: the
/// centres' relative speed plus each turning body's angular speed times its bounding radius,
/// cannot step over a touch), then the one root search of a contact time
/// ([`touch_time`]: Newton's method from the outside, regula falsi once an iterate
/// penetrates), to rounding. A pair already touching and approaching at `t` touches at
/// `t`.
pub(crate) fn first_body_touch(
    a: &Mover,
    b: &Mover,
    t: f64,
    t_end: f64,
) -> Result<Option<(f64, BodyTouch)>, BodyStalled> {
    // Touching, for the search, as for a ground (`geometry::first_impact`): within this of
    // each other a touch that separates is stepped over by it, and one that closes is
    // polished to rounding.
    let close = touch_tolerance(a.geom.radius.min(b.geom.radius));
    let bound = |t: f64, sa: &State, sb: &State| {
        let left = (t_end - t).max(0.0);
        let accel = a.moving.motion.accel_bound(sa) + b.moving.motion.accel_bound(sb);
        let turn = |m: &Mover, s: &State| {
            if m.turns {
                m.moving.motion.max_angular_speed(s) * m.geom.radius
            } else {
                0.0
            }
        };
        (sb.v - sa.v).norm() + accel * left + turn(a, sa) + turn(b, sb)
    };
    let states = |t: f64| (a.moving.at(t), b.moving.at(t));
    let at = |t: f64, reach: f64| {
        let (sa, sb) = states(t);
        body_contact(a.geom, &sa, b.geom, &sb, reach)
    };
    let mut t = t;
    for _ in 0..ADVANCE_STEPS {
        let prev = t;
        let (sa, sb) = states(t);
        let speed = bound(t, &sa, &sb);
        if !speed.is_finite() {
            return Err(BodyStalled);
        }
        let reach = speed * (t_end - t) + close;
        let Some(touch) = body_contact(a.geom, &sa, b.geom, &sb, reach) else {
            return Ok(None);
        };
        if touch.dist <= close {
            if touch.rate < 0.0 {
                let (tp, found) = polish(&at, t, touch, t_end);
                if found.rate < 0.0 {
                    return Ok(Some((tp, found)));
                }
                // Newton's step passed a closest approach that never touched (a graze): on
                // from here by the safe step, as for a touch that separates (the polished
                // iterate may lie past a dip of a turning corner).
            }
            // Touching and separating (a graze, or a pair just resolved): step past it.
            t += close.max(touch.dist) / speed.max(BODIES_SPEED_FLOOR);
        } else {
            t += touch.dist / speed.max(BODIES_SPEED_FLOOR);
        }
        if t > t_end {
            // The last step may have passed a touch at the interval's end by a rounding:
            // asked once at the end itself.
            if prev < t_end {
                t = t_end;
                continue;
            }
            return Ok(None);
        }
    }
    Err(BodyStalled)
}

impl Gap for BodyTouch {
    fn gap(&self) -> f64 {
        self.dist
    }
    fn rate(&self) -> f64 {
        self.rate
    }
}

/// [`touch_time`] of two bodies' contact, from `(t, touch)` near touching and approaching:
/// the last iterate outside (or touching), where the normal is the closest-point direction.
fn polish(
    at: &impl Fn(f64, f64) -> Option<BodyTouch>,
    t: f64,
    touch: BodyTouch,
    t_end: f64,
) -> (f64, BodyTouch) {
    let reach = 4.0 * touch.dist.abs() + 1e-6;
    touch_time((t, touch), t_end, |t_new| at(t_new, reach))
}

/// The contact point of an impact between two bodies at a touch, resolved as one impact (as a
/// flat landing on a ground is, see `docs/guide.md`): the points of parry's contact
/// manifold of the two touching parts (for two faces, the corners of their overlap) that lie
/// within `flat_tolerance x` the body's size of the closest one and approach there. Two or
/// more give one impact at their centroid, moved onto the contact plane; otherwise the touch
/// point. Returns the point and the count.
pub(crate) fn touch_point(
    a: &BodyGeom,
    sa: &State,
    b: &BodyGeom,
    sb: &State,
    touch: &BodyTouch,
    flat_tolerance: f64,
) -> (Vector3<f64>, usize) {
    let (pa, pb) = (&a.parts[touch.parts.0], &b.parts[touch.parts.1]);
    if pa.shape.as_ball().is_some() || pb.shape.as_ball().is_some() {
        // A ball touches at one point.
        return (touch.point, 1);
    }
    let (pose_a, pose_b) = (part_pose(pa, sa), part_pose(pb, sb));
    let rel = pose_a.inverse() * pose_b;
    let size = a.radius.min(b.radius);
    let tol = flat_tolerance * size + POSITION_ROUNDING * (1.0 + size);
    let skins = pa.skin + pb.skin;
    let prediction = touch.dist.max(0.0) + skins + tol;
    let Some(found) = manifold_points(pa, pb, &pose_a, &rel, prediction) else {
        return (touch.point, 1);
    };
    // The points, each once: parry clips each face against the other, and two faces'
    // coinciding corners come back from both. Only the points that approach (a tumbling
    // face lands on some corners first), as for a landing on a ground.
    let mut points: Vec<Vector3<f64>> = Vec::new();
    for (dist, _, p1, p2) in found {
        let x = 0.5 * (p1 + p2);
        let u = body_velocity_at(sa, &x) - body_velocity_at(sb, &x);
        let approaching = touch.normal.dot(&u) > 0.0;
        if dist - skins - touch.dist <= tol
            && approaching
            && !points.iter().any(|q| (q - x).norm() <= tol)
        {
            points.push(x);
        }
    }
    if points.len() < 2 {
        return (touch.point, 1);
    }
    let count = points.len();
    let c = points.iter().sum::<Vector3<f64>>() / count as f64;
    // On the contact plane through the touch point.
    (
        c - touch.normal * touch.normal.dot(&(c - touch.point)),
        count,
    )
}
