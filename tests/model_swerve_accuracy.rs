//! The consistent law's swerve integration against an independent reference.
//!
//! The reference is deliberately simple and shares no code with the crate: the
//! collision matrix `K` is formed as a plain 3x3 matrix in the world frame, and
//! `du/dp = K (n - mu s)`, `dW/dp = u_n`, `dF/dp = -mu s` are integrated by the classic
//! fourth-order Runge-Kutta method with small fixed steps in the normal impulse `p`
//! (not in the crate's `tau`, and without its closed forms or error control). Events
//! (compression end `u_n = 0`, restitution end `W = (1 - e^2) W_c`) are located by
//! bisection on a partial RK4 step from the start of the step that crosses them.
//!
//! Only impacts whose slip stays well away from zero are compared (in `p` the slip's
//! turning rate grows like `1/|u_t|`; there fixed steps are accurate). The reference is
//! itself checked by halving its step.

use rapier_impact::model::{
    Body, BodyVelocity, Contact, Law, Material, Regime, SWERVE_TOLERANCE, resolve,
};
use rapier_impact::na::{Matrix3, Rotation3, Vector3};

// SplitMix64 (`model_support`'s), seeded, so every run checks the same impacts.
mod model_support;

use model_support::Rng;

/// The reference's state: contact velocity, work of the normal impulse, friction
/// impulse.
#[derive(Clone, Copy)]
struct Y {
    u: Vector3<f64>,
    w: f64,
    f: Vector3<f64>,
}

impl Y {
    fn add(&self, h: f64, k: &Y) -> Y {
        Y {
            u: self.u + k.u * h,
            w: self.w + k.w * h,
            f: self.f + k.f * h,
        }
    }
}

struct Reference {
    k: Matrix3<f64>,
    n: Vector3<f64>,
    mu: f64,
}

impl Reference {
    fn rate(&self, y: &Y) -> Y {
        let ut = y.u - self.n * self.n.dot(&y.u);
        let s = ut / ut.norm();
        Y {
            u: self.k * (self.n - s * self.mu),
            w: self.n.dot(&y.u),
            f: -s * self.mu,
        }
    }

    fn rk4(&self, y: &Y, h: f64) -> Y {
        let k1 = self.rate(y);
        let k2 = self.rate(&y.add(0.5 * h, &k1));
        let k3 = self.rate(&y.add(0.5 * h, &k2));
        let k4 = self.rate(&y.add(h, &k3));
        Y {
            u: y.u + (k1.u + k2.u * 2.0 + k3.u * 2.0 + k4.u) * (h / 6.0),
            w: y.w + (k1.w + 2.0 * k2.w + 2.0 * k3.w + k4.w) * (h / 6.0),
            f: y.f + (k1.f + k2.f * 2.0 + k3.f * 2.0 + k4.f) * (h / 6.0),
        }
    }

    /// Integrates from `y` in steps of `h` until `value(y) >= 0`; returns the state at
    /// the crossing, the normal impulse there, and the smallest slip on the way.
    fn until(&self, mut y: Y, mut p: f64, h: f64, value: impl Fn(&Y) -> f64) -> (Y, f64, f64) {
        let mut min_slip = f64::INFINITY;
        for _ in 0..10_000_000 {
            let next = self.rk4(&y, h);
            min_slip = min_slip.min((next.u - self.n * self.n.dot(&next.u)).norm());
            if value(&next) >= 0.0 {
                let (mut lo, mut hi) = (0.0, h);
                for _ in 0..80 {
                    let mid = 0.5 * (lo + hi);
                    if value(&self.rk4(&y, mid)) >= 0.0 {
                        hi = mid;
                    } else {
                        lo = mid;
                    }
                }
                return (self.rk4(&y, hi), p + hi, min_slip);
            }
            y = next;
            p += h;
        }
        panic!("reference did not reach its event");
    }

    /// The impulse on the body of an impact with restitution `e`, with `steps` RK4
    /// steps over the compression's normal impulse; and the smallest slip on the way.
    fn impulse(&self, u1: &Vector3<f64>, e: f64, steps: f64) -> (Vector3<f64>, f64) {
        let knn = self.n.dot(&(self.k * self.n));
        let h = -self.n.dot(u1) / knn / steps;
        let y0 = Y {
            u: *u1,
            w: 0.0,
            f: Vector3::zeros(),
        };
        let (yc, pc, slip_c) = self.until(y0, 0.0, h, |y| self.n.dot(&y.u));
        if e == 0.0 {
            return (self.n * pc + yc.f, slip_c);
        }
        let target = (1.0 - e * e) * yc.w;
        let (yr, pr, slip_r) = self.until(yc, pc, h, |y| y.w - target);
        (self.n * pr + yr.f, slip_c.min(slip_r))
    }
}

/// `K = E/m - [r]x I_w^-1 [r]x`, as one matrix.
fn collision_matrix(body: &Body, r: &Vector3<f64>) -> Matrix3<f64> {
    let rx = r.cross_matrix();
    Matrix3::identity() / body.mass - rx * body.inv_inertia * rx
}

struct Case {
    body: Body,
    contact: Contact,
    velocity: BodyVelocity,
    material: Material,
}

/// Cube corners slipping across their offset (the bench's swerve batch), and random
/// anisotropic bodies on random normals.
fn cases(rng: &mut Rng) -> Vec<Case> {
    let mut out = Vec::new();
    for _ in 0..150 {
        let corner = Vector3::new(rng.uniform(-0.5, 0.5), rng.uniform(-0.5, 0.5), -0.5);
        let across = Vector3::new(-corner.y, corner.x, 0.0).normalize() * rng.uniform(1.0, 3.0);
        out.push(Case {
            body: Body::isotropic(1.0, 1.0 / 6.0),
            contact: Contact::fixed(Vector3::z(), corner),
            velocity: BodyVelocity {
                linear: across + Vector3::new(0.0, 0.0, rng.uniform(-3.0, -1.0)),
                angular: Vector3::zeros(),
            },
            material: Material::new(rng.uniform(0.0, 1.0), rng.uniform(0.1, 0.3)),
        });
    }
    for _ in 0..150 {
        let n = rng.direction();
        let rot = Rotation3::new(rng.direction() * rng.uniform(0.0, 3.0));
        let principal = Matrix3::from_diagonal(&Vector3::new(
            rng.uniform(0.5, 2.0),
            rng.uniform(0.5, 2.0),
            rng.uniform(0.5, 2.0),
        ));
        out.push(Case {
            body: Body {
                mass: rng.uniform(0.5, 2.0),
                inv_inertia: rot.matrix() * principal * rot.matrix().transpose(),
            },
            contact: Contact::fixed(n, -n * 0.5 + rng.direction() * 0.4),
            velocity: BodyVelocity {
                linear: -n * rng.uniform(1.0, 5.0) + rng.direction() * rng.uniform(1.0, 4.0),
                angular: rng.direction() * rng.uniform(0.0, 2.0),
            },
            material: Material::new(rng.uniform(0.0, 1.0), rng.uniform(0.05, 0.5)),
        });
    }
    out
}

#[test]
fn swerving_slip_matches_an_independent_fixed_step_rk4_reference() {
    let mut rng = Rng::new(0x05E4_E47E);
    let (mut compared, mut worst, mut worst_reference) = (0, 0.0f64, 0.0f64);
    for (k, c) in cases(&mut rng).iter().enumerate() {
        let impact = resolve(
            Law::Consistent,
            &c.body,
            &c.velocity,
            &c.contact,
            &c.material,
        )
        .expect("valid input");
        if impact.regime != Regime::Slip {
            continue;
        }
        let r = c.contact.offset;
        let u1 = c.velocity.linear + c.velocity.angular.cross(&r);
        let reference = Reference {
            k: collision_matrix(&c.body, &r),
            n: c.contact.normal,
            mu: c.material.friction,
        };
        let e = c.material.restitution;
        let (fine, min_slip) = reference.impulse(&u1, e, 4000.0);
        // In p the slip's turning rate grows like 1/|u_t|: compare only where the slip
        // stays away from zero, where fixed steps are accurate.
        if min_slip < 0.05 * u1.norm() {
            continue;
        }
        let (coarse, _) = reference.impulse(&u1, e, 2000.0);
        let reference_error = (fine - coarse).norm() / fine.norm();
        let d = (impact.impulse - fine).norm() / fine.norm();
        assert!(
            reference_error <= 1e-11,
            "case {k}: the reference itself moves by {reference_error:e} when its step halves"
        );
        assert!(
            d <= 10.0 * SWERVE_TOLERANCE,
            "case {k}: Consistent {:?} vs RK4 reference {fine:?}: relative {d:e} > {:e}",
            impact.impulse,
            10.0 * SWERVE_TOLERANCE
        );
        worst = worst.max(d);
        worst_reference = worst_reference.max(reference_error);
        compared += 1;
    }
    eprintln!(
        "swerve vs RK4 reference on {compared} slipping impacts: worst relative impulse \
         difference {worst:.2e} (reference self-consistency {worst_reference:.2e})"
    );
    assert!(compared >= 100, "only {compared} impacts compared");
}
