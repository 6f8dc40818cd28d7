//! `cargo xtask imports`: no file of the workspace imports a file that imports it back,
//! directly or through others (the team's rule: one direction of flow, no import circles).
//!
//! Each crate's module tree is read from its `src/` (from `lib.rs` and `main.rs`, following
//! `mod name;`), and each file's paths are resolved with `syn`: `use` trees and every path
//! that starts with `crate`, `super`, `self` or a child module's name. A path leads to the
//! file of the longest module prefix it names (a re-export counts as its re-exporting
//! file). Paths inside macro invocations are not read (a `quote!` body is generated code,
//! whose `super` is not the compiler's); a module declared by a macro is not followed.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};
use syn::visit::Visit;

/// The crates' source folders, relative to the workspace root.
const SOURCE_ROOTS: &[&str] = &[
    "model-dsl/src",
    "codegen-macros/src",
    "model-codegen/src",
    "generated-demo/src",
    "tests/src",
    "xtask/src",
    "targets/src",
    "examples/dc-motor/src",
    "examples/ahrs/src",
];

/// Checks every crate; `Ok` with a summary, or `Err` naming each circle.
pub fn check(root: &Path) -> Result<String, String> {
    let mut files = 0;
    let mut circles = Vec::new();
    for source in SOURCE_ROOTS {
        let dir = root.join(source);
        for entry in ["lib.rs", "main.rs"] {
            let path = dir.join(entry);
            if !path.exists() {
                continue;
            }
            let graph = Graph::read(&path)?;
            files += graph.files.len();
            for circle in graph.circles() {
                let names: Vec<String> = circle.iter().map(|f| relative(root, f)).collect();
                circles.push(names.join(" -> "));
            }
        }
    }
    if circles.is_empty() {
        Ok(format!(
            "no import circle among the {files} source files of {} crates",
            SOURCE_ROOTS.len()
        ))
    } else {
        Err(format!(
            "files that import each other (directly or through others):\n  {}",
            circles.join("\n  ")
        ))
    }
}

fn relative(root: &Path, file: &Path) -> String {
    file.strip_prefix(root)
        .unwrap_or(file)
        .display()
        .to_string()
}

/// One crate's modules and the files that import each other.
struct Graph {
    /// Module path (from the crate root) -> the file that holds it.
    modules: BTreeMap<Vec<String>, PathBuf>,
    /// The crate's files.
    files: BTreeSet<PathBuf>,
    /// File -> the files it imports.
    edges: BTreeMap<PathBuf, BTreeSet<PathBuf>>,
}

impl Graph {
    /// The module tree rooted at `root_file`, and each file's imports.
    fn read(root_file: &Path) -> Result<Graph, String> {
        let mut graph = Graph {
            modules: BTreeMap::new(),
            files: BTreeSet::new(),
            edges: BTreeMap::new(),
        };
        let mut parsed = Vec::new();
        let mut pending = vec![(Vec::new(), root_file.to_path_buf(), true)];
        while let Some((module, file, owns_dir)) = pending.pop() {
            let text = std::fs::read_to_string(&file)
                .map_err(|e| format!("cannot read {}: {e}", file.display()))?;
            let ast = syn::parse_file(&text)
                .map_err(|e| format!("cannot parse {}: {e}", file.display()))?;
            let dir = module_dir(&file, owns_dir);
            let mut children = Vec::new();
            declared_modules(&ast.items, &module, &mut children);
            for (child, inline, explicit) in children {
                if inline {
                    graph.modules.insert(child, file.clone());
                    continue;
                }
                // `#[path = ".."]`: relative to the declaring file's folder.
                if let Some(relative) = explicit {
                    let folder = file.parent().unwrap_or(Path::new(""));
                    pending.push((child, folder.join(relative), true));
                    continue;
                }
                let name = child.last().cloned().unwrap_or_default();
                // Inline modules between the file and the child nest its folder.
                let nested: PathBuf = child[module.len()..child.len() - 1].iter().collect();
                let flat = dir.join(&nested).join(format!("{name}.rs"));
                let folder = dir.join(&nested).join(&name).join("mod.rs");
                let (path, owns) = if flat.exists() {
                    (flat, false)
                } else {
                    (folder, true)
                };
                pending.push((child, path, owns));
            }
            graph.modules.insert(module.clone(), file.clone());
            graph.files.insert(file.clone());
            parsed.push((module, file, ast));
        }
        for (module, file, ast) in &parsed {
            let mut visitor = Paths {
                graph: &graph,
                module: module.clone(),
                found: BTreeSet::new(),
            };
            visitor.visit_file(ast);
            let mut targets = visitor.found;
            targets.remove(file);
            graph.edges.insert(file.clone(), targets);
        }
        Ok(graph)
    }

    /// The file holding the longest module prefix of `path`.
    fn file_of(&self, path: &[String]) -> Option<&PathBuf> {
        (0..=path.len())
            .rev()
            .find_map(|n| self.modules.get(&path[..n]))
    }

    /// Whether `module` declares a child module `name`.
    fn has_child(&self, module: &[String], name: &str) -> bool {
        let mut child = module.to_vec();
        child.push(name.to_owned());
        self.modules.contains_key(&child)
    }

    /// Strongly connected groups of more than one file: each is a circle of imports.
    fn circles(&self) -> Vec<Vec<PathBuf>> {
        let files: Vec<&PathBuf> = self.files.iter().collect();
        let index: BTreeMap<&PathBuf, usize> =
            files.iter().enumerate().map(|(i, f)| (*f, i)).collect();
        let reach = |from: usize| {
            let mut seen = vec![false; files.len()];
            let mut stack = vec![from];
            while let Some(i) = stack.pop() {
                for next in self.edges.get(files[i]).into_iter().flatten() {
                    let j = index[next];
                    if !std::mem::replace(&mut seen[j], true) {
                        stack.push(j);
                    }
                }
            }
            seen
        };
        let reaches: Vec<Vec<bool>> = (0..files.len()).map(reach).collect();
        let mut assigned = vec![false; files.len()];
        let mut circles = Vec::new();
        for i in 0..files.len() {
            if assigned[i] || !reaches[i][i] {
                continue;
            }
            let group: Vec<usize> = (0..files.len())
                .filter(|&j| reaches[i][j] && reaches[j][i])
                .collect();
            for &j in &group {
                assigned[j] = true;
            }
            if group.len() > 1 {
                circles.push(group.iter().map(|&j| files[j].clone()).collect());
            }
        }
        circles
    }
}

/// The folder a module's children live in: its own for `lib.rs`, `main.rs` and `mod.rs`,
/// else the folder named after the file.
fn module_dir(file: &Path, owns_dir: bool) -> PathBuf {
    let parent = file.parent().unwrap_or(Path::new("")).to_path_buf();
    if owns_dir {
        parent
    } else {
        parent.join(file.file_stem().unwrap_or_default())
    }
}

/// A module `items` declares: its path, whether it is inline, and its `#[path]` if any.
type Declared = (Vec<String>, bool, Option<String>);

/// The modules `items` declare under `module`, inline ones' own children included (their
/// files nest in the inline module's folder).
fn declared_modules(items: &[syn::Item], module: &[String], out: &mut Vec<Declared>) {
    for item in items {
        if let syn::Item::Mod(m) = item {
            let mut child = module.to_vec();
            child.push(m.ident.to_string());
            match &m.content {
                Some((_, inner)) => {
                    out.push((child.clone(), true, None));
                    declared_modules(inner, &child, out);
                }
                None => out.push((child, false, path_attribute(&m.attrs))),
            }
        }
    }
}

/// The file a `#[path = "file.rs"]` attribute names.
fn path_attribute(attrs: &[syn::Attribute]) -> Option<String> {
    attrs.iter().find_map(|attr| match &attr.meta {
        syn::Meta::NameValue(pair) if pair.path.is_ident("path") => match &pair.value {
            syn::Expr::Lit(syn::ExprLit {
                lit: syn::Lit::Str(file),
                ..
            }) => Some(file.value()),
            _ => None,
        },
        _ => None,
    })
}

/// Collects the files a file's paths lead to.
struct Paths<'g> {
    graph: &'g Graph,
    /// The module being read (inline modules push onto it).
    module: Vec<String>,
    found: BTreeSet<PathBuf>,
}

impl Paths<'_> {
    /// Resolves a path given by its segments, if it starts in this crate.
    fn resolve(&mut self, segments: &[String]) {
        let Some(first) = segments.first() else {
            return;
        };
        let mut base = match first.as_str() {
            "crate" => Vec::new(),
            "self" | "super" => self.module.clone(),
            name if self.graph.has_child(&self.module, name) => self.module.clone(),
            _ => return,
        };
        let mut rest = segments;
        while let Some(head) = rest.first() {
            match head.as_str() {
                "crate" | "self" => {}
                "super" => {
                    base.pop();
                }
                _ => break,
            }
            rest = &rest[1..];
        }
        base.extend(rest.iter().cloned());
        if let Some(file) = self.graph.file_of(&base) {
            self.found.insert(file.clone());
        }
    }

    /// Every full path a `use` tree names.
    fn use_paths(tree: &syn::UseTree, prefix: &mut Vec<String>, out: &mut Vec<Vec<String>>) {
        match tree {
            syn::UseTree::Path(p) => {
                prefix.push(p.ident.to_string());
                Self::use_paths(&p.tree, prefix, out);
                prefix.pop();
            }
            syn::UseTree::Name(n) if n.ident == "self" => out.push(prefix.clone()),
            syn::UseTree::Name(n) => out.push(extend(prefix, &n.ident)),
            syn::UseTree::Rename(r) => out.push(extend(prefix, &r.ident)),
            syn::UseTree::Glob(_) => out.push(prefix.clone()),
            syn::UseTree::Group(g) => {
                for item in &g.items {
                    Self::use_paths(item, prefix, out);
                }
            }
        }
    }
}

fn extend(prefix: &[String], ident: &syn::Ident) -> Vec<String> {
    let mut path = prefix.to_vec();
    path.push(ident.to_string());
    path
}

impl<'ast> Visit<'ast> for Paths<'_> {
    fn visit_item_use(&mut self, item: &'ast syn::ItemUse) {
        let mut paths = Vec::new();
        Self::use_paths(&item.tree, &mut Vec::new(), &mut paths);
        for path in paths {
            self.resolve(&path);
        }
    }

    fn visit_path(&mut self, path: &'ast syn::Path) {
        let segments: Vec<String> = path.segments.iter().map(|s| s.ident.to_string()).collect();
        if segments.len() > 1 {
            self.resolve(&segments);
        }
        syn::visit::visit_path(self, path);
    }

    fn visit_item_mod(&mut self, item: &'ast syn::ItemMod) {
        self.module.push(item.ident.to_string());
        syn::visit::visit_item_mod(self, item);
        self.module.pop();
    }

    fn visit_macro(&mut self, _mac: &'ast syn::Macro) {
        // Macro bodies are not read: see the module's docs.
    }
}

#[cfg(test)]
mod tests {
    use super::Graph;

    /// A crate of three files in a fresh folder; `b.rs` imports `a.rs` as given.
    fn crate_with(b_imports: &str) -> Graph {
        let dir = std::env::temp_dir().join(format!(
            "xtask-imports-{}-{}",
            std::process::id(),
            b_imports.len()
        ));
        std::fs::create_dir_all(dir.join("c")).unwrap();
        let files = [
            ("lib.rs", "mod a;\nmod c;\npub fn top() { a::f(); }\n"),
            ("a.rs", "mod b;\npub fn f() { b::g(); }\n"),
            ("c/mod.rs", "pub struct C;\n"),
        ];
        for (name, text) in files {
            std::fs::write(dir.join(name), text).unwrap();
        }
        std::fs::create_dir_all(dir.join("a")).unwrap();
        std::fs::write(
            dir.join("a/b.rs"),
            format!("{b_imports}\npub fn g() {{}}\n"),
        )
        .unwrap();
        Graph::read(&dir.join("lib.rs")).unwrap()
    }

    #[test]
    fn a_file_importing_its_importer_is_a_circle() {
        let graph = crate_with("use super::f;");
        let circles = graph.circles();
        assert_eq!(circles.len(), 1, "{circles:?}");
        assert_eq!(circles[0].len(), 2);
        let longer = crate_with("fn h() { crate::top(); }");
        assert_eq!(longer.circles()[0].len(), 3, "lib -> a -> b -> lib");
    }

    #[test]
    fn imports_in_one_direction_are_no_circle() {
        let graph = crate_with("use crate::c::C;");
        assert!(graph.circles().is_empty());
        assert_eq!(graph.files.len(), 4);
    }

    #[test]
    fn a_module_file_named_by_a_path_attribute_is_read_there() {
        let dir = std::env::temp_dir().join(format!("xtask-imports-path-{}", std::process::id()));
        std::fs::create_dir_all(dir.join("shared")).unwrap();
        std::fs::write(
            dir.join("lib.rs"),
            "#[path = \"shared/s.rs\"]\nmod s;\npub fn top() { s::h(); }\n",
        )
        .unwrap();
        std::fs::write(dir.join("shared/s.rs"), "pub fn h() { crate::top(); }\n").unwrap();
        let graph = Graph::read(&dir.join("lib.rs")).unwrap();
        assert!(
            graph.files.contains(&dir.join("shared/s.rs")),
            "{:?}",
            graph.files
        );
        assert_eq!(graph.circles().len(), 1, "lib -> s -> lib");
    }
}
