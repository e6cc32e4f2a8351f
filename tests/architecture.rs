//! The shape of `src/`'s dependencies, read from the source with `syn`.
//!
//! An edge A → B means file A names an item defined in file B: through a `use` (a `pub use` of a
//! module's own descendant is a facade and does not count; other re-exports are followed to the
//! file that defines the item) or through a qualified path in the code (`crate::…`, `super::…`,
//! `self::…`, or a child module's name). `#[cfg(test)]` items are not read: tests may reach anywhere.
//! The checks: within every folder, no circle between its sub-modules taken whole (a folder's
//! `mod.rs` holds what its files share and may call them: a parent and its children are one unit);
//! and the top-level modules form the layers of [`LAYERS`], each using only those before it.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

use syn::visit::Visit;

/// The top-level modules from the bottom up: each may use only the ones before it.
const LAYERS: &[&str] = &[
    "atomic",
    "memory",
    "threads",
    "linalg",
    "mesh",
    "collision",
    "scene",
    "energy",
    "solver",
    "render",
    "app",
    "eval",
];

type ModPath = Vec<String>;

/// File → (file it uses → a path that shows it).
type Edges = BTreeMap<String, BTreeMap<String, String>>;

/// One module: where it lives and the names it re-exports.
#[derive(Default)]
struct Module {
    file: PathBuf,
    /// `pub use` names: the alias and the absolute path it stands for.
    reexports: BTreeMap<String, ModPath>,
    /// Absolute or module-relative paths this module names, resolved later.
    uses: Vec<ModPath>,
}

fn is_test(attrs: &[syn::Attribute]) -> bool {
    attrs
        .iter()
        .any(|a| a.path().is_ident("cfg") && a.parse_args::<syn::Meta>().is_ok_and(|m| m.path().is_ident("test")))
}

/// Flatten a use tree into its paths (`a::{b, c::d as e}` → `a::b`, `a::c::d`), each with its alias.
fn flatten(tree: &syn::UseTree, prefix: &mut ModPath, out: &mut Vec<(ModPath, Option<String>)>) {
    match tree {
        syn::UseTree::Path(p) => {
            prefix.push(p.ident.to_string());
            flatten(&p.tree, prefix, out);
            prefix.pop();
        }
        syn::UseTree::Name(n) if n.ident == "self" => out.push((prefix.clone(), prefix.last().cloned())),
        syn::UseTree::Name(n) => {
            let mut p = prefix.clone();
            p.push(n.ident.to_string());
            out.push((p, Some(n.ident.to_string())));
        }
        syn::UseTree::Rename(r) => {
            let mut p = prefix.clone();
            if r.ident != "self" {
                p.push(r.ident.to_string());
            }
            out.push((p, Some(r.rename.to_string())));
        }
        syn::UseTree::Glob(_) => out.push((prefix.clone(), None)),
        syn::UseTree::Group(g) => g.items.iter().for_each(|t| flatten(t, prefix, out)),
    }
}

/// Collects the qualified paths of a module's code.
struct Paths<'a> {
    module: &'a ModPath,
    children: &'a BTreeSet<String>,
    out: Vec<ModPath>,
}

impl<'ast> Visit<'ast> for Paths<'_> {
    fn visit_path(&mut self, path: &'ast syn::Path) {
        let segs: ModPath = path.segments.iter().map(|s| s.ident.to_string()).collect();
        if segs.len() > 1 {
            let first = segs[0].as_str();
            if matches!(first, "crate" | "super" | "self") || self.children.contains(first) {
                self.out.push(absolute(self.module, &segs));
            }
        }
        syn::visit::visit_path(self, path);
    }
    fn visit_item_mod(&mut self, _: &'ast syn::ItemMod) {} // read as modules of their own
    fn visit_item_use(&mut self, _: &'ast syn::ItemUse) {} // read by `read_items`
    fn visit_attribute(&mut self, _: &'ast syn::Attribute) {}
}

/// `segs` as seen from `module`, made absolute (without the leading `crate`).
fn absolute(module: &ModPath, segs: &[String]) -> ModPath {
    let mut base = module.clone();
    let mut rest = segs;
    match segs.first().map(String::as_str) {
        Some("crate") => {
            base.clear();
            rest = &segs[1..];
        }
        Some("self") => rest = &segs[1..],
        Some("super") => {
            while rest.first().map(String::as_str) == Some("super") {
                base.pop();
                rest = &rest[1..];
            }
        }
        _ => {}
    }
    base.extend(rest.iter().cloned());
    base
}

struct Crate {
    root: PathBuf,
    modules: BTreeMap<ModPath, Module>,
}

impl Crate {
    fn read(root: &Path) -> Self {
        let mut c = Crate { root: root.to_path_buf(), modules: BTreeMap::new() };
        c.read_file(Vec::new(), root.join("lib.rs"), root.to_path_buf());
        c
    }

    fn read_file(&mut self, path: ModPath, file: PathBuf, dir: PathBuf) {
        let text = std::fs::read_to_string(&file).unwrap_or_else(|e| panic!("{}: {e}", file.display()));
        let ast = syn::parse_file(&text).unwrap_or_else(|e| panic!("{}: {e}", file.display()));
        self.read_items(path, &ast.items, file, dir);
    }

    fn read_items(&mut self, path: ModPath, items: &[syn::Item], file: PathBuf, dir: PathBuf) {
        let children: BTreeSet<String> = items
            .iter()
            .filter_map(|i| match i {
                syn::Item::Mod(m) if !is_test(&m.attrs) => Some(m.ident.to_string()),
                _ => None,
            })
            .collect();
        let mut module = Module { file: file.clone(), ..Default::default() };
        for item in items {
            match item {
                syn::Item::Mod(m) if is_test(&m.attrs) => {}
                syn::Item::Mod(m) => {
                    let mut child = path.clone();
                    child.push(m.ident.to_string());
                    let sub = dir.join(m.ident.to_string());
                    match &m.content {
                        Some((_, inner)) => self.read_items(child, inner, file.clone(), sub),
                        None => {
                            let flat = dir.join(format!("{}.rs", m.ident));
                            let nested = sub.join("mod.rs");
                            let child_file = if flat.exists() { flat } else { nested };
                            self.read_file(child, child_file, sub);
                        }
                    }
                }
                syn::Item::Use(u) if is_test(&u.attrs) => {}
                syn::Item::Use(u) => {
                    let mut flat = Vec::new();
                    let mut prefix = Vec::new();
                    if u.leading_colon.is_none() {
                        flatten(&u.tree, &mut prefix, &mut flat);
                    }
                    let public = !matches!(u.vis, syn::Visibility::Inherited);
                    for (segs, alias) in flat {
                        let first = segs.first().map(String::as_str).unwrap_or("");
                        let local = matches!(first, "crate" | "super" | "self") || children.contains(first);
                        if !local {
                            continue; // another crate
                        }
                        let target = absolute(&path, &segs);
                        let facade = public && target.starts_with(&path) && target.len() > path.len();
                        if let Some(alias) = alias.filter(|_| public) {
                            module.reexports.insert(alias, target.clone());
                        }
                        if !facade {
                            module.uses.push(target);
                        }
                    }
                }
                other if has_test_attr(other) => {}
                other => {
                    let mut v = Paths { module: &path, children: &children, out: Vec::new() };
                    v.visit_item(other);
                    module.uses.extend(v.out);
                }
            }
        }
        self.modules.insert(path, module);
    }

    /// The file that defines the item `segs` names, following re-exports.
    fn resolve(&self, segs: &[String], depth: usize) -> Option<&Path> {
        let mut at: ModPath = Vec::new();
        let mut i = 0;
        while i < segs.len() {
            let mut next = at.clone();
            next.push(segs[i].clone());
            if !self.modules.contains_key(&next) {
                break;
            }
            at = next;
            i += 1;
        }
        let module = self.modules.get(&at)?;
        if let Some(target) = segs.get(i).and_then(|s| module.reexports.get(s)).filter(|_| depth < 16) {
            let mut full = target.clone();
            full.extend(segs[i + 1..].iter().cloned());
            return self.resolve(&full, depth + 1);
        }
        Some(&module.file)
    }

    /// File → the files it depends on, each with the first path that names it (`a::b::C`).
    fn edges(&self) -> Edges {
        let name = |p: &Path| p.strip_prefix(&self.root).unwrap_or(p).to_string_lossy().into_owned();
        let mut edges = Edges::new();
        for m in self.modules.values() {
            let from = name(&m.file);
            let entry = edges.entry(from.clone()).or_default();
            for u in &m.uses {
                if let Some(to) = self.resolve(u, 0).map(name).filter(|to| *to != from) {
                    entry.entry(to).or_insert_with(|| u.join("::"));
                }
            }
        }
        edges
    }
}

fn has_test_attr(item: &syn::Item) -> bool {
    match item {
        syn::Item::Fn(i) => is_test(&i.attrs),
        syn::Item::Impl(i) => is_test(&i.attrs),
        syn::Item::Const(i) => is_test(&i.attrs),
        syn::Item::Static(i) => is_test(&i.attrs),
        syn::Item::Struct(i) => is_test(&i.attrs),
        syn::Item::Enum(i) => is_test(&i.attrs),
        syn::Item::Trait(i) => is_test(&i.attrs),
        syn::Item::Type(i) => is_test(&i.attrs),
        _ => false,
    }
}

/// The strongly connected components of more than one node (Tarjan).
fn circles(edges: &Edges) -> Vec<Vec<String>> {
    struct State<'a> {
        edges: &'a Edges,
        index: BTreeMap<&'a str, usize>,
        low: BTreeMap<&'a str, usize>,
        stack: Vec<&'a str>,
        on_stack: BTreeSet<&'a str>,
        out: Vec<Vec<String>>,
    }
    fn visit<'a>(s: &mut State<'a>, v: &'a str) {
        let i = s.index.len();
        s.index.insert(v, i);
        s.low.insert(v, i);
        s.stack.push(v);
        s.on_stack.insert(v);
        for w in s.edges.get(v).into_iter().flat_map(|t| t.keys()) {
            let w = w.as_str();
            if !s.index.contains_key(w) {
                visit(s, w);
                let lw = s.low[w];
                let lv = s.low.get_mut(v).expect("visited");
                *lv = (*lv).min(lw);
            } else if s.on_stack.contains(w) {
                let iw = s.index[w];
                let lv = s.low.get_mut(v).expect("visited");
                *lv = (*lv).min(iw);
            }
        }
        if s.low[v] == s.index[v] {
            let mut component = Vec::new();
            while let Some(w) = s.stack.pop() {
                s.on_stack.remove(w);
                component.push(w.to_string());
                if w == v {
                    break;
                }
            }
            if component.len() > 1 {
                component.sort();
                s.out.push(component);
            }
        }
    }
    let mut s = State {
        edges,
        index: BTreeMap::new(),
        low: BTreeMap::new(),
        stack: Vec::new(),
        on_stack: BTreeSet::new(),
        out: Vec::new(),
    };
    for v in edges.keys() {
        if !s.index.contains_key(v.as_str()) {
            visit(&mut s, v);
        }
    }
    s.out
}

/// The folder-level graph: for each file, the sub-module of `folder` it lies in (`None` outside).
fn within(folder: &str, file: &str) -> Option<String> {
    let rest = if folder.is_empty() { file } else { file.strip_prefix(folder)?.strip_prefix('/')? };
    let head = rest.split('/').next()?;
    (head != "mod.rs" && head != "lib.rs").then(|| head.trim_end_matches(".rs").to_string())
}

fn src() -> Crate {
    Crate::read(&Path::new(env!("CARGO_MANIFEST_DIR")).join("src"))
}

/// The edges inside one circle, each with the path that makes it.
fn explain(edges: &Edges, circle: &[String]) -> Vec<String> {
    let mut out = Vec::new();
    for a in circle {
        for (b, why) in edges.get(a).into_iter().flatten() {
            if circle.contains(b) {
                out.push(format!("{a} → {b} ({why})"));
            }
        }
    }
    out
}

#[test]
fn no_folder_has_a_circle_between_its_sub_modules() {
    let edges = src().edges();
    let folders: BTreeSet<String> =
        edges.keys().filter_map(|f| f.rsplit_once('/').map(|(d, _)| d.to_string())).chain([String::new()]).collect();
    let mut found = Vec::new();
    for folder in &folders {
        let mut graph = Edges::new();
        for (from, tos) in &edges {
            let Some(a) = within(folder, from) else { continue };
            for (to, why) in tos {
                if let Some(b) = within(folder, to).filter(|b| *b != a) {
                    graph.entry(a.clone()).or_default().entry(b).or_insert_with(|| format!("{from} → {to}: {why}"));
                }
            }
        }
        found.extend(circles(&graph).iter().map(|c| format!("{folder}/: {:#?}", explain(&graph, c))));
    }
    assert!(found.is_empty(), "circles between sub-modules: {found:#?}");
}

#[test]
fn the_top_level_modules_are_layers() {
    let edges = src().edges();
    let layer = |file: &str| {
        let top = within("", file)?;
        LAYERS.iter().position(|l| *l == top).or_else(|| panic!("{top} is in no layer"))
    };
    let mut upward = Vec::new();
    for (from, tos) in &edges {
        let Some(a) = layer(from) else { continue };
        for (to, why) in tos {
            if layer(to).is_some_and(|b| b > a) {
                upward.push(format!("{from} → {to} ({why})"));
            }
        }
    }
    assert!(upward.is_empty(), "arrows from a lower layer to a higher one: {upward:#?}");
}

#[test]
fn the_reader_sees_the_edges_it_must() {
    let edges = src().edges();
    let has = |a: &str, b: &str| edges.get(a).is_some_and(|t| t.contains_key(b));
    // A `use super::…` group, a `crate::` path in code, and a name re-exported by a parent.
    assert!(has("solver/pbd/project.rs", "solver/pbd/model.rs"), "{:?}", edges.get("solver/pbd/project.rs"));
    assert!(has("app/viewer.rs", "render/frame.rs"), "{:?}", edges.get("app/viewer.rs"));
    // Every file of the library is read: all but the binary's and the test-only ones.
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut unread: Vec<String> = Vec::new();
    walk(&root, &mut |p| {
        let name = p.strip_prefix(&root).expect("below src").to_string_lossy().into_owned();
        if !edges.contains_key(&name) {
            unread.push(name);
        }
    });
    unread.sort();
    assert_eq!(
        unread,
        [
            "cli/eval.rs",
            "cli/mod.rs",
            "cli/modes.rs",
            "cli/render.rs",
            "cli/scenes.rs",
            "cli/sim.rs",
            "cli/view.rs",
            "energy/fd.rs",
            "energy/tests.rs",
            "main.rs"
        ]
    );
}

/// Call `f` on every `.rs` file below `dir`.
fn walk(dir: &Path, f: &mut dyn FnMut(&Path)) {
    for entry in std::fs::read_dir(dir).expect("src is readable") {
        let p = entry.expect("a folder entry").path();
        if p.is_dir() {
            walk(&p, f);
        } else if p.extension().is_some_and(|e| e == "rs") {
            f(&p);
        }
    }
}
