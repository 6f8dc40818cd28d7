//! The `model!` grammar: tokens to a [`ModelDecl`].
//!
//! ```text
//! model       := doc* vis 'mod' IDENT '{' item* '}'
//! item        := doc* ( 'scalar' IDENT,+ ';'
//!                     | 'const' IDENT '=' expr ';'
//!                     | ('state' | 'param' | 'input' | 'known') (doc* IDENT [':' TYPE]),+ ';'
//!                     | 'output' (doc* IDENT '=' expr),+ ';'
//!                     | 'sensor' IDENT ['(' (IDENT '=' value),* ')'] '=' '[' IDENT,+ ']' ';'
//!                     | 'dynamics' ('discrete' | 'continuous' ['(' method [',' 'dt' '=' expr] [',' 'substeps' '=' INT] ')'])
//!                       '{' (('let' IDENT | IDENT | 'der' '(' IDENT ')') '=' expr ';')* '}'
//!                     | 'generate' (IDENT ['(' (IDENT '=' value),* ')']),+ ';' )
//! value       := number | IDENT | '[' IDENT,* ']' | '[' number,* ']' | '[' (IDENT '=' number),+ ']'
//! ```
//! Expressions are Rust expressions restricted to arithmetic, calls of the model
//! functions (`sin cos tan tanh exp ln sqrt abs powi atan2 min max clamp`, also as methods,
//! `x.sin()`, `y.atan2(x)`), and `if a > b { .. } else { .. }`; with `TYPE` `Vec3` or
//! `Rot3`, also vectors and rotations (`vec3(a, b, c)`, `v.x`, `q * v`, `exp(theta)`, ..:
//! the typed calls are checked in `check`).

use crate::ast::{
    ArgValue, BinaryOp, Comparison, ConstDecl, DynamicsDecl, DynamicsKind, GenerateArg,
    GenerateDecl, ModelDecl, Name, OutputDecl, SensorDecl, Statement, SurfaceExpr, SurfaceKind,
    SymbolDecl, SymbolKind,
};
use crate::diagnostics::Diagnostics;
use proc_macro2::{Span, TokenStream};
use quote::ToTokens;
use syn::buffer::Cursor;
use syn::parse::{Parse, ParseStream, Parser};
use syn::spanned::Spanned;
use syn::{braced, parenthesized, Attribute, Expr, Ident, Token};

mod kw {
    syn::custom_keyword!(scalar);
    syn::custom_keyword!(state);
    syn::custom_keyword!(param);
    syn::custom_keyword!(input);
    syn::custom_keyword!(known);
    syn::custom_keyword!(interval);
    syn::custom_keyword!(output);
    syn::custom_keyword!(sensor);
    syn::custom_keyword!(dynamics);
    syn::custom_keyword!(discrete);
    syn::custom_keyword!(continuous);
    syn::custom_keyword!(der);
    syn::custom_keyword!(dt);
    syn::custom_keyword!(substeps);
    syn::custom_keyword!(generate);
}

/// Parses the body of a `model!` invocation. Syntax errors stop the parse; mistakes inside
/// well-formed expressions and doc attributes are collected in the returned diagnostics,
/// for the checker to report together with its own.
pub fn parse_model(tokens: TokenStream) -> syn::Result<(ModelDecl, Diagnostics)> {
    super::limits::check_tokens(&tokens)?;
    let mut diag = Diagnostics::default();
    let decl = (|input: ParseStream| {
        let decl = parse_decl(input, &mut diag)?;
        if !input.is_empty() {
            return Err(input
                .error("one `model!` declares one model: give this one its own `model! { .. }`"));
        }
        Ok(decl)
    })
    .parse2(tokens)?;
    Ok((decl, diag))
}

fn parse_decl(input: ParseStream, diag: &mut Diagnostics) -> syn::Result<ModelDecl> {
    let docs = docs(&Attribute::parse_outer(input)?, diag);
    let vis: syn::Visibility = input.parse()?;
    input.parse::<Token![mod]>()?;
    let name = name(&input.parse::<Ident>()?);
    let content;
    let brace = braced!(content in input);
    let mut decl = ModelDecl {
        docs,
        vis: vis.into_token_stream(),
        span: brace.span.join(),
        name,
        scalars: Vec::new(),
        constants: Vec::new(),
        symbols: Vec::new(),
        outputs: Vec::new(),
        sensors: Vec::new(),
        dynamics: Vec::new(),
        generate: Vec::new(),
    };
    while !content.is_empty() {
        parse_item(&content, &mut decl, diag)?;
    }
    Ok(decl)
}

fn parse_item(input: ParseStream, decl: &mut ModelDecl, diag: &mut Diagnostics) -> syn::Result<()> {
    let mut attrs = Attribute::parse_outer(input)?;
    let allow_unused = take_allow_unused(&mut attrs);
    let docs = docs(&attrs, diag);
    let symbols = [
        input.peek(kw::param),
        input.peek(kw::input),
        input.peek(kw::known),
    ];
    if let (Some(span), false) = (allow_unused, symbols.contains(&true)) {
        diag.error(span, ALLOW_UNUSED_APPLIES_TO);
    }
    let look = input.lookahead1();
    if look.peek(kw::scalar) {
        parse_scalar(input, decl, diag)?;
    } else if look.peek(Token![const]) || look.peek(kw::interval) {
        let constant = parse_const(input, docs, diag)?;
        decl.constants.push(constant);
    } else if look.peek(kw::state)
        || look.peek(kw::param)
        || look.peek(kw::input)
        || look.peek(kw::known)
    {
        let symbols = parse_symbols(input, &docs, allow_unused.is_some(), diag)?;
        decl.symbols.extend(symbols);
    } else if look.peek(kw::output) {
        let outputs = parse_outputs(input, &docs, diag)?;
        decl.outputs.extend(outputs);
    } else if look.peek(kw::sensor) {
        let sensor = parse_sensor(input, docs, diag)?;
        decl.sensors.push(sensor);
    } else if look.peek(kw::dynamics) {
        let dynamics = parse_dynamics(input, diag)?;
        decl.dynamics.push(dynamics);
    } else if look.peek(kw::generate) {
        input.parse::<kw::generate>()?;
        let items = input.parse_terminated_until_semi(parse_generate_item, diag)?;
        decl.generate.extend(items);
    } else {
        return Err(look.error());
    }
    Ok(())
}

/// `scalar f32, f64;`: the scalar types, declared once.
fn parse_scalar(
    input: ParseStream,
    decl: &mut ModelDecl,
    diag: &mut Diagnostics,
) -> syn::Result<()> {
    let keyword = input.parse::<kw::scalar>()?;
    let types = input.parse_terminated_until_semi(|i| i.parse::<Ident>(), diag)?;
    if types.is_empty() {
        return Err(syn::Error::new(
            keyword.span,
            "write `scalar f32;` or `scalar f64;`",
        ));
    }
    if !decl.scalars.is_empty() {
        diag.error(keyword.span, "the scalar type is declared twice");
    }
    decl.scalars.extend(types.iter().map(name));
    Ok(())
}

/// `const NAME = expr;`, or `interval NAME = expr;`.
fn parse_const(
    input: ParseStream,
    docs: Vec<String>,
    diag: &mut Diagnostics,
) -> syn::Result<ConstDecl> {
    let start = input.cursor();
    let interval = match input.parse::<Option<kw::interval>>()? {
        Some(keyword) => Some(keyword.span),
        None => {
            input.parse::<Token![const]>()?;
            None
        }
    };
    let ident: Ident = input.parse()?;
    input.parse::<Token![=]>()?;
    let value = expr(&input.parse()?, diag);
    end_with_semi(input, start, &ITEM, diag)?;
    Ok(ConstDecl {
        docs,
        name: name(&ident),
        value,
        interval,
    })
}

/// `state a, b;` (or `param`, `input`, `known`): each name with its own doc comment, or
/// the item's, and `#[allow(unused)]` on the list or on the name.
fn parse_symbols(
    input: ParseStream,
    docs: &[String],
    list_allows_unused: bool,
    diag: &mut Diagnostics,
) -> syn::Result<Vec<SymbolDecl>> {
    let kind = if input.parse::<Option<kw::state>>()?.is_some() {
        SymbolKind::State
    } else if input.parse::<Option<kw::param>>()?.is_some() {
        SymbolKind::Param
    } else if input.parse::<Option<kw::known>>()?.is_some() {
        SymbolKind::Known
    } else {
        input.parse::<kw::input>()?;
        SymbolKind::Input
    };
    let entries = input.parse_terminated_until_semi(
        |i| {
            let own = Attribute::parse_outer(i)?;
            let ident = i.parse::<Ident>()?;
            let ty = match i.parse::<Option<Token![:]>>()? {
                Some(_) => Some(i.parse::<Ident>()?),
                None => None,
            };
            Ok((own, ident, ty))
        },
        diag,
    )?;
    let symbols = entries.into_iter().map(|(mut own, ident, ty)| {
        let own_allows_unused = take_allow_unused(&mut own);
        if let (Some(span), SymbolKind::State) = (own_allows_unused, kind) {
            diag.error(span, ALLOW_UNUSED_APPLIES_TO);
        }
        let allow_unused = own_allows_unused.is_some() || list_allows_unused;
        let own = self::docs(&own, diag);
        SymbolDecl {
            docs: if own.is_empty() { docs.to_vec() } else { own },
            name: name(&ident),
            kind,
            ty: ty.as_ref().map(name),
            allow_unused,
        }
    });
    Ok(symbols.collect())
}

/// `output y = expr, z = expr;`: each output with its own doc comment, or the item's.
fn parse_outputs(
    input: ParseStream,
    docs: &[String],
    diag: &mut Diagnostics,
) -> syn::Result<Vec<OutputDecl>> {
    input.parse::<kw::output>()?;
    let entries = input.parse_terminated_until_semi(
        |i| {
            let own = Attribute::parse_outer(i)?;
            let ident: Ident = i.parse()?;
            i.parse::<Token![=]>()?;
            Ok((own, ident, i.parse::<Expr>()?))
        },
        diag,
    )?;
    let outputs = entries.into_iter().map(|(own, ident, value)| {
        let own = self::docs(&own, diag);
        OutputDecl {
            docs: if own.is_empty() { docs.to_vec() } else { own },
            name: name(&ident),
            expr: expr(&value, diag),
        }
    });
    Ok(outputs.collect())
}

/// `sensor gnss = [gnss_pn, gnss_pe];`: outputs measured together, by name; options
/// after the name as a generator's are, `sensor gnss(gate = 13.82) = [..];`.
fn parse_sensor(
    input: ParseStream,
    docs: Vec<String>,
    diag: &mut Diagnostics,
) -> syn::Result<SensorDecl> {
    let start = input.cursor();
    input.parse::<kw::sensor>()?;
    let sensor = name(&input.parse::<Ident>()?);
    let options = parse_options(input)?;
    input.parse::<Token![=]>()?;
    let content;
    syn::bracketed!(content in input);
    let outputs = content.parse_terminated(Ident::parse, Token![,])?;
    end_with_semi(input, start, &ITEM, diag)?;
    Ok(SensorDecl {
        docs,
        name: sensor,
        options,
        outputs: outputs.iter().map(name).collect(),
    })
}

/// `dynamics discrete { .. }` or `dynamics continuous(..) { .. }`.
fn parse_dynamics(input: ParseStream, diag: &mut Diagnostics) -> syn::Result<DynamicsDecl> {
    let keyword = input.parse::<kw::dynamics>()?;
    let kind = parse_dynamics_kind(input, diag)?;
    let content;
    braced!(content in input);
    let mut statements = Vec::new();
    while !content.is_empty() {
        statements.push(parse_statement(&content, diag)?);
    }
    Ok(DynamicsDecl {
        span: keyword.span,
        kind,
        statements,
    })
}

/// `[x1, x2]` (names) or `[1e-6, 1e-4]` (numbers, which no option takes: the option's
/// reader says what it takes instead); a list that mixes them is an error here.
fn parse_list(content: ParseStream) -> syn::Result<ArgValue> {
    let list;
    let bracket = syn::bracketed!(list in content);
    let span = bracket.span.join();
    if list.peek(Ident) && list.peek2(Token![=]) {
        return parse_table(&list, span);
    }
    if list.peek(Ident) || list.is_empty() {
        let names = list.parse_terminated(Ident::parse, Token![,])?;
        return Ok(ArgValue::Names(names.iter().map(name).collect(), span));
    }
    let mut numbers = Vec::new();
    while !list.is_empty() {
        if list.peek(Ident) {
            return Err(list.error(
                "a list holds names or numbers, not both: write every entry as a name of a \
                 model constant (`const Q1 = 1e-6;`)",
            ));
        }
        numbers.push(parse_number(&list)?.0);
        if !list.is_empty() {
            list.parse::<Token![,]>()?;
        }
    }
    Ok(ArgValue::Numbers(numbers, span))
}

/// `[predict = 250, update_gnss = 5]`, the inside of a list whose first entry is
/// `name = number`: numbers by name (every entry so written).
fn parse_table(list: ParseStream, span: Span) -> syn::Result<ArgValue> {
    let mut entries = Vec::new();
    while !list.is_empty() {
        let key = name(&list.parse::<Ident>()?);
        if !list.peek(Token![=]) {
            return Err(list.error(
                "a list of `name = number` entries gives every entry so: `[predict = 250, \
                 update_gnss = 5]`",
            ));
        }
        list.parse::<Token![=]>()?;
        let (value, at) = parse_number(list)?;
        entries.push((key, value, at));
        if !list.is_empty() {
            list.parse::<Token![,]>()?;
        }
    }
    Ok(ArgValue::Table(entries, span))
}

/// A number, with an optional minus sign, and where its literal was written.
fn parse_number(input: ParseStream) -> syn::Result<(f64, proc_macro2::Span)> {
    let negative = input.parse::<Option<Token![-]>>()?.is_some();
    let lit: syn::Lit = input.parse()?;
    let value = match &lit {
        syn::Lit::Int(i) => i.base10_parse::<f64>()?,
        syn::Lit::Float(f) => f.base10_parse::<f64>()?,
        _ => return Err(syn::Error::new(lit.span(), "expected a number")),
    };
    Ok((if negative { -value } else { value }, lit.span()))
}

/// `ekf`, `dkf(eta = 0.5)`, `lqr(horizon = 50, states = [x1, x2], input = u)`
fn parse_generate_item(input: ParseStream) -> syn::Result<GenerateDecl> {
    let generator = name(&input.parse::<Ident>()?);
    Ok(GenerateDecl {
        name: generator,
        args: parse_options(input)?,
    })
}

/// `(name = value, ..)` after a generator's or a sensor's name, if it is there (no
/// options without it).
fn parse_options(input: ParseStream) -> syn::Result<Vec<GenerateArg>> {
    let mut args = Vec::new();
    if input.peek(syn::token::Paren) {
        let content;
        parenthesized!(content in input);
        while !content.is_empty() {
            let arg_name = name(&content.parse::<Ident>()?);
            content.parse::<Token![=]>()?;
            let value = if content.peek(syn::token::Bracket) {
                parse_list(&content)?
            } else if content.peek(Ident) {
                ArgValue::Name(name(&content.parse::<Ident>()?))
            } else {
                let (value, span) = parse_number(&content)?;
                ArgValue::Number(value, span)
            };
            args.push(GenerateArg {
                name: arg_name,
                value,
            });
            if !content.is_empty() {
                content.parse::<Token![,]>()?;
            }
        }
    }
    Ok(args)
}

fn parse_dynamics_kind(input: ParseStream, diag: &mut Diagnostics) -> syn::Result<DynamicsKind> {
    let look = input.lookahead1();
    if look.peek(kw::discrete) {
        input.parse::<kw::discrete>()?;
        return Ok(DynamicsKind::Discrete);
    }
    if !look.peek(kw::continuous) {
        return Err(look.error());
    }
    input.parse::<kw::continuous>()?;
    let (mut method, mut dt, mut substeps) = (None, None, None);
    if input.peek(syn::token::Paren) {
        let args;
        parenthesized!(args in input);
        if args.peek(Ident) && !args.peek(kw::dt) && !args.peek(kw::substeps) {
            method = Some(name(&args.parse::<Ident>()?));
            if !args.is_empty() {
                args.parse::<Token![,]>()?;
            }
        }
        while !args.is_empty() {
            let look = args.lookahead1();
            if look.peek(kw::dt) {
                args.parse::<kw::dt>()?;
                args.parse::<Token![=]>()?;
                dt = Some(expr(&args.parse()?, diag));
            } else if look.peek(kw::substeps) {
                args.parse::<kw::substeps>()?;
                args.parse::<Token![=]>()?;
                let n: syn::LitInt = args.parse()?;
                // Past u64 it is still "too many": the check says the limit.
                let count = n.base10_parse::<u64>().unwrap_or(u64::MAX);
                substeps = Some((count, n.span()));
            } else {
                return Err(look.error());
            }
            if !args.is_empty() {
                args.parse::<Token![,]>()?;
            }
        }
    }
    Ok(DynamicsKind::Continuous {
        method,
        dt,
        substeps,
    })
}

fn parse_statement(input: ParseStream, diag: &mut Diagnostics) -> syn::Result<Statement> {
    let start = input.cursor();
    for attr in Attribute::parse_outer(input)? {
        diag.error(
            attr.span(),
            "a doc comment inside `dynamics` documents nothing: write `//` for a comment, \
             or document the state where it is declared",
        );
    }
    let statement = if input.parse::<Option<Token![let]>>()?.is_some() {
        let ident: Ident = input.parse()?;
        input.parse::<Token![=]>()?;
        Statement::Let {
            name: name(&ident),
            value: expr(&input.parse()?, diag),
        }
    } else {
        let derivative = input.peek(kw::der) && input.peek2(syn::token::Paren);
        let target = if derivative {
            input.parse::<kw::der>()?;
            let inner;
            parenthesized!(inner in input);
            inner.parse::<Ident>()?
        } else {
            input.parse::<Ident>()?
        };
        input.parse::<Token![=]>()?;
        Statement::Equation {
            target: name(&target),
            derivative,
            value: expr(&input.parse()?, diag),
        }
    };
    end_with_semi(input, start, &STATEMENT, diag)?;
    Ok(statement)
}

/// Comma-separated entries up to and including a `;`.
trait UntilSemi {
    fn parse_terminated_until_semi<T>(
        &self,
        entry: impl FnMut(ParseStream) -> syn::Result<T>,
        diag: &mut Diagnostics,
    ) -> syn::Result<Vec<T>>;
}

impl UntilSemi for ParseStream<'_> {
    fn parse_terminated_until_semi<T>(
        &self,
        mut entry: impl FnMut(ParseStream) -> syn::Result<T>,
        diag: &mut Diagnostics,
    ) -> syn::Result<Vec<T>> {
        let start = self.cursor();
        let mut entries = vec![entry(self)?];
        while self.parse::<Option<Token![,]>>()?.is_some() {
            if self.peek(Token![;]) {
                break;
            }
            entries.push(entry(self)?);
        }
        end_with_semi(self, start, &LIST, diag)?;
        Ok(entries)
    }
}

/// What a `;` ends, for the messages when it is missing.
struct Ending {
    /// When only the `;` is missing: the message under the last token before it.
    missing: &'static str,
    /// When something else is wrong: the message under the unexpected token.
    unexpected: &'static str,
    /// Whether the tokens ahead begin the next one, so that only the `;` is missing.
    starts_next: fn(ParseStream) -> bool,
}

/// A declaration's tokens end here: the next is a declaration's keyword, a doc comment,
/// or the end of the model.
fn starts_item(input: ParseStream) -> bool {
    input.is_empty()
        || input.peek(Token![#])
        || input.peek(Token![const])
        || input.peek(kw::scalar)
        || input.peek(kw::state)
        || input.peek(kw::param)
        || input.peek(kw::input)
        || input.peek(kw::known)
        || input.peek(kw::output)
        || input.peek(kw::sensor)
        || input.peek(kw::dynamics)
        || input.peek(kw::generate)
}

const ITEM: Ending = Ending {
    missing: "expected `;` after this: each declaration in a model ends with `;`",
    unexpected: "expected `;` here, to end the declaration",
    starts_next: starts_item,
};

const LIST: Ending = Ending {
    missing: ITEM.missing,
    unexpected: "expected `,` between two entries, or `;` to end the declaration",
    starts_next: starts_item,
};

const STATEMENT: Ending = Ending {
    missing: "expected `;` after this: each equation in `dynamics` ends with `;`",
    unexpected: "expected an operator, or `;` to end the equation",
    starts_next: |input| {
        input.is_empty()
            || input.peek(Token![#])
            || input.peek(Token![let])
            || (input.peek(kw::der) && input.peek2(syn::token::Paren))
            || (input.peek(Ident) && input.peek2(Token![=]))
    },
};

/// The `;` that ends what was parsed from `start`. `syn` reports a missing one at the
/// token after it, which is the next declaration, a line below the mistake; this reports
/// it under the last token before it, as rustc does. When the next declaration follows, only
/// the `;` is missing: the error is recorded and the parse goes on, so the mistakes after
/// it are reported in the same compile. Anything else stays `syn`'s error where it is.
fn end_with_semi(
    input: ParseStream,
    start: Cursor,
    ending: &Ending,
    diag: &mut Diagnostics,
) -> syn::Result<()> {
    if input.parse::<Option<Token![;]>>()?.is_some() {
        return Ok(());
    }
    if !(ending.starts_next)(input) {
        return Err(input.error(ending.unexpected));
    }
    let last = last_span(start, input.cursor()).unwrap_or_else(|| input.span());
    diag.error(last, ending.missing);
    Ok(())
}

/// The span of the last token from `start` up to `end`, two cursors in one stream (a
/// group's closing delimiter for a group).
fn last_span(start: Cursor, end: Cursor) -> Option<Span> {
    let mut last = None;
    let mut at = start;
    while at != end {
        let (tree, next) = at.token_tree()?;
        last = Some(match tree {
            proc_macro2::TokenTree::Group(group) => group.span_close(),
            other => other.span(),
        });
        at = next;
    }
    last
}

fn name(ident: &Ident) -> Name {
    Name {
        text: ident.to_string(),
        span: ident.span(),
    }
}

/// Where `#[allow(unused)]` is written on anything else: a state is never warned about.
const ALLOW_UNUSED_APPLIES_TO: &str =
    "`#[allow(unused)]` applies to a `param`, `input` or `known` list, or one name in it";

/// Removes `#[allow(unused)]` from `attrs` (a symbol read by nothing on purpose), and says
/// where it was, if anywhere.
fn take_allow_unused(attrs: &mut Vec<Attribute>) -> Option<Span> {
    let mut at = None;
    attrs.retain(|attr| {
        let allows_unused = attr.path().is_ident("allow")
            && matches!(&attr.meta, syn::Meta::List(list) if list.tokens.to_string() == "unused");
        if allows_unused {
            at = Some(attr.path().span());
        }
        !allows_unused
    });
    at
}

/// Doc comment lines of `attrs`; any other attribute is an error.
fn docs(attrs: &[Attribute], diag: &mut Diagnostics) -> Vec<String> {
    let mut lines = Vec::new();
    for attr in attrs {
        let doc = match &attr.meta {
            syn::Meta::NameValue(nv) if nv.path.is_ident("doc") => match &nv.value {
                Expr::Lit(syn::ExprLit {
                    lit: syn::Lit::Str(s),
                    ..
                }) => Some(s.value()),
                _ => None,
            },
            _ => None,
        };
        match doc {
            Some(line) => lines.push(line),
            None => diag.error(
                attr.span(),
                "only doc comments (`///`) are allowed in a model",
            ),
        }
    }
    lines
}

/// Converts a Rust expression into a model expression, recording what the language lacks.
fn expr(e: &Expr, diag: &mut Diagnostics) -> SurfaceExpr {
    let span = e.span();
    let kind = match e {
        Expr::Lit(lit) => match &lit.lit {
            syn::Lit::Int(i) => number(i.base10_parse::<f64>(), span, diag),
            syn::Lit::Float(f) => number(f.base10_parse::<f64>(), span, diag),
            _ => unsupported(span, "only numeric literals are allowed", diag),
        },
        Expr::Path(p) => path(p, span, diag),
        Expr::Paren(p) => return expr(&p.expr, diag),
        Expr::Group(g) => return expr(&g.expr, diag),
        Expr::Unary(u) => match u.op {
            syn::UnOp::Neg(_) => SurfaceKind::Neg(Box::new(expr(&u.expr, diag))),
            _ => unsupported(span, "the only unary operator is `-`", diag),
        },
        Expr::Binary(b) => binary(b, diag),
        Expr::Call(c) => call(c, span, diag),
        Expr::MethodCall(m) => {
            let mut args = vec![expr(&m.receiver, diag)];
            args.extend(m.args.iter().map(|a| expr(a, diag)));
            SurfaceKind::Call(name(&m.method), args)
        }
        Expr::Field(f) => match &f.member {
            syn::Member::Named(component) => {
                SurfaceKind::Field(Box::new(expr(&f.base, diag)), name(component))
            }
            syn::Member::Unnamed(_) => unsupported(
                span,
                "a vector's components are `.x`, `.y` and `.z`: write `v.x`",
                diag,
            ),
        },
        Expr::Index(_) => unsupported(
            span,
            "a model has no indexing: a vector's components are `v.x`, `v.y` and `v.z`",
            diag,
        ),
        Expr::Array(array) => {
            diag.error(span, "a vector is written `vec3(a, b, c)`, not as an array");
            // Three entries are read on as the `vec3` meant, so that what uses it reports
            // nothing more.
            let elements: Vec<SurfaceExpr> = array.elems.iter().map(|e| expr(e, diag)).collect();
            if elements.len() == 3 {
                let vec3 = Name {
                    text: "vec3".to_owned(),
                    span,
                };
                SurfaceKind::Call(vec3, elements)
            } else {
                SurfaceKind::Number(0.0)
            }
        }
        Expr::If(i) => return piecewise(i, diag),
        Expr::Block(b) => return block_value(&b.block, span, diag),
        _ => unsupported(
            span,
            "unsupported expression: a model uses numbers, names, `+ - * /`, function calls \
             and `if a > b { .. } else { .. }`",
            diag,
        ),
    };
    SurfaceExpr { kind, span }
}

/// A name: a plain identifier; a path (`core::f64::consts::PI`) is refused.
fn path(p: &syn::ExprPath, span: Span, diag: &mut Diagnostics) -> SurfaceKind {
    match p.path.get_ident() {
        Some(ident) if p.qself.is_none() => SurfaceKind::Name(ident.to_string()),
        None if p.path.segments.len() > 1 => {
            let path = p.path.to_token_stream().to_string().replace(' ', "");
            let message = format!(
                "`{path}` is a path: a model sees only its own names; write the value \
                 here, or declare it in the model (`const NAME = ..;`)"
            );
            unsupported(span, &message, diag)
        }
        _ => unsupported(span, "write a plain name such as `x1`", diag),
    }
}

/// `a + b`, `a - b`, `a * b`, `a / b`; any other operator is an error (both operands are
/// still converted, to report their mistakes too).
fn binary(b: &syn::ExprBinary, diag: &mut Diagnostics) -> SurfaceKind {
    let op = match b.op {
        syn::BinOp::Add(_) => Some(BinaryOp::Add),
        syn::BinOp::Sub(_) => Some(BinaryOp::Sub),
        syn::BinOp::Mul(_) => Some(BinaryOp::Mul),
        syn::BinOp::Div(_) => Some(BinaryOp::Div),
        syn::BinOp::BitXor(_) => {
            diag.error(
                b.op.span(),
                "`^` is exclusive-or in Rust, not a power: write `powi(x, 2)`",
            );
            None
        }
        _ => {
            diag.error(
                b.op.span(),
                "unsupported operator: use `+ - * /`, and comparisons only in the \
                 condition of `if`",
            );
            None
        }
    };
    let (lhs, rhs) = (expr(&b.left, diag), expr(&b.right, diag));
    match op {
        Some(op) => SurfaceKind::Binary(op, Box::new(lhs), Box::new(rhs)),
        None => SurfaceKind::Number(0.0),
    }
}

/// `f(a, b)`, calling a function by its plain name.
fn call(call: &syn::ExprCall, span: Span, diag: &mut Diagnostics) -> SurfaceKind {
    match &*call.func {
        Expr::Path(p) if p.path.get_ident().is_some() => {
            let ident = p.path.get_ident().map(name);
            let args = call.args.iter().map(|a| expr(a, diag)).collect();
            match ident {
                Some(func) => SurfaceKind::Call(func, args),
                None => unsupported(span, "call a function by its plain name", diag),
            }
        }
        _ => unsupported(
            span,
            "call a function by its plain name, such as `sin(x)`",
            diag,
        ),
    }
}

fn number(value: syn::Result<f64>, span: Span, diag: &mut Diagnostics) -> SurfaceKind {
    match value {
        Ok(v) => SurfaceKind::Number(v),
        Err(e) => unsupported(span, e, diag),
    }
}

/// Records an error and stands in a zero so conversion can continue and find more.
fn unsupported(span: Span, message: impl std::fmt::Display, diag: &mut Diagnostics) -> SurfaceKind {
    diag.error(span, message);
    SurfaceKind::Number(0.0)
}

fn piecewise(i: &syn::ExprIf, diag: &mut Diagnostics) -> SurfaceExpr {
    let span = i.span();
    let then = block_value(&i.then_branch, span, diag);
    let otherwise = match &i.else_branch {
        Some((_, e)) => expr(e, diag),
        None => {
            diag.error(
                i.if_token.span,
                "a piecewise term needs an `else` branch: `if a > b { .. } else { .. }`",
            );
            SurfaceExpr {
                kind: SurfaceKind::Number(0.0),
                span,
            }
        }
    };
    let condition = match &*i.cond {
        Expr::Binary(b) => match b.op {
            syn::BinOp::Gt(_) => Some(Comparison::Gt),
            syn::BinOp::Ge(_) => Some(Comparison::Ge),
            syn::BinOp::Lt(_) => Some(Comparison::Lt),
            syn::BinOp::Le(_) => Some(Comparison::Le),
            _ => None,
        }
        .map(|cmp| (cmp, expr(&b.left, diag), expr(&b.right, diag))),
        _ => None,
    };
    let kind = match condition {
        Some((cmp, lhs, rhs)) => SurfaceKind::If {
            cmp,
            lhs: Box::new(lhs),
            rhs: Box::new(rhs),
            then: Box::new(then),
            otherwise: Box::new(otherwise),
        },
        None => unsupported(
            i.cond.span(),
            "the condition of a piecewise term is one comparison: `a > b`, `a >= b`, `a < b` \
             or `a <= b`",
            diag,
        ),
    };
    SurfaceExpr { kind, span }
}

/// The value of `{ expr }`: a block holding a single expression.
fn block_value(block: &syn::Block, span: Span, diag: &mut Diagnostics) -> SurfaceExpr {
    match block.stmts.as_slice() {
        [syn::Stmt::Expr(e, None)] => expr(e, diag),
        _ => SurfaceExpr {
            kind: unsupported(
                span,
                "each branch of a piecewise term holds one expression, without `;`",
                diag,
            ),
            span,
        },
    }
}
