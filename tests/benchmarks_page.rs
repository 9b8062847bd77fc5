//! BENCHMARKS.md stays a short page of current figures: under 300 lines, and every row of its
//! tables names the command that reproduces the figure and the date it was measured.

use std::path::Path;

const MAX_LINES: usize = 300;
const COLUMNS: [&str; 5] = ["what", "figure", "command", "date", "machine"];

/// The cells of a markdown table row; `\|` inside a cell is not a separator.
fn cells(row: &str) -> Vec<String> {
    let inner = row.trim().trim_start_matches('|').trim_end_matches('|');
    let mut cells = vec![String::new()];
    let mut chars = inner.chars().peekable();
    while let Some(c) = chars.next() {
        match c {
            '\\' if chars.peek() == Some(&'|') => {
                cells.last_mut().unwrap().push('|');
                chars.next();
            }
            '|' => cells.push(String::new()),
            _ => cells.last_mut().unwrap().push(c),
        }
    }
    cells.into_iter().map(|c| c.trim().to_string()).collect()
}

/// A date `YYYY-MM-DD` at the start of the cell.
fn is_date(cell: &str) -> bool {
    let b = cell.as_bytes();
    b.len() >= 10
        && b[..10].iter().enumerate().all(|(i, c)| {
            if i == 4 || i == 7 {
                *c == b'-'
            } else {
                c.is_ascii_digit()
            }
        })
}

/// Problems with the page, one line each.
fn problems(page: &str) -> Vec<String> {
    let mut found = Vec::new();
    let lines: Vec<&str> = page.lines().collect();
    if lines.len() >= MAX_LINES {
        found.push(format!("{} lines (limit {MAX_LINES})", lines.len()));
    }
    let mut header: Option<Vec<String>> = None;
    for (i, line) in lines.iter().enumerate() {
        if !line.trim_start().starts_with('|') {
            header = None;
            continue;
        }
        let row = cells(line);
        let Some(columns) = &header else {
            if row != COLUMNS {
                found.push(format!("line {}: table header is not {COLUMNS:?}", i + 1));
            }
            header = Some(row);
            continue;
        };
        if row.iter().all(|c| c.chars().all(|ch| ch == '-')) {
            continue;
        }
        if row.len() != columns.len() {
            found.push(format!(
                "line {}: {} cells, not {}",
                i + 1,
                row.len(),
                columns.len()
            ));
            continue;
        }
        if !row[2].contains('`') {
            found.push(format!("line {}: no command in backticks", i + 1));
        }
        if !is_date(&row[3]) {
            found.push(format!("line {}: `{}` is not a date", i + 1, row[3]));
        }
        if row[1].is_empty() || row[4].is_empty() {
            found.push(format!("line {}: empty figure or machine", i + 1));
        }
    }
    found
}

#[test]
fn the_benchmarks_page_is_short_and_every_row_has_a_command_and_a_date() {
    let page = std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("BENCHMARKS.md"))
        .expect("BENCHMARKS.md is readable");
    let found = problems(&page);
    assert!(found.is_empty(), "BENCHMARKS.md:\n{}", found.join("\n"));
}

#[test]
fn the_check_finds_a_row_without_a_command_or_date_and_a_long_page() {
    let table = "| what | figure | command | date | machine |\n|---|---|---|---|---|\n";
    assert!(
        problems(&format!(
            "{table}| a | 1 s | `x` | 2026-11-22 | 2 cores |\n"
        ))
        .is_empty()
    );
    assert_eq!(
        problems(&format!("{table}| a | 1 s | x | 2026-11-22 | 2 cores |\n")).len(),
        1
    );
    assert_eq!(
        problems(&format!("{table}| a | 1 s | `x` | recent | 2 cores |\n")).len(),
        1
    );
    assert_eq!(problems("| a | b |\n|---|---|\n").len(), 1);
    assert_eq!(problems(&"line\n".repeat(MAX_LINES)).len(), 1);
}
