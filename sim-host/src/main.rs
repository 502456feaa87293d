//! `sim-host`: the command line of the simulator.

use clap::{Parser, Subcommand};
use sim_host::boot::{boot, default_images_dir, parse_board, FIVE};
use sim_host::emu::CPU_HZ;
use std::path::PathBuf;
use std::process::ExitCode;
use vme_map::BoardId;

/// The host simulator of the five-board 68020 robot controller.
#[derive(Parser)]
#[command(version, about)]
struct Cli {
    #[command(subcommand)]
    cmd: Cmd,
}

#[derive(Subcommand)]
enum Cmd {
    /// Boot board images on emulated 68020s and print each board's heartbeat and status.
    Boot {
        /// A board name (sensing, cspace, servo, reflex, planner, cspace0..2) or `all`.
        board: String,
        /// Directory holding `<board>.elf` (written by `cargo xtask images`).
        #[arg(long)]
        images: Option<PathBuf>,
        /// Emulated milliseconds to run after every board's first heartbeat.
        #[arg(long, default_value_t = 10.0)]
        ms: f64,
    },
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    match cli.cmd {
        Cmd::Boot { board, images, ms } => {
            let boards: Vec<BoardId> = if board == "all" {
                FIVE.to_vec()
            } else {
                match parse_board(&board) {
                    Some(b) => vec![b],
                    None => {
                        eprintln!("sim-host: unknown board {board:?} (sensing, cspace, servo, reflex, planner, cspace0..2, all)");
                        return ExitCode::from(2);
                    }
                }
            };
            let dir = images.unwrap_or_else(default_images_dir);
            let reports = match boot(&dir, &boards, ms) {
                Ok(r) => r,
                Err(e) => {
                    eprintln!("sim-host: {e}");
                    if !dir.exists() {
                        eprintln!("sim-host: build the images first: cargo xtask images");
                    }
                    return ExitCode::FAILURE;
                }
            };
            println!(
                "{:<9} {:>14} {:>10} {:>10} {:>12} {:<9} fault",
                "board", "cycles->beat", "us->beat", "heartbeat", "loops/s", "state"
            );
            let mut ok = true;
            for r in &reports {
                let (cyc, us) = match r.cycles_to_first_heartbeat {
                    Some(c) => (
                        c.to_string(),
                        format!("{:.1}", c as f64 * 1e6 / CPU_HZ as f64),
                    ),
                    None => ("never".into(), "-".into()),
                };
                let state = r
                    .status
                    .state()
                    .map_or("corrupt".to_string(), |s| format!("{s:?}"));
                let fault = r
                    .status
                    .fault()
                    .map_or("corrupt".to_string(), |f| format!("{f:?}"));
                println!(
                    "{:<9} {:>14} {:>10} {:>10} {:>12.0} {:<9} {}",
                    r.board.name(),
                    cyc,
                    us,
                    r.heartbeat,
                    r.loops_per_s,
                    state,
                    fault
                );
                ok &= r.cycles_to_first_heartbeat.is_some() && r.running;
            }
            if ok {
                ExitCode::SUCCESS
            } else {
                ExitCode::FAILURE
            }
        }
    }
}
