//! A real ECU board: STM32F405 (Cortex-M4F), bxCAN1 on PB8 (RX) / PB9
//! (TX) through a transceiver, 500 kbit/s, the 16 MHz internal oscillator
//! as system clock (APB1 = 16 MHz). Built in CI compile-only.
//!
//! The bxCAN driver is written here against the registers of the `stm32f4`
//! peripheral access crate (RM0090 chapter 32). The `bxcan` crate builds
//! with this toolchain too, but links panic paths (filter-bank and
//! mailbox index asserts), which the firmware's no-panic check refuses;
//! the few registers the ECU needs (one FIFO, three mailboxes, two filter
//! banks) are simple enough to drive directly.

use embedded_can::{ExtendedId, Frame, Id, StandardId};
use hp_ctrl::can::ecu::{Ecu, Link};
use hp_ctrl::can::CanFrame;
use stm32f4::stm32f405 as pac;

use crate::run::{run, Timing};

/// System clock after reset (HSI), Hz.
pub const SYSCLK_HZ: u32 = 16_000_000;

/// Bit timing for 500 kbit/s at APB1 = 16 MHz: prescaler 2 (125 ns time
/// quanta), 16 quanta per bit: sync 1 + TS1 13 + TS2 2 (sample point
/// 87.5 %), SJW 1. BTR = (SJW-1)<<24 | (TS2-1)<<20 | (TS1-1)<<16 | (BRP-1).
pub const BTR_500K_AT_16MHZ: u32 = (1 << 20) | (12 << 16) | 1;

// MCR / MSR bits.
const MCR_INRQ: u32 = 1 << 0;
const MCR_TXFP: u32 = 1 << 2;
const MCR_ABOM: u32 = 1 << 6;
const MSR_INAK: u32 = 1 << 0;
// RF0R bits.
const RFR_FMP_MASK: u32 = 0b11;
const RFR_FOVR: u32 = 1 << 4;
const RFR_RFOM: u32 = 1 << 5;
// TSR bits.
const TSR_TME_SHIFT: u32 = 26;
const TSR_CODE_SHIFT: u32 = 24;
// TIR / RIR bits.
const IR_TXRQ: u32 = 1 << 0;
const IR_RTR: u32 = 1 << 1;
const IR_IDE: u32 = 1 << 2;
// FMR bit.
const FMR_FINIT: u32 = 1 << 0;
/// Polls of INAK before giving up on initialisation mode.
const INIT_POLLS: u32 = 100_000;

/// The ECU's CAN link on bxCAN1.
pub struct BxCanLink {
    can: pac::CAN1,
    /// Receive FIFO overruns seen.
    pub overruns: u32,
}

impl BxCanLink {
    /// Initialises bxCAN1: bit timing, automatic bus-off recovery, transmit
    /// in request order, acceptance filters for exactly the ECU's receive
    /// messages. Returns `None` if the peripheral never acknowledged
    /// initialisation mode (no clock): the ECU then hears nothing and its
    /// link supervision keeps the controller in the safe state.
    pub fn new(can: pac::CAN1) -> Option<Self> {
        // SAFETY (all `bits` writes below): values composed from the bit
        // definitions of RM0090 for these registers.
        can.mcr.write(|w| unsafe { w.bits(MCR_INRQ) });
        (0..INIT_POLLS).find(|_| can.msr.read().bits() & MSR_INAK != 0)?;
        can.btr.write(|w| unsafe { w.bits(BTR_500K_AT_16MHZ) });
        can.mcr.write(|w| unsafe { w.bits(MCR_INRQ | MCR_ABOM | MCR_TXFP) });
        configure_filters(&can);
        // Leave initialisation mode; the controller joins the bus after 11
        // recessive bits, frames simply start flowing.
        can.mcr.write(|w| unsafe { w.bits(MCR_ABOM | MCR_TXFP) });
        Some(BxCanLink { can, overruns: 0 })
    }
}

/// One filter bank in 32-bit mask mode that passes every extended
/// (29-bit, J1939) data frame into FIFO 0 and no standard one: a J1939 ECU
/// must hear address claims and requests from any node, so the network
/// layer and the receiver filter by PGN (`hp_ctrl::can`).
fn configure_filters(can: &pac::CAN1) {
    // SAFETY: filter registers written in filter-init mode, bit layouts of
    // RM0090 32.7.4; bank 0 belongs to CAN1 (CAN2SB stays 14).
    can.fmr.modify(|r, w| unsafe { w.bits(r.bits() | FMR_FINIT) });
    can.fa1r.modify(|r, w| unsafe { w.bits(r.bits() & !0b1) });
    can.fm1r.modify(|r, w| unsafe { w.bits(r.bits() & !0b1) }); // mask mode
    can.fs1r.modify(|r, w| unsafe { w.bits(r.bits() | 0b1) }); // 32-bit scale
    can.ffa1r.modify(|r, w| unsafe { w.bits(r.bits() & !0b1) }); // FIFO 0
    can.fb[0].fr1.write(|w| unsafe { w.bits(IR_IDE) }); // identifier: IDE set, RTR clear
    can.fb[0].fr2.write(|w| unsafe { w.bits(IR_IDE | IR_RTR) }); // mask: compare IDE and RTR only
    can.fa1r.modify(|r, w| unsafe { w.bits(r.bits() | 0b1) });
    can.fmr.modify(|r, w| unsafe { w.bits(r.bits() & !FMR_FINIT) });
}

impl Link for BxCanLink {
    fn receive(&mut self) -> Option<CanFrame> {
        let rfr = &self.can.rfr[0];
        let status = rfr.read().bits();
        if status & RFR_FOVR != 0 {
            // Frames were lost in hardware; the E2E counters will show it.
            self.overruns = self.overruns.saturating_add(1);
            // SAFETY: write-1-to-clear of FOVR0.
            rfr.write(|w| unsafe { w.bits(RFR_FOVR) });
        }
        if status & RFR_FMP_MASK == 0 {
            return None;
        }
        let mailbox = &self.can.rx[0];
        let rir = mailbox.rir.read().bits();
        let dlc = (mailbox.rdtr.read().bits() & 0xF) as usize;
        let low = mailbox.rdlr.read().bits().to_le_bytes();
        let high = mailbox.rdhr.read().bits().to_le_bytes();
        // SAFETY: RFOM0 releases the mailbox just read.
        rfr.write(|w| unsafe { w.bits(RFR_RFOM) });
        let id: Id = if rir & IR_IDE != 0 {
            ExtendedId::new(rir >> 3)?.into()
        } else {
            StandardId::new((rir >> 21) as u16)?.into()
        };
        if rir & IR_RTR != 0 {
            return CanFrame::new_remote(id, dlc.min(8));
        }
        let [b0, b1, b2, b3] = low;
        let [b4, b5, b6, b7] = high;
        let data = [b0, b1, b2, b3, b4, b5, b6, b7];
        CanFrame::new(id, data.get(..dlc.min(8))?)
    }

    fn transmit(&mut self, frame: &CanFrame) -> bool {
        let tsr = self.can.tsr.read().bits();
        if (tsr >> TSR_TME_SHIFT) & 0b111 == 0 {
            return false; // all three mailboxes busy
        }
        let Some(mailbox) = self.can.tx.get(((tsr >> TSR_CODE_SHIFT) & 0b11) as usize) else {
            return false;
        };
        let mut data = [0u8; 8];
        for (d, s) in data.iter_mut().zip(frame.data()) {
            *d = *s;
        }
        let [b0, b1, b2, b3, b4, b5, b6, b7] = data;
        let id = match frame.id() {
            Id::Standard(id) => u32::from(id.as_raw()) << 21,
            Id::Extended(id) => id.as_raw() << 3 | IR_IDE,
        };
        let rtr = if frame.is_remote_frame() { IR_RTR } else { 0 };
        // SAFETY: an empty mailbox (TME set, CODE points at it) is filled
        // and then requested, as RM0090 32.7.1 describes.
        mailbox.tdtr.write(|w| unsafe { w.bits(frame.dlc() as u32) });
        mailbox.tdlr.write(|w| unsafe { w.bits(u32::from_le_bytes([b0, b1, b2, b3])) });
        mailbox.tdhr.write(|w| unsafe { w.bits(u32::from_le_bytes([b4, b5, b6, b7])) });
        mailbox.tir.write(|w| unsafe { w.bits(id | rtr | IR_TXRQ) });
        true
    }
}

static TICKS: core::sync::atomic::AtomicU32 = core::sync::atomic::AtomicU32::new(0);

#[cortex_m_rt::exception]
fn SysTick() {
    TICKS.fetch_add(1, core::sync::atomic::Ordering::Relaxed);
}

/// Corners of the vehicle this build controls.
pub const CORNERS: usize = 8;

/// The identity number in the ECU's J1939 NAME (a production ECU's serial
/// number; one per unit built).
const IDENTITY_NUMBER: u32 = 1;

/// Boots the board and runs the ECU on the 1 kHz SysTick. If the
/// peripherals or the CAN controller cannot be had, it parks with the valve
/// outputs untouched, i.e. de-energised.
pub fn main() -> ! {
    let mut ecu = Ecu::<CORNERS>::new(&hp_ctrl::calibration::SEED_8, IDENTITY_NUMBER);
    let (Some(dp), Some(mut cp)) = (pac::Peripherals::take(), cortex_m::Peripherals::take()) else {
        park()
    };
    dp.RCC.ahb1enr.modify(|_, w| w.gpioben().set_bit());
    dp.RCC.apb1enr.modify(|_, w| w.can1en().set_bit());
    dp.GPIOB.moder.modify(|_, w| w.moder8().alternate().moder9().alternate());
    dp.GPIOB.afrh.modify(|_, w| w.afrh8().af9().afrh9().af9());
    let Some(mut link) = BxCanLink::new(dp.CAN1) else { park() };

    cp.SYST.set_clock_source(cortex_m::peripheral::syst::SystClkSource::Core);
    cp.SYST.set_reload(SYSCLK_HZ / 1000 - 1);
    cp.SYST.clear_current();
    cp.SYST.enable_interrupt();
    cp.SYST.enable_counter();
    run(&mut ecu, &mut link, || TICKS.load(core::sync::atomic::Ordering::Relaxed), |_| {}, |_| {}, Timing::Timer)
}

fn park() -> ! {
    loop {
        cortex_m::asm::wfi();
    }
}
