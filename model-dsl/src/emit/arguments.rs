//! The arguments of a generated method or constructor: their parameters, the statements
//! binding the entries the code reads, and the checks made where the arguments enter,
//! before anything is computed or stored: every entry read finite, and every covariance a
//! covariance (symmetric, positive semi-definite).

use super::code::{all_finite, reject_non_finite, upper_triangle};
use super::names::ident;
use proc_macro2::{Ident, Literal, TokenStream};
use quote::quote;

/// What a constructor's `# Errors` section says of the check every constructor makes.
pub const REJECTS_NON_FINITE: &str = " [`Status::RejectedInput`] if an entry it reads is not \
     finite (of a symmetric matrix, the upper triangle).";

/// What a filter constructor's `# Errors` section says of its covariance arguments.
pub const REJECTS_NON_COVARIANCE: &str = " [`Status::InvalidCovariance`] if a covariance \
     argument is not symmetric and positive semi-definite (to within rounding; a diagonal \
     one, if a variance is negative).";

/// What a controller constructor's `# Errors` section says of its weight arguments.
pub const REJECTS_NON_WEIGHT: &str = " [`Status::InvalidWeight`] if a weight argument is not \
     positive semi-definite, as its upper triangle reads (to within rounding).";

/// The arguments of a generated method or constructor, the statements unpacking them into
/// the variables the code reads, and those variables, which it rejects unless finite.
#[derive(Default)]
pub struct Arguments {
    /// `name: type`, in order.
    params: Vec<TokenStream>,
    /// `let [..] = *name;`, in order.
    unpack: Vec<TokenStream>,
    /// The variables checked finite before anything is computed.
    checked: Vec<Ident>,
    /// The symmetric matrix arguments' finiteness tests, one library loop each.
    matrices_finite: Vec<TokenStream>,
    /// Their scalar type, `f32` or `f64` (the last one given).
    scalar_type: Option<Ident>,
    /// The tests that the covariance arguments are covariances, made once they are known
    /// finite.
    covariances: Vec<TokenStream>,
    /// The tests that the weight arguments are weights, made once they are known finite.
    weights: Vec<TokenStream>,
}

impl Arguments {
    /// An argument read as it is (a time; a gated step's `t_prev`).
    pub fn plain(&mut self, param: TokenStream) {
        self.params.push(param);
    }

    /// `name: &[S; len]`, unpacked into `vars` and checked finite.
    pub fn array(&mut self, name: &str, vars: Vec<Ident>, ty: &Ident) {
        let arg = ident(name);
        let len = Literal::usize_unsuffixed(vars.len());
        self.params.push(quote! { #arg: &[#ty; #len] });
        self.unpack.push(quote! { let [#(#vars),*] = *#arg; });
        self.checked.extend(vars);
        self.scalar_type = Some(ty.clone());
    }

    /// `name: &[S; len]`, unpacked into `<name>_0`, `<name>_1`, .. (returned) and checked
    /// finite.
    pub fn vector(&mut self, name: &str, len: usize, ty: &Ident) -> Vec<Ident> {
        let entries: Vec<Ident> = (0..len).map(|i| ident(&format!("{name}_{i}"))).collect();
        self.array(name, entries.clone(), ty);
        entries
    }

    /// `name: &[[S; n]; n]`, a symmetric matrix: its upper triangle, the entries read,
    /// unpacked into `<name>_<i>_<j>` and checked finite. Returns them packed, row by row.
    pub fn symmetric(&mut self, name: &str, n: usize, ty: &Ident) -> Vec<Ident> {
        let arg = ident(name);
        let len = Literal::usize_unsuffixed(n);
        let (pattern, packed) = upper_triangle(name, n);
        self.params.push(quote! { #arg: &[[#ty; #len]; #len] });
        self.unpack.push(quote! { let #pattern = *#arg; });
        // A loop: a test of each of a 100-state covariance's 5050 entries would be
        // 5050 branches, a chain LLVM's jump threading recursed through until rustc's
        // stack overflowed.
        self.matrices_finite
            .push(quote! { stateforge_math::#ty::upper_triangle_finite(#arg) });
        self.scalar_type = Some(ty.clone());
        packed
    }

    /// A weight `name: &[[S; n]; n]` (a controller's state or input weight): a
    /// [`Arguments::symmetric`] matrix, then tested positive semi-definite from its upper
    /// triangle (`stateforge_math`'s `is_weight`). Returns its upper triangle's entries.
    pub fn weight(&mut self, name: &str, n: usize, ty: &Ident) -> Vec<Ident> {
        let packed = self.symmetric(name, n, ty);
        let arg = ident(name);
        self.weights
            .push(quote! { stateforge_math::#ty::is_weight(#arg) });
        packed
    }

    /// A covariance `name: &[[S; n]; n]`: its upper triangle tested finite, then the
    /// matrix tested symmetric and positive semi-definite (`stateforge_math`'s
    /// `is_covariance`), both by library loops. Returns its upper triangle packed row by
    /// row, as an expression (`stateforge_math::f32::pack_upper(p0)`), so that a
    /// 100-state covariance is a few instructions to check and store, not 5050 of each
    /// (rustc's release build of that code took minutes).
    pub fn covariance(&mut self, name: &str, n: usize, ty: &Ident) -> TokenStream {
        let arg = ident(name);
        let len = Literal::usize_unsuffixed(n);
        self.params.push(quote! { #arg: &[[#ty; #len]; #len] });
        self.matrices_finite
            .push(quote! { stateforge_math::#ty::upper_triangle_finite(#arg) });
        self.covariances.push(covariance_test(name, false, ty));
        self.scalar_type = Some(ty.clone());
        quote! { stateforge_math::#ty::pack_upper(#arg) }
    }

    /// A further test of a covariance argument, made with the tests that they are
    /// covariances (a structural zero it must have: between two blocks of the covariance,
    /// between two sensors' noise).
    pub fn covariance_structure(&mut self, test: TokenStream) {
        self.covariances.push(test);
    }

    /// A process noise covariance `name` (`n x n`): its variances if `diagonal`
    /// ([`Arguments::vector`], tested non-negative; the array itself), else a
    /// [`Arguments::covariance`]. Returns the value stored, as an expression.
    pub fn process_noise(
        &mut self,
        name: &str,
        n: usize,
        diagonal: bool,
        ty: &Ident,
    ) -> TokenStream {
        if diagonal {
            self.vector(name, n, ty);
            self.covariances.push(covariance_test(name, true, ty));
            let arg = ident(name);
            quote! { *#arg }
        } else {
            self.covariance(name, n, ty)
        }
    }

    /// A time `name: S`, checked finite when the code reads it (`read`; a NaN time would
    /// only show as a non-finite estimate), else named `_name`.
    pub fn time(&mut self, name: &str, read: bool, ty: &Ident) {
        if read {
            let arg = ident(name);
            self.params.push(quote! { #arg: #ty });
            self.checked.push(arg);
            self.scalar_type = Some(ty.clone());
        } else {
            let arg = ident(&format!("_{name}"));
            self.params.push(quote! { #arg: #ty });
        }
    }

    /// `name: S`, bound to `var` and checked finite.
    pub fn scalar(&mut self, name: &str, var: Ident, ty: &Ident) {
        let arg = ident(name);
        self.params.push(quote! { #arg: #ty });
        self.unpack.push(quote! { let #var = #arg; });
        self.checked.push(var);
        self.scalar_type = Some(ty.clone());
    }

    /// `pub fn name(&mut self, ..) -> Status`, documented by the attributes `doc`: unpacks
    /// and checks the arguments, then runs `body` (which ends by returning the status).
    pub fn method(self, name: &Ident, doc: &TokenStream, body: TokenStream) -> TokenStream {
        self.method_with(quote! { pub }, name, doc, body)
    }

    /// The parameters, `name: type`, in order.
    pub fn params(&self) -> &[TokenStream] {
        &self.params
    }

    /// [`Arguments::method`] with `visibility` (and attributes) in place of `pub`.
    fn method_with(
        self,
        visibility: TokenStream,
        name: &Ident,
        doc: &TokenStream,
        body: TokenStream,
    ) -> TokenStream {
        let Arguments {
            params,
            unpack,
            checked,
            matrices_finite,
            scalar_type,
            covariances,
            weights,
        } = self;
        let check = scalar_type.map(|ty| reject_non_finite(&checked, &matrices_finite, &ty));
        let covariance_check = reject_non_covariance(&covariances, false);
        let weight_check = reject(&weights, &quote! { Status::InvalidWeight });
        quote! {
            #doc
            #visibility fn #name(&mut self, #(#params),*) -> Status {
                #(#unpack)*
                #check
                #covariance_check
                #weight_check
                #body
            }
        }
    }

    /// [`Arguments::method`] as a private `fn`, out of line: a cold path of a public
    /// method (the continuous-time EKF's `step_split`).
    pub fn private_method(self, name: &Ident, doc: &TokenStream, body: TokenStream) -> TokenStream {
        self.method_with(quote! { #[inline(never)] }, name, doc, body)
    }

    /// `pub fn new(..) -> Result<Self, Status>`, documented by the attributes `doc` and
    /// its `# Errors` section, `errors` ([`REJECTS_NON_FINITE`], and what else `body`
    /// rejects): unpacks the arguments and returns `Err(Status::RejectedInput)` unless
    /// every entry read is finite, then runs `body` (which ends in `Ok(..)`, or returns
    /// another `Err`).
    pub fn constructor(self, doc: &TokenStream, errors: &str, body: TokenStream) -> TokenStream {
        let Arguments {
            params,
            unpack,
            checked,
            matrices_finite,
            scalar_type,
            covariances,
            weights,
        } = self;
        let check = scalar_type.and_then(|ty| {
            let finite = all_finite(&checked, &matrices_finite, &ty)?;
            Some(quote! {
                if !#finite {
                    return Err(Status::RejectedInput);
                }
            })
        });
        let covariance_check = reject_non_covariance(&covariances, true);
        let covariance_errors = (!covariances.is_empty()).then(|| {
            quote! {
                ///
                #[doc = #REJECTS_NON_COVARIANCE]
            }
        });
        let weight_check = reject(&weights, &quote! { Err(Status::InvalidWeight) });
        let weight_errors = (!weights.is_empty()).then(|| {
            quote! {
                ///
                #[doc = #REJECTS_NON_WEIGHT]
            }
        });
        quote! {
            #doc
            ///
            /// # Errors
            ///
            #[doc = #errors]
            #covariance_errors
            #weight_errors
            pub fn new(#(#params),*) -> Result<Self, Status> {
                #(#unpack)*
                #check
                #covariance_check
                #weight_check
                #body
            }
        }
    }
}

/// `stateforge_math::<ty>::is_covariance(name)`, or `all_non_negative(name)` of the
/// variances of a `diagonal` covariance.
pub fn covariance_test(name: &str, diagonal: bool, ty: &Ident) -> TokenStream {
    let arg = ident(name);
    if diagonal {
        quote! { stateforge_math::#ty::all_non_negative(#arg) }
    } else {
        quote! { stateforge_math::#ty::is_covariance(#arg) }
    }
}

/// `if !(test && ..) { return Status::InvalidCovariance; }` (`Err(..)` in a
/// `constructor`), or nothing without a test.
pub fn reject_non_covariance(tests: &[TokenStream], constructor: bool) -> Option<TokenStream> {
    let status = if constructor {
        quote! { Err(Status::InvalidCovariance) }
    } else {
        quote! { Status::InvalidCovariance }
    };
    reject(tests, &status)
}

/// `if !(test && ..) { return refusal; }`, or nothing without a test.
fn reject(tests: &[TokenStream], refusal: &TokenStream) -> Option<TokenStream> {
    (!tests.is_empty()).then(|| {
        quote! {
            if !(#(#tests)&&*) {
                return #refusal;
            }
        }
    })
}
