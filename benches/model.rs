//! Cost per impact of each law, per regime and per effect set, against a naive
//! reference (the document's 3x3 system (10)-(12) through a general LU solve).
//!
//! ```text
//! cargo bench --bench model
//! ```
//!
//! Every group runs a seeded batch of `BATCH` impacts per iteration, so the reported
//! time divided by `BATCH` is the cost of one impact (criterion's throughput line shows
//! it as elements per second).

use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use rapier_impact::model::{Body, BodyVelocity, Contact, Law, Material, resolve, seed};
use rapier_impact::na::{Matrix3, Rotation3, Vector3};
use std::hint::black_box;

/// SplitMix64 (the tests' generator): the batches are the same on every run.
#[path = "../tests/model_support/rng.rs"]
mod rng;
use rng::Rng;

const BATCH: usize = 1024;

#[derive(Clone, Copy)]
struct Sample {
    body: Body,
    contact: Contact,
    velocity: BodyVelocity,
    material: Material,
}

/// A solid ball of unit mass and radius `radius` touching the ground (normal +z) at its
/// bottom.
fn ball(radius: f64, linear: Vector3<f64>, angular: Vector3<f64>, material: Material) -> Sample {
    Sample {
        body: Body::isotropic(1.0, 0.4 * radius * radius),
        contact: Contact::fixed(Vector3::z(), Vector3::new(0.0, 0.0, -radius)),
        velocity: BodyVelocity { linear, angular },
        material,
    }
}

/// Balls landing with little slip for their friction: the document's case A.
fn stick_batch(rng: &mut Rng) -> Vec<Sample> {
    (0..BATCH)
        .map(|_| {
            ball(
                rng.uniform(0.02, 0.5),
                Vector3::new(
                    rng.uniform(-1.0, 1.0),
                    rng.uniform(-1.0, 1.0),
                    rng.uniform(-5.0, -1.0),
                ),
                Vector3::new(
                    rng.uniform(-2.0, 2.0),
                    rng.uniform(-2.0, 2.0),
                    rng.uniform(-2.0, 2.0),
                ),
                Material::new(rng.uniform(0.2, 0.9), rng.uniform(0.5, 1.0)),
            )
        })
        .collect()
}

/// Balls landing fast sideways with low friction: case B, slip that never stops.
fn slip_batch(rng: &mut Rng) -> Vec<Sample> {
    (0..BATCH)
        .map(|_| {
            ball(
                rng.uniform(0.02, 0.5),
                Vector3::new(
                    rng.uniform(5.0, 10.0),
                    rng.uniform(-5.0, 5.0),
                    rng.uniform(-3.0, -1.0),
                ),
                Vector3::zeros(),
                Material::new(rng.uniform(0.2, 0.9), rng.uniform(0.05, 0.2)),
            )
        })
        .collect()
}

/// Cube corners slipping across their offset: 3-D coupling turns the slip direction,
/// so the consistent law integrates numerically.
fn swerve_batch(rng: &mut Rng) -> Vec<Sample> {
    (0..BATCH)
        .map(|_| {
            let corner = Vector3::new(rng.uniform(-0.5, 0.5), rng.uniform(-0.5, 0.5), -0.5);
            // Slip perpendicular to the corner's horizontal offset.
            let across = Vector3::new(-corner.y, corner.x, 0.0).normalize() * rng.uniform(1.0, 3.0);
            Sample {
                body: Body::isotropic(1.0, 1.0 / 6.0),
                contact: Contact::fixed(Vector3::z(), corner),
                velocity: BodyVelocity {
                    linear: across + Vector3::new(0.0, 0.0, rng.uniform(-3.0, -1.0)),
                    angular: Vector3::zeros(),
                },
                material: Material::new(rng.uniform(0.2, 0.9), rng.uniform(0.1, 0.3)),
            }
        })
        .collect()
}

/// Rods landing on an end with high restitution and friction: the document's sticking
/// result gains energy, so `Guarded` falls back to `Consistent`.
fn fallback_batch(rng: &mut Rng) -> Vec<Sample> {
    (0..BATCH)
        .map(|_| {
            let phi = rng.uniform(0.6, 1.0);
            let axis = Vector3::new(phi.cos(), 0.0, phi.sin());
            let inertia =
                Matrix3::identity() / 12.0 + axis * axis.transpose() * (1e-6 / 12.0 - 1.0 / 12.0);
            Sample {
                body: Body::from_inertia(1.0, inertia).expect("SPD"),
                contact: Contact::fixed(Vector3::z(), -axis * 0.5),
                velocity: BodyVelocity {
                    linear: Vector3::new(rng.uniform(0.4, 0.8), 0.0, -1.0),
                    angular: Vector3::zeros(),
                },
                material: Material::new(1.0, 1.0),
            }
        })
        .collect()
}

/// Random bodies (anisotropic inertia, random normal and offset), with the material's
/// friction and the body's rotation switched on or off by the effect set.
fn effect_batch(rng: &mut Rng, friction: bool, spin: bool) -> Vec<Sample> {
    (0..BATCH)
        .map(|_| {
            let n = rng.direction();
            let rot = Rotation3::new(rng.direction() * rng.uniform(0.0, 3.0));
            let principal = Matrix3::from_diagonal(&Vector3::new(
                rng.uniform(0.5, 2.0),
                rng.uniform(0.5, 2.0),
                rng.uniform(0.5, 2.0),
            ));
            let inv_inertia = if spin {
                rot.matrix() * principal * rot.matrix().transpose()
            } else {
                Matrix3::zeros()
            };
            Sample {
                body: Body {
                    mass: 1.0,
                    inv_inertia,
                },
                contact: Contact::fixed(n, -n * 0.5 + rng.direction() * 0.2),
                velocity: BodyVelocity {
                    linear: -n * rng.uniform(1.0, 5.0) + rng.direction(),
                    angular: rng.direction(),
                },
                material: Material::new(
                    rng.uniform(0.2, 0.9),
                    if friction { rng.uniform(0.1, 1.0) } else { 0.0 },
                ),
            }
        })
        .collect()
}

/// The naive reference: the document's system (10)-(12) assembled as printed and solved
/// by a general LU, then its cone test and slip law (13)-(19), for an isotropic body
/// with the ground normal +z. The same physics as `Law::Document` in that case.
fn naive_document(input: &seed::SeedInput) -> Vector3<f64> {
    let (m, i, e, mu) = (input.mass, input.inertia, input.restitution, input.friction);
    let (lx, ly, h) = (input.lx, input.ly, input.h);
    let ut = seed::contact_velocity(input, &input.u1, &input.w1);
    if ut.z >= 0.0 {
        return Vector3::zeros();
    }
    let a = Matrix3::new(
        -i / m - h * h - ly * ly,
        lx * ly,
        h * lx,
        lx * ly,
        -i / m - h * h - lx * lx,
        h * ly,
        -h * lx,
        -h * ly,
        i / m + lx * lx + ly * ly,
    );
    let b = Vector3::new(-ut.x * i, -ut.y * i, -(1.0 + e) * ut.z * i);
    let j = a.lu().solve(&b).unwrap_or_else(Vector3::zeros);
    if j.z >= 0.0 && j.x.hypot(j.y) <= mu * j.z {
        return j;
    }
    let theta = ut.y.atan2(ut.x);
    let (sin, cos) = theta.sin_cos();
    let jz = -(1.0 + e) * ut.z * i / (lx * lx + ly * ly + i / m - mu * h * (lx * cos + ly * sin));
    Vector3::new(mu * jz * cos, mu * jz * sin, jz)
}

fn to_seed(s: &Sample) -> seed::SeedInput {
    seed::SeedInput {
        mass: s.body.mass,
        inertia: 1.0 / s.body.inv_inertia.m11,
        lx: s.contact.offset.x,
        ly: s.contact.offset.y,
        h: -s.contact.offset.z,
        restitution: s.material.restitution,
        friction: s.material.friction,
        u1: s.velocity.linear,
        w1: s.velocity.angular,
    }
}

fn run_law(
    c: &mut Criterion,
    group_name: &str,
    batches: &[(&str, Vec<Sample>)],
    with_reference: bool,
) {
    let mut group = c.benchmark_group(group_name);
    group.throughput(Throughput::Elements(BATCH as u64));
    for (name, batch) in batches {
        for law in [Law::Document, Law::Guarded, Law::Consistent] {
            group.bench_with_input(
                BenchmarkId::new(format!("{law:?}"), name),
                batch,
                |b, batch| {
                    b.iter(|| {
                        let mut sum = 0.0;
                        for s in batch {
                            if let Ok(impact) =
                                resolve(law, &s.body, &s.velocity, &s.contact, &s.material)
                            {
                                sum += impact.normal_impulse;
                            }
                        }
                        black_box(sum)
                    })
                },
            );
        }
        if with_reference {
            let seeds: Vec<_> = batch.iter().map(to_seed).collect();
            group.bench_with_input(BenchmarkId::new("naive_lu", name), &seeds, |b, seeds| {
                b.iter(|| {
                    let mut sum = 0.0;
                    for s in seeds {
                        sum += naive_document(black_box(s)).z;
                    }
                    black_box(sum)
                })
            });
            group.bench_with_input(BenchmarkId::new("seed_solve", name), &seeds, |b, seeds| {
                b.iter(|| {
                    let mut sum = 0.0;
                    for s in seeds {
                        if let Ok(out) = seed::solve(black_box(s)) {
                            sum += out.impulse.z;
                        }
                    }
                    black_box(sum)
                })
            });
        }
    }
    group.finish();
}

fn per_regime(c: &mut Criterion) {
    let mut rng = Rng::new(0x5EED);
    let batches = [
        ("stick", stick_batch(&mut rng)),
        ("slip", slip_batch(&mut rng)),
        ("swerve", swerve_batch(&mut rng)),
        ("fallback", fallback_batch(&mut rng)),
    ];
    run_law(c, "impact_per_regime", &batches[..3], true);
    run_law(c, "impact_fallback", &batches[3..], false);
}

fn per_effect_set(c: &mut Criterion) {
    let mut rng = Rng::new(0xEFFEC7);
    let batches = [
        ("frictionless", effect_batch(&mut rng, false, true)),
        ("no_spin", effect_batch(&mut rng, true, false)),
        ("full", effect_batch(&mut rng, true, true)),
    ];
    run_law(c, "impact_per_effect_set", &batches, false);
}

criterion_group!(benches, per_regime, per_effect_set);
criterion_main!(benches);
