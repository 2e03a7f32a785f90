//! The firmware image: the loadable segments and the symbols of an ELF32 little-endian file.
//!
//! The bench runs the file the build produced, byte for byte: what the linker placed in flash
//! (`.vector_table`, `.text`, `.rodata`, the initial values of `.data`) is loaded at its load
//! address (`p_paddr`), exactly as a probe would program it; nothing else is taken from the
//! file but the symbol table, which names functions in reports and finds the RTT control block.

use std::collections::BTreeMap;
use std::fmt;

/// Why a file is not a loadable image.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum ElfError {
    /// Not an ELF32 little-endian ARM executable.
    NotArmElf,
    /// A header or segment lies outside the file.
    Truncated,
}

impl fmt::Display for ElfError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::NotArmElf => write!(f, "not a 32-bit little-endian ARM ELF executable"),
            Self::Truncated => write!(f, "the ELF file is truncated"),
        }
    }
}

/// One loadable segment: `bytes` go to `address` (the load address).
#[derive(Debug, Clone)]
pub struct Segment {
    /// Load (physical) address.
    pub address: u32,
    /// The segment's bytes as stored in the file (zero-initialised memory is not loaded).
    pub bytes: Vec<u8>,
}

/// A parsed image.
#[derive(Debug, Clone)]
pub struct Image {
    /// The loadable segments.
    pub segments: Vec<Segment>,
    /// Function and object symbols: address (Thumb bit cleared) → (name, size).
    pub symbols: BTreeMap<u32, (String, u32)>,
    /// Linker-script symbols (no type): name and value, e.g. `__sheap`, `_stack_start`.
    pub markers: Vec<(String, u32)>,
}

fn u16_at(bytes: &[u8], at: usize) -> Result<u16, ElfError> {
    let b =
        bytes.get(at..at.checked_add(2).ok_or(ElfError::Truncated)?).ok_or(ElfError::Truncated)?;
    Ok(u16::from_le_bytes([b[0], b[1]]))
}

fn u32_at(bytes: &[u8], at: usize) -> Result<u32, ElfError> {
    let b =
        bytes.get(at..at.checked_add(4).ok_or(ElfError::Truncated)?).ok_or(ElfError::Truncated)?;
    Ok(u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
}

fn slice(bytes: &[u8], offset: u32, len: u32) -> Result<&[u8], ElfError> {
    let start = offset as usize;
    let end = start.checked_add(len as usize).ok_or(ElfError::Truncated)?;
    bytes.get(start..end).ok_or(ElfError::Truncated)
}

impl Image {
    /// Parses an ELF32 ARM executable.
    pub fn parse(bytes: &[u8]) -> Result<Self, ElfError> {
        // e_ident: magic, ELFCLASS32, ELFDATA2LSB; e_machine EM_ARM (40).
        if bytes.get(0..6) != Some(&[0x7f, b'E', b'L', b'F', 1, 1]) || u16_at(bytes, 18)? != 40 {
            return Err(ElfError::NotArmElf);
        }
        let phoff = u32_at(bytes, 28)?;
        let shoff = u32_at(bytes, 32)?;
        let phentsize = u32::from(u16_at(bytes, 42)?);
        let phnum = u32::from(u16_at(bytes, 44)?);
        let shentsize = u32::from(u16_at(bytes, 46)?);
        let shnum = u32::from(u16_at(bytes, 48)?);
        let mut segments = Vec::new();
        for index in 0..phnum {
            let at = (phoff + index * phentsize) as usize;
            // PT_LOAD = 1
            if u32_at(bytes, at)? != 1 {
                continue;
            }
            let offset = u32_at(bytes, at + 4)?;
            let paddr = u32_at(bytes, at + 12)?;
            let filesz = u32_at(bytes, at + 16)?;
            if filesz == 0 {
                continue;
            }
            segments
                .push(Segment { address: paddr, bytes: slice(bytes, offset, filesz)?.to_vec() });
        }
        let mut symbols = BTreeMap::new();
        let mut markers = Vec::new();
        for index in 0..shnum {
            let at = (shoff + index * shentsize) as usize;
            // SHT_SYMTAB = 2
            if u32_at(bytes, at + 4)? != 2 {
                continue;
            }
            let offset = u32_at(bytes, at + 16)?;
            let size = u32_at(bytes, at + 20)?;
            let link = u32_at(bytes, at + 24)?;
            let strtab_at = (shoff + link * shentsize) as usize;
            let str_offset = u32_at(bytes, strtab_at + 16)?;
            let str_size = u32_at(bytes, strtab_at + 20)?;
            let strings = slice(bytes, str_offset, str_size)?;
            let table = slice(bytes, offset, size)?;
            for entry in table.chunks_exact(16) {
                let name_at = u32_at(entry, 0)? as usize;
                let value = u32_at(entry, 4)?;
                let sym_size = u32_at(entry, 8)?;
                let kind = entry[12] & 0xf;
                // STT_NOTYPE = 0 (linker-script symbols), STT_OBJECT = 1, STT_FUNC = 2.
                if kind > 2 {
                    continue;
                }
                let name = strings
                    .get(name_at..)
                    .and_then(|s| s.split(|&b| b == 0).next())
                    .map(|s| String::from_utf8_lossy(s).into_owned())
                    .unwrap_or_default();
                // Mapping symbols ($t, $d) and section-less names say nothing.
                if name.is_empty() || name.starts_with('$') {
                    continue;
                }
                // Linker-script symbols, and defmt's interned strings (their "address" is the
                // string's index, which must not lose its low bit as code addresses do).
                if kind == 0 || name.starts_with('{') {
                    markers.push((name, value));
                    continue;
                }
                symbols.insert(value & !1, (name, sym_size));
            }
        }
        Ok(Self { segments, symbols, markers })
    }

    /// The address of the symbol called `name`.
    pub fn symbol(&self, name: &str) -> Option<u32> {
        self.symbols
            .iter()
            .find(|(_, (n, _))| n == name)
            .map(|(&a, _)| a)
            .or_else(|| self.markers.iter().find(|(n, _)| n == name).map(|&(_, v)| v))
    }

    /// The function containing `address`, as `name+offset`.
    pub fn describe(&self, address: u32) -> String {
        match self.symbols.range(..=address).next_back() {
            Some((&start, (name, size))) if address < start.saturating_add((*size).max(1)) => {
                format!("{}+{:#x}", demangle_short(name), address - start)
            }
            _ => format!("{address:#010x}"),
        }
    }
}

/// A Rust v0/legacy mangled name shortened to its path's last two parts (`module::function`),
/// enough to recognise a function in a report; other names unchanged.
pub fn demangle_short(name: &str) -> String {
    let Some(rest) = name.strip_prefix("_ZN") else { return name.to_string() };
    let mut parts = Vec::new();
    let mut s = rest;
    while let Some(digits_end) = s.find(|c: char| !c.is_ascii_digit()) {
        if digits_end == 0 {
            break;
        }
        let Ok(len) = s[..digits_end].parse::<usize>() else { break };
        let Some(part) = s.get(digits_end..digits_end + len) else { break };
        parts.push(part.to_string());
        s = &s[digits_end + len..];
    }
    if parts.last().is_some_and(|p| p.starts_with('h') && p.len() == 17) {
        parts.pop();
    }
    let n = parts.len();
    parts[n.saturating_sub(2)..].join("::")
}
