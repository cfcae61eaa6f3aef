//! The general form's inputs and outputs: a body, its velocity, the contact, the
//! material, the chosen law, and the resolved impact. All vectors are in one
//! world frame of the caller's choosing; nothing here assumes an "up" axis.

use super::error::{ModelError, check_coefficients, check_tangential_restitution, finite, finite3};
use nalgebra::{Matrix3, Vector3};

/// The inertial properties of the impacting body, in the world frame.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(
    feature = "serde-serialize",
    derive(serde::Serialize, serde::Deserialize)
)]
pub struct Body {
    /// Mass `m` (kg), finite and `> 0`.
    pub mass: f64,
    /// World-frame inverse inertia tensor `I_w^-1` about the centre of mass (1/(kg m^2)):
    /// symmetric positive semi-definite. A zero row/column means the body cannot rotate
    /// about that axis (infinite inertia, a locked rotation); the zero matrix is a body
    /// that does not rotate at all.
    pub inv_inertia: Matrix3<f64>,
}

impl Body {
    /// A body of mass `mass` (kg) and world-frame inverse inertia tensor `inv_inertia`
    /// (1/(kg m^2)), as the fields say; checked by [`Body::validate`].
    pub fn new(mass: f64, inv_inertia: Matrix3<f64>) -> Self {
        Self { mass, inv_inertia }
    }

    /// A body with an isotropic inertia `inertia` (kg m^2), such as a sphere or a cube.
    pub fn isotropic(mass: f64, inertia: f64) -> Self {
        Self {
            mass,
            inv_inertia: Matrix3::from_diagonal_element(1.0 / inertia),
        }
    }

    /// A fixed or kinematic body in an impact between two bodies ([`super::resolve_pair`]):
    /// infinite mass and inertia (zero inverse inertia), so that no impulse changes its
    /// velocity. It carries no kinetic energy in the model's results (its motion is
    /// prescribed). [`super::resolve`] refuses it as the body hitting the ground
    /// (`body.mass` not finite).
    pub fn fixed() -> Self {
        Self {
            mass: f64::INFINITY,
            inv_inertia: Matrix3::zeros(),
        }
    }

    /// Is this [`Body::fixed`]: infinite mass and zero inverse inertia?
    pub fn is_fixed(&self) -> bool {
        self.mass == f64::INFINITY && self.inv_inertia == Matrix3::zeros()
    }

    /// A body from a world-frame inertia tensor (kg m^2), which must be symmetric
    /// positive definite; it is inverted here, once.
    pub fn from_inertia(mass: f64, inertia: Matrix3<f64>) -> Result<Self, ModelError> {
        if !inertia.iter().all(|c| c.is_finite()) {
            return Err(ModelError::NotFinite { what: "inertia" });
        }
        let chol =
            nalgebra::Cholesky::new(inertia).ok_or(ModelError::NotPositiveSemiDefiniteInertia)?;
        let body = Self {
            mass,
            inv_inertia: chol.inverse(),
        };
        body.validate()?;
        Ok(body)
    }

    /// Checks the mass and the inverse inertia tensor (finite, symmetric, PSD).
    pub fn validate(&self) -> Result<(), ModelError> {
        finite(self.mass, "body.mass")?;
        if self.mass <= 0.0 {
            return Err(ModelError::NonPositiveMass(self.mass));
        }
        let a = &self.inv_inertia;
        // One sum is finite iff every entry is (a NaN or an infinity propagates).
        if !a.iter().sum::<f64>().is_finite() && !a.iter().all(|c| c.is_finite()) {
            return Err(ModelError::NotFinite {
                what: "body.inv_inertia",
            });
        }
        let diag_ok = a.m11 >= 0.0 && a.m22 >= 0.0 && a.m33 >= 0.0;
        if a.m12 == 0.0
            && a.m13 == 0.0
            && a.m23 == 0.0
            && a.m21 == 0.0
            && a.m31 == 0.0
            && a.m32 == 0.0
        {
            // Diagonal (isotropic, principal frame): PSD iff the diagonal is >= 0.
            return if diag_ok {
                Ok(())
            } else {
                Err(ModelError::NotPositiveSemiDefiniteInertia)
            };
        }
        // The entries are finite here, so plain comparisons take the maxima (no NaN
        // handling needed); the largest magnitude of all nine entries is the scale.
        let larger = |x: f64, y: f64| if x > y { x } else { y };
        let scale = larger(
            larger(
                larger(a.m11.abs(), a.m22.abs()),
                larger(a.m33.abs(), a.m12.abs()),
            ),
            larger(
                larger(a.m21.abs(), a.m13.abs()),
                larger(larger(a.m31.abs(), a.m23.abs()), a.m32.abs()),
            ),
        );
        let asym = larger(
            larger((a.m12 - a.m21).abs(), (a.m13 - a.m31).abs()),
            (a.m23 - a.m32).abs(),
        );
        if asym > 1e-9 * scale {
            return Err(ModelError::AsymmetricInertia(asym / scale));
        }
        // Positive semi-definite iff every principal minor is >= 0 (for a symmetric
        // matrix). Rounding makes a singular PSD tensor's minors slightly negative,
        // so each minor is compared with the size of its terms.
        let eps = 1e-12;
        let m2 = |x: f64, y: f64, xy: f64| x * y - xy * xy >= -eps * (x * y + xy * xy);
        let minors2 = m2(a.m11, a.m22, a.m12) && m2(a.m11, a.m33, a.m13) && m2(a.m22, a.m33, a.m23);
        // The determinant by cofactors of the first row.
        let det = a.m11 * (a.m22 * a.m33 - a.m32 * a.m23) - a.m12 * (a.m21 * a.m33 - a.m31 * a.m23)
            + a.m13 * (a.m21 * a.m32 - a.m31 * a.m22);
        let det_ok = det >= -eps * scale * scale * scale;
        if !(diag_ok && minors2 && det_ok) {
            return Err(ModelError::NotPositiveSemiDefiniteInertia);
        }
        Ok(())
    }

    /// The part `w*` of the angular velocity `w` that carries its angular momentum about the
    /// unit axis `n`, `n . I w`, with the least rotational energy, and that energy (J): `w* =
    /// P n (n . I w) / (n . I n)`, `P` the projection on the axes the body can turn about and
    /// `I` its inertia there (the inverse of `I^-1` on them, as [`Self::kinetic_energy`] takes
    /// it). The rest of `w` carries no momentum about `n`, and the two energies add up
    /// (`w* . I (w - w*) = 0`). Zero for a body that cannot turn about `n` at all.
    pub fn spin_about(&self, n: &Vector3<f64>, w: &Vector3<f64>) -> (Vector3<f64>, f64) {
        let Some((inertia, projection)) = rotatable_axes(&self.inv_inertia) else {
            return (Vector3::zeros(), 0.0);
        };
        let (i_n, p_n) = (inertia * n, projection * n);
        let n_i_n = n.dot(&i_n);
        if n_i_n.is_nan() || n_i_n <= 0.0 {
            return (Vector3::zeros(), 0.0);
        }
        let momentum = i_n.dot(w);
        (p_n * (momentum / n_i_n), 0.5 * momentum * momentum / n_i_n)
    }

    /// The part of the angular velocity `w` about the axes the body cannot turn about: its
    /// projection on the null space of `I^-1` (a locked rotation, infinite inertia). It moves
    /// the contact point, but no impulse changes it and [`Self::kinetic_energy`] gives it no
    /// energy: an impulse's work against it goes to whatever holds the axis. The null space
    /// is found as [`Self::kinetic_energy`] finds it: the diagonal's zero entries for a
    /// diagonal `I^-1`, else as `rotatable_axes` says.
    pub fn locked_spin(&self, w: &Vector3<f64>) -> Vector3<f64> {
        let a = &self.inv_inertia;
        if a.m12 == 0.0 && a.m13 == 0.0 && a.m23 == 0.0 {
            let locked = |ai: f64, wi: f64| if ai > 0.0 { 0.0 } else { wi };
            return Vector3::new(locked(a.m11, w.x), locked(a.m22, w.y), locked(a.m33, w.z));
        }
        match rotatable_axes(a) {
            Some((_, projection)) => w - projection * w,
            None => *w,
        }
    }

    /// Kinetic energy `1/2 m |v|^2 + 1/2 w . I_w w` (J). The rotational term is computed
    /// by solving with the inverse inertia on the axes where the body can rotate. Zero for
    /// a [`Body::fixed`] (prescribed motion).
    pub fn kinetic_energy(&self, velocity: &BodyVelocity) -> f64 {
        if self.is_fixed() {
            return 0.0;
        }
        0.5 * self.mass * velocity.linear.norm_squared()
            + 0.5 * rotational_energy(&self.inv_inertia, &velocity.angular)
    }
}

/// `I^-1` is taken as invertible when its determinant exceeds this times the cube of its
/// largest diagonal entry; otherwise its eigen-decomposition is used.
const INVERTIBLE: f64 = 1e-9;
/// An eigenvalue of `I^-1` at most this times its largest diagonal entry is a null axis: the
/// body cannot turn about it.
const NULL_EIGENVALUE: f64 = 1e-12;

/// The inertia `I` on the axes a body of inverse inertia `a` can turn about (the inverse of
/// `a` there, zero on its null axes) and the projection `P` on those axes: `a` inverted and
/// the identity when its determinant passes [`INVERTIBLE`], else from its eigen-decomposition
/// without the eigenvalues [`NULL_EIGENVALUE`] takes as zero. `None` for a body that turns
/// about no axis (or an `a` that is not finite).
fn rotatable_axes(a: &Matrix3<f64>) -> Option<(Matrix3<f64>, Matrix3<f64>)> {
    let scale = a.m11.max(a.m22).max(a.m33);
    if scale.is_nan() || scale <= 0.0 {
        return None;
    }
    if a.determinant() > INVERTIBLE * scale * scale * scale {
        if let Some(inertia) = a.try_inverse() {
            return Some((inertia, Matrix3::identity()));
        }
    }
    let eig = a.symmetric_eigen();
    let (mut inertia, mut projection) = (Matrix3::zeros(), Matrix3::zeros());
    for k in 0..3 {
        let lambda = eig.eigenvalues[k];
        if lambda > NULL_EIGENVALUE * scale {
            let e = eig.eigenvectors.column(k);
            let outer = e * e.transpose();
            inertia += outer / lambda;
            projection += outer;
        }
    }
    Some((inertia, projection))
}

/// `1/2 w . I w` given `I^-1` (J, without the 1/2): `w . I w = w . (I^-1)^-1 w`.
/// With a singular `I^-1` (locked rotations) only the rotatable part of `w` carries
/// energy; a pseudo-inverse on the symmetric eigen-decomposition gives it.
fn rotational_energy(inv_inertia: &Matrix3<f64>, w: &Vector3<f64>) -> f64 {
    if w.norm_squared() == 0.0 {
        return 0.0;
    }
    let a = inv_inertia;
    if a.m12 == 0.0 && a.m13 == 0.0 && a.m23 == 0.0 {
        // Diagonal: isotropic bodies and bodies in their principal frame.
        let term = |ai: f64, wi: f64| if ai > 0.0 { wi * wi / ai } else { 0.0 };
        return term(a.m11, w.x) + term(a.m22, w.y) + term(a.m33, w.z);
    }
    // Symmetric 3x3 solve by the adjugate: w . adj(A) w / det(A).
    let c11 = a.m22 * a.m33 - a.m23 * a.m23;
    let c22 = a.m11 * a.m33 - a.m13 * a.m13;
    let c33 = a.m11 * a.m22 - a.m12 * a.m12;
    let c12 = a.m13 * a.m23 - a.m12 * a.m33;
    let c13 = a.m12 * a.m23 - a.m13 * a.m22;
    let c23 = a.m12 * a.m13 - a.m11 * a.m23;
    let det = a.m11 * c11 + a.m12 * c12 + a.m13 * c13;
    let scale = a.m11.max(a.m22).max(a.m33);
    if det > INVERTIBLE * scale * scale * scale {
        let quad = c11 * w.x * w.x
            + c22 * w.y * w.y
            + c33 * w.z * w.z
            + 2.0 * (c12 * w.x * w.y + c13 * w.x * w.z + c23 * w.y * w.z);
        return quad / det;
    }
    // Singular (locked rotations), or nearly: the pseudo-inverse on the rotatable axes.
    rotatable_axes(a).map_or(0.0, |(inertia, _)| w.dot(&(inertia * w)))
}

/// Linear and angular velocity of a body's centre of mass, world frame.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[cfg_attr(
    feature = "serde-serialize",
    derive(serde::Serialize, serde::Deserialize)
)]
pub struct BodyVelocity {
    /// Velocity of the centre of mass (m/s).
    pub linear: Vector3<f64>,
    /// Angular velocity (rad/s).
    pub angular: Vector3<f64>,
}

/// The contact between the body and the ground, world frame.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(
    feature = "serde-serialize",
    derive(serde::Serialize, serde::Deserialize)
)]
pub struct Contact {
    /// Unit normal `n`, pointing from the ground into the body. `u.n < 0` approaches.
    pub normal: Vector3<f64>,
    /// Offset `r = A - B` from the body's centre of mass `B` to the contact point `A` (m).
    pub offset: Vector3<f64>,
    /// Velocity of the ground's material point at `A` (m/s): zero for fixed ground,
    /// the platform's point velocity for a moving (kinematic) ground.
    pub ground_velocity: Vector3<f64>,
}

impl Contact {
    /// A contact of unit normal `normal` (from the ground into the body) at `offset` from
    /// the body's centre of mass, on a ground whose material point there moves at
    /// `ground_velocity` (m/s).
    pub fn new(normal: Vector3<f64>, offset: Vector3<f64>, ground_velocity: Vector3<f64>) -> Self {
        Self {
            normal,
            offset,
            ground_velocity,
        }
    }

    /// A contact on a fixed ground.
    pub fn fixed(normal: Vector3<f64>, offset: Vector3<f64>) -> Self {
        Self {
            normal,
            offset,
            ground_velocity: Vector3::zeros(),
        }
    }

    /// Checks the vectors are finite and the normal has unit length (to 1e-6).
    pub fn validate(&self) -> Result<(), ModelError> {
        if !(self.normal.sum() + self.offset.sum() + self.ground_velocity.sum()).is_finite() {
            finite3(&self.normal, "contact.normal")?;
            finite3(&self.offset, "contact.offset")?;
            finite3(&self.ground_velocity, "contact.ground_velocity")?;
        }
        let len2 = self.normal.norm_squared();
        // |len - 1| <= 1e-6, compared on the square to avoid the root.
        if (len2 - 1.0).abs() > 2e-6 {
            let len = len2.sqrt();
            return Err(ModelError::NonUnitNormal(len));
        }
        Ok(())
    }
}

/// The contact's material: Newton's coefficient of restitution, Coulomb's friction and
/// Walton's tangential restitution (Walton's three parameters, see `docs/model.md`).
///
/// Build it with [`Material::new`] (or [`Default`], rapier's collider defaults) and set
/// fields after, or with [`Material::with_tangential_restitution`]: it is
/// `#[non_exhaustive]`, so that a coefficient added later breaks no caller. A restitution
/// that depends on the impact speed is a [`super::RestitutionCurve`], evaluated at the
/// contact's approach speed into [`Material::restitution`] before the impact is resolved.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(
    feature = "serde-serialize",
    derive(serde::Serialize, serde::Deserialize)
)]
#[non_exhaustive]
pub struct Material {
    /// Coefficient of restitution `e >= 0` (1 = elastic; above 1 adds energy on purpose).
    pub restitution: f64,
    /// Coefficient of friction `mu >= 0`.
    pub friction: f64,
    /// Tangential restitution `beta0` in `[-1, 1]` (default 0): a contact that grips ends the
    /// impact with its tangential contact velocity at `-beta0` times the incoming one, if the
    /// friction cone allows it (0: it stops, Coulomb's stick; 1: it reverses, a superball;
    /// -1: friction leaves it alone). Otherwise the contact slips, as with `beta0 = 0`.
    #[cfg_attr(feature = "serde-serialize", serde(default))]
    pub tangential_restitution: f64,
}

impl Default for Material {
    /// rapier's collider defaults: `e = 0`, `mu = 0.5`.
    fn default() -> Self {
        Self::new(0.0, 0.5)
    }
}

impl Material {
    /// Restitution `e` and friction `mu` (checked by [`Material::validate`], and by the
    /// model when it resolves an impact).
    pub fn new(restitution: f64, friction: f64) -> Self {
        Self {
            restitution,
            friction,
            tangential_restitution: 0.0,
        }
    }

    /// The same material with Walton's tangential restitution `beta0` (in `[-1, 1]`).
    pub fn with_tangential_restitution(self, beta0: f64) -> Self {
        Self {
            tangential_restitution: beta0,
            ..self
        }
    }

    /// Checks `e >= 0`, `mu >= 0`, `beta0` in `[-1, 1]`, all finite.
    pub fn validate(&self) -> Result<(), ModelError> {
        check_coefficients(self.restitution, self.friction)?;
        check_tangential_restitution(self.tangential_restitution)
    }
}

/// Which impact law resolves a contact. Accuracy costs time; the user chooses.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
#[cfg_attr(
    feature = "serde-serialize",
    derive(serde::Serialize, serde::Deserialize)
)]
pub enum Law {
    /// The document's law, corrected and generalised: Newton restitution, stick if the
    /// sticking impulse is inside the friction cone, else slip along the initial slip
    /// direction (eqs. 10-19). Closed form, fastest. Can gain energy (`docs/model.md`, "Where the
    /// document's law is not physical") and reports it in [`Impact::ke_after`]; a jam is
    /// [`ModelError::Jam`].
    Document,
    /// Impulse-space integration (Routh) with Stronge's energetic restitution: slip may
    /// stop, stick, reverse and swerve. Never gains energy for `e <= 1`: its impulse does no
    /// positive work at the contact, `P . (u1 + u2) / 2`, which is the body's energy change
    /// on a still ground without spin about a locked axis (`docs/model.md`, "Energy").
    Consistent,
    /// `Document`, falling back to `Consistent` exactly where the document's result is
    /// unphysical (see [`Fallback`]).
    #[default]
    Guarded,
}

/// What the contact did during the impact.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[cfg_attr(
    feature = "serde-serialize",
    derive(serde::Serialize, serde::Deserialize)
)]
pub enum Regime {
    /// Case A of the document: the contact point does not slip at the end.
    Stick,
    /// Case B of the document: the contact point slips throughout.
    Slip,
    /// (`Consistent`) slip that stopped during the impact, after which the contact stuck.
    SlipThenStick,
    /// The contact is separating or resting (`u.n >= 0`): no impulse.
    Separating,
}

/// Why the `Guarded` law left the document's result for the consistent one.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[cfg_attr(
    feature = "serde-serialize",
    derive(serde::Serialize, serde::Deserialize)
)]
#[non_exhaustive]
pub enum Fallback {
    /// The document's normal impulse would pull the body into the ground.
    PullingNormalImpulse,
    /// The slip denominator is `<= 0` (Painleve-like jam).
    Jam,
    /// Friction along the initial slip direction overshot: the slip reversed (beyond
    /// `-beta0` times the initial slip, which a tangential restitution `beta0 > 0` allows).
    SlipReversal,
    /// The document's result gained kinetic energy with `e <= 1`.
    EnergyGain,
}

/// A resolved impact: the impulse, the velocities after, and what happened.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(
    feature = "serde-serialize",
    derive(serde::Serialize, serde::Deserialize)
)]
pub struct Impact {
    /// Impulse on the body at the contact point, world frame (N s).
    pub impulse: Vector3<f64>,
    /// Normal impulse `P.n >= 0` (N s).
    pub normal_impulse: f64,
    /// Tangential (friction) impulse `P - (P.n) n` (N s).
    pub tangent_impulse: Vector3<f64>,
    /// Velocity of the body after the impact.
    pub velocity: BodyVelocity,
    /// Stick, slip, or the sequence of the two.
    pub regime: Regime,
    /// The law that produced this result (`Document` or `Consistent`; never `Guarded`).
    pub law: Law,
    /// Set when `Guarded` fell back to `Consistent`, with the reason.
    pub fallback: Option<Fallback>,
    /// Kinetic energy before the impact (J, [`Body::kinetic_energy`]: a spin about a locked
    /// axis holds none).
    pub ke_before: f64,
    /// Kinetic energy after the impact (J): that of [`Self::velocity`] to rounding, computed
    /// as `ke_before` plus the impulse's work on the body.
    pub ke_after: f64,
}

impl Impact {
    /// `ke_after - ke_before` (J): negative when the impact dissipates energy.
    pub fn energy_change(&self) -> f64 {
        self.ke_after - self.ke_before
    }
}
