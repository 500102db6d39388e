//! How far something moving in one dimension travels before it can stop,
//! braking as hard as the acceleration and jerk limits allow: the
//! time-optimal profile Ruckig's velocity interface follows for a zero
//! target (jerk −J until the acceleration reaches −A or a peak, hold, jerk
//! +J back to zero). Pure arithmetic, RT-safe.

/// Room needed ahead if braking starts one cycle of `dt` from now, with
/// the worst case meanwhile (full jerk towards the boundary): the travel in
/// that cycle plus the stopping distance from where it leaves the motion.
/// Braking now is due when this reaches the room left.
pub fn room_to_brake_next_cycle(v: f64, a: f64, a_max: f64, j_max: f64, dt: f64) -> f64 {
    v * dt
        + a * dt * dt / 2.0
        + j_max * dt * dt * dt / 6.0
        + stopping_distance(
            v + a * dt + j_max * dt * dt / 2.0,
            a + j_max * dt,
            a_max,
            j_max,
        )
}

/// The state one cycle of `dt` later when braking as hard as the limits
/// allow: the planner's fallback (if it ever fails, the arm still brakes
/// jerk-limited along the time-optimal profile). At rest: `(0, 0)`.
pub fn brake_step(v: f64, a: f64, a_max: f64, j_max: f64, dt: f64) -> (f64, f64) {
    if !(v.is_finite() && a.is_finite()) {
        return (0.0, 0.0);
    }
    let (mut v, mut a, mut left) = (v, a, dt);
    for phase in brake_phases(v, a, a_max, j_max).iter().flatten() {
        let t = phase.duration.min(left);
        v += a * t + phase.jerk * t * t / 2.0;
        a += phase.jerk * t;
        left -= t;
        if left <= 0.0 {
            return (v, a);
        }
    }
    (0.0, 0.0)
}

/// One phase of constant jerk.
#[derive(Debug, Clone, Copy)]
struct Phase {
    jerk: f64,
    duration: f64,
}

/// Furthest forward position reached from (`v`, `a`) at position 0 while
/// braking to rest under `a_max`, `j_max`. Positive means towards +;
/// 0 when nothing moves forward.
pub fn stopping_distance(v: f64, a: f64, a_max: f64, j_max: f64) -> f64 {
    let phases = brake_phases(v, a, a_max, j_max);
    let (mut p, mut v, mut a) = (0.0f64, v, a);
    let mut furthest = 0.0f64;
    for phase in phases.iter().flatten() {
        let (j, t) = (phase.jerk, phase.duration);
        furthest = furthest.max(furthest_in_phase(p, v, a, j, t));
        p += v * t + a * t * t / 2.0 + j * t * t * t / 6.0;
        v += a * t + j * t * t / 2.0;
        a += j * t;
    }
    furthest.max(p)
}

/// The furthest position within one constant-jerk phase: at its ends or
/// where the velocity crosses zero.
fn furthest_in_phase(p: f64, v: f64, a: f64, j: f64, t: f64) -> f64 {
    let at = |tau: f64| p + v * tau + a * tau * tau / 2.0 + j * tau * tau * tau / 6.0;
    let mut best = at(0.0).max(at(t));
    // v + a τ + j τ²/2 = 0
    let roots = if j.abs() < 1e-300 {
        [(a.abs() > 1e-300).then(|| -v / a), None]
    } else {
        let disc = a * a - 2.0 * j * v;
        if disc < 0.0 {
            [None, None]
        } else {
            let s = disc.sqrt();
            [Some((-a + s) / j), Some((-a - s) / j)]
        }
    };
    for tau in roots.into_iter().flatten() {
        if tau > 0.0 && tau < t {
            best = best.max(at(tau));
        }
    }
    best
}

/// The three phases that bring (`v`, `a`) to (0, 0) fastest.
fn brake_phases(v: f64, a: f64, a_max: f64, j_max: f64) -> [Option<Phase>; 3] {
    // Velocity left if the acceleration were ramped to zero right away.
    let v_flat = v + a * a.abs() / (2.0 * j_max);
    // Work in the frame where braking means negative acceleration.
    let sign = if v_flat >= 0.0 { 1.0 } else { -1.0 };
    let (v, a) = (v * sign, a * sign);
    // Peak deceleration a1 ≤ 0: v + (a² − 2 a1²)/(2J) + a1·t2 = 0.
    let peak_sq = j_max * v + a * a / 2.0;
    let (a1, hold) = if peak_sq <= a_max * a_max {
        (-peak_sq.max(0.0).sqrt(), 0.0)
    } else {
        let t2 = (v + (a * a - 2.0 * a_max * a_max) / (2.0 * j_max)) / a_max;
        (-a_max, t2.max(0.0))
    };
    [
        Some(Phase {
            jerk: -j_max * sign,
            duration: ((a - a1) / j_max).max(0.0),
        }),
        Some(Phase {
            jerk: 0.0,
            duration: hold,
        }),
        Some(Phase {
            jerk: j_max * sign,
            duration: (-a1 / j_max).max(0.0),
        }),
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Simulates braking with a fine time step: the reference.
    fn simulated(v0: f64, a0: f64, a_max: f64, j_max: f64) -> (f64, f64, f64) {
        let phases = brake_phases(v0, a0, a_max, j_max);
        let (mut p, mut v, mut a) = (0.0f64, v0, a0);
        let mut furthest = 0.0f64;
        let dt = 1e-6;
        for phase in phases.iter().flatten() {
            let steps = (phase.duration / dt).round() as u64;
            for _ in 0..steps {
                p += v * dt + a * dt * dt / 2.0 + phase.jerk * dt * dt * dt / 6.0;
                v += a * dt + phase.jerk * dt * dt / 2.0;
                a += phase.jerk * dt;
                furthest = furthest.max(p);
            }
        }
        (furthest, v, a)
    }

    #[test]
    fn from_cruise_with_a_hold_phase() {
        // 0.2 m/s, A = 0.64, J = 3.2: t1 = t3 = 0.2 s, Δv in them 0.064
        // each, hold t2 = (0.2 − 0.128)/0.64 = 0.1125 s.
        // Distance: phase 1: 0.2·0.2 − 3.2·0.008/6 = 0.0357333…
        // phase 2 from v = 0.136: 0.136·0.1125 − 0.32·0.1125² = 0.0112500
        // phase 3 from v = 0.064: 0.064·0.2 − 0.32·0.04 + 3.2·0.008/6 = 0.0042667
        let d = stopping_distance(0.2, 0.0, 0.64, 3.2);
        assert!((d - 0.05125).abs() < 1e-12, "{d}");
    }

    #[test]
    fn short_brake_without_a_hold_phase() {
        // Peak deceleration √(J v) = √(3.2·0.05) = 0.4 < A: t1 = t3 = 0.125 s,
        // distance = v·t_total/2 by symmetry = 0.05 · 0.25 / 2.
        let d = stopping_distance(0.05, 0.0, 0.64, 3.2);
        assert!((d - 0.00625).abs() < 1e-12, "{d}");
    }

    #[test]
    fn matches_simulation_and_ends_at_rest() {
        for &(v, a) in &[
            (0.2, 0.64),
            (0.2, -0.64),
            (0.01, -0.6),
            (0.0, 0.3),
            (-0.1, 0.5),
            (0.15, 0.2),
            (1.07, 2.75),
        ] {
            let (a_max, j_max) = if v > 0.5 { (2.75, 14.0) } else { (0.64, 3.2) };
            let (furthest, v_end, a_end) = simulated(v, a, a_max, j_max);
            let d = stopping_distance(v, a, a_max, j_max);
            assert!(
                (d - furthest).abs() < 1e-5,
                "v {v} a {a}: {d} vs {furthest}"
            );
            assert!(
                v_end.abs() < 1e-5 && a_end.abs() < 1e-5,
                "v {v} a {a}: ends at {v_end} {a_end}"
            );
        }
    }

    #[test]
    fn brake_steps_follow_the_profile_to_rest() {
        let (a_max, j_max, dt) = (0.64, 12.8, 0.001);
        let (mut v, mut a) = (0.2, 0.3);
        let mut ticks = 0;
        while (v, a) != (0.0, 0.0) {
            let (v1, a1) = brake_step(v, a, a_max, j_max, dt);
            assert!(a1.abs() <= a_max * (1.0 + 1e-12), "{a1}");
            assert!((a1 - a).abs() <= j_max * dt * (1.0 + 1e-9), "{a} → {a1}");
            (v, a) = (v1, a1);
            ticks += 1;
            assert!(ticks < 1000);
        }
        // a → 0 (0.3/12.8), then the usual stop from the peak speed.
        assert!((300..400).contains(&ticks), "{ticks}");
    }

    #[test]
    fn nothing_forward_when_at_rest_or_moving_away() {
        assert_eq!(stopping_distance(0.0, 0.0, 0.64, 3.2), 0.0);
        assert_eq!(stopping_distance(-0.2, 0.0, 0.64, 3.2), 0.0);
        assert_eq!(stopping_distance(-0.2, -0.3, 0.64, 3.2), 0.0);
    }
}
