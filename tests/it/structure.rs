//! The layer order of `src/lib.rs`'s docs holds in the sources: every module imports only
//! modules listed above its own.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

fn src() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("src")
}

/// The layers as `lib.rs` lists them: one module per numbered doc line, lowest first.
fn layers() -> Vec<String> {
    let lib = std::fs::read_to_string(src().join("lib.rs")).unwrap();
    let doc = lib
        .split("//! # Layers")
        .nth(1)
        .expect("lib.rs has a `# Layers` section");
    doc.lines()
        .skip(1)
        .take_while(|l| l.starts_with("//!"))
        .filter_map(|l| {
            let l = l.trim_start_matches("//!").trim_start();
            let (n, rest) = l.split_once(". ")?;
            n.parse::<usize>().ok()?;
            let name = rest.strip_prefix("[`")?.split('`').next()?;
            Some(name.to_string())
        })
        .collect()
}

/// The source with comments, string and char literals blanked out, so that only code is
/// searched.
fn code_only(text: &str) -> String {
    let c: Vec<char> = text.chars().collect();
    let mut out = String::with_capacity(text.len());
    let mut i = 0;
    while i < c.len() {
        let next = c.get(i + 1).copied();
        if c[i] == '/' && next == Some('/') {
            while i < c.len() && c[i] != '\n' {
                i += 1;
            }
        } else if c[i] == '/' && next == Some('*') {
            let mut depth = 0;
            while i < c.len() {
                if c[i] == '/' && c.get(i + 1) == Some(&'*') {
                    depth += 1;
                    i += 2;
                } else if c[i] == '*' && c.get(i + 1) == Some(&'/') {
                    depth -= 1;
                    i += 2;
                    if depth == 0 {
                        break;
                    }
                } else {
                    i += 1;
                }
            }
        } else if c[i] == 'r'
            && (next == Some('"') || next == Some('#'))
            && !ident(c.get(i.wrapping_sub(1)))
        {
            // A raw string: r"..." or r#"..."#.
            let mut j = i + 1;
            let mut hashes = 0;
            while c.get(j) == Some(&'#') {
                hashes += 1;
                j += 1;
            }
            if c.get(j) != Some(&'"') {
                out.push(c[i]);
                i += 1;
                continue;
            }
            j += 1;
            while j < c.len()
                && !(c[j] == '"' && (0..hashes).all(|h| c.get(j + 1 + h) == Some(&'#')))
            {
                j += 1;
            }
            i = j + 1 + hashes;
            out.push_str("\"\"");
        } else if c[i] == '"' {
            i += 1;
            while i < c.len() && c[i] != '"' {
                i += if c[i] == '\\' { 2 } else { 1 };
            }
            i += 1;
            out.push_str("\"\"");
        } else if c[i] == '\'' && (next == Some('\\') || c.get(i + 2) == Some(&'\'')) {
            // A char literal ('x', '\n', '\u{..}'); a lifetime has no closing quote.
            i += 2;
            while i < c.len() && c[i] != '\'' {
                i += 1;
            }
            i += 1;
            out.push_str("' '");
        } else {
            out.push(c[i]);
            i += 1;
        }
    }
    out
}

fn ident(c: Option<&char>) -> bool {
    c.is_some_and(|c| c.is_alphanumeric() || *c == '_')
}

/// `code` without its `#[cfg(test)]` items (unit tests may use any module for fixtures).
fn without_tests(code: &str) -> String {
    let mut out = code.to_string();
    while let Some(at) = out.find("#[cfg(test)]") {
        let rest = &out[at..];
        let end = match (rest.find('{'), rest.find(';')) {
            (Some(b), s) if s.is_none_or(|s| b < s) => {
                let mut depth = 0;
                let mut end = rest.len();
                for (k, ch) in rest[b..].char_indices() {
                    match ch {
                        '{' => depth += 1,
                        '}' => {
                            depth -= 1;
                            if depth == 0 {
                                end = b + k + 1;
                                break;
                            }
                        }
                        _ => {}
                    }
                }
                end
            }
            (_, Some(s)) => s + 1,
            _ => rest.len(),
        };
        out.replace_range(at..at + end, "");
    }
    out
}

/// The top-level modules a file's code names through `crate::`.
fn imports(code: &str) -> Vec<String> {
    // The root's re-exports, by the module that defines them.
    let root = |name: &str| match name {
        "Error" | "Result" => "error".to_string(),
        "Limits" => "limits".to_string(),
        other => other.to_string(),
    };
    let mut found = Vec::new();
    for (at, _) in code.match_indices("crate::") {
        if ident(code[..at].chars().last().as_ref()) {
            continue; // `dexwarp_crate::` and the like
        }
        let rest = &code[at + "crate::".len()..];
        if let Some(list) = rest.strip_prefix('{') {
            // `use crate::{a::b, c, D}`: the first name of each top-level item.
            let mut depth = 0;
            let mut item = String::new();
            let mut first = true;
            for ch in list.chars() {
                match ch {
                    '{' => depth += 1,
                    '}' if depth == 0 => break,
                    '}' => depth -= 1,
                    ',' if depth == 0 => {
                        first = true;
                        if !item.is_empty() {
                            found.push(root(&item));
                        }
                        item.clear();
                        continue;
                    }
                    _ => {}
                }
                if first && depth == 0 {
                    if ch.is_alphanumeric() || ch == '_' {
                        item.push(ch);
                    } else if !item.is_empty() || ch == ':' {
                        first = false;
                    }
                }
            }
            if !item.is_empty() {
                found.push(root(&item));
            }
        } else {
            let name: String = rest
                .chars()
                .take_while(|c| c.is_alphanumeric() || *c == '_')
                .collect();
            found.push(root(&name));
        }
    }
    found
}

fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    for entry in std::fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        if path.is_dir() {
            rust_files(&path, out);
        } else if path.extension().is_some_and(|e| e == "rs") {
            out.push(path);
        }
    }
}

#[test]
fn every_module_imports_only_the_layers_below_it() {
    let order = layers();
    let rank: BTreeMap<&str, usize> = order
        .iter()
        .enumerate()
        .map(|(k, m)| (m.as_str(), k))
        .collect();
    // Every module of the library is on the list, once.
    let lib = std::fs::read_to_string(src().join("lib.rs")).unwrap();
    let declared: Vec<&str> = lib
        .lines()
        .filter_map(|l| l.strip_prefix("pub mod ")?.strip_suffix(';'))
        .collect();
    assert_eq!(
        rank.len(),
        order.len(),
        "a module is listed twice: {order:?}"
    );
    for m in &declared {
        assert!(
            rank.contains_key(m),
            "lib.rs's `# Layers` does not list module `{m}`"
        );
    }
    assert_eq!(
        declared.len(),
        order.len(),
        "the layers list a module lib.rs lacks: {order:?}"
    );

    let mut files = Vec::new();
    rust_files(&src(), &mut files);
    let mut wrong = Vec::new();
    let mut checked = 0;
    for file in &files {
        let rel = file.strip_prefix(src()).unwrap();
        let top = rel
            .components()
            .next()
            .unwrap()
            .as_os_str()
            .to_string_lossy();
        let module = top.trim_end_matches(".rs");
        let Some(&own) = rank.get(module) else {
            continue; // lib.rs, and the binary in bin/: above every layer
        };
        let text = std::fs::read_to_string(file).unwrap();
        for used in imports(&without_tests(&code_only(&text))) {
            checked += 1;
            match rank.get(used.as_str()) {
                Some(&r) if r < own || used == module => {}
                Some(_) => wrong.push(format!("{} uses crate::{used}", rel.display())),
                None => wrong.push(format!(
                    "{} uses crate::{used}, which is not a listed module",
                    rel.display()
                )),
            }
        }
    }
    assert!(
        checked > 300,
        "only {checked} crate paths found: the scan is broken"
    );
    assert!(
        wrong.is_empty(),
        "imports against the layer order of lib.rs:\n{}",
        wrong.join("\n")
    );
}

#[test]
fn the_scan_sees_imports_and_skips_comments_strings_and_unit_tests() {
    let code = code_only(
        "use crate::{model::Demo, Error, geometry::{Mesh, shape}};\n\
         // crate::physics in a comment\n\
         let s = \"crate::hand in a string\";\n\
         let c = '{';\n\
         fn f<'a>(x: &'a str) -> crate::robot::Robot { todo!() }\n\
         #[cfg(test)]\nmod tests { use crate::reproduce; fn g() { let _ = crate::synth::x; } }\n\
         #[cfg(test)]\nuse crate::augment;\n\
         pub fn h() -> crate::warp::ObjectWarp { todo!() }\n",
    );
    assert_eq!(
        imports(&without_tests(&code)),
        ["model", "error", "geometry", "robot", "warp"]
    );
}

/// Longest a function in `src/` may be, from its `fn` line to its closing brace.
const MAX_FUNCTION_LINES: usize = 120;

/// Every function of `code` (comments and literals blanked) as `(name, first line, lines)`.
fn functions(code: &str) -> Vec<(String, usize, usize)> {
    let lines: Vec<&str> = code.lines().collect();
    let mut found = Vec::new();
    for (i, line) in lines.iter().enumerate() {
        let Some(at) = line.find("fn ") else {
            continue;
        };
        let before = &line[..at];
        let is_item = before.split_whitespace().all(|w| {
            matches!(w, "pub" | "const" | "async" | "unsafe" | "extern") || w.starts_with("pub(")
        });
        if !is_item || (at > 0 && ident(line[..at].chars().last().as_ref())) {
            continue;
        }
        let name: String = line[at + 3..]
            .chars()
            .take_while(|c| c.is_alphanumeric() || *c == '_')
            .collect();
        // The body: from the first `{` after the signature to its matching `}`; a `;` first
        // is a declaration without a body.
        let mut depth = 0usize;
        let mut end = None;
        'scan: for (j, l) in lines.iter().enumerate().skip(i) {
            for ch in l.chars() {
                match ch {
                    ';' if depth == 0 => break 'scan,
                    '{' => depth += 1,
                    '}' => {
                        depth -= 1;
                        if depth == 0 {
                            end = Some(j);
                            break 'scan;
                        }
                    }
                    _ => {}
                }
            }
        }
        if let Some(end) = end {
            found.push((name, i + 1, end - i + 1));
        }
    }
    found
}

#[test]
fn no_function_in_src_is_longer_than_the_limit() {
    let mut files = Vec::new();
    rust_files(&src(), &mut files);
    let mut long = Vec::new();
    let mut counted = 0;
    for file in &files {
        let text = std::fs::read_to_string(file).unwrap();
        for (name, line, len) in functions(&code_only(&text)) {
            counted += 1;
            if len > MAX_FUNCTION_LINES {
                let rel = file.strip_prefix(src()).unwrap();
                long.push(format!("src/{}:{line} {name}: {len} lines", rel.display()));
            }
        }
    }
    assert!(
        counted > 900,
        "only {counted} functions found: the scan is broken"
    );
    assert!(
        long.is_empty(),
        "functions over {MAX_FUNCTION_LINES} lines (split them into named steps):\n{}",
        long.join("\n")
    );
}

#[test]
fn the_function_scan_measures_bodies_and_skips_declarations() {
    let code = code_only(
        "pub fn a() {\n    let s = \"}\";\n}\n\
         fn b(x: u8) -> u8 {\n    if x > 0 { 1 } else { 0 }\n}\n\
         trait T { fn c(&self); }\n\
         impl T for u8 {\n    fn c(&self) {}\n}\n\
         pub(crate) fn d()\nwhere\n    u8: Copy,\n{\n}\n",
    );
    let found: Vec<(String, usize, usize)> = functions(&code);
    assert_eq!(
        found,
        [
            ("a".to_string(), 1, 3),
            ("b".to_string(), 4, 3),
            ("c".to_string(), 9, 1),
            ("d".to_string(), 11, 5),
        ]
    );
}
