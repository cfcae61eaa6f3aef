//! Settle: after rapier's step, the end-of-step checks of what rapier's state holds in a
//! ground, and their corrections.
//!
//! Contract: [`Settle`] reads rapier's end-of-step state, the step's plan ([`EndOfStep`]) and
//! the registry; it writes bodies (through `commit::write_state`) and reports every change as
//! an event: a step-end impact from the model (`EventKind::Impact`, `ImpactTiming::StepEnd`),
//! a push-out (`EventKind::PushOut`) or an energy cap (`EventKind::EnergyCap`). Its entry
//! points, one per way rapier's step can leave a body in a ground:
//! - [`Settle::end_fallback`]: a body the in-step search cannot fly alone (it touched
//!   another body, had a joint or a torque, or rapier's CCD cut it short);
//! - [`Settle::resting_end`]: a body turning fast on resting pairs (the decision is
//!   [`super::policy::Policy::deep_resting_body`]);
//! - [`Settle::turned_end`]: a tumbling body whose step the search found clear;
//! - [`Settle::woken_end`]: a body woken inside the step;
//! - [`Settle::rolling_end`]: a rolling ball something acted on.
//!
//! The pure state corrections are free functions: [`put_on_ground`] moves a state out of the
//! ground along a contact normal (for a ball, also removing its speed into the ground);
//! [`capped_energy`] scales a state's velocities so that its mechanical energy is no more
//! than another's.

use super::commit::{Shadow, write_state};
use super::config::{ImpactConfig, TimingMode};
use super::convert::{to_f64, vec_from_na, vec_to_na};
use super::events::{EventKind, ImpactEvent, ImpactTiming};
use super::filter;
use super::geometry::{BodyGeom, GroundGeom, SmallList, closest, landing_point};
use super::ground_index::GroundMotion;
use super::handles::HandleMap;
use super::hook_flags::HookFlags;
use super::observe::{body_geom, ground_geom, neighbours, rapier_state};
use super::plan::{Candidate, EndOfStep, StepData};
use super::policy::{DeepResting, EndContact, Role};
use super::registry::Registry;
use super::resolve::{ImpactInput, Inertia, PairKey, Site, correction, resolve};
use crate::motion::{Flight, Rolling, State};
use crate::rapier::math::{Real, Vector};
use crate::rapier::prelude::{
    ActiveHooks, ColliderHandle, ColliderSet, RigidBody, RigidBodyHandle, RigidBodySet,
};
use nalgebra::Vector3;

/// `s` moved out of the ground along `hit`'s normal and, if `stop`, without its speed into
/// the ground: what a resting contact holds a ball at (for a ball, an `e = 0` frictionless
/// normal impulse, through its centre).
pub(crate) fn put_on_ground(s: &mut State, hit: &super::geometry::Hit, stop: bool) {
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

/// The end-of-step stage's view of the plugin: what it reads (configuration, registry, hook
/// flags, the step's roles) and what it writes (events, the Exact-mode shadows).
pub(crate) struct Settle<'a> {
    pub config: &'a ImpactConfig,
    pub registry: &'a Registry,
    pub flags: &'a HookFlags,
    pub roles: &'a HandleMap<PairKey, Role>,
    pub events: &'a mut Vec<ImpactEvent>,
    pub shadows: &'a mut HandleMap<RigidBodyHandle, Shadow>,
}

impl Settle<'_> {
    /// Keeps the `f64` state of a body just written in `Exact` mode.
    pub fn remember(&mut self, handle: RigidBodyHandle, rb: &RigidBody, s: &State) {
        self.shadows.insert(handle, Shadow::of(rb, s));
    }

    /// The step-end fallback (`step_end`) for a candidate, then the energy cap
    /// (`cap_energy`).
    #[allow(clippy::too_many_arguments)]
    pub fn end_fallback(
        &mut self,
        bodies: &mut RigidBodySet,
        colliders: &ColliderSet,
        cand: &Candidate,
        geom: &BodyGeom,
        grounds: &[GroundGeom],
        step: &EndOfStep,
        settle: bool,
    ) {
        let Some(rb) = bodies.get(cand.body) else {
            return;
        };
        let inertia = Inertia::of(rb);
        let events = self.events.len();
        let moved = self.step_end(
            bodies,
            colliders,
            cand.body,
            &cand.local_com,
            geom,
            grounds,
            &inertia,
            step,
            settle,
        );
        let elastic = self.events[events..].iter().all(|e| e.restitution <= 1.0);
        if moved && elastic {
            self.cap_energy(bodies, colliders, cand, &inertia, step);
        }
    }

    /// A body moved out of the ground by position at the step's end gains the potential
    /// energy of the lift: its end state is deeper than any state of a true flight (a corner
    /// swung or a ball rode into the ground), and moving it out keeps the speed it gathered
    /// getting there. Repeated every step, that lift fed a box rocking on its corners at
    /// the step rate for ever (`Step` mode, 60 Hz: 60 bounces a second), and it is the
    /// energy a tumbling cube gained over its throw. So, for a body whose energy can only
    /// have been lost (`may_cap_energy`; the callers also require no restitution above 1),
    /// the end state's mechanical energy in its constant force field (`Flight::accel`) is
    /// held to the start's (see `capped_energy`).
    pub fn cap_energy(
        &mut self,
        bodies: &mut RigidBodySet,
        colliders: &ColliderSet,
        cand: &Candidate,
        inertia: &Inertia,
        step: &EndOfStep,
    ) {
        if !bodies
            .get(cand.body)
            .is_some_and(|rb| self.may_cap_energy(rb, colliders, cand, step))
        {
            return;
        }
        let rb = &mut bodies[cand.body];
        let end = rapier_state(rb);
        // Only after a push-out, which reported where it was.
        let Some(site) = self
            .events
            .iter()
            .rev()
            .find(|e| e.body == cand.body)
            .map(Site::of)
        else {
            return;
        };
        if let Some(capped) = self.cap(&site, inertia, cand, &end, step.dt) {
            rb.set_linvel(vec_from_na(&capped.v), true);
            rb.set_angvel(vec_from_na(&capped.w), true);
        }
    }

    /// `end` capped to the candidate's start energy (`capped_energy`), reported as an
    /// `EnergyCap` event at `site`; `None` when it gains nothing.
    pub fn cap(
        &mut self,
        site: &Site,
        inertia: &Inertia,
        cand: &Candidate,
        end: &State,
        dt: f64,
    ) -> Option<State> {
        let capped = capped_energy(&cand.start, end, &cand.flight, inertia)?;
        self.events.push(correction(
            EventKind::EnergyCap,
            site,
            inertia,
            end,
            &capped,
            dt,
        ));
        Some(capped)
    }

    /// Nothing but still grounds touched the candidate in the step (no body, wall or joint:
    /// read from rapier's contact graph after the step), through the plugin's pairs with no contact
    /// modification of the user's, and no user torque acted: its energy can only have been
    /// lost.
    pub fn may_cap_energy(
        &self,
        rb: &RigidBody,
        colliders: &ColliderSet,
        cand: &Candidate,
        step: &EndOfStep,
    ) -> bool {
        let grounds = &step.grounds;
        if rb.user_torque() != Vector::ZERO
            || neighbours(cand.body, rb, &step.sets, self.registry, &step.down).touching
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

    /// The `StepEnd` fallback on rapier's end-of-step state: each ground contact still
    /// touching and approaching gets its impulse (with `e = 0` if `settle`), and the body is
    /// moved out of the ground. Returns whether it changed the body's state.
    #[allow(clippy::too_many_arguments)]
    pub fn step_end(
        &mut self,
        bodies: &mut RigidBodySet,
        colliders: &ColliderSet,
        body: RigidBodyHandle,
        local_com: &Vector3<f64>,
        geom: &BodyGeom,
        grounds: &[GroundGeom],
        inertia: &Inertia,
        step: &EndOfStep,
        settle: bool,
    ) -> bool {
        let Some(rb) = bodies.get(body) else {
            return false;
        };
        let mut s = rapier_state(rb);
        let t = step.dt;
        let mut changed = false;
        for k in 0..self.config.max_impacts_per_step {
            let Some(hit) = closest(geom, grounds, &s, t, 0.0) else {
                break;
            };
            match step.policy.step_end_contact(hit.dist, hit.un) {
                EndContact::Impact => {}
                // A point deeper than the resting gap that already leaves the ground: it
                // swung through it inside the step (a box tumbling at 15 rad/s and 20 m/s at
                // 30 Hz ended 9.2 mm deep, rising). Moved out, its velocity kept.
                EndContact::PushOut => {
                    let before = s;
                    s.com -= hit.normal * hit.dist;
                    changed = true;
                    self.report_push_out(body, geom, grounds, &hit, inertia, &before, &s, step);
                    break;
                }
                EndContact::Keep => break,
            }
            let part = &geom.parts[hit.part];
            let gg = &grounds[hit.ground];
            let (point, points) = landing_point(part, gg, &s, t, &hit, self.config.flat_tolerance);
            let input = ImpactInput {
                body,
                inertia,
                law: self.config.law,
                material: self.registry.material_of(colliders, part.handle, gg.handle),
                // A body that touched another body or a wall in the step: no bounce slower
                // than a fall through the resting gap (see the pressed roles).
                resting_speed: if neighbours(
                    body,
                    &bodies[body],
                    &step.sets,
                    self.registry,
                    &step.down,
                )
                .touching
                {
                    step.policy.pressed_speed
                } else {
                    step.policy.resting_speed
                },
                force_settle: settle || k + 1 >= self.config.max_impacts_per_step,
                timing: ImpactTiming::StepEnd,
            };
            let Some((after, event)) = resolve(&input, geom, gg, &s, t, &hit, point, points) else {
                break;
            };
            s = after;
            s.com -= hit.normal * hit.dist;
            self.events.push(event);
            changed = true;
        }
        if changed {
            write_state(&mut bodies[body], &s, local_com, true);
        }
        changed
    }

    /// After the step, for a body whose ground pairs were all resting (rapier's) while it
    /// turned fast. Two ways rapier's resting contact lets it end the step deep:
    /// - rapier's contact manifold, made at the step's start, holds only the points near the
    ///   ground then, so a point swinging down from higher up (a box tipping off its edge, a
    ///   capsule's end at a wall) can end the step deep in the ground, still approaching
    ///   (issue 5: 8-13 mm at 30-60 Hz, rapier alone 5.3 cm). When the deepest point is deeper
    ///   than the resting gap and approaches faster than a fall through it, while the resting
    ///   contact point itself does not (the body turned about it, rather than being pushed
    ///   into the ground by a body on it: a heavy box on a light one, see the pressed roles),
    ///   it is resolved as a step-end impact (`step_end`, pushed out). Slower, on a body
    ///   touching nothing but grounds, it is settled (`e = 0`) and moved out (a box that took a
    ///   `Step` impulse at one corner while its spin brought another down: 11.7 mm deep at
    ///   30 Hz, approaching at 0.14 m/s); a body touching another is left to rapier then:
    ///   pushing it out fights the body on it;
    /// - rapier's solver moves a contact point with its body over the step, as a material
    ///   point; a ball's contact point stays at its bottom however it spins, so a fast-spinning
    ///   ball is under-supported and rides low (rapier alone: a 0.1 m ball sliding at 5-15 m/s,
    ///   spun up by friction to 20 rad/s, 8.4 mm deep at 30 Hz, 7.3 mm at 60 Hz), and a
    ///   fast-turning box's contact points lag its faces likewise. A body left deeper than the
    ///   resting gap otherwise, with nothing lying on it (`NonGround::loaded`: two balls sliding
    ///   side by side at 20 m/s, spun at 20 rad/s, had gone 14-22 mm deep at 30 Hz), is
    ///   moved out of the ground; a ball's speed into the ground is removed, other bodies'
    ///   velocities are kept. The lift's energy is capped (`cap_energy`).
    ///
    /// Returns whether it changed the body (a step-end impact or a push-out): rapier's end
    /// state, corrected, then stands, and no flight is written over it.
    pub fn resting_end(
        &mut self,
        bodies: &mut RigidBodySet,
        colliders: &ColliderSet,
        cand: &Candidate,
        step: &EndOfStep,
    ) -> bool {
        let Some(rb) = bodies.get(cand.body) else {
            return false;
        };
        let geom = body_geom(rb, colliders, &cand.local_com);
        // Each ground once (a body of several colliders lists it per collider).
        let listed = &cand.turning_resting;
        let grounds: SmallList<GroundGeom> = listed
            .iter()
            .enumerate()
            .filter(|(k, (i, _))| !listed[..*k].iter().any(|(j, _)| j == i))
            .filter_map(|(_, (i, _))| self.pair_geom(&step.grounds[*i], &geom, colliders))
            .collect();
        let mut end = rapier_state(rb);
        let Some(hit) = closest(&geom, &grounds, &end, step.dt, 0.0) else {
            return false;
        };
        if hit.dist >= -step.policy.resting_gap {
            return false;
        }
        let neighbours = neighbours(cand.body, rb, &step.sets, self.registry, &step.down);
        // The resting contact's material point, now.
        let pivot_pushed = || {
            listed.iter().any(|(i, local)| {
                if step.grounds[*i].handle != grounds[hit.ground].handle {
                    return false;
                }
                let p = end.com + end.rot * local;
                let u = super::geometry::body_velocity_at(&end, &p)
                    - grounds[hit.ground].velocity_at(&p, step.dt);
                hit.normal.dot(&u) < -step.policy.pressed_speed
            })
        };
        let decision = step.policy.deep_resting_body(
            hit.dist,
            hit.un,
            cand.turns_surface,
            pivot_pushed,
            neighbours.touching,
            neighbours.loaded,
        );
        if let DeepResting::Resolve { settle } = decision {
            self.end_fallback(bodies, colliders, cand, &geom, &grounds, step, settle);
            return true;
        }
        // A body that nothing loads (balls side by side, a box at a wall) is moved out; a
        // body something lies on is left to rapier, whose solver holds the load.
        if decision == DeepResting::PushOut {
            // A ball riding low sinks on: rapier's under-supporting contact let gravity build
            // a speed into the ground (0.3 to 0.9 m/s at 30 Hz for balls spun at 20 rad/s),
            // which kept would take it deeper next step: removed for a ball.
            let inertia = Inertia::of(&bodies[cand.body]);
            let before = end;
            put_on_ground(&mut end, &hit, !cand.turns_surface);
            self.report_push_out(
                cand.body, &geom, &grounds, &hit, &inertia, &before, &end, step,
            );
            write_state(&mut bodies[cand.body], &end, &cand.local_com, true);
            self.cap_energy(bodies, colliders, cand, &inertia, step);
            return true;
        }
        false
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

    /// After a step the search found clear, for a body whose rotation moves its surface (not
    /// a ball about its centre): the search flies it torque-free, rapier's integrator turns
    /// it its own way (and `Exact` mode keeps rapier's rotation), and for a fast tumble the
    /// two part by centimetres at the corners (a 0.9 m rod at 21 rad/s, 30 Hz: 6 cm deep,
    /// no event). The step-end fallback (`step_end`) then resolves what rapier's end pose
    /// holds in the ground.
    pub fn turned_end(
        &mut self,
        bodies: &mut RigidBodySet,
        colliders: &ColliderSet,
        cand: &Candidate,
        step: &EndOfStep,
    ) {
        if !cand.turns_surface {
            return;
        }
        let Some(rb) = bodies.get(cand.body) else {
            return;
        };
        let geom = body_geom(rb, colliders, &cand.local_com);
        let grounds = self.impact_ground_geoms(cand, &geom, colliders, step);
        self.end_fallback(bodies, colliders, cand, &geom, &grounds, step, false);
    }

    /// After the step, for a body asleep at its start and woken inside it (by a body hitting
    /// it): rapier solves the woken body without its ground contacts for that step (they
    /// were not updated while it slept), so a box resting on the ground falls by gravity
    /// for a step, into the ground (rapier alone, box resting flat, woken by a rolling ball:
    /// 8.8 mm deep at 30 Hz, pushed out over the next steps; in a scene of tumbling boxes,
    /// 6.9 mm). If a point ends deeper than the resting gap and approaching, the contact is
    /// resolved at the step end with `e = 0` (what a resting contact would have done) and
    /// the body moved out of the ground.
    pub fn woken_end(
        &mut self,
        bodies: &mut RigidBodySet,
        colliders: &ColliderSet,
        handle: RigidBodyHandle,
        step: &EndOfStep,
        refused: &dyn Fn(&RigidBodySet, ColliderHandle, ColliderHandle) -> bool,
    ) {
        let rb = &bodies[handle];
        let local_com = vec_to_na(rb.local_center_of_mass());
        let geom = body_geom(rb, colliders, &local_com);
        if geom.parts.is_empty() {
            return;
        }
        let com = rb.center_of_mass();
        let half = super::convert::to_real(geom.radius + step.policy.resting_gap);
        let grounds: SmallList<GroundGeom> = self
            .registry
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
            .collect();
        if grounds.is_empty() {
            return;
        }
        let end = rapier_state(rb);
        let Some(hit) = closest(&geom, &grounds, &end, step.dt, 0.0) else {
            return;
        };
        if step.policy.woken_contact(hit.dist, hit.un) == EndContact::Impact {
            let inertia = Inertia::of(rb);
            self.step_end(
                bodies, colliders, handle, &local_com, &geom, &grounds, &inertia, step, true,
            );
        }
    }

    /// After the step, for a ball sliding on a level ground (`Role::Rolling`): its closed-form
    /// motion over the step from the start (which touches the ground), if nothing else acted
    /// on it (`disturbed`) and it still touches the same ground plane at the end. Otherwise
    /// rapier's state stands, in which the ball flew without its ground (the pair was out of
    /// its solver) and so fell by up to `|g| dt^2 / 2` while pushed by whatever touched it:
    /// - moving into the ground no faster than that fall (`|a.n| dt`, plus the resting
    ///   speed), it is put back on the ground with no speed into it, as rapier's resting
    ///   contact would have held it (a `PushOut` event: a ball rolling up to another);
    /// - faster (something pushed it down), it is resolved at the step end (`step_end`,
    ///   `e = 0`, moved out).
    #[allow(clippy::too_many_arguments)]
    pub fn rolling_end(
        &mut self,
        bodies: &mut RigidBodySet,
        colliders: &ColliderSet,
        cand: &Candidate,
        ground: usize,
        motion: &Rolling,
        disturbed: bool,
        step: &EndOfStep,
    ) {
        let Some(gg) = ground_geom(&step.grounds[ground], colliders) else {
            return;
        };
        let geom = body_geom(&bodies[cand.body], colliders, &cand.local_com);
        let grounds = [gg];
        if !disturbed {
            let end = motion.advance(&cand.start, step.dt);
            let on = closest(&geom, &grounds, &end, step.dt, step.policy.resting_gap);
            if on.is_some_and(|hit| {
                hit.dist.abs() <= 1e-9 * motion.radius.max(1.0)
                    && hit.normal.dot(&motion.normal) >= 1.0 - 1e-9
            }) {
                let rb = &mut bodies[cand.body];
                write_state(rb, &end, &cand.local_com, true);
                if self.config.timing == TimingMode::Exact {
                    self.remember(cand.body, rb, &end);
                }
                return;
            }
        }
        let mut end = rapier_state(&bodies[cand.body]);
        let Some(hit) = closest(&geom, &grounds, &end, step.dt, 0.0) else {
            return;
        };
        let fall = -motion.accel.dot(&motion.normal) * step.dt;
        if step.policy.disturbed_rolling(hit.un, fall) == EndContact::PushOut {
            let before = end;
            put_on_ground(&mut end, &hit, true);
            let inertia = Inertia::of(&bodies[cand.body]);
            self.report_push_out(
                cand.body, &geom, &grounds, &hit, &inertia, &before, &end, step,
            );
            write_state(&mut bodies[cand.body], &end, &cand.local_com, true);
        } else {
            self.end_fallback(bodies, colliders, cand, &geom, &grounds, step, true);
        }
    }

    /// Reports a push-out (`put_on_ground`) from `before` to `after` at `hit`, unless it
    /// changed nothing.
    #[allow(clippy::too_many_arguments)]
    pub fn report_push_out(
        &mut self,
        body: RigidBodyHandle,
        geom: &BodyGeom,
        grounds: &[GroundGeom],
        hit: &super::geometry::Hit,
        inertia: &Inertia,
        before: &State,
        after: &State,
        step: &StepData,
    ) {
        if before.com == after.com && before.v == after.v {
            return;
        }
        let site = Site::of_hit(body, geom, grounds, hit);
        self.events.push(correction(
            EventKind::PushOut,
            &site,
            inertia,
            before,
            after,
            step.dt,
        ));
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
