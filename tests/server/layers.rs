//! Issue 30: the server in layers. Reads the files of `src/`, builds the file-level import
//! graph from their paths into the crate, and pins two properties of it:
//!
//! - the domain modules (scene, clock, bodies, impacts, frames, journal) import nothing from
//!   `state` (`AppState`), `api`, `stream` or `wire`; the transport-free `service` nothing from
//!   `api`, `stream` or `wire`;
//! - no import circle spans more than two files (every strongly connected component of the
//!   graph has at most two).
//! - only the transports (`api`, `stream`) and `error` name `ApiError` or `ErrorCode`; every
//!   layer below returns an error of its own, mapped once in `crate::error::mapping`.
//!
//! An arrow `a.rs -> b.rs` is a path in `a.rs` that names `b.rs`'s module or an item in it:
//! `crate::…` anywhere in code, `super::…`, and `use`/`pub use` of a child module in a module
//! root (`mod.rs`, `lib.rs`). Comments are dropped, and so are `#[cfg(test)]` modules (a test
//! may reach across layers to build its fixture). Run with `--nocapture` to see the graph's
//! figures.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// A source file: its path under `src/` and its module path (`["state", "apply"]`).
struct File {
    rel: String,
    module: Vec<String>,
    code: String,
}

fn walk(dir: &Path, out: &mut Vec<PathBuf>) {
    for e in std::fs::read_dir(dir).unwrap() {
        let p = e.unwrap().path();
        if p.is_dir() {
            walk(&p, out);
        } else if p.extension().is_some_and(|x| x == "rs") {
            out.push(p);
        }
    }
}

/// `src/state/mod.rs` → `["state"]`; `src/lib.rs` → `[]`; `src/error/code.rs` →
/// `["error", "code"]`.
fn module_of(rel: &str) -> Vec<String> {
    let mut parts: Vec<String> = rel
        .trim_end_matches(".rs")
        .split('/')
        .map(str::to_owned)
        .collect();
    if matches!(
        parts.last().map(String::as_str),
        Some("mod" | "lib" | "main")
    ) {
        parts.pop();
    }
    parts
}

/// The code without comments and without `#[cfg(test)]` modules.
fn code_of(text: &str) -> String {
    let mut out = String::new();
    let mut in_block = 0usize;
    for line in text.lines() {
        let mut l = line;
        if in_block > 0 {
            match l.find("*/") {
                Some(i) => {
                    in_block -= 1;
                    l = &l[i + 2..];
                }
                None => continue,
            }
        }
        let l = match l.find("//") {
            Some(i) => &l[..i],
            None => l,
        };
        let l = match l.find("/*") {
            Some(i) if !l[i..].contains("*/") => {
                in_block += 1;
                &l[..i]
            }
            _ => l,
        };
        out.push_str(l);
        out.push('\n');
    }
    // Drop `#[cfg(test)] mod name { … }` by matching braces.
    while let Some(at) = out.find("#[cfg(test)]") {
        let rest = &out[at..];
        let header_end = rest
            .find(['{', ';'])
            .map(|i| (i, rest.as_bytes()[i] == b'{'));
        match header_end {
            Some((i, true)) if rest[..i].contains("mod ") => {
                let mut depth = 0usize;
                let mut end = rest.len();
                for (j, c) in rest[i..].char_indices() {
                    match c {
                        '{' => depth += 1,
                        '}' => {
                            depth -= 1;
                            if depth == 0 {
                                end = i + j + 1;
                                break;
                            }
                        }
                        _ => {}
                    }
                }
                out.replace_range(at..at + end, "");
            }
            // A test-only item that is not a module (`#[cfg(test)] use …;`, a function):
            // only the attribute goes.
            _ => out.replace_range(at..at + "#[cfg(test)]".len(), ""),
        }
    }
    out
}

fn is_ident(c: char) -> bool {
    c.is_ascii_alphanumeric() || c == '_'
}

/// Expands a use tree (`a::{b, c::{d, e}}`) into its paths.
fn expand(prefix: &[String], tree: &str, out: &mut Vec<Vec<String>>) {
    let tree = tree.trim();
    if tree.is_empty() {
        return;
    }
    if let Some(open) = tree.find('{') {
        let head: Vec<String> = tree[..open]
            .split("::")
            .map(str::trim)
            .filter(|s| !s.is_empty())
            .map(str::to_owned)
            .collect();
        let mut p = prefix.to_vec();
        p.extend(head);
        let inner = &tree[open + 1..tree.rfind('}').unwrap_or(tree.len())];
        let mut depth = 0;
        let mut start = 0;
        for (i, c) in inner.char_indices() {
            match c {
                '{' => depth += 1,
                '}' => depth -= 1,
                ',' if depth == 0 => {
                    expand(&p, &inner[start..i], out);
                    start = i + 1;
                }
                _ => {}
            }
        }
        expand(&p, &inner[start..], out);
    } else {
        let mut p = prefix.to_vec();
        let path = tree.split(" as ").next().unwrap_or(tree);
        p.extend(
            path.split("::")
                .map(str::trim)
                .filter(|s| !s.is_empty() && *s != "*")
                .map(str::to_owned),
        );
        out.push(p);
    }
}

/// Every path into the crate that `f` names, as module paths from the crate root.
fn paths_of(f: &File, children: &BTreeSet<String>) -> Vec<Vec<String>> {
    let code = &f.code;
    let mut raw = Vec::new();
    // `use` statements (their trees may break lines).
    let mut rest = code.as_str();
    while let Some(i) = rest.find("use ") {
        let before_ok = i == 0 || !is_ident(rest[..i].chars().last().unwrap_or(' '));
        let tail = &rest[i + 4..];
        let end = tail.find(';').unwrap_or(tail.len());
        if before_ok {
            expand(&[], &tail[..end], &mut raw);
        }
        rest = &tail[end.min(tail.len())..];
    }
    // Inline `crate::…` and `super::…` paths.
    for anchor in ["crate::", "super::"] {
        let mut from = 0;
        while let Some(i) = code[from..].find(anchor) {
            let at = from + i;
            from = at + anchor.len();
            if at > 0 && is_ident(code[..at].chars().last().unwrap_or(' ')) {
                continue;
            }
            let path: String = code[at..]
                .chars()
                .take_while(|c| is_ident(*c) || *c == ':')
                .collect();
            raw.push(
                path.split("::")
                    .filter(|s| !s.is_empty())
                    .map(str::to_owned)
                    .collect(),
            );
        }
    }
    let root = f.rel.ends_with("mod.rs") || f.rel == "lib.rs" || f.rel == "main.rs";
    // The module `super` names: the parent of this file's module.
    let parent: Vec<String> = f.module[..f.module.len().saturating_sub(1)].to_vec();
    raw.into_iter()
        .filter_map(|p| {
            let first = p.first()?.as_str();
            let mut abs = match first {
                "crate" => Vec::new(),
                "super" => parent.clone(),
                "self" => f.module.clone(),
                c if root && children.contains(c) => {
                    let mut m = f.module.clone();
                    m.push(c.to_owned());
                    return Some(
                        m.into_iter()
                            .chain(p.into_iter().skip(1))
                            .collect::<Vec<_>>(),
                    );
                }
                _ => return None,
            };
            let mut it = p.into_iter().skip(1).peekable();
            while it.peek().is_some_and(|s| s == "super") {
                it.next();
                abs.pop();
            }
            abs.extend(it);
            Some(abs)
        })
        .collect()
}

/// The file-level import graph of `src/`: file → files it imports.
/// Every file under `src/`, its path relative to it and its code without comments.
fn sources() -> Vec<File> {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut paths = Vec::new();
    walk(&src, &mut paths);
    paths
        .iter()
        .map(|p| {
            let rel = p
                .strip_prefix(&src)
                .unwrap()
                .to_string_lossy()
                .replace('\\', "/");
            File {
                module: module_of(&rel),
                code: code_of(&std::fs::read_to_string(p).unwrap()),
                rel,
            }
        })
        .collect()
}

fn graph() -> BTreeMap<String, BTreeSet<String>> {
    let files: Vec<File> = sources()
        .into_iter()
        .filter(|f| f.rel != "main.rs") // the binary, a crate of its own
        .collect();
    let by_module: BTreeMap<Vec<String>, String> = files
        .iter()
        .map(|f| (f.module.clone(), f.rel.clone()))
        .collect();
    let mut g = BTreeMap::new();
    for f in &files {
        let children: BTreeSet<String> = by_module
            .keys()
            .filter(|m| m.len() == f.module.len() + 1 && m.starts_with(&f.module))
            .map(|m| m[m.len() - 1].clone())
            .collect();
        let mut to = BTreeSet::new();
        for p in paths_of(f, &children) {
            // The longest module prefix of the path is the file it names.
            let target = (1..=p.len())
                .rev()
                .find_map(|n| by_module.get(&p[..n]))
                .or_else(|| by_module.get(&Vec::new()).filter(|_| p.is_empty()));
            if let Some(t) = target
                && *t != f.rel
            {
                to.insert(t.clone());
            }
        }
        g.insert(f.rel.clone(), to);
    }
    g
}

/// Strongly connected components (Tarjan), each sorted.
fn components(g: &BTreeMap<String, BTreeSet<String>>) -> Vec<Vec<String>> {
    struct T<'a> {
        g: &'a BTreeMap<String, BTreeSet<String>>,
        index: BTreeMap<&'a str, usize>,
        low: BTreeMap<&'a str, usize>,
        stack: Vec<&'a str>,
        on: BTreeSet<&'a str>,
        out: Vec<Vec<String>>,
    }
    fn visit<'a>(t: &mut T<'a>, v: &'a str) {
        let i = t.index.len();
        t.index.insert(v, i);
        t.low.insert(v, i);
        t.stack.push(v);
        t.on.insert(v);
        for w in &t.g[v] {
            let w = w.as_str();
            if !t.index.contains_key(w) {
                visit(t, w);
                let l = t.low[v].min(t.low[w]);
                t.low.insert(v, l);
            } else if t.on.contains(w) {
                let l = t.low[v].min(t.index[w]);
                t.low.insert(v, l);
            }
        }
        if t.low[v] == t.index[v] {
            let mut c = Vec::new();
            while let Some(w) = t.stack.pop() {
                t.on.remove(w);
                c.push(w.to_owned());
                if w == v {
                    break;
                }
            }
            c.sort();
            t.out.push(c);
        }
    }
    let mut t = T {
        g,
        index: BTreeMap::new(),
        low: BTreeMap::new(),
        stack: Vec::new(),
        on: BTreeSet::new(),
        out: Vec::new(),
    };
    for v in g.keys() {
        if !t.index.contains_key(v.as_str()) {
            visit(&mut t, v);
        }
    }
    t.out
}

/// One circle through every file of a component (for the failure message): a path from its
/// first file back to itself that visits each file of the component it can.
fn circle(g: &BTreeMap<String, BTreeSet<String>>, comp: &[String]) -> Vec<String> {
    let inside: BTreeSet<&str> = comp.iter().map(String::as_str).collect();
    let start = comp[0].as_str();
    // Breadth-first from each successor of `start` back to it, inside the component.
    let mut best: Vec<String> = Vec::new();
    for first in g[start].iter().filter(|w| inside.contains(w.as_str())) {
        let mut prev: BTreeMap<&str, &str> = BTreeMap::new();
        let mut queue = std::collections::VecDeque::from([first.as_str()]);
        let mut seen = BTreeSet::from([first.as_str()]);
        while let Some(v) = queue.pop_front() {
            if v == start {
                break;
            }
            for w in &g[v] {
                let w = w.as_str();
                if inside.contains(w) && seen.insert(w) {
                    prev.insert(w, v);
                    queue.push_back(w);
                }
            }
        }
        let mut path = vec![start.to_owned()];
        let mut v = start;
        while let Some(p) = prev.get(v) {
            path.push((*p).to_owned());
            v = p;
        }
        path.push(start.to_owned());
        path.reverse();
        if path.len() > best.len() {
            best = path;
        }
    }
    best
}

#[test]
fn no_import_circle_spans_more_than_two_files() {
    let g = graph();
    assert!(g.len() > 40, "found only {} files", g.len());
    let arrows: usize = g.values().map(BTreeSet::len).sum();
    let comps = components(&g);
    let mut sizes: Vec<usize> = comps.iter().map(Vec::len).filter(|n| *n > 1).collect();
    sizes.sort_unstable_by(|a, b| b.cmp(a));
    println!(
        "{} files, {arrows} import arrows; circles (files each): {sizes:?}",
        g.len()
    );
    let big: Vec<String> = comps
        .iter()
        .filter(|c| c.len() > 2)
        .map(|c| {
            format!(
                "{} files {:?}; a circle among them: {}",
                c.len(),
                c,
                circle(&g, c).join(" -> ")
            )
        })
        .collect();
    assert!(
        big.is_empty(),
        "import circles over two files:\n{}",
        big.join("\n")
    );
}

/// Whether `file` (a path under `src/`) is in module `m` (`"scene"`: `scene.rs`, `scene/…`).
fn in_module(file: &str, m: &str) -> bool {
    file == format!("{m}.rs") || file.starts_with(&format!("{m}/"))
}

#[test]
fn the_layers_point_down() {
    let g = graph();
    let rules: &[(&[&str], &[&str])] = &[
        // Domain: plain types and functions.
        (
            &["scene", "bodies", "impacts", "frames", "journal"],
            &["state", "api", "stream", "wire"],
        ),
        // The transport-free service.
        (&["service"], &["api", "stream", "wire"]),
        // The registry and its store.
        (&["state"], &["api", "wire"]),
    ];
    let mut offenders = Vec::new();
    for (from, to) in g {
        for (layer, forbidden) in rules {
            if !layer.iter().any(|m| in_module(&from, m)) {
                continue;
            }
            for t in &to {
                if forbidden.iter().any(|m| in_module(t, m)) {
                    offenders.push(format!("{from} -> {t}"));
                }
            }
        }
    }
    assert!(
        offenders.is_empty(),
        "imports that point up a layer:\n{offenders:#?}"
    );
}

#[test]
fn only_the_top_layer_names_app_state() {
    let files = sources();
    let mut naming: Vec<String> = files
        .iter()
        .filter(|f| f.code.contains("AppState"))
        .map(|f| f.rel.clone())
        .collect();
    naming.sort();
    println!(
        "{} of {} files name AppState: {naming:?}",
        naming.len(),
        files.len()
    );
    let allowed = ["state", "api", "stream", "service", "store"];
    let wrong: Vec<&String> = naming
        .iter()
        .filter(|f| *f != "lib.rs" && !allowed.iter().any(|m| in_module(f, m)))
        .collect();
    assert!(wrong.is_empty(), "AppState below the top layers: {wrong:?}");
}

/// Issue 30: the domain returns domain errors and the API maps them. Before, the domain modules
/// built `ApiError`s themselves (`ErrorCode::SceneFull` in the body driver, `invalid_spec` in
/// `Scene::build`), so a scene or a body world knew HTTP statuses. Now they return `SceneError`,
/// `BodyError`, … and `crate::error` maps each to an `ApiError` once; this fails if a domain
/// module names `ApiError` or `ErrorCode` again (comments and `#[cfg(test)]` modules aside: a
/// test may check what a client would see).
#[test]
fn the_domain_names_no_api_error() {
    let domain = ["scene", "bodies", "impacts", "frames", "journal"];
    let mut checked = 0;
    let mut naming = Vec::new();
    for f in sources() {
        if !domain.iter().any(|m| in_module(&f.rel, m)) {
            continue;
        }
        checked += 1;
        for name in ["ApiError", "ErrorCode"] {
            if f.code.contains(name) {
                naming.push(format!("{} names {name}", f.rel));
            }
        }
    }
    assert!(checked > 10, "found only {checked} domain files");
    naming.sort();
    assert!(
        naming.is_empty(),
        "domain modules that speak HTTP (return a domain error; map it in crate::error):\n{naming:#?}"
    );
}

/// Issue 30: `ApiError` (a code with its HTTP status) is built only where a request is answered.
/// Before, the query service, the registry, the stores, the byte budget, the protobuf decoder
/// and the config's time check all built `ApiError`s (15 files outside `api/`), so a layer below
/// the transports chose HTTP statuses. Now each returns its own error (`QueryError`,
/// `StateError`, `ReserveRefused`, `ConvertError`, `TimeOutOfRange`, …) and `crate::error`
/// maps each once. This fails if any other file names `ApiError` or `ErrorCode` again
/// (comments and `#[cfg(test)]` modules aside: a test may check what a client would see).
///
/// Allowed: `api/` and `stream/` (the transports: they answer HTTP requests and WebSocket
/// messages, and `stream/` writes `error` frames with the same code, message and field as HTTP,
/// plus the WebSocket-only codes `unknown_type` and `wrong_frame_type`, and refuses upgrades
/// with HTTP answers), `error.rs` and `error/` (the type, its codes and the mapping), and
/// `lib.rs` (which re-exports it).
#[test]
fn only_the_transports_name_api_error() {
    let allowed = ["api", "stream", "error"];
    let mut naming = Vec::new();
    let files = sources();
    for f in &files {
        if f.rel == "lib.rs" || allowed.iter().any(|m| in_module(&f.rel, m)) {
            continue;
        }
        for name in ["ApiError", "ErrorCode"] {
            if f.code.contains(name) {
                naming.push(format!("{} names {name}", f.rel));
            }
        }
    }
    assert!(files.len() > 40, "found only {} files", files.len());
    naming.sort();
    assert!(
        naming.is_empty(),
        "layers below the transports that speak HTTP (return an error of the layer's own; map \
         it in crate::error::mapping):\n{naming:#?}"
    );
}
