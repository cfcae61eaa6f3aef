//! One pair's role: rapier's filtering first, then a piece of the plane the ball rolls on or
//! a ground it may roll into, then by its contact at the step's start: resting, `Step` mode's
//! start impulse, or impact; and what a ground's pairs tell the search after the step.

use super::body::{BodyNear, BodyPlan, BodyReads, StartContact};
use super::{Planner, closes_within};
use crate::motion::State;
use crate::plugin::bridge::convert::to_f64;
use crate::plugin::bridge::resolve::{Inertia, Site, correction};
use crate::plugin::config::{TimingMode, coefficients_in_range};
use crate::plugin::events::Diagnostic;
use crate::plugin::events::{EventKind, ImpactTiming};
use crate::plugin::policy::Role;
use crate::plugin::queries::filter::{self, FilterSide};
use crate::plugin::queries::geometry::{
    BodyGeom, BodyPart, COPLANAR_TOLERANCE, GroundGeom, Hit, PairContact, Search, Sweep,
    body_velocity_at, cannot_close, contact_checked, contact_from_side, first_impact, part_pose,
};
use crate::plugin::queries::observe::{Scene, touched_besides_grounds};
use crate::plugin::state::handles::PairKey;
use crate::plugin::state::small_list::SmallList;
use crate::plugin::state::step::{GroundPair, MeshSide, StepData};
use crate::rapier::prelude::{ActiveHooks, Collider, ColliderHandle, PhysicsHooks};
use nalgebra::Vector3;

/// One pair of the body with a ground: the ground's index in `BodyNear::grounds`, the body's
/// part, the pair's key, its two colliders, and the hook flags the user set on them (read
/// once: the filter and the rolling ask them).
#[derive(Clone, Copy)]
pub(super) struct Pair<'q, 'c> {
    pub k: usize,
    /// The body's part, and its index in the body's parts.
    pub part: &'q BodyPart<'c>,
    pub part_index: usize,
    pub gg: &'q GroundGeom<'c>,
    pub key: PairKey,
    pub colliders: (&'c Collider, &'c Collider),
    pub user: ActiveHooks,
}

/// What every pair with one ground reads of its collider, whatever the body: the hook flags
/// the user set on it, whether its coefficients are in the plugin's ranges, and its side of
/// rapier's filtering. rapier's sets and the hook flags are not written while the plan runs,
/// so a ground's side read once holds for the whole plan stage; the stage keeps the last one
/// read (`Planner::ground_side`: most bodies of a step rest on the same floor).
#[derive(Clone, Copy)]
pub(crate) struct GroundSide {
    /// The ground's index in `StepData::grounds`.
    index: usize,
    user: ActiveHooks,
    in_range: bool,
    filter: FilterSide,
}

/// What a ground's pairs with the body tell the search after the step.
struct GroundVerdict {
    /// A pair is `Impact` and within reach: the search runs against the ground.
    any_impact: bool,
    /// No pair of the body with the ground can meet in the step.
    clear: bool,
}

impl<H: PhysicsHooks> Planner<'_, H> {
    /// The roles of the body's pairs with its `k`-th ground near it (in `step.roles`, and in
    /// `step.ground_pairs` with the user's flags read for them, in the order of the body's
    /// parts), and whether the search after the step runs against it (`plan.impact_grounds`,
    /// `plan.closing`). Writes only `plan`, `step` and, in `Step`
    /// mode or on a release, the events; rapier is not written here.
    pub(super) fn plan_ground(
        &mut self,
        reads: BodyReads,
        plan: &mut BodyPlan,
        k: usize,
        step: &mut StepData,
    ) {
        let BodyReads { body, scene, .. } = reads;
        let (gi, gg) = &body.grounds[k];
        let mut verdict = GroundVerdict {
            any_impact: false,
            clear: true,
        };
        let side = self.ground_side(*gi, gg.handle, scene);
        for (part_index, part) in body.geom.parts.iter().enumerate() {
            let key = (part.handle, gg.handle);
            // Read once: the user's filter and the rolling decision both ask for them (the
            // pair's flags: either collider's, `HookFlags::recorded_pair_flags`).
            let body_user = self.flags.recorded_user_flags(scene.colliders, key.0);
            let user = body_user | side.user;
            // Both exist: the body's geometry and the ground's were read from them.
            let colliders = (&scene.colliders[key.0], &scene.colliders[key.1]);
            let pair = Pair {
                k,
                part,
                part_index,
                gg,
                key,
                colliders,
                user,
            };
            let role = if self.filtered(body, scene, key, colliders, (user, &side.filter))
                || self.coefficients_refused(key, colliders, side.in_range)
            {
                Role::Filtered
            } else if let Some(pieces) = &plan.rolling_pieces {
                rolling_piece_role(body, (&plan.state, pieces), pair, &mut verdict)
            } else {
                self.contact_role(reads, plan, pair, &mut verdict, step)
            };
            let planned = GroundPair {
                key,
                role,
                body_user,
                user,
            };
            if step.roles.insert(key, role).is_none() {
                step.ground_pairs.push(planned);
            } else {
                decided_again(step, planned);
            }
        }
        if verdict.any_impact {
            plan.impact_grounds.push(*gi);
            plan.closing |= !verdict.clear;
        }
    }

    /// The side of the ground of index `index` (collider `ground`) in its pairs
    /// ([`GroundSide`]): the one kept, if it is that ground's, else read and kept.
    fn ground_side(&mut self, index: usize, ground: ColliderHandle, scene: &Scene) -> GroundSide {
        match self.ground_side.filter(|side| side.index == index) {
            Some(side) => side,
            None => self.read_ground_side(index, ground, scene),
        }
    }

    /// [`Self::ground_side`] for a ground other than the one kept: read, and kept. Out of
    /// line: most bodies of a step rest on the ground planned before them.
    #[cold]
    #[inline(never)]
    fn read_ground_side(
        &mut self,
        index: usize,
        ground: ColliderHandle,
        scene: &Scene,
    ) -> GroundSide {
        let co = &scene.colliders[ground];
        let side = GroundSide {
            index,
            user: self.flags.recorded_user_flags(scene.colliders, ground),
            in_range: coefficients_in_range(to_f64(co.restitution()), to_f64(co.friction())),
            filter: FilterSide::of(scene.bodies, co),
        };
        *self.ground_side = Some(side);
        side
    }

    /// Does rapier have no contact for the pair: a joint of the body with the ground's body
    /// that disables contacts, rapier's own filtering, or the user's filter (asked when `user`,
    /// the pair's user hook flags, asks for it, with the start-of-step state, so that every
    /// pair the plugin could resolve in the step is covered; rapier asks it again during the
    /// step, for the pairs its broad phase has)? `(body_co, ground_co)`: the pair's two
    /// colliders; `ground_side`: the ground collider's side of rapier's filtering. Reads only.
    #[inline]
    fn filtered(
        &self,
        body: &BodyNear,
        scene: &Scene,
        key: PairKey,
        (body_co, ground_co): (&Collider, &Collider),
        (user, ground_side): (ActiveHooks, &FilterSide),
    ) -> bool {
        let (bodies, colliders, sets) = (scene.bodies, scene.colliders, scene.sets);
        let joint_filtered = body.jointed
            && ground_co.parent().is_some_and(|ground_body| {
                filter::joint_disables_contacts(
                    sets.impulse_joints,
                    sets.multibody_joints,
                    body.handle,
                    ground_body,
                )
            });
        // The body's collider is one of `body.rb`'s (its geometry was read from them): its
        // side takes that body as it is, not looked up again.
        joint_filtered
            || !filter::sides_solve(
                &FilterSide::with_parent(body_co, Some(body.rb)),
                ground_side,
            )
            || filter::user_refuses(self.user_hooks, user, bodies, colliders, key)
    }

    /// Is the pair of the body's part `part` with its `k`-th ground rapier's whatever happens,
    /// as [`Self::plan_ground`] finds it (`Role::Filtered`), for a part whose pair it has not
    /// decided yet: rapier's filtering or the user's refuses it, or a collider's coefficients
    /// are out of range (here even where the ground's material would replace them). Reads
    /// only; diagnoses nothing. Asked by a `Step` impulse of another part, of the parts that
    /// may land with it.
    pub(super) fn part_refused(
        &self,
        body: &BodyNear,
        scene: &Scene,
        part: &BodyPart,
        k: usize,
    ) -> bool {
        let (gi, gg) = &body.grounds[k];
        let Some(side) = self.ground_side.filter(|side| side.index == *gi) else {
            return true;
        };
        let key = (part.handle, gg.handle);
        let colliders = (&scene.colliders[key.0], &scene.colliders[key.1]);
        let user = self.flags.recorded_user_flags(scene.colliders, key.0) | side.user;
        let body_in_range = coefficients_in_range(
            to_f64(colliders.0.restitution()),
            to_f64(colliders.0.friction()),
        );
        !(body_in_range && side.in_range)
            || self.filtered(body, scene, key, colliders, (user, &side.filter))
    }

    /// Is a collider of the pair out of the plugin's coefficient ranges, with no ground
    /// material to replace them? The pair is then rapier's, as a filtered one is (nothing made
    /// up for it), and each such collider is diagnosed (reported once, `Memory::reported`).
    /// Reads the body's collider (`pair_colliders.0`; `ground_in_range`: whether the ground's
    /// are in range); the registry only when one is out of range.
    fn coefficients_refused(
        &mut self,
        key: PairKey,
        pair_colliders: (&Collider, &Collider),
        ground_in_range: bool,
    ) -> bool {
        let out = |co: &&Collider| {
            !coefficients_in_range(to_f64(co.restitution()), to_f64(co.friction()))
        };
        let (body, ground) = (
            Some(pair_colliders.0).filter(out),
            Some(pair_colliders.1).filter(|_| !ground_in_range),
        );
        if body.is_none() && ground.is_none() {
            return false;
        }
        self.coefficients_out_of_range(key, (body, ground))
    }

    /// [`Self::coefficients_refused`] for a pair with a collider out of range (`body`,
    /// `ground`: each collider that is): refused, and diagnosed, unless the ground's material
    /// replaces them. Out of line: colliders out of range are rare.
    #[cold]
    #[inline(never)]
    fn coefficients_out_of_range(
        &mut self,
        key: PairKey,
        (body, ground): (Option<&Collider>, Option<&Collider>),
    ) -> bool {
        if self.registry.replaces_coefficients(key.1) {
            return false;
        }
        for (c, co) in [(key.0, body), (key.1, ground)] {
            if let Some(co) = co {
                self.reports
                    .diagnostics
                    .push(Diagnostic::CoefficientsOutOfRange {
                        collider: c,
                        restitution: to_f64(co.restitution()),
                        friction: to_f64(co.friction()),
                    });
            }
        }
        true
    }

    /// A mesh or heightfield has no inside: a contact's normal is turned towards the body. A
    /// body whose contact faces the other way than at the last step's start, its part's
    /// centre behind the face it touched then, crossed the surface (rapier's resting contact
    /// can let a thin body through a mesh's edge): while it is over
    /// the face, it is put back on the side it was on, by its depth measured from that side,
    /// its speed into the ground removed (a `PushOut` at the step's start, written with the
    /// plan's state), and the contact found again; not where that puts it deeper than the
    /// resting gap in another of its grounds (a mesh lying on a solid floor). Records the
    /// side of the pair's contact for the next step (`StepData::mesh_sides`). Other grounds:
    /// `found` as it is.
    fn mesh_side(
        &mut self,
        reads: BodyReads,
        plan: &mut BodyPlan,
        pair: Pair,
        found: StartContact,
        step: &mut StepData,
    ) -> StartContact {
        use crate::parry::shape::TypedShape;
        let Ok(Some((dist, n, _))) = found else {
            return found;
        };
        let mesh = matches!(
            pair.gg.shape.as_typed_shape(),
            TypedShape::TriMesh(_) | TypedShape::HeightField(_)
        );
        if !mesh {
            return found;
        }
        self.on_mesh_side(reads, plan, pair, (found, dist, n), step)
    }

    /// [`Self::mesh_side`] for a mesh or heightfield with a contact `found` at `dist` along
    /// `n`. Out of line: most grounds are solids, whose plans skip it.
    #[inline(never)]
    fn on_mesh_side(
        &mut self,
        reads: BodyReads,
        plan: &mut BodyPlan,
        pair: Pair,
        (found, dist, n): (StartContact, f64, Vector3<f64>),
        step: &mut StepData,
    ) -> StartContact {
        let Pair {
            k, part, gg, key, ..
        } = pair;
        let body = reads.body;
        let mut found = found;
        let centre = part_pose(part, &plan.state).translation.vector;
        let pose_g = gg.pose_at(0.0);
        // Crossed: the contact now faces the other way, and the part's centre lies behind
        // the face it touched. A contact that turns between two faces of a crease (parry
        // takes either when the body touches both) leaves the centre in front of each.
        let crossed_from = reads.last.mesh_sides.get(&key).and_then(|last| {
            let normal = pose_g.rotation * last.normal;
            let face_point = (pose_g * nalgebra::Point3::from(last.face_point)).coords;
            (normal.dot(&n) < 0.0 && (centre - face_point).dot(&normal) < 0.0).then_some(normal)
        });
        if let Some(side) = crossed_from {
            let from = centre + side * (2.0 * body.geom.radius + dist.abs());
            let crossed = contact_from_side(part, gg, &plan.state, 0.0, from, true)
                .filter(|(depth, ..)| *depth < 0.0)
                .filter(|(depth, normal, _)| {
                    // Not back inside another ground: a mesh lying on a solid floor has no
                    // side below it a body can be on, and the solid's outside wins.
                    let back = State {
                        com: plan.state.com - normal * *depth,
                        ..plan.state
                    };
                    !body.grounds.iter().enumerate().any(|(j, (_, other))| {
                        let other_co = &reads.scene.colliders[other.handle];
                        j != k
                            && !self.filtered(
                                body,
                                reads.scene,
                                (part.handle, other.handle),
                                (&reads.scene.colliders[part.handle], other_co),
                                (
                                    self.flags.recorded_pair_flags(
                                        reads.scene.colliders,
                                        (part.handle, other.handle),
                                    ),
                                    &FilterSide::of(reads.scene.bodies, other_co),
                                ),
                            )
                            && contact_checked(part, other, &back, 0.0, 0.0).is_ok_and(|c| {
                                c.is_some_and(|(dist, ..)| dist < -step.policy.resting_gap)
                            })
                    })
                });
            if let Some((depth, normal, point)) = crossed {
                let before = plan.state;
                plan.state.com -= normal * depth;
                let vn = normal.dot(&plan.state.v);
                if vn < 0.0 {
                    plan.state.v -= normal * vn;
                }
                plan.touched = true;
                let site = Site {
                    body: body.handle,
                    collider: part.handle,
                    ground: gg.handle,
                    body2: None,
                    normal,
                    point: point - normal * depth,
                };
                let inertia = Inertia::of(body.rb);
                let mut event = correction(
                    EventKind::PushOut,
                    &site,
                    &inertia,
                    &before,
                    &plan.state,
                    0.0,
                );
                event.timing = ImpactTiming::StepStart;
                self.reports.events.push(event);
                found = contact_checked(part, gg, &plan.state, 0.0, body.reach_to(gg));
            }
        }
        if let Ok(Some((dist, normal, point))) = found {
            // The contact's normal and its point on the ground, in the ground's frame.
            let on_ground = nalgebra::Point3::from(point - normal * dist);
            let face_point = pose_g.inverse_transform_point(&on_ground).coords;
            let normal = pose_g.rotation.inverse() * normal;
            step.mesh_sides.insert(key, MeshSide { normal, face_point });
        }
        found
    }

    /// The role of a pair rapier's filtering keeps, by its contact at the body's current
    /// state: out of reach, rapier's (parry cannot query it), resting, `Step` mode's impulse
    /// or impact, a resting ball's rolling, held or reached (`rest_on_ground`); records the
    /// resting contacts turning slides (`plan.turning_resting`) and what the pair tells the
    /// search (`verdict`). Does not insert the role: the caller does.
    fn contact_role(
        &mut self,
        reads: BodyReads,
        plan: &mut BodyPlan,
        pair: Pair,
        verdict: &mut GroundVerdict,
        step: &mut StepData,
    ) -> Role {
        let body = reads.body;
        let Pair { k, part, gg, .. } = pair;
        let at_start = plan.state.com == body.start.com && plan.state.rot == body.start.rot;
        let found = match at_start.then(|| body.start_contact(k)).flatten() {
            Some(found) => found,
            None => contact_checked(part, gg, &plan.state, 0.0, body.reach_to(gg)),
        };
        let found = self.mesh_side(reads, plan, pair, found, step);
        let contact0 = found.as_ref().ok().copied().flatten();
        // A pair beyond reach cannot touch in this step: out of the solver, and no search
        // after the step.
        let reachable = matches!(found, Ok(Some(_)));
        let mut role = match found {
            // parry cannot query this pair: rapier keeps it, restitution included.
            Err(_) => Role::Rapier,
            Ok(None) => Role::Impact,
            Ok(Some(contact)) => self.touching_role(reads, plan, pair, contact, step),
        };
        // A ball sliding or rolling on a ground, alone on it: the closed form instead of
        // rapier's resting contact where it applies (`rolling_of`). rapier's contact turns
        // its point with the ball, which then hops and keeps slipping.
        if role == Role::Resting && !body.turns_surface && plan.rolling.is_none() && !plan.held {
            // Within the resting gap of it (a `Step` impulse can leave a ball resting on its
            // way down, up to a step's travel above the ground).
            if let Some(contact) =
                contact0.filter(|(dist, ..)| dist.abs() <= step.policy.resting_gap)
            {
                role = self.rest_on_ground(reads, plan, pair, contact, step);
            }
        }
        if role == Role::Resting
            && body.turning_reach(&plan.state, step.dt) > step.policy.resting_gap
        {
            if let Some((_, _, p)) = contact0 {
                let (gi, _) = &body.grounds[k];
                plan.turning_resting
                    .push((*gi, plan.state.rot.inverse() * (p - plan.state.com)));
            }
        }
        verdict.any_impact |= role == Role::Impact && reachable;
        // Only asked of a ground the search may run against (a single part's pair that is
        // not `Impact` does not make one).
        verdict.clear = verdict.clear
            && match contact0 {
                Some(_) if role != Role::Impact && body.geom.parts.len() == 1 => true,
                Some((dist, n, _)) => {
                    self.config.timing != TimingMode::Step
                        && cannot_close(
                            part,
                            gg,
                            &Sweep {
                                flight: body.flight,
                                s: &plan.state,
                                dt: step.dt,
                                radius: body.geom.radius,
                                speed: body.speed,
                                lag: step.integrator_lag,
                                gap: step.policy.resting_gap,
                            },
                            (dist, n),
                        )
                }
                None => false,
            };
        role
    }

    /// The role of a pair touching or within reach at `contact` (gap, normal, point): resting
    /// (`Policy::rests`, with hysteresis for a pair rapier held at rest last step), in `Step`
    /// mode the start impulse of a contact that closes in the step (`step_start_impulse`),
    /// else impact. May apply that impulse to `plan.state`; reads rapier's contact graph only
    /// where the policy asks whether the body is pressed. Inlined into both its callers: the
    /// per-pair plan, where it is hot, and `Step` mode's re-decision, which is cold.
    #[inline(always)]
    pub(super) fn touching_role(
        &mut self,
        reads: BodyReads,
        plan: &mut BodyPlan,
        pair: Pair,
        (dist, n, p): PairContact,
        step: &StepData,
    ) -> Role {
        let BodyReads { body, scene, last } = reads;
        let Pair { gg, key, .. } = pair;
        let flight = &body.flight;
        let u = body_velocity_at(&plan.state, &p) - gg.velocity_at(&p, 0.0);
        let un = n.dot(&u);
        // The normal speed the contact will have on reaching the ground (gravity, or any
        // acceleration towards it, included): `sqrt(un^2 + 2 |an| dist)`.
        let an = n.dot(&flight.accel);
        let arrival = (un * un + 2.0 * (-an).max(0.0) * dist.max(0.0)).sqrt();
        // Hysteresis: a pair rapier held at rest last step shows the normal speed rapier's
        // solver leaves at rest (up to g dt and more for a fast-rolling ball): it stays
        // resting unless clearly hit.
        let prev_role = last.roles.get(&key);
        // A ball the closed form rolled ends on its plane: one above it has left it since
        // (an impact lifted it, and it flies), and is not held (the hysteresis would put it
        // back on the ground, within the resting gap, with no event).
        let was_resting = match prev_role {
            Some(Role::Resting) => true,
            Some(Role::Rolling) => dist <= COPLANAR_TOLERANCE,
            _ => false,
        };
        // The plugin had the pair last step: what touched the body then is known (a body new
        // near the ground has nothing to go on).
        let measured = matches!(
            prev_role,
            Some(&Role::Resting | &Role::Impact | &Role::Rolling)
        );
        // A pressed contact: a resting pair of a body that also touched another body (or a
        // wall, or had a joint) last step approaches only because something pushes it (a
        // box dropped on it, the pile above it). The push must stay inside rapier's solver,
        // which holds the body out of the ground, so rapier keeps the pair, with e = 0
        // (`Policy::rests`): out of the solver the push would sink the body for a step and
        // the end of step would bounce it back out. What touched the body is asked only
        // where it decides (rarely: most resting pairs are slow), and only of a body
        // measured after the last step.
        let rb = body.rb;
        let pressed =
            || measured && touched_besides_grounds(body.handle, rb, scene.sets, self.registry);
        if step.policy.rests(dist, arrival, was_resting, pressed) {
            Role::Resting
        } else if self.config.timing == TimingMode::Step {
            self.step_mode_role(reads, plan, pair, (dist, n, p), (un, step))
        } else {
            Role::Impact
        }
    }

    /// [`Self::touching_role`] in `Step` mode for a pair that does not rest, at `contact`
    /// with normal speed `un`: the start impulse of a contact that closes in the step
    /// (`step_start_impulse`), else impact. Out of line: the other modes' plans skip it.
    ///
    /// The contact closes when its gap, carried along the start normal, closes within the
    /// step (`closes_within`) and, for a gap still open, the search along the body's flight
    /// finds the part touching the ground in the step (`first_impact`), or rapier's
    /// integrator, lagging behind that flight, would (`touches_in_step`): a path that passes
    /// an edge or a corner closes the first line without ever touching.
    #[cold]
    #[inline(never)]
    fn step_mode_role(
        &mut self,
        reads: BodyReads,
        plan: &mut BodyPlan,
        pair: Pair,
        (dist, n, p): PairContact,
        (un, step): (f64, &StepData),
    ) -> Role {
        let closes = closes_within(dist, un, n.dot(&(reads.body.flight.accel)), step.dt)
            && un < 0.0
            && (dist <= 0.0 || touches_in_step(reads, plan, &pair, (step.dt, step.integrator_lag)));
        if closes {
            let hit = Hit {
                part: pair.part_index,
                ground: 0,
                dist,
                normal: n,
                point: p,
                un,
            };
            self.step_start_impulse(reads, plan, pair, &hit, step)
        } else {
            Role::Impact
        }
    }
}

/// A pair decided again in the step (its key already in `step.roles`, which now holds
/// `planned`'s role): its entry in `step.ground_pairs` takes `planned`, so that the list keeps
/// one entry a key, with the role the map keeps. Out of line: a pair is most often decided
/// once.
#[cold]
#[inline(never)]
pub(super) fn decided_again(step: &mut StepData, planned: GroundPair) {
    if let Some(held) = step.ground_pairs.iter_mut().rfind(|p| p.key == planned.key) {
        *held = planned;
    }
}

/// The role of a pair of a ball already rolling in closed form on the plane of an earlier
/// (nearer) ground (from its state `state`, `pieces` the grounds of that plane); a ball that
/// does not roll yet is not asked. A piece of that plane: the pair is the rolling's too, out
/// of rapier's solver (rapier's contact with a tile's edge at a flush seam would throw the
/// ball up, and `Step` mode would bounce it). Another ground it may roll into (a slope's
/// foot, a wall): out of rapier's solver too, and the search along the rolling finds the
/// impact, run only if the ground is within reach (`verdict`). Reads only.
fn rolling_piece_role(
    body: &BodyNear,
    (state, pieces): (&State, &SmallList<ColliderHandle>),
    pair: Pair,
    verdict: &mut GroundVerdict,
) -> Role {
    let Pair { k, part, gg, .. } = pair;
    if pieces.contains(&gg.handle) {
        return Role::Rolling;
    }
    let found = body
        .start_contact(k)
        .unwrap_or_else(|| contact_checked(part, gg, state, 0.0, body.reach_to(gg)));
    verdict.any_impact |= within_reach(&found);
    Role::Impact
}

/// Does the pair's part touch its ground, approaching, within `[0, dt]` of the body's flight
/// from `plan.state` (`first_impact` over that part and ground alone), or end the step closer
/// to it than rapier's integrator lags behind that flight (`lag` per unit of acceleration:
/// `StepData::integrator_lag`), so that rapier's own step closes it? A search that gives up
/// counts as touching: the contact then closes as its start normal says.
fn touches_in_step(reads: BodyReads, plan: &BodyPlan, pair: &Pair, (dt, lag): (f64, f64)) -> bool {
    let body = reads.body;
    let mut parts = SmallList::default();
    parts.push(*pair.part);
    let part_alone = BodyGeom {
        parts,
        radius: body.geom.radius,
    };
    let flight = body.flight;
    let grounds = std::slice::from_ref(pair.gg);
    if !matches!(
        first_impact(&part_alone, grounds, flight, &plan.state, 0.0, 0.0, dt),
        Search::Clear
    ) {
        return true;
    }
    let end = flight.advance(&plan.state, dt);
    let sink = lag * flight.accel.norm();
    contact_checked(pair.part, pair.gg, &end, dt, sink)
        .is_ok_and(|c| c.is_some_and(|(dist, n, _)| dist <= lag * (-n.dot(&flight.accel)).max(0.0)))
}

/// Is the contact within reach (found, and parry could query it)?
fn within_reach(found: &StartContact) -> bool {
    matches!(found, Ok(Some(_)))
}
