//! Whether the reflex's inputs can be believed (design.md section 5; issue 8's fail-safe):
//! a map that no C-space board keeps up to date, a map an update was abandoned in the middle
//! of, and obstacle positions that stopped arriving all make the reflex stop the arm at its
//! arrest point. Missing data is never free space.
//!
//! Time is the servo board's clock (`ServoState::t_us`), the only clock the reflex sees.

use crate::masks::{lt, pick};

/// A C-space map no board has worked on for this long is stale (no heartbeat moved and
/// no claimed work-list entry changed).
pub const MAP_STALE_US: u32 = 30_000;
/// A work-list entry claimed, unchanged, for this long was abandoned mid-update: the map is
/// torn (an image half drawn). A board at work marks its progress in the claim word
/// (`cspace::worklist`), so a long job is not taken for an abandoned one.
pub const MAP_TORN_US: u32 = 20_000;
/// An obstacle whose drawn image lies this far from its sensed position ...
pub const LAG_UM: i32 = 15_000;
/// ... for this long means the map does not show where the obstacle is.
pub const LAG_US: u32 = 100_000;
/// An object table whose frame counter stood still this long is stale.
pub const OBJECTS_STALE_US: u32 = 30_000;
/// After power-up the inputs may take this long to become good before that is a fault
/// (the arm holds meanwhile).
pub const STARTUP_US: u32 = 500_000;

/// The C-space work list as the reflex sees it, per entry. `repr(C)`: the runtime's
/// `__reflex_health_entry` reads it (offsets asserted in `entry_layout`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[repr(C)]
pub struct EntryView {
    /// The entry's claim word (0 = free).
    pub claim: u32,
    /// The entry's state word (changes with every redraw).
    pub state: u32,
    /// Largest axis distance between the drawn image's position and the sensed one.
    pub lag_um: i32,
    /// Whether an image is drawn and its obstacle's beacon is valid.
    pub tracked: bool,
    /// The obstacle exists (its beacon is valid, or the host configured it) but no image is
    /// drawn.
    pub undrawn: bool,
}

impl EntryView {
    /// An entry never read: free, nothing drawn.
    pub const EMPTY: EntryView = EntryView {
        claim: 0,
        state: 0,
        tracked: false,
        undrawn: false,
        lag_um: 0,
    };
}

/// Number of work-list entries watched (the obstacle beacons).
pub const ENTRIES: usize = 6;

/// What the reflex reads about its inputs' freshness each pass.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct HealthInput {
    /// Heartbeats of the three C-space board slots (a slot without a board stays 0).
    pub cspace_heartbeats: [u32; 3],
    /// The object table's frame counter (ignored when `objects_torn`).
    pub objects_frame: u32,
    /// The object table read torn.
    pub objects_torn: bool,
    /// The work list.
    pub entries: [EntryView; ENTRIES],
    /// Bit `i` set: entry `i` was read this pass (the others are as last read).
    pub fresh: u32,
}

/// What is wrong with the inputs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Problem {
    /// No C-space board is running.
    MapStale,
    /// An obstacle's image lags its sensed position (or was never drawn).
    MapLag,
    /// An update of the map was abandoned half done.
    MapTorn,
    /// The obstacle positions stopped arriving (or read torn throughout).
    ObjectsStale,
}

/// Tracks the inputs' freshness over passes. `repr(C)`: the runtime's
/// `__reflex_health_observe` and `__reflex_health_entry` update it (offsets asserted in
/// `entry_layout`).
#[derive(Clone, Copy, Debug, Default)]
#[repr(C)]
pub struct Monitor {
    hb: [u32; 3],
    hb_since_us: u32,
    frame: u32,
    /// A frame counter has been read (-1).
    frame_had: i32,
    frame_since_us: u32,
    /// Each entry's claim and state words at its last reading (only these are compared:
    /// copying whole views was a `memcpy` call a pass on the 68020).
    claims: [u32; ENTRIES],
    states: [u32; ENTRIES],
    claimed_since_us: [u32; ENTRIES],
    lag_since_us: [u32; ENTRIES],
    /// A C-space heartbeat and the frame counter have been seen to change (-1): until then
    /// the map and the positions count as stale.
    hb_seen: i32,
    frame_seen: i32,
    /// Some entry lags or is undrawn right now (not yet for long): -1.
    behind_now: i32,
    /// Per entry, at its last reading, as bit `i` of each word: torn, lagging, behind now
    /// (bits: the or over the entries is then one test, not a loop of 18 loads).
    verdict: [u32; 3],
    /// Bit `i`: entry `i` has been read at least once.
    seen: u32,
    /// Last, so that the words before it lie alike on the host and the 68020 (which aligns
    /// words to 2 bytes).
    started: bool,
}

impl Monitor {
    /// Whether, at the last [`Monitor::observe`], some obstacle's image lagged its sensed
    /// position or was missing (even if not yet for long enough to be a problem): before
    /// the inputs were first good, the arm waits for this to clear too.
    pub fn behind(&self) -> bool {
        // Entries not read yet count as behind: the board reads one a pass.
        self.behind_now != 0 || self.seen != (1 << ENTRIES) - 1
    }

    /// A monitor that has seen nothing.
    pub const fn new() -> Self {
        Self {
            hb: [0; 3],
            hb_since_us: 0,
            frame: 0,
            frame_had: 0,
            frame_since_us: 0,
            claims: [0; ENTRIES],
            states: [0; ENTRIES],
            claimed_since_us: [0; ENTRIES],
            lag_since_us: [0; ENTRIES],
            started: false,
            hb_seen: 0,
            frame_seen: 0,
            behind_now: 0,
            verdict: [0; 3],
            seen: 0,
        }
    }

    /// Takes one pass's readings `h` at `now_us` (servo clock, wrapping) and says what, if
    /// anything, is wrong.
    pub fn observe(&mut self, h: &HealthInput, now_us: u32) -> Option<Problem> {
        if !self.started {
            self.start(h, now_us);
        }
        match self.observe_code(h, now_us) {
            1 => Some(Problem::MapStale),
            2 => Some(Problem::MapTorn),
            3 => Some(Problem::MapLag),
            4 => Some(Problem::ObjectsStale),
            _ => None,
        }
    }

    /// [`Monitor::observe`] after the first reading, as a code (0 none, then 1-4 in the
    /// order of precedence: stale map, torn map, lagging map, stale positions). On the
    /// 68020 one call of `__reflex_health_observe` (crates/rt/asm/servo.S), bit for bit
    /// [`Monitor::observe_host`] (the reflex image's scripted passes against the host,
    /// `the_reflex_image_steps_like_the_host`, reach every problem; compiled, ~1,000
    /// cycles a pass).
    #[inline(always)]
    fn observe_code(&mut self, h: &HealthInput, now_us: u32) -> u32 {
        #[cfg(target_arch = "m68k")]
        {
            extern "C" {
                fn __reflex_health_observe(
                    m: *mut Monitor,
                    hb: *const [u32; 3],
                    frame: u32,
                    torn: u32,
                    fresh: u32,
                    entries: *const EntryView,
                    stride: u32,
                    now_us: u32,
                    limits: *const [u32; 5],
                ) -> u32;
            }
            /// The limits the routine compares with: lag (um), then torn, lag, map and
            /// positions staleness (us).
            static LIMITS: [u32; 5] = [
                LAG_UM as u32,
                MAP_TORN_US,
                LAG_US,
                MAP_STALE_US,
                OBJECTS_STALE_US,
            ];
            // SAFETY: the routine updates `self` at the offsets `entry_layout` asserts and
            // reads the three heartbeats and the ENTRIES entries `stride` bytes apart.
            unsafe {
                __reflex_health_observe(
                    self,
                    &h.cspace_heartbeats,
                    h.objects_frame,
                    h.objects_torn as u32,
                    h.fresh,
                    h.entries.as_ptr(),
                    core::mem::size_of::<EntryView>() as u32,
                    now_us,
                    &LIMITS,
                )
            }
        }
        #[cfg(not(target_arch = "m68k"))]
        self.observe_host(h, now_us)
    }

    /// [`Monitor::observe_code`] in Rust (the host's, and the reference for the image's).
    #[cfg_attr(target_arch = "m68k", allow(dead_code))]
    fn observe_host(&mut self, h: &HealthInput, now_us: u32) -> u32 {
        // Decisions as masks (-1 = yes), not booleans (docs/toolchain.md).
        let now = now_us as i32;
        let older = |since: u32, limit: u32| {
            lt(limit as i32, now_us.wrapping_sub(since).min(1 << 30) as i32)
        };
        let since = |m: i32, since: u32| pick(m, now, since as i32) as u32;
        let (a, b) = (h.cspace_heartbeats, self.hb);
        let beat = nonzero((a[0] ^ b[0]) | (a[1] ^ b[1]) | (a[2] ^ b[2]));
        self.hb = a;
        self.hb_seen |= beat;
        let ok = -(!h.objects_torn as i32);
        let new = nonzero(h.objects_frame ^ self.frame) & ok;
        self.frame_seen |= new & self.frame_had;
        self.frame_had |= ok;
        self.frame = pick(ok, h.objects_frame as i32, self.frame as i32) as u32;
        self.frame_since_us = since(new, self.frame_since_us);
        // Only the entries read this pass are looked at again; the others keep the verdict
        // of their last reading (a few passes old: the limits are 20-100 ms).
        self.seen |= h.fresh & ((1 << ENTRIES) - 1);
        let mut working = 0;
        let mut i = 0;
        // Up to the last entry read (the board reads one a pass).
        let mut fresh = h.fresh & ((1 << ENTRIES) - 1);
        while fresh != 0 {
            if fresh & 1 != 0 {
                working |= self.entry(i, &h.entries[i], now_us);
            }
            fresh >>= 1;
            i += 1;
        }
        // A board at work on a long job beats no heartbeat until it ends (the bench's worst
        // job is 46 ms, over MAP_STALE_US), but its progress marks move its entry's claim
        // word: that is a board keeping the map too.
        self.hb_since_us = since(beat | working, self.hb_since_us);
        let [torn, lag, behind_now] = self.verdict;
        let (torn, lag) = (nonzero(torn), nonzero(lag));
        self.behind_now = nonzero(behind_now);
        let stale = !self.hb_seen | older(self.hb_since_us, MAP_STALE_US);
        let objects = !self.frame_seen | older(self.frame_since_us, OBJECTS_STALE_US);
        // In order of precedence: stale map, torn map, lagging map, stale positions.
        let mut code = pick(objects, 4, 0);
        code = pick(lag, 3, code);
        code = pick(torn, 2, code);
        code = pick(stale, 1, code);
        code as u32
    }
}

impl Monitor {
    /// The first reading: every timer starts at `now_us` (out of line: the pass's code
    /// stays short).
    #[cold]
    #[inline(never)]
    fn start(&mut self, h: &HealthInput, now_us: u32) {
        self.started = true;
        self.hb = h.cspace_heartbeats;
        self.hb_since_us = now_us;
        self.frame = h.objects_frame;
        self.frame_had = -(!h.objects_torn as i32);
        self.frame_since_us = now_us;
        let mut i = 0;
        while i < ENTRIES {
            self.claims[i] = h.entries[i].claim;
            self.states[i] = h.entries[i].state;
            i += 1;
        }
        self.claimed_since_us = [now_us; ENTRIES];
        self.lag_since_us = [now_us; ENTRIES];
    }

    /// Takes entry `i`'s new reading `e` at `now_us`: its timers and verdict (torn, lagging,
    /// behind now: masks). Returns -1 when the entry is claimed and changed since its last
    /// reading (a C-space board at work on it: its progress marks, `WorkEntry::claim`). On
    /// the 68020 one call of `__reflex_health_entry` (crates/rt/asm/servo.S), bit for bit
    /// [`Monitor::entry_host`] (`the_reflex_images_health_entries_match_the_host`; compiled,
    /// ~490 cycles a pass).
    #[inline(always)]
    pub fn entry(&mut self, i: usize, e: &EntryView, now_us: u32) -> i32 {
        #[cfg(target_arch = "m68k")]
        {
            extern "C" {
                fn __reflex_health_entry(
                    m: *mut Monitor,
                    i: u32,
                    e: *const EntryView,
                    now_us: u32,
                    lag_um: i32,
                    torn_us: u32,
                    lag_us: u32,
                ) -> i32;
            }
            // SAFETY: the routine reads `e` and updates entry `i`'s words of `self` and the
            // verdicts, at the offsets `entry_layout` asserts; `i` < ENTRIES.
            unsafe { __reflex_health_entry(self, i as u32, e, now_us, LAG_UM, MAP_TORN_US, LAG_US) }
        }
        #[cfg(not(target_arch = "m68k"))]
        self.entry_host(i, e, now_us)
    }

    /// [`Monitor::entry`] in Rust (the host's, and the reference for the image's).
    #[cfg_attr(target_arch = "m68k", allow(dead_code))]
    fn entry_host(&mut self, i: usize, e: &EntryView, now_us: u32) -> i32 {
        let now = now_us as i32;
        let since = |m: i32, since: u32| pick(m, now, since as i32) as u32;
        let older = |since: u32, limit: u32| {
            lt(limit as i32, now_us.wrapping_sub(since).min(1 << 30) as i32)
        };
        let free = nonzero(e.claim) ^ -1;
        let changed = nonzero((e.claim ^ self.claims[i]) | (e.state ^ self.states[i]));
        self.claimed_since_us[i] = since(free | changed, self.claimed_since_us[i]);
        let behind = -(e.undrawn as i32) | (-(e.tracked as i32) & lt(LAG_UM, e.lag_um));
        self.lag_since_us[i] = since(!behind, self.lag_since_us[i]);
        let bit = 1u32 << i;
        let put = |word: u32, m: i32| (word & !bit) | (m as u32 & bit);
        self.verdict[0] = put(
            self.verdict[0],
            older(self.claimed_since_us[i], MAP_TORN_US),
        );
        self.verdict[1] = put(self.verdict[1], older(self.lag_since_us[i], LAG_US));
        self.verdict[2] = put(self.verdict[2], behind);
        self.claims[i] = e.claim;
        self.states[i] = e.state;
        changed & !free
    }
}

/// The layouts `__reflex_health_entry` and `__reflex_health_observe` (crates/rt/asm/servo.S)
/// use.
mod entry_layout {
    use super::{EntryView, Monitor};
    use core::mem::offset_of;
    const _: () = assert!(offset_of!(EntryView, claim) == 0);
    const _: () = assert!(offset_of!(EntryView, state) == 4);
    const _: () = assert!(offset_of!(EntryView, lag_um) == 8);
    const _: () = assert!(offset_of!(EntryView, tracked) == 12);
    const _: () = assert!(offset_of!(EntryView, undrawn) == 13);
    const _: () = assert!(offset_of!(Monitor, claims) == 28);
    const _: () = assert!(offset_of!(Monitor, states) == 52);
    const _: () = assert!(offset_of!(Monitor, claimed_since_us) == 76);
    const _: () = assert!(offset_of!(Monitor, lag_since_us) == 100);
    const _: () = assert!(offset_of!(Monitor, verdict) == 136);
    const _: () = assert!(offset_of!(Monitor, hb) == 0);
    const _: () = assert!(offset_of!(Monitor, hb_since_us) == 12);
    const _: () = assert!(offset_of!(Monitor, frame) == 16);
    const _: () = assert!(offset_of!(Monitor, frame_had) == 20);
    const _: () = assert!(offset_of!(Monitor, frame_since_us) == 24);
    const _: () = assert!(offset_of!(Monitor, hb_seen) == 124);
    const _: () = assert!(offset_of!(Monitor, frame_seen) == 128);
    const _: () = assert!(offset_of!(Monitor, behind_now) == 132);
    const _: () = assert!(offset_of!(Monitor, seen) == 148);
}

impl Monitor {
    /// The verdicts of entry `i` after [`Monitor::entry`] (torn, lagging, behind now: -1
    /// yes) and its kept words (claim, state, claimed since, lagging since), for the tests
    /// that compare the image's with the host's.
    pub fn entry_state(&self, i: usize) -> [i32; 7] {
        let bit = |w: u32| -(((w >> i) & 1) as i32);
        [
            bit(self.verdict[0]),
            bit(self.verdict[1]),
            bit(self.verdict[2]),
            self.claims[i] as i32,
            self.states[i] as i32,
            self.claimed_since_us[i] as i32,
            self.lag_since_us[i] as i32,
        ]
    }
}

/// -1 when `x` is not zero, else 0.
fn nonzero(x: u32) -> i32 {
    ((x | x.wrapping_neg()) as i32) >> 31
}
