//! `sim-host bench cspace`: the C-space board image on emulated 68020s at 16.7 MHz (thesis
//! ch. IV section 7: draw + erase 7-30 ms per obstacle on one board; N boards proposed).
//!
//! * Cycles per obstacle update (draw the new image, erase the old one, with the work-list
//!   claim and release around them), for a 2-inch obstacle at radii from 40 to 520 mm: the
//!   host moves the obstacle 1 mm at a time and counts the cycles from the board's claim of
//!   the entry to its release, stepping the CPU one instruction at a time.
//! * Refresh rate of 5 obstacles moving at once with N = 1, 2, 3 C-space boards sharing the
//!   work list: redraws per obstacle per second of emulated time, the host publishing the
//!   object table every 2 ms as the sensing board does (500 Hz per beacon).
//!
//! Global RAM is modelled without VME wait states (the emulator bills the 68020's cache-case
//! instruction times), so the cycle counts are a lower bound for a real VME map.

use crate::boot::{FunctionCycles, System};
use crate::emu::{RunState, CPU_HZ};
use crate::image::Image;
use cspace::worklist::{JOB_SHIFT, OBSTACLE_BEACONS};
use std::path::Path;
use vme_map::layout::work_entry;
use vme_map::records::{beacon_flags, ObjectTable};
use vme_map::{BoardId, GlobalBus};

/// Cycles of one obstacle update at one radius.
#[derive(Clone, Debug)]
pub struct Update {
    /// Radius of the obstacle's centre, mm.
    pub r_mm: f64,
    /// CPU cycles from claim to release.
    pub cycles: u64,
    /// Those cycles by function, costliest first.
    pub functions: Vec<(String, u64)>,
}

fn publish(sys: &mut System, t: &ObjectTable) {
    vme_map::OBJECTS.publish(&mut sys.bus(), t);
}

fn table(frame: u32, t_us: u32, obstacles: &[(i32, i32)]) -> ObjectTable {
    let mut t = ObjectTable {
        frame,
        ..Default::default()
    };
    for (k, &(x, y)) in obstacles.iter().enumerate() {
        let b = &mut t.beacons[OBSTACLE_BEACONS[k] as usize];
        b.x_um = x;
        b.y_um = y;
        b.t_us = t_us;
        b.flags = beacon_flags::VALID;
    }
    t
}

/// Steps board 0 until entry 0 has been claimed and released again, returning the cycles
/// the claim was held (within `limit` cycles; `None` if it never completed), charging them
/// to the image's functions in `per`.
fn time_job(sys: &mut System, limit: u64, per: &mut FunctionCycles) -> Option<u64> {
    let claim = work_entry(0);
    let b = &mut sys.boards[0];
    let end = b.cycles + limit;
    let mut start = None;
    while b.cycles < end && b.state == RunState::Running {
        let pc = b.cpu.pc;
        let c = b.step(&mut sys.global);
        if start.is_some() {
            per.charge(pc, c);
        }
        let held = vme_map::ArrayBus::new(&mut sys.global).read_u32(claim) != 0;
        match (start, held) {
            (None, true) => start = Some(b.cycles),
            (Some(s), false) => return Some(b.cycles - s),
            _ => {}
        }
    }
    None
}

/// Cycles per obstacle update of a 2-inch obstacle at radii `radii_mm` on the x axis (and at
/// 45 degrees, both counted), one C-space board.
pub fn updates(dir: &Path, radii_mm: &[f64]) -> Result<Vec<Update>, String> {
    let mut sys = System::power_up(dir, &[BoardId::Cspace0]).map_err(|e| e.to_string())?;
    sys.run_to_first_heartbeat(0)
        .ok_or("the cspace image never beat")?;
    let image = Image::load(&dir.join("cspace.elf")).map_err(|e| e.to_string())?;
    let mut per = FunctionCycles::new(&image);
    let mut out = Vec::new();
    let mut frame = 0;
    for &r in radii_mm {
        for deg in [0.0f64, 45.0] {
            let (c, s) = (deg.to_radians().cos(), deg.to_radians().sin());
            // Draw it once there, then move it 1 mm: the second job draws and erases at r.
            // Samples 10 s apart: no velocity, no sweep.
            for step in 0..2 {
                frame += 1;
                let rr = r + step as f64;
                let p = ((rr * c * 1e3) as i32, (rr * s * 1e3) as i32);
                publish(&mut sys, &table(frame, frame * 10_000_000, &[p]));
                per.clear();
                let cycles =
                    time_job(&mut sys, CPU_HZ, &mut per).ok_or(format!("no job at r = {r} mm"))?;
                if step == 1 {
                    out.push(Update {
                        r_mm: r,
                        cycles,
                        functions: per.top(),
                    });
                }
            }
        }
    }
    Ok(out)
}

/// Redraws per obstacle per second of 5 obstacles moving together, with `n` boards.
pub fn refresh_rate(dir: &Path, n: usize, seconds: f64) -> Result<f64, String> {
    let ids = [BoardId::Cspace0, BoardId::Cspace1, BoardId::Cspace2];
    let mut sys = System::power_up(dir, &ids[..n]).map_err(|e| e.to_string())?;
    for i in 0..n {
        sys.run_to_first_heartbeat(i)
            .ok_or("a cspace image never beat")?;
    }
    // Five obstacles on circles about the shoulder, 150-450 mm, 1 rad/s: always moving.
    let at = |k: usize, t: f64| {
        let r = 150.0 + 75.0 * k as f64;
        let a = k as f64 * 1.2 + t * if k.is_multiple_of(2) { 1.0 } else { -1.0 };
        ((r * a.cos() * 1e3) as i32, (r * a.sin() * 1e3) as i32)
    };
    let jobs = |sys: &mut System| -> u64 {
        let mut bus = sys.bus();
        (0..5)
            .map(|k| (cspace::worklist::entry(&mut bus, k).state >> JOB_SHIFT) as u64)
            .sum()
    };
    let frame_cycles = CPU_HZ / 500;
    let mut frame = 0u32;
    let mut run = |sys: &mut System, secs: f64| {
        let frames = (secs * 500.0) as u32;
        for _ in 0..frames {
            frame += 1;
            let t = frame as f64 / 500.0;
            let obs: Vec<(i32, i32)> = (0..5).map(|k| at(k, t)).collect();
            publish(sys, &table(frame, frame * 2000, &obs));
            sys.run_cycles(frame_cycles);
        }
    };
    run(&mut sys, 0.2);
    let j0 = jobs(&mut sys);
    run(&mut sys, seconds);
    let j1 = jobs(&mut sys);
    Ok((j1 - j0) as f64 / 5.0 / seconds)
}

/// The object tables [`report`] checks the image against the host with: six obstacles
/// (every region of fig. IV.7) stepping up to 20 mm every 10 ms, one beacon blinking invalid.
pub fn equivalence_tables(seed: u64, frames: u32) -> Vec<ObjectTable> {
    let mut g = crate::sim::Rng::new(seed);
    let mut pos = [(0i32, 0i32); 6];
    for (k, p) in pos.iter_mut().enumerate() {
        let (r, a) = (30_000.0 + 95_000.0 * k as f64, k as f64 * 1.1);
        *p = ((r * a.cos()) as i32, (r * a.sin()) as i32);
    }
    (0..frames)
        .map(|f| {
            let mut t = ObjectTable {
                frame: f + 1,
                ..Default::default()
            };
            for (k, &b) in OBSTACLE_BEACONS.iter().enumerate() {
                pos[k].0 += ((g.next_f64() - 0.5) * 40_000.0) as i32;
                pos[k].1 += ((g.next_f64() - 0.5) * 40_000.0) as i32;
                let e = &mut t.beacons[b as usize];
                e.x_um = pos[k].0;
                e.y_um = pos[k].1;
                e.t_us = 10_000 * (f + 1);
                e.flags = if k == 2 && f % 5 == 3 {
                    beacon_flags::OCCLUDED
                } else {
                    beacon_flags::VALID
                };
            }
            t
        })
        .collect()
}

/// Runs the whole bench and returns its report.
pub fn report(dir: &Path) -> Result<String, String> {
    use std::fmt::Write as _;
    let radii: Vec<f64> = (0..=48).map(|i| 40.0 + 10.0 * i as f64).collect();
    let u = updates(dir, &radii)?;
    let ms = |c: f64| c * 1e3 / CPU_HZ as f64;
    let worst = u.iter().max_by_key(|x| x.cycles).expect("radii");
    let mean = u.iter().map(|x| x.cycles).sum::<u64>() as f64 / u.len() as f64;
    let mut o = String::new();
    let _ = writeln!(
        o,
        "C-space board image on the emulated 68020 at 16.7 MHz (no VME wait states; timing: {})",
        crate::emu::timing_name()
    );
    let _ = writeln!(
        o,
        "image against host (work list, map, stripes after each of 24 tables): {}",
        match image_vs_host(dir, &equivalence_tables(11, 24)) {
            Ok(()) => "identical".to_string(),
            Err(e) => format!("DIFFERENT: {e}"),
        }
    );
    let _ = writeln!(
        o,
        "draw + erase of one 2-inch obstacle, radii 40-520 mm at 0 and 45 degrees:"
    );
    let _ = writeln!(o, "{:>8} {:>10} {:>8}", "r (mm)", "cycles", "ms");
    for x in u.iter().step_by(8) {
        let _ = writeln!(
            o,
            "{:>8.0} {:>10} {:>8.3}",
            x.r_mm,
            x.cycles,
            ms(x.cycles as f64)
        );
    }
    let _ = writeln!(
        o,
        "worst {} cycles = {:.3} ms at r = {:.0} mm (target <= 3 ms; thesis 7-30 ms); mean {:.0} cycles = {:.3} ms",
        worst.cycles,
        ms(worst.cycles as f64),
        worst.r_mm,
        mean,
        ms(mean)
    );
    let _ = writeln!(o, "  the worst update's costliest functions:");
    for (name, c) in worst.functions.iter().take(8) {
        let _ = writeln!(
            o,
            "  {:>10} {:5.1}%  {}",
            c,
            100.0 * *c as f64 / worst.cycles as f64,
            crate::boot::demangle_short(name)
        );
    }
    let _ = writeln!(
        o,
        "refresh rate of 5 moving obstacles (redraws per obstacle per second, 3 s emulated):"
    );
    let mut one = 0.0;
    for n in 1..=3 {
        let r = refresh_rate(dir, n, 3.0)?;
        if n == 1 {
            one = r;
        }
        let _ = writeln!(
            o,
            "  N = {n}: {r:7.1} Hz = {:.2} x N x (N = 1){}",
            r / (n as f64 * one),
            if n == 1 {
                "  (target >= 60 Hz)"
            } else {
                "  (target >= 0.85)"
            }
        );
    }
    Ok(o)
}

/// Runs the object tables `tables` through the C-space image on the emulated 68020 and
/// through `cspace::worklist::step` natively, and requires the same work list, map and stripe
/// layer after each table (bit for bit): the image's compiled code against the host's.
pub fn image_vs_host(dir: &Path, tables: &[ObjectTable]) -> Result<(), String> {
    use vme_map::layout::{
        CSPACE_MAP, CSPACE_MAP_BYTES, CSPACE_STRIPES, CSPACE_STRIPES_BYTES, WORK_CURSOR,
    };
    let mut sys = System::power_up(dir, &[BoardId::Cspace0]).map_err(|e| e.to_string())?;
    sys.run_to_first_heartbeat(0)
        .ok_or("the cspace image never beat")?;
    let mut host = vec![0u8; vme_map::GLOBAL_RAM_SIZE as usize];
    let n = OBSTACLE_BEACONS.len() as u32;
    let entries = work_entry(0)..work_entry(n);
    let mut scratch = Box::new(cspace::worklist::Scratch::new());
    for (k, t) in tables.iter().enumerate() {
        publish(&mut sys, t);
        // One whole round of the cursor after the table is in place, plus the job in flight.
        let c0 = sys.bus().read_u32(WORK_CURSOR);
        let mut waited = 0;
        while sys.bus().read_u32(WORK_CURSOR).wrapping_sub(c0) < n + 1 {
            sys.run_cycles(CPU_HZ / 1000);
            waited += 1;
            if waited > 20_000 || sys.boards[0].state != RunState::Running {
                let st = sys.boards[0].state;
                let f = sys.fault(BoardId::Cspace0);
                let log = sys.log_text(BoardId::Cspace0);
                return Err(format!(
                    "table {k}: the image stopped working the list ({st:?}, fault {f:?}, log {log:?})"
                ));
            }
        }
        // Between jobs: no claim held (a job half done would show a half-drawn map).
        let claims_held = |sys: &mut System| (0..n).any(|i| sys.bus().read_u32(work_entry(i)) != 0);
        let mut slices = 0;
        while claims_held(&mut sys) {
            sys.run_cycles(500);
            slices += 1;
            if slices > 1_000_000 {
                return Err(format!("table {k}: a job never ends"));
            }
        }
        let mut hb = vme_map::ArrayBus::new(&mut host);
        for _ in 0..n {
            cspace::worklist::step(&mut hb, 1, t, &mut scratch);
        }
        for (name, r) in [
            ("work list", entries.start as usize..entries.end as usize),
            (
                "map",
                CSPACE_MAP as usize..(CSPACE_MAP + CSPACE_MAP_BYTES) as usize,
            ),
            (
                "stripes",
                CSPACE_STRIPES as usize..(CSPACE_STRIPES + CSPACE_STRIPES_BYTES) as usize,
            ),
        ] {
            let (a, b) = (&sys.global[r.clone()], &host[r.clone()]);
            if let Some(i) = (0..a.len()).find(|&i| a[i] != b[i]) {
                // Eight words from the one that differs.
                let words = |m: &[u8]| -> Vec<String> {
                    let w0 = (r.start + i) & !3;
                    (0..8)
                        .map(|j| {
                            let o = w0 + 4 * j;
                            format!(
                                "{:#x}",
                                u32::from_be_bytes([m[o], m[o + 1], m[o + 2], m[o + 3]])
                            )
                        })
                        .collect()
                };
                return Err(format!(
                    "table {k}: {name} differs at byte {} (image {:#04x}, host {:#04x}); \
                     words there: image {:?}, host {:?}",
                    r.start + i,
                    a[i],
                    b[i],
                    words(&sys.global),
                    words(&host)
                ));
            }
        }
    }
    Ok(())
}
