//! Unit tests of the servo logic, stepping it alone.

use super::*;
use params::{LINK1_THESIS as LINK1_LAW, LINK2_THESIS as LINK2_LAW, LINKS, THESIS, TIMER_TICK_Q40};
use proptest::prelude::*;

/// The thesis's constants: the regime tests check law III.36 against the thesis's numbers.
const T1: &LinkConst = &THESIS[0];
/// The board's constants.
const K1: &LinkConst = &params::TUNED[0];
const K2: &LinkConst = &params::TUNED[1];

fn q16(x: f64) -> i32 {
    (x * 65536.0).round() as i32
}

#[test]
fn link_2_is_derived_like_link_1() {
    let near = |p: &params::LawParams, i: f64| {
        let k = p.uhat_nm * p.eps / p.s_sat_rad;
        let b = p.uhat_nm / p.omega_sat_rad_s;
        (
            (k / i).sqrt() / std::f64::consts::TAU,
            b / (2.0 * (k * i).sqrt()),
        )
    };
    let (f1, z1) = near(&LINK1_LAW, arm::LINK1.inertia_kgm2);
    let (f2, z2) = near(&LINK2_LAW, arm::LINK2.inertia_kgm2);
    assert!(
        (f1 - 9.9).abs() < 0.1 && (z1 - 0.995).abs() < 0.01,
        "{f1} Hz zeta {z1}"
    );
    assert!(
        (f2 - f1).abs() < 1e-9 && (z2 - z1).abs() < 1e-9,
        "{f2} Hz zeta {z2}"
    );
    assert!((LINK2_LAW.omega_sat_rad_s - 6.04).abs() < 0.01);
    assert!((LINK2_LAW.s_sat_rad - 0.772).abs() < 0.001);
}

#[test]
fn observer_gains_map_the_continuous_poles() {
    let (k1, k2) = params::observer_gains(params::T_NOMINAL_S);
    assert!((k1 - 892.6).abs() < 1.0, "{k1}");
    assert!((k2 - 344_400.0).abs() < 1000.0, "{k2}");
    // At a vanishing period the discrete gains tend to the continuous ones.
    let (a, b) = params::observer_gains(1e-7);
    assert!(
        (a - 900.0).abs() < 0.1 && (b - 400_000.0).abs() < 100.0,
        "{a} {b}"
    );
}

#[test]
fn each_regime_of_the_law() {
    // Far from the goal at rest: full torque toward it.
    let (u, r) = law(T1, T1.brake_q32, q16(-3.0), 0);
    assert_eq!(r, Regime::Saturated);
    assert_eq!(u, T1.umax_q16);
    // On the switching curve while braking: err = -w^2 I/(2u^) makes s~ = 0; the velocity
    // term alone (saturated at 1) gives u^ of braking torque: sliding, not saturated.
    let w = 20.0;
    let err = -w * w * arm::LINK1.inertia_kgm2 / (2.0 * LINK1_LAW.uhat_nm);
    let (u, r) = law(T1, T1.brake_q32, q16(err), q16(w));
    assert_eq!(r, Regime::Sliding);
    let u_nm = u as f64 / 65536.0;
    assert!((u_nm + LINK1_LAW.uhat_nm).abs() < 0.01, "{u_nm}");
    // Near the goal: PD with K = 182.6 N m/rad, b = 5.83 N m s.
    let (u, r) = law(T1, T1.brake_q32, q16(0.001), q16(0.0));
    assert_eq!(r, Regime::Linear);
    let k = LINK1_LAW.uhat_nm * LINK1_LAW.eps / LINK1_LAW.s_sat_rad;
    assert!(
        ((u as f64 / 65536.0) + k * 0.001).abs() < 0.002,
        "{}",
        u as f64 / 65536.0
    );
    let (u, _) = law(T1, T1.brake_q32, 0, q16(0.1));
    let b = LINK1_LAW.uhat_nm / LINK1_LAW.omega_sat_rad_s;
    assert!(
        ((u as f64 / 65536.0) + b * 0.1 + k * 0.1 * 0.1 * arm::LINK1.inertia_kgm2 / 21.0).abs()
            < 0.01
    );
}

#[test]
fn the_arrest_point_is_where_the_switching_curve_stops() {
    // The thesis's form with u = umax: theta + w|w| I / (2 umax).
    let w = 10.0;
    let umax_brake = fx::host_div_shl(
        (arm::LINK1.inertia_kgm2 * 65536.0) as i32,
        (2.0 * 13.0 * 65536.0) as i32,
        32,
    );
    let a = arrest_point(umax_brake, q16(1.0), q16(w)) as f64 / 65536.0;
    let want = 1.0 + w * w / (2.0 * 13.0 / arm::LINK1.inertia_kgm2);
    assert!((a - want).abs() < 1e-3, "{a} vs {want}");
    // The board's: braking at u^ with the prior inertia (1.25 x nominal until measured),
    // always further out.
    let a = arrest_point(K2.brake_q32, q16(0.0), q16(-w)) as f64 / 65536.0;
    let uhat = params::LINK2_TUNED.uhat_nm;
    let i = params::PRIOR_INERTIA_SCALE * arm::LINK2.inertia_kgm2;
    assert!((a + w * w * i / (2.0 * uhat)).abs() < 1e-3, "{a}");
    assert!(a < -w * w / (2.0 * arm::LINK2.torque_limit_nm / arm::LINK2.inertia_kgm2));
}

#[test]
fn each_regime_of_the_proximate_law() {
    let k = K1;
    let two_a = k.two_a_q16;
    let a = two_a as f64 / 65536.0 / 2.0; // rad/s^2
    let b = k.b_q16 as f64 / 65536.0;
    let slope = k.slope_q16 as f64 / 65536.0;
    let yl = 2.0 * a * (k.yl_per_two_a_q32 as f64 / 4294967296.0);
    let c = 2.0 * a * (k.c_per_two_a_q32 as f64 / 4294967296.0);
    // Far from the goal at rest: full torque toward it.
    let (u, r) = proximate_law(k, two_a, q16(-3.0), 0);
    assert_eq!((u, r), (k.umax_q16, Regime::Saturated));
    // Braking down the curve: u^ / b faster than the curve's speed gives u^ of braking.
    let e = -0.5;
    let uhat = k.uhat_q16 as f64 / 65536.0;
    let w = (2.0 * a * 0.5f64).sqrt() - c + uhat / b;
    let (u, r) = proximate_law(k, two_a, q16(e), q16(w));
    assert_eq!(r, Regime::Sliding);
    assert!(
        (u as f64 / 65536.0 + uhat).abs() < 0.02,
        "{}",
        u as f64 / 65536.0
    );
    // Near the goal: PD with K = b slope.
    let (u, r) = proximate_law(k, two_a, q16(0.001), q16(0.01));
    assert_eq!(r, Regime::Linear);
    let (eq, wq) = (q16(0.001) as f64 / 65536.0, q16(0.01) as f64 / 65536.0);
    let want = -b * slope * eq - b * wq;
    assert!(
        (u as f64 / 65536.0 - want).abs() < 0.01,
        "{} vs {want}",
        u as f64 / 65536.0
    );
    // The curve joins the line continuously at y_l: the command just inside and just
    // outside differs by no more than the step in position would make it.
    let (ui, _) = proximate_law(k, two_a, q16(-yl * 0.999), 0);
    let (uo, _) = proximate_law(k, two_a, q16(-yl * 1.001), 0);
    assert!((ui - uo).abs() < q16(0.05), "{ui} {uo}");
}

#[test]
fn near_the_goal_friction_is_compensated_and_rest_is_quiet() {
    let k = K1;
    let fc = k.friction_comp_q16;
    // Moving: friction torque in the direction of motion is added.
    assert_eq!(near_goal(k, q16(1.0), q16(-0.1), q16(2.0)), q16(1.0) + fc);
    assert_eq!(near_goal(k, q16(1.0), q16(-0.1), q16(-2.0)), q16(1.0) - fc);
    // At rest outside the dead band: the law's direction, at full friction for 0.1 N m.
    assert_eq!(near_goal(k, q16(-0.5), q16(0.01), 0), q16(-0.5) - fc);
    // At rest within the dead band: damping only (zero at zero speed).
    assert_eq!(near_goal(k, q16(0.3), k.deadband_q16 / 2, 0), 0);
    // Never beyond umax.
    assert_eq!(near_goal(k, k.umax_q16, q16(-1.0), q16(5.0)), k.umax_q16);
    // The thesis's constants have none of it.
    assert_eq!(near_goal(T1, q16(0.3), 0, 0), q16(0.3));
}

#[test]
fn the_notch_removes_the_resonance_and_passes_steady_torque() {
    let run = |hz: f64| {
        let mut n = Notch::default();
        let mut peak = 0i32;
        for i in 0..3000 {
            let x = q16((std::f64::consts::TAU * hz * i as f64 / 3000.0).sin());
            let y = n.filter(K1, x);
            if i > 1500 {
                peak = peak.max(y.abs());
            }
        }
        peak as f64 / 2048.0 // Q11
    };
    assert!(run(arm::LINK1.resonance_hz) < 0.05, "{}", run(212.0));
    assert!((run(5.0) - 1.0).abs() < 0.02, "{}", run(5.0));
    let mut n = Notch::default();
    let mut y = 0;
    for _ in 0..300 {
        y = n.filter(K1, q16(2.0));
    }
    // Within one Q11 step: b0 = (1 + a2) / 2 keeps the coefficients' gain at DC 1 (rounded
    // independently, it was 0.1% off: 4,100 for 4,096); the filter's rounding leaves a step.
    assert!((y - 2 * 2048).abs() <= 1, "{y}");
}

#[test]
fn the_inertia_estimate_measures_a_heavier_link() {
    // A pure inertia 1.2 x nominal under full torque, sampled at 3 kHz.
    let k = K1;
    let i_true = 1.2 * arm::LINK1.inertia_kgm2;
    let dt_q32 = fx::mul_shr(667, TIMER_TICK_Q40, 8);
    let dt = 667.0 / 2e6;
    let u = k.umax_q16;
    let mut est = InertiaEstimate::new(k);
    let mut w = 0.0;
    for _ in 0..200 {
        est.observe(k, true, u, q16(w), dt_q32);
        w += (u as f64 / 65536.0) / i_true * dt;
    }
    let got = est.inertia_q32 as f64 / 4294967296.0;
    assert!((got / i_true - 1.0).abs() < 0.01, "{got} vs {i_true}");
    let two_a = est.two_a_q16 as f64 / 65536.0;
    let want = 2.0 * (k.uhat_q16 as f64 / 65536.0) / i_true;
    assert!((two_a / want - 1.0).abs() < 0.01, "{two_a} vs {want}");
    // An implausible reading (a link blocked: no speed gained) is refused.
    let mut est = InertiaEstimate::new(k);
    for _ in 0..2000 {
        est.observe(k, true, u, q16(0.001), dt_q32);
    }
    assert_eq!(est.inertia_q32, 0);
    assert_eq!(est.two_a_q16, k.two_a_q16);
}

#[test]
fn torque_maps_to_dac_codes_within_range() {
    assert_eq!(dac_code(K1, 0), 0);
    assert_eq!(
        dac_code(K1, K1.umax_q16),
        params::DAC_MAX,
        "umax is full scale: clamps to 2047"
    );
    assert_eq!(dac_code(K1, -K1.umax_q16), params::DAC_MIN);
    // 6.5 N m on link 1 = 5 A = 5 V = code 1024.
    assert_eq!(dac_code(K1, q16(6.5)), 1024);
    // 1.625 N m on link 2 = 5 A: code 1024.
    assert_eq!(dac_code(K2, q16(1.625)), 1024);
}

fn input(enc: [i32; 2], timer: u16, goal: [f64; 2], cycle: u32) -> Input {
    Input {
        enc: [enc[0] as u16, enc[1] as u16],
        timer,
        subgoal: Some(Subgoal {
            goal_urad: [(goal[0] * 1e6) as i32, (goal[1] * 1e6) as i32],
            cycle,
        }),
    }
}

#[test]
fn the_timer_and_counters_unwrap() {
    let mut s = Servo::new();
    s.step(&input([-5, 100], 65000, [0.0; 2], 1));
    let o = s.step(&input([-5 + 100, 100], 200, [0.0; 2], 2));
    assert_eq!(o.period_ticks, 736, "65000 -> 200 across the wrap");
    // +40000 counts on link 1, 100 per latch, wrap the 16-bit counter past +32767: the
    // extension must still count them all.
    let mut o = o;
    for n in 2..=400 {
        o = s.step(&input(
            [-5 + 100 * n, 100],
            200u16.wrapping_add(667u16.wrapping_mul(n as u16)),
            [0.0; 2],
            2 + n as u32,
        ));
    }
    let want = (40000 - 5) as f64 * std::f64::consts::TAU / 32768.0;
    assert!(
        (o.theta_q16[0] as f64 / 65536.0 - want).abs() < 1e-4,
        "{}",
        o.theta_q16[0]
    );
    assert_eq!(TIMER_TICK_Q40, 549_756);
}

#[test]
fn the_arrest_points_come_every_other_pass_and_the_log_clock_every_pass() {
    let mut s = Servo::new();
    let mut outs = Vec::new();
    let mut t = 0u16;
    for k in 0..12 {
        // Link 1 turning (its counts rising), toward a goal 0.5 rad out.
        outs.push(s.step(&input([k * k * 30, 0], t, [0.5, 0.0], 1 + k as u32)));
        t = t.wrapping_add(667);
    }
    for (k, o) in outs.iter().enumerate() {
        assert_eq!(o.arrest_new, k % 2 == 0, "pass {k}");
        if k % 2 == 1 {
            // Carried: the last pass's.
            assert_eq!(o.arrest_q16, outs[k - 1].arrest_q16, "pass {k}");
        } else if k > 0 {
            // Computed from this pass's angle and speed with the link's brake.
            for i in 0..2 {
                let want = arrest_point(s.law[i].est.brake_q32, o.theta_q16[i], o.omega_q16[i]);
                assert_eq!(o.arrest_q16[i], want, "pass {k} link {i}");
            }
        }
    }
    // The link moved, so the arrest points did.
    assert_ne!(outs[10].arrest_q16, outs[2].arrest_q16);
    // The log holds the six passes that computed them; its clock counts all twelve periods
    // (the first pass's period is its timer reading, 0).
    let (n, kept, times, _) = s.log.raw();
    assert_eq!((n, kept), (6, 6));
    let dt_q24 = (fx::mul_shr(667, TIMER_TICK_Q40, 8) >> 8) as u32;
    assert_eq!(s.clock_q24, 11 * dt_q24);
    assert_eq!(times[5], 10 * dt_q24);
}

#[test]
fn the_first_pass_only_initialises() {
    let mut s = Servo::new();
    let o = s.step(&input([1000, -300], 10, [1.0, 1.0], 1));
    assert!(!o.enable);
    assert_eq!(o.dac, [0, 0]);
    assert_eq!(
        s.observers()[0].theta_q16(),
        // The middle of count 1000.
        fx::mul_shr(2 * 1000 + 1, K1.rad_per_count_q32, 17)
    );
}

#[test]
fn the_observer_converges_to_a_ramp() {
    // Link 2 turning at 5 rad/s, sampled at 3 kHz with the encoder's quantisation.
    let mut obs = Observer::default();
    let dt_ticks = 667u16;
    let dt_q32 = fx::mul_shr(dt_ticks as i32, TIMER_TICK_Q40, 8);
    let dt = dt_ticks as f64 / 2e6;
    let counts_per_rad = 8192.0 / std::f64::consts::TAU;
    for n in 1..=300 {
        let theta = 5.0 * dt * n as f64;
        let y = fx::mul_shr(
            (theta * counts_per_rad).floor() as i32,
            K2.rad_per_count_q32,
            16,
        );
        obs.update(K2, y, 0, dt_q32);
    }
    let w = obs.omega_q16 as f64 / 65536.0;
    assert!((w - 5.0).abs() < 0.05, "observed {w} rad/s");
}

#[test]
fn a_stale_subgoal_makes_the_servo_hold_at_its_arrest_point_once() {
    let mut s = Servo::new();
    let mut timer = 0u16;
    let mut step = |s: &mut Servo, cycle| {
        timer = timer.wrapping_add(667);
        s.step(&input([0, 0], timer, [0.5, 0.0], cycle))
    };
    for c in 0..10 {
        let o = step(&mut s, c);
        assert_eq!(o.hold, None);
    }
    // The reflex stops: the cycle counter freezes. 20 ms later the servo holds.
    let mut faults = 0;
    let mut held = None;
    for _ in 0..100 {
        let o = step(&mut s, 9);
        if o.new_fault.is_some() {
            faults += 1;
            assert_eq!(o.new_fault, Some(Hold::Stale));
        }
        if o.hold == Some(Hold::Stale) {
            held.get_or_insert(o.goal_q16);
            assert_eq!(Some(o.goal_q16), held, "the hold goal stays put");
            assert_ne!(o.goal_q16[0], urad_to_q16(500_000), "not the stale subgoal");
        }
    }
    assert_eq!(faults, 1, "the fault is recorded once");
    // Fresh again: it follows the subgoal.
    let o = step(&mut s, 10);
    assert_eq!(o.hold, None);
    assert_eq!(o.goal_q16[0], urad_to_q16(500_000));
}

#[test]
fn torn_missing_and_out_of_range_subgoals_hold() {
    let mut s = Servo::new();
    let o = s.step(&Input {
        enc: [0, 0],
        timer: 0,
        subgoal: None,
    });
    assert_eq!(
        (o.hold, o.new_fault),
        (Some(Hold::NoSubgoal), None),
        "start-up: hold quietly"
    );
    s.step(&input([0, 0], 667, [0.1, 0.0], 1));
    let o = s.step(&Input {
        enc: [0, 0],
        timer: 1334,
        subgoal: None,
    });
    assert_eq!((o.hold, o.new_fault), (Some(Hold::Torn), Some(Hold::Torn)));
    let o = s.step(&input([0, 0], 2001, [30.0, 0.0], 2));
    assert_eq!(
        (o.hold, o.new_fault),
        (Some(Hold::OutOfRange), Some(Hold::OutOfRange))
    );
}

#[test]
fn unit_conversions() {
    assert_eq!(urad_to_q16(1_000_000), 65536);
    assert_eq!(urad_to_q16(-3_000_000), -196_608);
    assert_eq!(q16_to_urad(65536), 1_000_000);
    // Q16's LSB is 15.26 urad: a round trip is exact to half of it.
    for u in [1_234_567, -7, 25_000_000, -25_000_000] {
        assert!((q16_to_urad(urad_to_q16(u)) - u).abs() <= 8, "{u}");
    }
}

#[test]
fn the_shift_and_add_conversion_is_the_product_at_and_around_its_range_edges() {
    let edge = 1i32 << 22;
    let near = |c: i32| (c - 3000..=c + 3000).collect::<Vec<_>>();
    let mut qs: Vec<i32> = [near(0), near(edge), near(-edge), near(65536), near(-65536)].concat();
    qs.extend([
        i32::MIN,
        i32::MIN + 1,
        i32::MAX,
        i32::MAX - 1,
        140_737_488,
        -140_737_489,
    ]);
    for q in qs {
        assert_eq!(q16_to_urad(q), fx::host_mul_shr(q, 1_000_000, 16), "{q}");
    }
}

proptest! {
    #[test]
    fn the_shift_and_add_conversion_is_the_product(q in any::<i32>()) {
        prop_assert_eq!(q16_to_urad(q), fx::host_mul_shr(q, 1_000_000, 16));
    }

    #[test]
    fn the_command_never_exceeds_umax(err in -100.0f64..100.0, w in -700.0f64..700.0, link in 0usize..2) {
        let k = &LINKS[link];
        let t = &THESIS[link];
        let (u, _) = law(t, t.brake_q32, q16(err), q16(w));
        prop_assert!(u.abs() <= t.umax_q16);
        let (u, _) = proximate_law(k, k.two_a_q16, q16(err), q16(w));
        prop_assert!(u.abs() <= k.umax_q16);
        let u = near_goal(k, u, q16(err), q16(w));
        prop_assert!(u.abs() <= k.umax_q16);
        let code = dac_code(k, u);
        let nm = code as i32 * k.nm_per_dac_q16;
        prop_assert!(nm.abs() <= k.umax_q16);
    }

    #[test]
    fn any_encoder_and_timer_sequence_stays_within_umax(
        seq in proptest::collection::vec((any::<u16>(), any::<u16>(), any::<u16>(), -30_000_000i32..30_000_000, any::<bool>()), 1..60)
    ) {
        let mut s = Servo::new();
        for (i, (e0, e1, t, g, fresh)) in seq.into_iter().enumerate() {
            let sub = fresh.then_some(Subgoal { goal_urad: [g, -g], cycle: i as u32 });
            let o = s.step(&Input { enc: [e0, e1], timer: t, subgoal: sub });
            for (l, k) in LINKS.iter().enumerate() {
                prop_assert!(o.torque_q16[l].abs() <= k.umax_q16);
                prop_assert!((params::DAC_MIN..=params::DAC_MAX).contains(&o.dac[l]));
            }
        }
    }
}
