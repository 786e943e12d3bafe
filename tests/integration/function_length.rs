//! No function over 100 lines (issue 32). Counted with `syn` over every `.rs` file under each
//! workspace member's `src/` (tests modules included) and under `tests/integration/` (issue 39): a
//! function is a free `fn`, a method in an `impl` or a trait's default method (a nested `fn` counts
//! in its parent too, and on its own); its length is the lines of its body from the line of its `{`
//! to the line of its `}`, both counted, blank lines and comments included. A table of cases is
//! data, not a function: an array literal of four or more elements, or a `vec![...]`, counts as one
//! line however many lines it spans.

use crate::import_circles::workspace_members;
use crate::root;
use std::path::{Path, PathBuf};
use syn::visit::Visit;

/// Longest body allowed, in lines.
const LIMIT: usize = 100;

/// Functions still over the limit, each with why; a function named here may keep its length
/// (the test prints the entries that are no longer needed: remove them).
const KNOWN: &[(&str, &str, &str)] = &[];

/// A function's length: its file (relative to the root), name, first line and body lines.
#[derive(Debug, PartialEq)]
struct Length {
    file: String,
    name: String,
    line: usize,
    lines: usize,
}

/// Lines of a table's brackets beyond its first: what a table of cases takes off a body.
#[derive(Default)]
struct DataLines(usize);

/// The lines from `open` to `close`, both counted.
fn span_lines(open: proc_macro2::Span, close: proc_macro2::Span) -> usize {
    close.end().line + 1 - open.start().line
}

impl<'ast> Visit<'ast> for DataLines {
    fn visit_expr_array(&mut self, a: &'ast syn::ExprArray) {
        if a.elems.len() >= 4 {
            let s = a.bracket_token.span;
            self.0 += span_lines(s.open(), s.close()) - 1;
        } else {
            syn::visit::visit_expr_array(self, a);
        }
    }

    fn visit_macro(&mut self, m: &'ast syn::Macro) {
        if let (true, syn::MacroDelimiter::Bracket(b)) = (m.path.is_ident("vec"), &m.delimiter) {
            self.0 += span_lines(b.span.open(), b.span.close()) - 1;
        }
    }
}

/// Every function of one file.
struct Functions<'a> {
    file: &'a str,
    found: Vec<Length>,
}

impl Functions<'_> {
    fn measure(&mut self, name: &syn::Ident, body: &syn::Block) {
        let s = body.brace_token.span;
        let mut data = DataLines::default();
        data.visit_block(body);
        self.found.push(Length {
            file: self.file.to_string(),
            name: name.to_string(),
            line: name.span().start().line,
            lines: span_lines(s.open(), s.close()) - data.0,
        });
    }
}

impl<'ast> Visit<'ast> for Functions<'_> {
    fn visit_item_fn(&mut self, f: &'ast syn::ItemFn) {
        self.measure(&f.sig.ident, &f.block);
        syn::visit::visit_item_fn(self, f);
    }

    fn visit_impl_item_fn(&mut self, f: &'ast syn::ImplItemFn) {
        self.measure(&f.sig.ident, &f.block);
        syn::visit::visit_impl_item_fn(self, f);
    }

    fn visit_trait_item_fn(&mut self, f: &'ast syn::TraitItemFn) {
        if let Some(body) = &f.default {
            self.measure(&f.sig.ident, body);
        }
        syn::visit::visit_trait_item_fn(self, f);
    }
}

/// The functions of the source `text` of `file`.
fn functions(file: &str, text: &str) -> Vec<Length> {
    let ast = syn::parse_file(text).unwrap_or_else(|e| panic!("cannot parse {file}: {e}"));
    let mut v = Functions {
        file,
        found: Vec::new(),
    };
    v.visit_file(&ast);
    v.found
}

/// The `.rs` files below `dir`, in name order.
fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    let mut paths: Vec<PathBuf> = entries.flatten().map(|e| e.path()).collect();
    paths.sort();
    for p in paths {
        if p.is_dir() {
            rust_files(&p, out);
        } else if p.extension().is_some_and(|x| x == "rs") {
            out.push(p);
        }
    }
}

/// Every function of the workspace's `src/` folders and of the integration tests.
fn all_functions(root: &Path) -> Vec<Length> {
    let mut files = Vec::new();
    for member in workspace_members(root) {
        rust_files(&root.join(member).join("src"), &mut files);
    }
    rust_files(&root.join("tests/integration"), &mut files);
    assert!(files.len() > 50, "too few source files: {}", files.len());
    files
        .iter()
        .flat_map(|f| {
            let text = std::fs::read_to_string(f)
                .unwrap_or_else(|e| panic!("cannot read {}: {e}", f.display()));
            let rel = f.strip_prefix(root).unwrap_or(f).display().to_string();
            functions(&rel, &text)
        })
        .collect()
}

#[test]
fn no_function_over_100_lines() {
    let root = root().canonicalize().unwrap_or_else(|_| root());
    let all = all_functions(&root);
    assert!(all.len() > 500, "too few functions: {}", all.len());
    let mut longest: Vec<&Length> = all.iter().collect();
    longest.sort_by_key(|l| std::cmp::Reverse(l.lines));
    for l in longest.iter().take(5) {
        eprintln!("long: {}:{} {}, {} lines", l.file, l.line, l.name, l.lines);
    }
    let known = |l: &Length| KNOWN.iter().any(|(f, n, _)| l.file == *f && l.name == *n);
    for (f, n, why) in KNOWN {
        match all.iter().find(|l| l.file == *f && l.name == *n) {
            Some(l) if l.lines > LIMIT => {
                eprintln!(
                    "known long function ({why}): {f}:{} {n}, {} lines",
                    l.line, l.lines
                )
            }
            _ => eprintln!("known long function gone, remove it from KNOWN: {f} {n}"),
        }
    }
    let long: Vec<String> = all
        .iter()
        .filter(|l| l.lines > LIMIT && !known(l))
        .map(|l| format!("  {}:{} {}: {} lines", l.file, l.line, l.name, l.lines))
        .collect();
    assert!(
        long.is_empty(),
        "functions over {LIMIT} lines (split them into steps named for what they do):\n{}",
        long.join("\n")
    );
}

#[test]
fn the_counter_counts_bodies_and_takes_tables_as_one_line() {
    let body = |n: usize| "    let x = 1;\n".repeat(n);
    let table = format!("    let t = [\n{}    ];\n", "        1,\n".repeat(200));
    let text = format!(
        "fn long() {{\n{}}}\nimpl A {{\n    fn short(&self) {{\n{}    }}\n}}\nfn data() {{\n{table}}}\n\
         trait T {{\n    fn default_body() {{\n        let v = vec![\n{}        ];\n    }}\n}}\n",
        body(99),
        body(98),
        "            0,\n".repeat(300)
    );
    let got: Vec<(String, usize)> = functions("x.rs", &text)
        .into_iter()
        .map(|l| (l.name, l.lines))
        .collect();
    let want: Vec<(String, usize)> = [
        ("long", 101),
        ("short", 100),
        ("data", 3),
        ("default_body", 3),
    ]
    .iter()
    .map(|(n, l)| (n.to_string(), *l))
    .collect();
    assert_eq!(got, want);
}
