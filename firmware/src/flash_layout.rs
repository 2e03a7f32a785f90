//! Where things live in the STM32G431RB's internal flash.
//!
//! # Theory of operation
//!
//! The G431's 128 KiB of flash is one bank of 64 pages of 2 KiB (RM0440, section 3.3.1,
//! "Flash memory organization", category 2 devices). It is programmed a double word (8 bytes)
//! at a time, every double word carries ECC, and a programmed double word may only be
//! programmed again with all zeros. An erased byte reads `0xFF`.
//!
//! The image occupies pages 0–59 (the first 120 KiB, `FLASH` in `memory.x`); the settings
//! store occupies the last four pages, 60–63 (`0x0801_E000 ..= 0x0801_FFFF`), which the
//! linker script leaves out so no code can ever land there. Four pages let the store
//! (sequential-storage's map) keep the current record while filling and recycling the
//! others: a 128-byte record written 8 times a day takes years to wear a page past the
//! 10 000 cycles the datasheet guarantees.
//!
//! Offsets here are from the start of flash, as embassy-stm32's flash driver takes them.

use core::ops::Range;

/// Start address of the flash in the memory map.
pub const FLASH_BASE: u32 = 0x0800_0000;

/// Size of the flash: 128 KiB.
pub const FLASH_SIZE: u32 = 128 * 1024;

/// Erase granularity: one page, 2 KiB.
pub const PAGE_SIZE: u32 = 2048;

/// Program granularity: one double word, 8 bytes.
pub const WRITE_SIZE: usize = 8;

/// Pages given to the settings store.
pub const SETTINGS_PAGES: u32 = 4;

/// Offset of the first settings page (page 60): everything below is the image's.
pub const SETTINGS_OFFSET: u32 = FLASH_SIZE - SETTINGS_PAGES * PAGE_SIZE;

/// The settings store's flash range, as offsets from [`FLASH_BASE`].
pub const SETTINGS_RANGE: Range<u32> = SETTINGS_OFFSET..FLASH_SIZE;

/// The flash the image may use, in KiB: the `FLASH` length in `memory.x`.
pub const IMAGE_FLASH_KIB: u32 = SETTINGS_OFFSET / 1024;

#[cfg(test)]
mod tests {
    use super::*;
    use std::format;

    #[test]
    fn settings_pages_are_the_last_four_and_page_aligned() {
        assert_eq!(SETTINGS_OFFSET, 0x1_E000);
        assert_eq!(SETTINGS_OFFSET % PAGE_SIZE, 0);
        assert_eq!(SETTINGS_OFFSET / PAGE_SIZE, 60);
        assert_eq!(FLASH_BASE + SETTINGS_RANGE.end - 1, 0x0801_FFFF);
    }

    #[test]
    fn linker_script_keeps_the_image_out_of_the_settings_pages() {
        let memory = include_str!("../memory.x");
        let flash_line = memory
            .lines()
            .find(|line| line.trim_start().starts_with("FLASH"))
            .expect("memory.x has a FLASH region");
        assert!(flash_line.contains("ORIGIN = 0x08000000"), "{flash_line}");
        assert!(flash_line.contains(&format!("LENGTH = {IMAGE_FLASH_KIB}K")), "{flash_line}");
    }
}
