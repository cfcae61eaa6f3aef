//! A ball sliding and rolling on a plane ground in closed form, in `f64`: the motion between
//! a landing and rest, which a stepped resting contact does not follow (its contact point
//! turns with the ball, which then hops and slips on). No rapier types.

use super::flight::State;
use super::pursuit::Pursuit;
use nalgebra::{UnitQuaternion, Vector3};

/// A ball sliding or rolling on a fixed flat ground, the ground pressing it with the force
/// that cancels the normal acceleration, so the ball neither hops nor sinks: it keeps touching
/// the ground (`v . n = 0`) while it slides, rolls or rests.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Rolling {
    /// Unit ground normal, out of the ground.
    pub normal: Vector3<f64>,
    /// Ball radius (m), from its centre to the contact point.
    pub radius: f64,
    /// `I / (m r^2)`: 2/5 for a solid ball.
    pub inertia_ratio: f64,
    /// Coulomb friction coefficient.
    pub friction: f64,
    /// Rolling resistance `mu_r`: while the ball rolls, a torque `mu_r r N` opposes it.
    pub rolling_resistance: f64,
    /// Spinning friction `mu_sp`: a torque `mu_sp r N` about the normal opposes the spin
    /// about it.
    pub spinning_friction: f64,
    /// Constant acceleration (gravity): into the ground, and along it on a slope.
    pub accel: Vector3<f64>,
    /// The ground's velocity (m/s), constant, along its plane (`normal . u = 0`: a conveyor,
    /// a sliding platform), without turning. Relative to the ground the ball moves as on a
    /// still one (Galilean invariance: the friction acts on the slip against the ground, the
    /// accelerations are the same in both frames).
    pub ground_velocity: Vector3<f64>,
}

/// Sine of the largest angle between a slip (or a rolling velocity) and a slope's fall line
/// for the motion to count as along it (a straight phase rather than a pursuit): the pursuit
/// then differs from the straight line by less than that fraction of its travel, and its
/// terms in `tan(psi/2)^4` stay far from overflow.
const FALL_LINE_TOLERANCE: f64 = 1e-12;

/// True when the unit direction `u` is along the fall line of a ground of acceleration
/// `at` along it (or the ground is level): within [`FALL_LINE_TOLERANCE`].
fn along_fall_line(at: &Vector3<f64>, u: &Vector3<f64>) -> bool {
    at.cross(u).norm() <= FALL_LINE_TOLERANCE * at.norm()
}

/// One phase of the motion along the ground and how long it lasts.
struct Phase {
    kind: PhaseKind,
    until: f64,
    /// What the ball does at `until`.
    then: PhaseEnd,
}

enum PhaseKind {
    /// Constant accelerations: linear, and angular of the spin along the ground.
    Constant {
        linear: Vector3<f64>,
        angular: Vector3<f64>,
    },
    /// Sliding across a slope's fall line: the slip's pursuit (`motion::pursuit`), friction
    /// `mu g_n` along it and gravity `a_t`.
    SlideAcross(Pursuit),
    /// Rolling across a slope's fall line against rolling resistance: the velocity's
    /// pursuit, the spin `n x v / r`.
    RollAcross(Pursuit),
}

impl Phase {
    /// A phase of constant accelerations, `linear` and `angular` (of the spin along the
    /// ground), lasting `until`, the ball doing `then` at its end.
    fn constant(linear: Vector3<f64>, angular: Vector3<f64>, until: f64, then: PhaseEnd) -> Self {
        Phase {
            kind: PhaseKind::Constant { linear, angular },
            until,
            then,
        }
    }
}

#[derive(Clone, Copy, PartialEq)]
enum PhaseEnd {
    /// The next phase follows from the state.
    Continue,
    /// At rest (the rolling resistance stopped it).
    Rest,
    /// The slip has vanished: rolling from here (the spin set to match exactly).
    Rolls,
    /// Rolling needs more friction than `mu N` from here: it slides.
    Slides,
}

impl Rolling {
    /// The state `dt` seconds after `s`, which touches the ground (`v . n = 0`), or `None`
    /// where the closed form below does not reach: the narrow band where the ball can
    /// neither roll (the friction it needs exceeds `mu N`) nor keep a slip it starts.
    ///
    /// With `g_n = -a.n` (the normal force per unit mass, `N = m g_n`), `a_t` the acceleration
    /// along the ground, `k = I / (m r^2)`, the contact at `-r n` and its slip
    /// `s = v - r w x n`:
    /// - sliding: kinetic friction `F = -mu N s/|s|` at the contact, `dv/dt = a_t + F/m`,
    ///   `dw/dt = (-r n) x F / I`, so `ds/dt = a_t - mu g_n (1 + 1/k) s/|s|`: along the fall
    ///   line (or on level ground) the slip keeps its direction and changes at
    ///   `a_t.s/|s| - mu g_n (1 + 1/k)`, ending when it reaches zero. A ball launched sliding
    ///   without spin on level ground rolls at `5/7 v0` from `t = 2 v0 / (7 mu g)`. Across
    ///   the fall line the slip turns down it as a pursuit curve (`motion::pursuit`), and the
    ///   friction's integrals follow from the slip's: `int F/m dt = (s - s0 - a_t t) / (1 + 1/k)`;
    /// - rolling: `dv/dt = (a_t - mu_r g_n v/|v|) / (1 + k)`, `w = n x v / r`: on level ground
    ///   it stops after `v0^2 (1 + k) / (2 mu_r g)`, down a slope of angle `theta` it speeds up
    ///   at `g (sin - mu_r cos) / (1 + k)`, up it slows at `g (sin + mu_r cos) / (1 + k)`;
    ///   across the fall line `v` is a pursuit too, which stops where `tan(theta) < mu_r`. It
    ///   rolls as long as the friction this needs, `m (dv/dt - a_t)`, stays within `mu N`, and
    ///   then slides down the fall line;
    /// - at rest: it stays where `|a_t| <= mu_r g_n` and `<= mu g_n` (`tan(theta) <= mu_r`,
    ///   `mu`), else rolls down; where only the friction falls short it would slide without
    ///   turning, out of reach (`None`);
    /// - the spin about the normal `w.n` decays at `mu_sp g_n / (k r)` to zero
    ///   (`5 mu_sp g / (2 r)` for a solid ball on level ground), whatever the ball does, and
    ///   moves nothing else (it does not turn the contact point).
    ///
    /// Every phase is exact; the orientation turns by the integral of `w`, exact when `w`
    /// keeps its axis and second order in the step otherwise.
    pub fn advance(&self, s: &State, dt: f64) -> State {
        self.advance_checked(s, dt).unwrap_or_else(|| {
            let rel = self.relative(s);
            self.absolute(&self.advance_unresisted(&rel, dt), dt)
        })
    }

    /// [`Self::advance`], `None` where the closed form does not reach.
    pub fn advance_checked(&self, s: &State, dt: f64) -> Option<State> {
        let rel = self.relative(s);
        self.advance_on_still(&rel, dt)
            .map(|end| self.absolute(&end, dt))
    }

    /// Is the ball at `s` at rest on a still ground, to the closed form's own measure: its
    /// centre and its rolling no faster than the rounding of the speeds the closed form
    /// compares ([`rest_scale`]), and a spin about the normal only where no spinning friction
    /// brakes it (which is then the same whoever steps it)? So a ball spinning in place about
    /// the normal without spinning friction is at rest here, however fast. An instant's test:
    /// on a slope steeper than `mu_r` a ball at rest rolls off.
    pub fn at_rest(&self, s: &State) -> bool {
        let n = self.normal;
        let wn = s.w.dot(&n);
        let rolls = self.radius * (s.w - n * wn).norm();
        let at = self.accel - n * self.accel.dot(&n);
        let scale = rest_scale(s.v.norm(), rolls, &at);
        self.ground_velocity == Vector3::zeros()
            && s.v.norm() <= scale
            && rolls <= scale
            && (wn == 0.0 || self.spinning_friction == 0.0)
    }

    /// Does the closed form bring the ball at `s` to rest ([`Self::at_rest`]) within `dt`?
    pub fn comes_to_rest(&self, s: &State, dt: f64) -> bool {
        self.advance_checked(s, dt)
            .is_some_and(|end| self.at_rest(&end))
    }

    /// The slope's tilt `a_t / g_n` (downhill, of length `tan(theta)`) if the ground holds a
    /// ball at rest on it, `None` if no ball stays at rest there. On a slope of angle `theta`
    /// the static friction `m |a_t|` at the contact point holds the centre, and its torque
    /// `m |a_t| h` about the centre (`h` the friction's lever along the normal, `r` for a rigid
    /// contact) is balanced by the normal force `N = m g_n` acting `h tan(theta)` downhill of
    /// the contact point: the contact patch pressed harder on the side the ball would roll
    /// to, the static form of the rolling resistance (which bounds that shift by `mu_r r`).
    /// So a ball stays at rest where `tan(theta) <= mu_r` and `tan(theta) <= mu`, on a still
    /// ground (zero tilt on level ground).
    pub fn holding_tilt(&self) -> Option<Vector3<f64>> {
        let n = self.normal;
        let gn = -self.accel.dot(&n);
        let at = self.accel - n * self.accel.dot(&n);
        let holds = gn > 0.0
            && self.ground_velocity == Vector3::zeros()
            && at.norm() <= self.rolling_resistance.min(self.friction) * gn;
        holds.then(|| at / gn)
    }

    /// `s` in the ground's frame: the velocity relative to the ground (the frames coincide at
    /// the start).
    fn relative(&self, s: &State) -> State {
        State {
            v: s.v - self.ground_velocity,
            ..*s
        }
    }

    /// A state `dt` into the motion in the ground's frame, back in the world's.
    fn absolute(&self, end: &State, dt: f64) -> State {
        State {
            com: end.com + self.ground_velocity * dt,
            v: end.v + self.ground_velocity,
            ..*end
        }
    }

    /// [`Self::advance_checked`] on a still ground.
    fn advance_on_still(&self, s: &State, dt: f64) -> Option<State> {
        let n = self.normal;
        let gn = -self.accel.dot(&n).min(0.0);
        let at = self.accel - n * self.accel.dot(&n);
        // The spin about the normal: its own closed form.
        let wn0 = s.w.dot(&n);
        let decay = self.spinning_friction * gn / (self.inertia_ratio * self.radius);
        let (wn1, turned_n) = spin_down(wn0, decay, dt);
        let mut st = State {
            w: s.w - n * wn0,
            ..*s
        };
        let mut turned = Vector3::zeros();
        let finite_step = dt > 0.0 && dt < f64::INFINITY;
        // The commonest step (a ball rolling or at rest on level ground, no rolling
        // resistance): the phase's accelerations are known without the phase.
        let level = if finite_step {
            self.level_unresisted(&st, &at, gn)
        } else {
            None
        };
        if let Some((linear, angular)) = level {
            accelerate(&mut st, &mut turned, (&linear, &angular), dt);
        } else {
            let first = if finite_step {
                Some(self.phase(&st, &at, gn, false)?)
            } else {
                None
            };
            match first {
                // The common step (a roll, a ball at rest): one phase of constant
                // accelerations lasting past the step's end, taken as the phases' walk below
                // would take it, without the walk.
                Some(Phase {
                    kind: PhaseKind::Constant { linear, angular },
                    until,
                    ..
                }) if until > dt => {
                    accelerate(&mut st, &mut turned, (&linear, &angular), dt);
                }
                first => self.walk_phases(&mut st, &mut turned, (&at, gn), first, dt)?,
            }
        }
        st.w += n * wn1;
        turned += n * turned_n;
        Some(State {
            rot: UnitQuaternion::from_scaled_axis(turned) * s.rot,
            ..st
        })
    }

    /// The phases of the motion from `st` (its spin along the ground only; `turned` the
    /// angle its spin turned so far) over `dt`, on a ground of acceleration `at` along it and
    /// `gn` into it, the first phase `first` where it is known: `st` and `turned` moved to
    /// the end. `None` where the closed form does not reach.
    fn walk_phases(
        &self,
        st: &mut State,
        turned: &mut Vector3<f64>,
        (at, gn): (&Vector3<f64>, f64),
        mut first: Option<Phase>,
        dt: f64,
    ) -> Option<()> {
        let n = self.normal;
        let mut t = 0.0;
        let mut slides = false;
        // At most: slide, roll, slide again (rolling needs too much friction further down),
        // stop, roll back down, so a few phases.
        for _ in 0..8 {
            let left = dt - t;
            if left <= 0.0 {
                break;
            }
            let phase = match first.take() {
                Some(phase) => phase,
                None => self.phase(st, at, gn, slides)?,
            };
            let h = phase.until.min(left);
            let p0 = *st;
            match phase.kind {
                PhaseKind::Constant { linear, angular } => {
                    accelerate(st, turned, (&linear, &angular), h);
                }
                PhaseKind::SlideAcross(slip) => {
                    // dv/dt = a_t - mu g_n s/|s| and ds/dt = a_t - B s/|s| with
                    // B = mu g_n (1 + 1/k): the friction's integrals are the slip's.
                    let brake = self.friction * gn * (1.0 + 1.0 / self.inertia_ratio);
                    let ratio = self.friction * gn / brake;
                    let s0 = p0.v - self.radius * p0.w.cross(&n);
                    let end = slip.at(h);
                    // int_0^h F/m dt and int_0^h int_0^t F/m, from s(h) and int s.
                    let impulse = (end.w - s0 - at * h) * ratio;
                    let moment = (end.travelled - s0 * h - 0.5 * at * h * h) * ratio;
                    st.com += p0.v * h + 0.5 * at * h * h + moment;
                    st.v = p0.v + at * h + impulse;
                    // dw/dt = (-r n) x F / I = n x (-F/m) / (k r).
                    let spin = -1.0 / (self.inertia_ratio * self.radius);
                    *turned += p0.w * h + n.cross(&moment) * spin;
                    st.w = p0.w + n.cross(&impulse) * spin;
                }
                PhaseKind::RollAcross(velocity) => {
                    let end = velocity.at(h);
                    st.com += end.travelled;
                    st.v = end.w;
                    let r = self.radius;
                    *turned += n.cross(&end.travelled) / r;
                    st.w = n.cross(&st.v) / r;
                }
            }
            t += h;
            slides = false;
            if h == phase.until {
                match phase.then {
                    PhaseEnd::Rest => {
                        st.v = Vector3::zeros();
                        st.w = Vector3::zeros();
                    }
                    PhaseEnd::Rolls => st.w = n.cross(&st.v) / self.radius,
                    PhaseEnd::Slides => slides = true,
                    PhaseEnd::Continue => {}
                }
            }
        }
        Some(())
    }

    /// The phase the ball is in at `st` (its spin along the ground only), on a ground of
    /// acceleration `at` along it and `gn` into it; `slides`: the last phase ended where
    /// rolling needs more friction than `mu N`.
    fn phase(&self, st: &State, at: &Vector3<f64>, gn: f64, slides: bool) -> Option<Phase> {
        let (slip, scale) = self.slip_and_scale(st, st.v.norm(), at);
        if slides {
            return self.slide_down(at, gn);
        }
        let slip_speed = slip.norm();
        if slip_speed > scale {
            return Some(self.sliding(&slip, slip_speed, at, gn));
        }
        self.rolling(st, at, gn, scale)
    }

    /// The slip at `st` (the contact point's velocity, `v - r w x n`) and the speed below
    /// which a slip or a roll counts as none (`rest_scale`, `speed` the centre's, `|v|`):
    /// what decides whether the ball slides, rolls or rests.
    #[inline]
    fn slip_and_scale(&self, st: &State, speed: f64, at: &Vector3<f64>) -> (Vector3<f64>, f64) {
        let r = self.radius;
        let scale = rest_scale(speed, r * st.w.norm(), at);
        (st.v - r * st.w.cross(&self.normal), scale)
    }

    /// The constant accelerations, linear and angular, of the phase [`Self::phase`] finds at
    /// `st` (not after a slide) where they are known without it: no slip, no rolling
    /// resistance (`mu_r = 0`) and a level ground, its `at` exactly `+0` (as
    /// `accel - n (accel.n)` gives it for a normal along the acceleration), with `1 + k > 0`,
    /// `mu g_n >= 0`, `g_n` finite and a positive radius. Rolling's
    /// `linear = (at - u mu_r g_n) / (1 + k)` is then `+0` for any finite `u`, the friction
    /// it needs, `|linear - at| = 0`, is within `mu N`, and neither a pursuit nor a stop
    /// follows: the phase lasts for good, at `(+0, (n x +0) / r)` rolling and `(+0, +0)` at
    /// rest, the same values [`Self::rolling`] returns. `None` otherwise: the phase is then
    /// asked.
    fn level_unresisted(
        &self,
        st: &State,
        at: &Vector3<f64>,
        gn: f64,
    ) -> Option<(Vector3<f64>, Vector3<f64>)> {
        let level = at.iter().all(|a| a.to_bits() == 0);
        let in_range = 1.0 + self.inertia_ratio > 0.0
            && self.friction * gn >= 0.0
            && gn.is_finite()
            && self.radius > 0.0;
        if !level || self.rolling_resistance != 0.0 || !in_range {
            return None;
        }
        let speed = st.v.norm();
        let (slip, scale) = self.slip_and_scale(st, speed, at);
        if slip.norm() > scale {
            return None;
        }
        let zero = Vector3::zeros();
        if speed > scale {
            Some((zero, self.normal.cross(&zero) / self.radius))
        } else {
            Some((zero, zero))
        }
    }

    /// Sliding along the unit direction `u` with a slip of speed `slip_speed`, under
    /// constant accelerations: friction `mu g_n` along `-u` (and its torque about `n x u`)
    /// and `a_t`. It lasts until the slip, changing at `a_t.u - mu g_n (1 + 1/k)`, stops,
    /// if it slows.
    fn slide(&self, u: Vector3<f64>, slip_speed: f64, at: &Vector3<f64>, gn: f64) -> Phase {
        let (n, r, k) = (self.normal, self.radius, self.inertia_ratio);
        // Friction's accelerations: linear along -u, angular about n x u.
        let linear = at - u * (self.friction * gn);
        let angular = n.cross(&u) * (self.friction * gn / (r * k));
        let rate = at.dot(&u) - self.friction * gn * (1.0 + 1.0 / k);
        let until = if rate < 0.0 {
            slip_speed / -rate
        } else {
            f64::INFINITY
        };
        Phase::constant(linear, angular, until, PhaseEnd::Continue)
    }

    /// A ball that cannot roll slides, its slip growing down the fall line, if it can keep
    /// growing there; `None` otherwise (the narrow band out of reach).
    fn slide_down(&self, at: &Vector3<f64>, gn: f64) -> Option<Phase> {
        let phase = self.slide(at.try_normalize(0.0)?, 0.0, at, gn);
        (phase.until == f64::INFINITY).then_some(phase)
    }

    /// The phase of a ball that slips at `slip` (`slip_speed` its norm): a straight slide
    /// along the fall line, on level ground or without friction; across a slope's fall line
    /// the slip's pursuit, braked at `mu g_n (1 + 1/k)`, until it stops and the ball rolls.
    fn sliding(&self, slip: &Vector3<f64>, slip_speed: f64, at: &Vector3<f64>, gn: f64) -> Phase {
        let u = slip / slip_speed;
        if along_fall_line(at, &u) || self.friction == 0.0 {
            return self.slide(u, slip_speed, at, gn);
        }
        let brake = self.friction * gn * (1.0 + 1.0 / self.inertia_ratio);
        let Some(pursuit) = Pursuit::new(slip, at, brake) else {
            // Braking so much harder than gravity drifts it that the slip keeps its
            // direction to rounding.
            return self.slide(u, slip_speed, at, gn);
        };
        Phase {
            kind: PhaseKind::SlideAcross(pursuit),
            until: pursuit.stop_time().unwrap_or(f64::INFINITY),
            then: PhaseEnd::Rolls,
        }
    }

    /// The phase of a ball without slip (speeds at or below `scale`): rolling at
    /// `dv/dt = (a_t - mu_r g_n v/|v|) / (1 + k)` as long as the friction this needs stays
    /// within `mu N` (else it slides down the fall line), or at rest where the rolling
    /// resistance and the friction hold it; `None` where only the friction falls short.
    fn rolling(&self, st: &State, at: &Vector3<f64>, gn: f64, scale: f64) -> Option<Phase> {
        let (n, r, k) = (self.normal, self.radius, self.inertia_ratio);
        // The direction it rolls (or would start to).
        let speed = st.v.norm();
        let u = if speed > scale {
            st.v / speed
        } else if at.norm() > self.rolling_resistance * gn {
            at.normalize()
        } else if at.norm() > self.friction * gn {
            // The rolling resistance holds its turning but the friction cannot hold its
            // centre (`mu < tan(theta) <= mu_r`): it would slide without turning, a phase the
            // closed form does not follow.
            return None;
        } else {
            // Held at rest by the rolling resistance and the friction (or on level ground).
            let zero = Vector3::zeros();
            return Some(Phase::constant(
                zero,
                zero,
                f64::INFINITY,
                PhaseEnd::Continue,
            ));
        };
        let linear = (at - u * (self.rolling_resistance * gn)) / (1.0 + k);
        // Rolling needs the friction m (dv/dt - a_t); beyond mu N the ball slides.
        let limit = self.friction * gn * (1.0 + 1e-12);
        if (linear - at).norm() > limit {
            return self.slide_down(at, gn);
        }
        if self.rolling_resistance > 0.0 && !along_fall_line(at, &u) {
            let brake = self.rolling_resistance * gn / (1.0 + k);
            if let Some(pursuit) = Pursuit::new(&st.v, &(at / (1.0 + k)), brake) {
                return Some(self.roll_across(pursuit, at, gn));
            }
        }
        // Only the rolling resistance stops a ball: without it the acceleration is constant
        // (a_t / (1 + k)) and the velocity passes through zero, or turns, unbroken.
        let slowing = linear.dot(&u);
        let stops = self.rolling_resistance > 0.0 && slowing < 0.0 && speed > scale;
        Some(Phase::constant(
            linear,
            n.cross(&linear) / r,
            if stops {
                speed / -slowing
            } else {
                f64::INFINITY
            },
            if stops {
                PhaseEnd::Rest
            } else {
                PhaseEnd::Continue
            },
        ))
    }

    /// Rolling across a slope's fall line against the rolling resistance: the velocity's
    /// `pursuit`, until the ball slides (the friction rolling needs reaches `mu N`) or,
    /// before that, stops.
    fn roll_across(&self, pursuit: Pursuit, at: &Vector3<f64>, gn: f64) -> Phase {
        let k = self.inertia_ratio;
        // The friction rolling needs, |k a_t + mu_r g_n v/|v|| / (1 + k), grows as
        // the velocity turns down the fall line: it reaches mu N where
        // cos(psi) = ((mu g_n (1 + k))^2 - (k |a_t|)^2 - (mu_r g_n)^2)
        //   / (2 k |a_t| mu_r g_n).
        let (ka, rg) = (k * at.norm(), self.rolling_resistance * gn);
        let mu = self.friction * gn * (1.0 + k);
        let cos_limit = (mu * mu - ka * ka - rg * rg) / (2.0 * ka * rg);
        let stop = pursuit.stop_time();
        let slides_at = (cos_limit < 1.0).then(|| pursuit.time_at_angle(cos_limit));
        let (until, then) = match (slides_at, stop) {
            (Some(t), _) => (t, PhaseEnd::Slides),
            (None, Some(t)) => (t, PhaseEnd::Rest),
            (None, None) => (f64::INFINITY, PhaseEnd::Continue),
        };
        Phase {
            kind: PhaseKind::RollAcross(pursuit),
            until,
            then,
        }
    }

    /// For the states [`Self::advance_checked`] does not reach (the band where the ball can
    /// neither roll nor slide; the plugin leaves those to rapier): friction held along the
    /// initial slip for its sliding time on level ground, plus the acceleration along the
    /// ground, without rolling resistance or spinning friction. An approximation, never more
    /// energetic than the slope gives.
    fn advance_unresisted(&self, s: &State, dt: f64) -> State {
        let n = self.normal;
        let r = self.radius;
        let an = self.accel.dot(&n).min(0.0);
        let slip = s.v - r * s.w.cross(&n);
        let slip_speed = slip.norm();
        // Slip deceleration and how long the slip lasts.
        let decay = -self.friction * an * (1.0 + 1.0 / self.inertia_ratio);
        let sliding = if slip_speed > 0.0 && decay > 0.0 {
            (slip_speed / decay).min(dt)
        } else {
            0.0
        };
        let (mut v, mut w, mut turned) = (s.v, s.w, Vector3::zeros());
        let mut com = s.com;
        if sliding > 0.0 {
            let dir = slip / slip_speed;
            // Friction's accelerations: linear along -dir, angular about n x dir.
            let lin = self.friction * an * dir;
            let ang = n.cross(&dir) * (-self.friction * an / (r * self.inertia_ratio));
            com += v * sliding + 0.5 * lin * sliding * sliding;
            turned += w * sliding + 0.5 * ang * sliding * sliding;
            v += lin * sliding;
            w += ang * sliding;
        }
        let rest = dt - sliding;
        com += v * rest;
        turned += w * rest;
        let at = self.accel - n * self.accel.dot(&n);
        com += 0.5 * at * dt * dt;
        v += at * dt;
        State {
            com,
            rot: UnitQuaternion::from_scaled_axis(turned) * s.rot,
            v,
            w,
        }
    }
}

/// `h` seconds of constant accelerations `linear` and `angular` (of the spin along the ground)
/// from `st`, `turned` adding the angle its spin turns.
fn accelerate(
    st: &mut State,
    turned: &mut Vector3<f64>,
    (linear, angular): (&Vector3<f64>, &Vector3<f64>),
    h: f64,
) {
    st.com += st.v * h + 0.5 * linear * h * h;
    *turned += st.w * h + 0.5 * angular * h * h;
    st.v += linear * h;
    st.w += angular * h;
}

/// The speed (m/s) at and below which the closed form takes a ball moving at `speed`, its
/// rolling at `rolling` (`r |w|` along the ground) under the acceleration `at` along the
/// ground, to be at rest (or rolling without slip): the rounding of the speeds it compares.
fn rest_scale(speed: f64, rolling: f64, at: &Vector3<f64>) -> f64 {
    1e-12 * (1e-3 + speed + rolling + at.norm())
}

/// A spin `w0` (rad/s) slowed at `decay` (rad/s^2) to zero: the spin after `dt` and the angle
/// it turned.
fn spin_down(w0: f64, decay: f64, dt: f64) -> (f64, f64) {
    if decay <= 0.0 || w0 == 0.0 {
        return (w0, w0 * dt);
    }
    let stop = w0.abs() / decay;
    let h = stop.min(dt);
    let slowing = -decay * w0.signum();
    let w1 = if h == stop { 0.0 } else { w0 + slowing * h };
    (w1, w0 * h + 0.5 * slowing * h * h)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sliding_ball(v0: Vector3<f64>, w0: Vector3<f64>, mu: f64) -> (Rolling, State) {
        let rolling = Rolling {
            normal: Vector3::y(),
            radius: 0.1,
            inertia_ratio: 0.4,
            friction: mu,
            rolling_resistance: 0.0,
            spinning_friction: 0.0,
            accel: Vector3::new(0.0, -9.81, 0.0),
            ground_velocity: Vector3::zeros(),
        };
        let s = State {
            com: Vector3::new(0.0, 0.1, 0.0),
            rot: UnitQuaternion::identity(),
            v: v0,
            w: w0,
        };
        (rolling, s)
    }

    #[test]
    fn a_ball_launched_sliding_rolls_at_five_sevenths_at_the_closed_form_time() {
        let (v0, mu, g) = (2.0, 0.3, 9.81);
        let (rolling, s) = sliding_ball(Vector3::new(v0, 0.0, 0.0), Vector3::zeros(), mu);
        let t_roll = 2.0 * v0 / (7.0 * mu * g);
        // Half-way: v = v0 - mu g t, w r = 5/2 mu g t (w about -z for motion along +x).
        let half = rolling.advance(&s, 0.5 * t_roll);
        assert!((half.v.x - (v0 - mu * g * 0.5 * t_roll)).abs() < 1e-14);
        assert!((half.w.z * 0.1 + 2.5 * mu * g * 0.5 * t_roll).abs() < 1e-14);
        assert!(
            (half.com.x - (v0 * 0.5 * t_roll - 0.25 * mu * g * t_roll * t_roll / 2.0)).abs()
                < 1e-14
        );
        // Past the rolling time, in one step or in many: 5/7 v0, rolling, same place.
        let one = rolling.advance(&s, 3.0 * t_roll);
        let mut many = s;
        for _ in 0..30 {
            many = rolling.advance(&many, 0.1 * t_roll);
        }
        for end in [one, many] {
            assert!((end.v.x - 5.0 / 7.0 * v0).abs() < 1e-14, "{:?}", end.v);
            assert!(
                (end.v.x + end.w.z * 0.1).abs() < 1e-14,
                "slip {:?} {:?}",
                end.v,
                end.w
            );
            assert_eq!((end.v.y, end.v.z, end.com.y), (0.0, 0.0, 0.1));
        }
        // Distance: sliding (v0 + 5/7 v0)/2 t_roll, then rolling 2 t_roll.
        let x = 6.0 / 7.0 * v0 * t_roll + 5.0 / 7.0 * v0 * 2.0 * t_roll;
        assert!((one.com.x - x).abs() < 1e-14 && (many.com.x - x).abs() < 1e-13);
        // The orientation turned by the integral of w about -z.
        let turned = Vector3::z() * (0.5 * one.w.z * t_roll + one.w.z * 2.0 * t_roll);
        assert!(one.rot.angle_to(&UnitQuaternion::from_scaled_axis(turned)) < 1e-12);
    }

    #[test]
    fn backspin_and_side_slip_conserve_momentum_about_the_contact_and_lose_energy() {
        let (v0, r) = (2.0, 0.1);
        // Backspin as fast as the motion: the ball ends rolling at (1 - 2/5)/(7/5) v0 = 3/7 v0.
        let (rolling, s) = sliding_ball(
            Vector3::new(v0, 0.0, 0.0),
            Vector3::new(0.0, 0.0, v0 / r),
            0.2,
        );
        let end = rolling.advance(&s, 2.0);
        assert!((end.v.x - 3.0 / 7.0 * v0).abs() < 1e-14, "{:?}", end.v);
        // A slip across the motion (side spin about x): every direction by the same law.
        let (rolling, s) = sliding_ball(
            Vector3::new(1.0, 0.0, 0.5),
            Vector3::new(7.0, 3.0, -2.0),
            0.5,
        );
        let energy = |s: &State| 0.5 * s.v.norm_squared() + 0.5 * 0.4 * r * r * s.w.norm_squared();
        let mut prev = s;
        for _ in 0..20 {
            let next = rolling.advance(&prev, 0.01);
            assert!(energy(&next) <= energy(&prev) * (1.0 + 1e-15));
            prev = next;
        }
        let slip = prev.v - r * prev.w.cross(&Vector3::y());
        assert!(slip.norm() < 1e-13, "{slip:?}");
        // Angular momentum about the contact point, m (r n x v) + I w, along the ground.
        let l = |s: &State| Vector3::y().cross(&s.v) * r + 0.4 * r * r * s.w;
        let (l0, l1) = (l(&s), l(&prev));
        assert!((l0.x - l1.x).abs() < 1e-14 && (l0.z - l1.z).abs() < 1e-14);
        // The spin about the normal is untouched.
        assert_eq!(prev.w.y, 3.0);
    }

    #[test]
    fn without_friction_the_ball_keeps_its_velocities() {
        let (rolling, s) = sliding_ball(
            Vector3::new(1.0, 0.0, 0.0),
            Vector3::new(0.0, 0.0, 4.0),
            0.0,
        );
        let end = rolling.advance(&s, 0.5);
        assert_eq!((end.v, end.w), (s.v, s.w));
        assert!((end.com.x - 0.5).abs() < 1e-15);
    }

    const G: f64 = 9.81;
    const R: f64 = 0.1;
    const K: f64 = 0.4;

    /// A solid ball of radius 0.1 m on a plane tilted by `slope` degrees about z, downhill
    /// along `(cos, -sin, 0)`, with the coefficients given.
    fn on_slope(slope: f64, mu: f64, mu_r: f64, mu_sp: f64) -> (Rolling, Vector3<f64>) {
        let th = slope.to_radians();
        let normal = Vector3::new(th.sin(), th.cos(), 0.0);
        let rolling = Rolling {
            normal,
            radius: R,
            inertia_ratio: K,
            friction: mu,
            rolling_resistance: mu_r,
            spinning_friction: mu_sp,
            accel: Vector3::new(0.0, -G, 0.0),
            ground_velocity: Vector3::zeros(),
        };
        (rolling, Vector3::new(th.cos(), -th.sin(), 0.0))
    }

    /// At the contact point's height above the origin, moving at `v` along `dir`, spinning
    /// `w`.
    fn state(rolling: &Rolling, v: Vector3<f64>, w: Vector3<f64>) -> State {
        State {
            com: rolling.normal * R,
            rot: UnitQuaternion::identity(),
            v,
            w,
        }
    }

    /// Rolling without slip at `v` on the ground of `rolling`.
    fn rolling_at(rolling: &Rolling, v: Vector3<f64>) -> State {
        state(rolling, v, rolling.normal.cross(&v) / R)
    }

    /// One step of `t`, and `t` in 60 Hz steps: both must agree with the closed form.
    fn both_ways(rolling: &Rolling, s: &State, t: f64) -> [State; 2] {
        let one = rolling
            .advance_checked(s, t)
            .expect("in the closed form's reach");
        let steps = (t * 60.0).ceil() as usize;
        let h = t / steps as f64;
        let mut many = *s;
        for _ in 0..steps {
            many = rolling.advance_checked(&many, h).expect("in reach");
        }
        [one, many]
    }

    #[test]
    fn a_rolling_ball_stops_at_the_closed_form_distance_and_time() {
        let (rolling, dir) = on_slope(0.0, 0.3, 0.02, 0.0);
        let v0 = 1.5;
        let s = rolling_at(&rolling, dir * v0);
        let t_stop = v0 * (1.0 + K) / (0.02 * G);
        let d = v0 * v0 * (1.0 + K) / (2.0 * 0.02 * G);
        // Half-way in time: v0 / 2, three quarters of the distance.
        for half in both_ways(&rolling, &s, 0.5 * t_stop) {
            assert!(
                (half.v.dot(&dir) - 0.5 * v0).abs() < 1e-12 * v0,
                "{:?}",
                half.v
            );
            assert!((half.com.x - 0.75 * d).abs() < 1e-12 * d);
        }
        for end in both_ways(&rolling, &s, 1.5 * t_stop) {
            assert_eq!((end.v, end.w), (Vector3::zeros(), Vector3::zeros()));
            assert!((end.com.x - d).abs() < 1e-12 * d, "{} vs {d}", end.com.x);
        }
    }

    #[test]
    fn at_rest_is_the_closed_forms_own_rest_and_one_steps_braking_comes_to_it() {
        let dt = 1.0 / 60.0;
        let (level, dir) = on_slope(0.0, 0.3, 0.05, 0.0);
        // Rolling as slowly as rounding: held at rest, its speed kept (the closed form's own
        // rest), and so at rest; a spin about the normal that nothing brakes does not count.
        let crawl = rolling_at(&level, dir * 6.5e-17);
        assert!(level.at_rest(&crawl));
        assert_eq!(level.advance_checked(&crawl, dt).unwrap().v, crawl.v);
        let twirl = State {
            w: crawl.w + level.normal * 2.0,
            ..crawl
        };
        assert!(level.at_rest(&twirl));
        let (braked, _) = on_slope(0.0, 0.3, 0.05, 0.02);
        assert!(!braked.at_rest(&twirl) && braked.comes_to_rest(&twirl, 1.0));
        // Ten times the rounding is motion.
        assert!(!level.at_rest(&rolling_at(&level, dir * 1e-14)));
        // One step's braking, mu_r g dt / (1 + k), stops a ball within the step; a little
        // more does not.
        let brake = 0.05 * G * dt / (1.0 + K);
        assert!(!level.at_rest(&rolling_at(&level, dir * 0.99 * brake)));
        assert!(level.comes_to_rest(&rolling_at(&level, dir * 0.99 * brake), dt));
        assert!(!level.comes_to_rest(&rolling_at(&level, dir * 1.01 * brake), dt));
        // Still on a slope: held below mu_r, rolling off above it. Carried by a moving
        // ground: not at rest.
        let still = |rolling: &Rolling| state(rolling, Vector3::zeros(), Vector3::zeros());
        let (gentle, _) = on_slope(1.0, 0.3, 0.05, 0.0);
        assert!(gentle.at_rest(&still(&gentle)) && gentle.comes_to_rest(&still(&gentle), dt));
        let (steep, _) = on_slope(5.0, 0.3, 0.05, 0.0);
        assert!(steep.at_rest(&still(&steep)) && !steep.comes_to_rest(&still(&steep), dt));
        let conveyor = Rolling {
            ground_velocity: Vector3::new(0.5, 0.0, 0.0),
            ..level
        };
        assert!(!conveyor.at_rest(&crawl));
    }

    #[test]
    fn sliding_turns_to_rolling_then_the_resistance_stops_it() {
        let (mu, mu_r) = (0.2, 0.01);
        let (rolling, dir) = on_slope(0.0, mu, mu_r, 0.0);
        let v0 = 2.0;
        let s = state(&rolling, dir * v0, Vector3::zeros());
        let t_roll = 2.0 * v0 / (7.0 * mu * G);
        let v1 = 5.0 / 7.0 * v0;
        let t_stop = v1 * (1.0 + K) / (mu_r * G);
        let d = 6.0 / 7.0 * v0 * t_roll + v1 * v1 * (1.0 + K) / (2.0 * mu_r * G);
        for end in both_ways(&rolling, &s, t_roll + t_stop + 1.0) {
            assert!((end.com.x - d).abs() < 1e-12 * d, "{} vs {d}", end.com.x);
            assert_eq!(end.v, Vector3::zeros());
        }
        // Just after rolling starts: 5/7 v0, less the resistance's slowing since.
        let [just, _] = both_ways(&rolling, &s, t_roll + 0.1);
        let v = v1 - mu_r * G / (1.0 + K) * 0.1;
        assert!((just.v.x - v).abs() < 1e-12, "{} vs {v}", just.v.x);
    }

    #[test]
    fn a_draw_shot_comes_back_and_stops() {
        // Backspin three times the rolling spin: the ball rolls back at (v0 - k r w)/(1 + k).
        let (mu, mu_r) = (0.2, 0.01);
        let (rolling, dir) = on_slope(0.0, mu, mu_r, 0.0);
        let (v0, w0) = (1.0, 30.0);
        let s = state(&rolling, dir * v0, Vector3::new(0.0, 0.0, w0));
        let slip = v0 + R * w0;
        let t_roll = slip / (mu * G * (1.0 + 1.0 / K));
        let back = (v0 - K * R * w0) / (1.0 + K);
        assert!(back < 0.0);
        let x_roll = v0 * t_roll - 0.5 * mu * G * t_roll * t_roll;
        let d_back = back * back * (1.0 + K) / (2.0 * mu_r * G);
        for end in both_ways(&rolling, &s, 10.0) {
            assert!(
                (end.com.x - (x_roll - d_back)).abs() < 1e-12,
                "{}",
                end.com.x
            );
            assert_eq!(end.v, Vector3::zeros());
        }
        let [rolling_back, _] = both_ways(&rolling, &s, t_roll + 1e-3);
        assert!((rolling_back.v.x - (back + mu_r * G / (1.0 + K) * 1e-3)).abs() < 1e-12);
    }

    #[test]
    fn spin_about_the_normal_decays_at_the_closed_form_rate() {
        let mu_sp = 0.05;
        let (rolling, _) = on_slope(0.0, 0.3, 0.0, mu_sp);
        let w0 = 20.0;
        let s = state(&rolling, Vector3::zeros(), Vector3::new(0.0, w0, 0.0));
        let rate = 5.0 * mu_sp * G / (2.0 * R);
        let t0 = w0 / rate;
        for half in both_ways(&rolling, &s, 0.5 * t0) {
            assert!((half.w.y - 0.5 * w0).abs() < 1e-12 * w0, "{}", half.w.y);
            assert_eq!(half.com, s.com);
        }
        for end in both_ways(&rolling, &s, 2.0 * t0) {
            assert_eq!(end.w, Vector3::zeros());
            // It turned w0^2 / (2 rate) about the normal.
            let turned = w0 * w0 / (2.0 * rate);
            let expected = UnitQuaternion::from_scaled_axis(Vector3::y() * turned);
            assert!(end.rot.angle_to(&expected) < 1e-9, "{:?}", end.rot);
        }
    }

    #[test]
    fn on_a_slope_it_rests_below_mu_r_and_rolls_down_above() {
        let mu_r: f64 = 0.05;
        for (tan, moves) in [(0.5 * mu_r, false), (mu_r, false), (2.0 * mu_r, true)] {
            let slope = tan.atan().to_degrees();
            let (rolling, down) = on_slope(slope, 0.5, mu_r, 0.0);
            let s = state(&rolling, Vector3::zeros(), Vector3::zeros());
            let th = tan.atan();
            let accel = G * (th.sin() - mu_r * th.cos()) / (1.0 + K);
            for end in both_ways(&rolling, &s, 1.0) {
                if moves {
                    let x = end.com - s.com;
                    assert!((x.dot(&down) - 0.5 * accel).abs() < 1e-12, "{x:?}");
                    let slip = end.v - R * end.w.cross(&rolling.normal);
                    assert!(slip.norm() < 1e-12, "rolls: {slip:?}");
                } else {
                    assert_eq!((end.com, end.v), (s.com, Vector3::zeros()), "tan {tan}");
                }
            }
        }
    }

    #[test]
    fn at_rest_on_a_slope_the_normal_force_acts_h_tan_theta_downhill_while_it_holds() {
        let mu_r: f64 = 0.05;
        for (tan, mu, holds) in [
            (0.5 * mu_r, 0.5, true),
            (0.9 * mu_r, 0.5, true),
            (2.0 * mu_r, 0.5, false),
            // The rolling resistance holds the turning, the friction not the centre.
            (0.5 * mu_r, 0.2 * mu_r, false),
        ] {
            let (rolling, down) = on_slope(tan.atan().to_degrees(), mu, mu_r, 0.0);
            let tilt = rolling.holding_tilt();
            assert_eq!(tilt.is_some(), holds, "tan {tan}, mu {mu}");
            if let Some(offset) = tilt.map(|t| t * R) {
                // Its torque about the centre cancels the friction's: (b d) x (N n) +
                // (-r n) x (-m |a_t| d) = 0, with N = m g cos, m |a_t| = m g sin.
                assert!((offset - down * (R * tan)).norm() < 1e-15, "{offset:?}");
                let n = rolling.normal;
                let th = tan.atan();
                let torque =
                    offset.cross(&(n * (G * th.cos()))) + (-R * n).cross(&(-down * (G * th.sin())));
                assert!(torque.norm() < 1e-15, "{torque:?}");
            }
            let at_rest = state(&rolling, Vector3::zeros(), Vector3::zeros());
            if mu < tan {
                // Not the closed form's: it would slide without turning.
                assert!(rolling.advance_checked(&at_rest, 0.01).is_none());
            }
        }
        let (rolling, down) = on_slope((0.5 * mu_r).atan().to_degrees(), 0.5, mu_r, 0.0);
        // A moving ground holds nothing still.
        let belt = Rolling {
            ground_velocity: down * 0.5,
            ..rolling
        };
        assert_eq!(belt.holding_tilt(), None);
    }

    #[test]
    fn rolling_up_a_slope_it_slows_stops_and_rolls_back_down() {
        let (mu_r, slope) = (0.02, 5.0f64);
        let (rolling, down) = on_slope(slope, 0.5, mu_r, 0.0);
        let th = slope.to_radians();
        let (up_rate, down_rate) = (
            G * (th.sin() + mu_r * th.cos()) / (1.0 + K),
            G * (th.sin() - mu_r * th.cos()) / (1.0 + K),
        );
        let v0 = 1.0;
        let s = rolling_at(&rolling, -down * v0);
        let t_up = v0 / up_rate;
        let climb = v0 * v0 / (2.0 * up_rate);
        let t = t_up + 0.7;
        let expected = -climb + 0.5 * down_rate * 0.7 * 0.7;
        for end in both_ways(&rolling, &s, t) {
            let x = (end.com - s.com).dot(&down);
            assert!((x - expected).abs() < 1e-12, "{x} vs {expected}");
            assert!((end.v.dot(&down) - down_rate * 0.7).abs() < 1e-12);
        }
    }

    #[test]
    fn on_a_steep_slope_it_slides_down_and_spins_up() {
        // k tan(30 deg) = 0.23 > mu (1 + k) = 0.14: it cannot roll.
        let (mu, slope) = (0.1, 30.0f64);
        let (rolling, down) = on_slope(slope, mu, 0.0, 0.0);
        let th = slope.to_radians();
        let s = state(&rolling, Vector3::zeros(), Vector3::zeros());
        for end in both_ways(&rolling, &s, 0.5) {
            let x = (end.com - s.com).dot(&down);
            assert!(
                (x - 0.5 * G * (th.sin() - mu * th.cos()) * 0.25).abs() < 1e-12,
                "{x}"
            );
            // Friction spins it up towards rolling down (about n x down) at mu g cos / (k r).
            let spin = end.w.dot(&rolling.normal.cross(&down));
            assert!(
                (spin - mu * G * th.cos() / (K * R) * 0.5).abs() < 1e-11,
                "{spin}"
            );
        }
    }

    #[test]
    fn energy_never_rises_on_level_ground_or_a_slope() {
        let energy = |rolling: &Rolling, s: &State| {
            0.5 * s.v.norm_squared() + 0.5 * K * R * R * s.w.norm_squared()
                - rolling.accel.dot(&s.com)
        };
        let mut x = 0.37f64;
        let mut next = || {
            x = (x * 7.31 + 0.13).fract();
            4.0 * x - 2.0
        };
        for (slope, mu_r) in [(0.0, 0.02), (5.0, 0.02), (5.0, 0.2), (12.0, 0.0)] {
            let (rolling, _) = on_slope(slope, 0.3, mu_r, 0.05);
            let n = rolling.normal;
            for _ in 0..100 {
                let v = Vector3::new(next(), next(), next());
                let mut s = state(
                    &rolling,
                    v - n * v.dot(&n),
                    Vector3::new(5.0 * next(), 5.0 * next(), 5.0 * next()) * 3.0,
                );
                for _ in 0..120 {
                    let after = rolling.advance_checked(&s, 1.0 / 60.0).expect("in reach");
                    assert!(
                        energy(&rolling, &after) <= energy(&rolling, &s) + 1e-12,
                        "slope {slope}: {s:?} -> {after:?}"
                    );
                    assert!(
                        after.v.dot(&n).abs() < 1e-12 && (after.com - s.com).dot(&n).abs() < 1e-12
                    );
                    s = after;
                }
            }
        }
    }

    /// The ball's own equations, `dv/dt = a_t + F/m`, `dw/dt = (-r n) x F / I` with kinetic
    /// friction against the slip, by classical Runge-Kutta in 1e-5 s steps: the reference for
    /// a slip across a slope (the closed form's pursuit is held to it in `motion::pursuit`).
    fn integrate_sliding(rolling: &Rolling, s: &State, t: f64) -> State {
        let (n, r) = (rolling.normal, R);
        let gn = -rolling.accel.dot(&n);
        let at = rolling.accel - n * rolling.accel.dot(&n);
        let f = |v: &Vector3<f64>, w: &Vector3<f64>| {
            let slip = v - r * w.cross(&n);
            let force = -slip.normalize() * (rolling.friction * gn);
            (at + force, (-n * r).cross(&force) / (K * r * r))
        };
        let steps = (t / 1e-5).ceil() as usize;
        let h = t / steps as f64;
        let (mut com, mut v, mut w) = (s.com, s.v, s.w);
        for _ in 0..steps {
            let (a1, b1) = f(&v, &w);
            let (a2, b2) = f(&(v + a1 * (0.5 * h)), &(w + b1 * (0.5 * h)));
            let (a3, b3) = f(&(v + a2 * (0.5 * h)), &(w + b2 * (0.5 * h)));
            let (a4, b4) = f(&(v + a3 * h), &(w + b3 * h));
            com += (v * 6.0 + (a1 + a2 + a3) * h) * (h / 6.0);
            v += (a1 + a2 * 2.0 + a3 * 2.0 + a4) * (h / 6.0);
            w += (b1 + b2 * 2.0 + b3 * 2.0 + b4) * (h / 6.0);
        }
        State { com, v, w, ..*s }
    }

    #[test]
    fn a_slip_across_a_slope_turns_down_it_as_the_ball_equations_say() {
        // 10 degrees, mu = 0.3: a ball thrown across the fall line, slightly uphill, with
        // some backspin. Gravity turns the slip down the slope while friction ends it.
        let (rolling, down) = on_slope(10.0, 0.3, 0.0, 0.0);
        let across = Vector3::z();
        let v0 = across * 1.5 - down * 0.4;
        let s = state(&rolling, v0, rolling.normal.cross(&v0) / R * -0.5);
        let slip = |s: &State| s.v - R * s.w.cross(&rolling.normal);
        for t in [0.03, 0.08, 0.15] {
            let reference = integrate_sliding(&rolling, &s, t);
            assert!(slip(&reference).norm() > 1e-3, "still sliding at {t}");
            for end in both_ways(&rolling, &s, t) {
                assert!(
                    (end.v - reference.v).norm() < 1e-11,
                    "{t}: {:?} vs {:?}",
                    end.v,
                    reference.v
                );
                assert!(
                    (end.w - reference.w).norm() * R < 1e-11,
                    "{t}: {:?} vs {:?}",
                    end.w,
                    reference.w
                );
                assert!(
                    (end.com - reference.com).norm() < 1e-11,
                    "{t}: {:?}",
                    end.com
                );
            }
        }
        // Whatever friction does, it acts at the contact: the angular momentum about the
        // contact point changes only by gravity's moment, r n x a_t per unit mass. It holds
        // through the end of the slip into rolling (no rolling resistance here).
        let at = rolling.accel - rolling.normal * rolling.accel.dot(&rolling.normal);
        let l = |s: &State| rolling.normal.cross(&s.v) * R + s.w * (K * R * R);
        for t in [0.4, 1.0, 2.0] {
            for end in both_ways(&rolling, &s, t) {
                let expected = l(&s) + rolling.normal.cross(&at) * (R * t);
                assert!(
                    (l(&end) - expected).norm() < 1e-12,
                    "{t}: {:?} vs {expected:?}",
                    l(&end)
                );
            }
        }
        let [rolled, _] = both_ways(&rolling, &s, 2.0);
        assert!(slip(&rolled).norm() < 1e-12, "{:?}", slip(&rolled));
    }

    #[test]
    fn rolling_across_a_slope_against_rolling_resistance_stops_at_the_capture_time() {
        // tan(5 deg) = 0.087 < mu_r = 0.12: set rolling square to the fall line, the ball
        // curves down and stops after the pursuit's capture time v0 B / (B^2 - A^2), with
        // A = g sin / (1 + k) and B = mu_r g cos / (1 + k).
        let (mu_r, slope) = (0.12, 5.0f64);
        let (rolling, down) = on_slope(slope, 0.4, mu_r, 0.0);
        let th = slope.to_radians();
        let (a, b) = (G * th.sin() / (1.0 + K), mu_r * G * th.cos() / (1.0 + K));
        let v0 = 0.8;
        let s = rolling_at(&rolling, Vector3::z() * v0);
        let stop = v0 * b / (b * b - a * a);
        let along = v0 * v0 * a / (4.0 * (b * b - a * a));
        let across = 2.0 * v0 * v0 * b / (4.0 * b * b - a * a);
        for end in both_ways(&rolling, &s, stop + 0.5) {
            // At rest (its start's spin about the normal, the rounding of n x v / r, stays).
            assert_eq!(end.v, Vector3::zeros());
            assert!(end.w.norm() < 1e-15, "{:?}", end.w);
            let moved = end.com - s.com;
            assert!(
                (moved.dot(&down) - along).abs() < 1e-12,
                "{moved:?} vs {along}"
            );
            assert!((moved.z - across).abs() < 1e-12, "{moved:?} vs {across}");
        }
        // Just before the stop it still rolls, without slip, nearly straight down the slope.
        let [before, _] = both_ways(&rolling, &s, 0.999 * stop);
        assert!(before.v.norm() > 0.0 && before.v.dot(&down) > 0.99 * before.v.norm());
        let slip = before.v - R * before.w.cross(&rolling.normal);
        assert!(slip.norm() < 1e-14, "{slip:?}");
    }

    #[test]
    fn rolling_across_a_slope_steeper_than_mu_r_it_runs_down_for_ever() {
        let (rolling, down) = on_slope(8.0, 0.5, 0.05, 0.0);
        let s = rolling_at(&rolling, Vector3::z() * 1.0 - down * 0.3);
        let [one, many] = both_ways(&rolling, &s, 3.0);
        assert!((one.com - many.com).norm() < 1e-12 && (one.v - many.v).norm() < 1e-12);
        // It turns towards the fall line and speeds up: gravity's work exceeds the
        // resistance's, sin > mu_r cos.
        assert!(one.v.dot(&down) > 0.9 * one.v.norm() && one.v.norm() > s.v.norm());
        // The energy lost is the resistance's work, mu_r g_n times the length rolled, which
        // the straight line between start and end bounds from below.
        let g_n = G * 8.0f64.to_radians().cos();
        let lost = (0.5 * (1.0 + K) * s.v.norm_squared()
            + G * 8.0f64.to_radians().sin() * (one.com - s.com).dot(&down))
            - 0.5 * (1.0 + K) * one.v.norm_squared();
        assert!(
            lost >= 0.05 * g_n * (one.com - s.com).norm() * (1.0 - 1e-12),
            "{lost}"
        );
    }

    #[test]
    fn rolling_up_across_a_steep_slope_it_slides_once_it_turns_down_far_enough() {
        // 50 degrees, mu = 0.3, mu_r = 0.45: rolling needs the friction
        // |k a_t + mu_r g_n v/|v|| / (1 + k), small while it rolls uphill and above mu g_n
        // once its velocity has turned down to cos(psi) = -0.59; there it slides, its slip
        // growing down the fall line at g (sin - mu cos (1 + 1/k)).
        let (mu, mu_r, slope) = (0.3, 0.45, 50.0f64);
        let (rolling, down) = on_slope(slope, mu, mu_r, 0.0);
        let th = slope.to_radians();
        let (g_t, g_n) = (G * th.sin(), G * th.cos());
        let s = rolling_at(&rolling, (Vector3::z() * 0.2 - down) * 2.0);
        let slip = |s: &State| s.v - R * s.w.cross(&rolling.normal);
        let at = |t: f64| rolling.advance_checked(&s, t).expect("in reach");
        // When it starts to slide: bisection on the slip.
        let (mut lo, mut hi) = (0.0, 2.0);
        assert!(slip(&at(hi)).norm() > 1e-3);
        for _ in 0..60 {
            let mid = 0.5 * (lo + hi);
            if slip(&at(mid)).norm() > 1e-14 {
                hi = mid
            } else {
                lo = mid
            }
        }
        let onset = at(lo);
        let cos = onset.v.dot(&down) / onset.v.norm();
        let limit = ((mu * g_n * (1.0 + K)).powi(2) - (K * g_t).powi(2) - (mu_r * g_n).powi(2))
            / (2.0 * K * g_t * mu_r * g_n);
        assert!((cos - limit).abs() < 1e-9, "{cos} vs {limit}");
        let later = at(lo + 0.1);
        let rate = g_t - mu * g_n * (1.0 + 1.0 / K);
        assert!(
            (slip(&later) - down * (rate * 0.1)).norm() < 1e-12,
            "{:?}",
            slip(&later)
        );
        let [one, many] = both_ways(&rolling, &s, lo + 0.1);
        assert!((one.com - many.com).norm() < 1e-12 && (one.v - many.v).norm() < 1e-12);
    }

    #[test]
    fn where_it_can_neither_roll_nor_keep_a_slip_it_is_out_of_reach() {
        // 40 degrees, mu = 0.3 and mu_r = 0.5 at rest: rolling needs (k tan + mu_r) / (1 + k)
        // = 0.59 of g_n > mu, while a slip down it would shrink (tan < mu (1 + 1/k)).
        let (rolling, _) = on_slope(40.0, 0.3, 0.5, 0.0);
        let s = state(&rolling, Vector3::zeros(), Vector3::zeros());
        assert_eq!(rolling.advance_checked(&s, 0.1), None);
    }

    #[test]
    fn set_at_rest_on_a_conveyor_it_is_dragged_to_rolling_and_then_carried() {
        // Level ground moving at u along x, the ball set on it at rest, no spin. In the world
        // frame friction mu m g pushes it along x until the slip against the belt vanishes:
        // at t1 = u k / ((1 + k) mu g) it rolls at v1 = u k / (1 + k), -rel = -u / (1 + k)
        // relative to the belt. The rolling resistance then slows it relative to the belt at
        // mu_r g / (1 + k), to rest on it after t2 = rel (1 + k) / (mu_r g), in which it
        // rolls back rel t2 / 2 on the belt while the belt moves u t2; from there it is
        // carried at u.
        let (mu, mu_r, u) = (0.3, 0.02, 0.8);
        let (mut rolling, _) = on_slope(0.0, mu, mu_r, 0.0);
        rolling.ground_velocity = Vector3::new(u, 0.0, 0.0);
        let s = state(&rolling, Vector3::zeros(), Vector3::zeros());
        let t1 = u * K / ((1.0 + K) * mu * G);
        let v1 = u * K / (1.0 + K);
        let x1 = 0.5 * mu * G * t1 * t1;
        let rel = u - v1;
        let t2 = rel * (1.0 + K) / (mu_r * G);
        let x2 = x1 + u * t2 - rel * t2 / 2.0;
        for (t, x, v) in [
            (t1, x1, v1),
            (t1 + t2, x2, u),
            (t1 + t2 + 1.5, x2 + 1.5 * u, u),
        ] {
            for end in both_ways(&rolling, &s, t) {
                let dx = end.com.x - s.com.x;
                assert!((dx - x).abs() < 1e-12 * x.max(1.0), "at {t}: {dx} vs {x}");
                assert!(
                    (end.v - Vector3::new(v, 0.0, 0.0)).norm() < 1e-12,
                    "at {t}: {:?}",
                    end.v
                );
                // Rolling without slip on the belt from t1 on: w x (-r n) + v = u.
                let contact = end.v + end.w.cross(&(-rolling.normal * R));
                assert!(
                    (contact.x - u).abs() < 1e-12,
                    "at {t}: contact moves at {contact:?}"
                );
            }
        }
    }

    /// The level, unresisted shortcut returns, bit for bit, the accelerations of the phase it
    /// stands for, wherever it applies: rolling or at rest, on normals with signed zeros and
    /// rounded tilts, at velocities with signed zeros.
    #[test]
    fn level_unresisted_is_the_phase_bit_for_bit() {
        let bits = |v: &Vector3<f64>| v.map(f64::to_bits);
        let normals = [
            Vector3::y(),
            Vector3::new(-0.0, 1.0, -0.0),
            Vector3::new(1e-17, 1.0, -3e-18),
            Vector3::new(0.6, 0.8, 0.0),
        ];
        let velocities = [
            Vector3::new(1.5, 0.0, -0.25),
            Vector3::new(-0.0, 0.0, -2.0),
            Vector3::new(-1e-13, -0.0, 0.0),
            Vector3::zeros(),
        ];
        let mut shortcuts = 0;
        for n in normals {
            let (mut rolling, _) = sliding_ball(Vector3::zeros(), Vector3::zeros(), 0.3);
            rolling.normal = n;
            let gn = -rolling.accel.dot(&n).min(0.0);
            let at = rolling.accel - n * rolling.accel.dot(&n);
            for v in velocities {
                // Rolling without slip: w = n x v / r.
                let st = State {
                    com: Vector3::zeros(),
                    rot: UnitQuaternion::identity(),
                    v,
                    w: n.cross(&v) / rolling.radius,
                };
                let Some((linear, angular)) = rolling.level_unresisted(&st, &at, gn) else {
                    continue;
                };
                shortcuts += 1;
                let phase = rolling.phase(&st, &at, gn, false).expect("a phase");
                let PhaseKind::Constant {
                    linear: l,
                    angular: a,
                } = phase.kind
                else {
                    panic!("not a constant phase");
                };
                assert!(phase.until == f64::INFINITY);
                assert_eq!((bits(&linear), bits(&angular)), (bits(&l), bits(&a)));
            }
        }
        assert!(shortcuts >= 8, "{shortcuts}");
    }

    /// Where the phase is not a roll at `+0` (a radius that is not positive makes the rest
    /// scale negative and the roll's direction NaN; an infinite push into the ground makes
    /// the rolling resistance's term NaN), the shortcut leaves the step to the phase.
    #[test]
    fn level_unresisted_is_asked_only_of_a_ball_of_positive_size_and_finite_push() {
        let (mut rolling, _) = sliding_ball(Vector3::zeros(), Vector3::zeros(), 0.3);
        let n = rolling.normal;
        let gn = -rolling.accel.dot(&n).min(0.0);
        let at = rolling.accel - n * rolling.accel.dot(&n);
        let spinning = State {
            com: Vector3::zeros(),
            rot: UnitQuaternion::identity(),
            v: Vector3::zeros(),
            w: Vector3::z(),
        };
        assert!(
            rolling
                .level_unresisted(&spinning, &at, f64::INFINITY)
                .is_none()
        );
        rolling.radius = f64::NEG_INFINITY;
        assert!(rolling.level_unresisted(&spinning, &at, gn).is_none());
    }
}
