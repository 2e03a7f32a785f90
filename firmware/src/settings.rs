//! The persisted record on internal flash, kept power-safe by sequential-storage.
//!
//! # Theory of operation
//!
//! The core decides *what* is persisted — settings, calibration, presets, counters — and
//! encodes it as one fixed-length byte record (`taut_core::store::Record::encode`); it also
//! validates what comes back (`Record::decode`). This module only keeps those bytes on flash
//! and hands them back, whole, after any power cut.
//!
//! The store is a [`sequential_storage::map::MapStorage`] with one key ([`RECORD_KEY`]) over
//! the pages of [`crate::flash_layout::SETTINGS_RANGE`]. sequential-storage never overwrites
//! data in place: a save appends a new item (header with CRC, then data with CRC) to the
//! current page and only afterwards is the old item considered superseded; full pages are
//! recycled one at a time, moving any live item first. A power cut therefore leaves either
//! the previous item or the new one as the newest *valid* item — a torn item fails its CRC
//! and is skipped — and the crate repairs half-done page transitions on the next access.
//! `power_cut` in `tests/power_cut.rs` cuts power at random points of more than 10 000 saves
//! on a model of the G431's flash and checks that the previous or the new record always
//! reads back whole.
//!
//! The flash is taken through `embedded-storage-async`'s `NorFlash`, so the same code runs on
//! the board (embassy-stm32's flash driver) and on the host's model.

use core::ops::Range;
use embedded_storage_async::nor_flash::NorFlash;
use sequential_storage::cache::{Cache, Uncached};
use sequential_storage::map::{MapConfig, MapStorage};

/// The map key under which the record is stored.
pub const RECORD_KEY: u8 = 0;

/// Bytes of working buffer: the longest record this store accepts plus its one-byte key,
/// rounded up to the flash's 8-byte program unit.
pub const BUFFER_LEN: usize = 256;

/// The longest record [`SettingsStore::save`] accepts.
pub const MAX_RECORD_LEN: usize = BUFFER_LEN - 8;

/// Why the store could not do what was asked.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug)]
pub enum StoreError {
    /// The flash range is not a whole number (at least two) of pages.
    BadRange,
    /// The record is longer than [`MAX_RECORD_LEN`].
    RecordTooLong,
    /// The flash driver reported an error (programming error, or power lost mid-operation).
    Flash,
    /// The pages hold data the store cannot make sense of even after repair.
    Corrupted,
    /// No page can be freed for the new record.
    Full,
    /// Any other failure of the storage layer.
    Storage,
}

impl<E> From<sequential_storage::Error<E>> for StoreError {
    fn from(error: sequential_storage::Error<E>) -> Self {
        match error {
            sequential_storage::Error::Storage { .. } => Self::Flash,
            sequential_storage::Error::Corrupted { .. } => Self::Corrupted,
            sequential_storage::Error::FullStorage => Self::Full,
            sequential_storage::Error::ItemTooBig
            | sequential_storage::Error::BufferTooSmall(_)
            | sequential_storage::Error::BufferTooBig => Self::RecordTooLong,
            _ => Self::Storage,
        }
    }
}

/// The working buffer, aligned for the flash driver's double-word writes.
#[repr(align(8))]
struct Buffer([u8; BUFFER_LEN]);

/// The record store on a range of flash pages.
pub struct SettingsStore<F: NorFlash> {
    map: MapStorage<u8, F, Cache<Uncached, Uncached, Uncached, u8>>,
    buffer: Buffer,
}

impl<F: NorFlash> SettingsStore<F> {
    /// A store on `range` (offsets into `flash`).
    ///
    /// # Errors
    /// [`StoreError::BadRange`] unless `range` is at least two whole pages of `flash`.
    pub fn new(flash: F, range: Range<u32>) -> Result<Self, StoreError> {
        let config = MapConfig::<F>::try_new(range).map_err(|_| StoreError::BadRange)?;
        Ok(Self {
            map: MapStorage::new(flash, config, Cache::new_uncached()),
            buffer: Buffer([0; BUFFER_LEN]),
        })
    }

    /// The newest record saved, or `None` on a store that has never been written.
    ///
    /// # Errors
    /// [`StoreError`] when the flash cannot be read or its contents cannot be repaired.
    pub async fn load(&mut self) -> Result<Option<&[u8]>, StoreError> {
        Ok(self.map.fetch_item::<&[u8]>(&mut self.buffer.0, &RECORD_KEY).await?)
    }

    /// Saves `record` as the newest record. If power is lost during the save, the next
    /// [`SettingsStore::load`] returns either this record or the previous one, whole.
    ///
    /// # Errors
    /// [`StoreError::RecordTooLong`] beyond [`MAX_RECORD_LEN`] bytes; otherwise a flash or
    /// storage failure.
    pub async fn save(&mut self, record: &[u8]) -> Result<(), StoreError> {
        if record.len() > MAX_RECORD_LEN {
            return Err(StoreError::RecordTooLong);
        }
        Ok(self.map.store_item(&mut self.buffer.0, &RECORD_KEY, &record).await?)
    }

    /// Gives the flash back (to re-open the store, as after a reset).
    pub fn into_flash(self) -> F {
        self.map.destroy().0
    }
}
