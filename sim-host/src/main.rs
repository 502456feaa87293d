//! `sim-host`: the command line of the simulator.

use clap::{Parser, Subcommand};
use sim_host::boot::{boot, default_images_dir, parse_board, FIVE};
use sim_host::emu::CPU_HZ;
use sim_host::run::{run_to_dir, RunOptions};
use sim_host::scenario::Scenario;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use vme_map::BoardId;

/// The board names the command line accepts (`parse_board`).
const BOARD_NAMES: &str = "sensing, cspace, servo, reflex, planner, cspace0..2";

/// The host simulator of the five-board 68020 robot controller.
#[derive(Parser)]
#[command(version, about)]
struct Cli {
    /// Image mode, benches and profiles: model the 68020's 256-byte instruction cache, so
    /// an instruction takes the manual's cache-case time only when it was fetched from the
    /// cache and its worst-case time otherwise. Without it every instruction takes the
    /// cache-case time (an upper bound on the images' speed; the basis of the figures in
    /// docs/ before 2026-11-26's seventh session). docs/performance.md compares the two.
    #[arg(long, global = true)]
    icache: bool,
    #[command(subcommand)]
    cmd: Cmd,
}

/// How a run executes the boards.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
enum Mode {
    /// The boards' crates compiled for the host, at their set rates.
    Native,
    /// The real images on emulated 68020s at 16.7 MHz.
    Image,
}

/// How a scenario is run (`run` and `demo`).
#[derive(clap::Args)]
struct RunArgs {
    /// native or image.
    #[arg(long, value_enum, default_value_t = Mode::Native)]
    mode: Mode,
    /// Image mode: directory holding `<board>.elf` (written by `cargo xtask images`).
    #[arg(long)]
    images: Option<PathBuf>,
    /// Image mode: only these boards (comma-separated) as images, the others native.
    #[arg(long, value_delimiter = ',')]
    image_boards: Vec<String>,
    /// Image mode: serve the GDB remote protocol for `<board>:<port>` on 127.0.0.1 and
    /// wait for GDB before the run starts (e.g. `reflex:1234`; port 0 picks a free one).
    #[arg(long)]
    gdb: Option<String>,
    /// Image mode: where this board's main-loop passes longer than its budget (1 ms for
    /// the reflex; `budget us` in the board table) spend their cycles, every instruction
    /// charged to its function; printed after the table and kept in summary.json.
    #[arg(long)]
    long_passes: Option<String>,
    /// Run directory to write (default out/run, or out/demo for `demo`).
    #[arg(long)]
    out: Option<PathBuf>,
    /// No progress bar.
    #[arg(long)]
    quiet: bool,
    /// Trace interval in microseconds (a multiple of the plant step).
    #[arg(long, default_value_t = 1000.0)]
    trace_every_us: f64,
    /// Serve the live monitor on 127.0.0.1:<PORT> (0: any free port) and pace the run to
    /// real time.
    #[arg(long)]
    monitor: Option<u16>,
}

#[derive(Subcommand)]
enum Cmd {
    /// Run a scenario and write its run directory (trace.csv, summary.json, PNGs): natively
    /// (`--mode native`, the boards' crates on the host at their set rates) or as the real
    /// images on emulated 68020s at 16.7 MHz (`--mode image`, the loop rates the code
    /// reaches), optionally serving GDB for one board (`--gdb servo:1234`).
    Run {
        /// The scenario file (TOML; docs/scenarios.md).
        scenario: PathBuf,
        #[command(flatten)]
        run: RunArgs,
    },
    /// The main job: the integrated demo (sim-host/scenarios/demo.toml: the arm following a
    /// moving wand among moving obstacles and the instructional robot, all five boards) with
    /// its run directory and `report.html` (default `out/demo`); `--seed` picks the run.
    Demo {
        /// Seed (default: the scenario's).
        #[arg(long)]
        seed: Option<u64>,
        #[command(flatten)]
        run: RunArgs,
    },
    /// Measurements: `sim` = real-time factor of the native simulation (`--seconds`, `--reps`);
    /// `servo` = step responses against the thesis's baselines, with pictures (`--out`);
    /// `cspace` = the C-space image's cycles per obstacle update and refresh rates with 1-3
    /// boards; `reflex` = the reflex image's loop and pixel-test rates and its cost to a free
    /// move.
    Bench {
        /// What to measure (sim, servo, cspace, sensing, reflex).
        what: String,
        /// Simulated seconds per repetition.
        #[arg(long, default_value_t = 10.0)]
        seconds: f64,
        /// Repetitions (the report gives best, median and worst).
        #[arg(long, default_value_t = 5)]
        reps: usize,
        /// Where `servo` and `sensing` write their pictures (default out/bench-<what>).
        #[arg(long)]
        out: Option<PathBuf>,
        /// `sensing`: a quick look (8 x 8 scan, 70 survey points) instead of the full bench.
        #[arg(long)]
        quick: bool,
        /// `sensing`: the seed of the sensor model and the survey.
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// `reflex`: after each case, its this many costliest functions (cycles a pass in
        /// their own code, every instruction charged), then those of its longest pass alone
        /// (0: no profile).
        #[arg(long, default_value_t = 0)]
        top: usize,
    },
    /// Campaigns: `reflex` runs random scenes (1-5 disks, random start in free space
    /// and wand goal) with the sensing, C-space, servo and reflex boards and the collision
    /// oracle at every plant step: `--scenes` static ones, then `--moving` ones whose disks
    /// circle the shoulder at C-space border speeds up to 30 pixels/s. Writes
    /// `<out>/static/` and `<out>/moving/` (summary.json, scenes.csv, a scenario file per
    /// scene with a collision); exits 1 if any scene had a collision. `planner` runs
    /// `--scenes` random static scenes with all five boards, each judged by an A* oracle on
    /// the same C-space map (solvable or not, time estimate); writes summary.json,
    /// scenes.csv, a scenario per scene with a collision, a missed goal or an unsolvable
    /// goal neither reported nor reached, and `--pictures` C-space pictures with the
    /// oracle's path; exits 1 on a collision, a missed solvable goal or an unsolvable goal
    /// not reported.
    Campaign {
        /// What to run (reflex, planner).
        what: String,
        /// Static scenes.
        #[arg(long, default_value_t = 2000)]
        scenes: u64,
        /// Moving scenes (default: a quarter of --scenes).
        #[arg(long)]
        moving: Option<u64>,
        /// Campaign seed: scene i of seed s is always the same scene.
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// Output directory (default out/campaign-<what>).
        #[arg(long)]
        out: Option<PathBuf>,
        /// Threads (default: the machine's cores).
        #[arg(long)]
        threads: Option<usize>,
        /// `planner`: pictures of this many scenes that needed the planner.
        #[arg(long, default_value_t = 12)]
        pictures: usize,
        /// `planner`: run only scene I of the campaign and write its picture
        /// (`<out>/scene-I.png`).
        #[arg(long)]
        only: Option<u64>,
        /// `reflex`: where the disks are: `sensed` keeps their centres inside the camera's
        /// calibrated 0.7 m square (a moving disk's whole circle); `reach` anywhere
        /// 0.12-0.55 m from the shoulder, where the sensing can misplace them (default
        /// sensed).
        #[arg(long, value_enum)]
        place: Option<sim_host::campaign::Place>,
        /// `faults` and `demo`: native or image.
        #[arg(long, value_enum, default_value_t = Mode::Native)]
        mode: Mode,
        /// Image mode: directory holding `<board>.elf` (written by `cargo xtask images`).
        #[arg(long)]
        images: Option<PathBuf>,
    },
    /// Profile one board image on the emulated 68020: cycles per main-loop pass and the
    /// functions they go to.
    Profile {
        /// A board name (sensing, cspace, servo, reflex, planner).
        board: String,
        /// Directory holding `<board>.elf` (written by `cargo xtask images`).
        #[arg(long)]
        images: Option<PathBuf>,
        /// Emulated milliseconds to profile after the first heartbeat.
        #[arg(long, default_value_t = 10.0)]
        ms: f64,
        /// Functions to list.
        #[arg(long, default_value_t = 15)]
        top: usize,
        /// The sensing board with a servo state of an arm resting, its tip at the tip's
        /// lit beacon: the drift learnt from the tip and corrected (the running system at
        /// rest).
        #[arg(long)]
        resting: bool,
        /// Also list this many costliest instruction addresses (with their function), to
        /// read beside `m68k-linux-gnu-objdump -d` of the image.
        #[arg(long, default_value_t = 0)]
        addresses: usize,
        /// The servo board: the reflex subgoal the host publishes, link 1 and link 2 in
        /// urad. The standalone board's encoders stay at 0, so a goal away from 0 keeps the
        /// law on its braking curve (a square root a link a pass): the moving arm's pass.
        #[arg(long, value_delimiter = ',', allow_hyphen_values = true,
              default_values_t = [0, 0])]
        servo_goal_urad: Vec<i32>,
        /// The servo board: the subgoal's cycle stops changing this many milliseconds into
        /// the profile, as when the reflex dies (20 ms later the servo holds, its first hold
        /// pass looking up the arrest point of the last fresh subgoal).
        #[arg(long)]
        servo_subgoal_freeze_ms: Option<f64>,
    },
    /// Build the C-space image database from the arm's outline and check it against the
    /// committed `crates/cspace/src/tables.rs` (or rewrite that file with `--write`).
    CspaceDb {
        /// Rewrite the committed tables instead of checking them.
        #[arg(long)]
        write: bool,
    },
    /// Check the C-space map against the exact oracle for random disks (centres over the
    /// arm's reach, radii up to 2 inches): false-free pixels (must be none), false-occupied
    /// area, undecided pixels.
    CspaceCheck {
        /// Number of random disks.
        #[arg(long, default_value_t = 100_000)]
        disks: u64,
        /// Seed of the disks.
        #[arg(long, default_value_t = 1)]
        seed: u64,
    },
    /// Draw the thesis's C-space figures (IV.1-IV.6, IV.9-IV.11): exact image and map side by
    /// side.
    CspaceFigures {
        /// Where to write the PNGs.
        #[arg(long, default_value = "docs/cspace")]
        out: PathBuf,
    },
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

/// The exit status when standard output's reader has gone (128 + SIGPIPE, what a shell
/// reports for a program a closed pipe ended).
const CLOSED_STDOUT_EXIT: i32 = 141;

/// A closed standard output (`sim-host run ... | head -1`) ends the program quietly with
/// [`CLOSED_STDOUT_EXIT`], as command-line tools end, instead of `println!`'s panic and
/// backtrace. Every other panic reports as before. (SIGPIPE stays ignored, Rust's default:
/// the live monitor's closed sockets stay errors it handles, not a signal that kills it.)
fn end_quietly_on_closed_stdout() {
    let report = std::panic::take_hook();
    std::panic::set_hook(Box::new(move |info| {
        let msg = info.payload_as_str().unwrap_or("");
        // "failed printing to stdout: Broken pipe (os error 32)"
        if msg.starts_with("failed printing to stdout")
            && msg.to_ascii_lowercase().contains("broken pipe")
        {
            std::process::exit(CLOSED_STDOUT_EXIT);
        }
        report(info);
    }));
}

/// Whether `cmd` runs board images on emulated 68020s (where `--icache` means something).
fn runs_images(cmd: &Cmd) -> bool {
    match cmd {
        Cmd::Run { run, .. } | Cmd::Demo { run, .. } => run.mode == Mode::Image,
        Cmd::Bench { what, .. } => {
            matches!(what.as_str(), "cspace" | "sensing" | "reflex" | "planner")
        }
        Cmd::Campaign { what, mode, .. } => what == "faults" && *mode == Mode::Image,
        Cmd::Profile { .. } | Cmd::Boot { .. } => true,
        _ => false,
    }
}

fn main() -> ExitCode {
    end_quietly_on_closed_stdout();
    let cli = Cli::parse();
    if cli.icache && !runs_images(&cli.cmd) {
        eprintln!(
            "sim-host: --icache times the images' instructions, and this command runs no image \
             (image runs: run/demo --mode image, campaign faults --mode image, bench cspace, \
             sensing, reflex or planner, profile, boot)"
        );
        return ExitCode::from(2);
    }
    sim_host::emu::set_icache_model(cli.icache);
    match cli.cmd {
        Cmd::Run { scenario, run } => match Scenario::load(&scenario) {
            Ok(sc) => run_cmd(&sc, run, "out/run"),
            Err(e) => {
                eprintln!("sim-host: {e}");
                ExitCode::from(2)
            }
        },
        Cmd::Demo { seed, run } => {
            match Scenario::load(&sim_host::demo_campaign::scenario_path()) {
                Ok(mut sc) => {
                    if let Some(seed) = seed {
                        sc.config.seed = seed;
                    }
                    run_cmd(&sc, run, "out/demo")
                }
                Err(e) => {
                    eprintln!("sim-host: {e}");
                    ExitCode::from(2)
                }
            }
        }
        Cmd::Campaign {
            what,
            scenes,
            moving,
            seed,
            out,
            threads,
            pictures,
            only,
            mode,
            images,
            place,
        } => {
            if place.is_some() && what != "reflex" {
                eprintln!("sim-host: campaign {what}: --place is for the reflex campaign");
                return ExitCode::from(2);
            }
            let place = place.unwrap_or(sim_host::campaign::Place::Sensed);
            let out = out.unwrap_or_else(|| PathBuf::from(format!("out/campaign-{what}")));
            let threads = threads
                .unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()));
            let images = (mode == Mode::Image).then(|| images.unwrap_or_else(default_images_dir));
            if what == "faults" {
                return fault_campaign(images.as_deref(), threads, &out);
            }
            if what == "demo" {
                return demo_campaign(scenes, images.as_deref(), threads, &out);
            }
            if images.is_some() {
                eprintln!(
                    "sim-host: campaign {what}: --mode image is for the faults and demo campaigns"
                );
                return ExitCode::from(2);
            }
            if what == "planner" {
                if let Some(i) = only {
                    if let Err(e) = std::fs::create_dir_all(&out) {
                        eprintln!("sim-host: {}: {e}", out.display());
                        return ExitCode::FAILURE;
                    }
                    return match sim_host::planner_campaign::picture(seed, i, &out) {
                        Ok(r) => {
                            println!("{}", serde_json::to_string(&r).expect("serializes"));
                            println!("wrote {}", out.join(format!("scene-{i}.png")).display());
                            ExitCode::SUCCESS
                        }
                        Err(e) => {
                            eprintln!("sim-host: {e}");
                            ExitCode::FAILURE
                        }
                    };
                }
                return planner_campaign(seed, scenes, threads, pictures, &out);
            }
            if what != "reflex" {
                eprintln!("sim-host: campaign: unknown campaign {what:?} (known: reflex, planner, faults, demo)");
                return ExitCode::from(2);
            }
            let mut any = false;
            for (kind, n) in [
                (sim_host::campaign::Kind::Static, scenes),
                (
                    sim_host::campaign::Kind::Moving,
                    moving.unwrap_or(scenes / 4),
                ),
            ] {
                if n == 0 {
                    continue;
                }
                let name = kind.name();
                let bar = indicatif::ProgressBar::new(n);
                bar.set_message(name);
                let dir = out.join(name);
                match sim_host::campaign::run_to_dir(kind, place, seed, n, threads, &dir, &|| {
                    bar.inc(1)
                }) {
                    Ok(s) => {
                        bar.finish_and_clear();
                        println!(
                            "reflex campaign, {name}: {} scenes (seed {seed}, disks placed {}), {} with collisions ({} contacts), min clearance {:.1} mm; goals reached {} ({:.1}%), time to goal median {:.2} s, p95 {:.2} s, max {:.2} s; stalled {}; escapes in {} scenes; holds in {}; map unmarked next to the arm in {} scenes ({} ms); {:.0} s wall -> {}",
                            s.scenes,
                            place.name(),
                            s.scenes_with_collisions,
                            s.collisions,
                            s.min_clearance_m * 1e3,
                            s.goals_reached,
                            100.0 * s.goals_reached as f64 / s.scenes as f64,
                            s.time_to_goal_s[0],
                            s.time_to_goal_s[1],
                            s.time_to_goal_s[2],
                            s.stalled,
                            s.scenes_with_escapes,
                            s.scenes_with_holds,
                            s.scenes_unmarked_near_arm,
                            s.unmarked_ms,
                            s.wall_s,
                            dir.display()
                        );
                        if !s.collision_scenes.is_empty() {
                            println!("  scenes with collisions: {:?} (replay: sim-host run {}/collision-<i>.toml)", s.collision_scenes, dir.display());
                            println!("  of them, the arm trapped in both angles (no controller avoids the contact): {:?}", s.collision_scenes_unwinnable);
                            any = true;
                        }
                    }
                    Err(e) => {
                        eprintln!("sim-host: {e}");
                        return ExitCode::FAILURE;
                    }
                }
            }
            if any {
                ExitCode::FAILURE
            } else {
                ExitCode::SUCCESS
            }
        }
        Cmd::Bench {
            what,
            seconds,
            reps,
            out,
            quick,
            seed,
            top,
        } => {
            if top > 0 && what != "reflex" {
                eprintln!("sim-host: bench {what}: --top is for the reflex bench");
                return ExitCode::FAILURE;
            }
            match what.as_str() {
                "sim" => {
                    let r = sim_host::bench::sim(seconds, reps);
                    println!("{r}");
                    ExitCode::SUCCESS
                }
                "planner" => {
                    match sim_host::planner_bench::report(&default_images_dir()) {
                        Ok(r) => {
                            print!("{r}");
                            ExitCode::SUCCESS
                        }
                        Err(e) => {
                            eprintln!("sim-host: bench planner: {e} (build the images: cargo xtask images)");
                            ExitCode::FAILURE
                        }
                    }
                }
                "reflex" => {
                    match sim_host::reflex_bench::report(&sim_host::boot::default_images_dir(), top)
                    {
                        Ok(r) => {
                            print!("{r}");
                            ExitCode::SUCCESS
                        }
                        Err(e) => {
                            eprintln!("sim-host: bench reflex: {e} (build the images first: cargo xtask images)");
                            ExitCode::FAILURE
                        }
                    }
                }
                "cspace" => {
                    match sim_host::cspace_bench::report(&sim_host::boot::default_images_dir()) {
                        Ok(r) => {
                            print!("{r}");
                            ExitCode::SUCCESS
                        }
                        Err(e) => {
                            eprintln!("sim-host: bench cspace: {e} (build the images first: cargo xtask images)");
                            ExitCode::FAILURE
                        }
                    }
                }
                "sensing" => {
                    let out = out.unwrap_or_else(|| PathBuf::from("out/bench-sensing"));
                    let size = if quick {
                        sim_host::sensing_bench::Size::quick()
                    } else {
                        sim_host::sensing_bench::Size::full()
                    };
                    match sim_host::sensing_bench::report(&out, size, seed) {
                        Ok(r) => {
                            print!("{r}");
                            ExitCode::SUCCESS
                        }
                        Err(e) => {
                            eprintln!("sim-host: bench sensing: {e}");
                            ExitCode::FAILURE
                        }
                    }
                }
                "servo" => match sim_host::servo_bench::report(
                    &out.unwrap_or_else(|| PathBuf::from("out/bench-servo")),
                ) {
                    Ok(r) => {
                        print!("{r}");
                        ExitCode::SUCCESS
                    }
                    Err(e) => {
                        eprintln!("sim-host: bench servo: {e}");
                        ExitCode::FAILURE
                    }
                },
                other => {
                    eprintln!("sim-host: unknown benchmark {other:?} (sim, servo, cspace, sensing, reflex)");
                    ExitCode::from(2)
                }
            }
        }
        Cmd::Profile {
            board,
            images,
            ms,
            top,
            resting,
            addresses,
            servo_goal_urad,
            servo_subgoal_freeze_ms,
        } => {
            let Some(id) = parse_board(&board) else {
                eprintln!("sim-host: unknown board {board:?} ({BOARD_NAMES})");
                return ExitCode::from(2);
            };
            if resting && id != BoardId::Sensing {
                eprintln!("sim-host: --resting is for the sensing board");
                return ExitCode::from(2);
            }
            let &[g1, g2] = servo_goal_urad.as_slice() else {
                eprintln!("sim-host: --servo-goal-urad takes two angles, LINK1,LINK2");
                return ExitCode::from(2);
            };
            let goal = [g1, g2];
            if (goal != [0, 0] || servo_subgoal_freeze_ms.is_some()) && id != BoardId::Servo {
                eprintln!(
                    "sim-host: --servo-goal-urad and --servo-subgoal-freeze-ms are for the servo board"
                );
                return ExitCode::from(2);
            }
            if servo_subgoal_freeze_ms.is_some_and(|t| !(0.0..1e6).contains(&t)) {
                eprintln!("sim-host: --servo-subgoal-freeze-ms wants milliseconds, 0 or more");
                return ExitCode::from(2);
            }
            let servo = sim_host::boot::ServoFeed {
                goal_urad: goal,
                freeze_after_ms: servo_subgoal_freeze_ms,
            };
            let dir = images.unwrap_or_else(default_images_dir);
            match sim_host::boot::profile(&dir, id, ms, resting, servo) {
                Ok(p) => {
                    let per = p.cycles as f64 / p.loops.max(1) as f64;
                    println!(
                        "{board}: {} cycles, {} loops: {per:.0} cycles per loop = {:.0} loops/s at {:.1} MHz (timing: {})",
                        p.cycles,
                        p.loops,
                        CPU_HZ as f64 / per,
                        CPU_HZ as f64 / 1e6,
                        sim_host::emu::timing_name()
                    );
                    let per_beat = sim_host::boot::passes_per_beat(id);
                    if per_beat > 1 {
                        println!(
                            "(a sensing loop is a strobe frame of {per_beat} slots: {:.0} cycles a slot, budget {})",
                            per / per_beat as f64,
                            CPU_HZ / 4000
                        );
                    }
                    if let Some((busy, n)) = p.busy {
                        let (unit, units) = if per_beat > 1 {
                            ("slot", "slots")
                        } else {
                            ("pass", "passes")
                        };
                        println!(
                            "(busy {:.0} cycles a {unit} over {n} {units}; the rest of a {unit} waits for the timer)",
                            busy as f64 / n.max(1) as f64
                        );
                    }
                    println!("{:>10} {:>6} {:>12}  function", "cycles", "%", "per loop");
                    for (name, c) in p.functions.iter().take(top) {
                        println!(
                            "{c:>10} {:>6.1} {:>12.0}  {:#}",
                            100.0 * *c as f64 / p.cycles as f64,
                            *c as f64 / p.loops.max(1) as f64,
                            rustc_demangle::demangle(name)
                        );
                    }
                    if addresses > 0 {
                        println!(
                            "{:>10} {:>10} {:>10} {:>8}  function",
                            "address", "cycles", "per loop", "times"
                        );
                    }
                    for (a, c, n, f) in p.addresses.iter().take(addresses) {
                        println!(
                            "{a:>#10x} {c:>10} {:>10.1} {n:>8}  {f}",
                            *c as f64 / p.loops.max(1) as f64,
                        );
                    }
                    ExitCode::SUCCESS
                }
                Err(e) => {
                    eprintln!("sim-host: {e}");
                    ExitCode::FAILURE
                }
            }
        }
        Cmd::CspaceDb { write } => {
            let t = std::time::Instant::now();
            let fams = sim_host::cspace_db::build();
            for f in &fams {
                let n = |v: &Vec<cspace::db::ChainTable>| -> usize {
                    v.iter().map(|t| t.samples.len()).sum()
                };
                println!(
                    "disk {:5.1} mm: {} stripe widths, {} front and {} rear images, {} vertex growths",
                    f.disk_m * 1e3,
                    f.stripe.len(),
                    n(&f.front),
                    n(&f.rear),
                    f.grown
                );
            }
            let text = sim_host::cspace_db::render(&fams);
            let path = sim_host::cspace_db::TABLES_PATH;
            println!("built in {:.1} s", t.elapsed().as_secs_f64());
            if write {
                if let Err(e) = std::fs::write(path, &text) {
                    eprintln!("error: cannot write {path}: {e}");
                    return ExitCode::FAILURE;
                }
                println!("wrote {path} ({} bytes)", text.len());
            } else {
                match std::fs::read_to_string(path) {
                    Ok(old) if old == text => println!("{path} is up to date"),
                    Ok(_) => {
                        eprintln!(
                            "error: {path} differs from the generator's output; run with --write"
                        );
                        return ExitCode::FAILURE;
                    }
                    Err(e) => {
                        eprintln!("error: cannot read {path}: {e}");
                        return ExitCode::FAILURE;
                    }
                }
            }
            ExitCode::SUCCESS
        }
        Cmd::CspaceCheck { disks, seed } => {
            let t = std::time::Instant::now();
            let bar = indicatif::ProgressBar::new(disks);
            let s = sim_host::cspace_oracle::survey(seed, disks, &|k| bar.set_position(k));
            bar.finish_and_clear();
            let c = s.total;
            println!(
                "C-space map against the exact oracle: {} random disks (seed {seed}), {:.0} s",
                s.disks,
                t.elapsed().as_secs_f64()
            );
            println!("  pixels holding a collision (exact area): {}", c.exact);
            println!(
                "  false free (must be 0):                  {} in {} disks",
                c.false_free, s.disks_with_false_free
            );
            println!(
                "  false occupied:                          {} = {:.1}% of the exact area",
                c.false_occupied,
                100.0 * c.false_occupied as f64 / c.exact.max(1) as f64
            );
            println!(
                "  undecided at 1/64 pixel:                 {} = {:.2}% of the exact area",
                c.unknown,
                100.0 * c.unknown as f64 / c.exact.max(1) as f64
            );
            if let (r, Some(d)) = s.worst_ratio {
                println!(
                    "  worst single disk (image >= 100 px): {:.0}% false occupied, {d:?}",
                    100.0 * r
                );
            }
            if let Some(d) = s.first_false_free {
                eprintln!("error: false-free pixels, first for {d:?}");
                return ExitCode::FAILURE;
            }
            ExitCode::SUCCESS
        }
        Cmd::CspaceFigures { out } => match sim_host::cspace_oracle::figures(&out) {
            Ok(v) => {
                println!("{:<34} {:>12} {:>16}", "figure", "exact px", "margin px");
                for (f, e, m) in v {
                    println!(
                        "{f:<34} {e:>12} {m:>10} ({:>3.0}%)",
                        100.0 * m as f64 / e.max(1) as f64
                    );
                }
                ExitCode::SUCCESS
            }
            Err(e) => {
                eprintln!("error: {e}");
                ExitCode::FAILURE
            }
        },
        Cmd::Boot { board, images, ms } => {
            let boards: Vec<BoardId> = if board == "all" {
                FIVE.to_vec()
            } else {
                match parse_board(&board) {
                    Some(b) => vec![b],
                    None => {
                        eprintln!("sim-host: unknown board {board:?} ({BOARD_NAMES}, all)");
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

/// Warns of obstacles (and the wand) the sensing board read beyond the camera's calibrated
/// square.
fn print_extrapolated(s: &sim_host::run::Summary) {
    if s.wand_extrapolated_ms > 0 {
        println!(
            "warning: the wand was read beyond the camera's calibrated square for {} ms: the goal taken from it can be up to 139 mm short of where the wand is (docs/sensing.md)",
            s.wand_extrapolated_ms
        );
    }
    for (k, &ms) in s.obstacles_extrapolated_ms.iter().enumerate() {
        if ms > 0 {
            println!(
                "warning: obstacle {k} was read beyond the camera's calibrated square (0.7 m, centred on the shoulder) for {ms} ms: its sensed position can be up to 139 mm short there and the C-space map does not cover it conservatively (docs/sensing.md)"
            );
        }
    }
}

/// `sim-host campaign planner`.
fn planner_campaign(
    seed: u64,
    n: u64,
    threads: usize,
    pictures: usize,
    out: &std::path::Path,
) -> ExitCode {
    let bar = indicatif::ProgressBar::new(n);
    match sim_host::planner_campaign::run_to_dir(seed, n, threads, pictures, out, &|| bar.inc(1)) {
        Ok(s) => {
            bar.finish_and_clear();
            println!(
                "planner campaign: {} scenes (seed {seed}): {} solvable, reached {} ({:.1}%), reported unreachable {}, undecided {}; marginal {} (reached {}, reported {}, undecided {}); unsolvable {} (goal in obstacle {}, enclosed {}), reported {} (slowest after {:.2} s), reached anyway {}; collisions {} in {} scenes, min clearance {:.1} mm; time to goal median {:.2} s, oracle estimate median {:.2} s, median ratio {:.2}; wall following in {} scenes (time to goal median {:.2} s, estimate {:.2} s, median ratio {:.2}), approach changes in {}; {:.0} s wall -> {}",
                s.scenes,
                s.solvable,
                s.solvable_reached,
                100.0 * s.solvable_reached as f64 / s.solvable.max(1) as f64,
                s.solvable_reported_unreachable,
                s.solvable_undecided,
                s.marginal[0],
                s.marginal[1],
                s.marginal[2],
                s.marginal[3],
                s.unsolvable[0] + s.unsolvable[1],
                s.unsolvable[0],
                s.unsolvable[1],
                s.unsolvable_reported,
                s.report_time_max_s,
                s.unsolvable_reached,
                s.collisions,
                s.scenes_with_collisions,
                s.min_clearance_m * 1e3,
                s.time_to_goal_median_s,
                s.estimate_median_s,
                s.ratio_median,
                s.scenes_with_walls,
                s.walls_time_median_s,
                s.walls_estimate_median_s,
                s.walls_ratio_median,
                s.scenes_with_approach_changes,
                s.wall_s,
                out.display()
            );
            if !s.collision_scenes.is_empty() {
                println!("  scenes with collisions: {:?}", s.collision_scenes);
            }
            if !s.missed_scenes.is_empty() {
                println!(
                    "  solvable scenes missed: {:?} (replay: sim-host run {}/scene-<i>.toml)",
                    s.missed_scenes,
                    out.display()
                );
            }
            if !s.unreported_scenes.is_empty() {
                println!(
                    "  unsolvable scenes neither reported nor reached: {:?} (replay: sim-host run {}/scene-<i>.toml)",
                    s.unreported_scenes,
                    out.display()
                );
            }
            if s.scenes_with_collisions > 0
                || !s.missed_scenes.is_empty()
                || !s.unreported_scenes.is_empty()
            {
                ExitCode::FAILURE
            } else {
                ExitCode::SUCCESS
            }
        }
        Err(e) => {
            eprintln!("sim-host: {e}");
            ExitCode::FAILURE
        }
    }
}

/// Runs `sc` as `a` asks and writes its run directory (default `default_out`).
fn run_cmd(sc: &Scenario, a: RunArgs, default_out: &str) -> ExitCode {
    let RunArgs {
        mode,
        images,
        image_boards,
        gdb,
        long_passes,
        out,
        quiet,
        trace_every_us,
        monitor,
    } = a;
    let out = out.unwrap_or_else(|| PathBuf::from(default_out));
    let steps = trace_every_us * 1e-6 / sc.config.dt_s;
    if !(steps >= 1.0 && (steps - steps.round()).abs() < 1e-6) {
        eprintln!(
            "sim-host: --trace-every-us must be a multiple of the plant step ({} us)",
            sc.config.dt_s * 1e6
        );
        return ExitCode::from(2);
    }
    let gdb = match gdb.as_deref().map(sim_host::gdb::parse_spec).transpose() {
        Ok(g) => g,
        Err(e) => {
            eprintln!("sim-host: {e}");
            return ExitCode::from(2);
        }
    };
    if mode == Mode::Native
        && (images.is_some() || gdb.is_some() || !image_boards.is_empty() || long_passes.is_some())
    {
        eprintln!("sim-host: --images, --image-boards, --gdb and --long-passes need --mode image");
        return ExitCode::from(2);
    }
    let long_passes = match long_passes.as_deref().map(|b| (b, parse_board(b))) {
        None => None,
        Some((_, Some(id))) => Some(id),
        Some((b, None)) => {
            eprintln!("sim-host: --long-passes: no board {b} ({BOARD_NAMES})");
            return ExitCode::from(2);
        }
    };
    let mut which = Vec::new();
    for b in &image_boards {
        match parse_board(b) {
            Some(id) => which.push(id),
            None => {
                eprintln!("sim-host: --image-boards: no board {b} ({BOARD_NAMES})");
                return ExitCode::from(2);
            }
        }
    }
    let opts = RunOptions {
        trace_every: steps.round() as u64,
        quiet,
        images: (mode == Mode::Image).then(|| images.unwrap_or_else(default_images_dir)),
        image_boards: which,
        gdb,
        monitor,
        long_passes,
    };
    match run_to_dir(sc, &out, &opts) {
        Ok(s) => {
            println!(
                "{}: {:.3} s simulated in {:.3} s ({:.0}x real time); collisions {}; min clearance {}; goal {}",
                sc.name,
                s.duration_s,
                s.wall_s,
                s.real_time_factor,
                s.collisions,
                s.min_clearance_m.map_or("-".into(), |c| format!("{:.1} mm", c * 1e3)),
                s.goal_reached.map_or("-".into(), |g| if g { "reached".into() } else { format!("not reached ({:.1} mm off)", s.final_goal_error_m.unwrap_or(0.0) * 1e3) })
            );
            print_extrapolated(&s);
            if s.mode == "image" {
                println!("board      loop min/mean/max (us at 16.7 MHz)   rate Hz  budget us  share  stack B  state");
                for b in &s.boards {
                    println!(
                        "{:<10} {:>9.1} {:>9.1} {:>9.1}          {:>8.0} {:>10.0} {:>6.2} {:>8} {}",
                        b.board,
                        b.loop_min_us.unwrap_or(f64::NAN),
                        b.loop_mean_us.unwrap_or(f64::NAN),
                        b.loop_max_us.unwrap_or(f64::NAN),
                        b.rate_hz,
                        b.period_us,
                        b.budget_share.unwrap_or(f64::NAN),
                        b.stack_bytes.map_or("-".into(), |x| x.to_string()),
                        b.state
                    );
                }
                if let Some(b) = s.boards.iter().find(|b| b.board == BoardId::Reflex.name()) {
                    if let (Some(n), Some(over), Some(max)) =
                        (b.loop_periods, b.loop_over_1ms, b.loop_max_us)
                    {
                        println!(
                            "reflex passes: {n} timed, {over} over 1 ms ({:.1}%), the longest {max:.0} us",
                            100.0 * over as f64 / n.max(1) as f64
                        );
                    }
                }
                if let Some(l) = &s.long_passes {
                    println!(
                        "{} passes over {:.0} us: {} of {}; where they go (cycles and calls a long pass):",
                        l.board, l.over_us, l.passes, l.periods
                    );
                    for (name, cycles, calls) in &l.functions {
                        println!("  {cycles:>9.0} {calls:>7.1}  {name}");
                    }
                    println!("  the longest ({:.0} us):", l.longest_us);
                    for (name, cycles, calls) in &l.longest_functions {
                        println!("  {cycles:>9.0} {calls:>7.0}  {name}");
                    }
                }
                if let Some(p) = &s.servo_busy {
                    println!(
                        "servo passes: {} metered, busy {:.0} cycles mean, {} max; {} over 5,566 (3 kHz)",
                        p.passes, p.mean_cycles, p.max_cycles, p.over_3khz
                    );
                }
            }
            println!(
                "wrote trace.csv, summary.json, joints.png, task.png, cspace.png and report.html to {}",
                out.display()
            );
            println!("open {} in a browser", out.join("report.html").display());
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("sim-host: {e}");
            ExitCode::FAILURE
        }
    }
}

/// `campaign faults`: every scenario of `sim-host/scenarios/faults/`; exits 1 on a collision
/// or a stop beyond the published arrest distance.
fn fault_campaign(images: Option<&Path>, threads: usize, out: &Path) -> ExitCode {
    let s = match sim_host::fault_campaign::run(
        &sim_host::fault_campaign::default_dir(),
        images,
        threads,
    ) {
        Ok(s) => s,
        Err(e) => {
            eprintln!("sim-host: {e}");
            return ExitCode::FAILURE;
        }
    };
    print!("{}", sim_host::fault_campaign::table(&s));
    println!(
        "{} fault scenarios ({}): {} with collisions, {} stopped beyond the published arrest distance",
        s.scenarios, s.mode, s.with_collisions, s.beyond_arrest
    );
    if let Err(e) = sim_host::campaign::write_summary(out, &s) {
        eprintln!("sim-host: {e}");
        return ExitCode::FAILURE;
    }
    println!("wrote {}", out.join("summary.json").display());
    if s.with_collisions + s.beyond_arrest > 0 {
        ExitCode::FAILURE
    } else {
        ExitCode::SUCCESS
    }
}

/// `campaign demo`: the demo scenario with seeds 1..=n; exits 1 on a collision.
fn demo_campaign(n: u64, images: Option<&Path>, threads: usize, out: &Path) -> ExitCode {
    let s = match sim_host::demo_campaign::run(n, images, threads) {
        Ok(s) => s,
        Err(e) => {
            eprintln!("sim-host: {e}");
            return ExitCode::FAILURE;
        }
    };
    for r in s.results.iter().filter(|r| !r.reached || r.collisions > 0) {
        println!("seed {}: {} ({} collisions)", r.seed, r.why, r.collisions);
    }
    println!(
        "demo, {} seeds ({}): goal reached in {}, not reached in {} (each with its reason above), {} with collisions; min clearance {:.1} mm",
        s.seeds, s.mode, s.reached, s.seeds - s.reached, s.with_collisions, s.min_clearance_m * 1e3
    );
    if let Err(e) = sim_host::campaign::write_summary(out, &s) {
        eprintln!("sim-host: {e}");
        return ExitCode::FAILURE;
    }
    println!("wrote {}", out.join("summary.json").display());
    if s.with_collisions > 0 {
        ExitCode::FAILURE
    } else {
        ExitCode::SUCCESS
    }
}
