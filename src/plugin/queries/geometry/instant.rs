//! The contact of a body part with a ground at one instant: the signed distance, normal and
//! point, in `f64` against flat faces (a half-space, a cuboid's face, a mesh's or
//! heightfield's triangle) and from parry otherwise, and the closest contact over a body's
//! parts and the grounds.

use super::{BodyGeom, BodyPart, GroundGeom, Hit, PairContact, part_pose};
use crate::motion::State;
use crate::parry::query;
use crate::parry::shape::Triangle;
use crate::plugin::bridge::convert::{pose_from_na, to_f64, vec_to_na};
use crate::plugin::policy::FACE_ROUNDING;
use crate::plugin::queries::ground_index::half_space_unit_normal;
use nalgebra::Vector3;

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
    // Flat grounds first, without parry: a flat face's contact is exact in `f64`, where
    // parry's GJK in `f32` can report a thin, wide ground's penetrating contact as a gap.
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
/// touching shapes against large flat grounds (in `f32` it can tilt far from the face's
/// normal); the plane's normal is exact. The body's support point
/// towards the plane must lie over the face, else `None` (parry's answer stands).
///
/// A cuboid's face is the one the body's contact point is out of, unless that face's normal
/// is more than 45 degrees from parry's (`FACE_AGREES_COS`): then the contact point lies
/// inside the cuboid nearer another face than the one the body is out of (the deepest point
/// of a body that pierced a thin plate, beyond the far face; a corner that went in at the
/// top just inside a side), and the face is the one parry's normal leaves by.
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
    let parry_normal = vec_to_na(c.normal1);
    match plane_contact_on(part, ground, s, t, vec_to_na(c.point2), first) {
        Ok(found) if first.is_none() && found.1.dot(&parry_normal) < FACE_AGREES_COS => {
            let locator = cuboid_face_along(ground, t, &parry_normal)?;
            plane_contact_on(part, ground, s, t, locator, None).ok()
        }
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
    let poses = Poses::at(part, ground, s, t);
    let center = poses.part.translation.vector;
    match ground.shape.as_typed_shape() {
        TypedShape::Cuboid(cb) => {
            let half = vec_to_na(cb.half_extents);
            let local = poses
                .ground
                .inverse_transform_point(&nalgebra::Point3::from(center))
                .coords;
            if (0..3).filter(|i| local[*i].abs() > half[*i]).count() >= 2 {
                return edge_plane_contact(part, ground, &poses, (&local, &half));
            }
            let locator = Locator::known(center, local);
            plane_contact_with(part, ground, &poses, locator, None, true).ok()
        }
        TypedShape::HalfSpace(_) => {
            let locator = Locator::facing(center, None);
            plane_contact_with(part, ground, &poses, locator, None, true).ok()
        }
        TypedShape::TriMesh(_) | TypedShape::HeightField(_) => triangles_under(ground, t, &center)
            .into_iter()
            .find_map(|tri| {
                let locator = Locator::facing(center, None);
                plane_contact_with(part, ground, &poses, locator, Some(tri), true).ok()
            }),
        _ => None,
    }
}

/// [`direct_plane_contact`] for a body whose centre (`local`, in the frame of a cuboid
/// ground of half extents `half`) lies beyond the planes of two or three of its faces, past
/// an edge or a corner. No one face is the body's there: a plank sliding off a table's edge
/// has its centre beyond the side and above the top, its far end over neither. Each face
/// whose plane has the centre in front stands only where the body's deepest point towards it
/// lies over the face and, if behind it, within the cuboid's thickness and no nearer another
/// such face than this one (a point a rounding under the top, half a metre in from the side,
/// came in by the top: met on the side, the plank would be pushed out across its length).
/// Of the faces that stand, the one the body is least deep behind; `None` if none stands
/// (parry decides).
fn edge_plane_contact(
    part: &BodyPart,
    ground: &GroundGeom,
    poses: &Poses,
    (local, half): (&Vector3<f64>, &Vector3<f64>),
) -> Option<PairContact> {
    let pose_g = &poses.ground;
    let tol = FACE_ROUNDING * (1.0 + local.norm());
    let mut best: Option<PairContact> = None;
    for axis in (0..3).filter(|i| local[*i].abs() > half[*i]) {
        let mut out = Vector3::zeros();
        out[axis] = 2.0 * half[axis].copysign(local[axis]);
        let locator = Locator::known((pose_g * nalgebra::Point3::from(out)).coords, out);
        let Ok(found) = plane_contact_with(part, ground, poses, locator, None, true) else {
            continue;
        };
        // The deepest point (the contact's point, back out by the part's skin) in the
        // cuboid's frame, and how deep it is behind this face.
        let deepest = pose_g
            .inverse_transform_point(&nalgebra::Point3::from(found.2 + found.1 * part.skin))
            .coords;
        let depth = half[axis] - deepest[axis] * local[axis].signum();
        let stands = depth <= 0.0
            || (depth <= 2.0 * half[axis] + tol
                && (0..3).all(|i| {
                    i == axis
                        || local[i].abs() <= half[i]
                        || half[i] - deepest[i].abs() >= depth - tol
                }));
        if stands && best.is_none_or(|b| found.0 > b.0) {
            best = Some(found);
        }
    }
    best
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
    let (n, height) = match ground.shape.as_typed_shape() {
        // A still half-space: its unit normal kept with its motion, its pose `pose0`.
        TypedShape::HalfSpace(hs) => match ground.motion.still_unit_normal(hs.normal) {
            Some(n) => (
                n,
                n.dot(&(centre - ground.motion.pose0.translation.vector)) - radius,
            ),
            None => {
                let pose_g = ground.pose_at(t);
                let Some(n) = half_space_unit_normal(&pose_g, hs.normal) else {
                    return Some(None);
                };
                (n, n.dot(&(centre - pose_g.translation.vector)) - radius)
            }
        },
        TypedShape::Cuboid(cb) => {
            let pose_g = ground.pose_at(t);
            let half = vec_to_na(cb.half_extents);
            let p = pose_g
                .inverse_transform_point(&nalgebra::Point3::from(centre))
                .coords;
            let (axis, nl) = cuboid_face(&p, &half);
            let tol = FACE_ROUNDING * (1.0 + centre.norm());
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

/// The face of a cuboid of half extents `half` that a point `p` (in the cuboid's frame)
/// belongs to, with its outward unit normal: outside the cuboid, the face it is furthest out
/// of relative to the half extents (over a face, the one it is over); inside, the nearest
/// face, as parry's projection of an inner point takes it. The relative measure inside would
/// send a point near a thin plate's underside to a side face metres away.
pub(super) fn cuboid_face(p: &Vector3<f64>, half: &Vector3<f64>) -> (usize, Vector3<f64>) {
    let inside = (0..3).all(|i| p[i].abs() <= half[i]);
    let axis = if inside {
        (0..3).max_by(|i, j| (p[*i].abs() - half[*i]).total_cmp(&(p[*j].abs() - half[*j])))
    } else {
        (0..3).max_by(|i, j| (p[*i].abs() / half[*i]).total_cmp(&(p[*j].abs() / half[*j])))
    }
    .unwrap_or(1);
    let mut n = Vector3::zeros();
    n[axis] = if p[axis] < 0.0 { -1.0 } else { 1.0 };
    (axis, n)
}

/// The least cosine between parry's contact normal and the normal of the cuboid face the
/// body's contact point locates for that face to stand ([`plane_contact`]): 45 degrees, far
/// beyond the tilt of parry's normal against a flat face, far below the right angle between
/// two faces.
const FACE_AGREES_COS: f64 = std::f64::consts::FRAC_1_SQRT_2;

/// A world point at time `t` that locates (for [`cuboid_face`]) the face of a cuboid ground
/// whose outward normal is nearest the world direction `n`: outside that face's centre, at
/// twice the half extent. `None` for another shape.
fn cuboid_face_along(ground: &GroundGeom, t: f64, n: &Vector3<f64>) -> Option<Vector3<f64>> {
    let half = vec_to_na(ground.shape.as_cuboid()?.half_extents);
    let pose_g = ground.pose_at(t);
    let local = pose_g.rotation.inverse() * n;
    let axis = local.iamax();
    let mut p = Vector3::zeros();
    p[axis] = 2.0 * half[axis].copysign(local[axis]);
    Some((pose_g * nalgebra::Point3::from(p)).coords)
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
pub(super) fn plane_contact_on(
    part: &BodyPart,
    ground: &GroundGeom,
    s: &State,
    t: f64,
    locator: Vector3<f64>,
    triangle: Option<Triangle>,
) -> Result<PairContact, Option<Vector3<f64>>> {
    plane_contact_facing(part, ground, s, t, (locator, None), triangle, true)
}

/// The contact of a body part at `s` with the plane of the face of a flat ground on the side
/// `from` is on (a world point at `t`, where the body was outside the ground): the cuboid's
/// face towards it, the half-space, or the mesh or heightfield triangle under it with its
/// normal turned towards it; the plane extends past the face, as the body may have gone in
/// across the face's edge. A body that went deep into or through a thin ground is then
/// measured from the side it came from, not from the nearest face, which may be the far one.
/// `bounded`: only over the face itself (a body that went through the ground, rather than
/// past its edge). `None`: no flat ground under `from` (or, `bounded`, not over it).
pub(crate) fn contact_from_side(
    part: &BodyPart,
    ground: &GroundGeom,
    s: &State,
    t: f64,
    from: Vector3<f64>,
    bounded: bool,
) -> Option<PairContact> {
    use crate::parry::shape::TypedShape;
    match ground.shape.as_typed_shape() {
        TypedShape::HalfSpace(_) | TypedShape::Cuboid(_) => {
            plane_contact_facing(part, ground, s, t, (from, Some(from)), None, bounded).ok()
        }
        TypedShape::TriMesh(_) | TypedShape::HeightField(_) => {
            // The triangle the body's support point is over: one under `from` (of a
            // heightfield cell's two), else the one under where that triangle's plane says
            // it is (across a mesh's diagonal); unbounded, else the first one's plane.
            let under = triangles_under(ground, t, &from);
            let facing = |tri: &Triangle, bounded| {
                plane_contact_facing(part, ground, s, t, (from, Some(from)), Some(*tri), bounded)
            };
            let mut over = None;
            for tri in &under {
                match facing(tri, true) {
                    Ok(found) => return Some(found),
                    Err(Some(p)) => over = over.or(Some(p)),
                    Err(None) => {}
                }
            }
            let across = over.and_then(|p| {
                triangles_under(ground, t, &p)
                    .iter()
                    .find_map(|tri| facing(tri, true).ok())
            });
            across.or_else(|| {
                under
                    .first()
                    .filter(|_| !bounded)
                    .and_then(|tri| facing(tri, false).ok())
            })
        }
        _ => None,
    }
}

/// The contact of a body part with a cuboid ground out of the face it came in by: of the
/// faces whose plane has `from` (where the body was, outside the ground) in front and whose
/// contact `admits` holds for, the one the part is least deep behind, each face's plane
/// taken unbounded: of those `prefers` holds for, where it holds for any; `None` for other
/// grounds, or if no face is admitted. A long body whose end went into a small cuboid is
/// out of its entry face, not out of whichever face its own centre lies beyond (the far
/// side of a post, across the whole body).
pub(crate) fn entry_face_contact(
    part: &BodyPart,
    ground: &GroundGeom,
    s: &State,
    t: f64,
    from: Vector3<f64>,
    admits: impl Fn(&PairContact) -> bool,
    prefers: impl Fn(&PairContact) -> bool,
) -> Option<PairContact> {
    let half = vec_to_na(ground.shape.as_cuboid()?.half_extents);
    let poses = Poses::at(part, ground, s, t);
    let pose_g = &poses.ground;
    let p = pose_g
        .inverse_transform_point(&nalgebra::Point3::from(from))
        .coords;
    // The least deep face of all, and of those `prefers` holds for.
    let (mut best, mut preferred): (Option<PairContact>, Option<PairContact>) = (None, None);
    for axis in 0..3 {
        if p[axis].abs() <= half[axis] {
            continue;
        }
        // A point out along the face's normal, which `cuboid_face` takes to that face.
        let mut out = Vector3::zeros();
        out[axis] = 2.0 * half[axis].copysign(p[axis]);
        let locator = Locator::known((pose_g * nalgebra::Point3::from(out)).coords, out);
        if let Ok(found) = plane_contact_with(part, ground, &poses, locator, None, false)
            && admits(&found)
        {
            if best.is_none_or(|b| found.0 > b.0) {
                best = Some(found);
            }
            if preferred.is_none_or(|b| found.0 > b.0) && prefers(&found) {
                preferred = Some(found);
            }
        }
    }
    preferred.or(best)
}

/// [`plane_contact_on`], the face chosen by `locator` and a mesh triangle's normal turned
/// towards `side` (`(locator, side)`; `None`: the part's centre); `bounded`: the body's
/// support point must lie over the face (else its plane, unbounded).
fn plane_contact_facing(
    part: &BodyPart,
    ground: &GroundGeom,
    s: &State,
    t: f64,
    (locator, side): (Vector3<f64>, Option<Vector3<f64>>),
    triangle: Option<Triangle>,
    bounded: bool,
) -> Result<PairContact, Option<Vector3<f64>>> {
    let poses = Poses::at(part, ground, s, t);
    let locator = Locator::facing(locator, side);
    plane_contact_with(part, ground, &poses, locator, triangle, bounded)
}

/// The ground's and the part's poses at one instant, made once by a caller that asks
/// [`plane_contact_with`] more than once or has read them already.
struct Poses {
    ground: nalgebra::Isometry3<f64>,
    part: nalgebra::Isometry3<f64>,
}

impl Poses {
    fn at(part: &BodyPart, ground: &GroundGeom, s: &State, t: f64) -> Self {
        Poses {
            ground: ground.pose_at(t),
            part: part_pose(part, s),
        }
    }
}

/// The world point that chooses a cuboid's face (`world`), with its coordinates in the
/// ground's frame where the caller has them (`local`, read only on a cuboid to choose the
/// face: otherwise [`plane_contact_with`] takes `world` into that frame), and the side a
/// mesh triangle's normal is turned towards (`side`; `None`: the part's centre).
struct Locator {
    world: Vector3<f64>,
    local: Option<Vector3<f64>>,
    side: Option<Vector3<f64>>,
}

impl Locator {
    /// The world point `world`, with the side `side`.
    fn facing(world: Vector3<f64>, side: Option<Vector3<f64>>) -> Self {
        Locator {
            world,
            local: None,
            side,
        }
    }

    /// A point whose coordinates in the ground's frame are known, with no side.
    fn known(world: Vector3<f64>, local: Vector3<f64>) -> Self {
        Locator {
            world,
            local: Some(local),
            side: None,
        }
    }
}

/// The bounds of a flat ground's face in [`plane_contact_with`]: none (a half-space), a
/// cuboid's face (the axis of its normal and the cuboid's half extents, in its frame), or a
/// mesh triangle (its corners in the world).
enum Face {
    Unbounded,
    Rect { axis: usize, half: Vector3<f64> },
    Tri([Vector3<f64>; 3]),
}

impl Face {
    /// Does the world point `over`, on the face's plane of unit normal `n`, lie on the face,
    /// within `tol` of its edges (`pose_g` the ground's pose)?
    fn holds(
        &self,
        over: &Vector3<f64>,
        n: &Vector3<f64>,
        pose_g: &nalgebra::Isometry3<f64>,
        tol: f64,
    ) -> bool {
        match self {
            Face::Unbounded => true,
            Face::Rect { axis, half } => {
                let p = pose_g
                    .inverse_transform_point(&nalgebra::Point3::from(*over))
                    .coords;
                (0..3).all(|i| i == *axis || p[i].abs() <= half[i] + tol)
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
        }
    }
}

/// [`plane_contact_facing`] with the poses at the instant (`poses`) and the locator
/// (`locator`) made by the caller.
fn plane_contact_with(
    part: &BodyPart,
    ground: &GroundGeom,
    poses: &Poses,
    locator: Locator,
    triangle: Option<Triangle>,
    bounded: bool,
) -> Result<PairContact, Option<Vector3<f64>>> {
    use crate::parry::shape::TypedShape;
    let pose_g = &poses.ground;
    let local = |v: Vector3<f64>| pose_g.rotation * v;
    let at = |v: Vector3<f64>| (pose_g * nalgebra::Point3::from(v)).coords;
    let (body_point, side) = (locator.world, locator.side);
    // The plane (world normal, world point) and the face's bounds.
    let (n, q, face) = match ground.shape.as_typed_shape() {
        TypedShape::HalfSpace(hs) => (
            local(vec_to_na(hs.normal)),
            at(Vector3::zeros()),
            Face::Unbounded,
        ),
        TypedShape::Cuboid(cb) => {
            let half = vec_to_na(cb.half_extents);
            let p = locator.local.unwrap_or_else(|| {
                pose_g
                    .inverse_transform_point(&nalgebra::Point3::from(body_point))
                    .coords
            });
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
    let pose_b = &poses.part;
    let toward = side.unwrap_or(pose_b.translation.vector);
    if matches!(face, Face::Tri(_)) && n.dot(&(toward - q)) < 0.0 {
        n = -n; // A mesh triangle has no outside: the body's side (or `side`) is.
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
    let tol = FACE_ROUNDING * (1.0 + body_point.norm());
    let inside = !bounded || face.holds(&over, &n, pose_g, tol);
    if !inside {
        return Err(Some(over).filter(|_| matches!(face, Face::Tri(_))));
    }
    let skins = part.skin + ground.skin;
    Ok((height - skins, n, support - n * part.skin))
}

/// The closest contact over every body part and ground (indices in `grounds`), at `t`. A
/// ball skips the grounds whose [`GroundGeom::gap_bound`] exceeds the best gap found or
/// `prediction`: their contact could not be taken.
pub(crate) fn closest(
    body: &BodyGeom,
    grounds: &[GroundGeom],
    s: &State,
    t: f64,
    prediction: f64,
) -> Option<Hit> {
    let mut best: Option<Hit> = None;
    for (i, part) in body.parts.iter().enumerate() {
        // A ball's centre and radius, for a bound of its gap to each ground without a query
        // (worth it only among several grounds).
        let ball = part.shape.as_ball().filter(|_| grounds.len() > 1).map(|b| {
            let centre = part_pose(part, s).translation.vector;
            (centre, to_f64(b.radius) + part.skin)
        });
        for (j, ground) in grounds.iter().enumerate() {
            if ground.skip.contains(&part.handle) {
                continue;
            }
            // A ground the ball cannot be nearer than the best found (or within
            // `prediction`) is not queried: its contact could not be taken.
            if let Some((centre, radius)) = ball {
                let limit = best.map_or(prediction, |b| b.dist.min(prediction));
                if ground.gap_bound(&centre, radius) > limit {
                    continue;
                }
            }
            if let Some(found) = contact(part, ground, s, t, prediction) {
                if best.is_none_or(|b| found.0 < b.dist) {
                    best = Some(Hit::at((i, j), ground, s, t, found));
                }
            }
        }
    }
    best
}

#[cfg(test)]
mod tests {
    use super::{BodyPart, GroundGeom, contact_checked, cuboid_face};
    use crate::motion::State;
    use crate::parry::bounding_volume::Aabb;
    use crate::parry::shape::Cuboid;
    use crate::plugin::bridge::convert::to_real;
    use crate::plugin::queries::ground_index::GroundMotion;
    use crate::rapier::math::Vector;
    use crate::rapier::prelude::ColliderHandle;
    use nalgebra::{Isometry3, UnitQuaternion, Vector3};

    /// The contact (signed distance, normal) of a cuboid body of half extents `body` at
    /// centre `com`, turned by `about_z` (rad) about the `z` axis, with a still plate of half
    /// extents `plate` whose top is at `y = 0`.
    fn plate_contact(
        plate: [f64; 3],
        body: [f64; 3],
        com: [f64; 3],
        about_z: f64,
    ) -> (f64, Vector3<f64>) {
        let v = |a: [f64; 3]| Vector::new(to_real(a[0]), to_real(a[1]), to_real(a[2]));
        let plate_shape = Cuboid::new(v(plate));
        let pose = Isometry3::translation(0.0, -plate[1], 0.0);
        let motion = GroundMotion {
            handle: ColliderHandle::invalid(),
            body: None,
            com0: pose.translation.vector,
            rot0: UnitQuaternion::identity(),
            local: Isometry3::identity(),
            pose0: pose,
            v: Vector3::zeros(),
            w: Vector3::zeros(),
            aabb: Aabb::new_invalid(),
            plane: None,
            slab: None,
            unit_normal: None,
        };
        let ground = GroundGeom {
            handle: ColliderHandle::invalid(),
            shape: &plate_shape,
            skin: 0.0,
            motion: &motion,
            skip: Vec::new(),
        };
        let body_shape = Cuboid::new(v(body));
        let part = BodyPart {
            handle: ColliderHandle::invalid(),
            shape: &body_shape,
            local: Isometry3::identity(),
            skin: 0.0,
        };
        let s = State {
            com: Vector3::from(com),
            rot: UnitQuaternion::from_euler_angles(0.0, 0.0, about_z),
            v: Vector3::zeros(),
            w: Vector3::zeros(),
        };
        let (dist, n, _) = contact_checked(&part, &ground, &s, 0.0, 0.0)
            .unwrap()
            .expect("the body is inside the plate");
        (dist, n)
    }

    /// A long bar lies across a plate's side edge, sloping gently down past it: its bottom
    /// edge is 4 mm under the plate's top at its inner end and 6 mm at the side. Its contact
    /// is out of the top, as parry finds it: the bar's deepest point inside the plate, at the
    /// side, is nearer the side face, out of which the bar is 12 cm deep (a tumbling plate's
    /// corner under a floor of tiles' edge was pushed out sideways by that much and left in
    /// the floor under the tiles).
    #[test]
    fn a_bar_across_a_plates_edge_is_out_of_its_top() {
        let plate = [2.0, 0.05, 2.0];
        let (dist, n) = plate_contact(plate, [0.14, 0.035, 0.01], [2.02, 0.0286, 0.3], -0.02);
        assert!(n.y > 0.99, "out of the top: {n:?} at {dist}");
        assert!((-0.01..0.0).contains(&dist), "{dist}");
    }

    /// A cube pierces a thin plate near its edge from above: its centre over the top, its
    /// lowest corner beyond the plate's side (tilted about `z`) and its bottom below the
    /// plate's underside. Its contact is on the top's side, as parry finds it: the deepest
    /// point of the cube, below the plate, must not send it to the underside, 0.45 m deep (a
    /// tumbling box dropped through a floor of tiles was resolved against the underside and
    /// thrown down through it).
    #[test]
    fn a_body_piercing_a_thin_plate_from_above_is_out_of_its_top() {
        let plate = [1.0, 0.05, 1.0];
        let (dist, n) = plate_contact(plate, [0.2, 0.2, 0.2], [0.95, 0.1, 0.3], -0.3);
        // The cube's corner hangs past the side, so the top face does not hold it and parry's
        // contact stands: along the cube's own tilted face, 0.12 m deep.
        assert!(n.y > 0.9, "out of the top side: {n:?} at {dist}");
        assert!((-0.25..0.0).contains(&dist), "{dist}");
    }

    #[test]
    fn a_cuboid_face_is_the_one_a_point_is_over_outside_and_the_nearest_inside() {
        let plate = Vector3::new(2.0, 0.05, 2.0);
        // Over the top face, and beside the plate, beyond its side.
        assert_eq!(
            cuboid_face(&Vector3::new(1.9, 0.3, -1.5), &plate).1,
            Vector3::y()
        );
        assert_eq!(
            cuboid_face(&Vector3::new(0.1, 0.0, -2.5), &plate).1,
            -Vector3::z()
        );
        // Inside, 8 mm over the underside and 0.31 m from the side at z = 2: relative to the
        // half extents it is further out towards that side (0.845 against 0.84).
        let inside = Vector3::new(0.694, -0.042, 1.69);
        assert_eq!(cuboid_face(&inside, &plate), (1, -Vector3::y()));
        // Inside a cube, off its centre towards one face.
        let cube = Vector3::new(1.0, 1.0, 1.0);
        assert_eq!(
            cuboid_face(&Vector3::new(-0.9, 0.5, 0.2), &cube),
            (0, -Vector3::x())
        );
    }
}
