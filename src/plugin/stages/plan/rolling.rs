//! A ball resting on a plane ground: whether the closed form rolls it (`Role::Rolling`),
//! rapier's contact holds it at rest on a slope, or something besides its grounds can reach
//! it (rapier's resting contact), and the grounds that make up the plane under its path.

use super::Planner;
use super::body::{BodyNear, BodyPlan, BodyReads};
use super::role::Pair;
use crate::motion::{Rolling, State};
use crate::parry::shape::Ball;
use crate::plugin::bridge::resolve::{Inertia, Site, released};
use crate::plugin::policy::{HELD_SPEED, IN_PLANE_TOLERANCE, ROLLING_MIN_SLIP, Role};
use crate::plugin::policy::{LEVEL_TOLERANCE, on_plane_through_rounding};
use crate::plugin::queries::geometry::{
    BodyPart, COPLANAR_TOLERANCE, GroundGeom, PairContact, PlaneNear, contact_checked,
    earliest_touch, flat_relative, one_plane_under, plane_piece_of,
};
use crate::plugin::queries::observe::{Scene, pressed_besides};
use crate::plugin::queries::reach::{OwnCollider, OwnMotion, within_reach_of_other};
use crate::plugin::state::memory::LastStep;
use crate::plugin::state::small_list::SmallList;
use crate::plugin::state::step::{FirstHold, StepData};
use crate::rapier::math::Vector;
use crate::rapier::prelude::{ActiveHooks, Collider, ColliderHandle, PhysicsHooks};
use nalgebra::Vector3;

/// What the closed form makes of a ball resting on a plane ground (`Planner::rolling_of`).
pub(crate) enum OnPlane {
    /// It moves (`Role::Rolling`), on the plane of these grounds (`pieces`). `on_one_face`:
    /// on level ground, over one flat face of a still ground for the whole step, the only
    /// ground near it (see `Candidate::rolls_on_one_face`).
    Rolls {
        motion: Rolling,
        pieces: SmallList<ColliderHandle>,
        on_one_face: bool,
    },
    /// It stays at rest on a slope of this tilt (`Rolling::holding_tilt`): rapier's resting
    /// contact (`Role::Resting`) with these grounds, their normal force acting downhill of the
    /// contact point so that rapier holds the ball still and sleeps it. (The closed form
    /// writing the rest pose back after each step would move the collider, and rapier wakes
    /// the body of every collider moved by hand.)
    Held(Vector3<f64>, SmallList<ColliderHandle>),
    /// Something besides its grounds can touch it within the step
    /// (`reach::within_reach_of_other`): rapier's resting contact, as any resting pair. Told
    /// apart from `None` only for a ball the closed form rolled last step (its release).
    Reached,
}

/// A ball (the body's only collider, centred) resting on the ground `gg` (the `gi`-th of the
/// step's grounds) with normal `n`, as `Planner::rolling_of` asks it: `body` the body near its
/// grounds (its rapier body, whether it is a ball of an impact between bodies or has a joint),
/// `on_ground` its state put on the ground (touching it, no normal speed), `colliders` the
/// pair's two colliders and `user` their user hook flags, `last` what the plugin kept of the
/// last step. It borrows rather than copies, and its other grounds are gone through where
/// asked rather than gathered: most balls resting on a ground are refused at once
/// (`Planner::slide_of`), and most of the others are alone on it.
struct BallOnGround<'q, 'c> {
    body: &'q BodyNear<'q, 'c>,
    gi: usize,
    part: &'q BodyPart<'c>,
    gg: &'q GroundGeom<'c>,
    colliders: (&'c Collider, &'c Collider),
    user: ActiveHooks,
    last: &'q LastStep,
    n: Vector3<f64>,
    on_ground: &'q State,
}

impl<'q, 'c> BallOnGround<'q, 'c> {
    /// The other grounds near it, in the step's grounds' order: most often a ball is alone
    /// on one ground, and there are none.
    fn others(&self) -> impl Iterator<Item = &'q GroundGeom<'c>> + use<'q, 'c> {
        let gi = self.gi;
        let grounds: &'q [(usize, GroundGeom<'c>)] = &self.body.grounds;
        grounds
            .iter()
            .filter(move |(other, _)| *other != gi)
            .map(|(_, g)| g)
    }

    /// Is it near no ground but its own? Asked of every rolling ball, so kept inline.
    #[inline]
    fn alone(&self) -> bool {
        self.body.grounds.iter().all(|(other, _)| *other == self.gi)
    }

    /// Did the closed form roll it on its ground last step (`Role::Rolling`)?
    fn rolled(&self) -> bool {
        self.last.roles.get(&(self.part.handle, self.gg.handle)) == Some(&Role::Rolling)
    }

    /// Was its pair with its ground rapier's resting contact last step, and none of its pairs
    /// with the other grounds near it the closed form's rolling (a roll that ends on another
    /// piece of the plane is the closed form's to its stop)?
    fn rested(&self) -> bool {
        let role = |g: &GroundGeom| self.last.roles.get(&(self.part.handle, g.handle));
        role(self.gg) == Some(&Role::Resting)
            && self.others().all(|g| role(g) != Some(&Role::Rolling))
    }
}

/// The ball on its ground with the terms of their contact, once the cheap refusals passed
/// (`Planner::slide_of`).
struct Slide<'b, 'q, 'c> {
    ball: &'b BallOnGround<'q, 'c>,
    /// The ball's shape, as its collider has it.
    shape: &'c Ball,
    /// The ball's radius, skins added (m).
    radius: f64,
    /// The acceleration along `n` (negative: towards the ground).
    an: f64,
    /// Its acceleration is along `n` (level ground).
    level: bool,
    /// The ground's velocity (along its plane, without turning).
    u: Vector3<f64>,
    /// The ball's velocity relative to the ground.
    v: Vector3<f64>,
    /// The contact point's slip velocity.
    slip: Vector3<f64>,
    /// The config's rolling resistance and spinning friction.
    default: (f64, f64),
    rolling_resistance: f64,
    spinning_friction: f64,
    friction: f64,
    /// From the ball's centre to the plane of the ground's face (skin included).
    to_plane: Vector3<f64>,
}

impl Slide<'_, '_, '_> {
    /// The closed-form motion of the ball on its ground, `None` for an inertia the closed
    /// form does not take (`Inertia::ball_ratio`).
    fn motion(&self) -> Option<Rolling> {
        let ball = self.ball;
        let inertia_ratio = Inertia::of(ball.body.rb).ball_ratio(self.radius)?;
        Some(Rolling {
            normal: ball.n,
            radius: self.radius,
            inertia_ratio,
            friction: self.friction,
            rolling_resistance: self.rolling_resistance,
            spinning_friction: self.spinning_friction,
            accel: ball.body.flight.accel,
            ground_velocity: self.u,
        })
    }

    /// Is the ball rapier's at rest on level ground (`motion` its closed form, in a step of
    /// `dt`)? At rest as the closed form holds it (moving by no more than its rounding), or
    /// at rest in rapier's contact last step and now moving slower than the held speed and
    /// than the closed form would brake away within this step (rapier's solver's rounding,
    /// about 1e-7 m/s on a tile in `f32`): rapier sleeps it. Taken back, the ball would be
    /// stopped each other step and written, and never sleep. rapier has no rolling
    /// resistance: it lets such a ball drift until it sleeps it, at most the held speed for
    /// 0.5 s at its defaults. Only the rolling resistance and the spinning friction brake a
    /// ball on level ground. Not a ball of an impact between bodies (its cluster moves it).
    fn rests_level(&self, motion: &Rolling, dt: f64) -> bool {
        let ball = self.ball;
        let (n, on_ground) = (ball.n, ball.on_ground);
        let brakes = self.rolling_resistance > 0.0 || self.spinning_friction > 0.0;
        let turning = (on_ground.w - n * on_ground.w.dot(&n)).norm() * self.radius;
        let held = self.v.norm() <= HELD_SPEED && turning <= HELD_SPEED;
        self.level
            && !ball.body.member
            && brakes
            && held
            && (motion.at_rest(on_ground) || ball.rested() && motion.comes_to_rest(on_ground, dt))
    }
}

impl<H: PhysicsHooks> Planner<'_, H> {
    /// A pair rapier would hold at rest, of a ball alone on a ground within the resting gap
    /// (`(dist, n, point)` its contact): the closed form's role for it (`rolling_of`).
    /// Returns `Role::Rolling` when it rolls (its rolling and plane in `plan`, its state put
    /// on the ground), else `Role::Resting`: held at rest on a slope (its holds in
    /// `step.holds`, `step.first_holds` on its first step held), or reached by something else
    /// (the event of its release if it rolled last step), or not the closed form's. Reads
    /// rapier's contact graph (a sleeping body's pairs included: a ball of a pile is not
    /// taken); a body new to the plugin is taken, and the settle stage puts it back on the
    /// ground if something touches it in the step.
    pub(super) fn rest_on_ground(
        &mut self,
        reads: BodyReads,
        plan: &mut BodyPlan,
        pair: Pair,
        (dist, n, point): PairContact,
        step: &mut StepData,
    ) -> Role {
        let BodyReads { body, scene, last } = reads;
        let Pair {
            k,
            part,
            gg,
            key,
            colliders,
            user,
            ..
        } = pair;
        let (gi, _) = &body.grounds[k];
        let state = &plan.state;
        let on_ground = State {
            com: state.com - n * dist,
            v: state.v - n * n.dot(&state.v),
            ..*state
        };
        let ball = BallOnGround {
            body,
            gi: *gi,
            part,
            gg,
            colliders,
            user,
            last,
            n,
            on_ground: &on_ground,
        };
        match self.rolling_of(scene, &ball, step) {
            Some(OnPlane::Rolls {
                motion,
                pieces,
                on_one_face,
            }) => {
                plan.rolling_pieces = Some(pieces);
                plan.rolling = Some((*gi, motion));
                plan.rolls_on_one_face = on_one_face;
                plan.state = on_ground;
                return Role::Rolling;
            }
            Some(OnPlane::Held(tilt, pieces)) => {
                plan.held = true;
                if !self.prev_holds.contains(&key) {
                    step.first_holds.push(FirstHold {
                        body: body.handle,
                        collider: part.handle,
                        ground: gg.handle,
                        start: State {
                            v: Vector3::zeros(),
                            w: Vector3::zeros(),
                            ..on_ground
                        },
                        local_com: body.local_com,
                        normal: n,
                        radius: body.geom.radius,
                    });
                }
                for piece in pieces.iter() {
                    step.holds.insert((part.handle, *piece), tilt);
                }
            }
            // Rolled in closed form last step: the event says it is rapier's from here.
            Some(OnPlane::Reached) if ball.rolled() => {
                let site = Site {
                    body: body.handle,
                    collider: part.handle,
                    ground: gg.handle,
                    body2: None,
                    normal: n,
                    point,
                };
                let inertia = Inertia::of(body.rb);
                self.reports
                    .events
                    .push(released(&site, &inertia, &plan.state, 0.0));
                plan.released = Some(*gi);
            }
            Some(OnPlane::Reached) | None => {}
        }
        Role::Resting
    }

    /// The closed-form motion of the `ball` sliding on its ground, when it applies: a ground
    /// at rest (or moving along its plane without turning, in its frame) whose one flat face
    /// (a half-space, or a cuboid's face the ball stays over: `flat_relative`) is all it can
    /// meet in the step, or with `others` near too, the faces of those in its plane under the
    /// ball's path (`one_plane_under`: a flush seam between tiles) up to where it first
    /// touches one of the others (a crease, a wall: not touching it at the start), gravity
    /// (and any constant force) along `-n`, no damping, torque or contact modification by
    /// the user, isotropic inertia with no locked axis, nothing besides its grounds able to
    /// touch it within the step (`reach::within_reach_of_other`; else `OnPlane::Reached`,
    /// asked of a ball at rest on level ground only if the closed form rolled it last step),
    /// and a ball that slips (faster than `ROLLING_MIN_SLIP`) or rolls faster than the
    /// resting speed (slower, it is rapier's, which brings it to rest and to sleep). Or, at
    /// rest on a still slope that holds it (`OnPlane::Held`), rapier's contact holding it.
    /// Reads only, besides the reach test's memo (`Planner::neighbours`).
    fn rolling_of(
        &mut self,
        scene: &Scene,
        ball: &BallOnGround,
        step: &StepData,
    ) -> Option<OnPlane> {
        let BallOnGround {
            part,
            gg,
            on_ground,
            ..
        } = *ball;
        let member = ball.body.member;
        let slide = self.slide_of(ball, step)?;
        let Slide {
            radius, level, v, ..
        } = slide;
        let motion = slide.motion();
        // A ball at rest on level ground is rapier's whatever can reach it, so that is asked
        // first: the reach test then only decides whether a ball the closed form rolled last
        // step is released (its event). In a crowd with rolling resistance most balls come to
        // rest beside others, and the reach test is the costlier of the two.
        if motion
            .as_ref()
            .is_some_and(|m| slide.rests_level(m, step.dt))
        {
            if ball.rolled() && self.reached_by_other(scene, &slide, step) {
                return Some(OnPlane::Reached);
            }
            return None;
        }
        if self.reached(scene, &slide, member, step) {
            return Some(OnPlane::Reached);
        }
        let motion = motion?;
        // The ground's one flat face under the ball for the whole step (a half-space, or a
        // cuboid's face the ball stays well inside of), or the faces in one plane under its
        // contact point's whole path: a mesh's or heightfield's other triangles, or a
        // cuboid's edge, could be met inside the step, out of rapier's solver. On a moving
        // ground: its one flat face, in its frame.
        let travel = (v.norm() + on_ground.w.norm() * radius) * step.dt;
        let inside = ball.alone() && flat_relative(part, gg, on_ground, travel, radius);
        // At rest on a slope that holds it (its closed-form stop, or placed there): rapier's
        // contact holds it, nothing else touching it.
        if !level && !member {
            let at_rest = v.norm() <= HELD_SPEED && on_ground.w.norm() * radius <= HELD_SPEED;
            if let Some(tilt) = motion.holding_tilt().filter(|_| at_rest) {
                return self.held(scene, &slide, tilt, step);
            }
        }
        // On level ground the closed form reaches every state unless the rolling resistance
        // needs more friction than `mu N` (`mu_r / (1 + k) > mu`): then it is asked.
        if level
            && inside
            && (slide.rolling_resistance <= slide.friction
                || motion.advance_checked(on_ground, step.dt).is_some())
        {
            return Some(OnPlane::Rolls {
                motion,
                pieces: SmallList::One(gg.handle),
                on_one_face: ends_on_its_face(part, gg, on_ground, radius),
            });
        }
        let plane = rolling_plane(&slide, step.dt);
        // Only where the closed form reaches (on a slope, the band where a ball can neither
        // roll nor slide is not).
        let end = motion.advance_checked(on_ground, step.dt)?;
        let piece_handles = if inside {
            SmallList::One(gg.handle)
        } else {
            self.pieces_under(scene, &slide, &motion, &plane, &end, step.dt)?
        };
        Some(OnPlane::Rolls {
            motion,
            pieces: piece_handles,
            on_one_face: false,
        })
    }

    /// The terms of the ball's contact with its ground, or `None` where the closed form does
    /// not take it (the cheap refusals, before anything else is asked): a ground that turns
    /// or moves off its plane, no pull towards the ground, damping or a user torque, a ball
    /// rapier brings to rest (slow, no resistance, still ground; a ball of an impact between
    /// bodies is taken at rest too), contacts the user modifies, or a friction that is not a
    /// finite non-negative number. Reads only.
    fn slide_of<'b, 'q, 'c>(
        &self,
        ball: &'b BallOnGround<'q, 'c>,
        step: &StepData,
    ) -> Option<Slide<'b, 'q, 'c>> {
        let BallOnGround {
            body,
            part,
            gg,
            ref n,
            on_ground,
            ..
        } = *ball;
        let BodyNear {
            handle,
            rb,
            member,
            flight,
            ..
        } = *body;
        let b = part.shape.as_ball()?;
        let radius = crate::plugin::bridge::convert::to_f64(b.radius) + part.skin + gg.skin;
        let an = flight.accel.dot(n);
        let level = (flight.accel - n * an).norm() <= LEVEL_TOLERANCE * flight.accel.norm();
        let user_modifies = ball.user.contains(ActiveHooks::MODIFY_SOLVER_CONTACTS);
        let plain = flight.linear_damping == 0.0
            && flight.angular_damping == 0.0
            && rb.user_torque() == Vector::ZERO;
        // A ground moving at constant velocity along its plane without turning (a conveyor):
        // relative to it the ball moves as on a still one. Any other moving ground is
        // rapier's.
        let u = gg.motion.v;
        if gg.motion.w != Vector3::zeros() || u.dot(n).abs() > IN_PLANE_TOLERANCE * u.norm() {
            return None;
        }
        let v = on_ground.v - u;
        let slip = v - radius * on_ground.w.cross(n);
        let default = (
            self.config.rolling_resistance,
            self.config.spinning_friction,
        );
        let (rolling_resistance, spinning_friction) =
            self.registry.rolling_of(handle, gg.handle, default);
        // Without rolling resistance or spinning friction, a ball rolling slower than the
        // resting speed is rapier's, which brings it to rest and to sleep. With them, rapier
        // would roll it on (it has neither): the closed form takes it to a stop; at rest on
        // level ground it is rapier's again, and sleeps. On a slope that holds it, rapier's
        // contact holds it too, its normal force moved downhill (`OnPlane::Held`), and sleeps
        // it.
        let slow = slip.norm() <= ROLLING_MIN_SLIP && v.norm() <= step.policy.resting_speed;
        let resisted = rolling_resistance > 0.0 && (v.norm() > 0.0 || !level)
            || spinning_friction > 0.0 && on_ground.w.dot(n) != 0.0;
        // Any slope: the closed form says where it reaches (along the fall line). A ball of an
        // impact between bodies is taken at rest too, and beside the other ball: the
        // reconstruct stage moves the pair together (and if anything else touched it in the
        // step, hands it back to rapier's end state). So is one at rest on a moving ground,
        // which cannot sleep: rapier's resting contact there lets it sink into the ground and
        // lag behind it, where the closed form carries it with the ground exactly.
        let carried = u != Vector3::zeros();
        if !(an < 0.0 && plain) || !member && slow && !resisted && !carried || user_modifies {
            return None;
        }
        let (body_co, ground_co) = ball.colliders;
        let friction = self
            .registry
            .friction_between(body_co, ground_co, gg.handle);
        if !(friction.is_finite() && friction >= 0.0) {
            return None;
        }
        Some(Slide {
            ball,
            shape: b,
            radius,
            an,
            level,
            u,
            v,
            slip,
            default,
            rolling_resistance,
            spinning_friction,
            friction,
            to_plane: n * (radius - gg.skin),
        })
    }

    /// Is the ball reached by something besides its grounds, so that it is rapier's? A ball of
    /// an impact between bodies (`member`) meets its partners in its cluster, however close;
    /// but one that rapier's solver pushed last step through a contact with another body (a
    /// ball lying on it) would be pushed again, and rolled out of rapier's solver it would
    /// sink under that body. Any other ball: [`Self::reached_by_other`].
    fn reached(&mut self, scene: &Scene, slide: &Slide, member: bool, step: &StepData) -> bool {
        if member {
            let body = slide.ball.body;
            pressed_besides(body.handle, body.rb, None, scene.sets, scene.registry)
        } else {
            self.reached_by_other(scene, slide, step)
        }
    }

    /// Can something besides its grounds touch the ball within the step
    /// (`reach::within_reach_of_other`)? Asked after the cheap refusals (most resting balls
    /// are at rest). Its ground holds it (`|an|` along `n`) and pulls it along the plane by at
    /// most `mu |an|` (slip) or `mu_r |an|` (rolling resistance). Reads rapier's contact
    /// graph, and keeps what it read of each neighbouring ball for the rest of the plan.
    fn reached_by_other(&mut self, scene: &Scene, slide: &Slide, step: &StepData) -> bool {
        let ball = slide.ball;
        let (an, slip, v) = (slide.an, slide.slip, slide.v);
        let own = OwnMotion {
            v: ball.on_ground.v,
            accel: ball.body.flight.accel,
            normal: ball.n,
            pressed: -an,
            dragged: -an * slide.friction.max(slide.rolling_resistance),
            drag_along: slide.level.then(|| {
                [
                    slip.try_normalize(0.0).unwrap_or_else(Vector3::zeros),
                    v.try_normalize(0.0).unwrap_or_else(Vector3::zeros),
                ]
            }),
            gravity: step.gravity,
            dt: step.dt,
        };
        let ball_collider = OwnCollider {
            handle: ball.part.handle,
            collider: ball.colliders.0,
            ball: slide.shape,
        };
        let body = ball.body;
        within_reach_of_other(
            body.rb,
            ball_collider,
            body.jointed,
            &own,
            scene,
            self.neighbours,
        )
    }

    /// At rest on a slope of `tilt` that holds it: `OnPlane::Held` with the grounds holding
    /// it, if its own ground is one flat face under it or one plane near it (not a crease
    /// inside a mesh) and the others near are pieces of that plane (`held_on`); else `None`.
    /// Reads only.
    #[inline(never)]
    fn held(
        &self,
        scene: &Scene,
        slide: &Slide,
        tilt: Vector3<f64>,
        step: &StepData,
    ) -> Option<OnPlane> {
        let BallOnGround {
            part,
            gg,
            n,
            on_ground,
            ..
        } = *slide.ball;
        let radius = slide.radius;
        let plane = PlaneNear {
            n,
            height: n.dot(&(on_ground.com - slide.to_plane)),
            centre: on_ground.com,
            reach: radius + step.policy.resting_gap,
        };
        let one_face =
            flat_relative(part, gg, on_ground, 0.0, radius) || plane_piece_of(gg, &plane);
        one_face
            .then(|| self.held_on(scene, slide, &plane, step))
            .flatten()
            .map(|pieces| OnPlane::Held(tilt, pieces))
    }

    /// The grounds holding the ball at rest on `plane`, the plane of its ground, that ground
    /// first: the others within the resting gap of it must be pieces of that plane with the
    /// same coefficients (a flush seam: its friction and its ground's rolling ones), or it is
    /// not held (a ball resting in a crease is rapier's). Reads only.
    #[inline(never)]
    fn held_on(
        &self,
        scene: &Scene,
        slide: &Slide,
        plane: &PlaneNear,
        step: &StepData,
    ) -> Option<SmallList<ColliderHandle>> {
        let ball = slide.ball;
        let (handle, part, gg) = (ball.body.handle, ball.part, ball.gg);
        let (colliders, friction) = (scene.colliders, slide.friction);
        let mut pieces = SmallList::One(gg.handle);
        let default = (
            self.config.rolling_resistance,
            self.config.spinning_friction,
        );
        for og in ball.others() {
            let gap = step.policy.resting_gap;
            if matches!(
                contact_checked(part, og, ball.on_ground, 0.0, gap),
                Ok(None)
            ) {
                continue;
            }
            let same = self.registry.friction_of(colliders, part.handle, og.handle) == friction
                && self.registry.rolling_of(handle, og.handle, default)
                    == self.registry.rolling_of(handle, gg.handle, default)
                && !self
                    .flags
                    .recorded_user_flags(colliders, og.handle)
                    .contains(ActiveHooks::MODIFY_SOLVER_CONTACTS);
            if !same || !plane_piece_of(og, plane) {
                return None;
            }
            pieces.push(og.handle);
        }
        Some(pieces)
    }

    /// The grounds of `plane` under the ball's rolling `motion` from its start to `end` (not
    /// over one flat face of its own ground): its ground and the others near that are pieces
    /// of the plane with the same coefficients; the rest are obstacles, which must not touch
    /// it at the start (a ball resting in a crease is rapier's). The pieces must cover its
    /// contact point's path (`one_plane_under`), or at least up to where it first touches an
    /// obstacle (rolling down into a crease, it touches the level ground while still on the
    /// slope: the reconstruct stage's search, with the same samples, finds the touch).
    /// `None` where that fails. Reads only.
    #[inline(never)]
    fn pieces_under(
        &self,
        scene: &Scene,
        slide: &Slide,
        motion: &Rolling,
        plane: &PlaneNear,
        end: &State,
        dt: f64,
    ) -> Option<SmallList<ColliderHandle>> {
        let ball = slide.ball;
        let (handle, part, gg, on_ground) = (ball.body.handle, ball.part, ball.gg, ball.on_ground);
        let colliders = scene.colliders;
        let (to_plane, friction, default) = (slide.to_plane, slide.friction, slide.default);
        // Its path's bow from the chord is below (|a_t| + mu g_n) dt^2 / 8. On level ground
        // the slip keeps its direction until it is gone, within tau <= |slip| / (mu g_n), and
        // the ball then rolls straight on: its path leaves the line of its last heading by at
        // most mu g_n tau^2 / 2 <= |slip|^2 / (2 mu g_n), and a ball rolling without slip
        // (slowed only along its heading) keeps to its chord.
        let (p, q) = (on_ground.com - to_plane, end.com - to_plane);
        let mut bow = accel_bound(slide) * dt * dt / 8.0;
        let grip = -slide.friction * slide.an;
        if slide.level && grip > 0.0 {
            bow = bow.min(slide.slip.norm_squared() / (2.0 * grip));
        }
        // The others are the plane's pieces, or grounds it may roll into, which must not
        // touch it yet. One it has just left (a slope behind the crease) may be nearer than
        // the resting gap: the search along the rolling finds whether it comes back. A piece
        // rolls the ball with this ground's coefficients: one of other materials, or whose
        // contacts the user modifies, is an obstacle (touching it, the ball is rapier's).
        let same = |g: &GroundGeom| {
            let user = self.flags.recorded_user_flags(colliders, g.handle);
            self.registry.friction_of(colliders, part.handle, g.handle) == friction
                && self.registry.rolling_of(handle, g.handle, default)
                    == (slide.rolling_resistance, slide.spinning_friction)
                && !user.contains(ActiveHooks::MODIFY_SOLVER_CONTACTS)
        };
        let (pieces, obstacles): (Vec<&GroundGeom>, Vec<&GroundGeom>) = std::iter::once(gg)
            .chain(ball.others())
            .partition(|g| (g.handle == gg.handle || same(g)) && plane_piece_of(g, plane));
        let touching = |s: &State, t: f64| {
            obstacles
                .iter()
                .any(|og| !matches!(contact_checked(part, og, s, t, 0.0), Ok(None)))
        };
        if touching(on_ground, 0.0) {
            return None;
        }
        let piece_handles = pieces.iter().map(|g| g.handle).collect();
        if !one_plane_under(&pieces, plane, &p, &q, bow + COPLANAR_TOLERANCE) {
            // Its contact point leaves the plane: the plane need only reach as far as its
            // first touch of an obstacle.
            let t = earliest_touch(dt, |t| touching(&motion.advance(on_ground, t), t))?;
            let q = motion.advance(on_ground, t).com - to_plane;
            let bow = bow * (t / dt).powi(2);
            if !one_plane_under(&pieces, plane, &p, &q, bow + COPLANAR_TOLERANCE) {
                return None;
            }
        }
        Some(piece_handles)
    }
}

/// The acceleration along the ground is at most gravity's along it and the friction:
/// `|a_t| - mu a_n` (m/s^2). Pure.
fn accel_bound(slide: &Slide) -> f64 {
    let ball = slide.ball;
    let at = ball.body.flight.accel - ball.n * slide.an;
    at.norm() - slide.friction * slide.an
}

/// Does a ball of radius `radius` rolling on level ground over one flat face of `gg` for its
/// whole travel (`flat_relative`, from `on_ground`) end the step touching that face to
/// `on_plane`'s measure, so that no query need confirm it (`Candidate::rolls_on_one_face`)?
/// Its centre moves in the plane, no farther than `flat_relative`'s bound: the rolling
/// resistance and spinning friction only slow it, and while it slides its speed stays between
/// `|v0|` and `|v0 + k r w0 x n| / (1 + k)`, both at most `|v0| + r |w0|`. So it does where
/// the ground stays put, its collider sits exactly at its centre (one within
/// `CENTRED_TOLERANCE` turns its centre up to twice that off the plane) and its coordinates
/// round finely enough. Pure.
fn ends_on_its_face(part: &BodyPart, gg: &GroundGeom, on_ground: &State, radius: f64) -> bool {
    gg.motion.is_still()
        && part.local.translation.vector == Vector3::zeros()
        && on_plane_through_rounding(&on_ground.com, radius)
}

/// The plane under the rolling ball and how far a point of it can get in the step `dt`: its
/// radius, its travel `|v| dt + (|a_t| - mu a_n) dt^2 / 2`, and `COPLANAR_TOLERANCE`. Pure.
fn rolling_plane(slide: &Slide, dt: f64) -> PlaneNear {
    let BallOnGround { n, on_ground, .. } = *slide.ball;
    PlaneNear {
        n,
        height: n.dot(&(on_ground.com - slide.to_plane)),
        centre: on_ground.com,
        reach: slide.radius
            + on_ground.v.norm() * dt
            + accel_bound(slide) * dt * dt / 2.0
            + COPLANAR_TOLERANCE,
    }
}
