//! ECU firmware of the hydro-pneumatic spring/damper unit (Cortex-M4F).
//!
//! The controller is `hp_ctrl::step`, unchanged; this crate only wires it
//! to a CAN link and a 1 kHz time base:
//!
//! - [`hp_ctrl::can::ecu`] (in `hp-ctrl`, so the host runs the same code):
//!   the board-independent application: receive frames into the codec's
//!   receiver, run one control period, send valve commands, status and
//!   diagnostics.
//! - [`run`]: the fixed-rate loop shared by the boards.
//! - [`stack`]: the stack's high-water mark (painted at reset).
//! - `mps2`: the emulator board (QEMU `mps2-an386`): CAN frames over the
//!   CMSDK UART0 in the SLCAN protocol.
//! - `stm32f4`: a real ECU board (STM32F405, bxCAN1 on PB8/PB9).
//!
//! No heap, no panics: every fallible call has a documented fallback, and
//! `scripts/firmware-build.sh` checks the linked binaries for panic and
//! allocation machinery.
#![no_std]

pub mod run;
pub mod stack;

#[cfg(feature = "figures")]
pub mod figures;
#[cfg(feature = "mps2")]
pub mod mps2;
#[cfg(feature = "stm32f4")]
pub mod stm32f4;

/// Never reached: the firmware is written without panicking paths, and the
/// build script fails if any panic machinery (this handler included) is
/// linked into a binary.
#[panic_handler]
fn panic(_: &core::panic::PanicInfo) -> ! {
    cortex_m::asm::udf()
}
