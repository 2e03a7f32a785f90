//! Power-cut test of the settings store on a model of the STM32G431's flash.
//!
//! The store (`taut_firmware::settings`) must give back, after any power cut, either the
//! previous record or the new one — whole. This test saves a long sequence of distinct
//! records and, for most saves, cuts the power at a random point inside the save; it then
//! "resets" (re-opens the store on the same flash bytes, as the firmware does at boot) and
//! checks what loads. It runs until more than 10 000 saves have actually been cut and prints
//! how many it survived.
//!
//! # The flash model
//!
//! [`G4Flash`] behaves like the G431's internal flash as RM0440 describes it: 2 KiB pages
//! erased to `0xFF`; programming by aligned 8-byte double words, which may only clear bits;
//! a double word already programmed since the last erase may only be programmed again with
//! all zeros (otherwise the controller raises PROGERR). Power is cut after a random number of
//! double-word operations (one per double word programmed or erased), and the operation
//! in flight is **torn**: a torn program clears a random subset of the bits it was clearing,
//! a torn erase leaves the page's words before the cut erased, the word at the cut with a
//! random mix of old and erased bits, and the rest untouched. After the cut every operation
//! fails until the reset.
//!
//! What the model cannot show: on the real part a torn double word may also carry a bad ECC
//! code, and reading it raises an ECC error (single-bit errors are corrected silently;
//! double-bit errors raise an NMI). `firmware/README.md` says how the firmware handles that.
#![allow(
    clippy::indexing_slicing,
    clippy::arithmetic_side_effects,
    clippy::cast_possible_truncation,
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::panic,
    reason = "a host test: an out-of-range index or overflow panics the test, which is the \
              report we want"
)]
#![allow(missing_docs, reason = "test crate")]

use core::future::Future;
use core::pin::pin;
use core::task::{Context, Poll, Waker};
use embedded_storage_async::nor_flash::{
    ErrorType, NorFlash, NorFlashError, NorFlashErrorKind, ReadNorFlash,
};
use taut_core::store::{Counters, RECORD_LEN, Record};
use taut_firmware::flash_layout::{PAGE_SIZE, SETTINGS_PAGES, WRITE_SIZE};
use taut_firmware::settings::{SettingsStore, StoreError};

/// Power cuts the test must survive.
const CUTS_REQUIRED: u32 = 10_000;

const FLASH_BYTES: usize = (SETTINGS_PAGES * PAGE_SIZE) as usize;
const WORDS_PER_PAGE: usize = PAGE_SIZE as usize / WRITE_SIZE;

/// xorshift64*: a small deterministic generator, so a failure reproduces exactly.
#[derive(Clone)]
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }

    fn below(&mut self, bound: u32) -> u32 {
        (self.next() % u64::from(bound)) as u32
    }
}

#[derive(Clone, Copy, PartialEq, Eq, Debug)]
enum FlashError {
    /// Power was lost: this operation (and every one until reset) did not complete.
    PowerCut,
    /// Programming a double word that is not erased with anything but zeros (PROGERR).
    ProgrammingError,
    /// Misaligned or out-of-range access.
    Bounds,
}

impl NorFlashError for FlashError {
    fn kind(&self) -> NorFlashErrorKind {
        match self {
            Self::Bounds => NorFlashErrorKind::OutOfBounds,
            Self::PowerCut | Self::ProgrammingError => NorFlashErrorKind::Other,
        }
    }
}

/// The G431 flash model described in the module docs.
#[derive(Clone)]
struct G4Flash {
    bytes: Vec<u8>,
    programmed: Vec<bool>,
    /// Double-word operations left before the power fails, if a cut is armed.
    budget: Option<u32>,
    /// The power has failed; nothing works until [`G4Flash::reset`].
    dead: bool,
    rng: Rng,
    /// Operations that violated the PROGERR rule (must stay zero).
    programming_errors: u32,
    /// Double-word operations (programs and erases) performed so far.
    operations: u32,
    /// The last cut tore a page erase (rather than a program).
    cut_in_erase: bool,
}

impl G4Flash {
    fn new(seed: u64) -> Self {
        Self {
            bytes: vec![0xFF; FLASH_BYTES],
            programmed: vec![false; FLASH_BYTES / WRITE_SIZE],
            budget: None,
            dead: false,
            rng: Rng(seed),
            programming_errors: 0,
            operations: 0,
            cut_in_erase: false,
        }
    }

    fn arm_cut(&mut self, after_operations: u32) {
        self.budget = Some(after_operations);
    }

    /// Power comes back: the cut is disarmed and the flash works again.
    fn reset(&mut self) -> bool {
        let was_cut = self.dead;
        self.dead = false;
        self.budget = None;
        was_cut
    }

    /// Spends one double-word operation; `true` when the power fails during it.
    fn cut_now(&mut self) -> bool {
        self.operations += 1;
        match self.budget {
            Some(0) => {
                self.dead = true;
                self.budget = None;
                true
            }
            Some(left) => {
                self.budget = Some(left - 1);
                false
            }
            None => false,
        }
    }

    fn random_byte(&mut self) -> u8 {
        self.rng.next().to_le_bytes()[0]
    }
}

impl ErrorType for G4Flash {
    type Error = FlashError;
}

impl ReadNorFlash for G4Flash {
    const READ_SIZE: usize = 1;

    async fn read(&mut self, offset: u32, bytes: &mut [u8]) -> Result<(), FlashError> {
        if self.dead {
            return Err(FlashError::PowerCut);
        }
        let start = offset as usize;
        let source = self.bytes.get(start..start + bytes.len()).ok_or(FlashError::Bounds)?;
        bytes.copy_from_slice(source);
        Ok(())
    }

    fn capacity(&self) -> usize {
        FLASH_BYTES
    }
}

impl NorFlash for G4Flash {
    const WRITE_SIZE: usize = WRITE_SIZE;
    const ERASE_SIZE: usize = PAGE_SIZE as usize;

    async fn erase(&mut self, from: u32, to: u32) -> Result<(), FlashError> {
        if self.dead {
            return Err(FlashError::PowerCut);
        }
        let (from, to) = (from as usize, to as usize);
        if !from.is_multiple_of(PAGE_SIZE as usize)
            || !to.is_multiple_of(PAGE_SIZE as usize)
            || to > FLASH_BYTES
        {
            return Err(FlashError::Bounds);
        }
        for word in from / WRITE_SIZE..to / WRITE_SIZE {
            let range = word * WRITE_SIZE..(word + 1) * WRITE_SIZE;
            if self.cut_now() {
                // Torn erase: some bits of this word already read erased, the rest not yet.
                for index in range {
                    let erased = self.random_byte();
                    self.bytes[index] |= erased;
                }
                self.programmed[word] = true;
                self.cut_in_erase = true;
                return Err(FlashError::PowerCut);
            }
            self.bytes[range].fill(0xFF);
            self.programmed[word] = false;
        }
        debug_assert_eq!((to - from) % (WORDS_PER_PAGE * WRITE_SIZE), 0);
        Ok(())
    }

    async fn write(&mut self, offset: u32, bytes: &[u8]) -> Result<(), FlashError> {
        if self.dead {
            return Err(FlashError::PowerCut);
        }
        let start = offset as usize;
        if !start.is_multiple_of(WRITE_SIZE) || !bytes.len().is_multiple_of(WRITE_SIZE) {
            return Err(FlashError::Bounds);
        }
        if start + bytes.len() > FLASH_BYTES {
            return Err(FlashError::Bounds);
        }
        for (chunk_index, chunk) in bytes.chunks_exact(WRITE_SIZE).enumerate() {
            let address = start + chunk_index * WRITE_SIZE;
            let word = address / WRITE_SIZE;
            if self.programmed[word] && chunk.iter().any(|&byte| byte != 0) {
                self.programmed_error();
                return Err(FlashError::ProgrammingError);
            }
            let torn = self.cut_now();
            for (index, &byte) in chunk.iter().enumerate() {
                // Programming only clears bits; a torn program clears a random subset of
                // the bits it was clearing.
                let clearing = !byte;
                let cleared = if torn { clearing & self.random_byte() } else { clearing };
                self.bytes[address + index] &= !cleared;
            }
            self.programmed[word] = true;
            if torn {
                self.cut_in_erase = false;
                return Err(FlashError::PowerCut);
            }
        }
        Ok(())
    }
}

impl G4Flash {
    fn programmed_error(&mut self) {
        self.programming_errors += 1;
    }
}

/// Runs a future that never waits on anything but the (synchronous) flash model.
fn block_on<F: Future>(future: F) -> F::Output {
    let mut future = pin!(future);
    let mut context = Context::from_waker(Waker::noop());
    loop {
        if let Poll::Ready(output) = future.as_mut().poll(&mut context) {
            return output;
        }
    }
}

/// Record number `sequence`: the core's own record format, with the counters (and so the
/// CRC and most bytes of the tail) different for every save.
fn record(sequence: u32) -> [u8; RECORD_LEN] {
    let counters = Counters {
        pulls: sequence,
        string_used_mm: sequence.wrapping_mul(7_919),
        boots: sequence / 8,
    };
    Record { counters, ..Record::default() }.encode()
}

fn open(flash: G4Flash) -> SettingsStore<G4Flash> {
    let range = 0..SETTINGS_PAGES * PAGE_SIZE;
    SettingsStore::new(flash, range).expect("four pages are a valid range")
}

fn load(store: &mut SettingsStore<G4Flash>) -> Option<Vec<u8>> {
    block_on(store.load()).expect("load after reset must succeed").map(<[u8]>::to_vec)
}

#[test]
fn power_cut() {
    let mut rng = Rng(0x7A07_5EED);
    let mut store = open(G4Flash::new(0x0F1A_5B00));
    assert_eq!(load(&mut store), None, "a blank store holds no record");

    let mut durable: Option<Vec<u8>> = None;
    let (mut cuts, mut completed, mut new_after_cut, mut sequence) = (0u32, 0u32, 0u32, 0u32);
    let mut cuts_in_erase = 0u32;
    while cuts < CUTS_REQUIRED {
        sequence += 1;
        let new = record(sequence);
        let mut flash = store.into_flash();
        // One save in eight runs uncut. The others are cut at a uniformly random double-word
        // operation of the save, so cuts land in appends, in page erases and in the moves of
        // live data between pages in proportion to the time each takes. The save's length is
        // measured on a copy of the flash first.
        if sequence % 8 != 0 {
            let mut rehearsal = open(flash.clone());
            let before = flash.operations;
            block_on(rehearsal.save(&new)).expect("an uncut save succeeds");
            let length = rehearsal.into_flash().operations - before;
            flash.arm_cut(rng.below(length.max(1)));
        }
        store = open(flash);
        let result = block_on(store.save(&new));

        // Reset: power returns, the firmware boots and opens the store afresh.
        let mut flash = store.into_flash();
        let was_cut = flash.reset();
        if was_cut && flash.cut_in_erase {
            cuts_in_erase += 1;
        }
        assert_eq!(flash.programming_errors, 0, "save {sequence} broke the PROGERR rule");
        store = open(flash);
        let loaded = load(&mut store);

        match (result, was_cut) {
            (Ok(()), false) => {
                completed += 1;
                assert_eq!(loaded.as_deref(), Some(&new[..]), "save {sequence} completed");
                durable = loaded;
            }
            (Err(StoreError::Flash), true) => {
                cuts += 1;
                let old_or_new = loaded == durable || loaded.as_deref() == Some(&new[..]);
                assert!(
                    old_or_new,
                    "save {sequence} cut: read back neither the previous record nor the new one \
                     (lost or garbled): {loaded:?}"
                );
                if loaded.as_deref() == Some(&new[..]) {
                    new_after_cut += 1;
                }
                durable = loaded;
            }
            (result, was_cut) => panic!("save {sequence}: {result:?}, power cut: {was_cut}"),
        }
        // What the firmware hands the machine at boot must be a valid record.
        if let Some(bytes) = &durable {
            let decoded = Record::decode(bytes).expect("the loaded record decodes");
            assert!(decoded.counters.pulls <= sequence);
        }
    }
    println!(
        "settings power-cut test: {cuts} power cuts survived ({cuts_in_erase} during a page \
         erase, {} during a program; {new_after_cut} kept the new record, {} the previous one), \
         {completed} uncut saves, 0 records lost or garbled",
        cuts - cuts_in_erase,
        cuts - new_after_cut
    );
    assert!(cuts_in_erase > 0 && cuts_in_erase < cuts, "cuts must land in both kinds of operation");
}
