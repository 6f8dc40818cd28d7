//! Conversions between the generated arrays and `nalgebra`'s statically sized matrices,
//! emitted when the macro's `nalgebra` feature is on. Every generated matrix is an array of
//! rows, `[[S; C]; R]`, while `SMatrix::from([[S; R]; C])` reads an array of columns: the
//! natural `SMatrix::from(jacobian)` compiles for a square matrix and silently transposes
//! it. These functions read rows as rows.

use proc_macro2::TokenStream;
use quote::quote;

/// The `interop` module of a model, in the user's crate, which must depend on `nalgebra`.
pub fn nalgebra_module() -> TokenStream {
    quote! {
        /// Conversions between the generated arrays (matrices row by row, `[[S; C]; R]`)
        /// and `nalgebra`'s `SMatrix` / `SVector`, in the right orientation
        /// (`SMatrix::from` reads arrays of columns, and would transpose).
        pub mod interop {
            /// The generated matrix `rows` (`R` rows of `C` entries) as an `SMatrix`.
            #[must_use]
            pub fn to_matrix<S: ::nalgebra::Scalar + Copy, const R: usize, const C: usize>(
                rows: &[[S; C]; R],
            ) -> ::nalgebra::SMatrix<S, R, C> {
                ::nalgebra::SMatrix::from_fn(|i, j| rows[i][j])
            }

            /// An `SMatrix` as the generated layout: `R` rows of `C` entries.
            #[must_use]
            pub fn from_matrix<S: ::nalgebra::Scalar + Copy, const R: usize, const C: usize>(
                matrix: &::nalgebra::SMatrix<S, R, C>,
            ) -> [[S; C]; R] {
                ::core::array::from_fn(|i| ::core::array::from_fn(|j| matrix[(i, j)]))
            }

            /// A generated vector (a state, an input, a measurement) as an `SVector`.
            #[must_use]
            pub fn to_vector<S: ::nalgebra::Scalar + Copy, const N: usize>(
                entries: &[S; N],
            ) -> ::nalgebra::SVector<S, N> {
                ::nalgebra::SVector::from_fn(|i, _| entries[i])
            }

            /// An `SVector` as a generated vector.
            #[must_use]
            pub fn from_vector<S: ::nalgebra::Scalar + Copy, const N: usize>(
                vector: &::nalgebra::SVector<S, N>,
            ) -> [S; N] {
                ::core::array::from_fn(|i| vector[i])
            }

            /// A rotation as the model stores it, the unit quaternion `[x, y, z, w]` (a
            /// `Rot3` field of `State` or `Input`, four entries of a state), as a
            /// `UnitQuaternion`: the same order as `Quaternion::coords`. Not normalised
            /// again: the filters keep theirs unit. Not for a `w`-first array.
            #[must_use]
            pub fn to_rotation<S: ::nalgebra::RealField + Copy>(
                q: &[S; 4],
            ) -> ::nalgebra::UnitQuaternion<S> {
                let [x, y, z, w] = *q;
                ::nalgebra::UnitQuaternion::new_unchecked(::nalgebra::Quaternion::new(w, x, y, z))
            }

            /// A `UnitQuaternion` as the model stores a rotation, `[x, y, z, w]`.
            #[must_use]
            pub fn from_rotation<S: ::nalgebra::RealField + Copy>(
                q: &::nalgebra::UnitQuaternion<S>,
            ) -> [S; 4] {
                [q.i, q.j, q.k, q.w]
            }
        }
    }
}
