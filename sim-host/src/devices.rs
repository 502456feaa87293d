//! The boards' private I/O at register level (design.md section 7, "Devices").
//!
//! [`PrivateIo`] decodes a board's register table from the `regs` crate: an access to an
//! offset the table does not list, or in a direction it does not allow, is not decoded and
//! the CPU takes a bus error. Every board has its board-ID switch; the servo board's 2 MHz
//! free-running counter counts from the board's CPU cycles. Other registers latch what was
//! written until the device models of the simulator issue (encoders, DACs and amplifiers,
//! LED driver, A/D converters) are attached behind the same table.

use crate::emu::{Device, CPU_HZ};
use regs::{decodes, Register};
use vme_map::BoardId;

/// The private I/O block of one board.
pub struct PrivateIo {
    table: &'static [Register],
    switch: u16,
    timer: bool,
    latches: Vec<(u32, u16)>,
}

impl PrivateIo {
    /// The private I/O of `board`: the servo and sensing boards have their register tables;
    /// the others decode only the board-ID switch.
    pub fn for_board(board: BoardId) -> Self {
        let (table, timer): (&'static [Register], bool) = match board {
            BoardId::Servo => (&regs::servo::REGISTERS, true),
            BoardId::Sensing => (&regs::sensing::REGISTERS, false),
            _ => (&ID_ONLY, false),
        };
        let switch = match board {
            BoardId::Cspace1 => 1,
            BoardId::Cspace2 => 2,
            _ => 0,
        };
        Self {
            table,
            switch,
            timer,
            latches: Vec::new(),
        }
    }
}

static ID_ONLY: [Register; 1] = [Register {
    name: "BOARD_ID",
    offset: regs::BOARD_ID,
    access: regs::Access::R,
}];

/// The 2 MHz counter's value at CPU cycle `now`.
pub fn timer_at(now: u64) -> u16 {
    (now as u128 * regs::servo::TIMER_HZ as u128 / CPU_HZ as u128) as u16
}

impl Device for PrivateIo {
    fn read16(&mut self, off: u32, now: u64) -> Option<u16> {
        if !decodes(self.table, off, false) {
            return None;
        }
        Some(match off {
            regs::BOARD_ID => self.switch,
            regs::servo::TIMER if self.timer => timer_at(now),
            _ => self
                .latches
                .iter()
                .find(|(o, _)| *o == off)
                .map_or(0, |(_, v)| *v),
        })
    }

    fn write16(&mut self, off: u32, val: u16, _now: u64) -> bool {
        if !decodes(self.table, off, true) {
            return false;
        }
        match self.latches.iter_mut().find(|(o, _)| *o == off) {
            Some(l) => l.1 = val,
            None => self.latches.push((off, val)),
        }
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn undecoded_and_wrong_direction_accesses_are_refused() {
        let mut io = PrivateIo::for_board(BoardId::Servo);
        assert_eq!(io.read16(regs::UNDECODED_PROBE, 0), None);
        assert_eq!(io.read16(regs::servo::DAC0, 0), None, "DACs are write-only");
        assert!(
            !io.write16(regs::servo::TIMER, 1, 0),
            "the timer is read-only"
        );
        assert!(io.write16(regs::servo::AMP_CTRL, 3, 0));
        assert_eq!(io.read16(regs::servo::AMP_CTRL, 0), Some(3));
        let mut planner = PrivateIo::for_board(BoardId::Planner);
        assert_eq!(planner.read16(regs::servo::TIMER, 0), None);
        assert_eq!(planner.read16(regs::BOARD_ID, 0), Some(0));
        assert_eq!(
            PrivateIo::for_board(BoardId::Cspace2).read16(regs::BOARD_ID, 0),
            Some(2)
        );
    }

    #[test]
    fn the_timer_counts_at_2_mhz_and_wraps() {
        let mut io = PrivateIo::for_board(BoardId::Servo);
        let t = |io: &mut PrivateIo, c| io.read16(regs::servo::TIMER, c).unwrap();
        assert_eq!(t(&mut io, 0), 0);
        assert_eq!(t(&mut io, CPU_HZ / 1000), 2000, "1 ms is 2000 counts");
        // 32.768 ms = 65536 counts: back to 0.
        let wrap = (CPU_HZ * 65536).div_ceil(2_000_000);
        assert_eq!(t(&mut io, wrap), 0);
        assert_eq!(t(&mut io, wrap + CPU_HZ / 1000), 2000);
    }
}
