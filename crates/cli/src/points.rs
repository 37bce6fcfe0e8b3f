//! Point files: `x y z` per line, separated by spaces, tabs, `;` or commas; an optional
//! header line naming the columns (`id x y z`, `x y z i j k`); `#` comments; blank lines
//! ignored; decimal commas recognised. Read in stages: a line's fields, the header's
//! columns, each row's values.

use crate::report::CliError;

/// A point and the line it came from.
#[derive(Debug, Clone, Copy)]
pub struct Point {
    /// Coordinates.
    pub p: [f64; 3],
    /// 1-based source line.
    pub line: usize,
    /// The normal (or tool axis) `i j k`, when the header names those columns.
    pub normal: Option<[f64; 3]>,
}

fn located(file: &str, line: usize, col: usize, text: &str, what: &str, hint: &str) -> CliError {
    let num = line.to_string();
    let pad = " ".repeat(num.len());
    CliError::failed(format!(
        "error: {what}\n{pad}--> {file}:{line}:{col}\n{pad} |\n{num} | {text}\n{pad} | {}^\n  = help: {hint}\n",
        " ".repeat(col.saturating_sub(1))
    ))
}

/// What a column holds, as a header names it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Column {
    /// A coordinate: 0, 1, 2 for x, y, z.
    Coord(usize),
    /// A point's name or number (any text).
    Id,
    /// A normal's component: 0, 1, 2 for i, j, k.
    Normal(usize),
}

/// The names a header may give its columns (case does not matter).
const COLUMN_NAMES: [(&str, Column); 16] = [
    ("x", Column::Coord(0)),
    ("y", Column::Coord(1)),
    ("z", Column::Coord(2)),
    ("id", Column::Id),
    ("n", Column::Id),
    ("no", Column::Id),
    ("name", Column::Id),
    ("point", Column::Id),
    ("pt", Column::Id),
    ("label", Column::Id),
    ("i", Column::Normal(0)),
    ("j", Column::Normal(1)),
    ("k", Column::Normal(2)),
    ("nx", Column::Normal(0)),
    ("ny", Column::Normal(1)),
    ("nz", Column::Normal(2)),
];

/// Stage 1: a line's fields and their byte columns. Separators are blanks, tabs, `;`
/// and `,`, except in a line that uses decimal commas (see [`decimal_commas`]), where
/// a comma is the decimal mark.
fn fields(code: &str, decimal_comma: bool) -> Vec<(usize, String)> {
    let mut out = Vec::new();
    let mut start = None;
    for (pos, ch) in code.char_indices() {
        let sep = ch == ' ' || ch == '\t' || ch == ';' || (ch == ',' && !decimal_comma);
        match (sep, start) {
            (false, None) => start = Some(pos),
            (true, Some(s)) => {
                out.push((s, code[s..pos].to_string()));
                start = None;
            }
            _ => {}
        }
    }
    if let Some(s) = start {
        out.push((s, code[s..].to_string()));
    }
    if decimal_comma {
        for f in &mut out {
            f.1 = f.1.replace(',', ".");
        }
    }
    out
}

/// Whether a line writes its numbers with decimal commas: its fields, split at blanks,
/// tabs and `;` only, are two or more, and one of them is a number with a comma for its
/// point (`1,5` in `1,5 2,25 -0,5`, or `1,5;2;3`). A comma-separated line (`1,2,3`,
/// `1.5, 2, 3`) is not.
fn decimal_commas(code: &str) -> bool {
    let parts: Vec<&str> = code
        .split([' ', '\t', ';'])
        .filter(|p| !p.is_empty())
        .collect();
    let decimal = |p: &str| {
        let body = p.strip_prefix(['-', '+']).unwrap_or(p);
        match body.split_once(',') {
            Some((a, b)) => {
                !a.is_empty()
                    && a.bytes().all(|c| c.is_ascii_digit())
                    && !b.is_empty()
                    && b.bytes().all(|c| c.is_ascii_digit())
            }
            None => false,
        }
    };
    parts.len() >= 2 && parts.iter().any(|p| decimal(p))
}

/// Stage 2: a header line's columns, or the error naming the bad one.
fn header_columns(
    flds: &[(usize, String)],
    raw: &str,
    file: &str,
    line: usize,
) -> Result<Vec<Column>, CliError> {
    let mut cols = Vec::with_capacity(flds.len());
    for (col, name) in flds {
        let key = name.trim_matches(['"', '\'']).to_ascii_lowercase();
        let key = key.trim_start_matches('#');
        let found = if key.is_empty() {
            Some(Column::Id)
        } else {
            COLUMN_NAMES
                .iter()
                .find(|(n, _)| *n == key)
                .map(|(_, c)| *c)
        };
        let Some(c) = found else {
            return Err(located(
                file,
                line,
                raw[..*col].chars().count() + 1,
                raw,
                &format!("the header names an unknown column `{name}`"),
                "name the columns x, y, z, and optionally an id (id, n, name, point) and a normal (i, j, k); every column needs a name",
            ));
        };
        if cols.contains(&c) {
            return Err(located(
                file,
                line,
                raw[..*col].chars().count() + 1,
                raw,
                &format!("the header names column `{name}` twice"),
                "give each column one name",
            ));
        }
        cols.push(c);
    }
    let normals = (0..3)
        .filter(|&k| cols.contains(&Column::Normal(k)))
        .count();
    if normals != 0 && normals != 3 {
        return Err(located(
            file,
            line,
            1,
            raw,
            "the header names some of the normal's columns i, j, k but not all three",
            "name all three of i, j, k, or none",
        ));
    }
    for (k, axis) in ["x", "y", "z"].iter().enumerate() {
        if !cols.contains(&Column::Coord(k)) {
            return Err(located(
                file,
                line,
                1,
                raw,
                &format!("the header has no `{axis}` column"),
                "name the coordinate columns x, y and z",
            ));
        }
    }
    Ok(cols)
}

/// Read a point file's text; `file` names it in errors. Without a header, every row is
/// exactly `x y z` (a NIST `.ds` file's count line aside); with one, its names say which
/// column is which (`id x y z`, `x y z i j k`, …), and every row has that many columns.
/// Nothing is dropped silently: a row with another number of columns is an error.
/// Decimal commas (`1,5 2 3`, `1,5;2;3`) are read as decimal points, with a note.
pub fn parse_points(text: &str, file: &str) -> Result<Vec<Point>, CliError> {
    let mut out = Vec::new();
    let mut first_data = true;
    let mut expected: Option<(usize, usize)> = None;
    let mut columns: Option<Vec<Column>> = None;
    let mut comma_note: Option<usize> = None;
    for (i, raw) in text.lines().enumerate() {
        let line = i + 1;
        let code = raw.split('#').next().unwrap_or("");
        // A header may start with `#` (`# id x y z`): read the comment's words too.
        let code = if first_data && code.trim().is_empty() {
            let after = raw.trim_start().trim_start_matches('#');
            if after
                .split([' ', '\t', ';', ','])
                .filter(|w| !w.is_empty())
                .any(|w| w.eq_ignore_ascii_case("x"))
                && after
                    .split([' ', '\t', ';', ','])
                    .filter(|w| !w.is_empty())
                    .all(|w| w.parse::<f64>().is_err())
            {
                &raw[raw.len() - after.len()..]
            } else {
                code
            }
        } else {
            code
        };
        if code.trim().is_empty() {
            continue;
        }
        let comma = decimal_commas(code);
        if comma && comma_note.is_none() {
            comma_note = Some(line);
        }
        let flds = fields(code, comma);
        let parsed: Vec<Option<f64>> = flds.iter().map(|(_, f)| f.parse::<f64>().ok()).collect();
        // A NIST `.ds` file starts with the number of points alone on its line.
        if first_data && flds.len() == 1 && flds[0].1.bytes().all(|b| b.is_ascii_digit()) {
            first_data = false;
            expected = flds[0].1.parse::<usize>().ok().map(|n| (n, line));
            continue;
        }
        if first_data
            && parsed.iter().all(Option::is_none)
            && flds.iter().any(|(_, f)| f.chars().any(char::is_alphabetic))
        {
            // A header line such as `x y z` or `id x y z i j k`.
            first_data = false;
            columns = Some(header_columns(&flds, raw, file, line)?);
            continue;
        }
        first_data = false;
        let want = columns.as_ref().map_or(3, Vec::len);
        if flds.len() != want {
            let col = if flds.len() > want {
                raw[..flds[want].0].chars().count() + 1
            } else {
                code.len() + 1
            };
            let (what, hint) = match &columns {
                None if flds.len() > 3 => (
                    format!("{} columns but no header to name them: a point is `x y z`", flds.len()),
                    "add a header line naming the columns, e.g. `id x y z` (a CMM's numbered points) or `x y z i j k`",
                ),
                None => (
                    format!("expected 3 numbers x y z, found {}", flds.len()),
                    "write each point as `x y z` (spaces, tabs or commas)",
                ),
                Some(_) => (
                    format!("{} columns, but the header names {want}", flds.len()),
                    "give every row the header's columns",
                ),
            };
            return Err(located(file, line, col, raw, &what, hint));
        }
        let cols = columns
            .clone()
            .unwrap_or_else(|| (0..3).map(Column::Coord).collect());
        let mut p = [0.0; 3];
        let mut normal = [0.0; 3];
        for (k, c) in cols.iter().enumerate() {
            if *c == Column::Id {
                continue;
            }
            let (col, f) = &flds[k];
            let col = raw[..*col].chars().count() + 1;
            let v = match parsed[k] {
                Some(v) if v.is_finite() && v.abs() > lampost_align::MAX_COORD => {
                    return Err(located(
                        file,
                        line,
                        col,
                        raw,
                        &format!("`{f}` is beyond ±1e9 of the unit: no machine measures that far"),
                        "check the units and the numbers in the file",
                    ));
                }
                // −0 and +0 are the same coordinate (`-0 0 1` is the point `0 0 1`).
                Some(v) if v.is_finite() => v + 0.0,
                _ => {
                    return Err(located(
                        file,
                        line,
                        col,
                        raw,
                        &format!("`{f}` is not a finite number"),
                        "give a plain decimal number",
                    ));
                }
            };
            match c {
                Column::Coord(a) => p[*a] = v,
                Column::Normal(a) => normal[*a] = v,
                Column::Id => {}
            }
        }
        let has_normal = cols.iter().any(|c| matches!(c, Column::Normal(_)));
        out.push(Point {
            p,
            line,
            normal: has_normal.then_some(normal),
        });
    }
    if let Some((n, line)) = expected {
        if n != out.len() {
            let first = text.lines().nth(line - 1).unwrap_or("");
            return Err(located(
                file,
                line,
                1,
                first,
                &format!("the count line says {n} points, the file has {}", out.len()),
                "correct the count, or remove the line",
            ));
        }
    }
    if let Some(line) = comma_note {
        eprintln!(
            "note: {file}:{line}: decimal commas (`1,5`) read as decimal points; export with points to be sure"
        );
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reads_every_layout() {
        let pts =
            parse_points("x,y,z\n1 2 3\n# note\n4\t5\t6 # tail\n\n7,8,9\n", "f").expect("reads");
        assert_eq!(pts.len(), 3);
        assert_eq!(pts[2].p, [7.0, 8.0, 9.0]);
        assert_eq!(pts[2].line, 6);
    }

    #[test]
    fn nist_count_line() {
        let pts = parse_points("2\n1\t2\t3\n4\t5\t6\n", "f.ds").expect("reads");
        assert_eq!(pts.len(), 2);
        let e = parse_points("3\n1\t2\t3\n", "f.ds").expect_err("count");
        assert!(e.message.contains("says 3 points"), "{}", e.message);
    }

    #[test]
    fn negative_zero_is_zero() {
        let pts = parse_points("-0 0 1\n0 -0.0 1\n", "f").expect("reads");
        assert_eq!(pts[0].p[0].to_bits(), 0.0f64.to_bits());
        assert_eq!(pts[1].p[1].to_bits(), 0.0f64.to_bits());
    }

    #[test]
    fn huge_numbers_are_located() {
        let e = parse_points("1 2 3\n1 1e200 6\n", "pts.txt").expect_err("huge");
        assert!(e.message.contains("pts.txt:2:3"), "{}", e.message);
        assert!(e.message.contains("beyond"), "{}", e.message);
    }

    #[test]
    fn bad_numbers_are_located() {
        let e = parse_points("1 2 3\n4 abc 6\n", "pts.txt").expect_err("bad");
        assert!(e.message.contains("pts.txt:2:3"), "{}", e.message);
        let e = parse_points("1 2 NaN\n", "pts.txt").expect_err("nan");
        assert!(e.message.contains("pts.txt:1:5"), "{}", e.message);
        let e = parse_points("1 2\n", "pts.txt").expect_err("short");
        assert!(e.message.contains("expected 3 numbers"), "{}", e.message);
    }

    #[test]
    fn a_header_names_the_columns() {
        // A CMM export: numbered points.
        let pts = parse_points("n x y z\n1 10 20 30\n2 11 21 31\n", "cmm.txt").expect("reads");
        assert_eq!(pts[0].p, [10.0, 20.0, 30.0]);
        assert_eq!(pts[1].line, 3);
        // Columns in any order, a normal, text ids, a `#` header.
        let pts = parse_points("# id,z,y,x,i,j,k\nP1,3,2,1,0,0,1\n", "f").expect("reads");
        assert_eq!(pts[0].p, [1.0, 2.0, 3.0]);
        // The same file without its header is refused, not misread as x=1, y=10, z=20.
        let e = parse_points("1 10 20 30\n", "cmm.txt").expect_err("4 columns");
        assert!(
            e.message.contains("4 columns but no header"),
            "{}",
            e.message
        );
        assert!(e.message.contains("cmm.txt:1:9"), "{}", e.message);
        assert!(e.message.contains("id x y z"), "{}", e.message);
    }

    #[test]
    fn bad_headers_and_ragged_rows_are_located() {
        let e = parse_points("x y z temp\n1 2 3 20\n", "f").expect_err("unknown");
        assert!(
            e.message.contains("unknown column `temp`") && e.message.contains("f:1:7"),
            "{}",
            e.message
        );
        let e = parse_points("x y x\n1 2 3\n", "f").expect_err("twice");
        assert!(e.message.contains("twice"), "{}", e.message);
        let e = parse_points("id x y\n1 2 3\n", "f").expect_err("no z");
        assert!(e.message.contains("no `z` column"), "{}", e.message);
        let e = parse_points("id x y z\n1 2 3 4\n5 6 7\n", "f").expect_err("ragged");
        assert!(
            e.message.contains("3 columns, but the header names 4") && e.message.contains("f:3:"),
            "{}",
            e.message
        );
        let e = parse_points("x y z\n1 2 3\n4 5 6 7\n", "f").expect_err("extra");
        assert!(
            e.message.contains("4 columns, but the header names 3") && e.message.contains("f:3:7"),
            "{}",
            e.message
        );
    }

    #[test]
    fn decimal_commas_are_recognised() {
        for text in [
            "1,5 2,25 -0,5\n3 4 5\n",
            "1,5;2,25;-0,5\n3;4;5\n",
            "x;y;z\n1,5;2,25;-0,5\n3;4;5\n",
        ] {
            let pts = parse_points(text, "f").expect("reads");
            assert_eq!(pts[0].p, [1.5, 2.25, -0.5], "{text}");
            assert_eq!(pts[1].p, [3.0, 4.0, 5.0]);
        }
        // Comma-separated values are not decimal commas.
        for text in ["1,2,3\n", "1.5, 2, 3\n", "1 ,2 ,3\n"] {
            let pts = parse_points(text, "f").expect("reads");
            assert_eq!(pts[0].p[2], 3.0, "{text}");
        }
    }
}
