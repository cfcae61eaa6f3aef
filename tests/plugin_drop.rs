//! A ball dropped on a half-space ground, against the closed forms (docs/model.md, "Closed forms used in the tests"):
//! apexes `e^(2n) h0`, impact times `t_(k+1) = t1 + 2 t1 e (1 - e^k)/(1 - e)`, time to rest
//! `t1 (1 + e)/(1 - e)`; h0 = 1 m, g = 9.81, e = 0.8, dt = 1/60 unless stated.
//!
//! What went wrong without the plugin: rapier alone loses 2 % of the first apex and 18 % of
//! the fifth at 60 Hz (docs/accuracy.md). Each test prints the measured values, the expected ones and
//! rapier's own error on the same scene beside them; the assertions are the tolerances each
//! mode reaches, per precision.

// Precision-generic: `Real` is f32 or f64 (feature `f64`), so conversions that are
// widening in one build are identities in the other.
#![allow(clippy::useless_conversion, clippy::unnecessary_cast)]

mod plugin_support;

use approx::{abs_diff_eq, assert_abs_diff_eq};
use plugin_support::*;
use rapier_impact::TimingMode;
use rapier_impact::rapier::prelude::*;

const H0: f64 = 1.0;
const E: f64 = 0.8;
const RADIUS: f64 = 0.1;

/// The closed form's first five impact times for h0 = 1, g = 9.81, e = 0.8.
const NOTES_TIMES: [f64; 5] = [0.451524, 1.173961, 1.751912, 2.214272, 2.584160];

fn t1() -> f64 {
    (2.0 * H0 / G).sqrt()
}

fn impact_time(k: usize) -> f64 {
    t1() + 2.0 * t1() * E * (1.0 - E.powi(k as i32)) / (1.0 - E)
}

fn apex(n: usize) -> f64 {
    E.powi(2 * n as i32) * H0
}

fn time_to_rest() -> f64 {
    t1() * (1.0 + E) / (1.0 - E)
}

/// What one run measured.
struct Trace {
    /// Impact times (s): the plugin's events, or rapier's step where the ball turned up.
    impacts: Vec<f64>,
    /// Apex of each flight after a bounce: `y - R + vy^2/(2g)` at its highest sample (exact
    /// for ballistic flight, whatever the sample).
    apexes: Vec<f64>,
    /// First time from which the ball stays below 1 mm/s.
    rest: Option<f64>,
}

fn run(mode: Option<TimingMode>, dt: f64, duration: f64) -> Trace {
    let mut world = PhysicsWorld::default();
    world.integration_parameters.dt = dt as Real;
    let (_, ground) = world.insert(
        RigidBodyBuilder::fixed(),
        ColliderBuilder::halfspace(up())
            .restitution(E as Real)
            .friction(0.5),
    );
    let (ball, _) = world.insert(
        RigidBodyBuilder::dynamic().translation(Vector::new(0.0, (RADIUS + H0) as Real, 0.0)),
        ColliderBuilder::ball(RADIUS as Real)
            .restitution(E as Real)
            .friction(0.5),
    );
    let mut plugin = mode.map(|timing| plugin_on(&world, ground, timing));
    let dt = f64::from(world.integration_parameters.dt);
    let steps = (duration / dt).ceil() as usize;
    let mut trace = Trace {
        impacts: Vec::new(),
        apexes: Vec::new(),
        rest: None,
    };
    let mut top: Option<(f64, f64)> = None;
    let mut prev_vy = 0.0;
    let mut flights = 0;
    for k in 1..=steps {
        let t = k as f64 * dt;
        match plugin.as_mut() {
            Some(p) => {
                p.step(&mut world);
                for e in p.events() {
                    if !e.settled {
                        trace.impacts.push(t - dt + e.time);
                    }
                }
            }
            None => world.step(),
        }
        let rb = &world.bodies[ball];
        let (y, vy) = (f64::from(rb.center_of_mass().y), f64::from(rb.linvel().y));
        if plugin.is_none() && prev_vy < 0.0 && vy > 0.0 {
            trace.impacts.push(t);
        }
        if prev_vy < 0.0 && vy > 0.0 {
            if let Some((ty, tvy)) = top.take() {
                if flights > 0 {
                    trace.apexes.push(ty - RADIUS + tvy * tvy / (2.0 * G));
                }
                flights += 1;
            }
        }
        if vy.abs() > 1e-9 && top.is_none_or(|(ty, _)| y > ty) {
            top = Some((y, vy));
        }
        let speed = f64::from(rb.linvel().length());
        match (speed < 1e-3, trace.rest) {
            (true, None) => trace.rest = Some(t),
            (false, Some(_)) => trace.rest = None,
            _ => {}
        }
        prev_vy = vy;
    }
    trace
}

fn name(mode: Option<TimingMode>) -> &'static str {
    match mode {
        None => "rapier",
        Some(TimingMode::Step) => "step",
        Some(TimingMode::TimeOfImpact) => "toi",
        Some(TimingMode::Exact) => "exact",
    }
}

/// Prints the table for `mode` beside rapier's own run; returns the largest apex error
/// (relative) and impact-time error (s) over `bounces` bounces.
fn report(mode: TimingMode, dt: f64, bounces: usize) -> (f64, f64, Trace) {
    let trace = run(Some(mode), dt, 4.6);
    let rapier = run(None, dt, 4.6);
    println!(
        "\n{} mode, dt = {dt:.6} s, {}: measured vs expected (rapier alone beside)",
        name(Some(mode)),
        if F64 { "f64" } else { "f32" }
    );
    println!(
        "{:>3} {:>11} {:>11} {:>10} {:>10} | {:>10} {:>10} {:>10} {:>10}",
        "n", "t_impact", "expected", "err s", "rapier", "apex", "expected", "rel err", "rapier"
    );
    let (mut worst_apex, mut worst_time) = (0.0f64, 0.0f64);
    for n in 1..=bounces {
        let te = impact_time(n - 1);
        let ae = apex(n);
        let t = trace.impacts.get(n - 1).copied();
        let a = trace.apexes.get(n - 1).copied();
        let rt = rapier.impacts.get(n - 1).map(|t| t - te);
        let ra = rapier.apexes.get(n - 1).map(|a| a / ae - 1.0);
        let fmt = |x: Option<f64>, p: usize| x.map_or("-".to_string(), |x| format!("{x:.p$}"));
        let fe = |x: Option<f64>| x.map_or("-".to_string(), |x| format!("{x:+.2e}"));
        println!(
            "{n:>3} {:>11} {te:>11.7} {:>10} {:>10} | {:>10} {ae:>10.7} {:>10} {:>10}",
            fmt(t, 7),
            fe(t.map(|t| t - te)),
            fe(rt),
            fmt(a, 7),
            fe(a.map(|a| a / ae - 1.0)),
            fe(ra),
        );
        worst_time = worst_time.max(t.map_or(f64::INFINITY, |t| (t - te).abs()));
        worst_apex = worst_apex.max(a.map_or(f64::INFINITY, |a| (a / ae - 1.0).abs()));
    }
    println!(
        "time to rest: {:?} s (expected {:.6} s; rapier alone {:?} s)",
        trace.rest,
        time_to_rest(),
        rapier.rest
    );
    println!(
        "worst over {bounces} bounces: apex {worst_apex:.2e} relative, impact time {worst_time:.2e} s"
    );
    (worst_apex, worst_time, trace)
}

#[test]
fn notes_impact_times_are_the_closed_form() {
    for (k, t) in NOTES_TIMES.iter().enumerate() {
        assert!(
            abs_diff_eq!(impact_time(k), *t, epsilon = 1e-6),
            "t_{k}: {} vs {t}",
            impact_time(k)
        );
    }
}

#[test]
fn exact_mode_apexes_follow_e_squared_over_ten_bounces() {
    let (apex_err, time_err, trace) = report(TimingMode::Exact, 1.0 / 60.0, 10);
    // Reached: f32 5.4e-7 relative / 1.4e-7 s; f64 5.8e-15 / 1.8e-15 s.
    let (apex_tol, time_tol) = if F64 { (1e-12, 1e-12) } else { (1e-6, 5e-7) };
    assert!(
        apex_err <= apex_tol,
        "exact apexes: worst relative error {apex_err:.3e}, tolerance {apex_tol:.0e}"
    );
    assert!(
        time_err <= time_tol,
        "exact impact times: worst error {time_err:.3e} s, tolerance {time_tol:.0e} s"
    );
    for (k, t) in NOTES_TIMES.iter().enumerate() {
        let m = trace.impacts[k];
        assert!(
            abs_diff_eq!(m, *t, epsilon = 1e-6),
            "impact {k}: measured {m:.7} s, closed form {t} s"
        );
    }
}

#[test]
fn exact_mode_holds_at_240_and_1000_hz() {
    for dt in [1.0 / 240.0, 1.0 / 1000.0] {
        let (apex_err, time_err, _) = report(TimingMode::Exact, dt, 10);
        // Reached: f32 5.4e-7 / 1.4e-7 s; f64 7e-14 / 9e-14 s at 1000 Hz.
        let (apex_tol, time_tol) = if F64 { (1e-12, 1e-12) } else { (2e-6, 1e-6) };
        assert!(
            apex_err <= apex_tol && time_err <= time_tol,
            "exact at dt = {dt}: apex {apex_err:.3e} (tol {apex_tol:.0e}), time {time_err:.3e} s (tol {time_tol:.0e})"
        );
    }
}

#[test]
fn exact_mode_comes_to_rest_near_the_closed_form_time() {
    let trace = run(Some(TimingMode::Exact), 1.0 / 60.0, 6.0);
    let rest = trace.rest.expect("the ball comes to rest");
    // The last bounces (approach below the resting speed 0.5 g dt = 0.08 m/s) are given to
    // rapier's solver with e = 0: the ball stops at most ~ (2 e / (g (1 - e))) 0.08 = 0.07 s
    // early, plus a step.
    let expected = time_to_rest();
    println!("time to rest: {rest:.4} s, expected {expected:.4} s");
    assert_abs_diff_eq!(rest, expected, epsilon = 0.1);
}

#[test]
fn toi_mode_impacts_in_step_with_rapier_flight() {
    let (_, _, trace) = report(TimingMode::TimeOfImpact, 1.0 / 60.0, 10);
    let rapier = run(None, 1.0 / 60.0, 4.6);
    // The first impact comes from an exact in-step time after rapier's flight: rapier's
    // integrator leaves the ball ~ g h t / 2 low, so it lands ~2 ms early.
    let t = trace.impacts[0];
    assert_abs_diff_eq!(t, NOTES_TIMES[0], epsilon = 3e-3);
    // Free flight is rapier's, so apexes carry its flight error, but never its restitution
    // error on top: at least as close as rapier alone over five bounces.
    for n in 1..=5 {
        let (a, r) = (trace.apexes[n - 1], rapier.apexes[n - 1]);
        let (ea, er) = ((a / apex(n) - 1.0).abs(), (r / apex(n) - 1.0).abs());
        assert!(
            ea <= er,
            "toi apex {n}: error {ea:.3e} vs rapier alone {er:.3e}"
        );
    }
}

#[test]
fn step_mode_bounces_at_step_boundaries() {
    let (_, _, trace) = report(TimingMode::Step, 1.0 / 60.0, 10);
    // Impulse at the start of the step in which the contact closes: the bounce starts up to
    // one step early, from up to one step's travel above the ground.
    for n in 1..=5 {
        let a = trace.apexes[n - 1];
        let err = a / apex(n) - 1.0;
        assert!(
            abs_diff_eq!(err, 0.0, epsilon = 0.05),
            "step apex {n}: {a:.6} vs {:.6} ({err:+.3e})",
            apex(n)
        );
        let t = trace.impacts[n - 1];
        let te = impact_time(n - 1);
        assert!(
            abs_diff_eq!(t, te, epsilon = 0.1),
            "step impact {n}: {t:.6} s vs {te:.6} s"
        );
    }
}
