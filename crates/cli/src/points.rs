//! Point files: `x y z` per line, separated by spaces, tabs or commas; an optional header
//! line; `#` comments; blank lines ignored.

use crate::report::CliError;

/// A point and the line it came from.
#[derive(Debug, Clone, Copy)]
pub struct Point {
    /// Coordinates.
    pub p: [f64; 3],
    /// 1-based source line.
    pub line: usize,
}

fn located(file: &str, line: usize, col: usize, text: &str, what: &str, hint: &str) -> CliError {
    let num = line.to_string();
    let pad = " ".repeat(num.len());
    CliError::failed(format!(
        "error: {what}\n{pad}--> {file}:{line}:{col}\n{pad} |\n{num} | {text}\n{pad} | {}^\n  = help: {hint}\n",
        " ".repeat(col.saturating_sub(1))
    ))
}

/// Read a point file's text; `file` names it in errors. Lines with more than three
/// columns keep the first three (NIST `.ds` files have exactly three).
pub fn parse_points(text: &str, file: &str) -> Result<Vec<Point>, CliError> {
    let mut out = Vec::new();
    let mut first_data = true;
    let mut expected: Option<(usize, usize)> = None;
    for (i, raw) in text.lines().enumerate() {
        let line = i + 1;
        let code = raw.split('#').next().unwrap_or("");
        if code.trim().is_empty() {
            continue;
        }
        // Fields and their columns.
        let mut fields = Vec::new();
        let mut start = None;
        for (pos, ch) in code.char_indices() {
            let sep = ch == ' ' || ch == '\t' || ch == ',' || ch == ';';
            match (sep, start) {
                (false, None) => start = Some(pos),
                (true, Some(s)) => {
                    fields.push((s, &code[s..pos]));
                    start = None;
                }
                _ => {}
            }
        }
        if let Some(s) = start {
            fields.push((s, &code[s..]));
        }
        let parsed: Vec<Option<f64>> = fields.iter().map(|(_, f)| f.parse::<f64>().ok()).collect();
        // A NIST `.ds` file starts with the number of points alone on its line.
        if first_data && fields.len() == 1 && fields[0].1.bytes().all(|b| b.is_ascii_digit()) {
            first_data = false;
            expected = fields[0].1.parse::<usize>().ok().map(|n| (n, line));
            continue;
        }
        if first_data
            && parsed.iter().all(Option::is_none)
            && fields
                .iter()
                .any(|(_, f)| f.chars().any(char::is_alphabetic))
        {
            // A header line such as `x y z`.
            first_data = false;
            continue;
        }
        first_data = false;
        if fields.len() < 3 {
            let col = code.len() + 1;
            return Err(located(
                file,
                line,
                col,
                raw,
                &format!("expected 3 numbers x y z, found {}", fields.len()),
                "write each point as `x y z` (spaces, tabs or commas)",
            ));
        }
        let mut p = [0.0; 3];
        for k in 0..3 {
            let (col, f) = fields[k];
            match parsed[k] {
                Some(v) if v.is_finite() && v.abs() > lampost_align::MAX_COORD => {
                    let col = raw[..col].chars().count() + 1;
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
                Some(v) if v.is_finite() => p[k] = v + 0.0,
                _ => {
                    let col = raw[..col].chars().count() + 1;
                    return Err(located(
                        file,
                        line,
                        col,
                        raw,
                        &format!("`{f}` is not a finite number"),
                        "give a plain decimal number",
                    ));
                }
            }
        }
        out.push(Point { p, line });
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
}
