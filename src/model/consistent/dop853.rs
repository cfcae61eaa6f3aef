//! Dormand and Prince's 8th-order Runge-Kutta method (DOP853: Hairer, Norsett & Wanner,
//! "Solving ODEs I", 2nd ed., II.10; coefficients of Hairer's `dop853`): one step with its
//! 5th- and 3rd-order error estimates, the 7th-order dense output over an accepted step,
//! and the root of an event on that dense output.

use super::swerve::{Flow, Z};

/// `z + h * sum(c_i k_i)` over the stages `i` listed with their coefficients `c_i` (the
/// step's twelve, or the dense output's sixteen).
#[inline(always)]
fn stage<const N: usize, const M: usize>(z: &Z, h: f64, c: &[(usize, f64); N], k: &[Z; M]) -> Z {
    let mut out = *z;
    for j in 0..4 {
        let mut acc = 0.0;
        for &(i, ci) in c {
            acc += ci * k[i][j];
        }
        out[j] += h * acc;
    }
    out
}

/// One step of DOP853 from `z`: the 8th-order solution, its two error estimates, the
/// rate at its end and its stages.
pub(super) struct Step {
    /// The 8th-order solution at the step's end.
    pub(super) z: Z,
    /// The 5th-order error vector, without the factor `h` (as in Hairer's estimate).
    pub(super) err5: Z,
    /// The 3rd-order error vector, without the factor `h`.
    pub(super) err3: Z,
    /// The rate at the step's end (the next step's first stage, the dense output's 13th).
    pub(super) rate: Z,
    /// The twelve stages, for the dense output.
    pub(super) stages: [Z; 12],
}

/// One step of Dormand and Prince's 8th-order method with 5th- and 3rd-order error
/// estimates (DOP853: Hairer, Norsett & Wanner, "Solving ODEs I", 2nd ed., II.10;
/// coefficients of Hairer's `dop853`) from `z`, whose rate is `k1`, over `h`.
#[inline(always)]
pub(super) fn dop853_step(flow: &Flow, z: &Z, k1: &Z, h: f64) -> Step {
    let mut k = [[0.0; 4]; 12];
    k[0] = *k1;
    k[1] = flow.rate(&stage(z, h, &A2, &k));
    k[2] = flow.rate(&stage(z, h, &A3, &k));
    k[3] = flow.rate(&stage(z, h, &A4, &k));
    k[4] = flow.rate(&stage(z, h, &A5, &k));
    k[5] = flow.rate(&stage(z, h, &A6, &k));
    k[6] = flow.rate(&stage(z, h, &A7, &k));
    k[7] = flow.rate(&stage(z, h, &A8, &k));
    k[8] = flow.rate(&stage(z, h, &A9, &k));
    k[9] = flow.rate(&stage(z, h, &A10, &k));
    k[10] = flow.rate(&stage(z, h, &A11, &k));
    k[11] = flow.rate(&stage(z, h, &A12, &k));
    let z_new = stage(z, h, &B, &k);
    let err5 = stage(&[0.0; 4], 1.0, &E5, &k);
    let err3 = stage(&[0.0; 4], 1.0, &E3, &k);
    let k_new = flow.rate(&z_new);
    Step {
        z: z_new,
        err5,
        err3,
        rate: k_new,
        stages: k,
    }
}

/// DOP853's dense output over one accepted step from `z` (Hairer's contd8): with
/// `x` the fraction of the step, `z(x) = z + x (f0 + (1-x) (f1 + x (f2 + (1-x) (f3 +
/// x (f4 + (1-x) (f5 + x f6))))))`, of order 7.
pub(super) struct Dense {
    pub(super) f: [Z; 7],
}

impl Dense {
    pub(super) fn new(flow: &Flow, z: &Z, z_new: &Z, k: &[Z; 12], k_new: &Z, h: f64) -> Self {
        let mut ext = [[0.0; 4]; 16];
        ext[..12].copy_from_slice(k);
        ext[12] = *k_new;
        ext[13] = flow.rate(&stage(z, h, &A14, &ext));
        ext[14] = flow.rate(&stage(z, h, &A15, &ext));
        ext[15] = flow.rate(&stage(z, h, &A16, &ext));
        let mut f = [[0.0; 4]; 7];
        for j in 0..4 {
            let dz = z_new[j] - z[j];
            f[0][j] = dz;
            f[1][j] = h * ext[0][j] - dz;
            f[2][j] = 2.0 * dz - h * (ext[0][j] + ext[12][j]);
            for (row, d) in [&D4[..], &D5[..], &D6[..], &D7[..]].iter().enumerate() {
                let mut acc = 0.0;
                for &(i, c) in d.iter() {
                    acc += c * ext[i][j];
                }
                f[3 + row][j] = h * acc;
            }
        }
        Self { f }
    }
}

/// The dense-output polynomial with coefficients `f` at `x`, and its derivative in `x`.
#[inline(always)]
fn dense_value(f: &[f64; 7], x: f64) -> (f64, f64) {
    let x1 = 1.0 - x;
    // Horner from the inside out, alternating factors x and 1 - x, with the derivative.
    let (mut y, mut dy) = (f[6] * x, f[6]);
    for (i, &c) in f[..6].iter().enumerate().rev() {
        y += c;
        if i % 2 == 1 {
            (y, dy) = (y * x1, dy * x1 - y);
        } else {
            (y, dy) = (y * x, dy * x + y);
        }
    }
    (y, dy)
}

/// The fraction `x` in `[0, 1]` of the step where `base + p(x)` crosses zero upwards,
/// with `p` the dense-output polynomial with coefficients `f` (`base < 0 <= base +
/// p(1)`): Newton's method, safeguarded by bisection on the bracket.
pub(super) fn dense_root(base: f64, f: &[f64; 7]) -> f64 {
    let (mut lo, mut hi) = (0.0f64, 1.0f64);
    // The secant through the ends as the first guess.
    let end = base + dense_value(f, 1.0).0;
    let mut x = if end > base {
        -base / (end - base)
    } else {
        1.0
    };
    for _ in 0..60 {
        let (p, dp) = dense_value(f, x);
        let v = base + p;
        if v < 0.0 {
            lo = x;
        } else {
            hi = x;
        }
        let newton = if dp > 0.0 { x - v / dp } else { f64::NAN };
        // Converged when Newton's step is at rounding level. Tested before the bracket:
        // at the root the step is a few ulps and may land on the bracket's end just
        // moved to x, where bisecting would throw the converged x away.
        if (newton - x).abs() <= 1e-15 {
            return newton.clamp(lo, hi);
        }
        let next = if newton > lo && newton < hi {
            newton
        } else {
            0.5 * (lo + hi)
        };
        if hi - lo <= 1e-15 {
            return next;
        }
        x = next;
    }
    hi
}

// DOP853 tableau (Hairer's dop853.f, to double precision), nonzero entries only as
// (stage, coefficient): the rows of A (stages 2-12), the weights B, and the error
// weights E5 = b - b5, E3 = b - b3.
const A2: [(usize, f64); 1] = [(0, 0.05260015195876773)];
const A3: [(usize, f64); 2] = [(0, 0.0197250569845379), (1, 0.0591751709536137)];
const A4: [(usize, f64); 2] = [(0, 0.02958758547680685), (2, 0.08876275643042054)];
const A5: [(usize, f64); 3] = [
    (0, 0.2413651341592667),
    (2, -0.8845494793282861),
    (3, 0.924834003261792),
];
const A6: [(usize, f64); 3] = [
    (0, 0.037037037037037035),
    (3, 0.17082860872947386),
    (4, 0.12546768756682242),
];
const A7: [(usize, f64); 4] = [
    (0, 0.037109375),
    (3, 0.17025221101954405),
    (4, 0.06021653898045596),
    (5, -0.017578125),
];
const A8: [(usize, f64); 5] = [
    (0, 0.03709200011850479),
    (3, 0.17038392571223998),
    (4, 0.10726203044637328),
    (5, -0.015319437748624402),
    (6, 0.008273789163814023),
];
const A9: [(usize, f64); 6] = [
    (0, 0.6241109587160757),
    (3, -3.3608926294469414),
    (4, -0.868219346841726),
    (5, 27.59209969944671),
    (6, 20.154067550477894),
    (7, -43.48988418106996),
];
const A10: [(usize, f64); 7] = [
    (0, 0.47766253643826434),
    (3, -2.4881146199716677),
    (4, -0.590290826836843),
    (5, 21.230051448181193),
    (6, 15.279233632882423),
    (7, -33.28821096898486),
    (8, -0.020331201708508627),
];
const A11: [(usize, f64); 8] = [
    (0, -0.9371424300859873),
    (3, 5.186372428844064),
    (4, 1.0914373489967295),
    (5, -8.149787010746927),
    (6, -18.52006565999696),
    (7, 22.739487099350505),
    (8, 2.4936055526796523),
    (9, -3.0467644718982196),
];
const A12: [(usize, f64); 9] = [
    (0, 2.273310147516538),
    (3, -10.53449546673725),
    (4, -2.0008720582248625),
    (5, -17.9589318631188),
    (6, 27.94888452941996),
    (7, -2.8589982771350235),
    (8, -8.87285693353063),
    (9, 12.360567175794303),
    (10, 0.6433927460157636),
];
const B: [(usize, f64); 8] = [
    (0, 0.054293734116568765),
    (5, 4.450312892752409),
    (6, 1.8915178993145003),
    (7, -5.801203960010585),
    (8, 0.3111643669578199),
    (9, -0.1521609496625161),
    (10, 0.20136540080403034),
    (11, 0.04471061572777259),
];
const E5: [(usize, f64); 8] = [
    (0, 0.01312004499419488),
    (5, -1.2251564463762044),
    (6, -0.4957589496572502),
    (7, 1.6643771824549864),
    (8, -0.35032884874997366),
    (9, 0.3341791187130175),
    (10, 0.08192320648511571),
    (11, -0.022355307863886294),
];
const E3: [(usize, f64); 8] = [
    (0, -0.18980075407240762),
    (5, 4.450312892752409),
    (6, 1.8915178993145003),
    (7, -5.801203960010585),
    (8, -0.42268232132379197),
    (9, -0.1521609496625161),
    (10, 0.20136540080403034),
    (11, 0.022651792198360825),
];

// DOP853's dense output (Hairer's dop853.f, contd8): the three extra stages 14-16
// (rows of A, over the twelve stages and the rate at the step's end, stage 13), and
// the coefficients d4-d7 of the interpolant.
const A14: [(usize, f64); 8] = [
    (0, 5.616750228304795e-2),
    (6, 2.535002102166248e-1),
    (7, -2.462390374708025e-1),
    (8, -1.2419142326381637e-1),
    (9, 1.532917982787657e-1),
    (10, 8.20105229563469e-3),
    (11, 7.5678976605457e-3),
    (12, -8.298e-3),
];
const A15: [(usize, f64); 8] = [
    (0, 3.183464816350214e-2),
    (5, 2.8300909672366776e-2),
    (6, 5.354198830743857e-2),
    (7, -5.492374857139099e-2),
    (10, -1.0834732869724932e-4),
    (11, 3.825710908356584e-4),
    (12, -3.4046500868740456e-4),
    (13, 1.413124436746325e-1),
];
const A16: [(usize, f64); 8] = [
    (0, -4.288963015837919e-1),
    (5, -4.697621415361164),
    (6, 7.683421196062599),
    (7, 4.06898981839711),
    (8, 3.567271874552811e-1),
    (12, -1.3990241651590146e-3),
    (13, 2.9475147891527723),
    (14, -9.15095847217987),
];
const D4: [(usize, f64); 12] = [
    (0, -8.428938276109013),
    (5, 5.667149535193778e-1),
    (6, -3.0689499459498917),
    (7, 2.38466765651207),
    (8, 2.1170345824450283),
    (9, -8.71391583777973e-1),
    (10, 2.2404374302607883),
    (11, 6.315787787694688e-1),
    (12, -8.899033645133331e-2),
    (13, 18.148505520854727),
    (14, -9.194632392478356),
    (15, -4.436036387594894),
];
const D5: [(usize, f64); 12] = [
    (0, 10.427508642579134),
    (5, 242.28349177525817),
    (6, 165.20045171727028),
    (7, -374.5467547226902),
    (8, -22.113666853125306),
    (9, 7.733432668472264),
    (10, -30.674084731089398),
    (11, -9.332130526430229),
    (12, 15.697238121770845),
    (13, -31.139403219565178),
    (14, -9.35292435884448),
    (15, 35.81684148639408),
];
const D6: [(usize, f64); 12] = [
    (0, 19.985053242002433),
    (5, -387.0373087493518),
    (6, -189.17813819516758),
    (7, 527.8081592054236),
    (8, -11.573902539959631),
    (9, 6.8812326946963),
    (10, -1.0006050966910838),
    (11, 7.777137798053443e-1),
    (12, -2.778205752353508),
    (13, -60.19669523126412),
    (14, 84.32040550667716),
    (15, 11.99229113618279),
];
const D7: [(usize, f64); 12] = [
    (0, -25.69393346270375),
    (5, -154.18974869023643),
    (6, -231.5293791760455),
    (7, 357.6391179106141),
    (8, 93.40532418362432),
    (9, -37.45832313645163),
    (10, 104.09964950896231),
    (11, 29.840293426660504),
    (12, -43.53345659001114),
    (13, 96.32455395918828),
    (14, -39.17726167561544),
    (15, -149.72683625798564),
];
