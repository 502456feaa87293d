//! Debugging one emulated board with GDB (design.md section 7, image mode): a server of the
//! GDB remote serial protocol for one board of an image-mode simulation.
//!
//! `sim-host run <scenario> --mode image --gdb <board>:<port>` listens on `127.0.0.1:<port>`
//! and waits for `gdb-multiarch <board>.elf -ex 'target remote :<port>'`. The simulation is
//! stopped before the board's first instruction; while the board is stopped the whole world
//! (plant, devices, other boards) waits. `continue` runs the simulation until the board
//! reaches a breakpoint (or GDB sends an interrupt), `stepi` executes one instruction of the
//! board alone (its clock moves ahead; the world catches up when it runs again).
//!
//! Supported: registers (`g`, `G`, `p`, `P`: d0-d7, a0-a7, sr, pc as GDB's
//! `org.gnu.gdb.m68k.core` feature, sent as `target.xml`), memory (`m`, `M`: local RAM and
//! global RAM; the private I/O registers are refused with an error, since reading them has
//! side effects on the devices), breakpoints (`Z0`/`Z1`, `z0`/`z1`, kept by the emulator, the
//! image is not patched), `c`, `s`, `?`, interrupt (0x03), `D` and `k` (both detach: the
//! simulation runs on to its end). When the run ends with GDB attached, GDB is told the
//! program exited (`W00`).

use crate::emu::{Device, EmuBoard, RunState};
use crate::image::LOCAL_RAM_SIZE;
use std::io::{self, Read, Write};
use std::net::{TcpListener, TcpStream};
use vme_map::{BoardId, GLOBAL_RAM_BASE, GLOBAL_RAM_SIZE};

/// The register set GDB is told the board has: the 68020's integer registers without a
/// 68881 (the boards have none).
const TARGET_XML: &str = r#"<?xml version="1.0"?>
<!DOCTYPE target SYSTEM "gdb-target.dtd">
<target version="1.0">
  <architecture>m68k:68020</architecture>
  <feature name="org.gnu.gdb.m68k.core">
    <reg name="d0" bitsize="32"/>
    <reg name="d1" bitsize="32"/>
    <reg name="d2" bitsize="32"/>
    <reg name="d3" bitsize="32"/>
    <reg name="d4" bitsize="32"/>
    <reg name="d5" bitsize="32"/>
    <reg name="d6" bitsize="32"/>
    <reg name="d7" bitsize="32"/>
    <reg name="a0" bitsize="32" type="data_ptr"/>
    <reg name="a1" bitsize="32" type="data_ptr"/>
    <reg name="a2" bitsize="32" type="data_ptr"/>
    <reg name="a3" bitsize="32" type="data_ptr"/>
    <reg name="a4" bitsize="32" type="data_ptr"/>
    <reg name="a5" bitsize="32" type="data_ptr"/>
    <reg name="fp" bitsize="32" type="data_ptr"/>
    <reg name="sp" bitsize="32" type="data_ptr"/>
    <reg name="ps" bitsize="32"/>
    <reg name="pc" bitsize="32" type="code_ptr"/>
  </feature>
</target>
"#;

/// Registers in GDB's numbering: d0-d7, a0-a7, sr, pc.
const NREGS: usize = 18;

/// The GDB server of one board.
pub struct Server {
    board: BoardId,
    conn: TcpStream,
    breaks: Vec<u32>,
    /// Stop the board at its next instruction (attached, or GDB sent an interrupt).
    stop: bool,
    /// GDB is waiting for a stop reply (after `c`).
    owe_reply: bool,
}

/// Parses `<board>:<port>` as given to `--gdb`.
pub fn parse_spec(spec: &str) -> Result<(BoardId, u16), String> {
    let (b, p) = spec
        .split_once(':')
        .ok_or_else(|| format!("--gdb {spec}: expected <board>:<port>, e.g. servo:1234"))?;
    let board = crate::boot::parse_board(b).ok_or_else(|| format!("--gdb {spec}: no board {b}"))?;
    let port = p
        .parse()
        .map_err(|_| format!("--gdb {spec}: {p} is not a TCP port"))?;
    Ok((board, port))
}

impl Server {
    /// Listens on `127.0.0.1:port` (0: any free port; `on_listen` is told the port) and
    /// waits for GDB to connect.
    pub fn listen(board: BoardId, port: u16, on_listen: impl FnOnce(u16)) -> io::Result<Self> {
        let l = TcpListener::bind(("127.0.0.1", port))?;
        on_listen(l.local_addr()?.port());
        let (conn, _) = l.accept()?;
        conn.set_nodelay(true)?;
        Ok(Self {
            board,
            conn,
            breaks: Vec::new(),
            stop: true,
            owe_reply: false,
        })
    }

    /// The board being debugged.
    pub fn board(&self) -> BoardId {
        self.board
    }

    /// The breakpoints set.
    pub fn breakpoints(&self) -> &[u32] {
        &self.breaks
    }

    /// Whether the board must stop before its next instruction.
    pub fn wants_stop(&self) -> bool {
        self.stop
    }

    /// Notices an interrupt (Ctrl-C, byte 0x03) GDB sent while the simulation runs.
    pub fn poll_interrupt(&mut self) {
        if !self.owe_reply {
            return;
        }
        let _ = self.conn.set_nonblocking(true);
        let mut b = [0u8; 64];
        if let Ok(n) = self.conn.read(&mut b) {
            if b[..n].contains(&0x03) {
                self.stop = true;
            }
        }
        let _ = self.conn.set_nonblocking(false);
    }

    /// The board has stopped (breakpoint, interrupt, halt or attach): answers GDB until it
    /// resumes the board. Returns `false` if GDB detached or the connection closed.
    pub fn serve(&mut self, b: &mut EmuBoard, global: &mut [u8], dev: &mut dyn Device) -> bool {
        self.stop = false;
        if self.owe_reply {
            self.owe_reply = false;
            if self.send(&stop_reply(b)).is_err() {
                return false;
            }
        }
        loop {
            let Ok(p) = self.recv() else { return false };
            let reply = match p.as_bytes().first() {
                Some(b'?') => stop_reply(b),
                Some(b'g') => (0..NREGS).map(|r| format!("{:08x}", reg(b, r))).collect(),
                Some(b'G') => {
                    let hex = &p[1..];
                    for r in 0..NREGS {
                        if let Some(v) = hex.get(8 * r..8 * r + 8) {
                            if let Ok(v) = u32::from_str_radix(v, 16) {
                                set_reg(b, r, v);
                            }
                        }
                    }
                    "OK".into()
                }
                Some(b'p') => match usize::from_str_radix(&p[1..], 16) {
                    Ok(r) if r < NREGS => format!("{:08x}", reg(b, r)),
                    _ => "E00".into(),
                },
                Some(b'P') => match p[1..].split_once('=').and_then(|(r, v)| {
                    Some((
                        usize::from_str_radix(r, 16).ok()?,
                        u32::from_str_radix(v, 16).ok()?,
                    ))
                }) {
                    Some((r, v)) if r < NREGS => {
                        set_reg(b, r, v);
                        "OK".into()
                    }
                    _ => "E00".into(),
                },
                Some(b'm') => match addr_len(&p[1..]) {
                    Some((a, n)) => match mem(b, global, a, n) {
                        Some(m) => m.iter().map(|x| format!("{x:02x}")).collect(),
                        None => "E14".into(),
                    },
                    None => "E00".into(),
                },
                Some(b'M') => {
                    let r = p[1..].split_once(':').and_then(|(al, data)| {
                        let (a, n) = addr_len(al)?;
                        let bytes = hex_bytes(data)?;
                        (bytes.len() == n as usize).then_some((a, bytes))
                    });
                    match r {
                        Some((a, bytes)) => match mem(b, global, a, bytes.len() as u32) {
                            Some(m) => {
                                m.copy_from_slice(&bytes);
                                "OK".into()
                            }
                            None => "E14".into(),
                        },
                        None => "E00".into(),
                    }
                }
                Some(b'Z') | Some(b'z') if matches!(p.as_bytes().get(1), Some(b'0' | b'1')) => {
                    match p[3..]
                        .split(',')
                        .next()
                        .and_then(|a| u32::from_str_radix(a, 16).ok())
                    {
                        Some(a) => {
                            self.breaks.retain(|&x| x != a);
                            if p.starts_with('Z') {
                                self.breaks.push(a);
                            }
                            "OK".into()
                        }
                        None => "E00".into(),
                    }
                }
                Some(b'c') => {
                    if let Some(a) = p.get(1..).and_then(|a| u32::from_str_radix(a, 16).ok()) {
                        b.cpu.pc = a;
                    }
                    self.owe_reply = true;
                    return true;
                }
                Some(b's') => {
                    if let Some(a) = p.get(1..).and_then(|a| u32::from_str_radix(a, 16).ok()) {
                        b.cpu.pc = a;
                    }
                    b.step_with(global, Some(&mut *dev));
                    stop_reply(b)
                }
                Some(b'D') => {
                    let _ = self.send("OK");
                    return false;
                }
                Some(b'k') => return false,
                Some(b'H') => "OK".into(),
                _ if p.starts_with("qSupported") => "PacketSize=4000;qXfer:features:read+".into(),
                _ if p.starts_with("qXfer:features:read:target.xml:") => {
                    xfer(TARGET_XML, &p["qXfer:features:read:target.xml:".len()..])
                }
                _ if p == "qAttached" => "1".into(),
                _ if p == "qfThreadInfo" => "m1".into(),
                _ if p == "qsThreadInfo" => "l".into(),
                _ if p == "qC" => "QC1".into(),
                _ if p.starts_with("qSymbol") => "OK".into(),
                _ => String::new(),
            };
            if self.send(&reply).is_err() {
                return false;
            }
        }
    }

    /// Reads one packet (acknowledging it); an interrupt byte between packets is dropped
    /// (the board is already stopped).
    fn recv(&mut self) -> io::Result<String> {
        let mut byte = [0u8; 1];
        loop {
            self.conn.read_exact(&mut byte)?;
            if byte[0] == b'$' {
                break;
            }
        }
        let mut body = Vec::new();
        loop {
            self.conn.read_exact(&mut byte)?;
            if byte[0] == b'#' {
                break;
            }
            body.push(byte[0]);
        }
        let mut sum = [0u8; 2];
        self.conn.read_exact(&mut sum)?;
        let want = u8::from_str_radix(std::str::from_utf8(&sum).unwrap_or("zz"), 16).ok();
        let got = body.iter().fold(0u8, |a, &x| a.wrapping_add(x));
        if want != Some(got) {
            self.conn.write_all(b"-")?;
            return self.recv();
        }
        self.conn.write_all(b"+")?;
        Ok(String::from_utf8_lossy(&unescape(&body)).into_owned())
    }

    /// Sends one packet and waits for its acknowledgement (resending on `-`).
    fn send(&mut self, body: &str) -> io::Result<()> {
        let sum = body.bytes().fold(0u8, |a, x| a.wrapping_add(x));
        let pkt = format!("${body}#{sum:02x}");
        loop {
            self.conn.write_all(pkt.as_bytes())?;
            let mut ack = [0u8; 1];
            loop {
                self.conn.read_exact(&mut ack)?;
                match ack[0] {
                    b'+' => return Ok(()),
                    b'-' => break,
                    _ => {} // an interrupt byte racing the reply
                }
            }
        }
    }
}

impl Drop for Server {
    /// GDB waiting on a `continue` when the run ends is told the program exited.
    fn drop(&mut self) {
        if self.owe_reply {
            let _ = self.send("W00");
        }
    }
}

/// `S05` (trap) for a board stopped at a breakpoint, a step or an interrupt; `S06` (abort)
/// for a board whose CPU has halted (the runtime's stop after a fault).
fn stop_reply(b: &EmuBoard) -> String {
    if b.state == RunState::Halted {
        "S06".into()
    } else {
        "S05".into()
    }
}

fn reg(b: &EmuBoard, r: usize) -> u32 {
    match r {
        0..=15 => b.cpu.dar[r],
        16 => b.cpu.get_sr() as u32,
        _ => b.cpu.pc,
    }
}

fn set_reg(b: &mut EmuBoard, r: usize, v: u32) {
    match r {
        0..=15 => b.cpu.dar[r] = v,
        16 => b.cpu.set_sr(v as u16),
        _ => b.cpu.pc = v,
    }
}

/// `addr,len` in hex.
fn addr_len(s: &str) -> Option<(u32, u32)> {
    let (a, n) = s.split_once(',')?;
    Some((
        u32::from_str_radix(a, 16).ok()?,
        u32::from_str_radix(n, 16).ok()?,
    ))
}

fn hex_bytes(s: &str) -> Option<Vec<u8>> {
    (0..s.len() / 2)
        .map(|i| u8::from_str_radix(s.get(2 * i..2 * i + 2)?, 16).ok())
        .collect()
}

/// The bytes at `a..a + n` of the board's local RAM or of global RAM; `None` elsewhere
/// (private I/O, unmapped).
fn mem<'a>(b: &'a mut EmuBoard, global: &'a mut [u8], a: u32, n: u32) -> Option<&'a mut [u8]> {
    let end = a.checked_add(n)?;
    if end <= LOCAL_RAM_SIZE {
        return Some(&mut b.ram[a as usize..end as usize]);
    }
    let g = a.checked_sub(GLOBAL_RAM_BASE)?;
    (g.checked_add(n)? <= GLOBAL_RAM_SIZE).then(|| &mut global[g as usize..(g + n) as usize])
}

/// A `qXfer` read of `doc` at `off,len`.
fn xfer(doc: &str, off_len: &str) -> String {
    let Some((off, len)) = addr_len(off_len) else {
        return "E00".into();
    };
    let bytes = doc.as_bytes();
    let start = (off as usize).min(bytes.len());
    let end = (start + len as usize).min(bytes.len());
    let more = if end < bytes.len() { 'm' } else { 'l' };
    format!("{more}{}", String::from_utf8_lossy(&bytes[start..end]))
}

/// Undoes the protocol's `}` escaping.
fn unescape(body: &[u8]) -> Vec<u8> {
    let mut out = Vec::with_capacity(body.len());
    let mut it = body.iter();
    while let Some(&c) = it.next() {
        if c == b'}' {
            if let Some(&n) = it.next() {
                out.push(n ^ 0x20);
            }
        } else {
            out.push(c);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn specs_parse_and_bad_ones_say_why() {
        assert_eq!(parse_spec("servo:1234"), Ok((BoardId::Servo, 1234)));
        assert_eq!(parse_spec("cspace:9"), Ok((BoardId::Cspace0, 9)));
        assert!(parse_spec("servo").unwrap_err().contains("<board>:<port>"));
        assert!(parse_spec("arm:1").unwrap_err().contains("no board arm"));
        assert!(parse_spec("servo:x")
            .unwrap_err()
            .contains("not a TCP port"));
    }

    #[test]
    fn target_description_is_served_in_pieces() {
        let a = xfer(TARGET_XML, "0,10");
        assert!(a.starts_with('m') && a.len() == 17);
        let all = xfer(TARGET_XML, &format!("0,{:x}", TARGET_XML.len() + 5));
        assert!(all.starts_with('l') && all.ends_with("</target>\n"));
        assert_eq!(unescape(b"a}\x03b"), b"a#b");
    }
}
