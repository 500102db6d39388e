//! Architecture test for `sipnpuff`: the top-level modules stand on floors ([`FLOORS`]) and
//! import only from floors below their own, the runtime uses only the seams' roots, and no
//! source files import each other in a cycle. Std only, so it costs nothing to keep.
//!
//! How: every `.rs` file under `src/` is tokenised with comments and string/char literals
//! skipped (so doc examples and "crate::x" strings don't count). Paths rooted at `crate::`,
//! `super::`, `self::` and `sipnpuff::` (the library as main.rs names it) are collected from
//! `use` trees (nested groups, globs, `self`, `as`) and from expressions/types. Bare paths resolve
//! too when their first segment is a child module file (`pub use csv::CsvSensor;` in a mod.rs)
//! or a module brought in by `use` (`use crate::sensor; sensor::csv::X`): the obvious loophole.
//! A path resolves to the longest prefix that is a module *file*, so `crate::control::Tick`
//! lands in src/control/mod.rs. Inline `mod x { … }` blocks belong to their file but do shift
//! what `super::`/`self::` mean. Standard layout only (no `#[path]`); `mod x;` is not an edge.
//!
//! main.rs is the binary root: it resolves names like the crate root, its `sipnpuff::` paths
//! are library `crate::` paths, and it takes the `cli` role (top of the stack, unrestricted).

use std::collections::{BTreeMap, BTreeSet};
use std::fmt;
use std::path::Path;

const CRATE_NAME: &str = "sipnpuff";

// ------------------------------------------------------------------------------------ rules

/// The crate's top-level modules by floor, the ground first. A module
/// imports only from floors below its own: the core knows nothing else,
/// nor do the clock and the threads' wake-up log beside it;
/// the seams (sensor, arm, output) know the core; configuration and the
/// runtime know the seams; fitting, and the wiring that opens backends
/// from their specs, know the configuration and the runtime; simulation
/// and the display know fitting and the runtime; the tools sit above
/// them; the designer, and the sessions that wire the runtime, the
/// backends, the display, the recorder and the synthetic sensor, sit on
/// the tools; the command line sits on top.
pub const FLOORS: &[&[&str]] = &[
    &["control", "clock", "wakes"],
    &["sensor", "arm", "output"],
    &["config", "rt"],
    &["fit", "gestures", "wiring"],
    &["sim", "display"],
    &["tools"],
    &["design", "session"],
    &["cli"],
];

/// The floor of top-level module `top` (1 = the ground); the crate root
/// (lib.rs) is 0, an unknown module is above every floor.
pub fn floor(top: &str) -> usize {
    if top.is_empty() {
        return 0;
    }
    FLOORS
        .iter()
        .position(|f| f.contains(&top))
        .map_or(usize::MAX, |i| i + 1)
}

/// The rule broken by a reference from a file of top-level role `from_role` to the module file
/// with module path `to` (`[]` = lib.rs), if any. One message per offending reference.
pub fn rule_violation(from_role: &str, to: &[String]) -> Option<&'static str> {
    let top = to.first().map_or("", String::as_str);
    if top == from_role {
        return None;
    }
    if floor(from_role) == usize::MAX {
        return Some("rule 1: every top-level module has a floor in FLOORS");
    }
    if floor(top) >= floor(from_role) {
        return Some("rule 1: a module imports only from floors below its own");
    }
    let port_root = matches!(top, "sensor" | "arm" | "output") && to.len() == 1;
    if from_role == "rt" && !port_root && !matches!(top, "control" | "clock" | "wakes") {
        return Some(
            "rule 2: rt/ may use only the sensor/arm/output module roots (mod.rs), not backends",
        );
    }
    None
}

// ------------------------------------------------------------------------------------ lexing

struct Tok {
    text: String,
    line: usize,
}

fn is_ident(s: &str) -> bool {
    s.starts_with(|c: char| c.is_alphabetic() || c == '_')
}

/// Splits source into identifiers (and numbers), `::` and single punctuation characters,
/// dropping whitespace, comments and literals.
fn tokenize(src: &str) -> Vec<Tok> {
    let c: Vec<char> = src.chars().collect();
    let word = |ch: char| ch.is_alphanumeric() || ch == '_';
    let (mut toks, mut line, mut i) = (Vec::new(), 1, 0);
    while i < c.len() {
        let start = i;
        if let Some(end) = skip_non_code(&c, i) {
            i = end.min(c.len());
        } else if c[i].is_whitespace() {
            i += 1;
        } else {
            i += c[i..].iter().take_while(|&&ch| word(ch)).count().max(1);
            i += usize::from(c[start] == ':' && c.get(i) == Some(&':'));
            toks.push(Tok {
                text: c[start..i].iter().collect(),
                line,
            });
        }
        line += c[start..i].iter().filter(|&&ch| ch == '\n').count();
    }
    toks
}

/// If a comment or a string/char literal starts at `c[i]`, the index just past it.
fn skip_non_code(c: &[char], i: usize) -> Option<usize> {
    let at = |k: usize, s: &str| {
        c.get(k..k + s.len())
            .is_some_and(|w| w.iter().copied().eq(s.chars()))
    };
    let past = |from: usize, s: &str| {
        (from..c.len())
            .find(|&k| at(k, s))
            .map_or(c.len(), |k| k + s.len())
    };
    let after_word = i > 0 && (c[i - 1].is_alphanumeric() || c[i - 1] == '_');
    if at(i, "//") {
        Some((i..c.len()).find(|&k| c[k] == '\n').unwrap_or(c.len()))
    } else if at(i, "/*") {
        let (mut depth, mut k) = (0, i); // block comments nest
        while k < c.len() {
            let step = i32::from(at(k, "/*")) - i32::from(at(k, "*/")); // +1 opens, -1 closes
            (depth, k) = (depth + step, k + 1 + step.unsigned_abs() as usize);
            if depth == 0 {
                break;
            }
        }
        Some(k)
    } else if at(i, "\"") {
        let mut k = i + 1;
        while k < c.len() && c[k] != '"' {
            k += if c[k] == '\\' { 2 } else { 1 };
        }
        Some(k + 1)
    } else if at(i, "'\\") {
        Some(past(i + 3, "'")) // escaped char literal such as '\'' or '\u{1F600}'
    } else if at(i, "'") && at(i + 2, "'") {
        Some(i + 3) // 'x'; a lifetime 'a never has a quote two characters later
    } else if let Some(r) = ["r", "br", "cr"].iter().find(|p| !after_word && at(i, p)) {
        // r"…", r#"…"#, br"…", cr"…"; a raw identifier `r#type` has no quote and is code.
        let hashes = c[i + r.len()..].iter().take_while(|&&ch| ch == '#').count();
        let open = i + r.len() + hashes;
        at(open, "\"").then(|| past(open + 1, &format!("\"{}", "#".repeat(hashes))))
    } else {
        None
    }
}

// ------------------------------------------------------------------------------------ parsing

/// A path as written in one file, before resolution.
#[derive(Debug, Clone)]
pub struct RawPath {
    pub line: usize,
    pub segs: Vec<String>,
    /// Enclosing inline modules (`mod tests { … }`), from which `super::`/`self::` start.
    pub inline_mods: Vec<String>,
    /// Name a `use` leaf binds (last segment or `as` alias); `None` for globs and other paths.
    pub binding: Option<String>,
}

/// Collects every leaf of every `use` tree and every `a::b…` path in expressions and types.
pub fn scan_paths(src: &str) -> Vec<RawPath> {
    let t = tokenize(src);
    let text = |k: usize| t.get(k).map_or("", |tok| tok.text.as_str());
    let (mut out, mut mods, mut depth, mut i) =
        (Vec::new(), Vec::<(String, usize)>::new(), 0usize, 0);
    while i < t.len() {
        let scope: Vec<String> = mods.iter().map(|m| m.0.clone()).collect();
        let after_sep = i > 0 && text(i - 1) == "::";
        match text(i) {
            "{" => depth += 1,
            "}" => {
                depth = depth.saturating_sub(1);
                while mods.last().is_some_and(|m| m.1 > depth) {
                    mods.pop();
                }
            }
            "mod" if is_ident(text(i + 1)) && text(i + 2) == "{" => {
                mods.push((text(i + 1).into(), depth + 1))
            }
            "use" if !after_sep => {
                i += 1;
                parse_use_tree(&t, &mut i, Vec::new(), &scope, &mut out);
                continue;
            }
            s if is_ident(s) && text(i + 1) == "::" && !after_sep => {
                let (line, mut segs) = (t[i].line, Vec::new());
                while is_ident(text(i)) {
                    segs.push(text(i).to_string());
                    i += 1;
                    if text(i) != "::" {
                        break;
                    }
                    i += 1; // stops before `<` in `a::b::<T>`
                }
                out.push(RawPath {
                    line,
                    segs,
                    inline_mods: scope,
                    binding: None,
                });
                continue;
            }
            _ => {}
        }
        i += 1;
    }
    out
}

/// Parses the use tree at `t[*i]` and records each leaf with the full path, so
/// `use crate::{a::b, c::{self as d, *}};` yields crate::a::b, crate::c (bound as d), crate::c.
fn parse_use_tree(
    t: &[Tok],
    i: &mut usize,
    mut prefix: Vec<String>,
    scope: &[String],
    out: &mut Vec<RawPath>,
) {
    let text = |k: usize| t.get(k).map_or("", |tok| tok.text.as_str());
    let mut leaf = |segs: Vec<String>, binding: Option<String>, line: usize| {
        out.push(RawPath {
            line,
            segs,
            inline_mods: scope.to_vec(),
            binding,
        })
    };
    while *i < t.len() {
        let line = t[*i].line;
        match text(*i) {
            "::" => *i += 1,
            "{" => {
                *i += 1;
                while *i < t.len() && text(*i) != "}" {
                    let before = *i;
                    parse_use_tree(t, i, prefix.clone(), scope, out);
                    *i += usize::from(text(*i) == "," || *i == before);
                }
                *i += 1;
                return;
            }
            "*" => {
                *i += 1;
                return leaf(prefix, None, line);
            }
            s if is_ident(s) => {
                prefix.push(s.to_string());
                *i += 1;
                if text(*i) == "::" {
                    continue;
                }
                if prefix.last().is_some_and(|s| s == "self") {
                    prefix.pop();
                }
                let mut binding = prefix.last().cloned();
                if text(*i) == "as" {
                    binding = Some(text(*i + 1).to_string());
                    *i += 2;
                }
                return leaf(prefix, binding, line);
            }
            _ => return,
        }
    }
}

// ------------------------------------------------------------------------------------ resolution

/// Module path of a file relative to src/: lib.rs and main.rs → [], a/mod.rs → [a], a/b.rs → [a, b].
pub fn module_path(rel: &str) -> Vec<String> {
    let mut segs: Vec<String> = rel
        .trim_end_matches(".rs")
        .split('/')
        .map(String::from)
        .collect();
    if segs.last().is_some_and(|s| s == "mod") || rel == "lib.rs" || rel == "main.rs" {
        segs.pop();
    }
    segs
}

/// The layer a file belongs to for the rules: its top-level module (main.rs counts as `cli`).
fn role(rel: &str) -> String {
    if rel == "main.rs" {
        "cli".into()
    } else {
        module_path(rel).first().cloned().unwrap_or_default()
    }
}

/// One resolved reference: file `from` uses `path` (as written) on `line`, landing in file `to`.
#[derive(Debug, Clone, PartialEq)]
pub struct Edge {
    pub from: String,
    pub line: usize,
    pub path: String,
    pub to: String,
}

/// Module path → file relative to src/ (main.rs is not a module of the library).
type Modules = BTreeMap<Vec<String>, String>;

/// Absolute path of `segs` written in module `here`, or `None` when it is not crate-local
/// (std, external crates, locals, `Self::`, globs' unknown names).
fn absolute(
    segs: &[String],
    here: &[String],
    aliases: &Modules,
    modules: &Modules,
) -> Option<Vec<String>> {
    let supers = segs.iter().take_while(|s| *s == "super").count();
    let (mut base, rest) = match segs[0].as_str() {
        // `sipnpuff::` is the library from main.rs, or `extern crate self as sipnpuff` anywhere.
        "crate" | CRATE_NAME => (vec![], &segs[1..]),
        "self" => (here.to_vec(), &segs[1..]),
        "super" if supers <= here.len() => (here[..here.len() - supers].to_vec(), &segs[supers..]),
        _ if modules.contains_key(&[here, &segs[..1]].concat()) => (here.to_vec(), segs),
        _ => (module_path(aliases.get(&segs[..1])?), &segs[1..]),
    };
    base.extend_from_slice(rest);
    Some(base)
}

/// Resolves every path in every file into file-to-file edges; `files` holds
/// (path relative to src/ with `/` separators, source text).
pub fn edges(files: &[(String, String)]) -> Vec<Edge> {
    let modules: Modules = files
        .iter()
        .filter(|(rel, _)| rel != "main.rs")
        .map(|(rel, _)| (module_path(rel), rel.clone()))
        .collect();
    let mut out = Vec::new();
    for (rel, src) in files {
        let (file_mod, paths) = (module_path(rel), scan_paths(src));
        let here = |p: &RawPath| [&file_mod[..], &p.inline_mods].concat();
        // Names a `use` binds to a module file (`use crate::sensor;`), keyed like `Modules`.
        let aliases: Modules = paths
            .iter()
            .filter_map(|p| {
                let abs = absolute(&p.segs, &here(p), &Modules::new(), &modules)?;
                let file = modules.get(&abs)?;
                Some((vec![p.binding.clone()?], file.clone()))
            })
            .collect();
        for p in &paths {
            let Some(abs) = absolute(&p.segs, &here(p), &aliases, &modules) else {
                continue;
            };
            // Longest prefix that is a module file; lib.rs ([]) always matches.
            if let Some(to) = (0..=abs.len()).rev().find_map(|n| modules.get(&abs[..n])) {
                out.push(Edge {
                    from: rel.clone(),
                    line: p.line,
                    path: p.segs.join("::"),
                    to: to.clone(),
                });
            }
        }
    }
    out
}

// ------------------------------------------------------------------------------------ checks

/// Everything found wrong: layering violations and file import cycles (rule 3).
#[derive(Debug, Default)]
pub struct Report {
    pub violations: Vec<(Edge, &'static str)>,
    pub cycles: Vec<Vec<String>>,
    /// First edge per (from, to) pair, to show *why* the files of a cycle depend on each other.
    evidence: BTreeMap<(String, String), Edge>,
}

/// Runs every rule over the crate's sources.
pub fn analyse(files: &[(String, String)]) -> Report {
    let mut report = Report::default();
    let mut graph: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    for edge in edges(files) {
        if let Some(rule) = rule_violation(&role(&edge.from), &module_path(&edge.to)) {
            report.violations.push((edge.clone(), rule));
        }
        if edge.from != edge.to {
            graph
                .entry(edge.from.clone())
                .or_default()
                .insert(edge.to.clone());
            report
                .evidence
                .entry((edge.from.clone(), edge.to.clone()))
                .or_insert(edge);
        }
    }
    report.cycles = cycles(&graph);
    report
}

/// Groups of files that transitively import each other (the strongly connected components
/// with more than one file; self-loops don't count). Plain per-file reachability rather than
/// Tarjan: the crate has tens of files, and this is obviously correct.
pub fn cycles(graph: &BTreeMap<String, BTreeSet<String>>) -> Vec<Vec<String>> {
    let reach = |from: &String| {
        let (mut seen, mut todo) = (BTreeSet::new(), vec![from.clone()]);
        while let Some(v) = todo.pop() {
            for w in graph.get(&v).into_iter().flatten() {
                if seen.insert(w.clone()) {
                    todo.push(w.clone());
                }
            }
        }
        seen
    };
    let reach: BTreeMap<&String, BTreeSet<String>> = graph.keys().map(|v| (v, reach(v))).collect();
    let mut out: Vec<Vec<String>> = Vec::new();
    for (v, reachable) in &reach {
        let scc: Vec<String> = reachable
            .iter()
            .filter(|w| reach.get(w).is_some_and(|r| r.contains(*v)))
            .cloned()
            .collect();
        if scc.len() > 1 && !out.contains(&scc) {
            out.push(scc);
        }
    }
    out
}

impl fmt::Display for Report {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(f, "{} import-rule violation(s):", self.violations.len())?;
        for (e, rule) in &self.violations {
            let (from, line, path, to) = (&e.from, e.line, &e.path, &e.to);
            writeln!(
                f,
                "  src/{from}:{line}: `{path}` (-> src/{to}) breaks {rule}"
            )?;
        }
        let n = self.cycles.len();
        writeln!(
            f,
            "{n} file import cycle(s) (rule 3: no import cycles between files):"
        )?;
        for scc in &self.cycles {
            writeln!(f, "  cycle between src/{}:", scc.join(", src/"))?;
            for ((from, to), e) in self
                .evidence
                .iter()
                .filter(|((a, b), _)| scc.contains(a) && scc.contains(b))
            {
                writeln!(
                    f,
                    "    src/{from}:{} uses `{}` (-> src/{to})",
                    e.line, e.path
                )?;
            }
        }
        Ok(())
    }
}

/// Reads every `.rs` file below `dir` as (path relative to `dir` joined with `/`, text), sorted.
pub fn load_sources(dir: &Path) -> Vec<(String, String)> {
    fn walk(root: &Path, dir: &Path, out: &mut Vec<(String, String)>) {
        for entry in
            std::fs::read_dir(dir).unwrap_or_else(|e| panic!("reading {}: {e}", dir.display()))
        {
            let path = entry.expect("directory entry").path();
            if path.is_dir() {
                walk(root, &path, out);
            } else if path.extension().is_some_and(|x| x == "rs") {
                let rel = path
                    .strip_prefix(root)
                    .unwrap()
                    .to_string_lossy()
                    .replace('\\', "/");
                out.push((rel, std::fs::read_to_string(&path).expect("UTF-8 source")));
            }
        }
    }
    let mut out = Vec::new();
    walk(dir, dir, &mut out);
    out.sort();
    out
}

// ------------------------------------------------------------------------------------ tests

#[test]
fn import_rules_hold() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let files = load_sources(&src);
    assert!(
        files.iter().any(|(rel, _)| rel == "lib.rs"),
        "no lib.rs in {}",
        src.display()
    );
    let report = analyse(&files);
    assert!(
        report.violations.is_empty() && report.cycles.is_empty(),
        "architecture rules broken:\n{report}"
    );
}

#[cfg(test)]
fn fixture(files: &[(&str, &str)]) -> Vec<(String, String)> {
    files
        .iter()
        .map(|(rel, src)| (rel.to_string(), src.to_string()))
        .collect()
}

/// `"path -> file"` for each edge leaving `from`, for compact assertions.
#[cfg(test)]
fn edges_from(files: &[(&str, &str)], from: &str) -> Vec<String> {
    edges(&fixture(files))
        .into_iter()
        .filter(|e| e.from == from)
        .map(|e| format!("{} -> {}", e.path, e.to))
        .collect()
}

#[test]
fn nested_use_groups_expand_to_every_leaf() {
    let src = "use crate::{a::b, c::{self as d, e::*}, f};\npub use super::g;";
    let leaves: Vec<String> = scan_paths(src)
        .into_iter()
        .map(|p| {
            format!(
                "{}@{}:{}",
                p.segs.join("::"),
                p.line,
                p.binding.unwrap_or_default()
            )
        })
        .collect();
    assert_eq!(
        leaves,
        [
            "crate::a::b@1:b",
            "crate::c@1:d",
            "crate::c::e@1:",
            "crate::f@1:f",
            "super::g@2:g"
        ]
    );
}

#[test]
fn super_self_and_inline_paths_resolve_to_module_files() {
    let clock = "use super::super::control::Tick;\nfn f() { crate::rt::alloc_counter::count::<u8>(); }\n\
                 mod tests { use super::*; use super::super::X; use self::inner::Y; }";
    let files = [
        ("lib.rs", ""),
        ("control/mod.rs", ""),
        ("rt/mod.rs", ""),
        ("rt/alloc_counter.rs", ""),
        ("rt/clock.rs", clock),
    ];
    assert_eq!(
        edges_from(&files, "rt/clock.rs"),
        [
            "super::super::control::Tick -> control/mod.rs",
            "crate::rt::alloc_counter::count -> rt/alloc_counter.rs",
            "super -> rt/clock.rs", // inside `mod tests`, `super` is the file's own module
            "super::super::X -> rt/mod.rs",
            "self::inner::Y -> rt/clock.rs",
        ]
    );
}

#[test]
fn comments_and_strings_are_ignored() {
    let src = "//! crate::a::X\n/// ```\n/// use crate::b::Y;\n/// ```\n/* crate::c /* nested */ crate::d */\n\
               fn f<'a>(s: &'a str) { (\"crate::e\\\"\", r#\"crate::f\"#, br#\"\"crate::\"#, cr\"\\\", b'\"', '\\'', crate::g::h) }";
    let paths: Vec<String> = scan_paths(src)
        .iter()
        .map(|p| format!("{}@{}", p.segs.join("::"), p.line))
        .collect();
    assert_eq!(paths, ["crate::g::h@6"]);
}

#[test]
fn bare_child_and_imported_module_paths_resolve() {
    let files = [
        ("lib.rs", ""),
        ("sensor/mod.rs", "pub use csv::CsvSensor;"),
        ("sensor/csv.rs", ""),
        (
            "rt/mod.rs",
            "use crate::sensor as s;\nfn f() { s::csv::read(); std::mem::drop(1); }",
        ),
    ];
    assert_eq!(
        edges_from(&files, "sensor/mod.rs"),
        ["csv::CsvSensor -> sensor/csv.rs"]
    );
    assert_eq!(
        edges_from(&files, "rt/mod.rs"),
        [
            "crate::sensor -> sensor/mod.rs",
            "s::csv::read -> sensor/csv.rs"
        ]
    );
}

#[test]
fn forbidden_edges_are_reported_and_allowed_ones_are_not() {
    let report = analyse(&fixture(&[
        ("lib.rs", ""),
        ("control/mod.rs", "use crate::config::Config;"),
        ("config/mod.rs", "use crate::sensor::settings::S;"),
        ("sensor/mod.rs", "pub trait Sensor {}"),
        ("sensor/settings.rs", ""),
        ("sensor/csv.rs", "use crate::arm::Arm;"),
        ("arm/mod.rs", ""),
        ("sim/mod.rs", "use crate::tools::X;"),
        ("tools/mod.rs", ""),
        (
            "rt/mod.rs",
            "use crate::sensor::{Sensor, csv::CsvSensor};\nuse crate::{control, sim::Plant};",
        ),
        ("stray/mod.rs", "use crate::control::X;"),
    ]));
    let found: Vec<String> = report
        .violations
        .iter()
        .map(|(e, rule)| format!("{}:{} {}", e.from, e.line, &rule[..6]))
        .collect();
    assert_eq!(
        found,
        [
            "control/mod.rs:1 rule 1",
            "sensor/csv.rs:1 rule 1",
            "sim/mod.rs:1 rule 1",
            "rt/mod.rs:1 rule 2",
            "rt/mod.rs:2 rule 1",
            "stray/mod.rs:1 rule 1",
        ]
    );
    let text = report.to_string();
    assert!(text.contains(
        "src/rt/mod.rs:1: `crate::sensor::csv::CsvSensor` (-> src/sensor/csv.rs) breaks rule 2"
    ));
}

#[test]
fn every_module_of_the_crate_has_a_floor() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    for (rel, _) in load_sources(&src) {
        let role = role(&rel);
        assert!(
            role.is_empty() || floor(&role) != usize::MAX,
            "src/{rel}: its module `{role}` is on no floor of FLOORS"
        );
    }
}

#[test]
fn file_cycles_are_detected_but_self_loops_are_not() {
    let report = analyse(&fixture(&[
        ("lib.rs", "use crate::X;"),
        ("tools/mod.rs", ""),
        ("tools/a.rs", "use super::b::B;"),
        ("tools/b.rs", "fn f() { crate::tools::c::go() }"),
        ("tools/c.rs", "use crate::tools::a;"),
    ]));
    assert_eq!(report.cycles, [["tools/a.rs", "tools/b.rs", "tools/c.rs"]]);
    assert!(report.violations.is_empty());
    assert!(
        report
            .to_string()
            .contains("src/tools/c.rs:1 uses `crate::tools::a` (-> src/tools/a.rs)")
    );
}
