//! The plan's members: the opted-in bodies with one enabled, solid, convex collider, as the
//! plan sees them at the step's start, and what is computed once for each (whether it moves,
//! its sphere swept over the step, its leaf in the pair index).

use super::PairInputs;
use crate::motion::State;
use crate::plugin::bridge::convert::{to_f64, to_real, vec_to_na};
use crate::plugin::config::coefficients_in_range;
use crate::plugin::events::Diagnostic;
use crate::plugin::queries::geometry::BodyGeom;
use crate::plugin::queries::observe::{body_geom, centred, rapier_state};
use crate::plugin::state::handles::Slotted;
use crate::rapier::math::Vector;
use crate::rapier::parry::bounding_volume::Aabb;
use crate::rapier::prelude::{
    CoefficientCombineRule, ColliderHandle, ColliderSet, RigidBody, RigidBodyHandle, RigidBodySet,
};
use nalgebra::Vector3;

/// A body that takes part in impacts between bodies, as the plan sees it at the step start
/// (named for the common case). The list of them is written for every member each step: its
/// centre of mass and velocity are kept as rapier holds them (read in `f64`, converted exactly,
/// through [`Self::com`] and [`Self::v`]), and what only other shapes have is boxed, so that a
/// member takes 72 bytes in single precision.
pub(super) struct Ball<'a> {
    pub body: RigidBodyHandle,
    pub collider: ColliderHandle,
    com: Vector,
    v: Vector,
    /// Radius, skin included (m): a centred ball's, or for any other shape the radius of a
    /// sphere about the centre of mass that holds it (its rotation stays inside).
    pub radius: f64,
    pub asleep: bool,
    /// Its body's dominance group, as rapier's contacts weigh it (`effective_dominance_group`).
    pub dominance: i16,
    /// The acceleration of its user force (m/s^2).
    pub force_accel: f64,
    /// Not a centred ball: its collider and state, for the contact queries.
    pub shape: Option<Box<Shape<'a>>>,
}

/// A member that is not a centred ball, as the contact queries read it.
pub(super) struct Shape<'a> {
    pub geom: BodyGeom<'a>,
    pub state: State,
    /// How fast its turning can move a surface point: the angular speed times the radius
    /// (m/s).
    turn_speed: f64,
}

impl Ball<'_> {
    /// Its centre of mass at the step's start (m).
    #[inline]
    pub fn com(&self) -> Vector3<f64> {
        vec_to_na(self.com)
    }

    /// Its centre of mass at the step's start in rapier's numbers (m).
    #[inline]
    pub fn rapier_com(&self) -> Vector {
        self.com
    }

    /// Its velocity at the step's start (m/s).
    #[inline]
    pub fn v(&self) -> Vector3<f64> {
        vec_to_na(self.v)
    }

    /// How fast its turning can move a surface point (m/s): 0 for a centred ball.
    #[inline]
    fn turn_speed(&self) -> f64 {
        self.shape.as_ref().map_or(0.0, |shape| shape.turn_speed)
    }
}

/// The step's members and what every later part of the plan reads of them. Built once by
/// [`Members::gather`], read-only afterwards; every table is indexed like `balls`.
pub(super) struct Members<'a> {
    pub balls: Vec<Ball<'a>>,
    /// Faster than half the resting speed (its centre's speed plus its turn's reach): a pair
    /// approaching faster than the resting speed has at least one mover.
    pub is_mover: Vec<bool>,
    /// How many of the balls are movers.
    pub movers: usize,
    /// Some ball's restitution can make a pair's combined restitution reach 1 (its own of 1,
    /// or a summing combine rule): rapier then bounces any approach, so every overlapping
    /// pair is looked at.
    pub any_elastic: bool,
    /// Each ball's sphere swept over the step (m): `radius + |v| dt + (|g| + |a_force|) dt^2
    /// + margin`, a bound on its travel under gravity and its user force.
    pub swept: Vec<f64>,
    /// Each ball's leaf in the pair index: its body's slot and its swept sphere's box.
    pub leaves: Vec<(u32, Aabb)>,
}

impl<'a> Members<'a> {
    /// The members of the step, or `None` when no pair can be planned (no body takes pairs,
    /// fewer than two members, or none of them awake: two sleeping bodies cannot meet).
    /// Reads the bodies, their colliders and the registry; writes only `refused`: an opted-in
    /// body whose collider's coefficients are out of the plugin's ranges is no member (its
    /// pairs stay rapier's), and is listed there.
    pub(super) fn gather<H>(
        bodies: &RigidBodySet,
        inputs: &PairInputs<'a, H>,
        refused: &mut Vec<Diagnostic>,
    ) -> Option<Self> {
        let registry = inputs.registry;
        if !registry.any_pairs()
            || !bodies
                .iter()
                .any(|(handle, rb)| !rb.is_sleeping() && registry.takes_pairs(handle, rb))
        {
            return None;
        }
        // Sized for every opted-in body at once: grown ball by ball, the list (rebuilt each
        // step) was copied about as many times as it doubled.
        let mut balls: Vec<Ball> = Vec::with_capacity(registry.pairs_capacity(bodies.len()));
        let (mut any_elastic, mut any_awake) = (false, false);
        for (handle, rb) in bodies.iter() {
            if !registry.takes_pairs(handle, rb) {
                continue;
            }
            if let Some((ball, elastic)) = member(handle, rb, inputs.colliders, refused) {
                any_elastic |= elastic;
                any_awake |= !ball.asleep;
                balls.push(ball);
            }
        }
        if balls.len() < 2 || !any_awake {
            return None;
        }
        Some(Self::of_balls(balls, any_elastic, inputs))
    }

    /// The members of these balls: each one's mover flag, swept sphere and leaf, in one pass.
    fn of_balls<H>(balls: Vec<Ball<'a>>, any_elastic: bool, inputs: &PairInputs<'a, H>) -> Self {
        let policy = inputs.policy;
        let (margin, dt) = (policy.contact_margin(), inputs.dt);
        let g_len = inputs.gravity.norm();
        let mut is_mover = Vec::with_capacity(balls.len());
        let mut swept = Vec::with_capacity(balls.len());
        let mut leaves = Vec::with_capacity(balls.len());
        for b in &balls {
            let speed = b.v().norm();
            is_mover.push(2.0 * (speed + b.turn_speed()) > policy.resting_speed);
            let reach = b.radius + speed * dt + (g_len + b.force_accel) * dt * dt + margin;
            swept.push(reach);
            let half = to_real(reach);
            leaves.push((
                // A leaf is keyed by its body's arena slot (an arena index is a `u32`).
                b.body.slot() as u32,
                Aabb::from_half_extents(b.com, Vector::splat(half)),
            ));
        }
        let movers = is_mover.iter().filter(|m| **m).count();
        Members {
            balls,
            is_mover,
            movers,
            any_elastic,
            swept,
            leaves,
        }
    }
}

/// The member of one opted-in body, and whether its restitution can make a pair's combined
/// restitution reach 1 (its own of 1, or a summing combine rule); or `None` when its pairs
/// stay rapier's: not exactly one collider, a disabled or sensor collider, coefficients out
/// of range (listed in `refused`), or a shape that is neither a centred ball (met in
/// closed form) nor convex (parry's contact manifolds of a compound or a mesh are in their
/// pieces' frames). Reads the body and its collider only.
fn member<'a>(
    handle: RigidBodyHandle,
    rb: &RigidBody,
    colliders: &'a ColliderSet,
    refused: &mut Vec<Diagnostic>,
) -> Option<(Ball<'a>, bool)> {
    let [collider] = rb.colliders() else {
        return None;
    };
    let co = colliders.get(*collider)?;
    if !co.is_enabled() || co.is_sensor() {
        return None;
    }
    let (restitution, friction) = (to_f64(co.restitution()), to_f64(co.friction()));
    if !coefficients_in_range(restitution, friction) {
        refused.push(Diagnostic::CoefficientsOutOfRange {
            collider: *collider,
            restitution,
            friction,
        });
        return None;
    }
    // Centred on the centre of mass in the body's frame, where both are exact.
    let centre = co
        .position_wrt_parent()
        .map_or(Vector3::zeros(), |pose| vec_to_na(pose.translation));
    let local_com = vec_to_na(rb.local_center_of_mass());
    let ball = co
        .shape()
        .as_ball()
        .map(|b| to_f64(b.radius))
        .filter(|r| centred(&(centre - local_com), *r));
    let (radius, shape) = match ball {
        Some(r) => (r + to_f64(co.contact_skin()), None),
        None if !co.shape().is_convex() => return None,
        None => {
            let geom = body_geom(rb, colliders, &local_com);
            let radius = geom.radius;
            let shape = Shape {
                geom,
                state: rapier_state(rb),
                turn_speed: to_f64(rb.angvel().length()) * radius,
            };
            (radius, Some(Box::new(shape)))
        }
    };
    let elastic = co.restitution() >= 1.0
        || co.restitution_combine_rule() == CoefficientCombineRule::ClampedSum;
    let ball = Ball {
        body: handle,
        collider: *collider,
        com: rb.center_of_mass(),
        v: rb.linvel(),
        radius,
        asleep: rb.is_sleeping(),
        dominance: rb.effective_dominance_group(),
        force_accel: to_f64(rb.user_force().length()) / to_f64(rb.mass()),
        shape,
    };
    Some((ball, elastic))
}

/// A member's colliders and state for a contact query: kept in the member for a shape that
/// is not a centred ball, made from the body otherwise.
pub(super) fn geom_state<'g, 'a>(
    m: &'g Ball<'a>,
    bodies: &RigidBodySet,
    colliders: &'a ColliderSet,
) -> (GeomRef<'g, 'a>, State) {
    match &m.shape {
        Some(shape) => (GeomRef::Borrowed(&shape.geom), shape.state),
        None => {
            let rb = &bodies[m.body];
            let local_com = vec_to_na(rb.local_center_of_mass());
            (
                GeomRef::Owned(body_geom(rb, colliders, &local_com)),
                rapier_state(rb),
            )
        }
    }
}

/// A body's colliders for a contact query: kept in the plan's list, or made for the query.
pub(super) enum GeomRef<'g, 'a> {
    Borrowed(&'g BodyGeom<'a>),
    Owned(BodyGeom<'a>),
}

impl<'a> GeomRef<'_, 'a> {
    pub(super) fn get(&self) -> &BodyGeom<'a> {
        match self {
            GeomRef::Borrowed(g) => g,
            GeomRef::Owned(g) => g,
        }
    }
}
