//! One pass of the reflex from a flat word script, for comparing the 68020 image with the
//! host bit for bit (the image's test probe `reflex_probe_run` and the system tests call it
//! with the same words).
//!
//! Input, [`IN_WORDS`] words: servo present (0/1), theta1, theta2, omega1, omega2, arrest1,
//! arrest2, t_us, loops; goal kind (0 none, 1 planner, 2 wand), goal a, goal b, planner
//! cycle; three C-space heartbeats, objects frame, objects torn (bit 0) and obstacles moving
//! (bit 1); per work-list entry
//! claim, state, flags (1 tracked, 2 undrawn), lag_um.
//!
//! Output, [`OUT_WORDS`] words: subgoal present, subgoal1, subgoal2, flags, goal1, goal2,
//! window (lo1, hi1, lo2, hi2), tests, dt_us, new fault code (0 none, 1 servo stale, 2 servo
//! torn, 3 planner stale, 4 map stale, 5 map lag, 6 map torn, 7 objects stale).

use crate::health::{EntryView, HealthInput, Problem, ENTRIES};
use crate::window::Map;
use crate::{Fault, GoalInput, Input, Reflex, ServoView};

/// Words of one pass's input.
pub const IN_WORDS: usize = 18 + 4 * ENTRIES;
/// Words of one pass's output.
pub const OUT_WORDS: usize = 14;

/// Runs one pass of `r` on the input words `w` and the map `map`; writes `out`.
#[inline(never)]
pub fn scripted_pass<M: Map + ?Sized>(
    r: &mut Reflex,
    w: &[u32; IN_WORDS],
    map: &mut M,
    out: &mut [i32; OUT_WORDS],
) {
    let servo = (w[0] != 0).then(|| ServoView {
        theta_urad: [w[1] as i32, w[2] as i32],
        omega_urad_s: [w[3] as i32, w[4] as i32],
        arrest_urad: [w[5] as i32, w[6] as i32],
        t_us: w[7],
        loops: w[8],
    });
    let goal = match w[9] {
        1 => GoalInput::Planner {
            goal_urad: [w[10] as i32, w[11] as i32],
            cycle: w[12],
        },
        2 => GoalInput::Wand {
            x_um: w[10] as i32,
            y_um: w[11] as i32,
        },
        _ => GoalInput::None,
    };
    let mut health = HealthInput {
        cspace_heartbeats: [w[13], w[14], w[15]],
        objects_frame: w[16],
        objects_torn: w[17] & 1 != 0,
        entries: [EntryView::default(); ENTRIES],
        fresh: (1 << ENTRIES) - 1,
    };
    entries(&mut health, w);
    let o = r.step(
        &Input {
            servo,
            goal,
            health,
            obstacles_moving: w[17] & 2 != 0,
        },
        map,
    );
    *out = [
        0,
        0,
        0,
        o.flags as i32,
        o.goal_urad[0],
        o.goal_urad[1],
        o.window[0].0,
        o.window[0].1,
        o.window[1].0,
        o.window[1].1,
        o.tests as i32,
        o.dt_us as i32,
        o.new_fault.map_or(0, fault_code),
        0,
    ];
    if let Some(sub) = o.subgoal_urad {
        out[0] = 1;
        out[1] = sub[0];
        out[2] = sub[1];
    }
}

/// The work-list words of the script into `h` (a non-inlined fill through a reference: a
/// local array filled in a loop lost its index on the 68k; docs/toolchain.md, class 6).
#[inline(never)]
fn entries(h: &mut HealthInput, w: &[u32; IN_WORDS]) {
    let mut i = 0;
    while i < ENTRIES {
        let k = 18 + 4 * i;
        h.entries[i] = EntryView {
            claim: w[k],
            state: w[k + 1],
            tracked: w[k + 2] & 1 != 0,
            undrawn: w[k + 2] & 2 != 0,
            lag_um: w[k + 3] as i32,
        };
        i += 1;
    }
}

/// The script's code of a fault.
pub fn fault_code(f: Fault) -> i32 {
    match f {
        Fault::ServoStale => 1,
        Fault::ServoTorn => 2,
        Fault::PlannerStale => 3,
        Fault::Input(Problem::MapStale) => 4,
        Fault::Input(Problem::MapLag) => 5,
        Fault::Input(Problem::MapTorn) => 6,
        Fault::Input(Problem::ObjectsStale) => 7,
    }
}

/// Words of one escape question ([`scripted_escape`]): arm pixel (2), goal pixel (2),
/// clearance wanted, may cross (0/1), previous target present (0/1) and its pixel (2).
pub const ESCAPE_IN_WORDS: usize = 9;
/// Words of one escape answer: found (0/1), target (2), step (2), clearance, rings crossed.
pub const ESCAPE_OUT_WORDS: usize = 7;

/// Plans one escape ([`crate::escape::plan`]) from the words `w` on `map` with the bitmaps
/// `s`; writes `out`. For the image's probe `reflex_probe_escape` and the system tests.
#[inline(never)]
pub fn scripted_escape<M: Map + ?Sized>(
    s: &mut crate::escape::Scratch,
    w: &[i32; ESCAPE_IN_WORDS],
    map: &mut M,
    out: &mut [i32; ESCAPE_OUT_WORDS],
) {
    let ask = crate::escape::Ask {
        at_px: [w[0], w[1]],
        toward_px: [w[2], w[3]],
        clear_px: w[4],
        cross: w[5] != 0,
        prev_px: (w[6] != 0).then_some([w[7], w[8]]),
    };
    let mut tests = 0;
    *out = [0; ESCAPE_OUT_WORDS];
    if let Some(p) = crate::escape::plan(map, s, &ask, &mut tests) {
        *out = [
            1,
            p.target_px[0],
            p.target_px[1],
            p.step_px[0],
            p.step_px[1],
            p.clear_px,
            p.crossed as i32,
        ];
    }
}

/// Words of one evasion question ([`scripted_evade`]): the arm's angles (2, urad), the
/// previous way (2), whether to score every way too (0/1), then [`crate::OBSTACLES`]
/// obstacles of six words each (valid 0/1, x, y, radius in um, velocity x, y in um/s).
pub const EVADE_IN_WORDS: usize = 5 + 6 * crate::OBSTACLES;
/// Words of one evasion answer: the best way (2), its score, then each of the 49 ways'
/// score ([`crate::evade::score`]; link 1's way outer, link 2's inner, in the order of
/// [`crate::evade::WAY_MULT`]) if asked, else zeros (the reflex's own work: its cycles).
pub const EVADE_OUT_WORDS: usize = 3 + crate::evade::WAYS * crate::evade::WAYS;

/// Answers one evasion question ([`crate::evade`]) from the words `w` with the arrays `s`;
/// writes `out`. For the image's probe `reflex_probe_evade` and the system tests.
#[inline(never)]
pub fn scripted_evade(
    s: &mut crate::evade::Scratch,
    w: &[i32; EVADE_IN_WORDS],
    obs: &mut [crate::ObstacleView; crate::OBSTACLES],
    out: &mut [i32; EVADE_OUT_WORDS],
) {
    let mut i = 0;
    while i < crate::OBSTACLES {
        let o = &mut obs[i];
        let b = 5 + 6 * i;
        o.valid = w[b] != 0;
        o.x_um = w[b + 1];
        o.y_um = w[b + 2];
        o.r_um = w[b + 3];
        o.vx_um_s = w[b + 4];
        o.vy_um_s = w[b + 5];
        i += 1;
    }
    let theta = [w[0], w[1]];
    crate::evade::prepare(s, &theta, obs);
    let mut b = [0; 3];
    crate::evade::best(s, &[w[2], w[3]], &mut b);
    out[0] = b[0];
    out[1] = b[1];
    out[2] = b[2];
    const N: usize = crate::evade::WAYS;
    let mut k = 3;
    while k < EVADE_OUT_WORDS {
        out[k] = 0;
        k += 1;
    }
    // Every way only if asked: the loop runs no row otherwise (a bound, not a branch:
    // docs/toolchain.md, class 1).
    let rows = (N as i32 & -w[4]) as usize;
    let mut a = 0;
    while a < rows {
        let mut c = 0;
        while c < N {
            let d = [crate::evade::WAY_MULT[a], crate::evade::WAY_MULT[c]];
            out[3 + N * a + c] = crate::evade::score(s, &d) as i32;
            c += 1;
        }
        a += 1;
    }
}

/// Words of one known-columns step ([`scripted_known`]): kind (0 a write, 1 a rectangle, 2
/// a column), then four. A write: column, row, stripe (0/1), the word; a rectangle: first
/// column, columns, first row, rows (unwrapped); a column: column, unused, first row, rows.
pub const KNOWN_IN_WORDS: usize = 5;
/// Words of one known-columns answer: free (0/1), words read, pixels vouched for (all 0
/// after a write).
pub const KNOWN_OUT_WORDS: usize = 3;

/// One step of [`crate::window::Known`] over the map in global RAM `g`: a write (the map's
/// or stripe's word, then the column's generation raised, as the C-space boards write) or a
/// rectangle or column asked through `k`. For the image's probe `reflex_probe_known` and
/// the system tests (the runtime's `__reflex_known_hits` against the host's loop).
#[inline(never)]
pub fn scripted_known<G: vme_map::GlobalBus>(
    k: &mut crate::window::Known,
    g: &mut G,
    w: &[i32; KNOWN_IN_WORDS],
    out: &mut [i32; KNOWN_OUT_WORDS],
) {
    use crate::window::{self, BusMap, Span};
    *out = [0; KNOWN_OUT_WORDS];
    let s2 = Span {
        lo: w[3],
        hi: w[3] + w[4] - 1,
    };
    let mut tests = 0;
    let free = match w[0] {
        0 => {
            let i1 = (w[1] & 127) as u32;
            let off = if w[3] != 0 {
                vme_map::layout::CSPACE_STRIPES + 4 * i1
            } else {
                vme_map::layout::cspace_counter(i1, (w[2] & 127) as u32, 0)
            };
            g.write_u32(off, w[4] as u32);
            vme_map::layout::raise_column_gen(g, i1);
            return;
        }
        1 => {
            let s1 = Span {
                lo: w[1],
                hi: w[1] + w[2] - 1,
            };
            window::rect_free_known(&mut BusMap(&mut *g), k, s1, s2, &mut tests)
        }
        _ => window::col_free_known(&mut BusMap(&mut *g), k, w[1], s2, &mut tests),
    };
    out[0] = free as i32;
    out[1] = tests as i32;
    out[2] = k.take_vouched() as i32;
}

/// Words of one axis question ([`scripted_prepare`]): the axis (0/1), the servo's angles,
/// speeds and arrest points (two words each, urad and urad/s), the previous subgoal (2,
/// urad), its and the goal's angle units (2 + 2), the margins (latency Q32 s, base and own
/// margins in angle units).
pub const PREPARE_IN_WORDS: usize = 16;
/// Words of one axis answer: the axis's arithmetic in its layout's order (theta, goal,
/// adv, stop_us, theta_urad, arrest_urad, prev_urad, omega_urad_s, then lo and hi of the
/// base, core, own and rest spans).
pub const PREPARE_OUT_WORDS: usize = 16;

/// Answers one axis question (the reflex's `prepare`, on the 68020 `__reflex_prepare`) from
/// the words `w`; writes `out`. For the image's probe `reflex_probe_prepare` and the
/// system tests.
#[inline(never)]
pub fn scripted_prepare(w: &[i32; PREPARE_IN_WORDS], out: &mut [i32; PREPARE_OUT_WORDS]) {
    let sv = ServoView {
        theta_urad: [w[1], w[2]],
        omega_urad_s: [w[3], w[4]],
        arrest_urad: [w[5], w[6]],
        t_us: 0,
        loops: 0,
    };
    let m = crate::Margins {
        lat_q32: w[13],
        base: w[14],
        own: w[15],
    };
    let a = crate::prepare(
        (w[0] & 1) as usize,
        &sv,
        &[w[7], w[8]],
        &[w[9], w[10]],
        &[w[11], w[12]],
        &m,
    );
    *out = [
        a.theta,
        a.goal,
        a.adv,
        a.stop_us,
        a.theta_urad,
        a.arrest_urad,
        a.prev_urad,
        a.omega_urad_s,
        a.base.lo,
        a.base.hi,
        a.core.lo,
        a.core.hi,
        a.own.lo,
        a.own.hi,
        a.rest.lo,
        a.rest.hi,
    ];
}

/// Words of one stall question ([`scripted_stall`]): the servo's angles and speeds (2 + 2,
/// urad and urad/s), the goal and the subgoal (2 + 2, urad), the stall clock (its subgoal,
/// 2, and its time), the time now (us).
pub const STALL_IN_WORDS: usize = 12;
/// Words of one stall answer: the flags, then the stall clock after the pass (its subgoal,
/// 2, and its time).
pub const STALL_OUT_WORDS: usize = 4;

/// Answers one stall question (`reflex::stall_flags`, on the 68020 `__reflex_stall`) from
/// the words `w`; writes `out`. For the image's probe `reflex_probe_stall` and the system
/// tests.
#[inline(never)]
pub fn scripted_stall(w: &[i32; STALL_IN_WORDS], out: &mut [i32; STALL_OUT_WORDS]) {
    let sv = ServoView {
        theta_urad: [w[0], w[1]],
        omega_urad_s: [w[2], w[3]],
        arrest_urad: [0, 0],
        t_us: 0,
        loops: 0,
    };
    let mut clk = crate::StallClock {
        ref_urad: [w[8], w[9]],
        since_us: w[10] as u32,
    };
    let f = crate::stall_flags(&sv, &[w[4], w[5]], &[w[6], w[7]], &mut clk, w[11] as u32);
    *out = [
        f as i32,
        clk.ref_urad[0],
        clk.ref_urad[1],
        clk.since_us as i32,
    ];
}

/// Words of one goal-clamp question ([`scripted_clamp`]): the goal's component (urad) and
/// its angle units, the span's first and last pixel, the distance to keep (angle units).
pub const CLAMP_IN_WORDS: usize = 5;

/// Answers one goal-clamp question (`reflex::clamp_into`, on the 68020
/// `__reflex_clamp_into`) from the words `w` into `out[0]`. For the image's probe
/// `reflex_probe_clamp` and the system tests.
#[inline(never)]
pub fn scripted_clamp(w: &[i32; CLAMP_IN_WORDS], out: &mut [i32; 1]) {
    let s = crate::window::Span { lo: w[2], hi: w[3] };
    out[0] = crate::clamp_into(w[0], w[1], s, w[4]);
}

/// Words of one health-entry step ([`scripted_health_entry`]): the entry (0-5), its claim
/// and state words, tracked and undrawn (0/1), its lag (um), the time (us).
pub const HEALTH_IN_WORDS: usize = 7;
/// Words of one health-entry answer: the returned mask, then
/// `health::Monitor::entry_state` (the three verdicts and the four kept words).
pub const HEALTH_OUT_WORDS: usize = 8;

/// One step of a health monitor's entry reading (`health::Monitor::entry`, on the 68020
/// `__reflex_health_entry`) on `m`, kept from step to step, from the words `w`; writes
/// `out`. For the image's probe `reflex_probe_health` and the system tests.
#[inline(never)]
pub fn scripted_health_entry(
    m: &mut crate::health::Monitor,
    w: &[i32; HEALTH_IN_WORDS],
    out: &mut [i32; HEALTH_OUT_WORDS],
) {
    let i = (w[0] as u32 % ENTRIES as u32) as usize;
    let e = EntryView {
        claim: w[1] as u32,
        state: w[2] as u32,
        tracked: w[3] != 0,
        undrawn: w[4] != 0,
        lag_um: w[5],
    };
    out[0] = m.entry(i, &e, w[6] as u32);
    // Word by word: a loop copying the local array took its first word seven times on the
    // 68k (docs/toolchain.md, class 6).
    let s = m.entry_state(i);
    out[1] = s[0];
    out[2] = s[1];
    out[3] = s[2];
    out[4] = s[3];
    out[5] = s[4];
    out[6] = s[5];
    out[7] = s[6];
}
