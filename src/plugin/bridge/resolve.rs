//! The hand-over to the model: a rapier body, a contact and a material become the model's
//! `Body`, `BodyVelocity`, `Contact` and `Material`; the model's `Impact` becomes a new
//! state and an [`ImpactEvent`]. No impulse algebra here: the model does it.

use crate::model::{
    self, Body, BodyVelocity, Contact, Fallback, Impact, Law, Material, ModelError,
    RestitutionCurve,
};
use crate::motion::State;
use crate::plugin::bridge::convert::{diag_to_na, rot_to_na, to_f64, vec_from_na};
use crate::plugin::events::{EventKind, ImpactEvent, ImpactTiming};
use crate::plugin::policy::{ISOTROPIC_TOLERANCE, TOUCHING_ROUNDING, rests_at};
use crate::plugin::queries::geometry::{BodyGeom, GroundGeom, Hit, body_velocity_at};
use crate::rapier::prelude::{
    CoefficientCombineRule, Collider, ColliderHandle, LockedAxes, RigidBody, RigidBodyHandle,
};
use nalgebra::{Matrix3, UnitQuaternion, Vector3};

/// The inertial data the model needs, read once per step from rapier.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Inertia {
    pub mass: f64,
    /// Inverse principal inertia (1/(kg m^2)).
    inv_principal: Matrix3<f64>,
    /// Principal axes in the body frame.
    principal_frame: UnitQuaternion<f64>,
    /// Locked rotation axes (world x, y, z), as rapier locks them.
    locked: [bool; 3],
}

impl Inertia {
    /// Inlined into its callers: one that reads only part of it (a ball's ratio, which needs
    /// no principal frame) then skips the rest, the renormalised quaternion above all.
    #[inline]
    pub fn of(rb: &RigidBody) -> Self {
        let mp = &rb.mass_properties().local_mprops;
        let flags = rb.locked_axes();
        Self {
            mass: to_f64(rb.mass()),
            inv_principal: diag_to_na(mp.inv_principal_inertia),
            principal_frame: rot_to_na(mp.principal_inertia_local_frame),
            locked: [
                flags.contains(LockedAxes::ROTATION_LOCKED_X),
                flags.contains(LockedAxes::ROTATION_LOCKED_Y),
                flags.contains(LockedAxes::ROTATION_LOCKED_Z),
            ],
        }
    }

    /// `I / (m r^2)` for a body of isotropic inertia (to `ISOTROPIC_TOLERANCE`) with no locked
    /// rotation axis (a ball about its centre) and contact radius `radius`, else `None`.
    #[inline]
    pub fn ball_ratio(&self, radius: f64) -> Option<f64> {
        let inv = self.inv_principal.diagonal();
        let (lo, hi) = (inv.min(), inv.max());
        let isotropic = lo > 0.0 && hi.is_finite() && hi - lo <= ISOTROPIC_TOLERANCE * hi;
        let ratio = 1.0 / (hi * self.mass * radius * radius);
        (isotropic && !self.locked.contains(&true) && ratio.is_finite() && ratio > 0.0)
            .then_some(ratio)
    }

    /// The model's body at orientation `rot`: `I_w^-1 = R diag(1/I) R^T`, with the rows and
    /// columns of locked axes zeroed (what rapier's solver uses).
    pub fn body_at(&self, rot: &UnitQuaternion<f64>) -> Body {
        let r = (rot * self.principal_frame)
            .to_rotation_matrix()
            .into_inner();
        let mut inv = r * self.inv_principal * r.transpose();
        for (axis, locked) in self.locked.iter().enumerate() {
            if *locked {
                inv.row_mut(axis).fill(0.0);
                inv.column_mut(axis).fill(0.0);
            }
        }
        // Symmetrise away rounding so the model's symmetry check never trips.
        let inv = 0.5 * (inv + inv.transpose());
        Body {
            mass: self.mass,
            inv_inertia: inv,
        }
    }
}

/// Restitution and friction of a body collider against a ground: the ground's override, or
/// rapier's combination of the two colliders' coefficients (their combine rules). A pair of a
/// collider out of the plugin's ranges never gets here (it is rapier's, and reported:
/// `Diagnostic::CoefficientsOutOfRange`), and every combination of values in range is finite
/// and `>= 0`: nothing is changed here.
pub(crate) fn material(body: &Collider, ground: &Collider, over: Option<Material>) -> Material {
    if let Some(m) = over {
        return m;
    }
    let e = CoefficientCombineRule::combine(
        body.restitution(),
        ground.restitution(),
        body.restitution_combine_rule(),
        ground.restitution_combine_rule(),
    );
    Material::new(to_f64(e), combined_friction(body, ground))
}

/// rapier's combination of the two colliders' frictions, by their combine rules (the
/// friction of [`material`] without a ground's material).
pub(crate) fn combined_friction(body: &Collider, ground: &Collider) -> f64 {
    to_f64(CoefficientCombineRule::combine(
        body.friction(),
        ground.friction(),
        body.friction_combine_rule(),
        ground.friction_combine_rule(),
    ))
}

/// A contact's coefficients before its approach speed is known: the constant ones (with the
/// tangential restitution), and the restitution curve that replaces the constant `e` where
/// one applies (two for a pair of bodies that each have one: their mean).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct ContactMaterial<'a> {
    constant: Material,
    curves: [Option<&'a RestitutionCurve>; 2],
}

impl<'a> ContactMaterial<'a> {
    /// `constant`, with `e` from `curves` where the first is set (the mean of both if both
    /// are).
    pub fn new(constant: Material, curves: [Option<&'a RestitutionCurve>; 2]) -> Self {
        Self { constant, curves }
    }

    /// The material of an impact approaching at `approach` (m/s): the one `e(v_n)` every
    /// decision of the plugin about this contact's bounce uses.
    pub fn at(&self, approach: f64) -> Material {
        let restitution = match self.curves {
            [None, _] => return self.constant,
            [Some(c), None] => c.at(approach),
            [Some(a), Some(b)] => 0.5 * (a.at(approach) + b.at(approach)),
        };
        Material {
            restitution,
            ..self.constant
        }
    }

    /// The material of an impact that rests: `e = 0`, whatever a curve says (none is
    /// evaluated).
    pub fn resting(&self) -> Material {
        Material {
            restitution: 0.0,
            ..self.constant
        }
    }

    /// The Coulomb friction coefficient.
    pub fn friction(&self) -> f64 {
        self.constant.friction
    }
}

/// Everything about one impact that is not geometry.
pub(crate) struct ImpactInput<'a> {
    pub body: RigidBodyHandle,
    pub inertia: &'a Inertia,
    pub law: Law,
    pub material: ContactMaterial<'a>,
    /// Approach speeds below this (m/s) are resolved with `e = 0`.
    pub resting_speed: f64,
    /// Resolve with `e = 0` whatever the speed (last impact allowed in the step).
    pub force_settle: bool,
    pub timing: ImpactTiming,
}

impl<'a> ImpactInput<'a> {
    /// The input of an impact of `body` (of inertia `inertia`) resolved by `law` with
    /// `material`, at `timing`, with no bounce slower than `resting_speed` (m/s). The one
    /// construction of the model's input, for impacts with grounds and between bodies.
    pub fn new(
        body: RigidBodyHandle,
        inertia: &'a Inertia,
        law: Law,
        material: ContactMaterial<'a>,
        resting_speed: f64,
        timing: ImpactTiming,
    ) -> Self {
        Self {
            body,
            inertia,
            law,
            material,
            resting_speed,
            force_settle: false,
            timing,
        }
    }

    /// The same input, resolved with `e = 0` whatever the speed if `force` (the last impact
    /// a body is allowed in a step, or an impact the settle stage's table settles).
    pub fn forced_to_settle(self, force: bool) -> Self {
        Self {
            force_settle: force,
            ..self
        }
    }

    /// Whether an impact approaching at `approach` (m/s) settles (slower than the resting
    /// speed, or forced), and the material it is resolved with (`e = 0` if it settles, else
    /// the material's `e` at that speed).
    fn material_at(&self, approach: f64) -> (bool, Material) {
        let settled = self.force_settle || rests_at(approach, self.resting_speed);
        let material = if settled {
            self.material.resting()
        } else {
            self.material.at(approach)
        };
        (settled, material)
    }
}

/// Where a body touches a ground at an impact: the contact the search found, and the point
/// the impulse acts at (a landing point, or the deepest point) with how many contact points
/// it stands for.
#[derive(Clone, Copy, Debug)]
pub(crate) struct GroundContactAt<'h> {
    pub hit: &'h Hit,
    pub point: Vector3<f64>,
    pub points: usize,
}

impl<'h> GroundContactAt<'h> {
    pub fn new(hit: &'h Hit, point: Vector3<f64>, points: usize) -> Self {
        Self { hit, point, points }
    }
}

/// Resolves the impact of the body at state `s` (time `t` in the step) on a ground at the contact
/// `at.point` (a landing point, see [`crate::plugin::queries::geometry::landing_point`]) with the
/// hit's normal. Returns the state after and the event, or `None` when the point does not approach
/// the ground or the model refuses the input.
pub(crate) fn resolve(
    input: &ImpactInput,
    geom: &BodyGeom,
    ground: &GroundGeom,
    s: &State,
    t: f64,
    at: &GroundContactAt,
) -> Option<(State, ImpactEvent)> {
    let (hit, point, points) = (at.hit, at.point, at.points);
    let n = hit.normal;
    let ground_velocity = ground.velocity_at(&point, t);
    let un = n.dot(&(body_velocity_at(s, &point) - ground_velocity));
    if un.is_nan() || un >= 0.0 {
        return None;
    }
    let (settled, material) = input.material_at(-un);
    let body = input.inertia.body_at(&s.rot);
    let contact = Contact {
        normal: n,
        offset: point - s.com,
        ground_velocity,
    };
    let velocity = BodyVelocity {
        linear: s.v,
        angular: s.w,
    };
    let impact = match model::resolve(input.law, &body, &velocity, &contact, &material) {
        Ok(impact) => impact,
        // The document's slip law has no solution here (eq. 19's denominator <= 0, the
        // Painleve-like jam): rather than leave the body at the contact with its approach
        // velocity, the consistent law resolves it, and the event says so.
        Err(ModelError::Jam { .. }) => Impact {
            fallback: Some(Fallback::Jam),
            ..model::resolve(Law::Consistent, &body, &velocity, &contact, &material).ok()?
        },
        Err(_) => return None,
    };
    let after = State {
        v: impact.velocity.linear,
        w: impact.velocity.angular,
        ..*s
    };
    let site = Site {
        body: input.body,
        collider: geom.parts[hit.part].handle,
        ground: ground.handle,
        body2: None,
        normal: n,
        point,
    };
    let resolution = Resolution {
        time: t,
        timing: input.timing,
        contact_points: points,
        approach_speed: -un,
        settled,
        material,
    };
    let exchange = Exchange {
        impulse: impact.impulse,
        normal_impulse: impact.normal_impulse,
        tangent_impulse: impact.tangent_impulse,
        regime: impact.regime,
        law: impact.law,
        fallback: impact.fallback,
    };
    let energies = (impact.ke_before, impact.ke_after);
    let event = event(EventKind::Impact, &site, &resolution, &exchange, energies);
    Some((after, event))
}

/// One body of an impact between two bodies, at the impact.
pub(crate) struct PairSide<'a> {
    pub body: RigidBodyHandle,
    pub collider: ColliderHandle,
    pub inertia: &'a Inertia,
    pub state: State,
    /// A ball's radius to the contact point, skin included (m): read by [`resolve_balls`]
    /// only (0 for other shapes).
    pub radius: f64,
}

impl<'a> PairSide<'a> {
    /// A body of a pair at `state`.
    pub fn new(
        body: RigidBodyHandle,
        collider: ColliderHandle,
        inertia: &'a Inertia,
        state: State,
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

impl<'a> ImpactInput<'a> {
    /// The input of an impact between body `a` and another ([`resolve_balls`],
    /// [`resolve_bodies`], which read the law, the material, the resting speed and the timing;
    /// `body` and `inertia` are `a`'s), never forced to settle.
    pub fn between(
        a: &PairSide<'a>,
        law: Law,
        material: ContactMaterial<'a>,
        resting_speed: f64,
        timing: ImpactTiming,
    ) -> Self {
        Self::new(a.body, a.inertia, law, material, resting_speed, timing)
    }
}

/// Resolves the impact of ball `a` on ball `b` (states at time `t`): the contact normal is
/// the line of centres, the point on it at `a`'s radius, and each ball's lever arm its radius
/// (the spheres' closed form), also for balls that overlap (by more than
/// [`TOUCHING_ROUNDING`]): `b` is then resolved as if touching `a` along the line of
/// centres, and keeps its position. See [`resolve_bodies`].
pub(crate) fn resolve_balls(
    input: &ImpactInput,
    a: &PairSide,
    b: &PairSide,
    t: f64,
) -> Option<(State, State, [ImpactEvent; 2])> {
    let d = b.state.com - a.state.com;
    let n = d.try_normalize(0.0)?;
    let point = a.state.com + n * a.radius;
    let reach = a.radius + b.radius;
    let com = if (d.norm() - reach).abs() > TOUCHING_ROUNDING * reach {
        a.state.com + n * reach
    } else {
        b.state.com
    };
    let touching = PairSide {
        state: State { com, ..b.state },
        ..*b
    };
    let (after_a, after_b, events) = resolve_bodies(
        input,
        a,
        &touching,
        &BodyContactAt {
            normal: n,
            point,
            points: 1,
        },
        t,
    )?;
    let after_b = State {
        com: b.state.com,
        ..after_b
    };
    Some((after_a, after_b, events))
}

/// Where two bodies touch at an impact between them.
#[derive(Clone, Copy, Debug)]
pub(crate) struct BodyContactAt {
    /// Unit normal from body `a` towards body `b`.
    pub normal: Vector3<f64>,
    /// The contact point (m).
    pub point: Vector3<f64>,
    /// How many contact points it stands for (a flat landing of one on the other).
    pub points: usize,
}

/// Resolves the impact of body `a` on body `b` (states at time `t`) at `contact`, with the
/// model's two-body form (`model::resolve_pair`). `input` gives the law, the material and the
/// resting speed (its `body` and `inertia` are not read). Returns both states after and an
/// event for each body (each naming the other), or `None` when the bodies do not approach at
/// the contact point or the model refuses the input. `PairSide::radius` is not read.
pub(crate) fn resolve_bodies(
    input: &ImpactInput,
    a: &PairSide,
    b: &PairSide,
    at: &BodyContactAt,
    t: f64,
) -> Option<(State, State, [ImpactEvent; 2])> {
    let (n, point) = (at.normal, at.point);
    let contact = model::PairContact {
        normal: n,
        offset_a: point - a.state.com,
        offset_b: point - b.state.com,
    };
    let closing = n.dot(&(body_velocity_at(&a.state, &point) - body_velocity_at(&b.state, &point)));
    if closing.is_nan() || closing <= 0.0 {
        return None;
    }
    let (settled, material) = input.material_at(closing);
    let velocity = |s: &State| BodyVelocity {
        linear: s.v,
        angular: s.w,
    };
    let (body_a, body_b) = (
        a.inertia.body_at(&a.state.rot),
        b.inertia.body_at(&b.state.rot),
    );
    let (va, vb) = (velocity(&a.state), velocity(&b.state));
    let solve = |law| model::resolve_pair(law, &body_a, &va, &body_b, &vb, &contact, &material);
    let impact = match solve(input.law) {
        Ok(impact) => impact,
        // The document's jam, as for a ground: the consistent law, and the event says so.
        Err(ModelError::Jam { .. }) => model::PairImpact {
            fallback: Some(Fallback::Jam),
            ..solve(Law::Consistent).ok()?
        },
        Err(_) => return None,
    };
    let after = |s: &State, v: &BodyVelocity| State {
        v: v.linear,
        w: v.angular,
        ..*s
    };
    let (after_a, after_b) = (after(&a.state, &impact.a), after(&b.state, &impact.b));
    let event = |side: &PairSide, other: &PairSide, before: &State, after: &State, sign: f64| {
        let energy = |s: &State| side.inertia.body_at(&s.rot).kinetic_energy(&velocity(s));
        let impulse = impact.impulse * sign;
        // The normal from the other body into this one.
        let site = Site {
            body: side.body,
            collider: side.collider,
            ground: other.collider,
            body2: Some(other.body),
            normal: n * sign,
            point,
        };
        let resolution = Resolution {
            time: t,
            timing: input.timing,
            contact_points: at.points,
            approach_speed: closing,
            settled,
            material,
        };
        let exchange = Exchange {
            impulse,
            normal_impulse: impact.normal_impulse,
            tangent_impulse: impact.tangent_impulse * sign,
            regime: impact.regime,
            law: impact.law,
            fallback: impact.fallback,
        };
        let energies = (energy(before), energy(after));
        event(EventKind::Impact, &site, &resolution, &exchange, energies)
    };
    let events = [
        event(a, b, &a.state, &after_a, -1.0),
        event(b, a, &b.state, &after_b, 1.0),
    ];
    Some((after_a, after_b, events))
}

/// Where a correction happened: the body, its collider and the ground, the contact normal
/// (from the ground into the body) and point.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Site {
    pub body: RigidBodyHandle,
    pub collider: ColliderHandle,
    /// The ground collider, or the other body's collider.
    pub ground: ColliderHandle,
    /// The other body of a pair; `None` for a ground.
    pub body2: Option<RigidBodyHandle>,
    pub normal: Vector3<f64>,
    pub point: Vector3<f64>,
}

impl Site {
    /// The site of a contact `hit` of `body` (its parts `geom`) with one of `grounds`, at the
    /// ground's surface (the hit's point moved out by its depth).
    pub fn of_hit(
        body: RigidBodyHandle,
        geom: &BodyGeom,
        grounds: &[GroundGeom],
        hit: &Hit,
    ) -> Self {
        Self {
            body,
            collider: geom.parts[hit.part].handle,
            ground: grounds[hit.ground].handle,
            body2: None,
            normal: hit.normal,
            point: hit.point - hit.normal * hit.dist,
        }
    }

    /// The site of an event already reported.
    pub fn of(e: &ImpactEvent) -> Self {
        Self {
            body: e.body,
            collider: e.collider,
            ground: e.ground,
            body2: e.body2,
            normal: crate::plugin::bridge::convert::vec_to_na(e.normal),
            point: crate::plugin::bridge::convert::vec_to_na(e.point),
        }
    }
}

/// The event of a correction (`kind` not `Impact`) at the step's end (`time`) that took the
/// body from `before` to `after`.
pub(crate) fn correction(
    kind: EventKind,
    site: &Site,
    inertia: &Inertia,
    before: &State,
    after: &State,
    time: f64,
) -> ImpactEvent {
    let energy = |s: &State| {
        inertia.body_at(&s.rot).kinetic_energy(&BodyVelocity {
            linear: s.v,
            angular: s.w,
        })
    };
    let impulse = (after.v - before.v) * inertia.mass;
    let normal_impulse = impulse.dot(&site.normal);
    let approach = -site.normal.dot(&body_velocity_at(before, &site.point));
    let resolution = Resolution {
        time,
        timing: if kind == EventKind::Settle {
            ImpactTiming::InStep
        } else {
            ImpactTiming::StepEnd
        },
        contact_points: 0,
        // Not `approach.max(0.0)`: `f64::max` leaves the sign of a zero unspecified, and a
        // body at rest (`approach` -0.0) got +0.0 from an optimised build and -0.0 from an
        // unoptimised one.
        approach_speed: if approach > 0.0 { approach } else { 0.0 },
        settled: true,
        material: Material::new(0.0, 0.0),
    };
    let exchange = Exchange {
        impulse,
        normal_impulse,
        tangent_impulse: impulse - site.normal * normal_impulse,
        regime: model::Regime::Separating,
        law: Law::Consistent,
        fallback: None,
    };
    event(
        kind,
        site,
        &resolution,
        &exchange,
        (energy(before), energy(after)),
    )
}

/// The [`EventKind::Released`] event of a rolling ball handed to rapier's contact at `time`
/// (`StepStart` at 0, or `StepEnd` at `dt`) in `state`, which the plugin does not change.
pub(crate) fn released(site: &Site, inertia: &Inertia, state: &State, time: f64) -> ImpactEvent {
    let mut event = correction(EventKind::Released, site, inertia, state, state, time);
    if time == 0.0 {
        event.timing = ImpactTiming::StepStart;
    }
    event
}

/// How an impact was resolved: when, at how many contact points, how fast it approached,
/// whether it settled, and the material it was resolved with (`e = 0` if it settled).
struct Resolution {
    time: f64,
    timing: ImpactTiming,
    contact_points: usize,
    approach_speed: f64,
    settled: bool,
    material: Material,
}

/// The impulse an event reports, and what produced it.
struct Exchange {
    impulse: Vector3<f64>,
    normal_impulse: f64,
    tangent_impulse: Vector3<f64>,
    regime: model::Regime,
    law: Law,
    fallback: Option<Fallback>,
}

/// The one place an [`ImpactEvent`] is made: what changed a body at `site`, resolved as
/// `resolution` says, with the impulse `exchange` and the kinetic energies before and after.
fn event(
    kind: EventKind,
    site: &Site,
    resolution: &Resolution,
    exchange: &Exchange,
    (ke_before, ke_after): (f64, f64),
) -> ImpactEvent {
    ImpactEvent {
        kind,
        body: site.body,
        collider: site.collider,
        ground: site.ground,
        body2: site.body2,
        time: resolution.time,
        timing: resolution.timing,
        point: vec_from_na(&site.point),
        normal: vec_from_na(&site.normal),
        contact_points: resolution.contact_points,
        approach_speed: resolution.approach_speed,
        impulse: vec_from_na(&exchange.impulse),
        normal_impulse: exchange.normal_impulse,
        tangent_impulse: vec_from_na(&exchange.tangent_impulse),
        regime: exchange.regime,
        law: exchange.law,
        fallback: exchange.fallback,
        settled: resolution.settled,
        restitution: resolution.material.restitution,
        friction: resolution.material.friction,
        tangential_restitution: resolution.material.tangential_restitution,
        ke_before,
        ke_after,
    }
}
