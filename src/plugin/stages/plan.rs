//! Plan: what the step decides for each body and pair before rapier's step, and the data it
//! carries to the stages after it.
//!
//! Contract: [`Planner::plan_body`] takes one awake managed body that may reach a ground and
//! gives each of its pairs with the grounds near it a role (`Role`, decided by
//! `crate::plugin::policy::Policy`: rapier's filtering first, then resting, rolling or impact), and
//! the body a [`Candidate`] (its start state, flight, and which grounds may reach it) for the
//! stages after rapier's step. In `Step` mode it also applies the impulses of the contacts
//! that close in the step, the only write of this stage, each with its event. It reads rapier
//! and the registry and calls the user's filter where the colliders ask for it; [`StepData`]
//! carries the step's thresholds, roles and candidates.

use crate::plugin::bridge::convert::{to_f64, vec_from_na};
use crate::plugin::config::{ImpactConfig, TimingMode};
use crate::plugin::events::{ImpactEvent, ImpactTiming};
use crate::plugin::hooks::flags::HookFlags;
use crate::plugin::queries::filter;
use crate::plugin::queries::geometry::{
    BodyGeom, BodyPart, COPLANAR_TOLERANCE, GroundGeom, PairContact, PlaneNear, Sweep,
    cannot_close, contact_checked, earliest_touch, flat_relative, landing_point, one_plane_under,
    plane_piece_of,
};
use crate::plugin::stages::commit::write_state;
use crate::plugin::state::handles::{HandleMap, HandleSet};
use crate::plugin::state::memory::Shadow;
use crate::plugin::state::small_list::SmallList;
use crate::plugin::state::step::{Candidate, FirstHold, StepData};

use crate::motion::{Flight, Rolling, State};
use crate::plugin::bridge::resolve::{ImpactInput, Inertia, Site, released, resolve};
use crate::plugin::policy::{HELD_SPEED, IN_PLANE_TOLERANCE, ROLLING_MIN_SLIP, Role};
use crate::plugin::queries::observe::{
    OwnMotion, Sets, body_geom, centred_ball, ground_geom, snapshot, touched_besides_grounds,
    within_reach_of_other,
};
use crate::plugin::state::handles::PairKey;
use crate::plugin::state::registry::Registry;
use crate::rapier::math::Vector;
use crate::rapier::parry::bounding_volume::Aabb;
use crate::rapier::prelude::{
    ActiveHooks, ColliderHandle, ColliderSet, PhysicsHooks, RigidBodyHandle, RigidBodySet,
};
use nalgebra::Vector3;

/// What the closed form makes of a ball resting on a plane ground (`Planner::rolling_of`).
pub(crate) enum OnPlane {
    /// It moves (`Role::Rolling`), on the plane of these grounds.
    Rolls(Rolling, SmallList<ColliderHandle>),
    /// It stays at rest on a slope of this tilt (`Rolling::holding_tilt`): rapier's resting
    /// contact (`Role::Resting`) with these grounds, their normal force acting downhill of the
    /// contact point so that rapier holds the ball still and sleeps it. (The closed form
    /// writing the rest pose back after each step would move the collider, and rapier wakes
    /// the body of every collider moved by hand.)
    Held(Vector3<f64>, SmallList<ColliderHandle>),
    /// It would move, but something besides its grounds can touch it within the step
    /// (`observe::within_reach_of_other`): rapier's resting contact, as any resting pair.
    Reached,
}

/// Does the contact, at gap `dist` (m) with normal speed `un` and normal acceleration `an`,
/// close within `dt`? `dist + un t + an t^2 / 2 <= 0` for some `t` in `[0, dt]`.
pub(crate) fn closes_within(dist: f64, un: f64, an: f64, dt: f64) -> bool {
    let at = |t: f64| dist + un * t + 0.5 * an * t * t;
    if at(0.0) <= 0.0 || at(dt) <= 0.0 {
        return true;
    }
    if an > 0.0 {
        let t = -un / an;
        return t > 0.0 && t < dt && at(t) <= 0.0;
    }
    false
}

/// The plan stage's view of the plugin: what it reads, and the events of `Step` mode's
/// step-start impulses.
pub(crate) struct Planner<'a, H> {
    pub config: &'a ImpactConfig,
    pub registry: &'a Registry,
    pub flags: &'a HookFlags,
    pub user_hooks: &'a H,
    /// The pairs held at rest last step (`StepData::holds`).
    pub prev_holds: &'a HandleSet<PairKey>,
    pub events: &'a mut Vec<ImpactEvent>,
}

impl<H: PhysicsHooks> Planner<'_, H> {
    /// Plans one awake managed body that may reach a ground (see the module's contract):
    /// the roles of its pairs with the grounds near it (in `step.roles`), its candidate (in
    /// `step.candidates`), and in `Step` mode the impulses of the contacts that close in the
    /// step (written, with their events). Returns whether a ground is near it (its
    /// colliders then need the plugin's hook flags in the bodies arrangement).
    #[allow(clippy::too_many_arguments)]
    pub fn plan_body(
        &mut self,
        handle: RigidBodyHandle,
        bodies: &mut RigidBodySet,
        colliders: &ColliderSet,
        sets: &Sets,
        shadows: &HandleMap<RigidBodyHandle, Shadow>,
        prev_roles: &HandleMap<PairKey, Role>,
        g: Vector3<f64>,
        dt: f64,
        step: &mut StepData,
    ) -> bool {
        let rb = &bodies[handle];
        let (start, flight, local_com) = snapshot(rb, g, dt, shadows.get(&handle));
        let geom = body_geom(rb, colliders, &local_com);
        if geom.parts.is_empty() {
            return false;
        }
        // The cheap test: the bounding sphere swept over the step against ground AABBs.
        let speed = flight.max_speed(&start, dt) + flight.max_angular_speed(&start) * geom.radius;
        let reach = speed * dt + step.policy.resting_gap.max(step.policy.prediction);
        let sphere = Aabb::from_half_extents(
            vec_from_na(&start.com),
            Vector::splat(crate::plugin::bridge::convert::to_real(geom.radius + reach)),
        );
        let near =
            self.registry
                .index
                .near(&step.grounds, sphere.center(), sphere.half_extents().x);
        // A ball of an impact between bodies is moved by the reconstruct stage: it needs its
        // candidate in every mode.
        let member = step.pairs.members.contains(&handle);
        if near.is_empty() {
            if self.config.timing == TimingMode::Exact || member {
                step.candidates
                    .push(Candidate::flying(handle, start, flight, local_com));
            }
            return false;
        }
        let mut ground_geoms: SmallList<(usize, GroundGeom)> = near
            .iter()
            .filter_map(|i| Some((*i, ground_geom(&step.grounds[*i], colliders)?)))
            .collect();
        let turns_surface = !(geom.parts.len() == 1 && centred_ball(&geom.parts[0]));
        // A ball near several grounds (a seam between floor tiles): the one it rests on
        // first, so that if it rolls there on one plane with the others the rest are only
        // that plane's pieces (below). One query per ground (a sort would ask each pair's,
        // 22 % of a 64 x 64 tiled floor's run).
        // Those queries are the loop's below while the ball has not moved (a `Step` impulse
        // changes only its velocity).
        let mut start_contacts: SmallList<_> = SmallList::Empty;
        if !turns_surface && ground_geoms.len() > 1 {
            start_contacts = ground_geoms
                .iter()
                .map(|(_, gg)| contact_checked(&geom.parts[0], gg, &start, 0.0, reach))
                .collect();
            let gap = |found: &Result<Option<PairContact>, _>| match found {
                Ok(Some((dist, ..))) => f64::abs(*dist),
                _ => f64::INFINITY,
            };
            let nearest = start_contacts
                .iter()
                .map(gap)
                .enumerate()
                .min_by(|(_, a), (_, b)| a.total_cmp(b))
                .map_or(0, |(k, _)| k);
            ground_geoms.swap(0, nearest);
            start_contacts.swap(0, nearest);
        }
        let mut state = start;
        let mut touched = false;
        let mut impact_grounds = SmallList::Empty;
        let mut closing = false;
        let mut turning_resting = SmallList::Empty;
        let mut rolling = None;
        // Held at rest on a slope (`OnPlane::Held`): its pairs are rapier's.
        let mut held = false;
        // The grounds of the plane it rolls on (`rolling_of`): their pairs are the rolling's.
        let mut rolling_pieces: Option<SmallList<ColliderHandle>> = None;
        // How far a point of the body can move relative to a resting contact point in the
        // step by turning (for a ball about its centre: how fast rapier's contact point
        // slides off its bottom). From the state after any `Step` impulse applied above.
        let turning_reach = |s: &State| flight.max_angular_speed(s) * 2.0 * geom.radius * dt;
        let jointed = sets.impulse_joints.attached_joints(handle).next().is_some()
            || sets.multibody_joints.rigid_body_link(handle).is_some();
        for (k, (gi, gg)) in ground_geoms.iter().enumerate() {
            let mut any_impact = false;
            // No pair of the body with this ground can meet in the step.
            let mut clear = true;
            for part in &geom.parts {
                let key = (part.handle, gg.handle);
                let joint_filtered = jointed
                    && colliders[key.1].parent().is_some_and(|ground_body| {
                        filter::joint_disables_contacts(
                            sets.impulse_joints,
                            sets.multibody_joints,
                            handle,
                            ground_body,
                        )
                    });
                if joint_filtered
                    || !filter::rapier_solves(bodies, &colliders[key.0], &colliders[key.1])
                    || self.user_refuses(bodies, colliders, key)
                {
                    step.roles.insert(key, Role::Filtered);
                    continue;
                }
                // The ball rolls on the plane of an earlier (nearer) ground. A piece of that
                // plane: the pair is the rolling's too, out of rapier's solver (rapier's
                // contact with a tile's edge at a flush seam throws the ball up, and `Step`
                // mode would bounce it). Another ground it may roll into (a slope's foot, a
                // wall): out of rapier's solver too, the search along the rolling finds the
                // impact.
                if let Some(pieces) = &rolling_pieces {
                    let role = if pieces.contains(&gg.handle) {
                        Role::Rolling
                    } else {
                        // Searched after the step only if within reach of it.
                        any_impact |= match start_contacts.get(k) {
                            Some(found) => matches!(found, Ok(Some(_))),
                            None => {
                                matches!(contact_checked(part, gg, &state, 0.0, reach), Ok(Some(_)))
                            }
                        };
                        Role::Impact
                    };
                    step.roles.insert(key, role);
                    continue;
                }
                let found = match start_contacts.get(k) {
                    Some(found) if state.com == start.com && state.rot == start.rot => *found,
                    _ => contact_checked(part, gg, &state, 0.0, reach),
                };
                let contact0 = found.as_ref().ok().copied().flatten();
                // A pair beyond reach cannot touch in this step: out of the solver, and
                // no search after the step.
                let reachable = matches!(found, Ok(Some(_)));
                let mut role = match found {
                    // parry cannot query this pair: rapier keeps it, restitution included.
                    Err(_) => Role::Rapier,
                    Ok(None) => Role::Impact,
                    Ok(Some((dist, n, p))) => {
                        let u = crate::plugin::queries::geometry::body_velocity_at(&state, &p)
                            - gg.velocity_at(&p, 0.0);
                        let un = n.dot(&u);
                        // The normal speed the contact will have on reaching the ground
                        // (gravity, or any acceleration towards it, included).
                        let an = n.dot(&flight.accel);
                        let arrival = (un * un + 2.0 * (-an).max(0.0) * dist.max(0.0)).sqrt();
                        // Hysteresis: a pair rapier held at rest last step shows the
                        // normal speed rapier's solver leaves at rest (up to g dt and more
                        // for a fast-rolling ball): it stays resting unless clearly hit.
                        let prev_role = prev_roles.get(&key);
                        // A ball the closed form rolled ends on its plane: one above it has
                        // left it since (an impact with a wall or another ball lifted it, and
                        // it flies), and is not held (the hysteresis would put it back on the
                        // ground, within the resting gap, with no event).
                        let was_resting = match prev_role {
                            Some(Role::Resting) => true,
                            Some(Role::Rolling) => dist <= COPLANAR_TOLERANCE,
                            _ => false,
                        };
                        // The plugin had the pair last step: what touched the body
                        // then is known (a body new near the ground has nothing to go
                        // on).
                        let measured = matches!(
                            prev_role,
                            Some(&Role::Resting | &Role::Impact | &Role::Rolling)
                        );
                        // A pressed contact: a resting pair of a body that also
                        // touched another body (or a wall, or had a joint) last step
                        // approaches only because something pushes it (a box dropped
                        // on it, the pile above it). Taking it from rapier's solver
                        // would let the push sink the body for a step and then push
                        // it out and bounce it at the step end against the solver
                        // (issue 5: 125-ball pile never settling, a 1e6 mass ratio
                        // sinking twice as deep as rapier alone). rapier keeps it,
                        // with e = 0 (`Policy::rests`). What touched the body is asked
                        // only where it decides (rarely: most resting pairs are slow),
                        // and only of a body measured after the last step.
                        let pressed =
                            || measured && touched_besides_grounds(handle, rb, sets, self.registry);
                        if step.policy.rests(dist, arrival, was_resting, pressed) {
                            Role::Resting
                        } else if self.config.timing == TimingMode::Step
                            && closes_within(dist, un, n.dot(&(flight.accel)), dt)
                            && un < 0.0
                        {
                            // Step mode: the impulse at the start of the step.
                            let hit = crate::plugin::queries::geometry::Hit {
                                part: 0,
                                ground: 0,
                                dist,
                                normal: n,
                                point: p,
                                un,
                            };
                            let (point, count) = landing_point(
                                part,
                                gg,
                                &state,
                                0.0,
                                &hit,
                                self.config.flat_tolerance,
                            );
                            let inertia = Inertia::of(rb);
                            let single = BodyGeom {
                                parts: SmallList::One(*part),
                                radius: geom.radius,
                            };
                            let input = ImpactInput {
                                body: handle,
                                inertia: &inertia,
                                law: self.config.law,
                                material: self.registry.material_of(
                                    colliders,
                                    part.handle,
                                    gg.handle,
                                ),
                                resting_speed: step.policy.resting_speed,
                                force_settle: false,
                                timing: ImpactTiming::StepStart,
                            };
                            match resolve(&input, &single, gg, &state, 0.0, &hit, point, count) {
                                Some((after, event)) => {
                                    state = after;
                                    touched = true;
                                    self.events.push(event);
                                    // Out of rapier's solver unless the point leaves
                                    // slower than the resting speed. (Keeping a touching
                                    // pair in the solver after the impulse let a box
                                    // bounced at 10 m/s be pressed 17 cm into the ground
                                    // by a ball 135 times its mass landing on it in the
                                    // same step, 240 Hz. Boxes rocking on two edges, each
                                    // bounced in turn at the step's start and end, come
                                    // to rest by the energy cap instead.)
                                    let un2 = n.dot(
                                        &(crate::plugin::queries::geometry::body_velocity_at(
                                            &state, &point,
                                        ) - gg.velocity_at(&point, 0.0)),
                                    );
                                    if un2 <= step.policy.resting_speed {
                                        Role::Resting
                                    } else {
                                        Role::Impact
                                    }
                                }
                                None => Role::Resting,
                            }
                        } else {
                            Role::Impact
                        }
                    }
                };
                // A ball sliding on a level fixed ground, alone on it: the closed form
                // instead of rapier's resting contact, which turns the contact point with
                // the ball (it hops and slips on: at 60 Hz still 1.1 cm/s of slip after
                // three closed-form rolling times).
                if role == Role::Resting && !turns_surface && rolling.is_none() && !held {
                    // Within the resting gap of it (a `Step` impulse can leave a ball
                    // resting on its way down, up to a step's travel above the ground).
                    if let Some((dist, n, point)) =
                        contact0.filter(|(dist, ..)| dist.abs() <= step.policy.resting_gap)
                    {
                        // What touches it is read from rapier's contact graph (in
                        // `rolling_of`), which keeps a sleeping body's pairs: a ball of a
                        // pile is not taken. A body new to the plugin (just created, first
                        // near the ground, or just woken, such as a ball at rest putted by
                        // setting its velocity: one step of rapier's contact sent it 6 %
                        // too far at 30 Hz) is taken, and if something touches it in the
                        // step, the settle stage puts it back on the ground.
                        let on_ground = State {
                            com: state.com - n * dist,
                            v: state.v - n * n.dot(&state.v),
                            ..state
                        };
                        let others: SmallList<&GroundGeom> = ground_geoms
                            .iter()
                            .filter(|(other, _)| other != gi)
                            .map(|(_, g)| g)
                            .collect();
                        match self.rolling_of(
                            bodies, colliders, handle, part, gg, &others, &flight, &n, &on_ground,
                            step, sets,
                        ) {
                            Some(OnPlane::Rolls(motion, pieces)) => {
                                role = Role::Rolling;
                                rolling_pieces = Some(pieces);
                                rolling = Some((*gi, motion));
                                state = on_ground;
                            }
                            Some(OnPlane::Held(tilt, pieces)) => {
                                held = true;
                                if !self.prev_holds.contains(&key) {
                                    step.first_holds.push(FirstHold {
                                        body: handle,
                                        collider: part.handle,
                                        ground: gg.handle,
                                        start: State {
                                            v: Vector3::zeros(),
                                            w: Vector3::zeros(),
                                            ..on_ground
                                        },
                                        local_com,
                                        normal: n,
                                        radius: geom.radius,
                                    });
                                }
                                for piece in pieces.iter() {
                                    step.holds.insert((part.handle, *piece), tilt);
                                }
                            }
                            // Rolled in closed form last step: the event says it is
                            // rapier's from here.
                            Some(OnPlane::Reached)
                                if prev_roles.get(&key) == Some(&Role::Rolling) =>
                            {
                                let site = Site {
                                    body: handle,
                                    collider: part.handle,
                                    ground: gg.handle,
                                    body2: None,
                                    normal: n,
                                    point,
                                };
                                let inertia = Inertia::of(&bodies[handle]);
                                self.events.push(released(&site, &inertia, &state, 0.0));
                            }
                            Some(OnPlane::Reached) | None => {}
                        }
                    }
                }
                if role == Role::Resting && turning_reach(&state) > step.policy.resting_gap {
                    if let Some((_, _, p)) = contact0 {
                        turning_resting.push((*gi, state.rot.inverse() * (p - state.com)));
                    }
                }
                any_impact |= role == Role::Impact && reachable;
                // Only asked of a ground the search may run against (a single part's
                // pair that is not `Impact` does not make one).
                clear = clear
                    && match contact0 {
                        Some(_) if role != Role::Impact && geom.parts.len() == 1 => true,
                        Some((dist, n, _)) => {
                            self.config.timing != TimingMode::Step
                                && cannot_close(
                                    part,
                                    gg,
                                    &Sweep {
                                        flight: &flight,
                                        s: &state,
                                        dt,
                                        radius: geom.radius,
                                        speed,
                                    },
                                    (dist, n),
                                )
                        }
                        None => false,
                    };
                step.roles.insert(key, role);
            }
            if any_impact {
                impact_grounds.push(*gi);
                closing |= !clear;
            }
        }
        if touched {
            write_state(&mut bodies[handle], &state, &local_com, true);
        }
        if !impact_grounds.is_empty()
            || !turning_resting.is_empty()
            || rolling.is_some()
            || self.config.timing == TimingMode::Exact
            || member
        {
            step.candidates.push(Candidate {
                body: handle,
                start: state,
                flight,
                local_com,
                near,
                impact_grounds,
                touched,
                closing,
                turning_resting,
                turns_surface,
                rolling,
            });
        }
        true
    }

    /// Does the user's filter refuse the managed pair `(body collider, ground collider)`?
    /// Asked only when the colliders' own hook flags ask for the user's filter, with the
    /// start-of-step state, so that every pair the plugin could resolve in the step is
    /// covered (rapier asks it again during the step, for the pairs its broad phase has).
    fn user_refuses(&self, bodies: &RigidBodySet, colliders: &ColliderSet, key: PairKey) -> bool {
        let flags = self.flags.recorded_user_flags(colliders, key.0)
            | self.flags.recorded_user_flags(colliders, key.1);
        filter::user_refuses(self.user_hooks, flags, bodies, colliders, key)
    }

    /// The closed-form motion of a ball (`part`, the body's only collider, centred) sliding on
    /// the ground `gg` with normal `n`, from the state `on_ground` (touching it, no normal
    /// speed), when it applies: a ground at rest (or moving along its plane without turning, in
    /// its frame) whose one flat face (a half-space, or a cuboid's face the ball stays over:
    /// `flat_relative`) is all it can meet in the step, or with `others` near too, the faces of
    /// those in its plane under the ball's path (`one_plane_under`: a flush seam between tiles)
    /// up to where it first touches one of the others (a crease, a wall: not touching it at the
    /// start), gravity (and any constant force) along `-n`, no damping, torque or contact
    /// modification by the user, isotropic inertia with no locked axis, nothing besides its
    /// grounds able to touch it within the step (`observe::within_reach_of_other`; else
    /// `OnPlane::Reached`), and a ball that slips (faster than 1 mm/s) or rolls faster than
    /// the resting speed (slower, it is rapier's, which brings it to rest and to sleep). Or,
    /// at rest on a still slope that holds it (`OnPlane::Held`), rapier's contact holding it.
    #[allow(clippy::too_many_arguments)]
    fn rolling_of(
        &self,
        bodies: &RigidBodySet,
        colliders: &ColliderSet,
        handle: RigidBodyHandle,
        part: &BodyPart,
        gg: &GroundGeom,
        others: &[&GroundGeom],
        flight: &Flight,
        n: &Vector3<f64>,
        on_ground: &State,
        step: &StepData,
        sets: &Sets,
    ) -> Option<OnPlane> {
        let rb = &bodies[handle];
        let member = step.pairs.members.contains(&handle);
        let ball = part.shape.as_ball()?;
        let radius = to_f64(ball.radius) + part.skin + gg.skin;
        let an = flight.accel.dot(n);
        let level = (flight.accel - n * an).norm() <= 1e-9 * flight.accel.norm();
        let user_modifies = (self.flags.recorded_user_flags(colliders, part.handle)
            | self.flags.recorded_user_flags(colliders, gg.handle))
        .contains(ActiveHooks::MODIFY_SOLVER_CONTACTS);
        let plain = flight.linear_damping == 0.0
            && flight.angular_damping == 0.0
            && rb.user_torque() == Vector::ZERO;
        // A ground moving at constant velocity along its plane without turning (a conveyor):
        // relative to it the ball moves as on a still one. Any other moving ground is
        // rapier's.
        let u = gg.v;
        if gg.w != Vector3::zeros() || u.dot(n).abs() > IN_PLANE_TOLERANCE * u.norm() {
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
        // impact between bodies is taken at rest too, and beside the other ball:
        // the reconstruct stage moves the pair together (and if anything else touched it in
        // the step, hands it back to rapier's end state). So is one at rest on a moving
        // ground, which cannot sleep: rapier's resting contact on a belt at 0.8 m/s sank it
        // 0.28 mm and let it lag 6e-5 m/s behind.
        let carried = u != Vector3::zeros();
        if !(an < 0.0 && plain) || !member && slow && !resisted && !carried || user_modifies {
            return None;
        }
        let friction = self
            .registry
            .material_of(colliders, part.handle, gg.handle)
            .friction;
        if !(friction.is_finite() && friction >= 0.0) {
            return None;
        }
        // After the cheap refusals (most resting balls are at rest): nothing besides its
        // grounds can touch it in the step. Its ground holds it (`|an|` along `n`) and pulls
        // it along the plane by at most `mu |an|` (slip) or `mu_r |an|` (rolling resistance).
        let own = OwnMotion {
            v: on_ground.v,
            accel: flight.accel,
            normal: *n,
            pressed: -an,
            dragged: -an * friction.max(rolling_resistance),
            drag_along: level.then(|| {
                [
                    slip.try_normalize(0.0).unwrap_or_else(Vector3::zeros),
                    v.try_normalize(0.0).unwrap_or_else(Vector3::zeros),
                ]
            }),
            gravity: step.gravity,
        };
        if !member
            && within_reach_of_other(
                handle,
                rb,
                &own,
                bodies,
                colliders,
                sets,
                self.registry,
                step.dt,
            )
        {
            return Some(OnPlane::Reached);
        }
        // The ground's one flat face under the ball for the whole step (a half-space, or a
        // cuboid's face the ball stays well inside of), or the faces in one plane under its
        // contact point's whole path: a mesh's or heightfield's other triangles, or a
        // cuboid's edge, could be met inside the step, out of rapier's solver. On a moving
        // ground: its one flat face, in its frame.
        let travel = (v.norm() + on_ground.w.norm() * radius) * step.dt;
        let inside = others.is_empty() && flat_relative(part, gg, on_ground, travel, radius);
        let inertia_ratio = Inertia::of(rb).ball_ratio(radius)?;
        let motion = Rolling {
            normal: *n,
            radius,
            inertia_ratio,
            friction,
            rolling_resistance,
            spinning_friction,
            accel: flight.accel,
            ground_velocity: u,
        };
        // At rest on a slope that holds it (its closed-form stop, or placed there): rapier's
        // contact holds it, nothing else touching it.
        let to_plane = n * (radius - gg.skin);
        if !level && !member {
            let at_rest = v.norm() <= HELD_SPEED && on_ground.w.norm() * radius <= HELD_SPEED;
            if let Some(tilt) = motion.holding_tilt().filter(|_| at_rest) {
                let plane = PlaneNear {
                    n: *n,
                    height: n.dot(&(on_ground.com - to_plane)),
                    centre: on_ground.com,
                    reach: radius + step.policy.resting_gap,
                };
                // Its own ground one flat face under it, or one plane near it (not a crease
                // inside a mesh).
                let one_face =
                    flat_relative(part, gg, on_ground, 0.0, radius) || plane_piece_of(gg, &plane);
                return one_face
                    .then(|| {
                        self.held_on(
                            colliders, handle, part, gg, others, &plane, on_ground, friction, step,
                        )
                    })
                    .flatten()
                    .map(|pieces| OnPlane::Held(tilt, pieces));
            }
        }
        let at = flight.accel - n * an;
        // The acceleration along the ground is at most gravity's along it and the friction.
        let accel_bound = at.norm() - friction * an;
        let plane = PlaneNear {
            n: *n,
            height: n.dot(&(on_ground.com - to_plane)),
            centre: on_ground.com,
            reach: radius
                + on_ground.v.norm() * step.dt
                + accel_bound * step.dt * step.dt / 2.0
                + COPLANAR_TOLERANCE,
        };
        // On level ground the closed form reaches every state unless the rolling resistance
        // needs more friction than `mu N` (`mu_r / (1 + k) > mu`): then it is asked.
        if level
            && inside
            && (rolling_resistance <= friction
                || motion.advance_checked(on_ground, step.dt).is_some())
        {
            return Some(OnPlane::Rolls(motion, SmallList::One(gg.handle)));
        }
        let mut piece_handles = SmallList::One(gg.handle);
        // Only where the closed form reaches (on a slope, the band where a ball can neither
        // roll nor slide is not).
        let end = motion.advance_checked(on_ground, step.dt)?;
        if !inside {
            // Its path's bow from the chord is below (|a_t| + mu g_n) dt^2 / 8.
            let (p, q) = (on_ground.com - to_plane, end.com - to_plane);
            let bow = accel_bound * step.dt * step.dt / 8.0;
            // The others are the plane's pieces, or grounds it may roll into, which must
            // not touch it yet (a ball resting in a crease is rapier's). One it has just
            // left (a slope behind the crease) may be nearer than the resting gap: the
            // search along the rolling finds whether it comes back.
            // A piece rolls the ball with this ground's coefficients: one of other materials,
            // or whose contacts the user modifies, is an obstacle (touching it, the ball is
            // rapier's).
            let same = |g: &GroundGeom| {
                let user = self.flags.recorded_user_flags(colliders, g.handle);
                self.registry
                    .material_of(colliders, part.handle, g.handle)
                    .friction
                    == friction
                    && self.registry.rolling_of(handle, g.handle, default)
                        == (rolling_resistance, spinning_friction)
                    && !user.contains(ActiveHooks::MODIFY_SOLVER_CONTACTS)
            };
            let (pieces, obstacles): (Vec<&GroundGeom>, Vec<&GroundGeom>) = std::iter::once(gg)
                .chain(others.iter().copied())
                .partition(|g| (g.handle == gg.handle || same(g)) && plane_piece_of(g, &plane));
            let touching = |s: &State, t: f64| {
                obstacles
                    .iter()
                    .any(|og| !matches!(contact_checked(part, og, s, t, 0.0), Ok(None)))
            };
            if touching(on_ground, 0.0) {
                return None;
            }
            piece_handles = pieces.iter().map(|g| g.handle).collect();
            if !one_plane_under(&pieces, &plane, &p, &q, bow + COPLANAR_TOLERANCE) {
                // Its contact point leaves the plane, but it may meet another ground first
                // (rolling down into a crease, it touches the level ground while still on
                // the slope): the plane need only reach that far, the reconstruct stage's
                // search (the same samples) finds the touch.
                let t = earliest_touch(step.dt, |t| touching(&motion.advance(on_ground, t), t))?;
                let q = motion.advance(on_ground, t).com - to_plane;
                let bow = bow * (t / step.dt).powi(2);
                if !one_plane_under(&pieces, &plane, &p, &q, bow + COPLANAR_TOLERANCE) {
                    return None;
                }
            }
        }
        Some(OnPlane::Rolls(motion, piece_handles))
    }

    /// The grounds holding a ball at rest on `plane`, the plane of `gg`, `gg` first: the
    /// others within the resting gap of it must be pieces of that plane with the same
    /// coefficients (a flush seam: `friction` and `gg`'s rolling ones), or it is not held (a
    /// ball resting in a crease is rapier's).
    #[allow(clippy::too_many_arguments)]
    fn held_on(
        &self,
        colliders: &ColliderSet,
        handle: RigidBodyHandle,
        part: &BodyPart,
        gg: &GroundGeom,
        others: &[&GroundGeom],
        plane: &PlaneNear,
        on_ground: &State,
        friction: f64,
        step: &StepData,
    ) -> Option<SmallList<ColliderHandle>> {
        let mut pieces = SmallList::One(gg.handle);
        let default = (
            self.config.rolling_resistance,
            self.config.spinning_friction,
        );
        for og in others {
            let gap = step.policy.resting_gap;
            if matches!(contact_checked(part, og, on_ground, 0.0, gap), Ok(None)) {
                continue;
            }
            let same = self
                .registry
                .material_of(colliders, part.handle, og.handle)
                .friction
                == friction
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
}
