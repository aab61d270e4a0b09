//! The fixed-rate loop shared by the boards.

use hp_ctrl::can::ecu::{Ecu, Link};

/// How control periods are triggered.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Timing {
    /// By the 1 kHz timer (the ECU). `HP_PilTick` frames are ignored.
    Timer,
    /// Only by `HP_PilTick` frames, from power-on: each accepted tick
    /// closes exactly one period (processor-in-the-loop in the emulator,
    /// where the host's plant simulation sets the pace).
    LockStep,
}

/// Runs the ECU forever. `ticks` reads a counter that the 1 kHz timer
/// interrupt increments; `service` moves bytes between the hardware and
/// the link's queues; neither may block. `wait` is called when a pass
/// found no frame: it may sleep until the next interrupt if the board
/// wakes on both the timer and received data (or return at once).
///
/// If the loop ever falls behind the timer, the missed ticks are skipped:
/// one period runs per observed change of the counter.
pub fn run<L: Link, const N: usize>(
    ecu: &mut Ecu<N>,
    link: &mut L,
    ticks: impl Fn() -> u32,
    service: impl Fn(&mut L),
    wait: impl Fn(&mut L),
    timing: Timing,
) -> ! {
    let mut done = ticks();
    loop {
        service(link);
        let mut idle = true;
        let mut due = false;
        while let Some(frame) = link.receive() {
            idle = false;
            if ecu.receive(&frame).is_some() && timing == Timing::LockStep {
                // Frames after the tick belong to the next period.
                due = true;
                break;
            }
        }
        let now = ticks();
        if timing == Timing::Timer && now != done {
            done = now;
            due = true;
        }
        // One call site: the period (the whole vehicle step) is inlined
        // once, not once per timing.
        if due {
            ecu.period(link);
            idle = false;
        }
        if idle {
            service(link);
            wait(link);
        }
    }
}
