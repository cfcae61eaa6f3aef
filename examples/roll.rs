//! A ball set on a plane ground, headless: when it starts rolling, when it stops and how far
//! it went, beside the closed form (`docs/model.md`, "A ball on a plane"); `--mode rapier` is
//! rapier alone on the same scene.
//!
//! ```text
//! cargo run --release --example roll -- --speed 2 --rolling-resistance 0.01
//! cargo run --release --example roll -- --speed 1 --backspin 60 --rolling-resistance 0.01
//! ```
//!
//! Every flag has a default; `--help` lists them with their units. `--csv PATH` writes the
//! trace `t,x,y,z,vx,vy,vz,wx,wy,wz`, world frame, y up, one row per step and one at t = 0.
//!
//! Measured: the first step end at which the contact point's slip is below 1e-6 m/s (rolls),
//! the first at which the ball is at rest (its speed below 1e-6 m/s), and the distance along
//! the ground then, or at the end of the run.

mod common;

use clap::Parser;
use common::{Coefficient, Mode, Shell, TraceCsv, real, wide};
use rapier_impact::na::Vector3;
use rapier_impact::rapier::prelude::*;
use rapier_impact::{ImpactConfig, ImpactPlugin};

/// A ball on a plane ground, level or sloped, launched sliding, spinning or rolling: when it
/// starts rolling, when it stops (and its spin about the normal) and how far it went, measured
/// beside the closed form with rolling resistance and spinning friction.
#[derive(Parser, Debug)]
#[command(
    name = "roll",
    after_help = "Example: cargo run --release --example roll -- --rolling --speed 1.8 --rolling-resistance 0.078"
)]
struct Args {
    /// Initial centre speed along the ground, +x of the ground's frame, downhill (m/s)
    #[arg(long, value_name = "V", default_value = "2", value_parser = common::non_negative)]
    speed: f64,
    /// Backspin (rad/s; 0: no spin, negative: topspin)
    #[arg(long, value_name = "W", default_value = "0", value_parser = common::number)]
    backspin: f64,
    /// Start rolling without slip (the spin is then v/R: not with --backspin)
    #[arg(long, conflicts_with = "backspin")]
    rolling: bool,
    /// Spin about the ground normal (rad/s)
    #[arg(long, value_name = "W", default_value = "0", value_parser = common::number)]
    normal_spin: f64,
    /// Ball-ground coefficient of friction
    #[arg(long, value_name = "MU", default_value = "0.2", value_parser = common::non_negative)]
    friction: f64,
    /// Rolling resistance coefficient (dimensionless)
    #[arg(long, value_name = "MU_R", default_value = "0.01", value_parser = common::non_negative)]
    rolling_resistance: f64,
    /// Spinning friction coefficient (dimensionless)
    #[arg(long, value_name = "MU_SP", default_value = "0.01", value_parser = common::non_negative)]
    spinning_friction: f64,
    /// Ground tilt about world z, downhill +x, in [0, 80) (deg)
    #[arg(long, value_name = "DEG", default_value = "0", value_parser = |s: &str| common::degrees_below(s, 80.0))]
    slope: f64,
    /// Ball radius (m; the default is a golf ball)
    #[arg(long, value_name = "R", default_value = "0.021335", value_parser = common::positive)]
    radius: f64,
    /// Solid ball or thin shell
    #[arg(long, value_enum, value_name = "SHELL", default_value_t = Shell::Solid)]
    shell: Shell,
    /// Simulated time (s)
    #[arg(long, value_name = "T", default_value = "20", value_parser = common::positive)]
    duration: f64,
    // --dt, --mode and --f64, as in the other scenes.
    #[command(flatten)]
    common: common::CommonArgs,
    /// Write the trace t,x,y,z,vx,vy,vz,wx,wy,wz of the ball (m, m/s, rad/s), one row per step
    /// and one at t = 0 [default: none]
    #[arg(long, value_name = "PATH")]
    csv: Option<String>,
}

/// The closed form along the fall line (or on level ground): when the slip ends, when the
/// ball stops (`None`: not within the run), and how far it went along +x of the ground by
/// then, or by the end of the run.
struct ClosedForm {
    rolls_at: Option<f64>,
    stops_at: Option<f64>,
    distance: f64,
    spin_stops_at: Option<f64>,
}

#[allow(clippy::too_many_arguments)]
fn closed_form(
    v0: f64,
    slip0: f64,
    k: f64,
    r: f64,
    g: f64,
    slope: f64,
    mu: f64,
    mu_r: f64,
    mu_sp: f64,
    normal_spin: f64,
    duration: f64,
) -> ClosedForm {
    let (gs, gc) = (g * slope.sin(), g * slope.cos());
    // Phases of constant acceleration along +x of the ground: (length, acceleration).
    let mut phases: Vec<(f64, f64)> = Vec::new();
    let mut v = v0;
    let mut rolls_at = Some(0.0);
    if slip0 != 0.0 {
        // Sliding: the slip changes at gs - mu gc (1 + 1/k) against its sign, the speed at
        // gs - mu gc against it.
        let sign = slip0.signum();
        let rate = gs - mu * gc * (1.0 + 1.0 / k) * sign;
        let a = gs - mu * gc * sign;
        if rate * sign >= 0.0 {
            rolls_at = None;
            phases.push((f64::INFINITY, a));
        } else {
            let t_roll = -slip0 / rate;
            phases.push((t_roll, a));
            v += a * t_roll;
            rolls_at = Some(t_roll);
        }
    }
    let mut stops_at = None;
    if let Some(t_roll) = rolls_at {
        // Rolling: (gs -+ mu_r gc) / (1 + k) against the motion; at rest, held where
        // |gs| <= mu_r gc, else rolling down for ever.
        let sign = if v != 0.0 { v.signum() } else { gs.signum() };
        let a = (gs - mu_r * gc * sign) / (1.0 + k);
        if v != 0.0 && a * v < 0.0 {
            let h = -v / a;
            phases.push((h, a));
            if gs.abs() <= mu_r * gc {
                stops_at = Some(t_roll + h);
            } else {
                phases.push((f64::INFINITY, (gs - mu_r * gc * gs.signum()) / (1.0 + k)));
            }
        } else if v == 0.0 && gs.abs() <= mu_r * gc {
            stops_at = Some(t_roll);
        } else {
            phases.push((f64::INFINITY, a));
        }
    }
    // Where it is at the end of the run (or where it stopped).
    let (mut t, mut x, mut v) = (0.0, 0.0, v0);
    for (length, a) in phases {
        let h = length.min(duration - t);
        if h <= 0.0 {
            break;
        }
        x += v * h + 0.5 * a * h * h;
        v += a * h;
        t += h;
    }
    let spin_stops_at = (mu_sp > 0.0 && normal_spin != 0.0)
        .then(|| normal_spin.abs() * k * r / (mu_sp * gc))
        .filter(|t| *t <= duration);
    ClosedForm {
        rolls_at: rolls_at.filter(|t| *t <= duration),
        stops_at: stops_at.filter(|t| *t <= duration),
        distance: x,
        spin_stops_at,
    }
}

/// The ground's frame: its normal `n` and downhill direction `d` (+x on level ground).
fn frame(slope: f64) -> (Vector3<f64>, Vector3<f64>) {
    (
        Vector3::new(slope.sin(), slope.cos(), 0.0),
        Vector3::new(slope.cos(), -slope.sin(), 0.0),
    )
}

/// The ground tilted by `args.slope`, the ball on it with velocity `v` and spin `w`, and the
/// plugin of `args.common.mode` (none for rapier alone).
fn build(
    args: &Args,
    v: Vector3<f64>,
    w: Vector3<f64>,
) -> (PhysicsWorld, RigidBodyHandle, Option<ImpactPlugin>) {
    let (r, mu) = (args.radius, args.friction);
    let (n, _) = frame(args.slope.to_radians());
    let mut world = common::world(args.common.dt);
    let (_, ground) = world.insert(
        RigidBodyBuilder::fixed(),
        ColliderBuilder::halfspace(rapier_impact::rapier::na::Unit::new_unchecked(
            Vector::new(real(n.x), real(n.y), 0.0).normalize(),
        ))
        .restitution(0.0)
        .friction(real(mu)),
    );
    let at = n * r;
    let mass_props = if args.shell == Shell::Hollow {
        // A thin shell: I = 2/3 m R^2, from a ball of density 1 with its inertia replaced.
        let m = 4.0 / 3.0 * std::f64::consts::PI * r * r * r;
        Some(MassProperties::new(
            Vector::ZERO,
            real(m),
            Vector::splat(real(2.0 / 3.0 * m * r * r)),
        ))
    } else {
        None
    };
    let mut collider = ColliderBuilder::ball(real(r))
        .restitution(0.0)
        .friction(real(mu));
    if let Some(mp) = mass_props {
        collider = collider.mass_properties(mp);
    }
    let (ball, _) = world.insert(
        RigidBodyBuilder::dynamic()
            .translation(Vector::new(real(at.x), real(at.y), real(at.z)))
            .linvel(Vector::new(real(v.x), real(v.y), real(v.z)))
            .angvel(Vector::new(real(w.x), real(w.y), real(w.z)))
            .allow_fast_rotation(true),
        collider,
    );
    let plugin = match args.common.mode {
        Mode::Rapier => None,
        Mode::Plugin(timing) => {
            let mut config = ImpactConfig::default();
            config.timing = timing;
            config.rolling_resistance = args.rolling_resistance;
            config.spinning_friction = args.spinning_friction;
            let mut p = ImpactPlugin::new(config).unwrap_or_else(|e| common::fail::<Args>(e));
            p.add_ground(&world.bodies, &world.colliders, ground)
                .expect("the ground exists");
            Some(p)
        }
    };
    (world, ball, plugin)
}

/// What the run measured: the first step ends at which the ball rolls, stops, and stops
/// spinning about the normal, and the distance along the ground at the end.
struct Measured {
    rolls: Option<f64>,
    stops: Option<f64>,
    spin_stops: Option<f64>,
    distance: f64,
}

/// Steps for `args.duration`, writing the trace if asked.
fn run(
    args: &Args,
    world: &mut PhysicsWorld,
    ball: RigidBodyHandle,
    plugin: &mut Option<ImpactPlugin>,
) -> Measured {
    let (r, dt, normal_spin) = (args.radius, args.common.dt, args.normal_spin);
    let (n, d) = frame(args.slope.to_radians());
    let mut csv = args.csv.as_deref().map(|p| TraceCsv::create(p, ball));
    if let Some(c) = csv.as_mut() {
        c.row(0.0, &world.bodies);
    }
    let state = |bodies: &RigidBodySet| {
        let rb = &bodies[ball];
        let na = |x: Vector| Vector3::new(wide(x.x), wide(x.y), wide(x.z));
        (na(rb.center_of_mass()), na(rb.linvel()), na(rb.angvel()))
    };
    let (start, _, _) = state(&world.bodies);
    let steps = (args.duration / dt).round() as usize;
    let (mut rolls, mut stops, mut spin_stops) = (None, None, None);
    let mut distance = 0.0;
    for step in 1..=steps {
        common::step(world, plugin);
        let t = step as f64 * dt;
        if let Some(c) = csv.as_mut() {
            c.row(t, &world.bodies);
        }
        let (com, v, w) = state(&world.bodies);
        let slip = v - r * w.cross(&n);
        if rolls.is_none() && slip.norm() < 1e-6 {
            rolls = Some(t);
        }
        if spin_stops.is_none() && normal_spin != 0.0 && w.dot(&n).abs() < 1e-6 {
            spin_stops = Some(t);
        }
        distance = (com - start).dot(&d);
        if stops.is_none() && v.norm() < 1e-6 && w.norm() < 1e-6 {
            stops = Some(t);
        }
    }
    if let Some(c) = csv {
        c.finish();
    }
    Measured {
        rolls,
        stops,
        spin_stops,
        distance,
    }
}

fn main() {
    let args: Args = common::parse();
    common::check_precision::<Args>(args.common.f64);
    common::check_coefficients::<Args>(
        args.common.mode,
        &[("--friction", Coefficient::Friction, args.friction)],
    );
    let (v0, r, mu, mu_r, mu_sp) = (
        args.speed,
        args.radius,
        args.friction,
        args.rolling_resistance,
        args.spinning_friction,
    );
    let slope_deg = args.slope;
    let slope = slope_deg.to_radians();
    let k = args.shell.inertia_ratio();
    let (dt, duration, mode, normal_spin) = (
        args.common.dt,
        args.duration,
        args.common.mode,
        args.normal_spin,
    );
    // The ground's frame: normal n, downhill d. Rolling forward along d spins at v / R about
    // n x d; backspin is the opposite sense.
    let (n, d) = frame(slope);
    let roll_axis = n.cross(&d);
    let spin_along = if args.rolling { v0 / r } else { -args.backspin };
    let slip0 = v0 - r * spin_along;
    let w = roll_axis * spin_along + n * normal_spin;
    let (mut world, ball, mut plugin) = build(&args, d * v0, w);
    let measured = run(&args, &mut world, ball, &mut plugin);
    let expected = closed_form(
        v0,
        slip0,
        k,
        r,
        9.81,
        slope,
        mu,
        mu_r,
        mu_sp,
        normal_spin,
        duration,
    );
    println!(
        "roll: V = {v0} m/s, slip = {slip0:.4} m/s, normal spin = {normal_spin} rad/s, mu = {mu}, \
mu_r = {mu_r}, mu_sp = {mu_sp}, slope = {slope_deg} deg, R = {r} m, k = {k:.4}, dt = {dt:.7} s, \
mode = {}, precision = {}",
        mode.name(),
        common::PRECISION
    );
    print_comparison(&measured, &expected, normal_spin);
}

/// The measured times and distance beside the closed form's.
fn print_comparison(measured: &Measured, expected: &ClosedForm, normal_spin: f64) {
    let time = |t: Option<f64>| t.map_or("never".to_string(), |t| format!("{t:.4} s"));
    println!("{:>22} {:>14} {:>14}", "", "measured", "closed form");
    println!(
        "{:>22} {:>14} {:>14}",
        "rolls from",
        time(measured.rolls),
        time(expected.rolls_at)
    );
    println!(
        "{:>22} {:>14} {:>14}",
        "stops at",
        time(measured.stops),
        time(expected.stops_at)
    );
    if normal_spin != 0.0 {
        println!(
            "{:>22} {:>14} {:>14}",
            "normal spin stops at",
            time(measured.spin_stops),
            time(expected.spin_stops_at)
        );
    }
    let distance = measured.distance;
    println!(
        "{:>22} {:>14} {:>14}",
        "distance",
        format!("{distance:.7} m"),
        format!("{:.7} m", expected.distance)
    );
    if expected.distance != 0.0 {
        println!(
            "{:>22} {:>14.2e}",
            "relative error",
            (distance - expected.distance) / expected.distance
        );
    }
}
