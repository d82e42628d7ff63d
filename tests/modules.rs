//! The files of `src/` import one another one way: from the binary down to `lanes/`,
//! never back, so no two files depend on each other, directly or through others
//! (ARCHITECTURE.md, "Modules"). Read from the source text of each crate (the library,
//! and the binary: `main.rs` and `cli/`): every path that starts at `crate::`, `super::`,
//! `self::` or a child module, in `use` declarations and in code, resolved to the file
//! that defines its item, through `pub use` re-exports. A re-export of a name the file
//! does not use itself is not an edge, nor is a directory module's `mod.rs` using its
//! own files (containment; its files importing the types it declares for them are
//! edges), and `#[cfg(test)]` items are left out.

use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;

/// A source file: its crate ("lib" or "bin"), module path and name under `src/`.
struct File {
    krate: &'static str,
    module: Vec<String>,
    name: String,
}

#[derive(Clone, Debug, PartialEq)]
enum Token {
    Ident(String),
    /// `::`
    Path,
    Punct(char),
}

/// A path found in a file: the module it is written in (the file's, or an inline
/// module's inside it), its segments, the name a `use` brings in, whether it is a
/// re-export (`pub use`) and the line.
struct Use {
    here: Vec<String>,
    segments: Vec<String>,
    name: String,
    reexport: bool,
    line: usize,
}

/// The text without comments, string and character literals, and `#[cfg(test)]` items,
/// as tokens with their line numbers.
fn tokenize(text: &str) -> Vec<(Token, usize)> {
    let chars: Vec<char> = text.chars().collect();
    let mut out = Vec::new();
    let (mut i, mut line) = (0, 1);
    while i < chars.len() {
        let c = chars[i];
        let next = chars.get(i + 1).copied();
        if c == '\n' {
            line += 1;
            i += 1;
        } else if c.is_whitespace() {
            i += 1;
        } else if c == '/' && next == Some('/') {
            while i < chars.len() && chars[i] != '\n' {
                i += 1;
            }
        } else if c == '/' && next == Some('*') {
            i += 2;
            while i + 1 < chars.len() && !(chars[i] == '*' && chars[i + 1] == '/') {
                line += usize::from(chars[i] == '\n');
                i += 1;
            }
            i += 2;
        } else if c == '"' || (c == 'r' && matches!(next, Some('"') | Some('#'))) {
            // A string, plain (with escapes) or raw (`r#"…"#`).
            let raw = c == 'r';
            let mut hashes = 0;
            if raw {
                i += 1;
                while chars.get(i) == Some(&'#') {
                    hashes += 1;
                    i += 1;
                }
                if chars.get(i) != Some(&'"') {
                    out.push((Token::Ident("r".into()), line));
                    continue;
                }
            }
            i += 1;
            while i < chars.len() {
                if chars[i] == '\n' {
                    line += 1;
                }
                if !raw && chars[i] == '\\' {
                    i += 2;
                    continue;
                }
                if chars[i] == '"' && chars[i + 1..].iter().take(hashes).all(|&h| h == '#') {
                    i += 1 + hashes;
                    break;
                }
                i += 1;
            }
        } else if c == '\'' {
            // A character literal ('x', '\n', '\u{1b}'), or a lifetime.
            if next == Some('\\') {
                i += 2;
                while i < chars.len() && chars[i] != '\'' {
                    i += 1;
                }
                i += 1;
            } else if chars.get(i + 2) == Some(&'\'') {
                i += 3;
            } else {
                i += 1;
            }
        } else if c.is_alphanumeric() || c == '_' {
            let start = i;
            while i < chars.len() && (chars[i].is_alphanumeric() || chars[i] == '_') {
                i += 1;
            }
            out.push((Token::Ident(chars[start..i].iter().collect()), line));
        } else if c == ':' && next == Some(':') {
            out.push((Token::Path, line));
            i += 2;
        } else {
            out.push((Token::Punct(c), line));
            i += 1;
        }
    }
    drop_test_items(out)
}

/// The tokens without the items under `#[cfg(test)]` (a test module, a test-only
/// function or `use`).
fn drop_test_items(tokens: Vec<(Token, usize)>) -> Vec<(Token, usize)> {
    let attr: Vec<Token> = "# [ cfg ( test ) ]"
        .split(' ')
        .map(|s| match s {
            "cfg" | "test" => Token::Ident(s.into()),
            _ => Token::Punct(s.chars().next().unwrap()),
        })
        .collect();
    let mut out = Vec::new();
    let mut i = 0;
    while i < tokens.len() {
        let is_attr = tokens.len() >= i + attr.len()
            && tokens[i..i + attr.len()]
                .iter()
                .zip(&attr)
                .all(|((t, _), a)| t == a);
        if !is_attr {
            out.push(tokens[i].clone());
            i += 1;
            continue;
        }
        // Skip to the end of the item: its `;` or its closing brace.
        i += attr.len();
        let mut depth = 0;
        while i < tokens.len() {
            match tokens[i].0 {
                Token::Punct('{') => depth += 1,
                Token::Punct('}') => {
                    depth -= 1;
                    if depth == 0 {
                        i += 1;
                        break;
                    }
                }
                Token::Punct(';') if depth == 0 => {
                    i += 1;
                    break;
                }
                _ => {}
            }
            i += 1;
        }
    }
    out
}

fn read_files(src: &Path) -> Vec<File> {
    let mut files = Vec::new();
    let mut dirs = vec![src.to_path_buf()];
    while let Some(dir) = dirs.pop() {
        for entry in std::fs::read_dir(&dir).unwrap() {
            let path = entry.unwrap().path();
            if path.is_dir() {
                dirs.push(path);
                continue;
            }
            if path.extension().is_none_or(|e| e != "rs") {
                continue;
            }
            let name = path
                .strip_prefix(src)
                .unwrap()
                .to_string_lossy()
                .replace('\\', "/");
            let mut module: Vec<String> = name
                .trim_end_matches(".rs")
                .split('/')
                .map(String::from)
                .collect();
            if matches!(module.last().unwrap().as_str(), "mod" | "lib" | "main") {
                module.pop();
            }
            let krate = if name == "main.rs" || name.starts_with("cli/") {
                "bin"
            } else {
                "lib"
            };
            files.push(File {
                krate,
                module,
                name,
            });
        }
    }
    files.sort_by(|a, b| a.name.cmp(&b.name));
    files
}

fn ident(t: Option<&(Token, usize)>) -> Option<&str> {
    match t {
        Some((Token::Ident(s), _)) => Some(s),
        _ => None,
    }
}

/// The leaves of a use tree starting at `tokens[*i]`, each as its full path and the name
/// it brings in (`self` in a group is the group's own path; `as` renames).
fn use_tree(
    tokens: &[(Token, usize)],
    i: &mut usize,
    prefix: &[String],
    out: &mut Vec<(Vec<String>, String)>,
) {
    let mut path = prefix.to_vec();
    let leaf = |path: Vec<String>| {
        let name = path.last().cloned().unwrap_or_default();
        (path, name)
    };
    loop {
        match tokens.get(*i).map(|t| &t.0) {
            Some(Token::Ident(s))
                if s == "self" && path.len() == prefix.len() && !prefix.is_empty() =>
            {
                *i += 1
            }
            Some(Token::Ident(s)) => {
                path.push(s.clone());
                *i += 1;
            }
            Some(Token::Punct('*')) => {
                *i += 1;
                out.push(leaf(path.clone()));
                return;
            }
            Some(Token::Punct('{')) => {
                *i += 1;
                loop {
                    match tokens.get(*i).map(|t| &t.0) {
                        Some(Token::Punct('}')) => {
                            *i += 1;
                            return;
                        }
                        Some(Token::Punct(',')) => *i += 1,
                        None => return,
                        _ => use_tree(tokens, i, &path, out),
                    }
                }
            }
            _ => return,
        }
        match tokens.get(*i).map(|t| &t.0) {
            Some(Token::Path) => *i += 1,
            Some(Token::Ident(s)) if s == "as" => {
                let name = ident(tokens.get(*i + 1)).unwrap_or_default().to_string();
                *i += 2;
                out.push((path, name));
                return;
            }
            _ => {
                out.push(leaf(path));
                return;
            }
        }
    }
}

/// The child modules `file` declares (`mod x;`), and every path it writes that starts at
/// `crate`, `super`, `self` or a child module.
/// The child modules `file` declares, the paths it writes, and the names its code
/// (outside `use` declarations) mentions.
fn uses(file: &File, text: &str) -> (BTreeSet<String>, Vec<Use>, BTreeSet<String>) {
    let tokens = tokenize(text);
    let mut children = BTreeSet::new();
    for w in tokens.windows(3) {
        if let [(Token::Ident(m), _), (Token::Ident(name), _), (Token::Punct(';'), _)] = w {
            if m == "mod" {
                children.insert(name.clone());
            }
        }
    }
    let mut found = Vec::new();
    let mut mentioned = BTreeSet::new();
    // Inline modules (`mod defaults { … }`) and the brace depth each one closes at.
    let mut inline: Vec<(String, usize)> = Vec::new();
    let mut depth = 0;
    let mut i = 0;
    while i < tokens.len() {
        let mut here = file.module.clone();
        here.extend(inline.iter().map(|(m, _)| m.clone()));
        match &tokens[i].0 {
            Token::Punct('{') => depth += 1,
            Token::Punct('}') => {
                depth -= 1;
                if inline.last().is_some_and(|&(_, d)| d == depth) {
                    inline.pop();
                }
            }
            Token::Ident(m)
                if m == "mod" && matches!(tokens.get(i + 2), Some((Token::Punct('{'), _))) =>
            {
                inline.push((ident(tokens.get(i + 1)).unwrap().to_string(), depth));
                i += 2;
                continue;
            }
            Token::Ident(u) if u == "use" => {
                // `pub use`, `pub(crate) use`, `pub(super) use`: a re-export.
                let reexport = matches!(tokens.get(i.wrapping_sub(1)), Some((Token::Ident(p), _)) if p == "pub")
                    || matches!(tokens.get(i.wrapping_sub(1)), Some((Token::Punct(')'), _)));
                let line = tokens[i].1;
                i += 1;
                if matches!(tokens.get(i), Some((Token::Path, _))) {
                    i += 1;
                }
                let mut leaves = Vec::new();
                use_tree(&tokens, &mut i, &[], &mut leaves);
                for (segments, name) in leaves {
                    found.push(Use {
                        here: here.clone(),
                        segments,
                        name,
                        reexport,
                        line,
                    });
                }
                continue;
            }
            Token::Ident(head)
                if matches!(tokens.get(i + 1), Some((Token::Path, _)))
                    && !matches!(tokens.get(i.wrapping_sub(1)), Some((Token::Path, _))) =>
            {
                let line = tokens[i].1;
                let mut segments = vec![head.clone()];
                let mut j = i + 1;
                while matches!(tokens.get(j), Some((Token::Path, _))) {
                    match ident(tokens.get(j + 1)) {
                        Some(s) => segments.push(s.to_string()),
                        None => break,
                    }
                    j += 2;
                }
                found.push(Use {
                    here: here.clone(),
                    segments,
                    name: String::new(),
                    reexport: false,
                    line,
                });
                mentioned.extend(found.last().unwrap().segments.iter().cloned());
                i = j;
                continue;
            }
            Token::Ident(name) => {
                mentioned.insert(name.clone());
            }
            _ => {}
        }
        i += 1;
    }
    (children, found, mentioned)
}

/// A re-exported path and the module it is written in.
struct Reexport {
    here: Vec<String>,
    segments: Vec<String>,
}

struct Crate<'a> {
    files: BTreeMap<Vec<String>, &'a File>,
    children: BTreeMap<String, BTreeSet<String>>,
    /// Per file: each name it re-exports.
    reexports: BTreeMap<String, BTreeMap<String, Reexport>>,
}

impl Crate<'_> {
    /// The absolute module path of `segments` written in module `here`, if it starts at
    /// this crate (`crate`, `super`, `self` or a child of `here`'s file).
    fn absolute(&self, file: &str, here: &[String], segments: &[String]) -> Option<Vec<String>> {
        let (base, rest): (Vec<String>, &[String]) = match segments[0].as_str() {
            "crate" => (Vec::new(), &segments[1..]),
            "self" => (here.to_vec(), &segments[1..]),
            "super" => {
                let ups = segments.iter().take_while(|s| *s == "super").count();
                (
                    here[..here.len().checked_sub(ups)?].to_vec(),
                    &segments[ups..],
                )
            }
            child if self.children[file].contains(child) => (here.to_vec(), segments),
            _ => return None,
        };
        Some(base.into_iter().chain(rest.iter().cloned()).collect())
    }

    /// The file that defines what `path` names: the longest prefix that is a file, and
    /// through that file's re-export of the next segment, if it has one.
    fn resolve(&self, path: &[String], hops: usize) -> Option<&File> {
        let n = (0..=path.len())
            .rev()
            .find(|&n| self.files.contains_key(&path[..n]))?;
        let file = self.files[&path[..n]];
        if let (Some(name), true) = (path.get(n), hops < 16) {
            if let Some(r) = self.reexports[&file.name].get(name) {
                if let Some(mut target) = self.absolute(&file.name, &r.here, &r.segments) {
                    target.extend(path[n + 1..].iter().cloned());
                    return self.resolve(&target, hops + 1).or(Some(file));
                }
            }
        }
        Some(file)
    }
}

/// Each edge between files: (from, to) → the first line of `from` that makes it.
fn edges(src: &Path) -> BTreeMap<(String, String), usize> {
    let files = read_files(src);
    let mut edges = BTreeMap::new();
    for krate in ["lib", "bin"] {
        let members: Vec<&File> = files.iter().filter(|f| f.krate == krate).collect();
        let mut c = Crate {
            files: members.iter().map(|f| (f.module.clone(), *f)).collect(),
            children: BTreeMap::new(),
            reexports: BTreeMap::new(),
        };
        let mut all = Vec::new();
        for f in &members {
            let text = std::fs::read_to_string(src.join(&f.name)).unwrap();
            let (children, found, mentioned) = uses(f, &text);
            c.children.insert(f.name.clone(), children);
            let mut reexports = BTreeMap::new();
            for u in found.iter().filter(|u| u.reexport) {
                reexports.insert(
                    u.name.clone(),
                    Reexport {
                        here: u.here.clone(),
                        segments: u.segments.clone(),
                    },
                );
            }
            c.reexports.insert(f.name.clone(), reexports);
            all.push((f, found, mentioned));
        }
        for (f, found, mentioned) in all {
            for u in found {
                let Some(path) = c.absolute(&f.name, &u.here, &u.segments) else {
                    continue;
                };
                let Some(target) = c.resolve(&path, 0) else {
                    continue;
                };
                // A re-export the file's own code does not use is a name, not a
                // dependency (a path through it is followed to the file that defines the
                // item), and a module's use of its own files is containment (the files
                // importing the types their `mod.rs` declares for them are edges).
                let name_only = u.reexport && !mentioned.contains(&u.name);
                let below =
                    target.module.len() > f.module.len() && target.module.starts_with(&f.module);
                if target.name == f.name || name_only || below {
                    continue;
                }
                edges
                    .entry((f.name.clone(), target.name.clone()))
                    .or_insert(u.line);
            }
        }
    }
    edges
}

/// The strongly connected groups of more than one file (Tarjan's algorithm).
fn cycles(edges: &BTreeMap<(String, String), usize>) -> Vec<Vec<String>> {
    let mut graph: BTreeMap<&str, Vec<&str>> = BTreeMap::new();
    for (a, b) in edges.keys() {
        graph.entry(a).or_default().push(b);
        graph.entry(b).or_default();
    }
    struct State<'a> {
        index: BTreeMap<&'a str, usize>,
        low: BTreeMap<&'a str, usize>,
        stack: Vec<&'a str>,
        on_stack: BTreeSet<&'a str>,
        groups: Vec<Vec<String>>,
    }
    fn visit<'a>(v: &'a str, graph: &BTreeMap<&'a str, Vec<&'a str>>, s: &mut State<'a>) {
        let n = s.index.len();
        s.index.insert(v, n);
        s.low.insert(v, n);
        s.stack.push(v);
        s.on_stack.insert(v);
        for &w in &graph[v] {
            if !s.index.contains_key(w) {
                visit(w, graph, s);
                let low = s.low[v].min(s.low[w]);
                s.low.insert(v, low);
            } else if s.on_stack.contains(w) {
                let low = s.low[v].min(s.index[w]);
                s.low.insert(v, low);
            }
        }
        if s.low[v] == s.index[v] {
            let mut group = Vec::new();
            loop {
                let w = s.stack.pop().unwrap();
                s.on_stack.remove(w);
                group.push(w.to_string());
                if w == v {
                    break;
                }
            }
            if group.len() > 1 {
                group.sort();
                s.groups.push(group);
            }
        }
    }
    let mut s = State {
        index: BTreeMap::new(),
        low: BTreeMap::new(),
        stack: Vec::new(),
        on_stack: BTreeSet::new(),
        groups: Vec::new(),
    };
    for &v in graph.keys() {
        if !s.index.contains_key(v) {
            visit(v, &graph, &mut s);
        }
    }
    s.groups
}

/// The edges inside each group, `a.rs:12 -> b.rs`, for the failure message.
fn describe(groups: &[Vec<String>], edges: &BTreeMap<(String, String), usize>) -> String {
    let mut text = String::new();
    for group in groups {
        text += &format!("cycle among {}:\n", group.join(", "));
        for ((a, b), line) in edges {
            if group.contains(a) && group.contains(b) {
                text += &format!("  src/{a}:{line} -> src/{b}\n");
            }
        }
    }
    text
}

#[test]
fn no_file_of_src_imports_back() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let edges = edges(&src);
    let groups = cycles(&edges);
    assert!(groups.is_empty(), "{}", describe(&groups, &edges));
}

/// The reader finds the edges a cycle is made of: a crate whose files import each other
/// in each of the ways the source writes an import.
#[test]
fn the_reader_finds_each_kind_of_import() {
    let dir = tempfile::tempdir().unwrap();
    let src = dir.path();
    let write = |name: &str, text: &str| {
        let path = src.join(name);
        std::fs::create_dir_all(path.parent().unwrap()).unwrap();
        std::fs::write(path, text).unwrap();
    };
    write("lib.rs", "mod a;\nmod b;\nmod d;\npub use b::Thing;\n");
    write(
        "a/mod.rs",
        "mod c;\npub use c::{Deep, Other as Renamed};\n// crate::b::X in a comment\nconst S: &str = \"crate::b::Y\";\n#[cfg(test)]\nmod tests { use crate::b::Z; }\n",
    );
    write("a/c.rs", "pub fn f() { let _ = crate::Thing::new(); }\n");
    write("b.rs", "use crate::a::{self, Deep};\n");
    write("d.rs", "pub use crate::b::Thing;\npub fn g(_: Thing) {}\n");
    let found = edges(src);
    let pairs: BTreeSet<(&str, &str)> = found
        .keys()
        .map(|(a, b)| (a.as_str(), b.as_str()))
        .collect();
    // `crate::Thing` goes through lib.rs's re-export to b.rs; `crate::a::Deep` through
    // a/mod.rs's to a/c.rs; the facade's `pub use c::…`, the comment, the string and the
    // test module make no edge; d.rs's re-export counts, as its code uses the name.
    let want: BTreeSet<(&str, &str)> = [
        ("a/c.rs", "b.rs"),
        ("b.rs", "a/mod.rs"),
        ("b.rs", "a/c.rs"),
        ("d.rs", "b.rs"),
    ]
    .into_iter()
    .collect();
    assert_eq!(pairs, want);
    assert_eq!(
        cycles(&found),
        vec![vec!["a/c.rs".to_string(), "b.rs".to_string()]]
    );
}
