//! The figures builds (emulator board, no UART; `hp-fw-figures` for four
//! corners, `hp-fw-figures8` for eight): runs a scripted driving
//! scenario through the whole ECU path (sensor frames -> receiver ->
//! controller step -> output frames), times each part with SysTick, measures
//! the stack high-water mark, prints one `figures ...` line over
//! semihosting and exits. `scripts/firmware_figures.py` runs it under
//! `qemu-system-arm -icount shift=0` (deterministic: one instruction per
//! nanosecond of virtual time; SysTick counts the 25 MHz core clock, so one
//! tick is 40 instructions).
use core::hint::black_box;
use core::sync::atomic::{compiler_fence, Ordering};

use cortex_m::peripheral::{syst::SystClkSource, SYST};
use cortex_m_semihosting::{debug, hprintln};
use hp_ctrl::can::ecu::{Ecu, Link};
use hp_ctrl::can::messages::{address, Ctrl, Diag, DiagE2e, DiagLink, Driver, Inclination, Motion, PilTick, Pressures, Status, Steering, Valves, Vehicle};
use hp_ctrl::can::{CanFrame, InputDecoder, LinkParams, Message, Transmitter};
use hp_ctrl::vehicle::{HeightMode, VehicleOutputs, VehicleParams};
use hp_ctrl::{Config, DriverMode};

use crate::stack;

/// Periods timed; the first WARMUP are not timed (power-on safe state,
/// recovery, the handling hold).
const PERIODS: u32 = 6000;
const WARMUP: u32 = 3000;
/// Untimed periods after the timed ones: stopped on a slope with slope
/// levelling (so the stack high-water covers that path too).
const SLOPE_PERIODS: u32 = 1500;
/// Frames timed per message in the per-frame figures.
const FRAME_REPS: u32 = 100;
/// Lookups timed per direction in the gas-table figures.
const TABLE_REPS: u32 = 100;

/// Counts what the ECU sends instead of sending it.
struct CountingLink {
    frames: u32,
}

impl Link for CountingLink {
    fn receive(&mut self) -> Option<CanFrame> {
        None
    }
    fn transmit(&mut self, frame: &CanFrame) -> bool {
        black_box(frame);
        self.frames += 1;
        true
    }
}

fn now() -> u32 {
    compiler_fence(Ordering::SeqCst);
    let t = SYST::get_current();
    compiler_fence(Ordering::SeqCst);
    t
}

/// SysTick counts down, 24 bits.
fn elapsed(start: u32, end: u32) -> u32 {
    start.wrapping_sub(end) & 0x00FF_FFFF
}

#[derive(Default)]
struct Stat {
    sum: u64,
    max: u32,
}

impl Stat {
    fn add(&mut self, ticks: u32) {
        self.sum += u64::from(ticks);
        self.max = self.max.max(ticks);
    }
}

/// Frames one period can bring: two per corner and the vehicle's.
const FRAMES: usize = 24;

/// The sensor frames of period `k`: a 10 m/s straight road with a 1.5 Hz
/// body motion (each corner a little out of phase), a lane change at 4 s,
/// a lowering request at 4.5 s; from period `PERIODS` on, stopped on a
/// slope (pitch 0.01 rad) with slope levelling on the lowered base.
fn scenario<const N: usize>(k: u32, tx: &mut Transmitter, cfg: &Config, out: &mut heapless::Vec<CanFrame, FRAMES>) {
    let t_s = k as f32 * 1e-3;
    let stopped = k >= PERIODS;
    let w = 2.0 * core::f32::consts::PI * 1.5;
    let lane_change = (4.0..5.0).contains(&t_s);
    let steer = if lane_change { 0.8 * libm::sinf(2.0 * core::f32::consts::PI * (t_s - 4.0)) } else { 0.0 };
    let mut msgs: heapless::Vec<Message, FRAMES> = heapless::Vec::new();
    for c in 0..N {
        let phase = 0.3 * c as f32;
        let (sin, cos) = if stopped { (0.0, 0.0) } else { (libm::sinf(w * t_s + phase), libm::cosf(w * t_s + phase)) };
        let p_pa = cfg.unit.static_pressure_pa * (1.0 + 0.05 * f64::from(sin));
        // Stopped: L above S, as in a lowered corner at rest.
        let p_large_pa = if stopped { 1.1 * p_pa } else { p_pa };
        let c = c as u8;
        let _ = msgs.push(Message::CornerPressures(c, Pressures { p_gas_pa: p_pa, p_gas2_pa: p_large_pa }));
        let _ = msgs.push(Message::CornerMotion(
            c,
            Motion { strut_disp_m: 0.01 * f64::from(sin), body_acc_m_s2: -0.8 * f64::from(cos), t_gas_k: cfg.unit.static_temperature_k },
        ));
    }
    if k % 10 == 0 {
        let _ = msgs.push(Message::Vehicle(Vehicle {
            speed_m_s: if stopped { 0.0 } else { 10.0 },
            brake_pressed: false,
            lat_acc_m_s2: f64::from(steer * 2.0),
            long_acc_m_s2: 0.0,
        }));
        let _ = msgs.push(Message::Steering(Steering {
            angle_rad: f64::from(steer),
            rate_rad_s: f64::from(steer * 2.0 * core::f32::consts::PI),
        }));
        let _ = msgs.push(Message::Inclination(Inclination { pitch_rad: 0.01, roll_rad: -0.005 }));
    }
    if k % 100 == 0 {
        let request = if t_s >= 4.5 { -0.02 } else { 0.0 };
        let height_mode = if stopped { HeightMode::SlopeLevel } else { HeightMode::Normal };
        let _ = msgs.push(Message::Driver(Driver { mode: DriverMode::Auto, height_mode, ride_height_request_m: request }));
    }
    out.clear();
    for m in &msgs {
        if let Ok(f) = tx.frame(m, m.kind().def().source) {
            let _ = out.push(f);
        }
    }
}

/// The receiver's cost per frame of each input message: `FRAME_REPS`
/// frames in sequence (after one that synchronises the counter), each
/// timed alone. Prints `frame rx NAME sum=.. max=.. n=..` (ticks).
fn receive_costs(cfg: &Config) {
    let p_pa = cfg.unit.static_pressure_pa;
    let t_k = cfg.unit.static_temperature_k;
    let samples: [fn(f64, f64, f64) -> Message; 6] = [
        |_, _, x| Message::PilTick(PilTick { index: (x * 1000.0) as u16 }),
        |p, _, x| Message::CornerPressures(1, Pressures { p_gas_pa: p * (1.0 + 0.05 * x), p_gas2_pa: p * (1.0 - 0.03 * x) }),
        |_, t, x| Message::CornerMotion(1, Motion { strut_disp_m: 0.0123 * x, body_acc_m_s2: -0.81 * x, t_gas_k: t + 3.0 * x }),
        |_, _, x| Message::Vehicle(Vehicle { speed_m_s: 10.0 + x, brake_pressed: false, lat_acc_m_s2: 1.7 * x, long_acc_m_s2: -0.4 * x }),
        |_, _, x| Message::Steering(Steering { angle_rad: 0.35 * x, rate_rad_s: 1.1 * x }),
        |_, _, x| Message::Driver(Driver { mode: DriverMode::Auto, height_mode: HeightMode::Normal, ride_height_request_m: -0.02 * x }),
    ];
    for make in samples {
        let mut rx = InputDecoder::<4>::new(LinkParams::default());
        let mut tx = Transmitter::new();
        let name = make(p_pa, t_k, 0.0).kind().name();
        let (mut stat, mut n) = (Stat::default(), 0u32);
        for k in 0..=FRAME_REPS {
            let x = libm::sin(f64::from(k) * 0.37);
            let Ok(frame) = tx.frame(&make(p_pa, t_k, x), address::SENSORS) else { continue };
            let t0 = now();
            let used = black_box(rx.receive(black_box(&frame))).is_ok();
            let t1 = now();
            if k > 0 && used {
                stat.add(elapsed(t0, t1));
                n += 1;
            }
        }
        hprintln!("frame rx {} sum={} max={} n={}", name, stat.sum, stat.max, n);
    }
}

/// The transmitter's cost per frame of each output message, from the
/// last period's outputs. Prints `frame tx NAME sum=.. max=.. n=..`.
fn send_costs<const N: usize>(out: &VehicleOutputs<N>) {
    let (Some(c), Some(_)) = (out.corners.first(), out.gas.first()) else { return };
    let msgs = [
        Message::Valves(Valves::from_outputs(out, false, 1234)),
        Message::CornerStatus(0, Status::from_outputs(out, 0)),
        Message::CornerCtrl(0, Ctrl::from_outputs(c)),
        Message::CornerDiag(0, Diag::from_outputs(c)),
        Message::DiagE2e(DiagE2e::default()),
        Message::DiagLink(DiagLink::default()),
    ];
    for msg in &msgs {
        let mut tx = Transmitter::new();
        let (mut stat, mut n) = (Stat::default(), 0u32);
        for _ in 0..FRAME_REPS {
            let t0 = now();
            let ok = black_box(tx.frame(black_box(msg), address::HPECU)).is_ok();
            let t1 = now();
            if ok {
                stat.add(elapsed(t0, t1));
                n += 1;
            }
        }
        hprintln!("frame tx {} sum={} max={} n={}", msg.kind().name(), stat.sum, stat.max, n);
    }
}

/// The gas table's cost per lookup, both ways (`LargeTable::pressure_pa`,
/// `LargeTable::offset_m`, the ride height's and the gas-charge detector's
/// lookups): `TABLE_REPS` lookups each at points spread over the table,
/// each timed alone. Prints `table NAME sum=.. max=.. n=..`. (The table
/// itself is built on the host, `hp_ctrl::calibration`: no start-up cost.)
fn table_costs<const N: usize>(params: &VehicleParams<N>) {
    let table = params.corner().large_table();
    let (u_min, u_max) = table.offset_range_m();
    let t_k = params.corner().config().unit.static_temperature_k as f32;
    let p_pa = params.corner().config().unit.static_pressure_pa as f32;
    let (mut forward, mut backward) = (Stat::default(), Stat::default());
    for k in 0..TABLE_REPS {
        let x = libm::sinf(k as f32 * 0.37);
        let u = u_min + (u_max - u_min) * 0.5 * (1.0 + x);
        let t = t_k + 40.0 * x;
        let t0 = now();
        black_box(table.pressure_pa(black_box(u), black_box(t)));
        let t1 = now();
        black_box(table.offset_m(black_box(p_pa * (1.0 + 0.3 * x)), black_box(t)));
        let t2 = now();
        forward.add(elapsed(t0, t1));
        backward.add(elapsed(t1, t2));
    }
    hprintln!("table pressure sum={} max={} n={}", forward.sum, forward.max, TABLE_REPS);
    hprintln!("table offset sum={} max={} n={}", backward.sum, backward.max, TABLE_REPS);
}

/// 4000 `nop`s for the calibration (plus the call and return: within the
/// check's one-tick tolerance). A function of its own, never inlined:
/// LLVM sizes the inline assembly as one instruction, not 8000 bytes, so in
/// a function with a literal pool it places literals out of reach
/// ("out of range pc-relative fixup value", seen with rustc 1.85).
#[inline(never)]
fn nops_4000() {
    // SAFETY: nops only.
    unsafe { core::arch::asm!(".rept 4000", "nop", ".endr", options(nomem, nostack)) };
}

/// Runs the figures for `N` corners with `params` and exits the emulator.
pub fn main<const N: usize>(params: &'static VehicleParams<N>) -> ! {
    let Some(mut core) = cortex_m::Peripherals::take() else {
        debug::exit(debug::EXIT_FAILURE);
        loop {
            cortex_m::asm::wfi();
        }
    };
    core.SYST.set_clock_source(SystClkSource::Core);
    core.SYST.set_reload(0x00FF_FFFF);
    core.SYST.clear_current();
    core.SYST.enable_counter();

    // Calibration: 4000 single-cycle instructions in a row.
    let c0 = now();
    nops_4000();
    let calib = elapsed(c0, now());

    let cfg = *params.corner().config();
    let mut ecu = Ecu::<N>::new(params, 1);
    let stack_init = stack::high_water_bytes();
    stack::repaint();
    let mut sensors = Transmitter::new();
    let mut link = CountingLink { frames: 0 };
    let mut frames = heapless::Vec::new();
    let (mut rx, mut step, mut send, mut period) = (Stat::default(), Stat::default(), Stat::default(), Stat::default());
    let (mut safe, mut valve5, mut valve6, mut frames_timed, mut levelling) = (0u32, 0u32, 0u32, 0u32, 0u32);
    let mut last = VehicleOutputs::<N>::safe();
    for k in 0..PERIODS + SLOPE_PERIODS {
        scenario::<N>(k, &mut sensors, &cfg, &mut frames);
        let t0 = now();
        for f in &frames {
            black_box(ecu.receive(f));
        }
        let inputs = black_box(ecu.end_period());
        let t2 = now();
        let out = black_box(ecu.step(&inputs));
        let t3 = now();
        ecu.send(&mut link, &inputs, &out);
        let t4 = now();
        if k == WARMUP {
            frames_timed = link.frames;
        } else if k == PERIODS {
            frames_timed = link.frames - frames_timed;
        }
        if k >= PERIODS {
            levelling += u32::from(out.height_mode == HeightMode::SlopeLevel);
            continue;
        }
        if k >= WARMUP {
            rx.add(elapsed(t0, t2));
            step.add(elapsed(t2, t3));
            send.add(elapsed(t3, t4));
            period.add(elapsed(t0, t4));
            for c in &out.corners {
                safe += u32::from(c.diag & hp_ctrl::diag::SAFE_STATE != 0);
                valve5 += u32::from(c.valve5_open);
                valve6 += u32::from(c.valve6_open);
            }
        }
        last = out;
    }
    let stack_loop = stack::high_water_bytes();
    receive_costs(&cfg);
    send_costs(&last);
    table_costs(params);
    let n = PERIODS - WARMUP;
    hprintln!(
        "figures corners={} calib_4000_nops={} stack_init_bytes={} periods={} rx_sum={} rx_max={} step_sum={} step_max={} send_sum={} send_max={} period_sum={} period_max={} stack_loop_bytes={} frames_sent={} safe_periods={} valve5_open={} valve6_open={} tx_dropped={} slope_level_periods={}",
        N,
        calib,
        stack_init,
        n,
        rx.sum,
        rx.max,
        step.sum,
        step.max,
        send.sum,
        send.max,
        period.sum,
        period.max,
        stack_loop,
        frames_timed,
        safe,
        valve5,
        valve6,
        ecu.tx_dropped,
        levelling
    );
    hprintln!(
        "sizes corners={} ecu_bytes={} params_bytes={} state_bytes={}",
        N,
        core::mem::size_of::<Ecu<N>>(),
        core::mem::size_of::<hp_ctrl::vehicle::VehicleParams<N>>(),
        core::mem::size_of::<hp_ctrl::vehicle::VehicleState<N>>()
    );
    debug::exit(debug::EXIT_SUCCESS);
    loop {
        cortex_m::asm::wfi();
    }
}
