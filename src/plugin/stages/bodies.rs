//! Bodies: after rapier's step, every planned candidate not moved with a cluster of impacts
//! between bodies is routed to its reconstruction and checked at the step's end.
//!
//! Contract: for each candidate, in the plan's order, one route, decided from the plan (its
//! role: rolling, turning while resting, with `Impact` grounds or none) and from what rapier's
//! step did to it (a contact, a joint, a torque, rapier's CCD stopping it short):
//! - a rolling ball nothing else acted on: its closed form, written as it ends where the plan
//!   proved it stays over one flat face of a still ground (`Candidate::rolls_on_one_face`;
//!   steered there by rapier's integrator, and only its velocities written
//!   where rapier's pose carries the end: `Commit::rolled`), else once a contact query finds
//!   it still on its plane (`reconstruct::rolled`); or, if it rolls into another ground, that
//!   impact and on (`rolled_into`); one something else acted on: rapier's end state (a
//!   steered ball's velocities given back the steering's offsets), checked
//!   (`EndCheck::DisturbedRolling`), with a `Released` event;
//! - a body that flew alone with a closing ground: the in-step impacts from its start state
//!   (`reconstruct::through_impacts`, with the grounds along its way after an impact that
//!   sends it beyond its plan's reach), the end state checked (`EndCheck::Flown`) against
//!   the grounds searched;
//! - a body that flew alone with the step clear: `Exact` mode's exact flight
//!   (`fly_exactly`; of a flight the steer stage steered, the velocity alone where rapier's
//!   integrator carried the translation), and a check of rapier's rotation for a body whose
//!   turning moves its surface (`turned_end`); a steered body something else touched keeps
//!   rapier's end state, its velocity given back the steering's offset;
//! - any other: rapier's end state, checked (`EndCheck::RapierEnd`); after impulses at the
//!   step's start (`Step` mode's, a push-out), also against the grounds along the way they
//!   sent it, beyond its plan's reach (`reconstruct::grounds_beyond_plan`).
//!
//! The checks are the settle stage's (`settle.rs`); every write and event goes through the
//! commit (`commit.rs`). Also here: the balls held at rest on a slope for their first step,
//! put back (`put_back_held`).

use crate::motion::{Rolling, State};
use crate::plugin::bridge::convert::{rot_to_na, to_f64, vec_from_na, vec_to_na};
use crate::plugin::bridge::resolve::{
    GroundContactAt, ImpactInput, Inertia, Site, correction, released, resolve,
};
use crate::plugin::config::TimingMode;
use crate::plugin::events::{EventKind, ImpactEvent, ImpactTiming};
use crate::plugin::impact_plugin::ImpactPlugin;
use crate::plugin::policy::{EndAction, EndCheck, IN_PLANE_TOLERANCE, on_plane};
use crate::plugin::queries::geometry::{GroundGeom, Hit, Search, closest, first_impact};
use crate::plugin::queries::observe::{
    body_geom, pushed_by_other, touched_besides_grounds, touches_other,
};
use crate::plugin::stages::commit::Origin;
use crate::plugin::stages::reconstruct::{
    self, FlownEnd, Subject, ccd_consistent, ccd_consistent_far, ccd_consistent_steered,
};
use crate::plugin::stages::settle::Checked;
use crate::plugin::stages::view::AfterStep;
use crate::plugin::stages::view::EndOfStep;
use crate::plugin::state::handles::PairKey;
use crate::plugin::state::small_list::SmallList;
use crate::plugin::state::step::{Candidate, FirstHold};
use crate::plugin::state::writes::Now;
use crate::rapier::math::Vector;
use crate::rapier::prelude::{ColliderSet, LockedAxes, PhysicsHooks, RigidBody, RigidBodySet};
use nalgebra::Vector3;
use std::cell::OnceCell;

impl<H: PhysicsHooks> ImpactPlugin<H> {
    /// Routes every candidate not in `step.moved_together` (see the module's contract). A body
    /// rapier put to sleep in the step rests: rapier zeroed its velocities, and its contacts
    /// have left the solver's graph, so that it would look free and fall for a step.
    pub(super) fn reconstruct_bodies(
        &mut self,
        step: &EndOfStep,
        bodies: &RigidBodySet,
        colliders: &ColliderSet,
    ) {
        let moved_together = &step.moved_together;
        let mut view = self.after_view();
        for cand in &step.candidates {
            // A body moved with a cluster is passed over before its body is read.
            if !moved_together.is_empty() && moved_together.contains(&cand.body) {
                continue;
            }
            let Some(rb) = bodies.get(cand.body) else {
                continue;
            };
            if !view.registry.manages(cand.body, rb) || view.commit.is_sleeping(cand.body, rb) {
                continue;
            }
            // The route reads the body found here (`rb`), not the set again.
            if let Some((ground, motion)) = &cand.rolling {
                view.roll(step, (cand, rb), *ground, motion, bodies, colliders);
            } else {
                view.fly(step, (cand, rb), bodies, colliders);
            }
            if let Some(ground) = cand.released {
                view.released_checked(step, cand, ground, bodies, colliders);
            }
        }
        let released = std::mem::take(&mut view.released);
        self.memory.release(released);
    }

    /// The balls held at rest on a slope for their first step (`FirstHold`): each put back
    /// where it stopped, at rest, with its `EventKind::Hold` event, unless something else
    /// touched it in the step (or it leaves faster than the resting speed), or rapier put it
    /// to sleep.
    pub(super) fn put_back_held(&mut self, step: &EndOfStep, bodies: &RigidBodySet) {
        let mut view = self.after_view();
        for hold in &step.first_holds {
            view.put_back(hold, step, bodies);
        }
    }
}

impl AfterStep<'_> {
    /// A rolling candidate (see the module's contract).
    fn roll(
        &mut self,
        step: &EndOfStep,
        (cand, rb): (&Candidate, &RigidBody),
        ground: usize,
        motion: &Rolling,
        bodies: &RigidBodySet,
        colliders: &ColliderSet,
    ) {
        let now = self.commit.now(cand.body, rb);
        // Something else acted on it in the step: a contact, a joint, or rapier's CCD
        // stopping it short (against a thin body).
        let sets = &step.sets;
        let steered_roll = step.steered_roll(cand);
        let ccd_left_it = match steered_roll {
            Some(steered) => ccd_consistent_steered(&now, cand, steered, step),
            None => ccd_consistent(&now, &FlownEnd::new(cand, step.dt), step.dt, step),
        };
        let disturbed =
            sets.jointed(cand.body) || pushed_by_other(now.rb(), sets.narrow_phase) || !ccd_left_it;
        if let Some(steered) = steered_roll {
            if !disturbed {
                // rapier's integrator carried it to the roll's end (`steer.rs`).
                let body = (cand.body, &now);
                self.commit.rolled(body, &steered.end, &cand.local_com);
                return;
            }
            // rapier's end state stands (checked below): its velocities get the steering's
            // offsets back, as an unsteered ball's that flew without its ground.
            let (dv, dw) = steered.offsets;
            let linvel = vec_from_na(&(vec_to_na(now.linvel()) + dv));
            let angvel = vec_from_na(&(vec_to_na(now.angvel()) + dw));
            let _ = self.commit.velocities(cand.body, linvel, angvel);
        }
        // Alone over one flat face of a still ground for the whole step (the plan's proof):
        // its closed-form end touches the face, and needs no query.
        if !disturbed && cand.rolls_on_one_face {
            let end = motion.advance(&cand.start, step.dt);
            self.commit
                .state(cand.body, &end, &cand.local_com, Origin::Roll);
            return;
        }
        let geom = body_geom(now.rb(), colliders, &cand.local_com);
        let Some(gg) = self.pair_geom(&step.grounds[ground], &geom, colliders) else {
            return;
        };
        // With the other grounds near it (the pieces of its plane, if it rolls across a seam),
        // each without the pairs rapier's or the user's filter refused.
        let grounds: SmallList<_> = std::iter::once(gg)
            .chain(
                cand.near
                    .iter()
                    .filter(|i| **i != ground)
                    .filter_map(|i| self.pair_geom(&step.grounds[*i], &geom, colliders)),
            )
            .collect();
        let subject = Subject::new(cand, &geom, &grounds, step);
        if !disturbed && !cand.impact_grounds.is_empty() {
            // A ground it may roll into: where it does, that impact, and on from there.
            let obstacles = self.impact_ground_geoms(&cand.impact_grounds, &geom, colliders, step);
            if let Some(touch) = reconstruct::rolling_touch(cand, motion, &geom, &obstacles, step) {
                self.rolled_into(bodies, colliders, &subject, motion, &obstacles, touch);
                return;
            }
        }
        let rolled = (!disturbed)
            .then(|| reconstruct::rolled(cand, motion, &geom, &grounds, step))
            .flatten();
        if let Some(end) = rolled {
            self.commit
                .state(cand.body, &end, &cand.local_com, Origin::Roll);
            return;
        }
        // rapier's end state stands, in which the ball flew without its ground (a steered
        // ball's pose rolled on it; its velocities are an unsteered one's).
        if let (true, Some(part)) = (disturbed, geom.parts.first()) {
            let key = (part.handle, grounds[0].handle);
            let Some(now) = self.commit.body(bodies, cand.body) else {
                return;
            };
            let event = released_at_end(cand, &now, key, motion, step.dt);
            self.commit.event(event);
            self.released.push(key);
        }
        let fall = -motion.accel.dot(&motion.normal) * step.dt;
        let why = EndCheck::DisturbedRolling {
            fall,
            plane: motion.normal,
        };
        self.settle_rapier_end(bodies, colliders, &subject, why);
    }

    /// A candidate that is not rolling (see the module's contract).
    fn fly(
        &mut self,
        step: &EndOfStep,
        (cand, rb): (&Candidate, &RigidBody),
        bodies: &RigidBodySet,
        colliders: &ColliderSet,
    ) {
        let mode = self.config.timing;
        let has_grounds = cand
            .impact_grounds
            .iter()
            .any(|i| colliders.get(step.grounds[*i].handle).is_some());
        if !has_grounds
            && !cand.turning_resting.is_empty()
            && self.turning_resting_corrected(step, cand, bodies, colliders)
        {
            return;
        }
        let now = self.commit.now(cand.body, rb);
        let flown = FlownEnd::new(cand, step.dt);
        // Whether it flew alone walks its contacts: asked only on the routes that read it (not
        // for a body with no ground outside `Exact` mode, whose end rapier's integrator keeps).
        let alone = OnceCell::new();
        let free = || *alone.get_or_init(|| flew_alone(&now, &flown, has_grounds, step));
        // Before any geometry: a body with no ground left to search, or whose search would
        // find the step clear (`Candidate::closing`) and that rapier's CCD did not cut short,
        // only flies (exactly, in `Exact` mode).
        let clear = mode != TimingMode::Step
            && has_grounds
            && !cand.closing
            && free()
            && ccd_consistent(&now, &flown, step.dt, step);
        if !has_grounds || clear {
            if mode == TimingMode::Exact
                && free()
                && (clear || ccd_consistent_far(&now, &flown, step))
            {
                self.fly_exactly(&now, &flown);
            } else if let Some(steer) = cand.flight_steering(step.steering_lag) {
                // rapier's end state stands: its velocity gets the steering's offset back.
                let v = vec_to_na(now.linvel()) + steer;
                self.commit.velocity(cand.body, vec_from_na(&v));
            }
            if has_grounds {
                self.turned_end(bodies, colliders, cand, step);
                self.turning_resting_checked(step, cand, bodies, colliders);
            }
            return;
        }
        self.fly_searched(step, (&now, &flown), free, bodies, colliders);
    }

    /// A candidate with `Impact` grounds whose step is not surely clear (see [`Self::fly`]):
    /// the search from its start, and the route its first event decides. Out of line: most
    /// candidates have no ground to search, and their route stays small.
    #[inline(never)]
    fn fly_searched(
        &mut self,
        step: &EndOfStep,
        (now, flown): (&Now, &FlownEnd),
        free: impl Fn() -> bool,
        bodies: &RigidBodySet,
        colliders: &ColliderSet,
    ) {
        let (mode, cand) = (self.config.timing, flown.candidate());
        let geom = body_geom(now.rb(), colliders, &cand.local_com);
        let grounds = self.impact_ground_geoms(&cand.impact_grounds, &geom, colliders, step);
        let subject = Subject::new(cand, &geom, &grounds, step);
        let inertia = Inertia::of(now.rb());
        match first_search(now, &subject, flown, mode != TimingMode::Step && free()) {
            None if cand.touched => {
                // Impulses at the step's start (`Step` mode's, or a push-out back over a mesh)
                // may have sent it beyond its plan's reach (a bat's hit), or into a ground it
                // rested on, whose pair is rapier's resting contact: its end is checked against
                // the grounds along its new way and all those near it.
                let sets = (bodies, colliders, &step.sets);
                let moved = (&cand.start, &cand.flight, 0.0);
                let mut checked =
                    reconstruct::grounds_beyond_plan(self, sets, &subject, &grounds, moved)
                        .unwrap_or_else(|| grounds.to_vec());
                let joined = checked.len();
                let near = self.other_near_geoms(cand, &geom, (colliders, step), &checked);
                checked.extend(near);
                let subject = Subject {
                    joined,
                    ..Subject::new(cand, &geom, &checked, step)
                };
                self.settle_rapier_end(bodies, colliders, &subject, EndCheck::RapierEnd);
                self.turning_resting_checked(step, cand, bodies, colliders);
            }
            None => {
                self.settle_rapier_end(bodies, colliders, &subject, EndCheck::RapierEnd);
                self.turning_resting_checked(step, cand, bodies, colliders);
            }
            Some(Search::Clear) if mode == TimingMode::TimeOfImpact && !cand.turns_surface => {
                // rapier's integrator, whose end state stands in this mode, ends lower than
                // the flight the search followed (`StepData::integrator_lag`; 0.3 m lower at
                // dt = 0.5 s): its end is checked (a turning body's, more strictly, below).
                self.settle_rapier_end(bodies, colliders, &subject, EndCheck::Lagged);
                self.turning_resting_checked(step, cand, bodies, colliders);
            }
            Some(Search::Clear) => {
                if mode == TimingMode::Exact {
                    self.fly_exactly(now, flown);
                }
                self.turned_end(bodies, colliders, cand, step);
                self.turning_resting_checked(step, cand, bodies, colliders);
            }
            Some(first) => {
                self.fly_through_impacts(bodies, colliders, &subject, &inertia, first);
            }
        }
    }

    /// A body with no `Impact` ground whose resting pairs turn fast: rapier's end state,
    /// checked against those grounds (`EndCheck::TurningResting`); `true` when corrected
    /// (rapier's end state then stands, and no flight is written over it).
    fn turning_resting_corrected(
        &mut self,
        step: &EndOfStep,
        cand: &Candidate,
        bodies: &RigidBodySet,
        colliders: &ColliderSet,
    ) -> bool {
        let geom = body_geom(&bodies[cand.body], colliders, &cand.local_com);
        let grounds = self.turning_resting_geoms(&cand.turning_resting, &geom, colliders, step);
        let subject = Subject::new(cand, &geom, &grounds, step);
        let why = EndCheck::TurningResting {
            turns_surface: cand.turns_surface,
        };
        self.settle_rapier_end(bodies, colliders, &subject, why) != EndAction::Keep
    }

    /// A body with `Impact` grounds whose end state is rapier's after their checks: its
    /// resting pairs that turn fast are checked too (`EndCheck::TurningResting`), as for a
    /// body with none, so that a body tumbling on one ground beside another it may hit ends
    /// no deeper than the resting gap in the first.
    fn turning_resting_checked(
        &mut self,
        step: &EndOfStep,
        cand: &Candidate,
        bodies: &RigidBodySet,
        colliders: &ColliderSet,
    ) {
        if !cand.turning_resting.is_empty() {
            self.turning_resting_corrected(step, cand, bodies, colliders);
        }
    }

    /// A ball released from its closed-form rolling at the step's start
    /// (`Candidate::released`): rapier's end state checked against that ground
    /// (`EndCheck::ReleasedResting`): another body can push it deeper into the ground than
    /// rapier's resting contact leaves it.
    fn released_checked(
        &mut self,
        step: &EndOfStep,
        cand: &Candidate,
        ground: usize,
        bodies: &RigidBodySet,
        colliders: &ColliderSet,
    ) {
        let Some(rb) = bodies.get(cand.body) else {
            return;
        };
        let geom = body_geom(rb, colliders, &cand.local_com);
        let Some(gg) = self.pair_geom(&step.grounds[ground], &geom, colliders) else {
            return;
        };
        let grounds = [gg];
        let subject = Subject::new(cand, &geom, &grounds, step);
        self.settle_rapier_end(bodies, colliders, &subject, EndCheck::ReleasedResting);
    }

    /// `Exact` mode, a body that flew free all step: its translation and linear velocity
    /// from the exact flight. Its rotation stays rapier's, and so does the spin of an
    /// anisotropic body or of one with a locked rotation axis (rapier turns it its own way,
    /// and the two must agree); a body whose spin keeps its axis (isotropic inertia, or
    /// rapier's gyroscopic forces off) gets the exact spin too.
    fn fly_exactly(&mut self, now: &Now, flown: &FlownEnd) {
        let (cand, (com, v)) = (flown.candidate(), *flown.centre());
        let exact_spin = cand.flight.gyro.is_none()
            && !now
                .rb()
                .locked_axes()
                .intersects(LockedAxes::ROTATION_LOCKED);
        let s = State {
            com,
            rot: rot_to_na(now.rotation()),
            v,
            w: if exact_spin {
                flown.spin_keeping_axis()
            } else {
                vec_to_na(now.angvel())
            },
        };
        let body = (cand.body, now);
        let spin_steered = (exact_spin, cand.steered);
        self.commit.flight(body, &s, &cand.local_com, spin_steered);
    }

    /// One ball held at rest for its first step (`ImpactPlugin::put_back_held`).
    fn put_back(&mut self, hold: &FirstHold, step: &EndOfStep, bodies: &RigidBodySet) {
        let Some(now) = self.commit.body(bodies, hold.body) else {
            return;
        };
        let (rb, end) = (now.rb(), now.state());
        let still = step.policy.is_still(&end, hold.radius);
        if now.is_sleeping()
            || !still
            || (end.com == hold.start.com && end.rot == hold.start.rot)
            || touched_besides_grounds(hold.body, rb, &step.sets, self.registry)
        {
            return;
        }
        let site = Site {
            body: hold.body,
            collider: hold.collider,
            ground: hold.ground,
            body2: None,
            normal: hold.normal,
            point: hold.start.com - hold.normal * hold.radius,
        };
        let inertia = Inertia::of(rb);
        let event = correction(EventKind::Hold, &site, &inertia, &end, &hold.start, step.dt);
        self.commit
            .state(hold.body, &hold.start, &hold.local_com, Origin::Model);
        self.commit.event(event);
    }

    /// A rolling ball that meets another ground in the step, at `touch`
    /// (`reconstruct::rolling_touch`): the impact there, by the model. Left on that ground
    /// (e = 0) and leaving its own plane (rolling off a slope onto the level ground at its
    /// foot), it rolls on in closed form on the new ground to the step's end; otherwise it
    /// goes on through the impacts the search finds, as any impact's body does, and the
    /// settle stage checks where it ends. `subject.grounds`: every ground near it,
    /// `obstacles` among them.
    fn rolled_into(
        &mut self,
        bodies: &RigidBodySet,
        colliders: &ColliderSet,
        subject: &Subject,
        motion: &Rolling,
        obstacles: &[GroundGeom],
        touch: (f64, State, Hit),
    ) {
        let (t, s, hit) = touch;
        let cand = subject.cand;
        let inertia = Inertia::of(&bodies[cand.body]);
        let og = &obstacles[hit.ground];
        let rolls_on = self.roll_on_new_ground(colliders, subject, &inertia, motion, og, touch);
        if let Some((end, event)) = rolls_on {
            self.commit.event(event);
            self.commit
                .state(cand.body, &end, &cand.local_com, Origin::Roll);
            return;
        }
        let Some(index) = subject.grounds.iter().position(|g| g.handle == og.handle) else {
            return;
        };
        let first = Search::Hit(
            t,
            s,
            Hit {
                ground: index,
                ..hit
            },
        );
        self.fly_through_impacts(bodies, colliders, subject, &inertia, first);
    }

    /// The impact of a rolling ball on the ground `og` it rolls into, and, if that impact
    /// leaves it on `og` (`e = 0`, the materials' or a settled impact's), leaving its own
    /// plane, and `og` neither turns nor moves off its plane, its closed-form rolling on `og`
    /// to the step's end, if it ends there on `og`'s plane and in no other ground: that end
    /// state and the impact's event.
    fn roll_on_new_ground(
        &self,
        colliders: &ColliderSet,
        subject: &Subject,
        inertia: &Inertia,
        motion: &Rolling,
        og: &GroundGeom,
        (t, s, hit): (f64, State, Hit),
    ) -> Option<(State, ImpactEvent)> {
        let (cand, geom, step) = (subject.cand, subject.geom, subject.step);
        let part = &geom.parts[hit.part];
        let material = self
            .registry
            .material_of(colliders, part.handle, og.handle, self.config);
        let input = ImpactInput::new(
            cand.body,
            inertia,
            self.config.law,
            material,
            step.policy.resting_speed,
            ImpactTiming::InStep,
        );
        let n = hit.normal;
        let (after, event) = resolve(
            &input,
            geom,
            og,
            &s,
            t,
            &GroundContactAt::new(&hit, hit.point, 1),
        )?;
        let onto = (event.settled || event.restitution == 0.0)
            && after.v.dot(&motion.normal) > 0.0
            && n.dot(&motion.accel) < 0.0;
        let in_plane = og.motion.w == Vector3::zeros()
            && og.motion.v.dot(&n).abs() <= IN_PLANE_TOLERANCE * og.motion.v.norm();
        let ball = part.shape.as_ball().filter(|_| onto && in_plane)?;
        let radius = to_f64(ball.radius) + part.skin + og.skin;
        let default = (
            self.config.rolling_resistance,
            self.config.spinning_friction,
        );
        let (rolling_resistance, spinning_friction) =
            self.registry.rolling_of(cand.body, og.handle, default);
        let on_new = Rolling {
            normal: n,
            radius,
            inertia_ratio: inertia.ball_ratio(radius)?,
            friction: material.friction(),
            rolling_resistance,
            spinning_friction,
            accel: motion.accel,
            ground_velocity: og.motion.v,
        };
        let end = on_new.advance_checked(&after, step.dt - t)?;
        // Still on the new ground's plane at the end, and in no other ground.
        let reach = step.policy.contact_margin();
        let last = closest(geom, subject.grounds, &end, step.dt, reach)?;
        on_plane(last.dist, &last.normal, &n, radius).then_some((end, event))
    }

    /// A candidate moved through the impacts from `first` on to the step's end
    /// (`reconstruct::through_impacts`), checked there by the settle stage (never left inside
    /// a ground, nor lifted out with energy gained), and committed.
    fn fly_through_impacts(
        &mut self,
        bodies: &RigidBodySet,
        colliders: &ColliderSet,
        subject: &Subject,
        inertia: &Inertia,
        first: Search,
    ) {
        let (cand, geom, grounds, step) =
            (subject.cand, subject.geom, subject.grounds, subject.step);
        let events_from = self.commit.reported().len();
        let (flown, widened) =
            reconstruct::through_impacts(self, (bodies, colliders), subject, inertia, first);
        let grounds = widened.as_deref().unwrap_or(grounds);
        let checked = Checked {
            body: cand.body,
            geom,
            inertia,
            cand: Some(cand),
            grounds,
            joined: grounds.len(),
            events_from,
        };
        let why = EndCheck::Flown;
        let (_, settled) = self.check(bodies, colliders, &checked, &flown, why, step);
        let end = settled.unwrap_or(flown);
        self.commit
            .state(cand.body, &end, &cand.local_com, Origin::Model);
    }

    /// The settle stage's check of rapier's end state of a candidate against its grounds for
    /// `why`, and the commit of what it corrected; returns the action it took.
    fn settle_rapier_end(
        &mut self,
        bodies: &RigidBodySet,
        colliders: &ColliderSet,
        subject: &Subject,
        why: EndCheck,
    ) -> EndAction {
        let (cand, geom, grounds, step) =
            (subject.cand, subject.geom, subject.grounds, subject.step);
        let Some(now) = self.commit.body(bodies, cand.body) else {
            return EndAction::Keep;
        };
        let (inertia, end) = (Inertia::of(now.rb()), now.state());
        let checked = Checked {
            body: cand.body,
            geom,
            inertia: &inertia,
            cand: Some(cand),
            grounds,
            joined: subject.joined,
            events_from: self.commit.reported().len(),
        };
        let (action, settled) = self.check(bodies, colliders, &checked, &end, why, step);
        if let Some(s) = settled {
            self.commit
                .state(cand.body, &s, &cand.local_com, Origin::Correction);
        }
        action
    }

    /// After a step the search found clear, for a body whose rotation moves its surface (not
    /// a ball about its centre): the search flies it torque-free while rapier's integrator
    /// turns it its own way (and `Exact` mode keeps rapier's rotation), so that for a fast
    /// tumble the two part at the corners. What rapier's end pose holds in its `Impact`
    /// grounds is checked (`RapierEnd`).
    fn turned_end(
        &mut self,
        bodies: &RigidBodySet,
        colliders: &ColliderSet,
        cand: &Candidate,
        step: &EndOfStep,
    ) {
        if !cand.turns_surface {
            return;
        }
        let geom = body_geom(&bodies[cand.body], colliders, &cand.local_com);
        let grounds = self.impact_ground_geoms(&cand.impact_grounds, &geom, colliders, step);
        let subject = Subject::new(cand, &geom, &grounds, step);
        self.settle_rapier_end(bodies, colliders, &subject, EndCheck::RapierEnd);
    }
}

/// Nothing but its flight moved the body in rapier's step: no contact in rapier's solver,
/// joint, torque or `Step` impulse. A body whose linear velocity rapier changed otherwise than
/// its flight does was pushed (a ball resting in a pile), and its contacts are not walked.
fn flew_alone(body: &Now, flown: &FlownEnd, has_grounds: bool, step: &EndOfStep) -> bool {
    let (sets, rb, cand) = (&step.sets, body.rb(), flown.candidate());
    (has_grounds || reconstruct::moved_as_flown(body, flown, step))
        && !sets.jointed(cand.body)
        && rb.user_torque() == Vector::ZERO
        && !cand.touched
        && !touches_other(rb, sets.narrow_phase)
}

/// The first event of an in-step resolution from the start-of-step state, or `None` when there
/// is none: the body did not fly `free` (it touched something else, or the mode is `Step`),
/// or rapier's CCD cut its motion short before that first event; rapier's end state is then
/// checked instead.
fn first_search(body: &Now, subject: &Subject, flown: &FlownEnd, free: bool) -> Option<Search> {
    let (cand, geom, grounds, step) = (subject.cand, subject.geom, subject.grounds, subject.step);
    let first = free.then(|| {
        if cand.closing {
            first_impact(geom, grounds, &cand.flight, &cand.start, 0.0, 0.0, step.dt)
        } else {
            Search::Clear
        }
    });
    first.filter(|f| {
        let t_first = match f {
            Search::Hit(t, ..) | Search::Stalled(t, _) => *t,
            Search::Clear => step.dt,
        };
        ccd_consistent(body, flown, t_first, step)
    })
}

/// The [`EventKind::Released`] event of a rolling ball that something besides its ground
/// touched in the step: rapier's end state, unchanged.
fn released_at_end(
    cand: &Candidate,
    body: &Now,
    (collider, ground): PairKey,
    motion: &Rolling,
    dt: f64,
) -> ImpactEvent {
    let end = body.state();
    let site = Site {
        body: cand.body,
        collider,
        ground,
        body2: None,
        normal: motion.normal,
        point: end.com - motion.normal * motion.radius,
    };
    released(&site, &Inertia::of(body.rb()), &end, dt)
}
