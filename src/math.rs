//! The transcendental functions the crate's own `f64` code calls, in one place: the
//! platform's (`std`) by default, or, with the `enhanced-determinism` feature, libm's
//! portable implementations, so that the model and the motion give bitwise the same results
//! on every platform (rapier's and parry's feature of the same name does the same for
//! nalgebra's functions). `sqrt` and the arithmetic are IEEE 754 correctly rounded
//! everywhere and need nothing.

/// `atan2(y, x)` (rad).
#[inline]
pub(crate) fn atan2(y: f64, x: f64) -> f64 {
    #[cfg(feature = "enhanced-determinism")]
    return libm::atan2(y, x);
    #[cfg(not(feature = "enhanced-determinism"))]
    return y.atan2(x);
}

/// `(sin x, cos x)`.
#[inline]
pub(crate) fn sin_cos(x: f64) -> (f64, f64) {
    #[cfg(feature = "enhanced-determinism")]
    return (libm::sin(x), libm::cos(x));
    #[cfg(not(feature = "enhanced-determinism"))]
    return x.sin_cos();
}

/// `sqrt(x^2 + y^2)` without overflow.
#[inline]
pub(crate) fn hypot(x: f64, y: f64) -> f64 {
    #[cfg(feature = "enhanced-determinism")]
    return libm::hypot(x, y);
    #[cfg(not(feature = "enhanced-determinism"))]
    return x.hypot(y);
}

/// `e^x`.
#[inline]
pub(crate) fn exp(x: f64) -> f64 {
    #[cfg(feature = "enhanced-determinism")]
    return libm::exp(x);
    #[cfg(not(feature = "enhanced-determinism"))]
    return x.exp();
}

/// `e^x - 1`, accurate for small `x`.
#[inline]
pub(crate) fn exp_m1(x: f64) -> f64 {
    #[cfg(feature = "enhanced-determinism")]
    return libm::expm1(x);
    #[cfg(not(feature = "enhanced-determinism"))]
    return x.exp_m1();
}

/// The natural logarithm.
#[inline]
pub(crate) fn ln(x: f64) -> f64 {
    #[cfg(feature = "enhanced-determinism")]
    return libm::log(x);
    #[cfg(not(feature = "enhanced-determinism"))]
    return x.ln();
}

#[cfg(all(test, feature = "enhanced-determinism"))]
mod tests {
    /// Under the feature every function is libm's, bit for bit (the platform's `std` may
    /// round differently on another machine; libm does the same everywhere).
    #[test]
    fn every_function_is_libms() {
        let mut x = 0.123_456_789_f64;
        for _ in 0..10_000 {
            x = (x * 3.7 + 0.61).rem_euclid(20.0) - 10.0;
            let y = (x * 1.3).sin();
            assert_eq!(super::atan2(y, x).to_bits(), libm::atan2(y, x).to_bits());
            let (s, c) = super::sin_cos(x);
            assert_eq!(
                (s.to_bits(), c.to_bits()),
                (libm::sin(x).to_bits(), libm::cos(x).to_bits())
            );
            assert_eq!(super::hypot(x, y).to_bits(), libm::hypot(x, y).to_bits());
            assert_eq!(super::exp(x).to_bits(), libm::exp(x).to_bits());
            assert_eq!(
                super::exp_m1(x * 1e-3).to_bits(),
                libm::expm1(x * 1e-3).to_bits()
            );
            assert_eq!(super::ln(x.abs()).to_bits(), libm::log(x.abs()).to_bits());
        }
    }
}
