//! The collision matrix `K` of the general form and the solves built on it.
//!
//! An impulse `P` applied at the contact point changes the contact point's velocity by
//! `du = K P` with
//!
//! ```text
//! K = (1/m) E - [r]x I_w^-1 [r]x,        x.K y = x.y/m + (r × x).I_w^-1 (r × y)
//! ```
//!
//! (`docs/model.md`, "The general form"; the document's (4)-(9) substituted into (1)-(3)).
//! `K` is symmetric positive definite for any `m > 0` and PSD `I_w^-1`. It is never
//! formed as one 3x3 matrix and inverted: for small `I/m` that loses the `1/m` part
//! along `r` (`docs/model.md`, erratum 4). Instead every product is the bilinear form above,
//! a sum of non-negative terms on the diagonal, and the sticking solve splits `K`
//! along `r`, where it is exactly block diagonal.

use super::types::Body;
use nalgebra::{Matrix2, Matrix3, Vector2, Vector3};

/// What an impulse `P` at the contact does to the relative contact velocity, `du = K P`:
/// the one thing the laws need to know of the bodies (`docs/model.md`, "The general form").
pub(crate) trait Compliance {
    /// The bilinear form `x.K y` (1/kg).
    fn k_form(&self, x: &Vector3<f64>, y: &Vector3<f64>) -> f64;
    /// `K P` (m/s per N s).
    fn apply(&self, p: &Vector3<f64>) -> Vector3<f64>;
    /// The impulse `P` with `K P = d`.
    fn solve(&self, d: &Vector3<f64>) -> Vector3<f64>;
    /// `K` in the contact basis of the normal `n`.
    fn contact_k(&self, n: &Vector3<f64>) -> ContactK;
}

/// One body struck at the offset `r` from its centre of mass by a ground that does not
/// yield: `K = E/m - [r]x I_w^-1 [r]x`. `iso` is `Some(a)` when `I_w^-1 = a E`, whose
/// sticking solve and forms have cheaper closed forms.
#[derive(Clone, Copy)]
pub(crate) struct OneBody<'a> {
    pub body: &'a Body,
    pub r: &'a Vector3<f64>,
    pub iso: Option<f64>,
}

impl Compliance for OneBody<'_> {
    #[inline(always)]
    fn k_form(&self, x: &Vector3<f64>, y: &Vector3<f64>) -> f64 {
        match self.iso {
            Some(a) => x.dot(y) / self.body.mass + a * self.r.cross(x).dot(&self.r.cross(y)),
            None => k_form(self.body, self.r, x, y),
        }
    }

    #[inline(always)]
    fn apply(&self, p: &Vector3<f64>) -> Vector3<f64> {
        p / self.body.mass + (self.body.inv_inertia * self.r.cross(p)).cross(self.r)
    }

    #[inline(always)]
    fn solve(&self, d: &Vector3<f64>) -> Vector3<f64> {
        match self.iso {
            // K^-1 = m (I E + m r r^T) / (I + m |r|^2) (`docs/model.md`, erratum 4), I = 1/a,
            // written with a (numerator and denominator times a): one division.
            Some(a) => {
                let (m, r) = (self.body.mass, self.r);
                let c = m * a;
                (d + r * (c * r.dot(d))) * (m / (1.0 + c * r.norm_squared()))
            }
            None => solve_k(self.body, self.r, d),
        }
    }

    fn contact_k(&self, n: &Vector3<f64>) -> ContactK {
        ContactK::new(self.body, self.r, n)
    }
}

/// Two bodies struck at their offsets from their centres of mass, `K = K_a + K_b`. A
/// fixed body (`Body::fixed`) adds nothing, so against one the other body's own solve is
/// used, exactly as against a ground.
#[derive(Clone, Copy)]
pub(crate) struct TwoBodies<'a> {
    pub a: OneBody<'a>,
    pub b: OneBody<'a>,
}

impl Compliance for TwoBodies<'_> {
    fn k_form(&self, x: &Vector3<f64>, y: &Vector3<f64>) -> f64 {
        self.a.k_form(x, y) + self.b.k_form(x, y)
    }

    fn apply(&self, p: &Vector3<f64>) -> Vector3<f64> {
        self.a.apply(p) + self.b.apply(p)
    }

    /// Cholesky on the formed `K`, then two steps of iterative refinement with the
    /// residual `d - K P` from [`Compliance::apply`], whose terms are each exact to
    /// rounding: formed, `K` loses the digits of its smallest eigenvalue relative to its
    /// largest (`docs/model.md`, erratum 4), and refinement wins them back as long as that
    /// ratio is above the rounding (`cond(K) < 1e15`).
    fn solve(&self, d: &Vector3<f64>) -> Vector3<f64> {
        if self.b.body.is_fixed() {
            return self.a.solve(d);
        }
        if self.a.body.is_fixed() {
            return self.b.solve(d);
        }
        let (x, y, z) = (Vector3::x(), Vector3::y(), Vector3::z());
        let (kxx, kyy, kzz) = (
            self.k_form(&x, &x),
            self.k_form(&y, &y),
            self.k_form(&z, &z),
        );
        let (kxy, kxz, kyz) = (
            self.k_form(&x, &y),
            self.k_form(&x, &z),
            self.k_form(&y, &z),
        );
        let k = Matrix3::new(kxx, kxy, kxz, kxy, kyy, kyz, kxz, kyz, kzz);
        let Some(chol) = nalgebra::Cholesky::new(k) else {
            // Not positive definite to rounding: the least-squares impulse.
            return k
                .pseudo_inverse(0.0)
                .map(|k_inv| k_inv * d)
                .unwrap_or_default();
        };
        let mut p = chol.solve(d);
        for _ in 0..2 {
            p += chol.solve(&(d - self.apply(&p)));
        }
        p
    }

    fn contact_k(&self, n: &Vector3<f64>) -> ContactK {
        let (ka, kb) = (self.a.contact_k(n), self.b.contact_k(n));
        ContactK {
            ktt: ka.ktt + kb.ktt,
            ktn: ka.ktn + kb.ktn,
            knn: ka.knn + kb.knn,
            ..ka
        }
    }
}

/// The bilinear form `x.K y` (1/kg).
#[inline]
pub(crate) fn k_form(body: &Body, r: &Vector3<f64>, x: &Vector3<f64>, y: &Vector3<f64>) -> f64 {
    x.dot(y) / body.mass + r.cross(x).dot(&(body.inv_inertia * r.cross(y)))
}

/// Two unit vectors completing `a` (unit) to a right-handed orthonormal basis
/// `(t1, t2, a)`, branch-free except for the sign (Duff et al. 2017, "Building an
/// orthonormal basis, revisited").
#[inline]
pub(crate) fn orthonormal_basis(a: &Vector3<f64>) -> (Vector3<f64>, Vector3<f64>) {
    let sign = 1.0f64.copysign(a.z);
    let p = -1.0 / (sign + a.z);
    let q = a.x * a.y * p;
    let t1 = Vector3::new(1.0 + sign * a.x * a.x * p, sign * q, -sign * a.x);
    let t2 = Vector3::new(q, sign + a.y * a.y * p, -a.y);
    (t1, t2)
}

/// Solves `K P = d` for the impulse `P` accurately at any `I/m`.
///
/// The rotational part of `K` vanishes along `r` (`r × r = 0`) and `K` is symmetric,
/// so `K` maps `r` to `r/m` and the plane normal to `r` to itself: along `r`,
/// `P_r = m (r̂.d) r̂`; in the plane `K` is the 2x2 block `E/m + |r|^2 adj(A)` with
/// `A = [x_i . I_w^-1 x_j]` on two orthogonal in-plane vectors. For an isotropic body
/// this is the closed form `K^-1 = m (I E + m r r^T) / (I + m |r|^2)` of
/// `docs/model.md`, erratum 4.
///
/// The in-plane vectors are `u = (e × r) / |r|`, with `e = z` when `|r_x| > |r_z|` and
/// `e = x` otherwise (Hughes and Möller 1999), and `v = r̂ × u`: orthogonal, of equal
/// length in `[1/√2, 1]`. Not normalising them saves two divisions and the basis's
/// construction; the 2x2 system is written for the coefficients of `P` on `(u, v)` (a
/// Galerkin system), with `r × u = |r| v` and `r × v = -|r| u`.
pub(crate) fn solve_k(body: &Body, r: &Vector3<f64>, d: &Vector3<f64>) -> Vector3<f64> {
    let r2 = r.norm_squared();
    if r2 == 0.0 {
        return d * body.mass;
    }
    let inv_len = 1.0 / r2.sqrt();
    let u = if r.x.abs() > r.z.abs() {
        Vector3::new(-r.y, r.x, 0.0)
    } else {
        Vector3::new(0.0, -r.z, r.y)
    } * inv_len;
    let v = r.cross(&u) * inv_len;
    let a = &body.inv_inertia;
    let au = a * u;
    let av = a * v;
    let uu = u.norm_squared();
    let inv_m = 1.0 / body.mass;
    // u.K u = |u|^2/m + (r × u).A (r × u) = |u|^2/m + |r|^2 v.A v, and likewise.
    let kuu = uu * inv_m + r2 * v.dot(&av);
    let kvv = uu * inv_m + r2 * u.dot(&au);
    let kuv = -r2 * 0.5 * (v.dot(&au) + u.dot(&av));
    let (du, dv) = (u.dot(d), v.dot(d));
    let inv_det = 1.0 / (kuu * kvv - kuv * kuv);
    let alpha = (kvv * du - kuv * dv) * inv_det;
    let beta = (kuu * dv - kuv * du) * inv_det;
    r * (r.dot(d) * body.mass * (inv_len * inv_len)) + u * alpha + v * beta
}

/// Solves the symmetric positive definite 2x2 system `[[a, b], [b, c]] x = y`.
#[inline]
pub(crate) fn solve_spd2(a: f64, b: f64, c: f64, y: &Vector2<f64>) -> Vector2<f64> {
    let det = a * c - b * b;
    Vector2::new((c * y.x - b * y.y) / det, (a * y.y - b * y.x) / det)
}

/// `K` written in the contact basis `(t1, t2, n)`, with its tangential block, its
/// tangential-normal column and its normal-normal entry.
#[derive(Clone, Copy, Debug)]
pub(crate) struct ContactK {
    /// Tangent basis vectors (unit, orthogonal to `n` and to each other).
    pub t1: Vector3<f64>,
    pub t2: Vector3<f64>,
    /// Tangential block `K_tt` (2x2, SPD).
    pub ktt: Matrix2<f64>,
    /// Tangential-normal coupling `K_tn`: how a normal impulse moves the contact sideways.
    pub ktn: Vector2<f64>,
    /// Normal-normal entry `K_nn = n.K n > 0`.
    pub knn: f64,
}

impl ContactK {
    pub(crate) fn new(body: &Body, r: &Vector3<f64>, n: &Vector3<f64>) -> Self {
        let (t1, t2) = orthonormal_basis(n);
        let inv_m = 1.0 / body.mass;
        let rn = r.cross(n);
        let r1 = r.cross(&t1);
        let r2 = r.cross(&t2);
        let ii = &body.inv_inertia;
        let i_rn = ii * rn;
        let i_r1 = ii * r1;
        let k11 = inv_m + r1.dot(&i_r1);
        let k22 = inv_m + r2.dot(&(ii * r2));
        let k12 = r1.dot(&(ii * r2));
        let k1n = r1.dot(&i_rn);
        let k2n = r2.dot(&i_rn);
        let knn = inv_m + rn.dot(&i_rn);
        Self {
            t1,
            t2,
            ktt: Matrix2::new(k11, k12, k12, k22),
            ktn: Vector2::new(k1n, k2n),
            knn,
        }
    }

    /// Tangential components `(v.t1, v.t2)` of a world vector.
    #[inline]
    pub(crate) fn tangential(&self, v: &Vector3<f64>) -> Vector2<f64> {
        Vector2::new(v.dot(&self.t1), v.dot(&self.t2))
    }

    /// The world vector with tangential components `t`.
    #[inline]
    pub(crate) fn world(&self, t: &Vector2<f64>) -> Vector3<f64> {
        self.t1 * t.x + self.t2 * t.y
    }

    /// Tangential friction per unit normal impulse that keeps the slip at zero:
    /// `f = -K_tt^-1 K_tn` (the tangential part of the sticking impulse `K^-1 n`,
    /// scaled to unit normal component).
    #[inline]
    pub(crate) fn sticking_friction_ratio(&self) -> Vector2<f64> {
        -solve_spd2(self.ktt.m11, self.ktt.m12, self.ktt.m22, &self.ktn)
    }

    /// Rate of change of the contact velocity per unit normal impulse while the
    /// friction impulse per unit normal impulse is `f` (tangential, 2-D):
    /// `du/dp = K (n + f)`, returned as (tangential, normal) parts.
    #[inline]
    pub(crate) fn rate(&self, f: &Vector2<f64>) -> (Vector2<f64>, f64) {
        (self.ktn + self.ktt * f, self.knn + self.ktn.dot(f))
    }

    /// The slip direction `s` that stays invariant while slipping from zero slip:
    /// `K_tn - mu K_tt s = lambda s` with `lambda > 0`, `|s| = 1`. It exists whenever
    /// sticking is impossible, `|K_tt^-1 K_tn| > mu` (then `|s(lambda)|` falls from
    /// above 1 at `lambda = 0` to 0 as `lambda -> inf`). Found by bracketing and
    /// bisection on `lambda`; for an isotropic body it is the sticking impulse's
    /// tangential direction (`docs/model.md`, erratum 2).
    pub(crate) fn invariant_slip_direction(&self, mu: f64) -> Vector2<f64> {
        let s_of = |lambda: f64| {
            solve_spd2(
                lambda + mu * self.ktt.m11,
                mu * self.ktt.m12,
                lambda + mu * self.ktt.m22,
                &self.ktn,
            )
        };
        let at_zero = s_of(0.0);
        if !at_zero.iter().all(|c| c.is_finite()) || self.ktn.norm_squared() == 0.0 {
            let n = self.ktn.norm();
            return if n > 0.0 {
                self.ktn / n
            } else {
                Vector2::new(1.0, 0.0)
            };
        }
        let mut lo = 0.0;
        let mut hi = self.ktn.norm().max(f64::MIN_POSITIVE);
        while s_of(hi).norm() > 1.0 {
            hi *= 2.0;
        }
        for _ in 0..200 {
            let mid = 0.5 * (lo + hi);
            if mid <= lo || mid >= hi {
                break;
            }
            if s_of(mid).norm() > 1.0 {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        let s = s_of(0.5 * (lo + hi));
        s / s.norm()
    }
}
