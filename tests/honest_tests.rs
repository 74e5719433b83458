//! The suite cannot pass by not running: every `#[test]` function under
//! `tests/` that returns early must say why through `skip::missing` in the
//! same statement (which fails under `CI=true` and is counted elsewhere, see
//! `tests/skip/mod.rs`), and no test carries the `ignore` attribute.
//!
//! This reads the test sources as text: comments and string literals are
//! blanked, each `#[test]` function's body is found by brace matching, and
//! every `return` in it must have `skip::missing(` before the statement ends.

use std::path::{Path, PathBuf};

/// Replaces comments and the contents of string and char literals by
/// spaces (newlines kept), so that braces and words in them do not count.
fn blank_comments_and_strings(src: &str) -> String {
    let b = src.as_bytes();
    let mut out = b.to_vec();
    let blank = |out: &mut Vec<u8>, from: usize, to: usize| {
        for c in &mut out[from..to] {
            if *c != b'\n' {
                *c = b' ';
            }
        }
    };
    let mut i = 0;
    while i < b.len() {
        match b[i] {
            b'/' if b.get(i + 1) == Some(&b'/') => {
                let end = src[i..].find('\n').map_or(b.len(), |e| i + e);
                blank(&mut out, i, end);
                i = end;
            }
            b'/' if b.get(i + 1) == Some(&b'*') => {
                let end = src[i + 2..].find("*/").map_or(b.len(), |e| i + 2 + e + 2);
                blank(&mut out, i, end);
                i = end;
            }
            b'r' if matches!(b.get(i + 1), Some(b'"') | Some(b'#'))
                && (i == 0 || !(b[i - 1].is_ascii_alphanumeric() || b[i - 1] == b'_')) =>
            {
                // Raw string r"..." or r#"..."#.
                let mut j = i + 1;
                let mut hashes = 0;
                while b.get(j) == Some(&b'#') {
                    hashes += 1;
                    j += 1;
                }
                if b.get(j) != Some(&b'"') {
                    i += 1;
                    continue;
                }
                let close = format!("\"{}", "#".repeat(hashes));
                let end = src[j + 1..]
                    .find(&close)
                    .map_or(b.len(), |e| j + 1 + e + close.len());
                blank(&mut out, j + 1, end.saturating_sub(close.len()).max(j + 1));
                i = end;
            }
            b'"' => {
                let mut j = i + 1;
                while j < b.len() && b[j] != b'"' {
                    j += if b[j] == b'\\' { 2 } else { 1 };
                }
                blank(&mut out, i + 1, j.min(b.len()));
                i = j + 1;
            }
            b'\'' => {
                // A char literal ('x', '\n', '\u{..}') or a lifetime ('a).
                if b.get(i + 1) == Some(&b'\\') {
                    let end = src[i + 2..].find('\'').map_or(b.len(), |e| i + 2 + e + 1);
                    blank(&mut out, i + 1, end - 1);
                    i = end;
                } else if let Some(c) = src[i + 1..].chars().next() {
                    let after = i + 1 + c.len_utf8();
                    if b.get(after) == Some(&b'\'') {
                        blank(&mut out, i + 1, after);
                        i = after + 1;
                    } else {
                        i += 1;
                    }
                } else {
                    i += 1;
                }
            }
            _ => i += 1,
        }
    }
    String::from_utf8(out).expect("blanking keeps UTF-8 (only ASCII replaced)")
}

/// The `#[test]` functions of a (blanked) source: name, first line, body.
fn test_functions(code: &str) -> Vec<(String, usize, String)> {
    let mut found = Vec::new();
    let mut from = 0;
    while let Some(at) = code[from..].find("#[test]") {
        let start = from + at;
        from = start + 7;
        let Some(fn_at) = code[from..].find("fn ") else {
            break;
        };
        let name_start = from + fn_at + 3;
        let name: String = code[name_start..]
            .chars()
            .take_while(|c| c.is_alphanumeric() || *c == '_')
            .collect();
        let Some(open) = code[name_start..].find('{') else {
            break;
        };
        let open = name_start + open;
        let mut depth = 0usize;
        let mut close = code.len();
        for (k, c) in code[open..].char_indices() {
            match c {
                '{' => depth += 1,
                '}' => {
                    depth -= 1;
                    if depth == 0 {
                        close = open + k;
                        break;
                    }
                }
                _ => {}
            }
        }
        let line = code[..start].matches('\n').count() + 1;
        found.push((name, line, code[open..close].to_string()));
        from = close;
    }
    found
}

/// Early returns in `body` not explained by `skip::missing(` before the
/// statement ends (the next `;`, or the end of the enclosing block).
fn unexplained_returns(body: &str) -> usize {
    let bytes = body.as_bytes();
    let mut count = 0;
    let mut from = 0;
    while let Some(at) = body[from..].find("return") {
        let start = from + at;
        from = start + 6;
        let word_start =
            start == 0 || !(bytes[start - 1].is_ascii_alphanumeric() || bytes[start - 1] == b'_');
        let word_end = bytes
            .get(start + 6)
            .is_none_or(|c| !(c.is_ascii_alphanumeric() || *c == b'_'));
        if !(word_start && word_end) {
            continue;
        }
        // The statement: up to the first `;` or the `}` closing its block.
        let mut depth = 0i32;
        let mut end = body.len();
        for (k, c) in body[start..].char_indices() {
            match c {
                '(' | '[' | '{' => depth += 1,
                ')' | ']' => depth -= 1,
                '}' if depth == 0 => {
                    end = start + k;
                    break;
                }
                '}' => depth -= 1,
                ';' if depth == 0 => {
                    end = start + k;
                    break;
                }
                _ => {}
            }
        }
        if !body[start..end].contains("skip::missing(") {
            count += 1;
        }
    }
    count
}

fn sources(dir: &Path, out: &mut Vec<PathBuf>) {
    let mut entries: Vec<PathBuf> = std::fs::read_dir(dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|e| e.expect("dir entry").path())
        .collect();
    entries.sort();
    for p in entries {
        if p.is_dir() {
            sources(&p, out);
        } else if p.extension().is_some_and(|e| e == "rs") {
            out.push(p);
        }
    }
}

#[test]
fn no_test_returns_early_without_a_recorded_reason() {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests");
    let mut files = Vec::new();
    sources(&root, &mut files);
    let mut tests = 0;
    let mut problems = Vec::new();
    for f in &files {
        let src = std::fs::read_to_string(f).unwrap_or_else(|e| panic!("{}: {e}", f.display()));
        let code = blank_comments_and_strings(&src);
        if code.contains("#[ignore") {
            problems.push(format!(
                "{}: an ignore attribute (a test that never runs)",
                f.display()
            ));
        }
        for (name, line, body) in test_functions(&code) {
            tests += 1;
            let n = unexplained_returns(&body);
            if n > 0 {
                problems.push(format!(
                    "{}:{line} {name}: {n} early return(s) without skip::missing",
                    f.display()
                ));
            }
        }
    }
    // The scan must have found the suite (a broken parser finds nothing).
    assert!(
        files.len() >= 20 && tests >= 150,
        "scanned {} files, {tests} tests: the scanner is broken",
        files.len()
    );
    assert!(problems.is_empty(), "{}", problems.join("\n"));
}

/// The scanner itself: a silent early return is found, an explained one is
/// not, and comments or strings do not fool it.
#[test]
fn scanner_finds_silent_returns_and_accepts_recorded_ones() {
    let src = r#####"
        #[test]
        fn silent() {
            let Some(t) = tools() else { return };
            if x { return; }
            use_it(t);
        }
        #[test]
        fn recorded() {
            let t = match tools() {
                Ok(t) => t,
                Err(why) => return skip::missing("recorded", &why),
            };
            if let Err(why) = asan() {
                return skip::missing("recorded", &why);
            }
            let s = "return { in a string";
            // return in a comment
            let c = '{';
            let f = |x: u32| -> u32 { x };
            use_it(t, s, c, f);
        }
        #[test]
        fn closure_and_nested() {
            let v: Vec<u32> = (0..3).map(|i| { if i > 1 { return 0; } i }).collect();
        }
    "#####;
    let code = blank_comments_and_strings(src);
    let fns = test_functions(&code);
    let names: Vec<&str> = fns.iter().map(|(n, _, _)| n.as_str()).collect();
    assert_eq!(names, ["silent", "recorded", "closure_and_nested"]);
    assert_eq!(unexplained_returns(&fns[0].2), 2);
    assert_eq!(unexplained_returns(&fns[1].2), 0);
    // A `return` inside a closure counts too: the rule is strict on purpose.
    assert_eq!(unexplained_returns(&fns[2].2), 1);
}
