//! `vsqrt.f32` on an Arm FPU.
//!
//! Stable Rust cannot name `s` registers in `asm!` on this target (the `vfp2` register
//! class is unstable), so the value goes through a core register: `vmov` to `s0`, the
//! square root, `vmov` back, with `s0`'s previous value kept in a core register and put
//! back (the compiler does not know `s0` is used).
#![allow(unsafe_code)]

/// `sqrt(x)`, correctly rounded, by the FPU.
#[inline(always)]
pub fn vsqrt(x: f32) -> f32 {
    let bits: u32;
    // SAFETY: the instructions read and write only the operand registers and `s0`, whose
    // value is restored before the block ends; they touch no memory and no flags, and
    // `vsqrt.f32` exists on every Arm FPU the `eabihf` targets require (VFPv2 on).
    unsafe {
        core::arch::asm!(
            "vmov {saved}, s0",
            "vmov s0, {x}",
            "vsqrt.f32 s0, s0",
            "vmov {x}, s0",
            "vmov s0, {saved}",
            x = inout(reg) x.to_bits() => bits,
            saved = out(reg) _,
            options(pure, nomem, nostack, preserves_flags),
        );
    }
    f32::from_bits(bits)
}
