//! The accuracy sweep: what accuracy costs in time. Runs fixed scenes over timing mode (rapier
//! alone, `step`, `toi`, `exact`) x law (`document`, `consistent`, `guarded`) x dt (1/30, 1/60,
//! 1/120, 1/240, 1/1000) x precision (f32, f64), measures each run's error against the closed
//! form and its wall time per simulated second, and writes the report `accuracy.md` and the
//! plots `tradeoff.svg`, `drop_trace.svg`, `spin_trace.svg`: into `target/accuracy_sweep/` of
//! the crate, into `--out DIR`, or, with `--write-docs`, over the committed ones in `docs/`.
//!
//! ```text
//! cargo run --release --example accuracy_sweep                   # report in target/accuracy_sweep/
//! cargo run --release --example accuracy_sweep -- --write-docs   # regenerate docs/accuracy.md
//! ```
//!
//! One command runs both precisions: the binary runs the sweep in the precision it was built
//! with, then builds and runs itself in the other one (`cargo run --release [--features f64]
//! --example accuracy_sweep -- --rows PATH`, which only writes its rows), and writes the report
//! from both. `--help` lists the flags.
//!
//! Scenes (y up, ground surface y = 0, g = 9.81, half-space ground):
//! - drop: ball R = 0.1 m dropped from 1 m (gap), e = 0.8, mu = 0.5, 3.8 s. Worst relative apex
//!   error over 10 bounces against `e^(2n) h0`, worst impact-time error against
//!   `t_(k+1) = t1 + 2 t1 e (1 - e^k)/(1 - e)`.
//! - spin: solid ball R = 0.1 m reaching the ground at 5 m/s down and 5 m/s along x, e = 0.8,
//!   in the stick regime (mu = 0.5, backspin 20 rad/s) and the slip regime (mu = 0.1, topspin
//!   100 rad/s); worst relative error of `vx'`, `w_z'` and take-off speed after the first bounce
//!   against the closed forms (as `tests/plugin_spin.rs`), 1.5 s each.
//! - cube: a 0.1 m cube thrown 6 times (seeds 1-6, as `examples/dice.rs`), e = 0.5, mu = 0.5,
//!   3 s each: energy gained at impacts, i.e. the sum of the increases of the mechanical energy
//!   `KE + m g y` over the steps in which the cube is within 2 cm of the ground, as a share of
//!   the throw's energy above rest (0 is right: an impact with `e <= 1` never adds energy), and
//!   for the plugin the largest KE gain a single impact event reported.
//! - pile: 125 balls R = 5 cm dropped into a walled box (walls are not ground), e = 0.5,
//!   mu = 0.5, 4 s: settling time (from when every ball stays below 2 cm/s), the deepest
//!   penetration of a ball into the ground, and jitter (mean of the fastest ball's speed over
//!   the last second). No closed form: rapier alone is the reference.

// Precision-generic: `Real` is f32 or f64 (feature `f64`).
#![allow(clippy::unnecessary_cast, clippy::useless_conversion)]

mod common;

use clap::Parser;
use common::{Mode, Rng, real, wide};
use indicatif::{ProgressBar, ProgressStyle};
use plotters::prelude::*;
use rapier_impact::TimingMode;
use rapier_impact::model::Law;
use rapier_impact::rapier::prelude::*;
use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// The accuracy sweep: error against the closed forms and CPU time per simulated second for
/// every timing mode, law, dt and precision (this build's, then the other one's, which it
/// builds and runs), on a drop, a spin bounce, a thrown cube, a pile and a putt. It prints the
/// report and writes it with its plots into target/accuracy_sweep/ of the crate, into --out,
/// or, with --write-docs, over docs/accuracy.md and the plots in docs/.
#[derive(Parser, Debug)]
#[command(
    name = "accuracy_sweep",
    after_help = "Example: cargo run --release --example accuracy_sweep -- --write-docs"
)]
struct Args {
    /// Run this build's precision only and write its rows to PATH (no report)
    /// [default: none]
    #[arg(long, value_name = "PATH")]
    rows: Option<PathBuf>,
    /// Directory of accuracy.md and the plots [default: target/accuracy_sweep in the crate]
    #[arg(long, value_name = "DIR", conflicts_with = "write_docs")]
    out: Option<PathBuf>,
    /// This build's precision only, report included
    #[arg(long)]
    single: bool,
    /// Rewrite docs/accuracy.md and the plots in docs/ of the crate (the committed report)
    #[arg(long, conflicts_with = "rows")]
    write_docs: bool,
}

const G: f64 = 9.81;
const DTS: [(f64, &str); 5] = [
    (1.0 / 30.0, "1/30"),
    (1.0 / 60.0, "1/60"),
    (1.0 / 120.0, "1/120"),
    (1.0 / 240.0, "1/240"),
    (1.0 / 1000.0, "1/1000"),
];
const MODES: [Mode; 4] = [
    Mode::Rapier,
    Mode::Plugin(TimingMode::Step),
    Mode::Plugin(TimingMode::TimeOfImpact),
    Mode::Plugin(TimingMode::Exact),
];
const LAWS: [Law; 3] = [Law::Document, Law::Consistent, Law::Guarded];

fn law_name(law: Law) -> &'static str {
    match law {
        Law::Document => "document",
        Law::Consistent => "consistent",
        Law::Guarded => "guarded",
    }
}

/// The runs of one precision: rapier alone once per dt (the law is not used), the plugin's
/// modes with each law.
fn configs() -> Vec<(Mode, Option<Law>, usize)> {
    let mut out = Vec::new();
    for di in 0..DTS.len() {
        for mode in MODES {
            if mode == Mode::Rapier {
                out.push((mode, None, di));
            } else {
                for law in LAWS {
                    out.push((mode, Some(law), di));
                }
            }
        }
    }
    out
}

/// The measured values of one configuration, in one precision.
#[derive(Clone, Debug, Default)]
struct Row {
    precision: String,
    mode: String,
    law: String,
    dt: String,
    /// Drop: worst relative apex error, worst impact-time error (s), bounces found, cost.
    drop_apex: f64,
    drop_time: f64,
    drop_bounces: usize,
    drop_cost: f64,
    /// Spin: worst relative error after the first bounce, stick and slip cases; cost.
    spin_stick: f64,
    spin_slip: f64,
    spin_cost: f64,
    /// Cube: energy gained at impacts (share of the throw's energy), worst per-event KE gain
    /// (relative, NaN for rapier alone), cost.
    cube_gain: f64,
    cube_event_gain: f64,
    cube_cost: f64,
    /// Pile: settling time (s, NaN if never), deepest penetration (m), jitter (m/s), cost.
    pile_settle: f64,
    pile_pen: f64,
    pile_jitter: f64,
    pile_cost: f64,
    /// Putt: relative error of the stopping distance (NaN where it does not stop in time).
    putt_err: f64,
}

const FIELDS: usize = 20;

impl Row {
    fn to_line(&self) -> String {
        format!(
            "{}\t{}\t{}\t{}\t{:e}\t{:e}\t{}\t{:e}\t{:e}\t{:e}\t{:e}\t{:e}\t{:e}\t{:e}\t{:e}\t{:e}\t{:e}\t{:e}\t{:e}",
            self.precision,
            self.mode,
            self.law,
            self.dt,
            self.drop_apex,
            self.drop_time,
            self.drop_bounces,
            self.drop_cost,
            self.spin_stick,
            self.spin_slip,
            self.spin_cost,
            self.cube_gain,
            self.cube_event_gain,
            self.cube_cost,
            self.pile_settle,
            self.pile_pen,
            self.pile_jitter,
            self.pile_cost,
            self.putt_err,
        )
    }

    fn from_line(line: &str) -> Option<Row> {
        let f: Vec<&str> = line.split('\t').collect();
        if f.len() != FIELDS - 1 {
            return None;
        }
        let n = |i: usize| f[i].parse::<f64>().ok();
        Some(Row {
            precision: f[0].into(),
            mode: f[1].into(),
            law: f[2].into(),
            dt: f[3].into(),
            drop_apex: n(4)?,
            drop_time: n(5)?,
            drop_bounces: f[6].parse().ok()?,
            drop_cost: n(7)?,
            spin_stick: n(8)?,
            spin_slip: n(9)?,
            spin_cost: n(10)?,
            cube_gain: n(11)?,
            cube_event_gain: n(12)?,
            cube_cost: n(13)?,
            pile_settle: n(14)?,
            pile_pen: n(15)?,
            pile_jitter: n(16)?,
            pile_cost: n(17)?,
            putt_err: n(18)?,
        })
    }
}

// ---------------------------------------------------------------------------------------------
// Scenes

/// The CPU time of this thread (s): the wall time the steps take on an otherwise idle core,
/// unaffected by other processes sharing the machine. Rapier runs single-threaded here.
#[cfg(unix)]
fn cpu_seconds() -> f64 {
    let mut ts = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: `ts` is a valid, writable timespec; the clock id is a constant of the platform.
    let rc = unsafe { libc::clock_gettime(libc::CLOCK_THREAD_CPUTIME_ID, &mut ts) };
    if rc == 0 {
        ts.tv_sec as f64 + ts.tv_nsec as f64 * 1e-9
    } else {
        wall_seconds()
    }
}

#[cfg(not(unix))]
fn cpu_seconds() -> f64 {
    wall_seconds()
}

/// Seconds since the first call.
fn wall_seconds() -> f64 {
    static START: std::sync::OnceLock<Instant> = std::sync::OnceLock::new();
    START.get_or_init(Instant::now).elapsed().as_secs_f64()
}

/// A world at `dt` with a half-space ground, and the plugin for `mode` (none for rapier alone).
fn scene(
    dt: f64,
    mode: Mode,
    law: Law,
    e: f64,
    mu: f64,
) -> (
    PhysicsWorld,
    Option<rapier_impact::ImpactPlugin>,
    ColliderHandle,
) {
    let mut world = common::world(dt);
    let ground = common::ground(&mut world, e, mu);
    (world, None, ground).with(mode, law)
}

trait WithPlugin {
    fn with(self, mode: Mode, law: Law) -> Self;
}

impl WithPlugin
    for (
        PhysicsWorld,
        Option<rapier_impact::ImpactPlugin>,
        ColliderHandle,
    )
{
    fn with(mut self, mode: Mode, law: Law) -> Self {
        self.1 = common::plugin(mode, law, &mut self.0, self.2);
        self
    }
}

const DROP_H0: f64 = 1.0;
const DROP_E: f64 = 0.8;
const DROP_R: f64 = 0.1;
const DROP_T: f64 = 3.8;
const BOUNCES: usize = 10;

fn drop_t1() -> f64 {
    (2.0 * DROP_H0 / G).sqrt()
}

/// The closed-form impact times.
fn drop_impact_time(k: usize) -> f64 {
    let (t1, e) = (drop_t1(), DROP_E);
    t1 + 2.0 * t1 * e * (1.0 - e.powi(k as i32)) / (1.0 - e)
}

/// The closed-form height of the ball's bottom at `t`.
fn drop_height(t: f64) -> f64 {
    let t1 = drop_t1();
    if t <= t1 {
        return DROP_H0 - 0.5 * G * t * t;
    }
    let mut k = 0;
    while k < 60 && drop_impact_time(k + 1) <= t {
        k += 1;
    }
    let v = DROP_E.powi(k as i32 + 1) * G * t1;
    let s = t - drop_impact_time(k);
    (v * s - 0.5 * G * s * s).max(0.0)
}

struct DropResult {
    apex_err: f64,
    time_err: f64,
    bounces: usize,
    cost: f64,
    /// (t, height of the ball's bottom).
    trace: Vec<(f64, f64)>,
}

fn run_drop(dt: f64, mode: Mode, law: Law) -> DropResult {
    let (mut world, mut plugin, _) = scene(dt, mode, law, DROP_E, 0.5);
    let (ball, _) = world.insert(
        RigidBodyBuilder::dynamic().translation(Vector::new(0.0, real(DROP_R + DROP_H0), 0.0)),
        ColliderBuilder::ball(real(DROP_R))
            .restitution(real(DROP_E))
            .friction(0.5),
    );
    let dt = wide(world.integration_parameters.dt);
    let steps = (DROP_T / dt).ceil() as usize;
    let mut impacts = Vec::new();
    let mut apexes = Vec::new();
    let mut trace = vec![(0.0, DROP_H0)];
    let mut top: Option<(f64, f64)> = None;
    let mut prev_vy = 0.0;
    let clock = cpu_seconds();
    for k in 1..=steps {
        let t = k as f64 * dt;
        let events = common::step(&mut world, &mut plugin);
        for e in events {
            if !e.settled {
                impacts.push(t - dt + e.time);
            }
        }
        let rb = &world.bodies[ball];
        let (y, vy) = (wide(rb.center_of_mass().y), wide(rb.linvel().y));
        trace.push((t, y - DROP_R));
        if prev_vy < 0.0 && vy > 0.0 {
            if plugin.is_none() {
                impacts.push(t);
            }
            if let Some((ty, tvy)) = top.take() {
                apexes.push(ty - DROP_R + tvy * tvy / (2.0 * G));
            }
        }
        if vy.abs() > 1e-9 && top.is_none_or(|(ty, _)| y > ty) {
            top = Some((y, vy));
        }
        prev_vy = vy;
    }
    let wall = cpu_seconds() - clock;
    // The first "apex" is the release height.
    let apexes: Vec<f64> = apexes.into_iter().skip(1).collect();
    let bounces = apexes.len().min(impacts.len()).min(BOUNCES);
    let apex_err = (0..BOUNCES)
        .map(|n| match apexes.get(n) {
            Some(a) => (a / (DROP_E.powi(2 * (n as i32 + 1)) * DROP_H0) - 1.0).abs(),
            None => 1.0, // a bounce that never came: 100 % off
        })
        .fold(0.0, f64::max);
    let time_err = (0..BOUNCES)
        .filter_map(|k| impacts.get(k).map(|t| (t - drop_impact_time(k)).abs()))
        .fold(0.0, f64::max);
    DropResult {
        apex_err,
        time_err,
        bounces,
        cost: wall / (steps as f64 * dt),
        trace,
    }
}

const SPIN_R: f64 = 0.1;
const SPIN_GAP: f64 = 0.2;
const SPIN_E: f64 = 0.8;
const SPIN_K: f64 = 0.4;
const SPIN_VX: f64 = 5.0;
const SPIN_VY: f64 = 5.0;
const SPIN_T: f64 = 1.5;
/// (friction, w_z at release): stick (backspin 20) and slip (topspin 100).
const SPIN_CASES: [(f64, f64); 2] = [(0.5, 20.0), (0.1, -100.0)];

/// The closed-form bounce: `(vx', w_z', vy' upward)` from `(vx, w_z, vy down)`.
fn spin_bounce(mu: f64, vx: f64, wz: f64, vy: f64) -> (f64, f64, f64) {
    let (k, r, e) = (SPIN_K, SPIN_R, SPIN_E);
    let u = vx + r * wz;
    let pn = (1.0 + e) * vy;
    if u.abs() <= mu * pn * (1.0 + k) / k {
        let vx2 = (vx - k * r * wz) / (1.0 + k);
        (vx2, -vx2 / r, e * vy)
    } else {
        let s = u.signum();
        (vx - mu * pn * s, wz - mu * pn * s / (k * r), e * vy)
    }
}

/// The closed-form `(vx, w_z)` at `t` for a case released at the nominal state.
fn spin_closed(mu: f64, spin: f64, t: f64) -> (f64, f64) {
    let vy0 = (SPIN_VY * SPIN_VY - 2.0 * G * SPIN_GAP).sqrt();
    let mut t_hit = (SPIN_VY - vy0) / G;
    let (mut vx, mut wz, mut vy) = (SPIN_VX, spin, SPIN_VY);
    while t_hit <= t && vy > 1e-3 {
        (vx, wz, vy) = spin_bounce(mu, vx, wz, vy);
        t_hit += 2.0 * vy / G;
    }
    (vx, wz)
}

/// `(t, vx, w_z)` per step.
type SpinTrace = Vec<(f64, f64, f64)>;

struct SpinResult {
    err: f64,
    cost: f64,
    trace: SpinTrace,
}

fn run_spin(dt: f64, mode: Mode, law: Law, case: (f64, f64)) -> SpinResult {
    let (mu, spin) = case;
    let (mut world, mut plugin, _) = scene(dt, mode, law, SPIN_E, mu);
    let vy0 = -(SPIN_VY * SPIN_VY - 2.0 * G * SPIN_GAP).sqrt();
    let mass = 1.0;
    let (ball, _) = world.insert(
        RigidBodyBuilder::dynamic()
            .translation(Vector::new(0.0, real(SPIN_R + SPIN_GAP), 0.0))
            .linvel(Vector::new(real(SPIN_VX), real(vy0), 0.0))
            .angvel(Vector::new(0.0, 0.0, real(spin)))
            .allow_fast_rotation(true),
        ColliderBuilder::ball(real(SPIN_R))
            .mass_properties(MassProperties::new(
                Vector::ZERO,
                real(mass),
                Vector::splat(real(SPIN_K * mass * SPIN_R * SPIN_R)),
            ))
            .restitution(real(SPIN_E))
            .friction(real(mu)),
    );
    // The closed form on the rounded release state.
    let (rb, r) = (&world.bodies[ball], wide(real(SPIN_R)));
    let (vx, wz) = (wide(rb.linvel().x), wide(rb.angvel().z));
    let (y0, vy0) = (wide(rb.center_of_mass().y), wide(rb.linvel().y));
    let vy_contact = (vy0 * vy0 + 2.0 * G * (y0 - r)).sqrt();
    let expected = spin_bounce(mu, vx, wz, vy_contact);
    let dt = wide(world.integration_parameters.dt);
    let steps = (SPIN_T / dt).ceil() as usize;
    let mut trace = vec![(0.0, vx, wz)];
    let mut err = None;
    let clock = cpu_seconds();
    for k in 1..=steps {
        common::step(&mut world, &mut plugin);
        let rb = &world.bodies[ball];
        let (y, v, w) = (wide(rb.center_of_mass().y), rb.linvel(), rb.angvel());
        trace.push((k as f64 * dt, wide(v.x), wide(w.z)));
        let vy = wide(v.y);
        // The first sample clear of the ground after the bounce (as tests/plugin_spin.rs).
        if err.is_none() && vy > 0.0 && y - r > 5e-3 {
            let takeoff = (vy * vy + 2.0 * G * (y - r)).sqrt();
            let m = [wide(v.x), wide(w.z), takeoff];
            let x = [expected.0, expected.1, expected.2];
            err = Some(
                (0..3)
                    .map(|i| (m[i] / x[i] - 1.0).abs())
                    .fold(0.0, f64::max),
            );
        }
    }
    let wall = cpu_seconds() - clock;
    SpinResult {
        err: err.unwrap_or(1.0),
        cost: wall / (steps as f64 * dt),
        trace,
    }
}

const CUBE_SEEDS: u64 = 6;
const CUBE_T: f64 = 3.0;
const CUBE_SIZE: f64 = 0.1;

/// `(energy gained at impacts / throw energy, worst event KE gain, wall s, simulated s)`.
fn run_cube(dt: f64, mode: Mode, law: Law, seed: u64) -> (f64, f64, f64, f64) {
    let (e, mu) = (0.5, 0.5);
    let (mut world, mut plugin, _) = scene(dt, mode, law, e, mu);
    // The throw of examples/dice.rs.
    let half = 0.5 * CUBE_SIZE;
    let cube = common::DiceThrow::new(seed).insert_cube(&mut world, half, e, mu);
    let energy = |world: &PhysicsWorld| -> (f64, f64) {
        let rb = &world.bodies[cube];
        let m = wide(rb.mass());
        let (v, w) = (rb.linvel(), rb.angvel());
        let iw = rb.mass_properties().effective_angular_inertia() * w;
        let ke = 0.5 * m * wide(v.length_squared()) + 0.5 * wide(w.dot(iw));
        let y = wide(rb.center_of_mass().y);
        let rot = *rb.rotation();
        let lowest = [-1.0, 1.0]
            .iter()
            .flat_map(|&a| [-1.0, 1.0].map(move |b| (a, b)))
            .flat_map(|(a, b)| [-1.0, 1.0].map(move |c| [a, b, c]))
            .map(|c| {
                wide((rot * Vector::new(real(c[0] * half), real(c[1] * half), real(c[2] * half))).y)
            })
            .fold(f64::INFINITY, f64::min);
        (ke + m * G * y, y + lowest)
    };
    let rest = wide(world.bodies[cube].mass()) * G * half;
    let (e0, _) = energy(&world);
    let steps = (CUBE_T / wide(world.integration_parameters.dt)).ceil() as usize;
    let (mut prev, mut gained, mut event_gain) = (energy(&world), 0.0, 0.0f64);
    let clock = cpu_seconds();
    for _ in 0..steps {
        let events = common::step(&mut world, &mut plugin);
        for ev in events {
            if ev.ke_before > 0.0 {
                event_gain = event_gain.max(ev.ke_after / ev.ke_before - 1.0);
            }
        }
        let now = energy(&world);
        if (now.1.min(prev.1)) < 0.02 && now.0 > prev.0 {
            gained += now.0 - prev.0;
        }
        prev = now;
    }
    let wall = cpu_seconds() - clock;
    let sim = steps as f64 * wide(world.integration_parameters.dt);
    (gained / (e0 - rest), event_gain, wall, sim)
}

const PILE_N: usize = 125;
const PILE_R: f64 = 0.05;
const PILE_T: f64 = 4.0;

/// `(settling time or NaN, deepest penetration, jitter, cost)`.
/// The putt of the README: a golf ball (R = 21.335 mm, solid) rolling at 1.8 m/s on a level
/// green with rolling resistance 0.078 (stimp 10). Returns the relative error of where it
/// stops against `v0^2 (1 + k) / (2 mu_r g)` (NaN if it has not stopped after 6 s, as in
/// rapier alone, which has no rolling resistance).
fn run_putt(dt: f64, mode: Mode, law: Law) -> f64 {
    let (r, v0, mu_r) = (0.021_335, 1.8, 0.078);
    let mut world = common::world(dt);
    let ground = common::ground(&mut world, 0.0, 0.2);
    let (ball, _) = world.insert(
        RigidBodyBuilder::dynamic()
            .translation(Vector::new(0.0, real(r), 0.0))
            .linvel(Vector::new(real(v0), 0.0, 0.0))
            .angvel(Vector::new(0.0, 0.0, real(-v0 / r))),
        ColliderBuilder::ball(real(r))
            .restitution(0.0)
            .friction(0.2),
    );
    let mut plugin = common::plugin(mode, law, &mut world, ground);
    if let Some(p) = plugin.as_mut() {
        let mut config = p.config().clone();
        config.rolling_resistance = mu_r;
        p.set_config(config).expect("a valid configuration");
    }
    let steps = (6.0 / dt).ceil() as usize;
    for _ in 0..steps {
        common::step(&mut world, &mut plugin);
    }
    let rb = &world.bodies[ball];
    if wide(rb.linvel().length()) > 1e-9 {
        return f64::NAN;
    }
    let expected = v0 * v0 * 1.4 / (2.0 * mu_r * 9.81);
    (wide(rb.center_of_mass().x) - expected) / expected
}

fn run_pile(dt: f64, mode: Mode, law: Law) -> (f64, f64, f64, f64) {
    let (mut world, _, ground) = {
        let mut world = common::world(dt);
        let ground = common::ground(&mut world, 0.5, 0.5);
        (world, (), ground)
    };
    let pitch = 2.0 * PILE_R + 0.01;
    let side = 5usize;
    let inner = 0.5 * side as f64 * pitch;
    let (h, t) = (0.5, 0.1);
    for (x, z, hx, hz) in [
        (inner + t, 0.0, t, inner + 2.0 * t),
        (-inner - t, 0.0, t, inner + 2.0 * t),
        (0.0, inner + t, inner, t),
        (0.0, -inner - t, inner, t),
    ] {
        world.insert(
            RigidBodyBuilder::fixed(),
            ColliderBuilder::cuboid(real(hx), real(h), real(hz))
                .translation(Vector::new(real(x), real(h), real(z)))
                .friction(0.5),
        );
    }
    let mut rng = Rng::new(3);
    let mut balls = Vec::new();
    for i in 0..PILE_N {
        let (level, cell) = (i / (side * side), i % (side * side));
        let (row, col) = (cell / side, cell % side);
        let p = [
            (col as f64 + 0.5) * pitch - inner + rng.range(-0.01, 0.01),
            PILE_R + 0.1 + level as f64 * (pitch + 0.03),
            (row as f64 + 0.5) * pitch - inner + rng.range(-0.01, 0.01),
        ];
        let (b, _) = world.insert(
            RigidBodyBuilder::dynamic().translation(Vector::new(
                real(p[0]),
                real(p[1]),
                real(p[2]),
            )),
            ColliderBuilder::ball(real(PILE_R))
                .restitution(0.5)
                .friction(0.5),
        );
        balls.push(b);
    }
    let mut plugin = common::plugin(mode, law, &mut world, ground);
    let dt = wide(world.integration_parameters.dt);
    let steps = (PILE_T / dt).ceil() as usize;
    let (mut settle, mut pen, mut jitter, mut jitter_n) = (None, 0.0f64, 0.0, 0);
    let clock = cpu_seconds();
    for k in 1..=steps {
        common::step(&mut world, &mut plugin);
        let t = k as f64 * dt;
        let mut fastest = 0.0f64;
        for b in &balls {
            let rb = &world.bodies[*b];
            fastest = fastest.max(wide(rb.linvel().length()));
            pen = pen.max(PILE_R - wide(rb.center_of_mass().y));
        }
        match (fastest < 0.02, settle) {
            (true, None) => settle = Some(t),
            (false, Some(_)) => settle = None,
            _ => {}
        }
        if t > PILE_T - 1.0 {
            jitter += fastest;
            jitter_n += 1;
        }
    }
    let wall = cpu_seconds() - clock;
    (
        settle.unwrap_or(f64::NAN),
        pen,
        jitter / jitter_n.max(1) as f64,
        wall / (steps as f64 * dt),
    )
}

/// Every scene for one configuration.
fn measure(mode: Mode, law: Option<Law>, di: usize) -> Row {
    let (dt, dt_name) = DTS[di];
    let l = law.unwrap_or(Law::Guarded);
    let drop = run_drop(dt, mode, l);
    let stick = run_spin(dt, mode, l, SPIN_CASES[0]);
    let slip = run_spin(dt, mode, l, SPIN_CASES[1]);
    let (mut gain, mut event_gain, mut wall, mut sim) = (0.0f64, 0.0f64, 0.0, 0.0);
    for seed in 1..=CUBE_SEEDS {
        let (g, eg, w, s) = run_cube(dt, mode, l, seed);
        gain = gain.max(g);
        event_gain = event_gain.max(eg);
        wall += w;
        sim += s;
    }
    let pile = run_pile(dt, mode, l);
    let putt_err = run_putt(dt, mode, l);
    Row {
        precision: common::PRECISION.into(),
        mode: mode.name().into(),
        law: law.map_or("-", law_name).into(),
        dt: dt_name.into(),
        drop_apex: drop.apex_err,
        drop_time: drop.time_err,
        drop_bounces: drop.bounces,
        drop_cost: drop.cost,
        spin_stick: stick.err,
        spin_slip: slip.err,
        spin_cost: 0.5 * (stick.cost + slip.cost),
        cube_gain: gain,
        cube_event_gain: if mode == Mode::Rapier {
            f64::NAN
        } else {
            event_gain
        },
        cube_cost: wall / sim,
        pile_settle: pile.0,
        pile_pen: pile.1,
        pile_jitter: pile.2,
        pile_cost: pile.3,
        putt_err,
    }
}

fn sweep() -> Vec<Row> {
    let configs = configs();
    let bar = ProgressBar::new(configs.len() as u64);
    bar.set_style(
        ProgressStyle::with_template(
            "{prefix} [{bar:40}] {pos}/{len} runs, {elapsed} elapsed, ~{eta} left: {msg}",
        )
        .expect("a valid template")
        .progress_chars("=> "),
    );
    bar.set_prefix(format!("accuracy sweep ({})", common::PRECISION));
    let mut rows = Vec::new();
    for (mode, law, di) in configs {
        bar.set_message(format!(
            "{} {} dt {}",
            mode.name(),
            law.map_or("-", law_name),
            DTS[di].1
        ));
        rows.push(measure(mode, law, di));
        bar.inc(1);
    }
    bar.finish();
    rows
}

// ---------------------------------------------------------------------------------------------
// Report

fn sci(x: f64) -> String {
    if x.is_nan() {
        "-".into()
    } else if x == 0.0 {
        "0".into()
    } else {
        format!("{x:.1e}")
    }
}

fn ms(x: f64) -> String {
    format!("{:.3}", x * 1e3)
}

fn machine() -> String {
    let cpu = std::fs::read_to_string("/proc/cpuinfo")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("model name"))
                .and_then(|l| l.split_once(':'))
                .map(|(_, v)| v.trim().to_string())
        })
        .unwrap_or_else(|| "unknown CPU".into());
    let cores = std::thread::available_parallelism().map_or(0, |n| n.get());
    let date = std::process::Command::new("date")
        .args(["-u", "+%Y-%m-%d %H:%M UTC"])
        .output()
        .ok()
        .map(|o| String::from_utf8_lossy(&o.stdout).trim().to_string())
        .unwrap_or_default();
    let rustc = std::process::Command::new("rustc")
        .arg("-V")
        .output()
        .ok()
        .map(|o| String::from_utf8_lossy(&o.stdout).trim().to_string())
        .unwrap_or_default();
    format!("{cpu}, {cores} cores (`nproc`); {rustc}; run {date}")
}

fn report(rows: &[Row], secs: &BTreeMap<String, (f64, f64)>, total: f64, single: bool) -> String {
    let mut s = String::new();
    report_intro(&mut s, secs, total, single);
    report_headline(&mut s, rows);
    report_rolling(&mut s, rows);
    report_every_run(&mut s, rows);
    s
}

/// The report's title, how to rerun it, the machine, and how it was made (`single`: by
/// `--single`, of this build's precision only).
fn report_intro(w: &mut String, secs: &BTreeMap<String, (f64, f64)>, total: f64, single: bool) {
    let precision = common::PRECISION;
    let (only, other, precisions) = if single {
        (
            format!("; this report, made with `--single`, is of the {precision} build only"),
            "",
            format!("{precision} only"),
        )
    } else {
        let both = "f32, f64".to_string();
        (
            String::new(),
            ", building the other precision included",
            both,
        )
    };
    let _ = writeln!(
        w,
        "# Accuracy against cost\n\n\
         Generated by `examples/accuracy_sweep.rs`; do not edit by hand. Rerun with\n\n\
         ```sh\ncargo run --release --example accuracy_sweep -- --write-docs\n```\n\n\
         (it runs both precisions: f32, then itself rebuilt with `--features f64`{only}; `--write-docs` makes it\n\
         rewrite this file and the plots `docs/tradeoff.svg`, `docs/drop_trace.svg`, `docs/spin_trace.svg`).\n\n\
         Machine: {}.\n\n\
         The sweep took {:.0} s of wall time in all{other}\n\
         ({}). Costs are the CPU time of the thread that steps, per simulated second, around the\n\
         steps only (scene set-up excluded), one run each: on an idle core that is the wall time;\n\
         measured this way, other processes sharing the machine do not inflate it (they still\n\
         perturb caches: expect some ten per cent of noise).\n",
        machine(),
        total,
        secs.iter()
            .map(|(p, (wall, cpu))| format!("{p}: {wall:.0} s wall, {cpu:.0} s CPU"))
            .collect::<Vec<_>>()
            .join("; ")
    );
    let _ = writeln!(
        w,
        "## How it was made\n\n\
         Every combination of timing mode (`rapier` = rapier 0.36 alone, no plugin; the plugin's\n\
         `step`, `toi` = `TimeOfImpact`, `exact`), law (`document`, `consistent`, `guarded`;\n\
         rapier alone has none), dt (1/30 to 1/1000 s) and precision ({precisions}) runs four fixed\n\
         scenes, y up, half-space ground at y = 0, g = 9.81, rapier's default parameters\n\
         (4 solver iterations):\n\n\
         - **drop**: ball R = 0.1 m released 1 m above the ground, e = 0.8, 3.8 s. Worst\n\
           relative apex error over 10 bounces against `apex_n = e^(2n) h0` (a missing bounce\n\
           counts 100 %), worst impact-time error against `t_(k+1) = t1 + 2 t1 e (1-e^k)/(1-e)`.\n\
           Apex = height of the bottom plus `vy^2/2g` at the highest sample of each flight.\n\
         - **spin**: solid ball R = 0.1 m reaching the ground at 5 m/s down and 5 m/s along x,\n\
           e = 0.8, stick case (mu = 0.5, backspin 20 rad/s) and slip case (mu = 0.1, topspin\n\
           100 rad/s), 1.5 s each. Worst relative error of `vx'`, `w_z'` and take-off speed after\n\
           the first bounce against the closed forms (`tests/plugin_spin.rs`).\n\
         - **cube**: a 0.1 m cube thrown as `examples/dice.rs` with seeds 1-6, e = 0.5,\n\
           mu = 0.5, 3 s each. *Energy gain*: the sum of the increases of `KE + m g y` over the\n\
           steps in which the cube is within 2 cm of the ground, as a share of the throw's energy\n\
           above rest, worst seed (0 is right: no impact with e <= 1 adds energy; rapier's\n\
           flight and the plugin's exact flight never do). *Event gain*: the largest\n\
           `ke_after/ke_before - 1` of a single impact event (plugin only).\n\
         - **pile**: 125 balls R = 5 cm dropped in five layers into a walled box (walls are not\n\
           ground), e = 0.5, mu = 0.5, 4 s. Settling time: from when every ball stays below\n\
           2 cm/s (`-`: never within 4 s); deepest penetration of a ball into the ground; jitter:\n\
           the fastest ball's speed averaged over the last second. No closed form: rapier alone\n\
           is the reference.\n\n\
         Cost: CPU time of the steps per simulated second (ms per simulated s), single-threaded.\n"
    );
    // Headline: guarded law (the default), per mode, at 1/60 and 1/1000.
}

/// The headline table: law `guarded` and rapier alone at dt 1/60 and 1/1000.
fn report_headline(w: &mut String, rows: &[Row]) {
    let _ = writeln!(
        w,
        "## Headline (law `guarded`, the default; rapier alone for comparison)\n\n\
         | precision | mode | dt | drop apex err | drop time err (s) | spin err (stick / slip) | cube energy gain | pile settle (s) / max pen. (mm) | cost drop / pile (ms per sim. s) |\n\
         |---|---|---|---|---|---|---|---|---|"
    );
    for r in rows
        .iter()
        .filter(|r| (r.law == "guarded" || r.law == "-") && (r.dt == "1/60" || r.dt == "1/1000"))
    {
        let _ = writeln!(
            w,
            "| {} | {} | {} | {} | {} | {} / {} | {} | {} / {:.2} | {} / {} |",
            r.precision,
            r.mode,
            r.dt,
            sci(r.drop_apex),
            sci(r.drop_time),
            sci(r.spin_stick),
            sci(r.spin_slip),
            sci(r.cube_gain),
            if r.pile_settle.is_nan() {
                "-".into()
            } else {
                format!("{:.2}", r.pile_settle)
            },
            r.pile_pen * 1e3,
            ms(r.drop_cost),
            ms(r.pile_cost),
        );
    }
}

/// The putt's stopping distance, and the plots.
fn report_rolling(w: &mut String, rows: &[Row]) {
    let _ = writeln!(
        w,
        "\n## Rolling (law `guarded`)\n\n\
         The putt of the README: a golf ball rolling at 1.8 m/s on a level green with rolling\n\
         resistance 0.078, against its closed-form stop `v0^2 (1 + k) / (2 mu_r g)` = 2.964 m\n\
         (`-`: still rolling after 6 s).\n\n\
         | precision | mode | dt | stopping distance err |\n\
         |---|---|---|---|"
    );
    for r in rows.iter().filter(|r| r.law == "guarded" || r.law == "-") {
        let _ = writeln!(
            w,
            "| {} | {} | {} | {} |",
            r.precision,
            r.mode,
            r.dt,
            sci(r.putt_err)
        );
    }
    let _ = writeln!(
        w,
        "\n![error against cost per mode](tradeoff.svg)\n\n\
         ![drop trace](drop_trace.svg)\n\n![spin trace](spin_trace.svg)\n"
    );
}

/// Every run's row.
fn report_every_run(w: &mut String, rows: &[Row]) {
    let _ = writeln!(
        w,
        "## Every run\n\n\
         Errors are relative unless a unit is given; costs in ms of CPU time per simulated\n\
         second.\n\n\
         | precision | mode | law | dt | drop apex err | drop time err (s) | bounces | drop cost | spin stick err | spin slip err | spin cost | cube energy gain | cube event gain | cube cost | pile settle (s) | pile pen. (mm) | pile jitter (m/s) | pile cost |\n\
         |---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"
    );
    for r in rows {
        let _ = writeln!(
            w,
            "| {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {:.2} | {} | {} |",
            r.precision,
            r.mode,
            r.law,
            r.dt,
            sci(r.drop_apex),
            sci(r.drop_time),
            r.drop_bounces,
            ms(r.drop_cost),
            sci(r.spin_stick),
            sci(r.spin_slip),
            ms(r.spin_cost),
            sci(r.cube_gain),
            sci(r.cube_event_gain),
            ms(r.cube_cost),
            if r.pile_settle.is_nan() {
                "-".into()
            } else {
                format!("{:.2}", r.pile_settle)
            },
            r.pile_pen * 1e3,
            sci(r.pile_jitter),
            ms(r.pile_cost),
        );
    }
}

// ---------------------------------------------------------------------------------------------
// Plots

type PlotResult = Result<(), Box<dyn std::error::Error>>;
/// The axes of the drop and spin plots.
type Axis = plotters::coord::types::RangedCoordf64;

const MODE_COLORS: [RGBColor; 4] = [
    RGBColor(200, 30, 30),
    RGBColor(230, 150, 0),
    RGBColor(30, 110, 200),
    RGBColor(20, 150, 60),
];

fn mode_color(mode: &str) -> RGBColor {
    let i = MODES.iter().position(|m| m.name() == mode).unwrap_or(0);
    MODE_COLORS[i]
}

/// Error against cost, one line per mode and precision (law `guarded`), the points at each dt.
fn plot_tradeoff(rows: &[Row], path: &Path) -> PlotResult {
    let root = SVGBackend::new(path, (1100, 480)).into_drawing_area();
    root.fill(&WHITE)?;
    let panels = root.split_evenly((1, 2));
    type Get = fn(&Row) -> (f64, f64);
    let specs: [(&str, &str, Get); 2] = [
        (
            "drop: worst apex error over 10 bounces",
            "relative apex error",
            |r| (r.drop_cost, r.drop_apex),
        ),
        (
            "spin: worst post-bounce error (slip case)",
            "relative error of vx', w_z', vy'",
            |r| (r.spin_cost, r.spin_slip),
        ),
    ];
    for (panel, (title, ylabel, get)) in panels.iter().zip(specs) {
        let pts: Vec<(f64, f64)> = rows
            .iter()
            .filter(|r| r.law == "guarded" || r.law == "-")
            .map(get)
            .map(|(c, e)| (c * 1e3, e.max(1e-16)))
            .collect();
        let (xmin, xmax) = pts.iter().fold((f64::INFINITY, 0.0f64), |(a, b), p| {
            (a.min(p.0), b.max(p.0))
        });
        let mut chart = ChartBuilder::on(panel)
            .caption(title, ("sans-serif", 18))
            .margin(12)
            .x_label_area_size(40)
            .y_label_area_size(60)
            .build_cartesian_2d(
                (xmin * 0.7..xmax * 1.5).log_scale(),
                (1e-16f64..2.0).log_scale(),
            )?;
        chart
            .configure_mesh()
            .x_desc("CPU time per simulated second (ms); points: dt = 1/30 (left) to 1/1000")
            .y_desc(ylabel)
            .x_labels(6)
            .y_label_formatter(&|y| format!("{y:.0e}"))
            .x_label_formatter(&|x| format!("{x:.2}"))
            .draw()?;
        for mode in MODES {
            for precision in ["f32", "f64"] {
                let line: Vec<(f64, f64)> = rows
                    .iter()
                    .filter(|r| {
                        r.mode == mode.name()
                            && r.precision == precision
                            && (r.law == "guarded" || r.law == "-")
                    })
                    .map(get)
                    .map(|(c, e)| (c * 1e3, e.max(1e-16)))
                    .collect();
                if line.is_empty() {
                    continue;
                }
                let color = mode_color(mode.name());
                let style = if precision == "f32" {
                    color.stroke_width(2)
                } else {
                    color.mix(0.45).stroke_width(2)
                };
                chart
                    .draw_series(LineSeries::new(line.clone(), style))?
                    .label(format!(
                        "{} ({precision})",
                        if mode == Mode::Rapier {
                            "rapier alone"
                        } else {
                            mode.name()
                        }
                    ))
                    .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], style));
                if precision == "f32" {
                    chart.draw_series(line.iter().map(|p| Circle::new(*p, 3, color.filled())))?;
                } else {
                    chart.draw_series(
                        line.iter()
                            .map(|p| TriangleMarker::new(*p, 4, color.mix(0.45).filled())),
                    )?;
                }
            }
        }
        chart
            .configure_series_labels()
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK)
            .label_font(("sans-serif", 12))
            .position(SeriesLabelPosition::MiddleRight)
            .draw()?;
    }
    root.present()?;
    Ok(())
}

/// Draws the closed form (thick, black) and each mode's trace (`width` px, in the mode's
/// colour) on `chart`, with their legend at `position`.
fn draw_against_closed_form<'c, 'b: 'c, 'n>(
    chart: &mut ChartContext<'c, SVGBackend<'b>, Cartesian2d<Axis, Axis>>,
    analytic: Vec<(f64, f64)>,
    traces: impl Iterator<Item = (&'n str, Vec<(f64, f64)>)>,
    width: u32,
    position: SeriesLabelPosition,
) -> PlotResult {
    chart
        .draw_series(LineSeries::new(analytic, BLACK.stroke_width(3)))?
        .label("closed form")
        .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], BLACK.stroke_width(3)));
    for (name, trace) in traces {
        let color = mode_color(name);
        chart
            .draw_series(LineSeries::new(trace, color.stroke_width(width)))?
            .label(if name == "rapier" {
                "rapier alone".to_string()
            } else {
                format!("plugin, {name}")
            })
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], color));
    }
    chart
        .configure_series_labels()
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .position(position)
        .draw()?;
    Ok(())
}

/// The drop at dt = 1/60: analytic, rapier alone, the plugin in `toi` and `exact` modes.
fn plot_drop(traces: &[(&str, Vec<(f64, f64)>)], path: &Path) -> PlotResult {
    let root = SVGBackend::new(path, (1000, 420)).into_drawing_area();
    root.fill(&WHITE)?;
    let mut chart = ChartBuilder::on(&root)
        .caption(
            "drop at dt = 1/60 (f32): height of the ball's bottom, h0 = 1 m, e = 0.8",
            ("sans-serif", 18),
        )
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(50)
        .build_cartesian_2d(0.0..DROP_T, -0.02..1.05)?;
    chart
        .configure_mesh()
        .x_desc("t (s)")
        .y_desc("height (m)")
        .draw()?;
    let analytic: Vec<(f64, f64)> = (0..=3800)
        .map(|i| {
            let t = i as f64 * DROP_T / 3800.0;
            (t, drop_height(t))
        })
        .collect();
    draw_against_closed_form(
        &mut chart,
        analytic,
        traces.iter().map(|(name, trace)| (*name, trace.clone())),
        1,
        SeriesLabelPosition::UpperRight,
    )?;
    root.present()?;
    Ok(())
}

/// The slip case at dt = 1/60: `vx` and `w_z` against the chained closed form.
fn plot_spin(traces: &[(&str, SpinTrace)], path: &Path) -> PlotResult {
    let (mu, spin) = SPIN_CASES[1];
    let root = SVGBackend::new(path, (1100, 420)).into_drawing_area();
    root.fill(&WHITE)?;
    let panels = root.split_evenly((1, 2));
    type Pick = fn(&(f64, f64, f64)) -> f64;
    let specs: [(&str, Pick, usize); 2] = [("vx (m/s)", |p| p.1, 0), ("w_z (rad/s)", |p| p.2, 1)];
    for (panel, (label, pick, which)) in panels.iter().zip(specs) {
        let analytic: Vec<(f64, f64)> = (0..=1500)
            .map(|i| {
                let t = i as f64 * SPIN_T / 1500.0;
                let (vx, wz) = spin_closed(mu, spin, t);
                (t, if which == 0 { vx } else { wz })
            })
            .collect();
        let all = analytic
            .iter()
            .map(|p| p.1)
            .chain(traces.iter().flat_map(|(_, t)| t.iter().map(pick)));
        let (lo, hi) = all.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
            (a.min(v), b.max(v))
        });
        let pad = 0.08 * (hi - lo).max(1e-3);
        let mut chart = ChartBuilder::on(panel)
            .caption(
                format!("spin, slip case at dt = 1/60 (f32): {label}"),
                ("sans-serif", 16),
            )
            .margin(12)
            .x_label_area_size(40)
            .y_label_area_size(55)
            .build_cartesian_2d(0.0..SPIN_T, (lo - pad)..(hi + pad))?;
        chart
            .configure_mesh()
            .x_desc("t (s)")
            .y_desc(label)
            .draw()?;
        draw_against_closed_form(
            &mut chart,
            analytic,
            traces
                .iter()
                .map(|(name, trace)| (*name, trace.iter().map(|p| (p.0, pick(p))).collect())),
            2,
            SeriesLabelPosition::LowerRight,
        )?;
    }
    root.present()?;
    Ok(())
}

// ---------------------------------------------------------------------------------------------

/// CPU time of the whole process (s).
#[cfg(unix)]
fn process_cpu_seconds() -> f64 {
    let mut ts = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: `ts` is a valid, writable timespec; the clock id is a constant of the platform.
    let rc = unsafe { libc::clock_gettime(libc::CLOCK_PROCESS_CPUTIME_ID, &mut ts) };
    if rc == 0 {
        ts.tv_sec as f64 + ts.tv_nsec as f64 * 1e-9
    } else {
        f64::NAN
    }
}

#[cfg(not(unix))]
fn process_cpu_seconds() -> f64 {
    f64::NAN
}

/// The rows, after a first line `#cpu SECONDS` (the process's CPU time).
fn write_rows(rows: &[Row], path: &Path) {
    let text: String = std::iter::once(format!("#cpu\t{}\n", process_cpu_seconds()))
        .chain(rows.iter().map(|r| r.to_line() + "\n"))
        .collect();
    common::or_exit(
        std::fs::write(path, text),
        &format!("cannot write {}", path.display()),
    );
}

/// Runs the other precision's build of this example and reads its rows.
fn other_precision(rows_path: &Path) -> (Vec<Row>, f64) {
    // The crate's `target/` is not there when cargo builds elsewhere (`CARGO_TARGET_DIR`).
    if let Some(dir) = rows_path.parent() {
        common::or_exit(
            std::fs::create_dir_all(dir),
            &format!("cannot create {}", dir.display()),
        );
    }
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let mut cmd = std::process::Command::new(cargo);
    cmd.current_dir(env!("CARGO_MANIFEST_DIR"))
        .args(["run", "--release", "--quiet"]);
    if !cfg!(feature = "f64") {
        cmd.args(["--features", "f64"]);
    }
    cmd.args(["--example", "accuracy_sweep", "--", "--rows"])
        .arg(rows_path);
    eprintln!(
        "accuracy sweep: building and running the {} build",
        if cfg!(feature = "f64") { "f32" } else { "f64" }
    );
    let status = common::or_exit(cmd.status(), "cannot run cargo for the other precision");
    if !status.success() {
        eprintln!("the other precision's sweep failed ({status})");
        std::process::exit(1);
    }
    let text = common::or_exit(
        std::fs::read_to_string(rows_path),
        &format!("cannot read {}", rows_path.display()),
    );
    let cpu = text
        .lines()
        .find_map(|l| l.strip_prefix("#cpu\t"))
        .and_then(|c| c.parse().ok())
        .unwrap_or(f64::NAN);
    (text.lines().filter_map(Row::from_line).collect(), cpu)
}

/// Where the report and plots go: `--out`, `docs/` with `--write-docs`, else
/// `target/accuracy_sweep/`, so that a plain run never rewrites the committed report.
fn out_dir(args: &Args) -> PathBuf {
    let crate_dir = Path::new(env!("CARGO_MANIFEST_DIR"));
    match (&args.out, args.write_docs) {
        (Some(dir), _) => dir.clone(),
        (None, true) => crate_dir.join("docs"),
        (None, false) => crate_dir.join("target").join("accuracy_sweep"),
    }
}

/// The rows of this precision and, unless `--single`, of the other one, sorted for the
/// report; with the wall and CPU seconds each precision took.
fn all_rows(args: &Args, start: Instant) -> (Vec<Row>, BTreeMap<String, (f64, f64)>) {
    let mut rows = sweep();
    let mut secs = BTreeMap::new();
    secs.insert(
        common::PRECISION.to_string(),
        (start.elapsed().as_secs_f64(), process_cpu_seconds()),
    );
    if !args.single {
        let other_start = Instant::now();
        let tmp = Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("target")
            .join("accuracy_sweep_rows.tsv");
        let (other, cpu) = other_precision(&tmp);
        secs.insert(
            if cfg!(feature = "f64") { "f32" } else { "f64" }.to_string(),
            (other_start.elapsed().as_secs_f64(), cpu),
        );
        rows.extend(other);
    }
    rows.sort_by_key(|r| {
        (
            r.precision.clone(),
            MODES.iter().position(|m| m.name() == r.mode),
            r.law.clone(),
            DTS.iter().position(|d| d.1 == r.dt),
        )
    });
    (rows, secs)
}

/// Draws the three plots into `out` (the traces in this build's precision).
fn write_plots(rows: &[Row], out: &Path) {
    let at60 = DTS[1].0;
    let drop_traces: Vec<(&str, Vec<(f64, f64)>)> = [MODES[0], MODES[2], MODES[3]]
        .into_iter()
        .map(|m| (m.name(), run_drop(at60, m, Law::Guarded).trace))
        .collect();
    let spin_traces: Vec<(&str, SpinTrace)> = [MODES[0], MODES[2], MODES[3]]
        .into_iter()
        .map(|m| {
            (
                m.name(),
                run_spin(at60, m, Law::Guarded, SPIN_CASES[1]).trace,
            )
        })
        .collect();
    common::or_exit(
        std::fs::create_dir_all(out),
        "cannot create the output directory",
    );
    common::or_exit(
        plot_tradeoff(rows, &out.join("tradeoff.svg")),
        "cannot draw tradeoff.svg",
    );
    common::or_exit(
        plot_drop(&drop_traces, &out.join("drop_trace.svg")),
        "cannot draw drop_trace.svg",
    );
    common::or_exit(
        plot_spin(&spin_traces, &out.join("spin_trace.svg")),
        "cannot draw spin_trace.svg",
    );
}

fn main() {
    let args: Args = common::parse();
    let start = Instant::now();
    if let Some(path) = &args.rows {
        let rows = sweep();
        write_rows(&rows, path);
        return;
    }
    let out = out_dir(&args);
    let (rows, secs) = all_rows(&args, start);
    write_plots(&rows, &out);
    let total = start.elapsed().as_secs_f64();
    let text = report(&rows, &secs, total, args.single);
    print!("{text}");
    let md = out.join("accuracy.md");
    common::or_exit(std::fs::write(&md, &text), "cannot write accuracy.md");
    eprintln!(
        "accuracy sweep: {} runs in {total:.0} s; wrote {} and the plots",
        rows.len(),
        md.display()
    );
}
