//! The five real images boot on emulated 68020s, publish heartbeats, and record faults.

use sim_host::boot::{System, FIVE};
use sim_host::emu::RunState;
use sim_host::image::Image;
use system_tests::images_dir;
use vme_map::records::host_cmd;
use vme_map::{BoardId, BoardState, FaultCode};

#[test]
fn all_five_images_boot_and_their_heartbeats_advance() {
    let mut sys = System::power_up(&images_dir(), &FIVE).unwrap();
    // The sensing board's runtime copies 9 KiB of initial filter state first (3.2 ms).
    sys.run_ms(5.0);
    let first: Vec<u32> = FIVE.iter().map(|&b| sys.heartbeat(b)).collect();
    sys.run_ms(2.0);
    for (i, &b) in FIVE.iter().enumerate() {
        let hb = sys.heartbeat(b);
        assert!(first[i] > 0, "{} never beat", b.name());
        assert!(hb > first[i], "{} heartbeat stuck at {hb}", b.name());
        let st = sys.status(b);
        assert_eq!(st.state(), Some(BoardState::Running), "{}", b.name());
        assert_eq!(st.fault(), Some(FaultCode::None), "{}", b.name());
        assert_eq!(st.faults(), 0);
    }
}

#[test]
fn a_bus_error_is_recorded_in_the_status_record_and_the_board_halts() {
    let mut sys = System::power_up(&images_dir(), &FIVE).unwrap();
    // A board takes host commands posted after its boot (it starts from the serial it
    // finds): wait for its first heartbeat.
    run_until_beating(&mut sys, BoardId::Reflex);
    sys.host_command(host_cmd::INJECT_BUS_ERROR, BoardId::Reflex);
    // The reflex acts on host commands once per main-loop pass, and with the servo
    // publishing its pass runs the whole window (2-3 ms on the 68020, `sim-host bench
    // reflex`).
    sys.run_ms(5.0);
    let st = sys.status(BoardId::Reflex);
    assert_eq!(st.state(), Some(BoardState::SafeStop));
    assert_eq!(st.fault(), Some(FaultCode::BusError));
    let rec = sys.fault(BoardId::Reflex).expect("fault record");
    assert_eq!(rec.vector, 2, "bus error vector");
    assert_eq!(
        rec.fault_addr,
        regs::PRIVATE_IO_BASE + regs::UNDECODED_PROBE
    );
    assert_eq!(rec.detail, 0xB, "68020 long bus-cycle fault frame");
    assert_eq!(rec.sr & 0x2000, 0x2000, "supervisor mode when it faulted");
    assert!(
        rec.pc > 0x400 && rec.pc < 0x8_0000,
        "PC {:#x} inside the image's code",
        rec.pc
    );
    // The CPU stopped; its heartbeat is frozen; the other boards carry on.
    assert_eq!(sys.board(BoardId::Reflex).unwrap().state, RunState::Halted);
    let frozen = sys.heartbeat(BoardId::Reflex);
    let servo = sys.heartbeat(BoardId::Servo);
    sys.run_ms(1.0);
    assert_eq!(sys.heartbeat(BoardId::Reflex), frozen);
    assert!(sys.heartbeat(BoardId::Servo) > servo);
    assert_eq!(
        sys.status(BoardId::Servo).state(),
        Some(BoardState::Running)
    );
}

#[test]
fn a_panic_writes_its_message_to_the_log_ring_and_safe_stops() {
    let mut sys = System::power_up(&images_dir(), &FIVE).unwrap();
    run_until_beating(&mut sys, BoardId::Servo);
    sys.host_command(host_cmd::INJECT_PANIC, BoardId::Servo);
    sys.run_ms(3.0);
    let st = sys.status(BoardId::Servo);
    assert_eq!(st.state(), Some(BoardState::SafeStop));
    assert_eq!(st.fault(), Some(FaultCode::Panic));
    let log = sys.log_text(BoardId::Servo);
    assert!(
        log.starts_with("panic: host-injected panic at "),
        "log: {log:?}"
    );
    assert!(
        log.contains("boards/shell/src/lib.rs"),
        "log names the panic site: {log:?}"
    );
    assert_eq!(sys.board(BoardId::Servo).unwrap().state, RunState::Halted);
}

#[test]
fn three_cspace_boards_run_one_image_and_tell_themselves_apart() {
    let boards = [BoardId::Cspace0, BoardId::Cspace1, BoardId::Cspace2];
    let mut sys = System::power_up(&images_dir(), &boards).unwrap();
    sys.run_ms(2.0);
    for b in boards {
        assert!(sys.heartbeat(b) > 0, "{} has no heartbeat", b.name());
        assert_eq!(sys.status(b).state(), Some(BoardState::Running));
    }
}

#[test]
fn a_board_waits_for_the_global_ram_header_and_says_why() {
    let mut sys = System::power_up(&images_dir(), &[BoardId::Planner]).unwrap();
    // The host has not initialised global RAM (as if the header were lost).
    sys.global[..16].fill(0);
    // Reset the board against the empty header.
    let img = Image::load(&images_dir().join("planner.elf")).unwrap();
    let io = sim_host::devices::standalone(BoardId::Planner);
    sys.boards[0] = sim_host::emu::EmuBoard::new(BoardId::Planner, &img, io, &mut sys.global);
    // Until the board has said something (its start-up copies 13 KiB of initial state: about
    // 2 ms), and then a while longer: it must keep waiting.
    let mut ms = 0.0;
    while sys.status(BoardId::Planner).state() == Some(BoardState::Off) && ms < 10.0 {
        sys.run_ms(0.1);
        ms += 0.1;
    }
    sys.run_ms(2.0);
    assert_eq!(sys.heartbeat(BoardId::Planner), 0);
    let st = sys.status(BoardId::Planner);
    assert_eq!(st.state(), Some(BoardState::Degraded));
    assert_eq!(st.fault(), Some(FaultCode::LayoutMismatch));
    // Once the host writes the header, the board runs.
    vme_map::init_header(&mut sys.bus());
    sys.run_ms(1.0);
    assert!(sys.heartbeat(BoardId::Planner) > 0);
    assert_eq!(
        sys.status(BoardId::Planner).state(),
        Some(BoardState::Running)
    );
}

/// Runs the system until `board` has beaten (within 20 ms).
fn run_until_beating(sys: &mut System, board: BoardId) {
    for _ in 0..200 {
        if sys.heartbeat(board) != 0 {
            return;
        }
        sys.run_ms(0.1);
    }
    panic!("{} never beat", board.name());
}
