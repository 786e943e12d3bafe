//! No import circle between the files of a crate (issue 32): file A depends on file B when A
//! names an item defined in B (a `use`, or a path in the code starting with `crate::`,
//! `super::`, `self::` or a child module). Names are followed through re-exports to the file
//! that defines them, and a module re-exporting its own children's items (`pub use
//! child::Item` in a mod.rs or lib.rs) is forwarding, not a dependency. `#[cfg(test)]` code
//! is left out: a test module may use anything. A circle is a set of two or more files each
//! reaching the others (a strongly connected component of the dependency graph).
//!
//! The crates are every workspace member's library, binaries and the integration tests'
//! crate, read with `syn` from the roots (`src/lib.rs`, `src/main.rs`, `src/bin/*.rs`)
//! through their `mod` declarations (and `#[path]`).

use crate::root;
use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};
use syn::visit::Visit;

/// Circles tolerated while they are being removed (none: the last four went in issue 32); each
/// entry is the set of files (relative to the repository root) of one circle, and a circle
/// within one of these sets is tolerated. Remove an entry when its circle is gone (the test
/// prints which entries no longer match).
const KNOWN: &[&[&str]] = &[];

/// A module: its file, child modules, names it defines, `use` imports and the paths its code
/// names (each with the module path it is written in, for `self`/`super`).
#[derive(Default, Debug)]
struct Module {
    file: PathBuf,
    children: BTreeSet<String>,
    defines: BTreeSet<String>,
    /// Imported name (alias) -> (path, public).
    imports: BTreeMap<String, (Vec<String>, bool)>,
    /// Glob imports (`use a::b::*`): the module paths, public or not.
    globs: Vec<(Vec<String>, bool)>,
    /// Paths in the code (and glob or self imports) to resolve: segments.
    mentions: Vec<Vec<String>>,
}

type ModPath = Vec<String>;

/// One crate's modules by path (`[]` is the root).
struct Crate {
    modules: BTreeMap<ModPath, Module>,
}

fn is_cfg_test(attrs: &[syn::Attribute]) -> bool {
    attrs.iter().any(|a| {
        a.path().is_ident("cfg")
            && a.meta
                .require_list()
                .map(|l| {
                    l.tokens
                        .to_string()
                        .split(|c: char| !c.is_alphanumeric() && c != '_')
                        .any(|w| w == "test")
                })
                .unwrap_or(false)
    })
}

fn path_attr(attrs: &[syn::Attribute]) -> Option<String> {
    attrs.iter().find_map(|a| match &a.meta {
        syn::Meta::NameValue(nv) if nv.path.is_ident("path") => match &nv.value {
            syn::Expr::Lit(syn::ExprLit {
                lit: syn::Lit::Str(s),
                ..
            }) => Some(s.value()),
            _ => None,
        },
        _ => None,
    })
}

/// Expands a use tree into (alias or `*`, full path) pairs.
fn expand(tree: &syn::UseTree, prefix: &mut Vec<String>, out: &mut Vec<(String, Vec<String>)>) {
    match tree {
        syn::UseTree::Path(p) => {
            prefix.push(p.ident.to_string());
            expand(&p.tree, prefix, out);
            prefix.pop();
        }
        syn::UseTree::Name(n) => {
            let name = n.ident.to_string();
            if name == "self" {
                let alias = prefix.last().cloned().unwrap_or_default();
                out.push((alias, prefix.clone()));
            } else {
                let mut p = prefix.clone();
                p.push(name.clone());
                out.push((name, p));
            }
        }
        syn::UseTree::Rename(r) => {
            let mut p = prefix.clone();
            if r.ident != "self" {
                p.push(r.ident.to_string());
            }
            out.push((r.rename.to_string(), p));
        }
        syn::UseTree::Glob(_) => out.push(("*".into(), prefix.clone())),
        syn::UseTree::Group(g) => {
            for t in &g.items {
                expand(t, prefix, out);
            }
        }
    }
}

/// Collects the paths a module's code names (not inside nested modules or `use` items).
#[derive(Default)]
struct Paths(Vec<Vec<String>>);

impl<'ast> Visit<'ast> for Paths {
    fn visit_path(&mut self, p: &'ast syn::Path) {
        if p.segments.len() > 1 {
            self.0
                .push(p.segments.iter().map(|s| s.ident.to_string()).collect());
        }
        syn::visit::visit_path(self, p);
    }
    fn visit_item_mod(&mut self, _: &'ast syn::ItemMod) {}
    fn visit_item_use(&mut self, u: &'ast syn::ItemUse) {
        // a `use` inside a function body
        let mut pairs = Vec::new();
        expand(&u.tree, &mut Vec::new(), &mut pairs);
        self.0.extend(pairs.into_iter().map(|(_, p)| p));
    }
    fn visit_item_macro(&mut self, m: &'ast syn::ItemMacro) {
        // macro bodies are tokens: read the paths in `crate::a::b` form from them
        self.macro_tokens(&m.mac.tokens);
    }
    fn visit_macro(&mut self, m: &'ast syn::Macro) {
        self.macro_tokens(&m.tokens);
        syn::visit::visit_macro(self, m);
    }
    fn visit_attribute(&mut self, _: &'ast syn::Attribute) {}
}

impl Paths {
    fn macro_tokens(&mut self, tokens: &proc_macro2::TokenStream) {
        let text = tokens.to_string().replace(" :: ", "::");
        for word in text.split(|c: char| !(c.is_alphanumeric() || c == '_' || c == ':')) {
            let segs: Vec<String> = word.split("::").map(str::to_string).collect();
            if segs.len() > 1 && ["crate", "super", "self"].contains(&segs[0].as_str()) {
                self.0.push(segs);
            }
        }
    }
}

fn item_attrs(item: &syn::Item) -> &[syn::Attribute] {
    match item {
        syn::Item::Const(i) => &i.attrs,
        syn::Item::Enum(i) => &i.attrs,
        syn::Item::ExternCrate(i) => &i.attrs,
        syn::Item::Fn(i) => &i.attrs,
        syn::Item::ForeignMod(i) => &i.attrs,
        syn::Item::Impl(i) => &i.attrs,
        syn::Item::Macro(i) => &i.attrs,
        syn::Item::Mod(i) => &i.attrs,
        syn::Item::Static(i) => &i.attrs,
        syn::Item::Struct(i) => &i.attrs,
        syn::Item::Trait(i) => &i.attrs,
        syn::Item::TraitAlias(i) => &i.attrs,
        syn::Item::Type(i) => &i.attrs,
        syn::Item::Union(i) => &i.attrs,
        syn::Item::Use(i) => &i.attrs,
        _ => &[],
    }
}

impl Crate {
    /// Reads the crate whose root file is `root_file`.
    fn read(root_file: &Path) -> Crate {
        let mut c = Crate {
            modules: BTreeMap::new(),
        };
        let dir = root_file
            .parent()
            .map(Path::to_path_buf)
            .unwrap_or_default();
        c.read_file(root_file, Vec::new(), &dir);
        c
    }

    /// Reads `file` as module `path`, whose child modules' files are in `dir`.
    fn read_file(&mut self, file: &Path, path: ModPath, dir: &Path) {
        let text = std::fs::read_to_string(file)
            .unwrap_or_else(|e| panic!("cannot read {}: {e}", file.display()));
        let ast = syn::parse_file(&text)
            .unwrap_or_else(|e| panic!("cannot parse {}: {e}", file.display()));
        self.read_items(&ast.items, file, path, dir);
    }

    fn read_items(&mut self, items: &[syn::Item], file: &Path, path: ModPath, dir: &Path) {
        let mut m = Module {
            file: file.to_path_buf(),
            ..Module::default()
        };
        let mut nested = Vec::new();
        for item in items {
            if is_cfg_test(item_attrs(item)) {
                continue;
            }
            let public = |v: &syn::Visibility| !matches!(v, syn::Visibility::Inherited);
            match item {
                syn::Item::Mod(im) => {
                    let name = im.ident.to_string();
                    m.children.insert(name.clone());
                    nested.push(im);
                }
                syn::Item::Use(u) => {
                    let mut pairs = Vec::new();
                    expand(&u.tree, &mut Vec::new(), &mut pairs);
                    for (alias, p) in pairs {
                        if alias == "*" {
                            m.globs.push((p, public(&u.vis)));
                        } else if alias != "_" {
                            m.imports.insert(alias, (p, public(&u.vis)));
                        } else {
                            m.mentions.push(p);
                        }
                    }
                }
                other => {
                    let name = match other {
                        syn::Item::Const(i) => Some(&i.ident),
                        syn::Item::Enum(i) => Some(&i.ident),
                        syn::Item::Fn(i) => Some(&i.sig.ident),
                        syn::Item::Static(i) => Some(&i.ident),
                        syn::Item::Struct(i) => Some(&i.ident),
                        syn::Item::Trait(i) => Some(&i.ident),
                        syn::Item::Type(i) => Some(&i.ident),
                        syn::Item::Union(i) => Some(&i.ident),
                        syn::Item::Macro(i) => i.ident.as_ref(),
                        _ => None,
                    };
                    if let Some(n) = name {
                        m.defines.insert(n.to_string());
                    }
                    let mut v = Paths::default();
                    v.visit_item(other);
                    m.mentions.extend(v.0);
                }
            }
        }
        self.modules.insert(path.clone(), m);
        for im in nested {
            let name = im.ident.to_string();
            let mut child = path.clone();
            child.push(name.clone());
            match &im.content {
                Some((_, items)) => {
                    self.read_items(items, file, child, &dir.join(&name));
                }
                None => {
                    let f = match path_attr(&im.attrs) {
                        Some(p) => dir.join(p),
                        None if dir.join(format!("{name}.rs")).is_file() => {
                            dir.join(format!("{name}.rs"))
                        }
                        None => dir.join(&name).join("mod.rs"),
                    };
                    self.read_file(&f, child, &dir.join(&name));
                }
            }
        }
    }

    /// The module a path's leading `crate`/`super`/`self`/child/imported-module segments name,
    /// and the rest; `None` for another crate's path.
    fn start(&self, at: &ModPath, segs: &[String], depth: usize) -> Option<(ModPath, Vec<String>)> {
        let first = segs.first()?;
        let m = self.modules.get(at)?;
        match first.as_str() {
            "crate" => Some((Vec::new(), segs[1..].to_vec())),
            "self" => Some((at.clone(), segs[1..].to_vec())),
            "super" => {
                let mut base = at.clone();
                let mut rest = segs;
                while rest.first().map(String::as_str) == Some("super") {
                    base.pop();
                    rest = &rest[1..];
                }
                Some((base, rest.to_vec()))
            }
            name if m.children.contains(name) => Some((at.clone(), segs.to_vec())),
            name if depth < 8 => {
                let (target, _) = m.imports.get(name)?;
                let (base, mut rest) = self.start(at, target, depth + 1)?;
                rest.extend_from_slice(&segs[1..]);
                Some((base, rest))
            }
            _ => None,
        }
    }

    /// The module whose file defines what `segs`, written in module `at`, names.
    fn resolve(&self, at: &ModPath, segs: &[String], depth: usize) -> Option<ModPath> {
        let (mut m, rest) = self.start(at, segs, depth)?;
        for (i, seg) in rest.iter().enumerate() {
            let module = self.modules.get(&m)?;
            if module.children.contains(seg) {
                m.push(seg.clone());
                continue;
            }
            if depth > 8 || i + 1 < rest.len() && module.defines.contains(seg) {
                // an item's associated item (`Type::new`): the item's module
                return Some(m);
            }
            return Some(self.find(&m, seg, depth + 1).unwrap_or(m));
        }
        Some(m)
    }

    /// Where `name`, an item of module `m`, is defined: in `m`, or through its imports.
    fn find(&self, m: &ModPath, name: &str, depth: usize) -> Option<ModPath> {
        let module = self.modules.get(m)?;
        if module.defines.contains(name) {
            return Some(m.clone());
        }
        if let Some((target, _)) = module.imports.get(name) {
            return self.resolve(m, target, depth);
        }
        module.globs.iter().find_map(|(g, _)| {
            let gm = self.resolve(m, g, depth)?;
            self.find(&gm, name, depth + 1)
        })
    }

    /// Edges between files: (from, to) -> one path that makes it.
    fn edges(&self) -> BTreeMap<(PathBuf, PathBuf), String> {
        let mut edges = BTreeMap::new();
        for (at, m) in &self.modules {
            let mut paths: Vec<Vec<String>> = m.mentions.clone();
            for (p, public) in m.imports.values().chain(&m.globs) {
                // a module forwarding its own descendants' items is no dependency
                let forwards = *public
                    && self
                        .resolve(at, p, 0)
                        .is_some_and(|t| t.len() > at.len() && t.starts_with(at));
                if !forwards {
                    paths.push(p.clone());
                }
            }
            for p in paths {
                let Some(target) = self.resolve(at, &p, 0) else {
                    continue;
                };
                let Some(to) = self.modules.get(&target) else {
                    continue;
                };
                if to.file != m.file {
                    edges
                        .entry((m.file.clone(), to.file.clone()))
                        .or_insert_with(|| p.join("::"));
                }
            }
        }
        edges
    }
}

/// Strongly connected components of two or more files (Tarjan's algorithm).
fn circles(edges: &BTreeMap<(PathBuf, PathBuf), String>) -> Vec<BTreeSet<PathBuf>> {
    let mut next: BTreeMap<&PathBuf, Vec<&PathBuf>> = BTreeMap::new();
    for (a, b) in edges.keys() {
        next.entry(a).or_default().push(b);
        next.entry(b).or_default();
    }
    struct State<'a> {
        next: &'a BTreeMap<&'a PathBuf, Vec<&'a PathBuf>>,
        index: BTreeMap<&'a PathBuf, usize>,
        low: BTreeMap<&'a PathBuf, usize>,
        stack: Vec<&'a PathBuf>,
        on: BTreeSet<&'a PathBuf>,
        out: Vec<BTreeSet<PathBuf>>,
    }
    fn visit<'a>(s: &mut State<'a>, v: &'a PathBuf) {
        let i = s.index.len();
        s.index.insert(v, i);
        s.low.insert(v, i);
        s.stack.push(v);
        s.on.insert(v);
        for &w in &s.next[v] {
            if !s.index.contains_key(w) {
                visit(s, w);
                let lw = s.low[w];
                if let Some(l) = s.low.get_mut(v) {
                    *l = (*l).min(lw);
                }
            } else if s.on.contains(w) {
                let iw = s.index[w];
                if let Some(l) = s.low.get_mut(v) {
                    *l = (*l).min(iw);
                }
            }
        }
        if s.low[v] == s.index[v] {
            let mut c = BTreeSet::new();
            while let Some(w) = s.stack.pop() {
                s.on.remove(w);
                c.insert(w.clone());
                if w == v {
                    break;
                }
            }
            if c.len() > 1 {
                s.out.push(c);
            }
        }
    }
    let mut s = State {
        next: &next,
        index: BTreeMap::new(),
        low: BTreeMap::new(),
        stack: Vec::new(),
        on: BTreeSet::new(),
        out: Vec::new(),
    };
    for v in next.keys() {
        if !s.index.contains_key(v) {
            visit(&mut s, v);
        }
    }
    s.out
}

/// The workspace's members (folders), from the root Cargo.toml.
pub fn workspace_members(root: &Path) -> Vec<String> {
    let manifest = std::fs::read_to_string(root.join("Cargo.toml"))
        .unwrap_or_else(|e| panic!("cannot read Cargo.toml: {e}"));
    let members: Vec<String> = manifest
        .split("members = [")
        .nth(1)
        .and_then(|s| s.split(']').next())
        .unwrap_or_default()
        .split(',')
        .map(|m| m.trim().trim_matches('"').to_string())
        .filter(|m| !m.is_empty())
        .collect();
    assert!(
        members.len() > 5,
        "workspace members not found: {members:?}"
    );
    members
}

/// Every crate root of the workspace: libraries, binaries, the integration tests.
fn crate_roots(root: &Path) -> Vec<PathBuf> {
    let mut roots = vec![root.join("tests/integration/main.rs")];
    for member in workspace_members(root) {
        let src = root.join(&member).join("src");
        for f in ["lib.rs", "main.rs"] {
            if src.join(f).is_file() {
                roots.push(src.join(f));
            }
        }
        if let Ok(dir) = std::fs::read_dir(src.join("bin")) {
            for e in dir.flatten() {
                let p = e.path();
                if p.extension().is_some_and(|x| x == "rs") {
                    roots.push(p);
                } else if p.join("main.rs").is_file() {
                    roots.push(p.join("main.rs"));
                }
            }
        }
    }
    roots.sort();
    roots
}

/// The circles of every crate, as sorted file lists relative to `root`, each with the edges
/// that make it.
fn all_circles(root: &Path) -> Vec<(Vec<String>, Vec<String>)> {
    let root = root.canonicalize().unwrap_or_else(|_| root.to_path_buf());
    let rel = |p: &Path| {
        p.strip_prefix(&root)
            .unwrap_or(p)
            .to_string_lossy()
            .into_owned()
    };
    let mut found = Vec::new();
    for r in crate_roots(&root) {
        let c = Crate::read(&r);
        let edges = c.edges();
        for circle in circles(&edges) {
            let files: Vec<String> = circle.iter().map(|p| rel(p)).collect();
            let why: Vec<String> = edges
                .iter()
                .filter(|((a, b), _)| circle.contains(a) && circle.contains(b))
                .map(|((a, b), p)| format!("{} -> {} ({p})", rel(a), rel(b)))
                .collect();
            found.push((files, why));
        }
    }
    found.sort();
    found.dedup();
    found
}

#[test]
fn no_import_circle_inside_a_crate() {
    let found = all_circles(&root());
    let known = |files: &[String]| {
        KNOWN
            .iter()
            .any(|k| files.iter().all(|f| k.contains(&f.as_str())))
    };
    for k in KNOWN {
        if !found
            .iter()
            .any(|(f, _)| f.iter().all(|f| k.contains(&f.as_str())))
        {
            eprintln!("known circle gone, remove it from KNOWN: {k:?}");
        }
    }
    let report = |(files, why): &(Vec<String>, Vec<String>)| {
        format!("  {}\n    {}", files.join(" <-> "), why.join("\n    "))
    };
    for c in found.iter().filter(|(f, _)| known(f)) {
        eprintln!("known circle (being removed):\n{}", report(c));
    }
    let new: Vec<String> = found
        .iter()
        .filter(|(f, _)| !known(f))
        .map(report)
        .collect();
    assert!(
        new.is_empty(),
        "import circles between files (move the shared item to a file of its own):\n{}",
        new.join("\n")
    );
}

#[test]
fn the_circle_finder_finds_a_circle_and_follows_re_exports() {
    let dir = std::env::temp_dir().join(format!("import_circles_{}", std::process::id()));
    let src = dir.join("src");
    let write = |p: &str, text: &str| {
        let f = src.join(p);
        std::fs::create_dir_all(f.parent().unwrap_or(&src)).unwrap_or_else(|e| panic!("{e}"));
        std::fs::write(&f, text).unwrap_or_else(|e| panic!("{e}"));
    };
    // a <-> b through a re-export in mod.rs; c only forwards its children's items
    write(
        "lib.rs",
        "mod a;\nmod c;\npub use c::Thing;\n#[cfg(test)]\nmod tests { use crate::a::A; }\n",
    );
    write("a.rs", "use crate::c::Thing;\npub struct A(Thing);\n");
    write(
        "c/mod.rs",
        "mod b;\nmod d;\npub use b::Thing;\npub use d::D;\n",
    );
    write(
        "c/b.rs",
        "pub struct Thing;\nfn f() -> usize { std::mem::size_of::<crate::a::A>() }\n",
    );
    write("c/d.rs", "pub struct D(pub super::Thing);\n");
    let c = Crate::read(&src.join("lib.rs"));
    let edges = c.edges();
    let found = circles(&edges);
    let _ = std::fs::remove_dir_all(&dir);
    let names: Vec<Vec<String>> = found
        .iter()
        .map(|c| {
            c.iter()
                .map(|p| p.strip_prefix(&src).unwrap_or(p).display().to_string())
                .collect()
        })
        .collect();
    assert_eq!(names, vec![vec!["a.rs".to_string(), "c/b.rs".to_string()]]);
    // d.rs's `super::Thing` is b.rs's, through mod.rs: an edge d -> b, none to mod.rs
    let d_edges: Vec<_> = edges
        .keys()
        .filter(|(a, _)| a.ends_with("c/d.rs"))
        .map(|(_, b)| b.strip_prefix(&src).unwrap_or(b).display().to_string())
        .collect();
    assert_eq!(d_edges, ["c/b.rs"]);
}
