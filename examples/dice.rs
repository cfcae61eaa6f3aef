//! A cube thrown onto the ground, tumbling, headless: a table of its impacts (time, contact
//! points, regime, kinetic energy before and after) and the face that ends up on top.
//!
//! ```text
//! cargo run --release --example dice -- --seed 7 --law consistent --events dice_events.csv
//! ```
//!
//! Flags (each has a default; `--help` lists them): `--seed N` (the throw: height, velocity,
//! spin and orientation, 1), `--restitution E` (0.5), `--friction MU` (0.5),
//! `--law document|consistent|guarded` (guarded), `--mode rapier|step|toi|exact` (exact;
//! `rapier` is rapier alone, which has no impact events), `--size S` (edge length, m, 0.1),
//! `--dt DT` (s, 1/60), `--duration T` (s, 4), `--f64` (needs `--features f64`), `--csv PATH`
//! (trace `t,x,y,z,vx,vy,vz,wx,wy,wz` of the cube's centre of mass), `--events PATH` (the
//! impacts, `t,body,px,py,pz,nx,ny,nz,jn,jt,regime,ke_before,ke_after`).
//!
//! The faces are numbered as on a die, opposite faces summing to 7: local +x = 1, +y = 2,
//! +z = 3, -z = 4, -y = 5, -x = 6.

mod common;

use common::{Args, CSV, DiceThrow, EventsCsv, F64, LAW, MODE, Mode, TraceCsv, flag, real, wide};
use rapier_impact::rapier::prelude::*;

const ABOUT: &str = "A cube thrown onto the ground, tumbling: its impacts and the face on top.";

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
    let spec = [
        flag(
            "--seed",
            "N",
            "1",
            "random throw: height, velocity, spin, orientation",
        ),
        flag(
            "--restitution",
            "E",
            "0.5",
            "restitution of cube and ground",
        ),
        flag("--friction", "MU", "0.5", "friction of cube and ground"),
        LAW,
        MODE,
        flag("--size", "S", "0.1", "edge length of the cube (m)"),
        flag("--dt", "DT", "1/60", "time step (s)"),
        flag("--duration", "T", "4", "simulated time (s)"),
        F64,
        CSV,
        flag(
            "--events",
            "PATH",
            "",
            "write the impacts t,body,px,py,pz,nx,ny,nz,jn,jt,regime,ke_before,ke_after",
        ),
    ];
    let args = Args::parse("dice", ABOUT, &spec);
    args.check_precision();
    let seed = args.count("--seed", 0);
    let e = args.non_negative("--restitution");
    let mu = args.non_negative("--friction");
    let law = args.law();
    let mode = args.mode();
    let size = args.positive("--size");
    let dt = args.positive("--dt");
    let duration = args.positive("--duration");

    // The throw: 0.5 to 1 m up, 1 to 3 m/s sideways in a random direction, a random spin of
    // up to 10 rad/s per axis, a random orientation (uniform unit quaternion).
    let throw = DiceThrow::new(seed);
    let (height, speed, spin) = (throw.height, throw.speed, throw.spin);

    let mut world = common::world(dt);
    let ground = common::ground(&mut world, e, mu);
    let cube = throw.insert_cube(&mut world, 0.5 * size, e, mu);
    let mut plugin = common::plugin(mode, law, &mut world, ground);
    let mut csv = args.path("--csv").map(|p| TraceCsv::create(&p, cube));
    let mut events_csv = args.path("--events").map(|p| EventsCsv::create(&p));

    let dt = wide(world.integration_parameters.dt);
    let steps = (duration / dt).ceil() as usize;
    // (t, points, regime, jn, ke_before, ke_after)
    let mut impacts: Vec<(f64, usize, String, f64, f64, f64)> = Vec::new();
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
        "dice: seed {seed}, edge {size} m, e = {e}, mu = {mu}, law {law:?}, mode {}, dt = {dt:.7} s, \
         precision {}",
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
    let rb = &world.bodies[cube];
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
