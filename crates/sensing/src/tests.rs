//! Unit tests of the sensing logic: the board alone, with a linear calibration table and
//! samples made up in the test.

use crate::cal::{self, CalWords, Checker, Reason, State};
use crate::filter::{self, Filter, LONG, MIN_VALID, SHORT};
use crate::*;
use proptest::prelude::*;
use vme_map::records::cal as fmt;

/// Q5 codes per micrometre of the linear test sensor: 1 code = 0.2 mm.
const Q5_PER_MM: f64 = 32.0 / 0.2;

/// A table for a linear sensor: signal = position / 0.2 mm per code.
fn linear_table() -> Vec<u32> {
    let mut w = vec![0u32; fmt::WORDS as usize];
    w[fmt::W_MAGIC as usize] = fmt::MAGIC;
    w[fmt::W_VERSION as usize] = fmt::VERSION;
    w[fmt::W_GENERATION as usize] = 7;
    w[fmt::W_WORDS as usize] = fmt::WORDS;
    w[fmt::W_S_REF as usize] = DEFAULT_S_REF_CODES as u32;
    w[fmt::W_FWD_N as usize] = fmt::FWD_N;
    w[fmt::W_FWD_X0 as usize] = (-350_000i32) as u32;
    w[fmt::W_FWD_Y0 as usize] = (-350_000i32) as u32;
    w[fmt::W_FWD_PITCH as usize] = 20_000;
    w[fmt::W_INV_N as usize] = fmt::INV_N;
    for (k, v) in [-350_000i32, 350_000, -350_000, 350_000].iter().enumerate() {
        w[fmt::W_AREA as usize + k] = *v as u32;
    }
    let n = fmt::FWD_N as usize;
    for j in 0..n {
        for i in 0..n {
            let p = [-350.0 + 20.0 * i as f64, -350.0 + 20.0 * j as f64];
            let k = fmt::FWD as usize + 2 * (j * n + i);
            w[k] = (p[0] * Q5_PER_MM).round() as i32 as u32;
            w[k + 1] = (p[1] * Q5_PER_MM).round() as i32 as u32;
        }
    }
    let n = fmt::INV_N as usize;
    for j in 0..n {
        for i in 0..n {
            let c = [
                (i as f64 * 64.0 - 2048.0) * 32.0,
                (j as f64 * 64.0 - 2048.0) * 32.0,
            ];
            let k = fmt::INV as usize + 2 * (j * n + i);
            w[k] = ((c[0] / Q5_PER_MM) * 1000.0).round() as i32 as u32;
            w[k + 1] = ((c[1] / Q5_PER_MM) * 1000.0).round() as i32 as u32;
        }
    }
    w[fmt::W_CHECKSUM as usize] = cal::checksum(&w);
    w
}

struct Words(Vec<u32>);
impl CalWords for Words {
    fn word(&mut self, i: u32) -> u32 {
        self.0[i as usize]
    }
}

fn check_fully(c: &mut Checker, t: &mut Words) -> Option<Reason> {
    let mut last = None;
    for _ in 0..=fmt::WORDS / cal::CHECK_WORDS + 1 {
        if let Some(r) = c.step(t) {
            last = Some(r);
        }
    }
    last
}

#[test]
fn a_good_table_is_accepted_after_its_words_are_read() {
    let mut t = Words(linear_table());
    let mut c = Checker::new();
    for _ in 0..fmt::WORDS / cal::CHECK_WORDS {
        assert_eq!(c.step(&mut t), None);
        assert!(c.header().is_none(), "not in use before every word is read");
    }
    assert_eq!(check_fully(&mut c, &mut t), None);
    let h = c.header().expect("accepted");
    assert_eq!(h.pitch_um, 20_000);
    assert_eq!(h.area_um, [-350_000, 350_000, -350_000, 350_000]);
}

/// The common slot's assembly takes the lookup's products 16 x 16 bits, so a table goes to it
/// only when every step between neighbouring inverse nodes fits a word: one node moved so
/// that a step along a row (x) or down a column (y) is one micrometre too wide clears the
/// mask, one micrometre less keeps it, and a table of another generation is judged afresh.
/// The steps are checked after the table is accepted (`Checker::step_steps`, in the slots
/// the Rust takes: its first positions as soon as before); until then the mask is clear. (The linear table steps 12.8 mm along both; a
/// row's last node is not its next row's first node's neighbour, 819 mm away.)
#[test]
fn only_tables_whose_node_steps_fit_a_word_go_to_the_word_lookup() {
    let mut c = Checker::new();
    let mut t = Words(linear_table());
    assert_eq!(check_fully(&mut c, &mut t), None);
    assert!(c.header().is_some(), "in use");
    assert_eq!(c.word_steps_mask(), 0, "steps not checked yet");
    let slots = (fmt::WORDS - fmt::INV).div_ceil(cal::CHECK_WORDS);
    for _ in 1..slots {
        c.step_steps(&mut t);
    }
    assert_eq!(c.word_steps_mask(), 0, "the last steps not checked yet");
    c.step_steps(&mut t);
    assert_eq!(c.word_steps_mask(), usize::MAX, "every step checked");
    let check_steps = |c: &mut Checker, t: &mut Words| {
        for _ in 0..slots {
            c.step_steps(t);
        }
    };
    let n = fmt::INV_N as usize;
    let step = cal::MAX_WORD_STEP_UM - 12_800;
    for (comp, by, wide) in [
        (0, step, false),
        (0, step + 1, true),
        (1, step, false),
        (1, step + 1, true),
    ] {
        let mut w = linear_table();
        w[fmt::W_GENERATION as usize] = 8 + comp as u32 * 2 + wide as u32;
        let k = fmt::INV as usize + 2 * (20 * n + 10) + comp;
        w[k] = (w[k] as i32 + by) as u32;
        w[fmt::W_CHECKSUM as usize] = cal::checksum(&w);
        let mut t = Words(w);
        assert_eq!(check_fully(&mut c, &mut t), None, "still a good table");
        check_steps(&mut c, &mut t);
        assert!(c.header().is_some());
        let mask = if wide { 0 } else { usize::MAX };
        assert_eq!(c.word_steps_mask(), mask, "component {comp} moved {by} um");
    }
    let mut t = Words(linear_table());
    assert_eq!(check_fully(&mut c, &mut t), None);
    check_steps(&mut c, &mut t);
    assert_eq!(
        c.word_steps_mask(),
        usize::MAX,
        "a new table is judged afresh"
    );
}

#[test]
fn corrupt_tables_are_refused_with_their_reason() {
    type Spoil = fn(&mut Vec<u32>);
    let cases: [(&str, Spoil, Reason); 5] = [
        (
            "never written",
            |w| w.iter_mut().for_each(|x| *x = 0),
            Reason::Missing,
        ),
        (
            "other version",
            |w| w[fmt::W_VERSION as usize] = 2,
            Reason::Format,
        ),
        (
            "zero pitch",
            |w| w[fmt::W_FWD_PITCH as usize] = 0,
            Reason::Pitch,
        ),
        (
            "a node 2 m out",
            |w| w[fmt::INV as usize + 100] = 2_000_000,
            Reason::Node,
        ),
        (
            "one flipped bit",
            |w| w[fmt::FWD as usize + 33] ^= 1 << 9,
            Reason::Checksum,
        ),
    ];
    for (what, spoil, reason) in cases {
        let mut w = linear_table();
        spoil(&mut w);
        let mut c = Checker::new();
        assert_eq!(check_fully(&mut c, &mut Words(w)), Some(reason), "{what}");
        assert_eq!(c.state, State::Bad(reason), "{what}");
        assert!(c.header().is_none(), "{what}: never used");
    }
}

#[test]
fn a_new_generation_is_checked_again_before_use() {
    let mut t = Words(linear_table());
    let mut c = Checker::new();
    check_fully(&mut c, &mut t);
    assert!(c.header().is_some());
    // The host rewrites the table: magic cleared first, then the words, then the magic.
    t.0[fmt::W_MAGIC as usize] = 0;
    assert_eq!(c.step(&mut t), Some(Reason::Missing));
    t.0[fmt::W_MAGIC as usize] = fmt::MAGIC;
    t.0[fmt::W_GENERATION as usize] = 8;
    t.0[fmt::W_CHECKSUM as usize] = cal::checksum(&t.0);
    assert_eq!(c.step(&mut t), None);
    assert!(c.header().is_none(), "checking the new table");
    assert_eq!(check_fully(&mut c, &mut t), None);
    assert!(c.header().is_some());
}

#[test]
fn lookups_of_a_linear_table_are_exact_to_a_micrometre() {
    let mut t = Words(linear_table());
    let mut c = Checker::new();
    check_fully(&mut c, &mut t);
    let h = c.header().unwrap();
    for p_mm in [[0.0, 0.0], [123.4, -77.7], [-349.0, 349.0], [301.25, 12.5]] {
        let v = [(p_mm[0] * Q5_PER_MM) as i32, (p_mm[1] * Q5_PER_MM) as i32];
        let p = cal::position_um(&mut t, v);
        for k in 0..2 {
            assert!(
                (p[k] as f64 - v[k] as f64 / Q5_PER_MM * 1000.0).abs() <= 8.0,
                "{p_mm:?}: {p:?}"
            );
        }
        let s = cal::signals_q5(
            &mut t,
            &h,
            [(p_mm[0] * 1000.0) as i32, (p_mm[1] * 1000.0) as i32],
        )
        .unwrap();
        for k in 0..2 {
            assert!((s[k] - v[k]).abs() <= 2, "{p_mm:?}: {s:?} vs {v:?}");
        }
    }
    assert_eq!(
        cal::signals_q5(&mut t, &h, [360_000, 0]),
        None,
        "outside the scanned grid"
    );
}

#[test]
fn the_filter_averages_every_sample_of_a_resting_beacon_up_to_its_window() {
    let mut f = Filter::new();
    for k in 0..LONG as i32 {
        assert_eq!(f.estimate(true).is_some(), k >= MIN_VALID as i32);
        if k >= MIN_VALID as i32 {
            // Every sample so far (shown saturated at 255).
            assert_eq!(f.estimate(true).unwrap().samples, k.min(255) as u16, "{k}");
        }
        f.push([400 + (k % 2) * 4, -80], true);
    }
    let e = f.estimate(true).unwrap();
    // Q2 400 / 404 alternating = codes 100 / 101: mean 100.5 codes = 3216 Q5.
    assert_eq!(e.q5, [3216, -640]);
    assert!(!e.moving && !e.filling);
    assert_eq!(e.samples, 255, "256 samples, shown saturated");
    assert_eq!(
        f.estimate(false).unwrap().samples,
        SHORT as u16,
        "the thesis's window"
    );
    f.reset();
    assert_eq!(f.estimate(true), None);
}

#[test]
fn a_moving_beacon_gets_the_thesis_window_and_no_more_lag() {
    let mut f = Filter::new();
    // 100 mm/s along x at 500 samples/s: 0.2 mm a sample = 1 code = Q2 4.
    let (mut moving, mut first) = (0, None);
    for k in 0..400 {
        f.push([4 * k, 0], true);
        if k >= SHORT as i32 {
            let e = f.estimate(true).unwrap();
            let thesis = f.estimate(false).unwrap();
            // The 32-sample mean lags 15.5 samples: 15.5 codes behind the newest.
            assert_eq!(thesis.q5[0], k * 32 - 496);
            assert!(
                (e.q5[0] - thesis.q5[0]).abs() <= filter::MOVE_Q5 + 32,
                "{k}"
            );
            if e.moving {
                first.get_or_insert(k);
                // Flagged moving, published from the thesis's window: no lag beyond it
                // (until 2026-11-27 the window since the last detection, which grew
                // between detections and fell up to the threshold behind).
                assert_eq!(e.q5, thesis.q5, "{k}");
                moving += 1;
            } else {
                // Once found moving, a steady motion is found again before the flag
                // lapses (the window since the detection leaves the short one by the
                // threshold in under MOVING_HOLD samples at this speed).
                assert_eq!(first, None, "the flag lapsed at {k}");
            }
        }
    }
    assert!(
        moving > 300,
        "flagged moving from its first detection on ({moving} of 368)"
    );
}

proptest! {
    #[test]
    fn the_estimate_stays_within_its_samples(samples in proptest::collection::vec(-8000i32..8000, 8..300)) {
        let mut f = Filter::new();
        for s in &samples {
            f.push([*s, -*s], true);
        }
        let e = f.estimate(true).unwrap();
        let win = &samples[samples.len().saturating_sub(LONG)..];
        let lo = *win.iter().min().unwrap() * 8;
        let hi = *win.iter().max().unwrap() * 8;
        prop_assert!(e.q5[0] >= lo - 1 && e.q5[0] <= hi + 1, "{} not in {}..{}", e.q5[0], lo, hi);
        prop_assert!(-e.q5[1] >= lo - 1 && -e.q5[1] <= hi + 1);
    }

    #[test]
    fn the_drift_estimate_learns_offset_and_gain(o in -60i32..60, g_ppm in -15_000i32..15_000) {
        let mut d = drift::Drift::default();
        let places = [[-30000, 25000], [28000, -26000], [0, 0], [29000, 29000], [-27000, -28000]];
        for _ in 0..40 {
            for p in places {
                for _ in 0..200 {
                    let m = [p[0] + o * 32 + ((p[0] as i64 * g_ppm as i64) / 1_000_000) as i32,
                             p[1] - o * 32 + ((p[1] as i64 * g_ppm as i64) / 1_000_000) as i32];
                    prop_assert_eq!(d.observe(m, p), 0);
                }
            }
        }
        // Corrected signals within half a code (0.1 mm) anywhere in the field.
        for p in [[-32000, 32000], [15000, -5000]] {
            let m = [p[0] + o * 32 + ((p[0] as i64 * g_ppm as i64) / 1_000_000) as i32,
                     p[1] - o * 32 + ((p[1] as i64 * g_ppm as i64) / 1_000_000) as i32];
            let c = d.correct(m);
            prop_assert!((c[0] - p[0]).abs() <= 16 && (c[1] - p[1]).abs() <= 16, "{c:?} vs {p:?}");
        }
    }

    #[test]
    fn the_tip_matches_the_arms_geometry(t1 in -7.0f64..7.0, t2 in -7.0f64..7.0) {
        let p = tip_um([(t1 * 1e6) as i32, (t2 * 1e6) as i32]);
        let (x, y) = arm::geometry::tip((t1 * 1e6) as i32 as f64 * 1e-6, (t2 * 1e6) as i32 as f64 * 1e-6);
        prop_assert!((p[0] as f64 - x * 1e6).abs() < 4.0 && (p[1] as f64 - y * 1e6).abs() < 4.0);
    }

    #[test]
    fn the_current_feedback_settles_on_the_reference(gain in 0.3f64..8.0) {
        // Sum proportional to the drive: gain codes per mA, the reference reachable. From
        // the reset current, a beacon up to 5x too bright (near the camera axis) settles
        // without ever being driven so low that it reads as occluded.
        let s_ref = DEFAULT_S_REF_CODES;
        let mut level = 560;
        for _ in 0..8 {
            let sum = (level as f64 * gain) as i32;
            level = crate::feedback_ma(level, sum.min(2047), s_ref);
            let reachable_low = (s_ref as f64 / gain) >= LEVEL_MIN_MA as f64;
            if reachable_low {
                prop_assert!(level as f64 * gain >= OCCLUDED_BELOW_CODES as f64, "level {level} reads occluded");
            }
        }
        let sum = level as f64 * gain;
        let reachable = (s_ref as f64 / gain) <= LEVEL_MAX_MA as f64 && (s_ref as f64 / gain) >= LEVEL_MIN_MA as f64;
        if reachable {
            prop_assert!((sum - s_ref as f64).abs() <= gain + 1.0, "sum {sum} level {level}");
        } else {
            prop_assert!(level == LEVEL_MAX_MA || level == LEVEL_MIN_MA);
        }
    }
}

/// A sensing board stepped with made-up samples for one beacon (all others dark).
struct Rig {
    s: Sensing,
    t: Words,
    timer: u16,
}

impl Rig {
    fn new() -> Self {
        let mut r = Rig {
            s: Sensing::new(),
            t: Words(linear_table()),
            timer: 1000,
        };
        // Let the table check finish on dark slots.
        for _ in 0..fmt::WORDS / cal::CHECK_WORDS + 2 {
            r.slot(None);
        }
        assert!(r.s.checker.header().is_some());
        r
    }
    /// One slot: the sample the board reads is `lit(beacon)` for the beacon processed.
    fn slot(&mut self, lit: Option<(u8, AdcSample)>) -> Output {
        self.timer = self.timer.wrapping_add(500);
        let slot = self.s.slot(self.timer).expect("due");
        let sample = match (slot.processing, lit) {
            (Some(b), Some((lb, s))) if b == lb => Some(s),
            (Some(_), _) => Some(AdcSample {
                x: 2048,
                y: 2048,
                sum: 2050,
                over: false,
            }),
            (None, _) => None,
        };
        self.s.step(
            &Input {
                sample,
                servo: None,
                config: None,
            },
            &mut self.t,
        )
    }
    /// Runs whole frames with beacon 2 at codes (x, y) and sum `sum`.
    fn frames(&mut self, n: usize, x: u16, y: u16, sum: u16, over: bool) -> Vec<(Output, Beacon)> {
        let mut out = Vec::new();
        for _ in 0..8 * n {
            let o = self.slot(Some((2, AdcSample { x, y, sum, over })));
            if o.beacon == Some(2) {
                out.push((o, self.s.objects.beacons[2]));
            }
        }
        out
    }
}

#[test]
fn a_visible_beacon_becomes_valid_after_its_minimum_samples() {
    let mut r = Rig::new();
    let v = r.frames(20, 2048 + 500, 2048 - 250, 2048 + 819, false);
    for (k, (_, b)) in v.iter().enumerate() {
        let valid = b.flags & bf::VALID != 0;
        assert_eq!(
            valid,
            k + 1 >= MIN_VALID as usize,
            "after {} samples",
            k + 1
        );
    }
    let b = v.last().unwrap().1;
    // 500 codes = 100 mm, -250 codes = -50 mm, plus the crosstalk correction for the dark
    // beacon before it (these made-up samples have no residue to remove): a/(1-a) of the
    // step at 250 us, 133/65536.
    let x = 500.0 * (1.0 + 133.0 / 65536.0) * 200.0;
    let y = -250.0 * (1.0 + 133.0 / 65536.0) * 200.0;
    assert!(
        (b.x_um as f64 - x).abs() < 60.0 && (b.y_um as f64 - y).abs() < 60.0,
        "{b:?}"
    );
    assert_eq!(
        b.flags & (bf::OCCLUDED | bf::SATURATED | bf::UNCALIBRATED),
        0
    );
}

#[test]
fn an_occluded_beacon_is_invalid_in_the_same_frame() {
    let mut r = Rig::new();
    r.frames(20, 2548, 1798, 2048 + 819, false);
    let v = r.frames(1, 2548, 1798, 2048 + 100, false);
    let b = v[0].1;
    assert_eq!(
        b.flags & bf::VALID,
        0,
        "invalid at the first occluded sample"
    );
    assert_ne!(b.flags & bf::OCCLUDED, 0);
    // It comes back only after fresh samples.
    let v = r.frames(MIN_VALID as usize, 2548, 1798, 2048 + 819, false);
    assert!(v[..MIN_VALID as usize - 1]
        .iter()
        .all(|(_, b)| b.flags & bf::VALID == 0));
    assert_ne!(v.last().unwrap().1.flags & bf::VALID, 0);
}

#[test]
fn a_saturated_beacon_is_invalid_and_reported() {
    let mut r = Rig::new();
    r.frames(20, 2548, 1798, 2048 + 819, false);
    let v = r.frames(3, 4095, 1798, 4095, true);
    for (o, b) in &v {
        assert_eq!(b.flags & bf::VALID, 0);
        assert_ne!(b.flags & bf::SATURATED, 0);
        assert_eq!(o.event(), Some(Event::Saturated(2)));
    }
}

#[test]
fn without_a_table_nothing_is_valid() {
    let mut r = Rig::new();
    r.t.0[fmt::FWD as usize] ^= 1;
    // The host changed the table without a new checksum: a generation change re-checks it.
    r.t.0[fmt::W_GENERATION as usize] += 1;
    let v = r.frames(100, 2548, 1798, 2048 + 819, false);
    assert!(matches!(r.s.checker.state, State::Bad(Reason::Checksum)));
    for (_, b) in v.iter().skip(90) {
        assert_eq!(b.flags & bf::VALID, 0);
        assert_ne!(b.flags & bf::UNCALIBRATED, 0);
    }
}

#[test]
fn the_timer_paces_slots_and_counts_microseconds_across_its_wrap() {
    let mut s = Sensing::new();
    assert!(s.slot(65000).is_some());
    assert!(s.slot(65000u16.wrapping_add(489)).is_none(), "not yet");
    let mut t = 65000u16;
    for _ in 0..1000 {
        t = t.wrapping_add(501);
        assert!(s.slot(t).is_some());
    }
    assert_eq!(s.now_us(), 1000 * 501 / 2);
    // A late slot: the next one comes on the grid, shorter, so the rate holds.
    let mut s = Sensing::new();
    s.slot(0);
    assert!(s.slot(500).is_some());
    assert!(s.slot(1200).is_some(), "200 ticks late");
    assert!(s.slot(1480).is_none(), "the grid point is 1500");
    assert!(s.slot(1495).is_none(), "lit for less than MIN_LIT_TICKS");
    assert!(s.slot(1504).is_some());
    // Almost three slots late (a long slot): the slots after it start as soon as their
    // beacon has been lit MIN_LIT_TICKS, until the grid point is ahead again.
    assert!(s.slot(3400).is_some(), "due at 2000");
    assert!(s.slot(3400 + MIN_LIT_TICKS - 1).is_none(), "lit for less");
    let (mut t, mut due, mut caught_up) = (3400u16, 2000u16, 0);
    while due + SLOT_TICKS <= t + MIN_LIT_TICKS + SLOT_EARLY_TICKS {
        t += MIN_LIT_TICKS;
        due += SLOT_TICKS;
        assert!(s.slot(t).is_some(), "catching up at {t}, due at {due}");
        caught_up += 1;
    }
    assert_eq!(caught_up, 7, "1,400 ticks late, 196 made up a slot");
    assert!(
        s.slot(t + MIN_LIT_TICKS).is_none(),
        "the grid point is ahead again"
    );
    assert!(s.slot(due + SLOT_TICKS).is_some());
    // CATCH_UP_SLOTS late or more: the grid restarts from the pass.
    let t = due + SLOT_TICKS + CATCH_UP_SLOTS * SLOT_TICKS + SLOT_TICKS;
    assert!(s.slot(t).is_some());
    assert!(s.slot(t + 400).is_none());
    assert!(s.slot(t + 500).is_some());
}

/// The common slot's assembly divides by `FEEDBACK_RECIP`: the high word of n m must be
/// n / d for every dividend the feedback forms (level x s_ref < 2^21) and every sum it
/// divides by. Checked where a floor can first go wrong, at each multiple of d and one
/// below it, up to the largest dividend, and at the largest dividend itself.
#[test]
fn the_feedback_reciprocals_divide_exactly() {
    let n_max = (crate::LEVEL_MAX_MA * 2047) as u64;
    assert!(n_max < 1 << 21);
    for d in crate::OCCLUDED_BELOW_CODES as u64..2048 {
        let m = crate::FEEDBACK_RECIP[d as usize] as u64;
        let q = |n: u64| (n * m) >> 32;
        assert_eq!(q(n_max), n_max / d, "n {n_max} d {d}");
        let mut k = 1;
        while k * d <= n_max + d {
            for n in [k * d - 1, k * d] {
                assert_eq!(q(n), n / d, "n {n} d {d}");
            }
            k += 1;
        }
    }
}
