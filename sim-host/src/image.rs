//! Board images: loading ELF, Motorola S-record and raw binary files into a board's local
//! RAM, with every refusal naming the file and the reason (design.md section 8).
//!
//! An image must be for the 68k (ELF `e_machine` = `EM_68K`, big-endian, 32-bit, executable),
//! must fit in the board's 1 MiB of local RAM, and must start with a vector table at address 0
//! (initial stack pointer and reset PC). An S-record file must have valid hex, consistent byte
//! counts and checksums on every line, a record count (S5/S6) that matches if present, and
//! end with a termination record (S7/S8/S9): a file that stops early is refused as truncated.

use object::elf;
use object::read::elf::{ElfFile32, FileHeader, ProgramHeader};
use object::{Endianness, Object, ObjectSection, ObjectSymbol, SectionFlags};
use std::fmt;
use std::path::{Path, PathBuf};

/// Bytes of local RAM on every board (1 MiB at address 0).
pub const LOCAL_RAM_SIZE: u32 = 0x0010_0000;

/// A contiguous run of bytes to place in local RAM.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Segment {
    /// Load address.
    pub addr: u32,
    /// Contents.
    pub data: Vec<u8>,
}

/// A loadable image.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Image {
    /// The file it came from.
    pub path: PathBuf,
    /// The segments to load, in file order.
    pub segments: Vec<Segment>,
    /// Section sizes when the file says (ELF only).
    pub sizes: Option<Sizes>,
    /// Function and object symbols with their addresses (ELF only), for tests and debugging.
    pub symbols: Vec<(String, u32)>,
}

/// Sizes of an image's parts in bytes.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Sizes {
    /// Code, vectors and read-only data (loaded, not written).
    pub text: u32,
    /// Initialised data (loaded, copied to RAM at reset).
    pub data: u32,
    /// Zero-initialised data (cleared at reset).
    pub bss: u32,
}

/// Why an image was refused.
#[derive(Debug, thiserror::Error)]
pub enum ImageError {
    /// The file could not be read.
    #[error("{path}: cannot read: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The I/O error.
        source: std::io::Error,
    },
    /// The ELF file is malformed or not for this machine.
    #[error("{path}: {reason}")]
    Elf {
        /// The file.
        path: PathBuf,
        /// Why.
        reason: String,
    },
    /// An S-record line is malformed.
    #[error("{path}:{line}: {reason}")]
    Srec {
        /// The file.
        path: PathBuf,
        /// 1-based line number.
        line: usize,
        /// Why.
        reason: String,
    },
    /// The image does not fit in local RAM, or lacks its vector table.
    #[error("{path}: {reason}")]
    Layout {
        /// The file.
        path: PathBuf,
        /// Why.
        reason: String,
    },
}

impl Image {
    /// Loads an image, choosing the format by content: ELF magic, else a leading `S`
    /// (S-record), else by the `.bin` extension (raw bytes loaded at 0).
    pub fn load(path: &Path) -> Result<Image, ImageError> {
        let bytes = std::fs::read(path).map_err(|source| ImageError::Io {
            path: path.to_owned(),
            source,
        })?;
        Self::parse(path, &bytes)
    }

    /// Parses an image already in memory; `path` names it in errors.
    pub fn parse(path: &Path, bytes: &[u8]) -> Result<Image, ImageError> {
        let img = if bytes.starts_with(b"\x7fELF") {
            parse_elf(path, bytes)?
        } else if bytes.first() == Some(&b'S') {
            parse_srec(path, bytes)?
        } else if path.extension().is_some_and(|e| e == "bin") {
            Image {
                path: path.to_owned(),
                segments: vec![Segment {
                    addr: 0,
                    data: bytes.to_vec(),
                }],
                sizes: None,
                symbols: Vec::new(),
            }
        } else {
            return Err(ImageError::Layout {
                path: path.to_owned(),
                reason: "not an ELF file, an S-record file or a .bin image".into(),
            });
        };
        img.check()?;
        Ok(img)
    }

    fn check(&self) -> Result<(), ImageError> {
        let err = |reason: String| ImageError::Layout {
            path: self.path.clone(),
            reason,
        };
        if self.segments.iter().all(|s| s.data.is_empty()) {
            return Err(err("image is empty".into()));
        }
        for s in &self.segments {
            let end = s.addr as u64 + s.data.len() as u64;
            if end > LOCAL_RAM_SIZE as u64 {
                return Err(err(format!(
                    "does not fit in local RAM: {} bytes at {:#010x} end at {:#x}, beyond {:#x}",
                    s.data.len(),
                    s.addr,
                    end,
                    LOCAL_RAM_SIZE
                )));
            }
        }
        if self.read_u32(0).is_none() || self.read_u32(4).is_none() {
            return Err(err(
                "no vector table at address 0 (initial SSP and reset PC)".into(),
            ));
        }
        let pc = self.read_u32(4).unwrap_or(0);
        if pc >= LOCAL_RAM_SIZE || !pc.is_multiple_of(2) {
            return Err(err(format!(
                "reset vector {pc:#010x} is not an even address in local RAM"
            )));
        }
        Ok(())
    }

    /// The big-endian word the image places at `addr`, if it covers all four bytes.
    pub fn read_u32(&self, addr: u32) -> Option<u32> {
        let mut b = [0u8; 4];
        for (i, byte) in b.iter_mut().enumerate() {
            let a = addr + i as u32;
            *byte = *self
                .segments
                .iter()
                .find_map(|s| a.checked_sub(s.addr).and_then(|o| s.data.get(o as usize)))?;
        }
        Some(u32::from_be_bytes(b))
    }

    /// The image as local RAM contents: a 1 MiB array with every segment placed.
    pub fn to_ram(&self) -> Vec<u8> {
        let mut ram = vec![0u8; LOCAL_RAM_SIZE as usize];
        for s in &self.segments {
            ram[s.addr as usize..s.addr as usize + s.data.len()].copy_from_slice(&s.data);
        }
        ram
    }

    /// The address of the symbol named `name`, or whose demangled path ends with `name`.
    pub fn symbol(&self, name: &str) -> Option<u32> {
        self.symbols.iter().find(|(n, _)| n == name).map(|s| s.1)
    }

    /// Total bytes loaded.
    pub fn loaded_bytes(&self) -> usize {
        self.segments.iter().map(|s| s.data.len()).sum()
    }
}

fn parse_elf(path: &Path, bytes: &[u8]) -> Result<Image, ImageError> {
    let err = |reason: String| ImageError::Elf {
        path: path.to_owned(),
        reason,
    };
    if bytes.len() < 52 {
        return Err(err("truncated ELF header".into()));
    }
    if bytes[4] != elf::ELFCLASS32 {
        return Err(err(
            "not a 32-bit ELF file (the 68020 is a 32-bit machine)".into()
        ));
    }
    if bytes[5] != elf::ELFDATA2MSB {
        return Err(err(
            "not a big-endian ELF file (the 68020 is big-endian)".into()
        ));
    }
    let file =
        ElfFile32::<Endianness>::parse(bytes).map_err(|e| err(format!("malformed ELF: {e}")))?;
    let hdr = file.elf_header();
    let endian = file.endian();
    let machine = hdr.e_machine(endian);
    if machine != elf::EM_68K {
        return Err(err(format!(
            "wrong architecture: e_machine {machine} ({}), expected {} (EM_68K)",
            machine_name(machine),
            elf::EM_68K
        )));
    }
    if hdr.e_type(endian) != elf::ET_EXEC {
        return Err(err(
            "not an executable (a relocatable object or shared library?)".into(),
        ));
    }
    let mut segments = Vec::new();
    for ph in file.elf_program_headers() {
        if ph.p_type(endian) != elf::PT_LOAD || ph.p_filesz(endian) == 0 {
            continue;
        }
        let data = ph.data(endian, bytes).map_err(|_| {
            err(format!(
                "segment at {:#x} extends past the end of the file (truncated?)",
                ph.p_paddr(endian)
            ))
        })?;
        segments.push(Segment {
            addr: ph.p_paddr(endian),
            data: data.to_vec(),
        });
        let vend = ph.p_vaddr(endian) as u64 + ph.p_memsz(endian) as u64;
        if vend > LOCAL_RAM_SIZE as u64 {
            return Err(ImageError::Layout {
                path: path.to_owned(),
                reason: format!("does not fit in local RAM: a segment ends at {vend:#x}, beyond {LOCAL_RAM_SIZE:#x}"),
            });
        }
    }
    let mut sizes = Sizes::default();
    for s in file.sections() {
        let SectionFlags::Elf { sh_flags } = s.flags() else {
            continue;
        };
        if sh_flags & elf::SHF_ALLOC as u64 == 0 {
            continue;
        }
        let size = s.size() as u32;
        if s.kind() == object::SectionKind::UninitializedData {
            sizes.bss += size;
        } else if sh_flags & elf::SHF_WRITE as u64 != 0 {
            sizes.data += size;
        } else {
            sizes.text += size;
        }
    }
    let symbols = file
        .symbols()
        .filter(|s| !s.is_undefined() && s.section_index().is_some())
        .filter_map(|s| Some((s.name().ok()?.to_string(), s.address() as u32)))
        .collect();
    Ok(Image {
        path: path.to_owned(),
        segments,
        sizes: Some(sizes),
        symbols,
    })
}

fn machine_name(m: u16) -> &'static str {
    match m {
        elf::EM_386 => "i386",
        elf::EM_X86_64 => "x86-64",
        elf::EM_ARM => "ARM",
        elf::EM_AARCH64 => "AArch64",
        elf::EM_RISCV => "RISC-V",
        elf::EM_68K => "68k",
        _ => "other",
    }
}

fn parse_srec(path: &Path, bytes: &[u8]) -> Result<Image, ImageError> {
    let text = std::str::from_utf8(bytes).map_err(|e| ImageError::Srec {
        path: path.to_owned(),
        line: bytes[..e.valid_up_to()]
            .iter()
            .filter(|&&b| b == b'\n')
            .count()
            + 1,
        reason: "not ASCII text".into(),
    })?;
    let mut segments: Vec<Segment> = Vec::new();
    let mut data_records = 0u32;
    let mut terminated = false;
    let mut last_line = 0;
    for (i, raw) in text.lines().enumerate() {
        let line_no = i + 1;
        last_line = line_no;
        let line = raw.trim_end_matches('\r');
        let err = |reason: String| ImageError::Srec {
            path: path.to_owned(),
            line: line_no,
            reason,
        };
        if line.is_empty() {
            continue;
        }
        if terminated {
            return Err(err("record after the termination record".into()));
        }
        let rec = SRecord::parse(line).map_err(err)?;
        match rec.kind {
            0 => {}
            1..=3 => {
                data_records += 1;
                match segments.last_mut() {
                    Some(s) if s.addr as u64 + s.data.len() as u64 == rec.addr as u64 => {
                        s.data.extend_from_slice(&rec.data)
                    }
                    _ => segments.push(Segment {
                        addr: rec.addr,
                        data: rec.data,
                    }),
                }
            }
            5 | 6 => {
                if rec.addr != data_records {
                    return Err(err(format!(
                        "record count says {} data records, file has {data_records}",
                        rec.addr
                    )));
                }
            }
            7..=9 => terminated = true,
            k => return Err(err(format!("unknown record type S{k}"))),
        }
    }
    if !terminated {
        return Err(ImageError::Srec {
            path: path.to_owned(),
            line: last_line,
            reason: "truncated: file ends without a termination record (S7, S8 or S9)".into(),
        });
    }
    Ok(Image {
        path: path.to_owned(),
        segments,
        sizes: None,
        symbols: Vec::new(),
    })
}

/// One parsed S-record line.
struct SRecord {
    kind: u8,
    addr: u32,
    data: Vec<u8>,
}

impl SRecord {
    fn parse(line: &str) -> Result<SRecord, String> {
        let b = line.as_bytes();
        if b.len() < 4 || b[0] != b'S' || !b[1].is_ascii_digit() {
            return Err(format!("not an S-record: {:?}", truncate(line)));
        }
        let kind = b[1] - b'0';
        let hex = &line[2..];
        if !hex.len().is_multiple_of(2) {
            return Err("odd number of hex digits".into());
        }
        let mut bytes = Vec::with_capacity(hex.len() / 2);
        for (j, pair) in hex.as_bytes().chunks(2).enumerate() {
            let s = std::str::from_utf8(pair).unwrap_or("??");
            let v = u8::from_str_radix(s, 16)
                .map_err(|_| format!("bad hex digits {s:?} at column {}", 3 + 2 * j))?;
            bytes.push(v);
        }
        let count = bytes[0] as usize;
        if count != bytes.len() - 1 {
            return Err(format!(
                "byte count says {count}, line has {}",
                bytes.len() - 1
            ));
        }
        let sum: u32 = bytes[..bytes.len() - 1].iter().map(|&v| v as u32).sum();
        let want = !(sum as u8);
        let got = bytes[bytes.len() - 1];
        if got != want {
            return Err(format!("checksum {got:02X} should be {want:02X}"));
        }
        let alen = match kind {
            0 | 1 | 5 | 9 => 2,
            2 | 6 | 8 => 3,
            3 | 7 => 4,
            _ => return Err(format!("unknown record type S{kind}")),
        };
        if count < alen + 1 {
            return Err(format!("record too short for a {alen}-byte address"));
        }
        let addr = bytes[1..1 + alen]
            .iter()
            .fold(0u32, |a, &v| a << 8 | v as u32);
        let data = bytes[1 + alen..bytes.len() - 1].to_vec();
        Ok(SRecord { kind, addr, data })
    }
}

fn truncate(s: &str) -> &str {
    &s[..s.len().min(20)]
}

impl fmt::Display for Sizes {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "text {} data {} bss {}", self.text, self.data, self.bss)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn srec_line(kind: u8, addr: u32, alen: usize, data: &[u8]) -> String {
        let mut bytes = vec![(alen + data.len() + 1) as u8];
        bytes.extend_from_slice(&addr.to_be_bytes()[4 - alen..]);
        bytes.extend_from_slice(data);
        let sum: u32 = bytes.iter().map(|&b| b as u32).sum();
        bytes.push(!(sum as u8));
        let mut s = format!("S{kind}");
        for b in bytes {
            s += &format!("{b:02X}");
        }
        s
    }

    fn good() -> String {
        [
            srec_line(0, 0, 2, b"test"),
            srec_line(1, 0, 2, &[0, 0x10, 0, 0, 0, 0, 4, 0]),
            srec_line(1, 0x400, 2, &[0x60, 0xFE]),
            srec_line(5, 2, 2, &[]),
            srec_line(9, 0x400, 2, &[]),
        ]
        .join("\n")
    }

    #[test]
    fn a_good_srecord_loads() {
        let img = Image::parse(Path::new("x.s19"), good().as_bytes()).unwrap();
        assert_eq!(img.read_u32(0), Some(0x0010_0000));
        assert_eq!(img.read_u32(4), Some(0x400));
        assert_eq!(img.to_ram()[0x400..0x402], [0x60, 0xFE]);
    }

    fn refusal(text: &str) -> String {
        Image::parse(Path::new("bad.s19"), text.as_bytes())
            .unwrap_err()
            .to_string()
    }

    #[test]
    fn corrupt_srecords_are_refused_with_file_line_and_reason() {
        let g = good();
        let lines: Vec<&str> = g.lines().collect();
        // Flip a data digit: checksum error on line 2.
        let mut bad = lines.clone();
        let l2 = bad[1].replacen("0010", "0011", 1);
        bad[1] = &l2;
        let e = refusal(&bad.join("\n"));
        assert!(e.starts_with("bad.s19:2: checksum"), "{e}");
        // Truncated: no termination record.
        let e = refusal(&lines[..3].join("\n"));
        assert!(e.contains("bad.s19:3: truncated"), "{e}");
        // A line cut in the middle.
        let cut = format!("{}\n{}", lines[0], &lines[1][..9]);
        let e = refusal(&cut);
        assert!(e.starts_with("bad.s19:2:"), "{e}");
        // Bad hex.
        let e = refusal(&format!("{}\nS1ZZ", lines[0]));
        assert!(e.contains("bad.s19:2: bad hex"), "{e}");
        // Wrong record count.
        let mut bad = lines.clone();
        let s5 = srec_line(5, 7, 2, &[]);
        bad[3] = &s5;
        let e = refusal(&bad.join("\n"));
        assert!(e.contains("bad.s19:4: record count"), "{e}");
    }

    #[test]
    fn images_that_do_not_fit_are_refused() {
        let text = [
            srec_line(1, 0, 2, &[0, 0x10, 0, 0, 0, 0, 4, 0]),
            srec_line(3, 0x000F_FFFE, 4, &[1, 2, 3, 4]),
            srec_line(7, 0x400, 4, &[]),
        ]
        .join("\n");
        let e = refusal(&text);
        assert!(e.contains("does not fit in local RAM"), "{e}");
        let text = [srec_line(1, 0x400, 2, &[1, 2]), srec_line(9, 0x400, 2, &[])].join("\n");
        assert!(refusal(&text).contains("no vector table"));
    }

    #[test]
    fn non_images_are_refused() {
        let e = Image::parse(Path::new("notes.txt"), b"hello")
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("notes.txt: not an ELF"), "{e}");
        // A little-endian ELF header (x86-64 class 64): refused by class first.
        let mut h = vec![0x7f, b'E', b'L', b'F', 2, 1, 1];
        h.resize(64, 0);
        let e = Image::parse(Path::new("host.elf"), &h)
            .unwrap_err()
            .to_string();
        assert!(e.contains("host.elf: not a 32-bit ELF"), "{e}");
    }
}
