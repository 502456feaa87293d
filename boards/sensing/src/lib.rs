//! The sensing board: wires the LED strobe driver, the A/D converters, the 2 MHz timer and
//! global RAM to the logic of `crates/sensing` (thesis ch. II section 3, optical sensing;
//! design.md section 3). The same code runs in the image (`src/main.rs`, volatile MMIO) and
//! in the simulator's native mode (device models behind [`IoBus`]).
//!
//! One pass per 250 us strobe slot (paced by the timer): read the finished conversion,
//! start the next on the beacon lit during the slot, light the next beacon, then process
//! the sample and publish the object table, the raw signal table and the drift estimate
//! under their sequence locks. Faults (a saturated converter input, a refused calibration
//! table, a stale servo state, an implausible drift estimate) are recorded when they start;
//! the board is `Degraded` while one lasts and publishes the affected beacons invalid.
#![no_std]
#![deny(missing_docs)]

use board_shell::Shell;
use regs::sensing::{AdcStatus, SensingIo};
use regs::IoBus;
pub use sensing::cal::GlobalCal;
use sensing::cal::State;
use sensing::{AdcSample, Config, Event, Input, Sensing, ServoView};
use vme_map::records::beacon_index;
use vme_map::{BoardId, BoardState, FaultCode, GlobalBus};

/// Strobe slots per heartbeat: the board beats once per strobe frame of eight beacons.
pub const SLOTS_PER_BEAT: u32 = 8;

/// The sensing board's state between main-loop passes. `repr(C)` with the logic's 9 KiB
/// last: LLVM's M68k backend folds only small displacements into an instruction, and a
/// field behind the logic cost a register load and an indexed access each time.
#[repr(C)]
pub struct Board {
    shell: Shell,
    /// The fault seen in the current strobe frame, if any.
    fault: Option<FaultCode>,
    /// Whether a fault was seen in the current frame.
    fault_this_frame: bool,
    heartbeat: u32,
    /// The configuration record's sequence number when it was last read whole (`None`:
    /// not yet): the record is read again only when that word changes.
    config_seq: Option<u32>,
    /// Strobe frames since the drift record was last published.
    drift_age: u32,
    /// The servo state record's words as last read.
    servo_words: [u32; SERVO_WORDS],
    /// The logic.
    pub sensing: Sensing,
}

/// Words of the servo state record.
const SERVO_WORDS: usize =
    <vme_map::records::ServoState as vme_map::record::Record>::WORDS as usize;

/// Strobe frames between publications of the drift estimate (16 ms): the host only shows it;
/// the correction itself is the board's own. Published every frame, encoding and writing
/// it cost a tenth of a slot's budget.
pub const DRIFT_EVERY_FRAMES: u32 = 8;

impl Default for Board {
    fn default() -> Self {
        Self::new()
    }
}

impl Board {
    /// A fresh board.
    pub const fn new() -> Self {
        Self {
            shell: Shell::new(BoardId::Sensing),
            fault: None,
            fault_this_frame: false,
            heartbeat: 0,
            config_seq: None,
            drift_age: 0,
            servo_words: [0; SERVO_WORDS],
            sensing: Sensing::new(),
        }
    }

    /// The board's identity.
    pub const fn id(&self) -> BoardId {
        self.shell.id()
    }

    /// Puts the outputs in their safe state and waits for the global RAM header.
    pub fn boot(&mut self, g: &mut dyn GlobalBus, io: &mut impl IoBus) {
        safe(io);
        self.shell.boot(g, || {});
    }

    /// One pass of the main loop: nothing until the timer says a strobe slot has passed,
    /// then the slot's work. Returns the heartbeat (one beat per strobe frame of 8 slots).
    pub fn poll<G: GlobalBus>(&mut self, g: &mut G, io: &mut impl IoBus) -> u32 {
        let mut hw = SensingIo::new(&mut *io);
        let Some(slot) = self.sensing.slot(hw.timer()) else {
            return self.heartbeat;
        };
        // The finished conversion first: a new start clears the status bits.
        let sample = hw.sample().map(|s| AdcSample {
            x: s.x,
            y: s.y,
            sum: s.sum,
            over: s
                .status
                .intersects(AdcStatus::OVER_X | AdcStatus::OVER_Y | AdcStatus::OVER_SUM),
        });
        if slot.start {
            hw.start_conversion();
        }
        hw.set_level_ma(slot.level_ma);
        hw.strobe(slot.next as u16, true);
        // Host commands once per strobe frame (2 ms): they cost a tenth of a slot.
        if slot.next == 0 {
            self.shell.begin(g, io);
        }
        let servo = if slot.processing == Some(beacon_index::TIP as u8) {
            // The record's words in one call (the word-by-word read cost 1,400 cycles), into
            // the board's buffer (a zeroed local cost a memset call, 30 cycles a slot).
            let w = &mut self.servo_words;
            match vme_map::SERVO_STATE
                .read_raw(g, w)
                .map(|seq| (vme_map::records::ServoState::from_words(w), seq))
            {
                Ok((s, seq)) if seq != 0 => Some(ServoView {
                    theta_urad: [s.theta1_urad, s.theta2_urad],
                    loops: s.loops,
                }),
                _ => None,
            }
        } else {
            None
        };
        // The host's configuration once a frame, read whole only when its sequence word
        // moved (a publication always moves it): the same configurations as reading it
        // every frame, for one word a frame.
        let config = if slot.processing == Some(0)
            && Some(vme_map::SENSING_CONFIG.sequence(g)) != self.config_seq
        {
            match vme_map::SENSING_CONFIG.read(g) {
                Ok((c, seq)) => {
                    self.config_seq = Some(seq);
                    Some(if seq != 0 {
                        Config::from_record(&c)
                    } else {
                        Config::default()
                    })
                }
                Err(_) => None,
            }
        } else {
            None
        };
        let out = self.sensing.step(
            &Input {
                sample,
                servo,
                config,
            },
            &mut GlobalCal(g),
        );
        if let Some(b) = out.beacon {
            // Only the processed beacon's words change (and the frame after beacon 7); on
            // the 68020 the common slot's assembly has published them already.
            if !out.published {
                self.sensing.publish(g, b);
            }
            let i = b as usize & 7;
            if i == beacon_index::TIP {
                self.drift_age += 1;
                if self.drift_age >= DRIFT_EVERY_FRAMES {
                    self.drift_age = 0;
                    let d = &self.sensing.drift;
                    let o = d.offset_q5();
                    let rec = vme_map::records::SensingDrift {
                        ox_q5: o[0],
                        oy_q5: o[1],
                        gx_q24: d.g_q24[0],
                        gy_q24: d.g_q24[1],
                        observations: d.observations,
                    };
                    vme_map::SENSING_DRIFT.publish(g, &rec);
                }
            }
        }
        // Most slots have no event: the word is tested before it is decoded.
        if let Some(ev) = (out.event != 0).then(|| out.event()).flatten() {
            let (code, detail) = match ev {
                Event::Saturated(b) => (FaultCode::AdcSaturated, b as u32),
                Event::BadCalibration(r) => (FaultCode::BadCalibration, r as u32),
                Event::StaleServo => (FaultCode::StaleHeartbeat, vme_map::SERVO_STATE.offset()),
                Event::DriftBound => (FaultCode::OutOfRange, vme_map::SENSING_DRIFT.offset()),
            };
            // A fault is recorded when it starts (or changes), not on every slot it lasts.
            if self.fault != Some(code) {
                self.shell.life().degraded(g, code, detail);
            }
            self.fault = Some(code);
            self.fault_this_frame = true;
        }
        if out.beacon == Some(7) {
            if !self.fault_this_frame {
                self.fault = None;
            }
            self.fault_this_frame = false;
        }
        // One beat per strobe frame (2 ms), in the slot that polled the host: a beat every
        // slot cost a tenth of the slot's budget.
        const _: () = assert!(SLOTS_PER_BEAT as usize == vme_map::records::BEACONS);
        if slot.next == 0 {
            let bad_table = matches!(self.sensing.checker.state, State::Bad(_));
            let state = if self.fault.is_some() || bad_table {
                BoardState::Degraded
            } else {
                BoardState::Running
            };
            self.heartbeat = self.shell.end(g, state);
        }
        self.heartbeat
    }
}

/// The board's safe state: all LEDs off. Also the image's safe-stop hook after a fault.
pub fn safe(io: &mut impl IoBus) {
    SensingIo::new(io).safe();
}
