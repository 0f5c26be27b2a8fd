//! Parsing and formatting helpers shared by the commands: DoF and frequency lists, bands,
//! triples; frequencies and byte counts as text.

use sparsemor::{Error, Result};

/// Parses `AxBxC` into three values.
pub fn parse_triple<T: std::str::FromStr>(s: &str, what: &str) -> Result<[T; 3]> {
    let parts: Vec<&str> = s.split(['x', 'X']).collect();
    let bad = || Error::InvalidSetting(format!("{what} '{s}': expected three values like 2x3x45"));
    if parts.len() != 3 {
        return Err(bad());
    }
    let v: Vec<T> = parts
        .iter()
        .map(|p| p.trim().parse::<T>().map_err(|_| bad()))
        .collect::<Result<_>>()?;
    let mut it = v.into_iter();
    Ok([
        it.next().ok_or_else(bad)?,
        it.next().ok_or_else(bad)?,
        it.next().ok_or_else(bad)?,
    ])
}

/// Parses `LO:HI` (Hz).
pub fn parse_band(s: &str) -> Result<[f64; 2]> {
    let bad = || Error::InvalidSetting(format!("--band '{s}': expected LO:HI in Hz, e.g. 1:1000"));
    let (a, b) = s.split_once(':').ok_or_else(bad)?;
    let band: [f64; 2] = [
        a.trim().parse().map_err(|_| bad())?,
        b.trim().parse().map_err(|_| bad())?,
    ];
    if !(band[0] >= 0.0 && band[1] > band[0] && band[1].is_finite()) {
        return Err(Error::InvalidSetting(format!(
            "--band '{s}': need 0 <= LO < HI (empty band)"
        )));
    }
    Ok(band)
}

/// Parses a comma-separated list of numbers.
pub fn parse_list<T: std::str::FromStr>(s: &str, what: &str) -> Result<Vec<T>> {
    s.split(',')
        .map(|p| {
            p.trim().parse::<T>().map_err(|_| {
                Error::InvalidSetting(format!("{what}: '{}' is not a valid value", p.trim()))
            })
        })
        .collect()
}

/// A frequency (Hz) with `decimals` decimals. A rigid mode, which the library reports at
/// exactly 0 Hz (`Modes::freqs_hz`, `metrics::rom_spectrum`), is `0`; any other value that
/// would print as zero is written in scientific notation, so no frequency reads `-0.0`.
pub fn hz(f: f64, decimals: usize) -> String {
    if f == 0.0 {
        return "0".into();
    }
    let s = format!("{f:.decimals$}");
    if s.bytes().all(|b| matches!(b, b'-' | b'0' | b'.')) {
        format!("{f:.1e}")
    } else {
        s
    }
}

/// Frequencies (Hz) as [`hz`] writes each, joined by `sep`.
pub fn hz_list(freqs: &[f64], decimals: usize, sep: &str) -> String {
    freqs
        .iter()
        .map(|&f| hz(f, decimals))
        .collect::<Vec<_>>()
        .join(sep)
}

/// A memory budget given in GB (`--memory-gb`), in bytes: a finite number above 0.
pub fn gigabytes(s: &str) -> std::result::Result<usize, String> {
    match s.trim().parse::<f64>() {
        Ok(g) if g.is_finite() && g > 0.0 => Ok((g * 1e9) as usize),
        _ => Err(format!(
            "{s:?} is no memory budget: give the GB as a number above 0, e.g. 8"
        )),
    }
}

/// 1234567 → "1.2 MB".
pub fn human_bytes(b: f64) -> String {
    let units = ["B", "kB", "MB", "GB", "TB"];
    let mut v = b;
    let mut u = 0;
    while v >= 1000.0 && u + 1 < units.len() {
        v /= 1000.0;
        u += 1;
    }
    format!("{v:.1} {}", units[u])
}
