//! The machine link on USART2 (PA2 TX, PA3 RX: the NUCLEO's ST-LINK virtual COM port), moved
//! by DMA and served from the control tick.
//!
//! # Theory of operation
//!
//! The link has no interrupt and no task of its own. Two DMA1 channels, routed by DMAMUX1,
//! move every byte: channel 1 writes what USART2 receives into a ring in RAM, circularly,
//! for good; channel 2 sends one span of the transmit ring at a time
//! (`taut_firmware::link` holds the ring arithmetic). The USART raises no interrupt and its
//! overrun detection is off (a byte the DMA has not taken is overwritten, never a stalled
//! receiver), and a framing or noise error does not stop the DMA, so garbage, a break or an
//! unplugged cable cannot stop reception or reach anything but the deframer.
//!
//! The control tick calls [`Link::service`] once per millisecond **after** it has applied the
//! machine's outputs to the drive, beeper, panel and store, so the link never delays them:
//! it hands the bytes received since the last tick to the `taut-link` server (which answers
//! each complete request into the transmit ring), lets the server observe the tick (live
//! samples and events while the host streams), and restarts the transmit DMA on the next span.
//! The work is bounded by what the line can deliver between two ticks (≈ 11.5 bytes, at most
//! the receive ring after a flash stall) and by the transmit ring's room. The fast loop
//! preempts it as it preempts the rest of the tick. The server sees the machine only as a
//! `LinkAccess`, so no byte on the line can move the machine (REQ-LINK-02).

use core::sync::atomic::{Ordering, compiler_fence};
use embassy_stm32::Peri;
use embassy_stm32::pac;
use embassy_stm32::peripherals::{PA2, PA3};
use static_cell::StaticCell;
use taut_core::io::{Inputs, Outputs};
use taut_core::machine::Machine;
use taut_core::machine::access::LinkAccess;
use taut_firmware::link::{FIRMWARE_VERSION, RX_RING, RxCursor, TxRing, board_id};
use taut_link::{BAUD, Server, TX_QUEUE};

use super::SYSCLK_HZ;

/// DMA1 channel 1 (index 0): USART2 receive, circular.
const RX_CHANNEL: usize = 0;
/// DMA1 channel 2 (index 1): USART2 transmit, one span at a time.
const TX_CHANNEL: usize = 1;
/// DMAMUX1 request inputs (RM0440, table "DMAMUX: assignment of multiplexer inputs to
/// resources"): `USART2_RX` and `USART2_TX`.
const USART2_RX_REQUEST: u8 = 26;
const USART2_TX_REQUEST: u8 = 27;
/// USART2's kernel clock is PCLK1 (`RCC_CCIPR.USART2SEL` = 00 at reset), which runs at the
/// system clock (APB1 undivided); BRR is the clock over the baud rate, rounded.
const BRR: u32 = (SYSCLK_HZ + BAUD / 2) / BAUD;
/// `USART_CR1`: UE (bit 0), RE (bit 2), TE (bit 3); FIFO off, 8 data bits, no parity.
const CR1_ENABLED: u32 = 1 | 1 << 2 | 1 << 3;
/// `USART_CR3`: DMAR (bit 6), DMAT (bit 7), OVRDIS (bit 12).
const CR3_DMA: u32 = 1 << 6 | 1 << 7 | 1 << 12;
/// `DMA_CCRx`: EN (bit 0), DIR (bit 4: read from memory), CIRC (bit 5), MINC (bit 7); byte
/// sizes, low priority, no interrupt.
const CCR_EN: u32 = 1;
const CCR_DIR_FROM_MEMORY: u32 = 1 << 4;
const CCR_CIRC: u32 = 1 << 5;
const CCR_MINC: u32 = 1 << 7;
/// The receive ring's length as the DMA's transfer count.
const RX_RING_COUNT: u16 = {
    assert!(RX_RING <= 0xFFFF, "the DMA counts in 16 bits");
    #[allow(clippy::cast_possible_truncation, reason = "checked just above")]
    let count = RX_RING as u16;
    count
};
/// The MCU's 96-bit unique id (RM0440 section 48.1).
const UID_BASE: usize = 0x1FFF_7590;
/// Bytes handed to the server per call: the tick copies the DMA's ring through this much of
/// its stack.
const CHUNK: usize = 32;

/// The link's state, in the tick's care.
pub struct Link {
    server: Server,
    /// The receive ring, written by DMA channel 1 only: read with volatile reads.
    rx: *const u8,
    cursor: RxCursor,
    tx: &'static mut TxRing<TX_QUEUE>,
}

// SAFETY: `Link` lives in the control tick's state and is used from that interrupt only; the
// raw pointer is to a static ring only the DMA writes.
unsafe impl Send for Link {}

impl Link {
    /// Sets up USART2 and both DMA channels and starts receiving. Called once at start-up,
    /// before the tick's interrupt is unmasked.
    #[inline(never)]
    pub fn init(tx_pin: Peri<'static, PA2>, rx_pin: Peri<'static, PA3>) -> Self {
        // The pins are claimed here (their tokens consumed) and programmed at register level
        // below.
        let (_tx, _rx) = (tx_pin, rx_pin);
        static RX: StaticCell<[u8; RX_RING]> = StaticCell::new();
        static TX: StaticCell<TxRing<TX_QUEUE>> = StaticCell::new();
        let rx: *mut u8 = RX.init([0; RX_RING]).as_mut_ptr();
        let tx = TX.init(TxRing::new());

        pac::RCC.ahb1enr().modify(|w| {
            w.set_dma1en(true);
            w.set_dmamux1en(true);
        });
        pac::RCC.apb1enr1().modify(|w| w.set_usart2en(true));

        // PA2 and PA3 to alternate function 7 (USART2), the receive line pulled up so an
        // open line idles as a stop bit.
        let gpio = pac::GPIOA;
        gpio.afr(0).modify(|w| {
            w.set_afr(2, 7);
            w.set_afr(3, 7);
        });
        gpio.pupdr().modify(|w| w.set_pupdr(3, pac::gpio::vals::Pupdr::PULL_UP));
        gpio.moder().modify(|w| {
            w.set_moder(2, pac::gpio::vals::Moder::ALTERNATE);
            w.set_moder(3, pac::gpio::vals::Moder::ALTERNATE);
        });

        pac::DMAMUX1.ccr(RX_CHANNEL).write(|w| w.set_dmareq_id(USART2_RX_REQUEST));
        pac::DMAMUX1.ccr(TX_CHANNEL).write(|w| w.set_dmareq_id(USART2_TX_REQUEST));

        let usart = pac::USART2;
        let data = usart.rdr().as_ptr() as usize;
        let transmit = usart.tdr().as_ptr() as usize;
        let receive = pac::DMA1.ch(RX_CHANNEL);
        receive.par().write_value(address(data));
        receive.mar().write_value(address(rx as usize));
        receive.ndtr().write(|w| w.set_ndt(RX_RING_COUNT));
        receive.cr().write_value(pac::bdma::regs::Cr(CCR_MINC | CCR_CIRC | CCR_EN));
        pac::DMA1.ch(TX_CHANNEL).par().write_value(address(transmit));

        usart.brr().write_value(pac::usart::regs::Brr(BRR));
        usart.cr3().write_value(pac::usart::regs::Cr3(CR3_DMA));
        usart.cr1().write_value(pac::usart::regs::Cr1(CR1_ENABLED));

        // SAFETY: the unique id is a read-only factory word in system memory.
        let uid = |offset: usize| unsafe {
            core::ptr::read_volatile(UID_BASE.wrapping_add(offset) as *const u32)
        };
        let board = board_id([uid(0), uid(4), uid(8)]);
        Self { server: Server::new(board, FIRMWARE_VERSION), rx, cursor: RxCursor::default(), tx }
    }

    /// One tick's link work (see the module docs): the bytes received, the tick observed,
    /// the next span sent. Not inlined: the processor-in-the-loop bench times it by its
    /// symbol, inside the tick.
    #[inline(never)]
    pub fn service(&mut self, machine: &mut Machine, inputs: &Inputs, outputs: &Outputs) {
        let remaining = pac::DMA1.ch(RX_CHANNEL).ndtr().read().ndt();
        // The bytes the count says are written are read after the count.
        compiler_fence(Ordering::Acquire);
        let mut access = LinkAccess::new(machine);
        for span in self.cursor.arrived(remaining) {
            let mut chunk = [0u8; CHUNK];
            let mut filled = 0;
            for index in span {
                // SAFETY: `index` < RX_RING (RxCursor's spans lie in the ring), and the DMA
                // wrote this byte before its count said so.
                let byte = unsafe { core::ptr::read_volatile(self.rx.wrapping_add(index)) };
                if let Some(slot) = chunk.get_mut(filled) {
                    *slot = byte;
                    filled = filled.saturating_add(1);
                }
                if filled == CHUNK {
                    self.server.receive(&chunk, &mut access, self.tx);
                    filled = 0;
                }
            }
            if let Some(rest) = chunk.get(..filled) {
                self.server.receive(rest, &mut access, self.tx);
            }
        }
        self.server.observe(inputs, outputs, &access, self.tx);
        self.transmit();
    }

    /// Frees the span the DMA finished and starts the next.
    fn transmit(&mut self) {
        let channel = pac::DMA1.ch(TX_CHANNEL);
        if self.tx.sending() {
            if channel.ndtr().read().ndt() != 0 {
                return;
            }
            self.tx.finish();
        }
        let Some(span) = self.tx.start() else { return };
        let start = self.tx.bytes().as_ptr().wrapping_add(span.start) as usize;
        channel.cr().write_value(pac::bdma::regs::Cr(0));
        channel.mar().write_value(address(start));
        channel.ndtr().write(|w| w.set_ndt(u16::try_from(span.len()).unwrap_or(0)));
        // The frame's bytes are in RAM before the DMA may read them.
        compiler_fence(Ordering::Release);
        channel.cr().write_value(pac::bdma::regs::Cr(CCR_DIR_FROM_MEMORY | CCR_MINC | CCR_EN));
    }
}

/// A 32-bit bus address (the part's address space is 32 bits).
fn address(pointer: usize) -> u32 {
    u32::try_from(pointer).unwrap_or(0)
}
