//! The stack's high-water mark.
//!
//! cortex-m-rt paints the whole stack, from `_stack_end` up to
//! `_stack_start`, with [`cortex_m_rt::STACK_PAINT_VALUE`] at reset
//! (feature `paint-stack`). The stack grows down, so the lowest word whose
//! paint is gone marks the deepest the stack has reached. On the emulator
//! board the host can read the same words through QEMU's monitor
//! (`scripts/firmware_figures.py`).

use cortex_m_rt::STACK_PAINT_VALUE;

extern "C" {
    static _stack_start: u32;
    static _stack_end: u32;
}

fn bounds() -> (*const u32, *const u32) {
    // Only the addresses of the linker symbols are taken.
    (core::ptr::addr_of!(_stack_end), core::ptr::addr_of!(_stack_start))
}

/// Bytes of stack used at the deepest point since reset (or since the
/// last [`repaint`]).
pub fn high_water_bytes() -> u32 {
    let (end, start) = bounds();
    let mut p = end;
    // SAFETY: reads aligned words of the stack region, below the current
    // stack pointer's frames or inside them; volatile, as the compiler
    // does not know the stack's contents.
    unsafe {
        while p < start && p.read_volatile() == STACK_PAINT_VALUE {
            p = p.add(1);
        }
    }
    (start as usize - p as usize) as u32
}

/// Paints the free part of the stack again, from `_stack_end` up to 64
/// bytes below the current stack pointer, so a later
/// [`high_water_bytes`] measures only what runs after this call.
pub fn repaint() {
    let (end, _) = bounds();
    let sp = cortex_m::register::msp::read() as usize;
    let mut p = end.cast_mut();
    // SAFETY: the region is below every live frame (64 bytes of margin
    // for this function's own); nothing else lives there.
    unsafe {
        while (p as usize) + 64 < sp {
            p.write_volatile(STACK_PAINT_VALUE);
            p = p.add(1);
        }
    }
}
