//! Milliseconds per step of whole scenes, rapier alone against the plugin in each timing mode
//! (issue 4, "Scene"). `cargo bench --bench scene`; a filter picks groups, e.g.
//! `cargo bench --bench scene -- bouncing/1000`.
//!
//! Groups, each at N = 100, 1 000 and 10 000 balls (radius 5 cm, e = 0.8, mu = 0.5, dt = 1/60,
//! rapier's default parameters) on a fixed cuboid ground, with the benchmark named
//! `GROUP/N/MODE`, `MODE` = `rapier` (rapier alone, no plugin), `step`, `toi` or `exact`:
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
//! - `tiles8/500`, `tiles64/500`: 500 balls as in `bouncing` over a floor of 8 x 8 or 64 x 64
//!   fixed cuboid tiles, every fixed collider ground: the cost must not grow with the grounds.
//!
//! `bouncing` and `idle` time a window of `WINDOW` steps from the release and start again from
//! a freshly built scene (not timed) when it is used up, so every sample averages the same
//! motion. `pile` is built and settled once per benchmark (not timed) and then stepped on:
//! its state barely changes. Each iteration is one `step`, timed alone.

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

/// The scene with the plugin in `mode` (none for rapier alone), `ground` its ground, or every
/// fixed collider (`None`).
fn with_plugin(world: PhysicsWorld, ground: Option<ColliderHandle>, mode: Mode) -> Scene {
    let plugin = match mode {
        Mode::Rapier => None,
        Mode::Plugin(timing) => {
            let mut p = ImpactPlugin::new(ImpactConfig {
                timing,
                ..Default::default()
            })
            .expect("valid configuration");
            match ground {
                Some(ground) => p
                    .add_ground(&world.bodies, &world.colliders, ground)
                    .expect("the ground exists"),
                None => p.set_all_fixed_colliders_ground(true),
            }
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
    let mut scene = with_plugin(world, Some(ground), mode);
    // The first step builds rapier's broad phase: not part of the window.
    scene.step();
    scene
}

/// `n` balls dropped into a walled box about five layers deep, settled for 3 s, never asleep.
fn pile(n: usize, mode: Mode) -> Scene {
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
    let mut scene = with_plugin(world, Some(ground), mode);
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
/// up, in group `name` for every mode.
fn windowed_group(c: &mut Criterion, name: &str, n: usize, build: impl Fn(Mode) -> Scene) {
    let mut group = c.benchmark_group(name);
    configure(&mut group, n);
    for (mode, label) in MODES {
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
        windowed_group(c, &format!("{name}/{n}"), n, |mode| layer(n, lift, mode));
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
    let mut scene = with_plugin(world, None, mode);
    scene.step();
    scene
}

/// `tilesN/500`: 500 balls bouncing on floors of 8 x 8 and 64 x 64 tiles: the cost must not
/// grow with the number of grounds.
fn tiled(c: &mut Criterion) {
    const BALLS: usize = 500;
    for tiles in [8, 64] {
        windowed_group(c, &format!("tiles{tiles}/{BALLS}"), BALLS, |mode| {
            tiled_layer(BALLS, tiles, mode)
        });
    }
}

criterion_group!(benches, bouncing, idle, piled, tiled);
criterion_main!(benches);
