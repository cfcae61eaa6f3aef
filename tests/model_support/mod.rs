//! Helpers shared by the `model_*` integration tests: a seeded random generator (`rng.rs`,
//! which the scene test and the benches include too),
//! random rotations and bodies, an independent kinetic energy, relative errors, and a
//! double-double (about 106-bit) linear solve used as the exact reference.
//!
//! Nothing here calls into `rapier_impact::model` except to build its input types, so
//! the references stay independent of the code under test.
#![allow(dead_code)]

use rapier_impact::model::seed::SeedInput;
use rapier_impact::model::{Body, BodyVelocity, Contact, Material};
use rapier_impact::na::{Matrix3, Rotation3, Vector3};

mod rng;

pub use rng::Rng;

/// A seed input's scalars in the document's notation: `(I, m, l_x, l_y, h, mu, e)`.
pub fn notation(s: &SeedInput) -> (f64, f64, f64, f64, f64, f64, f64) {
    (
        s.inertia,
        s.mass,
        s.lx,
        s.ly,
        s.h,
        s.friction,
        s.restitution,
    )
}

/// A rotation taking `+z` to the unit vector `n`.
pub fn rotation_z_to(n: &Vector3<f64>) -> Matrix3<f64> {
    let z = Vector3::z();
    match Rotation3::rotation_between(&z, n) {
        Some(r) => *r.matrix(),
        // n = -z: half turn about x.
        None => *Rotation3::from_axis_angle(&Vector3::x_axis(), std::f64::consts::PI).matrix(),
    }
}

/// Symmetrised `R D R^T`.
pub fn rotate_tensor(r: &Matrix3<f64>, diag: &Vector3<f64>) -> Matrix3<f64> {
    let t = r * Matrix3::from_diagonal(diag) * r.transpose();
    (t + t.transpose()) * 0.5
}

/// A body with principal moments `moments` (kg m^2) and principal axes the columns of
/// `axes`. Returns the body (inverse tensor) and the inertia tensor itself.
pub fn anisotropic_body(
    mass: f64,
    moments: &Vector3<f64>,
    axes: &Matrix3<f64>,
) -> (Body, Matrix3<f64>) {
    let inv = Vector3::new(1.0 / moments.x, 1.0 / moments.y, 1.0 / moments.z);
    let body = Body {
        mass,
        inv_inertia: rotate_tensor(axes, &inv),
    };
    (body, rotate_tensor(axes, moments))
}

/// A random anisotropic body: mass log-uniform in `[1e-2, 1e2]`, principal radii of
/// gyration log-uniform in `[0.05, 2]` times `size`, random principal axes.
pub fn random_body(rng: &mut Rng, size: f64) -> (Body, Matrix3<f64>) {
    let mass = rng.log_uniform(1e-2, 1e2);
    let moments = Vector3::new(
        mass * (rng.log_uniform(0.05, 2.0) * size).powi(2),
        mass * (rng.log_uniform(0.05, 2.0) * size).powi(2),
        mass * (rng.log_uniform(0.05, 2.0) * size).powi(2),
    );
    let axes = rng.rotation();
    anisotropic_body(mass, &moments, &axes)
}

/// Kinetic energy from the inertia tensor itself (not its inverse).
pub fn kinetic_energy(mass: f64, inertia: &Matrix3<f64>, v: &BodyVelocity) -> f64 {
    0.5 * mass * v.linear.norm_squared() + 0.5 * v.angular.dot(&(inertia * v.angular))
}

/// Kinetic energy of an isotropic body in the document's notation.
pub fn seed_energy(input: &SeedInput, u: &Vector3<f64>, w: &Vector3<f64>) -> f64 {
    0.5 * input.mass * u.norm_squared() + 0.5 * input.inertia * w.norm_squared()
}

/// `|a - b| / |b|` (or `|a - b|` when `b = 0`).
pub fn rel(a: &Vector3<f64>, b: &Vector3<f64>) -> f64 {
    let d = (a - b).norm();
    let s = b.norm();
    if s > 0.0 { d / s } else { d }
}

/// `|a - b| / scale`.
pub fn rel_to(a: &Vector3<f64>, b: &Vector3<f64>, scale: f64) -> f64 {
    (a - b).norm() / scale
}

/// The contact-point velocity `v + w × r - u_ground`.
pub fn contact_velocity(v: &BodyVelocity, c: &Contact) -> Vector3<f64> {
    v.linear + v.angular.cross(&c.offset) - c.ground_velocity
}

/// The impact expressed in a random frame: every vector rotated by `q`, the inverse
/// inertia tensor conjugated.
pub fn rotate_problem(
    q: &Matrix3<f64>,
    body: &Body,
    v: &BodyVelocity,
    c: &Contact,
) -> (Body, BodyVelocity, Contact) {
    let t = q * body.inv_inertia * q.transpose();
    (
        Body {
            mass: body.mass,
            inv_inertia: (t + t.transpose()) * 0.5,
        },
        BodyVelocity {
            linear: q * v.linear,
            angular: q * v.angular,
        },
        Contact {
            normal: q * c.normal,
            offset: q * c.offset,
            ground_velocity: q * c.ground_velocity,
        },
    )
}

/// The general-form problem equal to a seed input: isotropic body, `n = +z`,
/// `r = (l_x, l_y, -h)`.
pub fn general_from_seed(s: &SeedInput) -> (Body, BodyVelocity, Contact, Material) {
    (
        Body::isotropic(s.mass, s.inertia),
        BodyVelocity {
            linear: s.u1,
            angular: s.w1,
        },
        Contact::fixed(Vector3::z(), Vector3::new(s.lx, s.ly, -s.h)),
        Material::new(s.restitution, s.friction),
    )
}

/// The impulse on the body from the document's `(J_x, J_y, J_z)`.
pub fn body_impulse(j: &Vector3<f64>) -> Vector3<f64> {
    Vector3::new(-j.x, -j.y, j.z)
}

// ---------------------------------------------------------------------------------
// Double-double arithmetic (Dekker; Hida, Li & Bailey), about 106 significant bits.

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Dd {
    pub hi: f64,
    pub lo: f64,
}

fn two_sum(a: f64, b: f64) -> (f64, f64) {
    let s = a + b;
    let bb = s - a;
    (s, (a - (s - bb)) + (b - bb))
}

fn quick_two_sum(a: f64, b: f64) -> (f64, f64) {
    let s = a + b;
    (s, b - (s - a))
}

impl Dd {
    pub const ZERO: Dd = Dd { hi: 0.0, lo: 0.0 };

    pub fn new(x: f64) -> Self {
        Dd { hi: x, lo: 0.0 }
    }

    pub fn to_f64(self) -> f64 {
        self.hi + self.lo
    }

    pub fn add(self, y: Dd) -> Dd {
        let (s, e) = two_sum(self.hi, y.hi);
        let (t, f) = two_sum(self.lo, y.lo);
        let (s, e) = quick_two_sum(s, e + t);
        let (hi, lo) = quick_two_sum(s, e + f);
        Dd { hi, lo }
    }

    pub fn neg(self) -> Dd {
        Dd {
            hi: -self.hi,
            lo: -self.lo,
        }
    }

    pub fn sub(self, y: Dd) -> Dd {
        self.add(y.neg())
    }

    pub fn mul(self, y: Dd) -> Dd {
        let p = self.hi * y.hi;
        let e = self.hi.mul_add(y.hi, -p);
        let e = e + (self.hi * y.lo + self.lo * y.hi);
        let (hi, lo) = quick_two_sum(p, e);
        Dd { hi, lo }
    }

    pub fn div(self, y: Dd) -> Dd {
        let q1 = self.hi / y.hi;
        let r = self.sub(y.mul(Dd::new(q1)));
        let q2 = r.hi / y.hi;
        let r = r.sub(y.mul(Dd::new(q2)));
        let q3 = r.hi / y.hi;
        let (hi, lo) = quick_two_sum(q1, q2);
        Dd { hi, lo }.add(Dd::new(q3))
    }

    pub fn abs(self) -> Dd {
        if self.hi < 0.0 { self.neg() } else { self }
    }
}

/// Solves the 3x3 system `a x = b` in double-double by Gaussian elimination with
/// partial pivoting. (Indexed loops: the textbook form reads best here.)
#[allow(clippy::needless_range_loop)]
pub fn dd_solve3(a: [[Dd; 3]; 3], b: [Dd; 3]) -> [Dd; 3] {
    let mut m = a;
    let mut y = b;
    for col in 0..3 {
        let mut piv = col;
        for row in col + 1..3 {
            if m[row][col].abs().hi > m[piv][col].abs().hi {
                piv = row;
            }
        }
        m.swap(col, piv);
        y.swap(col, piv);
        for row in col + 1..3 {
            let f = m[row][col].div(m[col][col]);
            for k in col..3 {
                m[row][k] = m[row][k].sub(f.mul(m[col][k]));
            }
            y[row] = y[row].sub(f.mul(y[col]));
        }
    }
    let mut x = [Dd::ZERO; 3];
    for row in (0..3).rev() {
        let mut acc = y[row];
        for k in row + 1..3 {
            acc = acc.sub(m[row][k].mul(x[k]));
        }
        x[row] = acc.div(m[row][row]);
    }
    x
}

/// The document's (10)-(12) as printed, built and solved in double-double from the
/// given `f64` contact velocity `u1t`. Returns `(J_x, J_y, J_z)`.
pub fn dd_document_sticking(s: &SeedInput, u1t: &Vector3<f64>) -> Vector3<f64> {
    let d = Dd::new;
    let (i, lx, ly, h) = (d(s.inertia), d(s.lx), d(s.ly), d(s.h));
    let i_m = i.div(d(s.mass));
    let a = [
        [
            i_m.add(h.mul(h)).add(ly.mul(ly)).neg(),
            lx.mul(ly),
            h.mul(lx),
        ],
        [
            lx.mul(ly),
            i_m.add(h.mul(h)).add(lx.mul(lx)).neg(),
            h.mul(ly),
        ],
        [
            h.mul(lx).neg(),
            h.mul(ly).neg(),
            i_m.add(lx.mul(lx)).add(ly.mul(ly)),
        ],
    ];
    let b = [
        d(u1t.x).mul(i).neg(),
        d(u1t.y).mul(i).neg(),
        d(1.0).add(d(s.restitution)).mul(d(u1t.z)).mul(i).neg(),
    ];
    let x = dd_solve3(a, b);
    Vector3::new(x[0].to_f64(), x[1].to_f64(), x[2].to_f64())
}

/// `K P = rhs` of the general form, `K = E/m - [r]x I^-1 [r]x`, formed and solved in
/// double-double from the `f64` inputs.
pub fn dd_general_solve(body: &Body, r: &Vector3<f64>, rhs: &Vector3<f64>) -> Vector3<f64> {
    let d = Dd::new;
    // [r]x as a matrix of Dd.
    let rx = [
        [Dd::ZERO, d(-r.z), d(r.y)],
        [d(r.z), Dd::ZERO, d(-r.x)],
        [d(-r.y), d(r.x), Dd::ZERO],
    ];
    let inv = |i: usize, j: usize| d(body.inv_inertia[(i, j)]);
    // t = I^-1 [r]x
    let mut t = [[Dd::ZERO; 3]; 3];
    for (i, row) in t.iter_mut().enumerate() {
        for (j, cell) in row.iter_mut().enumerate() {
            let mut acc = Dd::ZERO;
            for (k, rxk) in rx.iter().enumerate() {
                acc = acc.add(inv(i, k).mul(rxk[j]));
            }
            *cell = acc;
        }
    }
    let inv_m = d(1.0).div(d(body.mass));
    let mut k = [[Dd::ZERO; 3]; 3];
    for i in 0..3 {
        for j in 0..3 {
            let mut acc = Dd::ZERO;
            for (l, tl) in t.iter().enumerate() {
                acc = acc.add(rx[i][l].mul(tl[j]));
            }
            k[i][j] = acc.neg();
            if i == j {
                k[i][j] = k[i][j].add(inv_m);
            }
        }
    }
    let x = dd_solve3(k, [d(rhs.x), d(rhs.y), d(rhs.z)]);
    Vector3::new(x[0].to_f64(), x[1].to_f64(), x[2].to_f64())
}

// ---------------------------------------------------------------------------------
// Random inputs and assertions.

/// A random impact in the document's notation. Mass log-uniform in `[1e-2, 1e2]` kg,
/// length scale `L` log-uniform in `[0.1, 10]` m, `I/(m L^2)` log-uniform in
/// `[1e-3, 1]`, `l_x, l_y` in `[-L, L]`, `h` in `[0.05 L, L]`, `e` in `[0, 1]`,
/// `mu` in `[0, 1.5]`, `|u_i| <= 5` m/s, `|w_i| <= 5/L` rad/s, `u_z` in `[-5, 0)`.
pub fn random_seed_input(rng: &mut Rng) -> SeedInput {
    let mass = rng.log_uniform(1e-2, 1e2);
    let l = rng.log_uniform(0.1, 10.0);
    let mut u1 = rng.vector(5.0);
    u1.z = -rng.uniform(1e-3, 5.0);
    SeedInput {
        mass,
        inertia: mass * l * l * rng.log_uniform(1e-3, 1.0),
        lx: rng.uniform(-l, l),
        ly: rng.uniform(-l, l),
        h: rng.uniform(0.05 * l, l),
        restitution: rng.unit(),
        friction: rng.uniform(0.0, 1.5),
        u1,
        w1: rng.vector(5.0 / l),
    }
}

/// Asserts `|measured - expected| <= tol * scale` for vectors, printing both. The bound is on
/// the Euclidean norm of the difference: `approx`'s comparisons of nalgebra vectors bound each
/// component instead, up to `sqrt 3` times looser.
#[track_caller]
pub fn assert_vec_close(
    what: &str,
    measured: &Vector3<f64>,
    expected: &Vector3<f64>,
    tol: f64,
    scale: f64,
) {
    let err = (measured - expected).norm();
    assert!(
        err <= tol * scale,
        "{what}: measured {measured:?}, expected {expected:?} (|error| {err:.3e} > {tol:e} x scale {scale:.3e})"
    );
}

/// A random approaching impact in the general form: anisotropic body (see
/// [`random_body`]), random unit normal, contact offset with `r.n < 0` and `|r_i| <= 1`
/// m, `|v_i| <= 5` m/s, `|w_i| <= 5` rad/s, the normal approach speed in `[1e-3, 5]`
/// m/s, `e` in `[0, 1]`, `mu` in `[0, 1.5]`.
pub fn random_general(rng: &mut Rng) -> (Body, Matrix3<f64>, BodyVelocity, Contact, Material) {
    let (body, inertia) = random_body(rng, 0.5);
    let n = rng.unit_vector();
    let mut r = rng.vector(1.0);
    if r.dot(&n) > 0.0 {
        r -= n * (2.0 * r.dot(&n));
    }
    let contact = Contact::fixed(n, r);
    let mut v = BodyVelocity {
        linear: rng.vector(5.0),
        angular: rng.vector(5.0),
    };
    let un = n.dot(&contact_velocity(&v, &contact));
    v.linear -= n * (un + rng.uniform(1e-3, 5.0));
    let material = Material::new(rng.unit(), rng.uniform(0.0, 1.5));
    (body, inertia, v, contact, material)
}

/// An approaching impact where jams live: a thin or flat body (mass log-uniform in
/// `[1e-2, 1e2]` kg, principal radii of gyration in `[0.025, 1]` m, random axes) hit at a
/// random point of its lower side (`|r_i| <= 1` m), with `|v_i|, |w_i| <= 5` and an approach
/// speed in `[1e-3, 5]` m/s.
pub fn jam_prone_impact(rng: &mut Rng) -> (Body, BodyVelocity, Contact) {
    let mass = 10f64.powf(rng.uniform(-2.0, 2.0));
    let moments = Vector3::new(
        mass * rng.uniform(0.025, 1.0).powi(2),
        mass * rng.uniform(0.025, 1.0).powi(2),
        mass * rng.uniform(0.025, 1.0).powi(2),
    );
    let axes = rng.rotation();
    let (body, _) = anisotropic_body(mass, &moments, &axes);
    let n = rng.unit_vector();
    let mut r = Vector3::new(
        rng.uniform(-1.0, 1.0),
        rng.uniform(-1.0, 1.0),
        rng.uniform(-1.0, 1.0),
    );
    if r.dot(&n) > 0.0 {
        r -= n * (2.0 * r.dot(&n));
    }
    let mut velocity = BodyVelocity {
        linear: rng.vector(5.0),
        angular: rng.vector(5.0),
    };
    let un = n.dot(&(velocity.linear + velocity.angular.cross(&r)));
    velocity.linear -= n * (un + rng.uniform(1e-3, 5.0));
    (body, velocity, Contact::fixed(n, r))
}
