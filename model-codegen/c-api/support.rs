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

/// The tag of a written slot (`SFGW`, "stateforge written").
const WRITTEN: u32 = 0x5346_4757;

impl<T> Slot<T> {
    /// The slot of `value`, tagged as written.
    pub fn new(value: T) -> Self {
        Slot {
            tag: WRITTEN,
            value,
        }
    }
}

/// `Ok` if `p` is neither null nor misaligned for a `T`.
fn check<T>(p: *const T) -> Result<(), Refused> {
    if p.is_null() {
        Err(Refused::Null)
    } else if !p.is_aligned() {
        Err(Refused::Misaligned)
    } else {
        Ok(())
    }
}

/// The argument `p` points to.
///
/// # Safety
///
/// `p` is null or valid for reads of a `T` for `'a`, and nothing writes it meanwhile.
pub unsafe fn read<'a, T>(p: *const T) -> Result<&'a T, Refused> {
    check(p)?;
    // SAFETY: `p` is neither null nor misaligned (checked above) and valid for reads of
    // a `T` for `'a`, unwritten meanwhile (this function's contract).
    Ok(unsafe { &*p })
}

/// The optional argument `p` points to: `None` if `p` is null.
///
/// # Safety
///
/// As [`read`].
pub unsafe fn read_optional<'a, T>(p: *const T) -> Result<Option<&'a T>, Refused> {
    if p.is_null() {
        return Ok(None);
    }
    // SAFETY: `p` is valid for reads as `read` requires (this function's contract).
    unsafe { read(p) }.map(Some)
}

/// Where to write a result: `p`, whose contents may be uninitialised.
///
/// # Safety
///
/// `p` is null or valid for writes of a `T` for `'a`, and nothing else reads or writes it
/// meanwhile.
pub unsafe fn out<'a, T>(p: *mut T) -> Result<&'a mut MaybeUninit<T>, Refused> {
    check(p)?;
    // SAFETY: `p` is neither null nor misaligned (checked above) and valid for writes of
    // a `T`, unaliased, for `'a` (this function's contract); `MaybeUninit<T>` has the
    // layout of `T` and claims nothing of its contents.
    Ok(unsafe { &mut *p.cast::<MaybeUninit<T>>() })
}

/// The storage `p` points to, to construct a `T` in: `S` is the storage type the header
/// declares, at least as large and aligned as a `Slot<T>` (asserted where it is defined).
///
/// # Safety
///
/// As [`out`], for an `S`.
pub unsafe fn slot<'a, S, T>(p: *mut S) -> Result<&'a mut MaybeUninit<Slot<T>>, Refused> {
    check(p)?;
    // SAFETY: `p` is neither null nor misaligned for an `S` (checked above), so for a
    // `Slot<T>`, which is no larger and no more aligned; valid for writes, unaliased, for
    // `'a` (this function's contract).
    Ok(unsafe { &mut *p.cast::<MaybeUninit<Slot<T>>>() })
}

/// The value in the storage `p` points to, if a constructor wrote it: `S` is the storage
/// type, as for [`slot`].
///
/// # Safety
///
/// `p` is null or valid for reads of an `S` for `'a`, nothing writes it meanwhile, and
/// its tag was initialised: the storage was zeroed or a constructor wrote it.
pub unsafe fn value<'a, S, T>(p: *const S) -> Result<&'a T, Refused> {
    check(p)?;
    let p = p.cast::<Slot<T>>();
    // SAFETY: `p` is neither null nor misaligned (checked above, for the larger alignment
    // of `S`) and its tag, the first field of the `repr(C)` slot, is initialised (this
    // function's contract).
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
pub unsafe fn value_mut<'a, S, T>(p: *mut S) -> Result<&'a mut T, Refused> {
    // SAFETY: as `value` requires (this function's contract).
    unsafe { value::<S, T>(p) }?;
    // SAFETY: `value` checked the pointer and the tag; the storage is not aliased (this
    // function's contract).
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
