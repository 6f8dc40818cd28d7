//! Measuring on the emulated Cortex-M4F: executed instructions through SysTick under
//! QEMU's `-icount shift=0` (one instruction per virtual nanosecond, SysTick at 25 MHz:
//! 40 instructions per tick, checked against a loop of known length), and the deepest
//! stack a call uses, by painting the free stack and looking for the first overwritten word.
//!
//! One harness for every firmware that measures: the project's own (`targets/`, which
//! includes this file) and the one `stateforge-codegen measure` writes for a user's model
//! (which embeds it). The host side, which reads what it prints and traces the calls
//! between its markers, is `stateforge_cli::measure`.

use cortex_m::peripheral::{syst::SystClkSource, SYST};

/// Instructions per SysTick tick on mps2-an386 under `-icount shift=0`.
pub const INSTRUCTIONS_PER_TICK: u32 = 40;

/// A free-running 24-bit SysTick counter.
pub struct Clock {
    _syst: SYST,
}

impl Clock {
    /// Starts SysTick from the core clock, counting down over its full 24-bit range.
    pub fn start(mut syst: SYST) -> Clock {
        syst.set_clock_source(SystClkSource::Core);
        syst.set_reload(0x00FF_FFFF);
        syst.clear_current();
        syst.enable_counter();
        // The counter reads 0 until its first reload.
        while SYST::get_current() == 0 {}
        Clock { _syst: syst }
    }

    /// Instructions executed by `work`, within 40 (one tick); average many calls.
    pub fn instructions(&self, work: impl FnOnce()) -> u32 {
        let start = SYST::get_current();
        work();
        let end = SYST::get_current();
        (start.wrapping_sub(end) & 0x00FF_FFFF) * INSTRUCTIONS_PER_TICK
    }

    /// Waits for the counter's next tick, then runs about `j % 40` more instructions
    /// (`2 (j % 40 / 2)` in a delay loop, and a `nop` when it is odd): the reading that
    /// follows starts at a point of its tick set by `j` alone, whatever ran before, so that
    /// over 40 consecutive `j` the 40-instruction steps of single readings average out
    /// instead of rounding every call the same way.
    #[inline(never)]
    pub fn dither(&self, j: usize) {
        let now = SYST::get_current();
        while SYST::get_current() == now {}
        let phase = (j % 40) as u32;
        cortex_m::asm::delay(phase / 2);
        if phase % 2 == 1 {
            cortex_m::asm::nop();
        }
    }
}

/// Bytes of stack below the caller's stack pointer that `work` used.
///
/// Painting the free stack and reading it back is raw memory access below the stack
/// pointer, which safe Rust cannot express; it is confined to this function.
#[allow(unsafe_code)]
pub fn stack_depth(work: impl FnOnce()) -> usize {
    const PAINT: u32 = 0xA5A5_A5A5;
    const SPAN: usize = 8 * 1024;
    let top = cortex_m::register::msp::read() as usize;
    // Leave a margin for this function's own pushes at the call below.
    let (bottom, paint_top) = (top - SPAN, top - 64);
    let mut address = bottom;
    while address < paint_top {
        // SAFETY: [bottom, paint_top) lies in free stack below the stack pointer, within
        // RAM (the stack starts at the top of 128 KiB and the firmware's frames above
        // this one are small); nothing else runs (no interrupts are enabled).
        unsafe { (address as *mut u32).write_volatile(PAINT) };
        address += 4;
    }
    work();
    let mut address = bottom;
    // SAFETY: the same region, read back.
    while address < paint_top && unsafe { (address as *const u32).read_volatile() } == PAINT {
        address += 4;
    }
    top - address
}

/// Does nothing with a sample: the harness loop's own cost, subtracted from a kernel's.
#[inline(never)]
fn nothing<S>(sample: S) -> S {
    sample
}

/// Runs `work` between the trace markers ([`trace_begin`], [`trace_end`]), so that
/// `cargo xtask`'s instruction trace follows the kernel calls it makes.
pub fn traced<R>(work: impl FnOnce() -> R) -> R {
    trace_begin();
    let result = work();
    trace_end();
    result
}

/// Marks the start of measured calls for `cargo xtask`'s instruction trace, which
/// follows each kernel call between the two markers to estimate its cycles.
#[inline(never)]
fn trace_begin() {
    core::hint::black_box(1_u32);
}

/// Marks the end of measured calls (see [`trace_begin`]).
#[inline(never)]
fn trace_end() {
    core::hint::black_box(2_u32);
}

/// Instructions per call of `kernel` over `samples`, the harness loop excluded: the same
/// loop passing each sample to [`nothing`] instead is measured and subtracted. The
/// kernel's calls lie between the trace markers.
pub fn per_call<S: Copy>(
    clock: &Clock,
    samples: impl Iterator<Item = S> + Clone,
    mut kernel: impl FnMut(S),
) -> u32 {
    use core::hint::black_box;
    let calls = samples.clone().count() as u32;
    let overhead = clock.instructions(|| {
        for sample in samples.clone() {
            black_box(nothing(black_box(sample)));
        }
    });
    trace_begin();
    let total = clock.instructions(|| {
        for sample in samples {
            kernel(black_box(sample));
        }
    });
    trace_end();
    (total.saturating_sub(overhead) + calls / 2) / calls.max(1)
}

/// Prints a kernel's `cost` and `stack` lines: generated code, then the nalgebra baseline
/// (0 where there is none).
pub fn report(kernel: &str, instructions: (u32, u32), stack: (usize, usize)) {
    cortex_m_semihosting::hprintln!("cost {} {} {}", kernel, instructions.0, instructions.1);
    cortex_m_semihosting::hprintln!("stack {} {} {}", kernel, stack.0, stack.1);
}

/// The instructions of `N` single calls of one kernel, each read around its own call
/// (to within a tick, 40 instructions), for their median and worst; and their mean,
/// accurate to a few instructions: each reading starts at a point of its tick set by
/// [`Clock::dither`], and an empty reading (the reads' own instruction), made the same
/// way before each call, is subtracted.
pub struct Calls<const N: usize> {
    each: [u32; N],
    count: usize,
    empty: u32,
}

impl<const N: usize> Calls<N> {
    /// No calls yet.
    pub fn new() -> Self {
        Calls {
            each: [0; N],
            count: 0,
            empty: 0,
        }
    }

    /// Runs and reads `work`, one call of the kernel (beyond `N` calls, runs it unread).
    ///
    /// Never inlined, so that each kernel's reading is code of its own: inlined, the
    /// compiler merged the three navigation kernels' readings into one, with the choice
    /// between them inside the read span.
    #[inline(never)]
    pub fn measure<R>(&mut self, clock: &Clock, work: impl FnOnce() -> R) -> R {
        if self.count == N {
            return work();
        }
        // Consecutive calls take phases 21 apart: any 40 of them take every phase, and
        // fewer spread over the tick.
        let j = 21 * self.count;
        clock.dither(j);
        self.empty += clock.instructions(|| {});
        clock.dither(j);
        let mut result = None;
        self.each[self.count] = clock.instructions(|| result = Some(work()));
        self.count += 1;
        let Some(result) = result else {
            unreachable!("the closure ran")
        };
        result
    }

    /// The mean empty reading, subtracted from each reading.
    #[cfg(feature = "symforce")]
    fn empty_mean(&self) -> u32 {
        (self.empty + self.count as u32 / 2) / (self.count.max(1) as u32)
    }

    /// Mean instructions per call, the empty reading's subtracted.
    pub fn mean(&self) -> u32 {
        let total: u32 = self.each[..self.count].iter().sum();
        let calls = self.count.max(1) as u32;
        (total.saturating_sub(self.empty) + calls / 2) / calls
    }

    /// Median and worst single call, each less the mean empty reading (within 40).
    #[cfg(feature = "symforce")]
    pub fn median_worst(&mut self) -> (u32, u32) {
        let empty = self.empty_mean();
        let read = &mut self.each[..self.count];
        read.sort_unstable();
        let at = |i: usize| read.get(i).map_or(0, |v| v.saturating_sub(empty));
        (at(read.len() / 2), at(read.len().saturating_sub(1)))
    }
}
