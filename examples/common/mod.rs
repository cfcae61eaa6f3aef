//! Code shared by the example scenes (`mod common;` in each): a small flag parser where every
//! flag has a default, the `--mode` and `--law` choices, the `--f64` check, the scene's ground,
//! one step with or without the plugin, the dice throw, the CSV trace and events writers, and a
//! seeded random number generator.
//!
//! Conventions of every scene: y up, ground surface at y = 0, rapier's default gravity.
#![allow(dead_code)] // each example uses a part of this module

use rapier_impact::model::{Fallback, Law, Regime};
use rapier_impact::rapier::prelude::*;
use rapier_impact::{ImpactConfig, ImpactEvent, ImpactPlugin, TimingMode};
use std::collections::HashMap;
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
// Flags

/// One command-line flag: `--name VALUE`, or a switch when `value` is empty.
#[derive(Clone, Copy, Debug)]
pub struct Flag {
    /// With the dashes: `"--height"`.
    pub name: &'static str,
    /// Placeholder shown in the usage (`"H"`); empty for a switch.
    pub value: &'static str,
    /// The value used when the flag is absent; empty means "off" (no file written, switch
    /// not set).
    pub default: &'static str,
    /// One line of help, units included.
    pub help: &'static str,
}

/// A flag taking a value.
pub const fn flag(
    name: &'static str,
    value: &'static str,
    default: &'static str,
    help: &'static str,
) -> Flag {
    Flag {
        name,
        value,
        default,
        help,
    }
}

/// A switch (no value; off by default).
pub const fn switch(name: &'static str, help: &'static str) -> Flag {
    Flag {
        name,
        value: "",
        default: "",
        help,
    }
}

/// `--mode rapier|step|toi|exact`, default `exact`.
pub const MODE: Flag = flag(
    "--mode",
    "rapier|step|toi|exact",
    "exact",
    "rapier = rapier alone (no plugin); step, toi, exact = the plugin's timing modes",
);
/// `--f64`.
pub const F64: Flag = switch(
    "--f64",
    "double precision: needs a build with `--features f64` (the precision is chosen at build time)",
);
/// `--shell solid|hollow`, default `solid`: see [`Args::inertia_ratio`].
pub const SHELL: Flag = flag(
    "--shell",
    "solid|hollow",
    "solid",
    "solid ball (I = 2/5 m R^2) or thin shell (2/3 m R^2)",
);
/// `--csv PATH`.
pub const CSV: Flag = flag(
    "--csv",
    "PATH",
    "",
    "write the trace t,x,y,z,vx,vy,vz,wx,wy,wz of the first dynamic body (centre of mass)",
);
/// `--law document|consistent|guarded`, default `guarded`.
pub const LAW: Flag = flag(
    "--law",
    "document|consistent|guarded",
    "guarded",
    "the impact law (see rapier_impact::model::Law)",
);

/// Parsed flags. The getters exit with a message and the usage when a value is bad.
pub struct Args {
    program: &'static str,
    about: &'static str,
    spec: Vec<Flag>,
    given: HashMap<&'static str, String>,
}

impl Args {
    /// Parses the process arguments against `spec`; exits with the usage on `--help` (status
    /// 0) or on a bad command line (status 2).
    pub fn parse(program: &'static str, about: &'static str, spec: &[Flag]) -> Self {
        match Self::parse_from(program, about, spec, std::env::args().skip(1)) {
            Ok(a) => a,
            Err(None) => {
                println!("{}", usage(program, about, spec));
                std::process::exit(0);
            }
            Err(Some(msg)) => {
                eprintln!("{program}: {msg}\n\n{}", usage(program, about, spec));
                std::process::exit(2);
            }
        }
    }

    /// Parses `argv` (without the program name). `Err(None)` is a request for help.
    pub fn parse_from(
        program: &'static str,
        about: &'static str,
        spec: &[Flag],
        argv: impl IntoIterator<Item = String>,
    ) -> Result<Self, Option<String>> {
        let mut given = HashMap::new();
        let mut it = argv.into_iter();
        while let Some(arg) = it.next() {
            if arg == "-h" || arg == "--help" {
                return Err(None);
            }
            let (name, inline) = match arg.split_once('=') {
                Some((n, v)) if n.starts_with("--") => (n.to_string(), Some(v.to_string())),
                _ => (arg.clone(), None),
            };
            let Some(f) = spec.iter().find(|f| f.name == name) else {
                return Err(Some(format!("unknown flag `{arg}`")));
            };
            let value = if f.value.is_empty() {
                if inline.is_some() {
                    return Err(Some(format!("`{}` takes no value", f.name)));
                }
                "on".to_string()
            } else {
                match inline.or_else(|| it.next()) {
                    Some(v) => v,
                    None => return Err(Some(format!("`{}` needs a value {}", f.name, f.value))),
                }
            };
            if given.insert(f.name, value).is_some() {
                return Err(Some(format!("`{}` given twice", f.name)));
            }
        }
        Ok(Self {
            program,
            about,
            spec: spec.to_vec(),
            given,
        })
    }

    /// Prints `msg` and the usage, exits with status 2.
    pub fn fail(&self, msg: &str) -> ! {
        eprintln!(
            "{}: {msg}\n\n{}",
            self.program,
            usage(self.program, self.about, &self.spec)
        );
        std::process::exit(2);
    }

    fn raw(&self, name: &str) -> &str {
        let f = self
            .spec
            .iter()
            .find(|f| f.name == name)
            .unwrap_or_else(|| panic!("{name} is not a flag of {}", self.program));
        self.given.get(f.name).map_or(f.default, String::as_str)
    }

    /// Was the flag given?
    pub fn given(&self, name: &str) -> bool {
        self.given.contains_key(name)
    }

    /// `I / (m R^2)` of the `--shell` chosen: 2/5 solid, 2/3 hollow.
    pub fn inertia_ratio(&self) -> f64 {
        if self.choice("--shell") == "hollow" {
            2.0 / 3.0
        } else {
            0.4
        }
    }

    /// A switch.
    pub fn on(&self, name: &str) -> bool {
        !self.raw(name).is_empty()
    }

    /// The text of a flag.
    pub fn text(&self, name: &str) -> String {
        self.raw(name).to_string()
    }

    /// A path, or `None` when the flag is off.
    pub fn path(&self, name: &str) -> Option<String> {
        let p = self.raw(name);
        (!p.is_empty()).then(|| p.to_string())
    }

    /// A finite number. `1/60` style fractions are accepted too.
    pub fn number(&self, name: &str) -> f64 {
        let v = self.raw(name);
        let parsed = match v.split_once('/') {
            Some((a, b)) => match (a.trim().parse::<f64>(), b.trim().parse::<f64>()) {
                (Ok(a), Ok(b)) => Some(a / b),
                _ => None,
            },
            None => v.parse::<f64>().ok(),
        };
        match parsed.filter(|x| x.is_finite()) {
            Some(x) => x,
            None => self.fail(&format!("`{name}`: `{v}` is not a finite number")),
        }
    }

    /// A number `> 0`.
    pub fn positive(&self, name: &str) -> f64 {
        let x = self.number(name);
        if x <= 0.0 {
            self.fail(&format!("`{name}` must be > 0, got {x}"));
        }
        x
    }

    /// A number `>= 0`.
    pub fn non_negative(&self, name: &str) -> f64 {
        let x = self.number(name);
        if x < 0.0 {
            self.fail(&format!("`{name}` must be >= 0, got {x}"));
        }
        x
    }

    /// A whole number `>= min`.
    pub fn count(&self, name: &str, min: u64) -> u64 {
        let v = self.raw(name);
        match v.parse::<u64>() {
            Ok(n) if n >= min => n,
            _ => self.fail(&format!("`{name}`: `{v}` is not a whole number >= {min}")),
        }
    }

    /// One of `options` (the text after the flag's name in its placeholder, `a|b|c`).
    pub fn choice(&self, name: &str) -> String {
        let v = self.raw(name);
        let f = self.spec.iter().find(|f| f.name == name).unwrap();
        if f.value.split('|').any(|o| o == v) {
            v.to_string()
        } else {
            self.fail(&format!("`{name}`: `{v}` is not one of {}", f.value))
        }
    }

    /// `--mode`.
    pub fn mode(&self) -> Mode {
        match self.choice(MODE.name).as_str() {
            "rapier" => Mode::Rapier,
            "step" => Mode::Plugin(TimingMode::Step),
            "toi" => Mode::Plugin(TimingMode::TimeOfImpact),
            _ => Mode::Plugin(TimingMode::Exact),
        }
    }

    /// `--law`.
    pub fn law(&self) -> Law {
        match self.choice(LAW.name).as_str() {
            "document" => Law::Document,
            "consistent" => Law::Consistent,
            _ => Law::Guarded,
        }
    }

    /// `--f64`: refused, with the command that works, in an `f32` build.
    pub fn check_precision(&self) {
        if self.on(F64.name) && !cfg!(feature = "f64") {
            self.fail(&format!(
                "`--f64` needs the f64 build: cargo run --release --features f64 --example {} -- --f64 ...",
                self.program
            ));
        }
    }
}

/// The usage text: one line per flag with its default.
pub fn usage(program: &str, about: &str, spec: &[Flag]) -> String {
    let mut s = format!("{about}\n\nusage: cargo run --release --example {program} -- [FLAGS]\n");
    for f in spec {
        let head = if f.value.is_empty() {
            f.name.to_string()
        } else {
            format!("{} {}", f.name, f.value)
        };
        let default = if f.value.is_empty() {
            "off".to_string()
        } else if f.default.is_empty() {
            "none".to_string()
        } else {
            f.default.to_string()
        };
        s += &format!("  {head:<36} {} (default: {default})\n", f.help);
    }
    s
}

// ---------------------------------------------------------------------------------------------
// Modes and the scene

/// Rapier alone, or the plugin with a timing mode.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Mode {
    /// No plugin: rapier's own contacts and restitution.
    Rapier,
    /// The plugin.
    Plugin(TimingMode),
}

impl Mode {
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
    let mut p = ImpactPlugin::new(ImpactConfig {
        law,
        timing,
        ..Default::default()
    })
    .expect("the default configuration is valid");
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

/// The first dynamic body of the set (in insertion order).
pub fn first_dynamic(bodies: &RigidBodySet) -> Option<RigidBodyHandle> {
    bodies
        .iter()
        .filter(|(_, rb)| rb.is_dynamic())
        .min_by_key(|(h, _)| h.into_raw_parts())
        .map(|(h, _)| h)
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
