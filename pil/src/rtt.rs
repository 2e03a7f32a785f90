//! The firmware's log: defmt frames in the RTT up-buffer, read as a debug probe reads them.
//!
//! The image logs with `defmt` over `defmt-rtt`: a control block `_SEGGER_RTT` in RAM ("SEGGER
//! RTT", the channel counts, then the up channel: name, buffer, size, write and read offsets,
//! flags) and a ring buffer the firmware writes rzCOBS-encoded frames into, each ended by a
//! zero. The bench plays the probe: every tick it takes the bytes between the read and write
//! offsets and moves the read offset (so the firmware never finds the buffer full), splits the
//! frames at their zeros, undoes the rzCOBS encoding (read backwards: a byte `0xxxxxxx` says
//! which of the next seven bytes are zeros, `1nnnnnnn` copies n + 7 bytes and a zero, `0xFF`
//! copies 134), and looks the frame's first two bytes — the interned format string's index —
//! up in the image's `.defmt` symbols, whose names carry the level and the format string.
//! Arguments are shown as the bytes that follow (the bench does not re-implement defmt's
//! argument formatting).

use std::collections::HashMap;

use crate::elf::Image;

/// One decoded log line.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Line {
    /// `info`, `warn`, `error`, …
    pub level: String,
    /// The format string, with the arguments' bytes after it when it has any.
    pub text: String,
}

/// The probe side of RTT and the defmt table.
#[derive(Debug, Default)]
pub struct Reader {
    control_block: Option<u32>,
    table: HashMap<u16, (String, String)>,
    pending: Vec<u8>,
    /// The lines read so far.
    pub lines: Vec<Line>,
    /// Frames that did not decode.
    pub corrupt: u64,
}

fn json_field(json: &str, field: &str) -> Option<String> {
    let key = format!("\"{field}\":\"");
    let start = json.find(&key)? + key.len();
    let mut out = String::new();
    let mut chars = json[start..].chars();
    while let Some(c) = chars.next() {
        match c {
            '\\' => out.push(chars.next()?),
            '"' => return Some(out),
            c => out.push(c),
        }
    }
    None
}

/// Undoes rzCOBS (see the module docs); `None` if the frame is corrupt.
pub fn rzcobs_decode(data: &[u8]) -> Option<Vec<u8>> {
    let mut out = Vec::new();
    let mut it = data.iter().rev().copied();
    while let Some(x) = it.next() {
        match x {
            0 => return None,
            0x01..=0x7F => {
                for i in 0..7 {
                    if x & (1 << (6 - i)) == 0 {
                        out.push(it.next()?);
                    } else {
                        out.push(0);
                    }
                }
            }
            0x80..=0xFE => {
                out.push(0);
                for _ in 0..(x & 0x7F) + 7 {
                    out.push(it.next()?);
                }
            }
            0xFF => {
                for _ in 0..134 {
                    out.push(it.next()?);
                }
            }
        }
    }
    out.reverse();
    Some(out)
}

impl Reader {
    /// A reader for `image`'s RTT block and defmt table.
    pub fn new(image: &Image) -> Self {
        let mut table = HashMap::new();
        for (name, value) in &image.markers {
            if let (Some(level), Some(data)) = (json_field(name, "tag"), json_field(name, "data")) {
                if let Ok(index) = u16::try_from(*value) {
                    table
                        .entry(index)
                        .or_insert((level.trim_start_matches("defmt_").to_string(), data));
                }
            }
        }
        Self { control_block: image.symbol("_SEGGER_RTT"), table, ..Self::default() }
    }

    /// Takes what the firmware wrote since the last call; `read`/`write` access the part's RAM.
    pub fn poll(
        &mut self,
        read: impl Fn(u32, usize) -> Vec<u8>,
        mut write: impl FnMut(u32, &[u8]),
    ) {
        let Some(cb) = self.control_block else { return };
        let header = read(cb, 48);
        if header.get(0..10) != Some(b"SEGGER RTT") {
            return;
        }
        let word = |at: usize| {
            u32::from_le_bytes([header[at], header[at + 1], header[at + 2], header[at + 3]])
        };
        let (buffer, size, write_at, read_at) = (word(28), word(32), word(36), word(40));
        if size == 0 || write_at >= size || read_at >= size || write_at == read_at {
            return;
        }
        let bytes = if write_at > read_at {
            read(buffer + read_at, (write_at - read_at) as usize)
        } else {
            let mut b = read(buffer + read_at, (size - read_at) as usize);
            b.extend(read(buffer, write_at as usize));
            b
        };
        write(cb + 40, &write_at.to_le_bytes());
        if std::env::var_os("TAUT_PIL_RTT").is_some() {
            eprintln!("rtt: {bytes:02x?}");
        }
        for byte in bytes {
            if byte == 0 {
                let frame = std::mem::take(&mut self.pending);
                if !frame.is_empty() {
                    self.frame(&frame);
                }
            } else {
                self.pending.push(byte);
            }
        }
    }

    fn frame(&mut self, encoded: &[u8]) {
        let decoded = rzcobs_decode(encoded);
        if std::env::var_os("TAUT_PIL_RTT").is_some() {
            eprintln!("frame {encoded:02x?} -> {decoded:02x?}");
        }
        let Some(frame) = decoded else {
            self.corrupt += 1;
            return;
        };
        let Some(index) = frame.get(0..2).map(|b| u16::from_le_bytes([b[0], b[1]])) else {
            self.corrupt += 1;
            return;
        };
        match self.table.get(&index) {
            Some((level, text)) => {
                let mut args = &frame[2..];
                let text = self
                    .format(text, &mut args)
                    .unwrap_or_else(|| format!("{text} [arguments: {:02x?}]", &frame[2..]));
                self.lines.push(Line { level: level.clone(), text });
            }
            None => self.corrupt += 1,
        }
    }
}

impl Reader {
    /// Fills `text`'s parameters from `args`: the integer and boolean types (`{=u8}` …
    /// `{=i32}`, `:x`/`:#x` in hex) and `{}`, whose argument starts with the index of its own
    /// format (a primitive's); `None` for anything else.
    fn format(&self, text: &str, args: &mut &[u8]) -> Option<String> {
        let mut out = String::new();
        let mut rest = text;
        while let Some(open) = rest.find('{') {
            out.push_str(&rest[..open]);
            let close = rest[open..].find('}')? + open;
            let spec = &rest[open + 1..close];
            rest = &rest[close + 1..];
            let (ty, hint) = spec.split_once(':').unwrap_or((spec, ""));
            let ty = if ty.is_empty() {
                let index = u16::from_le_bytes([*args.first()?, *args.get(1)?]);
                *args = &args[2..];
                let (_, inner) = self.table.get(&index)?;
                inner.trim_start_matches("{=").trim_end_matches('}').to_string()
            } else {
                ty.trim_start_matches('=').to_string()
            };
            let width = match ty.as_str() {
                "u8" | "i8" | "bool" => 1,
                "u16" | "i16" => 2,
                "u32" | "i32" => 4,
                _ => return None,
            };
            let bytes = args.get(..width)?;
            let mut raw = [0u8; 4];
            raw[..width].copy_from_slice(bytes);
            *args = &args[width..];
            let value = u32::from_le_bytes(raw);
            match (ty.as_str(), hint) {
                ("bool", _) => out.push_str(if value != 0 { "true" } else { "false" }),
                (_, "#x") => out.push_str(&format!("{value:#x}")),
                (_, "x") => out.push_str(&format!("{value:x}")),
                ("i8", _) => out.push_str(&(value as u8 as i8).to_string()),
                ("i16", _) => out.push_str(&(value as u16 as i16).to_string()),
                ("i32", _) => out.push_str(&(value as i32).to_string()),
                _ => out.push_str(&value.to_string()),
            }
        }
        out.push_str(rest);
        Some(out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rzcobs_round_trips_defmts_own_examples() {
        // Pairs from defmt's encoder tests: (decoded, encoded without the frame's zero).
        let cases: &[(&[u8], &[u8])] = &[
            (&[0x00], &[0x7f]),
            (&[0x01], &[0x01, 0x7e]),
            (&[0x00, 0x01], &[0x01, 0x7d]),
            (&[0x01, 0x02], &[0x01, 0x02, 0x7c]),
            (
                &[0x11, 0x22, 0x33, 0x44, 0x55, 0x66, 0x00],
                &[0x11, 0x22, 0x33, 0x44, 0x55, 0x66, 0x40],
            ),
            (
                &[0x11, 0x22, 0x33, 0x44, 0x55, 0x66, 0x77],
                &[0x11, 0x22, 0x33, 0x44, 0x55, 0x66, 0x77, 0x80],
            ),
        ];
        for (decoded, encoded) in cases {
            let got = rzcobs_decode(encoded).expect("decodes");
            // The encoder pads the last group with zeros: compare the meaningful prefix.
            assert_eq!(&got[..decoded.len()], *decoded, "{encoded:02x?}");
            assert!(got[decoded.len()..].iter().all(|&b| b == 0));
        }
    }

    #[test]
    fn a_json_symbol_gives_level_and_text() {
        let name = r#"{"package":"taut-firmware","tag":"defmt_error","data":"settings writer not started","disambiguator":"1"}"#;
        assert_eq!(json_field(name, "tag").as_deref(), Some("defmt_error"));
        assert_eq!(json_field(name, "data").as_deref(), Some("settings writer not started"));
    }
}
