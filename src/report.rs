//! Plots for the user (docs/design.md §7 `report`, `tradeoff --svg`), drawn with the
//! `plotters` crate's SVG backend (pure Rust, no system library): line/marker charts on
//! linear or logarithmic axes ([`chart_svg`]), heat maps ([`heat_map_svg`]) and the
//! speed/accuracy trade of `sparsemor tradeoff` ([`tradeoff_svg`], its CSV rows
//! [`TradeoffRow`]). Every function returns the SVG text; nothing is printed or written.

use crate::{Error, Result};
use plotters::coord::ranged1d::{AsRangedCoord, Ranged, ValueFormatter};
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use std::path::Path;

/// How a series is drawn.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Draw {
    /// A solid line through the points.
    Line,
    /// A dashed line through the points.
    Dashed,
    /// A marker at each point.
    Markers,
    /// A solid line with a marker at each point.
    LineMarkers,
}

/// One named series of a chart.
#[derive(Clone, Debug)]
pub struct Series {
    /// Legend entry.
    pub name: String,
    /// (x, y) points; on a logarithmic axis non-positive values are left out.
    pub points: Vec<(f64, f64)>,
    /// Colour: index into the palette ([`color`]); 0 is black.
    pub color: usize,
    /// Line, dashes or markers.
    pub draw: Draw,
    /// A text next to each point (empty: none).
    pub labels: Vec<String>,
}

/// A chart: axes, their scales and the series drawn on them.
#[derive(Clone, Debug)]
pub struct Chart {
    /// Caption.
    pub title: String,
    /// x-axis description.
    pub x_label: String,
    /// y-axis description.
    pub y_label: String,
    /// Logarithmic x-axis.
    pub x_log: bool,
    /// Logarithmic y-axis.
    pub y_log: bool,
    /// The series, drawn in order (the legend lists them in the same order).
    pub series: Vec<Series>,
    /// The x-axis range; `None`: from the data.
    pub x_range: Option<(f64, f64)>,
}

/// Width and height of a chart (px), the legend's column included.
const CHART_SIZE: (u32, u32) = (1100, 420);

/// Width of the legend column right of the plot (px).
const LEGEND_WIDTH: u32 = 230;

/// Palette colour `k`: black, then a qualitative palette (tab10) repeating.
pub fn color(k: usize) -> RGBColor {
    const TAB: [RGBColor; 8] = [
        RGBColor(31, 119, 180),
        RGBColor(214, 39, 40),
        RGBColor(44, 160, 44),
        RGBColor(148, 103, 189),
        RGBColor(255, 127, 14),
        RGBColor(140, 86, 75),
        RGBColor(227, 119, 194),
        RGBColor(23, 190, 207),
    ];
    match k {
        0 => BLACK,
        k => TAB[(k - 1) % TAB.len()],
    }
}

fn plot_error(title: &str, e: impl std::fmt::Display) -> Error {
    Error::InvalidSetting(format!("plot '{title}': {e}"))
}

/// The axis range of `values`: whole decades on a logarithmic axis (non-positive values
/// ignored), the data range on a linear one; [0, 1] or [1, 10] when nothing is left.
fn axis_range(values: impl Iterator<Item = f64>, log: bool) -> (f64, f64) {
    let (lo, hi) = values
        .filter(|v| v.is_finite() && (!log || *v > 0.0))
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
            (lo.min(v), hi.max(v))
        });
    match (log, lo.is_finite()) {
        (true, true) => {
            let (a, b) = (lo.log10().floor(), hi.log10().ceil());
            // a hair below the lower decade, so that plotters (which rounds log10 of the
            // bound up to find its first tick) labels that decade too
            (10f64.powf(a) * (1.0 - 1e-9), 10f64.powf(b.max(a + 1.0)))
        }
        (true, false) => (1.0, 10.0),
        (false, true) if hi > lo => (lo, hi),
        (false, true) => (lo - 0.5, hi + 0.5),
        (false, false) => (0.0, 1.0),
    }
}

/// `v` in the shortest readable form: "1e-3" for powers of ten, else 3 significant digits.
fn tick(v: f64) -> String {
    let l = v.abs().log10();
    if v != 0.0 && (l - l.round()).abs() < 1e-9 && !(0.0..=3.0).contains(&l.round()) {
        format!("1e{}", l.round())
    } else if v != 0.0 && (v.abs() < 1e-2 || v.abs() >= 1e5) {
        format!("{v:.1e}")
    } else {
        format!("{}", (v * 1e3).round() / 1e3)
    }
}

/// SVG of `c` (1100 × 420 px): one line or marker set per series, the legend right of the plot.
///
/// # Errors
/// [`Error::InvalidSetting`] naming the chart if plotters fails to draw it.
pub fn chart_svg(c: &Chart) -> Result<String> {
    let xr = c.x_range.unwrap_or_else(|| {
        axis_range(
            c.series.iter().flat_map(|s| s.points.iter().map(|p| p.0)),
            c.x_log,
        )
    });
    let yr = axis_range(
        c.series.iter().flat_map(|s| s.points.iter().map(|p| p.1)),
        c.y_log,
    );
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, CHART_SIZE).into_drawing_area();
        let (x, y) = (xr.0..xr.1, yr.0..yr.1);
        match (c.x_log, c.y_log) {
            (false, false) => draw_chart(&root, c, x, y),
            (false, true) => draw_chart(&root, c, x, y.log_scale()),
            (true, false) => draw_chart(&root, c, x.log_scale(), y),
            (true, true) => draw_chart(&root, c, x.log_scale(), y.log_scale()),
        }
        .map_err(|e| plot_error(&c.title, e))?;
        root.present().map_err(|e| plot_error(&c.title, e))?;
    }
    Ok(svg)
}

type DrawResult = std::result::Result<(), DrawingAreaErrorKind<std::io::Error>>;

fn draw_chart<X, Y>(root: &DrawingArea<SVGBackend<'_>, Shift>, c: &Chart, x: X, y: Y) -> DrawResult
where
    X: AsRangedCoord<Value = f64>,
    Y: AsRangedCoord<Value = f64>,
    X::CoordDescType: Ranged<ValueType = f64> + ValueFormatter<f64>,
    Y::CoordDescType: Ranged<ValueType = f64> + ValueFormatter<f64>,
{
    root.fill(&WHITE)?;
    let mut chart = ChartBuilder::on(root)
        .caption(&c.title, ("sans-serif", 17))
        .margin(12)
        .margin_right(LEGEND_WIDTH)
        .x_label_area_size(45)
        .y_label_area_size(70)
        .build_cartesian_2d(x, y)?;
    chart
        .configure_mesh()
        .x_desc(c.x_label.as_str())
        .y_desc(c.y_label.as_str())
        .x_label_formatter(&|v| tick(*v))
        .y_label_formatter(&|v| tick(*v))
        .light_line_style(RGBColor(235, 235, 235))
        .label_style(("sans-serif", 12))
        .axis_desc_style(("sans-serif", 14))
        .draw()?;
    let (x_log, y_log) = (c.x_log, c.y_log);
    let shown = |p: &&(f64, f64)| {
        p.0.is_finite() && p.1.is_finite() && (!x_log || p.0 > 0.0) && (!y_log || p.1 > 0.0)
    };
    for s in &c.series {
        let col = color(s.color);
        let pts: Vec<(f64, f64)> = s.points.iter().filter(shown).copied().collect();
        let line = ShapeStyle::from(&col).stroke_width(2);
        if matches!(s.draw, Draw::Line | Draw::LineMarkers) {
            chart.draw_series(std::iter::once(PathElement::new(pts.clone(), line)))?;
        }
        if s.draw == Draw::Dashed {
            chart.draw_series(DashedLineSeries::new(pts.clone(), 8, 5, line))?;
        }
        if matches!(s.draw, Draw::Markers | Draw::LineMarkers) {
            chart.draw_series(pts.iter().map(|&p| Circle::new(p, 4, col.filled())))?;
        }
        chart.draw_series(
            s.points
                .iter()
                .zip(&s.labels)
                .filter(|(p, _)| shown(p))
                .map(|(&p, l)| {
                    EmptyElement::at(p)
                        + Text::new(
                            l.clone(),
                            (6, -14),
                            ("sans-serif", 11).into_font().color(&col),
                        )
                }),
        )?;
    }
    // the legend in its own column right of the plot, clear of the data
    let (px, py) = chart.plotting_area().get_base_pixel();
    let x = px + chart.plotting_area().dim_in_pixel().0 as i32 + 16;
    for (k, s) in c.series.iter().enumerate() {
        let (col, y) = (color(s.color), py + 8 + 20 * k as i32);
        let line = ShapeStyle::from(&col).stroke_width(2);
        match s.draw {
            Draw::Line | Draw::LineMarkers => {
                root.draw(&PathElement::new(vec![(x, y), (x + 24, y)], line))?
            }
            Draw::Dashed => {
                for dash in [x, x + 16] {
                    root.draw(&PathElement::new(vec![(dash, y), (dash + 8, y)], line))?;
                }
            }
            Draw::Markers => {}
        }
        if matches!(s.draw, Draw::Markers | Draw::LineMarkers) {
            root.draw(&Circle::new((x + 12, y), 4, col.filled()))?;
        }
        root.draw(&Text::new(
            s.name.clone(),
            (x + 32, y - 7),
            ("sans-serif", 13).into_font(),
        ))?;
    }
    Ok(())
}

/// A matrix of values in [0, 1] drawn as coloured cells (white 0 → dark blue 1) with the
/// value printed in each cell.
#[derive(Clone, Debug)]
pub struct HeatMap {
    /// Caption.
    pub title: String,
    /// x-axis (column) description.
    pub x_label: String,
    /// y-axis (row) description.
    pub y_label: String,
    /// Column tick labels, left to right.
    pub columns: Vec<String>,
    /// Row tick labels, bottom to top.
    pub rows: Vec<String>,
    /// `values[r][c]`, row r from the bottom.
    pub values: Vec<Vec<f64>>,
}

/// SVG of `h`: 40 px cells (at least 300 px of plot each way) plus axes and labels.
///
/// # Errors
/// [`Error::InvalidSetting`] naming the heat map if it is empty or plotters fails.
pub fn heat_map_svg(h: &HeatMap) -> Result<String> {
    let (nc, nr) = (h.columns.len(), h.rows.len());
    if nc == 0 || nr == 0 || h.values.len() != nr || h.values.iter().any(|r| r.len() != nc) {
        return Err(plot_error(
            &h.title,
            "no cells, or values do not match the labels",
        ));
    }
    let cell = 40u32;
    let size = (
        (nc as u32 * cell).max(300) + 110,
        (nr as u32 * cell).max(300) + 110,
    );
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, size).into_drawing_area();
        draw_heat_map(&root, h).map_err(|e| plot_error(&h.title, e))?;
        root.present().map_err(|e| plot_error(&h.title, e))?;
    }
    Ok(svg)
}

fn draw_heat_map(root: &DrawingArea<SVGBackend<'_>, Shift>, h: &HeatMap) -> DrawResult {
    let (nc, nr) = (h.columns.len(), h.rows.len());
    root.fill(&WHITE)?;
    let mut chart = ChartBuilder::on(root)
        .caption(&h.title, ("sans-serif", 15))
        .margin(10)
        .x_label_area_size(45)
        .y_label_area_size(60)
        .build_cartesian_2d(0.0..nc as f64, 0.0..nr as f64)?;
    // ticks at the cell centres, labelled by the cell's name
    let name = |names: &[String], v: f64| {
        let k = v.floor();
        if (v - k - 0.5).abs() < 1e-6 && k >= 0.0 {
            names.get(k as usize).cloned().unwrap_or_default()
        } else {
            String::new()
        }
    };
    chart
        .configure_mesh()
        .disable_mesh()
        .x_labels(2 * nc + 1)
        .y_labels(2 * nr + 1)
        .x_label_formatter(&|v| name(&h.columns, *v))
        .y_label_formatter(&|v| name(&h.rows, *v))
        .x_desc(h.x_label.as_str())
        .y_desc(h.y_label.as_str())
        .label_style(("sans-serif", 11))
        .axis_desc_style(("sans-serif", 13))
        .draw()?;
    let shade = |v: f64| {
        let t = v.clamp(0.0, 1.0);
        let mix = |a: f64, b: f64| (a + (b - a) * t).round() as u8;
        RGBColor(mix(255.0, 8.0), mix(255.0, 48.0), mix(255.0, 107.0))
    };
    for (r, row) in h.values.iter().enumerate() {
        for (c, &v) in row.iter().enumerate() {
            let (x, y) = (c as f64, r as f64);
            chart.draw_series(std::iter::once(Rectangle::new(
                [(x, y), (x + 1.0, y + 1.0)],
                shade(v).filled(),
            )))?;
            let ink = if v > 0.5 { WHITE } else { BLACK };
            chart.draw_series(std::iter::once(Text::new(
                format!("{v:.2}"),
                (x + 0.5, y + 0.5),
                ("sans-serif", 10)
                    .into_font()
                    .color(&ink)
                    .pos(Pos::new(HPos::Center, VPos::Center)),
            )))?;
        }
    }
    Ok(())
}

/// One row of `sparsemor tradeoff --csv`: a reduction and its verified accuracy.
#[derive(Clone, Debug, PartialEq)]
pub struct TradeoffRow {
    /// `linefit`, `serep` or `craig-bampton`.
    pub method: String,
    /// What was asked: "tol 1e-3", "9 modes".
    pub setting: String,
    /// Wall time of the reduction (s).
    pub seconds: f64,
    /// Factorizations it spent.
    pub factorizations: usize,
    /// Full solves at frequencies (line-fitting: the sampling loop's; `None` for methods that
    /// solve none).
    pub solves: Option<usize>,
    /// ROM order.
    pub order: usize,
    /// Verified max elastic ε (eq. 23) on the fine grid.
    pub max_eps: f64,
}

impl TradeoffRow {
    /// The CSV header line.
    pub const CSV_HEADER: &'static str =
        "method,setting,seconds,factorizations,order,max_eps,solves";

    /// The header of files written before the `solves` column.
    const CSV_HEADER_V1: &'static str = "method,setting,seconds,factorizations,order,max_eps";

    /// `rows` as CSV (header + one line each, floats round-trip exactly).
    pub fn to_csv(rows: &[TradeoffRow]) -> String {
        let mut s = format!("{}\n", Self::CSV_HEADER);
        for r in rows {
            s.push_str(&format!(
                "{},{},{:?},{},{},{:?},{}\n",
                r.method,
                r.setting,
                r.seconds,
                r.factorizations,
                r.order,
                r.max_eps,
                r.solves.map_or(String::new(), |n| n.to_string())
            ));
        }
        s
    }

    /// For each line-fitting row, the fastest Craig–Bampton row at least as accurate (verified
    /// max ε ≤ line-fitting's), as indices into `rows`: the comparison at equal verified
    /// accuracy (docs/performance.md, "Speed and accuracy"); `None` when no Craig–Bampton row
    /// reaches it.
    pub fn equal_accuracy(rows: &[TradeoffRow]) -> Vec<(usize, Option<usize>)> {
        let of = |m: &'static str| (0..rows.len()).filter(move |&i| rows[i].method == m);
        of("linefit")
            .map(|l| {
                let cb = of("craig-bampton")
                    .filter(|&c| rows[c].max_eps <= rows[l].max_eps)
                    .min_by(|&a, &b| rows[a].seconds.total_cmp(&rows[b].seconds));
                (l, cb)
            })
            .collect()
    }

    /// Parses [`Self::to_csv`]'s text; `path` names the file in errors.
    ///
    /// # Errors
    /// [`Error::Parse`] with the line for a wrong header, field count or number.
    pub fn parse_csv(text: &str, path: &Path) -> Result<Vec<TradeoffRow>> {
        let err = |line: usize, msg: String| Error::Parse {
            path: path.to_path_buf(),
            line,
            msg,
        };
        let mut lines = text
            .lines()
            .enumerate()
            .filter(|(_, l)| !l.trim().is_empty());
        let fields = match lines.next() {
            Some((_, h)) if h.trim() == Self::CSV_HEADER => 7,
            Some((_, h)) if h.trim() == Self::CSV_HEADER_V1 => 6,
            _ => {
                return Err(err(
                    1,
                    format!(
                        "expected the header '{}' (sparsemor tradeoff --csv)",
                        Self::CSV_HEADER
                    ),
                ))
            }
        };
        lines
            .map(|(k, l)| {
                let f: Vec<&str> = l.split(',').map(str::trim).collect();
                let bad = |what: &str| err(k + 1, format!("{what} in '{l}'"));
                if f.len() != fields {
                    return Err(bad(&format!("expected {fields} comma-separated fields")));
                }
                Ok(TradeoffRow {
                    method: f[0].to_string(),
                    setting: f[1].to_string(),
                    seconds: f[2].parse().map_err(|_| bad("bad seconds"))?,
                    factorizations: f[3].parse().map_err(|_| bad("bad factorizations"))?,
                    order: f[4].parse().map_err(|_| bad("bad order"))?,
                    max_eps: f[5].parse().map_err(|_| bad("bad max_eps"))?,
                    solves: match f.get(6) {
                        None | Some(&"") => None,
                        Some(n) => Some(n.parse().map_err(|_| bad("bad solves"))?),
                    },
                })
            })
            .collect()
    }
}

/// Log–log chart of the speed/accuracy trade: wall time of each reduction vs its verified
/// max ε (eq. 23), one line per method, each point labelled by its setting.
///
/// # Errors
/// As [`chart_svg`].
pub fn tradeoff_svg(title: &str, rows: &[TradeoffRow]) -> Result<String> {
    let mut methods: Vec<&str> = Vec::new();
    for r in rows {
        if !methods.contains(&r.method.as_str()) {
            methods.push(&r.method);
        }
    }
    let series = methods
        .iter()
        .enumerate()
        .map(|(k, m)| {
            let of: Vec<&TradeoffRow> = rows.iter().filter(|r| r.method == *m).collect();
            Series {
                name: match *m {
                    "linefit" => "line-fitting (sampling loop)".to_string(),
                    "serep" => "SEREP".to_string(),
                    "craig-bampton" => "Craig–Bampton".to_string(),
                    m => m.to_string(),
                },
                points: of.iter().map(|r| (r.seconds, r.max_eps)).collect(),
                color: k + 1,
                draw: Draw::LineMarkers,
                labels: of.iter().map(|r| r.setting.clone()).collect(),
            }
        })
        .collect();
    chart_svg(&Chart {
        title: title.to_string(),
        x_label: "wall time of the reduction (s)".into(),
        y_label: "verified max ε (fine grid)".into(),
        x_log: true,
        y_log: true,
        series,
        x_range: None,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Each line-fitting row is paired with the fastest Craig–Bampton row whose verified
    /// error is no larger; none when every one is less accurate.
    #[test]
    fn equal_accuracy_pairs_the_fastest_craig_bampton_at_least_as_accurate() {
        let row = |method: &str, seconds: f64, max_eps: f64| TradeoffRow {
            method: method.into(),
            setting: String::new(),
            seconds,
            factorizations: 2,
            solves: None,
            order: 10,
            max_eps,
        };
        let rows = vec![
            row("linefit", 1.0, 1e-2),
            row("linefit", 1.5, 1e-5),
            row("craig-bampton", 0.5, 5e-2),
            row("craig-bampton", 2.0, 1e-3),
            row("craig-bampton", 3.0, 1e-4),
            row("serep", 0.1, 1e-6),
        ];
        assert_eq!(
            TradeoffRow::equal_accuracy(&rows),
            vec![(0, Some(3)), (1, None)]
        );
    }

    #[test]
    fn tradeoff_csv_round_trips_and_plots() {
        let rows = vec![
            TradeoffRow {
                method: "linefit".into(),
                setting: "tol 1e-2".into(),
                seconds: 0.25,
                factorizations: 12,
                solves: Some(20),
                order: 14,
                max_eps: 3.5e-3,
            },
            TradeoffRow {
                method: "serep".into(),
                setting: "9 modes".into(),
                seconds: 0.5,
                factorizations: 1,
                solves: None,
                order: 9,
                max_eps: 0.1,
            },
        ];
        let csv = TradeoffRow::to_csv(&rows);
        let back = TradeoffRow::parse_csv(&csv, Path::new("t.csv")).unwrap();
        assert_eq!(back, rows);
        let svg = tradeoff_svg("t", &rows).unwrap();
        assert!(svg.starts_with("<svg") && svg.contains("tol 1e-2") && svg.contains("SEREP"));
        // a file written before the solves column reads back without them
        let old =
            "method,setting,seconds,factorizations,order,max_eps\nserep,9 modes,0.5,1,9,0.1\n";
        let back = TradeoffRow::parse_csv(old, Path::new("t.csv")).unwrap();
        assert_eq!(back, rows[1..]);
        let e = TradeoffRow::parse_csv("a,b\n", Path::new("t.csv")).unwrap_err();
        assert!(e.to_string().contains("header"), "{e}");
    }

    #[test]
    fn log_axis_covers_whole_decades_and_ticks_read_well() {
        let (lo, hi) = axis_range([0.003, 0.2, 0.0].into_iter(), true);
        assert!(
            (lo / 1e-3 - 1.0).abs() < 1e-8 && lo <= 1e-3 && hi == 1.0,
            "{lo} {hi}"
        );
        assert_eq!(axis_range([5.0, 1000.0].into_iter(), false), (5.0, 1000.0));
        assert_eq!(tick(1e-3), "1e-3");
        assert_eq!(tick(100.0), "100");
        assert_eq!(tick(250.5), "250.5");
        assert_eq!(tick(2e-3), "2.0e-3");
    }
}
