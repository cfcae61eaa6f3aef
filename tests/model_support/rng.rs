//! SplitMix64: a small seeded generator, so every run draws the same numbers. Shared by the
//! `model_*` tests (through `model_support`), `scene_robustness` and the benches (by `#[path]`:
//! a bench cannot import a test module).
#![allow(dead_code)]

use rapier_impact::na::{Matrix3, Rotation3, Unit, Vector3};

/// SplitMix64's increment (the golden gamma).
const GAMMA: u64 = 0x9E37_79B9_7F4A_7C15;

/// SplitMix64: small, seeded, reproducible.
pub struct Rng(u64);

impl Rng {
    pub fn new(seed: u64) -> Self {
        Self(seed)
    }

    /// The generator `examples/common` makes from `seed` (the seed mixed with the
    /// increment), so a test can replay an example's scene.
    pub fn like_examples(seed: u64) -> Self {
        Self(seed ^ GAMMA)
    }

    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(GAMMA);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in `[0, 1)`.
    pub fn unit(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    }

    pub fn uniform(&mut self, a: f64, b: f64) -> f64 {
        a + (b - a) * self.unit()
    }

    /// `10^x` with `x` uniform in `[log10 a, log10 b]`.
    pub fn log_uniform(&mut self, a: f64, b: f64) -> f64 {
        10f64.powf(self.uniform(a.log10(), b.log10()))
    }

    pub fn vector(&mut self, a: f64) -> Vector3<f64> {
        Vector3::new(
            self.uniform(-a, a),
            self.uniform(-a, a),
            self.uniform(-a, a),
        )
    }

    /// Uniform on the unit sphere.
    pub fn unit_vector(&mut self) -> Vector3<f64> {
        loop {
            let v = self.vector(1.0);
            let n2 = v.norm_squared();
            if n2 > 1e-4 && n2 <= 1.0 {
                return v / n2.sqrt();
            }
        }
    }

    /// Uniform on the unit sphere, by rejection of the draws of norm outside `(0.1, 1]`: the
    /// sequence the benches' batches and `model_swerve_accuracy`'s impacts were drawn with.
    pub fn direction(&mut self) -> Vector3<f64> {
        loop {
            let v = self.vector(1.0);
            let n = v.norm();
            if n > 0.1 && n <= 1.0 {
                return v / n;
            }
        }
    }

    /// A uniformly random rotation.
    pub fn rotation(&mut self) -> Matrix3<f64> {
        let axis = Unit::new_normalize(self.unit_vector());
        let angle = self.uniform(-std::f64::consts::PI, std::f64::consts::PI);
        *Rotation3::from_axis_angle(&axis, angle).matrix()
    }
}
