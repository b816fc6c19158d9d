//! `cargo xtask modules [CRATE]`: the import graph among a crate's modules, read from its
//! `crate::…` paths (test modules left out), and any circle in it.
//!
//! Each file is a node (`scene/assembly.rs` is `scene::assembly`); a `crate::a::b::Item` path is
//! an edge to the longest module path it names, a `crate::Item` re-exported at the root an edge to
//! `lib` (which imports everything, so using a root re-export inside the crate shows as a circle),
//! and a folder's `mod.rs` an edge to each child whose items it uses (`pub use child::X`). Folders are then summed into
//! their top-level modules, the layers `lib.rs` lists. The graph must have no circle at either
//! level: `cargo test -p xtask` checks `crates/integrator`.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

use anyhow::Context;

/// Arguments of `cargo xtask modules`.
#[derive(Debug, clap::Args)]
pub(crate) struct ModulesArgs {
    /// The crate's folder.
    #[arg(default_value = "crates/integrator")]
    krate: PathBuf,
}

/// File-level edges (module path → module paths it imports).
pub(crate) type Graph = BTreeMap<String, BTreeSet<String>>;

pub(crate) fn run(args: &ModulesArgs) -> anyhow::Result<()> {
    let dir = if args.krate.is_absolute() { args.krate.clone() } else { crate::project_root().join(&args.krate) };
    let files = read_graph(&dir.join("src"))?;
    let top = top_level(&files);
    println!("modules of {} (each line: a module and what it imports)", args.krate.display());
    for (m, to) in &top {
        let to: Vec<&str> = to.iter().map(String::as_str).collect();
        println!("  {m:<14} -> {}", if to.is_empty() { "-".to_owned() } else { to.join(", ") });
    }
    let file_circles = circles(&files);
    let top_circles = circles(&top);
    let edges: usize = files.values().map(BTreeSet::len).sum();
    println!(
        "{} files, {edges} edges between them; circles: {} among files, {} among modules",
        files.len(),
        file_circles.len(),
        top_circles.len()
    );
    for c in file_circles.iter().chain(&top_circles) {
        println!("  circle: {}", c.join(" <-> "));
    }
    anyhow::ensure!(file_circles.is_empty() && top_circles.is_empty(), "the module graph has a circle");
    Ok(())
}

/// The file-level graph of the crate whose sources are in `src`.
pub(crate) fn read_graph(src: &Path) -> anyhow::Result<Graph> {
    let mut sources = Vec::new();
    collect(src, src, &mut sources)?;
    let modules: BTreeSet<String> = sources.iter().map(|(m, _)| m.clone()).collect();
    let mut graph = Graph::new();
    for (module, path) in &sources {
        let text = std::fs::read_to_string(path).with_context(|| path.display().to_string())?;
        let lines: Vec<&str> = code_lines(&text).collect();
        let mut to = BTreeSet::new();
        for line in &lines {
            for target in crate_paths(line) {
                let resolved = resolve(&target, &modules);
                if resolved != *module {
                    to.insert(resolved);
                }
            }
        }
        // A folder's module depends on the children whose items it uses (`use child::X`,
        // `pub use child::X`, `child::f()`); declaring one (`mod child;`) is no use of it.
        let children = modules
            .iter()
            .filter(|m| parent(m) == Some(module.as_str()) || (module == "lib" && !m.contains("::") && *m != "lib"));
        for child in children {
            let name = child.rsplit("::").next().unwrap_or(child);
            if lines.iter().any(|line| uses_relative(line, name)) {
                to.insert(child.clone());
            }
        }
        graph.insert(module.clone(), to);
    }
    Ok(graph)
}

/// The module a module path is declared in (`None` for a top-level one).
fn parent(module: &str) -> Option<&str> {
    module.rsplit_once("::").map(|(p, _)| p)
}

/// Whether `line` names `name::…` as a relative path (not `crate::name::` or `x::name::`).
fn uses_relative(line: &str, name: &str) -> bool {
    let pattern = format!("{name}::");
    line.match_indices(&pattern).any(|(at, _)| {
        let before = line[..at].chars().next_back();
        !before.is_some_and(|c| c.is_alphanumeric() || c == '_' || c == ':')
    })
}

/// Every `.rs` file under `dir` as (module path, file); test-only files left out.
fn collect(root: &Path, dir: &Path, out: &mut Vec<(String, PathBuf)>) -> anyhow::Result<()> {
    for entry in std::fs::read_dir(dir).with_context(|| dir.display().to_string())? {
        let path = entry?.path();
        if path.is_dir() {
            collect(root, &path, out)?;
            continue;
        }
        let name = path.file_name().and_then(|n| n.to_str()).unwrap_or_default();
        if !name.ends_with(".rs") || name == "tests.rs" || name.ends_with("_tests.rs") {
            continue;
        }
        let rel = path.strip_prefix(root)?.with_extension("");
        let mut parts: Vec<String> = rel.iter().map(|p| p.to_string_lossy().into_owned()).collect();
        if parts.last().is_some_and(|p| p == "mod") {
            parts.pop();
        }
        out.push((parts.join("::"), path));
    }
    Ok(())
}

/// The file's lines of code before its test module, without comments.
fn code_lines(text: &str) -> impl Iterator<Item = &str> {
    let mut lines = text.lines().peekable();
    let mut out = Vec::new();
    while let Some(line) = lines.next() {
        let test_module = |next: &&str| next.trim_start().starts_with("mod ") && next.contains('{');
        if line.trim() == "#[cfg(test)]" && lines.peek().is_some_and(test_module) {
            break;
        }
        let code = line.split("//").next().unwrap_or_default();
        if !code.trim().is_empty() {
            out.push(code);
        }
    }
    out.into_iter()
}

/// The `crate::…` paths of one line, with one level of `crate::{a::X, b}` groups expanded.
fn crate_paths(line: &str) -> Vec<Vec<String>> {
    let mut out = Vec::new();
    let mut rest = line;
    while let Some(at) = rest.find("crate::") {
        let before = rest[..at].chars().next_back();
        rest = &rest[at + "crate::".len()..];
        if before.is_some_and(|c| c.is_alphanumeric() || c == '_') {
            continue; // e.g. `mycrate::`
        }
        if let Some(group) = rest.strip_prefix('{') {
            let inner = group.split('}').next().unwrap_or_default();
            out.extend(inner.split(',').map(|p| segments(p.trim())));
        } else {
            out.push(segments(rest));
        }
    }
    out
}

fn segments(path: &str) -> Vec<String> {
    let end = path.find(|c: char| !(c.is_alphanumeric() || c == '_' || c == ':')).unwrap_or(path.len());
    path[..end].split("::").filter(|s| !s.is_empty()).map(str::to_owned).collect()
}

/// The longest module path `target` names; a path naming no module refers to the root (`lib`).
fn resolve(target: &[String], modules: &BTreeSet<String>) -> String {
    (1..=target.len())
        .rev()
        .map(|n| target[..n].join("::"))
        .find(|m| modules.contains(m))
        .unwrap_or_else(|| "lib".to_owned())
}

/// The graph with every file summed into its top-level module (`scene::assembly` → `scene`).
pub(crate) fn top_level(files: &Graph) -> Graph {
    let top = |m: &str| m.split("::").next().unwrap_or(m).to_owned();
    let mut graph = Graph::new();
    for (from, to) in files {
        let entry = graph.entry(top(from)).or_default();
        entry.extend(to.iter().map(|t| top(t)).filter(|t| *t != top(from)));
    }
    graph
}

/// The graph's circles: its strongly connected components of more than one node (Tarjan).
pub(crate) fn circles(graph: &Graph) -> Vec<Vec<String>> {
    struct State<'a> {
        graph: &'a Graph,
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
        for w in s.graph.get(v).into_iter().flatten() {
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
                component.push(w.to_owned());
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
        graph,
        index: BTreeMap::new(),
        low: BTreeMap::new(),
        stack: Vec::new(),
        on_stack: BTreeSet::new(),
        out: Vec::new(),
    };
    for v in graph.keys() {
        if !s.index.contains_key(v.as_str()) {
            visit(&mut s, v);
        }
    }
    s.out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_integrator_crate_has_no_import_circle() {
        let files = read_graph(&crate::project_root().join("crates/integrator/src")).unwrap();
        assert!(files.len() > 20, "read {} files", files.len());
        assert!(files["render"].contains("integrators"), "{:?}", files["render"]);
        assert_eq!(circles(&files), Vec::<Vec<String>>::new());
        assert_eq!(circles(&top_level(&files)), Vec::<Vec<String>>::new());
    }

    #[test]
    fn circles_and_root_reexports_are_found() {
        let modules: BTreeSet<String> = ["lib", "a", "b", "b::c"].map(str::to_owned).into();
        assert_eq!(resolve(&segments("b::c::Item"), &modules), "b::c");
        assert_eq!(resolve(&segments("RenderScene"), &modules), "lib");
        assert_eq!(crate_paths("use crate::{a::X, b::c::Y};").len(), 2);
        assert!(crate_paths("use mycrate::a::X;").is_empty());
        let edge = |a: &str, b: &str| (a.to_owned(), BTreeSet::from([b.to_owned()]));
        let graph: Graph = [edge("a", "b::c"), edge("b::c", "b"), edge("b", "a")].into();
        assert_eq!(circles(&graph), vec![vec!["a".to_owned(), "b".to_owned(), "b::c".to_owned()]]);
        assert_eq!(circles(&top_level(&graph)), vec![vec!["a".to_owned(), "b".to_owned()]]);
        let acyclic: Graph = [edge("a", "b"), edge("b", "b::c")].into();
        assert!(circles(&acyclic).is_empty());
    }
}
