//! Code shared by the example scenes (`mod common;` in each): the command-line values they
//! share (numbers such as `1/60`, the `--mode`, `--law` and `--shell` choices, the `--f64`
//! check, the flags `roll`, `drop` and `spin` all take), the scene's ground, the plugin, one
//! step with or without it, the dice throw, the CSV trace and events writers, and a seeded
//! random number generator.
//!
//! Conventions of every scene: y up, ground surface at y = 0, rapier's default gravity.
#![allow(dead_code)] // each example uses a part of this module

use clap::builder::PossibleValue;
use clap::error::ErrorKind;
use clap::{CommandFactory, Parser, ValueEnum};
use rapier_impact::model::{Fallback, Law, Regime};
use rapier_impact::rapier::prelude::*;
use rapier_impact::{GroundMaterial, ImpactConfig, ImpactEvent, ImpactPlugin, TimingMode};
use std::fs::File;
use std::io::{BufWriter, Write};

/// `"f64"` in a build with the `f64` feature, else `"f32"`.
pub const PRECISION: &str = if cfg!(feature = "f64") { "f64" } else { "f32" };

/// An `f64` as rapier's scalar (rounded in the `f32` build).
#[allow(clippy::unnecessary_cast)]
pub fn real(x: f64) -> Real {
    x as Real
}

/// A rapier scalar as `f64` (exact).
#[allow(clippy::unnecessary_cast)]
pub fn wide(x: Real) -> f64 {
    x as f64
}

// ---------------------------------------------------------------------------------------------
// Command-line values (parsers for clap's `value_parser`, value enums, checks)

/// A finite number, finite in the build's precision too: the scenes hand their values to
/// rapier as `Real`, where in the `f32` build `1e300` is infinite. `1/60` style fractions are
/// accepted too, so that a time step can be given exactly as users think of it.
pub fn number(text: &str) -> Result<f64, String> {
    let parsed = match text.split_once('/') {
        Some((a, b)) => match (a.trim().parse::<f64>(), b.trim().parse::<f64>()) {
            (Ok(a), Ok(b)) => Some(a / b),
            _ => None,
        },
        None => text.parse::<f64>().ok(),
    };
    let x = parsed
        .filter(|x| x.is_finite())
        .ok_or_else(|| "not a finite number (a fraction such as 1/60 is accepted)".to_string())?;
    if real(x).is_finite() {
        Ok(x)
    } else {
        Err(format!(
            "infinite in this build's precision, {PRECISION} (the largest is {:e}; the f64 \
             build, --features f64, takes larger numbers)",
            Real::MAX
        ))
    }
}

/// A finite number `> 0`, and not zero in the build's precision.
pub fn positive(text: &str) -> Result<f64, String> {
    let x = number(text)?;
    if x <= 0.0 {
        Err(format!("must be > 0, got {x}"))
    } else if real(x) == 0.0 {
        // A time step of zero would never end a run.
        Err(format!(
            "zero in this build's precision, {PRECISION} (the smallest is {:e})",
            Real::from_bits(1)
        ))
    } else {
        Ok(x)
    }
}

/// A finite number `>= 0`.
pub fn non_negative(text: &str) -> Result<f64, String> {
    let x = number(text)?;
    if x >= 0.0 {
        Ok(x)
    } else {
        Err(format!("must be >= 0, got {x}"))
    }
}

/// A whole number `>= min`.
pub fn whole(text: &str, min: u64) -> Result<u64, String> {
    match text.parse::<u64>() {
        Ok(n) if n >= min => Ok(n),
        _ => Err(format!("not a whole number >= {min}")),
    }
}

/// An angle in degrees, in `[0, max)`.
pub fn degrees_below(text: &str, max: f64) -> Result<f64, String> {
    let x = number(text)?;
    if (0.0..max).contains(&x) {
        Ok(x)
    } else {
        Err(format!("must be in [0, {max}) degrees, got {x}"))
    }
}

/// The scene's flags from the process arguments; exits on `--help` (status 0) or on a bad
/// command line (status 2). Every option takes the next word as its value even when it starts
/// with `-`, so that negative numbers (`--spin -30`, `--spin -1/2`) read as they always did.
pub fn parse<P: Parser>() -> P {
    let command = P::command().mut_args(|arg| {
        if arg.get_action().takes_values() {
            arg.allow_hyphen_values(true)
        } else {
            arg
        }
    });
    let mut matches = command.get_matches();
    P::from_arg_matches_mut(&mut matches).unwrap_or_else(|e| e.exit())
}

/// Exits as clap does on a bad command line (the message, the usage, status 2), for what one
/// value's parser cannot see: a value against another, or the plugin's own ranges.
pub fn fail<C: CommandFactory>(message: impl std::fmt::Display) -> ! {
    C::command()
        .error(ErrorKind::ValueValidation, message)
        .exit()
}

/// A collider coefficient set by a flag, as the plugin ranges it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Coefficient {
    /// A restitution, as a ground material ranges it.
    Restitution,
    /// A friction, as a ground material ranges it.
    Friction,
}

/// In a plugin mode, exits as on a bad command line (status 2) when a flag's coefficient is
/// outside the plugin's range: the plugin would leave every contact of such a collider to
/// rapier (reporting only a diagnostic), and the scene would print rapier's result under the
/// plugin's mode. Rapier alone (`--mode rapier`) takes any value. `flags`: the flag, what it
/// sets, its value.
pub fn check_coefficients<C: CommandFactory>(mode: Mode, flags: &[(&str, Coefficient, f64)]) {
    if mode == Mode::Rapier {
        return;
    }
    for &(flag, coefficient, value) in flags {
        // The plugin checks a collider's coefficient against a ground material's ranges, on
        // the value the collider holds: the flag's, rounded to `Real`.
        let held = wide(real(value));
        let material = match coefficient {
            Coefficient::Restitution => GroundMaterial::new(held, 0.0),
            Coefficient::Friction => GroundMaterial::new(0.0, held),
        };
        if let Err(e) = material.validate() {
            out_of_range::<C>(flag, value, e);
        }
    }
}

/// [`check_coefficients`] of a scene's `--restitution` and `--friction`.
pub fn check_material<C: CommandFactory>(mode: Mode, restitution: f64, friction: f64) {
    check_coefficients::<C>(
        mode,
        &[
            ("--restitution", Coefficient::Restitution, restitution),
            ("--friction", Coefficient::Friction, friction),
        ],
    );
}

/// Exits as on a bad command line (status 2): the flag's value is outside the plugin's range,
/// as its check `error` says.
pub fn out_of_range<C: CommandFactory>(flag: &str, value: f64, error: impl std::fmt::Display) -> ! {
    fail::<C>(format!(
        "{flag} {value} is outside the plugin's range ({error}); --mode rapier takes it"
    ))
}

/// `--f64`: the precision is chosen at build time, so in an `f32` build the switch is refused
/// with the command that works (status 2).
pub fn check_precision<C: CommandFactory>(f64: bool) {
    if f64 && !cfg!(feature = "f64") {
        let mut command = C::command();
        let message = format!(
            "`--f64` needs the f64 build: cargo run --release --features f64 --example {} -- --f64 ...",
            command.get_name()
        );
        command.error(ErrorKind::ArgumentConflict, message).exit();
    }
}

/// The flags `roll`, `drop` and `spin` share, the same in name, default and help:
/// `#[command(flatten)]` in a scene's own flags.
#[derive(clap::Args, Debug)]
pub struct CommonArgs {
    /// Time step (s)
    #[arg(long, value_name = "DT", default_value = "1/60", value_parser = positive)]
    pub dt: f64,
    /// Rapier alone, or the plugin in one of its timing modes
    #[arg(long, value_enum, value_name = "MODE", default_value_t = Mode::EXACT)]
    pub mode: Mode,
    /// Double precision: needs a build with `--features f64` (the precision is chosen at
    /// build time)
    #[arg(long)]
    pub f64: bool,
}

/// `--mode`: rapier alone, or the plugin with a timing mode.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Mode {
    /// No plugin: rapier's own contacts and restitution.
    Rapier,
    /// The plugin.
    Plugin(TimingMode),
}

impl Mode {
    /// The command line's order.
    pub const ALL: [Mode; 4] = [
        Mode::Rapier,
        Mode::Plugin(TimingMode::Step),
        Mode::Plugin(TimingMode::TimeOfImpact),
        Mode::Plugin(TimingMode::Exact),
    ];

    /// The default of every scene.
    pub const EXACT: Mode = Mode::Plugin(TimingMode::Exact);

    /// The name used on the command line.
    pub fn name(self) -> &'static str {
        match self {
            Mode::Rapier => "rapier",
            Mode::Plugin(TimingMode::Step) => "step",
            Mode::Plugin(TimingMode::TimeOfImpact) => "toi",
            Mode::Plugin(TimingMode::Exact) => "exact",
        }
    }
}

// Written by hand, not derived: `Mode` wraps the library's `TimingMode`, which the scenes use
// as it is, and the command-line names (`toi`) are not the variants' names.
impl ValueEnum for Mode {
    fn value_variants<'a>() -> &'a [Self] {
        &Self::ALL
    }

    fn to_possible_value(&self) -> Option<PossibleValue> {
        let help = match self {
            Mode::Rapier => "Rapier alone, no plugin",
            Mode::Plugin(TimingMode::Step) => {
                "The plugin, impulses at the start of the step in which the contact closes"
            }
            Mode::Plugin(TimingMode::TimeOfImpact) => "The plugin, impulses at the impact's time",
            Mode::Plugin(TimingMode::Exact) => "The plugin, with exact flight too",
        };
        Some(PossibleValue::new(self.name()).help(help))
    }
}

/// `--law`: the impact law (`rapier_impact::model::Law`, which this names on the command line).
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum LawChoice {
    /// The source document's closed form
    Document,
    /// Integration in impulse space: never gains energy
    Consistent,
    /// The closed form, falling back to the consistent law where it is unphysical
    Guarded,
}

impl LawChoice {
    /// The name used on the command line (and in the scenes' headers).
    pub fn name(self) -> &'static str {
        match self {
            LawChoice::Document => "document",
            LawChoice::Consistent => "consistent",
            LawChoice::Guarded => "guarded",
        }
    }
}

impl From<LawChoice> for Law {
    fn from(choice: LawChoice) -> Law {
        match choice {
            LawChoice::Document => Law::Document,
            LawChoice::Consistent => Law::Consistent,
            LawChoice::Guarded => Law::Guarded,
        }
    }
}

/// `--shell`: a solid ball or a thin shell.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum Shell {
    /// A solid ball, I = 2/5 m R^2
    Solid,
    /// A thin shell, I = 2/3 m R^2
    Hollow,
}

impl Shell {
    /// `I / (m R^2)`: 2/5 solid, 2/3 hollow.
    pub fn inertia_ratio(self) -> f64 {
        match self {
            Shell::Solid => 0.4,
            Shell::Hollow => 2.0 / 3.0,
        }
    }

    /// The name used on the command line (and in the scenes' headers).
    pub fn name(self) -> &'static str {
        match self {
            Shell::Solid => "solid",
            Shell::Hollow => "hollow",
        }
    }
}

// ---------------------------------------------------------------------------------------------
// The scene

/// A world stepping at `dt` with rapier's default gravity.
pub fn world(dt: f64) -> PhysicsWorld {
    let mut w = PhysicsWorld::default();
    w.integration_parameters.dt = real(dt);
    w
}

/// A fixed half-space ground, surface at y = 0, normal +y, with the given coefficients (rapier
/// combines them with the body's by its default rule, the average).
pub fn ground(world: &mut PhysicsWorld, restitution: f64, friction: f64) -> ColliderHandle {
    world
        .insert(
            RigidBodyBuilder::fixed(),
            ColliderBuilder::halfspace(rapier_impact::rapier::na::Unit::new_unchecked(Vector::Y))
                .restitution(real(restitution))
                .friction(real(friction)),
        )
        .1
}

/// The plugin for `mode` with `ground` marked, or `None` for rapier alone.
pub fn plugin(
    mode: Mode,
    law: Law,
    world: &mut PhysicsWorld,
    ground: ColliderHandle,
) -> Option<ImpactPlugin> {
    let Mode::Plugin(timing) = mode else {
        return None;
    };
    let mut config = ImpactConfig::default();
    config.law = law;
    config.timing = timing;
    let mut p = ImpactPlugin::new(config).expect("the default configuration is valid");
    p.add_ground(&world.bodies, &world.colliders, ground)
        .expect("the ground collider exists");
    Some(p)
}

/// One step, with the plugin or rapier alone. Returns the plugin's events of this step.
pub fn step<'a>(
    world: &mut PhysicsWorld,
    plugin: &'a mut Option<ImpactPlugin>,
) -> &'a [ImpactEvent] {
    match plugin {
        Some(p) => {
            p.step(world);
            p.events()
        }
        None => {
            world.step();
            &[]
        }
    }
}

/// The random throw of `examples/dice.rs`: 0.5 to 1 m up, 1 to 3 m/s sideways in a random
/// direction, a random spin of up to 10 rad/s per axis, a random orientation (uniform unit
/// quaternion).
pub struct DiceThrow {
    /// Height of the cube's bounding sphere's bottom above the ground (m).
    pub height: f64,
    /// Horizontal speed (m/s) and its direction (rad about y, from +x).
    pub speed: f64,
    pub heading: f64,
    /// Angular velocity (rad/s).
    pub spin: [f64; 3],
    /// Orientation `[x, y, z, w]`.
    pub q: [f64; 4],
}

impl DiceThrow {
    /// The throw for `seed`.
    pub fn new(seed: u64) -> Self {
        let mut rng = Rng::new(seed);
        let height = rng.range(0.5, 1.0);
        let (speed, heading) = (rng.range(1.0, 3.0), rng.range(0.0, std::f64::consts::TAU));
        let spin: [f64; 3] = std::array::from_fn(|_| rng.range(-10.0, 10.0));
        let q = loop {
            let q: [f64; 4] = std::array::from_fn(|_| rng.range(-1.0, 1.0));
            let n2: f64 = q.iter().map(|x| x * x).sum();
            if n2 > 1e-3 && n2 <= 1.0 {
                let n = n2.sqrt();
                break [q[0] / n, q[1] / n, q[2] / n, q[3] / n];
            }
        };
        Self {
            height,
            speed,
            heading,
            spin,
            q,
        }
    }

    /// Inserts a cube of half edge `half` (restitution `e`, friction `mu`) thrown so.
    pub fn insert_cube(
        &self,
        world: &mut PhysicsWorld,
        half: f64,
        e: f64,
        mu: f64,
    ) -> RigidBodyHandle {
        let (q, spin) = (self.q, self.spin);
        world
            .insert(
                RigidBodyBuilder::dynamic()
                    .pose(Pose::from_parts(
                        // The bounding sphere's bottom `height` above the ground.
                        Vector::new(0.0, real(self.height + half * 3f64.sqrt()), 0.0),
                        Rotation::from_xyzw(real(q[0]), real(q[1]), real(q[2]), real(q[3])),
                    ))
                    .linvel(Vector::new(
                        real(self.speed * self.heading.cos()),
                        0.0,
                        real(self.speed * self.heading.sin()),
                    ))
                    .angvel(Vector::new(real(spin[0]), real(spin[1]), real(spin[2]))),
                ColliderBuilder::cuboid(real(half), real(half), real(half))
                    .restitution(real(e))
                    .friction(real(mu)),
            )
            .0
    }
}

// ---------------------------------------------------------------------------------------------
// CSV

/// Exits with status 1 and `what: error` when `r` failed.
pub fn or_exit<T, E: std::fmt::Display>(r: Result<T, E>, what: &str) -> T {
    r.unwrap_or_else(|e| {
        eprintln!("{what}: {e}");
        std::process::exit(1);
    })
}

/// The trace: header `t,x,y,z,vx,vy,vz,wx,wy,wz`, one row per call, of one body's centre of
/// mass (m), linear (m/s) and angular (rad/s) velocity, world frame, y up.
pub struct TraceCsv {
    out: BufWriter<File>,
    path: String,
    body: RigidBodyHandle,
}

impl TraceCsv {
    /// Creates `path` for the trace of `body`; exits with a message if it cannot.
    pub fn create(path: &str, body: RigidBodyHandle) -> Self {
        let mut out = BufWriter::new(or_exit(
            File::create(path),
            &format!("cannot create {path}"),
        ));
        or_exit(
            writeln!(out, "t,x,y,z,vx,vy,vz,wx,wy,wz"),
            &format!("cannot write {path}"),
        );
        Self {
            out,
            path: path.to_string(),
            body,
        }
    }

    /// The row at time `t` (s).
    pub fn row(&mut self, t: f64, bodies: &RigidBodySet) {
        let rb = &bodies[self.body];
        let (p, v, w) = (rb.center_of_mass(), rb.linvel(), rb.angvel());
        or_exit(
            writeln!(
                self.out,
                "{t},{},{},{},{},{},{},{},{},{}",
                p.x, p.y, p.z, v.x, v.y, v.z, w.x, w.y, w.z
            ),
            &format!("cannot write {}", self.path),
        );
    }

    /// Flushes the file.
    pub fn finish(mut self) {
        or_exit(self.out.flush(), &format!("cannot write {}", self.path));
    }
}

/// The `regime` column: `stick`, `slip` or `slip_then_stick`, followed by `+fallback_REASON`
/// when the `Guarded` law fell back to the consistent one, `+settled` when the impact was
/// resolved with `e = 0` below the resting speed, and `+step_end` for the step-end fallback of
/// a body that touched something else in the step.
pub fn regime_label(e: &ImpactEvent) -> String {
    let mut s = match e.regime {
        Regime::Stick => "stick",
        Regime::Slip => "slip",
        Regime::SlipThenStick => "slip_then_stick",
        Regime::Separating => "separating",
    }
    .to_string();
    if let Some(f) = e.fallback {
        s += match f {
            Fallback::PullingNormalImpulse => "+fallback_pulling",
            Fallback::Jam => "+fallback_jam",
            Fallback::SlipReversal => "+fallback_slip_reversal",
            Fallback::EnergyGain => "+fallback_energy_gain",
            _ => "+fallback_other",
        };
    }
    if e.settled {
        s += "+settled";
    }
    if e.timing == rapier_impact::ImpactTiming::StepEnd {
        s += "+step_end";
    }
    s
}

/// The events file: header `t,body,px,py,pz,nx,ny,nz,jn,jt,regime,ke_before,ke_after`; `t` the
/// simulation time of the impact (s), `body` the body handle's index, `p` the contact point
/// (m), `n` the normal (ground into body), `jn` the normal impulse and `jt` the magnitude of
/// the friction impulse (N s), `regime` as [`regime_label`], kinetic energies (J).
pub struct EventsCsv {
    out: BufWriter<File>,
    path: String,
}

impl EventsCsv {
    /// Creates `path`; exits with a message if it cannot.
    pub fn create(path: &str) -> Self {
        let mut out = BufWriter::new(or_exit(
            File::create(path),
            &format!("cannot create {path}"),
        ));
        or_exit(
            writeln!(
                out,
                "t,body,px,py,pz,nx,ny,nz,jn,jt,regime,ke_before,ke_after"
            ),
            &format!("cannot write {path}"),
        );
        Self {
            out,
            path: path.to_string(),
        }
    }

    /// The events of the step that started at `step_start` (s).
    pub fn write(&mut self, step_start: f64, events: &[ImpactEvent]) {
        for e in events {
            let (p, n) = (e.point, e.normal);
            or_exit(
                writeln!(
                    self.out,
                    "{},{},{},{},{},{},{},{},{},{},{},{},{}",
                    step_start + e.time,
                    e.body.into_raw_parts().0,
                    p.x,
                    p.y,
                    p.z,
                    n.x,
                    n.y,
                    n.z,
                    e.normal_impulse,
                    wide(e.tangent_impulse.length()),
                    regime_label(e),
                    e.ke_before,
                    e.ke_after
                ),
                &format!("cannot write {}", self.path),
            );
        }
    }

    /// Flushes the file.
    pub fn finish(mut self) {
        or_exit(self.out.flush(), &format!("cannot write {}", self.path));
    }
}

// ---------------------------------------------------------------------------------------------
// Random numbers

/// SplitMix64: a small seeded generator, so a scene is the same for the same seed on every
/// machine.
pub struct Rng(u64);

impl Rng {
    /// A generator from a seed.
    pub fn new(seed: u64) -> Self {
        Self(seed ^ 0x9E37_79B9_7F4A_7C15)
    }

    /// The next 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in `[lo, hi)`.
    pub fn range(&mut self, lo: f64, hi: f64) -> f64 {
        let u = (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64;
        lo + (hi - lo) * u
    }
}
