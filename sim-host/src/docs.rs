//! Generated parts of `docs/memory-map.md` and `docs/registers.md`: the tables come from
//! `vme-map` and `regs`, so the documents cannot drift from the code. A system test
//! compares them; `cargo xtask docs` rewrites them.

use std::fmt::Write;
use vme_map::layout::{BoardSlot, Writer, LAYOUT};
use vme_map::record::{Record, SeqLock};
use vme_map::records::{
    cal, HostCommand, ObjectTable, PlannerGoal, RawTable, ReflexStatus, ReflexSubgoal,
    SensingConfig, SensingDrift, ServoState, WorkEntry,
};
use vme_map::{BoardId, FaultRecord, GLOBAL_RAM_BASE};

/// Marker that starts a generated block.
pub const BEGIN: &str = "<!-- generated: begin -->";
/// Marker that ends a generated block.
pub const END: &str = "<!-- generated: end -->";

fn writer(w: Writer) -> String {
    match w {
        Writer::Host => "host".into(),
        Writer::Board(b) => b.name().into(),
        Writer::EachBoard => "each board its own".into(),
        Writer::CspaceBoards => "C-space boards (CAS claim)".into(),
    }
}

fn fields<R: Record>(out: &mut String, name: &str, at: SeqLock<R>) {
    let base = at.offset();
    writeln!(
        out,
        "\n#### `{name}` at `{:#06x}` ({} bytes)\n",
        base,
        SeqLock::<R>::SIZE
    )
    .unwrap();
    writeln!(out, "| offset | word |\n|---|---|").unwrap();
    writeln!(out, "| `{base:#06x}` | sequence (odd while writing) |").unwrap();
    for (i, f) in R::FIELDS.iter().enumerate() {
        writeln!(out, "| `{:#06x}` | `{f}` |", base + 4 + 4 * i as u32).unwrap();
    }
}

/// The generated block of `docs/memory-map.md`.
pub fn memory_map() -> String {
    let mut o = String::new();
    writeln!(
        o,
        "Offsets are from global RAM at `{GLOBAL_RAM_BASE:#010x}`.\n"
    )
    .unwrap();
    writeln!(
        o,
        "| region | offset | bytes | writer | sequence lock |\n|---|---|---|---|---|"
    )
    .unwrap();
    for r in LAYOUT {
        let seq = if r.seqlock { "yes" } else { "no" };
        writeln!(
            o,
            "| `{}` | `{:#07x}` | {} | {} | {} |",
            r.name,
            r.offset,
            r.size,
            writer(r.writer),
            seq
        )
        .unwrap();
    }
    writeln!(o, "\n#### Board slots\n\n| board | heartbeat | status word | fault record |\n|---|---|---|---|").unwrap();
    for b in BoardId::ALL {
        let s = BoardSlot::of(b);
        writeln!(
            o,
            "| {} | `{:#06x}` | `{:#06x}` | `{:#06x}` |",
            b.name(),
            s.heartbeat(),
            s.status(),
            s.fault().offset()
        )
        .unwrap();
    }
    fields::<FaultRecord>(
        &mut o,
        "fault record (in each board slot)",
        BoardSlot::of(BoardId::Sensing).fault(),
    );
    fields::<ObjectTable>(&mut o, "objects", vme_map::OBJECTS);
    fields::<ServoState>(&mut o, "servo_state", vme_map::SERVO_STATE);
    fields::<ReflexSubgoal>(&mut o, "reflex_subgoal", vme_map::REFLEX_SUBGOAL);
    fields::<PlannerGoal>(&mut o, "planner_goal", vme_map::PLANNER_GOAL);
    fields::<HostCommand>(&mut o, "host_command", vme_map::HOST_COMMAND);
    fields::<SensingConfig>(&mut o, "sensing_config", vme_map::SENSING_CONFIG);
    fields::<SensingDrift>(&mut o, "sensing_drift", vme_map::SENSING_DRIFT);
    fields::<RawTable>(&mut o, "sensing_raw", vme_map::SENSING_RAW);
    fields::<ReflexStatus>(&mut o, "reflex_status", vme_map::REFLEX_STATUS);
    writeln!(
        o,
        "\n#### `work_list` entry {} bytes, {} entries from `{:#06x}`\n",
        vme_map::WORK_ENTRY_BYTES,
        vme_map::records::WORK_ENTRIES,
        vme_map::WORK_LIST
    )
    .unwrap();
    writeln!(o, "| word | field |\n|---|---|").unwrap();
    for (i, f) in WorkEntry::FIELDS.iter().enumerate() {
        writeln!(o, "| {i} | `{f}` |").unwrap();
    }
    writeln!(
        o,
        "\n#### `sensing_cal`: {} words (format `vme_map::records::cal`, docs/sensing.md)\n",
        cal::WORDS
    )
    .unwrap();
    writeln!(o, "| words | content |\n|---|---|").unwrap();
    writeln!(o, "| 0..{} | header |", cal::HEADER).unwrap();
    writeln!(
        o,
        "| {}..{} | forward grid, {} x {} (x_q5, y_q5) |",
        cal::FWD,
        cal::INV,
        cal::FWD_N,
        cal::FWD_N
    )
    .unwrap();
    writeln!(
        o,
        "| {}..{} | inverse grid, {} x {} (x_um, y_um) |",
        cal::INV,
        cal::WORDS,
        cal::INV_N,
        cal::INV_N
    )
    .unwrap();
    o
}

/// The generated block of `docs/registers.md`.
pub fn registers() -> String {
    let mut o = String::new();
    for (board, table) in [
        ("servo", &regs::servo::REGISTERS[..]),
        ("sensing", &regs::sensing::REGISTERS[..]),
    ] {
        writeln!(
            o,
            "\n#### {board} board\n\n| register | address | access |\n|---|---|---|"
        )
        .unwrap();
        for r in table {
            writeln!(
                o,
                "| `{}` | `{:#010x}` | {:?} |",
                r.name,
                regs::PRIVATE_IO_BASE + r.offset,
                r.access
            )
            .unwrap();
        }
    }
    o
}

/// Replaces the generated block of a document's text, or `None` if it has no markers.
pub fn splice(doc: &str, block: &str) -> Option<String> {
    let a = doc.find(BEGIN)? + BEGIN.len();
    let b = doc.find(END)?;
    (a <= b).then(|| format!("{}\n{}{}", &doc[..a], block, &doc[b..]))
}
