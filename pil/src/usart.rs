//! USART2, DMA1 and DMAMUX1 as the machine link uses them (RM0440 chapters 37, 12 and 13),
//! and the PC's end of the ST-LINK virtual COM port.
//!
//! The USART's registers hold what the firmware writes; its line is a byte queue each way,
//! moved at the rate its BRR sets ([`SerialPort::bytes_per_second`]). A received byte goes
//! where the DMA channel that DMAMUX routes `USART2_RX` to says (memory address, remaining
//! count, circular reload) — or, with no channel ready, is lost, as on the part with overrun
//! detection off; a byte to send comes from the channel routed to `USART2_TX` while its count
//! is not zero. The bench moves the bytes and the memory ([`crate::bench::Bench`]); this
//! module decides only where each byte goes or comes from, and flags what a correct binding
//! never does (a channel's address or count written while it is enabled, a baud rate the
//! PC's port would not read).

use crate::soc::Registers;

/// DMAMUX1 request inputs: USART2's receive and transmit.
pub const USART2_RX_REQUEST: u32 = 26;
/// See [`USART2_RX_REQUEST`].
pub const USART2_TX_REQUEST: u32 = 27;

/// `DMA_CCRx` bits.
const EN: u32 = 1;
const DIR_FROM_MEMORY: u32 = 1 << 4;
const CIRC: u32 = 1 << 5;
const MINC: u32 = 1 << 7;
/// Bits of `DMA_CCRx` that exist.
const CCR_MASK: u32 = 0x7FFF;

/// `USART_CR1`: UE, RE, TE.
const UE: u32 = 1;
const RE: u32 = 1 << 2;
const TE: u32 = 1 << 3;
/// `USART_CR3`: DMAR, DMAT.
const DMAR: u32 = 1 << 6;
const DMAT: u32 = 1 << 7;

/// One DMA channel.
#[derive(Clone, Debug, Default)]
pub struct Channel {
    /// `CCRx`.
    pub ccr: u32,
    /// `CNDTRx`: transfers left.
    pub cndtr: u32,
    /// `CPARx`.
    pub cpar: u32,
    /// `CMARx`.
    pub cmar: u32,
    /// The count programmed when the channel was enabled (the circular reload).
    initial: u32,
    /// Transfers done since the enable or the last reload: the memory offset.
    done: u32,
}

impl Channel {
    fn enabled(&self) -> bool {
        self.ccr & EN != 0
    }
}

/// USART2, DMA1's six channels and DMAMUX1's routing (see the module docs).
#[derive(Clone, Debug)]
pub struct SerialPort {
    /// USART2's registers.
    pub usart: Registers,
    /// DMA1's channels 1-6.
    pub channels: [Channel; 6],
    /// DMA1's interrupt status (`ISR`): TCIF/HTIF/GIF per channel.
    pub dma_isr: u32,
    /// DMAMUX1's channel configuration registers `C0CR`-`C15CR`.
    pub mux: [u32; 16],
    /// Bytes received with no DMA channel ready for them (lost).
    pub lost: u64,
}

impl Default for SerialPort {
    fn default() -> Self {
        Self::new()
    }
}

/// USART2's registers and reset values: CR1, CR2, CR3, BRR, GTPR, RTOR, PRESC.
const USART_RESET: &[(u32, u32)] =
    &[(0x00, 0), (0x04, 0), (0x08, 0), (0x0C, 0), (0x10, 0), (0x14, 0), (0x2C, 0)];

impl SerialPort {
    /// At reset.
    pub fn new() -> Self {
        Self {
            usart: Registers::new(USART_RESET),
            channels: Default::default(),
            dma_isr: 0,
            mux: [0; 16],
            lost: 0,
        }
    }

    /// The line's rate, bytes a second (10 bits a byte, 8N1), at kernel clock `pclk_hz`; 0
    /// while the USART is off or its BRR is unset.
    pub fn bytes_per_second(&self, pclk_hz: u64) -> f64 {
        let brr = self.usart.value(0x0C) & 0xFFFF;
        if self.usart.value(0x00) & UE == 0 || brr < 16 {
            return 0.0;
        }
        pclk_hz as f64 / f64::from(brr) / 10.0
    }

    /// A USART2 register read (`offset` from its base).
    pub fn read_usart(&self, offset: u32) -> Option<u32> {
        match offset {
            // ISR: TXE and TC (the DMA keeps the transmitter fed), TEACK/REACK with TE/RE.
            0x1C => {
                let cr1 = self.usart.value(0x00);
                let ack = if cr1 & UE != 0 {
                    (u32::from(cr1 & TE != 0) << 21) | (u32::from(cr1 & RE != 0) << 22)
                } else {
                    0
                };
                Some((1 << 7) | (1 << 6) | ack)
            }
            // RDR: the DMA takes every byte; a read finds nothing new.
            0x24 => Some(0),
            _ => self.usart.get(offset),
        }
    }

    /// A USART2 register write; `Err` for a misuse.
    pub fn write_usart(&mut self, offset: u32, value: u32) -> Result<bool, String> {
        match offset {
            // ICR, RQR: flags the model does not raise; TDR: the link writes only by DMA.
            0x20 | 0x18 => Ok(true),
            0x28 => Err("USART2_TDR written by the CPU (the link transmits by DMA)".into()),
            0x0C if self.usart.value(0x00) & UE != 0 => {
                Err("USART2_BRR written while the USART is enabled (RM0440: UE must be 0)".into())
            }
            _ => Ok(self.usart.set(offset, value)),
        }
    }

    /// A DMA1 register read (`offset` from its base).
    pub fn read_dma(&self, offset: u32) -> Option<u32> {
        match offset {
            0x00 => Some(self.dma_isr),
            0x04 => Some(0),
            0x08..=0x7F => {
                let (index, register) = Self::channel_register(offset)?;
                let c = &self.channels[index];
                Some(match register {
                    0 => c.ccr,
                    1 => c.cndtr,
                    2 => c.cpar,
                    3 => c.cmar,
                    _ => return None,
                })
            }
            _ => None,
        }
    }

    /// A DMA1 register write; `Err` for a misuse.
    pub fn write_dma(&mut self, offset: u32, value: u32) -> Result<bool, String> {
        match offset {
            0x04 => {
                // IFCR: clears the channel's flags (a GIF clear clears all four).
                let mut clear = value;
                for channel in 0..6 {
                    if value >> (4 * channel) & 1 != 0 {
                        clear |= 0xF << (4 * channel);
                    }
                }
                self.dma_isr &= !clear;
                Ok(true)
            }
            0x08..=0x7F => {
                let Some((index, register)) = Self::channel_register(offset) else {
                    return Ok(false);
                };
                let c = &mut self.channels[index];
                if register != 0 && c.enabled() {
                    return Err(format!(
                        "DMA1 channel {} address or count written while enabled (RM0440: \
                         written only with EN = 0)",
                        index + 1
                    ));
                }
                match register {
                    0 => {
                        let enabling = !c.enabled() && value & EN != 0;
                        c.ccr = value & CCR_MASK;
                        if enabling {
                            c.initial = c.cndtr;
                            c.done = 0;
                        }
                    }
                    1 => c.cndtr = value & 0xFFFF,
                    2 => c.cpar = value,
                    3 => c.cmar = value,
                    _ => return Ok(false),
                }
                Ok(true)
            }
            _ => Ok(false),
        }
    }

    /// A DMAMUX1 register read.
    pub fn read_mux(&self, offset: u32) -> Option<u32> {
        self.mux.get((offset / 4) as usize).copied().filter(|_| offset < 0x40)
    }

    /// A DMAMUX1 register write.
    pub fn write_mux(&mut self, offset: u32, value: u32) -> bool {
        match self.mux.get_mut((offset / 4) as usize) {
            Some(slot) if offset < 0x40 => {
                *slot = value & 0x01FF_FF7F;
                true
            }
            _ => false,
        }
    }

    /// Channel index and register (0 CCR, 1 CNDTR, 2 CPAR, 3 CMAR) of a DMA1 offset.
    fn channel_register(offset: u32) -> Option<(usize, u32)> {
        let relative = offset.checked_sub(0x08)?;
        let (index, register) = ((relative / 0x14) as usize, (relative % 0x14) / 4);
        (index < 6 && register < 4).then_some((index, register))
    }

    /// The enabled channel DMAMUX routes `request` to, moving data in direction `from_memory`.
    fn routed(&mut self, request: u32, from_memory: bool, peripheral: u32) -> Option<usize> {
        let index = self.mux.iter().take(6).position(|&c| c & 0x7F == request)?;
        let c = &self.channels[index];
        let direction = c.ccr & DIR_FROM_MEMORY != 0;
        (c.enabled() && direction == from_memory && c.cndtr > 0 && c.cpar == peripheral)
            .then_some(index)
    }

    /// Moves one transfer of channel `index`: the memory address it used. Sets the flags,
    /// reloads in circular mode.
    fn transfer(&mut self, index: usize) -> u32 {
        let c = &mut self.channels[index];
        let address = if c.ccr & MINC != 0 { c.cmar.wrapping_add(c.done) } else { c.cmar };
        c.done += 1;
        c.cndtr -= 1;
        let shift = 4 * index as u32;
        if c.cndtr == c.initial / 2 {
            self.dma_isr |= (1 | 4) << shift;
        }
        let c = &mut self.channels[index];
        if c.cndtr == 0 {
            self.dma_isr |= (1 | 2) << shift;
            if c.ccr & CIRC != 0 {
                c.cndtr = c.initial;
                c.done = 0;
            }
        }
        address
    }

    /// Where a byte arriving on the line now goes: the RAM address the receive channel
    /// writes it to, or `None` (lost: the receiver or its DMA not ready).
    pub fn receive(&mut self) -> Option<u32> {
        let cr1 = self.usart.value(0x00);
        let ready = cr1 & UE != 0 && cr1 & RE != 0 && self.usart.value(0x08) & DMAR != 0;
        let channel = if ready { self.routed(USART2_RX_REQUEST, false, RDR) } else { None };
        match channel {
            Some(index) => Some(self.transfer(index)),
            None => {
                self.lost += 1;
                None
            }
        }
    }

    /// The RAM address of the next byte the transmitter sends, if the transmit channel has
    /// one.
    pub fn transmit(&mut self) -> Option<u32> {
        let cr1 = self.usart.value(0x00);
        if cr1 & UE == 0 || cr1 & TE == 0 || self.usart.value(0x08) & DMAT == 0 {
            return None;
        }
        let index = self.routed(USART2_TX_REQUEST, true, TDR)?;
        Some(self.transfer(index))
    }
}

/// USART2's receive and transmit data registers.
pub const RDR: u32 = 0x4000_4424;
/// See [`RDR`].
pub const TDR: u32 = 0x4000_4428;

#[cfg(test)]
mod tests {
    use super::*;

    fn port() -> SerialPort {
        let mut p = SerialPort::new();
        p.write_mux(0, USART2_RX_REQUEST);
        p.write_mux(4, USART2_TX_REQUEST);
        // Channel 1: receive into 0x2000_0100, 4 bytes, circular.
        p.write_dma(0x10, RDR).unwrap();
        p.write_dma(0x14, 0x2000_0100).unwrap();
        p.write_dma(0x0C, 4).unwrap();
        p.write_dma(0x08, MINC | CIRC | EN).unwrap();
        p.write_usart(0x0C, 1476).unwrap();
        p.write_usart(0x08, DMAR | DMAT).unwrap();
        p.write_usart(0x00, UE | RE | TE).unwrap();
        p
    }

    #[test]
    fn received_bytes_go_round_the_ring() {
        let mut p = port();
        let addresses: Vec<u32> = (0..6).map(|_| p.receive().unwrap()).collect();
        assert_eq!(
            addresses,
            [0x2000_0100, 0x2000_0101, 0x2000_0102, 0x2000_0103, 0x2000_0100, 0x2000_0101]
        );
        assert_eq!(p.read_dma(0x0C), Some(2));
        assert_ne!(p.dma_isr & 2, 0, "TCIF1 at the wrap");
        assert_eq!(p.lost, 0);
    }

    #[test]
    fn a_transmit_span_is_sent_once_and_stops() {
        let mut p = port();
        assert_eq!(p.transmit(), None, "no channel yet");
        p.write_dma(0x24, TDR).unwrap();
        p.write_dma(0x28, 0x2000_0200).unwrap();
        p.write_dma(0x20, 3).unwrap();
        p.write_dma(0x1C, DIR_FROM_MEMORY | MINC | EN).unwrap();
        let sent: Vec<u32> = std::iter::from_fn(|| p.transmit()).collect();
        assert_eq!(sent, [0x2000_0200, 0x2000_0201, 0x2000_0202]);
        assert_eq!(p.read_dma(0x20), Some(0));
        assert!(p.write_dma(0x20, 5).is_err(), "count written while enabled");
        p.write_dma(0x1C, 0).unwrap();
        p.write_dma(0x20, 5).unwrap();
    }

    #[test]
    fn without_its_dma_a_byte_is_lost() {
        let mut p = port();
        p.write_dma(0x08, 0).unwrap();
        assert_eq!(p.receive(), None);
        assert_eq!(p.lost, 1);
    }

    #[test]
    fn the_rate_is_the_clock_over_brr() {
        let p = port();
        let rate = p.bytes_per_second(170_000_000);
        assert!((rate - 11_517.6).abs() < 1.0, "{rate}");
        assert!(SerialPort::new().bytes_per_second(170_000_000) == 0.0);
    }
}
