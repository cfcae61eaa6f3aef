//! Shared checks of the scene tests (issue 5): after every step, every body is finite, no
//! dynamic body is below the ground by more than rapier's allowed linear error, and no impact
//! event with `e <= 1` gains kinetic energy. Ground surfaces are at `y = GROUND_Y` unless a
//! scene says otherwise.

// Precision-generic: `Real` is f32 or f64 (feature `f64`), so conversions that are
// widening in one build are identities in the other.
#![allow(
    clippy::useless_conversion,
    clippy::unnecessary_cast,
    dead_code,
    unused_imports
)]

use approx::abs_diff_eq;
use rapier_impact::rapier::na::Unit;
use rapier_impact::rapier::prelude::*;
use rapier_impact::{
    EventKind, GroundMaterial, ImpactConfig, ImpactEvent, ImpactPlugin, TimingMode,
};
use std::hash::{DefaultHasher, Hash, Hasher};

pub const G: f64 = 9.81;
pub const F64: bool = cfg!(feature = "f64");

/// Relative tolerance on an impact's kinetic-energy change with `e <= 1`: the model works in
/// `f64` in both builds, so this is rounding of a few dozen flops.
pub const ENERGY_REL_TOL: f64 = 1e-9;
/// Absolute floor of that tolerance (J), for impacts of near-zero energy.
pub const ENERGY_ABS_TOL: f64 = 1e-15;
/// Rounding allowed on top of rapier's allowed linear error when checking penetration (m):
/// positions are `Real`, so a few ulps of the coordinates at hand.
pub fn penetration_rounding(scale: f64) -> f64 {
    if F64 {
        1e-12 * scale.max(1.0)
    } else {
        1e-6 * scale.max(1.0)
    }
}

#[allow(clippy::unnecessary_cast)]
pub fn real(x: f64) -> Real {
    x as Real
}

#[allow(clippy::unnecessary_cast)]
pub fn wide(x: Real) -> f64 {
    x as f64
}

pub fn up() -> Unit<Vector> {
    Unit::new_unchecked(Vector::Y)
}

/// A world with gravity `gravity` (m/s^2) along -y and rapier's other defaults.
pub fn world_with_gravity(gravity: f64) -> PhysicsWorld {
    PhysicsWorld {
        gravity: Vector::new(0.0, real(-gravity), 0.0),
        ..Default::default()
    }
}

pub fn plugin(timing: TimingMode) -> ImpactPlugin {
    ImpactPlugin::new(ImpactConfig::default().with_timing(timing)).unwrap()
}

/// [`plugin`] with `ground` registered at its collider's own restitution and friction.
pub fn plugin_on(world: &PhysicsWorld, ground: ColliderHandle, timing: TimingMode) -> ImpactPlugin {
    let mut p = plugin(timing);
    p.add_ground(&world.bodies, &world.colliders, ground)
        .unwrap();
    p
}

/// [`plugin`] with `ground` registered under the material `(restitution, friction)`.
pub fn plugin_with_material(
    world: &PhysicsWorld,
    ground: ColliderHandle,
    timing: TimingMode,
    restitution: f64,
    friction: f64,
) -> ImpactPlugin {
    let mut p = plugin(timing);
    p.add_ground_with_material(
        &world.bodies,
        &world.colliders,
        ground,
        GroundMaterial::new(restitution, friction),
    )
    .unwrap();
    p
}

/// What the checks measured over a run.
#[derive(Clone, Debug, Default)]
pub struct Stats {
    pub steps: usize,
    /// Deepest any dynamic body went below its ground surface (m; 0 if never).
    pub max_penetration: f64,
    /// Largest relative kinetic-energy change `(ke_after - ke_before) / ke_before` over the
    /// impacts with `e <= 1` (negative: every impact lost energy).
    pub worst_energy_change: f64,
    /// Impact events, and those not `settled` (bounces).
    pub events: usize,
    pub bounces: usize,
    /// Correction events (push-outs, settles, energy caps).
    pub corrections: usize,
    /// Step-end writes checked against their event (`check_written`).
    pub checked_writes: usize,
    /// Largest `|P_t| / (mu P_n)` over the events with friction (<= 1 inside the cone).
    pub worst_cone_ratio: f64,
}

impl Stats {
    pub fn new() -> Self {
        Self {
            worst_energy_change: f64::NEG_INFINITY,
            ..Default::default()
        }
    }

    pub fn summary(&self) -> String {
        format!(
            "steps {}, max penetration {:.3e} m, worst impact KE change {:+.3e} (relative), events {} (bounces {}), corrections {} (writes checked {}), worst |Pt|/(mu Pn) {:.6}",
            self.steps,
            self.max_penetration,
            self.worst_energy_change,
            self.events,
            self.bounces,
            self.corrections,
            self.checked_writes,
            self.worst_cone_ratio
        )
    }
}

/// Every body's pose and velocities are finite.
pub fn assert_finite(world: &PhysicsWorld, label: &str) {
    for (h, rb) in world.bodies.iter() {
        let t = rb.translation();
        let r = rb.rotation();
        let v = rb.linvel();
        let w = rb.angvel();
        let ok = [
            t.x, t.y, t.z, r.x, r.y, r.z, r.w, v.x, v.y, v.z, w.x, w.y, w.z,
        ]
        .iter()
        .all(|x| x.is_finite());
        assert!(
            ok,
            "{label}: body {h:?} is not finite: t {t:?} r {r:?} v {v:?} w {w:?}"
        );
    }
}

/// Deepest point of any dynamic body's collider below `ground_y` (m; <= 0 when above):
/// the collider's world AABB bottom, exact for balls, capsules and boxes.
pub fn penetration(world: &PhysicsWorld, ground_y: f64) -> f64 {
    deepest_body(world, ground_y).0
}

/// [`penetration`] and the body it belongs to.
pub fn deepest_body(world: &PhysicsWorld, ground_y: f64) -> (f64, Option<RigidBodyHandle>) {
    let mut deepest = (f64::NEG_INFINITY, None);
    for (_, co) in world.colliders.iter() {
        let Some(parent) = co.parent() else { continue };
        let Some(rb) = world.bodies.get(parent) else {
            continue;
        };
        if !rb.is_dynamic() || !co.is_enabled() || co.is_sensor() {
            continue;
        }
        let bottom = wide(co.compute_aabb().mins.y);
        if ground_y - bottom > deepest.0 {
            deepest = (ground_y - bottom, Some(parent));
        }
    }
    deepest
}

/// Does the body touch another dynamic body in rapier's contact graph?
pub fn touches_a_body(world: &PhysicsWorld, body: RigidBodyHandle) -> bool {
    world.bodies[body].colliders().iter().any(|c| {
        world.narrow_phase.contact_pairs_with(*c).any(|pair| {
            let other = if pair.collider1 == *c {
                pair.collider2
            } else {
                pair.collider1
            };
            pair.has_any_active_contact()
                && world
                    .colliders
                    .get(other)
                    .and_then(|co| co.parent())
                    .is_some_and(|p| world.bodies[p].is_dynamic())
        })
    })
}

/// Checks one event: finite, a pushing normal impulse (an energy cap scales the velocity
/// along the normal down, whichever way it points, so its change may pull), friction inside the
/// cone, and no kinetic-energy gain when `e <= 1` (on a fixed ground); a correction (push-out,
/// settle, energy cap) never gains kinetic energy.
pub fn check_event(ev: &ImpactEvent, stats: &mut Stats, label: &str) {
    let nums = [
        ev.time,
        ev.approach_speed,
        ev.normal_impulse,
        ev.ke_before,
        ev.ke_after,
        wide(ev.impulse.x),
        wide(ev.impulse.y),
        wide(ev.impulse.z),
    ];
    assert!(
        nums.iter().all(|x| x.is_finite()),
        "{label}: non-finite event {ev:?}"
    );
    assert!(
        ev.normal_impulse >= 0.0 || ev.kind == EventKind::EnergyCap,
        "{label}: pulling normal impulse {ev:?}"
    );
    if ev.kind != EventKind::Impact {
        assert!(
            ev.ke_after <= ev.ke_before,
            "{label}: a correction gained kinetic energy {ev:?}"
        );
        stats.corrections += 1;
        return;
    }
    stats.events += 1;
    if !ev.settled {
        stats.bounces += 1;
    }
    if ev.friction > 0.0 && ev.normal_impulse > 0.0 {
        let jt = wide(ev.tangent_impulse.length());
        let ratio = jt / (ev.friction * ev.normal_impulse);
        if ev.normal_impulse > 1e-12 {
            stats.worst_cone_ratio = stats.worst_cone_ratio.max(ratio);
        }
        // Relative rounding (the event's vectors are `Real`), and an absolute floor for
        // impulses of no physical size (1e-21 N s seen, 1.6e-5 relative off the cone).
        assert!(
            jt <= ev.friction * ev.normal_impulse * (1.0 + 1e-6) + 1e-15,
            "{label}: friction impulse outside the cone: |Pt| = {jt:e}, mu Pn = {:e}",
            ev.friction * ev.normal_impulse
        );
    }
    // One ball of an impact between two bodies may gain what the other loses: the pair's
    // energy is checked by `check_pair_energy`.
    if ev.restitution <= 1.0 && ev.body2.is_none() {
        let gain = ev.ke_after - ev.ke_before;
        let rel = if ev.ke_before > 0.0 {
            gain / ev.ke_before
        } else {
            0.0
        };
        stats.worst_energy_change = stats.worst_energy_change.max(rel);
        assert!(
            gain <= ENERGY_REL_TOL * ev.ke_before + ENERGY_ABS_TOL,
            "{label}: impact gained energy: KE {:e} -> {:e} J ({rel:+e} relative, tolerance {ENERGY_REL_TOL:e}), e = {}, mu = {}, regime {:?}, law {:?}",
            ev.ke_before,
            ev.ke_after,
            ev.restitution,
            ev.friction,
            ev.regime,
            ev.law
        );
    }
}

/// The impacts between two bodies in a step's events (one event per body, side by side, at
/// the same point): the two bodies together gain no kinetic energy when `e <= 1`. The two
/// events of one impact are taken together, and then both skipped: a pair resolved twice in
/// a step (`Step` mode's passes along a chain) gives four events in a row, and the second and
/// third are halves of different impacts.
pub fn check_pair_energy(events: &[ImpactEvent], label: &str) {
    let mut i = 0;
    while i + 1 < events.len() {
        let (a, b) = (&events[i], &events[i + 1]);
        let pair = a.kind == EventKind::Impact
            && b.kind == EventKind::Impact
            && a.body2 == Some(b.body)
            && b.body2 == Some(a.body)
            && a.time == b.time
            && a.point == b.point;
        if !pair {
            i += 1;
            continue;
        }
        if a.restitution <= 1.0 {
            let (before, after) = (a.ke_before + b.ke_before, a.ke_after + b.ke_after);
            assert!(
                after - before <= ENERGY_REL_TOL * before + ENERGY_ABS_TOL,
                "{label}: impact between bodies gained energy: {before:e} -> {after:e} J: {a:?} {b:?}"
            );
        }
        i += 2;
    }
}

/// The per-step checks: finite state, penetration within rapier's allowed linear error (plus
/// rounding), and every event of the step.
pub fn check_step(
    world: &PhysicsWorld,
    events: &[ImpactEvent],
    ground_y: f64,
    stats: &mut Stats,
    label: &str,
) {
    stats.steps += 1;
    assert_finite(world, label);
    let allowed = wide(world.integration_parameters.allowed_linear_error());
    for ev in events {
        check_event(ev, stats, label);
    }
    check_written(world, events, stats, label);
    let (depth, body) = deepest_body(world, ground_y);
    stats.max_penetration = stats.max_penetration.max(depth);
    if depth > allowed + penetration_rounding(ground_y.abs()) {
        let rb = body.map(|h| &world.bodies[h]);
        let mine: Vec<&ImpactEvent> = events.iter().filter(|e| Some(e.body) == body).collect();
        panic!(
            "{label}: step {}: body {body:?} is {depth:e} m below the ground (allowed linear error {allowed:e} m); pose {:?}, v {:?}, w {:?}; its events this step: {mine:?}",
            stats.steps,
            rb.map(|rb| *rb.position()),
            rb.map(|rb| rb.linvel()),
            rb.map(|rb| rb.angvel()),
        );
    }
}

/// Every change is reported, and the last one's after-state is what was written: for each
/// body whose last event of the step is at the step's end (no flight follows it), its kinetic
/// energy as rapier now holds it equals the event's `ke_after`, to the rounding of rapier's
/// precision.
pub fn check_written(world: &PhysicsWorld, events: &[ImpactEvent], stats: &mut Stats, label: &str) {
    for (k, ev) in events.iter().enumerate() {
        let last = !events[k + 1..].iter().any(|later| later.body == ev.body);
        if !last || ev.timing != rapier_impact::ImpactTiming::StepEnd {
            continue;
        }
        let Some(rb) = world.bodies.get(ev.body) else {
            continue;
        };
        let written = kinetic_energy_f64(rb);
        let rounding = if F64 { 1e-12 } else { 1e-5 };
        assert!(
            abs_diff_eq!(
                written,
                ev.ke_after,
                epsilon = rounding * written.max(ev.ke_after) + 1e-12
            ),
            "{label}: step {}: body {:?} was written with KE {written:e} J, its last event says {:e} J: {ev:?}",
            stats.steps,
            ev.body,
            ev.ke_after
        );
        stats.checked_writes += 1;
    }
}

/// A body's kinetic energy (J) from its velocities, mass and principal inertia at its current
/// rotation, in `f64`: rapier's own `kinetic_energy` inverts its world inverse inertia in
/// `Real` (ill-conditioned for a thin body: 1e-5 off for a 4 mm capsule 30 cm long) and that
/// inertia is the one of the last step's rotation until the next step.
///
/// A spin about a locked rotation axis holds no energy (no impulse changes it): for a body
/// with one, the rotational energy is the model's, on the world inverse inertia with the
/// locked axes' rows and columns zeroed, as rapier's solver takes it.
pub fn kinetic_energy_f64(rb: &RigidBody) -> f64 {
    let m = &rb.mass_properties().local_mprops;
    let v = rb.linvel();
    let w = rb.angvel();
    let frame = *rb.rotation() * m.principal_inertia_local_frame;
    let i = m.principal_inertia();
    let linear = wide(rb.mass()) * (wide(v.x).powi(2) + wide(v.y).powi(2) + wide(v.z).powi(2));
    let locked = [
        LockedAxes::ROTATION_LOCKED_X,
        LockedAxes::ROTATION_LOCKED_Y,
        LockedAxes::ROTATION_LOCKED_Z,
    ]
    .map(|axis| rb.locked_axes().contains(axis));
    if locked.contains(&true) {
        use rapier_impact::model::{Body, BodyVelocity};
        use rapier_impact::na::{Matrix3, Quaternion, UnitQuaternion, Vector3};
        let (x, y, z, s) = (wide(frame.x), wide(frame.y), wide(frame.z), wide(frame.w));
        let turn =
            UnitQuaternion::from_quaternion(Quaternion::new(s, x, y, z)).to_rotation_matrix();
        let principal = Vector3::new(1.0 / wide(i.x), 1.0 / wide(i.y), 1.0 / wide(i.z));
        let mut inv =
            turn.matrix() * Matrix3::from_diagonal(&principal) * turn.matrix().transpose();
        for (axis, _) in locked.iter().enumerate().filter(|(_, l)| **l) {
            inv.row_mut(axis).fill(0.0);
            inv.column_mut(axis).fill(0.0);
        }
        let spin = BodyVelocity {
            linear: Vector3::zeros(),
            angular: Vector3::new(wide(w.x), wide(w.y), wide(w.z)),
        };
        return 0.5 * linear + Body::new(1.0, inv).kinetic_energy(&spin);
    }
    // The spin in the principal frame.
    let wl = frame.inverse() * w;
    let angular = wide(i.x) * wide(wl.x).powi(2)
        + wide(i.y) * wide(wl.y).powi(2)
        + wide(i.z) * wide(wl.z).powi(2);
    0.5 * (linear + angular)
}

/// One step with the plugin and the checks.
pub fn step_checked(
    world: &mut PhysicsWorld,
    plugin: &mut ImpactPlugin,
    ground_y: f64,
    stats: &mut Stats,
    label: &str,
) {
    plugin.step(world);
    check_step(world, plugin.events(), ground_y, stats, label);
}

/// The mass-ratio scene: a light box (2 m x 0.2 m x 2 m, density 1e-2: 8 kg) resting on a
/// half-space ground (e = 0.5, mu = 0.5) and a heavy one (a 1 m cube, density 1e4: 10 t, 1.25e6
/// times the light one) dropped on it from `drop_height`, stepped 600 times (10 s) with the
/// plugin in `timing` (every event checked) or rapier alone, every body finite at every step.
/// Returns the mass ratio and the stats; their `max_penetration` is the deepest the boxes went
/// below the ground.
pub fn mass_ratio_run(drop_height: f64, timing: Option<TimingMode>, label: &str) -> (f64, Stats) {
    mass_ratio_run_with(drop_height, timing, 0, label)
}

/// [`mass_ratio_run`] with the light box in dominance group `light_dominance` (the heavy box
/// stays in group 0).
pub fn mass_ratio_run_with(
    drop_height: f64,
    timing: Option<TimingMode>,
    light_dominance: i8,
    label: &str,
) -> (f64, Stats) {
    let mut world = PhysicsWorld::default();
    let (_, ground) = world.insert(
        RigidBodyBuilder::fixed(),
        ColliderBuilder::halfspace(up())
            .restitution(0.5)
            .friction(0.5),
    );
    let (light, _) = world.insert(
        RigidBodyBuilder::dynamic()
            .translation(Vector::new(0.0, 0.1, 0.0))
            .dominance_group(light_dominance),
        ColliderBuilder::cuboid(1.0, 0.1, 1.0)
            .density(1e-2)
            .restitution(0.5),
    );
    let (heavy, _) = world.insert(
        RigidBodyBuilder::dynamic().translation(Vector::new(0.0, real(0.7 + drop_height), 0.0)),
        ColliderBuilder::cuboid(0.5, 0.5, 0.5)
            .density(1e4)
            .restitution(0.5),
    );
    let ratio = wide(world.bodies[heavy].mass() / world.bodies[light].mass());
    let mut p = timing.map(|t| plugin_on(&world, ground, t));
    let mut stats = Stats::new();
    for _ in 0..600 {
        match p.as_mut() {
            Some(p) => {
                p.step(&mut world);
                for ev in p.events() {
                    check_event(ev, &mut stats, label);
                }
            }
            None => world.step(),
        }
        assert_finite(&world, label);
        stats.steps += 1;
        stats.max_penetration = stats.max_penetration.max(penetration(&world, 0.0));
    }
    (ratio, stats)
}

/// A hash of every body's pose and velocities, bit for bit.
pub fn state_hash(world: &PhysicsWorld) -> u64 {
    let mut h = DefaultHasher::new();
    for (handle, rb) in world.bodies.iter() {
        handle.into_raw_parts().hash(&mut h);
        let t = rb.translation();
        let r = rb.rotation();
        let v = rb.linvel();
        let w = rb.angvel();
        for x in [
            t.x, t.y, t.z, r.x, r.y, r.z, r.w, v.x, v.y, v.z, w.x, w.y, w.z,
        ] {
            x.to_bits().hash(&mut h);
        }
        rb.is_sleeping().hash(&mut h);
    }
    h.finish()
}

/// A hash of the events of a step, bit for bit.
pub fn events_hash(events: &[ImpactEvent]) -> u64 {
    let mut h = DefaultHasher::new();
    for ev in events {
        ev.body.into_raw_parts().hash(&mut h);
        ev.collider.into_raw_parts().hash(&mut h);
        for x in [
            ev.time,
            ev.normal_impulse,
            ev.ke_before,
            ev.ke_after,
            ev.approach_speed,
        ] {
            x.to_bits().hash(&mut h);
        }
    }
    h.finish()
}

/// Kinetic energy of every dynamic body (J), in `f64`.
pub fn kinetic_energy(world: &PhysicsWorld) -> f64 {
    world
        .bodies
        .iter()
        .filter(|(_, rb)| rb.is_dynamic())
        .map(|(_, rb)| wide(rb.kinetic_energy()))
        .sum()
}

/// A flat square trimesh of half size `half` at `y = 0`, normals up.
pub fn trimesh_ground(half: f64) -> ColliderBuilder {
    let l = real(half);
    let vertices = vec![
        Vector::new(-l, 0.0, -l),
        Vector::new(l, 0.0, -l),
        Vector::new(l, 0.0, l),
        Vector::new(-l, 0.0, l),
    ];
    ColliderBuilder::trimesh(vertices, vec![[0, 3, 2], [0, 2, 1]]).unwrap()
}

/// A thin cuboid slab of half size `half`, half thickness `thick`, top at `y = 0`.
pub fn slab_ground(half: f64, thick: f64) -> ColliderBuilder {
    ColliderBuilder::cuboid(real(half), real(thick), real(half)).translation(Vector::new(
        0.0,
        real(-thick),
        0.0,
    ))
}

/// A V-shaped crease along z of one trimesh: two faces `y = |x| tan` meeting at the origin,
/// over `|x|, |z| <= half` (m).
pub fn crease_trimesh(half: f64, tan: f64) -> ColliderBuilder {
    let (w, h) = (real(half), real(half * tan));
    let vertices = vec![
        Vector::new(-w, h, -w),
        Vector::new(0.0, 0.0, -w),
        Vector::new(w, h, -w),
        Vector::new(-w, h, w),
        Vector::new(0.0, 0.0, w),
        Vector::new(w, h, w),
    ];
    let triangles = vec![[0, 3, 4], [0, 4, 1], [1, 4, 5], [1, 5, 2]];
    ColliderBuilder::trimesh(vertices, triangles).unwrap()
}

/// Four fixed walls, 10 cm thick and 2 m high, around the square `|x|, |z| < half` (m), of
/// restitution 0.7 and friction 0.5: the box a pile is dropped into.
pub fn walled_box(world: &mut PhysicsWorld, half: f64) {
    for (x, z, hx, hz) in [
        (half + 0.05, 0.0, 0.05, half + 0.1),
        (-half - 0.05, 0.0, 0.05, half + 0.1),
        (0.0, half + 0.05, half + 0.1, 0.05),
        (0.0, -half - 0.05, half + 0.1, 0.05),
    ] {
        world.insert(
            RigidBodyBuilder::fixed().translation(Vector::new(real(x), 1.0, real(z))),
            ColliderBuilder::cuboid(real(hx), 1.0, real(hz))
                .restitution(0.7)
                .friction(0.5),
        );
    }
}

/// A fixed sequence of numbers uniform in `[-half_width, half_width]` (xorshift64 from
/// `seed`, non-zero): the jitter of a scene's layout, the same on every run.
pub fn jitter(seed: u64, half_width: f64) -> impl FnMut() -> f64 {
    let mut state = seed;
    move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        ((state >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0) * half_width
    }
}

/// A copy of what rapier's serialization keeps of a world: every set and the islands, the
/// broad and narrow phases; the pipelines and the CCD solver (workspaces) new.
pub fn saved_world(world: &PhysicsWorld) -> PhysicsWorld {
    PhysicsWorld {
        gravity: world.gravity,
        integration_parameters: world.integration_parameters,
        islands: world.islands.clone(),
        broad_phase: world.broad_phase.clone(),
        narrow_phase: world.narrow_phase.clone(),
        bodies: world.bodies.clone(),
        colliders: world.colliders.clone(),
        impulse_joints: world.impulse_joints.clone(),
        multibody_joints: world.multibody_joints.clone(),
        soft_bodies: world.soft_bodies.clone(),
        ..PhysicsWorld::default()
    }
}

/// The configuration of a random-scene property test: `default_cases` cases unless the
/// environment variable `cases_var` gives another count, drawn from a fixed seed, so that
/// every run of the suite, CI's included, checks the same scenes and a failure it reports is
/// one anyone can replay. `RAPIER_IMPACT_PROPTEST_SEED` draws other scenes for a longer
/// search: a number picks that seed, `random` a fresh one each run. A value that is neither
/// stops the test at once rather than falling back to the fixed seed unseen.
pub fn random_scene_config(cases_var: &str, default_cases: u32) -> proptest::test_runner::Config {
    use proptest::test_runner::{Config, RngAlgorithm, RngSeed};
    fn number<T: std::str::FromStr>(var: &str, value: String) -> T {
        value
            .parse()
            .unwrap_or_else(|_| panic!("{var}={value:?}: expected a whole number"))
    }
    let cases = std::env::var(cases_var)
        .map(|v| number(cases_var, v))
        .unwrap_or(default_cases);
    let seed_var = "RAPIER_IMPACT_PROPTEST_SEED";
    let rng_seed = match std::env::var(seed_var) {
        Err(_) => RngSeed::Fixed(RANDOM_SCENE_SEED),
        Ok(v) if v == "random" => RngSeed::Random,
        Ok(v) => RngSeed::Fixed(number(seed_var, v)),
    };
    Config {
        cases,
        rng_algorithm: RngAlgorithm::ChaCha,
        rng_seed,
        ..Config::default()
    }
}

/// The seed of the random-scene tests' cases when `RAPIER_IMPACT_PROPTEST_SEED` is not set.
pub const RANDOM_SCENE_SEED: u64 = 0x5eed_5ce0;
