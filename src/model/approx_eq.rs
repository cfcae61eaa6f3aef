//! `approx`'s comparisons for the model's value types, as nalgebra's vectors have them: two
//! velocities or two impacts are equal to a tolerance when every number is (vectors compared
//! as nalgebra compares them) and every discrete field (regime, law, fallback) is the same.

use super::pair::PairImpact;
use super::types::{BodyVelocity, Impact};
use approx::{AbsDiffEq, RelativeEq, UlpsEq};

impl AbsDiffEq for BodyVelocity {
    type Epsilon = f64;

    fn default_epsilon() -> f64 {
        f64::EPSILON
    }

    fn abs_diff_eq(&self, other: &Self, epsilon: f64) -> bool {
        self.linear.abs_diff_eq(&other.linear, epsilon)
            && self.angular.abs_diff_eq(&other.angular, epsilon)
    }
}

impl RelativeEq for BodyVelocity {
    fn default_max_relative() -> f64 {
        f64::EPSILON
    }

    fn relative_eq(&self, other: &Self, epsilon: f64, max_relative: f64) -> bool {
        self.linear
            .relative_eq(&other.linear, epsilon, max_relative)
            && self
                .angular
                .relative_eq(&other.angular, epsilon, max_relative)
    }
}

impl UlpsEq for BodyVelocity {
    fn default_max_ulps() -> u32 {
        4
    }

    fn ulps_eq(&self, other: &Self, epsilon: f64, max_ulps: u32) -> bool {
        self.linear.ulps_eq(&other.linear, epsilon, max_ulps)
            && self.angular.ulps_eq(&other.angular, epsilon, max_ulps)
    }
}

/// The numbers of an impact, in one order, for the comparisons below.
macro_rules! impact_numbers {
    ($compare:ident, $a:expr, $b:expr, $($arg:expr),*) => {
        $a.impulse.$compare(&$b.impulse, $($arg),*)
            && $a.normal_impulse.$compare(&$b.normal_impulse, $($arg),*)
            && $a.tangent_impulse.$compare(&$b.tangent_impulse, $($arg),*)
            && $a.ke_before.$compare(&$b.ke_before, $($arg),*)
            && $a.ke_after.$compare(&$b.ke_after, $($arg),*)
            && ($a.regime, $a.law, $a.fallback) == ($b.regime, $b.law, $b.fallback)
    };
}

impl AbsDiffEq for Impact {
    type Epsilon = f64;

    fn default_epsilon() -> f64 {
        f64::EPSILON
    }

    fn abs_diff_eq(&self, other: &Self, epsilon: f64) -> bool {
        impact_numbers!(abs_diff_eq, self, other, epsilon)
            && self.velocity.abs_diff_eq(&other.velocity, epsilon)
    }
}

impl RelativeEq for Impact {
    fn default_max_relative() -> f64 {
        f64::EPSILON
    }

    fn relative_eq(&self, other: &Self, epsilon: f64, max_relative: f64) -> bool {
        impact_numbers!(relative_eq, self, other, epsilon, max_relative)
            && self
                .velocity
                .relative_eq(&other.velocity, epsilon, max_relative)
    }
}

impl AbsDiffEq for PairImpact {
    type Epsilon = f64;

    fn default_epsilon() -> f64 {
        f64::EPSILON
    }

    fn abs_diff_eq(&self, other: &Self, epsilon: f64) -> bool {
        impact_numbers!(abs_diff_eq, self, other, epsilon)
            && self.a.abs_diff_eq(&other.a, epsilon)
            && self.b.abs_diff_eq(&other.b, epsilon)
    }
}

impl RelativeEq for PairImpact {
    fn default_max_relative() -> f64 {
        f64::EPSILON
    }

    fn relative_eq(&self, other: &Self, epsilon: f64, max_relative: f64) -> bool {
        impact_numbers!(relative_eq, self, other, epsilon, max_relative)
            && self.a.relative_eq(&other.a, epsilon, max_relative)
            && self.b.relative_eq(&other.b, epsilon, max_relative)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::{assert_relative_eq, assert_relative_ne};
    use nalgebra::Vector3;

    #[test]
    fn velocities_compare_to_a_tolerance() {
        let a = BodyVelocity {
            linear: Vector3::new(1.0, -2.0, 3.0),
            angular: Vector3::new(0.5, 0.0, -4.0),
        };
        let mut b = a;
        b.angular.z += 1e-13;
        assert_relative_eq!(a, b, max_relative = 1e-12);
        assert_relative_ne!(a, b, max_relative = 1e-15);
        assert!(a.abs_diff_eq(&b, 1e-12) && !a.abs_diff_eq(&b, 1e-14));
        assert!(a.ulps_eq(&a, 0.0, 0));
    }
}
