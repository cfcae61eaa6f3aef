//! Each pair's role: whether a pair of members may meet in the step, and if so whether it is
//! an `Impact` (out of rapier's solver, resolved by the reconstruct stage) or `Resting`
//! (rapier's solver keeps it, with zero restitution where rapier would bounce it above the
//! resting gap).

use super::gather::{Ball, Members, geom_state};
use super::index::PairIndex;
use super::{PairInputs, pair_key};
use crate::motion::State;
use crate::plugin::bridge::convert::{to_real, vec_to_na};
use crate::plugin::bridge::resolve::material;
use crate::plugin::policy::rests_at;
use crate::plugin::policy::{LOADED_COS, Role, model_may_pair};
use crate::plugin::queries::body_contact::body_contact;
use crate::plugin::queries::filter;
use crate::plugin::queries::geometry::contact;
use crate::plugin::queries::ground_index::GroundMotion;
use crate::plugin::queries::observe::{
    ground_geom, held_besides, pressed_besides, stacked_besides,
};
use crate::plugin::stages::plan::closes_within;
use crate::plugin::state::handles::PairKey;
use crate::plugin::state::step::{PairPlan, PlannedPair};
use crate::rapier::prelude::{ColliderHandle, PhysicsHooks, RigidBodyHandle, RigidBodySet};
use nalgebra::Vector3;
use std::cell::OnceCell;

/// At most this many grounds are weighed, for every pair that might ask them, in
/// [`Judge::bounce_may_lift`]; more grounds are asked for each member's own contacts.
const STILL_PLANES_MAX: usize = 4;

/// How far a contact normal with a half-space may be from its plane's normal, and a unit
/// normal's length from 1 (`f32` rounding is a thousand times smaller).
const PLANE_NORMAL_SLACK: f64 = 1e-4;

/// The rounding of a closing speed's computation, relative to the members' speeds (far above
/// a few ulps).
const CLOSING_ROUNDING: f64 = 1e-9;

/// What deciding a pair reads: the stage's inputs, the bodies, the members and the pair
/// index (its list the members'). Read-only but for its caches (`lying`, `grounds`,
/// `stacks`), which hold answers that do not change within the step.
pub(super) struct Judge<'p, 'a, H> {
    pub inputs: &'p PairInputs<'a, H>,
    pub bodies: &'p RigidBodySet,
    pub members: &'p Members<'a>,
    pub index: &'p PairIndex,
    /// `Policy::contact_margin` (m): the slack of every reach and closing test.
    pub margin: f64,
    /// The unit direction of gravity, zero without gravity.
    pub down: Vector3<f64>,
    /// Whether member `k`, not a centred ball, lies within the resting gap of a ground:
    /// computed once a step, for the bodies of a pair looked at.
    lying: Vec<OnceCell<bool>>,
    /// Member `k` against the grounds near it ([`Self::grounded`]): computed once a step, for
    /// the bodies of a pair looked at.
    grounds: Vec<OnceCell<Grounded>>,
    /// Whether rapier's solver pushed member `k` along gravity's line through a contact with
    /// any body but a ground (`stacked_besides`, no partner left out): computed once a step,
    /// for the bodies of an impact looked at ([`Self::stacked`]).
    stacks: Vec<OnceCell<bool>>,
    /// The grounds' outward normals, when there are at most [`STILL_PLANES_MAX`] grounds and
    /// each is a half-space that stays still over the step; `None` otherwise.
    still_planes: Option<Vec<Vector3<f64>>>,
}

/// A member against the grounds near it at the step's start ([`Judge::grounded`]).
#[derive(Clone, Copy, Default)]
struct Grounded {
    /// It lies on a ground: within the resting gap, approaching no faster than the held
    /// speed (`Policy::held_speed`).
    lies: bool,
    /// Its velocity after a bounce off the ground it may hit fastest in the step, if it does
    /// not lie on one.
    bounced: Option<Vector3<f64>>,
}

/// How two members approach at the step's start.
struct Approach {
    /// Their surfaces' distance (m): the centres' less `reach` for two balls, parry's
    /// otherwise.
    gap: f64,
    /// The closing speed along `normal` (m/s), what turning can add included.
    closing: f64,
    /// The unit contact normal from the first to the second.
    normal: Vector3<f64>,
    /// Their radii summed (m).
    reach: f64,
    /// Two centred balls.
    balls_only: bool,
}

impl<'p, 'a, H: PhysicsHooks> Judge<'p, 'a, H> {
    pub(super) fn new(
        inputs: &'p PairInputs<'a, H>,
        bodies: &'p RigidBodySet,
        members: &'p Members<'a>,
        index: &'p PairIndex,
    ) -> Self {
        let policy = inputs.policy;
        Judge {
            inputs,
            bodies,
            members,
            index,
            margin: policy.contact_margin(),
            down: inputs
                .gravity
                .try_normalize(0.0)
                .unwrap_or_else(Vector3::zeros),
            lying: members.balls.iter().map(|_| OnceCell::new()).collect(),
            grounds: members.balls.iter().map(|_| OnceCell::new()).collect(),
            stacks: members.balls.iter().map(|_| OnceCell::new()).collect(),
            still_planes: still_planes(inputs.grounds),
        }
    }

    /// Could a bounce of a member moving at `speed` (m/s) off a ground raise the closing
    /// speed of its pair along `normal` above the resting speed, `base` ((v_a - v_b)·normal)
    /// being the closing speed without it and `speeds` the members' speeds summed? A bounce
    /// off a still ground of normal `n` turns back the member's normal speed `u = v·n`
    /// ([`Self::grounded`]): it adds `2 |u| |n·normal|` at most, with `|u| <= |v|`, and a
    /// contact with a half-space has the plane's normal. `true` (the ground must be asked)
    /// where some ground is not a still half-space, or for a NaN.
    fn bounce_may_lift(&self, speed: f64, base: f64, normal: &Vector3<f64>, speeds: f64) -> bool {
        let Some(planes) = &self.still_planes else {
            return true;
        };
        // Summed rather than the largest taken: at least as large, and a NaN stays one.
        let tilt: f64 = planes.iter().map(|n| n.dot(normal).abs()).sum();
        let lift = 2.0 * speed * (tilt + PLANE_NORMAL_SLACK) * (1.0 + PLANE_NORMAL_SLACK);
        let most = base + lift + CLOSING_ROUNDING * speeds;
        !rests_at(most, self.inputs.policy.resting_speed)
    }

    /// Member `k` against the grounds near it at the step's start (parry's contact with each
    /// ground near its swept sphere): whether it lies on one (within the resting gap, not
    /// approaching faster than the held speed, what rapier's resting contact leaves), and if
    /// not, its velocity reflected off the ground it closes on fastest within the step faster
    /// than the resting speed (its normal speed relative to the ground turned back whole, as
    /// `e = 1` would). A body flying onto
    /// a ground can turn onto a neighbour it was not closing on at the step's start (a ball
    /// dropped with another on top of it): its pairs are judged at that velocity too. A
    /// ball lying on a ground (rolling into a wall, say) is the rolling's and the bodies
    /// stage's, and bounces nowhere here.
    fn grounded(&self, k: usize) -> Grounded {
        *self.grounds[k].get_or_init(|| {
            let (inputs, policy, dt) = (self.inputs, self.inputs.policy, self.inputs.dt);
            let m = &self.members.balls[k];
            let swept = self.members.swept[k];
            let near = inputs
                .registry
                .index
                .near(inputs.grounds, m.rapier_com(), to_real(swept));
            let mut found = Grounded::default();
            if near.is_empty() {
                return found;
            }
            let (geom, state) = geom_state(m, self.bodies, inputs.colliders);
            let accel = inputs.gravity.dot(&self.down) * self.down;
            let mut fastest: Option<(Vector3<f64>, f64)> = None;
            for g in near.iter() {
                let Some(gg) = ground_geom(&inputs.grounds[*g], inputs.colliders) else {
                    continue;
                };
                for part in geom.get().parts.iter() {
                    let Some((dist, n, point)) = contact(part, &gg, &state, 0.0, swept) else {
                        continue;
                    };
                    // The normal speed, negative approaching.
                    let un = (m.v() - gg.velocity_at(&point, 0.0)).dot(&n);
                    if dist <= policy.resting_gap && -un <= policy.held_speed {
                        found.lies = true;
                        return found;
                    }
                    let an = accel.dot(&n);
                    let arrival = -un - an.min(0.0) * dt;
                    let hits =
                        closes_within(dist, un, an, dt) && !rests_at(arrival, policy.resting_speed);
                    if hits && fastest.is_none_or(|(_, u)| un < u) {
                        fastest = Some((n, un));
                    }
                }
            }
            found.bounced = fastest.map(|(n, un)| m.v() - n * (2.0 * un.min(0.0)));
            found
        })
    }

    /// Does one member of the pair of `i` and `j`, within the resting gap of each other along
    /// `normal` (from `i` to `j`), lie on the other, along gravity's line, while that one lies
    /// on a ground? A stack on the ground, held as a pair held at rest last step is.
    fn lies_on_grounded(&self, (i, j): (usize, usize), gap: f64, normal: &Vector3<f64>) -> bool {
        let along = normal.dot(&self.down);
        gap <= self.inputs.policy.resting_gap
            && along.abs() > LOADED_COS
            && self.grounded(if along > 0.0 { j } else { i }).lies
    }

    /// Member `k`, a body that is not a centred ball, lies within the resting gap of a ground
    /// (parry's distance to the grounds near it): its pairs are rapier's. `false` for a
    /// centred ball.
    fn on_ground(&self, k: usize) -> bool {
        *self.lying[k].get_or_init(|| {
            let (inputs, policy) = (self.inputs, self.inputs.policy);
            let m = &self.members.balls[k];
            let Some(shape) = &m.shape else {
                return false;
            };
            let (geom, state) = (&shape.geom, &shape.state);
            let half = to_real(m.radius + policy.resting_gap);
            inputs
                .registry
                .index
                .near(inputs.grounds, m.rapier_com(), half)
                .iter()
                .any(|g| {
                    ground_geom(&inputs.grounds[*g], inputs.colliders).is_some_and(|gg| {
                        geom.parts.iter().any(|part| {
                            contact(part, &gg, state, 0.0, policy.resting_gap).is_some()
                        })
                    })
                })
        })
    }

    /// Has rapier's solver held the pair in contact (an impulse last step)?
    fn held(&self, a: &Ball, b: &Ball) -> bool {
        self.inputs
            .sets
            .narrow_phase
            .contact_pair(a.collider, b.collider)
            .is_some_and(|pair| {
                pair.manifolds()
                    .iter()
                    .any(|m| m.points.iter().any(|p| p.data.impulse > 0.0))
            })
    }

    /// Would rapier not solve the pair `key` of the bodies' colliders, or the user's filter
    /// refuse it? (`filter.rs`; every test there is symmetric in the two.)
    pub(super) fn refused(&self, key: PairKey, a: RigidBodyHandle, b: RigidBodyHandle) -> bool {
        let inputs = self.inputs;
        filter::pair_refused(
            (inputs.user_hooks, inputs.flags),
            (self.bodies, inputs.colliders, inputs.sets),
            key,
            (a, b),
        )
    }

    /// The closing speed of two members along their line of centres, and their centres'
    /// distance less their radii (the gap of two balls).
    pub(super) fn closing_gap(&self, a: RigidBodyHandle, b: RigidBodyHandle) -> (f64, f64) {
        let balls = &self.members.balls;
        let (ba, bb) = (
            &balls[self.index.ball_of_body(a)],
            &balls[self.index.ball_of_body(b)],
        );
        let d = bb.com() - ba.com();
        let len = d.norm();
        let closing = if len > 0.0 {
            (ba.v() - bb.v()).dot(&(d / len))
        } else {
            0.0
        };
        (closing, len - (ba.radius + bb.radius))
    }

    /// How members `i` and `j` (`a` and `b`) approach, or `None` when their swept spheres are
    /// apart (their travel cannot close the gap in the step) or, for shapes other than two
    /// centred balls, when the pair is rapier's as it is or parry finds no contact within
    /// reach.
    fn approach(&self, (i, j): (usize, usize), (a, b): (&Ball, &Ball)) -> Option<Approach> {
        let swept = &self.members.swept;
        let d = b.com() - a.com();
        let (reach, reach_swept) = (a.radius + b.radius, swept[i] + swept[j]);
        if d.norm_squared() > reach_swept * reach_swept {
            return None;
        }
        let len = d.norm();
        let travel = reach_swept - reach;
        let balls_only = a.shape.is_none() && b.shape.is_none();
        let (gap, closing, normal) = if balls_only {
            // Along the line of centres: a ball's spin does not move its surface along the
            // normal.
            let closing = if len > 0.0 {
                (a.v() - b.v()).dot(&(d / len))
            } else {
                0.0
            };
            let normal = if len > 0.0 { d / len } else { Vector3::zeros() };
            (len - reach, closing, normal)
        } else {
            self.shapes_approach(i, j, travel)?
        };
        Some(Approach {
            gap,
            closing,
            normal,
            reach,
            balls_only,
        })
    }

    /// The gap, closing speed and normal of members `i` and `j`, not both centred balls, at
    /// parry's contact within `travel` (plus what turning adds, and the margin); `None` when
    /// the pair is rapier's as it is or parry finds no contact within reach.
    ///
    /// A body rapier's solver holds against something else, or one within the resting gap
    /// of a ground at the step's start (where rapier's narrow phase may not hold the contact
    /// yet), cannot be moved alone through an impact, and out of rapier's solver the pair
    /// would be checked only at the step's end, where a fast body may have passed through:
    /// such a pair is rapier's. Out of line: two centred balls, the common pair, never ask it.
    #[inline(never)]
    fn shapes_approach(&self, i: usize, j: usize, travel: f64) -> Option<(f64, f64, Vector3<f64>)> {
        let (bodies, sets) = (self.bodies, self.inputs.sets);
        let (a, b) = (&self.members.balls[i], &self.members.balls[j]);
        if self.on_ground(i)
            || self.on_ground(j)
            || held_besides(a.body, &bodies[a.body], b.collider, sets)
            || held_besides(b.body, &bodies[b.body], a.collider, sets)
        {
            return None;
        }
        let dt = self.inputs.dt;
        let colliders = self.inputs.colliders;
        let ((ga, sa), (gb, sb)) = (
            geom_state(a, bodies, colliders),
            geom_state(b, bodies, colliders),
        );
        // A turning body can bring a point closer by its angular speed times its radius.
        let turn = |m: &Ball, s: &State| match m.shape {
            Some(_) => s.w.norm() * m.radius * dt,
            None => 0.0,
        };
        let turn = turn(a, &sa) + turn(b, &sb);
        let touch = body_contact(ga.get(), &sa, gb.get(), &sb, travel + turn + self.margin)?;
        // The closest points' closing speed, plus what a turn can add along the normal (the
        // spin about the normal adds nothing): a turning body's other corner may swing in
        // first. Without turning it is the closest points' speed.
        let n = touch.normal;
        let tilt = |m: &Ball, s: &State| match m.shape {
            Some(_) => (s.w - n * n.dot(&s.w)).norm() * m.radius,
            None => 0.0,
        };
        let closing = -touch.rate + tilt(a, &sa) + tilt(b, &sb);
        Some((touch.dist, closing, n))
    }

    /// Do two members `gap` apart (m) close it within the step at `closing` (m/s), their user
    /// forces adding `forces` (m/s^2)? Both fall alike under gravity.
    fn closes(&self, gap: f64, closing: f64, forces: f64) -> bool {
        let dt = self.inputs.dt;
        gap <= closing * dt + 0.5 * forces * dt * dt + self.margin
    }

    /// The closing speed of members `i` and `j` (`gap` apart, `closing` along `normal` at the
    /// step's start), raised, in the step's modes, to what it is after one of them bounces off
    /// a ground it flies onto in the step (its normal speed turned back,
    /// [`Self::grounded`]), where that could make the pair meet and the start's approach does
    /// not: the cluster moves both through the bounce. `Step` mode resolves pairs at the
    /// step's start, before any bounce. Only for a pair whose speeds could close the gap (a
    /// bounce keeps a body's speed at most), so that most pairs ask no ground.
    ///
    /// A member whose bounce keeps the pair's closing speed at most the resting speed
    /// ([`Self::bounce_may_lift`]) is not asked: the speed returned is then the exact one
    /// where that is above the resting speed, and at most the resting speed where the exact
    /// one is (a slow pair's speed is read for nothing else, [`Self::evaluate`]).
    fn closing_with_bounces(
        &self,
        ((i, a), (j, b)): ((usize, &Ball), (usize, &Ball)),
        (gap, closing, normal): (f64, f64, &Vector3<f64>),
        forces: f64,
    ) -> f64 {
        let resting_speed = self.inputs.policy.resting_speed;
        let (speed_a, speed_b) = (a.v().norm(), b.v().norm());
        let fastest = speed_a + speed_b;
        // Every test below is a comparison of numbers already at hand: evaluated whole
        // (`&`, `|`) rather than branch by branch, the pair's outcome is one branch.
        let may_turn = self.inputs.in_step
            & !rests_at(fastest, resting_speed)
            & self.closes(gap, fastest, forces);
        if !may_turn | (!rests_at(closing, resting_speed) & self.closes(gap, closing, forces)) {
            return closing;
        }
        let along = |va: Vector3<f64>, vb: Vector3<f64>| (va - vb).dot(normal);
        let base = along(a.v(), b.v());
        // A NaN closing speed (a non-finite spin of a shape's member) is replaced by any
        // bounce's in the fold below (`f64::max`), so every bounce is then asked.
        let asks =
            |speed: f64| closing.is_nan() || self.bounce_may_lift(speed, base, normal, fastest);
        let bounced_a = if asks(speed_a) {
            self.grounded(i).bounced.map(|va| along(va, b.v()))
        } else {
            None
        };
        let bounced_b = if asks(speed_b) {
            self.grounded(j).bounced.map(|vb| along(a.v(), vb))
        } else {
            None
        };
        [bounced_a, bounced_b]
            .into_iter()
            .flatten()
            .fold(closing, f64::max)
    }

    /// Is either member pressed, as a ground pair is: pushed by rapier's solver against
    /// something else in the last step (rapier's solver holds the pile)? Not by each other:
    /// their own contact does not press them together.
    fn pressed(&self, a: &Ball, b: &Ball) -> bool {
        let (bodies, sets, registry) = (self.bodies, self.inputs.sets, self.inputs.registry);
        pressed_besides(a.body, &bodies[a.body], Some(b.collider), sets, registry)
            || pressed_besides(b.body, &bodies[b.body], Some(a.collider), sets, registry)
    }

    /// In the step's modes, is either member part of a stack or a pile (rapier's solver pushed
    /// it last step against a third body along gravity's line)? rapier's solver pushes it in
    /// the step too: it cannot be moved alone through the impact, which rapier's solver is
    /// left to resolve with the pile's other contacts (out of it, the pair would be settled
    /// at the step's end, one pair at a time, pushing the pile's balls into each other).
    /// `Step` mode's impulse at the step's start leaves the pair in rapier's solver.
    fn stacked(&self, (i, j): (usize, usize), (a, b): (&Ball, &Ball)) -> bool {
        self.inputs.in_step
            && (self.member_stacked_besides(i, b.collider)
                || self.member_stacked_besides(j, a.collider))
    }

    /// `stacked_besides` of member `k` with `partner` left out. A member no contact stacks
    /// (the common case, asked once a step with `ColliderHandle::invalid()`, which names no
    /// collider, as the partner: no contact left out) is stacked besides no partner; only one
    /// that some contact stacks walks rapier's graph again for the partner.
    fn member_stacked_besides(&self, k: usize, partner: ColliderHandle) -> bool {
        let (bodies, sets, registry) = (self.bodies, self.inputs.sets, self.inputs.registry);
        let rb = &bodies[self.members.balls[k].body];
        let stacked_at_all = |partner| stacked_besides(rb, partner, sets, registry, &self.down);
        *self.stacks[k].get_or_init(|| stacked_at_all(ColliderHandle::invalid()))
            && stacked_at_all(partner)
    }

    /// The pair of members `i < j` with its role, or `None` when its bodies are of two
    /// dominance groups, when it cannot meet in the step, it is slow and rapier's resting
    /// contact as it is (unless `chain`: side by side with a body of an impact, it may pass
    /// the impact on), or it is hooked and rapier would not solve it or the user's filter
    /// refuses it. Reads only; the caller adds the pair.
    ///
    /// Most pairs asked are apart or slow and leave here; the rest are decided out of line
    /// ([`Self::role`]), so that the code every pair runs through stays small.
    pub(super) fn evaluate(&self, i: usize, j: usize, chain: bool) -> Option<PlannedPair> {
        let (a, b) = (&self.members.balls[i], &self.members.balls[j]);
        if !model_may_pair(a.dominance, b.dominance) {
            return None;
        }
        let approach = self.approach((i, j), (a, b))?;
        let forces = a.force_accel + b.force_accel;
        let start = (approach.gap, approach.closing, &approach.normal);
        // Exact where not slow (only whether it is slow is read of a slow pair's speed).
        let closing = self.closing_with_bounces(((i, a), (j, b)), start, forces);
        let slow = rests_at(closing, self.inputs.policy.resting_speed);
        // Slow, and with every restitution below 1: rapier's bounce of it (`e` times the
        // approach) stays below the pressed speed, so `rapier_bounces` in `role` is false and
        // the pair is not planned; it leaves before its colliders and contacts are read.
        if slow && !chain && !self.members.any_elastic {
            return None;
        }
        self.role((i, j), (a, b), &approach, (closing, slow, forces), chain)
    }

    /// [`Self::evaluate`] for a pair that may meet in the step (`approach`) and is not slow,
    /// or may be rapier's bounce or a chain's: its closing speed with bounces `closing`
    /// (m/s), whether that is `slow`, its user forces `forces` (m/s^2).
    #[inline(never)]
    fn role(
        &self,
        (i, j): (usize, usize),
        (a, b): (&Ball, &Ball),
        approach: &Approach,
        (closing, slow, forces): (f64, bool, f64),
        chain: bool,
    ) -> Option<PlannedPair> {
        let (inputs, policy) = (self.inputs, self.inputs.policy);
        let (gap, normal) = (approach.gap, approach.normal);
        let closes_at = |closing: f64| self.closes(gap, closing, forces);
        // rapier's own bounce of the pair is its approach at the step's start.
        let approaching = approach.closing;
        let (ca, cb) = (&inputs.colliders[a.collider], &inputs.colliders[b.collider]);
        // Asked by both rapier's bounce and the pair's rest below: a walk of rapier's graph.
        let held_last_step = OnceCell::new();
        let held_pair = || *held_last_step.get_or_init(|| self.held(a, b));
        // rapier's own bounce of a pair it solves: `e` times the approach, the step the
        // contact is new (no impulse the step before), or every step at `e >= 1`. Where that
        // cannot rise above the resting gap (below the pressed speed) it is rapier's resting
        // noise, and the pair keeps rapier's restitution.
        let rapier_bounces = approaching > 0.0 && closes_at(approaching) && {
            let e = material(ca, cb, None).restitution;
            e >= 1.0 || e * approaching > policy.pressed_speed && !held_pair()
        };
        // Slower than the resting speed it is no impact: rapier's resting contact, left as it
        // is where rapier's bounce of it is noise, and not planned.
        if slow && !chain && !rapier_bounces {
            return None;
        }
        let key = pair_key(a.collider, b.collider);
        // Held at rest last step: planned `Resting`, or (slow pairs are not planned) touching
        // in rapier's solver; or one lying on the other, which lies on a ground (out of
        // rapier's solver, a cluster leaves such a pair touching, approaching by up to what
        // gravity adds over the rest of the step).
        let was_resting = || {
            inputs.prev.get(&key) == Some(&Role::Resting)
                || held_pair()
                || self.lies_on_grounded((i, j), gap, &normal)
        };
        let pressed = || self.pressed(a, b);
        // An impact: approaching faster than the resting speed, closing the gap within the
        // step (both fall alike; a user force adds its acceleration), not resting or pressed,
        // and neither body in a stack. Anything else is rapier's (`Resting`), with e = 0
        // where rapier would bounce it.
        let impact = !slow
            && closes_at(closing)
            && !policy.rests(gap, closing, was_resting(), pressed)
            && !self.stacked((i, j), (a, b));
        let hooked = impact || rapier_bounces;
        // rapier's filtering and the user's decide a pair the plugin takes out of rapier's
        // solver or changes: an impact, a pair it zeroes (one a chain takes is asked there).
        // A resting pair it leaves as it is stays rapier's whatever they say (the hooks ask
        // the user's filter of it, `hooks/mod.rs`).
        if hooked && self.refused(key, a.body, b.body) {
            return None;
        }
        Some(PlannedPair {
            a: a.body,
            b: b.body,
            key,
            balls: approach.balls_only,
            reach: approach.reach,
            normal,
            offset: b.com() - a.com(),
            relative_v: b.v() - a.v(),
            role: if impact { Role::Impact } else { Role::Resting },
            hooked,
        })
    }
}

/// The outward normals of `grounds` when there are at most [`STILL_PLANES_MAX`] and each is
/// a half-space that neither moves nor turns in the step (its points' velocity is zero),
/// `None` otherwise.
fn still_planes(grounds: &[GroundMotion]) -> Option<Vec<Vector3<f64>>> {
    if grounds.len() > STILL_PLANES_MAX {
        return None;
    }
    let still = Vector3::zeros();
    grounds
        .iter()
        .map(|g| match g.plane {
            Some((n, _)) if g.v == still && g.w == still => Some(vec_to_na(n)),
            _ => None,
        })
        .collect()
}

/// The plan as it grows, and the sleeping bodies it reaches (to wake once planning is done).
#[derive(Default)]
pub(super) struct Planned {
    pub plan: PairPlan,
    pub woken: Vec<RigidBodyHandle>,
}

impl Planned {
    /// Makes `body` a member of the plan's `Impact` pairs; the first time, a sleeping body
    /// is listed to be woken. Reads the bodies only.
    pub(super) fn join(&mut self, bodies: &RigidBodySet, body: RigidBodyHandle) {
        if self.plan.members.insert(body, ()) && bodies[body].is_sleeping() {
            self.woken.push(body);
        }
    }

    /// Adds a pair, with its role, after every pair added before (the plan's order is the
    /// order pairs are decided); an `Impact` pair's bodies join.
    pub(super) fn add(&mut self, bodies: &RigidBodySet, pair: PlannedPair) {
        if pair.role == Role::Impact {
            self.join(bodies, pair.a);
            self.join(bodies, pair.b);
        }
        self.plan.roles.insert(pair.key, pair.role);
        self.plan.pairs.push(pair);
    }
}
