//! N balls raining on a ground, headless: the wall-clock cost of a step, with the plugin in
//! each timing mode or rapier alone (`--mode rapier`) for comparison.
//!
//! ```text
//! cargo run --release --example many_balls -- --count 1000 --steps 600 --mode exact
//! cargo run --release --example many_balls -- --count 1000 --steps 600 --mode rapier
//! ```
//!
//! Every flag has a default; `--help` lists them. `--pairs` hands the balls' impacts with each
//! other to the plugin too (`set_all_dynamic_bodies_impact`); `--profile` prints the time of
//! each stage of the step, the bodies and pairs each took, and the writes into rapier
//! (`ImpactPlugin::profile`); `--csv PATH` writes the trace of the first ball.
//!
//! Scenes (balls of radius 5 cm, each start position jittered by up to 2 cm):
//! - `bouncing`: a grid of 20 x 20 balls per layer, 15 cm apart, layers 15 cm apart from 1 m
//!   up; they fall, bounce on the ground, and collide with each other (rapier's contacts).
//! - `idle`: the same grid 50 m up, launched upwards at `g T / 2` (`T` the whole run), so
//!   that every ball rises and falls back to its start height at the run's end: no ball is
//!   within reach of the ground, and no two touch, for the whole run.
//! - `pile`: 10 x 10 balls per layer, 11 cm apart, dropped into a walled box 1.2 m wide (the
//!   walls are fixed cuboids, 2 m high); they come to rest on each other.
//! - `rolling`: one layer of balls on the ground (no height jitter), 15 cm apart in a square
//!   grid, each rolling at 1 m/s along x without slip: the cost of the closed-form rolling
//!   against rapier's resting contact. With `--rolling-resistance MU_R` (the plugin's; rapier
//!   alone has none) they stop after `v0^2 (1 + k) / (2 mu_r g)`, 71 m at 0.001. On `--tiles`
//!   the balls right of the grid's centre roll off the 8 m floor within 300 steps.
//!
//! The ground is a half-space at y = 0, or with `--tiles N` (N > 0) an N x N floor of fixed
//! cuboid tiles (0.5 m thick, top at y = 0) covering 8 m x 8 m about the origin, marked with
//! `set_all_fixed_colliders_ground(true)` (the pile's walls are then ground too). The tiles
//! are flush and of one material: the plugin takes them as one box (a slab), and rapier
//! pairs each ball with every tile its box overlaps. Timing covers the steps only, not the
//! set-up; whole-process figures (`/usr/bin/time`) cover everything.
//!
//! `below ground` counts the balls whose centre ends below y = 0: on the half-space none; on
//! `--tiles`, those that bounced or rolled off the floor's edge, more with the plugin than
//! under rapier alone, whose bounces lose most of their height at 60 Hz (docs/accuracy.md).

mod common;

use clap::{Parser, ValueEnum};
use common::{Mode, Rng, TraceCsv, real, wide};
use rapier_impact::model::Law;
use rapier_impact::rapier::prelude::*;
use rapier_impact::{EventKind, ImpactConfig, ImpactPlugin, Stage, StepProfile};
use std::time::Instant;

/// N balls raining on a ground: milliseconds per step (mean, median, max), the impacts, how
/// many balls sleep or fell through the ground, with the plugin in a timing mode or rapier
/// alone. The scenes: `bouncing` (layers of balls falling from 1 m), `idle` (balls in flight
/// far above the ground for the whole run), `pile` (balls settling in a walled box),
/// `rolling` (one layer rolling at 1 m/s).
#[derive(Parser, Debug)]
#[command(
    name = "many_balls",
    after_help = "Example: cargo run --release --example many_balls -- --count 1000 --steps 600 --mode rapier"
)]
struct Args {
    /// Number of balls (at least 1)
    #[arg(long, value_name = "N", default_value = "500", value_parser = |s: &str| common::whole(s, 1))]
    count: u64,
    /// Number of steps (at least 1)
    #[arg(long, value_name = "S", default_value = "600", value_parser = |s: &str| common::whole(s, 1))]
    steps: u64,
    /// Rapier alone, or the plugin in one of its timing modes
    #[arg(long, value_enum, value_name = "MODE", default_value_t = Mode::EXACT)]
    mode: Mode,
    /// The scene
    #[arg(long, value_enum, value_name = "SCENE", default_value_t = Scene::Bouncing)]
    scene: Scene,
    /// 0: a half-space ground; N > 0: an N x N floor of fixed cuboid tiles, 8 m x 8 m
    #[arg(long, value_name = "N", default_value = "0", value_parser = |s: &str| common::whole(s, 0))]
    tiles: u64,
    /// Coefficient of restitution of balls and ground
    #[arg(long, value_name = "E", default_value = "0.7", value_parser = common::non_negative)]
    restitution: f64,
    /// Coefficient of friction of balls and ground
    #[arg(long, value_name = "MU", default_value = "0.5", value_parser = common::non_negative)]
    friction: f64,
    /// Rolling resistance of the balls the plugin rolls (ImpactConfig::rolling_resistance,
    /// dimensionless)
    #[arg(long, value_name = "MU_R", default_value = "0", value_parser = common::non_negative)]
    rolling_resistance: f64,
    /// Time step (s)
    #[arg(long, value_name = "DT", default_value = "1/60", value_parser = common::positive)]
    dt: f64,
    /// Seed of the layout's jitter
    #[arg(long, value_name = "N", default_value = "1", value_parser = |s: &str| common::whole(s, 0))]
    seed: u64,
    /// The balls' impacts with each other by the plugin too (set_all_dynamic_bodies_impact)
    #[arg(long)]
    pairs: bool,
    /// Print the time of each stage of the step and the bodies each took (plugin modes;
    /// reading the clock adds to the ms per step)
    #[arg(long)]
    profile: bool,
    /// Double precision: needs a build with `--features f64` (the precision is chosen at
    /// build time)
    #[arg(long)]
    f64: bool,
    /// Write the trace t,x,y,z,vx,vy,vz,wx,wy,wz of the first ball (m, m/s, rad/s)
    /// [default: none]
    #[arg(long, value_name = "PATH")]
    csv: Option<String>,
}

/// `--scene`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
enum Scene {
    /// Layers of 20 x 20 balls from 1 m up: they fall, bounce and collide
    Bouncing,
    /// The same grid 50 m up, launched to rise and fall back by the run's end: nothing touches
    Idle,
    /// Layers of 10 x 10 balls dropped into a walled box, coming to rest on each other
    Pile,
    /// One layer on the ground, each ball rolling at 1 m/s along x without slip
    Rolling,
}

impl Scene {
    /// The name used on the command line.
    fn name(self) -> &'static str {
        match self {
            Scene::Bouncing => "bouncing",
            Scene::Idle => "idle",
            Scene::Pile => "pile",
            Scene::Rolling => "rolling",
        }
    }
}

/// Inserts the balls of `args.scene` (and the pile's walls); returns the first ball.
fn insert_balls(world: &mut PhysicsWorld, args: &Args) -> RigidBodyHandle {
    let (count, steps, e, mu, dt) = (
        args.count,
        args.steps,
        args.restitution,
        args.friction,
        args.dt,
    );
    let mut rng = Rng::new(args.seed);
    let scene = args.scene;
    let (radius, spacing, per_row, bottom) = match scene {
        Scene::Pile => {
            walls(world, 0.6, 2.0, e, mu);
            (0.05, 0.11, 10u64, 0.3)
        }
        Scene::Idle => (0.05, 0.15, 20u64, 50.0),
        Scene::Rolling => (0.05, 0.15, (count as f64).sqrt().ceil() as u64, 0.05),
        Scene::Bouncing => (0.05, 0.15, 20u64, 1.0),
    };
    // Idle: up at g T / 2, back at the start height when the run ends.
    let launch = if scene == Scene::Idle {
        0.5 * wide(-world.gravity.y) * steps as f64 * dt
    } else {
        0.0
    };
    let rolling = scene == Scene::Rolling;
    let (roll_v, roll_w) = if rolling {
        (1.0, -1.0 / radius)
    } else {
        (0.0, 0.0)
    };
    let mut first = None;
    for i in 0..count {
        let (layer, cell) = (i / (per_row * per_row), i % (per_row * per_row));
        let (row, col) = (cell / per_row, cell % per_row);
        let centre = 0.5 * (per_row - 1) as f64 * spacing;
        let p = [
            col as f64 * spacing - centre + rng.range(-0.02, 0.02),
            if rolling {
                bottom
            } else {
                bottom + layer as f64 * spacing + rng.range(-0.02, 0.02)
            },
            row as f64 * spacing - centre + rng.range(-0.02, 0.02),
        ];
        let (h, _) = world.insert(
            RigidBodyBuilder::dynamic()
                .translation(Vector::new(real(p[0]), real(p[1]), real(p[2])))
                .linvel(Vector::new(real(roll_v), real(launch), 0.0))
                .angvel(Vector::new(0.0, 0.0, real(roll_w))),
            ColliderBuilder::ball(real(radius))
                .restitution(real(e))
                .friction(real(mu)),
        );
        first.get_or_insert(h);
    }
    first.expect("--count >= 1")
}

/// The plugin of `args.mode` (none for rapier alone): `ground` marked, or every fixed
/// collider when the floor is tiles.
fn make_plugin(
    world: &mut PhysicsWorld,
    ground: Option<ColliderHandle>,
    args: &Args,
) -> Option<ImpactPlugin> {
    let mut plugin = match (args.mode, ground) {
        (Mode::Plugin(timing), None) => {
            let mut config = ImpactConfig::default();
            config.law = Law::Guarded;
            config.timing = timing;
            let mut p = ImpactPlugin::new(config).expect("the default configuration is valid");
            p.set_all_fixed_colliders_ground(true);
            Some(p)
        }
        (_, Some(ground)) => common::plugin(args.mode, Law::Guarded, world, ground),
        (Mode::Rapier, None) => None,
    };
    if let Some(p) = plugin.as_mut() {
        p.set_profiling(args.profile);
        p.set_all_dynamic_bodies_impact(args.pairs);
        let mut config = p.config().clone();
        config.rolling_resistance = args.rolling_resistance;
        p.set_config(config)
            .unwrap_or_else(|e| common::fail::<Args>(e));
    }
    plugin
}

/// What a run measured.
struct Run {
    /// Wall time of each step (ms).
    times: Vec<f64>,
    profile: StepProfile,
    impacts: usize,
    /// Steps after which some ball was still awake.
    awake_steps: usize,
}

/// Steps the scene `args.steps` times, timing each step.
fn run(
    world: &mut PhysicsWorld,
    plugin: &mut Option<ImpactPlugin>,
    csv: &mut Option<TraceCsv>,
    args: &Args,
) -> Run {
    let steps = args.steps;
    let dt = wide(world.integration_parameters.dt);
    if let Some(c) = csv.as_mut() {
        c.row(0.0, &world.bodies);
    }
    let mut times = Vec::with_capacity(steps as usize);
    let mut profile = StepProfile::default();
    let mut impacts = 0usize;
    // Steps after which some ball is still awake: a whole run's cost is as much how long the
    // scene takes to fall asleep as what a step costs (a pile settles sooner or later by the
    // order its contacts are met in).
    let mut awake_steps = 0usize;
    for n in 1..=steps {
        let start = Instant::now();
        impacts += common::step(world, plugin)
            .iter()
            .filter(|e| e.kind == EventKind::Impact)
            .count();
        times.push(start.elapsed().as_secs_f64() * 1e3);
        if let Some(p) = plugin.as_ref().and_then(|p| p.profile()) {
            profile.accumulate(p);
        }
        if world
            .bodies
            .iter()
            .any(|(_, rb)| rb.is_dynamic() && !rb.is_sleeping())
        {
            awake_steps += 1;
        }
        if let Some(c) = csv.as_mut() {
            c.row(n as f64 * dt, &world.bodies);
        }
    }
    Run {
        times,
        profile,
        impacts,
        awake_steps,
    }
}

fn main() {
    let args: Args = common::parse();
    common::check_precision::<Args>(args.f64);
    common::check_material::<Args>(args.mode, args.restitution, args.friction);
    let mut world = common::world(args.dt);
    let ground = floor(&mut world, args.tiles, args.restitution, args.friction);
    let first = insert_balls(&mut world, &args);
    let mut plugin = make_plugin(&mut world, ground, &args);
    let mut csv = args.csv.as_deref().map(|p| TraceCsv::create(p, first));
    let Run {
        times,
        profile,
        impacts,
        awake_steps,
    } = run(&mut world, &mut plugin, &mut csv, &args);
    if let Some(c) = csv {
        c.finish();
    }

    let (count, steps) = (args.count, args.steps);
    let dt = wide(world.integration_parameters.dt);
    let total: f64 = times.iter().sum();
    let mut sorted = times.clone();
    sorted.sort_by(f64::total_cmp);
    let median = sorted[sorted.len() / 2];
    let max = sorted[sorted.len() - 1];
    let asleep = world
        .bodies
        .iter()
        .filter(|(_, rb)| rb.is_dynamic() && rb.is_sleeping())
        .count();
    let below = world
        .bodies
        .iter()
        .filter(|(_, rb)| rb.is_dynamic() && wide(rb.translation().y) < 0.0)
        .count();
    println!(
        "many_balls: {count} balls, {steps} steps of {dt:.7} s, scene {}, tiles {}, mode {}, precision {}",
        args.scene.name(),
        args.tiles,
        args.mode.name(),
        common::PRECISION
    );
    println!(
        "{:>12} {:>12} {:>12} {:>10} {:>8} {:>14} {:>12}",
        "ms/step", "median ms", "max ms", "impacts", "asleep", "below ground", "awake steps"
    );
    println!(
        "{:>12.4} {median:>12.4} {max:>12.4} {impacts:>10} {asleep:>8} {below:>14} {awake_steps:>12}",
        total / steps as f64
    );
    if args.profile && plugin.is_some() {
        print_profile(&profile, steps);
    }
}

/// The run's profile: each stage's time per step and share of the step, then the bodies and
/// pairs each stage took per step.
fn print_profile(profile: &StepProfile, steps: u64) {
    let per_step = |d: std::time::Duration| d.as_secs_f64() * 1e3 / steps as f64;
    let whole: f64 = Stage::ALL.iter().map(|s| per_step(profile.time(*s))).sum();
    println!("profile, per step: {:>12} {:>8}", "ms", "share");
    for stage in Stage::ALL.iter().copied() {
        let ms = per_step(profile.time(stage));
        println!(
            "  {:<22} {ms:>12.4} {:>7.1}%",
            stage.name(),
            100.0 * ms / whole
        );
    }
    let plugin = per_step(profile.plugin_time());
    println!(
        "  {:<22} {plugin:>12.4} {:>7.1}%",
        "plugin (all but rapier)",
        100.0 * plugin / whole
    );
    let c = &profile.counts;
    let avg = |n: usize| n as f64 / steps as f64;
    println!(
        "bodies per step: asleep {:.1}, far {:.1}, planned {:.1}, near a ground {:.1}, candidates {:.1}, hooked {:.1}",
        avg(c.asleep),
        avg(c.far),
        avg(c.planned),
        avg(c.near),
        avg(c.candidates),
        avg(c.hooked_bodies)
    );
    println!(
        "pairs per step: impact {:.1}, resting {:.1}, rolling {:.1}, rapier's {:.1}, between bodies {:.1} (cluster runs {:.2})",
        avg(c.impact_pairs),
        avg(c.resting_pairs),
        avg(c.rolling_pairs),
        avg(c.rapier_pairs),
        avg(c.body_pairs),
        avg(c.cluster_runs)
    );
    println!(
        "writes per step {:.1} ({:.1} of them moves), events per step {:.2}",
        avg(c.writes),
        avg(c.moves),
        avg(c.events)
    );
}

/// The ground: a half-space at y = 0 (its handle, marked by `common::plugin`), or (`tiles` >
/// 0) a floor of `tiles` x `tiles` fixed cuboids, top at y = 0, over 8 m x 8 m (`None`: the
/// plugin marks every fixed collider).
fn floor(world: &mut PhysicsWorld, tiles: u64, e: f64, mu: f64) -> Option<ColliderHandle> {
    if tiles == 0 {
        return Some(common::ground(world, e, mu));
    }
    let side = 8.0;
    let half = 0.5 * side / tiles as f64;
    let body = world.bodies.insert(RigidBodyBuilder::fixed());
    for i in 0..tiles {
        for k in 0..tiles {
            let at = |n: u64| -0.5 * side + (2 * n + 1) as f64 * half;
            world.colliders.insert_with_parent(
                ColliderBuilder::cuboid(real(half), 0.25, real(half))
                    .translation(Vector::new(real(at(i)), -0.25, real(at(k))))
                    .restitution(real(e))
                    .friction(real(mu)),
                body,
                &mut world.bodies,
            );
        }
    }
    None
}

/// Four fixed walls, `height` m high and 5 cm thick, around the square of half-width `half`
/// (m) about the origin (not ground, unless every fixed collider is).
fn walls(world: &mut PhysicsWorld, half: f64, height: f64, e: f64, mu: f64) {
    let body = world.bodies.insert(RigidBodyBuilder::fixed());
    let t = 0.025;
    for (x, z, hx, hz) in [
        (half + t, 0.0, t, half + 2.0 * t),
        (-half - t, 0.0, t, half + 2.0 * t),
        (0.0, half + t, half, t),
        (0.0, -half - t, half, t),
    ] {
        world.colliders.insert_with_parent(
            ColliderBuilder::cuboid(real(hx), real(0.5 * height), real(hz))
                .translation(Vector::new(real(x), real(0.5 * height), real(z)))
                .restitution(real(e))
                .friction(real(mu)),
            body,
            &mut world.bodies,
        );
    }
}
