//! The layer rule of the crate, checked on its sources.
//!
//! Top-level modules (`src/x.rs` and `src/x/` are module `x`; `src/main.rs`
//! and `src/cli/` are the `cli` layer, which names the library through
//! `orogen::` paths) sit in tiers, bottom to top:
//!
//! ```text
//! error, raster            errors; cells, grids, windows, georeferencing and
//!                          projections, tile layouts and perimeters, 3x3 neighbours
//! io, store                readers and writers; the tile store; tile sinks (store::sink)
//! exec                     step traits, engines, output nodata rules, run plans
//! flow                     the flow graph: routers, sink resolvers, accumulation
//! hydro < oro < metrics < erosion < synth < tiles < report < compare
//!                          the algorithms, one tier each, in this order
//! ops, job                 user operations and batch jobs
//! cli                      main.rs and cli/
//! ```
//!
//! A module may name (`crate::x` in `use` lines, grouped `use crate::{a, b}`
//! forms, inline paths, and doc comments and their links) only itself,
//! modules of its own tier, and modules of lower tiers. Names re-exported at
//! the crate root (`crate::Error`) count as the module they come from.
//! No two top-level modules may name each other, directly or through
//! others (no import cycle), except `io` and `store`, which the tier lets
//! use each other (`io::atomic` marks `store::crash` points; the store's
//! writer removes dead temporaries through `io::atomic`).
//!
//! Every module declared in `src/lib.rs` must have a tier here. Paths
//! through `super::` are not followed: by house style they stay inside the
//! module they start in.

use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;

/// Tiers, bottom to top; the modules of one tier may name each other.
const TIERS: &[&[&str]] = &[
    &["error", "raster"],
    &["io", "store"],
    &["exec"],
    &["flow"],
    &["hydro"],
    &["oro"],
    &["metrics"],
    &["erosion"],
    &["synth"],
    &["tiles"],
    &["report"],
    &["compare"],
    &["ops", "job"],
    &["cli"],
];

/// Pairs of top-level modules allowed to name each other (see the module
/// documentation).
const ALLOWED_CYCLES: &[(&str, &str)] = &[("io", "store")];

/// One source file: its path relative to the crate root and its text.
struct Source {
    path: String,
    text: String,
}

/// One reference from a file to a top-level module.
#[derive(Debug, Clone, PartialEq)]
struct Reference {
    path: String,
    line: usize,
    from: String,
    to: String,
}

fn tier(module: &str) -> Option<usize> {
    TIERS.iter().position(|t| t.contains(&module))
}

/// The top-level module (layer) of a file under `src/`, `None` for the
/// crate root `src/lib.rs`.
fn module_of(path: &str) -> Option<String> {
    let rel = path.strip_prefix("src/").unwrap_or(path);
    if rel == "lib.rs" {
        return None;
    }
    if rel == "main.rs" {
        return Some("cli".into());
    }
    let first = rel.split('/').next().unwrap_or(rel);
    Some(first.strip_suffix(".rs").unwrap_or(first).to_string())
}

fn is_ident(c: char) -> bool {
    c.is_ascii_alphanumeric() || c == '_'
}

fn line_at(text: &str, offset: usize) -> usize {
    text[..offset].bytes().filter(|&b| b == b'\n').count() + 1
}

/// The first identifier at `text[i..]` after whitespace, with its offset.
fn ident_at(text: &str, mut i: usize) -> Option<(usize, String)> {
    let b = text.as_bytes();
    while i < b.len() && (b[i] as char).is_whitespace() {
        i += 1;
    }
    let start = i;
    while i < b.len() && is_ident(b[i] as char) {
        i += 1;
    }
    (i > start).then(|| (start, text[start..i].to_string()))
}

/// Every `crate::NAME` in `text` (NAME the first path segment; in a group
/// `crate::{a, b::c}` each item's first segment), as (offset, NAME).
/// `$crate::` (macros) and `foo::crate::` are not references.
fn crate_paths(text: &str) -> Vec<(usize, String)> {
    let mut out = Vec::new();
    let b = text.as_bytes();
    let mut from = 0;
    while let Some(k) = text[from..].find("crate::") {
        let at = from + k;
        from = at + "crate::".len();
        if at > 0 {
            let prev = b[at - 1] as char;
            if is_ident(prev) || prev == '$' || prev == ':' {
                continue;
            }
        }
        let mut i = from;
        while i < b.len() && (b[i] as char).is_whitespace() {
            i += 1;
        }
        if i < b.len() && b[i] == b'{' {
            // A group: the first segment of each item at depth 1.
            let mut depth = 0usize;
            let mut expect_item = true;
            while i < b.len() {
                match b[i] {
                    b'{' => {
                        depth += 1;
                        if depth == 1 {
                            expect_item = true;
                        }
                    }
                    b'}' => {
                        depth -= 1;
                        if depth == 0 {
                            break;
                        }
                    }
                    b',' if depth == 1 => expect_item = true,
                    c if expect_item && depth == 1 && is_ident(c as char) => {
                        if let Some((s, name)) = ident_at(text, i) {
                            i = s + name.len();
                            out.push((s, name));
                            expect_item = false;
                            continue;
                        }
                    }
                    _ => {}
                }
                i += 1;
            }
        } else if let Some((s, name)) = ident_at(text, i) {
            out.push((s, name));
        }
    }
    out
}

/// Names the crate root re-exports (`pub use x::{A, B as C}` in lib.rs),
/// mapped to the module they come from.
fn root_names(lib: &str) -> BTreeMap<String, String> {
    let mut map = BTreeMap::new();
    let mut rest = lib;
    while let Some(k) = rest.find("pub use ") {
        let stmt_start = k + "pub use ".len();
        let end = rest[stmt_start..]
            .find(';')
            .map_or(rest.len(), |e| stmt_start + e);
        let stmt = &rest[stmt_start..end];
        let stmt = stmt.strip_prefix("crate::").unwrap_or(stmt);
        if let Some((module, items)) = stmt.split_once("::") {
            let module = module.trim().to_string();
            let items = items.trim().trim_start_matches('{').trim_end_matches('}');
            for item in items.split(',') {
                let leaf = item
                    .rsplit(" as ")
                    .next()
                    .unwrap_or(item)
                    .rsplit("::")
                    .next()
                    .unwrap_or(item)
                    .trim();
                if !leaf.is_empty() && leaf != "self" {
                    map.insert(leaf.to_string(), module.clone());
                }
            }
        }
        rest = &rest[end..];
    }
    map
}

/// Every reference between two different top-level modules in `sources`.
/// `modules` is the set of top-level modules, `roots` the crate root's
/// re-exported names (see [`root_names`]).
fn references(
    sources: &[Source],
    modules: &BTreeSet<String>,
    roots: &BTreeMap<String, String>,
) -> Vec<Reference> {
    let mut out = Vec::new();
    for s in sources {
        let Some(from) = module_of(&s.path) else {
            continue;
        };
        for (offset, name) in crate_paths(&s.text) {
            let to = if modules.contains(&name) {
                name
            } else if let Some(m) = roots.get(&name) {
                m.clone()
            } else {
                continue;
            };
            if to != from {
                out.push(Reference {
                    path: s.path.clone(),
                    line: line_at(&s.text, offset),
                    from: from.clone(),
                    to,
                });
            }
        }
    }
    out
}

/// The references that break the tier rule, as `file:line: a -> b` lines
/// (a module without a tier is a violation too).
fn violations(refs: &[Reference]) -> Vec<String> {
    let mut out = Vec::new();
    for r in refs {
        match (tier(&r.from), tier(&r.to)) {
            (Some(a), Some(b)) if b <= a => {}
            (Some(a), Some(b)) => out.push(format!(
                "{}:{}: {} (tier {a}) names {} (tier {b}), a higher layer",
                r.path, r.line, r.from, r.to
            )),
            (None, _) => out.push(format!(
                "{}:{}: module {} has no tier in tests/architecture.rs",
                r.path, r.line, r.from
            )),
            (_, None) => out.push(format!(
                "{}:{}: module {} has no tier in tests/architecture.rs",
                r.path, r.line, r.to
            )),
        }
    }
    out
}

/// Import cycles between top-level modules (strongly connected components
/// of more than one module, after dropping [`ALLOWED_CYCLES`] edges), each
/// as `a -> b (file:line), b -> a (file:line)`.
fn cycles(refs: &[Reference]) -> Vec<String> {
    let allowed = |a: &str, b: &str| {
        ALLOWED_CYCLES
            .iter()
            .any(|&(x, y)| (x == a && y == b) || (x == b && y == a))
    };
    // One example reference per edge.
    let mut edges: BTreeMap<(String, String), String> = BTreeMap::new();
    for r in refs {
        if !allowed(&r.from, &r.to) {
            edges
                .entry((r.from.clone(), r.to.clone()))
                .or_insert_with(|| format!("{}:{}", r.path, r.line));
        }
    }
    let nodes: BTreeSet<String> = edges
        .keys()
        .flat_map(|(a, b)| [a.clone(), b.clone()])
        .collect();
    let reach = |start: &str| -> BTreeSet<String> {
        let mut seen = BTreeSet::new();
        let mut stack = vec![start.to_string()];
        while let Some(n) = stack.pop() {
            for ((a, b), _) in edges.range((n.clone(), String::new())..) {
                if *a != n {
                    break;
                }
                if seen.insert(b.clone()) {
                    stack.push(b.clone());
                }
            }
        }
        seen
    };
    let reachable: BTreeMap<String, BTreeSet<String>> =
        nodes.iter().map(|n| (n.clone(), reach(n))).collect();
    let mut done = BTreeSet::new();
    let mut out = Vec::new();
    for n in &nodes {
        if done.contains(n) {
            continue;
        }
        let component: BTreeSet<String> = nodes
            .iter()
            .filter(|m| {
                *m == n || (reachable[n].contains(*m) && reachable[*m].contains(n.as_str()))
            })
            .cloned()
            .collect();
        done.extend(component.iter().cloned());
        if component.len() > 1 {
            let inside: Vec<String> = edges
                .iter()
                .filter(|((a, b), _)| component.contains(a) && component.contains(b))
                .map(|((a, b), at)| format!("{a} -> {b} ({at})"))
                .collect();
            out.push(inside.join(", "));
        }
    }
    out
}

fn read_sources(dir: &Path, root: &Path, out: &mut Vec<Source>) {
    let mut entries: Vec<_> = std::fs::read_dir(dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|e| e.unwrap().path())
        .collect();
    entries.sort();
    for p in entries {
        if p.is_dir() {
            read_sources(&p, root, out);
        } else if p.extension().is_some_and(|x| x == "rs") {
            let rel = p
                .strip_prefix(root)
                .unwrap()
                .to_string_lossy()
                .replace('\\', "/");
            let text = std::fs::read_to_string(&p).unwrap();
            out.push(Source { path: rel, text });
        }
    }
}

/// The crate's sources, its top-level modules and root re-exports.
fn crate_sources() -> (Vec<Source>, BTreeSet<String>, BTreeMap<String, String>) {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut sources = Vec::new();
    read_sources(&root.join("src"), root, &mut sources);
    let lib = std::fs::read_to_string(root.join("src/lib.rs")).unwrap();
    let mut modules: BTreeSet<String> = lib
        .lines()
        .filter_map(|l| l.trim().strip_prefix("pub mod "))
        .chain(lib.lines().filter_map(|l| l.trim().strip_prefix("mod ")))
        .map(|m| m.trim_end_matches(';').trim().to_string())
        .collect();
    modules.insert("cli".into());
    (sources, modules, root_names(&lib))
}

#[test]
fn every_module_has_a_tier() {
    let (_, modules, _) = crate_sources();
    let missing: Vec<&String> = modules.iter().filter(|m| tier(m).is_none()).collect();
    assert!(
        missing.is_empty(),
        "modules of src/lib.rs without a tier in tests/architecture.rs: {missing:?}"
    );
}

#[test]
fn layers_point_one_way() {
    let (sources, modules, roots) = crate_sources();
    assert!(sources.len() > 100, "read only {} files", sources.len());
    let refs = references(&sources, &modules, &roots);
    assert!(refs.len() > 100, "found only {} references", refs.len());
    let bad = violations(&refs);
    assert!(
        bad.is_empty(),
        "{} reference(s) from a lower layer to a higher one:\n{}",
        bad.len(),
        bad.join("\n")
    );
}

#[test]
fn no_import_cycle_between_top_level_modules() {
    let (sources, modules, roots) = crate_sources();
    let found = cycles(&references(&sources, &modules, &roots));
    assert!(
        found.is_empty(),
        "import cycles between top-level modules:\n{}",
        found.join("\n")
    );
}

fn synthetic(files: &[(&str, &str)]) -> Vec<Reference> {
    let sources: Vec<Source> = files
        .iter()
        .map(|&(path, text)| Source {
            path: path.into(),
            text: text.into(),
        })
        .collect();
    let modules: BTreeSet<String> = TIERS
        .iter()
        .flat_map(|t| t.iter())
        .map(|m| m.to_string())
        .collect();
    let roots = root_names("pub use error::{Error, Result};\npub use ops::fill as fill_dem;\n");
    references(&sources, &modules, &roots)
}

#[test]
fn the_check_finds_synthetic_violations() {
    let refs = synthetic(&[
        // An inline path, a multi-line group, a doc link, a root re-export.
        (
            "src/io/fake.rs",
            "fn f() { crate::ops::choose_layout(); }\n",
        ),
        (
            "src/hydro/fake/deep.rs",
            "use crate::{\n    raster::Grid,\n    metrics::{terrain, x},\n    error::Result,\n};\n",
        ),
        (
            "src/exec/fake.rs",
            "//! See [`crate::ops::run`].\nuse crate::fill_dem;\n",
        ),
        ("src/store.rs", "use crate::exec::TileSink;\n"),
        // Allowed: lower tiers, the same tier, roots, macros, the cli.
        (
            "src/oro/ok.rs",
            "use crate::hydro::x;\nuse crate::Error;\nuse crate::{raster, exec::E};\n",
        ),
        (
            "src/io/ok.rs",
            "use crate::store::x;\nmacro_rules! m { () => { $crate::ops::x } }\n",
        ),
        (
            "src/main.rs",
            "use crate::cli::x;\nfn main() { orogen::ops::x(); }\n",
        ),
        ("src/lib.rs", "pub use ops::fill as fill_dem;\n"),
    ]);
    let bad = violations(&refs);
    let expected = [
        "src/io/fake.rs:1: io (tier 1) names ops (tier 12), a higher layer",
        "src/hydro/fake/deep.rs:3: hydro (tier 4) names metrics (tier 6), a higher layer",
        "src/exec/fake.rs:1: exec (tier 2) names ops (tier 12), a higher layer",
        "src/exec/fake.rs:2: exec (tier 2) names ops (tier 12), a higher layer",
        "src/store.rs:1: store (tier 1) names exec (tier 2), a higher layer",
    ];
    assert_eq!(bad, expected);
    // The same-tier and lower references were found, not skipped.
    let oro: Vec<&str> = refs
        .iter()
        .filter(|r| r.path == "src/oro/ok.rs")
        .map(|r| r.to.as_str())
        .collect();
    assert_eq!(oro, ["hydro", "error", "raster", "exec"]);
    assert!(refs
        .iter()
        .any(|r| r.path == "src/io/ok.rs" && r.to == "store"));
    assert!(!refs
        .iter()
        .any(|r| r.path == "src/io/ok.rs" && r.to == "ops"));
}

#[test]
fn the_check_finds_a_synthetic_cycle() {
    // ops and job share a tier, so each may name the other, but not both.
    let refs = synthetic(&[
        ("src/ops/a.rs", "use crate::job::Job;\n"),
        ("src/job.rs", "\nuse crate::ops::fill;\n"),
        ("src/io/a.rs", "use crate::store::x;\n"),
        ("src/store/a.rs", "use crate::io::y;\n"),
    ]);
    assert!(violations(&refs).is_empty());
    assert_eq!(
        cycles(&refs),
        ["job -> ops (src/job.rs:2), ops -> job (src/ops/a.rs:1)"]
    );
    // A module without a tier is reported.
    let refs = synthetic(&[("src/drainage/a.rs", "use crate::raster::Grid;\n")]);
    assert_eq!(
        violations(&refs),
        ["src/drainage/a.rs:1: module drainage has no tier in tests/architecture.rs"]
    );
}
