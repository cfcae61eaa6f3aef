//! A cube thrown onto the ground, tumbling, headless: a table of its impacts (time, contact
//! points, regime, kinetic energy before and after) and the face that ends up on top.
//!
//! ```text
//! cargo run --release --example dice -- --seed 7 --law consistent --events dice_events.csv
//! ```
//!
//! Every flag has a default; `--help` lists them with their units. `--csv PATH` writes the
//! trace `t,x,y,z,vx,vy,vz,wx,wy,wz` of the cube's centre of mass, `--events PATH` the impacts,
//! `t,body,px,py,pz,nx,ny,nz,jn,jt,regime,ke_before,ke_after`.
//!
//! The faces are numbered as on a die, opposite faces summing to 7: local +x = 1, +y = 2,
//! +z = 3, -z = 4, -y = 5, -x = 6.

mod common;

use clap::Parser;
use common::{DiceThrow, EventsCsv, LawChoice, Mode, TraceCsv, real, wide};
use rapier_impact::model::Law;
use rapier_impact::rapier::prelude::*;

/// A cube thrown onto the ground, tumbling: the table of its impacts (time, contact points,
/// regime, normal impulse, kinetic energy before and after) and the face on top at the end,
/// its tilt and whether it sleeps. The throw (height, velocity, spin, orientation) is drawn
/// from the seed.
#[derive(Parser, Debug)]
#[command(
    name = "dice",
    after_help = "Example: cargo run --release --example dice -- --seed 7 --law consistent --events dice_events.csv"
)]
struct Args {
    /// Seed of the random throw: height, velocity, spin, orientation
    #[arg(long, value_name = "N", default_value = "1", value_parser = |s: &str| common::whole(s, 0))]
    seed: u64,
    /// Coefficient of restitution of cube and ground
    #[arg(long, value_name = "E", default_value = "0.5", value_parser = common::non_negative)]
    restitution: f64,
    /// Coefficient of friction of cube and ground
    #[arg(long, value_name = "MU", default_value = "0.5", value_parser = common::non_negative)]
    friction: f64,
    /// The impact law
    #[arg(long, value_enum, value_name = "LAW", default_value_t = LawChoice::Guarded)]
    law: LawChoice,
    /// Rapier alone (which has no impact events), or the plugin in one of its timing modes
    #[arg(long, value_enum, value_name = "MODE", default_value_t = Mode::EXACT)]
    mode: Mode,
    /// Edge length of the cube (m)
    #[arg(long, value_name = "S", default_value = "0.1", value_parser = common::positive)]
    size: f64,
    /// Time step (s)
    #[arg(long, value_name = "DT", default_value = "1/60", value_parser = common::positive)]
    dt: f64,
    /// Simulated time (s)
    #[arg(long, value_name = "T", default_value = "4", value_parser = common::positive)]
    duration: f64,
    /// Double precision: needs a build with `--features f64` (the precision is chosen at
    /// build time)
    #[arg(long)]
    f64: bool,
    /// Write the trace t,x,y,z,vx,vy,vz,wx,wy,wz of the cube's centre of mass (m, m/s, rad/s)
    /// [default: none]
    #[arg(long, value_name = "PATH")]
    csv: Option<String>,
    /// Write the impacts t,body,px,py,pz,nx,ny,nz,jn,jt,regime,ke_before,ke_after (s, m, N s,
    /// J) [default: none]
    #[arg(long, value_name = "PATH")]
    events: Option<String>,
}

/// The die faces: local outward normal and pips.
const FACES: [([f64; 3], u32); 6] = [
    ([1.0, 0.0, 0.0], 1),
    ([0.0, 1.0, 0.0], 2),
    ([0.0, 0.0, 1.0], 3),
    ([0.0, 0.0, -1.0], 4),
    ([0.0, -1.0, 0.0], 5),
    ([-1.0, 0.0, 0.0], 6),
];

fn main() {
    let args: Args = common::parse();
    common::check_precision::<Args>(args.f64);
    common::check_material::<Args>(args.mode, args.restitution, args.friction);
    let (seed, e, mu, size) = (args.seed, args.restitution, args.friction, args.size);
    let (law, mode): (Law, Mode) = (args.law.into(), args.mode);
    let (dt, duration) = (args.dt, args.duration);

    // The throw: 0.5 to 1 m up, 1 to 3 m/s sideways in a random direction, a random spin of
    // up to 10 rad/s per axis, a random orientation (uniform unit quaternion).
    let throw = DiceThrow::new(seed);
    let (height, speed, spin) = (throw.height, throw.speed, throw.spin);

    let mut world = common::world(dt);
    let ground = common::ground(&mut world, e, mu);
    let cube = throw.insert_cube(&mut world, 0.5 * size, e, mu);
    let mut plugin = common::plugin(mode, law, &mut world, ground);
    let mut csv = args.csv.as_deref().map(|p| TraceCsv::create(p, cube));
    let mut events_csv = args.events.as_deref().map(EventsCsv::create);

    let dt = wide(world.integration_parameters.dt);
    let steps = (duration / dt).ceil() as usize;
    // (t, points, regime, jn, ke_before, ke_after)
    let mut impacts: Vec<Impact> = Vec::new();
    let mut asleep_at = None;
    if let Some(c) = csv.as_mut() {
        c.row(0.0, &world.bodies);
    }
    for n in 1..=steps {
        let t0 = (n - 1) as f64 * dt;
        let events = common::step(&mut world, &mut plugin);
        for ev in events {
            impacts.push((
                t0 + ev.time,
                ev.contact_points,
                common::regime_label(ev),
                ev.normal_impulse,
                ev.ke_before,
                ev.ke_after,
            ));
        }
        if let Some(c) = events_csv.as_mut() {
            c.write(t0, events);
        }
        if let Some(c) = csv.as_mut() {
            c.row(n as f64 * dt, &world.bodies);
        }
        if asleep_at.is_none() && world.bodies[cube].is_sleeping() {
            asleep_at = Some(n as f64 * dt);
        }
    }
    if let Some(c) = csv {
        c.finish();
    }
    if let Some(c) = events_csv {
        c.finish();
    }

    println!(
        "dice: seed {seed}, edge {size} m, e = {e}, mu = {mu}, law {}, mode {}, dt = {dt:.7} s, \
         precision {}",
        args.law.name(),
        mode.name(),
        common::PRECISION
    );
    println!(
        "throw: {height:.3} m up, {speed:.3} m/s sideways, spin ({:.2}, {:.2}, {:.2}) rad/s",
        spin[0], spin[1], spin[2]
    );
    if mode == Mode::Rapier {
        println!("rapier alone: no impact events (rapier's own contacts and restitution)");
    } else {
        print_impacts(&impacts);
    }
    print_top(&world.bodies[cube], asleep_at);
}

/// One impact of the table: (t, points, regime, jn, ke_before, ke_after).
type Impact = (f64, usize, String, f64, f64, f64);

/// The table of the first impacts.
fn print_impacts(impacts: &[Impact]) {
    println!(
        "{:>3} {:>10} {:>6} {:<28} {:>10} {:>11} {:>11} {:>7}",
        "n", "t (s)", "points", "regime", "jn (N s)", "KE before", "KE after", "after %"
    );
    const SHOWN: usize = 40;
    for (i, (t, points, regime, jn, kb, ka)) in impacts.iter().enumerate().take(SHOWN) {
        let kept = if *kb > 0.0 { 100.0 * ka / kb } else { 100.0 };
        println!(
            "{:>3} {t:>10.5} {points:>6} {regime:<28} {jn:>10.5} {kb:>11.6} {ka:>11.6} {kept:>7.1}",
            i + 1
        );
    }
    if impacts.len() > SHOWN {
        println!("... {} impacts in all", impacts.len());
    }
}

/// The face on top, its tilt, and the cube's rest.
fn print_top(rb: &RigidBody, asleep_at: Option<f64>) {
    let rot = *rb.rotation();
    let (face, up) = FACES
        .iter()
        .map(|(n, pips)| {
            let world_n = rot * Vector::new(real(n[0]), real(n[1]), real(n[2]));
            (*pips, wide(world_n.y))
        })
        .max_by(|a, b| a.1.total_cmp(&b.1))
        .unwrap();
    let tilt = up.clamp(-1.0, 1.0).acos().to_degrees();
    println!(
        "on top: {face} (tilt {tilt:.2} deg), centre {:.4} m up, speed {:.2e} m/s, spin {:.2e} rad/s, {}",
        wide(rb.center_of_mass().y),
        wide(rb.linvel().length()),
        wide(rb.angvel().length()),
        match asleep_at {
            Some(t) if rb.is_sleeping() => format!("asleep since {t:.3} s"),
            _ => "still awake".to_string(),
        }
    );
}
