//! Newton's cradle, headless: a row of balls lying touching on a frictionless ground, the
//! first one arriving at the row; every ball's velocity once the chain of impacts reaches the
//! last ball (in the first step at the defaults), and the impacts the plugin resolved.
//!
//! ```text
//! cargo run --release --example cradle -- --balls 5 --speed 1 --restitution 1
//! ```
//!
//! Every flag has a default; `--help` lists them with their units.
//!
//! The balls (R = 25 mm, 0.1 kg) lie on a half-space ground with no friction; the first is
//! 1 mm from the row, moving along +x. With the plugin the impact passes along the row inside
//! one step, one pair after the other (`docs/guide.md`, "Impacts between bodies"): at
//! `e = 1` the last ball leaves at `V` and the others stop; with `e < 1` each impact keeps
//! `(1 - e)/2` of the speed in the ball behind. The closed form printed is that sequence of
//! two-ball impacts.

mod common;

use clap::Parser;
use common::{Coefficient, Mode, real, wide};
use rapier_impact::rapier::prelude::*;
use rapier_impact::{EventKind, ImpactConfig, ImpactPlugin};

/// Newton's cradle on a frictionless ground: a ball arrives at a row of touching balls, and
/// every ball's velocity after the chain of impacts is printed beside the sequence of two-ball
/// impacts along the row (R = 25 mm, 0.1 kg each).
#[derive(Parser, Debug)]
#[command(
    name = "cradle",
    after_help = "Example: cargo run --release --example cradle -- --balls 5 --restitution 0.9"
)]
struct Args {
    /// Number of balls, the arriving one included (at least 2)
    #[arg(long, value_name = "N", default_value = "5", value_parser = |s: &str| common::whole(s, 2))]
    balls: u64,
    /// Speed of the arriving ball (m/s)
    #[arg(long, value_name = "V", default_value = "1", value_parser = common::positive)]
    speed: f64,
    /// Coefficient of restitution between the balls
    #[arg(long, value_name = "E", default_value = "1", value_parser = common::non_negative)]
    restitution: f64,
    /// Time step (s)
    #[arg(long, value_name = "DT", default_value = "1/60", value_parser = common::positive)]
    dt: f64,
    /// Rapier alone, or the plugin in one of its timing modes
    #[arg(long, value_enum, value_name = "MODE", default_value_t = Mode::EXACT)]
    mode: Mode,
}

fn main() {
    let args: Args = common::parse();
    common::check_coefficients::<Args>(
        args.mode,
        &[("--restitution", Coefficient::Restitution, args.restitution)],
    );
    let n = args.balls as usize;
    let (speed, e, dt, mode) = (args.speed, args.restitution, args.dt, args.mode);
    let (r, m) = (0.025, 0.1);
    let density = m / (4.0 / 3.0 * std::f64::consts::PI * r * r * r);
    let mut world = common::world(dt);
    let mut balls = Vec::new();
    for k in 0..n {
        // The first ball 1 mm short of the row, the row touching.
        let x = if k == 0 {
            -2.0 * r - 0.001
        } else {
            2.0 * r * (k - 1) as f64
        };
        let v = if k == 0 { speed } else { 0.0 };
        let (h, _) = world.insert(
            RigidBodyBuilder::dynamic()
                .translation(Vector::new(real(x), real(r), 0.0))
                .linvel(Vector::new(real(v), 0.0, 0.0)),
            ColliderBuilder::ball(real(r))
                .density(real(density))
                .restitution(real(e))
                .friction(0.0)
                .restitution_combine_rule(CoefficientCombineRule::Min)
                .friction_combine_rule(CoefficientCombineRule::Min),
        );
        balls.push(h);
    }
    let ground = common::ground(&mut world, 0.0, 0.0);
    let mut plugin = match mode {
        Mode::Rapier => None,
        Mode::Plugin(timing) => {
            let mut config = ImpactConfig::default();
            config.timing = timing;
            let mut p = ImpactPlugin::new(config).expect("the default configuration is valid");
            p.add_ground(&world.bodies, &world.colliders, ground)
                .expect("the ground exists");
            p.set_all_dynamic_bodies_impact(true);
            Some(p)
        }
    };
    // The first ball is 1 mm short of the row: stepped until the chain reaches the last ball
    // (at the defaults, in the first step; with `e < 1` the balls meet again later, slowly:
    // not part of this chain), at most ten seconds.
    let last_moves = |world: &PhysicsWorld| world.bodies[balls[n - 1]].linvel().x != 0.0;
    let mut events = Vec::new();
    for _ in 0..(10.0 / dt).ceil() as u64 {
        events.extend_from_slice(common::step(&mut world, &mut plugin));
        if last_moves(&world) {
            break;
        }
    }
    let impacts = events
        .iter()
        .filter(|ev| ev.kind == EventKind::Impact && ev.body2.is_some())
        .count()
        / 2;
    // The sequence of two-ball impacts along the row: equal masses, the ball behind keeps
    // (1 - e)/2 of the speed and the one ahead takes (1 + e)/2, which it passes on.
    let mut expected = vec![0.0; n];
    let mut moving = speed;
    for slot in expected.iter_mut().take(n - 1) {
        *slot = (1.0 - e) / 2.0 * moving;
        moving *= (1.0 + e) / 2.0;
    }
    expected[n - 1] = moving;
    println!(
        "cradle: {n} balls, V = {speed} m/s, e = {e}, dt = {dt:.7} s, mode = {}, precision = {}, \
ball-ball impacts resolved by the plugin: {impacts}",
        mode.name(),
        common::PRECISION
    );
    println!(
        "{:>5} {:>12} {:>12} {:>10}",
        "ball", "vx (m/s)", "closed form", "error"
    );
    for (k, h) in balls.iter().enumerate() {
        let vx = wide(world.bodies[*h].linvel().x);
        println!(
            "{k:>5} {vx:>12.7} {:>12.7} {:>10.2e}",
            expected[k],
            vx - expected[k]
        );
    }
}
