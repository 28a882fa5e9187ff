//! The import graph has no cycle (issue 22, item 3: "no module imports one that
//! imports it back").
//!
//! The test reads every source file of the library and of the binary (the
//! module tree from `src/lib.rs` and `src/main.rs`, following `mod name;`),
//! with comments and string literals removed, and collects every path that
//! names an item of the same crate: `use` trees (`crate::`, `super::`,
//! `self::` and a file's own child modules, braces expanded) and paths in the
//! code (`crate::a::b`, `super::x`, `child::f`). Each path goes to the file
//! that holds it: the longest prefix that is a file module, followed through
//! that module's `pub use` re-exports (`crate::Error` is `crate::error`).
//!
//! Two graphs must be acyclic: the top-level modules (`scene`, `accel`,
//! `integrator`, ...), where every path counts, and the files, where a folder
//! is one room: its `mod.rs` may use and re-export the files inside it (the
//! trait in `bsdf/mod.rs` and its models in `bsdf/*.rs`), while a file using
//! its parent, a sibling or anything outside is an edge. A cycle is printed
//! with every import inside it, each with the line that makes it.

use std::collections::{BTreeMap, BTreeSet, VecDeque};
use std::fs;
use std::path::{Path, PathBuf};

/// A token of Rust source, reduced to what paths are made of.
#[derive(Debug, Clone, PartialEq)]
enum Tok {
    Ident(String),
    PathSep,
    Open,
    Close,
    Comma,
    Semi,
    Star,
    Dollar,
    Other,
}

/// Source tokens with the line of each.
fn tokenize(src: &str) -> Vec<(Tok, usize)> {
    let c: Vec<char> = src.chars().collect();
    let mut out = Vec::new();
    let (mut i, mut line) = (0, 1);
    let at = |i: usize| c.get(i).copied().unwrap_or('\0');
    while i < c.len() {
        let ch = c[i];
        if ch == '\n' {
            line += 1;
            i += 1;
        } else if ch.is_whitespace() {
            i += 1;
        } else if ch == '/' && at(i + 1) == '/' {
            while i < c.len() && c[i] != '\n' {
                i += 1;
            }
        } else if ch == '/' && at(i + 1) == '*' {
            let mut depth = 0;
            loop {
                if i >= c.len() {
                    break;
                }
                if c[i] == '/' && at(i + 1) == '*' {
                    depth += 1;
                    i += 2;
                } else if c[i] == '*' && at(i + 1) == '/' {
                    depth -= 1;
                    i += 2;
                    if depth == 0 {
                        break;
                    }
                } else {
                    line += usize::from(c[i] == '\n');
                    i += 1;
                }
            }
        } else if ch == '"'
            || ((ch == 'r' || ch == 'b') && (at(i + 1) == '"' || at(i + 1) == '#'))
            || (ch == 'b' && at(i + 1) == 'r' && (at(i + 2) == '"' || at(i + 2) == '#'))
        {
            // A string literal, raw or not; `r#ident` falls through as an identifier.
            let mut j = i;
            let raw = ch == 'r' || at(i + 1) == 'r';
            while c[j] != '"' && c[j] != '#' {
                j += 1;
            }
            let mut hashes = 0;
            while at(j) == '#' {
                hashes += 1;
                j += 1;
            }
            if at(j) != '"' {
                // `r#ident`: skip the prefix, read the identifier next round.
                i = j;
                continue;
            }
            j += 1;
            loop {
                if j >= c.len() {
                    break;
                }
                if !raw && c[j] == '\\' {
                    line += usize::from(at(j + 1) == '\n');
                    j += 2;
                    continue;
                }
                if c[j] == '"' && (0..hashes).all(|k| at(j + 1 + k) == '#') {
                    j += 1 + hashes;
                    break;
                }
                line += usize::from(c[j] == '\n');
                j += 1;
            }
            i = j;
            out.push((Tok::Other, line));
        } else if ch == '\'' {
            // A char literal ('x', '\n', '\u{..}') or a lifetime ('a).
            if at(i + 1) == '\\' {
                i += 2;
                while i < c.len() && c[i] != '\'' {
                    i += 1;
                }
                i += 1;
                out.push((Tok::Other, line));
            } else if at(i + 2) == '\'' {
                i += 3;
                out.push((Tok::Other, line));
            } else {
                i += 1;
            }
        } else if ch.is_alphabetic() || ch == '_' {
            let start = i;
            while i < c.len() && (c[i].is_alphanumeric() || c[i] == '_') {
                i += 1;
            }
            out.push((Tok::Ident(c[start..i].iter().collect()), line));
        } else if ch.is_ascii_digit() {
            while i < c.len() && (c[i].is_alphanumeric() || c[i] == '_' || c[i] == '.') {
                // `1.0`, `0x1f`, `1e-3` read as one token; `1..n` stops at the second dot.
                if c[i] == '.' && at(i + 1) == '.' {
                    break;
                }
                i += 1;
            }
            out.push((Tok::Other, line));
        } else {
            let tok = match ch {
                ':' if at(i + 1) == ':' => {
                    i += 1;
                    Tok::PathSep
                }
                '{' => Tok::Open,
                '}' => Tok::Close,
                ',' => Tok::Comma,
                ';' => Tok::Semi,
                '*' => Tok::Star,
                '$' => Tok::Dollar,
                _ => Tok::Other,
            };
            i += 1;
            out.push((tok, line));
        }
    }
    out
}

/// A source file in the module tree.
struct File {
    /// The module it holds: `["scene", "obj"]`; empty for a crate root.
    module: Vec<String>,
    path: PathBuf,
    tokens: Vec<(Tok, usize)>,
    /// Child modules declared with `mod name;`.
    children: Vec<String>,
}

/// One path a file names, before resolution.
struct Mention {
    /// Segments as written, `crate`/`super`/`self` included.
    segments: Vec<String>,
    /// The module the path is written in (inline modules included).
    scope: Vec<String>,
    line: usize,
    /// Part of a `pub use` (a re-export).
    reexport: bool,
    /// The name a `pub use` gives it (its alias or last segment).
    name: Option<String>,
}

fn ident(toks: &[(Tok, usize)], i: usize) -> Option<&str> {
    match toks.get(i) {
        Some((Tok::Ident(s), _)) => Some(s),
        _ => None,
    }
}

/// Expands the use tree at `toks[*i]` (after `use`) into full paths with
/// the name each binds.
fn use_tree(
    toks: &[(Tok, usize)],
    i: &mut usize,
    prefix: &[String],
    out: &mut Vec<(Vec<String>, String)>,
) {
    let mut path = prefix.to_vec();
    loop {
        match toks.get(*i).map(|t| &t.0) {
            Some(Tok::Ident(s)) => {
                path.push(s.clone());
                *i += 1;
            }
            Some(Tok::PathSep) => *i += 1,
            Some(Tok::Star) => {
                *i += 1;
                out.push((path, "*".into()));
                return;
            }
            Some(Tok::Open) => {
                *i += 1;
                loop {
                    match toks.get(*i).map(|t| &t.0) {
                        Some(Tok::Close) => {
                            *i += 1;
                            return;
                        }
                        Some(Tok::Comma) => *i += 1,
                        None => return,
                        _ => use_tree(toks, i, &path, out),
                    }
                }
            }
            _ => break,
        }
    }
    // `a::b as c` was read as [.., b, as, c].
    let mut name = path.last().cloned().unwrap_or_default();
    if path.len() >= 2 && path[path.len() - 2] == "as" {
        name = path.pop().unwrap();
        path.pop();
    }
    if path.last().map(String::as_str) == Some("self") {
        path.pop();
        if name == "self" {
            name = path.last().cloned().unwrap_or_default();
        }
    }
    out.push((path, name));
}

/// Every path in `file` that may name an item of its own crate.
fn mentions(file: &File) -> Vec<Mention> {
    let toks = &file.tokens;
    let mut out = Vec::new();
    // Inline modules open at brace depths.
    let mut inline: Vec<(String, usize)> = Vec::new();
    let mut depth = 0;
    let mut i = 0;
    let scope = |inline: &[(String, usize)]| {
        let mut s = file.module.clone();
        s.extend(inline.iter().map(|(n, _)| n.clone()));
        s
    };
    while i < toks.len() {
        let (tok, line) = (&toks[i].0, toks[i].1);
        match tok {
            Tok::Open => depth += 1,
            Tok::Close => {
                depth -= 1;
                while inline.last().is_some_and(|(_, d)| *d > depth) {
                    inline.pop();
                }
            }
            Tok::Ident(s) if s == "mod" => {
                if let (Some(name), Some((Tok::Open, _))) = (ident(toks, i + 1), toks.get(i + 2)) {
                    inline.push((name.to_string(), depth + 1));
                }
            }
            Tok::Ident(s) if s == "use" => {
                // `pub use`, `pub(crate) use`, `pub(super) use`.
                let reexport = (i >= 1 && ident(toks, i - 1) == Some("pub"))
                    || (i >= 4 && ident(toks, i - 4) == Some("pub") && toks[i - 3].0 == Tok::Other);
                let mut j = i + 1;
                let mut paths = Vec::new();
                use_tree(toks, &mut j, &[], &mut paths);
                for (segments, name) in paths {
                    out.push(Mention {
                        segments,
                        scope: scope(&inline),
                        line,
                        reexport,
                        name: reexport.then_some(name),
                    });
                }
                i = j;
                continue;
            }
            Tok::Ident(s) => {
                let after_sep = i >= 1 && matches!(toks[i - 1].0, Tok::PathSep | Tok::Dollar);
                let starts_path = matches!(s.as_str(), "crate" | "super" | "self")
                    || (inline.is_empty() && file.children.contains(s));
                if !after_sep && starts_path && matches!(toks.get(i + 1), Some((Tok::PathSep, _))) {
                    let mut segments = vec![s.clone()];
                    let mut j = i + 1;
                    while let (Some((Tok::PathSep, _)), Some(next)) =
                        (toks.get(j), ident(toks, j + 1))
                    {
                        segments.push(next.to_string());
                        j += 2;
                    }
                    out.push(Mention {
                        segments,
                        scope: scope(&inline),
                        line,
                        reexport: false,
                        name: None,
                    });
                    i = j;
                    continue;
                }
            }
            _ => {}
        }
        i += 1;
    }
    out
}

/// The module tree of the crate rooted at `root` (`src/lib.rs`, `src/main.rs`).
fn module_tree(root: &Path) -> Vec<File> {
    let mut files = Vec::new();
    let mut queue = VecDeque::from([(Vec::<String>::new(), root.to_path_buf())]);
    while let Some((module, path)) = queue.pop_front() {
        let text = fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        let tokens = tokenize(&text);
        let mut children = Vec::new();
        let mut depth = 0;
        for k in 0..tokens.len() {
            match tokens[k].0 {
                Tok::Open => depth += 1,
                Tok::Close => depth -= 1,
                _ => {}
            }
            if depth == 0
                && ident(&tokens, k) == Some("mod")
                && let (Some(name), Some((Tok::Semi, _))) =
                    (ident(&tokens, k + 1), tokens.get(k + 2))
            {
                children.push(name.to_string());
            }
        }
        // Children of `a/mod.rs`, `lib.rs`, `main.rs` sit in `a/`; of `a.rs` in `a/`.
        let stem = path.file_stem().unwrap().to_str().unwrap();
        let dir = if matches!(stem, "mod" | "lib" | "main") {
            path.parent().unwrap().to_path_buf()
        } else {
            path.parent().unwrap().join(stem)
        };
        for child in &children {
            let flat = dir.join(format!("{child}.rs"));
            let folder = dir.join(child).join("mod.rs");
            let file = if flat.exists() { flat } else { folder };
            let mut m = module.clone();
            m.push(child.clone());
            queue.push_back((m, file));
        }
        files.push(File {
            module,
            path,
            tokens,
            children,
        });
    }
    files
}

/// An edge of the import graph with the place that makes it.
type Edges = BTreeMap<String, BTreeMap<String, String>>;

/// The file-level import graph of one crate: module path (`scene::obj`, `crate`
/// for the root) to module path, each edge with its first witness.
fn import_graph(root: &Path) -> Edges {
    let files = module_tree(root);
    let src = root.parent().unwrap();
    let modules: BTreeSet<Vec<String>> = files.iter().map(|f| f.module.clone()).collect();
    let all: Vec<(usize, Mention)> = files
        .iter()
        .enumerate()
        .flat_map(|(k, f)| mentions(f).into_iter().map(move |m| (k, m)))
        .collect();

    // Absolute form of a mention, or None for another crate's path.
    let absolute = |m: &Mention, file: &File| -> Option<Vec<String>> {
        let mut segs = m.segments.iter().peekable();
        let mut base = match segs.peek().map(|s| s.as_str()) {
            Some("crate") => {
                segs.next();
                Vec::new()
            }
            Some("self") => {
                segs.next();
                m.scope.clone()
            }
            Some("super") => m.scope.clone(),
            Some(s) if m.scope == file.module && file.children.iter().any(|c| c == s) => {
                m.scope.clone()
            }
            _ => return None,
        };
        while segs.peek().map(|s| s.as_str()) == Some("super") {
            segs.next();
            base.pop()?;
        }
        base.extend(segs.cloned());
        Some(base)
    };

    // Re-exports: (module, name) -> absolute path.
    let mut reexports: BTreeMap<(Vec<String>, String), Vec<String>> = BTreeMap::new();
    for (k, m) in &all {
        if let (true, Some(name)) = (m.reexport, &m.name)
            && name != "*"
            && m.scope == files[*k].module
            && let Some(abs) = absolute(m, &files[*k])
        {
            reexports.insert((files[*k].module.clone(), name.clone()), abs);
        }
    }

    // The file module that holds the item an absolute path names.
    let resolve = |path: &[String]| -> Vec<String> {
        let mut path = path.to_vec();
        for _ in 0..16 {
            let n = (0..=path.len())
                .rev()
                .find(|&n| modules.contains(&path[..n]))
                .unwrap_or(0);
            let module = path[..n].to_vec();
            match path
                .get(n)
                .and_then(|name| reexports.get(&(module.clone(), name.clone())))
            {
                Some(target) if target != &path[..=n] => {
                    let mut next = target.clone();
                    next.extend(path[n + 1..].iter().cloned());
                    path = next;
                }
                _ => return module,
            }
        }
        panic!("re-export loop at {}", path.join("::"))
    };

    let name = |m: &[String]| {
        if m.is_empty() {
            "crate".to_string()
        } else {
            m.join("::")
        }
    };
    let mut edges = Edges::new();
    for f in &files {
        edges.entry(name(&f.module)).or_default();
    }
    for (k, m) in &all {
        let file = &files[*k];
        let Some(abs) = absolute(m, file) else {
            continue;
        };
        let target = resolve(&abs);
        // A folder is one room: its `mod.rs` may use (and re-export) the files in it.
        if target.starts_with(&file.module) {
            continue;
        }
        let witness = format!(
            "{}:{} `{}`",
            file.path
                .strip_prefix(src.parent().unwrap())
                .unwrap_or(&file.path)
                .display(),
            m.line,
            m.segments.join("::")
        );
        edges
            .entry(name(&file.module))
            .or_default()
            .entry(name(&target))
            .or_insert(witness);
    }
    edges
}

/// The graph with each module replaced by its top-level module (`scene::obj`
/// becomes `scene`); the crate root is left out.
fn top_level(edges: &Edges) -> Edges {
    let top = |m: &str| m.split("::").next().unwrap().to_string();
    let mut out = Edges::new();
    for (from, tos) in edges {
        if from == "crate" {
            continue;
        }
        out.entry(top(from)).or_default();
        for (to, witness) in tos {
            if to != "crate" && top(to) != top(from) {
                out.entry(top(from))
                    .or_default()
                    .entry(top(to))
                    .or_insert_with(|| witness.clone());
            }
        }
    }
    out
}

/// Strongly connected components with more than one node (Tarjan).
fn cycles(edges: &Edges) -> Vec<Vec<String>> {
    struct State<'a> {
        edges: &'a Edges,
        index: BTreeMap<&'a str, usize>,
        low: BTreeMap<&'a str, usize>,
        stack: Vec<&'a str>,
        on_stack: BTreeSet<&'a str>,
        out: Vec<Vec<String>>,
    }
    fn visit<'a>(s: &mut State<'a>, v: &'a str) {
        let n = s.index.len();
        s.index.insert(v, n);
        s.low.insert(v, n);
        s.stack.push(v);
        s.on_stack.insert(v);
        for w in s.edges.get(v).into_iter().flat_map(|t| t.keys()) {
            let w = w.as_str();
            if !s.index.contains_key(w) {
                visit(s, w);
                let lw = s.low[w];
                let lv = s.low.get_mut(v).unwrap();
                *lv = (*lv).min(lw);
            } else if s.on_stack.contains(w) {
                let iw = s.index[w];
                let lv = s.low.get_mut(v).unwrap();
                *lv = (*lv).min(iw);
            }
        }
        if s.low[v] == s.index[v] {
            let mut comp = Vec::new();
            loop {
                let w = s.stack.pop().unwrap();
                s.on_stack.remove(w);
                comp.push(w.to_string());
                if w == v {
                    break;
                }
            }
            if comp.len() > 1 {
                comp.sort();
                s.out.push(comp);
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

/// A shortest cycle through `start` inside `component`, as its edges.
fn shortest_cycle(edges: &Edges, component: &[String], start: &str) -> Vec<(String, String)> {
    let inside: BTreeSet<&str> = component.iter().map(String::as_str).collect();
    let mut parent: BTreeMap<&str, &str> = BTreeMap::new();
    let mut queue = VecDeque::from([start]);
    while let Some(v) = queue.pop_front() {
        for w in edges[v]
            .keys()
            .map(String::as_str)
            .filter(|w| inside.contains(w))
        {
            if w == start {
                let mut path = vec![(v.to_string(), w.to_string())];
                let mut x = v;
                while x != start {
                    let p = parent[x];
                    path.push((p.to_string(), x.to_string()));
                    x = p;
                }
                path.reverse();
                return path;
            }
            if !parent.contains_key(w) {
                parent.insert(w, v);
                queue.push_back(w);
            }
        }
    }
    unreachable!("{start} is in a strongly connected component")
}

/// Every cycle of `edges`, written out; empty when there is none.
fn report(what: &str, edges: &Edges) -> String {
    let mut text = String::new();
    for comp in cycles(edges) {
        text += &format!(
            "{what}: {} modules import each other: {}\n",
            comp.len(),
            comp.join(", ")
        );
        text += "  a shortest cycle:\n";
        for (from, to) in shortest_cycle(edges, &comp, &comp[0]) {
            text += &format!("    {from} -> {to}   ({})\n", edges[&from][&to]);
        }
        text += "  every import inside the cycle:\n";
        for from in &comp {
            for (to, witness) in edges[from].iter().filter(|(to, _)| comp.contains(to)) {
                text += &format!("    {from} -> {to}   ({witness})\n");
            }
        }
    }
    text
}

fn src() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("src")
}

#[test]
fn top_level_modules_import_no_cycle() {
    let mut text = String::new();
    for root in ["lib.rs", "main.rs"] {
        text += &report(
            &format!("{root}, top level"),
            &top_level(&import_graph(&src().join(root))),
        );
    }
    assert!(
        text.is_empty(),
        "import cycles between top-level modules:\n{text}"
    );
}

#[test]
fn files_import_no_cycle() {
    let mut text = String::new();
    for root in ["lib.rs", "main.rs"] {
        text += &report(&format!("{root}, files"), &import_graph(&src().join(root)));
    }
    assert!(text.is_empty(), "import cycles between files:\n{text}");
}

/// The checker itself: a cycle written in the ways the source writes paths
/// is found; comments, strings, char literals and a folder using its own
/// files are not edges.
#[test]
fn the_checker_finds_a_cycle() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path();
    let write = |rel: &str, text: &str| {
        let p = dir.join(rel);
        fs::create_dir_all(p.parent().unwrap()).unwrap();
        fs::write(p, text).unwrap();
    };
    write(
        "lib.rs",
        "pub mod a;\npub mod b;\npub mod c;\npub use a::Thing;\n",
    );
    write(
        "a/mod.rs",
        "mod inner;\npub use inner::Thing;\n// crate::c::X in a comment\n",
    );
    write(
        "a/inner.rs",
        "use super::super::b::{self, Other as O};\npub struct Thing;\n",
    );
    write(
        "b.rs",
        "pub fn f() { let s = \"crate::a::Thing\"; crate::c::g(); }\n",
    );
    write(
        "c.rs",
        "pub fn g() { let _ = crate::Thing; }\n\
         fn h<'a>(_: &'a str) -> char { let _ = r#\"crate::b::f\"#; '\"' }\n\
         #[cfg(test)]\nmod tests { use super::*; }\n",
    );
    let files = import_graph(&dir.join("lib.rs"));
    let top = top_level(&files);
    let edge = |g: &Edges, a: &str, b: &str| g[a].contains_key(b);
    assert!(
        edge(&files, "a::inner", "b") && edge(&files, "b", "c") && edge(&files, "c", "a::inner")
    );
    assert!(
        !edge(&files, "a", "a::inner"),
        "a folder may use its own files"
    );
    assert!(
        !edge(&files, "b", "a::inner"),
        "string literals are not paths"
    );
    assert!(!edge(&files, "a", "c"), "comments are not paths");
    assert!(!edge(&files, "c", "b"), "raw strings are not paths");
    assert_eq!(
        cycles(&files),
        vec![vec!["a::inner".to_string(), "b".into(), "c".into()]]
    );
    assert_eq!(
        cycles(&top),
        vec![vec!["a".to_string(), "b".into(), "c".into()]]
    );
    let text = report("test", &files);
    assert!(
        text.contains("c -> a::inner   (") && text.contains("c.rs:1 `crate::Thing`)"),
        "{text}"
    );
}
