//! Emulator board: QEMU `mps2-an386` (Cortex-M4F, 25 MHz). It has no CAN
//! controller, so CAN frames travel over the CMSDK APB UART0 in the SLCAN
//! (Lawicel) protocol: the firmware is the ECU and its USB-CAN adapter in
//! one, and python-can's `slcan` interface talks to it through QEMU's
//! `-serial tcp:...`.

use core::ptr::{read_volatile, write_volatile};

use heapless::Deque;
use hp_ctrl::can::slcan::{self, Adapter, LineReader};
use hp_ctrl::can::CanFrame;

use hp_ctrl::can::ecu::Link;

/// Core and peripheral clock of the board, Hz.
pub const SYSCLK_HZ: u32 = 25_000_000;

/// CMSDK APB UART0 registers.
const UART0_BASE: usize = 0x4000_4000;
const DATA: usize = UART0_BASE;
const STATE: usize = UART0_BASE + 0x4;
const CTRL: usize = UART0_BASE + 0x8;
const INTCLEAR: usize = UART0_BASE + 0xC;
const BAUDDIV: usize = UART0_BASE + 0x10;
const STATE_TX_FULL: u32 = 1 << 0;
const STATE_RX_FULL: u32 = 1 << 1;
const CTRL_TX_EN: u32 = 1 << 0;
const CTRL_RX_EN: u32 = 1 << 1;
const CTRL_RX_INT_EN: u32 = 1 << 3;
const INT_RX: u32 = 1 << 1;
/// NVIC interrupt set-enable register 0; UART0's receive interrupt is
/// IRQ 0 on the AN385/AN386 images.
const NVIC_ISER0: usize = 0xE000_E100;
const UART0_RX_IRQ: u32 = 0;

fn read_reg(addr: usize) -> u32 {
    // SAFETY: a fixed, aligned MMIO register of the board's UART0.
    unsafe { read_volatile(addr as *const u32) }
}

fn write_reg(addr: usize, value: u32) {
    // SAFETY: a fixed, aligned MMIO register of the board's UART0.
    unsafe { write_volatile(addr as *mut u32, value) }
}

/// Enables UART0 at 115200 Bd (QEMU ignores the rate but needs a legal
/// divider before it moves bytes), with its receive interrupt, which only
/// wakes the core from [`SlcanLink::wait`] (the bytes are polled).
pub fn uart_init() {
    write_reg(BAUDDIV, SYSCLK_HZ / 115_200);
    write_reg(CTRL, CTRL_TX_EN | CTRL_RX_EN | CTRL_RX_INT_EN);
    write_reg(NVIC_ISER0, 1 << UART0_RX_IRQ);
}

/// The only device interrupt enabled is UART0's receive interrupt; its
/// handler only acknowledges it (the main loop, woken from `wfi`, polls
/// the byte).
#[cortex_m_rt::exception]
unsafe fn DefaultHandler(_irqn: i16) {
    write_reg(INTCLEAR, INT_RX);
}

fn uart_rx_ready() -> bool {
    read_reg(STATE) & STATE_RX_FULL != 0
}

fn uart_read() -> Option<u8> {
    uart_rx_ready().then(|| read_reg(DATA) as u8)
}

fn uart_try_write(byte: u8) -> bool {
    if read_reg(STATE) & STATE_TX_FULL != 0 {
        return false;
    }
    write_reg(DATA, u32::from(byte));
    true
}

/// Bytes waiting to go out: a few periods of traffic (27-byte extended
/// frames: up to five a period with eight corners, plus answers).
const TX_QUEUE: usize = 512;

/// The SLCAN link over UART0.
pub struct SlcanLink {
    reader: LineReader,
    adapter: Adapter,
    out: Deque<u8, TX_QUEUE>,
    /// Answers or frames dropped because the queue was full.
    pub dropped: u32,
}

impl SlcanLink {
    pub const fn new() -> Self {
        SlcanLink { reader: LineReader::new(), adapter: Adapter::new(), out: Deque::new(), dropped: 0 }
    }

    /// Queues all of `bytes` or, if they do not fit, none.
    fn queue(&mut self, bytes: &[u8]) -> bool {
        if self.out.capacity() - self.out.len() < bytes.len() {
            self.dropped = self.dropped.saturating_add(1);
            return false;
        }
        bytes.iter().all(|&b| self.out.push_back(b).is_ok())
    }

    /// Moves queued bytes into the UART while it takes them.
    pub fn flush(&mut self) {
        while let Some(&b) = self.out.front() {
            if !uart_try_write(b) {
                break;
            }
            self.out.pop_front();
        }
    }

    /// Sleeps until an interrupt (a received byte, the SysTick) if there
    /// is nothing to do: no byte waiting and nothing left to send. Checked
    /// with interrupts masked, so a byte arriving just before `wfi` still
    /// wakes it (a pending interrupt ends `wfi` even while masked; its
    /// handler runs after the critical section). Polling the UART in a
    /// tight loop instead costs QEMU most of its time in the emulator.
    pub fn wait(&mut self) {
        cortex_m::interrupt::free(|_| {
            if self.out.is_empty() && !uart_rx_ready() {
                cortex_m::asm::wfi();
            }
        });
    }
}

impl Default for SlcanLink {
    fn default() -> Self {
        Self::new()
    }
}

impl Link for SlcanLink {
    /// Reads UART bytes until a line carrying a frame is complete, or no
    /// byte is waiting; command lines are answered on the way.
    fn receive(&mut self) -> Option<CanFrame> {
        while let Some(byte) = uart_read() {
            let Some(cmd) = self.reader.push(byte) else { continue };
            let response = self.adapter.handle(cmd);
            self.queue(response.answer);
            if response.frame.is_some() {
                return response.frame;
            }
        }
        None
    }

    fn transmit(&mut self, frame: &CanFrame) -> bool {
        if !self.adapter.is_open() {
            // Like an adapter with the channel closed: the frame is on the
            // bus, but nobody on the host side listens.
            return true;
        }
        let mut text = [0u8; slcan::MAX_FRAME_TEXT];
        let n = slcan::format_frame(frame, &mut text);
        self.queue(text.get(..n).unwrap_or(&[]))
    }
}

/// Core clock ticks of SysTick per control period.
const SYSTICK_RELOAD: u32 = SYSCLK_HZ / 1000 - 1;

static TICKS: core::sync::atomic::AtomicU32 = core::sync::atomic::AtomicU32::new(0);

#[cortex_m_rt::exception]
fn SysTick() {
    TICKS.fetch_add(1, core::sync::atomic::Ordering::Relaxed);
}

/// Boots the board and runs the ECU for `N` corners with the parameters
/// `params` and `timing`.
pub fn main<const N: usize>(params: &'static hp_ctrl::vehicle::VehicleParams<N>, timing: crate::run::Timing) -> ! {
    // Identity number 1: the emulator is one ECU.
    let mut ecu = hp_ctrl::can::ecu::Ecu::<N>::new(params, 1);
    let mut link = SlcanLink::new();
    uart_init();
    if let Some(mut core) = cortex_m::Peripherals::take() {
        core.SYST.set_clock_source(cortex_m::peripheral::syst::SystClkSource::Core);
        core.SYST.set_reload(SYSTICK_RELOAD);
        core.SYST.clear_current();
        core.SYST.enable_interrupt();
        core.SYST.enable_counter();
    }
    crate::run::run(&mut ecu, &mut link, || TICKS.load(core::sync::atomic::Ordering::Relaxed), SlcanLink::flush, SlcanLink::wait, timing)
}
