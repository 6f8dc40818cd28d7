//! The checks every C function of this crate makes of the pointers it is given, written
//! once for all of them: null and misaligned pointers are refused with a status, and a
//! filter's storage is read only once its constructor has written it.

use core::mem::MaybeUninit;

/// Why a C function refused a pointer.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Refused {
    /// It was null.
    Null,
    /// It was not aligned for what it points to.
    Misaligned,
    /// It points to storage that no successful constructor wrote.
    NotInitialised,
}

/// The storage of a generated filter or controller: the value, then a tag saying that
/// its constructor wrote it. Storage the C program zeroed (a `static`) has no tag. The
/// value comes first, at the storage's own address, so that a call passes the storage's
/// pointer on as it is.
#[repr(C)]
pub struct Slot<T> {
    value: T,
    tag: u32,
}

/// The tag of a written slot ("WWWW", written): one byte repeated, so that a Thumb-2
/// compare takes it as an immediate and the check is a load and a compare.
const WRITTEN: u32 = 0x5757_5757;

impl<T> Slot<T> {
    /// The slot of `value`, tagged as written.
    pub fn new(value: T) -> Self {
        Slot {
            value,
            tag: WRITTEN,
        }
    }
}

/// `Ok` if none of `pointers`, each an address and the alignment its type needs, is null
/// or misaligned; else the refusal of the first that is.
#[inline(always)]
pub fn checked<const N: usize>(pointers: [(usize, usize); N]) -> Result<(), Refused> {
    if valid(pointers) {
        return Ok(());
    }
    // `valid` said one is refused, so `refusal` names it; `Null` is never reached.
    Err(refusal(pointers).unwrap_or(Refused::Null))
}

/// Whether none of `pointers` is null or misaligned: one test of all of them (a branch for
/// any null, one for any low address bit its alignment forbids), so that the checks of a
/// call cost a few instructions beside the Rust call. Which pointer was refused, and why,
/// is worked out ([`refusal`]) only when one was.
#[inline(always)]
fn valid<const N: usize>(pointers: [(usize, usize); N]) -> bool {
    let mut misaligned = 0;
    let mut null = false;
    for (address, align) in pointers {
        misaligned |= address & (align - 1);
        null |= address == 0;
    }
    !null & (misaligned == 0)
}

/// The refusal of the first null or misaligned pointer of `pointers`, if one is.
///
/// Inlined, so that the pointers stay in registers on the way that succeeds (a function
/// of its own would take them through memory on every call). The pointers pass through
/// `black_box` first: its tests are then not shared with [`valid`]'s, which the compiler
/// would otherwise compute one pointer at a time on the way that succeeds too.
#[inline(always)]
fn refusal<const N: usize>(pointers: [(usize, usize); N]) -> Option<Refused> {
    for (address, align) in core::hint::black_box(pointers) {
        if address == 0 {
            return Some(Refused::Null);
        }
        if address & (align - 1) != 0 {
            return Some(Refused::Misaligned);
        }
    }
    None
}

/// The argument `p` points to.
///
/// # Safety
///
/// `p` is neither null nor misaligned (the caller [`checked`] it), valid for reads of a
/// `T` for `'a`, and nothing writes it meanwhile.
#[inline(always)]
pub unsafe fn read<'a, T>(p: *const T) -> &'a T {
    // SAFETY: `p` is neither null nor misaligned, valid for reads of a `T` for `'a`,
    // unwritten meanwhile (this function's contract).
    unsafe { &*p }
}

/// The optional argument `p` points to: `None` if `p` is null.
///
/// # Safety
///
/// `p` is null or valid for reads of a `T` for `'a`, and nothing writes it meanwhile.
// A model whose calls take no optional argument (the navigation EKF's) leaves it unused.
#[allow(dead_code)]
pub unsafe fn read_optional<'a, T>(p: *const T) -> Result<Option<&'a T>, Refused> {
    if p.is_null() {
        return Ok(None);
    }
    checked([(p as usize, core::mem::align_of::<T>())])?;
    // SAFETY: `p` is neither null nor misaligned (checked above) and valid for reads
    // (this function's contract).
    Ok(Some(unsafe { read(p) }))
}

/// Where to write a result: `p`, whose contents may be uninitialised.
///
/// # Safety
///
/// `p` is neither null nor misaligned (the caller [`checked`] it), valid for writes of a
/// `T` for `'a`, and nothing else reads or writes it meanwhile.
#[inline(always)]
pub unsafe fn out<'a, T>(p: *mut T) -> &'a mut MaybeUninit<T> {
    // SAFETY: `p` is neither null nor misaligned and valid for writes of a `T`,
    // unaliased, for `'a` (this function's contract); `MaybeUninit<T>` has the layout of
    // `T` and claims nothing of its contents.
    unsafe { &mut *p.cast::<MaybeUninit<T>>() }
}

/// Where to write an optional result: `None` if `p` is null.
///
/// # Safety
///
/// `p` is null or valid for writes of a `T` for `'a`, and nothing else reads or writes
/// it meanwhile.
// A model whose calls return no outcome (the navigation EKF's) leaves it unused.
#[allow(dead_code)]
#[inline(always)]
pub unsafe fn out_optional<'a, T>(p: *mut T) -> Result<Option<&'a mut MaybeUninit<T>>, Refused> {
    if p.is_null() {
        return Ok(None);
    }
    checked([(p as usize, core::mem::align_of::<T>())])?;
    // SAFETY: `p` is neither null nor misaligned (checked above), valid for writes and
    // unaliased (this function's contract).
    Ok(Some(unsafe { out(p) }))
}

/// The storage `p` points to, to construct a `T` in: `S` is the storage type the header
/// declares, at least as large and aligned as a `Slot<T>` (asserted where it is defined).
///
/// # Safety
///
/// As [`out`], for an `S`.
#[inline(always)]
pub unsafe fn slot<'a, S, T>(p: *mut S) -> &'a mut MaybeUninit<Slot<T>> {
    // SAFETY: `p` is neither null nor misaligned for an `S`, so for a `Slot<T>`, which is
    // no larger and no more aligned; valid for writes, unaliased, for `'a` (this
    // function's contract).
    unsafe { &mut *p.cast::<MaybeUninit<Slot<T>>>() }
}

/// The alignment a storage `p` of type `S` is checked for: the storage type's, as the
/// header declares it, which the slot it holds never exceeds (asserted where `S` is
/// defined, and taken as the larger here all the same).
const fn storage_align<S, T>() -> usize {
    let (storage, slot) = (core::mem::align_of::<S>(), core::mem::align_of::<Slot<T>>());
    if storage > slot {
        storage
    } else {
        slot
    }
}

/// The slot in the storage `p` points to, once `p` and `others` (the call's other pointers
/// that may not be null) are neither null nor misaligned and a constructor wrote it (its
/// tag): `S` is the storage type the header declares, as for [`slot`]. Else the refusal of
/// the first pointer refused, `p` first, or `NotInitialised`.
///
/// The tag is checked with the pointers, so that the way that succeeds has a single test
/// of each, and the refusal is worked out only when one fails.
///
/// # Safety
///
/// `p` is null or valid for reads of an `S`, its tag's bytes initialised (the storage was
/// zeroed or a constructor wrote it), and nothing writes it during the call.
#[inline(always)]
unsafe fn written<S, T, const N: usize>(
    p: *const S,
    others: [(usize, usize); N],
) -> Result<*const Slot<T>, Refused> {
    let storage = [(p as usize, storage_align::<S, T>())];
    let p = p.cast::<Slot<T>>();
    if valid(storage) & valid(others) {
        // SAFETY: `p` is neither null nor misaligned for an `S`, so for a `Slot<T>`
        // (checked above); valid for reads, and its tag, a `u32` inside the storage, is
        // initialised (this function's contract).
        if unsafe { core::ptr::addr_of!((*p).tag).read() } == WRITTEN {
            return Ok(p);
        }
    }
    Err(refusal(storage)
        .or_else(|| refusal(others))
        .unwrap_or(Refused::NotInitialised))
}

/// The value in the storage `p` points to, once [`written`] checked it and `others`.
///
/// # Safety
///
/// As [`written`], for `'a`.
#[inline(always)]
pub unsafe fn value<'a, S, T, const N: usize>(
    p: *const S,
    others: [(usize, usize); N],
) -> Result<&'a T, Refused> {
    // SAFETY: as `written` requires (this function's contract).
    let slot = unsafe { written::<S, T, N>(p, others) }?;
    // SAFETY: the tag says that a constructor wrote the whole slot, value included;
    // nothing writes it during `'a` (this function's contract).
    Ok(unsafe { &(*slot).value })
}

/// The value in the storage `p` points to, mutable, once [`written`] checked it and
/// `others`.
///
/// # Safety
///
/// As [`written`], for `'a`; `p` is also null or valid for writes, and nothing else
/// reads the storage meanwhile.
#[inline(always)]
pub unsafe fn value_mut<'a, S, T, const N: usize>(
    p: *mut S,
    others: [(usize, usize); N],
) -> Result<&'a mut T, Refused> {
    // SAFETY: as `written` requires (this function's contract).
    let slot = unsafe { written::<S, T, N>(p, others) }?;
    // SAFETY: the tag says that a constructor wrote the whole slot; `p` is valid for
    // writes and unaliased during `'a` (this function's contract).
    Ok(unsafe { &mut (*slot.cast_mut()).value })
}

/// The value of a check, or the C function returns the status of its refusal.
macro_rules! take {
    ($checked:expr) => {
        match $checked {
            Ok(value) => value,
            Err(refused) => return refused.into(),
        }
    };
}
