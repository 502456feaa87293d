//! The miscompile checks: refuse images in which LLVM's M68k backend
//!
//! 1. placed a register move between an instruction that sets the condition codes and the
//!    branch that reads them (llvm/llvm-project#152816, #213564), or
//! 2. made an extend-flag reader (`ADDX`, `SUBX`, `NEGX`, `ROXL`, `ROXR`) consume the borrow
//!    of a `CMP` or `TST`, which set C but leave X untouched on the 68k: the reader gets a
//!    stale X from older code, or
//! 3. emitted a 32-bit `DIVS.L`/`DIVU.L` whose remainder register differs from its quotient
//!    register: the backend encodes the remainder field as %d0 whatever it allocated
//!    (llvm/llvm-project#224186), so the divide silently overwrites %d0, or
//! 4. gave a stack frame over 32 KiB a `LINK.W` whose 16-bit displacement wrapped to a
//!    positive one, so the function's locals lie over its caller's frame.
//!
//! See docs/toolchain.md.
//!
//! On the 68k, `MOVE`, `MOVEQ` and `CLR` set N and Z and clear V and C, but LLVM models its
//! register copies as leaving the flags alone. The backend never means to branch on a move's
//! flags (it emits `TST`/`CMP` for that), so a conditional branch or `Scc` whose nearest
//! flag-setting predecessor in straight-line code is a move is a miscompile.

/// One miscompiled site.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Hit {
    /// Function (symbol) containing it.
    pub function: String,
    /// Address of the branch.
    pub branch_addr: u32,
    /// The branch, as disassembled.
    pub branch: String,
    /// The move that clobbers the flags, as disassembled.
    pub clobber: String,
}

/// Functions only reachable through `core::fmt` formatting, which the firmware never does
/// (the panic handler logs without formatting). They are linked because core's panic paths
/// refer to them. Hits inside them are reported but do not fail the build.
pub const NEVER_EXECUTED: [&str; 2] = ["4core3fmt", "4core3str5count"];

fn stem(mn: &str) -> &str {
    mn.split('.').next().unwrap_or(mn)
}

/// Whether a mnemonic is a conditional branch or set-on-condition (reads the flags).
fn reads_ccr(mn: &str) -> bool {
    const CC: [&str; 14] = [
        "eq", "ne", "cs", "cc", "ls", "hi", "lt", "ge", "gt", "le", "mi", "pl", "vs", "vc",
    ];
    let m = stem(mn);
    for p in ["b", "s"] {
        if let Some(rest) = m.strip_prefix(p) {
            for c in CC {
                if let Some(sz) = rest.strip_prefix(c) {
                    if ["", "s", "b", "w", "l"].contains(&sz) {
                        return true;
                    }
                }
            }
        }
    }
    false
}

/// How an instruction affects the flags.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Ccr {
    /// Leaves them alone.
    Keeps,
    /// A move-class instruction: the clobber LLVM does not expect.
    Move,
    /// An operation whose flags the branch may mean to read.
    Op,
    /// Ends straight-line code (branch, jump, call, return).
    Flow,
}

/// Whether an instruction's destination (its last operand) is an address register.
fn to_areg(ops: &str) -> bool {
    ops.trim_end().rsplit(',').next().is_some_and(|d| {
        let d = d.trim();
        d.starts_with("%a") || d == "%sp" || d == "%fp"
    })
}

/// Whether an instruction ends straight-line code (branch, jump, call, return, loop).
fn ends_run(m: &str) -> bool {
    ["bra", "bsr", "jmp", "jsr", "rt", "db"]
        .iter()
        .any(|p| m.starts_with(p))
}

fn classify(mn: &str, ops: &str) -> Ccr {
    let m = stem(mn);
    if m.starts_with("movea")
        || m.starts_with("movem")
        || m.starts_with("adda")
        || m.starts_with("suba")
    {
        return Ccr::Keeps;
    }
    if ["lea", "pea", "link", "linkw", "unlk", "exg", "nop", "trap"].contains(&m) {
        return Ccr::Keeps;
    }
    if ends_run(m) {
        return Ccr::Flow;
    }
    if (m.starts_with("addq") || m.starts_with("subq")) && to_areg(ops) {
        return Ccr::Keeps;
    }
    if m.starts_with("move")
        && (ops.contains("%sr") || ops.contains("%ccr") || ops.contains("%usp"))
    {
        return Ccr::Keeps;
    }
    if m.starts_with("move") && to_areg(ops) {
        return Ccr::Keeps; // objdump may print movea as movel to an address register
    }
    if m.starts_with("move") || m.starts_with("clr") {
        return Ccr::Move;
    }
    if reads_ccr(mn) && m.starts_with('s') {
        return Ccr::Keeps; // Scc reads but does not set
    }
    const OPS: [&str; 26] = [
        "add", "sub", "cmp", "tst", "and", "or", "eor", "not", "neg", "ext", "swap", "lsl", "lsr",
        "asl", "asr", "rol", "ror", "roxl", "roxr", "mul", "div", "btst", "bset", "bclr", "bchg",
        "tas",
    ];
    if OPS.iter().any(|o| m.starts_with(o))
        || m.starts_with("cas")
        || m.starts_with("chk")
        || m.starts_with("bf")
    {
        return Ccr::Op;
    }
    Ccr::Keeps
}

/// Whether a mnemonic reads the X (extend) flag.
fn reads_x(mn: &str) -> bool {
    let m = stem(mn);
    ["addx", "subx", "negx", "roxl", "roxr"]
        .iter()
        .any(|p| m.starts_with(p))
}

/// How an instruction affects the X flag, seen from an X reader looking back.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum XEffect {
    /// Sets X (and C): a proper carry source.
    Sets,
    /// Sets C but not X: a compare or test whose borrow an X reader cannot see.
    CarryOnly,
    /// Leaves X alone.
    Keeps,
    /// Ends straight-line code.
    Flow,
}

fn x_effect(mn: &str, ops: &str) -> XEffect {
    let m = stem(mn);
    if ends_run(m) {
        return XEffect::Flow;
    }
    if m.starts_with("adda")
        || m.starts_with("suba")
        || ((m.starts_with("addq") || m.starts_with("subq")) && to_areg(ops))
    {
        return XEffect::Keeps;
    }
    const SETS: [&str; 11] = [
        "add", "sub", "neg", "asl", "asr", "lsl", "lsr", "roxl", "roxr", "abcd", "sbcd",
    ];
    if SETS.iter().any(|p| m.starts_with(p)) {
        return XEffect::Sets;
    }
    if m.starts_with("cmp") || m.starts_with("tst") {
        return XEffect::CarryOnly;
    }
    XEffect::Keeps
}

/// Scans `objdump -d --no-show-raw-insn` output.
pub fn scan(disassembly: &str) -> Vec<Hit> {
    let mut hits = Vec::new();
    let mut function = String::new();
    let mut run: Vec<(String, String)> = Vec::new();
    for line in disassembly.lines() {
        if let Some(name) = line
            .strip_suffix(">:")
            .and_then(|l| l.split_once(" <"))
            .map(|(_, n)| n)
        {
            function = name.to_string();
            run.clear();
            continue;
        }
        let Some((addr, rest)) = line.trim_start().split_once(":\t") else {
            if line.trim().is_empty() {
                run.clear();
            }
            continue;
        };
        let Ok(addr) = u32::from_str_radix(addr.trim(), 16) else {
            continue;
        };
        let rest = rest.trim();
        let (mn, ops) = rest.split_once(char::is_whitespace).unwrap_or((rest, ""));
        if reads_x(mn) {
            for (pm, po) in run.iter().rev() {
                match x_effect(pm, po) {
                    XEffect::CarryOnly => {
                        hits.push(Hit {
                            function: function.clone(),
                            branch_addr: addr,
                            branch: rest.to_string(),
                            clobber: format!("{pm} {po} (sets C, not X)"),
                        });
                        break;
                    }
                    XEffect::Sets | XEffect::Flow => break,
                    XEffect::Keeps => {}
                }
            }
        }
        // A frame over 32 KiB: the backend emits LINK.W with the displacement wrapped to
        // 16 bits, positive, so the locals overlap the caller's stack (found when the
        // C-space board's job memory grew past 32 KiB: the image never beat).
        if mn == "linkw" {
            if let Some(d) = ops
                .split_once(",#")
                .and_then(|(_, d)| d.trim().parse::<i32>().ok())
            {
                if d > 0 {
                    hits.push(Hit {
                        function: function.clone(),
                        branch_addr: addr,
                        branch: rest.to_string(),
                        clobber: format!(
                            "a stack frame of {} bytes wrapped to LINK.W #{d} (keep large data off the stack)",
                            65536 - d
                        ),
                    });
                }
            }
        }
        if ["divsll", "divull"].contains(&mn) {
            let regs: Vec<&str> = ops.split(',').map(str::trim).collect();
            if regs.len() == 3 && regs[1] != regs[2] {
                hits.push(Hit {
                    function: function.clone(),
                    branch_addr: addr,
                    branch: rest.to_string(),
                    clobber: format!(
                        "remainder written to {} (llvm/llvm-project#224186)",
                        regs[1]
                    ),
                });
            }
        }
        if reads_ccr(mn) {
            for (pm, po) in run.iter().rev() {
                match classify(pm, po) {
                    Ccr::Move => {
                        hits.push(Hit {
                            function: function.clone(),
                            branch_addr: addr,
                            branch: rest.to_string(),
                            clobber: format!("{pm} {po}"),
                        });
                        break;
                    }
                    Ccr::Op | Ccr::Flow => break,
                    Ccr::Keeps => {}
                }
            }
        }
        if classify(mn, ops) == Ccr::Flow && !reads_ccr(mn) {
            run.clear();
        } else {
            run.push((mn.to_string(), ops.to_string()));
        }
    }
    hits
}

/// Whether a hit lies in code the firmware never executes ([`NEVER_EXECUTED`]).
pub fn tolerated(hit: &Hit) -> bool {
    NEVER_EXECUTED.iter().any(|n| hit.function.contains(n))
}

#[cfg(test)]
mod tests {
    use super::*;

    const BAD: &str = "00000ed6 <memcpy>:\n     ed4:\tsubl %d1,%d4\n     ed6:\tmovel %d3,%d4\n     ed8:\tblss ec2 <memcpy+0x3c>\n";

    #[test]
    fn a_move_between_compare_and_branch_is_found() {
        let h = scan(BAD);
        assert_eq!(h.len(), 1);
        assert_eq!(h[0].function, "memcpy");
        assert_eq!(h[0].branch_addr, 0xed8);
        assert!(h[0].clobber.starts_with("movel"));
        assert!(!tolerated(&h[0]));
    }

    #[test]
    fn flag_neutral_instructions_between_are_fine() {
        let ok = "00000100 <f>:\n 100:\tcmpil #0,%d7\n 106:\tmoveal %d1,%a5\n 108:\tmoveml %fp@(-4),%d2\n 10c:\tlea %fp@(-2),%a0\n 110:\tbeqs 120 <f+0x20>\n";
        assert!(scan(ok).is_empty());
        let addq = "00000100 <f>:\n 100:\tsubl #1,%d0\n 102:\taddql #4,%a0\n 104:\tbnes 100 <f>\n";
        assert!(scan(addq).is_empty());
        let tst = "00000100 <f>:\n 100:\tmovel %d1,%d0\n 102:\ttstl %d0\n 104:\tbnes 100 <f>\n";
        assert!(scan(tst).is_empty());
    }

    #[test]
    fn straight_line_code_ends_at_calls_and_labels() {
        let call = "00000100 <f>:\n 100:\tmovel %d1,%d0\n 102:\tjsr 200 <g>\n 108:\tbeqs 100 <f>\n";
        assert!(scan(call).is_empty());
        let scc = "00000100 <f>:\n 100:\tcmpl %d1,%d0\n 102:\tmoveq #0,%d2\n 104:\tseq %d3\n";
        assert_eq!(scan(scc).len(), 1, "Scc reads the flags too");
    }

    #[test]
    fn a_wrapped_stack_frame_is_found() {
        let bad = "00001eba <main>:\n    1eba:\tlinkw %fp,#32256\n";
        let ok = "00001eba <main>:\n    1eba:\tlinkw %fp,#-312\n";
        assert_eq!(scan(bad).len(), 1);
        assert!(scan(bad)[0].clobber.contains("33280 bytes"));
        assert!(scan(ok).is_empty());
    }

    #[test]
    fn a_divide_that_clobbers_d0_is_found() {
        let bad = "000027d2 <f>:\n 27d2:\tdivsll %d0,%d0,%d3\n";
        let h = scan(bad);
        assert_eq!(h.len(), 1);
        assert!(h[0].clobber.contains("%d0"));
        let ok = "00000100 <f>:\n 100:\tdivsll %d1,%d3,%d3\n 104:\tdivsl %d3,%d1,%d0\n";
        assert!(
            scan(ok).is_empty(),
            "quotient-only and 64-bit forms are fine"
        );
    }

    #[test]
    fn an_extend_reader_after_a_compare_is_found() {
        // From the servo image: cmpi sets C (not X), subx reads a stale X.
        let bad = "000016f0 <g>:\n 1708:\tcmpib #1,%d1\n 170c:\tsubxb %d1,%d1\n";
        let h = scan(bad);
        assert_eq!(h.len(), 1);
        assert!(h[0].clobber.contains("sets C, not X"));
        // 64-bit add: add then addx, with moves between: fine.
        let ok = "00000100 <f>:\n 100:\taddl %d3,%d0\n 102:\tmoveq #0,%d3\n 104:\taddxl %d3,%d1\n";
        assert!(scan(ok).is_empty());
        // A 64-bit subtract-compare (sub then subx) is fine too.
        let ok2 = "00000100 <f>:\n 100:\tsubl %d2,%d0\n 102:\tsubxl %d3,%d1\n";
        assert!(scan(ok2).is_empty());
    }

    #[test]
    fn hits_in_formatting_code_are_tolerated() {
        let fmt = BAD.replace("<memcpy>", "<_RNvNtCshnA4rcpSRlJ_4core3fmt5write>");
        let h = scan(&fmt);
        assert_eq!(h.len(), 1);
        assert!(tolerated(&h[0]));
    }
}
