//! The one place where rapier's glam types (in `f32` or `f64`, see [`crate::rapier`]) and
//! the model's nalgebra `f64` types meet. Everything the adapter computes is `f64`;
//! values go back to rapier's precision only when written into rapier or handed to parry.

use crate::rapier::math::{Pose, Real, Rotation, Vector};
use nalgebra::{Isometry3, Matrix3, Quaternion, Translation3, UnitQuaternion, Vector3};

/// A rapier scalar as `f64` (exact: `f32` widens losslessly).
#[inline]
#[allow(clippy::unnecessary_cast)]
pub(crate) fn to_f64(x: Real) -> f64 {
    x as f64
}

/// An `f64` as a rapier scalar (rounded to nearest in an `f32` build).
#[inline]
#[allow(clippy::unnecessary_cast)]
pub(crate) fn to_real(x: f64) -> Real {
    x as Real
}

/// glam vector -> nalgebra `f64` vector.
#[inline]
pub(crate) fn vec_to_na(v: Vector) -> Vector3<f64> {
    Vector3::new(to_f64(v.x), to_f64(v.y), to_f64(v.z))
}

/// nalgebra `f64` vector -> glam vector.
#[inline]
pub(crate) fn vec_from_na(v: &Vector3<f64>) -> Vector {
    Vector::new(to_real(v.x), to_real(v.y), to_real(v.z))
}

/// glam quaternion -> nalgebra unit quaternion (renormalised in `f64`).
#[inline]
pub(crate) fn rot_to_na(q: Rotation) -> UnitQuaternion<f64> {
    UnitQuaternion::from_quaternion(Quaternion::new(
        to_f64(q.w),
        to_f64(q.x),
        to_f64(q.y),
        to_f64(q.z),
    ))
}

/// nalgebra unit quaternion -> glam quaternion.
#[inline]
pub(crate) fn rot_from_na(q: &UnitQuaternion<f64>) -> Rotation {
    let q = q.quaternion();
    Rotation::from_xyzw(to_real(q.i), to_real(q.j), to_real(q.k), to_real(q.w))
}

/// glam pose -> nalgebra isometry.
#[inline]
pub(crate) fn pose_to_na(p: &Pose) -> Isometry3<f64> {
    Isometry3::from_parts(
        Translation3::from(vec_to_na(p.translation)),
        rot_to_na(p.rotation),
    )
}

/// nalgebra isometry -> glam pose.
#[inline]
pub(crate) fn pose_from_na(p: &Isometry3<f64>) -> Pose {
    Pose::from_parts(vec_from_na(&p.translation.vector), rot_from_na(&p.rotation))
}

/// A diagonal matrix from a glam vector (principal inertia values).
#[inline]
pub(crate) fn diag_to_na(v: Vector) -> Matrix3<f64> {
    Matrix3::from_diagonal(&vec_to_na(v))
}
