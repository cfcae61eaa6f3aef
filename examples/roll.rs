//! A ball set on a plane ground, headless: when it starts rolling, when it stops and how far
//! it went, beside the closed form (`docs/model.md`, "A ball on a plane"); `--mode rapier` is
//! rapier alone on the same scene.
//!
//! ```text
//! cargo run --release --example roll -- --speed 2 --rolling-resistance 0.01
//! cargo run --release --example roll -- --speed 1 --backspin 60 --rolling-resistance 0.01
//! ```
//!
//! Flags (each has a default; `--help` lists them): `--speed V` (initial centre speed along
//! the ground, m/s, +x of the ground's frame, downhill on a slope, 2), `--backspin W` (rad/s,
//! 0: no spin; negative: topspin), `--rolling` (start rolling without slip instead),
//! `--normal-spin W` (rad/s about the ground normal, 0), `--friction MU` (0.2),
//! `--rolling-resistance MU_R` (0.01), `--spinning-friction MU_SP` (0.01), `--slope DEG` (the
//! ground tilted about world z, downhill +x and down, 0), `--radius R` (m, 0.021335, a golf
//! ball), `--shell solid|hollow` (solid), `--dt DT` (s, 1/60), `--duration T` (s, 20),
//! `--mode rapier|step|toi|exact` (exact), `--f64` (needs `--features f64`), `--csv PATH`
//! (trace `t,x,y,z,vx,vy,vz,wx,wy,wz`, world frame, y up, one row per step and one at t = 0).
//!
//! Measured: the first step end at which the contact point's slip is below 1e-6 m/s (rolls),
//! the first at which the ball is at rest (its speed below 1e-6 m/s), and the distance along
//! the ground then, or at the end of the run.

mod common;

use common::{Args, CSV, F64, MODE, Mode, SHELL, TraceCsv, flag, real, switch, wide};
use rapier_impact::na::Vector3;
use rapier_impact::rapier::prelude::*;
use rapier_impact::{ImpactConfig, ImpactPlugin};

const ABOUT: &str = "A ball on a plane ground: when it rolls, when it stops and how far it \
went, beside the closed form.";

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

fn main() {
    let spec = [
        flag(
            "--speed",
            "V",
            "2",
            "initial centre speed along the ground, +x, downhill (m/s)",
        ),
        flag(
            "--backspin",
            "W",
            "0",
            "backspin (rad/s; negative: topspin)",
        ),
        switch(
            "--rolling",
            "start rolling without slip (instead of --backspin)",
        ),
        flag(
            "--normal-spin",
            "W",
            "0",
            "spin about the ground normal (rad/s)",
        ),
        flag(
            "--friction",
            "MU",
            "0.2",
            "ball-ground coefficient of friction",
        ),
        flag(
            "--rolling-resistance",
            "MU_R",
            "0.01",
            "rolling resistance coefficient",
        ),
        flag(
            "--spinning-friction",
            "MU_SP",
            "0.01",
            "spinning friction coefficient",
        ),
        flag(
            "--slope",
            "DEG",
            "0",
            "ground tilt about world z, downhill +x (deg)",
        ),
        flag("--radius", "R", "0.021335", "ball radius (m)"),
        SHELL,
        flag("--dt", "DT", "0.016666666666666666", "time step (s)"),
        flag("--duration", "T", "20", "simulated time (s)"),
        MODE,
        F64,
        CSV,
    ];
    let args = Args::parse("roll", ABOUT, &spec);
    args.check_precision();
    let v0 = args.non_negative("--speed");
    let r = args.positive("--radius");
    let mu = args.non_negative("--friction");
    let mu_r = args.non_negative("--rolling-resistance");
    let mu_sp = args.non_negative("--spinning-friction");
    let slope_deg = args.number("--slope");
    if !(0.0..80.0).contains(&slope_deg) {
        args.fail("--slope must be in [0, 80) degrees");
    }
    let slope = slope_deg.to_radians();
    let k = args.inertia_ratio();
    let hollow = k != 0.4;
    let (dt, duration) = (args.positive("--dt"), args.positive("--duration"));
    let mode = args.mode();
    let normal_spin = args.number("--normal-spin");
    // The ground's frame: normal n, downhill d. Rolling forward along d spins at v / R about
    // n x d; backspin is the opposite sense.
    let n = Vector3::new(slope.sin(), slope.cos(), 0.0);
    let d = Vector3::new(slope.cos(), -slope.sin(), 0.0);
    let roll_axis = n.cross(&d);
    let spin_along = if args.on("--rolling") {
        v0 / r
    } else {
        -args.number("--backspin")
    };
    let slip0 = v0 - r * spin_along;
    let w = roll_axis * spin_along + n * normal_spin;
    let mut world = common::world(dt);
    let (_, ground) = world.insert(
        RigidBodyBuilder::fixed(),
        ColliderBuilder::halfspace(rapier_impact::rapier::na::Unit::new_unchecked(
            Vector::new(real(n.x), real(n.y), 0.0).normalize(),
        ))
        .restitution(0.0)
        .friction(real(mu)),
    );
    let at = n * r;
    let v = d * v0;
    let mass_props = if hollow {
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
    let mut plugin = match mode {
        Mode::Rapier => None,
        Mode::Plugin(timing) => {
            let mut p = ImpactPlugin::new(ImpactConfig {
                timing,
                rolling_resistance: mu_r,
                spinning_friction: mu_sp,
                ..Default::default()
            })
            .unwrap_or_else(|e| args.fail(&e.to_string()));
            p.add_ground(&world.bodies, &world.colliders, ground)
                .expect("the ground exists");
            Some(p)
        }
    };
    let mut csv = args.path("--csv").map(|p| TraceCsv::create(&p, ball));
    if let Some(c) = csv.as_mut() {
        c.row(0.0, &world.bodies);
    }
    let state = |bodies: &RigidBodySet| {
        let rb = &bodies[ball];
        let na = |x: Vector| Vector3::new(wide(x.x), wide(x.y), wide(x.z));
        (na(rb.center_of_mass()), na(rb.linvel()), na(rb.angvel()))
    };
    let (start, _, _) = state(&world.bodies);
    let steps = (duration / dt).round() as usize;
    let (mut rolls, mut stops, mut spin_stops) = (None, None, None);
    let mut distance = 0.0;
    for step in 1..=steps {
        common::step(&mut world, &mut plugin);
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
    let time = |t: Option<f64>| t.map_or("never".to_string(), |t| format!("{t:.4} s"));
    println!("{:>22} {:>14} {:>14}", "", "measured", "closed form");
    println!(
        "{:>22} {:>14} {:>14}",
        "rolls from",
        time(rolls),
        time(expected.rolls_at)
    );
    println!(
        "{:>22} {:>14} {:>14}",
        "stops at",
        time(stops),
        time(expected.stops_at)
    );
    if normal_spin != 0.0 {
        println!(
            "{:>22} {:>14} {:>14}",
            "normal spin stops at",
            time(spin_stops),
            time(expected.spin_stops_at)
        );
    }
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
