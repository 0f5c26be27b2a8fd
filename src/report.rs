//! Plots for the user (DESIGN.md §5 `report`): a dependency-free SVG of the speed/accuracy
//! trade (wall time vs verified max ε, both logarithmic), one polyline per method.

use std::fmt::Write as _;

/// One point of a series: x (s), y (ε), label.
pub type Point = (f64, f64, String);

/// Log–log SVG plot of `series` (name, points); non-positive values are skipped.
pub fn tradeoff_svg(title: &str, series: &[(String, Vec<Point>)]) -> String {
    let (w, h, m) = (720.0, 460.0, 70.0);
    let pts = series
        .iter()
        .flat_map(|s| s.1.iter())
        .filter(|p| p.0 > 0.0 && p.1 > 0.0);
    let (mut x0, mut x1, mut y0, mut y1) = (
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::INFINITY,
        f64::NEG_INFINITY,
    );
    for p in pts {
        x0 = x0.min(p.0.log10());
        x1 = x1.max(p.0.log10());
        y0 = y0.min(p.1.log10());
        y1 = y1.max(p.1.log10());
    }
    if !x0.is_finite() {
        (x0, x1, y0, y1) = (0.0, 1.0, 0.0, 1.0);
    }
    let (x0, x1, y0, y1) = (
        x0.floor(),
        x1.ceil().max(x0.floor() + 1.0),
        y0.floor(),
        y1.ceil().max(y0.floor() + 1.0),
    );
    let px = |x: f64| m + (x.log10() - x0) / (x1 - x0) * (w - 2.0 * m);
    let py = |y: f64| h - m - (y.log10() - y0) / (y1 - y0) * (h - 2.0 * m);
    let mut s = String::new();
    let _ = writeln!(
        s,
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="{w}" height="{h}" font-family="sans-serif" font-size="12">"#
    );
    let _ = writeln!(s, r#"<rect width="100%" height="100%" fill="white"/>"#);
    let _ = writeln!(
        s,
        r#"<text x="{}" y="24" text-anchor="middle" font-size="15">{title}</text>"#,
        w / 2.0
    );
    for d in (x0 as i32)..=(x1 as i32) {
        let x = px(10f64.powi(d));
        let _ = writeln!(
            s,
            r##"<line x1="{x}" y1="{m}" x2="{x}" y2="{}" stroke="#ddd"/><text x="{x}" y="{}" text-anchor="middle">1e{d}</text>"##,
            h - m,
            h - m + 18.0
        );
    }
    for d in (y0 as i32)..=(y1 as i32) {
        let y = py(10f64.powi(d));
        let _ = writeln!(
            s,
            r##"<line x1="{m}" y1="{y}" x2="{}" y2="{y}" stroke="#ddd"/><text x="{}" y="{}" text-anchor="end">1e{d}</text>"##,
            w - m,
            m - 6.0,
            y + 4.0
        );
    }
    let _ = writeln!(
        s,
        r#"<text x="{}" y="{}" text-anchor="middle">wall time of the reduction (s)</text>"#,
        w / 2.0,
        h - 20.0
    );
    let _ = writeln!(
        s,
        r#"<text x="18" y="{}" text-anchor="middle" transform="rotate(-90 18 {})">verified max ε (fine grid)</text>"#,
        h / 2.0,
        h / 2.0
    );
    let colors = ["#1f77b4", "#d62728", "#2ca02c", "#9467bd"];
    for (k, (name, points)) in series.iter().enumerate() {
        let c = colors[k % colors.len()];
        let valid: Vec<&Point> = points.iter().filter(|p| p.0 > 0.0 && p.1 > 0.0).collect();
        let path: Vec<String> = valid
            .iter()
            .map(|p| format!("{:.1},{:.1}", px(p.0), py(p.1)))
            .collect();
        let _ = writeln!(
            s,
            r#"<polyline points="{}" fill="none" stroke="{c}" stroke-width="2"/>"#,
            path.join(" ")
        );
        for p in valid {
            let _ = writeln!(
                s,
                r#"<circle cx="{:.1}" cy="{:.1}" r="4" fill="{c}"/><text x="{:.1}" y="{:.1}" fill="{c}">{}</text>"#,
                px(p.0),
                py(p.1),
                px(p.0) + 6.0,
                py(p.1) - 6.0,
                p.2
            );
        }
        let _ = writeln!(
            s,
            r#"<rect x="{}" y="{}" width="14" height="4" fill="{c}"/><text x="{}" y="{}">{name}</text>"#,
            w - m - 200.0,
            m + 10.0 + 18.0 * k as f64,
            w - m - 180.0,
            m + 15.0 + 18.0 * k as f64
        );
    }
    s.push_str("</svg>\n");
    s
}
