//! The generated documentation speaks of the user's model: a filter or controller built
//! for a pendulum or a rover says nothing of the papers' cantilever, blade or helicopter
//! (it may cite a paper by its title, whatever that title names).

use quote::quote;
use syn::visit::Visit;

/// The documentation the generated module carries: every `#[doc = ".."]` string.
fn generated_docs(model: proc_macro2::TokenStream) -> Vec<String> {
    let expanded = stateforge_compiler::expand(model).expect("the model compiles");
    let file: syn::File = syn::parse2(expanded).expect("the generated code parses");
    let mut docs = Docs(Vec::new());
    docs.visit_file(&file);
    docs.0
}

/// Collects the doc attributes' strings.
struct Docs(Vec<String>);

impl Visit<'_> for Docs {
    fn visit_attribute(&mut self, attribute: &syn::Attribute) {
        if let syn::Meta::NameValue(meta) = &attribute.meta {
            if meta.path.is_ident("doc") {
                if let syn::Expr::Lit(syn::ExprLit {
                    lit: syn::Lit::Str(text),
                    ..
                }) = &meta.value
                {
                    self.0.push(text.value());
                }
            }
        }
    }
}

/// Words of the papers' and the demo's systems that a user's unrelated model's docs must
/// not contain except inside a cited title.
const PAPERS_SYSTEMS: [&str; 7] = [
    "cantilever",
    "vibrating",
    "blade",
    "helicopter",
    "stinger",
    "navigation",
    "gnss",
];

fn assert_about_the_model(what: &str, docs: &[String]) {
    assert!(!docs.is_empty(), "{what}: no generated docs found");
    // A title cited in quotes (which may run over several doc lines) is the paper's own
    // name, not a description of the model.
    let text = docs.join("\n");
    let unquoted: String = text.split('"').step_by(2).collect::<Vec<_>>().join(" ");
    let unquoted = unquoted.to_lowercase();
    for word in PAPERS_SYSTEMS {
        let line = unquoted.lines().find(|line| line.contains(word));
        assert!(
            line.is_none(),
            "{what}: the generated docs speak of `{word}`: {}",
            line.unwrap_or_default()
        );
    }
}

#[test]
fn a_pendulums_discrete_filters_and_controllers_are_documented_as_its_own() {
    let docs = generated_docs(quote! {
        /// A pendulum with an unknown damping.
        pub mod pendulum {
            scalar f64;
            const TS = 0.01;
            state theta, omega;
            param damping;
            input torque;
            output angle = theta;
            generate ekf(process_noise = diagonal), ekf(gate = 10.83, name = GatedEkf),
                dkf(eta = 0.5, process_noise = diagonal),
                lqr(horizon = 50, states = [theta, omega], input = torque),
                mpc(horizon = 6, states = [theta, omega], input = torque);
            dynamics discrete {
                theta = theta + TS * omega;
                omega = omega + TS * (-9.81 * sin(theta) + damping * omega + torque);
            }
        }
    });
    assert_about_the_model("pendulum", &docs);
}

#[test]
fn a_rovers_continuous_filters_are_documented_as_its_own() {
    let docs = generated_docs(quote! {
        /// A rover's heading and speed.
        pub mod rover {
            scalar f64;
            const TS = 0.01;
            state heading, speed;
            input turn_rate, thrust;
            output compass = heading;
            generate ekf, hybrid_ekf(process_noise = diagonal),
                continuous_ekf(alpha = 0.3, process_noise = diagonal);
            dynamics continuous(rk4, dt = TS, substeps = 2) {
                der(heading) = turn_rate;
                der(speed) = thrust - 0.1 * speed;
            }
        }
    });
    assert_about_the_model("rover", &docs);
}

#[test]
fn a_rovers_continuous_ekf_of_one_rk4_step_is_documented_as_its_own() {
    let docs = generated_docs(quote! {
        /// A rover's heading and speed, one RK4 step per sample.
        pub mod rover {
            scalar f32;
            const TS = 0.01;
            state heading, speed;
            input turn_rate, thrust;
            output compass = heading;
            generate continuous_ekf(alpha = 0.3, process_noise = diagonal, gate = off);
            dynamics continuous(rk4, dt = TS, substeps = 1) {
                der(heading) = turn_rate;
                der(speed) = thrust - 0.1 * speed;
            }
        }
    });
    assert_about_the_model("rover of one RK4 step", &docs);
}
