//! The size of the storage a C program reserves for a generated type: an upper bound of
//! the type's size, from its fields' types laid out as C lays out a struct, in
//! declaration order (Rust reorders fields to pad less, so its layout is never larger),
//! with the wrapper's tag after it. The companion crate asserts at compile time that the Rust type
//! fits (`const _: () = assert!(..)`), so a bound too small is a build error, never an
//! overrun.

/// The alignment of every storage: that of `uint64_t` and `double`, the largest any
/// generated field has (a `usize` is counted as 8 bytes, its size on a 64-bit host).
pub const ALIGN: usize = 8;

/// The bytes of the wrapper's tag after the value: a `u32`, and up to 4 bytes of padding
/// before it.
const TAG: usize = ALIGN;

/// The storage's size for a type with fields `fields` (their types as the code writes
/// them), a multiple of [`ALIGN`]; `None` if a field's type has no known layout.
pub fn size(fields: &[String]) -> Option<usize> {
    let mut end: usize = 0;
    for field in fields {
        let (size, align) = layout(field)?;
        end = end.next_multiple_of(align) + size;
    }
    Some((TAG + end).next_multiple_of(ALIGN))
}

/// The size and alignment of a field's type, at least what Rust gives it.
fn layout(ty: &str) -> Option<(usize, usize)> {
    match ty {
        "f32" | "u32" | "i32" => return Some((4, 4)),
        "f64" | "u64" | "i64" | "usize" | "isize" => return Some((8, 8)),
        "bool" | "u8" | "i8" => return Some((1, 1)),
        "u16" | "i16" => return Some((2, 2)),
        _ => {}
    }
    if let Some(inner) = ty.strip_prefix("Option<").and_then(|t| t.strip_suffix('>')) {
        // The discriminant before the value, padded to its alignment.
        let (size, align) = layout(inner)?;
        return Some((align + size, align));
    }
    let inner = ty.strip_prefix('[')?.strip_suffix(']')?;
    let (element, count) = inner.rsplit_once(';')?;
    let count: usize = count.trim().parse().ok()?;
    let (size, align) = layout(element.trim())?;
    Some((size.checked_mul(count)?, align))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn storage_bounds_the_c_layout() {
        assert_eq!(layout("[[f32; 5]; 5]"), Some((100, 4)));
        assert_eq!(layout("Option<[f32; 1]>"), Some((8, 4)));
        assert_eq!(layout("[bool; 5]"), Some((5, 1)));
        assert_eq!(layout("WindowStatus"), None);
        // The cantilever's EKF: 5 + 15 + 5 + 1 + 1 + 1 floats and a count, then the tag.
        let ekf = [
            "[f32; 5]",
            "[f32; 15]",
            "[f32; 5]",
            "[f32; 1]",
            "[f32; 1]",
            "[f32; 1]",
            "u32",
        ];
        let fields: Vec<String> = ekf.iter().map(|&f| f.to_owned()).collect();
        assert_eq!(size(&fields), Some(128));
        let fields = ["bool".to_owned(), "f64".to_owned()];
        assert_eq!(size(&fields), Some(8 + 16));
    }
}
