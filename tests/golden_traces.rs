//! Golden traces: the plugin's behaviour, bit for bit, on fixed scenes (a drop, a spin shot,
//! dice, a billiards break, a cradle, a ball rolling off a slope, a pile of opted-in balls,
//! balls on an 8 x 8 tiled floor) in every timing mode under every law. After every step,
//! every body's pose and velocities, whether it sleeps, and the step's events are folded into
//! one chained hash (FNV-1a over the bits: stable across Rust versions); its value every 10
//! steps is kept in `tests/golden/<build>.txt`, one line a run.
//!
//! A change that is meant to keep behaviour (a refactor) keeps every line. A change of
//! behaviour shows which runs moved and from which step on; once each difference is measured
//! and explained, record the new traces with `GOLDEN_TRACES=record cargo test --release
//! --test golden_traces` (and the same with `--features f64`, and with
//! `--features enhanced-determinism`).
//!
//! The traces are of one build: `f32` and `f64` on x86_64 (the platform's own `sin`, `cos`,
//! `atan2`), and with `enhanced-determinism` (libm's, the same on every platform). Elsewhere
//! the first two are not compared.

mod scene_support;

use rapier_impact::model::Law;
use rapier_impact::rapier::prelude::*;
use rapier_impact::{EventKind, ImpactConfig, ImpactEvent, ImpactPlugin, TimingMode};
use scene_support::{real, up, walled_box};
use std::fmt::Write as _;

/// Steps between two kept values of a run's chained hash.
const EVERY: usize = 10;

/// The build whose traces this is, and whether they are compared on this platform.
fn build() -> (&'static str, bool) {
    let precision = if cfg!(feature = "f64") { "f64" } else { "f32" };
    if cfg!(feature = "enhanced-determinism") {
        let name = if cfg!(feature = "f64") {
            "f64-libm"
        } else {
            "f32-libm"
        };
        (name, true)
    } else {
        let native = cfg!(all(target_arch = "x86_64", target_os = "linux"));
        (precision, native)
    }
}

/// FNV-1a, 64 bits.
struct Fnv(u64);

impl Fnv {
    fn new() -> Self {
        Self(0xcbf2_9ce4_8422_2325)
    }

    fn bytes(&mut self, bytes: &[u8]) {
        for b in bytes {
            self.0 ^= u64::from(*b);
            self.0 = self.0.wrapping_mul(0x0000_0100_0000_01b3);
        }
    }

    fn u64(&mut self, x: u64) {
        self.bytes(&x.to_le_bytes());
    }

    fn real(&mut self, x: Real) {
        self.u64(scene_support::wide(x).to_bits());
    }
}

/// Folds the world's bodies and the step's events into `h`.
fn fold_step(h: &mut Fnv, world: &PhysicsWorld, events: &[ImpactEvent]) {
    for (handle, rb) in world.bodies.iter() {
        let (index, generation) = handle.into_raw_parts();
        h.u64(u64::from(index) << 32 | u64::from(generation));
        let (t, r, v, w) = (rb.translation(), rb.rotation(), rb.linvel(), rb.angvel());
        for x in [
            t.x, t.y, t.z, r.x, r.y, r.z, r.w, v.x, v.y, v.z, w.x, w.y, w.z,
        ] {
            h.real(x);
        }
        h.u64(u64::from(rb.is_sleeping()));
    }
    for e in events {
        let what = (e.kind, e.timing, e.regime, e.law, e.fallback, e.settled);
        h.bytes(format!("{what:?}").as_bytes());
        h.u64(u64::from(e.body.into_raw_parts().0));
        h.u64(u64::from(e.collider.into_raw_parts().0));
        h.u64(u64::from(e.ground.into_raw_parts().0));
        h.u64(
            e.body2
                .map_or(u64::MAX, |b| u64::from(b.into_raw_parts().0)),
        );
        h.u64(e.contact_points as u64);
        for x in [
            e.time,
            e.approach_speed,
            e.normal_impulse,
            e.restitution,
            e.ke_before,
            e.ke_after,
        ] {
            h.u64(x.to_bits());
        }
        for v in [e.point, e.normal, e.impulse, e.tangent_impulse] {
            for x in [v.x, v.y, v.z] {
                h.real(x);
            }
        }
        h.u64(e.friction.to_bits());
    }
}

/// A scene: the world, its ground colliders, whether its dynamic bodies take impacts between
/// bodies, the rolling resistance, and how many steps it runs.
struct Scene {
    world: PhysicsWorld,
    grounds: Vec<ColliderHandle>,
    pairs: bool,
    rolling_resistance: f64,
    steps: usize,
}

fn world() -> PhysicsWorld {
    PhysicsWorld::default()
}

fn ball(
    w: &mut PhysicsWorld,
    r: f64,
    at: [f64; 3],
    v: [f64; 3],
    spin: [f64; 3],
    (e, mu): (f64, f64),
) -> RigidBodyHandle {
    let vec = |a: [f64; 3]| Vector::new(real(a[0]), real(a[1]), real(a[2]));
    w.insert(
        RigidBodyBuilder::dynamic()
            .translation(vec(at))
            .linvel(vec(v))
            .angvel(vec(spin)),
        ColliderBuilder::ball(real(r))
            .restitution(real(e))
            .friction(real(mu)),
    )
    .0
}

fn halfspace(w: &mut PhysicsWorld, e: f64, mu: f64) -> ColliderHandle {
    w.insert(
        RigidBodyBuilder::fixed(),
        ColliderBuilder::halfspace(up())
            .restitution(real(e))
            .friction(real(mu)),
    )
    .1
}

/// A ball dropped from 1 m.
fn drop() -> Scene {
    let mut w = world();
    let ground = halfspace(&mut w, 0.8, 0.5);
    ball(&mut w, 0.1, [0.0, 1.0, 0.0], [0.0; 3], [0.0; 3], (0.8, 0.5));
    Scene {
        world: w,
        grounds: vec![ground],
        pairs: false,
        rolling_resistance: 0.0,
        steps: 150,
    }
}

/// A ball shot down and sideways with backspin onto a cuboid ground.
fn spin() -> Scene {
    let mut w = world();
    let ground = w.insert(
        RigidBodyBuilder::fixed().translation(Vector::new(0.0, -0.5, 0.0)),
        ColliderBuilder::cuboid(20.0, 0.5, 20.0)
            .restitution(0.6)
            .friction(0.4),
    );
    ball(
        &mut w,
        0.1,
        [0.0, 0.5, 0.0],
        [5.0, -2.0, 0.0],
        [0.0, 0.0, 30.0],
        (0.6, 0.4),
    );
    Scene {
        world: w,
        grounds: vec![ground.1],
        pairs: false,
        rolling_resistance: 0.0,
        steps: 120,
    }
}

/// Three dice thrown spinning onto a half-space.
fn dice() -> Scene {
    let mut w = world();
    let ground = halfspace(&mut w, 0.5, 0.6);
    for k in 0..3 {
        let x = k as f64 * 0.3 - 0.3;
        w.insert(
            RigidBodyBuilder::dynamic()
                .translation(Vector::new(real(x), real(0.6 + 0.1 * k as f64), 0.0))
                .rotation(Vector::new(0.3, real(0.2 * k as f64), 0.5))
                .linvel(Vector::new(1.0, -1.0, real(0.5 - 0.4 * k as f64)))
                .angvel(Vector::new(real(4.0 - k as f64), 7.0, -3.0)),
            ColliderBuilder::cuboid(0.05, 0.05, 0.05)
                .restitution(0.5)
                .friction(0.6),
        );
    }
    Scene {
        world: w,
        grounds: vec![ground],
        pairs: false,
        rolling_resistance: 0.0,
        steps: 180,
    }
}

/// A cue ball rolling into a triangle of six balls on the table, every ball opted in.
fn billiards() -> Scene {
    let mut w = world();
    let ground = halfspace(&mut w, 0.5, 0.2);
    let r = 0.028;
    let m = (0.95, 0.2);
    ball(
        &mut w,
        r,
        [0.0, r, 0.0],
        [3.0, 0.0, 0.0],
        [0.0, 0.0, -3.0 / r],
        m,
    );
    let d = 2.0 * r + 1e-4;
    for row in 0..3 {
        for k in 0..=row {
            let x = 0.6 + row as f64 * d * 0.866;
            let z = (k as f64 - row as f64 / 2.0) * d;
            ball(&mut w, r, [x, r, z], [0.0; 3], [0.0; 3], m);
        }
    }
    Scene {
        world: w,
        grounds: vec![ground],
        pairs: true,
        rolling_resistance: 0.0,
        steps: 90,
    }
}

/// Newton's cradle: five touching balls on a frictionless floor, the first moving into them.
fn cradle() -> Scene {
    let mut w = world();
    let ground = halfspace(&mut w, 0.0, 0.0);
    let r = 0.05;
    ball(
        &mut w,
        r,
        [-0.3, r, 0.0],
        [1.0, 0.0, 0.0],
        [0.0; 3],
        (1.0, 0.0),
    );
    for k in 0..4 {
        let x = k as f64 * 2.0 * r;
        ball(&mut w, r, [x, r, 0.0], [0.0; 3], [0.0; 3], (1.0, 0.0));
    }
    Scene {
        world: w,
        grounds: vec![ground],
        pairs: true,
        rolling_resistance: 0.0,
        steps: 60,
    }
}

/// A ball rolling down a 10-degree slope onto level ground, with rolling resistance.
fn roll() -> Scene {
    let mut w = world();
    let level = halfspace(&mut w, 0.3, 0.5);
    let th = 10f64.to_radians();
    let slope = w.insert(
        RigidBodyBuilder::fixed()
            .translation(Vector::new(-1.0, real(0.5 * th.sin()), 0.0))
            .rotation(Vector::new(0.0, 0.0, real(-th))),
        ColliderBuilder::cuboid(0.5, 0.01, 0.5)
            .restitution(0.3)
            .friction(0.5),
    );
    let r = 0.05;
    let n = [th.sin(), th.cos()];
    let top = [-1.4, (0.5 - 0.4) * th.sin() + 0.01 * n[1]];
    ball(
        &mut w,
        r,
        [top[0] + n[0] * r, top[1] + n[1] * r, 0.0],
        [0.5, 0.0, 0.0],
        [0.0, 0.0, -10.0],
        (0.3, 0.5),
    );
    Scene {
        world: w,
        grounds: vec![level, slope.1],
        pairs: false,
        rolling_resistance: 0.02,
        steps: 240,
    }
}

/// 60 opted-in balls dropped into a walled box.
fn pile() -> Scene {
    let mut w = world();
    let floor = halfspace(&mut w, 0.7, 0.5);
    walled_box(&mut w, 0.25);
    for k in 0..60 {
        let (layer, cell) = (k / 16, k % 16);
        let at = [
            (cell % 4) as f64 * 0.11 - 0.165 + 0.003 * (k % 3) as f64,
            0.3 + layer as f64 * 0.11,
            (cell / 4) as f64 * 0.11 - 0.165 - 0.002 * (k % 2) as f64,
        ];
        ball(&mut w, 0.05, at, [0.0; 3], [0.0; 3], (0.7, 0.5));
    }
    Scene {
        world: w,
        grounds: vec![floor],
        pairs: true,
        rolling_resistance: 0.0,
        steps: 240,
    }
}

/// 40 balls raining onto an 8 x 8 floor of cuboid tiles (0.5 m square).
fn tiles() -> Scene {
    let mut w = world();
    let mut grounds = Vec::new();
    for i in 0..8 {
        for j in 0..8 {
            let centre = |k: usize| (k as f64 - 3.5) * 0.5;
            grounds.push(
                w.insert(
                    RigidBodyBuilder::fixed().translation(Vector::new(
                        real(centre(i)),
                        -0.25,
                        real(centre(j)),
                    )),
                    ColliderBuilder::cuboid(0.25, 0.25, 0.25)
                        .restitution(0.7)
                        .friction(0.5),
                )
                .1,
            );
        }
    }
    for k in 0..40 {
        let at = [
            (k % 8) as f64 * 0.45 - 1.6 + 0.01 * (k % 3) as f64,
            0.5 + (k / 8) as f64 * 0.2,
            (k / 8) as f64 * 0.7 - 1.5,
        ];
        ball(&mut w, 0.05, at, [0.3, 0.0, 0.2], [0.0; 3], (0.7, 0.5));
    }
    Scene {
        world: w,
        grounds,
        pairs: false,
        rolling_resistance: 0.0,
        steps: 150,
    }
}

/// A scene's name and how it is built.
type NamedScene = (&'static str, fn() -> Scene);

const SCENES: [NamedScene; 8] = [
    ("drop", drop),
    ("spin", spin),
    ("dice", dice),
    ("billiards", billiards),
    ("cradle", cradle),
    ("roll", roll),
    ("pile", pile),
    ("tiles", tiles),
];

/// One run's line: the chained hash every `EVERY` steps and after the last.
fn trace(make: fn() -> Scene, timing: TimingMode, law: Law) -> String {
    let Scene {
        mut world,
        grounds,
        pairs,
        rolling_resistance,
        steps,
    } = make();
    let mut p = ImpactPlugin::new(
        ImpactConfig::default()
            .with_timing(timing)
            .with_law(law)
            .with_rolling_resistance(rolling_resistance),
    )
    .unwrap();
    for g in grounds {
        p.add_ground(&world.bodies, &world.colliders, g).unwrap();
    }
    p.set_all_dynamic_bodies_impact(pairs);
    let mut h = Fnv::new();
    let mut line = String::new();
    let (mut ground_impacts, mut pair_impacts) = (0, 0);
    for n in 1..=steps {
        p.step(&mut world);
        fold_step(&mut h, &world, p.events());
        for e in p.events().iter().filter(|e| e.kind == EventKind::Impact) {
            match e.body2 {
                Some(_) => pair_impacts += 1,
                None => ground_impacts += 1,
            }
        }
        if n % EVERY == 0 || n == steps {
            write!(line, " {:08x}", h.0 >> 32).unwrap();
        }
    }
    // A trace of nothing would keep itself: every scene has the impacts it is there for.
    let label = format!("{timing:?} {law:?}");
    assert!(
        ground_impacts + pair_impacts > 0,
        "{label}: the scene met nothing"
    );
    if pairs && timing != TimingMode::Step {
        assert!(pair_impacts > 0, "{label}: no impact between bodies");
    }
    line
}

fn traces() -> String {
    let (name, _) = build();
    let mut out = format!(
        "# Golden traces of the {name} build (tests/golden_traces.rs): a run a line, its chained\n\
         # hash every {EVERY} steps. Record with GOLDEN_TRACES=record.\n"
    );
    for (scene, make) in SCENES {
        for timing in [
            TimingMode::Step,
            TimingMode::TimeOfImpact,
            TimingMode::Exact,
        ] {
            for law in [Law::Document, Law::Consistent, Law::Guarded] {
                writeln!(
                    out,
                    "{scene} {timing:?} {law:?}:{}",
                    trace(make, timing, law)
                )
                .unwrap();
            }
        }
    }
    out
}

#[test]
fn every_scene_keeps_its_golden_trace() {
    let (name, compared) = build();
    let path = format!("{}/tests/golden/{name}.txt", env!("CARGO_MANIFEST_DIR"));
    let now = traces();
    if std::env::var("GOLDEN_TRACES").as_deref() == Ok("record") {
        std::fs::create_dir_all(format!("{}/tests/golden", env!("CARGO_MANIFEST_DIR"))).unwrap();
        std::fs::write(&path, &now).unwrap();
        println!("recorded {path}");
        return;
    }
    if !compared {
        println!("no golden traces for this platform's {name} build: not compared");
        return;
    }
    let kept = std::fs::read_to_string(&path)
        .unwrap_or_else(|e| panic!("{path}: {e} (record it with GOLDEN_TRACES=record)"));
    let mut moved = Vec::new();
    for (was, is) in kept.lines().zip(now.lines()) {
        if was != is {
            let (run, old) = was.split_once(':').unwrap_or((was, ""));
            let new = is.split_once(':').map_or("", |(_, v)| v);
            let first = old
                .split_whitespace()
                .zip(new.split_whitespace())
                .position(|(a, b)| a != b)
                .map_or(0, |k| k * EVERY);
            moved.push(format!(
                "{run}: first differs in steps {} to {}",
                first + 1,
                first + EVERY
            ));
        }
    }
    assert_eq!(
        kept.lines().count(),
        now.lines().count(),
        "{path}: the runs changed"
    );
    assert!(
        moved.is_empty(),
        "{} of {} runs left their golden trace ({path}):\n{}",
        moved.len(),
        now.lines().count() - 2,
        moved.join("\n")
    );
}
