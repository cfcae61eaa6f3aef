//! Contact geometry along a body's flight, with parry: the signed distance to the grounds,
//! the earliest time of impact inside a step, and the landing points of a flat face.
//!
//! All arithmetic is `f64`; poses are rounded to rapier's precision only to call parry.

use crate::motion::{Flight, State};
use crate::parry::query;
use crate::parry::shape::{PolygonalFeature, Shape, Triangle};
use crate::plugin::bridge::convert::{pose_from_na, to_f64, vec_to_na};
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
    /// The collider's world pose at the start of the step (`pose_at(0)`, kept because a
    /// still ground is asked for it in every query).
    pub pose0: Isometry3<f64>,
    /// Body colliders that have no contact with this ground for the plugin (the pair is
    /// `Filtered`: rapier's filtering or the user's filter refuses it).
    pub skip: Vec<ColliderHandle>,
}

impl GroundGeom<'_> {
    fn com_at(&self, t: f64) -> Vector3<f64> {
        self.com0 + self.v * t
    }

    /// The collider's world pose at time `t` of the step.
    pub fn pose_at(&self, t: f64) -> Isometry3<f64> {
        if self.v == Vector3::zeros() && self.w == Vector3::zeros() {
            return self.pose0;
        }
        // A ground that does not turn: no rotation to compose.
        let rot = if self.w == Vector3::zeros() {
            self.rot0
        } else {
            UnitQuaternion::from_scaled_axis(self.w * t) * self.rot0
        };
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
    // Flat grounds first, without parry: its GJK in f32 misses contacts with very flat
    // shapes (a box 1 mm into a 100 m x 1 cm slab reported beyond 16 cm).
    if let Some(found) = direct_plane_contact(part, ground, s, t) {
        return Ok((found.0 <= prediction).then_some(found));
    }
    let skins = part.skin + ground.skin;
    let pose_g = pose_from_na(&ground.pose_at(t));
    let pose_b = pose_from_na(&part_pose(part, s));
    let Some(c) = query::contact(
        &pose_g,
        ground.shape,
        &pose_b,
        part.shape,
        crate::plugin::bridge::convert::to_real(prediction + skins),
    )?
    else {
        return Ok(None);
    };
    if let Some(plane) = plane_contact(part, ground, s, t, &c) {
        return Ok((plane.0 <= prediction).then_some(plane));
    }
    let n = vec_to_na(c.normal1);
    let norm = n.norm();
    if norm.is_nan() || norm <= 0.5 {
        return Ok(None);
    }
    let n = n / norm;
    let point = vec_to_na(c.point2) - n * part.skin;
    Ok(Some((to_f64(c.dist) - skins, n, point)))
}

/// The contact of a convex body with a flat piece of ground, in `f64`: a half-space, the
/// face of a ground cuboid, or the triangle of a mesh or heightfield that parry's contact
/// `c` found. parry's own normal, from GJK/EPA in rapier's precision, is unreliable for
/// touching shapes against large flat grounds (tens of degrees off for a box exactly on a
/// 100 m slab or mesh in `f32`); the plane's normal is exact. The body's support point
/// towards the plane must lie over the face, else `None` (parry's answer stands).
fn plane_contact(
    part: &BodyPart,
    ground: &GroundGeom,
    s: &State,
    t: f64,
    c: &query::Contact,
) -> Option<PairContact> {
    use crate::parry::shape::TypedShape;
    let first = match ground.shape.as_typed_shape() {
        TypedShape::TriMesh(m) if (c.subshape1 as usize) < m.indices().len() => {
            Some(m.triangle(c.subshape1))
        }
        TypedShape::HeightField(hf) => Some(hf.triangle_at_id(c.subshape1)?),
        TypedShape::TriMesh(_) => return None,
        _ => None,
    };
    match plane_contact_on(part, ground, s, t, vec_to_na(c.point2), first) {
        Ok(found) => Some(found),
        // Over another triangle of the mesh (a body across a diagonal): that one's plane.
        Err(Some(over)) => triangles_under(ground, t, &over)
            .into_iter()
            .find_map(|tri| {
                plane_contact_on(part, ground, s, t, vec_to_na(c.point2), Some(tri)).ok()
            }),
        Err(None) => None,
    }
}

/// [`plane_contact`] located by the body collider's origin instead of parry's contact: the
/// half-space, the ground cuboid's face towards the body, or the mesh or heightfield
/// triangles under it. `None` when the body is not over a face (parry decides then).
fn direct_plane_contact(
    part: &BodyPart,
    ground: &GroundGeom,
    s: &State,
    t: f64,
) -> Option<PairContact> {
    use crate::parry::shape::TypedShape;
    if let Some(ball) = part.shape.as_ball() {
        if let Some(found) = ball_plane_contact(part, to_f64(ball.radius), ground, s, t) {
            return found;
        }
    }
    let center = part_pose(part, s).translation.vector;
    match ground.shape.as_typed_shape() {
        TypedShape::HalfSpace(_) | TypedShape::Cuboid(_) => {
            plane_contact_on(part, ground, s, t, center, None).ok()
        }
        TypedShape::TriMesh(_) | TypedShape::HeightField(_) => triangles_under(ground, t, &center)
            .into_iter()
            .find_map(|tri| plane_contact_on(part, ground, s, t, center, Some(tri)).ok()),
        _ => None,
    }
}

/// [`plane_contact_on`] for a ball on a half-space or a cuboid, with the ball's support
/// point written out (`centre - r n`): the same contact, without the general path's pose
/// compositions and support-map call (most bodies in a ball scene take this path every step
/// they are near the ground). `None`: not such a pair, take the general path; `Some(None)`:
/// the ball is beside the cuboid's nearest face.
fn ball_plane_contact(
    part: &BodyPart,
    radius: f64,
    ground: &GroundGeom,
    s: &State,
    t: f64,
) -> Option<Option<PairContact>> {
    use crate::parry::shape::TypedShape;
    let offset = part.local.translation.vector;
    let centre = if offset == Vector3::zeros() {
        s.com
    } else {
        s.com + s.rot * offset
    };
    let skins = part.skin + ground.skin;
    let pose_g = ground.pose_at(t);
    let (n, height) = match ground.shape.as_typed_shape() {
        TypedShape::HalfSpace(hs) => {
            let n = pose_g.rotation * vec_to_na(hs.normal);
            let len = n.norm();
            if len.is_nan() || len <= 0.0 {
                return Some(None);
            }
            let n = n / len;
            (n, n.dot(&(centre - pose_g.translation.vector)) - radius)
        }
        TypedShape::Cuboid(cb) => {
            let half = vec_to_na(cb.half_extents);
            let p = pose_g
                .inverse_transform_point(&nalgebra::Point3::from(centre))
                .coords;
            let (axis, nl) = cuboid_face(&p, &half);
            let tol = 1e-6 * (1.0 + centre.norm());
            if !(0..3).all(|i| i == axis || p[i].abs() <= half[i] + tol) {
                return Some(None);
            }
            (pose_g.rotation * nl, p[axis].abs() - half[axis] - radius)
        }
        _ => return None,
    };
    let support = centre - n * radius;
    Some(Some((height - skins, n, support - n * part.skin)))
}

/// The face of a cuboid of half extents `half` that a point `p` (in the cuboid's frame) is
/// furthest out of, relative to the half extents: its axis and outward unit normal.
fn cuboid_face(p: &Vector3<f64>, half: &Vector3<f64>) -> (usize, Vector3<f64>) {
    let axis = (0..3)
        .max_by(|i, j| (p[*i].abs() / half[*i]).total_cmp(&(p[*j].abs() / half[*j])))
        .unwrap_or(1);
    let mut n = Vector3::zeros();
    n[axis] = if p[axis] < 0.0 { -1.0 } else { 1.0 };
    (axis, n)
}

/// The mesh or heightfield triangles under the world point `p` at time `t`: the closest
/// triangle of a mesh, the two of a heightfield cell.
fn triangles_under(ground: &GroundGeom, t: f64, p: &Vector3<f64>) -> Vec<Triangle> {
    use crate::parry::query::PointQueryWithLocation;
    use crate::parry::shape::TypedShape;
    let pose_g = ground.pose_at(t);
    let local = pose_g
        .inverse_transform_point(&nalgebra::Point3::from(*p))
        .coords;
    let local = crate::plugin::bridge::convert::vec_from_na(&local);
    match ground.shape.as_typed_shape() {
        TypedShape::TriMesh(m) => {
            let id = m.project_local_point_and_get_location(local, false).1.0;
            vec![m.triangle(id)]
        }
        TypedShape::HeightField(hf) => match hf.cell_at_point(local) {
            Some((i, j)) => {
                let (a, b) = hf.triangles_at(i, j);
                a.into_iter().chain(b).collect()
            }
            None => Vec::new(),
        },
        _ => Vec::new(),
    }
}

/// [`plane_contact`] on one face (`triangle` for meshes and heightfields). `Err(Some(p))`:
/// the body's support point projects to `p`, outside that face; `Err(None)`: no flat face.
fn plane_contact_on(
    part: &BodyPart,
    ground: &GroundGeom,
    s: &State,
    t: f64,
    locator: Vector3<f64>,
    triangle: Option<Triangle>,
) -> Result<PairContact, Option<Vector3<f64>>> {
    use crate::parry::shape::TypedShape;
    let pose_g = ground.pose_at(t);
    let local = |v: Vector3<f64>| pose_g.rotation * v;
    let at = |v: Vector3<f64>| (pose_g * nalgebra::Point3::from(v)).coords;
    let body_point = locator;
    // The plane (world normal, world point) and the face's bounds.
    enum Face {
        Unbounded,
        Rect { axis: usize, half: Vector3<f64> },
        Tri([Vector3<f64>; 3]),
    }
    let (n, q, face) = match ground.shape.as_typed_shape() {
        TypedShape::HalfSpace(hs) => (
            local(vec_to_na(hs.normal)),
            at(Vector3::zeros()),
            Face::Unbounded,
        ),
        TypedShape::Cuboid(cb) => {
            let half = vec_to_na(cb.half_extents);
            let p = pose_g
                .inverse_transform_point(&nalgebra::Point3::from(body_point))
                .coords;
            let (axis, nl) = cuboid_face(&p, &half);
            (local(nl), at(nl * half[axis]), Face::Rect { axis, half })
        }
        TypedShape::TriMesh(_) | TypedShape::HeightField(_) => {
            let tri = triangle.ok_or(None)?;
            let v = [
                at(vec_to_na(tri.a)),
                at(vec_to_na(tri.b)),
                at(vec_to_na(tri.c)),
            ];
            ((v[1] - v[0]).cross(&(v[2] - v[0])), v[0], Face::Tri(v))
        }
        _ => return Err(None),
    };
    let len = n.norm();
    if len.is_nan() || len <= 0.0 {
        return Err(None);
    }
    let mut n = n / len;
    let pose_b = part_pose(part, s);
    if matches!(face, Face::Tri(_)) && n.dot(&(pose_b.translation.vector - q)) < 0.0 {
        // A mesh triangle has no outside: the body's side is.
        n = -n;
    }
    let support = match part.shape.as_ball() {
        // Written out in `f64`, as `ball_plane_contact` does: parry's support map takes the
        // direction in rapier's precision, which moves a ball on a mesh by nanometres from
        // one triangle to the next.
        Some(ball) => pose_b.translation.vector - n * to_f64(ball.radius),
        None => {
            let sm = part.shape.as_support_map().ok_or(None)?;
            let dir_local = pose_b.rotation.inverse() * (-n);
            let support_local = vec_to_na(
                sm.local_support_point(crate::plugin::bridge::convert::vec_from_na(&dir_local)),
            );
            (pose_b * nalgebra::Point3::from(support_local)).coords
        }
    };
    let height = n.dot(&(support - q));
    let over = support - n * height;
    let tol = 1e-6 * (1.0 + body_point.norm());
    let inside = match face {
        Face::Unbounded => true,
        Face::Rect { axis, half } => {
            let p = pose_g
                .inverse_transform_point(&nalgebra::Point3::from(over))
                .coords;
            (0..3).all(|i| i == axis || p[i].abs() <= half[i] + tol)
        }
        Face::Tri(v) => {
            let inside_edge = |a: &Vector3<f64>, b: &Vector3<f64>| {
                n.dot(&(b - a).cross(&(over - a))) >= -tol * (b - a).norm()
            };
            let ccw = n.dot(&(v[1] - v[0]).cross(&(v[2] - v[0]))) > 0.0;
            let (a, b, c3) = if ccw {
                (v[0], v[1], v[2])
            } else {
                (v[0], v[2], v[1])
            };
            inside_edge(&a, &b) && inside_edge(&b, &c3) && inside_edge(&c3, &a)
        }
    };
    if !inside {
        return Err(Some(over).filter(|_| matches!(face, Face::Tri(_))));
    }
    let skins = part.skin + ground.skin;
    Ok((height - skins, n, support - n * part.skin))
}

/// The first time in `(0, dt]` at which `touches` holds, for a body moving smoothly along
/// one closed-form path (a rolling ball): `touches` is asked at `TOUCH_SAMPLES` evenly
/// spaced times and the first touch bisected to rounding. A path that grazes a ground
/// between two samples is not found: the caller's end check must catch it.
pub(crate) fn earliest_touch(dt: f64, touches: impl Fn(f64) -> bool) -> Option<f64> {
    let mut lo = 0.0;
    for i in 1..=TOUCH_SAMPLES {
        let t = dt * i as f64 / TOUCH_SAMPLES as f64;
        if touches(t) {
            let mut hi = t;
            // 64 halvings take a step's interval to rounding (f64's 53 bits and margin).
            for _ in 0..64 {
                let mid = 0.5 * (lo + hi);
                if mid <= lo || mid >= hi {
                    break;
                }
                if touches(mid) {
                    hi = mid;
                } else {
                    lo = mid;
                }
            }
            return Some(hi);
        }
        lo = t;
    }
    None
}

/// How many times in the step [`earliest_touch`] asks: a rolling ball moves straight or nearly
/// (its path bows by under `(|a_t| + mu g_n) dt^2 / 8`), so it meets a plane or a cuboid's
/// face once, and a sample every 16th of a step finds it.
const TOUCH_SAMPLES: usize = 16;

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
            if ground.skip.contains(&part.handle) {
                continue;
            }
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

/// How close to a ground [`first_impact`] counts as touching (m), for a body of `radius`.
pub(crate) fn close_tolerance(radius: f64) -> f64 {
    (1e-3 * radius).clamp(1e-7, 1e-3)
}

/// Is every query of `part` against `ground` over a flight from `s` in which every point of
/// the body moves at most `travel` the direct plane query of one face, with the body's support
/// point over it? For a ground that does not move (no velocity): a half-space, or a cuboid
/// whose face the direct query picks stays picked and under the body wherever it goes (the
/// part's origin within `travel` plus its offset turning, the support point within `radius`
/// of the centre of mass). The part must have a support map.
pub(crate) fn flat_throughout(
    part: &BodyPart,
    ground: &GroundGeom,
    s: &State,
    travel: f64,
    radius: f64,
) -> bool {
    ground.v == Vector3::zeros() && flat_relative(part, ground, s, travel, radius)
}

/// [`flat_throughout`] for a ground that may translate (without turning), with `travel`
/// measured relative to it: in the ground's frame the ground is still and the body moves by
/// its velocity relative to it.
pub(crate) fn flat_relative(
    part: &BodyPart,
    ground: &GroundGeom,
    s: &State,
    travel: f64,
    radius: f64,
) -> bool {
    use crate::parry::shape::TypedShape;
    if ground.w != Vector3::zeros()
        || part.shape.as_support_map().is_none()
        || !(travel.is_finite() && radius.is_finite())
    {
        return false;
    }
    match ground.shape.as_typed_shape() {
        TypedShape::HalfSpace(_) => true,
        TypedShape::Cuboid(cb) => {
            let pose_g = ground.pose_at(0.0);
            let to_local = |p: Vector3<f64>| {
                pose_g
                    .inverse_transform_point(&nalgebra::Point3::from(p))
                    .coords
            };
            let origin_w = part_pose(part, s).translation.vector;
            let origin = to_local(origin_w);
            let com = to_local(s.com);
            let r_o = travel + 2.0 * (origin_w - s.com).norm();
            let half = vec_to_na(cb.half_extents);
            // The face plane_contact_on picks.
            let (axis, _) = cuboid_face(&origin, &half);
            let lead = (origin[axis].abs() - r_o) / half[axis];
            lead > 0.0
                && (0..3).filter(|i| *i != axis).all(|i| {
                    (origin[i].abs() + r_o) / half[i] < lead
                        && com[i].abs() + travel + radius < half[i]
                })
        }
        _ => false,
    }
}

/// Largest height difference (m) between two grounds' faces for a ball to roll from one to the
/// other as on one plane: below rapier's contact tolerances, and above the rounding of `f32`
/// poses of flush cuboids a few metres from the origin (about 5e-7 m).
pub(crate) const COPLANAR_TOLERANCE: f64 = 1e-6;

/// Cosine of the largest angle between two faces' normals for them to count as one plane:
/// the rounding of one rotation stored twice in `f32`.
const COPLANAR_COS: f64 = 1.0 - 1e-12;

/// The plane under a rolling ball, and the part of space the ball can reach in the step: what
/// decides whether a ground is a piece of that plane ([`plane_piece_of`], [`one_plane_under`]).
#[derive(Clone, Copy, Debug)]
pub(crate) struct PlaneNear {
    /// Unit normal, out of the grounds.
    pub n: Vector3<f64>,
    /// `n . x` of the plane's points: the grounds' faces plus their contact skins.
    pub height: f64,
    /// The ball's centre at the step's start.
    pub centre: Vector3<f64>,
    /// How far from `centre` a point of the ball can get in the step (m): its radius, its
    /// travel and its path's bow.
    pub reach: f64,
}

/// Does the plane `plane` carry a ball rolling from `p` straight to `q` (contact points, both
/// on it) across the still grounds `grounds`, as one flat face would? Each ground must be a
/// piece of the plane ([`plane_piece_of`]: a ball resting on the plane then touches it only at
/// its contact point, whatever edges lie under it), and their faces must cover the path `p..q`
/// and `margin` around it (the path bows from its chord by less: the caller's bound). A flush
/// seam between two floor tiles passes, and so does a flat stretch of a mesh across its
/// triangles' edges; a gap, a step, a bump, or a tile's outer edge within the path does not.
pub(crate) fn one_plane_under(
    grounds: &[&GroundGeom],
    plane: &PlaneNear,
    p: &Vector3<f64>,
    q: &Vector3<f64>,
    margin: f64,
) -> bool {
    let Some(pieces) = grounds
        .iter()
        .map(|g| plane_piece(g, plane))
        .collect::<Option<Vec<_>>>()
    else {
        return false;
    };
    let n = &plane.n;
    // The path lies within `margin` of its chord: the chord and its two parallels at
    // `margin` either side in the plane, each lengthened by `margin` at both ends, must be
    // covered (for faces tiling the plane, that covers the band between them).
    let chord = q - p;
    let length = chord.norm();
    let ahead = if length > 0.0 {
        chord / length
    } else {
        n.cross(&Vector3::x())
            .try_normalize(0.0)
            .unwrap_or_else(|| n.cross(&Vector3::y()).normalize())
    };
    let side = n.cross(&ahead) * margin;
    let (from, to) = (p - ahead * margin, q + ahead * margin);
    [Vector3::zeros(), side, -side]
        .iter()
        .all(|offset| pieces_cover(&pieces, n, &(from + offset), &(to + offset)))
}

/// A ground as a piece of a plane (see [`one_plane_under`]).
enum PlanePiece {
    /// A half-space: all of the plane.
    Everywhere,
    /// A cuboid's face in the plane: the cuboid's pose, half extents, and the axis normal
    /// to the face.
    Face {
        pose: Isometry3<f64>,
        half: Vector3<f64>,
        axis: usize,
    },
    /// A mesh's or heightfield's triangles in the plane within the ball's reach (world
    /// vertices); every other triangle within it lies below the plane.
    Triangles(Vec<[Vector3<f64>; 3]>),
}

/// `ground` as a piece of `plane`: a still ground lying wholly below the plane with a face in
/// it (a half-space, a cuboid), or a still mesh or heightfield whose triangles within the
/// ball's reach all lie below the plane; `None` for any other ground.
fn plane_piece(ground: &GroundGeom, plane: &PlaneNear) -> Option<PlanePiece> {
    use crate::parry::shape::TypedShape;
    if ground.v != Vector3::zeros() || ground.w != Vector3::zeros() {
        return None;
    }
    let (n, height) = (&plane.n, plane.height);
    let pose = ground.pose0;
    match ground.shape.as_typed_shape() {
        TypedShape::HalfSpace(hs) => {
            let normal = pose.rotation * vec_to_na(hs.normal);
            let top = pose.translation.vector.dot(n) + ground.skin;
            (normal.dot(n) >= COPLANAR_COS && (top - height).abs() <= COPLANAR_TOLERANCE)
                .then_some(PlanePiece::Everywhere)
        }
        TypedShape::Cuboid(cb) => {
            let half = vec_to_na(cb.half_extents);
            let n_local = pose.rotation.inverse() * n;
            let axis = (0..3)
                .max_by(|i, j| n_local[*i].abs().total_cmp(&n_local[*j].abs()))
                .unwrap_or(1);
            let top = pose.translation.vector.dot(n)
                + (0..3).map(|i| half[i] * n_local[i].abs()).sum::<f64>()
                + ground.skin;
            (n_local[axis].abs() >= COPLANAR_COS && (top - height).abs() <= COPLANAR_TOLERANCE)
                .then_some(PlanePiece::Face { pose, half, axis })
        }
        TypedShape::TriMesh(_) | TypedShape::HeightField(_) => {
            let mut flat = Vec::new();
            let mut below = true;
            triangles_near(ground, &plane.centre, plane.reach, &mut |v| {
                let above = v.map(|x| x.dot(n) + ground.skin - height);
                if above.iter().any(|h| *h > COPLANAR_TOLERANCE) {
                    below = false;
                } else if above.iter().all(|h| h.abs() <= COPLANAR_TOLERANCE) {
                    let normal = (v[1] - v[0]).cross(&(v[2] - v[0]));
                    if normal.norm() > 0.0 && normal.normalize().dot(n).abs() >= COPLANAR_COS {
                        flat.push(v);
                    }
                }
            });
            below.then_some(PlanePiece::Triangles(flat))
        }
        _ => None,
    }
}

/// Calls `f` with the world vertices of every triangle of the still mesh or heightfield
/// `ground` whose bounding box meets the cube of half side `reach` around `centre`.
fn triangles_near(
    ground: &GroundGeom,
    centre: &Vector3<f64>,
    reach: f64,
    f: &mut impl FnMut([Vector3<f64>; 3]),
) {
    use crate::parry::bounding_volume::Aabb;
    use crate::parry::shape::TypedShape;
    let pose = ground.pose0;
    // A ball's reach is a sphere: its box in the ground's frame is the same cube.
    let local = pose
        .inverse_transform_point(&nalgebra::Point3::from(*centre))
        .coords;
    let r = Vector3::repeat(reach);
    let aabb = Aabb::new(
        crate::plugin::bridge::convert::vec_from_na(&(local - r)),
        crate::plugin::bridge::convert::vec_from_na(&(local + r)),
    );
    let mut world = |tri: &Triangle| {
        f([tri.a, tri.b, tri.c].map(|x| (pose * nalgebra::Point3::from(vec_to_na(x))).coords));
    };
    match ground.shape.as_typed_shape() {
        TypedShape::TriMesh(m) => {
            for id in m.bvh().intersect_aabb(&aabb) {
                world(&m.triangle(id));
            }
        }
        TypedShape::HeightField(hf) => {
            hf.map_elements_in_local_aabb(&aabb, &mut |_, tri| world(tri))
        }
        _ => {}
    }
}

/// Is `ground` a piece of `plane` (a still half-space or cuboid wholly below it with a face in
/// it, or a still mesh or heightfield with every triangle within the ball's reach below it)?
/// A ball on the plane touches such a ground only at its contact point.
pub(crate) fn plane_piece_of(ground: &GroundGeom, plane: &PlaneNear) -> bool {
    plane_piece(ground, plane).is_some()
}

/// [`one_plane_under`] for one straight path `p..q` over the pieces of one plane.
fn pieces_cover(
    pieces: &[PlanePiece],
    n: &Vector3<f64>,
    p: &Vector3<f64>,
    q: &Vector3<f64>,
) -> bool {
    let mut covered: Vec<(f64, f64)> = Vec::with_capacity(pieces.len());
    for piece in pieces {
        match piece {
            PlanePiece::Everywhere => covered.push((0.0, 1.0)),
            PlanePiece::Face { pose, half, axis } => {
                // The path's stretch over the face, by its two in-plane axes.
                let (a, b) = (
                    pose.inverse_transform_point(&nalgebra::Point3::from(*p))
                        .coords,
                    pose.inverse_transform_point(&nalgebra::Point3::from(*q))
                        .coords,
                );
                let (mut lo, mut hi) = (0.0f64, 1.0f64);
                for i in (0..3).filter(|i| i != axis) {
                    let d = b[i] - a[i];
                    if d == 0.0 {
                        if a[i].abs() > half[i] {
                            hi = -1.0;
                        }
                        continue;
                    }
                    let (t1, t2) = ((-half[i] - a[i]) / d, (half[i] - a[i]) / d);
                    lo = lo.max(t1.min(t2));
                    hi = hi.min(t1.max(t2));
                }
                if lo <= hi {
                    covered.push((lo, hi));
                }
            }
            PlanePiece::Triangles(triangles) => {
                for v in triangles {
                    if let Some(stretch) = stretch_over_triangle(v, n, p, q) {
                        covered.push(stretch);
                    }
                }
            }
        }
    }
    // The stretches must join up from 0 to 1; faces apart by less than `COPLANAR_TOLERANCE`
    // (the rounding of a shared edge computed from two faces) join.
    let slack = COPLANAR_TOLERANCE / (q - p).norm().max(COPLANAR_TOLERANCE);
    covered.sort_by(|x, y| x.0.total_cmp(&y.0));
    let mut reached = 0.0;
    for (lo, hi) in covered {
        if lo > reached + slack {
            return false;
        }
        reached = f64::max(reached, hi);
    }
    reached >= 1.0
}

/// The stretch `(lo, hi)` of the path `p + s (q - p)`, `s` in 0..1, over the triangle `v`
/// (in the plane of normal `n`, as the path), by its three edges; `None` if it misses it or
/// the triangle has no area.
fn stretch_over_triangle(
    v: &[Vector3<f64>; 3],
    n: &Vector3<f64>,
    p: &Vector3<f64>,
    q: &Vector3<f64>,
) -> Option<(f64, f64)> {
    let (mut lo, mut hi) = (0.0f64, 1.0f64);
    for i in 0..3 {
        let (a, b, c) = (v[i], v[(i + 1) % 3], v[(i + 2) % 3]);
        // The edge's normal in the plane, towards the third vertex.
        let mut inward = n.cross(&(b - a));
        let to_c = inward.dot(&(c - a));
        if to_c == 0.0 {
            return None;
        }
        if to_c < 0.0 {
            inward = -inward;
        }
        // inward . (p - a) + s inward . (q - p) >= 0
        let (at0, rate) = (inward.dot(&(p - a)), inward.dot(&(q - p)));
        if rate == 0.0 {
            if at0 < 0.0 {
                return None;
            }
            continue;
        }
        let s = -at0 / rate;
        if rate > 0.0 {
            lo = lo.max(s);
        } else {
            hi = hi.min(s);
        }
    }
    (lo <= hi).then_some((lo, hi))
}

/// [`first_impact`] in closed form for a ball (one collider, a ball centred on the centre of
/// mass, so its rotation does not move it) without linear damping against grounds whose
/// every query over the flight is one face's plane ([`flat_throughout`]) and towards which
/// the acceleration does not point (`n.a <= 0`: a concave gap, so the approach, once
/// started, ends on the ground): the gap to each plane is `d + un t + an t^2 / 2`, exactly,
/// and the impact is its downward root. `None` where that does not apply, or where the
/// search could decide otherwise (a start inside a ground and separating; a contact within
/// the touching tolerance at the end of the interval): the search then runs.
fn ball_on_flat(
    body: &BodyGeom,
    grounds: &[GroundGeom],
    flight: &Flight,
    s0: &State,
    t0: f64,
    t_from: f64,
    t_to: f64,
) -> Option<Search> {
    let [part] = &body.parts[..] else {
        return None;
    };
    if part.shape.as_ball().is_none()
        || part.local.translation.vector != Vector3::zeros()
        || flight.linear_damping != 0.0
        || t_from != t0
        || t_to < t_from
        || t_to.is_nan()
    {
        return None;
    }
    let span = t_to - t0;
    let travel = flight.max_speed(s0, span) * span;
    let close = close_tolerance(body.radius);
    let center = s0.com;
    let mut first: Option<f64> = None;
    for ground in grounds {
        if ground.skip.contains(&part.handle) {
            continue;
        }
        if !flat_throughout(part, ground, s0, travel, body.radius) {
            return None;
        }
        let (d, n, _) = plane_contact_on(part, ground, s0, t0, center, None).ok()?;
        let (vn, an) = (n.dot(&s0.v), n.dot(&flight.accel));
        if an > 0.0 || !an.is_finite() || !d.is_finite() || !vn.is_finite() {
            return None;
        }
        // The downward root of `d + vn t + an t^2 / 2`, if any.
        let root = if d < 0.0 {
            if vn < 0.0 {
                0.0
            } else {
                return None;
            }
        } else if an == 0.0 {
            if vn < 0.0 { d / -vn } else { continue }
        } else {
            let sq = (vn * vn - 2.0 * an * d).sqrt();
            if vn < 0.0 {
                2.0 * d / (sq - vn)
            } else {
                (vn + sq) / -an
            }
        };
        if root > span || root.is_nan() {
            // No impact in the interval, unless within the touching tolerance at its end.
            if d + vn * span + 0.5 * an * span * span <= close {
                return None;
            }
            continue;
        }
        first = Some(first.map_or(root, |f: f64| f.min(root)));
    }
    let Some(tau) = first else {
        return Some(Search::Clear);
    };
    let t = t0 + tau;
    let s = flight.advance(s0, tau);
    let h = closest(body, grounds, &s, t, close)?;
    (h.un < 0.0).then_some(Search::Hit(t, s, h))
}

/// Can the pair provably not meet in `[0, dt]` of the flight from `s`, so that
/// [`first_impact`] would find it `Clear`? `(dist, n)`: the pair's contact at `s` (signed
/// distance, normal); `radius`: the body's; `speed`: the body's approach bound over the step
/// (`Flight::max_speed + Flight::max_angular_speed x radius`, as [`approach_bound`] for a
/// fixed ground).
///
/// Only for a ground that does not move (no velocity) and is a half-space, or a cuboid whose
/// face under the part stays the face the direct query picks, with the body's support point
/// over it, wherever the part goes in the step: every query of the search is then the direct
/// plane query, and for a convex ground the gap along the face normal (translation of the
/// centre of mass, less what the rotation can bring any point of the body closer) bounds the
/// distance from below. `true` when that bound stays above the search's touching tolerance
/// over the whole step, by enough that the conservative advancement crosses the step in well
/// under its step limit.
#[allow(clippy::too_many_arguments)]
pub(crate) fn cannot_close(
    part: &BodyPart,
    ground: &GroundGeom,
    flight: &Flight,
    s: &State,
    dt: f64,
    (dist, n): (f64, Vector3<f64>),
    radius: f64,
    speed: f64,
) -> bool {
    if !(dt >= 0.0 && speed.is_finite() && radius.is_finite() && dist.is_finite()) {
        return false;
    }
    // Any point of the body moves at most this far in the step.
    let travel = speed.max(1e-9) * dt;
    if !flat_throughout(part, ground, s, travel, radius) {
        return false;
    }
    // The lowest the centre of mass's flight goes along `n` in the step:
    // `n.(v phi1 + a phi2)`, with `phi1 = t` and `phi2 = t^2 / 2` undamped, and
    // `0 <= phi1 <= t`, `0 <= phi2 <= t^2 / 2` under damping.
    let (vn, an) = (n.dot(&s.v), n.dot(&flight.accel));
    let sink = if flight.linear_damping == 0.0 {
        let at = |t: f64| vn * t + 0.5 * an * t * t;
        let mut low = at(dt).min(0.0);
        if an > 0.0 && vn < 0.0 && -vn / an < dt {
            low = low.min(at(-vn / an));
        }
        low
    } else {
        vn.min(0.0) * dt + 0.5 * an.min(0.0) * dt * dt
    };
    let turn = flight.max_angular_speed(s) * dt * radius;
    let rounding = 1e-9 * (1.0 + s.com.norm() + dist.abs());
    let low = dist + sink - turn - rounding;
    low > close_tolerance(radius) && travel <= 256.0 * low
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
    let body_bound = lin + flight.max_angular_speed(s0) * body.radius;
    let travel = lin * span + body.radius;
    let ground_bound = grounds
        .iter()
        .map(|g| g.max_speed((s0.com - g.com_at(t0)).norm() + travel))
        .fold(0.0, f64::max);
    (body_bound + ground_bound).max(1e-9)
}

/// What the search for the next impact found.
pub(crate) enum Search {
    /// A contact at this time, with the state there and the contact.
    Hit(f64, State, Hit),
    /// No contact until the end of the interval.
    Clear,
    /// The search gave up at this time (a body spinning fast against the ground can need
    /// thousands of conservative steps); the state there touches no ground.
    Stalled(f64, State),
}

/// The earliest time in `[t_from, t_to]` at which the body, flying from `s0` (its state at
/// `t0 <= t_from`), touches a ground while approaching it.
///
/// Conservative advancement (steps of `dist / bound`, which cannot pass a contact) brings
/// the body within `close` of the ground; Newton's method and regula falsi on the signed
/// distance, whose time derivative is the normal velocity `un` at the contact point, then
/// find the contact time to rounding. A touching contact that separates is stepped over.
#[allow(clippy::too_many_arguments)]
pub(crate) fn first_impact(
    body: &BodyGeom,
    grounds: &[GroundGeom],
    flight: &Flight,
    s0: &State,
    t0: f64,
    t_from: f64,
    t_to: f64,
) -> Search {
    const MAX_ADVANCE: usize = 512;
    if let Some(found) = ball_on_flat(body, grounds, flight, s0, t0, t_from, t_to) {
        return found;
    }
    let bound = approach_bound(body, grounds, flight, s0, t0, t_to - t0);
    let close = close_tolerance(body.radius);
    let mut t = t_from;
    let mut last = (t, flight.advance(s0, t - t0));
    for _ in 0..MAX_ADVANCE {
        let s = flight.advance(s0, t - t0);
        let reach = bound * (t_to - t) + close;
        let Some(h) = closest(body, grounds, &s, t, reach) else {
            return Search::Clear;
        };
        if h.dist <= close {
            if h.un < 0.0 {
                let (t, s, h) = polish(body, grounds, flight, s0, t0, (t_from, t_to), t, s, h);
                return Search::Hit(t, s, h);
            }
            if h.dist >= 0.0 {
                last = (t, s);
            }
            t += close.max(h.dist) / bound;
        } else {
            last = (t, s);
            t += h.dist / bound;
        }
        if t > t_to {
            return Search::Clear;
        }
    }
    Search::Stalled(last.0, last.1)
}

/// The contact time to rounding, from `(t, h)` at most `close` from the ground, within
/// `range`: Newton's method on the signed distance (its time derivative is `un`) until an
/// iterate penetrates, then regula falsi (Illinois) on the bracket. Returns the last iterate
/// on the outside (`dist >= 0`): there the normal is the closest-point direction, well
/// defined even against a single triangle of a mesh, where a penetration normal may point
/// sideways through the triangle's edge.
#[allow(clippy::too_many_arguments)]
fn polish(
    body: &BodyGeom,
    grounds: &[GroundGeom],
    flight: &Flight,
    s0: &State,
    t0: f64,
    range: (f64, f64),
    t: f64,
    s: State,
    h: Hit,
) -> (f64, State, Hit) {
    if h.dist < 0.0 {
        // Already inside at the start of the search: the impact is now.
        return (t, s, h);
    }
    let mut out = (t, s, h);
    // Bracket ends for regula falsi: distances as used (Illinois halves a stale one), and the
    // penetrating end once found.
    let mut d_a = h.dist;
    let mut inside: Option<(f64, f64)> = None;
    let mut last_side = 0i8; // +1: the last iterate was outside, -1: inside
    let reach = 4.0 * h.dist + 1e-3 * body.radius + 1e-9;
    for _ in 0..48 {
        let t_a = out.0;
        if out.2.dist == 0.0 {
            break;
        }
        let t_new = match inside {
            None if out.2.un < 0.0 => (t_a + out.2.dist / -out.2.un).min(range.1),
            None => break,
            Some((t_b, d_b)) => t_a + d_a * (t_b - t_a) / (d_a - d_b),
        };
        if t_new.is_nan() || t_new <= t_a || (t_new - t_a) <= 1e-15 * (1.0 + t_a.abs()) {
            break;
        }
        let s_new = flight.advance(s0, t_new - t0);
        let Some(h_new) = closest(body, grounds, &s_new, t_new, reach) else {
            break;
        };
        if h_new.dist >= 0.0 {
            out = (t_new, s_new, h_new);
            d_a = h_new.dist;
            if let (Some((_, d_b)), 1) = (inside.as_mut(), last_side) {
                *d_b *= 0.5;
            }
            last_side = 1;
        } else {
            if inside.is_some() && last_side == -1 {
                d_a *= 0.5;
            }
            inside = Some((t_new, h_new.dist));
            last_side = -1;
        }
        if let Some((t_b, _)) = inside {
            if t_b - out.0 <= 1e-15 * (1.0 + t_b.abs()) {
                break;
            }
        }
    }
    out
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
    pfm.local_support_feature(
        crate::plugin::bridge::convert::vec_from_na(&dir_local),
        &mut feature,
    );
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
