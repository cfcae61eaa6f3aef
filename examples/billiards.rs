//! A cue ball rolling into an object ball on a table, headless: both balls' velocities and
//! spins right after the impact beside the closed form, and the object ball's direction off
//! the line of centres (the throw).
//!
//! ```text
//! cargo run --release --example billiards -- --speed 2 --cut 30 --sidespin 20
//! ```
//!
//! Every flag has a default; `--help` lists them with their units. `--csv PATH` writes the
//! trace `t,body,x,y,z,vx,vy,vz,wx,wy,wz` of both balls (body 0 the cue ball and 1 the object
//! ball, y up), `--events PATH` the events CSV of the other examples with a second body column
//! `body2`, empty for the table.
//!
//! The table is a half-space at y = 0, marked as ground. The cue ball moves along +x and
//! starts a hair (1 um along its path) from contact, so that its state at the impact is the flags'. The
//! closed form (two spheres, docs/model.md "Two bodies"): the normal impulse is
//! `(1 + e) u_n / C_n` with `C_n = 2/m`; the contact point's slip `u_t` sticks iff
//! `|u_t| / C_t <= mu (1 + e) u_n / C_n`, `C_t = 2/m + 2 R^2 / I` (`7/m` for solid balls),
//! else it slips with `mu P_n` against `u_t`.

mod common;

use clap::Parser;
use common::{Coefficient, LawChoice, Mode, real, wide};
use rapier_impact::na::Vector3;
use rapier_impact::rapier::prelude::*;
use rapier_impact::{EventKind, GroundMaterial, ImpactConfig, ImpactEvent, ImpactPlugin};
use std::fs::File;
use std::io::{BufWriter, Write};

/// A cue ball into an object ball on a table: both balls' velocities and spins right after
/// the impact beside the closed form of two spheres (stick or slip), and the throw, the object
/// ball's direction off the line of centres.
#[derive(Parser, Debug)]
#[command(
    name = "billiards",
    after_help = "Example: cargo run --release --example billiards -- --speed 2 --cut 30 --sidespin 20"
)]
struct Args {
    /// The cue ball's speed at impact (m/s)
    #[arg(long, value_name = "V", default_value = "2", value_parser = common::positive)]
    speed: f64,
    /// Angle between the cue ball's velocity and the line of centres, in [0, 90) (deg)
    #[arg(long, value_name = "DEG", default_value = "0", value_parser = |s: &str| common::degrees_below(s, 90.0))]
    cut: f64,
    /// Spin about the horizontal axis perpendicular to the motion (rad/s) [default: rolling,
    /// V / R]
    #[arg(long, value_name = "W", value_parser = common::number)]
    topspin: Option<f64>,
    /// Spin about the vertical (rad/s)
    #[arg(long, value_name = "W", default_value = "0", value_parser = common::number)]
    sidespin: f64,
    /// Ball-ball coefficient of restitution
    #[arg(long, value_name = "E", default_value = "0.95", value_parser = common::non_negative)]
    ball_restitution: f64,
    /// Ball-ball coefficient of friction
    #[arg(long, value_name = "MU", default_value = "0.06", value_parser = common::non_negative)]
    ball_friction: f64,
    /// Ball-cloth coefficient of friction
    #[arg(long, value_name = "MU", default_value = "0.2", value_parser = common::non_negative)]
    cloth_friction: f64,
    /// Ball radius (m)
    #[arg(long, value_name = "R", default_value = "0.028575", value_parser = common::positive)]
    radius: f64,
    /// Ball mass (kg)
    #[arg(long, value_name = "M", default_value = "0.17", value_parser = common::positive)]
    mass: f64,
    /// Time step (s)
    #[arg(long, value_name = "DT", default_value = "1/60", value_parser = common::positive)]
    dt: f64,
    /// Rapier alone, or the plugin in one of its timing modes
    #[arg(long, value_enum, value_name = "MODE", default_value_t = Mode::EXACT)]
    mode: Mode,
    /// The impact law
    #[arg(long, value_enum, value_name = "LAW", default_value_t = LawChoice::Guarded)]
    law: LawChoice,
    /// Double precision: needs a build with `--features f64` (the precision is chosen at
    /// build time)
    #[arg(long)]
    f64: bool,
    /// Write the trace t,body,x,y,z,vx,vy,vz,wx,wy,wz of both balls (m, m/s, rad/s; body 0 the
    /// cue ball, 1 the object ball) [default: none]
    #[arg(long, value_name = "PATH")]
    csv: Option<String>,
    /// Write the events t,body,body2,px,py,pz,nx,ny,nz,jn,jt,regime,ke_before,ke_after
    /// (body2 empty for the table) [default: none]
    #[arg(long, value_name = "PATH")]
    events: Option<String>,
}

/// Both balls right after the impact: (linear, angular) velocity of the cue and object
/// balls.
type After = [(Vector3<f64>, Vector3<f64>); 2];

/// The closed form of two equal solid spheres: the velocities after, from the cue ball's
/// `(v, w)` and the unit line of centres `n` (cue to object), the object ball at rest.
fn closed_form(
    m: f64,
    r: f64,
    e: f64,
    mu: f64,
    v: Vector3<f64>,
    w: Vector3<f64>,
    n: Vector3<f64>,
) -> (After, bool) {
    let inertia = 0.4 * m * r * r;
    // The contact point's relative velocity (cue minus object).
    let u = v + w.cross(&(n * r));
    let un = u.dot(&n);
    let ut = u - n * un;
    let (cn, ct) = (2.0 / m, 2.0 / m + 2.0 * r * r / inertia);
    let pn = (1.0 + e) * un / cn;
    let stick = ut.norm() / ct <= mu * pn;
    let pt = if stick {
        ut / ct
    } else {
        ut.normalize() * (mu * pn)
    };
    // On the object ball (at -n R from its centre's view: the contact is at +n R from the
    // cue's centre and -n R from the object's).
    let j = n * pn + pt;
    let cue = (v - j / m, w - (n * r).cross(&j) / inertia);
    let object = (j / m, (-n * r).cross(&j) / inertia);
    ([cue, object], stick)
}

/// The balls on the table and the plugin (none for rapier alone).
struct Scene {
    world: PhysicsWorld,
    cue: RigidBodyHandle,
    object: RigidBodyHandle,
    plugin: Option<ImpactPlugin>,
}

/// The cue ball with velocity `v` and spin `w` a hair from contact along the line of centres
/// `n`, the object ball at rest, the cloth, and the plugin of `args.mode`.
fn build(args: &Args, v: Vector3<f64>, w: Vector3<f64>, n: Vector3<f64>) -> Scene {
    let (r, m, e, mu_cloth) = (
        args.radius,
        args.mass,
        args.ball_restitution,
        args.cloth_friction,
    );
    let mut world = common::world(args.dt);
    let object_at = Vector3::new(0.5, r, 0.0);
    // At contact after travelling 1 um along its velocity: the line of centres is then n.
    let cue_at = object_at - n * (2.0 * r) - v / args.speed * 1e-6;
    let density = m / (4.0 / 3.0 * std::f64::consts::PI * r * r * r);
    let mut insert = |at: Vector3<f64>, v: Vector3<f64>, w: Vector3<f64>| {
        world.insert(
            RigidBodyBuilder::dynamic()
                .translation(Vector::new(real(at.x), real(at.y), real(at.z)))
                .linvel(Vector::new(real(v.x), real(v.y), real(v.z)))
                .angvel(Vector::new(real(w.x), real(w.y), real(w.z)))
                .allow_fast_rotation(true),
            ColliderBuilder::ball(real(r))
                .density(real(density))
                .restitution(real(e))
                .friction(real(args.ball_friction))
                .restitution_combine_rule(CoefficientCombineRule::Min)
                .friction_combine_rule(CoefficientCombineRule::Min),
        )
    };
    let (cue, _) = insert(cue_at, v, w);
    let (object, _) = insert(object_at, Vector3::zeros(), Vector3::zeros());
    // The cloth: its friction with a ball is the cloth's (the smaller by the Min rule
    // above is the ball's for ball on ball; for ball on cloth both colliders ask Min, so the
    // cloth's coefficient must be the smaller: it is set on the cloth, and the balls'
    // friction against it overridden by a ground material).
    let table = common::ground(&mut world, 0.0, mu_cloth);
    let plugin = match args.mode {
        Mode::Rapier => None,
        Mode::Plugin(timing) => {
            let mut config = ImpactConfig::default();
            config.law = args.law.into();
            config.timing = timing;
            let mut p = ImpactPlugin::new(config).expect("the default configuration is valid");
            p.add_ground_with_material(
                &world.bodies,
                &world.colliders,
                table,
                GroundMaterial::new(0.0, mu_cloth),
            )
            // The table exists: only the material's range can refuse it.
            .unwrap_or_else(|e| common::out_of_range::<Args>("--cloth-friction", mu_cloth, e));
            p.add_impact_body(&world.bodies, cue)
                .expect("a dynamic body");
            p.add_impact_body(&world.bodies, object)
                .expect("a dynamic body");
            Some(p)
        }
    };
    Scene {
        world,
        cue,
        object,
        plugin,
    }
}

/// Creates the CSV at `path` with its header line.
fn csv_file(path: &str, header: &str, what: &str) -> BufWriter<File> {
    let mut f = BufWriter::new(common::or_exit(File::create(path), what));
    writeln!(f, "{header}").unwrap();
    f
}

/// A ball's (linear, angular) velocity.
fn state(h: RigidBodyHandle, bodies: &RigidBodySet) -> (Vector3<f64>, Vector3<f64>) {
    let rb = &bodies[h];
    let (v, w) = (rb.linvel(), rb.angvel());
    (
        Vector3::new(wide(v.x), wide(v.y), wide(v.z)),
        Vector3::new(wide(w.x), wide(w.y), wide(w.z)),
    )
}

/// The trace rows of both balls at `t`.
fn trace_rows(f: &mut BufWriter<File>, t: f64, scene: &Scene) {
    for (k, h) in [scene.cue, scene.object].iter().enumerate() {
        let rb = &scene.world.bodies[*h];
        let (p, v, w) = (rb.center_of_mass(), rb.linvel(), rb.angvel());
        writeln!(
            f,
            "{t},{k},{},{},{},{},{},{},{},{},{}",
            p.x, p.y, p.z, v.x, v.y, v.z, w.x, w.y, w.z
        )
        .unwrap();
    }
}

/// The events rows of the step that started at `step_start` (s).
fn event_rows(f: &mut BufWriter<File>, step_start: f64, events: &[ImpactEvent]) {
    for ev in events {
        let (p, nn) = (ev.point, ev.normal);
        let body2 = ev
            .body2
            .map_or(String::new(), |b| b.into_raw_parts().0.to_string());
        writeln!(
            f,
            "{},{},{body2},{},{},{},{},{},{},{},{},{},{},{}",
            step_start + ev.time,
            ev.body.into_raw_parts().0,
            p.x,
            p.y,
            p.z,
            nn.x,
            nn.y,
            nn.z,
            ev.normal_impulse,
            wide(ev.tangent_impulse.length()),
            common::regime_label(ev),
            ev.ke_before,
            ev.ke_after
        )
        .unwrap();
    }
}

/// Both balls right after the impact, if this step's `events` hold it: the model's impulses
/// on the states at the impact `before` (the plugin's in-step events), or the state after the
/// step of the contact (rapier alone, or the plugin's step-end impact in `Step` mode).
fn after_impact(
    args: &Args,
    scene: &Scene,
    events: &[ImpactEvent],
    before: &After,
) -> Option<After> {
    let (r, m) = (args.radius, args.mass);
    let pair: Vec<&ImpactEvent> = events
        .iter()
        .filter(|ev| ev.kind == EventKind::Impact && ev.body2.is_some())
        .collect();
    let step_end = pair
        .iter()
        .any(|ev| ev.timing == rapier_impact::ImpactTiming::StepEnd);
    let bodies = &scene.world.bodies;
    if scene.plugin.is_some() && !step_end {
        if pair.len() != 2 {
            return None;
        }
        let inertia = 0.4 * m * r * r;
        // Each ball's contact point is R from its centre along the event's normal (from the
        // other ball into it).
        let apply = |h: RigidBodyHandle, (v, w): (Vector3<f64>, Vector3<f64>)| {
            let ev = pair
                .iter()
                .find(|ev| ev.body == h)
                .expect("an event for each ball");
            let j = Vector3::new(wide(ev.impulse.x), wide(ev.impulse.y), wide(ev.impulse.z));
            let normal = Vector3::new(wide(ev.normal.x), wide(ev.normal.y), wide(ev.normal.z));
            (v + j / m, w + (-normal * r).cross(&j) / inertia)
        };
        Some([apply(scene.cue, before[0]), apply(scene.object, before[1])])
    } else if step_end || scene.plugin.is_none() && state(scene.object, bodies).0.norm() > 0.0 {
        Some([state(scene.cue, bodies), state(scene.object, bodies)])
    } else {
        None
    }
}

/// Steps for 1 s, writing the CSVs asked for; returns both balls right after the impact.
fn run(args: &Args, scene: &mut Scene) -> Option<After> {
    let dt = args.dt;
    let mut csv = args
        .csv
        .as_deref()
        .map(|p| csv_file(p, "t,body,x,y,z,vx,vy,vz,wx,wy,wz", "cannot create the CSV"));
    let mut events_csv = args.events.as_deref().map(|p| {
        csv_file(
            p,
            "t,body,body2,px,py,pz,nx,ny,nz,jn,jt,regime,ke_before,ke_after",
            "cannot create the events CSV",
        )
    });
    if let Some(f) = csv.as_mut() {
        trace_rows(f, 0.0, scene);
    }
    let before = [
        state(scene.cue, &scene.world.bodies),
        state(scene.object, &scene.world.bodies),
    ];
    let mut after: Option<After> = None;
    let steps = (1.0 / dt).ceil() as usize;
    for k in 0..steps {
        let events: Vec<ImpactEvent> = common::step(&mut scene.world, &mut scene.plugin).to_vec();
        if let Some(f) = csv.as_mut() {
            trace_rows(f, (k + 1) as f64 * dt, scene);
        }
        if let Some(f) = events_csv.as_mut() {
            event_rows(f, k as f64 * dt, &events);
        }
        if after.is_none() {
            after = after_impact(args, scene, &events, &before);
        }
    }
    for f in [csv, events_csv].into_iter().flatten() {
        let mut f = f;
        f.flush().unwrap();
    }
    after
}

fn main() {
    let args: Args = common::parse();
    common::check_precision::<Args>(args.f64);
    common::check_coefficients::<Args>(
        args.mode,
        &[
            (
                "--ball-restitution",
                Coefficient::Restitution,
                args.ball_restitution,
            ),
            ("--ball-friction", Coefficient::Friction, args.ball_friction),
        ],
    );
    let (speed, cut, r, m) = (args.speed, args.cut, args.radius, args.mass);
    let topspin = args.topspin.unwrap_or(speed / r);
    let sidespin = args.sidespin;
    let (e, mu_ball, mu_cloth) = (
        args.ball_restitution,
        args.ball_friction,
        args.cloth_friction,
    );
    // The cue ball moves along +x; topspin (forward roll) is about -z, side spin about +y.
    let v = Vector3::new(speed, 0.0, 0.0);
    let w = Vector3::new(0.0, sidespin, -topspin);
    let n = {
        let c = cut.to_radians();
        Vector3::new(c.cos(), 0.0, c.sin())
    };
    let mut scene = build(&args, v, w, n);
    let after = run(&args, &mut scene);
    let (expected, stick) = closed_form(m, r, e, mu_ball, v, w, n);
    println!(
        "billiards: V = {speed} m/s, cut = {cut} deg, topspin = {topspin} rad/s, sidespin = {sidespin} rad/s, \
e = {e}, mu_ball = {mu_ball}, mu_cloth = {mu_cloth}, R = {r} m, m = {m} kg, dt = {:.7} s, mode = {}, precision = {}",
        args.dt,
        args.mode.name(),
        common::PRECISION
    );
    let Some(after) = after else {
        println!("no impact in 1 s");
        return;
    };
    print_comparison(&after, &expected, speed, r);
    let throw = |v: Vector3<f64>| {
        let along = v.dot(&n);
        (v - n * along).norm().atan2(along).to_degrees()
    };
    println!(
        "throw: object ball {:.4} deg off the line of centres (closed form {:.4} deg, {})",
        throw(after[1].0),
        throw(expected[1].0),
        if stick { "stick" } else { "slip" }
    );
}

/// Each ball measured beside the closed form, with the errors in units of `V` and `V / R`.
fn print_comparison(after: &After, expected: &After, speed: f64, r: f64) {
    println!(
        "{:>12} {:>32} {:>32}",
        "", "measured (vx vy vz | wx wy wz)", "closed form"
    );
    let fmt = |(v, w): (Vector3<f64>, Vector3<f64>)| {
        format!(
            "{:+.5} {:+.5} {:+.5} | {:+.3} {:+.3} {:+.3}",
            v.x, v.y, v.z, w.x, w.y, w.z
        )
    };
    for (k, name) in ["cue ball", "object ball"].iter().enumerate() {
        println!("{name:>12} {} {}", fmt(after[k]), fmt(expected[k]));
        let err = (after[k].0 - expected[k].0).norm() / speed;
        let spin_err = (after[k].1 - expected[k].1).norm() * r / speed;
        println!(
            "{:>12} velocity error {err:.2e} of V, spin error {spin_err:.2e} of V/R",
            ""
        );
    }
}
