//! Node coordinate tables ([`read_node_table`]): rows `node x y z` with any separator and a
//! decimal point or a decimal comma, as given with ANSYS files (docs/design.md §4,
//! "Importers").

use super::types::NodeTable;
use crate::io::text::{first_fields, first_nonblank_line, par_lines, parse_u64, show};
use crate::{Error, Result};
use std::path::Path;

/// True when `head` (a file's first bytes) has a line that is not blank. The dispatcher asks
/// this last: a text file that no other reader recognizes is taken as a node table.
pub(crate) fn looks_like(head: &[u8]) -> bool {
    !first_nonblank_line(head).is_empty()
}

/// Reads a node coordinate table: rows `node x y z` (further columns ignored) separated by
/// tabs, semicolons or spaces, or by commas when a row has none of those; numbers with a
/// decimal point or a decimal comma (`0,15`, `1,e-001`, `5,e-002` as the German-locale ANSYS
/// export of `ansys_rotor_exudyn/` writes them). Leading lines whose first field is not a
/// number are headers; a header field like `X-Position (m)` names the length unit.
///
/// # Errors
/// [`Error::Parse`] with the line: fewer than 4 fields, a number that is neither (`1.000,5`,
/// `1,2,3` in one field), a node number that is not a positive integer.
pub fn read_node_table(path: &Path) -> Result<NodeTable> {
    /// A line of the table, parsed on its own ([`par_lines`]): whether it is a header line
    /// depends on the lines before it, so a line whose first field is no number carries both
    /// readings — the unit a header line may name, and the error it is as a data line.
    enum Line {
        Row(u64, [f64; 3]),
        Text(Option<String>, Error),
    }
    let parse = |line: usize, bytes: &[u8]| -> Result<Option<Line>> {
        let (f, count) = first_fields::<4>(table_fields(bytes));
        if count == 0 {
            return Ok(None);
        }
        let as_data = || -> Result<Line> {
            if count < 4 {
                return Err(Error::parse(
                    path,
                    line,
                    format!(
                        "expected `node x y z`, found {count} field(s) (separators: tab, semicolon, space or comma)"
                    ),
                ));
            }
            let node = parse_u64(f[0], path, line, "node number")?;
            let mut xyz = [0.0; 3];
            for (c, f) in xyz.iter_mut().zip(&f[1..4]) {
                *c = parse_locale_number(f).ok_or_else(|| {
                    Error::parse(
                        path,
                        line,
                        format!(
                            "coordinate '{}' is not a number with a decimal point or a decimal comma",
                            show(f)
                        ),
                    )
                })?;
            }
            Ok(Line::Row(node, xyz))
        };
        if std::str::from_utf8(f[0]).is_ok_and(|t| t.parse::<u64>().is_ok()) {
            return as_data().map(Some);
        }
        let unit = table_fields(bytes).find_map(|f| {
            let f = String::from_utf8_lossy(f);
            let (_, rest) = f.split_once('(')?;
            Some(rest.split_once(')')?.0.trim().to_string())
        });
        let error = as_data()
            .err()
            .unwrap_or_else(|| Error::parse(path, line, "not a node line"));
        Ok(Some(Line::Text(unit, error)))
    };
    let mut table = NodeTable::default();
    let mut in_header = true;
    par_lines(path, parse, |_, l| {
        match l {
            Line::Row(node, xyz) => {
                in_header = false;
                table.rows.push((node, xyz));
            }
            Line::Text(_, error) if !in_header => return Err(error),
            Line::Text(unit, _) => {
                if table.length_unit.is_none() {
                    table.length_unit = unit;
                }
            }
        }
        Ok(())
    })?;
    Ok(table)
}

/// The fields of a node-table line: split at tabs and semicolons when the line has one, else
/// at blanks when the trimmed line has some, else at commas; trimmed, empty ones dropped.
fn table_fields(line: &[u8]) -> impl Iterator<Item = &[u8]> {
    let sep: fn(&u8) -> bool = if line.iter().any(|&b| b == b'\t' || b == b';') {
        |&b| b == b'\t' || b == b';'
    } else if line.trim_ascii().iter().any(u8::is_ascii_whitespace) {
        u8::is_ascii_whitespace
    } else {
        |&b| b == b','
    };
    line.split(sep)
        .map(<[u8]>::trim_ascii)
        .filter(|f| !f.is_empty())
}

/// A number with a decimal point or one decimal comma (`0,15` → 0.15; `1,e-001` → 0.1);
/// `None` for anything else (`1.000,5`, `1,2,3`, non-finite).
fn parse_locale_number(s: &[u8]) -> Option<f64> {
    let mut buf = [0u8; 64];
    let s = match (s.iter().filter(|&&b| b == b',').count(), s.contains(&b'.')) {
        (0, _) => s,
        (1, false) if s.len() <= buf.len() => {
            let buf = &mut buf[..s.len()];
            buf.copy_from_slice(s);
            buf.iter_mut()
                .filter(|b| **b == b',')
                .for_each(|b| *b = b'.');
            buf
        }
        _ => return None,
    };
    fast_float2::parse::<f64, _>(s)
        .ok()
        .filter(|v| v.is_finite())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn locale_numbers() {
        let p = |s: &str| parse_locale_number(s.as_bytes());
        assert_eq!(p("0,15"), Some(0.15));
        assert_eq!(p("1,e-001"), Some(0.1));
        assert_eq!(p("-5,e-002"), Some(-0.05));
        assert_eq!(p("0,"), Some(0.0));
        assert_eq!(p("2.5e3"), Some(2500.0));
        assert_eq!(p("1.000,5"), None);
        assert_eq!(p("1,2,3"), None);
        assert_eq!(p("inf"), None);
    }
}
