//! The Markdown link check (issue 32): in every Markdown file of the repository, a relative link
//! names a file or folder that exists, its `#anchor` names a heading of the Markdown file it
//! points to (GitHub's anchor rules) or a line of any other file (`#L12`, `#L12-L20`), and an
//! external link is well-formed. External links are not fetched: CI has no network.
//!
//! Markdown is parsed with pulldown-cmark (a CommonMark parser), so links in code blocks and
//! code spans are not links, and reference-style links are resolved as GitHub resolves them.
//!
//! A file path written in a code span (`capsule_plant/src/scene.rs`, `docs/ros.md:12`) is
//! checked too (issue 39): when its first component is a top-level file or folder of the
//! repository, the path must exist. Spans with spaces or patterns (`*`, `{a,b}`, `<N>`) are not
//! paths; paths under build output (`target/`, `install/`) are not the repository's.

use crate::common::TempDir;
use crate::root;
use pulldown_cmark::{Event, Options, Parser, Tag, TagEnd};
use std::collections::{BTreeMap, HashMap, HashSet};
use std::path::{Component, Path, PathBuf};

/// Folders never walked: build output, installed packages, recordings, hidden folders.
const SKIPPED_DIRS: &[&str] = &["target", "node_modules", "build", "install", "log", "runs"];

/// A link found in a Markdown file: where, and the destination as written.
struct Link {
    line: usize,
    dest: String,
}

/// What one Markdown file holds for the check: its anchors, its links and its code spans.
struct Page {
    anchors: HashSet<String>,
    links: Vec<Link>,
    code_spans: Vec<Link>,
}

/// What the check found: how many files, links and code-span paths, and each problem.
struct Report {
    files: usize,
    links: usize,
    paths: usize,
    problems: Vec<String>,
}

/// The repository path a code span names, if it names one: no spaces or pattern characters,
/// a `/` in it, not a ROS 2 type name, and a first component among `top` (the repository's
/// top-level entries). A `:line` or `#L12` suffix is dropped.
fn code_span_path<'a>(span: &'a str, top: &HashSet<String>) -> Option<&'a str> {
    let path = span.split([':', '#']).next()?.trim_end_matches('/');
    let pattern = |c: char| c.is_whitespace() || "*?{}<>[]$~`'\"|,;=()".contains(c);
    if path.contains(pattern) || !path.contains('/') || path.contains("//") || path.contains("..") {
        return None;
    }
    // a ROS 2 type name (`capsule_msgs/msg/CapsuleState`), not a file
    let last = path.rsplit('/').next()?;
    if last.starts_with(|c: char| c.is_ascii_uppercase()) && !last.contains('.') {
        return None;
    }
    let first = path.split('/').next()?;
    top.contains(first).then_some(path)
}

/// Every Markdown file under `dir`, sorted, skipping build output and hidden folders.
fn markdown_files(dir: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    let mut todo = vec![dir.to_path_buf()];
    while let Some(d) = todo.pop() {
        let entries = std::fs::read_dir(&d).unwrap_or_else(|e| panic!("{}: {e}", d.display()));
        for entry in entries {
            let path = entry
                .unwrap_or_else(|e| panic!("{}: {e}", d.display()))
                .path();
            let name = path.file_name().map(|n| n.to_string_lossy().into_owned());
            let name = name.unwrap_or_default();
            if path.is_dir() {
                if !name.starts_with('.') && !SKIPPED_DIRS.contains(&name.as_str()) {
                    todo.push(path);
                }
            } else if name.ends_with(".md") {
                out.push(path);
            }
        }
    }
    out.sort();
    out
}

/// GitHub's anchor for a heading's text: lower case, punctuation removed except `-` and `_`,
/// each space a hyphen (github-slugger, which github.com follows).
fn slug(text: &str) -> String {
    text.to_lowercase()
        .chars()
        .filter(|c| c.is_alphanumeric() || matches!(c, '-' | '_' | ' '))
        .map(|c| if c == ' ' { '-' } else { c })
        .collect()
}

/// The values of `name="..."` attributes in a piece of HTML (`id`, `name`, `href`, `src`).
fn html_attributes(html: &str, name: &str) -> Vec<String> {
    let needle = format!("{name}=\"");
    let mut out = Vec::new();
    let mut rest = html;
    while let Some(i) = rest.find(&needle) {
        let preceded_by_space = i == 0 || rest[..i].ends_with(char::is_whitespace);
        rest = &rest[i + needle.len()..];
        if let Some(end) = rest.find('"') {
            if preceded_by_space {
                out.push(rest[..end].to_string());
            }
            rest = &rest[end..];
        }
    }
    out
}

/// Parses one Markdown text: its headings' anchors (with GitHub's `-1`, `-2` for repeats, and
/// HTML `id` / `name` anchors) and its links and images.
fn parse(text: &str) -> Page {
    let line_of = |offset: usize| text[..offset].matches('\n').count() + 1;
    let mut anchors = HashSet::new();
    let mut seen: HashMap<String, usize> = HashMap::new();
    let mut links = Vec::new();
    let mut code_spans = Vec::new();
    let mut heading: Option<String> = None;
    let options = Options::ENABLE_TABLES
        | Options::ENABLE_FOOTNOTES
        | Options::ENABLE_STRIKETHROUGH
        | Options::ENABLE_TASKLISTS;
    for (event, range) in Parser::new_ext(text, options).into_offset_iter() {
        match event {
            Event::Start(Tag::Heading { .. }) => heading = Some(String::new()),
            Event::End(TagEnd::Heading(_)) => {
                let base = slug(&heading.take().unwrap_or_default());
                let n = seen.entry(base.clone()).or_insert(0);
                let anchor = if *n == 0 {
                    base.clone()
                } else {
                    format!("{base}-{n}")
                };
                *n += 1;
                anchors.insert(anchor);
            }
            Event::Text(t) => {
                if let Some(h) = heading.as_mut() {
                    h.push_str(&t);
                }
            }
            Event::Code(t) => {
                if let Some(h) = heading.as_mut() {
                    h.push_str(&t);
                }
                code_spans.push(Link {
                    line: line_of(range.start),
                    dest: t.into_string(),
                });
            }
            Event::Start(Tag::Link { dest_url, .. })
            | Event::Start(Tag::Image { dest_url, .. }) => {
                links.push(Link {
                    line: line_of(range.start),
                    dest: dest_url.into_string(),
                });
            }
            Event::Html(h) | Event::InlineHtml(h) => {
                for attr in ["id", "name"] {
                    anchors.extend(html_attributes(&h, attr));
                }
                for attr in ["href", "src"] {
                    for dest in html_attributes(&h, attr) {
                        links.push(Link {
                            line: line_of(range.start),
                            dest,
                        });
                    }
                }
            }
            _ => {}
        }
    }
    Page {
        anchors,
        links,
        code_spans,
    }
}

/// Why an external link is not well-formed, if it is not: `http(s)://host[:port][/path]` with a
/// dotted host or `localhost`, or `mailto:` an address; no spaces or angle brackets anywhere.
fn external_problem(dest: &str) -> Option<String> {
    if dest
        .chars()
        .any(|c| c.is_whitespace() || matches!(c, '<' | '>' | '"'))
    {
        return Some("space, angle bracket or quote in the address".into());
    }
    let lower = dest.to_ascii_lowercase();
    if let Some(address) = lower.strip_prefix("mailto:") {
        let ok = address
            .split_once('@')
            .is_some_and(|(user, host)| !user.is_empty() && host.contains('.'));
        return (!ok).then(|| "mailto: without a user@host.domain address".into());
    }
    let rest = match lower
        .strip_prefix("https://")
        .or_else(|| lower.strip_prefix("http://"))
    {
        Some(rest) => rest,
        None => return Some("scheme is not http, https or mailto".into()),
    };
    let authority = rest.split(['/', '?', '#']).next().unwrap_or("");
    let (host, port) = match authority.rsplit_once(':') {
        Some((h, p)) => (h, Some(p)),
        None => (authority, None),
    };
    if port.is_some_and(|p| p.is_empty() || !p.chars().all(|c| c.is_ascii_digit())) {
        return Some(format!("bad port in `{authority}`"));
    }
    let labels_ok = host.split('.').all(|l| {
        !l.is_empty()
            && !l.starts_with('-')
            && !l.ends_with('-')
            && l.chars().all(|c| c.is_ascii_alphanumeric() || c == '-')
    });
    if !labels_ok || !(host.contains('.') || host == "localhost") {
        return Some(format!("host `{host}` is not a domain name"));
    }
    None
}

/// Decodes `%XX` escapes in a link's path (GitHub serves `a%20b.md` as `a b.md`).
fn percent_decoded(path: &str) -> String {
    let bytes = path.as_bytes();
    let mut out = Vec::with_capacity(bytes.len());
    let mut i = 0;
    while i < bytes.len() {
        let hex = bytes
            .get(i + 1..i + 3)
            .and_then(|h| std::str::from_utf8(h).ok())
            .and_then(|h| u8::from_str_radix(h, 16).ok());
        match (bytes[i], hex) {
            (b'%', Some(b)) => {
                out.push(b);
                i += 3;
            }
            (b, _) => {
                out.push(b);
                i += 1;
            }
        }
    }
    String::from_utf8_lossy(&out).into_owned()
}

/// `path` with `.` and `..` resolved, or None when it climbs out of `root`.
fn inside(root: &Path, path: &Path) -> Option<PathBuf> {
    let mut out = PathBuf::new();
    for c in path.strip_prefix(root).ok()?.components() {
        match c {
            // climbing above the root ends the walk: None
            Component::ParentDir => out.pop().then_some(())?,
            Component::Normal(p) => out.push(p),
            _ => {}
        }
    }
    Some(root.join(out))
}

/// Whether `#L12` or `#L12-L20` names lines that `file` has.
fn line_anchor_ok(file: &Path, anchor: &str) -> bool {
    let lines = std::fs::read_to_string(file)
        .map(|t| t.lines().count())
        .unwrap_or(0);
    let number = |s: &str| s.strip_prefix('L').and_then(|n| n.parse::<usize>().ok());
    let (first, last) = match anchor.split_once('-') {
        Some((a, b)) => (number(a), number(b)),
        None => (number(anchor), number(anchor)),
    };
    matches!((first, last), (Some(a), Some(b)) if 1 <= a && a <= b && b <= lines)
}

/// Checks every Markdown file under `dir`; returns the number of files and links checked and
/// one line per problem, `file:line: `dest`: reason`.
fn check(dir: &Path) -> Report {
    let dir = dir
        .canonicalize()
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()));
    let files = markdown_files(&dir);
    let mut pages = BTreeMap::new();
    for f in &files {
        let text = std::fs::read_to_string(f).unwrap_or_else(|e| panic!("{}: {e}", f.display()));
        pages.insert(f.clone(), parse(&text));
    }
    let mut problems = Vec::new();
    let mut checked = 0;
    let paths = code_span_problems(&dir, &pages, &mut problems);
    for (file, page) in &pages {
        let shown = file
            .strip_prefix(&dir)
            .unwrap_or(file)
            .display()
            .to_string();
        for link in &page.links {
            checked += 1;
            let mut problem = |why: String| {
                problems.push(format!("{shown}:{}: `{}`: {why}", link.line, link.dest))
            };
            let dest = link.dest.as_str();
            let has_scheme = dest.split_once(':').is_some_and(|(s, _)| {
                s.len() > 1
                    && s.chars().next().is_some_and(|c| c.is_ascii_alphabetic())
                    && s.chars()
                        .all(|c| c.is_ascii_alphanumeric() || matches!(c, '+' | '-' | '.'))
            });
            if has_scheme {
                if let Some(why) = external_problem(dest) {
                    problem(why);
                }
                continue;
            }
            if dest.is_empty() {
                problem("empty link".into());
                continue;
            }
            let (path_part, anchor) = match dest.split_once('#') {
                Some((p, a)) => (p, Some(a)),
                None => (dest, None),
            };
            let path_part = path_part.split('?').next().unwrap_or("");
            let target = if path_part.is_empty() {
                file.clone()
            } else {
                let decoded = percent_decoded(path_part);
                let joined = match decoded.strip_prefix('/') {
                    Some(from_root) => dir.join(from_root),
                    None => file.parent().unwrap_or(&dir).join(&decoded),
                };
                match inside(&dir, &joined) {
                    Some(t) => t,
                    None => {
                        problem("points outside the repository".into());
                        continue;
                    }
                }
            };
            if !target.exists() {
                problem("no such file or folder".into());
                continue;
            }
            let Some(anchor) = anchor.filter(|a| !a.is_empty()) else {
                continue;
            };
            let anchor = percent_decoded(anchor);
            match pages.get(&target) {
                Some(p) if p.anchors.contains(&anchor) => {}
                Some(_) => problem(format!("no heading with anchor #{anchor}")),
                None if target.is_file() && line_anchor_ok(&target, &anchor) => {}
                None => problem(format!(
                    "#{anchor} is neither a heading of a Markdown file nor a line of the file"
                )),
            }
        }
    }
    Report {
        files: files.len(),
        links: checked,
        paths,
        problems,
    }
}

/// Checks the repository paths named in code spans; returns how many there were.
fn code_span_problems(
    dir: &Path,
    pages: &BTreeMap<PathBuf, Page>,
    problems: &mut Vec<String>,
) -> usize {
    let top: HashSet<String> = std::fs::read_dir(dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .filter_map(|e| e.ok().map(|e| e.file_name().to_string_lossy().into_owned()))
        .filter(|n| !SKIPPED_DIRS.contains(&n.as_str()))
        .collect();
    let mut paths = 0;
    // the vendored crates' own docs name paths inside those crates
    for (file, page) in pages
        .iter()
        .filter(|(f, _)| !f.starts_with(dir.join("vendor")))
    {
        let shown = file.strip_prefix(dir).unwrap_or(file).display().to_string();
        for span in &page.code_spans {
            let Some(path) = code_span_path(&span.dest, &top) else {
                continue;
            };
            paths += 1;
            if !dir.join(path).exists() {
                problems.push(format!(
                    "{shown}:{}: `{}`: names no file or folder of the repository",
                    span.line, span.dest
                ));
            }
        }
    }
    paths
}

#[test]
fn every_markdown_file_links_to_what_exists() {
    let Report {
        files,
        links,
        paths,
        problems,
    } = check(&root());
    println!("checked {links} links and {paths} paths in code spans in {files} Markdown files");
    // the walk must have found the docs, or the check proves nothing
    assert!(
        files >= 15 && links >= 100 && paths >= 100,
        "only {files} Markdown files, {links} links and {paths} paths found"
    );
    assert!(
        problems.is_empty(),
        "{} broken link(s) or path(s) in {files} Markdown files:\n{}",
        problems.len(),
        problems.join("\n")
    );
}

#[test]
fn github_anchor_rules() {
    assert_eq!(slug("colcon and ros2 launch"), "colcon-and-ros2-launch");
    assert_eq!(
        slug("Lock-step: where a step goes, and the 10,000 steps/s goal (issue 19, 2026-11-26)"),
        "lock-step-where-a-step-goes-and-the-10000-stepss-goal-issue-19-2026-11-26"
    );
    assert_eq!(slug("Poincaré map  and_more"), "poincaré-map--and_more");
    // repeated headings get -1, -2; code spans count by their text
    let page = parse("# Tests\n## Tests\n### `capsule replay FILE`\n# Tests\n");
    for a in ["tests", "tests-1", "tests-2", "capsule-replay-file"] {
        assert!(page.anchors.contains(a), "{a} missing: {:?}", page.anchors);
    }
}

#[test]
fn a_broken_link_an_unknown_anchor_and_a_malformed_address_are_reported() {
    let dir = TempDir::new("docs_links");
    std::fs::create_dir_all(dir.file("docs")).expect("create docs/");
    std::fs::write(dir.file("code.rs"), "fn main() {}\n").expect("write code.rs");
    std::fs::write(
        dir.file("README.md"),
        "# Top\n\n[good](docs/a.md#the-part) [good dir](docs) [good line](code.rs#L1)\n\
         [gone](docs/missing.md) [bad anchor](docs/a.md#no-such-part)\n\
         [bad line](code.rs#L9) [outside](../x.md) [own](#top) [own bad](#bottom)\n\
         [web](https://example.org/a?b#c) [bad web](<https://exa mple.org>) [bad host](http://nohost/)\n\
         `[in code](docs/missing.md)`\n\n```\n[in a block](docs/missing.md)\n```\n\
         `docs/a.md` `code.rs:1` `docs/gone.rs` `docs/*.md` `install/setup.sh` `a b/c` `docs/msg/Type`\n",
    )
    .expect("write README.md");
    std::fs::write(
        dir.file("docs/a.md"),
        "# A\n\n## The part\n\n[back](../README.md#top) [ref][r]\n\n[r]: ./nothing.md\n",
    )
    .expect("write docs/a.md");
    let Report {
        files,
        links,
        paths,
        problems,
    } = check(&dir);
    assert_eq!(files, 2);
    assert_eq!(links, 14, "{problems:#?}");
    // `code.rs:1` has no `/`; the pattern, build output, spaced span and type name are not paths
    assert_eq!(paths, 2, "{problems:#?}");
    let expected = [
        "README.md:4: `docs/missing.md`: no such file or folder",
        "README.md:4: `docs/a.md#no-such-part`: no heading with anchor #no-such-part",
        "README.md:5: `code.rs#L9`: #L9 is neither",
        "README.md:5: `../x.md`: points outside the repository",
        "README.md:5: `#bottom`: no heading with anchor #bottom",
        "README.md:6: `https://exa mple.org`: space",
        "README.md:6: `http://nohost/`: host `nohost` is not a domain name",
        "docs/a.md:5: `./nothing.md`: no such file or folder",
        "README.md:12: `docs/gone.rs`: names no file or folder",
    ];
    for e in expected {
        assert!(
            problems.iter().any(|p| p.starts_with(e)),
            "not reported: {e}\nreported: {problems:#?}"
        );
    }
    assert_eq!(problems.len(), expected.len(), "{problems:#?}");
}
