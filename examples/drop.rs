//! A ball dropped on a ground, headless: bounce apexes and impact times, measured against
//! the closed forms `apex_n = e^(2n) h0`, `t_(k+1) = t1 + 2 t1 e (1 - e^k)/(1 - e)`. In a
//! plugin mode, the same drop in rapier alone is printed beside it (its apexes, their
//! error, its impact times: rapier's are the steps at which the ball starts rising).
//!
//! ```text
//! cargo run --release --example drop -- --mode exact --dt 0.0166667 --csv drop.csv
//! ```
//!
//! Every flag has a default; `--help` lists them with their units. The CSV trace
//! (`--csv PATH`) is `t,x,y,z,vx,vy,vz,wx,wy,wz` of the ball's centre of mass, one row per
//! step and one at t = 0; ground surface at y = 0, y up.

// Precision-generic: `Real` is f32 or f64 (feature `f64`), so conversions that are
// widening in one build are identities in the other.
#![allow(clippy::useless_conversion, clippy::unnecessary_cast)]

mod common;

use clap::Parser;
use common::Mode;
use rapier_impact::rapier::prelude::*;
use rapier_impact::{EventKind, ImpactConfig, ImpactPlugin};
use std::io::Write;

/// A ball dropped on a ground: its impact times and bounce apexes beside the closed forms
/// `t_(k+1) = t1 + 2 t1 e (1 - e^k)/(1 - e)` and `apex_n = e^(2n) h0`, and, in a plugin mode,
/// the same drop in rapier alone beside them.
#[derive(Parser, Debug)]
#[command(
    name = "drop",
    after_help = "Example: cargo run --release --example drop -- --mode toi --dt 1/120 --csv drop.csv"
)]
struct Args {
    /// Gap from the ball's bottom to the ground at release (m)
    #[arg(long, value_name = "H", default_value = "1", value_parser = common::positive)]
    height: f64,
    /// Ball radius (m)
    #[arg(long, value_name = "R", default_value = "0.1", value_parser = common::positive)]
    radius: f64,
    /// Coefficient of restitution of ball and ground
    #[arg(long, value_name = "E", default_value = "0.8", value_parser = common::non_negative)]
    restitution: f64,
    /// Coefficient of friction of ball and ground
    #[arg(long, value_name = "MU", default_value = "0.5", value_parser = common::non_negative)]
    friction: f64,
    /// Simulated time (s)
    #[arg(long, value_name = "T", default_value = "5", value_parser = common::positive)]
    duration: f64,
    // --dt, --mode and --f64, as in the other scenes.
    #[command(flatten)]
    common: common::CommonArgs,
    /// Write the trace t,x,y,z,vx,vy,vz,wx,wy,wz of the ball's centre of mass (m, m/s,
    /// rad/s), one row per step and one at t = 0 [default: none]
    #[arg(long, value_name = "PATH")]
    csv: Option<String>,
}

/// What a drop gave: the impact times and the apex heights of the ball's bottom, and the
/// trace for the CSV.
struct Drop {
    impacts: Vec<f64>,
    apexes: Vec<f64>,
    dt: f64,
}

/// Drops the ball in `mode` and measures its impacts and apexes (writing the trace to
/// `csv`, if given).
fn drop_ball(args: &Args, mode: Mode, csv: Option<&str>) -> Drop {
    let g = 9.81;
    let mut world = PhysicsWorld::default();
    world.integration_parameters.dt = args.common.dt as Real;
    let (_, ground) = world.insert(
        RigidBodyBuilder::fixed(),
        ColliderBuilder::halfspace(rapier_impact::rapier::na::Unit::new_unchecked(Vector::Y))
            .restitution(args.restitution as Real)
            .friction(args.friction as Real),
    );
    let (ball, _) = world.insert(
        RigidBodyBuilder::dynamic().translation(Vector::new(
            0.0,
            (args.radius + args.height) as Real,
            0.0,
        )),
        ColliderBuilder::ball(args.radius as Real)
            .restitution(args.restitution as Real)
            .friction(args.friction as Real),
    );
    let mut plugin = match mode {
        Mode::Rapier => None,
        Mode::Plugin(timing) => {
            let mut config = ImpactConfig::default();
            config.timing = timing;
            let mut p = ImpactPlugin::new(config).expect("valid config");
            p.add_ground(&world.bodies, &world.colliders, ground)
                .expect("the ground collider exists");
            Some(p)
        }
    };
    let dt = f64::from(world.integration_parameters.dt);
    let steps = (args.duration / dt).ceil() as usize;
    let mut csv = csv.map(|path| {
        let mut f = std::io::BufWriter::new(common::or_exit(
            std::fs::File::create(path),
            &format!("cannot create {path}"),
        ));
        common::or_exit(
            writeln!(f, "t,x,y,z,vx,vy,vz,wx,wy,wz"),
            &format!("cannot write {path}"),
        );
        (f, path)
    });
    let mut impacts: Vec<f64> = Vec::new();
    let mut apexes: Vec<f64> = Vec::new();
    let mut top: Option<(f64, f64)> = None; // (y, vy) of the highest sample of this flight
    let mut prev_vy = 0.0;
    let radius = args.radius;
    for k in 0..=steps {
        let t = k as f64 * dt;
        if k > 0 {
            match plugin.as_mut() {
                Some(p) => {
                    p.step(&mut world);
                    for e in p.events() {
                        if e.kind == EventKind::Impact && !e.settled {
                            impacts.push(t - dt + e.time);
                        }
                    }
                }
                None => world.step(),
            }
        }
        let rb = &world.bodies[ball];
        let (p, v, w) = (rb.center_of_mass(), rb.linvel(), rb.angvel());
        if let Some((f, path)) = csv.as_mut() {
            common::or_exit(
                writeln!(
                    f,
                    "{t:.9},{},{},{},{},{},{},{},{},{}",
                    p.x, p.y, p.z, v.x, v.y, v.z, w.x, w.y, w.z
                ),
                &format!("cannot write {path}"),
            );
        }
        let (y, vy) = (f64::from(p.y), f64::from(v.y));
        if plugin.is_none() && prev_vy < 0.0 && vy > 0.0 {
            impacts.push(t);
        }
        // A flight ends when the ball starts rising again after falling.
        if prev_vy < 0.0 && vy > 0.0 {
            if let Some((ty, tvy)) = top.take() {
                apexes.push(ty - radius + tvy * tvy / (2.0 * g));
            }
        }
        if vy.abs() > 1e-9 && top.is_none_or(|(ty, _)| y > ty) {
            top = Some((y, vy));
        }
        prev_vy = vy;
    }
    if let Some((mut f, path)) = csv {
        common::or_exit(f.flush(), &format!("cannot write {path}"));
    }
    // The first "apex" is the release height: skip it.
    let apexes = apexes.into_iter().skip(1).collect();
    Drop {
        impacts,
        apexes,
        dt,
    }
}

fn main() {
    let args: Args = common::parse();
    common::check_precision::<Args>(args.common.f64);
    common::check_material::<Args>(args.common.mode, args.restitution, args.friction);
    let g = 9.81;
    let run = drop_ball(&args, args.common.mode, args.csv.as_deref());
    // Rapier alone on the same drop, beside a plugin mode.
    let alone = (args.common.mode != Mode::Rapier).then(|| drop_ball(&args, Mode::Rapier, None));
    let (h0, e, dt, radius) = (args.height, args.restitution, run.dt, args.radius);
    let t1 = (2.0 * h0 / g).sqrt();
    println!(
        "drop: h0 = {h0} m, R = {radius} m, e = {e}, mu = {}, dt = {dt:.7} s, mode = {}, precision = {}",
        args.friction,
        args.common.mode.name(),
        common::PRECISION
    );
    let mut header = format!(
        "{:>3} {:>12} {:>12} {:>10} {:>12} {:>12} {:>10}",
        "n", "t_impact", "analytic", "error s", "apex", "analytic", "rel err"
    );
    if alone.is_some() {
        header += &format!(
            " | {:>12} {:>10} {:>12}",
            "rapier apex", "rel err", "rapier t"
        );
    }
    println!("{header}");
    let rows = run.impacts.len().max(run.apexes.len()).min(12);
    let cell = |v: Option<&f64>, f: &dyn Fn(f64) -> String| v.map_or(String::from("-"), |x| f(*x));
    for n in 0..rows {
        let t_exp = if n == 0 {
            t1
        } else if e == 1.0 {
            // The closed form is 0/0 at e = 1: its limit, n equal flights of 2 t1.
            t1 + 2.0 * t1 * n as f64
        } else {
            t1 + 2.0 * t1 * e * (1.0 - e.powi(n as i32)) / (1.0 - e)
        };
        let apex_exp = e.powi(2 * (n as i32 + 1)) * h0;
        let ti = cell(run.impacts.get(n), &|t| format!("{t:.7}"));
        let te = cell(run.impacts.get(n), &|t| format!("{:+.2e}", t - t_exp));
        let ap = cell(run.apexes.get(n), &|a| format!("{a:.7}"));
        let ae = cell(run.apexes.get(n), &|a| {
            format!("{:+.2e}", a / apex_exp - 1.0)
        });
        let mut row = format!(
            "{:>3} {ti:>12} {t_exp:>12.7} {te:>10} {ap:>12} {apex_exp:>12.7} {ae:>10}",
            n + 1
        );
        if let Some(alone) = &alone {
            let rap = cell(alone.apexes.get(n), &|a| format!("{a:.7}"));
            let rae = cell(alone.apexes.get(n), &|a| {
                format!("{:+.2e}", a / apex_exp - 1.0)
            });
            let rt = cell(alone.impacts.get(n), &|t| format!("{t:.7}"));
            row += &format!(" | {rap:>12} {rae:>10} {rt:>12}");
        }
        println!("{row}");
    }
}
