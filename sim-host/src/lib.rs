//! The host simulator of the five-board controller (design.md section 7).
//!
//! * [`bench`](mod@bench): measurements of the simulator itself.
//! * [`image`]: board images (ELF, S-record, binary) and why one is refused.
//! * [`emu`]: a board's real image on an emulated 68020 and the bus it sees.
//! * [`devices`]: the boards' private I/O at register level.
//! * [`boot`]: powering the system up: global RAM header, boards out of reset, heartbeats.
//! * [`campaign`]: the reflex's safety campaign over random scenes.
//! * [`plant`]: the arm: amplifiers, motors, bands with their resonance, friction.
//! * [`plots`]: PNG pictures of a run.
//! * [`reflex_bench`]: the reflex image's loop and pixel-test rates, and its cost to a free move.
//! * [`run`]: a scenario run and its run directory.
//! * [`scenario`]: scenario files (TOML) and their errors.
//! * [`servo_bench`]: step responses of the servo against the thesis baselines.
//! * [`sim`]: the deterministic native-mode simulation: scheduler, world, collision oracle.
//! * [`docs`]: the generated tables of the memory-map and register documents.
#![deny(missing_docs)]

pub mod bench;
pub mod boot;
pub mod campaign;
pub mod cspace_bench;
pub mod cspace_db;
pub mod cspace_oracle;
pub mod demo_campaign;
pub mod devices;
pub mod docs;
pub mod emu;
pub mod fault_campaign;
pub mod gdb;
pub mod image;
pub mod monitor;
pub mod optics;
pub mod planner_bench;
pub mod planner_campaign;
pub mod plant;
pub mod plots;
pub mod reflex_bench;
pub mod report;
pub mod run;
pub mod scenario;
pub mod sensing_bench;
pub mod sensing_cal;
pub mod servo_bench;
pub mod sim;

/// Names of the five board images, as built by `cargo xtask images`.
pub const IMAGE_NAMES: [&str; 5] = ["sensing", "cspace", "servo", "reflex", "planner"];
