//! Settle, for the pairs between bodies: the `Impact` pairs not moved together by
//! `pair_reconstruct.rs` (something else touched a body, or a search gave up) are checked at
//! rapier's end state, in which the pair was out of rapier's solver.
//!
//! Contract: [`AfterStep::pair_end`] reads the pair's two bodies as the step leaves them
//! (rapier's end states, or a member's state as the bodies stage already corrected it); where
//! they met in the step, it resolves their impact with the model at the step's end
//! (`ImpactTiming::StepEnd`), moves them apart along the contact normal to touching, each by
//! its inverse-mass share (a `PushOut` event each), checks each against the grounds near it
//! (the settle stage's check, `settle.rs`), and commits both.

use crate::motion::State;
use crate::plugin::bridge::convert::{to_f64, vec_from_na, vec_to_na};
use crate::plugin::bridge::resolve::{
    BodyContactAt, ImpactInput, Inertia, PairSide, Site, correction, resolve_balls, resolve_bodies,
};
use crate::plugin::config::ImpactConfig;
use crate::plugin::events::{EventKind, ImpactTiming};
use crate::plugin::impact_plugin::ImpactPlugin;
use crate::plugin::policy::{BENT_RELATIVE_MOTION, EndCheck, Role};
use crate::plugin::queries::body_contact::{body_contact, touch_point};
use crate::plugin::queries::observe::{body_geom, touched_besides_grounds};
use crate::plugin::stages::commit::Origin;
use crate::plugin::stages::settle::Checked;
use crate::plugin::stages::view::AfterStep;
use crate::plugin::stages::view::EndOfStep;
use crate::plugin::state::registry::Registry;
use crate::plugin::state::step::PlannedPair;
use crate::rapier::prelude::{
    ColliderHandle, ColliderSet, PhysicsHooks, RigidBody, RigidBodyHandle, RigidBodySet,
};
use nalgebra::Vector3;

impl<H: PhysicsHooks> ImpactPlugin<H> {
    /// The `Impact` pairs between bodies not moved together: rapier's end state (the pair
    /// out of its solver), checked at the step's end (`AfterStep::pair_end`).
    pub(super) fn settle_pairs(
        &mut self,
        step: &EndOfStep,
        bodies: &RigidBodySet,
        colliders: &ColliderSet,
    ) {
        let (moved_together, mut view) = (&step.moved_together, self.after_view());
        for pair in &step.pairs.pairs {
            if pair.role == Role::Impact
                && !(moved_together.contains(&pair.a) && moved_together.contains(&pair.b))
            {
                view.pair_end(bodies, colliders, pair, step);
            }
        }
    }
}

impl<'v> AfterStep<'v> {
    /// After the step, for an `Impact` pair of balls not moved together (something else touched
    /// one, or a search gave up): rapier's end state, in which the pair was out of its solver, so
    /// that the balls may have passed into, or right through, each other. If they met in the step
    /// (they overlap, their straight relative motion or the straight path between their start and
    /// end offsets came within reach, or their centres crossed the line of centres they started on
    /// while their relative motion bent), the model's impulse along the line of centres where they
    /// touched, on the straight way from their start offset to their end offset (`entry_normal`;
    /// else the line now, or the one they started on if they crossed) (`ImpactTiming::StepEnd`; no
    /// bounce slower than the resting speed, or the pressed speed for a ball touching something
    /// else), and both balls moved apart along it until their offset along it is the touching
    /// distance (off the line of centres now, they end a little apart), on the sides they started
    /// on, each by its inverse-mass share, with a `PushOut` event each. Other shapes:
    /// [`AfterStep::pair_end_bodies`].
    pub fn pair_end(
        &mut self,
        bodies: &RigidBodySet,
        colliders: &ColliderSet,
        pair: &PlannedPair,
        step: &EndOfStep,
    ) {
        if !pair.balls {
            return self.pair_end_bodies(bodies, colliders, pair, step);
        }
        // Each body as the step left it: a member may have been corrected already.
        let (Some(na), Some(nb)) = (
            self.commit.body(bodies, pair.a),
            self.commit.body(bodies, pair.b),
        ) else {
            return;
        };
        let (ra, rb, mut sa, mut sb) = (na.rb(), nb.rb(), na.state(), nb.state());
        let d = sb.com - sa.com;
        let len = d.norm();
        let crossed = d.dot(&pair.normal) < 0.0;
        let met = met_in_step(pair, d, sb.v - sa.v, step.dt);
        if !met || pair.normal == Vector3::zeros() && len == 0.0 {
            return;
        }
        // The contact normal: the line of centres where they touched, on the way from their
        // start offset to their end offset; else the line of centres now, or the one they
        // started on if they have crossed (or passed by).
        let n = entry_normal(pair.offset, d, pair.reach).unwrap_or(
            if !crossed && len > 0.0 && len < pair.reach {
                d / len
            } else {
                pair.normal
            },
        );
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
            [Pushed::of(&side_a, &mut sa), Pushed::of(&side_b, &mut sb)],
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
        bodies: &RigidBodySet,
        colliders: &ColliderSet,
        pair: &PlannedPair,
        step: &EndOfStep,
    ) {
        // Each body as the step left it: a member may have been corrected already.
        let (Some(na), Some(nb)) = (
            self.commit.body(bodies, pair.a),
            self.commit.body(bodies, pair.b),
        ) else {
            return;
        };
        let (ra, rb, mut sa, mut sb) = (na.rb(), nb.rb(), na.state(), nb.state());
        let (la, lb) = (
            vec_to_na(ra.local_center_of_mass()),
            vec_to_na(rb.local_center_of_mass()),
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
            [Pushed::of(&side_a, &mut sa), Pushed::of(&side_b, &mut sb)],
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
    ) -> ImpactInput<'a>
    where
        'v: 'a,
    {
        let pressed = |h: RigidBodyHandle, rb: &RigidBody| {
            touched_besides_grounds(h, rb, &step.sets, self.registry)
        };
        let touching = pressed(a.body, ra) || pressed(b.body, rb);
        let (registry, config): (&'v Registry, &'v ImpactConfig) = (self.registry, self.config);
        ImpactInput::between(
            a,
            config.law,
            registry.pair_material_of(colliders, a.collider, b.collider, config),
            step.policy.bounce_floor(touching),
            ImpactTiming::StepEnd,
        )
    }

    /// Writes the two bodies of a pair resolved at the step's end: moved apart, a body may be
    /// moved into a ground (a light ball pushed down by a heavy one), so each is checked
    /// against the grounds near it, as rapier's end state is.
    fn check_moved_apart(
        &mut self,
        bodies: &RigidBodySet,
        colliders: &ColliderSet,
        moved: [(RigidBodyHandle, State); 2],
        step: &EndOfStep,
    ) {
        for (body, state) in moved {
            let rb = &bodies[body];
            let local_com = vec_to_na(rb.local_center_of_mass());
            let geom = body_geom(rb, colliders, &local_com);
            let inertia = Inertia::of(rb);
            let com = vec_from_na(&state.com);
            let grounds = self.woken_geoms((bodies, colliders), body, (com, &geom), step, false);
            let checked = Checked {
                body,
                geom: &geom,
                inertia: &inertia,
                cand: None,
                grounds: &grounds,
                joined: grounds.len(),
                events_from: self.commit.reported().len(),
            };
            let why = EndCheck::RapierEnd;
            let (_, settled) = self.check(bodies, colliders, &checked, &state, why, step);
            let end = settled.unwrap_or(state);
            self.commit
                .state(body, &end, &local_com, Origin::Correction);
        }
    }
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
    /// The body of `side`, its state `state` to be moved.
    fn of(side: &PairSide<'s>, state: &'s mut State) -> Self {
        Self {
            body: side.body,
            collider: side.collider,
            inertia: side.inertia,
            state,
            radius: side.radius,
        }
    }
}

/// The unit line of centres (from the first ball to the second) where two balls of contact
/// radii summing to `reach` came to touch in the step: on the straight path of their offset
/// from `start` (the step's start) to `end` (its end; second less first), its entry into the
/// sphere of radius `reach`. Both balls fall alike, so gravity leaves that path straight for
/// balls in flight; the end's line of centres, after the balls ran up to `|dv| dt` into each
/// other, can be tens of degrees off it (and with it the impulse's direction). The path
/// between the two offsets, not the end's relative velocity, so that a ball whose state the
/// step already corrected (a ground impact) is taken from where it was. `None` where the
/// path does not enter (they started overlapping, or pass by).
fn entry_normal(start: Vector3<f64>, end: Vector3<f64>, reach: f64) -> Option<Vector3<f64>> {
    let travel = end - start;
    let len2 = travel.norm_squared();
    if !(len2 > 0.0 && reach > 0.0) || start.norm_squared() <= reach * reach {
        return None;
    }
    // |start + travel u| = reach: u^2 |travel|^2 + 2 u start.travel + |start|^2 - reach^2 = 0;
    // from outside, the entry is the smaller root.
    let b = start.dot(&travel);
    let disc = b * b - len2 * (start.norm_squared() - reach * reach);
    if disc < 0.0 {
        return None;
    }
    let u = (-b - disc.sqrt()) / len2;
    if !(0.0..=1.0).contains(&u) {
        return None;
    }
    let n = (start + travel * u) / reach;
    n.iter().all(|c| c.is_finite()).then_some(n)
}

/// Did two balls out of rapier's solver meet in the step, given their centres' offset `d`
/// (b less a) and relative velocity `dv` at its end? They may have passed into or through
/// each other: they met if they overlap now, or if on the way their centres came within
/// reach: by their relative motion over the step (straight, as out of the solver), or on the
/// straight line from where one started relative to the other to where it ended. Centres
/// that crossed the line of centres they started on met there too when the relative motion
/// bent on the way (a ball that passed through the other and bounced off the ground); moving
/// straight, they passed each other farther apart than the reach.
fn met_in_step(pair: &PlannedPair, d: Vector3<f64>, dv: Vector3<f64>, dt: f64) -> bool {
    let len = d.norm();
    let crossed = d.dot(&pair.normal) < 0.0;
    let bent = (dv - pair.relative_v).norm()
        > BENT_RELATIVE_MOTION * dv.norm().max(pair.relative_v.norm());
    let back = dv.norm_squared();
    let nearest = if back > 0.0 {
        // The closest approach of d - dv s for s in [0, dt] before the step's end.
        let s_min = (d.dot(&dv) / back).clamp(0.0, dt);
        (d - dv * s_min).norm()
    } else {
        len
    };
    let travel = d - pair.offset;
    let along_path = match -pair.offset.dot(&travel) {
        // The closest approach of offset + travel u for u in (0, 1]; none where the path
        // leads apart from its start (a pair that started touching and separated).
        closing if closing > 0.0 => {
            let u = (closing / travel.norm_squared()).min(1.0);
            (pair.offset + travel * u).norm()
        }
        _ => f64::INFINITY,
    };
    len < pair.reach || nearest < pair.reach || along_path < pair.reach || crossed && bent
}
