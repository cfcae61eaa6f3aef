//! Flat faces: whether a flight stays over one flat face of a ground ([`flat_relative`]),
//! whether the grounds near a rolling ball are pieces of one plane that
//! cover its path ([`plane_piece_of`], [`one_plane_under`]), and the landing points of a flat
//! face of the body ([`landing_point`]).

use super::instant::{contact, cuboid_face};
use super::{BodyGeom, BodyPart, GroundGeom, Hit, body_velocity_at, part_pose};
use crate::motion::State;
use crate::parry::shape::{PolygonalFeature, Triangle};
use crate::plugin::bridge::convert::{to_f64, vec_to_na};
use crate::plugin::policy::{FACE_ROUNDING, FACE_SIZE_FLOOR};
use nalgebra::{Isometry3, Vector3};

/// Is every query of `part` against `ground` over a flight from `s` in which every point of
/// the body moves at most `travel` relative to the ground the direct plane query of one face,
/// with the body's support point over it? For a ground that does not turn (it may translate;
/// `travel` is then measured in its frame, where it is still): a half-space, or a cuboid whose
/// face the direct query picks stays picked and under the body wherever it goes (the part's
/// origin within `travel` plus its offset turning, the support point within `radius` of the
/// centre of mass). The part must have a support map. A caller that needs the ground still as
/// well asks `ground.v` itself.
pub(crate) fn flat_relative(
    part: &BodyPart,
    ground: &GroundGeom,
    s: &State,
    travel: f64,
    radius: f64,
) -> bool {
    use crate::parry::shape::TypedShape;
    if ground.motion.w != Vector3::zeros()
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
            // The face plane_contact_on picks: outside the cuboid, the relative lead of
            // `axis` over the others holds over the reach (which stays on one side of the
            // cuboid's mid-plane across `axis`); where the reach goes inside, and the nearest
            // face is picked, the depth under that face stays below the depth under every
            // other.
            let (axis, _) = cuboid_face(&origin, &half);
            let lead = (origin[axis].abs() - r_o) / half[axis];
            let depth = half[axis] - (origin[axis].abs() - r_o);
            lead > 0.0
                && (0..3).filter(|i| *i != axis).all(|i| {
                    (origin[i].abs() + r_o) / half[i] < lead
                        && com[i].abs() + travel + radius < half[i]
                        && (depth <= 0.0 || depth < half[i] - origin[i].abs() - r_o)
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
    if ground.motion.v != Vector3::zeros() || ground.motion.w != Vector3::zeros() {
        return None;
    }
    let (n, height) = (&plane.n, plane.height);
    let pose = ground.motion.pose0;
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
    let pose = ground.motion.pose0;
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

/// [`landing_point`] for a body of any number of colliders (`geom`, `h` the hit of its part
/// `h.part`, the body at `s`, time `t`): the landing points of its other parts on the same
/// ground that lie on the contact plane within `flat_tolerance` times the spread of all the
/// points (with the rounding a face's test allows), along the same normal (within
/// `flat_tolerance`), and approach it at the hit part's velocity (within `flat_tolerance` of
/// it: a level landing without a tumble or a spin about the normal) land with it. When the body's centre of mass,
/// projected on the contact plane, lies in the hull of their points, they are one impact
/// there, with the count of all their contact points: every point then leaves at the same
/// speed, the simultaneous impact's answer, and a dumbbell, a hammer or a table on its feet
/// landing level leaves without spin, rather than spun by one foot's impact before the
/// other's. Otherwise the hit part's landing stands alone. `joins(j, part)` says whether part
/// `j` may join (the caller's rule: the hit part's material, a pair rapier's filtering and the
/// user's keep).
pub(crate) fn body_landing_point(
    geom: &BodyGeom,
    ground: &GroundGeom,
    (s, t): (&State, f64),
    h: &Hit,
    flat_tolerance: f64,
    joins: impl Fn(usize, &BodyPart) -> bool,
) -> (Vector3<f64>, usize) {
    let own = landing_point(&geom.parts[h.part], ground, s, t, h, flat_tolerance);
    if geom.parts.len() < 2 {
        return own;
    }
    let relative = |p: &Vector3<f64>| body_velocity_at(s, p) - ground.velocity_at(p, t);
    let own_velocity = relative(&own.0);
    // The others are looked for within the largest tolerance any spread can give, the
    // body's diameter's, beyond the hit (never a negative distance: parry refuses one).
    let diameter = 2.0 * geom.radius;
    let widest = flat_tolerance * diameter + FACE_ROUNDING * (diameter + FACE_SIZE_FLOOR);
    let look = (h.dist + widest).max(0.0);
    let min_cos = flat_tolerance.cos();
    // The same velocity relative to the ground at every point: no tumble, and no spin about
    // the normal, whose friction at each point one impulse at one point would not have.
    let same_velocity = |u: &Vector3<f64>| {
        (u - own_velocity).norm() <= flat_tolerance * own_velocity.norm() + FACE_ROUNDING
    };
    let mut points = vec![own];
    for (j, part) in geom.parts.iter().enumerate() {
        if j == h.part || ground.skip.contains(&part.handle) || !joins(j, part) {
            continue;
        }
        let Some(found) = contact(part, ground, s, t, look) else {
            continue;
        };
        if found.1.dot(&h.normal) < min_cos {
            continue;
        }
        let hit = Hit::at((j, h.ground), ground, s, t, found);
        let (p, count) = landing_point(part, ground, s, t, &hit, flat_tolerance);
        let u = relative(&p);
        if h.normal.dot(&u) < 0.0 && same_velocity(&u) {
            points.push((p, count));
        }
    }
    if points.len() < 2 {
        return own;
    }
    let spread = points
        .iter()
        .flat_map(|(a, _)| points.iter().map(move |(b, _)| (a - b).norm()))
        .fold(0.0, f64::max);
    let tol = flat_tolerance * spread + FACE_ROUNDING * (spread + FACE_SIZE_FLOOR);
    let level = |p: &Vector3<f64>| h.normal.dot(&(p - h.point));
    points.retain(|(p, _)| level(p).abs() <= tol);
    if points.len() < 2 {
        return own;
    }
    // The centre of mass on the contact plane, if the points hold it.
    let under = s.com - h.normal * level(&s.com);
    let corners: Vec<Vector3<f64>> = points
        .iter()
        .map(|(p, _)| p - h.normal * level(p))
        .collect();
    if !in_hull(&corners, &under, &h.normal, tol) {
        return own;
    }
    (under, points.iter().map(|(_, n)| n).sum())
}

/// Is `q` within `tol` of the convex hull of `points`, all of them and `q` in one plane of
/// unit normal `n`? The points in the plane's coordinates, their hull by the monotone chain
/// (counter-clockwise); `q` inside it by more than `tol`, or within `tol` of one of its edges
/// as a segment (of the segment, for points on a line; of the point, for one). Not within
/// `tol` of each edge's line: by a sharp corner of a thin hull that reaches far beyond it.
fn in_hull(points: &[Vector3<f64>], q: &Vector3<f64>, n: &Vector3<f64>, tol: f64) -> bool {
    let u = if n.x.abs() < 0.9 {
        Vector3::x()
    } else {
        Vector3::y()
    };
    let u = (u - n * n.dot(&u)).normalize();
    let v = n.cross(&u);
    let flat = |p: &Vector3<f64>| (p.dot(&u), p.dot(&v));
    let q = flat(q);
    let mut pts: Vec<(f64, f64)> = points.iter().map(flat).collect();
    pts.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.total_cmp(&b.1)));
    let cross = |o: (f64, f64), a: (f64, f64), b: (f64, f64)| {
        (a.0 - o.0) * (b.1 - o.1) - (a.1 - o.1) * (b.0 - o.0)
    };
    let mut hull: Vec<(f64, f64)> = Vec::with_capacity(2 * pts.len());
    for pass in 0..2 {
        let floor = hull.len();
        for &p in pts.iter() {
            while hull.len() >= floor + 2
                && cross(hull[hull.len() - 2], hull[hull.len() - 1], p) <= 0.0
            {
                hull.pop();
            }
            hull.push(p);
        }
        hull.pop();
        if pass == 0 {
            pts.reverse();
        }
    }
    // The distance from `q` to the segment `ab` (to `a`, for a point).
    let to_segment = |a: (f64, f64), b: (f64, f64)| {
        let (dx, dy) = (b.0 - a.0, b.1 - a.1);
        let len2 = dx * dx + dy * dy;
        let along = if len2 > 0.0 {
            (((q.0 - a.0) * dx + (q.1 - a.1) * dy) / len2).clamp(0.0, 1.0)
        } else {
            0.0
        };
        ((q.0 - a.0 - along * dx).powi(2) + (q.1 - a.1 - along * dy).powi(2)).sqrt()
    };
    let k = hull.len();
    let edges = || (0..k).map(|i| (hull[i], hull[(i + 1) % k]));
    // Inside by more than `tol` from every edge's line (a hull thinner than that, three
    // points all but on a line, has no such inside), or within `tol` of an edge.
    let deep = |(a, b): ((f64, f64), (f64, f64))| {
        cross(a, b, q) >= tol * ((b.0 - a.0).powi(2) + (b.1 - a.1).powi(2)).sqrt()
    };
    k > 0 && ((k > 2 && edges().all(deep)) || edges().any(|(a, b)| to_segment(a, b) <= tol))
}

/// The world corners, in order around it, of the face of a cuboid ground whose outward
/// normal is nearest the world direction `n` at time `t`; `None` for another shape.
fn cuboid_face_polygon(ground: &GroundGeom, t: f64, n: &Vector3<f64>) -> Option<[Vector3<f64>; 4]> {
    let half = vec_to_na(ground.shape.as_cuboid()?.half_extents);
    let pose = ground.pose_at(t);
    let local = pose.rotation.inverse() * n;
    let a = local.iamax();
    let (b, c) = ((a + 1) % 3, (a + 2) % 3);
    let corner = |sb: f64, sc: f64| {
        let mut p = Vector3::zeros();
        p[a] = half[a].copysign(local[a]);
        p[b] = sb * half[b];
        p[c] = sc * half[c];
        (pose * nalgebra::Point3::from(p)).coords
    };
    Some([
        corner(1.0, 1.0),
        corner(-1.0, 1.0),
        corner(-1.0, -1.0),
        corner(1.0, -1.0),
    ])
}

/// The convex polygon (or segment) `poly`, its vertices in order, clipped to the convex
/// polygon `face`, both seen along the unit normal `n` (Sutherland-Hodgman): the vertices of
/// their overlap, in order, at `poly`'s height along `n` (each of `poly`'s own where kept).
/// A vertex within `tol` (m) outside an edge's line counts as inside (a face flush with the
/// ground's edge, turned by rounding, is not cut at its middle). Vertices that coincide are
/// kept once.
fn clip_to_face(
    poly: &[Vector3<f64>],
    face: &[Vector3<f64>],
    n: &Vector3<f64>,
    tol: f64,
) -> Vec<Vector3<f64>> {
    let (e1, e2) = plane_basis(n);
    let flat = |p: &Vector3<f64>| (e1.dot(p), e2.dot(p));
    let cross = |a: (f64, f64), b: (f64, f64), p: (f64, f64)| {
        (b.0 - a.0) * (p.1 - a.1) - (b.1 - a.1) * (p.0 - a.0)
    };
    let face2: Vec<_> = face.iter().map(flat).collect();
    let k = face2.len();
    let area: f64 = (0..k)
        .map(|i| cross((0.0, 0.0), face2[i], face2[(i + 1) % k]))
        .sum();
    let orient = area.signum();
    let mut out: Vec<Vector3<f64>> = poly.to_vec();
    for i in 0..k {
        let (a, b) = (face2[i], face2[(i + 1) % k]);
        let slack = tol * ((b.0 - a.0).powi(2) + (b.1 - a.1).powi(2)).sqrt();
        // Signed, positive inside; a vertex is kept within `slack` outside.
        let side = |p: &Vector3<f64>| orient * cross(a, b, flat(p));
        let input = std::mem::take(&mut out);
        for (j, cur) in input.iter().enumerate() {
            let prev = &input[(j + input.len() - 1) % input.len()];
            let (dc, dp) = (side(cur), side(prev));
            let (keep_cur, keep_prev) = (dc + slack >= 0.0, dp + slack >= 0.0);
            if keep_cur != keep_prev {
                // Where the edge crosses the line; with both ends outside (one within the
                // slack), that end.
                out.push(if (dc >= 0.0) != (dp >= 0.0) {
                    prev + (cur - prev) * (dp / (dp - dc))
                } else if keep_prev {
                    *prev
                } else {
                    *cur
                });
            }
            if keep_cur {
                out.push(*cur);
            }
        }
    }
    let size = poly.iter().map(|p| p.norm()).fold(1.0, f64::max);
    let mut kept: Vec<Vector3<f64>> = Vec::with_capacity(out.len());
    for p in out {
        if !kept.iter().any(|q| (q - p).norm() <= FACE_ROUNDING * size) {
            kept.push(p);
        }
    }
    kept
}

/// The distance (m) from the world point `p` to the ground's surface at time `t`, its skin
/// deducted (0 inside).
fn ground_distance(ground: &GroundGeom, p: &Vector3<f64>, t: f64) -> f64 {
    let local = ground
        .pose_at(t)
        .inverse_transform_point(&nalgebra::Point3::from(*p))
        .coords;
    let local = crate::plugin::bridge::convert::vec_from_na(&local);
    to_f64(ground.shape.distance_to_local_point(local, true)) - ground.skin
}

/// The contact points of a landing, resolved as one impact (see `docs/guide.md`):
/// the vertices of the body's support face towards the ground (parry's polygonal feature)
/// that lie within `flat_tolerance x face size` of the contact plane, on the ground's surface
/// (a face hanging over the ground's edge lands on the part over it), and approach the
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
    let tol = flat_tolerance * size + FACE_ROUNDING * (size + FACE_SIZE_FLOOR);
    // The face must be the one touching: its lowest vertex at the contact point (a rounded
    // shape's core vertices sit `border` above its surface).
    if (h_min - to_f64(border)).abs() > tol + FACE_ROUNDING * (1.0 + size) {
        return (h.point, 1);
    }
    let flat: Vec<Vector3<f64>> = verts
        .iter()
        .zip(&heights)
        .filter(|(_, hx)| *hx - h_min <= tol)
        .map(|(x, _)| *x)
        .collect();
    // Where the ground's surface ends under the face (a cube landing half on a post, a rod
    // lying across a narrow bat), the landing is the part over it: the face clipped to a
    // cuboid's face; on another bounded shape, the vertices over its surface.
    // (Measured at the vertex's foot on the ground's face plane: in `Step` mode the face may
    // still be above it.)
    let surface = h.point - h.normal * h.dist;
    let on_ground = |x: &Vector3<f64>| {
        let foot = x - h.normal * h.normal.dot(&(x - surface));
        ground_distance(ground, &foot, t) <= tol + FACE_ROUNDING * (1.0 + x.norm())
    };
    let (points, clipped) = match cuboid_face_polygon(ground, t, &h.normal) {
        Some(face) => {
            let points = clip_to_face(&flat, &face, &h.normal, tol);
            let clipped = points != flat;
            (points, clipped)
        }
        // A half-space is under every vertex: no query.
        None if ground.shape.as_halfspace().is_some() => (flat, false),
        None => (flat.into_iter().filter(on_ground).collect(), false),
    };
    let approaching = |x: &Vector3<f64>| {
        let u = body_velocity_at(s, x) - ground.velocity_at(x, t);
        h.normal.dot(&u) < 0.0
    };
    let landing: Vec<_> = points.iter().copied().filter(approaching).collect();
    let n = landing.len();
    if n < 2 {
        return (h.point, 1);
    }
    // The part over a cuboid, all of it approaching: its area's centroid (a clipped face is
    // no parallelogram in general); otherwise the points' mean, as for a whole face.
    let whole_part = clipped && n == points.len() && n > 2;
    let c = match whole_part.then(|| area_centroid(&landing, &h.normal)) {
        Some(Some(c)) => c,
        _ => landing.iter().sum::<Vector3<f64>>() / n as f64,
    };
    (c - h.normal * h.normal.dot(&(c - h.point)), n)
}

/// An orthonormal pair spanning the plane normal to the unit vector `n`.
fn plane_basis(n: &Vector3<f64>) -> (Vector3<f64>, Vector3<f64>) {
    // Crossed with the axis of `n`'s smallest component: never near parallel to it.
    let axis = Vector3::ith(n.iamin(), 1.0);
    let e1 = n.cross(&axis).normalize();
    (e1, n.cross(&e1))
}

/// The centroid of the area of the convex polygon `poly` (vertices in order) seen along the
/// unit normal `n`, at its vertices' mean height; `None` for a polygon of no area.
fn area_centroid(poly: &[Vector3<f64>], n: &Vector3<f64>) -> Option<Vector3<f64>> {
    let (e1, e2) = plane_basis(n);
    let flat: Vec<(f64, f64)> = poly.iter().map(|p| (e1.dot(p), e2.dot(p))).collect();
    let (mut area, mut cx, mut cy) = (0.0, 0.0, 0.0);
    for i in 0..flat.len() {
        let (a, b) = (flat[i], flat[(i + 1) % flat.len()]);
        let w = a.0 * b.1 - b.0 * a.1;
        area += w;
        cx += (a.0 + b.0) * w;
        cy += (a.1 + b.1) * w;
    }
    let scale: f64 = poly.iter().map(|p| p.norm_squared()).sum();
    if area.abs() <= f64::EPSILON * scale {
        return None;
    }
    let height = poly.iter().map(|p| n.dot(p)).sum::<f64>() / poly.len() as f64;
    Some(e1 * (cx / (3.0 * area)) + e2 * (cy / (3.0 * area)) + n * height)
}
