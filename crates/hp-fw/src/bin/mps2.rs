//! The ECU firmware on the emulator board (QEMU mps2-an386): SLCAN over
//! UART0, 1 kHz SysTick, lock-step ticks for processor-in-the-loop runs.
#![no_std]
#![no_main]

use core::sync::atomic::{AtomicU32, Ordering};

use cortex_m::peripheral::syst::SystClkSource;
use cortex_m_rt::{entry, exception};
use hp_fw::ecu::Ecu;
use hp_fw::mps2::{uart_init, SlcanLink, SYSCLK_HZ};
use hp_fw::run::{run, Timing};

static TICKS: AtomicU32 = AtomicU32::new(0);

#[exception]
fn SysTick() {
    TICKS.fetch_add(1, Ordering::Relaxed);
}

#[entry]
fn main() -> ! {
    let mut ecu = Ecu::new();
    let mut link = SlcanLink::new();
    uart_init();
    if let Some(mut core) = cortex_m::Peripherals::take() {
        core.SYST.set_clock_source(SystClkSource::Core);
        core.SYST.set_reload(SYSCLK_HZ / 1000 - 1);
        core.SYST.clear_current();
        core.SYST.enable_interrupt();
        core.SYST.enable_counter();
    }
    run(&mut ecu, &mut link, || TICKS.load(Ordering::Relaxed), SlcanLink::flush, Timing::TimerOrLockStep)
}
