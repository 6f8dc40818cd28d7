//! The size of the storage a C program reserves for a generated type: an upper bound of
//! the type's size, from its fields' types laid out as C lays out a struct, in
//! declaration order (Rust reorders fields to pad less, so its layout is never larger),
//! with the wrapper's tag after it. The companion crate asserts at compile time that the Rust type
//! fits (`const _: () = assert!(..)`), so a bound too small is a build error, never an
//! overrun. A field may be a struct or a fieldless enum of the generated code (`PredictionModel`),
//! or the one type of `stateforge-math` a generated type holds (`HeldLimits`).

use super::records::Known;

/// The alignment of every storage: that of `uint64_t` and `double`, the largest any
/// generated field has (a `usize` is counted as 8 bytes, its size on a 64-bit host).
pub const ALIGN: usize = 8;

/// The bytes of the wrapper's tag after the value: a `u32`, and padding before it (up to
/// 4 bytes after a value of 4-byte alignment) or after it (to the 8-byte alignment of a
/// value that has it).
const TAG: usize = ALIGN;

/// How deep structs may nest in a storage's type (the generated code's nest one deep).
const NESTING: usize = 4;

/// The storage's size for a type with fields `fields` (their types as the code writes
/// them), a multiple of [`ALIGN`]; `None` if a field's type has no known layout.
pub fn size(fields: &[String], known: &Known) -> Option<usize> {
    let (end, _) = fields_layout(fields, known, NESTING)?;
    (TAG.checked_add(end)?).checked_next_multiple_of(ALIGN)
}

/// The size and alignment of a struct with fields `fields`, laid out as C would: each
/// field after the last, padded to its alignment, the whole to the largest.
fn fields_layout(fields: &[String], known: &Known, depth: usize) -> Option<(usize, usize)> {
    let mut end: usize = 0;
    let mut largest = 1;
    for field in fields {
        let (size, align) = layout(field, known, depth)?;
        end = end.checked_next_multiple_of(align)?.checked_add(size)?;
        largest = largest.max(align);
    }
    Some((end.checked_next_multiple_of(largest)?, largest))
}

/// The size and alignment of a field's type, at least what Rust gives it.
fn layout(ty: &str, known: &Known, depth: usize) -> Option<(usize, usize)> {
    match ty {
        "f32" | "u32" | "i32" => return Some((4, 4)),
        "f64" | "u64" | "i64" | "usize" | "isize" => return Some((8, 8)),
        "bool" | "u8" | "i8" => return Some((1, 1)),
        "u16" | "i16" => return Some((2, 2)),
        _ => {}
    }
    if let Some(inner) = ty.strip_prefix("Option<").and_then(|t| t.strip_suffix('>')) {
        // The discriminant before the value, padded to its alignment.
        let (size, align) = layout(inner, known, depth)?;
        return Some((align.checked_add(size)?, align));
    }
    if let Some(inner) = ty.strip_prefix('[').and_then(|t| t.strip_suffix(']')) {
        let (element, count) = inner.rsplit_once(';')?;
        let count: usize = count.trim().parse().ok()?;
        let (size, align) = layout(element.trim(), known, depth)?;
        return Some((size.checked_mul(count)?, align));
    }
    if known.enumeration(ty).is_some() || ty == "Status" {
        // Fieldless, with at most 256 variants: one byte.
        return Some((1, 1));
    }
    if let Some(fields) = known.struct_fields(ty) {
        return fields_layout(fields, known, depth.checked_sub(1)?);
    }
    held_limits(ty)
}

/// `stateforge_math::HeldLimits<M, R>`: `[i8; M]` then `[i8; R]`.
fn held_limits(ty: &str) -> Option<(usize, usize)> {
    let compact = ty.replace(' ', "");
    let generics = compact
        .strip_prefix("stateforge_math::HeldLimits<")?
        .strip_suffix('>')?;
    let (moves, rows) = generics.split_once(',')?;
    let moves: usize = moves.parse().ok()?;
    let rows: usize = rows.parse().ok()?;
    Some((moves.checked_add(rows)?, 1))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn known(code: &str) -> Known {
        let file: syn::File = syn::parse_str(code).expect("parses");
        super::super::records::read(&file.items, super::super::values::Scalar::F32)
    }

    #[test]
    fn storage_bounds_the_c_layout() {
        let none = known("");
        let layout = |ty: &str| layout(ty, &none, NESTING);
        assert_eq!(layout("[[f32; 5]; 5]"), Some((100, 4)));
        assert_eq!(layout("Option<[f32; 1]>"), Some((8, 4)));
        assert_eq!(layout("[bool; 5]"), Some((5, 1)));
        assert_eq!(layout("WindowStatus"), None);
        assert_eq!(layout("[f32; 18446744073709551615]"), None);
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
        assert_eq!(size(&fields, &none), Some(128));
        let fields = ["bool".to_owned(), "f64".to_owned()];
        assert_eq!(size(&fields, &none), Some(8 + 16));
    }

    #[test]
    fn nested_structs_enums_and_the_held_limits_are_laid_out() {
        let known = known(
            "pub enum MpcRebuild { Nothing, Problem }
             pub struct PredictionModel { pub a: [[f32; 2]; 2], pub b: [[f32; 1]; 2] }
             struct Outer { model: PredictionModel, flag: bool }
             struct Loop { inner: Loop }",
        );
        let layout = |ty: &str| layout(ty, &known, NESTING);
        assert_eq!(layout("PredictionModel"), Some((24, 4)));
        assert_eq!(layout("Outer"), Some((28, 4)));
        assert_eq!(layout("MpcRebuild"), Some((1, 1)));
        assert_eq!(layout("Option<MpcRebuild>"), Some((2, 1)));
        assert_eq!(
            layout("stateforge_math :: HeldLimits<32, 64>"),
            Some((96, 1))
        );
        // A type that holds itself is refused, not followed forever.
        assert_eq!(layout("Loop"), None);
        let fields = [
            "stateforge_math::HeldLimits<3, 5>".to_owned(),
            "f32".to_owned(),
        ];
        assert_eq!(size(&fields, &known), Some(24));
    }
}
