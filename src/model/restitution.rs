//! Restitution that depends on the impact speed: a curve `e(v_n)` over the normal approach
//! speed of the contact point, given as data so that a configuration holding one stays
//! serializable.
//!
//! The curve is piecewise linear through its points, constant before the first and after
//! the last. Two points at the same speed make a step: below that speed the first one's `e`
//! holds, from it on the second one's (so a threshold below which nothing bounces is
//! `[(v0, 0), (v0, e)]`, [`RestitutionCurve::threshold`]).

use super::error::ModelError;

/// A coefficient of restitution as a function of the normal approach speed `v_n >= 0` (m/s)
/// of the contact point: piecewise linear through `(speed, e)` points, constant beyond the
/// first and the last.
///
/// ```
/// use rapier_impact::model::RestitutionCurve;
///
/// // A ball that does not bounce below 0.3 m/s, then bounces less as the impact gets harder.
/// let curve = RestitutionCurve::new(vec![(0.3, 0.0), (0.3, 0.9), (10.0, 0.6)]).unwrap();
/// assert_eq!(curve.at(0.1), 0.0);
/// assert_eq!(curve.at(0.3), 0.9);
/// assert!((curve.at(5.15) - 0.75).abs() < 1e-12);
/// assert_eq!(curve.at(20.0), 0.6);
/// ```
#[derive(Clone, Debug, PartialEq)]
#[cfg_attr(
    feature = "serde-serialize",
    derive(serde::Serialize, serde::Deserialize),
    serde(try_from = "Vec<(f64, f64)>", into = "Vec<(f64, f64)>")
)]
pub struct RestitutionCurve {
    /// `(speed, e)` by non-decreasing speed; at least one; all finite and `>= 0`.
    points: Vec<(f64, f64)>,
}

impl RestitutionCurve {
    /// The curve through `points`, each `(speed in m/s, e)`: at least one point, speeds and
    /// `e` finite and `>= 0`, speeds in non-decreasing order (two equal speeds make a step).
    pub fn new(points: impl Into<Vec<(f64, f64)>>) -> Result<Self, ModelError> {
        let points = points.into();
        if points.is_empty() {
            return Err(ModelError::EmptyRestitutionCurve);
        }
        let mut previous = 0.0;
        for (index, &(speed, restitution)) in points.iter().enumerate() {
            let fine = speed.is_finite()
                && restitution.is_finite()
                && speed >= previous
                && restitution >= 0.0;
            if !fine {
                return Err(ModelError::InvalidCurvePoint {
                    index,
                    speed,
                    restitution,
                });
            }
            previous = speed;
        }
        Ok(Self { points })
    }

    /// No bounce below `speed` (m/s), `restitution` from it on: the threshold engines apply
    /// (Box2D, Jolt and Avian at 1 m/s, PhysX at 2 m/s, Bullet at 0.2 m/s).
    pub fn threshold(speed: f64, restitution: f64) -> Result<Self, ModelError> {
        Self::new(vec![(speed, 0.0), (speed, restitution)])
    }

    /// The points, `(speed, e)` by non-decreasing speed.
    pub fn points(&self) -> &[(f64, f64)] {
        &self.points
    }

    /// The coefficient of restitution at the normal approach speed `speed` (m/s).
    pub fn at(&self, speed: f64) -> f64 {
        let points = &self.points;
        // The points at or below `speed`: the segment starts at the last of them.
        let above = points.partition_point(|&(v, _)| v <= speed);
        match above {
            0 => points[0].1,
            n if n == points.len() => points[n - 1].1,
            n => {
                let ((v0, e0), (v1, e1)) = (points[n - 1], points[n]);
                // v0 <= speed < v1, so the segment has a length.
                e0 + (e1 - e0) * ((speed - v0) / (v1 - v0))
            }
        }
    }

    /// The largest `e` the curve reaches (at one of its points).
    pub fn max(&self) -> f64 {
        self.points.iter().fold(0.0, |m, &(_, e)| m.max(e))
    }
}

impl TryFrom<Vec<(f64, f64)>> for RestitutionCurve {
    type Error = ModelError;

    fn try_from(points: Vec<(f64, f64)>) -> Result<Self, ModelError> {
        Self::new(points)
    }
}

impl From<RestitutionCurve> for Vec<(f64, f64)> {
    fn from(curve: RestitutionCurve) -> Self {
        curve.points
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn interpolates_and_holds_the_ends() {
        let c = RestitutionCurve::new(vec![(1.0, 0.8), (3.0, 0.4)]).unwrap();
        assert_eq!(c.at(0.0), 0.8);
        assert_eq!(c.at(1.0), 0.8);
        assert!((c.at(2.0) - 0.6).abs() <= 1e-15);
        assert_eq!(c.at(3.0), 0.4);
        assert_eq!(c.at(f64::INFINITY), 0.4);
        let one = RestitutionCurve::new(vec![(2.0, 0.5)]).unwrap();
        assert_eq!((one.at(0.0), one.at(9.0)), (0.5, 0.5));
    }

    #[test]
    fn a_threshold_is_a_step() {
        let c = RestitutionCurve::threshold(0.5, 0.7).unwrap();
        assert_eq!(c.at(0.4999), 0.0);
        assert_eq!(c.at(0.5), 0.7);
        assert_eq!(c.at(4.0), 0.7);
        assert_eq!(c.max(), 0.7);
    }

    #[test]
    fn refuses_bad_points() {
        assert_eq!(
            RestitutionCurve::new(Vec::new()),
            Err(ModelError::EmptyRestitutionCurve)
        );
        for (points, index) in [
            (vec![(1.0, 0.5), (0.5, 0.5)], 1),
            (vec![(-0.1, 0.5)], 0),
            (vec![(0.0, -0.5)], 0),
            (vec![(0.0, 0.5), (f64::NAN, 0.5)], 1),
            (vec![(0.0, f64::INFINITY)], 0),
        ] {
            match RestitutionCurve::new(points) {
                Err(ModelError::InvalidCurvePoint { index: i, .. }) => assert_eq!(i, index),
                other => panic!("{other:?}"),
            }
        }
    }
}
