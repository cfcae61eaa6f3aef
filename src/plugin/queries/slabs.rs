//! Slabs: a floor of flush coplanar tiles as one ground.
//!
//! Contract:
//! - [`find_slabs`] takes still cuboid grounds (their index, world pose, half extents and a key
//!   of everything else a contact with them depends on) and returns the groups that form one
//!   box: the same key, the same orientation, the same thickness along one of their axes at
//!   the same height along it (within [`COPLANAR_TOLERANCE`]), and faces that tile a rectangle
//!   with neither gap nor overlap wider than that tolerance. The union of such tiles is that
//!   box, so every query of a body against the tiles is the query against the box: a ball
//!   rolling across a seam meets no edge, and one query replaces one per tile;
//! - [`Slab::tile_at`] names the tile under a point of the box (the ground an event reports);
//! - pure: no rapier types, nothing read but the arguments, the same answer for the same
//!   tiles in the same order.
//!
//! Tiles that tile anything but a rectangle (an L-shaped floor, two floors at one height with
//! a gap between) are not one box, though their rows may be; nor are tiles too irregular for
//! the grid (more than `CELLS_PER_TILE` cells a tile), at heights that straddle a bucket of
//! the tolerance, or turned alike only to rounding. Those stay tiles: correct, and as costly
//! as before.

use crate::plugin::queries::geometry::COPLANAR_TOLERANCE;
use nalgebra::{Isometry3, Point3, Translation3, Vector3};

/// A still cuboid ground offered to [`find_slabs`].
pub(crate) struct Tile {
    /// The ground's index (in the ground index's motions).
    pub index: usize,
    pub pose: Isometry3<f64>,
    pub half: Vector3<f64>,
    /// The class of everything else a contact with the tile depends on (material,
    /// coefficients, filtering, skin): tiles merge only with equal keys.
    pub key: usize,
}

/// Tiles that form one box.
#[derive(Clone, Debug)]
pub(crate) struct Slab {
    /// The tiles' indices, increasing.
    pub members: Vec<usize>,
    /// The box's world pose (its centre, the tiles' orientation).
    pub pose: Isometry3<f64>,
    /// The box's half extents in that frame.
    pub half: Vector3<f64>,
    /// The in-plane axes of the box frame (`across.0`, `across.1`), the third being normal to
    /// the tiles' faces.
    across: (usize, usize),
    /// The grid the tiles' edges make, along each in-plane axis: edge coordinates in the box
    /// frame, increasing.
    edges: (Vec<f64>, Vec<f64>),
    /// By grid cell (`a * cells_b + b`): the position in `members` of the tile covering it.
    cells: Vec<u32>,
}

/// Largest number of grid cells per tile: beyond, the tiles are too irregular for the grid
/// test to pay (a regular floor has one cell a tile).
const CELLS_PER_TILE: usize = 4;

/// The groups of `tiles` that form one box each (see the module's contract), in the order of
/// their first member.
pub(crate) fn find_slabs(tiles: &[Tile]) -> Vec<Slab> {
    // The boxes along each axis as the normal (a floor's tiles along their local `y`; a row
    // of tiles is a box along either in-plane axis too), the largest taken first, each tile
    // in one box at most.
    let mut found: Vec<Slab> = [1, 0, 2]
        .into_iter()
        .flat_map(|normal| boxes_along(tiles, normal))
        .collect();
    found.sort_by_key(|s| (std::cmp::Reverse(s.members.len()), s.members[0]));
    let mut taken = std::collections::HashSet::new();
    let mut slabs: Vec<Slab> = Vec::new();
    for slab in found {
        if slab.members.iter().all(|m| !taken.contains(m)) {
            taken.extend(slab.members.iter().copied());
            slabs.push(slab);
        }
    }
    slabs.sort_by_key(|s| s.members[0]);
    slabs
}

/// The boxes of [`find_slabs`] whose faces are normal to the tiles' local axis `normal`.
fn boxes_along(tiles: &[Tile], normal: usize) -> Vec<Slab> {
    // Candidates for one box share the key, the orientation (bit for bit: tiles placed
    // alike), the half extent along the normal, and the height along it to within the
    // tolerance (a bucket of that width: tiles straddling a bucket's edge stay apart, which
    // is only slower).
    type GroupKey = (usize, [u64; 4], u64, i64);
    let mut keyed: Vec<(GroupKey, usize)> = tiles
        .iter()
        .enumerate()
        .filter(|(_, t)| t.half.iter().all(|h| h.is_finite() && *h > 0.0))
        .map(|(k, t)| {
            let local = t.pose.rotation.inverse() * t.pose.translation.vector;
            let height = (local[normal] / COPLANAR_TOLERANCE).round() as i64;
            let rot = t.pose.rotation.coords.map(f64::to_bits);
            (
                (
                    t.key,
                    [rot[0], rot[1], rot[2], rot[3]],
                    t.half[normal].to_bits(),
                    height,
                ),
                k,
            )
        })
        .collect();
    keyed.sort();
    let mut boxes = Vec::new();
    let mut from = 0;
    while from < keyed.len() {
        let to = from
            + keyed[from..]
                .iter()
                .take_while(|(key, _)| *key == keyed[from].0)
                .count();
        if to - from >= 2 {
            let group: Vec<&Tile> = keyed[from..to].iter().map(|(_, k)| &tiles[*k]).collect();
            boxes.extend(one_box(&group, normal));
        }
        from = to;
    }
    boxes
}

/// The box `group` forms, if its faces tile a rectangle (see the module's contract).
fn one_box(group: &[&Tile], normal: usize) -> Option<Slab> {
    let (a, b) = match normal {
        0 => (1, 2),
        1 => (0, 2),
        _ => (0, 1),
    };
    let rot = group[0].pose.rotation;
    // Each tile's centre in the tiles' common frame.
    let local: Vec<Vector3<f64>> = group
        .iter()
        .map(|t| rot.inverse() * t.pose.translation.vector)
        .collect();
    let edges_along = |axis: usize| {
        let mut all: Vec<f64> = group
            .iter()
            .zip(&local)
            .flat_map(|(t, c)| [c[axis] - t.half[axis], c[axis] + t.half[axis]])
            .collect();
        all.sort_by(f64::total_cmp);
        // Edges within the tolerance of the last kept one are that edge.
        let mut kept: Vec<f64> = Vec::new();
        for x in all {
            if kept.last().is_none_or(|last| x - last > COPLANAR_TOLERANCE) {
                kept.push(x);
            }
        }
        kept
    };
    let (ea, eb) = (edges_along(a), edges_along(b));
    let (na, nb) = (ea.len() - 1, eb.len() - 1);
    // Tiles thinner than the tolerance along an in-plane axis have no cell there.
    if na == 0 || nb == 0 || na * nb > CELLS_PER_TILE * group.len() {
        return None;
    }
    // The grid line an edge lies on (within the tolerance), if any.
    let line = |edges: &[f64], x: f64| {
        let k = edges.partition_point(|e| *e < x - COPLANAR_TOLERANCE);
        (k < edges.len() && (edges[k] - x).abs() <= COPLANAR_TOLERANCE).then_some(k)
    };
    let mut cells = vec![u32::MAX; na * nb];
    for (m, (t, c)) in group.iter().zip(&local).enumerate() {
        let a0 = line(&ea, c[a] - t.half[a])?;
        let a1 = line(&ea, c[a] + t.half[a])?;
        let b0 = line(&eb, c[b] - t.half[b])?;
        let b1 = line(&eb, c[b] + t.half[b])?;
        if a0 >= a1 || b0 >= b1 {
            return None;
        }
        for i in a0..a1 {
            for j in b0..b1 {
                let cell = &mut cells[i * nb + j];
                if *cell != u32::MAX {
                    return None; // Two tiles overlap.
                }
                *cell = m as u32;
            }
        }
    }
    if cells.contains(&u32::MAX) {
        return None; // A hole.
    }
    let mut centre = Vector3::zeros();
    centre[a] = 0.5 * (ea[0] + ea[na]);
    centre[b] = 0.5 * (eb[0] + eb[nb]);
    centre[normal] = local[0][normal];
    let mut half = Vector3::zeros();
    half[a] = 0.5 * (ea[na] - ea[0]);
    half[b] = 0.5 * (eb[nb] - eb[0]);
    half[normal] = group[0].half[normal];
    let shift = |e: Vec<f64>, c: f64| e.into_iter().map(|x| x - c).collect();
    Some(Slab {
        members: group.iter().map(|t| t.index).collect(),
        pose: Isometry3::from_parts(Translation3::from(rot * centre), rot),
        half,
        across: (a, b),
        edges: (shift(ea, centre[a]), shift(eb, centre[b])),
        cells,
    })
}

impl Slab {
    /// The plane of the box's face whose interior holds the world point `p` (within
    /// `COPLANAR_TOLERANCE` of that face's plane and of no other, and inside its rectangle by
    /// more than that), as its outward unit normal `n` and offset `n.q` (`q` on the face), in
    /// the world. Where tiles meet inside a face the box is flat, whichever tile's edge a
    /// contact there was found on. `None` on the box's own edges and corners, and off its
    /// faces.
    pub fn face_plane_at(&self, p: &Vector3<f64>) -> Option<(Vector3<f64>, f64)> {
        let local = self.pose.inverse_transform_point(&Point3::from(*p)).coords;
        let off_plane = |i: usize| (local[i].abs() - self.half[i]).abs();
        let mut on = (0..3).filter(|i| off_plane(*i) <= COPLANAR_TOLERANCE);
        let (Some(axis), None) = (on.next(), on.next()) else {
            return None;
        };
        let inside = (0..3)
            .filter(|i| *i != axis)
            .all(|i| local[i].abs() < self.half[i] - COPLANAR_TOLERANCE);
        let mut n = Vector3::zeros();
        n[axis] = local[axis].signum();
        let q = self.pose * Point3::from(n * self.half[axis]);
        let n = self.pose.rotation * n;
        inside.then(|| (n, n.dot(&q.coords)))
    }

    /// [`Self::face_plane_at`] of every one of `points`, if they lie inside one face.
    pub fn face_plane_of(
        &self,
        points: impl IntoIterator<Item = Vector3<f64>>,
    ) -> Option<(Vector3<f64>, f64)> {
        let mut found: Option<(Vector3<f64>, f64)> = None;
        for p in points {
            let plane = self.face_plane_at(&p)?;
            if found.is_some_and(|f| f.0 != plane.0) {
                return None;
            }
            found = Some(plane);
        }
        found
    }

    /// The index of the tile under the world point `p` (its projection on the faces, clamped
    /// to the box: a point beyond the box's side names the tile at that side).
    pub fn tile_at(&self, p: &Vector3<f64>) -> usize {
        let local = self.pose.inverse_transform_point(&Point3::from(*p)).coords;
        let cell = |edges: &[f64], x: f64| {
            edges.partition_point(|e| *e <= x).clamp(1, edges.len() - 1) - 1
        };
        let i = cell(&self.edges.0, local[self.across.0]);
        let j = cell(&self.edges.1, local[self.across.1]);
        let nb = self.edges.1.len() - 1;
        self.members[self.cells[i * nb + j] as usize]
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::UnitQuaternion;

    fn tile(index: usize, x: f64, z: f64, half: f64) -> Tile {
        Tile {
            index,
            pose: Isometry3::translation(x, -0.25, z),
            half: Vector3::new(half, 0.25, half),
            key: 7,
        }
    }

    /// An `n` x `n` floor of tiles of side `side`, top at y = 0, its corner at the origin.
    fn floor(n: usize, side: f64) -> Vec<Tile> {
        (0..n * n)
            .map(|k| {
                let (i, j) = ((k / n) as f64, (k % n) as f64);
                tile(k, (i + 0.5) * side, (j + 0.5) * side, 0.5 * side)
            })
            .collect()
    }

    #[test]
    fn a_full_floor_is_one_box_and_names_the_tile_under_a_point() {
        let slabs = find_slabs(&floor(8, 0.125));
        assert_eq!(slabs.len(), 1);
        let s = &slabs[0];
        assert_eq!(s.members, (0..64).collect::<Vec<_>>());
        assert!((s.half - Vector3::new(0.5, 0.25, 0.5)).norm() < 1e-15);
        assert!((s.pose.translation.vector - Vector3::new(0.5, -0.25, 0.5)).norm() < 1e-15);
        // Tile (i, j) is index 8 i + j.
        assert_eq!(s.tile_at(&Vector3::new(0.3, 0.0, 0.9)), 2 * 8 + 7);
        assert_eq!(s.tile_at(&Vector3::new(0.01, 0.0, 0.01)), 0);
        // Beyond the side: the tile at that side.
        assert_eq!(s.tile_at(&Vector3::new(-3.0, 0.0, 0.9)), 7);
        assert_eq!(s.tile_at(&Vector3::new(5.0, 0.0, 5.0)), 63);
    }

    #[test]
    fn tiles_of_several_sizes_that_tile_a_rectangle_are_one_box() {
        // A 2 x 1 tile beside two 1 x 1 tiles, and a 1 x 3 strip along the far side.
        let tiles = vec![
            Tile {
                half: Vector3::new(0.5, 0.25, 1.0),
                ..tile(0, 0.5, 1.0, 0.0)
            },
            tile(1, 1.5, 0.5, 0.5),
            tile(2, 1.5, 1.5, 0.5),
            Tile {
                half: Vector3::new(1.0, 0.25, 0.5),
                ..tile(3, 1.0, 2.5, 0.0)
            },
        ];
        let slabs = find_slabs(&tiles);
        assert_eq!(slabs.len(), 1);
        assert_eq!(slabs[0].tile_at(&Vector3::new(0.2, 0.0, 1.9)), 0);
        assert_eq!(slabs[0].tile_at(&Vector3::new(1.2, 0.0, 1.1)), 2);
        assert_eq!(slabs[0].tile_at(&Vector3::new(1.9, 0.0, 2.9)), 3);
    }

    /// Is tile `i` in some box?
    fn merged(tiles: &[Tile], i: usize) -> bool {
        find_slabs(tiles).iter().any(|s| s.members.contains(&i))
    }

    #[test]
    fn a_hole_an_overlap_a_step_another_key_or_a_turn_keeps_the_tiles_apart() {
        // A hole: the middle tile of 3 x 3 left out. The rows and columns of three around
        // it are boxes; no box holds the hole.
        let holed: Vec<Tile> = floor(3, 1.0).into_iter().filter(|t| t.index != 4).collect();
        let slabs = find_slabs(&holed);
        assert!(!slabs.is_empty());
        for s in &slabs {
            let local = s
                .pose
                .inverse_transform_point(&Point3::new(1.5, -0.25, 1.5))
                .coords;
            assert!((0..3).any(|i| local[i].abs() > s.half[i]), "{s:?}");
        }
        // An overlap: the middle tile 1 mm wider.
        let mut t = floor(3, 1.0);
        t[4].half.x += 1e-3;
        assert!(!merged(&t, 4));
        // A gap of 2e-6 m between two columns: each column is a box, no box spans the gap.
        let mut t = floor(2, 1.0);
        t[2].pose.translation.vector.x += 2e-6;
        t[3].pose.translation.vector.x += 2e-6;
        let slabs = find_slabs(&t);
        assert_eq!(slabs.len(), 2);
        assert!(
            slabs
                .iter()
                .all(|s| s.members == [0, 1] || s.members == [2, 3])
        );
        // A step of 1 mm, another material, a turn of 1e-9 rad about the vertical: that tile
        // stays apart.
        let mut t = floor(2, 1.0);
        t[3].pose.translation.vector.y += 1e-3;
        assert!(!merged(&t, 3));
        let mut t = floor(2, 1.0);
        t[1].key = 8;
        assert!(!merged(&t, 1));
        let mut t = floor(2, 1.0);
        t[0].pose.rotation = UnitQuaternion::from_euler_angles(0.0, 1e-9, 0.0);
        assert!(!merged(&t, 0));
        // Rounding within the tolerance still tiles: a seam 1e-7 m wide.
        let mut t = floor(2, 1.0);
        t[2].pose.translation.vector.x += 1e-7;
        t[3].pose.translation.vector.x += 1e-7;
        let slabs = find_slabs(&t);
        assert_eq!(slabs.len(), 1);
        assert_eq!(slabs[0].members, vec![0, 1, 2, 3]);
    }

    #[test]
    fn tiles_thinner_than_the_tolerance_are_no_box() {
        // Two plates 2e-7 m thick, 3 m apart along x (their faces normal to y would be a
        // box only with the gap filled; normal to x, their edges along x merge into one).
        let plate = |index: usize, x: f64| Tile {
            index,
            pose: Isometry3::translation(x, 0.0, 0.0),
            half: Vector3::new(1e-7, 0.5, 0.5),
            key: 1,
        };
        assert!(find_slabs(&[plate(0, 0.0), plate(1, 3.0)]).is_empty());
    }

    #[test]
    fn two_floors_at_two_heights_are_two_boxes() {
        let mut tiles = floor(2, 1.0);
        tiles.extend(floor(2, 1.0).into_iter().map(|mut t| {
            t.index += 4;
            t.pose.translation.vector += Vector3::new(5.0, 1.0, 0.0);
            t
        }));
        let slabs = find_slabs(&tiles);
        assert_eq!(slabs.len(), 2);
        assert_eq!(slabs[0].members, vec![0, 1, 2, 3]);
        assert_eq!(slabs[1].members, vec![4, 5, 6, 7]);
    }
}
