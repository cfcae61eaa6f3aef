//! Oblique impacts of a small sphere on a plane, headless: the rebound angle, the tangential
//! coefficient of restitution and the spin after the impact against Walton's closed form,
//! one shot per incidence angle. The defaults are the experiment of Kharaz, Gorham & Salman
//! (Powder Technology 120, 2001): 5 mm alumina spheres at 3.9 m/s, `e = 0.98`, `mu = 0.092`.
//!
//! ```text
//! cargo run --release --example oblique
//! cargo run --release --example oblique -- --tangential-restitution 0.5 --svg oblique.svg
//! cargo run --release --example oblique -- --mode rapier --csv oblique.csv
//! ```
//!
//! Every flag has a default; `--help` lists them with their units.
//!
//! The scene: y up, ground a fixed half-space with normal +y and surface y = 0. Each angle
//! gets a fresh world; the ball starts 1.5 steps of normal travel above the ground with
//! velocity `(V sin(theta), -V cos(theta), 0)` and spin `(0, 0, W)`. Without gravity (the
//! default) the state after the impact's step is the state right after the impact.
//!
//! The closed form (Walton's tangential restitution), per unit mass, with `k = I/(m R^2)` (2/5
//! solid, 2/3 hollow), `vy` the downward speed and `u = vx + R w_z` the contact point's slip:
//! - normal impulse `pn = (1+e) vy`; sticking impulse `pt = -(1+beta0) u / (1 + 1/k)`;
//! - stick when `|pt| <= mu pn`, else slip: `pt = -mu pn sgn(u)`;
//! - after: `vx' = vx + pt`, `vy' = e vy` (up), `w_z' = w_z + pt/(k R)`.
//!
//! Measured as Kharaz et al. and Maw et al. do: the tangential coefficient of restitution
//! `beta = -u'/u` (contact point's slip after over before) and the rebound angle
//! `atan2(vx', vy')` from the normal. Without spin and with a constant `e`, stick turns to
//! slip at `tan(theta_c) = mu (1+e)(1 + 1/k)/(1+beta0)`.
//!
//! The CSV has one row per incidence: `incidence_deg,vx_in,vy_in,wz_in,vx_out,vy_out,wz_out`
//! (the centre's velocity and spin just before and just after the impact, vy_in < 0), then
//! `e,regime,vx_out_closed,vy_out_closed,wz_out_closed,regime_closed,rebound_deg,
//! rebound_deg_closed,beta,beta_closed`. The closed form is taken from the simulated state
//! before the impact. With `--svg PATH`, the three quantities against incidence for
//! `beta0 = 0` and the given `beta0` (the plugin) and for rapier alone, with the closed forms
//! as lines.

mod common;

use clap::Parser;
use common::{Mode, Shell, or_exit, real, regime_label, wide};
use plotters::prelude::*;
use rapier_impact::rapier::prelude::*;
use rapier_impact::{
    EventKind, GroundMaterial, ImpactConfig, ImpactPlugin, RestitutionCurve, TimingMode,
};
use std::io::Write;

/// A small sphere shot at a plane ground once per incidence angle: the rebound angle, the
/// tangential coefficient of restitution and the spin after the impact beside Walton's closed
/// form, and the angle where stick turns to slip. The defaults are Kharaz, Gorham & Salman's
/// experiment (2001): 5 mm alumina spheres at 3.9 m/s on glass.
#[derive(Parser, Debug)]
#[command(
    name = "oblique",
    after_help = "Example: cargo run --release --example oblique -- --tangential-restitution 0.4 --svg oblique.svg"
)]
struct Args {
    /// Launch speed: the impact speed without gravity (m/s)
    #[arg(long, value_name = "V", default_value = "3.9", value_parser = common::positive)]
    speed: f64,
    /// Incidence angles from the normal, 0 <= FROM <= TO < 90, STEP > 0 (deg)
    #[arg(long, value_name = "FROM:TO:STEP", default_value = "5:85:5", value_parser = parse_angles)]
    angles: Angles,
    /// Ball radius (m)
    #[arg(long, value_name = "R", default_value = "0.0025", value_parser = common::positive)]
    radius: f64,
    /// Solid ball or thin shell
    #[arg(long, value_enum, value_name = "SHELL", default_value_t = Shell::Solid)]
    shell: Shell,
    /// Coefficient of restitution
    #[arg(long, value_name = "E", default_value = "0.98", value_parser = common::non_negative)]
    restitution: f64,
    /// Restitution against the normal approach speed (m/s : e), piecewise linear; replaces
    /// --restitution [default: none]
    #[arg(long, value_name = "V:E,V:E,...", value_parser = parse_curve)]
    restitution_curve: Option<RestitutionCurve>,
    /// Coefficient of friction
    #[arg(long, value_name = "MU", default_value = "0.092", value_parser = common::non_negative)]
    friction: f64,
    /// Walton's tangential restitution beta0, in [-1, 1] (0 is Coulomb's stick)
    #[arg(long, value_name = "BETA0", default_value = "0", value_parser = common::number)]
    tangential_restitution: f64,
    /// Initial spin about +z (rad/s)
    #[arg(long, value_name = "W", default_value = "0", value_parser = common::number)]
    spin: f64,
    /// Gravity, downwards (m/s^2)
    #[arg(long, value_name = "G", default_value = "0", value_parser = common::non_negative)]
    gravity: f64,
    /// Rapier alone, or the plugin in one of its timing modes
    #[arg(long, value_enum, value_name = "MODE", default_value_t = Mode::EXACT)]
    mode: Mode,
    /// Time step (s)
    #[arg(long, value_name = "DT", default_value = "1/60", value_parser = common::positive)]
    dt: f64,
    /// Double precision: needs a build with `--features f64` (the precision is chosen at
    /// build time)
    #[arg(long)]
    f64: bool,
    /// Write incidence_deg,vx_in,vy_in,wz_in,vx_out,vy_out,wz_out,... per angle (m/s, rad/s,
    /// deg) [default: none]
    #[arg(long, value_name = "PATH")]
    csv: Option<String>,
    /// Plot beta0 = 0, the given beta0 (the plugin) and rapier alone against incidence (SVG)
    /// [default: none]
    #[arg(long, value_name = "PATH")]
    svg: Option<String>,
}

/// The incidence angles of `--angles` (deg), in order.
#[derive(Clone, Debug)]
struct Angles(Vec<f64>);

/// The ball's mass (kg). The closed form is per unit mass and neither the plugin nor rapier
/// depends on it: an alumina ball's 0.26 g gives the same velocities, to `f32` rounding.
const MASS: f64 = 1.0;
/// Launch gap between the ball's bottom and the ground, in steps of normal travel: the impact
/// falls inside the second step, away from a step boundary.
const LAUNCH_GAP_STEPS: f64 = 1.5;
/// Steps after which a shot that has not reached the ground is given up.
const MAX_STEPS: usize = 10_000;
/// Steps rapier alone is given, from its contact's first step, to send the ball up: its
/// contact can hold a ball for a step or two before it rises.
const REBOUND_WINDOW: usize = 120;

/// What the flags ask for.
struct Setup {
    speed: f64,
    angles: Vec<f64>,
    radius: f64,
    shell: Shell,
    /// `I / (m R^2)`.
    k: f64,
    restitution: f64,
    curve: Option<RestitutionCurve>,
    friction: f64,
    beta0: f64,
    spin: f64,
    /// Downwards, m/s^2.
    gravity: f64,
    dt: f64,
    mode: Mode,
}

impl Setup {
    /// The coefficient of restitution at the normal approach speed `vy` (> 0).
    fn e_at(&self, vy: f64) -> f64 {
        self.curve.as_ref().map_or(self.restitution, |c| c.at(vy))
    }

    /// The plugin's ground material for tangential restitution `beta0`.
    fn material(&self, beta0: f64) -> GroundMaterial {
        let m =
            GroundMaterial::new(self.restitution, self.friction).with_tangential_restitution(beta0);
        match &self.curve {
            Some(c) => m.with_restitution_curve(c.clone()),
            None => m,
        }
    }

    /// The launch velocity `(vx, vy)` (vy < 0) and gap (m) of the shot at `incidence` (deg).
    fn launch(&self, incidence: f64) -> (f64, f64, f64) {
        let (s, c) = incidence.to_radians().sin_cos();
        let vy = self.speed * c;
        (self.speed * s, -vy, LAUNCH_GAP_STEPS * vy * self.dt)
    }

    /// The state at first contact in exact free flight from the launch of `incidence`.
    fn incoming(&self, incidence: f64) -> State {
        let (vx, vy, gap) = self.launch(incidence);
        State {
            vx,
            vy: -(vy * vy + 2.0 * self.gravity * gap).sqrt(),
            wz: self.spin,
        }
    }
}

/// The centre's velocity and the spin about +z (y up, so `vy < 0` is downwards).
#[derive(Clone, Copy, Debug)]
struct State {
    vx: f64,
    vy: f64,
    wz: f64,
}

impl State {
    fn of(world: &PhysicsWorld, ball: RigidBodyHandle) -> Self {
        let rb = &world.bodies[ball];
        Self {
            vx: wide(rb.linvel().x),
            vy: wide(rb.linvel().y),
            wz: wide(rb.angvel().z),
        }
    }

    /// The contact point's slip along +x, `vx + R w_z`.
    fn slip(self, radius: f64) -> f64 {
        self.vx + radius * self.wz
    }

    /// The largest difference from `other` in m/s, the spin counted at the rim (`R w_z`).
    fn distance(self, other: State, radius: f64) -> f64 {
        (self.vx - other.vx)
            .abs()
            .max((self.vy - other.vy).abs())
            .max(radius * (self.wz - other.wz).abs())
    }
}

/// Walton's closed form from the state before the impact.
#[derive(Clone, Copy, Debug)]
struct Closed {
    out: State,
    stick: bool,
    /// The coefficient of restitution used (the curve's at this approach speed).
    e: f64,
}

fn closed_form(setup: &Setup, beta0: f64, vin: State) -> Closed {
    let (k, r) = (setup.k, setup.radius);
    let vy = -vin.vy;
    let e = setup.e_at(vy);
    let u = vin.slip(r);
    let pn = (1.0 + e) * vy;
    // K_tt = (1/m)(1 + 1/k): the tangential compliance of the contact point.
    let stick_pt = -(1.0 + beta0) * u / (1.0 + 1.0 / k);
    let stick = stick_pt.abs() <= setup.friction * pn;
    let pt = if stick {
        stick_pt
    } else {
        -setup.friction * pn * u.signum()
    };
    Closed {
        out: State {
            vx: vin.vx + pt,
            vy: e * vy,
            wz: vin.wz + pt / (k * r),
        },
        stick,
        e,
    }
}

/// Rebound angle from the normal (deg).
fn rebound_angle(out: State) -> f64 {
    out.vx.atan2(out.vy).to_degrees()
}

/// Tangential coefficient of restitution `-u'/u` (NaN when the ball arrives without slip).
fn tangential_cor(vin: State, out: State, radius: f64) -> f64 {
    let u = vin.slip(radius);
    if u == 0.0 {
        f64::NAN
    } else {
        // `+ 0.0` turns the -0 of an exact stick into 0 (in the CSV).
        -out.slip(radius) / u + 0.0
    }
}

/// One shot: the simulated states around the impact and the closed form from `vin`.
struct Shot {
    incidence: f64,
    vin: State,
    vout: State,
    /// The plugin's regime label; for rapier alone `rapier`, or `no_rebound` when rapier kept
    /// the ball on the ground.
    label: String,
    closed: Closed,
}

/// A fresh world with the ball of `setup` launched at `incidence`; rapier's restitution on
/// both colliders is `e_rapier` (rapier averages the two, so this is the contact's).
fn scene(
    setup: &Setup,
    incidence: f64,
    e_rapier: f64,
) -> (PhysicsWorld, RigidBodyHandle, ColliderHandle) {
    let mut world = common::world(setup.dt);
    world.gravity = Vector::new(0.0, real(-setup.gravity), 0.0);
    // Rapier's length unit stays 1 m although a 2.5 mm ball is smaller than its allowed linear
    // error (5 mm): with soft CCD (below) every mode gives the same velocities at 0.1 and
    // 0.025; without soft CCD a smaller unit shrinks rapier's speculative margin, so the ball
    // passes through the ground at every angle; and rapier caps linear speeds at 400 units/s
    // (4 m/s at 0.01, which clips a 3.9 m/s ball under gravity).
    let ground = common::ground(&mut world, e_rapier, setup.friction);
    let (vx, vy, gap) = setup.launch(incidence);
    let r = setup.radius;
    // Two steps of travel at the launch speed: gravity adds little over the launch gap.
    let soft_ccd = 2.0 * setup.speed * setup.dt;
    let (ball, _) = world.insert(
        RigidBodyBuilder::dynamic()
            .translation(Vector::new(0.0, real(r + gap), 0.0))
            .linvel(Vector::new(real(vx), real(vy), 0.0))
            .angvel(Vector::new(0.0, 0.0, real(setup.spin)))
            // Rapier caps the angular speed at pi/4 rad per step (47 rad/s at 60 Hz)
            // otherwise; a 2.5 mm ball at 3.9 m/s leaves spinning at over 1000 rad/s.
            .allow_fast_rotation(true)
            .can_sleep(false)
            // Rapier sees a contact only within its prediction distance (2 cm), and its CCD
            // does not sweep against a half-space: a ball moving a step's 6.5 cm (3.9 m/s,
            // 60 Hz) would pass whole through the surface and be pushed back out from beneath
            // (with spin of the wrong sign). Soft CCD lets rapier's contact look a step ahead.
            // The plugin finds its impacts itself: its results are the same without it.
            .soft_ccd_prediction(real(soft_ccd)),
        ColliderBuilder::ball(real(r))
            .mass_properties(MassProperties::new(
                Vector::ZERO,
                real(MASS),
                Vector::splat(real(setup.k * MASS * r * r)),
            ))
            .restitution(real(e_rapier))
            .friction(real(setup.friction)),
    );
    (world, ball, ground)
}

/// A shot with the plugin: steps until it reports the ball's impact, then takes the state
/// before the impact from the step start (the approach speed from the event: with gravity
/// the ball gained speed in the step) and the state after from the step end, less the
/// gravity of the rest of the step. `None` when no impact comes within [`MAX_STEPS`].
fn shoot_plugin(
    setup: &Setup,
    timing: TimingMode,
    beta0: f64,
    incidence: f64,
) -> Result<Option<Shot>, String> {
    let (mut world, ball, ground) = scene(setup, incidence, setup.restitution);
    let mut config = ImpactConfig::default();
    config.timing = timing;
    let mut plugin = ImpactPlugin::new(config).map_err(|e| e.to_string())?;
    plugin
        .add_ground_with_material(
            &world.bodies,
            &world.colliders,
            ground,
            setup.material(beta0),
        )
        .map_err(|e| e.to_string())?;
    for _ in 0..MAX_STEPS {
        let before = State::of(&world, ball);
        plugin.step(&mut world);
        let events = plugin.events();
        let Some(ev) = events
            .iter()
            .find(|e| e.kind == EventKind::Impact && e.body == ball)
        else {
            continue;
        };
        let mut label = regime_label(ev);
        if events.iter().filter(|e| e.body == ball).count() > 1 {
            // Not expected for a lone ball: flag the row rather than hide it.
            label += "+more_events";
        }
        let after = State::of(&world, ball);
        let rest = setup.dt - ev.time;
        let vin = State {
            vy: -ev.approach_speed,
            ..before
        };
        let vout = State {
            vy: after.vy + setup.gravity * rest,
            ..after
        };
        let closed = closed_form(setup, beta0, vin);
        return Ok(Some(Shot {
            incidence,
            vin,
            vout,
            label,
            closed,
        }));
    }
    Ok(None)
}

/// A shot with rapier alone, its restitution the curve's at this shot's approach speed. The
/// state before the impact is the one at the start of the first step whose end is not free
/// flight; the state after is the first that moves up with the ball's bottom above the
/// ground (rapier's contact skin is zero), as rapier's contact may take more than one step.
/// A ball that does not rise within [`REBOUND_WINDOW`] steps of the contact is reported
/// `no_rebound`, with the state after the contact's first step.
fn shoot_rapier(setup: &Setup, incidence: f64) -> Shot {
    let e = setup.e_at(-setup.incoming(incidence).vy);
    let (mut world, ball, _) = scene(setup, incidence, e);
    let (dt, g, r) = (setup.dt, setup.gravity, setup.radius);
    // The state before the contact, the state after its first step, and that step.
    let mut contact: Option<(State, State, usize)> = None;
    for n in 0..MAX_STEPS {
        let before = State::of(&world, ball);
        world.step();
        let after = State::of(&world, ball);
        let free = State {
            vy: before.vy - g * dt,
            ..before
        };
        // A change beyond rounding is the contact's.
        if contact.is_none() && after.distance(free, r) > 1e-5 * setup.speed {
            contact = Some((before, after, n));
        }
        let Some((vin, first, n0)) = contact else {
            continue;
        };
        let bottom = wide(world.bodies[ball].center_of_mass().y) - r;
        let (vout, label) = if after.vy > 0.0 && bottom > 0.0 {
            (after, "rapier")
        } else if n - n0 >= REBOUND_WINDOW {
            (first, "no_rebound")
        } else {
            continue;
        };
        return Shot {
            incidence,
            vin,
            vout,
            label: label.into(),
            closed: closed_form(setup, 0.0, vin),
        };
    }
    // Never touched (not expected: the ball is launched at the ground).
    let vin = setup.incoming(incidence);
    Shot {
        incidence,
        vin,
        vout: State::of(&world, ball),
        label: "no_contact".into(),
        closed: closed_form(setup, 0.0, vin),
    }
}

/// Why a shot with the plugin is left out: no impact within [`MAX_STEPS`].
const NO_IMPACT: &str = "a contact approaching no faster than the plugin's resting speed, \
                         ImpactConfig::resting_speed, is a resting contact, not an impact";

/// Every angle of `setup` in `mode` with tangential restitution `beta0` (rapier alone has
/// none of its own: its closed form is `beta0 = 0`'s). An incidence with no impact (a slow
/// approach is a resting contact) is left out, and named on stderr after `series` where that
/// is given (`None`: a run another one reported). `Err` when no incidence had an impact, or
/// the plugin refused the setup.
fn run(setup: &Setup, mode: Mode, beta0: f64, series: Option<&str>) -> Result<Vec<Shot>, String> {
    let mut shots = Vec::new();
    let mut missed = Vec::new();
    for &a in &setup.angles {
        match mode {
            Mode::Rapier => shots.push(shoot_rapier(setup, a)),
            Mode::Plugin(t) => match shoot_plugin(setup, t, beta0, a)? {
                Some(shot) => shots.push(shot),
                None => missed.push(a),
            },
        }
    }
    let why = format!("within {MAX_STEPS} steps ({NO_IMPACT})");
    if shots.is_empty() {
        return Err(format!("no impact at any incidence {why}"));
    }
    if let Some(series) = series {
        for a in missed {
            eprintln!("oblique: {series}: no impact at incidence {a} deg {why}: left out");
        }
    }
    Ok(shots)
}

/// The incidences in `[0, 90)` deg where the closed form's regime changes, each with `true`
/// when stick turns to slip there: a scan at 0.05 deg, then bisection to 1e-10 deg.
fn regime_changes(setup: &Setup, beta0: f64) -> Vec<(f64, bool)> {
    let stick = |a: f64| closed_form(setup, beta0, setup.incoming(a)).stick;
    let n = 1800;
    let top = 89.999;
    let mut changes = Vec::new();
    let mut prev = (0.0, stick(0.0));
    for i in 1..=n {
        let a = top * i as f64 / n as f64;
        let s = stick(a);
        if s != prev.1 {
            let (mut lo, mut hi) = (prev.0, a);
            while hi - lo > 1e-10 {
                let mid = 0.5 * (lo + hi);
                if stick(mid) == prev.1 {
                    lo = mid;
                } else {
                    hi = mid;
                }
            }
            changes.push((0.5 * (lo + hi), prev.1));
        }
        prev = (a, s);
    }
    changes
}

/// Parses `--angles FROM:TO:STEP`: `0 <= FROM <= TO < 90`, `STEP > 0`.
fn parse_angles(text: &str) -> Result<Angles, String> {
    let parts: Vec<Option<f64>> = text
        .split(':')
        .map(|p| p.trim().parse::<f64>().ok().filter(|x| x.is_finite()))
        .collect();
    let [Some(from), Some(to), Some(step)] = parts[..] else {
        return Err("not FROM:TO:STEP (degrees)".into());
    };
    if !(0.0..90.0).contains(&from) || !(from..90.0).contains(&to) || step <= 0.0 {
        return Err("needs 0 <= FROM <= TO < 90 and STEP > 0".into());
    }
    let count = ((to - from) / step + 1e-9).floor() + 1.0;
    if count > 10_000.0 {
        return Err(format!("gives {count} angles (at most 10000)"));
    }
    Ok(Angles(
        (0..count as usize)
            .map(|i| from + step * i as f64)
            .collect(),
    ))
}

/// Parses `--restitution-curve V:E,V:E,...`.
fn parse_curve(text: &str) -> Result<RestitutionCurve, String> {
    let points: Option<Vec<(f64, f64)>> = text
        .split(',')
        .map(|p| {
            let (v, e) = p.split_once(':')?;
            Some((v.trim().parse().ok()?, e.trim().parse().ok()?))
        })
        .collect();
    let points = points.ok_or("not V:E,V:E,... (m/s : restitution)")?;
    RestitutionCurve::new(points).map_err(|e| e.to_string())
}

/// The run the flags ask for; exits with the plugin's message when its ranges (e, mu, beta0,
/// the curve's e) refuse a value.
fn setup(args: &Args) -> Setup {
    common::check_precision::<Args>(args.f64);
    let setup = Setup {
        speed: args.speed,
        angles: args.angles.0.clone(),
        radius: args.radius,
        shell: args.shell,
        k: args.shell.inertia_ratio(),
        restitution: args.restitution,
        curve: args.restitution_curve.clone(),
        friction: args.friction,
        beta0: args.tangential_restitution,
        spin: args.spin,
        gravity: args.gravity,
        dt: args.dt,
        mode: args.mode,
    };
    if let Err(e) = setup.material(setup.beta0).validate() {
        common::fail::<Args>(e);
    }
    setup
}

/// A number for the table, `-` for NaN.
fn cell(x: f64, decimals: usize, width: usize) -> String {
    if x.is_nan() {
        return format!("{:>width$}", "-");
    }
    // A rounding-level negative (a closed-form beta of -0.0) prints as 0, not -0.
    let x = if x.abs() < 0.5 * 10f64.powi(-(decimals as i32)) {
        0.0
    } else {
        x
    };
    format!("{x:>width$.decimals$}")
}

fn regime_name(stick: bool) -> &'static str {
    if stick { "stick" } else { "slip" }
}

/// The table: per incidence, the simulated value beside the closed form's, for the rebound
/// angle, the tangential coefficient of restitution and the spin after; then the regime of
/// the closed form and the one the simulation reports.
fn print_table(setup: &Setup, shots: &[Shot]) {
    println!(
        "incidence |  rebound angle (deg) | tangential COR -u'/u | spin after w_z' (rad/s) |     regime"
    );
    println!(
        "    (deg) | simulated     closed | simulated     closed |   simulated      closed | closed simulated"
    );
    let r = setup.radius;
    for s in shots {
        let c = &s.closed;
        println!(
            "{} | {} {} | {} {} | {} {} | {:>6} {}",
            cell(s.incidence, 2, 9),
            cell(rebound_angle(s.vout), 4, 9),
            cell(rebound_angle(c.out), 4, 10),
            cell(tangential_cor(s.vin, s.vout, r), 5, 9),
            cell(tangential_cor(s.vin, c.out, r), 5, 10),
            cell(s.vout.wz, 3, 11),
            cell(c.out.wz, 3, 11),
            regime_name(c.stick),
            s.label
        );
    }
}

/// The line on where stick turns to slip, and the worst deviation of the run.
fn print_summary(setup: &Setup, shots: &[Shot]) {
    let changes = regime_changes(setup, setup.beta0);
    let formula = setup.spin == 0.0 && setup.curve.is_none() && setup.gravity == 0.0;
    let mut how = if formula {
        "closed form: tan(theta_c) = mu (1+e)(1 + 1/k)/(1+beta0)"
    } else {
        "closed form, by bisection"
    }
    .to_string();
    if setup.gravity > 0.0 {
        // The table's angles are the launch's too; gravity steepens the path before contact.
        how += "; incidence at launch";
    }
    if changes.is_empty() {
        let all = regime_name(closed_form(setup, setup.beta0, setup.incoming(45.0)).stick);
        println!("no change of regime between 0 and 90 deg: {all} throughout ({how})");
    }
    for (angle, from_stick) in changes {
        let (a, b) = if from_stick {
            ("stick", "slip")
        } else {
            ("slip", "stick")
        };
        println!("{a} turns to {b} at {angle:.4} deg incidence ({how})");
    }
    let worst = shots
        .iter()
        .map(|s| (s.vout.distance(s.closed.out, setup.radius), s.incidence))
        .fold((0.0, f64::NAN), |w, x| {
            if x.0 > w.0 || w.1.is_nan() { x } else { w }
        });
    println!(
        "worst deviation from the closed form: {:.2e} of the speed (largest of |dvx'|, |dvy'|, \
         R |dw_z'|, at {} deg)",
        worst.0 / setup.speed,
        worst.1
    );
}

fn write_csv(path: &str, setup: &Setup, shots: &[Shot]) {
    let mut out = std::io::BufWriter::new(or_exit(
        std::fs::File::create(path),
        &format!("cannot create {path}"),
    ));
    let mut text = String::from(
        "incidence_deg,vx_in,vy_in,wz_in,vx_out,vy_out,wz_out,e,regime,vx_out_closed,\
         vy_out_closed,wz_out_closed,regime_closed,rebound_deg,rebound_deg_closed,beta,\
         beta_closed\n",
    );
    let r = setup.radius;
    for s in shots {
        let (i, o, c) = (s.vin, s.vout, s.closed);
        text += &format!(
            "{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{}\n",
            s.incidence,
            i.vx,
            i.vy,
            i.wz,
            o.vx,
            o.vy,
            o.wz,
            c.e,
            s.label,
            c.out.vx,
            c.out.vy,
            c.out.wz,
            regime_name(c.stick),
            rebound_angle(o),
            rebound_angle(c.out),
            tangential_cor(i, o, r),
            tangential_cor(i, c.out, r)
        );
    }
    or_exit(
        out.write_all(text.as_bytes()).and_then(|_| out.flush()),
        &format!("cannot write {path}"),
    );
}

// ---------------------------------------------------------------------------------------------
// Plot

type PlotResult = Result<(), Box<dyn std::error::Error>>;
type Area<'a> = DrawingArea<SVGBackend<'a>, plotters::coord::Shift>;

/// One simulated series of the plot.
struct Series {
    name: String,
    color: RGBColor,
    shots: Vec<Shot>,
    /// Tangential restitution of its closed-form line, if it has one of its own.
    closed_beta0: Option<f64>,
}

/// The three configurations of the plot: the plugin with `beta0 = 0` and with the given
/// `beta0` (in `--mode`'s timing, `exact` for `--mode rapier`), and rapier alone.
fn plot_series(setup: &Setup) -> Result<Vec<Series>, String> {
    let timing = match setup.mode {
        Mode::Plugin(t) => t,
        Mode::Rapier => TimingMode::Exact,
    };
    let name = Mode::Plugin(timing).name();
    // What a run leaves out is named once: the table's run is the second series in a plugin
    // mode, and the first series is the second when beta0 is 0.
    let table_ran = setup.mode != Mode::Rapier;
    let first = (!(table_ran && setup.beta0 == 0.0)).then_some("plot, beta0 = 0");
    let second = (!table_ran && setup.beta0 != 0.0).then_some("plot");
    Ok(vec![
        Series {
            name: format!("plugin ({name}), beta0 = 0"),
            color: RGBColor(30, 110, 200),
            shots: run(setup, Mode::Plugin(timing), 0.0, first)?,
            closed_beta0: Some(0.0),
        },
        Series {
            name: format!("plugin ({name}), beta0 = {}", setup.beta0),
            color: RGBColor(200, 30, 30),
            shots: run(setup, Mode::Plugin(timing), setup.beta0, second)?,
            closed_beta0: Some(setup.beta0),
        },
        Series {
            name: "rapier alone (its closed form: beta0 = 0)".into(),
            color: RGBColor(20, 150, 60),
            shots: run(setup, Mode::Rapier, 0.0, None)?,
            closed_beta0: None,
        },
    ])
}

/// What a panel shows, from the state before and after, and its tick decimals.
type Quantity = fn(State, State, f64) -> f64;

fn plot(path: &str, setup: &Setup, title: &str) -> PlotResult {
    let series = plot_series(setup)?;
    let root = SVGBackend::new(path, (1500, 560)).into_drawing_area();
    root.fill(&WHITE)?;
    let (top, bottom) = root.split_vertically(80);
    plot_legend(&top, &series, title)?;
    let panels = bottom.split_evenly((1, 3));
    let quantities: [(&str, Quantity, usize); 3] = [
        (
            "rebound angle from the normal (deg)",
            |_, o, _| rebound_angle(o),
            0,
        ),
        ("tangential COR -u'/u", tangential_cor, 1),
        ("spin after, w_z' (rad/s)", |_, o, _| o.wz, 0),
    ];
    let (lo, hi) = (setup.angles[0], *setup.angles.last().unwrap());
    // A single angle still gets an axis of some width.
    let range = if hi > lo {
        (lo, hi)
    } else {
        ((lo - 1.0).max(0.0), hi + 1.0)
    };
    for (panel, (label, q, decimals)) in panels.iter().zip(quantities) {
        plot_panel(panel, setup, &series, (label, q, decimals), range)?;
    }
    root.present()?;
    Ok(())
}

/// The marker of series `i`, at `at` (pixels) in `area`: different shapes, so that series
/// that coincide stay visible.
fn marker(area: &Area, i: usize, at: (i32, i32), color: RGBColor) -> PlotResult {
    match i {
        0 => area.draw(&Circle::new(at, 4, color.filled()))?,
        1 => area.draw(&Cross::new(at, 5, color.stroke_width(2)))?,
        _ => area.draw(&TriangleMarker::new(at, 5, color.filled()))?,
    }
    Ok(())
}

/// The title and one legend for the three panels, above them.
fn plot_legend(top: &Area, series: &[Series], title: &str) -> PlotResult {
    top.draw(&Text::new(title.to_string(), (20, 10), ("sans-serif", 16)))?;
    let font = ("sans-serif", 14);
    for (i, s) in series.iter().enumerate() {
        let x = 20 + 480 * i as i32;
        marker(top, i, (x + 9, 44), s.color)?;
        top.draw(&Text::new(s.name.clone(), (x + 24, 37), font))?;
        if let Some(b) = s.closed_beta0 {
            let style = s.color.mix(0.6).stroke_width(1);
            top.draw(&PathElement::new(vec![(x, 64), (x + 18, 64)], style))?;
            top.draw(&Text::new(
                format!("closed form, beta0 = {b}"),
                (x + 24, 57),
                font,
            ))?;
        }
    }
    Ok(())
}

/// The closed form of `q` along the incidence range, from the exact incoming state.
fn closed_line(setup: &Setup, beta0: f64, q: Quantity, range: (f64, f64)) -> Vec<(f64, f64)> {
    (0..=400)
        .map(|i| range.0 + (range.1 - range.0) * i as f64 / 400.0)
        .filter(|&a| a < 90.0)
        .map(|a| {
            let vin = setup.incoming(a);
            (a, q(vin, closed_form(setup, beta0, vin).out, setup.radius))
        })
        .filter(|p| p.1.is_finite())
        .collect()
}

fn plot_panel(
    panel: &Area,
    setup: &Setup,
    series: &[Series],
    (label, q, decimals): (&str, Quantity, usize),
    range: (f64, f64),
) -> PlotResult {
    let r = setup.radius;
    let lines: Vec<(RGBColor, Vec<(f64, f64)>)> = series
        .iter()
        .filter_map(|s| Some((s.color, closed_line(setup, s.closed_beta0?, q, range))))
        .collect();
    let points: Vec<(RGBColor, Vec<(f64, f64)>)> = series
        .iter()
        .map(|s| {
            let pts = s.shots.iter().map(|x| (x.incidence, q(x.vin, x.vout, r)));
            (s.color, pts.filter(|p| p.1.is_finite()).collect())
        })
        .collect();
    let ys = lines
        .iter()
        .chain(&points)
        .flat_map(|(_, v)| v.iter().map(|p| p.1));
    let (ymin, ymax) = ys.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), y| {
        (a.min(y), b.max(y))
    });
    // Every value NaN (a single normal shot's COR): any axis will do.
    let (ymin, ymax) = if ymin <= ymax {
        (ymin, ymax)
    } else {
        (0.0, 1.0)
    };
    let pad = 0.05 * (ymax - ymin).max(1e-9);
    let mut chart = ChartBuilder::on(panel)
        .caption(label, ("sans-serif", 18))
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(60)
        .build_cartesian_2d(range.0..range.1, (ymin - pad)..(ymax + pad))?;
    chart
        .configure_mesh()
        .x_desc("incidence from the normal (deg)")
        .y_label_formatter(&|y| cell(*y, decimals, 0))
        .x_label_formatter(&|x| cell(*x, 0, 0))
        .draw()?;
    for (color, line) in lines {
        chart.draw_series(LineSeries::new(line, color.mix(0.6).stroke_width(1)))?;
    }
    // The markers are drawn in pixels, relative to the plotting area's corner.
    let area = chart.plotting_area();
    let (pixels, base) = (area.strip_coord_spec(), area.get_base_pixel());
    for (i, (color, pts)) in points.into_iter().enumerate() {
        for p in pts {
            let (x, y) = area.map_coordinate(&p);
            marker(&pixels, i, (x - base.0, y - base.1), color)?;
        }
    }
    Ok(())
}

// ---------------------------------------------------------------------------------------------

/// The parameters of the run, for the printed header and the plot's title.
fn describe(setup: &Setup) -> String {
    let e = match &setup.curve {
        Some(c) => format!("e = curve {:?}", c.points()),
        None => format!("e = {}", setup.restitution),
    };
    format!(
        "V = {} m/s, R = {} m, {} sphere (k = {:.4}), {e}, mu = {}, beta0 = {}, spin = {} rad/s, \
         g = {} m/s^2, dt = {:.7} s",
        setup.speed,
        setup.radius,
        setup.shell.name(),
        setup.k,
        setup.friction,
        setup.beta0,
        setup.spin,
        setup.gravity,
        setup.dt,
    )
}

fn main() {
    let args: Args = common::parse();
    let setup = setup(&args);
    let shots = or_exit(
        run(&setup, setup.mode, setup.beta0, Some("table")),
        "oblique",
    );
    let about = describe(&setup);
    println!(
        "oblique: {about}, mode = {}, precision = {}",
        setup.mode.name(),
        common::PRECISION
    );
    print_table(&setup, &shots);
    print_summary(&setup, &shots);
    if let Some(path) = &args.csv {
        write_csv(path, &setup, &shots);
    }
    if let Some(path) = &args.svg {
        let title = format!("oblique impacts: {about} ({})", common::PRECISION);
        or_exit(plot(path, &setup, &title), &format!("cannot plot {path}"));
    }
}
