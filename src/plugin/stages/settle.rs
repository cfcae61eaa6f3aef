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
//! [`capped_energy`] scales a state's velocities down so that its mechanical energy is no more
//! than another's.

use crate::motion::{Flight, State};
use crate::plugin::bridge::convert::{to_f64, vec_to_na};
use crate::plugin::bridge::resolve::{
    GroundContactAt, ImpactInput, Inertia, Site, correction, resolve,
};
use crate::plugin::events::{EventKind, ImpactEvent, ImpactTiming};
use crate::plugin::policy::{EndAction, EndCheck, Role, Surroundings};
use crate::plugin::queries::geometry::{
    BodyGeom, BodyPart, GroundGeom, Hit, PairContact, closest, contact_from_side,
    entry_face_contact, part_pose,
};
use crate::plugin::queries::ground_index::GroundMotion;
use crate::plugin::queries::observe::{
    NonGround, Sets, ground_geom, neighbours, touched_besides_grounds,
};
use crate::plugin::stages::view::AfterStep;
use crate::plugin::stages::view::EndOfStep;
use crate::plugin::state::handles::PairKey;
use crate::plugin::state::small_list::SmallList;
use crate::plugin::state::step::Candidate;
use crate::plugin::state::step::StepData;
use crate::rapier::math::{Real, Vector};
use crate::rapier::prelude::{ActiveHooks, ColliderSet, RigidBody, RigidBodyHandle, RigidBodySet};
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

/// `end` with its mechanical energy `1/2 m v^2 + 1/2 w.I w - m a.x` (`a` the flight's constant
/// acceleration) brought down to `start`'s, or `None` when it is no more already (within the
/// rounding of the potential at rapier's precision, so that `f32` positions far from the
/// origin do not drain a slow body). The excess is taken from the motion a frictionless
/// contact of normal `normal` (unit) can change, scaled down by one factor: the velocity along
/// the normal, and the spin but for the part that carries the angular momentum about the
/// normal (`Body::spin_about`; for a cube or a ball, the spin about the normal). The velocity
/// along the ground and that angular momentum are what no such contact changes, and taking
/// from them would brake a body sliding or spinning on a frictionless ground, step after
/// step, as friction does; they are scaled, by a factor of their own, only for what the rest
/// cannot pay. When even the potential energy exceeds the start's energy, the body is left
/// at rest.
pub(crate) fn capped_energy(
    start: &State,
    end: &State,
    flight: &Flight,
    inertia: &Inertia,
    normal: &Vector3<f64>,
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
    let excess = end_total - start_total;
    let along_normal = normal * normal.dot(&end.v);
    let along_ground = end.v - along_normal;
    let (spin_kept, spin_kept_energy) = inertia.body_at(&end.rot).spin_about(normal, &end.w);
    let spin_rest = end.w - spin_kept;
    let kept_kinetic = 0.5 * inertia.mass * along_ground.norm_squared() + spin_kept_energy;
    let contact_kinetic = end_kinetic - kept_kinetic;
    let (kept_scale, contact_scale) = if contact_kinetic >= excess {
        (1.0, ((contact_kinetic - excess) / contact_kinetic).sqrt())
    } else {
        // Below `kept_kinetic`, as the contact's part could not pay the excess.
        let left = (end_kinetic - excess).max(0.0);
        let kept_scale = if kept_kinetic > 0.0 {
            (left / kept_kinetic).sqrt().min(1.0)
        } else {
            0.0
        };
        (kept_scale, 0.0)
    };
    Some(State {
        v: along_ground * kept_scale + along_normal * contact_scale,
        w: spin_kept * kept_scale + spin_rest * contact_scale,
        ..*end
    })
}

/// The candidate's start state, moved out along the normal of its deepest point among the
/// checked grounds where it already lay deeper than `gap` (the resting gap) in one at the
/// step's start (`Checked::grounds`, at their start poses): the reference of the energy cap.
/// A ground the user moved into the body, a body moved into it or made bigger: the lift out
/// of that depth is not the step's gain. Reads only.
fn out_of_start_grounds(checked: &Checked, cand: &Candidate, gap: f64) -> State {
    let mut start = cand.start;
    if let Some(hit) = closest(checked.geom, checked.grounds, &start, 0.0, 0.0) {
        if hit.dist < -gap {
            start.com -= hit.normal * hit.dist;
        }
    }
    start
}

/// A body the settle stage checks, with what its checks need.
#[derive(Clone, Copy)]
pub(crate) struct Checked<'c> {
    pub body: RigidBodyHandle,
    pub geom: &'c BodyGeom<'c>,
    pub inertia: &'c Inertia,
    /// The plan's candidate: the energy cap's start state and flight, the resting contacts.
    /// `None` for a body asleep at the start (no plan, no cap).
    pub cand: Option<&'c Candidate>,
    /// The grounds it is checked against.
    pub grounds: &'c [GroundGeom<'c>],
    /// The grounds from this index on are checked only where the body is deeper in them
    /// than the resting gap (their pairs are rapier's resting contacts): `grounds.len()` for
    /// none.
    pub joined: usize,
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
    /// - once either has moved the body farther than the resting gap, its other near grounds
    ///   join, met only deeper than the gap (`moved_into`, `Checked::joined`), the rounds go
    ///   on, and at the end a body left deeper than the gap in a still ground is moved out of
    ///   it (`out_of_still_grounds`);
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
        let body = checked.body;
        let Some(rb) = bodies.get(body) else {
            return (EndAction::Keep, None);
        };
        // A correction that moves the body farther than the resting gap adds its other
        // grounds (`Self::moved_into`): a bat does not drive a ball into its floor.
        let mut grounds = std::borrow::Cow::Borrowed(checked.grounds);
        let mut widened = false;
        let (dt, mut s, mut first) = (step.dt, *end, EndAction::Keep);
        let mut settle = false;
        let mut changed = false;
        let mut around: Option<NonGround> = None;
        let mut neighbours_of = || {
            *around
                .get_or_insert_with(|| neighbours(body, rb, &step.sets, self.registry, &step.down))
        };
        for k in 0..self.config.max_impacts_per_step {
            // The body as this round checks it: against the grounds so far.
            let now = &Checked {
                grounds: &grounds,
                ..*checked
            };
            let Some(hit) = deepest(now, checked.joined, &s, step) else {
                break;
            };
            let rule = why.row_for(k, &hit.normal);
            let action = step.policy.end_action(rule, hit.dist, hit.un, || {
                let around = neighbours_of();
                Surroundings {
                    touching: around.touching,
                    loaded: around.loaded,
                    pivot_pushed: now
                        .cand
                        .is_some_and(|c| pivot_pushed(c, &now.grounds[hit.ground], &hit, &s, step)),
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
                    self.report_push_out(now, &hit, &before, &s, step);
                    changed |= s != before;
                    if !self.moved_into(
                        (colliders, step),
                        checked,
                        &hit,
                        &mut grounds,
                        &mut widened,
                    ) {
                        break;
                    }
                    continue;
                }
                EndAction::Impact { settle: settling } => settle |= settling,
            }
            let resting_speed = step.policy.bounce_floor(neighbours_of().touching);
            let settling = settle || k + 1 >= self.config.max_impacts_per_step;
            let at = (&s, dt);
            let Some((after, event)) =
                self.step_end_impact(colliders, now, (&hit, at), resting_speed, settling)
            else {
                break;
            };
            // A contact touching with no approach left: the impact changes nothing, and
            // resolving it again would report the same empty impact up to the step's limit.
            if after == s && hit.dist == 0.0 {
                break;
            }
            s = after;
            s.com -= hit.normal * hit.dist;
            self.commit.event(event);
            changed = true;
            self.moved_into((colliders, step), checked, &hit, &mut grounds, &mut widened);
        }
        if grounds.len() > checked.grounds.len() {
            changed |= self.out_of_still_grounds(checked, &grounds, &mut s, step);
        }
        if !changed {
            return (first, None);
        }
        if let Some(capped) = self.cap_if_gained(rb, colliders, checked, &s, step) {
            s = capped;
        }
        (first, Some(s))
    }

    /// The model's impulse at the checked body's contact `hit` at the step's end (`s`, time
    /// `dt`), at its landing point, under the resting speed `resting_speed`; `settling`: with
    /// `e = 0`. `None` where the contact does not approach.
    fn step_end_impact(
        &self,
        colliders: &ColliderSet,
        checked: &Checked,
        (hit, (s, dt)): (&Hit, (&State, f64)),
        resting_speed: f64,
        settling: bool,
    ) -> Option<(State, ImpactEvent)> {
        let gg = &checked.grounds[hit.ground];
        let (material, point, points) = self.landing(colliders, (checked.geom, gg), (s, dt), hit);
        let (law, timing) = (self.config.law, ImpactTiming::StepEnd);
        let input = ImpactInput::new(
            checked.body,
            checked.inertia,
            law,
            material,
            resting_speed,
            timing,
        )
        .forced_to_settle(settling);
        let at = GroundContactAt::new(hit, point, points);
        resolve(&input, checked.geom, gg, s, dt, &at)
    }

    /// After a correction moved the checked body out of a ground along its normal by the
    /// depth of `hit`: if that is farther than the resting gap, the body's other grounds near
    /// it (`Candidate::near`, each without its `Filtered` pairs) join `grounds`, once
    /// (`widened`), so that the next rounds of the check find it if the move put it into one (a
    /// ball resting on a floor that a bat swung down drove out of the bat and into the floor;
    /// the floor's pair is rapier's resting contact, not among the `Impact` grounds checked).
    /// Returns whether grounds joined.
    fn moved_into<'g>(
        &self,
        (colliders, step): (&'g ColliderSet, &'g EndOfStep),
        checked: &Checked<'g>,
        hit: &Hit,
        grounds: &mut std::borrow::Cow<'g, [GroundGeom<'g>]>,
        widened: &mut bool,
    ) -> bool {
        let Some(cand) = checked.cand else {
            return false;
        };
        if *widened || -hit.dist <= step.policy.resting_gap {
            return false;
        }
        *widened = true;
        let more = self.other_near_geoms(cand, checked.geom, (colliders, step), grounds);
        if more.is_empty() {
            return false;
        }
        grounds.to_mut().extend(more);
        true
    }

    /// The geometry of the candidate's grounds near it (`Candidate::near`, each without its
    /// `Filtered` pairs) that `present` does not hold.
    pub fn other_near_geoms<'g>(
        &self,
        cand: &Candidate,
        geom: &BodyGeom,
        (colliders, step): (&'g ColliderSet, &'g StepData),
        present: &[GroundGeom],
    ) -> Vec<GroundGeom<'g>> {
        cand.near
            .iter()
            .filter_map(|i| self.pair_geom(&step.grounds[*i], geom, colliders))
            .filter(|gg| !present.iter().any(|g| g.handle == gg.handle))
            .collect()
    }

    /// After rounds of the check that moved the body between grounds (`Self::moved_into`): a
    /// body pinched between a moving ground and a still one (a bat driving a ball into the
    /// floor), which the rounds left in the still one, is moved out of it along its normal,
    /// its speed into it removed (a `PushOut`); the moving ground's contact is met again at
    /// the next step. Returns whether it moved.
    fn out_of_still_grounds(
        &mut self,
        checked: &Checked,
        grounds: &[GroundGeom],
        s: &mut State,
        step: &EndOfStep,
    ) -> bool {
        let still: Vec<_> = grounds
            .iter()
            .filter(|gg| gg.motion.is_still())
            .cloned()
            .collect();
        let checked = Checked {
            grounds: &still,
            joined: 0,
            ..*checked
        };
        // Measured from the side it came from, or through a thin one (`deepest`); deeper
        // than the gap only.
        let Some(hit) = deepest(&checked, 0, s, step) else {
            return false;
        };
        let before = *s;
        put_on_ground(s, &hit, true);
        self.report_push_out(&checked, &hit, &before, s, step);
        true
    }

    /// A state moved out of the ground by position at the step's end gains the potential
    /// energy of the lift: its end state is deeper than any state of a true flight (a corner
    /// swung or a ball rode into the ground), and moving it out keeps the speed it gathered
    /// getting there. Repeated every step, that lift would feed a body rocking on its corners
    /// at the step rate. Invariant: a body whose energy can only have been lost
    /// (`may_cap_energy`, and no restitution above 1 among its events of the step from
    /// `Checked::events_from`) ends no higher in mechanical energy, in its constant force
    /// field (`Flight::accel`), than it started, once out of any ground it already lay deeper
    /// in than the resting gap at the step's start (`out_of_start_grounds`: the user moved
    /// the ground or the body, or made the body bigger; that lift is not the step's)
    /// (`capped_energy`); the cap is reported as an `EnergyCap` event at the site of the
    /// body's last event.
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
        if !elastic || !self.may_cap_energy(rb, colliders, (cand, checked.grounds), step) {
            return None;
        }
        let site = self
            .commit
            .reported()
            .iter()
            .rev()
            .find(|e| e.body == checked.body)
            .map(Site::of)?;
        let start = out_of_start_grounds(checked, cand, step.policy.resting_gap);
        let capped = capped_energy(&start, end, &cand.flight, checked.inertia, &site.normal)?;
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
    /// lost. `searched`: the grounds it was checked against, among them any an impact sent it
    /// to beyond its plan (`reconstruct::grounds_beyond_plan`), which have no role.
    fn may_cap_energy(
        &self,
        rb: &RigidBody,
        colliders: &ColliderSet,
        (cand, searched): (&Candidate, &[GroundGeom]),
        step: &EndOfStep,
    ) -> bool {
        let grounds = &step.grounds;
        if rb.user_torque() != Vector::ZERO
            || touched_besides_grounds(cand.body, rb, &step.sets, self.registry)
            || searched.iter().any(|gg| {
                !gg.motion.is_still() && !cand.near.iter().any(|i| grounds[*i].handle == gg.handle)
            })
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

    /// The geometry of a candidate's `Impact` grounds (`Candidate::impact_grounds`), without
    /// its `Filtered` pairs (no contact for the plugin).
    pub fn impact_ground_geoms<'a>(
        &self,
        impact_grounds: &[usize],
        geom: &BodyGeom,
        colliders: &'a ColliderSet,
        step: &'a StepData,
    ) -> SmallList<GroundGeom<'a>> {
        self.pair_geoms(impact_grounds.iter().copied(), geom, colliders, step)
    }

    /// The geometry of the grounds of a candidate's resting pairs turning fast
    /// (`Candidate::turning_resting`), each ground once (a body of several colliders lists it
    /// per collider).
    pub fn turning_resting_geoms<'a>(
        &self,
        listed: &[(usize, Vector3<f64>)],
        geom: &BodyGeom,
        colliders: &'a ColliderSet,
        step: &'a StepData,
    ) -> SmallList<GroundGeom<'a>> {
        let once = listed
            .iter()
            .enumerate()
            .filter(|(k, (i, _))| !listed[..*k].iter().any(|(j, _)| j == i))
            .map(|(_, (i, _))| *i);
        self.pair_geoms(once, geom, colliders, step)
    }

    /// [`AfterStep::pair_geom`] of each ground of these indices (in `StepData::grounds`).
    fn pair_geoms<'a>(
        &self,
        indices: impl Iterator<Item = usize>,
        geom: &BodyGeom,
        colliders: &'a ColliderSet,
        step: &'a StepData,
    ) -> SmallList<GroundGeom<'a>> {
        indices
            .filter_map(|i| self.pair_geom(&step.grounds[i], geom, colliders))
            .collect()
    }

    /// The geometry of the grounds near a body asleep at the step's start (it has no roles):
    /// [`AfterStep::unplanned_geom`] of each; a slab's tiles for a body that meets them one by
    /// one (`tiles`, `observe::meets_tiles`).
    pub fn woken_geoms<'a>(
        &self,
        (bodies, colliders): (&RigidBodySet, &'a ColliderSet),
        body: RigidBodyHandle,
        (com, geom): (Vector, &BodyGeom),
        step: &'a EndOfStep,
        tiles: bool,
    ) -> SmallList<GroundGeom<'a>> {
        let half = crate::plugin::bridge::convert::to_real(geom.radius + step.policy.resting_gap);
        self.registry
            .index
            .near_cube(&step.grounds, com, half, tiles)
            .iter()
            .filter_map(|i| {
                let sets = (bodies, colliders, &step.sets);
                self.unplanned_geom(&step.grounds[*i], sets, body, geom)
            })
            .collect()
    }

    /// A ground's geometry for the queries of the body `body` (`geom`) where its pairs with
    /// the ground have no role this step, the pairs rapier would not solve, that a joint
    /// disables or that the user's filter refuses skipped ([`AfterStep::refuses`]).
    pub fn unplanned_geom<'a>(
        &self,
        gm: &'a GroundMotion,
        (bodies, colliders, sets): (&RigidBodySet, &'a ColliderSet, &Sets),
        body: RigidBodyHandle,
        geom: &BodyGeom,
    ) -> Option<GroundGeom<'a>> {
        geom_skipping(gm, geom, colliders, |key| {
            self.refuses((bodies, colliders, sets), body, key)
        })
    }

    /// A ground's geometry for the queries of a body whose pairs have roles this step, its
    /// `Filtered` pairs skipped.
    pub fn pair_geom<'a>(
        &self,
        gm: &'a GroundMotion,
        geom: &BodyGeom,
        colliders: &'a ColliderSet,
    ) -> Option<GroundGeom<'a>> {
        geom_skipping(gm, geom, colliders, |key| {
            self.roles.get(&key) == Some(&Role::Filtered)
        })
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

/// A ground's geometry for the queries of a body (`geom`), its colliders whose pair with the
/// ground (body collider, ground collider) `skipped` holds left out.
#[inline]
fn geom_skipping<'a>(
    gm: &'a GroundMotion,
    geom: &BodyGeom,
    colliders: &'a ColliderSet,
    skipped: impl Fn(PairKey) -> bool,
) -> Option<GroundGeom<'a>> {
    let mut gg = ground_geom(gm, colliders)?;
    gg.skip = geom
        .parts
        .iter()
        .map(|part| part.handle)
        .filter(|h| skipped((*h, gg.handle)))
        .collect();
    Some(gg)
}

/// The checked body's deepest point at `s` (the step's end) in its grounds, measured from the
/// side it came from (`on_entry_side`), or through a thin one (`passed_through`); `None` if
/// none. The grounds from index `joined` on joined the check after a move
/// (`AfterStep::moved_into`): one is met only where the body is deeper in it than the
/// resting gap, as its resting contact within the gap stays rapier's.
fn deepest(checked: &Checked, joined: usize, s: &State, step: &EndOfStep) -> Option<Hit> {
    let (gap, dt) = (step.policy.resting_gap, step.dt);
    let found = closest(checked.geom, checked.grounds, s, dt, 0.0);
    let hit = found.or_else(|| passed_through(checked, s, dt, gap))?;
    let jointed = step.sets.jointed(checked.body);
    let hit = on_entry_side(hit, checked, s, (dt, gap), jointed);
    (hit.ground < joined || hit.dist < -gap).then_some(hit)
}

/// `hit` measured from the side of its ground the body came from. The closest contact of a
/// body that went deep into a thin ground in the step (a spinning plate's corner, a step-end
/// push, a fast small capsule) is out of its nearest face, which may be the far one: pushed
/// out there, the body would end under the ground (and, on a thin slab above a floor, be
/// pushed through both). Where the body's part was at the step's start is outside the
/// ground: a contact on a face whose plane has it behind is taken again on the face towards
/// it (on a cuboid, of the faces whose planes have it in front and that the body's deepest
/// point moved into, the one the body is least deep behind, `entry_face_contact`: a centre
/// past an edge is in front of two; else `contact_from_side`). On a cuboid ground, so is
/// one on a face whose plane had the hit's own point of the body behind it at the start,
/// that point then outside the ground, where a face that point was in front of holds the
/// body less deep
/// (`entry_face_contact`): a long body whose end went into a post while its centre stayed
/// beside it (a hinged flap onto a stop, a door swung into a post) is out of the face its
/// end came in by, not out of the face its centre lies beyond, across the whole body. A
/// body without a joint (`jointed`: it has one) whose hit on a cuboid is shallower than the
/// cuboid's smallest half extent takes only a face whose measured point was in front of it
/// at the start (within the resting gap `gap`), or keeps `hit` if none was and `hit`'s own
/// point was. A body with no start state (asleep at the start) keeps `hit`.
fn on_entry_side(
    hit: Hit,
    checked: &Checked,
    s: &State,
    (dt, gap): (f64, f64),
    jointed: bool,
) -> Hit {
    let Some(cand) = checked.cand else {
        return hit;
    };
    let part = &checked.geom.parts[hit.part];
    let ground = &checked.grounds[hit.ground];
    // The face's plane: the hit's point less its signed distance along the normal.
    let face = hit.point - hit.normal * hit.dist;
    let behind = |p: &Vector3<f64>| hit.normal.dot(&(p - face)) < 0.0;
    let centre = start_point(cand, part, ground, dt);
    let found = if behind(&centre) {
        // On a cuboid, of the faces the centre was in front of (two past an edge), the one
        // the body is least deep behind, of those its deepest point moved into over the step
        // (a body comes in through a face only moving into it): a hinged flap whose tip went
        // down through a 2 cm stop is less deep behind the stop's side, which its tip moved
        // away from, than behind the top it came in by. None moved into: of them all.
        let entering = |(_, normal, point): &PairContact| {
            normal.dot(&(point - point_at_start(cand, part, ground, s, *point, dt))) < 0.0
        };
        // The faces the centre was in front of are measured on their unbounded planes, which
        // run on past the cuboid's edges: a plank pivoting over a 2 cm slab's edge, 4 mm into
        // the edge, its far end past the edge and below the top's plane from the step's
        // start, would be lifted 0.39 m onto that plane. So where the hit is shallower than
        // the cuboid's smallest half extent, a face needs the point it measures (the body's
        // deepest behind its plane) to have been in front of that plane at the start, within
        // the resting gap: that point came in by it. Where none did, the hit stands if its own
        // point came in by its face (the edge the plank pivots on); else (the face a centre
        // that went nearly through a slab is nearest, a side face a body's centre lies beyond
        // across its length) every such face is weighed as without the test. Not for a body
        // with a joint: the joint, which the impact does not see, pulls it back in, and the
        // unbounded face's larger push-out keeps a motorised door from a post it would
        // otherwise pass.
        let shallow = !jointed
            && ground
                .shape
                .as_cuboid()
                .is_some_and(|c| -hit.dist < to_f64(c.half_extents.min_element()));
        let came_in = |(dist, normal, point): &PairContact| {
            let face = point - normal * *dist;
            let start = point_at_start(cand, part, ground, s, *point, dt);
            normal.dot(&(start - face)) >= -gap
        };
        let admitted = shallow
            .then(|| entry_face_contact(part, ground, s, dt, centre, came_in, entering))
            .flatten();
        if admitted.is_some() {
            admitted
        } else if shallow && came_in(&(hit.dist, hit.normal, hit.point)) {
            return hit;
        } else {
            entry_face_contact(part, ground, s, dt, centre, |_| true, entering)
                .or_else(|| contact_from_side(part, ground, s, dt, centre, false))
        }
    } else {
        // Only ever shallower than `hit`: a body resting on a cuboid's top with its end out
        // past the side (its contact point then a rounding under the top, beyond the side)
        // came in by the top, not by that side across its whole length.
        match hit_point_start(cand, part, ground, s, &hit, dt) {
            Some(point) if behind(&point) => {
                entry_face_contact(part, ground, s, dt, point, |_| true, |_| true)
                    .filter(|(dist, ..)| *dist > hit.dist)
            }
            _ => return hit,
        }
    };
    match found {
        Some(found) => Hit::at((hit.part, hit.ground), ground, s, dt, found),
        None => hit,
    }
}

/// Where a part of the body was at the step's start, carried with `ground` to `t`.
fn start_point(cand: &Candidate, part: &BodyPart, ground: &GroundGeom, t: f64) -> Vector3<f64> {
    carried(ground, t, part_pose(part, &cand.start).translation.vector)
}

/// Where the point of the body at `hit` (at `s`, time `t`) was at the step's start, carried
/// with `ground` to `t`, if that lay outside the ground, a cuboid; `None` for other grounds
/// and inside.
fn hit_point_start(
    cand: &Candidate,
    part: &BodyPart,
    ground: &GroundGeom,
    s: &State,
    hit: &Hit,
    t: f64,
) -> Option<Vector3<f64>> {
    let cuboid = ground.shape.as_cuboid()?;
    let start = point_at_start(cand, part, ground, s, hit.point, t);
    let local = ground
        .pose_at(t)
        .inverse_transform_point(&nalgebra::Point3::from(start));
    let half = vec_to_na(cuboid.half_extents);
    (0..3).any(|i| local[i].abs() > half[i]).then_some(start)
}

/// Where the point `point` of the body's part at `s` (time `t`) was at the step's start,
/// carried with `ground` to `t`.
fn point_at_start(
    cand: &Candidate,
    part: &BodyPart,
    ground: &GroundGeom,
    s: &State,
    point: Vector3<f64>,
    t: f64,
) -> Vector3<f64> {
    let on_body = part_pose(part, s).inverse_transform_point(&nalgebra::Point3::from(point));
    carried(ground, t, (part_pose(part, &cand.start) * on_body).coords)
}

/// A point `p` at the step's start, carried with `ground` to `t`.
fn carried(ground: &GroundGeom, t: f64, p: Vector3<f64>) -> Vector3<f64> {
    if ground.motion.v == Vector3::zeros() && ground.motion.w == Vector3::zeros() {
        return p;
    }
    (ground.pose_at(t) * ground.pose_at(0.0).inverse() * nalgebra::Point3::from(p)).coords
}

/// The contact of a body that went through a thin ground in the step and ends clear of it
/// on the far side, where no contact is found (a fast ball a heavy one pushed into a 2 cm
/// slab, a spinning plate): a part over a face it was in front of at the step's start is
/// measured from that face (`contact_from_side`, the face itself, not its plane: a body that
/// fell past the ground's edge is not below it). The deepest such, if any part is deeper
/// than `gap` (m) below it (a body touching a face from beside it is not through it).
fn passed_through(checked: &Checked, s: &State, dt: f64, gap: f64) -> Option<Hit> {
    let cand = checked.cand?;
    let mut deepest: Option<Hit> = None;
    for (i, part) in checked.geom.parts.iter().enumerate() {
        for (j, ground) in checked.grounds.iter().enumerate() {
            if ground.skip.contains(&part.handle) {
                continue;
            }
            let from = start_point(cand, part, ground, dt);
            let Some(found) = contact_from_side(part, ground, s, dt, from, true) else {
                continue;
            };
            // In front of that face at the start, below it now, and through it on the way.
            // On a cuboid, so was the body's deepest point within the resting gap: a long
            // body leaning over a slab's edge has its far end over the face and behind the
            // underside's plane from the start; it went beside the slab, not through it. (A
            // mesh triangle's plane runs on past the triangle: a point over the other face
            // of a crease lies behind it.)
            let (dist, normal, point) = found;
            let face = point - normal * dist;
            let was_in_front = normal.dot(&(from - face)) >= 0.0;
            let deepest_was_in_front = || {
                ground.shape.as_cuboid().is_none()
                    || normal.dot(&(point_at_start(cand, part, ground, s, point, dt) - face))
                        >= -gap
            };
            let end = part_pose(part, s).translation.vector;
            let margin = checked.geom.radius;
            let through = || crosses_face(ground, dt, (from, end), (face, normal), margin);
            if dist < -gap
                && was_in_front
                && deepest.is_none_or(|d| dist < d.dist)
                && deepest_was_in_front()
                && through()
            {
                deepest = Some(Hit::at((i, j), ground, s, dt, found));
            }
        }
    }
    deepest
}

/// Does the way of a body part from `from` (its start, carried with the ground) to `end`
/// (its centre at the step's end, time `t`) cross the plane of a cuboid ground's face (a
/// point `face` of it, its unit normal `normal`) within `margin` (m) of the face? A part that
/// ends behind the face's plane with its foot on the face went through the ground only if
/// so: behind a blade that turned past it, it went round the blade's end. The way is taken
/// straight (exact for a ground that does not turn, a chord for one that does). Other
/// grounds (a half-space, a mesh's triangle): yes.
fn crosses_face(
    ground: &GroundGeom,
    t: f64,
    (from, end): (Vector3<f64>, Vector3<f64>),
    (face, normal): (Vector3<f64>, Vector3<f64>),
    margin: f64,
) -> bool {
    let Some(cuboid) = ground.shape.as_cuboid() else {
        return true;
    };
    let across = normal.dot(&(from - end));
    if across <= 0.0 {
        return true;
    }
    let along = (normal.dot(&(from - face)) / across).clamp(0.0, 1.0);
    let crossing = from + (end - from) * along;
    let pose = ground.pose_at(t);
    let local = pose
        .inverse_transform_point(&nalgebra::Point3::from(crossing))
        .coords;
    let axis = (pose.rotation.inverse() * normal).iamax();
    let half = crate::plugin::bridge::convert::vec_to_na(cuboid.half_extents);
    (0..3).all(|i| i == axis || local[i].abs() <= half[i] + margin)
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

    /// `capped_energy` of a state that gained energy, checked to have the start's mechanical
    /// energy again.
    fn capped_to_start(start: &State, end: &State, flight: &Flight, inertia: &Inertia) -> State {
        let capped = capped_energy(start, end, flight, inertia, &up()).expect("energy was gained");
        let (e0, e1) = (
            total_energy(start, inertia, flight),
            total_energy(&capped, inertia, flight),
        );
        assert!((e1 - e0).abs() <= 1e-12 * e0.abs(), "{e0} -> {e1}");
        capped
    }

    /// The ground's normal in the tests.
    fn up() -> Vector3<f64> {
        Vector3::y()
    }

    /// The angular momentum about the normal `n.I w` of a body of `inertia` turned by `rot`.
    fn momentum_about_up(inertia: &Inertia, rot: &UnitQuaternion<f64>, w: &Vector3<f64>) -> f64 {
        let i = inertia.body_at(rot).inv_inertia.try_inverse().unwrap();
        up().dot(&(i * w))
    }

    #[test]
    fn a_lift_is_paid_from_the_speed_along_the_normal_and_the_spin_about_other_axes() {
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
        let capped = capped_to_start(&start, &end, &flight, &inertia);
        // The velocity along the ground and the angular momentum about the normal kept.
        assert_eq!((capped.v.x, capped.v.z), (end.v.x, end.v.z));
        let (l0, l1) = (
            momentum_about_up(&inertia, &rot, &end.w),
            momentum_about_up(&inertia, &rot, &capped.w),
        );
        assert!((l1 - l0).abs() <= 1e-14 * l0.abs(), "{l0} -> {l1}");
        // The velocity along the normal and the spin but its part carrying that momentum
        // (`n (n.I w) / (n.I n)`, computed here from the inertia) scaled by one factor below
        // 1; the pose untouched.
        let k = capped.v.y / end.v.y;
        assert!(k < 1.0 && k > 0.0);
        let i_n = inertia.body_at(&rot).inv_inertia.try_inverse().unwrap() * up();
        let kept = up() * (i_n.dot(&end.w) / up().dot(&i_n));
        assert!(((capped.w - kept) - (end.w - kept) * k).norm() < 1e-14 * end.w.norm());
        assert!((capped.w - end.w).norm() > 0.1);
        assert_eq!((capped.com, capped.rot), (end.com, end.rot));
    }

    #[test]
    fn a_body_that_turns_only_about_the_normal_keeps_its_spin() {
        // The brick with its x and z rotations locked: it can only spin about the normal, so
        // a cap takes nothing from that spin (the inverse inertia is singular there).
        let mut world = crate::rapier::prelude::PhysicsWorld::default();
        let (handle, _) = world.insert(
            RigidBodyBuilder::dynamic().locked_axes(
                crate::rapier::prelude::LockedAxes::ROTATION_LOCKED_X
                    | crate::rapier::prelude::LockedAxes::ROTATION_LOCKED_Z,
            ),
            ColliderBuilder::cuboid(0.15, 0.1, 0.05),
        );
        let inertia = Inertia::of(&world.bodies[handle]);
        let (_, flight) = brick();
        let start = State {
            com: Vector3::new(0.0, 0.1, 0.0),
            rot: UnitQuaternion::identity(),
            v: Vector3::new(0.5, -0.2, 0.1),
            w: Vector3::new(0.0, 3.0, 0.0),
        };
        // Lifted 1 mm: 9.8e-3 J/kg, less than the speed along the normal holds (0.02).
        let end = State {
            com: Vector3::new(0.0, 0.101, 0.0),
            ..start
        };
        let capped = capped_to_start(&start, &end, &flight, &inertia);
        assert!(
            (capped.w - end.w).norm() <= 1e-15 * end.w.norm(),
            "{:?}",
            capped.w
        );
        assert_eq!((capped.v.x, capped.v.z), (end.v.x, end.v.z));
        assert!(capped.v.y > end.v.y && capped.v.y < 0.0);
    }

    #[test]
    fn a_lift_beyond_the_normal_speed_and_spin_is_paid_from_the_speed_along_the_ground() {
        let (inertia, flight) = brick();
        let start = State {
            com: Vector3::new(0.0, 0.1, 0.0),
            rot: UnitQuaternion::identity(),
            v: Vector3::new(0.6, -0.1, -0.8),
            w: Vector3::new(0.3, 0.5, 0.0),
        };
        // Lifted 1 cm: 0.098 J/kg, more than the speed along the normal and the spin about
        // the other axes hold, less than the whole kinetic energy.
        let end = State {
            com: Vector3::new(0.0, 0.11, 0.0),
            ..start
        };
        let capped = capped_to_start(&start, &end, &flight, &inertia);
        // Unrotated, the brick's axes are the world's: the spin about the normal carries all
        // the momentum about it. It and the velocity along the ground are scaled down by one
        // factor, their directions kept; the rest is gone.
        assert_eq!((capped.v.y, capped.w.x, capped.w.z), (0.0, 0.0, 0.0));
        let k = capped.v.x / end.v.x;
        assert!(k < 1.0 && k > 0.0);
        assert!((capped.v.z - end.v.z * k).abs() < 1e-15);
        assert!((capped.w.y - end.w.y * k).abs() < 1e-15);
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
        assert_eq!(
            capped_energy(&start, &lower, &flight, &inertia, &up()),
            None
        );
        // Lifted 1 cm: more than 1/2 v^2 / g = 4.6 mm can pay for.
        let lifted = State {
            com: Vector3::new(0.0, 0.11, 0.0),
            ..start
        };
        let capped = capped_energy(&start, &lifted, &flight, &inertia, &up()).unwrap();
        assert_eq!((capped.v, capped.w), (Vector3::zeros(), Vector3::zeros()));
        // At rest and lifted: nothing to scale, nothing done.
        let resting = State {
            v: Vector3::zeros(),
            ..lifted
        };
        assert_eq!(
            capped_energy(&start, &resting, &flight, &inertia, &up()),
            None
        );
    }
}
