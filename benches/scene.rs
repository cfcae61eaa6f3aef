//! Milliseconds per step of whole scenes, rapier alone against the plugin in each timing mode.
//! `cargo bench --bench scene`; a filter picks groups, e.g.
//! `cargo bench --bench scene -- bouncing/1000`.
//!
//! Groups of N balls (radius 5 cm, e = 0.8, mu = 0.5, dt = 1/60, rapier's default parameters)
//! on a fixed cuboid ground, with the benchmark named `GROUP/N/MODE`, `MODE` = `rapier`
//! (rapier alone, no plugin), `step`, `toi` or `exact`. The `many_balls` scenes of the
//! cost model in `docs/guide.md` ("Cost") (`--scene bouncing|idle|pile|rolling`, the pile with
//! `--pairs`, `--tiles`) each have a group here; the bouncing scene with `--pairs` has none. `bouncing`, `idle` and `pile` run at N = 100, 1 000 and 10 000 in every mode;
//! the others at one size, in the modes named:
//!
//! - `bouncing`: one layer of balls 15 cm apart (they never touch each other), released
//!   5-45 cm above the ground (seeded jitter), so every ball bounces on the ground several
//!   times in the window.
//! - `idle`: the same layout 100 m above the ground: every body falls freely and is never
//!   near the ground in the window. What the plugin costs when it has nothing to do.
//! - `pile`: balls dropped into a walled box (walls are not ground) and settled for 3 s, about
//!   five layers deep, sleeping disabled so the pile stays awake: most contacts are rapier's
//!   (ball on ball, ball on wall); the bottom layer rests on the ground (the plugin hands those
//!   contacts to rapier with `e = 0`).
//! - `pile_pairs/500` (`rapier`, `toi`, `exact`): the example's pile size (10 x 10 balls a
//!   layer, five layers) as in `pile`, every ball opted in to impacts between bodies
//!   (`ImpactPlugin::set_all_dynamic_bodies_impact`), timed from the drop: the balls land on
//!   each other and on the ground and the pile forms, so the plugin resolves impacts between
//!   bodies (a settled pile gives them none), against rapier's own contacts.
//! - `tiles8/500`, `tiles64/500`: 500 balls as in `bouncing` over a floor of 8 x 8 or 64 x 64
//!   fixed cuboid tiles, every fixed collider ground: the cost must not grow with the grounds.
//! - `rolling/1000` (`rapier`, `exact`): one layer of balls 15 cm apart resting on the ground,
//!   each rolling at 1 m/s along x without slip, rolling resistance 0.001
//!   (`ImpactConfig::rolling_resistance`; rapier alone has none): the plugin's closed-form
//!   rolling against rapier's resting contact.
//!
//! `bouncing`, `idle`, `pile_pairs`, `tiles` and `rolling` time a window of `WINDOW` steps
//! from the release and start again from a freshly built scene (not timed) when it is used up,
//! so every sample averages the same motion. `pile` is built and settled once per benchmark
//! (not timed) and then stepped on: its state barely changes. Each iteration is one `step`,
//! timed alone.

// Precision-generic: `Real` is f32 or f64 (feature `f64`).
#![allow(clippy::unnecessary_cast)]

use criterion::{BenchmarkId, Criterion, criterion_group, criterion_main};
use rapier_impact::rapier::prelude::*;
use rapier_impact::{ImpactConfig, ImpactPlugin, TimingMode};
use std::hint::black_box;
use std::time::{Duration, Instant};

/// SplitMix64 (the tests' generator), so each scene is the same on every run.
#[path = "../tests/model_support/rng.rs"]
mod rng;
use rng::Rng;

const SIZES: [usize; 3] = [100, 1_000, 10_000];
const RADIUS: f64 = 0.05;
const SPACING: f64 = 0.15;
const RESTITUTION: f64 = 0.8;
const FRICTION: f64 = 0.5;
const DT: f64 = 1.0 / 60.0;
/// Steps timed from one release (1.5 s).
const WINDOW: usize = 90;
const SEED: u64 = 4;

/// Rapier alone, or the plugin in one timing mode.
#[derive(Clone, Copy)]
enum Mode {
    Rapier,
    Plugin(TimingMode),
}

const MODES: [(Mode, &str); 4] = [
    (Mode::Rapier, "rapier"),
    (Mode::Plugin(TimingMode::Step), "step"),
    (Mode::Plugin(TimingMode::TimeOfImpact), "toi"),
    (Mode::Plugin(TimingMode::Exact), "exact"),
];
/// `pile_pairs`' modes.
const PAIR_MODES: [(Mode, &str); 3] = [MODES[0], MODES[2], MODES[3]];
/// `rolling`'s modes.
const ROLLING_MODES: [(Mode, &str); 2] = [MODES[0], MODES[3]];

/// What the plugin does beyond the ground's impacts.
#[derive(Clone, Copy, Default)]
struct Extras {
    /// Every dynamic body opted in to impacts between bodies.
    pairs: bool,
    /// `ImpactConfig::rolling_resistance`.
    rolling_resistance: f64,
}

fn real(x: f64) -> Real {
    x as Real
}

/// A world, its plugin (none for rapier alone), and the steps taken since it was built.
struct Scene {
    world: PhysicsWorld,
    plugin: Option<ImpactPlugin>,
    steps: usize,
}

impl Scene {
    fn step(&mut self) {
        match self.plugin.as_mut() {
            Some(p) => p.step(&mut self.world),
            None => self.world.step(),
        }
        self.steps += 1;
    }
}

/// A world with a fixed cuboid ground (top face at y = 0) `half` m wide each way from the origin.
fn world_with_ground(half: f64) -> (PhysicsWorld, ColliderHandle) {
    let mut world = PhysicsWorld::default();
    world.integration_parameters.dt = real(DT);
    let (_, ground) = world.insert(
        RigidBodyBuilder::fixed(),
        ColliderBuilder::cuboid(real(half), 0.5, real(half))
            .translation(Vector::new(0.0, -0.5, 0.0))
            .restitution(real(RESTITUTION))
            .friction(real(FRICTION)),
    );
    (world, ground)
}

fn ball(world: &mut PhysicsWorld, p: [f64; 3], sleep: bool) {
    world.insert(
        RigidBodyBuilder::dynamic()
            .translation(Vector::new(real(p[0]), real(p[1]), real(p[2])))
            .can_sleep(sleep),
        ColliderBuilder::ball(real(RADIUS))
            .restitution(real(RESTITUTION))
            .friction(real(FRICTION)),
    );
}

/// The scene with the plugin in `mode` (none for rapier alone) doing `extras`, `ground` its
/// ground, or every fixed collider (`None`).
fn with_plugin(
    world: PhysicsWorld,
    ground: Option<ColliderHandle>,
    mode: Mode,
    extras: Extras,
) -> Scene {
    let plugin = match mode {
        Mode::Rapier => None,
        Mode::Plugin(timing) => {
            let mut p = ImpactPlugin::new(
                ImpactConfig::default()
                    .with_timing(timing)
                    .with_rolling_resistance(extras.rolling_resistance),
            )
            .expect("valid configuration");
            match ground {
                Some(ground) => p
                    .add_ground(&world.bodies, &world.colliders, ground)
                    .expect("the ground exists"),
                None => p.set_all_fixed_colliders_ground(true),
            }
            p.set_all_dynamic_bodies_impact(extras.pairs);
            Some(p)
        }
    };
    Scene {
        world,
        plugin,
        steps: 0,
    }
}

/// Half the width (m) of the square grid of `n` balls 15 cm apart, from the origin to the
/// outermost row's centre.
fn grid_half(n: usize) -> f64 {
    let side = (n as f64).sqrt().ceil() as usize;
    0.5 * (side - 1) as f64 * SPACING
}

/// One layer of `n` balls on a square grid (seeded jitter), the balls' bottoms `lift` plus
/// 5-45 cm above y = 0.
fn add_layer(world: &mut PhysicsWorld, n: usize, lift: f64) {
    let side = (n as f64).sqrt().ceil() as usize;
    let centre = grid_half(n);
    let mut rng = Rng::new(SEED);
    for i in 0..n {
        let (row, col) = (i / side, i % side);
        let gap = rng.uniform(0.05, 0.45);
        let p = [
            col as f64 * SPACING - centre + rng.uniform(-0.02, 0.02),
            lift + gap + RADIUS,
            row as f64 * SPACING - centre + rng.uniform(-0.02, 0.02),
        ];
        ball(world, p, true);
    }
}

/// One layer of `n` balls (`add_layer`) over a cuboid ground.
fn layer(n: usize, lift: f64, mode: Mode) -> Scene {
    let (mut world, ground) = world_with_ground(grid_half(n) + 1.0);
    add_layer(&mut world, n, lift);
    let mut scene = with_plugin(world, Some(ground), mode, Extras::default());
    // The first step builds rapier's broad phase: not part of the window.
    scene.step();
    scene
}

/// `n` balls about to drop into a walled box about five layers deep, 2 cm apart in height,
/// never asleep; with `pairs`, every ball opted in to impacts between bodies.
fn dropped_pile(n: usize, mode: Mode, pairs: bool) -> Scene {
    let pitch = 2.0 * RADIUS + 0.01;
    let side = ((n as f64 / 5.0).sqrt().ceil() as usize).max(2);
    let inner = 0.5 * side as f64 * pitch; // half width of the box
    let (mut world, ground) = world_with_ground(inner + 1.0);
    let (h, t) = (0.5 * (6.0 * pitch + 0.5), 0.1);
    for (x, z, hx, hz) in [
        (inner + t, 0.0, t, inner + 2.0 * t),
        (-inner - t, 0.0, t, inner + 2.0 * t),
        (0.0, inner + t, inner, t),
        (0.0, -inner - t, inner, t),
    ] {
        world.insert(
            RigidBodyBuilder::fixed(),
            ColliderBuilder::cuboid(real(hx), real(h), real(hz))
                .translation(Vector::new(real(x), real(h), real(z)))
                .friction(real(FRICTION)),
        );
    }
    let mut rng = Rng::new(SEED);
    let per_layer = side * side;
    for i in 0..n {
        let (level, cell) = (i / per_layer, i % per_layer);
        let (row, col) = (cell / side, cell % side);
        let p = [
            (col as f64 + 0.5) * pitch - inner + rng.uniform(-0.004, 0.004),
            RADIUS + 0.02 + level as f64 * (pitch + 0.02),
            (row as f64 + 0.5) * pitch - inner + rng.uniform(-0.004, 0.004),
        ];
        ball(&mut world, p, false);
    }
    let extras = Extras {
        pairs,
        ..Default::default()
    };
    with_plugin(world, Some(ground), mode, extras)
}

/// `n` balls dropped into a walled box (`dropped_pile`) and settled for 3 s.
fn pile(n: usize, mode: Mode) -> Scene {
    let mut scene = dropped_pile(n, mode, false);
    for _ in 0..(3.0 / DT) as usize {
        scene.step();
    }
    scene
}

/// Samples and measurement time per size: 10 000 balls take milliseconds per step.
fn configure(
    group: &mut criterion::BenchmarkGroup<'_, criterion::measurement::WallTime>,
    n: usize,
) {
    let (samples, seconds) = match n {
        0..=100 => (30, 2),
        101..=1_000 => (20, 3),
        _ => (10, 4),
    };
    group.sample_size(samples);
    group.measurement_time(Duration::from_secs(seconds));
    group.warm_up_time(Duration::from_millis(500));
}

/// A window of `WINDOW` steps from a fresh scene (`build`, not timed), built again when used
/// up, in group `name` for each of `modes`.
fn windowed_group(
    c: &mut Criterion,
    name: &str,
    n: usize,
    modes: &[(Mode, &str)],
    build: impl Fn(Mode) -> Scene,
) {
    let mut group = c.benchmark_group(name);
    configure(&mut group, n);
    for &(mode, label) in modes {
        // Built on first use, so a filtered-out benchmark costs nothing.
        let mut scene: Option<Scene> = None;
        group.bench_function(BenchmarkId::from_parameter(label), |b| {
            let scene = scene.get_or_insert_with(|| build(mode));
            b.iter_custom(|iters| {
                let mut total = Duration::ZERO;
                for _ in 0..iters {
                    if scene.steps > WINDOW {
                        *scene = build(mode);
                    }
                    let start = Instant::now();
                    scene.step();
                    total += start.elapsed();
                    black_box(&scene.world.bodies);
                }
                total
            });
        });
    }
    group.finish();
}

/// `bouncing` (lift 0) and `idle` (lift 100 m).
fn windowed(c: &mut Criterion, name: &str, lift: f64) {
    for n in SIZES {
        windowed_group(c, &format!("{name}/{n}"), n, &MODES, |mode| {
            layer(n, lift, mode)
        });
    }
}

fn bouncing(c: &mut Criterion) {
    windowed(c, "bouncing", 0.0);
}

fn idle(c: &mut Criterion) {
    windowed(c, "idle", 100.0);
}

fn piled(c: &mut Criterion) {
    for n in SIZES {
        let mut group = c.benchmark_group(format!("pile/{n}"));
        configure(&mut group, n);
        for (mode, label) in MODES {
            let mut scene: Option<Scene> = None;
            group.bench_function(BenchmarkId::from_parameter(label), |b| {
                let scene = scene.get_or_insert_with(|| pile(n, mode));
                b.iter(|| {
                    scene.step();
                    black_box(&scene.world.bodies);
                });
            });
        }
        group.finish();
    }
}

/// `pile_pairs/500`: the example's pile (`--scene pile --pairs`: 500 balls, 10 x 10 a layer)
/// with impacts between bodies, timed from the drop, where they happen.
fn piled_pairs(c: &mut Criterion) {
    const BALLS: usize = 500;
    windowed_group(
        c,
        &format!("pile_pairs/{BALLS}"),
        BALLS,
        &PAIR_MODES,
        |mode| {
            let mut scene = dropped_pile(BALLS, mode, true);
            // The first step builds rapier's broad phase: not part of the window.
            scene.step();
            scene
        },
    );
}

/// A floor of `tiles` x `tiles` fixed cuboids (top at y = 0) `half` m wide each way from the
/// origin, every fixed collider ground (`set_all_fixed_colliders_ground`), under one layer of
/// `n` balls as in `layer`.
fn tiled_layer(n: usize, tiles: usize, mode: Mode) -> Scene {
    let half = grid_half(n) + 1.0;
    let mut world = PhysicsWorld::default();
    world.integration_parameters.dt = real(DT);
    let floor = world.bodies.insert(RigidBodyBuilder::fixed());
    let tile = half / tiles as f64;
    for i in 0..tiles {
        for k in 0..tiles {
            let at = |j: usize| -half + (2 * j + 1) as f64 * tile;
            world.colliders.insert_with_parent(
                ColliderBuilder::cuboid(real(tile), 0.25, real(tile))
                    .translation(Vector::new(real(at(i)), -0.25, real(at(k))))
                    .restitution(real(RESTITUTION))
                    .friction(real(FRICTION)),
                floor,
                &mut world.bodies,
            );
        }
    }
    add_layer(&mut world, n, 0.0);
    let mut scene = with_plugin(world, None, mode, Extras::default());
    scene.step();
    scene
}

/// `tilesN/500`: 500 balls bouncing on floors of 8 x 8 and 64 x 64 tiles: the cost must not
/// grow with the number of grounds.
fn tiled(c: &mut Criterion) {
    const BALLS: usize = 500;
    for tiles in [8, 64] {
        windowed_group(c, &format!("tiles{tiles}/{BALLS}"), BALLS, &MODES, |mode| {
            tiled_layer(BALLS, tiles, mode)
        });
    }
}

/// Rolling speed (m/s) of the `rolling` scene's balls.
const ROLL_SPEED: f64 = 1.0;
/// Rolling resistance of the `rolling` scene (the plugin's).
const ROLLING_RESISTANCE: f64 = 0.001;

/// One layer of `n` balls on a square grid 15 cm apart (seeded jitter along the ground),
/// resting on the ground and rolling along x at `ROLL_SPEED` without slip, the ground wide
/// enough that none rolls off it in the window.
fn rolling_layer(n: usize, mode: Mode) -> Scene {
    let reach = (WINDOW + 1) as f64 * DT * ROLL_SPEED;
    let (mut world, ground) = world_with_ground(grid_half(n) + reach + 1.0);
    let side = (n as f64).sqrt().ceil() as usize;
    let centre = grid_half(n);
    let mut rng = Rng::new(SEED);
    for i in 0..n {
        let (row, col) = (i / side, i % side);
        let (x, z) = (
            col as f64 * SPACING - centre + rng.uniform(-0.02, 0.02),
            row as f64 * SPACING - centre + rng.uniform(-0.02, 0.02),
        );
        world.insert(
            RigidBodyBuilder::dynamic()
                .translation(Vector::new(real(x), real(RADIUS), real(z)))
                .linvel(Vector::new(real(ROLL_SPEED), 0.0, 0.0))
                .angvel(Vector::new(0.0, 0.0, real(-ROLL_SPEED / RADIUS))),
            ColliderBuilder::ball(real(RADIUS))
                .restitution(real(RESTITUTION))
                .friction(real(FRICTION)),
        );
    }
    let extras = Extras {
        rolling_resistance: ROLLING_RESISTANCE,
        ..Default::default()
    };
    let mut scene = with_plugin(world, Some(ground), mode, extras);
    // The first step builds rapier's broad phase: not part of the window.
    scene.step();
    scene
}

/// `rolling/1000`: 1 000 balls rolling on the ground (`--scene rolling --rolling-resistance
/// 0.001`).
fn rolling(c: &mut Criterion) {
    const BALLS: usize = 1_000;
    windowed_group(
        c,
        &format!("rolling/{BALLS}"),
        BALLS,
        &ROLLING_MODES,
        |mode| rolling_layer(BALLS, mode),
    );
}

criterion_group!(benches, bouncing, idle, piled, piled_pairs, tiled, rolling);
criterion_main!(benches);
