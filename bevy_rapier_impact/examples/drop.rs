//! A ball dropped in a headless Bevy app (minimal plugins, no window): bounce apexes with the
//! impact plugin and with bevy_rapier alone, against the closed form `apex_n = e^(2n) h0`.
//!
//! ```text
//! cargo run --release -p bevy_rapier_impact --example drop --ignore-rust-version -- --substeps 4
//! ```
//!
//! Flags (`--help` lists them): `--dt DT` (s, the frame's physics time, 1/60), `--substeps N`
//! (rapier steps per frame, `TimestepMode::Fixed`, 1), `--frames F` (300). The ball (radius
//! 0.1 m, e = 0.8, mu = 0.5) falls 1 m onto a half-space, a `Ground` with its own
//! `GroundMaterial`.

use bevy::prelude::*;
use bevy::time::TimeUpdateStrategy;
use bevy_rapier_impact::{
    EventKind, Ground, GroundMaterial, ImpactConfig, ImpactMessage, RapierImpactPlugin,
};
use bevy_rapier3d::prelude::*;
use clap::Parser;
use std::time::Duration;

const H0: f64 = 1.0;
const E: f64 = 0.8;
const RADIUS: f64 = 0.1;
const G: f64 = 9.81;

/// A ball dropped 1 m onto a half-space in a headless Bevy app: bounce apexes with the impact
/// plugin and with bevy_rapier alone, against e^(2n) h0.
#[derive(Parser)]
#[command(name = "drop")]
struct Args {
    /// The frame's physics time (s).
    #[arg(
        long,
        value_name = "DT",
        default_value_t = 1.0 / 60.0,
        value_parser = positive_time,
        allow_negative_numbers = true
    )]
    dt: f32,
    /// Rapier steps per frame (`TimestepMode::Fixed`).
    #[arg(long, value_name = "N", default_value_t = 1, value_parser = positive_count)]
    substeps: usize,
    /// Frames to run.
    #[arg(long, value_name = "F", default_value_t = 300)]
    frames: usize,
}

/// A finite time step above zero.
fn positive_time(value: &str) -> Result<f32, String> {
    value
        .parse()
        .ok()
        .filter(|x: &f32| x.is_finite() && *x > 0.0)
        .ok_or_else(|| format!("not a positive, finite number of seconds: {value}"))
}

/// A count above zero.
fn positive_count(value: &str) -> Result<usize, String> {
    value
        .parse()
        .ok()
        .filter(|n| *n > 0)
        .ok_or_else(|| format!("not a whole number above 0: {value}"))
}

/// Impacts counted by the app (with the plugin only).
#[derive(Resource, Default)]
struct Impacts(usize);

fn count(mut n: ResMut<Impacts>, mut messages: MessageReader<ImpactMessage>) {
    n.0 += messages
        .read()
        .filter(|m| m.event.kind == EventKind::Impact)
        .count();
}

/// Runs the drop, with the impact plugin or bevy_rapier alone; returns the apex of each
/// flight after a bounce (`y - R + vy^2/(2g)` at its highest frame: exact for ballistic
/// flight) and the impacts counted.
fn run(args: &Args, with_plugin: bool) -> (Vec<f64>, usize) {
    let mut app = App::new();
    app.add_plugins((MinimalPlugins, TransformPlugin));
    if with_plugin {
        let plugin = match RapierImpactPlugin::<NoUserData>::new(ImpactConfig::default()) {
            Ok(p) => p,
            Err(e) => panic!("the default configuration was refused: {e}"),
        };
        app.add_plugins(plugin).add_systems(Last, count);
    } else {
        app.add_plugins(RapierPhysicsPlugin::<NoUserData>::default());
    }
    app.insert_resource(TimestepMode::Fixed {
        dt: args.dt,
        substeps: args.substeps,
    })
    .insert_resource(TimeUpdateStrategy::ManualDuration(Duration::from_secs_f32(
        args.dt,
    )))
    .init_resource::<Impacts>();
    // The ground's own material: the plugin uses its coefficients in place of those rapier
    // combines from the two colliders (which bevy_rapier alone uses). Its `e` is the colliders'
    // as rapier stores them (f32), so that both runs bounce with the same coefficient.
    app.world_mut().spawn((
        Transform::default(),
        Collider::halfspace(Vec3::Y).unwrap_or_else(|| Collider::cuboid(10.0, 0.5, 10.0)),
        Restitution::coefficient(E as f32),
        Friction::coefficient(0.5),
        Ground,
        GroundMaterial::new(f64::from(E as f32), 0.5),
    ));
    let ball = app
        .world_mut()
        .spawn((
            Transform::from_xyz(0.0, (RADIUS + H0) as f32, 0.0),
            RigidBody::Dynamic,
            Collider::ball(RADIUS as f32),
            Restitution::coefficient(E as f32),
            Friction::coefficient(0.5),
        ))
        .id();
    let mut apexes = Vec::new();
    let mut top: Option<(f64, f64)> = None;
    let (mut prev_vy, mut flights) = (0.0, 0);
    for _ in 0..args.frames {
        app.update();
        let Some(handle) = app.world().get::<RapierRigidBodyHandle>(ball).map(|h| h.0) else {
            continue;
        };
        let mut sets = app.world_mut().query::<&RapierRigidBodySet>();
        let Some(rb) = sets.iter(app.world()).find_map(|s| s.bodies.get(handle)) else {
            continue;
        };
        let (y, vy) = (f64::from(rb.center_of_mass().y), f64::from(rb.linvel().y));
        if prev_vy < 0.0
            && vy > 0.0
            && let Some((ty, tvy)) = top.take()
        {
            if flights > 0 {
                apexes.push(ty - RADIUS + tvy * tvy / (2.0 * G));
            }
            flights += 1;
        }
        if vy.abs() > 1e-9 && top.is_none_or(|(ty, _)| y > ty) {
            top = Some((y, vy));
        }
        prev_vy = vy;
    }
    (apexes, app.world().resource::<Impacts>().0)
}

fn main() {
    let args = Args::parse();
    let (plugin, impacts) = run(&args, true);
    let (rapier, _) = run(&args, false);
    println!(
        "drop 1 m, e = {E}, frame {:.6} s in {} rapier step(s), {} frames: apex n vs e^(2n) h0",
        args.dt, args.substeps, args.frames
    );
    println!(
        "{:>3} {:>10} {:>10} {:>10} | {:>10} {:>10}",
        "n", "expected", "plugin", "rel err", "rapier", "rel err"
    );
    let fmt = |x: Option<f64>| x.map_or("-".to_string(), |x| format!("{x:.7}"));
    let err =
        |x: Option<f64>, e: f64| x.map_or("-".to_string(), |x| format!("{:+.2e}", x / e - 1.0));
    for n in 1..=plugin.len().max(rapier.len()).min(10) {
        let expected = E.powi(2 * n as i32) * H0;
        let (p, r) = (plugin.get(n - 1).copied(), rapier.get(n - 1).copied());
        println!(
            "{n:>3} {expected:>10.7} {:>10} {:>10} | {:>10} {:>10}",
            fmt(p),
            err(p, expected),
            fmt(r),
            err(r, expected)
        );
    }
    println!("impact messages: {impacts}");
}
