//! A cue ball rolling into an object ball on a table, headless: both balls' velocities and
//! spins right after the impact beside the closed form, and the object ball's direction off
//! the line of centres (the throw).
//!
//! ```text
//! cargo run --release --example billiards -- --speed 2 --cut 30 --sidespin 20
//! ```
//!
//! Flags (each has a default; `--help` lists them): `--speed V` (the cue ball's speed at
//! impact, m/s, 2), `--cut DEG` (angle between its velocity and the line of centres at
//! contact, 0), `--topspin W` (its spin at impact about the horizontal axis perpendicular to
//! its motion, rad/s; default: rolling, `V / R`), `--sidespin W` (about the vertical, rad/s,
//! 0), `--ball-restitution E` (0.95), `--ball-friction MU` (0.06), `--cloth-friction MU`
//! (0.2), `--radius R` (m, 0.028575), `--mass M` (kg, 0.17), `--dt DT` (s, 1/60), `--mode
//! rapier|step|toi|exact` (exact), `--law document|consistent|guarded` (guarded), `--f64`
//! (needs `--features f64`), `--csv PATH` (trace `t,body,x,y,z,vx,vy,vz,wx,wy,wz` of both
//! balls, body 0 the cue ball and 1 the object ball, y up), `--events PATH` (the events CSV of
//! the other examples, with a second body column `body2`, empty for the table).
//!
//! The table is a half-space at y = 0, marked as ground. The cue ball moves along +x and
//! starts a hair (1 um along its path) from contact, so that its state at the impact is the flags'. The
//! closed form (two spheres, MODEL-NOTES "Two bodies"): the normal impulse is
//! `(1 + e) u_n / C_n` with `C_n = 2/m`; the contact point's slip `u_t` sticks iff
//! `|u_t| / C_t <= mu (1 + e) u_n / C_n`, `C_t = 2/m + 2 R^2 / I` (`7/m` for solid balls),
//! else it slips with `mu P_n` against `u_t`.

mod common;

use common::{Args, CSV, F64, LAW, MODE, Mode, flag, real, wide};
use rapier_impact::na::Vector3;
use rapier_impact::rapier::prelude::*;
use rapier_impact::{EventKind, ImpactConfig, ImpactEvent, ImpactPlugin};
use std::io::Write;

const ABOUT: &str = "A cue ball into an object ball on a table: velocities and spins right \
after the impact beside the closed form, and the throw.";

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

fn main() {
    let spec = [
        flag("--speed", "V", "2", "the cue ball's speed at impact (m/s)"),
        flag(
            "--cut",
            "DEG",
            "0",
            "angle between the cue ball's velocity and the line of centres (deg)",
        ),
        flag(
            "--topspin",
            "W",
            "",
            "spin about the horizontal axis perpendicular to the motion (rad/s); default rolling, V / R",
        ),
        flag("--sidespin", "W", "0", "spin about the vertical (rad/s)"),
        flag(
            "--ball-restitution",
            "E",
            "0.95",
            "ball-ball coefficient of restitution",
        ),
        flag(
            "--ball-friction",
            "MU",
            "0.06",
            "ball-ball coefficient of friction",
        ),
        flag(
            "--cloth-friction",
            "MU",
            "0.2",
            "ball-cloth coefficient of friction",
        ),
        flag("--radius", "R", "0.028575", "ball radius (m)"),
        flag("--mass", "M", "0.17", "ball mass (kg)"),
        flag("--dt", "DT", "0.016666666666666666", "time step (s)"),
        MODE,
        LAW,
        F64,
        CSV,
        flag(
            "--events",
            "PATH",
            "",
            "events CSV, with a second body column body2",
        ),
    ];
    let args = Args::parse("billiards", ABOUT, &spec);
    args.check_precision();
    let speed = args.positive("--speed");
    let cut = args.number("--cut");
    if !(0.0..90.0).contains(&cut) {
        args.fail("--cut must be in [0, 90) degrees");
    }
    let (r, m) = (args.positive("--radius"), args.positive("--mass"));
    let topspin = if args.given("--topspin") {
        args.number("--topspin")
    } else {
        speed / r
    };
    let sidespin = args.number("--sidespin");
    let (e, mu_ball, mu_cloth) = (
        args.non_negative("--ball-restitution"),
        args.non_negative("--ball-friction"),
        args.non_negative("--cloth-friction"),
    );
    let dt = args.positive("--dt");
    let mode = args.mode();
    let mut world = common::world(dt);
    // The cue ball moves along +x; topspin (forward roll) is about -z, side spin about +y.
    let v = Vector3::new(speed, 0.0, 0.0);
    let w = Vector3::new(0.0, sidespin, -topspin);
    let n = {
        let c = cut.to_radians();
        Vector3::new(c.cos(), 0.0, c.sin())
    };
    let object_at = Vector3::new(0.5, r, 0.0);
    // At contact after travelling 1 um along its velocity: the line of centres is then n.
    let cue_at = object_at - n * (2.0 * r) - v / speed * 1e-6;
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
                .friction(real(mu_ball))
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
    let mut plugin = match mode {
        Mode::Rapier => None,
        Mode::Plugin(timing) => {
            let mut p = ImpactPlugin::new(ImpactConfig {
                law: args.law(),
                timing,
                ..Default::default()
            })
            .expect("the default configuration is valid");
            p.add_ground_with_material(
                &world.bodies,
                &world.colliders,
                table,
                rapier_impact::GroundMaterial::new(0.0, mu_cloth),
            )
            .expect("the table exists");
            p.add_impact_body(&world.bodies, cue)
                .expect("a dynamic body");
            p.add_impact_body(&world.bodies, object)
                .expect("a dynamic body");
            Some(p)
        }
    };
    let mut csv = args.path("--csv").map(|path| {
        let mut f = std::io::BufWriter::new(common::or_exit(
            std::fs::File::create(&path),
            "cannot create the CSV",
        ));
        writeln!(f, "t,body,x,y,z,vx,vy,vz,wx,wy,wz").unwrap();
        f
    });
    let mut events_csv = args.path("--events").map(|path| {
        let mut f = std::io::BufWriter::new(common::or_exit(
            std::fs::File::create(&path),
            "cannot create the events CSV",
        ));
        writeln!(
            f,
            "t,body,body2,px,py,pz,nx,ny,nz,jn,jt,regime,ke_before,ke_after"
        )
        .unwrap();
        f
    });
    let trace =
        |t: f64, bodies: &RigidBodySet, csv: &mut Option<std::io::BufWriter<std::fs::File>>| {
            if let Some(f) = csv.as_mut() {
                for (k, h) in [cue, object].iter().enumerate() {
                    let rb = &bodies[*h];
                    let (p, v, w) = (rb.center_of_mass(), rb.linvel(), rb.angvel());
                    writeln!(
                        f,
                        "{t},{k},{},{},{},{},{},{},{},{},{}",
                        p.x, p.y, p.z, v.x, v.y, v.z, w.x, w.y, w.z
                    )
                    .unwrap();
                }
            }
        };
    trace(0.0, &world.bodies, &mut csv);
    let state = |h: RigidBodyHandle, bodies: &RigidBodySet| {
        let rb = &bodies[h];
        let (v, w) = (rb.linvel(), rb.angvel());
        (
            Vector3::new(wide(v.x), wide(v.y), wide(v.z)),
            Vector3::new(wide(w.x), wide(w.y), wide(w.z)),
        )
    };
    let before = [state(cue, &world.bodies), state(object, &world.bodies)];
    let mut after: Option<After> = None;
    let steps = (1.0 / dt).ceil() as usize;
    for k in 0..steps {
        let events: Vec<ImpactEvent> = common::step(&mut world, &mut plugin).to_vec();
        let t = (k + 1) as f64 * dt;
        trace(t, &world.bodies, &mut csv);
        if let Some(f) = events_csv.as_mut() {
            for ev in &events {
                let (p, nn) = (ev.point, ev.normal);
                let body2 = ev
                    .body2
                    .map_or(String::new(), |b| b.into_raw_parts().0.to_string());
                writeln!(
                    f,
                    "{},{},{body2},{},{},{},{},{},{},{},{},{},{},{}",
                    k as f64 * dt + ev.time,
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
        if after.is_some() {
            continue;
        }
        // Right after the impact: the model's impulses on the states at the impact (the
        // plugin's in-step events), or the state after the step of the contact (rapier alone,
        // or the plugin's step-end impact in `Step` mode).
        let pair: Vec<&ImpactEvent> = events
            .iter()
            .filter(|ev| ev.kind == EventKind::Impact && ev.body2.is_some())
            .collect();
        let step_end = pair
            .iter()
            .any(|ev| ev.timing == rapier_impact::ImpactTiming::StepEnd);
        if plugin.is_some() && !step_end {
            if pair.len() == 2 {
                let inertia = 0.4 * m * r * r;
                // Each ball's contact point is R from its centre along the event's normal
                // (from the other ball into it).
                let apply = |h: RigidBodyHandle, (v, w): (Vector3<f64>, Vector3<f64>)| {
                    let ev = pair
                        .iter()
                        .find(|ev| ev.body == h)
                        .expect("an event for each ball");
                    let j =
                        Vector3::new(wide(ev.impulse.x), wide(ev.impulse.y), wide(ev.impulse.z));
                    let normal =
                        Vector3::new(wide(ev.normal.x), wide(ev.normal.y), wide(ev.normal.z));
                    (v + j / m, w + (-normal * r).cross(&j) / inertia)
                };
                after = Some([apply(cue, before[0]), apply(object, before[1])]);
            }
        } else if step_end || plugin.is_none() && state(object, &world.bodies).0.norm() > 0.0 {
            after = Some([state(cue, &world.bodies), state(object, &world.bodies)]);
        }
    }
    if let Some(mut f) = csv {
        f.flush().unwrap();
    }
    if let Some(mut f) = events_csv {
        f.flush().unwrap();
    }
    let (expected, stick) = closed_form(m, r, e, mu_ball, v, w, n);
    println!(
        "billiards: V = {speed} m/s, cut = {cut} deg, topspin = {topspin} rad/s, sidespin = {sidespin} rad/s, \
e = {e}, mu_ball = {mu_ball}, mu_cloth = {mu_cloth}, R = {r} m, m = {m} kg, dt = {dt:.7} s, mode = {}, precision = {}",
        mode.name(),
        common::PRECISION
    );
    let Some(after) = after else {
        println!("no impact in 1 s");
        return;
    };
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
