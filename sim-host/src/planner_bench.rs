//! The planner image against its native code, pass for pass, and its cycle cost (issue 9):
//! `sim-host bench planner` and the image-equivalence test.
//!
//! The real planner image runs on the emulated 68020 at 16.7 MHz against global RAM the
//! host writes: a C-space map drawn by the C-space logic from disks, the wand's beacon,
//! the servo state of a kinematic arm (it moves toward the planner's request at a quarter
//! pixel per pass, never into a marked pixel) and the reflex's flags (a stall when the arm
//! stays short of its request). The native board gets the same records in its own copy of
//! global RAM. The image is stepped one instruction at a time to the end of each main-loop
//! pass (its heartbeat), so both see identical inputs; their published `PLANNER_GOAL`
//! records must agree word for word, and the image's cycles per pass are its cost.

use crate::boot::System;
use crate::emu::CPU_HZ;
use std::path::Path;
use vme_map::records::{beacon_flags, reflex_flags, Beacon, ObjectTable, ServoState};
use vme_map::{ArrayBus, BoardId, BoardSlot, GlobalBus, GLOBAL_RAM_SIZE};

/// One case: obstacles (x, y, r in mm), the arm's start (rad), the wand (mm), passes.
#[derive(Clone, Debug, PartialEq)]
pub struct Case {
    /// What it shows.
    pub name: &'static str,
    /// Obstacle disks, mm.
    pub disks: Vec<(i32, i32, i32)>,
    /// The arm's start, rad.
    pub start_rad: [f64; 2],
    /// The wand, mm.
    pub wand_mm: (i32, i32),
    /// Main-loop passes to run.
    pub passes: u32,
}

/// The cases of the bench and the test: free space; an obstacle across the way that the
/// planner must follow round; a goal inside an obstacle; an arm that stalls within the
/// planner's clearance of a wall, where the planner searches for the way out
/// (`planner::escape`) before it follows the wall.
pub fn cases() -> Vec<Case> {
    vec![
        Case {
            name: "free space",
            disks: vec![],
            start_rad: [-1.0, 0.5],
            wand_mm: (200, 250),
            passes: 1500,
        },
        Case {
            name: "wall following (fig. VI.5's obstacle)",
            disks: vec![(320, 180, 50), (-350, -300, 30)],
            start_rad: [-0.3, 0.0],
            wand_mm: (50, 340),
            passes: 4000,
        },
        Case {
            name: "goal inside an obstacle",
            disks: vec![(250, 150, 45)],
            start_rad: [-2.0, 1.0],
            wand_mm: (250, 150),
            passes: 1500,
        },
        Case {
            name: "stalled within the clearance",
            disks: vec![(-40, 247, 46), (-229, 58, 21)],
            start_rad: [0.7, 0.01],
            wand_mm: (-178, 37),
            passes: 1000,
        },
    ]
}

/// What a case measured.
#[derive(Clone, Debug, PartialEq)]
pub struct Report {
    /// The case.
    pub name: &'static str,
    /// Passes compared.
    pub passes: u32,
    /// The first pass whose records differed (`None`: all agreed) and the two records.
    pub mismatch: Option<(u32, [u32; 5], [u32; 5])>,
    /// Cycles per pass: min, mean, max.
    pub cycles: [f64; 3],
    /// Modes seen (bit per mode code).
    pub modes: u32,
    /// Where the worst pass's cycles went: the five costliest functions.
    pub worst: Vec<(String, u64)>,
    /// Searches for the way out of blocked cells the native board's planner made.
    pub escapes: u32,
}

impl Report {
    /// Planner cycles per second at 16.7 MHz, from the mean and the worst pass.
    pub fn rate_hz(&self) -> [f64; 2] {
        [
            CPU_HZ as f64 / self.cycles[1],
            CPU_HZ as f64 / self.cycles[2],
        ]
    }
}

/// Global RAM with the header and the map of `disks`.
fn global_with(disks: &[(i32, i32, i32)]) -> Result<Vec<u8>, String> {
    let mut global = vec![0u8; GLOBAL_RAM_SIZE as usize];
    vme_map::init_header(&mut ArrayBus::new(&mut global));
    draw(&mut global, disks)?;
    Ok(global)
}

fn draw(global: &mut [u8], disks: &[(i32, i32, i32)]) -> Result<(), String> {
    crate::cspace_oracle::draw_disks_mm(&mut ArrayBus::new(global), disks)
        .map_err(|e| format!("{e:?}"))
}

/// Whether the map in `global` marks the pixel of angles `a` (rad).
fn marked(global: &mut [u8], a: [f64; 2]) -> bool {
    let px = std::f64::consts::TAU / 128.0;
    let i = |x: f64| ((x / px).floor() as i64).rem_euclid(128) as u32;
    crate::run::pixel_marked(&mut ArrayBus::new(global), i(a[0]), i(a[1]))
}

/// The records the host writes before pass `k`: the servo state of an arm at rest at
/// `theta` (rad), the reflex's `flags`, the wand at `wand` (mm).
pub fn feed(global: &mut [u8], theta: [f64; 2], k: u32, flags: u32, wand: (i32, i32)) {
    let u = |x: f64| (x * 1e6).round() as i32;
    let mut g = ArrayBus::new(global);
    vme_map::SERVO_STATE.publish(
        &mut g,
        &ServoState {
            theta1_urad: u(theta[0]),
            theta2_urad: u(theta[1]),
            arrest1_urad: u(theta[0]),
            arrest2_urad: u(theta[1]),
            t_us: 1000 * k,
            loops: 3 * k + 1,
            ..Default::default()
        },
    );
    vme_map::REFLEX_SUBGOAL.publish(
        &mut g,
        &vme_map::records::ReflexSubgoal {
            goal1_urad: u(theta[0]),
            goal2_urad: u(theta[1]),
            flags,
            cycle: k + 1,
        },
    );
    let mut t = ObjectTable {
        frame: k + 1,
        ..Default::default()
    };
    t.beacons[vme_map::records::beacon_index::WAND] = Beacon {
        x_um: wand.0 * 1000,
        y_um: wand.1 * 1000,
        t_us: 1000 * k,
        flags: beacon_flags::VALID,
    };
    vme_map::OBJECTS.publish(&mut g, &t);
}

/// The planner record's words.
fn record(global: &mut [u8]) -> [u32; 5] {
    let mut g = ArrayBus::new(global);
    let base = vme_map::PLANNER_GOAL.offset();
    // The record's words follow its sequence word.
    let mut w = [0u32; 5];
    for (i, v) in w.iter_mut().enumerate() {
        *v = g.read_u32(base + 4 + 4 * i as u32);
    }
    w
}

/// Runs `case` with the image in `dir` and the native board side by side.
pub fn run(dir: &Path, case: &Case) -> Result<Report, String> {
    let mut sys = System::power_up(dir, &[BoardId::Planner]).map_err(|e| e.to_string())?;
    draw(&mut sys.global, &case.disks)?;
    let mut native_g = global_with(&case.disks)?;
    let mut native = board_planner::Board::new();
    let mut io = crate::devices::IdOnly::new(BoardId::Planner);
    native.boot(&mut ArrayBus::new(&mut native_g), &mut io);
    // The image to its first heartbeat (boot done).
    sys.run_to_first_heartbeat(0)
        .ok_or("the planner image never beat")?;
    let hb = BoardSlot::of(BoardId::Planner).heartbeat();
    // The image's functions, to say where the worst pass's cycles went.
    let image = crate::image::Image::load(&dir.join("planner.elf")).map_err(|e| e.to_string())?;
    let mut cur = crate::boot::FunctionCycles::new(&image);
    let mut worst: Vec<(String, u64)> = Vec::new();
    let mut theta = case.start_rad;
    let (mut stuck, mut flags) = (0u32, 0u32);
    let (mut cmin, mut csum, mut cmax) = (u64::MAX, 0u64, 0u64);
    let mut modes = 0u32;
    let mut mismatch = None;
    for k in 0..case.passes {
        feed(&mut sys.global, theta, k, flags, case.wand_mm);
        feed(&mut native_g, theta, k, flags, case.wand_mm);
        // One image pass: to the next heartbeat.
        let b = &mut sys.boards[0];
        let h0 = ArrayBus::new(&mut sys.global).read_u32(hb);
        let c0 = b.cycles;
        cur.clear();
        while ArrayBus::new(&mut sys.global).read_u32(hb) == h0 {
            if b.state != crate::emu::RunState::Running || b.cycles - c0 > CPU_HZ {
                return Err(format!("{}: the image stopped at pass {k}", case.name));
            }
            let pc = b.cpu.pc;
            let c = b.step(&mut sys.global);
            cur.charge(pc, c);
        }
        let c = b.cycles - c0;
        native.poll(&mut ArrayBus::new(&mut native_g), &mut io);
        let (ri, rn) = (record(&mut sys.global), record(&mut native_g));
        if ri != rn && mismatch.is_none() {
            mismatch = Some((k, ri, rn));
        }
        modes |= 1 << (rn[2] & 0x1F);
        // Skip the start-up passes (the first whole read of the map) in the cost.
        if k >= 40 {
            cmin = cmin.min(c);
            if c > cmax {
                worst = cur.top();
                worst.truncate(5);
            }
            cmax = cmax.max(c);
            csum += c;
        }
        // The kinematic arm: a quarter pixel per pass toward the request.
        let req = [rn[0] as i32 as f64 * 1e-6, rn[1] as i32 as f64 * 1e-6];
        let step = std::f64::consts::TAU / 128.0 / 4.0;
        let mut moved = false;
        for i in 0..2 {
            let d = (req[i] - theta[i]).clamp(-step, step);
            if d.abs() > 1e-7 {
                let mut next = theta;
                next[i] += d;
                if !marked(&mut native_g, next) {
                    theta = next;
                    moved = true;
                }
            }
        }
        let at = (req[0] - theta[0]).abs() < 1e-4 && (req[1] - theta[1]).abs() < 1e-4;
        stuck = if moved || at { 0 } else { stuck + 1 };
        flags = reflex_flags::FROM_PLANNER | if stuck > 50 { reflex_flags::STALLED } else { 0 };
    }
    let n = case.passes.saturating_sub(40).max(1) as f64;
    Ok(Report {
        name: case.name,
        passes: case.passes,
        mismatch,
        cycles: [cmin as f64, csum as f64 / n, cmax as f64],
        modes,
        worst,
        escapes: native.planner().escapes(),
    })
}

/// `sim-host bench planner`: every case; the report text.
pub fn report(dir: &Path) -> Result<String, String> {
    let mut t = format!(
        "planner image on the emulated 68020 at 16.7 MHz (timing: {}), against the native board pass for pass\n\
         case                                    passes  agree  cycles/pass min / mean / max   rate mean / worst   modes  escapes\n",
        crate::emu::timing_name()
    );
    for c in cases() {
        let r = run(dir, &c)?;
        let [mean_hz, worst_hz] = r.rate_hz();
        t += &format!(
            "{:<40}{:>6}  {:>5}  {:>8.0} / {:>8.0} / {:>8.0}   {:>6.0} / {:>6.0} Hz   {:#x}  {}\n",
            r.name,
            r.passes,
            if r.mismatch.is_none() { "yes" } else { "NO" },
            r.cycles[0],
            r.cycles[1],
            r.cycles[2],
            mean_hz,
            worst_hz,
            r.modes,
            r.escapes
        );
        let names: Vec<String> = r
            .worst
            .iter()
            .map(|(n, c)| format!("{} {c}", crate::boot::demangle_short(n)))
            .collect();
        t += &format!("  worst pass: {}\n", names.join(", "));
        if let Some((k, a, b)) = r.mismatch {
            t += &format!("  first difference at pass {k}: image {a:x?}, native {b:x?}\n");
        }
    }
    t += "target: planner cycle >= 1 kHz (thesis 0.5-1 kHz)\n";
    Ok(t)
}
