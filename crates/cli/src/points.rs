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
                Some(v) if v.is_finite() => p[k] = v,
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
    fn bad_numbers_are_located() {
        let e = parse_points("1 2 3\n4 abc 6\n", "pts.txt").expect_err("bad");
        assert!(e.message.contains("pts.txt:2:3"), "{}", e.message);
        let e = parse_points("1 2 NaN\n", "pts.txt").expect_err("nan");
        assert!(e.message.contains("pts.txt:1:5"), "{}", e.message);
        let e = parse_points("1 2\n", "pts.txt").expect_err("short");
        assert!(e.message.contains("expected 3 numbers"), "{}", e.message);
    }
}
