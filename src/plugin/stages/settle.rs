//! Settle: after rapier's step, one end-of-step check of what a body's end state holds in a
//! ground, and one decision table for what is done about it.
//!
//! Contract: [`AfterStep::check`] takes a body's end state (rapier's, or the in-step impacts'
//! from `reconstruct.rs`), the reason it is checked ([`EndCheck`], a row group of the table
//! [`crate::plugin::policy::Policy::end_action`]) and the grounds to check it against; it finds the
//! deepest point, asks the table, and returns the corrected state: a push-out
//! (`EventKind::PushOut`), step-end impacts from the model (`EventKind::Impact`,
//! `ImpactTiming::StepEnd`), and an energy cap (`EventKind::EnergyCap`), each reported as an
//! event. It reads rapier's state, the step's plan ([`EndOfStep`]) and the registry, and
//! writes nothing into rapier: the caller commits the state.
//!
//! The pure state corrections are free functions: [`put_on_ground`] moves a state out of the
//! ground along a contact normal (for a ball, also removing its speed into the ground);
//! [`capped_energy`] scales a state's velocities so that its mechanical energy is no more
//! than another's.

use crate::motion::{Flight, State};
use crate::plugin::bridge::convert::to_f64;
use crate::plugin::bridge::resolve::{
    ImpactInput, Inertia, PairSide, Site, correction, material, resolve, resolve_balls,
};
use crate::plugin::events::{EventKind, ImpactTiming};
use crate::plugin::policy::{EndAction, EndCheck, Role, Surroundings};
use crate::plugin::queries::filter;
use crate::plugin::queries::geometry::{BodyGeom, GroundGeom, closest, landing_point};
use crate::plugin::queries::ground_index::GroundMotion;
use crate::plugin::queries::observe::{
    NonGround, body_geom, ground_geom, neighbours, rapier_state, touched_besides_grounds,
};
use crate::plugin::stages::commit::Origin;
use crate::plugin::stages::pair_plan::PlannedPair;
use crate::plugin::state::small_list::SmallList;
use crate::plugin::state::step::AfterStep;
use crate::plugin::state::step::Candidate;
use crate::plugin::state::step::EndOfStep;
use crate::plugin::state::step::StepData;
use crate::rapier::math::{Real, Vector};
use crate::rapier::prelude::{
    ActiveHooks, ColliderHandle, ColliderSet, RigidBody, RigidBodyHandle, RigidBodySet,
};
use nalgebra::Vector3;

/// `s` moved out of the ground along `hit`'s normal and, if `stop`, without its speed into
/// the ground: what a resting contact holds a ball at (for a ball, an `e = 0` frictionless
/// normal impulse, through its centre).
pub(crate) fn put_on_ground(
    s: &mut State,
    hit: &crate::plugin::queries::geometry::Hit,
    stop: bool,
) {
    s.com -= hit.normal * hit.dist;
    let vn = hit.normal.dot(&s.v);
    if stop && vn < 0.0 {
        s.v -= hit.normal * vn;
    }
}

/// `end` with its velocities scaled down by one factor (directions kept) so that its
/// mechanical energy `1/2 m v^2 + 1/2 w.I w - m a.x` (`a` the flight's constant acceleration)
/// is no more than `start`'s, or `None` when it already is (within the rounding of the
/// potential at rapier's precision, so that `f32` positions far from the origin do not
/// drain a slow body). When even the potential energy exceeds the start's energy, the body
/// is left at rest.
pub(crate) fn capped_energy(
    start: &State,
    end: &State,
    flight: &Flight,
    inertia: &Inertia,
) -> Option<State> {
    let energy = |s: &State| {
        let velocity = crate::model::BodyVelocity {
            linear: s.v,
            angular: s.w,
        };
        let kinetic = inertia.body_at(&s.rot).kinetic_energy(&velocity);
        (kinetic, kinetic - inertia.mass * flight.accel.dot(&s.com))
    };
    let (_, start_total) = energy(start);
    let (end_kinetic, end_total) = energy(end);
    let rounding = inertia.mass
        * flight.accel.norm()
        * to_f64(Real::EPSILON)
        * (1.0 + start.com.norm() + end.com.norm());
    if !(end_total > start_total + rounding && end_kinetic > 0.0) {
        return None;
    }
    let scale = ((end_kinetic - (end_total - start_total)).max(0.0) / end_kinetic).sqrt();
    Some(State {
        v: end.v * scale,
        w: end.w * scale,
        ..*end
    })
}

/// A body the settle stage checks, with what its checks need.
pub(crate) struct Checked<'c> {
    pub body: RigidBodyHandle,
    pub geom: &'c BodyGeom<'c>,
    pub inertia: &'c Inertia,
    /// The plan's candidate: the energy cap's start state and flight, the resting contacts.
    /// `None` for a body asleep at the start (no plan, no cap).
    pub cand: Option<&'c Candidate>,
    /// The grounds it is checked against.
    pub grounds: &'c [GroundGeom<'c>],
    /// Where the body's events of the step start among the step's events (the energy cap is
    /// for bodies with no restitution above 1 among them).
    pub events_from: usize,
}

impl AfterStep<'_> {
    /// The one end-of-step check: the body's deepest point at `end` against `grounds`, the
    /// decision table's action for `why` ([`crate::plugin::policy::Policy::end_action`]), and that
    /// action on `end`:
    /// - `PushOut`: moved out along the normal (`put_on_ground`), a `PushOut` event;
    /// - `Impact`: the model's impulse at the contact (`ImpactTiming::StepEnd`, `e = 0` if
    ///   settling, or at the body's last allowed impact), moved out, and again for the next
    ///   deepest point under the `RapierEnd` row, up to `max_impacts_per_step`;
    /// - then, if it changed the state, the energy cap (`cap_if_gained`).
    ///
    /// Returns the action taken on the first point and the corrected state (`None`: `end`
    /// stands). It writes nothing into rapier: the caller commits the state. `events_from` is
    /// where this body's events of the step start in `self.events` (the cap is for bodies
    /// with no restitution above 1 among them).
    pub fn check(
        &mut self,
        bodies: &RigidBodySet,
        colliders: &ColliderSet,
        checked: &Checked,
        end: &State,
        why: EndCheck,
        step: &EndOfStep,
    ) -> (EndAction, Option<State>) {
        let (body, grounds) = (checked.body, checked.grounds);
        let Some(rb) = bodies.get(body) else {
            return (EndAction::Keep, None);
        };
        let dt = step.dt;
        let mut s = *end;
        let mut first = EndAction::Keep;
        let mut settle = false;
        let mut changed = false;
        let mut around: Option<NonGround> = None;
        let mut neighbours_of = || {
            *around
                .get_or_insert_with(|| neighbours(body, rb, &step.sets, self.registry, &step.down))
        };
        for k in 0..self.config.max_impacts_per_step {
            let Some(hit) = closest(checked.geom, grounds, &s, dt, 0.0) else {
                break;
            };
            let rule = if k == 0 { why } else { EndCheck::RapierEnd };
            let action = step.policy.end_action(rule, hit.dist, hit.un, || {
                let around = neighbours_of();
                Surroundings {
                    touching: around.touching,
                    loaded: around.loaded,
                    pivot_pushed: checked
                        .cand
                        .is_some_and(|c| pivot_pushed(c, &grounds[hit.ground], &hit, &s, step)),
                }
            });
            if k == 0 {
                first = action;
            }
            match action {
                EndAction::Keep => break,
                EndAction::PushOut { stop } => {
                    let before = s;
                    put_on_ground(&mut s, &hit, stop);
                    self.report_push_out(checked, &hit, &before, &s, step);
                    changed |= s != before;
                    break;
                }
                EndAction::Impact { settle: settling } => settle |= settling,
            }
            let part = &checked.geom.parts[hit.part];
            let gg = &grounds[hit.ground];
            let (point, points) = landing_point(part, gg, &s, dt, &hit, self.config.flat_tolerance);
            let input = ImpactInput {
                body,
                inertia: checked.inertia,
                law: self.config.law,
                material: self.registry.material_of(colliders, part.handle, gg.handle),
                // A body that touched another body or a wall in the step: no bounce slower
                // than a fall through the resting gap (see the pressed roles).
                resting_speed: if neighbours_of().touching {
                    step.policy.pressed_speed
                } else {
                    step.policy.resting_speed
                },
                force_settle: settle || k + 1 >= self.config.max_impacts_per_step,
                timing: ImpactTiming::StepEnd,
            };
            let Some((after, event)) =
                resolve(&input, checked.geom, gg, &s, dt, &hit, point, points)
            else {
                break;
            };
            s = after;
            s.com -= hit.normal * hit.dist;
            self.commit.event(event);
            changed = true;
        }
        if !changed {
            return (first, None);
        }
        if let Some(capped) = self.cap_if_gained(rb, colliders, checked, &s, step) {
            s = capped;
        }
        (first, Some(s))
    }

    /// A state moved out of the ground by position at the step's end gains the potential
    /// energy of the lift: its end state is deeper than any state of a true flight (a corner
    /// swung or a ball rode into the ground), and moving it out keeps the speed it gathered
    /// getting there. Repeated every step, that lift would feed a body rocking on its corners
    /// at the step rate. Invariant: a body whose energy can only have been lost
    /// (`may_cap_energy`, and no restitution above 1 among its events of the step from
    /// `Checked::events_from`) ends no higher in mechanical energy, in its constant force
    /// field (`Flight::accel`), than it started (`capped_energy`); the cap is reported as an
    /// `EnergyCap` event at the site of the body's last event.
    fn cap_if_gained(
        &mut self,
        rb: &RigidBody,
        colliders: &ColliderSet,
        checked: &Checked,
        end: &State,
        step: &EndOfStep,
    ) -> Option<State> {
        let cand = checked.cand?;
        let elastic = self.commit.reported()[checked.events_from..]
            .iter()
            .all(|e| e.body != checked.body || e.restitution <= 1.0);
        if !elastic || !self.may_cap_energy(rb, colliders, cand, step) {
            return None;
        }
        let site = self
            .commit
            .reported()
            .iter()
            .rev()
            .find(|e| e.body == checked.body)
            .map(Site::of)?;
        let capped = capped_energy(&cand.start, end, &cand.flight, checked.inertia)?;
        self.commit.event(correction(
            EventKind::EnergyCap,
            &site,
            checked.inertia,
            end,
            &capped,
            step.dt,
        ));
        Some(capped)
    }

    /// Nothing but still grounds touched the candidate in the step (no body, wall or joint:
    /// read from rapier's contact graph after the step), through the plugin's pairs with no contact
    /// modification of the user's, and no user torque acted: its energy can only have been
    /// lost.
    fn may_cap_energy(
        &self,
        rb: &RigidBody,
        colliders: &ColliderSet,
        cand: &Candidate,
        step: &EndOfStep,
    ) -> bool {
        let grounds = &step.grounds;
        if rb.user_torque() != Vector::ZERO
            || touched_besides_grounds(cand.body, rb, &step.sets, self.registry)
        {
            return false;
        }
        let modifies = |c| {
            self.flags
                .recorded_user_flags(colliders, c)
                .contains(ActiveHooks::MODIFY_SOLVER_CONTACTS)
        };
        // Every ground pair of the body (only the grounds near it have one): a still ground,
        // the plugin's role, no contact modification of the user's (a conveyor ground puts
        // energy in).
        rb.colliders().iter().all(|ch| {
            !modifies(*ch)
                && cand.near.iter().map(|i| &grounds[*i]).all(|gm| {
                    match self.roles.get(&(*ch, gm.handle)) {
                        None | Some(Role::Filtered) => true,
                        Some(Role::Rapier) => false,
                        Some(_) => {
                            gm.v == Vector3::zeros()
                                && gm.w == Vector3::zeros()
                                && !modifies(gm.handle)
                        }
                    }
                })
        })
    }

    /// The geometry of a candidate's `Impact` grounds, without its `Filtered` pairs (no
    /// contact for the plugin).
    pub fn impact_ground_geoms<'a>(
        &self,
        cand: &Candidate,
        geom: &BodyGeom,
        colliders: &'a ColliderSet,
        step: &StepData,
    ) -> SmallList<GroundGeom<'a>> {
        cand.impact_grounds
            .iter()
            .filter_map(|i| self.pair_geom(&step.grounds[*i], geom, colliders))
            .collect()
    }

    /// The geometry of the grounds of a candidate's resting pairs turning fast, each ground
    /// once (a body of several colliders lists it per collider).
    pub fn turning_resting_geoms<'a>(
        &self,
        cand: &Candidate,
        geom: &BodyGeom,
        colliders: &'a ColliderSet,
        step: &StepData,
    ) -> SmallList<GroundGeom<'a>> {
        let listed = &cand.turning_resting;
        listed
            .iter()
            .enumerate()
            .filter(|(k, (i, _))| !listed[..*k].iter().any(|(j, _)| j == i))
            .filter_map(|(_, (i, _))| self.pair_geom(&step.grounds[*i], geom, colliders))
            .collect()
    }

    /// The geometry of the grounds near a body asleep at the step's start (it has no roles),
    /// without the pairs rapier would not solve or the user `refused`.
    pub fn woken_geoms<'a>(
        &self,
        bodies: &RigidBodySet,
        colliders: &'a ColliderSet,
        com: Vector,
        geom: &BodyGeom,
        step: &StepData,
        refused: &dyn Fn(&RigidBodySet, ColliderHandle, ColliderHandle) -> bool,
    ) -> SmallList<GroundGeom<'a>> {
        let half = crate::plugin::bridge::convert::to_real(geom.radius + step.policy.resting_gap);
        self.registry
            .index
            .near(&step.grounds, com, half)
            .iter()
            .filter_map(|i| {
                let mut gg = ground_geom(&step.grounds[*i], colliders)?;
                let ground = &colliders[gg.handle];
                gg.skip = geom
                    .parts
                    .iter()
                    .map(|part| part.handle)
                    .filter(|h| {
                        !filter::rapier_solves(bodies, &colliders[*h], ground)
                            || refused(bodies, *h, gg.handle)
                    })
                    .collect();
                Some(gg)
            })
            .collect()
    }

    /// A ground's geometry for the queries of a body whose pairs have roles this step, its
    /// `Filtered` pairs skipped.
    pub fn pair_geom<'a>(
        &self,
        gm: &GroundMotion,
        geom: &BodyGeom,
        colliders: &'a ColliderSet,
    ) -> Option<GroundGeom<'a>> {
        let mut gg = ground_geom(gm, colliders)?;
        gg.skip = geom
            .parts
            .iter()
            .map(|part| part.handle)
            .filter(|h| self.roles.get(&(*h, gg.handle)) == Some(&Role::Filtered))
            .collect();
        Some(gg)
    }

    /// After the step, for an `Impact` pair of balls not moved together (something else
    /// touched one, or a search gave up): rapier's end state, in which the pair was out of
    /// its solver, so that the balls may have passed into, or right through, each other. If
    /// they met in the step (they overlap, their centres crossed the line of centres they
    /// started on, or their straight relative motion came within reach), the model's impulse
    /// along that line (`ImpactTiming::StepEnd`; no bounce slower than the resting speed, or
    /// the pressed speed for a ball touching something else), and both balls moved apart
    /// along it to touching, on the sides they started on, each by its inverse-mass share,
    /// with a `PushOut` event each. Other shapes: [`AfterStep::pair_end_bodies`].
    pub fn pair_end(
        &mut self,
        bodies: &mut RigidBodySet,
        colliders: &ColliderSet,
        pair: &PlannedPair,
        step: &EndOfStep,
    ) {
        if !pair.balls {
            return self.pair_end_bodies(bodies, colliders, pair, step);
        }
        let (Some(ra), Some(rb)) = (bodies.get(pair.a), bodies.get(pair.b)) else {
            return;
        };
        let (mut sa, mut sb) = (rapier_state(ra), rapier_state(rb));
        let d = sb.com - sa.com;
        let len = d.norm();
        // Out of rapier's solver, the balls may have passed into or through each other in the
        // step: they met if they overlap now, if their centres crossed the line of centres
        // they started on, or if their relative motion over the step (straight, as out of the
        // solver) came within reach.
        let crossed = d.dot(&pair.normal) < 0.0;
        let dv = sb.v - sa.v;
        let back = dv.norm_squared();
        let nearest = if back > 0.0 {
            // The closest approach of d - dv s for s in [0, dt] before the step's end.
            let s_min = (d.dot(&dv) / back).clamp(0.0, step.dt);
            (d - dv * s_min).norm()
        } else {
            len
        };
        let met = len < pair.reach || crossed || nearest < pair.reach;
        if !met || pair.normal == Vector3::zeros() && len == 0.0 {
            return;
        }
        // The contact normal: the line of centres now, or the one they started on if they
        // have crossed (or passed by).
        let n = if !crossed && len > 0.0 && len < pair.reach {
            d / len
        } else {
            pair.normal
        };
        // How far apart to move them along n: to touching, on the sides they started on.
        let along = d.dot(&n);
        let overlap = (pair.reach - along).max(0.0);
        // The model's impulse is taken with the balls touching along n.
        let touching_b = State {
            com: sa.com + n * pair.reach,
            ..sb
        };
        let (ia, ib) = (Inertia::of(ra), Inertia::of(rb));
        let (ca, cb) = (pair.key.0, pair.key.1);
        // The key orders the colliders by slot: match them to the bodies.
        let (ca, cb) = if colliders.get(ca).and_then(|c| c.parent()) == Some(pair.a) {
            (ca, cb)
        } else {
            (cb, ca)
        };
        let radius = |c: ColliderHandle| {
            colliders.get(c).and_then(|co| {
                Some(to_f64(co.shape().as_ball()?.radius) + to_f64(co.contact_skin()))
            })
        };
        let (Some(rad_a), Some(rad_b)) = (radius(ca), radius(cb)) else {
            return;
        };
        let side_a = PairSide::new(pair.a, ca, &ia, sa, rad_a);
        let side_b = PairSide::new(pair.b, cb, &ib, touching_b, rad_b);
        let input = self.step_end_input(&side_a, (ra, rb), &side_b, colliders, step);
        if let Some((after_a, after_b, events)) = resolve_balls(&input, &side_a, &side_b, step.dt) {
            self.commit.events(events);
            sa = after_a;
            sb = State {
                com: sb.com,
                ..after_b
            };
        }
        // Each ball's push-out at its surface point facing the other ball.
        let facing =
            |side: &Pushed, before: &State, normal: Vector3<f64>| before.com - normal * side.radius;
        self.push_apart(
            [
                Pushed::new(pair.a, ca, &ia, &mut sa, rad_a),
                Pushed::new(pair.b, cb, &ib, &mut sb, rad_b),
            ],
            n,
            overlap,
            facing,
            step.dt,
        );
        self.check_moved_apart(bodies, colliders, [(pair.a, sa), (pair.b, sb)], step);
    }

    /// [`AfterStep::pair_end`] for a pair not both centred balls: where parry finds the two
    /// bodies touching or overlapping at rapier's end state, the model's impulse at their
    /// contact (the flat-landing points of `touch_point`; `ImpactTiming::StepEnd`, no bounce
    /// slower than the resting speed, or the pressed speed for a body touching something
    /// else) if they approach there, and both moved apart along the contact normal to
    /// touching, each by its inverse-mass share, with a `PushOut` event each. (A pair that
    /// passed through each other inside the step is not found: the step's end is all that is
    /// checked, as rapier's solver would see it.)
    fn pair_end_bodies(
        &mut self,
        bodies: &mut RigidBodySet,
        colliders: &ColliderSet,
        pair: &PlannedPair,
        step: &EndOfStep,
    ) {
        use crate::plugin::bridge::resolve::{BodyContactAt, resolve_bodies};
        use crate::plugin::queries::body_contact::{body_contact, touch_point};
        let (Some(ra), Some(rb)) = (bodies.get(pair.a), bodies.get(pair.b)) else {
            return;
        };
        let (mut sa, mut sb) = (rapier_state(ra), rapier_state(rb));
        let (la, lb) = (
            crate::plugin::bridge::convert::vec_to_na(ra.local_center_of_mass()),
            crate::plugin::bridge::convert::vec_to_na(rb.local_center_of_mass()),
        );
        let (ga, gb) = (body_geom(ra, colliders, &la), body_geom(rb, colliders, &lb));
        let Some(touch) = body_contact(&ga, &sa, &gb, &sb, 0.0) else {
            return;
        };
        let (ca, cb) = (
            ga.parts[touch.parts.0].handle,
            gb.parts[touch.parts.1].handle,
        );
        let (ia, ib) = (Inertia::of(ra), Inertia::of(rb));
        let (point, points) = touch_point(&ga, &sa, &gb, &sb, &touch, self.config.flat_tolerance);
        let side_a = PairSide::new(pair.a, ca, &ia, sa, 0.0);
        let side_b = PairSide::new(pair.b, cb, &ib, sb, 0.0);
        let input = self.step_end_input(&side_a, (ra, rb), &side_b, colliders, step);
        let at = BodyContactAt {
            normal: touch.normal,
            point,
            points,
        };
        if let Some((after_a, after_b, events)) =
            resolve_bodies(&input, &side_a, &side_b, &at, step.dt)
        {
            self.commit.events(events);
            (sa, sb) = (after_a, after_b);
        }
        let overlap = (-touch.dist).max(0.0);
        self.push_apart(
            [
                Pushed::new(pair.a, ca, &ia, &mut sa, 0.0),
                Pushed::new(pair.b, cb, &ib, &mut sb, 0.0),
            ],
            touch.normal,
            overlap,
            |_: &Pushed, _: &State, _| touch.point,
            step.dt,
        );
        self.check_moved_apart(bodies, colliders, [(pair.a, sa), (pair.b, sb)], step);
    }

    /// Moves the two bodies of a pair apart along `n` (from the first towards the second) by
    /// `overlap` (m), each by its inverse-mass share, with a `PushOut` event each at the point
    /// `point` gives (from the body, its state before and the normal into it).
    fn push_apart(
        &mut self,
        pair: [Pushed; 2],
        n: Vector3<f64>,
        overlap: f64,
        point: impl Fn(&Pushed, &State, Vector3<f64>) -> Vector3<f64>,
        dt: f64,
    ) {
        if overlap <= 0.0 {
            return;
        }
        let [a, b] = pair;
        let (wa, wb) = (1.0 / a.inertia.mass, 1.0 / b.inertia.mass);
        let (ha, ca, hb, cb) = (a.body, a.collider, b.body, b.collider);
        let moves = [(a, -n, wa, hb, cb), (b, n, wb, ha, ca)];
        for (side, normal, w, body2, other) in moves {
            let before = *side.state;
            side.state.com += normal * (overlap * w / (wa + wb));
            let site = Site {
                body: side.body,
                collider: side.collider,
                ground: other,
                body2: Some(body2),
                normal,
                point: point(&side, &before, normal),
            };
            self.commit.event(correction(
                EventKind::PushOut,
                &site,
                side.inertia,
                &before,
                side.state,
                dt,
            ));
        }
    }

    /// The model's input for a pair resolved at the step's end (`ImpactTiming::StepEnd`): no
    /// bounce slower than the resting speed, or the pressed speed if either body touched
    /// something else in the step.
    fn step_end_input<'a>(
        &self,
        a: &PairSide<'a>,
        (ra, rb): (&RigidBody, &RigidBody),
        b: &PairSide,
        colliders: &ColliderSet,
        step: &EndOfStep,
    ) -> ImpactInput<'a> {
        let pressed = |h: RigidBodyHandle, rb: &RigidBody| {
            touched_besides_grounds(h, rb, &step.sets, self.registry)
        };
        let touching = pressed(a.body, ra) || pressed(b.body, rb);
        ImpactInput::between(
            a,
            self.config.law,
            material(&colliders[a.collider], &colliders[b.collider], None),
            if touching {
                step.policy.pressed_speed
            } else {
                step.policy.resting_speed
            },
            ImpactTiming::StepEnd,
        )
    }

    /// Writes the two bodies of a pair resolved at the step's end: moved apart, a body may be
    /// moved into a ground (a light ball pushed down by a heavy one), so each is checked
    /// against the grounds near it, as rapier's end state is.
    fn check_moved_apart(
        &mut self,
        bodies: &mut RigidBodySet,
        colliders: &ColliderSet,
        moved: [(RigidBodyHandle, State); 2],
        step: &EndOfStep,
    ) {
        for (body, state) in moved {
            let rb = &bodies[body];
            let local_com = crate::plugin::bridge::convert::vec_to_na(rb.local_center_of_mass());
            let geom = body_geom(rb, colliders, &local_com);
            let inertia = Inertia::of(rb);
            let com = crate::plugin::bridge::convert::vec_from_na(&state.com);
            let grounds = self.woken_geoms(bodies, colliders, com, &geom, step, &|_, _, _| false);
            let checked = Checked {
                body,
                geom: &geom,
                inertia: &inertia,
                cand: None,
                grounds: &grounds,
                events_from: self.commit.reported().len(),
            };
            let why = EndCheck::RapierEnd;
            let (_, settled) = self.check(bodies, colliders, &checked, &state, why, step);
            let end = settled.unwrap_or(state);
            self.commit
                .state(bodies, body, &end, &local_com, Origin::Correction);
        }
    }

    /// Reports a push-out (`put_on_ground`) from `before` to `after` at `hit`, unless it
    /// changed nothing.
    fn report_push_out(
        &mut self,
        checked: &Checked,
        hit: &crate::plugin::queries::geometry::Hit,
        before: &State,
        after: &State,
        step: &StepData,
    ) {
        if before.com == after.com && before.v == after.v {
            return;
        }
        let site = Site::of_hit(checked.body, checked.geom, checked.grounds, hit);
        self.commit.event(correction(
            EventKind::PushOut,
            &site,
            checked.inertia,
            before,
            after,
            step.dt,
        ));
    }
}

/// Is a turning resting body's resting contact point on the ground of `hit` pushed into it
/// faster than the pressed speed at `s` (a body pressed from above, not turning about the
/// contact)?
fn pivot_pushed(
    cand: &Candidate,
    ground: &GroundGeom,
    hit: &crate::plugin::queries::geometry::Hit,
    s: &State,
    step: &EndOfStep,
) -> bool {
    cand.turning_resting.iter().any(|(i, local)| {
        if step.grounds[*i].handle != ground.handle {
            return false;
        }
        let p = s.com + s.rot * local;
        let u = crate::plugin::queries::geometry::body_velocity_at(s, &p)
            - ground.velocity_at(&p, step.dt);
        hit.normal.dot(&u) < -step.policy.pressed_speed
    })
}

/// A body of a pair moved apart at the step's end (`AfterStep::push_apart`).
struct Pushed<'s> {
    body: RigidBodyHandle,
    collider: ColliderHandle,
    inertia: &'s Inertia,
    state: &'s mut State,
    /// A ball's radius to its contact point (m; 0 for other shapes).
    radius: f64,
}

impl<'s> Pushed<'s> {
    fn new(
        body: RigidBodyHandle,
        collider: ColliderHandle,
        inertia: &'s Inertia,
        state: &'s mut State,
        radius: f64,
    ) -> Self {
        Self {
            body,
            collider,
            inertia,
            state,
            radius,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rapier::prelude::{ColliderBuilder, RigidBodyBuilder};
    use nalgebra::{UnitQuaternion, Vector3};

    /// A 0.3 x 0.2 x 0.1 m brick (density 1): its inertia, and the flight under gravity.
    fn brick() -> (Inertia, Flight) {
        let mut world = crate::rapier::prelude::PhysicsWorld::default();
        let (handle, _) = world.insert(
            RigidBodyBuilder::dynamic(),
            ColliderBuilder::cuboid(0.15, 0.1, 0.05),
        );
        let flight = Flight {
            accel: Vector3::new(0.0, -9.81, 0.0),
            linear_damping: 0.0,
            angular_damping: 0.0,
            gyro: None,
        };
        (Inertia::of(&world.bodies[handle]), flight)
    }

    fn total_energy(s: &State, inertia: &Inertia, flight: &Flight) -> f64 {
        let velocity = crate::model::BodyVelocity {
            linear: s.v,
            angular: s.w,
        };
        inertia.body_at(&s.rot).kinetic_energy(&velocity) - inertia.mass * flight.accel.dot(&s.com)
    }

    #[test]
    fn a_lift_that_adds_energy_is_paid_from_the_speeds() {
        let (inertia, flight) = brick();
        let rot = UnitQuaternion::from_euler_angles(0.3, -0.2, 0.7);
        let start = State {
            com: Vector3::new(0.0, 0.1, 0.0),
            rot,
            v: Vector3::new(0.5, -0.2, 0.1),
            w: Vector3::new(1.0, 2.0, -3.0),
        };
        // Pushed 4 mm up at the end with the start's velocities: more energy than at start.
        let end = State {
            com: Vector3::new(0.01, 0.104, 0.0),
            ..start
        };
        let capped = capped_energy(&start, &end, &flight, &inertia).expect("energy was gained");
        let (e0, e1) = (
            total_energy(&start, &inertia, &flight),
            total_energy(&capped, &inertia, &flight),
        );
        assert!((e1 - e0).abs() <= 1e-12 * e0.abs(), "{e0} -> {e1}");
        // One factor for both velocities, below 1; the pose untouched.
        let k = capped.v.norm() / end.v.norm();
        assert!(k < 1.0 && k > 0.0);
        assert!((capped.v - end.v * k).norm() < 1e-15 && (capped.w - end.w * k).norm() < 1e-14);
        assert_eq!((capped.com, capped.rot), (end.com, end.rot));
    }

    #[test]
    fn a_state_without_gain_is_left_alone_and_a_lift_beyond_the_energy_stops_the_body() {
        let (inertia, flight) = brick();
        let start = State {
            com: Vector3::new(0.0, 0.1, 0.0),
            rot: UnitQuaternion::identity(),
            v: Vector3::new(0.0, -0.3, 0.0),
            w: Vector3::zeros(),
        };
        // Lower and as fast: energy lost.
        let lower = State {
            com: Vector3::new(0.0, 0.09, 0.0),
            ..start
        };
        assert_eq!(capped_energy(&start, &lower, &flight, &inertia), None);
        // Lifted 1 cm: more than 1/2 v^2 / g = 4.6 mm can pay for.
        let lifted = State {
            com: Vector3::new(0.0, 0.11, 0.0),
            ..start
        };
        let capped = capped_energy(&start, &lifted, &flight, &inertia).unwrap();
        assert_eq!((capped.v, capped.w), (Vector3::zeros(), Vector3::zeros()));
        // At rest and lifted: nothing to scale, nothing done.
        let resting = State {
            v: Vector3::zeros(),
            ..lifted
        };
        assert_eq!(capped_energy(&start, &resting, &flight, &inertia), None);
    }
}
