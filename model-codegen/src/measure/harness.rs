//! The measuring firmware's `main.rs` for one model: it builds each generated type with
//! deterministic tuning, feeds its calls a simulated run of the model itself, and reads
//! every call through the shared harness (`firmware/measure.rs`).
//!
//! The data: the true state starts at 0.5 in every entry (a unit quaternion for a
//! rotation) and follows the model's own `f`, driven by inputs uniform in +-0.1; the
//! measurements are its `h` plus noise uniform in +-0.01; times advance 0.01 s per sample.
//! A filter starts at the true state with variances 0.1 (`p0`), process noise 1e-3 and
//! measurement noise 1e-2 per entry; a controller weighs states and inputs by 1, its
//! inputs bounded to +-1. Each type's calls but `step` run on one object, in the order the
//! code declares them (`predict`, then each update), and `step` on another.

use super::api::{Api, Arg, Function, Outcome, Shape, Type};
use stateforge_compiler::model::Model;
use std::fmt::Write as _;

/// Seconds between samples, for the calls that take times.
const SAMPLE_TIME: &str = "0.01";

/// A measured call, as the firmware reports it (`call <index> ..`).
#[derive(Clone, Debug)]
pub struct Call {
    /// `Ekf::predict`.
    pub label: String,
    /// The never-inlined function around it, which the trace follows.
    pub wrapper: String,
    /// The type's name (`Ekf`).
    pub type_name: String,
    /// The method's name (`predict`).
    pub method: String,
}

/// The firmware's source and the calls it reports, in the order of their index.
pub struct Harness {
    /// `src/main.rs`.
    pub main: String,
    /// The calls, by index.
    pub calls: Vec<Call>,
}

/// The sizes of the model's vectors, read from the signatures.
#[derive(Clone, Copy)]
struct Sizes {
    x: usize,
    u: usize,
    y: usize,
    known: usize,
}

/// The firmware for `api`, the model `model`'s generated `f32` code, running `samples`
/// samples.
pub fn write(api: &Api, model: &Model, samples: usize) -> Result<Harness, String> {
    let sizes = sizes(api);
    let mut main = header(api, samples, sizes);
    main.push_str(&truth(api, sizes)?);
    let (mut calls, mut runs) = (Vec::new(), Vec::new());
    for ty in &api.types {
        main.push_str(&constructor(ty, sizes)?);
        let (step, others): (Vec<&Function>, Vec<&Function>) =
            ty.calls.iter().partition(|c| c.name == "step");
        for (group, suffix) in [(others, "calls"), (step, "step")] {
            if group.is_empty() {
                continue;
            }
            let run = format!("run_{}_{suffix}", snake(&ty.name));
            let first = calls.len();
            for call in &group {
                let wrapper = format!("measured_{}_{}", snake(&ty.name), call.name);
                main.push_str(&wrapper_fn(&wrapper, &ty.name, call));
                calls.push(Call {
                    label: format!("{}::{}", ty.name, call.name),
                    wrapper,
                    type_name: ty.name.clone(),
                    method: call.name.clone(),
                });
            }
            let scenario = Scenario {
                run: &run,
                type_name: &ty.name,
                group: &group,
                first,
                model,
                sizes,
            };
            main.push_str(&scenario.write()?);
            runs.push(run);
        }
    }
    main.push_str(&entry(&runs));
    let file = syn::parse_file(&main)
        .map_err(|e| format!("the measuring firmware does not parse ({e}):\n{main}"))?;
    Ok(Harness {
        main: prettyplease::unparse(&file),
        calls,
    })
}

/// `GatedEkf` -> `gated_ekf`.
fn snake(name: &str) -> String {
    crate::generated_api::snake(name)
}

/// The sizes of `x`, `u`, `y` and `known`, from `f`, `h` and the constructors.
fn sizes(api: &Api) -> Sizes {
    let functions = api.f.iter().chain(&api.h).chain(
        api.types
            .iter()
            .flat_map(|t| t.calls.iter().chain([&t.new])),
    );
    let args: Vec<&Arg> = functions.flat_map(|f| &f.args).collect();
    let length = |names: &[&str]| {
        args.iter()
            .find_map(|a| match a.shape {
                Shape::Vector(n) if names.contains(&a.name.as_str()) => Some(n),
                _ => None,
            })
            .unwrap_or(0)
    };
    let y = match api.h.as_ref().and_then(|h| h.output_shape.clone()) {
        Some(Shape::Vector(n)) => n,
        _ => 0,
    };
    Sizes {
        x: length(&["x", "x0"]),
        u: length(&["u", "u_prev"]),
        y,
        known: length(&["known"]),
    }
}

/// The crate's attributes, imports and the data's constants.
fn header(api: &Api, samples: usize, sizes: Sizes) -> String {
    let Sizes { x, known, .. } = sizes;
    format!(
        "//! Measures the generated calls of `{module}` on the emulated Cortex-M4F: written by \
         `stateforge-codegen measure`, rewritten at each run.\n\
         #![no_std]\n#![no_main]\n#![allow(unused, unexpected_cfgs, clippy::all)]\n\
         mod generated;\nmod measure;\nmod support;\n\
         use core::hint::black_box;\nuse cortex_m_rt::entry;\n\
         use cortex_m_semihosting::{{debug, hprintln}};\nuse generated::{module} as model;\n\
         use measure::{{stack_depth, traced, Calls, Clock}};\nuse panic_semihosting as _;\n\
         use support::{{diag, report, uniform, Refused}};\n\
         /// Samples of the run: each measured call is called once per sample.\n\
         const SAMPLES: usize = {samples};\n\
         /// Seconds between samples.\nconst SAMPLE_TIME: f32 = {SAMPLE_TIME};\n\
         /// The true initial state, and the filters' initial estimate.\n\
         const X0: [f32; {x}] = [0.5; {x}];\n\
         /// The run-time constants (`known`).\nconst KNOWN: [f32; {known}] = [0.5; {known}];\n",
        module = api.module,
    )
}

/// The simulated truth: `f` from `X0` under uniform inputs, `h` plus uniform noise.
fn truth(api: &Api, sizes: Sizes) -> Result<String, String> {
    let Sizes { x, u, y, .. } = sizes;
    let model_args = |f: &Function, at: &str| -> Result<String, String> {
        let args: Result<Vec<String>, String> = f
            .args
            .iter()
            .map(|a| match (a.name.as_str(), &a.shape) {
                ("t", Shape::Scalar) => Ok(if at == "prev" { "t_prev" } else { "t" }.to_owned()),
                ("x", _) => Ok("&x".to_owned()),
                ("u", _) => Ok(if at == "prev" { "&u_prev" } else { "&u" }.to_owned()),
                ("known", _) => Ok("&KNOWN".to_owned()),
                _ => Err(format!("cannot give `{}`'s argument `{}`", f.name, a.name)),
            })
            .collect();
        Ok(args?.join(", "))
    };
    let advance = match &api.f {
        Some(f) => format!("let x = model::f({});", model_args(f, "prev")?),
        None => "let x = self.x;".to_owned(),
    };
    let measure = match &api.h {
        Some(h) => format!("let mut y = model::h({});", model_args(h, "now")?),
        None => "let mut y = [0.0_f32; 0];".to_owned(),
    };
    Ok(format!(
        "/// One sample of the run: the true state after it, the inputs, the measurement.\n\
         #[derive(Clone, Copy)]\nstruct Sample {{ t: f32, t_prev: f32, x: [f32; {x}], \
         u: [f32; {u}], u_prev: [f32; {u}], y: [f32; {y}] }}\n\
         /// The model's own run, from `X0`.\n\
         struct Truth {{ k: usize, x: [f32; {x}], u_prev: [f32; {u}] }}\n\
         impl Truth {{\n\
         fn new() -> Truth {{ Truth {{ k: 0, x: X0, u_prev: input(0) }} }}\n\
         fn next(&mut self) -> Sample {{\n\
         let t_prev = self.k as f32 * SAMPLE_TIME;\nself.k += 1;\n\
         let t = self.k as f32 * SAMPLE_TIME;\n\
         let (x, u_prev) = (self.x, self.u_prev);\n{advance}\nlet u = input(self.k);\n\
         {measure}\n\
         for (i, entry) in y.iter_mut().enumerate() {{ *entry += 0.01 * uniform(self.k, 1000 + i); }}\n\
         self.x = x;\nself.u_prev = u;\n\
         Sample {{ t, t_prev, x, u, u_prev, y }}\n}}\n}}\n\
         /// The inputs at sample `k`, uniform in +-0.1.\n\
         fn input(k: usize) -> [f32; {u}] {{ core::array::from_fn(|i| 0.1 * uniform(k, i)) }}\n"
    ))
}

/// `new_<type>()`: the type built with the run's tuning.
fn constructor(ty: &Type, sizes: Sizes) -> Result<String, String> {
    let is_filter = ty.new.args.iter().any(|a| a.name == "x0");
    let args = ty
        .new
        .args
        .iter()
        .map(|a| tuning(&ty.name, a, is_filter, sizes).map(|v| v.argument()))
        .collect::<Result<Vec<_>, _>>()?
        .join(", ");
    let name = &ty.name;
    let built = if ty.new_is_fallible {
        format!(
            "match model::{name}::new({args}) {{ Ok(object) => object, Err(status) => \
             panic!(\"{name}::new refused the measuring data: {{:?}}\", status) }}"
        )
    } else {
        format!("model::{name}::new({args})")
    };
    Ok(format!(
        "fn new_{}() -> model::{name} {{ {built} }}\n",
        snake(name)
    ))
}

/// A value the firmware passes: an expression, and whether it is passed by reference.
struct Value {
    expr: String,
    by_ref: bool,
}

impl Value {
    /// A value passed by reference (`&expr`).
    fn referenced(expr: impl Into<String>) -> Value {
        Value {
            expr: expr.into(),
            by_ref: true,
        }
    }

    /// A value passed as it is (a scalar, an `Option`).
    fn direct(expr: impl Into<String>) -> Value {
        Value {
            expr: expr.into(),
            by_ref: false,
        }
    }

    /// The value as an argument written in place.
    fn argument(&self) -> String {
        match self.by_ref {
            true => format!("&{}", self.expr),
            false => self.expr.clone(),
        }
    }
}

/// A constructor's argument: the initial estimate, covariances and weights given by their
/// variances, input bounds, run-time constants.
fn tuning(type_name: &str, arg: &Arg, is_filter: bool, sizes: Sizes) -> Result<Value, String> {
    let name = arg.name.as_str();
    let variance = match (is_filter, name.chars().next()) {
        (true, Some('p')) => "0.1",
        (true, Some('q')) => "1e-3",
        (true, Some('r')) => "1e-2",
        _ => "1.0",
    };
    Ok(match &arg.shape {
        Shape::Vector(n) if name == "x0" && *n == sizes.x => Value::referenced("X0"),
        Shape::Vector(n) if name == "known" && *n == sizes.known => Value::referenced("KNOWN"),
        Shape::Vector(n) if name == "u_min" => Value::referenced(format!("[-1.0; {n}]")),
        Shape::Vector(n) if name == "u_max" => Value::referenced(format!("[1.0; {n}]")),
        Shape::Vector(n) => Value::referenced(format!("[{variance}_f32; {n}]")),
        Shape::OptionalVector(n) if name == "u_max" => Value::direct(format!("Some(&[1.0; {n}])")),
        Shape::OptionalVector(n) if name == "u_min" => Value::direct(format!("Some(&[-1.0; {n}])")),
        Shape::OptionalVector(_) => Value::direct("None"),
        Shape::Matrix(rows, cols) if rows == cols => {
            Value::referenced(format!("diag::<{rows}>({variance})"))
        }
        Shape::Matrix(rows, cols) => Value::referenced(format!("[[0.0_f32; {cols}]; {rows}]")),
        // A gate given at construction: a chi-square quantile no measurement of the run
        // reaches.
        Shape::Scalar if name.contains("gate") => Value::direct("1e6"),
        Shape::Scalar => Value::direct("0.5"),
        Shape::Other(ty) => {
            return Err(format!(
                "cannot make a `{ty}` for `{type_name}::new`'s argument `{name}`"
            ))
        }
    })
}

/// The never-inlined function around one call: the trace follows it, and its code size
/// and stack are the call's.
fn wrapper_fn(wrapper: &str, type_name: &str, call: &Function) -> String {
    let params: Vec<String> = call
        .args
        .iter()
        .enumerate()
        .map(|(i, a)| format!("a{i}: {}", a.ty))
        .collect();
    let args: Vec<String> = (0..call.args.len()).map(|i| format!("a{i}")).collect();
    let output = call
        .output
        .as_ref()
        .map_or(String::new(), |o| format!(" -> {o}"));
    format!(
        "#[inline(never)]\nfn {wrapper}(object: &mut model::{type_name}{}{}){output} {{ \
         object.{}({}) }}\n",
        if params.is_empty() { "" } else { ", " },
        params.join(", "),
        call.name,
        args.join(", ")
    )
}

/// One object of a type and the calls it runs each sample.
struct Scenario<'a> {
    run: &'a str,
    type_name: &'a str,
    group: &'a [&'a Function],
    /// The index of the group's first call.
    first: usize,
    model: &'a Model,
    sizes: Sizes,
}

impl Scenario<'_> {
    /// `run_<type>_<group>(clock)`: the calls over the run, read one by one between the
    /// trace markers; then each call's stack on the object at the run's end, and its report.
    fn write(&self) -> Result<String, String> {
        let mut declared = String::new();
        let mut each_sample = String::new();
        let mut after = String::new();
        for (k, call) in self.group.iter().enumerate() {
            let i = self.first + k;
            let _ = write!(
                declared,
                "let mut calls_{i} = Calls::<SAMPLES>::new();\nlet mut refused_{i} = Refused::new();\n"
            );
            let (lets, args) = self.arguments(call)?;
            let wrapper = format!("measured_{}_{}", snake(self.type_name), call.name);
            let accepted = match call.outcome {
                Outcome::Status => "result == model::Status::Ok",
                Outcome::IsOk => "result.is_ok()",
                Outcome::StatusField => "result.status == model::Status::Ok",
                Outcome::Always => "true",
            };
            let _ = writeln!(
                each_sample,
                "{{ {lets} let result = calls_{i}.measure(clock, || {wrapper}(&mut object{args})); \
                 refused_{i}.add({accepted}, result); }}"
            );
            let _ = writeln!(
                after,
                "{{ {lets} let stack = stack_depth(|| {{ let _ = black_box({wrapper}(black_box(&mut \
                 object){args})); }}); report({i}, &calls_{i}, stack, &refused_{i}); }}"
            );
        }
        Ok(format!(
            "fn {run}(clock: &Clock) {{\nlet mut object = new_{snake}();\n{declared}\
             let mut truth = Truth::new();\n\
             traced(|| {{ for _ in 0..SAMPLES {{ let s = truth.next();\n{each_sample}}} }});\n\
             let s = truth.next();\n{after}}}\n",
            run = self.run,
            snake = snake(self.type_name),
        ))
    }

    /// The `let`s that compute a call's arguments from the sample `s` before it is read,
    /// and the arguments as passed (each after a comma).
    fn arguments(&self, call: &Function) -> Result<(String, String), String> {
        let (mut lets, mut args) = (String::new(), String::new());
        for (j, arg) in call.args.iter().enumerate() {
            let value = self.argument(call, arg)?;
            let _ = write!(lets, "let a{j}: {} = {};", pointee(&arg.ty), value.expr);
            let _ = write!(args, ", {}a{j}", if value.by_ref { "&" } else { "" });
        }
        Ok((lets, args))
    }

    /// A call's argument at sample `s`.
    fn argument(&self, call: &Function, arg: &Arg) -> Result<Value, String> {
        let sizes = self.sizes;
        Ok(match (arg.name.as_str(), &arg.shape) {
            ("t", Shape::Scalar) => Value::direct("s.t"),
            ("t_prev", Shape::Scalar) => Value::direct("s.t_prev"),
            ("dt", Shape::Scalar) => Value::direct("SAMPLE_TIME"),
            ("u_prev", Shape::Vector(n)) if *n == sizes.u => Value::referenced("s.u_prev"),
            ("u", Shape::Vector(n)) if *n == sizes.u => Value::referenced("s.u"),
            ("x", Shape::Vector(n)) if *n == sizes.x => Value::referenced("s.x"),
            ("known", Shape::Vector(n)) if *n == sizes.known => Value::referenced("KNOWN"),
            ("y", Shape::Scalar) => Value::direct(format!("s.y[{}]", self.measured(call, 1)[0])),
            ("y", Shape::Vector(n)) => {
                let entries = self.measured(call, *n);
                let all: Vec<usize> = (0..sizes.y).collect();
                match entries == all {
                    true => Value::referenced("s.y"),
                    false => Value::referenced(format!(
                        "[{}]",
                        entries
                            .iter()
                            .map(|i| format!("s.y[{i}]"))
                            .collect::<Vec<_>>()
                            .join(", ")
                    )),
                }
            }
            (name, Shape::Other(ty)) if ty == "usize" => match self.max_delay(call, name) {
                Some(delay) => Value::direct(delay.to_string()),
                None => {
                    return Err(format!(
                        "cannot give `{}::{}` its argument `{name}` (`usize`)",
                        self.type_name, call.name
                    ))
                }
            },
            (_, Shape::Scalar) => Value::direct("0.5"),
            (_, Shape::Vector(n)) => Value::referenced(format!("[0.5_f32; {n}]")),
            (_, Shape::OptionalVector(_)) => Value::direct("None"),
            (_, Shape::Matrix(rows, cols)) if rows == cols => {
                Value::referenced(format!("diag::<{rows}>(1e-2)"))
            }
            (name, shape) => {
                return Err(format!(
                    "cannot give `{}::{}` its argument `{name}` ({shape:?})",
                    self.type_name, call.name
                ))
            }
        })
    }

    /// The delay a call's argument `name` gives a sensor whose delay is given at run time
    /// (`update_flow`'s `delay`, the joint calls' `flow_delay`): the sensor's maximum, at
    /// which a sensor whose maximum is the horizon's fuses its measurement at once, the
    /// dearer of its update's two paths (the measurement of one of a shorter maximum is
    /// stored, one a sample, and the prediction that reaches it fuses it).
    fn max_delay(&self, call: &Function, name: &str) -> Option<usize> {
        let sensor = match name.strip_suffix("_delay") {
            Some(sensor) => sensor,
            None if name == "delay" => call.name.strip_prefix("update_")?,
            None => return None,
        };
        let sensor = self.model.sensors.iter().find(|s| s.name == sensor)?;
        sensor.delay_at_run_time.then_some(sensor.delay)
    }

    /// The entries of `h` that `call` measures, `n` of them: those of the sensor or output
    /// its name ends with (`update_gnss`, `update_y_act`), else the first `n`.
    fn measured(&self, call: &Function, n: usize) -> Vec<usize> {
        let model = self.model;
        let named = call.name.strip_prefix("update_").and_then(|name| {
            let sensor = model.sensors.iter().find(|s| s.name == name);
            let output = model.outputs.iter().position(|o| o.name == name);
            sensor
                .map(|s| s.outputs.clone())
                .or(output.map(|i| vec![i]))
        });
        match named {
            Some(entries) if entries.len() == n && entries.iter().all(|&i| i < self.sizes.y) => {
                entries
            }
            _ => (0..n.min(self.sizes.y))
                .chain(std::iter::repeat(0))
                .take(n)
                .collect(),
        }
    }
}

/// The type a reference argument points to (`&[f32; 5]` -> `[f32; 5]`); other types as
/// they are.
fn pointee(ty: &str) -> &str {
    ty.strip_prefix('&').unwrap_or(ty)
}

/// The entry point: the runs in order, then `done`.
fn entry(runs: &[String]) -> String {
    let calls: String = runs.iter().map(|r| format!("{r}(&clock);\n")).collect();
    format!(
        "#[entry]\nfn main() -> ! {{\n\
         let Some(peripherals) = cortex_m::Peripherals::take() else {{ panic!(\"peripherals taken twice\") }};\n\
         let clock = Clock::start(peripherals.SYST);\n{calls}\
         hprintln!(\"done\");\ndebug::exit(debug::EXIT_SUCCESS);\n\
         loop {{ cortex_m::asm::wfi(); }}\n}}\n"
    )
}
