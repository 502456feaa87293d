//! Every class of CPU exception the runtime handles is recorded in the board's slot, with
//! vector, PC and SR, and the board safe-stops. The faulting instruction is planted at the
//! running board's PC, as a corrupted image or a stray jump would put it there.

use sim_host::boot::System;
use sim_host::emu::RunState;
use system_tests::images_dir;
use vme_map::{BoardId, BoardState, FaultCode};

fn planted(words: &[u16]) -> (System, u32) {
    let mut sys = System::power_up(&images_dir(), &[BoardId::Planner]).unwrap();
    // Running: past the runtime's start-up (the planner copies 14 KiB of state first, under
    // 3 ms: `sim-host boot planner`).
    sys.run_ms(4.0);
    assert!(sys.heartbeat(BoardId::Planner) > 0, "the planner runs");
    let b = &mut sys.boards[0];
    let pc = b.cpu.pc;
    for (i, w) in words.iter().enumerate() {
        let a = pc as usize + 2 * i;
        b.ram[a..a + 2].copy_from_slice(&w.to_be_bytes());
    }
    (sys, pc)
}

fn expect(sys: &mut System, code: FaultCode, vector: u32, pc: Option<u32>) {
    sys.run_ms(1.0);
    let st = sys.status(BoardId::Planner);
    assert_eq!(st.state(), Some(BoardState::SafeStop));
    assert_eq!(st.fault(), Some(code));
    let rec = sys.fault(BoardId::Planner).unwrap();
    assert_eq!(rec.vector, vector);
    if let Some(pc) = pc {
        assert_eq!(rec.pc, pc);
    }
    assert_eq!(
        rec.sr & 0x2700,
        0x2700,
        "supervisor, interrupts masked: SR {:#x}",
        rec.sr
    );
    assert_eq!(sys.boards[0].state, RunState::Halted);
}

#[test]
fn illegal_instruction() {
    let (mut sys, pc) = planted(&[0x4AFC]); // ILLEGAL
    expect(&mut sys, FaultCode::IllegalInstruction, 4, Some(pc));
}

#[test]
fn line_f_is_an_illegal_instruction_too() {
    let (mut sys, pc) = planted(&[0xF200, 0x0000]); // a 68881 instruction: no FPU fitted
    expect(&mut sys, FaultCode::IllegalInstruction, 11, Some(pc));
}

#[test]
fn zero_divide() {
    let (mut sys, _) = planted(&[0x80FC, 0x0000]); // DIVU.W #0,D0
    expect(&mut sys, FaultCode::ZeroDivide, 5, None);
}

#[test]
fn address_error_on_an_odd_jump() {
    let (mut sys, _) = planted(&[0x4EF9, 0x0000, 0x0401]); // JMP $401
    expect(&mut sys, FaultCode::AddressError, 3, None);
}

#[test]
fn a_non_maskable_interrupt_with_no_handler_is_unexpected() {
    let mut sys = System::power_up(&images_dir(), &[BoardId::Planner]).unwrap();
    sys.run_ms(4.0);
    sys.boards[0].cpu.set_irq(7);
    sys.run_ms(0.2);
    sys.boards[0].cpu.set_irq(0);
    expect(&mut sys, FaultCode::UnexpectedException, 31, None);
}
