//! N balls raining on a ground, headless: the wall-clock cost of a step, with the plugin in
//! each timing mode or rapier alone (`--mode rapier`) for comparison.
//!
//! ```text
//! cargo run --release --example many_balls -- --count 1000 --steps 600 --mode exact
//! cargo run --release --example many_balls -- --count 1000 --steps 600 --mode rapier
//! ```
//!
//! Flags (each has a default; `--help` lists them): `--count N` (balls, 500), `--steps S`
//! (600), `--mode rapier|step|toi|exact` (exact), `--restitution E` (0.7), `--friction MU`
//! (0.5), `--dt DT` (s, 1/60), `--seed N` (the layout's jitter, 1), `--f64` (needs
//! `--features f64`), `--csv PATH` (trace of the first ball).
//!
//! The balls (radius 5 cm) start on a grid of 20 x 20 per layer, 15 cm apart, layers 15 cm
//! apart from 1 m up, each position jittered by up to 2 cm; they fall, bounce on a half-space
//! ground, and collide with each other (rapier's contacts) as they pile up. Timing covers the
//! steps only, not the set-up.

mod common;

use common::{Args, CSV, F64, MODE, Rng, TraceCsv, flag, real, wide};
use rapier_impact::model::Law;
use rapier_impact::rapier::prelude::*;
use std::time::Instant;

const ABOUT: &str = "N balls raining on a ground: milliseconds per step, with the plugin or \
rapier alone.";

fn main() {
    let spec = [
        flag("--count", "N", "500", "number of balls"),
        flag("--steps", "S", "600", "number of steps"),
        MODE,
        flag(
            "--restitution",
            "E",
            "0.7",
            "restitution of balls and ground",
        ),
        flag("--friction", "MU", "0.5", "friction of balls and ground"),
        flag("--dt", "DT", "1/60", "time step (s)"),
        flag("--seed", "N", "1", "seed of the layout's jitter"),
        F64,
        CSV,
    ];
    let args = Args::parse("many_balls", ABOUT, &spec);
    args.check_precision();
    let count = args.count("--count", 1);
    let steps = args.count("--steps", 1);
    let mode = args.mode();
    let e = args.non_negative("--restitution");
    let mu = args.non_negative("--friction");
    let dt = args.positive("--dt");
    let mut rng = Rng::new(args.count("--seed", 0));

    let mut world = common::world(dt);
    let ground = common::ground(&mut world, e, mu);
    let (radius, spacing, per_row) = (0.05, 0.15, 20u64);
    let mut first = None;
    for i in 0..count {
        let (layer, cell) = (i / (per_row * per_row), i % (per_row * per_row));
        let (row, col) = (cell / per_row, cell % per_row);
        let centre = 0.5 * (per_row - 1) as f64 * spacing;
        let p = [
            col as f64 * spacing - centre + rng.range(-0.02, 0.02),
            1.0 + layer as f64 * spacing + rng.range(-0.02, 0.02),
            row as f64 * spacing - centre + rng.range(-0.02, 0.02),
        ];
        let (h, _) = world.insert(
            RigidBodyBuilder::dynamic().translation(Vector::new(
                real(p[0]),
                real(p[1]),
                real(p[2]),
            )),
            ColliderBuilder::ball(real(radius))
                .restitution(real(e))
                .friction(real(mu)),
        );
        first.get_or_insert(h);
    }
    let mut plugin = common::plugin(mode, Law::Guarded, &mut world, ground);
    let mut csv = args
        .path("--csv")
        .map(|p| TraceCsv::create(&p, first.expect("--count >= 1")));
    let dt = wide(world.integration_parameters.dt);
    if let Some(c) = csv.as_mut() {
        c.row(0.0, &world.bodies);
    }

    let mut times = Vec::with_capacity(steps as usize);
    let mut impacts = 0usize;
    for n in 1..=steps {
        let start = Instant::now();
        impacts += common::step(&mut world, &mut plugin).len();
        times.push(start.elapsed().as_secs_f64() * 1e3);
        if let Some(c) = csv.as_mut() {
            c.row(n as f64 * dt, &world.bodies);
        }
    }
    if let Some(c) = csv {
        c.finish();
    }

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
        "many_balls: {count} balls, {steps} steps of {dt:.7} s, mode {}, precision {}",
        mode.name(),
        common::PRECISION
    );
    println!(
        "{:>12} {:>12} {:>12} {:>10} {:>8} {:>14}",
        "ms/step", "median ms", "max ms", "impacts", "asleep", "below ground"
    );
    println!(
        "{:>12.4} {median:>12.4} {max:>12.4} {impacts:>10} {asleep:>8} {below:>14}",
        total / steps as f64
    );
}
