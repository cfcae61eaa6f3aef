//! A velocity pushed at a constant rate along a fixed direction and braked at a constant rate
//! against itself, `dw/dt = A e - B w/|w|`, in closed form: the pursuit curve (a ship holding
//! its bow on a port while a current sets it sideways; Bouguer, 1732). On a slope it is the
//! slip of a ball sliding across the fall line (`A e` the acceleration along the ground, `B`
//! the friction's braking of the slip) and the velocity of a ball rolling across it against
//! rolling resistance. No rapier types.
//!
//! With `psi` the angle from `e` to `w` (in `(0, pi)`: `w` not along `e`), `tau = tan(psi/2)`,
//! `beta = B / A` and `rho = tau / tau0`, the angle only falls, and
//! `|w| / sin(psi) = C tau^beta` (`d ln|w| / d psi = -cot(psi) + beta / sin(psi)`), so
//! `|w| = |w0| rho^(beta-1) (1 + tau^2) / (1 + tau0^2)`, and with `x = ln(rho) <= 0`,
//! `D(q) = (1 - rho^q) / q` (`-x` at `q = 0`) and `K0 = |w0| / (A (1 + tau0^2))`:
//! - elapsed time: `t = K0 (D(beta-1) + tau0^2 D(beta+1))`;
//! - travelled (`int w dt`), along `e` and across it:
//!   `|w0|^2 / (A (1 + tau0^2)^2) (D(2 beta-2) - tau0^4 D(2 beta+2))` and
//!   `2 |w0|^2 / (A (1 + tau0^2)^2) (tau0 D(2 beta-1) + tau0^3 D(2 beta+1))`.
//!
//! For `beta > 1` the velocity vanishes at `rho = 0`, aligned with `e`, after
//! `K0 (1/(beta-1) + tau0^2/(beta+1))` (starting square to `e`: `|w0| B / (B^2 - A^2)`, the
//! pursuit's classic capture time); otherwise it never does and turns towards `e`.
//! Everything is written in ratios to the start so that no power of `tau0` alone over- or
//! underflows.

use nalgebra::Vector3;

/// Largest `B / A` taken as a pursuit: beyond it the velocity turns by less than `A / B` of a
/// radian before it stops, below `f64` rounding of its direction, and the motion is a
/// straight braking (the caller's constant-acceleration phase).
pub(crate) const MAX_BRAKE_TO_DRIFT: f64 = 1e12;

/// One pursuit from its start.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Pursuit {
    /// Unit drift direction `e`.
    along: Vector3<f64>,
    /// Unit direction across `e`, towards the start's `w`.
    across: Vector3<f64>,
    /// `|w0|`.
    speed0: f64,
    /// `tan(psi0 / 2)`.
    tau0: f64,
    /// `A`, the drift rate (> 0).
    drift: f64,
    /// `B / A`.
    beta: f64,
}

/// Where a pursuit is `h` after its start.
#[derive(Clone, Copy, Debug)]
pub(crate) struct PursuitState {
    /// `w`.
    pub w: Vector3<f64>,
    /// `int_0^h w dt`.
    pub travelled: Vector3<f64>,
}

/// `(1 - rho^q) / q` with `x = ln(rho) <= 0`, `-x` at `q = 0`, exact near `q = 0`.
fn ratio_integral(q: f64, x: f64) -> f64 {
    if q == 0.0 {
        -x
    } else if x == f64::NEG_INFINITY {
        if q > 0.0 { 1.0 / q } else { f64::INFINITY }
    } else {
        -crate::math::exp_m1(q * x) / q
    }
}

impl Pursuit {
    /// The pursuit from `w0` under drift `drift` (the vector `A e`) and braking rate `brake`
    /// (`B`), or `None` where it is not one: no drift, no braking, `w0` along the drift
    /// direction (either way) or too small to have one, or braking so much stronger than the
    /// drift that `w` keeps its direction (`MAX_BRAKE_TO_DRIFT`).
    pub fn new(w0: &Vector3<f64>, drift: &Vector3<f64>, brake: f64) -> Option<Self> {
        let a = drift.norm();
        let speed0 = w0.norm();
        if !(a > 0.0 && brake > 0.0 && speed0 > 0.0) || brake > MAX_BRAKE_TO_DRIFT * a {
            return None;
        }
        let along = drift / a;
        let w_along = w0.dot(&along);
        let w_across = w0 - along * w_along;
        let across_speed = w_across.norm();
        if across_speed == 0.0 {
            return None;
        }
        // tan(psi/2) = sin / (1 + cos) = (1 - cos) / sin: the form without cancellation.
        let tau0 = if w_along >= 0.0 {
            across_speed / (speed0 + w_along)
        } else {
            (speed0 - w_along) / across_speed
        };
        let tau0 = (tau0.is_finite() && tau0 > 0.0).then_some(tau0)?;
        Some(Self {
            along,
            across: w_across / across_speed,
            speed0,
            tau0,
            drift: a,
            beta: brake / a,
        })
    }

    /// Whether `w` vanishes (`B > A`), and then when.
    pub fn stop_time(&self) -> Option<f64> {
        (self.beta > 1.0).then(|| self.time_at(f64::NEG_INFINITY))
    }

    /// The time at which `ln(tau / tau0)` has fallen to `x`.
    fn time_at(&self, x: f64) -> f64 {
        let (b, t2) = (self.beta, self.tau0 * self.tau0);
        let k0 = self.speed0 / (self.drift * (1.0 + t2));
        k0 * (ratio_integral(b - 1.0, x) + t2 * ratio_integral(b + 1.0, x))
    }

    /// The time at which the angle from the drift direction has fallen to `psi`: 0 if it is
    /// already there or below (a start at the limit, within rounding), and always before the
    /// pursuit ends otherwise (the angle falls to 0 at its end).
    pub fn time_at_angle(&self, cos_psi: f64) -> f64 {
        let cos_psi = cos_psi.clamp(-1.0, 1.0);
        let tau = ((1.0 - cos_psi) / (1.0 + cos_psi)).sqrt();
        let x = crate::math::ln(tau / self.tau0);
        if x < 0.0 { self.time_at(x) } else { 0.0 }
    }

    /// `ln(tau / tau0)` at time `h` (`0 <= h`, below the stop time): `time_at` falls
    /// monotonically in `x`, so Newton's steps inside a bracket that bisection keeps.
    fn angle_at(&self, h: f64) -> f64 {
        if h <= 0.0 {
            return 0.0;
        }
        let (b, t2) = (self.beta, self.tau0 * self.tau0);
        let k0 = self.speed0 / (self.drift * (1.0 + t2));
        let slope =
            |x: f64| -k0 * crate::math::exp((b - 1.0) * x) * (1.0 + t2 * crate::math::exp(2.0 * x));
        let (mut hi, mut lo) = (0.0f64, -1.0f64);
        while self.time_at(lo) < h && lo > -1e6 {
            hi = lo;
            lo *= 2.0;
        }
        let mut x = 0.5 * (hi + lo);
        for _ in 0..200 {
            let f = self.time_at(x) - h;
            if f == 0.0 {
                break;
            }
            if f > 0.0 {
                lo = x;
            } else {
                hi = x;
            }
            let newton = x - f / slope(x);
            let next = if newton > lo && newton < hi {
                newton
            } else {
                0.5 * (lo + hi)
            };
            if (next - x).abs() <= 1e-16 * x.abs().max(1e-300) || next == lo || next == hi {
                x = next;
                break;
            }
            x = next;
        }
        x
    }

    /// The state `h >= 0` after the start; at or past the stop time, `w = 0` and the whole
    /// travel.
    pub fn at(&self, h: f64) -> PursuitState {
        let x = match self.stop_time() {
            Some(stop) if h >= stop => f64::NEG_INFINITY,
            _ => self.angle_at(h),
        };
        self.at_angle(x)
    }

    fn at_angle(&self, x: f64) -> PursuitState {
        let (b, tau0) = (self.beta, self.tau0);
        let t2 = tau0 * tau0;
        let rho = crate::math::exp(x);
        let tau = tau0 * rho;
        // |w| (cos, sin) = |w0| rho^(beta-1) (1 - tau^2, 2 tau) / (1 + tau0^2).
        let w = if x == f64::NEG_INFINITY {
            Vector3::zeros()
        } else {
            let scale = self.speed0 * crate::math::exp((b - 1.0) * x) / (1.0 + t2);
            self.along * (scale * (1.0 - tau * tau)) + self.across * (scale * 2.0 * tau)
        };
        let c = self.speed0 * self.speed0 / (self.drift * (1.0 + t2) * (1.0 + t2));
        let along =
            c * (ratio_integral(2.0 * b - 2.0, x) - t2 * t2 * ratio_integral(2.0 * b + 2.0, x));
        let across = 2.0
            * c
            * (tau0 * ratio_integral(2.0 * b - 1.0, x)
                + tau0 * t2 * ratio_integral(2.0 * b + 1.0, x));
        PursuitState {
            w,
            travelled: self.along * along + self.across * across,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `dw/dt = A e - B w/|w|` by classical Runge-Kutta, with its travel: the reference the
    /// closed form is held to (4th order: 1e-5 s steps leave about 1e-15).
    fn integrate(
        w0: Vector3<f64>,
        drift: Vector3<f64>,
        brake: f64,
        t: f64,
    ) -> (Vector3<f64>, Vector3<f64>) {
        let f = |w: &Vector3<f64>| drift - w.normalize() * brake;
        let n = (t / 1e-5).ceil() as usize;
        let h = t / n as f64;
        let (mut w, mut x) = (w0, Vector3::zeros());
        for _ in 0..n {
            let k1 = f(&w);
            let k2 = f(&(w + k1 * (0.5 * h)));
            let k3 = f(&(w + k2 * (0.5 * h)));
            let k4 = f(&(w + k3 * h));
            // The travel's own stages: dx/dt = w.
            x += (w * 6.0 + (k1 + k2 + k3) * h) * (h / 6.0);
            w += (k1 + k2 * 2.0 + k3 * 2.0 + k4) * (h / 6.0);
        }
        (w, x)
    }

    #[test]
    fn agrees_with_runge_kutta_before_the_stop() {
        let drift = Vector3::new(0.6, 0.0, 0.0);
        for (w0, beta) in [
            (Vector3::new(0.3, 0.0, 1.0), 3.0),
            (Vector3::new(-1.5, 0.0, 0.2), 1.7),
            (Vector3::new(0.0, 0.0, -2.0), 1.0),
            (Vector3::new(0.5, 0.0, 0.5), 0.5),
            (Vector3::new(-0.02, 0.0, 1.0), 1.0 + 1e-9),
        ] {
            let brake = beta * drift.norm();
            let p = Pursuit::new(&w0, &drift, brake).unwrap();
            let t = p.stop_time().map_or(1.0, |s| (0.8 * s).min(1.0));
            let (w_ref, x_ref) = integrate(w0, drift, brake, t);
            let s = p.at(t);
            let scale = w0.norm() + drift.norm() * t;
            assert!(
                (s.w - w_ref).norm() < 1e-11 * scale,
                "beta {beta}: {:?} vs {w_ref:?}",
                s.w
            );
            assert!(
                (s.travelled - x_ref).norm() < 1e-11 * scale * t,
                "beta {beta}: {:?} vs {x_ref:?}",
                s.travelled
            );
        }
    }

    #[test]
    fn square_to_the_drift_it_stops_at_the_classic_capture_time() {
        // Square to the drift (tau0 = 1): T = |w0| B / (B^2 - A^2), and it travels
        // |w0|^2 A / (4 (B^2 - A^2)) along the drift and 2 |w0|^2 B / (4 B^2 - A^2) across.
        let (speed, a, b) = (1.3, 0.7, 2.1);
        let p = Pursuit::new(
            &Vector3::new(0.0, speed, 0.0),
            &Vector3::new(a, 0.0, 0.0),
            b,
        )
        .unwrap();
        let stop = p.stop_time().unwrap();
        assert!(
            (stop - speed * b / (b * b - a * a)).abs() < 1e-15 * stop,
            "{stop}"
        );
        let end = p.at(stop + 1.0);
        assert_eq!(end.w, Vector3::zeros());
        let along = speed * speed * a / (4.0 * (b * b - a * a));
        let across = 2.0 * speed * speed * b / (4.0 * b * b - a * a);
        assert!(
            (end.travelled.x - along).abs() < 1e-15,
            "{:?}",
            end.travelled
        );
        assert!(
            (end.travelled.y - across).abs() < 1e-15,
            "{:?}",
            end.travelled
        );
    }

    #[test]
    fn the_angle_at_a_time_is_the_time_at_that_angle() {
        let drift = Vector3::new(1.0, 0.0, 0.0);
        for (w0, brake) in [
            (Vector3::new(-0.4, 0.0, 0.9), 1.4),
            (Vector3::new(0.4, 0.0, 0.01), 0.6),
        ] {
            let p = Pursuit::new(&w0, &drift, brake).unwrap();
            for h in [1e-9, 1e-3, 0.1, 0.5] {
                // The inverse of the time is exact to rounding...
                let back = p.time_at(p.angle_at(h));
                assert!((back - h).abs() <= 4.0 * f64::EPSILON * h, "{h} {back}");
            }
            // ... and an angle read off the velocity gives its time back (a direction's
            // rounding is 1e-16 of a radian, and the angle turns at A sin(psi) / |w|).
            for h in [0.1, 0.5] {
                let s = p.at(h);
                let back = p.time_at_angle(s.w.x / s.w.norm());
                assert!((back - h).abs() < 1e-12, "{h} {back}");
            }
        }
    }

    #[test]
    fn not_a_pursuit_along_the_drift_without_drift_or_brake() {
        let e = Vector3::new(1.0, 0.0, 0.0);
        assert!(Pursuit::new(&(e * 2.0), &e, 1.0).is_none());
        assert!(Pursuit::new(&(e * -2.0), &e, 1.0).is_none());
        assert!(Pursuit::new(&Vector3::y(), &Vector3::zeros(), 1.0).is_none());
        assert!(Pursuit::new(&Vector3::y(), &e, 0.0).is_none());
        assert!(Pursuit::new(&Vector3::zeros(), &e, 1.0).is_none());
        assert!(Pursuit::new(&Vector3::y(), &(e * 1e-13), 1.0).is_none());
    }
}
