//! A ball landing with horizontal speed and spin, headless: the velocity and spin after each
//! bounce, measured against the closed forms (docs/model.md, "Closed forms used in the tests").
//!
//! ```text
//! cargo run --release --example spin -- --vx 5 --vy 5 --spin 30 --friction 0.1 --shell hollow
//! ```
//!
//! Every flag has a default; `--help` lists them with their units. `--vy` is the downward
//! speed at first contact (the release velocity is chosen for it); `--csv PATH` writes the
//! trace `t,x,y,z,vx,vy,vz,wx,wy,wz`.
//!
//! Axes. rapier is y up; the closed forms are written z up with a spin `w_y` about the
//! horizontal axis. The right-handed map from z-up `(x, y, z)` to y-up is `(x, -z, y)`, so
//! `w_y (z up) = -w_z (y up)`. Here the contact point is `r = (0, -R, 0)` and its slip velocity
//! is `u = vx + R w_z`: a ball rolling forward along +x has `w_z = -vx / R < 0`, and a positive
//! `--spin` is backspin. The closed forms, in this frame, with `k = I/(m R^2)` (2/5 solid,
//! 2/3 hollow) and `vy` the downward speed:
//! - stick iff `|u| <= mu (1+e) vy (1+k)/k`: `vx' = (vx - k R w_z)/(1+k)`, `w_z' = -vx'/R`;
//! - slip otherwise: `vx' = vx - mu (1+e) vy sgn(u)`, `w_z' = w_z - mu (1+e) vy sgn(u)/(k R)`;
//! - `vy' = e vy` upwards, in both.
//!
//! The ball is built with `allow_fast_rotation(true)`: without it rapier caps a body's angular
//! speed at pi/4 rad per step (47 rad/s at 60 Hz), so a 300 rad/s spin would become 47 rad/s
//! before the first bounce.
//!
//! Measured values are read from the highest sample of each flight after a bounce: `vx` and
//! `w_z` are constant in flight, and the take-off speed is `sqrt(vy^2 + 2 g (y - R))`, exact
//! for ballistic flight whatever the sample.

mod common;

use clap::Parser;
use common::{Mode, Shell, TraceCsv, real, wide};
use rapier_impact::model::Law;
use rapier_impact::rapier::prelude::*;

/// A ball landing with horizontal speed and spin: after each bounce, its horizontal velocity,
/// spin and take-off speed measured beside the closed forms (stick or slip), chained from the
/// release state. A positive `--spin` is backspin.
#[derive(Parser, Debug)]
#[command(
    name = "spin",
    after_help = "Example: cargo run --release --example spin -- --vx 5 --vy 5 --spin 30 --friction 0.1 --shell hollow"
)]
struct Args {
    /// Gap from the ball's bottom to the ground at release (m)
    #[arg(long, value_name = "H", default_value = "0.5", value_parser = common::positive)]
    height: f64,
    /// Ball radius (m)
    #[arg(long, value_name = "R", default_value = "0.1", value_parser = common::positive)]
    radius: f64,
    /// Coefficient of restitution of ball and ground
    #[arg(long, value_name = "E", default_value = "0.6", value_parser = common::non_negative)]
    restitution: f64,
    /// Coefficient of friction of ball and ground
    #[arg(long, value_name = "MU", default_value = "0.4", value_parser = common::non_negative)]
    friction: f64,
    /// Horizontal speed along +x (m/s)
    #[arg(long, value_name = "VX", default_value = "5", value_parser = common::number)]
    vx: f64,
    /// Downward speed at first contact, > 0 (m/s)
    #[arg(long, value_name = "VY", default_value = "5", value_parser = common::positive)]
    vy: f64,
    /// Angular velocity about world z (rad/s); > 0 is backspin
    #[arg(long, value_name = "W", default_value = "0", value_parser = common::number)]
    spin: f64,
    /// Solid ball or thin shell
    #[arg(long, value_enum, value_name = "SHELL", default_value_t = Shell::Solid)]
    shell: Shell,
    /// Simulated time (s)
    #[arg(long, value_name = "T", default_value = "1.5", value_parser = common::positive)]
    duration: f64,
    // --dt, --mode and --f64, as in the other scenes.
    #[command(flatten)]
    common: common::CommonArgs,
    /// Write the trace t,x,y,z,vx,vy,vz,wx,wy,wz of the ball (m, m/s, rad/s), one row per step
    /// and one at t = 0 [default: none]
    #[arg(long, value_name = "PATH")]
    csv: Option<String>,
}

/// The closed-form bounce of a ball with `k = I/(m R^2)`: returns `(vx', w_z', vy', stick)`
/// from `(vx, w_z, vy)`, `vy` the downward speed (y up, see the module docs).
fn closed_form(
    k: f64,
    r: f64,
    e: f64,
    mu: f64,
    vx: f64,
    wz: f64,
    vy: f64,
) -> (f64, f64, f64, bool) {
    let u = vx + r * wz;
    let pn = (1.0 + e) * vy; // normal impulse per unit mass
    if u.abs() <= mu * pn * (1.0 + k) / k {
        let vx2 = (vx - k * r * wz) / (1.0 + k);
        (vx2, -vx2 / r, e * vy, true)
    } else {
        let s = u.signum();
        (vx - mu * pn * s, wz - mu * pn * s / (k * r), e * vy, false)
    }
}

/// What one flight after a bounce showed at its highest sample.
struct Flight {
    vx: f64,
    wz: f64,
    /// Take-off speed, `sqrt(vy^2 + 2 g (y - R))`.
    vy: f64,
}
/// The ground, and the ball released `args.height` above it so as to reach it at `args.vy`;
/// exits with a message when no release speed does (`g` downwards, `k = I/(m R^2)`).
fn insert_ball(
    args: &Args,
    world: &mut PhysicsWorld,
    g: f64,
    k: f64,
) -> (ColliderHandle, RigidBodyHandle) {
    let (height, radius, e, mu) = (args.height, args.radius, args.restitution, args.friction);
    // Released at gap `height`, moving down so as to reach the ground at `--vy`.
    let vy0_sq = args.vy * args.vy - 2.0 * g * height;
    if vy0_sq < 0.0 {
        common::fail::<Args>(format!(
            "a ball released {height} m above the ground reaches it at >= {:.4} m/s: \
             raise --vy or lower --height",
            (2.0 * g * height).sqrt()
        ));
    }
    let ground = common::ground(world, e, mu);
    let mass = 1.0;
    let (ball, _) = world.insert(
        RigidBodyBuilder::dynamic()
            .translation(Vector::new(0.0, real(radius + height), 0.0))
            .linvel(Vector::new(real(args.vx), real(-vy0_sq.sqrt()), 0.0))
            .angvel(Vector::new(0.0, 0.0, real(args.spin)))
            .allow_fast_rotation(true),
        ColliderBuilder::ball(real(radius))
            .mass_properties(MassProperties::new(
                Vector::ZERO,
                real(mass),
                Vector::splat(real(k * mass * radius * radius)),
            ))
            .restitution(real(e))
            .friction(real(mu)),
    );
    (ground, ball)
}

/// Steps for `args.duration` (writing the trace if asked) and returns each flight after a
/// bounce, as seen at its highest sample.
fn fly(
    args: &Args,
    world: &mut PhysicsWorld,
    ball: RigidBodyHandle,
    plugin: &mut Option<rapier_impact::ImpactPlugin>,
    g: f64,
) -> Vec<Flight> {
    let radius = args.radius;
    let mut csv = args.csv.as_deref().map(|p| TraceCsv::create(p, ball));
    let dt = wide(world.integration_parameters.dt);
    let steps = (args.duration / dt).ceil() as usize;
    let mut flights: Vec<Flight> = Vec::new();
    let mut top: Option<(f64, Flight)> = None; // highest sample of the current flight
    let mut prev_vy = -1.0;
    let mut bounced = false;
    for n in 0..=steps {
        if n > 0 {
            common::step(world, plugin);
        }
        let t = n as f64 * dt;
        if let Some(c) = csv.as_mut() {
            c.row(t, &world.bodies);
        }
        let rb = &world.bodies[ball];
        let (y, v, w) = (wide(rb.center_of_mass().y), rb.linvel(), rb.angvel());
        let vy = wide(v.y);
        if prev_vy <= 0.0 && vy > 0.0 {
            // A new flight starts: the previous one ended.
            if let Some((_, f)) = top.take() {
                // Rapier's resting jitter is not a bounce.
                if f.vy > 0.05 {
                    flights.push(f);
                }
            }
            bounced = true;
        }
        if bounced && top.as_ref().is_none_or(|(ty, _)| y > *ty) {
            let takeoff = (vy * vy + 2.0 * g * (y - radius)).max(0.0).sqrt();
            top = Some((
                y,
                Flight {
                    vx: wide(v.x),
                    wz: wide(w.z),
                    vy: takeoff,
                },
            ));
        }
        prev_vy = vy;
    }
    // The last flight counts if it reached its apex before the end.
    if let Some((_, f)) = top.take() {
        if prev_vy < 0.0 && f.vy > 0.05 {
            flights.push(f);
        }
    }
    if let Some(c) = csv {
        c.finish();
    }
    flights
}

fn main() {
    let args: Args = common::parse();
    common::check_precision::<Args>(args.common.f64);
    common::check_material::<Args>(args.common.mode, args.restitution, args.friction);
    let (radius, e, mu, k) = (
        args.radius,
        args.restitution,
        args.friction,
        args.shell.inertia_ratio(),
    );
    let (vx0, vy_contact, spin0, mode) = (args.vx, args.vy, args.spin, args.common.mode);
    let mut world = common::world(args.common.dt);
    let g = -wide(world.gravity.y);
    let (ground, ball) = insert_ball(&args, &mut world, g, k);
    let mut plugin = common::plugin(mode, Law::Guarded, &mut world, ground);
    let flights = fly(&args, &mut world, ball, &mut plugin, g);
    let dt = wide(world.integration_parameters.dt);
    println!(
        "spin: R = {radius} m, {} sphere (k = {k:.4}), e = {e}, mu = {mu}, vx = {vx0} m/s, \
         vy = {vy_contact} m/s down, spin w_z = {spin0} rad/s, dt = {dt:.7} s, mode = {}, \
         precision = {}",
        args.shell.name(),
        mode.name(),
        common::PRECISION
    );
    if flights.is_empty() {
        println!("no complete bounce within --duration {} s", args.duration);
        return;
    }
    println!(
        "{:>6} {:>7} {:>9} {:>14} {:>14} {:>11}",
        "bounce", "regime", "quantity", "measured", "closed form", "rel err"
    );
    // The closed form chained from the release state, bounce after bounce.
    let (mut vx, mut wz, mut vy) = (vx0, spin0, vy_contact);
    for (i, f) in flights.iter().enumerate().take(5) {
        let (vx2, wz2, vy2, stick) = closed_form(k, radius, e, mu, vx, wz, vy);
        let regime = if stick { "stick" } else { "slip" };
        for (name, m, x) in [("vx'", f.vx, vx2), ("w_z'", f.wz, wz2), ("vy'", f.vy, vy2)] {
            let rel = if x.abs() > 1e-12 {
                format!("{:+.2e}", m / x - 1.0)
            } else {
                format!("{:+.2e} abs", m - x)
            };
            println!(
                "{:>6} {regime:>7} {name:>9} {m:>14.7} {x:>14.7} {rel:>11}",
                i + 1
            );
        }
        (vx, wz, vy) = (vx2, wz2, vy2);
    }
    if mode == Mode::Rapier {
        println!("(rapier alone: rapier's own contact, restitution and friction)");
    }
}
