//! The settings store on the board: the core's record on flash pages 60–63.
//!
//! The machine raises `Outputs::store` when its record changes; the control tick hands a copy
//! of the record to [`writer`], a thread-mode task, through a signal (only the newest record
//! is kept — an older one still waiting is superseded), and the writer encodes it: the
//! encoding (magic, version, CRC: ≈ 4 000 instructions, `scripts/tick-cost`) runs at the
//! lowest priority, never on the control tick. A page erase stalls instruction
//! fetch from flash for ~22 ms (RM0440 section 3.3.7; the G431 has a single bank), during
//! which neither real-time loop can run; so while the store works the bridge's main output is
//! held off ([`flash_busy`]) and the motor freewheels. The machine asks for a store when it is
//! idle, so in practice no torque is lost.

use core::sync::atomic::{AtomicBool, Ordering};
use embassy_embedded_hal::adapter::BlockingAsync;
use embassy_stm32::Peri;
use embassy_stm32::flash::{Blocking, Flash};
use embassy_stm32::peripherals::FLASH;
use embassy_sync::blocking_mutex::raw::CriticalSectionRawMutex;
use embassy_sync::signal::Signal;
use static_cell::StaticCell;
use taut_core::store::{RECORD_LEN, Record, StoreError};
use taut_firmware::flash_layout::SETTINGS_RANGE;
use taut_firmware::settings::SettingsStore;

use super::bridge;

/// The store over embassy-stm32's blocking flash driver.
pub type Store = SettingsStore<BlockingAsync<Flash<'static, Blocking>>>;

/// The newest record waiting to be written.
pub static REQUEST: Signal<CriticalSectionRawMutex, Record> = Signal::new();

static FLASH_BUSY: AtomicBool = AtomicBool::new(false);

/// Whether a flash operation is in progress (the bridge must stay off).
pub fn flash_busy() -> bool {
    FLASH_BUSY.load(Ordering::Acquire)
}

/// Opens the store and reads the record the machine starts from. A blank store (first boot)
/// yields the default record; an unreadable store or a record the core rejects yields the
/// core's error, which [`Machine::from_stored`](taut_core::machine::Machine::from_stored) turns
/// into defaults plus a visible notice — the firmware only reports what the flash returned.
pub async fn open(flash: Peri<'static, FLASH>) -> (Option<Store>, Result<Record, StoreError>) {
    let flash = BlockingAsync::new(Flash::new_blocking(flash));
    let Ok(mut store) = SettingsStore::new(flash, SETTINGS_RANGE) else {
        taut_firmware::error!("settings: flash range rejected");
        // No usable store: the machine runs on defaults and shows the store notice.
        return (None, Err(StoreError::CrcMismatch));
    };
    let record = match store.load().await {
        Ok(Some(bytes)) => Record::decode(bytes),
        Ok(None) => Ok(Record::default()),
        Err(_) => {
            taut_firmware::warn!("settings: store unreadable");
            Err(StoreError::CrcMismatch)
        }
    };
    (Some(store), record)
}

/// [`open`], polled to completion right here: the store is async (sequential-storage) over a
/// blocking flash driver, so it never actually waits. Its state lives on the stack for the
/// read only (not inlined, so not in the caller's frame), instead of in a task's static
/// storage for good; the store itself moves to its own static, where [`writer`] uses it.
#[inline(never)]
pub fn read(
    flash: Peri<'static, FLASH>,
) -> (Option<&'static mut Store>, Result<Record, StoreError>) {
    static STORE: StaticCell<Store> = StaticCell::new();
    let (store, record) = embassy_futures::block_on(open(flash));
    (store.map(|store| STORE.init(store)), record)
}

/// Writes each requested record. Without a usable store (see [`open`]) requests are dropped.
#[embassy_executor::task]
pub async fn writer(store: Option<&'static mut Store>) {
    let Some(store) = store else { return };
    loop {
        let record: [u8; RECORD_LEN] = REQUEST.wait().await.encode();
        FLASH_BUSY.store(true, Ordering::Release);
        bridge::set_main_output(false);
        let result = store.save(&record).await;
        FLASH_BUSY.store(false, Ordering::Release);
        if result.is_err() {
            taut_firmware::error!("settings: save failed");
        }
    }
}
