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

/// The storage of a generated filter or controller: a tag saying that its constructor
/// wrote it, then the value. Storage the C program zeroed (a `static`) has no tag.
#[repr(C)]
pub struct Slot<T> {
    tag: u32,
    value: T,
}

/// The tag of a written slot ("WWWW", written): one byte repeated, so that a Thumb-2
/// compare takes it as an immediate and the check is a load and a compare.
const WRITTEN: u32 = 0x5757_5757;

impl<T> Slot<T> {
    /// The slot of `value`, tagged as written.
    pub fn new(value: T) -> Self {
        Slot {
            tag: WRITTEN,
            value,
        }
    }
}

/// `Ok` if none of `pointers`, each an address and the alignment its type needs, is null
/// or misaligned; else the refusal of the first that is, null before misaligned.
///
/// One test of all of them on the way that succeeds (a branch for any null, one for any
/// low address bit its alignment forbids), so that the checks of a call cost a few
/// instructions beside the Rust call; which pointer was refused, and why, is worked out
/// only when one was.
#[inline(always)]
pub fn checked<const N: usize>(pointers: [(usize, usize); N]) -> Result<(), Refused> {
    let mut misaligned = 0;
    let mut null = false;
    for (address, align) in pointers {
        misaligned |= address & (align - 1);
        null |= address == 0;
    }
    if null || misaligned != 0 {
        return Err(first_refusal(pointers));
    }
    Ok(())
}

/// The refusal of the first null or misaligned pointer of `pointers`: inlined, so that
/// the pointers stay in registers (a function of its own would take them through memory
/// on every call, refused or not).
#[inline(always)]
fn first_refusal<const N: usize>(pointers: [(usize, usize); N]) -> Refused {
    for (address, align) in pointers {
        if address == 0 {
            return Refused::Null;
        }
        if address & (align - 1) != 0 {
            return Refused::Misaligned;
        }
    }
    Refused::Null
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

/// The value in the storage `p` points to, if a constructor wrote it: `S` is the storage
/// type, as for [`slot`].
///
/// # Safety
///
/// `p` is neither null nor misaligned for an `S` (the caller [`checked`] it), valid for
/// reads of an `S` for `'a`, nothing writes it meanwhile, and its tag was initialised:
/// the storage was zeroed or a constructor wrote it.
#[inline(always)]
pub unsafe fn value<'a, S, T>(p: *const S) -> Result<&'a T, Refused> {
    let p = p.cast::<Slot<T>>();
    // SAFETY: `p` is neither null nor misaligned (for the larger alignment of `S`) and
    // its tag, the first field of the `repr(C)` slot, is initialised (this function's
    // contract).
    let tag = unsafe { p.cast::<u32>().read() };
    if tag != WRITTEN {
        return Err(Refused::NotInitialised);
    }
    // SAFETY: the tag says that a constructor wrote the whole slot, value included;
    // nothing writes it during `'a` (this function's contract).
    Ok(unsafe { &(*p).value })
}

/// The value in the storage `p` points to, mutable, if a constructor wrote it.
///
/// # Safety
///
/// As [`value`], and nothing else reads the storage meanwhile.
#[inline(always)]
pub unsafe fn value_mut<'a, S, T>(p: *mut S) -> Result<&'a mut T, Refused> {
    // SAFETY: as `value` requires (this function's contract).
    unsafe { value::<S, T>(p) }?;
    // SAFETY: `value` checked the tag; the storage is not aliased (this function's
    // contract).
    Ok(unsafe { &mut (*p.cast::<Slot<T>>()).value })
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
